//! The RATTLE step's velocity-level fallback (one-sided rows present) aims its joint
//! rows at the end of the step, `J v' = J v − C(x + h v)/h` (`world/velocity.rs`,
//! `Aim::EndOfStep`), so that `x + h v'` meets the joints to `O(h³)` and the position
//! projection after it has little or nothing to do. The reference is the same step
//! aimed at the start (`Method::VelocityProjected`, `J v' = −C(x)/h`, the projection at
//! the same tolerance): what the fallback is with `World::set_end_of_step_aim(false)`.
//! Every tolerance carries the value measured when it was set.

use constraint_articulated::{Joint, JointKind, Method, RigidBody, World};
use constraint_core::{DMat3, DQuat, DVec3, Hinge, Pose};

/// The unilateral projection floor the runs set (`World::set_unilateral_tolerance`).
const FLOOR: f64 = 1e-7;

/// The fallback as it was: velocity level aimed at the start, then the projection.
const START_AIMED: Method = Method::VelocityProjected {
    beta: 1.0,
    tolerance: FLOOR,
    max_iterations: 30,
    correct_velocity: false,
};

/// An undamped three-link hinge chain (1 kg links 1 m long, axes `y`) swinging from the
/// world at the origin with joint rates `rates` (rad/s), and beside it a 1 kg flap on a hinge at
/// `(3, 0, 0)` held horizontal by gravity against a one-sided limit: the limit's row is
/// present on every step, so every RATTLE step takes the velocity-level fallback, and
/// the flap at rest on its stop does no work (the energy is the chain's).
fn chain_and_flap(rates: [f64; 3]) -> World {
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let mut parent_pose = Pose::IDENTITY;
    for i in 0..rates.len() {
        let pose = Pose {
            x: DVec3::new(0.0, 0.0, -(i as f64) - 0.5),
            q: DQuat::IDENTITY,
        };
        // Joint-consistent start twists: ω_i = Σ_{k≤i} r_k ŷ and
        // v_i = Σ_{k≤i} r_k ŷ × (x_i − a_k), the pivot a_k at (0, 0, −k).
        let (mut v, mut omega) = (DVec3::ZERO, DVec3::ZERO);
        for (k, r) in rates.iter().enumerate().take(i + 1) {
            let w = DVec3::new(0.0, *r, 0.0);
            omega += w;
            v += w.cross(pose.x - DVec3::new(0.0, 0.0, -(k as f64)));
        }
        let body = RigidBody::new(i, 1.0, DMat3::IDENTITY * 0.1, pose)
            .unwrap()
            .with_velocity(v, omega);
        w.add_body(body).unwrap();
        let anchor = DVec3::new(0.0, 0.0, -(i as f64));
        let hinge = Hinge::from_world(&parent_pose, &pose, anchor, DVec3::Y).unwrap();
        w.add_joint(Joint {
            parent: i.checked_sub(1),
            child: i,
            kind: JointKind::Hinge(hinge),
            damping: 0.0,
        })
        .unwrap();
        parent_pose = pose;
    }
    let pose = Pose {
        x: DVec3::new(3.5, 0.0, 0.0),
        q: DQuat::IDENTITY,
    };
    let flap = w
        .add_body(RigidBody::new(3, 1.0, DMat3::IDENTITY * 0.1, pose).unwrap())
        .unwrap();
    let anchor = DVec3::new(3.0, 0.0, 0.0);
    let hinge = Hinge::from_world(&Pose::IDENTITY, &pose, anchor, DVec3::Y).unwrap();
    let j = w
        .add_joint(Joint {
            parent: None,
            child: flap,
            kind: JointKind::Hinge(hinge),
            damping: 0.0,
        })
        .unwrap();
    // Gravity turns the flap's angle one way: the stop goes on that side, at 0.
    let mut probe = w.clone();
    probe.step(1e-3, Method::Velocity { beta: 1.0 }).unwrap();
    if probe.joint_position(j).unwrap() > 0.0 {
        w.set_limit(j, f64::NEG_INFINITY, 0.0).unwrap();
    } else {
        w.set_limit(j, 0.0, f64::INFINITY).unwrap();
    }
    w
}

/// What a run of `steps` steps of `h` with `method` did: the projection iterations in
/// all, the steps that took the fallback, the largest joint separation after a step
/// (m) and the largest `|E − E₀|` (J).
fn run(method: Method, h: f64, steps: usize) -> (usize, usize, f64, f64) {
    run_rows(method, h, steps, false)
}

/// [`run`] with the aim's rows at the predicted poses when `predicted`
/// (`World::set_end_of_step_rows_predicted`).
fn run_rows(method: Method, h: f64, steps: usize, predicted: bool) -> (usize, usize, f64, f64) {
    let mut w = chain_and_flap([1.0, -0.5, 0.8]);
    w.set_end_of_step_aim(true);
    w.set_end_of_step_rows_predicted(predicted);
    w.set_unilateral_tolerance(FLOOR).unwrap();
    // The Newton projection's iterations are what these tests count: the tree sweep
    // (on by default, `world/projection/sweep.rs`) closes these joints without them.
    w.set_projection_sweep(false, false);
    let total = |w: &World| w.energy().0 + w.energy().1;
    let e0 = total(&w);
    let (mut iterations, mut fallbacks, mut sep, mut drift) = (0, 0, 0.0f64, 0.0f64);
    for _ in 0..steps {
        let s = w.step(h, method).unwrap();
        iterations += s.projection_iterations;
        fallbacks += s.unilateral_fallbacks;
        sep = sep.max(w.max_separation());
        drift = drift.max((total(&w) - e0).abs());
    }
    (iterations, fallbacks, sep, drift)
}

/// At 1 ms the aimed fallback lands within the projection's tolerance on every step
/// (no iteration), where the start-aimed one needs one or more a step; both end every
/// step on the joints.
#[test]
fn aimed_fallback_needs_no_projection_at_a_small_step() {
    let steps = 3000;
    let (aimed, fallbacks, aimed_sep, aimed_drift) = run(Method::default(), 1e-3, steps);
    let (start, _, start_sep, start_drift) = run(START_AIMED, 1e-3, steps);
    println!("h 1e-3: max |E − E0| aimed {aimed_drift:.3e} J start {start_drift:.3e} J");
    // Measured (E0 = −38.31 J): aimed 3.7e-3 J, start-aimed 6.2e-3 J.
    assert!(aimed_drift <= start_drift, "{aimed_drift} vs {start_drift}");
    println!(
        "h 1e-3: iterations aimed {aimed} start {start}; fallbacks {fallbacks}; \
         separation aimed {aimed_sep:.2e} start {start_sep:.2e}"
    );
    assert_eq!(
        fallbacks, steps,
        "the flap's limit row was not on every step"
    );
    // Measured: aimed 0, start-aimed 2556 (the start-aimed step misses the joints by
    // (ωh)²r/2 ≈ 1e-7 m and more).
    assert!(aimed * 10 <= start, "aimed {aimed} vs {start}");
    assert!(start >= steps / 2, "start-aimed {start}");
    // Measured: aimed 2.3e-9 m, start-aimed 1.0e-7 m.
    assert!(aimed_sep <= FLOOR, "aimed separation {aimed_sep:e}");
    assert!(start_sep <= FLOOR, "start-aimed separation {start_sep:e}");
}

/// At 10 ms the aimed fallback still ends every step on the joints, projects no more
/// than the start-aimed one, and the undamped chain's energy error stays bounded and
/// smaller (no growth from the chord velocity `v' = (x' − x)/h` it keeps).
#[test]
fn aimed_fallback_keeps_the_energy_bounded() {
    let (aimed, _, aimed_sep, aimed_drift) = run(Method::default(), 1e-2, 1000);
    let (start, _, start_sep, start_drift) = run(START_AIMED, 1e-2, 1000);
    let (_, _, _, aimed_long) = run(Method::default(), 1e-2, 5000);
    let (_, _, _, start_long) = run(START_AIMED, 1e-2, 5000);
    println!(
        "h 1e-2: iterations aimed {aimed} start {start}; separation aimed {aimed_sep:.2e} \
         start {start_sep:.2e}; max |E − E0| over 10 s aimed {aimed_drift:.3e} J start \
         {start_drift:.3e} J, over 50 s aimed {aimed_long:.3e} J start {start_long:.3e} J"
    );
    // Measured: aimed 992, start-aimed 1000 (the residual O(h²ω|v' − v|) of the
    // aimed step is over the 1e-7 m floor at this step).
    assert!(aimed <= start, "aimed {aimed} vs {start}");
    // Measured: 9.6e-8 m.
    assert!(aimed_sep <= FLOOR, "aimed separation {aimed_sep:e}");
    // Measured (E0 = −38.31 J): 10 s aimed 3.7e-2 J, start-aimed 0.140 J; 50 s aimed
    // 3.7e-2 J (bounded), start-aimed 0.481 J (growing).
    assert!(aimed_drift <= start_drift, "{aimed_drift} vs {start_drift}");
    assert!(
        aimed_long <= 1.5 * aimed_drift,
        "grew: {aimed_long} vs {aimed_drift}"
    );
    assert!(aimed_long <= start_long, "{aimed_long} vs {start_long}");
}

/// With the rows at the predicted poses (off by default) the fallback at 10 ms needs no
/// projection iteration, where the default's needs one nearly every step, and ends every
/// step on the joints; its energy error is the damping the predicted rows bring (about
/// `¾ (ω h)²` of the turning's kinetic energy a step), larger than the default's.
#[test]
fn predicted_rows_need_no_projection_and_damp() {
    let (aimed, _, _, aimed_drift) = run(Method::default(), 1e-2, 1000);
    let (predicted, _, predicted_sep, predicted_drift) =
        run_rows(Method::default(), 1e-2, 1000, true);
    println!(
        "h 1e-2: iterations default {aimed} predicted {predicted}; separation predicted \
         {predicted_sep:.2e}; max |E − E0| over 10 s default {aimed_drift:.3e} J predicted \
         {predicted_drift:.3e} J"
    );
    // Measured: default 992, predicted 0.
    assert!(predicted * 10 <= aimed, "predicted {predicted} vs {aimed}");
    // Measured: 6.4e-8 m.
    assert!(
        predicted_sep <= FLOOR,
        "predicted separation {predicted_sep:e}"
    );
    // Measured (E0 = −38.31 J): default 3.7e-2 J, predicted 1.36 J.
    assert!(
        predicted_drift > aimed_drift,
        "{predicted_drift} vs {aimed_drift}"
    );
    // The error is a loss: the chain's energy after 10 s against its start.
    let mut w = chain_and_flap([1.0, -0.5, 0.8]);
    w.set_end_of_step_rows_predicted(true);
    w.set_unilateral_tolerance(FLOOR).unwrap();
    let total = |w: &World| w.energy().0 + w.energy().1;
    let e0 = total(&w);
    for _ in 0..1000 {
        w.step(1e-2, Method::default()).unwrap();
    }
    let change = total(&w) - e0;
    println!("h 1e-2: predicted rows, E − E0 after 10 s {change:.3e} J");
    // Measured: −1.36 J (all of the largest error: a steady loss).
    assert!(change < 0.0, "{change}");
    let mut w = World::new(DVec3::ZERO);
    assert!(!w.end_of_step_rows_predicted());
    w.set_end_of_step_rows_predicted(true);
    assert!(w.end_of_step_rows_predicted());
}

/// The aim is the default; a world can go back to the start aim.
#[test]
fn end_of_step_aim_is_on_by_default() {
    let mut w = World::new(DVec3::ZERO);
    assert!(w.end_of_step_aim());
    w.set_end_of_step_aim(false);
    assert!(!w.end_of_step_aim());
}
