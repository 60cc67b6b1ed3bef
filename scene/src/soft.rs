//! The soft scenes shared by the tests, the sweeps and the report: the integrator
//! configurations compared everywhere ([`Method`]), the hanging cloth of the stability
//! map ([`sweep_cloth`]), the free cloth and jelly of the momentum checks, and the
//! momentum drift they are measured by.

use crate::rng::Rng;
use constraint_core::DVec3;
use constraint_soft::{
    CgSettings, Cloth, HessianMode, ImplicitEuler, Integrator, LinearSolver, SoftError, SoftSystem,
    Softness, SymplecticEuler,
};

/// The integrator configurations compared everywhere.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Symplectic Euler.
    Symplectic,
    /// Linearized implicit Euler with the given Hessian treatment and sparse LDLᵀ.
    ImplicitLdlt(HessianMode),
    /// Linearized implicit Euler with the projected Hessian and CG (relative tol 1e-8).
    ImplicitCg(HessianMode),
}

impl Method {
    /// Every configuration, in report order.
    pub const ALL: [Method; 5] = [
        Method::Symplectic,
        Method::ImplicitLdlt(HessianMode::Projected),
        Method::ImplicitLdlt(HessianMode::GaussNewton),
        Method::ImplicitLdlt(HessianMode::Exact),
        Method::ImplicitCg(HessianMode::Projected),
    ];

    /// A short label.
    pub fn label(self) -> String {
        match self {
            Method::Symplectic => "symplectic Euler".into(),
            Method::ImplicitLdlt(m) => format!("implicit, LDLT, {m:?}"),
            Method::ImplicitCg(m) => format!("implicit, CG, {m:?}"),
        }
    }

    /// The integrator at step `h`.
    ///
    /// # Errors
    /// `InvalidTimeStep`.
    pub fn build(self, h: f64) -> Result<Box<dyn Integrator>, SoftError> {
        Ok(match self {
            Method::Symplectic => Box::new(SymplecticEuler::new(h)?),
            Method::ImplicitLdlt(m) => {
                Box::new(ImplicitEuler::new(h, m, LinearSolver::SparseLdlt)?)
            }
            Method::ImplicitCg(m) => Box::new(ImplicitEuler::new(
                h,
                m,
                LinearSolver::ConjugateGradient(CgSettings {
                    tolerance: 1e-8,
                    max_iterations: 2000,
                }),
            )?),
        })
    }
}

/// The cloth used by the sweeps: `n × n`, 1 m, 0.5 kg, hung from its two top corners,
/// spring stiffness `k` (N/m) and area stiffness `k / dx²` so both act on the same scale.
pub fn sweep_cloth(n: usize, k: f64) -> Result<SoftSystem, SoftError> {
    let dx = 1.0 / (n - 1) as f64;
    Cloth {
        n,
        spring: Softness::stiff(k),
        area: Softness::stiff(k / (dx * dx)),
        ..Cloth::default()
    }
    .build()
}

/// Energy scale of the cloth: `M g L` (0.5 kg × 9.81 m/s² × 1 m).
pub const CLOTH_ENERGY_SCALE: f64 = 0.5 * 9.81 * 1.0;

/// Relative drift of linear and angular momentum over `duration`:
/// `|P(T) − P(0)| / Σ m|v(0)|` and `|L(T) − L(0)| / Σ m|x(0)||v(0)|`.
///
/// # Errors
/// The integrator's error, if a step fails.
pub fn momentum_drift(
    mut sys: SoftSystem,
    integ: &mut dyn Integrator,
    duration: f64,
) -> Result<(f64, f64), SoftError> {
    let p0 = sys.linear_momentum();
    let l0 = sys.angular_momentum();
    let m = sys.masses().to_vec();
    let pscale: f64 = sys.v.iter().zip(&m).map(|(v, m)| m * v.length()).sum();
    let lscale: f64 = sys
        .x
        .iter()
        .zip(&sys.v)
        .zip(&m)
        .map(|((x, v), m)| m * x.length() * v.length())
        .sum();
    let steps = (duration / integ.time_step()).round() as usize;
    for _ in 0..steps {
        integ.step(&mut sys)?;
    }
    Ok((
        (sys.linear_momentum() - p0).length() / pscale,
        (sys.angular_momentum() - l0).length() / lscale,
    ))
}

/// A free cloth for momentum checks: `n × n`, no pins, no gravity, positions jittered
/// by `±0.02` m (so internal forces act), velocities = drift + spin + noise, all drawn
/// from `seed`.
pub fn free_cloth(n: usize, seed: u64) -> Result<SoftSystem, SoftError> {
    let mut sys = Cloth {
        n,
        pins: constraint_soft::ClothPins::None,
        spring: Softness {
            stiffness: 500.0,
            damping: 0.5,
        },
        ..Cloth::default()
    }
    .build()?;
    shake(&mut sys, seed, 0.02)?;
    Ok(sys)
}

/// A free jelly for momentum checks: 2×2×2 cells, no pins, no gravity, jittered by
/// `±0.01` m, random drift + spin + noise from `seed`.
pub fn free_jelly(seed: u64) -> Result<SoftSystem, SoftError> {
    let mut sys = constraint_soft::Jelly {
        cells: [2, 2, 2],
        pins: constraint_soft::JellyPins::None,
        volume: Softness::stiff(1e7),
        ..constraint_soft::Jelly::default()
    }
    .build()?;
    shake(&mut sys, seed, 0.01)?;
    Ok(sys)
}

fn shake(sys: &mut SoftSystem, seed: u64, amp: f64) -> Result<(), SoftError> {
    let mut rng = Rng::new(seed);
    sys.gravity = DVec3::ZERO;
    for x in &mut sys.x {
        *x += rng.in_box(DVec3::ZERO, amp);
    }
    let drift = rng.in_box(DVec3::ZERO, 1.0);
    let spin = rng.in_box(DVec3::ZERO, 2.0);
    let v: Vec<DVec3> = sys
        .x
        .iter()
        .map(|x| drift + spin.cross(*x) + rng.in_box(DVec3::ZERO, 0.3))
        .collect();
    sys.set_velocities(&v)
}
