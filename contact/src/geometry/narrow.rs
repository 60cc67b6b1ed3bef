//! Narrow phase: contact points, normals, depths and feature ids for a pair of colliders,
//! and particles (points with a radius) against a collider.
//!
//! Every pair of shapes is handled (plane–plane yields nothing). Contacts are reported
//! for `depth ≥ −margin` (see [`crate::geometry::contact`] for the sign convention).
//!
//! | pair | points | ids |
//! |---|---|---|
//! | sphere–anything | 1 (closest point of the other shape to the centre) | 0 |
//! | capsule–plane | 2 (the segment's end spheres; 1 if `half_length = 0`) | 0, 1 (end `−z`, `+z`) |
//! | capsule–capsule | 1, or 2 when the axes are parallel to within 0.02 rad and overlap | 0; 1, 2 |
//! | capsule–box | 1 (closest points segment–box), or 2 when the segment lies along a face (to within 0.2 rad) | 0; `4 face + 1`, `4 face + 2` |
//! | box–plane | up to 4 vertices (the deepest within the margin) | vertex index 0..8 |
//! | box–box | SAT over 15 axes; a face axis gives up to 4 points by clipping the incident face against the reference face's sides (Sutherland–Hodgman, sides pushed out by [`CLIP_SLACK`] so flush vertices keep their ids; more than 4 reduced to 4), an edge axis gives 1 point | reference face, incident face and the two clipping features of each point |
//!
//! Degenerate inputs have documented fallback normals instead of NaN: a point at a
//! sphere's centre gets the outward normal `+z` (world), a point on a capsule's axis a
//! direction normal to the axis ([`DVec3::any_orthonormal_vector`] of the axis), a point
//! exactly at the centre of a box face ties to the lowest axis and the `+` side,
//! intersecting capsule axes the common normal of the two axes (or a direction normal to
//! both when they are collinear). Poses are assumed finite (as [`Pose::new`] checks).

use alloc::vec::Vec;

use constraint_core::Pose;
use glam::{DMat3, DVec3, Vec3Swizzles};

use super::contact::{Contact, ParticleContact};
use super::shape::{Collider, Shape};

#[inline]
fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}

#[inline]
fn sign(x: f64) -> f64 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Closest point of a shape's surface to a world point, with the outward normal there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// Closest point on the surface (world).
    pub surface: DVec3,
    /// Outward unit normal of the surface at `surface` (world); the query point is at
    /// `surface + distance · normal`.
    pub normal: DVec3,
    /// Signed distance of the query point from the surface (negative inside).
    pub distance: f64,
}

/// The closest surface point of `shape`, placed at the world frame `frame` (the
/// collider frame, [`Collider::world_pose`]), to the world point `p`, with the outward
/// normal and the signed distance. Fallbacks for degenerate queries are in the module
/// documentation.
pub fn closest_point(shape: &Shape, frame: &Pose, p: DVec3) -> Closest {
    match *shape {
        Shape::Plane { normal, offset } => {
            let n = frame.q * normal;
            let d = offset + n.dot(frame.x);
            let dist = n.dot(p) - d;
            Closest {
                surface: p - n * dist,
                normal: n,
                distance: dist,
            }
        }
        Shape::Sphere { radius } => ball_closest(frame.x, radius, p, DVec3::Z),
        Shape::Capsule {
            radius,
            half_length,
        } => {
            let axis = frame.q * DVec3::Z;
            let t = (p - frame.x).dot(axis).clamp(-half_length, half_length);
            let q = frame.x + axis * t;
            ball_closest(q, radius, p, axis.any_orthonormal_vector())
        }
        Shape::Box { half } => {
            let local = frame.to_local(p);
            let c = local.clamp(-half, half);
            if c != local {
                let delta = local - c;
                let dist = delta.length();
                Closest {
                    surface: frame.point(c),
                    normal: frame.q * (delta / dist),
                    distance: dist,
                }
            } else {
                // Inside: leave through the nearest face (ties: lowest axis, `+` side).
                let mut k = 0;
                let mut best = f64::INFINITY;
                for m in 0..3 {
                    let g = half[m] - local[m].abs();
                    if g < best {
                        best = g;
                        k = m;
                    }
                }
                let s = sign(local[k]);
                let mut surf = local;
                surf[k] = s * half[k];
                let mut n = DVec3::ZERO;
                n[k] = s;
                Closest {
                    surface: frame.point(surf),
                    normal: frame.q * n,
                    distance: -best,
                }
            }
        }
    }
}

fn ball_closest(c: DVec3, r: f64, p: DVec3, fallback: DVec3) -> Closest {
    let delta = p - c;
    let dist = delta.length();
    let n = if dist > 1e-12 * r {
        delta / dist
    } else {
        fallback
    };
    Closest {
        surface: c + n * r,
        normal: n,
        distance: dist - r,
    }
}

/// A particle (centre `p`, `radius ≥ 0`) against a collider whose body is at `body`:
/// the contact if `depth ≥ −margin`. The normal points out of the collider.
pub fn point_vs(
    collider: &Collider,
    body: &Pose,
    p: DVec3,
    radius: f64,
    margin: f64,
) -> Option<ParticleContact> {
    let frame = collider.world_pose(body);
    let cl = closest_point(&collider.shape, &frame, p);
    let depth = radius - cl.distance;
    (depth >= -margin).then_some(ParticleContact {
        surface: cl.surface,
        normal: cl.normal,
        depth,
    })
}

/// Appends the contacts of one pair, normal from `a` to `b`.
struct Sink<'o> {
    out: &'o mut Vec<Contact>,
    a: usize,
    b: usize,
    flip: bool,
    margin: f64,
    count: usize,
}

impl Sink<'_> {
    /// `pa`, `pb`: witness points on the first and second shape of the native routine;
    /// `n` from the first to the second.
    #[inline(always)]
    fn push(&mut self, pa: DVec3, pb: DVec3, n: DVec3, depth: f64, id: u64) {
        if !(depth >= -self.margin) {
            return;
        }
        self.out.push(Contact {
            a: self.a,
            b: self.b,
            point: (pa + pb) * 0.5,
            normal: if self.flip { -n } else { n },
            depth,
            id,
        });
        self.count += 1;
    }
}

fn rank(s: &Shape) -> u8 {
    match s {
        Shape::Sphere { .. } => 0,
        Shape::Plane { .. } => 1,
        Shape::Capsule { .. } => 2,
        Shape::Box { .. } => 3,
    }
}

/// Contacts between collider `a` (body pose `pose_a`) and collider `b` (body pose
/// `pose_b`; [`Pose::IDENTITY`] for world colliders), appended to `out` with
/// `Contact::a, Contact::b = pair`, normals from `a` to `b`, for every point with
/// `depth ≥ −margin`. Returns the number of contacts appended.
pub fn collide(
    pair: (usize, usize),
    a: &Collider,
    pose_a: &Pose,
    b: &Collider,
    pose_b: &Pose,
    margin: f64,
    out: &mut Vec<Contact>,
) -> usize {
    let (fa, fb) = (a.world_pose(pose_a), b.world_pose(pose_b));
    let (ra, rb) = (a.rotation(&fa), b.rotation(&fb));
    let bufs = &mut ClipBuffers::default();
    collide_framed(pair, (a, &fa, &ra), (b, &fb, &rb), margin, bufs, out)
}

/// A collider with its frame in the world ([`Collider::world_pose`]) and that frame's
/// [`Collider::rotation`].
pub(crate) type Framed<'c> = (&'c Collider, &'c Pose, &'c DMat3);

/// [`collide`] from the colliders' world frames and rotations, computed once per step
/// by the caller (the broad phase computes them for the bounding boxes), with the
/// clipping polygons `bufs` kept by the caller: the same contacts, the same bits.
pub(crate) fn collide_framed(
    pair: (usize, usize),
    a: Framed,
    b: Framed,
    margin: f64,
    bufs: &mut ClipBuffers,
    out: &mut Vec<Contact>,
) -> usize {
    let ((ca, mut fa, mut ra), (cb, mut fb, mut rb)) = (a, b);
    // The shapes by reference (not copied per pair).
    let (mut sa, mut sb) = (&ca.shape, &cb.shape);
    let flip = rank(sa) > rank(sb);
    if flip {
        core::mem::swap(&mut fa, &mut fb);
        core::mem::swap(&mut ra, &mut rb);
        core::mem::swap(&mut sa, &mut sb);
    }
    let mut sink = Sink {
        out,
        a: pair.0,
        b: pair.1,
        flip,
        margin,
        count: 0,
    };
    match (sa, sb) {
        (&Shape::Sphere { radius }, other) => {
            let cl = closest_point(other, fb, fa.x);
            let n = -cl.normal;
            sink.push(fa.x + n * radius, cl.surface, n, radius - cl.distance, 0);
        }
        (Shape::Plane { .. }, Shape::Plane { .. }) => {}
        (Shape::Plane { .. }, Shape::Capsule { .. }) => {
            let (p0, p1, r) = segment(sb, fb);
            let ends: &[DVec3] = if p0 == p1 { &[p0] } else { &[p0, p1] };
            for (k, &e) in ends.iter().enumerate() {
                let cl = closest_point(sa, fa, e);
                sink.push(
                    cl.surface,
                    e - cl.normal * r,
                    cl.normal,
                    r - cl.distance,
                    k as u64,
                );
            }
        }
        (&Shape::Plane { normal, offset }, &Shape::Box { half }) => {
            plane_box(fa, normal, offset, fb, half, &mut sink)
        }
        (Shape::Capsule { .. }, Shape::Capsule { .. }) => {
            capsule_capsule(sa, fa, sb, fb, &mut sink)
        }
        (Shape::Capsule { .. }, &Shape::Box { half }) => capsule_box(sa, fa, half, fb, &mut sink),
        (&Shape::Box { half: ha }, &Shape::Box { half: hb }) => {
            box_box((fa, ra), ha, (fb, rb), hb, &mut sink, bufs)
        }
        // `rank` orders the pair so the first shape never ranks above the second.
        _ => {}
    }
    sink.count
}

/// World end points of a capsule's core segment (`−z`, `+z`) and its radius.
fn segment(s: &Shape, f: &Pose) -> (DVec3, DVec3, f64) {
    match *s {
        Shape::Capsule {
            radius,
            half_length,
        } => {
            let h = f.q * DVec3::new(0.0, 0.0, half_length);
            (f.x - h, f.x + h, radius)
        }
        _ => (f.x, f.x, 0.0),
    }
}

fn plane_box(fp: &Pose, normal: DVec3, offset: f64, fb: &Pose, half: DVec3, sink: &mut Sink) {
    let n = fp.q * normal;
    let d = offset + n.dot(fp.x);
    let mut depth = [0.0; 8];
    let mut vert = [DVec3::ZERO; 8];
    for k in 0..8 {
        vert[k] = fb.point(box_vertex(half, k));
        depth[k] = d - n.dot(vert[k]);
    }
    // The (up to) four deepest vertices within the margin, reported in vertex order:
    // vertex k is among the four first of the order "deeper first (`f64::total_cmp`),
    // then lower index" when fewer than four vertices come before it, counted over the
    // 28 pairs (no sort).
    let mut before = [0u8; 8];
    for j in 0..8 {
        for k in j + 1..8 {
            if depth[j].total_cmp(&depth[k]).is_ge() {
                before[k] += 1;
            } else {
                before[j] += 1;
            }
        }
    }
    for k in 0..8 {
        if before[k] < 4 && depth[k] >= -sink.margin {
            sink.push(vert[k] + n * depth[k], vert[k], n, depth[k], k as u64);
        }
    }
}

/// Box vertex `k` (bit 0: x sign, bit 1: y, bit 2: z; set bit = `+`) in the box frame.
#[inline]
fn box_vertex(half: DVec3, k: usize) -> DVec3 {
    let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
    DVec3::new(s(1) * half.x, s(2) * half.y, s(4) * half.z)
}

/// Closest points of the segments `p1 + s (q1 − p1)` and `p2 + t (q2 − p2)`,
/// `s, t ∈ [0, 1]` (Ericson, Real-Time Collision Detection, 5.1.9); parallel segments
/// take `s = 0` where it is a minimiser.
pub fn closest_segments(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> (f64, f64, DVec3, DVec3) {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    let tiny = 1e-300;
    let (s, t) = if a <= tiny && e <= tiny {
        (0.0, 0.0)
    } else if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-14 * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    (s, t, p1 + d1 * s, p2 + d2 * t)
}

/// Two balls (core points `ca`, `cb`) given a fallback normal for coincident centres.
fn balls(sink: &mut Sink, ca: DVec3, ra: f64, cb: DVec3, rb: f64, fallback: DVec3, id: u64) {
    let delta = cb - ca;
    let dist = delta.length();
    let n = if dist > 1e-12 * (ra + rb) {
        delta / dist
    } else {
        fallback
    };
    sink.push(ca + n * ra, cb - n * rb, n, ra + rb - dist, id);
}

fn capsule_capsule(sa: &Shape, fa: &Pose, sb: &Shape, fb: &Pose, sink: &mut Sink) {
    let (a0, a1, ra) = segment(sa, fa);
    let (b0, b1, rb) = segment(sb, fb);
    let da = a1 - a0;
    let db = b1 - b0;
    // Fallback for intersecting axes: their common normal, oriented from a to b.
    let cross = da.cross(db);
    let towards = (b0 + b1 - a0 - a1) * 0.5;
    let fallback = if cross.length_squared() > 1e-20 * da.length_squared() * db.length_squared()
        && cross.length_squared() > 0.0
    {
        let c = cross.normalize();
        if c.dot(towards) < 0.0 {
            -c
        } else {
            c
        }
    } else {
        let axis = if da.length_squared() > 0.0 {
            da
        } else if db.length_squared() > 0.0 {
            db
        } else {
            DVec3::Z
        };
        let perp = towards - axis * (towards.dot(axis) / axis.length_squared());
        if perp.length_squared() > 1e-24 * (1.0 + towards.length_squared()) {
            perp.normalize()
        } else {
            axis.normalize().any_orthonormal_vector()
        }
    };
    let la = da.length();
    let lb = db.length();
    // Parallel axes: the two ends of the overlap of b's projection onto a's axis.
    if la > 0.0 && lb > 0.0 && cross.length() <= 0.02 * la * lb {
        let u = da / la;
        let t0 = (b0 - a0).dot(u);
        let t1 = (b1 - a0).dot(u);
        let lo = t0.min(t1).max(0.0);
        let hi = t0.max(t1).min(la);
        if hi - lo > 1e-9 * la {
            for (k, t) in [lo, hi].into_iter().enumerate() {
                let p = a0 + u * t;
                let (_, _, q, _) = closest_segments(b0, b1, p, p);
                balls(sink, p, ra, q, rb, fallback, k as u64 + 1);
            }
            return;
        }
    }
    let (_, _, p, q) = closest_segments(a0, a1, b0, b1);
    balls(sink, p, ra, q, rb, fallback, 0);
}

fn capsule_box(sc: &Shape, fc: &Pose, half: DVec3, fb: &Pose, sink: &mut Sink) {
    let (w0, w1, r) = segment(sc, fc);
    // Work in the box frame.
    let p0 = fb.to_local(w0);
    let p1 = fb.to_local(w1);
    let u = p1 - p0;
    // Closest points of the segment and the (solid) box: end points against the box,
    // the segment against the 12 edges.
    let mut best_d2 = f64::INFINITY;
    let mut sp = p0;
    let mut bp = p0;
    for p in [p0, p1] {
        let c = p.clamp(-half, half);
        let d2 = (p - c).length_squared();
        if d2 < best_d2 {
            best_d2 = d2;
            sp = p;
            bp = c;
        }
    }
    for axis in 0..3 {
        let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
        for corner in 0..4 {
            let mut e0 = DVec3::ZERO;
            e0[i] = if corner & 1 != 0 { half[i] } else { -half[i] };
            e0[j] = if corner & 2 != 0 { half[j] } else { -half[j] };
            let mut e1 = e0;
            e0[axis] = -half[axis];
            e1[axis] = half[axis];
            let (_, _, s, e) = closest_segments(p0, p1, e0, e1);
            let d2 = (s - e).length_squared();
            if d2 < best_d2 {
                best_d2 = d2;
                sp = s;
                bp = e;
            }
        }
    }
    let scale = half.max_element();
    let (n, core_depth) = if best_d2 > (1e-9 * scale) * (1e-9 * scale) {
        // Separated core: outward normal of the box towards the segment.
        let d = sqrt(best_d2);
        ((sp - bp) / d, -d)
    } else {
        // The core segment meets the box: separating-axis test over the 3 face normals
        // and the 3 cross products of the segment with them; the axis of least
        // penetration (faces preferred by a small tolerance).
        let mut best = (f64::INFINITY, DVec3::Z, 0.0, 0usize);
        let mut axes = [DVec3::ZERO; 6];
        for k in 0..3 {
            axes[k][k] = 1.0;
            let mut e = DVec3::ZERO;
            e[k] = 1.0;
            axes[3 + k] = u.cross(e);
        }
        for (idx, &l) in axes.iter().enumerate() {
            let len = l.length();
            if !(len > 1e-9 * (1.0 + u.length())) {
                continue;
            }
            let l = l / len;
            let rb = half.dot(l.abs());
            // Both orientations: push the segment out along +l or −l.
            for l in [l, -l] {
                let pen = rb - l.dot(p0).min(l.dot(p1));
                let pen_cmp = if idx < 3 {
                    pen
                } else {
                    pen * 1.05 + 1e-9 * scale
                };
                if pen_cmp < best.0 {
                    best = (pen_cmp, l, pen, idx);
                }
            }
        }
        let (_, l, pen, idx) = best;
        sp = if idx >= 3 {
            // Cross axis: the segment's closest point to the box edge along `e_k` that
            // supports the box in direction `l`.
            let k = idx - 3;
            let mut c = DVec3::new(sign(l.x), sign(l.y), sign(l.z)) * half;
            c[k] = -half[k];
            let mut c1 = c;
            c1[k] = half[k];
            closest_segments(p0, p1, c, c1).2
        } else {
            let (d0, d1) = (l.dot(p0), l.dot(p1));
            if (d0 - d1).abs() <= 1e-12 * scale {
                (p0 + p1) * 0.5
            } else if d0 < d1 {
                p0
            } else {
                p1
            }
        };
        bp = sp + l * (rb_of(half, l) - l.dot(sp));
        (l, pen)
    };
    // `core_depth`: penetration of the core segment (negative: its distance).
    let depth = r + core_depth;
    // Along a face: clip the segment to the face rectangle, two points.
    let k = n.abs().max_position();
    if n[k].abs() >= 0.98 && u.length() > 0.0 && u[k].abs() <= 0.2 * u.length() {
        let s = sign(n[k]);
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for m in [i, j] {
            if u[m].abs() > 1e-15 * u.length() {
                let ta = (-half[m] - p0[m]) / u[m];
                let tb = (half[m] - p0[m]) / u[m];
                lo = lo.max(ta.min(tb));
                hi = hi.min(ta.max(tb));
            } else if p0[m].abs() > half[m] {
                hi = -1.0;
            }
        }
        if hi >= lo {
            let face = (2 * k + usize::from(s < 0.0)) as u64;
            let ts: &[f64] = if hi - lo > 1e-9 { &[lo, hi] } else { &[lo] };
            let mut nf = DVec3::ZERO;
            nf[k] = s;
            let nw = fb.q * nf;
            for (e, &t) in ts.iter().enumerate() {
                let q = p0 + u * t;
                let dist = s * q[k] - half[k];
                let mut on_box = q;
                on_box[k] = s * half[k];
                // Native order is capsule (first) to box (second): normal −n_face.
                sink.push(
                    fb.point(q - nf * r),
                    fb.point(on_box),
                    -nw,
                    r - dist,
                    4 * face + e as u64 + 1,
                );
            }
            return;
        }
    }
    let nw = fb.q * n;
    // Native order is capsule (first) to box (second): normal −n.
    sink.push(fb.point(sp) - nw * r, fb.point(bp), -nw, depth, 0);
}

/// Half the width of a box along the unit direction `l` (box frame).
#[inline]
fn rb_of(half: DVec3, l: DVec3) -> f64 {
    half.dot(l.abs())
}

/// A vertex of a clipped polygon: position and the features (incident edges 0..4,
/// reference side planes 4..8) of the edges entering and leaving it.
#[derive(Clone, Copy, Debug)]
struct Vtx {
    p: DVec3,
    inn: u8,
    out: u8,
}

/// A clipped polygon: its vertices and, per vertex, `g = u · p` for the side axis `u`
/// being clipped against (both of that axis's planes read it: `(−u) · p = −(u · p)`
/// exactly, so one dot product serves the two).
#[derive(Clone, Copy, Debug)]
struct Poly {
    v: [Vtx; 12],
    g: [f64; 12],
    n: usize,
}

impl Poly {
    const EMPTY: Poly = Poly {
        v: [Vtx {
            p: DVec3::ZERO,
            inn: 0,
            out: 0,
        }; 12],
        g: [0.0; 12],
        n: 0,
    };
}

/// The two polygons of box–box clipping and the manifold's candidate points (position,
/// depth, id), kept by the caller between pairs (the broad phase's scratch) so that
/// nothing is zeroed per pair (6.5 M instructions, 0.5 %, of the 210-box pyramid's
/// 120 steps, callgrind).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ClipBuffers {
    polys: [Poly; 2],
    pts: [(DVec3, f64, u64); 12],
}

impl Default for ClipBuffers {
    fn default() -> Self {
        Self {
            polys: [Poly::EMPTY; 2],
            pts: [(DVec3::ZERO, 0.0, 0); 12],
        }
    }
}

/// `k mod n` for `k < 2 n`.
#[inline]
fn wrap(k: usize, n: usize) -> usize {
    if k >= n {
        k - n
    } else {
        k
    }
}

/// Sutherland–Hodgman against the half-space `m·p ≤ o` (side feature `label`) of the
/// polygon whose vertices are those of `input` from index `start < input.n` on (then
/// from 0), given each vertex's signed distance `dist[k] = m·p_k − o`, into `out`
/// (emptied first). The caller clips only where some vertex is outside: with every
/// vertex inside the output would be the same polygon from its second vertex on, so
/// the caller moves `start` on instead of copying. Two buffers taken in turn by the
/// caller: no polygon is zeroed or copied per plane (that was 1.9 % of the 210-box
/// pyramid's step, callgrind). With `g_axis = Some(u)` each output vertex carries its
/// `g = u · p` (kept, or computed once for a new one) for the next plane.
fn clip(
    input: &Poly,
    start: usize,
    dist: &[f64; 12],
    g_axis: Option<DVec3>,
    label: u8,
    out: &mut Poly,
) {
    let n = input.n;
    if start >= n {
        out.n = 0;
        return;
    }
    let (v, g, dist) = (&input.v[..n], &input.g[..n], &dist[..n]);
    // The output count in a register, stored once.
    let mut m = 0;
    let mut put = |p: Vtx, gp: f64| {
        if m < out.v.len() {
            out.v[m] = p;
            out.g[m] = gp;
            m += 1;
        }
    };
    // The edges `cur → next` from vertex `start` round to it again.
    let (mut ci, mut cur, mut dc) = (start, &v[start], dist[start]);
    for _ in 0..n {
        let nx = wrap(ci + 1, n);
        let (next, dn) = (&v[nx], dist[nx]);
        let cross = || {
            let t = dc / (dc - dn);
            let p = cur.p + (next.p - cur.p) * t;
            (p, g_axis.map_or(0.0, |u| u.dot(p)))
        };
        match (dc <= 0.0, dn <= 0.0) {
            (true, true) => put(*next, g[nx]),
            (true, false) => {
                let (p, gp) = cross();
                put(
                    Vtx {
                        p,
                        inn: cur.out,
                        out: label,
                    },
                    gp,
                );
            }
            (false, true) => {
                let (p, gp) = cross();
                put(
                    Vtx {
                        p,
                        inn: label,
                        out: next.inn,
                    },
                    gp,
                );
                put(*next, g[nx]);
            }
            (false, false) => {}
        }
        (ci, cur, dc) = (nx, next, dn);
    }
    out.n = m;
}

/// Signed distances `±g_k − o` of a polygon's vertices from the side plane `±u·p = o`
/// (`Poly::g`), and whether any vertex is outside (`> 0`, or NaN).
#[inline(always)]
fn side_dist(poly: &Poly, minus: bool, o: f64, dist: &mut [f64; 12]) -> bool {
    let mut outside = false;
    for (d, &g) in dist.iter_mut().zip(&poly.g[..poly.n]) {
        *d = if minus { -g } else { g } - o;
        outside |= !(*d <= 0.0);
    }
    outside
}

/// The two axes after `k` in cyclic order, `((k + 1) mod 3, (k + 2) mod 3)`, without a
/// division.
#[inline]
fn others(k: usize) -> (usize, usize) {
    match k {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    }
}

/// Relative slack of the reference face's side planes in box–box clipping: a point may
/// lie this fraction of the reference box's smallest half extent outside the face.
pub const CLIP_SLACK: f64 = 1e-4;

/// Box `a` (frame `fa`, rotation matrix `ra`, half extents `ha`) against box `b`.
fn box_box(
    (fa, ra): (&Pose, &DMat3),
    ha: DVec3,
    (fb, rb): (&Pose, &DMat3),
    hb: DVec3,
    sink: &mut Sink,
    bufs: &mut ClipBuffers,
) {
    let ua = [ra.x_axis, ra.y_axis, ra.z_axis];
    let ub = [rb.x_axis, rb.y_axis, rb.z_axis];
    let t = fb.x - fa.x;
    let proj = |h: DVec3, u: &[DVec3; 3], l: DVec3| {
        h.x * u[0].dot(l).abs() + h.y * u[1].dot(l).abs() + h.z * u[2].dot(l).abs()
    };
    let sep = |l: DVec3| t.dot(l).abs() - proj(ha, &ua, l) - proj(hb, &ub, l);
    // The 15 axes' separations from `R_ij = u_a,i · u_b,j` and `t` in both frames
    // (Gottschalk et al. 1996, OBBTree, table 1): the same quantities as `sep` on
    // each axis (up to rounding) for 9 dot products instead of 6 per axis. They only
    // choose the axis (and stop early); the edge case's depth is `sep` of the chosen
    // axis, as before.
    // The rows of `R` and `|R|` (lane `j`), and `t` in both frames. The separations
    // below are computed three axes at a time, lane-wise: each lane is its axis's
    // scalar expression, the same operations in the same order (the same bits).
    // Built as vectors (built as arrays and then mapped to vectors, they were copied
    // through the stack 16 and 8 bytes at a time and read back 16 bytes across two of
    // those stores: a store-forwarding stall a pair, 6.8 % of the narrow phase's
    // wall-time samples on the 10-box stack, `perf record`).
    let row = |a: DVec3| DVec3::new(a.dot(ub[0]), a.dot(ub[1]), a.dot(ub[2]));
    let rv = [row(ua[0]), row(ua[1]), row(ua[2])];
    let arv = rv.map(DVec3::abs);
    let ta = [t.dot(ua[0]), t.dot(ua[1]), t.dot(ua[2])];
    let tb = [t.dot(ub[0]), t.dot(ub[1]), t.dot(ub[2])];
    // Best face of A, face of B, edge pair.
    let mut face_a = (f64::NEG_INFINITY, 0usize);
    let mut face_b = (f64::NEG_INFINITY, 0usize);
    let mut edge = (f64::NEG_INFINITY, 0usize, 0usize);
    // Lane i: |t·a_i| − h_a,i − Σ_j h_b,j |R_ij| (the columns of |R| scaled by h_b).
    let col = |j: usize| DVec3::new(arv[0][j], arv[1][j], arv[2][j]);
    let sep_a = DVec3::from_array(ta).abs() - ha - (hb.x * col(0) + hb.y * col(1) + hb.z * col(2));
    // Lane j: |t·b_j| − Σ_i h_a,i |R_ij| − h_b,j.
    let sep_b = DVec3::from_array(tb).abs() - (ha.x * arv[0] + ha.y * arv[1] + ha.z * arv[2]) - hb;
    for i in 0..3 {
        let s = sep_a[i];
        if s > sink.margin {
            return;
        }
        if s > face_a.0 {
            face_a = (s, i);
        }
    }
    for j in 0..3 {
        let s = sep_b[j];
        if s > sink.margin {
            return;
        }
        if s > face_b.0 {
            face_b = (s, j);
        }
    }
    // Prefer faces of A, then faces of B, then edges, by small tolerances, so resting
    // contact keeps one reference face from frame to frame: an edge axis wins only
    // where its separation exceeds `edge_thr`.
    let tol = 1e-3 * ha.min_element().min(hb.min_element());
    let (face_sep, ref_is_b) = if face_b.0 > face_a.0 + 0.01 * face_a.0.abs() + tol {
        (face_b.0, true)
    } else {
        (face_a.0, false)
    };
    let edge_thr = face_sep + 0.05 * face_sep.abs() + tol;
    // An edge axis whose separation's numerator is `≤ 0` has `s = num / |l| ≤ 0`
    // (`|l| > 0`), so with `margin ≥ 0` and `edge_thr ≥ 0` it neither separates
    // (`s > margin`) nor wins (`s > edge_thr`), nor is it the first maximum of the
    // axes above `edge_thr` when another axis wins: skipped without its `|l|` and
    // division, the same result bit for bit (NaN fails `≤` and takes the full path).
    let skip_overlapping = sink.margin >= 0.0 && edge_thr >= 0.0;
    // The nine edge axes, `i` major and `j` minor (the first of equal separations
    // wins), the three of one `i` lane-wise (`edge_row!`, constant `i`): a row whose
    // three numerators are all `≤ 0` is skipped whole (`skip_overlapping`).
    macro_rules! edge_row {
        ($i:literal) => {{
            let (i, i1, i2) = ($i, ($i + 1) % 3, ($i + 2) % 3);
            // a_i × b_j in A's frame is (0, −R_i2,j, R_i1,j) at (i, i1, i2); lane j
            // of `num` is the numerator |t·l| − h_a,i1 |R_i2,j| − h_a,i2 |R_i1,j|
            // − h_b,j1 |R_i,j2| − h_b,j2 |R_i,j1| of the separation along l / |l|
            // (`yzx`, `zxy`: lane j reads j1 = j + 1, j2 = j + 2 mod 3).
            let tl = rv[i1] * ta[i2] - rv[i2] * ta[i1];
            let num = tl.abs()
                - (arv[i2] * ha[i1] + arv[i1] * ha[i2])
                - (hb.yzx() * arv[i].zxy() + hb.zxy() * arv[i].yzx());
            if !(skip_overlapping && num.cmple(DVec3::ZERO).all()) {
                for j in 0..3 {
                    if !(skip_overlapping && num[j] <= 0.0) {
                        let len = sqrt(rv[i2][j] * rv[i2][j] + rv[i1][j] * rv[i1][j]);
                        if len >= 1e-6 {
                            let s = num[j] / len;
                            if s > sink.margin {
                                return;
                            }
                            if s > edge.0 {
                                edge = (s, i, j);
                            }
                        }
                    }
                }
            }
        }};
    }
    edge_row!(0);
    edge_row!(1);
    edge_row!(2);
    if edge.0 > edge_thr {
        // Edge–edge: the supporting edges of A (towards +n) and B (towards −n).
        let (_, i, j) = edge;
        let l = ua[i].cross(ub[j]);
        let mut l = l / l.length();
        let s = sep(l);
        if t.dot(l) < 0.0 {
            l = -l;
        }
        let mut ca = fa.x;
        let mut bits_a = 0u64;
        for m in 0..3 {
            if m != i {
                let sg = sign(ua[m].dot(l));
                ca += ua[m] * (sg * ha[m]);
                bits_a |= u64::from(sg < 0.0) << m;
            }
        }
        let mut cb = fb.x;
        let mut bits_b = 0u64;
        for m in 0..3 {
            if m != j {
                let sg = -sign(ub[m].dot(l));
                cb += ub[m] * (sg * hb[m]);
                bits_b |= u64::from(sg < 0.0) << m;
            }
        }
        let (_, _, pa, pb) = closest_segments(
            ca - ua[i] * ha[i],
            ca + ua[i] * ha[i],
            cb - ub[j] * hb[j],
            cb + ub[j] * hb[j],
        );
        let id =
            (1u64 << 20) | ((i as u64) << 14) | (bits_a << 10) | ((j as u64) << 6) | (bits_b << 2);
        // Witnesses consistent with the SAT depth along l.
        let mid = (pa + pb) * 0.5;
        sink.push(mid + l * (0.5 * -s), mid - l * (0.5 * -s), l, -s, id);
        return;
    }
    // Face contact: reference box R (face `i`, outward normal n towards the other box),
    // incident box I.
    let (fr, hr, ur, hi, ui, ci, i) = if ref_is_b {
        (fb, hb, &ub, ha, &ua, fa.x, face_b.1)
    } else {
        (fa, ha, &ua, hb, &ub, fb.x, face_a.1)
    };
    // The products the face needs are entries of `R` and `t` in both frames: the
    // reference axis against the centre offset `ur_i · (c_I − c_R)` is `ta_i`, or
    // `−tb_i` with B as reference, and the incident axes against it, `u_I,m · u_R,i`,
    // `R_im` (`R_mi`). Products commute exactly and the sums run in the same order, so
    // these are the dot products as computed before up to the sign of a zero, which
    // no test below reads (`< 0`, `|·|`, [`sign`]).
    let flip = if ref_is_b { tb[i] > 0.0 } else { ta[i] < 0.0 };
    let n = if flip { -ur[i] } else { ur[i] };
    let ref_face = (2 * i + usize::from(flip)) as u64;
    // `u_I,m · n`, up to the sign of a zero, for m = 0, 1, 2 (read once).
    let col = if ref_is_b {
        [rv[0][i], rv[1][i], rv[2][i]]
    } else {
        rv[i].to_array()
    };
    let along = if flip {
        [-col[0], -col[1], -col[2]]
    } else {
        col
    };
    // Incident face: the face of I most anti-parallel to n.
    let mut k = 0;
    for m in 1..3 {
        if along[m].abs() > along[k].abs() {
            k = m;
        }
    }
    let sk = -sign(along[k]);
    let inc_face = (2 * k + usize::from(sk < 0.0)) as u64;
    let (k1, k2) = others(k);
    let fc = ci + ui[k] * (sk * hi[k]);
    let e1 = ui[k1] * hi[k1];
    let e2 = ui[k2] * hi[k2];
    let corners = [fc + e1 + e2, fc - e1 + e2, fc - e1 - e2, fc + e1 - e2];
    let [first, second] = &mut bufs.polys;
    let (mut poly, mut spare) = (first, second);
    poly.n = 4;
    for (c, &p) in corners.iter().enumerate() {
        poly.v[c] = Vtx {
            p,
            inn: ((c + 3) % 4) as u8,
            out: c as u8,
        };
    }
    let (i1, i2) = others(i);
    // The side planes are pushed out by `CLIP_SLACK` of the reference box's smallest
    // half extent, so an incident vertex lying on a side (equal boxes stacked flush)
    // stays a vertex, whatever the rounding, and keeps its id.
    let slack = CLIP_SLACK * hr.min_element();
    // Each plane clips `poly` into `spare` and the two swap; a plane with every vertex
    // inside leaves `poly` as it is and moves its first vertex on by one (`clip`). The
    // two planes of a side axis share the vertices' `g = u · p` (`Poly`).
    let mut start = 0;
    let mut dist = [0.0; 12];
    for (m, label) in [(i1, 4u8), (i2, 6)] {
        let u = ur[m];
        let c = u.dot(fr.x);
        // `(±u)·c_R + h_m + slack` (`(−u)·x = −(u·x)` exactly); a vertex is inside a
        // plane where `±g − o ≤ 0`.
        let (op, om) = (c + hr[m] + slack, -c + hr[m] + slack);
        let (mut out_p, mut out_m) = (false, false);
        for (g, v) in poly.g.iter_mut().zip(&poly.v[..poly.n]) {
            *g = u.dot(v.p);
            out_p |= !(*g - op <= 0.0);
            out_m |= !(-*g - om <= 0.0);
        }
        if out_p {
            side_dist(poly, false, op, &mut dist);
            clip(poly, start, &dist, Some(u), label, spare);
            core::mem::swap(&mut poly, &mut spare);
            if poly.n == 0 {
                return;
            }
            start = 0;
            // Whether the new vertices (on the `+` plane) are all inside the `−` one.
            out_m = side_dist(poly, true, om, &mut dist);
        } else {
            start = wrap(start + 1, poly.n);
        }
        if out_m {
            side_dist(poly, true, om, &mut dist);
            clip(poly, start, &dist, None, label + 1, spare);
            core::mem::swap(&mut poly, &mut spare);
            if poly.n == 0 {
                return;
            }
            start = 0;
        } else {
            start = wrap(start + 1, poly.n);
        }
    }
    let plane = n.dot(fr.x) + hr[i];
    let base = (u64::from(ref_is_b) << 12) | (ref_face << 9) | (inc_face << 6);
    let sgn = if ref_is_b { -1.0 } else { 1.0 };
    let mut at = start;
    if poly.n <= 4 {
        // At most four points: all kept ([`reduce`]), pushed in polygon order as they
        // come.
        for _ in 0..poly.n {
            let v = &poly.v[at];
            let depth = plane - n.dot(v.p);
            if depth >= -sink.margin {
                face_point(
                    sink,
                    (n, sgn, ref_is_b),
                    v.p,
                    depth,
                    base | (u64::from(v.inn) * 8 + u64::from(v.out)),
                );
            }
            at = wrap(at + 1, poly.n);
        }
        return;
    }
    let pts = &mut bufs.pts;
    let mut np = 0;
    for _ in 0..poly.n {
        let v = &poly.v[at];
        let depth = plane - n.dot(v.p);
        if depth >= -sink.margin {
            pts[np] = (v.p, depth, u64::from(v.inn) * 8 + u64::from(v.out));
            np += 1;
        }
        at = wrap(at + 1, poly.n);
    }
    let keep = reduce(&pts[..np], n);
    for (idx, &(p, depth, vid)) in pts[..np].iter().enumerate() {
        if keep[idx] {
            face_point(sink, (n, sgn, ref_is_b), p, depth, base | vid);
        }
    }
}

/// A face contact's point `p` on the incident face at `depth` below the reference face
/// (outward normal `n`; `sgn = −1` when B is the reference box): witnesses `p + n·depth`
/// on the reference face and `p`; native order a = A, b = B, normal from A to B.
#[inline(always)]
fn face_point(
    sink: &mut Sink,
    (n, sgn, ref_is_b): (DVec3, f64, bool),
    p: DVec3,
    depth: f64,
    id: u64,
) {
    let on_ref = p + n * depth;
    let (pa, pb) = if ref_is_b { (p, on_ref) } else { (on_ref, p) };
    sink.push(pa, pb, n * sgn, depth, id);
}

/// Which of up to 12 manifold points to keep (at most 4): the deepest, the farthest
/// from it, and the two spanning the largest triangles on either side of that segment.
/// Near ties (rectangles make exact ones) go to the deeper point, then the lower id, so
/// the choice does not depend on rounding.
fn reduce(pts: &[(DVec3, f64, u64)], n: DVec3) -> [bool; 12] {
    let mut keep = [false; 12];
    if pts.len() <= 4 {
        keep[..pts.len()].fill(true);
        return keep;
    }
    let mut size = 0.0f64;
    for p in pts {
        size = size.max((p.0 - pts[0].0).length());
    }
    let tol_d = 1e-9 * size;
    // Is candidate `k` (score `a`) better than `best` (score `b`), scores compared to
    // within `tol`?
    let better = |a: f64, k: usize, b: f64, best: usize, tol: f64| {
        if a > b + tol {
            return true;
        }
        if a < b - tol {
            return false;
        }
        let (dk, db) = (pts[k].1, pts[best].1);
        dk > db + tol_d || (dk >= db - tol_d && pts[k].2 < pts[best].2)
    };
    let mut i0 = 0;
    for k in 1..pts.len() {
        if better(pts[k].1, k, pts[i0].1, i0, tol_d) {
            i0 = k;
        }
    }
    let p0 = pts[i0].0;
    let dist2 = |k: usize| (pts[k].0 - p0).length_squared();
    let mut i1 = usize::from(i0 == 0);
    for k in 0..pts.len() {
        if k != i0 && better(dist2(k), k, dist2(i1), i1, tol_d * size) {
            i1 = k;
        }
    }
    let e = pts[i1].0 - p0;
    let area = |k: usize| e.cross(pts[k].0 - p0).dot(n);
    let tol_a = tol_d * size;
    let (mut i2, mut i3) = (None::<usize>, None::<usize>);
    for k in 0..pts.len() {
        if k == i0 || k == i1 {
            continue;
        }
        let a = area(k);
        if a > tol_a && i2.is_none_or(|b| better(a, k, area(b), b, tol_a)) {
            i2 = Some(k);
        }
        if a < -tol_a && i3.is_none_or(|b| better(-a, k, -area(b), b, tol_a)) {
            i3 = Some(k);
        }
    }
    for k in [Some(i0), Some(i1), i2, i3].into_iter().flatten() {
        keep[k] = true;
    }
    keep
}
