//! Typed errors of the articulated crate.

use core::fmt;

use constraint_core::ConstraintError;

/// Why a body, joint or world was rejected, or why a step failed.
#[derive(Clone, Debug, PartialEq)]
pub enum ArticulatedError {
    /// A body's mass, inertia, pose or velocity was invalid.
    InvalidBody {
        /// Index of the body (in the order bodies were added).
        body: usize,
        /// Which rule it broke.
        reason: &'static str,
    },
    /// A joint was invalid (bad geometry, unknown body, a body joined to itself).
    InvalidJoint {
        /// Index of the joint.
        joint: usize,
        /// Which rule it broke.
        reason: &'static str,
    },
    /// A joint's geometry was rejected by constraint-core.
    Constraint {
        /// Index of the joint.
        joint: usize,
        /// The underlying error.
        error: ConstraintError,
    },
    /// A step parameter (time step, stabilisation gain, tolerance) was out of range.
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its rule.
        rule: &'static str,
    },
    /// A step produced a non-finite or huge (> 1e12) state; the state was left as it was
    /// before the step.
    Diverged {
        /// The step counter at which it happened.
        step: u64,
        /// The first offending body.
        body: usize,
    },
    /// A pivot block of the tree factorization could not be factored (a body with a
    /// non-positive mass matrix after elimination).
    Singular {
        /// The node (body index, or `bodies + joint` for a joint node).
        node: usize,
    },
    /// The loop-closure system failed (non-finite entries).
    LoopSolve,
    /// The scene file could not be turned into a world.
    Scene(alloc::string::String),
    /// The complementarity problem of the one-sided rows (limits, contacts) could not be
    /// solved by any of its solvers (the state was left as before the step).
    Unilateral(constraint_contact::lcp::LcpError),
    /// A collider was rejected by the contact crate's geometry checks (`collider` is
    /// `usize::MAX` when contact generation failed for the scene as a whole).
    Geometry {
        /// Index of the collider.
        collider: usize,
        /// The geometry error.
        error: constraint_contact::geometry::GeometryError,
    },
    /// A collider was invalid (unknown body).
    InvalidCollider {
        /// Index of the collider.
        collider: usize,
        /// Which rule it broke.
        reason: &'static str,
    },
}

impl fmt::Display for ArticulatedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidBody { body, reason } => write!(f, "body {body}: {reason}"),
            Self::InvalidJoint { joint, reason } => write!(f, "joint {joint}: {reason}"),
            Self::Constraint { joint, error } => write!(f, "joint {joint}: {error}"),
            Self::InvalidParameter { name, rule } => write!(f, "parameter {name}: {rule}"),
            Self::Diverged { step, body } => {
                write!(
                    f,
                    "step {step} diverged (body {body} non-finite or beyond 1e12)"
                )
            }
            Self::Singular { node } => {
                write!(f, "tree factorization: singular pivot at node {node}")
            }
            Self::LoopSolve => f.write_str("loop-closure system could not be solved"),
            Self::Scene(s) => write!(f, "scene: {s}"),
            Self::Unilateral(e) => write!(f, "limits and contacts: {e}"),
            Self::Geometry { collider, error } => write!(f, "collider {collider}: {error:?}"),
            Self::InvalidCollider { collider, reason } => {
                write!(f, "collider {collider}: {reason}")
            }
        }
    }
}

impl core::error::Error for ArticulatedError {}

impl From<constraint_core::BodyError> for ArticulatedError {
    fn from(e: constraint_core::BodyError) -> Self {
        Self::InvalidBody {
            body: e.body,
            reason: e.reason,
        }
    }
}
