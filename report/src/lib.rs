//! # constraint-report
//!
//! The verification report: what `cargo xtask verify` measures and writes to
//! `target/verify/` (through the `verify-report` binary). The tests are
//! `constraint-verify`'s; this crate measures, draws and writes.
//!
//! * [`sweeps`] runs the soft crate's integrators over stiffness and time step (the
//!   stability map) and measures error against run time (the work-precision diagram).
//! * [`chart`] draws log–log SVG charts for the report (with the Pareto front marked);
//!   [`bar_chart`] the per-model bars; [`heatmap`] the stability maps.
//! * [`articulated_report`] measures the MJCF scenes' error against run time next to
//!   MuJoCo's committed points, and the joint drift of the 20-link chain.
//! * [`contact_report`] measures the contact LCP solvers' residual against run time on
//!   the LCPs of stacks and pyramids, and the contact scenes' error against run time.
//! * [`particle_report`] and [`hard`] measure the particle formulations (drift,
//!   soft-versus-hard strain against run time).
//! * [`articulated_stability`] classifies the articulated formulations on the ball
//!   chain over time step × mass ratio, chain length, initial violation and joint
//!   compliance.
//! * [`chain_stability`] classifies the soft and Lagrange (particle) formulations on a
//!   hanging particle chain over time step × stiffness (compliance), mass ratio, chain
//!   length and initial violation.
//! * [`contact_stability`] classifies the rigid contact solvers on a box stack over
//!   time step × stack height, top mass ratio, initial overlap and Baumgarte factor.
//! * [`stability`] is the one stability map those three are instances of: axes and
//!   formulations as data, a scene runner per map, and one skeleton (grid, parallel run,
//!   classes, heat maps, tables, CSV, summary).
//! * [`par`] maps cells over threads with results independent of the thread count and
//!   a panic in one cell caught as that cell's result.
//! * [`peer_points`] draws the contact scenes' accuracy against time per step, our
//!   settings next to rapier3d's and MuJoCo's, from the points `cargo xtask bench`
//!   measured (`verify-report --contact-points`).
//! * [`models_report`] writes the real-models section from `cargo xtask models`' table.
//! * [`deps`] lists, per scene, the crate and features it declares, what they compile
//!   (`cargo tree`) and the stages its steps were seen to run.
//! * [`replays`] runs a few scenes into viewer pages for the report.
//! * [`html`] turns the Markdown report into one self-contained HTML page, opened by
//!   [`summary`]: one screen of what the run found and a table of contents.
#![deny(missing_docs)]

pub mod articulated_report;
pub mod articulated_stability;
pub mod bar_chart;
pub mod chain_stability;
pub mod chart;
pub mod contact_report;
pub mod contact_stability;
pub mod deps;
pub mod hard;
pub mod heatmap;
pub mod html;
pub mod models_report;
pub mod par;
pub mod particle_report;
pub mod peer_points;
pub mod replays;
pub mod stability;
pub mod summary;
pub mod sweeps;
