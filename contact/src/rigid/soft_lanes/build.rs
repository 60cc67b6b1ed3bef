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
// The arrays below are written out for four points.
const _: () = assert!(N == 4);

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
    if pts.iter().any(|m| m.len() != N) {
        return ([[0.0; 4]; N * N], [[0.0; 4]; N]);
    }
    let zero = L::splat(0.0);
    let mut ok = [true; W];
    let mut cs = [[0.0; N]; W];
    let mut c = [zero; N];
    // Per point: `r_a × n`, `r_b × n`, `I_a⁻¹(r_a × n)`, `I_b⁻¹(r_b × n)` and the normal.
    // Plain loops: `core::array::from_fn` here was left out of line (its closures
    // cost 287k instructions a step of the 210-box pyramid, callgrind). Each branch
    // assigns the whole array (declared unset): the packed rows' without filling it
    // with zeros first (filled and then overwritten, its 1.9 kB in AVX lanes and the
    // 640 B of `built` below were two `memset` calls a build, 16.8k of the 210-box
    // pyramid's 4.76M instructions a step, callgrind).
    let g: [[Lanes3<L>; 5]; N];
    let m = match packed.and_then(|(pr, half)| Some((pr.head, pr.rows.get(..N)?, half))) {
        Some((head, pr, half)) => {
            // Written out by a macro, not by closures: a closure is compiled without
            // the AVX build's target features, so its lane operations were calls
            // (+167k instructions a step of the 210-box pyramid, callgrind).
            macro_rules! point {
                ($q:expr) => {{
                    let q = $q;
                    [
                        q.ang(head, 0, 0, half),
                        q.ang(head, 0, 1, half),
                        q.ang(head, 0, 2, half),
                        q.ang(head, 0, 3, half),
                        head.dir(0, half),
                    ]
                }};
            }
            g = [
                point!(&pr[0]),
                point!(&pr[1]),
                point!(&pr[2]),
                point!(&pr[3]),
            ];
            for (i, q) in pr.iter().enumerate() {
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
            // Filled with zeros first here (the manifolds not packed: the rare way).
            let mut h = [[Lanes3::new(zero, zero, zero); 5]; N];
            for (i, hi) in h.iter_mut().enumerate() {
                for (r, x) in hi.iter_mut().enumerate() {
                    *x = row(i, r);
                }
            }
            g = h;
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
    // Every entry written (by a macro: see `point!` above).
    macro_rules! lanes_of {
        ($v:expr; $($i:literal)*) => {
            [$($v[$i].array()),*]
        };
    }
    let built: Built = (
        lanes_of!(out; 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15),
        lanes_of!(c; 0 1 2 3),
    );
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
