//! Sweeps over the soft crate's integrators: the stability map (stiffness × time step)
//! and the work-precision diagram (error against run time) of the cloth scene, and what
//! the work-precision sections share: the best-of-repeats timing of a point
//! ([`best_of`]), the chart ([`error_chart`]) and the table ([`work_precision_table`]).

use constraint_core::DVec3;
use constraint_soft::{Cloth, SoftError, SoftSystem, Softness};
use std::fmt::Write as _;
use std::time::Instant;

use crate::chart::{LogLogChart, Series};
pub use constraint_scene::soft::{
    free_cloth, free_jelly, momentum_drift, sweep_cloth, Method, CLOTH_ENERGY_SCALE,
};

/// Outcome of one run in the stability sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// Finite throughout and total energy never rose above `E(0) + 0.1·E_ref`.
    Stable,
    /// Finite, but the energy rose above `E(0) + 0.1·E_ref` (an instability in the
    /// making, or the exact Hessian's spurious energy injection).
    EnergyGrowth,
    /// The step returned the typed divergence error (non-finite or beyond 1e12).
    Diverged,
    /// The linear solver failed (CG met an indefinite matrix, LDLᵀ a zero pivot).
    SolverFailed,
    /// Some CG solve stopped at its iteration limit (the run itself stayed bounded).
    NotConverged,
    /// The run panicked (caught per cell; a bug that must never happen).
    Panicked,
}

impl Outcome {
    /// One-character cell for tables.
    pub fn symbol(self) -> &'static str {
        match self {
            Outcome::Stable => "✓",
            Outcome::EnergyGrowth => "↑",
            Outcome::Diverged => "✗",
            Outcome::SolverFailed => "!",
            Outcome::NotConverged => "~",
            Outcome::Panicked => "P",
        }
    }
}

/// Runs `method` for `duration` seconds on `sys`, classifying the run.
pub fn classify(mut sys: SoftSystem, method: Method, h: f64, duration: f64) -> Outcome {
    let Ok(mut integ) = method.build(h) else {
        return Outcome::SolverFailed;
    };
    let e0 = sys.kinetic_energy() + sys.potential_energy();
    let steps = (duration / h).round().max(1.0) as usize;
    let mut outcome = Outcome::Stable;
    for k in 0..steps {
        match integ.step(&mut sys) {
            Ok(st) if !st.converged => outcome = Outcome::NotConverged,
            Ok(_) => {}
            Err(SoftError::Diverged { .. }) => return Outcome::Diverged,
            Err(_) => return Outcome::SolverFailed,
        }
        if k % 16 == 15 || k + 1 == steps {
            let e = sys.kinetic_energy() + sys.potential_energy();
            if !(e <= e0 + 0.1 * CLOTH_ENERGY_SCALE) {
                return Outcome::EnergyGrowth;
            }
        }
    }
    outcome
}

/// One row of the stability table.
#[derive(Clone, Debug, PartialEq)]
pub struct StabilityRow {
    /// The method.
    pub method: Method,
    /// Spring stiffness.
    pub k: f64,
    /// Outcome per time step, in the order of the sweep's `hs`.
    pub outcomes: Vec<Outcome>,
}

/// Stiffness × time-step sweep of the cloth for every method. The cells run in
/// parallel on [`crate::par::threads`] threads ([`crate::par::map_cells`]); each cell is
/// deterministic and the rows come back in method, stiffness, step order whatever the
/// thread count.
pub fn stability_sweep(n: usize, ks: &[f64], hs: &[f64], duration: f64) -> Vec<StabilityRow> {
    stability_sweep_on(n, ks, hs, duration, crate::par::threads())
}

/// [`stability_sweep`] on `threads` threads.
pub fn stability_sweep_on(
    n: usize,
    ks: &[f64],
    hs: &[f64],
    duration: f64,
    threads: usize,
) -> Vec<StabilityRow> {
    let mut cells = Vec::new();
    for method in Method::ALL {
        for &k in ks {
            for &h in hs {
                cells.push((method, k, h));
            }
        }
    }
    // Cost: steps, with CG and the exact Hessian dearer.
    let cost = |&(m, _, h): &(Method, f64, f64)| {
        duration / h
            * match m {
                Method::Symplectic => 0.2,
                _ => 1.0,
            }
    };
    let run = |&(m, k, h): &(Method, f64, f64)| match sweep_cloth(n, k) {
        Ok(sys) => classify(sys, m, h, duration),
        Err(_) => Outcome::SolverFailed,
    };
    let out = crate::par::map_cells("cloth", &cells, threads, cost, run, |_, _| {
        Outcome::Panicked
    });
    let mut rows = Vec::new();
    let mut it = out.into_iter();
    for method in Method::ALL {
        for &k in ks {
            rows.push(StabilityRow {
                method,
                k,
                outcomes: it.by_ref().take(hs.len()).collect(),
            });
        }
    }
    rows
}

/// Positions sampled every `sample` seconds (including `t = 0`) of a run of `duration`.
/// `h` must divide `sample`.
pub fn trajectory(
    mut sys: SoftSystem,
    method: Method,
    h: f64,
    duration: f64,
    sample: f64,
) -> Result<(Vec<Vec<DVec3>>, f64), SoftError> {
    let mut integ = method.build(h)?;
    let per = (sample / h).round().max(1.0) as usize;
    let samples = (duration / sample).round() as usize;
    let mut out = vec![sys.x.clone()];
    let t0 = Instant::now();
    for _ in 0..samples {
        for _ in 0..per {
            integ.step(&mut sys)?;
        }
        out.push(sys.x.clone());
    }
    Ok((out, t0.elapsed().as_secs_f64()))
}

/// Max over samples and particles of `|x − x_ref|`.
pub fn max_error(a: &[Vec<DVec3>], b: &[Vec<DVec3>]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(sa, sb)| sa.iter().zip(sb).map(|(x, y)| (*x - *y).length()))
        .fold(0.0, f64::max)
}

/// One point of the work-precision diagram.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkPoint {
    /// The method.
    pub method: Method,
    /// Time step.
    pub h: f64,
    /// Wall-clock seconds per simulated second (best of the repeats).
    pub cost: f64,
    /// Max position error against the reference (m); `None` if the run failed.
    pub error: Option<f64>,
    /// Why the run failed, if it did.
    pub failure: Option<String>,
}

impl WorkPoint {
    /// The point as a row of [`work_precision_table`].
    pub fn row(&self) -> (String, f64, f64, Option<f64>, Option<String>) {
        (
            self.method.label(),
            self.h,
            self.cost,
            self.error,
            self.failure.clone(),
        )
    }
}

/// Work-precision sweep of the cloth: every method at every `h`, error against
/// symplectic Euler at `h_ref` (which must divide every `h` and `sample`).
pub fn work_precision(
    n: usize,
    hs: &[f64],
    h_ref: f64,
    duration: f64,
    sample: f64,
    repeats: usize,
) -> Result<Vec<WorkPoint>, SoftError> {
    let k = Cloth::default().spring.stiffness;
    work_precision_of(
        &|| sweep_cloth(n, k),
        &Method::ALL,
        hs,
        h_ref,
        duration,
        sample,
        repeats,
    )
}

/// Work-precision sweep of any soft scene built by `build`: each of `methods` at every
/// `h`, error (max over particles and samples of `|x − x_ref|`) against symplectic
/// Euler at `h_ref` (which must divide every `h` and `sample`); run time is the best
/// of `repeats` runs, per simulated second.
///
/// # Errors
/// Building the scene, or the reference run failing.
pub fn work_precision_of(
    build: &dyn Fn() -> Result<SoftSystem, SoftError>,
    methods: &[Method],
    hs: &[f64],
    h_ref: f64,
    duration: f64,
    sample: f64,
    repeats: usize,
) -> Result<Vec<WorkPoint>, SoftError> {
    let (reference, _) = trajectory(build()?, Method::Symplectic, h_ref, duration, sample)?;
    let mut pts = Vec::new();
    for &method in methods {
        for &h in hs {
            let m = best_of(repeats, &reference, || {
                Ok(trajectory(build()?, method, h, duration, sample))
            })?;
            pts.push(WorkPoint {
                method,
                h,
                cost: m.seconds / duration,
                error: m.error,
                failure: m.failure,
            });
        }
    }
    Ok(pts)
}

/// One work-precision point measured by [`best_of`].
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// Best wall time of the runs (s; infinite if the first run failed).
    pub seconds: f64,
    /// Max position error of the last run against the reference (m); `None` if a run
    /// failed.
    pub error: Option<f64>,
    /// The failure, if a run failed.
    pub failure: Option<String>,
}

/// Runs one work-precision point `repeats` times (at least once) and keeps the best
/// wall time: `run` returns a run's sampled positions and wall time, or the run's
/// failure (recorded; no further repeats), inside an outer error that ends the sweep.
/// The last run's positions are compared with `reference` ([`max_error`]).
///
/// # Errors
/// The outer error of `run`, at once.
pub fn best_of<E: std::fmt::Display, F>(
    repeats: usize,
    reference: &[Vec<DVec3>],
    mut run: impl FnMut() -> Result<Result<(Vec<Vec<DVec3>>, f64), E>, F>,
) -> Result<Measurement, F> {
    let mut best = f64::INFINITY;
    let mut res = None;
    for _ in 0..repeats.max(1) {
        match run()? {
            Ok((traj, secs)) => {
                best = best.min(secs);
                res = Some(Ok(traj));
            }
            Err(e) => {
                res = Some(Err(e));
                break;
            }
        }
    }
    let (error, failure) = match res {
        Some(Ok(traj)) => (Some(max_error(&traj, reference)), None),
        Some(Err(e)) => (None, Some(e.to_string())),
        None => (None, Some("not run".into())),
    };
    Ok(Measurement {
        seconds: best,
        error,
        failure,
    })
}

/// A work-precision chart: max position error against run time per simulated second
/// (log–log), the Pareto front marked.
pub fn error_chart(title: String, note: String, series: Vec<Series>) -> LogLogChart {
    LogLogChart {
        title,
        x_label: "run time per simulated second (s)".into(),
        y_label: "max position error (m)".into(),
        series,
        note,
        log_x: true,
        pareto: true,
    }
}

/// One chart series per method of [`Method::ALL`]: `(cost, error)` of its points that ran.
pub fn series_by_method(pts: &[WorkPoint]) -> Vec<Series> {
    Method::ALL
        .iter()
        .map(|m| Series {
            name: m.label(),
            points: pts
                .iter()
                .filter(|q| q.method == *m)
                .filter_map(|q| q.error.map(|e| (q.cost, e)))
                .collect(),
        })
        .collect()
}

/// Writes a work-precision table to `md` (method, h, run time per simulated second, max
/// error, or `failed: …` and `–`; no blank line after it) and its rows to `csv`
/// (`[scene,]method,h,cost,error,failure`, commas in the failure as `;`). A row is
/// `(method, h, cost, error, failure)`.
pub fn work_precision_table(
    md: &mut String,
    csv: &mut String,
    scene: Option<&str>,
    rows: impl IntoIterator<Item = (String, f64, f64, Option<f64>, Option<String>)>,
) {
    let _ = writeln!(
        md,
        "| method | h (s) | run time / simulated s | max error (m) |\n|---|---|---|---|"
    );
    for (m, h, cost, err, fail) in rows {
        let (e, c) = match err {
            Some(e) => (format!("{e:.3e}"), format!("{cost:.3e}")),
            None => (
                format!("failed: {}", fail.clone().unwrap_or_default()),
                "–".into(),
            ),
        };
        let _ = writeln!(md, "| {m} | {h:.3e} | {c} | {e} |");
        if let Some(scene) = scene {
            let _ = write!(csv, "{scene},");
        }
        let _ = writeln!(
            csv,
            "{m},{h:e},{cost:e},{},{}",
            err.map_or(String::new(), |e| format!("{e:e}")),
            fail.unwrap_or_default().replace(',', ";")
        );
    }
}

/// Volume preservation of the hanging jelly with soft volume constraints.
#[derive(Clone, Debug, PartialEq)]
pub struct JellyRun {
    /// Volume stiffness (J/m⁶).
    pub k_volume: f64,
    /// Max over time and tetrahedra of `|V − V₀| / V₀`; `None` if the run failed.
    pub volume_error: Option<f64>,
    /// Max over time and springs of `|L − L₀| / L₀`.
    pub strain: Option<f64>,
    /// Wall-clock seconds per simulated second.
    pub cost: f64,
}

/// Hangs the default 3×3×3 jelly (10 cm cells, top layer pinned) for `duration` with
/// `method` at step `h`, for each volume stiffness.
pub fn jelly_volume(method: Method, h: f64, ks: &[f64], duration: f64) -> Vec<JellyRun> {
    ks.iter()
        .map(|&k| {
            let jelly = constraint_soft::Jelly {
                volume: Softness::stiff(k),
                ..constraint_soft::Jelly::default()
            };
            let v0 = jelly.cell.powi(3) / 6.0;
            let l0 = jelly.cell; // shortest rest edge; strains are relative to it
            let run = || -> Result<(f64, f64, f64), SoftError> {
                let mut sys = jelly.build()?;
                let mut integ = method.build(h)?;
                let steps = (duration / h).round() as usize;
                let (mut dv, mut st) = (0.0f64, 0.0f64);
                let t0 = Instant::now();
                for _ in 0..steps {
                    integ.step(&mut sys)?;
                    for set in sys.sets() {
                        let c = set.max_violation(&sys.x);
                        match set.name() {
                            "volumes" => dv = dv.max(c / v0),
                            _ => st = st.max(c / l0),
                        }
                    }
                }
                Ok((dv, st, t0.elapsed().as_secs_f64() / duration))
            };
            match run() {
                Ok((dv, st, cost)) => JellyRun {
                    k_volume: k,
                    volume_error: Some(dv),
                    strain: Some(st),
                    cost,
                },
                Err(_) => JellyRun {
                    k_volume: k,
                    volume_error: None,
                    strain: None,
                    cost: f64::NAN,
                },
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel sweep gives the same table on one thread and on several.
    #[test]
    fn the_cloth_sweep_does_not_depend_on_the_thread_count() {
        let (ks, hs) = ([1e2, 1e5], [1e-2, 3e-2]);
        let one = stability_sweep_on(6, &ks, &hs, 0.1, 1);
        let three = stability_sweep_on(6, &ks, &hs, 0.1, 3);
        assert_eq!(one.len(), Method::ALL.len() * ks.len());
        assert_eq!(one, three);
        assert!(one
            .iter()
            .flat_map(|r| &r.outcomes)
            .all(|o| *o != Outcome::Panicked));
    }
}
