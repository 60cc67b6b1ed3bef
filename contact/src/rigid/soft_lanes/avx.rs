//! Four lanes of one 256-bit AVX register (`__m256d`) for the soft step's passes:
//! four manifolds of a colour per operation where the two-lane passes take two.
//!
//! An AVX lane rounds as an SSE2 lane and as a scalar operation does (IEEE-754
//! round-to-nearest per operation; only `VADDPD VSUBPD VMULPD VDIVPD VMAXPD VMINPD VXORPD`,
//! never a fused multiply-add), so the four-lane passes give the two-lane passes'
//! bits. The passes are compiled for AVX (`#[target_feature(enable = "avx")]`), and
//! run only where [`available`] found it on this processor, once per step
//! (`Paired::plan`); without `std` they are compiled only with
//! `-C target-feature=+avx` (then always taken).
//!
//! Each pass is compiled twice (`passes!`): for AVX, and for AVX with AVX-512F and
//! AVX-512VL, taken where [`wide()`] finds those. The second runs the same 256-bit
//! operations in the same order (EVEX-encoded where it names a register above
//! `ymm15`; the same IEEE-754 rounding, and still no fused multiply-add: the lane
//! operations are the intrinsics above, never contracted) but on AVX-512VL's 32
//! vector registers instead of AVX's 16, so that the relax pass keeps its twelve
//! velocity vectors and its rows in registers. 256-bit stack stores / stack operand
//! reads of the AVX → AVX-512VL builds (`objdump -d` of `soft_points`): relax 45/58
//! → 0/0, warm 15/15 → 2/2, block 130/80 → 52/15, gaps 28/28 → 5/5 (lane stores),
//! build 94/164 → 39/90 (its `K` and `K⁻¹` are 32 vectors).
//!
//! The preparation's per-point loop ([`fill_points`]) is compiled the same two ways,
//! from the same Rust as its baseline build (two-lane `f64x2` and scalar operations:
//! no intrinsics, no contraction, the same bits). Its stack stores / stack operand
//! reads of vector registers, AVX → AVX-512VL: 92/85 → 76/68 (what stays is mostly
//! the loop's many array pointers, general-purpose registers, and their neighbours).
//! Callgrind (the AVX build; valgrind hides AVX-512): `soft_points pyramid20` a step
//! 5.094M → 4.952M instructions; wall, AVX-512 build, a 0.989 median ratio (61
//! alternating runs of 600 steps on 2 loaded cores, quartiles 0.965–1.013).

use core::arch::x86_64::{
    __m256d, _mm256_add_pd, _mm256_castpd128_pd256, _mm256_castpd256_pd128, _mm256_cmp_pd,
    _mm256_div_pd, _mm256_extractf128_pd, _mm256_insertf128_pd, _mm256_loadu_pd, _mm256_max_pd,
    _mm256_min_pd, _mm256_movemask_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_set_pd,
    _mm256_setzero_pd, _mm256_storeu_pd, _mm256_sub_pd, _mm256_unpackhi_pd, _mm256_unpacklo_pd,
    _mm256_xor_pd, _mm_loadu_pd, _mm_storeu_pd, _CMP_GE_OQ, _CMP_GT_OQ,
};
use core::ops::{Add, Div, Mul, Neg, Sub};

use super::{
    block_lanes, build_lanes, gaps_lanes, relax_lanes, warm_lanes, Built, Lane, Normals, Pack,
    Quad, RelaxIo,
};
use crate::rigid::soft_step::{Block, Pass, PointConsts, Rows, SoftState};
use crate::rigid::ContactWorld;
use constraint_core::{DMat3, DVec3};

/// Whether this processor has AVX (the one gate of every `unsafe` below).
#[inline]
pub(super) fn available() -> bool {
    #[cfg(target_feature = "avx")]
    {
        true
    }
    #[cfg(all(not(target_feature = "avx"), feature = "std"))]
    {
        std::is_x86_feature_detected!("avx")
    }
}

/// Whether this processor has AVX-512F and AVX-512VL too, where the passes take
/// their builds for those (`passes!`; the same bits either way).
#[inline]
fn wide() -> bool {
    #[cfg(all(test, feature = "std"))]
    if tests::NARROW.with(core::cell::Cell::get) {
        return false;
    }
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    {
        true
    }
    #[cfg(all(
        not(all(target_feature = "avx512f", target_feature = "avx512vl")),
        feature = "std"
    ))]
    {
        use core::sync::atomic::{AtomicU8, Ordering::Relaxed};
        /// 0 before the first look, then 1 (no) or 2 (yes): one load per pass instead
        /// of two feature tests.
        static WIDE: AtomicU8 = AtomicU8::new(0);
        match WIDE.load(Relaxed) {
            0 => {
                let wide = std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512vl");
                WIDE.store(if wide { 2 } else { 1 }, Relaxed);
                wide
            }
            w => w == 2,
        }
    }
    #[cfg(all(
        not(all(target_feature = "avx512f", target_feature = "avx512vl")),
        not(feature = "std")
    ))]
    {
        false
    }
}

/// Proof that this processor has AVX: made only by [`Avx::detect`], where
/// [`available`] found it (the passes that take one run the AVX code unchecked).
#[derive(Clone, Copy, Debug)]
pub(in crate::rigid) struct Avx(());

impl Avx {
    /// `Some` where this processor has AVX ([`available`]).
    #[inline]
    pub(in crate::rigid) fn detect() -> Option<Self> {
        available().then_some(Avx(()))
    }
}

/// Four `f64` lanes. Private to this module and made only inside the
/// `#[target_feature]` functions below, which enable AVX (AVX-512F implies it) and
/// run only where [`available`] is true: every value of this type exists on a
/// processor with AVX.
#[derive(Clone, Copy, Debug)]
struct F4(__m256d);

/// Every operation below: SAFETY: an `F4` exists only on a processor with AVX (see
/// [`F4`]), the one precondition of these intrinsics.
macro_rules! avx {
    ($e:expr) => {
        // SAFETY: AVX is present wherever an `F4` exists (see `F4`).
        unsafe { $e }
    };
}

impl Add for F4 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        F4(avx!(_mm256_add_pd(self.0, o.0)))
    }
}

impl Sub for F4 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        F4(avx!(_mm256_sub_pd(self.0, o.0)))
    }
}

impl Mul for F4 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        F4(avx!(_mm256_mul_pd(self.0, o.0)))
    }
}

impl Div for F4 {
    type Output = Self;
    /// `VDIVPD`: IEEE-754 division per lane, rounded as the scalar `DIVSD`.
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        F4(avx!(_mm256_div_pd(self.0, o.0)))
    }
}

impl Neg for F4 {
    type Output = Self;
    /// The sign bit flipped (as `wide::f64x2`'s negation: `−0` from `0`).
    #[inline(always)]
    fn neg(self) -> Self {
        F4(avx!(_mm256_xor_pd(self.0, _mm256_set1_pd(-0.0))))
    }
}

impl Lane for F4 {
    const LANES: usize = 4;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        F4(avx!(_mm256_set1_pd(x)))
    }
    #[inline(always)]
    fn gather<const K: usize>(mut f: impl FnMut(usize) -> [f64; K]) -> [Self; K] {
        let (a, b, c, d) = (f(0), f(1), f(2), f(3));
        let mut out = [F4(avx!(_mm256_setzero_pd())); K];
        for (k, o) in out.iter_mut().enumerate() {
            *o = F4(avx!(_mm256_set_pd(d[k], c[k], b[k], a[k])));
        }
        out
    }
    /// `x, y` of the four lanes as two 128-bit loads inserted into each half of two
    /// registers (`[a₀ a₁ c₀ c₁]`, `[b₀ b₁ d₀ d₁]`) and unpacked (`[a₀ b₀ c₀ d₀]`,
    /// `[a₁ b₁ c₁ d₁]`); `z` as `gather` sets it. Moves only: the same lanes.
    #[inline(always)]
    fn gather3<'a>(mut f: impl FnMut(usize) -> &'a [f64; 3]) -> [Self; 3] {
        let (a, b, c, d) = (f(0), f(1), f(2), f(3));
        // SAFETY: AVX is present (see `F4`); each array holds three `f64`, of which
        // the loads read the first two. (No closure: one would be left out of line.)
        let (ac, bd) = unsafe {
            let (a, b) = (_mm_loadu_pd(a.as_ptr()), _mm_loadu_pd(b.as_ptr()));
            let (c, d) = (_mm_loadu_pd(c.as_ptr()), _mm_loadu_pd(d.as_ptr()));
            (
                _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(a), c),
                _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(b), d),
            )
        };
        [
            F4(avx!(_mm256_unpacklo_pd(ac, bd))),
            F4(avx!(_mm256_unpackhi_pd(ac, bd))),
            F4(avx!(_mm256_set_pd(d[2], c[2], b[2], a[2]))),
        ]
    }
    /// `x, y` of the four lanes unpacked (`[a₀ a₁ c₀ c₁]`, `[b₀ b₁ d₀ d₁]`) and each
    /// lane's pair stored as one 128-bit store, then its `z`. Moves only.
    #[inline(always)]
    fn scatter3(v: [Self; 3], out: &mut [[f64; 3]], mut at: impl FnMut(usize) -> usize) {
        let [x, y, z] = v;
        // SAFETY: AVX is present (see `F4`).
        let xy = unsafe {
            let (ac, bd) = (_mm256_unpacklo_pd(x.0, y.0), _mm256_unpackhi_pd(x.0, y.0));
            [
                _mm256_castpd256_pd128(ac),
                _mm256_castpd256_pd128(bd),
                _mm256_extractf128_pd::<1>(ac),
                _mm256_extractf128_pd::<1>(bd),
            ]
        };
        for (l, (xy, z)) in xy.into_iter().zip(z.array()).enumerate() {
            let o = &mut out[at(l)];
            // SAFETY: AVX is present; `o` holds three `f64`, of which the store
            // writes the first two.
            unsafe { _mm_storeu_pd(o.as_mut_ptr(), xy) };
            o[2] = z;
        }
    }
    #[inline(always)]
    fn lane(self, l: usize) -> f64 {
        let mut x = [0.0; 4];
        // The four lanes stored into `x` (unaligned 256-bit store into 32 bytes).
        avx!(_mm256_storeu_pd(x.as_mut_ptr(), self.0));
        x[l]
    }
    #[inline(always)]
    fn array(self) -> [f64; 4] {
        let mut x = [0.0; 4];
        // The four lanes stored into `x` (unaligned 256-bit store into 32 bytes).
        avx!(_mm256_storeu_pd(x.as_mut_ptr(), self.0));
        x
    }
    /// `VMAXPD`: `x` if `x > lo`, else `lo` (NaN and signed zeros as the scalar).
    #[inline(always)]
    fn at_least(self, lo: Self) -> Self {
        F4(avx!(_mm256_max_pd(self.0, lo.0)))
    }
    /// `VMINPD`: `x` if `x < hi`, else `hi`.
    #[inline(always)]
    fn at_most(self, hi: Self) -> Self {
        F4(avx!(_mm256_min_pd(self.0, hi.0)))
    }
    #[inline(always)]
    fn positive_mask(self) -> u32 {
        let gt = avx!(_mm256_cmp_pd::<_CMP_GT_OQ>(self.0, _mm256_setzero_pd()));
        avx!(_mm256_movemask_pd(gt)) as u32
    }
    #[inline(always)]
    fn nonneg_mask(self) -> u32 {
        let ge = avx!(_mm256_cmp_pd::<_CMP_GE_OQ>(self.0, _mm256_setzero_pd()));
        avx!(_mm256_movemask_pd(ge)) as u32
    }
    #[inline(always)]
    fn load(q: &Quad, _half: usize) -> Self {
        // `q` is 32 contiguous bytes (two `f64x2`), read as one unaligned load.
        F4(avx!(_mm256_loadu_pd(q.as_ptr().cast::<f64>())))
    }
}

/// Each pass twice: `$avx` compiled for AVX, `$wide` for AVX with AVX-512F and
/// AVX-512VL (the same four-lane operations on 32 vector registers: see the module's
/// documentation), both `unsafe`, calling `$body` (a lane pass on `F4`).
macro_rules! passes {
    ($(
        $(#[$doc:meta])*
        fn $avx:ident / $wide:ident ($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty = $body:expr;
    )*) => {$(
        $(#[$doc])*
        ///
        /// # Safety
        ///
        /// The processor has AVX ([`available`]).
        #[target_feature(enable = "avx")]
        unsafe fn $avx($($arg: $ty),*) -> $ret {
            $body
        }

        $(#[$doc])*
        /// Built for AVX-512F and AVX-512VL (the same bits).
        ///
        /// # Safety
        ///
        /// The processor has AVX, AVX-512F and AVX-512VL ([`available`], [`wide()`]).
        #[target_feature(enable = "avx,avx512f,avx512vl")]
        unsafe fn $wide($($arg: $ty),*) -> $ret {
            let out = $body;
            // `ymm16`–`ymm31` zeroed before returning: `VZEROUPPER` (which the compiler
            // puts before the return) clears only the upper halves of `ymm0`–`ymm15`,
            // and Intel's optimisation manual has upper halves left dirty slow the
            // caller's SSE code (its effect here was within this machine's noise:
            // `ab_time.sh` pyramid20 without / with the zeroing 1.011 median).
            // SAFETY: writes only the registers it names (declared clobbered), on a
            // processor with AVX-512F (this function's precondition).
            unsafe {
                core::arch::asm!(
                    "vpxord xmm16, xmm16, xmm16",
                    "vpxord xmm17, xmm17, xmm17",
                    "vpxord xmm18, xmm18, xmm18",
                    "vpxord xmm19, xmm19, xmm19",
                    "vpxord xmm20, xmm20, xmm20",
                    "vpxord xmm21, xmm21, xmm21",
                    "vpxord xmm22, xmm22, xmm22",
                    "vpxord xmm23, xmm23, xmm23",
                    "vpxord xmm24, xmm24, xmm24",
                    "vpxord xmm25, xmm25, xmm25",
                    "vpxord xmm26, xmm26, xmm26",
                    "vpxord xmm27, xmm27, xmm27",
                    "vpxord xmm28, xmm28, xmm28",
                    "vpxord xmm29, xmm29, xmm29",
                    "vpxord xmm30, xmm30, xmm30",
                    "vpxord xmm31, xmm31, xmm31",
                    out("zmm16") _, out("zmm17") _, out("zmm18") _, out("zmm19") _,
                    out("zmm20") _, out("zmm21") _, out("zmm22") _, out("zmm23") _,
                    out("zmm24") _, out("zmm25") _, out("zmm26") _, out("zmm27") _,
                    out("zmm28") _, out("zmm29") _, out("zmm30") _, out("zmm31") _,
                    options(nomem, nostack, preserves_flags),
                );
            }
            out
        }
    )*};
}

passes! {
    /// [`relax_lanes`] in four AVX lanes.
    fn relax_avx / relax_wide(
        rows: &Rows,
        pr: Pack,
        pts: [&[usize]; 4],
        io: &mut RelaxIo,
        inv_h: f64,
    ) -> bool = relax_lanes::<F4, 4, false>(rows, pr, 0, pts, io, inv_h, 0.0);

    /// [`biased_manifolds`](super::biased_manifolds)' lanes in four AVX lanes.
    fn biased_avx / biased_wide(
        rows: &Rows,
        pr: Pack,
        pts: [&[usize]; 4],
        io: &mut RelaxIo,
        inv_h: f64,
        max_push: f64,
    ) -> bool = relax_lanes::<F4, 4, true>(rows, pr, 0, pts, io, inv_h, max_push);

    /// [`warm_lanes`] in four AVX lanes.
    fn warm_avx / warm_wide(
        rows: &Rows,
        pr: Pack,
        pts: [&[usize]; 4],
        v: &mut [DVec3],
        w: &mut [DVec3],
        impulse: &[[f64; 3]],
    ) -> bool = warm_lanes::<F4, 4>(rows, pr, 0, pts, v, w, impulse);

    /// [`block_lanes`] in four AVX lanes.
    fn block_avx / block_wide(
        rows: &Rows,
        pr: Pack,
        blk: [&Block; 4],
        io: &mut RelaxIo,
        pass: Pass,
    ) -> Option<u32> = block_lanes::<F4, 4>(rows, pr, 0, blk, io, pass);

    /// [`gaps_lanes`] in four AVX lanes.
    fn gaps_avx / gaps_wide(
        rows: &Rows,
        pts: [&[usize]; 4],
        shared: Option<Normals>,
        ab: [[usize; 2]; 4],
        disp: (&[DVec3], &[DMat3]),
        gap: &mut [f64],
    ) -> bool = gaps_lanes::<F4, 4>(rows, pts, shared, ab, disp, gap);

    /// [`build_lanes`] in four AVX lanes.
    fn build_avx / build_wide(
        rows: &Rows,
        pr: Pack,
        pts: [&[usize]; 4],
        blk: [&mut Block; 4],
    ) -> Built = build_lanes::<F4, 4>(rows, pts, Some((pr, 0)), blk);

    /// The soft step preparation's per-point loop,
    /// [`ContactWorld::fill_points`]: the same Rust (no intrinsics; `f64x2` lanes
    /// and scalars), compiled for AVX (three-operand VEX forms) and AVX-512VL (32
    /// vector registers: its angular terms and effective masses without spills).
    fn points_avx / points_wide(
        world: &ContactWorld,
        st: &mut SoftState,
        k: &PointConsts,
    ) -> bool = world.fill_points(st, k);
}

// The passes' signatures: one call site per pass, its target chosen by [`wide()`].
/// `points_avx` or `points_wide`.
type PointsPass = unsafe fn(&ContactWorld, &mut SoftState, &PointConsts) -> bool;
/// `relax_avx` or `relax_wide`.
type RelaxPass = unsafe fn(&Rows, Pack, [&[usize]; 4], &mut RelaxIo, f64) -> bool;
/// `biased_avx` or `biased_wide`.
type BiasedPass = unsafe fn(&Rows, Pack, [&[usize]; 4], &mut RelaxIo, f64, f64) -> bool;
/// `warm_avx` or `warm_wide`.
type WarmPass =
    unsafe fn(&Rows, Pack, [&[usize]; 4], &mut [DVec3], &mut [DVec3], &[[f64; 3]]) -> bool;
/// `block_avx` or `block_wide`.
type BlockPass = unsafe fn(&Rows, Pack, [&Block; 4], &mut RelaxIo, Pass) -> Option<u32>;
/// `gaps_avx` or `gaps_wide`.
type GapsPass = unsafe fn(
    &Rows,
    [&[usize]; 4],
    Option<Normals>,
    [[usize; 2]; 4],
    (&[DVec3], &[DMat3]),
    &mut [f64],
) -> bool;
/// `build_avx` or `build_wide`.
type BuildPass = unsafe fn(&Rows, Pack, [&[usize]; 4], [&mut Block; 4]) -> Built;

/// The relax pass over the quad of manifolds `pts` (one per lane; `pr`: their rows,
/// [`Paired::quad`](super::Paired::quad), `Some` only where AVX was found), as
/// [`relax_manifolds`](super::relax_manifolds) on its two pairs. Returns false, having
/// changed nothing, where it does not apply (the caller then takes the two pairs).
#[inline]
pub(in crate::rigid) fn relax_quad(
    rows: &Rows,
    pr: Option<Pack>,
    pts: [&[usize]; 4],
    io: &mut RelaxIo,
    inv_h: f64,
) -> bool {
    let Some(pr) = pr else {
        return false;
    };
    // One call site, its target chosen (with two, one per build, the callers took
    // +16.2k instructions a step of the 210-box pyramid over the AVX-only code; with
    // one, +13.0k: callgrind, where valgrind hides AVX-512).
    let run: RelaxPass = if wide() { relax_wide } else { relax_avx };
    // SAFETY: `Paired::quad` gives rows only where `available()` found AVX; the wide
    // build only where `wide()` found AVX-512F and AVX-512VL too.
    unsafe { run(rows, pr, pts, io, inv_h) }
}

/// The biased pass point by point over the quad of manifolds `pts` (as
/// [`relax_quad`]), as [`biased_manifolds`](super::biased_manifolds) on its two pairs:
/// false, having changed nothing, where either would decline.
#[inline]
pub(in crate::rigid) fn biased_quad(
    rows: &Rows,
    pr: Option<Pack>,
    pts: [&[usize]; 4],
    io: &mut RelaxIo,
    pass: Pass,
) -> bool {
    let Some(pr) = pr else {
        return false;
    };
    if pass.anchors {
        return false;
    }
    let run: BiasedPass = if wide() { biased_wide } else { biased_avx };
    // SAFETY: as in `relax_quad`.
    unsafe { run(rows, pr, pts, io, pass.inv_h, pass.max_push) }
}

/// The warm start of the quad of manifolds `pts` (as [`relax_quad`]), as
/// [`warm_manifolds`](super::warm_manifolds) on its two pairs.
#[inline]
pub(in crate::rigid) fn warm_quad(
    rows: &Rows,
    pr: Option<Pack>,
    pts: [&[usize]; 4],
    v: &mut [DVec3],
    w: &mut [DVec3],
    impulse: &[[f64; 3]],
) -> bool {
    let Some(pr) = pr else {
        return false;
    };
    let run: WarmPass = if wide() { warm_wide } else { warm_avx };
    // SAFETY: as in `relax_quad`.
    unsafe { run(rows, pr, pts, v, w, impulse) }
}

/// The biased pass's block solve of the quad of manifolds `blk` (as [`relax_quad`]),
/// as [`block_pair`](super::block_pair) on its two pairs: `None`, having changed
/// nothing, where the lanes do not apply, else the manifolds left to the caller
/// (bit `l`: `blk[l]`), nothing of theirs changed.
#[inline]
pub(in crate::rigid) fn block_quad(
    rows: &Rows,
    pr: Option<Pack>,
    blk: [&Block; 4],
    io: &mut RelaxIo,
    pass: Pass,
) -> Option<u32> {
    let pr = pr?;
    let run: BlockPass = if wide() { block_wide } else { block_avx };
    // SAFETY: as in `relax_quad`.
    unsafe { run(rows, pr, blk, io, pass) }
}

/// The gaps of four manifolds with as many points (one per lane), as
/// [`manifold_gaps`](super::manifold_gaps) on two pairs (`shared`: where they are a
/// packed quad, its shared rows): false, having written nothing, where the point
/// counts differ.
#[inline]
pub(in crate::rigid) fn gaps_quad(
    _: Avx,
    rows: &Rows,
    pts: [&[usize]; 4],
    shared: Option<Normals>,
    ab: [[usize; 2]; 4],
    disp: (&[DVec3], &[DMat3]),
    gap: &mut [f64],
) -> bool {
    let run: GapsPass = if wide() { gaps_wide } else { gaps_avx };
    // SAFETY: an `Avx` exists only where `available()` found AVX; the wide build only
    // where `wide()` found AVX-512F and AVX-512VL too.
    unsafe { run(rows, pts, shared, ab, disp, gap) }
}

/// The blocks of four manifolds of `BLOCK_POINTS` points (one per lane; `pr`: their
/// packed rows, [`Paired::quad`](super::Paired::quad)), as
/// [`build_lanes`] on two pairs.
#[inline]
pub(in crate::rigid) fn build_quad(
    _: Avx,
    rows: &Rows,
    pr: Pack,
    pts: [&[usize]; 4],
    blk: [&mut Block; 4],
) -> Built {
    let run: BuildPass = if wide() { build_wide } else { build_avx };
    // SAFETY: as in `gaps_quad`.
    unsafe { run(rows, pr, pts, blk) }
}

/// The preparation's per-point loop ([`ContactWorld::fill_points`]) in its AVX or
/// AVX-512F/VL build where the processor has AVX: `Some` of its result, else `None`
/// (having done nothing; the caller runs the baseline build).
#[inline]
pub(in crate::rigid) fn fill_points(
    world: &ContactWorld,
    st: &mut SoftState,
    k: &PointConsts,
) -> Option<bool> {
    #[cfg(all(test, feature = "std"))]
    if tests::BASELINE.with(core::cell::Cell::get) {
        return None;
    }
    if !available() {
        return None;
    }
    let run: PointsPass = if wide() { points_wide } else { points_avx };
    // SAFETY: `available()` found AVX; the wide build only where `wide()` found
    // AVX-512F and AVX-512VL too.
    Some(unsafe { run(world, st, k) })
}

#[cfg(test)]
#[cfg(feature = "std")]
mod tests {
    use crate::rigid::ContactWorld;
    use crate::scenes::{box_stack, pyramid};

    std::thread_local! {
        /// Where set, this thread's four-lane passes take their AVX builds even where
        /// the processor has AVX-512F and AVX-512VL.
        pub(super) static NARROW: core::cell::Cell<bool> = const { core::cell::Cell::new(false) };
        /// Where set, this thread's preparation runs its per-point loop's baseline
        /// build (`fill_points` declines).
        pub(super) static BASELINE: core::cell::Cell<bool> = const { core::cell::Cell::new(false) };
    }

    /// Every body's pose and velocities after `steps` soft steps (3 sub-steps, h =
    /// 1/60) of `w`, as bits, the passes' builds chosen by `narrow` and `two` (as
    /// `NARROW` and `TWO_LANES`).
    fn run(w: ContactWorld, steps: usize, narrow: bool, two: bool) -> Vec<u64> {
        NARROW.with(|t| t.set(narrow));
        let bits = super::super::tests::run(w, steps, two);
        NARROW.with(|t| t.set(false));
        bits
    }

    /// The AVX-512VL builds of the four-lane passes give the AVX builds' bits and the
    /// two-lane passes' (tolerance 0: every pose and velocity bit-equal after 60
    /// steps; measured equal) on the 10-box stack and the 21-box pyramid. Where the
    /// processor has no AVX-512 the first two runs are the same build.
    #[test]
    fn wide_builds_match_avx_builds() {
        for scene in [box_stack(10), pyramid(6)] {
            let w = scene.expect("the scene builds");
            let wide = run(w.clone(), 60, false, false);
            let narrow = run(w.clone(), 60, true, false);
            let two = run(w, 60, false, true);
            assert_eq!(wide, narrow);
            assert_eq!(wide, two);
        }
    }

    /// The AVX and AVX-512F/VL builds of the preparation's per-point loop give the
    /// baseline build's bits (tolerance 0: every pose and velocity bit-equal after 60
    /// steps; measured equal) on the 10-box stack and the 21-box pyramid, with the
    /// four-lane passes in either build. Where the processor has no AVX-512 the wide
    /// and narrow runs are the same build.
    #[test]
    fn avx_preparation_matches_baseline_preparation() {
        for scene in [box_stack(10), pyramid(6)] {
            let w = scene.expect("the scene builds");
            let mut bits = Vec::new();
            for (narrow, baseline) in [(false, false), (true, false), (false, true), (true, true)] {
                BASELINE.with(|t| t.set(baseline));
                bits.push(run(w.clone(), 60, narrow, false));
                BASELINE.with(|t| t.set(false));
            }
            assert!(bits.iter().all(|b| *b == bits[0]));
        }
    }
}
