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

/// SplitMix64 (Steele et al. 2014): the pile's seeded, platform-independent numbers.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// A uniformly distributed unit quaternion (Shoemake 1992).
    fn rotation(&mut self) -> DQuat {
        let (u1, u2, u3) = (
            self.range(0.0, 1.0),
            self.range(0.0, core::f64::consts::TAU),
            self.range(0.0, core::f64::consts::TAU),
        );
        let (a, b) = (libm::sqrt(1.0 - u1), libm::sqrt(u1));
        DQuat::from_xyzw(
            a * libm::sin(u2),
            a * libm::cos(u2),
            b * libm::sin(u3),
            b * libm::cos(u3),
        )
        .normalize()
    }
}

/// Spacing of the pile's pouring lattice (m): no two shapes overlap at the start (the
/// largest shape reaches 0.52 m from its centre).
pub const PILE_PITCH: f64 = 1.1;

/// Layers of the pile's pouring lattice: the container's floor grows with the body
/// count, so the pile's height (and each body's neighbourhood) does not.
pub const PILE_LAYERS: usize = 8;

/// Inner side of the square container of [`pile`]`(n, …)` (m).
pub fn pile_side(n: usize) -> f64 {
    let cols = libm::ceil(libm::sqrt(n as f64 / PILE_LAYERS as f64)).max(1.0);
    cols * PILE_PITCH
}

/// `n` bodies poured into a container (issue 14's pile): a square box open at the top,
/// inner side [`pile_side`]`(n)`, made of the ground plane and four wall planes (static,
/// friction 0.5). The bodies cycle through boxes (half extents 0.15–0.3 m), spheres
/// (radius 0.15–0.3 m) and capsules (radius 0.1–0.2 m, half length 0.1–0.25 m), all of
/// density 1000 kg/m³, friction 0.5, randomly oriented, on a lattice of
/// [`PILE_LAYERS`] layers at [`PILE_PITCH`] starting 0.6 m above the floor, with a
/// horizontal velocity of up to 1 m/s each: they fall, collide and settle. Sizes,
/// orientations and velocities come from `seed` (SplitMix64, the same on every
/// platform).
pub fn pile(n: usize, seed: u64) -> Result<ContactWorld, ContactError> {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
    ground(&mut w, 0.5)?;
    let side = pile_side(n);
    let cols = libm::round(side / PILE_PITCH) as usize;
    let half = 0.5 * side;
    // Walls: x ≥ −half, x ≤ half, y ≥ −half, y ≤ half (outward normals into the box).
    for normal in [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y] {
        let plane = Shape::plane(normal, -half).map_err(ContactError::Geometry)?;
        w.add_collider(
            Collider::simple(None, plane)
                .map_err(ContactError::Geometry)?
                .with_material(0.5, 0.0)
                .map_err(ContactError::Geometry)?,
        )?;
    }
    let mut rng = SplitMix(seed);
    let x0 = -half + 0.5 * PILE_PITCH;
    for k in 0..n {
        let (layer, cell) = (k / (cols * cols), k % (cols * cols));
        let x = DVec3::new(
            x0 + (cell % cols) as f64 * PILE_PITCH,
            x0 + (cell / cols) as f64 * PILE_PITCH,
            0.6 + layer as f64 * PILE_PITCH,
        );
        let q = rng.rotation();
        let (shape, m, inertia) = match k % 3 {
            0 => {
                let h = DVec3::new(
                    rng.range(0.15, 0.3),
                    rng.range(0.15, 0.3),
                    rng.range(0.15, 0.3),
                );
                let m = 1000.0 * 8.0 * h.x * h.y * h.z;
                (Shape::cuboid(h), m, box_inertia(m, h))
            }
            1 => {
                let r = rng.range(0.15, 0.3);
                let m = 1000.0 * 4.0 / 3.0 * core::f64::consts::PI * r * r * r;
                (Shape::sphere(r), m, DVec3::splat(0.4 * m * r * r))
            }
            _ => {
                let r = rng.range(0.1, 0.2);
                let hl = rng.range(0.1, 0.25);
                let (m, inertia) = capsule_mass(1000.0, r, hl);
                (Shape::capsule(r, hl), m, inertia)
            }
        };
        let shape = shape.map_err(ContactError::Geometry)?;
        let mut b = RigidBody::new(k, m, DMat3::from_diagonal(inertia), Pose { x, q })
            .map_err(ContactError::Body)?;
        b.v = DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0);
        let i = w.add_body(b)?;
        w.add_collider(
            Collider::simple(Some(i), shape)
                .map_err(ContactError::Geometry)?
                .with_material(0.5, 0.0)
                .map_err(ContactError::Geometry)?,
        )?;
    }
    Ok(w)
}

/// Mass and principal inertia (axis `z`) of a capsule of `density`, radius `r` and
/// core half length `hl`: a cylinder of length `2 hl` and two hemispheres (the
/// hemispheres' centres of mass `3r/8` beyond the core's ends, parallel axes).
pub fn capsule_mass(density: f64, r: f64, hl: f64) -> (f64, DVec3) {
    let pi = core::f64::consts::PI;
    let len = 2.0 * hl;
    let mc = density * pi * r * r * len;
    let ms = density * 4.0 / 3.0 * pi * r * r * r;
    let axial = mc * r * r / 2.0 + ms * 2.0 * r * r / 5.0;
    let across = mc * (len * len / 12.0 + r * r / 4.0)
        + ms * (2.0 * r * r / 5.0 + hl * hl + 3.0 * hl * r / 4.0);
    (mc + ms, DVec3::new(across, across, axial))
}
