//! Sparse direct solve of the implicit system with faer's supernodal LDLᵀ.
//!
//! faer's layered API is used as intended (STYLE.md): the scalar CSC pattern of the
//! block matrix and its symbolic factorization (AMD ordering) are computed once per
//! topology; every step only copies block values into the CSC array (through a fixed
//! map), refactors numerically and solves, with scratch memory sized up front.
//! LDLᵀ rather than LLᵀ so that the exact (possibly indefinite) Hessian can be used as
//! long as no pivot vanishes; a zero pivot is reported as
//! [`SoftError::Factorization`]. Runs sequentially (`Par::Seq`): same input, same bits.

use crate::bsr::BlockMatrix;
use crate::cg::SolveStats;
use crate::error::SoftError;
use constraint_core::DVec3;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// Symbolic analysis and numeric workspace for one sparsity pattern.
pub struct SparseLdlt {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// For each CSC entry: (block slot, row in block, column in block).
    map: Vec<(u32, u8, u8)>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    rhs: Vec<f64>,
    buf: MemBuffer,
}

impl core::fmt::Debug for SparseLdlt {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SparseLdlt")
            .field("n", &self.n)
            .field("nnz", &self.values.len())
            .field("factor_len", &self.l_values.len())
            .finish()
    }
}

impl SparseLdlt {
    /// Analyses the lower triangle of `a`'s pattern.
    ///
    /// # Errors
    /// [`SoftError::Factorization`] if the symbolic analysis fails.
    pub fn new(a: &BlockMatrix) -> Result<Self, SoftError> {
        let p = &a.pattern;
        let nb = p.len();
        let n = 3 * nb;
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut map = Vec::new();
        col_ptr.push(0);
        for bj in 0..nb {
            // The pattern is symmetric: block rows of column bj are the columns of row bj.
            let (cols, _) = p.row(bj);
            for c in 0..3 {
                let j = 3 * bj + c;
                for &bi in cols.iter().filter(|&&bi| bi as usize >= bj) {
                    let bi = bi as usize;
                    let slot = p.slot(bi, bj).ok_or(SoftError::Factorization)?;
                    for r in 0..3 {
                        let i = 3 * bi + r;
                        if i >= j {
                            row_idx.push(i);
                            map.push((slot as u32, r as u8, c as u8));
                        }
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|_| SoftError::Factorization)?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let l_values = vec![0.0; symbolic.len_val()];
        Ok(Self {
            n,
            values: vec![0.0; row_idx.len()],
            col_ptr,
            row_idx,
            map,
            symbolic,
            l_values,
            rhs: vec![0.0; n],
            buf: MemBuffer::new(req),
        })
    }

    /// Factors the current values of `a` and solves `a x = b`.
    ///
    /// # Errors
    /// [`SoftError::Factorization`] on a zero pivot.
    pub fn solve(
        &mut self,
        a: &BlockMatrix,
        b: &[DVec3],
        x: &mut [DVec3],
    ) -> Result<SolveStats, SoftError> {
        for (v, &(slot, r, c)) in self.values.iter_mut().zip(&self.map) {
            *v = a.values[slot as usize].col(c as usize)[r as usize];
        }
        for (i, bi) in b.iter().enumerate() {
            self.rhs[3 * i..3 * i + 3].copy_from_slice(&bi.to_array());
        }
        let sym = SymbolicSparseColMatRef::new_checked(
            self.n,
            self.n,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        let mat = SparseColMatRef::new(sym, &self.values);
        let stack = MemStack::new(&mut self.buf);
        let ldlt = self
            .symbolic
            .factorize_numeric_ldlt(
                &mut self.l_values,
                mat,
                Side::Lower,
                LdltRegularization::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .map_err(|_| SoftError::Factorization)?;
        let rhs = MatMut::from_column_major_slice_mut(&mut self.rhs, self.n, 1);
        ldlt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack);
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = DVec3::from_slice(&self.rhs[3 * i..3 * i + 3]);
        }
        Ok(SolveStats {
            iterations: 1,
            residual: 0.0,
            converged: true,
        })
    }
}
