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

#[cfg(test)]
use alloc::vec;
use alloc::vec::Vec;

use super::problem::{check_tolerance, Lcp, LcpError, LcpSolution};

mod pinned;

pub(crate) use pinned::pgs_free_rows;

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
    /// Stall window (0, the default: off): at a residual check at least this many
    /// sweeps after the last stall mark, a residual that has not halved since that mark
    /// ends the solve as if out of sweeps (the round-off acceptance, then
    /// [`LcpError::IterationLimit`] with the sweeps run). A projected Gauss–Seidel that
    /// gains less than a factor 2 in 100 sweeps converges at a rate above 0.993 per
    /// sweep: thousands of sweeps more for each decade, where they rarely help (the
    /// staggered friction solve of a box face on four coplanar points, whose block is
    /// only semi-definite, sat at its residual for all its 10,000 sweeps).
    pub stall_sweeps: usize,
}

impl Default for PgsSettings {
    fn default() -> Self {
        PgsSettings {
            omega: 1.0,
            tolerance: 1e-8,
            max_iterations: 10_000,
            check_every: 1,
            stall_sweeps: 0,
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
    pgs_keep(lcp, settings, z0).map_err(|(e, _)| e)
}

/// [`pgs`], keeping the last iterate when the sweeps run out or stall: the error comes
/// with the `z` the sweeps reached (`None` for the other errors). The staggered friction
/// solve keeps that iterate as its budget answer instead of sweeping the same budget
/// again from the warm start (which reached the same point, up to round-off, at twice
/// the cost).
pub(crate) fn pgs_keep(
    lcp: &Lcp,
    settings: &PgsSettings,
    z0: Option<&[f64]>,
) -> Result<LcpSolution, (LcpError, Option<Vec<f64>>)> {
    let mut s = PgsScratch::default();
    match pgs_in(lcp, settings, z0, &mut s, true) {
        Ok(PgsEnd::Solved {
            iterations,
            residual,
        }) => Ok(Lcp::solved(s.z, s.w, residual, iterations)),
        Ok(PgsEnd::Stopped {
            iterations,
            residual,
        }) => Err((
            LcpError::IterationLimit {
                iterations,
                residual,
            },
            Some(s.z),
        )),
        Ok(PgsEnd::Diverged {
            iterations,
            residual,
        }) => Err((
            LcpError::IterationLimit {
                iterations,
                residual,
            },
            None,
        )),
        Err(e) => Err((e, None)),
    }
}

/// Buffers of [`pgs_in`] kept by a caller that solves many problems (the staggered
/// friction solve: one per alternation): the iterate `z`, the inverse diagonal and
/// `w = M z + q`. Once they have grown to `n`, a solve allocates nothing.
#[derive(Clone, Debug, Default)]
pub(crate) struct PgsScratch {
    /// The iterate: the answer after [`PgsEnd::Solved`], the last sweep's after
    /// [`PgsEnd::Stopped`].
    pub(crate) z: Vec<f64>,
    /// `1 / M_ii`.
    inv_diag: Vec<f64>,
    /// `w = M z + q` at the last residual check.
    pub(crate) w: Vec<f64>,
    /// [`pgs_free_rows`]: the rows whose box is not `[0, 0]`, their block of `M`
    /// (row-major) and their iterate.
    free: Vec<usize>,
    block: Vec<f64>,
    zf: Vec<f64>,
}

/// How [`pgs_in`] ended (its errors are the settings' and the start's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum PgsEnd {
    /// The residual met the tolerance (or its round-off floor, [`Lcp::accepts`], once
    /// the sweeps ran out or stalled) after `iterations` sweeps; `z` and `w = M z + q`
    /// in the scratch.
    Solved { iterations: usize, residual: f64 },
    /// Out of sweeps or stalled above the tolerance; the last iterate in the scratch.
    Stopped { iterations: usize, residual: f64 },
    /// The residual went non-finite: nothing worth keeping.
    Diverged { iterations: usize, residual: f64 },
}

/// [`pgs`] in the caller's buffers `s` (no allocation once they have grown): the same
/// sweeps, checks and answers, bit for bit, as [`pgs_keep`] (which runs it on fresh
/// buffers).
///
/// `check_last: false` leaves out the residual check of the last sweep where it is not
/// a [`PgsSettings::check_every`] sweep: a solve that gets there ends
/// [`PgsEnd::Stopped`] with the last sweep's iterate (the residual reported is the last
/// check's) — the same iterate, without the check's `w = M z + q` and round-off floor.
/// For a caller that judges the answer by another residual anyway (the staggered
/// friction solve in the residual-driven mode: the whole problem's).
pub(crate) fn pgs_in(
    lcp: &Lcp,
    settings: &PgsSettings,
    z0: Option<&[f64]>,
    s: &mut PgsScratch,
    check_last: bool,
) -> Result<PgsEnd, LcpError> {
    check_tolerance(settings.tolerance)?;
    if !(settings.omega > 0.0 && settings.omega < 2.0) {
        return Err(LcpError::BadSettings("PGS relaxation ω must lie in (0, 2)"));
    }
    if settings.check_every == 0 {
        return Err(LcpError::BadSettings("PGS check_every must be ≥ 1"));
    }
    let n = lcp.n();
    let PgsScratch { z, inv_diag, w, .. } = s;
    z.clear();
    match z0 {
        Some(z0) => {
            lcp.check_vector("z0", z0)?;
            z.extend_from_slice(z0);
        }
        None => z.resize(n, 0.0),
    }
    inverse_diagonal(lcp, inv_diag)?;
    // Project the start: fixed-bound rows first, then the friction rows that read them.
    for pass in 0..2 {
        for i in 0..n {
            if lcp.friction()[i].is_some() == (pass == 1) {
                let (lo, hi) = lcp.bounds(i, z);
                z[i] = z[i].max(lo).min(hi);
            }
        }
    }
    // `w = M z + q` at the residual checks, in one kept buffer.
    lcp.w_into(z, w);
    let mut residual = lcp.residual_with(z, w);
    if residual <= settings.tolerance {
        return Ok(PgsEnd::Solved {
            iterations: 0,
            residual,
        });
    }
    let omega = settings.omega;
    // The residual's scale `max(1, |q|∞)`: `q` is fixed during the solve.
    let scale = lcp.scale();
    let mut mark = (0, residual);
    let mut ran = settings.max_iterations;
    // Fixed boxes on full rows (the staggered friction block of a tree): the sweep
    // over `M`'s contiguous rows ([`Lcp::full_rows`]) and the stored bounds.
    let fixed_full = lcp
        .full_rows()
        .filter(|_| lcp.friction().iter().all(Option::is_none));
    for sweep in 1..=settings.max_iterations {
        match fixed_full {
            Some(m) => sweep_fixed_full(m, lcp, inv_diag, omega, z),
            None => {
                for i in 0..n {
                    let wi = lcp.q()[i] + lcp.row_dot(i, z);
                    let (lo, hi) = lcp.bounds(i, z);
                    z[i] = (z[i] - omega * wi * inv_diag[i]).max(lo).min(hi);
                }
            }
        }
        let last = sweep == settings.max_iterations;
        if last && !check_last && sweep % settings.check_every != 0 {
            return Ok(PgsEnd::Stopped {
                iterations: sweep,
                residual,
            });
        }
        if sweep % settings.check_every == 0 || last {
            residual = lcp.w_residual_into(z, w, scale);
            if residual <= settings.tolerance {
                return Ok(PgsEnd::Solved {
                    iterations: sweep,
                    residual,
                });
            }
            if !residual.is_finite() {
                return Ok(PgsEnd::Diverged {
                    iterations: sweep,
                    residual,
                });
            }
            if settings.stall_sweeps > 0 && sweep - mark.0 >= settings.stall_sweeps {
                if !(residual <= 0.5 * mark.1) {
                    ran = sweep;
                    break;
                }
                mark = (sweep, residual);
            }
        }
    }
    // Out of sweeps (or stalled): the answer stands if the residual is down to its
    // round-off floor (huge impulses; [`Lcp::round_off`]). `w` is `M z + q` at this `z`
    // (the last check ran at this sweep, or none ran: the start's), and `residual` its
    // natural map (`w_residual_into` gives `residual_with`'s bits), so the answer is
    // [`Lcp::finish`]'s without evaluating `w` again.
    if lcp.accepts(z, residual, settings.tolerance) {
        return Ok(PgsEnd::Solved {
            iterations: ran,
            residual,
        });
    }
    Ok(PgsEnd::Stopped {
        iterations: ran,
        residual,
    })
}

/// One Gauss–Seidel sweep `z_i ← mid(lo_i, z_i − ω (q_i + M_i · z) / M_ii, hi_i)`,
/// `i = 0, 1, …, n−1`, for fixed bounds (no friction links) with `M` row-major `m`
/// ([`Lcp::full_rows`]): [`pgs_in`]'s sweep with the same operations in the same
/// order (the same bits), over zipped slices instead of indexed look-ups per row
/// (the row starts, the friction match, the bounds checks: as many instructions as
/// the product itself on the friction block of a lying humanoid).
#[inline]
/// `1 / M_ii` per row into `inv_diag` (cleared first); a diagonal that is not positive
/// (or NaN) is [`LcpError::NonPositiveDiagonal`]: a Gauss–Seidel sweep divides by it.
fn inverse_diagonal(lcp: &Lcp, inv_diag: &mut Vec<f64>) -> Result<(), LcpError> {
    inv_diag.clear();
    for i in 0..lcp.n() {
        let d = lcp.m_ij(i, i);
        if !(d > 0.0) {
            return Err(LcpError::NonPositiveDiagonal { index: i });
        }
        inv_diag.push(1.0 / d);
    }
    Ok(())
}

fn sweep_fixed_full(m: &[f64], lcp: &Lcp, inv_diag: &[f64], omega: f64, z: &mut [f64]) {
    let n = z.len();
    let bounds = lcp.lo().iter().zip(lcp.hi());
    let rows = m.chunks_exact(n).zip(lcp.q()).zip(inv_diag).zip(bounds);
    for (i, (((row, &qi), &di), (&lo, &hi))) in rows.enumerate() {
        let dot: f64 = row.iter().zip(z.iter()).map(|(v, x)| v * x).sum();
        let wi = qi + dot;
        if let Some(zi) = z.get_mut(i) {
            *zi = (*zi - omega * wi * di).max(lo).min(hi);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stall window: Gauss–Seidel on `[[1, 1−ε], [1−ε, 1]] z = −q` (unbounded) gains
    /// a factor `(1−ε)²` per sweep; at ε = 1e-4 the residual falls by about 2 % in 100
    /// sweeps, so with `stall_sweeps: 100` the solve stops at sweep 100 instead of
    /// running all 10,000 (measured: 100 sweeps, residual 0.98 of its start); with a
    /// window on a fast problem (ε = 0.5) it converges as before (15 sweeps both ways).
    #[test]
    fn a_stalled_solve_stops_at_its_window() {
        let problem = |eps: f64| {
            let c = 1.0 - eps;
            let inf = f64::INFINITY;
            Lcp::boxed(
                vec![1.0, c, c, 1.0],
                vec![1.0, -1.0],
                vec![-inf; 2],
                vec![inf; 2],
            )
            .unwrap()
        };
        let windowed = PgsSettings {
            stall_sweeps: 100,
            ..PgsSettings::default()
        };
        match pgs(&problem(1e-4), &windowed, None) {
            Err(LcpError::IterationLimit { iterations, .. }) => assert_eq!(iterations, 100),
            other => panic!("{other:?}"),
        }
        match pgs(&problem(1e-4), &PgsSettings::default(), None) {
            Err(LcpError::IterationLimit { iterations, .. }) => assert_eq!(iterations, 10_000),
            other => panic!("{other:?}"),
        }
        let fast = pgs(&problem(0.5), &windowed, None).unwrap();
        let plain = pgs(&problem(0.5), &PgsSettings::default(), None).unwrap();
        assert_eq!(fast.iterations, plain.iterations);
        assert_eq!(fast.z, plain.z);
    }
}
