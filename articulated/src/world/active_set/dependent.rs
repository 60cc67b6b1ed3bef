//! A dependent one-sided row the others leave short: which active row gives way.
//!
//! A one-sided Schur row whose direction `S` truncates (its rows' Jacobian a
//! combination of the other active rows', through the tree: a box on the floor whose
//! floor rows hold all of its freedoms, touching a neighbour also held by its own)
//! gets no impulse of its own from the minimum-norm solve, and its value `w` is what
//! the others leave it. Where that is short (`w < −tol`), no impulse along the rows'
//! null space changes it: the set is wrong, not the solve. Goldfarb and Idnani's step
//! for a dependent constraint (1983, §3, "case (ii)"): push the short row's impulse
//! up along the null space (the velocities unchanged, `G Δx = 0` on every active row)
//! until an active one-sided row's impulse reaches zero, and release that row. Without
//! it the short row is independent of the rest, the next solve holds it (`w = 0`), and
//! the released row's value has the sign of `n_j (nᵀ b)`, positive by the choice of
//! the side of the ratio test (the one whose impulse falls).
//!
//! Measured (issue 13, dm_control's stacker, perturbed start, 5 s, with the friction
//! bounds' extrapolation from a zero bound): box2 tipped on one bottom edge, its other
//! edge 9.2e-7 m above the floor (a speculative row, target `−gap/h`), leaning on box3
//! beside it. The far edge's floor row active, the side contact between the boxes is
//! dependent (both boxes held by their floor rows) and short by 9.2e-4 m/s: every try
//! failed on it and went to the dense path (271 of 848 tries, the back-off skipping the
//! rest), whose impulses, the next step's warm start, put the far edge's row back. The
//! step releases that row and box2 rests on box3: 4 867 tries, 5 failed (not settled
//! within the iterations), 9 releases; `World::step` 6 116.9M → 1 785.5M instructions
//! (main without the extrapolation: 1 975.0M). `tests/dependent_rows.rs` starts from
//! the saved boxes.

use super::{scatter, ActiveSet, RowStatus, World};
use constraint_contact::lcp::RowBound;

impl World {
    /// For the short dependent one-sided Schur row `i`, the active one-sided row to release (module doc): the response of the
    /// active rows' impulses to a unit impulse on `i` with the velocities held (one
    /// factor solve, the Schur rows' minimum-norm solve and correction), then the
    /// ratio test `min z_k / (−Δz_k)` over the active one-sided rows `k ≠ i` whose
    /// impulse falls (`Δz_k < −1e-9 max |Δz|`; the first of equals). `None` when the
    /// Schur rows' solve is not current, the push does not raise `i`'s own impulse,
    /// or no row's impulse falls (then the rows cannot hold it: the dense path).
    #[cold]
    #[inline(never)]
    pub(super) fn dependent_release(&self, st: &mut ActiveSet, i: usize) -> Option<usize> {
        let ci = st.schur.iter().position(|&k| k == i)?;
        if !st.s_ready {
            return None;
        }
        let m = self.urows.len();
        let f = &st.factor;
        let size = f.size;
        // Δx = H_A⁻¹ (g_iᵀ − G_Dᵀ Δζ), Δζ = S⁺ G_D H_A⁻¹ g_iᵀ.
        st.ex_resp.clear();
        st.ex_resp.resize(size, 0.0);
        scatter(f, &mut st.ex_resp, &self.urows[i], 1.0);
        f.solve(&self.solver, &mut st.ex_resp);
        st.s_rhs.clear();
        for &k in &st.schur {
            st.s_rhs.push(self.schur_gather(f, &st.ex_resp, k));
        }
        st.ex_zeta.clear();
        st.ex_zeta.resize(st.schur.len(), 0.0);
        if !st.s_fac.apply(&st.s_rhs, &mut st.ex_zeta) {
            return None;
        }
        self.schur_correction(f, &st.schur, &st.ex_zeta, &mut st.corr);
        for (x, y) in st.ex_resp.iter_mut().zip(&st.corr) {
            *x -= y;
        }
        // Δz: −Δx at a factor row, −Δζ at a Schur row, 1 − Δζ_i at `i` itself.
        st.ex_dz.clear();
        st.ex_dz.resize(m, 0.0);
        for (k, &r) in st.map.iter().enumerate() {
            st.ex_dz[r] = -st.ex_resp[f.row_position(k)];
        }
        for (c, &r) in st.schur.iter().enumerate() {
            if r < m {
                st.ex_dz[r] = -st.ex_zeta[c];
            }
        }
        st.ex_dz[i] = 1.0 - st.ex_zeta[ci];
        let scale = st.ex_dz.iter().fold(0.0f64, |s, d| s.max(d.abs()));
        if !(st.ex_dz[i] > 1e-9 * scale) {
            return None;
        }
        let mut best: Option<(usize, f64)> = None;
        for k in 0..m {
            let dz = st.ex_dz[k];
            if k == i
                || st.status[k] != RowStatus::Active
                || !matches!(self.urows[k].bound, RowBound::Unilateral)
                || !(dz < -1e-9 * scale)
            {
                continue;
            }
            let t = st.z[k].max(0.0) / -dz;
            if best.is_none_or(|(_, b)| t < b) {
                best = Some((k, t));
            }
        }
        best.map(|(k, _)| k)
    }
}
