//! The KKT system of a constrained step and its solution.
//!
//! Otaduy 2010, "Opción 2" and "Multiplicadores de Lagrange — hay que resolver sistemas
//! del tipo `[A Jᵀ; J 0]`":
//!
//! ```text
//! [A  Jᵀ] [x]   [b]          A: masses (or the implicit soft matrix), per point
//! [J  −D] [λ] = [c]          D = diag(α/h²) ≥ 0: compliance (0 for hard rows)
//! ```
//!
//! The constraint force is `−Jᵀλ`. Solvers, as the lecture lists them:
//!
//! * **Schur complement** ("si A es fácil de invertir, se sustituye la primera ecuación
//!   en la segunda"): `(J A⁻¹ Jᵀ + D) λ = J A⁻¹ b − c`, then `x = A⁻¹(b − Jᵀλ)`; dense
//!   Cholesky for small systems (no `std` needed), sparse Cholesky (faer, symbolic
//!   analysis reused) for large ones. Needs a diagonal `A`.
//! * **MINRES / GMRES** ("si es disperso") on the whole symmetric indefinite matrix,
//!   matrix-free; any `A`.
//! * **SVD / damped least squares** ("SVD si es incompatible (overconstrained)"): the
//!   minimum-norm multipliers of a rank-deficient Schur system (redundant constraints,
//!   closed loops).
//!
//! Pinned points have prescribed (zero) unknowns: their rows of `A` are the identity,
//! their right-hand side zero, and their Jacobian blocks must be zero
//! ([`ConstraintRows::zero_columns`]).
//!
//! Every solve reports the relative residual of the whole KKT system,
//! `|K [x; λ] − rhs| / |rhs|`, whatever the solver.

use crate::rows::ConstraintRows;
use crate::solve::{self, DenseMatrix, IterSettings, LinearOperator, SolveError};
use alloc::vec::Vec;
use constraint_core::DVec3;

/// The `A` block.
#[derive(Clone, Copy, Debug)]
pub enum MassMatrix<'a> {
    /// One mass per point (`A = diag(m_i I₃)`); pinned points are prescribed.
    Diagonal {
        /// Masses (kg), positive.
        mass: &'a [f64],
        /// Prescribed points.
        pinned: &'a [bool],
    },
    /// A symmetric 3×3-block matrix, e.g. the linearized implicit soft step's
    /// `M − h∂F/∂v − h²∂F/∂x` (pinned rows already the identity times the mass).
    #[cfg(feature = "std")]
    Block {
        /// The matrix.
        a: &'a constraint_soft::bsr::BlockMatrix,
        /// Prescribed points.
        pinned: &'a [bool],
    },
}

impl MassMatrix<'_> {
    fn points(&self) -> usize {
        match self {
            Self::Diagonal { mass, .. } => mass.len(),
            #[cfg(feature = "std")]
            Self::Block { a, .. } => a.pattern.len(),
        }
    }

    fn pinned(&self) -> &[bool] {
        match self {
            Self::Diagonal { pinned, .. } => pinned,
            #[cfg(feature = "std")]
            Self::Block { pinned, .. } => pinned,
        }
    }

    /// `y = A x` (identity rows for pinned points).
    fn apply(&self, x: &[DVec3], y: &mut [DVec3]) {
        match self {
            Self::Diagonal { mass, pinned } => {
                for i in 0..x.len() {
                    y[i] = if pinned[i] { x[i] } else { x[i] * mass[i] };
                }
            }
            #[cfg(feature = "std")]
            Self::Block { a, .. } => a.mul_vec(x, y),
        }
    }

    /// `1/m_i` (0 for pinned points) when `A` is diagonal.
    fn inverse_diagonal(&self, out: &mut Vec<f64>) -> bool {
        match self {
            Self::Diagonal { mass, pinned } => {
                out.clear();
                out.extend(
                    mass.iter()
                        .zip(pinned.iter())
                        .map(|(m, p)| if *p { 0.0 } else { 1.0 / m }),
                );
                true
            }
            #[cfg(feature = "std")]
            Self::Block { .. } => false,
        }
    }
}

/// A KKT system `[A Jᵀ; J −D][x; λ] = [b; c]`.
#[derive(Clone, Copy, Debug)]
pub struct KktProblem<'a> {
    /// `A`.
    pub mass: MassMatrix<'a>,
    /// `J` (with zero blocks for pinned points).
    pub rows: &'a ConstraintRows,
    /// `D = diag(α/h²)`, one entry per row (≥ 0).
    pub compliance: &'a [f64],
    /// `b`, one 3-vector per point (zero for pinned points).
    pub b: &'a [DVec3],
    /// `c`, one entry per row.
    pub c: &'a [f64],
}

/// Which solver to use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KktSolver {
    /// Chosen by size and structure: with a diagonal `A`, the dense Schur complement up
    /// to [`AUTO_DENSE_ROWS`] rows and the sparse one above (MINRES without the
    /// `sparse` feature); with a block `A`, MINRES. [`KktStats::chosen`] says which.
    Auto,
    /// Dense Cholesky of the Schur complement, falling back to the SVD when the
    /// complement is singular (redundant constraints). Needs a diagonal `A`.
    DenseSchur,
    /// Sparse Cholesky (faer) of the Schur complement; when it is singular (redundant
    /// constraints), the dense minimum-norm SVD up to [`SPARSE_SVD_FALLBACK_ROWS`] rows
    /// and MINRES from zero above ([`KktStats::chosen`] then says MINRES). Needs a
    /// diagonal `A`.
    #[cfg(feature = "sparse")]
    SparseSchur,
    /// MINRES on the whole KKT matrix.
    Minres(IterSettings),
    /// Restarted GMRES on the whole KKT matrix.
    Gmres {
        /// Restart length.
        restart: usize,
        /// Stopping rule.
        settings: IterSettings,
    },
    /// Minimum-norm least squares by SVD of the dense Schur complement; singular values
    /// below `rank_tol · σ_max` count as zero.
    Svd {
        /// Relative rank tolerance.
        rank_tol: f64,
    },
    /// Damped least squares `(SᵀS + μ²I) λ = Sᵀ r` on the dense Schur complement.
    DampedLeastSquares {
        /// Damping `μ`.
        damping: f64,
    },
}

impl KktSolver {
    /// The solver a solve runs for a problem with `rows` rows and a diagonal (`true`)
    /// or block `A`: [`KktSolver::Auto`] resolved by its rule, any other solver itself.
    /// [`KktStats::chosen`] reports the same after a solve.
    pub fn resolve(self, diagonal_mass: bool, rows: usize) -> KktSolver {
        match self {
            KktSolver::Auto if diagonal_mass && rows <= AUTO_DENSE_ROWS => KktSolver::DenseSchur,
            #[cfg(feature = "sparse")]
            KktSolver::Auto if diagonal_mass => KktSolver::SparseSchur,
            KktSolver::Auto => KktSolver::Minres(IterSettings::default()),
            s => s,
        }
    }
}

/// Largest number of rows [`KktSolver::Auto`] hands to the dense Schur solve.
pub const AUTO_DENSE_ROWS: usize = 300;

/// What a KKT solve did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KktStats {
    /// The solver actually used (differs from the request for [`KktSolver::Auto`]).
    pub chosen: Option<KktSolver>,
    /// Iterations (1 for direct solves).
    pub iterations: usize,
    /// Relative residual of the whole KKT system.
    pub residual: f64,
    /// Whether the solver met its own stopping rule.
    pub converged: bool,
    /// Numerical rank of the Schur complement (SVD paths), else the number of rows.
    pub rank: usize,
    /// Residual history (iterative solvers).
    pub history: Vec<f64>,
}

/// Errors of a KKT solve.
#[derive(Clone, Debug, PartialEq)]
pub enum KktError {
    /// Sizes of `A`, `J`, `b`, `c` or `D` disagree.
    DimensionMismatch,
    /// The chosen Schur solver needs a diagonal `A`.
    NeedsDiagonalMass,
    /// A linear-algebra failure.
    Solve(SolveError),
    /// The sparse factorization failed.
    Factorization,
    /// A solver parameter was out of range (named).
    InvalidSolver(&'static str),
}

impl core::fmt::Display for KktError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::DimensionMismatch => f.write_str("KKT blocks have inconsistent sizes"),
            Self::NeedsDiagonalMass => {
                f.write_str("the Schur-complement solvers need a diagonal A; use MINRES or GMRES")
            }
            Self::Solve(e) => write!(f, "{e}"),
            Self::Factorization => f.write_str("sparse Cholesky factorization failed"),
            Self::InvalidSolver(p) => write!(f, "solver parameter {p} out of range"),
        }
    }
}

impl core::error::Error for KktError {}

impl From<SolveError> for KktError {
    fn from(e: SolveError) -> Self {
        Self::Solve(e)
    }
}

impl KktProblem<'_> {
    fn check(&self) -> Result<(), KktError> {
        let n = self.mass.points();
        let m = self.rows.len();
        if self.b.len() != n
            || self.c.len() != m
            || self.compliance.len() != m
            || self.mass.pinned().len() != n
            || self.rows.entries().any(|(_, i, _)| i >= n)
        {
            return Err(KktError::DimensionMismatch);
        }
        Ok(())
    }

    /// `|K [x; λ] − rhs| / |rhs|`.
    pub fn residual(&self, x: &[DVec3], lambda: &[f64]) -> f64 {
        let n = x.len();
        let mut ax = alloc::vec![DVec3::ZERO; n];
        self.mass.apply(x, &mut ax);
        self.rows.mul_transpose_add(lambda, &mut ax);
        let mut jx = alloc::vec![0.0; self.rows.len()];
        self.rows.mul(x, &mut jx);
        let mut num = 0.0;
        let mut den = 0.0;
        for (r, bi) in ax.iter().zip(self.b) {
            num += (*r - *bi).length_squared();
            den += bi.length_squared();
        }
        for k in 0..jx.len() {
            let r = jx[k] - self.compliance[k] * lambda[k] - self.c[k];
            num += r * r;
            den += self.c[k] * self.c[k];
        }
        if den > 0.0 {
            libm_sqrt(num / den)
        } else {
            libm_sqrt(num)
        }
    }

    /// The dense Schur complement `S = J W Jᵀ + D` (`W = A⁻¹` diagonal) and the
    /// right-hand side `J W b − c`.
    pub fn dense_schur(&self, w: &[f64]) -> (DenseMatrix, Vec<f64>) {
        let m = self.rows.len();
        let mut s = DenseMatrix::zeros(m, m);
        // Entries grouped by point: S += w_i g_r g_sᵀ for every pair of rows at point i.
        let mut by_point: Vec<(usize, usize, DVec3)> = self
            .rows
            .entries()
            .map(|(r, i, g)| (i, r, g))
            .filter(|(i, _, g)| w[*i] != 0.0 && *g != DVec3::ZERO)
            .collect();
        by_point.sort_by_key(|e| (e.0, e.1));
        let mut a = 0;
        while a < by_point.len() {
            let i = by_point[a].0;
            let mut b = a;
            while b < by_point.len() && by_point[b].0 == i {
                b += 1;
            }
            for p in a..b {
                for q in a..b {
                    let (r, s_) = (by_point[p].1, by_point[q].1);
                    let v = s.get(r, s_) + w[i] * by_point[p].2.dot(by_point[q].2);
                    s.set(r, s_, v);
                }
            }
            a = b;
        }
        for (r, d) in self.compliance.iter().enumerate() {
            let v = s.get(r, r) + d;
            s.set(r, r, v);
        }
        let wb: Vec<DVec3> = self.b.iter().zip(w).map(|(b, w)| *b * *w).collect();
        let mut rhs = alloc::vec![0.0; m];
        self.rows.mul(&wb, &mut rhs);
        for (r, c) in rhs.iter_mut().zip(self.c) {
            *r -= c;
        }
        (s, rhs)
    }

    /// `x = W (b − Jᵀ λ)`.
    fn back_substitute(&self, w: &[f64], lambda: &[f64], x: &mut [DVec3]) {
        let mut f: Vec<DVec3> = self.b.to_vec();
        let mut jtl = alloc::vec![DVec3::ZERO; f.len()];
        self.rows.mul_transpose_add(lambda, &mut jtl);
        for i in 0..f.len() {
            f[i] -= jtl[i];
            x[i] = f[i] * w[i];
        }
    }
}

fn libm_sqrt(x: f64) -> f64 {
    <f64 as nalgebra::ComplexField>::sqrt(x)
}

/// The whole KKT matrix as a flat operator on `[x (3n); λ (m)]`. The two point-sized
/// scratch vectors are allocated once per solve, not per product.
struct KktOperator<'a, 'b> {
    p: &'b KktProblem<'a>,
    n: usize,
    scratch: core::cell::RefCell<(Vec<DVec3>, Vec<DVec3>)>,
}

impl LinearOperator for KktOperator<'_, '_> {
    fn dim(&self) -> usize {
        3 * self.n + self.p.rows.len()
    }

    fn apply(&self, z: &[f64], y: &mut [f64]) {
        let n = self.n;
        let mut scratch = self.scratch.borrow_mut();
        let (x, ax) = &mut *scratch;
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = DVec3::from_slice(&z[3 * i..3 * i + 3]);
        }
        let lambda = &z[3 * n..];
        self.p.mass.apply(x, ax);
        self.p.rows.mul_transpose_add(lambda, ax);
        for i in 0..n {
            y[3 * i..3 * i + 3].copy_from_slice(&ax[i].to_array());
        }
        let (_, yl) = y.split_at_mut(3 * n);
        self.p.rows.mul(x, yl);
        for (k, yk) in yl.iter_mut().enumerate() {
            *yk -= self.p.compliance[k] * lambda[k];
        }
    }
}

/// Largest number of rows for which a failed sparse Cholesky (a singular Schur
/// complement: redundant constraints) falls back to the dense minimum-norm SVD solve;
/// above it the fallback is MINRES on the whole KKT system from `λ = 0` (the one-sided
/// Jacobi SVD costs about n³·10 flops: 0.9 s at 400 rows, 9 s at 800, measured on this
/// project's machine). From a zero start MINRES stays in the range of the (singular,
/// consistent) system, so it converges to the same minimum-norm multipliers.
pub const SPARSE_SVD_FALLBACK_ROWS: usize = 300;

/// Reusable scratch for [`solve_kkt`]: the sparse analysis (kept while the row
/// structure is unchanged) and the MINRES/GMRES work vectors. (The Schur right-hand
/// side, the dense complement and the residual check still allocate once per call —
/// per step or projection iteration, never per inner iteration.)
#[derive(Debug, Default)]
pub struct KktWorkspace {
    #[cfg(feature = "sparse")]
    sparse: crate::sparse::SparseSchur,
    w: Vec<f64>,
    minres: solve::MinresWork,
    gmres: solve::GmresWork,
}

impl KktWorkspace {
    /// Number of sparse symbolic analyses performed so far.
    #[cfg(feature = "sparse")]
    pub fn analyses(&self) -> usize {
        self.sparse.analyses
    }
}

fn check_solver(solver: KktSolver) -> Result<(), KktError> {
    let nonneg = |v: f64| v >= 0.0 && v.is_finite();
    match solver {
        KktSolver::Svd { rank_tol } if !nonneg(rank_tol) => {
            Err(KktError::InvalidSolver("rank_tol"))
        }
        KktSolver::DampedLeastSquares { damping } if !nonneg(damping) => {
            Err(KktError::InvalidSolver("damping"))
        }
        KktSolver::Gmres { restart: 0, .. } => Err(KktError::InvalidSolver("restart")),
        KktSolver::Minres(s) | KktSolver::Gmres { settings: s, .. }
            if !(s.tolerance > 0.0 && s.tolerance.is_finite()) =>
        {
            Err(KktError::InvalidSolver("tolerance"))
        }
        _ => Ok(()),
    }
}

/// Solves `problem`, writing `x` and `λ` (both used as the initial guess by the
/// iterative solvers).
///
/// # Errors
/// [`KktError`] for inconsistent sizes, a solver parameter out of range, a Schur
/// solver with a non-diagonal `A`, or a failed factorization. A non-converged iterative solve is **not** an error: it is
/// reported in [`KktStats::converged`] and [`KktStats::residual`].
pub fn solve_kkt(
    problem: &KktProblem<'_>,
    solver: KktSolver,
    ws: &mut KktWorkspace,
    x: &mut [DVec3],
    lambda: &mut [f64],
) -> Result<KktStats, KktError> {
    // Non-finite input, or a solve that overflows (a zero mass, 1e300 entries, a tiny
    // compliance against a huge right-hand side), is an error, never an `Ok` holding
    // NaN or infinity.
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if !problem.b.iter().all(|b| b.is_finite())
        || !finite(problem.c)
        || !finite(problem.compliance)
        || !problem.rows.blocks().iter().all(|b| b.is_finite())
    {
        return Err(KktError::Solve(SolveError::NonFinite));
    }
    let stats = solve_kkt_unchecked(problem, solver, ws, x, lambda)?;
    if !x.iter().all(|v| v.is_finite()) || !finite(lambda) || !stats.residual.is_finite() {
        return Err(KktError::Solve(SolveError::NonFinite));
    }
    Ok(stats)
}

fn solve_kkt_unchecked(
    problem: &KktProblem<'_>,
    solver: KktSolver,
    ws: &mut KktWorkspace,
    x: &mut [DVec3],
    lambda: &mut [f64],
) -> Result<KktStats, KktError> {
    problem.check()?;
    check_solver(solver)?;
    let n = problem.mass.points();
    let m = problem.rows.len();
    if x.len() != n || lambda.len() != m {
        return Err(KktError::DimensionMismatch);
    }
    let w = &mut ws.w;
    let diagonal = problem.mass.inverse_diagonal(w);
    let solver = solver.resolve(diagonal, m);
    let mut stats = KktStats {
        chosen: Some(solver),
        iterations: 1,
        converged: true,
        rank: m,
        ..KktStats::default()
    };
    match solver {
        KktSolver::DenseSchur | KktSolver::Svd { .. } | KktSolver::DampedLeastSquares { .. } => {
            if !diagonal {
                return Err(KktError::NeedsDiagonalMass);
            }
            let (s, rhs) = problem.dense_schur(w);
            let sol = match solver {
                KktSolver::Svd { rank_tol } => {
                    let r = solve::svd::min_norm_solve(&s, &rhs, rank_tol)?;
                    stats.rank = r.rank;
                    r.x
                }
                KktSolver::DampedLeastSquares { damping } => {
                    solve::svd::damped_solve(&s, &rhs, damping)?
                }
                // Dense Schur: Cholesky, or the minimum-norm SVD solve when the
                // complement is singular (redundant hard constraints).
                _ => match solve::Cholesky::factor(&s).and_then(|c| c.solve(&rhs)) {
                    Ok(l) => l,
                    Err(SolveError::NotPositiveDefinite { .. }) => {
                        let tol = solve::SvdSolver::default_tolerance(m, m).max(1e-12);
                        let r = solve::svd::min_norm_solve(&s, &rhs, tol)?;
                        stats.rank = r.rank;
                        r.x
                    }
                    Err(e) => return Err(e.into()),
                },
            };
            lambda.copy_from_slice(&sol);
            problem.back_substitute(w, lambda, x);
        }
        #[cfg(feature = "sparse")]
        KktSolver::SparseSchur => {
            if !diagonal {
                return Err(KktError::NeedsDiagonalMass);
            }
            match ws.sparse.solve(problem, w, lambda) {
                Ok(()) => {}
                // Singular complement (redundant hard constraints): minimum-norm
                // multipliers from the dense SVD while the system is small enough.
                Err(KktError::Factorization) if m <= SPARSE_SVD_FALLBACK_ROWS => {
                    let (s, rhs) = problem.dense_schur(w);
                    let tol = solve::SvdSolver::default_tolerance(m, m).max(1e-12);
                    let r = solve::svd::min_norm_solve(&s, &rhs, tol)?;
                    stats.rank = r.rank;
                    lambda.copy_from_slice(&r.x);
                }
                Err(KktError::Factorization) => {
                    x.fill(DVec3::ZERO);
                    lambda.fill(0.0);
                    return solve_kkt_unchecked(
                        problem,
                        KktSolver::Minres(IterSettings::default()),
                        ws,
                        x,
                        lambda,
                    );
                }
                Err(e) => return Err(e),
            }
            problem.back_substitute(w, lambda, x);
        }
        // Resolved above; treated as MINRES should it ever reach here.
        KktSolver::Auto | KktSolver::Minres(_) | KktSolver::Gmres { .. } => {
            let settings = match solver {
                KktSolver::Minres(s) | KktSolver::Gmres { settings: s, .. } => s,
                _ => IterSettings::default(),
            };
            let op = KktOperator {
                p: problem,
                n,
                scratch: core::cell::RefCell::new((
                    alloc::vec![DVec3::ZERO; n],
                    alloc::vec![DVec3::ZERO; n],
                )),
            };
            let mut rhs = alloc::vec![0.0; 3 * n + m];
            for i in 0..n {
                rhs[3 * i..3 * i + 3].copy_from_slice(&problem.b[i].to_array());
            }
            rhs[3 * n..].copy_from_slice(problem.c);
            let mut z = alloc::vec![0.0; 3 * n + m];
            for i in 0..n {
                z[3 * i..3 * i + 3].copy_from_slice(&x[i].to_array());
            }
            z[3 * n..].copy_from_slice(lambda);
            let it = match solver {
                KktSolver::Gmres { restart, .. } => {
                    if ws.gmres.restart() != restart.max(1) {
                        ws.gmres = solve::GmresWork::new(restart.max(1));
                    }
                    solve::gmres(&op, &rhs, &mut z, &settings, &mut ws.gmres)?
                }
                _ => solve::minres(&op, &rhs, &mut z, &settings, &mut ws.minres)?,
            };
            for i in 0..n {
                x[i] = DVec3::from_slice(&z[3 * i..3 * i + 3]);
            }
            lambda.copy_from_slice(&z[3 * n..]);
            stats.iterations = it.iterations;
            stats.converged = it.converged;
            stats.history = it.history;
        }
    }
    stats.residual = problem.residual(x, lambda);
    Ok(stats)
}
