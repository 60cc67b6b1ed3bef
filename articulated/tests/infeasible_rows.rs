//! One-sided rows without a solution (issue 13): when the push-out of violated rows
//! (Baumgarte correction, restitution) asks for a motion that the other rows forbid, the
//! velocity-level complementarity problem has no solution (a ray `d ≥ 0`, `A d = 0`,
//! `qᵀd < 0`) and no solver converges. The step then solves the rows again with every
//! push-out at 0 (`UnilateralStats::relaxed`): nothing closes further, the violation
//! stays as it was, and the run's checks (penetration) still see it.

#![cfg(all(feature = "mjcf", feature = "contact"))]

use constraint_articulated::{Method, MjcfScene};

/// An arm at its lower limit (0: horizontal) lying 3 cm deep in a floor whose only way
/// out is to turn up, past the limit.
const ARM_IN_FLOOR: &str = r#"<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 .1" pos="0 0 0.06"/>
    <body name="arm" pos="0 0 0.05">
      <joint name="j" type="hinge" axis="0 1 0" range="0 90"/>
      <geom type="capsule" fromto="0.05 0 0 0.3 0 0" size="0.02"/>
    </body>
  </worldbody>
</mujoco>"#;

#[test]
fn rows_that_cannot_all_open_are_solved_without_their_push_out() {
    let model = constraint_mjcf::load_str(ARM_IN_FLOOR).expect("model");
    let mut s = MjcfScene::new(&model, None).expect("scene");
    let (k0, p0) = s.world.energy();
    let (mut relaxed, mut deepest, mut worst_rise, mut worst_q) = (0, 0.0f64, 0.0f64, 0.0f64);
    for _ in 0..100 {
        // Before the fallback: `LCP: no convergence in 1000 iterations (residual 19)`
        // at the first step.
        s.world.step(2e-3, Method::default()).expect("step");
        let u = s.world.unilateral_stats();
        relaxed += usize::from(u.relaxed);
        deepest = deepest.max(u.max_penetration);
        let (k, p) = s.world.energy();
        worst_rise = worst_rise.max(k + p - (k0 + p0));
        let q = s.world.joint_coordinates(0).expect("coordinates").0[0];
        worst_q = worst_q.max(q.abs());
        assert!(s.world.bodies()[0].v.is_finite() && s.world.bodies()[0].omega.is_finite());
    }
    println!(
        "relaxed steps {relaxed}/100, deepest {deepest:.6e} m, energy rise {worst_rise:.3e} J, |q| ≤ {worst_q:.3e}"
    );
    // Every step needs it (the arm never gets out).
    assert_eq!(relaxed, 100);
    // The arm stays at its limit and in the floor as deep as it started: gates 1e-8
    // (the unilateral projection floor), measured 0 rad and 3.0e-2 + 2e-17 m.
    assert!(worst_q < 1e-8, "{worst_q}");
    assert!(deepest < 0.03 + 1e-8, "{deepest}");
    // No energy from the rows: gate 1e-9 J, measured 5.6e-17.
    assert!(worst_rise < 1e-9, "{worst_rise}");
}
