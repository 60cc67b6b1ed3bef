//! The soft step's passes two or four manifolds at a time, one per SIMD lane
//! (`wide::f64x2`, or four lanes of a 256-bit AVX register where the processor has
//! AVX: the [`avx`] module; Box2D v3 solves its contact constraints in SIMD lanes the
//! same way, `contact_solver.c`, `b2SolveContactTwoPointsTask`).
//!
//! The colouring's groups (one place of one colour: see the `colouring` module) hold
//! points whose manifolds share no moving body, so within a group the Gauss–Seidel
//! updates of two points commute: solving them side by side in lanes is the same
//! work as solving them one after the other. Each lane does exactly the arithmetic of
//! [`solve_point`](super::soft_step::solve_point) in the relax pass (`use_bias`
//! false; and with `use_bias`, the biased pass without the block normal solve),
//! operation for operation and in the same order (IEEE-754 lanes round as the
//! scalar operations do, SSE2 and AVX alike, and nothing is contracted into a fused
//! multiply-add; `at_least`/`at_most` keep the scalar compare-and-select), so the
//! result is the same, bit for bit, as the one-point pass (and as the threaded
//! passes, which stay one point at a time: `verify/tests/determinism.rs`).
//!
//! The passes take the manifolds of a colour two or four at a time, one per lane,
//! with their points in order: the two bodies' velocities of each manifold (every
//! point of a manifold has the same two) are gathered once, updated point by point
//! and scattered back once per manifold (loading and storing them per point was a
//! quarter of the warm start; the 210-box pyramid's step −2.0 %, callgrind). The
//! rows come packed per quad of manifolds ([`Paired`]; lanes 0–1 one pair, 2–3 the
//! next), written once per step by `prepare` as it computes each point, in the order
//! the passes read them (looking each pair of points up by solve position instead
//! cost 4.6 % of the pyramid's step); the four lanes of a value are contiguous, so
//! that the four-lane passes load them with one 256-bit load and the two-lane passes
//! with one 128-bit load of either half.

use core::ops::{Add, Div, Mul, Neg, Sub};

use constraint_core::{DMat3, DVec3};
use wide::f64x2;

use super::soft_step::{Block, Pass, Rows, BLOCK_POINTS};

// The crate's one `unsafe`: AVX intrinsics, run only where the processor has AVX.
#[allow(unsafe_code)]
#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx")))]
mod avx;
pub(super) use avx::{
    biased_quad, block_quad, build_quad, fill_points, gaps_quad, relax_quad, warm_quad, Avx,
};

mod build;
pub(super) use build::{build_lanes, Built};

mod packed;
use packed::{HeadRows, Pack, QuadRows};
pub(super) use packed::{Paired, PointRows};

/// Without AVX (other processors, or `no_std` builds without
/// `-C target-feature=+avx`): no quads ([`Paired::quad`] is `None`), two lanes only.
#[cfg(not(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx"))))]
mod avx {
    use super::{Block, DMat3, DVec3, Normals, Pack, Pass, RelaxIo, Rows};

    /// Declines (no AVX builds of the preparation's per-point loop here).
    pub(in crate::rigid) fn fill_points(
        _: &crate::rigid::ContactWorld,
        _: &mut crate::rigid::soft_step::SoftState,
        _: &crate::rigid::soft_step::PointConsts,
    ) -> Option<bool> {
        None
    }

    /// No AVX here: no value of this type exists.
    #[derive(Clone, Copy, Debug)]
    pub(in crate::rigid) enum Avx {}

    impl Avx {
        /// `None`: no AVX here.
        #[inline]
        pub(in crate::rigid) fn detect() -> Option<Self> {
            None
        }
    }

    /// Never called (no [`Avx`] exists here).
    pub(in crate::rigid) fn build_quad(
        avx: Avx,
        _: &Rows,
        _: Pack,
        _: [&[usize]; 4],
        _: [&mut Block; 4],
    ) -> super::Built {
        match avx {}
    }

    /// Never called (no [`Avx`] exists here).
    pub(in crate::rigid) fn gaps_quad(
        avx: Avx,
        _: &Rows,
        _: [&[usize]; 4],
        _: Option<Normals>,
        _: [[usize; 2]; 4],
        _: (&[DVec3], &[DMat3]),
        _: &mut [f64],
    ) -> bool {
        match avx {}
    }

    /// Declines (no four-lane passes here).
    pub(in crate::rigid) fn relax_quad(
        _: &Rows,
        _: Option<Pack>,
        _: [&[usize]; 4],
        _: &mut RelaxIo,
        _: f64,
    ) -> bool {
        false
    }

    /// Declines (no four-lane passes here).
    pub(in crate::rigid) fn biased_quad(
        _: &Rows,
        _: Option<Pack>,
        _: [&[usize]; 4],
        _: &mut RelaxIo,
        _: Pass,
    ) -> bool {
        false
    }

    /// Declines (no four-lane passes here).
    pub(in crate::rigid) fn warm_quad(
        _: &Rows,
        _: Option<Pack>,
        _: [&[usize]; 4],
        _: &mut [DVec3],
        _: &mut [DVec3],
        _: &[[f64; 3]],
    ) -> bool {
        false
    }

    /// Declines (no four-lane passes here).
    pub(in crate::rigid) fn block_quad(
        _: &Rows,
        _: Option<Pack>,
        _: [&Block; 4],
        _: &mut RelaxIo,
        _: Pass,
    ) -> Option<u32> {
        None
    }
}

/// Four lanes of one packed value: lanes 0–1 (manifold pair `(j, j + 1)`) and 2–3
/// (`(j + 2, j + 3)`), contiguous.
type Quad = [f64x2; 2];

/// Lanes of `f64`, each doing the scalar operations (`+ − × ÷ neg`, and the scalar
/// compare-and-select of `at_least`/`at_most`) with the scalar's rounding: `f64x2`,
/// and four AVX lanes in the [`avx`] module.
pub(super) trait Lane:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The number of lanes.
    const LANES: usize;
    /// Every lane `x`.
    fn splat(x: f64) -> Self;
    /// `K` lane values `f(l)[k]` at once, lane `l` from `f(l)` (lanes in order).
    fn gather<const K: usize>(f: impl FnMut(usize) -> [f64; K]) -> [Self; K];
    /// [`Lane::gather`] of three values read in place (`f(l)`: lane `l`'s), the same
    /// lanes; the AVX lanes load two of each lane's values as one 128-bit load and
    /// transpose them (two loads and two shuffles where eight scalar loads took four
    /// inserts).
    #[inline(always)]
    fn gather3<'a>(mut f: impl FnMut(usize) -> &'a [f64; 3]) -> [Self; 3] {
        Self::gather(|l| *f(l))
    }
    /// Lane `l` of `[x, y, z]` written to `out[at(l)]`, lanes in order (the writes
    /// of [`Lane::array`]'s lanes one by one); the AVX lanes store two of each lane's
    /// values as one 128-bit store.
    #[inline(always)]
    fn scatter3(v: [Self; 3], out: &mut [[f64; 3]], mut at: impl FnMut(usize) -> usize) {
        let [x, y, z] = [v[0].array(), v[1].array(), v[2].array()];
        for l in 0..Self::LANES {
            out[at(l)] = [x[l], y[l], z[l]];
        }
    }
    /// Lane `l`.
    fn lane(self, l: usize) -> f64;
    /// The lanes in order (zeros past the last).
    fn array(self) -> [f64; 4];
    /// `x` if `x > lo`, else `lo`, per lane.
    fn at_least(self, lo: Self) -> Self;
    /// `x` if `x < hi`, else `hi`, per lane.
    fn at_most(self, hi: Self) -> Self;
    /// Bit `l` set where lane `l` is `≥ 0` (clear for NaN).
    fn nonneg_mask(self) -> u32;
    /// Bit `l` set where lane `l` is `> 0` (clear for NaN).
    fn positive_mask(self) -> u32;
    /// The lanes of packed value `q`: half `half` (two lanes) or all four (`half`
    /// ignored).
    fn load(q: &Quad, half: usize) -> Self;
}

impl Lane for f64x2 {
    const LANES: usize = 2;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        f64x2::splat(x)
    }
    #[inline(always)]
    fn gather<const K: usize>(mut f: impl FnMut(usize) -> [f64; K]) -> [Self; K] {
        let (p, q) = (f(0), f(1));
        let mut out = [f64x2::ZERO; K];
        for (k, o) in out.iter_mut().enumerate() {
            *o = pair(p[k], q[k]);
        }
        out
    }
    #[inline(always)]
    fn lane(self, l: usize) -> f64 {
        self.as_array()[l]
    }
    #[inline(always)]
    fn array(self) -> [f64; 4] {
        let [x, y] = self.to_array();
        [x, y, 0.0, 0.0]
    }
    #[inline(always)]
    fn at_least(self, lo: Self) -> Self {
        at_least(self, lo)
    }
    #[inline(always)]
    fn at_most(self, hi: Self) -> Self {
        at_most(self, hi)
    }
    #[inline(always)]
    fn nonneg_mask(self) -> u32 {
        // An ordered compare (false for NaN), its sign bits.
        self.simd_ge(f64x2::ZERO).to_bitmask()
    }
    #[inline(always)]
    fn positive_mask(self) -> u32 {
        self.simd_gt(f64x2::ZERO).to_bitmask()
    }
    #[inline(always)]
    fn load(q: &Quad, half: usize) -> Self {
        q[half & 1]
    }
}

/// The lanes of a [`Lanes3`], by component.
#[derive(Clone, Copy)]
struct Arrays3([[f64; 4]; 3]);

impl Arrays3 {
    /// Lane `l`.
    #[inline(always)]
    fn lane(&self, l: usize) -> DVec3 {
        let [x, y, z] = &self.0;
        DVec3::new(x[l], y[l], z[l])
    }
}

/// One 3-vector per lane.
#[derive(Clone, Copy, Debug)]
struct Lanes3<L> {
    x: L,
    y: L,
    z: L,
}

impl<L: Lane> Lanes3<L> {
    #[inline(always)]
    fn new(x: L, y: L, z: L) -> Self {
        Self { x, y, z }
    }

    /// Lane `l` from `f(l)`.
    #[inline(always)]
    fn of(mut f: impl FnMut(usize) -> DVec3) -> Self {
        let [x, y, z] = L::gather(|l| f(l).to_array());
        Self { x, y, z }
    }

    /// The lanes of each component stored once ([`Lane::array`]).
    #[inline(always)]
    fn array(self) -> Arrays3 {
        Arrays3([self.x.array(), self.y.array(), self.z.array()])
    }

    /// `xx' + yy' + zz'`, summed left to right as `DVec3::dot` does.
    #[inline(always)]
    fn dot(self, o: Self) -> L {
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
    fn scale(self, s: L) -> Self {
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

/// Where this processor runs the four-lane passes (AVX: detected at run time with
/// `std`, or compiled in with `-C target-feature=+avx`; never without `std` otherwise).
#[inline]
fn four_lanes() -> Option<Avx> {
    #[cfg(all(test, feature = "std"))]
    if tests::TWO_LANES.with(core::cell::Cell::get) {
        return None;
    }
    Avx::detect()
}

/// The velocities and impulses the lane passes write (the single-thread state's own
/// slices).
pub(super) struct RelaxIo<'a> {
    pub(super) v: &'a mut [DVec3],
    pub(super) w: &'a mut [DVec3],
    pub(super) impulse: &'a mut [[f64; 3]],
    pub(super) max_normal: &'a mut [f64],
    /// Gaps at the current displacements.
    pub(super) gap: &'a [f64],
    /// Whether `max_normal` is kept: only restitution reads it, so a step without
    /// restitution ([`SoftState::bouncy`](super::soft_step::SoftState) false) neither
    /// gathers nor stores it in the lanes (the same impulses and velocities).
    pub(super) track: bool,
}

impl RelaxIo<'_> {
    /// The same slices, those indexed by a point cut to one length (the points') and
    /// those indexed by a body to another, so that an index is checked once for
    /// all of them (per array, each lane's index was checked per array: 14 % of the
    /// four-lane biased pass was bounds checks, callgrind); `None` where they are
    /// shorter than that.
    #[inline(always)]
    fn even(&mut self) -> Option<RelaxIo<'_>> {
        let (n, bodies) = (self.gap.len(), self.v.len());
        Some(RelaxIo {
            v: &mut *self.v,
            w: self.w.get_mut(..bodies)?,
            impulse: self.impulse.get_mut(..n)?,
            max_normal: self.max_normal.get_mut(..n)?,
            gap: self.gap,
            track: self.track,
        })
    }
}

/// `[f(0), …, f(W − 1)]` (a plain loop: `<[T; W]>::map` was left out of line in the
/// four-lane biased pass, 3.9 % of the 210-box pyramid's step, callgrind).
#[inline(always)]
fn each<T: Copy + Default, const W: usize>(mut f: impl FnMut(usize) -> T) -> [T; W] {
    let mut out = [T::default(); W];
    for (l, o) in out.iter_mut().enumerate() {
        *o = f(l);
    }
    out
}

/// The bodies' slots of `W` manifolds (one per lane), where their rows were packed
/// side by side (`pr`) with the same number of points; `None` otherwise (the caller
/// then solves them one point at a time).
#[inline(always)]
fn packed<const W: usize>(rows: &Rows, pr: Pack, pts: &[&[usize]; W]) -> Option<[[usize; 2]; W]> {
    let len = pr.rows.len();
    if len == 0 || pts.iter().any(|m| m.len() != len) {
        return None;
    }
    let mut ab = [[0; 2]; W];
    for (ab, m) in ab.iter_mut().zip(pts) {
        *ab = *rows.slots.get(*m.first()?)?;
    }
    Some(ab)
}

/// The two bodies' velocities of `W` manifolds, one per lane: `(v_a, ω_a, v_b, ω_b)`
/// (every point of a manifold has the same two bodies).
#[inline(always)]
fn load<L: Lane, const W: usize>(v: &[DVec3], w: &[DVec3], ab: &[[usize; 2]; W]) -> [Lanes3<L>; 4] {
    // Each vector gathered in place ([`Lane::gather3`]).
    let [vax, vay, vaz] = L::gather3(|l| v[ab[l][0]].as_ref());
    let [wax, way, waz] = L::gather3(|l| w[ab[l][0]].as_ref());
    let [vbx, vby, vbz] = L::gather3(|l| v[ab[l][1]].as_ref());
    let [wbx, wby, wbz] = L::gather3(|l| w[ab[l][1]].as_ref());
    [
        Lanes3::new(vax, vay, vaz),
        Lanes3::new(wax, way, waz),
        Lanes3::new(vbx, vby, vbz),
        Lanes3::new(wbx, wby, wbz),
    ]
}

/// Stores what [`load`] loaded, lane by lane; the static slot keeps its zero velocity
/// (its inverse mass and inertia are zero: it stays at rest).
#[inline(always)]
fn store<L: Lane, const W: usize>(
    v: &mut [DVec3],
    w: &mut [DVec3],
    ab: &[[usize; 2]; W],
    [va, wa, vb, wb]: [Lanes3<L>; 4],
    fixed: usize,
) {
    // Every lane written, the static slot's too, and the static slot then set back
    // to the `+0` it holds (`load_bodies` writes it and no pass writes another): no
    // branch per body on whether it is the static slot (whether a manifold touches
    // the ground is data; that branch was 17.5k of the 210-box pyramid's 534k
    // simulated mispredicts in 60 steps, cachegrind `--branch-sim`). Within a colour
    // only the static slot is shared between lanes, so every moving body is written
    // once, as before, and nothing reads the static slot in between.
    let [va, wa, vb, wb] = [va.array(), wa.array(), vb.array(), wb.array()];
    for (lane, &[a, b]) in ab.iter().enumerate() {
        v[a] = va.lane(lane);
        w[a] = wa.lane(lane);
        v[b] = vb.lane(lane);
        w[b] = wb.lane(lane);
    }
    if let (Some(v), Some(w)) = (v.get_mut(fixed), w.get_mut(fixed)) {
        (*v, *w) = (DVec3::ZERO, DVec3::ZERO);
    }
}

/// The relax pass over two manifolds of one colour (no shared moving body), one per
/// lane, their points in order: per point the rigid normal row (the speculative
/// target `C/h` where separated, else no bias: `Δv = −m (J v + b)`, `λ ≥ 0`), then
/// the two friction rows bounded by `μ λ_n` (`|λ_t| ≤ μ λ_n`), as `solve_point` with
/// `use_bias` false on each point, the bodies' velocities loaded once and stored once
/// per manifold (Box2D v3 loads them per point). `pr`: their packed rows and lane
/// half ([`Paired::of`]). Returns false, having changed nothing, where they were not
/// packed (point counts that differ or exceed [`BLOCK_POINTS`]): the caller then
/// solves them one point at a time (the same bits, the two being independent).
#[inline(always)]
pub(super) fn relax_manifolds(
    rows: &Rows,
    pr: Option<(Pack, usize)>,
    pts: [&[usize]; 2],
    io: &mut RelaxIo,
    inv_h: f64,
) -> bool {
    pr.is_some_and(|(pr, half)| relax_lanes::<f64x2, 2, false>(rows, pr, half, pts, io, inv_h, 0.0))
}

/// The biased pass point by point (without the block normal solve,
/// `SoftStepSettings::block_normal` off) over two manifolds of one colour, one per
/// lane, their points in order: per point the soft normal row (`Δλ = −m·mass_scale·(J
/// v + b) − impulse_scale·(λ − λ_pre)`, `λ ≥ 0`, the preload capped by the
/// penetration), then the two friction rows bounded by `μ λ_n`, as `solve_point` with
/// `use_bias` on each point. Returns false, having changed nothing, where they were
/// not packed (as [`relax_manifolds`]), with friction anchors on, or where a point is
/// separated (speculative, `C > 0`): the caller then solves them one point at a time
/// (the same bits).
#[inline(always)]
pub(super) fn biased_manifolds(
    rows: &Rows,
    pr: Option<(Pack, usize)>,
    pts: [&[usize]; 2],
    io: &mut RelaxIo,
    pass: Pass,
) -> bool {
    pr.is_some_and(|(pr, half)| {
        !pass.anchors
            && relax_lanes::<f64x2, 2, true>(rows, pr, half, pts, io, pass.inv_h, pass.max_push)
    })
}

/// [`relax_manifolds`] (`BIASED` false) or [`biased_manifolds`] (`BIASED` true, the
/// caller having checked that friction anchors are off; `max_push` read only then)
/// on `W` manifolds in the `W` lanes of `L` (`half`: the lanes of the packed rows
/// `pr` two lanes take).
#[inline(always)]
fn relax_lanes<L: Lane, const W: usize, const BIASED: bool>(
    rows: &Rows,
    pr: Pack,
    half: usize,
    pts: [&[usize]; W],
    io: &mut RelaxIo,
    inv_h: f64,
    max_push: f64,
) -> bool {
    // `relax_rows` takes `max(C, 0) · inv_h` for the speculative `C · inv_h` where `C
    // > 0` (else 0): the same where `inv_h` is positive and finite (`0 · ∞` is NaN).
    let usable = inv_h > 0.0 && inv_h.is_finite();
    if !BIASED && !usable {
        return false;
    }
    let Some(ab) = packed(rows, pr, &pts) else {
        return false;
    };
    let Some(mut io) = io.even() else {
        return false;
    };
    let io = &mut io;
    // The biased rows: every point touching (`C ≤ 0`; a NaN gap takes the touching
    // branch, as in `solve_point`), and the manifolds' softness (one per manifold).
    let normal = if BIASED {
        let Some(soft) = rows.soft.get(..io.gap.len()) else {
            return false;
        };
        if pts.iter().flat_map(|m| m.iter()).any(|&p| io.gap[p] > 0.0) {
            return false;
        }
        let p0: [usize; W] = each(|l| pts[l][0]);
        let [rate, mass, impulse] = L::gather(|l| {
            let s = soft[p0[l]];
            [s.bias_rate, s.mass_scale, s.impulse_scale]
        });
        NormalRow::Soft(SoftLanes {
            rate,
            mass,
            impulse,
            max_push: -L::splat(max_push),
        })
    } else {
        NormalRow::Rigid { inv_h }
    };
    let [mut va, mut wa, mut vb, mut wb] = load::<L, W>(io.v, io.w, &ab);
    // `BLOCK_POINTS` points (every box–box manifold) with the count a constant: the
    // loop unrolled (the same operations in the same order).
    let vel = (&mut va, &mut wa, &mut vb, &mut wb);
    if let Ok(four) = <&[QuadRows; BLOCK_POINTS]>::try_from(pr.rows) {
        relax_points(pr.head, four, half, &pts, io, vel, normal);
    } else {
        relax_points(pr.head, pr.rows, half, &pts, io, vel, normal);
    }
    store(io.v, io.w, &ab, [va, wa, vb, wb], rows.fixed);
    true
}

/// The normal row of [`relax_lanes`]' points: rigid (the relax pass, speculative
/// where separated, `inv_h` the inverse sub-step) or soft (the biased pass).
#[derive(Clone, Copy)]
enum NormalRow<L> {
    Rigid { inv_h: f64 },
    Soft(SoftLanes<L>),
}

/// The soft normal rows' coefficients of `W` manifolds, one per lane (the biased
/// point pass, [`biased_manifolds`]): `bias_rate`, `mass_scale`, `impulse_scale`,
/// and `−max_push`.
#[derive(Clone, Copy)]
struct SoftLanes<L> {
    rate: L,
    mass: L,
    impulse: L,
    max_push: L,
}

/// [`relax_lanes`]' points: `rows` of the packed rows (an array where their count
/// is a constant), on velocities held by the caller (`[v_a, ω_a, v_b, ω_b]`).
#[inline(always)]
fn relax_points<L: Lane, const W: usize>(
    head: &HeadRows,
    rows: &[QuadRows],
    half: usize,
    pts: &[&[usize]; W],
    io: &mut RelaxIo,
    (va, wa, vb, wb): (
        &mut Lanes3<L>,
        &mut Lanes3<L>,
        &mut Lanes3<L>,
        &mut Lanes3<L>,
    ),
    normal: NormalRow<L>,
) {
    for (i, q) in rows.iter().enumerate() {
        let p: [usize; W] = each(|l| pts[l][i]);
        relax_rows(
            head,
            q,
            half,
            &p,
            io,
            (&mut *va, &mut *wa, &mut *vb, &mut *wb),
            normal,
        );
    }
}

/// Points `p` of [`relax_lanes`], one per lane, on velocities held by the caller
/// (`[v_a, ω_a, v_b, ω_b]`).
#[inline(always)]
fn relax_rows<L: Lane, const W: usize>(
    head: &HeadRows,
    pr: &QuadRows,
    half: usize,
    p: &[usize; W],
    io: &mut RelaxIo,
    (va, wa, vb, wb): (
        &mut Lanes3<L>,
        &mut Lanes3<L>,
        &mut Lanes3<L>,
        &mut Lanes3<L>,
    ),
    normal: NormalRow<L>,
) {
    let (ma, mb) = head.im::<L>(half);
    // The point's impulses, largest normal impulse and gap gathered at once.
    let [z0, z1, z2] = L::gather3(|l| &io.impulse[p[l]]);
    let [gap] = L::gather(|l| [io.gap[p[l]]]);
    let (one, zero) = (L::splat(1.0), L::splat(0.0));
    let (bias, mass_scale, impulse_scale, pre) = match normal {
        // Relax: speculative where separated, approach at most to the surface within
        // the sub-step; rigid (mass_scale 1, impulse_scale 0, no preload) either way.
        // `gap · inv_h` where `gap > 0`, else `+0`: `max(gap, 0) · inv_h` per lane (a
        // NaN gap gives 0 either way; `inv_h` is positive and finite: see
        // `relax_lanes`).
        NormalRow::Rigid { inv_h } => (gap.at_least(zero) * L::splat(inv_h), one, zero, zero),
        // Biased, every point touching (see `relax_lanes`): the soft row, its bias
        // `max(bias_rate · C, −max_push)` and its preload `min(λ_pre, max(cap · (−C),
        // floor))`, as `solve_point`.
        NormalRow::Soft(s) => {
            let [preload, cap, floor] = pr.pre::<L>(half);
            (
                (s.rate * gap).at_least(s.max_push),
                s.mass,
                s.impulse,
                preload.at_most((cap * -gap).at_least(floor)),
            )
        }
    };
    let d0 = head.dir::<L>(0, half);
    let vn =
        d0.dot(vb.sub(*va)) + pr.ang(head, 0, 1, half).dot(*wb) - pr.ang(head, 0, 0, half).dot(*wa);
    let mass0 = pr.mass::<L>(0, half);
    let new = (z0 - mass0 * mass_scale * (vn + bias) - impulse_scale * (z0 - pre)).at_least(zero);
    let dz = new - z0;
    *va = va.sub(d0.scale(ma * dz));
    *wa = wa.sub(pr.ang(head, 0, 2, half).scale(dz));
    *vb = vb.add(d0.scale(mb * dz));
    *wb = wb.add(pr.ang(head, 0, 3, half).scale(dz));
    let bound = head.friction::<L>(half) * new;
    let mut z = [new, z1, z2];
    for r in 1..3 {
        let d = head.dir::<L>(r, half);
        let zr = z[r];
        let vt = d.dot(vb.sub(*va)) + pr.ang(head, r, 1, half).dot(*wb)
            - pr.ang(head, r, 0, half).dot(*wa);
        let unbounded = zr - pr.mass::<L>(r, half) * vt;
        let new = unbounded.at_most(bound).at_least(-bound);
        let dz = new - zr;
        z[r] = new;
        *va = va.sub(d.scale(ma * dz));
        *wa = wa.sub(pr.ang(head, r, 2, half).scale(dz));
        *vb = vb.add(d.scale(mb * dz));
        *wb = wb.add(pr.ang(head, r, 3, half).scale(dz));
    }
    // Written lane by lane ([`Lane::scatter3`]).
    L::scatter3(z, io.impulse, |l| p[l]);
    // The largest normal impulses where restitution reads them.
    if io.track {
        let most = L::gather(|l| [io.max_normal[p[l]]])[0];
        let m = z[0].at_least(most).array();
        for (lane, &point) in p.iter().enumerate() {
            io.max_normal[point] = m[lane];
        }
    }
}

/// The biased pass over manifolds `b0` and `b1` (of one colour: no shared moving
/// body) with their normal rows solved as blocks, one manifold per lane: exactly
/// `solve_block` on each (`(A + diag c) Δλ = −(J v + b + c∘(λ − λ_pre))`, then the
/// friction rows point by point), for two blocks of the same point count without
/// friction anchors; `pr`: their packed rows and lane half ([`Paired::of`]).
/// Returns the manifolds left to the caller, bit `l` for lane `l`, having changed
/// nothing of theirs: both where the lanes do not apply, and each for which
/// `solve_block` would not take the fast path (a separated point, a preload on its
/// cap, an impulse turning negative); the caller then solves those one at a time
/// (the same bits either way, the manifolds of a colour being independent).
#[inline(always)]
pub(super) fn block_pair(
    rows: &Rows,
    pr: Option<(Pack, usize)>,
    blk: [&Block; 2],
    io: &mut RelaxIo,
    pass: Pass,
) -> u32 {
    pr.and_then(|(pr, half)| block_lanes::<f64x2, 2>(rows, pr, half, blk, io, pass))
        .unwrap_or(0b11)
}

/// [`block_pair`] on `W` manifolds in the `W` lanes of `L` (`half`: the lanes of the
/// packed rows `pr` two lanes take): `None`, having changed nothing, where the lanes
/// do not apply, else the lanes left to the caller.
#[inline(always)]
fn block_lanes<L: Lane, const W: usize>(
    rows: &Rows,
    pr: Pack,
    half: usize,
    blk: [&Block; W],
    io: &mut RelaxIo,
    pass: Pass,
) -> Option<u32> {
    // A manifold of `BLOCK_POINTS` points (every box–box manifold) takes a build with
    // the point count a constant: its point loops unrolled and their arrays held in
    // registers instead of on the stack (the same operations in the same order).
    let len = blk[0].len;
    if len == BLOCK_POINTS {
        block_points::<L, W>(rows, pr, half, blk, io, pass, BLOCK_POINTS)
    } else {
        block_points::<L, W>(rows, pr, half, blk, io, pass, len)
    }
}

/// [`block_lanes`] on blocks of `len` points (a constant where inlined with one).
#[inline(always)]
fn block_points<L: Lane, const W: usize>(
    rows: &Rows,
    pr: Pack,
    half: usize,
    blk: [&Block; W],
    io: &mut RelaxIo,
    pass: Pass,
    len: usize,
) -> Option<u32> {
    const N: usize = BLOCK_POINTS;
    if len == 0 || len > N || blk.iter().any(|b| b.len != len) || pass.anchors {
        return None;
    }
    // One length for the packed rows too (one bounds check each).
    let (rows_of, blocks_of) = (pr.rows.get(..len)?, pr.blocks.get(..len)?);
    // One length for every slice indexed by a point (see `RelaxIo::even`).
    let io = io.even()?;
    let n = io.gap.len();
    let (slots, soft) = (rows.slots.get(..n)?, rows.soft.get(..n)?);
    let RelaxIo {
        v,
        w,
        impulse,
        max_normal,
        gap: gaps,
        track,
    } = io;
    let zero = L::splat(0.0);
    // The lanes that stay (bit `l`: lane `l`); a lane that leaves is computed with
    // the others but not written.
    let all = (1u32 << W) - 1;
    let mut keep = all;
    let mut gap = [zero; N];
    for (i, g) in gap.iter_mut().enumerate().take(len) {
        *g = L::gather(|l| [gaps[blk[l].pts[i]]])[0];
        keep &= !g.positive_mask();
    }
    if keep == 0 {
        return Some(all);
    }
    let p0: [usize; W] = each(|l| blk[l].pts[0]);
    let ab: [[usize; 2]; W] = each(|l| slots[p0[l]]);
    let [mut va, mut wa, mut vb, mut wb] = load::<L, W>(v, w, &ab);
    let [bias_rate] = L::gather(|l| [soft[p0[l]].bias_rate]);
    let max_push = -L::splat(pass.max_push);
    // The points' impulses, lane by lane.
    let mut z = [[zero; 3]; N];
    for i in 0..len {
        z[i] = L::gather3(|l| &impulse[blk[l].pts[i]]);
    }
    // r = J v + b + c∘(λ − λ_pre), zero in the padding.
    let mut r = [zero; N];
    for i in 0..len {
        let (q, d0) = (&rows_of[i], pr.head.dir::<L>(0, half));
        let vn = d0.dot(vb.sub(va)) + q.ang(pr.head, 0, 1, half).dot(wb)
            - q.ang(pr.head, 0, 0, half).dot(wa);
        let bias = (bias_rate * gap[i]).at_least(max_push);
        // Packed once a step beside the point's rows (`Paired::put`).
        let [preload, cap, floor] = q.pre::<L>(half);
        // `c` as the blocks' build packed it (the same values) where it did.
        let c = if len == N {
            blocks_of[i].c::<L>(half)
        } else {
            L::gather(|l| [blk[l].c[i]])[0]
        };
        let capped = cap * -gap[i];
        let pre = preload.at_most(capped.at_least(floor));
        // A preload on its cap: the manifold goes to `solve_block` (which takes the
        // cap at the sub-step's end).
        // On the cap: `floor < κ(−C) < λ_pre`, i.e. `min(κ(−C) − floor, λ_pre − κ(−C)) >
        // 0` (exact: a difference of doubles is positive just where `a > b`; NaN goes
        // to `solve_block` too).
        keep &= (zero - (capped - floor).at_most(preload - capped)).nonneg_mask();
        r[i] = vn + bias + c * (z[i][0] - pre);
    }
    // Δλ = −K⁻¹ r over all N rows (the padding of K⁻¹ is the identity).
    let mut dz = [zero; N];
    for (i, dz) in dz.iter_mut().enumerate() {
        // `K⁻¹` as the blocks' build packed it (`Paired::put_block`: every lane's
        // block has `len` N and was built this step), else gathered from the blocks.
        let k = if len == N {
            let k = &blocks_of[i];
            [
                k.kinv::<L>(0, half),
                k.kinv::<L>(1, half),
                k.kinv::<L>(2, half),
                k.kinv::<L>(3, half),
            ]
        } else {
            L::gather(|l| {
                let kinv = &blk[l].kinv;
                [
                    kinv[i * N],
                    kinv[i * N + 1],
                    kinv[i * N + 2],
                    kinv[i * N + 3],
                ]
            })
        };
        *dz = -(k[0] * r[0] + k[1] * r[1] + k[2] * r[2] + k[3] * r[3]);
        keep &= (z[i][0] + *dz).nonneg_mask();
    }
    if keep == 0 {
        return Some(all);
    }
    let (head, (ma, mb)) = (pr.head, pr.head.im::<L>(half));
    for i in 0..len {
        let q = &rows_of[i];
        let d0 = head.dir::<L>(0, half);
        z[i][0] = z[i][0] + dz[i];
        va = va.sub(d0.scale(ma * dz[i]));
        wa = wa.sub(q.ang(head, 0, 2, half).scale(dz[i]));
        vb = vb.add(d0.scale(mb * dz[i]));
        wb = wb.add(q.ang(head, 0, 3, half).scale(dz[i]));
    }
    // Friction point by point (no anchors: velocity rows, |λ_t| ≤ μ λ_n).
    for (i, zi) in z.iter_mut().enumerate().take(len) {
        let q = &rows_of[i];
        let bound = head.friction::<L>(half) * zi[0];
        for rr in 1..3 {
            let d = head.dir::<L>(rr, half);
            let vt = d.dot(vb.sub(va)) + q.ang(head, rr, 1, half).dot(wb)
                - q.ang(head, rr, 0, half).dot(wa);
            let unbounded = zi[rr] - q.mass::<L>(rr, half) * vt;
            let new = unbounded.at_most(bound).at_least(-bound);
            let dz = new - zi[rr];
            zi[rr] = new;
            va = va.sub(d.scale(ma * dz));
            wa = wa.sub(q.ang(head, rr, 2, half).scale(dz));
            vb = vb.add(d.scale(mb * dz));
            wb = wb.add(q.ang(head, rr, 3, half).scale(dz));
        }
    }
    if keep != all {
        // Only the lanes that stay written (the others' values discarded).
        // (Lanes turned to arrays here, where the lanes' instructions are enabled.)
        let mut za = [[[0.0; 4]; 3]; N];
        for (a, zi) in za.iter_mut().zip(&z).take(len) {
            *a = [zi[0].array(), zi[1].array(), zi[2].array()];
        }
        store_some(keep, &za[..len], (impulse, max_normal, track), blk);
        let vel = [va.array(), wa.array(), vb.array(), wb.array()];
        store_lanes(keep, v, w, &ab, vel, rows.fixed);
        return Some(all & !keep);
    }
    // Written lane by lane ([`Lane::scatter3`]).
    for i in 0..len {
        L::scatter3(z[i], impulse, |l| blk[l].pts[i]);
    }
    // The largest normal impulses (the normal impulse after the block, unchanged by
    // friction) where restitution reads them.
    if track {
        for i in 0..len {
            let most = L::gather(|l| [max_normal[blk[l].pts[i]]])[0];
            let m = z[i][0].at_least(most).array();
            for (lane, b) in blk.iter().enumerate() {
                max_normal[b.pts[i]] = m[lane];
            }
        }
    }
    store(v, w, &ab, [va, wa, vb, wb], rows.fixed);
    Some(0)
}

/// [`block_points`]' writes of the impulses (and the largest normal impulses where
/// `track`) of the lanes in `keep` only (bit `l`: lane `l`), lane by lane: the same
/// values as its all-lanes writes.
#[inline(never)]
fn store_some<const W: usize>(
    keep: u32,
    z: &[[[f64; 4]; 3]],
    (impulse, max_normal, track): (&mut [[f64; 3]], &mut [f64], bool),
    blk: [&Block; W],
) {
    for (i, &[x, y, zz]) in z.iter().enumerate() {
        for (l, b) in blk.iter().enumerate() {
            if keep & (1 << l) == 0 {
                continue;
            }
            let p = b.pts[i];
            impulse[p] = [x[l], y[l], zz[l]];
            if track {
                // `at_least(λ', most)`, as the lanes' `at_least`.
                let most = max_normal[p];
                max_normal[p] = if x[l] > most { x[l] } else { most };
            }
        }
    }
}

/// [`store`] of the lanes in `keep` only (bit `l`: lane `l`).
#[inline(never)]
fn store_lanes<const W: usize>(
    keep: u32,
    v: &mut [DVec3],
    w: &mut [DVec3],
    ab: &[[usize; 2]; W],
    [va, wa, vb, wb]: [Arrays3; 4],
    fixed: usize,
) {
    for (lane, &[a, b]) in ab.iter().enumerate() {
        if keep & (1 << lane) != 0 {
            v[a] = va.lane(lane);
            w[a] = wa.lane(lane);
            v[b] = vb.lane(lane);
            w[b] = wb.lane(lane);
        }
    }
    if let (Some(v), Some(w)) = (v.get_mut(fixed), w.get_mut(fixed)) {
        (*v, *w) = (DVec3::ZERO, DVec3::ZERO);
    }
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
    pr: Option<(Pack, usize)>,
    pts: [&[usize]; 2],
    v: &mut [DVec3],
    w: &mut [DVec3],
    impulse: &[[f64; 3]],
) -> bool {
    pr.is_some_and(|(pr, half)| warm_lanes::<f64x2, 2>(rows, pr, half, pts, v, w, impulse))
}

/// [`warm_manifolds`] on `W` manifolds in the `W` lanes of `L` (`half`: the lanes of
/// the packed rows `pr` two lanes take).
#[inline(always)]
fn warm_lanes<L: Lane, const W: usize>(
    rows: &Rows,
    pr: Pack,
    half: usize,
    pts: [&[usize]; W],
    v: &mut [DVec3],
    w: &mut [DVec3],
    impulse: &[[f64; 3]],
) -> bool {
    let Some(ab) = packed(rows, pr, &pts) else {
        return false;
    };
    let [mut va, mut wa, mut vb, mut wb] = load::<L, W>(v, w, &ab);
    let (head, (ma, mb)) = (pr.head, pr.head.im::<L>(half));
    for (i, q) in pr.rows.iter().enumerate() {
        let z = L::gather3(|l| &impulse[pts[l][i]]);
        let lin = head
            .dir(0, half)
            .scale(z[0])
            .add(head.dir(1, half).scale(z[1]))
            .add(head.dir(2, half).scale(z[2]));
        va = va.sub(lin.scale(ma));
        wa = wa.sub(q.inv_sum(&z, 0, half));
        vb = vb.add(lin.scale(mb));
        wb = wb.add(q.inv_sum(&z, 1, half));
    }
    store(v, w, &ab, [va, wa, vb, wb], rows.fixed);
    true
}

/// The columns `R₀, R₁, R₂` of lane `l`'s rotation `m[l]`, gathered once per group
/// of manifolds (gathered inside the point loop, they were reloaded per point).
#[inline(always)]
fn columns<L: Lane, const W: usize>(m: [&DMat3; W]) -> [Lanes3<L>; 3] {
    [
        Lanes3::of(|l| m[l].x_axis),
        Lanes3::of(|l| m[l].y_axis),
        Lanes3::of(|l| m[l].z_axis),
    ]
}

/// `R r` per lane from `R`'s columns ([`columns`]), summed as `DMat3::mul_vec3`
/// does: `((R₀ r_x) + (R₁ r_y)) + (R₂ r_z)`.
#[inline(always)]
fn rotate<L: Lane>([x, y, z]: &[Lanes3<L>; 3], r: Lanes3<L>) -> Lanes3<L> {
    x.scale(r.x).add(y.scale(r.y)).add(z.scale(r.z))
}

/// The gaps `C₀ + nᵀ Δd` of the points of two manifolds with as many points, one
/// manifold per lane, their points in order (`ab[l]`: lane `l`'s two bodies, their
/// displacements `(Δx, ΔR)` in `dp`, `rot`), `Δd = (Δx_b + ΔR_b r_b) − (Δx_a + ΔR_a
/// r_a)`: the scalar arithmetic of `update_gaps` per lane in the same order (the same
/// bits). `shared`: where the manifolds are a packed pair, their packed rows and lane
/// half ([`Paired::shared`]), whose normals are every point's (the same bits): the
/// normals loaded once and the anchors point by point, instead of gathered per
/// point. Returns false, having written nothing, where the point counts differ.
#[inline(always)]
pub(super) fn manifold_gaps(
    rows: &Rows,
    pts: [&[usize]; 2],
    shared: Option<Normals>,
    ab: [[usize; 2]; 2],
    disp: (&[DVec3], &[DMat3]),
    gap: &mut [f64],
) -> bool {
    gaps_lanes::<f64x2, 2>(rows, pts, shared, ab, disp, gap)
}

/// The shared rows and the points' rows of a packed pair or quad of manifolds and the
/// half of their lanes a pair takes (0 for a quad), where the gap pass takes exactly
/// those manifolds ([`manifold_gaps`]).
pub(super) type Normals<'a> = (&'a HeadRows, &'a [QuadRows], usize);

/// [`manifold_gaps`] on `W` manifolds with as many points in the `W` lanes of `L`.
#[inline(always)]
fn gaps_lanes<L: Lane, const W: usize>(
    rows: &Rows,
    pts: [&[usize]; W],
    shared: Option<Normals>,
    ab: [[usize; 2]; W],
    (dp, rot): (&[DVec3], &[DMat3]),
    gap: &mut [f64],
) -> bool {
    let len = pts[0].len();
    if pts.iter().any(|m| m.len() != len) {
        return false;
    }
    // One length for every slice indexed by a point (one bounds check per index).
    let n = gap.len();
    let (Some(anchor), Some(dir), Some(base_gap)) = (
        rows.anchor.get(..n),
        rows.dir.get(..n),
        rows.base_gap.get(..n),
    ) else {
        return false;
    };
    let xa = Lanes3::<L>::of(|l| dp[ab[l][0]]);
    let xb = Lanes3::<L>::of(|l| dp[ab[l][1]]);
    let ra_m = columns::<L, W>(each_ref(|l| &rot[ab[l][0]]));
    let rb_m = columns::<L, W>(each_ref(|l| &rot[ab[l][1]]));
    let shared = shared
        .and_then(|(head, rows, half)| Some((head.dir::<L>(0, half), rows.get(..len)?, half)));
    for i in 0..len {
        let p: [usize; W] = each(|l| pts[l][i]);
        let (ra, rb, nrm, base) = match shared {
            Some((n, rows, half)) => {
                let [ra, rb] = rows[i].anchors(half);
                (ra, rb, n, rows[i].base::<L>(half))
            }
            None => (
                Lanes3::<L>::of(|l| anchor[p[l]][0]),
                Lanes3::<L>::of(|l| anchor[p[l]][1]),
                Lanes3::<L>::of(|l| dir[p[l]][0]),
                L::gather(|l| [base_gap[p[l]]])[0],
            ),
        };
        let dd = xb.add(rotate(&rb_m, rb)).sub(xa.add(rotate(&ra_m, ra)));
        let g = base + nrm.dot(dd);
        for (l, &p) in p.iter().enumerate() {
            gap[p] = g.lane(l);
        }
    }
    true
}

/// `[f(0), …, f(W − 1)]` of references (as [`each`]).
#[inline(always)]
fn each_ref<'a, T, const W: usize>(f: impl FnMut(usize) -> &'a T) -> [&'a T; W] {
    core::array::from_fn(f)
}

#[cfg(test)]
#[cfg(feature = "std")]
mod tests {
    use super::Paired;
    use crate::rigid::{ContactSolver, ContactStats, ContactWorld};
    use crate::scenes::{box_stack, pyramid};
    use constraint_core::DVec3;

    std::thread_local! {
        /// Where set, this thread's steps take the two-lane passes only (as on a
        /// processor without AVX).
        pub(super) static TWO_LANES: core::cell::Cell<bool> = const { core::cell::Cell::new(false) };
    }

    /// Every body's pose and velocities after `steps` soft steps (3 sub-steps, h =
    /// 1/60) of `w`, as bits.
    pub(super) fn run(mut w: ContactWorld, steps: usize, two: bool) -> Vec<u64> {
        TWO_LANES.with(|t| t.set(two));
        w.settings.solver = ContactSolver::SoftStep { substeps: 3 };
        for _ in 0..steps {
            w.step(1.0 / 60.0).expect("the scene steps");
        }
        TWO_LANES.with(|t| t.set(false));
        let mut bits = Vec::new();
        for b in w.bodies() {
            let (x, q) = (b.pose.x, b.pose.q);
            for c in [x.x, x.y, x.z, q.x, q.y, q.z, q.w] {
                bits.push(c.to_bits());
            }
            for c in b.v.to_array().into_iter().chain(b.omega.to_array()) {
                bits.push(c.to_bits());
            }
        }
        bits
    }

    /// The four-lane (AVX) passes give the two-lane passes' bits (tolerance 0: every
    /// pose and velocity bit-equal after 60 steps; measured equal), on the 10-box
    /// stack (colours of five manifolds: a quad and a single each) and the 21-box
    /// pyramid. Where the processor has no AVX both runs take two lanes.
    #[test]
    fn four_lanes_match_two_lanes() {
        for scene in [box_stack(10), pyramid(6)] {
            let w = scene.expect("the scene builds");
            let (four, two) = (run(w.clone(), 60, false), run(w, 60, true));
            assert_eq!(four, two);
        }
    }

    /// Every body's pose and velocities after one soft step (3 sub-steps, h = 1/60)
    /// on the contacts already in `w` (packed or, with `no_pack`, none packed: the
    /// colouring is the last step's, so the step keeps the emptied plan), as bits,
    /// and how many groups the step unpacked for normals not shared.
    fn step_on_contacts(mut w: ContactWorld, no_pack: bool) -> (Vec<u64>, usize) {
        if let (true, Some(st)) = (no_pack, w.soft.as_mut()) {
            st.paired = Paired::default();
        }
        let _ = w.soft_with_contacts(1.0 / 60.0, 3, ContactStats::default());
        let unshared = w.soft.as_ref().map_or(0, |st| st.paired.unshared());
        (run(w, 0, false), unshared)
    }

    /// With restitution (the only reader of the largest normal impulses, which the
    /// lane passes keep only then) a packed step gives the bits of a step with
    /// nothing packed, whose one-point passes keep them always (tolerance 0: every
    /// pose and velocity bit-equal; measured equal), on a step where the boxes hit
    /// at 2 m/s; and restitution acted (the step differs from one without it). The
    /// 10-box stack and the 21-box pyramid, after 10 steps.
    #[test]
    fn restitution_in_lanes_matches_one_point() {
        for scene in [box_stack(10), pyramid(6)] {
            let mut w = scene.expect("the scene builds");
            w.settings.solver = ContactSolver::SoftStep { substeps: 3 };
            for c in &mut w.colliders {
                c.restitution = 0.5;
            }
            for _ in 0..10 {
                w.step(1.0 / 60.0).expect("the scene steps");
            }
            for b in w.bodies_mut() {
                b.v.z -= 2.0;
            }
            let mut dead = w.clone();
            for c in &mut dead.colliders {
                c.restitution = 0.0;
            }
            let (packed, _) = step_on_contacts(w.clone(), false);
            let (none, _) = step_on_contacts(w, true);
            let (inelastic, _) = step_on_contacts(dead, false);
            assert_eq!(packed, none);
            assert_ne!(packed, inelastic);
        }
    }

    /// With the block normal solve off, the biased pass point by point in lanes
    /// ([`super::biased_manifolds`]) gives the bits of a step with nothing packed (one
    /// point at a time; tolerance 0: every pose and velocity bit-equal, measured
    /// equal) at rest after 10 steps, and on a step where the boxes fly apart (each
    /// box's upward velocity 0.5/s times its height: points separate, and the lanes
    /// decline their manifolds, solved one point at a time: measured 16 → 88 such
    /// point solves over the step's passes on the stack, 0 → 288 on the pyramid); and
    /// four lanes give two lanes' bits over 60 steps. The 10-box stack and the 21-box
    /// pyramid.
    #[test]
    fn biased_points_in_lanes_match_one_point() {
        for scene in [box_stack(10), pyramid(6)] {
            let mut w = scene.expect("the scene builds");
            w.settings.solver = ContactSolver::SoftStep { substeps: 3 };
            w.settings.soft_step.block_normal = false;
            let (four, two) = (run(w.clone(), 60, false), run(w.clone(), 60, true));
            assert_eq!(four, two);
            for _ in 0..10 {
                w.step(1.0 / 60.0).expect("the scene steps");
            }
            let singles = |w: &ContactWorld| w.soft.as_ref().map_or(0, |st| st.one_point);
            let mut rest = w.clone();
            let _ = rest.soft_with_contacts(1.0 / 60.0, 3, ContactStats::default());
            let (packed, _) = step_on_contacts(w.clone(), false);
            let (none, _) = step_on_contacts(w.clone(), true);
            assert_eq!(packed, none);
            for b in w.bodies_mut() {
                b.v.z += 0.5 * b.pose.x.z;
            }
            let mut apart = w.clone();
            let _ = apart.soft_with_contacts(1.0 / 60.0, 3, ContactStats::default());
            assert!(
                singles(&apart) > singles(&rest),
                "{} {}",
                singles(&rest),
                singles(&apart)
            );
            let (packed, _) = step_on_contacts(w.clone(), false);
            let (none, _) = step_on_contacts(w, true);
            assert_eq!(packed, none);
        }
    }

    /// A manifold whose points do not share their normal's bits (here every second
    /// contact's normal tilted by about 1e-6 rad) has its group unpacked for the step,
    /// and the step gives the bits of a step with nothing packed (tolerance 0: every
    /// pose and velocity bit-equal; measured equal); with the normals as found
    /// nothing is unpacked. The 10-box stack and the 21-box pyramid, after 5 steps.
    #[test]
    fn unshared_normals_unpack_their_group() {
        for scene in [box_stack(10), pyramid(6)] {
            let mut w = scene.expect("the scene builds");
            w.settings.solver = ContactSolver::SoftStep { substeps: 3 };
            for _ in 0..5 {
                w.step(1.0 / 60.0).expect("the scene steps");
            }
            let (_, unshared) = step_on_contacts(w.clone(), false);
            assert_eq!(unshared, 0);
            for (k, c) in w.contacts.iter_mut().enumerate() {
                if k % 2 == 1 {
                    c.normal = (c.normal + DVec3::new(1e-6, 0.0, 0.0)).normalize();
                }
            }
            let (packed, unshared) = step_on_contacts(w.clone(), false);
            let (none, _) = step_on_contacts(w, true);
            assert_eq!(packed, none);
            assert!(unshared > 0, "{unshared} groups unpacked");
        }
    }
}
