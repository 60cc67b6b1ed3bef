//! Point-on-plane constraint.
//!
//! The signed distance of the lecture's contact slide, `d_i = nᵀ(p_i − p)`
//! ("Contacto mediante restricciones"), used as an equality:
//!
//! ```text
//! C(x) = nᵀ(x − p) = nᵀx − nᵀp,   ∂C/∂x = n,   ∂²C/∂x² = 0
//! ```
//!
//! `n` is normalised at construction, so `C` is a distance in metres. The contact crate
//! uses the same function as the unilateral constraint `C ≥ 0`.

use crate::constraint::{Curvature, Jacobian, PointConstraint};
use crate::error::ConstraintError;
use glam::DVec3;

/// `C = nᵀ(x − p)` for one point `x`, plane through `p` with unit normal `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointOnPlane {
    /// The constrained point.
    pub point: usize,
    /// Unit normal `n`.
    pub normal: DVec3,
    /// `nᵀp` for a point `p` of the plane.
    pub offset: f64,
}

impl PointOnPlane {
    /// The plane through `origin` with normal direction `normal` (normalised here).
    ///
    /// # Errors
    /// `NonFinite` for non-finite input, `ZeroNormal` when `|normal|` is zero or
    /// underflows.
    pub fn new(point: usize, origin: DVec3, normal: DVec3) -> Result<Self, ConstraintError> {
        if !(origin.is_finite() && normal.is_finite()) {
            return Err(ConstraintError::NonFinite);
        }
        let len = normal.length();
        if len.is_nan() || len <= f64::MIN_POSITIVE || !len.is_finite() {
            return Err(ConstraintError::ZeroNormal);
        }
        let n = normal / len;
        let offset = n.dot(origin);
        if !offset.is_finite() {
            return Err(ConstraintError::NonFinite);
        }
        Ok(Self {
            point,
            normal: n,
            offset,
        })
    }
}

impl PointConstraint<1, 1> for PointOnPlane {
    #[inline]
    fn stencil(&self) -> [usize; 1] {
        [self.point]
    }

    #[inline]
    fn value(&self, x: &[DVec3; 1]) -> [f64; 1] {
        [self.normal.dot(x[0]) - self.offset]
    }

    #[inline]
    fn jacobian(&self, x: &[DVec3; 1]) -> Jacobian<1, 1> {
        Jacobian {
            value: self.value(x),
            grad: [[self.normal]],
        }
    }

    #[inline]
    fn curvature(&self, _x: &[DVec3; 1], _w: &[f64; 1]) -> Curvature<1> {
        Curvature::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_distance() {
        let c = PointOnPlane::new(0, DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, 2.0)).unwrap();
        assert_eq!(c.value(&[DVec3::new(5.0, 1.0, 3.0)]), [2.0]);
        assert_eq!(c.jacobian(&[DVec3::ZERO]).grad, [[DVec3::Z]]);
    }

    #[test]
    fn rejects_zero_and_nan_normals() {
        assert_eq!(
            PointOnPlane::new(0, DVec3::ZERO, DVec3::ZERO),
            Err(ConstraintError::ZeroNormal)
        );
        assert_eq!(
            PointOnPlane::new(0, DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 1.0)),
            Err(ConstraintError::NonFinite)
        );
        assert_eq!(
            PointOnPlane::new(0, DVec3::ZERO, DVec3::splat(1e-320)),
            Err(ConstraintError::ZeroNormal)
        );
    }
}
