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

/// Conjugate-gradient workspace.
#[derive(Clone, Debug, Default)]
pub struct Cg {
    r: Vec<DVec3>,
    z: Vec<DVec3>,
    p: Vec<DVec3>,
    ap: Vec<DVec3>,
    dinv: Vec<DMat3>,
}

fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a.dot(*b)).sum()
}

impl Cg {
    fn resize(&mut self, n: usize) {
        for v in [&mut self.r, &mut self.z, &mut self.p, &mut self.ap] {
            v.resize(n, DVec3::ZERO);
        }
        self.dinv.resize(n, DMat3::ZERO);
    }

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
        let n = b.len();
        self.resize(n);
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
        let bnorm = dot(b, b).sqrt();
        if bnorm == 0.0 {
            x.fill(DVec3::ZERO);
            return Ok(SolveStats {
                iterations: 0,
                residual: 0.0,
                converged: true,
            });
        }
        a.mul_vec(x, &mut self.ap);
        for i in 0..n {
            self.r[i] = b[i] - self.ap[i];
            self.z[i] = self.dinv[i] * self.r[i];
            self.p[i] = self.z[i];
        }
        let mut rz = dot(&self.r, &self.z);
        let mut res = dot(&self.r, &self.r).sqrt() / bnorm;
        let mut it = 0;
        while res > settings.tolerance && it < settings.max_iterations {
            a.mul_vec(&self.p, &mut self.ap);
            let pap = dot(&self.p, &self.ap);
            if !(pap > 0.0) {
                return Err(SoftError::Indefinite { iteration: it });
            }
            let alpha = rz / pap;
            for i in 0..n {
                x[i] += self.p[i] * alpha;
                self.r[i] -= self.ap[i] * alpha;
                self.z[i] = self.dinv[i] * self.r[i];
            }
            let rz_new = dot(&self.r, &self.z);
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..n {
                self.p[i] = self.z[i] + self.p[i] * beta;
            }
            res = dot(&self.r, &self.r).sqrt() / bnorm;
            it += 1;
        }
        Ok(SolveStats {
            iterations: it,
            residual: res,
            converged: res <= settings.tolerance,
        })
    }
}
