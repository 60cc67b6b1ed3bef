//! One world: joints, joint limits and contacts solved together (feature `contact`).
//! Every tolerance carries the value measured when it was set.

use constraint_articulated::scenes::chain_on_floor;
use constraint_articulated::{Joint, JointKind, Method, RigidBody, RowSource, World};
use constraint_contact::geometry::{Collider, Shape};
use constraint_core::{DMat3, DQuat, DVec3, Hinge, Pose, Prismatic};

const VELOCITY: Method = Method::Velocity { beta: 1.0 };
const PROJECTED: Method = Method::VelocityProjected {
    beta: 1.0,
    tolerance: 1e-10,
    max_iterations: 20,
    correct_velocity: false,
};

/// A 1 kg bob on a massless-looking rod: a hinge about `y` through the origin, the bob
/// 1 m below, with angular velocity `w0` about `y`.
fn pendulum(w0: f64) -> World {
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let pose = Pose {
        x: DVec3::new(0.0, 0.0, -1.0),
        q: DQuat::IDENTITY,
    };
    // Rigid rotation about the hinge: v = ω × r with r from the pivot to the bob.
    let body = RigidBody::new(0, 1.0, DMat3::IDENTITY * 1e-3, pose)
        .unwrap()
        .with_velocity(
            DVec3::new(0.0, w0, 0.0).cross(DVec3::new(0.0, 0.0, -1.0)),
            DVec3::new(0.0, w0, 0.0),
        );
    w.add_body(body).unwrap();
    let hinge = Hinge::from_world(&Pose::IDENTITY, &pose, DVec3::ZERO, DVec3::Y).unwrap();
    w.add_joint(Joint {
        parent: None,
        child: 0,
        kind: JointKind::Hinge(hinge),
        damping: 0.0,
    })
    .unwrap();
    w
}

/// A hinge pendulum thrown at 6 rad/s against limits at ±0.5 rad: the angle never
/// leaves the range by more than the solver tolerance, the limit impulse is one-sided,
/// each impact step loses energy (inelastic), and after the first impact the pendulum
/// swings between the stops with at most the energy of a bob at rest at a stop.
#[test]
fn hinge_limit_hit_at_speed() {
    for method in [VELOCITY, PROJECTED] {
        let mut w = pendulum(6.0);
        w.set_limit(0, -0.5, 0.5).unwrap();
        let h = 1e-3;
        let total = |w: &World| w.energy().0 + w.energy().1;
        let mut worst_excess: f64 = 0.0;
        let mut worst_impact_gain = f64::NEG_INFINITY;
        let mut hits = 0;
        let mut after_first_hit = f64::NEG_INFINITY;
        let mut first_hit = None;
        for step in 0..5000 {
            let e_before = total(&w);
            w.step(h, method).unwrap();
            let q = w.joint_position(0).unwrap();
            worst_excess = worst_excess.max(q.abs() - 0.5);
            let mut pushed = false;
            for (src, z) in w.row_impulses() {
                assert!(matches!(src, RowSource::Limit { joint: 0, .. }));
                // Measured: the smallest impulse is −1e-17 (round-off of z ≥ 0).
                assert!(z >= -1e-12, "limit impulse {z} < 0");
                pushed |= z > 1e-6;
            }
            if pushed {
                hits += 1;
                worst_impact_gain = worst_impact_gain.max(total(&w) - e_before);
                first_hit.get_or_insert(step);
            }
            // A speculative row lets the bob arrive at the stop with the speed that
            // closes the gap in the step; the next step's row stops it. Count from then.
            if first_hit.is_some_and(|f| step > f + 1) {
                after_first_hit = after_first_hit.max(total(&w));
            }
        }
        // Energy of the bob at rest at a stop, potential zero at the pivot.
        let at_stop = -9.81 * 0.5f64.cos();
        println!(
            "{method:?}: worst excess {worst_excess:.2e} rad, {hits} impact steps, worst energy change on one {worst_impact_gain:.2e} J, energy after the first impact ≤ {after_first_hit:.6} J (at a stop {at_stop:.6} J)"
        );
        // Measured (velocity and projected): excess ≤ 3e-14 rad (the speculative row
        // lands on the limit); every impact step loses ≥ 1e-3 J.
        assert!(worst_excess < 1e-9, "limit exceeded by {worst_excess}");
        assert!(hits > 0, "the limit never acted");
        assert!(
            worst_impact_gain < 0.0,
            "an impact gained {worst_impact_gain} J"
        );
        // Measured: at most 2e-3 J above the bob at rest at a stop (the velocity level's
        // symplectic-Euler energy oscillation).
        assert!(
            after_first_hit < at_stop + 1e-2,
            "{after_first_hit} vs {at_stop}"
        );
    }
}

/// A box on a horizontal slider pushed into its stops: the displacement stays within
/// `[−0.2, 0.3]`.
#[test]
fn prismatic_limits_hold() {
    let mut w = World::new(DVec3::ZERO);
    let pose = Pose::IDENTITY;
    let body = RigidBody::new(0, 2.0, DMat3::IDENTITY, pose)
        .unwrap()
        .with_velocity(DVec3::new(1.5, 0.0, 0.0), DVec3::ZERO);
    w.add_body(body).unwrap();
    let slider = Prismatic::from_world(&Pose::IDENTITY, &pose, DVec3::ZERO, DVec3::X).unwrap();
    w.add_joint(Joint {
        parent: None,
        child: 0,
        kind: JointKind::Prismatic(slider),
        damping: 0.0,
    })
    .unwrap();
    w.set_limit(0, -0.2, 0.3).unwrap();
    let mut lo: f64 = 0.0;
    let mut hi: f64 = 0.0;
    for _ in 0..2000 {
        w.step(1e-3, VELOCITY).unwrap();
        let q = w.joint_position(0).unwrap();
        lo = lo.min(q);
        hi = hi.max(q);
    }
    println!("slider range reached [{lo:.12}, {hi:.12}]");
    // Measured: hi = 0.3 to 1e-16; the inelastic stop leaves the box at the upper stop.
    assert!(hi <= 0.3 + 1e-9 && lo >= -0.2 - 1e-9, "[{lo}, {hi}]");
    assert!((hi - 0.3).abs() < 1e-6, "never reached the stop: {hi}");
}

/// Limits are validated: kinds, order, NaN.
#[test]
fn limits_reject_bad_input() {
    let mut w = pendulum(0.0);
    assert!(w.set_limit(0, 0.5, -0.5).is_err());
    assert!(w.set_limit(0, f64::NAN, 0.5).is_err());
    assert!(w.set_limit(3, -0.5, 0.5).is_err());
    assert!(w.set_limit(0, f64::NEG_INFINITY, 0.5).is_ok());
}

/// A 10-link chain dropped 5 cm onto the floor: after 2 s it lies on it (penetration
/// within the slop plus the Baumgarte residue, every link at rest), with its ball joints
/// at the projection tolerance, and the complementarity problem solved to its tolerance
/// at every step.
#[test]
fn chain_falls_onto_the_floor() {
    let mut w = chain_on_floor(10, 0.06, 0.5).unwrap();
    let h = 1e-3;
    let (k0, p0) = w.energy();
    let mut worst_residual: f64 = 0.0;
    let mut worst_sep: f64 = 0.0;
    let mut first_contact = None;
    for step in 0..2000 {
        w.step(h, PROJECTED).unwrap();
        let s = w.unilateral_stats();
        worst_residual = worst_residual.max(s.residual);
        worst_sep = worst_sep.max(w.max_separation());
        if first_contact.is_none() && s.contacts > 0 {
            first_contact = Some(step);
        }
    }
    let (k1, p1) = w.energy();
    let lowest = w
        .bodies()
        .iter()
        .map(|b| b.pose.x.z)
        .fold(f64::INFINITY, f64::min);
    let highest = w
        .bodies()
        .iter()
        .map(|b| b.pose.x.z)
        .fold(f64::NEG_INFINITY, f64::max);
    let s = w.unilateral_stats();
    println!(
        "chain: first contact row at step {first_contact:?}, residual ≤ {worst_residual:.1e}, joints ≤ {worst_sep:.1e} m, link axes z ∈ [{lowest:.6}, {highest:.6}], penetration {:.1e} m, energy {:.5} -> {:.5} J (kinetic {k1:.1e})",
        s.max_penetration,
        k0 + p0,
        k1 + p1
    );
    // Measured: residual ≤ 1e-11; joints ≤ 1e-10 m (the projection tolerance).
    assert!(worst_residual < 1e-8, "LCP residual {worst_residual}");
    assert!(worst_sep < 1e-9, "joint separation {worst_sep}");
    // Resting on the floor: link axes at the radius 0.01 m within 1 mm.
    // Measured: z ∈ [0.00990, 0.01000], penetration 1.0e-4 m (the slop).
    assert!((lowest - 0.01).abs() < 1e-3 && (highest - 0.01).abs() < 1e-3);
    assert!(
        s.max_penetration < 1e-3,
        "penetration {}",
        s.max_penetration
    );
    // Inelastic impact: energy lost; at rest after 2 s (measured kinetic 1e-9 J).
    assert!(k1 + p1 < k0 + p0, "energy grew");
    assert!(k1 < 1e-5, "still moving: {k1}");
}

/// A box on the floor at rest stays at rest with its weight carried by the contacts
/// (the normal impulses sum to `m g h`), and friction holds it on a 20° slope with
/// `μ = 0.5 > tan 20°`.
#[test]
fn box_rests_and_friction_holds_on_a_slope() {
    let slope = 20f64.to_radians();
    let n = DVec3::new(-slope.sin(), 0.0, slope.cos());
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    w.add_collider(
        Collider::new(
            None,
            Shape::plane(n, 0.0).unwrap(),
            Pose::IDENTITY,
            0.5,
            0.0,
        )
        .unwrap(),
    )
    .unwrap();
    let q = DQuat::from_rotation_y(-slope);
    let half = DVec3::splat(0.1);
    let pose = Pose { x: n * 0.1, q };
    let m = 1.0;
    let i = m * (0.2f64 * 0.2 + 0.2 * 0.2) / 12.0;
    let b = w
        .add_body(RigidBody::new(0, m, DMat3::IDENTITY * i, pose).unwrap())
        .unwrap();
    w.add_collider(Collider::simple(Some(b), Shape::cuboid(half).unwrap()).unwrap())
        .unwrap();
    let h = 1e-3;
    for _ in 0..1000 {
        w.step(h, VELOCITY).unwrap();
    }
    let x = w.bodies()[0].pose.x;
    let drift = (x - n * 0.1).length();
    let normal: f64 = w
        .row_impulses()
        .filter(|(s, _)| matches!(s, RowSource::Contact { axis: 0, .. }))
        .map(|(_, z)| z)
        .sum();
    let weight_n = m * 9.81 * slope.cos() * h;
    println!(
        "box on slope: drift {drift:.2e} m, normal impulse {normal:.6e} vs m g cos θ h {weight_n:.6e}"
    );
    // Measured: drift 1.0e-4 m (the slop the box sinks into), impulse equal to 1e-9.
    assert!(drift < 5e-4, "slid or sank: {drift}");
    assert!((normal - weight_n).abs() < 1e-6 * weight_n.max(1e-3) + 1e-9);
}

/// RATTLE on a step with one-sided rows is taken at the velocity level with projection
/// (counted), and without rows it is RATTLE, unchanged.
#[test]
fn rattle_with_unilateral_rows_is_a_projected_velocity_step() {
    let mut w = pendulum(6.0);
    w.set_limit(0, -0.5, 0.5).unwrap();
    let rattle = Method::default();
    let mut fallbacks = 0;
    let mut worst_excess: f64 = 0.0;
    for _ in 0..2000 {
        let s = w.step(1e-3, rattle).unwrap();
        fallbacks += s.unilateral_fallbacks;
        worst_excess = worst_excess.max(w.joint_position(0).unwrap().abs() - 0.5);
    }
    println!("rattle: {fallbacks} velocity-level steps of 2000, excess {worst_excess:.1e}");
    assert!(fallbacks > 0 && fallbacks < 2000);
    assert!(worst_excess < 1e-9);
    // No limit: identical to a world that never had one.
    let mut a = pendulum(2.0);
    let mut b = pendulum(2.0);
    b.set_limit(0, -3.0, 3.0).unwrap();
    b.clear_limit(0);
    for _ in 0..500 {
        assert_eq!(a.step(1e-3, rattle).unwrap().unilateral_fallbacks, 0);
        b.step(1e-3, rattle).unwrap();
    }
    assert_eq!(a.bodies(), b.bodies());
}

/// `scenes/ragdoll.xml` (issue 12): a free torso with limited two-hinge shoulders and
/// hips and limited elbows and knees, capsules, dropped tilted onto the floor. Over 3 s
/// at the file's step, under the velocity level and the projected velocity level:
/// every step succeeds and stays finite; with projection the joints hold to the
/// projection tolerance, and so do the limits (the velocity level's to a few slops);
/// after settling nothing
/// penetrates the floor beyond the slop; the ragdoll comes to rest lying on the floor
/// (torso axis at its radius, 0.1 m, as in MuJoCo); and the total energy never grows
/// from one step to the next beyond round-off (inelastic impacts, damped joints).
#[test]
fn ragdoll_lands_and_comes_to_rest() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/ragdoll.xml");
    for (name, method) in [("velocity", VELOCITY), ("projected", PROJECTED)] {
        let scene = constraint_articulated::MjcfScene::from_file(&path, Some("start")).unwrap();
        let mut w = scene.world;
        let h = scene.timestep;
        let total = |w: &World| w.energy().0 + w.energy().1;
        let e0 = total(&w);
        let (mut worst_sep, mut worst_limit, mut worst_gain, mut settled_pen) =
            (0.0f64, 0.0f64, f64::NEG_INFINITY, 0.0f64);
        let mut first_contact = None;
        let steps = (3.0 / h).round() as usize;
        for step in 0..steps {
            let before = total(&w);
            w.step(h, method).unwrap();
            worst_gain = worst_gain.max(total(&w) - before);
            worst_sep = worst_sep.max(w.max_separation());
            for (j, lim) in w.limits().iter().enumerate() {
                let Some((q, n)) = w.joint_coordinates(j) else {
                    continue;
                };
                for d in 0..n {
                    if let Some([lo, hi]) = lim[d] {
                        worst_limit = worst_limit.max(lo - q[d]).max(q[d] - hi);
                    }
                }
            }
            let s = w.unilateral_stats();
            if first_contact.is_none() && s.contacts > 0 {
                first_contact = Some(step);
            }
            if (step as f64) * h > 2.0 {
                settled_pen = settled_pen.max(s.max_penetration);
            }
        }
        let (k1, _) = w.energy();
        let torso_z = w.bodies()[0].pose.x.z;
        println!(
            "ragdoll {name}: first contact row at step {first_contact:?}, joints ≤ {worst_sep:.1e} m, limits exceeded by ≤ {worst_limit:.1e} rad, penetration after 2 s ≤ {settled_pen:.1e} m, worst energy gain per step {worst_gain:.1e} J, energy {e0:.3} -> {:.3} J, kinetic at 3 s {k1:.1e} J, torso at z = {torso_z:.4} m",
            total(&w)
        );
        // Measured (velocity / projected): first contact row at step 125 / 125.
        assert!(first_contact.is_some_and(|s| s < 200), "never landed");
        // Measured: joints 2.5e-4 / 9.9e-11 m.
        let joint_tol = if name == "projected" { 1e-9 } else { 1e-3 };
        assert!(worst_sep < joint_tol, "joint separation {worst_sep}");
        // Measured: 3.7e-4 / 9.3e-11 rad (slop 1e-4). The velocity level's excess is the
        // drift of the linearised row over a step; the projection takes violated limits
        // as equalities at their bound (before it did not, and a shoulder loaded
        // against its stop went 3.9e-3 rad past it while the ragdoll lay on that arm).
        let limit_tol = if name == "projected" { 1e-9 } else { 5e-4 };
        assert!(worst_limit <= limit_tol, "limit exceeded by {worst_limit}");
        // Measured: 2.1e-6 / 1.5e-5 m (slop 1e-4).
        assert!(settled_pen <= 1e-4, "penetration {settled_pen}");
        // Measured: kinetic 9.4e-14 / 3.7e-14 J at 3 s.
        assert!(k1 < 1e-6, "still moving: {k1} J");
        // Measured: worst gain 2.2e-8 / 2.4e-8 J per step (e0 = 478 J). With two fixed
        // staggered sweeps the landing left a residual of 1.6 and gained 11 J in a step.
        assert!(
            worst_gain < 1e-9 * e0,
            "energy grew by {worst_gain} J in one step"
        );
        // Measured: 0.1000 / 0.1000 m.
        assert!((torso_z - 0.1).abs() < 2e-3, "torso at {torso_z}");
    }
}

/// `option/flag constraint="disable"` (dm_control's acrobot, fish, lqr) leaves out every
/// constraint kind MuJoCo leaves out: joint limits, dry friction, contacts; `limit` and
/// `frictionloss` one kind each. A pendulum with dry friction thrown past its limit, and
/// a ball dropped on the floor: with the flags the rows are not there.
#[test]
fn constraint_flags_leave_rows_out() {
    let xml = |flag: &str| {
        format!(
            r#"<mujoco>
  <option timestep="0.001">{flag}</option>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body name="arm" pos="0 0 1">
      <joint name="j" type="hinge" axis="0 1 0" range="-30 30" frictionloss="0.01"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.02"/>
    </body>
    <body name="ball" pos="1 0 0.1">
      <freejoint/>
      <geom type="sphere" size="0.05"/>
    </body>
  </worldbody>
  <keyframe><key name="start" qpos="0  1 0 0.1 1 0 0 0" qvel="8  0 0 0 0 0 0"/></keyframe>
</mujoco>"#
        )
    };
    let run = |flag: &str| {
        let model = constraint_mjcf::load_str(&xml(flag)).unwrap();
        let mut w = constraint_articulated::MjcfScene::new(&model, Some("start"))
            .unwrap()
            .world;
        let (mut limit_rows, mut contacts, mut dry) = (0, 0, 0);
        for _ in 0..400 {
            w.step(1e-3, VELOCITY).unwrap();
            let s = w.unilateral_stats();
            limit_rows = limit_rows.max(s.limit_rows);
            contacts = contacts.max(s.contacts);
            dry = dry.max(
                w.row_impulses()
                    .filter(|(r, _)| matches!(r, RowSource::DryFriction { .. }))
                    .count(),
            );
        }
        (limit_rows, contacts, dry)
    };
    // Measured: (2, 1, 1) with every kind on: the limit rows, the floor, dry friction.
    let all = run("");
    assert!(all.0 > 0 && all.1 > 0 && all.2 > 0, "{all:?}");
    assert_eq!(run(r#"<flag constraint="disable"/>"#), (0, 0, 0));
    let no_limit = run(r#"<flag limit="disable"/>"#);
    assert!(no_limit.0 == 0 && no_limit.2 > 0, "{no_limit:?}");
    let no_dry = run(r#"<flag frictionloss="disable"/>"#);
    assert!(no_dry.0 > 0 && no_dry.2 == 0, "{no_dry:?}");
}

/// A hinge started 0.5 rad outside its limit (gymnasium's ant starts with its ankles
/// 30° outside their range) comes back at no more than
/// `UnilateralSettings::max_correction` (1 rad/s): no kick of kinetic energy, and inside
/// the range within about 0.5 s. Gravity off, so only the correction moves it.
#[test]
fn violated_limit_comes_back_at_the_capped_rate() {
    let mut w = pendulum(0.0);
    w.gravity = DVec3::ZERO;
    w.set_limit(0, 0.5, 1.0).unwrap();
    let h = 1e-2;
    let mut fastest: f64 = 0.0;
    let mut inside_at = None;
    for step in 0..100 {
        w.step(h, VELOCITY).unwrap();
        fastest = fastest.max(w.bodies()[0].omega.length());
        let q = w.joint_position(0).unwrap();
        if inside_at.is_none() && q >= 0.5 - w.unilateral.slop {
            inside_at = Some(step);
        }
    }
    println!("violated limit: fastest {fastest:.3} rad/s, back inside at step {inside_at:?}");
    // Measured: 1.000 rad/s (uncapped, β·0.5/h = 10 rad/s in the first step).
    assert!(fastest <= 1.0 + 1e-9, "corrected at {fastest} rad/s");
    // Measured: step 49 (0.5 rad at 1 rad/s).
    assert!(
        inside_at.is_some_and(|s| s < 60),
        "not back inside: {inside_at:?}"
    );
}

/// RATTLE's unilateral fallback projects to `max(tolerance, unilateral_tolerance)`: the
/// pendulum thrown at 6 rad/s between limits at ±0.5 rad (a limit row on many steps)
/// keeps its hinge within each floor after every step, and a looser floor costs no more
/// projection iterations.
#[test]
fn unilateral_tolerance_sets_the_fallback_projection() {
    let run = |floor: f64| {
        let mut w = pendulum(6.0);
        w.set_limit(0, -0.5, 0.5).unwrap();
        w.set_unilateral_tolerance(floor).unwrap();
        assert_eq!(w.unilateral_tolerance(), floor);
        let (mut fallbacks, mut iterations) = (0, 0);
        let mut worst_sep: f64 = 0.0;
        for _ in 0..2000 {
            let s = w.step(1e-3, Method::default()).unwrap();
            fallbacks += s.unilateral_fallbacks;
            iterations += s.projection_iterations;
            worst_sep = worst_sep.max(w.max_separation());
        }
        println!("floor {floor:.0e}: {fallbacks} fallbacks, {iterations} iterations, sep {worst_sep:.2e}");
        (fallbacks, iterations, worst_sep)
    };
    let default_floor = World::new(DVec3::ZERO).unilateral_tolerance();
    assert_eq!(default_floor, World::DEFAULT_UNILATERAL_TOLERANCE);
    assert_eq!(default_floor, 1e-8);
    let tight = run(1e-12);
    let mid = run(default_floor);
    let loose = run(1e-7);
    // Measured: 285 one-sided steps of 2000 at each floor; projection iterations
    // 2079 / 1989 / 1800; worst separation 9.6e-13 / 9.9e-9 / 9.5e-8 m.
    for ((fallbacks, _, sep), floor) in [(tight, 1e-12), (mid, 1e-8), (loose, 1e-7)] {
        assert!(fallbacks > 0, "floor {floor}: no one-sided steps");
        assert!(sep <= floor, "floor {floor}: separation {sep}");
    }
    assert!(
        mid.1 <= tight.1 && loose.1 <= mid.1,
        "{tight:?} {mid:?} {loose:?}"
    );
}
