//! The smallest build of the soft crate: one spring, implicit Euler with conjugate
//! gradient, no faer (`cargo run -p constraint-soft --no-default-features --example
//! spring_only`). `report/tests/leave_out.rs` builds it and checks that it links none of
//! the lagrange, articulated or contact crates, nor faer.

use constraint_core::{DVec3, Distance};
use constraint_soft::{
    CgSettings, ConstraintSet, HessianMode, ImplicitEuler, Integrator, LinearSolver, SoftSystem,
    Softness,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // A 1 kg bob on a 1 m spring, hanging from a pinned point.
    let x = vec![DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0)];
    let mut sys = SoftSystem::new(x.clone(), vec![1.0, 1.0])?;
    sys.pin(0)?;
    let spring = Distance::from_rest(0, 1, &x)?;
    sys.add_set(ConstraintSet::uniform(
        "spring",
        vec![spring],
        Softness::stiff(1e4),
    )?)?;
    let mut step = ImplicitEuler::new(
        1e-2,
        HessianMode::Projected,
        LinearSolver::ConjugateGradient(CgSettings::default()),
    )?;
    for _ in 0..100 {
        step.step(&mut sys)?;
    }
    println!("bob at z = {:.5} m", sys.x[1].z);
    Ok(())
}
