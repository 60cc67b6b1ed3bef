//! The position projection's chord steps (simplified Newton, e.g. Kelley 2003,
//! *Solving Nonlinear Equations with Newton's Method*, §2.3.3): after the first
//! iteration the factor of `[M₀ J₀ᵀ; J₀ 0]` (`projection.rs`) is kept and each step
//! solves `[M₀ J₀ᵀ; J₀ 0][δ; λ] = [0; −C(x_k)]`, so only `C(x_k)` is evaluated — no
//! Jacobians, no mass blocks, no factorization. The loop, limit, equality and contact
//! rows are assembled at `x_k` as in a Newton step (each solve forms their complement
//! through the factor anew). The steps contract linearly, `‖C(x_{k+1})‖ ≲ κ‖x_k −
//! x₀‖ ‖C(x_k)‖` (`κ` the constraints' curvature): the projection's steps start from
//! the velocity level's end, about 10⁻³ m off, so about 10⁻³ per step on the small
//! contact models (half_cheetah, dm hopper), one step more than Newton's quadratic
//! convergence at a third of a Newton step's cost.
//!
//! Measured on humanoid_CMU controlled 0.5 s (issue 13, an `eprintln!` per iteration,
//! not kept): the usual projection is a Newton step and two chord steps, `‖C‖` 1e-4 →
//! 1e-8 → 1e-11 → 1e-15 m (122 of 250 projections; the chord ratio ≈ 1e-3 ≈ `κ|δ₀|`),
//! the start error joint separation (the velocity level's second-order drift) and limit
//! violations, no contact part. The error is evaluated once at the start and once per
//! trial step: its 4.7 evaluations a step were the start and 3.7 trials (3.1 iterations,
//! the rest backtracking and re-evaluations after dropping contacts or limits); none is
//! redundant (each decides acceptance and convergence).
//!
//! Tried and left out: the previous projection's joint step (body frame, kept across
//! steps where a step starts at the poses the last projection ended at) added to the
//! velocity level's end as a predictor. The start error grew (5e-6 → 4e-5 m by the
//! second step, 8e-4 m later): the stored correction keeps its part tangent to the
//! joints (a limit's correction, and whatever of the normal correction is tangent at
//! the next pose), which no projection removes, so it acts as a spurious velocity. A
//! predictor would have to be rebuilt each step from the multipliers at the end pose
//! (`M⁻¹Jᵀλ`, normal there), not accumulated.

use super::*;

/// The largest error ratio `‖C(x_{k+1})‖/‖C(x_k)‖` of a step after which the factor is
/// kept; after a slower one the next iteration refactors (a Newton step). A Newton
/// step from `‖C‖ ≈ e` ends near `κe²`, so its ratio `κe` is about the rate of the
/// chord steps that would follow it.
pub(super) const CHORD_RATE: f64 = 0.01;

impl World {
    /// The right-hand side of a chord step at the current poses: zero body rows, the
    /// tree joints' hard rows `−C(x_k)` (compliant joints: zero, as `Soft::Free`
    /// assembles them), the rate rows zero (`Rates::None`), `C(x_k)` as the error last
    /// evaluated it when at these poses; returns the loop rows, as
    /// [`Self::assemble_with`] returns them (a world with loop joints assembles them
    /// there, without the matrix).
    pub(super) fn chord_rhs(&mut self) -> LoopRows {
        if !self.solver.loops.is_empty() {
            self.body_rhs_with(false, |_, _, _| (DVec3::ZERO, DVec3::ZERO));
            let mut rhs = |_: usize, _: &Joint, rows: &crate::joint::JointRows, r: &mut [f64]| {
                for k in 0..rows.n_hard {
                    r[k] = -rows.value[k];
                }
            };
            return self.assemble_with(1.0, Rates::None, Soft::Free, false, Some(&mut rhs));
        }
        self.eq.active = false;
        let size = self.solver.size;
        self.rhs.clear();
        self.rhs.resize(size, 0.0);
        for (j, joint) in self.joints.iter().enumerate() {
            if self.compliance.get(j).is_some_and(|&a| a > 0.0) {
                continue;
            }
            let Some(o) = self.solver.joint_offset(j) else {
                continue;
            };
            // The values the error evaluated at this iterate (`Scratch::values`), or anew.
            let c = if self.proj.values_current {
                self.proj.values[j]
            } else {
                let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
                let b = self.bodies[joint.child].pose;
                joint.value(&a, &b)
            };
            for (x, v) in self.rhs[o..o + joint.hard_rows()].iter_mut().zip(&c) {
                *x = -v;
            }
        }
        self.take_loop_buffers()
    }
}
