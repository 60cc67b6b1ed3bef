//! Sweeps over the lagrange crate: constraint drift of a particle chain per
//! formulation, and the soft-versus-hard trade-off on the inextensible cloth (strain
//! reached against run time).

use constraint_lagrange::scenes::{chain, structural_links, tilted_inextensible_cloth};
use constraint_lagrange::{
    AccelerationLevel, BaseStep, Baumgarte, Constraints, FastProjection, HardSet, KktSolver,
    LagrangeError, ProjectedStep, VelocityLevel,
};
use constraint_soft::{
    ConstraintSet, HessianMode, ImplicitEuler, Integrator, LinearSolver, Softness,
};
use std::time::Instant;

/// The chain formulations compared in the drift chart.
pub const DRIFT_METHODS: [&str; 4] = [
    "acceleration level, no Baumgarte",
    "acceleration level, Baumgarte τ = 10 ms",
    "velocity level",
    "velocity level + projection",
];

/// Max `|C|` (m) of a 10-link chain (0.1 m links, 0.1 kg beads, released at 1 rad)
/// sampled every `sample` s over `secs`, for the formulation `DRIFT_METHODS[method]`
/// at step `h`.
///
/// # Errors
/// A failed step.
pub fn chain_drift(
    method: usize,
    h: f64,
    secs: f64,
    sample: f64,
) -> Result<Vec<(f64, f64)>, LagrangeError> {
    let (mut sys, cons) = chain(10, 0.1, 0.1, 1.0)?;
    let solver = KktSolver::DenseSchur;
    let mut acc = AccelerationLevel::new(
        h,
        if method == 1 {
            Baumgarte::critical(0.01)?
        } else {
            Baumgarte::NONE
        },
        solver,
    )?;
    let mut vel = VelocityLevel::new(h, BaseStep::Explicit, solver)?;
    if method == 3 {
        vel.projection = Some(FastProjection::new(1e-12, 20, solver)?);
    }
    let per = (sample / h).round().max(1.0) as usize;
    let mut out = Vec::new();
    let mut worst: f64 = 0.0;
    let steps = (secs / h).round() as usize;
    for k in 1..=steps {
        match method {
            0 | 1 => {
                acc.step(&mut sys, &cons)?;
            }
            _ => {
                vel.step(&mut sys, &cons)?;
            }
        }
        for i in 0..10 {
            worst = worst.max(((sys.x[i + 1] - sys.x[i]).length() - 0.1).abs());
        }
        if k % per == 0 {
            out.push((k as f64 * h, worst.max(1e-17)));
            worst = 0.0;
        }
    }
    Ok(out)
}

/// Weak shear springs (N/m) on every edge in the cloth comparison: weak enough for the
/// explicit base step of the compliant variant to be stable at `h = 1/60`.
pub const K_SHEAR: f64 = 2.0;

/// One point of the strain-against-run-time comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct StrainPoint {
    /// Series name.
    pub method: String,
    /// The knob: projection tolerance, spring stiffness or compliance.
    pub parameter: f64,
    /// Max structural strain `|L − L₀|/L₀` over the run; `None` if it failed.
    pub strain: Option<f64>,
    /// Wall-clock milliseconds per step.
    pub ms_per_step: f64,
    /// Mean projection iterations per step (projection only).
    pub iterations: f64,
}

fn strain_of(links: &[constraint_core::Distance], x: &[constraint_core::DVec3]) -> f64 {
    links
        .iter()
        .map(|d| ((x[d.points[0]] - x[d.points[1]]).length() / d.rest_length - 1.0).abs())
        .fold(0.0, f64::max)
}

/// The inextensible-cloth trade-off at `n × n`, `h = 1/60`, over `secs`:
/// fast projection at each tolerance, stiff soft springs at each stiffness (implicit
/// Euler, sparse LDLᵀ), and compliant constraints at each compliance (velocity level).
pub fn cloth_strain_vs_time(
    n: usize,
    secs: f64,
    tolerances: &[f64],
    stiffnesses: &[f64],
    compliances: &[f64],
) -> Vec<StrainPoint> {
    let h = 1.0 / 60.0;
    let steps = (secs / h).round() as usize;
    let tilt = 1.0;
    let mut pts = Vec::new();
    let links = |x: &[constraint_core::DVec3]| structural_links(n, x);
    for &tol in tolerances {
        let run = || -> Result<StrainPoint, LagrangeError> {
            let (mut sys, cons) = tilted_inextensible_cloth(n, K_SHEAR, tilt)?;
            let l = links(&sys.x)?;
            let mut step = ProjectedStep::new(
                ImplicitEuler::new(h, HessianMode::GaussNewton, LinearSolver::SparseLdlt)?,
                FastProjection::new(tol, 100, KktSolver::SparseSchur)?,
            );
            let (mut s, mut it) = (0.0f64, 0usize);
            let t0 = Instant::now();
            for _ in 0..steps {
                it += step.step(&mut sys, &cons)?.iterations;
                s = s.max(strain_of(&l, &sys.x));
            }
            Ok(StrainPoint {
                method: "fast projection".into(),
                parameter: tol,
                strain: Some(s),
                ms_per_step: t0.elapsed().as_secs_f64() * 1e3 / steps as f64,
                iterations: it as f64 / steps as f64,
            })
        };
        pts.push(run().unwrap_or(StrainPoint {
            method: "fast projection".into(),
            parameter: tol,
            strain: None,
            ms_per_step: f64::NAN,
            iterations: f64::NAN,
        }));
    }
    for &k in stiffnesses {
        let run = || -> Result<StrainPoint, LagrangeError> {
            let (mut sys, _) = tilted_inextensible_cloth(n, K_SHEAR, tilt)?;
            let l = links(&sys.x)?;
            sys.add_set(ConstraintSet::uniform(
                "structural",
                l.clone(),
                Softness::stiff(k),
            )?)?;
            let mut step =
                ImplicitEuler::new(h, HessianMode::GaussNewton, LinearSolver::SparseLdlt)?;
            let mut s = 0.0f64;
            let t0 = Instant::now();
            for _ in 0..steps {
                step.step(&mut sys)?;
                s = s.max(strain_of(&l, &sys.x));
            }
            Ok(StrainPoint {
                method: "soft springs (implicit)".into(),
                parameter: k,
                strain: Some(s),
                ms_per_step: t0.elapsed().as_secs_f64() * 1e3 / steps as f64,
                iterations: 0.0,
            })
        };
        pts.push(run().unwrap_or(StrainPoint {
            method: "soft springs (implicit)".into(),
            parameter: k,
            strain: None,
            ms_per_step: f64::NAN,
            iterations: f64::NAN,
        }));
    }
    for &alpha in compliances {
        let run = || -> Result<StrainPoint, LagrangeError> {
            let (mut sys, _) = tilted_inextensible_cloth(n, K_SHEAR, tilt)?;
            let l = links(&sys.x)?;
            let mut cons = Constraints::new();
            let m = l.len();
            cons.add(
                HardSet::compliant("structural", l.clone(), vec![alpha; m])
                    .map_err(|_| LagrangeError::InvalidParameter("compliance"))?,
            );
            let mut step = VelocityLevel::new(h, BaseStep::Explicit, KktSolver::SparseSchur)?;
            let mut s = 0.0f64;
            let t0 = Instant::now();
            for _ in 0..steps {
                step.step(&mut sys, &cons)?;
                s = s.max(strain_of(&l, &sys.x));
            }
            Ok(StrainPoint {
                method: "compliant (velocity level)".into(),
                parameter: alpha,
                strain: Some(s),
                ms_per_step: t0.elapsed().as_secs_f64() * 1e3 / steps as f64,
                iterations: 0.0,
            })
        };
        pts.push(run().unwrap_or(StrainPoint {
            method: "compliant (velocity level)".into(),
            parameter: alpha,
            strain: None,
            ms_per_step: f64::NAN,
            iterations: f64::NAN,
        }));
    }
    pts
}

/// Names used in the chart legend, in order of first appearance.
pub fn series_names(pts: &[StrainPoint]) -> Vec<String> {
    crate::chart::first_appearances(pts.iter().map(|p| p.method.as_str()))
}

/// One row of the hard-versus-soft volume comparison on the jelly.
#[derive(Clone, Debug, PartialEq)]
pub struct JellyVolumeRow {
    /// What enforces volume.
    pub method: String,
    /// Max over time of the worst one-ring relative volume error; `None` if it failed.
    pub ring_error: Option<f64>,
    /// Max over time of how far the lowest node moved down (m).
    pub sag: f64,
    /// Wall-clock milliseconds per step.
    pub ms_per_step: f64,
}

/// The jelly with soft 100 N/m edge springs hanging for `secs` at `h = 1/60`: volume
/// enforced hard per node (fast projection, tolerance 1e-7) or by soft
/// per-tetrahedron volume springs of each stiffness in `ks`. Errors are measured on
/// the same one-ring volumes for both.
pub fn jelly_hard_vs_soft(secs: f64, ks: &[f64]) -> Vec<JellyVolumeRow> {
    use constraint_lagrange::scenes::hard_volume_jelly;
    let h = 1.0 / 60.0;
    let steps = (secs / h).round() as usize;
    let mut out = Vec::new();
    let lowest =
        |x: &[constraint_core::DVec3]| -x.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
    let hard = || -> Result<JellyVolumeRow, LagrangeError> {
        let (mut sys, cons, rings) = hard_volume_jelly(100.0)?;
        let mut step = ProjectedStep::new(
            ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt)?,
            FastProjection::new(1e-7, 30, KktSolver::SparseSchur)?,
        );
        let (mut e, mut sag) = (0.0f64, 0.0f64);
        let t0 = Instant::now();
        for _ in 0..steps {
            step.step(&mut sys, &cons)?;
            e = e.max(rings.max_relative_error(&sys.x));
            sag = sag.max(lowest(&sys.x));
        }
        Ok(JellyVolumeRow {
            method: "hard one-ring volumes (fast projection, tol 1e-7)".into(),
            ring_error: Some(e),
            sag,
            ms_per_step: t0.elapsed().as_secs_f64() * 1e3 / steps as f64,
        })
    };
    out.push(hard().unwrap_or(JellyVolumeRow {
        method: "hard one-ring volumes".into(),
        ring_error: None,
        sag: f64::NAN,
        ms_per_step: f64::NAN,
    }));
    for &k in ks {
        let soft = || -> Result<JellyVolumeRow, LagrangeError> {
            let (_, _, rings) = hard_volume_jelly(100.0)?;
            let mut sys = constraint_soft::Jelly {
                spring: Softness::stiff(100.0),
                volume: Softness::stiff(k),
                ..constraint_soft::Jelly::default()
            }
            .build()?;
            let mut step = ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt)?;
            let (mut e, mut sag) = (0.0f64, 0.0f64);
            let t0 = Instant::now();
            for _ in 0..steps {
                step.step(&mut sys)?;
                e = e.max(rings.max_relative_error(&sys.x));
                sag = sag.max(lowest(&sys.x));
            }
            Ok(JellyVolumeRow {
                method: format!("soft tetrahedron volumes, k = {k:.0e} J/m⁶"),
                ring_error: Some(e),
                sag,
                ms_per_step: t0.elapsed().as_secs_f64() * 1e3 / steps as f64,
            })
        };
        out.push(soft().unwrap_or(JellyVolumeRow {
            method: format!("soft tetrahedron volumes, k = {k:.0e} J/m⁶"),
            ring_error: None,
            sag: f64::NAN,
            ms_per_step: f64::NAN,
        }));
    }
    out
}
