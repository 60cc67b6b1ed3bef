//! Lagged-factor preconditioned conjugate gradients for the implicit step.
//!
//! The matrix of the linearized backward Euler step,
//! `A(t) = M − h ∂F/∂v − h² ∂F/∂x`, changes little from one step to the next: its
//! pattern is fixed and its values follow the (slowly turning) constraint gradients.
//! A sparse LDLᵀ factor of an earlier `A(t')` can serve as the preconditioner for
//! `A(t)`: conjugate gradients with `z = A(t')⁻¹ r` converge in a few iterations, each
//! costing one product with `A` and one pair of triangular solves.
//!
//! Measured (this project's machine, one core): whether that pays depends on how fast
//! the matrix turns. A PCG iteration costs 1/5 (hanging 64 × 64 cloth) to 1/11
//! (64 × 64 inextensible cloth with bending) of a numeric refactorization, and a
//! one-step-old factor needs 6–12 iterations to a relative residual of 1e-8 on those
//! cloths at h = 1/60 s. So on them the lagged solver is a wash or a loss: 37.3 against
//! 35.3 ms per step for the inextensible cloth, 17.7 against 16.4 ms for the hanging
//! cloth; at h = 1 ms (15 factorizations in 100 steps instead of 100) it is 4 % faster.
//! It is kept as an option for systems whose refactorization is far dearer than a
//! solve and whose matrix changes little per step; [`crate::LinearSolver::SparseLdlt`]
//! remains the default choice for the cloth.
//!
//! Policy (one pass per step, no hidden state beyond the held factor):
//! 1. no factor held, or the previous solve's iteration count exceeded the average
//!    cost per step since the last refresh ([`LaggedSettings::factor_cost`]): factor
//!    the current `A` and solve directly;
//! 2. otherwise run PCG from the warm start (the current velocities) with the held
//!    factor, to `|b − Ax| ≤ tolerance·|b|`;
//! 3. PCG not converged within [`LaggedSettings::max_iterations`], or a non-positive
//!    curvature `pᵀAp ≤ 0` (the held factor or `A` indefinite): factor the current
//!    `A` and solve directly — the answer is never worse than [`crate::direct`]'s —
//!    and solve directly for the next `b` steps too, `b` doubling (1, 2, 4, … 64) on
//!    each failure in a row and reset by a PCG success. A matrix that changes too
//!    fast for a lagged factor (a stiff cloth flapping freely) so costs at most about
//!    `max_iterations` wasted PCG iterations per `b` direct steps.
//!
//! Deterministic: the same sequence of matrices gives the same factorizations and
//! iterates, bit for bit.

use crate::bsr::BlockMatrix;
use crate::cg::{PcgEnd, PcgWork, SolveStats};
use crate::direct::SparseLdlt;
use crate::error::SoftError;
use constraint_core::DVec3;

/// Stopping and refactorization rule of [`LaggedLdlt`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaggedSettings {
    /// Stop PCG when `|b − Ax| ≤ tolerance · |b|`.
    pub tolerance: f64,
    /// Give up PCG after this many iterations and factor the current matrix instead.
    pub max_iterations: usize,
    /// Cost of one numeric factorization, in PCG iterations (one product with `A`
    /// and one pair of triangular solves each). The factor is refreshed at the step
    /// where an iteration count exceeds the average cost per step since the last
    /// refresh, `(factor_cost + Σ iterations) / steps` — the rule that minimises the
    /// average cost when the iteration count grows with the factor's age. A count,
    /// not a clock: the decisions, and so the results, are deterministic.
    pub factor_cost: f64,
}

impl Default for LaggedSettings {
    /// `tolerance = 1e-8` (as [`crate::CgSettings`]), `max_iterations = 12`,
    /// `factor_cost = 11` (measured on the 64 × 64 cloth with bending: a factorization
    /// takes 28 ms, a PCG iteration 2.5 ms).
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: 12,
            factor_cost: 11.0,
        }
    }
}

impl LaggedSettings {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`SoftError::InvalidParameter`] unless `tolerance` is positive and finite and
    /// `max_iterations ≥ 1`, and `factor_cost` is non-negative and finite.
    pub fn check(self) -> Result<Self, SoftError> {
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(SoftError::InvalidParameter {
                name: "tolerance",
                rule: "positive and finite",
            });
        }
        if self.max_iterations == 0 {
            return Err(SoftError::InvalidParameter {
                name: "max_iterations",
                rule: "at least 1",
            });
        }
        if !(self.factor_cost >= 0.0 && self.factor_cost.is_finite()) {
            return Err(SoftError::InvalidParameter {
                name: "factor_cost",
                rule: "non-negative and finite",
            });
        }
        Ok(self)
    }
}

/// A sparse LDLᵀ factor reused as the preconditioner of conjugate gradients until it
/// goes stale (see the module docs for the policy).
pub struct LaggedLdlt {
    ldlt: SparseLdlt,
    refactor_next: bool,
    /// Cost (in PCG iterations) spent since the last refresh, and steps since then.
    spent: f64,
    steps: u32,
    /// Direct steps still to do after a PCG failure.
    skip: u32,
    /// Length of the last back-off (0 after a PCG success).
    backoff: u32,
    work: PcgWork,
    /// Numeric factorizations done so far.
    pub factorizations: usize,
    /// Solves done so far.
    pub solves: usize,
    /// PCG iterations done so far (direct solves count none).
    pub iterations: usize,
}

impl core::fmt::Debug for LaggedLdlt {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("LaggedLdlt")
            .field("ldlt", &self.ldlt)
            .field("factorizations", &self.factorizations)
            .field("solves", &self.solves)
            .field("iterations", &self.iterations)
            .finish()
    }
}

impl LaggedLdlt {
    /// Wraps an analysed (not necessarily factored) [`SparseLdlt`].
    pub fn new(ldlt: SparseLdlt) -> Self {
        Self {
            ldlt,
            refactor_next: true,
            spent: 0.0,
            steps: 0,
            skip: 0,
            backoff: 0,
            work: PcgWork::default(),
            factorizations: 0,
            solves: 0,
            iterations: 0,
        }
    }

    /// The wrapped factorization.
    pub fn ldlt(&self) -> &SparseLdlt {
        &self.ldlt
    }

    /// Factor the current `a` and solve directly.
    fn direct(
        &mut self,
        a: &BlockMatrix,
        b: &[DVec3],
        x: &mut [DVec3],
        pcg_iterations: usize,
        factor_cost: f64,
    ) -> Result<SolveStats, SoftError> {
        self.ldlt.factor(a)?;
        self.factorizations += 1;
        self.refactor_next = false;
        // This step's cost: the factorization, one solve, and any wasted iterations.
        self.spent = factor_cost + 1.0 + pcg_iterations as f64;
        self.steps = 1;
        self.ldlt.solve_factored(b, x)?;
        let residual = relative_residual(a, b, x, self.work.scratch(b.len()));
        Ok(SolveStats {
            iterations: pcg_iterations + 1,
            residual,
            converged: residual.is_finite(),
        })
    }

    /// Solves `a x = b` from the warm start in `x`.
    ///
    /// # Errors
    /// [`SoftError::InvalidParameter`] for bad settings, [`SoftError::LengthMismatch`]
    /// for sizes that do not match the analysed pattern, [`SoftError::Factorization`]
    /// when the current matrix cannot be factored (a zero pivot).
    pub fn solve(
        &mut self,
        a: &BlockMatrix,
        b: &[DVec3],
        x: &mut [DVec3],
        settings: LaggedSettings,
    ) -> Result<SolveStats, SoftError> {
        let settings = settings.check()?;
        let n = b.len();
        if x.len() != n || a.pattern.len() != n {
            return Err(SoftError::LengthMismatch);
        }
        self.solves += 1;
        if self.skip > 0 {
            self.skip -= 1;
            return self.direct(a, b, x, 0, settings.factor_cost);
        }
        if self.refactor_next || !self.ldlt.is_factored() {
            return self.direct(a, b, x, 0, settings.factor_cost);
        }
        // Preconditioned CG with z = A(t')⁻¹ r (the held factor).
        let ldlt = &mut self.ldlt;
        let (end, it, res) = self.work.run(
            a,
            b,
            x,
            settings.tolerance,
            settings.max_iterations,
            &mut |r, z| ldlt.solve_factored(r, z),
        )?;
        self.iterations += it;
        if end != PcgEnd::Converged {
            // Out of iterations, or an indefinite matrix or preconditioner (or NaN):
            // factor the current A, and back off from PCG for a while.
            self.backoff = (self.backoff * 2).clamp(1, 64);
            self.skip = self.backoff;
            return self.direct(a, b, x, it, settings.factor_cost);
        }
        // Refresh when this step cost more than the average since the last refresh.
        self.refactor_next = it as f64 * f64::from(self.steps) > self.spent;
        self.spent += it as f64;
        self.steps += 1;
        self.backoff = 0;
        Ok(SolveStats {
            iterations: it,
            residual: res,
            converged: true,
        })
    }
}

/// `|b − A x| / |b|`, using `scratch` for `A x`.
pub(crate) fn relative_residual(
    a: &BlockMatrix,
    b: &[DVec3],
    x: &[DVec3],
    scratch: &mut [DVec3],
) -> f64 {
    a.mul_vec(x, scratch);
    let (mut num, mut den) = (0.0, 0.0);
    for (bi, ax) in b.iter().zip(scratch.iter()) {
        num += (*bi - *ax).length_squared();
        den += bi.length_squared();
    }
    if den == 0.0 {
        num.sqrt()
    } else {
        (num / den).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::cloth::Cloth;
    use crate::{HessianMode, ImplicitEuler, Integrator, LinearSolver};

    /// Runs the default 12 × 12 cloth `steps` steps of `h` with the direct and the
    /// lagged solver; returns (max |Δv| / max |v|, lagged factorizations, PCG
    /// iterations).
    fn compare(h: f64, steps: usize) -> (f64, usize, usize) {
        let cloth = Cloth {
            n: 12,
            ..Cloth::default()
        };
        let mut a = cloth.build().unwrap();
        let mut b = cloth.build().unwrap();
        let mut direct =
            ImplicitEuler::new(h, HessianMode::GaussNewton, LinearSolver::SparseLdlt).unwrap();
        let settings = LaggedSettings::default();
        let mut lagged = ImplicitEuler::new(
            h,
            HessianMode::GaussNewton,
            LinearSolver::LaggedLdlt(settings),
        )
        .unwrap();
        let (mut worst, mut vmax, mut iterations) = (0.0f64, 0.0f64, 0);
        for _ in 0..steps {
            direct.step(&mut a).unwrap();
            let st = lagged.step(&mut b).unwrap();
            assert!(st.converged && st.residual <= settings.tolerance, "{st:?}");
            iterations += st.iterations;
            for (va, vb) in a.v.iter().zip(&b.v) {
                worst = worst.max((*va - *vb).length());
                vmax = vmax.max(va.length());
            }
        }
        assert_eq!(direct.factorizations(), steps);
        (worst / vmax, lagged.factorizations(), iterations)
    }

    /// Small steps (h = 1 ms): the matrix changes slowly and one factor serves many
    /// steps, while the velocities follow the direct solver's to the PCG tolerance.
    #[test]
    fn lagged_tracks_direct_with_few_factorizations() {
        let (rel, f, it) = compare(1e-3, 100);
        // Measured: 1.8e-7 relative after 100 steps (PCG relative residual 1e-8; the
        // velocity error is the residual times the matrix's condition).
        assert!(rel < 1e-6, "lagged vs direct: {rel:e}");
        // Measured: 5 factorizations, 316 iterations in 100 steps.
        assert!(f <= 15, "{f} factorizations in 100 steps ({it} iterations)");
    }

    /// Large steps of a stiff, freely falling cloth (h = 1/60 s): the lagged factor
    /// goes stale at once, PCG gives up and the solver backs off to direct solves, so
    /// it factors no more often than the direct solver and wastes a bounded number of
    /// iterations.
    #[test]
    fn lagged_backs_off_when_the_factor_goes_stale_at_once() {
        let (rel, f, it) = compare(1.0 / 60.0, 60);
        // Measured: 2.0e-10 relative.
        assert!(rel < 1e-7, "lagged vs direct: {rel:e}");
        // Measured: 59 factorizations, 140 iterations (PCG attempts 1, 2, 4, … steps
        // apart, at most 12 iterations each, plus one per direct solve).
        assert!(f <= 60, "{f} factorizations");
        assert!(it <= 60 + 12 * 8, "{it} iterations");
    }

    #[test]
    fn bad_settings_are_rejected() {
        for s in [
            LaggedSettings {
                tolerance: f64::NAN,
                ..LaggedSettings::default()
            },
            LaggedSettings {
                tolerance: 0.0,
                ..LaggedSettings::default()
            },
            LaggedSettings {
                max_iterations: 0,
                ..LaggedSettings::default()
            },
        ] {
            assert!(matches!(s.check(), Err(SoftError::InvalidParameter { .. })));
        }
    }
}
