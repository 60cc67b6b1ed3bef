//! Broad phase: which bounding boxes overlap, without testing all pairs.
//!
//! [`sweep_and_prune`] sorts the boxes by their lower bound along the axis on which the
//! box centres vary most and sweeps: box `i` is tested only against the boxes that start
//! before it ends on that axis. Output pairs are `(i, j)` with `i < j`, sorted, so the
//! result does not depend on the sort (deterministic). [`brute_force`] is the all-pairs
//! reference. [`generate_contacts`] runs both phases over a scene of colliders, with
//! the broad phase of [`super::grid`] (the same pairs in the same order, linear in the
//! number of bodies, its sorted order kept between steps in a [`BroadScratch`]).

use alloc::vec::Vec;

use constraint_core::{DVec3, Pose};
use glam::DMat3;

use super::contact::Contact;
use super::grid::{grid_pairs, GridScratch};
use super::narrow::{collide_framed, ClipBuffers};
use super::shape::{Aabb, Collider, GeometryError, Shape};

/// What a broad-phase pass did.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct BroadStats {
    /// Box–box overlap tests performed.
    pub tests: usize,
    /// Overlapping pairs found.
    pub pairs: usize,
    /// Sweep axis (0 = x, 1 = y, 2 = z; 0 for the brute force).
    pub axis: usize,
}

/// The axis along which the finite box centres have the largest variance (ties: lowest
/// axis; x when there are none).
fn sweep_axis(aabbs: &[Aabb]) -> usize {
    let mut n = 0.0;
    let mut mean = [0.0; 3];
    let mut m2 = [0.0; 3];
    for b in aabbs {
        if !(b.min.is_finite() && b.max.is_finite()) {
            continue;
        }
        n += 1.0;
        let c = (b.min + b.max) * 0.5;
        for k in 0..3 {
            // Welford's update.
            let d = c[k] - mean[k];
            mean[k] += d / n;
            m2[k] += d * (c[k] - mean[k]);
        }
    }
    let mut axis = 0;
    for k in 1..3 {
        if m2[k] > m2[axis] {
            axis = k;
        }
    }
    axis
}

/// Overlapping pairs `(i, j)`, `i < j`, sorted, by sort-and-sweep along the axis of
/// largest variance of the box centres. `out` is cleared first. Unbounded boxes (planes)
/// are handled (they overlap everything they span); boxes with NaN bounds overlap
/// nothing.
pub fn sweep_and_prune(aabbs: &[Aabb], out: &mut Vec<(usize, usize)>) -> BroadStats {
    sweep_and_prune_masked(aabbs, &[], out)
}

/// [`sweep_and_prune`] that leaves out pairs of two boxes marked static
/// (`is_static[i]`; a shorter mask marks the rest dynamic): a scene with many static
/// shapes on top of each other never lists their pairs. The overlap tests are counted
/// as in [`sweep_and_prune`].
pub fn sweep_and_prune_masked(
    aabbs: &[Aabb],
    is_static: &[bool],
    out: &mut Vec<(usize, usize)>,
) -> BroadStats {
    sweep_and_prune_into(aabbs, is_static, &mut Vec::new(), out)
}

/// [`sweep_and_prune_masked`] with the sweep order in a caller's buffer (no allocation
/// once `order` and `out` have grown to the scene).
fn sweep_and_prune_into(
    aabbs: &[Aabb],
    is_static: &[bool],
    order: &mut Vec<usize>,
    out: &mut Vec<(usize, usize)>,
) -> BroadStats {
    out.clear();
    let fixed = |i: usize| is_static.get(i).copied().unwrap_or(false);
    let axis = sweep_axis(aabbs);
    order.clear();
    order.extend(0..aabbs.len());
    order.sort_unstable_by(|&i, &j| {
        aabbs[i].min[axis]
            .total_cmp(&aabbs[j].min[axis])
            .then(i.cmp(&j))
    });
    let mut tests = 0;
    for (si, &i) in order.iter().enumerate() {
        let end = aabbs[i].max[axis];
        for &j in &order[si + 1..] {
            if aabbs[j].min[axis] > end {
                break;
            }
            tests += 1;
            if fixed(i) && fixed(j) {
                continue;
            }
            if aabbs[i].overlaps(&aabbs[j]) {
                out.push(if i < j { (i, j) } else { (j, i) });
            }
        }
    }
    out.sort_unstable();
    BroadStats {
        tests,
        pairs: out.len(),
        axis,
    }
}

/// All pairs tested: the reference for [`sweep_and_prune`]. `out` is cleared first.
pub fn brute_force(aabbs: &[Aabb], out: &mut Vec<(usize, usize)>) -> BroadStats {
    out.clear();
    let mut tests = 0;
    for i in 0..aabbs.len() {
        for j in i + 1..aabbs.len() {
            tests += 1;
            if aabbs[i].overlaps(&aabbs[j]) {
                out.push((i, j));
            }
        }
    }
    BroadStats {
        tests,
        pairs: out.len(),
        axis: 0,
    }
}

/// All contacts of a scene: bounding boxes grown by `margin / 2` (so pairs closer than
/// `margin` meet), [`sweep_and_prune`], then [`collide`](super::narrow::collide) on every overlapping pair except
/// two colliders on the same body or two static ones. `body_poses[k]` is the pose of
/// body `k`; static colliders use [`Pose::IDENTITY`]. `out` is cleared first and filled
/// in pair order `(a, b)`, `a < b`, then in each pair's point order.
///
/// Errors: a negative or non-finite margin, a collider naming a body beyond
/// `body_poses`, a non-finite body pose.
pub fn generate_contacts(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    out: &mut Vec<Contact>,
) -> Result<BroadStats, GeometryError> {
    generate_contacts_filtered(colliders, body_poses, margin, |_, _| true, out)
}

/// [`generate_contacts`] with a pair filter: the narrow phase runs only on overlapping
/// pairs `(i, j)` (collider indices, `i < j`) for which `keep(i, j)` holds — MuJoCo's
/// `contype`/`conaffinity` test, a body against its joint parent, explicit exclusions.
/// The filter is applied after the broad phase, so it never changes the order of the
/// contacts that remain.
pub fn generate_contacts_filtered(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    keep: impl Fn(usize, usize) -> bool,
    out: &mut Vec<Contact>,
) -> Result<BroadStats, GeometryError> {
    generate_contacts_with(
        colliders,
        body_poses,
        margin,
        keep,
        &mut BroadScratch::default(),
        out,
    )
}

/// The buffers of [`generate_contacts_with`] (bounding boxes, static mask, the grid's
/// sorted order, overlapping pairs), kept between calls so that a step allocates
/// nothing once they have grown to the scene, and the grid re-sorts a nearly sorted
/// list instead of sorting anew.
#[derive(Clone, Debug, Default)]
pub struct BroadScratch {
    pub(super) aabbs: Vec<Aabb>,
    /// Each collider's world frame and its rotation matrix ([`Collider::rotation`]),
    /// computed once per call for the bounding box and the narrow phase.
    pub(super) frames: Vec<(Pose, DMat3)>,
    /// The planes unbounded in every direction: collider index and world `(n, d)`
    /// ([`beyond_plane`]; usually none).
    pub(super) tilted: Vec<(usize, DVec3, f64)>,
    is_static: Vec<bool>,
    grid: GridScratch,
    pairs: Vec<(usize, usize)>,
    /// The narrow phase's clipping polygons.
    pub(super) clip: ClipBuffers,
    /// The sweep order of [`super::generate_contacts_masked`], kept between calls.
    pub(super) order: Vec<usize>,
    /// The boxes' lower bounds along its sweep axis, by collider.
    pub(super) lower: Vec<f64>,
    /// Its overlapping allowed pairs, a bit matrix ([`super::PairMask`]'s layout).
    pub(super) hit: Vec<u64>,
    /// The allowed pairs whose boxes only overlap grown by a listing's extra
    /// ([`super::generate_contacts_masked_pairs`]), the same layout.
    pub(super) near: Vec<u64>,
}

/// [`generate_contacts_filtered`] with its buffers in `scratch`: the same contacts in
/// the same order, without allocating once `scratch` and `out` have grown to the scene.
pub fn generate_contacts_with(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    keep: impl Fn(usize, usize) -> bool,
    scratch: &mut BroadScratch,
    out: &mut Vec<Contact>,
) -> Result<BroadStats, GeometryError> {
    generate_contacts_awake(colliders, body_poses, margin, keep, &[], scratch, out)
}

/// [`generate_contacts_with`] for a world with sleeping bodies: a body marked in
/// `asleep` (a shorter mask marks the rest awake) pairs like a static collider, so two
/// asleep or static colliders are never paired; an asleep body against an awake one
/// still is (the caller wakes it). With an empty mask, the same contacts as
/// [`generate_contacts_with`].
pub fn generate_contacts_awake(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    keep: impl Fn(usize, usize) -> bool,
    asleep: &[bool],
    scratch: &mut BroadScratch,
    out: &mut Vec<Contact>,
) -> Result<BroadStats, GeometryError> {
    out.clear();
    let BroadScratch {
        aabbs,
        frames,
        tilted,
        is_static,
        grid,
        pairs,
        clip,
        ..
    } = scratch;
    frame_colliders(colliders, body_poses, margin, aabbs, frames, tilted)?;
    let framed = |k: usize| (&colliders[k], &frames[k].0, &frames[k].1);
    is_static.clear();
    is_static.extend(colliders.iter().map(|c| {
        c.body
            .is_none_or(|b| asleep.get(b).copied().unwrap_or(false))
    }));
    let stats = grid_pairs(aabbs, is_static, grid, pairs);
    // Tilted planes' pairs beyond them skipped (a separate loop: the usual scene has
    // none, and its loop stays as it was).
    let beyond = |i: usize, j: usize| {
        beyond_plane(tilted, i, &aabbs[j], margin) || beyond_plane(tilted, j, &aabbs[i], margin)
    };
    if tilted.is_empty() {
        for &(i, j) in pairs.iter() {
            let (a, b) = (&colliders[i], &colliders[j]);
            if a.body == b.body || !keep(i, j) {
                continue;
            }
            collide_framed((i, j), framed(i), framed(j), margin, clip, out);
        }
    } else {
        for &(i, j) in pairs.iter() {
            let (a, b) = (&colliders[i], &colliders[j]);
            if a.body == b.body || beyond(i, j) || !keep(i, j) {
                continue;
            }
            collide_framed((i, j), framed(i), framed(j), margin, clip, out);
        }
    }
    Ok(stats)
}

/// Each collider's world frame, rotation and bounding box grown by `margin / 2`, into
/// `aabbs` and `frames` (cleared first), and the tilted planes into `tilted`
/// ([`tilted_plane`]). Errors as [`generate_contacts`]: a negative or non-finite
/// margin, a non-finite body pose, a collider naming a body beyond `body_poses`.
pub(super) fn frame_colliders(
    colliders: &[Collider],
    body_poses: &[Pose],
    margin: f64,
    aabbs: &mut Vec<Aabb>,
    frames: &mut Vec<(Pose, DMat3)>,
    tilted: &mut Vec<(usize, DVec3, f64)>,
) -> Result<(), GeometryError> {
    if !(margin >= 0.0) || !margin.is_finite() {
        return Err(GeometryError::BadMargin);
    }
    if !all_finite(body_poses) {
        return Err(GeometryError::NonFinite);
    }
    let pose_of = |c: &Collider| match c.body {
        Some(b) => body_poses[b],
        None => Pose::IDENTITY,
    };
    // Written in place (no per-collider capacity check or copy through the stack).
    let n = colliders.len();
    aabbs.resize(n, Aabb::new(DVec3::ZERO, DVec3::ZERO));
    frames.resize(n, (Pose::IDENTITY, DMat3::IDENTITY));
    tilted.clear();
    let slots = aabbs.iter_mut().zip(frames.iter_mut());
    for (k, (c, (aabb, frame))) in colliders.iter().zip(slots).enumerate() {
        if let Some(b) = c.body {
            if b >= body_poses.len() {
                return Err(GeometryError::BodyOutOfRange {
                    collider: k,
                    body: b,
                });
            }
        }
        let w = c.world_pose(&pose_of(c));
        let rot = c.rotation(&w);
        *aabb = c.aabb_framed(&w, &rot, 0.5 * margin);
        if matches!(c.shape, Shape::Plane { .. }) {
            if let Some((n, d)) = tilted_plane(c, &w, aabb) {
                tilted.push((k, n, d));
            }
        }
        *frame = (w, rot);
    }
    Ok(())
}

/// Whether every component of every pose is finite: `0 v` is `±0` for a finite `v`
/// and NaN for an infinite or NaN one, and a sum of zeros is a zero while NaN spreads,
/// so the sum over all components is zero exactly when all are finite. One pass of
/// subtractions and additions, with no branch per component (the short-circuiting
/// `is_finite` per pose cost about 67 instructions a pose, callgrind).
fn all_finite(poses: &[Pose]) -> bool {
    let (mut x, mut q) = (DVec3::ZERO, glam::DVec4::ZERO);
    for p in poses {
        x += p.x * 0.0;
        q += glam::DVec4::from(p.q) * 0.0;
    }
    (x.element_sum() + q.element_sum()) == 0.0
}

/// `(n, d)` of a plane collider `c` (world frame `w`) whose box `own` is unbounded in every direction (a
/// normal off the axes; the half-space is `n · p ≤ d`), else `None`: the box of a
/// plane with an axis-aligned normal is bounded on its free side, and the grid
/// already tests it exactly.
#[inline]
fn tilted_plane(c: &Collider, w: &Pose, own: &Aabb) -> Option<(DVec3, f64)> {
    let Shape::Plane { normal, offset } = c.shape else {
        return None;
    };
    if own.min.max_element() > f64::NEG_INFINITY || own.max.min_element() < f64::INFINITY {
        return None;
    }
    let n = w.q * normal;
    Some((n, offset + n.dot(w.x)))
}

/// Whether collider `k` is one of the `tilted` planes ([`tilted_plane`]) and the box
/// `other` (another collider's, grown by half the margin) lies outside its half-space
/// `n · p ≤ d` by more than `margin`: then no point of that collider has `n · p − d ≤ margin`, and the
/// narrow phase would report no contact (depth `≥ −margin`, [`collide`](super::narrow::collide)). A tilted
/// plane's box is unbounded, so the grid pairs it with every collider (dm_control's
/// manipulator: two walls, 36 narrow tests a step, none in contact); this is the exact
/// test of the box against the plane, `min_{p ∈ box} n · p − d = n · c − |n| · e − d`
/// (centre `c`, half extents `e`). The threshold is raised by `1e-12` of the
/// magnitudes involved, far above the rounding of either computation, so a pair is
/// skipped only where the narrow phase finds nothing; an unbounded `other` (NaN or
/// −∞ gap) is never skipped.
pub(super) fn beyond_plane(
    tilted: &[(usize, DVec3, f64)],
    k: usize,
    other: &Aabb,
    margin: f64,
) -> bool {
    let Some(&(_, n, d)) = tilted.iter().find(|t| t.0 == k) else {
        return false;
    };
    let centre = (other.min + other.max) * 0.5;
    let half = (other.max - other.min) * 0.5;
    let gap = n.dot(centre) - n.abs().dot(half) - d;
    let scale = 1.0 + d.abs() + centre.abs().max_element() + half.max_element();
    gap > margin + 1e-12 * scale
}
