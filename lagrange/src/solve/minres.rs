//! MINRES: minimum-residual Krylov solver for symmetric, possibly indefinite systems.
//!
//! C. C. Paige and M. A. Saunders, "Solution of sparse indefinite systems of linear
//! equations", *SIAM J. Numer. Anal.* 12(4), 1975. The symmetric Lanczos process builds
//! an orthonormal basis `V_k` of the Krylov space `K_k(A, r₀)` with `A V_k = V_{k+1} T_k`
//! (`T_k` tridiagonal); Givens rotations reduce `T_k` to upper triangular form one
//! column at a time, so the iterate minimizing `|b − A x|` over `x₀ + K_k` is updated
//! with a three-term recurrence and the residual norm `|r_k| = φ̄_k` is known without
//! forming `r_k`. The unpreconditioned recurrences follow the reference implementation
//! of Paige & Saunders (as in SciPy's `minres`).
//!
//! MINRES needs only `y = A x` and works for the indefinite KKT saddle-point matrix
//! `[A Jᵀ; J 0]` where conjugate gradients does not apply. `A` must be symmetric; this
//! cannot be checked matrix-free.
//!
//! ## Honest residuals
//!
//! The recurrence `φ̄_k` drifts from the true residual when the matrix is ill
//! conditioned (the Lanczos vectors lose orthogonality). A MINRES run therefore ends when
//! `φ̄_k / |b|` reaches the tolerance or after `n` steps (the exact-arithmetic bound,
//! `n` the dimension); the solver then recomputes `r = b − A x` and, if that is still
//! above the tolerance, restarts MINRES from the current `x` (iterative refinement). It
//! stops as soon as a restart fails to reduce the true residual and then returns the
//! best iterate seen at a restart, so the returned residual never exceeds the initial
//! one. [`IterStats::residual`] is always the recomputed value for the returned `x`.

use super::{
    check_iterative_inputs, dot, hypot, norm, residual, IterSettings, IterStats, LinearOperator,
    SolveError,
};
use alloc::vec::Vec;
use core::mem::swap;

/// Scratch vectors of [`minres`], sized on first use and reused across solves.
#[derive(Clone, Debug, Default)]
pub struct MinresWork {
    r1: Vec<f64>,
    r2: Vec<f64>,
    y: Vec<f64>,
    v: Vec<f64>,
    w: Vec<f64>,
    w1: Vec<f64>,
    w2: Vec<f64>,
    x_best: Vec<f64>,
}

impl MinresWork {
    /// Empty work space; the first solve sizes it.
    pub fn new() -> Self {
        Self::default()
    }

    /// Work space preallocated for dimension `n`.
    pub fn with_dim(n: usize) -> Self {
        let mut w = Self::new();
        w.resize(n);
        w
    }

    fn resize(&mut self, n: usize) {
        for v in [
            &mut self.r1,
            &mut self.r2,
            &mut self.y,
            &mut self.v,
            &mut self.w,
            &mut self.w1,
            &mut self.w2,
            &mut self.x_best,
        ] {
            v.resize(n, 0.0);
        }
    }
}

/// Solves the symmetric system `A x = b` by MINRES.
///
/// `x` holds the initial guess on entry and the best iterate on return (also when not
/// converged). The returned [`IterStats`] has the recomputed relative residual; use
/// [`IterStats::check`] to turn non-convergence into an error.
///
/// Errors: [`SolveError::DimensionMismatch`] unless `b.len() == x.len() == a.dim()`;
/// [`SolveError::NonFinite`] for non-finite `b`, `x`, tolerance, or operator output.
pub fn minres<A: LinearOperator + ?Sized>(
    a: &A,
    b: &[f64],
    x: &mut [f64],
    settings: &IterSettings,
    work: &mut MinresWork,
) -> Result<IterStats, SolveError> {
    let n = a.dim();
    check_iterative_inputs(n, b, x, settings)?;
    work.resize(n);
    let mut stats = IterStats::default();
    let bnorm = norm(b);
    if bnorm == 0.0 {
        x.fill(0.0);
        stats.converged = true;
        return Ok(stats);
    }
    let mut best = f64::INFINITY;
    loop {
        let rnorm = residual(a, b, x, &mut work.r1)?;
        let rel = rnorm / bnorm;
        if !(rel < best) {
            // The last run did not reduce the true residual: return the best iterate.
            x.copy_from_slice(&work.x_best);
            break;
        }
        best = rel;
        work.x_best.copy_from_slice(x);
        if rel <= settings.tolerance || stats.iterations >= settings.max_iterations {
            break;
        }
        cycle(a, x, work, rnorm, bnorm, settings, &mut stats)?;
    }
    stats.residual = best;
    stats.converged = best <= settings.tolerance;
    Ok(stats)
}

/// One MINRES run from `x` with `work.r1 = b − A x`, `|r1| = beta1 > 0`, until the
/// recurrence residual reaches the tolerance, the budget is spent or Lanczos breaks down.
fn cycle<A: LinearOperator + ?Sized>(
    a: &A,
    x: &mut [f64],
    work: &mut MinresWork,
    beta1: f64,
    bnorm: f64,
    settings: &IterSettings,
    stats: &mut IterStats,
) -> Result<(), SolveError> {
    let MinresWork {
        r1,
        r2,
        y,
        v,
        w,
        w1,
        w2,
        ..
    } = work;
    r2.copy_from_slice(r1);
    w.fill(0.0);
    w2.fill(0.0);
    let mut oldb = 0.0;
    let mut beta = beta1;
    let mut dbar = 0.0;
    let mut epsln = 0.0;
    let mut phibar = beta1;
    let mut cs = -1.0;
    let mut sn = 0.0;
    let mut first = true;
    // In exact arithmetic MINRES terminates within n steps; past that only rounding is
    // being iterated, so the run ends and the caller re-anchors on the true residual.
    let n = x.len();
    let mut steps = 0;
    while stats.iterations < settings.max_iterations && steps < n {
        steps += 1;
        // Lanczos step: v = r2/β, y = A v − (β/β_old) r1 − (α/β) r2.
        let s = 1.0 / beta;
        for (vi, ri) in v.iter_mut().zip(r2.iter()) {
            *vi = s * ri;
        }
        a.apply(v, y);
        if !first {
            let f = beta / oldb;
            for (yi, ri) in y.iter_mut().zip(r1.iter()) {
                *yi -= f * ri;
            }
        }
        let alfa = dot(v, y);
        let f = alfa / beta;
        for (yi, ri) in y.iter_mut().zip(r2.iter()) {
            *yi -= f * ri;
        }
        swap(r1, r2);
        swap(r2, y);
        oldb = beta;
        beta = norm(r2);
        if !alfa.is_finite() || !beta.is_finite() {
            return Err(SolveError::NonFinite);
        }

        // Apply the previous rotation, then a new one annihilating β.
        let oldeps = epsln;
        let delta = cs * dbar + sn * alfa;
        let gbar = sn * dbar - cs * alfa;
        epsln = sn * beta;
        dbar = -cs * beta;
        let gamma = hypot(gbar, beta).max(f64::EPSILON);
        cs = gbar / gamma;
        sn = beta / gamma;
        let phi = cs * phibar;
        phibar *= sn;

        // Search direction w = (v − ε w₁ − δ w₂)/γ and update x += φ w.
        swap(w1, w2);
        swap(w2, w);
        let denom = 1.0 / gamma;
        for i in 0..v.len() {
            w[i] = (v[i] - oldeps * w1[i] - delta * w2[i]) * denom;
            x[i] += phi * w[i];
        }
        stats.iterations += 1;
        first = false;

        let estimate = phibar.abs() / bnorm;
        if !estimate.is_finite() {
            return Err(SolveError::NonFinite);
        }
        stats.history.push(estimate);
        if estimate <= settings.tolerance {
            break;
        }
        // The Krylov space is invariant: nothing new can be learned in this run.
        if beta <= f64::EPSILON * (alfa.abs() + oldb) {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{ill_conditioned, rel_err, rel_residual, KktOperator, Rng};
    use super::super::{lu_solve, DenseMatrix};
    use super::*;

    fn tight() -> IterSettings {
        IterSettings {
            tolerance: 1e-14,
            max_iterations: 10_000,
        }
    }

    #[test]
    fn matches_lu_on_symmetric_systems() {
        let mut rng = Rng::new(11);
        let mut work = MinresWork::new();
        let mut worst = 0.0f64;
        let mut worst_res = 0.0f64;
        for case in 0..60 {
            let n = rng.range(1, 40);
            let a = if case % 2 == 0 {
                rng.spd(n)
            } else {
                rng.sym_indefinite(n)
            };
            let b = rng.vec(n);
            let x_ref = lu_solve(&a, &b).unwrap();
            let mut x = alloc::vec![0.0; n];
            let stats = minres(&a, &b, &mut x, &tight(), &mut work).unwrap();
            assert!(stats.converged, "case {case}: {stats:?}");
            assert_eq!(stats.history.len(), stats.iterations);
            let res = rel_residual(&a, &x, &b);
            assert!((res - stats.residual).abs() <= 1e-3 * res.max(1e-300));
            worst_res = worst_res.max(res);
            worst = worst.max(rel_err(&x, &x_ref));
        }
        // Measured worst: error 8.9e-15, residual 8.7e-15.
        eprintln!("MINRES vs LU: worst error {worst:e}, worst residual {worst_res:e}");
        assert!(worst < 9e-14);
    }

    #[test]
    fn solves_saddle_point_kkt_matrix_free() {
        let mut rng = Rng::new(12);
        let mut work = MinresWork::new();
        let mut worst = 0.0f64;
        for case in 0..60 {
            let n = rng.range(2, 30);
            let k = rng.range(1, n / 2 + 1);
            let kkt = rng.kkt(n, k, &[]);
            let op = KktOperator {
                a: DenseMatrix::from_fn(n, n, |r, s| kkt.get(r, s)),
                j: DenseMatrix::from_fn(k, n, |r, s| kkt.get(n + r, s)),
            };
            let b = rng.vec(n + k);
            let x_ref = lu_solve(&kkt, &b).unwrap();
            let mut x = alloc::vec![0.0; n + k];
            let stats = minres(&op, &b, &mut x, &tight(), &mut work).unwrap();
            assert!(stats.converged, "case {case}: {stats:?}");
            // The recurrence residual never increases within a run.
            assert!(stats
                .history
                .windows(2)
                .all(|p| p[1] <= p[0] * (1.0 + 1e-12)));
            worst = worst.max(rel_err(&x, &x_ref));
        }
        // Measured worst: 1.08e-14.
        eprintln!("MINRES vs LU (KKT): worst error {worst:e}");
        assert!(worst < 1.1e-13);
    }

    #[test]
    fn ill_conditioned_reports_honestly() {
        // A = Q diag(σ) Q with a Householder Q and σ from 1 down to 1e-12.
        let n = 40;
        let mut rng = Rng::new(13);
        let a = ill_conditioned(&mut rng, n, 1e-12, |i| if i % 2 == 0 { 1.0 } else { -1.0 });
        let b = rng.vec(n);
        let mut x = alloc::vec![0.0; n];
        let settings = IterSettings::default();
        let stats = minres(&a, &b, &mut x, &settings, &mut MinresWork::new()).unwrap();
        let res = rel_residual(&a, &x, &b);
        eprintln!(
            "MINRES cond 1e12: converged {}, residual {:e} (recomputed {res:e}), {} iterations",
            stats.converged, stats.residual, stats.iterations
        );
        assert!((res - stats.residual).abs() <= 1e-6 * res);
        assert_eq!(stats.converged, stats.residual <= settings.tolerance);
        assert!(!stats.converged && stats.residual > settings.tolerance);
        assert!(matches!(
            stats.check(),
            Err(SolveError::NotConverged { .. })
        ));
        assert!(x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn zero_rhs_and_reuse() {
        let mut rng = Rng::new(14);
        let a = rng.spd(5);
        let mut work = MinresWork::with_dim(3);
        let mut x = alloc::vec![1.0; 5];
        let stats = minres(&a, &[0.0; 5], &mut x, &IterSettings::default(), &mut work).unwrap();
        assert!(stats.converged && stats.iterations == 0);
        assert_eq!(x, alloc::vec![0.0; 5]);
        // Exact initial guess: no iterations.
        let b = rng.vec(5);
        let mut x = lu_solve(&a, &b).unwrap();
        let stats = minres(&a, &b, &mut x, &IterSettings::default(), &mut work).unwrap();
        assert!(stats.converged && stats.iterations == 0);
    }

    #[test]
    fn invalid_input() {
        let a = DenseMatrix::identity(3);
        let mut work = MinresWork::new();
        let s = IterSettings::default();
        let mut x = alloc::vec![0.0; 3];
        assert_eq!(
            minres(&a, &[1.0, 2.0], &mut x, &s, &mut work),
            Err(SolveError::DimensionMismatch)
        );
        assert_eq!(
            minres(&a, &[1.0, f64::NAN, 0.0], &mut x, &s, &mut work),
            Err(SolveError::NonFinite)
        );
        let mut bad_x = alloc::vec![f64::INFINITY, 0.0, 0.0];
        assert_eq!(
            minres(&a, &[1.0, 1.0, 0.0], &mut bad_x, &s, &mut work),
            Err(SolveError::NonFinite)
        );
        let mut nan_a = DenseMatrix::identity(3);
        nan_a.set(2, 1, f64::NAN);
        assert_eq!(
            minres(&nan_a, &[1.0, 1.0, 1.0], &mut x, &s, &mut work),
            Err(SolveError::NonFinite)
        );
    }
}
