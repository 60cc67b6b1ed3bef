//! Preconditioned conjugate gradients on a [`BlockMatrix`].
//!
//! Hestenes & Stiefel 1952 with a block-Jacobi preconditioner (the inverse of each 3×3
//! diagonal block). Work vectors live in [`Cg`] and are reused across solves; nothing
//! allocates once the sizes are known. A curvature `pᵀAp ≤ 0` means the matrix is not
//! positive definite and is reported as [`SoftError::Indefinite`].

use crate::bsr::BlockMatrix;
use crate::error::SoftError;
use constraint_core::{DMat3, DVec3};

/// Stopping rule for conjugate gradients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CgSettings {
    /// Stop when `|b − Ax| ≤ tolerance · |b|`.
    pub tolerance: f64,
    /// Give up after this many iterations (the result is then marked not converged).
    pub max_iterations: usize,
}

impl Default for CgSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: 1000,
        }
    }
}

/// Outcome of a linear solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Iterations used (1 for a direct solve).
    pub iterations: usize,
    /// Final relative residual `|b − Ax| / |b|`.
    pub residual: f64,
    /// Whether the tolerance was met.
    pub converged: bool,
}

/// How a preconditioned CG run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PcgEnd {
    /// `|b − Ax| ≤ tolerance·|b|`.
    Converged,
    /// The iteration budget ran out first.
    OutOfIterations,
    /// `pᵀAp ≤ 0` or `rᵀz ≤ 0` (or NaN): the matrix or the preconditioner is not
    /// positive definite.
    Breakdown,
}

/// A preconditioner application `z = P⁻¹ r`.
pub(crate) type Precond<'a> = dyn FnMut(&[DVec3], &mut [DVec3]) -> Result<(), SoftError> + 'a;

/// Work vectors of preconditioned conjugate gradients, reused across solves.
#[derive(Clone, Debug, Default)]
pub(crate) struct PcgWork {
    r: Vec<DVec3>,
    z: Vec<DVec3>,
    p: Vec<DVec3>,
    ap: Vec<DVec3>,
}

impl PcgWork {
    /// Scratch of length `n` (for a residual computed outside [`PcgWork::run`]).
    // Only the lagged preconditioner (feature `faer`) computes a residual outside `run`.
    #[cfg_attr(not(feature = "faer"), allow(dead_code))]
    pub(crate) fn scratch(&mut self, n: usize) -> &mut [DVec3] {
        self.ap.resize(n, DVec3::ZERO);
        &mut self.ap
    }

    /// Preconditioned CG (Hestenes & Stiefel 1952) on `A x = b` from the given `x`,
    /// with `precond(r, z)` writing `z = P⁻¹ r`. Returns how it ended, the iterations
    /// and the relative residual `|b − Ax| / |b|` (a zero `b` gives `x = 0` at once).
    ///
    /// # Errors
    /// Only what `precond` returns.
    pub(crate) fn run(
        &mut self,
        a: &BlockMatrix,
        b: &[DVec3],
        x: &mut [DVec3],
        tolerance: f64,
        max_iterations: usize,
        precond: &mut Precond<'_>,
    ) -> Result<(PcgEnd, usize, f64), SoftError> {
        let n = b.len();
        for v in [&mut self.r, &mut self.z, &mut self.p, &mut self.ap] {
            v.resize(n, DVec3::ZERO);
        }
        let bnorm = dot(b, b).sqrt();
        if bnorm == 0.0 {
            x.fill(DVec3::ZERO);
            return Ok((PcgEnd::Converged, 0, 0.0));
        }
        a.mul_vec(x, &mut self.ap);
        for i in 0..n {
            self.r[i] = b[i] - self.ap[i];
        }
        precond(&self.r, &mut self.z)?;
        self.p.copy_from_slice(&self.z);
        let mut rz = dot(&self.r, &self.z);
        let mut res = dot(&self.r, &self.r).sqrt() / bnorm;
        let mut it = 0;
        while res > tolerance {
            if it == max_iterations {
                return Ok((PcgEnd::OutOfIterations, it, res));
            }
            a.mul_vec(&self.p, &mut self.ap);
            let pap = dot(&self.p, &self.ap);
            if !(pap > 0.0 && rz > 0.0) {
                return Ok((PcgEnd::Breakdown, it, res));
            }
            let alpha = rz / pap;
            for i in 0..n {
                x[i] += self.p[i] * alpha;
                self.r[i] -= self.ap[i] * alpha;
            }
            precond(&self.r, &mut self.z)?;
            let rz_new = dot(&self.r, &self.z);
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..n {
                self.p[i] = self.z[i] + self.p[i] * beta;
            }
            res = dot(&self.r, &self.r).sqrt() / bnorm;
            it += 1;
        }
        Ok((PcgEnd::Converged, it, res))
    }
}

/// Conjugate-gradient workspace.
#[derive(Clone, Debug, Default)]
pub struct Cg {
    work: PcgWork,
    dinv: Vec<DMat3>,
}

fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a.dot(*b)).sum()
}

impl Cg {
    /// Solves `A x = b`, starting from the given `x`.
    ///
    /// # Errors
    /// [`SoftError::Indefinite`] when `pᵀAp ≤ 0` (or is NaN) is met.
    pub fn solve(
        &mut self,
        a: &BlockMatrix,
        b: &[DVec3],
        x: &mut [DVec3],
        settings: CgSettings,
    ) -> Result<SolveStats, SoftError> {
        self.dinv.resize(b.len(), DMat3::ZERO);
        a.diagonal(&mut self.dinv);
        for d in &mut self.dinv {
            let det = d.determinant();
            *d = if det.is_finite() && det > 0.0 {
                d.inverse()
            } else {
                // Not SPD on the diagonal: fall back to the absolute diagonal.
                let diag = DVec3::new(d.x_axis.x, d.y_axis.y, d.z_axis.z).abs();
                DMat3::from_diagonal(diag.max(DVec3::splat(f64::MIN_POSITIVE)).recip())
            };
        }
        let dinv = &self.dinv;
        let (end, iterations, residual) = self.work.run(
            a,
            b,
            x,
            settings.tolerance,
            settings.max_iterations,
            &mut |r, z| {
                for ((zi, ri), d) in z.iter_mut().zip(r).zip(dinv) {
                    *zi = *d * *ri;
                }
                Ok(())
            },
        )?;
        match end {
            PcgEnd::Breakdown => Err(SoftError::Indefinite {
                iteration: iterations,
            }),
            _ => Ok(SolveStats {
                iterations,
                residual,
                converged: end == PcgEnd::Converged,
            }),
        }
    }
}
