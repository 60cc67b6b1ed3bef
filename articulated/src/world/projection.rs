//! Newton projection onto `C(x) = 0` with mass-weighted minimum-norm steps (Goldenthal
//! et al. 2007), with backtracking.

use constraint_core::rigid::rotate_by;
use constraint_core::DVec3;

use super::*;

impl World {
    /// Newton projection onto `C(x) = 0` with mass-weighted minimum-norm steps
    /// `[M Jᵀ; J 0][δ; λ] = [0; −C]` (Goldenthal et al. 2007, fast projection).
    pub(super) fn project(
        &mut self,
        tolerance: f64,
        max_iterations: usize,
        velocity_h: Option<f64>,
    ) -> Result<usize, ArticulatedError> {
        // Compliant joints are not projected (their separation is their spring's).
        // Equality rows are projected with the joints: `[M Eᵀ; E 0][δ; ν] = [0; −C_E]`.
        let mut err = self.projection_error();
        for it in 0..max_iterations {
            if err <= tolerance {
                return Ok(it);
            }
            self.body_rhs(|_, _, _| (DVec3::ZERO, DVec3::ZERO));
            let loops = self.assemble(1.0, Rates::None, Soft::Free, |_, _, rows, rhs| {
                for r in 0..rows.n_hard {
                    rhs[r] = -rows.value[r];
                }
            });
            self.load_equalities(|c| -c);
            self.solve(loops)?;
            // Backtracking: a full Newton step can overshoot far from the manifold (light
            // bodies turned by large angles); halve it until the separation decreases.
            // The iterate the trials start from, in a reused scratch (no allocation per
            // iteration).
            let mut base = core::mem::take(&mut self.proj_base);
            base.clear();
            base.extend(self.bodies.iter().map(|b| (b.pose, b.v, b.omega)));
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
                let trial = self.projection_error();
                if trial < err {
                    err = trial;
                    accepted = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted {
                for (b, &(pose, v, w)) in self.bodies.iter_mut().zip(&base) {
                    b.pose = pose;
                    b.v = v;
                    b.omega = w;
                }
            }
            self.proj_base = base;
            if !accepted {
                return Ok(it + 1);
            }
        }
        Ok(max_iterations)
    }

    /// What the projection drives to zero: the hard joints' separation and the
    /// equalities' `|C|`.
    fn projection_error(&self) -> f64 {
        self.max_hard_separation()
            .max(self.max_equality_violation())
    }
}
