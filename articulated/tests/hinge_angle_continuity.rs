//! Hinge coordinates continuous across `±π` for hinges built through the World API
//! (issue 13). `atan2` reads a hinge's angle in `(−π, π]`; MuJoCo's coordinate is
//! unbounded. The world takes each angle on the branch nearest the joint's last one
//! (`world/projection/branch.rs`), so a limit at `−π`, a spring past `π` and a spinning
//! hinge see the angle the joint turned to. (`hinge_branch_cut.rs`: the MJCF loader's
//! re-centred ranges.)

use core::f64::consts::PI;

use constraint_articulated::{DofSpring, Joint, JointKind, Method, RigidBody, World};
use constraint_core::{Compound, DMat3, DQuat, DVec3, Hinge, Pose};

/// Distance of the arm's centre of mass from the hinge (m).
const ARM: f64 = 0.15;

/// One arm (1 kg, inertia 0.01 kg·m²) on a hinge about `y` at the origin, built at the
/// arm along `x` (angle 0), then turned to `angle` and spinning at `rate` (rad/s); no
/// gravity.
fn arm(angle: f64, rate: f64) -> World {
    let mut w = World::new(DVec3::ZERO);
    let built = Pose {
        x: DVec3::new(ARM, 0.0, 0.0),
        q: DQuat::IDENTITY,
    };
    let hinge = Hinge::from_world(&Pose::IDENTITY, &built, DVec3::ZERO, DVec3::Y).unwrap();
    let q = DQuat::from_axis_angle(DVec3::Y, angle);
    let pose = Pose { x: q * built.x, q };
    let omega = DVec3::new(0.0, rate, 0.0);
    let body = RigidBody::new(0, 1.0, DMat3::IDENTITY * 0.01, pose)
        .unwrap()
        .with_velocity(omega.cross(pose.x), omega);
    w.add_body(body).unwrap();
    w.add_joint(Joint {
        parent: None,
        child: 0,
        kind: JointKind::Hinge(hinge),
        damping: 0.0,
    })
    .unwrap();
    w
}

/// The arm's angle about `y` from its pose alone, in `(−π, π]` (positive turns `x`
/// towards `−z`, as the hinge's angle).
fn pose_angle(w: &World) -> f64 {
    let tip = w.bodies()[0].pose.q * DVec3::X;
    (-tip.z).atan2(tip.x)
}

/// The continuous angle `a` a pose's angle `θ` stands for near `near`.
fn near(theta: f64, near: f64) -> f64 {
    near + (theta - near + PI).rem_euclid(2.0 * PI) - PI
}

/// Steps `w` `n` times (1 ms), returning per step the joint's coordinate and the pose's
/// angle unwrapped step to step from `start` (the continuous angle the arm turned to).
fn run(w: &mut World, n: usize, start: f64) -> Vec<(f64, f64)> {
    let mut angle = near(pose_angle(w), start);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        w.step(1e-3, Method::default()).unwrap();
        angle = near(pose_angle(w), angle);
        out.push((w.joint_coordinates(0).unwrap().0[0], angle));
    }
    out
}

/// Largest `|coordinate − unwrapped pose angle|` over a run.
fn worst_gap(trace: &[(f64, f64)]) -> f64 {
    trace.iter().map(|(q, a)| (q - a).abs()).fold(0.0, f64::max)
}

#[test]
fn a_world_hinge_driven_into_its_bound_at_minus_pi_stays_there() {
    // Limited to [−π, 0], from −170° at −20 rad/s into the bound −π, and pressed on it
    // for 0.2 s by a spring towards −4 rad (0.86 N·m). Before the fix the angle read +π
    // a hair past the bound (3.1 rad past the upper one) and the projection turned the
    // arm half a turn in one step.
    let mut w = arm(-170f64.to_radians(), -20.0);
    w.set_limit(0, -PI, 0.0).unwrap();
    w.add_dof_spring(DofSpring {
        joint: 0,
        dof: 0,
        stiffness: 1.0,
        reference: -4.0,
    })
    .unwrap();
    let trace = run(&mut w, 200, -170f64.to_radians());
    let lowest = trace.iter().map(|t| t.0).fold(f64::INFINITY, f64::min);
    let highest = trace.iter().map(|t| t.0).fold(f64::NEG_INFINITY, f64::max);
    let turn = trace
        .windows(2)
        .map(|p| (p[1].1 - p[0].1).abs())
        .fold(0.0, f64::max);
    let gap = worst_gap(&trace);
    println!("coordinate {lowest:.12} … {highest:.12}, largest turn {turn:.3e}, gap {gap:.1e}");
    // Reaches −π and stays in range: gate 1e-6 rad past it (projection floor 1e-8),
    // measured 0 past it.
    assert!(lowest > -PI - 1e-6, "{lowest}");
    assert!(lowest < -PI + 1e-3, "never reached the bound: {lowest}");
    assert!(highest < -170f64.to_radians() + 1e-9, "{highest}");
    // About speed × step (20 rad/s · 1 ms): gate 0.025 rad, measured 2.02e-2.
    assert!(turn < 0.025, "{turn}");
    // The coordinate is the pose's continuous angle: gate 1e-9 rad, measured 0.
    assert!(gap < 1e-9, "{gap}");
}

#[test]
fn a_free_hinge_spins_through_several_turns_continuously() {
    // Unlimited, no force: 20 rad/s for 1 s is 20 rad, past ±π three times.
    let mut w = arm(0.0, 20.0);
    let trace = run(&mut w, 1000, 0.0);
    let (q, angle) = trace[trace.len() - 1];
    println!("after 1 s: coordinate {q:.15}, pose angle {angle:.15}");
    // Gate 1e-9 rad, measured 0 (the same atan2, shifted by whole turns).
    assert!(worst_gap(&trace) < 1e-9, "{}", worst_gap(&trace));
    // The rate is about kept (no force, no gravity): gate 2e-3 rad, measured 9.2e-4
    // (the projected steps' drift of the spin over 1 000 steps).
    assert!((q - 20.0).abs() < 2e-3, "{q}");
}

#[test]
fn a_spring_acts_on_the_unbounded_angle() {
    // k = 0.1 N·m/rad about q_ref = 0, arm inertia about the hinge I = 0.01 + 0.15² =
    // 0.0325 kg·m²: Ω = √(k/I), thrown at 4Ω rad/s it swings out to 4 rad (past π) and
    // back, q = 4 sin Ω t (MuJoCo's coordinate). With the angle cut at π the spring
    // pushed on past it instead (a full turn in this run).
    let inertia = 0.01 + ARM * ARM;
    let omega = (0.1f64 / inertia).sqrt();
    let mut w = arm(0.0, 4.0 * omega);
    w.add_dof_spring(DofSpring {
        joint: 0,
        dof: 0,
        stiffness: 0.1,
        reference: 0.0,
    })
    .unwrap();
    let trace = run(&mut w, 1500, 0.0);
    let peak = trace.iter().map(|t| t.1).fold(f64::NEG_INFINITY, f64::max);
    let harmonic = trace
        .iter()
        .enumerate()
        .map(|(i, t)| (t.0 - 4.0 * (omega * (i + 1) as f64 * 1e-3).sin()).abs())
        .fold(0.0, f64::max);
    let gap = worst_gap(&trace);
    println!("peak {peak:.6} rad, off 4 sin Ωt by {harmonic:.2e}, gap {gap:.1e}");
    // Gate 1e-9 rad, measured 8.9e-16.
    assert!(gap < 1e-9, "{gap}");
    // Turns back at 4 rad: gate 1e-3 rad (spring impulse per 1 ms step), measured
    // 6e-6 off.
    assert!((peak - 4.0).abs() < 1e-3, "{peak}");
    // Follows 4 sin Ωt over 1.5 s: gate 1e-3 rad, measured 1.4e-5.
    assert!(harmonic < 1e-3, "{harmonic}");
}

#[test]
fn a_world_hinge_a_hair_past_minus_pi_is_pushed_back_to_it() {
    // Limited to [−π, 0], started 1e-7 rad past −π (atan2 reads +π − 1e-7, 3.1 rad past
    // the upper bound) and pressing on at −1 rad/s. The first reading starts from the
    // middle of the range (−π/2), so the limit sees −π − 1e-7 and holds the arm at −π;
    // before the fix it turned the arm half a turn to 0 in the first step.
    let mut w = arm(-PI - 1e-7, -1.0);
    w.set_limit(0, -PI, 0.0).unwrap();
    let trace = run(&mut w, 50, -PI);
    let highest = trace.iter().map(|t| t.0).fold(f64::NEG_INFINITY, f64::max);
    let lowest = trace.iter().map(|t| t.0).fold(f64::INFINITY, f64::min);
    let gap = worst_gap(&trace);
    println!(
        "coordinate −π {:+.1e} … −π {:+.1e}, gap {gap:.1e}",
        lowest + PI,
        highest + PI
    );
    // Held at the bound: gate 1e-6 rad either side, measured 0 (−π to the bit).
    assert!(highest < -PI + 1e-6, "{highest}");
    assert!(lowest > -PI - 1e-6, "{lowest}");
    // The coordinate is the pose's angle (the unwrapped start −π − 1e-7): gate 1e-9
    // rad, measured 0.
    assert!(gap < 1e-9, "{gap}");
}

#[test]
fn a_compound_joints_hinge_spins_through_several_turns_continuously() {
    // Slides along x and z and a hinge about y (half_cheetah's root), unlimited, no
    // force: the body spins about its centre at 20 rad/s for 1 s, 20 rad.
    let mut w = World::new(DVec3::ZERO);
    let omega = DVec3::new(0.0, 20.0, 0.0);
    let body = RigidBody::new(0, 1.0, DMat3::IDENTITY * 0.01, Pose::IDENTITY)
        .unwrap()
        .with_velocity(DVec3::ZERO, omega);
    w.add_body(body).unwrap();
    let c = Compound::from_world(
        &Pose::IDENTITY,
        &Pose::IDENTITY,
        DVec3::ZERO,
        &[DVec3::X, DVec3::Z],
        &[DVec3::Y],
    )
    .unwrap();
    w.add_joint(Joint {
        parent: None,
        child: 0,
        kind: JointKind::Compound(c, [0.0; 6]),
        damping: 0.0,
    })
    .unwrap();
    let mut angle = 0.0;
    let mut gap: f64 = 0.0;
    for _ in 0..1000 {
        w.step(1e-3, Method::default()).unwrap();
        angle = near(pose_angle(&w), angle);
        let (q, n) = w.joint_coordinates(0).unwrap();
        assert_eq!(n, 3);
        gap = gap.max((q[2] - angle).abs());
    }
    let q = w.joint_coordinates(0).unwrap().0[2];
    println!("after 1 s: hinge coordinate {q:.15}, pose angle {angle:.15}, gap {gap:.1e}");
    // The coordinate is the pose's continuous angle: gate 1e-9 rad, measured 3.6e-15.
    assert!(gap < 1e-9, "{gap}");
    // Gate 1e-6 rad, measured below 1e-14 (a free spin about a
    // principal axis).
    assert!((q - 20.0).abs() < 1e-6, "{q}");
}
