//! Mass and inertia from geoms (MuJoCo `mjCGeom::GetVolume`, `mjCGeom::SetInertia`,
//! `mjCBody::InertiaFromGeom`), for solid ("volume") geoms.

use crate::math::{self, M3, Q, V3};
use crate::model::Primitive;

/// Volume of a shape (planes have none).
pub fn volume(shape: &Primitive) -> f64 {
    use std::f64::consts::PI;
    match *shape {
        Primitive::Plane { .. } => 0.0,
        Primitive::Sphere { radius } => 4.0 * PI * radius * radius * radius / 3.0,
        Primitive::Box { half } => 8.0 * half[0] * half[1] * half[2],
        Primitive::Cylinder {
            radius,
            half_length,
        } => PI * radius * radius * 2.0 * half_length,
        Primitive::Ellipsoid { radii } => 4.0 * PI * radii[0] * radii[1] * radii[2] / 3.0,
        Primitive::Capsule {
            radius,
            half_length,
        } => {
            let height = 2.0 * half_length;
            PI * (radius * radius * height + 4.0 * radius * radius * radius / 3.0)
        }
    }
}

/// Principal moments of inertia about the geom's centre, along the geom axes, for a
/// solid of the given mass.
///
/// - sphere `2/5 m r²`;
/// - box (half sizes `a, b, c`) `m/3 (b² + c²)` and cyclic;
/// - capsule: a cylinder of height `h = 2·half_length` plus two hemispheres, the mass
///   split by volume (`m_s = m·4r/(4r + 3h)`): `I_xx = m_c (3r² + h²)/12 + 2/5 m_s r² +
///   m_s h (3r + 2h)/8`, `I_zz = m_c r²/2 + 2/5 m_s r²` (MuJoCo's formula, which places
///   each hemisphere's mass at its centroid `3r/8` beyond the cylinder end);
/// - cylinder (height `h`): `I_xx = m (3r² + h²)/12`, `I_zz = m r²/2`;
/// - ellipsoid (semi-axes `a, b, c`): `m/5 (b² + c²)` and cyclic.
pub fn principal(shape: &Primitive, mass: f64) -> V3 {
    match *shape {
        Primitive::Plane { .. } => [0.0; 3],
        Primitive::Sphere { radius } => [2.0 * mass * radius * radius / 5.0; 3],
        Primitive::Cylinder {
            radius,
            half_length,
        } => {
            let h = 2.0 * half_length;
            let x = mass * (3.0 * radius * radius + h * h) / 12.0;
            [x, x, mass * radius * radius / 2.0]
        }
        Primitive::Ellipsoid { radii } => {
            let [a, b, c] = radii;
            [
                mass * (b * b + c * c) / 5.0,
                mass * (a * a + c * c) / 5.0,
                mass * (a * a + b * b) / 5.0,
            ]
        }
        Primitive::Box { half } => {
            let [a, b, c] = half;
            [
                mass * (b * b + c * c) / 3.0,
                mass * (a * a + c * c) / 3.0,
                mass * (a * a + b * b) / 3.0,
            ]
        }
        Primitive::Capsule {
            radius,
            half_length,
        } => {
            let height = 2.0 * half_length;
            let sphere_mass = mass * 4.0 * radius / (4.0 * radius + 3.0 * height);
            let cylinder_mass = mass - sphere_mass;
            let mut i = [0.0; 3];
            i[0] = cylinder_mass * (3.0 * radius * radius + height * height) / 12.0;
            i[1] = i[0];
            i[2] = cylinder_mass * radius * radius / 2.0;
            let sphere_inertia = 2.0 * sphere_mass * radius * radius / 5.0;
            let shift = sphere_mass * height * (3.0 * radius + 2.0 * height) / 8.0;
            i[0] += sphere_inertia + shift;
            i[1] += sphere_inertia + shift;
            i[2] += sphere_inertia;
            i
        }
    }
}

/// A geom's mass properties in its body's frame.
#[derive(Clone, Copy, Debug)]
pub struct GeomMass {
    /// Mass.
    pub mass: f64,
    /// Geom position in the body frame (its centre of mass).
    pub pos: V3,
    /// Geom orientation in the body frame.
    pub quat: Q,
    /// Principal inertia along the geom axes.
    pub inertia: V3,
}

/// Combined mass, centre of mass and inertia about it (in the body frame) of several
/// geoms; geoms of mass `≤ 1e-14` are skipped as in MuJoCo. `None` when none count.
pub fn combine(geoms: &[GeomMass]) -> Option<(f64, V3, M3)> {
    let sel: Vec<&GeomMass> = geoms.iter().filter(|g| g.mass > math::EPS).collect();
    match sel.as_slice() {
        [] => None,
        [g] => Some((g.mass, g.pos, math::rotate_diag(g.quat, g.inertia))),
        _ => {
            let mass: f64 = sel.iter().map(|g| g.mass).sum();
            let mut com = [0.0; 3];
            for g in &sel {
                com = math::add(com, math::scale(g.pos, g.mass));
            }
            let com = math::scale(com, 1.0 / mass);
            let mut total = [[0.0; 3]; 3];
            for g in &sel {
                let rot = math::rotate_diag(g.quat, g.inertia);
                let off = parallel_axis(g.mass, math::sub(g.pos, com));
                for r in 0..3 {
                    for c in 0..3 {
                        total[r][c] += rot[r][c] + off[r][c];
                    }
                }
            }
            Some((mass, com, total))
        }
    }
}

/// Inertia of a point mass at offset `d`: `m (|d|² I − d dᵀ)`.
pub fn parallel_axis(mass: f64, d: V3) -> M3 {
    let dd = math::dot(d, d);
    let mut out = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            let delta = if r == c { dd } else { 0.0 };
            out[r][c] = mass * (delta - d[r] * d[c]);
        }
    }
    out
}
