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

/// A sum `Σ_i rot_hessian(w_i, p_i)` (the angular diagonal block of a joint's curvature)
/// kept as `M = Σ_i w_i p_iᵀ`, from which the sum is `½(M + Mᵀ) − tr(M) I`
/// ([`rot_hessian`] is linear in `w pᵀ`), and `σ = Σ_i |w_i| |p_i|`, the scale of its
/// round-off: a bound on the block's Frobenius norm at a few dozen flops, without the
/// joint's curvature.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RotHessianSum {
    m: DMat3,
    scale: f64,
}

impl RotHessianSum {
    /// The empty sum.
    pub const ZERO: Self = Self {
        m: DMat3::ZERO,
        scale: 0.0,
    };

    /// Adds the term `rot_hessian(w, p)`.
    #[inline]
    pub fn add(&mut self, w: DVec3, p: DVec3) {
        self.m += outer(w, p);
        self.scale += libm::sqrt(w.length_squared() * p.length_squared());
    }

    /// Upper bounds on the block `H = Σ_i rot_hessian(w_i, p_i)` as the curvature
    /// computes it (the same `w_i`, `p_i` to the bit, summed in any order, scaled by
    /// `s` before or after the sum), [`BlockBounds`]:
    ///
    /// - its Frobenius norm, `‖H‖_F + 1e-12 σ`. In exact arithmetic `‖H‖_F² = Σ_j (M_jj −
    ///   t)² + 2 Σ_{j<k} ((M_jk + M_kj)/2)²` with `t = tr M`. Each entry of `H`, computed
    ///   either way, is a sum of at most a few dozen products of terms bounded by
    ///   `|w_i| |p_i|`, so it is within `γ_n σ ≤ 1e-14 σ` of the exact entry (`n ≤ 40`,
    ///   `u = 2⁻⁵³`), and the two computed norms differ by at most `3 · 2 · 1e-14 σ`:
    ///   the margin `1e-12 σ` covers that ~15 times over.
    /// - the largest eigenvalue of its positive semi-definite part, `max(μ + √(2/3)
    ///   ‖D‖_F, 0) + 1e-6 σ` with the mean `μ = tr H / 3 = −2t/3` and the deviator `D = H
    ///   − μ I = ½(M + Mᵀ) − (t/3) I`: the deviations `d_j` of the eigenvalues from `μ`
    ///   sum to zero, so `d_max² ≤ (2/3) Σ d_j² = (2/3) ‖D‖_F²` (equality for the
    ///   eigenvalues `(2a, −a, −a)`: a single term with `w ∥ p` is negative
    ///   semi-definite, and the bound is then the margin). The margin covers what the
    ///   geometric stiffness's eigen-solve adds (`psd_part`'s Jacobi rotations to `1e-15`
    ///   of the diagonal, then `symmetric_eigenvalues`' `acos`, whose argument near −1 —
    ///   the two largest eigenvalues equal — turns a round-off `δr ≈ 1e-14` into `δφ ≈
    ///   √(2δr)/3 ≈ 5e-8`, at most `2p · 5e-8 ≤ 6e-8 σ` with `p ≤ ‖H‖_F/√6`,
    ///   `‖H‖_F ≤ √2 σ`): ~15 times over.
    ///
    /// Non-finite inputs give non-finite or NaN bounds.
    pub fn bounds(&self) -> BlockBounds {
        let m = &self.m;
        let t = m.x_axis.x + m.y_axis.y + m.z_axis.z;
        let (d0, d1, d2) = (m.x_axis.x - t, m.y_axis.y - t, m.z_axis.z - t);
        // `m.col(c)[r]` is `M_rc`.
        let o01 = 0.5 * (m.y_axis.x + m.x_axis.y);
        let o02 = 0.5 * (m.z_axis.x + m.x_axis.z);
        let o12 = 0.5 * (m.z_axis.y + m.y_axis.z);
        let off = 2.0 * (o01 * o01 + o02 * o02 + o12 * o12);
        let frobenius = libm::sqrt(d0 * d0 + d1 * d1 + d2 * d2 + off) + 1e-12 * self.scale;
        let t3 = t / 3.0;
        let (e0, e1, e2) = (m.x_axis.x - t3, m.y_axis.y - t3, m.z_axis.z - t3);
        let dev_sq = e0 * e0 + e1 * e1 + e2 * e2 + off;
        let top = -2.0 * t3 + libm::sqrt(dev_sq * (2.0 / 3.0));
        // `f64::max` would turn a NaN into 0: keep it.
        let top = if top > 0.0 || top.is_nan() { top } else { 0.0 };
        BlockBounds {
            frobenius,
            max_eigenvalue: top + 1e-6 * self.scale,
        }
    }
}

/// Upper bounds on one angular diagonal block `H` of a joint's curvature as
/// [`crate::BodyConstraint::curvature`] computes it (round-off included), which decide
/// whether the geometric stiffness needs the curvature at all.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockBounds {
    /// At least `‖H‖_F`.
    pub frobenius: f64,
    /// At least the largest eigenvalue of `H`'s positive semi-definite part as
    /// `body::symmetric_eigenvalues(&body::psd_part(&H))[2]` computes it (so at least
    /// 0).
    pub max_eigenvalue: f64,
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
///
/// Each block product `J_Aᵢᵀ J_Bⱼ` is formed by [`block_product`] from the blocks' shapes
/// (`s I` or `−[p]×`) without its terms that multiply a zero entry: the same sums, in the
/// same order, of the same non-zero terms, so each entry is the full product's up to
/// the sign of a zero — which, as above, no entry of `h` keeps.
pub(crate) fn add_dot_hessian(a: &FrameExpr, b: &FrameExpr, s: f64, h: &mut TwistCurvature) {
    let ja = a.blocks();
    let jb = b.blocks();
    let (la, lb) = (a.live_blocks(), b.live_blocks());
    for i in 0..4 {
        for j in 0..4 {
            let m = match (la[i] && lb[j], lb[i] && la[j]) {
                (true, true) => block_product(&ja[i], &jb[j]) + block_product(&jb[i], &ja[j]),
                (true, false) => block_product(&ja[i], &jb[j]),
                (false, true) => block_product(&jb[i], &ja[j]),
                (false, false) => continue,
            };
            h.blocks[i][j] += m * s;
        }
    }
    a.add_hessian(b.value, s, h);
    b.add_hessian(a.value, s, h);
}

/// One block of [`FrameExpr::jac`] by its shape: `s I` (a position's) or `M = −[p]×` (a
/// rotated vector's: zero diagonal).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Block {
    /// `s I`.
    Scale(f64),
    /// `−[p]×`, as [`FrameExpr::jac`] builds it.
    Skew(DMat3),
}

impl FrameExpr {
    /// [`Self::jac`]'s blocks with their shapes ([`Block`]).
    #[inline]
    pub fn blocks(&self) -> [Block; 4] {
        [
            Block::Scale(self.s_a),
            Block::Skew(-skew(self.p_a)),
            Block::Scale(self.s_b),
            Block::Skew(-skew(self.p_b)),
        ]
    }
}

/// `Xᵀ Y` for two blocks ([`Block`]), entry for entry the product `Xᵀ * Y` of the full
/// matrices (glam's: column `c` is `Xᵀ.x_axis y_0c + Xᵀ.y_axis y_1c + Xᵀ.z_axis y_2c`,
/// summed in that order) without the terms with a zero factor (finite entries): a
/// term `0 · y` is `±0`, and `(u + ±0) + v`, `(±0 + u) + v`, `(u + v) + ±0` are `u + v`
/// up to the sign of a zero result. So `(sI)ᵀ(tI)` is `st` on the diagonal (zeros
/// elsewhere), `(sI)ᵀ M` is `s M` and `Mᵀ (tI)` is `t Mᵀ` (one term per entry), and
/// `Mᵀ N` of two zero-diagonal blocks keeps the one term `m_kr n_kc` (`k` the third
/// index) off the diagonal and the two terms `k ≠ r` in `k` order on it.
#[inline(always)]
fn block_product(x: &Block, y: &Block) -> DMat3 {
    match (x, y) {
        (Block::Scale(s), Block::Scale(t)) => DMat3::from_diagonal(DVec3::splat(s * t)),
        (Block::Scale(s), Block::Skew(m)) => *m * *s,
        (Block::Skew(m), Block::Scale(t)) => m.transpose() * *t,
        (Block::Skew(m), Block::Skew(n)) => {
            // `m.col(c)[r]` is `m_rc`; entry `(r, c)` of `Mᵀ N` is `Σ_k m_kr n_kc`.
            let e = |r: usize, c: usize| -> f64 {
                let (mr, nc) = (m.col(r), n.col(c));
                if r == c {
                    let (k0, k1) = match r {
                        0 => (1, 2),
                        1 => (0, 2),
                        _ => (0, 1),
                    };
                    mr[k0] * nc[k0] + mr[k1] * nc[k1]
                } else {
                    let k = 3 - r - c;
                    mr[k] * nc[k]
                }
            };
            DMat3::from_cols(
                DVec3::new(e(0, 0), e(1, 0), e(2, 0)),
                DVec3::new(e(0, 1), e(1, 1), e(2, 1)),
                DVec3::new(e(0, 2), e(1, 2), e(2, 2)),
            )
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    /// The full block products [`add_dot_hessian`] replaced: `J_Aᵢᵀ J_Bⱼ` by glam's
    /// 3×3 product of [`FrameExpr::jac`]'s blocks.
    fn add_dot_hessian_full(a: &FrameExpr, b: &FrameExpr, s: f64, h: &mut TwistCurvature) {
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

    /// `RotHessianSum::bounds` bounds the sum `H` of `rot_hessian(w_i, p_i) · s_i` as
    /// the curvature accumulates it: its Frobenius norm, and the largest eigenvalue of
    /// its PSD part as the geometric stiffness computes it (`psd_part`, then
    /// `symmetric_eigenvalues`). 120 000 random sums of 1 to 4 terms (the scale on the
    /// matrix, as the joints' row weights are, or on `p`), of six kinds: random; a pair
    /// `rot_hessian(w, p) s + rot_hessian(−p s, w)` (zero in exact arithmetic: `M`
    /// antisymmetric; the computed sum is round-off only); one term with `w = −αp`
    /// (eigenvalues `(k, k, 0)`: the two largest equal, the `acos` of
    /// `symmetric_eigenvalues` at −1); one with `w = αp` (negative semi-definite: PSD
    /// part zero); those two perturbed by 1e-9. Tolerance 0 (never above a bound);
    /// measured: the cancelled sums' computed norms reach 2.7e-16 σ (asserted < 1e-14
    /// σ) against the norm's margin 1e-12 σ; the norm bound is at most `norm (1 +
    /// 1e-9) + 2e-12 σ` elsewhere; the computed eigenvalue exceeds the eigenvalue bound
    /// without its margin `1e-6 σ` by at most 3.1e-16 σ (asserted < 1e-12 σ).
    #[test]
    fn rot_hessian_sum_bounds_the_accumulated_sum() {
        fn next(seed: &mut u64) -> f64 {
            *seed ^= *seed << 13;
            *seed ^= *seed >> 7;
            *seed ^= *seed << 17;
            (*seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
        fn v(seed: &mut u64) -> DVec3 {
            DVec3::new(next(seed), next(seed), next(seed)) * 10.0
        }
        let rng = &mut 0x9e37_79b9_7f4a_7c15u64;
        let (mut worst_cancelled, mut excess): (f64, f64) = (0.0, f64::NEG_INFINITY);
        for trial in 0..120_000 {
            let kind = trial % 6;
            let n = match kind {
                0 => 1 + (trial / 6) % 4,
                1 => 2 + (trial / 6) % 3,
                _ => 1,
            };
            let mut terms = [(DVec3::ZERO, DVec3::ZERO, 1.0); 4];
            for t in terms.iter_mut().take(n) {
                *t = (v(rng), v(rng), 1.0);
            }
            terms[n - 1].2 = 37.0 * (next(rng) + 1.5);
            let (p, alpha, tiny) = (terms[0].1, 3.0 * (next(rng) + 1.5), v(rng) * 1e-10);
            match kind {
                1 => {
                    // `rot_hessian(w, p) s + rot_hessian(−p s, w)`.
                    let (w, s) = (terms[0].0, 37.0 * (next(rng) + 1.5));
                    terms[0] = (w, p, s);
                    terms[1] = (-(p * s), w, 1.0);
                }
                2 => terms[0].0 = -p * alpha,
                3 => terms[0].0 = p * alpha,
                4 => terms[0].0 = -p * alpha + tiny,
                5 => terms[0].0 = p * alpha + tiny,
                _ => {}
            }
            let mut h = DMat3::ZERO;
            let mut sum = RotHessianSum::ZERO;
            let mut sigma = 0.0;
            for &(w, p, s) in terms.iter().take(n) {
                h += rot_hessian(w, p) * s;
                sum.add(w, p * s);
                sigma += w.length() * p.length() * s;
            }
            let sq = |c: DVec3| c.dot(c);
            let norm = (sq(h.x_axis) + sq(h.y_axis) + sq(h.z_axis)).sqrt();
            let bound = sum.bounds();
            assert!(norm <= bound.frobenius, "trial {trial}: {norm} > {bound:?}");
            let top = crate::body::symmetric_eigenvalues(&crate::body::psd_part(&h))[2];
            assert!(
                top <= bound.max_eigenvalue,
                "trial {trial}: {top} > {bound:?}"
            );
            excess = excess.max((top - (bound.max_eigenvalue - 1e-6 * sigma)) / sigma);
            if kind == 1 && n == 2 {
                worst_cancelled = worst_cancelled.max(norm / sigma);
            } else {
                assert!(bound.frobenius <= norm * (1.0 + 1e-9) + 2e-12 * sigma);
            }
        }
        assert!(worst_cancelled < 1e-14, "cancelled: {worst_cancelled}");
        assert!(excess < 1e-12, "eigenvalue excess: {excess}");
    }

    /// `add_dot_hessian` gives the bits of the full block products for every pair of
    /// expression kinds (directions in `a` or `b`, separations, constants), vectors
    /// with zero components (more zero entries in the skew blocks), and two products
    /// accumulated into one `h` (as a joint's rows are): every entry equal to the bit.
    #[test]
    fn block_products_match_the_full_products_to_the_bit() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut checked = 0;
        for trial in 0..400 {
            let mut v = || {
                let mut x = DVec3::new(next(), next(), next());
                // Some components exactly zero (axis-aligned anchors and axes).
                if trial % 3 == 0 {
                    x.y = 0.0;
                }
                if trial % 5 == 0 {
                    x.z = 0.0;
                }
                x
            };
            let pa = Pose::new(v(), DQuat::from_scaled_axis(v()).normalize()).unwrap();
            let pb = Pose::new(v(), DQuat::from_scaled_axis(v()).normalize()).unwrap();
            let (u1, u2, u3, u4) = (v(), v(), v(), v());
            let exprs = [
                FrameExpr::dir_a(&pa, u1),
                FrameExpr::dir_b(&pb, u2),
                FrameExpr::separation(&pa, u3, &pb, u4),
                FrameExpr::constant(u1),
                FrameExpr::dir_a(&Pose::IDENTITY, DVec3::Z),
            ];
            let (s1, s2) = (next(), next());
            for x in &exprs {
                for y in &exprs {
                    let (mut h, mut want) = (TwistCurvature::ZERO, TwistCurvature::ZERO);
                    add_dot_hessian(x, y, s1, &mut h);
                    add_dot_hessian(y, &exprs[2], s2, &mut h);
                    add_dot_hessian_full(x, y, s1, &mut want);
                    add_dot_hessian_full(y, &exprs[2], s2, &mut want);
                    for r in 0..12 {
                        for c in 0..12 {
                            assert_eq!(
                                h.entry(r, c).to_bits(),
                                want.entry(r, c).to_bits(),
                                "trial {trial} entry ({r}, {c})"
                            );
                        }
                    }
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 400 * 25);
    }
}
