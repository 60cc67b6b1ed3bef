//! The velocity level (Otaduy 2010, "Opción 2"): `[M Jᵀ; J −C][v'; λ] = [M v + h f; −β C/h]`,
//! with the joints' geometric stiffness where the explicit treatment would be unstable.
//!
//! RATTLE's fallback (steps with one-sided rows, projected after) aims the joint rows at
//! the end of the step instead ([`Aim::EndOfStep`], issue 13): `x + h v'` then misses
//! the joints by `O(h²ω|v' − v|)` instead of `(ωh)²r/2`, and the projection often has
//! nothing left to do (`simulate`, callgrind on `World::step`: gymnasium pusher
//! perturbed 81 → 0 Newton factorizations in 200 steps, dm manipulator controlled
//! 1,811 → 330 in 2,000, World::step −11 % and −20 %). Where the step is large against
//! the bodies' speed changes (contacts and actuators at 10 ms: the controlled runs of
//! gymnasium pusher and half_cheetah, dm cheetah, walker and hopper) the projection
//! still needs its Newton step, and the prediction (a joint evaluation at the moved
//! poses and `J v` per joint, about one error evaluation) costs up to 5 % (pusher).
//! Rows assembled at the predicted poses leave less (the projection's chord steps on
//! half_cheetah controlled halve), but their impulses damp the joints' turning:
//! opt-in, [`World::set_end_of_step_rows_predicted`].
//!
//! Tried and left out: the drift the last aimed step left (`C(x') + d̂` at its
//! projection's start) taken off this step's aim as its estimate `d̂` (the impulses stay
//! along the start rows). Under contacts and actuators the drift is not smooth from step
//! to step: half_cheetah controlled chord steps 147 → 136, dm hopper passive Newton
//! steps 357 → 311, but World::step instructions dm cheetah controlled 36.12M → 36.72M,
//! walker controlled 127.9M → 133.7M.

use alloc::vec;
use alloc::vec::Vec;

use constraint_core::rigid::rotate_by;
use constraint_core::{DQuat, DVec3, Pose};

use super::*;

/// Where the velocity level aims the hard joint rows `J v' = b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Aim {
    /// `b = −β C(x₀)/h` (the lecture's Opción 2): `C(x₀ + h v') = O(h²)` for a moving
    /// model, since `J` is the Jacobian at the start and the joints curve.
    Start(f64),
    /// `b = J v − C(x₀ + h v)/h`, the predictor: from `C(x₀ + h v') ≈ C(x₀ + h v) +
    /// h J (v' − v)` the end-of-step position `x₀ + h v'` meets the joints to
    /// `O(h² |v' − v|) = O(h³)` (the curvature along the start twist is in
    /// `C(x₀ + h v)`, evaluated at the pose the update `x' = x + h v'`,
    /// `R' = exp(h ω') R` gives for `v' = v`). Compliant joints keep `−C(x₀)/h`
    /// (their spring is the compliance's), equality rows too, and so do joints whose
    /// drift along the start twist is negligible (`World::predict_joint_values`).
    EndOfStep,
}

/// [`Aim::EndOfStep`]'s per-joint figures, reused from step to step.
#[derive(Clone, Debug, Default)]
pub(super) struct AimScratch {
    /// Per joint: `C(x₀ + h v)` (`None`: aimed at the start, a compliant joint or one
    /// whose drift is negligible).
    joints: Vec<Option<[f64; MAX_ROWS]>>,
    /// Per body: the pose moved by its start twist, where a predicted joint needed it.
    moved: Vec<Option<Pose>>,
    /// Per body: the start twist `(v, ω)` (with the predicted rows: the predicted twist
    /// `u`, the start twist or zero for a body linearized where it is).
    twists: Vec<(DVec3, DVec3)>,
    /// Whether the aim assembles the rows at the predicted poses
    /// ([`World::set_end_of_step_rows_predicted`]; off by default).
    predict_rows: bool,
    /// Whether this step's rows were assembled at the predicted poses (the update then
    /// turns the bodies from there).
    rows_predicted: bool,
    /// The bodies moved to their predicted poses, with their start poses.
    start_poses: Vec<(usize, Pose)>,
    /// Per body: the predicted orientation `exp(h ω) R` (`None`: a body linearized
    /// where it is, at `R`).
    predicted: Vec<Option<DQuat>>,
}

impl World {
    /// `[M Jᵀ; J −C][v'; λ] = [M v + h f; −β C/h]`, then `x' = x + h v'`.
    pub(super) fn velocity_solve(
        &mut self,
        ctx: &StepContext,
        beta: f64,
    ) -> Result<(), ArticulatedError> {
        self.velocity_solve_aimed(ctx, Aim::Start(beta))
    }

    /// [`Self::velocity_solve`] with the hard rows aimed by `aim`.
    pub(super) fn velocity_solve_aimed(
        &mut self,
        ctx: &StepContext,
        aim: Aim,
    ) -> Result<(), ArticulatedError> {
        let h = ctx.h();
        if !self.urows.is_empty() && self.unilateral.sparse {
            // The one-sided rows in the tree factor by an active set; the dense path
            // where that does not apply or does not settle.
            let loops = self.velocity_assemble(ctx, aim);
            // Loop joints go by their Schur complement on the dense path only; equality
            // rows are the active set's always-active Schur rows (`world/active_set.rs`).
            if loops.0.is_empty() && self.solve_unilateral_sparse() {
                self.last_loops = loops;
            } else {
                self.ustats.dense_fallback = true;
                self.solve(loops)?;
                self.store_impulses();
                let loops = core::mem::take(&mut self.last_loops);
                let out = self.solve_unilateral(&loops);
                self.last_loops = loops;
                out?;
                self.remember_dense_statuses();
            }
            self.store_impulses();
            #[cfg(feature = "contact")]
            self.store_warm_contacts();
        } else {
            self.velocity_system_solve(ctx, aim)?;
        }
        if !self.urows.is_empty() && !self.unilateral.sparse {
            // One-sided rows through the factored joint system: x' = x_free + Y z.
            let loops = core::mem::take(&mut self.last_loops);
            let out = self.solve_unilateral(&loops);
            self.last_loops = loops;
            out?;
            self.store_impulses();
            #[cfg(feature = "contact")]
            self.store_warm_contacts();
        }
        if core::mem::take(&mut self.aim.rows_predicted) {
            self.update_from_predicted(h);
            return Ok(());
        }
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
    ///
    /// # Errors
    /// [`ArticulatedError::InvalidParameter`] for a time step that
    /// [`StepContext::new`] rejects, or the solver's errors.
    pub fn velocity_twists(
        &mut self,
        h: f64,
        beta: f64,
    ) -> Result<Vec<(DVec3, DVec3)>, ArticulatedError> {
        let ctx = step_context(h)?;
        self.ensure_solver();
        self.velocity_system_solve(&ctx, Aim::Start(beta))?;
        Ok((0..self.bodies.len())
            .map(|i| self.body_solution(i))
            .collect())
    }

    /// The velocity-level KKT system of [`Self::velocity_twists`] as one dense matrix
    /// (all joints' rows, loop joints included, damping rows with compliance
    /// `1/(h d)`, compliant joints' hard rows with `α/h²`): unknowns `[v₀, ω₀, v₁, ω₁, …, λ]`. A reference for tests and for
    /// tiny systems; `O(n²)` memory. Equality rows ([`World::add_equality`]) are not in
    /// it (they are not joint rows; [`Self::velocity_twists`] does enforce them).
    pub fn dense_velocity_system(&self, h: f64, beta: f64) -> (Vec<Vec<f64>>, Vec<f64>) {
        let nb = self.bodies.len();
        let rows: usize = self
            .joints
            .iter()
            .enumerate()
            .map(|(ji, j)| j.hard_rows() + self.passive_rows_of(ji))
            .sum();
        let n = 6 * nb + rows;
        let mut m = vec![vec![0.0; n]; n];
        let mut rhs = vec![0.0; n];
        for (i, b) in self.bodies.iter().enumerate() {
            let iw = b.world_inertia();
            let w = b.gyroscopic_step(h);
            let lin = b.v * b.mass() + self.gravity * (b.mass() * h);
            let ang = iw * w;
            for k in 0..3 {
                m[6 * i + k][6 * i + k] = b.mass();
                for l in 0..3 {
                    m[6 * i + 3 + k][6 * i + 3 + l] = iw.col(l)[k];
                }
                rhs[6 * i + k] = lin[k];
                rhs[6 * i + 3 + k] = ang[k];
            }
        }
        let mut r0 = 6 * nb;
        for (ji, (joint, &alpha)) in self.joints.iter().zip(&self.compliance).enumerate() {
            let a = self.pose(joint.parent);
            let b = self.pose(Some(joint.child));
            let jr = joint.rows_with(&a, &b, self.passive_rows_of(ji) > 0);
            let tw = self.twist(joint);
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
                    let k = r - jr.n_hard;
                    let s = self.armature[ji][k] + h * joint.dof_damping(k);
                    if s > 0.0 {
                        m[row][row] = -1.0 / s;
                        let g = jr.rows[r];
                        let rate: f64 = (0..4).map(|q| g[q].dot(tw[q])).sum();
                        rhs[row] = self.armature[ji][k] / s * rate;
                    } else {
                        // A decoupled row (λ = 0): zero Jacobian, unit compliance.
                        for body in [joint.parent, Some(joint.child)].into_iter().flatten() {
                            for c in 0..6 {
                                m[row][6 * body + c] = 0.0;
                                m[6 * body + c][row] = 0.0;
                            }
                        }
                        m[row][row] = -1.0;
                    }
                } else {
                    rhs[row] = -beta * jr.value[r] / h;
                    if alpha > 0.0 {
                        m[row][row] = -alpha / (h * h);
                    }
                }
            }
            r0 += jr.n;
        }
        (m, rhs)
    }

    pub(super) fn velocity_system_solve(
        &mut self,
        ctx: &StepContext,
        aim: Aim,
    ) -> Result<(), ArticulatedError> {
        let loops = self.velocity_assemble(ctx, aim);
        self.solve(loops)?;
        self.store_impulses();
        Ok(())
    }

    /// Fills [`AimScratch`] for [`Aim::EndOfStep`]: each hard joint's `C` at the
    /// bodies moved by their start twists (`x + h v`, `R ← exp(h ω) R`, as
    /// [`Self::velocity_solve_aimed`] moves them), and the start twists.
    ///
    /// A joint whose drift along the start twist is negligible keeps the start aim: the
    /// aims differ by `J v − (C(x + h v) − C(x))/h = −(h/2) uᵀ∇²C u + O(h²)`, which
    /// moves the end of the step by at most `h² lever (|ω_a|² + |ω_b|²)`
    /// ([`Joint::lever`] bounds `|∇²C_r| ≤ 2 lever`; `C` is linear in the positions), and
    /// under a tenth of the unilateral tolerance that is not worth a joint evaluation
    /// (gymnasium pusher passive, at rest: +9.9 % World::step instructions without this).
    fn predict_joint_values(&mut self, h: f64) {
        let mut joints = core::mem::take(&mut self.aim.joints);
        let mut moved = core::mem::take(&mut self.aim.moved);
        joints.clear();
        moved.clear();
        moved.resize(self.bodies.len(), None);
        self.aim.twists.clear();
        self.aim
            .twists
            .extend(self.bodies.iter().map(|b| (b.v, b.omega)));
        let negligible = 0.1 * self.unilateral_tolerance;
        let spin = |b: Option<usize>| b.map_or(0.0, |i| self.bodies[i].omega.length_squared());
        for (j, joint) in self.joints.iter().enumerate() {
            let drift = h * h * joint.lever() * (spin(joint.parent) + spin(Some(joint.child)));
            // `!(drift > negligible)`: a NaN twist keeps the start aim (the step's
            // divergence check reports it).
            if self.is_soft(j) || !(drift > negligible) {
                joints.push(None);
                continue;
            }
            let mut at = |b: Option<usize>| {
                b.map_or(Pose::IDENTITY, |i| {
                    *moved[i].get_or_insert_with(|| {
                        let b = &self.bodies[i];
                        Pose {
                            x: b.pose.x + b.v * h,
                            q: rotate_by(b.pose.q, b.omega * h),
                        }
                    })
                })
            };
            let (a, b) = (at(joint.parent), at(Some(joint.child)));
            joints.push(Some(joint.value(&a, &b)));
        }
        self.aim.moved = moved;
        self.aim.joints = joints;
    }

    /// Whether the end-of-step aim ([`World::set_end_of_step_aim`]) assembles the
    /// joints' rows at the predicted poses ([`World::set_end_of_step_rows_predicted`]).
    pub fn end_of_step_rows_predicted(&self) -> bool {
        self.aim.predict_rows
    }

    /// With `on`, RATTLE's velocity-level fallback (the end-of-step aim,
    /// [`World::set_end_of_step_aim`]) assembles the
    /// joints' rows at the poses the start twists move the bodies to, `x_p = (x + h v,
    /// exp(h ω) R)`, aims them at `J_p v − C(x_p)/h`, and turns the bodies from there,
    /// `R' = exp(h (ω' − ω)) R_p`: the end of the step then meets the joints to
    /// `O(h² |v' − v|²)`, where the rows at the start leave `O(h² |v| |v' − v|)`, and
    /// the projection after it has less to do. Off by default: the constraint impulses
    /// then act along the predicted rows, not the start's (SHAKE's), which damps the
    /// turning of the joints by about `¾ (ω h)²` of its kinetic energy a step (a
    /// pendulum: `v'` keeps `cos(ω h)` of `v` across the predicted normal).
    ///
    /// Measured (`simulate … --duration 2`, callgrind on `World::step`, off → on):
    /// gymnasium half_cheetah controlled 34.64M → 33.14M instructions (chord steps 147 →
    /// 76 in 169 projections), dm cheetah controlled 36.12M → 34.52M, dm hopper passive
    /// 53.16M → 45.72M (Newton steps 357 → 152 in 391), walker controlled 127.9M →
    /// 126.4M, pusher controlled 39.73M → 38.97M (its start separation ~1e-6 → ~1.5e-7
    /// m, still one Newton step), dm humanoid passive 328.2M → 282.8M, humanoid_CMU
    /// passive 0.5 s 213.7M → 182.1M, controlled 379.8M → 391.6M; the models' checks pass
    /// (`cargo xtask models run`, six contact models), settled penetrations fall
    /// (half_cheetah controlled 1e-4 → 0 m, walker controlled 4.3e-5 → 8.0e-7 m). The
    /// undamped chain of `tests/end_of_step_aim.rs` at 10 ms: no projection iteration in
    /// 1,000 steps (992 off), but `|E − E₀|` 3.7e-2 J → 1.4 J over 10 s and 3.1 J over
    /// 50 s (growing; the start-aimed step 0.48 J); at 1 ms 3.7e-3 → 5.9e-2 J.
    pub fn set_end_of_step_rows_predicted(&mut self, on: bool) {
        self.aim.predict_rows = on;
    }

    /// The update after rows assembled at the predicted poses
    /// ([`Self::assemble_at_predicted`]): `x' = x + h v'`, `R' = exp(h (ω' − u_ω)) R_p`
    /// (`u` the predicted twist; a body linearized where it is: `exp(h ω') R`).
    fn update_from_predicted(&mut self, h: f64) {
        for i in 0..self.bodies.len() {
            let (v, w) = self.body_solution(i);
            let b = &mut self.bodies[i];
            b.pose.x += v * h;
            b.pose.q = match self.aim.predicted.get(i) {
                Some(Some(q)) => rotate_by(*q, (w - self.aim.twists[i].1) * h),
                _ => rotate_by(b.pose.q, w * h),
            };
            b.v = v;
            b.omega = w;
        }
    }

    /// Loads the velocity-level system (bodies, joints, forces, equality rows) into the
    /// solver and `self.rhs` without factoring it; returns the loop rows.
    fn velocity_assemble(&mut self, ctx: &StepContext, aim: Aim) -> LoopRows {
        let h = ctx.h();
        // Set again by `assemble_at_predicted` (a step that failed after it must not
        // leave it for the next update).
        self.aim.rows_predicted = false;
        let predicted_rows = aim == Aim::EndOfStep && self.aim.predict_rows;
        if aim == Aim::EndOfStep && !predicted_rows {
            self.predict_joint_values(h);
        }
        let g = self.gravity;
        self.body_rhs(|b, r, iw| {
            let w = b.gyroscopic_step_with(r, h);
            (b.v * b.mass() + g * (b.mass() * h), *iw * w)
        });
        self.add_dof_forces(h);
        self.add_fluid_rhs(h);
        if self.geometric_stiffness != GeometricStiffness::Off
            && self.impulses.len() == self.joints.len()
        {
            self.add_geometric_stiffness(ctx);
        }
        if predicted_rows {
            let loops = self.assemble_at_predicted(h);
            self.load_equalities(|c| -c / h);
            return loops;
        }
        let aimed = core::mem::take(&mut self.aim.joints);
        let twists = core::mem::take(&mut self.aim.twists);
        let twist = |b: Option<usize>| b.map_or((DVec3::ZERO, DVec3::ZERO), |i| twists[i]);
        let loops = self.assemble(h, Rates::Full, Soft::Implicit, |j, joint, rows, rhs| {
            match aim {
                Aim::Start(beta) => {
                    for r in 0..rows.n_hard {
                        rhs[r] = -beta * rows.value[r] / h;
                    }
                }
                Aim::EndOfStep => match aimed.get(j).and_then(Option::as_ref) {
                    // J v − C(x + h v)/h.
                    Some(c) => {
                        let (va, wa) = twist(joint.parent);
                        let (vb, wb) = twist(Some(joint.child));
                        for r in 0..rows.n_hard {
                            let g = &rows.rows[r];
                            let rate = g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb);
                            rhs[r] = rate - c[r] / h;
                        }
                    }
                    None => {
                        for r in 0..rows.n_hard {
                            rhs[r] = -rows.value[r] / h;
                        }
                    }
                },
            }
        });
        self.aim.joints = aimed;
        self.aim.twists = twists;
        let beta = match aim {
            Aim::Start(beta) => beta,
            Aim::EndOfStep => 1.0,
        };
        self.load_equalities(|c| -beta * c / h);
        loops
    }

    /// The joints' rows of [`Aim::EndOfStep`] with the predicted rows
    /// ([`Self::set_end_of_step_rows_predicted`]): assembled at the predicted poses
    /// `x_p = (x + h v, exp(h ω) R)`, with `b = J_p v − C(x_p)/h`; the update then turns
    /// the bodies from `R_p` ([`Self::update_from_predicted`]), so `C(x') = C(x_p) +
    /// h J_p (v' − v) + O(h² |v' − v|²)`. Compliant joints keep `−C(x₀)/h` at the start
    /// poses. The bodies are back at their start poses on return (bit for bit); the
    /// rate rows (damping, armature) are those at the predicted poses too.
    fn assemble_at_predicted(&mut self, h: f64) -> LoopRows {
        // Compliant joints' values at the start poses, before any body moves.
        let mut soft = core::mem::take(&mut self.aim.joints);
        soft.clear();
        let pose = |b: Option<usize>| b.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
        for (j, joint) in self.joints.iter().enumerate() {
            soft.push(
                self.is_soft(j)
                    .then(|| joint.value(&pose(joint.parent), &pose(Some(joint.child)))),
            );
        }
        let mut moved = core::mem::take(&mut self.aim.start_poses);
        let mut predicted = core::mem::take(&mut self.aim.predicted);
        let mut twists = core::mem::take(&mut self.aim.twists);
        moved.clear();
        predicted.clear();
        twists.clear();
        // A body whose turn over the step curves no joint by more than a twentieth of
        // the unilateral tolerance, `h² lever |ω|²` (`Joint::lever` bounds `|∇²C_r| ≤
        // 2 lever`; `C` is linear in the positions), is linearized where it is, with a
        // zero predicted twist: its rows and the update are the start aim's, the same
        // bits (gymnasium pusher passive, at rest: the rows' cache then hits, and no
        // rotation is predicted). `!(… > …)`: a NaN twist stays at the start (the step's
        // divergence check reports it).
        let lever = self.joints.iter().map(Joint::lever).fold(0.0, f64::max);
        let negligible = 0.05 * self.unilateral_tolerance;
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if h * h * lever * b.omega.length_squared() > negligible {
                moved.push((i, b.pose));
                twists.push((b.v, b.omega));
                b.pose = Pose {
                    x: b.pose.x + b.v * h,
                    q: rotate_by(b.pose.q, b.omega * h),
                };
                predicted.push(Some(b.pose.q));
            } else {
                twists.push((DVec3::ZERO, DVec3::ZERO));
                predicted.push(None);
            }
        }
        let twist = |b: Option<usize>| b.map_or((DVec3::ZERO, DVec3::ZERO), |i| twists[i]);
        let loops = self.assemble(h, Rates::Full, Soft::Implicit, |j, joint, rows, rhs| {
            match soft.get(j).and_then(Option::as_ref) {
                // J_p u − C(x_p)/h (`u` the predicted twists; both zero: the start
                // aim's `−C(x₀)/h`).
                None => {
                    let (va, wa) = twist(joint.parent);
                    let (vb, wb) = twist(Some(joint.child));
                    if [va, wa, vb, wb] == [DVec3::ZERO; 4] {
                        for r in 0..rows.n_hard {
                            rhs[r] = -rows.value[r] / h;
                        }
                        return;
                    }
                    for r in 0..rows.n_hard {
                        let g = &rows.rows[r];
                        let rate = g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb);
                        rhs[r] = rate - rows.value[r] / h;
                    }
                }
                Some(c) => {
                    for r in 0..rows.n_hard {
                        rhs[r] = -c[r] / h;
                    }
                }
            }
        });
        for &(i, p) in &moved {
            self.bodies[i].pose = p;
        }
        self.aim.start_poses = moved;
        self.aim.rows_predicted = true;
        self.aim.predicted = predicted;
        self.aim.twists = twists;
        self.aim.joints = soft;
        loops
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
    pub(super) fn add_geometric_stiffness(&mut self, ctx: &StepContext) {
        let h = ctx.h();
        let threshold = match self.geometric_stiffness {
            GeometricStiffness::Off => return,
            GeometricStiffness::Always => 0.0,
            GeometricStiffness::Auto { ratio } => ratio,
        };
        // h² K with K = Σ (λ_r/h) ∂²C_r (λ are impulses): h Σ λ_r ∂²C_r.
        let solver = &mut self.solver;
        for (j, joint) in self.joints.iter().enumerate() {
            let lam = &self.impulses[j];
            // Cheap bound first: |h Σ λ_r ∂²C_r| ≤ 2 h lever Σ|λ_r|.
            let bound = 2.0 * h * joint.lever() * lam.iter().map(|l| l.abs()).sum::<f64>();
            let i_min = |b: Option<usize>| {
                b.map_or(f64::INFINITY, |i| self.bodies[i].min_principal_inertia())
            };
            if !(bound > threshold * i_min(joint.parent).min(i_min(Some(joint.child)))) {
                continue;
            }
            let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
            let b = self.bodies[joint.child].pose;
            // A side's block is added below only when `‖h K‖_F` is at least half its
            // limit and the largest eigenvalue of its PSD part is over the limit. A
            // bound on both blocks' norms (a hinge's or a weld's,
            // `Joint::angular_curvature_bounds`) under half the limit, with a margin of
            // 1e-9 for the round-off of `h K`, shows that neither side is added, so the
            // curvature is not computed (gymnasium half_cheetah controlled: none of its
            // 630 curvatures added a block). Where that cheap bound fails, the blocks'
            // bounds from their terms (`Joint::angular_block_bounds`, round-off
            // included) decide per side, on the norm or on the eigenvalue (gymnasium
            // pusher controlled: 751 curvatures computed without them, 270 with the
            // norms alone, 45 with both). They cost about a sixth of a curvature and
            // its eigen-solve, and are tried wherever the cheap bound fails: gating
            // them on that bound's ratio to its test (under 8) lost more than it saved
            // (humanoid_CMU passive: 180 of its 370 joints at ratios 16 to 2048 skip).
            let below_norm = |bound: [f64; 2], side: usize, body: Option<usize>| {
                body.is_none_or(|i| {
                    bound[side] * h * (1.0 + 1e-9)
                        < 0.5 * threshold * self.bodies[i].min_principal_inertia()
                })
            };
            if let Some(bound) = joint.angular_curvature_bounds(&a, &b, lam) {
                if below_norm(bound, 0, joint.parent) && below_norm(bound, 1, Some(joint.child)) {
                    continue;
                }
            }
            if let Some(bb) = joint.angular_block_bounds(&a, &b, lam) {
                let not_added = |side: usize, body: Option<usize>| {
                    let norms = [bb[0].frobenius, bb[1].frobenius];
                    below_norm(norms, side, body)
                        || body.is_none_or(|i| {
                            bb[side].max_eigenvalue * h * (1.0 + 1e-9)
                                < threshold * self.bodies[i].min_principal_inertia()
                        })
                };
                if not_added(0, joint.parent) && not_added(1, Some(joint.child)) {
                    continue;
                }
            }
            let k = joint.curvature(&a, &b, lam);
            for (side, body) in [(0usize, joint.parent), (1usize, Some(joint.child))] {
                let Some(i) = body else { continue };
                let limit = threshold * self.bodies[i].min_principal_inertia();
                let raw = k.blocks[2 * side + 1][2 * side + 1] * h;
                // The largest eigenvalue of the PSD part is at most the spectral norm,
                // `λ_max(A⁺) ≤ ‖A‖₂ ≤ ‖A‖_F`: a block whose Frobenius norm is under half
                // the limit cannot pass the test below (the eigen-solve's round-off is
                // ~1e-15‖A‖, far inside the factor 2), so it is skipped without the
                // eigen-decomposition (gymnasium pusher controlled: 34 of 2,736 sides pass).
                if frobenius_sq(&raw) < 0.25 * limit * limit {
                    continue;
                }
                let tt = crate::body::psd_part(&raw);
                // (hω)² of the stiffest rotational mode this term describes, against the
                // body's smallest principal moment.
                let t_max = crate::body::symmetric_eigenvalues(&tt)[2];
                if t_max > limit {
                    let xx = crate::body::psd_part(&(k.blocks[2 * side][2 * side] * h));
                    solver.add_body_blocks(i, &xx, &tt);
                }
            }
        }
    }

    /// Copies the hard-row multipliers of the last solve (tree joints from the solution,
    /// loop joints from the loop multipliers, in joint order).
    pub(super) fn store_impulses(&mut self) {
        let solver = &self.solver;
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
}

/// `‖A‖_F² = Σ_ij a_ij²` of a 3×3 matrix (a bound on its squared spectral norm).
fn frobenius_sq(a: &constraint_core::DMat3) -> f64 {
    let sq = |c: DVec3| c.dot(c);
    sq(a.x_axis) + sq(a.y_axis) + sq(a.z_axis)
}
