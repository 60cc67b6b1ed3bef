//! The block normal solve's exact path: the manifold's normal rows as one small
//! linear complementarity problem, solved by enumerating the active sets, with a
//! preload on its cap taken at the sub-step's end.
//!
//! [`solve_block`]'s fast path takes `Δλ = −K⁻¹ r` when every `λ'` stays
//! non-negative and no preload is on its cap. Where an impulse would turn negative
//! this solves the manifold's rows together instead of one Gauss–Seidel pass over its
//! points (one pass over the corners of a face is not the face's solution: its error
//! is a rocking velocity). Where a point's preload is on its cap, `λ_pre = κ (−C)`
//! with `κ = M γ/(1 − γ) · m h ω²` ([`SoftStepSettings::preload_cap_margin`]), the
//! preload is a spring `M γ/(1 − γ)` (196 at the defaults) times as stiff as the
//! contact's own; read at the gap of the sub-step's start it is an explicit stiff
//! spring, and it grew the 210-box pyramid's out-of-plane sway (period ≈ 40 steps)
//! from 0.1 mm to 5 cm (`soft_points pyramid20 1800 3 preload=0.98000001`: the flank
//! points, whose static load estimate exceeds their load, rest on the cap). Here it
//! is taken at the sub-step's end, `C' = C + h J v'`, as the soft row takes its own
//! spring (implicit Euler):
//!
//! ```text
//! soft row:    w_i = J_i v' + b_i + c_i (λ_i' − λ_pre,i)
//! on the cap:  λ_pre,i = κ_i (−C_i − h J_i v')
//!          ⇒  w_i = J_i v' + (b_i + c_i κ_i C_i)/e_i + (c_i/e_i) λ_i',  e_i = 1 + c_i κ_i h
//! K = A + diag c',  c'_i = c_i, or c_i/e_i on the cap,  A = J M⁻¹ Jᵀ
//! λ' = λ + Δλ ≥ 0,  w = r + K Δλ ≥ 0,  λ'_i w_i = 0
//! ```
//!
//! (each row divided by `e_i` so that `K` stays symmetric). A capped preload that
//! would leave `[floor, λ_pre]` at the sub-step's end is held at that bound and the
//! manifold solved again. Each row is the complementarity `solve_point` clamps one
//! row at a time to, here coupled (Box2D v2.4's
//! `b2ContactSolver::SolveVelocityConstraints` enumerates the same cases for two
//! points; Cottle, Pang & Stone 1992, §1.1 for the LCP). `K` is symmetric positive
//! definite (`A` a Gram matrix, `c' > 0`), so the LCP has one solution, which one of
//! the `2^len` active sets `S` gives: `Δλ_i = −λ_i` off `S`, `K_SS Δλ_S = −(r_S +
//! K_{S,S̄} Δλ_S̄)` on it (Cholesky), taken when `λ'_S ≥ 0` and `w_S̄ ≥ 0`. The sets
//! are tried from all points down (the likely ones first).

use super::*;

/// Active sets of up to [`BLOCK_POINTS`] points as bit masks, the most points first.
const SETS: [u8; 16] = [15, 14, 13, 11, 7, 12, 10, 9, 6, 5, 3, 8, 4, 2, 1, 0];

/// How one row of the manifold is taken (see the module docs).
#[derive(Clone, Copy, PartialEq)]
enum Regime {
    /// The preload on its cap, taken at the sub-step's end.
    Capped,
    /// With this preload.
    Plain(f64),
}

/// Whether a preload is on its cap: `floor < κ (−C) < λ_pre` (strictly: with the
/// preload off, `κ` and `λ_pre` are 0 and no point is).
#[inline(always)]
pub(super) fn on_cap(cap: f64, floor: f64, preload: f64) -> bool {
    cap > floor && cap < preload
}

/// The manifold's normal rows as the LCP of the module docs, applied to the
/// velocities `(va, wa, vb, wb)` and the impulses `z`, `max_normal` (in `blk.pts`
/// order), `gaps` the points' gaps. A point whose capped preload would leave `[floor,
/// λ_pre]` at the sub-step's end is taken with that bound instead and the manifold
/// solved again (at most once per point). False, with nothing changed, where no
/// active set solves it (a pivot not positive or a value not finite): the caller
/// then solves the points one by one.
#[inline(never)]
pub(super) fn block_lcp(
    rows: &Rows,
    blk: &Block,
    gaps: &[f64; BLOCK_POINTS],
    z: &mut [[f64; 3]; BLOCK_POINTS],
    max_normal: &mut [f64; BLOCK_POINTS],
    v: (&mut DVec3, &mut DVec3, &mut DVec3, &mut DVec3),
    pass: Pass,
) -> bool {
    const N: usize = BLOCK_POINTS;
    let len = blk.len.min(N);
    let full = ((1u16 << len) - 1) as u8;
    let (va, wa, vb, wb) = v;
    let s = rows.soft[blk.pts[0]];
    let h = 1.0 / pass.inv_h;
    let mut vn = [0.0; N];
    let mut regime = [Regime::Plain(0.0); N];
    for i in 0..len {
        let p = blk.pts[i];
        let (d, g) = (&rows.dir[p], &rows.ang[p]);
        vn[i] = d[0].dot(*vb - *va) + g[0][1].dot(*wb) - g[0][0].dot(*wa);
        let gap = gaps[i];
        let (cap, floor, preload) = (
            rows.preload_cap[p] * -gap,
            rows.preload_floor[p],
            rows.preload[p],
        );
        regime[i] = if on_cap(cap, floor, preload) {
            Regime::Capped
        } else {
            Regime::Plain(at_most(preload, at_least(cap, floor)))
        };
    }
    let a = block_matrix(rows, blk, len);
    let lam: [f64; N] = core::array::from_fn(|i| if i < len { z[i][0] } else { 0.0 });
    let mut dz = [0.0; N];
    for _ in 0..=len {
        let mut r = [0.0; N];
        let mut k = a;
        for i in len..N {
            k[i * N + i] = 1.0;
        }
        for i in 0..len {
            let p = blk.pts[i];
            let (gap, c) = (gaps[i], blk.c[i]);
            let bias = at_least(s.bias_rate * gap, -pass.max_push);
            let (cd, ri) = match regime[i] {
                Regime::Plain(pre) => (c, vn[i] + bias + c * (lam[i] - pre)),
                Regime::Capped => {
                    // λ_pre = κ (−C − h J v'): (1 + c κ h) J v' + b + c κ C + c λ' = 0,
                    // divided by e = 1 + c κ h (K stays symmetric).
                    let kappa = rows.preload_cap[p];
                    let e = 1.0 + c * kappa * h;
                    let cd = c / e;
                    (cd, vn[i] + (bias + c * kappa * gap) / e + cd * lam[i])
                }
            };
            k[i * N + i] += cd;
            r[i] = ri;
        }
        let Some(x) = SETS
            .iter()
            .filter(|&&set| set & !full == 0)
            .find_map(|&set| try_set(&k, &r, &lam, set, len))
        else {
            return false;
        };
        dz = x;
        // A capped preload past its bounds at the sub-step's end: the bound instead.
        let mut again = false;
        for i in 0..len {
            if regime[i] != Regime::Capped || !(lam[i] + dz[i] > 0.0) {
                continue;
            }
            let p = blk.pts[i];
            let mut jv = vn[i];
            for l in 0..len {
                jv += a[i * N + l] * dz[l];
            }
            let pre = rows.preload_cap[p] * -(gaps[i] + h * jv);
            if pre > rows.preload[p] {
                regime[i] = Regime::Plain(rows.preload[p]);
                again = true;
            } else if pre < rows.preload_floor[p] {
                regime[i] = Regime::Plain(rows.preload_floor[p]);
                again = true;
            }
        }
        if !again {
            break;
        }
    }
    for i in 0..len {
        let p = blk.pts[i];
        let d = &rows.dir[p];
        let g = &rows.ang[p];
        let [ma, mb] = rows.im[p];
        // λ' = 0 exactly off the active set (λ + (−λ) is 0 for finite λ).
        z[i][0] = at_least(z[i][0] + dz[i], 0.0);
        max_normal[i] = at_least(z[i][0], max_normal[i]);
        *va -= d[0] * (ma * dz[i]);
        *wa -= g[0][2] * dz[i];
        *vb += d[0] * (mb * dz[i]);
        *wb += g[0][3] * dz[i];
    }
    true
}

/// `A = J M⁻¹ Jᵀ` of the manifold's normal rows (row-major, zero beyond `len`), as
/// [`build_block`] forms it.
fn block_matrix(rows: &Rows, blk: &Block, len: usize) -> [f64; BLOCK_POINTS * BLOCK_POINTS] {
    const N: usize = BLOCK_POINTS;
    let mut k = [0.0; N * N];
    let [ma, mb] = rows.im[blk.pts[0]];
    for i in 0..len {
        let p = blk.pts[i];
        let (n, g) = (rows.dir[p][0], &rows.ang[p][0]);
        for l in i..len {
            let q = blk.pts[l];
            let h = &rows.ang[q][0];
            let a = (ma + mb) * n.dot(rows.dir[q][0]) + g[0].dot(h[2]) + g[1].dot(h[3]);
            k[i * N + l] = a;
            k[l * N + i] = a;
        }
    }
    k
}

/// The update `Δλ` of active set `set` (see the module docs), if it is the LCP's
/// solution: `λ + Δλ ≥ 0` on the set, `w ≥ 0` off it.
fn try_set(
    k: &[f64; BLOCK_POINTS * BLOCK_POINTS],
    r: &[f64; BLOCK_POINTS],
    lam: &[f64; BLOCK_POINTS],
    set: u8,
    len: usize,
) -> Option<[f64; BLOCK_POINTS]> {
    const N: usize = BLOCK_POINTS;
    let on = |i: usize| set & (1 << i) != 0;
    let mut dz = [0.0; N];
    for i in 0..len {
        if !on(i) {
            dz[i] = -lam[i];
        }
    }
    // The active rows' system `K_SS x = −(r_S + K_{S,S̄} Δλ_S̄)`, gathered.
    let idx: [usize; N] = {
        let mut idx = [0; N];
        let mut m = 0;
        for i in 0..len {
            if on(i) {
                idx[m] = i;
                m += 1;
            }
        }
        idx
    };
    let m = set.count_ones() as usize;
    let mut a = [0.0; N * N];
    let mut b = [0.0; N];
    for (s, &i) in idx.iter().enumerate().take(m) {
        let mut rhs = r[i];
        for (l, &d) in dz.iter().enumerate().take(len) {
            rhs += k[i * N + l] * d;
        }
        b[s] = -rhs;
        for (t, &l) in idx.iter().enumerate().take(m) {
            a[s * N + t] = k[i * N + l];
        }
    }
    let x = cholesky_solve(&mut a, b, m)?;
    for (s, &i) in idx.iter().enumerate().take(m) {
        if !(lam[i] + x[s] >= 0.0) {
            return None;
        }
        dz[i] = x[s];
    }
    for i in 0..len {
        if !on(i) {
            let mut w = r[i];
            for (l, &d) in dz.iter().enumerate().take(len) {
                w += k[i * N + l] * d;
            }
            if !(w >= 0.0) {
                return None;
            }
        }
    }
    Some(dz)
}

/// Solves `a x = b` for the leading `m × m` block of `a` (row stride
/// [`BLOCK_POINTS`], symmetric positive definite) by Cholesky, `a = L Lᵀ` in place;
/// `None` if a pivot is not positive and finite.
fn cholesky_solve(
    a: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
    mut b: [f64; BLOCK_POINTS],
    m: usize,
) -> Option<[f64; BLOCK_POINTS]> {
    const N: usize = BLOCK_POINTS;
    for j in 0..m {
        let mut d = a[j * N + j];
        for l in 0..j {
            d -= a[j * N + l] * a[j * N + l];
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let d = libm::sqrt(d);
        a[j * N + j] = d;
        for i in j + 1..m {
            let mut s = a[i * N + j];
            for l in 0..j {
                s -= a[i * N + l] * a[j * N + l];
            }
            a[i * N + j] = s / d;
        }
    }
    // L y = b, then Lᵀ x = y.
    for i in 0..m {
        for l in 0..i {
            b[i] -= a[i * N + l] * b[l];
        }
        b[i] /= a[i * N + i];
    }
    for i in (0..m).rev() {
        for l in i + 1..m {
            b[i] -= a[l * N + i] * b[l];
        }
        b[i] /= a[i * N + i];
    }
    b.iter().all(|x| x.is_finite()).then_some(b)
}
