//! The soft step's relax pass two points at a time, one per SIMD lane (`wide::f64x2`;
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
//! Nothing is stored twice: each lane gathers its point's rows from the state's arrays
//! of structures (two loads per pair of values) and scatters the two bodies'
//! velocities back.

use constraint_core::DVec3;
use wide::f64x2;

use super::soft_step::Rows;

/// Two 3-vectors, one per lane.
#[derive(Clone, Copy)]
struct Lanes3 {
    x: f64x2,
    y: f64x2,
    z: f64x2,
}

impl Lanes3 {
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

/// Points `p` and `q` (of one colouring group: no shared moving body) in one relax
/// pass, one per lane: the rigid normal row (the speculative target `C/h` where
/// separated, else no bias: `Δλ = −m (J v + b)`, `λ ≥ 0`), then the two friction rows
/// bounded by `μ λ_n` (`|λ_t| ≤ μ λ_n`), as `solve_point` with `use_bias` false.
#[inline(always)]
pub(super) fn relax_pair(rows: &Rows, p: usize, q: usize, io: &mut RelaxIo, inv_h: f64) {
    let ([a0, b0], [a1, b1]) = (rows.slots[p], rows.slots[q]);
    let mut va = Lanes3::of(io.v[a0], io.v[a1]);
    let mut wa = Lanes3::of(io.w[a0], io.w[a1]);
    let mut vb = Lanes3::of(io.v[b0], io.v[b1]);
    let mut wb = Lanes3::of(io.w[b0], io.w[b1]);
    let (dp, dq) = (&rows.dir[p], &rows.dir[q]);
    let (gp, gq) = (&rows.ang[p], &rows.ang[q]);
    let (mp, mq) = (rows.mass[p], rows.mass[q]);
    let (ip, iq) = (rows.im[p], rows.im[q]);
    let (ma, mb) = (pair(ip[0], iq[0]), pair(ip[1], iq[1]));
    let (zp, zq) = (io.impulse[p], io.impulse[q]);
    // Speculative where separated: approach at most to the surface within the
    // sub-step; rigid (mass_scale 1, impulse_scale 0, no preload) either way.
    let spec = |gap: f64| if gap > 0.0 { gap * inv_h } else { 0.0 };
    let bias = pair(spec(io.gap[p]), spec(io.gap[q]));
    let (one, zero) = (f64x2::splat(1.0), f64x2::splat(0.0));
    let z0 = pair(zp[0], zq[0]);
    let d0 = Lanes3::of(dp[0], dq[0]);
    let vn = d0.dot(vb.sub(va)) + Lanes3::of(gp[0][1], gq[0][1]).dot(wb)
        - Lanes3::of(gp[0][0], gq[0][0]).dot(wa);
    let m0 = pair(mp[0], mq[0]);
    let new = at_least(z0 - m0 * one * (vn + bias) - zero * (z0 - zero), zero);
    let dz = new - z0;
    let max_normal = at_least(new, pair(io.max_normal[p], io.max_normal[q]));
    va = va.sub(d0.scale(ma * dz));
    wa = wa.sub(Lanes3::of(gp[0][2], gq[0][2]).scale(dz));
    vb = vb.add(d0.scale(mb * dz));
    wb = wb.add(Lanes3::of(gp[0][3], gq[0][3]).scale(dz));
    let bound = pair(rows.friction[p], rows.friction[q]) * new;
    let mut z = [new, zero, zero];
    for r in 1..3 {
        let d = Lanes3::of(dp[r], dq[r]);
        let zr = pair(zp[r], zq[r]);
        let vt = d.dot(vb.sub(va)) + Lanes3::of(gp[r][1], gq[r][1]).dot(wb)
            - Lanes3::of(gp[r][0], gq[r][0]).dot(wa);
        let unbounded = zr - pair(mp[r], mq[r]) * vt;
        let new = at_least(at_most(unbounded, bound), -bound);
        let dz = new - zr;
        z[r] = new;
        va = va.sub(d.scale(ma * dz));
        wa = wa.sub(Lanes3::of(gp[r][2], gq[r][2]).scale(dz));
        vb = vb.add(d.scale(mb * dz));
        wb = wb.add(Lanes3::of(gp[r][3], gq[r][3]).scale(dz));
    }
    for (lane, point) in [p, q].into_iter().enumerate() {
        io.impulse[point] = [
            z[0].as_array()[lane],
            z[1].as_array()[lane],
            z[2].as_array()[lane],
        ];
        io.max_normal[point] = max_normal.as_array()[lane];
    }
    // The static slot's inverse mass and inertia are zero: it stays at rest.
    for (lane, (a, b)) in [(a0, b0), (a1, b1)].into_iter().enumerate() {
        if a != rows.fixed {
            io.v[a] = va.lane(lane);
            io.w[a] = wa.lane(lane);
        }
        if b != rows.fixed {
            io.v[b] = vb.lane(lane);
            io.w[b] = wb.lane(lane);
        }
    }
}
