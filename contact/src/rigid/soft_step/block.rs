//! The block normal solves' matrices: `K⁻¹ = (A + diag c)⁻¹` per manifold of up to
//! [`BLOCK_POINTS`] points, by Gauss–Jordan, one, two or four manifolds (SIMD lanes) at
//! a time.

use super::*;
use crate::rigid::soft_lanes::{build_lanes, build_quad};

/// The block normal solves of the manifolds (colour order). With `c_i =
/// impulse_scale / (mass_scale · m_i)` (see [`solve_block`]) and
///
/// ```text
/// A_ij = J_i M⁻¹ J_jᵀ = (1/m_a + 1/m_b) n_iᵀn_j + (r_a,i × n_i)ᵀ I_a⁻¹ (r_a,j × n_j)
///                                          + (r_b,i × n_i)ᵀ I_b⁻¹ (r_b,j × n_j),
/// ```
///
/// keeps `K⁻¹ = (A + diag c)⁻¹` by Gauss–Jordan (`K` is symmetric positive definite:
/// `A` is a Gram matrix and `c > 0`). A manifold of one point or more than
/// [`BLOCK_POINTS`], a row without mass, or a pivot that is not positive and finite
/// keeps `len` 0: its points are solved one by one.
pub(super) fn build_blocks(st: &mut SoftState) {
    const N: usize = BLOCK_POINTS;
    let mp = &st.colouring.manifold_start;
    let manifolds = mp.len().saturating_sub(1);
    // Sized once (a no-op when the count is the last step's) and written in place: a
    // block's `pts`, `c` and `kinv` are read only when its `len` is set, and then all
    // of them have been written here (a new block pushed per manifold cost a zeroing
    // and a 200-byte copy each).
    // Taken while the rows are read beside them.
    let mut all = core::mem::take(&mut st.blocks);
    all.resize(manifolds, Block::default());
    let blocks = &mut all[..manifolds];
    // Taken while the rows are read beside it: the packed pairs' blocks go into it.
    let mut paired = core::mem::take(&mut st.paired);
    let points = &st.colouring.manifold_points;
    let manifold = |j: usize| &points[mp[j]..mp[j + 1]];
    let face = |j: usize| j < manifolds && manifold(j).len() == N;
    let (avx, rows) = (paired.avx(), rows!(st));
    // Four face manifolds (`N` points each) side by side in AVX lanes where the
    // processor has AVX and they are a packed quad, two in SIMD lanes ([`build_lanes`]:
    // the same bits; the face manifolds of no packed pair two by two in order), the
    // others one at a time. The packed pairs' (quads') blocks are
    // packed beside their rows ([`Paired::put_block`]: every packed pair of face
    // manifolds starts a build of its own, so the biased pass finds each one's
    // blocks there).
    let (mut j, mut single) = (0, None);
    while j < manifolds {
        let starts = paired.starts(j);
        if starts && face(j) {
            if let (Some(avx), Some(pr)) = (avx, paired.quad(j, N)) {
                if let [b0, b1, b2, b3] = &mut blocks[j..j + 4] {
                    let pts = [
                        manifold(j),
                        manifold(j + 1),
                        manifold(j + 2),
                        manifold(j + 3),
                    ];
                    let (kinv, c) = build_quad(avx, &rows, pr, pts, [b0, b1, b2, b3]);
                    paired.put_block::<4>(j, &kinv, &c);
                    j += 4;
                    continue;
                }
            }
            if let [b0, b1] = &mut blocks[j..j + 2] {
                let pts = [manifold(j), manifold(j + 1)];
                let (kinv, c) = build_lanes::<f64x2, 2>(&rows, pts, paired.of(j, N), [b0, b1]);
                paired.put_block::<2>(j, &kinv, &c);
                j += 2;
                continue;
            }
        }
        if !starts && face(j) {
            // Paired with the last such face manifold left alone, if any (a colour's
            // odd one: a block's bits do not depend on its lane).
            match single.take() {
                Some(i) => {
                    let (head, tail) = blocks.split_at_mut(j);
                    let pts = [manifold(i), manifold(j)];
                    build_lanes::<f64x2, 2>(&rows, pts, None, [&mut head[i], &mut tail[0]]);
                }
                None => single = Some(j),
            }
            j += 1;
            continue;
        }
        build_block(st, manifold(j), &mut blocks[j]);
        j += 1;
    }
    if let Some(i) = single {
        build_block(st, manifold(i), &mut blocks[i]);
    }
    st.paired = paired;
    st.blocks = all;
}

/// One manifold's block (see [`build_blocks`]).
#[inline(always)]
pub(super) fn build_block(st: &SoftState, pts: &[usize], blk: &mut Block) {
    const N: usize = BLOCK_POINTS;
    let len = pts.len();
    blk.len = 0;
    if (2..=N).contains(&len) {
        let [ma, mb] = st.im[pts[0]];
        let mut ok = true;
        for (i, &p) in pts.iter().enumerate() {
            let sp = st.soft[p];
            let m = st.mass[p][0];
            ok &= m > 0.0 && sp.mass_scale > 0.0;
            blk.c[i] = sp.impulse_scale / (sp.mass_scale * m);
        }
        // Padding: identity rows and columns, so that `K⁻¹` is too (the solve
        // runs over all N with zero residuals there).
        let mut k = [0.0; N * N];
        for i in 0..N {
            k[i * N + i] = 1.0;
        }
        for i in 0..len {
            let p = pts[i];
            let (n, g) = (st.dir[p][0], &st.ang[p][0]);
            for l in i..len {
                let q = pts[l];
                let h = &st.ang[q][0];
                let a = (ma + mb) * n.dot(st.dir[q][0]) + g[0].dot(h[2]) + g[1].dot(h[3]);
                k[i * N + l] = a;
                k[l * N + i] = a;
            }
            k[i * N + i] += blk.c[i];
        }
        if ok && invert(&mut k, &mut blk.kinv) {
            blk.pts[..len].copy_from_slice(pts);
            blk.len = len;
        }
    }
}

/// Inverts `k` (row-major `N × N`, symmetric positive definite) into `out` by
/// Gauss–Jordan without pivoting; false if a pivot is not positive and finite or the
/// inverse is not finite (`out` is then not to be used).
pub(super) fn invert(
    k: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
) -> bool {
    const N: usize = BLOCK_POINTS;
    *out = [0.0; N * N];
    for i in 0..N {
        out[i * N + i] = 1.0;
    }
    // One pivot per column, each with its column fixed at compile time (its loops
    // then unroll: with a run-time column the shortened loops cost more than they
    // save, 12.6k → 19.5k instructions a step for the 10-box stack's blocks).
    const _: () = assert!(BLOCK_POINTS == 4, "invert takes four pivots");
    pivot::<0>(k, out)
        && pivot::<1>(k, out)
        && pivot::<2>(k, out)
        && pivot::<3>(k, out)
        && out.iter().all(|x| x.is_finite())
}

/// Pivot `C` of [`invert`]'s Gauss–Jordan sweep: row `C` over its pivot, then column
/// `C` eliminated from the other rows; false if the pivot is not positive and finite.
/// Only what is read again is updated: `k`'s columns `≤ C` are never read after this
/// pivot (later pivots read the columns `> C`), and `out`'s row `C` is zero beyond
/// column `C` (row `c` of `out` is zero past column `c` until pivot `c`), so `out`
/// changes in the columns `≤ C` only (subtracting `f · 0` leaves an entry's bits as
/// they were: `f` and `1/pivot` are finite here, or `out` ends non-finite either
/// way). The same bits as the full sweep over all `N` columns.
#[inline(always)]
pub(super) fn pivot<const C: usize>(
    k: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
) -> bool {
    const N: usize = BLOCK_POINTS;
    let piv = k[C * N + C];
    if !(piv > 0.0 && piv.is_finite()) {
        return false;
    }
    let inv = 1.0 / piv;
    for l in C + 1..N {
        k[C * N + l] *= inv;
    }
    for l in 0..=C {
        out[C * N + l] *= inv;
    }
    for r in 0..N {
        if r != C {
            let f = k[r * N + C];
            for l in C + 1..N {
                k[r * N + l] -= f * k[C * N + l];
            }
            for l in 0..=C {
                out[r * N + l] -= f * out[C * N + l];
            }
        }
    }
    true
}
