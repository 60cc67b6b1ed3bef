//! Generic linear-algebra layer for KKT systems, independent of constraints.
//!
//! The KKT systems of the lecture,
//!
//! ```text
//! [A  Jᵀ] [x]   [b]
//! [J  −C] [λ] = [c]
//! ```
//!
//! are symmetric and, for `C = 0`, indefinite (a saddle point). This module solves such
//! systems (and the smaller ones derived from them) with the solver families the lecture
//! names, all working on flat `f64` slices:
//!
//! | module | solver | source |
//! |---|---|---|
//! | [`dense`] | Cholesky `LLᵀ`, `LDLᵀ` without pivoting, LU with partial pivoting | Golub & Van Loan, *Matrix Computations*, 4th ed., §4.2, §4.1, §3.4 |
//! | [`minres`](mod@minres) | MINRES (symmetric, possibly indefinite, matrix-free) | Paige & Saunders 1975 |
//! | [`gmres`](mod@gmres) | restarted GMRES(m) (general, matrix-free) | Saad & Schultz 1986 |
//! | [`svd`] | minimum-norm and damped least squares via a one-sided Jacobi SVD | Golub & Van Loan §5.5, §6.1, §8.6.3; Demmel & Veselić 1992 |
//!
//! Iterative solvers see the matrix only through [`LinearOperator`] (`y = A x`), so a
//! KKT operator can be applied block by block without assembling it. They keep their
//! scratch vectors in a work struct that is sized on first use and reused, and they
//! report [`IterStats`]: the final relative residual `|b − A x| / |b|` is always
//! recomputed from the returned `x`, never taken from the solver's internal recurrence,
//! so an ill-conditioned system that cannot reach the tolerance is reported as such
//! (`converged == false`). [`IterStats::check`] turns that into
//! [`SolveError::NotConverged`] for callers who want an error.
//!
//! Everything here needs only `core` and `alloc`.

pub mod dense;
pub mod gmres;
pub mod minres;
pub mod svd;

pub use dense::{lu_solve, Cholesky, DenseMatrix, Ldlt, Lu};
pub use gmres::{gmres, GmresWork};
pub use minres::{minres, MinresWork};
pub use svd::{damped_solve, min_norm_solve, MinNormSolution, SvdSolver};

use alloc::vec::Vec;
use core::fmt;

/// Why a linear solve failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SolveError {
    /// Operand sizes do not fit together (a non-square matrix where a square one is
    /// needed, or a vector whose length differs from the matrix dimension).
    DimensionMismatch,
    /// Cholesky met a pivot that is not (numerically) positive: the matrix is not
    /// positive definite. `pivot` is the zero-based row of the failing pivot.
    NotPositiveDefinite {
        /// Zero-based index of the failing pivot.
        pivot: usize,
    },
    /// An elimination met a (numerically) zero pivot: the matrix is singular, or, for
    /// `LDLᵀ` without pivoting, not quasi-definite. `pivot` is the zero-based row.
    ZeroPivot {
        /// Zero-based index of the failing pivot.
        pivot: usize,
    },
    /// An input (matrix entry, right-hand side, initial guess, parameter) or an
    /// operator output was NaN or infinite.
    NonFinite,
    /// An iterative method stopped before reaching its tolerance.
    NotConverged {
        /// Iterations performed.
        iterations: usize,
        /// Relative residual `|b − A x| / |b|` of the returned iterate.
        residual: f64,
    },
}

impl fmt::Display for SolveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::DimensionMismatch => f.write_str("operand dimensions do not match"),
            Self::NotPositiveDefinite { pivot } => {
                write!(f, "matrix is not positive definite (pivot {pivot})")
            }
            Self::ZeroPivot { pivot } => write!(f, "zero pivot at row {pivot}"),
            Self::NonFinite => f.write_str("non-finite input (NaN or infinity)"),
            Self::NotConverged {
                iterations,
                residual,
            } => write!(
                f,
                "not converged after {iterations} iterations (relative residual {residual:e})"
            ),
        }
    }
}

impl core::error::Error for SolveError {}

/// A square linear map applied matrix-free: `y = A x`.
///
/// Iterative solvers only ever call [`LinearOperator::apply`] with slices of length
/// [`LinearOperator::dim`]; they check the lengths of their own inputs first.
pub trait LinearOperator {
    /// The dimension `n` of the (square) operator.
    fn dim(&self) -> usize;

    /// Writes `y = A x`. Both slices have length [`LinearOperator::dim`]; `y` need not be
    /// zeroed beforehand.
    fn apply(&self, x: &[f64], y: &mut [f64]);
}

impl<T: LinearOperator + ?Sized> LinearOperator for &T {
    fn dim(&self) -> usize {
        (**self).dim()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        (**self).apply(x, y);
    }
}

/// Stopping criteria of the iterative solvers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterSettings {
    /// Target relative residual `|b − A x| / |b|`.
    pub tolerance: f64,
    /// Maximum number of operator applications inside the Krylov iterations (the
    /// residual recomputations at restarts are not counted).
    pub max_iterations: usize,
}

impl Default for IterSettings {
    /// `tolerance = 1e-10`, `max_iterations = 10_000`.
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_iterations: 10_000,
        }
    }
}

/// What an iterative solve achieved.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IterStats {
    /// Krylov iterations performed (operator applications, not counting the residual
    /// recomputations at start and restarts).
    pub iterations: usize,
    /// Relative residual `|b − A x| / |b|` of the returned `x`, recomputed with the
    /// operator (`0` when `b = 0`).
    pub residual: f64,
    /// `true` exactly when `residual <= tolerance`.
    pub converged: bool,
    /// The solver's relative residual estimate after each iteration (the Krylov
    /// recurrence value; at a restart it is re-anchored to the recomputed residual).
    pub history: Vec<f64>,
}

impl IterStats {
    /// `Ok(self)` when converged, otherwise [`SolveError::NotConverged`].
    pub fn check(self) -> Result<Self, SolveError> {
        if self.converged {
            Ok(self)
        } else {
            Err(SolveError::NotConverged {
                iterations: self.iterations,
                residual: self.residual,
            })
        }
    }
}

/// `√x` without `std` (libm through nalgebra's `ComplexField` when `std` is absent).
#[inline]
pub(crate) fn sqrt(x: f64) -> f64 {
    <f64 as nalgebra::ComplexField>::sqrt(x)
}

/// `√(a² + b²)` without undue overflow or underflow.
#[inline]
pub(crate) fn hypot(a: f64, b: f64) -> f64 {
    <f64 as nalgebra::ComplexField>::hypot(a, b)
}

/// Euclidean inner product of two equally long slices.
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Euclidean norm.
#[inline]
pub(crate) fn norm(a: &[f64]) -> f64 {
    sqrt(dot(a, a))
}

/// `true` when every entry is finite.
#[inline]
pub(crate) fn all_finite(a: &[f64]) -> bool {
    a.iter().all(|v| v.is_finite())
}

/// Checks the common preconditions of the iterative solvers and the finite settings.
pub(crate) fn check_iterative_inputs(
    n: usize,
    b: &[f64],
    x: &[f64],
    settings: &IterSettings,
) -> Result<(), SolveError> {
    if b.len() != n || x.len() != n {
        return Err(SolveError::DimensionMismatch);
    }
    if !all_finite(b) || !all_finite(x) || !settings.tolerance.is_finite() {
        return Err(SolveError::NonFinite);
    }
    Ok(())
}

/// `r = b − A x`; returns `|r|`. `NonFinite` when the operator produced NaN/∞.
pub(crate) fn residual<A: LinearOperator + ?Sized>(
    a: &A,
    b: &[f64],
    x: &[f64],
    r: &mut [f64],
) -> Result<f64, SolveError> {
    a.apply(x, r);
    for (ri, bi) in r.iter_mut().zip(b) {
        *ri = bi - *ri;
    }
    let rn = norm(r);
    if rn.is_finite() {
        Ok(rn)
    } else {
        Err(SolveError::NonFinite)
    }
}

/// Seeded random systems shared by the tests of every solver.
#[cfg(test)]
pub(crate) mod testutil {
    use super::{DenseMatrix, LinearOperator};
    use alloc::vec::Vec;

    /// xorshift64* (Marsaglia 2003; Vigna 2016): deterministic, dependency-free.
    pub struct Rng(u64);

    impl Rng {
        pub fn new(seed: u64) -> Self {
            Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
        }

        pub fn next_u64(&mut self) -> u64 {
            let mut x = self.0;
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            self.0 = x;
            x.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }

        /// Uniform in `[-1, 1)`.
        pub fn uniform(&mut self) -> f64 {
            ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }

        /// Uniform in `lo..hi` for small ranges.
        pub fn range(&mut self, lo: usize, hi: usize) -> usize {
            lo + (self.next_u64() % (hi - lo) as u64) as usize
        }

        pub fn vec(&mut self, n: usize) -> Vec<f64> {
            (0..n).map(|_| self.uniform()).collect()
        }

        pub fn matrix(&mut self, m: usize, n: usize) -> DenseMatrix {
            let mut a = DenseMatrix::zeros(m, n);
            for j in 0..n {
                for i in 0..m {
                    a.set(i, j, self.uniform());
                }
            }
            a
        }

        /// General nonsymmetric, well conditioned: random entries plus `2√n·I`.
        pub fn general(&mut self, n: usize) -> DenseMatrix {
            let mut a = self.matrix(n, n);
            let shift = 2.0 * super::sqrt(n as f64);
            for i in 0..n {
                a.set(i, i, a.get(i, i) + shift);
            }
            a
        }

        /// Symmetric positive definite: `B Bᵀ / n + I`.
        pub fn spd(&mut self, n: usize) -> DenseMatrix {
            let b = self.matrix(n, n);
            let mut a = DenseMatrix::zeros(n, n);
            for i in 0..n {
                for j in 0..n {
                    let mut s = 0.0;
                    for k in 0..n {
                        s += b.get(i, k) * b.get(j, k);
                    }
                    a.set(i, j, s / n as f64 + if i == j { 1.0 } else { 0.0 });
                }
            }
            a
        }

        /// Symmetric indefinite, diagonally dominant: diagonal `±(n + 1 + u)`, symmetric
        /// off-diagonal entries in `[-1, 1]`, so every eigenvalue has `|λ| ≥ 1`.
        pub fn sym_indefinite(&mut self, n: usize) -> DenseMatrix {
            let mut a = DenseMatrix::zeros(n, n);
            for i in 0..n {
                let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
                a.set(i, i, sign * (n as f64 + 1.0 + self.uniform().abs()));
                for j in 0..i {
                    let v = self.uniform();
                    a.set(i, j, v);
                    a.set(j, i, v);
                }
            }
            a
        }

        /// Saddle-point KKT matrix `[A Jᵀ; J −C]` with SPD `A` (`n × n`) and random
        /// (full-rank with probability one) `J` (`k × n`, `k < n`); `c` is the diagonal
        /// of `C` (empty for `C = 0`).
        pub fn kkt(&mut self, n: usize, k: usize, c: &[f64]) -> DenseMatrix {
            let a = self.spd(n);
            let j = self.matrix(k, n);
            let mut kkt = DenseMatrix::zeros(n + k, n + k);
            for r in 0..n {
                for s in 0..n {
                    kkt.set(r, s, a.get(r, s));
                }
            }
            for r in 0..k {
                for s in 0..n {
                    kkt.set(n + r, s, j.get(r, s));
                    kkt.set(s, n + r, j.get(r, s));
                }
                if let Some(&cr) = c.get(r) {
                    kkt.set(n + r, n + r, -cr);
                }
            }
            kkt
        }
    }

    /// The KKT operator `[A Jᵀ; J 0]` applied block by block, never assembled.
    pub struct KktOperator {
        pub a: DenseMatrix,
        pub j: DenseMatrix,
    }

    impl LinearOperator for KktOperator {
        fn dim(&self) -> usize {
            self.a.n_rows() + self.j.n_rows()
        }

        fn apply(&self, x: &[f64], y: &mut [f64]) {
            let n = self.a.n_rows();
            let (xv, xl) = x.split_at(n);
            let (yv, yl) = y.split_at_mut(n);
            self.a.mul_vec(xv, yv).unwrap();
            let mut jt = alloc::vec![0.0; n];
            self.j.mul_transpose_vec(xl, &mut jt).unwrap();
            for (a, b) in yv.iter_mut().zip(&jt) {
                *a += b;
            }
            self.j.mul_vec(xv, yl).unwrap();
        }
    }

    /// `Q diag(σ_i) Q` with `Q = I − 2uuᵀ/|u|²`, `σ_i = sign(i) · min^{i/(n−1)}`.
    pub fn ill_conditioned(
        rng: &mut Rng,
        n: usize,
        min: f64,
        sign: impl Fn(usize) -> f64,
    ) -> DenseMatrix {
        let u = rng.vec(n);
        let uu: f64 = u.iter().map(|v| v * v).sum();
        let q = DenseMatrix::from_fn(n, n, |i, j| {
            (if i == j { 1.0 } else { 0.0 }) - 2.0 * u[i] * u[j] / uu
        });
        let d = DenseMatrix::from_fn(n, n, |i, j| {
            if i == j {
                sign(i) * <f64 as nalgebra::ComplexField>::powf(min, i as f64 / (n - 1) as f64)
            } else {
                0.0
            }
        });
        q.matmul(&d).unwrap().matmul(&q).unwrap()
    }

    /// `|a − b| / |b|`.
    pub fn rel_err(a: &[f64], b: &[f64]) -> f64 {
        let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
        let den: f64 = b.iter().map(|y| y * y).sum();
        super::sqrt(num / den)
    }

    /// Independently recomputed `|b − A x| / |b|`.
    pub fn rel_residual(a: &DenseMatrix, x: &[f64], b: &[f64]) -> f64 {
        let mut ax = alloc::vec![0.0; a.n_rows()];
        a.mul_vec(x, &mut ax).unwrap();
        rel_err(&ax, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_and_check() {
        let e = SolveError::NotConverged {
            iterations: 3,
            residual: 0.5,
        };
        assert!(alloc::format!("{e}").contains("3 iterations"));
        let s = IterStats {
            iterations: 3,
            residual: 0.5,
            converged: false,
            history: Vec::new(),
        };
        assert_eq!(s.check(), Err(e));
        assert_eq!(
            alloc::format!("{}", SolveError::NotPositiveDefinite { pivot: 2 }),
            "matrix is not positive definite (pivot 2)"
        );
        let d = IterSettings::default();
        assert_eq!((d.tolerance, d.max_iterations), (1e-10, 10_000));
    }

    #[test]
    fn sqrt_hypot() {
        assert_eq!(sqrt(4.0), 2.0);
        assert!((hypot(3e200, 4e200) - 5e200).abs() < 1e186);
    }
}
