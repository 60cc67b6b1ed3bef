//! Shapes, colliders (a shape placed on a body) and their world-space bounding boxes.
//!
//! A [`Collider`] carries a [`Shape`] in its own frame, the pose of that frame in the
//! frame of its body ([`Collider::local`]), the body it rides on (`None` for the static
//! world) and its surface parameters. Every geometric query takes the *body* pose
//! (centre of mass and orientation, [`Pose::IDENTITY`] for world colliders); the
//! collider's frame in the world is `body ∘ local` ([`Collider::world_pose`]).

use core::fmt;

use constraint_core::Pose;
use glam::{DMat3, DQuat, DVec3};

/// Why a shape, collider or scene was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeometryError {
    /// A size, position, orientation or parameter was NaN or infinite.
    NonFinite,
    /// A radius or half extent was zero or negative (a capsule's half length may be
    /// zero, not negative).
    NonPositiveSize,
    /// A plane normal had (numerically) zero length.
    ZeroNormal,
    /// An offset orientation was not a unit quaternion (to within 1e-6).
    NonUnitQuaternion,
    /// The friction coefficient was negative.
    NegativeFriction,
    /// The restitution coefficient was outside `[0, 1]`.
    RestitutionOutOfRange,
    /// A collider names a body beyond the end of the body poses given.
    BodyOutOfRange {
        /// Index of the collider.
        collider: usize,
        /// The body index it names.
        body: usize,
    },
    /// A contact margin was negative or non-finite.
    BadMargin,
    /// A pair mask's size does not match the colliders
    /// ([`super::masked::generate_contacts_masked`]), or a pair names a collider beyond
    /// it ([`super::masked::PairMask::allow`]).
    PairMaskSize {
        /// The number of colliders of the mask.
        mask: usize,
        /// The number of colliders given (or the index named).
        colliders: usize,
    },
}

impl fmt::Display for GeometryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite => f.write_str("non-finite input (NaN or infinity)"),
            Self::NonPositiveSize => f.write_str("shape sizes must be positive"),
            Self::ZeroNormal => f.write_str("plane normal has zero length"),
            Self::NonUnitQuaternion => f.write_str("offset orientation is not a unit quaternion"),
            Self::NegativeFriction => f.write_str("friction coefficient is negative"),
            Self::RestitutionOutOfRange => f.write_str("restitution must lie in [0, 1]"),
            Self::BodyOutOfRange { collider, body } => write!(
                f,
                "collider {collider} is attached to body {body}, beyond the poses given"
            ),
            Self::BadMargin => f.write_str("contact margin must be finite and non-negative"),
            Self::PairMaskSize { mask, colliders } => write!(
                f,
                "pair mask over {mask} colliders used with {colliders} (or collider index {colliders})"
            ),
        }
    }
}

impl core::error::Error for GeometryError {}

/// A collision shape in its own frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The half-space `{ y : normalᵀy ≤ offset }` (solid below, free space on the side
    /// `normal` points to); its surface is `normalᵀy = offset`. `normal` is unit.
    /// Normally static (`body: None`), but it may ride on a body.
    Plane {
        /// Outward unit normal (pointing out of the solid).
        normal: DVec3,
        /// Signed distance of the surface from the frame origin along `normal`.
        offset: f64,
    },
    /// A ball centred at the frame origin.
    Sphere {
        /// Radius (> 0).
        radius: f64,
    },
    /// A box centred at the frame origin with faces normal to the frame axes.
    Box {
        /// Half extents along the frame axes (each > 0).
        half: DVec3,
    },
    /// The set of points within `radius` of the segment from `−half_length·z` to
    /// `+half_length·z` (frame `z` axis).
    Capsule {
        /// Radius (> 0).
        radius: f64,
        /// Half the length of the core segment (≥ 0; zero gives a sphere).
        half_length: f64,
    },
}

impl Shape {
    /// A half-space with outward `normal` and surface `normalᵀy = offset`; both are
    /// divided by `|normal|`, so the plane is the one given even for a non-unit normal.
    pub fn plane(normal: DVec3, offset: f64) -> Result<Self, GeometryError> {
        if !normal.is_finite() || !offset.is_finite() {
            return Err(GeometryError::NonFinite);
        }
        let len = normal.length();
        if !(len > 1e-12) {
            return Err(GeometryError::ZeroNormal);
        }
        // `normalᵀy = offset` with the normal scaled to unit length.
        Ok(Self::Plane {
            normal: normal / len,
            offset: offset / len,
        })
    }

    /// A sphere of the given radius.
    pub fn sphere(radius: f64) -> Result<Self, GeometryError> {
        let s = Self::Sphere { radius };
        s.validate()?;
        Ok(s)
    }

    /// A box with the given half extents.
    pub fn cuboid(half: DVec3) -> Result<Self, GeometryError> {
        let s = Self::Box { half };
        s.validate()?;
        Ok(s)
    }

    /// A capsule along the frame `z` axis.
    pub fn capsule(radius: f64, half_length: f64) -> Result<Self, GeometryError> {
        let s = Self::Capsule {
            radius,
            half_length,
        };
        s.validate()?;
        Ok(s)
    }

    /// Radius of the smallest sphere about the shape's frame origin that holds it
    /// (infinite for a plane): `r` for a sphere, `|half|` for a box, `half_length + r`
    /// for a capsule.
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            Self::Plane { .. } => f64::INFINITY,
            Self::Sphere { radius } => radius,
            Self::Box { half } => half.length(),
            Self::Capsule {
                radius,
                half_length,
            } => half_length + radius,
        }
    }

    /// Checks sizes (finite, positive) and, for a plane, that the normal is unit (to within
    /// 1e-9; [`Shape::plane`] normalises it).
    pub fn validate(&self) -> Result<(), GeometryError> {
        match *self {
            Self::Plane { normal, offset } => {
                if !normal.is_finite() || !offset.is_finite() {
                    return Err(GeometryError::NonFinite);
                }
                if (normal.length() - 1.0).abs() > 1e-9 {
                    return Err(GeometryError::ZeroNormal);
                }
            }
            Self::Sphere { radius } => positive(radius)?,
            Self::Box { half } => {
                positive(half.x)?;
                positive(half.y)?;
                positive(half.z)?;
            }
            Self::Capsule {
                radius,
                half_length,
            } => {
                positive(radius)?;
                if !half_length.is_finite() {
                    return Err(GeometryError::NonFinite);
                }
                if half_length < 0.0 {
                    return Err(GeometryError::NonPositiveSize);
                }
            }
        }
        Ok(())
    }
}

fn positive(v: f64) -> Result<(), GeometryError> {
    if !v.is_finite() {
        Err(GeometryError::NonFinite)
    } else if !(v > 0.0) {
        Err(GeometryError::NonPositiveSize)
    } else {
        Ok(())
    }
}

/// A shape placed on a body, with its surface parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collider {
    /// The body it is attached to; `None` for the static world.
    pub body: Option<usize>,
    /// The shape, in the collider frame.
    pub shape: Shape,
    /// Pose of the collider frame in the body frame (offset from the centre of mass and
    /// rotation); [`Pose::IDENTITY`] to centre the shape on the body.
    pub local: Pose,
    /// Coulomb friction coefficient (≥ 0).
    pub friction: f64,
    /// Restitution coefficient (in `[0, 1]`).
    pub restitution: f64,
}

impl Collider {
    /// A collider, validated: finite unit offset pose, valid shape, `friction ≥ 0`,
    /// `restitution ∈ [0, 1]`.
    pub fn new(
        body: Option<usize>,
        shape: Shape,
        local: Pose,
        friction: f64,
        restitution: f64,
    ) -> Result<Self, GeometryError> {
        shape.validate()?;
        if !local.x.is_finite() || !local.q.is_finite() {
            return Err(GeometryError::NonFinite);
        }
        if (local.q.length() - 1.0).abs() > 1e-6 {
            return Err(GeometryError::NonUnitQuaternion);
        }
        if !friction.is_finite() || !restitution.is_finite() {
            return Err(GeometryError::NonFinite);
        }
        if friction < 0.0 {
            return Err(GeometryError::NegativeFriction);
        }
        if !(0.0..=1.0).contains(&restitution) {
            return Err(GeometryError::RestitutionOutOfRange);
        }
        Ok(Self {
            body,
            shape,
            local,
            friction,
            restitution,
        })
    }

    /// A collider centred on its body (or at the world origin), friction 0.5,
    /// restitution 0.
    pub fn simple(body: Option<usize>, shape: Shape) -> Result<Self, GeometryError> {
        Self::new(body, shape, Pose::IDENTITY, 0.5, 0.0)
    }

    /// The same collider with another offset pose (validated).
    pub fn with_local(self, x: DVec3, q: DQuat) -> Result<Self, GeometryError> {
        Self::new(
            self.body,
            self.shape,
            Pose { x, q },
            self.friction,
            self.restitution,
        )
    }

    /// The same collider with other surface parameters (validated).
    pub fn with_material(self, friction: f64, restitution: f64) -> Result<Self, GeometryError> {
        Self::new(self.body, self.shape, self.local, friction, restitution)
    }

    /// The collider frame in the world: `body ∘ local`.
    #[inline]
    pub fn world_pose(&self, body: &Pose) -> Pose {
        Pose {
            x: body.x + body.q * self.local.x,
            q: body.q * self.local.q,
        }
    }

    /// World-space bounding box for the body pose `body`, grown by `margin` on every side.
    /// A plane's box is unbounded except, for an axis-aligned normal, on its free side.
    pub fn aabb(&self, body: &Pose, margin: f64) -> Aabb {
        let w = self.world_pose(body);
        self.aabb_framed(&w, &self.rotation(&w), margin)
    }

    /// The rotation matrix of the collider frame `w` for a box (whose bounding box and
    /// narrow phase use it), the identity for other shapes (which never read it).
    #[inline]
    pub(crate) fn rotation(&self, w: &Pose) -> DMat3 {
        match self.shape {
            Shape::Box { .. } => DMat3::from_quat(w.q),
            _ => DMat3::IDENTITY,
        }
    }

    /// [`Collider::aabb`] from the collider frame `w` ([`Collider::world_pose`]) and its
    /// [`Collider::rotation`] `rot`: the same box, the frame computed once per step for
    /// the bounding box and the narrow phase. Always inlined: out of line, its frame
    /// (built just before the call, stored 8 and 16 bytes at a time) was read back 16
    /// bytes across two stores, and its box (stored by the callee) read back the same
    /// way, two store-forwarding stalls a collider (a quarter of its wall-time samples
    /// on the 10-box stack, `perf record`).
    #[inline(always)]
    pub(crate) fn aabb_framed(&self, w: &Pose, rot: &DMat3, margin: f64) -> Aabb {
        let m = DVec3::splat(margin);
        match self.shape {
            Shape::Sphere { radius } => {
                let r = DVec3::splat(radius) + m;
                Aabb {
                    min: w.x - r,
                    max: w.x + r,
                }
            }
            Shape::Box { half } => {
                let e = DVec3::new(
                    rot.row(0).abs().dot(half),
                    rot.row(1).abs().dot(half),
                    rot.row(2).abs().dot(half),
                ) + m;
                Aabb {
                    min: w.x - e,
                    max: w.x + e,
                }
            }
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let e = rotated_z(w.q, half_length).abs() + DVec3::splat(radius) + m;
                Aabb {
                    min: w.x - e,
                    max: w.x + e,
                }
            }
            Shape::Plane { normal, offset } => {
                let n = w.q * normal;
                let d = offset + n.dot(w.x);
                let mut b = Aabb {
                    min: DVec3::splat(f64::NEG_INFINITY),
                    max: DVec3::splat(f64::INFINITY),
                };
                for k in 0..3 {
                    if n[k] == 1.0 {
                        b.max[k] = d + margin;
                    } else if n[k] == -1.0 {
                        b.min[k] = -d - margin;
                    }
                }
                b
            }
        }
    }
}

/// `q (0, 0, h)` as the rotation `q v = (w² − b·b) v + 2 (v·b) b +
/// 2 w (b × v)` (`b` the vector part; glam's `DQuat * DVec3`) computes it for
/// `v = (0, 0, h)`, with the products by the zero components left out: each one is a
/// zero added to a non-zero term (exact) or to zeros, so the components differ at most
/// in the sign of a zero, which the caller's `abs` drops: `rotated_z(q, h).abs()` has
/// the bits of `(q * DVec3::new(0.0, 0.0, h)).abs()` for finite `q`, `h`, in 19
/// operations instead of 33 (a capsule's bounding box, every collider every call).
#[inline]
fn rotated_z(q: DQuat, h: f64) -> DVec3 {
    let (x, y, z, w) = (q.x, q.y, q.z, q.w);
    let b2 = x * x + y * y + z * z;
    let d2 = (h * z) * 2.0;
    let w2 = w * 2.0;
    DVec3::new(
        x * d2 + (y * h) * w2,
        y * d2 - (x * h) * w2,
        h * (w * w - b2) + z * d2,
    )
}

/// An axis-aligned bounding box in world coordinates (`min ≤ max` componentwise; bounds
/// may be infinite for planes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
}

impl Aabb {
    /// A box from its corners.
    #[inline]
    pub const fn new(min: DVec3, max: DVec3) -> Self {
        Self { min, max }
    }

    /// Whether the closed boxes overlap (touching counts).
    ///
    /// All six comparisons are made and combined with `&`, not `&&`: which of them
    /// fails first is data (the broad phase's candidates), and the short-circuit's
    /// branches were 18.1k of the 210-box pyramid's 534k simulated mispredicts in 60
    /// steps (cachegrind `--branch-sim`); the result is the same boolean.
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        (self.min.x <= other.max.x)
            & (other.min.x <= self.max.x)
            & (self.min.y <= other.max.y)
            & (other.min.y <= self.max.y)
            & (self.min.z <= other.max.z)
            & (other.min.z <= self.max.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`rotated_z`]'s absolute values are the bits of glam's rotation's: quaternions
    /// with zero and negative components (the axis turns, half turns, where the left-out
    /// products are signed zeros) and a spread of general ones, half lengths of both
    /// signs' magnitudes and zero.
    #[test]
    fn rotated_z_matches_the_rotation_bits() {
        let mut qs = vec![
            DQuat::IDENTITY,
            DQuat::from_xyzw(1.0, 0.0, 0.0, 0.0),
            DQuat::from_xyzw(0.0, -1.0, 0.0, 0.0),
            DQuat::from_xyzw(0.0, 0.0, 1.0, -0.0),
            DQuat::from_xyzw(-0.0, -0.0, -0.0, -1.0),
            DQuat::from_rotation_x(core::f64::consts::FRAC_PI_2),
            DQuat::from_rotation_y(-core::f64::consts::FRAC_PI_2),
            DQuat::from_rotation_z(0.3),
        ];
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let q = DQuat::from_xyzw(next(), next(), next(), next());
            qs.push(q.normalize());
        }
        for q in qs {
            for h in [0.0, 1e-300, 0.25, 1.0, 7.5e3] {
                let want = (q * DVec3::new(0.0, 0.0, h)).abs();
                let got = rotated_z(q, h).abs();
                for k in 0..3 {
                    assert_eq!(got[k].to_bits(), want[k].to_bits(), "{q:?} {h} axis {k}");
                }
            }
        }
    }
}
