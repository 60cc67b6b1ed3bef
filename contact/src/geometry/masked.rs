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

use constraint_core::Pose;

use super::broad::{beyond_plane, frame_colliders, sweep_axis, BroadScratch, BroadStats};
use super::contact::Contact;
use super::narrow::collide_framed;
use super::shape::{Collider, GeometryError};

/// Which pairs of `n` colliders may touch: a symmetric bit matrix, one row of
/// `⌈n / 64⌉` words per collider. Empty (nothing allowed) when built.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PairMask {
    n: usize,
    words: usize,
    bits: Vec<u64>,
}

impl PairMask {
    /// A mask over `n` colliders allowing no pair.
    pub fn new(n: usize) -> Self {
        let words = n.div_ceil(64);
        Self {
            n,
            words,
            bits: vec![0; n * words],
        }
    }

    /// The number of colliders.
    pub fn len(&self) -> usize {
        self.n
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
/// `margin / 2`, a sort-and-sweep along the axis of largest variance of the box centres
/// (its order kept in `scratch`), then the narrow phase on every overlapping allowed
/// pair of colliders on different bodies, in pair order `(a, b)`, `a < b`. With `mask`
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
        clip,
        ..
    } = scratch;
    frame_colliders(colliders, body_poses, margin, aabbs, frames, tilted)?;
    let axis = sweep_axis(aabbs);
    // The kept order, re-sorted by (lower bound on the axis, index): unique keys, so
    // the insertion sort and its fallback give the one sorted order.
    if order.len() != n {
        order.clear();
        order.extend(0..n);
    }
    let after = |a: usize, b: usize| {
        aabbs[a].min[axis]
            .total_cmp(&aabbs[b].min[axis])
            .then(a.cmp(&b))
    };
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
    lower.clear();
    lower.extend(order.iter().map(|&i| aabbs[i].min[axis]));
    let words = mask.words;
    hit.clear();
    hit.resize(n * words, 0);
    // The sweep: box `i` meets the later boxes that start before it ends on the axis;
    // overlapping allowed pairs are marked at row min(i, j), column max(i, j).
    let mut tests = 0;
    for (p, &i) in order.iter().enumerate() {
        let end = aabbs[i].max[axis];
        for (q, &j) in order.iter().enumerate().skip(p + 1) {
            if lower[q] > end {
                break;
            }
            tests += 1;
            if mask.allows(i, j) && aabbs[i].overlaps(&aabbs[j]) {
                let (a, b) = if i < j { (i, j) } else { (j, i) };
                hit[a * words + b / 64] |= 1 << (b % 64);
            }
        }
    }
    // The marked pairs row by row, columns ascending: sorted pair order.
    let framed = |k: usize| (&colliders[k], &frames[k].0, &frames[k].1);
    let mut pairs = 0;
    for a in 0..n {
        for w in 0..words {
            let mut bits = hit[a * words + w];
            while bits != 0 {
                let b = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                pairs += 1;
                if colliders[a].body == colliders[b].body
                    || (!tilted.is_empty()
                        && (beyond_plane(tilted, a, &aabbs[b], margin)
                            || beyond_plane(tilted, b, &aabbs[a], margin)))
                {
                    continue;
                }
                collide_framed((a, b), framed(a), framed(b), margin, clip, out);
            }
        }
    }
    Ok(BroadStats { tests, pairs, axis })
}
