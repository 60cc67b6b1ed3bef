//! Errors of the constrained steps.

use crate::kkt::KktError;

/// Why a constrained step failed.
#[derive(Clone, Debug, PartialEq)]
pub enum LagrangeError {
    /// The KKT solve failed.
    Kkt(KktError),
    /// The underlying soft step failed.
    Soft(constraint_soft::SoftError),
    /// A constraint names a particle the system does not have.
    IndexOutOfBounds {
        /// One past the largest index used.
        needed: usize,
        /// Number of particles.
        len: usize,
    },
    /// The time step was rejected by `constraint_core::StepContext::new` (not positive,
    /// not finite, or outside `MIN_STEP..=MAX_STEP`).
    InvalidTimeStep,
    /// A parameter (Baumgarte gain, tolerance) was negative or not finite.
    InvalidParameter(&'static str),
    /// The step produced a non-finite or exploding state; the state was left unchanged.
    Diverged {
        /// Index of the step.
        step: u64,
        /// First bad particle.
        particle: usize,
    },
}

impl core::fmt::Display for LagrangeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Kkt(e) => write!(f, "KKT solve: {e}"),
            Self::Soft(e) => write!(f, "soft step: {e}"),
            Self::IndexOutOfBounds { needed, len } => {
                write!(
                    f,
                    "constraints need {needed} particles, the system has {len}"
                )
            }
            Self::InvalidTimeStep => {
                f.write_str("time step must be positive, finite and within StepContext's bounds")
            }
            Self::InvalidParameter(p) => write!(f, "parameter {p} must be finite and ≥ 0"),
            Self::Diverged { step, particle } => {
                write!(
                    f,
                    "step {step} diverged at particle {particle} (state unchanged)"
                )
            }
        }
    }
}

impl std::error::Error for LagrangeError {}

impl From<KktError> for LagrangeError {
    fn from(e: KktError) -> Self {
        Self::Kkt(e)
    }
}

impl From<constraint_soft::SoftError> for LagrangeError {
    fn from(e: constraint_soft::SoftError) -> Self {
        Self::Soft(e)
    }
}
