//! Free-body contact worlds ([`ContactWorld`]) from MJCF scene files (features `mjcf`
//! and `contact`): free bodies with collision geoms, and static world geoms.
//!
//! Every body must have a `free` joint (`<freejoint/>`): joints and contact in one world
//! are not supported yet, and such a file is an error naming the body. Geoms map to
//! colliders at their pose relative to the body's centre of mass: `plane` (world geoms
//! only; normal = the geom's z axis), `sphere`, `box`, `capsule`; `friction` is the
//! first (sliding) coefficient; geoms with `contype = conaffinity = 0` collide with
//! nothing and are left out. MuJoCo's contact is soft (`solref`, `solimp`), ours is
//! hard, so trajectories agree up to that softness (millimetres at rest).

use alloc::format;
use alloc::string::{String, ToString};
use alloc::vec::Vec;

use constraint_contact::geometry::{Collider, Shape};
use constraint_contact::rigid::{ContactError, ContactWorld};
use constraint_core::{DQuat, DVec3, Pose, RigidBody};
use constraint_mjcf::{JointKind, Model, Shape as MjShape};

use crate::MjcfScene;

fn q(a: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(a[1], a[2], a[3], a[0]).normalize()
}

fn bad(s: String) -> ContactError {
    ContactError::Scene(s)
}

/// A contact world built from an MJCF model, with the model's body names and time step.
#[derive(Clone, Debug)]
pub struct MjcfContactScene {
    /// The world (bodies in MJCF document order).
    pub world: ContactWorld,
    /// Body names, same order.
    pub body_names: Vec<String>,
    /// Body-frame centre-of-mass offsets (to report body origins).
    pub coms: Vec<DVec3>,
    /// `option timestep`.
    pub timestep: f64,
}

impl MjcfContactScene {
    /// Builds the world of `model` with keyframe `key` (`None`: default pose at rest).
    pub fn new(model: &Model, key: Option<&str>) -> Result<Self, ContactError> {
        for (i, b) in model.bodies.iter().enumerate() {
            let free = model
                .joints
                .iter()
                .any(|j| j.body == i && j.kind == JointKind::Free);
            if !free {
                return Err(bad(format!(
                    "body {:?} (line {}): contact scenes need every body free (<freejoint/>); joints with contact are not supported yet",
                    b.name, b.line
                )));
            }
        }
        // Bodies, masses and the keyframe state come from the articulated loader.
        let scene = MjcfScene::new(model, key).map_err(|e| bad(e.to_string()))?;
        let mut world = ContactWorld::new(DVec3::from_array(model.gravity));
        let mut coms = Vec::new();
        for b in scene.world.bodies() {
            let mut body = RigidBody::new(world.bodies().len(), b.mass(), b.inertia(), b.pose)
                .map_err(ContactError::Body)?;
            body.v = b.v;
            body.omega = b.omega;
            body.com = b.com;
            coms.push(b.com);
            world.add_body(body)?;
        }
        if !model.contact_disabled {
            for g in &model.geoms {
                if g.contype == 0 && g.conaffinity == 0 {
                    continue;
                }
                let where_ = |e: constraint_contact::geometry::GeometryError| {
                    bad(format!("geom {:?} (line {}): {e:?}", g.name, g.line))
                };
                if matches!(
                    g.primitive,
                    constraint_mjcf::Primitive::Cylinder { .. }
                        | constraint_mjcf::Primitive::Ellipsoid { .. }
                ) {
                    return Err(bad(format!(
                        "geom {:?} (line {}): cylinder and ellipsoid collision is not supported",
                        g.name, g.line
                    )));
                }
                let shape = match g.shape {
                    MjShape::Plane => {
                        if g.body.is_some() {
                            return Err(bad(format!(
                                "geom {:?} (line {}): planes must be world geoms",
                                g.name, g.line
                            )));
                        }
                        let n = q(g.quat) * DVec3::Z;
                        let offset = n.dot(DVec3::from_array(g.pos));
                        Shape::plane(n, offset).map_err(where_)?
                    }
                    MjShape::Sphere { radius } => Shape::sphere(radius).map_err(where_)?,
                    MjShape::Box { half } => {
                        Shape::cuboid(DVec3::from_array(half)).map_err(where_)?
                    }
                    MjShape::Capsule {
                        radius,
                        half_length,
                    } => Shape::capsule(radius, half_length).map_err(where_)?,
                };
                // Collider pose: in the world for world geoms (a plane carries its
                // normal and offset in the shape), else relative to the body's centre of
                // mass in the body frame.
                let local = match (g.body, g.shape) {
                    (_, MjShape::Plane) => Pose::IDENTITY,
                    (None, _) => Pose {
                        x: DVec3::from_array(g.pos),
                        q: q(g.quat),
                    },
                    (Some(b), _) => Pose {
                        x: DVec3::from_array(g.pos) - coms[b],
                        q: q(g.quat),
                    },
                };
                let c = Collider::new(g.body, shape, local, g.friction[0], 0.0).map_err(where_)?;
                world.add_collider(c)?;
            }
        }
        Ok(Self {
            world,
            body_names: scene.body_names.clone(),
            coms,
            timestep: scene.timestep,
        })
    }

    /// Loads `path` and builds its world.
    pub fn from_file(path: &std::path::Path, key: Option<&str>) -> Result<Self, ContactError> {
        let model = constraint_mjcf::load_file(path).map_err(|e| bad(e.to_string()))?;
        Self::new(&model, key)
    }
}
