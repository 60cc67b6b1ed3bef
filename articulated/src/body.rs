//! Rigid bodies: mass, inertia, pose and twist.
//!
//! State: centre of mass `x`, orientation `q` (unit quaternion, body → world), linear
//! velocity `v` of the centre of mass and angular velocity `ω` in world coordinates
//! (DESIGN.md §5). The inertia tensor is stored about the centre of mass in the body
//! frame, `I_world = R I Rᵀ`. `com` is the centre of mass in the body frame, kept only to
//! report the body frame origin (MuJoCo's `xpos`) as `x − R com`.

use constraint_core::{DMat3, DQuat, DVec3, Pose};

use crate::error::ArticulatedError;

/// A rigid body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidBody {
    /// Mass (kg), positive and finite.
    pub mass: f64,
    /// Inertia about the centre of mass in the body frame (kg·m²), symmetric positive
    /// definite, principal moments satisfying the triangle inequality.
    pub inertia: DMat3,
    /// Centre of mass and orientation.
    pub pose: Pose,
    /// Linear velocity of the centre of mass (world).
    pub v: DVec3,
    /// Angular velocity (world).
    pub omega: DVec3,
    /// Centre of mass in the body frame (offset from the body frame origin).
    pub com: DVec3,
    pub(crate) inv_inertia: DMat3,
}

/// Eigenvalues of a symmetric 3×3 matrix, ascending (closed form, Smith 1961).
pub fn symmetric_eigenvalues(a: &DMat3) -> [f64; 3] {
    let (a00, a11, a22) = (a.x_axis.x, a.y_axis.y, a.z_axis.z);
    let (a01, a02, a12) = (a.y_axis.x, a.z_axis.x, a.z_axis.y);
    let p1 = a01 * a01 + a02 * a02 + a12 * a12;
    let q = (a00 + a11 + a22) / 3.0;
    let p2 = (a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * p1;
    if p2 <= 1e-300 {
        return [q, q, q];
    }
    let p = (p2 / 6.0).sqrt();
    let b = (*a - DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
    let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = libm::acos(r) / 3.0;
    let e1 = q + 2.0 * p * libm::cos(phi);
    let e3 = q + 2.0 * p * libm::cos(phi + 2.0 * core::f64::consts::PI / 3.0);
    let e2 = 3.0 * q - e1 - e3;
    [e3, e2, e1]
}

impl RigidBody {
    /// A body at rest. Errors (`InvalidBody` with `body = index`): mass not positive and
    /// finite; inertia not finite, not symmetric, not positive definite, or violating the
    /// triangle inequality `I₁ ≤ I₂ + I₃` of principal moments (to 1e-9 relative);
    /// non-finite or non-unit (1e-6) pose.
    pub fn new(
        index: usize,
        mass: f64,
        inertia: DMat3,
        pose: Pose,
    ) -> Result<Self, ArticulatedError> {
        let bad = |reason| ArticulatedError::InvalidBody {
            body: index,
            reason,
        };
        if !(mass > 0.0) || !mass.is_finite() {
            return Err(bad("mass must be positive and finite"));
        }
        if !inertia.is_finite() {
            return Err(bad("inertia must be finite"));
        }
        let asym = (inertia - inertia.transpose()).abs().to_cols_array();
        let scale = inertia
            .abs()
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, v| m.max(*v));
        if asym.iter().any(|v| *v > 1e-9 * scale) {
            return Err(bad("inertia must be symmetric"));
        }
        let ev = symmetric_eigenvalues(&inertia);
        if !(ev[0] > 0.0) {
            return Err(bad("inertia must be positive definite"));
        }
        if ev[2] > (ev[0] + ev[1]) * (1.0 + 1e-9) {
            return Err(bad("principal moments violate the triangle inequality"));
        }
        if !pose.x.is_finite() || !pose.q.is_finite() {
            return Err(bad("pose must be finite"));
        }
        if (pose.q.length() - 1.0).abs() > 1e-6 {
            return Err(bad("orientation quaternion must be unit"));
        }
        Ok(Self {
            mass,
            inertia,
            pose: Pose {
                x: pose.x,
                q: pose.q.normalize(),
            },
            v: DVec3::ZERO,
            omega: DVec3::ZERO,
            com: DVec3::ZERO,
            inv_inertia: inertia.inverse(),
        })
    }

    /// The same body with the given velocities (checked finite by the world).
    pub fn with_velocity(mut self, v: DVec3, omega: DVec3) -> Self {
        self.v = v;
        self.omega = omega;
        self
    }

    /// The same body with the body-frame centre-of-mass offset `com` (for reporting the
    /// body frame origin).
    pub fn with_com(mut self, com: DVec3) -> Self {
        self.com = com;
        self
    }

    /// Rotation matrix body → world.
    #[inline]
    pub fn rotation(&self) -> DMat3 {
        DMat3::from_quat(self.pose.q)
    }

    /// World inertia `R I Rᵀ`.
    #[inline]
    pub fn world_inertia(&self) -> DMat3 {
        let r = self.rotation();
        r * self.inertia * r.transpose()
    }

    /// World inverse inertia `R I⁻¹ Rᵀ`.
    #[inline]
    pub fn world_inv_inertia(&self) -> DMat3 {
        let r = self.rotation();
        r * self.inv_inertia * r.transpose()
    }

    /// Kinetic energy `½ m v² + ½ ωᵀ I_world ω`.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.mass * self.v.length_squared()
            + 0.5 * self.omega.dot(self.world_inertia() * self.omega)
    }

    /// Body frame origin in world coordinates (MuJoCo's `xpos`).
    pub fn origin(&self) -> DVec3 {
        self.pose.x - self.pose.q * self.com
    }

    /// Orientation (MuJoCo's `xquat`).
    pub fn orientation(&self) -> DQuat {
        self.pose.q
    }

    /// Angular velocity after a free step of `h` under the gyroscopic term alone,
    /// `I ω̇ + ω × I ω = 0`, by one Newton step of its backward Euler discretisation in the
    /// body frame (Catto 2015, "Numerical methods", GDC): implicit, so a spinning body
    /// never gains energy from this term.
    pub fn gyroscopic_step(&self, h: f64) -> DVec3 {
        self.gyroscopic_step_with(&self.rotation(), h)
    }

    /// [`Self::gyroscopic_step`] with the rotation matrix `r` already at hand.
    pub fn gyroscopic_step_with(&self, r: &DMat3, h: f64) -> DVec3 {
        let r = *r;
        let w = r.transpose() * self.omega;
        let iw = self.inertia * w;
        let f = w.cross(iw) * h;
        let jac = self.inertia
            + (constraint_core::math::skew(w) * self.inertia - constraint_core::math::skew(iw)) * h;
        let det = jac.determinant();
        if !(det.abs() > 0.0) || !det.is_finite() {
            return self.omega;
        }
        r * (w - jac.inverse() * f)
    }
}
