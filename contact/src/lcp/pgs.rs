//! Projected Gauss–Seidel with over-relaxation (Erleben 2007; Catto's sequential impulses).
//!
//! One sweep visits the rows in index order `i = 0, 1, …, n−1` (deterministic) and sets
//!
//! ```text
//! w_i = q_i + Σ_j M_ij z_j,    z_i ← mid(lo_i, z_i − ω w_i / M_ii, hi_i),
//! ```
//!
//! using the latest values of the other unknowns (Gauss–Seidel). For the standard LCP
//! (`λ ≥ 0`, `d λ = 0`) the projection is `max(0, ·)`; friction rows take their bounds
//! `[−μ z_n, μ z_n]` from the current value of their normal `z_n`, updated within the
//! sweep (so the normal row should come first: the `(normal, t₁, t₂)` layout of
//! [`Lcp::contact`]). `ω ∈ (0, 2)`; `ω = 1` is plain PGS. Convergence is guaranteed for
//! symmetric positive definite `M` with fixed bounds, and is linear; friction-scaled
//! bounds have no such guarantee, so the residual decides success.

use alloc::vec;
use alloc::vec::Vec;

use super::problem::{check_tolerance, dot, Lcp, LcpError, LcpSolution};

/// Settings of [`pgs`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PgsSettings {
    /// Relaxation `ω ∈ (0, 2)` (default 1).
    pub omega: f64,
    /// Natural-map residual to reach (default `1e-8`).
    pub tolerance: f64,
    /// Sweep limit (default 10 000).
    pub max_iterations: usize,
    /// Sweeps between residual checks (each check costs about one sweep; default 1).
    pub check_every: usize,
}

impl Default for PgsSettings {
    fn default() -> Self {
        PgsSettings {
            omega: 1.0,
            tolerance: 1e-8,
            max_iterations: 10_000,
            check_every: 1,
        }
    }
}

/// Solves a standard or boxed LCP (with friction-scaled bounds) by projected
/// Gauss–Seidel from the warm start `z0` (zeros if `None`; projected onto the bounds
/// first). Returns the number of sweeps in [`LcpSolution::iterations`] (0 if `z0` already
/// meets the tolerance).
///
/// Errors: [`LcpError::IterationLimit`] with the last residual, [`LcpError::NonPositiveDiagonal`],
/// [`LcpError::BadSettings`], and length / finiteness errors for `z0`.
pub fn pgs(lcp: &Lcp, settings: &PgsSettings, z0: Option<&[f64]>) -> Result<LcpSolution, LcpError> {
    check_tolerance(settings.tolerance)?;
    if !(settings.omega > 0.0 && settings.omega < 2.0) {
        return Err(LcpError::BadSettings("PGS relaxation ω must lie in (0, 2)"));
    }
    if settings.check_every == 0 {
        return Err(LcpError::BadSettings("PGS check_every must be ≥ 1"));
    }
    let n = lcp.n();
    let mut z = match z0 {
        Some(z0) => {
            lcp.check_vector("z0", z0)?;
            z0.to_vec()
        }
        None => vec![0.0; n],
    };
    let mut inv_diag = Vec::with_capacity(n);
    for i in 0..n {
        let d = lcp.m_ij(i, i);
        if !(d > 0.0) {
            return Err(LcpError::NonPositiveDiagonal { index: i });
        }
        inv_diag.push(1.0 / d);
    }
    // Project the start: fixed-bound rows first, then the friction rows that read them.
    for pass in 0..2 {
        for i in 0..n {
            if lcp.friction()[i].is_some() == (pass == 1) {
                let (lo, hi) = lcp.bounds(i, &z);
                z[i] = z[i].max(lo).min(hi);
            }
        }
    }
    let mut residual = lcp.residual(&z);
    if residual <= settings.tolerance {
        return lcp.finish(z, 0, None, settings.tolerance);
    }
    let omega = settings.omega;
    // The check of sweep `k`'s iterate runs inside sweep `k + 1` (its copy in `prev`):
    // each row is read once for both sums, `w_i` of the new sweep and `w_i` at `prev`
    // (two independent accumulations, in the order of [`dot`], so the results are
    // those of a separate `q + M z` bit for bit), and nothing is allocated per check.
    // A checked iterate that meets the tolerance is returned as before; the sweep run
    // past it is dropped.
    let scale = lcp.scale();
    let start: f64 = core::iter::empty::<f64>().sum();
    let mut prev: Vec<f64> = Vec::with_capacity(n);
    let mut pending = false;
    for sweep in 1..=settings.max_iterations {
        let check = pending;
        if check {
            prev.clear();
            prev.extend_from_slice(&z);
        }
        let mut r = 0.0_f64;
        let mut finite = true;
        for i in 0..n {
            let row = lcp.row(i);
            let wi = if check {
                let (mut a_new, mut a_old) = (start, start);
                for ((m, zn), zo) in row.iter().zip(&z).zip(&prev) {
                    a_new += m * zn;
                    a_old += m * zo;
                }
                let w_old = lcp.q()[i] + a_old;
                if !prev[i].is_finite() || !w_old.is_finite() {
                    finite = false;
                }
                let (lo, hi) = lcp.bounds(i, &prev);
                let p = (prev[i] - w_old).max(lo).min(hi);
                r = r.max(libm::fabs(prev[i] - p));
                lcp.q()[i] + a_new
            } else {
                lcp.q()[i] + dot(row, &z)
            };
            let (lo, hi) = lcp.bounds(i, &z);
            z[i] = (z[i] - omega * wi * inv_diag[i]).max(lo).min(hi);
        }
        if check {
            residual = if finite { r / scale } else { f64::INFINITY };
            if residual <= settings.tolerance {
                return lcp.finish(prev, sweep - 1, None, settings.tolerance);
            }
            if !residual.is_finite() {
                return Err(LcpError::IterationLimit {
                    iterations: sweep - 1,
                    residual,
                });
            }
        }
        pending = sweep % settings.check_every == 0;
    }
    // The last sweep's iterate is always checked.
    if settings.max_iterations > 0 {
        residual = lcp.residual(&z);
        if residual <= settings.tolerance {
            return lcp.finish(z, settings.max_iterations, None, settings.tolerance);
        }
    }
    Err(LcpError::IterationLimit {
        iterations: settings.max_iterations,
        residual,
    })
}
