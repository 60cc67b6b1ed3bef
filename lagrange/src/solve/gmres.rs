//! Restarted GMRES(m) for general (nonsymmetric or indefinite) systems.
//!
//! Y. Saad and M. H. Schultz, "GMRES: A generalized minimal residual algorithm for
//! solving nonsymmetric linear systems", *SIAM J. Sci. Stat. Comput.* 7(3), 1986. The
//! Arnoldi process (modified Gram–Schmidt) builds an orthonormal basis `V_{k+1}` of the
//! Krylov space with `A V_k = V_{k+1} H̄_k` (`H̄_k` upper Hessenberg); Givens rotations
//! reduce `H̄_k` to triangular form column by column, so `min |β e₁ − H̄_k y|` — the
//! residual norm of the iterate `x₀ + V_k y` — is available at every step. After `m`
//! steps (the restart length) `x` is updated and the process restarts from the new
//! residual, bounding memory to `m + 1` basis vectors.
//!
//! Each restart begins from the recomputed residual `b − A x`, and the reported
//! [`IterStats::residual`] is always that recomputed value for the returned `x`. The
//! solver stops on convergence, when the budget is spent, or when a restart cycle fails
//! to reduce the true residual (stagnation, e.g. GMRES(m) on some indefinite matrices or
//! a residual floor set by the conditioning); it then returns the best iterate seen at a
//! restart, so the returned residual never exceeds the initial one.

use super::{
    check_iterative_inputs, dot, hypot, norm, residual, IterSettings, IterStats, LinearOperator,
    SolveError,
};
use alloc::vec::Vec;

/// Default restart length `m` of [`GmresWork::default`].
pub const DEFAULT_RESTART: usize = 30;

/// Scratch space of [`gmres`]: the Krylov basis, the Hessenberg matrix and the Givens
/// rotations, sized on first use and reused across solves.
#[derive(Clone, Debug)]
pub struct GmresWork {
    restart: usize,
    /// Basis vectors `v_0 … v_m`, each of length `n`, one after another.
    basis: Vec<f64>,
    /// `H̄` column-major, `(m + 1) × m`.
    hess: Vec<f64>,
    cs: Vec<f64>,
    sn: Vec<f64>,
    /// Rotated right-hand side `g = Qᵀ β e₁`, overwritten by `y` at the end of a cycle.
    g: Vec<f64>,
    r: Vec<f64>,
    x_best: Vec<f64>,
}

impl Default for GmresWork {
    fn default() -> Self {
        Self::new(DEFAULT_RESTART)
    }
}

impl GmresWork {
    /// Empty work space for GMRES(`restart`) (at least 1); the first solve sizes it.
    pub fn new(restart: usize) -> Self {
        Self {
            restart: restart.max(1),
            basis: Vec::new(),
            hess: Vec::new(),
            cs: Vec::new(),
            sn: Vec::new(),
            g: Vec::new(),
            r: Vec::new(),
            x_best: Vec::new(),
        }
    }

    /// The restart length `m`.
    pub fn restart(&self) -> usize {
        self.restart
    }

    /// Sizes the buffers for dimension `n`; returns the effective restart `min(m, n)`.
    fn resize(&mut self, n: usize) -> usize {
        let m = self.restart.min(n).max(1);
        self.basis.resize((m + 1) * n, 0.0);
        self.hess.resize((m + 1) * m, 0.0);
        self.cs.resize(m, 0.0);
        self.sn.resize(m, 0.0);
        self.g.resize(m + 1, 0.0);
        self.r.resize(n, 0.0);
        self.x_best.resize(n, 0.0);
        m
    }
}

/// Solves `A x = b` by restarted GMRES(m), `m = work.restart()`.
///
/// `x` holds the initial guess on entry and the best iterate on return (also when not
/// converged). The returned [`IterStats`] has the recomputed relative residual; use
/// [`IterStats::check`] to turn non-convergence into an error.
///
/// Errors: [`SolveError::DimensionMismatch`] unless `b.len() == x.len() == a.dim()`;
/// [`SolveError::NonFinite`] for non-finite `b`, `x`, tolerance, or operator output.
pub fn gmres<A: LinearOperator + ?Sized>(
    a: &A,
    b: &[f64],
    x: &mut [f64],
    settings: &IterSettings,
    work: &mut GmresWork,
) -> Result<IterStats, SolveError> {
    let n = a.dim();
    check_iterative_inputs(n, b, x, settings)?;
    let mut stats = IterStats::default();
    let bnorm = norm(b);
    if bnorm == 0.0 {
        x.fill(0.0);
        stats.converged = true;
        return Ok(stats);
    }
    let m = work.resize(n);
    let mut best = f64::INFINITY;
    loop {
        let rnorm = residual(a, b, x, &mut work.r)?;
        let rel = rnorm / bnorm;
        if !(rel < best) {
            // The last cycle did not reduce the true residual: return the best iterate.
            x.copy_from_slice(&work.x_best);
            break;
        }
        best = rel;
        work.x_best.copy_from_slice(x);
        if rel <= settings.tolerance || stats.iterations >= settings.max_iterations {
            break;
        }
        cycle(a, x, work, n, m, rnorm, bnorm, settings, &mut stats)?;
    }
    stats.residual = best;
    stats.converged = best <= settings.tolerance;
    Ok(stats)
}

/// One GMRES(m) cycle from `x` with `work.r = b − A x`, `|r| = beta > 0`.
#[allow(clippy::too_many_arguments)]
fn cycle<A: LinearOperator + ?Sized>(
    a: &A,
    x: &mut [f64],
    work: &mut GmresWork,
    n: usize,
    m: usize,
    beta: f64,
    bnorm: f64,
    settings: &IterSettings,
    stats: &mut IterStats,
) -> Result<(), SolveError> {
    let GmresWork {
        basis,
        hess,
        cs,
        sn,
        g,
        r,
        ..
    } = work;
    let ld = m + 1; // leading dimension of H̄
    for (vi, ri) in basis[..n].iter_mut().zip(r.iter()) {
        *vi = ri / beta;
    }
    g.fill(0.0);
    g[0] = beta;
    let mut k = 0;
    for j in 0..m {
        if stats.iterations >= settings.max_iterations {
            break;
        }
        let (head, tail) = basis.split_at_mut((j + 1) * n);
        let w = &mut tail[..n];
        a.apply(&head[j * n..], w);
        stats.iterations += 1;
        let w_norm0 = norm(w);
        if !w_norm0.is_finite() {
            return Err(SolveError::NonFinite);
        }
        // Modified Gram–Schmidt against v_0 … v_j.
        let h = &mut hess[j * ld..(j + 1) * ld];
        for i in 0..=j {
            let vi = &head[i * n..(i + 1) * n];
            let hij = dot(w, vi);
            for (wl, vl) in w.iter_mut().zip(vi) {
                *wl -= hij * vl;
            }
            h[i] = hij;
        }
        let h_next = norm(w);
        h[j + 1] = h_next;
        // Previous rotations, then a new one annihilating h[j+1].
        for i in 0..j {
            let t = cs[i] * h[i] + sn[i] * h[i + 1];
            h[i + 1] = -sn[i] * h[i] + cs[i] * h[i + 1];
            h[i] = t;
        }
        let d = hypot(h[j], h[j + 1]);
        if d == 0.0 {
            cs[j] = 1.0;
            sn[j] = 0.0;
        } else {
            cs[j] = h[j] / d;
            sn[j] = h[j + 1] / d;
        }
        h[j] = d;
        h[j + 1] = 0.0;
        g[j + 1] = -sn[j] * g[j];
        g[j] *= cs[j];
        k = j + 1;

        let estimate = g[j + 1].abs() / bnorm;
        stats.history.push(estimate);
        // Happy breakdown: A v_j lies in the current Krylov space.
        let breakdown = h_next <= f64::EPSILON * w_norm0;
        if !breakdown {
            for wl in w.iter_mut() {
                *wl /= h_next;
            }
        }
        if estimate <= settings.tolerance || breakdown {
            break;
        }
    }
    // Back substitution R y = g (in place in g); a zero diagonal (singular A) drops the
    // component instead of dividing by zero.
    for i in (0..k).rev() {
        let mut s = g[i];
        for l in i + 1..k {
            s -= hess[i + l * ld] * g[l];
        }
        let rii = hess[i + i * ld];
        g[i] = if rii != 0.0 { s / rii } else { 0.0 };
    }
    for (i, &yi) in g[..k].iter().enumerate() {
        let vi = &basis[i * n..(i + 1) * n];
        for (xl, vl) in x.iter_mut().zip(vi) {
            *xl += yi * vl;
        }
    }
    if x.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(SolveError::NonFinite)
    }
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
    fn matches_lu_on_general_systems() {
        let mut rng = Rng::new(21);
        let mut work = GmresWork::default();
        let mut worst = 0.0f64;
        for case in 0..60 {
            let n = rng.range(1, 40);
            let a = rng.general(n);
            let b = rng.vec(n);
            let x_ref = lu_solve(&a, &b).unwrap();
            let mut x = alloc::vec![0.0; n];
            let stats = gmres(&a, &b, &mut x, &tight(), &mut work).unwrap();
            assert!(stats.converged, "case {case}: {stats:?}");
            assert_eq!(stats.history.len(), stats.iterations);
            let res = rel_residual(&a, &x, &b);
            assert!((res - stats.residual).abs() <= 1e-3 * res.max(1e-300));
            worst = worst.max(rel_err(&x, &x_ref));
        }
        // Measured worst: 1.05e-14.
        eprintln!("GMRES(30) vs LU: worst error {worst:e}");
        assert!(worst < 1e-13);
    }

    #[test]
    fn short_restart_still_converges() {
        let mut rng = Rng::new(22);
        let mut work = GmresWork::new(5);
        let mut worst = 0.0f64;
        for case in 0..60 {
            let n = rng.range(1, 40);
            let a = rng.general(n);
            let b = rng.vec(n);
            let x_ref = lu_solve(&a, &b).unwrap();
            let mut x = alloc::vec![0.0; n];
            let stats = gmres(&a, &b, &mut x, &tight(), &mut work).unwrap();
            assert!(stats.converged, "case {case}: {stats:?}");
            worst = worst.max(rel_err(&x, &x_ref));
        }
        // Measured worst: 1.09e-14.
        eprintln!("GMRES(5) vs LU: worst error {worst:e}");
        assert!(worst < 1.1e-13);
    }

    #[test]
    fn solves_saddle_point_kkt_matrix_free() {
        let mut rng = Rng::new(23);
        let mut work = GmresWork::new(60);
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
            let stats = gmres(&op, &b, &mut x, &tight(), &mut work).unwrap();
            assert!(stats.converged, "case {case}: {stats:?}");
            // Within a cycle the GMRES residual never increases.
            assert!(stats
                .history
                .windows(2)
                .all(|p| p[1] <= p[0] * (1.0 + 1e-12)));
            worst = worst.max(rel_err(&x, &x_ref));
        }
        // Measured worst: 1.22e-14.
        eprintln!("GMRES vs LU (KKT): worst error {worst:e}");
        assert!(worst < 1.2e-13);
    }

    #[test]
    fn ill_conditioned_reports_honestly() {
        let n = 40;
        let mut rng = Rng::new(24);
        let a = ill_conditioned(&mut rng, n, 1e-12, |_| 1.0);
        let b = rng.vec(n);
        let mut x = alloc::vec![0.0; n];
        let settings = IterSettings::default();
        let stats = gmres(&a, &b, &mut x, &settings, &mut GmresWork::new(10)).unwrap();
        let res = rel_residual(&a, &x, &b);
        eprintln!(
            "GMRES(10) cond 1e12: converged {}, residual {:e} (recomputed {res:e}), {} iterations",
            stats.converged, stats.residual, stats.iterations
        );
        assert!((res - stats.residual).abs() <= 1e-6 * res);
        assert_eq!(stats.converged, stats.residual <= settings.tolerance);
        assert!(!stats.converged && stats.residual > settings.tolerance);
        assert!(x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn budget_exhaustion_is_reported() {
        let mut rng = Rng::new(25);
        let a = rng.general(30);
        let b = rng.vec(30);
        let mut x = alloc::vec![0.0; 30];
        let settings = IterSettings {
            tolerance: 1e-14,
            max_iterations: 3,
        };
        let stats = gmres(&a, &b, &mut x, &settings, &mut GmresWork::default()).unwrap();
        assert!(!stats.converged);
        assert_eq!(stats.iterations, 3);
        assert!((stats.residual - rel_residual(&a, &x, &b)).abs() < 1e-12);
        assert_eq!(
            stats.check(),
            Err(SolveError::NotConverged {
                iterations: 3,
                residual: rel_residual(&a, &x, &b)
            })
        );
    }

    #[test]
    fn zero_rhs_and_invalid_input() {
        let a = DenseMatrix::identity(3);
        let mut work = GmresWork::new(0);
        assert_eq!(work.restart(), 1);
        let s = IterSettings::default();
        let mut x = alloc::vec![1.0; 3];
        let stats = gmres(&a, &[0.0; 3], &mut x, &s, &mut work).unwrap();
        assert!(stats.converged && x == [0.0; 3]);
        let stats = gmres(&a, &[1.0, 2.0, 3.0], &mut x, &s, &mut work).unwrap();
        assert!(stats.converged);
        assert!(rel_err(&x, &[1.0, 2.0, 3.0]) < 1e-15);
        assert_eq!(
            gmres(&a, &[1.0, 2.0], &mut x, &s, &mut work),
            Err(SolveError::DimensionMismatch)
        );
        assert_eq!(
            gmres(&a, &[1.0, f64::NAN, 0.0], &mut x, &s, &mut work),
            Err(SolveError::NonFinite)
        );
        let mut nan_a = DenseMatrix::identity(3);
        nan_a.set(0, 0, f64::INFINITY);
        let mut x = alloc::vec![0.0; 3];
        assert_eq!(
            gmres(&nan_a, &[1.0, 1.0, 1.0], &mut x, &s, &mut work),
            Err(SolveError::NonFinite)
        );
    }
}
