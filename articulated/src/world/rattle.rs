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
//! * The old kicks (backward-Euler damping at `v½` and at `v'`) gave
//!   `(1 + hA/2)⁻² = 1 − hA + ¾ h²A² + …`, an `O(h²)` local error: first order.

use alloc::vec::Vec;

use constraint_core::rigid::rotate_by;
use constraint_core::{DVec3, Pose};

use super::*;

impl World {
    /// Restores the start of the step and redoes it with the velocity level (with its geometric
    /// stiffness), then projects the positions back onto the joints (`tolerance`), so a
    /// fallback step keeps the joints as tight as a RATTLE step.
    pub(super) fn fall_back(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
        stats: &mut StepStats,
    ) -> Result<(), ArticulatedError> {
        // Back to the start of the step (saved by `World::step`).
        self.restore_start();
        stats.fallbacks += 1;
        self.velocity_solve(h, 1.0)?;
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
    pub(super) fn rattle_step(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<(usize, bool), ArticulatedError> {
        if !self.joints.iter().any(|j| j.damping_rows() > 0) {
            return self.conservative_step(h, tolerance, max_iterations, true);
        }
        let w1 = 1.0 / (2.0 - libm::cbrt(2.0));
        let w0 = 1.0 - 2.0 * w1;
        if h < 0.0 {
            let full = h / w0;
            self.restore_start();
            self.damp(0.5 * full, false)?;
            let (first, ok) = self.conservative_step(w1 * full, tolerance, max_iterations, true)?;
            if !ok {
                return Ok((first, false));
            }
            let (middle, ok) = self.conservative_step(h, tolerance, max_iterations, true)?;
            return Ok((first + middle, ok));
        }
        if self.bodies == self.saved {
            self.damp(0.5 * h, true)?;
            let (it, ok) = self.conservative_step(h, tolerance, max_iterations, false)?;
            if ok {
                self.damp(0.5 * h, true)?;
            }
            return Ok((it, ok));
        }
        let (it, ok) = self.conservative_step(h, tolerance, max_iterations, true)?;
        if ok {
            self.damp(0.5 * h / w1, false)?;
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
    pub(super) fn damp(&mut self, tau: f64, forces: bool) -> Result<(), ArticulatedError> {
        if !(tau > 0.0) {
            return Ok(());
        }
        let gamma = 1.0 - core::f64::consts::FRAC_1_SQRT_2;
        // (1 − γ)/γ = 1 + √2.
        let c = (1.0 - gamma) / gamma;
        let s = gamma * tau;
        let g = if forces { self.gravity } else { DVec3::ZERO };
        // Stage 1: v₁ = BE_{γτ}(v).
        self.body_rhs(|b, _, iw| (b.v * b.mass() + g * (b.mass() * s), *iw * b.omega));
        if forces {
            self.add_spring_rhs(s);
            self.add_dof_forces(s);
            self.add_fluid_rhs(s);
        }
        let loops = self.assemble(s, Rates::Full, Soft::Free, |_, _, _, _| {});
        // Equality rows hold their rate (`E v = 0`) through the damping flow.
        self.load_equalities(|_| 0.0);
        let loops_2 = loops.clone();
        self.solve(loops)?;
        // Stage 2: v' = BE_{γτ}(v + c (v₁ − v)), same factor; all row right-hand sides 0.
        let stage: Vec<(DVec3, DVec3)> = (0..self.bodies.len())
            .map(|i| {
                let (v1, w1) = self.body_solution(i);
                let b = &self.bodies[i];
                (b.v + (v1 - b.v) * c, b.omega + (w1 - b.omega) * c)
            })
            .collect();
        let size = self.solver.size;
        self.rhs.clear();
        self.rhs.resize(size, 0.0);
        for (i, (v, w)) in stage.iter().enumerate() {
            let b = &self.bodies[i];
            let r = b.rotation();
            let iw = r * b.inertia() * r.transpose();
            let o = self.solver.body_offset(i);
            let lin = *v * b.mass() + g * (b.mass() * s);
            self.rhs[o..o + 3].copy_from_slice(&lin.to_array());
            self.rhs[o + 3..o + 6].copy_from_slice(&(iw * *w).to_array());
        }
        if forces {
            self.add_spring_rhs(s);
            self.add_dof_forces(s);
            self.add_fluid_rhs(s);
        }
        self.armature_rhs(s, &stage);
        self.solve_factored(&loops_2)?;
        for i in 0..self.bodies.len() {
            let (v, w) = self.body_solution(i);
            self.bodies[i].v = v;
            self.bodies[i].omega = w;
        }
        Ok(())
    }

    /// `C_h`: one undamped RATTLE step of `h` (may be negative inside a Yoshida
    /// composition); the damping rows are left out (decoupled, `λ_d = 0`); without
    /// `forces` also gravity and the springs (`C⁰_h`, constraints only). Returns the
    /// projection iterations and whether the projection converged (to `10³ ·
    /// tolerance`, at least 1e-9 m).
    pub(super) fn conservative_step(
        &mut self,
        h: f64,
        tolerance: f64,
        max_iterations: usize,
        forces: bool,
    ) -> Result<(usize, bool), ArticulatedError> {
        let g = if forces { self.gravity } else { DVec3::ZERO };
        let half = 0.5 * h;
        // Damping rows stay out (with_damping = false): their compliance is unused.
        let hd = half.abs();
        // 1. Half kick with the constraint impulse that makes the drift land on the
        //    linearised manifold: [M Jᵀ; J −C][v½; λ] = [M v + (h/2) m g; −C(x)/h].
        self.body_rhs(|b, _, iw| (b.v * b.mass() + g * (b.mass() * half), *iw * b.omega));
        // Compliant joints: half a kick of their spring force at x (Störmer–Verlet); their
        // rows are left out of the kicks and of SHAKE.
        if forces {
            self.add_spring_rhs(half);
            self.add_dof_forces(half);
            self.add_fluid_rhs(half);
        }
        // Armature rows stay (inertia on the coordinates), damping rows out.
        let loops = self.assemble(hd, Rates::Armature, Soft::Free, |_, _, rows, rhs| {
            for r in 0..rows.n_hard {
                rhs[r] = -rows.value[r] / h;
            }
        });
        // Equality rows as the joints: `−C/h` in the kick, `−C` in SHAKE (with the
        // start-of-step Jacobian), `0` in the final velocity projection.
        self.load_equalities(|c| -c / h);
        let loops_n = loops.clone();
        self.solve(loops)?;
        self.store_impulses();
        let first_kick = self.impulses.clone();
        let start: Vec<Pose> = self.bodies.iter().map(|b| b.pose).collect();
        // Armature: the coordinate rates at the half step, `G(x₀) v½`, carried to the
        // second kick like the angular momenta (with SHAKE's corrections), so that its
        // rows close on `I_a q̇' = I_a q̇½ + …` (time-symmetric, second order).
        let mut arm: Vec<(usize, crate::joint::JointRows, [f64; MAX_ROWS])> = Vec::new();
        for (j, joint) in self.joints.iter().enumerate() {
            if !self.armature[j].iter().any(|v| *v > 0.0) || self.solver.joint_offset(j).is_none() {
                continue;
            }
            let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
            let b = self.bodies[joint.child].pose;
            let rows = joint.rows_with(&a, &b, true);
            let mut rate = [0.0; MAX_ROWS];
            let tw =
                |i: Option<usize>| i.map_or((DVec3::ZERO, DVec3::ZERO), |i| self.body_solution(i));
            let ((va, wa), (vb, wb)) = (tw(joint.parent), tw(Some(joint.child)));
            for r in rows.n_hard..rows.n {
                let g = rows.rows[r];
                rate[r] = g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb);
            }
            arm.push((j, rows, rate));
        }
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
        // Rate-row counts of the loop joints' rows (no allocation without loops).
        let passive: Vec<usize> = if self.solver.loops.is_empty() {
            Vec::new()
        } else {
            (0..self.joints.len())
                .map(|j| self.passive_rows_of(j))
                .collect()
        };
        let mut iterations = 0;
        let mut final_err = 0.0;
        for it in 0..=max_iterations {
            let mut err: f64 = 0.0;
            let mut loop_rhs = Vec::new();
            let size = self.solver.size;
            self.rhs.clear();
            self.rhs.resize(size, 0.0);
            let solver = &self.solver;
            for (j, joint) in self.joints.iter().enumerate() {
                let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
                let b = self.bodies[joint.child].pose;
                let c = if self.compliance.get(j).is_some_and(|&a| a > 0.0) {
                    [0.0; MAX_ROWS]
                } else {
                    err = err.max(joint.separation(&a, &b));
                    joint.value(&a, &b)
                };
                let n = joint.hard_rows();
                match solver.joint_offset(j) {
                    Some(o) => {
                        for r in 0..n {
                            self.rhs[o + r] = -c[r];
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
            for (j, rows, rate) in &mut arm {
                let joint = &self.joints[*j];
                let tw = |i: Option<usize>| {
                    i.map_or((DVec3::ZERO, DVec3::ZERO), |i| {
                        let (dx, dth) = self.body_solution(i);
                        (dx / h, dth / h)
                    })
                };
                let ((va, wa), (vb, wb)) = (tw(joint.parent), tw(Some(joint.child)));
                for r in rows.n_hard..rows.n {
                    let g = rows.rows[r];
                    rate[r] += g[0].dot(va) + g[1].dot(wa) + g[2].dot(vb) + g[3].dot(wb);
                }
            }
        }
        // 4. Half kick and the velocity constraint at the new configuration:
        //    [M Jᵀ; J −C][v'; μ] = [M v½ + (h/2) m g; 0], angular part L½.
        self.body_rhs(|b, _, _| (b.v * b.mass() + g * (b.mass() * half), DVec3::ZERO));
        {
            let solver = &self.solver;
            for (i, l) in momenta.iter().enumerate() {
                let o = solver.body_offset(i) + 3;
                self.rhs[o..o + 3].copy_from_slice(&l.to_array());
            }
        }
        if forces {
            self.add_spring_rhs(half);
            self.add_dof_forces(half);
            self.add_fluid_rhs(half);
        }
        let loops = self.assemble(hd, Rates::Armature, Soft::Free, |_, _, _, _| {});
        self.load_equalities(|_| 0.0);
        for (j, rows, rate) in &arm {
            if let Some(o) = self.solver.joint_offset(*j) {
                for r in rows.n_hard..rows.n {
                    if self.armature[*j][r - rows.n_hard] > 0.0 {
                        self.rhs[o + r] = rate[r];
                    }
                }
            }
        }
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
}
