//! Time integrators: symplectic Euler and the linearized backward Euler of the lecture.
//!
//! Both take the state `(x, v)` of a [`SoftSystem`] one step `h` forward and write it
//! back only if every value is finite and bounded; otherwise they return
//! [`SoftError::Diverged`] and leave the state untouched.

use crate::bsr::{BlockMatrix, BlockPattern};
use crate::cg::{Cg, CgSettings, SolveStats};
use crate::energy::HessianMode;
use crate::error::SoftError;
use crate::system::SoftSystem;
use constraint_core::{DMat3, DVec3, StepContext};

/// A one-step method for a [`SoftSystem`].
pub trait Integrator {
    /// A short name for reports.
    fn name(&self) -> String;
    /// The time step `h` (s).
    fn time_step(&self) -> f64;
    /// Advances `sys` by one step.
    ///
    /// # Errors
    /// [`SoftError::Diverged`] (state unchanged), or a solver error.
    fn step(&mut self, sys: &mut SoftSystem) -> Result<SolveStats, SoftError>;
    /// What a step runs, as plain data (for reports and tools; the words are theirs).
    /// [`Scheme::Other`] unless an implementation says otherwise.
    fn scheme(&self) -> Scheme {
        Scheme::Other
    }
}

/// The scheme an [`Integrator`] steps with, as plain data ([`Integrator::scheme`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scheme {
    /// [`SymplecticEuler`]: explicit forces, `v' = v + h M⁻¹ F(x, v)`, `x' = x + h v'`.
    SymplecticEuler,
    /// [`ImplicitEuler`]: the linearized backward Euler system
    /// `(M − h ∂F/∂v − h² ∂F/∂x) v' = M v + h F`, with this Hessian and linear solver.
    ImplicitEuler {
        /// How the stiffness Hessian `∂F/∂x` is formed.
        mode: HessianMode,
        /// The linear solver of the system.
        solver: LinearSolver,
    },
    /// An integrator that does not describe itself.
    Other,
}

/// Gravity must be finite (a NaN or infinite field would otherwise reach the solver).
fn check_gravity(sys: &SoftSystem) -> Result<(), SoftError> {
    if sys.gravity.is_finite() {
        Ok(())
    } else {
        Err(SoftError::InvalidParameter {
            name: "gravity",
            rule: "must be finite",
        })
    }
}

/// The step context of `h`, checked once when the integrator is built
/// ([`StepContext::new`]); every [`StepError`](constraint_core::StepError) is
/// [`SoftError::InvalidTimeStep`].
fn step_context(h: f64) -> Result<StepContext, SoftError> {
    StepContext::new(h).map_err(|_| SoftError::InvalidTimeStep)
}

/// Commits `(x + h v_new, v_new)` if it is finite and bounded.
fn commit(
    sys: &mut SoftSystem,
    ctx: &StepContext,
    v_new: &[DVec3],
    x_new: &mut Vec<DVec3>,
) -> Result<(), SoftError> {
    let h = ctx.h();
    x_new.clear();
    x_new.extend(sys.x.iter().zip(v_new).map(|(x, v)| *x + *v * h));
    if let Some(p) = SoftSystem::first_bad(x_new, v_new) {
        return Err(SoftError::Diverged {
            step: sys.steps,
            particle: p,
        });
    }
    sys.x.copy_from_slice(x_new);
    sys.v.copy_from_slice(v_new);
    sys.steps += 1;
    Ok(())
}

/// Symplectic (semi-implicit) Euler: `v⁺ = v + h M⁻¹ F(x, v)`, `x⁺ = x + h v⁺`.
///
/// Conditionally stable: with a spring of stiffness `k` between masses `m` it needs
/// roughly `h < 2/ω = 2√(m/2k)`.
#[derive(Clone, Debug)]
pub struct SymplecticEuler {
    ctx: StepContext,
    f: Vec<DVec3>,
    v_new: Vec<DVec3>,
    x_new: Vec<DVec3>,
}

impl SymplecticEuler {
    /// With time step `h`.
    ///
    /// # Errors
    /// [`SoftError::InvalidTimeStep`].
    pub fn new(h: f64) -> Result<Self, SoftError> {
        Ok(Self {
            ctx: step_context(h)?,
            f: Vec::new(),
            v_new: Vec::new(),
            x_new: Vec::new(),
        })
    }
}

impl Integrator for SymplecticEuler {
    fn name(&self) -> String {
        "symplectic Euler".into()
    }

    fn scheme(&self) -> Scheme {
        Scheme::SymplecticEuler
    }

    fn time_step(&self) -> f64 {
        self.ctx.h()
    }

    fn step(&mut self, sys: &mut SoftSystem) -> Result<SolveStats, SoftError> {
        sys.check_lengths()?;
        check_gravity(sys)?;
        let n = sys.len();
        self.f.resize(n, DVec3::ZERO);
        sys.forces(true, &mut self.f);
        self.v_new.clear();
        let (h, m, pinned) = (self.ctx.h(), sys.masses(), sys.pinned());
        self.v_new.extend((0..n).map(|i| {
            if pinned[i] {
                DVec3::ZERO
            } else {
                sys.v[i] + self.f[i] * (h / m[i])
            }
        }));
        commit(sys, &self.ctx, &self.v_new, &mut self.x_new)?;
        Ok(SolveStats {
            iterations: 0,
            residual: 0.0,
            converged: true,
        })
    }
}

/// Linear solver for the implicit step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LinearSolver {
    /// Block-Jacobi preconditioned conjugate gradients, warm-started from `v(t)`.
    ConjugateGradient(CgSettings),
    /// Sparse LDLᵀ (faer). The fill-reducing ordering — nested dissection of the
    /// positions at the first step or AMD, whichever factors with fewer operations
    /// ([`SparseLdlt::with_positions`](crate::direct::SparseLdlt::with_positions)) —
    /// and the symbolic analysis are computed once per topology and reused.
    #[cfg(feature = "faer")]
    SparseLdlt,
    /// Conjugate gradients preconditioned by the sparse LDLᵀ factor of an earlier
    /// step's matrix, refactored only when it goes stale ([`crate::lagged`]): the
    /// direct solver's answer (to the PCG tolerance) at a fraction of its cost when the
    /// matrix changes slowly.
    #[cfg(feature = "faer")]
    LaggedLdlt(crate::lagged::LaggedSettings),
}

/// Linearized backward Euler (Otaduy 2010, slide "Integración Implícita"; Baraff &
/// Witkin 1998):
///
/// ```text
/// (M − h ∂F/∂v − h² ∂F/∂x) v(t+h) = (M − h ∂F/∂v) v(t) + h F(x(t), v(t))
/// x(t+h) = x(t) + h v(t+h)
/// ```
///
/// Damping forces are linear in `v` (`F_d = (∂F/∂v) v`), so they cancel on the right:
/// the right-hand side is assembled as `M v(t) + h F_nd` with `F_nd` the non-damping
/// forces. Pinned particles get the row `M_i v_i = 0`. The matrix pattern is built on
/// the first step (and again only if the system's topology changes); each step then
/// refills values in place.
#[derive(Debug)]
pub struct ImplicitEuler {
    ctx: StepContext,
    /// Treatment of the indefinite curvature term.
    pub mode: HessianMode,
    /// The linear solver.
    pub solver: LinearSolver,
    topology: Option<u64>,
    a: BlockMatrix,
    cg: Cg,
    #[cfg(feature = "faer")]
    ldlt: Option<crate::direct::SparseLdlt>,
    #[cfg(feature = "faer")]
    lagged: Option<crate::lagged::LaggedLdlt>,
    factorizations: usize,
    f: Vec<DVec3>,
    b: Vec<DVec3>,
    v_new: Vec<DVec3>,
    x_new: Vec<DVec3>,
}

impl ImplicitEuler {
    /// With time step `h`, Hessian treatment and solver.
    ///
    /// # Errors
    /// [`SoftError::InvalidTimeStep`].
    pub fn new(h: f64, mode: HessianMode, solver: LinearSolver) -> Result<Self, SoftError> {
        Ok(Self {
            ctx: step_context(h)?,
            mode,
            solver,
            topology: None,
            a: BlockMatrix::default(),
            cg: Cg::default(),
            #[cfg(feature = "faer")]
            ldlt: None,
            #[cfg(feature = "faer")]
            lagged: None,
            factorizations: 0,
            f: Vec::new(),
            b: Vec::new(),
            v_new: Vec::new(),
            x_new: Vec::new(),
        })
    }

    /// The assembled system matrix of the last step.
    pub fn matrix(&self) -> &BlockMatrix {
        &self.a
    }

    /// Numeric factorizations done by the sparse direct solvers so far (one per step
    /// for [`LinearSolver::SparseLdlt`], only the stale-factor refreshes for
    /// [`LinearSolver::LaggedLdlt`]; always 0 for conjugate gradients).
    pub fn factorizations(&self) -> usize {
        #[cfg(feature = "faer")]
        if let Some(l) = &self.lagged {
            return self.factorizations + l.factorizations;
        }
        self.factorizations
    }

    /// The assembled right-hand side `M v + h F` of the last step (zero rows for pinned
    /// particles).
    pub fn rhs(&self) -> &[DVec3] {
        &self.b
    }

    fn rebuild(&mut self, sys: &mut SoftSystem) -> Result<(), SoftError> {
        let mut stencils: Vec<usize> = Vec::new();
        let mut lens: Vec<usize> = Vec::new();
        for s in &sys.sets {
            s.for_each_stencil(&mut |st| {
                stencils.extend_from_slice(st);
                lens.push(st.len());
            });
        }
        let mut chunks = Vec::with_capacity(lens.len());
        let mut at = 0;
        for l in lens {
            chunks.push(&stencils[at..at + l]);
            at += l;
        }
        let pattern = BlockPattern::from_stencils(sys.len(), chunks.into_iter());
        for s in &mut sys.sets {
            s.bind(&pattern)?;
        }
        self.a = BlockMatrix::new(pattern);
        #[cfg(feature = "faer")]
        {
            if let Some(l) = self.lagged.take() {
                self.factorizations += l.factorizations;
            }
            self.ldlt = None;
        }
        self.topology = Some(sys.topology);
        Ok(())
    }

    /// Assembles `A = M − h∂F/∂v − h²∂F/∂x` and `b = M v + h F_nd` for the current state.
    pub fn assemble(&mut self, sys: &mut SoftSystem) -> Result<(), SoftError> {
        sys.check_lengths()?;
        check_gravity(sys)?;
        if self.topology != Some(sys.topology) {
            self.rebuild(sys)?;
        }
        let n = sys.len();
        let (ctx, h) = (self.ctx, self.ctx.h());
        self.a.clear();
        for i in 0..n {
            if let Some(s) = self.a.pattern.slot(i, i) {
                self.a.values[s] = DMat3::from_diagonal(DVec3::splat(sys.masses()[i]));
            }
        }
        for s in &sys.sets {
            s.add_implicit(&sys.x, &ctx, self.mode, sys.pinned(), &mut self.a);
        }
        self.f.resize(n, DVec3::ZERO);
        sys.forces(false, &mut self.f);
        self.b.clear();
        let (m, pinned) = (sys.masses(), sys.pinned());
        self.b.extend((0..n).map(|i| {
            if pinned[i] {
                DVec3::ZERO
            } else {
                sys.v[i] * m[i] + self.f[i] * h
            }
        }));
        Ok(())
    }
}

impl Integrator for ImplicitEuler {
    fn name(&self) -> String {
        let solver = match self.solver {
            LinearSolver::ConjugateGradient(_) => "CG",
            #[cfg(feature = "faer")]
            LinearSolver::SparseLdlt => "LDLT",
            #[cfg(feature = "faer")]
            LinearSolver::LaggedLdlt(_) => "lagged LDLT",
        };
        format!("implicit Euler ({solver}, {:?})", self.mode)
    }

    fn scheme(&self) -> Scheme {
        Scheme::ImplicitEuler {
            mode: self.mode,
            solver: self.solver,
        }
    }

    fn time_step(&self) -> f64 {
        self.ctx.h()
    }

    fn step(&mut self, sys: &mut SoftSystem) -> Result<SolveStats, SoftError> {
        self.assemble(sys)?;
        self.v_new.clear();
        self.v_new.extend_from_slice(&sys.v);
        let stats = match self.solver {
            LinearSolver::ConjugateGradient(s) => {
                self.cg.solve(&self.a, &self.b, &mut self.v_new, s)?
            }
            #[cfg(feature = "faer")]
            LinearSolver::SparseLdlt => {
                if self.ldlt.is_none() {
                    self.ldlt = Some(crate::direct::SparseLdlt::with_positions(&self.a, &sys.x)?);
                }
                let ldlt = self.ldlt.as_mut().ok_or(SoftError::Factorization)?;
                let mut st = ldlt.solve(&self.a, &self.b, &mut self.v_new)?;
                self.factorizations += 1;
                st.residual =
                    crate::lagged::relative_residual(&self.a, &self.b, &self.v_new, &mut self.f);
                st
            }
            #[cfg(feature = "faer")]
            LinearSolver::LaggedLdlt(settings) => {
                if self.lagged.is_none() {
                    self.lagged = Some(crate::lagged::LaggedLdlt::new(
                        crate::direct::SparseLdlt::with_positions(&self.a, &sys.x)?,
                    ));
                }
                let lagged = self.lagged.as_mut().ok_or(SoftError::Factorization)?;
                lagged.solve(&self.a, &self.b, &mut self.v_new, settings)?
            }
        };
        for (v, &p) in self.v_new.iter_mut().zip(sys.pinned()) {
            if p {
                *v = DVec3::ZERO;
            }
        }
        commit(sys, &self.ctx, &self.v_new, &mut self.x_new)?;
        Ok(stats)
    }
}
