//! Rigid bodies in contact: the lecture's velocity-level contact LCP (Otaduy 2010,
//! "Contacto mediante restricciones"):
//!
//! ```text
//! M v' = M v + h f + Jᵀ z,    w = J v' − b ≥ 0,    z ≥ 0,    zᵀ w = 0
//! ```
//!
//! one normal row per contact point (`J_n v` is the rate of the gap `d = nᵀ(p_b − p_a)`,
//! `z_n = λ` its impulse) and two tangent rows with Coulomb's pyramidal bounds
//! `|z_t| ≤ μ z_n`. Eliminating `v'` gives the LCP `w = A z + q` with the Delassus
//! matrix `A = J M⁻¹ Jᵀ` and `q = J v_free − b`.
//!
//! Solvers ([`ContactSolver`]):
//! * `SequentialImpulses`: projected Gauss–Seidel on `A` without forming it (each row's
//!   impulse goes straight into the two bodies' velocities; Catto 2005, Erleben 2007),
//!   warm-started from the previous step's impulses matched by contact id;
//! * `SoftStep`: Box2D v3's soft step (Catto 2024): sub-steps, each with one soft
//!   Gauss–Seidel pass and one rigid relax pass (the `soft_step` module's docs);
//! * `Pgs`, `Lemke`, `Newton`: the dense LCP of [`crate::lcp`] on the assembled `A`.
//!   Lemke and the Fischer–Burmeister Newton method take standard LCPs only, so friction
//!   goes by Kaufman et al.'s staggered projections (2008): a normal LCP with the
//!   friction impulses fixed, then the boxed friction problem with the normal impulses
//!   fixed, alternated ([`FrictionModel::Staggered`]); PGS can also solve the boxed
//!   problem in one go ([`FrictionModel::Boxed`]).
//!
//! Position error is corrected at velocity level (Baumgarte): a penetration deeper than
//! `slop` asks for a separating velocity `β (depth − slop)/h`; a speculative contact
//! (separated by less than `margin`) allows approach at `gap/h`, so bodies stop at the
//! surface instead of tunnelling in. Restitution `e` asks for `−e v_n` when the
//! approach speed exceeds a threshold. Shock propagation (Erleben 2007) can add final
//! Gauss–Seidel sweeps bottom-up with each lower body frozen, so a stack's weight does
//! not have to travel through many iterations.

use alloc::vec;
use alloc::vec::Vec;
use core::fmt;

use constraint_core::rigid::rotate_by;
use constraint_core::{BodyError, DMat3, DVec3, Pose, RigidBody, StepContext};

use crate::geometry::{BroadScratch, Collider, Contact, GeometryError};
mod colouring;
mod dense;
mod path;
mod sequential;
mod sleep;
mod soft_lanes;
#[cfg(feature = "parallel")]
mod soft_parallel;
mod soft_step;

pub use path::{RowsSolver, SolverPath};
pub use sleep::SleepSettings;
pub use soft_step::{
    SoftStepSettings, Softness, BLOCK_POINTS, MAX_RELAX_PASSES, MAX_SUBSTEPS, MAX_THREADS,
    PARALLEL_MIN_POINTS, PRELOAD_CAP_MARGIN, PRELOAD_FLOOR_DECAY,
};

use crate::lcp::{Coupling, LcpError, RowBound, RowMethod, RowSettings, SparseRows};

/// Which solver handles the contact LCP.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactSolver {
    /// `Newton` (staggered friction) while the scene has at most
    /// [`AUTO_DENSE_CONTACTS`] contact points (where every contact point has a static
    /// side, the sequential impulses first, kept when their answer solves the LCP to
    /// [`ContactSettings::tolerance`]: bodies that touch only static geometry); beyond,
    /// the soft step with
    /// [`AUTO_SUBSTEPS`] sub-steps (the fast path; its settings in
    /// [`ContactSettings::soft_step`], checked on every `Auto` step). The warm-start
    /// impulses carry over when a scene crosses the threshold either way.
    Auto,
    /// Matrix-free projected Gauss–Seidel (sequential impulses).
    SequentialImpulses,
    /// Projected Gauss–Seidel on the assembled Delassus matrix.
    Pgs,
    /// Lemke's pivoting on the assembled matrix (friction by staggered projections).
    Lemke,
    /// Fischer–Burmeister Newton on the assembled matrix (friction staggered).
    Newton,
    /// Box2D v3's soft step with `substeps` sub-steps per step (one soft Gauss–Seidel
    /// pass and one rigid relax pass each); stiffness and damping in
    /// [`ContactSettings::soft_step`]. The compliant form `[M Jᵀ; J −α/h²]` of the lecture
    /// applied row by row. Uses `margin`, `warm_start` and `restitution_threshold`;
    /// `iterations`, `baumgarte`, `slop`, `shock_propagation`, `split_impulse`,
    /// `friction` and `tolerance` are for the other solvers.
    SoftStep {
        /// Sub-steps per step (at least 1; 4 is Box2D's default).
        substeps: usize,
    },
}

/// Largest number of contact points [`ContactSolver::Auto`] solves densely (the
/// Delassus matrix has `9 n²` entries).
pub const AUTO_DENSE_CONTACTS: usize = 200;

/// Sub-steps of the soft step [`ContactSolver::Auto`] runs beyond
/// [`AUTO_DENSE_CONTACTS`] points: 3 (Box2D v3 uses 4). On the 210-box pyramid (840
/// points), 10 s at 60 Hz: worst box displacement 0.69 mm at 3 (0.55 mm at 4) for
/// 7.65M instructions per step against 8.73M (callgrind; `soft_points pyramid20 600
/// 3`); at 2 the flanks creep (10.6 cm). Earlier, with 4 sub-steps: 2.4 ms per step
/// and 3.6 cm, where the sequential impulses `Auto` ran before took 8.2 ms per step
/// for 2.2 cm (rapier3d: 0.85 ms per step).
pub const AUTO_SUBSTEPS: usize = 3;

/// How friction is coupled with the normal impulses in the dense solvers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrictionModel {
    /// One boxed LCP with bounds `|z_t| ≤ μ z_n` (PGS only).
    Boxed,
    /// Staggered projections (Kaufman et al. 2008): alternate normal and friction solves.
    Staggered {
        /// Normal/friction alternations per step.
        sweeps: usize,
    },
}

/// Step settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSettings {
    /// The LCP solver.
    pub solver: ContactSolver,
    /// Friction coupling for the dense solvers.
    pub friction: FrictionModel,
    /// Gauss–Seidel sweeps (sequential impulses) or iteration cap (dense PGS).
    pub iterations: usize,
    /// Residual tolerance for the dense solvers.
    pub tolerance: f64,
    /// Baumgarte factor `β ∈ [0, 1]`.
    pub baumgarte: f64,
    /// Penetration allowed without correction (m).
    pub slop: f64,
    /// Speculative margin (m): pairs closer than this get contact rows.
    pub margin: f64,
    /// Approach speed above which restitution applies (m/s).
    pub restitution_threshold: f64,
    /// Final bottom-up sweeps with the lower body frozen (Erleben 2007); 0 = off.
    pub shock_propagation: usize,
    /// Start from the previous step's impulses.
    pub warm_start: bool,
    /// Correct penetration with split impulses (Catto; Tonge et al. 2012): the
    /// Baumgarte target goes into a separate pseudo-velocity solve that moves positions
    /// only, so correcting position error never adds kinetic energy. Off: the target is
    /// part of the velocity rows (plain Baumgarte).
    pub split_impulse: bool,
    /// Contact stiffness, damping and push-out cap of [`ContactSolver::SoftStep`].
    pub soft_step: SoftStepSettings,
    /// Islands and sleeping (every solver; off by default, [`SleepSettings::default`]).
    pub sleep: SleepSettings,
}

impl Default for ContactSettings {
    fn default() -> Self {
        Self {
            solver: ContactSolver::Auto,
            friction: FrictionModel::Staggered { sweeps: 2 },
            iterations: 30,
            tolerance: 1e-10,
            baumgarte: 0.2,
            slop: 1e-4,
            margin: 0.02,
            restitution_threshold: 0.5,
            shock_propagation: 2,
            warm_start: true,
            split_impulse: true,
            soft_step: SoftStepSettings::default(),
            sleep: SleepSettings::default(),
        }
    }
}

/// What a step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// Contact points.
    pub contacts: usize,
    /// Broad-phase overlap tests.
    pub pair_tests: usize,
    /// Solver iterations (sweeps, pivots or Newton steps).
    pub iterations: usize,
    /// Natural-map residual of the contact LCP at the returned impulses,
    /// `|z − mid(lo, z − w, hi)|∞ / max(1, |q|∞)`; `None` where the step did not compute
    /// it (the soft step computes it only on request, [`SoftStepSettings::residual`]).
    pub residual: Option<f64>,
    /// Deepest penetration before the step (m).
    pub max_penetration: f64,
    /// The solver that ran ([`ContactSolver::Auto`] resolved by contact count).
    pub solver: Option<ContactSolver>,
    /// Bodies asleep after the step ([`ContactSettings::sleep`]).
    pub asleep: usize,
}

/// Why a contact world rejected input or a step failed.
#[derive(Clone, Debug, PartialEq)]
pub enum ContactError {
    /// A collider names a body that does not exist.
    UnknownBody {
        /// The collider.
        collider: usize,
    },
    /// A body was rejected (see [`RigidBody::new`]'s rules).
    Body(BodyError),
    /// A scene file could not be turned into a world (the message names the element
    /// and line).
    Scene(alloc::string::String),
    /// Geometry rejected a collider, margin or pose.
    Geometry(GeometryError),
    /// The LCP solver failed (typed; never a wrong answer reported as success).
    Lcp(LcpError),
    /// A setting or the time step was out of range.
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its rule.
        rule: &'static str,
    },
    /// The step left a non-finite or huge state (rolled back).
    Diverged {
        /// The step number.
        step: u64,
        /// The first offending body.
        body: usize,
    },
}

impl fmt::Display for ContactError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownBody { collider } => write!(f, "collider {collider}: unknown body"),
            Self::Body(e) => write!(f, "{e}"),
            Self::Scene(s) => write!(f, "scene: {s}"),
            Self::Geometry(e) => write!(f, "geometry: {e:?}"),
            Self::Lcp(e) => write!(f, "contact LCP: {e}"),
            Self::InvalidParameter { name, rule } => write!(f, "parameter {name}: {rule}"),
            Self::Diverged { step, body } => write!(f, "step {step} diverged (body {body})"),
        }
    }
}

impl core::error::Error for ContactError {}

/// One contact row: bodies, Jacobian blocks, `M⁻¹Jᵀ` blocks, effective mass, target.
#[derive(Clone, Copy, Debug)]
struct Row {
    a: Option<usize>,
    b: Option<usize>,
    j: [DVec3; 4],
    mj: [DVec3; 4],
    /// `J M⁻¹ Jᵀ`.
    k: f64,
    /// Required `J v' ≥ bias` (normal) or friction target 0.
    bias: f64,
    /// Split-impulse target for the pseudo velocities (normal rows; 0 otherwise).
    push: f64,
}

/// A contact key ([`Contact::key`]) and its impulses: normal, friction vector.
type WarmEntry = ((usize, usize, u64), (f64, DVec3));

/// Rigid bodies, colliders and the contact solver's state.
#[derive(Clone, Debug)]
pub struct ContactWorld {
    bodies: Vec<RigidBody>,
    colliders: Vec<Collider>,
    /// Gravity (m/s²).
    pub gravity: DVec3,
    /// Solver settings.
    pub settings: ContactSettings,
    contacts: Vec<Contact>,
    rows: Vec<Row>,
    impulses: Vec<f64>,
    /// The last step's impulses by contact key (normal impulse, friction vector),
    /// sorted by key with one entry per key (the last contact of a key, as a map insert
    /// keeps): a kept buffer searched by bisection, not a tree whose nodes were
    /// allocated anew every step (storing and looking up were 3–4 % of the ten-box
    /// stack's step in `perf` samples).
    warm: Vec<WarmEntry>,
    /// The last `Auto` step ran the soft step (its warm start is in `soft`).
    auto_soft: bool,
    steps: u64,
    /// The solver path of the last step ([`ContactWorld::last_path`]).
    path: SolverPath,
    /// The bodies' state (pose, linear and angular velocity) at the start of the step
    /// being taken (rollback on failure, and asleep bodies' state), reused: the only
    /// fields a step writes, 104 of a [`RigidBody`]'s 288 bytes (the whole copy was
    /// 60 k instructions, 0.7 %, of the 210-box pyramid's step, callgrind).
    saved: Vec<SavedState>,
    /// Buffers of the soft step, boxed so that a step takes and returns them as one
    /// pointer (moved by value the 3 kB state cost two `memcpy` per step); `None`
    /// before the first soft step.
    soft: Option<alloc::boxed::Box<soft_step::SoftState>>,
    /// Buffers of the broad phase (the other solvers; the soft step keeps its own).
    broad: BroadScratch,
    /// Buffers of the dense path (Delassus matrix, row buckets).
    dense: dense::DenseScratch,
    /// Islands and sleep state.
    sleep: sleep::SleepState,
}

/// The part of a body's state a step writes (its pose and velocities), kept at the
/// start of each step so that a failed step can be undone.
#[derive(Clone, Copy, Debug)]
struct SavedState {
    pose: Pose,
    v: DVec3,
    omega: DVec3,
}

impl SavedState {
    /// The state of `b`.
    #[inline]
    fn of(b: &RigidBody) -> Self {
        Self {
            pose: b.pose,
            v: b.v,
            omega: b.omega,
        }
    }

    /// Puts the state back into `b`.
    #[inline]
    fn restore(&self, b: &mut RigidBody) {
        b.pose = self.pose;
        b.v = self.v;
        b.omega = self.omega;
    }
}

impl ContactWorld {
    /// An empty world.
    pub fn new(gravity: DVec3) -> Self {
        Self {
            bodies: Vec::new(),
            colliders: Vec::new(),
            gravity,
            settings: ContactSettings::default(),
            contacts: Vec::new(),
            rows: Vec::new(),
            impulses: Vec::new(),
            warm: Vec::new(),
            auto_soft: false,
            steps: 0,
            path: SolverPath::NOT_STEPPED,
            saved: Vec::new(),
            soft: None,
            broad: BroadScratch::default(),
            dense: dense::DenseScratch::default(),
            sleep: sleep::SleepState::default(),
        }
    }

    /// Adds a body (re-validated); returns its index.
    pub fn add_body(&mut self, body: RigidBody) -> Result<usize, ContactError> {
        let i = self.bodies.len();
        let mut b = RigidBody::new(i, body.mass(), body.inertia(), body.pose)
            .map_err(ContactError::Body)?;
        if !body.v.is_finite() || !body.omega.is_finite() {
            return Err(ContactError::InvalidParameter {
                name: "velocity",
                rule: "must be finite",
            });
        }
        b.v = body.v;
        b.omega = body.omega;
        b.com = body.com;
        self.bodies.push(b);
        Ok(i)
    }

    /// Adds a collider (its body must exist); returns its index.
    pub fn add_collider(&mut self, c: Collider) -> Result<usize, ContactError> {
        let k = self.colliders.len();
        if c.body.is_some_and(|b| b >= self.bodies.len()) {
            return Err(ContactError::UnknownBody { collider: k });
        }
        let checked = Collider::new(c.body, c.shape, c.local, c.friction, c.restitution)
            .map_err(ContactError::Geometry)?;
        self.colliders.push(checked);
        Ok(k)
    }

    /// The bodies.
    pub fn bodies(&self) -> &[RigidBody] {
        &self.bodies
    }

    /// Mutable access to the bodies' state. Wakes every body (a changed state must be
    /// simulated).
    pub fn bodies_mut(&mut self) -> &mut [RigidBody] {
        self.sleep.wake_all();
        &mut self.bodies
    }

    /// The colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// The contacts of the last step.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Kinetic plus gravitational potential energy.
    pub fn energy(&self) -> f64 {
        self.bodies
            .iter()
            .map(|b| b.kinetic_energy() - b.mass() * self.gravity.dot(b.pose.x))
            .sum()
    }

    /// Checks the settings and the state, and builds the step context of `h` (the one
    /// check of the time step, [`StepContext::new`]).
    fn check(&self, h: f64) -> Result<StepContext, ContactError> {
        let s = &self.settings;
        let bad = |name, rule| Err(ContactError::InvalidParameter { name, rule });
        let ctx = match StepContext::new(h) {
            Ok(ctx) => ctx,
            Err(e) => return bad("h", e.rule()),
        };
        if !(0.0..=1.0).contains(&s.baumgarte) {
            return bad("baumgarte", "must be in [0, 1]");
        }
        if !(s.slop >= 0.0) || !s.slop.is_finite() || !(s.margin >= 0.0) || !s.margin.is_finite() {
            return bad("slop/margin", "must be finite and non-negative");
        }
        if !(s.tolerance > 0.0) || !s.tolerance.is_finite() {
            return bad("tolerance", "must be positive and finite");
        }
        s.sleep.check()?;
        if s.iterations == 0 {
            return bad("iterations", "must be at least 1");
        }
        if matches!(
            s.solver,
            ContactSolver::Lemke | ContactSolver::Newton | ContactSolver::Auto
        ) {
            if let FrictionModel::Boxed = s.friction {
                return bad(
                    "friction",
                    "Lemke, Newton and Auto take friction only as Staggered",
                );
            }
        }
        // Public fields and `bodies_mut` can hold anything: a non-finite gravity or body
        // state would reach `f64::clamp` with NaN bounds (a panic) in the solvers.
        if !self.gravity.is_finite() {
            return bad("gravity", "must be finite");
        }
        if !self.bodies.iter().all(finite_state) {
            return bad("body state", "positions and velocities must be finite");
        }
        Ok(ctx)
    }

    /// Advances by `h`. On error the state is left as before the call.
    pub fn step(&mut self, h: f64) -> Result<ContactStats, ContactError> {
        let ctx = self.check(h)?;
        // The rollback copy lives in a kept buffer: no allocation once it has grown.
        let mut saved = core::mem::take(&mut self.saved);
        saved.clear();
        saved.extend(self.bodies.iter().map(SavedState::of));
        let result = self.step_inner(ctx.h()).map(|mut stats| {
            self.update_sleep(ctx.h(), &saved);
            stats.asleep = self.sleep.count();
            stats
        });
        let result =
            result.and_then(
                |stats| match self.bodies.iter().position(|b| !within_limits(b)) {
                    Some(body) => Err(ContactError::Diverged {
                        step: self.steps + 1,
                        body,
                    }),
                    None => Ok(stats),
                },
            );
        if result.is_ok() {
            self.steps += 1;
        } else {
            for (b, s) in self.bodies.iter_mut().zip(&saved) {
                s.restore(b);
            }
        }
        self.saved = saved;
        result
    }

    fn step_inner(&mut self, h: f64) -> Result<ContactStats, ContactError> {
        if let ContactSolver::SoftStep { substeps } = self.settings.solver {
            return self.soft_step(h, substeps);
        }
        let auto = self.settings.solver == ContactSolver::Auto;
        if auto {
            self.check_soft(AUTO_SUBSTEPS)?;
        }
        let mut stats = ContactStats::default();
        // Contacts at the start of the step.
        let poses: Vec<Pose> = self.bodies.iter().map(|b| b.pose).collect();
        let mut contacts = core::mem::take(&mut self.contacts);
        let mut scratch = core::mem::take(&mut self.broad);
        let broad = self.awake_contacts(&poses, &mut scratch, &mut contacts);
        self.broad = scratch;
        let broad = broad?;
        stats.pair_tests = broad.tests;
        stats.contacts = contacts.len();
        stats.max_penetration = contacts.iter().map(|c| c.depth).fold(0.0, f64::max);
        if auto && contacts.len() > AUTO_DENSE_CONTACTS {
            self.contacts = contacts;
            if !self.auto_soft {
                self.warm_dense_to_soft(h);
                self.auto_soft = true;
            }
            return Ok(self.soft_with_contacts(h, AUTO_SUBSTEPS, stats));
        }
        if auto && self.auto_soft {
            self.warm_soft_to_dense(AUTO_SUBSTEPS);
            self.auto_soft = false;
        }
        // Velocities before the step (restitution) and free velocities.
        let v0: Vec<(DVec3, DVec3)> = self.bodies.iter().map(|b| (b.v, b.omega)).collect();
        let g = self.gravity;
        let inv: Vec<(f64, DMat3)> = self
            .bodies
            .iter()
            .map(|b| (1.0 / b.mass(), b.world_inv_inertia()))
            .collect();
        for b in &mut self.bodies {
            b.omega = b.gyroscopic_step(h);
            b.v += g * h;
        }
        self.build_rows(&contacts, &v0, &inv, h);
        self.contacts = contacts;
        let z0 = self.warm_impulses();
        let solver = match self.settings.solver {
            ContactSolver::Auto if self.contacts.len() <= AUTO_DENSE_CONTACTS => {
                ContactSolver::Newton
            }
            ContactSolver::Auto => ContactSolver::SequentialImpulses,
            s => s,
        };
        self.path = SolverPath::STEPPED;
        // `Auto` where every contact has a static side: sequential impulses first, kept
        // when their answer solves the LCP to `tolerance` (each body's rows then touch
        // no other body's, and the sweeps reach an exact fixed point within a few: on
        // the sliding box a residual of at most 5.8e-12 against the dense path's 2.9e-2
        // at the stop, 21.4k instructions per step against 58.7k); else, from the same
        // free velocities and warm start, the dense Newton solve.
        let static_only = solver == ContactSolver::Newton
            && self.settings.solver == ContactSolver::Auto
            && self
                .contacts
                .iter()
                .all(|c| self.colliders[c.a].body.is_none() || self.colliders[c.b].body.is_none());
        let (solver, (z, iterations)) = if static_only {
            self.static_first(z0, &inv)?
        } else {
            (
                solver,
                match solver {
                    ContactSolver::SequentialImpulses => self.sequential_impulses(z0, &inv),
                    _ => self.dense(solver, z0)?,
                },
            )
        };
        stats.solver = Some(solver);
        stats.iterations = iterations;
        // Apply the impulses (the sequential solver has applied them already).
        if solver != ContactSolver::SequentialImpulses {
            for (r, zi) in self.rows.iter().zip(&z) {
                apply(&mut self.bodies, r, *zi);
            }
        }
        stats.residual = Some(self.residual(&z));
        self.store_warm(&z);
        self.impulses = z;
        let pseudo = if self.settings.split_impulse {
            if self.rows.iter().any(|r| r.push != 0.0) {
                self.path.split = true;
            }
            self.pseudo_velocities()
        } else {
            vec![(DVec3::ZERO, DVec3::ZERO); self.bodies.len()]
        };
        for (b, (pv, pw)) in self.bodies.iter_mut().zip(pseudo) {
            b.pose.x += (b.v + pv) * h;
            b.pose.q = rotate_by(b.pose.q, (b.omega + pw) * h);
        }
        Ok(stats)
    }

    /// `Auto` on contacts that all have a static side: the sequential impulses, kept
    /// when their answer's residual meets `tolerance`; else the free velocities back and
    /// the dense Newton solve from the same warm start `z0`. Returns the solver whose
    /// answer stands, the impulses and the iterations.
    #[inline(never)]
    fn static_first(
        &mut self,
        z0: Vec<f64>,
        inv: &[(f64, DMat3)],
    ) -> Result<(ContactSolver, (Vec<f64>, usize)), ContactError> {
        let free: Vec<(DVec3, DVec3)> = self.bodies.iter().map(|b| (b.v, b.omega)).collect();
        let (z, iterations) = self.sequential_impulses(z0.clone(), inv);
        if self.residual(&z) <= self.settings.tolerance {
            return Ok((ContactSolver::SequentialImpulses, (z, iterations)));
        }
        for (b, (v, w)) in self.bodies.iter_mut().zip(free) {
            b.v = v;
            b.omega = w;
        }
        self.path = SolverPath::STEPPED;
        Ok((
            ContactSolver::Newton,
            self.dense(ContactSolver::Newton, z0)?,
        ))
    }

    fn build_rows(
        &mut self,
        contacts: &[Contact],
        v0: &[(DVec3, DVec3)],
        inv: &[(f64, DMat3)],
        h: f64,
    ) {
        let s = self.settings;
        self.rows.clear();
        for c in contacts {
            let (ca, cb) = (&self.colliders[c.a], &self.colliders[c.b]);
            let (ia, ib) = (ca.body, cb.body);
            let r_a = ia.map_or(DVec3::ZERO, |i| c.point_on_a() - self.bodies[i].pose.x);
            let r_b = ib.map_or(DVec3::ZERO, |i| c.point_on_b() - self.bodies[i].pose.x);
            let n = c.normal;
            let (t1, t2) = n.any_orthonormal_pair();
            let rate = |d: DVec3, v: &[(DVec3, DVec3)]| {
                let va = ia.map_or(DVec3::ZERO, |i| v[i].0 + v[i].1.cross(r_a));
                let vb = ib.map_or(DVec3::ZERO, |i| v[i].0 + v[i].1.cross(r_b));
                d.dot(vb - va)
            };
            // Normal target: Baumgarte on penetration beyond slop, speculative approach.
            let correction = if c.depth > s.slop {
                s.baumgarte * (c.depth - s.slop) / h
            } else {
                0.0
            };
            let mut bias = if c.depth < 0.0 {
                c.depth / h
            } else if s.split_impulse {
                0.0
            } else {
                correction
            };
            let push = if s.split_impulse { correction } else { 0.0 };
            let e = ca.restitution.max(cb.restitution);
            let vn = rate(n, v0);
            if e > 0.0 && vn < -s.restitution_threshold {
                bias = bias.max(-e * vn);
            }
            for (d, bias, push) in [(n, bias, push), (t1, 0.0, 0.0), (t2, 0.0, 0.0)] {
                let j = [-d, -r_a.cross(d), d, r_b.cross(d)];
                let mut mj = [DVec3::ZERO; 4];
                let mut k = 0.0;
                if let Some(i) = ia {
                    mj[0] = j[0] * inv[i].0;
                    mj[1] = inv[i].1 * j[1];
                    k += j[0].dot(mj[0]) + j[1].dot(mj[1]);
                }
                if let Some(i) = ib {
                    mj[2] = j[2] * inv[i].0;
                    mj[3] = inv[i].1 * j[3];
                    k += j[2].dot(mj[2]) + j[3].dot(mj[3]);
                }
                self.rows.push(Row {
                    a: ia,
                    b: ib,
                    j,
                    mj,
                    k,
                    bias,
                    push,
                });
            }
        }
    }

    /// Friction coefficient of contact `c` (the larger of the two colliders', as
    /// MuJoCo and Box2D combine them: `max`).
    fn mu(&self, c: usize) -> f64 {
        let ct = &self.contacts[c];
        self.colliders[ct.a]
            .friction
            .max(self.colliders[ct.b].friction)
    }

    fn warm_impulses(&self) -> Vec<f64> {
        let mut z = vec![0.0; self.rows.len()];
        if !self.settings.warm_start {
            return z;
        }
        for (k, c) in self.contacts.iter().enumerate() {
            let found = self.warm.binary_search_by_key(&c.key(), |e| e.0);
            if let Some((_, (zn, ft))) = found.ok().map(|i| &self.warm[i]) {
                let (t1, t2) = c.normal.any_orthonormal_pair();
                z[3 * k] = *zn;
                z[3 * k + 1] = ft.dot(t1);
                z[3 * k + 2] = ft.dot(t2);
            }
        }
        z
    }

    fn store_warm(&mut self, z: &[f64]) {
        let warm = &mut self.warm;
        warm.clear();
        for (k, c) in self.contacts.iter().enumerate() {
            let (t1, t2) = c.normal.any_orthonormal_pair();
            warm.push((c.key(), (z[3 * k], t1 * z[3 * k + 1] + t2 * z[3 * k + 2])));
        }
        // Contacts come in key order as a rule (then no sort runs); the sort is stable,
        // so of equal keys the last contact is last and is the one kept.
        if !warm.is_sorted_by_key(|e| e.0) {
            warm.sort_by_key(|e| e.0);
        }
        let mut kept = 0;
        for r in 0..warm.len() {
            if kept > 0 && warm[kept - 1].0 == warm[r].0 {
                warm[kept - 1] = warm[r];
            } else {
                warm[kept] = warm[r];
                kept += 1;
            }
        }
        warm.truncate(kept);
    }

    fn row_rate(&self, r: &Row) -> f64 {
        let mut s = 0.0;
        if let Some(i) = r.a {
            s += r.j[0].dot(self.bodies[i].v) + r.j[1].dot(self.bodies[i].omega);
        }
        if let Some(i) = r.b {
            s += r.j[2].dot(self.bodies[i].v) + r.j[3].dot(self.bodies[i].omega);
        }
        s
    }

    /// Bounds of row `i` at impulses `z`.
    fn bounds(&self, i: usize, z: &[f64]) -> (f64, f64) {
        if i % 3 == 0 {
            (0.0, f64::INFINITY)
        } else {
            let m = self.mu(i / 3) * z[i - i % 3];
            (-m, m)
        }
    }

    /// Natural-map residual of the contact LCP at `z` (velocities already updated).
    fn residual(&self, z: &[f64]) -> f64 {
        let mut worst: f64 = 0.0;
        let mut scale: f64 = 1.0;
        for (i, r) in self.rows.iter().enumerate() {
            let w = self.row_rate(r) - r.bias;
            scale = scale.max(w.abs());
            let (lo, hi) = self.bounds(i, z);
            let proj = (z[i] - w).min(hi).max(lo); // NaN-safe, see sequential.rs
            worst = worst.max((z[i] - proj).abs());
        }
        worst / scale
    }

    /// The impulses of the last step, three rows per contact (normal, two tangents).
    pub fn impulses(&self) -> &[f64] {
        &self.impulses
    }

    /// The soft step's carried warm-start state, five numbers per stored contact in
    /// key order: the normal impulse, the friction impulse vector (three) and the
    /// preload floor; empty before the first soft step. A diagnostic (e.g. counting
    /// subnormal values on long resting runs); the numbers are not part of the model.
    pub fn soft_warm_values(&self) -> impl Iterator<Item = f64> + '_ {
        self.soft
            .iter()
            .flat_map(|st| st.warm.iter())
            .flat_map(|&(_, zn, ft, fl)| [zn, ft.x, ft.y, ft.z, fl])
    }
}

/// `v += M⁻¹ Jᵀ dz` for the row's bodies.
fn apply(bodies: &mut [RigidBody], r: &Row, dz: f64) {
    if let Some(i) = r.a {
        bodies[i].v += r.mj[0] * dz;
        bodies[i].omega += r.mj[1] * dz;
    }
    if let Some(i) = r.b {
        bodies[i].v += r.mj[2] * dz;
        bodies[i].omega += r.mj[3] * dz;
    }
}

/// Whether a body's position, orientation and velocities are all finite (the
/// check's body test): `0 c` is `±0` for a finite `c` and NaN for an infinite or NaN
/// one, and a sum holding a NaN is NaN while a sum of zeros is a zero, so the sum of
/// the thirteen products is zero exactly when every component is finite (as
/// `broad::all_finite` tests poses). One comparison a body instead of thirteen tests
/// and branches (the same answer as `is_finite` on each of the four).
#[inline]
fn finite_state(b: &RigidBody) -> bool {
    let zero = |v: DVec3| (v * 0.0).element_sum();
    let q = (glam::DVec4::from(b.pose.q) * 0.0).element_sum();
    zero(b.pose.x) + q + zero(b.v) + zero(b.omega) == 0.0
}

/// [`constraint_core::math::within_limit`] of a body's position, velocity and
/// angular velocity: every component below [`constraint_core::math::DIVERGENCE_LIMIT`]
/// in magnitude, which no NaN is (`NaN < L` is false) and no infinity, so the strict
/// bound alone is `within_limit`'s finiteness test and bound; the nine comparisons
/// combined without branches.
#[inline]
fn within_limits(b: &RigidBody) -> bool {
    const L: f64 = constraint_core::math::DIVERGENCE_LIMIT;
    let below = |v: DVec3| (v.x.abs() < L) & (v.y.abs() < L) & (v.z.abs() < L);
    below(b.pose.x) & below(b.v) & below(b.omega)
}

#[cfg(test)]
mod tests {
    use super::*;
    use constraint_core::math::{within_limit, DIVERGENCE_LIMIT};
    use constraint_core::DQuat;

    /// The branch-free body tests give the answers of the tests they replace
    /// (`is_finite` on position, orientation and velocities; `within_limit` on
    /// position and velocities) on every body whose thirteen components are each one
    /// of: 0, −0, 1, the limit and just below it, ±∞, NaN (one component changed at a
    /// time, and pairs of the special values in two components).
    #[test]
    fn branch_free_body_tests_match_the_componentwise_ones() {
        let limit = DIVERGENCE_LIMIT;
        let values = [
            0.0,
            -0.0,
            1.0,
            -2.5,
            limit,
            -limit,
            limit * (1.0 - f64::EPSILON),
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MAX,
        ];
        let pose = Pose {
            x: DVec3::ZERO,
            q: DQuat::IDENTITY,
        };
        let base = RigidBody::new(0, 1.0, DMat3::IDENTITY, pose).unwrap();
        let set = |b: &mut RigidBody, c: usize, v: f64| match c {
            0..3 => b.pose.x[c] = v,
            3..7 => {
                let mut q = b.pose.q.to_array();
                q[c - 3] = v;
                b.pose.q = DQuat::from_array(q);
            }
            7..10 => b.v[c - 7] = v,
            _ => b.omega[c - 10] = v,
        };
        let mut checked = 0;
        for c in 0..13 {
            for d in c..13 {
                for &x in &values {
                    for &y in &values {
                        let mut b = base;
                        set(&mut b, c, x);
                        set(&mut b, d, y);
                        let finite = b.pose.x.is_finite()
                            && b.pose.q.is_finite()
                            && b.v.is_finite()
                            && b.omega.is_finite();
                        assert_eq!(finite_state(&b), finite, "{c} {d} {x} {y}");
                        let ok =
                            within_limit(b.pose.x) && within_limit(b.v) && within_limit(b.omega);
                        assert_eq!(within_limits(&b), ok, "{c} {d} {x} {y}");
                        checked += 1;
                    }
                }
            }
        }
        // 91 component pairs (with repeats) times 121 value pairs.
        assert_eq!(checked, 91 * 121);
    }
}
