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

use alloc::vec;
use alloc::vec::Vec;

use constraint_core::rigid::rotate_by;
use constraint_core::{DMat3, DVec3, Pose};

use crate::body::RigidBody;
use crate::error::ArticulatedError;
use crate::joint::{Joint, JointKind, MAX_ROWS};
use crate::tree::{JointTopo, TreeSolver};

/// Largest rotation of a body in one RATTLE drift (rad) before the step is redone at
/// the velocity level.
const MAX_TURN: f64 = 0.5;

/// Loop-closure rows of one assembly: `(a, b, row)`, compliance, right-hand side.
type LoopRows = (Vec<(Option<usize>, usize, [DVec3; 4])>, Vec<f64>, Vec<f64>);

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
    /// time-symmetric and second order; damping rows act over each half kick.
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
    /// (`Velocity { beta: 1.0 }`) is about 5× cheaper per step.
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
}

/// Bodies, joints, gravity and the solver's reusable storage.
#[derive(Clone, Debug)]
pub struct World {
    bodies: Vec<RigidBody>,
    joints: Vec<Joint>,
    /// Gravity (m/s²).
    pub gravity: DVec3,
    steps: u64,
    solver: Option<TreeSolver>,
    rhs: Vec<f64>,
    mu: Vec<f64>,
    saved: Vec<RigidBody>,
    /// Whether the velocity-level matrix gets the joints' geometric stiffness.
    pub geometric_stiffness: GeometricStiffness,
    /// Hard-row impulses `λ` of the last velocity solve, per joint.
    impulses: Vec<[f64; MAX_ROWS]>,
    /// Per-body angular momenta (RATTLE scratch).
    momenta: Vec<DVec3>,
}

impl World {
    /// An empty world with the given gravity.
    pub fn new(gravity: DVec3) -> Self {
        Self {
            bodies: Vec::new(),
            joints: Vec::new(),
            gravity,
            steps: 0,
            solver: None,
            rhs: Vec::new(),
            mu: Vec::new(),
            saved: Vec::new(),
            geometric_stiffness: GeometricStiffness::default(),
            impulses: Vec::new(),
            momenta: Vec::new(),
        }
    }

    /// Adds a body; returns its index. Its velocities must be finite.
    pub fn add_body(&mut self, body: RigidBody) -> Result<usize, ArticulatedError> {
        let i = self.bodies.len();
        if !body.v.is_finite() || !body.omega.is_finite() {
            return Err(ArticulatedError::InvalidBody {
                body: i,
                reason: "velocity must be finite",
            });
        }
        // Re-validate (fields are public).
        let mut checked = RigidBody::new(i, body.mass, body.inertia, body.pose)?;
        checked.v = body.v;
        checked.omega = body.omega;
        checked.com = body.com;
        self.bodies.push(checked);
        self.solver = None;
        Ok(i)
    }

    /// Adds a joint; returns its index. Errors: unknown body, a body joined to itself,
    /// negative or non-finite damping.
    pub fn add_joint(&mut self, joint: Joint) -> Result<usize, ArticulatedError> {
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
        self.joints.push(joint);
        self.solver = None;
        Ok(j)
    }

    /// The bodies.
    pub fn bodies(&self) -> &[RigidBody] {
        &self.bodies
    }

    /// Mutable access to the bodies' state (masses are re-checked by nothing here:
    /// change them through [`RigidBody::new`]).
    pub fn bodies_mut(&mut self) -> &mut [RigidBody] {
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

    /// Largest joint separation (m) at the current state.
    pub fn max_separation(&self) -> f64 {
        self.joints
            .iter()
            .map(|j| j.separation(&self.pose(j.parent), &self.pose(Some(j.child))))
            .fold(0.0, f64::max)
    }

    /// Kinetic plus gravitational potential energy `Σ ½mv² + ½ωᵀIω − m g·x`.
    pub fn energy(&self) -> (f64, f64) {
        let kin = self.bodies.iter().map(|b| b.kinetic_energy()).sum();
        let pot = self
            .bodies
            .iter()
            .map(|b| -b.mass * self.gravity.dot(b.pose.x))
            .sum();
        (kin, pot)
    }

    /// Number of loop-closure joints (joints outside the spanning tree).
    pub fn loop_joints(&mut self) -> usize {
        self.ensure_solver();
        self.solver.as_ref().map_or(0, |s| s.loops.len())
    }

    fn topo(&self, with_damping: bool) -> Vec<JointTopo> {
        self.joints
            .iter()
            .map(|j| JointTopo {
                a: j.parent,
                b: j.child,
                rows: j.hard_rows() + if with_damping { j.damping_rows() } else { 0 },
            })
            .collect()
    }

    fn ensure_solver(&mut self) {
        if self.solver.is_none() {
            self.solver = Some(TreeSolver::new(self.bodies.len(), &self.topo(true)));
        }
    }

    /// Advances the world by `h` seconds.
    ///
    /// On error (bad parameter, singular system, divergence) the state is left as it was
    /// before the call.
    pub fn step(&mut self, h: f64, method: Method) -> Result<StepStats, ArticulatedError> {
        if !(h > 0.0) || !h.is_finite() {
            return Err(ArticulatedError::InvalidParameter {
                name: "h",
                rule: "time step must be positive and finite",
            });
        }
        check_method(&method)?;
        self.ensure_solver();
        self.saved.clone_from(&self.bodies);
        let result = self.step_inner(h, method);
        match result {
            Ok(stats) => {
                if let Some(body) = self.first_bad_body() {
                    self.bodies.clone_from(&self.saved);
                    return Err(ArticulatedError::Diverged {
                        step: self.steps + 1,
                        body,
                    });
                }
                self.steps += 1;
                Ok(stats)
            }
            Err(e) => {
                self.bodies.clone_from(&self.saved);
                Err(e)
            }
        }
    }

    fn first_bad_body(&self) -> Option<usize> {
        let ok = |v: DVec3| v.is_finite() && v.abs().max_element() < 1e12;
        self.bodies
            .iter()
            .position(|b| !ok(b.pose.x) || !ok(b.v) || !ok(b.omega) || !b.pose.q.is_finite())
    }

    fn step_inner(&mut self, h: f64, method: Method) -> Result<StepStats, ArticulatedError> {
        let mut stats = StepStats::default();
        match method {
            Method::Velocity { beta } => self.velocity_solve(h, beta)?,
            Method::VelocityProjected {
                beta,
                tolerance,
                max_iterations,
                correct_velocity,
            } => {
                self.velocity_solve(h, beta)?;
                stats.projection_iterations =
                    self.project(tolerance, max_iterations, correct_velocity.then_some(h))?;
            }
            Method::Acceleration { kx, kv } => self.acceleration_solve(h, kx, kv)?,
            Method::Rattle {
                tolerance,
                max_iterations,
            } => {
                let start = (self.bodies.clone(), self.impulses.clone());
                let (it, ok) = self.rattle_step(h, tolerance, max_iterations)?;
                stats.projection_iterations = it;
                if !ok {
                    self.fall_back(start, h, &mut stats)?;
                }
            }
            Method::Rattle4 {
                tolerance,
                max_iterations,
            } => {
                let w1 = 1.0 / (2.0 - libm::cbrt(2.0));
                let w0 = 1.0 - 2.0 * w1;
                let start = (self.bodies.clone(), self.impulses.clone());
                for w in [w1, w0, w1] {
                    let (it, ok) = self.rattle_step(w * h, tolerance, max_iterations)?;
                    stats.projection_iterations += it;
                    if !ok {
                        self.fall_back(start.clone(), h, &mut stats)?;
                        break;
                    }
                }
            }
        }
        Ok(stats)
    }

    /// Loads the mass blocks and the joint rows into the solver; `rhs_joint(j, rows)`
    /// writes the joint's right-hand side and returns nothing. Returns the loop rows.
    fn assemble(
        &mut self,
        h: f64,
        with_damping: bool,
        mut joint_rhs: impl FnMut(usize, &Joint, &crate::joint::JointRows, &mut [f64]),
    ) -> LoopRows {
        let solver = self.solver.as_mut().expect("solver built by ensure_solver");
        let mut loop_rows = Vec::new();
        let mut loop_c = Vec::new();
        let mut loop_rhs = Vec::new();
        for (j, joint) in self.joints.iter().enumerate() {
            let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
            let b = self.bodies[joint.child].pose;
            let rows = joint.rows(&a, &b, with_damping);
            let mut comp = [0.0; MAX_ROWS];
            for r in rows.n_hard..rows.n {
                comp[r] = 1.0 / (h * joint.damping);
            }
            // In the topology every joint has its damping rows; without damping they get
            // infinite compliance, i.e. a decoupled row with λ = 0.
            let n_topo = joint.hard_rows() + joint.damping_rows();
            for r in rows.n..n_topo {
                comp[r] = 1.0;
            }
            let mut rhs = [0.0; MAX_ROWS];
            joint_rhs(j, joint, &rows, &mut rhs[..rows.n]);
            let topo = JointTopo {
                a: joint.parent,
                b: joint.child,
                rows: n_topo,
            };
            match solver.joint_offset(j) {
                Some(o) => {
                    solver.set_joint(j, &topo, &rows.rows[..rows.n], &comp[..n_topo]);
                    self.rhs[o..o + n_topo].copy_from_slice(&rhs[..n_topo]);
                }
                None => {
                    for r in 0..rows.n {
                        loop_rows.push((joint.parent, joint.child, rows.rows[r]));
                        loop_c.push(comp[r]);
                        loop_rhs.push(rhs[r]);
                    }
                }
            }
        }
        (loop_rows, loop_c, loop_rhs)
    }

    fn solve(&mut self, loops: LoopRows) -> Result<(), ArticulatedError> {
        let solver = self.solver.as_mut().expect("solver built by ensure_solver");
        solver.factor()?;
        self.solve_factored(&loops)
    }

    /// Solves with the factor already in the solver (loop rows as assembled with it).
    fn solve_factored(&mut self, loops: &LoopRows) -> Result<(), ArticulatedError> {
        let solver = self.solver.as_mut().expect("solver built by ensure_solver");
        let (rows, c, r) = loops;
        let mut free_scale: f64 = 0.0;
        for (a, b, row) in rows {
            let mut g = 0.0;
            for (side, body) in [(0usize, *a), (1usize, Some(*b))] {
                if let Some(i) = body {
                    let bd = &self.bodies[i];
                    g += row[2 * side].length_squared() / bd.mass
                        + row[2 * side + 1].dot(bd.world_inv_inertia() * row[2 * side + 1]);
                }
            }
            free_scale = free_scale.max(g);
        }
        solver.solve_with_loops(&mut self.rhs, rows, c, r, free_scale, &mut self.mu)
    }

    /// Loads every body's mass block `diag(m) ⊕ R I Rᵀ` into the solver and its
    /// right-hand side `f(body, R, I_world)`.
    fn body_rhs(&mut self, f: impl Fn(&RigidBody, &DMat3, &DMat3) -> (DVec3, DVec3)) {
        let size = self.solver.as_ref().map_or(0, |s| s.size);
        self.rhs.clear();
        self.rhs.resize(size, 0.0);
        let solver = self.solver.as_mut().expect("solver built by ensure_solver");
        for (i, b) in self.bodies.iter().enumerate() {
            let o = solver.body_offset(i);
            let r = b.rotation();
            let iw = r * b.inertia * r.transpose();
            solver.set_body(i, b.mass, &iw);
            let (lin, ang) = f(b, &r, &iw);
            self.rhs[o..o + 3].copy_from_slice(&lin.to_array());
            self.rhs[o + 3..o + 6].copy_from_slice(&ang.to_array());
        }
    }

    fn body_solution(&self, i: usize) -> (DVec3, DVec3) {
        let o = self.solver.as_ref().map_or(0, |s| s.body_offset(i));
        let x = &self.rhs;
        (
            DVec3::new(x[o], x[o + 1], x[o + 2]),
            DVec3::new(x[o + 3], x[o + 4], x[o + 5]),
        )
    }

    /// `[M Jᵀ; J −C][v'; λ] = [M v + h f; −β C/h]`, then `x' = x + h v'`.
    fn velocity_solve(&mut self, h: f64, beta: f64) -> Result<(), ArticulatedError> {
        self.velocity_system_solve(h, beta)?;
        for i in 0..self.bodies.len() {
            let (v, w) = self.body_solution(i);
            let b = &mut self.bodies[i];
            b.v = v;
            b.omega = w;
            b.pose.x += v * h;
            b.pose.q = rotate_by(b.pose.q, w * h);
        }
        Ok(())
    }

    /// The end-of-step twists `(v', ω')` of the velocity-level system
    /// `[M Jᵀ; J −C][v'; λ] = [M v + h f; −β C/h]`, solved by the tree factorization,
    /// without moving the bodies (for checking against [`Self::dense_velocity_system`]).
    pub fn velocity_twists(
        &mut self,
        h: f64,
        beta: f64,
    ) -> Result<Vec<(DVec3, DVec3)>, ArticulatedError> {
        self.ensure_solver();
        self.velocity_system_solve(h, beta)?;
        Ok((0..self.bodies.len())
            .map(|i| self.body_solution(i))
            .collect())
    }

    /// The velocity-level KKT system of [`Self::velocity_twists`] as one dense matrix
    /// (all joints' rows, loop joints included, damping rows with compliance
    /// `1/(h d)`): unknowns `[v₀, ω₀, v₁, ω₁, …, λ]`. A reference for tests and for
    /// tiny systems; `O(n²)` memory.
    pub fn dense_velocity_system(&self, h: f64, beta: f64) -> (Vec<Vec<f64>>, Vec<f64>) {
        let nb = self.bodies.len();
        let rows: usize = self
            .joints
            .iter()
            .map(|j| j.hard_rows() + j.damping_rows())
            .sum();
        let n = 6 * nb + rows;
        let mut m = vec![vec![0.0; n]; n];
        let mut rhs = vec![0.0; n];
        for (i, b) in self.bodies.iter().enumerate() {
            let iw = b.world_inertia();
            let w = b.gyroscopic_step(h);
            let lin = b.v * b.mass + self.gravity * (b.mass * h);
            let ang = iw * w;
            for k in 0..3 {
                m[6 * i + k][6 * i + k] = b.mass;
                for l in 0..3 {
                    m[6 * i + 3 + k][6 * i + 3 + l] = iw.col(l)[k];
                }
                rhs[6 * i + k] = lin[k];
                rhs[6 * i + 3 + k] = ang[k];
            }
        }
        let mut r0 = 6 * nb;
        for joint in &self.joints {
            let a = self.pose(joint.parent);
            let b = self.pose(Some(joint.child));
            let jr = joint.rows(&a, &b, true);
            for r in 0..jr.n {
                let row = r0 + r;
                for (side, body) in [(0usize, joint.parent), (1usize, Some(joint.child))] {
                    let Some(body) = body else { continue };
                    for c in 0..3 {
                        for (blk, off) in [(2 * side, 0), (2 * side + 1, 3)] {
                            let v = jr.rows[r][blk][c];
                            m[row][6 * body + off + c] = v;
                            m[6 * body + off + c][row] = v;
                        }
                    }
                }
                if r >= jr.n_hard {
                    m[row][row] = -1.0 / (h * joint.damping);
                } else {
                    rhs[row] = -beta * jr.value[r] / h;
                }
            }
            r0 += jr.n;
        }
        (m, rhs)
    }

    fn velocity_system_solve(&mut self, h: f64, beta: f64) -> Result<(), ArticulatedError> {
        let g = self.gravity;
        self.body_rhs(|b, r, iw| {
            let w = b.gyroscopic_step_with(r, h);
            (b.v * b.mass + g * (b.mass * h), *iw * w)
        });
        if self.geometric_stiffness != GeometricStiffness::Off
            && self.impulses.len() == self.joints.len()
        {
            self.add_geometric_stiffness(h);
        }
        let loops = self.assemble(h, true, |_, _, rows, rhs| {
            for r in 0..rows.n_hard {
                rhs[r] = -beta * rows.value[r] / h;
            }
        });
        self.solve(loops)?;
        self.store_impulses();
        Ok(())
    }

    /// Geometric stiffness (Andrews, Teichmann and Kry 2017, "Geometric stiffness for
    /// real-time constrained multibody dynamics"; Tournier et al. 2015): the constraint
    /// force `−Jᵀλ/h` depends on the configuration through `J`, with
    /// `∂(−Jᵀλ/h)/∂x = −Σ_r (λ_r/h) ∂²C_r/∂x²` — the joint curvature of
    /// `constraint-core`. Treating it implicitly, like the soft crate's linearized backward
    /// Euler, adds `h² Σ_r (λ_r/h) ∂²C_r = h Σ_r λ_r ∂²C_r` to the mass matrix, with the
    /// impulses `λ` of the previous step.
    /// Without it the transverse "string" modes of a tense chain (a light link under a
    /// heavy load: `ω² ≈ T/(mL)`) are integrated explicitly and blow up once `hω > 2`.
    /// To keep Baraff's tree structure only each body's own diagonal blocks (`xx` and
    /// `θθ`) are kept, and each is replaced by its positive semi-definite part, as in
    /// Andrews et al.'s diagonal approximation.
    fn add_geometric_stiffness(&mut self, h: f64) {
        let threshold = match self.geometric_stiffness {
            GeometricStiffness::Off => return,
            GeometricStiffness::Always => 0.0,
            GeometricStiffness::Auto { ratio } => ratio,
        };
        // h² K with K = Σ (λ_r/h) ∂²C_r (λ are impulses): h Σ λ_r ∂²C_r.
        let solver = self.solver.as_mut().expect("solver built by ensure_solver");
        for (j, joint) in self.joints.iter().enumerate() {
            let lam = &self.impulses[j];
            // Cheap bound first: |h Σ λ_r ∂²C_r| ≤ 2 h lever Σ|λ_r|.
            let bound = 2.0 * h * joint.lever() * lam.iter().map(|l| l.abs()).sum::<f64>();
            let i_min = |b: Option<usize>| b.map_or(f64::INFINITY, |i| self.bodies[i].i_min);
            if !(bound > threshold * i_min(joint.parent).min(i_min(Some(joint.child)))) {
                continue;
            }
            let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
            let b = self.bodies[joint.child].pose;
            let k = joint.curvature(&a, &b, lam);
            for (side, body) in [(0usize, joint.parent), (1usize, Some(joint.child))] {
                let Some(i) = body else { continue };
                let tt = crate::body::psd_part(&(k.blocks[2 * side + 1][2 * side + 1] * h));
                // (hω)² of the stiffest rotational mode this term describes, against the
                // body's smallest principal moment.
                let t_max = crate::body::symmetric_eigenvalues(&tt)[2];
                if t_max > threshold * self.bodies[i].i_min {
                    let xx = crate::body::psd_part(&(k.blocks[2 * side][2 * side] * h));
                    solver.add_body_blocks(i, &xx, &tt);
                }
            }
        }
    }

    /// Copies the hard-row multipliers of the last solve (tree joints from the solution,
    /// loop joints from the loop multipliers, in joint order).
    fn store_impulses(&mut self) {
        let solver = self.solver.as_ref().expect("solver built by ensure_solver");
        self.impulses.resize(self.joints.len(), [0.0; MAX_ROWS]);
        let mut next_loop = 0;
        for (j, joint) in self.joints.iter().enumerate() {
            let n = joint.hard_rows();
            let mut lam = [0.0; MAX_ROWS];
            match solver.joint_offset(j) {
                Some(o) => lam[..n].copy_from_slice(&self.rhs[o..o + n]),
                None => {
                    for r in 0..n {
                        lam[r] = self.mu.get(next_loop + r).copied().unwrap_or(0.0);
                    }
                    next_loop += n;
                }
            }
            self.impulses[j] = lam;
        }
    }

    /// Newton projection onto `C(x) = 0` with mass-weighted minimum-norm steps
    /// `[M Jᵀ; J 0][δ; λ] = [0; −C]` (Goldenthal et al. 2007, fast projection).
    fn project(
        &mut self,
        tolerance: f64,
        max_iterations: usize,
        velocity_h: Option<f64>,
    ) -> Result<usize, ArticulatedError> {
        let mut err = self.max_separation();
        for it in 0..max_iterations {
            if err <= tolerance {
                return Ok(it);
            }
            self.body_rhs(|_, _, _| (DVec3::ZERO, DVec3::ZERO));
            let loops = self.assemble(1.0, false, |_, _, rows, rhs| {
                for r in 0..rows.n_hard {
                    rhs[r] = -rows.value[r];
                }
            });
            self.solve(loops)?;
            // Backtracking: a full Newton step can overshoot far from the manifold (light
            // bodies turned by large angles); halve it until the separation decreases.
            let base: Vec<(Pose, DVec3, DVec3)> =
                self.bodies.iter().map(|b| (b.pose, b.v, b.omega)).collect();
            let mut alpha = 1.0;
            let mut accepted = false;
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
                let trial = self.max_separation();
                if trial < err {
                    err = trial;
                    accepted = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted {
                for (b, (pose, v, w)) in self.bodies.iter_mut().zip(base) {
                    b.pose = pose;
                    b.v = v;
                    b.omega = w;
                }
                return Ok(it + 1);
            }
        }
        Ok(max_iterations)
    }

    /// Restores `start` and redoes the step with the velocity level.
    fn fall_back(
        &mut self,
        start: (Vec<RigidBody>, Vec<[f64; MAX_ROWS]>),
        h: f64,
        stats: &mut StepStats,
    ) -> Result<(), ArticulatedError> {
        self.bodies = start.0;
        self.impulses = start.1;
        stats.fallbacks += 1;
        self.velocity_solve(h, 1.0)
    }

    /// One RATTLE step of `h` (may be negative inside a Yoshida composition). Returns
    /// the projection iterations and whether the projection converged (to `10³ ·
    /// tolerance`, at least 1e-9 m).
    fn rattle_step(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<(usize, bool), ArticulatedError> {
        let g = self.gravity;
        let half = 0.5 * h;
        let hd = half.abs();
        // 1. Half kick with the constraint impulse that makes the drift land on the
        //    linearised manifold: [M Jᵀ; J −C][v½; λ] = [M v + (h/2) m g; −C(x)/h].
        self.body_rhs(|b, _, iw| (b.v * b.mass + g * (b.mass * half), *iw * b.omega));
        let loops = self.assemble(hd, true, |_, _, rows, rhs| {
            for r in 0..rows.n_hard {
                rhs[r] = -rows.value[r] / h;
            }
        });
        let loops_n = loops.clone();
        self.solve(loops)?;
        self.store_impulses();
        let first_kick = self.impulses.clone();
        let start: Vec<Pose> = self.bodies.iter().map(|b| b.pose).collect();
        // 2. Drift: x' = x + h v½; q' = exp(h ω*) q with L = I(q) ω½ fixed and
        //    ω* = I(q_mid)⁻¹ L at q_mid = exp(h ω*/2) q (fixed point, 4 sweeps).
        let mut momenta = core::mem::take(&mut self.momenta);
        momenta.clear();
        let mut max_turn: f64 = 0.0;
        for i in 0..self.bodies.len() {
            let (v, w) = self.body_solution(i);
            let b = &mut self.bodies[i];
            let l = b.world_inertia() * w;
            let q0 = b.pose.q;
            let mut ws = w;
            for _ in 0..4 {
                let mut mid = *b;
                mid.pose.q = rotate_by(q0, ws * half);
                ws = mid.world_inv_inertia() * l;
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
            return Ok((0, false));
        }
        // 3. SHAKE: the constraint impulse of the first kick acts along J(x₀)ᵀ, so the
        //    corrections are δ = −M₀⁻¹J₀ᵀ(J₀M₀⁻¹J₀ᵀ)⁻¹ C(x') with the factor of step 1
        //    (a chord iteration: linear convergence at rate O(h)); δ/h enters the
        //    half-step velocities and I₀ δθ/h the angular momenta.
        let mut iterations = 0;
        let mut final_err = 0.0;
        for it in 0..=max_iterations {
            let mut err: f64 = 0.0;
            let mut loop_rhs = Vec::new();
            let size = self.solver.as_ref().map_or(0, |s| s.size);
            self.rhs.clear();
            self.rhs.resize(size, 0.0);
            let solver = self.solver.as_ref().expect("solver built by ensure_solver");
            for (j, joint) in self.joints.iter().enumerate() {
                let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
                let b = self.bodies[joint.child].pose;
                err = err.max(joint.separation(&a, &b));
                let c = joint.value(&a, &b);
                let n = joint.hard_rows();
                match solver.joint_offset(j) {
                    Some(o) => {
                        for r in 0..n {
                            self.rhs[o + r] = -c[r];
                        }
                    }
                    None => {
                        loop_rhs.extend(c[..n].iter().map(|v| -v));
                        loop_rhs.extend(core::iter::repeat_n(0.0, joint.damping_rows()));
                    }
                }
            }
            iterations = it;
            final_err = err;
            if err <= tolerance || it == max_iterations || !err.is_finite() {
                break;
            }
            let mut rows = loops_n.clone();
            rows.2 = loop_rhs;
            self.solve_factored(&rows)?;
            for i in 0..self.bodies.len() {
                let (dx, dth) = self.body_solution(i);
                let b = &mut self.bodies[i];
                b.pose.x += dx;
                b.pose.q = rotate_by(b.pose.q, dth);
                b.v += dx / h;
                b.omega += dth / h;
                let mut b0 = *b;
                b0.pose = start[i];
                momenta[i] += b0.world_inertia() * (dth / h);
            }
        }
        // 4. Half kick and the velocity constraint at the new configuration:
        //    [M Jᵀ; J −C][v'; μ] = [M v½ + (h/2) m g; 0], angular part L½.
        self.body_rhs(|b, _, _| (b.v * b.mass + g * (b.mass * half), DVec3::ZERO));
        {
            let solver = self.solver.as_ref().expect("solver built by ensure_solver");
            for (i, l) in momenta.iter().enumerate() {
                let o = solver.body_offset(i) + 3;
                self.rhs[o..o + 3].copy_from_slice(&l.to_array());
            }
        }
        let loops = self.assemble(hd, true, |_, _, _, _| {});
        self.solve(loops)?;
        // Whole-step impulses (both kicks), for the geometric stiffness of a later
        // velocity-level step.
        self.store_impulses();
        for (acc, first) in self.impulses.iter_mut().zip(&first_kick) {
            for (a, f) in acc.iter_mut().zip(first) {
                *a += f;
            }
        }
        for i in 0..self.bodies.len() {
            let (v, w) = self.body_solution(i);
            self.bodies[i].v = v;
            self.bodies[i].omega = w;
        }
        self.momenta = momenta;
        Ok((iterations, final_err <= (1e3 * tolerance).max(1e-9)))
    }

    /// `[M Jᵀ; J 0][a; λ] = [f; −J̇v − k_x C − k_v J v]`, then `v' = v + h a`,
    /// `x' = x + h v'`.
    fn acceleration_solve(&mut self, h: f64, kx: f64, kv: f64) -> Result<(), ArticulatedError> {
        let g = self.gravity;
        // Explicit joint damping torques/forces: −d J_dᵀ (J_d v).
        let mut damp = vec![(DVec3::ZERO, DVec3::ZERO); self.bodies.len()];
        for joint in &self.joints {
            if joint.damping_rows() == 0 {
                continue;
            }
            let a = self.pose(joint.parent);
            let b = self.pose(Some(joint.child));
            let rows = joint.rows(&a, &b, true);
            let twist = self.twist(joint);
            for r in rows.n_hard..rows.n {
                let rate: f64 = (0..4).map(|k| rows.rows[r][k].dot(twist[k])).sum();
                let s = -joint.damping * rate;
                if let Some(p) = joint.parent {
                    damp[p].0 += rows.rows[r][0] * s;
                    damp[p].1 += rows.rows[r][1] * s;
                }
                damp[joint.child].0 += rows.rows[r][2] * s;
                damp[joint.child].1 += rows.rows[r][3] * s;
            }
        }
        let bodies = self.bodies.clone();
        let joints = self.joints.clone();
        self.body_rhs(|b, _, iw| {
            let w = b.omega;
            (g * b.mass, -w.cross(*iw * w))
        });
        for (i, (f, t)) in damp.iter().enumerate() {
            let o = self.solver.as_ref().map_or(0, |s| s.body_offset(i));
            for c in 0..3 {
                self.rhs[o + c] += f[c];
                self.rhs[o + 3 + c] += t[c];
            }
        }
        let twist_of = |joint: &Joint| {
            let tw = |b: Option<usize>| {
                b.map_or((DVec3::ZERO, DVec3::ZERO), |i| {
                    (bodies[i].v, bodies[i].omega)
                })
            };
            let (va, wa) = tw(joint.parent);
            let (vb, wb) = tw(Some(joint.child));
            [va, wa, vb, wb]
        };
        let pose_of = |b: Option<usize>| b.map_or(Pose::IDENTITY, |i| bodies[i].pose);
        let loops = self.assemble(h, false, |j, _, rows, rhs| {
            let joint = &joints[j];
            let u = twist_of(joint);
            let (a, b) = (pose_of(joint.parent), pose_of(Some(joint.child)));
            for r in 0..rows.n_hard {
                let mut w = [0.0; MAX_ROWS];
                w[r] = 1.0;
                let jdot_v = joint.curvature(&a, &b, &w).quadratic(&u);
                let cdot: f64 = (0..4).map(|k| rows.rows[r][k].dot(u[k])).sum();
                rhs[r] = -jdot_v - kx * rows.value[r] - kv * cdot;
            }
        });
        self.solve(loops)?;
        for i in 0..self.bodies.len() {
            let (a, alpha) = self.body_solution(i);
            let b = &mut self.bodies[i];
            b.v += a * h;
            b.omega += alpha * h;
            b.pose.x += b.v * h;
            b.pose.q = rotate_by(b.pose.q, b.omega * h);
        }
        Ok(())
    }

    fn twist(&self, joint: &Joint) -> [DVec3; 4] {
        let tw = |b: Option<usize>| {
            b.map_or((DVec3::ZERO, DVec3::ZERO), |i| {
                (self.bodies[i].v, self.bodies[i].omega)
            })
        };
        let (va, wa) = tw(joint.parent);
        let (vb, wb) = tw(Some(joint.child));
        [va, wa, vb, wb]
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
            None => "none",
        }
    }
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
