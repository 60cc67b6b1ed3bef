//! The dense path's columns `Y = H⁻¹ Gᵀ` through the loop closure, with the loop rows'
//! Schur complement built once per solve instead of once per column.
//!
//! [`TreeSolver::solve_with_loops_in`] solves `[H Lᵀ; L −C][x; μ] = [b; r]` as
//!
//! ```text
//! x₀ = H⁻¹ b,   Y_L = H⁻¹ Lᵀ,   (L Y_L + C) μ = L x₀ − r,   x = x₀ − Y_L μ
//! ```
//!
//! (Baraff 1996, loops by their Schur complement; `μ` by the SVD's minimum-norm
//! solution). The one-sided rows' columns all solve it with the same `L`, `C` and
//! `r = 0`: `Y_L` (one tree solve per loop row) and the SVD of `L Y_L + C` are the same
//! for every column, and the same as the velocity solve's own with that factor: the
//! solver keeps them (`tree/loops.rs`), [`LoopColumns::new`] builds them only when it
//! does not hold them, and [`LoopColumns::solve`] costs one tree solve, `k` gathers
//! and the pseudo-inverse's product per column — the operations of `solve_with_loops_in`
//! in the same order, so the same bits.

use alloc::vec::Vec;

use crate::error::ArticulatedError;
use crate::tree::TreeSolver;

/// A loop row: bodies `a` (`None`: the world), `b` and its Jacobian `[v_a, ω_a, v_b, ω_b]`.
type LoopRow = (Option<usize>, usize, [constraint_core::DVec3; 4]);

/// The buffers of one solve's columns through the loop closure, whose `Y_L` and SVD
/// the solver keeps ([`TreeSolver::build_loop_closure`]).
pub(super) struct LoopColumns {
    /// `L x₀ − r` of the current column (reused).
    rhs: Vec<f64>,
    /// `μ` of the current column (reused).
    mu: Vec<f64>,
}

impl LoopColumns {
    /// `Y_L` and the SVD for the loop rows `rows` with compliances `c` (`free_scale`:
    /// the largest `g M⁻¹ gᵀ` of the rows, [`TreeSolver::solve_with_loops_in`]), built in
    /// the solver unless the solver already holds them for this factor and these rows
    /// (the velocity solve's own, `World::solve_factored`); `mu` is a reused buffer.
    /// Errors: a non-finite Schur complement or a failed SVD
    /// ([`ArticulatedError::LoopSolve`], as `solve_with_loops_in` gives them).
    pub(super) fn new(
        solver: &mut TreeSolver,
        rows: &[LoopRow],
        c: &[f64],
        free_scale: f64,
        mu: Vec<f64>,
    ) -> Result<Self, ArticulatedError> {
        let mut mark = Vec::new();
        solver.build_loop_closure(rows, c, free_scale, &mut mark)?;
        Ok(Self {
            rhs: Vec::with_capacity(rows.len()),
            mu,
        })
    }

    /// `x ← H⁻¹ x` through the loop closure with loop right-hand side `r`: the tree
    /// solve (with `sparse`, [`TreeSolver::solve_sparse`] for a right-hand side on those
    /// bodies alone, `mark` its scratch), then `x −= Y_L μ`, `μ = (L Y_L + C)⁺ (L x₀ − r)`
    /// ([`TreeSolver::close_loops`]). Errors: a non-finite `L x₀ − r` or `μ`
    /// ([`ArticulatedError::LoopSolve`]).
    pub(super) fn solve(
        &mut self,
        solver: &TreeSolver,
        rows: &[LoopRow],
        r: &[f64],
        x: &mut [f64],
        sparse: Option<&[bool]>,
    ) -> Result<(), ArticulatedError> {
        match sparse {
            Some(mark) => solver.solve_sparse(x, mark),
            None => solver.solve(x),
        }
        solver.close_loops(rows, r, x, &mut self.rhs, &mut self.mu)
    }

    /// The reused `μ` buffer back.
    pub(super) fn into_mu(self) -> Vec<f64> {
        self.mu
    }
}
