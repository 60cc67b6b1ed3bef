//! The solver path a step took, as plain data (the shape of Box2D v3's `b2Counters`
//! and rapier's `Counters`: what ran, not words about it). Reports turn it into text.

use crate::lcp::RowMethod;

use super::ContactWorld;

/// How a step solved its contact rows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RowsSolver {
    /// No contact rows: nothing to solve.
    #[default]
    NoRows,
    /// Matrix-free sequential impulses (projected Gauss–Seidel swept bottom-up).
    Sequential,
    /// The dense Delassus matrix `J M⁻¹ Jᵀ` handed to [`crate::lcp::solve_rows`].
    Dense,
    /// The soft step (sub-steps of soft solve, integrate and relax; Box2D v3's solver).
    SoftStep,
}

/// The solver path of one step ([`ContactWorld::last_path`]): which row solver ran and
/// which of its optional parts did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolverPath {
    /// The row solver.
    pub rows: RowsSolver,
    /// Shock-propagation sweeps ran (sequential impulses with
    /// `ContactSettings::shock_propagation > 0` and some contact).
    pub shock: bool,
    /// The dense path solved the boxed LCP with one PGS (friction in one problem)
    /// instead of staggered projections.
    pub boxed_pgs: bool,
    /// The boxed PGS ran out of sweeps and the staggered solve answered instead
    /// ([`crate::lcp::RowStats::boxed_fallback`]; `boxed_pgs` is then false).
    pub boxed_fallback: bool,
    /// The method whose answer to the normal LCP was accepted (dense, staggered).
    pub normal: Option<RowMethod>,
    /// The friction (tangent) block was solved by PGS (dense, staggered).
    pub friction_pgs: bool,
    /// The friction PGS ran out of sweeps and its sweep budget was kept.
    pub friction_budget: bool,
    /// Split-impulse pseudo velocities were solved (some contact beyond the slop).
    pub split: bool,
    /// Whether a step has run (private: [`ContactWorld::last_path`] is `None` before).
    stepped: bool,
}

impl SolverPath {
    /// Before any step.
    pub(super) const NOT_STEPPED: Self = Self {
        rows: RowsSolver::NoRows,
        shock: false,
        boxed_pgs: false,
        boxed_fallback: false,
        normal: None,
        friction_pgs: false,
        friction_budget: false,
        split: false,
        stepped: false,
    };

    /// The start of a step: nothing recorded yet.
    pub(super) const STEPPED: Self = Self {
        stepped: true,
        ..Self::NOT_STEPPED
    };
}

impl ContactWorld {
    /// The solver path the last step took, `None` before any step. A failed step keeps
    /// what it recorded until it failed.
    pub fn last_path(&self) -> Option<SolverPath> {
        self.path.stepped.then_some(self.path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rigid::{ContactSolver, FrictionModel};
    use crate::scenes::{box_stack, sphere_drop};

    #[test]
    fn the_path_follows_the_configuration_and_the_contacts() {
        let mut w = sphere_drop(0.1, 0.2).expect("scene");
        assert_eq!(w.last_path(), None);
        // Falling, far from the ground: no rows; then resting: Auto with one contact
        // point on the static ground keeps the sequential impulses, whose answer solves
        // the LCP to the tolerance.
        w.step(1e-3).expect("step");
        let p = w.last_path().expect("stepped");
        assert_eq!(p.rows, RowsSolver::NoRows);
        assert_eq!(p.normal, None);
        for _ in 0..400 {
            w.step(1e-3).expect("step");
        }
        let p = w.last_path().expect("stepped");
        assert_eq!(p.rows, RowsSolver::Sequential);
        assert_eq!(p.normal, None);

        // A box on a box under Auto: body-body contacts, the dense Newton solve, which
        // the staggered LCP accepts.
        let mut d = box_stack(2).expect("stack");
        d.step(1.0 / 60.0).expect("step");
        let p = d.last_path().expect("stepped");
        assert_eq!(p.rows, RowsSolver::Dense);
        assert_eq!(p.normal, Some(RowMethod::Newton));
        assert!(!p.boxed_pgs && !p.shock);

        // A box on a box: body-body contacts, swept by sequential impulses with shock
        // propagation (the default `shock_propagation` is not zero).
        let mut s = box_stack(3).expect("stack");
        s.settings.solver = ContactSolver::SequentialImpulses;
        s.step(1.0 / 60.0).expect("step");
        let p = s.last_path().expect("stepped");
        assert_eq!(p.rows, RowsSolver::Sequential);
        assert!(p.shock);
        assert_eq!(p.normal, None);
        s.settings.shock_propagation = 0;
        s.step(1.0 / 60.0).expect("step");
        assert!(!s.last_path().expect("stepped").shock);

        // Boxed friction: one PGS on the whole LCP, no staggered normal solve.
        s.settings.solver = ContactSolver::Pgs;
        s.settings.friction = FrictionModel::Boxed;
        s.settings.tolerance = 1e-6;
        let stats = s.step(1.0 / 60.0).expect("step");
        assert_eq!(stats.solver, Some(ContactSolver::Pgs));
        let p = s.last_path().expect("stepped");
        assert_eq!(p.rows, RowsSolver::Dense);
        assert!(p.boxed_pgs);
    }
}
