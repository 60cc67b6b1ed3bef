//! Tetrahedron volume constraint.
//!
//! Otaduy 2010, "Fuerzas de Restricción — simulación de sólidos: mallar mediante
//! tetraedros y formular restricciones que conserven el volumen de los tetraedros"
//! (and Irving et al. 2007 on the applications slide):
//!
//! ```text
//! C(x) = V(x) − V₀,   V = ⅙ e₁ · (e₂ × e₃),   eᵢ = xᵢ − x₀
//! ∂V/∂e₁ = ⅙ e₂ × e₃,   ∂V/∂e₂ = ⅙ e₃ × e₁,   ∂V/∂e₃ = ⅙ e₁ × e₂,   ∂V/∂x₀ = −Σ
//! ∂²V/∂e₁∂e₂ = −⅙[e₃]×,  ∂²V/∂e₁∂e₃ = ⅙[e₂]×,  ∂²V/∂e₂∂e₃ = −⅙[e₁]×,  diagonal 0
//! ```
//!
//! `V` is a cubic polynomial of the positions, so evaluation has no degenerate case:
//! a flat or inverted current tetrahedron simply has `V ≤ 0` and a well-defined
//! gradient (zero only when all four points coincide).

use crate::constraint::{Curvature, Jacobian, PointConstraint};
use crate::error::ConstraintError;
use crate::math::{all_finite, distinct, lift_edge_hessian, skew};
use glam::{DMat3, DVec3};

/// Rest tetrahedra with `|V| ≤ FLAT_TOL · (longest edge)³` are rejected as flat.
pub const FLAT_TOL: f64 = 1e-10;

/// `C = V(x) − V₀` for the tetrahedron `(x₀, x₁, x₂, x₃)` (positive when `x₃` lies on
/// the side of `(x₁ − x₀) × (x₂ − x₀)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Volume {
    /// The four corners.
    pub points: [usize; 4],
    /// Rest volume `V₀ > 0`.
    pub rest_volume: f64,
}

/// Signed volume `⅙ (x₁ − x₀) · ((x₂ − x₀) × (x₃ − x₀))`.
#[inline]
pub fn signed_volume(x: &[DVec3; 4]) -> f64 {
    (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) / 6.0
}

impl Volume {
    /// A volume constraint with an explicit rest volume.
    ///
    /// # Errors
    /// `NonFinite`, `FlatTetrahedron` (`V₀ = 0`), `InvertedTetrahedron` (`V₀ < 0`),
    /// `RepeatedIndex`.
    pub fn new(points: [usize; 4], rest_volume: f64) -> Result<Self, ConstraintError> {
        if !rest_volume.is_finite() {
            return Err(ConstraintError::NonFinite);
        }
        if rest_volume == 0.0 {
            return Err(ConstraintError::FlatTetrahedron);
        }
        if rest_volume < 0.0 {
            return Err(ConstraintError::InvertedTetrahedron);
        }
        distinct(&points)?;
        Ok(Self {
            points,
            rest_volume,
        })
    }

    /// A volume constraint whose rest volume is that of the tetrahedron in `rest`.
    ///
    /// # Errors
    /// `NonFinite`, `IndexOutOfBounds`, `RepeatedIndex`, `FlatTetrahedron`
    /// (see [`FLAT_TOL`]) or `InvertedTetrahedron`.
    pub fn from_rest(points: [usize; 4], rest: &[DVec3]) -> Result<Self, ConstraintError> {
        distinct(&points)?;
        let mut x = [DVec3::ZERO; 4];
        for (o, &i) in x.iter_mut().zip(points.iter()) {
            *o = *rest.get(i).ok_or(ConstraintError::IndexOutOfBounds)?;
        }
        if !all_finite(&x) {
            return Err(ConstraintError::NonFinite);
        }
        let mut longest: f64 = 0.0;
        for i in 0..4 {
            for j in 0..i {
                longest = longest.max((x[i] - x[j]).length());
            }
        }
        let v = signed_volume(&x);
        if v.is_nan() || v.abs() <= FLAT_TOL * longest * longest * longest {
            return Err(ConstraintError::FlatTetrahedron);
        }
        Self::new(points, v)
    }
}

impl PointConstraint<4, 1> for Volume {
    #[inline]
    fn stencil(&self) -> [usize; 4] {
        self.points
    }

    #[inline]
    fn value(&self, x: &[DVec3; 4]) -> [f64; 1] {
        [signed_volume(x) - self.rest_volume]
    }

    #[inline]
    fn jacobian(&self, x: &[DVec3; 4]) -> Jacobian<4, 1> {
        let e1 = x[1] - x[0];
        let e2 = x[2] - x[0];
        let e3 = x[3] - x[0];
        let g1 = e2.cross(e3) / 6.0;
        let g2 = e3.cross(e1) / 6.0;
        let g3 = e1.cross(e2) / 6.0;
        Jacobian {
            value: [e1.dot(e2.cross(e3)) / 6.0 - self.rest_volume],
            grad: [[-(g1 + g2 + g3), g1, g2, g3]],
        }
    }

    fn curvature(&self, x: &[DVec3; 4], w: &[f64; 1]) -> Curvature<4> {
        let s = w[0] / 6.0;
        let k1 = skew(s * (x[1] - x[0]));
        let k2 = skew(s * (x[2] - x[0]));
        let k3 = skew(s * (x[3] - x[0]));
        let z = DMat3::ZERO;
        // Skew matrices are antisymmetric, so block (j, i) = block (i, j)ᵀ = −block (i, j).
        let he = [
            [z, z, z, z],
            [z, z, -k3, k2],
            [z, k3, z, -k1],
            [z, -k2, k1, z],
        ];
        Curvature {
            blocks: lift_edge_hessian(&he),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_tet() -> [DVec3; 4] {
        [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z]
    }

    #[test]
    fn unit_tet_volume_is_one_sixth() {
        let v = Volume::from_rest([0, 1, 2, 3], &unit_tet()).unwrap();
        assert!((v.rest_volume - 1.0 / 6.0).abs() < 1e-16);
    }

    #[test]
    fn rejects_flat_and_inverted() {
        let flat = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)];
        assert_eq!(
            Volume::from_rest([0, 1, 2, 3], &flat),
            Err(ConstraintError::FlatTetrahedron)
        );
        assert_eq!(
            Volume::from_rest([0, 2, 1, 3], &unit_tet()),
            Err(ConstraintError::InvertedTetrahedron)
        );
        assert_eq!(
            Volume::new([0, 1, 2, 2], 1.0),
            Err(ConstraintError::RepeatedIndex)
        );
        assert_eq!(
            Volume::new([0, 1, 2, 3], f64::NAN),
            Err(ConstraintError::NonFinite)
        );
        assert_eq!(
            Volume::from_rest([0, 1, 2, 9], &unit_tet()),
            Err(ConstraintError::IndexOutOfBounds)
        );
    }

    #[test]
    fn collapsed_tet_is_finite() {
        let v = Volume::new([0, 1, 2, 3], 1.0).unwrap();
        let x = [DVec3::ONE; 4];
        let j = v.jacobian(&x);
        assert_eq!(j.value, [-1.0]);
        assert!(j.grad[0].iter().all(|g| *g == DVec3::ZERO));
    }
}
