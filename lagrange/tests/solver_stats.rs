//! What a step records about itself as data (`last_solver`): the KKT solver
//! [`KktSolver::Auto`] resolved to, following the step's configuration (diagonal or
//! block `A`, row count). Reports turn these into words; the library keeps none.

use constraint_lagrange::kkt::AUTO_DENSE_ROWS;
use constraint_lagrange::scenes::chain;
use constraint_lagrange::{AccelerationLevel, BaseStep, Baumgarte, KktSolver, VelocityLevel};
use constraint_soft::{HessianMode, ImplicitEuler, LinearSolver};

#[test]
fn auto_records_the_solver_it_resolved_to() {
    // A 3-link chain: 3 rows, a diagonal `A = M` (explicit base): the dense Schur solve.
    let (mut sys, cons) = chain(3, 0.1, 0.1, 1.0).expect("chain");
    assert!(cons.rows() <= AUTO_DENSE_ROWS);
    let mut vel = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::Auto).expect("vel");
    assert_eq!(vel.last_solver(), None);
    vel.step(&mut sys, &cons).expect("step");
    assert_eq!(vel.last_solver(), Some(KktSolver::DenseSchur));

    // The implicit base's `A` is a block matrix: Auto resolves to MINRES on the KKT
    // matrix.
    let (mut sys, cons) = chain(3, 0.1, 0.1, 1.0).expect("chain");
    let imp = ImplicitEuler::new(1e-3, HessianMode::Projected, LinearSolver::SparseLdlt)
        .expect("implicit");
    let mut vel =
        VelocityLevel::new(1e-3, BaseStep::Implicit(Box::new(imp)), KktSolver::Auto).expect("vel");
    vel.step(&mut sys, &cons).expect("step");
    assert!(
        matches!(vel.last_solver(), Some(KktSolver::Minres(_))),
        "{:?}",
        vel.last_solver()
    );

    // A requested solver is recorded as itself.
    let (mut sys, cons) = chain(3, 0.1, 0.1, 1.0).expect("chain");
    let mut acc =
        AccelerationLevel::new(1e-3, Baumgarte::NONE, KktSolver::DenseSchur).expect("acc");
    assert_eq!(acc.last_solver(), None);
    acc.step(&mut sys, &cons).expect("step");
    assert_eq!(acc.last_solver(), Some(KktSolver::DenseSchur));
}
