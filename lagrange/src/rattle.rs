//! RATTLE for particles with hard constraints (Andersen 1983; Hairer, Lubich & Wanner,
//! "Geometric Numerical Integration", VII.1): second order, symplectic for
//! conservative forces, positions on `C(x) = 0` and velocities on `J v = 0` after every
//! step — and RATTLE4, the same step composed by Yoshida's triple jump (1990), fourth
//! order. They give the particle scenes methods whose error falls as `h²` and `h⁴`,
//! where the lecture's velocity- and acceleration-level steps are first order.
//!
//! One step of size `h` from `(x, v)`, `M` the masses, `F` the forces of the soft
//! constraint sets and gravity, `J = ∂C/∂x`:
//!
//! ```text
//! v½ = v + (h/2) M⁻¹ (F(x) − J(x)ᵀ λ)
//! x' = x + h v½                        with λ such that C(x') = 0   (SHAKE)
//! v' = v½ + (h/2) M⁻¹ (F(x') − J(x')ᵀ μ)  with μ such that J(x') v' = 0
//! ```
//!
//! SHAKE: from `x̃ = x + h v + (h²/2) M⁻¹ F(x)`, chord iterations along the start
//! Jacobian `J₀ = J(x)`, each the KKT solve `[M J₀ᵀ; J₀ 0][δx; μ] = [0; −C(x_k)]`,
//! `x_{k+1} = x_k + δx`, until `max_r |C_r|/s_r ≤ tolerance`. The correction stays in
//! the span of `M⁻¹J₀ᵀ`, which is what makes the map symplectic. When the chord
//! iteration has not converged after half its budget (a fast whip, where `J(x')` has
//! turned far from `J₀`), the remaining iterations are Newton steps with the current
//! Jacobian (as [`crate::FastProjection`]): still on the manifold and second order,
//! no longer exactly symplectic; counted in [`RattleStats::newton_fallbacks`].
//! The velocity stage is the KKT solve `[M J'ᵀ; J' 0][v'; μ] = [M ṽ; 0]`.
//!
//! Damping forces (velocity-dependent) are evaluated at `v` in the first kick and at
//! `v½` in the second: RATTLE stays second order for conservative forces and is first
//! order in the damping terms. Pinned particles do not move. A failed step (KKT error,
//! non-finite or exploding state) leaves the system unchanged.

use crate::error::LagrangeError;
use crate::kkt::{solve_kkt, KktProblem, KktSolver, KktWorkspace, MassMatrix};
use crate::rows::ConstraintRows;
use crate::set::Constraints;
use crate::step::{check_indices, max_relative, rows_at, step_context};
use constraint_core::{DVec3, StepContext};
use constraint_soft::SoftSystem;

/// Order of the method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RattleOrder {
    /// RATTLE: one step of size `h`.
    Second,
    /// RATTLE4: RATTLE steps of `w₁h, w₀h, w₁h`, `w₁ = 1/(2 − 2^{1/3})`,
    /// `w₀ = 1 − 2w₁` (Yoshida 1990).
    Fourth,
}

/// What a RATTLE step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RattleStats {
    /// SHAKE iterations over the step (all sub-steps).
    pub iterations: usize,
    /// Sub-steps whose SHAKE iteration switched to Newton with the current Jacobian.
    pub newton_fallbacks: usize,
    /// `max |C_r|/s_r` at the end of the step.
    pub violation: f64,
    /// Worst relative KKT residual of the step's solves.
    pub worst_residual: f64,
}

/// A RATTLE or RATTLE4 step for a [`SoftSystem`] under hard [`Constraints`].
#[derive(Debug)]
pub struct Rattle {
    ctx: StepContext,
    /// Second or fourth order.
    pub order: RattleOrder,
    /// SHAKE stops when `max |C_r|/s_r ≤ tolerance` (`s_r` the rows' rest scales).
    pub tolerance: f64,
    /// Iteration budget of SHAKE per sub-step; not converging within it is the error
    /// `KktError::Solve(SolveError::NotConverged)` (state unchanged).
    pub max_iterations: usize,
    /// The KKT solver.
    pub solver: KktSolver,
    ws: KktWorkspace,
    rows0: ConstraintRows,
    rows: ConstraintRows,
    scales: Vec<f64>,
    zeros: Vec<f64>,
    zero_b: Vec<DVec3>,
    c: Vec<f64>,
    mu: Vec<f64>,
    f: Vec<DVec3>,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
    dx: Vec<DVec3>,
    mv: Vec<DVec3>,
    x0: Vec<DVec3>,
    v0: Vec<DVec3>,
}

/// Yoshida's triple-jump weights `(w₁, w₀)`.
fn yoshida() -> (f64, f64) {
    let w1 = 1.0 / (2.0 - 2f64.cbrt());
    (w1, 1.0 - 2.0 * w1)
}

impl Rattle {
    /// A RATTLE (or RATTLE4) step of size `h`, SHAKE to `tolerance` in at most
    /// `max_iterations` iterations per sub-step.
    ///
    /// # Errors
    /// `InvalidTimeStep`; `InvalidParameter` unless `tolerance > 0` and finite and
    /// `max_iterations ≥ 2`.
    pub fn new(
        h: f64,
        order: RattleOrder,
        tolerance: f64,
        max_iterations: usize,
        solver: KktSolver,
    ) -> Result<Self, LagrangeError> {
        let ctx = step_context(h)?;
        if !(tolerance > 0.0 && tolerance.is_finite()) {
            return Err(LagrangeError::InvalidParameter("tolerance"));
        }
        if max_iterations < 2 {
            return Err(LagrangeError::InvalidParameter("max_iterations"));
        }
        Ok(Self {
            ctx,
            order,
            tolerance,
            max_iterations,
            solver,
            ws: KktWorkspace::default(),
            rows0: ConstraintRows::new(),
            rows: ConstraintRows::new(),
            scales: Vec::new(),
            zeros: Vec::new(),
            zero_b: Vec::new(),
            c: Vec::new(),
            mu: Vec::new(),
            f: Vec::new(),
            x: Vec::new(),
            v: Vec::new(),
            dx: Vec::new(),
            mv: Vec::new(),
            x0: Vec::new(),
            v0: Vec::new(),
        })
    }

    /// The time step.
    pub fn time_step(&self) -> f64 {
        self.ctx.h()
    }

    /// Advances `sys` by one step of RATTLE or RATTLE4.
    ///
    /// # Errors
    /// Index or KKT errors, SHAKE not converging (`KktError::Solve(NotConverged)`),
    /// [`LagrangeError::Diverged`] for a non-finite or exploding state. The system is
    /// unchanged after any error.
    pub fn step(
        &mut self,
        sys: &mut SoftSystem,
        cons: &Constraints,
    ) -> Result<RattleStats, LagrangeError> {
        check_indices(sys, cons)?;
        if !sys.gravity.is_finite() {
            return Err(LagrangeError::Soft(
                constraint_soft::SoftError::InvalidParameter {
                    name: "gravity",
                    rule: "must be finite",
                },
            ));
        }
        self.x0.clear();
        self.x0.extend_from_slice(&sys.x);
        self.v0.clear();
        self.v0.extend_from_slice(&sys.v);
        let mut st = RattleStats::default();
        let (w1, w0) = yoshida();
        let subs: &[f64] = match self.order {
            RattleOrder::Second => &[1.0],
            RattleOrder::Fourth => &[w1, w0, w1],
        };
        let mut result = Ok(());
        for &w in subs {
            result = self.substep(sys, cons, w * self.ctx.h(), &mut st);
            if result.is_err() {
                break;
            }
        }
        if let Err(e) = result {
            sys.x.copy_from_slice(&self.x0);
            sys.v.copy_from_slice(&self.v0);
            return Err(e);
        }
        sys.steps += 1;
        Ok(st)
    }

    /// Forces at the system's current `x` and `v` into `self.f`.
    fn forces(&mut self, sys: &SoftSystem) {
        self.f.clear();
        self.f.resize(sys.len(), DVec3::ZERO);
        sys.forces(true, &mut self.f);
    }

    /// The KKT solve `[M Jᵀ; J 0][y; μ] = [b; c]` with `rows0` (`fixed`) or `rows`.
    fn solve(
        &mut self,
        sys: &SoftSystem,
        use_start_rows: bool,
        rhs_b: bool,
        st: &mut RattleStats,
    ) -> Result<(), LagrangeError> {
        let m = if use_start_rows {
            self.rows0.len()
        } else {
            self.rows.len()
        };
        self.zeros.clear();
        self.zeros.resize(m, 0.0);
        self.mu.clear();
        self.mu.resize(m, 0.0);
        let rows = if use_start_rows {
            &self.rows0
        } else {
            &self.rows
        };
        let p = KktProblem {
            mass: MassMatrix::Diagonal {
                mass: sys.masses(),
                pinned: sys.pinned(),
            },
            rows,
            compliance: &self.zeros,
            b: if rhs_b { &self.mv } else { &self.zero_b },
            c: &self.c,
        };
        let k = solve_kkt(&p, self.solver, &mut self.ws, &mut self.dx, &mut self.mu)?;
        st.worst_residual = crate::rows::nan_max(st.worst_residual, k.residual);
        Ok(())
    }

    /// One RATTLE step of size `h` on `sys` (positions and velocities written, step
    /// counter untouched).
    fn substep(
        &mut self,
        sys: &mut SoftSystem,
        cons: &Constraints,
        h: f64,
        st: &mut RattleStats,
    ) -> Result<(), LagrangeError> {
        let n = sys.len();
        cons.scales(&mut self.scales);
        self.zero_b.clear();
        self.zero_b.resize(n, DVec3::ZERO);
        self.dx.resize(n, DVec3::ZERO);
        // First kick without the constraint force, then drift: x̃ = x + h v + (h²/2) M⁻¹F.
        self.forces(sys);
        rows_at(sys.pinned(), cons, &sys.x, &mut self.rows0);
        self.x.clear();
        self.v.clear();
        {
            let (mass, pinned) = (sys.masses(), sys.pinned());
            for i in 0..n {
                if pinned[i] {
                    self.x.push(sys.x[i]);
                    self.v.push(DVec3::ZERO);
                } else {
                    let vh = sys.v[i] + self.f[i] * (0.5 * h / mass[i]);
                    self.v.push(vh);
                    self.x.push(sys.x[i] + vh * h);
                }
            }
        }
        // SHAKE: chord iterations along J₀, Newton with the current J after half the
        // budget.
        let mut k = 0;
        let mut newton = false;
        loop {
            rows_at(sys.pinned(), cons, &self.x, &mut self.rows);
            let err = max_relative(&self.rows, &self.scales);
            if !err.is_finite() || !self.x.iter().all(|p| p.is_finite()) {
                return Err(LagrangeError::Diverged {
                    step: sys.steps,
                    particle: self.x.iter().position(|p| !p.is_finite()).unwrap_or(0),
                });
            }
            if err <= self.tolerance {
                break;
            }
            if k == self.max_iterations {
                return Err(LagrangeError::Kkt(crate::kkt::KktError::Solve(
                    crate::solve::SolveError::NotConverged {
                        iterations: k,
                        residual: err,
                    },
                )));
            }
            if !newton && 2 * k >= self.max_iterations {
                newton = true;
                st.newton_fallbacks += 1;
            }
            self.c.clear();
            self.c.extend(self.rows.value.iter().map(|c| -c));
            self.dx.fill(DVec3::ZERO);
            self.solve(sys, !newton, false, st)?;
            for (xi, d) in self.x.iter_mut().zip(&self.dx) {
                *xi += *d;
            }
            k += 1;
            st.iterations += 1;
        }
        // v½ = (x' − x)/h (includes the constraint impulse), then the second kick at x'.
        for i in 0..n {
            if !sys.pinned()[i] {
                self.v[i] = (self.x[i] - sys.x[i]) / h;
            }
        }
        core::mem::swap(&mut sys.x, &mut self.x);
        core::mem::swap(&mut sys.v, &mut self.v);
        // sys now holds (x', v½); self.x, self.v hold the start state.
        self.forces(sys);
        self.mv.clear();
        {
            let (mass, pinned) = (sys.masses(), sys.pinned());
            for i in 0..n {
                self.mv.push(if pinned[i] {
                    DVec3::ZERO
                } else {
                    (sys.v[i] + self.f[i] * (0.5 * h / mass[i])) * mass[i]
                });
            }
        }
        // Velocity projection onto J(x') v' = 0 (rows already at x').
        let m = self.rows.len();
        self.c.clear();
        self.c.resize(m, 0.0);
        self.dx.copy_from_slice(&sys.v);
        let solved = self.solve(sys, false, true, st);
        let bad = constraint_core::math::first_out_of_limit(&self.dx, &sys.x);
        if solved.is_err() || bad.is_some() {
            core::mem::swap(&mut sys.x, &mut self.x);
            core::mem::swap(&mut sys.v, &mut self.v);
            solved?;
            return Err(LagrangeError::Diverged {
                step: sys.steps,
                particle: bad.unwrap_or(0),
            });
        }
        for i in 0..n {
            sys.v[i] = if sys.pinned()[i] {
                DVec3::ZERO
            } else {
                self.dx[i]
            };
        }
        st.violation = max_relative(&self.rows, &self.scales);
        Ok(())
    }
}
