//! Worlds from MJCF scene files (feature `mjcf`; DESIGN.md §8).
//!
//! The loaded [`constraint_mjcf::Model`] is turned into maximal coordinates: every body
//! is a [`RigidBody`] (centre of mass, orientation of the body frame, inertia about the
//! centre of mass in the body frame) and every MuJoCo joint a constraint between the
//! body and its parent, built at the model's default pose (`qpos0`, where MuJoCo's joint
//! frames coincide):
//!
//! | MJCF | here |
//! |---|---|
//! | `hinge` | [`Hinge`] through the joint anchor about its axis, damping on the axis rate |
//! | `ball` | [`Spherical`] at the anchor, damping on the relative angular velocity |
//! | `slide` | [`Prismatic`] along the axis, damping on the sliding rate |
//! | `free` / `freejoint` | no constraint |
//! | no joint | [`Fixed`] weld to the parent (or the world) |
//! | `equality/connect` | [`Spherical`] between `body1` and `body2` at the anchor |
//!
//! The initial state is the keyframe's (MuJoCo's generalized `qpos`/`qvel` converted to
//! body poses and twists by the loader), or the default pose at rest. Geoms only
//! contribute mass here (contact is the contact crate's); a scene whose geoms collide
//! in MuJoCo is reported by [`MjcfScene::collision_geoms`].

use alloc::string::{String, ToString};
use alloc::vec::Vec;

use constraint_core::{DMat3, DQuat, DVec3, Fixed, Hinge, Pose, Prismatic, Spherical};
use constraint_mjcf::{JointKind as MjKind, Model};

use crate::body::RigidBody;
use crate::error::ArticulatedError;
use crate::joint::{Joint, JointKind};
use crate::world::World;

/// A world built from an MJCF model, with the model's names and time step.
#[derive(Clone, Debug)]
pub struct MjcfScene {
    /// The world (bodies in MJCF document order, world body excluded).
    pub world: World,
    /// Body names, same order.
    pub body_names: Vec<String>,
    /// `option timestep`.
    pub timestep: f64,
    /// Geoms that would collide in MuJoCo (`contype`/`conaffinity` non-zero and contact
    /// not disabled); this crate does not simulate contact.
    pub collision_geoms: usize,
}

fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn quat(q: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize()
}

fn scene_err(e: impl ToString) -> ArticulatedError {
    ArticulatedError::Scene(e.to_string())
}

impl MjcfScene {
    /// Builds the world of `model` with the state of keyframe `key` (`None`: default pose
    /// at rest).
    pub fn new(model: &Model, key: Option<&str>) -> Result<Self, ArticulatedError> {
        let states = model.initial_state(key).map_err(scene_err)?;
        let mut world = World::new(v3(model.gravity));
        // Bodies at the default pose first: joints are defined there.
        let mut default_poses = Vec::with_capacity(model.bodies.len());
        for (i, b) in model.bodies.iter().enumerate() {
            let q = quat(b.quat);
            let com = v3(b.com);
            let pose = Pose {
                x: v3(b.pos) + q * com,
                q,
            };
            let inertia = DMat3::from_cols(v3(b.inertia[0]), v3(b.inertia[1]), v3(b.inertia[2]));
            let body = RigidBody::new(i, b.mass, inertia, pose)
                .map_err(|e| scene_err(format!("body {:?} (line {}): {e}", b.name, b.line)))?
                .with_com(com);
            default_poses.push(pose);
            world.add_body(body)?;
        }
        let pose_of = |b: Option<usize>| b.map_or(Pose::IDENTITY, |i| default_poses[i]);
        let mut joint_of = alloc::vec![None; model.bodies.len()];
        for j in &model.joints {
            if let Some(slot) = joint_of.get_mut(j.body) {
                *slot = Some(j);
            }
        }
        for (i, b) in model.bodies.iter().enumerate() {
            let pa = pose_of(b.parent);
            let pb = default_poses[i];
            let origin = v3(b.pos);
            let r = quat(b.quat);
            let wrap = |e| scene_err(format!("body {:?} (line {}): {e}", b.name, b.line));
            let (kind, damping) = match joint_of[i] {
                None => (
                    JointKind::Fixed(Fixed::from_world(&pa, &pb, origin).map_err(wrap)?),
                    0.0,
                ),
                Some(j) => {
                    let anchor = origin + r * v3(j.pos);
                    let axis = r * v3(j.axis);
                    let kind = match j.kind {
                        MjKind::Free => continue,
                        MjKind::Hinge => JointKind::Hinge(
                            Hinge::from_world(&pa, &pb, anchor, axis).map_err(wrap)?,
                        ),
                        MjKind::Ball => JointKind::Spherical(
                            Spherical::from_world(&pa, &pb, anchor).map_err(wrap)?,
                        ),
                        MjKind::Slide => JointKind::Prismatic(
                            Prismatic::from_world(&pa, &pb, anchor, axis).map_err(wrap)?,
                        ),
                    };
                    (kind, j.damping)
                }
            };
            world.add_joint(Joint {
                parent: b.parent,
                child: i,
                kind,
                damping,
            })?;
        }
        for c in &model.connects {
            let p1 = pose_of(c.body1);
            let p2 = pose_of(c.body2);
            let o1 = c.body1.map_or(DVec3::ZERO, |i| v3(model.bodies[i].pos));
            let q1 = c
                .body1
                .map_or(DQuat::IDENTITY, |i| quat(model.bodies[i].quat));
            let anchor = o1 + q1 * v3(c.anchor);
            let sph = Spherical::from_world(&p1, &p2, anchor)
                .map_err(|e| scene_err(format!("connect {:?} (line {}): {e}", c.name, c.line)))?;
            let (parent, child) = match (c.body1, c.body2) {
                (a, Some(b)) => (a, b),
                (Some(a), None) => {
                    // Swap so the world is the parent side: C changes sign only.
                    let sph = Spherical::from_world(&p2, &p1, anchor).map_err(|e| {
                        scene_err(format!("connect {:?} (line {}): {e}", c.name, c.line))
                    })?;
                    world.add_joint(Joint {
                        parent: None,
                        child: a,
                        kind: JointKind::Spherical(sph),
                        damping: 0.0,
                    })?;
                    continue;
                }
                (None, None) => {
                    return Err(scene_err(format!(
                        "connect {:?} (line {}) joins the world to itself",
                        c.name, c.line
                    )))
                }
            };
            world.add_joint(Joint {
                parent,
                child,
                kind: JointKind::Spherical(sph),
                damping: 0.0,
            })?;
        }
        // The keyframe's state.
        for (b, s) in world.bodies_mut().iter_mut().zip(&states) {
            b.pose = Pose {
                x: v3(s.com),
                q: quat(s.quat),
            };
            b.v = v3(s.vel);
            b.omega = v3(s.omega);
        }
        if let Some(i) = world
            .bodies()
            .iter()
            .position(|b| !b.pose.x.is_finite() || !b.v.is_finite() || !b.omega.is_finite())
        {
            return Err(ArticulatedError::InvalidBody {
                body: i,
                reason: "keyframe state is not finite",
            });
        }
        let collision_geoms = if model.contact_disabled {
            0
        } else {
            model
                .geoms
                .iter()
                .filter(|g| g.contype != 0 || g.conaffinity != 0)
                .count()
        };
        Ok(Self {
            world,
            body_names: model.bodies.iter().map(|b| b.name.clone()).collect(),
            timestep: model.timestep,
            collision_geoms,
        })
    }

    /// Loads `path` and builds its world (see [`Self::new`]).
    pub fn from_file(path: &std::path::Path, key: Option<&str>) -> Result<Self, ArticulatedError> {
        let model = constraint_mjcf::load_file(path).map_err(scene_err)?;
        Self::new(&model, key)
    }
}
