//! Forces on joint coordinates: actuators (MuJoCo's `motor`, `position`, `velocity`
//! and `general` with fixed gain and affine bias) and joint springs (`stiffness`,
//! `springref`).
//!
//! A degree of freedom `k` of a joint has a coordinate `q_k` (hinge angle, slide
//! displacement, a compound joint's coordinate) and a rate row `G_k` with
//! `q̇_k = G_k v`. A generalized force `τ_k` on it is the body wrench `G_kᵀ τ_k` — equal
//! and opposite on the two bodies, so internal forces and torques sum to zero. Each
//! step adds the impulse `h G_kᵀ τ_k` at the start-of-step state (explicit, as MuJoCo's
//! Euler integrator treats actuator and spring forces), with
//!
//! ```text
//! actuator:  s = clamp(gain·u + b₀ + b₁·(g q) + b₂·(g q̇), forcerange),  τ = g s,
//!            u = clamp(ctrl, ctrlrange)
//! spring:    τ = −k (q − q_ref)
//! ```
//!
//! (`g` the gear). Damping stays implicit in the joint's damping rows.

use constraint_core::compound::MAX_DOF;
use constraint_core::DVec3;

use super::*;

/// One actuator on a joint degree of freedom, in MuJoCo's general form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actuator {
    /// The joint it drives.
    pub joint: usize,
    /// The joint's degree of freedom (0 for hinges and slides).
    pub dof: usize,
    /// Gear `g` (MuJoCo's `gear[0]`); zero is allowed and gives no force.
    pub gear: f64,
    /// Gain on the control (`gainprm[0]`; `kp` for `position`, `kv` for `velocity`).
    pub gain: f64,
    /// Affine bias `b₀ + b₁ length + b₂ velocity` (`biasprm[0..3]`).
    pub bias: [f64; 3],
    /// Control clamp (MuJoCo's `ctrlrange` when `ctrllimited`).
    pub ctrl_range: Option<[f64; 2]>,
    /// Force clamp on the scalar actuator force (`forcerange` when `forcelimited`).
    pub force_range: Option<[f64; 2]>,
}

/// A joint spring on one degree of freedom: `τ = −k (q − q_ref)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DofSpring {
    /// The joint.
    pub joint: usize,
    /// Its degree of freedom.
    pub dof: usize,
    /// Stiffness `k ≥ 0` (N·m/rad or N/m).
    pub stiffness: f64,
    /// Rest coordinate `q_ref` (rad or m, in the joint's coordinates: zero at the pose
    /// the joint was built at).
    pub reference: f64,
}

fn range_ok(r: Option<[f64; 2]>) -> bool {
    r.is_none_or(|[lo, hi]| !lo.is_nan() && !hi.is_nan() && lo <= hi)
}

impl World {
    fn dofs_of(&self, joint: usize) -> usize {
        match self.joints.get(joint).map(|j| &j.kind) {
            Some(JointKind::Hinge(_)) | Some(JointKind::Prismatic(_)) => 1,
            Some(JointKind::Compound(c, _)) => c.dof(),
            _ => 0,
        }
    }

    /// Adds an actuator; returns its index (its control starts at 0). Errors: unknown
    /// joint or degree of freedom (spherical, fixed and distance joints have none),
    /// non-finite gain, gear or bias, ranges with NaN or `lo > hi`.
    pub fn add_actuator(&mut self, a: Actuator) -> Result<usize, ArticulatedError> {
        let k = self.actuators.len();
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "actuator",
            rule,
        };
        if a.dof >= self.dofs_of(a.joint) {
            return Err(bad(
                "must drive an existing hinge, slide or compound degree of freedom",
            ));
        }
        if !a.gear.is_finite() || !a.gain.is_finite() || a.bias.iter().any(|b| !b.is_finite()) {
            return Err(bad("gear, gain and bias must be finite"));
        }
        if !range_ok(a.ctrl_range) || !range_ok(a.force_range) {
            return Err(bad("ranges need lo <= hi and no NaN"));
        }
        self.actuators.push(a);
        self.ctrl.push(0.0);
        let _ = k;
        Ok(self.actuators.len() - 1)
    }

    /// The actuators.
    pub fn actuators(&self) -> &[Actuator] {
        &self.actuators
    }

    /// Sets actuator `i`'s control. Errors: unknown actuator, non-finite value.
    pub fn set_ctrl(&mut self, i: usize, value: f64) -> Result<(), ArticulatedError> {
        if !value.is_finite() {
            return Err(ArticulatedError::InvalidParameter {
                name: "ctrl",
                rule: "must be finite",
            });
        }
        let Some(c) = self.ctrl.get_mut(i) else {
            return Err(ArticulatedError::InvalidParameter {
                name: "ctrl",
                rule: "unknown actuator",
            });
        };
        *c = value;
        Ok(())
    }

    /// The controls, in actuator order.
    pub fn ctrl(&self) -> &[f64] {
        &self.ctrl
    }

    /// Adds a joint spring. Errors: unknown joint or degree of freedom, negative or
    /// non-finite stiffness, non-finite reference.
    pub fn add_dof_spring(&mut self, s: DofSpring) -> Result<(), ArticulatedError> {
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "joint spring",
            rule,
        };
        if s.dof >= self.dofs_of(s.joint) {
            return Err(bad(
                "must act on an existing hinge, slide or compound degree of freedom",
            ));
        }
        if !(s.stiffness >= 0.0) || !s.stiffness.is_finite() || !s.reference.is_finite() {
            return Err(bad("stiffness must be finite and >= 0, reference finite"));
        }
        self.springs.push(s);
        Ok(())
    }

    /// The joint springs.
    pub fn dof_springs(&self) -> &[DofSpring] {
        &self.springs
    }

    /// Potential energy of the joint springs, `Σ ½ k (q − q_ref)²`.
    pub fn spring_energy(&self) -> f64 {
        self.springs
            .iter()
            .map(|s| {
                let q = self
                    .joint_coordinates(s.joint)
                    .map_or(0.0, |(q, _)| q[s.dof]);
                0.5 * s.stiffness * (q - s.reference) * (q - s.reference)
            })
            .sum()
    }

    /// The generalized force on each degree of freedom of `joint` at the current state
    /// (actuators and springs), with the rate rows; `None` when nothing acts on it.
    fn dof_forces(&self, joint: usize) -> Option<([f64; MAX_DOF], [[DVec3; 4]; MAX_DOF])> {
        let acts = self.actuators.iter().any(|a| a.joint == joint);
        let springs = self.springs.iter().any(|s| s.joint == joint);
        if !acts && !springs {
            return None;
        }
        let j = &self.joints[joint];
        let (a, b) = (self.pose(j.parent), self.pose(Some(j.child)));
        let (q, rows) = match &j.kind {
            JointKind::Hinge(c) => {
                let mut q = [0.0; MAX_DOF];
                let mut r = [[DVec3::ZERO; 4]; MAX_DOF];
                q[0] = c.angle(&a, &b);
                r[0] = c.angle_row(&b);
                (q, r)
            }
            JointKind::Prismatic(c) => {
                let mut q = [0.0; MAX_DOF];
                let mut r = [[DVec3::ZERO; 4]; MAX_DOF];
                q[0] = c.displacement(&a, &b);
                r[0] = c.displacement_row(&a, &b);
                (q, r)
            }
            JointKind::Compound(c, _) => {
                let q = c.coordinates(&a, &b, &[0.0; MAX_DOF]);
                (q, c.dof_rows(&a, &b, &q))
            }
            _ => return None,
        };
        let tw = self.twist(j);
        let mut tau = [0.0; MAX_DOF];
        for act in self.actuators.iter().zip(&self.ctrl) {
            let (act, &u) = act;
            if act.joint != joint {
                continue;
            }
            let k = act.dof;
            let qd: f64 = (0..4).map(|s| rows[k][s].dot(tw[s])).sum();
            let u = act.ctrl_range.map_or(u, |[lo, hi]| u.min(hi).max(lo));
            let mut s = act.gain * u
                + act.bias[0]
                + act.bias[1] * act.gear * q[k]
                + act.bias[2] * act.gear * qd;
            if let Some([lo, hi]) = act.force_range {
                s = s.min(hi).max(lo);
            }
            tau[k] += act.gear * s;
        }
        for s in &self.springs {
            if s.joint == joint {
                tau[s.dof] -= s.stiffness * (q[s.dof] - s.reference);
            }
        }
        Some((tau, rows))
    }

    /// Adds `scale · Σ_k G_kᵀ τ_k` (the actuator and spring impulses over `scale`
    /// seconds) to the bodies' right-hand side.
    pub(super) fn add_dof_forces(&mut self, scale: f64) {
        if self.actuators.is_empty() && self.springs.is_empty() {
            return;
        }
        for ji in 0..self.joints.len() {
            let Some((tau, rows)) = self.dof_forces(ji) else {
                continue;
            };
            let (parent, child) = (self.joints[ji].parent, self.joints[ji].child);
            for k in 0..MAX_DOF {
                if tau[k] == 0.0 {
                    continue;
                }
                let s = tau[k] * scale;
                for (side, body) in [(0usize, parent), (1usize, Some(child))] {
                    let Some(i) = body else { continue };
                    let o = self.solver.body_offset(i);
                    for c in 0..3 {
                        self.rhs[o + c] += rows[k][2 * side][c] * s;
                        self.rhs[o + 3 + c] += rows[k][2 * side + 1][c] * s;
                    }
                }
            }
        }
    }

    /// The actuator and spring forces per body `(force, torque)` at the current state
    /// (for the acceleration level, which applies forces, not impulses).
    pub(super) fn dof_wrenches(&self) -> Option<Vec<(DVec3, DVec3)>> {
        if self.actuators.is_empty() && self.springs.is_empty() {
            return None;
        }
        let mut f = alloc::vec![(DVec3::ZERO, DVec3::ZERO); self.bodies.len()];
        for ji in 0..self.joints.len() {
            let Some((tau, rows)) = self.dof_forces(ji) else {
                continue;
            };
            let (parent, child) = (self.joints[ji].parent, self.joints[ji].child);
            for k in 0..MAX_DOF {
                if let Some(p) = parent {
                    f[p].0 += rows[k][0] * tau[k];
                    f[p].1 += rows[k][1] * tau[k];
                }
                f[child].0 += rows[k][2] * tau[k];
                f[child].1 += rows[k][3] * tau[k];
            }
        }
        Some(f)
    }
}
