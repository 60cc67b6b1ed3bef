//! Dense matrices and direct factorizations.
//!
//! * [`DenseMatrix`]: a column-major `m × n` matrix with the products the solvers need.
//! * [`Cholesky`]: `A = L Lᵀ` for symmetric positive definite `A` (the mass matrix, the
//!   Schur complement `J A⁻¹ Jᵀ + C`). Outer-product (right-looking) Cholesky, Golub &
//!   Van Loan, *Matrix Computations*, 4th ed., Algorithm 4.2.2.
//! * [`Ldlt`]: `A = L D Lᵀ` without pivoting (Golub & Van Loan §4.1.2). Without pivoting
//!   the factorization exists and is stable for symmetric *quasi-definite* matrices
//!   `[A Jᵀ; J −C]` with `A` positive definite and `C` positive semidefinite, `J` of
//!   full row rank when `C = 0` (Vanderbei 1995, "Symmetric quasidefinite matrices",
//!   SIAM J. Optim. 5(1)): the KKT matrices of the lecture. The signs of `D` give the
//!   inertia (`n` positive, `k` negative pivots for a KKT matrix).
//! * [`Lu`] / [`lu_solve`]: LU with partial (row) pivoting, `P A = L U` (Golub & Van
//!   Loan Algorithm 3.4.1): the dense reference solver for full, indefinite KKT matrices.
//!
//! All three factor in place in one `n × n` buffer: the only allocation happens when a
//! factorization is created ([`Cholesky::factor`] copies its input,
//! [`Cholesky::from_matrix`] consumes it, [`Cholesky::refactor`] reuses the buffer), and
//! `solve_in_place` allocates nothing.
//!
//! ## Pivot tolerance
//!
//! A pivot is treated as zero when `|pivot| ≤ n·ε·max|a_ij|` (for Cholesky: when
//! `pivot ≤ n·ε·max a_ii`), i.e. when it is at the level of the rounding error of the
//! elimination. Such a matrix is numerically singular (or, for Cholesky, not positive
//! definite) and the factorization reports the failing row instead of returning a
//! solution amplified by `1/ε`.

use super::{all_finite, sqrt, LinearOperator, SolveError};
use alloc::vec::Vec;

/// A dense `n_rows × n_cols` matrix stored column by column.
///
/// The entry `(i, j)` lives at `data[i + j·n_rows]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DenseMatrix {
    n_rows: usize,
    n_cols: usize,
    data: Vec<f64>,
}

impl DenseMatrix {
    /// The `n_rows × n_cols` zero matrix.
    pub fn zeros(n_rows: usize, n_cols: usize) -> Self {
        Self {
            n_rows,
            n_cols,
            data: alloc::vec![0.0; n_rows * n_cols],
        }
    }

    /// The `n × n` identity.
    pub fn identity(n: usize) -> Self {
        let mut a = Self::zeros(n, n);
        for i in 0..n {
            a.data[i + i * n] = 1.0;
        }
        a
    }

    /// Wraps column-major data. [`SolveError::DimensionMismatch`] when
    /// `data.len() != n_rows·n_cols`.
    pub fn from_col_major(
        n_rows: usize,
        n_cols: usize,
        data: Vec<f64>,
    ) -> Result<Self, SolveError> {
        if n_rows.checked_mul(n_cols) != Some(data.len()) {
            return Err(SolveError::DimensionMismatch);
        }
        Ok(Self {
            n_rows,
            n_cols,
            data,
        })
    }

    /// Copies row-major data (the order in which matrices are written in source code).
    /// [`SolveError::DimensionMismatch`] when `data.len() != n_rows·n_cols`.
    pub fn from_row_major(n_rows: usize, n_cols: usize, data: &[f64]) -> Result<Self, SolveError> {
        if n_rows.checked_mul(n_cols) != Some(data.len()) {
            return Err(SolveError::DimensionMismatch);
        }
        Ok(Self::from_fn(n_rows, n_cols, |i, j| data[i * n_cols + j]))
    }

    /// The matrix with entries `f(i, j)`.
    pub fn from_fn(n_rows: usize, n_cols: usize, mut f: impl FnMut(usize, usize) -> f64) -> Self {
        let mut data = Vec::with_capacity(n_rows * n_cols);
        for j in 0..n_cols {
            for i in 0..n_rows {
                data.push(f(i, j));
            }
        }
        Self {
            n_rows,
            n_cols,
            data,
        }
    }

    /// Number of rows.
    pub fn n_rows(&self) -> usize {
        self.n_rows
    }

    /// Number of columns.
    pub fn n_cols(&self) -> usize {
        self.n_cols
    }

    /// `true` when the matrix is square.
    pub fn is_square(&self) -> bool {
        self.n_rows == self.n_cols
    }

    /// The column-major entries.
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }

    /// The column-major entries, mutably.
    pub fn as_mut_slice(&mut self) -> &mut [f64] {
        &mut self.data
    }

    /// The column-major entries, by value.
    pub fn into_vec(self) -> Vec<f64> {
        self.data
    }

    /// Column `j` as a slice.
    ///
    /// # Panics
    /// When `j >= n_cols`.
    pub fn column(&self, j: usize) -> &[f64] {
        &self.data[j * self.n_rows..(j + 1) * self.n_rows]
    }

    /// Entry `(i, j)`.
    ///
    /// # Panics
    /// When `i >= n_rows` or `j >= n_cols`.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        assert!(i < self.n_rows && j < self.n_cols, "index out of range");
        self.data[i + j * self.n_rows]
    }

    /// Sets entry `(i, j)`.
    ///
    /// # Panics
    /// When `i >= n_rows` or `j >= n_cols`.
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, value: f64) {
        assert!(i < self.n_rows && j < self.n_cols, "index out of range");
        self.data[i + j * self.n_rows] = value;
    }

    /// Adds `value` to entry `(i, j)` (assembly).
    ///
    /// # Panics
    /// When `i >= n_rows` or `j >= n_cols`.
    #[inline]
    pub fn add_at(&mut self, i: usize, j: usize, value: f64) {
        assert!(i < self.n_rows && j < self.n_cols, "index out of range");
        self.data[i + j * self.n_rows] += value;
    }

    /// Sets every entry to zero, keeping the shape and the allocation.
    pub fn fill_zero(&mut self) {
        self.data.fill(0.0);
    }

    /// `true` when every entry is finite.
    pub fn is_finite(&self) -> bool {
        all_finite(&self.data)
    }

    /// The largest absolute entry (`0` for an empty matrix).
    pub fn max_abs(&self) -> f64 {
        self.data.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// `y = A x`. [`SolveError::DimensionMismatch`] unless `x.len() == n_cols` and
    /// `y.len() == n_rows`.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<(), SolveError> {
        if x.len() != self.n_cols || y.len() != self.n_rows {
            return Err(SolveError::DimensionMismatch);
        }
        self.gemv(x, y);
        Ok(())
    }

    /// `y = Aᵀ x`. [`SolveError::DimensionMismatch`] unless `x.len() == n_rows` and
    /// `y.len() == n_cols`.
    pub fn mul_transpose_vec(&self, x: &[f64], y: &mut [f64]) -> Result<(), SolveError> {
        if x.len() != self.n_rows || y.len() != self.n_cols {
            return Err(SolveError::DimensionMismatch);
        }
        if self.n_rows == 0 {
            y.fill(0.0);
            return Ok(());
        }
        for (yj, col) in y.iter_mut().zip(self.data.chunks_exact(self.n_rows)) {
            *yj = super::dot(col, x);
        }
        Ok(())
    }

    /// `Aᵀ`.
    pub fn transpose(&self) -> Self {
        Self::from_fn(self.n_cols, self.n_rows, |i, j| {
            self.data[j + i * self.n_rows]
        })
    }

    /// The product `A B`. [`SolveError::DimensionMismatch`] unless
    /// `A.n_cols == B.n_rows`.
    pub fn matmul(&self, other: &Self) -> Result<Self, SolveError> {
        if self.n_cols != other.n_rows {
            return Err(SolveError::DimensionMismatch);
        }
        let mut c = Self::zeros(self.n_rows, other.n_cols);
        if self.n_rows == 0 || other.n_rows == 0 {
            return Ok(c);
        }
        for (c_col, b_col) in c
            .data
            .chunks_exact_mut(self.n_rows)
            .zip(other.data.chunks_exact(other.n_rows))
        {
            self.gemv(b_col, c_col);
        }
        Ok(c)
    }

    /// Copies the matrix into a `nalgebra::DMatrix`.
    pub fn to_nalgebra(&self) -> nalgebra::DMatrix<f64> {
        nalgebra::DMatrix::from_column_slice(self.n_rows, self.n_cols, &self.data)
    }

    /// `y = A x` for lengths already checked (never panics on mismatch: extra entries
    /// are ignored).
    fn gemv(&self, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        if self.n_rows == 0 {
            return;
        }
        for (col, &xj) in self.data.chunks_exact(self.n_rows).zip(x) {
            if xj != 0.0 {
                for (yi, aij) in y.iter_mut().zip(col) {
                    *yi += aij * xj;
                }
            }
        }
    }
}

impl LinearOperator for DenseMatrix {
    /// `n_rows`; a `DenseMatrix` used as an operator must be square.
    fn dim(&self) -> usize {
        self.n_rows
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.gemv(x, y);
    }
}

/// Checks that `a` is square and finite; returns `n`.
fn check_square(a: &DenseMatrix) -> Result<usize, SolveError> {
    if !a.is_square() {
        return Err(SolveError::DimensionMismatch);
    }
    if !a.is_finite() {
        return Err(SolveError::NonFinite);
    }
    Ok(a.n_rows)
}

/// Checks a right-hand side against the factor dimension.
fn check_rhs(n: usize, b: &[f64]) -> Result<(), SolveError> {
    if b.len() != n {
        return Err(SolveError::DimensionMismatch);
    }
    if !all_finite(b) {
        return Err(SolveError::NonFinite);
    }
    Ok(())
}

/// `L y = b` in place, `L` lower triangular in column-major `l` (`unit`: implicit ones).
fn forward_substitute(l: &[f64], n: usize, unit: bool, b: &mut [f64]) {
    for j in 0..n {
        if !unit {
            b[j] /= l[j + j * n];
        }
        let bj = b[j];
        if bj != 0.0 {
            for i in j + 1..n {
                b[i] -= l[i + j * n] * bj;
            }
        }
    }
}

/// `Lᵀ x = y` in place, `L` lower triangular in column-major `l` (`unit`: implicit ones).
fn backward_substitute_transposed(l: &[f64], n: usize, unit: bool, b: &mut [f64]) {
    for j in (0..n).rev() {
        let col = &l[j * n..(j + 1) * n];
        let s: f64 = col[j + 1..]
            .iter()
            .zip(&b[j + 1..])
            .map(|(a, x)| a * x)
            .sum();
        b[j] -= s;
        if !unit {
            b[j] /= col[j];
        }
    }
}

/// Cholesky factorization `A = L Lᵀ` of a symmetric positive definite matrix.
///
/// Only the lower triangle of `A` is read.
#[derive(Clone, Debug, PartialEq)]
pub struct Cholesky {
    l: DenseMatrix,
}

impl Cholesky {
    /// Factors a copy of `a`.
    ///
    /// Errors: [`SolveError::DimensionMismatch`] (not square), [`SolveError::NonFinite`],
    /// [`SolveError::NotPositiveDefinite`] with the first failing pivot.
    pub fn factor(a: &DenseMatrix) -> Result<Self, SolveError> {
        Self::from_matrix(a.clone())
    }

    /// Factors `a` in its own storage.
    pub fn from_matrix(a: DenseMatrix) -> Result<Self, SolveError> {
        let mut c = Self { l: a };
        c.factor_stored()?;
        Ok(c)
    }

    /// Factors `a` into this factorization's storage (no allocation when the size is
    /// unchanged). On error the previous factor is lost.
    pub fn refactor(&mut self, a: &DenseMatrix) -> Result<(), SolveError> {
        self.l.clone_from(a);
        self.factor_stored()
    }

    fn factor_stored(&mut self) -> Result<(), SolveError> {
        let n = check_square(&self.l)?;
        let a = &mut self.l.data;
        let diag_max = (0..n).fold(0.0f64, |m, i| m.max(a[i + i * n].abs()));
        let tol = n as f64 * f64::EPSILON * diag_max;
        for j in 0..n {
            let d = a[j + j * n];
            if !(d > tol) {
                return Err(SolveError::NotPositiveDefinite { pivot: j });
            }
            let ljj = sqrt(d);
            a[j + j * n] = ljj;
            for i in j + 1..n {
                a[i + j * n] /= ljj;
            }
            // Outer-product update of the trailing lower triangle.
            for k in j + 1..n {
                let lkj = a[k + j * n];
                if lkj != 0.0 {
                    for i in k..n {
                        a[i + k * n] -= a[i + j * n] * lkj;
                    }
                }
            }
            // Clear the strict upper part of column j's row so `l` is truly lower.
            for k in j + 1..n {
                a[j + k * n] = 0.0;
            }
        }
        Ok(())
    }

    /// The dimension `n`.
    pub fn dim(&self) -> usize {
        self.l.n_rows
    }

    /// The factor `L` (lower triangular, zero above the diagonal).
    pub fn l(&self) -> &DenseMatrix {
        &self.l
    }

    /// Overwrites `b` with `A⁻¹ b`. Allocates nothing.
    pub fn solve_in_place(&self, b: &mut [f64]) -> Result<(), SolveError> {
        let n = self.dim();
        check_rhs(n, b)?;
        forward_substitute(&self.l.data, n, false, b);
        backward_substitute_transposed(&self.l.data, n, false, b);
        Ok(())
    }

    /// Returns `A⁻¹ b` in a new vector.
    pub fn solve(&self, b: &[f64]) -> Result<Vec<f64>, SolveError> {
        let mut x = b.to_vec();
        self.solve_in_place(&mut x)?;
        Ok(x)
    }
}

/// Factorization `A = L D Lᵀ` (unit lower `L`, diagonal `D`) without pivoting, for
/// symmetric quasi-definite matrices.
///
/// Only the lower triangle of `A` is read. `L` is stored below the diagonal and `D` on
/// it.
#[derive(Clone, Debug, PartialEq)]
pub struct Ldlt {
    ld: DenseMatrix,
}

impl Ldlt {
    /// Factors a copy of `a`.
    ///
    /// Errors: [`SolveError::DimensionMismatch`] (not square), [`SolveError::NonFinite`],
    /// [`SolveError::ZeroPivot`] with the first pivot `|d_j| ≤ n·ε·max|a_ij|`.
    pub fn factor(a: &DenseMatrix) -> Result<Self, SolveError> {
        Self::from_matrix(a.clone())
    }

    /// Factors `a` in its own storage.
    pub fn from_matrix(a: DenseMatrix) -> Result<Self, SolveError> {
        let mut f = Self { ld: a };
        f.factor_stored()?;
        Ok(f)
    }

    /// Factors `a` into this factorization's storage (no allocation when the size is
    /// unchanged). On error the previous factor is lost.
    pub fn refactor(&mut self, a: &DenseMatrix) -> Result<(), SolveError> {
        self.ld.clone_from(a);
        self.factor_stored()
    }

    fn factor_stored(&mut self) -> Result<(), SolveError> {
        let n = check_square(&self.ld)?;
        let a = &mut self.ld.data;
        let mut amax = 0.0f64;
        for j in 0..n {
            for i in j..n {
                amax = amax.max(a[i + j * n].abs());
            }
        }
        let tol = n as f64 * f64::EPSILON * amax;
        for j in 0..n {
            let d = a[j + j * n];
            if !(d.abs() > tol) {
                return Err(SolveError::ZeroPivot { pivot: j });
            }
            // Trailing update A₂₂ -= l d lᵀ, with l = a(j+1.., j) / d.
            for k in j + 1..n {
                let akj = a[k + j * n];
                if akj != 0.0 {
                    let lkj = akj / d;
                    for i in k..n {
                        a[i + k * n] -= a[i + j * n] * lkj;
                    }
                }
            }
            for i in j + 1..n {
                a[i + j * n] /= d;
            }
            for k in j + 1..n {
                a[j + k * n] = 0.0;
            }
        }
        Ok(())
    }

    /// The dimension `n`.
    pub fn dim(&self) -> usize {
        self.ld.n_rows
    }

    /// Pivot `d_j` of `D`.
    ///
    /// # Panics
    /// When `j >= n`.
    pub fn d(&self, j: usize) -> f64 {
        self.ld.get(j, j)
    }

    /// `(positive, negative)` pivot counts: the inertia of `A` (Sylvester's law). A KKT
    /// matrix `[A Jᵀ; J −C]` with `A` of size `n` and `k` constraints has `(n, k)`.
    pub fn inertia(&self) -> (usize, usize) {
        let n = self.dim();
        let pos = (0..n).filter(|&j| self.ld.data[j + j * n] > 0.0).count();
        (pos, n - pos)
    }

    /// Overwrites `b` with `A⁻¹ b`. Allocates nothing.
    pub fn solve_in_place(&self, b: &mut [f64]) -> Result<(), SolveError> {
        let n = self.dim();
        check_rhs(n, b)?;
        let l = &self.ld.data;
        forward_substitute(l, n, true, b);
        for j in 0..n {
            b[j] /= l[j + j * n];
        }
        backward_substitute_transposed(l, n, true, b);
        Ok(())
    }

    /// Returns `A⁻¹ b` in a new vector.
    pub fn solve(&self, b: &[f64]) -> Result<Vec<f64>, SolveError> {
        let mut x = b.to_vec();
        self.solve_in_place(&mut x)?;
        Ok(x)
    }
}

/// LU factorization with partial pivoting, `P A = L U`.
///
/// `L` (unit lower) and `U` share one column-major buffer; `pivots[k]` is the row
/// swapped with row `k` at step `k` (LAPACK `getrf` convention).
#[derive(Clone, Debug, PartialEq)]
pub struct Lu {
    lu: DenseMatrix,
    pivots: Vec<usize>,
}

impl Lu {
    /// Factors a copy of `a`.
    ///
    /// Errors: [`SolveError::DimensionMismatch`] (not square), [`SolveError::NonFinite`],
    /// [`SolveError::ZeroPivot`] when the largest candidate pivot of a column is
    /// `≤ n·ε·max|a_ij|` (numerically singular).
    pub fn factor(a: &DenseMatrix) -> Result<Self, SolveError> {
        Self::from_matrix(a.clone())
    }

    /// Factors `a` in its own storage.
    pub fn from_matrix(a: DenseMatrix) -> Result<Self, SolveError> {
        let mut f = Self {
            lu: a,
            pivots: Vec::new(),
        };
        f.factor_stored()?;
        Ok(f)
    }

    /// Factors `a` into this factorization's storage (no allocation when the size is
    /// unchanged). On error the previous factor is lost.
    pub fn refactor(&mut self, a: &DenseMatrix) -> Result<(), SolveError> {
        self.lu.clone_from(a);
        self.factor_stored()
    }

    fn factor_stored(&mut self) -> Result<(), SolveError> {
        let n = check_square(&self.lu)?;
        self.pivots.clear();
        self.pivots.resize(n, 0);
        let tol = n as f64 * f64::EPSILON * self.lu.max_abs();
        let a = &mut self.lu.data;
        for k in 0..n {
            let mut p = k;
            let mut best = a[k + k * n].abs();
            for i in k + 1..n {
                let v = a[i + k * n].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best > tol) {
                return Err(SolveError::ZeroPivot { pivot: k });
            }
            self.pivots[k] = p;
            if p != k {
                for j in 0..n {
                    a.swap(k + j * n, p + j * n);
                }
            }
            let akk = a[k + k * n];
            for i in k + 1..n {
                a[i + k * n] /= akk;
            }
            for j in k + 1..n {
                let akj = a[k + j * n];
                if akj != 0.0 {
                    for i in k + 1..n {
                        a[i + j * n] -= a[i + k * n] * akj;
                    }
                }
            }
        }
        Ok(())
    }

    /// The dimension `n`.
    pub fn dim(&self) -> usize {
        self.lu.n_rows
    }

    /// Overwrites `b` with `A⁻¹ b`. Allocates nothing.
    pub fn solve_in_place(&self, b: &mut [f64]) -> Result<(), SolveError> {
        let n = self.dim();
        check_rhs(n, b)?;
        for (k, &p) in self.pivots.iter().enumerate() {
            b.swap(k, p);
        }
        let a = &self.lu.data;
        forward_substitute(a, n, true, b);
        for j in (0..n).rev() {
            b[j] /= a[j + j * n];
            let bj = b[j];
            if bj != 0.0 {
                for i in 0..j {
                    b[i] -= a[i + j * n] * bj;
                }
            }
        }
        Ok(())
    }

    /// Returns `A⁻¹ b` in a new vector.
    pub fn solve(&self, b: &[f64]) -> Result<Vec<f64>, SolveError> {
        let mut x = b.to_vec();
        self.solve_in_place(&mut x)?;
        Ok(x)
    }
}

/// Solves `A x = b` by LU with partial pivoting: the dense reference solver for any
/// square nonsingular system, including indefinite KKT matrices.
pub fn lu_solve(a: &DenseMatrix, b: &[f64]) -> Result<Vec<f64>, SolveError> {
    if b.len() != a.n_rows {
        return Err(SolveError::DimensionMismatch);
    }
    Lu::factor(a)?.solve(b)
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{rel_err, rel_residual, Rng};
    use super::*;

    const CASES: usize = 60;

    #[test]
    fn matrix_helpers() {
        let a = DenseMatrix::from_row_major(2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!(a.get(1, 0), 4.0);
        assert_eq!(a.column(2), &[3.0, 6.0]);
        let mut y = [0.0; 2];
        a.mul_vec(&[1.0, 1.0, 1.0], &mut y).unwrap();
        assert_eq!(y, [6.0, 15.0]);
        let mut z = [0.0; 3];
        a.mul_transpose_vec(&[1.0, -1.0], &mut z).unwrap();
        assert_eq!(z, [-3.0, -3.0, -3.0]);
        let at = a.transpose();
        assert_eq!((at.n_rows(), at.n_cols(), at.get(2, 1)), (3, 2, 6.0));
        let ata = at.matmul(&a).unwrap();
        assert_eq!(ata.get(0, 0), 17.0);
        assert_eq!(ata.get(2, 1), 2.0 * 3.0 + 5.0 * 6.0);
        assert_eq!(
            a.mul_vec(&[1.0, 1.0], &mut y),
            Err(SolveError::DimensionMismatch)
        );
        assert_eq!(a.matmul(&a), Err(SolveError::DimensionMismatch));
        assert_eq!(
            DenseMatrix::from_col_major(2, 2, alloc::vec![0.0; 3]),
            Err(SolveError::DimensionMismatch)
        );
        let mut id = DenseMatrix::identity(3);
        id.add_at(0, 2, 5.0);
        assert_eq!(id.as_slice()[6], 5.0);
        assert_eq!(id.to_nalgebra()[(0, 2)], 5.0);
        id.fill_zero();
        assert_eq!(id.max_abs(), 0.0);
    }

    #[test]
    fn lu_recovers_known_solution() {
        let mut rng = Rng::new(1);
        let mut worst = 0.0f64;
        for case in 0..CASES {
            let n = rng.range(1, 40);
            let a = rng.general(n);
            let x_true = rng.vec(n);
            let mut b = alloc::vec![0.0; n];
            a.mul_vec(&x_true, &mut b).unwrap();
            let x = lu_solve(&a, &b).unwrap();
            let e = rel_err(&x, &x_true);
            worst = worst.max(e);
            assert!(e < 1e-12, "case {case}: {e:e}");
        }
        // Measured worst: 4.9e-16.
        eprintln!("LU vs known solution: worst relative error {worst:e}");
        assert!(worst < 5e-15);
    }

    #[test]
    fn cholesky_matches_lu() {
        let mut rng = Rng::new(2);
        let mut worst = 0.0f64;
        let mut chol = Cholesky::factor(&DenseMatrix::identity(1)).unwrap();
        for _ in 0..CASES {
            let n = rng.range(1, 40);
            let a = rng.spd(n);
            let b = rng.vec(n);
            let x_ref = lu_solve(&a, &b).unwrap();
            chol.refactor(&a).unwrap();
            let mut x = b.clone();
            chol.solve_in_place(&mut x).unwrap();
            worst = worst.max(rel_err(&x, &x_ref));
            // L Lᵀ reproduces A.
            let l = chol.l();
            let llt = l.matmul(&l.transpose()).unwrap();
            for (p, q) in llt.as_slice().iter().zip(a.as_slice()) {
                assert!((p - q).abs() < 1e-12);
            }
        }
        // Measured worst: 3.4e-16.
        eprintln!("Cholesky vs LU: worst relative difference {worst:e}");
        assert!(worst < 4e-15);
    }

    #[test]
    fn ldlt_matches_lu_on_quasi_definite_kkt() {
        let mut rng = Rng::new(3);
        let mut worst = 0.0f64;
        for case in 0..CASES {
            let n = rng.range(2, 30);
            let k = rng.range(1, n);
            // Hard (C = 0) for even cases, compliant C > 0 for odd ones.
            let c: Vec<f64> = if case % 2 == 0 {
                Vec::new()
            } else {
                (0..k).map(|_| 1e-3 * (1.0 + rng.uniform().abs())).collect()
            };
            let kkt = rng.kkt(n, k, &c);
            let b = rng.vec(n + k);
            let x_ref = lu_solve(&kkt, &b).unwrap();
            let f = Ldlt::factor(&kkt).unwrap();
            assert_eq!(f.inertia(), (n, k), "case {case}");
            let x = f.solve(&b).unwrap();
            worst = worst.max(rel_err(&x, &x_ref));
        }
        // Measured worst: 8.4e-14.
        eprintln!("LDLT vs LU (KKT): worst relative difference {worst:e}");
        assert!(worst < 1e-12);
    }

    #[test]
    fn ldlt_matches_lu_on_symmetric_indefinite() {
        let mut rng = Rng::new(4);
        let mut worst = 0.0f64;
        for _ in 0..CASES {
            let n = rng.range(1, 40);
            let a = rng.sym_indefinite(n);
            let b = rng.vec(n);
            let x_ref = lu_solve(&a, &b).unwrap();
            let x = Ldlt::factor(&a).unwrap().solve(&b).unwrap();
            worst = worst.max(rel_err(&x, &x_ref));
            assert!(rel_residual(&a, &x, &b) < 1e-14);
        }
        // Measured worst: 2.7e-16.
        eprintln!("LDLT vs LU (indefinite): worst relative difference {worst:e}");
        assert!(worst < 3e-15);
    }

    #[test]
    fn cholesky_rejects_indefinite() {
        let a = DenseMatrix::from_row_major(2, 2, &[1.0, 2.0, 2.0, 1.0]).unwrap();
        assert_eq!(
            Cholesky::factor(&a),
            Err(SolveError::NotPositiveDefinite { pivot: 1 })
        );
        let neg = DenseMatrix::from_row_major(1, 1, &[-1.0]).unwrap();
        assert_eq!(
            Cholesky::factor(&neg),
            Err(SolveError::NotPositiveDefinite { pivot: 0 })
        );
        // A hard KKT matrix fails at the first multiplier row.
        let mut rng = Rng::new(5);
        let kkt = rng.kkt(6, 2, &[]);
        assert_eq!(
            Cholesky::factor(&kkt),
            Err(SolveError::NotPositiveDefinite { pivot: 6 })
        );
        // Positive semidefinite (singular) is not positive definite either.
        let psd = DenseMatrix::from_row_major(2, 2, &[1.0, 1.0, 1.0, 1.0]).unwrap();
        assert_eq!(
            Cholesky::factor(&psd),
            Err(SolveError::NotPositiveDefinite { pivot: 1 })
        );
    }

    #[test]
    fn zero_pivots() {
        let swap = DenseMatrix::from_row_major(2, 2, &[0.0, 1.0, 1.0, 0.0]).unwrap();
        assert_eq!(Ldlt::factor(&swap), Err(SolveError::ZeroPivot { pivot: 0 }));
        // LU pivots its way through the same matrix.
        assert_eq!(lu_solve(&swap, &[2.0, 3.0]).unwrap(), alloc::vec![3.0, 2.0]);
        let singular =
            DenseMatrix::from_row_major(3, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
                .unwrap();
        assert_eq!(
            Lu::factor(&singular),
            Err(SolveError::ZeroPivot { pivot: 2 })
        );
        // A KKT matrix with a duplicated constraint row is singular.
        let mut rng = Rng::new(6);
        let mut kkt = rng.kkt(5, 2, &[]);
        for j in 0..5 {
            let v = kkt.get(5, j);
            kkt.set(6, j, v);
            kkt.set(j, 6, v);
        }
        assert_eq!(Ldlt::factor(&kkt), Err(SolveError::ZeroPivot { pivot: 6 }));
        assert!(matches!(
            Lu::factor(&kkt),
            Err(SolveError::ZeroPivot { .. })
        ));
    }

    #[test]
    fn invalid_input() {
        let rect = DenseMatrix::zeros(2, 3);
        assert_eq!(Lu::factor(&rect), Err(SolveError::DimensionMismatch));
        assert_eq!(Cholesky::factor(&rect), Err(SolveError::DimensionMismatch));
        assert_eq!(Ldlt::factor(&rect), Err(SolveError::DimensionMismatch));
        let id = DenseMatrix::identity(3);
        assert_eq!(lu_solve(&id, &[1.0]), Err(SolveError::DimensionMismatch));
        let chol = Cholesky::factor(&id).unwrap();
        let mut short = [1.0, 2.0];
        assert_eq!(
            chol.solve_in_place(&mut short),
            Err(SolveError::DimensionMismatch)
        );
        assert_eq!(
            chol.solve(&[1.0, f64::NAN, 0.0]),
            Err(SolveError::NonFinite)
        );
        let mut bad = DenseMatrix::identity(3);
        bad.set(1, 2, f64::INFINITY);
        assert_eq!(Lu::factor(&bad), Err(SolveError::NonFinite));
        bad.set(1, 2, f64::NAN);
        assert_eq!(Cholesky::factor(&bad), Err(SolveError::NonFinite));
        assert_eq!(Ldlt::factor(&bad), Err(SolveError::NonFinite));
        // Empty systems are trivially solvable.
        assert_eq!(
            lu_solve(&DenseMatrix::zeros(0, 0), &[]).unwrap(),
            Vec::new()
        );
    }
}
