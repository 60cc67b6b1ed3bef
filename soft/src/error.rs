//! Typed errors of the soft crate.

use constraint_core::ConstraintError;
use core::fmt;

/// Why a soft system could not be built or stepped.
#[derive(Clone, Debug, PartialEq)]
pub enum SoftError {
    /// A constraint could not be built (degenerate rest shape, non-finite input, ...).
    Constraint {
        /// Name of the constraint set.
        set: &'static str,
        /// Index of the constraint in its set.
        index: usize,
        /// The underlying reason.
        error: ConstraintError,
    },
    /// A particle's mass was zero, negative or not finite.
    InvalidMass {
        /// The particle.
        particle: usize,
    },
    /// A position or velocity was NaN or infinite.
    NonFiniteState {
        /// The particle.
        particle: usize,
    },
    /// A stencil names a particle that does not exist.
    IndexOutOfBounds {
        /// The offending index.
        index: usize,
        /// Number of particles.
        len: usize,
    },
    /// Stiffness or damping was negative or NaN.
    InvalidSoftness {
        /// Name of the constraint set.
        set: &'static str,
    },
    /// Stiffness was infinite: a soft constraint cannot be rigid. Use a hard constraint
    /// (the `lagrange` crate) or compliance zero instead.
    InfiniteStiffness {
        /// Name of the constraint set.
        set: &'static str,
    },
    /// The time step was rejected by `constraint_core::StepContext::new` (not positive,
    /// not finite, or outside `MIN_STEP..=MAX_STEP`).
    InvalidTimeStep,
    /// A scene parameter was out of range (named, with the rule it broke).
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// What it must satisfy.
        rule: &'static str,
    },
    /// Position and mass arrays differ in length.
    LengthMismatch,
    /// The implicit system matrix was found indefinite by conjugate gradients
    /// (`pᵀAp ≤ 0`); use [`HessianMode::Projected`](crate::HessianMode) or a direct solve.
    Indefinite {
        /// CG iteration at which it happened.
        iteration: usize,
    },
    /// The sparse direct factorization failed (zero pivot or symbolic error).
    Factorization,
    /// The step produced a non-finite or exploding state; the state was left unchanged.
    Diverged {
        /// Index of the step (0-based count of completed steps).
        step: u64,
        /// First particle with a bad value.
        particle: usize,
    },
}

impl fmt::Display for SoftError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Constraint { set, index, error } => {
                write!(f, "constraint {index} of set '{set}': {error}")
            }
            Self::InvalidMass { particle } => {
                write!(f, "particle {particle}: mass must be positive and finite")
            }
            Self::NonFiniteState { particle } => {
                write!(f, "particle {particle}: non-finite position or velocity")
            }
            Self::IndexOutOfBounds { index, len } => {
                write!(f, "index {index} out of bounds for {len} particles")
            }
            Self::InvalidSoftness { set } => {
                write!(
                    f,
                    "set '{set}': stiffness and damping must be ≥ 0 and not NaN"
                )
            }
            Self::InfiniteStiffness { set } => write!(
                f,
                "set '{set}': infinite stiffness; use a hard (Lagrange) constraint instead"
            ),
            Self::InvalidTimeStep => {
                f.write_str("time step must be positive, finite and within StepContext's bounds")
            }
            Self::InvalidParameter { name, rule } => write!(f, "parameter {name}: {rule}"),
            Self::LengthMismatch => f.write_str("positions and masses differ in length"),
            Self::Indefinite { iteration } => write!(
                f,
                "conjugate gradients met an indefinite matrix at iteration {iteration}"
            ),
            Self::Factorization => f.write_str("sparse LDLᵀ factorization failed"),
            Self::Diverged { step, particle } => {
                write!(
                    f,
                    "step {step} diverged at particle {particle} (state unchanged)"
                )
            }
        }
    }
}

impl std::error::Error for SoftError {}
