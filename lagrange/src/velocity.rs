//! Velocity-level constraints (Otaduy 2010, "Opción 2: restricciones sobre ecuaciones
//! discretizadas"), hard or compliant.
//!
//! The step `A v = b`, `x = x₀ + Δt v` is linearized together with the constraints,
//! `C(x) ≈ C(x₀) + J(x − x₀) = 0 ⇒ J v = −C(x₀)/Δt`, which gives the KKT system
//!
//! ```text
//! [A  Jᵀ     ] [v]   [b         ]
//! [J  −α/Δt² ] [λ] = [−C(x₀)/Δt ]
//! ```
//!
//! with the velocities at the end of the step and constraint impulse `−Jᵀλ` (force
//! `−Jᵀλ/Δt`). `A, b` come from the soft crate: `A = M, b = M v + Δt F(x, v)` for the
//! explicit step, or the linearized backward-Euler matrix and right-hand side for the
//! implicit one, so soft and hard constraints share a scene.
//!
//! Compliance `α ≥ 0` per constraint (Servin et al. 2006; XPBD): `α = 0` is hard;
//! `α = 1/k` reproduces a soft constraint of stiffness `k` under the implicit step with
//! the Gauss–Newton Hessian exactly — eliminating `λ = (Δt²/α)(Jv + C/Δt)` gives
//! `(M + Δt² k JᵀJ) v = M v₀ + Δt F_ext − Δt k JᵀC`.

use crate::error::LagrangeError;
use crate::kkt::{solve_kkt, KktProblem, KktSolver, KktStats, KktWorkspace, MassMatrix};
use crate::projection::{FastProjection, ProjectionStats};
use crate::rows::ConstraintRows;
use crate::set::Constraints;
use crate::step::{check_indices, commit, rows_at, step_context};
use constraint_core::{DVec3, StepContext};
use constraint_soft::{ImplicitEuler, SoftSystem};

/// How `A` and `b` are formed.
#[derive(Debug)]
pub enum BaseStep {
    /// `A = M`, `b = M v + Δt F(x, v)` (symplectic Euler for the unconstrained part).
    Explicit,
    /// The soft crate's linearized backward Euler matrix and right-hand side.
    Implicit(Box<ImplicitEuler>),
}

/// A velocity-level constrained step.
#[derive(Debug)]
pub struct VelocityLevel {
    ctx: StepContext,
    /// `A, b`.
    pub base: BaseStep,
    /// The KKT solver.
    pub solver: KktSolver,
    /// Optional position projection after the velocity solve ("velocity level +
    /// projection"): the end-of-step positions are projected onto `C(x) = 0` and the
    /// velocities recomputed as `(x − x₀)/Δt`. Removes the `O(Δt²)` drift per step.
    pub projection: Option<FastProjection>,
    /// Statistics of the last projection, if any.
    pub last_projection: Option<ProjectionStats>,
    ws: KktWorkspace,
    /// The solver the last step's KKT solve used.
    chosen: Option<KktSolver>,
    rows: ConstraintRows,
    compliance: Vec<f64>,
    c: Vec<f64>,
    b: Vec<DVec3>,
    f: Vec<DVec3>,
    lambda: Vec<f64>,
    v_new: Vec<DVec3>,
    x_new: Vec<DVec3>,
}

impl VelocityLevel {
    /// A step of size `h`. With [`BaseStep::Implicit`], the implicit integrator's own
    /// time step is used for `A, b` and must equal `h`.
    ///
    /// # Errors
    /// `InvalidTimeStep` (also when the implicit base step has another `h`).
    pub fn new(h: f64, base: BaseStep, solver: KktSolver) -> Result<Self, LagrangeError> {
        let ctx = step_context(h)?;
        if let BaseStep::Implicit(imp) = &base {
            use constraint_soft::Integrator;
            if imp.time_step() != ctx.h() {
                return Err(LagrangeError::InvalidTimeStep);
            }
        }
        Ok(Self {
            ctx,
            base,
            solver,
            projection: None,
            last_projection: None,
            ws: KktWorkspace::default(),
            chosen: None,
            rows: ConstraintRows::new(),
            compliance: Vec::new(),
            c: Vec::new(),
            b: Vec::new(),
            f: Vec::new(),
            lambda: Vec::new(),
            v_new: Vec::new(),
            x_new: Vec::new(),
        })
    }

    /// The time step.
    pub fn time_step(&self) -> f64 {
        self.ctx.h()
    }

    /// The KKT solver the last step used ([`KktStats::chosen`]: [`KktSolver::Auto`]
    /// resolved); `None` before the first successful solve.
    pub fn last_solver(&self) -> Option<KktSolver> {
        self.chosen
    }

    /// Multipliers (impulses) of the last step, one per row.
    pub fn multipliers(&self) -> &[f64] {
        &self.lambda
    }

    /// The rows of the last step (evaluated at the start of the step).
    pub fn rows(&self) -> &ConstraintRows {
        &self.rows
    }

    /// Advances `sys` by one step under `cons`.
    ///
    /// # Errors
    /// Index, KKT or soft errors; [`LagrangeError::Diverged`] with the state unchanged.
    pub fn step(
        &mut self,
        sys: &mut SoftSystem,
        cons: &Constraints,
    ) -> Result<KktStats, LagrangeError> {
        check_indices(sys, cons)?;
        let h = self.ctx.h();
        let n = sys.len();
        rows_at(sys.pinned(), cons, &sys.x, &mut self.rows);
        let m = self.rows.len();
        cons.compliance(&mut self.compliance);
        for a in &mut self.compliance {
            *a /= self.ctx.h2();
        }
        self.c.clear();
        self.c.extend(self.rows.value.iter().map(|c| -c / h));
        if self.lambda.len() != m {
            self.lambda = vec![0.0; m];
        }
        self.v_new.clear();
        self.v_new.extend_from_slice(&sys.v);
        let stats = match &mut self.base {
            BaseStep::Explicit => {
                self.f.resize(n, DVec3::ZERO);
                sys.forces(true, &mut self.f);
                self.b.clear();
                let (mass, pinned) = (sys.masses(), sys.pinned());
                self.b.extend((0..n).map(|i| {
                    if pinned[i] {
                        DVec3::ZERO
                    } else {
                        sys.v[i] * mass[i] + self.f[i] * h
                    }
                }));
                let p = KktProblem {
                    mass: MassMatrix::Diagonal { mass, pinned },
                    rows: &self.rows,
                    compliance: &self.compliance,
                    b: &self.b,
                    c: &self.c,
                };
                solve_kkt(
                    &p,
                    self.solver,
                    &mut self.ws,
                    &mut self.v_new,
                    &mut self.lambda,
                )?
            }
            BaseStep::Implicit(imp) => {
                imp.assemble(sys)?;
                let p = KktProblem {
                    mass: MassMatrix::Block {
                        a: imp.matrix(),
                        pinned: sys.pinned(),
                    },
                    rows: &self.rows,
                    compliance: &self.compliance,
                    b: imp.rhs(),
                    c: &self.c,
                };
                solve_kkt(
                    &p,
                    self.solver,
                    &mut self.ws,
                    &mut self.v_new,
                    &mut self.lambda,
                )?
            }
        };
        self.chosen = stats.chosen;
        for (v, &p) in self.v_new.iter_mut().zip(sys.pinned()) {
            if p {
                *v = DVec3::ZERO;
            }
        }
        self.x_new.clear();
        self.x_new
            .extend(sys.x.iter().zip(&self.v_new).map(|(x, v)| *x + *v * h));
        if let Some(proj) = &mut self.projection {
            let st = proj.project(sys.masses(), sys.pinned(), cons, &mut self.x_new)?;
            self.last_projection = Some(st);
            for ((v, xn), x0) in self.v_new.iter_mut().zip(&self.x_new).zip(&sys.x) {
                *v = (*xn - *x0) / h;
            }
        }
        commit(sys, &self.x_new, &self.v_new)?;
        Ok(stats)
    }
}
