//! Fischer–Burmeister semismooth Newton method for the standard LCP (high accuracy).
//!
//! The complementarity conditions `z ≥ 0`, `w ≥ 0`, `z w = 0` of each row hold exactly
//! when the Fischer–Burmeister function vanishes:
//!
//! ```text
//! φ(a, b) = √(a² + b²) − a − b,    Φ_i(z) = φ(z_i, w_i),   w = M z + q.
//! ```
//!
//! (the code pairs `z_i` with `w_i / α`, `α` the largest diagonal entry of `M`, so that
//! the iteration does not depend on the units of `M`; below, read `M / α` for `M`).
//! `Φ` is semismooth; a generalized Jacobian is `H = D_a + D_b M` with
//! `D_a = diag(z_i / r_i − 1)`, `D_b = diag(w_i / r_i − 1)`, `r_i = ‖(z_i, w_i)‖` (at
//! `r_i = 0` the element `1/√2 − 1` of the generalized gradient is used). Each step
//! solves `H d = −Φ` by dense LU with partial pivoting and backtracks (Armijo) on the
//! merit `Ψ = ½|Φ|²`, whose gradient is `Hᵀ Φ`; if `H` is singular or the Newton
//! direction is not a descent direction, the step falls back to the gradient direction
//! `−Hᵀ Φ`. The step actually solved is `(H − μI) d = −Φ` with `μ = min(|Φ|, 0.01)`:
//! `−(H − μI)` is a positive diagonal plus a nonnegative diagonal times `M`, nonsingular
//! whenever `M` is a P₀ matrix (PSD included), and `μ → 0` keeps a fast local rate on
//! problems whose solutions are not isolated. Near a non-degenerate solution convergence is quadratic (De Luca, Facchinei
//! & Kanzow 1996). Each step costs an `O(n³)` factorization.
//!
//! This method solves the **standard** LCP only (`lo = 0`, `hi = ∞`, no friction); use
//! [`super::pgs()`] for boxed and frictional problems.

use alloc::vec;
use alloc::vec::Vec;

use super::dense::Lu;
use super::problem::{check_tolerance, Lcp, LcpError, LcpSolution};

/// Settings of [`fischer_newton`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonSettings {
    /// Natural-map residual to reach (default `1e-12`).
    pub tolerance: f64,
    /// Newton step limit (default 100).
    pub max_iterations: usize,
    /// Armijo sufficient-decrease constant `σ` (default `1e-4`).
    pub armijo: f64,
    /// Backtracking factor `β ∈ (0, 1)` (default 0.5).
    pub backtrack: f64,
    /// Backtracking steps per line search (default 40).
    pub max_backtracks: usize,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        NewtonSettings {
            tolerance: 1e-12,
            max_iterations: 100,
            armijo: 1e-4,
            backtrack: 0.5,
            max_backtracks: 40,
        }
    }
}

/// `φ(a, b) = √(a² + b²) − a − b`, without cancellation when `a + b > 0`.
#[inline]
fn fb(a: f64, b: f64) -> f64 {
    let r = libm::hypot(a, b);
    if a + b > 0.0 {
        -2.0 * a * b / (r + a + b)
    } else {
        r - a - b
    }
}

/// `Ψ = ½|Φ|²` at `z`, with `Φ_i = φ(z_i, w_i / α)`; also stores `w = M z + q`.
fn merit(lcp: &Lcp, alpha: f64, z: &[f64], w: &mut Vec<f64>, phi: &mut [f64]) -> f64 {
    lcp.w_into(z, w);
    let mut s = 0.0;
    for i in 0..z.len() {
        phi[i] = fb(z[i], w[i] / alpha);
        s += phi[i] * phi[i];
    }
    0.5 * s
}

/// Solves a standard LCP by Fischer–Burmeister semismooth Newton with an Armijo line
/// search, from `z0` (zeros if `None`). [`LcpSolution::iterations`] counts Newton steps.
///
/// Errors: [`LcpError::Unsupported`] for boxed problems, [`LcpError::IterationLimit`],
/// [`LcpError::Stalled`] (no decrease possible: a non-solution stationary point of the
/// merit, as on the infeasible `M = [[−1]], q = [−1]`), [`LcpError::BadSettings`], and
/// length / finiteness errors for `z0`.
pub fn fischer_newton(
    lcp: &Lcp,
    settings: &NewtonSettings,
    z0: Option<&[f64]>,
) -> Result<LcpSolution, LcpError> {
    check_tolerance(settings.tolerance)?;
    if !(settings.armijo > 0.0 && settings.armijo < 0.5) {
        return Err(LcpError::BadSettings(
            "Newton Armijo constant must lie in (0, ½)",
        ));
    }
    if !(settings.backtrack > 0.0 && settings.backtrack < 1.0) {
        return Err(LcpError::BadSettings(
            "Newton backtracking factor must lie in (0, 1)",
        ));
    }
    if !lcp.is_standard() {
        return Err(LcpError::Unsupported(
            "Fischer–Burmeister Newton solves the standard LCP only",
        ));
    }
    let n = lcp.n();
    let mut z = match z0 {
        Some(z0) => {
            lcp.check_vector("z0", z0)?;
            z0.to_vec()
        }
        None => vec![0.0; n],
    };
    let mut w = Vec::new();
    let mut phi = vec![0.0; n];
    // Units: Φ pairs z with w / α, α the largest diagonal of M, so that the method does
    // not depend on the scale of M (heavy or light bodies).
    // (`max |M_ij|` only when no diagonal is positive: it is a chain of `n²`
    // dependent `max` over all of `M`, which every call paid before.)
    let dmax = (0..n).fold(0.0_f64, |a, i| a.max(lcp.m_ij(i, i)));
    let alpha = if dmax > 0.0 {
        dmax
    } else {
        let mmax = lcp.m().iter().fold(0.0_f64, |a, &x| a.max(libm::fabs(x)));
        if mmax > 0.0 {
            mmax
        } else {
            1.0
        }
    };
    let mut psi = merit(lcp, alpha, &z, &mut w, &mut phi);
    let mut residual = lcp.residual_with(&z, &w);
    // The iteration's buffers, sized at its first step: a warm start that already meets
    // the tolerance (a resting contact's, every step) allocates none of them.
    // `work` holds `D_a`, `D_b`, `∇Ψ`, `−Φ` and `−∇Ψ` (`n` each) in one allocation.
    let mut trial = Vec::new();
    let mut w_trial = Vec::new();
    let mut phi_trial = Vec::new();
    let mut work = Vec::new();
    // The Newton matrix's storage, kept from one iteration to the next (it comes back
    // from the factor): zeroed in place, not a fresh `n²` allocation per iteration
    // (above glibc's mmap threshold, 128 KiB or n ≥ 128, each was an mmap and its page
    // faults).
    let mut h: Vec<f64> = Vec::new();
    // Whether every row of `M` lists all `n` columns (a humanoid's contacts: they all
    // couple through its tree), so that `H`'s assembly writes every entry (found at
    // the first step, with the buffers).
    let mut all_full = false;
    for k in 0..=settings.max_iterations {
        if residual <= settings.tolerance {
            return Ok(Lcp::solved(z, w, residual, k));
        }
        if k == settings.max_iterations {
            break;
        }
        if k == 0 {
            trial.resize(n, 0.0);
            phi_trial.resize(n, 0.0);
            work.resize(5 * n, 0.0);
            all_full = (0..n).all(|i| lcp.row_nonzeros(i).0.len() == n);
        }
        let (da, rest) = work.split_at_mut(n);
        let (db, rest) = rest.split_at_mut(n);
        let (grad, rest) = rest.split_at_mut(n);
        let (minus_phi, neg_grad) = rest.split_at_mut(n);
        for i in 0..n {
            let wi = w[i] / alpha;
            let r = libm::hypot(z[i], wi);
            if r > 0.0 {
                da[i] = z[i] / r - 1.0;
                db[i] = wi / r - 1.0;
            } else {
                da[i] = core::f64::consts::FRAC_1_SQRT_2 - 1.0;
                db[i] = core::f64::consts::FRAC_1_SQRT_2 - 1.0;
            }
        }
        // H = D_a + D_b M / α; ∇Ψ = Hᵀ Φ.
        // Over the non-zero M_ij only: an off-diagonal zero gives h_ij = +0 and adds ±0
        // to the gradient (bit-neutral); the diagonal is always written. Full rows
        // write all their entries: when every row is full the kept storage (the last
        // iteration's factor) is not zeroed first.
        h.resize(n * n, 0.0);
        if !all_full {
            h.fill(0.0);
        }
        grad.fill(0.0);
        for i in 0..n {
            let (cols, vals) = lcp.row_nonzeros(i);
            if cols.len() == n {
                // A full row (columns 0, 1, …, n−1: a humanoid's contacts all couple
                // through its tree): the same entries and gradient terms over
                // contiguous slices, left of the diagonal, the diagonal, right of it
                // (each entry and each `grad[j]` one operation of its own, so the
                // compiler pairs them in vector lanes with the same bits).
                let (dbi, phii) = (db[i], phi[i]);
                let h_row = &mut h[i * n..(i + 1) * n];
                let (h_left, h_rest) = h_row.split_at_mut(i);
                let (g_left, g_rest) = grad.split_at_mut(i);
                let (m_left, m_rest) = vals.split_at(i);
                let segments = [
                    (h_left, g_left, m_left),
                    (&mut h_rest[1..], &mut g_rest[1..], &m_rest[1..]),
                ];
                for (hs, gs, ms) in segments {
                    for ((hv, g), &m) in hs.iter_mut().zip(gs.iter_mut()).zip(ms) {
                        let v = dbi * m / alpha + 0.0;
                        *hv = v;
                        *g += v * phii;
                    }
                }
                let v = dbi * m_rest[0] / alpha + da[i];
                h_rest[0] = v;
                g_rest[0] += v * phii;
                continue;
            }
            let mut diagonal = false;
            for (&j, &m) in cols.iter().zip(vals) {
                let v = db[i] * m / alpha + if i == j { da[i] } else { 0.0 };
                diagonal |= i == j;
                h[i * n + j] = v;
                grad[j] += v * phi[i];
            }
            if !diagonal {
                let v = db[i] * 0.0 / alpha + da[i];
                h[i * n + i] = v;
                grad[i] += v * phi[i];
            }
        }
        // Regularized step (H − μI) d = −Φ with μ = min(|Φ|₂, 0.01): since −D_a, −D_b ≥ 0 this
        // matrix is nonsingular for P₀ matrices (PSD included), and μ → 0 keeps the fast
        // local rate on problems whose solutions are not isolated.
        let mu = libm::sqrt(2.0 * psi).min(1e-2);
        for i in 0..n {
            h[i * n + i] -= mu;
        }
        for (m, p) in minus_phi.iter_mut().zip(&phi) {
            *m = -p;
        }
        let newton = match Lu::factor(core::mem::take(&mut h), n) {
            Some(lu) => {
                let d = lu.solve(minus_phi);
                h = lu.into_matrix();
                Some(d)
            }
            None => None,
        };
        let gnorm2: f64 = grad.iter().map(|g| g * g).sum();
        // The Newton direction where it descends, then the steepest descent `−∇Ψ`.
        let newton = newton.filter(|d| {
            let dn2: f64 = d.iter().map(|x| x * x).sum();
            let slope: f64 = d.iter().zip(&*grad).map(|(a, b)| a * b).sum();
            d.iter().all(|x| x.is_finite()) && slope < -1e-12 * libm::sqrt(dn2 * gnorm2)
        });
        for (m, g) in neg_grad.iter_mut().zip(&*grad) {
            *m = -g;
        }
        let directions = [newton.as_deref(), (gnorm2 > 0.0).then_some(&*neg_grad)];
        let mut accepted = false;
        for d in directions.into_iter().flatten() {
            let slope: f64 = d.iter().zip(&*grad).map(|(a, b)| a * b).sum();
            let mut t = 1.0;
            for _ in 0..=settings.max_backtracks {
                for i in 0..n {
                    trial[i] = z[i] + t * d[i];
                }
                let psi_t = merit(lcp, alpha, &trial, &mut w_trial, &mut phi_trial);
                if psi_t <= psi + settings.armijo * t * slope {
                    core::mem::swap(&mut z, &mut trial);
                    core::mem::swap(&mut w, &mut w_trial);
                    core::mem::swap(&mut phi, &mut phi_trial);
                    psi = psi_t;
                    accepted = true;
                    break;
                }
                t *= settings.backtrack;
            }
            if accepted {
                break;
            }
        }
        residual = lcp.residual_with(&z, &w);
        if !accepted {
            if lcp.accepts(&z, residual, settings.tolerance) {
                return lcp.finish(z, k, None, settings.tolerance);
            }
            return Err(LcpError::Stalled {
                iterations: k,
                residual,
            });
        }
    }
    // Out of steps: the answer stands if the residual is down to its round-off floor
    // (huge impulses; [`Lcp::round_off`]).
    if lcp.accepts(&z, residual, settings.tolerance) {
        return lcp.finish(z, settings.max_iterations, None, settings.tolerance);
    }
    Err(LcpError::IterationLimit {
        iterations: settings.max_iterations,
        residual,
    })
}
