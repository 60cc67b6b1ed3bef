//! The acceleration level with Baumgarte stabilisation (Otaduy 2010, "Opción 1").

use alloc::vec::Vec;

use constraint_core::rigid::rotate_by;
use constraint_core::{DVec3, Pose};

use super::*;

/// Buffers the acceleration level reuses from step to step.
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    /// The bodies at the start of the step.
    bodies: Vec<RigidBody>,
    /// Explicit damping, actuator, spring and tendon wrenches per body.
    damp: Vec<(DVec3, DVec3)>,
    /// The actuator, spring and tendon wrenches per body.
    wrench: Vec<(DVec3, DVec3)>,
}

impl World {
    /// `[M Jᵀ; J 0][a; λ] = [f; −J̇v − k_x C − k_v J v]`, then `v' = v + h a`,
    /// `x' = x + h v'`.
    pub(super) fn acceleration_solve(
        &mut self,
        ctx: &StepContext,
        kx: f64,
        kv: f64,
    ) -> Result<(), ArticulatedError> {
        let h = ctx.h();
        let g = self.gravity;
        // Explicit joint damping torques/forces: −d J_dᵀ (J_d v). Buffers reused across
        // steps (no allocation once sized).
        let mut damp = core::mem::take(&mut self.accel.damp);
        damp.clear();
        damp.resize(self.bodies.len(), (DVec3::ZERO, DVec3::ZERO));
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
                let s = -joint.dof_damping(r - rows.n_hard) * rate;
                if let Some(p) = joint.parent {
                    damp[p].0 += rows.rows[r][0] * s;
                    damp[p].1 += rows.rows[r][1] * s;
                }
                damp[joint.child].0 += rows.rows[r][2] * s;
                damp[joint.child].1 += rows.rows[r][3] * s;
            }
        }
        // The state at the start, for the rows' right-hand side (read while the solver
        // is assembled).
        let mut bodies = core::mem::take(&mut self.accel.bodies);
        bodies.clone_from(&self.bodies);
        self.body_rhs(|b, _, iw| {
            let w = b.omega;
            (g * b.mass(), -w.cross(*iw * w))
        });
        let mut wrench = core::mem::take(&mut self.accel.wrench);
        if self.dof_wrenches(&mut wrench) {
            for (d, e) in damp.iter_mut().zip(&wrench) {
                d.0 += e.0;
                d.1 += e.1;
            }
        }
        self.accel.wrench = wrench;
        self.add_fluid_rhs(1.0);
        for (i, (f, t)) in damp.iter().enumerate() {
            let o = self.solver.body_offset(i);
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
        // Compliant joints: explicit spring forces, rows out of the system.
        self.add_spring_rhs(1.0);
        let loops = self.assemble(h, Rates::None, Soft::Free, |_, joint, rows, rhs| {
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
        self.accel.damp = damp;
        self.accel.bodies = bodies;
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

    pub(super) fn twist(&self, joint: &Joint) -> [DVec3; 4] {
        let tw = |b: Option<usize>| {
            b.map_or((DVec3::ZERO, DVec3::ZERO), |i| {
                (self.bodies[i].v, self.bodies[i].omega)
            })
        };
        let (va, wa) = tw(joint.parent);
        let (vb, wb) = tw(Some(joint.child));
        [va, wa, vb, wb]
    }
}
