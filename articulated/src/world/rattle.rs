//! RATTLE (Andersen 1983) for rigid bodies in maximal coordinates, and its fallback.

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

    /// One RATTLE step of `h` (may be negative inside a Yoshida composition). Returns
    /// the projection iterations and whether the projection converged (to `10³ ·
    /// tolerance`, at least 1e-9 m).
    pub(super) fn rattle_step(
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
        self.body_rhs(|b, _, iw| (b.v * b.mass() + g * (b.mass() * half), *iw * b.omega));
        // Compliant joints: half a kick of their spring force at x (Störmer–Verlet); their
        // rows are left out of the kicks and of SHAKE.
        self.add_spring_rhs(half);
        self.add_dof_forces(half);
        self.add_fluid_rhs(half);
        let loops = self.assemble(hd, true, Soft::Free, |_, _, rows, rhs| {
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
        let passive: Vec<usize> = (0..self.joints.len())
            .map(|j| self.passive_rows_of(j))
            .collect();
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
        self.body_rhs(|b, _, _| (b.v * b.mass() + g * (b.mass() * half), DVec3::ZERO));
        {
            let solver = &self.solver;
            for (i, l) in momenta.iter().enumerate() {
                let o = solver.body_offset(i) + 3;
                self.rhs[o..o + 3].copy_from_slice(&l.to_array());
            }
        }
        self.add_spring_rhs(half);
        self.add_dof_forces(half);
        self.add_fluid_rhs(half);
        let loops = self.assemble(hd, true, Soft::Free, |_, _, _, _| {});
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
