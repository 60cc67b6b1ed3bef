//! The block normal solves' matrices: `K⁻¹ = (A + diag c)⁻¹` per manifold of up to
//! [`BLOCK_POINTS`] points, by Gauss–Jordan, one or two manifolds (SIMD lanes) at a time.

use super::*;

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
    let mut blocks = &mut all[..manifolds];
    let (mut j, points) = (0, &st.colouring.manifold_points);
    let manifold = |j: usize| &points[mp[j]..mp[j + 1]];
    // Two face manifolds (`N` points each) side by side in SIMD lanes
    // ([`build_block_pair`]: the same bits), the others one at a time.
    while let Some((blk, rest)) = blocks.split_first_mut() {
        let pts = manifold(j);
        if let Some(next) = rest.first_mut() {
            let pts2 = manifold(j + 1);
            if pts.len() == N && pts2.len() == N {
                build_block_pair(st, [pts, pts2], [blk, next]);
                blocks = &mut rest[1..];
                j += 2;
                continue;
            }
        }
        build_block(st, pts, blk);
        blocks = rest;
        j += 1;
    }
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

/// Two manifolds' blocks of [`BLOCK_POINTS`] points each (see [`build_blocks`]), one
/// per SIMD lane (`wide::f64x2`): each lane does [`build_block`]'s arithmetic
/// operation for operation and in the same order (IEEE-754 lanes round as the scalar
/// operations do; dot products summed left to right as `DVec3::dot` does), so the
/// blocks are the same, bit for bit (a lane whose pivot fails computes on, harmlessly,
/// where the scalar inversion stops: its block keeps `len` 0 either way).
pub(super) fn build_block_pair(st: &SoftState, pts: [&[usize]; 2], blk: [&mut Block; 2]) {
    const N: usize = BLOCK_POINTS;
    let lanes = |a: DVec3, b: DVec3| {
        [
            f64x2::new([a.x, b.x]),
            f64x2::new([a.y, b.y]),
            f64x2::new([a.z, b.z]),
        ]
    };
    let dot = |a: &[f64x2; 3], b: &[f64x2; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let [blk0, blk1] = blk;
    let mut ok = [true; 2];
    let mut c = [f64x2::ZERO; N];
    for (s, (pts, blk)) in pts.iter().zip([&mut *blk0, &mut *blk1]).enumerate() {
        for (i, &p) in pts.iter().enumerate() {
            let sp = st.soft[p];
            let m = st.mass[p][0];
            ok[s] &= m > 0.0 && sp.mass_scale > 0.0;
            blk.c[i] = sp.impulse_scale / (sp.mass_scale * m);
            c[i].as_mut_array()[s] = blk.c[i];
        }
    }
    let sum = |p: usize| {
        let [ma, mb] = st.im[p];
        ma + mb
    };
    let m = f64x2::new([sum(pts[0][0]), sum(pts[1][0])]);
    // Per point: the normal and `r_a × n`, `r_b × n`, `I_a⁻¹(r_a × n)`, `I_b⁻¹(r_b × n)`.
    let row = |i: usize, r: usize| {
        let (p, q) = (pts[0][i], pts[1][i]);
        if r == 4 {
            lanes(st.dir[p][0], st.dir[q][0])
        } else {
            lanes(st.ang[p][0][r], st.ang[q][0][r])
        }
    };
    let rows: [[[f64x2; 3]; 5]; N] = core::array::from_fn(|i| core::array::from_fn(|r| row(i, r)));
    let mut k = [f64x2::ZERO; N * N];
    for i in 0..N {
        let (n, g) = (&rows[i][4], &rows[i]);
        for l in i..N {
            let h = &rows[l];
            let a = m * dot(n, &h[4]) + dot(&g[0], &h[2]) + dot(&g[1], &h[3]);
            k[i * N + l] = a;
            k[l * N + i] = a;
        }
        k[i * N + i] += c[i];
    }
    let mut out = [f64x2::ZERO; N * N];
    let inverted = invert_pair(&mut k, &mut out);
    for (s, (pts, blk)) in pts.iter().zip([blk0, blk1]).enumerate() {
        blk.len = 0;
        if ok[s] && inverted[s] {
            let kinv: [f64; N * N] = core::array::from_fn(|e| out[e].as_array()[s]);
            if kinv.iter().all(|x| x.is_finite()) {
                blk.kinv = kinv;
                blk.pts.copy_from_slice(pts);
                blk.len = N;
            }
        }
    }
}

/// [`invert`] of two matrices, one per lane of `k` and `out`: per lane, whether every
/// pivot was positive and finite (the caller checks that the inverse is finite).
pub(super) fn invert_pair(
    k: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
) -> [bool; 2] {
    const N: usize = BLOCK_POINTS;
    *out = [f64x2::ZERO; N * N];
    for i in 0..N {
        out[i * N + i] = f64x2::ONE;
    }
    let mut ok = [true; 2];
    pivot_pair::<0>(k, out, &mut ok);
    pivot_pair::<1>(k, out, &mut ok);
    pivot_pair::<2>(k, out, &mut ok);
    pivot_pair::<3>(k, out, &mut ok);
    ok
}

/// [`pivot`] on both lanes (clearing a lane's `ok` where its pivot is not positive
/// and finite, where [`invert`] would stop).
#[inline(always)]
pub(super) fn pivot_pair<const C: usize>(
    k: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
    ok: &mut [bool; 2],
) {
    const N: usize = BLOCK_POINTS;
    let piv = k[C * N + C];
    for (ok, p) in ok.iter_mut().zip(piv.to_array()) {
        *ok &= p > 0.0 && p.is_finite();
    }
    let inv = f64x2::ONE / piv;
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
