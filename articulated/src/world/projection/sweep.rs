//! A tree-ordered projection of the hard tree joints before the Newton projection
//! (issue 13): the sweep.
//!
//! The velocity level leaves the joints `O(h²)` apart when bodies turn fast (controlled
//! runs: about 2e-4 m), so every step of those runs took a global Newton step (assemble,
//! factor, solve, re-check). The sweep visits the tree's joints parents first; at each
//! hard joint it moves only the joint's tree child `c` (the parent is already
//! corrected and does not move again) by the mass-weighted minimum-norm step of that
//! joint alone,
//!
//! `δ_c = −M_c⁻¹ J_cᵀ (J_c M_c⁻¹ J_cᵀ)⁻¹ C`,
//!
//! `J_c` the joint's hard rows' columns of the child (≤ 6 × 6, factored once by
//! Cholesky), then chord steps with the same factor at the new `C` until the error is
//! below `FINE` of the tolerance (one unchecked chord step where the Newton step's
//! contraction predicts it suffices, the usual case; else at most `MAX_CHORDS`, each
//! checked). After one sweep every tree joint is closed; the projection's error then
//! decides whether the Newton loop still runs (contacts, equalities, tendon ranges,
//! loop joints, limits the sweep missed). A joint whose separation is within the
//! tolerance is not moved, so a projection that would have ended at once ends at once
//! with the same bits.
//!
//! Joint limits: a limit of the swept joint violated by more than the tolerance joins
//! the joint's local system as a row at its bound (as `push_violated_limits`), and one
//! that the step takes past its bound joins and the step is taken again (once). Left
//! to the Newton loop, the sweep's controlled dm walker (2 s) ended 298 of 779
//! projections with a limit violated; clamped here, 6 (contacts).
//!
//! Left to the Newton loop: loop-closing joints (not in the tree), compliant joints
//! (their separation is their spring's; their children are still swept against them
//! as they are), a step whose first move did not decrease the joint's error (it is
//! taken back), and a joint whose `J_c M_c⁻¹ J_cᵀ` has a non-positive pivot.
//!
//! Only projections of the positions alone are swept (RATTLE's velocity-level
//! fallback, the default method's path on steps with one-sided rows). A
//! velocity-corrected projection (`v += δx/h`) would turn the child-only step into an
//! impulse without its reaction on the parent: measured on a 6-link ball chain spun at
//! ~6 rad/s (`VelocityProjected`, `β = 0`, `h = 5 ms`, 0.5 s), the energy went from
//! 0.0039 J to +0.111 J with the sweep, −0.054 J with the Newton projection and
//! −0.008 J at `h/10`.
//!
//! Trees whose root is a free body are swept only when asked
//! ([`World::set_projection_sweep`]): the root stays and its descendants move, so the
//! tree's centre of mass would move, where the global mass-weighted step keeps it (its
//! `Σ m δx = 0` for joints alone). The whole tree is then translated by minus the
//! mass-weighted mean displacement (joint values do not change under a common
//! translation), which restores the centre of mass.
//!
//! The default sweeps trees rooted at the world and not free ones (issue 13, World::step
//! instructions under callgrind, 2 s, against the Newton projection alone): gymnasium
//! pusher controlled −12.8 %, pusher_v5 −12.8 %, hopper −11.2 %, dm hopper controlled
//! −7.7 % (passive −6.2 %), cheetah −5.2 %, walker −4.3 %, half_cheetah −2.5 %,
//! manipulator −1.6 %, stacker +0.8 %; the free-rooted models unchanged (the same bits).
//! Sweeping free trees too (measured before the pause, `MISSES`) saved more on the
//! humanoids (dm humanoid controlled −12 %, humanoid_CMU −13 %, ant −16 %), but dm
//! humanoid passive went +2.6 % with its capped dense contact solves 4 → 18 in 2 s
//! and deeper settled penetration (3.0e-5 → 4.5e-5 m): left as a setting until that
//! is understood.
//!
//! Tried and left out (issue 13): free trees swept by default without restoring their
//! centre of mass (the root stays, the limbs move). World::step instructions (2 s): dm
//! humanoid controlled 303.57M → 260.54M (−14.2 %), passive 315.92M → 304.21M (−3.7 %),
//! gymnasium humanoid passive 275.39M → 275.37M; but dm humanoid passive's projections
//! that ended unconverged 4 → 10 steps and its penetration 3.05e-5 → 3.66e-5 m,
//! gymnasium humanoid passive 2.85e-5 → 4.15e-5 m (its unconverged steps 8 → 1), ant
//! controlled unconverged 0 → 1 (`simulate --summary`): the same contact regression as
//! with the centre restored, so not the cause of it.
//!
//! A third setting, off by default ([`World::set_projection_sweep_limbs`]): of a free
//! tree only the joints whose child's subtree has no body in contact (a body of a
//! contact of this step, generated at its start, that penetrates), the root and the
//! contact-bearing branches left to the Newton projection, no centre restored.
//! Against main (`simulate --summary`, World::step instructions under callgrind, 2 s,
//! humanoid_CMU 0.5 s): dm humanoid passive 315.92M → 345.79M (+9.5 %, in the velocity
//! level of a different fall: 230M → 263M), penetration 3.047e-5 → 3.045e-5 m,
//! unconverged projections 4 → 3; controlled 303.61M → 273.59M (−9.9 %), unconverged
//! 2 → 1; gymnasium humanoid passive 275.39M → 265.58M (−3.6 %), penetration 2.85e-5 →
//! 8.9e-6 m, unconverged 8 → 1; humanoid_CMU passive 211.07M → 202.97M (−3.8 %),
//! penetration 5.34e-6 → 5.20e-6 m; controlled 376.72M → 371.04M (−1.5 %), penetration
//! 1.0e-4 → 7.2e-5 m but unconverged 45 → 52 (of 250); gymnasium ant controlled 82.86M →
//! 80.60M (−2.7 %), penetration 1e-4 (the slop) both, unconverged 0 both; the largest
//! joint separations below the tolerance (≤ 1e-8 m) in all. Not the default: the
//! passive dm humanoid's cost and CMU controlled's unconverged projections. Counting
//! the speculative contacts too (apart by up to the margin) swept less and saved
//! nothing: dm humanoid passive +2.1 %, controlled −0.9 %, gymnasium humanoid −2.4 %,
//! CMU passive +0.9 % (penetration 5.57e-6 m), controlled −1.1 % (unconverged 53), ant
//! +1.1 %.

use constraint_core::rigid::rotate_by;
use constraint_core::DVec3;

use super::*;
use crate::joint::JointRows;
use crate::tree::NONE;

/// The error (fraction of the projection's tolerance) below which a joint's step ends
/// without a further chord step (1e-11 m at the unilateral floor of 1e-8 m).
const FINE: f64 = 1e-3;

/// The most chord steps of one joint after its Newton step (each after the first
/// checked, `sweep_joint`).
const MAX_CHORDS: usize = 3;

/// How far (per metre or radian of the step `|δx| + |δθ|`) a step may move a joint's
/// coordinates: a limit farther than this from its bound is not evaluated after the
/// step. A heuristic, not a bound (a compound joint's coordinates move with its lever
/// arms): a limit it misses is still in the projection's error, and the Newton loop
/// then brings it back.
const REACH: f64 = 10.0;

/// Which trees the sweep visits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(in crate::world) enum SweepMode {
    /// No sweep (the Newton projection alone).
    Off,
    /// Trees whose root joint is attached to the world.
    #[default]
    Rooted,
    /// Those and trees whose root is a free body (centre of mass restored).
    All,
    /// Trees rooted at the world, and of trees rooted at a free body the joints whose
    /// tree child's subtree has no body in contact (`touching`; the root and the
    /// contact-bearing branches stay, no centre of mass restored).
    Limbs,
}

/// The sweep's setting and reused buffers.
#[derive(Clone, Debug, Default)]
pub(in crate::world) struct SweepScratch {
    /// Which trees are swept.
    pub(in crate::world) mode: SweepMode,
    /// Per tree node: its joint (joint nodes) or `NONE`.
    node_joint: Vec<usize>,
    /// Per tree node: the root node of its tree.
    root: Vec<usize>,
    /// The joints to sweep, parents first: `(joint, tree parent node or NONE, whether
    /// its tree is rooted at a free body)`.
    plan: Vec<(usize, usize, bool)>,
    /// The tree `plan` was built for (the solver's `joint_node`, `parent`, `order`)
    /// and its mode.
    key: (Vec<usize>, Vec<usize>, Vec<usize>, SweepMode),
    /// Per body: the displacement the sweep gave it.
    moved: Vec<DVec3>,
    /// Per root body of a free tree: `(Σ m, Σ m δx)` of its bodies.
    centre: Vec<(f64, DVec3)>,
    /// Per tree node: whether a body of its subtree is in this step's contacts
    /// (`SweepMode::Limbs`).
    touch: Vec<bool>,
    /// Consecutive sweeps that moved bodies and still left the Newton loop to run
    /// (`SweepScratch::note`).
    misses: u32,
    /// Projections not swept since the last sweep, while `misses ≥ MISSES`.
    skipped: u32,
    /// Per joint: whether its separation was within the tolerance when the last sweep
    /// reached it (`sweep_joint` then evaluates its values before its rows).
    settled: Vec<bool>,
}

/// Sweeps in a row that did not end their projection after which the sweep pauses: a
/// projection that needs the Newton loop anyway (contacts held by the projection,
/// equalities) pays for the sweep's rows and local solves and saves little (dm
/// manipulator controlled: +4.6 % World::step instructions, stacker +5.3 %).
const MISSES: u32 = 2;

/// While paused, one projection in this many is swept (a probe: a sweep that ends its
/// projection resumes sweeping).
const PROBE: u32 = 8;

impl SweepScratch {
    /// Whether this projection is swept (`MISSES`, `PROBE`).
    fn due(&mut self) -> bool {
        if self.misses < MISSES {
            return true;
        }
        self.skipped += 1;
        if self.skipped >= PROBE {
            self.skipped = 0;
            return true;
        }
        false
    }

    /// Records a sweep's outcome: `moved` bodies, and whether the projection then
    /// still needed the Newton loop.
    pub(super) fn note(&mut self, moved: bool, newton: bool) {
        if moved {
            self.misses = if newton {
                self.misses.saturating_add(1)
            } else {
                0
            };
        }
    }
}

impl SweepScratch {
    /// Builds `plan` for `solver`'s tree (`nb` bodies) unless it is built for it.
    fn plan_for(&mut self, solver: &crate::tree::TreeSolver, nb: usize, mode: SweepMode) {
        let key = &self.key;
        if key.3 == mode
            && key.0 == solver.joint_node
            && key.1 == solver.parent
            && key.2 == solver.order
        {
            return;
        }
        self.key = (
            solver.joint_node.clone(),
            solver.parent.clone(),
            solver.order.clone(),
            mode,
        );
        let n_nodes = solver.parent.len();
        self.node_joint.clear();
        self.node_joint.resize(n_nodes, NONE);
        for (j, &n) in solver.joint_node.iter().enumerate() {
            if let Some(slot) = self.node_joint.get_mut(n) {
                *slot = j;
            }
        }
        self.root.clear();
        self.root.resize(n_nodes, NONE);
        self.plan.clear();
        // Parents before children: the elimination order reversed.
        for &node in solver.order.iter().rev() {
            let p = solver.parent[node];
            let root = if p == NONE { node } else { self.root[p] };
            self.root[node] = root;
            let j = self.node_joint.get(node).copied().unwrap_or(NONE);
            if node < nb || j == NONE {
                continue;
            }
            let free = root < nb;
            if !free || mode != SweepMode::Rooted {
                self.plan.push((j, p, free));
            }
        }
    }
}

impl World {
    /// Sets whether the position projection first sweeps the tree joints in tree order
    /// (`projection/sweep.rs`): `rooted` for trees attached to the world, `floating`
    /// also for trees rooted at a free body (their centre of mass restored). By
    /// default `(true, false)`: trees rooted at the world only (module doc).
    pub fn set_projection_sweep(&mut self, rooted: bool, floating: bool) {
        self.proj.sweep.mode = match (rooted, floating) {
            (_, true) => SweepMode::All,
            (true, false) => SweepMode::Rooted,
            (false, false) => SweepMode::Off,
        };
    }

    /// Whether the projection sweeps `(rooted trees, floating trees)`
    /// ([`Self::set_projection_sweep`]); with the limbs of floating trees swept
    /// ([`Self::set_projection_sweep_limbs`]) `(true, false)`.
    pub fn projection_sweep(&self) -> (bool, bool) {
        match self.proj.sweep.mode {
            SweepMode::Off => (false, false),
            SweepMode::Rooted | SweepMode::Limbs => (true, false),
            SweepMode::All => (true, true),
        }
    }

    /// A third setting of the sweep (module doc): `on` sweeps the trees rooted at the
    /// world and, of the trees rooted at a free body, the joints whose child's
    /// subtree has no body in the step's contacts (the root and the branches that
    /// hold contacts are left to the Newton projection; the centre of mass is not
    /// restored). `false` turns this setting back into the rooted trees' sweep and
    /// leaves the other settings as they are. Off by default.
    pub fn set_projection_sweep_limbs(&mut self, on: bool) {
        let mode = &mut self.proj.sweep.mode;
        if on {
            *mode = SweepMode::Limbs;
        } else if *mode == SweepMode::Limbs {
            *mode = SweepMode::Rooted;
        }
    }

    /// Whether the limbs of floating trees are swept
    /// ([`Self::set_projection_sweep_limbs`]).
    pub fn projection_sweep_limbs(&self) -> bool {
        self.proj.sweep.mode == SweepMode::Limbs
    }

    /// One sweep of the hard tree joints (module doc) at `tolerance`, moving positions
    /// only. Returns whether a body moved.
    pub(super) fn sweep_tree_joints(&mut self, tolerance: f64) -> bool {
        let mode = self.proj.sweep.mode;
        if mode == SweepMode::Off {
            return false;
        }
        if !self.proj.sweep.due() {
            return false;
        }
        let mut s = core::mem::take(&mut self.proj.sweep);
        let nb = self.bodies.len();
        s.plan_for(&self.solver, nb, mode);
        if s.plan.is_empty() {
            self.proj.sweep = s;
            return false;
        }
        s.moved.clear();
        s.moved.resize(nb, DVec3::ZERO);
        let mut any = false;
        let mut any_free = false;
        let limbs = mode == SweepMode::Limbs;
        if limbs {
            self.touching(&mut s);
        }
        // One set of per-joint buffers for the whole sweep (zeroed once, not per joint).
        let mut buf = JointScratch::new();
        s.settled.resize(self.joints.len(), false);
        for &(j, p, free) in &s.plan {
            if self.is_soft(j) {
                continue;
            }
            // A free tree's branch holding a contact is left to the Newton projection.
            if limbs && free && s.touch[self.solver.joint_node[j]] {
                continue;
            }
            let joint = &self.joints[j];
            // The joint's tree child: the body that is not its tree parent.
            let (moved, is_b) = match joint.parent {
                Some(a) if p == joint.child => (a, false),
                _ => (joint.child, true),
            };
            let settled = &mut s.settled[j];
            if let Some((dx, _)) = self.sweep_joint(j, moved, is_b, tolerance, settled, &mut buf) {
                any = true;
                any_free |= free;
                s.moved[moved] += dx;
            }
        }
        if any_free && !limbs {
            self.restore_free_centres(&mut s);
        }
        self.proj.sweep = s;
        if any {
            self.proj.values_current = false;
        }
        any
    }

    /// Marks in `s.touch` the tree nodes whose subtree holds a body in contact: a body
    /// of this step's contacts (generated at the step's start) that penetrate
    /// (`depth > 0`). The speculative ones (apart by up to the margin) are not counted:
    /// marking them too (module doc) swept less and saved nothing.
    fn touching(&self, s: &mut SweepScratch) {
        let n_nodes = self.solver.parent.len();
        s.touch.clear();
        s.touch.resize(n_nodes, false);
        #[cfg(feature = "contact")]
        for c in self.contacts.iter().filter(|c| c.depth > 0.0) {
            for k in [c.a, c.b] {
                let body = self.colliders.get(k).and_then(|col| col.body);
                if let Some(slot) = body.and_then(|b| s.touch.get_mut(b)) {
                    *slot = true;
                }
            }
        }
        // Children before parents (the elimination order).
        for &node in &self.solver.order {
            let p = self.solver.parent[node];
            if s.touch[node] && p != NONE {
                s.touch[p] = true;
            }
        }
    }

    /// Translates each swept free tree by minus its bodies' mass-weighted mean
    /// displacement (module doc).
    fn restore_free_centres(&mut self, s: &mut SweepScratch) {
        let nb = self.bodies.len();
        s.centre.clear();
        s.centre.resize(nb, (0.0, DVec3::ZERO));
        for i in 0..nb {
            let r = s.root[i];
            if r < nb {
                let m = self.bodies[i].mass();
                let c = &mut s.centre[r];
                c.0 += m;
                c.1 += s.moved[i] * m;
            }
        }
        for i in 0..nb {
            let r = s.root[i];
            if r >= nb {
                continue;
            }
            let (m, mdx) = s.centre[r];
            if !(m > 0.0) || mdx == DVec3::ZERO {
                continue;
            }
            let shift = mdx / m;
            self.bodies[i].pose.x -= shift;
        }
    }

    /// Moves body `moved` (the joint's child `b` when `is_b`, else its `a`) so that hard
    /// joint `j` is closed: a Newton step and at most one chord step (module doc). Its
    /// limits within `tolerance` of their bound (or past it) join as rows at the bound,
    /// as the Newton projection's limit rows (`push_violated_limits`), so the step
    /// clamps them rather than leaving them to the Newton loop; a limit that the step
    /// takes past its bound by more than `tolerance` joins, and the step is taken again
    /// from the start (once).
    /// Returns the displacement `(δx, δθ)`, or `None` when the joint is within
    /// `tolerance` or the step was not taken. `settled`: whether the joint was within
    /// `tolerance` at the last sweep (then its values are evaluated first, and its rows
    /// only when it is not within it now); set to whether it is now.
    fn sweep_joint(
        &mut self,
        j: usize,
        moved: usize,
        is_b: bool,
        tolerance: f64,
        settled: &mut bool,
        buf: &mut JointScratch,
    ) -> Option<(DVec3, DVec3)> {
        let JointScratch {
            rows,
            local,
            lims,
            forced,
        } = buf;
        let joint = &self.joints[j];
        let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
        let b = self.bodies[joint.child].pose;
        // A joint within the tolerance at the last sweep is likely within it again: its
        // values alone decide (the rows' values bit for bit, `Joint::value`), without the
        // Jacobian. (pusher_v5 controlled: about a third of the swept joints are within
        // the tolerance, and mostly the same ones from step to step.)
        if *settled && !(joint.separation_of(&joint.value(&a, &b)) > tolerance) {
            return None;
        }
        joint.rows_into(&a, &b, false, rows);
        let n_hard = rows.n_hard;
        let sep0 = joint.separation_of(&rows.value);
        // A joint within the tolerance is not moved (its limits, if violated, are the
        // Newton loop's).
        *settled = !(sep0 > tolerance);
        if *settled {
            return None;
        }
        let limited = self.limits[j].iter().any(Option::is_some);
        let start = self.bodies[moved].pose;
        // `lims`: the limit rows `±G δ = −c`, `c = q − lo` or `hi − q`; `forced`: limits
        // past their bound after a first try (rows in the second).
        forced.n = 0;
        for _attempt in 0..2 {
            let mut n = n_hard;
            let mut err0 = sep0;
            lims.n = 0;
            // The coordinates' smallest distance from a bound without a row.
            let mut margin = f64::INFINITY;
            let q0 = if limited {
                self.swept_coordinates(j, &a, &b)
            } else {
                None
            };
            if let Some(q) = q0 {
                let mut need = false;
                for (d, lim) in self.limits[j].iter().enumerate() {
                    let Some([lo, hi]) = *lim else { continue };
                    for (c, sign, bound) in [(q[d] - lo, 1.0, lo), (hi - q[d], -1.0, hi)] {
                        if c < -tolerance || forced.has((d, sign, bound)) {
                            need = true;
                        } else {
                            margin = margin.min(c);
                        }
                    }
                }
                // The rate rows only where a limit gets a row.
                if need {
                    let mut scratch = ([0.0; MAX_DOF], [[DVec3::ZERO; 4]; MAX_DOF]);
                    if let Some((_, g)) = self.coordinates_and_rows_ref(j, &mut scratch) {
                        for (d, lim) in self.limits[j].iter().enumerate() {
                            let Some([lo, hi]) = *lim else { continue };
                            for (c, sign, bound) in [(q[d] - lo, 1.0, lo), (hi - q[d], -1.0, hi)] {
                                let row = (d, sign, bound);
                                if (c < -tolerance || forced.has(row)) && n < MAX_ROWS {
                                    rows.rows[n] = g[d].map(|r| r * sign);
                                    rows.value[n] = c;
                                    lims.push(row);
                                    n += 1;
                                    err0 = err0.max(-c);
                                }
                            }
                        }
                    }
                }
            }
            let body = &self.bodies[moved];
            let (lin, ang) = if is_b { (2, 3) } else { (0, 1) };
            let r = body.rotation();
            let iinv = r * body.inv_inertia() * r.transpose();
            let inv_m = 1.0 / body.mass();
            if !local.factor(rows, n, lin, ang, inv_m, &iinv) {
                self.bodies[moved].pose = start;
                return None;
            }
            let mut c = rows.value;
            let (dx, dth) = local.step(&mut c);
            self.bodies[moved].pose.x = start.x + dx;
            self.bodies[moved].pose.q = rotate_by(start.q, dth);
            // The error after the Newton step: kept, chord step, or taken back.
            let joint = &self.joints[j];
            let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
            let b = self.bodies[joint.child].pose;
            // `value_into` (zeros past the hard rows, as `Joint::value`): a hinge's
            // directions come back for its angle below (`swept_coordinates_from`).
            let mut c = [0.0; MAX_ROWS];
            let dirs = joint.value_into(&a, &b, &mut c);
            let mut err1 = joint.separation_of(&c);
            // The coordinates after the step, where a limit has a row or a bound may be
            // within reach of the step (`REACH`).
            let reach = REACH * (dx.length() + dth.length()) + tolerance;
            // `coordinates_of` is `None` only for joint kinds without coordinates
            // (by kind, not by pose), which `set_dof_limit` gives no limits: should one
            // have limits, they are skipped here, as the projection's error skips them
            // (`limit_coordinates`), and no limit row was pushed for them above.
            let q_end = if limited && (lims.n > 0 || !(margin > reach)) {
                self.swept_coordinates_from(j, &a, &b, dirs)
            } else {
                None
            };
            if let Some(q) = q_end {
                for (ck, &(d, sign, bound)) in c[n_hard..].iter_mut().zip(&lims.rows[..lims.n]) {
                    let v = sign * (q[d] - bound);
                    *ck = v;
                    err1 = err1.max(v.abs());
                }
                // A limit without a row taken past its bound by more than the
                // tolerance: the step again with its row.
                let mut missed = false;
                for (d, lim) in self.limits[j].iter().enumerate() {
                    let Some([lo, hi]) = *lim else { continue };
                    for (v, row) in [(lo - q[d], (d, 1.0, lo)), (q[d] - hi, (d, -1.0, hi))] {
                        if v > tolerance && !lims.has(row) {
                            missed |= forced.push(row);
                        }
                    }
                }
                if missed {
                    self.bodies[moved].pose = start;
                    continue;
                }
            }
            if !(err1 < err0) {
                self.bodies[moved].pose = start;
                return None;
            }
            // Chord steps: the same factor and rows at the new `C`. They contract at
            // about the Newton step's rate `err1/err0`: where one is predicted to reach
            // `FINE` (the usual case) it is taken without evaluating its end; else each
            // is checked, at most `MAX_CHORDS`.
            let (mut tx, mut tth) = (dx, dth);
            let fine = FINE * tolerance;
            let mut err = err1;
            let single = err1 * (err1 / err0) <= fine;
            for k in 0..MAX_CHORDS {
                if err <= fine {
                    break;
                }
                let pose = self.bodies[moved].pose;
                let (dx2, dth2) = local.step(&mut c);
                self.bodies[moved].pose.x = pose.x + dx2;
                self.bodies[moved].pose.q = rotate_by(pose.q, dth2);
                if single || k + 1 == MAX_CHORDS {
                    return Some((tx + dx2, tth + dth2));
                }
                let next = self.sweep_error(j, n_hard, lims, &mut c);
                if !(next < err) {
                    // Not contracting: the step back, the rest to the Newton loop.
                    self.bodies[moved].pose = pose;
                    break;
                }
                err = next;
                (tx, tth) = (tx + dx2, tth + dth2);
            }
            return Some((tx, tth));
        }
        // A second limit past its bound: left to the Newton loop.
        self.bodies[moved].pose = start;
        None
    }
}

impl World {
    /// Joint `j`'s hard rows' values and its limit rows' `c` (`lims`, after the
    /// `n_hard` hard rows) at the current poses into `c`; returns the larger of its
    /// separation and the limit rows' `|c|`.
    fn sweep_error(&self, j: usize, n_hard: usize, lims: &Limits, c: &mut [f64; MAX_ROWS]) -> f64 {
        let joint = &self.joints[j];
        let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
        let b = self.bodies[joint.child].pose;
        *c = [0.0; MAX_ROWS];
        let dirs = joint.value_into(&a, &b, c);
        let mut err = joint.separation_of(c);
        // Limit rows exist only where `coordinates_of` gave the joint's coordinates
        // (`sweep_joint`), and it answers by the joint's kind: `None` is not reached
        // with rows; the rows' `c` then stay as they were and add no error.
        if lims.n > 0 {
            if let Some(q) = self.swept_coordinates_from(j, &a, &b, dirs) {
                for (ck, &(d, sign, bound)) in c[n_hard..].iter_mut().zip(&lims.rows[..lims.n]) {
                    *ck = sign * (q[d] - bound);
                    err = err.max(ck.abs());
                }
            }
        }
        err
    }

    /// Joint `j`'s coordinates at the current poses `a`, `b` (its parent's and
    /// child's), as [`Self::coordinates_of`] (the same bits): a hinge's angle computed
    /// at once ([`constraint_core::Hinge::angle`]) on its continuous branch, without
    /// `coordinates_of`'s look-ups of the force evaluation's and the coordinate
    /// cache's entries, whose pose keys the sweep's moves make miss (and which hold
    /// the same bits when they hit). Other joints through `coordinates_of`.
    #[inline]
    fn swept_coordinates(&self, j: usize, a: &Pose, b: &Pose) -> Option<[f64; MAX_DOF]> {
        if let JointKind::Hinge(h) = &self.joints[j].kind {
            let mut q = [0.0; MAX_DOF];
            q[0] = h.angle(a, b);
            self.continue_angles(j, &mut q);
            return Some(q);
        }
        self.coordinates_of(j)
    }

    /// [`Self::swept_coordinates`] at the poses where [`Joint::value_into`] returned
    /// `dirs` (a hinge's `[n, u]`): its angle from them
    /// ([`constraint_core::Hinge::angle_from`], the same operations as
    /// [`constraint_core::Hinge::angle`], so the same bits) without rotating `n` and `u`
    /// again. Other joints (`dirs` is `None`) as `swept_coordinates`. (Session 42, the
    /// same bits, World::step instructions, 2 s: half_cheetah controlled 32.478M →
    /// 32.459M, dm cheetah 32.681M → 32.653M, dm hopper 48.965M → 48.924M, walker
    /// 118.55M → 118.41M, pusher 23.94M → 23.91M.)
    #[inline]
    fn swept_coordinates_from(
        &self,
        j: usize,
        a: &Pose,
        b: &Pose,
        dirs: Option<[DVec3; 2]>,
    ) -> Option<[f64; MAX_DOF]> {
        if let (JointKind::Hinge(h), Some([n, u])) = (&self.joints[j].kind, dirs) {
            let mut q = [0.0; MAX_DOF];
            q[0] = h.angle_from(b, n, u);
            self.continue_angles(j, &mut q);
            return Some(q);
        }
        self.swept_coordinates(j, a, b)
    }
}

/// The buffers of one joint's step in the sweep, reused from joint to joint (each
/// reads only the entries it wrote for the current joint: `rows` and `local` their
/// first `n`, the limits their first `n`).
struct JointScratch {
    /// The joint's rows at the start of its step, then its limit rows.
    rows: JointRows,
    /// The step's local system.
    local: Local,
    /// The limit rows of the current try.
    lims: Limits,
    /// Limits past their bound after a first try.
    forced: Limits,
}

impl JointScratch {
    fn new() -> Self {
        Self {
            rows: JointRows::new(),
            local: Local::new(),
            lims: Limits::default(),
            forced: Limits::default(),
        }
    }
}

/// A joint's limit rows in the sweep: `(dof, sign, bound)` (`sign` 1 for a lower bound).
#[derive(Clone, Copy, Default)]
struct Limits {
    rows: [(usize, f64, f64); MAX_ROWS],
    n: usize,
}

impl Limits {
    fn has(&self, row: (usize, f64, f64)) -> bool {
        self.rows[..self.n].contains(&row)
    }

    /// Adds `row` when there is room; whether it was added.
    fn push(&mut self, row: (usize, f64, f64)) -> bool {
        if self.n < MAX_ROWS && !self.has(row) {
            self.rows[self.n] = row;
            self.n += 1;
            return true;
        }
        false
    }
}

/// One joint's local system: the columns `w` of `M_c⁻¹ J_cᵀ` and the Cholesky factor
/// `L` of `A = J_c M_c⁻¹ J_cᵀ` (`n ≤ 6` rows).
struct Local {
    n: usize,
    w: [[DVec3; 2]; MAX_ROWS],
    l: [[f64; MAX_ROWS]; MAX_ROWS],
}

impl Local {
    fn new() -> Self {
        Self {
            n: 0,
            w: [[DVec3::ZERO; 2]; MAX_ROWS],
            l: [[0.0; MAX_ROWS]; MAX_ROWS],
        }
    }

    /// Builds `w` and factors `A` from the first `n` rows' columns `lin`, `ang`;
    /// `false` when a pivot is not positive and finite.
    fn factor(
        &mut self,
        rows: &JointRows,
        n: usize,
        lin: usize,
        ang: usize,
        inv_m: f64,
        iinv: &constraint_core::DMat3,
    ) -> bool {
        self.n = n;
        match n {
            1 => self.factor_n::<1>(rows, lin, ang, inv_m, iinv),
            2 => self.factor_n::<2>(rows, lin, ang, inv_m, iinv),
            3 => self.factor_n::<3>(rows, lin, ang, inv_m, iinv),
            4 => self.factor_n::<4>(rows, lin, ang, inv_m, iinv),
            5 => self.factor_n::<5>(rows, lin, ang, inv_m, iinv),
            6 => self.factor_n::<6>(rows, lin, ang, inv_m, iinv),
            _ => false,
        }
    }

    #[inline(always)]
    fn factor_n<const N: usize>(
        &mut self,
        rows: &JointRows,
        lin: usize,
        ang: usize,
        inv_m: f64,
        iinv: &constraint_core::DMat3,
    ) -> bool {
        for k in 0..N {
            self.w[k] = [rows.rows[k][lin] * inv_m, *iinv * rows.rows[k][ang]];
        }
        // `A`'s lower triangle, factored in place (`A = L Lᵀ`).
        for p in 0..N {
            for q in 0..=p {
                let mut s =
                    rows.rows[p][lin].dot(self.w[q][0]) + rows.rows[p][ang].dot(self.w[q][1]);
                for k in 0..q {
                    s -= self.l[p][k] * self.l[q][k];
                }
                if p == q {
                    if !(s > 0.0) || !s.is_finite() {
                        return false;
                    }
                    self.l[p][p] = libm::sqrt(s);
                } else {
                    self.l[p][q] = s / self.l[q][q];
                }
            }
        }
        true
    }

    /// The step `δ = −M_c⁻¹ J_cᵀ A⁻¹ C`; `c` is overwritten by the multipliers.
    fn step(&self, c: &mut [f64; MAX_ROWS]) -> (DVec3, DVec3) {
        match self.n {
            1 => self.step_n::<1>(c),
            2 => self.step_n::<2>(c),
            3 => self.step_n::<3>(c),
            4 => self.step_n::<4>(c),
            5 => self.step_n::<5>(c),
            _ => self.step_n::<6>(c),
        }
    }

    #[inline(always)]
    fn step_n<const N: usize>(&self, c: &mut [f64; MAX_ROWS]) -> (DVec3, DVec3) {
        let l = &self.l;
        // L y = −C, then Lᵀ z = y.
        for p in 0..N {
            let mut s = -c[p];
            for k in 0..p {
                s -= l[p][k] * c[k];
            }
            c[p] = s / l[p][p];
        }
        for p in (0..N).rev() {
            let mut s = c[p];
            for k in p + 1..N {
                s -= l[k][p] * c[k];
            }
            c[p] = s / l[p][p];
        }
        let (mut dx, mut dth) = (DVec3::ZERO, DVec3::ZERO);
        for k in 0..N {
            dx += self.w[k][0] * c[k];
            dth += self.w[k][1] * c[k];
        }
        (dx, dth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::ball_chain;

    /// A limit on a joint without coordinates (a ball joint; `set_dof_limit` refuses
    /// it, so it is written into the table directly) is skipped by the sweep, as the
    /// projection's error skips it: no NaN enters the sweep's error, and the run has
    /// the same bits as without the limit.
    #[test]
    fn a_limit_on_a_joint_without_coordinates_is_skipped() {
        let method = Method::VelocityProjected {
            beta: 0.0,
            tolerance: 1e-10,
            max_iterations: 20,
            correct_velocity: false,
        };
        let run = |limit: bool| {
            let mut w = ball_chain(4, 1.0).unwrap();
            if limit {
                w.limits[1][0] = Some([-0.1, 0.1]);
            }
            for (i, b) in w.bodies_mut().iter_mut().enumerate() {
                let k = i as f64;
                b.omega = DVec3::new(3.0 + k, -2.0 * k, 5.0 - k);
            }
            let mut iterations = 0;
            for _ in 0..40 {
                iterations += w.step(5e-3, method).unwrap().projection_iterations;
            }
            (w, iterations)
        };
        let (plain, it_plain) = run(false);
        let (limited, it_limited) = run(true);
        assert!(limited.coordinates_of(1).is_none());
        assert_eq!(it_plain, it_limited);
        for (a, b) in plain.bodies().iter().zip(limited.bodies()) {
            assert_eq!(a.pose.x.to_array(), b.pose.x.to_array());
            assert_eq!(a.pose.q.to_array(), b.pose.q.to_array());
            assert!(b.pose.x.is_finite() && b.pose.q.is_finite());
        }
        let sep = limited.max_separation();
        println!("Newton iterations {it_limited}, separation {sep:e} m");
        // The sweep closed the joints: measured 0 Newton iterations in 40 steps and a
        // separation of 4.8e-15 m.
        assert!(sep <= 1e-10);
    }

    /// `touching` marks exactly the tree nodes on the path from a penetrating body up
    /// to its tree's root (the joints whose child subtree holds it), and nothing for a
    /// body out of contact.
    #[cfg(feature = "contact")]
    #[test]
    fn touching_marks_the_branch_above_a_penetrating_body() {
        let mut w = crate::scenes::chain_on_floor(4, 0.3, 0.5).unwrap();
        // Link 2 sunk 5 mm into the floor (its capsule's radius is 10 mm); the others
        // 0.29 m above it.
        w.bodies_mut()[2].pose.x.z = 0.005;
        w.step(1e-3, Method::default()).unwrap();
        assert!(w.contacts().iter().any(|c| c.depth > 0.0));
        let mut s = SweepScratch::default();
        w.touching(&mut s);
        let parent = &w.solver.parent;
        let mut path = vec![false; parent.len()];
        let mut node = 2;
        while node != NONE {
            path[node] = true;
            node = parent[node];
        }
        assert_eq!(s.touch, path);
        // Some joint is off the path (the chain has 3 joints, at most 2 above link 2
        // in any tree order): it is swept.
        assert!(w.solver.joint_node.iter().any(|&n| !s.touch[n]));
    }
}
