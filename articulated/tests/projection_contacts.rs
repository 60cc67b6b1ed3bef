//! Contacts in the position projection (feature `contact`): the projection that follows
//! every step with one-sided rows pushes this step's contacts out to the slop (one-sided
//! rows, never pulling), and the speculative contact rows reach as far as a body can
//! move in one step. Every tolerance carries the value measured when it was set.

use constraint_articulated::{Joint, JointKind, Method, RigidBody, World};
use constraint_contact::geometry::{Collider, Shape};
use constraint_core::{DMat3, DQuat, DVec3, Hinge, Pose};

const RADIUS: f64 = 0.05;

/// A 0.5 m link hinged to the world at the origin (axis y), lying along x, with a
/// sphere of [`RADIUS`] at its tip, `depth` into the floor `z = 0` below the hinge.
fn link_in_floor(depth: f64) -> World {
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let floor = Shape::plane(DVec3::Z, 0.0).unwrap();
    w.add_collider(Collider::new(None, floor, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    let z = RADIUS - depth;
    let pose = Pose {
        x: DVec3::new(0.5, 0.0, z),
        q: DQuat::IDENTITY,
    };
    let b = w
        .add_body(RigidBody::new(0, 1.0, DMat3::IDENTITY * 1e-3, pose).unwrap())
        .unwrap();
    let ball = Shape::sphere(RADIUS).unwrap();
    w.add_collider(Collider::new(Some(b), ball, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    let hinge =
        Hinge::from_world(&Pose::IDENTITY, &pose, DVec3::new(0.0, 0.0, z), DVec3::Y).unwrap();
    w.add_joint(Joint {
        parent: None,
        child: b,
        kind: JointKind::Hinge(hinge),
        damping: 0.0,
    })
    .unwrap();
    w
}

/// The sphere's penetration into the floor (m; negative: above it).
fn penetration(w: &World) -> f64 {
    RADIUS - w.bodies()[0].pose.x.z
}

/// A hinged link whose tip starts 5 mm in the floor: the velocity level corrects a
/// fifth of the depth beyond the slop per step (Baumgarte 0.2), and the projection that
/// follows (RATTLE's step with one-sided rows) takes the tip out to the slop, with the
/// hinge held.
#[test]
fn projection_pushes_a_contact_out_to_the_slop() {
    let h = 1e-3;
    let mut velocity = link_in_floor(5e-3);
    velocity.step(h, Method::Velocity { beta: 1.0 }).unwrap();
    let left = penetration(&velocity);
    // Without the projection: 5 mm − 0.2 · 4.9 mm, less the fall of one step.
    assert!(left > 3.9e-3, "velocity level alone: {left:e}"); // measured 4.02e-3
    let mut w = link_in_floor(5e-3);
    let slop = w.unilateral.slop;
    let st = w.step(h, Method::default()).unwrap();
    assert_eq!(st.unilateral_fallbacks, 1);
    let pen = penetration(&w);
    let sep = w.max_separation();
    let dv = (w.bodies()[0].v - velocity.bodies()[0].v).length();
    println!("velocity level {left:.4e} m, projected {pen:.6e} m, slop {slop:e}, hinge {sep:e}, dv {dv:e}");
    assert!(pen <= slop + 1e-9, "penetration {pen:e}"); // measured 1.000000e-4 (the slop)
    assert!(pen >= 0.5 * slop, "pushed past the slop: {pen:e}"); // measured 1.0e-4

    // The projection stops at the unilateral floor, 1e-7 m (measured 5.5e-10 at a
    // floor of 1e-9; 4.9e-15 when it was the method's 1e-12).
    assert!(sep <= w.unilateral_tolerance(), "hinge {sep:e}");
    // The projection moves positions only: the step's velocity is the velocity level's.
    assert!(dv <= 1e-9, "velocity changed by {dv:e}"); // measured 0
}

/// The contact rows push only: a tip resting just inside the slop is left where the
/// velocity level put it (the projection has nothing to do: no iteration).
#[test]
fn projection_leaves_a_contact_within_the_slop() {
    let h = 1e-3;
    let mut w = link_in_floor(5e-5);
    let mut v = link_in_floor(5e-5);
    let st = w.step(h, Method::default()).unwrap();
    v.step(h, Method::Velocity { beta: 1.0 }).unwrap();
    let d = (w.bodies()[0].pose.x - v.bodies()[0].pose.x).length();
    println!("iterations {} difference {d:e}", st.projection_iterations);
    assert!(d <= 1e-12, "moved by {d:e}"); // measured 0
    let pen = penetration(&w);
    assert!(pen <= w.unilateral.slop, "penetration {pen:e}"); // measured 5.0e-5
}

/// A ball falling at 5 m/s from 3 cm above the floor with `h` = 0.01 s: beyond the
/// 2 cm margin at the start of the step, it reaches the floor within it. The
/// speculative row reaches it (the narrow phase looks as far as the ball can move), so
/// it ends the step at the floor, its speed cut to the 3 m/s that close the gap,
/// instead of starting the next step 2.1 cm deep.
#[test]
fn fast_ball_gets_a_speculative_contact() {
    let h = 1e-2;
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let floor = Shape::plane(DVec3::Z, 0.0).unwrap();
    w.add_collider(Collider::new(None, floor, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    let pose = Pose {
        x: DVec3::new(0.0, 0.0, RADIUS + 0.03),
        q: DQuat::IDENTITY,
    };
    let body = RigidBody::new(0, 1.0, DMat3::IDENTITY * 1e-3, pose)
        .unwrap()
        .with_velocity(DVec3::new(0.0, 0.0, -5.0), DVec3::ZERO);
    let b = w.add_body(body).unwrap();
    let ball = Shape::sphere(RADIUS).unwrap();
    w.add_collider(Collider::new(Some(b), ball, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    w.step(h, Method::default()).unwrap();
    let st = w.unilateral_stats();
    assert_eq!(st.contacts, 1, "the speculative contact"); // measured 1
    let pen = penetration(&w);
    println!(
        "after the step: penetration {pen:e} m, v {}",
        w.bodies()[0].v.z
    );
    assert!(pen <= 1e-9, "penetration {pen:e}"); // measured 0 (at the floor)
    let vz = w.bodies()[0].v.z;
    assert!(vz >= -3.0 - 1e-9, "v {vz}"); // measured -3 (the gap over h)
}

/// A contact that no row held at the start of the step: a ball at rest 3 cm above the
/// floor (beyond the 2 cm margin, and not moving) under a gravity of 1000 m/s² falls
/// 10 cm within one step of 0.01 s. A second ball resting on the floor gives the step
/// its contact rows, so it ends with the projection, which generates the contacts at
/// the velocity level's end and pushes the first ball out to the slop (it ended the
/// step 7 cm deep before).
#[test]
fn projection_holds_a_contact_that_closed_within_the_step() {
    let h = 1e-2;
    let mut w = World::new(DVec3::new(0.0, 0.0, -1000.0));
    let floor = Shape::plane(DVec3::Z, 0.0).unwrap();
    w.add_collider(Collider::new(None, floor, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    for (x, z) in [(0.0, RADIUS + 0.03), (1.0, RADIUS)] {
        let pose = Pose {
            x: DVec3::new(x, 0.0, z),
            q: DQuat::IDENTITY,
        };
        let b = w
            .add_body(RigidBody::new(0, 1.0, DMat3::IDENTITY * 1e-3, pose).unwrap())
            .unwrap();
        let ball = Shape::sphere(RADIUS).unwrap();
        w.add_collider(Collider::new(Some(b), ball, Pose::IDENTITY, 0.5, 0.0).unwrap())
            .unwrap();
    }
    let st = w.step(h, Method::default()).unwrap();
    assert_eq!(st.unilateral_fallbacks, 1);
    assert_eq!(w.unilateral_stats().contacts, 1, "the resting ball's only"); // measured 1
    let pen = penetration(&w);
    println!("falling ball after the step: penetration {pen:.6e} m");
    assert!(pen <= w.unilateral.slop + 1e-9, "penetration {pen:e}"); // measured 1.000000e-4
}
