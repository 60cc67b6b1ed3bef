//! RATTLE (Andersen 1983) for rigid bodies in maximal coordinates, and its fallback.
//!
//! # Joint damping
//!
//! Damping is split off the conservative step (Strang splitting). With `C_h` the
//! undamped RATTLE step (gravity, compliant springs, hard joints), `C⁰_h` the same
//! without gravity and springs (the constrained drift), `D_τ` the flow of the damping
//! alone at frozen positions and `B_τ` that of damping, gravity and springs together:
//!
//! ```text
//! RATTLE  = B_{h/2} ∘ C⁰_h ∘ B_{h/2}
//! RATTLE4 = D_{h/2} ∘ C_{w₁h} ∘ C_{w₀h} ∘ C_{w₁h} ∘ D_{h/2}
//! ```
//!
//! At frozen positions the velocities obey a linear ODE, `M v̇ = f − Σ J_dᵀ d J_d v −
//! Jᵀλ` with `J v = 0` (`f` zero for `D`), approximated by the two-stage L-stable SDIRK
//! (Alexander 1977), `γ = 1 − 1/√2`:
//!
//! ```text
//! v₁ = BE_{γτ}(v),   v' = BE_{γτ}(v + (1 + √2)(v₁ − v)),
//! BE_s(u): [M Jᵀ J_dᵀ; J 0 0; J_d 0 −1/(s d)] [v; λ; λ_d] = [M u + s f; 0; 0],
//! R(z) = (1 − (√2 − 1) z) / (1 + γ z)² = e^{−z} + O(z³),   |R(z)| ≤ 1,   R(∞) = 0,
//! ```
//!
//! (`z = τ d / I` on one mode): one factorization of the backward-Euler KKT matrix (the
//! damping rows with compliance `1/(γτ d)`) and two solves. With second-order pieces
//! each split is second order. The choices:
//!
//! * RATTLE puts gravity and springs in `B` with the damping, so a joint damped far
//!   past the step (`h d/I ≫ 1`) relaxes inside `B` to its creep rate `v = A⁻¹ f`
//!   before the drift, as in the physics, instead of drifting over `h` with the
//!   undamped gravity kick (`tests/rattle_damping.rs`, `h d/I = 100`: the rate within
//!   0.65 % of the creep rate, against 9× too fast under RATTLE4). Without damping `B_τ` is the
//!   exact constant-force kick and the split is RATTLE again (the constraint impulses
//!   of the kicks are fixed by SHAKE and by `J v' = 0` whatever the split of the force).
//! * RATTLE4 keeps gravity and springs inside the triple jump so that its error tends
//!   to the fourth-order one as `d → 0`, and keeps damping outside it: inside, the
//!   middle step `w₀h < 0` would need anti-damping `exp(+|w₀|h A/2)` for the
//!   composition to keep its order, and every implicit form of that blows up (the
//!   trapezoidal `(1 − τA/2)/(1 + τA/2)` is singular at `|w₀| h d/(2I) = 2`). The old
//!   code damped the negative step positively (`|h|/2` per kick), so damping acted over
//!   `(2w₁ + |w₀|) h ≈ 4.4 h` per step. The price: RATTLE4 is stable for any `h d/I`
//!   but, like any split with the gravity kick before the drift, creeps too fast when
//!   `h d/I ≫ 1` (above) — use RATTLE there.
//! * An L-stable `D` rather than a time-symmetric one: a rational `R` with
//!   `R(z) R(−z) = 1` has `|R(∞)| = 1`, so under the trapezoidal rule a heavily damped
//!   joint would keep its rate, `R(z/2)² → 1`, instead of stopping. The exact
//!   exponential needs the dense constrained operator; SDIRK2 costs the factorization
//!   of the velocity level.
//! * Other velocity-dependent forces — velocity actuators (`b₂ q̇`), damped tendons,
//!   fluid drag — are split off like the damping: the kicks of `C` take the actuator,
//!   spring and tendon forces at rest `τ(q, 0)` only (so they stay symplectic), and `B`
//!   / `D` take the rest `τ(q, q̇) − τ(q, 0)` and the drag *explicitly*, paired with the
//!   SDIRK stages by the explicit tableau of Ascher–Ruuth–Spiteri's IMEX(2,2,2) (1997),
//!   `δ = 1 − 1/(2γ)`: stage 1 at `v`, stage 2 with `τ (δ − 1 + γ) f(v) + τ (1 − δ)
//!   f(v₁)`, second order. Scenes `actuated` and `fluid_drag` against MuJoCo RK4
//!   (`verify/tests/mujoco_reference.rs`, 2 s at dt = 1e-3): RATTLE 2.42e-6 and 4.65e-7
//!   m, ratio 4.00 for half the step; with these forces explicit in the kicks it was
//!   2.13e-4 and 6.11e-4 m, first order. Without such forces nothing changes (bit for
//!   bit).
//! * Tried without damping rows (issue 13): no flows, the velocity-dependent forces
//!   back in the kicks, the second at `x₁` and the extrapolated twists `ṽ = 2 v½ −
//!   v₀ = v₁ + O(h²)` — second order, four tree solves and two drag evaluations fewer
//!   per step (swimmer6, 2 s controlled: 144.4M → 112.8M instructions in
//!   `World::step`), but less accurate: `fluid_drag` 4.65e-7 → 5.27e-7 m, swimmer6
//!   against MuJoCo RK4 8.0e-7 → 1.1e-6 m, gymnasium swimmer 3.1e-7 → 6.2e-7 m. On a
//!   linear drag (`z = h c/m`) two evaluations per step err `z³/6` per step, the two
//!   flows' four `2 (z/2)³/6 = z³/24`; correcting the second kick once at `v₁` (the
//!   implicit trapezoidal rule) erred more still, 2.46e-6 m on `fluid_drag`.
//! * RATTLE's `C⁰_h` starts without its first kick (`conservative_step_with`,
//!   `after_flow`): `B_{h/2}` holds the hard rows at `J(x₀) v = 0`, so the kick
//!   `[M Jᵀ; J 0][v½; λ] = [M v; −C(x₀)/h]` only aimed the drift at the last step's SHAKE
//!   residual `C(x₀)` (at most the tolerance) and its `λ` was that small. SHAKE starts
//!   from `v½ = v` with the kick's factor (kept, `factor_cache.rs`): its corrections
//!   run along the same `M⁻¹J(x₀)ᵀ` and stop at the same tolerance, so the step solves
//!   the same equations; results move at the tolerance's level. Issue 13 (callgrind,
//!   `World::step` per step): dm swimmer6 passive 92.3k → 83.9k instructions,
//!   controlled 108.2k → 102.0k, dm fish perturbed 105.1k → 98.5k, controlled 122.9k →
//!   116.0k, dm reacher perturbed 53.8k → 49.4k, controlled 76.1k → 71.1k; errors
//!   against MuJoCo RK4 unchanged to 8 digits. Worlds with loop joints or equalities
//!   still solve the kick (its loop rows and equality rows load with it).
//! * SHAKE's first correction also solves a predicted remainder (`ShakeHistory`): the
//!   chord iteration's total right-hand side is `−C` at the drift's end plus the later
//!   iterations' remainder, which changes smoothly from step to step; the first solve
//!   takes `−C + 2R₋₁ − R₋₂` (`R` of the last two steps, consecutive RATTLE steps with
//!   a skipped first kick and tree joints only), so the chord iteration starts `O(h²)`
//!   relatively closer to its fixed point. Same equations and stop, results move at the
//!   tolerance's level. Issue 13 (2 s, SHAKE solves / `World::step` instructions):
//!   dm swimmer6 controlled 1635 → 1065 / 94.27M → 89.90M, perturbed 1150 → 1003 /
//!   88.24M → 87.82M, fish controlled 1700 → 1442 / 52.43M → 51.25M, perturbed 1018 →
//!   535 / 48.04M → 45.43M, dm reacher controlled 499 → 487 / 6.561M → 6.610M (its 20
//!   ms steps: the remainder hardly predictable), gymnasium reacher 361 → 336 / 14.22M
//!   → 14.20M; repeating `R₋₁` alone: 1299, 1002, 1549, 578, 479, 341 solves. Errors
//!   against MuJoCo RK4 (`xtask models run`, perturbed): swimmer6 8.040018109e-7 →
//!   8.040018064e-7 m, fish 8.172783070e-6 → 8.172783012e-6, dm reacher
//!   2.3399109665e-5 both, gymnasium reacher 1.434310912e-7 both. After three
//!   recorded steps the extrapolation is quadratic, `3R₋₁ − 3R₋₂ + R₋₃` (`O(h³)`):
//!   solves 1065 → 754 / 89.92M → 87.18M on swimmer6 controlled, fish controlled
//!   1442 → 1400 / 51.27M → 51.05M, perturbed 535 → 520 / 45.44M → 45.40M; dm reacher
//!   487 → 499 / 6.613M → 6.673M and swimmer6 perturbed 87.82M → 87.93M (steps the
//!   remainder's history predicts less well).
//! * A flow's rows, inertias and forces at one configuration are not looked up
//!   again: the rows an assembly saw are taken in the same pose epoch without their
//!   14-word key (`CachedRows::seen`; the flow's second stage, the drift's armature
//!   rows, the flow after the second kick), and the next step's first flow trusts the
//!   last one's factor, rows, inertias and actuator forces when nothing was assembled
//!   or written since (`World::flow_end`, `DofFlow`). Issue 13 (callgrind, `World::step`,
//!   2 s; the same bits): dm swimmer6 passive 76.33M → 72.21M instructions, perturbed
//!   86.98M → 82.81M, controlled 86.66M → 83.68M; dm fish perturbed 44.53M → 43.02M,
//!   controlled 50.69M → 49.24M.
//! * Where the smooth swimmers' steps go (issue 13, callgrind on `World::step`, 2 s,
//!   main 7bcef91). dm fish perturbed, 85.9k instructions a step: two factorizations
//!   (19 %; the second kick's at the new poses and the damping flow's, whose damping
//!   rows — fish's hinges have `damping="2e-5"` — give it another key), five flow and
//!   kick solves plus about one SHAKE correction (20 %), assemblies (16 %), actuator,
//!   spring and tendon forces (9 %), drift and SHAKE (13 %), fluid (6 %).
//!   Fish at rest (the suite's passive case, 38.6k a step) moves no bit, so it factors
//!   nothing: the perturbed case's extra half is the two factorizations (16.6k), the
//!   assembly and force evaluation at new poses and SHAKE. The same model without its
//!   joint damping runs 35.25M instead of 42.56M (one factorization of 6.1k a step
//!   instead of two of 8.3k). dm swimmer6 passive, 71.7k a step: five solves (27 %),
//!   one factorization (15 %), assemblies (16 %), fluid (8 %), drift and SHAKE (11 %),
//!   the flows' own loops (9 %); without its fluid (no flows) 50.08M instead of
//!   71.72M, without its armature 64.59M.
//! * The old kicks (backward-Euler damping at `v½` and at `v'`) gave
//!   `(1 + hA/2)⁻² = 1 − hA + ¾ h²A² + …`, an `O(h²)` local error: first order.

use alloc::vec::Vec;

use constraint_core::rigid::rotate_by;
use constraint_core::{DMat3, DVec3, Pose};

use super::actuator::ForcePart;

use super::*;

/// Relative change `|ω*ₖ₊₁ − ω*ₖ| ≤ DRIFT_STOP |ω*ₖ₊₁|` at which the drift's fixed point
/// `ω* = I(q_mid)⁻¹ L` stops (at most 4 sweeps). Each sweep contracts the error by
/// about `c ≈ (h/2)|ω|` times the inertia's anisotropy (`c ≤ MAX_TURN/2` where the
/// step is kept), so the iterate kept errs by at most `c/(1 − c) · DRIFT_STOP`
/// relative: round-off. It replaces a bit-exact stop (`ω*ₖ₊₁ = ω*ₖ` to the bit), which
/// ran more sweeps wherever the sweeps' last bits jittered; the sweep also applies
/// `R I⁻¹ Rᵀ` to `L` as three matrix–vector products instead of forming the matrix.
/// Measured (issue 13, callgrind `--toggle-collect` on `World::step`, `simulate … --duration
/// 2`): dm_control swimmer6 controlled 125.97M → 121.36M instructions, passive 99.17M →
/// 98.77M, gymnasium swimmer controlled 16.40M → 15.71M; recorded states within 3e-23 of
/// the old ones; smooth-model errors against MuJoCo RK4 and `mujoco_reference`'s RATTLE
/// errors unchanged to the printed digits.
const DRIFT_STOP: f64 = 1e-14;

/// Buffers RATTLE reuses from step to step (no allocation once they have grown to the
/// world's size).
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    /// Joint impulses of the first kick.
    first_kick: Vec<[f64; MAX_ROWS]>,
    /// Body world inertias `R₀ I R₀ᵀ` at the start of the drift.
    inertia0: Vec<DMat3>,
    /// Armature joints: joint, its `n_hard` and `n`, the start of its rate rows in
    /// `arm_rows`, the carried coordinate rates.
    arm: Vec<(usize, [usize; 3], [f64; MAX_ROWS])>,
    /// The armature joints' rate rows `r ∈ n_hard..n` at the start, one after another
    /// (only the rows read, not each joint's whole row set).
    arm_rows: Vec<[DVec3; 4]>,
    /// The damping flow's second-stage twists `v + (1 + √2)(v₁ − v)`.
    stage: Vec<(DVec3, DVec3)>,
    /// The damping flow's first-stage twists `v₁` (with velocity-dependent forces).
    v1: Vec<(DVec3, DVec3)>,
    /// Rate-row counts of the joints (with loop joints only).
    passive: Vec<usize>,
    /// A SHAKE iteration's body corrections over `h`, `(δx/h, δθ/h)` (with armature
    /// rows only).
    shake_rates: Vec<(DVec3, DVec3)>,
    /// SHAKE's remainders of the last steps, for its predictor.
    history: ShakeHistory,
    /// The forces of the last flow with forces ([`DofFlow`]).
    dof_flow: DofFlow,
    /// The impulses of the last force evaluation, flattened for their reapplication
    /// (`actuator.rs`).
    pub(super) impulses: super::actuator::DofImpulses,
}

/// The actuator, spring and tendon forces `τ(q, q̇)` (whole) that the first stage of
/// the last damping flow with forces evaluated, left in the world's buffers
/// (`World::reapply_dof_forces`): the next step's first flow at the same poses (RATTLE,
/// `World::flow_end`) applies them again instead of evaluating them, where that gives
/// the same bits — no evaluation since (`World::dof_evals`), the same controls bit
/// for bit and the same actuators, springs and tendons (only ever appended: their
/// counts), and forces that do not read the rates (`World::dof_forces_read_rates`; the
/// velocities differ between the two flows). dm fish perturbed: one evaluation of
/// three per step.
#[derive(Clone, Debug, Default)]
pub(super) struct DofFlow {
    /// Whether the record may be reused (forces that do not read the rates).
    valid: bool,
    /// `World::dof_evals` after the evaluation.
    evals: u64,
    /// Whether any force acts (`World::add_dof_forces_part`'s answer).
    any: bool,
    /// The controls of the evaluation.
    ctrl: Vec<f64>,
    /// The counts of actuators, springs and tendons.
    counts: [usize; 3],
}

impl DofFlow {
    /// Records an evaluation (`valid`: its forces do not read the rates).
    fn keep(&mut self, valid: bool, evals: u64, any: bool, ctrl: &[f64], counts: [usize; 3]) {
        self.valid = valid;
        self.evals = evals;
        self.any = any;
        self.ctrl.clear();
        self.ctrl.extend_from_slice(ctrl);
        self.counts = counts;
    }

    /// Whether the recorded forces are the ones an evaluation would give now (at the
    /// same poses): none evaluated since, same controls to the bit, same counts.
    fn holds(&self, evals: u64, ctrl: &[f64], counts: [usize; 3]) -> bool {
        self.valid
            && self.evals == evals
            && self.counts == counts
            && self.ctrl.len() == ctrl.len()
            && self
                .ctrl
                .iter()
                .zip(ctrl)
                .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

impl Scratch {
    /// Drops SHAKE's predictor history ([`ShakeHistory::forget`]).
    pub(super) fn forget_history(&mut self) {
        self.history.forget();
    }
}

/// SHAKE's predictor. The chord iteration's total right-hand side `T = Σₖ bₖ` (its
/// fixed point: `C(x(T)) = 0`, `x(T)` the drift's end moved by the solve of `T` with
/// the kick's factor) is its first term `b₀ = −C(x_drift)` plus a remainder `R` (the
/// later iterations', of relative size `O(h)`: the Jacobian's turn over the drift),
/// which changes smoothly from step to step. The first correction solves `b₀ + R̂` with
/// `R̂ = 3R₋₁ − 3R₋₂ + R₋₃` extrapolated from the last three steps (`2R₋₁ − R₋₂` after
/// two, `R₋₁` after one), so the chord iteration starts `O(h³)` relatively closer
/// (repeating `R₋₁`: `O(h)`, fewer iterations saved, module documentation). The
/// corrections stay in the range of `M₀⁻¹J₀ᵀ` and SHAKE still stops on
/// `|C(x)| ≤ tolerance`: the step solves the same equations, its result moves at the
/// tolerance's level.
#[derive(Clone, Debug, Default)]
pub(super) struct ShakeHistory {
    /// This step's remainder, accumulated.
    total: Vec<f64>,
    /// `R₋₁`.
    last: Vec<f64>,
    /// `R₋₂`.
    before: Vec<f64>,
    /// `R₋₃`.
    third: Vec<f64>,
    /// Consecutive steps recorded (0 to 3).
    kept: u8,
    /// The world's step count when `last` was recorded.
    step: u64,
}

impl ShakeHistory {
    /// Whether a prediction is at hand for the step after `steps` completed ones, of
    /// `size` unknowns: the last step was recorded (consecutive, same size).
    fn ready(&self, steps: u64, size: usize) -> bool {
        self.kept > 0 && self.step.checked_add(1) == Some(steps) && self.last.len() == size
    }

    /// Grows the records to `size` unknowns at once (the buffers rotate through
    /// [`Self::keep`]: each must hold a step's remainder, no allocation in later steps).
    fn reserve(&mut self, size: usize) {
        for v in [&mut self.last, &mut self.before, &mut self.third] {
            v.reserve(size.saturating_sub(v.len()));
        }
    }

    /// Adds `R̂` to `rhs` (of the recorded size), keeping it as this step's remainder
    /// so far.
    fn predict(&mut self, rhs: &mut [f64]) {
        let two = self.kept >= 2 && self.before.len() == self.last.len();
        let three = self.kept >= 3 && self.third.len() == self.last.len();
        for (i, (r, t)) in rhs.iter_mut().zip(self.total.iter_mut()).enumerate() {
            let p = if three {
                3.0 * self.last[i] - 3.0 * self.before[i] + self.third[i]
            } else if two {
                2.0 * self.last[i] - self.before[i]
            } else {
                self.last[i]
            };
            *r += p;
            *t = p;
        }
    }

    /// Records this step's remainder as `R₋₁` (during step `steps + 1`).
    fn keep(&mut self, steps: u64) {
        core::mem::swap(&mut self.third, &mut self.before);
        core::mem::swap(&mut self.before, &mut self.last);
        core::mem::swap(&mut self.last, &mut self.total);
        self.kept = if self.kept > 0 && self.step.checked_add(1) == Some(steps) {
            (self.kept + 1).min(3)
        } else {
            1
        };
        self.step = steps;
    }

    /// Drops the record (a step not recorded, or a state written by the user, breaks
    /// the sequence).
    pub(super) fn forget(&mut self) {
        self.kept = 0;
    }
}

impl World {
    /// Restores the start of the step and redoes it with the velocity level (with its geometric
    /// stiffness), then projects the positions back onto the joints (`tolerance`), so a
    /// fallback step keeps the joints as tight as a RATTLE step.
    pub(super) fn fall_back(
        &mut self,
        ctx: &StepContext,
        tolerance: f64,
        max_iterations: usize,
        stats: &mut StepStats,
    ) -> Result<(), ArticulatedError> {
        // Back to the start of the step (saved by `World::step`).
        self.restore_start();
        stats.fallbacks += 1;
        self.velocity_solve(ctx, 1.0)?;
        stats.projection_iterations += self.project(tolerance, max_iterations, None)?;
        Ok(())
    }

    /// One RATTLE step of `h`, or one sub-step `w h` of RATTLE4's triple jump (called by
    /// [`World::step`] as `w₁h, w₀h, w₁h`; `w₀ < 0`). Returns the projection iterations
    /// and whether every projection converged (to `10³ · tolerance`, at least 1e-9 m).
    ///
    /// Without damped joints this is the conservative step `C_h` alone (bit-identical to
    /// the step before damping was split off). With damping it applies the splittings of
    /// the module documentation, recognising its place from the sign of `h` and the
    /// start-of-step state saved by `World::step`:
    ///
    /// * `h > 0` at the start of the step: `B_{h/2} ∘ C⁰_h ∘ B_{h/2}` (RATTLE; also the
    ///   first sub-step of RATTLE4, which cannot know yet that it is one);
    /// * `h < 0` (RATTLE4's middle sub-step, so the whole step is `H = h/w₀`): back to
    ///   the start of the step, then `C_{w₀H} ∘ C_{w₁H} ∘ D_{H/2}` — the first sub-step
    ///   is redone;
    /// * `h > 0` after the start (RATTLE4's last sub-step): `D_{H/2} ∘ C_h`, `H = h/w₁`.
    ///
    /// The redo costs one extra sub-step per damped RATTLE4 step; calling `damp` and
    /// `conservative_step` from `World::step` directly would avoid it.
    ///
    /// `at_start`: the caller knows the bodies are the saved start of the step (RATTLE's
    /// one call from `World::step`), so they are not compared with it (13 bodies: about
    /// 900 instructions a step, 0.9 % of swimmer6's); `false` compares (RATTLE4's
    /// sub-steps).
    pub(super) fn rattle_step(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
        at_start: bool,
    ) -> Result<(usize, bool), ArticulatedError> {
        if !self.joints.iter().any(|j| j.damping_rows() > 0) && !self.has_velocity_forces() {
            return self.conservative_step(h, tolerance, max_iterations, true, false);
        }
        // Yoshida's weights, needed only by RATTLE4's sub-steps (`libm::cbrt` cost 135
        // instructions in every damped RATTLE step).
        let w1 = || 1.0 / (2.0 - libm::cbrt(2.0));
        if h < 0.0 {
            let w1 = w1();
            let w0 = 1.0 - 2.0 * w1;
            let full = h / w0;
            self.restore_start();
            let kept = self.damp(0.5 * full, false, false, false)?;
            let (first, ok) =
                self.conservative_step(w1 * full, tolerance, max_iterations, true, kept)?;
            if !ok {
                return Ok((first, false));
            }
            let (middle, ok) = self.conservative_step(h, tolerance, max_iterations, true, true)?;
            return Ok((first + middle, ok));
        }
        // A flow or step that ran to its end left the solver's factor at the bodies
        // (`unmoved` below): only velocities changed since its lookup.
        if at_start || self.bodies == self.saved {
            // The last step ended with its flow at these poses and nothing was assembled
            // or written since (`World::flow_end`): its factor, rows and inertias are
            // the bodies' (no keys compared).
            let unmoved = at_start && self.flow_end == Some((self.steps, self.rows_epoch));
            let kept = self.damp(0.5 * h, true, unmoved, unmoved)?;
            let (it, ok) =
                self.conservative_step_with(h, tolerance, max_iterations, false, kept, kept)?;
            if ok && self.damp(0.5 * h, true, true, false)? {
                self.flow_end = Some((self.steps + 1, self.rows_epoch));
            }
            return Ok((it, ok));
        }
        let (it, ok) = self.conservative_step(h, tolerance, max_iterations, true, false)?;
        if ok {
            self.damp(0.5 * h / w1(), false, true, false)?;
        }
        Ok((it, ok))
    }

    /// The velocity flow at frozen positions over `τ > 0` of the joint damping (`D_τ`),
    /// with `forces` also of gravity and the compliant joints' springs (`B_τ`), by the
    /// L-stable two-stage SDIRK of the module documentation (`γ = 1 − 1/√2`): two
    /// solves of the backward-Euler KKT system `[M Jᵀ J_dᵀ; J 0 0; J_d 0 −1/(γτ d)]`
    /// with one factor, right-hand side `M u (+ γτ f)`, the hard rows held at `J v = 0`
    /// (the compliant joints' hard rows free, as in the conservative step). Velocities
    /// change, positions and the stored joint impulses do not.
    ///
    /// `unmoved`: the caller knows that the bodies have not moved since the solver's
    /// factor was looked up or computed at them ([`World::reuse_factor_unmoved`]).
    /// `at_last_flow`: the caller knows that the bodies have not moved since the last
    /// flow with forces evaluated the actuator, spring and tendon forces (RATTLE's flow
    /// at the end of the last step, `World::flow_end`): where those forces are still
    /// in the world's buffers and do not read the rates, with the same controls
    /// ([`DofFlow`]), they are applied again instead of evaluated.
    /// Returns whether the flow ran (and so left its factor at the bodies).
    pub(super) fn damp(
        &mut self,
        tau: f64,
        forces: bool,
        unmoved: bool,
        at_last_flow: bool,
    ) -> Result<bool, ArticulatedError> {
        if !(tau > 0.0) {
            return Ok(false);
        }
        let gamma = 1.0 - core::f64::consts::FRAC_1_SQRT_2;
        // (1 − γ)/γ = 1 + √2.
        let c = (1.0 - gamma) / gamma;
        let s = gamma * tau;
        let g = if forces { self.gravity } else { DVec3::ZERO };
        // Velocity-dependent forces (velocity actuators, damped tendons, fluid) are
        // explicit: with them the stages pair with the explicit tableau of
        // Ascher–Ruuth–Spiteri (1997) IMEX(2,2,2), second order with the SDIRK above.
        let explicit = self.has_velocity_forces();
        let part = if forces {
            ForcePart::Full
        } else {
            ForcePart::Velocity
        };
        // Stage 1: v₁ = BE_{γτ}(v) with the explicit forces at v. The matrix is the
        // previous flow's when the positions have not moved since (`factor_cache.rs`).
        let (key_h, key_rates) = self.free_factor_key(s, Rates::Full);
        let reused = if unmoved {
            self.reuse_factor_unmoved(key_h, key_rates, Soft::Free)
        } else {
            self.reuse_factor(key_h, key_rates, Soft::Free)
        };
        let rhs_of = |b: &RigidBody, _: &DMat3, iw: &DMat3| {
            (b.v * b.mass() + g * (b.mass() * s), *iw * b.omega)
        };
        if unmoved {
            self.body_rhs_unmoved(!reused, rhs_of);
        } else {
            self.body_rhs_kept(!reused, false, rhs_of);
        }
        // The forces at `v` are kept for stage 2, which adds them again at the same
        // state (positions and velocities do not change between the stages).
        let mut dof_any = false;
        if forces {
            self.add_spring_rhs(s);
            let counts = [self.actuators.len(), self.springs.len(), self.tendons.len()];
            let flow = &self.rattle.dof_flow;
            if at_last_flow && flow.holds(self.dof_evals, &self.ctrl, counts) {
                // τ(q, q̇) at these poses, with these controls, in the buffers: the
                // same bits as evaluating it again (it does not read the rates).
                dof_any = flow.any;
                self.reapply_dof_forces(s, dof_any);
            } else {
                dof_any = self.add_dof_forces_part(s, ForcePart::Full);
                let reads = self.dof_forces_read_rates();
                let evals = self.dof_evals;
                self.rattle
                    .dof_flow
                    .keep(!reads, evals, dof_any, &self.ctrl, counts);
            }
            self.add_fluid_rhs(s);
        } else if explicit {
            dof_any = self.add_dof_forces_part(s, part);
            self.add_fluid_rhs(s);
        }
        // Unmoved: the poses are the last assembly's (the second kick's), whose rows
        // need no key comparison (`CachedRows::seen`).
        self.rows_unmoved = unmoved;
        let loops = self.assemble_with(s, Rates::Full, Soft::Free, !reused, None);
        // Equality rows hold their rate (`E v = 0`) through the damping flow.
        self.load_equalities(|_| 0.0);
        // Their complement is kept with the factor (`eq_cache.rs`).
        self.tag_equality_factor(key_h, key_rates);
        self.solve_reusing(loops, reused)?;
        // The same rows for the second solve (kept by `solve`; taken, not cloned).
        let loops_2 = core::mem::take(&mut self.last_loops);
        // Stage 2: v' = BE_{γτ}(v + c (v₁ − v)), same factor; all row right-hand sides 0.
        let mut v1 = core::mem::take(&mut self.rattle.v1);
        v1.clear();
        if explicit {
            v1.extend((0..self.bodies.len()).map(|i| self.solver.body_twist(&self.rhs, i)));
        }
        let mut stage = core::mem::take(&mut self.rattle.stage);
        stage.clear();
        stage.extend((0..self.bodies.len()).map(|i| {
            let (v1, w1) = self.solver.body_twist(&self.rhs, i);
            let b = &self.bodies[i];
            (b.v + (v1 - b.v) * c, b.omega + (w1 - b.omega) * c)
        }));
        let size = self.solver.size;
        self.rhs.clear();
        self.rhs.resize(size, 0.0);
        for (i, (v, w)) in stage.iter().enumerate() {
            let b = &self.bodies[i];
            // Stage 1's world inertia (same poses).
            let iw = self.body_iw[i];
            let o = self.solver.body_offset(i);
            let lin = *v * b.mass() + g * (b.mass() * s);
            self.rhs[o..o + 3].copy_from_slice(&lin.to_array());
            self.rhs[o + 3..o + 6].copy_from_slice(&(iw * *w).to_array());
        }
        if forces {
            self.add_spring_rhs(s);
        }
        if explicit {
            // IMEX(2,2,2), δ = 1 − 1/(2γ) = −1/√2: the stage's explicit forces are
            // τ (δ − 1 + γ) f(v) + τ (1 − δ) f(v₁) = −√2 τ f(v) + (1 + 1/√2) τ f(v₁)
            // (weights summing to γτ, so forces that do not depend on v are applied as
            // before).
            let (w_v, w_v1) = (
                -core::f64::consts::SQRT_2 * tau,
                (1.0 + core::f64::consts::FRAC_1_SQRT_2) * tau,
            );
            self.reapply_dof_forces(w_v, dof_any);
            self.reapply_fluid_rhs(w_v);
            // f(v₁): the forces read the bodies' velocities; swap v₁ in and back.
            let swap = |bodies: &mut [RigidBody], v1: &mut [(DVec3, DVec3)]| {
                for (b, (v, w)) in bodies.iter_mut().zip(v1.iter_mut()) {
                    core::mem::swap(&mut b.v, v);
                    core::mem::swap(&mut b.omega, w);
                }
            };
            swap(&mut self.bodies, &mut v1);
            if self.dof_forces_read_rates() {
                self.add_dof_forces_part(w_v1, part);
            } else {
                // τ(q, q̇) does not read q̇ (no b₂ ≠ 0, no damped tendon): τ(q, v₁) is
                // stage 1's τ(q, v), the same bits (`World::dof_forces_read_rates`),
                // applied again with the weight of f(v₁).
                self.reapply_dof_forces(w_v1, dof_any);
            }
            self.add_fluid_rhs(w_v1);
            swap(&mut self.bodies, &mut v1);
        } else if forces {
            self.reapply_dof_forces(s, dof_any);
            self.reapply_fluid_rhs(s);
        }
        self.armature_rhs(s, &stage);
        self.rattle.stage = stage;
        self.rattle.v1 = v1;
        let solved = self.solve_factored(&loops_2);
        self.last_loops = loops_2;
        solved?;
        for i in 0..self.bodies.len() {
            let (v, w) = self.solver.body_twist(&self.rhs, i);
            self.bodies[i].v = v;
            self.bodies[i].omega = w;
        }
        Ok(true)
    }

    /// The factor-cache key `(h, rates)` of an assembly `(h, rates, Soft::Free)`
    /// ([`World::reuse_factor`]), reduced to what its matrix reads. With compliant rows
    /// free, `h` enters the matrix only through the rate rows' compliance `1/(I_a + h d)`
    /// (`World::assemble_with`), and `d` is 0 in a `Rates::Armature` assembly and in
    /// every assembly of a world without damped joints, where a `Rates::Full` assembly
    /// also has the same rate rows as a `Rates::Armature` one (a joint has rate rows
    /// when damped or with armature). Then the matrix is that of `(0, Armature)`, bit
    /// for bit (`I_a + h · 0 = I_a` for finite `h`), so the kicks `|h|/2` and the
    /// damping flow's `γτ` of an undamped world with velocity-dependent forces (fluid
    /// drag, velocity actuators) share one factor per configuration.
    fn free_factor_key(&self, h: f64, rates: Rates) -> (f64, Rates) {
        let undamped = rates == Rates::Armature
            || (rates == Rates::Full && self.joints.iter().all(|j| j.damping_rows() == 0));
        if undamped && h.is_finite() {
            (0.0, Rates::Armature)
        } else {
            (h, rates)
        }
    }

    /// A kick's forces over `half`: the compliant joints' springs and the actuator,
    /// spring and tendon forces, at rest only (`τ(q, 0)`) when velocity-dependent forces
    /// are `explicit` in the damping flow, else whole and with the fluid.
    fn add_kick_forces(&mut self, half: f64, explicit: bool) {
        self.add_spring_rhs(half);
        if explicit {
            self.add_dof_forces_part(half, ForcePart::Position);
        } else {
            self.add_dof_forces(half);
            self.add_fluid_rhs(half);
        }
    }

    /// `C_h`: one undamped RATTLE step of `h` (may be negative inside a Yoshida
    /// composition); the damping rows are left out (decoupled, `λ_d = 0`); without
    /// `forces` also gravity and the springs (`C⁰_h`, constraints only). Returns the
    /// projection iterations and whether the projection converged (to `10³ ·
    /// tolerance`, at least 1e-9 m). `unmoved`: the caller knows that the bodies have
    /// not moved since the solver's factor was looked up or computed at them (the
    /// first kick's lookup, [`World::reuse_factor_unmoved`]). Whenever it returns
    /// through its last line (not the `MAX_TURN` failure), the solver's factor is the
    /// second kick's, at the bodies.
    pub(super) fn conservative_step(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
        forces: bool,
        unmoved: bool,
    ) -> Result<(usize, bool), ArticulatedError> {
        self.conservative_step_with(h, tolerance, max_iterations, forces, unmoved, false)
    }

    /// [`Self::conservative_step`]; `after_flow`: the damping flow `B_{h/2}` has just
    /// run at these positions (RATTLE's `B_{h/2} ∘ C⁰_h ∘ B_{h/2}`), so the velocities
    /// already satisfy `J(x₀) v = 0` and the first kick of `C⁰_h` (no forces) would
    /// only aim the drift at `−C(x₀)/h`, the last step's SHAKE residual (at most the
    /// tolerance). Then, where the kick's factor is kept (`factor_cache.rs`) and the
    /// world has no loop joints and no equalities, the kick is not solved: SHAKE starts
    /// from `v½ = v` with that factor (its corrections along `M⁻¹J(x₀)ᵀ`, as after the
    /// kick) and the first kick's impulses are zero (module documentation).
    fn conservative_step_with(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
        forces: bool,
        unmoved: bool,
        after_flow: bool,
    ) -> Result<(usize, bool), ArticulatedError> {
        let g = if forces { self.gravity } else { DVec3::ZERO };
        let half = 0.5 * h;
        // Damping rows stay out (with_damping = false): their compliance is unused.
        let hd = half.abs();
        // 1. Half kick with the constraint impulse that makes the drift land on the
        //    linearised manifold: [M Jᵀ; J −C][v½; λ] = [M v + (h/2) m g; −C(x)/h].
        //    Its matrix is the previous step's second kick's (same x, same |h|/2), kept
        //    by the factor cache (`factor_cache.rs`).
        let (key_h, key_rates) = self.free_factor_key(hd, Rates::Armature);
        let reused = if unmoved {
            self.reuse_factor_unmoved(key_h, key_rates, Soft::Free)
        } else {
            self.reuse_factor(key_h, key_rates, Soft::Free)
        };
        let skip_kick = after_flow
            && reused
            && !forces
            && self.solver.loops.is_empty()
            && self.equalities.is_empty();
        if skip_kick {
            // The flow's solution (`v`, in `rhs`) is `v½`; its world inertias are at x₀.
            return self.drift_and_second_kick(h, tolerance, max_iterations, forces, true);
        }
        self.body_rhs_kept(!reused, false, |b, _, iw| {
            (b.v * b.mass() + g * (b.mass() * half), *iw * b.omega)
        });
        // Compliant joints: half a kick of their spring force at x (Störmer–Verlet); their
        // rows are left out of the kicks and of SHAKE.
        // With velocity-dependent forces (moved to the damping flow) the kicks take the
        // forces at rest `τ(q, 0)` only, so that they stay symplectic.
        let explicit = forces && self.has_velocity_forces();
        if forces {
            self.add_kick_forces(half, explicit);
        }
        // Armature rows stay (inertia on the coordinates), damping rows out.
        let mut kick_rhs =
            |_: usize, _: &Joint, rows: &crate::joint::JointRows, rhs: &mut [f64]| {
                for r in 0..rows.n_hard {
                    rhs[r] = -rows.value[r] / h;
                }
            };
        let loops = self.assemble_with(
            hd,
            Rates::Armature,
            Soft::Free,
            !reused,
            Some(&mut kick_rhs),
        );
        // Equality rows as the joints: `−C/h` in the kick, `−C` in SHAKE (with the
        // start-of-step Jacobian), `0` in the final velocity projection.
        self.load_equalities(|c| -c / h);
        self.tag_equality_factor(key_h, key_rates);
        self.solve_reusing(loops, reused)?;
        self.drift_and_second_kick(h, tolerance, max_iterations, forces, false)
    }

    /// The rest of [`Self::conservative_step_with`] after its first kick: the drift,
    /// SHAKE and the second kick. `v½` is the last solve's solution (with the first
    /// kick's factor and loop rows in the solver and `last_loops`); `skipped`: the
    /// kick was not solved, its impulses are zero.
    fn drift_and_second_kick(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
        forces: bool,
        skipped: bool,
    ) -> Result<(usize, bool), ArticulatedError> {
        let g = if forces { self.gravity } else { DVec3::ZERO };
        let half = 0.5 * h;
        let hd = half.abs();
        let explicit = forces && self.has_velocity_forces();
        // The loop rows of this factor, for SHAKE's solves (their right-hand side is
        // rewritten each iteration).
        let mut loops_n = core::mem::take(&mut self.last_loops);
        let mut first_kick = core::mem::take(&mut self.rattle.first_kick);
        if skipped {
            first_kick.clear();
            first_kick.resize(self.joints.len(), [0.0; MAX_ROWS]);
        } else {
            self.store_impulses();
            first_kick.clone_from(&self.impulses);
        }
        // The world inertias at x₀, for the angular momenta `L = I₀ ω½` of the drift and
        // SHAKE's corrections `I₀ δθ/h`: the kick's, computed by `body_rhs_kept` at the
        // same poses with the operations of `RigidBody::world_inertia`.
        let mut inertia0 = core::mem::take(&mut self.rattle.inertia0);
        inertia0.clone_from(&self.body_iw);
        // Armature: the coordinate rates at the half step, `G(x₀) v½`, carried to the
        // second kick like the angular momenta (with SHAKE's corrections), so that its
        // rows close on `I_a q̇' = I_a q̇½ + …` (time-symmetric, second order).
        let mut arm = core::mem::take(&mut self.rattle.arm);
        arm.clear();
        let mut arm_rows = core::mem::take(&mut self.rattle.arm_rows);
        arm_rows.clear();
        for (j, joint) in self.joints.iter().enumerate() {
            if !self.armature[j].iter().any(|v| *v > 0.0) || self.solver.joint_offset(j).is_none() {
                continue;
            }
            // Only the rate rows are read (below and in SHAKE's corrections); the kick
            // (or, where it is skipped, the damping flow) just assembled them at these
            // poses: the rows it saw are taken without comparing keys
            // (`CachedRows::seen`).
            let mut computed = None;
            let rows = CachedRows::rates_at(
                &self.rows_cache,
                &self.coords,
                &self.bodies,
                (j, joint),
                self.rows_epoch,
                &mut computed,
            );
            let mut rate = [0.0; MAX_ROWS];
            let tw = |i: Option<usize>| {
                i.map_or((DVec3::ZERO, DVec3::ZERO), |i| {
                    self.solver.body_twist(&self.rhs, i)
                })
            };
            let ((va, wa), (vb, wb)) = (tw(joint.parent), tw(Some(joint.child)));
            for r in rows.n_hard..rows.n {
                let g = rows.rows[r];
                rate[r] = g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb);
            }
            let (n_hard, n) = (rows.n_hard, rows.n);
            arm.push((j, [n_hard, n, arm_rows.len()], rate));
            arm_rows.extend_from_slice(rows.rows.get(n_hard..n).unwrap_or(&[]));
        }
        // 2. Drift: x' = x + h v½; q' = exp(h ω*) q with L = I(q) ω½ fixed and
        //    ω* = I(q_mid)⁻¹ L at q_mid = exp(h ω*/2) q (fixed point, at most 4 sweeps,
        //    to `DRIFT_STOP`).
        let mut momenta = core::mem::take(&mut self.momenta);
        momenta.clear();
        let mut max_turn: f64 = 0.0;
        for i in 0..self.bodies.len() {
            let (v, w) = self.solver.body_twist(&self.rhs, i);
            let b = &mut self.bodies[i];
            let l = inertia0[i] * w;
            let q0 = b.pose.q;
            let mut ws = w;
            // `ω* = R I⁻¹ Rᵀ L` at `q_mid`, as three matrix–vector products.
            let inv = b.inv_inertia();
            for _ in 0..4 {
                let r = DMat3::from_quat(rotate_by(q0, ws * half));
                let next = r * (inv * (r.transpose() * l));
                let moved = (next - ws).length_squared();
                ws = next;
                // Converged to round-off (`DRIFT_STOP`): the later sweeps would only
                // move the last bits.
                if moved <= DRIFT_STOP * DRIFT_STOP * next.length_squared() {
                    break;
                }
            }
            b.v = v;
            b.omega = ws;
            b.pose.x += v * h;
            b.pose.q = rotate_by(q0, ws * h);
            momenta.push(l);
            max_turn = max_turn.max((ws * h).length());
        }
        // A body turning by more than MAX_TURN per step is outside the regime of the
        // explicit drift (a stiff mode at a large step): report failure, the caller falls
        // back to the velocity level.
        if !(max_turn <= MAX_TURN) {
            self.momenta = momenta;
            self.rattle.first_kick = first_kick;
            self.rattle.inertia0 = inertia0;
            self.rattle.arm = arm;
            self.rattle.arm_rows = arm_rows;
            return Ok((0, false));
        }
        // 3. SHAKE: the constraint impulse of the first kick acts along J(x₀)ᵀ, so the
        //    corrections are δ = −M₀⁻¹J₀ᵀ(J₀M₀⁻¹J₀ᵀ)⁻¹ C(x') with the factor of step 1
        //    (a chord iteration: linear convergence at rate O(h)); δ/h enters the
        //    half-step velocities and I₀ δθ/h the angular momenta. The first correction
        //    also solves the predicted remainder of the iteration (`ShakeHistory`).
        // Rate-row counts of the loop joints' rows (no allocation without loops).
        let mut passive = core::mem::take(&mut self.rattle.passive);
        passive.clear();
        if !self.solver.loops.is_empty() {
            passive.extend((0..self.joints.len()).map(|j| self.passive_rows_of(j)));
        }
        // The predictor (`ShakeHistory`): tree joints only, after a skipped first kick
        // (the drift from `v½ = v`, as in the steps recorded).
        let size = self.solver.size;
        let mut history = core::mem::take(&mut self.rattle.history);
        let record = skipped && self.solver.loops.is_empty() && self.equalities.is_empty();
        let predict = record && history.ready(self.steps, size);
        history.total.clear();
        history.total.resize(size, 0.0);
        if record {
            history.reserve(size);
        }
        let mut iterations = 0;
        let mut final_err = 0.0;
        for it in 0..=max_iterations {
            let mut err: f64 = 0.0;
            let loop_rhs = &mut loops_n.2;
            loop_rhs.clear();
            self.rhs.clear();
            self.rhs.resize(size, 0.0);
            let solver = &self.solver;
            for (j, joint) in self.joints.iter().enumerate() {
                // The poses by reference (a copy of both cost 0.2k instructions a
                // SHAKE iteration on swimmer6).
                let a = joint
                    .parent
                    .map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
                let b = &self.bodies[joint.child].pose;
                let c = if self.compliance.get(j).is_some_and(|&a| a > 0.0) {
                    [0.0; MAX_ROWS]
                } else {
                    // `C` once: the separation is read from the same values.
                    let c = joint.value(a, b);
                    err = err.max(joint.separation_of(&c));
                    c
                };
                let n = joint.hard_rows();
                match solver.joint_offset(j) {
                    Some(o) => {
                        // The joint's rows as one slice: one bounds check, not one a row.
                        if let Some(dst) = self.rhs.get_mut(o..o + n) {
                            for (d, v) in dst.iter_mut().zip(&c) {
                                *d = -v;
                            }
                        }
                        if record && it > 0 {
                            if let Some(t) = history.total.get_mut(o..o + n) {
                                for (t, v) in t.iter_mut().zip(&c) {
                                    *t -= v;
                                }
                            }
                        }
                    }
                    None => {
                        loop_rhs.extend(c[..n].iter().map(|v| -v));
                        loop_rhs.extend(core::iter::repeat_n(0.0, passive[j]));
                    }
                }
            }
            err = err.max(self.refresh_equality_rhs(|c| -c));
            iterations = it;
            final_err = err;
            if err <= tolerance || it == max_iterations || !err.is_finite() {
                break;
            }
            if predict && it == 0 {
                // The first correction also solves the predicted remainder.
                history.predict(&mut self.rhs);
            }
            // The bodies' right-hand side is +0.0 (cleared above).
            self.solve_factored_zero_bodies(&loops_n)?;
            // The corrections' rates `δ/h` per body, kept for the armature rows below
            // (the same quotients, computed once a body instead of once a joint side).
            let rates = &mut self.rattle.shake_rates;
            rates.clear();
            for i in 0..self.bodies.len() {
                let (dx, dth) = self.solver.body_twist(&self.rhs, i);
                let b = &mut self.bodies[i];
                b.pose.x += dx;
                b.pose.q = rotate_by(b.pose.q, dth);
                let (dv, dw) = (dx / h, dth / h);
                b.v += dv;
                b.omega += dw;
                momenta[i] += inertia0[i] * dw;
                if !arm.is_empty() {
                    rates.push((dv, dw));
                }
            }
            let rates = &self.rattle.shake_rates;
            for (j, [n_hard, n, start], rate) in &mut arm {
                let joint = &self.joints[*j];
                let tw = |i: Option<usize>| i.map_or((DVec3::ZERO, DVec3::ZERO), |i| rates[i]);
                let ((va, wa), (vb, wb)) = (tw(joint.parent), tw(Some(joint.child)));
                for r in *n_hard..*n {
                    let g = arm_rows[*start + r - *n_hard];
                    rate[r] += g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb);
                }
            }
        }
        // 4. Half kick and the velocity constraint at the new configuration:
        //    [M Jᵀ; J −C][v'; μ] = [M v½ + (h/2) m g; 0], angular part L½.
        let (key_h, key_rates) = self.free_factor_key(hd, Rates::Armature);
        let reused = self.reuse_factor(key_h, key_rates, Soft::Free);
        // The drift moved the bodies: their kept inertias (at x₀) are not compared.
        self.body_rhs_kept(!reused, true, |b, _, _| {
            (b.v * b.mass() + g * (b.mass() * half), DVec3::ZERO)
        });
        {
            let solver = &self.solver;
            for (i, l) in momenta.iter().enumerate() {
                let o = solver.body_offset(i) + 3;
                self.rhs[o..o + 3].copy_from_slice(&l.to_array());
            }
        }
        if forces {
            self.add_kick_forces(half, explicit);
        }
        let loops = self.assemble_with(hd, Rates::Armature, Soft::Free, !reused, None);
        self.load_equalities(|_| 0.0);
        self.tag_equality_factor(key_h, key_rates);
        for (j, [n_hard, n, _], rate) in &arm {
            if let Some(o) = self.solver.joint_offset(*j) {
                for r in *n_hard..*n {
                    if self.armature[*j][r - n_hard] > 0.0 {
                        self.rhs[o + r] = rate[r];
                    }
                }
            }
        }
        self.solve_reusing(loops, reused)?;
        // Whole-step impulses (both kicks), for the geometric stiffness of a later
        // velocity-level step.
        self.store_impulses();
        for (acc, first) in self.impulses.iter_mut().zip(&first_kick) {
            for (a, f) in acc.iter_mut().zip(first) {
                *a += f;
            }
        }
        for i in 0..self.bodies.len() {
            let (v, w) = self.solver.body_twist(&self.rhs, i);
            self.bodies[i].v = v;
            self.bodies[i].omega = w;
        }
        self.momenta = momenta;
        self.rattle.first_kick = first_kick;
        self.rattle.inertia0 = inertia0;
        self.rattle.arm = arm;
        self.rattle.arm_rows = arm_rows;
        self.rattle.passive = passive;
        if record && final_err <= tolerance {
            history.keep(self.steps);
        } else {
            history.forget();
        }
        self.rattle.history = history;
        self.recycle_loops(loops_n);
        Ok((iterations, final_err <= (1e3 * tolerance).max(1e-9)))
    }
}

#[cfg(test)]
mod tests {
    use super::ShakeHistory;
    use alloc::vec;

    /// The history predicts only for the step right after a recorded one of the same
    /// size; it repeats `R₋₁` after one record and extrapolates `2R₋₁ − R₋₂` after two,
    /// `3R₋₁ − 3R₋₂ + R₋₃` after three, adding the prediction to the right-hand side and
    /// keeping it as the remainder.
    #[test]
    fn predictor_extrapolates_consecutive_steps_only() {
        let mut h = ShakeHistory::default();
        assert!(!h.ready(1, 3));
        h.total = vec![1.0, 0.0, -2.0];
        h.keep(4);
        assert!(h.ready(5, 3) && !h.ready(6, 3) && !h.ready(5, 4));
        h.total = vec![0.0; 3];
        let mut rhs = vec![0.5, 0.0, 0.25];
        h.predict(&mut rhs);
        assert_eq!(rhs, vec![1.5, 0.0, -1.75]);
        assert_eq!(h.total, vec![1.0, 0.0, -2.0]);
        h.total = vec![3.0, 0.0, -1.0];
        h.keep(5);
        h.total = vec![0.0; 3];
        let mut rhs = vec![0.0; 3];
        h.predict(&mut rhs);
        assert_eq!(rhs, vec![5.0, 0.0, 0.0]);
        h.total = vec![2.0, 1.0, 0.0];
        h.keep(6);
        h.total = vec![0.0; 3];
        let mut rhs = vec![0.0; 3];
        h.predict(&mut rhs);
        assert_eq!(rhs, vec![-2.0, 3.0, 1.0]);
        // A gap (a step not recorded) starts the sequence again: `R₋₁` alone.
        h.total = vec![1.0, 1.0, 1.0];
        h.keep(8);
        h.total = vec![0.0; 3];
        let mut rhs = vec![0.0; 3];
        h.predict(&mut rhs);
        assert_eq!(rhs, vec![1.0, 1.0, 1.0]);
        h.forget();
        assert!(!h.ready(9, 3));
    }
}
