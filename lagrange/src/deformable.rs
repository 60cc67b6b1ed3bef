//! Deformables (cloth, tetrahedral solids) in contact with rigid shapes, solved together
//! with the soft crate's linearized backward Euler step, in the spirit of Otaduy et al.
//! 2009 ("Implicit contact handling for deformable objects"): the contact rows enter the
//! *implicit* velocity system, so stiff internal forces and contact forces are balanced
//! in one solve.
//!
//! Each particle `i` closer than `margin` to a collider's surface gets one row, the
//! lecture's `d_i = nᵀ(p_i − p) ≥ 0` at velocity level:
//!
//! ```text
//! [A  Jᵀ] [v']   [b]
//! [J  0 ] [λ ] = [c],    J v' ≥ c = depth/Δt,   −λ ≥ 0 (the contact pushes),   complementary
//! ```
//!
//! with `A`, `b` the implicit step's matrix and right-hand side
//! (`(M − h ∂F/∂v − h² ∂F/∂x) v' = (M − h ∂F/∂v) v + h F`). The LCP is solved by an
//! active-set method on the KKT system (the lagrange crate's solvers): rows whose
//! multiplier would pull are released, separated rows that the new velocity violates are
//! added, until the set repeats (exact for the convex QP this LCP is, `A` symmetric
//! positive definite). Friction is applied after the solve by Coulomb's law on each
//! contacting particle's tangential velocity, limited by `μ |λ|/m` (a first-order,
//! explicit friction projection; documented, not an LCP).

use alloc::vec;
use alloc::vec::Vec;

use crate::{solve_kkt, ConstraintRows, KktProblem, KktSolver, KktWorkspace, MassMatrix};
use constraint_core::{DVec3, Pose};
use constraint_soft::{ImplicitEuler, Integrator, SoftSystem};

use constraint_contact::geometry::{point_vs, Collider};

/// Settings of the deformable contact step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeformableSettings {
    /// Particle radius (m): the contact surface is offset by it.
    pub radius: f64,
    /// Rows are made for particles within this distance of contact (m), plus twice the
    /// distance they travel in the step.
    pub margin: f64,
    /// Most active-set iterations per step.
    pub max_active_set_iterations: usize,
    /// Multiplier and violation tolerance of the active set (relative).
    pub tolerance: f64,
}

impl Default for DeformableSettings {
    fn default() -> Self {
        Self {
            radius: 0.0,
            margin: 0.01,
            max_active_set_iterations: 20,
            tolerance: 1e-9,
        }
    }
}

/// What a step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeformableStats {
    /// Candidate contact rows (particles within the margin).
    pub candidates: usize,
    /// Rows active at the end.
    pub active: usize,
    /// Active-set iterations.
    pub iterations: usize,
    /// Whether the active set settled (else the last iterate was kept: reported).
    pub settled: bool,
    /// Deepest penetration before the step (m).
    pub max_penetration: f64,
}

/// Errors of the deformable contact step.
#[derive(Clone, Debug, PartialEq)]
pub enum DeformableError {
    /// The soft step failed (assembly or divergence).
    Soft(constraint_soft::SoftError),
    /// The KKT solve failed.
    Kkt(crate::KktError),
    /// A parameter was out of range.
    InvalidParameter {
        /// Name.
        name: &'static str,
        /// Rule.
        rule: &'static str,
    },
    /// A collider is attached to a body: only static colliders here.
    MovingCollider {
        /// The collider.
        collider: usize,
    },
}

impl core::fmt::Display for DeformableError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Soft(e) => write!(f, "soft step: {e}"),
            Self::Kkt(e) => write!(f, "contact KKT: {e:?}"),
            Self::InvalidParameter { name, rule } => write!(f, "parameter {name}: {rule}"),
            Self::MovingCollider { collider } => {
                write!(
                    f,
                    "collider {collider} is on a body; deformable contact takes static colliders"
                )
            }
        }
    }
}

impl core::error::Error for DeformableError {}

/// A candidate contact: particle, collider normal, target `c = depth/Δt`, friction.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    particle: usize,
    normal: DVec3,
    target: f64,
    mu: f64,
    depth: f64,
}

/// The implicit soft step with particle contacts against static colliders.
#[derive(Debug)]
pub struct DeformableContact {
    /// Static colliders (`body: None`).
    pub colliders: Vec<Collider>,
    /// Settings.
    pub settings: DeformableSettings,
    candidates: Vec<Candidate>,
    active: Vec<bool>,
    rows: ConstraintRows,
    ws: KktWorkspace,
}

impl DeformableContact {
    /// A contact handler for the given static colliders.
    pub fn new(
        colliders: Vec<Collider>,
        settings: DeformableSettings,
    ) -> Result<Self, DeformableError> {
        if let Some(k) = colliders.iter().position(|c| c.body.is_some()) {
            return Err(DeformableError::MovingCollider { collider: k });
        }
        let bad = |name, rule| Err(DeformableError::InvalidParameter { name, rule });
        if !(settings.radius >= 0.0) || !settings.radius.is_finite() {
            return bad("radius", "must be finite and non-negative");
        }
        if !(settings.margin >= 0.0) || !settings.margin.is_finite() {
            return bad("margin", "must be finite and non-negative");
        }
        if !(settings.tolerance > 0.0) || settings.max_active_set_iterations == 0 {
            return bad("tolerance/iterations", "must be positive");
        }
        Ok(Self {
            colliders,
            settings,
            candidates: Vec::new(),
            active: Vec::new(),
            rows: ConstraintRows::new(),
            ws: KktWorkspace::default(),
        })
    }

    /// One step of `imp`'s size: implicit soft forces and contacts in one KKT system.
    ///
    /// # Errors
    /// Soft assembly errors, KKT errors, and `Soft(Diverged)` for a non-finite or
    /// exploding new state (beyond 1e12 m or m/s). The system is unchanged after any
    /// error.
    pub fn step(
        &mut self,
        sys: &mut SoftSystem,
        imp: &mut ImplicitEuler,
    ) -> Result<DeformableStats, DeformableError> {
        // The public `x`/`v` may have been resized away from the particle count.
        sys.check_lengths().map_err(DeformableError::Soft)?;
        let h = imp.time_step();
        let s = self.settings;
        let mut stats = DeformableStats::default();
        // Candidates.
        self.candidates.clear();
        for (i, x) in sys.x.iter().enumerate() {
            if sys.pinned()[i] {
                continue;
            }
            // Speculative reach: the margin plus the distance the particle can cover in
            // this step (with room for the step's gravity), so fast particles get their
            // row before they cross the surface.
            let reach = s.margin + 2.0 * h * sys.v[i].length() + h * h * sys.gravity.length();
            for c in &self.colliders {
                if let Some(pc) = point_vs(c, &Pose::IDENTITY, *x, s.radius, reach) {
                    self.candidates.push(Candidate {
                        particle: i,
                        normal: pc.normal,
                        target: pc.depth / h,
                        mu: c.friction,
                        depth: pc.depth,
                    });
                    stats.max_penetration = stats.max_penetration.max(pc.depth);
                }
            }
        }
        stats.candidates = self.candidates.len();
        imp.assemble(sys).map_err(DeformableError::Soft)?;
        // Active set: start from the touching/penetrating candidates.
        self.active.clear();
        self.active
            .extend(self.candidates.iter().map(|c| c.depth >= 0.0));
        let n = sys.len();
        let mut v = sys.v.clone();
        let mut lambda: Vec<f64> = Vec::new();
        let mut settled = false;
        let mut seen: Vec<Vec<bool>> = Vec::new();
        for it in 0..s.max_active_set_iterations {
            stats.iterations = it + 1;
            self.rows.clear();
            let mut c = Vec::new();
            let mut idx = Vec::new();
            for (k, cand) in self.candidates.iter().enumerate() {
                if self.active[k] {
                    self.rows.push_row(0.0, &[(cand.particle, cand.normal)]);
                    c.push(cand.target);
                    idx.push(k);
                }
            }
            let compliance = vec![0.0; idx.len()];
            lambda.clear();
            lambda.resize(idx.len(), 0.0);
            v.clone_from(&sys.v);
            let p = KktProblem {
                mass: MassMatrix::Block {
                    a: imp.matrix(),
                    pinned: sys.pinned(),
                },
                rows: &self.rows,
                compliance: &compliance,
                b: imp.rhs(),
                c: &c,
            };
            solve_kkt(&p, KktSolver::Auto, &mut self.ws, &mut v, &mut lambda)
                .map_err(DeformableError::Kkt)?;
            // Release pulling rows (force −Jᵀλ must push along +n: λ ≤ 0); add violated ones.
            let scale = lambda.iter().fold(1e-12f64, |m, l| m.max(l.abs()));
            let mut changed = false;
            for (r, &k) in idx.iter().enumerate() {
                if lambda[r] > s.tolerance * scale {
                    self.active[k] = false;
                    changed = true;
                }
            }
            for (k, cand) in self.candidates.iter().enumerate() {
                if !self.active[k] {
                    let rate = cand.normal.dot(v[cand.particle]);
                    if rate < cand.target - s.tolerance * (1.0 + cand.target.abs()) {
                        self.active[k] = true;
                        changed = true;
                    }
                }
            }
            if !changed {
                settled = true;
                break;
            }
            // Cycling guard: a set seen before ends the loop (reported as not settled).
            if seen.contains(&self.active) {
                break;
            }
            seen.push(self.active.clone());
        }
        stats.settled = settled;
        stats.active = self.active.iter().filter(|a| **a).count();
        // Coulomb friction on the active particles' tangential velocity: the normal
        // impulse |λ| allows a tangential velocity change of at most μ|λ|/m.
        let mut r = 0;
        for (k, cand) in self.candidates.iter().enumerate() {
            if !self.active[k] {
                continue;
            }
            let lam = lambda.get(r).copied().unwrap_or(0.0).abs();
            r += 1;
            let i = cand.particle;
            let vn = cand.normal * cand.normal.dot(v[i]);
            let vt = v[i] - vn;
            let speed = vt.length();
            let dv = cand.mu * lam / sys.masses()[i];
            v[i] = if speed <= dv {
                vn
            } else {
                vn + vt * (1.0 - dv / speed)
            };
        }
        // The new state is built aside and committed only when every value is finite and
        // bounded (the soft integrators' rule): a non-finite position written through
        // the public `x`, or an exploding solve, is `Diverged` with the state unchanged.
        let pinned = sys.pinned();
        for (vi, &p) in v.iter_mut().zip(pinned) {
            if p {
                *vi = DVec3::ZERO;
            }
        }
        let x_new: Vec<DVec3> = sys
            .x
            .iter()
            .zip(&v)
            .take(n)
            .map(|(x, vi)| *x + *vi * h)
            .collect();
        if let Some(particle) = constraint_core::math::first_out_of_limit(&x_new, &v) {
            return Err(DeformableError::Soft(
                constraint_soft::SoftError::Diverged {
                    step: sys.steps,
                    particle,
                },
            ));
        }
        sys.set_velocities(&v).map_err(DeformableError::Soft)?;
        sys.x.copy_from_slice(&x_new);
        // Count the step, as the soft and Lagrange steppers do (the `step` of a later
        // `Diverged` names it).
        sys.steps += 1;
        Ok(stats)
    }
}
