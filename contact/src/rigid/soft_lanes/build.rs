//! The block normal solves' `K⁻¹ = (A + diag c)⁻¹` of `W` manifolds of
//! [`BLOCK_POINTS`] points at once, one manifold per lane (two `f64x2` lanes, or
//! four AVX lanes: `avx::build_quad`): each lane does the scalar `build_block`'s
//! arithmetic operation for operation and in the same order (IEEE-754 lanes round as
//! the scalar operations do, division included; dot products summed left to right
//! as `DVec3::dot` does), so the blocks are the same, bit for bit (a lane whose pivot
//! fails computes on, harmlessly, where the scalar inversion stops: its block keeps
//! `len` 0 either way).

use super::{Lane, Lanes3, Pack};
use crate::rigid::soft_step::{Block, Rows, BLOCK_POINTS};

const N: usize = BLOCK_POINTS;

/// The lanes of `K⁻¹`'s entries (row-major) and of `c` of a build.
pub(in crate::rigid) type Built = ([[f64; 4]; N * N], [[f64; 4]; N]);

/// The blocks of the `W` manifolds `pts` (each of [`BLOCK_POINTS`] points; others
/// are left as they were) into `blk`, one per lane of `L`: with `c_i = impulse_scale
/// / (mass_scale · m_i)` and `A_ij = (1/m_a + 1/m_b) n_iᵀn_j + (r_a,i × n_i)ᵀ I_a⁻¹
/// (r_a,j × n_j) + (r_b,i × n_i)ᵀ I_b⁻¹ (r_b,j × n_j)`, `K⁻¹ = (A + diag c)⁻¹` by
/// Gauss–Jordan without pivoting (Box2D v2.4's block solver's `K`, for four points).
/// Returns the lanes of `K⁻¹`'s entries (row-major) and of `c` (for
/// [`Paired::put_block`](super::Paired::put_block)).
///
/// `packed`: the manifolds' packed rows and the half of their lanes they take
/// ([`Paired::of`](super::Paired::of)), where they are a packed pair (or quad): the
/// normals, angular terms and inverse masses are then loaded from there, lanes at
/// once, instead of gathered point by point from `rows` (`prepare` wrote the same
/// values to both, [`Paired::put`](super::Paired::put)).
#[inline(always)]
pub(in crate::rigid) fn build_lanes<L: Lane, const W: usize>(
    rows: &Rows,
    pts: [&[usize]; W],
    packed: Option<(Pack, usize)>,
    blk: [&mut Block; W],
) -> Built {
    let mut built = ([[0.0; 4]; N * N], [[0.0; 4]; N]);
    if pts.iter().any(|m| m.len() != N) {
        return built;
    }
    let zero = L::splat(0.0);
    let mut ok = [true; W];
    let mut cs = [[0.0; N]; W];
    let mut c = [zero; N];
    // Per point: `r_a × n`, `r_b × n`, `I_a⁻¹(r_a × n)`, `I_b⁻¹(r_b × n)` and the normal.
    // Plain loops: `core::array::from_fn` here was left out of line (its closures
    // cost 287k instructions a step of the 210-box pyramid, callgrind).
    let mut g = [[Lanes3::new(zero, zero, zero); 5]; N];
    let m = match packed.and_then(|(pr, half)| Some((pr.head, pr.rows.get(..N)?, half))) {
        Some((head, pr, half)) => {
            for (i, (gi, q)) in g.iter_mut().zip(pr).enumerate() {
                for (r, x) in gi.iter_mut().enumerate() {
                    *x = if r == 4 {
                        head.dir(0, half)
                    } else {
                        q.ang(head, 0, r, half)
                    };
                }
                // `c_i` of the lanes at once: one lane division where the scalar
                // build takes one per lane.
                let [scale, ms] = L::gather(|l| {
                    let sp = &rows.soft[pts[l][i]];
                    [sp.impulse_scale, sp.mass_scale]
                });
                let m = q.mass::<L>(0, half);
                c[i] = scale / (ms * m);
                let (m, ms, ci) = (m.array(), ms.array(), c[i].array());
                for (s, ok) in ok.iter_mut().enumerate() {
                    *ok &= m[s] > 0.0 && ms[s] > 0.0;
                    cs[s][i] = ci[s];
                }
            }
            let (ma, mb) = head.im::<L>(half);
            ma + mb
        }
        None => {
            for (s, pts) in pts.iter().enumerate() {
                for (i, &p) in pts.iter().enumerate() {
                    let sp = rows.soft[p];
                    let m = rows.mass[p][0];
                    ok[s] &= m > 0.0 && sp.mass_scale > 0.0;
                    cs[s][i] = sp.impulse_scale / (sp.mass_scale * m);
                }
            }
            c = L::gather(|l| cs[l]);
            let row = |i: usize, r: usize| {
                Lanes3::<L>::of(|l| {
                    let p = pts[l][i];
                    if r == 4 {
                        rows.dir[p][0]
                    } else {
                        rows.ang[p][0][r]
                    }
                })
            };
            for (i, gi) in g.iter_mut().enumerate() {
                for (r, x) in gi.iter_mut().enumerate() {
                    *x = row(i, r);
                }
            }
            let [m] = L::gather(|l| {
                let [ma, mb] = rows.im[pts[l][0]];
                [ma + mb]
            });
            m
        }
    };
    let mut k = [zero; N * N];
    for i in 0..N {
        let (n, gi) = (g[i][4], &g[i]);
        for l in i..N {
            let h = &g[l];
            let a = m * n.dot(h[4]) + gi[0].dot(h[2]) + gi[1].dot(h[3]);
            k[i * N + l] = a;
            k[l * N + i] = a;
        }
        k[i * N + i] = k[i * N + i] + c[i];
    }
    let mut out = [zero; N * N];
    for i in 0..N {
        out[i * N + i] = L::splat(1.0);
    }
    pivot::<L, W, 0>(&mut k, &mut out, &mut ok);
    pivot::<L, W, 1>(&mut k, &mut out, &mut ok);
    pivot::<L, W, 2>(&mut k, &mut out, &mut ok);
    pivot::<L, W, 3>(&mut k, &mut out, &mut ok);
    for (e, x) in built.0.iter_mut().enumerate() {
        *x = out[e].array();
    }
    for (i, x) in built.1.iter_mut().enumerate() {
        *x = c[i].array();
    }
    // Per lane, whether every entry of `K⁻¹` is finite: `x − x` is `+0` for a finite
    // `x` and NaN for an infinite or NaN one, and a sum of them `+0` only where all
    // are (one vector sum instead of 16 checks per lane).
    let mut nonfinite = zero;
    for x in &out {
        // Deliberately `x − x` (the finiteness test above).
        #[allow(clippy::eq_op)]
        let d = *x - *x;
        nonfinite = nonfinite + d;
    }
    let finite = nonfinite.array();
    let lanes = &built.0;
    for (s, (pts, blk)) in pts.iter().zip(blk).enumerate() {
        blk.c = cs[s];
        blk.len = 0;
        if ok[s] {
            let mut kinv = [0.0; N * N];
            for (x, e) in kinv.iter_mut().zip(lanes) {
                *x = e[s];
            }
            if finite[s] == 0.0 {
                blk.kinv = kinv;
                blk.pts.copy_from_slice(pts);
                blk.len = N;
            }
        }
    }
    built
}

/// Pivot `C` of the scalar `invert`'s Gauss–Jordan sweep on every lane (clearing a
/// lane's `ok` where its pivot is not positive and finite, where `invert` stops):
/// row `C` over its pivot, then column `C` eliminated from the other rows, only
/// what is read again updated (as `pivot`).
#[inline(always)]
fn pivot<L: Lane, const W: usize, const C: usize>(
    k: &mut [L; N * N],
    out: &mut [L; N * N],
    ok: &mut [bool; W],
) {
    let piv = k[C * N + C];
    let p = piv.array();
    for (l, ok) in ok.iter_mut().enumerate() {
        *ok &= p[l] > 0.0 && p[l].is_finite();
    }
    let inv = L::splat(1.0) / piv;
    for l in C + 1..N {
        k[C * N + l] = k[C * N + l] * inv;
    }
    for l in 0..=C {
        out[C * N + l] = out[C * N + l] * inv;
    }
    for r in 0..N {
        if r != C {
            let f = k[r * N + C];
            for l in C + 1..N {
                k[r * N + l] = k[r * N + l] - f * k[C * N + l];
            }
            for l in 0..=C {
                out[r * N + l] = out[r * N + l] - f * out[C * N + l];
            }
        }
    }
}
