//! One solve for every kind of one-sided and boxed row a step produces: contact normals
//! and joint limits (`z ≥ 0`, `w ≥ 0`, `z w = 0`), Coulomb friction (`|z_t| ≤ μ z_n`)
//! and fixed boxes (joint dry friction, `|z| ≤ f h`), on a dense Delassus matrix
//! `A = J K⁻¹ Jᵀ` (Otaduy 2010, "Contacto mediante restricciones"; `K⁻¹` is `M⁻¹` for
//! free bodies or the joint-constrained inverse of a tree).
//!
//! Lemke and the Fischer–Burmeister Newton method take standard LCPs only, so the rows
//! that are not one-sided go by Kaufman et al.'s staggered projections (2008): the
//! standard LCP of the one-sided rows with the other impulses fixed, then the boxed
//! problem of the other rows with the one-sided impulses fixed, alternated; projected
//! Gauss–Seidel can also take the whole boxed problem in one go.

use alloc::vec;
use alloc::vec::Vec;

use super::pgs::{pgs_free_rows, PgsEnd, PgsScratch};
use super::{
    fischer_newton, lemke, pgs, Lcp, LcpError, LcpSolution, LemkeSettings, NewtonSettings,
    PgsSettings, SparseRows,
};

/// The bound of one row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowBound {
    /// One-sided: `z ≥ 0`, `w ≥ 0`, `z w = 0` (contact normal, joint limit).
    Unilateral,
    /// Coulomb friction tied to the one-sided row `normal`: `|z| ≤ mu z_normal`.
    Friction {
        /// Index of the normal row.
        normal: usize,
        /// Friction coefficient `μ ≥ 0`.
        mu: f64,
    },
    /// A fixed box `lo ≤ z ≤ hi` (joint dry friction `±f h`).
    Boxed {
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
}

impl RowBound {
    /// The interval `[lo, hi]` the row's impulse must lie in at `z`: `[0, ∞)` one-sided,
    /// `[−μ z_normal, μ z_normal]` for friction, `[lo, hi]` for a box. `z` must hold the
    /// normal row of a friction row (the solvers check it).
    #[inline]
    pub fn interval(self, z: &[f64]) -> (f64, f64) {
        match self {
            RowBound::Unilateral => (0.0, f64::INFINITY),
            RowBound::Friction { normal, mu } => (-mu * z[normal], mu * z[normal]),
            RowBound::Boxed { lo, hi } => (lo, hi),
        }
    }
}

/// The method for the one-sided part (and for the whole problem with `Boxed`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowMethod {
    /// Projected Gauss–Seidel.
    Pgs,
    /// Lemke's pivoting.
    Lemke,
    /// Fischer–Burmeister Newton.
    Newton,
}

/// How the non-one-sided rows couple with the one-sided ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coupling {
    /// One boxed LCP with the friction bounds moving with the normal impulses (PGS only;
    /// when PGS runs out of sweeps, two staggered alternations answer instead,
    /// [`RowStats::boxed_fallback`]).
    Boxed,
    /// Staggered projections, `sweeps` normal/friction alternations.
    Staggered {
        /// Alternations.
        sweeps: usize,
    },
}

/// Stall window of the staggered friction PGS ([`PgsSettings::stall_sweeps`]): a
/// friction solve whose residual has not halved in this many sweeps stops there.
pub const FRICTION_STALL_SWEEPS: usize = 100;

/// Stall window of the residual-driven staggered alternations
/// ([`RowSettings::max_sweeps`]): when the best residual of the whole problem has not
/// halved in this many alternations, they end there (with the last one-sided solve) as
/// at the cap. On humanoid_CMU lying on the floor (141 rows, Delassus rank ≤ 62) the
/// alternations that do not converge settle within about ten into a two-cycle (e.g.
/// residual 7.8e-5, 6.4e-5, 7.8e-5, … to the 50th), while those that converge gain a
/// factor 2 every 2 to 4 alternations. (5 instead, World::step instructions: humanoid_CMU
/// controlled 0.5 s −0.7 % but its unconverged steps 26 → 34; dm humanoid passive 2 s
/// −1.2 %, 18 → 15. Not taken. Alternations that stall do not repeat their iterate bit
/// for bit, one or two alternations back, often enough to skip the repeats: a replay of
/// such cycles saved 0.04M of CMU controlled's 658M.)
pub const ALTERNATION_STALL_SWEEPS: usize = 8;

/// Relaxation `ω` of the one-sided impulses once an alternation's residual has risen
/// over the previous one's, or the alternations have stalled with their best residual
/// above [`RELAX_STALLED_ABOVE`] times the tolerance (residual-driven mode): each
/// one-sided solve's answer `z_n*` then moves the impulses only to
/// `z_n + ω (z_n* − z_n)` (the fixed points are the same), with a new stall window
/// ([`ALTERNATION_STALL_SWEEPS`]). A sliding contact whose friction lifts its own
/// normal through the joints (`A_nt` large against `A_nn`) makes the plain alternation
/// a two-cycle: no friction, a large normal impulse; that impulse's friction, no normal
/// impulse (the gymnasium humanoid under control, μ = 1: residual 0.087, 0.100, 0.087,
/// …), where the relaxed one converges (ω = 0.5: 1e-6 in 20 alternations on that step;
/// ω = 0.7 left humanoid_CMU lying on the floor 119 of 139 dense steps unconverged
/// against 11). Alternations that converge slowly but steadily (the gymnasium humanoid
/// lying on the floor, stalling around 3e-6) are left unrelaxed: relaxing every stall
/// there cost 8 % more instructions and converged no more steps
/// (`examples/dense_stats.rs`).
pub const ALTERNATION_RELAXATION: f64 = 0.5;

/// Unrelaxed alternations that stall ([`ALTERNATION_STALL_SWEEPS`]) with their best
/// residual above this many times `friction_tolerance` go on relaxed
/// ([`ALTERNATION_RELAXATION`]) with a new window instead of ending.
/// (10 instead: World::step instructions over 2 s, humanoid_CMU −0.2 %, gymnasium
/// humanoid +0.4 %, no gain. Ending the alternations instead of relaxing them where the
/// residual rises with the best one within 10 times the tolerance — the dm humanoid
/// lying on the floor reaches its best, about 5e-6, at the second alternation and creeps
/// up to 8e-6 until the stall window ends it at the eleventh — saved 2.6 % on the dm
/// humanoid perturbed, but humanoid_CMU passive took 26 % more and its unconverged
/// steps went 16 → 169 of 1000: the truncated answers warm-start the next steps worse.)
pub const RELAX_STALLED_ABOVE: f64 = 100.0;

/// Settings of [`solve_rows`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowSettings {
    /// The requested method (the others are tried in turn when it fails).
    pub method: RowMethod,
    /// The coupling of friction and boxes with the one-sided rows.
    pub coupling: Coupling,
    /// Residual tolerance of the one-sided solve.
    pub tolerance: f64,
    /// Iteration cap of a PGS solve of the one-sided or the whole boxed problem.
    pub pgs_iterations: usize,
    /// Residual tolerance of the friction PGS.
    pub friction_tolerance: f64,
    /// Sweeps of the friction PGS (and of its last-budget fallback).
    pub friction_iterations: usize,
    /// Staggered coupling only: after its `sweeps`, keep alternating while the whole
    /// problem's residual ([`row_residual`]) exceeds `friction_tolerance`, up to this
    /// many sweeps in all, and if it still does, end with one more one-sided solve so
    /// that contacts and limits hold exactly against the final friction (which is then
    /// clamped into its cone). `0` (the default): exactly `sweeps` alternations.
    pub max_sweeps: usize,
}

impl Default for RowSettings {
    fn default() -> Self {
        Self {
            method: RowMethod::Newton,
            coupling: Coupling::Staggered { sweeps: 2 },
            tolerance: 1e-10,
            pgs_iterations: 10_000,
            friction_tolerance: 1e-8,
            friction_iterations: 10_000,
            max_sweeps: 0,
        }
    }
}

/// What [`solve_rows`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RowStats {
    /// Iterations over all solves (sweeps, pivots, Newton steps).
    pub iterations: usize,
    /// The method whose one-sided answer was accepted last (`None`: no one-sided rows
    /// or the boxed PGS).
    pub accepted: Option<RowMethod>,
    /// The whole problem went to one boxed PGS (and it answered).
    pub boxed_pgs: bool,
    /// The boxed PGS ([`Coupling::Boxed`]) ran out of sweeps and the staggered solve
    /// (two alternations, the one-sided rows by Newton, Lemke, then PGS) answered
    /// instead: with a heavy body on a light one PGS converges at a rate near
    /// `1 − 1/κ`, far too slowly for any sweep budget.
    pub boxed_fallback: bool,
    /// A friction PGS ran.
    pub friction_pgs: bool,
    /// A friction PGS ran out of sweeps and its last budget of sweeps was kept. In the
    /// residual-driven mode ([`RowSettings::max_sweeps`]) the last sweep goes unchecked
    /// unless it is a residual-check sweep (every 4th): a friction solve that gets there
    /// counts here even where that sweep met the tolerance (the iterate is the same;
    /// the whole problem's residual decides).
    pub friction_budget: bool,
    /// Normal/friction alternations of the staggered coupling.
    pub sweeps: usize,
    /// One-sided solves answered by the active-set guess ([`RowMethod::Newton`] in the
    /// residual-driven mode, [`RowSettings::max_sweeps`], only):
    /// the linear solve on the rows the warm start holds active passed the Newton
    /// method's residual check, so no Newton step ran.
    pub active_set: usize,
    /// Residual-driven mode only ([`RowSettings::max_sweeps`]): the alternations ended
    /// without the whole problem's residual reaching `friction_tolerance` (at
    /// `max_sweeps`, or stalled, [`RowStats::stalled`]); the answer is the last
    /// one-sided solve against the last friction, clamped into its cones, and its
    /// residual ([`row_residual`]) may be far above the tolerance. Not the alternation
    /// iterate of least residual: with a rank-deficient `A` (dependent rows) many
    /// impulses give the same velocities, and the residual does not order answers by
    /// their velocities' error (one contact of a one-degree-of-freedom system: the final
    /// one-sided solve's velocities exact at residual 0.45, the least-residual iterate's
    /// 0.21 off at residual 0.088, without relaxation;
    /// `rank_one_contact_keeps_exact_velocities`). The final one-sided solve from the
    /// least-residual iterate instead of the last did not pay either (humanoid_CMU
    /// +1.4 % instructions over 2 s; its passive case's unconverged steps 27 → 36 of 2500).
    pub capped: bool,
    /// The alternations ended by the stall window ([`ALTERNATION_STALL_SWEEPS`]) before
    /// `max_sweeps` (then [`RowStats::capped`] too).
    pub stalled: bool,
    /// An alternation's residual rose over the previous one's and the alternations went
    /// on relaxed ([`ALTERNATION_RELAXATION`]).
    pub relaxed: bool,
}

/// The residual of a solution of [`solve_rows`]'s problem: the largest
/// `|z_i − P_i(z_i − w_i)|` over the rows, `w = A z + q`, `P_i` the projection on row
/// `i`'s bounds (`[0, ∞)`, `[−μ z_n, μ z_n]`, `[lo, hi]`; zero exactly at a solution),
/// relative to `max(1, max |q|)`.
///
/// # Errors
/// The shapes [`solve_rows`] checks: `a` not `n × n`, `bounds` or `z` not of length
/// `n = q.len()` ([`LcpError::DimensionMismatch`]), a friction row whose normal is not a
/// unilateral row ([`LcpError::BadSettings`]); a residual that is not finite
/// ([`LcpError::NonFinite`] naming the first non-finite entry of `a`, `q` or `z`, or
/// `"residual"` when the entries are finite and a product overflowed).
pub fn row_residual(a: &[f64], q: &[f64], bounds: &[RowBound], z: &[f64]) -> Result<f64, LcpError> {
    let m = q.len();
    check_square(a, m)?;
    check_rows(m, bounds, z.len())?;
    let r = dense_residual(a, q, bounds, z);
    if r.is_finite() {
        return Ok(r);
    }
    let first = [("a", a), ("q", q), ("z", z)]
        .into_iter()
        .find_map(|(what, v)| v.iter().position(|x| !x.is_finite()).map(|i| (what, i)));
    let (what, index) = first.unwrap_or(("residual", 0));
    Err(LcpError::NonFinite { what, index })
}

/// [`row_residual`] on checked shapes.
fn dense_residual(a: &[f64], q: &[f64], bounds: &[RowBound], z: &[f64]) -> f64 {
    let m = q.len();
    let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
    let mut worst: f64 = 0.0;
    for i in 0..m {
        let (lo, hi) = bounds[i].interval(z);
        if lo == 0.0 && hi == 0.0 {
            // Pinned at zero: the term is `|z_i|` whatever `w_i` (`sparse_residual`).
            worst = worst.max(z[i].abs());
            continue;
        }
        let w: f64 = q[i] + (0..m).map(|k| a[i * m + k] * z[k]).sum::<f64>();
        let p = (z[i] - w).min(hi).max(lo);
        worst = worst.max((z[i] - p).abs());
    }
    worst / scale
}

/// A dense row-major `A` must be `n × n`.
fn check_square(a: &[f64], n: usize) -> Result<(), LcpError> {
    if a.len() == n * n {
        Ok(())
    } else {
        Err(LcpError::DimensionMismatch {
            what: "a",
            expected: n * n,
            found: a.len(),
        })
    }
}

/// The shapes every row solve needs: `bounds` and `z` (of length `z_len`) of length
/// `n`, and each friction row's normal a unilateral row of the problem (found by the
/// bad-input sweep: an index out of range, or a friction row as the normal, panicked or
/// chained bounds).
fn check_rows(n: usize, bounds: &[RowBound], z_len: usize) -> Result<(), LcpError> {
    for (what, len) in [("bounds", bounds.len()), ("z", z_len)] {
        if len != n {
            return Err(LcpError::DimensionMismatch {
                what,
                expected: n,
                found: len,
            });
        }
    }
    let normals_ok = bounds.iter().all(|b| match *b {
        RowBound::Friction { normal, .. } => {
            matches!(bounds.get(normal), Some(RowBound::Unilateral))
        }
        _ => true,
    });
    if normals_ok {
        Ok(())
    } else {
        Err(LcpError::BadSettings(
            "a friction row's normal must be a unilateral row of the problem",
        ))
    }
}

/// [`row_residual`] with `A` as sparse rows (the same bits: the products run over
/// the non-zeros in ascending column order).
fn sparse_residual(a: &SparseRows, q: &[f64], bounds: &[RowBound], z: &[f64]) -> f64 {
    let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
    let mut worst: f64 = 0.0;
    for (i, &qi) in q.iter().enumerate() {
        let (lo, hi) = bounds[i].interval(z);
        if lo == 0.0 && hi == 0.0 {
            // A row pinned at zero (the friction of a contact without normal impulse):
            // `mid(lo, z_i − w_i, hi)` is a zero whatever `w_i` (`min`/`max` pass a NaN
            // over), so its term is `|z_i|` without `w_i`'s product.
            worst = worst.max(z[i].abs());
            continue;
        }
        let (cols, vals) = a.row(i);
        // A full row (columns 0, 1, …, n−1) is the dense row: contiguous, no gather.
        let dot: f64 = if cols.len() == z.len() {
            vals.iter().zip(z).map(|(v, x)| v * x).sum()
        } else {
            cols.iter().zip(vals).map(|(&k, v)| v * z[k]).sum()
        };
        let w = qi + dot;
        let p = (z[i] - w).min(hi).max(lo);
        worst = worst.max((z[i] - p).abs());
    }
    worst / scale
}

/// Solves `w = A z + q` with the row bounds `bounds` (`A` dense row-major `n × n`),
/// starting from `z` (warm start; overwritten with the answer). Every accepted answer
/// passed its solver's residual check; a failure of every one-sided solver is the last
/// error.
pub fn solve_rows(
    a: &[f64],
    q: &[f64],
    bounds: &[RowBound],
    settings: &RowSettings,
    z: &mut [f64],
) -> Result<RowStats, LcpError> {
    solve_rows_with(&mut RowBuffers::default(), a, q, bounds, settings, z)
}

/// [`solve_rows`] with `A` as sparse rows (every non-zero entry listed; a Delassus
/// matrix has non-zeros only between rows that share a body). The same answer, bit for
/// bit: every product `A z` runs over the listed entries in ascending column order, as
/// the dense sums do over all (the others add `±0`), and the solvers see the same dense
/// blocks.
pub fn solve_rows_sparse(
    a: &SparseRows,
    q: &[f64],
    bounds: &[RowBound],
    settings: &RowSettings,
    z: &mut [f64],
) -> Result<RowStats, LcpError> {
    let n = q.len();
    if n == 0 {
        return Ok(RowStats::default());
    }
    check_rows(n, bounds, z.len())?;
    if !a.is_valid(n) {
        return Err(LcpError::BadSettings(
            "sparse rows of A inconsistent with q",
        ));
    }
    solve_rows_in(&mut RowScratch::default(), a, q, bounds, settings, z, false)
}

/// Buffers of [`solve_rows_with`], kept by a caller that solves a dense row problem
/// every step (the articulated world's dense Delassus path): `A`'s sparse rows and the
/// staggered solve's blocks, couplings and vectors, refilled in place (no allocation
/// once they have grown); a call whose `A` has the last call's non-zero pattern and
/// row classes refills the blocks' values only.
#[derive(Clone, Debug, Default)]
pub struct RowBuffers {
    /// `A`'s non-zero entries.
    sparse: SparseRows,
    /// The staggered solve's buffers.
    rows: RowScratch,
}

/// [`solve_rows`] in the caller's kept buffers: the same checks, errors and answer,
/// bit for bit, without `solve_rows`'s fresh sparse rows and scratch per call.
pub fn solve_rows_with(
    buffers: &mut RowBuffers,
    a: &[f64],
    q: &[f64],
    bounds: &[RowBound],
    settings: &RowSettings,
    z: &mut [f64],
) -> Result<RowStats, LcpError> {
    let n = q.len();
    check_square(a, n)?;
    if n == 0 {
        return Ok(RowStats::default());
    }
    check_rows(n, bounds, z.len())?;
    let RowBuffers { sparse, rows } = buffers;
    // `assign_dense` builds consistent rows (`solve_rows_in`'s contract).
    let same_pattern = sparse.assign_dense(a, n)
        && rows.one_sided.len() == n
        && bounds
            .iter()
            .zip(&rows.one_sided)
            .all(|(b, &o)| (*b == RowBound::Unilateral) == o);
    solve_rows_in(rows, sparse, q, bounds, settings, z, same_pattern)
}

/// Buffers of the staggered solve kept between calls (the dense contact path keeps one
/// per world): the row classes, the one-sided and the other rows' blocks (dense and
/// sparse) and the couplings between them are refilled in place each call, so once
/// they have grown a step allocates none of them.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowScratch {
    /// The one-sided rows, ascending.
    normal: Vec<usize>,
    /// The other rows (friction, boxes), ascending.
    tangent: Vec<usize>,
    /// Each row's position in its class.
    pos: Vec<usize>,
    /// Whether each row is one-sided.
    one_sided: Vec<bool>,
    /// The one-sided block, dense row-major and as sparse rows.
    ann: Vec<f64>,
    sn: SparseRows,
    /// The other rows' block, dense row-major and as sparse rows.
    att: Vec<f64>,
    st: SparseRows,
    /// Each row's entries in the other class's columns (original column indices):
    /// row `i`'s are `cross_cols/vals[cross_start[i]..cross_start[i + 1]]`.
    cross_start: Vec<usize>,
    cross_cols: Vec<usize>,
    cross_vals: Vec<f64>,
    /// Where each entry of `sn`, `st` and the couplings comes from in `A`'s values.
    sn_src: Vec<usize>,
    st_src: Vec<usize>,
    cross_src: Vec<usize>,
    /// The buffers hold the last call's split in full (blocks given back), so a call
    /// with the same pattern and classes refills the values only.
    split: bool,
    /// Each alternation's vectors, refilled in place: the one-sided rows' `q` and warm
    /// start, the other rows' `q`, boxes and warm start.
    qn: Vec<f64>,
    zn0: Vec<f64>,
    qt: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    zt0: Vec<f64>,
    /// `z` on the other class's rows, for the couplings' products.
    zo: Vec<f64>,
    /// The friction PGS's iterate, inverse diagonal and `w` (one solve per alternation).
    pgs: PgsScratch,
}

/// [`solve_rows_sparse`] on rows the caller has built consistent (`a.is_valid(n)`,
/// `n = q.len()`, checked in debug builds only: the Delassus assembly lists them by
/// construction; the check was 3 % of the ten-box stack's step), with kept buffers.
/// `same_pattern`: `A`'s columns and the rows' classes (one-sided or not) are those
/// of the previous call with this scratch (a resting stack keeps its contacts), so
/// the split into blocks refills values at the places it found last time.
pub(crate) fn solve_rows_in(
    scratch: &mut RowScratch,
    a: &SparseRows,
    q: &[f64],
    bounds: &[RowBound],
    settings: &RowSettings,
    z: &mut [f64],
    same_pattern: bool,
) -> Result<RowStats, LcpError> {
    let n = q.len();
    let mut stats = RowStats::default();
    let reuse = same_pattern && scratch.split;
    scratch.split = false;
    if n == 0 {
        return Ok(stats);
    }
    check_rows(n, bounds, z.len())?;
    debug_assert!(a.is_valid(n));
    let pgs_settings = PgsSettings {
        tolerance: settings.tolerance,
        max_iterations: settings.pgs_iterations,
        ..PgsSettings::default()
    };
    if settings.method == RowMethod::Pgs && settings.coupling == Coupling::Boxed {
        stats.boxed_pgs = true;
        let mut lo = Vec::with_capacity(n);
        let mut hi = Vec::with_capacity(n);
        let mut links = Vec::with_capacity(n);
        for b in bounds {
            let (l, h, link) = match *b {
                RowBound::Unilateral => (0.0, f64::INFINITY, None),
                RowBound::Friction { normal, mu } => {
                    (f64::NEG_INFINITY, f64::INFINITY, Some((normal, mu)))
                }
                RowBound::Boxed { lo, hi } => (lo, hi, None),
            };
            lo.push(l);
            hi.push(h);
            links.push(link);
        }
        let lcp =
            Lcp::boxed_sparse(a.to_dense(), a.clone(), q.to_vec(), lo, hi)?.with_friction(links)?;
        match pgs(&lcp, &pgs_settings, Some(z)) {
            Ok(sol) => {
                z.copy_from_slice(&sol.z);
                stats.iterations = sol.iterations;
                return Ok(stats);
            }
            Err(LcpError::IterationLimit { iterations, .. }) => {
                // Fall back on the staggered solve from the same warm start.
                stats.boxed_pgs = false;
                stats.boxed_fallback = true;
                stats.iterations = iterations;
            }
            Err(e) => return Err(e),
        }
    }
    let sweeps = match settings.coupling {
        Coupling::Staggered { sweeps } => sweeps.max(1),
        Coupling::Boxed if stats.boxed_fallback => 2,
        Coupling::Boxed => 1,
    };
    split_rows(scratch, a, bounds, reuse);
    let RowScratch {
        normal,
        tangent,
        ann,
        sn,
        att,
        st,
        cross_start,
        cross_cols,
        cross_vals,
        split,
        qn,
        zn0,
        qt,
        lo,
        hi,
        zt0,
        zo,
        pgs: pgs_scratch,
        ..
    } = scratch;
    let (normal, tangent) = (&normal[..], &tangent[..]);
    let nn = normal.len();
    // `Σ_j A_ij z_j` over row `i`'s couplings (columns ascending). `other` holds `z`
    // on the other class's rows in class order (ascending too): a row coupled to every
    // one of them (a tree's dense Delassus matrix) takes the contiguous product, the
    // same terms in the same order (the same bits) without the column gather.
    let coupled = |i: usize, z: &[f64], other: &[f64]| -> f64 {
        let (s, e) = (cross_start[i], cross_start[i + 1]);
        let vals = &cross_vals[s..e];
        if vals.len() == other.len() {
            vals.iter().zip(other).map(|(&v, &x)| v * x).sum::<f64>()
        } else {
            cross_cols[s..e]
                .iter()
                .zip(vals)
                .map(|(&j, &v)| v * z[j])
                .sum::<f64>()
        }
    };
    // The two sub-problems, built (and `A`'s blocks checked) once; each alternation
    // replaces only their right-hand sides and boxes.
    // Their matrices are the scratch's buffers, moved in and given back after the loop.
    let mut normal_lcp: Option<Lcp> = None;
    let mut ann_parts = Some((core::mem::take(ann), core::mem::take(sn)));
    let mut tangent_lcp: Option<Lcp> = None;
    let mut att_parts = Some((core::mem::take(att), core::mem::take(st)));
    // Friction rows with μ = 0 and boxes of zero width take no impulse: with none
    // left, one normal solve is the answer.
    let inert = |b: &RowBound| match *b {
        RowBound::Friction { mu, .. } => mu == 0.0,
        RowBound::Boxed { lo, hi } => lo == 0.0 && hi == 0.0,
        RowBound::Unilateral => true,
    };
    let frictionless = bounds.iter().all(inert);
    let bound = |i: usize, z: &[f64]| bounds[i].interval(z);
    let lemke_settings = LemkeSettings {
        tolerance: settings.tolerance,
        ..LemkeSettings::default()
    };
    let newton_settings = NewtonSettings {
        tolerance: settings.tolerance,
        max_iterations: 200,
        ..NewtonSettings::default()
    };
    let max_sweeps = settings.max_sweeps.max(sweeps);
    let mut done = 0;
    // The factor of the last active-set guess's block, kept over the alternations
    // (`A`'s one-sided block does not change between them).
    let mut guess: Option<ActiveSet> = None;
    let residual_driven = max_sweeps > sweeps;
    // (alternation, residual) where the best residual last halved (the stall window).
    let mut stall_mark = (0usize, f64::INFINITY);
    // Residual-driven mode: the smallest alternation residual so far (whether a stall
    // is far from the tolerance, `RELAX_STALLED_ABOVE`).
    let mut best_r = f64::INFINITY;
    // Relaxation of the one-sided impulses between alternations (1: none).
    let mut relax = 1.0f64;
    // The last alternation's residual (the relaxation's trigger).
    let mut last_r = f64::INFINITY;
    let mut alternate = || -> Result<(), LcpError> {
        loop {
            let final_normal = done == max_sweeps;
            if !normal.is_empty() {
                // The one-sided LCP with the other impulses fixed.
                zo.clear();
                zo.extend(tangent.iter().map(|&i| z[i]));
                qn.clear();
                qn.extend(normal.iter().map(|&i| q[i] + coupled(i, z, zo)));
                let lcp = match (&mut normal_lcp, ann_parts.take()) {
                    (Some(lcp), _) => {
                        *qn = lcp.swap_q(core::mem::take(qn))?;
                        lcp
                    }
                    (slot, Some((m, sm))) => slot.insert(Lcp::boxed_sparse(
                        m,
                        sm,
                        core::mem::take(qn),
                        vec![0.0; nn],
                        vec![f64::INFINITY; nn],
                    )?),
                    (None, None) => return Err(LcpError::BadSettings("no one-sided block")),
                };
                let lcp = &*lcp;
                zn0.clear();
                zn0.extend(normal.iter().map(|&i| z[i]));
                let zn0 = &zn0[..];
                // The requested solver first; where it fails (Newton stalls and Lemke loses
                // accuracy on the semi-definite Delassus matrix of coplanar contact points),
                // the others in turn, so a step fails only when all three do.
                let order = match settings.method {
                    // The boxed PGS already failed: the pivoting and Newton methods first.
                    RowMethod::Pgs if stats.boxed_fallback => {
                        [RowMethod::Newton, RowMethod::Lemke, RowMethod::Pgs]
                    }
                    RowMethod::Lemke => [RowMethod::Lemke, RowMethod::Newton, RowMethod::Pgs],
                    RowMethod::Newton => [RowMethod::Newton, RowMethod::Lemke, RowMethod::Pgs],
                    RowMethod::Pgs => [RowMethod::Pgs, RowMethod::Newton, RowMethod::Lemke],
                };
                let mut result = Err(LcpError::BadSettings("no solver ran"));
                // Residual-driven mode only (the whole problem's residual decides the
                // alternations anyway; the fixed-sweep mode keeps the contact world's
                // pinned trajectories, and on its pyramid a guess's answer from a
                // semi-definite block led later to a step no solver answered).
                if residual_driven && settings.method == RowMethod::Newton && !stats.boxed_fallback
                {
                    if let Some(sol) = active_set_guess(lcp, zn0, &mut guess, settings.tolerance) {
                        stats.active_set += 1;
                        stats.accepted = Some(RowMethod::Newton);
                        result = Ok(sol);
                    }
                }
                for which in order {
                    if result.is_ok() {
                        break;
                    }
                    result = match which {
                        RowMethod::Lemke => lemke(lcp, &lemke_settings, None),
                        RowMethod::Newton => fischer_newton(lcp, &newton_settings, Some(zn0)),
                        RowMethod::Pgs => pgs(lcp, &pgs_settings, Some(zn0)),
                    };
                    if result.is_ok() {
                        stats.accepted = Some(which);
                        break;
                    }
                }
                let sol = result?;
                stats.iterations += sol.iterations;
                for (k, &i) in normal.iter().enumerate() {
                    // The solvers return z ≥ 0 up to round-off; clamp so the friction bounds
                    // ±μ z_n stay ordered.
                    let zk = sol.z[k].max(0.0);
                    // Relaxed alternations: `z_n ← z_n + ω (z_n* − z_n)` (a convex
                    // combination of non-negative impulses, so still `≥ 0`).
                    z[i] = if relax < 1.0 && !final_normal {
                        zn0[k] + relax * (zk - zn0[k])
                    } else {
                        zk
                    };
                }
            }
            if frictionless {
                break;
            }
            if final_normal {
                // The one-sided rows hold against the last friction; that friction goes back
                // into the (new) cones.
                for &i in tangent {
                    let (lo, hi) = bound(i, z);
                    z[i] = z[i].min(hi).max(lo);
                }
                break;
            }
            // The boxed problem of the other rows with the one-sided impulses fixed: PGS on
            // its dense block. The block is only semi-definite when a face touches at four
            // coplanar points, where PGS can converge slowly; when it runs out of sweeps, a
            // last budget of sweeps from the warm start is kept instead of failing.
            zo.clear();
            zo.extend(normal.iter().map(|&i| z[i]));
            qt.clear();
            qt.extend(tangent.iter().map(|&i| q[i] + coupled(i, z, zo)));
            lo.clear();
            lo.extend(tangent.iter().map(|&i| bound(i, z).0));
            hi.clear();
            hi.extend(tangent.iter().map(|&i| bound(i, z).1));
            zt0.clear();
            zt0.extend(tangent.iter().map(|&i| z[i]));
            let friction_settings = PgsSettings {
                tolerance: settings.friction_tolerance,
                max_iterations: settings.friction_iterations,
                stall_sweeps: FRICTION_STALL_SWEEPS,
                // A residual check costs about a sweep: in the residual-driven mode
                // (where the whole problem's residual decides) every 4th sweep (the
                // fixed-sweep mode keeps every sweep and its pinned trajectories).
                check_every: if residual_driven { 4 } else { 1 },
                ..PgsSettings::default()
            };
            let lcp = match (&mut tangent_lcp, att_parts.take()) {
                (Some(lcp), _) => {
                    *qt = lcp.swap_q(core::mem::take(qt))?;
                    (*lo, *hi) = lcp.swap_bounds(core::mem::take(lo), core::mem::take(hi))?;
                    lcp
                }
                (slot, Some((m, sm))) => slot.insert(Lcp::boxed_sparse(
                    m,
                    sm,
                    core::mem::take(qt),
                    core::mem::take(lo),
                    core::mem::take(hi),
                )?),
                (None, None) => return Err(LcpError::BadSettings("no boxed block")),
            };
            let lcp = &*lcp;
            stats.friction_pgs = true;
            // In the residual-driven mode the whole problem's residual follows: the
            // last sweep goes unchecked (its iterate is kept either way).
            let check_last = !residual_driven;
            // Without the rows pinned at zero, the friction of contacts without normal
            // impulse (`pgs/pinned.rs`: the same iterate on the others).
            match pgs_free_rows(lcp, &friction_settings, zt0, pgs_scratch, check_last)? {
                PgsEnd::Solved { iterations, .. } => {
                    stats.iterations += iterations;
                    for (k, &i) in tangent.iter().enumerate() {
                        z[i] = pgs_scratch.z[k];
                    }
                }
                end
                @ (PgsEnd::Stopped { iterations, .. } | PgsEnd::Diverged { iterations, .. }) => {
                    // The budget answer: the iterate the sweeps reached before they
                    // stalled or ran out (without one, a non-finite residual, the warm
                    // start projected into the boxes).
                    stats.friction_budget = true;
                    stats.iterations += iterations;
                    let last = matches!(end, PgsEnd::Stopped { .. }).then_some(&pgs_scratch.z);
                    for (k, &i) in tangent.iter().enumerate() {
                        let (lo, hi) = bound(i, z);
                        let zk = last.map_or(z[i], |l| l[k]);
                        // `min`/`max`, not `clamp`: NaN bounds must not panic.
                        z[i] = zk.min(hi).max(lo);
                    }
                }
            }
            done += 1;
            stats.sweeps = done;
            if done < sweeps {
                continue;
            }
            if max_sweeps == sweeps {
                break;
            }
            let r = sparse_residual(a, q, bounds, z);
            if r <= settings.friction_tolerance {
                break;
            }
            best_r = best_r.min(r);
            // The stall window: the best residual so far must halve within
            // `ALTERNATION_STALL_SWEEPS` alternations, else the last one-sided solve
            // comes now instead of at `max_sweeps`.
            if r <= 0.5 * stall_mark.1 {
                stall_mark = (done, r);
            }
            // A residual that rose is an alternation that oscillates (a two-cycle):
            // from here on relaxed, with a new stall window.
            if relax == 1.0 && r > last_r {
                relax = ALTERNATION_RELAXATION;
                stats.relaxed = true;
                stall_mark = (done, r);
            }
            last_r = r;
            if done < max_sweeps && done - stall_mark.0 >= ALTERNATION_STALL_SWEEPS {
                if relax == 1.0 && best_r > RELAX_STALLED_ABOVE * settings.friction_tolerance {
                    // Stalled far from the tolerance: relaxed, with a new window.
                    relax = ALTERNATION_RELAXATION;
                    stats.relaxed = true;
                    stall_mark = (done, r);
                } else {
                    stats.stalled = true;
                    done = max_sweeps;
                }
            }
            stats.capped = done >= max_sweeps;
        }
        Ok(())
    };
    let result = alternate();
    // The blocks go back to the scratch for the next call (a block lost to a failed
    // build leaves the split to be redone).
    let mut back = 0;
    for (lcp, parts, (m, sm)) in [
        (normal_lcp, ann_parts, (ann, sn)),
        (tangent_lcp, att_parts, (att, st)),
    ] {
        if let Some(parts) = lcp.map(Lcp::into_matrix).or(parts) {
            (*m, *sm) = parts;
            back += 1;
        }
    }
    *split = back == 2;
    result.map(|()| stats)
}

/// The active set of a guess and its block's Cholesky factor (`None`: not safely
/// positive definite).
struct ActiveSet {
    rows: Vec<usize>,
    chol: Option<Cholesky>,
}

/// Block-pivoting rounds of an active-set guess after the warm start's set fails
/// ([`active_set_guess`]); then Newton answers.
const GUESS_PIVOTS: usize = 3;

/// Smallest pivot of an active-set guess's Cholesky factor, relative to the block's
/// largest diagonal entry: below it the block counts as singular and Newton answers.
/// Coplanar contact points (a face on four corners) make the one-sided block only
/// semi-definite; a guess on it picks one of many solutions, possibly with large
/// opposing impulses, whose warm start later failed every solver on the contact
/// crate's pyramid (with a plain LU's `1e-13` pivot test).
const GUESS_PIVOT: f64 = 1e-8;

/// `A = L Lᵀ` of a symmetric positive definite block, `L` lower triangular row-major.
struct Cholesky {
    n: usize,
    l: Vec<f64>,
}

impl Cholesky {
    /// `l_jj = √(a_jj − Σ_{k<j} l_jk²)`, `l_ij = (a_ij − Σ_{k<j} l_ik l_jk) / l_jj`
    /// (Golub & Van Loan, Alg. 4.2.1); `None` when a pivot `l_jj²` is below
    /// `GUESS_PIVOT · max a_jj` or not finite.
    fn factor(mut a: Vec<f64>, n: usize) -> Option<Self> {
        let dmax = (0..n).fold(0.0f64, |m, i| m.max(a[i * n + i]));
        let tiny = GUESS_PIVOT * dmax;
        for j in 0..n {
            let d = a[j * n + j] - (0..j).map(|k| a[j * n + k] * a[j * n + k]).sum::<f64>();
            if !(d > tiny && d.is_finite()) {
                return None;
            }
            let ljj = libm::sqrt(d);
            a[j * n + j] = ljj;
            for i in j + 1..n {
                let s = a[i * n + j] - (0..j).map(|k| a[i * n + k] * a[j * n + k]).sum::<f64>();
                a[i * n + j] = s / ljj;
            }
        }
        Some(Self { n, l: a })
    }

    /// Solves `L Lᵀ x = b` in place (forward, then back substitution).
    fn solve(&self, x: &mut [f64]) {
        let (n, l) = (self.n, &self.l);
        for i in 0..n {
            let s = x[i] - (0..i).map(|k| l[i * n + k] * x[k]).sum::<f64>();
            x[i] = s / l[i * n + i];
        }
        for i in (0..n).rev() {
            let s = x[i] - (i + 1..n).map(|k| l[k * n + i] * x[k]).sum::<f64>();
            x[i] = s / l[i * n + i];
        }
    }
}

/// The active-set guess for the standard LCP `lcp` (`w = M z + q`, `z ≥ 0`, `w ≥ 0`,
/// `zᵀw = 0`) from the warm start `z0`: with `S = {k : z0_k > 0}`, solve
/// `M_SS z_S = −q_S`, `z = 0` off `S` (the LCP's solution when `S` is its active set:
/// `w_S = 0` and complementarity hold by construction), and accept it only if its
/// natural-map residual (`z ≥ 0`, `w ≥ 0` off `S`) meets `tolerance` — the check the
/// Newton answer passes. Once the staggered alternations settle, the normals keep
/// their active set and only `q` moves: one triangular solve with the factor kept in
/// `cache` (refactored when `S` changes) replaces the Newton iterations, each of
/// which refactors the whole block. Where the warm start's set fails the check, up to
/// [`GUESS_PIVOTS`] rounds of block principal pivoting (Júdice & Pires 1994) move the
/// rows with `z_k < 0` out of `S` and those with `w_k < 0` into it, each refactored and
/// checked the same way (on humanoid_CMU lying on the floor the guess then answers
/// 1548 of 1606 one-sided solves instead of 1284 of 1828, and Newton's LU factors,
/// 16 % of the run, go). `M_SS` is a principal block of a symmetric positive
/// semi-definite Delassus matrix: factored by Cholesky, and a block that is not safely
/// definite ([`GUESS_PIVOT`]) makes no guess; an unchanged set or the last round
/// without an answer leaves the solve to Newton.
fn active_set_guess(
    lcp: &Lcp,
    z0: &[f64],
    cache: &mut Option<ActiveSet>,
    tolerance: f64,
) -> Option<LcpSolution> {
    let n = lcp.n();
    let same = cache.as_ref().is_some_and(|c| {
        let mut k = 0;
        z0.iter().enumerate().all(|(i, &z)| {
            let active = z > 0.0;
            let listed = c.rows.get(k) == Some(&i);
            k += usize::from(listed);
            active == listed
        }) && k == c.rows.len()
    });
    if !same {
        let rows: Vec<usize> = (0..n).filter(|&i| z0[i] > 0.0).collect();
        *cache = Some(ActiveSet::factor(lcp, rows));
    }
    let mut in_set = vec![false; n];
    for round in 0..=GUESS_PIVOTS {
        let set = cache.as_ref()?;
        let chol = set.chol.as_ref()?;
        let mut x: Vec<f64> = set.rows.iter().map(|&i| -lcp.q()[i]).collect();
        chol.solve(&mut x);
        let mut z = vec![0.0; n];
        in_set.iter_mut().for_each(|b| *b = false);
        for (&i, &v) in set.rows.iter().zip(&x) {
            z[i] = v;
            in_set[i] = true;
        }
        let w = lcp.w(&z);
        let r = lcp.residual_with(&z, &w);
        if r <= tolerance {
            // `finish_with`'s answer (within the tolerance it accepts) without the
            // residual's second evaluation.
            return Some(Lcp::solved(z, w, r, round));
        }
        if round == GUESS_PIVOTS {
            break;
        }
        // Block principal pivoting (Júdice & Pires 1994): the rows of `S` whose
        // `z` went negative leave it, the rows off `S` whose `w` is negative join it.
        let rows: Vec<usize> = (0..n)
            .filter(|&i| if in_set[i] { z[i] > 0.0 } else { w[i] < 0.0 })
            .collect();
        if rows == set.rows {
            break;
        }
        *cache = Some(ActiveSet::factor(lcp, rows));
    }
    None
}

impl ActiveSet {
    /// The set `rows` with the Cholesky factor of its block `M_SS` (`None`: empty or
    /// not safely definite, [`GUESS_PIVOT`]).
    fn factor(lcp: &Lcp, rows: Vec<usize>) -> Self {
        let (n, s, m) = (lcp.n(), rows.len(), lcp.m());
        let mut block = Vec::with_capacity(s * s);
        for &i in &rows {
            block.extend(rows.iter().map(|&j| m[i * n + j]));
        }
        let chol = if s == 0 {
            None
        } else {
            Cholesky::factor(block, s)
        };
        Self { rows, chol }
    }
}

/// Splits `A`'s rows by class into `scratch`: the one-sided block and the other rows'
/// block (sparse rows in class positions, and dense row-major for the solvers that
/// take dense `M`), and each row's entries in the other class's columns (the
/// couplings). One pass over the non-zeros, branch-free: each entry is written both to
/// its row's block and to the couplings and only the cursor of the one it belongs to
/// advances (rows alternate normal, friction, friction, so a branch on the class
/// mispredicted often; this pass with pushes was 12 % of the ten-box stack's step).
///
/// With `reuse` (the same pattern and classes as the split the buffers hold) only the
/// values move: each block entry and coupling is gathered from where it came from last
/// time, and the dense blocks are overwritten at the same places (the rest is still 0).
fn split_rows(scratch: &mut RowScratch, a: &SparseRows, bounds: &[RowBound], reuse: bool) {
    let RowScratch {
        normal,
        tangent,
        pos,
        one_sided,
        ann,
        sn,
        att,
        st,
        cross_start,
        cross_cols,
        cross_vals,
        sn_src,
        st_src,
        cross_src,
        ..
    } = scratch;
    if reuse {
        for (vals, src) in [
            (&mut sn.vals, &*sn_src),
            (&mut st.vals, &*st_src),
            (&mut *cross_vals, &*cross_src),
        ] {
            for (v, &k) in vals.iter_mut().zip(src) {
                *v = a.vals[k];
            }
        }
        for (block, sub, width) in [(ann, &*sn, normal.len()), (att, &*st, tangent.len())] {
            for r in 0..width {
                let (cols, vals) = sub.row(r);
                for (&c, &v) in cols.iter().zip(vals) {
                    block[r * width + c] = v;
                }
            }
        }
        return;
    }
    normal.clear();
    tangent.clear();
    pos.clear();
    one_sided.clear();
    for (i, b) in bounds.iter().enumerate() {
        let o = *b == RowBound::Unilateral;
        one_sided.push(o);
        let class = if o { &mut *normal } else { &mut *tangent };
        pos.push(class.len());
        class.push(i);
    }
    // Sizes first (the entries of each class, counted branch-free), then one slot more:
    // the slot an entry is written to in the class it does not belong to is the next
    // one, overwritten later or cut off at the end. Resizing to the last call's sizes
    // writes (almost) nothing.
    let (mut size_n, mut size_t) = (0, 0);
    for (i, &oi) in one_sided.iter().enumerate() {
        let (cols, _) = a.row(i);
        let mut same = 0;
        for &j in cols {
            same += usize::from(one_sided[j] == oi);
        }
        if oi {
            size_n += same;
        } else {
            size_t += same;
        }
    }
    let size_c = a.cols.len() - size_n - size_t;
    for (sub, src, size) in [
        (&mut *sn, &mut *sn_src, size_n),
        (&mut *st, &mut *st_src, size_t),
    ] {
        sub.start.clear();
        sub.start.push(0);
        sub.cols.resize(size + 1, 0);
        sub.vals.resize(size + 1, 0.0);
        src.resize(size + 1, 0);
    }
    cross_start.clear();
    cross_start.push(0);
    cross_cols.resize(size_c + 1, 0);
    cross_vals.resize(size_c + 1, 0.0);
    cross_src.resize(size_c + 1, 0);
    let (mut kn, mut kt, mut kc) = (0, 0, 0);
    {
        // Plain slices, so that the loop keeps their pointers in registers.
        let (one_sided, pos) = (&one_sided[..], &pos[..]);
        let (n_cols, n_vals, n_src) = (&mut sn.cols[..], &mut sn.vals[..], &mut sn_src[..]);
        let (t_cols, t_vals, t_src) = (&mut st.cols[..], &mut st.vals[..], &mut st_src[..]);
        let (c_cols, c_vals, c_src) =
            (&mut cross_cols[..], &mut cross_vals[..], &mut cross_src[..]);
        for (i, &oi) in one_sided.iter().enumerate() {
            let (cols, vals) = a.row(i);
            let (out_cols, out_vals, out_src, k) = if oi {
                (&mut *n_cols, &mut *n_vals, &mut *n_src, &mut kn)
            } else {
                (&mut *t_cols, &mut *t_vals, &mut *t_src, &mut kt)
            };
            let (mut kk, mut kx) = (*k, kc);
            for ((&j, &v), e) in cols.iter().zip(vals).zip(a.start[i]..) {
                let same = one_sided[j] == oi;
                out_cols[kk] = pos[j];
                out_vals[kk] = v;
                out_src[kk] = e;
                c_cols[kx] = j;
                c_vals[kx] = v;
                c_src[kx] = e;
                kk += usize::from(same);
                kx += usize::from(!same);
            }
            (*k, kc) = (kk, kx);
            if oi {
                sn.start.push(kk);
            } else {
                st.start.push(kk);
            }
            cross_start.push(kx);
        }
    }
    for (sub, src, k) in [(&mut *sn, &mut *sn_src, kn), (&mut *st, &mut *st_src, kt)] {
        sub.cols.truncate(k);
        sub.vals.truncate(k);
        src.truncate(k);
    }
    cross_cols.truncate(kc);
    cross_vals.truncate(kc);
    cross_src.truncate(kc);
    for (block, sub, width) in [(ann, &*sn, normal.len()), (att, &*st, tangent.len())] {
        block.clear();
        block.resize(width * width, 0.0);
        for r in 0..width {
            let (cols, vals) = sub.row(r);
            for (&c, &v) in cols.iter().zip(vals) {
                block[r * width + c] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frictional contact problem with a block pattern of zeros: `contacts` contacts in
    /// a chain, each coupled to the next (as boxes in a stack), rows `(n, t₁, t₂)`.
    fn chain(contacts: usize) -> (Vec<f64>, Vec<f64>, Vec<RowBound>) {
        let n = 3 * contacts;
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let (ci, cj) = (i / 3, j / 3);
                if ci.abs_diff(cj) <= 1 {
                    let v = if i == j {
                        2.0 + 0.1 * (i % 3) as f64
                    } else {
                        0.3 / (1.0 + (i + j) as f64)
                    };
                    a[i * n + j] = v;
                }
            }
        }
        let q: Vec<f64> = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    -1.0 - 0.01 * i as f64
                } else {
                    0.2 - 0.05 * (i % 7) as f64
                }
            })
            .collect();
        let bounds = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    RowBound::Unilateral
                } else {
                    RowBound::Friction {
                        normal: i - i % 3,
                        mu: 0.5,
                    }
                }
            })
            .collect();
        (a, q, bounds)
    }

    /// The residuals skip the product of a row pinned at zero (friction of a contact
    /// without normal impulse) and take `|z_i|` for it: the natural map of every row
    /// written out gives the same bits, with pinned rows at zero and one pinned row off
    /// zero (`|z_i| = 0.7`), dense and as sparse rows.
    #[test]
    fn pinned_rows_residual_is_the_natural_map() {
        let (a, q, bounds) = chain(6);
        let n = q.len();
        let mut z: Vec<f64> = (0..n).map(|i| 0.05 * (i % 5) as f64 - 0.04).collect();
        for c in [1, 4] {
            z[3 * c] = 0.0;
            z[3 * c + 1] = -0.0;
            z[3 * c + 2] = 0.0;
        }
        let natural = |z: &[f64]| {
            let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
            let worst = (0..n).fold(0.0f64, |worst, i| {
                let w: f64 = q[i] + (0..n).map(|k| a[i * n + k] * z[k]).sum::<f64>();
                let (lo, hi) = bounds[i].interval(z);
                worst.max((z[i] - (z[i] - w).min(hi).max(lo)).abs())
            });
            worst / scale
        };
        let sparse = SparseRows::from_dense(&a, n);
        for off in [0.0, 0.7] {
            z[4] = off;
            let want = natural(&z);
            assert_eq!(
                row_residual(&a, &q, &bounds, &z).unwrap().to_bits(),
                want.to_bits()
            );
            assert_eq!(
                sparse_residual(&sparse, &q, &bounds, &z).to_bits(),
                want.to_bits()
            );
        }
        // The pinned row off zero counts: scale max(1, |q|∞) = 1.11 (measured residual
        // 1.069 ≥ 0.7 / 1.11 = 0.631).
        assert!(natural(&z) >= 0.7 / 1.11);
    }

    /// The sparse rows give the dense solve's bits, also when they list explicit zeros
    /// (the Delassus path lists every column of rows that share a body).
    #[test]
    fn sparse_rows_solve_equals_dense_bit_for_bit() {
        let (a, q, bounds) = chain(8);
        let n = q.len();
        let exact = SparseRows::from_dense(&a, n);
        // Every entry listed, zeros included.
        let mut full = SparseRows {
            start: vec![0],
            ..SparseRows::default()
        };
        for i in 0..n {
            full.cols.extend(0..n);
            full.vals.extend_from_slice(&a[i * n..(i + 1) * n]);
            full.start.push(full.cols.len());
        }
        assert!(exact.is_valid(n) && full.is_valid(n));
        // Non-zeros: 3 × 3 blocks on three block diagonals, 8 + 2 · 7 = 22 blocks.
        assert_eq!(exact.cols.len(), 22 * 9);
        for method in [RowMethod::Newton, RowMethod::Lemke, RowMethod::Pgs] {
            for coupling in [Coupling::Staggered { sweeps: 2 }, Coupling::Boxed] {
                if coupling == Coupling::Boxed && method != RowMethod::Pgs {
                    continue;
                }
                // Staggered: alternate until the whole problem's residual is below
                // the friction tolerance (this also covers the sparse residual check).
                let settings = RowSettings {
                    method,
                    coupling,
                    max_sweeps: 100,
                    ..RowSettings::default()
                };
                let mut z_dense = vec![0.0; n];
                let dense = solve_rows(&a, &q, &bounds, &settings, &mut z_dense).unwrap();
                for sparse in [&exact, &full] {
                    let mut z = vec![0.0; n];
                    let stats = solve_rows_sparse(sparse, &q, &bounds, &settings, &mut z).unwrap();
                    assert_eq!(stats, dense);
                    assert!(z
                        .iter()
                        .zip(&z_dense)
                        .all(|(x, y)| x.to_bits() == y.to_bits()));
                }
                // A real answer, not only the same one: measured 5.9e-9 (staggered, 5
                // sweeps, all three methods) and 1.4e-11 (boxed PGS); tolerance 1e-8.
                let r = row_residual(&a, &q, &bounds, &z_dense).unwrap();
                println!(
                    "{method:?} {coupling:?}: residual {r:e}, {} sweeps",
                    dense.sweeps
                );
                assert!(r <= 1e-8, "{method:?} {coupling:?}: residual {r:e}");
            }
        }
    }

    /// One set of kept buffers over a sequence of problems (a first, the same pattern
    /// with other values, a smaller one, a zero entry more, the first again) gives
    /// each the fresh solve's bits and statistics (`solve_rows_with` against
    /// `solve_rows`), and `assign_dense` reports the pattern's repeats.
    #[test]
    fn kept_buffers_solve_equals_fresh() {
        let (a, q, bounds) = chain(6);
        let n = q.len();
        let scaled: Vec<f64> = a.iter().map(|v| 1.1 * v).collect();
        let (small, small_q, small_bounds) = chain(4);
        let mut holed = a.clone();
        holed[1] = 0.0;
        holed[n] = 0.0;
        let settings = RowSettings {
            max_sweeps: 50,
            friction_tolerance: 1e-6,
            friction_iterations: 10,
            ..RowSettings::default()
        };
        let mut buffers = RowBuffers::default();
        type Case<'a> = (&'a [f64], &'a [f64], &'a [RowBound], bool);
        let cases: [Case; 5] = [
            (&a, &q, &bounds, false),
            (&scaled, &q, &bounds, true),
            (&small, &small_q, &small_bounds, false),
            (&holed, &q, &bounds, false),
            (&a, &q, &bounds, false),
        ];
        for (k, (a, q, bounds, repeat)) in cases.into_iter().enumerate() {
            let mut fresh = vec![0.0; q.len()];
            let want = solve_rows(a, q, bounds, &settings, &mut fresh).unwrap();
            let mut pattern = buffers.sparse.clone();
            assert_eq!(pattern.assign_dense(a, q.len()), repeat, "case {k}");
            let mut kept = vec![0.0; q.len()];
            let got = solve_rows_with(&mut buffers, a, q, bounds, &settings, &mut kept).unwrap();
            assert_eq!(got, want, "case {k}");
            assert!(
                kept.iter()
                    .zip(&fresh)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "case {k}"
            );
        }
    }

    /// The exact solutions of one contact, a normal row `0` and one friction row `1`
    /// (`|z_1| ≤ μ z_0`), by enumerating the complementarity cases: separating
    /// (`z = 0`, `w_0 ≥ 0`), sliding (`w_0 = 0`, `z_1 = ∓μ z_0` with `±w_1 ≥ 0`) and
    /// sticking (`w = 0`, `|z_1| ≤ μ z_0`; with a singular `A` only where `−q` is in its
    /// range). Each candidate is kept where its residual ([`row_residual`]) is ≤ 1e-14.
    fn one_contact_exact(a: &[f64; 4], q: &[f64; 2], mu: f64) -> Vec<[f64; 2]> {
        let bounds = [RowBound::Unilateral, RowBound::Friction { normal: 0, mu }];
        let mut candidates = vec![[0.0, 0.0]];
        for s in [1.0, -1.0] {
            let zn = -q[0] / (a[0] - s * mu * a[1]);
            candidates.push([zn, -s * mu * zn]);
        }
        let det = a[0] * a[3] - a[1] * a[2];
        if det.abs() > 1e-12 * a[0] * a[3] {
            candidates.push([
                (-q[0] * a[3] + q[1] * a[1]) / det,
                (-q[1] * a[0] + q[0] * a[2]) / det,
            ]);
        }
        candidates
            .into_iter()
            .filter(|z| z[0] >= 0.0 && row_residual(a, q, &bounds, z).is_ok_and(|r| r <= 1e-14))
            .collect()
    }

    /// One contact of a one-degree-of-freedom system (equality.rs's two arms tied by a
    /// tendon equality, one ball sliding on the floor, the impact step): `A` has rank 1,
    /// so the velocities `w = A z + q` depend on one combination of the impulses only,
    /// and the natural-map residual of impulses does not order answers by their
    /// velocities' error. The exact solution is unique (sliding; sticking would need
    /// `w_0 = q_0 − A_01 q_1 / A_11 = 0.187` to be 0). At tolerance 1e-13 the
    /// alternations end capped and the final one-sided solve answers with the exact
    /// velocities (residual 3.8e-4; 0.45 without relaxation, where the alternation
    /// iterate of least residual, 0.088, has `w_0 = −0.088`, 0.21 from the exact
    /// velocities: why a capped solve does not return that iterate); at the world's
    /// tolerance 1e-6 the relaxed alternations converge.
    #[test]
    fn rank_one_contact_keeps_exact_velocities() {
        let a = [
            0.03969760593156355,
            -0.09607617740409741,
            -0.09607617740409741,
            0.23252364085876293,
        ];
        let q = [-0.22775268507191027, 1.0036061812128625];
        let bounds = [
            RowBound::Unilateral,
            RowBound::Friction { normal: 0, mu: 1.0 },
        ];
        let w = |z: &[f64; 2]| {
            [
                a[0] * z[0] + a[1] * z[1] + q[0],
                a[2] * z[0] + a[3] * z[1] + q[1],
            ]
        };
        let exact = one_contact_exact(&a, &q, 1.0);
        // Measured: one, z = (1.677442, −1.677442), w = (0, 0.452399).
        assert_eq!(exact.len(), 1, "{exact:?}");
        let we = w(&exact[0]);
        let strict = RowSettings {
            coupling: Coupling::Staggered { sweeps: 30 },
            tolerance: 1e-13,
            pgs_iterations: 1000,
            friction_tolerance: 1e-13,
            friction_iterations: 3000,
            max_sweeps: 50,
            ..RowSettings::default()
        };
        let world = RowSettings {
            friction_iterations: 10,
            pgs_iterations: 1000,
            max_sweeps: 50,
            friction_tolerance: 1e-6,
            ..RowSettings::default()
        };
        for (name, settings, bound) in [("strict", strict, 1e-12), ("world", world, 1e-5)] {
            let mut z = [0.0; 2];
            let stats = solve_rows(&a, &q, &bounds, &settings, &mut z).unwrap();
            let r = row_residual(&a, &q, &bounds, &z).unwrap();
            let wz = w(&z);
            let err = (wz[0] - we[0]).abs().max((wz[1] - we[1]).abs());
            println!("{name}: {stats:?}, z {z:?}, residual {r:e}, velocity error {err:e}");
            // Measured: strict 1.1e-16 (capped, residual 3.8e-4); world 2.4e-6
            // (converged, residual 9.8e-7 ≤ 1e-6).
            assert!(err <= bound, "{name}: velocity error {err:e}");
            if name == "world" {
                assert!(!stats.capped && r <= 1e-6, "{name}: residual {r:e}");
            }
        }
    }

    /// One sliding contact whose saturated friction lifts its own normal (`A_nt = 1.2 >
    /// A_nn = 1`, μ = 1): the plain alternation is a two-cycle between `z = (1, 1)` and
    /// `z = (0, 0)` (residual 0.25 at both), the relaxed one after the stall converges
    /// to the sliding solution `z_n = z_t = 1/2.2`.
    #[test]
    fn a_two_cycle_converges_relaxed() {
        let a = [1.0, 1.2, 1.2, 2.0];
        let q = [-1.0, -4.0];
        let bounds = [
            RowBound::Unilateral,
            RowBound::Friction { normal: 0, mu: 1.0 },
        ];
        let settings = RowSettings {
            max_sweeps: 50,
            friction_tolerance: 1e-6,
            ..RowSettings::default()
        };
        let mut z = [0.0; 2];
        let stats = solve_rows(&a, &q, &bounds, &settings, &mut z).unwrap();
        let r = row_residual(&a, &q, &bounds, &z).unwrap();
        println!("{stats:?}, z {z:?}, residual {r:e}");
        assert!(stats.relaxed && !stats.capped);
        // Measured 2.5e-7 after 16 alternations (tolerance 1e-6, the friction tolerance).
        assert!(r <= 1e-6, "residual {r:e}");
        // Measured |z_n − 1/2.2| 4.5e-7, z_t = z_n exactly (saturated).
        assert!((z[0] - 1.0 / 2.2).abs() <= 1e-6 && (z[1] - z[0]).abs() <= 1e-12);
    }

    /// Inconsistent sparse rows are a typed error, not a panic.
    #[test]
    fn bad_sparse_rows_are_rejected() {
        let (a, q, bounds) = chain(2);
        let n = q.len();
        let settings = RowSettings::default();
        let mut bad = SparseRows::from_dense(&a, n);
        bad.cols[1] = n; // out of range
        let mut z = vec![0.0; n];
        assert!(solve_rows_sparse(&bad, &q, &bounds, &settings, &mut z).is_err());
        let mut unsorted = SparseRows::from_dense(&a, n);
        unsorted.cols.swap(0, 1);
        assert!(solve_rows_sparse(&unsorted, &q, &bounds, &settings, &mut z).is_err());
        assert!(solve_rows(&a[1..], &q, &bounds, &settings, &mut z).is_err());
    }
}
