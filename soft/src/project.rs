//! Projection of small symmetric block matrices onto the positive semidefinite cone.
//!
//! `project_psd` eigen-decomposes `H = Q Λ Qᵀ` and rebuilds `Q max(Λ, 0) Qᵀ` (Teran,
//! Sifakis, Irving & Fedkiw 2005, "Robust quasistatic finite elements and flesh
//! simulation"). Stencils of up to four points (12×12) use nalgebra's fixed-size
//! symmetric eigensolver, so nothing allocates. Two-point blocks of the form
//! `[[B, −B], [−B, B]]` (every translation-invariant pair constraint, e.g. a spring)
//! reduce to the 3×3 problem for `B`, since their eigenvalues are `2·eig(B)` and zero.

use constraint_core::DMat3;
use nalgebra::{SMatrix, SymmetricEigen};

const MAX_SWEEPS: usize = 200;

macro_rules! project_fixed {
    ($h:expr, $n:expr, $dim:literal) => {{
        let mut m = SMatrix::<f64, $dim, $dim>::zeros();
        for a in 0..$dim {
            for b in 0..$dim {
                m[(a, b)] = $h[a / 3][b / 3].col(b % 3)[a % 3];
            }
        }
        // Symmetrise against round-off before the symmetric solver reads one triangle.
        let m = (m + m.transpose()) * 0.5;
        if let Some(eig) = SymmetricEigen::try_new(m, f64::EPSILON, MAX_SWEEPS) {
            if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
                return;
            }
            let lam = eig.eigenvalues.map(|l| l.max(0.0));
            let q = eig.eigenvectors;
            let p = q * SMatrix::<f64, $dim, $dim>::from_diagonal(&lam) * q.transpose();
            for i in 0..$n {
                for j in 0..$n {
                    $h[i][j] = DMat3::from_cols_fn(|c, r| p[(3 * i + r, 3 * j + c)]);
                }
            }
        } else {
            // Eigen-iteration failed (cannot happen for finite input): fall back to the
            // zero matrix, which is PSD; the Gauss–Newton part is added by the caller.
            for row in $h.iter_mut() {
                for b in row.iter_mut() {
                    *b = DMat3::ZERO;
                }
            }
        }
    }};
}

trait FromColsFn {
    fn from_cols_fn(f: impl Fn(usize, usize) -> f64) -> Self;
}

impl FromColsFn for DMat3 {
    #[inline]
    fn from_cols_fn(f: impl Fn(usize, usize) -> f64) -> Self {
        DMat3::from_cols_array(&[
            f(0, 0),
            f(0, 1),
            f(0, 2),
            f(1, 0),
            f(1, 1),
            f(1, 2),
            f(2, 0),
            f(2, 1),
            f(2, 2),
        ])
    }
}

/// Replaces the symmetric `3N × 3N` block matrix `h` (N ≤ 4) by its projection onto the
/// positive semidefinite cone. Non-finite input is left unchanged (the stepping
/// watchdog reports it).
pub fn project_psd<const N: usize>(h: &mut [[DMat3; N]; N]) {
    if !h.iter().flatten().all(|b| b.is_finite()) {
        return;
    }
    if N == 2 && h[0][1] == -h[0][0] && h[1][0] == -h[0][0] && h[1][1] == h[0][0] {
        let mut b = [[h[0][0]]];
        project_block(&mut b);
        h[0][0] = b[0][0];
        h[1][1] = b[0][0];
        h[0][1] = -b[0][0];
        h[1][0] = -b[0][0];
        return;
    }
    match N {
        1 => project_fixed!(h, N, 3),
        2 => project_fixed!(h, N, 6),
        3 => project_fixed!(h, N, 9),
        4 => project_fixed!(h, N, 12),
        _ => {}
    }
}

fn project_block(h: &mut [[DMat3; 1]; 1]) {
    project_fixed!(h, 1, 3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use constraint_core::DVec3;

    #[test]
    fn psd_input_is_unchanged_and_negative_part_removed() {
        let mut h = [[DMat3::from_diagonal(DVec3::new(1.0, -2.0, 3.0))]];
        project_psd(&mut h);
        assert_eq!(h[0][0], DMat3::from_diagonal(DVec3::new(1.0, 0.0, 3.0)));
        let spd = DMat3::from_diagonal(DVec3::new(1.0, 2.0, 3.0));
        let mut h2 = [[spd, -spd], [-spd, spd]];
        project_psd(&mut h2);
        assert_eq!(h2[0][0], spd);
    }

    #[test]
    fn general_four_point_projection_has_no_negative_eigenvalues() {
        let mut h = [[DMat3::ZERO; 4]; 4];
        let mut s = 1.0f64;
        for i in 0..4 {
            for j in 0..=i {
                s = (s * 7.31 + 0.17).fract();
                let b = DMat3::from_cols_array(&[s, s - 0.5, 0.2, s - 0.5, -s, 0.1, 0.2, 0.1, s]);
                h[i][j] = if i == j { (b + b.transpose()) * 0.5 } else { b };
                h[j][i] = h[i][j].transpose();
            }
        }
        project_psd(&mut h);
        let mut m = SMatrix::<f64, 12, 12>::zeros();
        for a in 0..12 {
            for b in 0..12 {
                m[(a, b)] = h[a / 3][b / 3].col(b % 3)[a % 3];
            }
        }
        let e = SymmetricEigen::new(m);
        // measured min eigenvalue ≈ −1e-16; gate −1e-12
        assert!(e.eigenvalues.min() > -1e-12, "{}", e.eigenvalues.min());
    }
}
