//! # constraint-verify
//!
//! The test suite of the constraint crates, and the checking kit its tests share.
//!
//! * [`fd`] checks analytic derivatives of any [`constraint_core::PointConstraint`]
//!   against finite differences, scales test gates through the `VERIFY_TOL_SCALE`
//!   environment variable, and generates seeded random and near-degenerate
//!   configurations.
//!
//! The integration tests (`tests/`) apply the checks:
//!
//! * `derivatives.rs` — Jacobian and curvature against finite differences on seeded
//!   regular and near-degenerate configurations;
//! * `balance.rs` — property tests: internal constraints produce balanced forces and
//!   torques, and are invariant (value) or covariant (gradient, curvature) under rigid
//!   motions;
//! * `soft_forces.rs` — soft forces and force/damping Jacobians against finite
//!   differences; projected Hessians are PSD;
//! * `momentum.rs` — linear and angular momentum of free bodies under every integrator;
//! * `state_hashes.rs` — bit-identical trajectories of every scene, pinned;
//! * `determinism.rs` — repeated runs are bit-identical;
//! * `long_runs.rs`, `joints.rs`, `compound_lines.rs` — long-horizon and joint checks;
//! * `mujoco_reference.rs`, `mujoco_contact.rs` — trajectories against MuJoCo's
//!   committed references;
//! * `bad_input_sweep.rs`, `bad_input_regressions.rs` — hostile input never panics and
//!   never yields a silent NaN.
//!
//! The report (stability maps, work-precision sweeps, charts, `report.html`) is the
//! `constraint-report` crate; running a scene file is `constraint-scene`.
#![deny(missing_docs)]

pub mod fd;

pub use fd::{
    check_derivatives, corrected_rel_error, exceeds, measure_only, tol_scale, FdOptions, FdReport,
    NearDegenerate, Rng, Worst,
};
