//! A particle system with soft constraints: state, masses, pins, gravity and the
//! constraint sets it was built with — nothing else is stored or evaluated.

use crate::error::SoftError;
use crate::set::{ConstraintSet, ForceSet};
use constraint_core::{DVec3, PointConstraint};

/// Particles, pins and soft-constraint sets.
pub struct SoftSystem {
    /// Positions (m).
    pub x: Vec<DVec3>,
    /// Velocities (m/s).
    pub v: Vec<DVec3>,
    mass: Vec<f64>,
    pinned: Vec<bool>,
    /// Gravity acceleration (m/s²), `(0, 0, −9.81)` by default.
    pub gravity: DVec3,
    pub(crate) sets: Vec<Box<dyn ForceSet>>,
    /// Incremented whenever the coupling pattern or pins change.
    pub(crate) topology: u64,
    /// Number of completed steps.
    pub steps: u64,
}

impl core::fmt::Debug for SoftSystem {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SoftSystem")
            .field("particles", &self.x.len())
            .field(
                "sets",
                &self.sets.iter().map(|s| s.name()).collect::<Vec<_>>(),
            )
            .field("steps", &self.steps)
            .finish()
    }
}

/// Standard gravity along −z (MuJoCo's default).
pub const GRAVITY: DVec3 = DVec3::new(0.0, 0.0, -9.81);

impl SoftSystem {
    /// Particles at rest at `positions` with the given masses.
    ///
    /// # Errors
    /// `LengthMismatch`, `NonFiniteState` for a non-finite position, `InvalidMass` for a
    /// mass that is not positive and finite.
    pub fn new(positions: Vec<DVec3>, masses: Vec<f64>) -> Result<Self, SoftError> {
        if positions.len() != masses.len() {
            return Err(SoftError::LengthMismatch);
        }
        if let Some(p) = positions.iter().position(|x| !x.is_finite()) {
            return Err(SoftError::NonFiniteState { particle: p });
        }
        if let Some(p) = masses.iter().position(|&m| !(m > 0.0 && m.is_finite())) {
            return Err(SoftError::InvalidMass { particle: p });
        }
        let n = positions.len();
        Ok(Self {
            x: positions,
            v: vec![DVec3::ZERO; n],
            mass: masses,
            pinned: vec![false; n],
            gravity: GRAVITY,
            sets: Vec::new(),
            topology: 0,
            steps: 0,
        })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// `true` when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Particle masses (kg).
    pub fn masses(&self) -> &[f64] {
        &self.mass
    }

    /// Which particles are pinned.
    pub fn pinned(&self) -> &[bool] {
        &self.pinned
    }

    /// The constraint sets, in the order they were added.
    pub fn sets(&self) -> impl Iterator<Item = &dyn ForceSet> {
        self.sets.iter().map(|s| s.as_ref())
    }

    /// Pins particle `i` in place (its velocity is held at zero).
    ///
    /// # Errors
    /// `IndexOutOfBounds`.
    pub fn pin(&mut self, i: usize) -> Result<(), SoftError> {
        let len = self.len();
        let p = self
            .pinned
            .get_mut(i)
            .ok_or(SoftError::IndexOutOfBounds { index: i, len })?;
        *p = true;
        self.v[i] = DVec3::ZERO;
        self.topology += 1;
        Ok(())
    }

    /// Sets all velocities.
    ///
    /// # Errors
    /// `LengthMismatch`, `NonFiniteState`. The state is unchanged on error.
    pub fn set_velocities(&mut self, v: &[DVec3]) -> Result<(), SoftError> {
        if v.len() != self.len() {
            return Err(SoftError::LengthMismatch);
        }
        if let Some(p) = v.iter().position(|x| !x.is_finite()) {
            return Err(SoftError::NonFiniteState { particle: p });
        }
        for (i, (dst, src)) in self.v.iter_mut().zip(v).enumerate() {
            *dst = if self.pinned[i] { DVec3::ZERO } else { *src };
        }
        Ok(())
    }

    /// Adds a set of soft constraints.
    ///
    /// # Errors
    /// `IndexOutOfBounds` when a stencil names a missing particle.
    pub fn add_set<C, const N: usize, const R: usize>(
        &mut self,
        set: ConstraintSet<C, N, R>,
    ) -> Result<(), SoftError>
    where
        C: PointConstraint<N, R> + Send + Sync + 'static,
    {
        set.validate(self.len())?;
        self.sets.push(Box::new(set));
        self.topology += 1;
        Ok(())
    }

    /// Sum of all internal (constraint) and external (gravity) forces, without damping
    /// when `damping` is false.
    pub fn forces(&self, damping: bool, f: &mut [DVec3]) {
        for (i, fi) in f.iter_mut().enumerate() {
            *fi = self.gravity * self.mass[i];
        }
        let v = damping.then_some(self.v.as_slice());
        for s in &self.sets {
            s.add_forces(&self.x, v, f);
        }
    }

    /// Kinetic energy `Σ ½ m v²`.
    pub fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.mass)
            .map(|(v, m)| 0.5 * m * v.length_squared())
            .sum()
    }

    /// Potential energy: constraint energies plus gravity `−Σ m gᵀx`.
    pub fn potential_energy(&self) -> f64 {
        let grav: f64 = self
            .x
            .iter()
            .zip(&self.mass)
            .map(|(x, m)| -m * self.gravity.dot(*x))
            .sum();
        grav + self.sets.iter().map(|s| s.energy(&self.x)).sum::<f64>()
    }

    /// Linear momentum `Σ m v`.
    pub fn linear_momentum(&self) -> DVec3 {
        self.v.iter().zip(&self.mass).map(|(v, m)| *v * *m).sum()
    }

    /// Angular momentum about the origin, `Σ m x × v`.
    pub fn angular_momentum(&self) -> DVec3 {
        self.x
            .iter()
            .zip(&self.v)
            .zip(&self.mass)
            .map(|((x, v), m)| x.cross(*v) * *m)
            .sum()
    }

    /// Largest `|C|` over all sets (NaN if any value is NaN).
    pub fn max_violation(&self) -> f64 {
        self.sets
            .iter()
            .map(|s| s.max_violation(&self.x))
            .fold(0.0, |m: f64, v| {
                if m.is_nan() || v.is_nan() {
                    f64::NAN
                } else {
                    m.max(v)
                }
            })
    }

    /// `Err(LengthMismatch)` when the public `x` or `v` was resized away from the
    /// particle count (every stepping entry point checks this first).
    pub fn check_lengths(&self) -> Result<(), SoftError> {
        let n = self.mass.len();
        if self.x.len() != n || self.v.len() != n {
            return Err(SoftError::LengthMismatch);
        }
        Ok(())
    }

    /// Checks a candidate state; returns the first bad particle. "Bad" means non-finite
    /// or beyond `1e12` m (or m/s): an exploding state is reported before it overflows.
    pub(crate) fn first_bad(x: &[DVec3], v: &[DVec3]) -> Option<usize> {
        constraint_core::math::first_out_of_limit(x, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{
        CgSettings, HessianMode, ImplicitEuler, Integrator, LinearSolver, Scheme, Softness,
    };
    use constraint_core::Distance;

    fn bob() -> SoftSystem {
        let x = vec![DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), DVec3::X];
        let mut sys = SoftSystem::new(x.clone(), vec![1.0; 3]).expect("system");
        sys.pin(0).expect("pin");
        let spring = Distance::from_rest(0, 1, &x).expect("spring");
        sys.add_set(
            ConstraintSet::uniform("spring", vec![spring], Softness::stiff(1e4)).expect("set"),
        )
        .expect("add");
        sys
    }

    /// The integrators describe their scheme as data (the configuration they step
    /// with), unchanged by a step; the words are the report's.
    #[test]
    fn integrators_report_their_scheme_as_data() {
        let mut sys = bob();
        let cg = LinearSolver::ConjugateGradient(CgSettings::default());
        let mut step = ImplicitEuler::new(1e-2, HessianMode::GaussNewton, cg).expect("integrator");
        step.step(&mut sys).expect("step");
        assert_eq!(
            step.scheme(),
            Scheme::ImplicitEuler {
                mode: HessianMode::GaussNewton,
                solver: cg
            }
        );
        step.mode = HessianMode::Projected;
        assert!(matches!(
            step.scheme(),
            Scheme::ImplicitEuler {
                mode: HessianMode::Projected,
                ..
            }
        ));
        let mut se = crate::SymplecticEuler::new(1e-3).expect("integrator");
        se.step(&mut sys).expect("step");
        assert_eq!(se.scheme(), Scheme::SymplecticEuler);
    }
}
