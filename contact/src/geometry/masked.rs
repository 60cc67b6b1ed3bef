//! Contact generation for a scene whose pair filter is fixed: a [`PairMask`] (which
//! collider pairs may ever touch, built once) and a sort-and-sweep over the colliders.
//!
//! The jointed worlds have a few dozen colliders and a filter that never changes during
//! a run (MuJoCo's `contype`/`conaffinity`, parent–child, `exclude`): the filter is a bit
//! matrix, looked up only for boxes that overlap along the sweep axis, and the
//! overlapping allowed pairs are marked in a second bit matrix and read back row by
//! row, so they come out sorted without a sort. The sweep (Baraff 1992; Ericson,
//! *Real-Time Collision Detection* (2005), §7.5.2) keeps its order between calls and
//! re-sorts it by insertion (linear on a nearly sorted list).

use alloc::vec;
use alloc::vec::Vec;

use constraint_core::{DVec3, Pose};

use super::broad::{beyond_plane, frame_colliders, BroadScratch, BroadStats};
use super::contact::Contact;
use super::narrow::collide_framed;
use super::shape::{Aabb, Collider, GeometryError};

/// Up to this many allowed pairs per collider, [`generate_contacts_masked`] tests every
/// allowed pair's boxes (about 15 instructions a pair) instead of sweeping: the sweep's
/// fixed cost (the axis, the re-sort, the marks: some 2 000 instructions a call at 10
/// colliders) is more than the pairs of the small models (callgrind, `World::step`:
/// dm hopper 2 s 72.48M all pairs, 73.46M swept; half_cheetah ctrl 43.30M / 44.10M)
/// and less than humanoid_CMU's 1 100 (0.5 s 387.86M all pairs, 379.90M swept).
/// Either side gives the same contacts in the same order.
const DIRECT_PAIRS_PER_COLLIDER: usize = 16;

/// Which pairs of `n` colliders may touch: a symmetric bit matrix, one row of
/// `⌈n / 64⌉` words per collider. Empty (nothing allowed) when built.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PairMask {
    n: usize,
    words: usize,
    bits: Vec<u64>,
    /// The number of allowed pairs `(i, j)`, `i < j`.
    allowed: usize,
    /// The allowed pairs `(i, j)`, `i < j`, sorted, while they were allowed in that
    /// order (`listed`; else empty): the direct path's loop without the bits' rows.
    list: Vec<(usize, usize)>,
    listed: bool,
}

impl PairMask {
    /// A mask over `n` colliders allowing no pair.
    pub fn new(n: usize) -> Self {
        let words = n.div_ceil(64);
        Self {
            n,
            words,
            bits: vec![0; n * words],
            allowed: 0,
            list: Vec::new(),
            listed: true,
        }
    }

    /// The number of colliders.
    pub fn len(&self) -> usize {
        self.n
    }

    /// The number of allowed pairs `(i, j)`, `i < j`.
    pub fn allowed(&self) -> usize {
        self.allowed
    }

    /// Whether the mask is over no collider.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Allows the pair `(i, j)` (either order). Errors: an index `≥ n`
    /// ([`GeometryError::PairMaskSize`] names the index and `n`).
    pub fn allow(&mut self, i: usize, j: usize) -> Result<(), GeometryError> {
        for k in [i, j] {
            if k >= self.n {
                return Err(GeometryError::PairMaskSize {
                    mask: self.n,
                    colliders: k,
                });
            }
        }
        if i != j && !self.allows(i, j) {
            self.allowed += 1;
            let p = (i.min(j), i.max(j));
            if self.listed && self.list.last().is_none_or(|&last| last < p) {
                self.list.push(p);
            } else {
                self.listed = false;
                self.list = Vec::new();
            }
        }
        self.bits[i * self.words + j / 64] |= 1 << (j % 64);
        self.bits[j * self.words + i / 64] |= 1 << (i % 64);
        Ok(())
    }

    /// Whether the pair `(i, j)` is allowed (`false` for an index `≥ n`).
    #[inline]
    pub fn allows(&self, i: usize, j: usize) -> bool {
        j < self.n
            && self
                .bits
                .get(i * self.words + j / 64)
                .is_some_and(|w| (w >> (j % 64)) & 1 == 1)
    }
}

/// All contacts of a scene whose allowed pairs are `mask`'s: bounding boxes grown by
/// `margin / 2`, a sort-and-sweep along the axis of largest spread of the box centres
/// (its order kept in `scratch`; a mask allowing at most 16 pairs per collider has each
/// pair tested directly instead), then the narrow phase on every overlapping allowed pair
/// of colliders on different bodies, in pair order `(a, b)`, `a < b`. With `mask`
/// allowing exactly the pairs `keep` accepts, the same contacts in the same order as
/// [`super::generate_contacts_with`] (the broad phases find the same overlapping pairs;
/// the filter only removes some), for a few dozen colliders at a fraction of its cost:
/// the filter is looked up only for the pairs the sweep meets, and not called per pair.
/// `tests` counts the box pairs the sweep met, `pairs` the overlapping allowed ones.
///
/// Errors: as [`super::generate_contacts`]; a mask over another number of colliders
/// ([`GeometryError::PairMaskSize`]).
pub fn generate_contacts_masked(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    mask: &PairMask,
    scratch: &mut BroadScratch,
    out: &mut Vec<Contact>,
) -> Result<BroadStats, GeometryError> {
    masked_into::<false>(
        colliders,
        body_poses,
        margin,
        0.0,
        mask,
        scratch,
        out,
        &mut Vec::new(),
    )
}

/// [`generate_contacts_masked`] that also lists, in `pairs` (cleared first), the
/// allowed pairs its sweep met whose boxes overlap when each is grown by `extra` (m)
/// more, `(a, b)`, `a < b`, sorted (a pair of one body's colliders or beyond a tilted
/// plane is listed too): the candidates for [`generate_contacts_listed`] at later
/// poses, where a tight box lies within its old one grown by the distance its
/// collider's points moved. The same contacts in the same order as
/// [`generate_contacts_masked`] (the narrow phase takes the pairs overlapping without
/// `extra` alone). The `bool` says
/// whether the pairs were listed: only where the mask is swept (more than 16 allowed
/// pairs per collider); the direct path's loop over the allowed pairs costs about what
/// a list of them would save.
///
/// Errors: as [`generate_contacts_masked`], and a negative or non-finite `extra`
/// ([`GeometryError::BadMargin`]); `pairs` is then empty.
#[allow(clippy::too_many_arguments)]
pub fn generate_contacts_masked_pairs(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    extra: f64,
    mask: &PairMask,
    scratch: &mut BroadScratch,
    out: &mut Vec<Contact>,
    pairs: &mut Vec<(usize, usize)>,
) -> Result<(BroadStats, bool), GeometryError> {
    pairs.clear();
    if !(extra >= 0.0 && extra.is_finite()) {
        out.clear();
        return Err(GeometryError::BadMargin);
    }
    let swept = mask.allowed > DIRECT_PAIRS_PER_COLLIDER * mask.n;
    let result = if swept {
        masked_into::<true>(
            colliders, body_poses, margin, extra, mask, scratch, out, pairs,
        )
    } else {
        masked_into::<false>(
            colliders, body_poses, margin, extra, mask, scratch, out, pairs,
        )
    };
    match result {
        Ok(stats) => Ok((stats, swept)),
        Err(e) => {
            pairs.clear();
            Err(e)
        }
    }
}

/// The contacts of the listed collider pairs only: bounding boxes grown by
/// `margin / 2` as in [`generate_contacts_masked`], then the narrow phase on each
/// listed pair whose boxes overlap (not one body's, not beyond a tilted plane), in list
/// order. With `pairs` sorted and holding every allowed pair whose boxes overlap at
/// these poses (those of [`generate_contacts_masked_pairs`] at poses no collider point
/// has moved from by more than its extra margin), the same contacts in the same order as
/// [`generate_contacts_masked`], without its sweep. `tests` and `pairs` of the
/// statistics count the listed and the overlapping pairs.
///
/// Errors: as [`super::generate_contacts`]; a pair naming a collider beyond
/// `colliders` ([`GeometryError::PairMaskSize`]).
pub fn generate_contacts_listed(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    pairs: &[(usize, usize)],
    scratch: &mut BroadScratch,
    out: &mut Vec<Contact>,
) -> Result<BroadStats, GeometryError> {
    out.clear();
    let n = colliders.len();
    if let Some(&(a, b)) = pairs.iter().find(|&&(a, b)| a >= n || b >= n) {
        return Err(GeometryError::PairMaskSize {
            mask: n,
            colliders: a.max(b),
        });
    }
    let BroadScratch {
        aabbs,
        frames,
        tilted,
        clip,
        ..
    } = scratch;
    frame_colliders(colliders, body_poses, margin, aabbs, frames, tilted)?;
    let framed = |k: usize| (&colliders[k], &frames[k].0, &frames[k].1);
    let mut met = 0;
    for &(a, b) in pairs {
        if !aabbs[a].overlaps(&aabbs[b]) {
            continue;
        }
        met += 1;
        if skipped(colliders, tilted, aabbs, margin, a, b) {
            continue;
        }
        collide_framed((a, b), framed(a), framed(b), margin, clip, out);
    }
    Ok(BroadStats {
        tests: pairs.len(),
        pairs: met,
        axis: 0,
    })
}

/// Whether an overlapping pair `(a, b)` goes without the narrow phase: both colliders
/// on one body, or either one's box wholly beyond the other's tilted plane.
#[inline(always)]
fn skipped(
    colliders: &[Collider],
    tilted: &[(usize, DVec3, f64)],
    aabbs: &[Aabb],
    margin: f64,
    a: usize,
    b: usize,
) -> bool {
    colliders[a].body == colliders[b].body
        || (!tilted.is_empty()
            && (beyond_plane(tilted, a, &aabbs[b], margin)
                || beyond_plane(tilted, b, &aabbs[a], margin)))
}

/// [`generate_contacts_masked`], listing the overlapping allowed pairs its sweep met
/// in `listed` where `LIST` ([`generate_contacts_masked_pairs`]; the direct path lists
/// nothing), with the pairs overlapping by `extra` more. Without `LIST` the loops are
/// [`generate_contacts_masked`]'s alone.
#[allow(clippy::too_many_arguments)]
fn masked_into<const LIST: bool>(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    extra: f64,
    mask: &PairMask,
    scratch: &mut BroadScratch,
    out: &mut Vec<Contact>,
    listed: &mut Vec<(usize, usize)>,
) -> Result<BroadStats, GeometryError> {
    out.clear();
    let n = colliders.len();
    if mask.len() != n {
        return Err(GeometryError::PairMaskSize {
            mask: mask.len(),
            colliders: n,
        });
    }
    let BroadScratch {
        aabbs,
        frames,
        tilted,
        order,
        lower,
        hit,
        near,
        clip,
        ..
    } = scratch;
    frame_colliders(colliders, body_poses, margin, aabbs, frames, tilted)?;
    let framed = |k: usize| (&colliders[k], &frames[k].0, &frames[k].1);
    let skip = |a: usize, b: usize| skipped(colliders, tilted, aabbs, margin, a, b);
    let words = mask.words;
    if mask.allowed <= DIRECT_PAIRS_PER_COLLIDER * n {
        // Few allowed pairs: each tested directly, in pair order (from the list when
        // the pairs were allowed in order, else row by row from the bits).
        let mut pairs = 0;
        if mask.listed {
            for &(a, b) in &mask.list {
                if aabbs[a].overlaps(&aabbs[b]) {
                    pairs += 1;
                    if !skip(a, b) {
                        collide_framed((a, b), framed(a), framed(b), margin, clip, out);
                    }
                }
            }
        } else {
            for a in 0..n {
                let own = aabbs[a];
                let row = &mask.bits[a * words..(a + 1) * words];
                for (w, &word) in row.iter().enumerate().skip(a / 64) {
                    // Columns after `a` only (each pair once, from its lower index).
                    let mut bits = if w == a / 64 {
                        word & (u64::MAX << (a % 64) << 1)
                    } else {
                        word
                    };
                    while bits != 0 {
                        let b = w * 64 + bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        if !own.overlaps(&aabbs[b]) {
                            continue;
                        }
                        pairs += 1;
                        if !skip(a, b) {
                            collide_framed((a, b), framed(a), framed(b), margin, clip, out);
                        }
                    }
                }
            }
        }
        return Ok(BroadStats {
            tests: mask.allowed,
            pairs,
            axis: 0,
        });
    }
    let axis = spread_axis(aabbs);
    // Each box's lower bound on the axis, by collider.
    lower.clear();
    lower.extend(aabbs.iter().map(|b| b.min[axis]));
    // The kept order, re-sorted by (lower bound, index) in the total order of `f64`:
    // unique keys, so the insertion sort and its fallback give the one sorted order.
    if order.len() != n {
        order.clear();
        order.extend(0..n);
    }
    let after = |a: usize, b: usize| lower[a].total_cmp(&lower[b]).then(a.cmp(&b));
    let budget = 4 * n + 64;
    let mut moves = 0;
    for k in 1..n {
        let v = order[k];
        let mut m = k;
        while m > 0 && after(order[m - 1], v).is_gt() {
            order[m] = order[m - 1];
            m -= 1;
            moves += 1;
        }
        order[m] = v;
        if moves > budget {
            order.sort_unstable_by(|&a, &b| after(a, b));
            break;
        }
    }
    hit.clear();
    hit.resize(n * words, 0);
    if LIST {
        near.clear();
        near.resize(n * words, 0);
    }
    // Listing: the two boxes grown by `extra` each (`2 extra` on one of them).
    let wider = 2.0 * extra;
    // The sweep: box `i` meets the later boxes that start before it ends on the axis
    // (ascending in the total order, so in `>` too: the first beyond ends the scan);
    // overlapping allowed pairs are marked at row min(i, j), column max(i, j).
    let mut tests = 0;
    for (p, &i) in order.iter().enumerate() {
        let own = aabbs[i];
        let end = if LIST {
            own.max[axis] + wider
        } else {
            own.max[axis]
        };
        let row = &mask.bits[i * words..(i + 1) * words];
        for &j in &order[p + 1..] {
            if lower[j] > end {
                break;
            }
            tests += 1;
            if (row[j / 64] >> (j % 64)) & 1 == 1 {
                if own.overlaps(&aabbs[j]) {
                    let (a, b) = if i < j { (i, j) } else { (j, i) };
                    hit[a * words + b / 64] |= 1 << (b % 64);
                } else if LIST && overlaps_within(&own, &aabbs[j], wider) {
                    let (a, b) = if i < j { (i, j) } else { (j, i) };
                    near[a * words + b / 64] |= 1 << (b % 64);
                }
            }
        }
    }
    // The marked pairs row by row, columns ascending: sorted pair order.
    let mut pairs = 0;
    for a in 0..n {
        for w in 0..words {
            let met = hit[a * words + w];
            let mut bits = if LIST { met | near[a * words + w] } else { met };
            while bits != 0 {
                let b = w * 64 + bits.trailing_zeros() as usize;
                let bit = bits & bits.wrapping_neg();
                bits &= bits - 1;
                if LIST {
                    listed.push((a, b));
                    if met & bit == 0 {
                        continue;
                    }
                }
                pairs += 1;
                if skip(a, b) {
                    continue;
                }
                collide_framed((a, b), framed(a), framed(b), margin, clip, out);
            }
        }
    }
    Ok(BroadStats { tests, pairs, axis })
}

/// Whether boxes `a` and `b` overlap with `b` grown by `g` on every side (NaN bounds:
/// no).
#[inline]
fn overlaps_within(a: &Aabb, b: &Aabb, g: f64) -> bool {
    (a.min.x <= b.max.x + g)
        & (b.min.x - g <= a.max.x)
        & (a.min.y <= b.max.y + g)
        & (b.min.y - g <= a.max.y)
        & (a.min.z <= b.max.z + g)
        & (b.min.z - g <= a.max.z)
}

/// The axis along which the finite box centres spread most: the largest
/// `m Σ c² − (Σ c)²` (`m` times the variance of the `m` centres `c`, taken as
/// `min + max`, twice the centre; ties: lowest axis; x when none is finite). Any axis
/// gives the same pairs: this only picks the one the sweep meets fewest boxes along,
/// for a few instructions a box (one pass of sums, no division).
fn spread_axis(aabbs: &[Aabb]) -> usize {
    let (mut m, mut s1, mut s2) = (0.0, [0.0; 3], [0.0; 3]);
    for b in aabbs {
        if !(b.min.is_finite() && b.max.is_finite()) {
            continue;
        }
        m += 1.0;
        let c = b.min + b.max;
        for k in 0..3 {
            s1[k] += c[k];
            s2[k] += c[k] * c[k];
        }
    }
    let spread = |k: usize| m * s2[k] - s1[k] * s1[k];
    let mut axis = 0;
    for k in 1..3 {
        if spread(k) > spread(axis) {
            axis = k;
        }
    }
    axis
}
