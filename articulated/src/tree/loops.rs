//! Loop rows of the tree solve by their Schur complement (Baraff 1996, §7):
//!
//! ```text
//! [H Gᵀ; G −C_G][x; μ] = [b; r_G]:
//! x₀ = H⁻¹ b,   Y = H⁻¹ Gᵀ,   (G Y + C_G) μ = G x₀ − r_G,   x = x₀ − Y μ
//! ```
//!
//! with `μ` by `LDLᵀ` when the loop rows are well independent ([`ldl_well_posed`]),
//! else the SVD's minimum-norm solution (a redundant closing row gives finite
//! multipliers). `Y` (one tree solve per loop row) and the factor of `G Y + C_G` depend
//! only on the factor and the loop rows, not on `b` or `r_G`: they are kept in the
//! solver ([`LoopClosure`]) for the factor they were built with and reused by every
//! later solve with that factor and the same rows (bits compared), so the velocity
//! solve's one-sided rows (`world/unilateral/loop_columns.rs`) and a reused factor
//! build them once. Any change of the factor's blocks drops them.
//!
//! Tried and not kept: `S` from the forward passes alone (`g_i H⁻¹ g_jᵀ = Σ s_i d s_j`
//! over the nodes on both rows' paths) with `x = x₀ − H⁻¹ Gᵀ μ` by one more tree
//! solve, and `Y`'s backward passes only when the one-sided rows need it. callgrind,
//! World::step over 0.3 s of dm humanoid / 0.1 s of humanoid_CMU, controlled: +0.6 % /
//! +1.4 % against keeping `Y` (the extra solve costs more than the backward passes it
//! saves when the one-sided rows need `Y` anyway); passive ±0.1 %. A rebuild copying
//! the column of each row the last build with the same factor had, bit for bit: no
//! column was ever found (humanoid_CMU controlled 0.5 s: the same 2,221 tree solves;
//! the projection's chord steps evaluate the limit rows at each new iterate, so their
//! Jacobians differ in the last bits even on one factor).

use alloc::vec::Vec;

use constraint_core::DVec3;
use constraint_lagrange::solve::svd::SvdSolver;
use constraint_lagrange::solve::{DenseMatrix, Ldlt};

use super::TreeSolver;
use crate::error::ArticulatedError;

/// A loop row: bodies `a` (`None`: the world), `b` and its Jacobian
/// `[v_a, ω_a, v_b, ω_b]`.
pub(crate) type LoopRow = (Option<usize>, usize, [DVec3; 4]);

/// The loop rows of [`TreeSolver::solve_with_loops_in`]: `(rows, compliances,
/// right-hand sides)`.
pub(crate) type LoopRowsRef<'a> = (&'a [LoopRow], &'a [f64], &'a [f64]);

/// Buffers of [`TreeSolver::solve_with_loops_in`] kept between calls.
#[derive(Clone, Debug, Default)]
pub(crate) struct LoopScratch {
    /// `G x₀ − r_G`.
    rhs: Vec<f64>,
    /// `μ = (G Y + C_G)⁺ (G x₀ − r_G)`.
    sol: Vec<f64>,
    /// Per tree node: on a column's path to the root ([`TreeSolver::mark_paths`]).
    mark: Vec<bool>,
}

/// `Y = H⁻¹ Gᵀ` and the truncated SVD of `G Y + C_G` for the solver's current factor
/// and the loop rows `rows`, `c`, `free_scale` they were built with.
#[derive(Clone, Debug, Default)]
pub(crate) struct LoopClosure {
    /// Built for the solver's current factor (cleared by every change of its blocks).
    valid: bool,
    /// The loop rows, compliances and free scale it was built with.
    rows: Vec<LoopRow>,
    c: Vec<f64>,
    free_scale: f64,
    /// `Y`, one column of the tree's unknowns per loop row.
    y: Vec<f64>,
    /// How `μ` is solved from `S = G Y + C_G`.
    schur: Schur,
    /// Scratch of [`ldl_well_posed`] (a column of `S⁻¹`).
    w: Vec<f64>,
}

/// How [`LoopClosure`] solves `S μ = G x₀ − r_G`.
#[derive(Clone, Debug, Default)]
enum Schur {
    /// No singular value of `S` above the rows' floor: `μ = 0`.
    #[default]
    Zero,
    /// `μ = L⁻ᵀ D⁻¹ L⁻¹ (G x₀ − r_G)`: `S` is positive definite with every eigenvalue
    /// far above the truncation ([`ldl_well_posed`]), so its inverse is the
    /// pseudo-inverse the SVD would give.
    Ldl(Ldlt),
    /// The SVD of `S` and the tolerance it is truncated at (dependent loop rows).
    Svd(SvdSolver, f64),
}

impl LoopClosure {
    /// Drops the closure (the factor it was built with changed).
    #[inline]
    pub(crate) fn forget(&mut self) {
        self.valid = false;
    }

    /// Built for these rows (bit for bit: the sign of a zero in a row can reach the
    /// solution's bits).
    fn matches(&self, rows: &[LoopRow], c: &[f64], free_scale: f64) -> bool {
        let same = |p: &[f64], q: &[f64]| {
            p.len() == q.len() && p.iter().zip(q).all(|(u, v)| u.to_bits() == v.to_bits())
        };
        self.valid
            && self.free_scale.to_bits() == free_scale.to_bits()
            && same(&self.c, c)
            && self.rows.len() == rows.len()
            && self.rows.iter().zip(rows).all(|(p, q)| {
                p.0 == q.0
                    && p.1 == q.1
                    && p.2.iter().zip(&q.2).all(|(u, v)| {
                        u.x.to_bits() == v.x.to_bits()
                            && u.y.to_bits() == v.y.to_bits()
                            && u.z.to_bits() == v.z.to_bits()
                    })
            })
    }
}

impl TreeSolver {
    /// `G_i v` of loop row `row` (side `a`, then `b`; each `j_v · v + j_ω · ω`).
    #[inline]
    pub(crate) fn gdot(&self, v: &[f64], (a, b, row): &LoopRow) -> f64 {
        let mut s = 0.0;
        for (side, body) in [(0usize, *a), (1usize, Some(*b))] {
            let Some(body) = body else { continue };
            let o = self.offset[body];
            s += row[2 * side].dot(DVec3::new(v[o], v[o + 1], v[o + 2]))
                + row[2 * side + 1].dot(DVec3::new(v[o + 3], v[o + 4], v[o + 5]));
        }
        s
    }

    /// Builds the loop closure ([`LoopClosure`]) of the current factor for `rows`
    /// (compliances `c`, `free_scale` the largest `g M⁻¹ gᵀ` of the rows), unless it is
    /// already built for them. `mark` is scratch. Errors: a non-finite Schur
    /// complement or a failed SVD ([`ArticulatedError::LoopSolve`]).
    pub(crate) fn build_loop_closure(
        &mut self,
        rows: &[LoopRow],
        c: &[f64],
        free_scale: f64,
        mark: &mut Vec<bool>,
    ) -> Result<(), ArticulatedError> {
        if self.closure.matches(rows, c, free_scale) {
            return Ok(());
        }
        let mut cl = core::mem::take(&mut self.closure);
        cl.valid = false;
        let out = self.fill_closure(&mut cl, rows, c, free_scale, mark);
        self.closure = cl;
        out
    }

    /// [`Self::build_loop_closure`]'s work into `cl`.
    fn fill_closure(
        &self,
        cl: &mut LoopClosure,
        rows: &[LoopRow],
        c: &[f64],
        free_scale: f64,
        mark: &mut Vec<bool>,
    ) -> Result<(), ArticulatedError> {
        let (k, size) = (rows.len(), self.size);
        // Y = H⁻¹ Gᵀ, one tree solve per loop row, its forward pass on the row's
        // bodies' paths to the root only (the column cleared there alone).
        // `Y` only grows: each of the `k` columns used is written whole below
        // (`mark_paths` clears the marked nodes, the backward pass writes every entry),
        // so columns past `k` from a call with more rows are left unread, and a later
        // call with more rows finds them allocated instead of zero-filling them again
        // (the `resize` after a shorter call filled the difference each time).
        if cl.y.len() < k * size {
            cl.y.resize(k * size, 0.0);
        }
        for (r, (a, b, row)) in rows.iter().enumerate() {
            let col = &mut cl.y[r * size..(r + 1) * size];
            self.mark_paths(col, [*a, Some(*b)], mark);
            self.scatter(col, *a, *b, row, 1.0);
            self.solve_sparse(col, mark);
        }
        let y = &cl.y;
        let s = DenseMatrix::from_fn(k, k, |i, j| {
            self.gdot(&y[j * size..(j + 1) * size], &rows[i]) + if i == j { c[i] } else { 0.0 }
        });
        if !s.is_finite() {
            return Err(ArticulatedError::LoopSolve);
        }
        let floor = 1e-10 * free_scale;
        cl.schur = match ldl_well_posed(&s, floor, &mut cl.w) {
            Some(f) => Schur::Ldl(f),
            None => Self::truncated_svd(&s, floor)?,
        };
        cl.rows.clear();
        cl.rows.extend_from_slice(rows);
        cl.c.clear();
        cl.c.extend_from_slice(c);
        cl.free_scale = free_scale;
        cl.valid = true;
        Ok(())
    }

    /// The SVD of the loop rows' Schur complement `s`, truncated below the rows'
    /// `floor` (`1e-10 ·` their free scale) and below `1e-10 σ_max`.
    fn truncated_svd(s: &DenseMatrix, floor: f64) -> Result<Schur, ArticulatedError> {
        // Truncate singular values below 1e-10 of the loop rows' scale without the tree
        // (`free_scale ≈ max G M⁻¹ Gᵀ`): a loop row that repeats a tree constraint has
        // `G H⁻¹ Gᵀ ≈ 0` up to round-off, and a tolerance relative to that noise would
        // turn the noise into forces.
        let svd = SvdSolver::new(s, 1e-10).map_err(|_| ArticulatedError::LoopSolve)?;
        let smax = svd.singular_values().first().copied().unwrap_or(0.0);
        if !(smax > floor) {
            return Ok(Schur::Zero);
        }
        // The decomposition at tolerance `floor / smax` is this one with a lower rank:
        // no second SVD of the same matrix ([`min_norm_truncated`]).
        let tol = if floor > 1e-10 * smax {
            floor / smax
        } else {
            1e-10
        };
        Ok(Schur::Svd(svd, tol))
    }

    /// `x ← x − Y μ`, `μ = (G Y + C_G)⁺ (G x − r)` with the closure built by
    /// [`Self::build_loop_closure`] for `rows` (`x` the tree solve's `x₀`); `μ` into
    /// `mu`, `rhs` scratch. Errors: a non-finite `G x − r` or `μ`, or no closure built
    /// ([`ArticulatedError::LoopSolve`]).
    pub(crate) fn close_loops(
        &self,
        rows: &[LoopRow],
        r: &[f64],
        x: &mut [f64],
        rhs: &mut Vec<f64>,
        mu: &mut Vec<f64>,
    ) -> Result<(), ArticulatedError> {
        let cl = &self.closure;
        let k = rows.len();
        if !cl.valid || cl.rows.len() != k || r.len() < k {
            return Err(ArticulatedError::LoopSolve);
        }
        rhs.clear();
        rhs.extend((0..k).map(|i| self.gdot(x, &rows[i]) - r[i]));
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(ArticulatedError::LoopSolve);
        }
        mu.clear();
        mu.resize(k, 0.0);
        match &cl.schur {
            Schur::Zero => {}
            Schur::Ldl(f) => {
                mu.copy_from_slice(rhs);
                if f.solve_in_place(mu).is_err() || mu.iter().any(|v| !v.is_finite()) {
                    return Err(ArticulatedError::LoopSolve);
                }
            }
            Schur::Svd(svd, tol) => {
                if !min_norm_truncated(svd, *tol, rhs, mu) {
                    return Err(ArticulatedError::LoopSolve);
                }
            }
        }
        let size = self.size;
        for (j, m) in mu.iter().enumerate() {
            let col = &cl.y[j * size..(j + 1) * size];
            for (xi, yi) in x.iter_mut().zip(col) {
                *xi -= m * yi;
            }
        }
        Ok(())
    }

    /// Solves the tree system augmented with loop rows:
    ///
    /// `[H Gᵀ; G −C_G][x; μ] = [b; r_G]`, `G` acting on body unknowns only.
    ///
    /// `rows = (loop_rows, loop_c, loop_rhs)`: `loop_rows[k] = (a, b, row)`, `loop_c[k]`
    /// its compliance, `loop_rhs[k] = r_G`. On return `x` holds the tree unknowns and
    /// `mu` the loop multipliers. `free_scale` is the largest `g M⁻¹ gᵀ` of the loop
    /// rows (their scale without the tree). The buffers (the Schur right-hand side, `μ`
    /// and the path marks) are in `scratch`, kept by the caller between calls instead
    /// of allocated per call. `Y` and the SVD
    /// come from the solver's [`LoopClosure`] when it was built for these rows and
    /// this factor.
    pub(crate) fn solve_with_loops_in(
        &mut self,
        x: &mut [f64],
        rows: LoopRowsRef<'_>,
        free_scale: f64,
        mu: &mut Vec<f64>,
        scratch: &mut LoopScratch,
    ) -> Result<(), ArticulatedError> {
        let (loop_rows, loop_c, loop_rhs) = rows;
        self.solve(x);
        mu.clear();
        if loop_rows.is_empty() {
            return Ok(());
        }
        self.build_loop_closure(loop_rows, loop_c, free_scale, &mut scratch.mark)?;
        self.close_loops(loop_rows, loop_rhs, x, &mut scratch.rhs, &mut scratch.sol)?;
        mu.extend_from_slice(&scratch.sol);
        Ok(())
    }
}

/// `x = A⁺ b` with the singular values `σ_i ≤ rel_tol · σ_max` of `A` dropped,
/// `x = Σ_{σ_i > rel_tol σ_max} v_i (u_iᵀ b) / σ_i`, from a decomposition `svd` of `A`
/// taken at any tolerance: the sums, in the same order, that
/// [`SvdSolver::solve_min_norm`] does on `SvdSolver::new(A, rel_tol)` (the tolerance
/// sets only the rank there; the factors are the same), without decomposing `A` again.
/// `false` (no solution) where that would fail: a non-finite `rel_tol`, `b` or `x`, or
/// lengths that do not match `A`.
pub(crate) fn min_norm_truncated(svd: &SvdSolver, rel_tol: f64, b: &[f64], x: &mut [f64]) -> bool {
    if !rel_tol.is_finite() || b.len() != svd.n_rows() || x.len() != svd.n_cols() {
        return false;
    }
    if !b.iter().all(|v| v.is_finite()) {
        return false;
    }
    let sigma = svd.singular_values();
    let cutoff = rel_tol.max(0.0) * sigma.first().copied().unwrap_or(0.0);
    let rank = sigma.iter().filter(|&&s| s > cutoff && s > 0.0).count();
    x.fill(0.0);
    for (i, &si) in sigma.iter().enumerate().take(rank) {
        let ub: f64 = svd.u(i).iter().zip(b).map(|(p, q)| p * q).sum();
        let t = (1.0 / si) * ub;
        for (xj, vj) in x.iter_mut().zip(svd.v(i)) {
            *xj += t * vj;
        }
    }
    x.iter().all(|v| v.is_finite())
}

/// How far above the truncation the smallest eigenvalue of the loop rows' Schur
/// complement must be (by its lower bound) for the `LDLᵀ` to stand in for the SVD.
const LDL_MARGIN: f64 = 1e3;

/// `S = L D Lᵀ` ([`Ldlt`]) when `S` is positive definite with every eigenvalue far
/// above the SVD's truncation `max(1e-10 σ_max, floor)`: then the truncated SVD keeps
/// every singular value and its minimum-norm solution is `S⁻¹ b`, which the `LDLᵀ`
/// gives for a fraction of the SVD's cost. The eigenvalues of a symmetric positive
/// definite `S` lie in `[1 / tr(S⁻¹), tr(S)]`; the test is
/// `1 / tr(S⁻¹) > LDL_MARGIN · max(1e-10 tr(S), floor)`, with `tr(S⁻¹) = Σ_i (S⁻¹ e_i)_i`.
/// `None` (use the SVD): a pivot `d_j ≤ 0`, dependent or nearly dependent loop rows, or
/// a non-finite value. `w` is scratch (one column of `S⁻¹`).
fn ldl_well_posed(s: &DenseMatrix, floor: f64, w: &mut Vec<f64>) -> Option<Ldlt> {
    let k = s.n_rows();
    if k == 0 || s.n_cols() != k {
        return None;
    }
    let f = Ldlt::factor(s).ok()?;
    if !(0..k).all(|j| f.d(j) > 0.0) {
        return None;
    }
    let trace: f64 = (0..k).map(|j| s.get(j, j)).sum();
    let mut tr_inv = 0.0;
    for i in 0..k {
        w.clear();
        w.resize(k, 0.0);
        w[i] = 1.0;
        f.solve_in_place(w).ok()?;
        tr_inv += w[i];
    }
    let cutoff = floor.max(1e-10 * trace);
    (tr_inv.is_finite() && trace.is_finite() && tr_inv * LDL_MARGIN * cutoff < 1.0).then_some(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a well-conditioned symmetric positive definite `S` (4×4, eigenvalues about
    /// 0.5–4) the `LDLᵀ` is taken and its solution is the SVD's minimum-norm one to
    /// 1e-14 relative; with a repeated row (two dependent loop rows) the test refuses
    /// it, as it does a small eigenvalue within 1e3 of the truncation.
    #[test]
    fn ldl_stands_in_for_the_svd_only_when_well_posed() {
        let s = DenseMatrix::from_fn(4, 4, |i, j| {
            let off = 0.3 * libm::cos(1.0 + (i + j) as f64);
            if i == j {
                2.0 + i as f64 * 0.5
            } else {
                off
            }
        });
        let b = [0.4, -1.1, 2.3, 0.7];
        let mut w = Vec::new();
        let f = ldl_well_posed(&s, 1e-10, &mut w).expect("well posed");
        let mut x = b;
        f.solve_in_place(&mut x).expect("solve");
        let svd = SvdSolver::new(&s, 1e-10).expect("svd");
        let mut want = [0.0; 4];
        svd.solve_min_norm(&b, &mut want).expect("solve");
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (p, q) in x.iter().zip(&want) {
            assert!((p - q).abs() <= 1e-14 * scale, "{x:?} vs {want:?}");
        }
        // Row and column 3 a copy of row and column 0: singular.
        let dep = DenseMatrix::from_fn(4, 4, |i, j| {
            let m = |k: usize| if k == 3 { 0 } else { k };
            s.get(m(i), m(j))
        });
        assert!(ldl_well_posed(&dep, 1e-10, &mut w).is_none());
        // An eigenvalue 1e-6: refused with the floor at 1e-8 (not 1e3 above it), taken
        // with the floor at 1e-10 (the truncation then 1e-10 · tr S).
        let tiny = DenseMatrix::from_fn(2, 2, |i, j| match (i, j) {
            (0, 0) => 1.0,
            (1, 1) => 1e-6,
            _ => 0.0,
        });
        assert!(ldl_well_posed(&tiny, 1e-8, &mut w).is_none());
        assert!(ldl_well_posed(&tiny, 1e-10, &mut w).is_some());
    }
}
