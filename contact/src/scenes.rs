//! Contact scenes built in Rust (tests, benchmarks and the report).

use constraint_core::{DMat3, DQuat, DVec3, Pose, RigidBody};

use crate::geometry::{Collider, Shape};
use crate::rigid::{ContactError, ContactWorld};

fn body(i: usize, mass: f64, inertia: DVec3, x: DVec3) -> Result<RigidBody, ContactError> {
    RigidBody::new(
        i,
        mass,
        DMat3::from_diagonal(inertia),
        Pose {
            x,
            q: DQuat::IDENTITY,
        },
    )
    .map_err(ContactError::Body)
}

/// Solid box inertia `m (b² + c²)/12, …` from half extents.
pub fn box_inertia(mass: f64, half: DVec3) -> DVec3 {
    let s = half * 2.0;
    DVec3::new(
        s.y * s.y + s.z * s.z,
        s.x * s.x + s.z * s.z,
        s.x * s.x + s.y * s.y,
    ) * (mass / 12.0)
}

/// The ground: a static plane `z = 0` with friction `mu`.
pub fn ground(w: &mut ContactWorld, mu: f64) -> Result<usize, ContactError> {
    let plane = Shape::plane(DVec3::Z, 0.0).map_err(ContactError::Geometry)?;
    w.add_collider(
        Collider::simple(None, plane)
            .map_err(ContactError::Geometry)?
            .with_material(mu, 0.0)
            .map_err(ContactError::Geometry)?,
    )
}

/// Adds a box of half extents `half`, density 1000 unless `mass` is given, at `x`.
pub fn add_box(
    w: &mut ContactWorld,
    half: DVec3,
    mass: Option<f64>,
    x: DVec3,
    mu: f64,
) -> Result<usize, ContactError> {
    let m = mass.unwrap_or(1000.0 * 8.0 * half.x * half.y * half.z);
    let i = w.bodies().len();
    let b = w.add_body(body(i, m, box_inertia(m, half), x)?)?;
    let shape = Shape::cuboid(half).map_err(ContactError::Geometry)?;
    w.add_collider(
        Collider::simple(Some(b), shape)
            .map_err(ContactError::Geometry)?
            .with_material(mu, 0.0)
            .map_err(ContactError::Geometry)?,
    )?;
    Ok(b)
}

/// `n` unit boxes (1 m, 1000 kg) stacked on the ground, friction 0.5, each resting
/// exactly on the one below.
pub fn box_stack(n: usize) -> Result<ContactWorld, ContactError> {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
    ground(&mut w, 0.5)?;
    for k in 0..n {
        add_box(
            &mut w,
            DVec3::splat(0.5),
            None,
            DVec3::new(0.0, 0.0, 0.5 + k as f64),
            0.5,
        )?;
    }
    Ok(w)
}

/// A pyramid of unit boxes in the x–z plane with `base` boxes in its bottom row (a
/// row of `base − k` boxes at level `k`), 0.1 m gaps between neighbours' sides.
pub fn pyramid(base: usize) -> Result<ContactWorld, ContactError> {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
    ground(&mut w, 0.5)?;
    let pitch = 1.1;
    for level in 0..base {
        let count = base - level;
        let x0 = -(count as f64 - 1.0) * 0.5 * pitch;
        for k in 0..count {
            let x = DVec3::new(x0 + k as f64 * pitch, 0.0, 0.5 + level as f64);
            add_box(&mut w, DVec3::splat(0.5), None, x, 0.5)?;
        }
    }
    Ok(w)
}

/// A heavy box on a light one (issue 14's mass-ratio test): a 0.5 m box of 125 kg
/// (density 1000) on the ground, and on it, exactly touching, a unit box `ratio` times
/// heavier; friction 0.5.
pub fn heavy_on_light(ratio: f64) -> Result<ContactWorld, ContactError> {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
    ground(&mut w, 0.5)?;
    let light = add_box(
        &mut w,
        DVec3::splat(0.25),
        None,
        DVec3::new(0.0, 0.0, 0.25),
        0.5,
    )?;
    let m = ratio * w.bodies()[light].mass();
    add_box(
        &mut w,
        DVec3::splat(0.5),
        Some(m),
        DVec3::new(0.0, 0.0, 1.0),
        0.5,
    )?;
    Ok(w)
}

/// A sphere of radius `r` (density 1000) dropped from height `z` onto the ground.
pub fn sphere_drop(r: f64, z: f64) -> Result<ContactWorld, ContactError> {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
    ground(&mut w, 0.5)?;
    let m = 1000.0 * 4.0 / 3.0 * core::f64::consts::PI * r * r * r;
    let b = w.add_body(body(
        0,
        m,
        DVec3::splat(0.4 * m * r * r),
        DVec3::new(0.0, 0.0, z),
    )?)?;
    let shape = Shape::sphere(r).map_err(ContactError::Geometry)?;
    w.add_collider(Collider::simple(Some(b), shape).map_err(ContactError::Geometry)?)?;
    Ok(w)
}
