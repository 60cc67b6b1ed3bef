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
//!
//! A release between two dependent Schur rows can cycle ([`Release::repeats`]). On the
//! humanoids the released row is mostly itself a dependent Schur row, `i`'s partner in
//! the minimum-norm split (`w_j = −w_i`, `Δz_j = −Δz_i`: two contacts of one foot):
//! once released, its contact's friction bounds `±μ z_j` fall to zero, the foot
//! slides, the row comes back (`w_j < 0`) and, three to five iterations on, the same
//! pair is released again from impulses within 0.04–2.4 % of the first ones. The
//! fingerprint of the sets (`World::unilateral_set_is_new`) holds the normals' impulses
//! to the bit and misses it; such a try ran on to [`super::MAX_ITERATIONS`] and went to
//! the dense path. The step now goes there at the repeat. Only those tries change, and
//! they end on the dense path as before, so every trajectory is the same to the bit
//! (the 13 reference runs and dm humanoid perturbed, stacker perturbed and controlled
//! `cmp`-equal). Measured (issue 13, `World::step` instructions, callgrind
//! `--toggle-collect`; dm humanoid perturbed 2 s at the `--qpos`/`--qvel` of
//! `target/models/work/mujoco.tsv`): dm humanoid perturbed 428.04M → 424.23M (4 of its
//! 7 failing releasing tries end at iteration 6 to 8 instead of 12), passive 321.26M →
//! 320.05M, humanoid_CMU controlled 353.75M → 350.52M; the other runs of `instr34` and
//! stacker within ±0.02 %. The successful tries that released a pair twice had moved
//! 16 % to 57 % (dm humanoid, humanoid_CMU controlled); at 20 % a dm humanoid passive
//! try that would have settled ends on the dense path (bits change), at 10 % and 1 %
//! none (320.05M → 319.33M and 320.05M; humanoid_CMU controlled 350.52M and 351.16M).
//! A released factor row is left out of the test: stacker perturbed settles a try that
//! releases the same factor row twice from the same impulses (the friction bounds'
//! drift breaks that cycle).

use super::{scatter, ActiveSet, RowStatus, World};
use constraint_contact::lcp::RowBound;

/// [`Release::repeats`]: the largest move of the pair's impulses, as a fraction of the
/// larger impulse, at which a release repeats an earlier one (the cycles measured moved
/// at most 2.4 %, the settling tries at least 16 %: module doc).
pub(super) const RELEASE_REPEAT: f64 = 0.05;

/// One release of a dependent Schur row for another within a step: the short row, the
/// released row and their impulses when it was made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Release {
    /// The short dependent one-sided row.
    pub(super) short: usize,
    /// The active row released for it.
    pub(super) released: usize,
    /// The short row's impulse at the release.
    pub(super) z_short: f64,
    /// The released row's impulse at the release.
    pub(super) z_released: f64,
}

impl Release {
    /// Whether `self` repeats `earlier`: the same pair, both impulses moved by at most
    /// [`RELEASE_REPEAT`] of the larger of `self`'s (`false` where one is NaN).
    pub(super) fn repeats(&self, earlier: &Release) -> bool {
        let limit = RELEASE_REPEAT * self.z_short.abs().max(self.z_released.abs());
        self.short == earlier.short
            && self.released == earlier.released
            && (self.z_short - earlier.z_short).abs() <= limit
            && (self.z_released - earlier.z_released).abs() <= limit
    }
}

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

#[cfg(test)]
mod tests {
    use super::Release;

    fn release(short: usize, released: usize, z_short: f64, z_released: f64) -> Release {
        Release {
            short,
            released,
            z_short,
            z_released,
        }
    }

    /// The pairs measured on dm humanoid perturbed and passive (module doc): a cycle's
    /// second release repeats the first; a settling try's does not; another pair never.
    #[test]
    fn a_release_repeats_only_the_same_pair_from_about_the_same_impulses() {
        // Cycle: moved 0.024 of 2.421 (1.0 %, limit 5 %).
        let first = release(12, 15, 0.2737, 2.421);
        assert!(release(12, 15, 0.2672, 2.397).repeats(&first));
        // Cycle repeated to the bit.
        assert!(first.repeats(&first));
        // Settled tries: moved 0.0154 of 0.0269 (57 %) and 0.084 of 0.52 (16 %).
        let settled = release(21, 15, 0.01473, -9.96e-4);
        assert!(!release(21, 15, 0.02689, -0.01635).repeats(&settled));
        let settled = release(14, 8, 0.4366, 0.3380);
        assert!(!release(14, 8, 0.5206, 0.3151).repeats(&settled));
        // Another pair, or the pair the other way round, at the same impulses.
        assert!(!release(12, 16, 0.2737, 2.421).repeats(&first));
        assert!(!release(15, 12, 0.2737, 2.421).repeats(&first));
        // NaN impulses repeat nothing.
        assert!(!release(12, 15, f64::NAN, 2.421).repeats(&first));
    }
}
