//! The one rigid world's newer entry points with arbitrary values: chains of hinge,
//! slide, ball and compound joints (slides then hinges), joint limits (any `lower`,
//! `upper`, NaN included), dry friction, armature, joint springs, fixed tendons,
//! actuators of every gain/bias form with any gear and ranges, controls, fluid drag, and
//! colliders on the jointed bodies over a floor, stepped under every method. Every call
//! returns a typed error or leaves a finite state; a rejected step leaves the state
//! unchanged.
#![no_main]

use arbitrary::Arbitrary;
use constraint_articulated::{
    Actuator, DofSpring, Fluid, Joint, JointKind, Method, RigidBody, Target, Tendon, World,
};
use constraint_contact::geometry::{Collider, Shape};
use constraint_core::{Compound, DMat3, DQuat, DVec3, Hinge, Pose, Prismatic, Spherical};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Link {
    mass: f64,
    inertia: [f64; 3],
    offset: [f64; 3],
    q: [f64; 4],
    v: [f64; 3],
    omega: [f64; 3],
    /// 0 hinge, 1 slide, 2 ball, 3 compound, 4 none (a free body).
    kind: u8,
    axes: [[f64; 3]; 3],
    n_slides: u8,
    n_hinges: u8,
    damping: f64,
    limit: Option<(u8, f64, f64)>,
    frictionloss: Option<(u8, f64)>,
    armature: Option<(u8, f64)>,
    spring: Option<(u8, f64, f64)>,
    /// Collider: 0 none, 1 sphere, 2 capsule, 3 box; its size.
    shape: u8,
    size: [f64; 2],
    friction: f64,
}

#[derive(Arbitrary, Debug)]
struct Act {
    joint: u8,
    dof: u8,
    tendon: bool,
    gear: f64,
    gain: f64,
    bias: [f64; 3],
    ctrl_range: Option<[f64; 2]>,
    force_range: Option<[f64; 2]>,
    ctrl: f64,
}

#[derive(Arbitrary, Debug)]
struct Input {
    links: Vec<Link>,
    tendon: Vec<(u8, u8, f64)>,
    tendon_k: f64,
    tendon_d: f64,
    actuators: Vec<Act>,
    fluid: Option<(f64, f64)>,
    floor: bool,
    method: u8,
    h: f64,
    param: f64,
    iters: u8,
    steps: u8,
    gravity: [f64; 3],
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

fn joint_kind(l: &Link, pa: &Pose, pb: &Pose) -> Option<JointKind> {
    let anchor = pb.x;
    let axis = v(l.axes[0]);
    let kind = match l.kind % 5 {
        0 => Hinge::from_world(pa, pb, anchor, axis).map(JointKind::Hinge),
        1 => Prismatic::from_world(pa, pb, anchor, axis).map(JointKind::Prismatic),
        2 => Spherical::from_world(pa, pb, anchor).map(JointKind::Spherical),
        3 => {
            let ns = (l.n_slides % 4) as usize;
            let nh = (l.n_hinges % 4) as usize;
            let axes: Vec<DVec3> = l.axes.iter().map(|a| v(*a)).collect();
            let slides = &axes[..ns];
            let hinges = &axes[(3 - nh)..];
            Compound::from_world(pa, pb, anchor, slides, hinges)
                .map(|c| JointKind::Compound(c, [l.damping; 6]))
        }
        _ => return None,
    };
    kind.ok()
}

fuzz_target!(|inp: Input| {
    let mut w = World::new(v(inp.gravity));
    if inp.floor {
        if let Ok(plane) = Shape::plane(DVec3::Z, 0.0) {
            if let Ok(c) = Collider::simple(None, plane) {
                let _ = w.add_collider(c);
            }
        }
    }
    // A chain: link i hangs from link i−1 (the first from the world) at its own origin.
    let mut prev: Option<usize> = None;
    let mut joints: Vec<usize> = Vec::new();
    for l in inp.links.iter().take(5) {
        let base = prev
            .and_then(|p| w.bodies().get(p))
            .map_or(DVec3::new(0.0, 0.0, 1.0), |b| b.pose.x);
        let q = DQuat::from_array(l.q);
        let q = if q.length() > 1e-3 && q.is_finite() {
            q.normalize()
        } else {
            q
        };
        let pose = Pose {
            x: base + v(l.offset),
            q,
        };
        let Ok(rb) = RigidBody::new(
            w.bodies().len(),
            l.mass,
            DMat3::from_diagonal(v(l.inertia)),
            pose,
        ) else {
            continue;
        };
        let Ok(b) = w.add_body(rb.with_velocity(v(l.v), v(l.omega))) else {
            continue;
        };
        let pa = prev.map_or(Pose::IDENTITY, |p| w.bodies()[p].pose);
        if let Some(kind) = joint_kind(l, &pa, &pose) {
            if let Ok(j) = w.add_joint(Joint {
                parent: prev,
                child: b,
                kind,
                damping: l.damping,
            }) {
                joints.push(j);
                if let Some((d, lo, hi)) = l.limit {
                    let _ = w.set_dof_limit(j, d as usize % 7, lo, hi);
                }
                if let Some((d, f)) = l.frictionloss {
                    let _ = w.set_frictionloss(j, d as usize % 7, f);
                }
                if let Some((d, a)) = l.armature {
                    let _ = w.set_armature(j, d as usize % 7, a);
                }
                if let Some((d, k, r)) = l.spring {
                    let _ = w.add_dof_spring(DofSpring {
                        joint: j,
                        dof: d as usize % 7,
                        stiffness: k,
                        reference: r,
                    });
                }
            }
        }
        let shape = match l.shape % 4 {
            1 => Some(Shape::sphere(l.size[0])),
            2 => Some(Shape::capsule(l.size[0], l.size[1])),
            3 => Some(Shape::cuboid(DVec3::splat(l.size[0]))),
            _ => None,
        };
        if let Some(Ok(s)) = shape {
            if let Ok(c) = Collider::simple(Some(b), s).and_then(|c| c.with_material(l.friction, 0.0))
            {
                let _ = w.add_collider(c);
            }
        }
        prev = Some(b);
    }
    let joint_at = |k: u8| joints.get(k as usize % joints.len().max(1)).copied();
    let terms: Vec<(usize, usize, f64)> = inp
        .tendon
        .iter()
        .take(4)
        .filter_map(|&(j, d, c)| Some((joint_at(j)?, d as usize % 4, c)))
        .collect();
    let tendon = w
        .add_tendon(Tendon {
            terms,
            stiffness: inp.tendon_k,
            damping: inp.tendon_d,
            rest_length: 0.0,
        })
        .ok();
    for a in inp.actuators.iter().take(4) {
        let target = match (a.tendon, tendon, joint_at(a.joint)) {
            (true, Some(t), _) => Target::Tendon(t),
            (_, _, Some(joint)) => Target::Dof {
                joint,
                dof: a.dof as usize % 4,
            },
            _ => continue,
        };
        if let Ok(k) = w.add_actuator(Actuator {
            target,
            gear: a.gear,
            gain: a.gain,
            bias: a.bias,
            ctrl_range: a.ctrl_range,
            force_range: a.force_range,
        }) {
            let _ = w.set_ctrl(k, a.ctrl);
        }
    }
    if let Some((density, viscosity)) = inp.fluid {
        let _ = w.set_fluid(Some(Fluid {
            density,
            viscosity,
            wind: DVec3::ZERO,
        }));
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
});
