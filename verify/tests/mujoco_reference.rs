//! Trajectories of the scenes in `scenes/` against the committed MuJoCo RK4 exports
//! (`scenes/reference/`, see its README): issue 4's "trajectories match the committed
//! MuJoCo RK4 exports within tolerances stated in the tests". No Python needed.
//!
//! Each scene runs from its `start` keyframe over 1 s with the default method (velocity
//! level) at `dt = 1e-3` and `dt = 2.5e-4`; the error is the largest centre-of-mass
//! distance to MuJoCo RK4 (at a far smaller step) over the reference's samples. The
//! gate is about 1.5× the measured error, and the ratio between the two steps must show
//! first order (`4×` ideally, gate `≥ 3.5`).

use std::path::PathBuf;

use constraint_scene::run::{run, RunOptions};
use constraint_scene::trajectory::{compare, Comparison, Trajectory};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn against_reference(scene: &str, method: &str, dt: f64, duration: f64) -> Comparison {
    let path = root().join(format!("scenes/reference/{scene}.csv"));
    let reference =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reference = Trajectory::parse(&reference).unwrap();
    let every = ((reference.rows[1][0] - reference.rows[0][0]) / dt).round() as usize;
    let opts = RunOptions {
        keyframe: Some("start".into()),
        dt: Some(dt),
        duration,
        every: every.max(1),
        method: method.into(),
        ..RunOptions::default()
    };
    let (traj, _) = run(&root().join(format!("scenes/{scene}.xml")), &opts).unwrap();
    let c = compare(&traj, &reference).unwrap();
    println!(
        "{scene} {method} dt={dt:e}: COM err {:.3e} m (t={:.2}, {}), angle {:.3e} rad, {} samples",
        c.com.0, c.com.1, c.com.2, c.angle.0, c.samples
    );
    c
}

/// `(scene, measured COM error at dt = 1e-3 over 1 s)`. Measured ratios for the 4×
/// smaller step: 3.95 (chain20) … 4.00.
fn check(scene: &str, measured: f64) {
    let coarse = against_reference(scene, "velocity", 1e-3, 1.0);
    let fine = against_reference(scene, "velocity", 2.5e-4, 1.0);
    assert!(
        coarse.samples >= 10,
        "{scene}: only {} samples",
        coarse.samples
    );
    assert!(
        coarse.com.0 <= 1.5 * measured,
        "{scene}: {:e} > 1.5 × {measured:e}",
        coarse.com.0
    );
    let order = coarse.com.0 / fine.com.0;
    println!("{scene}: ratio {order:.2} for a 4× smaller step");
    assert!(
        order >= 3.5,
        "{scene}: error ratio {order} (first order gives 4)"
    );
}

#[test]
fn pendulum_matches_mujoco_rk4() {
    check("pendulum", 1.50e-3);
}

#[test]
fn double_pendulum_matches_mujoco_rk4() {
    check("double_pendulum", 5.89e-4);
}

#[test]
fn spherical_pendulum_matches_mujoco_rk4() {
    check("spherical_pendulum", 6.90e-4);
}

#[test]
fn chain20_matches_mujoco_rk4() {
    check("chain20", 5.45e-3);
}

#[test]
fn chain20_heavy_tip_matches_mujoco_rk4() {
    // 2.89e-3 without geometric stiffness; the default `Auto` switches it on near the
    // heavy tip at this step (5.73e-3), not at 2.5e-4.
    check("chain20_heavy", 5.73e-3);
}

#[test]
fn four_bar_loop_matches_mujoco_rk4() {
    check("four_bar", 2.59e-4);
}

#[test]
fn chain100_matches_mujoco_rk4() {
    check("chain100", 6.14e-3);
}

/// RATTLE is second order and its Yoshida composition fourth order: the error ratio
/// between `dt = 2e-3` and `1e-3` is about 4 and 16 (measured below), and at
/// `dt = 1e-3` they beat the velocity level by one and three orders of magnitude.
#[test]
fn rattle_orders_against_mujoco_rk4() {
    // (scene, measured rattle error at 1e-3, measured rattle4 error at 1e-3)
    for (scene, r2, r4) in [
        ("pendulum", 1.92e-6, 6.02e-11),
        ("double_pendulum", 4.84e-7, 5.03e-11),
        ("spherical_pendulum", 1.08e-6, 2.48e-11),
        ("four_bar", 1.86e-6, 1.19e-10),
        ("chain20", 1.19e-4, 3.47e-6),
    ] {
        for (method, measured, order) in [("rattle", r2, 4.0), ("rattle4", r4, 16.0)] {
            let fine = against_reference(scene, method, 1e-3, 1.0).com.0;
            let coarse = against_reference(scene, method, 2e-3, 1.0).com.0;
            let ratio = coarse / fine;
            println!("{scene} {method}: {fine:.3e} m at 1e-3, ratio {ratio:.1} for a 2x step (order {order})");
            // Errors at or below 1e-9 m are near the reference's own accuracy (its RK4
            // self-convergence is 1e-14..8e-13 m, but the 10 ms samples carry 17 digits
            // of a 1e-5 step): the ratio is only checked above that.
            assert!(
                fine <= 1.5 * measured,
                "{scene} {method}: {fine:e} > 1.5 × {measured:e}"
            );
            if fine > 1e-9 {
                assert!(
                    ratio > 0.75 * order,
                    "{scene} {method}: ratio {ratio}, expected about {order}"
                );
            }
        }
    }
}

/// Issue 12's scenes of their own: a planar root (slide x, slide z, hinge y composed in
/// one body) with a hinged leg carrying damping, armature and a joint spring; two hinges
/// at one point (universal joint) with damping and armature; a motor-driven slider and a
/// hinge held by position and velocity actuators. The velocity level is first order
/// like MuJoCo's Euler (its error at `dt = 1e-3` is within a few per cent of Euler's)
/// and RATTLE below MuJoCo Euler's error at the same step, second order: halving the
/// step divides its error by at least 3.5 (velocity-dependent forces — velocity
/// actuators, fluid drag — are in RATTLE's damping flow, see `world/rattle.rs`).
/// `(scene, velocity-level COM error at dt = 1e-3 over 1 s, MuJoCo Euler's over 2 s
/// from scenes/reference/README.md, RATTLE's over 2 s)`.
fn check_new(scene: &str, velocity_1s: f64, euler_2s: f64, rattle_2s: f64) {
    check(scene, velocity_1s);
    let r = against_reference(scene, "rattle", 1e-3, 2.0);
    println!(
        "{scene}: RATTLE {:.3e} m vs MuJoCo Euler {euler_2s:.3e} m",
        r.com.0
    );
    assert!(r.com.0 <= 1.5 * rattle_2s, "{scene}: RATTLE {:e}", r.com.0);
    assert!(r.com.0 < euler_2s, "{scene}: RATTLE not below MuJoCo Euler");
    let half = against_reference(scene, "rattle", 5e-4, 2.0).com.0;
    // Measured ratios: planar_leg 4.00, two_hinge_pendulum 3.74, actuated 4.00,
    // fluid_drag 4.01.
    assert!(
        r.com.0 / half >= 3.5,
        "{scene}: RATTLE error ratio {} for a 2x smaller step",
        r.com.0 / half
    );
}

#[test]
fn planar_root_with_leg_matches_mujoco_rk4() {
    // Measured: RATTLE 6.95e-7 m over 2 s (1.74e-7 at dt = 5e-4: second order with
    // damping split off and armature carried like the angular momenta), Euler 8.57e-3.
    check_new("planar_leg", VEL_PLANAR, 8.57e-3, 6.95e-7);
}

#[test]
fn two_hinges_at_one_point_match_mujoco_rk4() {
    // Measured: RATTLE 2.68e-6 m over 2 s (7.17e-7 at dt = 5e-4), Euler 1.04e-3.
    check_new("two_hinge_pendulum", VEL_TWO_HINGE, 1.04e-3, 2.68e-6);
}

#[test]
fn actuators_match_mujoco_rk4() {
    // Measured: RATTLE 2.42e-6 m over 2 s (6.05e-7 at dt = 5e-4), Euler 1.12e-3; RATTLE4
    // 7.94e-7 (1.99e-7: second order, the velocity actuator's split-off flow). Before the
    // velocity actuator moved out of the kicks RATTLE erred 2.13e-4 m, first order.
    check_new("actuated", VEL_ACTUATED, 1.12e-3, 2.42e-6);
}

// Velocity level at dt = 1e-3 over 1 s, measured; the 4× smaller step gives 4.00× less
// error on all three (first order, converging to MuJoCo RK4's trajectory).
const VEL_PLANAR: f64 = 4.59e-3;
const VEL_TWO_HINGE: f64 = 9.80e-4;
const VEL_ACTUATED: f64 = 1.115e-3;

#[test]
fn fluid_drag_matches_mujoco_rk4() {
    // MuJoCo's inertia-box fluid model on a free box with wind. Measured over 2 s at
    // dt = 1e-3: RATTLE 4.65e-7 m (1.16e-7 at dt = 5e-4), RATTLE4 4.39e-7, velocity level
    // 2.39e-3, MuJoCo Euler 2.43e-3. With the drag explicit in the kicks RATTLE erred
    // 6.11e-4 m, first order.
    check_new("fluid_drag", VEL_FLUID, 2.43e-3, 4.65e-7);
}

// Measured 1.873e-3 m over 1 s; ratio 4.00 for a 4× smaller step.
const VEL_FLUID: f64 = 1.873e-3;

/// One control sequence replayed in both engines: `scenes/actuated_ctrl.csv` drives the
/// motor, servo and velocity actuator of `scenes/actuated.xml` from an initial state
/// given in MuJoCo's generalized coordinates (`--qpos`, `--qvel`), against MuJoCo RK4 fed
/// the same file. Measured over 2 s at dt = 1e-3: velocity level 2.19e-3 m (MuJoCo Euler
/// 2.20e-3), RATTLE 6.68e-6 m (4.81e-4 with the velocity actuator in its kicks).
#[test]
fn control_file_and_initial_state_replay_in_both_engines() {
    let path = root().join("scenes/reference/actuated_ctrl.csv");
    let reference = Trajectory::parse(&std::fs::read_to_string(path).unwrap()).unwrap();
    for (method, measured) in [("velocity", 2.19e-3), ("rattle", 6.68e-6)] {
        let opts = RunOptions {
            dt: Some(1e-3),
            duration: 2.0,
            every: 10,
            method: method.into(),
            qpos: Some(vec![0.1, 0.5]),
            qvel: Some(vec![0.2, -1.0]),
            ctrl: Some(root().join("scenes/actuated_ctrl.csv")),
            ..RunOptions::default()
        };
        let (traj, _) = run(&root().join("scenes/actuated.xml"), &opts).unwrap();
        let c = compare(&traj, &reference).unwrap();
        println!("actuated_ctrl {method}: {:.3e} m", c.com.0);
        assert!(c.com.0 <= 1.5 * measured, "{method}: {:e}", c.com.0);
    }
}

/// The control file's errors name the problem.
#[test]
fn control_files_are_checked() {
    use constraint_scene::run::Controls;
    let names = vec!["push".to_string(), "servo".to_string()];
    let ok = Controls::parse("t,servo,push\n0,1,2\n0.5,3,4\n", &names).unwrap();
    assert_eq!(ok.at(0.49), Some(&[(1, 1.0), (0, 2.0)][..]));
    assert_eq!(ok.at(0.5), Some(&[(1, 3.0), (0, 4.0)][..]));
    assert_eq!(ok.at(-0.1), None);
    // `#k` addresses actuator k (how an unnamed actuator is written).
    let by_index = Controls::parse("t,#1,#0\n0,1,2\n", &names).unwrap();
    assert_eq!(by_index.at(0.0), Some(&[(1, 1.0), (0, 2.0)][..]));
    let unnamed = vec![String::new(), String::new()];
    let u = Controls::parse("t,#1\n0,5\n", &unnamed).unwrap();
    assert_eq!(u.at(1.0), Some(&[(1, 5.0)][..]));
    for (text, what) in [
        ("t,#2\n0,1\n", "not an actuator"),
        ("t,#0,push\n0,1,2\n", "appears twice"),
        ("", "empty"),
        ("x,push\n0,1\n", "first column must be t"),
        ("t,pull\n0,1\n", "not an actuator"),
        ("t,push,push\n0,1,2\n", "appears twice"),
        ("t,push\n0,1,2\n", "fields"),
        ("t,push\n0,abc\n", "not a number"),
        ("t,push\n0,nan\n", "non-finite"),
        ("t,push\n0.5,1\n0.5,2\n", "times must increase"),
    ] {
        let e = Controls::parse(text, &names).unwrap_err();
        assert!(e.contains(what), "{text:?}: {e}");
    }
}

/// Equality rows (issue 13): `scenes/coupled_pendulums.xml`, an `equality joint`
/// (`ha = −hb`) and an `equality tendon` (`hc = −0.5 ha` through a fixed tendon), made
/// tight in MuJoCo (solref 2e-4) and hard here. Against MuJoCo RK4 at dt = 1e-4
/// (converged: RK4 at 5e-5 differs by 5.2e-13 m over 2 s; RK4 at 1e-3, whose refsafe
/// floor softens the rows to solref 2e-3, by 2.6e-7 m over 1 s, so the softness is
/// negligible here): ours, velocity level, 1.34e-3 m at 1e-3 and 3.35e-4 m at 2.5e-4
/// over 1 s (first order, ratio 4.00); MuJoCo's Euler at 1e-3 errs by 1.34e-3 m
/// (1.338e-3); RATTLE 1.11e-6 m, RATTLE4 2.6e-9 m at 1e-3. Our equality violation
/// over 2 s at 1e-3: 4.5e-10 (the velocity level's residue on `follow`, whose row
/// turns with body b).
#[test]
fn coupled_pendulums_match_mujoco_rk4() {
    use constraint_articulated::{Method, MjcfScene};
    check("coupled_pendulums", 1.34e-3);
    // RATTLE takes the rows in its kicks and SHAKE: second order (measured 1.11e-6 m
    // at 1e-3, 2.78e-7 at 5e-4, ratio 4.00), RATTLE4 at MuJoCo's own floor (2.6e-9 m;
    // MuJoCo RK4 at 1e-3 errs by 2.6e-7 m).
    let r = against_reference("coupled_pendulums", "rattle", 1e-3, 1.0);
    let r2 = against_reference("coupled_pendulums", "rattle", 5e-4, 1.0);
    assert!(r.com.0 <= 1.5 * 1.11e-6, "RATTLE {:e}", r.com.0);
    assert!(
        r.com.0 / r2.com.0 >= 3.5,
        "RATTLE ratio {}",
        r.com.0 / r2.com.0
    );
    let r4 = against_reference("coupled_pendulums", "rattle4", 1e-3, 1.0);
    assert!(r4.com.0 <= 1.5 * 2.62e-9, "RATTLE4 {:e}", r4.com.0);
    let mut scene =
        MjcfScene::from_file(&root().join("scenes/coupled_pendulums.xml"), Some("start")).unwrap();
    assert_eq!(scene.world.equalities().len(), 2);
    let mut worst: f64 = 0.0;
    for _ in 0..2000 {
        scene
            .world
            .step(1e-3, Method::Velocity { beta: 1.0 })
            .unwrap();
        worst = worst.max(scene.world.max_equality_violation());
    }
    println!("coupled_pendulums: max |C| {worst:.2e}");
    // measured 4.5e-10 rad
    assert!(worst <= 1e-8, "equality violation {worst:e}");
}

/// Two hinges on skew lines (issue 13, `scenes/offset_universal.xml`: dm_control
/// humanoid's ankle, an offset universal joint) against MuJoCo RK4. Measured over 2 s at
/// dt = 1e-3: velocity level 5.56e-4 m, RATTLE 1.47e-6 m (3.67e-7 at dt = 5e-4: second
/// order), MuJoCo Euler 7.01e-4 m.
#[test]
fn hinges_on_skew_lines_match_mujoco_rk4() {
    check_new("offset_universal", VEL_OFFSET, 7.01e-4, 1.47e-6);
    // The velocity level is below MuJoCo Euler over the same 2 s too (measured 5.56e-4).
    let v = against_reference("offset_universal", "velocity", 1e-3, 2.0);
    assert!(v.com.0 < 7.01e-4, "velocity level {:e}", v.com.0);
}

// Velocity level at dt = 1e-3 over 1 s, measured 5.314e-4 m; 4.00× less at a 4× smaller
// step.
const VEL_OFFSET: f64 = 5.314e-4;
