//! The LCP as plain, validated data; its natural-map residual; the solution and error
//! types shared by every solver.

use alloc::vec;
use alloc::vec::Vec;
use core::fmt;

/// A linear complementarity problem, standard or boxed, with dense row-major `M`.
///
/// **Standard LCP** (the lecture's contact conditions `λ ≥ 0`, `d λ = 0` at velocity
/// level): find `z` such that
///
/// ```text
/// w = M z + q,   z ≥ 0,   w ≥ 0,   zᵀ w = 0.
/// ```
///
/// **Boxed LCP** (friction): each `z_i` lies in `[lo_i, hi_i]` and
///
/// ```text
/// z_i = lo_i  ⇒ w_i ≥ 0,   z_i = hi_i ⇒ w_i ≤ 0,   lo_i < z_i < hi_i ⇒ w_i = 0,
/// ```
///
/// i.e. `z = mid(lo, z − w, hi)`. The standard LCP is the case `lo = 0`, `hi = ∞`.
///
/// **Friction-scaled bounds** (pyramidal Coulomb cone, `|z_f| ≤ μ z_n`): a row `i` with
/// `friction[i] = Some((n, μ))` has the bounds `[−μ z_n, μ z_n]` taken from the current
/// value of its normal variable `z_n`; its stored `lo_i`/`hi_i` are ignored. The normal
/// row must itself have fixed bounds with `lo_n ≥ 0`.
///
/// Fields are private so that every `Lcp` is valid (square finite `M`, finite `q`,
/// `lo ≤ hi`, consistent friction links); read them with the accessors.
#[derive(Clone, Debug, PartialEq)]
pub struct Lcp {
    n: usize,
    m: Vec<f64>,
    q: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    friction: Vec<Option<(usize, f64)>>,
    /// The non-zero entries of `M` by row ([`SparseRows`]). `w = M z + q` and the
    /// solvers' row products run over these only, in the same column order as the
    /// dense sum, so they give the dense sum's bits (a skipped term is `±0`).
    sparse: SparseRows,
}

/// A matrix as compressed sparse rows: row `i`'s entries are `cols[start[i]..start[i+1]]`
/// (ascending) with values `vals[..]`; entries not listed are zero (listed ones may be
/// zero too).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseRows {
    /// Row starts into `cols` and `vals` (`n + 1` of them, the first `0`).
    pub start: Vec<usize>,
    /// Columns, ascending within each row.
    pub cols: Vec<usize>,
    /// Values.
    pub vals: Vec<f64>,
}

impl SparseRows {
    /// The non-zero entries of the row-major `n × n` matrix `m` (a NaN is non-zero).
    pub fn from_dense(m: &[f64], n: usize) -> SparseRows {
        let mut s = SparseRows::default();
        s.assign_dense(m, n);
        s
    }

    /// [`SparseRows::from_dense`] into `self`'s buffers (no allocation once they have
    /// grown): the same rows, bit for bit. Returns whether the pattern (the rows and
    /// each row's columns) is the one `self` held, in which case only the values were
    /// rewritten (a step whose rows are those of the last: one pass to compare the
    /// patterns, one gather of the listed values).
    pub fn assign_dense(&mut self, m: &[f64], n: usize) -> bool {
        // Every entry listed (rows 0, 1, …, n−1 whole: a tree's dense Delassus matrix)
        // and every entry of `m` non-zero: the same pattern, and the values are `m` as
        // it stands (one count and one copy instead of the row-by-row comparison and
        // gather).
        if n > 0
            && m.len() == n * n
            && self.vals.len() == n * n
            && self.is_full(n)
            && m.iter().map(|&v| usize::from(v != 0.0)).sum::<usize>() == n * n
        {
            self.vals.copy_from_slice(m);
            return true;
        }
        if self.dense_pattern_is(m, n) {
            for i in 0..n {
                let row = &m[i * n..(i + 1) * n];
                let (s, e) = (self.start[i], self.start[i + 1]);
                for (v, &j) in self.vals[s..e].iter_mut().zip(&self.cols[s..e]) {
                    *v = row[j];
                }
            }
            return true;
        }
        // Branch-free compaction (every entry is written, the cursor moves past the
        // non-zero ones): the zero pattern of a Delassus matrix defeats branch prediction.
        // The entries kept (below the final cursor) were each written when the cursor
        // stood on them, so the old ones need no zeroing: the buffers only grow, to
        // room for a whole row past the cursor.
        let SparseRows { start, cols, vals } = self;
        start.clear();
        let mut k = 0;
        start.push(0);
        for row in m.chunks_exact(n.max(1)).take(n) {
            if cols.len() < k + n {
                cols.resize(k + n, 0);
            }
            if vals.len() < k + n {
                vals.resize(k + n, 0.0);
            }
            for (j, &v) in row.iter().enumerate() {
                cols[k] = j;
                vals[k] = v;
                k += usize::from(v != 0.0);
            }
            start.push(k);
        }
        cols.truncate(k);
        vals.truncate(k);
        false
    }

    /// Whether `self` lists every entry of an `n × n` matrix: `n + 1` row starts
    /// `0, n, 2n, …` and each row's columns `0, 1, …, n−1` (checked whole: one pass).
    fn is_full(&self, n: usize) -> bool {
        self.start.len() == n + 1
            && self.cols.len() == n * n
            && self.start.iter().enumerate().all(|(i, &s)| s == i * n)
            && self
                .cols
                .chunks_exact(n)
                .all(|row| row.iter().enumerate().all(|(j, &c)| c == j))
    }

    /// Whether `self` lists exactly the non-zero entries (NaN included) of the
    /// row-major `n × n` matrix `m` (`m` of length `n²`; an inconsistent `self` lists
    /// nothing).
    fn dense_pattern_is(&self, m: &[f64], n: usize) -> bool {
        if m.len() != n * n
            || self.start.len() != n + 1
            || self.start.first() != Some(&0)
            || self.start.last() != Some(&self.cols.len())
            || self.vals.len() != self.cols.len()
        {
            return false;
        }
        let mut same = true;
        for (i, row) in m.chunks_exact(n.max(1)).take(n).enumerate() {
            let Some(cols) = self.cols.get(self.start[i]..self.start[i + 1]) else {
                return false;
            };
            // The row's non-zeros counted branch-free; as many listed, ascending, each
            // a non-zero entry: the same set.
            let nnz: usize = row.iter().map(|&v| usize::from(v != 0.0)).sum();
            same &= nnz == cols.len();
            for &j in cols {
                same &= row.get(j).is_some_and(|&v| v != 0.0);
            }
            for w in cols.windows(2) {
                same &= w[0] < w[1];
            }
            if !same {
                return false;
            }
        }
        same
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// Row `i`: its columns (ascending) and values.
    #[inline]
    pub fn row(&self, i: usize) -> (&[usize], &[f64]) {
        let (s, e) = (self.start[i], self.start[i + 1]);
        (&self.cols[s..e], &self.vals[s..e])
    }

    /// The dense row-major `n × n` matrix (`n` = [`SparseRows::rows`]).
    pub fn to_dense(&self) -> Vec<f64> {
        let n = self.rows();
        let mut m = vec![0.0; n * n];
        for i in 0..n {
            let (cols, vals) = self.row(i);
            for (&j, &v) in cols.iter().zip(vals) {
                m[i * n + j] = v;
            }
        }
        m
    }

    /// Whether the structure is consistent with an `n × n` matrix (row starts
    /// non-decreasing from 0 to the number of entries, columns below `n` and ascending
    /// within each row).
    pub fn is_valid(&self, n: usize) -> bool {
        if !(self.start.len() == n + 1
            && self.start[0] == 0
            && self.start[n] == self.cols.len()
            && self.cols.len() == self.vals.len())
        {
            return false;
        }
        let mut ok = true;
        for w in self.start.windows(2) {
            let Some(c) = self.cols.get(w[0]..w[1]) else {
                return false;
            };
            // Ascending and below n: each column above the last (branch-free).
            let mut last = None::<usize>;
            for &j in c {
                ok &= j < n && last.is_none_or(|l| l < j);
                last = Some(j);
            }
        }
        ok
    }
}

/// Why a problem was rejected or a solver failed. No solver returns a `z` on failure: the
/// safe impulse for a caller that must continue is `z = 0` (for the infeasible
/// `M = [[−1]], q = [−1]` that is the issue's "failure with z = 0").
#[derive(Clone, Debug, PartialEq)]
pub enum LcpError {
    /// An array has the wrong length (`what` names it: `"m"`, `"lo"`, `"z0"`, ...).
    DimensionMismatch {
        /// Which array.
        what: &'static str,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        found: usize,
    },
    /// A NaN or infinite entry in `M`, `q`, or a warm-start vector.
    NonFinite {
        /// Which array.
        what: &'static str,
        /// Index of the first bad entry (row-major for `M`).
        index: usize,
    },
    /// Bounds with `lo_i > hi_i`, a NaN bound, `lo_i = +∞` or `hi_i = −∞`.
    BadBounds {
        /// The row.
        index: usize,
    },
    /// A friction link that points out of range, to itself, to another friction row or
    /// to a normal row with `lo < 0`, or a coefficient `μ` that is negative or not finite.
    BadFriction {
        /// The friction row.
        index: usize,
    },
    /// A solver setting out of range (`ω ∉ (0, 2)`, tolerance ≤ 0, ...).
    BadSettings(&'static str),
    /// The solver does not handle this kind of problem (e.g. Lemke or Newton on a boxed LCP).
    Unsupported(&'static str),
    /// Projected Gauss–Seidel needs `M_ii > 0`.
    NonPositiveDiagonal {
        /// The row.
        index: usize,
    },
    /// Lemke's method ended on a secondary ray: no complementary solution was found.
    /// With `proven_infeasible` the ray gave a Farkas certificate `y ≥ 0`, `Mᵀy ≤ 0`,
    /// `qᵀy < 0` (checked numerically), so no `z ≥ 0` with `M z + q ≥ 0` exists at all;
    /// otherwise (M not copositive-plus) the LCP may still have a solution.
    RayTermination {
        /// Pivots done before the ray.
        pivots: usize,
        /// Whether the ray certifies infeasibility.
        proven_infeasible: bool,
    },
    /// Lemke's method hit its pivot limit.
    PivotLimit {
        /// The limit.
        pivots: usize,
    },
    /// An iterative method hit its iteration limit above the tolerance.
    IterationLimit {
        /// Iterations done.
        iterations: usize,
        /// Natural-map residual of the last iterate.
        residual: f64,
    },
    /// The Newton method's line search found no decrease of the merit function (a
    /// stationary point of `½|Φ|²` that is not a solution, e.g. an infeasible problem).
    Stalled {
        /// Iterations done.
        iterations: usize,
        /// Natural-map residual of the last iterate.
        residual: f64,
    },
    /// The method finished but its answer misses the requested tolerance (round-off in
    /// an ill-conditioned pivot sequence); the answer is not returned as a success.
    Inaccurate {
        /// The residual reached.
        residual: f64,
        /// The tolerance asked for.
        tolerance: f64,
    },
}

impl fmt::Display for LcpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LcpError::DimensionMismatch {
                what,
                expected,
                found,
            } => write!(f, "LCP: `{what}` has length {found}, expected {expected}"),
            LcpError::NonFinite { what, index } => {
                write!(f, "LCP: non-finite entry {index} in `{what}`")
            }
            LcpError::BadBounds { index } => write!(f, "LCP: bad bounds in row {index}"),
            LcpError::BadFriction { index } => {
                write!(f, "LCP: bad friction link in row {index}")
            }
            LcpError::BadSettings(what) => write!(f, "LCP solver settings: {what}"),
            LcpError::Unsupported(what) => write!(f, "LCP solver: unsupported problem: {what}"),
            LcpError::NonPositiveDiagonal { index } => {
                write!(f, "LCP: M[{index}][{index}] ≤ 0 (projected Gauss–Seidel needs > 0)")
            }
            LcpError::RayTermination {
                pivots,
                proven_infeasible,
            } => {
                write!(f, "Lemke: ray termination after {pivots} pivots")?;
                if *proven_infeasible {
                    write!(f, " (infeasible: Farkas certificate found)")
                } else {
                    Ok(())
                }
            }
            LcpError::PivotLimit { pivots } => write!(f, "Lemke: pivot limit {pivots} reached"),
            LcpError::IterationLimit {
                iterations,
                residual,
            } => write!(
                f,
                "LCP: no convergence in {iterations} iterations (residual {residual:.3e})"
            ),
            LcpError::Stalled {
                iterations,
                residual,
            } => write!(
                f,
                "LCP Newton: line search stalled after {iterations} iterations (residual {residual:.3e})"
            ),
            LcpError::Inaccurate {
                residual,
                tolerance,
            } => write!(
                f,
                "LCP: residual {residual:.3e} above the tolerance {tolerance:.3e}"
            ),
        }
    }
}

impl core::error::Error for LcpError {}

/// A solver's answer: `z`, `w = M z + q`, the natural-map residual and the work done.
/// Only returned when `residual ≤` the solver's tolerance.
#[derive(Clone, Debug, PartialEq)]
pub struct LcpSolution {
    /// The unknowns (impulses, multipliers `λ`).
    pub z: Vec<f64>,
    /// `w = M z + q`, recomputed from `z` (not read from a tableau).
    pub w: Vec<f64>,
    /// [`Lcp::residual`] of `z`.
    pub residual: f64,
    /// Pivots (Lemke, warm attempt included), sweeps (PGS) or Newton steps.
    pub iterations: usize,
    /// Lemke only: the final complementary basis, `basis[i] = true` when `z_i` is basic
    /// (else `w_i`); pass it back as the warm start of the next, nearby problem.
    pub basis: Option<Vec<bool>>,
}

fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), LcpError> {
    if expected == found {
        Ok(())
    } else {
        Err(LcpError::DimensionMismatch {
            what,
            expected,
            found,
        })
    }
}

fn check_finite(what: &'static str, v: &[f64]) -> Result<(), LcpError> {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(index) => Err(LcpError::NonFinite { what, index }),
    }
}

impl Lcp {
    /// The standard LCP `w = M z + q ≥ 0`, `z ≥ 0`, `zᵀw = 0`; `n = q.len()`, `m` is
    /// row-major `n × n`. `n = 0` is valid (solved trivially by every solver).
    pub fn new(m: Vec<f64>, q: Vec<f64>) -> Result<Lcp, LcpError> {
        let n = q.len();
        Lcp::boxed(m, q, vec![0.0; n], vec![f64::INFINITY; n])
    }

    /// The boxed LCP `z = mid(lo, z − w, hi)`, `w = M z + q`; bounds may be infinite.
    pub fn boxed(m: Vec<f64>, q: Vec<f64>, lo: Vec<f64>, hi: Vec<f64>) -> Result<Lcp, LcpError> {
        let n = q.len();
        check_len("m", n * n, m.len())?;
        check_len("lo", n, lo.len())?;
        check_len("hi", n, hi.len())?;
        check_finite("m", &m)?;
        check_finite("q", &q)?;
        check_bounds(&lo, &hi)?;
        let sparse = SparseRows::from_dense(&m, n);
        Ok(Lcp {
            n,
            m,
            q,
            lo,
            hi,
            friction: vec![None; n],
            sparse,
        })
    }

    /// [`Lcp::boxed`] with the non-zero pattern of `m` already known (`sparse` lists
    /// every non-zero entry of `m` with its value): no pass over the whole of `m`; only
    /// the listed values are checked for finiteness.
    pub(crate) fn boxed_sparse(
        m: Vec<f64>,
        sparse: SparseRows,
        q: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
    ) -> Result<Lcp, LcpError> {
        let n = q.len();
        check_len("m", n * n, m.len())?;
        check_len("lo", n, lo.len())?;
        check_len("hi", n, hi.len())?;
        // The crate's callers build the pattern from a checked one.
        debug_assert!(sparse.is_valid(n));
        debug_assert!(sparse
            .to_dense()
            .iter()
            .zip(&m)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan())));
        if let Some(k) = sparse.vals.iter().position(|x| !x.is_finite()) {
            let i = sparse.start.partition_point(|&s| s <= k) - 1;
            return Err(LcpError::NonFinite {
                what: "m",
                index: i * n + sparse.cols[k],
            });
        }
        check_finite("q", &q)?;
        check_bounds(&lo, &hi)?;
        Ok(Lcp {
            n,
            m,
            q,
            lo,
            hi,
            friction: vec![None; n],
            sparse,
        })
    }

    /// Adds friction-scaled bounds: `friction[i] = Some((n, μ))` makes row `i`'s bounds
    /// `[−μ z_n, μ z_n]` (pyramidal cone `|z_i| ≤ μ z_n`).
    pub fn with_friction(mut self, friction: Vec<Option<(usize, f64)>>) -> Result<Lcp, LcpError> {
        check_len("friction", self.n, friction.len())?;
        for (i, link) in friction.iter().enumerate() {
            if let Some((k, mu)) = *link {
                let ok = k < self.n
                    && k != i
                    && friction[k].is_none()
                    && self.lo[k] >= 0.0
                    && mu.is_finite()
                    && mu >= 0.0;
                if !ok {
                    return Err(LcpError::BadFriction { index: i });
                }
            }
        }
        self.friction = friction;
        Ok(self)
    }

    /// A contact problem with rows ordered `(normal, tangent 1, tangent 2)` per contact:
    /// `n = 3 · mu.len()`, normal rows `z ≥ 0`, tangent rows `|z_t| ≤ μ_c z_n`.
    pub fn contact(m: Vec<f64>, q: Vec<f64>, mu: &[f64]) -> Result<Lcp, LcpError> {
        let n = 3 * mu.len();
        check_len("q", n, q.len())?;
        let mut lo = vec![0.0; n];
        let mut hi = vec![f64::INFINITY; n];
        let mut friction = vec![None; n];
        for (c, &m_c) in mu.iter().enumerate() {
            for t in 1..3 {
                lo[3 * c + t] = f64::NEG_INFINITY;
                hi[3 * c + t] = f64::INFINITY;
                friction[3 * c + t] = Some((3 * c, m_c));
            }
        }
        Lcp::boxed(m, q, lo, hi)?.with_friction(friction)
    }

    /// The empty problem (`n = 0`).
    pub fn empty() -> Lcp {
        Lcp {
            n: 0,
            m: Vec::new(),
            q: Vec::new(),
            lo: Vec::new(),
            hi: Vec::new(),
            friction: Vec::new(),
            sparse: SparseRows {
                start: vec![0],
                ..SparseRows::default()
            },
        }
    }

    /// Gives back `M` (dense row-major) and its sparse rows, for a caller that refills
    /// the same buffers for its next problem (no allocation once they have grown).
    pub(crate) fn into_matrix(self) -> (Vec<f64>, SparseRows) {
        (self.m, self.sparse)
    }

    /// Number of unknowns.
    pub fn n(&self) -> usize {
        self.n
    }

    /// `M`, row-major `n × n`.
    pub fn m(&self) -> &[f64] {
        &self.m
    }

    /// `M_ij`.
    #[inline]
    pub fn m_ij(&self, i: usize, j: usize) -> f64 {
        self.m[i * self.n + j]
    }

    /// Row `i` of `M`.
    #[inline]
    pub fn row(&self, i: usize) -> &[f64] {
        &self.m[i * self.n..(i + 1) * self.n]
    }

    /// `q`.
    pub fn q(&self) -> &[f64] {
        &self.q
    }

    /// Stored lower bounds (ignored on friction-scaled rows).
    pub fn lo(&self) -> &[f64] {
        &self.lo
    }

    /// Stored upper bounds (ignored on friction-scaled rows).
    pub fn hi(&self) -> &[f64] {
        &self.hi
    }

    /// Friction links `(normal row, μ)`.
    pub fn friction(&self) -> &[Option<(usize, f64)>] {
        &self.friction
    }

    /// Replaces the stored bounds (same `n`; checked as in [`Lcp::boxed`]), e.g. a boxed
    /// problem whose boxes moved while `M` stayed: no second pass over `M`.
    pub fn set_bounds(&mut self, lo: Vec<f64>, hi: Vec<f64>) -> Result<(), LcpError> {
        self.swap_bounds(lo, hi).map(drop)
    }

    /// [`Lcp::set_bounds`] giving back the replaced buffers `(lo, hi)` (refilled by the
    /// caller next time). On an error `lo` and `hi` are dropped.
    pub(crate) fn swap_bounds(
        &mut self,
        lo: Vec<f64>,
        hi: Vec<f64>,
    ) -> Result<(Vec<f64>, Vec<f64>), LcpError> {
        check_len("lo", self.n, lo.len())?;
        check_len("hi", self.n, hi.len())?;
        check_bounds(&lo, &hi)?;
        for (i, link) in self.friction.iter().enumerate() {
            if matches!(*link, Some((k, _)) if lo[k] < 0.0) {
                return Err(LcpError::BadFriction { index: i });
            }
        }
        Ok((
            core::mem::replace(&mut self.lo, lo),
            core::mem::replace(&mut self.hi, hi),
        ))
    }

    /// `M` row-major when every row lists all `n` columns (a Delassus block of a tree
    /// whose contacts all share its bodies): then row `i`'s non-zeros are `M`'s row
    /// `i` whole, in column order, and [`Lcp::row_dot`] is `M_i · z` over contiguous
    /// slices, the same terms in the same order (the same bits). For the sweeps that
    /// run over every row (PGS, `w = M z + q`): no row starts to read per row.
    #[inline]
    pub(crate) fn full_rows(&self) -> Option<&[f64]> {
        (self.n > 0 && self.sparse.vals.len() == self.n * self.n).then_some(&self.m[..])
    }

    /// `Σ_j M_ij z_j` over the non-zero `M_ij` (columns ascending: the bits of the dense
    /// sum, whose skipped terms are `±0`). A row with all `n` entries listed (a
    /// Delassus row of a tree whose contacts all share its bodies: humanoid_CMU's) has
    /// columns `0, 1, …, n−1`, so its values are the dense row: the product runs over the
    /// contiguous slices `vals · z` without the column gather, the same terms in the
    /// same order (the same bits).
    #[inline]
    pub fn row_dot(&self, i: usize, z: &[f64]) -> f64 {
        let (cols, vals) = self.sparse.row(i);
        if cols.len() == z.len() {
            vals.iter().zip(z).map(|(v, x)| v * x).sum()
        } else {
            vals.iter().zip(cols).map(|(v, &j)| v * z[j]).sum()
        }
    }

    /// Row `i`'s non-zero entries of `M`: columns (ascending) and values.
    #[inline]
    pub fn row_nonzeros(&self, i: usize) -> (&[usize], &[f64]) {
        self.sparse.row(i)
    }

    /// Replaces `q` (same `n`, finite), e.g. for the next time step of the same contacts.
    pub fn set_q(&mut self, q: Vec<f64>) -> Result<(), LcpError> {
        self.swap_q(q).map(drop)
    }

    /// [`Lcp::set_q`] giving back the replaced buffer (for a caller that refills it
    /// next time: no allocation once it has grown). On an error `q` is dropped.
    pub(crate) fn swap_q(&mut self, q: Vec<f64>) -> Result<Vec<f64>, LcpError> {
        check_len("q", self.n, q.len())?;
        check_finite("q", &q)?;
        Ok(core::mem::replace(&mut self.q, q))
    }

    /// Whether this is a standard LCP (`lo = 0`, `hi = ∞`, no friction links).
    pub fn is_standard(&self) -> bool {
        self.friction.iter().all(Option::is_none)
            && self.lo.iter().all(|&l| l == 0.0)
            && self.hi.iter().all(|&h| h == f64::INFINITY)
    }

    /// Bounds of row `i` at the point `z` (friction rows read `z` of their normal).
    #[inline]
    pub fn bounds(&self, i: usize, z: &[f64]) -> (f64, f64) {
        match self.friction[i] {
            Some((k, mu)) => {
                let b = mu * z[k].max(0.0);
                (-b, b)
            }
            None => (self.lo[i], self.hi[i]),
        }
    }

    /// `w = M z + q`.
    pub fn w(&self, z: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.n);
        self.w_into(z, &mut out);
        out
    }

    /// [`Lcp::w`] into `out` (cleared first; its buffer is kept: no allocation once it
    /// has grown to `n`).
    pub fn w_into(&self, z: &[f64], out: &mut Vec<f64>) {
        out.clear();
        match self.full_rows().filter(|_| z.len() == self.n) {
            Some(m) => {
                let rows = m.chunks_exact(self.n).zip(&self.q);
                out.extend(rows.map(|(row, &qi)| qi + full_dot(row, z)));
            }
            None => out.extend((0..self.n).map(|i| self.q[i] + self.row_dot(i, z))),
        }
    }

    /// `max(1, |q|_∞)`, the residual's scale.
    pub fn scale(&self) -> f64 {
        self.q.iter().fold(1.0_f64, |a, &x| a.max(libm::fabs(x)))
    }

    /// The natural-map residual `|z − mid(lo, z − w, hi)|_∞ / max(1, |q|_∞)` with
    /// `w = M z + q`; for the standard LCP `|z − max(0, z − w)|_∞ / max(1, |q|_∞)`. It is
    /// zero exactly at solutions; `+∞` for a `z` of the wrong length or with NaN/∞.
    pub fn residual(&self, z: &[f64]) -> f64 {
        if z.len() != self.n {
            return f64::INFINITY;
        }
        let w = self.w(z);
        self.residual_with(z, &w)
    }

    /// [`Lcp::residual`] with a precomputed `w` (must be `M z + q`).
    pub fn residual_with(&self, z: &[f64], w: &[f64]) -> f64 {
        if z.len() != self.n || w.len() != self.n {
            return f64::INFINITY;
        }
        let mut r = 0.0_f64;
        for i in 0..self.n {
            if !z[i].is_finite() || !w[i].is_finite() {
                return f64::INFINITY;
            }
            let (lo, hi) = self.bounds(i, z);
            let p = (z[i] - w[i]).max(lo).min(hi);
            r = r.max(libm::fabs(z[i] - p));
        }
        r / self.scale()
    }

    /// [`Lcp::w_into`] then [`Lcp::residual_with`] in one pass over the rows, with the
    /// residual's scale given (`scale` must be [`Lcp::scale`]): the same `w` and the
    /// same residual, bit for bit (each `w_i = q_i + Σ_j M_ij z_j` as `w_into` sums it,
    /// the natural map's `max` over the rows in the same order, `+∞` from the first
    /// non-finite `z_i` or `w_i` on). For a solver that checks its residual after each
    /// sweep (PGS).
    pub(crate) fn w_residual_into(&self, z: &[f64], out: &mut Vec<f64>, scale: f64) -> f64 {
        debug_assert_eq!(z.len(), self.n);
        debug_assert_eq!(scale.to_bits(), self.scale().to_bits());
        out.clear();
        let mut r = 0.0_f64;
        let mut finite = z.len() == self.n;
        let full = self.full_rows().filter(|_| finite);
        for i in 0..self.n {
            let dot = match full {
                Some(m) => full_dot(&m[i * self.n..(i + 1) * self.n], z),
                None => self.row_dot(i, z),
            };
            let wi = self.q[i] + dot;
            out.push(wi);
            if finite {
                if !z[i].is_finite() || !wi.is_finite() {
                    finite = false;
                } else {
                    let (lo, hi) = self.bounds(i, z);
                    let p = (z[i] - wi).max(lo).min(hi);
                    r = r.max(libm::fabs(z[i] - p));
                }
            }
        }
        if finite {
            r / scale
        } else {
            f64::INFINITY
        }
    }

    /// The round-off floor of [`Lcp::residual`] at `z`, in its units:
    ///
    /// ```text
    /// max_i (2 ε |z_i| + γ (|q_i| + Σ_j |M_ij z_j|)) / max(1, |q|_∞),    γ = (n + 1) ε
    /// ```
    ///
    /// the a-priori bound on the error of evaluating `w_i = q_i + Σ_j M_ij z_j` in
    /// floating point (Higham 2002, *Accuracy and Stability of Numerical Algorithms*,
    /// §3.1: `|fl(xᵀy) − xᵀy| ≤ γ_n |x|ᵀ|y|`) plus the two roundings of
    /// `z_i − mid(lo, z_i − w_i, hi)` (an ulp of `z_i` each: `z_i − w_i` cannot resolve a
    /// `w_i` below it). A solver cannot be sure to get below it: with a light body between
    /// a heavy one and the ground the impulses are `10⁴…10⁶` times `|q|`, `w` is a
    /// difference of terms that large, and a fixed tolerance relative to `|q|` alone
    /// (`1e-10`) is below the floor from a mass ratio of about `10⁵` on. So the
    /// iterative solvers still iterate to their tolerance, but where they run out of
    /// iterations (or stall) an answer at the floor is accepted
    /// ([`Lcp::accepts`]: residual ≤ `max(tolerance, floor)`), and Lemke's final answer
    /// is judged the same way. On well-scaled problems the floor is orders of magnitude
    /// below any tolerance and changes nothing.
    pub fn round_off(&self, z: &[f64]) -> f64 {
        if z.len() != self.n {
            return f64::INFINITY;
        }
        // Over the listed entries only (columns ascending, as `row_dot`): a skipped term
        // `|0 · z_j|` of a finite `z` is `+0`, which leaves the sum's bits as they are
        // (the sum of an empty list is `−0`, and `|q_i| + (−0) = |q_i|`). A non-finite
        // `z` goes over the dense rows (`0 · ∞` is NaN there).
        let finite = z.iter().all(|x| x.is_finite());
        let mut worst = 0.0_f64;
        for i in 0..self.n {
            let (cols, vals) = self.sparse.row(i);
            let s: f64 = if finite && cols.len() < self.n {
                vals.iter()
                    .zip(cols)
                    .map(|(m, &j)| libm::fabs(m * z[j]))
                    .sum()
            } else {
                // A full row (every column listed) is the dense row: contiguous.
                self.row(i)
                    .iter()
                    .zip(z)
                    .map(|(m, x)| libm::fabs(m * x))
                    .sum()
            };
            let gamma = (self.n as f64 + 1.0) * f64::EPSILON;
            let floor = 2.0 * f64::EPSILON * libm::fabs(z[i]) + gamma * (libm::fabs(self.q[i]) + s);
            worst = worst.max(floor);
        }
        worst / self.scale()
    }

    /// Whether `residual` (of [`Lcp::residual`] at `z`) is an acceptable answer for
    /// `tolerance`: at most `max(tolerance, round_off(z))` ([`Lcp::round_off`]; the
    /// floor is evaluated only when the tolerance alone is missed). A non-finite floor
    /// (an overflowing `|M||z|`, a non-finite `z`) accepts nothing: an answer that
    /// overflowed is never passed on as one at the round-off limit.
    pub fn accepts(&self, z: &[f64], residual: f64, tolerance: f64) -> bool {
        if residual <= tolerance {
            return true;
        }
        let floor = self.round_off(z);
        floor.is_finite() && residual <= floor
    }

    /// Validates a warm-start / initial vector.
    pub(crate) fn check_vector(&self, what: &'static str, z: &[f64]) -> Result<(), LcpError> {
        check_len(what, self.n, z.len())?;
        check_finite(what, z)
    }

    /// Packs `z` into a solution if its residual meets `tolerance`, else `Inaccurate`.
    pub(crate) fn finish(
        &self,
        z: Vec<f64>,
        iterations: usize,
        basis: Option<Vec<bool>>,
        tolerance: f64,
    ) -> Result<LcpSolution, LcpError> {
        let w = self.w(&z);
        self.finish_with(z, w, iterations, basis, tolerance)
    }

    /// The solution `z` whose residual the caller has just computed
    /// (`residual = self.residual_with(&z, &w)`, `w = M z + q`) and found within its
    /// tolerance: [`Lcp::finish_with`]'s answer (it accepts), without evaluating the
    /// residual a second time.
    pub(crate) fn solved(
        z: Vec<f64>,
        w: Vec<f64>,
        residual: f64,
        iterations: usize,
    ) -> LcpSolution {
        LcpSolution {
            z,
            w,
            residual,
            iterations,
            basis: None,
        }
    }

    /// [`Lcp::finish`] with `w = M z + q` already evaluated (must be `self.w(&z)`: the
    /// same bits, one pass over `M` saved).
    pub(crate) fn finish_with(
        &self,
        z: Vec<f64>,
        w: Vec<f64>,
        iterations: usize,
        basis: Option<Vec<bool>>,
        tolerance: f64,
    ) -> Result<LcpSolution, LcpError> {
        let residual = self.residual_with(&z, &w);
        if self.accepts(&z, residual, tolerance) {
            Ok(LcpSolution {
                z,
                w,
                residual,
                iterations,
                basis,
            })
        } else {
            Err(LcpError::Inaccurate {
                residual,
                tolerance,
            })
        }
    }
}

/// Bounds with `lo_i > hi_i`, a NaN bound, `lo_i = +∞` or `hi_i = −∞` are rejected.
fn check_bounds(lo: &[f64], hi: &[f64]) -> Result<(), LcpError> {
    for (i, (&l, &h)) in lo.iter().zip(hi).enumerate() {
        if l.is_nan() || h.is_nan() || l > h || l == f64::INFINITY || h == f64::NEG_INFINITY {
            return Err(LcpError::BadBounds { index: i });
        }
    }
    Ok(())
}

pub(crate) fn check_tolerance(tolerance: f64) -> Result<(), LcpError> {
    if tolerance > 0.0 && tolerance.is_finite() {
        Ok(())
    } else {
        Err(LcpError::BadSettings("tolerance must be finite and > 0"))
    }
}

/// `row · z` summed in column order from the first term: [`Lcp::row_dot`]'s full-row
/// product (the same bits), for a row of [`Lcp::full_rows`].
#[inline(always)]
fn full_dot(row: &[f64], z: &[f64]) -> f64 {
    row.iter().zip(z).map(|(v, x)| v * x).sum()
}
