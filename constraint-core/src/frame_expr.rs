//! Vectors built from two rigid bodies' poses, with their first and second derivatives
//! under `x ← x + δx`, `R ← exp(δθ) R` — the building block of every joint row.
//!
//! Every joint row of this crate is a dot product `A · B` (or a length `|A|`) of vectors
//! of the form
//!
//! `A = s_a x_a + s_b x_b + R_a u_a + R_b u_b + c`
//!
//! (centres of mass `x`, body-fixed vectors `u`, a constant `c`). With `p = R u` the
//! rotated vector, its derivatives are `∂A/∂x_a = s_a I`, `∂A/∂θ_a = −[p_a]×`, and its
//! second derivative contracted with a weight vector `w` is only on `(θ_a, θ_a)` and
//! `(θ_b, θ_b)`: from `exp(θ) p ≈ p + θ × p + ½ θ × (θ × p)`,
//! `∂²(w · exp(θ)p)/∂θ² = ½(w pᵀ + p wᵀ) − (w · p) I`.
//! For `C = A · B`: `∇C = J_Aᵀ B + J_Bᵀ A` and `∇²C = J_Aᵀ J_B + J_Bᵀ J_A + H_A[B] + H_B[A]`.

use glam::{DMat3, DVec3};

use crate::math::{outer, skew};
use crate::rigid::{Pose, TwistCurvature};

/// `A = s_a x_a + s_b x_b + p_a + p_b + c`, with `p_a = R_a u_a`, `p_b = R_b u_b` already
/// rotated into the world frame (the value includes everything).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FrameExpr {
    pub value: DVec3,
    pub s_a: f64,
    pub s_b: f64,
    pub p_a: DVec3,
    pub p_b: DVec3,
}

impl FrameExpr {
    /// A constant vector.
    pub fn constant(c: DVec3) -> Self {
        Self {
            value: c,
            s_a: 0.0,
            s_b: 0.0,
            p_a: DVec3::ZERO,
            p_b: DVec3::ZERO,
        }
    }

    /// `R_a u` (a direction fixed in body `a`).
    pub fn dir_a(a: &Pose, u: DVec3) -> Self {
        let p = a.q * u;
        Self {
            value: p,
            p_a: p,
            ..Self::constant(DVec3::ZERO)
        }
    }

    /// `R_b u` (a direction fixed in body `b`).
    pub fn dir_b(b: &Pose, u: DVec3) -> Self {
        let p = b.q * u;
        Self {
            value: p,
            p_b: p,
            ..Self::constant(DVec3::ZERO)
        }
    }

    /// `(x_b + R_b r_b) − (x_a + R_a r_a)`: from anchor `a` to anchor `b`.
    pub fn separation(a: &Pose, r_a: DVec3, b: &Pose, r_b: DVec3) -> Self {
        let p_a = -(a.q * r_a);
        let p_b = b.q * r_b;
        Self {
            value: b.x + p_b - a.x + p_a,
            s_a: -1.0,
            s_b: 1.0,
            p_a,
            p_b,
        }
    }

    /// `wᵀ ∂A` per block `[x_a, θ_a, x_b, θ_b]`: the gradient of `w · A`.
    /// (`w · (θ × p) = θ · (p × w)`.)
    pub fn grad(&self, w: DVec3) -> [DVec3; 4] {
        [
            w * self.s_a,
            self.p_a.cross(w),
            w * self.s_b,
            self.p_b.cross(w),
        ]
    }

    /// `∂A` per block as 3×3 matrices (`δA = Σ_k J_k δq_k`).
    pub fn jac(&self) -> [DMat3; 4] {
        [
            DMat3::from_diagonal(DVec3::splat(self.s_a)),
            -skew(self.p_a),
            DMat3::from_diagonal(DVec3::splat(self.s_b)),
            -skew(self.p_b),
        ]
    }

    /// Whether each block of [`Self::jac`] can be non-zero (`s ≠ 0`, `p ≠ 0`): a block
    /// that is not has only `±0` entries (with finite operands, so does every product
    /// with it).
    #[inline]
    pub fn live_blocks(&self) -> [bool; 4] {
        [
            self.s_a != 0.0,
            self.p_a != DVec3::ZERO,
            self.s_b != 0.0,
            self.p_b != DVec3::ZERO,
        ]
    }

    /// Adds `s · ∂²(w · A)` into `h` (a term with `p = 0` adds only zeros and is skipped,
    /// see [`add_dot_hessian`]).
    pub fn add_hessian(&self, w: DVec3, s: f64, h: &mut TwistCurvature) {
        if self.p_a != DVec3::ZERO {
            h.blocks[1][1] += rot_hessian(w, self.p_a) * s;
        }
        if self.p_b != DVec3::ZERO {
            h.blocks[3][3] += rot_hessian(w, self.p_b) * s;
        }
    }
}

/// `∂²(w · exp(θ)p)/∂θ²` at `θ = 0`: `½(w pᵀ + p wᵀ) − (w · p) I`.
#[inline]
pub(crate) fn rot_hessian(w: DVec3, p: DVec3) -> DMat3 {
    (outer(w, p) + outer(p, w)) * 0.5 - DMat3::from_diagonal(DVec3::splat(w.dot(p)))
}

/// Gradient of `A · B`.
#[inline]
pub(crate) fn dot_grad(a: &FrameExpr, b: &FrameExpr) -> [DVec3; 4] {
    let ga = a.grad(b.value);
    let gb = b.grad(a.value);
    [ga[0] + gb[0], ga[1] + gb[1], ga[2] + gb[2], ga[3] + gb[3]]
}

/// Adds `s · ∂²(A · B)` into `h`: `(J_Aᵢᵀ J_Bⱼ + J_Bᵢᵀ J_Aⱼ) s` into block `(i, j)`, then
/// `H_A[B] + H_B[A]` (module documentation).
///
/// Terms with a zero block of `J_A` or `J_B` ([`FrameExpr::live_blocks`]: a direction
/// fixed in one body has one live block of four) are skipped: each of their entries
/// is `±0`, and adding `±0` changes no entry of `h` — every `h` here starts at
/// [`TwistCurvature::ZERO`] and only receives sums, so its entries are non-zero or
/// `+0` (`x + (−x) = +0`, `+0 + (±0) = +0`). The result is the full product's to the
/// bit (finite poses); a Hinge's two direction rows take 2 block products instead of 32.
pub(crate) fn add_dot_hessian(a: &FrameExpr, b: &FrameExpr, s: f64, h: &mut TwistCurvature) {
    let ja = a.jac();
    let jb = b.jac();
    let (la, lb) = (a.live_blocks(), b.live_blocks());
    for i in 0..4 {
        for j in 0..4 {
            let m = match (la[i] && lb[j], lb[i] && la[j]) {
                (true, true) => ja[i].transpose() * jb[j] + jb[i].transpose() * ja[j],
                (true, false) => ja[i].transpose() * jb[j],
                (false, true) => jb[i].transpose() * ja[j],
                (false, false) => continue,
            };
            h.blocks[i][j] += m * s;
        }
    }
    a.add_hessian(b.value, s, h);
    b.add_hessian(a.value, s, h);
}

/// Adds `s · ∂²|A|` into `h` (`|A| > 0`): `J_Aᵀ (I − n nᵀ) J_A / |A| + H_A[n]`.
pub(crate) fn add_norm_hessian(a: &FrameExpr, s: f64, h: &mut TwistCurvature) {
    let len = a.value.length();
    if !(len > 0.0) {
        return;
    }
    let n = a.value / len;
    let p = (DMat3::IDENTITY - outer(n, n)) * (1.0 / len);
    let ja = a.jac();
    // Products with a zero block skipped, as in `add_dot_hessian`.
    let la = a.live_blocks();
    for i in 0..4 {
        for j in 0..4 {
            if la[i] && la[j] {
                h.blocks[i][j] += ja[i].transpose() * p * ja[j] * s;
            }
        }
    }
    a.add_hessian(n, s, h);
}
