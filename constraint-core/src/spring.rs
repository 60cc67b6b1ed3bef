//! Distance (spring length) constraint.
//!
//! Otaduy 2010, "Energía de Restricción — ejemplo: longitud de un muelle":
//!
//! ```text
//! C(x) = |x_a − x_b| − L₀
//! ∂C/∂x_a = n,   ∂C/∂x_b = −n,          n = (x_a − x_b)/|x_a − x_b|
//! ∂²C/∂x_a² = (I − n nᵀ)/|x_a − x_b|,   blocks [[H, −H], [−H, H]]
//! ```
//!
//! With `E = ½kC²` the force `F_a = −kC n` is Hooke's law ("¡La fuerza es la misma que
//! con la ley de Hooke!").
//!
//! **Degenerate current shape.** When the points (nearly) coincide,
//! `|x_a − x_b| ≤ 1e-12 · L₀`, the direction `n` is undefined: the value is still
//! `|x_a − x_b| − L₀` and the Jacobian and curvature are returned as zero.

use crate::constraint::{Curvature, Jacobian, PointConstraint};
use crate::error::ConstraintError;
use crate::math::{distinct, outer};
use glam::{DMat3, DVec3};

/// Relative length below which two points count as coincident.
pub const COINCIDENT_TOL: f64 = 1e-12;

/// `C = |x_a − x_b| − L₀`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Distance {
    /// The two points `[a, b]`.
    pub points: [usize; 2],
    /// Rest length `L₀ > 0`.
    pub rest_length: f64,
}

impl Distance {
    /// A distance constraint with an explicit rest length.
    ///
    /// # Errors
    /// [`ConstraintError::ZeroRestLength`] unless `rest_length > 0`,
    /// [`ConstraintError::NonFinite`] for NaN or infinity,
    /// [`ConstraintError::RepeatedIndex`] when `a == b`.
    pub fn new(a: usize, b: usize, rest_length: f64) -> Result<Self, ConstraintError> {
        if !rest_length.is_finite() {
            return Err(ConstraintError::NonFinite);
        }
        if rest_length <= 0.0 {
            return Err(ConstraintError::ZeroRestLength);
        }
        distinct(&[a, b])?;
        Ok(Self {
            points: [a, b],
            rest_length,
        })
    }

    /// A distance constraint whose rest length is the current distance of the two points.
    ///
    /// # Errors
    /// As [`Distance::new`]; coincident rest points give `ZeroRestLength`, an index
    /// beyond `rest` gives `IndexOutOfBounds`.
    pub fn from_rest(a: usize, b: usize, rest: &[DVec3]) -> Result<Self, ConstraintError> {
        let (pa, pb) = rest_pair(a, b, rest)?;
        Self::new(a, b, (pa - pb).length())
    }

    #[inline]
    fn direction(&self, d: DVec3) -> Option<(DVec3, f64)> {
        let len = d.length();
        if len > COINCIDENT_TOL * self.rest_length {
            Some((d / len, len))
        } else {
            None
        }
    }
}

fn rest_pair(a: usize, b: usize, rest: &[DVec3]) -> Result<(DVec3, DVec3), ConstraintError> {
    let (Some(&pa), Some(&pb)) = (rest.get(a), rest.get(b)) else {
        return Err(ConstraintError::IndexOutOfBounds);
    };
    if !(pa.is_finite() && pb.is_finite()) {
        return Err(ConstraintError::NonFinite);
    }
    Ok((pa, pb))
}

impl PointConstraint<2, 1> for Distance {
    #[inline]
    fn stencil(&self) -> [usize; 2] {
        self.points
    }

    #[inline]
    fn value(&self, x: &[DVec3; 2]) -> [f64; 1] {
        [(x[0] - x[1]).length() - self.rest_length]
    }

    #[inline]
    fn jacobian(&self, x: &[DVec3; 2]) -> Jacobian<2, 1> {
        let d = x[0] - x[1];
        match self.direction(d) {
            Some((n, len)) => Jacobian {
                value: [len - self.rest_length],
                grad: [[n, -n]],
            },
            None => Jacobian {
                value: [d.length() - self.rest_length],
                grad: [[DVec3::ZERO; 2]],
            },
        }
    }

    #[inline]
    fn curvature(&self, x: &[DVec3; 2], w: &[f64; 1]) -> Curvature<2> {
        let Some((n, len)) = self.direction(x[0] - x[1]) else {
            return Curvature::ZERO;
        };
        let h = (DMat3::IDENTITY - outer(n, n)) * (w[0] / len);
        Curvature {
            blocks: [[h, -h], [-h, h]],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_and_gradient_of_a_stretched_spring() {
        let c = Distance::new(0, 1, 1.0).unwrap();
        let x = [DVec3::new(2.0, 0.0, 0.0), DVec3::ZERO];
        let j = c.jacobian(&x);
        assert_eq!(j.value, [1.0]);
        assert_eq!(j.grad[0], [DVec3::X, -DVec3::X]);
    }

    #[test]
    fn rejects_bad_rest_lengths() {
        assert_eq!(
            Distance::new(0, 1, 0.0),
            Err(ConstraintError::ZeroRestLength)
        );
        assert_eq!(
            Distance::new(0, 1, -1.0),
            Err(ConstraintError::ZeroRestLength)
        );
        assert_eq!(
            Distance::new(0, 1, f64::NAN),
            Err(ConstraintError::NonFinite)
        );
        assert_eq!(
            Distance::new(0, 1, f64::INFINITY),
            Err(ConstraintError::NonFinite)
        );
        assert_eq!(
            Distance::new(3, 3, 1.0),
            Err(ConstraintError::RepeatedIndex)
        );
        let p = [DVec3::ONE, DVec3::ONE];
        assert_eq!(
            Distance::from_rest(0, 1, &p),
            Err(ConstraintError::ZeroRestLength)
        );
        assert_eq!(
            Distance::from_rest(0, 2, &p),
            Err(ConstraintError::IndexOutOfBounds)
        );
    }

    #[test]
    fn coincident_points_give_finite_zero_derivatives() {
        let c = Distance::new(0, 1, 0.5).unwrap();
        let x = [DVec3::splat(3.0); 2];
        let j = c.jacobian(&x);
        assert_eq!(j.value, [-0.5]);
        assert_eq!(j.grad, [[DVec3::ZERO; 2]]);
        assert_eq!(c.curvature(&x, &[1.0]), Curvature::ZERO);
    }
}
