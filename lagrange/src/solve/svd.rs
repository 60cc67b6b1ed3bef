//! Least squares through the singular value decomposition: minimum-norm solutions of
//! rank-deficient or incompatible systems and damped least squares.
//!
//! With the SVD `A = U Σ Vᵀ` (`A` is `m × n`, `p = min(m, n)` singular values
//! `σ_1 ≥ … ≥ σ_p ≥ 0`; Golub & Van Loan, *Matrix Computations*, 4th ed., §2.4),
//!
//! * the **minimum-norm least-squares** solution (Golub & Van Loan §5.5.4) is
//!   `x = A⁺ b = Σ_{σ_i > τ} (u_iᵀ b / σ_i) v_i`: of all minimizers of `|A x − b|` it has
//!   the smallest `|x|`, so it lies in the row space (`x ⟂ null(A)`). Singular values at
//!   or below `τ = tol · σ_max` are treated as zero, and the number kept is the numerical
//!   rank. This is the lecture's answer for overconstrained ("incompatible") KKT systems:
//!   a duplicated constraint row gives a finite solution that splits the multiplier
//!   evenly instead of a singular factorization.
//! * the **damped least-squares** (Tikhonov, Levenberg–Marquardt) solution
//!   `x = (AᵀA + μ²I)⁻¹ Aᵀ b = Σ_i σ_i / (σ_i² + μ²) (u_iᵀ b) v_i` (Golub & Van Loan
//!   §6.1.4, filter factors) minimizes `|A x − b|² + μ²|x|²`; it stays bounded as
//!   `σ_i → 0` and tends to `A⁺ b` as `μ → 0`.
//!
//! ## The decomposition: one-sided Jacobi
//!
//! The SVD is computed by one-sided (Hestenes) Jacobi, Golub & Van Loan §8.6.3 and
//! Demmel & Veselić, "Jacobi's method is more accurate than QR", *SIAM J. Matrix Anal.
//! Appl.* 13(4), 1992: plane rotations applied from the right orthogonalize the columns
//! of `W = A V` (of `Aᵀ` when `m < n`) until every pair satisfies
//! `|w_pᵀ w_q| ≤ √m·ε·|w_p||w_q|`; then `σ_j = |w_j|` and `u_j = w_j / σ_j`. Dependent
//! columns (a duplicated constraint row) are rotated into a column of rounding noise;
//! columns of norm `≤ ε·|A|_F` are set to exactly zero, so singular values below that
//! level are reported as `0` (they carry no information in `f64`) and are never
//! inverted, whatever the rank tolerance.
//!
//! nalgebra's Golub–Kahan `SVD` was the first choice but is not reliable on exactly the
//! matrices this module exists for: on random constraint matrices with one duplicated
//! row, `U Σ Vᵀ` differed from `A` by more than `1e-12` in 275 of 2000 cases with
//! `eps = ε` and in 41 of 2000 with its default `5ε` (errors up to `1.5` for entries of
//! size 1; nalgebra 0.35, cf. dimforge/nalgebra issues #1172 and #1072 on
//! near-rank-deficient input). The tests cross-check the Jacobi singular values against
//! nalgebra's on full-rank matrices, where it is accurate.
//!
//! Non-finite input gives [`SolveError::NonFinite`] before any iteration, so results are
//! never NaN.

use super::{all_finite, dot, hypot, sqrt, DenseMatrix, SolveError};
use alloc::vec::Vec;

/// Maximum number of Jacobi sweeps (convergence is quadratic; a handful suffice).
pub const MAX_SWEEPS: usize = 60;

/// A singular value decomposition ready for repeated least-squares solves.
#[derive(Clone, Debug, PartialEq)]
pub struct SvdSolver {
    n_rows: usize,
    n_cols: usize,
    /// `m × p` left singular vectors, column-major.
    u: Vec<f64>,
    /// `n × p` right singular vectors, column-major.
    v: Vec<f64>,
    /// `p` singular values, descending.
    sigma: Vec<f64>,
    rank: usize,
    sweeps: usize,
}

/// Result of [`min_norm_solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct MinNormSolution {
    /// The minimum-norm least-squares solution `A⁺ b`.
    pub x: Vec<f64>,
    /// Numerical rank: singular values above `tol · σ_max`.
    pub rank: usize,
}

/// One-sided Jacobi on the `rows × cols` column-major `w` (`rows ≥ cols`), accumulating
/// the rotations into the `cols × cols` column-major `v` (identity on entry). Returns
/// the sweeps used, or the final relative off-orthogonality when out of sweeps.
///
/// Pairs involving a column of norm `≤ ε·|W|_F` are skipped, and such columns are
/// zeroed at the end: a column at that level is rounding noise (e.g. what is left of a
/// duplicated row), and rotating it against the others only shrinks it towards
/// underflow without ever making it relatively orthogonal.
fn jacobi(w: &mut [f64], v: &mut [f64], rows: usize, cols: usize) -> Result<usize, f64> {
    let tol = sqrt(rows as f64) * f64::EPSILON;
    let negligible = f64::EPSILON * f64::EPSILON * dot(w, w);
    let mut worst = 0.0;
    for sweep in 1..=MAX_SWEEPS {
        worst = 0.0f64;
        for p in 0..cols {
            for q in p + 1..cols {
                let (left, right) = w.split_at_mut(q * rows);
                let wp = &mut left[p * rows..(p + 1) * rows];
                let wq = &mut right[..rows];
                let alpha = dot(wp, wp);
                let beta = dot(wq, wq);
                let gamma = dot(wp, wq);
                let scale = sqrt(alpha) * sqrt(beta);
                if gamma == 0.0
                    || alpha <= negligible
                    || beta <= negligible
                    || !(gamma.abs() > tol * scale)
                {
                    continue;
                }
                worst = worst.max(gamma.abs() / scale);
                // Rotation annihilating the (p, q) entry of WᵀW.
                let zeta = (beta - alpha) / (2.0 * gamma);
                let sign = if zeta < 0.0 { -1.0 } else { 1.0 };
                let t = sign / (zeta.abs() + hypot(1.0, zeta));
                let c = 1.0 / hypot(1.0, t);
                let s = c * t;
                rotate(wp, wq, c, s);
                let (vl, vr) = v.split_at_mut(q * cols);
                rotate(&mut vl[p * cols..(p + 1) * cols], &mut vr[..cols], c, s);
            }
        }
        if worst == 0.0 {
            // Negligible columns were never orthogonalized: make them exact zeros.
            for col in w.chunks_exact_mut(rows.max(1)) {
                if dot(col, col) <= negligible {
                    col.fill(0.0);
                }
            }
            return Ok(sweep);
        }
    }
    Err(worst)
}

/// `(x, y) ← (c x − s y, s x + c y)`.
fn rotate(x: &mut [f64], y: &mut [f64], c: f64, s: f64) {
    for (xi, yi) in x.iter_mut().zip(y.iter_mut()) {
        let (a, b) = (*xi, *yi);
        *xi = c * a - s * b;
        *yi = s * a + c * b;
    }
}

impl SvdSolver {
    /// The customary relative rank tolerance `max(m, n) · ε` (as LAPACK `gelss` and
    /// NumPy `lstsq` use).
    pub fn default_tolerance(n_rows: usize, n_cols: usize) -> f64 {
        n_rows.max(n_cols) as f64 * f64::EPSILON
    }

    /// Decomposes `a`; singular values `≤ rel_tol · σ_max` count as zero.
    ///
    /// Errors: [`SolveError::NonFinite`] for a non-finite entry or `rel_tol` (a negative
    /// `rel_tol` acts as zero) or an overflowing decomposition;
    /// [`SolveError::NotConverged`] if the Jacobi sweeps have not converged after
    /// [`MAX_SWEEPS`] (`residual` is then the largest relative off-orthogonality
    /// `|w_pᵀ w_q| / (|w_p||w_q|)` of the last sweep).
    pub fn new(a: &DenseMatrix, rel_tol: f64) -> Result<Self, SolveError> {
        if !a.is_finite() || !rel_tol.is_finite() {
            return Err(SolveError::NonFinite);
        }
        let (m, n) = (a.n_rows(), a.n_cols());
        // Work on the tall orientation: W = A (m ≥ n) or W = Aᵀ (m < n).
        let tall = m >= n;
        let (rows, cols) = if tall { (m, n) } else { (n, m) };
        let mut w = if tall {
            a.as_slice().to_vec()
        } else {
            a.transpose().into_vec()
        };
        // Scale entries into [-1, 1] so the column inner products neither overflow nor
        // underflow; σ is scaled back below.
        let amax = a.max_abs();
        if amax > 0.0 {
            for x in w.iter_mut() {
                *x /= amax;
            }
        }
        let mut v = DenseMatrix::identity(cols).into_vec();
        let sweeps =
            jacobi(&mut w, &mut v, rows, cols).map_err(|off| SolveError::NotConverged {
                iterations: MAX_SWEEPS,
                residual: off,
            })?;
        // σ_j = |w_j|, sorted descending; normalized w_j are the singular vectors on the
        // `rows` side, v_j those on the `cols` side.
        let mut order: Vec<(f64, usize)> = (0..cols)
            .map(|j| {
                (
                    sqrt(dot(
                        &w[j * rows..(j + 1) * rows],
                        &w[j * rows..(j + 1) * rows],
                    )),
                    j,
                )
            })
            .collect();
        order.sort_by(|x, y| y.0.total_cmp(&x.0));
        let mut left = Vec::with_capacity(rows * cols);
        let mut right = Vec::with_capacity(cols * cols);
        let mut sigma = Vec::with_capacity(cols);
        for &(s, j) in &order {
            let wj = &w[j * rows..(j + 1) * rows];
            if s > 0.0 {
                left.extend(wj.iter().map(|x| x / s));
            } else {
                left.extend(core::iter::repeat_n(0.0, rows));
            }
            right.extend_from_slice(&v[j * cols..(j + 1) * cols]);
            sigma.push(s * amax);
        }
        if !all_finite(&sigma) || !all_finite(&left) {
            return Err(SolveError::NonFinite);
        }
        let (u, v) = if tall { (left, right) } else { (right, left) };
        let sigma_max = sigma.first().copied().unwrap_or(0.0);
        let cutoff = rel_tol.max(0.0) * sigma_max;
        let rank = sigma.iter().filter(|&&s| s > cutoff && s > 0.0).count();
        Ok(Self {
            n_rows: m,
            n_cols: n,
            u,
            v,
            sigma,
            rank,
            sweeps,
        })
    }

    /// Number of rows `m` of the decomposed matrix.
    pub fn n_rows(&self) -> usize {
        self.n_rows
    }

    /// Number of columns `n` of the decomposed matrix.
    pub fn n_cols(&self) -> usize {
        self.n_cols
    }

    /// Numerical rank.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// Jacobi sweeps the decomposition took.
    pub fn sweeps(&self) -> usize {
        self.sweeps
    }

    /// The singular values, descending.
    pub fn singular_values(&self) -> &[f64] {
        &self.sigma
    }

    /// Left singular vector `u_i` (length `m`). For `σ_i = 0` one of `u_i`, `v_i` may be
    /// the zero vector.
    ///
    /// # Panics
    /// When `i >= min(m, n)`.
    pub fn u(&self, i: usize) -> &[f64] {
        &self.u[i * self.n_rows..(i + 1) * self.n_rows]
    }

    /// Right singular vector `v_i` (length `n`). For `σ_i = 0` one of `u_i`, `v_i` may be
    /// the zero vector.
    ///
    /// # Panics
    /// When `i >= min(m, n)`.
    pub fn v(&self, i: usize) -> &[f64] {
        &self.v[i * self.n_cols..(i + 1) * self.n_cols]
    }

    /// `σ_max / σ_rank` over the kept singular values (`∞` for rank 0).
    pub fn condition_number(&self) -> f64 {
        match self.rank {
            0 => f64::INFINITY,
            r => self.sigma[0] / self.sigma[r - 1],
        }
    }

    /// Writes `x = Σ_i f(σ_i) (u_iᵀ b) v_i` over the kept singular values.
    fn filtered_solve(
        &self,
        b: &[f64],
        x: &mut [f64],
        filter: impl Fn(f64) -> f64,
    ) -> Result<(), SolveError> {
        if b.len() != self.n_rows || x.len() != self.n_cols {
            return Err(SolveError::DimensionMismatch);
        }
        if !all_finite(b) {
            return Err(SolveError::NonFinite);
        }
        x.fill(0.0);
        for i in 0..self.rank {
            let t = filter(self.sigma[i]) * dot(self.u(i), b);
            for (xj, vj) in x.iter_mut().zip(self.v(i)) {
                *xj += t * vj;
            }
        }
        if all_finite(x) {
            Ok(())
        } else {
            Err(SolveError::NonFinite)
        }
    }

    /// Minimum-norm least-squares solution `x = A⁺ b` (rank-truncated pseudo-inverse).
    ///
    /// Errors: [`SolveError::DimensionMismatch`] unless `b.len() == m` and
    /// `x.len() == n`; [`SolveError::NonFinite`] for non-finite `b` (or an overflowing
    /// result).
    pub fn solve_min_norm(&self, b: &[f64], x: &mut [f64]) -> Result<(), SolveError> {
        self.filtered_solve(b, x, |s| 1.0 / s)
    }

    /// Damped least-squares solution `x = (AᵀA + μ²I)⁻¹ Aᵀ b`, by the filter factors
    /// `σ / (σ² + μ²)`. Singular values below the rank tolerance are dropped as in
    /// [`SvdSolver::solve_min_norm`], so `μ = 0` gives the minimum-norm solution.
    ///
    /// Errors: as [`SvdSolver::solve_min_norm`], and [`SolveError::NonFinite`] for a
    /// non-finite `mu`.
    pub fn solve_damped(&self, b: &[f64], mu: f64, x: &mut [f64]) -> Result<(), SolveError> {
        if !mu.is_finite() {
            return Err(SolveError::NonFinite);
        }
        // σ/(σ² + μ²) written as 1/(σ + μ·(μ/σ)) to avoid overflowing σ².
        self.filtered_solve(b, x, |s| 1.0 / (s + mu * (mu / s)))
    }
}

/// Minimum-norm least-squares solution of `A x ≈ b` for any `m × n` matrix, with
/// singular values `≤ rel_tol · σ_max` treated as zero (see
/// [`SvdSolver::default_tolerance`]).
///
/// Errors: [`SolveError::DimensionMismatch`] unless `b.len() == m`;
/// [`SolveError::NonFinite`] for non-finite input; see [`SvdSolver::new`].
pub fn min_norm_solve(
    a: &DenseMatrix,
    b: &[f64],
    rel_tol: f64,
) -> Result<MinNormSolution, SolveError> {
    if b.len() != a.n_rows() {
        return Err(SolveError::DimensionMismatch);
    }
    let svd = SvdSolver::new(a, rel_tol)?;
    let mut x = alloc::vec![0.0; a.n_cols()];
    svd.solve_min_norm(b, &mut x)?;
    Ok(MinNormSolution {
        x,
        rank: svd.rank(),
    })
}

/// Damped least-squares solution `x = (AᵀA + μ²I)⁻¹ Aᵀ b` for any `m × n` matrix (rank
/// tolerance [`SvdSolver::default_tolerance`]).
///
/// Errors: [`SolveError::DimensionMismatch`] unless `b.len() == m`;
/// [`SolveError::NonFinite`] for non-finite input or `mu`; see [`SvdSolver::new`].
pub fn damped_solve(a: &DenseMatrix, b: &[f64], mu: f64) -> Result<Vec<f64>, SolveError> {
    if b.len() != a.n_rows() {
        return Err(SolveError::DimensionMismatch);
    }
    if !mu.is_finite() {
        return Err(SolveError::NonFinite);
    }
    let svd = SvdSolver::new(a, SvdSolver::default_tolerance(a.n_rows(), a.n_cols()))?;
    let mut x = alloc::vec![0.0; a.n_cols()];
    svd.solve_damped(b, mu, &mut x)?;
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{rel_err, Rng};
    use super::super::{dot, lu_solve, Cholesky};
    use super::*;

    fn tol(a: &DenseMatrix) -> f64 {
        SvdSolver::default_tolerance(a.n_rows(), a.n_cols())
    }

    /// `J_rᵀ (J_r J_rᵀ)⁻¹ c` by Cholesky: the minimum-norm solution of a full-row-rank
    /// underdetermined system, computed without the SVD.
    fn min_norm_by_normal_equations(j: &DenseMatrix, c: &[f64]) -> Vec<f64> {
        let jjt = j.matmul(&j.transpose()).unwrap();
        let y = Cholesky::factor(&jjt).unwrap().solve(c).unwrap();
        let mut x = alloc::vec![0.0; j.n_cols()];
        j.mul_transpose_vec(&y, &mut x).unwrap();
        x
    }

    /// Largest entry of `|U Σ Vᵀ − A|` and of the orthogonality defects of `U`, `V`.
    fn decomposition_errors(a: &DenseMatrix, svd: &SvdSolver) -> (f64, f64) {
        let (m, n) = (a.n_rows(), a.n_cols());
        let p = m.min(n);
        let mut recon = 0.0f64;
        for i in 0..m {
            for j in 0..n {
                let s: f64 = (0..p)
                    .map(|k| svd.u(k)[i] * svd.singular_values()[k] * svd.v(k)[j])
                    .sum();
                recon = recon.max((s - a.get(i, j)).abs());
            }
        }
        let mut orth = 0.0f64;
        for k in 0..p {
            for l in 0..p {
                let id = if k == l { 1.0 } else { 0.0 };
                if k < svd.rank() && l < svd.rank() {
                    orth = orth.max((dot(svd.v(k), svd.v(l)) - id).abs());
                    orth = orth.max((dot(svd.u(k), svd.u(l)) - id).abs());
                }
            }
        }
        (recon, orth)
    }

    #[test]
    fn decomposition_is_accurate_including_duplicated_rows() {
        let mut rng = Rng::new(30);
        let (mut worst_recon, mut worst_orth, mut worst_sv) = (0.0f64, 0.0f64, 0.0f64);
        let mut max_sweeps = 0;
        for case in 0..200 {
            let m = rng.range(1, 30);
            let n = rng.range(1, 30);
            let mut a = rng.matrix(m, n);
            if case % 2 == 1 && m > 1 {
                let (src, dst) = (rng.range(0, m), rng.range(0, m));
                for s in 0..n {
                    let v = a.get(src, s);
                    a.set(dst, s, v);
                }
            }
            let svd = SvdSolver::new(&a, 0.0).unwrap();
            let (recon, orth) = decomposition_errors(&a, &svd);
            worst_recon = worst_recon.max(recon);
            worst_orth = worst_orth.max(orth);
            max_sweeps = max_sweeps.max(svd.sweeps());
            assert!(svd.singular_values().windows(2).all(|w| w[0] >= w[1]));
            if case % 2 == 0 {
                // Full rank with probability one: nalgebra's SVD is accurate here and
                // serves as an independent check of the singular values.
                let reference = a.to_nalgebra().svd(false, false).singular_values;
                for (s, r) in svd.singular_values().iter().zip(reference.iter()) {
                    worst_sv = worst_sv.max((s - r).abs() / reference[0]);
                }
            }
        }
        // Measured worst: reconstruction 6.0e-15, orthogonality 4.4e-15, singular
        // values vs nalgebra 2.7e-15 (relative to σ_max), 10 sweeps.
        eprintln!(
            "Jacobi SVD: reconstruction {worst_recon:e}, orthogonality {worst_orth:e}, \
             σ vs nalgebra {worst_sv:e}, max sweeps {max_sweeps}"
        );
        assert!(worst_recon < 6e-14 && worst_orth < 4.5e-14 && worst_sv < 3e-14);
    }

    #[test]
    fn matches_lu_on_square_systems() {
        let mut rng = Rng::new(31);
        let mut worst = 0.0f64;
        for case in 0..60 {
            let n = rng.range(1, 40);
            let a = rng.general(n);
            let b = rng.vec(n);
            let x_ref = lu_solve(&a, &b).unwrap();
            let sol = min_norm_solve(&a, &b, tol(&a)).unwrap();
            assert_eq!(sol.rank, n, "case {case}");
            worst = worst.max(rel_err(&sol.x, &x_ref));
        }
        // Measured worst: 2.0e-15.
        eprintln!("SVD vs LU: worst error {worst:e}");
        assert!(worst < 2e-14);
    }

    #[test]
    fn duplicated_row_gives_minimum_norm_solution() {
        let mut rng = Rng::new(32);
        let mut worst = 0.0f64;
        for case in 0..60 {
            let n = rng.range(3, 30);
            let k = rng.range(1, n - 1);
            let j_r = rng.matrix(k, n);
            let c_r = rng.vec(k);
            // Duplicate row d; for odd cases the copies disagree (incompatible system),
            // whose least-squares solution satisfies their mean.
            let d = rng.range(0, k);
            let shift = if case % 2 == 1 { 0.5 } else { 0.0 };
            let j = DenseMatrix::from_fn(k + 1, n, |r, s| j_r.get(if r == k { d } else { r }, s));
            let mut c = c_r.clone();
            c.push(c_r[d] + shift);
            let mut c_mean = c_r.clone();
            c_mean[d] += shift / 2.0;
            let sol = min_norm_solve(&j, &c, tol(&j)).unwrap();
            assert_eq!(sol.rank, k, "case {case}");
            assert!(sol.x.iter().all(|v| v.is_finite()));
            let x_ref = min_norm_by_normal_equations(&j_r, &c_mean);
            let e = rel_err(&sol.x, &x_ref);
            worst = worst.max(e);
        }
        // Measured worst: 1.28e-14.
        eprintln!("SVD min-norm (duplicated row) vs normal equations: worst {worst:e}");
        assert!(worst < 1.3e-13);
    }

    #[test]
    fn overconstrained_kkt_splits_multiplier() {
        // [A Jᵀ; J 0] with a duplicated constraint row: singular, but the minimum-norm
        // solution has the reduced system's x and splits λ evenly between the copies.
        let mut rng = Rng::new(33);
        let mut worst = 0.0f64;
        for _ in 0..60 {
            let n = rng.range(3, 20);
            let k = rng.range(1, n / 2 + 1);
            let kkt = rng.kkt(n, k, &[]);
            let rhs = rng.vec(n + k);
            let reduced = lu_solve(&kkt, &rhs).unwrap();
            let big = DenseMatrix::from_fn(n + k + 1, n + k + 1, |r, s| {
                let map = |i: usize| if i == n + k { n + k - 1 } else { i };
                if r == n + k && s == n + k {
                    0.0
                } else {
                    kkt.get(map(r), map(s))
                }
            });
            let mut b = rhs.clone();
            b.push(rhs[n + k - 1]);
            let sol = min_norm_solve(&big, &b, tol(&big)).unwrap();
            assert_eq!(sol.rank, n + k);
            let mut expected = reduced.clone();
            expected[n + k - 1] /= 2.0;
            expected.push(expected[n + k - 1]);
            worst = worst.max(rel_err(&sol.x, &expected));
        }
        // Measured worst: 1.8e-15.
        eprintln!("SVD overconstrained KKT: worst {worst:e}");
        assert!(worst < 2e-14);
    }

    #[test]
    fn overdetermined_matches_normal_equations() {
        let mut rng = Rng::new(34);
        let mut worst = 0.0f64;
        for _ in 0..60 {
            let n = rng.range(1, 20);
            let m = n + rng.range(1, 20);
            let a = rng.matrix(m, n);
            let b = rng.vec(m);
            let ata = a.transpose().matmul(&a).unwrap();
            let mut atb = alloc::vec![0.0; n];
            a.mul_transpose_vec(&b, &mut atb).unwrap();
            let x_ref = Cholesky::factor(&ata).unwrap().solve(&atb).unwrap();
            let sol = min_norm_solve(&a, &b, tol(&a)).unwrap();
            assert_eq!(sol.rank, n);
            worst = worst.max(rel_err(&sol.x, &x_ref));
        }
        // Measured worst: 1.63e-14 (the normal-equations reference squares the condition number).
        eprintln!("SVD overdetermined vs normal equations: worst {worst:e}");
        assert!(worst < 1.6e-13);
    }

    #[test]
    fn damped_matches_regularized_normal_equations() {
        let mut rng = Rng::new(35);
        let mut worst = 0.0f64;
        for case in 0..60 {
            let m = rng.range(1, 25);
            let n = rng.range(1, 25);
            let mut a = rng.matrix(m, n);
            if case % 3 == 0 && m > 1 {
                // Rank-deficient: duplicate the first row.
                for s in 0..n {
                    let v = a.get(0, s);
                    a.set(m - 1, s, v);
                }
            }
            let b = rng.vec(m);
            let mu = 0.1 + rng.uniform().abs();
            let mut lhs = a.transpose().matmul(&a).unwrap();
            for i in 0..n {
                lhs.add_at(i, i, mu * mu);
            }
            let mut atb = alloc::vec![0.0; n];
            a.mul_transpose_vec(&b, &mut atb).unwrap();
            let x_ref = Cholesky::factor(&lhs).unwrap().solve(&atb).unwrap();
            let x = damped_solve(&a, &b, mu).unwrap();
            worst = worst.max(rel_err(&x, &x_ref));
        }
        // Measured worst: 2.06e-14 (mostly the error of the normal-equations reference).
        eprintln!("SVD damped vs (AᵀA + μ²I) Cholesky: worst {worst:e}");
        assert!(worst < 2e-13);
    }

    #[test]
    fn damped_tends_to_min_norm_and_zero_damping_is_min_norm() {
        let a = DenseMatrix::from_row_major(3, 2, &[1.0, 2.0, 1.0, 2.0, 3.0, 1.0]).unwrap();
        let b = [1.0, 1.0, 2.0];
        let svd = SvdSolver::new(&a, 1e-12).unwrap();
        let mut x0 = [0.0; 2];
        svd.solve_min_norm(&b, &mut x0).unwrap();
        let mut xd = [0.0; 2];
        svd.solve_damped(&b, 0.0, &mut xd).unwrap();
        assert!(rel_err(&xd, &x0) < 1e-15);
        svd.solve_damped(&b, 1e-6, &mut xd).unwrap();
        assert!(rel_err(&xd, &x0) < 1e-10);
        svd.solve_damped(&b, 1e3, &mut xd).unwrap();
        assert!(xd.iter().all(|v| v.abs() < 1e-4));
        assert!(svd.condition_number() > 1.0 && svd.condition_number().is_finite());
        assert_eq!(svd.singular_values().len(), 2);
        assert_eq!((svd.n_rows(), svd.n_cols()), (3, 2));
    }

    #[test]
    fn rank_deficiency_and_degenerate_shapes() {
        // Zero matrix: rank 0, x = 0.
        let z = DenseMatrix::zeros(3, 4);
        let sol = min_norm_solve(&z, &[1.0, 2.0, 3.0], 1e-12).unwrap();
        assert_eq!(sol.rank, 0);
        assert_eq!(sol.x, alloc::vec![0.0; 4]);
        assert_eq!(
            damped_solve(&z, &[1.0, 2.0, 3.0], 0.0).unwrap(),
            alloc::vec![0.0; 4]
        );
        // Empty matrices.
        let e = DenseMatrix::zeros(0, 2);
        let sol = min_norm_solve(&e, &[], 1e-12).unwrap();
        assert_eq!((sol.rank, sol.x), (0, alloc::vec![0.0; 2]));
        assert_eq!(
            SvdSolver::new(&e, 0.0).unwrap().condition_number(),
            f64::INFINITY
        );
        // Rank 1 with tolerance: [[1, 1], [1, 1 + 1e-14]] is rank 1 at tol 1e-10.
        let a = DenseMatrix::from_row_major(2, 2, &[1.0, 1.0, 1.0, 1.0 + 1e-14]).unwrap();
        let sol = min_norm_solve(&a, &[2.0, 2.0], 1e-10).unwrap();
        assert_eq!(sol.rank, 1);
        assert!(rel_err(&sol.x, &[1.0, 1.0]) < 1e-12);
        // Negative tolerance keeps every nonzero singular value.
        assert_eq!(SvdSolver::new(&a, -1.0).unwrap().rank(), 2);
    }

    #[test]
    fn invalid_input() {
        let a = DenseMatrix::identity(2);
        assert_eq!(
            min_norm_solve(&a, &[1.0], 1e-12),
            Err(SolveError::DimensionMismatch)
        );
        assert_eq!(
            damped_solve(&a, &[1.0], 0.1),
            Err(SolveError::DimensionMismatch)
        );
        let svd = SvdSolver::new(&a, 1e-12).unwrap();
        let mut x = [0.0; 3];
        assert_eq!(
            svd.solve_min_norm(&[1.0, 1.0], &mut x),
            Err(SolveError::DimensionMismatch)
        );
        let mut x = [0.0; 2];
        assert_eq!(
            svd.solve_min_norm(&[1.0, f64::NAN], &mut x),
            Err(SolveError::NonFinite)
        );
        assert_eq!(
            svd.solve_damped(&[1.0, 1.0], f64::NAN, &mut x),
            Err(SolveError::NonFinite)
        );
        assert_eq!(
            damped_solve(&a, &[1.0, 1.0], f64::INFINITY),
            Err(SolveError::NonFinite)
        );
        assert!(matches!(
            SvdSolver::new(&a, f64::NAN),
            Err(SolveError::NonFinite)
        ));
        let mut bad = DenseMatrix::identity(2);
        bad.set(0, 1, f64::NAN);
        assert!(matches!(
            SvdSolver::new(&bad, 1e-12),
            Err(SolveError::NonFinite)
        ));
        assert_eq!(
            min_norm_solve(&bad, &[1.0, 1.0], 1e-12),
            Err(SolveError::NonFinite)
        );
    }
}
