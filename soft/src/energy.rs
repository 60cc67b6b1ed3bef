//! Soft-constraint energy, force and force Jacobians, derived generically from any
//! [`PointConstraint`].
//!
//! Otaduy 2010, "Restricciones débiles" and "Integración Implícita (1 Restricción)":
//!
//! ```text
//! E      = ½ k Σ_r C_r²
//! F      = −∇E = −k Σ_r C_r ∇C_r                       (Hooke for a spring)
//! ∂F/∂x  = −k Σ_r (∇C_r ∇C_rᵀ + C_r ∂²C_r/∂x²)
//! ```
//!
//! plus optional damping along the constraint, `F_d = −c Σ_r ∇C_r Ċ_r` with
//! `Ċ_r = ∇C_rᵀ v`, whose velocity Jacobian is `∂F_d/∂v = −c Σ_r ∇C_r ∇C_rᵀ`. (The
//! position derivative of the damping force is neglected, as is usual since
//! Baraff & Witkin 1998; it vanishes at `Ċ = 0`.)
//!
//! The term `−k C ∂²C/∂x²` makes `−∂F/∂x` indefinite when a constraint is violated in
//! the "wrong" direction (a compressed spring, an over-stretched triangle). Solvers that
//! need a positive (semi)definite matrix get one through [`HessianMode`].

use crate::project::project_psd_at;
use constraint_core::{math::outer, DMat3, DVec3, PointConstraint, StepContext};

/// Stiffness `k` and damping `c` of one soft constraint (SI: N/m and N·s/m for a spring).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Softness {
    /// Stiffness `k ≥ 0` in `E = ½kC²`.
    pub stiffness: f64,
    /// Damping `c ≥ 0` along the constraint gradient.
    pub damping: f64,
}

impl Softness {
    /// Stiffness `k` and no damping.
    pub const fn stiff(k: f64) -> Self {
        Self {
            stiffness: k,
            damping: 0.0,
        }
    }
}

/// How the curvature term `k C ∂²C/∂x²` of the energy Hessian enters the implicit matrix.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HessianMode {
    /// The exact Hessian. The system matrix may be indefinite: conjugate gradients can
    /// then fail with [`SoftError::Indefinite`](crate::SoftError); the sparse LDLᵀ solve
    /// still works while no pivot vanishes.
    Exact,
    /// Gauss–Newton: drop `k C ∂²C/∂x²`, keep `k ∇C∇Cᵀ`. Always positive semidefinite;
    /// loses the geometric stiffness (a spring's lateral stiffness `kC/L`).
    GaussNewton,
    /// Per-element projection (Teran et al. 2005): the element Hessian
    /// `k(∇C∇Cᵀ + C∂²C)` is eigen-decomposed and negative eigenvalues are set to zero.
    /// Positive semidefinite and exact wherever the element Hessian already is.
    #[default]
    Projected,
}

/// Energy `½ k Σ C_r²` of one constraint.
#[inline]
pub fn energy<C, const N: usize, const R: usize>(c: &C, s: Softness, x: &[DVec3; N]) -> f64
where
    C: PointConstraint<N, R>,
{
    0.5 * s.stiffness * c.value(x).iter().map(|v| v * v).sum::<f64>()
}

/// Elastic force `F_i = −k Σ_r C_r ∇_i C_r`, plus the damping force
/// `−c Σ_r ∇_i C_r (∇C_rᵀ v)` when velocities are given.
#[inline]
pub fn force<C, const N: usize, const R: usize>(
    c: &C,
    s: Softness,
    x: &[DVec3; N],
    v: Option<&[DVec3; N]>,
) -> [DVec3; N]
where
    C: PointConstraint<N, R>,
{
    let j = c.jacobian(x);
    let mut f = [DVec3::ZERO; N];
    for r in 0..R {
        let mut scale = s.stiffness * j.value[r];
        if let Some(v) = v {
            if s.damping != 0.0 {
                let cdot: f64 = j.grad[r].iter().zip(v.iter()).map(|(g, v)| g.dot(*v)).sum();
                scale += s.damping * cdot;
            }
        }
        for (fi, gi) in f.iter_mut().zip(j.grad[r].iter()) {
            *fi -= *gi * scale;
        }
    }
    f
}

/// Multiplies every block by `s`.
#[inline]
fn scale_blocks<const N: usize>(m: &mut [[DMat3; N]; N], s: f64) {
    for b in m.iter_mut().flatten() {
        *b *= s;
    }
}

/// `Σ_r ∇C_r ∇C_rᵀ` as blocks.
#[inline]
fn gram<const N: usize, const R: usize>(grad: &[[DVec3; N]; R]) -> [[DMat3; N]; N] {
    let mut g = [[DMat3::ZERO; N]; N];
    for row in grad {
        for i in 0..N {
            for j in 0..N {
                g[i][j] += outer(row[i], row[j]);
            }
        }
    }
    g
}

/// The energy Hessian `∂²E/∂x² = −∂F/∂x` of one constraint, treated per `mode`.
pub fn energy_hessian<C, const N: usize, const R: usize>(
    c: &C,
    k: f64,
    x: &[DVec3; N],
    mode: HessianMode,
) -> [[DMat3; N]; N]
where
    C: PointConstraint<N, R>,
{
    let j = c.jacobian(x);
    let mut h = gram(&j.grad);
    scale_blocks(&mut h, k);
    if mode == HessianMode::GaussNewton {
        return h;
    }
    let mut w = j.value;
    for wi in w.iter_mut() {
        *wi *= k;
    }
    if w.iter().all(|&wi| wi == 0.0) {
        // No curvature term: the Gram part alone is already PSD.
        return h;
    }
    let curv = c.curvature(x, &w);
    for i in 0..N {
        for jj in 0..N {
            h[i][jj] += curv.blocks[i][jj];
        }
    }
    if mode == HessianMode::Projected {
        project_psd_at(&mut h, x);
    }
    h
}

/// Force Jacobian `∂F/∂x = −k Σ_r (∇C_r∇C_rᵀ + C_r ∂²C_r/∂x²)` (exact for
/// [`HessianMode::Exact`]).
pub fn force_jacobian<C, const N: usize, const R: usize>(
    c: &C,
    k: f64,
    x: &[DVec3; N],
    mode: HessianMode,
) -> [[DMat3; N]; N]
where
    C: PointConstraint<N, R>,
{
    let mut h = energy_hessian(c, k, x, mode);
    scale_blocks(&mut h, -1.0);
    h
}

/// Damping Jacobian `∂F_d/∂v = −c Σ_r ∇C_r ∇C_rᵀ`.
pub fn damping_jacobian<C, const N: usize, const R: usize>(
    c: &C,
    damping: f64,
    x: &[DVec3; N],
) -> [[DMat3; N]; N]
where
    C: PointConstraint<N, R>,
{
    let mut g = gram(&c.jacobian(x).grad);
    scale_blocks(&mut g, -damping);
    g
}

/// Contribution `−h ∂F/∂v − h² ∂F/∂x` of one constraint to the implicit matrix
/// `A = M − h ∂F/∂v − h² ∂F/∂x` (slide "Integración Implícita"), computed with a single
/// Jacobian evaluation; `h` and `h²` come from the step context `ctx`.
pub fn implicit_blocks<C, const N: usize, const R: usize>(
    c: &C,
    s: Softness,
    x: &[DVec3; N],
    ctx: &StepContext,
    mode: HessianMode,
) -> [[DMat3; N]; N]
where
    C: PointConstraint<N, R>,
{
    let mut parts = implicit_parts(c, s, x, ctx, mode);
    if parts.project {
        project_psd_at(&mut parts.stiffness, x);
    }
    parts.sum()
}

/// [`implicit_blocks`] before the projection: the stiffness part `h²k(∇C∇Cᵀ + C∂²C)`
/// (with the damping folded in for Gauss–Newton), whether it still needs projecting,
/// and the damping part `h c ∇C∇Cᵀ`, added after the projection.
pub(crate) struct ImplicitParts<const N: usize> {
    pub(crate) stiffness: [[DMat3; N]; N],
    pub(crate) project: bool,
    pub(crate) damping: Option<[[DMat3; N]; N]>,
}

impl<const N: usize> ImplicitParts<N> {
    /// `stiffness + damping`.
    #[inline]
    pub(crate) fn sum(mut self) -> [[DMat3; N]; N] {
        if let Some(d) = &self.damping {
            for i in 0..N {
                for j in 0..N {
                    self.stiffness[i][j] += d[i][j];
                }
            }
        }
        self.stiffness
    }
}

/// The parts of [`implicit_blocks`] (see [`ImplicitParts`]).
#[inline]
pub(crate) fn implicit_parts<C, const N: usize, const R: usize>(
    c: &C,
    s: Softness,
    x: &[DVec3; N],
    ctx: &StepContext,
    mode: HessianMode,
) -> ImplicitParts<N>
where
    C: PointConstraint<N, R>,
{
    let j = c.jacobian(x);
    let g = gram(&j.grad);
    let h = ctx.h();
    // `h * h * k` as before: `h²` is the context's `h * h`.
    let h2k = ctx.h2() * s.stiffness;
    let mut a = [[DMat3::ZERO; N]; N];
    match mode {
        HessianMode::GaussNewton => {
            let coef = h2k + h * s.damping;
            for i in 0..N {
                for jj in 0..N {
                    a[i][jj] = g[i][jj] * coef;
                }
            }
            ImplicitParts {
                stiffness: a,
                project: false,
                damping: None,
            }
        }
        HessianMode::Exact | HessianMode::Projected => {
            let mut w = j.value;
            for wi in w.iter_mut() {
                *wi *= h2k;
            }
            // No curvature term: the Gram part alone is already PSD.
            let curved = !w.iter().all(|&wi| wi == 0.0);
            if curved {
                let curv = c.curvature(x, &w);
                for i in 0..N {
                    for jj in 0..N {
                        a[i][jj] = g[i][jj] * h2k + curv.blocks[i][jj];
                    }
                }
            } else {
                for i in 0..N {
                    for jj in 0..N {
                        a[i][jj] = g[i][jj] * h2k;
                    }
                }
            }
            let damping = (s.damping != 0.0).then(|| {
                let hc = h * s.damping;
                let mut d = g;
                for b in d.iter_mut().flatten() {
                    *b *= hc;
                }
                d
            });
            ImplicitParts {
                stiffness: a,
                project: curved && mode == HessianMode::Projected,
                damping,
            }
        }
    }
}
