//! One vocabulary for the constraint formulations of the lecture (Otaduy 2010,
//! "Restricciones"): soft springs, compliant constraints, the acceleration level with
//! Baumgarte stabilisation, the velocity level, the velocity level followed by a
//! position projection, RATTLE and RATTLE4 — plus fast projection (Goldenthal et al.
//! 2007), which the particle side also offers.
//!
//! Each [`Formulation`] maps to the particle types of `constraint_lagrange` /
//! `constraint_soft` ([`Formulation::particle_stepper`]) and to the body types of
//! `constraint_articulated` ([`Formulation::body_method`]), so a sweep names a
//! formulation once for both. A formulation that exists on one side only says so: the
//! body side returns `None` for soft springs, compliant rows (on bodies compliance is a
//! joint property, `World::set_compliance`, under any method) and fast projection.
//!
//! The parameters are those of the project's stability maps: Baumgarte critically
//! damped with time constant `τ = 5h` (`k_x = 1/τ²`, `k_v = 2/τ`); projections by Newton
//! to 1e-10 in at most 10 iterations; particle SHAKE to 1e-10 in at most 20 iterations
//! per sub-step; body RATTLE at `Method::default()` (1e-12, 30 iterations) and body
//! RATTLE4 to 1e-12 in at most 20.

use constraint_articulated::Method;
use constraint_lagrange::{
    AccelerationLevel, BaseStep, Baumgarte, Constraints, FastProjection, KktSolver, LagrangeError,
    ProjectedStep, Rattle, RattleOrder, VelocityLevel,
};
use constraint_soft::{
    HessianMode, ImplicitEuler, Integrator, LinearSolver, SoftSystem, SymplecticEuler,
};

/// The integrator of soft springs (`E = ½ k C²`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SoftIntegrator {
    /// Symplectic Euler, `v⁺ = v + h M⁻¹F(x)`, `x⁺ = x + h v⁺`.
    Symplectic,
    /// Linearized backward Euler, `(M − h²∂F/∂x) v⁺ = M v + h F` (sparse LDLᵀ,
    /// projected Hessian).
    Implicit,
}

/// A constraint formulation of the lecture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Formulation {
    /// Soft springs, `E = ½ k C²`, under an integrator.
    Soft(SoftIntegrator),
    /// Compliant velocity level, `[M Jᵀ; J −α/h²][v; λ] = [M v₀ + hF; −C(x₀)/h]`,
    /// `α = 1/k` (`α = 0`: hard).
    Compliant,
    /// Acceleration level `[M Jᵀ; J 0][ẍ; λ] = [F; −J̇ẋ − k_x C − k_v Ċ]` with critically
    /// damped Baumgarte gains, `τ = 5h`.
    AccelerationBaumgarte,
    /// Velocity level `[M Jᵀ; J 0][v; λ] = [M v₀ + hF; −C(x₀)/h]`.
    Velocity,
    /// Velocity level, then Newton projection on `C(x) = 0` with
    /// `(h² J M⁻¹ Jᵀ) δλ = C` and `v = (x − x₀)/h`.
    VelocityProjection,
    /// Fast projection (Goldenthal et al. 2007, Algorithm 1): a symplectic Euler step
    /// without the constraints, then the same projection. Particles only.
    FastProjection,
    /// RATTLE: `v½ = v + (h/2)M⁻¹(F − Jᵀλ)`, `x' = x + h v½` on `C(x') = 0` (SHAKE),
    /// `v' = v½ + (h/2)M⁻¹(F' − J'ᵀμ)` on `J(x')v' = 0` (second order).
    Rattle,
    /// RATTLE composed by Yoshida's triple jump (fourth order).
    Rattle4,
}

/// How a formulation models a constraint on the particle side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Links {
    /// Soft springs of stiffness `k` (no `k = ∞`).
    Springs,
    /// Compliant constraints, `α = 1/k` (`k = ∞`: `α = 0`, hard).
    Compliant,
    /// Hard constraints: no stiffness parameter.
    Hard,
}

/// Baumgarte time constant in steps: `τ = BAUMGARTE_STEPS · h`.
pub const BAUMGARTE_STEPS: f64 = 5.0;

/// Projection tolerance (strain on particles, m on bodies).
pub const PROJECTION_TOLERANCE: f64 = 1e-10;

/// Newton iterations of a projection at most.
pub const PROJECTION_ITERATIONS: usize = 10;

/// Particle SHAKE iterations per RATTLE sub-step at most (a larger budget lets a failing
/// SHAKE reach singular Schur complements, whose dense SVD fallback costs minutes on
/// 1000 links).
pub const SHAKE_ITERATIONS: usize = 20;

impl Formulation {
    /// The lecture's list, in its order (soft springs under symplectic Euler).
    pub const LECTURE: [Formulation; 7] = [
        Formulation::Soft(SoftIntegrator::Symplectic),
        Formulation::Compliant,
        Formulation::AccelerationBaumgarte,
        Formulation::Velocity,
        Formulation::VelocityProjection,
        Formulation::Rattle,
        Formulation::Rattle4,
    ];

    /// Short name (lower case, no spaces).
    pub fn name(self) -> &'static str {
        match self {
            Formulation::Soft(SoftIntegrator::Symplectic) => "soft-symplectic",
            Formulation::Soft(SoftIntegrator::Implicit) => "soft-implicit",
            Formulation::Compliant => "compliant",
            Formulation::AccelerationBaumgarte => "baumgarte",
            Formulation::Velocity => "velocity",
            Formulation::VelocityProjection => "projected",
            Formulation::FastProjection => "fast-projection",
            Formulation::Rattle => "rattle",
            Formulation::Rattle4 => "rattle4",
        }
    }

    /// How the formulation models a constraint on the particle side.
    pub fn links(self) -> Links {
        match self {
            Formulation::Soft(_) => Links::Springs,
            Formulation::Compliant => Links::Compliant,
            _ => Links::Hard,
        }
    }

    /// The body-side [`Method`] at step `h`; `None` where the formulation has no body
    /// counterpart (soft springs, fast projection) or is not a method there (compliant:
    /// a joint property under any method).
    pub fn body_method(self, h: f64) -> Option<Method> {
        match self {
            Formulation::Soft(_) | Formulation::Compliant | Formulation::FastProjection => None,
            Formulation::Velocity => Some(Method::Velocity { beta: 1.0 }),
            Formulation::VelocityProjection => Some(Method::VelocityProjected {
                beta: 1.0,
                tolerance: PROJECTION_TOLERANCE,
                max_iterations: PROJECTION_ITERATIONS,
                correct_velocity: false,
            }),
            Formulation::AccelerationBaumgarte => {
                // Critically damped C̈ + k_v Ċ + k_x C = 0, time constant τ = 5h.
                let tau = BAUMGARTE_STEPS * h;
                Some(Method::Acceleration {
                    kx: 1.0 / (tau * tau),
                    kv: 2.0 / tau,
                })
            }
            Formulation::Rattle => Some(Method::default()),
            Formulation::Rattle4 => Some(Method::Rattle4 {
                tolerance: 1e-12,
                max_iterations: 20,
            }),
        }
    }

    /// The particle-side stepper at step `h`, solving its KKT systems with `solver`.
    /// Every formulation exists on the particle side.
    ///
    /// # Errors
    /// A bad step or parameter (the constructors' typed errors).
    pub fn particle_stepper(
        self,
        h: f64,
        solver: KktSolver,
    ) -> Result<ParticleStepper, LagrangeError> {
        let projection =
            || FastProjection::new(PROJECTION_TOLERANCE, PROJECTION_ITERATIONS, solver);
        Ok(match self {
            Formulation::Soft(SoftIntegrator::Symplectic) => {
                ParticleStepper::Soft(Box::new(SymplecticEuler::new(h)?))
            }
            Formulation::Soft(SoftIntegrator::Implicit) => ParticleStepper::Soft(Box::new(
                ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt)?,
            )),
            // Critically damped C̈ + k_v Ċ + k_x C = 0, time constant τ = 5h.
            Formulation::AccelerationBaumgarte => ParticleStepper::Acceleration(Box::new(
                AccelerationLevel::new(h, Baumgarte::critical(BAUMGARTE_STEPS * h)?, solver)?,
            )),
            Formulation::Velocity | Formulation::Compliant => ParticleStepper::Velocity(Box::new(
                VelocityLevel::new(h, BaseStep::Explicit, solver)?,
            )),
            Formulation::VelocityProjection => {
                let mut v = VelocityLevel::new(h, BaseStep::Explicit, solver)?;
                v.projection = Some(projection()?);
                ParticleStepper::Velocity(Box::new(v))
            }
            Formulation::FastProjection => ParticleStepper::Projected(Box::new(
                ProjectedStep::new(SymplecticEuler::new(h)?, projection()?),
            )),
            Formulation::Rattle | Formulation::Rattle4 => {
                let order = if self == Formulation::Rattle {
                    RattleOrder::Second
                } else {
                    RattleOrder::Fourth
                };
                ParticleStepper::Rattle(Box::new(Rattle::new(
                    h,
                    order,
                    PROJECTION_TOLERANCE,
                    SHAKE_ITERATIONS,
                    solver,
                )?))
            }
        })
    }
}

/// What one particle step reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParticleStepStats {
    /// A projection stopped at its iteration limit.
    pub unconverged: bool,
    /// RATTLE sub-steps whose SHAKE iteration switched to Newton.
    pub fallbacks: usize,
}

/// A particle-side stepper of a [`Formulation`].
pub enum ParticleStepper {
    /// Soft springs (the links live in the system's constraint sets).
    Soft(Box<dyn Integrator>),
    /// Acceleration level.
    Acceleration(Box<AccelerationLevel>),
    /// Velocity level (compliant rows, with or without a projection).
    Velocity(Box<VelocityLevel>),
    /// Fast projection.
    Projected(Box<ProjectedStep<SymplecticEuler>>),
    /// RATTLE or RATTLE4.
    Rattle(Box<Rattle>),
}

impl ParticleStepper {
    /// One step of `sys` under the rows `cons` (ignored by soft springs).
    ///
    /// # Errors
    /// The step's typed error (soft errors converted).
    pub fn step(
        &mut self,
        sys: &mut SoftSystem,
        cons: &Constraints,
    ) -> Result<ParticleStepStats, LagrangeError> {
        let none = ParticleStepStats::default();
        match self {
            ParticleStepper::Soft(s) => s.step(sys).map(|_| none).map_err(LagrangeError::from),
            ParticleStepper::Acceleration(a) => a.step(sys, cons).map(|_| none),
            ParticleStepper::Velocity(v) => {
                v.step(sys, cons)?;
                Ok(ParticleStepStats {
                    unconverged: v.last_projection.is_some_and(|p| !p.converged),
                    fallbacks: 0,
                })
            }
            ParticleStepper::Projected(p) => p.step(sys, cons).map(|st| ParticleStepStats {
                unconverged: !st.converged,
                fallbacks: 0,
            }),
            ParticleStepper::Rattle(r) => r.step(sys, cons).map(|st| ParticleStepStats {
                unconverged: false,
                fallbacks: st.newton_fallbacks,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_body_side_says_which_formulations_it_lacks() {
        let h = 1e-3;
        let missing: Vec<&str> = Formulation::LECTURE
            .iter()
            .chain(&[Formulation::FastProjection])
            .filter(|f| f.body_method(h).is_none())
            .map(|f| f.name())
            .collect();
        assert_eq!(missing, ["soft-symplectic", "compliant", "fast-projection"]);
        // τ = 5h = 5e-3 s: k_x = 1/τ² = 4e4, k_v = 2/τ = 400 (exact up to rounding).
        match Formulation::AccelerationBaumgarte.body_method(h) {
            Some(Method::Acceleration { kx, kv }) => {
                assert!(
                    (kx - 4e4).abs() < 1e-8 && (kv - 400.0).abs() < 1e-10,
                    "{kx} {kv}"
                );
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn every_formulation_builds_a_particle_stepper_and_rejects_a_bad_step() {
        for f in Formulation::LECTURE.iter().chain(&[
            Formulation::FastProjection,
            Formulation::Soft(SoftIntegrator::Implicit),
        ]) {
            assert!(
                f.particle_stepper(1e-3, KktSolver::DenseSchur).is_ok(),
                "{f:?}"
            );
            assert!(
                f.particle_stepper(f64::NAN, KktSolver::DenseSchur).is_err(),
                "{f:?}"
            );
            assert!(
                f.particle_stepper(-1.0, KktSolver::DenseSchur).is_err(),
                "{f:?}"
            );
        }
    }

    #[test]
    fn names_are_distinct() {
        let mut names: Vec<&str> = Formulation::LECTURE.iter().map(|f| f.name()).collect();
        names.extend(["soft-implicit", "fast-projection"]);
        let n = names.len();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), n);
    }
}
