//! Contact points: what the narrow phase hands to the solvers.
//!
//! # Sign convention
//!
//! The lecture writes the non-penetration constraint of a contact point as the gap
//! `d = nᵀ(p_i − p) ≥ 0`. Here `n` = [`Contact::normal`] points from collider `a` to
//! collider `b`, `p` is the witness point on `a`'s surface ([`Contact::point_on_a`]) and
//! `p_i` the witness point on `b`'s surface ([`Contact::point_on_b`]), so
//!
//! ```text
//! d = nᵀ(point_on_b − point_on_a) = −depth.
//! ```
//!
//! `depth > 0` is penetration; `depth < 0` is a separation (a *speculative* contact, only
//! reported while `−depth ≤ margin`, so the solver can act before the surfaces touch:
//! the velocity-level row is `nᵀ(v_b − v_a) ≥ −d/Δt = depth/Δt`).
//!
//! [`Contact::point`] is the midpoint of the two witness points: `point_on_a = point +
//! ½ depth n`, `point_on_b = point − ½ depth n`.

use glam::DVec3;

/// One contact point between two colliders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Index of the first collider.
    pub a: usize,
    /// Index of the second collider.
    pub b: usize,
    /// World-space midpoint between the witness points on the two surfaces.
    pub point: DVec3,
    /// Unit normal from `a` to `b` (pushing `b` along it separates the pair).
    pub normal: DVec3,
    /// Penetration depth (`> 0`), or minus the separation for a speculative contact
    /// (`< 0`); the lecture's gap is `d = −depth`.
    pub depth: f64,
    /// Feature id of the point within its pair, stable across frames while the same
    /// features touch; `(a, b, id)` identifies a point for warm starting.
    pub id: u64,
}

impl Contact {
    /// The lecture's gap `d = nᵀ(p_b − p_a) = −depth`.
    #[inline]
    pub fn gap(&self) -> f64 {
        -self.depth
    }

    /// Witness point on `a`'s surface: `point + ½ depth n`.
    #[inline]
    pub fn point_on_a(&self) -> DVec3 {
        self.point + self.normal * (0.5 * self.depth)
    }

    /// Witness point on `b`'s surface: `point − ½ depth n`.
    #[inline]
    pub fn point_on_b(&self) -> DVec3 {
        self.point - self.normal * (0.5 * self.depth)
    }

    /// A key for matching points across frames: `(a, b, id)`.
    #[inline]
    pub fn key(&self) -> (usize, usize, u64) {
        (self.a, self.b, self.id)
    }
}

/// A particle (a point with a radius, for cloth and jelly vertices) touching a collider.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleContact {
    /// Closest point on the collider's surface (world).
    pub surface: DVec3,
    /// Unit normal out of the collider, towards the particle.
    pub normal: DVec3,
    /// `radius − signed distance` of the particle centre from the surface: penetration
    /// when positive, minus the separation (down to `−margin`) when negative. The gap of
    /// the lecture is `d = nᵀ(p − surface) − radius = −depth`.
    pub depth: f64,
}
