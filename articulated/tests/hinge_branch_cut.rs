//! Hinge ranges at the branch cut of the angle (issue 13). A [`constraint_core::Hinge`]
//! reads its angle by `atan2`, in `(−π, π]`, where MuJoCo's hinge coordinate is
//! unbounded; humanoid_CMU's wrists (`range="-180 0"`) crossed −π within a step, read
//! +π, 3.1 rad past the upper bound, and the projection turned the hand half a turn.
//! The loader now measures a single limited hinge whose bound lies within 0.1 rad of
//! `±π` (or past it: dm cheetah's `bfoot`, −230°) from the middle of its range.

#![cfg(feature = "mjcf")]

use core::f64::consts::{FRAC_PI_2, PI};

use constraint_articulated::{Method, MjcfScene};

/// One arm on a hinge about `y` with range `range` (degrees), no gravity; an optional
/// actuator element.
fn arm(range: &str, actuator: &str) -> String {
    format!(
        r#"<mujoco>
  <option gravity="0 0 0" timestep="0.001"/>
  <worldbody>
    <body name="arm">
      <joint name="j" type="hinge" axis="0 1 0" range="{range}" damping="0.5"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <actuator>{actuator}</actuator>
</mujoco>"#
    )
}

fn scene(range: &str, actuator: &str) -> (MjcfScene, constraint_mjcf::Model) {
    let model = constraint_mjcf::load_str(&arm(range, actuator)).expect("model");
    (MjcfScene::new(&model, None).expect("scene"), model)
}

/// The arm's angle about `y` from its pose alone (not from the joint's coordinate), in
/// MuJoCo's sense: positive turns `x` towards `−z`.
fn physical_angle(s: &MjcfScene) -> f64 {
    let b = &s.world.bodies()[0];
    let tip = b.pose.q * constraint_core::DVec3::X;
    (-tip.z).atan2(tip.x)
}

#[test]
fn a_range_at_the_cut_is_measured_from_its_middle() {
    // −180 … 0: the zero moves to −90°, MuJoCo's 0 reads +π/2, the bounds ±π/2.
    let (s, _) = scene("-180 0", "");
    let (q, n) = s.world.joint_coordinates(0).expect("coordinates");
    assert_eq!(n, 1);
    // Gate 1e-12 rad (round-off of the turned rest pose), measured 0.
    assert!((q[0] - FRAC_PI_2).abs() < 1e-12, "{}", q[0]);
    let [lo, hi] = s.world.limits()[0][0].expect("limit");
    assert!(
        (lo + FRAC_PI_2).abs() < 1e-15 && (hi - FRAC_PI_2).abs() < 1e-15,
        "{lo} {hi}"
    );
    // Past the cut (dm cheetah's bfoot): −230 … 50 about −90, ±140°.
    let (s, _) = scene("-230 50", "");
    let [lo, hi] = s.world.limits()[0][0].expect("limit");
    let b = 140f64.to_radians();
    assert!(
        (lo + b).abs() < 1e-14 && (hi - b).abs() < 1e-14,
        "{lo} {hi}"
    );
}

#[test]
fn a_range_away_from_the_cut_keeps_its_zero() {
    // −170 … 10 (dm hopper's hip): 0.17 rad from the cut, as before (same bits).
    let (s, model) = scene("-170 10", "");
    let (q, _) = s.world.joint_coordinates(0).expect("coordinates");
    assert_eq!(q[0], 0.0);
    let [lo, hi] = s.world.limits()[0][0].expect("limit");
    assert_eq!(
        (lo, hi),
        (model.joints[0].range[0], model.joints[0].range[1])
    );
}

#[test]
fn a_hinge_driven_into_its_bound_at_minus_pi_stays_there() {
    // From −170° at −20 rad/s into the bound −180° = −π, held there 0.2 s.
    let (mut s, model) = scene("-180 0", "");
    s.set_generalized(&model, &[-170f64.to_radians()], &[-20.0])
        .expect("state");
    // The arm's angle from its pose, unwrapped step to step (MuJoCo's coordinate).
    let mut angle = physical_angle(&s);
    let (mut lowest, mut highest, mut largest_turn) = (angle, angle, 0.0f64);
    for _ in 0..200 {
        s.world.step(1e-3, Method::default()).expect("step");
        let turn = (physical_angle(&s) - angle + PI).rem_euclid(2.0 * PI) - PI;
        angle += turn;
        largest_turn = largest_turn.max(turn.abs());
        lowest = lowest.min(angle);
        highest = highest.max(angle);
    }
    println!(
        "angle over the run: {lowest:.12} … {highest:.12}, largest turn in a step {largest_turn:.3e}"
    );
    // Reaches the bound and never leaves the range: gate 1e-6 rad past −π (the
    // unilateral projection floor is 1e-8), measured 0. Before the fix the angle read
    // +π past the bound and the projection turned the arm half a turn to the upper
    // bound 0 in one step.
    assert!(lowest > -PI - 1e-6, "{lowest}");
    assert!(lowest < -PI + 1e-3, "never reached the bound: {lowest}");
    assert!(highest < -170f64.to_radians() + 1e-9, "{highest}");
    // About the speed times the step (20 rad/s · 1 ms): gate 0.025 rad, measured
    // 1.96e-2 (a half turn before the fix).
    assert!(largest_turn < 0.025, "{largest_turn}");
    // The coordinate agrees with the pose: ours plus the effective reference −π/2.
    let q = s.world.joint_coordinates(0).expect("coordinates").0[0] - FRAC_PI_2;
    // Gate 1e-6 rad, measured below 1e-9 (the joints' projection tolerance).
    assert!((q - angle).abs() < 1e-6, "coordinate {q} pose {angle}");
}

#[test]
fn a_position_servo_on_a_moved_hinge_aims_at_mujocos_coordinate() {
    // kp = 20 towards ctrl = −2.5 rad (MuJoCo's coordinate) on a hinge measured from
    // −π/2: the bias carries the effective reference, so the arm settles at −2.5.
    let (mut s, _) = scene("-180 0", r#"<position joint="j" kp="20"/>"#);
    s.world.set_ctrl(0, -2.5).expect("ctrl");
    for _ in 0..3000 {
        s.world.step(1e-3, Method::default()).expect("step");
    }
    // Gate 1e-3 rad after 3 s (the damped servo's time constant is about 0.05 s),
    // measured below 1e-9.
    let p = physical_angle(&s);
    println!("servo angle {p:.12}");
    assert!((p + 2.5).abs() < 1e-3, "{p}");
}
