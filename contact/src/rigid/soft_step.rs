//! The soft step (Catto, Solver2D 2024; Box2D v3 `solver.c`, `contact_solver.c`):
//! contact rows prepared once per step, then `substeps` rounds of
//!
//! ```text
//! integrate velocities (gravity) → warm start → solve with soft bias
//!   → integrate positions → relax (solve without bias)
//! ```
//!
//! and at the end restitution and the impulses stored for the next step's warm start.
//!
//! Each normal row is the lecture's compliant constraint (Otaduy 2010, "Restricciones",
//! soft constraints `[M Jᵀ; J −α/h²] [v'; λ] = [M v; −β C/h]`) solved one row at a time
//! with Gauss–Seidel: with the row's effective mass `m = (J M⁻¹ Jᵀ)⁻¹`, a spring of
//! angular frequency `ω = 2π·hertz` and damping ratio `ζ` at sub-step `h` give
//!
//! ```text
//! bias_rate     = ω / (2ζ + hω)
//! mass_scale    = hω(2ζ + hω) / (1 + hω(2ζ + hω))
//! impulse_scale = 1 / (1 + hω(2ζ + hω))
//! Δλ = −m · mass_scale · (J v + bias_rate · C) − impulse_scale · λ
//! ```
//!
//! Two changes to that row, both on by default ([`SoftStepSettings::block_normal`],
//! [`SoftStepSettings::preload`]): the biased pass solves the normal rows of a
//! manifold (a box face's four corners) together, `(A + diag c) Δλ = −(J v + b +
//! c∘(λ − λ_pre))` with `c = impulse_scale/(mass_scale · m)` (the rows' own soft
//! equation, coupled as in Box2D v2.4's block solver), and the leak `impulse_scale ·
//! λ` becomes `impulse_scale · (λ − λ_pre)`, `λ_pre` a share `γ` of the manifold's
//! previous mean normal impulse (capped by the penetration), which shifts the
//! spring's rest length so that a carried load sinks `1 − γ` times as far. A manifold
//! met for the first time is warm-started from its static load estimate (the weight
//! it carries at rest, shared top-down), which also floors its preload for a while.
//!
//! (`C ≤ 0` the penetration, capped at `max_push_velocity`; a separated pair `C > 0`
//! gets the speculative target `C/h` and no softness). The separation `C` is updated
//! each sub-step from the bodies' displacements since the start of the step, with the
//! contact anchors fixed in the bodies (no new collision detection). The relax pass
//! solves the same rows rigidly with no bias, which removes the velocity the position
//! correction added (as split impulses do). Friction: two tangent rows per point,
//! `|λ_t| ≤ μ λ_n` (Coulomb's pyramid), solved after the normal row.
//!
//! Data layout (Box2D v3 style): points as flat arrays built once per step, in colour
//! order — the manifolds coloured greedily bottom-up along −gravity so that the points
//! of one colour touch disjoint moving bodies, then solved colour by colour with the
//! manifolds of a colour interleaved (the `colouring` module: independent rows side by
//! side, whose dependency chains the processor overlaps); body velocities,
//! displacements and inverse masses in dense arrays indexed by solver slot, with a
//! last, static slot (zero inverse mass) for the ground. Every buffer lives in [`SoftState`] and is reused: a step allocates nothing
//! once the buffers have grown to the scene.
//!
//! SIMD lanes (the `soft_lanes` module, `wide::f64x2`, or four AVX lanes where the
//! processor has AVX): on one thread the warm start, the biased pass (block normal
//! solve and friction) and the relax pass take the manifolds of a colour two (four)
//! at a time, one per lane, their rows packed side by side
//! once per step and each manifold's two bodies' velocities loaded once. Each lane does the scalar
//! pass's operations in the same order on independent bodies, so the bits are those
//! of one point (manifold) at a time, and of the threaded passes, which stay scalar.
//! The gaps are computed once per sub-step, after the positions, for the relax passes
//! and the next biased pass.

use alloc::boxed::Box;
use alloc::vec::Vec;
use core::f64::consts::TAU;

use constraint_core::rigid::rotate_by;
use constraint_core::{DMat3, DQuat, DVec3, Pose};
use wide::f64x2;

use super::colouring::Colouring;
use super::soft_lanes::{
    block_pair, block_quad, manifold_gaps, relax_manifolds, relax_quad, warm_manifolds, warm_quad,
    Paired, PointRows, RelaxIo,
};
use super::{ContactError, ContactSolver, ContactStats, ContactWorld, RowsSolver, SolverPath};
use crate::geometry::BroadScratch;

/// Settings of [`ContactSolver::SoftStep`] (Box2D v3's world definition values by
/// default, except the contact stiffness; see [`SoftStepSettings::default`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoftStepSettings {
    /// Contact stiffness as a frequency (Hz) for two moving bodies; contacts with a
    /// static collider use twice this (Box2D's `staticSoftness`). It is capped at a
    /// quarter of the sub-step rate, as Box2D caps it.
    ///
    /// At 2 sub-steps the default 30 Hz (`h_s ω` = 1.57, on the cap) leaves the
    /// 210-box pyramid in a vertical oscillation that grows over the first 2 s
    /// (period ≈ 15 steps, the top box's sink swinging between 0 and 22 mm) and walks
    /// the upper flanks sideways: worst displacement 106 mm over 600 steps
    /// (`soft_points pyramid20 600 2`). Not friction or the solve order: it stays
    /// with a second relax pass (38.6 mm), without the preload (52.3 mm), with the
    /// preload's cap lifted (`preload_cap_margin` 1000: 28.3 mm) and with the
    /// manifolds solved bottom-up one at a time instead of by colour (153 mm). It
    /// goes below about 20 Hz (`h_s ω` ≈ 1), where the sink wants `γ` near 0.995; both
    /// targets (stack drift and sink ≤ 1 mm, pyramid worst ≤ 1 cm over 600 steps)
    /// hold on a patch around 13 Hz, `γ` 0.996 (stack drift / sink, pyramid worst):
    ///
    /// | 2 sub-steps | `γ` 0.994 | 0.995 | 0.996 | 0.997 | 0.998 |
    /// |---|---|---|---|---|---|
    /// | 10 Hz | 1.38 / 1.38 mm, 1.8 mm | 1.16 / 1.15, 1.6 | 0.96 / 0.92, 6.3 | 0.71 / 0.69, 6.8 | 0.57 / 0.46, 6.6 |
    /// | 12 Hz | 0.99 / 0.96, 10.6 | 0.80 / 0.80, 5.5 | 0.64 / 0.64, 7.7 | 0.54 / 0.48, 7.1 | 0.42 / 0.32, 10.2 |
    /// | 13 Hz | 0.82 / 0.82, 5.0 | 0.69 / 0.68, 5.6 | 0.57 / 0.54, 6.3 | 0.47 / 0.41, 6.1 | 0.38 / 0.27, 12.6 |
    /// | 14 Hz | 0.71 / 0.70, 10.8 | 0.61 / 0.59, 7.0 | 0.53 / 0.47, 6.4 | 0.40 / 0.35, 8.1 | 0.34 / 0.23, 7.6 |
    /// | 15 Hz | — | 0.54 / 0.51, 8.2 | — | 0.36 / 0.31, 12.5 | — |
    /// | 18 Hz | — | 0.37 / 0.35, 17.8 | — | 0.28 / 0.21, 20.7 | — |
    ///
    /// There a step costs 156.3k instructions on the stack and 5.96M on the pyramid
    /// against 191.3k and 7.00M at the default 3 sub-steps (callgrind), but the
    /// pyramid moves ten times as far as at 3 sub-steps (0.69 mm), so the defaults
    /// stay.
    pub hertz: f64,
    /// Damping ratio `ζ ≥ 0` of the contact spring (10: heavily over-damped).
    pub damping_ratio: f64,
    /// Largest velocity (m/s) at which a penetration is pushed out.
    pub max_push_velocity: f64,
    /// Static-friction anchors: a sticking contact remembers how far its two material
    /// points have slid apart along the surface since it began (kept by contact id
    /// across steps), and its friction rows get the same soft bias as the normal row
    /// on that slip, `v_t + bias_rate · s_t`, pulling the pair back to where it
    /// stuck. A contact whose friction saturates (sliding) forgets its anchor. Off
    /// (the default): friction is a velocity row only. Measured over 10 s at 60 Hz:
    /// on the 10-box stack at 120 Hz with 8 sub-steps anchors cut the top box's
    /// drift from 7.5 mm to 4.8 mm (the `soft_step` tests), but on the 210-box
    /// pyramid at the defaults they add about 9 mm of sink (4.3 cm against 3.4 cm),
    /// so they are not on by default.
    pub friction_anchors: bool,
    /// One-way coupling for extreme mass ratios (≥ 1; `f64::INFINITY`, the default,
    /// is off): where a moving body rests on a moving body more than this many times
    /// lighter (the lower one along −gravity, by centre height at the start of the
    /// step), their rows treat the lower body as static — zero inverse mass and
    /// inertia in the row's effective mass, in the solve and in the warm start — as
    /// shock propagation does (Guendelman et al. 2003; Erleben 2007). One
    /// Gauss–Seidel pass per sub-step moves only a `1/ratio` share of a heavy body's
    /// momentum through a light one, so at 10⁴:1 the heavy box crushes the light one
    /// without it; with it the heavy box rests, but the light body no longer feels
    /// the heavy one (the ground's impulses carry only the light body's weight).
    pub one_way_mass_ratio: f64,
    /// Threads of the sub-steps (1, the default: the calling thread only). More than
    /// one needs the crate's `parallel` feature (a typed error without it) and runs
    /// the passes colour by colour on that many scoped threads when the step has at
    /// least [`PARALLEL_MIN_POINTS`] points (the `soft_parallel` module). The result is
    /// the same, bit for bit, on any number of threads.
    pub threads: usize,
    /// Block normal solve (on by default): in the biased pass the normal rows of a
    /// manifold (the points of one collider pair, up to [`BLOCK_POINTS`]: a box face's
    /// four) are solved together, `(A + diag c) Δλ = −(J v + b + c∘(λ − λ_pre))`, as
    /// Box2D v2.4's two-point block solver does, with a point-by-point fallback when a
    /// point is separated or an impulse would turn negative. One Gauss–Seidel pass
    /// over the corners of a face leaves the face rocking (the top box of the 10-box
    /// stack sways by about 1 cm at the defaults); the block solve does not.
    pub block_normal: bool,
    /// Spring preload `γ ∈ [0, 1]` (0.98 by default; 0: off): the soft normal rows leak
    /// `impulse_scale · (λ − λ_pre)` instead of `impulse_scale · λ`, with `λ_pre = γ ·`
    /// the static load estimate of the point's manifold (with
    /// [`SoftStepSettings::preload_estimate`], the default; where the manifold supports
    /// nothing, and with it off, the mean normal impulse of the manifold at the end of
    /// the previous step). A soft row at rest carries `λ` with a penetration
    /// `(λ − λ_pre)/(m h ω²)`: the spring keeps its stiffness and damping against
    /// changes of load, but the load it already carried sinks it `1 − γ` times as far
    /// (a stack's sink, `Σk g/ω²` at `γ = 0`, is cut fiftyfold at 0.98). It acts per
    /// manifold (the same `λ_pre` on every point of a face). From the previous impulse
    /// it lags a step: per point (tilting a face feeds back) or at `γ` above 0.95 (no
    /// spring left against the one-pass coupling of a stack) it rocks the 10-box stack
    /// by several centimetres; from the estimate it does not.
    ///
    /// `λ_pre` is capped at [`SoftStepSettings::preload_cap_margin`] times what the
    /// spring at rest would carry at the point's penetration, `M γ/(1 − γ) · m h ω² ·
    /// (−C)` (an impact's impulse does not become
    /// the next step's push), but not below the manifold's *floor*: when a manifold is
    /// met for the first time its rows start from its static load estimate (the
    /// weight it carries at rest, shared top-down over the supports as
    /// [`ContactWorld`]'s soft step documents in `estimate_loads`) as their warm start,
    /// and `γ` times that estimate is its floor, fading by [`PRELOAD_FLOOR_DECAY`] per
    /// step. Without it a new stack falls for the first sub-steps (one Gauss–Seidel
    /// pass moves the weight down one box per sub-step) and the cap holds the preload
    /// back until the penetration has built up: the 10-box stack's top sank 9 mm in
    /// its first 4 steps and rang for about 0.3 s; with it, it starts at rest.
    pub preload: f64,
    /// Margin `M ≥ 1` of the preload's cap (4, [`PRELOAD_CAP_MARGIN`], by default; 1:
    /// the cap of earlier versions): `λ_pre ≤ M γ/(1 − γ) · m h ω² · (−C)`, so that
    /// at rest, where a row carries `λ` at the penetration `−C = (λ − λ_pre)/(m h
    /// ω²)`, the cap lies `M` times above the preload and does not act. At `M = 1`
    /// the rest state sits on the cap's kink: a point that rises by `δ` loses `γ/(1 −
    /// γ) m h ω² δ` of preload (49 times the spring's own force at `γ` 0.98), a
    /// stiffness one biased pass per sub-step does not hold at 2 and 3 sub-steps —
    /// the rocking behind the 10-box stack's sideways drift there (top drift 105 mm
    /// at 2 sub-steps with `M = 1`, 0.55 mm with `M = 4`; `soft_points`, 600 steps).
    /// Where the static load estimate exceeds a point's real load (the flanks of the
    /// pyramid) the cap still acts and still bounds the push of a point that lifts.
    /// Measured (`soft_points`, 600 steps at 60 Hz, stack drift / sink, pyramid worst;
    /// with the load estimate of that version, an equal force per manifold — shared
    /// by moments now, the pyramid's figures at 4 and 3 sub-steps are 0.551 mm and
    /// 0.693 mm, see [`SoftStepSettings::preload_estimate`]):
    ///
    /// | setting | `M = 1` | `M = 4` |
    /// |---|---|---|
    /// | 4 sub-steps (defaults) | 0.570 / 0.511 mm, 4.12 mm | 0.514 / 0.511 mm, 1.06 mm |
    /// | 3 sub-steps (defaults) | 14.5 / 3.64 mm, 25.1 mm | 0.545 / 0.511 mm, 33.4 mm |
    /// | 3 sub-steps, `hertz` 20, `γ` 0.99 | 0.753 / 0.575 mm, 6.14 mm | 0.578 / 0.575 mm, 3.01 mm |
    /// | 2 sub-steps (defaults) | 105 / 9.83 mm, 123 mm | 0.553 / 0.511 mm, 140 mm |
    pub preload_cap_margin: f64,
    /// Relax passes per sub-step (1, Box2D v3's count, by default; at most
    /// [`MAX_RELAX_PASSES`]). A second one costs about a fifth of the step and
    /// converges the friction rows further: on the pyramid of 210 boxes it halves the
    /// creep of the boxes on the flanks (worst displacement 2.7 cm → 1.4 cm over 10 s;
    /// at preload 0.95 with the load estimate 3.1 cm → 8.9 mm, and 3.1 mm with
    /// [`SoftStepSettings::friction_anchors`] as well, for 22 % and 25 % more
    /// instructions per step).
    pub relax_passes: usize,
    /// Computes [`ContactStats::residual`] after the step (off by default: it costs as
    /// much as a pass over the points, 6 % of the 10-box stack's step; when off the
    /// statistic is `None`).
    pub residual: bool,
    /// Preload from the static load estimate every step (on by default): the
    /// estimate of [`SoftStepSettings::preload`]'s new manifolds (the weight each
    /// manifold carries at rest, shared top-down) is made for every manifold every
    /// step, and a supporting manifold's `λ_pre` is `γ ·` its estimate instead of `γ ·`
    /// its previous mean impulse (the cap and the fading floor as before). A
    /// feed-forward preload: no step-lagged feedback from the solve's impulses, which
    /// at `γ` 0.95 keeps the 210-box pyramid in a slow vertical oscillation (period ≈
    /// 2 s, top box between 2 and 12 mm of sink) that walks the flank boxes sideways,
    /// and which rocks stacks at `γ` above 0.95. Exact for a symmetric stack or
    /// pyramid; where a face's load is not uniform the spring carries the difference.
    /// Measured over 10 s at 60 Hz, 4 sub-steps (`soft_points`; top drift / sink of
    /// the 10-box stack, worst displacement on the pyramid):
    ///
    /// | setting | stack drift / sink | pyramid worst |
    /// |---|---|---|
    /// | `γ` 0.95 (lagged) | 1.455 / 1.277 mm | 30.9 mm |
    /// | `γ` 0.97, estimate | 0.830 / 0.766 mm | 10.3 mm |
    /// | `γ` 0.99, estimate | 0.320 / 0.256 mm | 10.7 mm |
    /// | `γ` 0.97, estimate, [`SoftStepSettings::refill_renamed`] | 0.830 / 0.766 mm | 4.09 mm |
    /// | `γ` 0.98, estimate, refill | 0.570 / 0.511 mm | 4.12 mm |
    /// | the same, [`SoftStepSettings::preload_cap_margin`] 4 | 0.514 / 0.511 mm | 1.06 mm |
    /// | the same, the estimate shared by moments (the default) | 0.512 / 0.511 mm | 0.551 mm |
    /// | the default at 3 sub-steps | 0.536 / 0.511 mm | 0.693 mm |
    ///
    /// The estimate every step costs 2.5 % of the pyramid's step (0.06 % of the
    /// stack's).
    pub preload_estimate: bool,
    /// Warm start of a point the narrow phase renamed (on by default): a point whose
    /// id was not in the previous step's contacts, in a manifold (collider pair) some
    /// of whose points were, starts from the mean normal impulse, friction impulse and
    /// preload floor of the points that were found, instead of from zero (and the
    /// manifold's mean impulse for [`SoftStepSettings::preload`] is over those points).
    /// On the 210-box pyramid the clipped face points of a box on two others get new
    /// ids once the boxes tilt slightly (with the estimate at `γ` 0.99, from step 37;
    /// up to 278 of 1600 points in one step): each lost its load for that step, and the pyramid
    /// sagged by about 7 mm over 10 steps (sink of the bottom row 0.06 → 0.63 mm).
    /// With [`SoftStepSettings::preload_estimate`] it takes the pyramid's worst
    /// displacement over 10 s from 10.3 mm to 4.1 mm (preload 0.97); without it, with
    /// the lagged preload, from 30.9 mm to 53.2 mm, so the two go together.
    pub refill_renamed: bool,
}

impl Default for SoftStepSettings {
    /// Box2D v3's defaults: `hertz` 30, `damping_ratio` 10, `max_push_velocity` 3 m/s,
    /// one relax pass; no friction anchors, no one-way coupling, one thread; and this
    /// library's block normal solve, spring preload 0.98 from the static load estimate
    /// with renamed points refilled, the residual not computed.
    /// A soft contact is a spring of stiffness `m ω²` (`m` the row's effective mass):
    /// carrying the weight of `k` unit boxes it settles by about `k g/ω²` (0.28 mm per
    /// box at 30 Hz; half of it against the ground, which gets twice the frequency),
    /// a fiftieth of that with the preload. Stiffer contacts need more sub-steps: one
    /// Gauss–Seidel pass per sub-step does not converge a stack's coupling at a quarter
    /// of the sub-step rate (a 3-box stack at 60 Hz with 4 sub-steps of 1/240 s keeps
    /// rocking at 0.1 m/s; at 30 Hz it rests), and they want the preload off (it rocks
    /// the 10-box stack at 120 Hz with 8 sub-steps: top drift 1.4 cm against 2.0 mm).
    fn default() -> Self {
        Self {
            hertz: 30.0,
            damping_ratio: 10.0,
            max_push_velocity: 3.0,
            friction_anchors: false,
            one_way_mass_ratio: f64::INFINITY,
            threads: 1,
            block_normal: true,
            preload: 0.98,
            preload_cap_margin: PRELOAD_CAP_MARGIN,
            relax_passes: 1,
            residual: false,
            preload_estimate: true,
            refill_renamed: true,
        }
    }
}

/// Soft-constraint coefficients of one row (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Softness {
    /// `ω / (2ζ + hω)` (1/s): the velocity asked per metre of penetration.
    pub bias_rate: f64,
    /// `hω(2ζ + hω) / (1 + hω(2ζ + hω))`.
    pub mass_scale: f64,
    /// `1 / (1 + hω(2ζ + hω))`.
    pub impulse_scale: f64,
}

impl Softness {
    /// Coefficients of a spring of `hertz` and damping ratio `zeta` at time step `h`;
    /// rigid (`mass_scale` 1, `impulse_scale` 0, no bias) when `hertz` is 0.
    pub fn new(hertz: f64, zeta: f64, h: f64) -> Self {
        if hertz == 0.0 {
            return Self {
                bias_rate: 0.0,
                mass_scale: 1.0,
                impulse_scale: 0.0,
            };
        }
        let omega = TAU * hertz;
        let a1 = 2.0 * zeta + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Self {
            bias_rate: omega / a1,
            mass_scale: a2 * a3,
            impulse_scale: a3,
        }
    }
}

/// A previous step's impulses of one point, for warm starting: key, normal impulse
/// per sub-step, tangent impulse per sub-step as a world vector, the friction
/// anchor's slip (world vector, zero when sliding or anchors are off), and the
/// preload floor per sub-step (see [`SoftStepSettings::preload`]).
type Warm = ((usize, usize, u64), f64, DVec3, DVec3, f64);

/// One manifold's normal rows solved together (at most [`BLOCK_POINTS`] points).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Block {
    /// Solve positions of the points.
    pub(super) pts: [usize; BLOCK_POINTS],
    /// Point count (0: solve the points one by one).
    pub(super) len: usize,
    /// `(A + diag c)⁻¹` (row-major `BLOCK_POINTS²`, the identity beyond `len`).
    pub(super) kinv: [f64; BLOCK_POINTS * BLOCK_POINTS],
    /// `c_i = impulse_scale / (mass_scale · m_i)`.
    pub(super) c: [f64; BLOCK_POINTS],
}

/// Largest manifold the block normal solve takes ([`SoftStepSettings::block_normal`]):
/// 4 points, a box face.
pub const BLOCK_POINTS: usize = 4;

/// Per-step factor of a manifold's preload floor after its first step (see
/// [`SoftStepSettings::preload`]): the floor, `γ` times the manifold's static load
/// estimate when it is met, fades by this factor every step (time constant 100 steps,
/// 1.7 s at 60 Hz), by when the spring has settled at the penetration whose cap
/// carries the same preload. Measured (10 s at 60 Hz, soft 4, γ 0.95): 0.9 let the
/// 10-box stack's transient back (top drift 3.6 mm at γ 0.9), 0.97 gave 1.97 mm, 0.99
/// 1.46 mm; without the fade (the floor kept) a box resting off centre on a stack
/// never stops creeping (a uniform floor over a face whose load is not uniform).
pub const PRELOAD_FLOOR_DECAY: f64 = 0.99;

/// Default [`SoftStepSettings::preload_cap_margin`]: 4 (2 and 8 measured: 10-box
/// stack and 210-box pyramid over 600 steps, 4 sub-steps, top drift / pyramid worst
/// 0.511 mm / 3.99 mm at 2, 0.514 / 1.06 mm at 4, 0.522 / 1.38 mm at 8).
pub const PRELOAD_CAP_MARGIN: f64 = 4.0;

/// The most relax passes per sub-step [`SoftStepSettings::relax_passes`] accepts.
pub const MAX_RELAX_PASSES: usize = 64;

/// Buffers of the soft step, kept by the world between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct SoftState {
    pub(super) broad: BroadScratch,
    pub(super) poses: Vec<Pose>,
    // Bodies, by solver slot (the last slot is the static ground).
    pub(super) inv_mass: Vec<f64>,
    pub(super) inv_inertia: Vec<DMat3>,
    pub(super) v: Vec<DVec3>,
    pub(super) w: Vec<DVec3>,
    pub(super) dp: Vec<DVec3>,
    pub(super) dq: Vec<DQuat>,
    /// `Δq` as a matrix (anchors rotate by it in every gap update).
    pub(super) rot: Vec<DMat3>,
    /// Colouring of the manifolds and the solve order of the points
    /// ([`Colouring::out`]).
    pub(super) colouring: Colouring,
    // Points, in solve order (colour-major, see the `colouring` module).
    pub(super) slots: Vec<[usize; 2]>,
    /// Normal then the two tangents.
    pub(super) dir: Vec<[DVec3; 3]>,
    /// Anchors relative to the body centres at the start of the step.
    pub(super) anchor: Vec<[DVec3; 2]>,
    /// Per direction `d`: `r_a × d`, `r_b × d`, `I_a⁻¹(r_a × d)`, `I_b⁻¹(r_b × d)`
    /// (288 B of the point's ≈ 600). Stored as `f32` (144 B, the effective masses
    /// from the rounded vectors) they cut the 3000-body pile's misses per step by
    /// 10 % in D1 and 24 % in an 8 MB last level (cachegrind, 3 steps after 2 s) for
    /// 4.3 % more instructions (6.5 % on the stack and pyramid: a conversion per
    /// component), but the box dropped on a 4-stack then slept again 58 steps later
    /// (step 407: `sleep_allocations` waits 400), so they are kept in `f64`.
    pub(super) ang: Vec<[[DVec3; 4]; 3]>,
    /// Effective masses `1/(J M⁻¹ Jᵀ)` of the three rows (0 for a row with none).
    pub(super) mass: Vec<[f64; 3]>,
    /// Inverse masses of the two bodies as the point's rows see them (zero for a
    /// body the one-way coupling freezes).
    pub(super) im: Vec<[f64; 2]>,
    /// Gap `nᵀ(p_b − p_a)` at the start of the step minus `nᵀ(r_b − r_a)`.
    pub(super) base_gap: Vec<f64>,
    /// Gap of each point at the bodies' current displacements (`C₀ + nᵀ Δd`,
    /// [`separation`]): set in `prepare` and after each sub-step's positions, read by
    /// the relax passes and the next sub-step's biased pass (the positions do not
    /// change between them).
    pub(super) gap: Vec<f64>,
    pub(super) soft: Vec<Softness>,
    pub(super) friction: Vec<f64>,
    pub(super) restitution: Vec<f64>,
    /// Normal velocity before the step (restitution).
    pub(super) approach: Vec<f64>,
    /// Whether some point of the step has a restitution coefficient (the
    /// restitution pass has nothing to do otherwise).
    pub(super) bouncy: bool,
    pub(super) impulse: Vec<[f64; 3]>,
    /// Preloaded impulse `λ_pre` of each point (see [`SoftStepSettings::preload`]).
    pub(super) preload: Vec<f64>,
    /// `M γ/(1 − γ) · m h ω²` of each point: the preload is capped at this times the
    /// penetration.
    pub(super) preload_cap: Vec<f64>,
    /// Floor of the cap: `γ ·` the static load estimate of each point (per sub-step).
    pub(super) preload_floor: Vec<f64>,
    /// Mean previous normal impulse of each contact's manifold (natural order).
    pub(super) mean: Vec<f64>,
    /// Block normal solve of each manifold in colour order (see [`Block`]).
    pub(super) blocks: Vec<Block>,
    /// The points the relax pass and the warm start take two at a time in SIMD lanes,
    /// with their rows packed per pair (the `soft_lanes` module).
    pub(super) paired: Paired,
    pub(super) max_normal: Vec<f64>,
    /// Impulses summed over the sub-steps (what [`ContactWorld::impulses`] reports).
    pub(super) total: Vec<[f64; 3]>,
    pub(super) warm: Vec<Warm>,
    pub(super) warm_next: Vec<Warm>,
    /// The previous step's impulses of each contact (natural order; zero if new).
    pub(super) found: Vec<(f64, DVec3, DVec3, f64)>,
    /// Whether each contact (natural order) was found in the previous step.
    pub(super) found_hit: Vec<bool>,
    /// Static load estimate of each contact (natural order), as a normal impulse per
    /// sub-step (see [`ContactWorld::estimate_loads`]); zero where not estimated.
    pub(super) estimate: Vec<f64>,
    /// Load (N) each body passes down to its supports, by solver slot (scratch of the
    /// estimate).
    pub(super) load: Vec<f64>,
    /// Moment of each body's load and its supporting points (by solver slot; scratch
    /// of the estimate).
    pub(super) pressure: Vec<Pressure>,
    /// Horizontal coordinates of each supporting contact point (natural order;
    /// scratch of the estimate).
    pub(super) flat: Vec<[f64; 2]>,
    /// Upper and lower slot and `n · up` of each manifold (natural order; `n · up` 0
    /// where it does not support; scratch of the estimate).
    pub(super) supports: Vec<(usize, usize, f64)>,
    /// Slip of the friction anchor at the start of the step along the two tangents,
    /// minus the anchors' offset `tᵀ(r_b − r_a)`.
    pub(super) slip: Vec<[f64; 2]>,
    /// Sub-step of the impulses in `warm` (they scale with it).
    pub(super) warm_h: f64,
    /// Buffers of the threaded sub-steps.
    #[cfg(feature = "parallel")]
    pub(super) parallel: super::soft_parallel::ParallelState,
}

/// One body's load and supports for the static load estimate
/// (`ContactWorld::estimate_loads`), in horizontal coordinates.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Pressure {
    /// `Σ f x` of the load: the weight at the centre and the forces passed down.
    moment: [f64; 2],
    /// Supporting points: count, `Σ x`, `Σ x xᵀ` as `[xx, xy, yy]`, and their
    /// bounding box (`lo`, `hi`).
    count: f64,
    sum: [f64; 2],
    second: [f64; 3],
    lo: [f64; 2],
    hi: [f64; 2],
}

impl Pressure {
    /// Adds a supporting point at `x`.
    fn add_point(&mut self, x: [f64; 2]) {
        if self.count == 0.0 {
            (self.lo, self.hi) = (x, x);
        }
        for k in 0..2 {
            self.lo[k] = at_most(self.lo[k], x[k]);
            self.hi[k] = at_least(self.hi[k], x[k]);
        }
        self.count += 1.0;
        self.sum[0] += x[0];
        self.sum[1] += x[1];
        self.second[0] += x[0] * x[0];
        self.second[1] += x[0] * x[1];
        self.second[2] += x[1] * x[1];
    }
}

/// The vertical force on a supporting point at `x` when a body carrying `load`
/// rests on the points of `p` as on equal springs (a rigid body on an elastic
/// foundation): `f(x) = L/N + βᵀ(x − x̄)`, linear over the points, with `Σ f = L`
/// and `Σ f x = Σ L x_c` (the load's centre of pressure `x_c` = moment / `L`):
/// `β = L S⁻¹ (x_c − x̄)`, `S = Σ (x − x̄)(x − x̄)ᵀ` the points' scatter. Points on a
/// line (`det S` below `10⁻⁹ (tr S)²`) take the pseudo-inverse along it, `β = L S (x_c
/// − x̄)/(tr S)²`; a single point takes the whole load. Where the centre of pressure
/// lies so far off centre that a point would pull (the body tips rather than rests),
/// `β` is scaled down until none does, by `t = min(1, (L/N)/B)` with `B = Σ_k |β_k|
/// max(hi_k − x̄_k, x̄_k − lo_k)` over the points' bounding box: every `f` stays in
/// `[0, 2L/N]` and they still sum to `L` (unscaled, a box leaning on one edge of a
/// 1000-body pile was given hundreds of times its weight and was thrown 180 m).
fn pressure_share(load: f64, p: &Pressure) -> impl Fn([f64; 2]) -> f64 {
    let n = p.count;
    let mean = [p.sum[0] / n, p.sum[1] / n];
    let (sxx, sxy, syy) = (
        p.second[0] - n * mean[0] * mean[0],
        p.second[1] - n * mean[0] * mean[1],
        p.second[2] - n * mean[1] * mean[1],
    );
    let mut beta = if load > 0.0 {
        let c = [p.moment[0] / load - mean[0], p.moment[1] / load - mean[1]];
        let det = sxx * syy - sxy * sxy;
        let tr = sxx + syy;
        if det > 1e-9 * tr * tr {
            [
                load * (syy * c[0] - sxy * c[1]) / det,
                load * (sxx * c[1] - sxy * c[0]) / det,
            ]
        } else if tr > 0.0 {
            let k = load / (tr * tr);
            [k * (sxx * c[0] + sxy * c[1]), k * (sxy * c[0] + syy * c[1])]
        } else {
            [0.0, 0.0]
        }
    } else {
        [0.0, 0.0]
    };
    let base = load / n;
    let reach = |k: usize| at_least(p.hi[k] - mean[k], mean[k] - p.lo[k]);
    let bound = beta[0].abs() * reach(0) + beta[1].abs() * reach(1);
    if bound > base {
        let t = base / bound;
        beta = [beta[0] * t, beta[1] * t];
    }
    move |x: [f64; 2]| {
        at_least(
            base + beta[0] * (x[0] - mean[0]) + beta[1] * (x[1] - mean[1]),
            0.0,
        )
    }
}

/// The most sub-steps one soft step accepts: 4096 (a 60 Hz step cut to 4 µs sub-steps;
/// Box2D v3 uses 4). Beyond it the step is a typed error rather than a step that
/// never ends (`usize::MAX` sub-steps would loop for centuries).
pub const MAX_SUBSTEPS: usize = 4096;

/// The most threads [`SoftStepSettings::threads`] accepts.
pub const MAX_THREADS: usize = 256;

/// A step with fewer points than this runs its sub-steps on one thread whatever
/// [`SoftStepSettings::threads`] says: starting the threads and meeting at a barrier
/// per colour and pass cost more than a small scene's passes (the 10-box stack has
/// 40 points). The same bits either way.
pub const PARALLEL_MIN_POINTS: usize = 512;

impl ContactWorld {
    /// Rejects soft-step settings out of range (before any state changes).
    pub(super) fn check_soft(&self, substeps: usize) -> Result<(), ContactError> {
        let s = &self.settings.soft_step;
        let bad = |name, rule| Err(ContactError::InvalidParameter { name, rule });
        if substeps == 0 {
            return bad("substeps", "must be at least 1");
        }
        if substeps > MAX_SUBSTEPS {
            return bad("substeps", "must be at most MAX_SUBSTEPS (4096)");
        }
        if !(s.hertz > 0.0) || !s.hertz.is_finite() {
            return bad("soft_step.hertz", "must be positive and finite");
        }
        if !(s.damping_ratio >= 0.0) || !s.damping_ratio.is_finite() {
            return bad("soft_step.damping_ratio", "must be finite and non-negative");
        }
        if !(s.one_way_mass_ratio >= 1.0) {
            return bad(
                "soft_step.one_way_mass_ratio",
                "must be at least 1 (infinity: off)",
            );
        }
        if !(0.0..=1.0).contains(&s.preload) {
            return bad("soft_step.preload", "must be in [0, 1]");
        }
        if !(s.preload_cap_margin >= 1.0) || !s.preload_cap_margin.is_finite() {
            return bad(
                "soft_step.preload_cap_margin",
                "must be finite and at least 1",
            );
        }
        if s.relax_passes == 0 {
            return bad("soft_step.relax_passes", "must be at least 1");
        }
        if s.relax_passes > MAX_RELAX_PASSES {
            return bad(
                "soft_step.relax_passes",
                "must be at most MAX_RELAX_PASSES (64)",
            );
        }
        if s.threads == 0 {
            return bad("soft_step.threads", "must be at least 1");
        }
        if s.threads > MAX_THREADS {
            return bad("soft_step.threads", "must be at most MAX_THREADS (256)");
        }
        if s.threads > 1 && !cfg!(feature = "parallel") {
            return bad(
                "soft_step.threads",
                "more than 1 needs the crate's `parallel` feature",
            );
        }
        if !(s.max_push_velocity >= 0.0) || !s.max_push_velocity.is_finite() {
            return bad(
                "soft_step.max_push_velocity",
                "must be finite and non-negative",
            );
        }
        Ok(())
    }

    /// One step of `h` by the soft step with `substeps` sub-steps.
    pub(super) fn soft_step(
        &mut self,
        h: f64,
        substeps: usize,
    ) -> Result<ContactStats, ContactError> {
        self.check_soft(substeps)?;
        let mut stats = ContactStats {
            solver: Some(ContactSolver::SoftStep { substeps }),
            iterations: substeps,
            ..ContactStats::default()
        };
        let mut st = self.soft.take().unwrap_or_default();
        // Contacts at the start of the step.
        st.poses.clear();
        st.poses.extend(self.bodies.iter().map(|b| b.pose));
        let mut contacts = core::mem::take(&mut self.contacts);
        // Asleep bodies are left out of the pairs (the sleep module's hook).
        let broad = self.awake_contacts(&st.poses, &mut st.broad, &mut contacts);
        self.contacts = contacts;
        let broad = match broad {
            Ok(b) => b,
            Err(e) => {
                self.soft = Some(st);
                return Err(e);
            }
        };
        stats.pair_tests = broad.tests;
        stats.contacts = self.contacts.len();
        stats.max_penetration = self.contacts.iter().map(|c| c.depth).fold(0.0, f64::max);
        Ok(self.soft_solve(st, h, substeps, stats))
    }

    /// The soft step on the contacts already in `self.contacts` (found at the start of
    /// the step; `stats` holds their counts): [`ContactSolver::Auto`] beyond
    /// [`super::AUTO_DENSE_CONTACTS`] points. The settings were checked.
    pub(super) fn soft_with_contacts(
        &mut self,
        h: f64,
        substeps: usize,
        mut stats: ContactStats,
    ) -> ContactStats {
        stats.solver = Some(ContactSolver::SoftStep { substeps });
        stats.iterations = substeps;
        let st = self.soft.take().unwrap_or_default();
        self.soft_solve(st, h, substeps, stats)
    }

    /// Converts the dense path's warm start (impulses over a step `h`) into the soft
    /// step's (its impulses scale with the sub-step: stored as over `h`, used as
    /// `h_s / h` of them), when `Auto` moves to the soft step.
    pub(super) fn warm_dense_to_soft(&mut self, h: f64) {
        let st = self.soft.get_or_insert_with(Default::default);
        st.warm.clear();
        st.warm.extend(
            self.warm
                .iter()
                .map(|&(key, (zn, ft))| (key, zn, ft, DVec3::ZERO, 0.0)),
        );
        st.warm_h = h;
    }

    /// Converts the soft step's warm start (impulses over one of `substeps` sub-steps)
    /// into the dense path's (over the whole step), when `Auto` leaves the soft step.
    /// The soft step keeps its own sorted by collider pair only (see `store`); the
    /// dense path searches by the whole key, so it is sorted here.
    pub(super) fn warm_soft_to_dense(&mut self, substeps: usize) {
        let k = substeps as f64;
        self.warm.clear();
        self.warm.extend(
            self.soft
                .iter()
                .flat_map(|st| &st.warm)
                .map(|&(key, zn, ft, _, _)| (key, (zn * k, ft * k))),
        );
        // Keys are unique: the unstable sort is deterministic.
        self.warm.sort_unstable_by_key(|e| e.0);
    }

    /// The sub-steps and the rest of the soft step from the contacts in
    /// `self.contacts`.
    fn soft_solve(
        &mut self,
        mut st: Box<SoftState>,
        h: f64,
        substeps: usize,
        stats: ContactStats,
    ) -> ContactStats {
        let hs = h / substeps as f64;
        self.load_bodies(&mut st, h);
        self.prepare(&mut st, hs);
        self.path = SolverPath::STEPPED;
        self.path.rows = if self.contacts.is_empty() {
            RowsSolver::NoRows
        } else {
            RowsSolver::SoftStep
        };
        let g = self.gravity;
        let s = self.settings.soft_step;
        #[cfg(feature = "parallel")]
        if s.threads > 1 && st.slots.len() >= PARALLEL_MIN_POINTS {
            let pass = |use_bias: bool| Pass {
                inv_h: 1.0 / hs,
                use_bias,
                max_push: if use_bias { s.max_push_velocity } else { 0.0 },
                anchors: use_bias && s.friction_anchors,
            };
            super::soft_parallel::run(
                &mut st,
                s.threads,
                super::soft_parallel::Plan {
                    substeps,
                    hs,
                    gravity: g,
                    biased: pass(true),
                    relax: pass(false),
                    relax_passes: s.relax_passes,
                },
            );
            return self.finish_soft(st, hs, stats);
        }
        for _ in 0..substeps {
            integrate_velocities(&mut st, g, hs);
            warm_start(&mut st);
            solve(&mut st, hs, true, s.max_push_velocity, s.friction_anchors);
            integrate_positions(&mut st, hs);
            update_gaps(&mut st);
            for _ in 0..s.relax_passes {
                solve(&mut st, hs, false, 0.0, false);
            }
            for (t, z) in st.total.iter_mut().zip(&st.impulse) {
                t[0] += z[0];
                t[1] += z[1];
                t[2] += z[2];
            }
        }
        self.finish_soft(st, hs, stats)
    }

    /// After the sub-steps: restitution, the residual, the bodies written back and the
    /// impulses kept.
    fn finish_soft(
        &mut self,
        mut st: Box<SoftState>,
        hs: f64,
        mut stats: ContactStats,
    ) -> ContactStats {
        restitution(&mut st, self.settings.restitution_threshold);
        stats.residual = self.settings.soft_step.residual.then(|| residual(&st, hs));
        self.store(&mut st, hs);
        self.soft = Some(st);
        stats
    }

    /// Body slots: inverse masses and world inverse inertias at the start of the step,
    /// velocities after the implicit gyroscopic update over `h`, zero displacements.
    fn load_bodies(&mut self, st: &mut SoftState, h: f64) {
        let n = self.bodies.len() + 1;
        // Sized to the slots with the static slot's values (its entry, the last, and
        // an asleep body's are these) and written in place: one reserve an array, not
        // a capacity check a push.
        st.v.clear();
        st.v.resize(n, DVec3::ZERO);
        st.w.clear();
        st.w.resize(n, DVec3::ZERO);
        st.inv_mass.clear();
        st.inv_mass.resize(n, 0.0);
        st.inv_inertia.clear();
        st.inv_inertia.resize(n, DMat3::ZERO);
        let slots = st
            .inv_mass
            .iter_mut()
            .zip(&mut st.inv_inertia)
            .zip(st.v.iter_mut().zip(&mut st.w));
        for (i, (b, ((im, ii), (v, w)))) in self.bodies.iter_mut().zip(slots).enumerate() {
            // An asleep body (the sleep module's hook) takes a static slot: at rest, zero
            // inverse mass, not integrated (it is in no contact row either).
            if self.sleep.asleep.get(i).copied().unwrap_or(false) {
                continue;
            }
            // One rotation matrix for both (`world_inv_inertia`'s `R I⁻¹ Rᵀ`).
            let r = b.rotation();
            b.omega = b.gyroscopic_step_with(&r, h);
            *im = 1.0 / b.mass();
            *ii = r * b.inv_inertia() * r.transpose();
            *v = b.v;
            *w = b.omega;
        }
        st.dp.clear();
        st.dp.resize(n, DVec3::ZERO);
        st.dq.clear();
        st.dq.resize(n, DQuat::IDENTITY);
        st.rot.clear();
        st.rot.resize(n, DMat3::IDENTITY);
    }

    /// Builds the point arrays once per step (colour order, see the module docs),
    /// warm-started by contact key from the previous step.
    fn prepare(&self, st: &mut SoftState, hs: f64) {
        let up = if self.gravity.length() > 0.0 {
            -self.gravity.normalize()
        } else {
            DVec3::Z
        };
        let contacts = &self.contacts;
        // Colour-major: manifolds ranked bottom-up (along −gravity, index tie-break:
        // deterministic) and coloured greedily, so that a colour's rows touch disjoint
        // bodies (the `colouring` module).
        let nb = self.bodies.len();
        let colliders = &self.colliders;
        let kept = st.colouring.order(
            contacts.len(),
            nb,
            (
                |k| (contacts[k].a, contacts[k].b),
                |k| {
                    let slot = |i: usize| colliders[i].body.unwrap_or(nb);
                    [slot(contacts[k].a), slot(contacts[k].b)]
                },
            ),
            |k| contacts[k].point.dot(up),
        );
        let s = self.settings.soft_step;
        let hertz = s.hertz.min(0.25 / hs);
        let dynamic = Softness::new(hertz, s.damping_ratio, hs);
        let fixed = Softness::new(2.0 * hertz, s.damping_ratio, hs);
        // Warm start by key: the contacts come in pair order `(a, b)` and `warm` is
        // sorted by pair, so one forward merge finds every previous point (the same
        // matches as a search per point, reading `warm` once, in order).
        // Sized once and written by position (as the point arrays below).
        let none = (0.0, DVec3::ZERO, DVec3::ZERO, 0.0);
        st.found.resize(contacts.len(), none);
        st.found_hit.resize(contacts.len(), false);
        let (found, found_hit) = (
            &mut st.found[..contacts.len()],
            &mut st.found_hit[..contacts.len()],
        );
        let mut cursor = 0;
        let warm = st.warm.as_slice();
        for (c, (f, h)) in contacts
            .iter()
            .zip(found.iter_mut().zip(found_hit.iter_mut()))
        {
            let (a, b, id) = c.key();
            while cursor < warm.len() && (warm[cursor].0 .0, warm[cursor].0 .1) < (a, b) {
                cursor += 1;
            }
            let hit = warm[cursor..]
                .iter()
                .take_while(|e| e.0 .0 == a && e.0 .1 == b)
                .find(|e| e.0 .2 == id);
            *h = hit.is_some();
            *f = hit.map_or(none, |&(_, zn, ft, sl, fl)| (zn, ft, sl, fl));
        }
        let scale = if st.warm_h > 0.0 { hs / st.warm_h } else { 0.0 };
        // Preload: the mean previous normal impulse of each manifold (a run of one
        // collider pair in natural order), the same on each of its points; a new
        // manifold's is its estimate.
        st.mean.clear();
        let mut i = 0;
        while i < contacts.len() {
            let pair = (contacts[i].a, contacts[i].b);
            let mut j = i;
            let mut sum = 0.0;
            let mut hits = 0usize;
            while j < contacts.len() && (contacts[j].a, contacts[j].b) == pair {
                sum += st.found[j].0;
                hits += usize::from(st.found_hit[j]);
                j += 1;
            }
            let mut m = sum / (j - i) as f64;
            // A renamed point of a known manifold: the mean of the points found.
            if s.refill_renamed && hits > 0 && hits < j - i {
                let (mut ft, mut fl) = (DVec3::ZERO, 0.0);
                for q in i..j {
                    ft += st.found[q].1;
                    fl += st.found[q].3;
                }
                let share = 1.0 / hits as f64;
                m = sum * share;
                for q in i..j {
                    if !st.found_hit[q] {
                        st.found[q] = (m, ft * share, DVec3::ZERO, fl * share);
                    }
                }
            }
            st.mean.extend(core::iter::repeat_n(m, j - i));
            // From here on `found_hit` marks the points of known manifolds: where no
            // point or every point was found they do already, so only a manifold with
            // points renamed is written (a fill per manifold was 0.15 % of the
            // 210-box pyramid's step, callgrind).
            if hits > 0 && hits < j - i {
                st.found_hit[i..j].fill(true);
            }
            i = j;
        }
        // A manifold met for the first time starts from the static load estimate
        // instead of zero (see `estimate_loads`).
        // With `preload_estimate` every manifold is estimated, every step.
        let every = self.settings.warm_start && s.preload_estimate;
        let new_manifolds = self.settings.warm_start && self.estimate_loads(st, up, hs, every);
        let preload = if self.settings.warm_start {
            s.preload * scale
        } else {
            0.0
        };
        // Spring stiffness over the sub-step, `h ω²` per unit effective mass, and the
        // cap's ratio `M γ/(1 − γ)` (`M` times the ratio of preload to spring force at
        // rest: `preload_cap_margin`).
        let omega2 = (TAU * hertz) * (TAU * hertz);
        let omega2_fixed = 4.0 * omega2;
        let kappa = if s.preload < 1.0 {
            s.preload_cap_margin * s.preload / (1.0 - s.preload)
        } else {
            f64::INFINITY
        };
        // The point arrays are sized to the point count (a no-op when it is the last
        // step's) and every entry is written by position below: a `push` per array
        // and point cost its length and capacity bookkeeping (≈ 100 instructions a
        // point over the 18 arrays, 1.7 % of the 210-box pyramid's step, callgrind).
        let np = st.colouring.out.len();
        macro_rules! size {
            ($($f:ident: $z:expr),*) => { $(st.$f.resize(np, $z);)* };
        }
        size!(
            slots: [0; 2],
            dir: [DVec3::ZERO; 3],
            anchor: [DVec3::ZERO; 2],
            ang: [[DVec3::ZERO; 4]; 3],
            mass: [0.0; 3],
            base_gap: 0.0,
            soft: dynamic,
            friction: 0.0,
            restitution: 0.0,
            approach: 0.0,
            impulse: [0.0; 3],
            max_normal: 0.0,
            total: [0.0; 3],
            slip: [0.0; 2],
            im: [0.0; 2],
            preload: 0.0,
            preload_cap: 0.0,
            preload_floor: 0.0,
            gap: 0.0
        );
        // Slices of exactly `np` entries: `p < np` needs no bounds check per write.
        let order = &st.colouring.out[..np];
        let (slots, dir, anchor) = (&mut st.slots[..np], &mut st.dir[..np], &mut st.anchor[..np]);
        let (ang_out, mass_out, im_out) = (&mut st.ang[..np], &mut st.mass[..np], &mut st.im[..np]);
        let (base_gap, soft, friction) = (
            &mut st.base_gap[..np],
            &mut st.soft[..np],
            &mut st.friction[..np],
        );
        let (restitution, approach, impulse) = (
            &mut st.restitution[..np],
            &mut st.approach[..np],
            &mut st.impulse[..np],
        );
        let (max_normal, total, slip) = (
            &mut st.max_normal[..np],
            &mut st.total[..np],
            &mut st.slip[..np],
        );
        let (preload_out, preload_cap, preload_floor) = (
            &mut st.preload[..np],
            &mut st.preload_cap[..np],
            &mut st.preload_floor[..np],
        );
        let gap = &mut st.gap[..np];
        // The SIMD lanes' packed rows, written point by point below (their plan, a
        // function of the colouring alone, is the last step's when the colouring is).
        if !kept {
            st.paired.plan(&st.colouring);
        }
        let paired = &mut st.paired;
        // One-way coupling off (the default, an infinite ratio): `im[lower] > ∞ ·
        // im[upper]` never holds (∞ · 0 is NaN), so the heights need not be read.
        let one_way = s.one_way_mass_ratio < f64::INFINITY;
        // Manifold by manifold (every point is in one; the points of a manifold
        // share their colliders, bodies, masses, softness and, where their normals
        // are the same bits, their tangents: these are read once a manifold), each
        // point written at its solve position.
        let (mp, mpts) = (
            st.colouring.manifold_start.as_slice(),
            st.colouring.manifold_points.as_slice(),
        );
        let mut bouncy = false;
        for j in 0..mp.len().saturating_sub(1) {
            let pts = &mpts[mp[j]..mp[j + 1]];
            let Some(&first) = pts.first() else {
                continue;
            };
            let c0 = &contacts[order[first]];
            let (ca, cb) = (&self.colliders[c0.a], &self.colliders[c0.b]);
            let (a, b) = (ca.body.unwrap_or(nb), cb.body.unwrap_or(nb));
            let xa = ca.body.map(|i| self.bodies[i].pose.x);
            let xb = cb.body.map(|i| self.bodies[i].pose.x);
            // One-way coupling: the lower of two moving bodies is static for this
            // manifold when the upper is more than `one_way_mass_ratio` times heavier.
            let mut im = [st.inv_mass[a], st.inv_mass[b]];
            // By reference: the two 72-byte matrices are not copied.
            let mut inertia = [&st.inv_inertia[a], &st.inv_inertia[b]];
            if one_way && a != nb && b != nb {
                let (ha, hb) = (self.bodies[a].pose.x.dot(up), self.bodies[b].pose.x.dot(up));
                let (lower, upper) = if ha < hb { (0, 1) } else { (1, 0) };
                if im[lower] > s.one_way_mass_ratio * im[upper] {
                    im[lower] = 0.0;
                    inertia[lower] = &DMat3::ZERO;
                }
            }
            let mu = ca.friction.max(cb.friction);
            let e = ca.restitution.max(cb.restitution);
            bouncy |= e != 0.0;
            let fixed_pair = a == nb || b == nb;
            let softness = if fixed_pair { fixed } else { dynamic };
            let omega2_pair = if fixed_pair { omega2_fixed } else { omega2 };
            // The tangents of the last normal (by its bits: a signed zero changes them).
            let bits = |n: DVec3| [n.x.to_bits(), n.y.to_bits(), n.z.to_bits()];
            let mut last: Option<([u64; 3], [DVec3; 3])> = None;
            for &p in pts {
                let k = order[p];
                let c = &contacts[k];
                let ra = xa.map_or(DVec3::ZERO, |x| c.point_on_a() - x);
                let rb = xb.map_or(DVec3::ZERO, |x| c.point_on_b() - x);
                let n = c.normal;
                let dirs = match last {
                    Some((key, d)) if key == bits(n) => d,
                    _ => {
                        let (t1, t2) = n.any_orthonormal_pair();
                        let d = [n, t1, t2];
                        last = Some((bits(n), d));
                        d
                    }
                };
                let [_, t1, t2] = dirs;
                let mut ang = [[DVec3::ZERO; 4]; 3];
                let mut mass = [0.0; 3];
                for (r, d) in dirs.iter().enumerate() {
                    let (ua, ub) = (ra.cross(*d), rb.cross(*d));
                    let (ia, ib) = (inertia[0].mul_vec3(ua), inertia[1].mul_vec3(ub));
                    // k = J M⁻¹ Jᵀ = 1/m_a + 1/m_b + (r_a×d)ᵀI_a⁻¹(r_a×d) + (r_b×d)ᵀI_b⁻¹(r_b×d)
                    let k = im[0] + im[1] + ua.dot(ia) + ub.dot(ib);
                    mass[r] = if k > 0.0 { 1.0 / k } else { 0.0 };
                    ang[r] = [ua, ub, ia, ib];
                }
                let mut z = [0.0; 3];
                if self.settings.warm_start {
                    let (zn, ft, _, _) = st.found[k];
                    z = [zn * scale, ft.dot(t1) * scale, ft.dot(t2) * scale];
                    if new_manifolds && !st.found_hit[k] {
                        z[0] = st.estimate[k];
                    }
                }
                // The anchor's slip, stored as `s₀ − tᵀ(r_b − r_a)`, so that `s₀ + tᵀ
                // Δd` below is the slip (Δd: the anchors' separation vector, as for
                // the gap); read only with anchors on.
                if s.friction_anchors {
                    let (sl, r) = (st.found[k].2, rb - ra);
                    slip[p] = [sl.dot(t1) - t1.dot(r), sl.dot(t2) - t2.dot(r)];
                }
                paired.put(
                    p,
                    PointRows {
                        dir: &dirs,
                        ang: &ang,
                        mass,
                        im,
                        friction: mu,
                    },
                );
                slots[p] = [a, b];
                dir[p] = dirs;
                anchor[p] = [ra, rb];
                ang_out[p] = ang;
                mass_out[p] = mass;
                im_out[p] = im;
                // The gap at the start of the step, `C₀ = base_gap + nᵀ(r_b − r_a)`
                // (what `update_gaps` gives at zero displacements, where `Δx + Δq r =
                // r`: the same bits, up to the sign of a zero), without a pass over the
                // points.
                let offset = n.dot(rb - ra);
                base_gap[p] = -c.depth - offset;
                gap[p] = base_gap[p] + offset;
                soft[p] = softness;
                friction[p] = mu;
                restitution[p] = e;
                // Relative normal velocity before the step, n·(v_b + ω_b×r_b − v_a −
                // ω_a×r_a), read only by restitution where `e` is not zero.
                approach[p] = if e == 0.0 {
                    0.0
                } else {
                    n.dot(st.v[b] - st.v[a]) + ang[0][1].dot(st.w[b]) - ang[0][0].dot(st.w[a])
                };
                impulse[p] = z;
                preload_out[p] =
                    if (every && st.estimate[k] > 0.0) || (new_manifolds && !st.found_hit[k]) {
                        s.preload * st.estimate[k]
                    } else {
                        preload * st.mean[k]
                    };
                preload_cap[p] = kappa * mass[0] * hs * omega2_pair;
                preload_floor[p] = if !self.settings.warm_start {
                    0.0
                } else if new_manifolds && !st.found_hit[k] {
                    s.preload * st.estimate[k]
                } else {
                    st.found[k].3 * scale * PRELOAD_FLOOR_DECAY
                };
                max_normal[p] = 0.0;
                total[p] = [0.0; 3];
            }
        }
        st.bouncy = bouncy;
        if s.block_normal {
            build_blocks(st);
        } else {
            st.blocks.clear();
        }
    }

    /// Static load estimate of the contacts, for the manifolds met for the first time
    /// (false, having estimated nothing, when every contact was found in the previous
    /// step). A new manifold has no previous impulse to warm start from: from zero, one
    /// Gauss–Seidel pass per sub-step moves a stack's weight down one box per sub-step,
    /// so a freshly built 10-box stack falls for the first sub-steps and its springs
    /// then overshoot (the top box sank 9 mm in the first 4 steps). The estimate is the
    /// weight each manifold carries at rest, found top-down as shock propagation orders
    /// its bodies (Guendelman et al. 2003): a manifold supports its upper body (along
    /// `up`) when `n · up ≥ 1/2` (within 60° of vertical); each moving body's load —
    /// its weight `m |g|` at its centre plus the vertical forces the points it
    /// supports pass down, at those points — is shared by the points of its supports
    /// as a rigid body on equal springs shares it ([`pressure_share`]): the vertical
    /// forces `f_i` vary linearly over the points' horizontal positions `x_i`, with
    /// `Σ f_i` the load and `Σ f_i x_i` its moment (the load's centre of pressure
    /// kept), clamped at zero. A point's normal impulse is `f_i h_s / n·up`, and its
    /// `f_i` goes to the lower body at `x_i` (not where
    /// [`SoftStepSettings::one_way_mass_ratio`] has the lower body not feel the
    /// upper one). Statically indeterminate supports (a box on two boxes) get the
    /// springs' share: exact for the stack, and on the pyramid's flanks, where a box
    /// carries one neighbour above on one side, its supports' unequal share (an
    /// equal force per manifold there over-estimated the outer support, whose
    /// preload then sat on its cap: the pyramid's worst displacement over 600 steps
    /// at 3 sub-steps 33.4 mm with equal forces, 0.69 mm with the share). The
    /// solve corrects the rest. Deterministic: the manifolds are taken by falling
    /// upper-body height, ties by contact index. With `all_manifolds` it estimates
    /// every manifold even when none is new (and still returns whether one was).
    fn estimate_loads(&self, st: &mut SoftState, up: DVec3, hs: f64, all_manifolds: bool) -> bool {
        let contacts = &self.contacts;
        let none_new = st.found_hit.iter().all(|&hit| hit);
        if none_new && !all_manifolds {
            return false;
        }
        let nb = self.bodies.len();
        let g = self.gravity.length();
        let ratio = self.settings.soft_step.one_way_mass_ratio;
        // Horizontal coordinates: along two axes normal to `up`.
        let (e1, e2) = up.any_orthonormal_pair();
        let flat = |x: DVec3| [x.dot(e1), x.dot(e2)];
        // Every entry is written below (each manifold's run; zero where it supports
        // nothing): sized, not cleared (zeroing it and the loads' moments each step
        // was 0.3 % of the 210-box pyramid's step, callgrind).
        st.estimate.resize(contacts.len(), 0.0);
        st.load.clear();
        st.load.extend(
            st.inv_mass
                .iter()
                .map(|&im| if im > 0.0 { g / im } else { 0.0 }),
        );
        // The weights' moments, at the bodies' centres.
        st.pressure.resize(nb + 1, Pressure::default());
        for ((p, b), &load) in st.pressure.iter_mut().zip(&self.bodies).zip(&st.load) {
            let x = flat(b.pose.x);
            *p = Pressure {
                moment: [load * x[0], load * x[1]],
                ..Pressure::default()
            };
        }
        st.pressure[nb] = Pressure::default();
        st.supports.clear();
        // Written for every supporting point below before it is read.
        st.flat.resize(contacts.len(), [0.0; 2]);
        let (by_rank, start) = st.colouring.bottom_up();
        let slot = |k: usize| self.colliders[k].body.unwrap_or(nb);
        for j in 0..by_rank.len() {
            let c = &contacts[start[j]];
            // The normal points from a to b: b is the upper body when n·up > 0.
            let n_up = c.normal.dot(up);
            let (upper, lower, n_up) = if n_up > 0.0 {
                (slot(c.b), slot(c.a), n_up)
            } else {
                (slot(c.a), slot(c.b), -n_up)
            };
            let supports = n_up >= 0.5 && upper != nb && st.inv_mass[upper] > 0.0;
            if supports {
                // The manifold's run sliced once (one bounds check, not one a point).
                let run = start[j]..start[j + 1];
                let pressure = &mut st.pressure[upper];
                for (out, c) in st.flat[run.clone()].iter_mut().zip(&contacts[run]) {
                    let x = flat(c.point);
                    *out = x;
                    pressure.add_point(x);
                }
            }
            st.supports
                .push((upper, lower, if supports { n_up } else { 0.0 }));
        }
        // Top-down (manifolds by falling lowest point): a body's load is complete once
        // the manifolds above it are taken.
        for &j in by_rank.iter().rev() {
            let j = j as usize;
            let (upper, lower, n_up) = st.supports[j];
            if n_up == 0.0 {
                st.estimate[start[j]..start[j + 1]].fill(0.0);
                continue;
            }
            let share = pressure_share(st.load[upper], &st.pressure[upper]);
            // One-way coupling: the lower body does not feel the upper one.
            let one_way = st.inv_mass[lower] > ratio * st.inv_mass[upper];
            let feels = lower != nb && st.inv_mass[lower] > 0.0 && !one_way;
            // The lower body's load and moment summed in locals, in the same order
            // (the same bits), and the run sliced once.
            let (mut load, mut m) = if feels {
                (st.load[lower], st.pressure[lower].moment)
            } else {
                (0.0, [0.0; 2])
            };
            let run = start[j]..start[j + 1];
            for (&x, e) in st.flat[run.clone()].iter().zip(&mut st.estimate[run]) {
                let f = share(x);
                *e = f / n_up * hs;
                if feels {
                    load += f;
                    m[0] += f * x[0];
                    m[1] += f * x[1];
                }
            }
            if feels {
                st.load[lower] = load;
                st.pressure[lower].moment = m;
            }
        }
        !none_new
    }

    /// Writes the bodies back (`x = x₀ + Δx`, `q = Δq q₀`) and keeps the impulses for
    /// the next step's warm start, sorted by collider pair.
    fn store(&mut self, st: &mut SoftState, hs: f64) {
        let anchors = self.settings.soft_step.friction_anchors;
        let moves = st.dp.iter().zip(&st.dq).zip(st.v.iter().zip(&st.w));
        for (b, ((dp, dq), (v, w))) in self.bodies.iter_mut().zip(moves) {
            b.pose.x += *dp;
            b.pose.q = (*dq * b.pose.q).normalize();
            b.v = *v;
            b.omega = *w;
        }
        // Sized once and written by position (every contact's entry is written).
        let nc = self.contacts.len();
        st.warm_next
            .resize(nc, ((0, 0, 0), 0.0, DVec3::ZERO, DVec3::ZERO, 0.0));
        // Every contact's three entries are written below: no clear.
        self.impulses.resize(3 * self.contacts.len(), 0.0);
        // In natural order: the contacts come sorted by collider pair, which is all
        // the merge in `prepare` needs (it finds a point by id within its pair's run),
        // so `warm` needs no sort. Within a pair the narrow phase's point ids are not
        // ascending (a box face's clipped corners), and sorting by the whole key cost
        // 4.5 % of the 210-box pyramid's step; checked by pair, and sorted if the
        // pairs are not in order.
        // Slices of exactly `nc` entries (the point arrays have one entry a contact):
        // `p < nc` is one bounds check for all of them, and the outputs are walked in
        // step (store was 4.8k of the 10-box stack's 206k instructions a step).
        let position = &st.colouring.position[..nc];
        let (impulse, dir, friction) = (&st.impulse[..nc], &st.dir[..nc], &st.friction[..nc]);
        let (preload_floor, total) = (&st.preload_floor[..nc], &st.total[..nc]);
        let outputs = st.warm_next[..nc]
            .iter_mut()
            .zip(self.impulses[..3 * nc].chunks_exact_mut(3));
        for ((c, &p), (warm, out)) in self.contacts.iter().zip(position).zip(outputs) {
            let [zn, z1, z2] = impulse[p];
            let [_, t1, t2] = dir[p];
            // The anchor's slip at the end of the step; forgotten when the friction
            // saturated (the pair slides) or anchors are off.
            let bound = friction[p] * zn;
            let sticking = z1.abs() < bound && z2.abs() < bound;
            let slip = if anchors && sticking {
                let [a, b] = st.slots[p];
                let [ra, rb] = st.anchor[p];
                let dd = (st.dp[b] + st.rot[b] * rb) - (st.dp[a] + st.rot[a] * ra);
                let [s1, s2] = st.slip[p];
                t1 * (s1 + t1.dot(dd)) + t2 * (s2 + t2.dot(dd))
            } else {
                DVec3::ZERO
            };
            *warm = (c.key(), zn, t1 * z1 + t2 * z2, slip, preload_floor[p]);
            out.copy_from_slice(&total[p]);
        }
        if !st.warm_next.is_sorted_by_key(|e| (e.0 .0, e.0 .1)) {
            // Keys are unique: the unstable sort is deterministic.
            st.warm_next.sort_unstable_by_key(|e| e.0);
        }
        core::mem::swap(&mut st.warm, &mut st.warm_next);
        st.warm_h = hs;
    }
}

/// The block normal solves of the manifolds (colour order). With `c_i =
/// impulse_scale / (mass_scale · m_i)` (see [`solve_block`]) and
///
/// ```text
/// A_ij = J_i M⁻¹ J_jᵀ = (1/m_a + 1/m_b) n_iᵀn_j + (r_a,i × n_i)ᵀ I_a⁻¹ (r_a,j × n_j)
///                                          + (r_b,i × n_i)ᵀ I_b⁻¹ (r_b,j × n_j),
/// ```
///
/// keeps `K⁻¹ = (A + diag c)⁻¹` by Gauss–Jordan (`K` is symmetric positive definite:
/// `A` is a Gram matrix and `c > 0`). A manifold of one point or more than
/// [`BLOCK_POINTS`], a row without mass, or a pivot that is not positive and finite
/// keeps `len` 0: its points are solved one by one.
fn build_blocks(st: &mut SoftState) {
    const N: usize = BLOCK_POINTS;
    let mp = &st.colouring.manifold_start;
    let manifolds = mp.len().saturating_sub(1);
    // Sized once (a no-op when the count is the last step's) and written in place: a
    // block's `pts`, `c` and `kinv` are read only when its `len` is set, and then all
    // of them have been written here (a new block pushed per manifold cost a zeroing
    // and a 200-byte copy each).
    // Taken while the rows are read beside them.
    let mut all = core::mem::take(&mut st.blocks);
    all.resize(manifolds, Block::default());
    let mut blocks = &mut all[..manifolds];
    let (mut j, points) = (0, &st.colouring.manifold_points);
    let manifold = |j: usize| &points[mp[j]..mp[j + 1]];
    // Two face manifolds (`N` points each) side by side in SIMD lanes
    // ([`build_block_pair`]: the same bits), the others one at a time.
    while let Some((blk, rest)) = blocks.split_first_mut() {
        let pts = manifold(j);
        if let Some(next) = rest.first_mut() {
            let pts2 = manifold(j + 1);
            if pts.len() == N && pts2.len() == N {
                build_block_pair(st, [pts, pts2], [blk, next]);
                blocks = &mut rest[1..];
                j += 2;
                continue;
            }
        }
        build_block(st, pts, blk);
        blocks = rest;
        j += 1;
    }
    st.blocks = all;
}

/// One manifold's block (see [`build_blocks`]).
#[inline(always)]
fn build_block(st: &SoftState, pts: &[usize], blk: &mut Block) {
    const N: usize = BLOCK_POINTS;
    let len = pts.len();
    blk.len = 0;
    if (2..=N).contains(&len) {
        let [ma, mb] = st.im[pts[0]];
        let mut ok = true;
        for (i, &p) in pts.iter().enumerate() {
            let sp = st.soft[p];
            let m = st.mass[p][0];
            ok &= m > 0.0 && sp.mass_scale > 0.0;
            blk.c[i] = sp.impulse_scale / (sp.mass_scale * m);
        }
        // Padding: identity rows and columns, so that `K⁻¹` is too (the solve
        // runs over all N with zero residuals there).
        let mut k = [0.0; N * N];
        for i in 0..N {
            k[i * N + i] = 1.0;
        }
        for i in 0..len {
            let p = pts[i];
            let (n, g) = (st.dir[p][0], &st.ang[p][0]);
            for l in i..len {
                let q = pts[l];
                let h = &st.ang[q][0];
                let a = (ma + mb) * n.dot(st.dir[q][0]) + g[0].dot(h[2]) + g[1].dot(h[3]);
                k[i * N + l] = a;
                k[l * N + i] = a;
            }
            k[i * N + i] += blk.c[i];
        }
        if ok && invert(&mut k, &mut blk.kinv) {
            blk.pts[..len].copy_from_slice(pts);
            blk.len = len;
        }
    }
}

/// Two manifolds' blocks of [`BLOCK_POINTS`] points each (see [`build_blocks`]), one
/// per SIMD lane (`wide::f64x2`): each lane does [`build_block`]'s arithmetic
/// operation for operation and in the same order (IEEE-754 lanes round as the scalar
/// operations do; dot products summed left to right as `DVec3::dot` does), so the
/// blocks are the same, bit for bit (a lane whose pivot fails computes on, harmlessly,
/// where the scalar inversion stops: its block keeps `len` 0 either way).
fn build_block_pair(st: &SoftState, pts: [&[usize]; 2], blk: [&mut Block; 2]) {
    const N: usize = BLOCK_POINTS;
    let lanes = |a: DVec3, b: DVec3| {
        [
            f64x2::new([a.x, b.x]),
            f64x2::new([a.y, b.y]),
            f64x2::new([a.z, b.z]),
        ]
    };
    let dot = |a: &[f64x2; 3], b: &[f64x2; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let [blk0, blk1] = blk;
    let mut ok = [true; 2];
    let mut c = [f64x2::ZERO; N];
    for (s, (pts, blk)) in pts.iter().zip([&mut *blk0, &mut *blk1]).enumerate() {
        for (i, &p) in pts.iter().enumerate() {
            let sp = st.soft[p];
            let m = st.mass[p][0];
            ok[s] &= m > 0.0 && sp.mass_scale > 0.0;
            blk.c[i] = sp.impulse_scale / (sp.mass_scale * m);
            c[i].as_mut_array()[s] = blk.c[i];
        }
    }
    let sum = |p: usize| {
        let [ma, mb] = st.im[p];
        ma + mb
    };
    let m = f64x2::new([sum(pts[0][0]), sum(pts[1][0])]);
    // Per point: the normal and `r_a × n`, `r_b × n`, `I_a⁻¹(r_a × n)`, `I_b⁻¹(r_b × n)`.
    let row = |i: usize, r: usize| {
        let (p, q) = (pts[0][i], pts[1][i]);
        if r == 4 {
            lanes(st.dir[p][0], st.dir[q][0])
        } else {
            lanes(st.ang[p][0][r], st.ang[q][0][r])
        }
    };
    let rows: [[[f64x2; 3]; 5]; N] = core::array::from_fn(|i| core::array::from_fn(|r| row(i, r)));
    let mut k = [f64x2::ZERO; N * N];
    for i in 0..N {
        let (n, g) = (&rows[i][4], &rows[i]);
        for l in i..N {
            let h = &rows[l];
            let a = m * dot(n, &h[4]) + dot(&g[0], &h[2]) + dot(&g[1], &h[3]);
            k[i * N + l] = a;
            k[l * N + i] = a;
        }
        k[i * N + i] += c[i];
    }
    let mut out = [f64x2::ZERO; N * N];
    let inverted = invert_pair(&mut k, &mut out);
    for (s, (pts, blk)) in pts.iter().zip([blk0, blk1]).enumerate() {
        blk.len = 0;
        if ok[s] && inverted[s] {
            let kinv: [f64; N * N] = core::array::from_fn(|e| out[e].as_array()[s]);
            if kinv.iter().all(|x| x.is_finite()) {
                blk.kinv = kinv;
                blk.pts.copy_from_slice(pts);
                blk.len = N;
            }
        }
    }
}

/// [`invert`] of two matrices, one per lane of `k` and `out`: per lane, whether every
/// pivot was positive and finite (the caller checks that the inverse is finite).
fn invert_pair(
    k: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
) -> [bool; 2] {
    const N: usize = BLOCK_POINTS;
    *out = [f64x2::ZERO; N * N];
    for i in 0..N {
        out[i * N + i] = f64x2::ONE;
    }
    let mut ok = [true; 2];
    pivot_pair::<0>(k, out, &mut ok);
    pivot_pair::<1>(k, out, &mut ok);
    pivot_pair::<2>(k, out, &mut ok);
    pivot_pair::<3>(k, out, &mut ok);
    ok
}

/// [`pivot`] on both lanes (clearing a lane's `ok` where its pivot is not positive
/// and finite, where [`invert`] would stop).
#[inline(always)]
fn pivot_pair<const C: usize>(
    k: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64x2; BLOCK_POINTS * BLOCK_POINTS],
    ok: &mut [bool; 2],
) {
    const N: usize = BLOCK_POINTS;
    let piv = k[C * N + C];
    for (ok, p) in ok.iter_mut().zip(piv.to_array()) {
        *ok &= p > 0.0 && p.is_finite();
    }
    let inv = f64x2::ONE / piv;
    for l in C + 1..N {
        k[C * N + l] *= inv;
    }
    for l in 0..=C {
        out[C * N + l] *= inv;
    }
    for r in 0..N {
        if r != C {
            let f = k[r * N + C];
            for l in C + 1..N {
                k[r * N + l] -= f * k[C * N + l];
            }
            for l in 0..=C {
                out[r * N + l] -= f * out[C * N + l];
            }
        }
    }
}

/// Inverts `k` (row-major `N × N`, symmetric positive definite) into `out` by
/// Gauss–Jordan without pivoting; false if a pivot is not positive and finite or the
/// inverse is not finite (`out` is then not to be used).
fn invert(
    k: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
) -> bool {
    const N: usize = BLOCK_POINTS;
    *out = [0.0; N * N];
    for i in 0..N {
        out[i * N + i] = 1.0;
    }
    // One pivot per column, each with its column fixed at compile time (its loops
    // then unroll: with a run-time column the shortened loops cost more than they
    // save, 12.6k → 19.5k instructions a step for the 10-box stack's blocks).
    const _: () = assert!(BLOCK_POINTS == 4, "invert takes four pivots");
    pivot::<0>(k, out)
        && pivot::<1>(k, out)
        && pivot::<2>(k, out)
        && pivot::<3>(k, out)
        && out.iter().all(|x| x.is_finite())
}

/// Pivot `C` of [`invert`]'s Gauss–Jordan sweep: row `C` over its pivot, then column
/// `C` eliminated from the other rows; false if the pivot is not positive and finite.
/// Only what is read again is updated: `k`'s columns `≤ C` are never read after this
/// pivot (later pivots read the columns `> C`), and `out`'s row `C` is zero beyond
/// column `C` (row `c` of `out` is zero past column `c` until pivot `c`), so `out`
/// changes in the columns `≤ C` only (subtracting `f · 0` leaves an entry's bits as
/// they were: `f` and `1/pivot` are finite here, or `out` ends non-finite either
/// way). The same bits as the full sweep over all `N` columns.
#[inline(always)]
fn pivot<const C: usize>(
    k: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
    out: &mut [f64; BLOCK_POINTS * BLOCK_POINTS],
) -> bool {
    const N: usize = BLOCK_POINTS;
    let piv = k[C * N + C];
    if !(piv > 0.0 && piv.is_finite()) {
        return false;
    }
    let inv = 1.0 / piv;
    for l in C + 1..N {
        k[C * N + l] *= inv;
    }
    for l in 0..=C {
        out[C * N + l] *= inv;
    }
    for r in 0..N {
        if r != C {
            let f = k[r * N + C];
            for l in C + 1..N {
                k[r * N + l] -= f * k[C * N + l];
            }
            for l in 0..=C {
                out[r * N + l] -= f * out[C * N + l];
            }
        }
    }
    true
}

/// `v += g h` for one body (the static slot and asleep bodies, zero inverse mass, stay
/// at rest).
#[inline(always)]
pub(super) fn integrate_velocity(v: &mut DVec3, inv_mass: f64, g: DVec3, hs: f64) {
    if inv_mass > 0.0 {
        *v += g * hs;
    }
}

/// `v += g h` for every moving body (the static slot is last).
fn integrate_velocities(st: &mut SoftState, g: DVec3, hs: f64) {
    let n = st.v.len() - 1;
    for (v, &m) in st.v[..n].iter_mut().zip(&st.inv_mass) {
        integrate_velocity(v, m, g, hs);
    }
}

/// `Δx += v h`, `Δq ← exp(ω h) Δq` (and its matrix) for one body; an asleep body (zero
/// inverse mass) is skipped.
#[inline(always)]
pub(super) fn integrate_position(
    dp: &mut DVec3,
    dq: &mut DQuat,
    rot: &mut DMat3,
    (v, w, inv_mass): (DVec3, DVec3, f64),
    hs: f64,
) {
    if !(inv_mass > 0.0) {
        return; // asleep
    }
    *dp += v * hs;
    *dq = rotate_by(*dq, w * hs);
    *rot = DMat3::from_quat(*dq);
}

/// [`integrate_position`] for every moving body (the static slot is last).
fn integrate_positions(st: &mut SoftState, hs: f64) {
    let n = st.v.len() - 1;
    for i in 0..n {
        integrate_position(
            &mut st.dp[i],
            &mut st.dq[i],
            &mut st.rot[i],
            (st.v[i], st.w[i], st.inv_mass[i]),
            hs,
        );
    }
}

/// Separation `Δd = (Δx_b + Δq_b r_b) − (Δx_a + Δq_a r_a)` of point `p`'s anchors
/// since the start of the step (the anchors fixed in the bodies).
#[inline(always)]
pub(super) fn separation<B: Bodies>(rows: &Rows, p: usize, vel: &B) -> DVec3 {
    let [a, b] = rows.slots[p];
    let [ra, rb] = rows.anchor[p];
    let ((dpa, rota), (dpb, rotb)) = (vel.displacement(a), vel.displacement(b));
    (dpb + rotb * rb) - (dpa + rota * ra)
}

/// Current gap of point `p` from the displacements since the start of the step:
/// `C = C₀ + nᵀ Δd` ([`separation`]; the threaded passes' gap stage).
#[cfg(feature = "parallel")]
#[inline(always)]
pub(super) fn gap_of<B: Bodies>(rows: &Rows, p: usize, vel: &B) -> f64 {
    rows.base_gap[p] + rows.dir[p][0].dot(separation(rows, p, vel))
}

/// The bodies as the point passes see them: velocities they read and write, and the
/// displacements since the start of the step they read. Plain slices on one thread;
/// atomics under the `parallel` feature (where the colouring keeps two threads off one
/// body).
pub(super) trait Bodies {
    /// `(v, ω)` of slot `i`.
    fn velocity(&self, i: usize) -> (DVec3, DVec3);
    /// Stores `(v, ω)` of slot `i`; never called for the static slot.
    fn set_velocity(&mut self, i: usize, v: DVec3, w: DVec3);
    /// `(Δx, Δq as a matrix)` of slot `i`.
    fn displacement(&self, i: usize) -> (DVec3, DMat3);
}

/// [`Bodies`] over the state's own slices (the single-thread passes).
struct Slices<'a> {
    v: &'a mut [DVec3],
    w: &'a mut [DVec3],
    dp: &'a [DVec3],
    rot: &'a [DMat3],
}

impl Bodies for Slices<'_> {
    #[inline(always)]
    fn velocity(&self, i: usize) -> (DVec3, DVec3) {
        (self.v[i], self.w[i])
    }
    #[inline(always)]
    fn set_velocity(&mut self, i: usize, v: DVec3, w: DVec3) {
        self.v[i] = v;
        self.w[i] = w;
    }
    #[inline(always)]
    fn displacement(&self, i: usize) -> (DVec3, DMat3) {
        (self.dp[i], self.rot[i])
    }
}

/// What the point passes read of each point, borrowed from [`SoftState`] (it does not
/// change during the sub-steps).
pub(super) struct Rows<'a> {
    pub(super) slots: &'a [[usize; 2]],
    pub(super) dir: &'a [[DVec3; 3]],
    pub(super) anchor: &'a [[DVec3; 2]],
    pub(super) ang: &'a [[[DVec3; 4]; 3]],
    pub(super) mass: &'a [[f64; 3]],
    pub(super) im: &'a [[f64; 2]],
    pub(super) base_gap: &'a [f64],
    pub(super) soft: &'a [Softness],
    pub(super) friction: &'a [f64],
    pub(super) slip: &'a [[f64; 2]],
    /// `λ_pre` of each point ([`SoftStepSettings::preload`]).
    pub(super) preload: &'a [f64],
    /// Its cap per metre of penetration.
    pub(super) preload_cap: &'a [f64],
    /// The cap's floor.
    pub(super) preload_floor: &'a [f64],
    /// The static slot (the last): never written.
    pub(super) fixed: usize,
}

/// Settings of one Gauss–Seidel pass (see [`solve_point`]).
#[derive(Clone, Copy)]
pub(super) struct Pass {
    pub(super) inv_h: f64,
    pub(super) use_bias: bool,
    pub(super) max_push: f64,
    pub(super) anchors: bool,
}

/// The [`Rows`] of a `SoftState` place: field borrows only, so the bodies' velocities
/// can be borrowed mutably beside them.
macro_rules! rows {
    ($st:expr) => {
        Rows {
            slots: &$st.slots,
            dir: &$st.dir,
            anchor: &$st.anchor,
            ang: &$st.ang,
            mass: &$st.mass,
            im: &$st.im,
            base_gap: &$st.base_gap,
            soft: &$st.soft,
            friction: &$st.friction,
            slip: &$st.slip,
            preload: &$st.preload,
            preload_cap: &$st.preload_cap,
            preload_floor: &$st.preload_floor,
            fixed: $st.v.len() - 1,
        }
    };
}

#[cfg(feature = "parallel")]
impl SoftState {
    /// The rows the passes read.
    pub(super) fn rows(&self) -> Rows<'_> {
        rows!(self)
    }
}

/// Splits the state into the rows the passes read, the bodies and the points'
/// impulses.
macro_rules! split {
    ($st:expr) => {
        (
            rows!($st),
            Slices {
                v: &mut $st.v,
                w: &mut $st.w,
                dp: &$st.dp,
                rot: &$st.rot,
            },
            &mut $st.impulse,
            &mut $st.max_normal,
        )
    };
}

/// `v += M⁻¹ Jᵀ λ` of the three rows of point `p` with impulses `z`.
#[inline(always)]
pub(super) fn apply_point<B: Bodies>(rows: &Rows, p: usize, z: [f64; 3], vel: &mut B) {
    let [a, b] = rows.slots[p];
    let d = rows.dir[p];
    let g = &rows.ang[p];
    let lin = d[0] * z[0] + d[1] * z[1] + d[2] * z[2];
    let [ma, mb] = rows.im[p];
    let ((va, wa), (vb, wb)) = (vel.velocity(a), vel.velocity(b));
    let va = va - lin * ma;
    let wa = wa - (g[0][2] * z[0] + g[1][2] * z[1] + g[2][2] * z[2]);
    let vb = vb + lin * mb;
    let wb = wb + (g[0][3] * z[0] + g[1][3] * z[1] + g[2][3] * z[2]);
    // The static slot's inverse mass and inertia are zero: it stays at rest.
    if a != rows.fixed {
        vel.set_velocity(a, va, wa);
    }
    if b != rows.fixed {
        vel.set_velocity(b, vb, wb);
    }
}

/// `v += M⁻¹ Jᵀ λ` of point `p` on the state's own velocities (restitution).
fn apply(st: &mut SoftState, p: usize, z: [f64; 3]) {
    let (rows, mut vel, _, _) = split!(st);
    apply_point(&rows, p, z, &mut vel);
}

/// Applies the stored impulses of every point (warm start, each sub-step) in solve
/// order: colour by colour, two manifolds at a time in SIMD lanes
/// ([`warm_manifolds`]: the same bits as [`apply_point`] one point at a time, the
/// manifolds of a colour touching disjoint moving bodies), a colour's odd manifold
/// and the overflow colour's points (whose manifolds may share bodies) one by one.
fn warm_start(st: &mut SoftState) {
    // The pairs' index (72 B) is taken, not borrowed: its `Vec`s as locals stay in
    // registers across the velocity writes (borrowed from `st`, the 210-box
    // pyramid's step took 8.580M instructions, taken with the blocks 8.550M;
    // callgrind). The 430 B colouring is borrowed: taking it copied it twice a pass.
    let paired = core::mem::take(&mut st.paired);
    let colouring = &st.colouring;
    {
        let (rows, mut vel, impulse, _) = split!(st);
        let mut one = |p: usize, vel: &mut Slices| apply_point(&rows, p, impulse[p], vel);
        for_manifold_pairs(
            colouring,
            rows.slots.len(),
            paired.four(),
            |j, pts, vel: &mut Slices| {
                let pr = paired.quad(j, pts[0].len());
                warm_quad(&rows, pr, pts, vel.v, vel.w, impulse)
            },
            |j, pts, vel: &mut Slices| {
                let pr = paired.of(j, pts[0].len());
                warm_manifolds(&rows, pr, pts, vel.v, vel.w, impulse)
            },
            &mut one,
            &mut vel,
        );
    }
    st.paired = paired;
}

/// Walks the colouring for the point passes that take two manifolds at a time: per
/// colour before the overflow colour, with `four`, `quad` on consecutive manifolds
/// `j … j + 3` (where it declines, and without `four`, as two pairs), `pair` on
/// consecutive manifolds `(j, j + 1)` (their points in order; where it declines, and
/// for a colour's odd manifold, `one` on each point in order), then `one` on the
/// overflow colour's points in solve order (its manifolds may share bodies). Within a
/// colour the manifolds touch disjoint moving bodies, so this is the same work, bit
/// for bit, as every point in solve order.
#[inline(always)]
fn for_manifold_pairs<S>(
    colouring: &Colouring,
    points: usize,
    four: bool,
    mut quad: impl FnMut(usize, [&[usize]; 4], &mut S) -> bool,
    mut pair: impl FnMut(usize, [&[usize]; 2], &mut S) -> bool,
    one: &mut impl FnMut(usize, &mut S),
    state: &mut S,
) {
    let (mp, pts) = (
        colouring.manifold_start.as_slice(),
        colouring.manifold_points.as_slice(),
    );
    let manifold = |j: usize| &pts[mp[j]..mp[j + 1]];
    let starts = colouring.colour_start.as_slice();
    let colours = starts.len().saturating_sub(1);
    let serial = colouring.serial_from + 1 < colouring.ranges.len();
    let empty: &[usize] = &[];
    // One call site of `one` (inlined once), fed the points of a declined pair, of a
    // colour's odd manifold or of the overflow colour.
    for c in 0..colours {
        let overflow = serial && c + 1 == colours;
        let (mut j, hi) = (starts[c], starts[c + 1]);
        while j < hi {
            let (m0, m1, positions) = if overflow {
                j = hi;
                (
                    empty,
                    empty,
                    colouring.ranges[colouring.serial_from]..points,
                )
            } else {
                let m0 = manifold(j);
                if four && j + 3 < hi {
                    let (m1, m2, m3) = (manifold(j + 1), manifold(j + 2), manifold(j + 3));
                    if quad(j, [m0, m1, m2, m3], state) {
                        j += 4;
                        continue;
                    }
                }
                let m1 = if j + 1 < hi { manifold(j + 1) } else { empty };
                j += 2;
                if !m1.is_empty() && pair(j - 2, [m0, m1], state) {
                    continue;
                }
                (m0, m1, 0..0)
            };
            for p in m0.iter().chain(m1).copied().chain(positions) {
                one(p, state);
            }
        }
    }
}

/// Every point's gap at the current displacements into `st.gap` (once per
/// sub-step, after the positions: the relax passes and the next biased pass share
/// it, where each pass computed it before; the same bits). Manifold by manifold, so
/// that the two bodies' displacements are loaded once for all of its points: the
/// same arithmetic as `C₀ + nᵀ Δd` ([`separation`]). Two consecutive manifolds
/// with as many points go side by side in SIMD lanes ([`manifold_gaps`]: each gap
/// reads only the step's rows and displacements, so any two manifolds may pair; the
/// same bits), the others one point at a time (the 210-box pyramid's `update_gaps`
/// 407k → 326k instructions a step, callgrind).
fn update_gaps(st: &mut SoftState) {
    let mut gap = core::mem::take(&mut st.gap);
    let colouring = &st.colouring;
    // Every point is in one manifold and is written below: no clear (zeroing 8 B a
    // point per sub-step cost 0.7 % of the 210-box pyramid's step, callgrind).
    gap.resize(st.slots.len(), 0.0);
    {
        let (rows, vel, _, _) = split!(st);
        let (mp, pts) = (
            colouring.manifold_start.as_slice(),
            colouring.manifold_points.as_slice(),
        );
        let manifolds = mp.len().saturating_sub(1);
        let mut j = 0;
        while j < manifolds {
            let m0 = &pts[mp[j]..mp[j + 1]];
            let Some(&first) = m0.first() else {
                j += 1;
                continue;
            };
            // The points of one manifold share their two bodies.
            let [a, b] = rows.slots[first];
            // Two manifolds with as many points at a time in SIMD lanes.
            if j + 1 < manifolds {
                let m1 = &pts[mp[j + 1]..mp[j + 2]];
                if let Some(&first1) = m1.first() {
                    let ab = [[a, b], rows.slots[first1]];
                    if manifold_gaps(&rows, [m0, m1], ab, (vel.dp, vel.rot), &mut gap) {
                        j += 2;
                        continue;
                    }
                }
            }
            let ((dpa, rota), (dpb, rotb)) = (vel.displacement(a), vel.displacement(b));
            for &p in m0 {
                let [ra, rb] = rows.anchor[p];
                let dd = (dpb + rotb * rb) - (dpa + rota * ra);
                gap[p] = rows.base_gap[p] + rows.dir[p][0].dot(dd);
            }
            j += 1;
        }
    }
    st.gap = gap;
}

/// Rate `J v` of row `r` of point `p`.
#[inline]
fn rate(st: &SoftState, p: usize, r: usize) -> f64 {
    let [a, b] = st.slots[p];
    let d = st.dir[p][r];
    let g = &st.ang[p][r];
    d.dot(st.v[b] - st.v[a]) + g[1].dot(st.w[b]) - g[0].dot(st.w[a])
}

/// One Gauss–Seidel pass over the points ([`solve_point`] on each, in solve order),
/// or, for the biased pass with block normal solves, over the manifolds in colour
/// order ([`solve_manifold`] on each: within a colour the manifolds touch disjoint
/// moving bodies, so this is the same work as the point order).
fn solve(st: &mut SoftState, hs: f64, use_bias: bool, max_push: f64, anchors: bool) {
    let pass = Pass {
        inv_h: 1.0 / hs,
        use_bias,
        max_push,
        anchors,
    };
    let gap = core::mem::take(&mut st.gap);
    if use_bias && !st.blocks.is_empty() {
        // Taken, not borrowed (see `warm_start`).
        let paired = core::mem::take(&mut st.paired);
        let blocks = core::mem::take(&mut st.blocks);
        let colouring = &st.colouring;
        {
            let (rows, mut vel, impulse, max_normal) = split!(st);
            let (mp, pts) = (
                colouring.manifold_start.as_slice(),
                colouring.manifold_points.as_slice(),
            );
            let mut io = PointSlices {
                impulse: &mut *impulse,
                max_normal: &mut *max_normal,
                gap: &gap,
            };
            let one = |j: usize, io: &mut PointSlices, vel: &mut Slices| {
                let pts = &pts[mp[j]..mp[j + 1]];
                solve_manifold(&rows, &blocks[j], pts, io, vel, pass);
            };
            // Colour by colour, two manifolds at a time in SIMD lanes
            // ([`block_pair`]: the same bits as one at a time), except in the
            // overflow colour (the last, if in use), whose manifolds may share bodies.
            let starts = colouring.colour_start.as_slice();
            let colours = starts.len().saturating_sub(1);
            let serial = colouring.serial_from + 1 < colouring.ranges.len();
            for c in 0..colours {
                let (mut j, hi) = (starts[c], starts[c + 1]);
                if !(serial && c + 1 == colours) {
                    while j + 1 < hi {
                        if paired.four() && j + 3 < hi {
                            let quad = [&blocks[j], &blocks[j + 1], &blocks[j + 2], &blocks[j + 3]];
                            let pr = paired.quad(j, blocks[j].len);
                            if block_quad(&rows, pr, quad, &mut io, &mut vel, pass) {
                                j += 4;
                                continue;
                            }
                        }
                        let pair = [&blocks[j], &blocks[j + 1]];
                        let pr = paired.of(j, blocks[j].len);
                        if !block_pair(&rows, pr, pair, &mut io, &mut vel, pass) {
                            one(j, &mut io, &mut vel);
                            one(j + 1, &mut io, &mut vel);
                        }
                        j += 2;
                    }
                }
                for j in j..hi {
                    one(j, &mut io, &mut vel);
                }
            }
        }
        st.paired = paired;
        st.blocks = blocks;
    } else if !use_bias {
        relax_in_lanes(st, &gap, pass);
    } else {
        let (rows, mut vel, impulse, max_normal) = split!(st);
        for (p, (z, m)) in impulse.iter_mut().zip(max_normal.iter_mut()).enumerate() {
            solve_point(&rows, p, gap[p], z, m, &mut vel, pass);
        }
    }
    st.gap = gap;
}

/// The relax pass ([`solve_point`] without bias on every point, in solve order) with
/// the manifolds of each colour taken two at a time in SIMD lanes
/// ([`relax_manifolds`]: the same bits as one point at a time; see
/// [`for_manifold_pairs`]).
fn relax_in_lanes(st: &mut SoftState, gap: &[f64], pass: Pass) {
    // The pairs' index (72 B) is taken, not borrowed: its `Vec`s as locals stay in
    // registers across the velocity writes (borrowed from `st`, the 210-box
    // pyramid's step took 8.580M instructions, taken with the blocks 8.550M;
    // callgrind). The 430 B colouring is borrowed: taking it copied it twice a pass.
    let paired = core::mem::take(&mut st.paired);
    let colouring = &st.colouring;
    {
        let (rows, vel, impulse, max_normal) = split!(st);
        let (dp, rot) = (vel.dp, vel.rot);
        let mut io = RelaxIo {
            v: &mut *vel.v,
            w: &mut *vel.w,
            impulse: &mut *impulse,
            max_normal: &mut *max_normal,
            gap,
        };
        let mut one = |p: usize, io: &mut RelaxIo| {
            let mut vel = Slices {
                v: &mut *io.v,
                w: &mut *io.w,
                dp,
                rot,
            };
            solve_point(
                &rows,
                p,
                gap[p],
                &mut io.impulse[p],
                &mut io.max_normal[p],
                &mut vel,
                pass,
            );
        };
        for_manifold_pairs(
            colouring,
            rows.slots.len(),
            paired.four(),
            |j, pts, io: &mut RelaxIo| {
                relax_quad(&rows, paired.quad(j, pts[0].len()), pts, io, pass.inv_h)
            },
            |j, pts, io: &mut RelaxIo| {
                relax_manifolds(&rows, paired.of(j, pts[0].len()), pts, io, pass.inv_h)
            },
            &mut one,
            &mut io,
        );
    }
    st.paired = paired;
}

/// The points' impulses as the manifold passes see them: plain slices on one
/// thread, atomics under the `parallel` feature.
pub(super) trait PointImpulses {
    /// Impulses `[λ_n, λ_t1, λ_t2]` and the largest normal impulse of point `p`.
    fn get(&self, p: usize) -> ([f64; 3], f64);
    /// Stores them.
    fn set(&mut self, p: usize, z: [f64; 3], max_normal: f64);
    /// Gap of point `p` at the current displacements ([`SoftState::gap`]).
    fn gap(&self, p: usize) -> f64;
}

/// [`PointImpulses`] over the state's own slices.
struct PointSlices<'a> {
    impulse: &'a mut [[f64; 3]],
    max_normal: &'a mut [f64],
    gap: &'a [f64],
}

impl PointImpulses for PointSlices<'_> {
    #[inline(always)]
    fn get(&self, p: usize) -> ([f64; 3], f64) {
        (self.impulse[p], self.max_normal[p])
    }
    #[inline(always)]
    fn set(&mut self, p: usize, z: [f64; 3], max_normal: f64) {
        self.impulse[p] = z;
        self.max_normal[p] = max_normal;
    }
    #[inline(always)]
    fn gap(&self, p: usize) -> f64 {
        self.gap[p]
    }
}

/// One manifold in the biased pass (points `pts`, bottom-up): [`solve_block`] or,
/// where that declines or the manifold has no block, point by point
/// ([`solve_point`]).
#[inline(always)]
pub(super) fn solve_manifold<B: Bodies, I: PointImpulses>(
    rows: &Rows,
    blk: &Block,
    pts: &[usize],
    io: &mut I,
    vel: &mut B,
    pass: Pass,
) {
    if blk.len > 0 {
        let mut z = [[0.0; 3]; BLOCK_POINTS];
        let mut m = [0.0; BLOCK_POINTS];
        for i in 0..blk.len {
            (z[i], m[i]) = io.get(blk.pts[i]);
        }
        let mut gap = [0.0; BLOCK_POINTS];
        for i in 0..blk.len {
            gap[i] = io.gap(blk.pts[i]);
        }
        if solve_block(rows, blk, &gap, &mut z, &mut m, vel, pass) {
            for i in 0..blk.len {
                io.set(blk.pts[i], z[i], m[i]);
            }
            return;
        }
    }
    for &p in pts {
        let (mut z, mut m) = io.get(p);
        solve_point(rows, p, io.gap(p), &mut z, &mut m, vel, pass);
        io.set(p, z, m);
    }
}

/// The biased pass over one manifold with its normal rows solved together. One soft
/// row's update `Δλ_i = −m_i·mass_scale·(J_i v + b_i) − impulse_scale·(λ_i − λ_pre,i)`
/// is the solution of `J_i v' + b_i + c_i (λ_i' − λ_pre,i) = 0` with `c_i =
/// impulse_scale / (mass_scale·m_i)` (`mass_scale + impulse_scale = 1`; Catto,
/// Solver2D 2024, soft step); the manifold's rows together give
///
/// ```text
/// (A + diag c) Δλ = −(J v + b + c∘(λ − λ_pre)),   A = J M⁻¹ Jᵀ
/// ```
///
/// (Box2D v2.4's block solver, `b2ContactSolver::SolveVelocityConstraints`, for four
/// points and with its all-active case only; `K⁻¹` from [`build_blocks`]). If every
/// `λ'` is non-negative it is taken, then the friction rows point by point as in
/// [`solve_point`]; otherwise, or if a point is separated (speculative), returns false
/// having changed nothing. `z`, `max_normal`: the points' impulses, in `blk.pts` order.
#[inline(always)]
fn solve_block<B: Bodies>(
    rows: &Rows,
    blk: &Block,
    gaps: &[f64; BLOCK_POINTS],
    z: &mut [[f64; 3]; BLOCK_POINTS],
    max_normal: &mut [f64; BLOCK_POINTS],
    vel: &mut B,
    pass: Pass,
) -> bool {
    const N: usize = BLOCK_POINTS;
    let len = blk.len;
    let p0 = blk.pts[0];
    let [a, b] = rows.slots[p0];
    let ((mut va, mut wa), (mut vb, mut wb)) = (vel.velocity(a), vel.velocity(b));
    let s = rows.soft[p0];
    // r = J v + b + c∘(λ − λ_pre), with the gap of each point as in `solve_point`.
    let mut r = [0.0; N];
    let mut dd = [DVec3::ZERO; N];
    for i in 0..len {
        let p = blk.pts[i];
        let d = &rows.dir[p];
        let g = &rows.ang[p];
        let gap = gaps[i];
        if gap > 0.0 {
            return false;
        }
        let vn = d[0].dot(vb - va) + g[0][1].dot(wb) - g[0][0].dot(wa);
        let bias = at_least(s.bias_rate * gap, -pass.max_push);
        let pre = at_most(
            rows.preload[p],
            at_least(rows.preload_cap[p] * -gap, rows.preload_floor[p]),
        );
        r[i] = vn + bias + blk.c[i] * (z[i][0] - pre);
    }
    // Δλ = −K⁻¹ r (the padding of K⁻¹ is the identity, and r is zero there).
    let mut dz = [0.0; N];
    let mut all_active = true;
    for i in 0..N {
        let k = &blk.kinv[i * N..i * N + N];
        dz[i] = -(k[0] * r[0] + k[1] * r[1] + k[2] * r[2] + k[3] * r[3]);
        all_active &= z[i][0] + dz[i] >= 0.0;
    }
    if !all_active {
        return false;
    }
    for i in 0..len {
        let p = blk.pts[i];
        let d = &rows.dir[p];
        let g = &rows.ang[p];
        let [ma, mb] = rows.im[p];
        z[i][0] += dz[i];
        max_normal[i] = at_least(z[i][0], max_normal[i]);
        va -= d[0] * (ma * dz[i]);
        wa -= g[0][2] * dz[i];
        vb += d[0] * (mb * dz[i]);
        wb += g[0][3] * dz[i];
    }
    // Every point penetrates (gap ≤ 0): anchored friction where anchors are on (the
    // slip needs the anchors' separation).
    if pass.anchors {
        for i in 0..len {
            dd[i] = separation(rows, blk.pts[i], vel);
        }
    }
    for i in 0..len {
        friction_rows(
            rows,
            blk.pts[i],
            &mut z[i],
            dd[i],
            true,
            (&mut va, &mut wa, &mut vb, &mut wb),
            pass,
        );
    }
    if a != rows.fixed {
        vel.set_velocity(a, va, wa);
    }
    if b != rows.fixed {
        vel.set_velocity(b, vb, wb);
    }
    true
}

/// The two friction rows of point `p` after its normal row, on velocities held by the
/// caller: Coulomb's `|λ_t| ≤ μ λ_n` per tangent row (pyramid). With anchors, the
/// biased pass pulls a sticking pair (`touching`: gap ≤ 0) back along its slip `s_t
/// = s₀ + tᵀ Δd` (`dd` = Δd, the anchors' separation since the start of the step) as
/// a soft row: `Δλ_t = −m_t · mass_scale · (J_t v + bias_rate · s_t) − impulse_scale ·
/// λ_t`.
#[inline(always)]
fn friction_rows(
    rows: &Rows,
    p: usize,
    z: &mut [f64; 3],
    dd: DVec3,
    touching: bool,
    (va, wa, vb, wb): (&mut DVec3, &mut DVec3, &mut DVec3, &mut DVec3),
    pass: Pass,
) {
    let d = &rows.dir[p];
    let g = &rows.ang[p];
    let m = rows.mass[p];
    let [ma, mb] = rows.im[p];
    let bound = rows.friction[p] * z[0];
    let anchored = pass.use_bias && pass.anchors && touching;
    let s = rows.soft[p];
    for r in 1..3 {
        let vt = d[r].dot(*vb - *va) + g[r][1].dot(*wb) - g[r][0].dot(*wa);
        let unbounded = if anchored {
            let slip = rows.slip[p][r - 1] + d[r].dot(dd);
            let bias = at_least(at_most(s.bias_rate * slip, pass.max_push), -pass.max_push);
            z[r] - m[r] * s.mass_scale * (vt + bias) - s.impulse_scale * z[r]
        } else {
            z[r] - m[r] * vt
        };
        let new = at_least(at_most(unbounded, bound), -bound);
        let dz = new - z[r];
        z[r] = new;
        *va -= d[r] * (ma * dz);
        *wa -= g[r][2] * dz;
        *vb += d[r] * (mb * dz);
        *wb += g[r][3] * dz;
    }
}

/// Point `p`'s rows in one Gauss–Seidel pass: the normal row (soft with bias when
/// `use_bias`, rigid without), then the two friction rows bounded by `μ λ_n`. The point
/// loads its two bodies' velocities once, updates them row by row, and stores them
/// back (Box2D v3's `b2SolveContact`); `z` are its impulses, `max_normal` the largest
/// normal impulse it has had this step (restitution).
#[inline(always)]
pub(super) fn solve_point<B: Bodies>(
    rows: &Rows,
    p: usize,
    gap: f64,
    z: &mut [f64; 3],
    max_normal: &mut f64,
    vel: &mut B,
    pass: Pass,
) {
    let Pass {
        inv_h,
        use_bias,
        max_push,
        ..
    } = pass;
    let [a, b] = rows.slots[p];
    // Borrowed, not copied: the twelve angular vectors stay in the point's row.
    let d = &rows.dir[p];
    let g = &rows.ang[p];
    let m = rows.mass[p];
    let [ma, mb] = rows.im[p];
    let ((mut va, mut wa), (mut vb, mut wb)) = (vel.velocity(a), vel.velocity(b));
    // `gap`: the current gap C = C₀ + nᵀ Δd ([`gap_of`]); the anchors' separation Δd
    // itself only where anchored friction reads the slip.
    let dd = if use_bias && pass.anchors {
        separation(rows, p, vel)
    } else {
        DVec3::ZERO
    };
    // Δλ = −m · mass_scale · (J v + bias) − impulse_scale · (λ − λ_pre), then λ ≥ 0,
    // with the preload capped at `γ/(1 − γ) · m h ω²` times the penetration (only a
    // penetrating point is preloaded, and no more than the spring at rest would be:
    // an impact's impulse does not become a push the next step).
    let (bias, mass_scale, impulse_scale, pre) = if gap > 0.0 {
        // Speculative: approach at most to the surface within the sub-step.
        (gap * inv_h, 1.0, 0.0, 0.0)
    } else if use_bias {
        let s = rows.soft[p];
        (
            at_least(s.bias_rate * gap, -max_push),
            s.mass_scale,
            s.impulse_scale,
            at_most(
                rows.preload[p],
                at_least(rows.preload_cap[p] * -gap, rows.preload_floor[p]),
            ),
        )
    } else {
        (0.0, 1.0, 0.0, 0.0)
    };
    let vn = d[0].dot(vb - va) + g[0][1].dot(wb) - g[0][0].dot(wa);
    let new = at_least(
        z[0] - m[0] * mass_scale * (vn + bias) - impulse_scale * (z[0] - pre),
        0.0,
    );
    let dz = new - z[0];
    z[0] = new;
    *max_normal = at_least(new, *max_normal);
    va -= d[0] * (ma * dz);
    wa -= g[0][2] * dz;
    vb += d[0] * (mb * dz);
    wb += g[0][3] * dz;
    friction_rows(
        rows,
        p,
        z,
        dd,
        gap <= 0.0,
        (&mut va, &mut wa, &mut vb, &mut wb),
        pass,
    );
    // The static slot's inverse mass and inertia are zero: it stays at rest.
    if a != rows.fixed {
        vel.set_velocity(a, va, wa);
    }
    if b != rows.fixed {
        vel.set_velocity(b, vb, wb);
    }
}

/// `max(x, lo)` as one compare-and-select (x86 `maxsd`): `x` if `x > lo`, else `lo`.
/// Unlike [`f64::max`] it does not skip a NaN bound: a NaN `lo` gives NaN, which the
/// step's divergence check rejects (a NaN `x` gives `lo`, as `f64::max` does). Never
/// panics (no `clamp`).
#[inline(always)]
fn at_least(x: f64, lo: f64) -> f64 {
    if x > lo {
        x
    } else {
        lo
    }
}

/// `min(x, hi)` as one compare-and-select (x86 `minsd`); NaN as in [`at_least`].
#[inline(always)]
fn at_most(x: f64, hi: f64) -> f64 {
    if x < hi {
        x
    } else {
        hi
    }
}

/// Restitution (after the sub-steps, Box2D's `b2ApplyRestitution`): a point that
/// approached faster than `threshold` and carried load gets `J v ≥ −e v_approach`.
fn restitution(st: &mut SoftState, threshold: f64) {
    if !st.bouncy {
        return; // every `e` is zero: every point is skipped below
    }
    for p in 0..st.slots.len() {
        let e = st.restitution[p];
        if e == 0.0 || st.approach[p] > -threshold || st.max_normal[p] == 0.0 {
            continue;
        }
        let vn = rate(st, p, 0);
        let z = st.impulse[p][0];
        let new = (z - st.mass[p][0] * (vn + e * st.approach[p])).max(0.0);
        st.impulse[p][0] = new;
        st.total[p][0] += new - z;
        apply(st, p, [new - z, 0.0, 0.0]);
    }
}

/// Natural-map residual of the last sub-step's unbiased problem (the relax pass) at
/// the final velocities and impulses: normal `w = J v + max(C/h, 0)` with `λ ≥ 0`,
/// tangents `w = J v` with `|λ_t| ≤ μ λ_n`, scaled by `max(1, |w|∞)`.
fn residual(st: &SoftState, hs: f64) -> f64 {
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 1.0;
    for p in 0..st.slots.len() {
        let [a, b] = st.slots[p];
        let [ra, rb] = st.anchor[p];
        let n = st.dir[p][0];
        let gap = st.base_gap[p] + n.dot((st.dp[b] + st.rot[b] * rb) - (st.dp[a] + st.rot[a] * ra));
        let z = st.impulse[p];
        let bound = st.friction[p] * z[0];
        for r in 0..3 {
            if !(st.mass[p][r] > 0.0) {
                continue;
            }
            let w = rate(st, p, r) + if r == 0 { (gap / hs).max(0.0) } else { 0.0 };
            let (lo, hi) = if r == 0 {
                (0.0, f64::INFINITY)
            } else {
                (-bound, bound)
            };
            scale = scale.max(w.abs());
            worst = worst.max((z[r] - (z[r] - w).min(hi).max(lo)).abs());
        }
    }
    worst / scale
}
