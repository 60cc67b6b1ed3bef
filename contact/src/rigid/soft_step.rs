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

#[cfg(feature = "parallel")]
use constraint_core::rigid::rotate_by;
use constraint_core::{DMat3, DQuat, DVec3, Pose};
use wide::f64x2;

use super::colouring::Colouring;
use super::soft_lanes::{
    biased_manifolds, biased_quad, block_pair, block_quad, manifold_gaps, relax_manifolds,
    relax_quad, warm_manifolds, warm_quad, Paired, PointRows, RelaxIo,
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
    /// Box2D v2.4's two-point block solver does; where an impulse would turn negative
    /// or a preload is on its cap, as a small LCP with the cap taken at the sub-step's
    /// end (the `block_lcp` module); a separated point that still carries an impulse
    /// keeps its soft row, one that does not (an approach) sends the manifold point by
    /// point. One Gauss–Seidel pass
    /// over the corners of a face leaves the face rocking (the top box of the 10-box
    /// stack sways by about 1 cm at the defaults); the block solve does not. Off, the
    /// biased pass runs point by point, two or four manifolds at a time in SIMD lanes
    /// as the relax pass does (the same bits as one point at a time).
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
    /// There the preload is a spring `M γ/(1 − γ)` times as stiff as the contact's
    /// own; the block normal solve takes it at the sub-step's end (implicitly, as the
    /// soft row takes its spring): read at the sub-step's start it grew an
    /// out-of-plane sway of the 210-box pyramid to 3–5 cm over 1800 steps under
    /// settings nudged in their 7th digit (`soft_points pyramid20 1800 3
    /// preload=0.98000001`: 48.9 mm read at the start, 0.63 mm at the end).
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
/// per sub-step, tangent impulse per sub-step as a world vector, and the preload
/// floor per sub-step (see [`SoftStepSettings::preload`]). The friction anchor's slip
/// is kept apart ([`SoftState::warm_slip`]): 64 bytes an entry, not 88, where anchors
/// are off (the default), for `store` to write and `prepare`'s merge to read.
type Warm = ((usize, usize, u64), f64, DVec3, f64);

/// One manifold's normal rows solved together (at most [`BLOCK_POINTS`] points).
/// 64-byte aligned (256 B, of which 200 used): `pts` and `len`, all the lane passes
/// read of a block whose rows are packed, then lie in one cache line (at a 200-byte
/// stride half of the blocks had them across two).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
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
/// A floor that fades into the subnormal range (after about 70k resting steps) is
/// flushed to 0 (subnormal products are slow on x86; see `prepare`).
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
    /// The bodies' rotation matrices at the start of the step (`load_bodies`' first
    /// pass; the gyroscopic step and the world inverse inertias read them).
    pub(super) body_rot: Vec<DMat3>,
    /// The bodies' rotations `exp(ω h)` over a sub-step (`integrate_positions`' first
    /// pass).
    pub(super) exp: Vec<DQuat>,
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
    ///
    /// Written only for the manifolds of `ang_kept` (the lane passes read a packed
    /// point's rows from [`Paired`] instead).
    pub(super) ang: Vec<[[DVec3; 4]; 3]>,
    /// Per manifold (colour order): whether its points' `ang` is written this step.
    /// It is where the manifold is not packed (the one-point passes solve it), not
    /// of [`BLOCK_POINTS`] points (the blocks' one-point build reads it), has
    /// restitution (the restitution pass reads it), in a group
    /// whose normals are not shared (solved one point at a time), and for every
    /// manifold in a step after one that solved as many points one at a time as
    /// there are points (`one_point`), on threads, without the block normal solve,
    /// or with the residual. Where it
    /// is not, a packed manifold that the biased pass solves one point at a time has
    /// its terms rebuilt for it into `ang_scratch` ([`rebuild_ang`]). Not writing
    /// them saves the 210-box pyramid's preparation 288 B of writes a point (≈ 7k of
    /// its 160k D1 misses a step, cachegrind); the 1000-box pile, many of whose lane
    /// groups decline the biased pass, mostly keeps them (its step +0.4 % instructions).
    pub(super) ang_kept: Vec<bool>,
    /// Where `ang` is not kept: the angular terms rebuilt for the one-point biased
    /// pass, by solve position.
    pub(super) ang_scratch: Vec<[[DVec3; 4]; 3]>,
    /// Points solved one at a time in the biased and relax passes since the last
    /// `prepare` (see `ang_kept`).
    pub(super) one_point: usize,
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
    /// The friction anchor's slip of each entry of `warm` (world vector, zero when
    /// sliding), in its order; empty where the step that stored `warm` had anchors
    /// off (a slip not kept reads as zero).
    pub(super) warm_slip: Vec<DVec3>,
    pub(super) warm_slip_next: Vec<DVec3>,
    /// Scratch of `store`'s sort of `warm_next` with its slips (anchors on, pairs
    /// out of order): kept, so that the sort does not allocate once grown.
    pub(super) warm_sort: Vec<(Warm, DVec3)>,
    /// Whether the keys in `warm` are unique (the step that stored them had no
    /// repeated contact key: the narrow phase does not promise it), which lets
    /// `prepare`'s merge take the entry after the last hit without a search.
    pub(super) warm_unique: bool,
    /// Whether this step's contact keys are unique (set by `prepare`; `warm_unique`
    /// once `store` keeps them).
    pub(super) unique_keys: bool,
    /// Whether this step's contacts come sorted by collider pair (set by `prepare`,
    /// which walks their runs; `store` then keeps their keys without checking).
    pub(super) pairs_ascending: bool,
    /// The previous step's impulses of each contact (natural order; zero if new):
    /// normal, tangent vector, preload floor (see [`Warm`]).
    pub(super) found: Vec<(f64, DVec3, f64)>,
    /// The previous step's anchor slip of each contact (natural order; zero if new),
    /// kept apart from `found` and only with friction anchors on (the only reader).
    pub(super) found_slip: Vec<DVec3>,
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
        st.warm
            .extend(self.warm.iter().map(|&(key, (zn, ft))| (key, zn, ft, 0.0)));
        st.warm_slip.clear();
        // Not checked: the merge searches every point.
        st.warm_unique = false;
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
                .map(|&(key, zn, ft, _)| (key, (zn * k, ft * k))),
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
            return self.finish_soft(st, hs, stats, false);
        }
        // Without restitution (which changes the totals after the sub-steps) the last
        // sub-step's impulses are added to the totals where `store` reads them: one
        // pass over the points fewer, the same additions.
        let deferred = !st.bouncy;
        for k in 0..substeps {
            integrate_velocities(&mut st, g, hs);
            warm_start(&mut st);
            solve(&mut st, hs, true, s.max_push_velocity, s.friction_anchors);
            integrate_positions(&mut st, hs);
            update_gaps(&mut st);
            for _ in 0..s.relax_passes {
                solve(&mut st, hs, false, 0.0, false);
            }
            if deferred && k + 1 == substeps {
                break;
            }
            // As flat slices (the same additions, two a packed instruction: per point
            // they were 9 instructions a sub-step, 0.7 % of the step, callgrind).
            let total = st.total.as_flattened_mut();
            for (t, z) in total.iter_mut().zip(st.impulse.as_flattened()) {
                *t += *z;
            }
        }
        self.finish_soft(st, hs, stats, deferred)
    }

    /// After the sub-steps: restitution, the residual, the bodies written back and the
    /// impulses kept (`deferred`: the last sub-step's impulses are still to be added
    /// to the totals, see [`ContactWorld::store`]).
    fn finish_soft(
        &mut self,
        mut st: Box<SoftState>,
        hs: f64,
        mut stats: ContactStats,
        deferred: bool,
    ) -> ContactStats {
        restitution(&mut st, self.settings.restitution_threshold);
        stats.residual = self.settings.soft_step.residual.then(|| residual(&st, hs));
        self.store(&mut st, hs, deferred);
        self.soft = Some(st);
        stats
    }

    /// Body slots: inverse masses and world inverse inertias at the start of the step,
    /// velocities after the implicit gyroscopic update over `h`, zero displacements.
    fn load_bodies(&mut self, st: &mut SoftState, h: f64) {
        let n = self.bodies.len() + 1;
        // Sized to the slots (a no-op when the body count is the last step's) and every
        // entry written below, once: the bodies' in one pass over the seven arrays
        // (the static values for an asleep body), then the static slot's (clearing
        // and refilling each array, then overwriting the bodies' entries, was seven
        // passes and four overwrites).
        st.v.resize(n, DVec3::ZERO);
        st.w.resize(n, DVec3::ZERO);
        st.inv_mass.resize(n, 0.0);
        st.inv_inertia.resize(n, DMat3::ZERO);
        st.dp.resize(n, DVec3::ZERO);
        st.dq.resize(n, DQuat::IDENTITY);
        st.rot.resize(n, DMat3::IDENTITY);
        // One rotation matrix a body for both the gyroscopic step and the inverse
        // inertia (`world_inv_inertia`'s `R I⁻¹ Rᵀ`), all of them first: the
        // gyroscopic step (out of line) reads its matrix from memory, and a matrix
        // stored just before the call, 8 and 16 bytes at a time, was read back 16
        // bytes across two of those stores (three store-forwarding stalls a call; its
        // first 16-byte load drew 13.5 % of its wall-time samples, `perf record`).
        st.body_rot.clear();
        st.body_rot.extend(self.bodies.iter().map(|b| b.rotation()));
        let slots = st
            .inv_mass
            .iter_mut()
            .zip(&mut st.inv_inertia)
            .zip(st.v.iter_mut().zip(&mut st.w));
        let moves = st.dp.iter_mut().zip(&mut st.dq).zip(&mut st.rot);
        let bodies = self.bodies.iter_mut().zip(&st.body_rot);
        for (i, ((b, r), (((im, ii), (v, w)), ((dp, dq), rot)))) in
            bodies.zip(slots.zip(moves)).enumerate()
        {
            (*dp, *dq, *rot) = (DVec3::ZERO, DQuat::IDENTITY, DMat3::IDENTITY);
            // An asleep body (the sleep module's hook) takes a static slot: at rest, zero
            // inverse mass, not integrated (it is in no contact row either).
            if self.sleep.asleep.get(i).copied().unwrap_or(false) {
                (*im, *ii, *v, *w) = (0.0, DMat3::ZERO, DVec3::ZERO, DVec3::ZERO);
                continue;
            }
            b.omega = b.gyroscopic_step_with(r, h);
            *im = 1.0 / b.mass();
            *ii = rotated_inertia(r, &b.inv_inertia());
            *v = b.v;
            *w = b.omega;
        }
        // The static slot, the last.
        let last = n - 1;
        (st.inv_mass[last], st.inv_inertia[last]) = (0.0, DMat3::ZERO);
        (st.v[last], st.w[last]) = (DVec3::ZERO, DVec3::ZERO);
        (st.dp[last], st.dq[last], st.rot[last]) = (DVec3::ZERO, DQuat::IDENTITY, DMat3::IDENTITY);
    }

    /// Writes the bodies back (`x = x₀ + Δx`, `q = Δq q₀`) and keeps the impulses for
    /// the next step's warm start, sorted by collider pair; the step's impulses are
    /// the totals, plus the last sub-step's where `deferred` (the same additions as
    /// the sub-steps' pass).
    fn store(&mut self, st: &mut SoftState, hs: f64, deferred: bool) {
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
        st.warm_next.resize(nc, ((0, 0, 0), 0.0, DVec3::ZERO, 0.0));
        // The slips only with anchors on (empty otherwise: read as zeros).
        st.warm_slip_next.clear();
        if anchors {
            st.warm_slip_next.resize(nc, DVec3::ZERO);
        }
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
        for (k, ((c, &p), (warm, out))) in
            self.contacts.iter().zip(position).zip(outputs).enumerate()
        {
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
            *warm = (c.key(), zn, t1 * z1 + t2 * z2, preload_floor[p]);
            if let Some(s) = st.warm_slip_next.get_mut(k) {
                *s = slip;
            }
            let t = total[p];
            if deferred {
                out.copy_from_slice(&[t[0] + zn, t[1] + z1, t[2] + z2]);
            } else {
                out.copy_from_slice(&t);
            }
        }
        // `warm_next` holds the contacts' keys in natural order: sorted by pair
        // exactly when the contacts' runs ascend, which `prepare` saw.
        if !st.pairs_ascending {
            // Keys are unique: the unstable sort is deterministic.
            if anchors {
                // The slips sorted with their entries.
                st.warm_sort.clear();
                let (warm, slip) = (&st.warm_next, &st.warm_slip_next);
                st.warm_sort
                    .extend(warm.iter().copied().zip(slip.iter().copied()));
                st.warm_sort.sort_unstable_by_key(|e| e.0 .0);
                let (warm, slip) = (&mut st.warm_next, &mut st.warm_slip_next);
                for ((w, s), &(e, sl)) in warm.iter_mut().zip(slip.iter_mut()).zip(&st.warm_sort) {
                    *w = e;
                    *s = sl;
                }
            } else {
                st.warm_next.sort_unstable_by_key(|e| e.0);
            }
        }
        core::mem::swap(&mut st.warm, &mut st.warm_next);
        core::mem::swap(&mut st.warm_slip, &mut st.warm_slip_next);
        st.warm_unique = st.unique_keys;
        st.warm_h = hs;
    }
}

/// `R I⁻¹ Rᵀ` as glam computes `r * m * r.transpose()`: each column of a product `A c`
/// is `(a_x c.x + a_y c.y) + a_z c.z`, component by component. Here the x and y
/// components of each column are the two lanes of an `f64x2` and the z component is
/// scalar: each lane does the scalar's operations in glam's order (the same bits), with
/// two thirds of the arithmetic instructions.
#[inline(always)]
fn rotated_inertia(r: &DMat3, m: &DMat3) -> DMat3 {
    let xy = |v: DVec3| f64x2::new([v.x, v.y]);
    let mul = |a: &DMat3, c: DVec3| {
        let (cx, cy, cz) = (f64x2::splat(c.x), f64x2::splat(c.y), f64x2::splat(c.z));
        let p = (xy(a.x_axis) * cx + xy(a.y_axis) * cy + xy(a.z_axis) * cz).to_array();
        let z = a.x_axis.z * c.x + a.y_axis.z * c.y + a.z_axis.z * c.z;
        DVec3::new(p[0], p[1], z)
    };
    let rm = DMat3::from_cols(mul(r, m.x_axis), mul(r, m.y_axis), mul(r, m.z_axis));
    let rt = r.transpose();
    DMat3::from_cols(
        mul(&rm, rt.x_axis),
        mul(&rm, rt.y_axis),
        mul(&rm, rt.z_axis),
    )
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
/// inverse mass) is skipped (the threaded passes'; [`integrate_positions`] does the
/// same operations in two passes over the bodies).
#[cfg(feature = "parallel")]
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

/// `Δx += v h`, `Δq ← exp(ω h) Δq` (and its matrix) for every moving body (the static
/// slot is last; an asleep body, zero inverse mass, is skipped), in two passes: the
/// rotations `exp(ω h)` of every moving body first (`DQuat::from_scaled_axis`: a
/// square root, a division and a `sincos` each, into [`SoftState::exp`]), then `Δx`,
/// `Δq ← (exp(ω h) Δq)/|·|` and `Δq`'s matrix. The same functions on the same values
/// as `rotate_by` (the same bits); a body's chain of square roots, divisions and the
/// `sincos` call no longer stands between the next body's, so the processor overlaps
/// them.
fn integrate_positions(st: &mut SoftState, hs: f64) {
    let n = st.v.len() - 1;
    // Every entry written below (the identity for an asleep body, never read).
    st.exp.resize(n, DQuat::IDENTITY);
    let (w, inv_mass) = (&st.w[..n], &st.inv_mass[..n]);
    for (e, (&w, &m)) in st.exp[..n].iter_mut().zip(w.iter().zip(inv_mass)) {
        *e = if m > 0.0 {
            DQuat::from_scaled_axis(w * hs)
        } else {
            DQuat::IDENTITY
        };
    }
    let poses = st.dp[..n].iter_mut().zip(&mut st.dq[..n]);
    let poses = poses.zip(&mut st.rot[..n]);
    let vels = st.v[..n].iter().zip(inv_mass).zip(&st.exp[..n]);
    for (((dp, dq), rot), ((&v, &m), &e)) in poses.zip(vels) {
        if !(m > 0.0) {
            continue; // asleep
        }
        // `rotate_by(Δq, ω h)`: `exp(ω h) Δq` renormalised.
        *dp += v * hs;
        *dq = (e * *dq).normalize();
        *rot = DMat3::from_quat(*dq);
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

impl Rows<'_> {
    /// Stores the velocities `[(v_a, ω_a), (v_b, ω_b)]` of a point's bodies `[a, b]`;
    /// the static slot keeps its zero velocity (its inverse mass and inertia are zero:
    /// it stays at rest).
    #[inline(always)]
    pub(super) fn store_pair<B: Bodies>(
        &self,
        vel: &mut B,
        [a, b]: [usize; 2],
        [(va, wa), (vb, wb)]: [(DVec3, DVec3); 2],
    ) {
        if a != self.fixed {
            vel.set_velocity(a, va, wa);
        }
        if b != self.fixed {
            vel.set_velocity(b, vb, wb);
        }
    }
}

/// Point `p`'s `ang` (see [`SoftState::ang`]) from its packed rows ([`Paired::inv_of`])
/// and its anchors and directions: `r × d` as `prepare` computes it (glam's
/// `cross`, the same operations), `I⁻¹(r × d)` as it stored it: the same bits.
/// `None` where `p` is not packed.
#[inline]
pub(super) fn rebuild_ang(
    paired: &Paired,
    anchor: &[[DVec3; 2]],
    dir: &[[DVec3; 3]],
    p: usize,
) -> Option<[[DVec3; 4]; 3]> {
    let inv = paired.inv_of(p)?;
    let ([ra, rb], d) = (*anchor.get(p)?, dir.get(p)?);
    Some(core::array::from_fn(|r| {
        [ra.cross(d[r]), rb.cross(d[r]), inv[r][0], inv[r][1]]
    }))
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
    rows.store_pair(vel, [a, b], [(va, wa), (vb, wb)]);
}

mod block;
mod block_lcp;
mod passes;
mod prepare;

use block::*;
use block_lcp::*;
pub(super) use passes::*;
use prepare::*;
// The per-point loop's constants, for its AVX builds (`soft_lanes::fill_points`).
pub(super) use prepare::PointConsts;

#[cfg(test)]
mod tests {
    use super::*;

    /// The two-pass [`integrate_positions`] gives, bit for bit, `Δx += v h`, `Δq ←
    /// rotate_by(Δq, ω h)` and `Δq`'s matrix body by body (tolerance 0; measured
    /// equal) on 19 bodies after 5 sub-steps, with an asleep body (zero inverse mass)
    /// left as it was and a body at rest (`ω = 0`).
    #[test]
    fn two_pass_positions_are_rotate_by_body_by_body() {
        let n = 19;
        let mut st = SoftState::default();
        let f = |i: usize, k: f64| ((i as f64 + 1.0) * k).sin();
        st.v = (0..=n)
            .map(|i| DVec3::new(f(i, 0.7), f(i, 1.3), f(i, 2.9)))
            .collect();
        st.w = (0..=n)
            .map(|i| DVec3::new(f(i, 3.1), f(i, 0.4), f(i, 1.7)) * (i as f64))
            .collect();
        st.inv_mass = (0..=n).map(|i| if i == 5 { 0.0 } else { 1.0 }).collect();
        st.dp = vec![DVec3::ZERO; n + 1];
        st.dq = vec![DQuat::IDENTITY; n + 1];
        st.rot = vec![DMat3::IDENTITY; n + 1];
        let hs = 1.0 / 180.0;
        let mut one = (st.dp.clone(), st.dq.clone(), st.rot.clone());
        for _ in 0..5 {
            integrate_positions(&mut st, hs);
            for i in 0..n {
                if st.inv_mass[i] > 0.0 {
                    one.0[i] += st.v[i] * hs;
                    one.1[i] = constraint_core::rigid::rotate_by(one.1[i], st.w[i] * hs);
                    one.2[i] = DMat3::from_quat(one.1[i]);
                }
            }
        }
        let bits = |dp: &[DVec3], dq: &[DQuat], rot: &[DMat3]| -> Vec<u64> {
            let mut b = Vec::new();
            for i in 0..dp.len() {
                b.extend(dp[i].to_array().map(f64::to_bits));
                b.extend(dq[i].to_array().map(f64::to_bits));
                b.extend(rot[i].to_cols_array().map(f64::to_bits));
            }
            b
        };
        assert_eq!(bits(&st.dp, &st.dq, &st.rot), bits(&one.0, &one.1, &one.2));
        assert_eq!(st.dq[5], DQuat::IDENTITY);
        assert_ne!(st.dq[1], DQuat::IDENTITY);
    }

    /// Where a step does not keep a packed manifold's angular terms
    /// ([`SoftState::ang_kept`]), [`rebuild_ang`] gives, bit for bit, what a step that
    /// keeps every manifold's stored (the same state: the residual, which keeps them
    /// all, changes no bits), on the 6-level pyramid and the 10-box stack after 20
    /// steps; and the steps do leave manifolds unkept there.
    #[test]
    fn rebuilt_angular_terms_are_the_stored_ones() {
        use crate::rigid::ContactSolver;
        use crate::scenes::{box_stack, pyramid};
        for scene in [pyramid(6), box_stack(10)] {
            let mut w = scene.expect("the scene builds");
            w.settings.solver = ContactSolver::SoftStep { substeps: 3 };
            let mut all = w.clone();
            all.settings.soft_step.residual = true;
            for _ in 0..20 {
                w.step(1.0 / 60.0).expect("the scene steps");
                all.step(1.0 / 60.0).expect("the scene steps");
            }
            let (Some(st), Some(kept)) = (w.soft.as_ref(), all.soft.as_ref()) else {
                panic!("no soft state");
            };
            assert!(kept.ang_kept.iter().all(|&k| k));
            let (mp, pts) = (&st.colouring.manifold_start, &st.colouring.manifold_points);
            let mut rebuilt = 0;
            for j in 0..mp.len() - 1 {
                if st.ang_kept[j] {
                    continue;
                }
                for &p in &pts[mp[j]..mp[j + 1]] {
                    let g = rebuild_ang(&st.paired, &st.anchor, &st.dir, p).expect("packed");
                    let bits =
                        |g: &[[DVec3; 4]; 3]| g.map(|r| r.map(|v| v.to_array().map(f64::to_bits)));
                    assert_eq!(bits(&g), bits(&kept.ang[p]), "point {p}");
                    rebuilt += 1;
                }
            }
            assert!(rebuilt > 0, "no manifold left unkept");
        }
    }

    /// Restitution reads the angular terms (`rate`, `apply`): a bouncy manifold keeps
    /// them ([`SoftState::ang_kept`]), so the 6-level pyramid with restitution 0.5,
    /// its boxes thrown down at 2 m/s after 10 steps, ends 20 steps later with the
    /// same bits as with every manifold's terms kept (the residual keeps them all).
    #[test]
    fn restitution_reads_kept_angular_terms() {
        use crate::rigid::ContactSolver;
        use crate::scenes::pyramid;
        let mut w = pyramid(6).expect("the scene builds");
        w.settings.solver = ContactSolver::SoftStep { substeps: 3 };
        for c in &mut w.colliders {
            c.restitution = 0.5;
        }
        let mut all = w.clone();
        all.settings.soft_step.residual = true;
        let state = |w: &ContactWorld| -> Vec<u64> {
            let mut bits = Vec::new();
            for b in w.bodies() {
                for v in [b.pose.x, b.v, b.omega] {
                    bits.extend(v.to_array().map(f64::to_bits));
                }
            }
            bits
        };
        for w in [&mut w, &mut all] {
            for k in 0..30 {
                if k == 10 {
                    for b in w.bodies_mut() {
                        b.v.z -= 2.0;
                    }
                }
                w.step(1.0 / 60.0).expect("the scene steps");
            }
        }
        assert_eq!(state(&w), state(&all));
        let st = w.soft.as_ref().expect("soft state");
        assert!(st.bouncy && st.ang_kept.iter().all(|&k| k));
    }

    /// [`rotated_inertia`] gives glam's `r * m * r.transpose()` bit for bit, on
    /// rotations about random axes and random (non-symmetric, signed) matrices.
    #[test]
    fn rotated_inertia_is_glams_product_bit_for_bit() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..1000 {
            let axis = DVec3::new(next(), next(), next()).normalize_or(DVec3::Z);
            let r = DMat3::from_quat(DQuat::from_axis_angle(axis, 4.0 * next()));
            let m = DMat3::from_cols_array(&core::array::from_fn(|_| 10.0 * next()));
            let (got, want) = (rotated_inertia(&r, &m), r * m * r.transpose());
            let bits = |a: DMat3| a.to_cols_array().map(f64::to_bits);
            assert_eq!(bits(got), bits(want), "{r} {m}");
        }
    }
}
