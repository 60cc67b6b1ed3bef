//! # constraint-verify
//!
//! Verification tooling for the constraint crates.
//!
//! * [`fd`] checks analytic derivatives of any [`constraint_core::PointConstraint`]
//!   against finite differences, scales test gates through the `VERIFY_TOL_SCALE`
//!   environment variable, and generates seeded random and near-degenerate
//!   configurations.
//! * [`sweeps`] runs the soft crate's integrators over stiffness and time step (the
//!   stability map) and measures error against run time (the work-precision diagram).
//! * [`chart`] draws log–log SVG charts for the report (with the Pareto front marked).
//! * [`articulated_report`] measures the MJCF scenes' error against run time next to
//!   MuJoCo's committed points, and the joint drift of the 20-link chain.
//! * [`contact_report`] measures the contact LCP solvers' residual against run time on
//!   the LCPs of stacks and pyramids, and the contact scenes' error against run time.
//! * [`articulated_stability`] classifies the articulated formulations on the ball
//!   chain over time step × mass ratio, chain length, initial violation and joint
//!   compliance, drawn by [`heatmap`].
//! * [`chain_stability`] classifies the soft and Lagrange (particle) formulations on a
//!   hanging particle chain over time step × stiffness (compliance), mass ratio, chain
//!   length and initial violation, drawn the same way.
//! * [`contact_stability`] classifies the rigid contact solvers on a box stack over
//!   time step × stack height, top mass ratio, initial overlap and Baumgarte factor.
//! * [`stability`] holds what those three maps share: the cell classes, the tally, and
//!   the writer of a map section (heat maps, tables, CSV, summary).
//! * [`deps`] lists, per scene, the crate and features it declares, what they compile
//!   (`cargo tree`) and the stages its steps were seen to run.
//! * [`html`] turns the Markdown report into one self-contained HTML page.
//! * [`viewer`] writes an animated, self-contained HTML page of a trajectory (shapes,
//!   cloth meshes, play/pause, time slider, orbit camera); [`scene_view`] feeds it an
//!   MJCF model and its trajectory; [`replays`] runs a few scenes into such pages for
//!   the report.
//!
//! The binary `verify-report` (run by `cargo xtask verify`) writes the sweeps to
//! `target/verify/`. The integration tests (`tests/`) apply the checks:
//!
//! * `derivatives.rs` — Jacobian and curvature against finite differences on seeded
//!   regular and near-degenerate configurations;
//! * `balance.rs` — property tests: internal constraints produce balanced forces and
//!   torques, and are invariant (value) or covariant (gradient, curvature) under rigid
//!   motions;
//! * `soft_forces.rs` — soft forces and force/damping Jacobians against finite
//!   differences; projected Hessians are PSD;
//! * `momentum.rs` — linear and angular momentum of free bodies under every integrator.
//! * `viewer_browser.rs` — the [`viewer`] page of the ragdoll in headless Chromium:
//!   screenshots at two pinned times, not blank and different.
#![deny(missing_docs)]

pub mod articulated_report;
pub mod articulated_stability;
pub mod bar_chart;
pub mod chain_stability;
pub mod chart;
pub mod contact_report;
pub mod contact_stability;
pub mod deps;
pub mod fd;
pub mod hard;
pub mod heatmap;
pub mod html;
pub mod models_report;
pub mod par;
pub mod particle_report;
pub mod replays;
pub mod scene;
pub mod scene_view;
pub mod stability;
pub mod sweeps;
pub mod trajectory;
pub mod viewer;

pub use fd::{
    check_derivatives, corrected_rel_error, exceeds, measure_only, tol_scale, FdOptions, FdReport,
    NearDegenerate, Rng, Worst,
};
