//! Scenes built in Rust (benchmarks and tests that do not go through MJCF).

use alloc::vec::Vec;

use constraint_core::{DMat3, DQuat, DVec3, Pose, Spherical};

use crate::body::RigidBody;
use crate::error::ArticulatedError;
use crate::joint::{Joint, JointKind};
use crate::world::World;

/// A chain of `links` rods (length 0.1 m, radius 0.01 m, density 1000 kg/m³: about 34 g
/// each) joined by ball joints, hanging from the world at the origin and laid out
/// horizontally along `−x`, released at rest under gravity `(0, 0, −9.81)`. The last
/// link's mass and inertia are multiplied by `tip_ratio` (1 for a uniform chain).
///
/// Each link's inertia is a solid cylinder's about its centre (`m(3r² + L²)/12`
/// across, `m r²/2` along).
pub fn ball_chain(links: usize, tip_ratio: f64) -> Result<World, ArticulatedError> {
    let (len, r, rho) = (0.1, 0.01, 1000.0);
    let m = rho * core::f64::consts::PI * r * r * len;
    let across = m * (3.0 * r * r + len * len) / 12.0;
    let along = m * r * r / 2.0;
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let mut poses: Vec<Pose> = Vec::with_capacity(links);
    for i in 0..links {
        let s = if i + 1 == links { tip_ratio } else { 1.0 };
        let pose = Pose {
            x: DVec3::new(-(i as f64 + 0.5) * len, 0.0, 0.0),
            q: DQuat::IDENTITY,
        };
        let inertia = DMat3::from_diagonal(DVec3::new(along, across, across) * s);
        w.add_body(RigidBody::new(i, m * s, inertia, pose)?)?;
        poses.push(pose);
    }
    for i in 0..links {
        let parent = i.checked_sub(1);
        let pa = parent.map_or(Pose::IDENTITY, |p| poses[p]);
        let anchor = DVec3::new(-(i as f64) * len, 0.0, 0.0);
        let sph = Spherical::from_world(&pa, &poses[i], anchor)
            .map_err(|error| ArticulatedError::Constraint { joint: i, error })?;
        w.add_joint(Joint {
            parent,
            child: i,
            kind: JointKind::Spherical(sph),
            damping: 0.0,
        })?;
    }
    Ok(w)
}

/// A chain of `links` capsules (length 0.1 m between the joints, radius 0.01 m, about
/// 34 g each, as [`ball_chain`]) joined by ball joints, its root link free (no joint to
/// the world), laid out along `−x` with its axis at height `z0` above a floor plane
/// `z = 0` (collider 0, friction `mu`), at rest under gravity `(0, 0, −9.81)`. With
/// `z0 = 0.01` every link rests on the floor; higher, the chain falls onto it. Each link
/// carries a capsule collider along its axis (adjacent links are joined, so they never
/// collide with each other).
#[cfg(feature = "contact")]
pub fn chain_on_floor(links: usize, z0: f64, mu: f64) -> Result<World, ArticulatedError> {
    use constraint_contact::geometry::{Collider, Shape};
    let (len, r, rho) = (0.1, 0.01, 1000.0);
    let m = rho * core::f64::consts::PI * r * r * len;
    let across = m * (3.0 * r * r + len * len) / 12.0;
    let along = m * r * r / 2.0;
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let geometry = |e| ArticulatedError::Geometry {
        collider: 0,
        error: e,
    };
    let floor = Shape::plane(DVec3::Z, 0.0).map_err(geometry)?;
    w.add_collider(Collider::new(None, floor, Pose::IDENTITY, mu, 0.0).map_err(geometry)?)?;
    let mut poses: Vec<Pose> = Vec::with_capacity(links);
    // Capsules lie along x: rotate the shape's z axis onto x.
    let along_x = DQuat::from_rotation_y(core::f64::consts::FRAC_PI_2);
    let capsule = Shape::capsule(r, 0.5 * len - r).map_err(geometry)?;
    for i in 0..links {
        let pose = Pose {
            x: DVec3::new(-(i as f64 + 0.5) * len, 0.0, z0),
            q: DQuat::IDENTITY,
        };
        let inertia = DMat3::from_diagonal(DVec3::new(along, across, across));
        let b = w.add_body(RigidBody::new(i, m, inertia, pose)?)?;
        let local = Pose {
            x: DVec3::ZERO,
            q: along_x,
        };
        w.add_collider(Collider::new(Some(b), capsule, local, mu, 0.0).map_err(geometry)?)?;
        poses.push(pose);
    }
    for i in 1..links {
        let anchor = DVec3::new(-(i as f64) * len, 0.0, z0);
        let sph = Spherical::from_world(&poses[i - 1], &poses[i], anchor).map_err(|error| {
            ArticulatedError::Constraint {
                joint: i - 1,
                error,
            }
        })?;
        w.add_joint(Joint {
            parent: Some(i - 1),
            child: i,
            kind: JointKind::Spherical(sph),
            damping: 0.0,
        })?;
    }
    Ok(w)
}
