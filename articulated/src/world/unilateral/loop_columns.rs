//! The dense path's columns `Y = H⁻¹ Gᵀ` through the loop closure, with the loop rows'
//! Schur complement built once per solve instead of once per column.
//!
//! [`TreeSolver::solve_with_loops`] solves `[H Lᵀ; L −C][x; μ] = [b; r]` as
//!
//! ```text
//! x₀ = H⁻¹ b,   Y_L = H⁻¹ Lᵀ,   (L Y_L + C) μ = L x₀ − r,   x = x₀ − Y_L μ
//! ```
//!
//! (Baraff 1996, loops by their Schur complement; `μ` by the SVD's minimum-norm
//! solution). The one-sided rows' columns all solve it with the same `L`, `C` and
//! `r = 0`: `Y_L` (one tree solve per loop row) and the SVD of `L Y_L + C` are the same
//! for every column, so [`LoopColumns::new`] builds them once and
//! [`LoopColumns::solve`] costs one tree solve, `k` gathers and the pseudo-inverse's
//! product per column — the operations of `solve_with_loops` in the same order, so the
//! same bits (dm humanoid passive: 400 columns a second, each with its own `Y_L` and
//! SVD before).

use alloc::vec;
use alloc::vec::Vec;

use constraint_core::DVec3;
use constraint_lagrange::solve::svd::SvdSolver;
use constraint_lagrange::solve::DenseMatrix;

use crate::error::ArticulatedError;
use crate::tree::{min_norm_truncated, TreeSolver};

/// A loop row: bodies `a` (`None`: the world), `b` and its Jacobian `[v_a, ω_a, v_b, ω_b]`.
type LoopRow = (Option<usize>, usize, [DVec3; 4]);

/// `Y_L` and the SVD of the loop rows' Schur complement, for the columns of one solve.
pub(super) struct LoopColumns {
    /// `Y_L = H⁻¹ Lᵀ`, one column of `size` unknowns per loop row.
    y: Vec<f64>,
    /// The tree's unknowns per column.
    size: usize,
    /// The SVD of `L Y_L + C` and the tolerance `solve_with_loops` truncates it at;
    /// `None` when its largest singular value is below the loop rows' floor (`μ = 0`).
    svd: Option<(SvdSolver, f64)>,
    /// `L x₀ − r` of the current column (reused).
    rhs: Vec<f64>,
    /// `μ` of the current column (reused).
    mu: Vec<f64>,
}

impl LoopColumns {
    /// `Y_L` and the SVD for the loop rows `rows` with compliances `c` (`free_scale`:
    /// the largest `g M⁻¹ gᵀ` of the rows, [`TreeSolver::solve_with_loops`]); `mu` is a
    /// reused buffer. Errors: a non-finite Schur complement or a failed SVD
    /// ([`ArticulatedError::LoopSolve`], as `solve_with_loops` gives them).
    pub(super) fn new(
        solver: &TreeSolver,
        rows: &[LoopRow],
        c: &[f64],
        free_scale: f64,
        mu: Vec<f64>,
    ) -> Result<Self, ArticulatedError> {
        let (k, size) = (rows.len(), solver.size);
        // Y_L column by column, each tree solve's forward pass on the row's bodies'
        // paths only (as `solve_with_loops`).
        let mut y = vec![0.0; k * size];
        let mut mark = Vec::new();
        for (r, (a, b, row)) in rows.iter().enumerate() {
            let col = &mut y[r * size..(r + 1) * size];
            solver.mark_paths(col, [*a, Some(*b)], &mut mark);
            solver.scatter(col, *a, *b, row, 1.0);
            solver.solve_sparse(col, &mark);
        }
        let s = DenseMatrix::from_fn(k, k, |i, j| {
            gdot(solver, &y[j * size..(j + 1) * size], &rows[i]) + if i == j { c[i] } else { 0.0 }
        });
        if !s.is_finite() {
            return Err(ArticulatedError::LoopSolve);
        }
        // The floor of `solve_with_loops`: singular values below 1e-10 of the rows'
        // scale without the tree are dropped.
        let svd = SvdSolver::new(&s, 1e-10).map_err(|_| ArticulatedError::LoopSolve)?;
        let smax = svd.singular_values().first().copied().unwrap_or(0.0);
        let floor = 1e-10 * free_scale;
        // Its truncation at `floor / smax` (no second decomposition of `s`,
        // `min_norm_truncated`).
        let svd = (smax > floor).then(|| {
            let tol = if floor > 1e-10 * smax {
                floor / smax
            } else {
                1e-10
            };
            (svd, tol)
        });
        Ok(Self {
            y,
            size,
            svd,
            rhs: Vec::with_capacity(k),
            mu,
        })
    }

    /// `x ← H⁻¹ x` through the loop closure with loop right-hand side `r`: the tree
    /// solve (with `sparse`, [`TreeSolver::solve_sparse`] for a right-hand side on those
    /// bodies alone, `mark` its scratch), then `x −= Y_L μ`, `μ = (L Y_L + C)⁺ (L x₀ − r)`. Errors: a non-finite
    /// `L x₀ − r` or `μ` ([`ArticulatedError::LoopSolve`]).
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
        let k = rows.len();
        self.rhs.clear();
        self.rhs
            .extend((0..k).map(|i| gdot(solver, x, &rows[i]) - r[i]));
        if self.rhs.iter().any(|v| !v.is_finite()) {
            return Err(ArticulatedError::LoopSolve);
        }
        self.mu.clear();
        self.mu.resize(k, 0.0);
        if let Some((svd, tol)) = &self.svd {
            if !min_norm_truncated(svd, *tol, &self.rhs, &mut self.mu) {
                return Err(ArticulatedError::LoopSolve);
            }
        }
        for (j, m) in self.mu.iter().enumerate() {
            let col = &self.y[j * self.size..(j + 1) * self.size];
            for (xi, yi) in x.iter_mut().zip(col) {
                *xi -= m * yi;
            }
        }
        Ok(())
    }

    /// The reused `μ` buffer back.
    pub(super) fn into_mu(self) -> Vec<f64> {
        self.mu
    }
}

/// `L_i v` of loop row `row` (side `a`, then `b`; each `j_v · v + j_ω · ω`: the sums of
/// `solve_with_loops`).
fn gdot(solver: &TreeSolver, v: &[f64], (a, b, row): &LoopRow) -> f64 {
    let mut s = 0.0;
    for (side, body) in [(0usize, *a), (1usize, Some(*b))] {
        let Some(body) = body else { continue };
        let o = solver.offset[body];
        s += row[2 * side].dot(DVec3::new(v[o], v[o + 1], v[o + 2]))
            + row[2 * side + 1].dot(DVec3::new(v[o + 3], v[o + 4], v[o + 5]));
    }
    s
}
