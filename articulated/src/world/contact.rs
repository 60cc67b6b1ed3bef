//! Colliders and contact rows in the jointed world (feature `contact`).
//!
//! A contact point with normal `n` (from collider `a` to `b`) keeps the lecture's gap
//! `d = nᵀ(p_b − p_a) ≥ 0` with impulse `λ ≥ 0` and `d λ = 0`; two tangent rows carry
//! Coulomb friction `|λ_t| ≤ μ λ` (pyramidal cone). The rows go into the same
//! complementarity problem as the joint limits ([`super::unilateral`]), coupled through
//! the joints' tree factorization, so a chain lying on the floor feels its links' joints
//! and the floor in one solve.
//!
//! Pair filter (MuJoCo's): two colliders meet when `contype₁ & conaffinity₂` or
//! `contype₂ & conaffinity₁` is non-zero, they are on different bodies, the two bodies
//! are not joined by a joint (parent–child filtering; the world is exempt), and the
//! body pair was not excluded ([`World::exclude_pair`]).

use constraint_contact::geometry::{
    generate_contacts_listed, generate_contacts_masked, generate_contacts_masked_pairs, Collider,
    Contact, PairMask, Shape,
};
use constraint_contact::lcp::RowBound;
use constraint_core::{DVec3, Pose};

use super::unilateral::{gather, row_bias, RowSource, URow};
use super::*;

/// MuJoCo's collision bits of a collider: the pair `(i, j)` is tested when
/// `contype_i & conaffinity_j != 0` or `contype_j & conaffinity_i != 0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionFilter {
    /// `contype`.
    pub contype: u32,
    /// `conaffinity`.
    pub conaffinity: u32,
}

impl Default for CollisionFilter {
    /// `contype = conaffinity = 1` (MuJoCo's default).
    fn default() -> Self {
        Self {
            contype: 1,
            conaffinity: 1,
        }
    }
}

/// What the position projection allows past the slop (m): see
/// `World::max_contact_violation`.
const CONTACT_ALLOWANCE: f64 = 1e-9;

/// A contact as the position projection sees it: its bodies, its witness points in
/// their body frames (in the world frame for the static world) and its normal (world,
/// fixed over the step).
#[derive(Clone, Copy, Debug)]
pub(super) struct ProjectionContact {
    a: Option<usize>,
    b: Option<usize>,
    la: DVec3,
    lb: DVec3,
    n: DVec3,
    /// The radii of the sides that are spheres or capsules, summed: their points are
    /// carried as the centres of curvature (the surface point of a turning sphere is
    /// not its lowest point any more).
    rounding: f64,
}

/// The contacts of the position projection and its scratch (kept across steps).
#[derive(Clone, Debug, Default)]
pub(super) struct Projection {
    /// This step's contacts.
    pub(super) contacts: Vec<ProjectionContact>,
    /// The rows of the complementarity problem of one iteration.
    rows: Vec<URow>,
    /// Their impulses.
    z: Vec<f64>,
    /// The joint solve's step `δ_free`.
    free: Vec<f64>,
    /// The poses the contacts were generated at.
    poses: Vec<Pose>,
    /// The generated contacts.
    found: Vec<Contact>,
    /// The collider pairs listed by the last sweep of the first contact generation
    /// (sorted), the body poses they were listed at, and what they hold for
    /// ([`NearPairs`]).
    near: Vec<(usize, usize)>,
    anchor: Vec<Pose>,
    /// Per body, the largest `|p| + r` of its colliders (offset and bounding radius;
    /// negative without colliders), for [`World::near_pairs_hold`].
    lever: Vec<f64>,
    near_for: Option<NearPairs>,
}

/// What the listed pairs (`Projection::near`) hold for: the pair filter they were
/// listed under, and the growth of their boxes at the poses they were listed at.
///
/// A sweep of the first contact generation, margin `M` (`margin + 2 r h`), lists the
/// allowed pairs whose boxes overlap grown by `M / 2 + e` each (`e` =
/// [`NEAR_EXTRA`] · margin: a skin, as a Verlet list's). A tight box (sphere, box,
/// capsule: `Collider::aabb_framed`) of a collider whose points moved by at most `d`
/// since lies within its old box grown by `d`, so two boxes that overlap grown by
/// `m / 2` (a later generation's margin `m`: the next steps' first, the position
/// projection's) at the new poses overlapped at the listed ones grown by `m / 2 + d_a`
/// and `m / 2 + d_b`; with `m + d_a + d_b ≤ M + 2 e` every such pair is listed, and the
/// contacts come out the same, in the same order, from the listed pairs alone
/// (`generate_contacts_listed`), without the sweep. Only a swept mask lists its pairs
/// (humanoid_CMU's 1 100 allowed pairs; dm humanoid's few per collider are tested
/// directly, which a list would not make cheaper).
#[derive(Clone, Copy, Debug, PartialEq)]
struct NearPairs {
    /// `PairFilter::built_for` when the pairs were listed.
    filter: (usize, usize, usize),
    /// `M + 2 e` (m): the most `m + d_a + d_b` may be (less [`NEAR_SLACK`]).
    cover: f64,
}

/// The listing's skin `e`, as a fraction of the margin (each box; the
/// `generate_contacts_masked_pairs`' `extra`): the list then holds while the
/// colliders' moves since it was made stay within it (and the start's `2 r h`). The
/// listed pairs' boxes are tested at every generation (about 15 instructions a
/// pair), so the skin is kept small.
const NEAR_EXTRA: f64 = 0.25;

/// Kept from [`NearPairs::cover`] for the rounding of the boxes' bounds (m): far
/// above it (coordinates of metres carry about 1e-15 m), far below any motion that
/// matters.
const NEAR_SLACK: f64 = 1e-9;

/// The collider pairs that may ever touch: on different bodies and passing
/// [`may_touch`] (filter bits, parent–child, exclusions). None of these changes during
/// a run, so the mask is built once (again only after a collider, exclusion or joint
/// was added) and contact generation looks it up for the pairs its sweep meets
/// ([`generate_contacts_masked`]) instead of calling the filter on every overlapping
/// pair: the same contacts in the same order.
#[derive(Clone, Debug, Default)]
pub(super) struct PairFilter {
    /// The numbers of colliders, excluded pairs and joints the mask was built for
    /// (each only grows).
    built_for: (usize, usize, usize),
    /// The allowed pairs.
    mask: PairMask,
}

impl World {
    /// Rebuilds the pair mask ([`PairFilter`]) if a collider, exclusion or joint was
    /// added since it was built; `O(n² J)` for `n` colliders and `J` joints, once.
    fn update_pair_filter(&mut self) {
        let key = (self.colliders.len(), self.excluded.len(), self.joints.len());
        if self.pair_filter.built_for == key {
            return;
        }
        let (filters, colliders, excluded, joints) =
            (&self.filters, &self.colliders, &self.excluded, &self.joints);
        let n = colliders.len();
        let mut mask = PairMask::new(n);
        for i in 0..n {
            for j in i + 1..n {
                if colliders[i].body != colliders[j].body
                    && may_touch(filters, colliders, excluded, joints, i, j)
                {
                    // In range by construction: `allow` cannot fail.
                    let _ = mask.allow(i, j);
                }
            }
        }
        self.pair_filter = PairFilter {
            built_for: key,
            mask,
        };
    }

    /// Adds a collider (its body must exist; `None` is the static world) with the
    /// default filter; returns its index.
    pub fn add_collider(&mut self, c: Collider) -> Result<usize, ArticulatedError> {
        self.add_collider_filtered(c, CollisionFilter::default())
    }

    /// Adds a collider with MuJoCo's `contype`/`conaffinity` bits; returns its index.
    /// Errors: unknown body, a collider the contact crate rejects (re-validated).
    pub fn add_collider_filtered(
        &mut self,
        c: Collider,
        filter: CollisionFilter,
    ) -> Result<usize, ArticulatedError> {
        let k = self.colliders.len();
        if c.body.is_some_and(|b| b >= self.bodies.len()) {
            return Err(ArticulatedError::InvalidCollider {
                collider: k,
                reason: "unknown body",
            });
        }
        let checked =
            Collider::new(c.body, c.shape, c.local, c.friction, c.restitution).map_err(|e| {
                ArticulatedError::Geometry {
                    collider: k,
                    error: e,
                }
            })?;
        self.colliders.push(checked);
        self.filters.push(filter);
        Ok(k)
    }

    /// Never generates contacts between bodies `a` and `b` (`None`: the world), as
    /// MJCF's `contact/exclude`. Errors: unknown body.
    pub fn exclude_pair(
        &mut self,
        a: Option<usize>,
        b: Option<usize>,
    ) -> Result<(), ArticulatedError> {
        let n = self.bodies.len();
        if a.is_some_and(|i| i >= n) || b.is_some_and(|i| i >= n) {
            return Err(ArticulatedError::InvalidParameter {
                name: "exclude_pair",
                rule: "bodies must exist",
            });
        }
        let key = pair_key(a, b);
        if let Err(pos) = self.excluded.binary_search(&key) {
            self.excluded.insert(pos, key);
        }
        Ok(())
    }

    /// The colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// The contact points of the last step (at its start).
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Contact generation at the start of the step and the contact rows (normal, then
    /// two tangents per point; restitution from the velocities before the step).
    pub(super) fn push_contact_rows(&mut self, ctx: &StepContext) -> Result<(), ArticulatedError> {
        self.ustats.contacts = 0;
        self.ustats.max_penetration = 0.0;
        if self.colliders.is_empty() {
            self.contacts.clear();
            return Ok(());
        }
        let s = self.unilateral;
        let h = ctx.h();
        let mut poses = core::mem::take(&mut self.poses);
        poses.clear();
        poses.extend(self.bodies.iter().map(|b| b.pose));
        let mut contacts = core::mem::take(&mut self.contacts);
        self.update_pair_filter();
        // Speculative rows must reach every pair the step can close: the narrow phase
        // looks `margin + 2 r h` out (`r` the fastest collider's point speed bound), and
        // a pair beyond `margin` is kept when its normal rate covers the rest within
        // the step (as the limit rows do). A fixed 2 cm let a foot of gymnasium's ant
        // (`h` = 0.01 s, over 3.5 m/s) pass the margin in one step and start the next
        // 1.5 cm deep.
        let reach = self.collider_reach();
        let wide = s.margin + 2.0 * reach * h;
        // The listed pairs where they hold every pair that can meet here
        // ([`NearPairs`]); else a sweep, listing the pairs again from these poses.
        let result = if self.near_pairs_hold(wide) {
            generate_contacts_listed(
                &self.colliders,
                &poses,
                wide,
                &self.projection.near,
                &mut self.broad,
                &mut contacts,
            )
        } else {
            let extra = NEAR_EXTRA * s.margin;
            let listed = generate_contacts_masked_pairs(
                &self.colliders,
                &poses,
                wide,
                extra,
                &self.pair_filter.mask,
                &mut self.broad,
                &mut contacts,
                &mut self.projection.near,
            );
            // Listed only where the mask is swept (many pairs per collider).
            self.projection.near_for = match listed {
                Ok((_, true)) => {
                    self.projection.anchor.clone_from(&poses);
                    let lever = &mut self.projection.lever;
                    lever.clear();
                    lever.resize(poses.len(), -1.0);
                    for c in &self.colliders {
                        if let Some(i) = c.body {
                            // The bound needs a tight box (`Collider::aabb_framed`);
                            // a shape without one has none (a sweep every call).
                            let l = match c.shape {
                                Shape::Sphere { .. }
                                | Shape::Box { .. }
                                | Shape::Capsule { .. } => {
                                    c.local.x.length() + c.shape.bounding_radius()
                                }
                                Shape::Plane { .. } => f64::INFINITY,
                            };
                            // NaN (never: validated shapes) would stay negative: kept
                            // out of the bound, so mark it infinite instead.
                            lever[i] = if l.is_nan() {
                                f64::INFINITY
                            } else {
                                lever[i].max(l)
                            };
                        }
                    }
                    Some(NearPairs {
                        filter: self.pair_filter.built_for,
                        cover: wide + 2.0 * extra,
                    })
                }
                _ => None,
            };
            listed.map(|(stats, _)| stats)
        };
        self.poses = poses;
        if let Err(e) = result {
            self.contacts = contacts;
            return Err(ArticulatedError::Geometry {
                collider: usize::MAX,
                error: e,
            });
        }
        if reach > 0.0 {
            contacts.retain(|c| {
                -c.depth < s.margin || -c.depth < s.margin + (self.contact_rate(c) * h).abs()
            });
        }
        self.ustats.contacts = contacts.len();
        self.ustats.max_penetration = contacts.iter().map(|c| c.depth).fold(0.0, f64::max);
        for (k, c) in contacts.iter().enumerate() {
            let (ca, cb) = (&self.colliders[c.a], &self.colliders[c.b]);
            let (ia, ib) = (ca.body, cb.body);
            let r_a = ia.map_or(DVec3::ZERO, |i| c.point_on_a() - self.bodies[i].pose.x);
            let r_b = ib.map_or(DVec3::ZERO, |i| c.point_on_b() - self.bodies[i].pose.x);
            let n = c.normal;
            let (t1, t2) = n.any_orthonormal_pair();
            let rate = |d: DVec3| {
                let va = ia.map_or(DVec3::ZERO, |i| {
                    self.bodies[i].v + self.bodies[i].omega.cross(r_a)
                });
                let vb = ib.map_or(DVec3::ZERO, |i| {
                    self.bodies[i].v + self.bodies[i].omega.cross(r_b)
                });
                d.dot(vb - va)
            };
            // The gap is d = −depth: speculative below the margin, Baumgarte beyond slop.
            let mut bias = row_bias(-c.depth, ctx, &s);
            let e = ca.restitution.max(cb.restitution);
            let vn = rate(n);
            if e > 0.0 && vn < -self.restitution_threshold {
                bias = bias.max(-e * vn);
            }
            let mu = ca.friction.max(cb.friction);
            let normal_row = self.urows.len();
            for (axis, d) in [(0u8, n), (1, t1), (2, t2)] {
                self.urows.push(URow {
                    a: ia,
                    b: ib,
                    j: [-d, -r_a.cross(d), d, r_b.cross(d)],
                    bias: if axis == 0 { bias } else { 0.0 },
                    bound: if axis == 0 {
                        RowBound::Unilateral
                    } else {
                        RowBound::Friction {
                            normal: normal_row,
                            mu,
                        }
                    },
                    source: RowSource::Contact { contact: k, axis },
                });
            }
        }
        self.contacts = contacts;
        Ok(())
    }

    /// A bound on the speed of any point of a collider on a moving body,
    /// `max (|v| + |ω| (|p| + r))` over the colliders (`p` the collider's offset in its
    /// body, `r` its shape's bounding radius; a plane on a body counts its body's `|v|`
    /// only), m/s; 0 without moving colliders.
    fn collider_reach(&self) -> f64 {
        let mut reach: f64 = 0.0;
        for c in &self.colliders {
            let Some(i) = c.body else { continue };
            let b = &self.bodies[i];
            let r = c.shape.bounding_radius();
            let lever = if r.is_finite() {
                c.local.x.length() + r
            } else {
                0.0
            };
            reach = reach.max(b.v.length() + b.omega.length() * lever);
        }
        if reach.is_finite() {
            reach
        } else {
            0.0
        }
    }

    /// The normal rate `nᵀ(v_b − v_a)` of contact `c`'s witness points (m/s).
    fn contact_rate(&self, c: &Contact) -> f64 {
        let point_velocity = |k: usize, p: DVec3| {
            self.colliders[k].body.map_or(DVec3::ZERO, |i| {
                let b = &self.bodies[i];
                b.v + b.omega.cross(p - b.pose.x)
            })
        };
        c.normal
            .dot(point_velocity(c.b, c.point_on_b()) - point_velocity(c.a, c.point_on_a()))
    }

    /// Loads the contacts for the position projection: contact generation at the
    /// current poses (the velocity level's end, so a pair that closed within the step
    /// without a row at its start is held too: a finger of humanoid_CMU, light and
    /// driven hard, started steps 4 mm inside the next one), with the narrow phase's
    /// margin; their bodies, points in the body frames and normals.
    pub(super) fn load_projection_contacts(&mut self) {
        let mut pc = core::mem::take(&mut self.projection.contacts);
        pc.clear();
        if self.colliders.is_empty() {
            self.projection.contacts = pc;
            return;
        }
        let mut poses = core::mem::take(&mut self.projection.poses);
        poses.clear();
        poses.extend(self.bodies.iter().map(|b| b.pose));
        let mut found = core::mem::take(&mut self.projection.found);
        self.update_pair_filter();
        let margin = self.unilateral.margin;
        // The listed pairs where they hold every pair that can meet here
        // ([`NearPairs`]): the same contacts without the sweep.
        let near = self.near_pairs_hold(margin);
        // A failure (non-finite poses, which the step reports anyway) leaves the
        // projection without contacts.
        let result = if near {
            generate_contacts_listed(
                &self.colliders,
                &poses,
                margin,
                &self.projection.near,
                &mut self.broad,
                &mut found,
            )
        } else {
            generate_contacts_masked(
                &self.colliders,
                &poses,
                margin,
                &self.pair_filter.mask,
                &mut self.broad,
                &mut found,
            )
        };
        if result.is_err() {
            found.clear();
        }
        for c in &found {
            let (ia, ib) = (self.colliders[c.a].body, self.colliders[c.b].body);
            let local = |b: Option<usize>, p: DVec3| {
                b.map_or(p, |i| {
                    let pose = poses[i];
                    pose.q.inverse() * (p - pose.x)
                })
            };
            let radius = |k: usize| match self.colliders[k].shape {
                Shape::Sphere { radius } | Shape::Capsule { radius, .. } => radius,
                _ => 0.0,
            };
            let (ra, rb) = (radius(c.a), radius(c.b));
            // Centres of curvature: inside `a` against the normal, inside `b` along it.
            pc.push(ProjectionContact {
                a: ia,
                b: ib,
                la: local(ia, c.point_on_a() - c.normal * ra),
                lb: local(ib, c.point_on_b() + c.normal * rb),
                n: c.normal,
                rounding: ra + rb,
            });
        }
        self.projection.contacts = pc;
        self.projection.poses = poses;
        self.projection.found = found;
    }

    /// Whether the listed pairs hold every pair whose boxes can meet at the current
    /// poses in a generation of margin `margin` ([`NearPairs`]): listed under the
    /// current pair filter, every collider's box tight, and `margin` plus the two
    /// largest displacements of a body's collider points since the listing within the
    /// cover less [`NEAR_SLACK`] (two colliders of a pair are on two bodies). A body's
    /// points move by `d ≤ |Δx| + 2 |q_v| ρ` (`Δx` its move, `q_v` the vector part of
    /// its rotation since, `sin(θ/2)` long: a point at `ρ` from the body's origin
    /// moves `2 sin(θ/2) ρ` at most by the rotation; `ρ` the largest `|p| + r` of its
    /// colliders, offset and bounding radius).
    fn near_pairs_hold(&self, margin: f64) -> bool {
        let Some(near) = self.projection.near_for else {
            return false;
        };
        let budget = near.cover - margin - NEAR_SLACK;
        let (anchor, lever) = (&self.projection.anchor, &self.projection.lever);
        if !(budget >= 0.0)
            || near.filter != self.pair_filter.built_for
            || anchor.len() != self.bodies.len()
            || lever.len() != self.bodies.len()
        {
            return false;
        }
        let (mut d1, mut d2) = (0.0f64, 0.0f64);
        for ((b, p0), &l) in self.bodies.iter().zip(anchor).zip(lever) {
            if l < 0.0 {
                continue;
            }
            let p1 = &b.pose;
            let rel = p1.q * p0.q.conjugate();
            let turn = DVec3::new(rel.x, rel.y, rel.z).length();
            let d = (p1.x - p0.x).length() + 2.0 * turn * l;
            // NaN or infinite (a plane on a body): no bound.
            if !(d < f64::INFINITY) {
                return false;
            }
            if d > d1 {
                (d1, d2) = (d, d1);
            } else if d > d2 {
                d2 = d;
            }
            if d1 + d2 > budget {
                return false;
            }
        }
        true
    }

    /// The gap `d = nᵀ(p_b − p_a) − ρ` of a projection contact at the current poses
    /// (its points carried by their bodies, the normal fixed in the world, `ρ` the
    /// rounded sides' radii) and its row `[−n, −r_a × n, n, r_b × n]` (the same through
    /// a centre of curvature as through the surface point: they differ along `n`).
    fn projection_gap(&self, c: &ProjectionContact) -> (f64, [DVec3; 4]) {
        let at = |b: Option<usize>, l: DVec3| {
            b.map_or((l, DVec3::ZERO), |i| {
                let pose = &self.bodies[i].pose;
                let r = pose.q * l;
                (pose.x + r, r)
            })
        };
        let ((pa, ra), (pb, rb)) = (at(c.a, c.la), at(c.b, c.lb));
        let n = c.n;
        (
            n.dot(pb - pa) - c.rounding,
            [-n, -ra.cross(n), n, rb.cross(n)],
        )
    }

    /// The deepest penetration of this step's contacts beyond the slop at the current
    /// poses, `max(−d − slop − 10⁻⁹, 0)` (m): what the projection drives to zero. The
    /// 1 nm allowance is below anything physical and above the accuracy of the
    /// complementarity solve (the rows ended near 1e-11 m past the slop, where the
    /// projection's 1e-12 tolerance made it iterate once more without them).
    pub(super) fn max_contact_violation(&self) -> f64 {
        let allowed = self.unilateral.slop + CONTACT_ALLOWANCE;
        self.projection
            .contacts
            .iter()
            .map(|c| -self.projection_gap(c).0 - allowed)
            .fold(0.0, f64::max)
    }

    /// The contacts' one-sided rows in a projection iteration, after the joint solve
    /// whose step `δ_free` is in `self.rhs`: the rows `d + G δ ≥ −slop` that `δ`
    /// violates join a complementarity problem through the factor (`z ≥ 0`: they only
    /// push apart, never pull), `δ = δ_free + Y z` (`World::solve_rows_in_factor`);
    /// rows the push makes violate join and the problem is solved again (at most four
    /// rounds; the next Newton iteration takes what is left). Returns `false` when the
    /// problem could not be solved (the complementarity solvers gave up): `self.rhs` is
    /// back at `δ_free` and the contacts leave this projection.
    pub(super) fn push_contacts_apart(&mut self) -> bool {
        if self.projection.contacts.is_empty() {
            return true;
        }
        let slop = self.unilateral.slop;
        let mut p = core::mem::take(&mut self.projection);
        let loops = core::mem::take(&mut self.last_loops);
        p.free.clone_from(&self.rhs);
        p.rows.clear();
        let mut solved = true;
        for _ in 0..4 {
            let before = p.rows.len();
            for (k, c) in p.contacts.iter().enumerate() {
                if p.rows
                    .iter()
                    .any(|r| matches!(r.source, RowSource::Contact { contact, .. } if contact == k))
                {
                    continue;
                }
                let (gap, j) = self.projection_gap(c);
                let row = URow {
                    a: c.a,
                    b: c.b,
                    j,
                    bias: -(gap + slop),
                    bound: RowBound::Unilateral,
                    source: RowSource::Contact {
                        contact: k,
                        axis: 0,
                    },
                };
                if gather(&self.solver, &self.tendon_spans, &self.rhs, &row) - row.bias < 0.0 {
                    p.rows.push(row);
                }
            }
            if p.rows.len() == before {
                break;
            }
            self.rhs.clone_from(&p.free);
            p.z.clear();
            p.z.resize(p.rows.len(), 0.0);
            if self
                .solve_rows_in_factor(&p.rows, &mut p.z, &loops)
                .is_err()
            {
                self.rhs.clone_from(&p.free);
                p.contacts.clear();
                solved = false;
                break;
            }
        }
        self.last_loops = loops;
        self.projection = p;
        solved
    }

    /// The previous step's contact impulses, matched by contact key (collider pair and
    /// feature id), as the warm start of this step's rows.
    pub(super) fn warm_contacts(&self, rows: &[URow], z: &mut [f64]) {
        for (i, r) in rows.iter().enumerate() {
            let RowSource::Contact { contact, axis } = r.source else {
                continue;
            };
            let key = self.contacts[contact].key();
            if let Ok(p) = self.warm.binary_search_by(|(k, _)| k.cmp(&key)) {
                let (zn, ft) = self.warm[p].1;
                z[i] = match axis {
                    0 => zn,
                    _ => ft.dot(r.j[2]),
                };
            }
        }
    }

    /// Keeps this step's contact impulses for the next step's warm start (friction as a
    /// world vector, so a re-chosen tangent basis still matches).
    pub(super) fn store_warm_contacts(&mut self) {
        self.warm.clear();
        let mut k = 0;
        while k < self.urows.len() {
            if let RowSource::Contact { contact, axis: 0 } = self.urows[k].source {
                let zn = self.uz[k];
                let ft = self.urows[k + 1].j[2] * self.uz[k + 1]
                    + self.urows[k + 2].j[2] * self.uz[k + 2];
                self.warm.push((self.contacts[contact].key(), (zn, ft)));
                k += 3;
            } else {
                k += 1;
            }
        }
        self.warm.sort_by_key(|w| w.0);
    }
}

/// Whether colliders `i` and `j` may touch (filter bits, parent–child, exclusions): a
/// function of the fields it reads, so [`PairFilter`]'s mask is built while the
/// world's other fields are borrowed.
fn may_touch(
    filters: &[CollisionFilter],
    colliders: &[constraint_contact::geometry::Collider],
    excluded: &[(usize, usize)],
    joints: &[super::Joint],
    i: usize,
    j: usize,
) -> bool {
    let (fi, fj) = (filters[i], filters[j]);
    if fi.contype & fj.conaffinity == 0 && fj.contype & fi.conaffinity == 0 {
        return false;
    }
    let (a, b) = (colliders[i].body, colliders[j].body);
    if excluded.binary_search(&pair_key(a, b)).is_ok() {
        return false;
    }
    if let (Some(a), Some(b)) = (a, b) {
        if joints.iter().any(|jt| {
            (jt.parent == Some(a) && jt.child == b) || (jt.parent == Some(b) && jt.child == a)
        }) {
            return false;
        }
    }
    true
}

fn pair_key(a: Option<usize>, b: Option<usize>) -> (usize, usize) {
    let (a, b) = (a.unwrap_or(usize::MAX), b.unwrap_or(usize::MAX));
    (a.min(b), a.max(b))
}
