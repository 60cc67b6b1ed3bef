//! Triangle area constraint.
//!
//! Otaduy 2010, "Fuerzas de Restricción — simulación de ropa: mallar mediante triángulos
//! y formular restricciones que conserven el área de los triángulos":
//!
//! ```text
//! C(x) = A(x) − A₀,   A = ½|u|,   u = e₁ × e₂,   e₁ = x₁ − x₀,   e₂ = x₂ − x₀
//! ∂A/∂e₁ = ½ e₂ × û,   ∂A/∂e₂ = ½ û × e₁,   ∂A/∂x₀ = −∂A/∂e₁ − ∂A/∂e₂
//! ∂²A/∂eᵢ∂eⱼ = Dᵢᵀ (I − ûûᵀ)/(2|u|) Dⱼ + B_ij,
//!     D₁ = ∂u/∂e₁ = −[e₂]×,  D₂ = ∂u/∂e₂ = [e₁]×,
//!     B₁₂ = −[½û]×,  B₂₁ = [½û]×,  B₁₁ = B₂₂ = 0
//! ```
//!
//! (`[a]×` is the cross-product matrix.) The edge-space Hessian is mapped to the three
//! points by `x₀`'s row and column being minus the sums of the others.
//!
//! **Degenerate current shape.** When the triangle collapses, `|u| ≤ 1e-12 · 2A₀`, the
//! normal `û` is undefined: the value is `½|u| − A₀` and the Jacobian and curvature are
//! zero.

use crate::constraint::{Curvature, Jacobian, PointConstraint};
use crate::error::ConstraintError;
use crate::math::{all_finite, distinct, lift_edge_hessian, outer, skew};
use glam::{DMat3, DVec3};

/// Relative size of `|u| = 2A` (against the rest value) below which a triangle counts as
/// collapsed at evaluation.
pub const COLLAPSE_TOL: f64 = 1e-12;

/// Rest triangles whose `2A / (longest edge)²` (about the sine of the smallest angle)
/// is below this are rejected as degenerate.
pub const SLIVER_TOL: f64 = 1e-10;

/// `C = A(x) − A₀` for the triangle `(x₀, x₁, x₂)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Area {
    /// The three corners.
    pub points: [usize; 3],
    /// Rest area `A₀ > 0`.
    pub rest_area: f64,
}

impl Area {
    /// An area constraint with an explicit rest area.
    ///
    /// # Errors
    /// `NonFinite`, `DegenerateTriangle` (for `rest_area ≤ 0`) or `RepeatedIndex`.
    pub fn new(points: [usize; 3], rest_area: f64) -> Result<Self, ConstraintError> {
        if !rest_area.is_finite() {
            return Err(ConstraintError::NonFinite);
        }
        if rest_area <= 0.0 {
            return Err(ConstraintError::DegenerateTriangle);
        }
        distinct(&points)?;
        Ok(Self { points, rest_area })
    }

    /// An area constraint whose rest area is the area of the triangle in `rest`.
    ///
    /// # Errors
    /// `NonFinite`, `IndexOutOfBounds`, `RepeatedIndex`, or
    /// `DegenerateTriangle` when the rest triangle is a sliver (see [`SLIVER_TOL`]).
    pub fn from_rest(points: [usize; 3], rest: &[DVec3]) -> Result<Self, ConstraintError> {
        distinct(&points)?;
        let x = gather3(points, rest)?;
        let e1 = x[1] - x[0];
        let e2 = x[2] - x[0];
        let twice_area = e1.cross(e2).length();
        let longest = e1
            .length_squared()
            .max(e2.length_squared())
            .max((e2 - e1).length_squared());
        if twice_area.is_nan() || twice_area <= SLIVER_TOL * longest {
            return Err(ConstraintError::DegenerateTriangle);
        }
        Self::new(points, 0.5 * twice_area)
    }
}

fn gather3(points: [usize; 3], rest: &[DVec3]) -> Result<[DVec3; 3], ConstraintError> {
    let mut x = [DVec3::ZERO; 3];
    for (o, &i) in x.iter_mut().zip(points.iter()) {
        *o = *rest.get(i).ok_or(ConstraintError::IndexOutOfBounds)?;
    }
    if !all_finite(&x) {
        return Err(ConstraintError::NonFinite);
    }
    Ok(x)
}

impl PointConstraint<3, 1> for Area {
    #[inline]
    fn stencil(&self) -> [usize; 3] {
        self.points
    }

    #[inline]
    fn value(&self, x: &[DVec3; 3]) -> [f64; 1] {
        [0.5 * (x[1] - x[0]).cross(x[2] - x[0]).length() - self.rest_area]
    }

    #[inline]
    fn jacobian(&self, x: &[DVec3; 3]) -> Jacobian<3, 1> {
        let e1 = x[1] - x[0];
        let e2 = x[2] - x[0];
        let u = e1.cross(e2);
        let len = u.length();
        let value = [0.5 * len - self.rest_area];
        if len <= COLLAPSE_TOL * 2.0 * self.rest_area {
            return Jacobian {
                value,
                grad: [[DVec3::ZERO; 3]],
            };
        }
        let n = u / len;
        let g1 = 0.5 * e2.cross(n);
        let g2 = 0.5 * n.cross(e1);
        Jacobian {
            value,
            grad: [[-g1 - g2, g1, g2]],
        }
    }

    fn curvature(&self, x: &[DVec3; 3], w: &[f64; 1]) -> Curvature<3> {
        let e1 = x[1] - x[0];
        let e2 = x[2] - x[0];
        let u = e1.cross(e2);
        let len = u.length();
        if len <= COLLAPSE_TOL * 2.0 * self.rest_area {
            return Curvature::ZERO;
        }
        let n = u / len;
        let p = (DMat3::IDENTITY - outer(n, n)) * (0.5 / len);
        let d = [DMat3::ZERO, -skew(e2), skew(e1)];
        let b = skew(0.5 * n);
        let mut he = [[DMat3::ZERO; 3]; 3];
        for i in 1..3 {
            for j in 1..3 {
                he[i][j] = d[i].transpose() * p * d[j];
            }
        }
        he[1][2] -= b;
        he[2][1] += b;
        Curvature {
            blocks: lift_edge_hessian(&he),
        }
        .scaled(w[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [DVec3; 3] {
        [DVec3::ZERO, DVec3::X, DVec3::Y]
    }

    #[test]
    fn rest_area_of_right_triangle() {
        let a = Area::from_rest([0, 1, 2], &tri()).unwrap();
        assert!((a.rest_area - 0.5).abs() < 1e-15);
        assert!(a.value(&tri())[0].abs() < 1e-15);
    }

    #[test]
    fn rejects_degenerate_rest_triangles() {
        let flat = [DVec3::ZERO, DVec3::X, 2.0 * DVec3::X];
        assert_eq!(
            Area::from_rest([0, 1, 2], &flat),
            Err(ConstraintError::DegenerateTriangle)
        );
        let nan = [DVec3::ZERO, DVec3::X, DVec3::NAN];
        assert_eq!(
            Area::from_rest([0, 1, 2], &nan),
            Err(ConstraintError::NonFinite)
        );
        assert_eq!(
            Area::from_rest([0, 1, 7], &tri()),
            Err(ConstraintError::IndexOutOfBounds)
        );
        assert_eq!(
            Area::new([0, 1, 1], 1.0),
            Err(ConstraintError::RepeatedIndex)
        );
        assert_eq!(
            Area::new([0, 1, 2], 0.0),
            Err(ConstraintError::DegenerateTriangle)
        );
    }

    #[test]
    fn collapsed_triangle_gives_finite_zero_derivatives() {
        let a = Area::new([0, 1, 2], 0.5).unwrap();
        let x = [DVec3::ZERO, DVec3::X, 2.0 * DVec3::X];
        let j = a.jacobian(&x);
        assert_eq!(j.value, [-0.5]);
        assert_eq!(j.grad, [[DVec3::ZERO; 3]]);
        assert_eq!(a.curvature(&x, &[1.0]), Curvature::ZERO);
    }
}
