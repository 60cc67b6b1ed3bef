//! The run-time stages of each formulation, for reports ("what does this scene run"):
//! derived from the step's configuration and the constraints it is given, with the KKT
//! solver the last step actually used where the step records it
//! ([`AccelerationLevel::last_solver`], [`VelocityLevel::last_solver`]) and, for the
//! projections and RATTLE (always a diagonal `A`), the solver [`KktSolver::resolve`]
//! picks for the constraints' row count.
//!
//! Each `stages` returns short `&'static str`s in step order; the constraint sets
//! themselves are [`Constraints::stages`], the soft forces
//! [`SoftSystem::stages`](constraint_soft::SoftSystem::stages).

use crate::acceleration::{AccelerationLevel, Baumgarte};
use crate::kkt::KktSolver;
use crate::projection::{FastProjection, ProjectedStep};
use crate::rattle::{Rattle, RattleOrder};
use crate::set::Constraints;
use crate::velocity::{BaseStep, VelocityLevel};
use constraint_soft::Integrator;

/// The KKT solver of a solve with a diagonal `A`: the recorded one, else the one
/// `requested` resolves to for `cons`.
fn kkt(recorded: Option<KktSolver>, requested: KktSolver, cons: &Constraints) -> &'static str {
    recorded
        .unwrap_or_else(|| requested.resolve(true, cons.rows()))
        .stage()
}

impl AccelerationLevel {
    /// The stages of a step under `cons`: the acceleration-level KKT system, the `J̇ẋ`
    /// term when included, Baumgarte stabilisation when its gains are not zero, the KKT
    /// solver and the symplectic Euler update.
    pub fn stages(&self, cons: &Constraints) -> Vec<&'static str> {
        let mut out = vec!["acceleration level [M Jᵀ; J 0][ẍ; λ] = [F; −J̇ẋ − k_x C − k_v Ċ]"];
        if self.velocity_term {
            out.push("velocity term J̇ẋ (constraint curvature)");
        }
        if self.baumgarte != Baumgarte::NONE {
            out.push("Baumgarte stabilisation");
        }
        out.push(kkt(self.last_solver(), self.solver, cons));
        out.push("symplectic Euler update");
        out
    }
}

impl VelocityLevel {
    /// The stages of a step under `cons`: the velocity-level KKT system, its base step
    /// (explicit `A = M`, or the soft implicit step's own stages), compliant rows when
    /// some set is compliant, the KKT solver, and the position projection when set.
    pub fn stages(&self, cons: &Constraints) -> Vec<&'static str> {
        let mut out = vec!["velocity level [A Jᵀ; J −α/h²][v; λ] = [b; −C/h]"];
        let diagonal = match &self.base {
            BaseStep::Explicit => {
                out.push("explicit base (A = M, b = M v + h F)");
                true
            }
            BaseStep::Implicit(imp) => {
                out.push("implicit base (the soft linearized backward Euler A, b)");
                imp.stages(&mut out);
                false
            }
        };
        if cons.any_compliant() {
            out.push("compliant rows (−α/h² block)");
        }
        out.push(
            self.last_solver()
                .unwrap_or_else(|| self.solver.resolve(diagonal, cons.rows()))
                .stage(),
        );
        if let Some(p) = &self.projection {
            p.push_stages(cons, &mut out);
        }
        out
    }
}

impl FastProjection {
    /// Appends the projection's stages: the Newton iterations and their KKT solver.
    pub fn push_stages(&self, cons: &Constraints, out: &mut Vec<&'static str>) {
        out.push("fast projection (Goldenthal): Newton on C(x) = 0");
        out.push(kkt(None, self.solver, cons));
        out.push("velocities from positions (x − x₀)/h");
    }
}

impl<I: Integrator> ProjectedStep<I> {
    /// The stages of a step under `cons`: the base integrator's, then the projection's.
    pub fn stages(&self, cons: &Constraints) -> Vec<&'static str> {
        let mut out = Vec::new();
        self.base.stages(&mut out);
        self.projection.push_stages(cons, &mut out);
        out
    }
}

impl Rattle {
    /// The stages of a step under `cons`: the kicks and drift, SHAKE, the velocity
    /// projection, their KKT solver, and Yoshida's composition for RATTLE4.
    pub fn stages(&self, cons: &Constraints) -> Vec<&'static str> {
        let mut out = vec![
            "RATTLE kick–drift–kick (Störmer–Verlet)",
            "SHAKE position projection (chord, Newton fallback)",
            "velocity projection J v = 0",
            kkt(None, self.solver, cons),
        ];
        if self.order == RattleOrder::Fourth {
            out.push("Yoshida triple jump (RATTLE4)");
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::chain;
    use crate::set::HardSet;
    use constraint_soft::{HessianMode, ImplicitEuler, LinearSolver};

    #[test]
    fn stages_follow_the_configuration_and_the_solver_used() {
        let (mut sys, cons) = chain(3, 0.1, 0.1, 1.0).expect("chain");
        assert_eq!(cons.stages(), ["hard links: 3 × Distance"]);
        let mut vel = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::Auto).expect("vel");
        // Before a step: Auto as it would resolve; after: the solver recorded.
        assert!(vel.stages(&cons).contains(&KktSolver::DenseSchur.stage()));
        vel.step(&mut sys, &cons).expect("step");
        assert_eq!(vel.last_solver(), Some(KktSolver::DenseSchur));
        let st = vel.stages(&cons);
        assert!(st.contains(&"explicit base (A = M, b = M v + h F)"));
        assert!(!st
            .iter()
            .any(|s| s.contains("compliant") || s.contains("projection")));
        vel.projection = Some(FastProjection::new(1e-10, 5, KktSolver::DenseSchur).expect("p"));
        assert!(vel
            .stages(&cons)
            .iter()
            .any(|s| s.contains("fast projection")));

        let imp = ImplicitEuler::new(1e-3, HessianMode::Projected, LinearSolver::SparseLdlt)
            .expect("implicit");
        let vel = VelocityLevel::new(1e-3, BaseStep::Implicit(Box::new(imp)), KktSolver::Auto)
            .expect("vel");
        let st = vel.stages(&cons);
        assert!(st.contains(&"sparse LDLᵀ (faer)"), "{st:?}");
        assert!(st.contains(&"MINRES on the KKT matrix"), "{st:?}");

        let acc = AccelerationLevel::new(1e-3, Baumgarte::NONE, KktSolver::DenseSchur).expect("a");
        assert!(!acc.stages(&cons).contains(&"Baumgarte stabilisation"));

        let r4 = Rattle::new(1e-3, RattleOrder::Fourth, 1e-12, 20, KktSolver::DenseSchur)
            .expect("rattle");
        assert!(r4.stages(&cons).contains(&"Yoshida triple jump (RATTLE4)"));

        let mut soft = Constraints::new();
        let x = sys.x.clone();
        let link = constraint_core::Distance::from_rest(0, 1, &x).expect("link");
        soft.add(HardSet::compliant("soft", vec![link], vec![1e-6]).expect("set"));
        assert_eq!(soft.stages(), ["compliant soft: 1 × Distance"]);
        let vel = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::DenseSchur).expect("v");
        assert!(vel.stages(&soft).contains(&"compliant rows (−α/h² block)"));
    }
}
