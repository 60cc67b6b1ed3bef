//! Shared plumbing of the constrained steps: checks, row assembly, committing a state.

use crate::error::LagrangeError;
use crate::rows::ConstraintRows;
use crate::set::Constraints;
use constraint_core::{DVec3, StepContext};
use constraint_soft::SoftSystem;

/// The step context of `h`, checked once when the step is built
/// ([`StepContext::new`]); every [`StepError`](constraint_core::StepError) is
/// [`LagrangeError::InvalidTimeStep`].
pub(crate) fn step_context(h: f64) -> Result<StepContext, LagrangeError> {
    StepContext::new(h).map_err(|_| LagrangeError::InvalidTimeStep)
}

pub(crate) fn check_indices(sys: &SoftSystem, cons: &Constraints) -> Result<(), LagrangeError> {
    sys.check_lengths()?;
    let needed = cons.max_index();
    if needed > sys.len() {
        return Err(LagrangeError::IndexOutOfBounds {
            needed,
            len: sys.len(),
        });
    }
    Ok(())
}

/// Rows at `x` with pinned columns zeroed.
pub(crate) fn rows_at(pinned: &[bool], cons: &Constraints, x: &[DVec3], rows: &mut ConstraintRows) {
    cons.assemble(x, rows);
    rows.zero_columns(pinned);
}

/// Largest `|C_r| / scale_r`.
pub(crate) fn max_relative(rows: &ConstraintRows, scales: &[f64]) -> f64 {
    rows.value
        .iter()
        .zip(scales)
        .map(|(c, s)| (c / s).abs())
        .fold(0.0, crate::rows::nan_max)
}

/// Writes `(x_new, v_new)` into `sys` if every value is finite and bounded by 1e12.
pub(crate) fn commit(
    sys: &mut SoftSystem,
    x_new: &[DVec3],
    v_new: &[DVec3],
) -> Result<(), LagrangeError> {
    if let Some(p) = constraint_core::math::first_out_of_limit(x_new, v_new) {
        return Err(LagrangeError::Diverged {
            step: sys.steps,
            particle: p,
        });
    }
    sys.x.copy_from_slice(x_new);
    sys.v.copy_from_slice(v_new);
    sys.steps += 1;
    Ok(())
}
