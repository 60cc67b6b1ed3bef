//! Forces on joint coordinates: actuators (MuJoCo's `motor`, `position`, `velocity`
//! and `general` with fixed gain and affine bias) and joint springs (`stiffness`,
//! `springref`).
//!
//! A degree of freedom `k` of a joint has a coordinate `q_k` (hinge angle, slide
//! displacement, a compound joint's coordinate) and a rate row `G_k` with
//! `q̇_k = G_k v`. A generalized force `τ_k` on it is the body wrench `G_kᵀ τ_k` — equal
//! and opposite on the two bodies, so internal forces and torques sum to zero. Each
//! step adds the impulse `h G_kᵀ τ_k` at the start-of-step state (explicit, as MuJoCo's
//! Euler integrator treats actuator and spring forces), with
//!
//! ```text
//! actuator:  s = clamp(gain·u + b₀ + b₁·(g q) + b₂·(g q̇), forcerange),  τ = g s,
//!            u = clamp(ctrl, ctrlrange)
//! spring:    τ = −k (q − q_ref)
//! ```
//!
//! (`g` the gear). Damping stays implicit in the joint's damping rows.

use alloc::vec::Vec;

use constraint_core::compound::MAX_DOF;
use constraint_core::DVec3;

use super::*;
use crate::joint::{Kept, KeptCoords};

mod impulses;
pub(super) use impulses::DofImpulses;

/// What an actuator drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// Degree of freedom `dof` of `joint` (0 for hinges and slides).
    Dof {
        /// The joint.
        joint: usize,
        /// Its degree of freedom.
        dof: usize,
    },
    /// A tendon ([`World::add_tendon`], [`World::add_spatial_tendon`]).
    Tendon(usize),
}

/// A fixed tendon (MuJoCo's `tendon/fixed`): the length `L = Σ c_i q_i` over joint
/// coordinates, with a spring `−k (L − L₀)` and viscous damping `−d L̇`, both as
/// generalized forces `c_i τ` on its coordinates (explicit). A spatial tendon
/// ([`World::add_spatial_tendon`]) is one with a path as well, whose length adds to
/// the sum and whose force acts through the path (`world/spatial_tendon.rs`).
#[derive(Clone, Debug, PartialEq)]
pub struct Tendon {
    /// `(joint, dof, coefficient)` terms.
    pub terms: alloc::vec::Vec<(usize, usize, f64)>,
    /// Stiffness `k ≥ 0`.
    pub stiffness: f64,
    /// Damping `d ≥ 0`.
    pub damping: f64,
    /// Rest length `L₀` of the spring.
    pub rest_length: f64,
}

/// Which part of the actuator, spring and tendon forces `τ(q, q̇)` to apply: all of it,
/// the part at rest `τ(q, 0)` (what RATTLE's symplectic kicks take), or the
/// velocity-dependent rest `τ(q, q̇) − τ(q, 0)` (velocity actuators' `b₂ q̇`, tendon
/// damping; what RATTLE's damping flow takes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ForcePart {
    Full,
    Position,
    Velocity,
}

/// One actuator on a joint degree of freedom or a tendon, in MuJoCo's general form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actuator {
    /// What it drives.
    pub target: Target,
    /// Gear `g` (MuJoCo's `gear[0]`); zero is allowed and gives no force.
    pub gear: f64,
    /// Gain on the control (`gainprm[0]`; `kp` for `position`, `kv` for `velocity`).
    pub gain: f64,
    /// Affine bias `b₀ + b₁ length + b₂ velocity` (`biasprm[0..3]`).
    pub bias: [f64; 3],
    /// Control clamp (MuJoCo's `ctrlrange` when `ctrllimited`).
    pub ctrl_range: Option<[f64; 2]>,
    /// Force clamp on the scalar actuator force (`forcerange` when `forcelimited`).
    pub force_range: Option<[f64; 2]>,
}

/// A joint spring on one degree of freedom: `τ = −k (q − q_ref)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DofSpring {
    /// The joint.
    pub joint: usize,
    /// Its degree of freedom.
    pub dof: usize,
    /// Stiffness `k ≥ 0` (N·m/rad or N/m).
    pub stiffness: f64,
    /// Rest coordinate `q_ref` (rad or m, in the joint's coordinates: zero at the pose
    /// the joint was built at).
    pub reference: f64,
}

fn range_ok(r: Option<[f64; 2]>) -> bool {
    r.is_none_or(|[lo, hi]| !lo.is_nan() && !hi.is_nan() && lo <= hi)
}

impl World {
    /// Degrees of freedom with a coordinate: 1 for hinges and slides, a compound
    /// joint's count, 0 otherwise (and for an unknown joint).
    pub(super) fn dofs_of(&self, joint: usize) -> usize {
        match self.joints.get(joint).map(|j| &j.kind) {
            Some(JointKind::Hinge(_)) | Some(JointKind::Prismatic(_)) => 1,
            Some(JointKind::Compound(c, _)) => c.dof(),
            _ => 0,
        }
    }

    /// Adds an actuator; returns its index (its control starts at 0). Errors: unknown
    /// joint or degree of freedom (spherical, fixed and distance joints have none),
    /// non-finite gain, gear or bias, ranges with NaN or `lo > hi`.
    pub fn add_actuator(&mut self, a: Actuator) -> Result<usize, ArticulatedError> {
        let k = self.actuators.len();
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "actuator",
            rule,
        };
        let ok = match a.target {
            Target::Dof { joint, dof } => dof < self.dofs_of(joint),
            Target::Tendon(t) => t < self.tendons.len(),
        };
        if !ok {
            return Err(bad(
                "must drive an existing hinge, slide or compound degree of freedom, or a tendon",
            ));
        }
        if !a.gear.is_finite() || !a.gain.is_finite() || a.bias.iter().any(|b| !b.is_finite()) {
            return Err(bad("gear, gain and bias must be finite"));
        }
        if !range_ok(a.ctrl_range) || !range_ok(a.force_range) {
            return Err(bad("ranges need lo <= hi and no NaN"));
        }
        self.actuators.push(a);
        self.ctrl.push(0.0);
        let _ = k;
        Ok(self.actuators.len() - 1)
    }

    /// The actuators.
    pub fn actuators(&self) -> &[Actuator] {
        &self.actuators
    }

    /// Sets actuator `i`'s control. Errors: unknown actuator, non-finite value.
    pub fn set_ctrl(&mut self, i: usize, value: f64) -> Result<(), ArticulatedError> {
        if !value.is_finite() {
            return Err(ArticulatedError::InvalidParameter {
                name: "ctrl",
                rule: "must be finite",
            });
        }
        let Some(c) = self.ctrl.get_mut(i) else {
            return Err(ArticulatedError::InvalidParameter {
                name: "ctrl",
                rule: "unknown actuator",
            });
        };
        *c = value;
        Ok(())
    }

    /// The controls, in actuator order.
    pub fn ctrl(&self) -> &[f64] {
        &self.ctrl
    }

    /// Adds a joint spring. Errors: unknown joint or degree of freedom, negative or
    /// non-finite stiffness, non-finite reference.
    pub fn add_dof_spring(&mut self, s: DofSpring) -> Result<(), ArticulatedError> {
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "joint spring",
            rule,
        };
        if s.dof >= self.dofs_of(s.joint) {
            return Err(bad(
                "must act on an existing hinge, slide or compound degree of freedom",
            ));
        }
        if !(s.stiffness >= 0.0) || !s.stiffness.is_finite() || !s.reference.is_finite() {
            return Err(bad("stiffness must be finite and >= 0, reference finite"));
        }
        self.springs.push(s);
        Ok(())
    }

    /// The joint springs.
    pub fn dof_springs(&self) -> &[DofSpring] {
        &self.springs
    }

    /// Adds a fixed tendon; returns its index. Errors: unknown joint or degree of
    /// freedom, non-finite coefficient, negative or non-finite stiffness or damping,
    /// non-finite rest length.
    pub fn add_tendon(&mut self, t: Tendon) -> Result<usize, ArticulatedError> {
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "tendon",
            rule,
        };
        if t.terms
            .iter()
            .any(|&(j, d, c)| d >= self.dofs_of(j) || !c.is_finite())
        {
            return Err(bad(
                "terms must name existing degrees of freedom with finite coefficients",
            ));
        }
        if !(t.stiffness >= 0.0)
            || !(t.damping >= 0.0)
            || !t.stiffness.is_finite()
            || !t.damping.is_finite()
            || !t.rest_length.is_finite()
        {
            return Err(bad(
                "stiffness and damping finite and >= 0, rest length finite",
            ));
        }
        self.tendons.push(t);
        Ok(self.tendons.len() - 1)
    }

    /// The tendons.
    pub fn tendons(&self) -> &[Tendon] {
        &self.tendons
    }

    /// Potential energy of the joint and tendon springs, `Σ ½ k (q − q_ref)²`.
    pub fn spring_energy(&self) -> f64 {
        if self.springs.is_empty() && self.tendons.iter().all(|t| t.stiffness == 0.0) {
            return 0.0;
        }
        let mut coords = Vec::new();
        self.coordinate_table(&mut coords);
        let q = |j: usize, d: usize| coords[j].as_ref().map_or(0.0, |c| c.q[d]);
        let joints: f64 = self
            .springs
            .iter()
            .map(|s| {
                let e = q(s.joint, s.dof) - s.reference;
                0.5 * s.stiffness * e * e
            })
            .sum();
        let tendons: f64 = self
            .tendons
            .iter()
            .enumerate()
            .map(|(ti, t)| {
                let l: f64 = t.terms.iter().map(|&(j, d, c)| c * q(j, d)).sum::<f64>()
                    + self.path_state(ti).0;
                0.5 * t.stiffness * (l - t.rest_length) * (l - t.rest_length)
            })
            .sum();
        joints + tendons
    }

    /// Coordinates, rates and rate rows of every joint that has coordinates (`None`
    /// for the others), into `out` (cleared first).
    fn coordinate_table(&self, out: &mut Vec<Option<DofState>>) {
        out.clear();
        out.extend((0..self.joints.len()).map(|ji| self.dof_state(ji)));
    }

    /// Joint `ji`'s entry of the coordinate table: coordinates, rates `q̇ = G v` and
    /// rate rows `G`; `None` for joints without coordinates.
    fn dof_state(&self, ji: usize) -> Option<DofState> {
        let mut slot = None;
        self.write_dof_state(ji, &mut slot, true);
        slot
    }

    /// [`Self::dof_state`] written into `slot` in place (an entry of the same joint, or
    /// `None`; the entries beyond the joint's degrees of freedom are zero in both);
    /// the rates as in [`Self::fill_dof_state`] (`rates`).
    fn write_dof_state(&self, ji: usize, slot: &mut Option<DofState>, rates: bool) {
        if self.dofs_of(ji) == 0 {
            *slot = None;
            return;
        }
        let key = self.pose_key(ji);
        let e = slot.get_or_insert(DofState {
            key,
            live: true,
            q: [0.0; MAX_DOF],
            qd: [0.0; MAX_DOF],
            rows: [[DVec3::ZERO; 4]; MAX_DOF],
        });
        e.key = key;
        e.live = true;
        // The world's table when it holds this configuration (a caller with a table of
        // its own, `spring_energy`), else computed.
        if let Some(c) = self.cached_coordinates(ji) {
            (e.q, e.rows) = (c.q, c.rows);
        } else {
            self.compute_coordinates(ji, &mut e.q, &mut e.rows);
        }
        self.fill_rates(ji, e, rates);
    }

    /// The bits of joint `ji`'s parent and child poses ([`CachedRows::key_of`]).
    fn pose_key(&self, ji: usize) -> [u64; 14] {
        let j = &self.joints[ji];
        let a = j.parent.map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
        CachedRows::key_of(a, &self.bodies[j.child].pose)
    }

    /// The rates `q̇_k = G_k v` of `state`'s rows at the current velocities, for the
    /// joint's degrees of freedom (the rest are never read: forces name existing
    /// degrees of freedom only). Without `rates` (forces that read no rates,
    /// [`Self::dof_forces_read_rates`]) the rates are set to zero instead: they enter
    /// the forces only as `b₂ · g · q̇` and `d · L̇` with `b₂ = d = 0`, signed zeros
    /// that leave `τ` with the same bits whatever `q̇` (finite) is. Issue 13: 5 joints'
    /// rates at every force evaluation of dm swimmer6 controlled, 0.7 % of its step.
    fn fill_rates(&self, ji: usize, state: &mut DofState, rates: bool) {
        if !rates {
            state.qd = [0.0; MAX_DOF];
            return;
        }
        let tw = self.twist(&self.joints[ji]);
        for k in 0..self.dofs_of(ji) {
            state.qd[k] = (0..4).map(|s| state.rows[k][s].dot(tw[s])).sum();
        }
    }

    /// Fills joint `ji`'s entry of a lazily built coordinate table (kept if already
    /// live). An entry of an earlier evaluation at the same poses (the bits of both
    /// poses, [`CachedRows::key_of`]) keeps its coordinates and rows — the same
    /// operations on the same bits would give the same values — and takes new rates
    /// `q̇ = G v` (the velocities change between evaluations at one configuration: the
    /// kicks and the damping flow's stages).
    fn fill_dof_state(&self, coords: &mut [Option<DofState>], ji: usize, rates: bool) {
        match &mut coords[ji] {
            Some(e) if e.live => {}
            Some(e) if same_key(&e.key, &self.pose_key(ji)) => {
                e.live = true;
                self.fill_rates(ji, e, rates);
            }
            slot => self.write_dof_state(ji, slot, rates),
        }
    }

    /// The coordinates and rate rows of joint `ji` from the coordinate table of the
    /// last force evaluation when they are at the current poses (same bits as
    /// computing them), else `None`.
    fn cached_coordinates(&self, ji: usize) -> Option<&DofState> {
        let e = self.dof_table.get(ji)?.as_ref()?;
        let j = &self.joints[ji];
        same_key(
            &e.key,
            &CachedRows::key_of(&self.pose(j.parent), &self.pose(Some(j.child))),
        )
        .then_some(e)
    }

    /// The coordinates of joint `ji` alone (those of [`Self::coordinates_and_rows`],
    /// the same bits, without the rate rows: a compound joint's rows cost more than its
    /// coordinates, and the projection's error needs only these); `None` for joints
    /// without coordinates.
    pub(super) fn coordinates_of(&self, ji: usize) -> Option<[f64; MAX_DOF]> {
        if let Some(e) = self.cached_coordinates(ji) {
            return Some(e.q);
        }
        if let Some(e) = self.kept_coordinates(ji) {
            let mut q = e.q;
            self.continue_angles(ji, &mut q);
            return Some(q);
        }
        let j = &self.joints[ji];
        let (a, b) = (self.pose(j.parent), self.pose(Some(j.child)));
        let mut q = [0.0; MAX_DOF];
        match &j.kind {
            JointKind::Hinge(c) => q[0] = c.angle(&a, &b),
            JointKind::Prismatic(c) => q[0] = c.displacement(&a, &b),
            JointKind::Compound(c, _) => q = c.coordinates(&a, &b, &q),
            _ => return None,
        }
        self.continue_angles(ji, &mut q);
        Some(q)
    }

    /// Joint `ji`'s hinge angles in `q` (a hinge's, a compound joint's hinge
    /// coordinates) on the branch nearest their last recorded values (continuous across
    /// `±π`, `projection/branch.rs`); other coordinates as they are.
    #[inline]
    pub(super) fn continue_angles(&self, ji: usize, q: &mut [f64; MAX_DOF]) {
        let branch = &self.proj.branch;
        if !branch.tracks(ji) {
            return;
        }
        match &self.joints[ji].kind {
            JointKind::Hinge(_) => q[0] = branch.continuous(ji, 0, q[0]),
            JointKind::Compound(c, _) => {
                for d in c.slides()..c.dof().min(MAX_DOF) {
                    q[d] = branch.continuous(ji, d, q[d]);
                }
            }
            _ => {}
        }
    }

    /// [`Self::coordinates_of`] (the same bits), kept in the coordinate cache
    /// (`World::coords`) for the next reader at the same poses: the projection's limit
    /// error evaluates them, its limit rows read them again at the same iterate, and the
    /// next step's limit rows at the last accepted one.
    pub(super) fn coordinates_kept(&mut self, ji: usize) -> Option<[f64; MAX_DOF]> {
        // Only a compound joint's coordinates are worth an entry (a hinge's angle or a
        // slide's displacement costs about what the key's comparison does).
        if !matches!(self.joints[ji].kind, JointKind::Compound(..)) {
            return self.coordinates_of(ji);
        }
        self.compound_coordinates_kept(ji)
    }

    /// [`Self::coordinates_kept`] of a compound joint (out of line: the callers' loops
    /// over the hinges stay small).
    #[inline(never)]
    fn compound_coordinates_kept(&mut self, ji: usize) -> Option<[f64; MAX_DOF]> {
        let j = &self.joints[ji];
        let JointKind::Compound(c, _) = &j.kind else {
            return self.coordinates_of(ji);
        };
        let a = j.parent.map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
        let b = &self.bodies[j.child].pose;
        // The key once: the cache's entry, then the force evaluations' table (the
        // readers of `coordinates_of`, in that order), then computed.
        let key = CachedRows::key_of(a, b);
        if let Some(Some(e)) = self.coords.get(ji) {
            if same_key(&e.key, &key) {
                // An entry of the rows' cache (`Joint::rows`) holds `atan2`'s angles.
                let mut q = e.q;
                self.continue_angles(ji, &mut q);
                return Some(q);
            }
        }
        let (mut q, rows) = match self.dof_table.get(ji) {
            Some(Some(e)) if same_key(&e.key, &key) => (e.q, Some(e.rows)),
            _ => (c.coordinates(a, b, &[0.0; MAX_DOF]), None),
        };
        self.continue_angles(ji, &mut q);
        if self.coords.len() <= ji {
            self.coords.resize(ji + 1, None);
        }
        // A new entry built only when there is none (`get_or_insert` evaluated its
        // argument, the zeroed rows, on every call).
        let slot = &mut self.coords[ji];
        match slot {
            Some(e) => {
                e.key = key;
                e.q = q;
                e.has_rows = rows.is_some();
                if let Some(rows) = rows {
                    e.rows = rows;
                }
            }
            None => {
                *slot = Some(KeptCoords {
                    key,
                    q,
                    has_rows: rows.is_some(),
                    rows: rows.unwrap_or([[DVec3::ZERO; 4]; MAX_DOF]),
                });
            }
        }
        Some(q)
    }

    /// Fills the coordinate cache's entries (coordinates and rate rows) of the compound
    /// joints whose limit or dry-friction rows [`Self::push_limit_rows`] reads at the
    /// current poses, so that it and the force evaluations at the same poses (the
    /// step's first kick) read them rather than computing the rows each.
    ///
    /// A hinge's or a slide's coordinate and row go into the force evaluations' table
    /// (`dof_table`, as an entry that is not live) instead: [`Self::push_limit_rows`]
    /// reads them from there, and so does the step's first force evaluation at the same
    /// poses (the velocity level's `add_dof_forces`), which computed them a second time
    /// before (issue 13, swimmer6 controlled: 1 750 of its 8 793 hinge angles).
    pub(super) fn keep_limit_coordinates(&mut self) {
        self.record_turned_angles();
        for ji in 0..self.joints.len() {
            if self.limits[ji].iter().all(|l| l.is_none())
                && self.frictionloss[ji].iter().all(|f| *f == 0.0)
            {
                continue;
            }
            let JointKind::Compound(c, _) = &self.joints[ji].kind else {
                self.keep_table_coordinates(ji);
                continue;
            };
            let c = *c;
            let Some(q) = self.compound_coordinates_kept(ji) else {
                continue;
            };
            let j = &self.joints[ji];
            let a = j.parent.map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
            let b = &self.bodies[j.child].pose;
            if let Some(Some(e)) = self.coords.get(ji) {
                if e.has_rows {
                    continue;
                }
            }
            let rows = c.dof_rows(a, b, &q);
            if let Some(Some(e)) = self.coords.get_mut(ji) {
                e.rows = rows;
                e.has_rows = true;
            }
        }
    }

    /// Writes joint `ji`'s coordinate and rate row at the current poses into its entry
    /// of the coordinate table, not live (no rate: a force evaluation at these poses
    /// takes the entry and fills it, `fill_dof_state`), unless the entry is already of
    /// these poses; for the hinges and slides whose entry the last force evaluation
    /// filled (live: a force read them, and will again). Other joints' entries are left
    /// as they are: a passive hopper's limited joints, whose forces are zero, paid a key
    /// comparison in every later lookup of their coordinates (dm hopper passive +0.4 %).
    /// The values are [`Self::compute_coordinates`]'s (the same operations), written in
    /// place (a taken entry was two 0.8 kB copies).
    fn keep_table_coordinates(&mut self, ji: usize) {
        if !matches!(self.dof_table.get(ji), Some(Some(e)) if e.live) {
            return;
        }
        let j = &self.joints[ji];
        let a = j.parent.map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
        let b = &self.bodies[j.child].pose;
        let key = CachedRows::key_of(a, b);
        if matches!(self.dof_table.get(ji), Some(Some(e)) if same_key(&e.key, &key)) {
            return;
        }
        // `compute_coordinates` of a one-coordinate joint: the coordinate cache's
        // value when it is of these poses, else computed; the row computed.
        let kept = self.kept_coordinates(ji).map(|e| e.q[0]);
        let (q, row) = match &j.kind {
            JointKind::Hinge(c) => {
                let q = self
                    .proj
                    .branch
                    .continuous(ji, 0, kept.unwrap_or_else(|| c.angle(a, b)));
                (q, c.angle_row(b))
            }
            JointKind::Prismatic(c) => (
                kept.unwrap_or_else(|| c.displacement(a, b)),
                c.displacement_row(a, b),
            ),
            _ => return,
        };
        let Some(Some(e)) = self.dof_table.get_mut(ji) else {
            return;
        };
        // The table no longer holds the last evaluation's rows.
        self.rattle.impulses.forget();
        e.key = key;
        e.live = false;
        e.q[0] = q;
        e.rows[0] = row;
    }

    /// Joint `ji`'s entry of the coordinate cache when it is of the current poses.
    fn kept_coordinates(&self, ji: usize) -> Option<&KeptCoords> {
        let e = self.coords.get(ji)?.as_ref()?;
        same_key(&e.key, &self.pose_key(ji)).then_some(e)
    }

    /// The coordinates of joint `ji` and the rows of their rates (hinge angle and its
    /// row, prismatic displacement and its row, a compound joint's coordinates and
    /// rows); `None` for joints without coordinates.
    pub(super) fn coordinates_and_rows(
        &self,
        ji: usize,
    ) -> Option<([f64; MAX_DOF], [[DVec3; 4]; MAX_DOF])> {
        if let Some(e) = self.cached_coordinates(ji) {
            return Some((e.q, e.rows));
        }
        let mut q = [0.0; MAX_DOF];
        let mut rows = [[DVec3::ZERO; 4]; MAX_DOF];
        self.compute_coordinates(ji, &mut q, &mut rows)
            .then_some((q, rows))
    }

    /// [`Self::coordinates_and_rows`] by reference (the same bits): the table's entry
    /// when it is of the current poses, else computed into `scratch` (zeroed first), so
    /// a caller reading a few rows does not copy the 624 bytes of all six.
    pub(super) fn coordinates_and_rows_ref<'a>(
        &'a self,
        ji: usize,
        scratch: &'a mut ([f64; MAX_DOF], [[DVec3; 4]; MAX_DOF]),
    ) -> Option<(&'a [f64; MAX_DOF], &'a [[DVec3; 4]; MAX_DOF])> {
        if let Some(e) = self.cached_coordinates(ji) {
            return Some((&e.q, &e.rows));
        }
        *scratch = ([0.0; MAX_DOF], [[DVec3::ZERO; 4]; MAX_DOF]);
        let (q, rows) = scratch;
        self.compute_coordinates(ji, q, rows)
            .then_some((&*q, &*rows))
    }

    /// Joint `ji`'s coordinates and rate rows written into `q` and `rows` (the entries
    /// of its degrees of freedom; the others are left as they are, zero in every
    /// caller); false for joints without coordinates.
    fn compute_coordinates(
        &self,
        ji: usize,
        q: &mut [f64; MAX_DOF],
        rows: &mut [[DVec3; 4]; MAX_DOF],
    ) -> bool {
        let j = &self.joints[ji];
        let a = j.parent.map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
        let b = &self.bodies[j.child].pose;
        // The coordinate cache's entry at these poses: its coordinates (and rows).
        if let Some(e) = self.kept_coordinates(ji) {
            match &j.kind {
                JointKind::Hinge(c) => rows[0] = c.angle_row(b),
                JointKind::Prismatic(c) => rows[0] = c.displacement_row(a, b),
                JointKind::Compound(..) if e.has_rows => *rows = e.rows,
                JointKind::Compound(c, _) => *rows = c.dof_rows(a, b, &e.q),
                _ => return false,
            }
            *q = e.q;
            self.continue_angles(ji, q);
            return true;
        }
        match &j.kind {
            JointKind::Hinge(c) => {
                q[0] = self.proj.branch.continuous(ji, 0, c.angle(a, b));
                rows[0] = c.angle_row(b);
            }
            JointKind::Prismatic(c) => {
                q[0] = c.displacement(a, b);
                rows[0] = c.displacement_row(a, b);
            }
            JointKind::Compound(c, _) => {
                *q = c.coordinates(a, b, &[0.0; MAX_DOF]);
                *rows = c.dof_rows(a, b, q);
                self.continue_angles(ji, q);
            }
            _ => return false,
        }
        true
    }

    /// The generalized force on every degree of freedom at the current state
    /// (actuators, joint springs, tendons) into `tau`, with the coordinate table into
    /// `coords`, and the force along each spatial tendon's path into `path_f` (empty
    /// without paths; all reused buffers). Returns `(evaluated, acting)`: `evaluated`
    /// false when there are no actuators, springs or tendons (nothing written), `acting`
    /// whether some entry of `tau` is nonzero.
    fn generalized_forces(
        &self,
        tau: &mut Vec<[f64; MAX_DOF]>,
        coords: &mut Vec<Option<DofState>>,
        path_f: &mut Vec<f64>,
        part: ForcePart,
    ) -> (bool, bool) {
        path_f.clear();
        if self.actuators.is_empty() && self.springs.is_empty() && self.tendons.is_empty() {
            return (false, false);
        }
        // The coordinate table, lazily: first the joints whose coordinates or rates a
        // force reads (springs; tendons with stiffness or damping, or driven; actuators
        // with a position or velocity bias `b₁`, `b₂`), after the forces the joints a
        // nonzero force acts on (their rows). An actuator with `b₁ = b₂ = 0` reads its
        // `len` and `vel` only in `b₁ gear len` and `b₂ gear vel`, zeros whatever the
        // coordinate (±0: `τ` starts at +0 and `x + (±0) = x` for `x ≠ 0`, `+0 + (±0) =
        // +0`, so `τ` has the same bits as with the coordinate read).
        // Entries of earlier evaluations stay as a cache (`fill_dof_state`), not live.
        coords.resize(self.joints.len(), None);
        for e in coords.iter_mut().flatten() {
            e.live = false;
        }
        // The rates `q̇` only where a force reads them (`fill_rates`); asked at the first
        // entry filled (most evaluations of a passive model fill none).
        let mut read_rates = None;
        let mut rates = || *read_rates.get_or_insert_with(|| self.dof_forces_read_rates());
        for s in &self.springs {
            self.fill_dof_state(coords, s.joint, rates());
        }
        for act in &self.actuators {
            match act.target {
                Target::Dof { joint, .. } => {
                    if act.bias[1] != 0.0 || act.bias[2] != 0.0 {
                        self.fill_dof_state(coords, joint, rates());
                    }
                }
                Target::Tendon(t) => {
                    for &(j, _, _) in &self.tendons[t].terms {
                        self.fill_dof_state(coords, j, rates());
                    }
                }
            }
        }
        for t in &self.tendons {
            if t.stiffness != 0.0 || t.damping != 0.0 {
                for &(j, _, _) in &t.terms {
                    self.fill_dof_state(coords, j, rates());
                }
            }
        }
        let table = &*coords;
        let q = |j: usize, d: usize| {
            table[j]
                .as_ref()
                .filter(|c| c.live)
                .map_or((0.0, 0.0), |c| (c.q[d], c.qd[d]))
        };
        tau.clear();
        tau.resize(self.joints.len(), [0.0; MAX_DOF]);
        if self.paths.any() {
            path_f.resize(self.tendons.len(), 0.0);
        }
        // A tendon's length and rate: its joint terms' and its path's.
        let tendon_state = |ti: usize| {
            let (lp, rp) = self.path_state(ti);
            self.tendons[ti]
                .terms
                .iter()
                .fold((lp, rp), |(l, ld), &(j, d, c)| {
                    let (qj, qdj) = q(j, d);
                    (l + c * qj, ld + c * qdj)
                })
        };
        for (act, &u) in self.actuators.iter().zip(&self.ctrl) {
            let (len, vel) = match act.target {
                Target::Dof { joint, dof } => q(joint, dof),
                Target::Tendon(t) => tendon_state(t),
            };
            let u = act.ctrl_range.map_or(u, |[lo, hi]| u.min(hi).max(lo));
            let clamp = |s: f64| act.force_range.map_or(s, |[lo, hi]| s.min(hi).max(lo));
            let at_rest = act.gain * u + act.bias[0] + act.bias[1] * act.gear * len;
            let s = match part {
                ForcePart::Full => clamp(at_rest + act.bias[2] * act.gear * vel),
                ForcePart::Position => clamp(at_rest),
                ForcePart::Velocity => {
                    clamp(at_rest + act.bias[2] * act.gear * vel) - clamp(at_rest)
                }
            };
            match act.target {
                Target::Dof { joint, dof } => tau[joint][dof] += act.gear * s,
                Target::Tendon(t) => {
                    for &(j, d, c) in &self.tendons[t].terms {
                        tau[j][d] += act.gear * s * c;
                    }
                    if let Some(f) = path_f.get_mut(t) {
                        *f += act.gear * s;
                    }
                }
            }
        }
        if part != ForcePart::Velocity {
            for s in &self.springs {
                tau[s.joint][s.dof] -= s.stiffness * (q(s.joint, s.dof).0 - s.reference);
            }
        }
        for (ti, t) in self.tendons.iter().enumerate() {
            if t.stiffness == 0.0 && t.damping == 0.0 {
                continue;
            }
            let (l, ld) = tendon_state(ti);
            let f = match part {
                ForcePart::Full => -t.stiffness * (l - t.rest_length) - t.damping * ld,
                ForcePart::Position => -t.stiffness * (l - t.rest_length),
                ForcePart::Velocity => -t.damping * ld,
            };
            for &(j, d, c) in &t.terms {
                tau[j][d] += c * f;
            }
            if let Some(p) = path_f.get_mut(ti) {
                *p += f;
            }
        }
        let mut acting = false;
        for (ji, t) in tau.iter().enumerate() {
            if t.iter().any(|v| *v != 0.0) {
                acting = true;
                self.fill_dof_state(coords, ji, rates());
            }
        }
        (true, acting)
    }

    /// Adds `scale · Σ_k G_kᵀ τ_k` (the actuator, spring and tendon impulses over
    /// `scale` seconds) to the bodies' right-hand side.
    /// Nothing is recorded for [`Self::reapply_dof_forces`] (the velocity level and
    /// RATTLE's last half kick reapply nothing).
    pub(super) fn add_dof_forces(&mut self, scale: f64) {
        self.dof_forces_into(scale, ForcePart::Full, false);
    }

    /// Whether any force depends on the velocities besides the joint damping rows: a
    /// velocity term `b₂ ≠ 0` of an actuator, a damped tendon, or a fluid. RATTLE moves
    /// these into its damping flow (see `world/rattle.rs`).
    pub(super) fn has_velocity_forces(&self) -> bool {
        self.actuators.iter().any(|a| a.bias[2] != 0.0)
            || self.tendons.iter().any(|t| t.damping != 0.0)
            || self
                .fluid
                .is_some_and(|f| f.density != 0.0 || f.viscosity != 0.0)
    }

    /// Whether the actuator, spring and tendon forces read the coordinate rates: an
    /// actuator with a velocity term `b₂ ≠ 0` or a damped tendon. Otherwise `τ(q, q̇)`
    /// is the same at any velocities of one configuration, bit for bit: the rates
    /// enter only as `b₂ · g · q̇` and `d · L̇` with `b₂ = d = 0`, signed zeros that
    /// leave every nonzero sum as it is, and each `τ` entry, starting at `+0`, stays
    /// `+0` under added zeros of either sign.
    pub(super) fn dof_forces_read_rates(&self) -> bool {
        self.actuators.iter().any(|a| a.bias[2] != 0.0)
            || self.tendons.iter().any(|t| t.damping != 0.0)
    }

    /// [`Self::add_dof_forces`] for one part of the forces ([`ForcePart`]). Returns
    /// whether any force acts; the forces stay in the world's buffers for
    /// [`Self::reapply_dof_forces`], their impulses recorded ([`DofImpulses`]).
    pub(super) fn add_dof_forces_part(&mut self, scale: f64, part: ForcePart) -> bool {
        self.dof_forces_into(scale, part, true)
    }

    /// [`Self::add_dof_forces_part`], recording the impulses where `record`; without,
    /// the last record is dropped (a later reapplication walks the joints).
    fn dof_forces_into(&mut self, scale: f64, part: ForcePart, record: bool) -> bool {
        self.dof_evals = self.dof_evals.wrapping_add(1);
        let mut tau = core::mem::take(&mut self.dof_tau);
        let mut coords = core::mem::take(&mut self.dof_table);
        let mut path_f = core::mem::take(&mut self.paths.force);
        let (evaluated, acting) = self.generalized_forces(&mut tau, &mut coords, &mut path_f, part);
        // Every force zero and no tendon paths: the impulses would add nothing
        // ([`Self::apply_dof_impulses`] skips zero forces), so nothing acts, for this
        // call and for [`Self::reapply_dof_forces`] (dm swimmer6 passive, controls zero:
        // 6 000 empty passes over the joints in 1 000 steps).
        let any = evaluated && (acting || !path_f.is_empty());
        self.paths.force = path_f;
        let mut sides = core::mem::take(&mut self.rattle.impulses);
        sides.forget();
        if any && record {
            self.apply_dof_impulses(&tau, &coords, scale, Some(&mut sides));
            sides.evals = Some(self.dof_evals);
            #[cfg(test)]
            if sides.off {
                sides.forget();
            }
            self.apply_path_forces(scale, None);
        } else if any {
            self.apply_dof_impulses(&tau, &coords, scale, None);
            self.apply_path_forces(scale, None);
        }
        self.rattle.impulses = sides;
        self.dof_tau = tau;
        self.dof_table = coords;
        any
    }

    /// The actuator, spring and tendon forces per body `(force, torque)` at the current
    /// state into `f` (resized to the bodies; for the acceleration level, which applies
    /// forces, not impulses). Returns false, leaving `f` untouched, when there are none.
    pub(super) fn dof_wrenches(&mut self, f: &mut Vec<(DVec3, DVec3)>) -> bool {
        self.dof_evals = self.dof_evals.wrapping_add(1);
        let mut tau = core::mem::take(&mut self.dof_tau);
        let mut coords = core::mem::take(&mut self.dof_table);
        let mut path_f = core::mem::take(&mut self.paths.force);
        let (any, _) = self.generalized_forces(&mut tau, &mut coords, &mut path_f, ForcePart::Full);
        self.paths.force = path_f;
        if any {
            // Every joint's rows, as before the table was built lazily (the loop below
            // adds each joint's rows times its force, zero or not).
            for ji in 0..self.joints.len() {
                self.fill_dof_state(&mut coords, ji, false);
            }
            f.clear();
            f.resize(self.bodies.len(), (DVec3::ZERO, DVec3::ZERO));
            for ji in 0..self.joints.len() {
                let Some(DofState {
                    live: true, rows, ..
                }) = &coords[ji]
                else {
                    continue;
                };
                let (parent, child) = (self.joints[ji].parent, self.joints[ji].child);
                for k in 0..MAX_DOF {
                    let t = tau[ji][k];
                    if let Some(p) = parent {
                        f[p].0 += rows[k][0] * t;
                        f[p].1 += rows[k][1] * t;
                    }
                    f[child].0 += rows[k][2] * t;
                    f[child].1 += rows[k][3] * t;
                }
            }
            self.apply_path_forces(1.0, Some(f.as_mut_slice()));
        }
        self.dof_tau = tau;
        self.dof_table = coords;
        any
    }
}

/// Joint `ji`'s entry of the coordinate cache `coords` (`World::coords`) when it is of
/// poses `a` (parent) and `b` (child), for [`Joint::rate_rows_only_kept`].
pub(super) fn kept_at<'k>(
    coords: &'k [Option<KeptCoords>],
    ji: usize,
    a: &Pose,
    b: &Pose,
) -> Kept<'k> {
    match coords.get(ji) {
        Some(Some(e)) if same_key(&e.key, &CachedRows::key_of(a, b)) => Kept::Read(e),
        _ => Kept::None,
    }
}

/// A joint's entry of the coordinate table: its coordinates, their rates and the rate
/// rows, with the bits of the poses they are of. The table is kept between force
/// evaluations; an entry is `live` when filled by the current one (the others are a
/// cache for evaluations at the same poses: the two kicks and the damping flow around
/// one configuration, the limit rows at the start of the next step).
#[derive(Clone, Copy, Debug)]
pub(super) struct DofState {
    /// Bits of the parent's and the child's poses ([`CachedRows::key_of`]).
    key: [u64; 14],
    /// Filled by the current evaluation.
    live: bool,
    /// Coordinates `q`.
    q: [f64; MAX_DOF],
    /// Rates `q̇ = G v` (at the velocities of the evaluation that filled the entry;
    /// zero where the forces read no rates, [`World::fill_rates`]).
    qd: [f64; MAX_DOF],
    /// Rate rows `G`.
    rows: [[DVec3; 4]; MAX_DOF],
}
