//! Newton projection onto `C(x) = 0` with mass-weighted minimum-norm steps (Goldenthal
//! et al. 2007), with backtracking. Joint limits that are violated join the projection
//! as equalities at their bound, so a step that ends past a stop is brought back to it
//! (the minimum-norm step onto the joints alone can move a coordinate loaded against
//! its stop: `scenes/ragdoll.xml`'s shoulder went 3.9e-3 rad past it, about 5e-4 rad a
//! step, while the ragdoll lay on that arm). A limit closer to its bound than the
//! projection's tolerance counts as reached (its row holds it at the bound): a
//! coordinate that an earlier projection left at its stop keeps its row from the first
//! iteration, so the Newton step does not first push it past the stop and the chord
//! steps do not let it back out (dm humanoid passive: 420 → 161 Newton steps in 161
//! projections, 1 s).
//!
//! This step's contacts (feature `contact`) join as one-sided rows `d(x) ≥ −slop`,
//! `z ≥ 0`: in each iteration the rows the joints' step would violate go into a
//! complementarity problem through the factor (`contact.rs`), so the projection pushes
//! a contact out to the slop and never pulls one in (without them its minimum-norm step
//! moved feet into the floor freely).
//!
//! The first iteration factors the matrix at the iterate; the later ones are chord
//! steps with that factor (`chord.rs`), refactoring when one contracts slowly.
//!
//! A step that took a limit without a row (inside its range by more than the
//! tolerance) past its bound while the rest of the error (joints, equalities, tendon
//! ranges, contacts) decreased is kept, and the limit's row joins the next iteration
//! (at most `MAX_LIMIT_EXCEPTIONS` such steps a projection). Before, the backtracking
//! halved such a step (humanoid_CMU's arms: separation 7e-5 m → 8e-9 m at the full
//! step, but a limit 2.8e-4 rad past its bound, so the step went to a quarter and left
//! the joints 5e-5 m apart) and the next iteration refactored. humanoid_CMU controlled
//! 0.5 s: 916 → 769 error evaluations in 250 projections.
//!
//! Tried and left out: a limit whose row joined an iteration keeping it for the rest of
//! the projection (a row that ends its step 1e-9 rad inside the bound leaves, and the
//! chord step after it moves the coordinate past again): 916 → 755 evaluations, but
//! coordinates then end exactly at their bounds, and humanoid_CMU controlled 2 s stopped
//! at a velocity-level LCP that did not converge (residual 3.7e-2; with 0, 1 or 4 kept
//! steps as well), where without it the run finishes.
//!
//! Why a controlled run costs more than a passive one (issue 13, `simulate … --duration
//! 2`, callgrind `--toggle-collect` on `World::step`): dm_control's cheetah 54.72M
//! instructions controlled against 34.17M passive. Both take the velocity level and
//! this projection on nearly every step (one-sided rows present: 191 of 200 steps
//! controlled, 200 passive), so RATTLE is not what is lost. The projection needs 678
//! iterations (3.4 a step: 192 Newton steps and 440 chord steps in 191 projections)
//! against 222 (1.1), `project` 18.3M against 12.1M: the controlled bodies move fast,
//! and the velocity level's end misses the joints by more. The active set needs 412
//! iterations against 209 and sends 18 steps to the dense path (13 after 4
//! iterations, 3 after 5, 2 at the cap of 12; the dense solves 4.4M plus the tries),
//! with up to 4 contacts against 2. gymnasium's half_cheetah the same: 756 projection
//! iterations against 232, 7 dense steps.
//!
//! Measured again with the sweep (session 42, main 7bcef91, the same tools): gymnasium
//! half_cheetah 32.48M controlled against 23.47M passive. The velocity level 16.48M
//! in 168 steps against 16.27M in 190 (98k a step against 86k); this projection 8.64M
//! against 3.90M (51k against 21k); RATTLE, on the steps without one-sided rows, 5.14M
//! in 32 steps against 0.99M in 10. The projection's difference is its Newton loop: 84
//! of the 168 controlled projections run it, none of the passive ones (the sweep
//! closes them). Of the 84, 21 follow a sweep that put a foot past the slop (no
//! contact violated before it, 2e-4 to 5e-4 m after it: the child-only step gives the
//! whole joint correction to the foot), and 63 were not swept because those misses
//! paused the sweep (`sweep.rs`, `MISSES`) while only the tree joints were apart
//! (dm cheetah: 15 and 35 of 50).
//!
//! Tried and left out (session 42, bits changed): ending that pause when a projection
//! it skipped starts with only the swept joints apart (the equalities, tendon ranges,
//! contacts and the other hard joints within the tolerance), for the next projection
//! or for this one. half_cheetah controlled: Newton projections 84 → 33, `project`
//! 8.64M → 7.54M, World::step 32.48M → 31.40M (−3.3 %); but a sweep there costs about
//! 24k instructions, near the single Newton iteration it replaces, and the changed
//! trajectories moved the rest more: dm cheetah 32.68M → 32.97M, dm hopper passive
//! 48.97M → 52.20M (its projection −0.1M, its velocity level +3.3M), stacker 701.52M →
//! 718.32M, manipulator 425.23M → 441.45M, walker 118.55M → 116.10M (sweeping now
//! instead of from the next projection: half_cheetah 31.53M, dm cheetah 33.16M).
//!
//! Tried and left out (issue 13, the same bits): the start error reading the hard
//! joints' values from the rows the first Newton step assembles at the same poses
//! (computed there into the rows' cache with the assembly's arguments, so the assembly
//! finds them), after a projection that iterated. 13 reference runs `cmp`-equal, but
//! World::step instructions +0.2 to +0.3 % on the small models (half_cheetah controlled
//! 34.64M → 34.75M), −0.3 % on pusher controlled, −0.03 to −0.13 % on the humanoids: a
//! hinge's rows cost about its value and the cache's key, and a hinge with a limit has
//! to keep `Joint::value_into` (its angle needs the directions the rows do not keep;
//! through `coordinates_of` instead: half_cheetah +0.45 %).

use constraint_core::rigid::rotate_by;
use constraint_core::DVec3;

mod branch;
mod chord;
mod limits;
mod sweep;

use super::*;
use chord::CHORD_RATE;

/// The most steps of one projection kept although they took a limit past its bound
/// (`World::project`); each adds at least one limit row to the next iteration.
const MAX_LIMIT_EXCEPTIONS: usize = 2;

/// The projection's reused buffers (no allocation per iteration once grown).
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    /// Per-body state at the start of an iteration.
    base: Vec<(Pose, DVec3, DVec3)>,
    /// The hard joints' `C(x)` ([`Joint::value`]) at the poses of the last
    /// [`World::projection_error`], per joint (soft joints: not written); a chord step's
    /// right-hand side `−C(x_k)` reads them when they are at its iterate.
    values: Vec<[f64; MAX_ROWS]>,
    /// The hard hinges' directions `[n, u]` ([`Joint::value_into`]) at the poses of
    /// `values`, per joint (other joints: not written): the limits' error takes the
    /// hinge's angle from them ([`constraint_core::Hinge::angle_from`]).
    dirs: Vec<[DVec3; 2]>,
    /// Whether `values` are at the current poses (no pose changed since they were
    /// evaluated).
    values_current: bool,
    /// The hinges' start angles for the limits' error (`limits.rs`).
    limits: limits::LimitRefs,
    /// The joints' last recorded hinge angles: the branch of the next ones
    /// (`branch.rs`, continuous across `±π`).
    pub(super) branch: branch::AngleBranches,
    /// The joints with a limit within the tolerance of its bound (or past it) at the
    /// poses of the last error evaluation with the limits, in joint order: exactly the
    /// joints [`World::push_violated_limits`] pushes rows for at those poses.
    near: Vec<usize>,
    /// `near` of the iterate while a backtracking's trials overwrite it.
    near_base: Vec<usize>,
    /// The tree-ordered sweep's setting and buffers (`sweep.rs`).
    sweep: sweep::SweepScratch,
}

impl World {
    /// Newton projection onto `C(x) = 0` with mass-weighted minimum-norm steps
    /// `[M Jᵀ; J 0][δ; λ] = [0; −C]` (Goldenthal et al. 2007, fast projection).
    pub(super) fn project(
        &mut self,
        tolerance: f64,
        max_iterations: usize,
        velocity_ctx: Option<&StepContext>,
    ) -> Result<usize, ArticulatedError> {
        let velocity_h = velocity_ctx.map(StepContext::h);
        // The tree joints closed one by one, parents first (`sweep.rs`; by default the
        // trees rooted at the world), on projections of the positions alone: a
        // child-only step as a velocity correction would be an impulse without its
        // reaction on the parent.
        let swept = velocity_h.is_none() && self.sweep_tree_joints(tolerance);
        self.proj.values_current = false;
        // Steps kept although a limit went past its bound (below): at most this many.
        let mut exceptions = MAX_LIMIT_EXCEPTIONS;
        self.start_limit_refs(tolerance);
        // This step's contacts join as one-sided rows (`d ≥ −slop`, push only).
        #[cfg(feature = "contact")]
        self.load_projection_contacts();
        // Compliant joints are not projected (their separation is their spring's).
        // Equality rows are projected with the joints: `[M Eᵀ; E 0][δ; ν] = [0; −C_E]`.
        // Violated (or reached) joint limits join as equalities until an iteration with them finds no
        // decrease; then the joints are projected without them (as without contacts).
        let mut limits = true;
        // The error and whether a limit is violated at the iterate (no limit rows to
        // look for otherwise: the coordinates are not evaluated again).
        let (mut err, mut past, _) = self.projection_error(limits);
        self.proj.sweep.note(swept, err > tolerance);
        // Whether the solver holds this projection's factor (of an earlier iterate):
        // the next iteration is then a chord step (`chord.rs`).
        let mut factored = false;
        for it in 0..max_iterations {
            // Half the iterations spent with the limits and still not converged (the
            // damped rate rows near a gimbal lock are not the coordinates' exact
            // gradients, constraint_core::compound): the rest project the joints alone.
            if limits && 2 * it >= max_iterations && err > tolerance {
                limits = false;
                (err, past, _) = self.projection_error(limits);
            }
            if err <= tolerance {
                return Ok(it);
            }
            if it == 0 {
                // The hinges' limits are measured from here (`limits.rs`).
                self.record_start_orientations();
            }
            let chord = factored;
            let mut loops = if chord {
                self.chord_rhs()
            } else {
                self.body_rhs(|_, _, _| (DVec3::ZERO, DVec3::ZERO));
                self.assemble(1.0, Rates::None, Soft::Free, |_, _, rows, rhs| {
                    for r in 0..rows.n_hard {
                        rhs[r] = -rows.value[r];
                    }
                })
            };
            if limits && past {
                self.push_violated_limits(&mut loops, tolerance);
            }
            self.load_equalities(|c| -c);
            self.push_violated_tendon_limits();
            if chord {
                let out = self.solve_factored(&loops);
                self.last_loops = loops;
                out?;
            } else {
                self.solve(loops)?;
                factored = true;
            }
            // The contacts' rows; where their problem has no solution the projection
            // goes on without them (the error then leaves them out too).
            #[cfg(feature = "contact")]
            if !self.push_contacts_apart() {
                (err, past, _) = self.projection_error(limits);
            }
            // Backtracking: a full Newton step can overshoot far from the manifold (light
            // bodies turned by large angles); halve it until the separation decreases.
            // The iterate the trials start from, in a reused scratch (no allocation per
            // iteration).
            let mut base = core::mem::take(&mut self.proj.base);
            base.clear();
            base.extend(self.bodies.iter().map(|b| (b.pose, b.v, b.omega)));
            let err_before = err;
            // The iterate's near limits, restored if no trial is accepted.
            core::mem::swap(&mut self.proj.near, &mut self.proj.near_base);
            self.proj.near.clear();
            let mut alpha = 1.0;
            let mut accepted = false;
            let mut fast = false;
            for _ in 0..8 {
                for i in 0..self.bodies.len() {
                    let (dx, dth) = self.body_solution(i);
                    let (pose, v, w) = base[i];
                    let b = &mut self.bodies[i];
                    b.pose.x = pose.x + dx * alpha;
                    b.pose.q = rotate_by(pose.q, dth * alpha);
                    if let Some(h) = velocity_h {
                        b.v = v + dx * (alpha / h);
                        b.omega = w + dth * (alpha / h);
                    }
                }
                let (trial, trial_past, trial_rest) = self.projection_error(limits);
                if trial < err {
                    (err, past) = (trial, trial_past);
                    accepted = true;
                    fast = err <= CHORD_RATE * err_before;
                    break;
                }
                // A limit that the step took past its bound (its row was not in the
                // step: it was inside by more than the tolerance) while the joints'
                // separation and the rest decreased: the step is kept and the limit's
                // row joins the next iteration, instead of halving the step towards
                // the bound (which left both apart and the next iteration a Newton
                // step). At most `MAX_LIMIT_EXCEPTIONS` a projection.
                if exceptions > 0 && limits && trial_past && trial_rest < err {
                    exceptions -= 1;
                    (err, past) = (trial, trial_past);
                    accepted = true;
                    fast = trial_rest <= CHORD_RATE * err_before;
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted {
                self.proj.values_current = false;
                core::mem::swap(&mut self.proj.near, &mut self.proj.near_base);
                for (b, &(pose, v, w)) in self.bodies.iter_mut().zip(&base) {
                    b.pose = pose;
                    b.v = v;
                    b.omega = w;
                }
            }
            self.proj.base = base;
            // A step that contracted the error slowly (`‖C‖` more than `CHORD_RATE` of
            // what it was: the chord steps would contract at about that rate) or, as a
            // chord step, did not decrease it: the next iteration refactors at this
            // iterate (a Newton step), before anything is dropped.
            if !(accepted && fast) {
                factored = false;
                if chord && !accepted {
                    continue;
                }
            }
            if !accepted {
                // Contacts that the joints (and limits) do not let out: the iteration
                // again without them, so the joints are still projected.
                #[cfg(feature = "contact")]
                if !self.projection.contacts.is_empty() {
                    self.projection.contacts.clear();
                    (err, past, _) = self.projection_error(limits);
                    continue;
                }
                // Limits that the joints do not let back to their bounds: a three-hinge
                // joint near its gimbal lock (humanoid_CMU's shoulders have their
                // `ry` limit at 90°, the lock itself) has rate rows growing as
                // `1/cos q₂`, and with them the Newton step of the limit rows is lost
                // to round-off: no trial decreased the error, and the joints were left
                // apart (up to 8e-4 m). The iteration again without the limits, so the
                // joints are still projected; the limits stay with the next step's
                // velocity-level rows.
                if limits {
                    limits = false;
                    (err, past, _) = self.projection_error(limits);
                    continue;
                }
                return Ok(it + 1);
            }
        }
        Ok(max_iterations)
    }

    /// What the projection drives to zero: the hard joints' separation, the
    /// equalities' `|C|`, the joint limits' violations `max(lo − q, q − hi)` (m or
    /// rad) and the tendon ranges' `max(lo − L, L − hi)`.
    /// Without `limits`, the joint limits' violations are left out. With the error,
    /// whether a joint limit is reached (`max(lo − q, q − hi) > −tolerance`: exactly
    /// when [`Self::push_violated_limits`] pushes a row at these poses), and the error
    /// without the joint limits' violations.
    /// The hard joints' values are kept for the next chord step (`Scratch::values`).
    fn projection_error(&mut self, limits: bool) -> (f64, bool, f64) {
        let separation = self.hard_separation_keeping_values();
        let (limit, near) = if limits {
            self.max_limit_violation_tracked()
        } else {
            (0.0, false)
        };
        let rest = separation
            .max(self.max_equality_violation_by(|j| self.error_coordinates(j)))
            .max(self.max_tendon_limit_violation());
        #[cfg(feature = "contact")]
        let rest = rest.max(self.max_contact_violation());
        (rest.max(limit), near, rest)
    }

    /// Largest separation of the hard joints (the ones the projection enforces;
    /// [`Joint::separation`], maxima in joint order), keeping each one's `C(x)` in
    /// `Scratch::values`.
    fn hard_separation_keeping_values(&mut self) -> f64 {
        let mut values = core::mem::take(&mut self.proj.values);
        let mut dirs = core::mem::take(&mut self.proj.dirs);
        values.resize(self.joints.len(), [0.0; MAX_ROWS]);
        dirs.resize(self.joints.len(), [DVec3::ZERO; 2]);
        let mut worst = 0.0;
        for ((j, joint), (v, d)) in self
            .joints
            .iter()
            .enumerate()
            .zip(values.iter_mut().zip(&mut dirs))
        {
            if self.is_soft(j) {
                continue;
            }
            let a = joint
                .parent
                .map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
            let b = &self.bodies[joint.child].pose;
            if let Some(n_u) = joint.value_into(a, b, v) {
                *d = n_u;
            }
            worst = f64::max(worst, joint.separation_of(v));
        }
        self.proj.values = values;
        self.proj.dirs = dirs;
        self.proj.values_current = true;
        worst
    }

    /// Adds each violated limit, and each within `tolerance` of its bound, as an
    /// equality row at its bound to the projection's loop
    /// rows: `±G δ = −C` with `C = q − lo` (lower) or `hi − q` (upper), `G` the rate row
    /// of the coordinate (Schur complement with the joints, as loop joints are).
    /// The joints are those the last error evaluation found near a bound
    /// (`Scratch::near`, at these poses and this tolerance): the others have no limit
    /// within `tolerance`, so their coordinates are not evaluated again.
    fn push_violated_limits(&self, loops: &mut LoopRows, tolerance: f64) {
        // The rows read by reference (the coordinate table's entry, no copy of it).
        let mut scratch = ([0.0; MAX_DOF], [[DVec3::ZERO; 4]; MAX_DOF]);
        for &ji in &self.proj.near {
            let joint = &self.joints[ji];
            let Some((q, rows)) = self.coordinates_and_rows_ref(ji, &mut scratch) else {
                continue;
            };
            for (d, lim) in self.limits[ji].iter().enumerate() {
                let Some([lo, hi]) = *lim else { continue };
                for (c, sign) in [(q[d] - lo, 1.0), (hi - q[d], -1.0)] {
                    if c < tolerance {
                        loops
                            .0
                            .push((joint.parent, joint.child, rows[d].map(|r| r * sign)));
                        loops.1.push(0.0);
                        loops.2.push(-c);
                    }
                }
            }
        }
    }
}
