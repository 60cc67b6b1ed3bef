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

use constraint_contact::geometry::{generate_contacts_with, Collider, Contact};
use constraint_contact::lcp::RowBound;
use constraint_core::DVec3;

use super::unilateral::{row_bias, RowSource, URow};
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

impl World {
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

    /// Whether colliders `i` and `j` may touch (filter bits, parent–child, exclusions).
    fn may_touch(&self, i: usize, j: usize) -> bool {
        let (fi, fj) = (self.filters[i], self.filters[j]);
        if fi.contype & fj.conaffinity == 0 && fj.contype & fi.conaffinity == 0 {
            return false;
        }
        let (a, b) = (self.colliders[i].body, self.colliders[j].body);
        if self.excluded.binary_search(&pair_key(a, b)).is_ok() {
            return false;
        }
        if let (Some(a), Some(b)) = (a, b) {
            if self.joints.iter().any(|jt| {
                (jt.parent == Some(a) && jt.child == b) || (jt.parent == Some(b) && jt.child == a)
            }) {
                return false;
            }
        }
        true
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
        let mut poses = core::mem::take(&mut self.poses);
        poses.clear();
        poses.extend(self.bodies.iter().map(|b| b.pose));
        let mut contacts = core::mem::take(&mut self.contacts);
        let mut broad = core::mem::take(&mut self.broad);
        let keep = |i: usize, j: usize| self.may_touch(i, j);
        let result = generate_contacts_with(
            &self.colliders,
            &poses,
            s.margin,
            keep,
            &mut broad,
            &mut contacts,
        );
        self.poses = poses;
        self.broad = broad;
        if let Err(e) = result {
            self.contacts = contacts;
            return Err(ArticulatedError::Geometry {
                collider: usize::MAX,
                error: e,
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

    /// The previous step's contact impulses, matched by contact key (collider pair and
    /// feature id), as the warm start of this step's rows.
    pub(super) fn warm_contacts(&self, z: &mut [f64]) {
        for (i, r) in self.urows.iter().enumerate() {
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

fn pair_key(a: Option<usize>, b: Option<usize>) -> (usize, usize) {
    let (a, b) = (a.unwrap_or(usize::MAX), b.unwrap_or(usize::MAX));
    (a.min(b), a.max(b))
}
