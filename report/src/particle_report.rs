//! Work-precision of the particle scenes that the cloth section does not cover: the
//! soft jelly block (every soft integrator) and the hard particle chain (every
//! Lagrange formulation, the soft-spring stand-in, and RATTLE / RATTLE4), with a
//! summary of the fastest method reaching each error level.
//!
//! Error: max over particles and samples (every 1/30 s) of `|x − x_ref|`. References:
//! the jelly's is symplectic Euler at 1/16 of the smallest step (as for the cloth);
//! the chain's is RATTLE4 at 1/4 of the smallest step (fourth order: its own error is
//! below the smallest plotted one). Run time: wall clock of the whole run, best of the
//! repeats, one thread, per simulated second.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use constraint_core::DVec3;
use constraint_lagrange::scenes::chain;
use constraint_lagrange::{
    AccelerationLevel, BaseStep, Baumgarte, Constraints, FastProjection, KktSolver, LagrangeError,
    Rattle, RattleOrder, VelocityLevel,
};
use constraint_soft::{
    ConstraintSet, HessianMode, ImplicitEuler, Integrator, Jelly, LinearSolver, SoftSystem,
    Softness,
};

use crate::chart::Series;
use crate::deps::words;
use crate::sweeps::{
    best_of, error_chart, series_by_method, work_precision_of, work_precision_table, Method,
    WorkPoint,
};

/// Links of the chain.
pub const LINKS: usize = 5;
/// Link length (m).
pub const LINK: f64 = 0.1;
/// Particle mass (kg).
pub const MASS: f64 = 0.1;
/// Stiffness of the soft-spring stand-in for the links (N/m).
pub const K_SOFT: f64 = 1e6;

/// The chain formulations, in chart order.
pub const CHAIN_METHODS: [&str; 7] = [
    "acceleration level",
    "acceleration + Baumgarte (τ = 5h)",
    "velocity level",
    "velocity level + projection",
    "soft springs k = 1e6 (implicit)",
    "RATTLE",
    "RATTLE4",
];

/// One point of the chain sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainPoint {
    /// Index into [`CHAIN_METHODS`].
    pub method: usize,
    /// Time step.
    pub h: f64,
    /// Wall time per simulated second.
    pub cost: f64,
    /// Max position error, or `None` when the run failed.
    pub error: Option<f64>,
    /// The failure, if any.
    pub failure: Option<String>,
}

enum Stepper {
    Acc(Box<AccelerationLevel>),
    Vel(Box<VelocityLevel>),
    Soft(Box<ImplicitEuler>),
    Rattle(Box<Rattle>),
}

impl Stepper {
    fn new(method: usize, h: f64) -> Result<Self, LagrangeError> {
        let solver = KktSolver::DenseSchur;
        Ok(match method {
            0 => Stepper::Acc(Box::new(AccelerationLevel::new(
                h,
                Baumgarte::NONE,
                solver,
            )?)),
            1 => Stepper::Acc(Box::new(AccelerationLevel::new(
                h,
                Baumgarte::critical(5.0 * h)?,
                solver,
            )?)),
            2 => Stepper::Vel(Box::new(VelocityLevel::new(h, BaseStep::Explicit, solver)?)),
            3 => {
                let mut v = VelocityLevel::new(h, BaseStep::Explicit, solver)?;
                v.projection = Some(FastProjection::new(1e-12, 20, solver)?);
                Stepper::Vel(Box::new(v))
            }
            4 => Stepper::Soft(Box::new(ImplicitEuler::new(
                h,
                HessianMode::Projected,
                LinearSolver::SparseLdlt,
            )?)),
            5 => Stepper::Rattle(Box::new(Rattle::new(
                h,
                RattleOrder::Second,
                1e-13,
                40,
                solver,
            )?)),
            _ => Stepper::Rattle(Box::new(Rattle::new(
                h,
                RattleOrder::Fourth,
                1e-13,
                40,
                solver,
            )?)),
        })
    }

    fn step(&mut self, sys: &mut SoftSystem, cons: &Constraints) -> Result<(), LagrangeError> {
        match self {
            Stepper::Acc(s) => s.step(sys, cons).map(|_| ()),
            Stepper::Vel(s) => s.step(sys, cons).map(|_| ()),
            Stepper::Soft(s) => s.step(sys).map(|_| ()).map_err(LagrangeError::from),
            Stepper::Rattle(s) => s.step(sys, cons).map(|_| ()),
        }
    }

    fn stages(&self, cons: &Constraints) -> Vec<&'static str> {
        match self {
            Stepper::Acc(s) => words::acceleration(s, cons),
            Stepper::Vel(s) => words::velocity(s, cons),
            Stepper::Soft(s) => words::integrator(s.as_ref()),
            Stepper::Rattle(s) => words::rattle(s, cons),
        }
    }
}

/// The run-time stages of chain formulation `method` (an index into [`CHAIN_METHODS`])
/// observed over `steps` steps of `h` from the chart's initial state: the system's force
/// stages, the hard sets, then the formulation's stages (with the KKT solver the steps
/// used), in first-seen order; nothing for `steps = 0`.
///
/// # Errors
/// Building the scene or the formulation, or a failed step.
pub fn chain_stages(method: usize, h: f64, steps: usize) -> Result<Vec<String>, LagrangeError> {
    let (mut sys, cons) = chain_scene(method)?;
    let mut s = Stepper::new(method, h)?;
    let mut out: Vec<String> = Vec::new();
    for _ in 0..steps {
        s.step(&mut sys, &cons)?;
        let now = words::soft_system(&sys)
            .into_iter()
            .chain(words::constraints(&cons))
            .chain(s.stages(&cons).into_iter().map(String::from));
        for st in now {
            if !out.contains(&st) {
                out.push(st);
            }
        }
    }
    Ok(out)
}

/// The chain (released at 1 rad) for `method`: hard links, or soft springs for the
/// soft stand-in (then with no hard constraints).
fn chain_scene(method: usize) -> Result<(SoftSystem, Constraints), LagrangeError> {
    let (mut sys, cons) = chain(LINKS, LINK, MASS, 1.0)?;
    if method != 4 {
        return Ok((sys, cons));
    }
    let links = (0..LINKS)
        .map(|i| constraint_core::Distance::new(i, i + 1, LINK))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|error| constraint_soft::SoftError::Constraint {
            set: "links",
            index: 0,
            error,
        })?;
    sys.add_set(ConstraintSet::uniform(
        "links",
        links,
        Softness::stiff(K_SOFT),
    )?)?;
    Ok((sys, Constraints::new()))
}

/// Positions every `sample` seconds over `duration`, and the wall time of the run.
fn chain_run(
    method: usize,
    h: f64,
    duration: f64,
    sample: f64,
) -> Result<(Vec<Vec<DVec3>>, f64), LagrangeError> {
    let (mut sys, cons) = chain_scene(method)?;
    let mut s = Stepper::new(method, h)?;
    let per = (sample / h).round().max(1.0) as usize;
    let samples = (duration / sample).round() as usize;
    let mut out = vec![sys.x.clone()];
    let t0 = Instant::now();
    for _ in 0..samples {
        for _ in 0..per {
            s.step(&mut sys, &cons)?;
        }
        out.push(sys.x.clone());
    }
    Ok((out, t0.elapsed().as_secs_f64()))
}

/// The chain sweep: every formulation at every `h` (each dividing `sample`), against
/// RATTLE4 at `h_ref`.
///
/// # Errors
/// The reference run failing.
pub fn chain_work_precision(
    hs: &[f64],
    h_ref: f64,
    duration: f64,
    sample: f64,
    repeats: usize,
) -> Result<Vec<ChainPoint>, LagrangeError> {
    let (reference, _) = chain_run(6, h_ref, duration, sample)?;
    let mut pts = Vec::new();
    for method in 0..CHAIN_METHODS.len() {
        for &h in hs {
            // No outer error: a failing run, scene included, is the point's failure.
            let m = best_of(repeats, &reference, || {
                Ok::<_, LagrangeError>(chain_run(method, h, duration, sample))
            })?;
            pts.push(ChainPoint {
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

/// The fastest `(label, h, cost)` with error ≤ `level`.
fn fastest<'a>(
    pts: impl Iterator<Item = (String, f64, f64, Option<f64>)> + 'a,
    level: f64,
) -> Option<(String, f64, f64)> {
    pts.filter(|p| p.3.is_some_and(|e| e <= level))
        .map(|p| (p.0, p.1, p.2))
        .min_by(|a, b| a.2.total_cmp(&b.2))
}

/// Writes the section: `jelly_work_precision.svg`, `chain_work_precision.svg`, their
/// tables, `particle_work_precision.csv`, and the summary.
///
/// # Errors
/// A reference run failing, or writing a file.
pub fn section(md: &mut String, out: &Path, quick: bool) -> Result<(), Box<dyn std::error::Error>> {
    let sample = 1.0 / 30.0;
    let hs = |k: i32| -> Vec<f64> { (0..k).map(|i| sample / 2f64.powi(i)).collect() };
    let (jelly_hs, chain_hs, duration, repeats) = if quick {
        (hs(7), hs(8), 0.5, 1)
    } else {
        (hs(9), hs(10), 1.0, 3)
    };
    let mut csv = String::from("scene,method,h,cost_s_per_s,error_m,failure\n");
    let _ = writeln!(md, "\n## Work-precision: jelly and particle chain\n");

    // Jelly.
    let t0 = Instant::now();
    let j_ref = jelly_hs[jelly_hs.len() - 1] / 16.0;
    eprintln!(
        "  jelly work-precision: {} methods × {} steps, reference h = {j_ref:.2e}",
        Method::ALL.len(),
        jelly_hs.len()
    );
    let jelly = Jelly::default();
    let jpts = work_precision_of(
        &|| jelly.build(),
        &Method::ALL,
        &jelly_hs,
        j_ref,
        duration,
        sample,
        repeats,
    )?;
    eprintln!("    done in {:.1} s", t0.elapsed().as_secs_f64());
    let jnote = format!(
        "Jelly 3×3×3 cells (64 particles, springs 2e3 N/m, volume 1e9 J/m⁶, top layer pinned), {duration} s \
         from rest. Error: max over particles and samples (every 1/30 s) of |x − x_ref|; x_ref: symplectic \
         Euler at h = {j_ref:.2e} s (16× below the smallest step)."
    );
    let chart = error_chart(
        "Jelly: error against run time".into(),
        jnote.clone(),
        series_by_method(&jpts),
    );
    std::fs::write(out.join("jelly_work_precision.svg"), chart.to_svg())?;
    let _ = writeln!(
        md,
        "### Jelly\n\n![jelly work-precision](jelly_work_precision.svg)\n"
    );
    let _ = writeln!(
        md,
        "{jnote} Run time: wall clock, best of {repeats} run(s), one thread.\n"
    );
    work_precision_table(md, &mut csv, Some("jelly"), jpts.iter().map(WorkPoint::row));
    let _ = writeln!(md);

    // Chain.
    let t0 = Instant::now();
    let c_ref = chain_hs[chain_hs.len() - 1] / 4.0;
    eprintln!(
        "  chain work-precision: {} formulations × {} steps, reference RATTLE4 at h = {c_ref:.2e}",
        CHAIN_METHODS.len(),
        chain_hs.len()
    );
    let cpts = chain_work_precision(&chain_hs, c_ref, duration, sample, repeats)?;
    eprintln!("    done in {:.1} s", t0.elapsed().as_secs_f64());
    let cnote = format!(
        "Particle chain: {LINKS} links of {LINK} m, {MASS} kg particles, first one pinned, released at 1 rad \
         from the vertical, {duration} s. Error: max over particles and samples (every 1/30 s) of |x − x_ref|; \
         x_ref: RATTLE4 at h = {c_ref:.2e} s (4× below the smallest step; fourth order). The soft stand-in \
         replaces the hard links by springs of {K_SOFT:.0e} N/m (implicit Euler, projected Hessian, LDLᵀ)."
    );
    let chart = error_chart(
        "Particle chain: error against run time".into(),
        cnote.clone(),
        (0..CHAIN_METHODS.len())
            .map(|m| Series {
                name: CHAIN_METHODS[m].into(),
                points: cpts
                    .iter()
                    .filter(|q| q.method == m)
                    .filter_map(|q| q.error.map(|e| (q.cost, e)))
                    .collect(),
            })
            .collect(),
    );
    std::fs::write(out.join("chain_work_precision.svg"), chart.to_svg())?;
    let _ = writeln!(
        md,
        "### Particle chain\n\n![particle chain work-precision](chain_work_precision.svg)\n"
    );
    let _ = writeln!(
        md,
        "{cnote} Run time: wall clock, best of {repeats} run(s), one thread.\n"
    );
    work_precision_table(
        md,
        &mut csv,
        Some("chain"),
        cpts.iter().map(|q| {
            (
                CHAIN_METHODS[q.method].to_string(),
                q.h,
                q.cost,
                q.error,
                q.failure.clone(),
            )
        }),
    );
    let _ = writeln!(md);

    // Summary.
    let _ = writeln!(
        md,
        "### Summary: fastest method reaching an error level\n\n| scene | error ≤ | method (h) | run time / simulated s |\n|---|---|---|---|"
    );
    for level in [1e-3, 1e-6] {
        let j = fastest(
            jpts.iter()
                .map(|q| (q.method.label(), q.h, q.cost, q.error)),
            level,
        );
        let c = fastest(
            cpts.iter()
                .map(|q| (CHAIN_METHODS[q.method].to_string(), q.h, q.cost, q.error)),
            level,
        );
        for (scene, f) in [("jelly", j), ("particle chain", c)] {
            let cell = f.map_or("none in the sweep | –".into(), |(m, h, cost)| {
                format!("{m} ({h:.1e}) | {cost:.2e}")
            });
            let _ = writeln!(md, "| {scene} | {level:.0e} | {cell} |");
        }
    }
    let _ = writeln!(md);
    std::fs::write(out.join("particle_work_precision.csv"), csv)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every chain formulation runs at a small step, and the high-order ones are the
    /// most accurate there.
    #[test]
    fn chain_formulations_run_and_rattle4_is_the_most_accurate() {
        let pts =
            chain_work_precision(&[1.0 / 120.0], 1.0 / 480.0, 0.1, 1.0 / 30.0, 1).expect("sweep");
        assert_eq!(pts.len(), CHAIN_METHODS.len());
        let err = |m: usize| pts[m].error.unwrap_or(f64::NAN);
        for p in &pts {
            assert!(p.error.is_some(), "{p:?}");
        }
        // Measured at h = 1/120 s over 0.1 s: RATTLE4 1.4e-6 m, RATTLE 3.2e-5 m,
        // velocity level 3.5e-3 m.
        assert!(err(6) < err(5) && err(5) < err(2), "{pts:?}");
    }
}
