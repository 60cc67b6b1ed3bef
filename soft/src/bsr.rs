//! Block-sparse matrices with 3×3 blocks and a fixed pattern.
//!
//! The pattern is built once from the constraint stencils (every pair of points that
//! share a constraint couples); each element then remembers the value slots of its
//! `N × N` blocks, so assembly in a step is a flat pass of `+=` with no search and no
//! allocation. Both triangles are stored, which keeps the product `A x` a single pass.

use constraint_core::{DMat3, DVec3};

/// Sparsity pattern: compressed rows of block columns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlockPattern {
    n: usize,
    row_ptr: Vec<usize>,
    cols: Vec<u32>,
}

impl BlockPattern {
    /// The pattern with a diagonal block for each of `n` points plus every block `(i, j)`
    /// of every stencil. Deterministic: rows and columns come out sorted.
    pub fn from_stencils<'a>(n: usize, stencils: impl Iterator<Item = &'a [usize]>) -> Self {
        let mut pairs: Vec<(u32, u32)> = (0..n as u32).map(|i| (i, i)).collect();
        for s in stencils {
            for &i in s {
                for &j in s {
                    if i != j {
                        pairs.push((i as u32, j as u32));
                    }
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut row_ptr = vec![0usize; n + 1];
        for &(i, _) in &pairs {
            row_ptr[i as usize + 1] += 1;
        }
        for i in 0..n {
            row_ptr[i + 1] += row_ptr[i];
        }
        let cols = pairs.into_iter().map(|(_, j)| j).collect();
        Self { n, row_ptr, cols }
    }

    /// Number of block rows (points).
    pub fn len(&self) -> usize {
        self.n
    }

    /// `true` for the empty pattern.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Number of stored blocks.
    pub fn nnz(&self) -> usize {
        self.cols.len()
    }

    /// Value slot of block `(i, j)`, if it is in the pattern.
    pub fn slot(&self, i: usize, j: usize) -> Option<usize> {
        let lo = *self.row_ptr.get(i)?;
        let hi = *self.row_ptr.get(i + 1)?;
        let row = &self.cols[lo..hi];
        row.binary_search(&(j as u32)).ok().map(|k| lo + k)
    }

    /// Block columns of row `i` and the slot of its first block.
    pub fn row(&self, i: usize) -> (&[u32], usize) {
        let lo = self.row_ptr[i];
        (&self.cols[lo..self.row_ptr[i + 1]], lo)
    }
}

/// A symmetric block matrix on a [`BlockPattern`].
#[derive(Clone, Debug, Default)]
pub struct BlockMatrix {
    /// The pattern.
    pub pattern: BlockPattern,
    /// One 3×3 block per pattern entry.
    pub values: Vec<DMat3>,
}

impl BlockMatrix {
    /// The zero matrix on `pattern`.
    pub fn new(pattern: BlockPattern) -> Self {
        let values = vec![DMat3::ZERO; pattern.nnz()];
        Self { pattern, values }
    }

    /// Sets every block to zero (keeps the allocation).
    pub fn clear(&mut self) {
        self.values.fill(DMat3::ZERO);
    }

    /// `y = A x`.
    pub fn mul_vec(&self, x: &[DVec3], y: &mut [DVec3]) {
        for (i, yi) in y.iter_mut().enumerate().take(self.pattern.n) {
            let (cols, base) = self.pattern.row(i);
            let mut acc = DVec3::ZERO;
            for (k, &j) in cols.iter().enumerate() {
                acc += self.values[base + k] * x[j as usize];
            }
            *yi = acc;
        }
    }

    /// The diagonal blocks.
    pub fn diagonal(&self, out: &mut [DMat3]) {
        for (i, o) in out.iter_mut().enumerate().take(self.pattern.n) {
            *o = self
                .pattern
                .slot(i, i)
                .map_or(DMat3::ZERO, |s| self.values[s]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_is_sorted_and_symmetric() {
        let s: [&[usize]; 2] = [&[2, 0], &[1, 2]];
        let p = BlockPattern::from_stencils(4, s.into_iter());
        assert_eq!(p.nnz(), 4 + 4);
        assert_eq!(p.row(2).0, &[0, 1, 2]);
        assert!(p.slot(0, 2).is_some() && p.slot(2, 0).is_some());
        assert!(p.slot(0, 1).is_none());
        assert!(p.slot(3, 3).is_some());
        assert!(p.slot(9, 0).is_none());
    }

    #[test]
    fn product_matches_dense() {
        let s: [&[usize]; 1] = [&[0, 1]];
        let mut a = BlockMatrix::new(BlockPattern::from_stencils(2, s.into_iter()));
        let m = DMat3::from_cols_array(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0]);
        let s01 = a.pattern.slot(0, 1).unwrap();
        a.values[s01] = m;
        let s11 = a.pattern.slot(1, 1).unwrap();
        a.values[s11] = DMat3::IDENTITY;
        let x = [DVec3::ONE, DVec3::new(1.0, -1.0, 2.0)];
        let mut y = [DVec3::ZERO; 2];
        a.mul_vec(&x, &mut y);
        assert_eq!(y[0], m * x[1]);
        assert_eq!(y[1], x[1]);
    }
}
