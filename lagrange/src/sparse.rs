//! Sparse Cholesky of the Schur complement `S = J W Jᵀ + D` with faer, analysed once.
//!
//! The pattern of `S` (rows coupled through a shared, unpinned point) and the symbolic
//! factorization are computed the first time a row structure is seen and reused while
//! it stays the same — across the Newton iterations of a projection and across steps.
//! Each call then only accumulates `S`'s values through a precomputed list of
//! contributions `S[slot] += w_i g_p·g_q`, refactors numerically and solves.

use crate::kkt::{KktError, KktProblem};
use alloc::vec::Vec;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// Cached analysis of one row structure.
#[derive(Default)]
pub struct SparseSchur {
    key: Vec<u64>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// `(slot, entry p, entry q, point)`.
    contrib: Vec<(u32, u32, u32, u32)>,
    diag: Vec<u32>,
    symbolic: Option<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    buf: Option<MemBuffer>,
    /// Number of symbolic analyses done (for tests and reports).
    pub analyses: usize,
}

impl core::fmt::Debug for SparseSchur {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SparseSchur")
            .field("rows", &self.diag.len())
            .field("nnz", &self.values.len())
            .field("analyses", &self.analyses)
            .finish()
    }
}

impl SparseSchur {
    /// The row structure and the pinned mask that the analysis depends on.
    fn structure<'p>(problem: &'p KktProblem<'_>, w: &'p [f64]) -> impl Iterator<Item = u64> + 'p {
        let rows = problem.rows;
        rows.row_ptr()
            .iter()
            .map(|&p| p as u64)
            .chain(rows.cols().iter().map(|&c| c as u64 | (1 << 40)))
            .chain(w.iter().map(|&w| u64::from(w == 0.0) | (1 << 41)))
    }

    /// `true` when `problem` has the structure the cached analysis was made for
    /// (compared in place: no allocation per call).
    fn same_structure(&self, problem: &KktProblem<'_>, w: &[f64]) -> bool {
        let len = problem.rows.row_ptr().len() + problem.rows.cols().len() + w.len();
        self.key.len() == len && self.key.iter().copied().eq(Self::structure(problem, w))
    }

    fn analyse(&mut self, problem: &KktProblem<'_>, w: &[f64]) -> Result<(), KktError> {
        let rows = problem.rows;
        let m = rows.len();
        let mut entries: Vec<(u32, u32, u32)> = Vec::new(); // (point, row, entry)
        for r in 0..m {
            for e in rows.row_ptr()[r]..rows.row_ptr()[r + 1] {
                let i = rows.cols()[e];
                if w[i as usize] != 0.0 {
                    entries.push((i, r as u32, e as u32));
                }
            }
        }
        entries.sort_unstable();
        // Lower-triangle pairs (row i ≥ col j) with their contribution.
        let mut pairs: Vec<(u32, u32, u32, u32, u32)> = Vec::new(); // (j, i, p, q, point)
        let mut a = 0;
        while a < entries.len() {
            let pt = entries[a].0;
            let mut b = a;
            while b < entries.len() && entries[b].0 == pt {
                b += 1;
            }
            for p in a..b {
                for q in a..b {
                    let (ri, rj) = (entries[p].1, entries[q].1);
                    if ri >= rj {
                        pairs.push((rj, ri, entries[p].2, entries[q].2, pt));
                    }
                }
            }
            a = b;
        }
        for r in 0..m as u32 {
            pairs.push((r, r, u32::MAX, u32::MAX, u32::MAX));
        }
        pairs.sort_unstable();
        self.col_ptr.clear();
        self.row_idx.clear();
        self.contrib.clear();
        self.diag.clear();
        self.col_ptr.push(0);
        let mut k = 0;
        for j in 0..m as u32 {
            while k < pairs.len() && pairs[k].0 == j {
                let i = pairs[k].1;
                if self.row_idx.len() == self.col_ptr[j as usize]
                    || *self.row_idx.last().unwrap_or(&usize::MAX) != i as usize
                {
                    self.row_idx.push(i as usize);
                }
                let slot = (self.row_idx.len() - 1) as u32;
                let (_, _, p, q, pt) = pairs[k];
                if p == u32::MAX {
                    self.diag.push(slot);
                } else {
                    self.contrib.push((slot, p, q, pt));
                }
                k += 1;
            }
            self.col_ptr.push(self.row_idx.len());
        }
        self.values = alloc::vec![0.0; self.row_idx.len()];
        let sym = SymbolicSparseColMatRef::new_checked(m, m, &self.col_ptr, None, &self.row_idx);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|_| KktError::Factorization)?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        self.l_values = alloc::vec![0.0; symbolic.len_val()];
        self.buf = Some(MemBuffer::new(req));
        self.symbolic = Some(symbolic);
        self.analyses += 1;
        Ok(())
    }

    /// Solves `S λ = J W b − c` for the problem's rows, reusing the analysis when the
    /// row structure is unchanged.
    ///
    /// # Errors
    /// [`KktError::Factorization`] when `S` is not numerically positive definite
    /// (redundant hard constraints: use the SVD solver).
    pub fn solve(
        &mut self,
        problem: &KktProblem<'_>,
        w: &[f64],
        lambda: &mut [f64],
    ) -> Result<(), KktError> {
        if self.symbolic.is_none() || !self.same_structure(problem, w) {
            self.analyse(problem, w)?;
            self.key.clear();
            self.key.extend(Self::structure(problem, w));
        }
        let rows = problem.rows;
        let m = rows.len();
        let blocks = rows.blocks();
        self.values.fill(0.0);
        for &(slot, p, q, pt) in &self.contrib {
            self.values[slot as usize] +=
                w[pt as usize] * blocks[p as usize].dot(blocks[q as usize]);
        }
        for (r, &slot) in self.diag.iter().enumerate() {
            self.values[slot as usize] += problem.compliance[r];
        }
        // Right-hand side J W b − c.
        let wb: Vec<constraint_core::DVec3> =
            problem.b.iter().zip(w).map(|(b, w)| *b * *w).collect();
        rows.mul(&wb, lambda);
        for (l, c) in lambda.iter_mut().zip(problem.c) {
            *l -= c;
        }
        let (Some(symbolic), Some(buf)) = (self.symbolic.as_ref(), self.buf.as_mut()) else {
            return Err(KktError::Factorization);
        };
        let sym = SymbolicSparseColMatRef::new_checked(m, m, &self.col_ptr, None, &self.row_idx);
        let mat = SparseColMatRef::new(sym, &self.values);
        let stack = MemStack::new(buf);
        let llt = symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                mat,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .map_err(|_| KktError::Factorization)?;
        let rhs = MatMut::from_column_major_slice_mut(lambda, m, 1);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack);
        Ok(())
    }
}
