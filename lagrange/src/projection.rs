//! Position projection: Goldenthal et al. 2007, "Efficient simulation of inextensible
//! cloth" (fast projection), from the lecture's applications slide.
//!
//! After an unconstrained (or soft) step has produced candidate positions `x̃`, Newton
//! iterations pull them back onto `C(x) = 0` with the mass-weighted minimum-norm
//! correction:
//!
//! ```text
//! (h² J M⁻¹ Jᵀ) δλ = C(x_j),    x_{j+1} = x_j − h² M⁻¹ Jᵀ δλ
//! ```
//!
//! (solved here as the KKT system `[M Jᵀ; J 0][δx; μ] = [0; −C(x_j)]`, `μ = h²δλ`),
//! until `max_r |C_r|/s_r ≤ tolerance` (`s_r` the constraint's rest scale: strain for
//! springs), then velocities from positions, `v = (x − x₀)/h`. The Jacobian is
//! re-evaluated at every iterate, so the sparse Cholesky reuses its symbolic analysis
//! across iterations and steps.

use crate::error::LagrangeError;
use crate::kkt::{solve_kkt, KktProblem, KktSolver, KktWorkspace, MassMatrix};
use crate::rows::ConstraintRows;
use crate::set::Constraints;
use crate::step::{check_indices, commit, max_relative, rows_at};
use constraint_core::DVec3;
use constraint_soft::{Integrator, SoftSystem};

/// Stopping rule and solver of the projection.
#[derive(Debug)]
pub struct FastProjection {
    /// Stop when `max |C_r|/s_r ≤ tolerance` (strain for springs).
    pub tolerance: f64,
    /// Give up after this many Newton iterations (reported, not an error).
    pub max_iterations: usize,
    /// The KKT solver for each iteration.
    pub solver: KktSolver,
    ws: KktWorkspace,
    rows: ConstraintRows,
    scales: Vec<f64>,
    zeros: Vec<f64>,
    zero_b: Vec<DVec3>,
    c: Vec<f64>,
    dx: Vec<DVec3>,
    mu: Vec<f64>,
}

/// What a projection did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectionStats {
    /// Newton iterations (0 when the candidate already met the tolerance).
    pub iterations: usize,
    /// `max |C_r|/s_r` before projecting.
    pub initial: f64,
    /// `max |C_r|/s_r` after projecting.
    pub r#final: f64,
    /// Whether the tolerance was met.
    pub converged: bool,
    /// Worst relative KKT residual over the iterations.
    pub worst_residual: f64,
}

impl FastProjection {
    /// A projection to `tolerance` in at most `max_iterations` iterations.
    ///
    /// # Errors
    /// `InvalidParameter` unless `tolerance > 0` and finite and `max_iterations ≥ 1`.
    pub fn new(
        tolerance: f64,
        max_iterations: usize,
        solver: KktSolver,
    ) -> Result<Self, LagrangeError> {
        if !(tolerance > 0.0 && tolerance.is_finite()) {
            return Err(LagrangeError::InvalidParameter("tolerance"));
        }
        if max_iterations == 0 {
            return Err(LagrangeError::InvalidParameter("max_iterations"));
        }
        Ok(Self {
            tolerance,
            max_iterations,
            solver,
            ws: KktWorkspace::default(),
            rows: ConstraintRows::new(),
            scales: Vec::new(),
            zeros: Vec::new(),
            zero_b: Vec::new(),
            c: Vec::new(),
            dx: Vec::new(),
            mu: Vec::new(),
        })
    }

    /// Projects the positions `x` (in place) of a system with masses `mass` and pins
    /// `pinned` onto the constraints.
    ///
    /// # Errors
    /// Index or KKT errors; `Kkt(Solve(NonFinite))` when a position is not finite (on
    /// input, or after an update that overflowed). `x` may be partly updated after an
    /// error.
    pub fn project(
        &mut self,
        mass: &[f64],
        pinned: &[bool],
        cons: &Constraints,
        x: &mut [DVec3],
    ) -> Result<ProjectionStats, LagrangeError> {
        let needed = cons.max_index();
        if needed > x.len() {
            return Err(LagrangeError::IndexOutOfBounds {
                needed,
                len: x.len(),
            });
        }
        let n = x.len();
        cons.scales(&mut self.scales);
        let mut st = ProjectionStats::default();
        self.zero_b.clear();
        self.zero_b.resize(n, DVec3::ZERO);
        self.dx.resize(n, DVec3::ZERO);
        loop {
            rows_at(pinned, cons, x, &mut self.rows);
            let err = max_relative(&self.rows, &self.scales);
            if st.iterations == 0 {
                st.initial = err;
            }
            st.r#final = err;
            // Non-finite input positions (or an update that overflowed): an error, never
            // an `Ok` with NaN positions. Checked before the tolerance: a NaN position
            // that no constraint touches leaves `err` finite (fuzz crash particle_step
            // "projection of unconstrained NaN positions").
            if !err.is_finite() || !x.iter().all(|p| p.is_finite()) {
                return Err(LagrangeError::Kkt(crate::kkt::KktError::Solve(
                    crate::solve::SolveError::NonFinite,
                )));
            }
            if err <= self.tolerance {
                st.converged = true;
                return Ok(st);
            }
            if st.iterations == self.max_iterations {
                return Ok(st);
            }
            let m = self.rows.len();
            self.zeros.clear();
            self.zeros.resize(m, 0.0);
            self.c.clear();
            self.c.extend(self.rows.value.iter().map(|c| -c));
            self.mu.clear();
            self.mu.resize(m, 0.0);
            self.dx.fill(DVec3::ZERO);
            let p = KktProblem {
                mass: MassMatrix::Diagonal { mass, pinned },
                rows: &self.rows,
                compliance: &self.zeros,
                b: &self.zero_b,
                c: &self.c,
            };
            let k = solve_kkt(&p, self.solver, &mut self.ws, &mut self.dx, &mut self.mu)?;
            st.worst_residual = crate::rows::nan_max(st.worst_residual, k.residual);
            for (xi, d) in x.iter_mut().zip(&self.dx) {
                *xi += *d;
            }
            st.iterations += 1;
        }
    }
}

/// A soft step followed by fast projection, velocities taken from the projected
/// positions (Goldenthal et al. 2007, Algorithm 1).
pub struct ProjectedStep<I: Integrator> {
    /// The unconstrained (or soft) step.
    pub base: I,
    /// The projection.
    pub projection: FastProjection,
    x0: Vec<DVec3>,
    v0: Vec<DVec3>,
    x: Vec<DVec3>,
    v: Vec<DVec3>,
}

impl<I: Integrator + core::fmt::Debug> core::fmt::Debug for ProjectedStep<I> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ProjectedStep")
            .field("base", &self.base)
            .field("projection", &self.projection)
            .finish()
    }
}

impl<I: Integrator> ProjectedStep<I> {
    /// `base` then `projection`.
    pub fn new(base: I, projection: FastProjection) -> Self {
        Self {
            base,
            projection,
            x0: Vec::new(),
            v0: Vec::new(),
            x: Vec::new(),
            v: Vec::new(),
        }
    }

    /// Advances `sys` by one step: the base step, then projection onto `cons`, then
    /// `v = (x − x₀)/h`.
    ///
    /// # Errors
    /// Soft, index or KKT errors; [`LagrangeError::Diverged`] with the state unchanged.
    pub fn step(
        &mut self,
        sys: &mut SoftSystem,
        cons: &Constraints,
    ) -> Result<ProjectionStats, LagrangeError> {
        check_indices(sys, cons)?;
        let h = self.base.time_step();
        self.x0.clear();
        self.x0.extend_from_slice(&sys.x);
        self.v0.clear();
        self.v0.extend_from_slice(&sys.v);
        let steps = sys.steps;
        self.base.step(sys)?;
        self.x.clear();
        self.x.extend_from_slice(&sys.x);
        let st = match self
            .projection
            .project(sys.masses(), sys.pinned(), cons, &mut self.x)
        {
            Ok(st) => st,
            Err(e) => {
                sys.x.copy_from_slice(&self.x0);
                sys.v.copy_from_slice(&self.v0);
                sys.steps = steps;
                return Err(e);
            }
        };
        self.v.clear();
        self.v
            .extend(self.x.iter().zip(&self.x0).map(|(x, x0)| (*x - *x0) / h));
        // Roll back the base step's commit, then commit the projected state.
        sys.x.copy_from_slice(&self.x0);
        sys.v.copy_from_slice(&self.v0);
        sys.steps = steps;
        commit(sys, &self.x, &self.v)?;
        Ok(st)
    }
}
