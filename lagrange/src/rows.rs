//! Constraint rows: the stacked values `C(x)` and the sparse Jacobian `J = ∂C/∂x` of
//! a set of point constraints, in compressed rows of 3-vector blocks.
//!
//! Each row holds the blocks `∂C_r/∂x_i` of the points of its stencil, so `J v`,
//! `Jᵀ λ` and the Schur complement `J M⁻¹ Jᵀ` are single passes over flat arrays.
//! Rows are appended in the order the constraints are given, which makes assembly
//! deterministic; [`ConstraintRows::clear`] keeps the allocations for the next step.

use alloc::vec::Vec;
use constraint_core::{DVec3, PointConstraint};

/// Values and Jacobian rows of a list of constraints.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ConstraintRows {
    /// `C_r(x)` per row.
    pub value: Vec<f64>,
    row_ptr: Vec<usize>,
    cols: Vec<u32>,
    blocks: Vec<DVec3>,
}

impl ConstraintRows {
    /// An empty set of rows.
    pub fn new() -> Self {
        Self {
            value: Vec::new(),
            row_ptr: alloc::vec![0],
            cols: Vec::new(),
            blocks: Vec::new(),
        }
    }

    /// Removes every row, keeping the allocations.
    pub fn clear(&mut self) {
        self.value.clear();
        self.row_ptr.clear();
        self.row_ptr.push(0);
        self.cols.clear();
        self.blocks.clear();
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.value.len()
    }

    /// `true` when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.value.is_empty()
    }

    /// Appends the `R` rows of `c` evaluated at the global positions `x`. Returns
    /// `false` (and appends nothing) when a stencil index is out of bounds.
    pub fn push<C, const N: usize, const R: usize>(&mut self, c: &C, x: &[DVec3]) -> bool
    where
        C: PointConstraint<N, R>,
    {
        let Some(xl) = c.gather(x) else {
            return false;
        };
        let idx = c.stencil();
        let j = c.jacobian(&xl);
        for r in 0..R {
            self.value.push(j.value[r]);
            for i in 0..N {
                self.cols.push(idx[i] as u32);
                self.blocks.push(j.grad[r][i]);
            }
            self.row_ptr.push(self.cols.len());
        }
        true
    }

    /// Appends one row given directly by its value and blocks.
    pub fn push_row(&mut self, value: f64, entries: &[(usize, DVec3)]) {
        self.value.push(value);
        for &(i, g) in entries {
            self.cols.push(i as u32);
            self.blocks.push(g);
        }
        self.row_ptr.push(self.cols.len());
    }

    /// Row offsets into [`ConstraintRows::cols`] and [`ConstraintRows::blocks`].
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// Point index of every block, row by row.
    pub fn cols(&self) -> &[u32] {
        &self.cols
    }

    /// Every block `∂C_r/∂x_i`, row by row.
    pub fn blocks(&self) -> &[DVec3] {
        &self.blocks
    }

    /// The points and blocks of row `r`.
    #[inline]
    pub fn row(&self, r: usize) -> (&[u32], &[DVec3]) {
        let (a, b) = (self.row_ptr[r], self.row_ptr[r + 1]);
        (&self.cols[a..b], &self.blocks[a..b])
    }

    /// `out[r] = (J v)_r`.
    pub fn mul(&self, v: &[DVec3], out: &mut [f64]) {
        for (r, o) in out.iter_mut().enumerate().take(self.len()) {
            let (cols, blocks) = self.row(r);
            *o = cols
                .iter()
                .zip(blocks)
                .map(|(&i, g)| g.dot(v[i as usize]))
                .sum();
        }
    }

    /// `out += Jᵀ λ`.
    pub fn mul_transpose_add(&self, lambda: &[f64], out: &mut [DVec3]) {
        for (r, &l) in lambda.iter().enumerate().take(self.len()) {
            let (cols, blocks) = self.row(r);
            for (&i, g) in cols.iter().zip(blocks) {
                out[i as usize] += *g * l;
            }
        }
    }

    /// Sets the blocks of the points flagged in `fixed` to zero: a pinned point's
    /// velocity is prescribed, so it takes no part in `J v` or `Jᵀ λ` (its value still
    /// counts in `C`).
    pub fn zero_columns(&mut self, fixed: &[bool]) {
        for (c, b) in self.cols.iter().zip(self.blocks.iter_mut()) {
            if fixed.get(*c as usize).copied().unwrap_or(false) {
                *b = DVec3::ZERO;
            }
        }
    }

    /// Iterates over `(row, point, block)` entries.
    pub fn entries(&self) -> impl Iterator<Item = (usize, usize, DVec3)> + '_ {
        (0..self.len()).flat_map(move |r| {
            let (cols, blocks) = self.row(r);
            cols.iter()
                .zip(blocks)
                .map(move |(&i, &g)| (r, i as usize, g))
        })
    }

    /// Largest `|C_r|` (NaN if any value is NaN).
    pub fn max_violation(&self) -> f64 {
        self.value.iter().fold(0.0, |m, v| nan_max(m, v.abs()))
    }
}

/// `max(a, b)` that propagates NaN (`f64::max` drops it, which would let a NaN state
/// pass as satisfied).
#[inline]
pub fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use constraint_core::Distance;

    #[test]
    fn products_are_adjoint() {
        let x = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)];
        let mut rows = ConstraintRows::new();
        assert!(rows.push(&Distance::new(0, 1, 0.5).unwrap(), &x));
        assert!(rows.push(&Distance::new(1, 2, 2.0).unwrap(), &x));
        assert!(!rows.push(&Distance::new(1, 7, 2.0).unwrap(), &x));
        assert_eq!(rows.len(), 2);
        assert_eq!(rows.value, [0.5, -1.0]);
        let v = [
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(-1.0, 0.5, 0.0),
            DVec3::Z,
        ];
        let l = [0.3, -0.7];
        let mut jv = [0.0; 2];
        rows.mul(&v, &mut jv);
        let mut jtl = [DVec3::ZERO; 3];
        rows.mul_transpose_add(&l, &mut jtl);
        let a: f64 = jv.iter().zip(&l).map(|(a, b)| a * b).sum();
        let b: f64 = jtl.iter().zip(&v).map(|(a, b)| a.dot(*b)).sum();
        assert!((a - b).abs() < 1e-15);
    }
}
