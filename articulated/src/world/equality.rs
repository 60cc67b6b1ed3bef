//! Equality rows over coordinates (MuJoCo's `equality/joint` and `equality/tendon`)
//! and tendon length limits (MuJoCo's tendon `range`).
//!
//! A *coordinate sum* `L = Σ_i c_i q_i` runs over degrees of freedom of hinge, slide
//! and compound joints (a single joint coordinate is the sum with one term; a fixed
//! tendon is its length). Its rate is `L̇ = Σ_i c_i G_i v` with `G_i` the rate row of
//! `q_i` (`World::coordinates_and_rows`), a row over *several* bodies: one two-body
//! segment `c_i G_i` per term. An equality couples two sums by a quartic,
//!
//! ```text
//! C(x) = L₁ − p₀ − Σ_{k=1..4} p_k L₂^k = 0,
//! J    = ∂C/∂v = Σ_{i ∈ L₁} c_i G_i − P'(L₂) Σ_{i ∈ L₂} c_i G_i,   P'(s) = Σ k p_k s^{k−1},
//! ```
//!
//! with every coordinate zero at the pose the joint was built at (MuJoCo's `qpos0`,
//! where MuJoCo's `q − q₀` and tendon `L − L₀` are zero); without a second sum the row
//! is `L₁ − p₀ = 0`.
//!
//! The rows are hard (MuJoCo's `solref`/`solimp` softness is not modelled) and are
//! solved with the joints as a second Schur complement over the factored tree-and-loop
//! system `H` (the loop joints' own complement, [`crate::tree`]): for the augmented
//! system `[H Eᵀ; E 0][x; ν] = [b; r_E]`
//!
//! ```text
//! Y_E = H⁻¹ Eᵀ  (one tree-and-loop solve per row),   S = E Y_E,
//! S ν = E x_free − r_E  (SVD, minimum norm: redundant rows give finite ν),
//! x   = x_free − Y_E ν.
//! ```
//!
//! They are not tree edges (a row over several bodies is neither a joint node nor a
//! two-body loop row), and a bilateral row is not a complementarity row: a separate
//! complement keeps the loop code and the one-sided solve unchanged, and the one-sided
//! rows see the equalities through the same correction of their columns
//! (`y ← y − Y_E S⁺ E y`, [`EqRows::correct`]), so limits, contacts and equalities hold
//! in one solve. A velocity-level step with one-sided rows and no loop joints solves
//! the same rows in the active set instead (`world/active_set.rs`): always-active
//! Schur rows over the factor of the tree and the active one-sided rows, with the
//! same `ν`; the dense path above is its fallback. Right-hand sides: `r_E = −β C/h` at the velocity level, `−C` in the
//! Newton position projection (which also counts `|C|` in its error, so
//! `VelocityProjected` drives `C → 0` at the position level).
//!
//! RATTLE and RATTLE4 take the rows as their joints: `−C/h` in the first kick, `−C(x)`
//! in each SHAKE iteration (with the start-of-step Jacobian, as the joints; the
//! projection's error includes `|C|`), `E v = 0` in the final kick and in the damping
//! flow. The acceleration level does not (it would need `Ė v`): its steps in a world
//! with equalities are taken at the velocity level, counted in
//! [`StepStats::equality_fallbacks`] — the rows are always enforced, never skipped.
//!
//! A tendon range `lo ≤ L ≤ hi` gives two one-sided rows `L − lo ≥ 0`, `hi − L ≥ 0`
//! with the Jacobian `±Σ c_i G_i` (plus a spatial tendon's path rows,
//! `world/spatial_tendon.rs`), solved in the complementarity problem with the
//! joint limits and contacts ([`RowSource::TendonLimit`]).

use alloc::vec::Vec;

use constraint_core::DVec3;
use constraint_lagrange::solve::svd::SvdSolver;
use constraint_lagrange::solve::DenseMatrix;

use super::unilateral::{row_bias, URow};
use super::*;

/// `(joint, dof, coefficient)` terms of a coordinate sum `L = Σ c q_{joint, dof}`.
pub type Terms = Vec<(usize, usize, f64)>;

/// A holonomic equality between two coordinate sums (MuJoCo's `equality/joint` with one
/// term per side, `equality/tendon` with the tendons' terms):
/// `L₁ − p₀ − Σ_{k=1..4} p_k L₂^k = 0`, every coordinate zero at the built pose.
#[derive(Clone, Debug, PartialEq)]
pub struct Equality {
    /// `L₁`'s terms (at least one).
    pub first: Terms,
    /// `L₂`'s terms; empty: the row is `L₁ = p₀`.
    pub second: Terms,
    /// `p₀ … p₄` (MuJoCo's `polycoef`).
    pub polycoef: [f64; 5],
}

impl Equality {
    /// `(C, ∂C/∂L₂)` at the sums' values `l1`, `l2`.
    pub fn value(&self, l1: f64, l2: f64) -> (f64, f64) {
        let p = &self.polycoef;
        if self.second.is_empty() {
            return (l1 - p[0], 0.0);
        }
        // Horner: P(s) − p₀ and P'(s).
        let poly = l2 * (p[1] + l2 * (p[2] + l2 * (p[3] + l2 * p[4])));
        let slope = p[1] + l2 * (2.0 * p[2] + l2 * (3.0 * p[3] + l2 * 4.0 * p[4]));
        (l1 - p[0] - poly, -slope)
    }
}

/// One two-body segment of a row over several bodies: `(a, b, [v_a, ω_a, v_b, ω_b])`.
pub(crate) type Seg = (Option<usize>, usize, [DVec3; 4]);

/// Rows over several bodies: each a range of two-body segments whose sum is the row.
#[derive(Clone, Debug, Default)]
pub(crate) struct Spans {
    segs: Vec<Seg>,
    ranges: Vec<(usize, usize)>,
}

impl Spans {
    fn clear(&mut self) {
        self.segs.clear();
        self.ranges.clear();
    }

    /// `x += s · rowᵀ` on the bodies' unknowns.
    pub(crate) fn scatter(
        &self,
        solver: &crate::tree::TreeSolver,
        x: &mut [f64],
        row: usize,
        s: f64,
    ) {
        let (lo, hi) = self.ranges[row];
        for (a, b, g) in &self.segs[lo..hi] {
            solver.scatter(x, *a, *b, g, s);
        }
    }

    /// `row · x` on the bodies' unknowns.
    pub(crate) fn gather(&self, solver: &crate::tree::TreeSolver, x: &[f64], row: usize) -> f64 {
        let (lo, hi) = self.ranges[row];
        let mut s = 0.0;
        for (a, b, g) in &self.segs[lo..hi] {
            for (side, body) in [(0usize, *a), (1usize, Some(*b))] {
                let Some(body) = body else { continue };
                let o = solver.body_offset(body);
                s += g[2 * side].dot(DVec3::new(x[o], x[o + 1], x[o + 2]))
                    + g[2 * side + 1].dot(DVec3::new(x[o + 3], x[o + 4], x[o + 5]));
            }
        }
        s
    }

    /// `max row M⁻¹ rowᵀ` over the rows, each segment's bodies taken free (the rows'
    /// scale without the tree; an upper bound for rows whose segments share a body).
    fn free_scale(&self, bodies: &[RigidBody]) -> f64 {
        (0..self.ranges.len()).fold(0.0f64, |w, r| w.max(self.row_free_scale(bodies, r)))
    }

    /// `row M⁻¹ rowᵀ` of one row, each segment's bodies taken free (an upper bound
    /// where segments share a body).
    pub(crate) fn row_free_scale(&self, bodies: &[RigidBody], row: usize) -> f64 {
        let mut g = 0.0;
        for (a, b, j) in self.segments(row) {
            for (side, body) in [(0usize, *a), (1usize, Some(*b))] {
                if let Some(i) = body {
                    let bd = &bodies[i];
                    g += j[2 * side].length_squared() / bd.mass()
                        + j[2 * side + 1].dot(bd.world_inv_inertia() * j[2 * side + 1]);
                }
            }
        }
        g
    }

    /// Row `row`'s two-body segments (their sum is the row).
    #[inline]
    pub(crate) fn segments(&self, row: usize) -> &[Seg] {
        let (lo, hi) = self.ranges[row];
        &self.segs[lo..hi]
    }
}

/// The equality rows of the current assembly and their complement (scratch kept
/// across steps).
#[derive(Clone, Debug, Default)]
pub(crate) struct EqRows {
    /// One row per equality.
    spans: Spans,
    /// `C` per row at the assembly.
    value: Vec<f64>,
    /// The right-hand side `r_E` per row.
    rhs: Vec<f64>,
    /// Whether the rows take part in the next solves (set by the assemblies that
    /// load them, cleared by every other assembly).
    pub active: bool,
    /// `Y_E = H⁻¹ Eᵀ`, a column of the tree size per row.
    cols: Vec<f64>,
    /// `S⁺`, row-major.
    pinv: Vec<f64>,
    /// The multipliers `ν` of the last solve.
    nu: Vec<f64>,
    /// Tree size of `cols`.
    size: usize,
    /// Zero loop right-hand side and loop multipliers of the column solves (scratch).
    zero: Vec<f64>,
    mu: Vec<f64>,
}

impl EqRows {
    /// The loaded rows (0 when the last assembly did not load them).
    #[inline]
    pub(crate) fn len(&self) -> usize {
        if self.active {
            self.value.len()
        } else {
            0
        }
    }

    /// Row `row`'s segments ([`Spans::segments`]).
    #[inline]
    pub(crate) fn segments(&self, row: usize) -> &[Seg] {
        self.spans.segments(row)
    }

    /// Row `row`'s right-hand side `r_E`.
    #[inline]
    pub(crate) fn target(&self, row: usize) -> f64 {
        self.rhs[row]
    }

    /// Row `row`'s `row M⁻¹ rowᵀ` with free bodies ([`Spans::row_free_scale`]).
    pub(crate) fn row_free_scale(&self, bodies: &[RigidBody], row: usize) -> f64 {
        self.spans.row_free_scale(bodies, row)
    }

    /// Records the multipliers `ν` of a solve made elsewhere (the active set's
    /// Schur rows, `world/active_set.rs`), for [`World::equality_impulses`].
    pub(crate) fn set_impulses(&mut self, nu: impl Iterator<Item = f64>) {
        self.nu.clear();
        self.nu.extend(nu);
    }

    /// `y ← y − Y_E S⁺ (E y)`: a column of `H⁻¹` extended to the equality rows.
    pub(crate) fn correct(&self, solver: &crate::tree::TreeSolver, y: &mut [f64]) {
        let k = self.value.len();
        if !self.active || k == 0 {
            return;
        }
        let (mut t, mut tv) = ([0.0; 8], Vec::new());
        let ey = small_buffer(&mut t, &mut tv, k);
        for (i, e) in ey.iter_mut().enumerate() {
            *e = self.spans.gather(solver, y, i);
        }
        for i in 0..k {
            let u: f64 = (0..k).map(|j| self.pinv[i * k + j] * ey[j]).sum();
            if u != 0.0 {
                let col = &self.cols[i * self.size..(i + 1) * self.size];
                for (x, c) in y.iter_mut().zip(col) {
                    *x -= u * c;
                }
            }
        }
    }
}

impl World {
    /// Adds an equality row ([`Equality`]); returns its index. Errors
    /// ([`ArticulatedError::InvalidParameter`]): no term in `first` (e.g. a tendon with
    /// no joints), a term naming an unknown joint or degree of freedom (spherical,
    /// free, fixed and distance joints have no coordinate), a non-finite coefficient
    /// or `polycoef`, both sides the same sum.
    pub fn add_equality(&mut self, e: Equality) -> Result<usize, ArticulatedError> {
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "equality",
            rule,
        };
        if e.first.is_empty() {
            return Err(bad("the first side needs at least one coordinate"));
        }
        if e.first
            .iter()
            .chain(&e.second)
            .any(|&(j, d, c)| d >= self.dofs_of(j) || !c.is_finite())
        {
            return Err(bad(
                "terms must name hinge, slide or compound degrees of freedom with finite coefficients",
            ));
        }
        if e.polycoef.iter().any(|p| !p.is_finite()) {
            return Err(bad("polycoef must be finite"));
        }
        if e.first == e.second {
            return Err(bad("the two sides must be different coordinates"));
        }
        self.equalities.push(e);
        Ok(self.equalities.len() - 1)
    }

    /// The equalities.
    pub fn equalities(&self) -> &[Equality] {
        &self.equalities
    }

    /// Sets the length limits `lower ≤ L ≤ upper` of tendon `tendon` (one-sided rows
    /// with the joint limits; infinite bounds allowed, one side only). Errors: unknown
    /// tendon, a tendon with no terms, NaN bounds or `lower > upper`, no range left.
    pub fn set_tendon_range(
        &mut self,
        tendon: usize,
        lower: f64,
        upper: f64,
    ) -> Result<(), ArticulatedError> {
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "tendon range",
            rule,
        };
        let Some(t) = self.tendons.get(tendon) else {
            return Err(bad("unknown tendon"));
        };
        if t.terms.is_empty() && self.tendon_path(tendon).is_empty() {
            return Err(bad(
                "a tendon with no joints and no path has no length to limit",
            ));
        }
        if lower.is_nan() || upper.is_nan() || lower > upper {
            return Err(bad("limits need lower <= upper (no NaN)"));
        }
        if lower == f64::INFINITY || upper == f64::NEG_INFINITY {
            return Err(bad("limits must leave some range"));
        }
        self.tendon_ranges.resize(self.tendons.len(), None);
        self.tendon_ranges[tendon] = Some([lower, upper]);
        Ok(())
    }

    /// The tendons' length limits, in tendon order (`None`: unlimited; shorter than
    /// the tendon list when the last tendons have none).
    pub fn tendon_ranges(&self) -> &[Option<[f64; 2]>] {
        &self.tendon_ranges
    }

    /// The value and rate `(Σ c q, Σ c q̇)` of a coordinate sum at the current state,
    /// the rate through the rate rows (`Σ c G v`); terms naming no coordinate (an
    /// unknown joint or degree of freedom) add nothing.
    pub fn coordinate_sum(&self, terms: &[(usize, usize, f64)]) -> (f64, f64) {
        let mut spans = Spans::default();
        let l = self.push_sum(&mut spans.segs, terms, 1.0);
        spans.ranges.push((0, spans.segs.len()));
        (l, self.span_rate(&spans.segs))
    }

    /// Tendon `t`'s length and rate at the current state, its joint terms' and its
    /// path's ([`World::add_spatial_tendon`]) together (`None`: unknown tendon).
    pub fn tendon_length(&self, t: usize) -> Option<(f64, f64)> {
        let (l, rate) = self.coordinate_sum(&self.tendons.get(t)?.terms);
        let (lp, rp) = self.path_state(t);
        Some((l + lp, rate + rp))
    }

    /// Equality `i`'s value `C` and its rate `J v` through the row's Jacobian at the
    /// current state (`None`: unknown equality).
    pub fn equality_residual(&self, i: usize) -> Option<(f64, f64)> {
        let e = self.equalities.get(i)?;
        let mut segs = Vec::new();
        let c = self.push_equality(&mut segs, e);
        Some((c, self.span_rate(&segs)))
    }

    /// `max |C|` over the equalities at the current state (0 without any).
    ///
    /// Each `C` from the joints' coordinates alone: the same bits as
    /// [`Self::equality_residual`]'s, without its rate rows, their segments' buffer
    /// (one allocation a call) and the rate (issue 13: dm manipulator controlled 2 s
    /// evaluates it 2,902 times, 6.6M instructions).
    pub fn max_equality_violation(&self) -> f64 {
        self.max_equality_violation_by(|j| self.coordinates_of(j))
    }

    /// [`Self::max_equality_violation`] with the coordinates of joint `j` from
    /// `coords(j)` (the same bits as [`Self::coordinates_of`]: the projection's error
    /// takes a hard hinge's angle from the directions its separation rotated). Out of
    /// line: inlined into the projection's error, it cost the models without
    /// equalities 0.06 to 0.1 % (half_cheetah, dm cheetah, pusher_v5 controlled).
    #[inline(never)]
    pub(super) fn max_equality_violation_by(
        &self,
        coords: impl Fn(usize) -> Option<[f64; MAX_DOF]>,
    ) -> f64 {
        self.equalities
            .iter()
            .fold(0.0, |m, e| m.max(self.equality_value(e, &coords).abs()))
    }

    /// An equality's `C = L₁ − P(L₂)` at the current state, from the coordinates
    /// alone (`coords`, the same bits as the rows' path): the value
    /// [`Self::push_equality`] returns, each sum from `+0` in term order as there.
    fn equality_value(
        &self,
        e: &Equality,
        coords: &impl Fn(usize) -> Option<[f64; MAX_DOF]>,
    ) -> f64 {
        let sum = |terms: &[(usize, usize, f64)]| {
            let mut l = 0.0;
            for &(j, d, c) in terms {
                // Terms without a coordinate (unknown joint or dof) add nothing.
                if d >= self.dofs_of(j) {
                    continue;
                }
                let Some(q) = coords(j) else {
                    continue;
                };
                l += c * q[d];
            }
            l
        };
        e.value(sum(&e.first), sum(&e.second)).0
    }

    /// The multipliers `ν` (impulses, N·s or N·m·s) of the equality rows in the last
    /// solve that had them: on the dense path before the one-sided rows' correction,
    /// from the active set (`world/active_set.rs`) with the one-sided rows' impulses.
    pub fn equality_impulses(&self) -> &[f64] {
        &self.eq.nu
    }

    /// `Σ c G v` over segments, with the body twists.
    pub(super) fn span_rate(&self, segs: &[Seg]) -> f64 {
        segs.iter()
            .map(|(a, b, g)| {
                let tw = |i: Option<usize>| {
                    i.map_or((DVec3::ZERO, DVec3::ZERO), |i| {
                        (self.bodies[i].v, self.bodies[i].omega)
                    })
                };
                let ((va, wa), (vb, wb)) = (tw(*a), tw(Some(*b)));
                g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb)
            })
            .sum()
    }

    /// Pushes the segments `scale · c G` of a coordinate sum; returns its value.
    fn push_sum(&self, segs: &mut Vec<Seg>, terms: &[(usize, usize, f64)], scale: f64) -> f64 {
        let mut l = 0.0;
        for &(j, d, c) in terms {
            // Terms without a coordinate (unknown joint or dof) add nothing.
            if d >= self.dofs_of(j) {
                continue;
            }
            let Some((q, rows)) = self.coordinates_and_rows(j) else {
                continue;
            };
            l += c * q[d];
            let joint = &self.joints[j];
            segs.push((joint.parent, joint.child, rows[d].map(|r| r * (c * scale))));
        }
        l
    }

    /// Pushes an equality's Jacobian segments; returns `C`.
    fn push_equality(&self, segs: &mut Vec<Seg>, e: &Equality) -> f64 {
        let l1 = self.push_sum(segs, &e.first, 1.0);
        let mid = segs.len();
        let l2 = self.push_sum(segs, &e.second, 1.0);
        let (c, slope) = e.value(l1, l2);
        for s in &mut segs[mid..] {
            s.2 = s.2.map(|r| r * slope);
        }
        c
    }

    /// Loads the equality rows at the current state with right-hand side
    /// `r_E = rhs(C)` for the next solves.
    pub(super) fn load_equalities(&mut self, rhs: impl Fn(f64) -> f64) {
        let mut eq = core::mem::take(&mut self.eq);
        eq.spans.clear();
        eq.value.clear();
        eq.rhs.clear();
        for e in &self.equalities {
            let lo = eq.spans.segs.len();
            let c = self.push_equality(&mut eq.spans.segs, e);
            eq.spans.ranges.push((lo, eq.spans.segs.len()));
            eq.value.push(c);
            eq.rhs.push(rhs(c));
        }
        eq.active = !self.equalities.is_empty();
        self.eq_cache.untag();
        self.eq = eq;
    }

    /// Re-evaluates the loaded rows' values at the current state, keeping their
    /// Jacobian (SHAKE's simplified Newton), with right-hand side `r_E = rhs(C)`;
    /// returns `max |C|` (0 without rows).
    pub(super) fn refresh_equality_rhs(&mut self, rhs: impl Fn(f64) -> f64) -> f64 {
        if !self.eq.active {
            return 0.0;
        }
        let mut worst: f64 = 0.0;
        for i in 0..self.equalities.len().min(self.eq.value.len()) {
            let e = &self.equalities[i];
            let (c, _) = e.value(self.sum_value(&e.first), self.sum_value(&e.second));
            self.eq.value[i] = c;
            self.eq.rhs[i] = rhs(c);
            worst = worst.max(c.abs());
        }
        worst
    }

    /// `Σ c q` of a coordinate sum at the current state (terms without a coordinate
    /// add nothing).
    fn sum_value(&self, terms: &[(usize, usize, f64)]) -> f64 {
        terms
            .iter()
            .filter(|&&(j, d, _)| d < self.dofs_of(j))
            .filter_map(|&(j, d, c)| self.coordinates_of(j).map(|q| c * q[d]))
            .sum()
    }

    /// The equality complement after the tree-and-loop solve in `self.rhs`:
    /// `S ν = E x_free − r_E`, `x = x_free − Y_E ν` (module docs).
    pub(super) fn solve_equalities(&mut self, loops: &LoopRows) -> Result<(), ArticulatedError> {
        let mut eq = core::mem::take(&mut self.eq);
        let out = self.equality_complement(&mut eq, loops);
        self.eq = eq;
        out
    }

    fn equality_complement(
        &mut self,
        eq: &mut EqRows,
        loops: &LoopRows,
    ) -> Result<(), ArticulatedError> {
        let k = eq.value.len();
        let size = self.solver.size;
        eq.size = size;
        let free_scale = self.loop_free_scale(loops);
        // Singular values below 1e-10 of the rows' free scale are dropped (a row that
        // repeats a joint or another equality), as for the loop rows.
        let floor = 1e-10 * eq.spans.free_scale(&self.bodies);
        let inputs = super::eq_cache::EqInputs {
            bodies: &self.bodies,
            compliance: &self.compliance,
            armature: &self.armature,
            size,
            loops,
            segs: &eq.spans.segs,
            ranges: &eq.spans.ranges,
            scales: [free_scale, floor],
        };
        let solved = match self.eq_cache.lookup(&inputs, &mut eq.cols, &mut eq.pinv) {
            Some(solved) => solved,
            None => {
                let solved = self.complement_matrix(eq, loops, free_scale, floor)?;
                self.eq_cache.store(&eq.cols, &eq.pinv, solved);
                solved
            }
        };
        // `small_buffer`, as `EqRows::correct` (a `Vec` collected per
        // solve before: one allocation each, 4,092 on dm manipulator controlled 2 s).
        let (mut t, mut tv) = ([0.0; 8], Vec::new());
        let b = small_buffer(&mut t, &mut tv, k);
        for (i, bi) in b.iter_mut().enumerate() {
            *bi = eq.spans.gather(&self.solver, &self.rhs, i) - eq.rhs[i];
        }
        if b.iter().any(|v| !v.is_finite()) {
            return Err(ArticulatedError::LoopSolve);
        }
        eq.nu.clear();
        eq.nu.resize(k, 0.0);
        if solved {
            for i in 0..k {
                eq.nu[i] = (0..k).map(|j| eq.pinv[i * k + j] * b[j]).sum();
            }
        }
        for (r, nu) in eq.nu.iter().enumerate() {
            let col = &eq.cols[r * size..(r + 1) * size];
            for (x, y) in self.rhs.iter_mut().zip(col) {
                *x -= nu * y;
            }
        }
        Ok(())
    }

    /// `Y_E = H⁻¹ Eᵀ` into `eq.cols` and `S⁺` (`S = E Y_E`, singular values below
    /// `floor` dropped) into `eq.pinv`; returns whether `S` had one above `floor` (else
    /// `S⁺ = 0`, `ν = 0`).
    fn complement_matrix(
        &mut self,
        eq: &mut EqRows,
        loops: &LoopRows,
        free_scale: f64,
        floor: f64,
    ) -> Result<bool, ArticulatedError> {
        let k = eq.value.len();
        let size = eq.size;
        eq.cols.clear();
        eq.cols.resize(k * size, 0.0);
        eq.zero.clear();
        eq.zero.resize(loops.2.len(), 0.0);
        // Each column through the loop closure (`tree/loops.rs`): `Y_L` and its SVD
        // built once (or kept from the velocity solve with this factor), not per row.
        let closed = !loops.0.is_empty();
        if closed {
            let mut mark = Vec::new();
            self.solver
                .build_loop_closure(&loops.0, &loops.1, free_scale, &mut mark)?;
        }
        let mut rhs = Vec::new();
        for r in 0..k {
            let col = &mut eq.cols[r * size..(r + 1) * size];
            eq.spans.scatter(&self.solver, col, r, 1.0);
            self.solver.solve(col);
            if closed {
                self.solver
                    .close_loops(&loops.0, &eq.zero, col, &mut rhs, &mut eq.mu)?;
            }
        }
        if k == 1 {
            let s = eq.spans.gather(&self.solver, &eq.cols[..size], 0);
            return scalar_pinv(s, floor, &mut eq.pinv);
        }
        let mut s = DenseMatrix::from_fn(k, k, |i, j| {
            eq.spans
                .gather(&self.solver, &eq.cols[j * size..(j + 1) * size], i)
        });
        for i in 0..k {
            for j in i + 1..k {
                let m = 0.5 * (s.get(i, j) + s.get(j, i));
                s.set(i, j, m);
                s.set(j, i, m);
            }
        }
        if !s.is_finite() {
            return Err(ArticulatedError::LoopSolve);
        }
        let svd = SvdSolver::new(&s, 1e-10).map_err(|_| ArticulatedError::LoopSolve)?;
        let smax = svd.singular_values().first().copied().unwrap_or(0.0);
        eq.pinv.clear();
        eq.pinv.resize(k * k, 0.0);
        if !(smax > floor) {
            return Ok(false);
        }
        let svd = if floor > 1e-10 * smax {
            SvdSolver::new(&s, floor / smax).map_err(|_| ArticulatedError::LoopSolve)?
        } else {
            svd
        };
        let mut unit = alloc::vec![0.0; k];
        let mut col = alloc::vec![0.0; k];
        for j in 0..k {
            unit.iter_mut().for_each(|u| *u = 0.0);
            unit[j] = 1.0;
            svd.solve_min_norm(&unit, &mut col)
                .map_err(|_| ArticulatedError::LoopSolve)?;
            for i in 0..k {
                eq.pinv[i * k + j] = col[i];
            }
        }
        Ok(true)
    }

    /// The largest violation of a tendon range, `max(lo − L, L − hi, 0)` (0 without
    /// ranges).
    pub(super) fn max_tendon_limit_violation(&self) -> f64 {
        let mut worst: f64 = 0.0;
        for (ti, t) in self.tendons.iter().enumerate() {
            let Some([lo, hi]) = self.tendon_ranges.get(ti).copied().flatten() else {
                continue;
            };
            let l = self.sum_value(&t.terms) + self.path_state(ti).0;
            worst = worst.max(lo - l).max(l - hi);
        }
        worst
    }

    /// Appends each violated tendon range to the loaded equality rows as an equality at
    /// its bound, for the projection (`[M Eᵀ; E 0][δ; ν] = [0; −C]`, Goldenthal et al.
    /// 2007): the row `± Σ c G` with `C = L − lo` (lower) or `hi − L` (upper), as
    /// `push_violated_limits` does for a joint limit. A tendon spans several joints, so
    /// the row goes with the equality rows' Schur complement, not the loop rows. Call
    /// after [`Self::load_equalities`]; the rows' buffers are reused.
    pub(super) fn push_violated_tendon_limits(&mut self) {
        let mut eq = core::mem::take(&mut self.eq);
        for (ti, t) in self.tendons.iter().enumerate() {
            let Some([lo, hi]) = self.tendon_ranges.get(ti).copied().flatten() else {
                continue;
            };
            let l = self.sum_value(&t.terms) + self.path_state(ti).0;
            for (c, sign) in [(l - lo, 1.0), (hi - l, -1.0)] {
                if c < 0.0 {
                    let start = eq.spans.segs.len();
                    self.push_sum(&mut eq.spans.segs, &t.terms, sign);
                    self.push_path(&mut eq.spans.segs, ti, sign);
                    eq.spans.ranges.push((start, eq.spans.segs.len()));
                    eq.value.push(c);
                    eq.rhs.push(-c);
                    eq.active = true;
                    self.eq_cache.untag();
                }
            }
        }
        self.eq = eq;
    }

    /// The tendon-limit rows at the current state (velocities before the solve): for
    /// each limited tendon near a bound, `L − lo ≥ 0` and/or `hi − L ≥ 0`.
    pub(super) fn push_tendon_limit_rows(&mut self, ctx: &StepContext) {
        let h = ctx.h();
        let mut spans = core::mem::take(&mut self.tendon_spans);
        spans.clear();
        let s = self.unilateral;
        for (ti, t) in self.tendons.iter().enumerate() {
            let lo = spans.segs.len();
            let range = self.tendon_ranges.get(ti).copied().flatten();
            let mut l = 0.0;
            if range.is_some() {
                l = self.push_sum(&mut spans.segs, &t.terms, 1.0)
                    + self.push_path(&mut spans.segs, ti, 1.0);
            }
            spans.ranges.push((lo, spans.segs.len()));
            let Some([lower, upper]) = range else {
                continue;
            };
            let rate = self.span_rate(&spans.segs[lo..]);
            for (up, c) in [(false, l - lower), (true, upper - l)] {
                if !(c < s.margin + (rate * h).abs()) {
                    continue;
                }
                self.urows.push(URow {
                    a: None,
                    b: None,
                    j: [DVec3::ZERO; 4],
                    bias: row_bias(c, ctx, &s),
                    bound: constraint_contact::lcp::RowBound::Unilateral,
                    source: RowSource::TendonLimit {
                        tendon: ti,
                        upper: up,
                    },
                });
            }
        }
        self.tendon_spans = spans;
    }
}

// The tests load MJCF text: they need the `mjcf` feature too.
/// [`World::complement_matrix`]'s `S⁺` of a single row, `S = [s]`: `S⁺ = [1/s]`
/// unless `|s|` is at most `floor` (then `S⁺ = 0`, returns `false`). The same bits
/// as its one-sided Jacobi SVD of the 1×1 matrix (`constraint_lagrange`'s
/// `SvdSolver`), without its allocations: the entry scaled by `amax = |s|` is
/// `w = s/|s| = ±1` (exact), no rotation, `σ = √(w·w)·amax = |s|`, `u = w`, `v = 1`;
/// its rank test `σ > rel·σ` with `rel = floor/σ` when that exceeds `1e-10` (the
/// second decomposition there); the min-norm solve of `e₁`:
/// `x = 0 + (1/σ)(u·1)·1 = (1/|s|)·(s/|s|)`, an error if not finite. (dm manipulator
/// controlled 2 s: 3,332 decompositions of its one tendon coupling, 6.5M instructions
/// with their allocations and frees.)
fn scalar_pinv(s: f64, floor: f64, pinv: &mut Vec<f64>) -> Result<bool, ArticulatedError> {
    if !s.is_finite() {
        return Err(ArticulatedError::LoopSolve);
    }
    let smax = s.abs();
    pinv.clear();
    pinv.resize(1, 0.0);
    if !(smax > floor) {
        return Ok(false);
    }
    let rel = if floor > 1e-10 * smax {
        floor / smax
    } else {
        1e-10
    };
    if !rel.is_finite() {
        return Err(ArticulatedError::LoopSolve);
    }
    let cutoff = rel.max(0.0) * smax;
    if smax > cutoff && smax > 0.0 {
        let x = (1.0 / smax) * (s / smax);
        if !x.is_finite() {
            return Err(ArticulatedError::LoopSolve);
        }
        pinv[0] = x;
    }
    Ok(true)
}

/// `k` zeros for a solve's scratch: on the stack `t` for up to 8 (every equality set of
/// the fetched models; no allocation), else in the heap `tv`.
fn small_buffer<'a>(t: &'a mut [f64; 8], tv: &'a mut Vec<f64>, k: usize) -> &'a mut [f64] {
    if k <= t.len() {
        &mut t[..k]
    } else {
        tv.resize(k, 0.0);
        tv
    }
}

#[cfg(test)]
mod scalar_tests {
    use super::*;

    /// [`scalar_pinv`] gives the general path's `S⁺` (`SvdSolver` at `1e-10`, again at
    /// `floor/σ` when that is larger, its min-norm solve of `e₁`) and its `false` below
    /// the floor, to the bit: signs, magnitudes from 1e-300 to 1e300, floors on both
    /// sides of `1e-10 σ` and up to just below `σ`, zeros.
    #[test]
    fn scalar_pinv_matches_the_svd_to_the_bit() {
        let general = |s: f64, floor: f64| -> (bool, u64) {
            let m = DenseMatrix::from_fn(1, 1, |_, _| s);
            let svd = SvdSolver::new(&m, 1e-10).unwrap();
            let smax = svd.singular_values()[0];
            if !(smax > floor) {
                return (false, 0.0f64.to_bits());
            }
            let svd = if floor > 1e-10 * smax {
                SvdSolver::new(&m, floor / smax).unwrap()
            } else {
                svd
            };
            let mut col = [0.0];
            svd.solve_min_norm(&[1.0], &mut col).unwrap();
            (true, col[0].to_bits())
        };
        let mut checked = 0;
        for e in (-300..=300).step_by(7) {
            for m in [1.0, 1.234_567_890_123, 3.999_999_999_9, 7.1e-3] {
                for sign in [1.0, -1.0] {
                    let s = sign * m * libm::pow(10.0, e as f64);
                    for floor in [
                        0.0,
                        1e-12 * s.abs(),
                        1e-10 * s.abs(),
                        0.5 * s.abs(),
                        s.abs(),
                    ] {
                        let mut pinv = Vec::new();
                        let got = scalar_pinv(s, floor, &mut pinv).unwrap();
                        assert_eq!(
                            (got, pinv[0].to_bits()),
                            general(s, floor),
                            "s {s:e}, floor {floor:e}"
                        );
                        checked += 1;
                    }
                }
            }
        }
        let mut pinv = Vec::new();
        assert!(!scalar_pinv(0.0, 0.0, &mut pinv).unwrap());
        assert_eq!(pinv, [0.0]);
        assert!(scalar_pinv(f64::NAN, 0.0, &mut pinv).is_err());
        assert!(checked > 1000, "{checked} cases");
    }
}

#[cfg(test)]
#[cfg(feature = "mjcf")]
mod tests {
    use super::*;
    use crate::MjcfScene;

    /// A hinge, a slide-then-hinge compound joint and a hinge with `ref`, two tendons
    /// and a nonlinear equality of each kind.
    const CHAIN: &str = r#"<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.001"><flag contact="disable"/></option>
  <worldbody>
    <body name="a">
      <joint name="ha" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05"/>
      <body name="b" pos="0 0 -0.5">
        <joint name="sb" type="slide" axis="1 0 0"/>
        <joint name="hb" type="hinge" axis="0 0.6 0.8"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04"/>
        <body name="c" pos="0 0 -0.4">
          <joint name="hc" type="hinge" axis="1 0 0" ref="0.2"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 -0.3" size="0.03"/>
        </body>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="t1"><joint joint="ha" coef="0.5"/><joint joint="sb" coef="1"/></fixed>
    <fixed name="t2"><joint joint="hb" coef="2"/><joint joint="hc" coef="-1"/></fixed>
  </tendon>
  <equality>
    <joint joint1="ha" joint2="hc" polycoef="0.1 -1 0.3 0.2 -0.1"/>
    <tendon tendon1="t1" tendon2="t2" polycoef="0 0.5 0.2"/>
  </equality>
</mujoco>"#;

    /// Two pendulums on parallel hinges, `q_a = −q_b` (`polycoef 0 -1`).
    const COUPLED: &str = r#"<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.001"><flag contact="disable"/></option>
  <worldbody>
    <body name="a"><joint name="ha" axis="0 1 0"/>
      <inertial pos="0 0 -0.5" mass="1" diaginertia="0.01 0.01 0.01"/></body>
    <body name="b" pos="0.3 0 0"><joint name="hb" axis="0 1 0"/>
      <inertial pos="0.1 0 -0.8" mass="2" diaginertia="0.02 0.03 0.02"/></body>
  </worldbody>
  <equality><joint joint1="ha" joint2="hb" polycoef="0 -1"/></equality>
  <keyframe><key name="start" qpos="0.5 -0.5" qvel="1 -1"/></keyframe>
</mujoco>"#;

    /// Two hinge arms over a floor, coupled by a fixed tendon held at zero
    /// (`q_a + q_b = 0`, MuJoCo's `equality/tendon`, a row over both arms): arm `a`'s
    /// ball swings onto the floor, arm `b`'s stays clear, so the contact holds `b`
    /// through the equality.
    #[cfg(feature = "contact")]
    const ARMS_ON_FLOOR: &str = r#"<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="a" pos="0 0 0.5"><joint name="ha" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.35" size="0.02" contype="0" conaffinity="0"/>
      <geom name="ball" type="sphere" pos="0 0 -0.45" size="0.1"/></body>
    <body name="b" pos="0.6 0 0.5"><joint name="hb" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" contype="0" conaffinity="0"/>
      <geom type="sphere" pos="0 0 -0.3" size="0.08" mass="2"/></body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="ha" coef="1"/><joint joint="hb" coef="1"/></fixed></tendon>
  <equality><tendon tendon1="t"/></equality>
  <keyframe><key name="start" qpos="0.6 -0.6" qvel="-1 1"/></keyframe>
</mujoco>"#;

    /// The active set takes the equality row as an always-active Schur row: with a
    /// contact in every step after the first impact, it solves those steps, holds the
    /// (linear) equality to round-off, matches one dense step from the same state, and
    /// its trajectory stays with the dense path's. The impact steps it leaves to the
    /// dense path are solved there at the world's friction tolerance (1e-6), so they
    /// match the strict dense step to that tolerance only: the one contact of this
    /// one-degree-of-freedom system has a rank-1 Delassus matrix and a unique exact
    /// solution (`constraint_contact`'s `rank_one_contact_keeps_exact_velocities`).
    #[cfg(feature = "contact")]
    #[test]
    fn active_set_holds_an_equality_with_contact() {
        use constraint_contact::lcp::{Coupling, RowSettings};
        let model = constraint_mjcf::load_str(ARMS_ON_FLOOR).expect("model");
        let mut w = MjcfScene::new(&model, Some("start")).expect("scene").world;
        w.unilateral.sparse = true;
        let dense = |w: &mut World| {
            w.unilateral.sparse = false;
            w.unilateral.solver = RowSettings {
                coupling: Coupling::Staggered { sweeps: 30 },
                friction_tolerance: 1e-13,
                friction_iterations: 3_000,
                tolerance: 1e-13,
                ..w.unilateral.solver
            };
        };
        let mut d = w.clone();
        dense(&mut d);
        let vel = Method::Velocity { beta: 1.0 };
        let (mut rows_steps, mut sparse_steps) = (0, 0);
        let (mut worst_c, mut worst_one, mut worst_traj, mut worst_nu): (f64, f64, f64, f64) =
            (0.0, 0.0, 0.0, 0.0);
        // One step against the strict dense step where `w` took the dense path itself.
        let mut worst_dense: f64 = 0.0;
        for _ in 0..600 {
            let mut one = w.clone();
            dense(&mut one);
            w.step(1e-3, vel).expect("step");
            one.step(1e-3, vel).expect("dense step");
            d.step(1e-3, vel).expect("dense step");
            let s = w.unilateral_stats();
            let by_dense = s.rows > 0 && !s.sparse;
            if s.rows > 0 {
                rows_steps += 1;
                if s.sparse {
                    sparse_steps += 1;
                    // ν of both paths (the dense one before its one-sided correction
                    // differs; compare the velocities instead) must be finite.
                    worst_nu = worst_nu.max(w.equality_impulses()[0].abs());
                }
            }
            worst_c = worst_c.max(w.max_equality_violation());
            let worst = if by_dense {
                &mut worst_dense
            } else {
                &mut worst_one
            };
            for (x, y) in w.bodies().iter().zip(one.bodies()) {
                *worst = worst
                    .max((x.omega - y.omega).abs().max_element())
                    .max((x.v - y.v).abs().max_element());
            }
            for j in 0..2 {
                let (qa, qb) = (w.joint_position(j).unwrap(), d.joint_position(j).unwrap());
                worst_traj = worst_traj.max((qa - qb).abs());
            }
        }
        println!(
            "{sparse_steps}/{rows_steps} steps with rows by the active set, |C| {worst_c:e}, \
             one step {worst_one:e} (dense steps {worst_dense:e}), trajectory {worst_traj:e}, \
             |nu| {worst_nu:e}"
        );
        // measured 567 of 571 (the impacts' first steps go to the dense path)
        assert!(rows_steps > 300, "contact steps {rows_steps}");
        assert!(
            sparse_steps + 10 >= rows_steps,
            "{sparse_steps}/{rows_steps}"
        );
        assert!(worst_nu.is_finite() && worst_nu > 0.0);
        // measured 0 (linear rows: exact at the velocity level)
        assert!(worst_c < 1e-12, "|C| {worst_c:e}");
        // measured 2.3e-15 m/s, rad/s
        assert!(worst_one < 1e-9, "one step vs dense {worst_one:e}");
        // measured 4.8e-6 m/s (the impact step: converged to residual 9.8e-7 ≤ 1e-6, row
        // velocities 2.4e-6 from the exact ones)
        assert!(
            worst_dense < 1e-5,
            "dense step vs strict dense {worst_dense:e}"
        );
        // measured 4.8e-9 rad (that step's 4.8e-6 over 1 ms)
        assert!(worst_traj < 1e-8, "trajectory vs dense {worst_traj:e}");
    }

    fn lcg(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    fn poly(p: &[f64; 5], x: f64) -> f64 {
        p[0] + x * (p[1] + x * (p[2] + x * (p[3] + x * p[4])))
    }

    #[test]
    fn equality_jacobian_matches_finite_differences() {
        let model = constraint_mjcf::load_str(CHAIN).expect("model");
        let mut scene = MjcfScene::new(&model, None).expect("scene");
        assert_eq!(scene.world.equalities().len(), 2);
        let mut seed = 7u64;
        let (mut worst_fd, mut worst_value, mut worst_tendon): (f64, f64, f64) = (0.0, 0.0, 0.0);
        let eps = 1e-6;
        for _ in 0..50 {
            let q: Vec<f64> = (0..4).map(|_| lcg(&mut seed)).collect();
            let v: Vec<f64> = (0..4).map(|_| 2.0 * lcg(&mut seed)).collect();
            let mut at = |s: f64, vel: &[f64]| {
                let qs: Vec<f64> = q.iter().zip(&v).map(|(a, b)| a + s * b).collect();
                scene.set_generalized(&model, &qs, vel).expect("state");
                let w = &scene.world;
                let e: Vec<(f64, f64)> = (0..2).map(|i| w.equality_residual(i).unwrap()).collect();
                let t: Vec<(f64, f64)> = (0..2).map(|i| w.tendon_length(i).unwrap()).collect();
                (e, t)
            };
            let (e0, t0) = at(0.0, &v);
            let (ep, tp) = at(eps, &[]);
            let (em, tm) = at(-eps, &[]);
            for i in 0..2 {
                let fd = (ep[i].0 - em[i].0) / (2.0 * eps);
                worst_fd = worst_fd.max((fd - e0[i].1).abs() / (1.0 + fd.abs()));
                let fdt = (tp[i].0 - tm[i].0) / (2.0 * eps);
                worst_tendon = worst_tendon.max((fdt - t0[i].1).abs() / (1.0 + fdt.abs()));
            }
            // Values in MuJoCo's coordinates (qpos; qpos0 = ref = 0.2 for hc):
            // ha − 0 = P(hc − 0.2); L1 = P2(L2) with L = Σ c (q − q0).
            let p1 = [0.1, -1.0, 0.3, 0.2, -0.1];
            let c1 = q[0] - poly(&p1, q[3] - 0.2);
            let (l1, l2) = (0.5 * q[0] + q[1], 2.0 * q[2] - (q[3] - 0.2));
            let c2 = l1 - poly(&[0.0, 0.5, 0.2, 0.0, 0.0], l2);
            worst_value = worst_value
                .max((c1 - e0[0].0).abs())
                .max((c2 - e0[1].0).abs());
        }
        // measured 1.9e-10 (central differences at ε = 1e-6)
        assert!(worst_fd < 1e-8, "equality Jacobian vs FD: {worst_fd:e}");
        // measured 3.7e-10
        assert!(worst_tendon < 1e-8, "tendon rate vs FD: {worst_tendon:e}");
        // measured 8.9e-16
        assert!(
            worst_value < 1e-12,
            "value vs MuJoCo's formula: {worst_value:e}"
        );
        println!("FD {worst_fd:e}, tendon {worst_tendon:e}, value {worst_value:e}");
    }

    fn coupled() -> (constraint_mjcf::Model, World) {
        let model = constraint_mjcf::load_str(COUPLED).expect("model");
        let scene = MjcfScene::new(&model, Some("start")).expect("scene");
        (model, scene.world)
    }

    /// Max `|C|` over steps 10 … 1000 of `xml` (from its `start` keyframe, else
    /// `qpos0`) and the stats of the last step.
    fn run(xml: &str, method: Method) -> (f64, StepStats, World) {
        let model = constraint_mjcf::load_str(xml).expect("model");
        let key = model.keyframes.first().map(|k| k.name.clone());
        let mut w = MjcfScene::new(&model, key.as_deref()).expect("scene").world;
        let mut worst: f64 = 0.0;
        let mut stats = StepStats::default();
        let mut fallbacks = 0;
        for i in 0..1000 {
            stats = w.step(1e-3, method).expect("step");
            fallbacks += stats.fallbacks;
            if i >= 10 {
                worst = worst.max(w.max_equality_violation());
            }
        }
        // Every RATTLE step converged (no step redone at the velocity level).
        assert_eq!(fallbacks, 0, "{method:?}");
        (worst, stats, w)
    }

    #[test]
    fn equalities_hold_for_every_method() {
        let projected = Method::VelocityProjected {
            beta: 1.0,
            tolerance: 1e-10,
            max_iterations: 20,
            correct_velocity: false,
        };
        let rattle4 = Method::Rattle4 {
            tolerance: 1e-12,
            max_iterations: 30,
        };
        let acc = Method::Acceleration { kx: 0.0, kv: 0.0 };
        let vel = Method::Velocity { beta: 1.0 };
        // Linear rows (parallel hinges on the world): exact at the velocity level.
        let (c, s, w) = run(COUPLED, vel);
        assert_eq!(s.equality_fallbacks, 0);
        // measured 1.1e-16 rad
        assert!(c < 1e-12, "coupled, velocity level |C| {c:e}");
        let qa = w.joint_position(0).unwrap();
        let qb = w.joint_position(1).unwrap();
        assert!((qa - 0.5).abs() > 0.1, "qa {qa}");
        assert!((qa + qb).abs() < 1e-12, "qa {qa} qb {qb}");
        // Nonlinear rows over a compound joint, violated at qpos0 (C₁ = −0.1): the
        // velocity level leaves the curvature residue, projection and the methods
        // that fall back to it the tolerance.
        let mut table = Vec::new();
        for (m, fallback, gate) in [
            (vel, 0, 1e-4),
            (acc, 1, 1e-4),
            (projected, 0, 1e-10),
            (Method::default(), 0, 1e-9),
            (rattle4, 0, 1e-9),
        ] {
            let (c, s, _) = run(CHAIN, m);
            assert_eq!(s.equality_fallbacks, fallback, "{m:?}");
            assert_eq!(s.unilateral_fallbacks, 0, "{m:?}");
            table.push((m, c));
            // measured: velocity 2.2e-6, acceleration 2.2e-6 (the same velocity-level
            // step), projected 1.4e-11, RATTLE 9.9e-13, RATTLE4 9.9e-13 (max over
            // steps 10 … 1000; the projections stop at their tolerances, RATTLE's
            // SHAKE within 1e3 × its own, as its convergence test)
            assert!(c <= gate, "{m:?}: |C| {c:e} > {gate:e}");
        }
        for (m, c) in table {
            println!("chain |C| {c:.2e}  {m:?}");
        }
    }

    /// RATTLE with equality rows stays symplectic: over 10 s of the undamped coupled
    /// pendulums the energy error stays bounded, far below the velocity level's drift.
    #[test]
    fn rattle_keeps_the_energy_of_coupled_pendulums() {
        let drift = |m: Method| {
            let (_, mut w) = coupled();
            let e0 = {
                let (k, p) = w.energy();
                k + p
            };
            let mut worst: f64 = 0.0;
            for _ in 0..10_000 {
                w.step(1e-3, m).expect("step");
                let (k, p) = w.energy();
                worst = worst.max((k + p - e0).abs());
            }
            (worst, w.max_equality_violation())
        };
        let (rattle, c) = drift(Method::default());
        let (vel, _) = drift(Method::Velocity { beta: 1.0 });
        println!("energy error over 10 s: RATTLE {rattle:e} J (|C| {c:e}), velocity {vel:e} J");
        // measured: RATTLE 1.3e-5 J, velocity level 1.3e-2 J
        assert!(rattle < 1e-4, "RATTLE energy error {rattle:e}");
        assert!(rattle < 1e-2 * vel, "RATTLE {rattle:e} vs velocity {vel:e}");
        assert!(c <= 1e-9, "|C| {c:e}");
    }

    /// Damped joints: RATTLE's damping flow (Strang-split, `rattle.rs`) keeps
    /// `E v = 0`, so the rows hold through it, for RATTLE and RATTLE4.
    #[test]
    fn damped_coupled_pendulums_hold_under_rattle() {
        let xml = COUPLED.replace(
            r#"<joint name="ha" axis="0 1 0"/>"#,
            r#"<joint name="ha" axis="0 1 0" damping="0.3" armature="0.01"/>"#,
        );
        for m in [
            Method::default(),
            Method::Rattle4 {
                tolerance: 1e-12,
                max_iterations: 30,
            },
        ] {
            let (c, s, w) = run(&xml, m);
            assert_eq!(s.equality_fallbacks, 0);
            let (k, _) = w.energy();
            // measured 0 rad (linear rows), the damping took energy out
            assert!(c <= 1e-9, "{m:?}: |C| {c:e}");
            let qa = w.joint_position(0).unwrap();
            let qb = w.joint_position(1).unwrap();
            assert!((qa + qb).abs() <= 1e-9, "{m:?}: qa {qa} qb {qb}");
            println!("damped {m:?}: |C| {c:e}, kinetic {k:e}");
            // The nonlinear rows over the compound joint, damped.
            let chain = CHAIN.replace(
                r#"<joint name="ha" type="hinge" axis="0 1 0"/>"#,
                r#"<joint name="ha" type="hinge" axis="0 1 0" damping="0.2"/>"#,
            );
            assert!(chain.contains("damping"));
            let (c, _, _) = run(&chain, m);
            println!("damped chain {m:?}: |C| {c:e}");
            // measured 9.9e-13 (RATTLE and RATTLE4)
            assert!(c <= 1e-9, "{m:?}: chain |C| {c:e}");
        }
    }

    #[test]
    fn projection_drives_a_violated_equality_to_zero() {
        let (model, mut w) = coupled();
        let mut scene = MjcfScene::new(&model, None).expect("scene");
        // qpos far off the coupling: q_a = 0.5, q_b = 0.2, C = 0.7.
        scene
            .set_generalized(&model, &[0.5, 0.2], &[])
            .expect("state");
        w.clone_from(&scene.world);
        assert!((w.max_equality_violation() - 0.7).abs() < 1e-12);
        let m = Method::VelocityProjected {
            beta: 0.2,
            tolerance: 1e-10,
            max_iterations: 20,
            correct_velocity: false,
        };
        let s = w.step(1e-3, m).expect("step");
        let c = w.max_equality_violation();
        // measured 1.1e-16 after 2 iterations (the row is linear in the angles)
        assert!(
            c <= 1e-10,
            "|C| {c:e} after {} iterations",
            s.projection_iterations
        );
        assert!(s.projection_iterations >= 1);
    }

    /// A pendulum whose tendon `L = q` has a range behaves exactly as the same range
    /// as a joint limit (the rows are the same), and the row is reported.
    #[test]
    fn tendon_range_acts_as_the_joint_limit() {
        let xml = |tendon: bool| {
            let (jr, tr) = if tendon {
                (
                    "",
                    r#"<tendon><fixed name="t" range="-0.3 0.3"><joint joint="h" coef="1"/></fixed></tendon>"#,
                )
            } else {
                (r#"range="-0.3 0.3""#, "")
            };
            format!(
                r#"<mujoco><compiler angle="radian"/><option timestep="0.001"><flag contact="disable"/></option>
  <worldbody><body><joint name="h" axis="0 1 0" {jr}/>
    <inertial pos="0.5 0 0" mass="1" diaginertia="0.01 0.01 0.01"/></body></worldbody>
  {tr}<keyframe><key name="start" qvel="3"/></keyframe></mujoco>"#
            )
        };
        let load = |t| {
            let model = constraint_mjcf::load_str(&xml(t)).expect("model");
            MjcfScene::new(&model, Some("start")).expect("scene").world
        };
        let (mut wt, mut wj) = (load(true), load(false));
        assert_eq!(wt.tendon_ranges(), &[Some([-0.3, 0.3])]);
        let m = Method::Velocity { beta: 1.0 };
        let (mut diff, mut high, mut pushed): (f64, f64, f64) = (0.0, f64::MIN, 0.0);
        for _ in 0..1000 {
            wt.step(1e-3, m).expect("tendon step");
            wj.step(1e-3, m).expect("limit step");
            let qt = wt.joint_position(0).unwrap();
            diff = diff.max((qt - wj.joint_position(0).unwrap()).abs());
            high = high.max(wt.tendon_length(0).unwrap().0);
            for (src, z) in wt.row_impulses() {
                if let RowSource::TendonLimit { tendon: 0, upper } = src {
                    pushed = pushed.max(if upper { z } else { 0.0 });
                }
            }
        }
        // measured 0 (the same rows, the same solve)
        assert!(diff <= 1e-12, "tendon range vs joint limit: {diff:e}");
        // measured 0.3 + 1.2e-16: the speculative row stops it at the bound
        assert!(high <= 0.3 + 1e-9 && high > 0.29, "highest L {high}");
        // measured 0.16 N·m·s (the impact)
        assert!(pushed > 0.1, "upper-limit impulse {pushed}");
    }

    /// A one-sided row and an equality in the same solve: pendulum b's hinge limited,
    /// pendulum a coupled to it, so the limit's impulse must reach a through the
    /// equality (the column correction `y ← y − Y_E S⁺ E y`).
    #[test]
    fn limits_act_through_the_equalities() {
        let xml = COUPLED.replace(
            r#"<joint name="hb" axis="0 1 0"/>"#,
            r#"<joint name="hb" axis="0 1 0" range="-0.7 0.2"/>"#,
        );
        let model = constraint_mjcf::load_str(&xml).expect("model");
        let mut w = MjcfScene::new(&model, Some("start")).expect("scene").world;
        let m = Method::Velocity { beta: 1.0 };
        let (mut c, mut qb_max, mut qa_min, mut hits): (f64, f64, f64, usize) = (0.0, -1.0, 1.0, 0);
        for _ in 0..2000 {
            w.step(1e-3, m).expect("step");
            c = c.max(w.max_equality_violation());
            qb_max = qb_max.max(w.joint_position(1).unwrap());
            qa_min = qa_min.min(w.joint_position(0).unwrap());
            hits += w
                .row_impulses()
                .filter(|(s, z)| matches!(s, RowSource::Limit { joint: 1, .. }) && *z > 0.0)
                .count();
        }
        assert!(hits > 0, "the limit was never hit");
        // measured 0 rad while the limit holds hb at 0.2 (2 steps with an impulse)
        assert!(c < 1e-12, "|C| {c:e}");
        // measured 0.2 + 4e-17 (speculative limit row), so qa ≥ −0.2
        assert!(qb_max <= 0.2 + 1e-9, "qb max {qb_max}");
        assert!(qa_min >= -0.2 - 1e-9, "qa min {qa_min}");
        println!(
            "limit through equality: hits {hits}, |C| {c:e}, qb max {qb_max}, qa min {qa_min}"
        );
    }

    /// The same equality twice: a redundant row pair (singular `S`), solved for the
    /// minimum-norm multipliers, which split the impulse evenly.
    #[test]
    fn a_repeated_equality_is_redundant_not_singular() {
        let (_, mut w) = coupled();
        let e = w.equalities()[0].clone();
        w.add_equality(e).expect("repeat");
        let (mut c, mut split, mut big): (f64, f64, f64) = (0.0, 0.0, 0.0);
        for _ in 0..500 {
            w.step(1e-3, Method::Velocity { beta: 1.0 }).expect("step");
            c = c.max(w.max_equality_violation());
            let nu = w.equality_impulses();
            split = split.max((nu[0] - nu[1]).abs());
            big = big.max(nu[0].abs());
        }
        println!("repeated equality: |C| {c:e}, split {split:e}, largest half {big:e}");
        // The rows carry the coupling (measured 2.8e-4 N·m·s per half and step).
        assert!(big > 1e-4, "multipliers {big:e}");
        assert!(w.coordinate_sum(&[(9, 0, 1.0), (0, 5, 1.0)]) == (0.0, 0.0));
        // measured 1.4e-17
        assert!(c < 1e-12, "|C| {c:e}");
        // measured 0 (min-norm: equal halves)
        assert!(split < 1e-12, "multipliers differ by {split:e}");
    }

    #[test]
    fn bad_equalities_and_ranges_are_typed_errors() {
        let (_, mut w) = coupled();
        let eq = |first: Terms, second: Terms, p0: f64| Equality {
            first,
            second,
            polycoef: [p0, 1.0, 0.0, 0.0, 0.0],
        };
        let invalid = |r: Result<usize, ArticulatedError>| {
            matches!(
                r,
                Err(ArticulatedError::InvalidParameter {
                    name: "equality",
                    ..
                })
            )
        };
        assert!(invalid(w.add_equality(eq(vec![], vec![(1, 0, 1.0)], 0.0))));
        assert!(invalid(w.add_equality(eq(vec![(9, 0, 1.0)], vec![], 0.0))));
        assert!(invalid(w.add_equality(eq(vec![(0, 1, 1.0)], vec![], 0.0))));
        assert!(invalid(w.add_equality(eq(
            vec![(0, 0, f64::NAN)],
            vec![],
            0.0
        ))));
        assert!(invalid(w.add_equality(eq(
            vec![(0, 0, 1.0)],
            vec![],
            f64::NAN
        ))));
        assert!(invalid(w.add_equality(eq(
            vec![(0, 0, 1.0)],
            vec![(0, 0, 1.0)],
            0.0
        ))));
        assert_eq!(w.equalities().len(), 1);
        let range = |w: &mut World, t, lo, hi| {
            matches!(
                w.set_tendon_range(t, lo, hi),
                Err(ArticulatedError::InvalidParameter {
                    name: "tendon range",
                    ..
                })
            )
        };
        assert!(range(&mut w, 0, -1.0, 1.0), "unknown tendon");
        w.add_tendon(Tendon {
            terms: vec![],
            stiffness: 0.0,
            damping: 0.0,
            rest_length: 0.0,
        })
        .expect("empty tendon");
        assert!(range(&mut w, 0, -1.0, 1.0), "tendon with no joints");
        w.add_tendon(Tendon {
            terms: vec![(0, 0, 1.0)],
            stiffness: 0.0,
            damping: 0.0,
            rest_length: 0.0,
        })
        .expect("tendon");
        assert!(range(&mut w, 1, f64::NAN, 1.0));
        assert!(range(&mut w, 1, 1.0, -1.0));
        assert!(range(&mut w, 1, f64::INFINITY, f64::INFINITY));
        assert!(w.tendon_ranges().iter().all(|r| r.is_none()));
        w.set_tendon_range(1, -1.0, f64::INFINITY)
            .expect("one-sided");
        // An equality on a spherical joint (no coordinate).
        let mut b = crate::scenes::ball_chain(2, 1.0).expect("chain");
        assert!(invalid(b.add_equality(eq(vec![(0, 0, 1.0)], vec![], 0.0))));
    }
}
