//! Rigid-body stencils: constraints between two bodies, differentiated with respect to
//! the twist `(v, ω)` (Otaduy 2010, "Sólidos Articulados").
//!
//! A body's pose is its centre of mass `x` and orientation `R` (a unit quaternion). A
//! point fixed in the body at `r` (body frame, from the centre of mass) sits at
//! `p = x + R r` and moves with `ṗ = v + ω × (R r)` (the lecture's velocity of the
//! joint point), so the Jacobian of a constraint with respect to `(v, ω)` is its
//! derivative under the perturbation `x ← x + δx`, `R ← exp(δθ) R` (world-frame
//! rotation vector `δθ`). The curvature is the second derivative under the same
//! perturbation; along a motion it gives `J̇ v = vᵀ (∂²C/∂q²) v` for the acceleration-level
//! formulation.
//!
//! Block order everywhere: `[v_a, ω_a, v_b, ω_b]`.

use glam::{DMat3, DQuat, DVec3};

use crate::ConstraintError;

/// Pose of a rigid body: centre of mass and orientation (unit quaternion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Centre of mass in world coordinates.
    pub x: DVec3,
    /// Orientation, body frame to world frame.
    pub q: DQuat,
}

impl Pose {
    /// The world frame (what a joint to the ground uses for its other side).
    pub const IDENTITY: Self = Self {
        x: DVec3::ZERO,
        q: DQuat::IDENTITY,
    };

    /// A pose, checking that it is finite and that `q` is unit to within 1e-6.
    pub fn new(x: DVec3, q: DQuat) -> Result<Self, ConstraintError> {
        if !x.is_finite() || !q.is_finite() {
            return Err(ConstraintError::NonFinite);
        }
        if (q.length() - 1.0).abs() > 1e-6 {
            return Err(ConstraintError::NonUnitQuaternion);
        }
        Ok(Self { x, q })
    }

    /// World coordinates of the body point `r` (body frame, from the centre of mass).
    #[inline]
    pub fn point(&self, r: DVec3) -> DVec3 {
        self.x + self.q * r
    }

    /// Body coordinates of the world point `p`.
    #[inline]
    pub fn to_local(&self, p: DVec3) -> DVec3 {
        self.q.inverse() * (p - self.x)
    }

    /// Body coordinates of the world direction `d`.
    #[inline]
    pub fn dir_to_local(&self, d: DVec3) -> DVec3 {
        self.q.inverse() * d
    }
}

/// Value and Jacobian of an `R`-row two-body constraint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwistJacobian<const R: usize> {
    /// `C_r` for each row.
    pub value: [f64; R],
    /// `rows[r] = [∂C_r/∂v_a, ∂C_r/∂ω_a, ∂C_r/∂v_b, ∂C_r/∂ω_b]`.
    pub rows: [[DVec3; 4]; R],
}

/// Weighted curvature `Σ_r w_r ∂²C_r` on `(δx_a, δθ_a, δx_b, δθ_b)`, as 4×4 blocks of
/// 3×3 (symmetric as a whole: `blocks[j][i] = blocks[i][j]ᵀ`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwistCurvature {
    /// Row-major blocks in the order `[x_a, θ_a, x_b, θ_b]`.
    pub blocks: [[DMat3; 4]; 4],
}

impl TwistCurvature {
    /// The zero matrix.
    pub const ZERO: Self = Self {
        blocks: [[DMat3::ZERO; 4]; 4],
    };

    /// The entry at scalar row `a` and column `b` (`0 ≤ a, b < 12`).
    #[inline]
    pub fn entry(&self, a: usize, b: usize) -> f64 {
        self.blocks[a / 3][b / 3].col(b % 3)[a % 3]
    }

    /// `uᵀ H u` for a twist pair `u = [v_a, ω_a, v_b, ω_b]`.
    pub fn quadratic(&self, u: &[DVec3; 4]) -> f64 {
        let mut s = 0.0;
        for i in 0..4 {
            for j in 0..4 {
                s += u[i].dot(self.blocks[i][j] * u[j]);
            }
        }
        s
    }
}

/// A constraint between two rigid bodies `a` and `b` with `R` scalar rows.
///
/// Implementations are plain data (anchors and axes in the body frames) and never
/// allocate; the caller supplies the poses (the world is [`Pose::IDENTITY`]).
pub trait BodyConstraint<const R: usize> {
    /// The value `C(pose_a, pose_b)`.
    fn value(&self, a: &Pose, b: &Pose) -> [f64; R];

    /// The value and the Jacobian with respect to `(v_a, ω_a, v_b, ω_b)`.
    fn jacobian(&self, a: &Pose, b: &Pose) -> TwistJacobian<R>;

    /// The weighted curvature `Σ_r w_r ∂²C_r` on `(δx_a, δθ_a, δx_b, δθ_b)`.
    fn curvature(&self, a: &Pose, b: &Pose, w: &[f64; R]) -> TwistCurvature;
}

/// Half-angles below which `sincos` returns `(x, 1)` exactly: glibc's `__sincos`
/// (`|x| < 2⁻²⁷`) and the `libm` crate's (`|x| < 2⁻²⁷ √2`) both return `sin x = x`,
/// `cos x = 1` there (`x − x³/6` rounds to `x` below `2⁻²⁶`).
const TINY_HALF_ANGLE: f64 = 1.0 / 134_217_728.0;

/// `exp(θ) q`: rotates `q` by the world-frame rotation vector `θ` (the perturbation that
/// defines the Jacobians above), renormalised.
///
/// The operations of `DQuat::from_scaled_axis` (`axis = θ/|θ|`, `v = axis · sin(|θ|/2)`,
/// `w = cos(|θ|/2)`), except that below a half-angle of `2⁻²⁷` the `sincos` call is
/// skipped for the values it gives there (`sin = |θ|/2`, `cos = 1`): the same bits.
/// Position corrections and drifts of bodies near rest turn by far less than `2⁻²⁶`
/// rad; each `sincos` costs about 150 instructions (dm fish controlled: 19 500 calls in
/// 2 s in RATTLE alone).
#[inline]
pub fn rotate_by(q: DQuat, theta: DVec3) -> DQuat {
    let length = theta.length();
    let turn = if length == 0.0 {
        DQuat::IDENTITY
    } else if length * 0.5 < TINY_HALF_ANGLE {
        let v = (theta / length) * (length * 0.5);
        DQuat::from_xyzw(v.x, v.y, v.z, 1.0)
    } else {
        DQuat::from_axis_angle(theta / length, length)
    };
    (turn * q).normalize()
}

#[cfg(test)]
mod tests {
    use super::{rotate_by, TINY_HALF_ANGLE};
    use glam::{DQuat, DVec3};

    /// `exp(θ) q` through glam's `from_scaled_axis` (its `sincos` at every angle).
    fn reference(q: DQuat, theta: DVec3) -> DQuat {
        (DQuat::from_scaled_axis(theta) * q).normalize()
    }

    /// `rotate_by` gives `from_scaled_axis`'s bits: below the tiny-angle threshold
    /// (where it skips `sincos`), at it and above, for turns of half-angle 1e-30 to
    /// 1e-3 about several axes from several orientations, and for no turn. Bits, not a
    /// tolerance: RATTLE's and the projections' results depend on them.
    #[test]
    fn rotate_by_gives_from_scaled_axis_bits() {
        let qs = [
            DQuat::IDENTITY,
            DQuat::from_xyzw(0.1, -0.7, 0.3, 0.6).normalize(),
            DQuat::from_xyzw(-0.5, 0.5, 0.5, -0.5),
        ];
        let axes = [
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.3, -0.4, 1.2),
            DVec3::new(-2.0, 1e-3, 0.7),
        ];
        let t = TINY_HALF_ANGLE;
        let halves = [
            1e-30,
            1e-12,
            3e-9,
            t * (1.0 - 1e-15),
            t,
            t * (1.0 + 1e-15),
            2.0 * t,
            1e-3,
        ];
        let mut tiny = 0;
        for q in qs {
            for a in axes {
                for half in halves {
                    let theta = a.normalize() * (2.0 * half);
                    if 0.5 * theta.length() < t {
                        tiny += 1;
                    }
                    let fast = rotate_by(q, theta).to_array().map(f64::to_bits);
                    let slow = reference(q, theta).to_array().map(f64::to_bits);
                    assert_eq!(fast, slow, "q {q:?}, theta {theta:?}");
                }
            }
            assert_eq!(rotate_by(q, DVec3::ZERO), reference(q, DVec3::ZERO));
        }
        // The fast path was taken: at least the 27 turns of half-angle 1e-30, 1e-12
        // and 3e-9 (the one just below the threshold may round to it).
        assert!(tiny >= 27, "{tiny} tiny turns");
    }
}
