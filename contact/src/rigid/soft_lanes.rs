//! The soft step's passes two points at a time, one per SIMD lane (`wide::f64x2`;
//! Box2D v3 solves its contact constraints in SIMD lanes the same way,
//! `contact_solver.c`, `b2SolveContactTwoPointsTask`).
//!
//! The colouring's groups (one place of one colour: see the `colouring` module) hold
//! points whose manifolds share no moving body, so within a group the Gauss–Seidel
//! updates of two points commute: solving them side by side in two lanes is the same
//! work as solving them one after the other. Each lane does exactly the arithmetic of
//! [`solve_point`](super::soft_step::solve_point) in the relax pass (`use_bias`
//! false), operation for operation and in the same order (IEEE-754 lanes round as the
//! scalar operations do; `at_least`/`at_most` keep the scalar compare-and-select),
//! so the result is the same, bit for bit, as the one-point pass (and as the threaded
//! passes, which stay one point at a time: `verify/tests/determinism.rs`).
//!
//! The passes take two manifolds of a colour at a time, one per lane, with their
//! points in order: the two bodies' velocities of each manifold (every point of a
//! manifold has the same two) are gathered once, updated point by point and
//! scattered back once per manifold (loading and storing them per point was a
//! quarter of the warm start; the 210-box pyramid's step −2.0 %, callgrind). The
//! rows come packed per pair of manifolds ([`Paired`]), written once per step by
//! `prepare` as it computes each point, in the order the passes read them (looking
//! each pair of points up by solve position instead cost 4.6 % of the pyramid's
//! step).

use alloc::vec::Vec;

use constraint_core::DVec3;
use wide::f64x2;

use super::colouring::Colouring;
use super::soft_step::{Block, Bodies, Pass, PointImpulses, Rows, BLOCK_POINTS};

/// Two 3-vectors, one per lane.
#[derive(Clone, Copy, Debug)]
struct Lanes3 {
    x: f64x2,
    y: f64x2,
    z: f64x2,
}

impl Lanes3 {
    const ZERO: Self = Self {
        x: f64x2::ZERO,
        y: f64x2::ZERO,
        z: f64x2::ZERO,
    };

    /// Sets lane `i` to `v`.
    #[inline(always)]
    fn set(&mut self, i: usize, v: DVec3) {
        self.x.as_mut_array()[i] = v.x;
        self.y.as_mut_array()[i] = v.y;
        self.z.as_mut_array()[i] = v.z;
    }

    #[inline(always)]
    fn of(p: DVec3, q: DVec3) -> Self {
        Self {
            x: f64x2::new([p.x, q.x]),
            y: f64x2::new([p.y, q.y]),
            z: f64x2::new([p.z, q.z]),
        }
    }

    #[inline(always)]
    fn lane(self, i: usize) -> DVec3 {
        DVec3::new(
            self.x.as_array()[i],
            self.y.as_array()[i],
            self.z.as_array()[i],
        )
    }

    /// `xx' + yy' + zz'`, summed left to right as `DVec3::dot` does.
    #[inline(always)]
    fn dot(self, o: Self) -> f64x2 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }

    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }

    #[inline(always)]
    fn scale(self, s: f64x2) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

#[inline(always)]
fn pair(p: f64, q: f64) -> f64x2 {
    f64x2::new([p, q])
}

/// `max(x, lo)` per lane as the scalar `at_least`: `x` if `x > lo`, else `lo` (x86
/// `MAXPD` is exactly that, NaN and signed zeros included).
#[inline(always)]
fn at_least(x: f64x2, lo: f64x2) -> f64x2 {
    #[cfg(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse2"
    ))]
    {
        x.fast_max(lo)
    }
    #[cfg(not(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse2"
    )))]
    {
        let (x, lo) = (x.to_array(), lo.to_array());
        let pick = |i: usize| if x[i] > lo[i] { x[i] } else { lo[i] };
        pair(pick(0), pick(1))
    }
}

/// `min(x, hi)` per lane as the scalar `at_most`: `x` if `x < hi`, else `hi` (x86
/// `MINPD`).
#[inline(always)]
fn at_most(x: f64x2, hi: f64x2) -> f64x2 {
    #[cfg(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse2"
    ))]
    {
        x.fast_min(hi)
    }
    #[cfg(not(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse2"
    )))]
    {
        let (x, hi) = (x.to_array(), hi.to_array());
        let pick = |i: usize| if x[i] < hi[i] { x[i] } else { hi[i] };
        pair(pick(0), pick(1))
    }
}

/// The rows of two points side by side, one per lane (copied from the state's
/// arrays once per step, so that the passes load each pair of values at once
/// instead of gathering it from two places).
#[derive(Clone, Copy, Debug)]
pub(super) struct PairRows {
    /// Normal and tangents.
    dir: [Lanes3; 3],
    /// Per direction `r_a × d`, `r_b × d`, `I_a⁻¹(r_a × d)`, `I_b⁻¹(r_b × d)`.
    ang: [[Lanes3; 4]; 3],
    /// Effective masses of the three rows.
    mass: [f64x2; 3],
    /// Inverse masses of the two bodies as the rows see them.
    im: [f64x2; 2],
    friction: f64x2,
}

/// The rows packed two points at a time, per pair of manifolds: the manifolds of each
/// colour before the overflow colour (no shared moving body) taken two at a time,
/// `(j, j + 1)` from the colour's first, as the passes take them; where the two have
/// the same point count (at most [`BLOCK_POINTS`]) their points' rows side by side,
/// place by place (the passes read them in order: no lookup per point). Kept
/// buffers: no allocation once grown.
#[derive(Clone, Debug, Default)]
pub(super) struct Paired {
    rows: Vec<PairRows>,
    /// Where the rows of manifold pair `(j, j + 1)` start in `rows`, by `j` (colour
    /// order; `u32::MAX` where `j` starts no packed pair).
    first: Vec<u32>,
    /// Of each point (solve position): `2 ×` its entry in `rows` `+` its lane
    /// (`u32::MAX` where it is not packed).
    lane_of: Vec<u32>,
}

/// One point's rows as `prepare` computes them (what [`Paired::put`] writes).
pub(super) struct PointRows<'a> {
    /// Normal and tangents.
    pub(super) dir: &'a [DVec3; 3],
    /// Per direction `r_a × d`, `r_b × d`, `I_a⁻¹(r_a × d)`, `I_b⁻¹(r_b × d)`.
    pub(super) ang: &'a [[DVec3; 4]; 3],
    /// Effective masses.
    pub(super) mass: [f64; 3],
    /// Inverse masses as the rows see them.
    pub(super) im: [f64; 2],
    /// Friction coefficient.
    pub(super) friction: f64,
}

/// Rows of zeros (the entries `Paired::plan` sizes before `prepare` writes them).
const ZERO_ROWS: PairRows = PairRows {
    dir: [Lanes3::ZERO; 3],
    ang: [[Lanes3::ZERO; 4]; 3],
    mass: [f64x2::ZERO; 3],
    im: [f64x2::ZERO; 2],
    friction: f64x2::ZERO,
};

impl Paired {
    /// Pairs up the manifolds of `colouring` and sizes the packed rows; `prepare`
    /// then writes each point's rows into its lane ([`Paired::put`]) as it computes
    /// them (packing them afterwards from the state's arrays read them back, 3 % of
    /// the 210-box pyramid's step).
    pub(super) fn plan(&mut self, colouring: &Colouring) {
        let (mp, pts) = (&colouring.manifold_start, &colouring.manifold_points);
        let manifolds = mp.len().saturating_sub(1);
        self.first.clear();
        self.first.resize(manifolds, u32::MAX);
        self.lane_of.clear();
        self.lane_of.resize(pts.len(), u32::MAX);
        let starts = &colouring.colour_start;
        let colours = starts.len().saturating_sub(1);
        let serial = colouring.serial_from + 1 < colouring.ranges.len();
        let laned = if serial { colours - 1 } else { colours };
        let mut count = 0;
        for c in 0..laned {
            let (mut j, hi) = (starts[c], starts[c + 1]);
            while j + 1 < hi {
                let (m0, m1) = (&pts[mp[j]..mp[j + 1]], &pts[mp[j + 1]..mp[j + 2]]);
                if m0.len() == m1.len() && m0.len() <= BLOCK_POINTS {
                    self.first[j] = count as u32;
                    for (&p, &q) in m0.iter().zip(m1) {
                        if let Some(l) = self.lane_of.get_mut(p) {
                            *l = 2 * count as u32;
                        }
                        if let Some(l) = self.lane_of.get_mut(q) {
                            *l = 2 * count as u32 + 1;
                        }
                        count += 1;
                    }
                }
                j += 2;
            }
        }
        // Kept at least at its bound (a packed entry is two points; grown as `Vec`
        // grows, doubling), so that a step that packs more pairs than any before
        // does not allocate: the 6-level pyramid's colouring packed one more pair at
        // step 70 with `preload_cap_margin` 4, and `soft_step_allocations` saw it.
        let bound = pts.len() / 2;
        if self.rows.capacity() < bound {
            self.rows.reserve(bound - self.rows.len());
        }
        // Every entry is written by `put` before the passes read it.
        self.rows.resize(count, ZERO_ROWS);
    }

    /// Writes point `p`'s rows into its lane, if it is in a packed pair.
    #[inline(always)]
    pub(super) fn put(&mut self, p: usize, point: PointRows) {
        let Some(&at) = self.lane_of.get(p) else {
            return;
        };
        let Some(pr) = self.rows.get_mut((at / 2) as usize) else {
            return;
        };
        let lane = (at % 2) as usize;
        for r in 0..3 {
            pr.dir[r].set(lane, point.dir[r]);
            for k in 0..4 {
                pr.ang[r][k].set(lane, point.ang[r][k]);
            }
            pr.mass[r].as_mut_array()[lane] = point.mass[r];
        }
        pr.im[0].as_mut_array()[lane] = point.im[0];
        pr.im[1].as_mut_array()[lane] = point.im[1];
        pr.friction.as_mut_array()[lane] = point.friction;
    }

    /// The packed rows of manifold pair `(j, j + 1)` (`len` points each), if packed.
    #[inline(always)]
    pub(super) fn of(&self, j: usize, len: usize) -> Option<&[PairRows]> {
        let k = *self.first.get(j)? as usize;
        self.rows.get(k..k + len)
    }
}

/// The velocities and impulses the relax pass writes (the single-thread state's own
/// slices).
pub(super) struct RelaxIo<'a> {
    pub(super) v: &'a mut [DVec3],
    pub(super) w: &'a mut [DVec3],
    pub(super) impulse: &'a mut [[f64; 3]],
    pub(super) max_normal: &'a mut [f64],
    /// Gaps at the current displacements.
    pub(super) gap: &'a [f64],
}

/// The packed rows of two manifolds and their bodies' slots, where the two were packed
/// side by side ([`Paired::of`]) with the same number of points; `None` otherwise (the
/// caller then solves them one point at a time).
#[inline(always)]
fn packed<'a>(
    rows: &Rows,
    pr: Option<&'a [PairRows]>,
    pts: [&[usize]; 2],
) -> Option<(&'a [PairRows], [[usize; 2]; 2])> {
    let pr = pr?;
    let len = pts[0].len();
    if len == 0 || pts[1].len() != len || pr.len() != len {
        return None;
    }
    Some((pr, [rows.slots[pts[0][0]], rows.slots[pts[1][0]]]))
}

/// The two bodies' velocities of two manifolds, one per lane: `(v_a, ω_a, v_b, ω_b)`
/// (every point of a manifold has the same two bodies).
#[inline(always)]
fn load(v: &[DVec3], w: &[DVec3], ab: [[usize; 2]; 2]) -> [Lanes3; 4] {
    let ([a0, b0], [a1, b1]) = (ab[0], ab[1]);
    [
        Lanes3::of(v[a0], v[a1]),
        Lanes3::of(w[a0], w[a1]),
        Lanes3::of(v[b0], v[b1]),
        Lanes3::of(w[b0], w[b1]),
    ]
}

/// Stores what [`load`] loaded, lane by lane; never the static slot (its inverse mass
/// and inertia are zero: it stays at rest).
#[inline(always)]
fn store(
    v: &mut [DVec3],
    w: &mut [DVec3],
    ab: [[usize; 2]; 2],
    [va, wa, vb, wb]: [Lanes3; 4],
    fixed: usize,
) {
    for (lane, [a, b]) in ab.into_iter().enumerate() {
        if a != fixed {
            v[a] = va.lane(lane);
            w[a] = wa.lane(lane);
        }
        if b != fixed {
            v[b] = vb.lane(lane);
            w[b] = wb.lane(lane);
        }
    }
}

/// The relax pass over two manifolds of one colour (no shared moving body), one per
/// lane, their points in order: per point the rigid normal row (the speculative
/// target `C/h` where separated, else no bias: `Δλ = −m (J v + b)`, `λ ≥ 0`), then
/// the two friction rows bounded by `μ λ_n` (`|λ_t| ≤ μ λ_n`), as `solve_point` with
/// `use_bias` false on each point, the bodies' velocities loaded once and stored once
/// per manifold (Box2D v3 loads them per point). `pr`: their packed rows
/// ([`Paired::of`]). Returns false, having changed nothing, where they were not
/// packed (point counts that differ or exceed [`BLOCK_POINTS`]): the caller then
/// solves them one point at a time (the same bits, the two being independent).
#[inline(always)]
pub(super) fn relax_manifolds(
    rows: &Rows,
    pr: Option<&[PairRows]>,
    pts: [&[usize]; 2],
    io: &mut RelaxIo,
    inv_h: f64,
) -> bool {
    let Some((pr, ab)) = packed(rows, pr, pts) else {
        return false;
    };
    let len = pr.len();
    let [mut va, mut wa, mut vb, mut wb] = load(io.v, io.w, ab);
    for i in 0..len {
        let vel = (&mut va, &mut wa, &mut vb, &mut wb);
        relax_rows(&pr[i], pts[0][i], pts[1][i], io, vel, inv_h);
    }
    store(io.v, io.w, ab, [va, wa, vb, wb], rows.fixed);
    true
}

/// Points `p` and `q` of [`relax_manifolds`], one per lane, on velocities held by the
/// caller (`[v_a, ω_a, v_b, ω_b]`).
#[inline(always)]
fn relax_rows(
    pr: &PairRows,
    p: usize,
    q: usize,
    io: &mut RelaxIo,
    (va, wa, vb, wb): (&mut Lanes3, &mut Lanes3, &mut Lanes3, &mut Lanes3),
    inv_h: f64,
) {
    let g = &pr.ang;
    let [ma, mb] = pr.im;
    let (zp, zq) = (io.impulse[p], io.impulse[q]);
    // Speculative where separated: approach at most to the surface within the
    // sub-step; rigid (mass_scale 1, impulse_scale 0, no preload) either way.
    let spec = |gap: f64| if gap > 0.0 { gap * inv_h } else { 0.0 };
    let bias = pair(spec(io.gap[p]), spec(io.gap[q]));
    let (one, zero) = (f64x2::splat(1.0), f64x2::splat(0.0));
    let z0 = pair(zp[0], zq[0]);
    let d0 = pr.dir[0];
    let vn = d0.dot(vb.sub(*va)) + g[0][1].dot(*wb) - g[0][0].dot(*wa);
    let new = at_least(
        z0 - pr.mass[0] * one * (vn + bias) - zero * (z0 - zero),
        zero,
    );
    let dz = new - z0;
    let max_normal = at_least(new, pair(io.max_normal[p], io.max_normal[q]));
    *va = va.sub(d0.scale(ma * dz));
    *wa = wa.sub(g[0][2].scale(dz));
    *vb = vb.add(d0.scale(mb * dz));
    *wb = wb.add(g[0][3].scale(dz));
    let bound = pr.friction * new;
    let mut z = [new, zero, zero];
    for r in 1..3 {
        let d = pr.dir[r];
        let zr = pair(zp[r], zq[r]);
        let vt = d.dot(vb.sub(*va)) + g[r][1].dot(*wb) - g[r][0].dot(*wa);
        let unbounded = zr - pr.mass[r] * vt;
        let new = at_least(at_most(unbounded, bound), -bound);
        let dz = new - zr;
        z[r] = new;
        *va = va.sub(d.scale(ma * dz));
        *wa = wa.sub(g[r][2].scale(dz));
        *vb = vb.add(d.scale(mb * dz));
        *wb = wb.add(g[r][3].scale(dz));
    }
    for (lane, point) in [p, q].into_iter().enumerate() {
        io.impulse[point] = [
            z[0].as_array()[lane],
            z[1].as_array()[lane],
            z[2].as_array()[lane],
        ];
        io.max_normal[point] = max_normal.as_array()[lane];
    }
}

/// The biased pass over manifolds `b0` and `b1` (of one colour: no shared moving
/// body) with their normal rows solved as blocks, one manifold per lane: exactly
/// `solve_block` on each (`(A + diag c) Δλ = −(J v + b + c∘(λ − λ_pre))`, then the
/// friction rows point by point), for two blocks of the same point count without
/// friction anchors; `pr`: their packed rows ([`Paired::of`]). Returns false, having changed nothing, where the lanes do not
/// apply or where `solve_block` would decline for either manifold (a separated
/// point, an impulse turning negative): the caller then solves both one at a time
/// (the same bits either way, the two manifolds being independent).
#[inline(always)]
pub(super) fn block_pair<B: Bodies, I: PointImpulses>(
    rows: &Rows,
    pr: Option<&[PairRows]>,
    blk: [&Block; 2],
    io: &mut I,
    vel: &mut B,
    pass: Pass,
) -> bool {
    const N: usize = BLOCK_POINTS;
    let len = blk[0].len;
    let Some(pr) = pr else {
        return false;
    };
    if len == 0 || blk[1].len != len || pr.len() != len || pass.anchors {
        return false;
    }
    let mut gap = [f64x2::splat(0.0); N];
    for (i, g) in gap.iter_mut().enumerate().take(len) {
        let (g0, g1) = (io.gap(blk[0].pts[i]), io.gap(blk[1].pts[i]));
        if g0 > 0.0 || g1 > 0.0 {
            return false;
        }
        *g = pair(g0, g1);
    }
    let p0 = [blk[0].pts[0], blk[1].pts[0]];
    let ([a0, b0], [a1, b1]) = (rows.slots[p0[0]], rows.slots[p0[1]]);
    let ((va0, wa0), (vb0, wb0)) = (vel.velocity(a0), vel.velocity(b0));
    let ((va1, wa1), (vb1, wb1)) = (vel.velocity(a1), vel.velocity(b1));
    let (mut va, mut wa) = (Lanes3::of(va0, va1), Lanes3::of(wa0, wa1));
    let (mut vb, mut wb) = (Lanes3::of(vb0, vb1), Lanes3::of(wb0, wb1));
    let (s0, s1) = (rows.soft[p0[0]], rows.soft[p0[1]]);
    let bias_rate = pair(s0.bias_rate, s1.bias_rate);
    let max_push = -f64x2::splat(pass.max_push);
    let zero = f64x2::splat(0.0);
    // The points' impulses and largest normal impulses, lane by lane.
    let mut z = [[zero; 3]; N];
    let mut most = [zero; N];
    for i in 0..len {
        let ((z0, m0), (z1, m1)) = (io.get(blk[0].pts[i]), io.get(blk[1].pts[i]));
        z[i] = [pair(z0[0], z1[0]), pair(z0[1], z1[1]), pair(z0[2], z1[2])];
        most[i] = pair(m0, m1);
    }
    // r = J v + b + c∘(λ − λ_pre), zero in the padding.
    let mut r = [zero; N];
    for i in 0..len {
        let (p, q) = (blk[0].pts[i], blk[1].pts[i]);
        let (g, d0) = (&pr[i].ang, pr[i].dir[0]);
        let vn = d0.dot(vb.sub(va)) + g[0][1].dot(wb) - g[0][0].dot(wa);
        let bias = at_least(bias_rate * gap[i], max_push);
        let pre = at_most(
            pair(rows.preload[p], rows.preload[q]),
            at_least(
                pair(rows.preload_cap[p], rows.preload_cap[q]) * -gap[i],
                pair(rows.preload_floor[p], rows.preload_floor[q]),
            ),
        );
        r[i] = vn + bias + pair(blk[0].c[i], blk[1].c[i]) * (z[i][0] - pre);
    }
    // Δλ = −K⁻¹ r over all N rows (the padding of K⁻¹ is the identity).
    let mut dz = [zero; N];
    for (i, dz) in dz.iter_mut().enumerate() {
        let k = |l: usize| pair(blk[0].kinv[i * N + l], blk[1].kinv[i * N + l]);
        *dz = -(k(0) * r[0] + k(1) * r[1] + k(2) * r[2] + k(3) * r[3]);
        let after = (z[i][0] + *dz).to_array();
        if !(after[0] >= 0.0 && after[1] >= 0.0) {
            return false;
        }
    }
    for i in 0..len {
        let (g, d0) = (&pr[i].ang, pr[i].dir[0]);
        let [ma, mb] = pr[i].im;
        z[i][0] += dz[i];
        most[i] = at_least(z[i][0], most[i]);
        va = va.sub(d0.scale(ma * dz[i]));
        wa = wa.sub(g[0][2].scale(dz[i]));
        vb = vb.add(d0.scale(mb * dz[i]));
        wb = wb.add(g[0][3].scale(dz[i]));
    }
    // Friction point by point (no anchors: velocity rows, |λ_t| ≤ μ λ_n).
    for (i, zi) in z.iter_mut().enumerate().take(len) {
        let (g, [ma, mb]) = (&pr[i].ang, pr[i].im);
        let bound = pr[i].friction * zi[0];
        for rr in 1..3 {
            let d = pr[i].dir[rr];
            let vt = d.dot(vb.sub(va)) + g[rr][1].dot(wb) - g[rr][0].dot(wa);
            let unbounded = zi[rr] - pr[i].mass[rr] * vt;
            let new = at_least(at_most(unbounded, bound), -bound);
            let dz = new - zi[rr];
            zi[rr] = new;
            va = va.sub(d.scale(ma * dz));
            wa = wa.sub(g[rr][2].scale(dz));
            vb = vb.add(d.scale(mb * dz));
            wb = wb.add(g[rr][3].scale(dz));
        }
    }
    for lane in 0..2 {
        for i in 0..len {
            let zi = [
                z[i][0].as_array()[lane],
                z[i][1].as_array()[lane],
                z[i][2].as_array()[lane],
            ];
            io.set(blk[lane].pts[i], zi, most[i].as_array()[lane]);
        }
    }
    // The static slot's inverse mass and inertia are zero: it stays at rest.
    for (lane, (a, b)) in [(a0, b0), (a1, b1)].into_iter().enumerate() {
        if a != rows.fixed {
            vel.set_velocity(a, va.lane(lane), wa.lane(lane));
        }
        if b != rows.fixed {
            vel.set_velocity(b, vb.lane(lane), wb.lane(lane));
        }
    }
    true
}

/// The warm start of two manifolds of one colour (no shared moving body), one per
/// lane, their points in order, as `apply_point` on each: `v += M⁻¹ Jᵀ λ`, the
/// linear part `d₀λ₀ + d₁λ₁ + d₂λ₂` and the angular parts `Σ_r I⁻¹(r × d_r) λ_r`
/// summed left to right, the bodies' velocities loaded and stored once per manifold.
/// Returns false, having changed nothing, where they were not packed (as
/// [`relax_manifolds`]).
#[inline(always)]
pub(super) fn warm_manifolds(
    rows: &Rows,
    pr: Option<&[PairRows]>,
    pts: [&[usize]; 2],
    v: &mut [DVec3],
    w: &mut [DVec3],
    impulse: &[[f64; 3]],
) -> bool {
    let Some((pr, ab)) = packed(rows, pr, pts) else {
        return false;
    };
    let len = pr.len();
    let [mut va, mut wa, mut vb, mut wb] = load(v, w, ab);
    for i in 0..len {
        let (zp, zq) = (impulse[pts[0][i]], impulse[pts[1][i]]);
        let z = [pair(zp[0], zq[0]), pair(zp[1], zq[1]), pair(zp[2], zq[2])];
        let (d, g) = (&pr[i].dir, &pr[i].ang);
        let lin = d[0].scale(z[0]).add(d[1].scale(z[1])).add(d[2].scale(z[2]));
        let ang = |k: usize| {
            g[0][k]
                .scale(z[0])
                .add(g[1][k].scale(z[1]))
                .add(g[2][k].scale(z[2]))
        };
        let [ma, mb] = pr[i].im;
        va = va.sub(lin.scale(ma));
        wa = wa.sub(ang(2));
        vb = vb.add(lin.scale(mb));
        wb = wb.add(ang(3));
    }
    store(v, w, ab, [va, wa, vb, wb], rows.fixed);
    true
}
