//! Projected Gauss–Seidel without the rows whose box is the point `0` (`lo_i = hi_i = 0`).
//!
//! In the staggered friction solve the boxes are `[−μ z_n, μ z_n]`: every friction row of
//! a contact whose normal impulse is zero (a speculative contact within the margin, a
//! foot lifting off) is pinned at `z_i = 0`. On the dm_control humanoid lying on the
//! floor 22 to 24 of the 38 friction rows are pinned, yet each sweep and each residual
//! check of [`super::pgs_in`] computes their products `M_i · z` only to clamp the answer
//! back to zero. Here the sweeps and checks run on the `k × k` block of the other rows:
//!
//! - a pinned row's `z_i` is its start projected into `[0, 0]` (a zero) and stays there,
//!   as every sweep of the whole block leaves it (a zero, again);
//! - its column contributes `M_ij · 0 = ±0` to the other rows' sums, which leaves a sum's
//!   value as it is (only an all-zero sum can change its sign of zero), so the free rows'
//!   sums over the free columns are the whole block's sums;
//! - its natural-map term `|z_i − mid(0, z_i − w_i, 0)|` is `0`, so the residual over the
//!   free rows, with the whole problem's scale `max(1, |q|∞)`, is the whole block's.
//!
//! So the free rows' iterates, the residuals, the checks, the stall window and the
//! round-off acceptance ([`Lcp::accepts`] on the whole problem) follow the whole block's
//! solve value for value; only the signs of zero of pinned impulses may differ.

use super::{PgsEnd, PgsScratch, PgsSettings};
use crate::lcp::problem::{check_tolerance, Lcp, LcpError};

/// [`super::pgs_in`] on an [`Lcp`] with fixed boxes and full rows ([`Lcp::full_rows`],
/// no friction links), sweeping only its rows whose box is not `[0, 0]` (module docs):
/// the same iterate on those rows, the same residuals and the same end, `z` in the
/// scratch (pinned rows zero). The scratch's `w` is not filled. Falls back on
/// [`super::pgs_in`] itself for other problems or when no row is pinned.
pub(crate) fn pgs_free_rows(
    lcp: &Lcp,
    settings: &PgsSettings,
    z0: &[f64],
    s: &mut PgsScratch,
    check_last: bool,
) -> Result<PgsEnd, LcpError> {
    let n = lcp.n();
    let (lo, hi) = (lcp.lo(), lcp.hi());
    let pinned = |i: usize| lo[i] == 0.0 && hi[i] == 0.0;
    let m = match lcp.full_rows() {
        Some(m) if lcp.friction().iter().all(Option::is_none) && (0..n).any(pinned) => m,
        _ => return super::pgs_in(lcp, settings, Some(z0), s, check_last),
    };
    // `pgs_in`'s checks, in its order (the same errors).
    check_tolerance(settings.tolerance)?;
    if !(settings.omega > 0.0 && settings.omega < 2.0) {
        return Err(LcpError::BadSettings("PGS relaxation ω must lie in (0, 2)"));
    }
    if settings.check_every == 0 {
        return Err(LcpError::BadSettings("PGS check_every must be ≥ 1"));
    }
    lcp.check_vector("z0", z0)?;
    let PgsScratch {
        z,
        inv_diag,
        free,
        block,
        zf,
        ..
    } = s;
    super::inverse_diagonal(lcp, inv_diag)?;
    // The start projected into the boxes (the pinned rows' zeros), then the free block.
    z.clear();
    z.extend(z0.iter().enumerate().map(|(i, &v)| v.max(lo[i]).min(hi[i])));
    free.clear();
    free.extend((0..n).filter(|&i| !pinned(i)));
    let k = free.len();
    block.clear();
    for &i in free.iter() {
        block.extend(free.iter().map(|&j| m[i * n + j]));
    }
    zf.clear();
    zf.extend(free.iter().map(|&i| z[i]));
    let q = lcp.q();
    let free = &free[..];
    let scale = lcp.scale();
    // The natural-map residual over the free rows at `zf` (`+∞` at a non-finite entry,
    // as `Lcp::residual_with`), with the whole problem's scale.
    let residual = |zf: &[f64]| -> f64 {
        let mut r = 0.0_f64;
        for (a, &i) in free.iter().enumerate() {
            let row = &block[a * k..(a + 1) * k];
            let wi = q[i] + row.iter().zip(zf).map(|(v, x)| v * x).sum::<f64>();
            if !zf[a].is_finite() || !wi.is_finite() {
                return f64::INFINITY;
            }
            let p = (zf[a] - wi).max(lo[i]).min(hi[i]);
            r = r.max(libm::fabs(zf[a] - p));
        }
        r / scale
    };
    let mut residual_now = residual(zf);
    let scatter = |zf: &[f64], z: &mut [f64]| {
        for (&i, &v) in free.iter().zip(zf) {
            z[i] = v;
        }
    };
    if residual_now <= settings.tolerance {
        scatter(zf, z);
        return Ok(PgsEnd::Solved {
            iterations: 0,
            residual: residual_now,
        });
    }
    let omega = settings.omega;
    let mut mark = (0, residual_now);
    let mut ran = settings.max_iterations;
    for sweep in 1..=settings.max_iterations {
        // `sweep_fixed_full` on the free block: the same operations in the same order.
        for (a, &i) in free.iter().enumerate() {
            let row = &block[a * k..(a + 1) * k];
            let dot: f64 = row.iter().zip(zf.iter()).map(|(v, x)| v * x).sum();
            let wi = q[i] + dot;
            zf[a] = (zf[a] - omega * wi * inv_diag[i]).max(lo[i]).min(hi[i]);
        }
        let last = sweep == settings.max_iterations;
        if last && !check_last && sweep % settings.check_every != 0 {
            scatter(zf, z);
            return Ok(PgsEnd::Stopped {
                iterations: sweep,
                residual: residual_now,
            });
        }
        if sweep % settings.check_every == 0 || last {
            residual_now = residual(zf);
            if residual_now <= settings.tolerance {
                scatter(zf, z);
                return Ok(PgsEnd::Solved {
                    iterations: sweep,
                    residual: residual_now,
                });
            }
            if !residual_now.is_finite() {
                scatter(zf, z);
                return Ok(PgsEnd::Diverged {
                    iterations: sweep,
                    residual: residual_now,
                });
            }
            if settings.stall_sweeps > 0 && sweep - mark.0 >= settings.stall_sweeps {
                if !(residual_now <= 0.5 * mark.1) {
                    ran = sweep;
                    break;
                }
                mark = (sweep, residual_now);
            }
        }
    }
    scatter(zf, z);
    if lcp.accepts(z, residual_now, settings.tolerance) {
        return Ok(PgsEnd::Solved {
            iterations: ran,
            residual: residual_now,
        });
    }
    Ok(PgsEnd::Stopped {
        iterations: ran,
        residual: residual_now,
    })
}

#[cfg(test)]
mod tests {
    use super::super::pgs_in;
    use super::*;
    use alloc::vec::Vec;

    /// A friction block as the staggered solve builds it: `M = J Jᵀ + 10⁻³ I` of 12 rows
    /// on 7 unknowns (nearly semi-definite, full rows), 8 rows pinned (`[0, 0]`, as
    /// `±μ·0` gives them: `lo = −0.0`), the other 4 boxed `[−4, 4]`.
    fn block() -> Lcp {
        let (n, dof) = (12, 7);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let j: Vec<f64> = (0..n * dof).map(|_| next()).collect();
        let mut m = alloc::vec![0.0; n * n];
        for r in 0..n {
            for c in 0..n {
                let dot: f64 = (0..dof).map(|k| j[r * dof + k] * j[c * dof + k]).sum();
                m[r * n + c] = dot + if r == c { 1e-3 } else { 0.0 };
            }
        }
        let q: Vec<f64> = (0..n).map(|_| next()).collect();
        let pinned = |i: usize| i % 3 != 1 && i != 4;
        let lo = (0..n)
            .map(|i| if pinned(i) { -0.0 } else { -4.0 })
            .collect();
        let hi = (0..n).map(|i| if pinned(i) { 0.0 } else { 4.0 }).collect();
        Lcp::boxed(m, q, lo, hi).unwrap()
    }

    /// The free rows' iterate, the end (solved, stopped at the budget, its sweeps and
    /// residual) are `pgs_in`'s bit for bit, the pinned rows zero, for the staggered
    /// friction settings (budget 10, checks every 4, last sweep unchecked) and others
    /// (every sweep checked; a budget that solves: 389 sweeps to 9.5e-11 here).
    #[test]
    fn free_rows_solve_is_the_whole_blocks() {
        let lcp = block();
        let z0: Vec<f64> = (0..lcp.n()).map(|i| 0.1 * i as f64 - 0.3).collect();
        let cases = [
            (10, 4, false),
            (10, 4, true),
            (7, 1, true),
            (10_000, 1, true),
        ];
        let mut solved = 0;
        for (max_iterations, check_every, check_last) in cases {
            let settings = PgsSettings {
                tolerance: 1e-10,
                max_iterations,
                check_every,
                ..PgsSettings::default()
            };
            let mut whole = PgsScratch::default();
            let want = pgs_in(&lcp, &settings, Some(&z0), &mut whole, check_last).unwrap();
            let mut free = PgsScratch::default();
            let got = pgs_free_rows(&lcp, &settings, &z0, &mut free, check_last).unwrap();
            assert_eq!(format!("{got:?}"), format!("{want:?}"));
            solved += usize::from(matches!(got, PgsEnd::Solved { .. }));
            for i in 0..lcp.n() {
                if lcp.lo()[i] == 0.0 && lcp.hi()[i] == 0.0 {
                    assert_eq!(free.z[i], 0.0);
                } else {
                    assert_eq!(free.z[i].to_bits(), whole.z[i].to_bits(), "row {i}");
                }
            }
        }
        assert_eq!(solved, 1);
    }
}
