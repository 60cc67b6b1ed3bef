//! The rows the lane passes read, packed four lanes at a time and split by who reads
//! them, so that each pass streams only what it reads:
//!
//! - [`HeadRows`], once per group of manifolds (a packed pair, or a quad): what every
//!   point of a manifold shares, normal and tangents, the inverse masses and the
//!   friction coefficient (12 four-lane values);
//! - [`QuadRows`], once per place of the group's points: the inverse-inertia terms
//!   `I⁻¹(r × d)` first (the warm start reads only those of a point), the anchors
//!   `r_a`, `r_b` (the passes take `r × d` from them and the shared directions, as
//!   `prepare` does: the same bits) and the effective masses (27 values);
//! - [`BlockRows`], beside them: `K⁻¹` and `c` of the block normal solves (5 values),
//!   read by the biased pass alone.
//!
//! Before, one 56-value entry per place held all of them (1,792 B, the shared values
//! repeated at every point, `r × d` stored): the 210-box pyramid's passes streamed
//! about 717 KB of it a step. Computing `r × d` in the passes (six cross products a
//! place and pass) instead of loading it: `soft_points pyramid20` a step 4913.2k →
//! 5048.9k instructions, 178.9k → 162.8k D1 misses (cachegrind, the gap pass reading
//! the packed anchors too); stack10 136.6k → 141.3k instructions.

use alloc::vec::Vec;

use constraint_core::DVec3;
use wide::f64x2;

use super::{pair, Avx, Lane, Lanes3, Normals, Quad};
use crate::rigid::colouring::Colouring;
use crate::rigid::soft_step::BLOCK_POINTS;

/// Four lanes of a packed 3-vector.
#[derive(Clone, Copy, Debug)]
pub(in crate::rigid) struct Quad3 {
    x: Quad,
    y: Quad,
    z: Quad,
}

impl Quad3 {
    /// Sets lane `h, l` (half `h`, lane `l` of it) to `v`.
    #[inline(always)]
    fn set(&mut self, h: usize, l: usize, v: DVec3) {
        self.x[h].as_mut_array()[l] = v.x;
        self.y[h].as_mut_array()[l] = v.y;
        self.z[h].as_mut_array()[l] = v.z;
    }

    /// The lanes ([`Lane::load`]).
    #[inline(always)]
    pub(super) fn load<L: Lane>(&self, half: usize) -> Lanes3<L> {
        Lanes3 {
            x: L::load(&self.x, half),
            y: L::load(&self.y, half),
            z: L::load(&self.z, half),
        }
    }
}

/// What the points of one manifold share, the manifolds of a group side by side, one
/// per lane (written by `prepare` once a manifold, [`Paired::put_head`]). The
/// directions are shared only where every point of the manifold has the same normal
/// bits (then the same tangents: computed from them); where one does not, `prepare`
/// says so ([`Paired::unshare`]) and the group's manifolds are solved point by point
/// that step (the same bits either way). 32-byte aligned: every value's four lanes
/// are one aligned 256-bit load.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(in crate::rigid) struct HeadRows {
    /// Normal and tangents.
    dir: [Quad3; 3],
    /// Inverse masses of the two bodies as the rows see them.
    im: [Quad; 2],
    friction: Quad,
}

impl HeadRows {
    /// Direction `r` (normal, tangents) of the lanes ([`Lane::load`]).
    #[inline(always)]
    pub(super) fn dir<L: Lane>(&self, r: usize, half: usize) -> Lanes3<L> {
        self.dir[r].load(half)
    }

    /// The two bodies' inverse masses of the lanes.
    #[inline(always)]
    pub(super) fn im<L: Lane>(&self, half: usize) -> (L, L) {
        (L::load(&self.im[0], half), L::load(&self.im[1], half))
    }

    /// The friction coefficients of the lanes.
    #[inline(always)]
    pub(super) fn friction<L: Lane>(&self, half: usize) -> L {
        L::load(&self.friction, half)
    }
}

/// The rows of four points side by side, one per lane (written by `prepare` once per
/// step, so that the passes load the lanes of each value at once instead of
/// gathering them from four places). 32-byte aligned (see [`HeadRows`]).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(in crate::rigid) struct QuadRows {
    /// Per direction `I_a⁻¹(r_a × d)`, `I_b⁻¹(r_b × d)` (first and contiguous: all the
    /// warm start reads of a point).
    inv: [[Quad3; 2]; 3],
    /// The anchors `r_a`, `r_b` (from the bodies' centres): the passes take `r × d`
    /// from them as `prepare` does (six values where the three directions' `r_a ×
    /// d`, `r_b × d` took eighteen).
    anchor: [Quad3; 2],
    /// Effective masses of the three rows.
    mass: [Quad; 3],
    /// The normal row's preload, preload cap ratio and preload floor (the biased
    /// pass's per-step constants, gathered point by point each pass before).
    pre: [Quad; 3],
    /// The gap at the start of the step less `nᵀ(r_b − r_a)` (`base_gap`: the gap
    /// pass's per-step constant).
    base: Quad,
}

/// `r × d` per lane as `prepare`'s `angular_terms` (glam's `cross`): `(r_y d_z − d_y
/// r_z, r_z d_x − d_z r_x, r_x d_y − d_x r_y)`, the same operations (the same bits).
#[inline(always)]
fn cross<L: Lane>(r: Lanes3<L>, d: Lanes3<L>) -> Lanes3<L> {
    Lanes3 {
        x: r.y * d.z - d.y * r.z,
        y: r.z * d.x - d.z * r.x,
        z: r.x * d.y - d.x * r.y,
    }
}

impl QuadRows {
    /// Angular term `k` of direction `r` of the lanes, in the order `r_a × d`, `r_b ×
    /// d`, `I_a⁻¹(r_a × d)`, `I_b⁻¹(r_b × d)` (`k` a constant once inlined: no
    /// branch); `head`: the lanes' shared rows (their directions).
    #[inline(always)]
    pub(super) fn ang<L: Lane>(
        &self,
        head: &HeadRows,
        r: usize,
        k: usize,
        half: usize,
    ) -> Lanes3<L> {
        if k < 2 {
            cross(self.anchor[k].load(half), head.dir(r, half))
        } else {
            self.inv[r][k - 2].load(half)
        }
    }

    /// The anchors `r_a`, `r_b` of the lanes.
    #[inline(always)]
    pub(super) fn anchors<L: Lane>(&self, half: usize) -> [Lanes3<L>; 2] {
        [self.anchor[0].load(half), self.anchor[1].load(half)]
    }

    /// `Σ_r I⁻¹(r_k × d_r) λ_r` (`k` 0: body a, 1: body b), summed left to right (an
    /// angular part of `M⁻¹ Jᵀ λ`).
    #[inline(always)]
    pub(super) fn inv_sum<L: Lane>(&self, z: &[L; 3], k: usize, half: usize) -> Lanes3<L> {
        let inv = |r: usize| self.inv[r][k].load::<L>(half);
        inv(0)
            .scale(z[0])
            .add(inv(1).scale(z[1]))
            .add(inv(2).scale(z[2]))
    }

    /// The effective mass of row `r` of the lanes.
    #[inline(always)]
    pub(super) fn mass<L: Lane>(&self, r: usize, half: usize) -> L {
        L::load(&self.mass[r], half)
    }

    /// The preload, preload cap ratio and preload floor of the lanes.
    #[inline(always)]
    pub(super) fn pre<L: Lane>(&self, half: usize) -> [L; 3] {
        [
            L::load(&self.pre[0], half),
            L::load(&self.pre[1], half),
            L::load(&self.pre[2], half),
        ]
    }

    /// The base gaps of the lanes.
    #[inline(always)]
    pub(super) fn base<L: Lane>(&self, half: usize) -> L {
        L::load(&self.base, half)
    }
}

/// Of a block of [`BLOCK_POINTS`] points per lane (point `i` of the manifolds, beside
/// the `i`-th [`QuadRows`]): row `i` of `K⁻¹`, by column, and `c_i` (written by
/// `build_blocks` with the blocks, [`Paired::put_block`]; read by the biased pass
/// only where every lane's block was built this step).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(in crate::rigid) struct BlockRows {
    kinv: [Quad; BLOCK_POINTS],
    c: Quad,
}

impl BlockRows {
    /// Entry `col` of the lanes' row of `K⁻¹`.
    #[inline(always)]
    pub(super) fn kinv<L: Lane>(&self, col: usize, half: usize) -> L {
        L::load(&self.kinv[col], half)
    }

    /// The lanes' `c_i`.
    #[inline(always)]
    pub(super) fn c<L: Lane>(&self, half: usize) -> L {
        L::load(&self.c, half)
    }
}

/// A group's packed rows as the passes read them ([`Paired::of`], [`Paired::quad`]):
/// its shared rows, and its points' rows and blocks, place by place.
#[derive(Clone, Copy, Debug)]
pub(in crate::rigid) struct Pack<'a> {
    pub(super) head: &'a HeadRows,
    pub(super) rows: &'a [QuadRows],
    pub(super) blocks: &'a [BlockRows],
}

/// The rows packed four points at a time, per quad of manifolds: the manifolds of
/// each colour before the overflow colour (no shared moving body) taken two at a
/// time, `(j, j + 1)` from the colour's first, as the passes take them; where the two
/// have the same point count (at most [`BLOCK_POINTS`]) their points' rows side by
/// side, place by place (the passes read them in order: no lookup per point), in
/// lanes 0–1, and where the next pair `(j + 2, j + 3)` of the colour has that point
/// count too, its rows in lanes 2–3 of the same entries (a quad: the four-lane passes
/// take the four manifolds at once), the quad's next pair then starting at `j + 4`.
/// Each pair or quad is a group, with its shared rows in `heads` at its first entry's
/// index (the other indices unused and never read). Kept buffers: no allocation once
/// grown.
#[derive(Clone, Debug, Default)]
pub(in crate::rigid) struct Paired {
    heads: Vec<HeadRows>,
    rows: Vec<QuadRows>,
    blocks: Vec<BlockRows>,
    /// Of manifold pair `(j, j + 1)`, by `j` (colour order): `2 ×` where its rows
    /// start in `rows` `+` the half of the lanes they take (`u32::MAX` where `j`
    /// starts no packed pair).
    first: Vec<u32>,
    /// Whether manifold `j` starts a quad (pairs `(j, j + 1)` and `(j + 2, j + 3)` in
    /// the two halves of the same entries).
    quad: Vec<bool>,
    /// Of each point (solve position): `4 ×` its entry in `rows` `+` its lane
    /// (`u32::MAX` where it is not packed).
    lane_of: Vec<u32>,
    /// By a group's first entry: whether a manifold's points do not all share its
    /// normal this step ([`Paired::unshare`]): its manifolds are then not taken as
    /// packed.
    off: Vec<bool>,
    /// Where the passes take quads four lanes at a time (the processor has AVX:
    /// [`Avx::detect`], checked once per step by [`Paired::plan`]).
    avx: Option<Avx>,
}

/// One point's rows as `prepare` computes them (what [`Paired::put`] writes).
pub(in crate::rigid) struct PointRows {
    /// The anchors `r_a`, `r_b`.
    pub(in crate::rigid) anchor: [DVec3; 2],
    /// Per direction the lanes of `I⁻¹(r × d)` by axis (x, y, z), `I_a⁻¹(r_a × d)` in
    /// lane 0 and `I_b⁻¹(r_b × d)` in lane 1, as `prepare` computes them (stored from
    /// them lane by lane; the passes take `r × d` from the anchors).
    pub(in crate::rigid) inv: [[f64x2; 3]; 3],
    /// Effective masses.
    pub(in crate::rigid) mass: [f64; 3],
    /// Preload, preload cap ratio, preload floor.
    pub(in crate::rigid) pre: [f64; 3],
    /// Base gap.
    pub(in crate::rigid) base_gap: f64,
}

const ZERO_QUAD: Quad = [f64x2::ZERO; 2];
const ZERO_QUAD3: Quad3 = Quad3 {
    x: ZERO_QUAD,
    y: ZERO_QUAD,
    z: ZERO_QUAD,
};

/// Zeros (the entries `Paired::plan` sizes before `prepare` writes them).
const ZERO_HEAD: HeadRows = HeadRows {
    dir: [ZERO_QUAD3; 3],
    im: [ZERO_QUAD; 2],
    friction: ZERO_QUAD,
};
const ZERO_ROWS: QuadRows = QuadRows {
    inv: [[ZERO_QUAD3; 2]; 3],
    anchor: [ZERO_QUAD3; 2],
    mass: [ZERO_QUAD; 3],
    pre: [ZERO_QUAD; 3],
    base: ZERO_QUAD,
};
const ZERO_BLOCK: BlockRows = BlockRows {
    kinv: [ZERO_QUAD; BLOCK_POINTS],
    c: ZERO_QUAD,
};

/// Grows `v`'s capacity to at least `bound` (so that a step that packs more than any
/// before does not allocate), then sets its length to `len` with `zero`.
fn size<T: Clone>(v: &mut Vec<T>, bound: usize, len: usize, zero: T) {
    if v.capacity() < bound {
        v.reserve(bound - v.len());
    }
    v.resize(len, zero);
}

impl Paired {
    /// Pairs up the manifolds of `colouring` (pairs of pairs into quads where they
    /// have the same point count) and sizes the packed rows; `prepare` then writes
    /// each manifold's shared rows ([`Paired::put_head`]) and each point's rows
    /// ([`Paired::put`]) into their lanes as it computes them (packing them
    /// afterwards from the state's arrays read them back, 3 % of the 210-box
    /// pyramid's step).
    pub(in crate::rigid) fn plan(&mut self, colouring: &Colouring) {
        let (mp, pts) = (&colouring.manifold_start, &colouring.manifold_points);
        let manifolds = mp.len().saturating_sub(1);
        self.avx = super::four_lanes();
        self.first.clear();
        self.first.resize(manifolds, u32::MAX);
        self.quad.clear();
        self.quad.resize(manifolds, false);
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
                let manifold = |k: usize| &pts[mp[k]..mp[k + 1]];
                let len = manifold(j).len();
                // Past both where their point counts differ. Stepping by one instead
                // (the passes too), so that a pair may start at an odd place, packed
                // more of the 1000-box pile's manifolds but cost more: 25.58M → 25.89M
                // instructions a step (callgrind, `soft_points pile1000`, (I(300 3) −
                // I(200 3))/100; the 10-box stack and the pyramid unchanged).
                if len == 0 || len > BLOCK_POINTS || manifold(j + 1).len() != len {
                    j += 2;
                    continue;
                }
                let quad = j + 3 < hi && (2..4).all(|m| manifold(j + m).len() == len);
                let lanes = if quad { 4 } else { 2 };
                self.first[j] = 2 * count as u32;
                if quad {
                    self.first[j + 2] = 2 * count as u32 + 1;
                    self.quad[j] = true;
                }
                for m in 0..lanes {
                    for (i, &p) in manifold(j + m).iter().enumerate() {
                        if let Some(l) = self.lane_of.get_mut(p) {
                            *l = 4 * (count + i) as u32 + m as u32;
                        }
                    }
                }
                count += len;
                j += lanes;
            }
        }
        // Kept at least at their bounds (an entry holds two points or more; grown as `Vec` grows, doubling), so that a step that
        // packs more pairs than any before does not allocate: the 6-level pyramid's
        // colouring packed one more pair at step 70 with `preload_cap_margin` 4, and
        // `soft_step_allocations` saw it. Every entry is written by `put`, every
        // head by `put_head`, before the passes read them.
        let bound = pts.len() / 2;
        size(&mut self.rows, bound, count, ZERO_ROWS);
        size(&mut self.blocks, bound, count, ZERO_BLOCK);
        size(&mut self.heads, bound, count, ZERO_HEAD);
        size(&mut self.off, bound, count, false);
    }

    /// Starts a step's writes: every group's manifolds share their normals until
    /// [`Paired::unshare`] says otherwise.
    #[inline]
    pub(in crate::rigid) fn begin(&mut self) {
        self.off.fill(false);
    }

    /// Writes the shared rows of the manifold whose first point is `p0` (solve
    /// position) into its lane, if it is packed: the directions of its first point
    /// (`dir`), the inverse masses as its rows see them and its friction coefficient
    /// (the first point's entry is its group's first).
    #[inline(always)]
    pub(in crate::rigid) fn put_head(
        &mut self,
        p0: usize,
        dir: &[DVec3; 3],
        im: [f64; 2],
        mu: f64,
    ) {
        let Some(&at) = self.lane_of.get(p0) else {
            return;
        };
        let Some(head) = self.heads.get_mut((at / 4) as usize) else {
            return;
        };
        let (h, l) = ((at / 2 % 2) as usize, (at % 2) as usize);
        for (q, &d) in head.dir.iter_mut().zip(dir) {
            q.set(h, l, d);
        }
        head.im[0][h].as_mut_array()[l] = im[0];
        head.im[1][h].as_mut_array()[l] = im[1];
        head.friction[h].as_mut_array()[l] = mu;
    }

    /// Marks the group of the manifold whose first point is `p0` as not packed this
    /// step (a point whose normal is not the first point's, bit for bit: its
    /// directions are not the shared ones), if it is packed.
    #[inline(never)]
    pub(in crate::rigid) fn unshare(&mut self, p0: usize) {
        let Some(&at) = self.lane_of.get(p0) else {
            return;
        };
        if let Some(off) = self.off.get_mut((at / 4) as usize) {
            *off = true;
        }
    }

    /// Whether point `p` (solve position) is packed.
    #[inline(always)]
    pub(in crate::rigid) fn packs(&self, p: usize) -> bool {
        self.lane_of.get(p).is_some_and(|&at| at != u32::MAX)
    }

    /// Whether some group's manifolds do not all share their normals this step
    /// ([`Paired::unshare`]).
    #[inline]
    pub(in crate::rigid) fn any_unshared(&self) -> bool {
        self.off.contains(&true)
    }

    /// Per direction `I_a⁻¹(r_a × d)`, `I_b⁻¹(r_b × d)` of point `p` (solve position) as
    /// [`Paired::put`] wrote them (for its own directions, shared or not), if it is
    /// packed.
    #[inline]
    pub(in crate::rigid) fn inv_of(&self, p: usize) -> Option<[[DVec3; 2]; 3]> {
        let at = *self.lane_of.get(p)?;
        let q = self.rows.get((at / 4) as usize)?;
        let (h, l) = ((at / 2 % 2) as usize, (at % 2) as usize);
        let lane = |v: &Quad3| {
            let x = |q: &Quad| q[h].as_array()[l];
            DVec3::new(x(&v.x), x(&v.y), x(&v.z))
        };
        Some(core::array::from_fn(|r| {
            [lane(&q.inv[r][0]), lane(&q.inv[r][1])]
        }))
    }

    /// Writes point `p`'s rows into its lane, if it is in a packed pair.
    #[inline(always)]
    pub(in crate::rigid) fn put(&mut self, p: usize, point: PointRows) {
        let Some(&at) = self.lane_of.get(p) else {
            return;
        };
        let Some(pr) = self.rows.get_mut((at / 4) as usize) else {
            return;
        };
        let (h, l) = ((at / 2 % 2) as usize, (at % 2) as usize);
        pr.anchor[0].set(h, l, point.anchor[0]);
        pr.anchor[1].set(h, l, point.anchor[1]);
        for r in 0..3 {
            let [x, y, z] = point.inv[r].map(f64x2::to_array);
            pr.inv[r][0].set(h, l, DVec3::new(x[0], y[0], z[0]));
            pr.inv[r][1].set(h, l, DVec3::new(x[1], y[1], z[1]));
            pr.mass[r][h].as_mut_array()[l] = point.mass[r];
            pr.pre[r][h].as_mut_array()[l] = point.pre[r];
        }
        pr.base[h].as_mut_array()[l] = point.base_gap;
    }

    /// Whether manifold `j` starts a packed pair `(j, j + 1)` (its own or half of a
    /// quad's).
    #[inline(always)]
    pub(in crate::rigid) fn starts(&self, j: usize) -> bool {
        self.first.get(j).is_some_and(|&f| f != u32::MAX)
    }

    /// Writes the blocks of the `W` manifolds from `j` (a packed pair, `W` 2, or a
    /// quad, `W` 4; each of [`BLOCK_POINTS`] points) into their lanes: `kinv[i N +
    /// c]` the lanes of `K⁻¹`'s entry `(i, c)`, `c[i]` those of `c_i`
    /// ([`build_lanes`](super::build_lanes)).
    #[inline(always)]
    pub(in crate::rigid) fn put_block<const W: usize>(
        &mut self,
        j: usize,
        kinv: &[[f64; 4]; BLOCK_POINTS * BLOCK_POINTS],
        c: &[[f64; 4]; BLOCK_POINTS],
    ) {
        let Some(&f) = self.first.get(j) else {
            return;
        };
        let (k, half) = ((f / 2) as usize, (f % 2) as usize);
        let Some(blocks) = self.blocks.get_mut(k..k + BLOCK_POINTS) else {
            return;
        };
        let put = |q: &mut Quad, x: &[f64; 4]| {
            q[half] = pair(x[0], x[1]);
            if W == 4 {
                q[1] = pair(x[2], x[3]);
            }
        };
        for (i, q) in blocks.iter_mut().enumerate() {
            for (col, e) in q.kinv.iter_mut().enumerate() {
                put(e, &kinv[i * BLOCK_POINTS + col]);
            }
            put(&mut q.c, &c[i]);
        }
    }

    /// The packed rows of manifold pair `(j, j + 1)` (`len` points each) and the half
    /// of their lanes it takes, if packed (and its group's normals shared this step).
    #[inline(always)]
    pub(in crate::rigid) fn of(&self, j: usize, len: usize) -> Option<(Pack<'_>, usize)> {
        let f = *self.first.get(j)?;
        let k = (f / 2) as usize;
        if *self.off.get(k)? {
            return None;
        }
        let pack = Pack {
            head: self.heads.get(k)?,
            rows: self.rows.get(k..k + len)?,
            blocks: self.blocks.get(k..k + len)?,
        };
        Some((pack, (f % 2) as usize))
    }

    /// The groups not taken as packed this step ([`Paired::unshare`]).
    #[cfg(test)]
    pub(super) fn unshared(&self) -> usize {
        self.off.iter().filter(|&&o| o).count()
    }

    /// The shared rows and the points' rows of manifold pair `(j, j + 1)` (`len`
    /// points each), the half of their lanes it takes and whether it starts a quad,
    /// if packed (and its group's normals shared this step): [`Paired::of`] without
    /// the blocks.
    #[inline(always)]
    pub(in crate::rigid) fn shared(&self, j: usize, len: usize) -> Option<(Normals<'_>, bool)> {
        let f = *self.first.get(j)?;
        let k = (f / 2) as usize;
        if *self.off.get(k)? {
            return None;
        }
        let (head, rows) = (self.heads.get(k)?, self.rows.get(k..k + len)?);
        Some(((head, rows, (f % 2) as usize), *self.quad.get(j)?))
    }

    /// Whether the passes take manifolds four at a time this step.
    #[inline(always)]
    pub(in crate::rigid) fn four(&self) -> bool {
        self.avx.is_some()
    }

    /// Where the passes take manifolds four at a time this step: the proof of AVX.
    #[inline(always)]
    pub(in crate::rigid) fn avx(&self) -> Option<Avx> {
        self.avx
    }

    /// The packed rows of the quad of manifolds `j … j + 3` (`len` points each), if
    /// `j` starts one and the passes take quads ([`Paired::four`]).
    #[inline(always)]
    pub(in crate::rigid) fn quad(&self, j: usize, len: usize) -> Option<Pack<'_>> {
        if self.avx.is_none() || !*self.quad.get(j)? {
            return None;
        }
        self.of(j, len).map(|(pack, _)| pack)
    }
}
