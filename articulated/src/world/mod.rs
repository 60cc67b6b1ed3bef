//! A world of rigid bodies and joints, and its time step.
//!
//! Every method assembles the same KKT matrix `[M Jᵀ; J −C]` and factors it with
//! Baraff's tree ordering ([`crate::tree`]); they differ in the unknowns and the
//! right-hand side (Otaduy 2010, "Restricciones Fuertes"):
//!
//! | [`Method`] | system | then |
//! |---|---|---|
//! | `Velocity` | `[M Jᵀ; J −C][v'; λ] = [M v + h f; −β C(x₀)/h]` ("Opción 2") | `x' = x + h v'`, `R' = exp(h ω') R` |
//! | `VelocityProjected` | as `Velocity` | Newton projection `[M Jᵀ; J 0][δ; λ] = [0; −C(x')]` until `max|C| ≤ tol` (Goldenthal 2007) |
//! | `Acceleration` | `[M Jᵀ; J 0][a; λ] = [f; −J̇v − k_x C − k_v J v]` ("Opción 1", Baumgarte) | `v' = v + h a`, `x' = x + h v'` |
//!
//! `f` is gravity; the gyroscopic term `−ω × I ω` enters through an implicit
//! (backward Euler, one Newton step) update of `ω` before the solve
//! ([`RigidBody::gyroscopic_step`]) in the velocity methods, explicitly in the
//! acceleration method. Joint damping is implicit in the velocity methods (compliant
//! rows, [`crate::joint`]) and explicit in the acceleration method.
//!
//! A joint can also be made *compliant* ([`World::set_compliance`]): `C(x) = −α λ_f`
//! instead of `C(x) = 0` (`α = 1/k`, `λ_f` the joint force), a stiff spring of potential
//! `C²/(2α)`. The velocity methods treat it implicitly in the lecture's compliant form
//! `[M Jᵀ; J −α/h²][v'; λ] = [M v + h f; −β C/h]` (exactly the backward-Euler spring for
//! `β = 1`) and leave it out of the position projection; the acceleration level and
//! RATTLE apply it as the explicit spring force `−(1/α) Jᵀ C` (symplectic Euler, and
//! Störmer–Verlet in RATTLE's kicks), with its rows out of the KKT system and out of the
//! SHAKE projection — stable only while `h √(k/m)` stays small.

use alloc::vec::Vec;

use constraint_core::{DMat3, DVec3, Pose, StepContext};

use crate::body::RigidBody;
use crate::error::ArticulatedError;
use crate::joint::{Joint, JointKind, Kept, MAX_ROWS};
use crate::tree::{JointTopo, TreeSolver};
use constraint_core::compound::MAX_DOF;

mod acceleration;
mod active_set;
mod actuator;
#[cfg(feature = "contact")]
mod contact;
mod eq_cache;
mod equality;
mod factor_cache;
mod fluid;
mod projection;
mod rattle;
mod spatial_tendon;
mod unilateral;
mod velocity;

pub use active_set::MAX_ITERATIONS as ACTIVE_SET_ITERATIONS;
pub use actuator::{Actuator, DofSpring, Target, Tendon};
#[cfg(feature = "contact")]
pub use contact::CollisionFilter;
pub use equality::{Equality, Terms};
pub use fluid::Fluid;
pub use spatial_tendon::{PathSite, SpatialTendon};
pub use unilateral::{RowSource, UnilateralSettings, UnilateralStats};

/// Largest rotation of a body in one RATTLE drift (rad) before the step is redone at
/// the velocity level.
const MAX_TURN: f64 = 0.5;

/// A contact's impulses kept for the next step: its key (collider pair, feature id),
/// normal impulse and friction impulse as a world vector.
#[cfg(feature = "contact")]
type WarmContact = ((usize, usize, u64), (f64, DVec3));

/// Loop-closure rows of one assembly: `(a, b, row)`, compliance, right-hand side.
type LoopRows = (Vec<(Option<usize>, usize, [DVec3; 4])>, Vec<f64>, Vec<f64>);

/// An assembly's writer of a joint's right-hand side: `(joint index, joint, its rows,
/// the right-hand side of its rows)`. It reads the hard rows only (`0..n_hard`): the
/// rows may be a kept entry's, with rate rows after them that this assembly does not
/// use, and the slice is as long as the rows the assembly uses.
type JointRhs<'a> = dyn FnMut(usize, &Joint, &crate::joint::JointRows, &mut [f64]) + 'a;

/// One joint's rows ([`Joint::rows_with`]) at one configuration: the bits of the two
/// poses (`x`, `q` of the parent, the world's identity without one, then of the child),
/// whether the rate rows were computed, the rows. A joint's rows are a function of its
/// kind (fixed once added: joints are only appended) and of these poses alone, so an
/// assembly at poses equal bit for bit takes the kept rows — the same bits the
/// computation would give. RATTLE assembles at each configuration up to three times
/// (its second kick and the damping flow at `x_{n+1}`, the next step's first kick at the
/// same `x_{n+1}`), the rows of a hinge cost about a thousand instructions, the key
/// fourteen comparisons.
#[derive(Clone, Copy, Debug)]
struct CachedRows {
    /// Whether the entry holds rows (false: never filled).
    valid: bool,
    /// Bits of the parent's and the child's `x` and `q`.
    key: [u64; 14],
    /// Whether `rows` has the rate rows.
    rates: bool,
    /// The pose epoch (`World::rows_epoch`) in which the key was last found equal to
    /// the poses (or the rows computed at them): within that epoch the poses have not
    /// moved, so a lookup of the same epoch takes the entry without comparing the key.
    seen: u64,
    rows: crate::joint::JointRows,
}

/// Whether two pose keys ([`CachedRows::key_of`]) are equal: the differences of all
/// their words or-ed, one test (the array `==` called `memcmp`, whose early exit on
/// keys that differ in a varying word mispredicts: 2.5 % of half_cheetah's time in
/// `perf`). The same answer as `a == b`.
#[inline]
pub(crate) fn same_key(a: &[u64; 14], b: &[u64; 14]) -> bool {
    let mut d = 0u64;
    for (x, y) in a.iter().zip(b) {
        d |= x ^ y;
    }
    d == 0
}

impl CachedRows {
    /// The bits of the poses `a` (parent) and `b` (child).
    fn key_of(a: &Pose, b: &Pose) -> [u64; 14] {
        [
            a.x.x, a.x.y, a.x.z, a.q.x, a.q.y, a.q.z, a.q.w, b.x.x, b.x.y, b.x.z, b.q.x, b.q.y,
            b.q.z, b.q.w,
        ]
        .map(f64::to_bits)
    }

    /// `joint.rows_with(a, b, rates)`, by reference: `cache[j]`'s rows when it holds
    /// them at the same poses (with the rate rows, when asked for), else computed —
    /// with the rate rows when `keep_rates` (a joint that has them in some assemblies:
    /// the next assembly at these poses may ask for them) — and kept there (`cache`
    /// grows to the joint count). Returns the rows and how many of them the assembly
    /// reads: `rows.n` with `rates`, else `rows.n_hard` (`rows_with(.., false)`'s rows
    /// are the same hard rows, without the rate rows a kept entry may hold after them).
    /// A reference rather than the rows by value: a copy of the ~640-byte rows was a
    /// `memcpy` per joint and assembly.
    #[allow(clippy::too_many_arguments)]
    fn rows<'c>(
        cache: &'c mut Vec<CachedRows>,
        coords: &mut Vec<Option<crate::joint::KeptCoords>>,
        j: usize,
        joint: &Joint,
        (a, b): (&Pose, &Pose),
        rates: bool,
        keep_rates: bool,
        epoch: u64,
    ) -> (&'c crate::joint::JointRows, usize) {
        // Seen in this pose epoch: the key is the poses' (not compared).
        let seen = cache
            .get(j)
            .is_some_and(|e| e.valid && e.seen == epoch && (e.rates || !rates));
        let hit = seen
            || cache.get(j).is_some_and(|e| {
                e.valid && same_key(&e.key, &Self::key_of(a, b)) && (e.rates || !rates)
            });
        if let Some(e) = cache.get_mut(j).filter(|_| hit) {
            e.seen = epoch;
        }
        if !hit {
            let key = Self::key_of(a, b);
            let with = rates || keep_rates;
            if cache.len() <= j {
                let rows = joint.rows_with(a, b, with);
                cache.resize(
                    j + 1,
                    CachedRows {
                        valid: false,
                        key: [0; 14],
                        rates: false,
                        seen: 0,
                        rows,
                    },
                );
            }
            // Written in place (the rows straight into the entry, not through a copy).
            let e = &mut cache[j];
            // A compound joint's rate rows through the coordinate cache
            // (`World::coords`): kept there, or taken from it.
            let kept = if with && matches!(joint.kind, JointKind::Compound(..)) {
                if coords.len() <= j {
                    coords.resize(j + 1, None);
                }
                Kept::Write(&key, &mut coords[j])
            } else {
                Kept::None
            };
            joint.rows_into_kept(a, b, with, kept, &mut e.rows);
            e.valid = true;
            e.key = key;
            e.rates = with;
            e.seen = epoch;
        }
        let rows = &cache[j].rows;
        (rows, if rates { rows.n } else { rows.n_hard })
    }

    /// `cache[j]`'s rows when it holds them with the rate rows at the poses `a`, `b`
    /// (their rate rows are [`Joint::rate_rows_only_kept`]'s; their hard rows, which a
    /// reader of the rate rows does not read, are the joint's Jacobian rather than
    /// zeros).
    fn kept_rates<'c>(
        cache: &'c [CachedRows],
        j: usize,
        a: &Pose,
        b: &Pose,
    ) -> Option<&'c crate::joint::JointRows> {
        cache
            .get(j)
            .filter(|e| e.valid && e.rates && same_key(&e.key, &Self::key_of(a, b)))
            .map(|e| &e.rows)
    }

    /// [`Self::kept_rates`] in pose epoch `epoch` (the poses those of the epoch's
    /// assembly): the entry when it was seen in the epoch (no key compared), else the
    /// key compared and the entry marked seen on a hit.
    fn kept_rates_in<'c>(
        cache: &'c mut [CachedRows],
        j: usize,
        a: &Pose,
        b: &Pose,
        epoch: u64,
    ) -> Option<&'c crate::joint::JointRows> {
        let e = cache.get_mut(j).filter(|e| e.valid && e.rates)?;
        if e.seen != epoch {
            if !same_key(&e.key, &Self::key_of(a, b)) {
                return None;
            }
            e.seen = epoch;
        }
        Some(&e.rows)
    }

    /// The entry's rows with their rate rows when it was seen in pose epoch `epoch`
    /// (no key compared: the caller is at the poses of the epoch's assembly).
    fn seen_rates(cache: &[CachedRows], j: usize, epoch: u64) -> Option<&crate::joint::JointRows> {
        cache
            .get(j)
            .filter(|e| e.valid && e.rates && e.seen == epoch)
            .map(|e| &e.rows)
    }

    /// Joint `j`'s rows with their rate rows at the bodies' current poses, for a
    /// reader of the rate rows only: the entry seen in pose epoch `epoch`
    /// ([`Self::seen_rates`], no key compared), else the entry whose key matches
    /// ([`Self::kept_rates`]), else [`Joint::rate_rows_only_kept`] computed into `fresh`.
    #[inline(always)]
    fn rates_at<'c>(
        cache: &'c [CachedRows],
        coords: &[Option<crate::joint::KeptCoords>],
        bodies: &[RigidBody],
        (j, joint): (usize, &Joint),
        epoch: u64,
        fresh: &'c mut Option<crate::joint::JointRows>,
    ) -> &'c crate::joint::JointRows {
        if let Some(seen) = Self::seen_rates(cache, j, epoch) {
            return seen;
        }
        let a = joint.parent.map_or(&Pose::IDENTITY, |i| &bodies[i].pose);
        let b = &bodies[joint.child].pose;
        match Self::kept_rates(cache, j, a, b) {
            Some(kept) => kept,
            None => {
                fresh.insert(joint.rate_rows_only_kept(a, b, actuator::kept_at(coords, j, a, b)))
            }
        }
    }
}

/// Which rate rows (one per degree of freedom) an assembly gives the joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Rates {
    /// None (acceleration level, projection).
    None,
    /// Armature only (the inertia of the coordinates; RATTLE's conservative kicks).
    Armature,
    /// Damping and armature (the velocity level, damping operators).
    Full,
}

/// How an assembly treats the hard rows of compliant joints (`α > 0`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Soft {
    /// Compliance `α/h²` on the rows: the implicit compliant form.
    Implicit,
    /// Rows decoupled (zero rows, `λ = 0`): the joint acts by its explicit spring force.
    Free,
}

/// How a step enforces the joints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Velocity level, `J v' = −β C(x₀)/h`, `0 < β ≤ 1` (`β = 1` is the lecture's).
    Velocity {
        /// Fraction of the position error corrected per step.
        beta: f64,
    },
    /// Velocity level followed by Newton position projection onto `C(x) = 0`.
    VelocityProjected {
        /// Fraction of the position error corrected by the velocity solve.
        beta: f64,
        /// Stop when every joint separation is `≤ tolerance` (m).
        tolerance: f64,
        /// Most Newton iterations per step.
        max_iterations: usize,
        /// Also add `δ/h` to the velocities (the correction becomes part of the motion,
        /// as in SHAKE) instead of moving positions only.
        correct_velocity: bool,
    },
    /// Acceleration level with Baumgarte stabilisation `C̈ + k_v Ċ + k_x C = 0`.
    Acceleration {
        /// Position gain `k_x` (1/s²), `≥ 0`.
        kx: f64,
        /// Velocity gain `k_v` (1/s), `≥ 0`.
        kv: f64,
    },
    /// RATTLE (Andersen 1983): kick–drift–kick with the position constraints solved at
    /// the end of the drift (SHAKE: Newton projection whose correction enters the
    /// half-step velocities) and the velocity constraints `J v = 0` at the end of the
    /// step. Rotations drift with the world angular momentum `L = I ω` held fixed and
    /// the implicit-midpoint angular velocity `ω* = I(q_{1/2})⁻¹ L`, so the step is
    /// time-symmetric and second order; joint damping is split off (Strang splitting,
    /// an L-stable damping flow over `h/2` on each side; `rattle.rs`), so damped joints
    /// stay second order.
    Rattle {
        /// Position tolerance of the SHAKE projection (m).
        tolerance: f64,
        /// Most Newton iterations of the projection.
        max_iterations: usize,
    },
    /// RATTLE composed by Yoshida's triple jump (steps `w₁h, w₀h, w₁h`,
    /// `w₁ = 1/(2 − 2^{1/3})`, `w₀ = 1 − 2w₁`): fourth order for undamped scenes.
    Rattle4 {
        /// Position tolerance of each SHAKE projection (m).
        tolerance: f64,
        /// Most Newton iterations of each projection.
        max_iterations: usize,
    },
}

impl Default for Method {
    /// `Rattle { tolerance: 1e-12, max_iterations: 30 }`: the best of the methods on
    /// trajectory error (second order: 1.2e-4 m against MuJoCo RK4 on the 20-link chain
    /// over 1 s at `h = 1e-3`, where the velocity level errs by 5.4e-3 m and MuJoCo's
    /// Euler by 0.16 m) and on energy (symplectic, no drift), with joints at the
    /// projection tolerance; where its projection does not converge it redoes the step
    /// at the velocity level ([`StepStats::fallbacks`]). The velocity level
    /// (`Velocity { beta: 1.0 }`) is about 5× cheaper per step. Steps with one-sided rows
    /// go to the velocity level (aimed at the end of the step,
    /// [`World::set_end_of_step_aim`]) and project to at most
    /// [`World::DEFAULT_UNILATERAL_TOLERANCE`]
    /// ([`World::set_unilateral_tolerance`]).
    fn default() -> Self {
        Method::Rattle {
            tolerance: 1e-12,
            max_iterations: 30,
        }
    }
}

/// Implicit treatment of the joints' geometric stiffness in the velocity-level step
/// (`World::add_geometric_stiffness`): the constraint force `−Jᵀλ/h` turns with the
/// bodies, and treating that explicitly makes the transverse modes of a tense chain
/// (a light link under a heavy load) blow up once `(hω)²` exceeds a few. Treating it
/// implicitly is stable at any step but adds first-order numerical damping: measured on
/// the MuJoCo scenes at `h = 1e-3`, `Always` raises the pendulum's error from 1.5e-3 to
/// 7.9e-3 m and chain20's from 5.4e-3 to 4e-2 m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GeometricStiffness {
    /// Never (the plain velocity level).
    Off,
    /// For every body.
    Always,
    /// Per body, only where the term's `(hω)²` against the body's smallest principal
    /// moment exceeds `ratio` — the bodies the explicit treatment would make unstable.
    Auto {
        /// Threshold on `h λ ∂²C / I_min`.
        ratio: f64,
    },
}

impl Default for GeometricStiffness {
    /// `Auto { ratio: 20.0 }`.
    fn default() -> Self {
        GeometricStiffness::Auto { ratio: 20.0 }
    }
}

/// What a step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Newton projection iterations used (0 without projection).
    pub projection_iterations: usize,
    /// RATTLE steps whose position projection did not converge (the explicit treatment
    /// of a stiff mode, e.g. a heavy-tip chain at a large step) and were redone with the
    /// velocity level (which has geometric stiffness).
    pub fallbacks: usize,
    /// Steps of a RATTLE or acceleration-level method taken instead at the velocity level
    /// (with projection for RATTLE) because one-sided rows (limits, contacts) were present:
    /// those methods are not defined across a complementarity event.
    pub unilateral_fallbacks: usize,
    /// Steps of the acceleration-level method taken instead at the velocity level
    /// because equality rows ([`World::add_equality`]) were present (its stages do not
    /// take the rows, `equality.rs`; RATTLE and RATTLE4 do).
    pub equality_fallbacks: usize,
}

/// Bodies, joints, gravity and the solver's reusable storage.
#[derive(Clone, Debug)]
pub struct World {
    bodies: Vec<RigidBody>,
    joints: Vec<Joint>,
    /// Gravity (m/s²).
    pub gravity: DVec3,
    steps: u64,
    solver: TreeSolver,
    /// The topology changed since `solver` was built.
    solver_stale: bool,
    rhs: Vec<f64>,
    mu: Vec<f64>,
    saved: Vec<RigidBody>,
    /// The joint impulses at the start of the step (restored with `saved`).
    saved_impulses: Vec<[f64; MAX_ROWS]>,
    /// Whether the velocity-level matrix gets the joints' geometric stiffness.
    pub geometric_stiffness: GeometricStiffness,
    /// Floor (m) on the projection tolerance of RATTLE steps taken at the velocity
    /// level because one-sided rows were present ([`Self::set_unilateral_tolerance`]).
    unilateral_tolerance: f64,
    /// Whether RATTLE's velocity-level fallback aims the joints at the end of the step
    /// ([`Self::set_end_of_step_aim`]).
    end_of_step_aim: bool,
    /// Hard-row impulses `λ` of the last velocity solve, per joint.
    impulses: Vec<[f64; MAX_ROWS]>,
    /// Per-body angular momenta (RATTLE scratch).
    momenta: Vec<DVec3>,
    /// The bodies' world inertias `R I Rᵀ` as the last [`Self::body_rhs_with`] computed
    /// them (valid while the bodies have not moved since).
    body_iw: Vec<DMat3>,
    /// RATTLE scratch: the first kick's joint impulses, the world inertias at the start of the
    /// drift, the armature rows' carried rates, and the damping flow's stage twists.
    rattle: rattle::Scratch,
    /// Acceleration-level scratch.
    accel: acceleration::Scratch,
    /// Position projection scratch (`projection.rs`).
    proj: projection::Scratch,
    /// The velocity level's end-of-step aim (`velocity.rs`, [`velocity::Aim`]): per
    /// joint the predicted `C(x + h v)`, per body the moved pose and the start twist.
    aim: velocity::AimScratch,
    /// Positional compliance `α ≥ 0` per joint (0: hard).
    compliance: Vec<f64>,
    /// Dry friction per joint and degree of freedom.
    frictionloss: Vec<[f64; constraint_core::compound::MAX_DOF]>,
    /// Armature (rotor inertia on the coordinate) per joint and degree of freedom.
    armature: Vec<[f64; constraint_core::compound::MAX_DOF]>,
    /// Actuators and their controls.
    actuators: Vec<Actuator>,
    ctrl: Vec<f64>,
    /// Joint springs.
    springs: Vec<DofSpring>,
    /// Tendons (fixed; spatial ones have a path in `paths` too).
    tendons: Vec<Tendon>,
    /// The spatial tendons' paths and the scratch of their forces.
    paths: spatial_tendon::Paths,
    /// Length limits per tendon (shorter than `tendons` when the last have none).
    tendon_ranges: Vec<Option<[f64; 2]>>,
    /// Equality rows over coordinates.
    equalities: Vec<Equality>,
    /// The equality rows of the current assembly and their complement (scratch).
    eq: equality::EqRows,
    /// Kept equality complements (`eq_cache.rs`).
    eq_cache: eq_cache::EqCache,
    /// The tendon-limit rows' segments, one range per tendon (scratch).
    tendon_spans: equality::Spans,
    /// The medium (fluid drag), if any.
    fluid: Option<Fluid>,
    /// Per body: principal axes (body frame) and drag factors of its inertia box.
    fluid_boxes: Vec<fluid::FluidBox>,
    /// Per body: the fluid's force and torque at the last evaluation (scratch).
    fluid_last: Vec<(DVec3, DVec3)>,
    /// Limits per joint and degree of freedom.
    limits: Vec<[Option<[f64; 2]>; constraint_core::compound::MAX_DOF]>,
    /// Settings of the one-sided rows (limits, contacts).
    pub unilateral: UnilateralSettings,
    /// What the one-sided rows did in the last step.
    ustats: UnilateralStats,
    /// One-sided rows of the current step (scratch kept across steps).
    urows: Vec<unilateral::URow>,
    /// Their impulses.
    uz: Vec<f64>,
    /// `Y = H⁻¹ Gᵀ`, column per row (scratch).
    ucols: Vec<f64>,
    /// The Delassus matrix `G Y` (scratch).
    udel: Vec<f64>,
    /// `q = G x_free − bias` (scratch).
    uq: Vec<f64>,
    /// Loop multipliers of the column solves (scratch).
    umu: Vec<f64>,
    /// Zero loop right-hand side (scratch).
    uzero: Vec<f64>,
    /// Per tree node: on a column's path to the root (scratch of
    /// [`crate::tree::TreeSolver::solve_sparse`]).
    umark: Vec<bool>,
    /// The path-wise Delassus build's index buffers (`unilateral/path_delassus.rs`).
    upaths: unilateral::PathDelassus,
    /// Buffers of the loop-closed tree solve (scratch,
    /// [`crate::tree::TreeSolver::solve_with_loops_in`]).
    loop_scratch: crate::tree::LoopScratch,
    /// The rows' bounds (scratch).
    ubounds: Vec<constraint_contact::lcp::RowBound>,
    /// The dense row solve's buffers (scratch, [`constraint_contact::lcp::RowBuffers`]).
    urowbuf: constraint_contact::lcp::RowBuffers,
    /// The active-set solve of the one-sided rows in the tree factor (scratch and the
    /// last step's statuses), boxed and taken out for each solve (`Option::take`: a
    /// pointer, where `mem::take` of the ~1.5 kB struct was a `memcpy`, a default
    /// struct and its drop, twice a step).
    aset: Option<alloc::boxed::Box<active_set::ActiveSet>>,
    /// Per joint, the generalized forces on its coordinates, and the coordinate table
    /// (scratch of the actuator, spring and tendon forces).
    dof_tau: Vec<[f64; MAX_DOF]>,
    /// Evaluations of the actuator, spring and tendon forces into `dof_tau` so far
    /// (`rattle::DofFlow`).
    dof_evals: u64,
    dof_table: Vec<Option<actuator::DofState>>,
    /// Per joint, its coordinates (and rate rows) at the poses they were last computed
    /// at ([`crate::joint::KeptCoords`], `actuator.rs`).
    coords: Vec<Option<crate::joint::KeptCoords>>,
    /// The loop rows of the last assembly.
    last_loops: LoopRows,
    /// Spare loop-row buffers (RATTLE keeps a second set; no allocation across steps).
    spare_loops: LoopRows,
    /// Per joint, its rows at the poses of its last assembly ([`CachedRows`]).
    rows_cache: Vec<CachedRows>,
    /// The pose epoch of the last assembly: a new one at every assembly, unless
    /// `rows_unmoved` says the poses are the last assembly's ([`CachedRows::seen`]).
    rows_epoch: u64,
    /// Set by a caller that knows the bodies have not moved since the last assembly
    /// (RATTLE's damping flow right after the second kick); taken by the next
    /// assembly, which then keeps the epoch.
    rows_unmoved: bool,
    /// `(steps, rows_epoch)` when the last RATTLE step ended with its damping flow:
    /// while both are unchanged (no step, no assembly since) and no state or parameter
    /// was written (`bodies_mut`, `set_compliance`, `set_armature`, `add_body`,
    /// `add_joint` clear it), the bodies are at the poses of that flow's assembly, its
    /// factor and kept rows and inertias (`rattle.rs`).
    flow_end: Option<(u64, u64)>,
    /// The factors kept for reuse by assemblies of the same matrix (`factor_cache.rs`).
    factors: factor_cache::FactorCache,
    /// Colliders (feature `contact`).
    #[cfg(feature = "contact")]
    colliders: Vec<constraint_contact::geometry::Collider>,
    #[cfg(feature = "contact")]
    filters: Vec<CollisionFilter>,
    /// Excluded body pairs, sorted (`usize::MAX`: the world).
    #[cfg(feature = "contact")]
    excluded: Vec<(usize, usize)>,
    #[cfg(feature = "contact")]
    contacts: Vec<constraint_contact::geometry::Contact>,
    /// Contact generation's buffers (bounding boxes, sweep order, pairs), kept between
    /// steps.
    #[cfg(feature = "contact")]
    broad: constraint_contact::geometry::BroadScratch,
    /// The collider pairs that may touch, built once (`contact.rs`).
    #[cfg(feature = "contact")]
    pair_filter: contact::PairFilter,
    /// Contact impulses of the last step by contact key, sorted (warm start).
    #[cfg(feature = "contact")]
    warm: Vec<WarmContact>,
    #[cfg(feature = "contact")]
    poses: Vec<Pose>,
    /// The contacts of the position projection and its scratch.
    #[cfg(feature = "contact")]
    projection: contact::Projection,
    /// Approach speed above which restitution applies (m/s; feature `contact`).
    #[cfg(feature = "contact")]
    pub restitution_threshold: f64,
}

/// What [`World::body_rhs_in`] does with the kept rotations and world inertias
/// (`factor_cache::KeptInertias`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum KeptInertia {
    /// Neither reads nor keeps them (the velocity level, the projection).
    No,
    /// Takes each body's where its bits are unchanged, computes and keeps the others.
    Use,
    /// Computes and keeps every body's (the bodies are known to have moved).
    Renew,
    /// Takes every body's kept entry without comparing its bits (the bodies are known
    /// not to have moved since the entries were kept), computes and keeps the others.
    Trust,
}

impl World {
    /// An empty world with the given gravity.
    pub fn new(gravity: DVec3) -> Self {
        Self {
            bodies: Vec::new(),
            joints: Vec::new(),
            gravity,
            steps: 0,
            solver: TreeSolver::new(0, &[]),
            solver_stale: true,
            rhs: Vec::new(),
            mu: Vec::new(),
            saved: Vec::new(),
            saved_impulses: Vec::new(),
            geometric_stiffness: GeometricStiffness::default(),
            unilateral_tolerance: Self::DEFAULT_UNILATERAL_TOLERANCE,
            end_of_step_aim: true,
            impulses: Vec::new(),
            momenta: Vec::new(),
            body_iw: Vec::new(),
            rattle: rattle::Scratch::default(),
            accel: acceleration::Scratch::default(),
            proj: projection::Scratch::default(),
            aim: velocity::AimScratch::default(),
            compliance: Vec::new(),
            limits: Vec::new(),
            frictionloss: Vec::new(),
            armature: Vec::new(),
            actuators: Vec::new(),
            ctrl: Vec::new(),
            springs: Vec::new(),
            tendons: Vec::new(),
            paths: spatial_tendon::Paths::default(),
            tendon_ranges: Vec::new(),
            equalities: Vec::new(),
            eq: equality::EqRows::default(),
            eq_cache: eq_cache::EqCache::default(),
            tendon_spans: equality::Spans::default(),
            fluid: None,
            fluid_boxes: Vec::new(),
            fluid_last: Vec::new(),
            unilateral: UnilateralSettings::default(),
            ustats: UnilateralStats::default(),
            urows: Vec::new(),
            uz: Vec::new(),
            ucols: Vec::new(),
            udel: Vec::new(),
            uq: Vec::new(),
            umu: Vec::new(),
            uzero: Vec::new(),
            umark: Vec::new(),
            upaths: unilateral::PathDelassus::default(),
            loop_scratch: crate::tree::LoopScratch::default(),
            ubounds: Vec::new(),
            urowbuf: Default::default(),
            aset: Some(alloc::boxed::Box::default()),
            dof_tau: Vec::new(),
            dof_evals: 0,
            dof_table: Vec::new(),
            coords: Vec::new(),
            last_loops: (Vec::new(), Vec::new(), Vec::new()),
            rows_cache: Vec::new(),
            rows_epoch: 0,
            rows_unmoved: false,
            flow_end: None,
            spare_loops: (Vec::new(), Vec::new(), Vec::new()),
            factors: factor_cache::FactorCache::default(),
            #[cfg(feature = "contact")]
            colliders: Vec::new(),
            #[cfg(feature = "contact")]
            filters: Vec::new(),
            #[cfg(feature = "contact")]
            excluded: Vec::new(),
            #[cfg(feature = "contact")]
            contacts: Vec::new(),
            #[cfg(feature = "contact")]
            broad: constraint_contact::geometry::BroadScratch::default(),
            #[cfg(feature = "contact")]
            pair_filter: contact::PairFilter::default(),
            #[cfg(feature = "contact")]
            warm: Vec::new(),
            #[cfg(feature = "contact")]
            poses: Vec::new(),
            #[cfg(feature = "contact")]
            projection: contact::Projection::default(),
            #[cfg(feature = "contact")]
            restitution_threshold: 0.5,
        }
    }

    /// Adds a body; returns its index. Its velocities must be finite.
    pub fn add_body(&mut self, body: RigidBody) -> Result<usize, ArticulatedError> {
        self.flow_end = None;
        let i = self.bodies.len();
        if !body.v.is_finite() || !body.omega.is_finite() {
            return Err(ArticulatedError::InvalidBody {
                body: i,
                reason: "velocity must be finite",
            });
        }
        // Re-validate (fields are public).
        let mut checked = RigidBody::new(i, body.mass(), body.inertia(), body.pose)?;
        checked.v = body.v;
        checked.omega = body.omega;
        checked.com = body.com;
        self.bodies.push(checked);
        self.solver_stale = true;
        Ok(i)
    }

    /// Adds a joint; returns its index. Errors: unknown body, a body joined to itself,
    /// negative or non-finite damping.
    pub fn add_joint(&mut self, joint: Joint) -> Result<usize, ArticulatedError> {
        self.flow_end = None;
        let j = self.joints.len();
        let bad = |reason| ArticulatedError::InvalidJoint { joint: j, reason };
        if joint.child >= self.bodies.len() || joint.parent.is_some_and(|p| p >= self.bodies.len())
        {
            return Err(bad("unknown body"));
        }
        if joint.parent == Some(joint.child) {
            return Err(bad("a joint needs two different bodies"));
        }
        if !(joint.damping >= 0.0) || !joint.damping.is_finite() {
            return Err(bad("damping must be finite and non-negative"));
        }
        if let JointKind::Compound(_, d) = &joint.kind {
            if d.iter().any(|v| !(*v >= 0.0) || !v.is_finite()) {
                return Err(bad("damping must be finite and non-negative"));
            }
        }
        self.joints.push(joint);
        self.compliance.push(0.0);
        self.limits.push([None; constraint_core::compound::MAX_DOF]);
        self.armature.push([0.0; MAX_DOF]);
        self.frictionloss.push([0.0; MAX_DOF]);
        self.solver_stale = true;
        Ok(j)
    }

    /// Default floor (m) on the projection tolerance of RATTLE steps taken at the
    /// velocity level because one-sided rows were present
    /// ([`Self::set_unilateral_tolerance`]): 1e-8 m, a hundred times under the model
    /// suite's 1e-6 m joint-separation check and far under the millimetres by which
    /// MuJoCo's soft contacts and limits give way. 1e-9 m in stop 33; from 1e-9 to
    /// 1e-8 `World::step` instructions on 2 s controlled runs: dm humanoid −8.3 %,
    /// hopper −3.5 %, pusher −4.1 %, walker −1.9 %, cheetahs −1.7 … −2.2 %. 1e-7 would
    /// save 1 … 4 % more, but humanoid_CMU's controlled run then stopped after 0.71 s
    /// (and at 3e-8 too) at a velocity-level complementarity problem that no solver
    /// answered. Set 1e-12 for the joints as tight as the other RATTLE steps.
    pub const DEFAULT_UNILATERAL_TOLERANCE: f64 = 1e-8;

    /// Sets the floor (m) on the position tolerance of the projection that follows a
    /// RATTLE or RATTLE4 step taken at the velocity level because one-sided rows
    /// (limits, contacts) were present ([`StepStats::unilateral_fallbacks`]): that
    /// projection stops at `max|C| ≤ max(tolerance, unilateral_tolerance)`, with
    /// `tolerance` the method's. The velocity level already leaves the joints within
    /// `O(h²)` of `C = 0`; projecting them to 1e-12 m costs a full Newton iteration and
    /// chord iterations on almost every step of a moving model in contact. Default
    /// [`Self::DEFAULT_UNILATERAL_TOLERANCE`]. Errors: `tolerance` not positive and finite.
    pub fn set_unilateral_tolerance(&mut self, tolerance: f64) -> Result<(), ArticulatedError> {
        if !(tolerance > 0.0) || !tolerance.is_finite() {
            return Err(ArticulatedError::InvalidParameter {
                name: "unilateral_tolerance",
                rule: "must be positive and finite",
            });
        }
        self.unilateral_tolerance = tolerance;
        Ok(())
    }

    /// Aims the hard joint rows of RATTLE's velocity-level fallback (the steps with
    /// limit or contact rows) at the end of the step, `J v' = J v − C(x + h v)/h`
    /// (on, the default), or at its start, `J v' = −C(x)/h` (off; the lecture's
    /// Opción 2, what the fallback did before stop 34). Aimed at the end, the step
    /// meets the joints to `O(h³)` instead of `O(h²)` and the projection after it has
    /// less to do: `World::step` instructions on 10 model runs of issue 13 −19 % in all
    /// (gymnasium humanoid passive 498M → 306M, dm humanoid passive 548M → 385M,
    /// manipulator controlled −20 %; pusher controlled +4.7 %, half_cheetah controlled
    /// +3.3 %), with a bounded energy error on an undamped chain where the start aim's
    /// grows (`tests/end_of_step_aim.rs`). The model suite passes every check either
    /// way (humanoid_CMU's controlled run stopped with it until its wrists' hinges,
    /// limited at −180°, were measured from the middle of their range: `mjcf.rs`).
    pub fn set_end_of_step_aim(&mut self, on: bool) {
        self.end_of_step_aim = on;
    }

    /// Whether RATTLE's velocity-level fallback aims at the end of the step
    /// ([`Self::set_end_of_step_aim`]).
    pub fn end_of_step_aim(&self) -> bool {
        self.end_of_step_aim
    }

    /// The floor on the projection tolerance of RATTLE's unilateral fallback steps
    /// ([`Self::set_unilateral_tolerance`]), in m.
    pub fn unilateral_tolerance(&self) -> f64 {
        self.unilateral_tolerance
    }

    /// Makes joint `joint` compliant: its hard rows obey `C(x) = −α λ_f` (a spring of
    /// stiffness `1/α` on each row; units m/N for position rows, rad/(N·m) for
    /// orientation rows) instead of `C(x) = 0`; `alpha = 0` makes it hard again. See the
    /// module documentation for how each [`Method`] treats it. Errors: unknown joint,
    /// negative or non-finite `alpha`.
    pub fn set_compliance(&mut self, joint: usize, alpha: f64) -> Result<(), ArticulatedError> {
        self.flow_end = None;
        let bad = |reason| ArticulatedError::InvalidJoint { joint, reason };
        let Some(slot) = self.compliance.get_mut(joint) else {
            return Err(bad("unknown joint"));
        };
        if !(alpha >= 0.0) || !alpha.is_finite() {
            return Err(bad("compliance must be finite and non-negative"));
        }
        *slot = alpha;
        Ok(())
    }

    /// The joints' compliances `α` (0: hard), in joint order.
    pub fn compliances(&self) -> &[f64] {
        &self.compliance
    }

    /// The bodies.
    pub fn bodies(&self) -> &[RigidBody] {
        &self.bodies
    }

    /// Mutable access to the bodies' state (masses are re-checked by nothing here:
    /// change them through [`RigidBody::new`]). It also drops SHAKE's predictor
    /// history (`world/rattle.rs`, `ShakeHistory`): the first RATTLE steps after a
    /// written state do not extrapolate from the steps before the write.
    pub fn bodies_mut(&mut self) -> &mut [RigidBody] {
        self.rattle.forget_history();
        self.flow_end = None;
        &mut self.bodies
    }

    /// The joints.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Steps taken so far.
    pub fn step_count(&self) -> u64 {
        self.steps
    }

    fn pose(&self, b: Option<usize>) -> Pose {
        b.map_or(Pose::IDENTITY, |i| self.bodies[i].pose)
    }

    /// Largest joint separation (m) at the current state (compliant joints included).
    pub fn max_separation(&self) -> f64 {
        self.joints
            .iter()
            .map(|j| j.separation(&self.pose(j.parent), &self.pose(Some(j.child))))
            .fold(0.0, f64::max)
    }

    /// Whether joint `j` is compliant (`α > 0`).
    fn is_soft(&self, j: usize) -> bool {
        self.compliance.get(j).is_some_and(|&a| a > 0.0)
    }

    /// Kinetic energy, and potential energy: gravitational plus the compliant joints'
    /// elastic `Σ C²/(2α)`: `(Σ ½mv² + ½ωᵀIω, −Σ m g·x + Σ C²/(2α))`.
    pub fn energy(&self) -> (f64, f64) {
        let kin =
            self.bodies.iter().map(|b| b.kinetic_energy()).sum::<f64>() + self.armature_energy();
        let gravity: f64 = self
            .bodies
            .iter()
            .map(|b| -b.mass() * self.gravity.dot(b.pose.x))
            .sum();
        let elastic: f64 = self
            .joints
            .iter()
            .zip(&self.compliance)
            .filter(|(_, &a)| a > 0.0)
            .map(|(j, &a)| {
                let c = j.value(&self.pose(j.parent), &self.pose(Some(j.child)));
                c[..j.hard_rows()].iter().map(|v| v * v).sum::<f64>() / (2.0 * a)
            })
            .sum();
        (kin, gravity + elastic + self.spring_energy())
    }

    /// The compliant joints' explicit spring forces `−(1/α) Jᵀ C` per body, `(force,
    /// torque)`; `None` when no joint is compliant.
    fn spring_forces(&self) -> Option<Vec<(DVec3, DVec3)>> {
        if !self.compliance.iter().any(|&a| a > 0.0) {
            return None;
        }
        let mut f = alloc::vec![(DVec3::ZERO, DVec3::ZERO); self.bodies.len()];
        for (joint, &alpha) in self.joints.iter().zip(&self.compliance) {
            if !(alpha > 0.0) {
                continue;
            }
            let rows = joint.rows(
                &self.pose(joint.parent),
                &self.pose(Some(joint.child)),
                false,
            );
            for r in 0..rows.n_hard {
                let s = -rows.value[r] / alpha;
                if let Some(p) = joint.parent {
                    f[p].0 += rows.rows[r][0] * s;
                    f[p].1 += rows.rows[r][1] * s;
                }
                f[joint.child].0 += rows.rows[r][2] * s;
                f[joint.child].1 += rows.rows[r][3] * s;
            }
        }
        Some(f)
    }

    /// Adds `scale ×` the compliant joints' spring forces to the bodies' right-hand side.
    fn add_spring_rhs(&mut self, scale: f64) {
        let Some(f) = self.spring_forces() else {
            return;
        };
        for (i, (force, torque)) in f.iter().enumerate() {
            let o = self.solver.body_offset(i);
            for c in 0..3 {
                self.rhs[o + c] += force[c] * scale;
                self.rhs[o + 3 + c] += torque[c] * scale;
            }
        }
    }

    /// Number of loop-closure joints (joints outside the spanning tree).
    pub fn loop_joints(&mut self) -> usize {
        self.ensure_solver();
        self.solver.loops.len()
    }

    fn topo(&self, with_damping: bool) -> Vec<JointTopo> {
        self.joints
            .iter()
            .enumerate()
            .map(|(ji, j)| JointTopo {
                a: j.parent,
                b: j.child,
                rows: j.hard_rows()
                    + if with_damping {
                        self.passive_rows_of(ji)
                    } else {
                        0
                    },
            })
            .collect()
    }

    /// Sets the armature `I_a ≥ 0` (rotor inertia, kg·m² or kg) of degree of freedom
    /// `dof` of `joint` (0 for a hinge or slide; 0…2 for a ball joint's relative
    /// rotation axes; a compound joint's coordinates in order): the kinetic energy
    /// `½ I_a q̇²` on the coordinate's rate, taken implicitly in the velocity-level
    /// methods and in RATTLE's kicks (see [`World::step`]); the acceleration level
    /// ignores it. Errors: unknown joint or degree of freedom, negative or non-finite
    /// value.
    pub fn set_armature(
        &mut self,
        joint: usize,
        dof: usize,
        armature: f64,
    ) -> Result<(), ArticulatedError> {
        self.flow_end = None;
        let bad = |reason| ArticulatedError::InvalidJoint { joint, reason };
        let Some(j) = self.joints.get(joint) else {
            return Err(bad("unknown joint"));
        };
        if dof >= j.rate_rows() {
            return Err(bad("the joint has no such degree of freedom"));
        }
        if !(armature >= 0.0) || !armature.is_finite() {
            return Err(bad("armature must be finite and non-negative"));
        }
        self.armature[joint][dof] = armature;
        self.solver_stale = true;
        Ok(())
    }

    /// Armature per joint and degree of freedom.
    pub fn armatures(&self) -> &[[f64; constraint_core::compound::MAX_DOF]] {
        &self.armature
    }

    /// Kinetic energy of the armatures, `Σ ½ I_a q̇²`.
    fn armature_energy(&self) -> f64 {
        let mut e = 0.0;
        for (ji, joint) in self.joints.iter().enumerate() {
            if !self.armature[ji].iter().any(|v| *v > 0.0) {
                continue;
            }
            let rows = joint.rows_with(
                &self.pose(joint.parent),
                &self.pose(Some(joint.child)),
                true,
            );
            let tw = self.twist(joint);
            for r in rows.n_hard..rows.n {
                let g = rows.rows[r];
                let rate: f64 = (0..4).map(|s| g[s].dot(tw[s])).sum();
                e += 0.5 * self.armature[ji][r - rows.n_hard] * rate * rate;
            }
        }
        e
    }

    /// Rate rows of joint `j` in the velocity-level system: one per degree of freedom
    /// when it is damped or has armature, else none.
    fn passive_rows_of(&self, ji: usize) -> usize {
        let j = &self.joints[ji];
        let armed = self
            .armature
            .get(ji)
            .is_some_and(|a| a.iter().any(|v| *v > 0.0));
        if j.damping_rows() > 0 || armed {
            j.rate_rows()
        } else {
            0
        }
    }

    fn ensure_solver(&mut self) {
        if self.solver_stale {
            self.solver = TreeSolver::new(self.bodies.len(), &self.topo(true));
            self.solver_stale = false;
            self.drop_factors();
        }
    }

    /// Advances the world by `h` seconds.
    ///
    /// On error (bad parameter, singular system, divergence) the state is left as it was
    /// before the call.
    pub fn step(&mut self, h: f64, method: Method) -> Result<StepStats, ArticulatedError> {
        let ctx = step_context(h)?;
        check_method(&method)?;
        self.ensure_solver();
        // Saved into buffers kept across steps: no allocation once the sizes are known.
        self.saved.clone_from(&self.bodies);
        self.saved_impulses.clone_from(&self.impulses);
        let result = self.step_inner(&ctx, method);
        match result {
            Ok(stats) => {
                if let Some(body) = self.first_bad_body() {
                    self.restore_start();
                    return Err(ArticulatedError::Diverged {
                        step: self.steps + 1,
                        body,
                    });
                }
                self.steps += 1;
                Ok(stats)
            }
            Err(e) => {
                self.restore_start();
                Err(e)
            }
        }
    }

    /// The one-sided rows of this step, at its start: joint limits, then contacts.
    fn collect_unilateral_rows(&mut self, ctx: &StepContext) -> Result<(), ArticulatedError> {
        self.urows.clear();
        self.ustats = UnilateralStats::default();
        self.keep_limit_coordinates();
        self.push_limit_rows(ctx);
        self.push_tendon_limit_rows(ctx);
        #[cfg(feature = "contact")]
        self.push_contact_rows(ctx)?;
        Ok(())
    }

    /// Puts the bodies and joint impulses back as they were at the start of the step.
    fn restore_start(&mut self) {
        self.bodies.clone_from(&self.saved);
        self.impulses.clone_from(&self.saved_impulses);
    }

    fn first_bad_body(&self) -> Option<usize> {
        let ok = constraint_core::math::within_limit;
        self.bodies
            .iter()
            .position(|b| !ok(b.pose.x) || !ok(b.v) || !ok(b.omega) || !b.pose.q.is_finite())
    }

    fn step_inner(
        &mut self,
        ctx: &StepContext,
        method: Method,
    ) -> Result<StepStats, ArticulatedError> {
        let h = ctx.h();
        let mut stats = StepStats::default();
        self.collect_unilateral_rows(ctx)?;
        let equalities = !self.equalities.is_empty();
        let acceleration = matches!(method, Method::Acceleration { .. });
        if !self.urows.is_empty() || (equalities && acceleration) {
            // RATTLE and the acceleration level are not defined across a complementarity
            // event: the step goes to the velocity level (projected for RATTLE).
            match method {
                Method::Rattle {
                    tolerance,
                    max_iterations,
                }
                | Method::Rattle4 {
                    tolerance,
                    max_iterations,
                } => {
                    stats.unilateral_fallbacks = 1;
                    // Aimed at the end of the step where asked
                    // (`velocity::Aim::EndOfStep`): the projection below then starts
                    // O(h³) from the joints, not O(h²).
                    let aim = if self.end_of_step_aim {
                        velocity::Aim::EndOfStep
                    } else {
                        velocity::Aim::Start(1.0)
                    };
                    self.velocity_solve_aimed(ctx, aim)?;
                    // The looser of the method's tolerance and the unilateral floor.
                    let tolerance = tolerance.max(self.unilateral_tolerance);
                    stats.projection_iterations = self.project(tolerance, max_iterations, None)?;
                    return Ok(stats);
                }
                Method::Acceleration { .. } => {
                    stats.unilateral_fallbacks = usize::from(!self.urows.is_empty());
                    stats.equality_fallbacks = usize::from(equalities);
                    self.velocity_solve(ctx, 1.0)?;
                    return Ok(stats);
                }
                _ => {}
            }
        }
        match method {
            Method::Velocity { beta } => self.velocity_solve(ctx, beta)?,
            Method::VelocityProjected {
                beta,
                tolerance,
                max_iterations,
                correct_velocity,
            } => {
                self.velocity_solve(ctx, beta)?;
                stats.projection_iterations =
                    self.project(tolerance, max_iterations, correct_velocity.then_some(ctx))?;
            }
            Method::Acceleration { kx, kv } => self.acceleration_solve(ctx, kx, kv)?,
            Method::Rattle {
                tolerance,
                max_iterations,
            } => {
                // The bodies are the start of the step saved above (nothing between
                // moves them): `rattle_step` need not compare them with it.
                let (it, ok) = self.rattle_step(h, tolerance, max_iterations, true)?;
                stats.projection_iterations = it;
                if !ok {
                    self.fall_back(ctx, tolerance, max_iterations, &mut stats)?;
                }
            }
            Method::Rattle4 {
                tolerance,
                max_iterations,
            } => {
                let w1 = 1.0 / (2.0 - libm::cbrt(2.0));
                let w0 = 1.0 - 2.0 * w1;
                // Damping stays outside the triple jump (rattle.rs):
                // D_{h/2} ∘ C_{w₁h} ∘ C_{w₀h} ∘ C_{w₁h} ∘ D_{h/2}.
                let damped = self.joints.iter().any(|j| j.damping_rows() > 0);
                if damped {
                    self.damp(ctx.half_h(), false, false, false)?;
                }
                let mut fell_back = false;
                for (i, w) in [w1, w0, w1].into_iter().enumerate() {
                    let (it, ok) = if damped {
                        self.conservative_step(w * h, tolerance, max_iterations, true, false)?
                    } else {
                        // The first sub-step starts from the saved start of the step.
                        self.rattle_step(w * h, tolerance, max_iterations, i == 0)?
                    };
                    stats.projection_iterations += it;
                    if !ok {
                        self.fall_back(ctx, tolerance, max_iterations, &mut stats)?;
                        fell_back = true;
                        break;
                    }
                }
                if damped && !fell_back {
                    self.damp(ctx.half_h(), false, false, false)?;
                }
            }
        }
        Ok(stats)
    }

    /// Loads the mass blocks and the joint rows into the solver; `rhs_joint(j, rows)`
    /// writes the joint's right-hand side and returns nothing. Returns the loop rows.
    /// `h` is the length of the implicit terms (damping `h d`, compliance `α/h²`): the
    /// step's `h` at the velocity and acceleration levels, `|h|/2` in RATTLE's kicks,
    /// the damping flow's `τ`, `1` in the projection — not always the step context's.
    fn assemble(
        &mut self,
        h: f64,
        rates: Rates,
        soft: Soft,
        mut joint_rhs: impl FnMut(usize, &Joint, &crate::joint::JointRows, &mut [f64]),
    ) -> LoopRows {
        self.assemble_with(h, rates, soft, true, Some(&mut joint_rhs))
    }

    /// The loop rows' buffers of the last assembly (or RATTLE's spare), emptied for
    /// reuse: no allocation once they have grown.
    fn take_loop_buffers(&mut self) -> LoopRows {
        let (mut rows, mut c, mut r) = core::mem::take(&mut self.last_loops);
        if rows.capacity() == 0 {
            (rows, c, r) = core::mem::take(&mut self.spare_loops);
        }
        rows.clear();
        c.clear();
        r.clear();
        (rows, c, r)
    }

    /// [`Self::assemble`] with `matrix` false for an assembly whose factor the solver
    /// already holds ([`Self::reuse_factor`]): the right-hand side and the loop rows
    /// only. Without `joint_rhs` (hard rows' right-hand side zero) a tree joint without
    /// armature rows then writes nothing (its right-hand side stays the zeros
    /// [`Self::body_rhs_with`] left), so its rows are not computed.
    fn assemble_with(
        &mut self,
        h: f64,
        rates: Rates,
        soft: Soft,
        matrix: bool,
        mut joint_rhs: Option<&mut JointRhs<'_>>,
    ) -> LoopRows {
        if matrix {
            self.factors.forget_current();
        }
        // Equality rows take part only in the solves of assemblies that load them.
        self.eq.active = false;
        // A new pose epoch unless the caller knows the poses are the last assembly's.
        if !core::mem::take(&mut self.rows_unmoved) {
            self.rows_epoch = self.rows_epoch.wrapping_add(1);
        }
        let epoch = self.rows_epoch;
        let (mut loop_rows, mut loop_c, mut loop_rhs) = self.take_loop_buffers();
        let solver = &mut self.solver;
        for (j, joint) in self.joints.iter().enumerate() {
            let armed = self.armature[j].iter().any(|v| *v > 0.0);
            let passive = if joint.damping_rows() > 0 || armed {
                joint.rate_rows()
            } else {
                0
            };
            let with_rates = match rates {
                Rates::None => false,
                Rates::Armature => armed,
                Rates::Full => passive > 0,
            };
            let tree = solver.joint_offset(j);
            // Only the rate rows' right-hand side to write (armature): the hard rows
            // stay zero, their Jacobian is not needed.
            let rates_only = !matrix && joint_rhs.is_none() && tree.is_some();
            if rates_only && !(with_rates && armed) {
                continue;
            }
            if let (true, Some(o)) = (rates_only, tree) {
                // The rate rows' right-hand side alone, `I_a/(I_a + h d) · G v` (the
                // operations of the general path below, without the compliances and
                // zero flags, which only a matrix reads); the other rows zero.
                let a = joint
                    .parent
                    .map_or(&Pose::IDENTITY, |i| &self.bodies[i].pose);
                let b = &self.bodies[joint.child].pose;
                let fresh;
                let rows = match CachedRows::kept_rates_in(&mut self.rows_cache, j, a, b, epoch) {
                    Some(kept) => kept,
                    None => {
                        fresh = joint.rate_rows_only_kept(
                            a,
                            b,
                            actuator::kept_at(&self.coords, j, a, b),
                        );
                        &fresh
                    }
                };
                let mut rhs = [0.0; MAX_ROWS];
                for r in rows.n_hard..rows.n {
                    let (arm, s) =
                        rate_row_scales(joint, &self.armature[j], r - rows.n_hard, rates, h);
                    if s > 0.0 && arm > 0.0 {
                        rhs[r] += arm / s * joint_rate(&self.bodies, joint, &rows.rows[r]);
                    }
                }
                let n_topo = joint.hard_rows() + passive;
                self.rhs[o..o + n_topo].copy_from_slice(&rhs[..n_topo]);
                continue;
            }
            let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
            let b = self.bodies[joint.child].pose;
            // The rows by reference (kept, or computed) and how many the assembly
            // reads; rows it zeroes are flagged in `zero` (bit `r`: row `r` taken as
            // zero) rather than written into a copy.
            let (rows, n) = {
                CachedRows::rows(
                    &mut self.rows_cache,
                    &mut self.coords,
                    j,
                    joint,
                    (&a, &b),
                    with_rates,
                    // Kept with the rate rows for a later assembly at these poses;
                    // not from a `Rates::None` one (the projection's Newton steps,
                    // the acceleration level): its iterates' poses are not assembled
                    // again with rates (humanoid_CMU passive: 3,510 `Compound::dof_rows`
                    // calls, 1.5 % of the step, never read).
                    passive > 0 && rates != Rates::None,
                    epoch,
                )
            };
            let mut zero = 0u8;
            let mut comp = [0.0; MAX_ROWS];
            // Rate rows: damping d and armature I_a on the coordinate rate q̇ = G v,
            // `(M + (I_a + h d) GᵀG) v' = M v + h f + I_a GᵀG v`: the row
            // `G v' − λ/(I_a + h d) = I_a/(I_a + h d) · G v` (implicit, so a large
            // armature or damping is stable).
            let mut rate_rhs = [0.0; MAX_ROWS];
            for r in rows.n_hard..n {
                let (arm, s) = rate_row_scales(joint, &self.armature[j], r - rows.n_hard, rates, h);
                if s > 0.0 {
                    comp[r] = 1.0 / s;
                    if arm > 0.0 {
                        rate_rhs[r] = arm / s * joint_rate(&self.bodies, joint, &rows.rows[r]);
                    }
                } else {
                    // An undamped, armature-free dof of a joint whose other dofs have some.
                    zero |= 1 << r;
                    comp[r] = 1.0;
                }
            }
            // In the topology every joint has its rate rows; without damping they get
            // infinite compliance, i.e. a decoupled row with λ = 0.
            let n_topo = joint.hard_rows() + passive;
            for r in n..n_topo {
                comp[r] = 1.0;
            }
            let mut rhs = [0.0; MAX_ROWS];
            if let Some(f) = joint_rhs.as_mut() {
                f(j, joint, rows, &mut rhs[..n]);
            }
            for r in rows.n_hard..n {
                rhs[r] += rate_rhs[r];
            }
            let alpha = self.compliance.get(j).copied().unwrap_or(0.0);
            if alpha > 0.0 {
                for r in 0..rows.n_hard {
                    match soft {
                        Soft::Implicit => comp[r] = alpha / (h * h),
                        Soft::Free => {
                            zero |= 1 << r;
                            comp[r] = 1.0;
                            rhs[r] = 0.0;
                        }
                    }
                }
            }
            let topo = JointTopo {
                a: joint.parent,
                b: joint.child,
                rows: n_topo,
            };
            match tree {
                Some(o) => {
                    if matrix {
                        solver.set_joint(j, &topo, &rows.rows[..n], zero, &comp[..n_topo]);
                    }
                    self.rhs[o..o + n_topo].copy_from_slice(&rhs[..n_topo]);
                }
                None => {
                    for r in 0..n {
                        let row = if zero & (1 << r) != 0 {
                            [DVec3::ZERO; 4]
                        } else {
                            rows.rows[r]
                        };
                        loop_rows.push((joint.parent, joint.child, row));
                        loop_c.push(comp[r]);
                        loop_rhs.push(rhs[r]);
                    }
                }
            }
        }
        (loop_rows, loop_c, loop_rhs)
    }

    /// Writes the armature rows' right-hand side `I_a/(I_a + s d) · G v` for the body
    /// twists `twists` into the tree rows (after a `Rates::Full` assembly at `s`), for a
    /// second solve with the same factor (loop joints' armature is not supported there).
    ///
    /// The bodies are at the poses of the last assembly: the rows that assembly saw are
    /// taken without comparing their keys ([`CachedRows::seen`]).
    pub(super) fn armature_rhs(&mut self, s: f64, twists: &[(DVec3, DVec3)]) {
        for (j, joint) in self.joints.iter().enumerate() {
            if !self.armature[j].iter().any(|v| *v > 0.0) {
                continue;
            }
            let Some(o) = self.solver.joint_offset(j) else {
                continue;
            };
            let mut fresh = None;
            let rows = CachedRows::rates_at(
                &self.rows_cache,
                &self.coords,
                &self.bodies,
                (j, joint),
                self.rows_epoch,
                &mut fresh,
            );
            let tw = |i: Option<usize>| i.map_or((DVec3::ZERO, DVec3::ZERO), |i| twists[i]);
            let ((va, wa), (vb, wb)) = (tw(joint.parent), tw(Some(joint.child)));
            for r in rows.n_hard..rows.n {
                let k = r - rows.n_hard;
                let arm = self.armature[j][k];
                let tot = arm + s * joint.dof_damping(k);
                if arm > 0.0 && tot > 0.0 {
                    let g = rows.rows[r];
                    let rate = g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb);
                    self.rhs[o + r] = arm / tot * rate;
                }
            }
        }
    }

    /// Keeps `loops`' buffers for a later assembly.
    pub(super) fn recycle_loops(&mut self, loops: LoopRows) {
        if self.last_loops.0.capacity() == 0 {
            self.last_loops = loops;
        } else {
            self.spare_loops = loops;
        }
    }

    fn solve(&mut self, loops: LoopRows) -> Result<(), ArticulatedError> {
        let solver = &mut self.solver;
        solver.factor()?;
        let out = self.solve_factored(&loops);
        self.last_loops = loops;
        out
    }

    /// [`Self::solve`] for an assembly looked up by [`Self::reuse_factor`]: with the
    /// solver's factor when `reused`, else factoring and keeping the factor for reuse.
    fn solve_reusing(&mut self, loops: LoopRows, reused: bool) -> Result<(), ArticulatedError> {
        if !reused {
            self.solver.factor()?;
            self.keep_factor();
        }
        let out = self.solve_factored(&loops);
        self.last_loops = loops;
        out
    }

    /// Solves with the factor already in the solver (loop rows as assembled with it).
    fn solve_factored(&mut self, loops: &LoopRows) -> Result<(), ArticulatedError> {
        let free_scale = self.loop_free_scale(loops);
        let solver = &mut self.solver;
        let (rows, c, r) = loops;
        let scratch = &mut self.loop_scratch;
        solver.solve_with_loops_in(
            &mut self.rhs,
            (rows, c, r),
            free_scale,
            &mut self.mu,
            scratch,
        )?;
        if self.eq.active {
            self.solve_equalities(loops)?;
        }
        Ok(())
    }

    /// [`Self::solve_factored`] for a right-hand side whose bodies' entries are all
    /// `+0.0` (SHAKE's corrections, `rattle.rs`): without loop rows and equality rows
    /// the tree solve skips the forward pass of the childless bodies
    /// ([`crate::tree::TreeSolver::solve_zero_bodies`]), the same bits.
    pub(super) fn solve_factored_zero_bodies(
        &mut self,
        loops: &LoopRows,
    ) -> Result<(), ArticulatedError> {
        if !loops.0.is_empty() || self.eq.active {
            return self.solve_factored(loops);
        }
        self.solver.solve_zero_bodies(&mut self.rhs);
        // As `solve_with_loops_in` without loop rows.
        self.mu.clear();
        Ok(())
    }

    /// Loads every body's mass block `diag(m) ⊕ R I Rᵀ` into the solver and its
    /// right-hand side `f(body, R, I_world)`.
    fn body_rhs(&mut self, f: impl Fn(&RigidBody, &DMat3, &DMat3) -> (DVec3, DVec3)) {
        self.body_rhs_with(true, f);
    }

    /// [`Self::body_rhs`]; without `matrix` the mass blocks are left as they are (the
    /// solver holds the factor, [`Self::reuse_factor`]). With it the solver's factor is
    /// overwritten, so it is no longer known.
    fn body_rhs_with(
        &mut self,
        matrix: bool,
        f: impl Fn(&RigidBody, &DMat3, &DMat3) -> (DVec3, DVec3),
    ) {
        self.body_rhs_in(matrix, KeptInertia::No, f);
    }

    /// [`Self::body_rhs_with`] for RATTLE's assemblies, which repeat at one
    /// configuration: the bodies' rotations and world inertias are kept with their
    /// bits (`factor_cache::KeptInertias`) and taken from there where the bits are
    /// unchanged — where the factor is reused, and where a new one is written at the
    /// poses of an earlier assembly (the damping flow after the second kick: dm fish
    /// controlled, 2 505 recomputations of 243 instructions each in 2 s). The other
    /// assemblies (velocity level, projection) rarely repeat a configuration and do
    /// not keep them (keeping cost dm hopper passive 0.4 %).
    ///
    /// `moved`: the caller knows that the bodies have moved since the last assembly
    /// that kept them (RATTLE's second kick, after the drift), so the kept entries are
    /// not compared (13 words a body) and the rotations are computed and kept afresh.
    pub(super) fn body_rhs_kept(
        &mut self,
        matrix: bool,
        moved: bool,
        f: impl Fn(&RigidBody, &DMat3, &DMat3) -> (DVec3, DVec3),
    ) {
        self.body_rhs_in(
            matrix,
            if moved {
                KeptInertia::Renew
            } else {
                KeptInertia::Use
            },
            f,
        );
    }

    /// [`Self::body_rhs_kept`] where the caller knows that the bodies have not moved
    /// since the kept rotations were last kept or taken (RATTLE's damping flow right
    /// after the second kick, or at the end of the last step): the kept entries are
    /// taken without comparing their bits.
    pub(super) fn body_rhs_unmoved(
        &mut self,
        matrix: bool,
        f: impl Fn(&RigidBody, &DMat3, &DMat3) -> (DVec3, DVec3),
    ) {
        self.body_rhs_in(matrix, KeptInertia::Trust, f);
    }

    #[inline(always)]
    fn body_rhs_in(
        &mut self,
        matrix: bool,
        kept_use: KeptInertia,
        f: impl Fn(&RigidBody, &DMat3, &DMat3) -> (DVec3, DVec3),
    ) {
        let keep = kept_use != KeptInertia::No;
        if matrix {
            self.factors.forget_current();
        }
        let size = self.solver.size;
        self.rhs.clear();
        self.rhs.resize(size, 0.0);
        // Each kept entry stays beside the world inertia computed from its bits.
        let kept = &mut self.factors.inertias;
        kept.truncate(if keep {
            self.body_iw.len().min(self.bodies.len())
        } else {
            0
        });
        self.body_iw.truncate(self.bodies.len());
        let solver = &mut self.solver;
        for (i, b) in self.bodies.iter().enumerate() {
            let o = solver.body_offset(i);
            // Also when the matrix is written: RATTLE's damping flow factors at the
            // poses its second kick just assembled (a new factor, the same inertias).
            // The compare out of line where a matrix is written (inlined there too, the
            // hit path of the reused factor's assembly compiled to scalar compares, 26
            // instructions a body more on swimmer6).
            let hit = match kept_use {
                KeptInertia::Use if !matrix => kept.rotation(i, b),
                KeptInertia::Use => kept.rotation_out_of_line(i, b),
                KeptInertia::Trust => kept.rotation_kept(i),
                _ => None,
            };
            let (r, iw) = match hit {
                Some(r) => (r, self.body_iw[i]),
                None => {
                    let r = b.rotation();
                    let iw = r * b.inertia() * r.transpose();
                    if keep {
                        kept.keep(i, b, r);
                    }
                    if i < self.body_iw.len() {
                        self.body_iw[i] = iw;
                    } else {
                        self.body_iw.push(iw);
                    }
                    (r, iw)
                }
            };
            if matrix {
                solver.set_body(i, b.mass(), &iw);
            }
            let (lin, ang) = f(b, &r, &iw);
            self.rhs[o..o + 3].copy_from_slice(&lin.to_array());
            self.rhs[o + 3..o + 6].copy_from_slice(&ang.to_array());
        }
    }

    fn body_solution(&self, i: usize) -> (DVec3, DVec3) {
        let o = self.solver.body_offset(i);
        let x = &self.rhs;
        (
            DVec3::new(x[o], x[o + 1], x[o + 2]),
            DVec3::new(x[o + 3], x[o + 4], x[o + 5]),
        )
    }

    /// The constraint-force multipliers of the last solve for loop joints (for tests).
    pub fn loop_multipliers(&self) -> &[f64] {
        &self.mu
    }

    /// Kind name of joint `j` (for reports).
    pub fn joint_kind_name(&self, j: usize) -> &'static str {
        match self.joints.get(j).map(|j| &j.kind) {
            Some(JointKind::Spherical(_)) => "spherical",
            Some(JointKind::Hinge(_)) => "hinge",
            Some(JointKind::Prismatic(_)) => "prismatic",
            Some(JointKind::Fixed(_)) => "fixed",
            Some(JointKind::Distance(_)) => "distance",
            Some(JointKind::Compound(..)) => "compound",
            None => "none",
        }
    }
}

/// The step context of `h` ([`StepContext::new`], the one check of the time step);
/// a rejected `h` is [`ArticulatedError::InvalidParameter`] named `"h"` with the
/// [`StepError`](constraint_core::StepError)'s rule.
fn step_context(h: f64) -> Result<StepContext, ArticulatedError> {
    StepContext::new(h).map_err(|e| ArticulatedError::InvalidParameter {
        name: "h",
        rule: e.rule(),
    })
}

fn check_method(m: &Method) -> Result<(), ArticulatedError> {
    let bad = |name, rule| Err(ArticulatedError::InvalidParameter { name, rule });
    match *m {
        Method::Velocity { beta } | Method::VelocityProjected { beta, .. }
            if !(0.0..=1.0).contains(&beta) =>
        {
            bad("beta", "must be in [0, 1]")
        }
        Method::VelocityProjected { tolerance, .. }
            if !(tolerance > 0.0) || !tolerance.is_finite() =>
        {
            bad("tolerance", "must be positive and finite")
        }
        Method::Acceleration { kx, kv }
            if !(kx >= 0.0) || !(kv >= 0.0) || !kx.is_finite() || !kv.is_finite() =>
        {
            bad("kx/kv", "Baumgarte gains must be finite and non-negative")
        }
        Method::Rattle { tolerance, .. } | Method::Rattle4 { tolerance, .. }
            if !(tolerance > 0.0) || !tolerance.is_finite() =>
        {
            bad("tolerance", "must be positive and finite")
        }
        _ => Ok(()),
    }
}

/// The armature `I_a` and the scale `I_a + h d` of rate row `k` of `joint` (damping
/// `d` only with [`Rates::Full`]): the row `G v' − λ/(I_a + h d) = I_a/(I_a + h d) · G v`
/// of [`World::assemble_with`].
#[inline(always)]
fn rate_row_scales(
    joint: &Joint,
    armature: &[f64; MAX_DOF],
    k: usize,
    rates: Rates,
    h: f64,
) -> (f64, f64) {
    let d = if rates == Rates::Full {
        joint.dof_damping(k)
    } else {
        0.0
    };
    let arm = armature[k];
    (arm, arm + h * d)
}

/// The rate `G v` of one rate row `g` of `joint` at the bodies' current twists.
#[inline(always)]
fn joint_rate(bodies: &[RigidBody], joint: &Joint, g: &[DVec3; 4]) -> f64 {
    let tw = |i: Option<usize>| {
        i.map_or((DVec3::ZERO, DVec3::ZERO), |i| {
            (bodies[i].v, bodies[i].omega)
        })
    };
    let ((va, wa), (vb, wb)) = (tw(joint.parent), tw(Some(joint.child)));
    g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb)
}
