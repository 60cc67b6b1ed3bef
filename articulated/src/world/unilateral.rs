//! One-sided and boxed rows solved together with the joints: joint limits, contact
//! normals and Coulomb friction (Otaduy 2010, "Contacto mediante restricciones": a
//! limit and a contact are the same object, `C(x) ≥ 0`, `λ ≥ 0`, `λ C = 0`).
//!
//! The bilateral joint rows keep Baraff's tree factorization of
//! `H = [M Jᵀ; J −C]`. Adding impulses `z` along one-sided rows `G` (each acting on at
//! most two bodies) to the velocity-level system gives `H x' = b + Gᵀ z`, so
//!
//! ```text
//! x' = x_free + Y z,    Y = H⁻¹ Gᵀ    (one tree solve per row, O(n) each),
//! w  = G x' − bias = (G x_free − bias) + (G Y) z = q + A z,
//! ```
//!
//! where `A = G Y = G K⁻¹ Gᵀ` is the Delassus matrix of the rows *through the joints*
//! (`K⁻¹`, the body block of `H⁻¹`, is the inverse mass of the constrained tree). The
//! complementarity problem `w ≥ 0, z ≥ 0, wᵀz = 0` (friction and dry-friction rows
//! boxed) goes to [`constraint_contact::lcp::solve_rows_with`]; then `x' = x_free + Y z`
//! updates the body velocities *and* the joint impulses, so every row holds in the same
//! solve. Loop joints enter through the same Schur complement as in the plain solve.
//!
//! Without loop rows, equality rows and tendon rows (the humanoids) `Y` is not formed:
//! `A = G H⁻¹ Gᵀ` from forward passes along the rows' paths to the root and
//! `x' = x_free + H⁻¹ (Gᵀ z)` by one solve (`unilateral/path_delassus.rs`).
//!
//! That dense path costs one tree solve per row and a dense `m × m` solve: quadratic
//! and worse in the rows of a chain lying on the floor. Rows that keep the joint tree a
//! tree (limits and dry friction of tree joints, contacts with the static world) are
//! solved instead by an active set inside the tree factor, `O(n)` per iteration
//! ([`super::active_set`], [`UnilateralSettings::sparse`]), body–body contacts with
//! them as coupled rows by their small Schur complement; this module's path remains
//! for tendon limits, loop joints and equality rows, and as the fallback.
//!
//! Rows at the velocity level: a limit or contact with value `C ≥ 0` at the start of the
//! step asks for `G v' ≥ −C/h` (speculative: it may close the gap within the step, no
//! further), one with `C < 0` (violated beyond the slop) for `G v' ≥ β (−C − slop)/h`,
//! at most [`UnilateralSettings::max_correction`].

use alloc::vec::Vec;

use constraint_contact::lcp::{
    row_residual, solve_rows_with, RowBound, RowBuffers, RowSettings, RowStats,
};
use constraint_core::compound::MAX_DOF;
use constraint_core::DVec3;

use super::*;

mod loop_columns;
mod path_delassus;
pub(super) use path_delassus::PathDelassus;

use loop_columns::LoopColumns;

/// Settings of the one-sided rows (limits and contacts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnilateralSettings {
    /// The complementarity solver (method, friction coupling, tolerances).
    pub solver: RowSettings,
    /// Baumgarte factor `β ∈ [0, 1]` for violation beyond `slop`.
    pub baumgarte: f64,
    /// Violation allowed without correction (m for contacts and slide limits, rad for
    /// hinge limits).
    pub slop: f64,
    /// Largest correction rate `β (−C − slop)/h` of a violated row (m/s for contacts and
    /// slide limits, rad/s for hinge limits), as Box2D caps its push-out velocity: a
    /// state that starts far inside a limit or a contact comes out at this rate instead
    /// of in a few steps, without a kick of kinetic energy. Negative or NaN: no
    /// correction beyond the speculative rows.
    pub max_correction: f64,
    /// Rows whose value `C` is below `margin` plus the distance the row's current rate
    /// covers in one step are added (speculative rows); contacts use it as the narrow
    /// phase's margin.
    pub margin: f64,
    /// Solve the rows that keep the joint tree a tree (limits and dry friction of tree
    /// joints, contacts with the static world) by the active set inside the tree factor
    /// (`O(n)` per iteration, `world/active_set.rs`), body–body contacts with them by
    /// their Schur complement; steps with other rows (tendon limits), or whose set does
    /// not settle, use the dense Delassus path. `false`: always the dense path.
    pub sparse: bool,
}

impl Default for UnilateralSettings {
    /// Staggered friction with Newton on the one-sided rows; the friction PGS capped at
    /// 10 sweeps per alternation (a contact patch of several points under joints gives a
    /// semi-definite friction block on which PGS creeps: at the contact crate's
    /// 10,000-sweep cap the dm_control hopper spent 800 µs a step in it; with the
    /// alternations below warm-starting each other, 20 rather than 100 took
    /// humanoid_CMU from 2.7 to 1.7 ms a step with the ragdoll's energy unchanged, and
    /// 10 rather than 20, with the alternations' stall window, 56 → 42 M instructions a
    /// step lying on the floor, `examples/dense_stats.rs`; once the sweeps left out
    /// the friction rows pinned at zero, `contact/src/lcp/pgs/pinned.rs`, 20 sweeps
    /// cost 3.5 % more World::step instructions over seven humanoid runs, 6 sweeps
    /// 1.7 % more with the dm humanoid's unconverged steps 40 → 82), to a residual of
    /// 1e-6; the
    /// staggered alternation kept up while the whole problem's residual is above 1e-6,
    /// up to 50 sweeps or until it stalls
    /// ([`constraint_contact::lcp::staggered::ALTERNATION_STALL_SWEEPS`]; an alternation
    /// whose residual rises, or that stalls above 1e-4, goes on relaxed,
    /// [`constraint_contact::lcp::staggered::ALTERNATION_RELAXATION`]), then ended on
    /// the one-sided rows ([`RowStats::capped`] says so). Two fixed sweeps left a knee of
    /// `scenes/ragdoll.xml` 0.012 rad past its stop with a residual of 1.6 at landing, and
    /// the next step gained 11 J; now 2.5e-8 J at worst (`tests/one_world.rs`); a tolerance
    /// of 1e-8 cost the gymnasium humanoid 5× its time for no visible gain. Baumgarte 0.2,
    /// slop 0.1 mm, correction at most 1 m/s or 1 rad/s (gymnasium's ant starts with its
    /// ankles 30° outside their range: uncapped, 10.5 rad/s in one step and 204 J of
    /// kinetic energy out of 6.7 J), margin 2 cm.
    fn default() -> Self {
        Self {
            solver: RowSettings {
                friction_iterations: 10,
                pgs_iterations: 1000,
                max_sweeps: 50,
                friction_tolerance: 1e-6,
                ..RowSettings::default()
            },
            baumgarte: 0.2,
            slop: 1e-4,
            max_correction: 1.0,
            margin: 0.02,
            sparse: true,
        }
    }
}

/// Where a one-sided row comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowSource {
    /// The lower (`θ − lo ≥ 0`) or upper (`hi − θ ≥ 0`) limit of a joint.
    Limit {
        /// The joint.
        joint: usize,
        /// Its degree of freedom (0 for hinges and prismatic joints).
        dof: usize,
        /// The upper limit (else the lower).
        upper: bool,
    },
    /// The dry friction (MuJoCo's `frictionloss`) of a joint's degree of freedom.
    DryFriction {
        /// The joint.
        joint: usize,
        /// Its degree of freedom.
        dof: usize,
    },
    /// The lower (`L − lo ≥ 0`) or upper (`hi − L ≥ 0`) length limit of a fixed tendon
    /// ([`World::set_tendon_range`]).
    TendonLimit {
        /// The tendon.
        tendon: usize,
        /// The upper limit (else the lower).
        upper: bool,
    },
    /// Contact point `contact` of the last step: its normal (`axis = 0`) or one of its
    /// two friction directions.
    Contact {
        /// Index into the last step's contacts (`World::contacts`, feature `contact`).
        contact: usize,
        /// 0: normal, 1 and 2: tangents.
        axis: u8,
    },
}

/// One row: bodies, Jacobian `[v_a, ω_a, v_b, ω_b]`, target and bound.
#[derive(Clone, Copy, Debug)]
pub(crate) struct URow {
    pub a: Option<usize>,
    pub b: Option<usize>,
    pub j: [DVec3; 4],
    /// `w = G v' − bias`.
    pub bias: f64,
    pub bound: RowBound,
    pub source: RowSource,
}

/// What the one-sided rows did in the last step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UnilateralStats {
    /// One-sided and boxed rows solved (limits, contact normals and tangents).
    pub rows: usize,
    /// Limit rows among them.
    pub limit_rows: usize,
    /// Contact points.
    pub contacts: usize,
    /// What the complementarity solver did.
    pub solver: RowStats,
    /// Natural-map residual of the row problem at the returned impulses (on the dense
    /// path above `friction_tolerance` where [`RowStats::capped`]: the alternations
    /// ended at their cap or stalled).
    pub residual: f64,
    /// Deepest contact penetration at the start of the step (m).
    pub max_penetration: f64,
    /// The rows were solved by the active set in the tree factor (else the dense path).
    pub sparse: bool,
    /// Iterations of the active set (each one `O(n)` factor and solve).
    pub active_set_iterations: usize,
    /// The active set was tried and the step went to the dense path (rows that do not
    /// keep the tree, loop joints, a set that did not settle).
    pub dense_fallback: bool,
    /// The dense problem had no answer with the rows' push-out (no solver converged)
    /// and was solved again with every positive bias (Baumgarte correction,
    /// restitution) set to 0: the step keeps the rows from closing further and leaves
    /// their violation as it was (the dense solve's fallback, `world/unilateral.rs`).
    pub relaxed: bool,
}

impl World {
    /// Sets the limits `lower ≤ q ≤ upper` of hinge (angle, rad, zero at the pose the
    /// joint was built at) or prismatic joint `joint` (displacement, m); one-sided rows
    /// solved with the joints and contacts. Errors: unknown joint, a joint kind other
    /// than hinge or prismatic, NaN bounds or `lower > upper`; infinite bounds are
    /// allowed (one side only).
    pub fn set_limit(
        &mut self,
        joint: usize,
        lower: f64,
        upper: f64,
    ) -> Result<(), ArticulatedError> {
        self.set_dof_limit(joint, 0, lower, upper)
    }

    /// Sets the limits of degree of freedom `dof` of `joint`: `0` for a hinge or a
    /// prismatic joint, `0 … dof − 1` of a compound joint (slides then hinges, the
    /// order of [`constraint_core::Compound::coordinates`]). Errors as
    /// [`Self::set_limit`], and a `dof` the joint does not have.
    pub fn set_dof_limit(
        &mut self,
        joint: usize,
        dof: usize,
        lower: f64,
        upper: f64,
    ) -> Result<(), ArticulatedError> {
        let bad = |reason| ArticulatedError::InvalidJoint { joint, reason };
        if joint >= self.joints.len() {
            return Err(bad("unknown joint"));
        }
        let dofs = self.dofs_of(joint);
        if dofs == 0 {
            return Err(bad(
                "limits apply to hinge, prismatic and compound joints only",
            ));
        }
        if dof >= dofs {
            return Err(bad("the joint has no such degree of freedom"));
        }
        if lower.is_nan() || upper.is_nan() || lower > upper {
            return Err(bad("limits need lower <= upper (no NaN)"));
        }
        if lower == f64::INFINITY || upper == f64::NEG_INFINITY {
            return Err(bad("limits must leave some range"));
        }
        self.limits[joint][dof] = Some([lower, upper]);
        Ok(())
    }

    /// Sets the dry friction `f ≥ 0` (N·m or N; MuJoCo's `frictionloss`) of degree of
    /// freedom `dof` of `joint`: a boxed row on the coordinate's rate, `|λ| ≤ f h`,
    /// solved with the limits and contacts. Errors: unknown joint or degree of freedom
    /// (hinge, prismatic and compound joints have them), negative or non-finite `f`.
    pub fn set_frictionloss(
        &mut self,
        joint: usize,
        dof: usize,
        f: f64,
    ) -> Result<(), ArticulatedError> {
        let bad = |reason| ArticulatedError::InvalidJoint { joint, reason };
        if joint >= self.joints.len() {
            return Err(bad("unknown joint"));
        }
        let dofs = self.dofs_of(joint);
        if dof >= dofs {
            return Err(bad("the joint has no such degree of freedom"));
        }
        if !(f >= 0.0) || !f.is_finite() {
            return Err(bad("frictionloss must be finite and non-negative"));
        }
        self.frictionloss[joint][dof] = f;
        Ok(())
    }

    /// Removes the limits of every degree of freedom of `joint` (no effect on an
    /// unknown joint).
    pub fn clear_limit(&mut self, joint: usize) {
        if let Some(l) = self.limits.get_mut(joint) {
            *l = [None; MAX_DOF];
        }
    }

    /// The joints' limits per degree of freedom, in joint order (`None`: unlimited).
    pub fn limits(&self) -> &[[Option<[f64; 2]>; MAX_DOF]] {
        &self.limits
    }

    /// The coordinate of the first degree of freedom of `joint`: the hinge angle (rad),
    /// the prismatic displacement (m), a compound joint's first coordinate; `None` for
    /// other joints.
    pub fn joint_position(&self, joint: usize) -> Option<f64> {
        self.joint_coordinates(joint).map(|(q, _)| q[0])
    }

    /// The coordinates of `joint` and how many there are: hinge angle, prismatic
    /// displacement, or a compound joint's coordinates (slides in m, then hinges in
    /// rad); `None` for joints without coordinates (spherical, fixed, distance).
    pub fn joint_coordinates(&self, joint: usize) -> Option<([f64; MAX_DOF], usize)> {
        if joint >= self.joints.len() {
            return None;
        }
        let q = self.coordinates_of(joint)?;
        Some((q, self.dofs_of(joint)))
    }

    /// What the one-sided rows did in the last step.
    pub fn unilateral_stats(&self) -> UnilateralStats {
        self.ustats
    }

    /// The impulses of the one-sided rows of the last step with their sources (N·s, or
    /// N·m·s for hinge limits).
    pub fn row_impulses(&self) -> impl Iterator<Item = (RowSource, f64)> + '_ {
        self.urows.iter().zip(&self.uz).map(|(r, z)| (r.source, *z))
    }

    /// The limit rows at the current state (velocities `v` before the solve).
    pub(super) fn push_limit_rows(&mut self, ctx: &StepContext) {
        let h = ctx.h();
        let s = self.unilateral;
        // The rows go to a taken vector so that the coordinates and rows are read by
        // reference from the coordinate table (no copy of its entry per joint).
        let mut urows = core::mem::take(&mut self.urows);
        let mut scratch = ([0.0; MAX_DOF], [[DVec3::ZERO; 4]; MAX_DOF]);
        for (ji, joint) in self.joints.iter().enumerate() {
            let dry = &self.frictionloss[ji];
            if self.limits[ji].iter().all(|l| l.is_none()) && dry.iter().all(|f| *f == 0.0) {
                continue;
            }
            let Some((qs, rows)) = self.coordinates_and_rows_ref(ji, &mut scratch) else {
                continue;
            };
            // Dry friction: a boxed row on the coordinate's rate, |z| ≤ f h (MuJoCo's
            // frictionloss), target rate 0.
            for dof in 0..MAX_DOF {
                let f = dry[dof];
                if f > 0.0 {
                    urows.push(URow {
                        a: joint.parent,
                        b: Some(joint.child),
                        j: rows[dof],
                        bias: 0.0,
                        bound: RowBound::Boxed {
                            lo: -f * h,
                            hi: f * h,
                        },
                        source: RowSource::DryFriction { joint: ji, dof },
                    });
                }
            }
            for dof in 0..MAX_DOF {
                let Some([lo, hi]) = self.limits[ji][dof] else {
                    continue;
                };
                let (q, row) = (qs[dof], rows[dof]);
                let tw = self.twist(joint);
                let rate: f64 = (0..4).map(|s| row[s].dot(tw[s])).sum();
                for (upper, c, sign) in [(false, q - lo, 1.0), (true, hi - q, -1.0)] {
                    if !(c < s.margin + (rate * h).abs()) {
                        continue;
                    }
                    let j = row.map(|r| r * sign);
                    urows.push(URow {
                        a: joint.parent,
                        b: Some(joint.child),
                        j,
                        bias: row_bias(c, ctx, &s),
                        bound: RowBound::Unilateral,
                        source: RowSource::Limit {
                            joint: ji,
                            dof,
                            upper,
                        },
                    });
                }
            }
        }
        self.urows = urows;
    }

    /// Solves the one-sided rows against the factored joint system whose solution
    /// (`x_free`) is in `self.rhs`, and adds `Y z` to it. `loops` are the loop rows the
    /// factor was assembled with.
    pub(super) fn solve_unilateral(&mut self, loops: &LoopRows) -> Result<(), ArticulatedError> {
        let m = self.urows.len();
        self.ustats.rows = m;
        self.ustats.limit_rows = self
            .urows
            .iter()
            .filter(|r| {
                matches!(
                    r.source,
                    RowSource::Limit { .. } | RowSource::TendonLimit { .. }
                )
            })
            .count();
        self.uz.clear();
        self.uz.resize(m, 0.0);
        if m == 0 {
            return Ok(());
        }
        let mut rows = core::mem::take(&mut self.urows);
        let mut z = core::mem::take(&mut self.uz);
        self.warm_unilateral_rows(&rows, &mut z);
        let mut result = self.solve_rows_in_factor(&rows, &mut z, loops);
        if matches!(result, Err(ArticulatedError::Unilateral(_)))
            && rows.iter().any(|r| r.bias > 0.0)
        {
            // No solver answered. A complementarity problem with a positive
            // semi-definite `A` has a solution iff no ray `d ≥ 0`, `A d = 0` has
            // `qᵀd < 0`; only the push-out (`bias > 0`: rows violated beyond the slop,
            // restitution) makes such a ray, when the rows cannot all open at once —
            // a contact whose separation a joint limit at its bound blocks, or two
            // contacts of one rigid pair with opposite normals (issue 13: a thumb 1 cm
            // inside two fingers from both sides). With every push-out at 0 the rows
            // only keep from closing further, which the velocities of the start
            // satisfy up to the joints' drift. Rows that did solve never get here (the
            // same bits as before).
            let first = result;
            let kept: Vec<f64> = rows.iter().map(|r| r.bias).collect();
            for r in rows.iter_mut() {
                r.bias = r.bias.min(0.0);
            }
            z.fill(0.0);
            self.warm_unilateral_rows(&rows, &mut z);
            result = self.solve_rows_in_factor(&rows, &mut z, loops);
            for (r, b) in rows.iter_mut().zip(kept) {
                r.bias = b;
            }
            if result.is_ok() {
                self.ustats.relaxed = true;
            } else {
                // The relaxed problem failed too: the first error is the one to report.
                result = first;
            }
        }
        self.urows = rows;
        self.uz = z;
        let (stats, residual) = result?;
        self.ustats.solver = stats;
        self.ustats.residual = residual;
        Ok(())
    }

    /// The complementarity problem `w = A z + q` of `rows` (their bounds into
    /// `self.ubounds`), solved from `z` (the warm start) by [`solve_movable`].
    fn solve_assembled(
        &mut self,
        rows: &[URow],
        a: &[f64],
        q: &[f64],
        z: &mut [f64],
    ) -> Result<RowStats, ArticulatedError> {
        let mut bounds = core::mem::take(&mut self.ubounds);
        bounds.clear();
        bounds.extend(rows.iter().map(|r| r.bound));
        let settings: RowSettings = self.unilateral.solver;
        let out = solve_movable(&mut self.urowbuf, a, q, &bounds, &settings, z);
        self.ubounds = bounds;
        out.map_err(ArticulatedError::Unilateral)
    }

    /// The natural-map residual at `z` of the problem [`Self::solve_assembled`] solved
    /// (its bounds in `self.ubounds`; the shapes were built there and checked by the
    /// solve).
    fn assembled_residual(&self, a: &[f64], q: &[f64], z: &[f64]) -> Result<f64, ArticulatedError> {
        row_residual(a, q, &self.ubounds, z).map_err(ArticulatedError::Unilateral)
    }

    /// The complementarity problem of `rows` through the factored joint system whose
    /// solution (`x_free`) is in `self.rhs`: `Y = H⁻¹ Gᵀ` (one tree solve per row, with
    /// the loop closure and the equality rows), `A = G Y`, `q = G x_free − bias`, solved
    /// from the impulses in `z` (warm start); then `x' = x_free + Y z` in `self.rhs`.
    /// Without loop rows, equality rows and tendon rows, `A` comes from forward passes
    /// along the rows' paths and `x' = x_free + H⁻¹ (Gᵀ z)` from one solve instead
    /// ([`Self::solve_rows_by_paths`], unilateral/path_delassus.rs).
    /// Returns the solver's statistics and the natural-map residual at `z`. `loops` are
    /// the loop rows the factor was assembled with.
    pub(super) fn solve_rows_in_factor(
        &mut self,
        rows: &[URow],
        z: &mut [f64],
        loops: &LoopRows,
    ) -> Result<(RowStats, f64), ArticulatedError> {
        // Without loops, equality rows and tendon rows: `A` from forward passes along
        // the rows' paths, no `Y` (unilateral/path_delassus.rs).
        if self.rows_on_paths(rows, loops) {
            return self.solve_rows_by_paths(rows, z);
        }
        let m = rows.len();
        let size = self.solver.size;
        // Y = H⁻¹ Gᵀ, one tree solve (with the loop closure) per row.
        let mut ycols = core::mem::take(&mut self.ucols);
        // Not cleared: each column is cleared where its solve reads it (below). Only
        // grown, never shrunk: the velocity level and the projection's contact solve
        // alternate between row counts, and a shrink then regrowth zero-filled the
        // difference each call (7.1M of memset on humanoid_CMU controlled 0.5 s).
        if ycols.len() < m * size {
            ycols.resize(m * size, 0.0);
        }
        let mut mu = core::mem::take(&mut self.umu);
        let zero_rhs = core::mem::take(&mut self.uzero);
        let mut zero_rhs = zero_rhs;
        zero_rhs.clear();
        zero_rhs.resize(loops.2.len(), 0.0);
        let free_scale = self.loop_free_scale(loops);
        let mut mark = core::mem::take(&mut self.umark);
        // With loops every column goes through their Schur complement: `Y_L` and its
        // SVD once for all the columns (loop_columns.rs, the same bits as
        // `solve_with_loops` per column).
        let mut closure = None;
        let mut columns = Ok(());
        if !loops.0.is_empty() && m > 0 {
            match LoopColumns::new(&mut self.solver, &loops.0, &loops.1, free_scale, mu) {
                Ok(c) => closure = Some(c),
                Err(e) => columns = Err(e),
            }
            mu = Vec::new();
        }
        for (k, r) in rows.iter().enumerate() {
            if columns.is_err() {
                break;
            }
            let col = &mut ycols[k * size..(k + 1) * size];
            // A body row's column needs the forward pass only along its bodies' paths
            // to the root, and clearing only there (the sparse backward pass takes the
            // other nodes' right-hand side as zero unread); a tendon's row spans its
            // joints' bodies: cleared whole, full solve.
            let tendon = matches!(r.source, RowSource::TendonLimit { .. });
            if tendon {
                col.fill(0.0);
            } else {
                self.solver.mark_paths(col, [r.a, r.b], &mut mark);
            }
            scatter(&self.solver, &self.tendon_spans, col, r, 1.0);
            let sparse = (!tendon).then_some(mark.as_slice());
            match &mut closure {
                Some(c) => {
                    if let Err(e) = c.solve(&self.solver, &loops.0, &zero_rhs, col, sparse) {
                        columns = Err(e);
                        break;
                    }
                }
                None if tendon => self.solver.solve(col),
                None => self.solver.solve_sparse(col, &mark),
            }
            // Through the equality rows too (equality.rs).
            self.eq.correct(&self.solver, col);
        }
        if let Some(c) = closure {
            mu = c.into_mu();
        }
        if let Err(e) = columns {
            self.ucols = ycols;
            self.umu = mu;
            self.uzero = zero_rhs;
            self.umark = mark;
            return Err(e);
        }
        // A = G Y, q = G x_free − bias: the lower triangle `a_ik = G_i Y_k`, `k ≤ i`,
        // then mirrored; every entry of `a[..m²]` is written, so it is not zeroed (and
        // the buffer only grows, as `ycols`). A body row's entries read its two bodies'
        // six unknowns of each column (`gather_at`, the same sums as `gather`); a tendon
        // limit's go through its spans.
        let mut a_buf = core::mem::take(&mut self.udel);
        if a_buf.len() < m * m {
            a_buf.resize(m * m, 0.0);
        }
        let a = &mut a_buf[..m * m];
        let mut q = core::mem::take(&mut self.uq);
        q.clear();
        for (i, ri) in rows.iter().enumerate() {
            let a_row = &mut a[i * m..i * m + i + 1];
            match row_offsets(&self.solver, ri) {
                Some(off) => {
                    for (k, e) in a_row.iter_mut().enumerate() {
                        *e = gather_at(&ycols[k * size..(k + 1) * size], off, &ri.j);
                    }
                }
                None => {
                    for (k, e) in a_row.iter_mut().enumerate() {
                        let col = &ycols[k * size..(k + 1) * size];
                        *e = gather(&self.solver, &self.tendon_spans, col, ri);
                    }
                }
            }
            q.push(gather(&self.solver, &self.tendon_spans, &self.rhs, ri) - ri.bias);
        }
        // A = G H⁻¹ Gᵀ is symmetric: the upper triangle is the lower one mirrored (half
        // the gathers of computing both and averaging their round-off).
        for i in 0..m {
            for k in i + 1..m {
                a[i * m + k] = a[k * m + i];
            }
        }
        let a = &*a;
        let outcome = match self.solve_assembled(rows, a, &q, z) {
            Ok(stats) => {
                // x' = x_free + Y z.
                for (k, zk) in z.iter().enumerate() {
                    if *zk != 0.0 {
                        let col = &ycols[k * size..(k + 1) * size];
                        for (x, y) in self.rhs.iter_mut().zip(col) {
                            *x += zk * y;
                        }
                    }
                }
                self.assembled_residual(a, &q, z).map(|r| (stats, r))
            }
            Err(e) => Err(e),
        };
        self.ucols = ycols;
        self.udel = a_buf;
        self.uq = q;
        self.umu = mu;
        self.uzero = zero_rhs;
        self.umark = mark;
        outcome
    }

    /// `max g M⁻¹ gᵀ` of the loop rows (their scale without the tree).
    pub(super) fn loop_free_scale(&self, loops: &LoopRows) -> f64 {
        let mut free_scale: f64 = 0.0;
        for (a, b, row) in &loops.0 {
            let mut g = 0.0;
            for (side, body) in [(0usize, *a), (1usize, Some(*b))] {
                if let Some(i) = body {
                    let bd = &self.bodies[i];
                    g += row[2 * side].length_squared() / bd.mass()
                        + row[2 * side + 1].dot(bd.world_inv_inertia() * row[2 * side + 1]);
                }
            }
            free_scale = free_scale.max(g);
        }
        free_scale
    }

    /// Warm start of `rows` (this step's one-sided rows): the contact impulses of the
    /// previous step matched by contact key; limits from zero.
    fn warm_unilateral_rows(&self, rows: &[URow], z: &mut [f64]) {
        #[cfg(feature = "contact")]
        self.warm_contacts(rows, z);
        #[cfg(not(feature = "contact"))]
        let _ = (rows, z);
    }
}

/// The target of a one-sided row of value `c` at the velocity level.
pub(super) fn row_bias(c: f64, ctx: &StepContext, s: &UnilateralSettings) -> f64 {
    let h = ctx.h();
    if c >= 0.0 {
        -c / h
    } else if -c > s.slop {
        // A negative or NaN cap corrects nothing (documented on the setting).
        let cap = if s.max_correction >= 0.0 {
            s.max_correction
        } else {
            0.0
        };
        (s.baumgarte * (-c - s.slop) / h).min(cap)
    } else {
        0.0
    }
}

/// `x += s · Gᵀ` on the row's bodies' unknowns (a tendon limit's on its segments).
fn scatter(
    solver: &crate::tree::TreeSolver,
    spans: &super::equality::Spans,
    x: &mut [f64],
    r: &URow,
    s: f64,
) {
    if let RowSource::TendonLimit { tendon, upper } = r.source {
        let sign = if upper { -1.0 } else { 1.0 };
        spans.scatter(solver, x, tendon, sign * s);
        return;
    }
    for (side, body) in [(0usize, r.a), (1usize, r.b)] {
        let Some(body) = body else { continue };
        let o = solver.body_offset(body);
        for c in 0..3 {
            x[o + c] += s * r.j[2 * side][c];
            x[o + 3 + c] += s * r.j[2 * side + 1][c];
        }
    }
}

/// `G x` on the row's bodies' unknowns (a tendon limit's on its segments).
pub(super) fn gather(
    solver: &crate::tree::TreeSolver,
    spans: &super::equality::Spans,
    x: &[f64],
    r: &URow,
) -> f64 {
    if let RowSource::TendonLimit { tendon, upper } = r.source {
        let sign = if upper { -1.0 } else { 1.0 };
        return sign * spans.gather(solver, x, tendon);
    }
    let mut s = 0.0;
    for (side, body) in [(0usize, r.a), (1usize, r.b)] {
        let Some(body) = body else { continue };
        let o = solver.body_offset(body);
        s += r.j[2 * side].dot(DVec3::new(x[o], x[o + 1], x[o + 2]))
            + r.j[2 * side + 1].dot(DVec3::new(x[o + 3], x[o + 4], x[o + 5]));
    }
    s
}

/// The unknowns' offsets `[o_a, o_b]` of a body row's two sides (`usize::MAX` for the
/// static world), for [`gather_at`]; `None` for a tendon limit (its spans) or a body
/// beyond the tree.
fn row_offsets(solver: &crate::tree::TreeSolver, r: &URow) -> Option<[usize; 2]> {
    if matches!(r.source, RowSource::TendonLimit { .. }) {
        return None;
    }
    let off = |b: Option<usize>| match b {
        None => Some(usize::MAX),
        Some(i) => solver.offset.get(i).copied(),
    };
    Some([off(r.a)?, off(r.b)?])
}

/// [`gather`] of a body row at the offsets [`row_offsets`] gave: `G x` summed in the
/// same order (side `a`, then `b`; each `j_v · v + j_ω · ω`), so the values are the same
/// to the bit, without the per-call source match and offset look-up (the dense
/// Delassus assembly calls it `m²` times a step).
#[inline(always)]
fn gather_at(x: &[f64], off: [usize; 2], j: &[DVec3; 4]) -> f64 {
    let mut s = 0.0;
    for (side, &o) in off.iter().enumerate() {
        if o == usize::MAX {
            continue;
        }
        let v = &x[o..o + 6];
        s += j[2 * side].dot(DVec3::new(v[0], v[1], v[2]))
            + j[2 * side + 1].dot(DVec3::new(v[3], v[4], v[5]));
    }
    s
}

/// [`solve_rows_with`] (in the world's kept buffers) on the rows the joints let move: a row whose Delassus diagonal
/// `G K⁻¹ Gᵀ` is zero (below `1e-12` of the largest) cannot change its rate — a
/// friction direction across a planar joint's plane, a contact on a welded body — so
/// its impulse does nothing and is undetermined; it gets `z = 0` and leaves the problem
/// (with the friction rows of such a normal).
fn solve_movable(
    buffers: &mut RowBuffers,
    a: &[f64],
    q: &[f64],
    bounds: &[RowBound],
    settings: &RowSettings,
    z: &mut [f64],
) -> Result<RowStats, constraint_contact::lcp::LcpError> {
    let m = q.len();
    let scale = (0..m).map(|i| a[i * m + i]).fold(0.0f64, f64::max);
    let movable = |i: usize| a[i * m + i] > 1e-12 * scale;
    let keep: Vec<bool> = (0..m)
        .map(|i| {
            movable(i)
                && match bounds[i] {
                    RowBound::Friction { normal, .. } => movable(normal),
                    _ => true,
                }
        })
        .collect();
    if keep.iter().all(|k| *k) {
        return solve_rows_with(buffers, a, q, bounds, settings, z);
    }
    let idx: Vec<usize> = (0..m).filter(|&i| keep[i]).collect();
    let mut pos = alloc::vec![usize::MAX; m];
    for (k, &i) in idx.iter().enumerate() {
        pos[i] = k;
    }
    let n = idx.len();
    let mut ac = Vec::with_capacity(n * n);
    for &i in &idx {
        for &j in &idx {
            ac.push(a[i * m + j]);
        }
    }
    let qc: Vec<f64> = idx.iter().map(|&i| q[i]).collect();
    let bc: Vec<RowBound> = idx
        .iter()
        .map(|&i| match bounds[i] {
            RowBound::Friction { normal, mu } => RowBound::Friction {
                normal: pos[normal],
                mu,
            },
            b => b,
        })
        .collect();
    let mut zc: Vec<f64> = idx.iter().map(|&i| z[i]).collect();
    let stats = solve_rows_with(buffers, &ac, &qc, &bc, settings, &mut zc)?;
    for v in z.iter_mut() {
        *v = 0.0;
    }
    for (k, &i) in idx.iter().enumerate() {
        z[i] = zc[k];
    }
    Ok(stats)
}
