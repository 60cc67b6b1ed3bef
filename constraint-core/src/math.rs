//! Small helpers on top of glam's `f64` types.

use glam::{DMat3, DVec3};

/// Skew-symmetric cross-product matrix: `skew(a) b = a × b`.
#[inline]
pub fn skew(a: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, a.z, -a.y),
        DVec3::new(-a.z, 0.0, a.x),
        DVec3::new(a.y, -a.x, 0.0),
    )
}

/// Outer product `a bᵀ`.
#[inline]
pub fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// `true` when every component of every vector is finite.
#[inline]
pub fn all_finite(xs: &[DVec3]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

/// Returns `Err(RepeatedIndex)` if two entries of `idx` coincide.
pub(crate) fn distinct<const N: usize>(idx: &[usize; N]) -> Result<(), crate::ConstraintError> {
    for i in 0..N {
        for j in 0..i {
            if idx[i] == idx[j] {
                return Err(crate::ConstraintError::RepeatedIndex);
            }
        }
    }
    Ok(())
}

/// Lifts a Hessian written in edge vectors `e_i = x_i − x_0` (`i = 1..N`, stored in
/// blocks `[1..N][1..N]`, row and column 0 ignored) to point coordinates `x_0..x_{N-1}`:
/// with `P = ∂e/∂x`, returns `Pᵀ H_e P`.
pub fn lift_edge_hessian<const N: usize>(he: &[[DMat3; N]; N]) -> [[DMat3; N]; N] {
    let mut h = [[DMat3::ZERO; N]; N];
    let mut corner = DMat3::ZERO;
    for (i, he_row) in he.iter().enumerate().skip(1) {
        let mut row = DMat3::ZERO;
        for j in 1..N {
            h[i][j] = he_row[j];
            row += he_row[j];
        }
        // Block (i, 0) = −Σ_j H_e(i, j).
        h[i][0] = -row;
        corner += row;
    }
    for j in 1..N {
        let col: DMat3 = he.iter().skip(1).map(|row| row[j]).sum();
        h[0][j] = -col;
    }
    h[0][0] = corner;
    h
}

/// The bound of every stepper's divergence watchdog: a coordinate whose magnitude
/// reaches it, or that is not finite, makes the step a typed divergence error.
pub const DIVERGENCE_LIMIT: f64 = 1e12;

/// `true` when every component of `v` is finite and below [`DIVERGENCE_LIMIT`] in
/// magnitude. Finiteness is tested first on purpose: glam's `max_element` drops a NaN
/// component (`max(NaN, y) = y`), so the bound alone would let `(NaN, 0, 0)` through.
#[inline]
pub fn within_limit(v: DVec3) -> bool {
    v.is_finite() && v.abs().max_element() < DIVERGENCE_LIMIT
}

/// The first index `i` where `a[i]` or `b[i]` is not [`within_limit`] (pairs up to the
/// shorter slice), for the watchdogs over positions and velocities.
pub fn first_out_of_limit(a: &[DVec3], b: &[DVec3]) -> Option<usize> {
    a.iter()
        .zip(b)
        .position(|(a, b)| !(within_limit(*a) && within_limit(*b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skew_is_cross_product() {
        let a = DVec3::new(1.0, -2.0, 3.5);
        let b = DVec3::new(-0.5, 4.0, 2.0);
        assert!((skew(a) * b - a.cross(b)).length() < 1e-14);
    }

    #[test]
    fn outer_product() {
        let a = DVec3::new(1.0, 2.0, 3.0);
        let b = DVec3::new(4.0, 5.0, 6.0);
        let c = DVec3::new(-1.0, 0.5, 2.0);
        assert!((outer(a, b) * c - a * b.dot(c)).length() < 1e-14);
    }

    #[test]
    fn the_watchdog_bound_catches_nan_in_any_component() {
        assert!(within_limit(DVec3::new(1.0, -2.0, 9.9e11)));
        for k in 0..3 {
            for bad in [f64::NAN, f64::INFINITY, -1e12] {
                let mut a = [0.0; 3];
                a[k] = bad;
                assert!(!within_limit(DVec3::from_array(a)), "{k} {bad}");
            }
        }
        let ok = [DVec3::ONE; 3];
        let mut bad = ok;
        bad[2].y = f64::NAN;
        assert_eq!(first_out_of_limit(&ok, &ok), None);
        assert_eq!(first_out_of_limit(&ok, &bad), Some(2));
    }
}
