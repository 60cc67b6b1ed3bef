//! The step context: the time step `h` and the quantities every stage derives from
//! it, validated once at the start of a step and passed down by value.
//!
//! Every integrator of the lecture advances the state by a time step `h` (Otaduy 2010,
//! slides "Integración Explícita" and "Integración Implícita": `v(t+h) = v(t) + h M⁻¹F`,
//! `x(t+h) = x(t) + h v(t+h)`; the implicit matrix `M − h ∂F/∂v − h² ∂F/∂x`; the
//! velocity-level bias `−β C / h` of the constraint rows). The stages use `h`, `h/2`,
//! `h²` and `1/h`. [`StepContext`] holds them, computed once from a checked `h`, in the
//! manner of Box2D v3's `b2StepContext` (`dt`, `inv_dt`, `h`, `inv_h`) and rapier's
//! `IntegrationParameters` (`dt`, `inv_dt()`): the public `step(h, …)` entry points
//! build one with [`StepContext::new`] and pass it down, so `h` is validated in one
//! place and the private stages never see an unchecked step.
//!
//! The derived values are the exact IEEE results of the expressions they replace
//! (`1.0 / h`, `h * h`, `0.5 * h`), so a stage that used `h * h` gives bit-identical
//! results with [`StepContext::h2`].

use core::fmt;

/// The smallest accepted time step, `2⁻⁵¹¹ ≈ 1.49e-154` s: the smallest `h` whose
/// square `h²` is a normal `f64` (`h² ≥ f64::MIN_POSITIVE = 2⁻¹⁰²²`). Below it `h²`
/// (the implicit matrix's `h² ∂F/∂x`, the compliant rows' `α/h²`) is subnormal or zero
/// and loses its precision or vanishes, and `α/h²` overflows for ordinary compliances.
pub const MIN_STEP: f64 = 1.491_668_146_240_041_3e-154;

/// The largest accepted time step, `2⁵¹¹ ≈ 6.70e153` s (`1 /` [`MIN_STEP`]): above it
/// `h²` is no longer below `2¹⁰²²` and overflows to infinity from `h ≈ 1.34e154`.
pub const MAX_STEP: f64 = 6.703_903_964_971_299e153;

/// Why a time step was rejected by [`StepContext::new`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepError {
    /// `h` was NaN.
    NotANumber,
    /// `h` was `+∞` or `−∞`.
    Infinite,
    /// `h` was zero (either sign) or negative.
    NonPositive,
    /// `0 < h <` [`MIN_STEP`]: `h²` would be subnormal or zero.
    TooSmall,
    /// `h >` [`MAX_STEP`]: `h²` would be at or near overflow.
    TooLarge,
}

impl StepError {
    /// The rule that was broken, as a static string (for the crates whose typed errors
    /// carry `rule: &'static str`).
    pub fn rule(&self) -> &'static str {
        match self {
            Self::NotANumber => "time step is NaN",
            Self::Infinite => "time step is infinite",
            Self::NonPositive => "time step must be positive",
            Self::TooSmall => "time step is below MIN_STEP (its square would be subnormal)",
            Self::TooLarge => "time step is above MAX_STEP (its square would overflow)",
        }
    }
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.rule())
    }
}

impl core::error::Error for StepError {}

/// A validated time step and the values derived from it (Box2D v3's `b2StepContext`,
/// rapier's `IntegrationParameters`).
///
/// The fields are private so that every context holds a checked step: `h` is finite
/// and in [[`MIN_STEP`], [`MAX_STEP`]], and `1/h`, `h²`, `h/2` are finite, normal and
/// positive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepContext {
    h: f64,
    inv_h: f64,
    h2: f64,
    half_h: f64,
}

impl StepContext {
    /// Checks `h` and derives `1/h`, `h²` and `h/2` from it.
    ///
    /// # Errors
    /// [`StepError::NotANumber`], [`StepError::Infinite`], [`StepError::NonPositive`]
    /// (`0`, `−0`, negative), [`StepError::TooSmall`] (`0 < h <` [`MIN_STEP`]) or
    /// [`StepError::TooLarge`] (`h >` [`MAX_STEP`]).
    pub fn new(h: f64) -> Result<Self, StepError> {
        if h.is_nan() {
            return Err(StepError::NotANumber);
        }
        if h.is_infinite() {
            return Err(StepError::Infinite);
        }
        if h <= 0.0 {
            return Err(StepError::NonPositive);
        }
        if h < MIN_STEP {
            return Err(StepError::TooSmall);
        }
        if h > MAX_STEP {
            return Err(StepError::TooLarge);
        }
        Ok(Self {
            h,
            inv_h: 1.0 / h,
            h2: h * h,
            half_h: 0.5 * h,
        })
    }

    /// The time step `h` (s).
    #[inline]
    pub fn h(&self) -> f64 {
        self.h
    }

    /// `1/h` (1/s), computed as `1.0 / h`.
    #[inline]
    pub fn inv_h(&self) -> f64 {
        self.inv_h
    }

    /// `h²` (s²), computed as `h * h`.
    #[inline]
    pub fn h2(&self) -> f64 {
        self.h2
    }

    /// `h/2` (s), computed as `0.5 * h`: the half kicks of RATTLE and the damping
    /// half-steps of its splittings.
    #[inline]
    pub fn half_h(&self) -> f64 {
        self.half_h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_steps_are_rejected_with_their_reason() {
        let cases = [
            (0.0, StepError::NonPositive),
            (-0.0, StepError::NonPositive),
            (-1.0, StepError::NonPositive),
            (-f64::MIN_POSITIVE, StepError::NonPositive),
            (f64::NAN, StepError::NotANumber),
            (-f64::NAN, StepError::NotANumber),
            (f64::INFINITY, StepError::Infinite),
            (f64::NEG_INFINITY, StepError::Infinite),
            (f64::MIN_POSITIVE, StepError::TooSmall),
            (5e-324, StepError::TooSmall),
            (1e-160, StepError::TooSmall),
            (1e154, StepError::TooLarge),
            (f64::MAX, StepError::TooLarge),
        ];
        for (h, want) in cases {
            assert_eq!(StepContext::new(h), Err(want), "h = {h:e}");
        }
    }

    #[test]
    fn the_bounds_are_the_steps_with_a_normal_finite_square() {
        // MIN_STEP = 2^-511 and MAX_STEP = 2^511 exactly: their squares are
        // f64::MIN_POSITIVE = 2^-1022 and 2^1022, both normal.
        assert_eq!(MIN_STEP.to_bits(), ((1023 - 511) as u64) << 52);
        assert_eq!(MAX_STEP.to_bits(), ((1023 + 511) as u64) << 52);
        assert_eq!(MIN_STEP * MIN_STEP, f64::MIN_POSITIVE);
        let below = f64::from_bits(MIN_STEP.to_bits() - 1);
        assert!(below * below < f64::MIN_POSITIVE);
        assert_eq!(StepContext::new(below), Err(StepError::TooSmall));
        let above = f64::from_bits(MAX_STEP.to_bits() + 1);
        assert_eq!(StepContext::new(above), Err(StepError::TooLarge));
        for h in [MIN_STEP, MAX_STEP] {
            let ctx = StepContext::new(h).unwrap_or_else(|e| panic!("{h:e}: {e}"));
            assert!(ctx.inv_h().is_normal() && ctx.h2().is_normal() && ctx.half_h().is_normal());
        }
    }

    #[test]
    fn derived_values_are_the_exact_expressions_they_replace() {
        for h in [1e-3, 0.01, 1.0 / 60.0, 0.1, 1.0, 3.7e-5, 1e150] {
            let ctx = StepContext::new(h).unwrap_or_else(|e| panic!("{h}: {e}"));
            assert_eq!(ctx.h().to_bits(), h.to_bits());
            assert_eq!(ctx.inv_h().to_bits(), (1.0 / h).to_bits());
            assert_eq!(ctx.h2().to_bits(), (h * h).to_bits());
            assert_eq!(ctx.half_h().to_bits(), (0.5 * h).to_bits());
        }
    }
}
