//! Keyframes (MuJoCo generalized coordinates) to world poses and velocities, against
//! hand-computed values. Measured agreement: ≤ 1e-15 everywhere; tolerance 1e-14.

mod common;

use common::{close, load, same_rotation};
use constraint_mjcf::MjcfError;
use std::f64::consts::FRAC_1_SQRT_2;

const TOL: f64 = 1e-14;

#[test]
fn hinge_pendulum() {
    // Bob: sphere 1 m below the body origin; hinge about y through an anchor 0.5 m
    // above the body origin, which sits at (0, 0, 2).
    let m = load(
        r#"<mujoco><compiler angle="radian"/><worldbody>
             <body pos="0 0 2"><joint axis="0 1 0" pos="0 0 0.5"/><geom size="0.1" pos="0 0 -1"/></body>
           </worldbody>
           <keyframe><key name="k" qpos="0.5" qvel="2"/></keyframe></mujoco>"#,
    );
    let (th, w): (f64, f64) = (0.5, 2.0);
    let s = &m.initial_state(Some("k")).expect("state")[0];
    // Rotation by θ about y: (x, z) offsets from the anchor (0, 0, 2.5) turn as
    // (0, −a) -> (−a sin θ, −a cos θ).
    close(s.pos, [-0.5 * th.sin(), 0.0, 2.5 - 0.5 * th.cos()], TOL);
    close(s.com, [-1.5 * th.sin(), 0.0, 2.5 - 1.5 * th.cos()], TOL);
    same_rotation(s.quat, [(th / 2.0).cos(), 0.0, (th / 2.0).sin(), 0.0], TOL);
    close(s.omega, [0.0, w, 0.0], TOL);
    // v = ω × r with r = (−1.5 sin θ, 0, −1.5 cos θ).
    close(s.vel, [-w * 1.5 * th.cos(), 0.0, w * 1.5 * th.sin()], TOL);
}

#[test]
fn ball_joint_chain() {
    // Link a: ball at its origin (0, 0, 1), sphere at (1, 0, 0). Link b: origin at
    // (1, 0, 0) in a, ball at its origin, sphere at (0, 0, −1).
    // Key: a turned 90° about z and spinning at (0, 0, 1) (own frame); b not turned,
    // spinning at (1, 0, 0) in b's frame, which is world y after a's turn.
    let h = FRAC_1_SQRT_2;
    let m = load(&format!(
        r#"<mujoco><worldbody>
             <body name="a" pos="0 0 1"><joint type="ball"/><geom size="0.1" pos="1 0 0"/>
               <body name="b" pos="1 0 0"><joint type="ball"/><geom size="0.1" pos="0 0 -1"/></body>
             </body>
           </worldbody>
           <keyframe><key name="k" qpos="{h} 0 0 {h}  1 0 0 0" qvel="0 0 1  1 0 0"/></keyframe>
           </mujoco>"#
    ));
    let st = m.initial_state(Some("k")).expect("state");
    let (a, b) = (&st[0], &st[1]);
    close(a.pos, [0.0, 0.0, 1.0], TOL);
    close(a.com, [0.0, 1.0, 1.0], TOL);
    same_rotation(a.quat, [h, 0.0, 0.0, h], TOL);
    close(a.omega, [0.0, 0.0, 1.0], TOL);
    close(a.vel, [-1.0, 0.0, 0.0], TOL); // (0,0,1) × (0,1,0)
    close(b.pos, [0.0, 1.0, 1.0], TOL);
    close(b.com, [0.0, 1.0, 0.0], TOL);
    same_rotation(b.quat, [h, 0.0, 0.0, h], TOL);
    close(b.omega, [0.0, 1.0, 1.0], TOL);
    // Origin moves with a: (−1, 0, 0); plus ω_b × (0, 0, −1) = (−1, 0, 0).
    close(b.vel, [-2.0, 0.0, 0.0], TOL);
}

#[test]
fn free_body() {
    // Free body, COM 0.5 m along its own x. Key: at (1, 2, 3), turned 90° about z;
    // linear velocity of the origin (0.1, 0.2, 0.3) in world; angular (1, 0, 2) in the
    // body frame = (0, 1, 2) in world.
    let h = FRAC_1_SQRT_2;
    let m = load(&format!(
        r#"<mujoco><worldbody>
             <body pos="5 5 5"><freejoint/><geom size="0.1" pos="0.5 0 0"/></body>
           </worldbody>
           <keyframe><key name="k" qpos="1 2 3 {h} 0 0 {h}" qvel="0.1 0.2 0.3 1 0 2"/></keyframe>
           </mujoco>"#
    ));
    let s = &m.initial_state(Some("k")).expect("state")[0];
    close(s.pos, [1.0, 2.0, 3.0], TOL);
    same_rotation(s.quat, [h, 0.0, 0.0, h], TOL);
    close(s.com, [1.0, 2.5, 3.0], TOL);
    close(s.omega, [0.0, 1.0, 2.0], TOL);
    // (0, 1, 2) × (0, 0.5, 0) = (−1, 0, 0).
    close(s.vel, [-0.9, 0.2, 0.3], TOL);
}

#[test]
fn slide_on_a_spinning_free_body() {
    // The slider's velocity is the parent's twist taken where the slider now is plus
    // its own rate (MuJoCo's cdof).
    let m = load(
        r#"<mujoco><worldbody>
             <body><freejoint/><geom size="0.1"/>
               <body><joint type="slide" axis="1 0 0"/><geom size="0.1"/></body>
             </body>
           </worldbody>
           <keyframe><key name="k" qpos="0 0 0 1 0 0 0 2" qvel="0 0 0 0 0 1 3"/></keyframe>
           </mujoco>"#,
    );
    let s = &m.initial_state(Some("k")).expect("state")[1];
    close(s.pos, [2.0, 0.0, 0.0], TOL);
    close(s.vel, [3.0, 2.0, 0.0], TOL); // (0,0,1) × (2,0,0) + 3 x̂
}

#[test]
fn default_state_is_the_compiled_pose_at_rest() {
    let m = load(
        r#"<mujoco><worldbody>
             <body pos="0 0 1" euler="10 20 30"><joint/><geom size="0.1" pos="0.2 0 0"/>
               <body pos="1 0 0" euler="0 0 45"><joint type="ball"/><geom size="0.1"/></body>
             </body>
             <body pos="3 0 0" quat="1 2 3 4"><freejoint/><geom size="0.1"/></body>
           </worldbody></mujoco>"#,
    );
    let st = m.initial_state(None).expect("state");
    for (b, s) in m.bodies.iter().zip(&st) {
        close(s.pos, b.pos, 1e-15);
        same_rotation(s.quat, b.quat, 1e-15);
        assert_eq!(s.vel, [0.0; 3]);
        assert_eq!(s.omega, [0.0; 3]);
    }
}

#[test]
fn body_states_checks_vector_lengths_and_values() {
    let m =
        load(r#"<mujoco><worldbody><body><joint/><geom size="0.1"/></body></worldbody></mujoco>"#);
    assert_eq!(
        m.body_states(&[0.0, 1.0], &[0.0]),
        Err(MjcfError::StateLength {
            what: "qpos",
            expected: 1,
            got: 2
        })
    );
    assert_eq!(
        m.body_states(&[0.0], &[f64::NAN]),
        Err(MjcfError::NonFiniteState {
            what: "qvel",
            index: 0
        })
    );
    // A zero quaternion counts as the identity, as in MuJoCo's mju_normalize4.
    let m = load(
        r#"<mujoco><worldbody><body><joint type="ball"/><geom size="0.1"/></body></worldbody></mujoco>"#,
    );
    let s = m.body_states(&[0.0; 4], &[0.0; 3]).expect("state");
    assert_eq!(s[0].quat, [1.0, 0.0, 0.0, 0.0]);
}
