//! # constraint-verify
//!
//! Verification tooling for the constraint crates.
//!
//! The library part, [`fd`], checks analytic derivatives of any
//! [`constraint_core::PointConstraint`] against finite differences, scales test gates
//! through the `VERIFY_TOL_SCALE` environment variable, and generates seeded random and
//! near-degenerate configurations.
//!
//! The integration tests (`tests/`) apply it to the stock constraints of
//! `constraint-core`:
//!
//! * `derivatives.rs` — Jacobian and curvature against finite differences on seeded
//!   regular and near-degenerate configurations;
//! * `balance.rs` — property tests: internal constraints produce balanced forces and
//!   torques, and are invariant (value) or covariant (gradient, curvature) under rigid
//!   motions.
#![deny(missing_docs)]

pub mod fd;

pub use fd::{
    check_derivatives, corrected_rel_error, exceeds, measure_only, tol_scale, FdOptions, FdReport,
    NearDegenerate, Rng, Worst,
};
