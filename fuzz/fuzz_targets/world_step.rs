//! Arbitrary small articulated worlds (bodies, joints of every kind between any pair,
//! any method and time step) stepped a few times, and a few contact bodies on a ground
//! plane: every call returns a typed error or leaves a finite state; a rejected step
//! leaves the state unchanged.
#![no_main]

use arbitrary::Arbitrary;
use constraint_articulated::{Joint, JointKind, Method, RigidBody, World};
use constraint_contact::geometry::{Collider, Shape};
use constraint_contact::rigid::{ContactSolver, ContactWorld};
use constraint_core::{
    DMat3, DQuat, DVec3, DistanceJoint, Fixed, Hinge, Pose, Prismatic, Spherical,
};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Body {
    mass: f64,
    inertia: [f64; 3],
    x: [f64; 3],
    q: [f64; 4],
    v: [f64; 3],
    omega: [f64; 3],
}

#[derive(Arbitrary, Debug)]
struct J {
    parent: Option<u8>,
    child: u8,
    kind: u8,
    anchor: [f64; 3],
    axis: [f64; 3],
    damping: f64,
}

#[derive(Arbitrary, Debug)]
struct Input {
    bodies: Vec<Body>,
    joints: Vec<J>,
    method: u8,
    h: f64,
    param: f64,
    iters: u8,
    steps: u8,
    gravity: [f64; 3],
    contact_solver: u8,
}

fn v(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn state(w: &World) -> Vec<u64> {
    w.bodies()
        .iter()
        .flat_map(|b| {
            [b.pose.x.to_array(), b.v.to_array(), b.omega.to_array()]
                .into_iter()
                .flatten()
                .chain(b.pose.q.to_array())
        })
        .map(f64::to_bits)
        .collect()
}

fn finite(w: &World) -> bool {
    w.bodies().iter().all(|b| {
        b.pose.x.is_finite() && b.pose.q.is_finite() && b.v.is_finite() && b.omega.is_finite()
    })
}

fn body_of(i: usize, b: &Body) -> Option<RigidBody> {
    let q = DQuat::from_array(b.q);
    let q = if q.length() > 1e-3 && q.is_finite() {
        q.normalize()
    } else {
        q
    };
    RigidBody::new(
        i,
        b.mass,
        DMat3::from_diagonal(v(b.inertia)),
        Pose { x: v(b.x), q },
    )
    .ok()
    .map(|r| r.with_velocity(v(b.v), v(b.omega)))
}

fuzz_target!(|inp: Input| {
    // Articulated world.
    let mut w = World::new(v(inp.gravity));
    for (i, b) in inp.bodies.iter().take(5).enumerate() {
        if let Some(rb) = body_of(i, b) {
            let _ = w.add_body(rb);
        }
    }
    let nb = w.bodies().len();
    for j in inp.joints.iter().take(6) {
        if nb == 0 {
            break;
        }
        let child = j.child as usize % (nb + 1);
        let parent = j.parent.map(|p| p as usize % (nb + 1));
        let pose = |b: Option<usize>| {
            b.and_then(|i| w.bodies().get(i))
                .map_or(Pose::IDENTITY, |b| b.pose)
        };
        let (pa, pb) = (pose(parent), pose(Some(child)));
        let (anchor, axis) = (v(j.anchor), v(j.axis));
        let kind = match j.kind % 5 {
            0 => Spherical::from_world(&pa, &pb, anchor).map(JointKind::Spherical),
            1 => Hinge::from_world(&pa, &pb, anchor, axis).map(JointKind::Hinge),
            2 => Prismatic::from_world(&pa, &pb, anchor, axis).map(JointKind::Prismatic),
            3 => Fixed::from_world(&pa, &pb, anchor).map(JointKind::Fixed),
            _ => DistanceJoint::from_world(&pa, &pb, anchor, pb.x).map(JointKind::Distance),
        };
        if let Ok(kind) = kind {
            let _ = w.add_joint(Joint {
                parent,
                child,
                kind,
                damping: j.damping,
            });
        }
    }
    let it = (inp.iters % 40) as usize;
    let p = inp.param;
    let method = match inp.method % 6 {
        0 => Method::Velocity { beta: p },
        1 => Method::VelocityProjected {
            beta: 1.0,
            tolerance: p,
            max_iterations: it,
            correct_velocity: inp.iters.is_multiple_of(2),
        },
        2 => Method::Acceleration {
            kx: p,
            kv: p.abs().sqrt(),
        },
        3 => Method::Rattle {
            tolerance: p,
            max_iterations: it,
        },
        4 => Method::Rattle4 {
            tolerance: p,
            max_iterations: it,
        },
        _ => Method::default(),
    };
    // Only worlds whose inputs were accepted as finite are asserted finite.
    let start_finite = finite(&w) && w.gravity.is_finite();
    for _ in 0..(inp.steps % 8) {
        let before = state(&w);
        match w.step(inp.h, method) {
            Ok(_) => {
                if start_finite {
                    assert!(finite(&w), "non-finite state after an accepted step");
                }
            }
            Err(_) => {
                assert_eq!(state(&w), before, "a rejected step changed the state");
                break;
            }
        }
    }

    // A few contact bodies (spheres and boxes) on a ground plane.
    let mut cw = ContactWorld::new(v(inp.gravity));
    cw.settings.solver = match inp.contact_solver % 7 {
        0 => ContactSolver::Auto,
        1 => ContactSolver::SequentialImpulses,
        2 => ContactSolver::Pgs,
        3 => ContactSolver::Lemke,
        4 => ContactSolver::Newton,
        // The soft step (issue 14) with fuzzed sub-steps and settings: the iteration
        // count as sub-steps (0 is a typed error), `param` as every float setting.
        5 => ContactSolver::SoftStep {
            substeps: usize::from(inp.iters),
        },
        _ => {
            cw.settings.soft_step.hertz = inp.param;
            cw.settings.soft_step.damping_ratio = inp.param;
            cw.settings.soft_step.max_push_velocity = inp.param;
            cw.settings.soft_step.one_way_mass_ratio = inp.param;
            cw.settings.soft_step.friction_anchors = inp.param > 1.0;
            // Thread counts 0 (a typed error) to 4 (the `parallel` feature is on: a
            // scene this small runs on one thread, with the same bits).
            cw.settings.soft_step.threads = usize::from(inp.iters % 5);
            ContactSolver::SoftStep { substeps: 4 }
        }
    };
    if let Ok(plane) = Shape::plane(DVec3::Z, 0.0) {
        let _ = cw.add_collider(Collider::simple(None, plane).unwrap());
    }
    for (i, b) in inp.bodies.iter().take(3).enumerate() {
        let Some(rb) = body_of(i, b) else { continue };
        let Ok(k) = cw.add_body(rb) else { continue };
        let shape = if i % 2 == 0 {
            Shape::sphere(b.inertia[0].abs())
        } else {
            Shape::cuboid(v(b.inertia).abs())
        };
        if let Ok(s) = shape {
            let _ = cw.add_collider(Collider::simple(Some(k), s).unwrap());
        }
    }
    for _ in 0..(inp.steps % 4) {
        let before: Vec<String> = cw.bodies().iter().map(|b| format!("{b:?}")).collect();
        match cw.step(inp.h) {
            Ok(_) => {
                assert!(
                    cw.bodies()
                        .iter()
                        .all(|b| b.pose.x.is_finite() && b.v.is_finite() && b.omega.is_finite()),
                    "non-finite contact state after an accepted step"
                );
            }
            Err(_) => {
                let after: Vec<String> = cw.bodies().iter().map(|b| format!("{b:?}")).collect();
                assert_eq!(after, before, "a rejected contact step changed the state");
                break;
            }
        }
    }
});
