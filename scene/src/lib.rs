//! # constraint-scene
//!
//! One path from a scene file to a trajectory, for users and for the project's own
//! tests, sweeps and report:
//!
//! * [`run()`] loads an MJCF file into the one rigid world (or, asked by name, the
//!   free-body contact world), steps it with a chosen formulation and records a
//!   [`trajectory::Trajectory`];
//! * [`trajectory`] is that trajectory, its CSV reader and writer, and the comparison
//!   of two trajectories (the metrics the MuJoCo checks use);
//! * [`viewer`] writes an animated, self-contained HTML page of a trajectory (shapes,
//!   cloth meshes, play/pause, time slider, orbit camera); [`scene_view`] feeds it an
//!   MJCF model and its trajectory;
//! * [`soft`] is the catalogue of soft scenes shared by tests and sweeps (the hanging
//!   cloth, the free cloth and jelly) and the integrator configurations compared on them;
//! * [`formulation`] is the one vocabulary of constraint formulations (soft, compliant,
//!   Baumgarte, velocity, projection, RATTLE, RATTLE4) mapped to the particle and the
//!   body types;
//! * [`catalogue`] lists the files of `scenes/` with their family and whether a
//!   MuJoCo reference is committed: the one list tests, report and benchmarks draw from;
//! * [`rng`] is the seeded generator behind every seeded configuration.
//!
//! The binaries (`cargo install --path scene`; `--help` lists every option with its
//! default): `simulate` runs a file from the command line and writes its trajectory as
//! CSV, a JSON summary or an HTML page; `compare A.csv B.csv [--tolerance TOL]` prints
//! [`trajectory::compare`]'s figures and exits with status 2 beyond the tolerance. Both
//! parse their arguments with `clap` (derive) and fail with one line on bad input.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod catalogue;
pub mod formulation;
pub mod rng;
pub mod run;
pub mod scene_view;
pub mod soft;
pub mod trajectory;
pub mod viewer;

pub use rng::Rng;
pub use run::{run, run_with_summary, RunOptions};
pub use trajectory::{compare, Comparison, Trajectory};
