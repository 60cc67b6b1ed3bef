//! The constraint abstraction.
//!
//! A constraint is a vector function `C(x) ∈ ℝ^R` of the positions of a stencil of `N`
//! points that must vanish (Otaduy 2010, "Concepto de Restricción": `C(x) = 0`). Every
//! treatment in the other crates — soft energy `E = ½kC²`, hard Lagrange rows `J v =
//! −C/Δt`, unilateral contact rows — needs only three things from it:
//!
//! * the value `C(x)`;
//! * the Jacobian `J = ∂C/∂x` ("Notación Jacobiana: `∇C = (∂C/∂x)ᵀ = Jᵀ`");
//! * the curvature `Σ_r w_r ∂²C_r/∂x²`, the second-derivative term of the force Jacobian
//!   `∂F/∂x = −k∇C∇Cᵀ − kC ∂²C/∂x²` (slide "Integración Implícita (1 Restricción)"),
//!   where the soft crate passes `w = kC`.
//!
//! Point stencils live here. Rigid-body stencils (Jacobian blocks with respect to the
//! twist `(v, ω)`) get a sibling trait when the articulated crate needs them; consumers
//! of constraints work with [`Jacobian`] rows, so they will accept both.

use glam::{DMat3, DVec3};

/// Value and Jacobian of a constraint with `N` points and `R` rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jacobian<const N: usize, const R: usize> {
    /// `C_r(x)` for each row.
    pub value: [f64; R],
    /// `grad[r][i] = ∂C_r/∂x_i`, the block of row `r` for point `i`.
    pub grad: [[DVec3; N]; R],
}

/// Weighted curvature `Σ_r w_r ∂²C_r/∂x²` as `N × N` blocks of 3×3.
///
/// Block `[i][j]` is `Σ_r w_r ∂²C_r/∂x_i∂x_j`; the whole matrix is symmetric, so
/// `blocks[j][i] = blocks[i][j]ᵀ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvature<const N: usize> {
    /// The blocks, row-major by point.
    pub blocks: [[DMat3; N]; N],
}

impl<const N: usize> Curvature<N> {
    /// The zero matrix (a constraint linear in `x`).
    pub const ZERO: Self = Self {
        blocks: [[DMat3::ZERO; N]; N],
    };

    /// Multiplies every block by `s`.
    #[inline]
    pub fn scaled(mut self, s: f64) -> Self {
        for row in &mut self.blocks {
            for b in row {
                *b *= s;
            }
        }
        self
    }

    /// The entry at scalar row `a` and column `b` (`0 ≤ a, b < 3N`).
    #[inline]
    pub fn entry(&self, a: usize, b: usize) -> f64 {
        self.blocks[a / 3][b / 3].col(b % 3)[a % 3]
    }
}

/// A constraint `C(x) = 0` on `N` points with `R` scalar rows.
///
/// Implementations are plain data (indices and rest values) and never allocate.
/// Evaluation must return finite numbers for every finite input; where a derivative is
/// undefined (coincident points, a collapsed triangle) the implementation documents the
/// finite value it returns.
pub trait PointConstraint<const N: usize, const R: usize> {
    /// Indices of the stencil's points in the caller's position array.
    fn stencil(&self) -> [usize; N];

    /// The value `C(x)`.
    fn value(&self, x: &[DVec3; N]) -> [f64; R];

    /// The value together with the Jacobian `J = ∂C/∂x` (they share most of the work).
    fn jacobian(&self, x: &[DVec3; N]) -> Jacobian<N, R>;

    /// The weighted curvature `Σ_r w_r ∂²C_r/∂x²`.
    fn curvature(&self, x: &[DVec3; N], w: &[f64; R]) -> Curvature<N>;

    /// Gathers the stencil's positions from a global array; `None` when an index is out
    /// of bounds.
    #[inline]
    fn gather(&self, positions: &[DVec3]) -> Option<[DVec3; N]> {
        let idx = self.stencil();
        let mut out = [DVec3::ZERO; N];
        for (o, &i) in out.iter_mut().zip(idx.iter()) {
            *o = *positions.get(i)?;
        }
        Some(out)
    }
}
