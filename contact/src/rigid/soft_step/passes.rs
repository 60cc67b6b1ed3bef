//! The soft step's point passes: warm start, gap updates, the biased and relax
//! Gauss–Seidel passes (block normal solves, friction), restitution and the residual.

use super::*;
use crate::rigid::soft_lanes::gaps_quad;

/// `v += M⁻¹ Jᵀ λ` of point `p` on the state's own velocities (restitution).
pub(super) fn apply(st: &mut SoftState, p: usize, z: [f64; 3]) {
    let (rows, mut vel, _, _) = split!(st);
    apply_point(&rows, p, z, &mut vel);
}

/// Applies the stored impulses of every point (warm start, each sub-step) in solve
/// order: colour by colour, two manifolds at a time in SIMD lanes
/// ([`warm_manifolds`]: the same bits as [`apply_point`] one point at a time, the
/// manifolds of a colour touching disjoint moving bodies), a colour's odd manifold
/// and the overflow colour's points (whose manifolds may share bodies) one by one.
pub(super) fn warm_start(st: &mut SoftState) {
    // The packed rows borrowed (taking them, seven `Vec`s since they were split by
    // reader, cost a 176 B copy out and back and a drop per pass: `soft_points
    // stack10` 137.4k → 136.6k instructions a step borrowed, pyramid20 4918.8k →
    // 4917.1k; when it was four `Vec`s, taking saved 0.35 %). The 430 B colouring is
    // borrowed too: taking it copied it twice a pass.
    let paired = &st.paired;
    let colouring = &st.colouring;
    {
        let (rows, mut vel, impulse, _) = split!(st);
        let mut one = |p: usize, vel: &mut Slices| apply_point(&rows, p, impulse[p], vel);
        for_manifold_pairs(
            colouring,
            rows.slots.len(),
            paired.four(),
            |j, pts, vel: &mut Slices| {
                let pr = paired.quad(j, pts[0].len());
                warm_quad(&rows, pr, pts, vel.v, vel.w, impulse)
            },
            |j, pts, vel: &mut Slices| {
                let pr = paired.of(j, pts[0].len());
                warm_manifolds(&rows, pr, pts, vel.v, vel.w, impulse)
            },
            &mut one,
            &mut vel,
        );
    }
}

/// Walks the colouring for the point passes that take two manifolds at a time: per
/// colour before the overflow colour, with `four`, `quad` on consecutive manifolds
/// `j … j + 3` (where it declines, and without `four`, as two pairs), `pair` on
/// consecutive manifolds `(j, j + 1)` (their points in order; where it declines, and
/// for a colour's odd manifold, `one` on each point in order), then `one` on the
/// overflow colour's points in solve order (its manifolds may share bodies). Within a
/// colour the manifolds touch disjoint moving bodies, so this is the same work, bit
/// for bit, as every point in solve order.
#[inline(always)]
pub(super) fn for_manifold_pairs<S>(
    colouring: &Colouring,
    points: usize,
    four: bool,
    mut quad: impl FnMut(usize, [&[usize]; 4], &mut S) -> bool,
    mut pair: impl FnMut(usize, [&[usize]; 2], &mut S) -> bool,
    one: &mut impl FnMut(usize, &mut S),
    state: &mut S,
) {
    let (mp, pts) = (
        colouring.manifold_start.as_slice(),
        colouring.manifold_points.as_slice(),
    );
    let manifold = |j: usize| &pts[mp[j]..mp[j + 1]];
    let starts = colouring.colour_start.as_slice();
    let colours = starts.len().saturating_sub(1);
    let serial = colouring.serial_from + 1 < colouring.ranges.len();
    let empty: &[usize] = &[];
    // One call site of `one` (inlined once), fed the points of a declined pair, of a
    // colour's odd manifold or of the overflow colour.
    for c in 0..colours {
        let overflow = serial && c + 1 == colours;
        let (mut j, hi) = (starts[c], starts[c + 1]);
        while j < hi {
            let (m0, m1, positions) = if overflow {
                j = hi;
                (
                    empty,
                    empty,
                    colouring.ranges[colouring.serial_from]..points,
                )
            } else {
                if four && j + 3 < hi {
                    // The five bounds of the four manifolds read (and checked) once.
                    if let Some(&[b0, b1, b2, b3, b4]) = mp.get(j..j + 5) {
                        let m = |a: usize, b: usize| &pts[a..b];
                        if quad(j, [m(b0, b1), m(b1, b2), m(b2, b3), m(b3, b4)], state) {
                            j += 4;
                            continue;
                        }
                    }
                }
                let m0 = manifold(j);
                let m1 = if j + 1 < hi { manifold(j + 1) } else { empty };
                j += 2;
                if !m1.is_empty() && pair(j - 2, [m0, m1], state) {
                    continue;
                }
                (m0, m1, 0..0)
            };
            for p in m0.iter().chain(m1).copied().chain(positions) {
                one(p, state);
            }
        }
    }
}

/// Every point's gap at the current displacements into `st.gap` (once per
/// sub-step, after the positions: the relax passes and the next biased pass share
/// it, where each pass computed it before; the same bits). Manifold by manifold, so
/// that the two bodies' displacements are loaded once for all of its points: the
/// same arithmetic as `C₀ + nᵀ Δd` ([`separation`]). Two consecutive manifolds
/// with as many points go side by side in SIMD lanes ([`manifold_gaps`]: each gap
/// reads only the step's rows and displacements, so any two manifolds may pair; the
/// same bits), the others one point at a time (the 210-box pyramid's `update_gaps`
/// 407k → 326k instructions a step, callgrind). The packed pairs and quads
/// ([`Paired`]) go as they were packed, their normals loaded once from their shared
/// rows instead of gathered per point; the other manifolds are taken together only
/// where that keeps the packed groups whole.
pub(super) fn update_gaps(st: &mut SoftState) {
    let mut gap = core::mem::take(&mut st.gap);
    let colouring = &st.colouring;
    let paired = &st.paired;
    let avx = paired.avx();
    // Every point is in one manifold and is written below: no clear (zeroing 8 B a
    // point per sub-step cost 0.7 % of the 210-box pyramid's step, callgrind).
    gap.resize(st.slots.len(), 0.0);
    {
        let (rows, vel, _, _) = split!(st);
        let (mp, pts) = (
            colouring.manifold_start.as_slice(),
            colouring.manifold_points.as_slice(),
        );
        let manifolds = mp.len().saturating_sub(1);
        let manifold = |j: usize| &pts[mp[j]..mp[j + 1]];
        let mut j = 0;
        while j < manifolds {
            let m0 = manifold(j);
            let Some(&first) = m0.first() else {
                j += 1;
                continue;
            };
            // The points of one manifold share their two bodies.
            let [a, b] = rows.slots[first];
            let len = m0.len();
            // A packed quad (its shared normals), or four other manifolds with as many
            // points none of which starts a packed pair, at a time in AVX lanes, where
            // the processor has AVX.
            let shared = paired.shared(j, len);
            let free = |k: usize| (1..k).all(|m| !paired.starts(j + m));
            let four = match shared {
                Some((_, quad)) => quad,
                None => j + 3 < manifolds && free(4),
            };
            if let (Some(avx), true) = (avx, four) {
                let ms = [m0, manifold(j + 1), manifold(j + 2), manifold(j + 3)];
                if ms.iter().all(|m| m.len() == len) {
                    let ab = [
                        [a, b],
                        rows.slots[ms[1][0]],
                        rows.slots[ms[2][0]],
                        rows.slots[ms[3][0]],
                    ];
                    let normals = shared.map(|((head, rows, _), _)| (head, rows, 0));
                    if gaps_quad(avx, &rows, ms, normals, ab, (vel.dp, vel.rot), &mut gap) {
                        j += 4;
                        continue;
                    }
                }
            }
            // A packed pair (its shared normals), or two other manifolds with as many
            // points, at a time in SIMD lanes.
            if j + 1 < manifolds && (shared.is_some() || free(2)) {
                let m1 = &pts[mp[j + 1]..mp[j + 2]];
                if let Some(&first1) = m1.first() {
                    let ab = [[a, b], rows.slots[first1]];
                    let normals = shared.map(|(normals, _)| normals);
                    let disp = (vel.dp, vel.rot);
                    if manifold_gaps(&rows, [m0, m1], normals, ab, disp, &mut gap) {
                        j += 2;
                        continue;
                    }
                }
            }
            let ((dpa, rota), (dpb, rotb)) = (vel.displacement(a), vel.displacement(b));
            for &p in m0 {
                let [ra, rb] = rows.anchor[p];
                let dd = (dpb + rotb * rb) - (dpa + rota * ra);
                gap[p] = rows.base_gap[p] + rows.dir[p][0].dot(dd);
            }
            j += 1;
        }
    }
    st.gap = gap;
}

/// Rate `J v` of row `r` of point `p`.
#[inline]
pub(super) fn rate(st: &SoftState, p: usize, r: usize) -> f64 {
    let [a, b] = st.slots[p];
    let d = st.dir[p][r];
    let g = &st.ang[p][r];
    d.dot(st.v[b] - st.v[a]) + g[1].dot(st.w[b]) - g[0].dot(st.w[a])
}

/// One Gauss–Seidel pass over the points ([`solve_point`] on each, in solve order),
/// or, for the biased pass with block normal solves, over the manifolds in colour
/// order ([`solve_manifold`] on each: within a colour the manifolds touch disjoint
/// moving bodies, so this is the same work as the point order).
pub(super) fn solve(st: &mut SoftState, hs: f64, use_bias: bool, max_push: f64, anchors: bool) {
    let pass = Pass {
        inv_h: 1.0 / hs,
        use_bias,
        max_push,
        anchors,
    };
    let gap = core::mem::take(&mut st.gap);
    // The largest normal impulses only where restitution reads them.
    let track = st.bouncy;
    // Points solved one at a time (see `SoftState::ang_kept`).
    let mut one_point = 0;
    if use_bias && !st.blocks.is_empty() {
        // Borrowed (see `warm_start`); the blocks and the scratch terms taken.
        let paired = &st.paired;
        let blocks = core::mem::take(&mut st.blocks);
        let mut scratch = core::mem::take(&mut st.ang_scratch);
        let colouring = &st.colouring;
        let kept = &st.ang_kept;
        {
            let (rows, mut vel, impulse, max_normal) = split!(st);
            let (mp, pts) = (
                colouring.manifold_start.as_slice(),
                colouring.manifold_points.as_slice(),
            );
            let mut io = PointSlices {
                impulse: &mut *impulse,
                max_normal: &mut *max_normal,
                gap: &gap,
                track,
            };
            let mut one = |j: usize, io: &mut PointSlices, vel: &mut Slices| {
                let pts = &pts[mp[j]..mp[j + 1]];
                one_point += pts.len();
                if kept.get(j).copied().unwrap_or(true) {
                    solve_manifold(&rows, &blocks[j], pts, io, vel, pass);
                    return;
                }
                // A packed manifold whose `ang` is not kept: its terms rebuilt from
                // its packed rows (the same bits), read by position as from `ang`.
                for &p in pts {
                    if let (Some(g), Some(s)) = (
                        rebuild_ang(paired, rows.anchor, rows.dir, p),
                        scratch.get_mut(p),
                    ) {
                        *s = g;
                    }
                }
                let rows = Rows {
                    ang: &scratch,
                    ..rows
                };
                solve_manifold(&rows, &blocks[j], pts, io, vel, pass);
            };
            // Colour by colour, two manifolds at a time in SIMD lanes
            // ([`block_pair`]: the same bits as one at a time), except in the
            // overflow colour (the last, if in use), whose manifolds may share bodies.
            // A manifold the lanes leave (bit `l` of `left`) is solved alone after
            // them (independent of them: the same bits).
            let starts = colouring.colour_start.as_slice();
            let colours = starts.len().saturating_sub(1);
            let serial = colouring.serial_from + 1 < colouring.ranges.len();
            for c in 0..colours {
                let (mut j, hi) = (starts[c], starts[c + 1]);
                if !(serial && c + 1 == colours) {
                    while j + 1 < hi {
                        if paired.four() && j + 3 < hi {
                            let quad = [&blocks[j], &blocks[j + 1], &blocks[j + 2], &blocks[j + 3]];
                            let pr = paired.quad(j, blocks[j].len);
                            let io4 = &mut lanes(&mut io, &mut vel);
                            if let Some(left) = block_quad(&rows, pr, quad, io4, pass) {
                                if left != 0 {
                                    for l in (0..4).filter(|l| left & (1 << l) != 0) {
                                        one(j + l, &mut io, &mut vel);
                                    }
                                }
                                j += 4;
                                continue;
                            }
                        }
                        let pair = [&blocks[j], &blocks[j + 1]];
                        let pr = paired.of(j, blocks[j].len);
                        let left = block_pair(&rows, pr, pair, &mut lanes(&mut io, &mut vel), pass);
                        if left != 0 {
                            for l in (0..2).filter(|l| left & (1 << l) != 0) {
                                one(j + l, &mut io, &mut vel);
                            }
                        }
                        j += 2;
                    }
                }
                for j in j..hi {
                    one(j, &mut io, &mut vel);
                }
            }
        }
        st.blocks = blocks;
        st.ang_scratch = scratch;
    } else {
        // The relax pass, or the biased pass without blocks (block normal solve off),
        // point by point in lanes.
        one_point = if use_bias {
            relax_in_lanes::<true>(st, &gap, pass)
        } else {
            relax_in_lanes::<false>(st, &gap, pass)
        };
    }
    st.one_point += one_point;
    st.gap = gap;
}

/// The relax pass ([`solve_point`] without bias on every point, in solve order), or
/// with `BIASED` (and `pass.use_bias`) the biased pass point by point (the block
/// normal solve off), with the manifolds of each colour taken two at a time in SIMD
/// lanes ([`relax_manifolds`], [`biased_manifolds`]: the same bits as one point at a
/// time; see [`for_manifold_pairs`]). Returns how many points it solved one at a
/// time. The pass chosen at compile time: with a run-time choice per pair of
/// manifolds the default step took +363 instructions (0.27 %) on `soft_points
/// stack10`, callgrind; chosen so, +39.
pub(super) fn relax_in_lanes<const BIASED: bool>(
    st: &mut SoftState,
    gap: &[f64],
    pass: Pass,
) -> usize {
    // The largest normal impulses only where restitution reads them.
    let track = st.bouncy;
    let mut one_point = 0;
    // Borrowed (see `warm_start`).
    let paired = &st.paired;
    let colouring = &st.colouring;
    {
        let (rows, vel, impulse, max_normal) = split!(st);
        let (dp, rot) = (vel.dp, vel.rot);
        let mut io = RelaxIo {
            v: &mut *vel.v,
            w: &mut *vel.w,
            impulse: &mut *impulse,
            max_normal: &mut *max_normal,
            gap,
            track,
        };
        let mut one = |p: usize, io: &mut RelaxIo| {
            one_point += 1;
            let mut vel = Slices {
                v: &mut *io.v,
                w: &mut *io.w,
                dp,
                rot,
            };
            solve_point(
                &rows,
                p,
                gap[p],
                &mut io.impulse[p],
                &mut io.max_normal[p],
                &mut vel,
                pass,
            );
        };
        // Running this loop inside a `#[target_feature(enable = "avx")]` function
        // did not inline `relax_avx` into it (still one call a quad): the 210-box
        // pyramid's step 5.366M → 5.367M instructions, stack10's 157.4k → 159.9k
        // (callgrind per step).
        for_manifold_pairs(
            colouring,
            rows.slots.len(),
            paired.four(),
            |j, pts, io: &mut RelaxIo| {
                let pr = paired.quad(j, pts[0].len());
                if BIASED {
                    biased_quad(&rows, pr, pts, io, pass)
                } else {
                    relax_quad(&rows, pr, pts, io, pass.inv_h)
                }
            },
            |j, pts, io: &mut RelaxIo| {
                let pr = paired.of(j, pts[0].len());
                if BIASED {
                    biased_manifolds(&rows, pr, pts, io, pass)
                } else {
                    relax_manifolds(&rows, pr, pts, io, pass.inv_h)
                }
            },
            &mut one,
            &mut io,
        );
    }
    one_point
}

/// The same slices as the lane passes take them.
#[inline(always)]
fn lanes<'a>(io: &'a mut PointSlices<'_>, vel: &'a mut Slices<'_>) -> RelaxIo<'a> {
    RelaxIo {
        v: &mut *vel.v,
        w: &mut *vel.w,
        impulse: &mut *io.impulse,
        max_normal: &mut *io.max_normal,
        gap: io.gap,
        track: io.track,
    }
}

/// The points' impulses as the manifold passes see them: plain slices on one
/// thread, atomics under the `parallel` feature.
pub(in crate::rigid) trait PointImpulses {
    /// Impulses `[λ_n, λ_t1, λ_t2]` and the largest normal impulse of point `p`.
    fn get(&self, p: usize) -> ([f64; 3], f64);
    /// Stores them.
    fn set(&mut self, p: usize, z: [f64; 3], max_normal: f64);
    /// Gap of point `p` at the current displacements ([`SoftState::gap`]).
    fn gap(&self, p: usize) -> f64;
}

/// [`PointImpulses`] over the state's own slices.
pub(super) struct PointSlices<'a> {
    impulse: &'a mut [[f64; 3]],
    max_normal: &'a mut [f64],
    gap: &'a [f64],
    /// Whether the lane passes keep `max_normal` ([`RelaxIo::track`]).
    track: bool,
}

impl PointImpulses for PointSlices<'_> {
    #[inline(always)]
    fn get(&self, p: usize) -> ([f64; 3], f64) {
        (self.impulse[p], self.max_normal[p])
    }
    #[inline(always)]
    fn set(&mut self, p: usize, z: [f64; 3], max_normal: f64) {
        self.impulse[p] = z;
        self.max_normal[p] = max_normal;
    }
    #[inline(always)]
    fn gap(&self, p: usize) -> f64 {
        self.gap[p]
    }
}

/// One manifold in the biased pass (points `pts`, bottom-up): [`solve_block`] or,
/// where that declines or the manifold has no block, point by point
/// ([`solve_point`]).
#[inline(always)]
pub(in crate::rigid) fn solve_manifold<B: Bodies, I: PointImpulses>(
    rows: &Rows,
    blk: &Block,
    pts: &[usize],
    io: &mut I,
    vel: &mut B,
    pass: Pass,
) {
    if blk.len > 0 {
        let mut z = [[0.0; 3]; BLOCK_POINTS];
        let mut m = [0.0; BLOCK_POINTS];
        for i in 0..blk.len {
            (z[i], m[i]) = io.get(blk.pts[i]);
        }
        let mut gap = [0.0; BLOCK_POINTS];
        for i in 0..blk.len {
            gap[i] = io.gap(blk.pts[i]);
        }
        if solve_block(rows, blk, &gap, &mut z, &mut m, vel, pass) {
            for i in 0..blk.len {
                io.set(blk.pts[i], z[i], m[i]);
            }
            return;
        }
    }
    for &p in pts {
        let (mut z, mut m) = io.get(p);
        solve_point(rows, p, io.gap(p), &mut z, &mut m, vel, pass);
        io.set(p, z, m);
    }
}

/// The biased pass over one manifold with its normal rows solved together. One soft
/// row's update `Δλ_i = −m_i·mass_scale·(J_i v + b_i) − impulse_scale·(λ_i − λ_pre,i)`
/// is the solution of `J_i v' + b_i + c_i (λ_i' − λ_pre,i) = 0` with `c_i =
/// impulse_scale / (mass_scale·m_i)` (`mass_scale + impulse_scale = 1`; Catto,
/// Solver2D 2024, soft step); the manifold's rows together give
///
/// ```text
/// (A + diag c) Δλ = −(J v + b + c∘(λ − λ_pre)),   A = J M⁻¹ Jᵀ
/// ```
///
/// (Box2D v2.4's block solver, `b2ContactSolver::SolveVelocityConstraints`, for four
/// points; `K⁻¹` from [`build_blocks`]). If every `λ'` is non-negative it is taken;
/// where one would turn negative or a preload is on its cap the rows are solved
/// together as a small LCP ([`block_lcp()`]); then the friction rows point by point as
/// in [`solve_point`]. A point that has separated (`C > 0`) but still carries an
/// impulse keeps its soft row and preload law (continued across `C = 0`, where a
/// rocking face's corner lifts by microns) instead of the speculative row; a
/// separated point without impulse (an approach) makes it return false, having
/// changed nothing, as does an LCP without solution: the points are then solved one
/// by one. `z`, `max_normal`: the points' impulses, in `blk.pts` order.
#[inline(always)]
pub(super) fn solve_block<B: Bodies>(
    rows: &Rows,
    blk: &Block,
    gaps: &[f64; BLOCK_POINTS],
    z: &mut [[f64; 3]; BLOCK_POINTS],
    max_normal: &mut [f64; BLOCK_POINTS],
    vel: &mut B,
    pass: Pass,
) -> bool {
    const N: usize = BLOCK_POINTS;
    let len = blk.len;
    let p0 = blk.pts[0];
    let [a, b] = rows.slots[p0];
    let ((mut va, mut wa), (mut vb, mut wb)) = (vel.velocity(a), vel.velocity(b));
    let s = rows.soft[p0];
    // r = J v + b + c∘(λ − λ_pre), with the gap of each point as in `solve_point`, but
    // a separated point (`C > 0`) that carries an impulse keeps this row (see above);
    // `plain`: no preload on its cap (the block's `K⁻¹` holds).
    let mut r = [0.0; N];
    let mut dd = [DVec3::ZERO; N];
    let mut plain = true;
    for i in 0..len {
        let p = blk.pts[i];
        let d = &rows.dir[p];
        let g = &rows.ang[p];
        let gap = gaps[i];
        if gap > 0.0 && !(z[i][0] > 0.0) {
            return false;
        }
        let vn = d[0].dot(vb - va) + g[0][1].dot(wb) - g[0][0].dot(wa);
        let bias = at_least(s.bias_rate * gap, -pass.max_push);
        let (cap, floor, preload) = (
            rows.preload_cap[p] * -gap,
            rows.preload_floor[p],
            rows.preload[p],
        );
        let pre = at_most(preload, at_least(cap, floor));
        plain &= !on_cap(cap, floor, preload);
        r[i] = vn + bias + blk.c[i] * (z[i][0] - pre);
    }
    // Δλ = −K⁻¹ r (the padding of K⁻¹ is the identity, and r is zero there).
    let mut dz = [0.0; N];
    let mut all_active = plain;
    if plain {
        for i in 0..N {
            let k = &blk.kinv[i * N..i * N + N];
            dz[i] = -(k[0] * r[0] + k[1] * r[1] + k[2] * r[2] + k[3] * r[3]);
            all_active &= z[i][0] + dz[i] >= 0.0;
        }
    }
    if !all_active {
        let v = (&mut va, &mut wa, &mut vb, &mut wb);
        if !block_lcp(rows, blk, gaps, z, max_normal, v, pass) {
            return false;
        }
    } else {
        for i in 0..len {
            let p = blk.pts[i];
            let d = &rows.dir[p];
            let g = &rows.ang[p];
            let [ma, mb] = rows.im[p];
            z[i][0] += dz[i];
            max_normal[i] = at_least(z[i][0], max_normal[i]);
            va -= d[0] * (ma * dz[i]);
            wa -= g[0][2] * dz[i];
            vb += d[0] * (mb * dz[i]);
            wb += g[0][3] * dz[i];
        }
    }
    // Anchored friction where anchors are on, on the points that penetrate (the slip
    // needs the anchors' separation).
    if pass.anchors {
        for i in 0..len {
            dd[i] = separation(rows, blk.pts[i], vel);
        }
    }
    for i in 0..len {
        friction_rows(
            rows,
            blk.pts[i],
            &mut z[i],
            dd[i],
            gaps[i] <= 0.0,
            (&mut va, &mut wa, &mut vb, &mut wb),
            pass,
        );
    }
    rows.store_pair(vel, [a, b], [(va, wa), (vb, wb)]);
    true
}

/// The two friction rows of point `p` after its normal row, on velocities held by the
/// caller: Coulomb's `|λ_t| ≤ μ λ_n` per tangent row (pyramid). With anchors, the
/// biased pass pulls a sticking pair (`touching`: gap ≤ 0) back along its slip `s_t
/// = s₀ + tᵀ Δd` (`dd` = Δd, the anchors' separation since the start of the step) as
/// a soft row: `Δλ_t = −m_t · mass_scale · (J_t v + bias_rate · s_t) − impulse_scale ·
/// λ_t`.
#[inline(always)]
pub(super) fn friction_rows(
    rows: &Rows,
    p: usize,
    z: &mut [f64; 3],
    dd: DVec3,
    touching: bool,
    (va, wa, vb, wb): (&mut DVec3, &mut DVec3, &mut DVec3, &mut DVec3),
    pass: Pass,
) {
    let d = &rows.dir[p];
    let g = &rows.ang[p];
    let m = rows.mass[p];
    let [ma, mb] = rows.im[p];
    let bound = rows.friction[p] * z[0];
    let anchored = pass.use_bias && pass.anchors && touching;
    let s = rows.soft[p];
    for r in 1..3 {
        let vt = d[r].dot(*vb - *va) + g[r][1].dot(*wb) - g[r][0].dot(*wa);
        let unbounded = if anchored {
            let slip = rows.slip[p][r - 1] + d[r].dot(dd);
            let bias = at_least(at_most(s.bias_rate * slip, pass.max_push), -pass.max_push);
            z[r] - m[r] * s.mass_scale * (vt + bias) - s.impulse_scale * z[r]
        } else {
            z[r] - m[r] * vt
        };
        let new = at_least(at_most(unbounded, bound), -bound);
        let dz = new - z[r];
        z[r] = new;
        *va -= d[r] * (ma * dz);
        *wa -= g[r][2] * dz;
        *vb += d[r] * (mb * dz);
        *wb += g[r][3] * dz;
    }
}

/// Point `p`'s rows in one Gauss–Seidel pass: the normal row (soft with bias when
/// `use_bias`, rigid without), then the two friction rows bounded by `μ λ_n`. The point
/// loads its two bodies' velocities once, updates them row by row, and stores them
/// back (Box2D v3's `b2SolveContact`); `z` are its impulses, `max_normal` the largest
/// normal impulse it has had this step (restitution).
#[inline(always)]
pub(in crate::rigid) fn solve_point<B: Bodies>(
    rows: &Rows,
    p: usize,
    gap: f64,
    z: &mut [f64; 3],
    max_normal: &mut f64,
    vel: &mut B,
    pass: Pass,
) {
    let Pass {
        inv_h,
        use_bias,
        max_push,
        ..
    } = pass;
    let [a, b] = rows.slots[p];
    // Borrowed, not copied: the twelve angular vectors stay in the point's row.
    let d = &rows.dir[p];
    let g = &rows.ang[p];
    let m = rows.mass[p];
    let [ma, mb] = rows.im[p];
    let ((mut va, mut wa), (mut vb, mut wb)) = (vel.velocity(a), vel.velocity(b));
    // `gap`: the current gap C = C₀ + nᵀ Δd ([`gap_of`]); the anchors' separation Δd
    // itself only where anchored friction reads the slip.
    let dd = if use_bias && pass.anchors {
        separation(rows, p, vel)
    } else {
        DVec3::ZERO
    };
    // Δλ = −m · mass_scale · (J v + bias) − impulse_scale · (λ − λ_pre), then λ ≥ 0,
    // with the preload capped at `γ/(1 − γ) · m h ω²` times the penetration (only a
    // penetrating point is preloaded, and no more than the spring at rest would be:
    // an impact's impulse does not become a push the next step).
    let (bias, mass_scale, impulse_scale, pre) = if gap > 0.0 {
        // Speculative: approach at most to the surface within the sub-step.
        (gap * inv_h, 1.0, 0.0, 0.0)
    } else if use_bias {
        let s = rows.soft[p];
        (
            at_least(s.bias_rate * gap, -max_push),
            s.mass_scale,
            s.impulse_scale,
            at_most(
                rows.preload[p],
                at_least(rows.preload_cap[p] * -gap, rows.preload_floor[p]),
            ),
        )
    } else {
        (0.0, 1.0, 0.0, 0.0)
    };
    let vn = d[0].dot(vb - va) + g[0][1].dot(wb) - g[0][0].dot(wa);
    let new = at_least(
        z[0] - m[0] * mass_scale * (vn + bias) - impulse_scale * (z[0] - pre),
        0.0,
    );
    let dz = new - z[0];
    z[0] = new;
    *max_normal = at_least(new, *max_normal);
    va -= d[0] * (ma * dz);
    wa -= g[0][2] * dz;
    vb += d[0] * (mb * dz);
    wb += g[0][3] * dz;
    friction_rows(
        rows,
        p,
        z,
        dd,
        gap <= 0.0,
        (&mut va, &mut wa, &mut vb, &mut wb),
        pass,
    );
    rows.store_pair(vel, [a, b], [(va, wa), (vb, wb)]);
}

/// `max(x, lo)` as one compare-and-select (x86 `maxsd`): `x` if `x > lo`, else `lo`.
/// Unlike [`f64::max`] it does not skip a NaN bound: a NaN `lo` gives NaN, which the
/// step's divergence check rejects (a NaN `x` gives `lo`, as `f64::max` does). Never
/// panics (no `clamp`).
#[inline(always)]
pub(super) fn at_least(x: f64, lo: f64) -> f64 {
    if x > lo {
        x
    } else {
        lo
    }
}

/// `min(x, hi)` as one compare-and-select (x86 `minsd`); NaN as in [`at_least`].
#[inline(always)]
pub(super) fn at_most(x: f64, hi: f64) -> f64 {
    if x < hi {
        x
    } else {
        hi
    }
}

/// Restitution (after the sub-steps, Box2D's `b2ApplyRestitution`): a point that
/// approached faster than `threshold` and carried load gets `J v ≥ −e v_approach`.
pub(super) fn restitution(st: &mut SoftState, threshold: f64) {
    if !st.bouncy {
        return; // every `e` is zero: every point is skipped below
    }
    for p in 0..st.slots.len() {
        let e = st.restitution[p];
        if e == 0.0 || st.approach[p] > -threshold || st.max_normal[p] == 0.0 {
            continue;
        }
        let vn = rate(st, p, 0);
        let z = st.impulse[p][0];
        let new = (z - st.mass[p][0] * (vn + e * st.approach[p])).max(0.0);
        st.impulse[p][0] = new;
        st.total[p][0] += new - z;
        apply(st, p, [new - z, 0.0, 0.0]);
    }
}

/// Natural-map residual of the last sub-step's unbiased problem (the relax pass) at
/// the final velocities and impulses: normal `w = J v + max(C/h, 0)` with `λ ≥ 0`,
/// tangents `w = J v` with `|λ_t| ≤ μ λ_n`, scaled by `max(1, |w|∞)`.
pub(super) fn residual(st: &SoftState, hs: f64) -> f64 {
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 1.0;
    for p in 0..st.slots.len() {
        let [a, b] = st.slots[p];
        let [ra, rb] = st.anchor[p];
        let n = st.dir[p][0];
        let gap = st.base_gap[p] + n.dot((st.dp[b] + st.rot[b] * rb) - (st.dp[a] + st.rot[a] * ra));
        let z = st.impulse[p];
        let bound = st.friction[p] * z[0];
        for r in 0..3 {
            if !(st.mass[p][r] > 0.0) {
                continue;
            }
            let w = rate(st, p, r) + if r == 0 { (gap / hs).max(0.0) } else { 0.0 };
            let (lo, hi) = if r == 0 {
                (0.0, f64::INFINITY)
            } else {
                (-bound, bound)
            };
            scale = scale.max(w.abs());
            worst = worst.max((z[r] - (z[r] - w).min(hi).max(lo)).abs());
        }
    }
    worst / scale
}
