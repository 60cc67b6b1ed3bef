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

use core::arch::x86_64::{
    __m256d, _mm256_add_pd, _mm256_cmp_pd, _mm256_div_pd, _mm256_loadu_pd, _mm256_max_pd,
    _mm256_min_pd, _mm256_movemask_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_set_pd,
    _mm256_setzero_pd, _mm256_storeu_pd, _mm256_sub_pd, _mm256_xor_pd, _CMP_GE_OQ,
};
use core::ops::{Add, Div, Mul, Neg, Sub};

use super::{
    block_lanes, build_lanes, gaps_lanes, relax_lanes, warm_lanes, Built, Lane, Quad, QuadRows,
    RelaxIo,
};
use crate::rigid::soft_step::{Block, Pass, Rows};
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
/// `#[target_feature(enable = "avx")]` functions below, which run only where
/// [`available`] is true: every value of this type exists on a processor with AVX.
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
    fn all_nonneg(self) -> bool {
        let ge = avx!(_mm256_cmp_pd::<_CMP_GE_OQ>(self.0, _mm256_setzero_pd()));
        avx!(_mm256_movemask_pd(ge)) == 0b1111
    }
    #[inline(always)]
    fn load(q: &Quad, _half: usize) -> Self {
        // `q` is 32 contiguous bytes (two `f64x2`), read as one unaligned load.
        F4(avx!(_mm256_loadu_pd(q.as_ptr().cast::<f64>())))
    }
}

/// The relax pass over the quad of manifolds `pts` (one per lane; `pr`: their rows,
/// [`Paired::quad`](super::Paired::quad), `Some` only where AVX was found), as
/// [`relax_manifolds`](super::relax_manifolds) on its two pairs. Returns false, having
/// changed nothing, where it does not apply (the caller then takes the two pairs).
#[inline]
pub(in crate::rigid) fn relax_quad(
    rows: &Rows,
    pr: Option<&[QuadRows]>,
    pts: [&[usize]; 4],
    io: &mut RelaxIo,
    inv_h: f64,
) -> bool {
    let Some(pr) = pr else {
        return false;
    };
    // SAFETY: `Paired::quad` gives rows only where `available()` found AVX.
    unsafe { relax_avx(rows, pr, pts, io, inv_h) }
}

/// [`relax_lanes`](super::relax_lanes) in four AVX lanes.
///
/// # Safety
///
/// The processor has AVX ([`available`]).
#[target_feature(enable = "avx")]
unsafe fn relax_avx(
    rows: &Rows,
    pr: &[QuadRows],
    pts: [&[usize]; 4],
    io: &mut RelaxIo,
    inv_h: f64,
) -> bool {
    relax_lanes::<F4, 4>(rows, pr, 0, pts, io, inv_h)
}

/// The warm start of the quad of manifolds `pts` (as [`relax_quad`]), as
/// [`warm_manifolds`](super::warm_manifolds) on its two pairs.
#[inline]
pub(in crate::rigid) fn warm_quad(
    rows: &Rows,
    pr: Option<&[QuadRows]>,
    pts: [&[usize]; 4],
    v: &mut [DVec3],
    w: &mut [DVec3],
    impulse: &[[f64; 3]],
) -> bool {
    let Some(pr) = pr else {
        return false;
    };
    // SAFETY: `Paired::quad` gives rows only where `available()` found AVX.
    unsafe { warm_avx(rows, pr, pts, v, w, impulse) }
}

/// [`warm_lanes`](super::warm_lanes) in four AVX lanes.
///
/// # Safety
///
/// The processor has AVX ([`available`]).
#[target_feature(enable = "avx")]
unsafe fn warm_avx(
    rows: &Rows,
    pr: &[QuadRows],
    pts: [&[usize]; 4],
    v: &mut [DVec3],
    w: &mut [DVec3],
    impulse: &[[f64; 3]],
) -> bool {
    warm_lanes::<F4, 4>(rows, pr, 0, pts, v, w, impulse)
}

/// The biased pass's block solve of the quad of manifolds `blk` (as [`relax_quad`]),
/// as [`block_pair`](super::block_pair) on its two pairs: false, having changed
/// nothing, where either would decline.
#[inline]
pub(in crate::rigid) fn block_quad(
    rows: &Rows,
    pr: Option<&[QuadRows]>,
    blk: [&Block; 4],
    io: &mut RelaxIo,
    pass: Pass,
) -> bool {
    let Some(pr) = pr else {
        return false;
    };
    // SAFETY: `Paired::quad` gives rows only where `available()` found AVX.
    unsafe { block_avx(rows, pr, blk, io, pass) }
}

/// [`block_lanes`](super::block_lanes) in four AVX lanes.
///
/// # Safety
///
/// The processor has AVX ([`available`]).
#[target_feature(enable = "avx")]
unsafe fn block_avx(
    rows: &Rows,
    pr: &[QuadRows],
    blk: [&Block; 4],
    io: &mut RelaxIo,
    pass: Pass,
) -> bool {
    block_lanes::<F4, 4>(rows, pr, 0, blk, io, pass)
}

/// The gaps of four manifolds with as many points (one per lane), as
/// [`manifold_gaps`](super::manifold_gaps) on two pairs: false, having written
/// nothing, where the point counts differ.
#[inline]
pub(in crate::rigid) fn gaps_quad(
    _: Avx,
    rows: &Rows,
    pts: [&[usize]; 4],
    ab: [[usize; 2]; 4],
    disp: (&[DVec3], &[DMat3]),
    gap: &mut [f64],
) -> bool {
    // SAFETY: an `Avx` exists only where `available()` found AVX.
    unsafe { gaps_avx(rows, pts, ab, disp, gap) }
}

/// [`gaps_lanes`](super::gaps_lanes) in four AVX lanes.
///
/// # Safety
///
/// The processor has AVX ([`available`]).
#[target_feature(enable = "avx")]
unsafe fn gaps_avx(
    rows: &Rows,
    pts: [&[usize]; 4],
    ab: [[usize; 2]; 4],
    disp: (&[DVec3], &[DMat3]),
    gap: &mut [f64],
) -> bool {
    gaps_lanes::<F4, 4>(rows, pts, ab, disp, gap)
}

/// The blocks of four manifolds of `BLOCK_POINTS` points (one per lane), as
/// [`build_lanes`](super::build_lanes) on two pairs.
#[inline]
pub(in crate::rigid) fn build_quad(
    _: Avx,
    rows: &Rows,
    pts: [&[usize]; 4],
    blk: [&mut Block; 4],
) -> Built {
    // SAFETY: an `Avx` exists only where `available()` found AVX.
    unsafe { build_avx(rows, pts, blk) }
}

/// [`build_lanes`](super::build_lanes) in four AVX lanes.
///
/// # Safety
///
/// The processor has AVX ([`available`]).
#[target_feature(enable = "avx")]
unsafe fn build_avx(rows: &Rows, pts: [&[usize]; 4], blk: [&mut Block; 4]) -> Built {
    build_lanes::<F4, 4>(rows, pts, blk)
}
