//! Acceleration-level constraints with Baumgarte stabilization (Otaduy 2010,
//! "Opción 1: diferenciación de restricciones").
//!
//! Differentiating `C(x) = 0` twice, `C̈ = J̇ẋ + Jẍ = 0`, and asking for the
//! accelerations closest to the unconstrained ones `ẍ* = M⁻¹F` gives
//!
//! ```text
//! [M  Jᵀ] [ẍ]   [F                      ]
//! [J  0 ] [λ] = [−J̇ẋ − k_x C − k_v Ċ   ]
//! ```
//!
//! The lecture notes that `J̇` "se suele tomar como 0"; here `J̇ẋ = ẋᵀ∇²C ẋ` is computed
//! exactly from the constraint's curvature unless disabled. Enforcing `C̈ = 0` alone
//! lets `C` drift; the Baumgarte terms `−k_x C − k_v Ċ` ("como una restricción débil que
//! se suma a la restricción fuerte: un muelle con amortiguamiento") pull it back.
//! `k_x = k_v = 0` is allowed, to show the drift. The accelerations are integrated with
//! symplectic Euler.

use crate::error::LagrangeError;
use crate::kkt::{solve_kkt, KktProblem, KktSolver, KktStats, KktWorkspace, MassMatrix};
use crate::rows::ConstraintRows;
use crate::set::Constraints;
use crate::step::{check_indices, commit, rows_at, step_context};
use constraint_core::{DVec3, StepContext};
use constraint_soft::SoftSystem;

/// Baumgarte gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Baumgarte {
    /// Position gain `k_x` (1/s²).
    pub kx: f64,
    /// Velocity gain `k_v` (1/s).
    pub kv: f64,
}

impl Baumgarte {
    /// No stabilization: pure `C̈ = 0`, which drifts.
    pub const NONE: Self = Self { kx: 0.0, kv: 0.0 };

    /// Critically damped gains for a response time `τ`: `k_x = 1/τ²`, `k_v = 2/τ`.
    ///
    /// # Errors
    /// `InvalidParameter("tau")` unless `τ > 0` and the gains are finite.
    pub fn critical(tau: f64) -> Result<Self, LagrangeError> {
        let g = Self {
            kx: 1.0 / (tau * tau),
            kv: 2.0 / tau,
        };
        if tau > 0.0 && g.kx.is_finite() && g.kv.is_finite() {
            Ok(g)
        } else {
            Err(LagrangeError::InvalidParameter("tau"))
        }
    }
}

/// An acceleration-level constrained step.
#[derive(Debug)]
pub struct AccelerationLevel {
    ctx: StepContext,
    /// Baumgarte gains.
    pub baumgarte: Baumgarte,
    /// Include `J̇ẋ` (the lecture's usual simplification drops it).
    pub velocity_term: bool,
    /// The KKT solver.
    pub solver: KktSolver,
    ws: KktWorkspace,
    /// The solver the last step's KKT solve used.
    chosen: Option<KktSolver>,
    rows: ConstraintRows,
    zeros: Vec<f64>,
    c: Vec<f64>,
    cdot: Vec<f64>,
    jdv: Vec<f64>,
    f: Vec<DVec3>,
    a: Vec<DVec3>,
    lambda: Vec<f64>,
    v_new: Vec<DVec3>,
    x_new: Vec<DVec3>,
}

impl AccelerationLevel {
    /// A step of size `h` with the given gains.
    ///
    /// # Errors
    /// `InvalidTimeStep`, or `InvalidParameter` for negative or non-finite gains.
    pub fn new(h: f64, baumgarte: Baumgarte, solver: KktSolver) -> Result<Self, LagrangeError> {
        let ctx = step_context(h)?;
        if !(baumgarte.kx >= 0.0 && baumgarte.kx.is_finite()) {
            return Err(LagrangeError::InvalidParameter("k_x"));
        }
        if !(baumgarte.kv >= 0.0 && baumgarte.kv.is_finite()) {
            return Err(LagrangeError::InvalidParameter("k_v"));
        }
        Ok(Self {
            ctx,
            baumgarte,
            velocity_term: true,
            solver,
            ws: KktWorkspace::default(),
            chosen: None,
            rows: ConstraintRows::new(),
            zeros: Vec::new(),
            c: Vec::new(),
            cdot: Vec::new(),
            jdv: Vec::new(),
            f: Vec::new(),
            a: Vec::new(),
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

    /// Advances `sys` by one step under `cons`.
    ///
    /// # Errors
    /// Index or KKT errors; [`LagrangeError::Diverged`] with the state unchanged.
    pub fn step(
        &mut self,
        sys: &mut SoftSystem,
        cons: &Constraints,
    ) -> Result<KktStats, LagrangeError> {
        check_indices(sys, cons)?;
        let (h, n) = (self.ctx.h(), sys.len());
        rows_at(sys.pinned(), cons, &sys.x, &mut self.rows);
        let m = self.rows.len();
        self.cdot.resize(m, 0.0);
        self.rows.mul(&sys.v, &mut self.cdot);
        if self.velocity_term {
            cons.jdot_v(&sys.x, &sys.v, &mut self.jdv);
        } else {
            self.jdv.clear();
            self.jdv.resize(m, 0.0);
        }
        let Baumgarte { kx, kv } = self.baumgarte;
        self.c.clear();
        self.c
            .extend((0..m).map(|r| -self.jdv[r] - kx * self.rows.value[r] - kv * self.cdot[r]));
        self.zeros.clear();
        self.zeros.resize(m, 0.0);
        self.f.resize(n, DVec3::ZERO);
        sys.forces(true, &mut self.f);
        for (f, &p) in self.f.iter_mut().zip(sys.pinned()) {
            if p {
                *f = DVec3::ZERO;
            }
        }
        if self.lambda.len() != m {
            self.lambda = vec![0.0; m];
        }
        self.a.resize(n, DVec3::ZERO);
        let p = KktProblem {
            mass: MassMatrix::Diagonal {
                mass: sys.masses(),
                pinned: sys.pinned(),
            },
            rows: &self.rows,
            compliance: &self.zeros,
            b: &self.f,
            c: &self.c,
        };
        let stats = solve_kkt(&p, self.solver, &mut self.ws, &mut self.a, &mut self.lambda)?;
        self.chosen = stats.chosen;
        self.v_new.clear();
        self.v_new.extend((0..n).map(|i| {
            if sys.pinned()[i] {
                DVec3::ZERO
            } else {
                sys.v[i] + self.a[i] * h
            }
        }));
        self.x_new.clear();
        self.x_new
            .extend(sys.x.iter().zip(&self.v_new).map(|(x, v)| *x + *v * h));
        commit(sys, &self.x_new, &self.v_new)?;
        Ok(stats)
    }
}
