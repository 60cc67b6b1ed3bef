//! # constraint-lagrange
//!
//! Hard constraints with Lagrange multipliers (Otaduy 2010, "Restricciones Fuertes:
//! Multiplicadores de Lagrange"): the KKT systems
//!
//! ```text
//! [A  Jᵀ] [x]   [b]
//! [J  −C] [λ] = [c]
//! ```
//!
//! (`C = 0` hard, `C = α/h²` compliant) and the solvers the lecture names for them:
//! "si A es fácil de invertir, se sustituye la primera ecuación en la segunda" (Schur
//! complement, dense or sparse), "MINRES ó GMRES si es disperso; SVD si es incompatible
//! (overconstrained)".
//!
//! | module | formulation | lecture |
//! |---|---|---|
//! | [`acceleration`] | `[M Jᵀ; J 0][ẍ; λ] = [F; −J̇ẋ − k_x C − k_v Ċ]` | "Opción 1", Baumgarte |
//! | [`velocity`] | `[A Jᵀ; J −α/h²][v; λ] = [b; −C(x₀)/Δt]` | "Opción 2"; compliant when `α > 0` |
//! | [`projection`] | Newton on `C(x) = 0` with `(h²JM⁻¹Jᵀ)δλ = C` | Goldenthal et al. 2007 |
//! | [`rattle`] | RATTLE (2nd order, symplectic) and RATTLE4 (Yoshida, 4th order) | beyond the lecture: the accurate corner |
//!
//! All share [`kkt::solve_kkt`] and its solvers ([`kkt::KktSolver`]). A step records
//! the solver it ran as data ([`kkt::KktStats::chosen`],
//! [`velocity::VelocityLevel::last_solver`]); reports put it into words.
//!
//! Without the default `std` feature the crate needs only `alloc`: the rows, the KKT
//! problem and its dense Schur, SVD, MINRES and GMRES solvers run on embedded targets;
//! the formulations, which step a `constraint_soft::SoftSystem`, need `std`.
//!
//! ## Example
//!
//! A hard pendulum: a 1 kg bob on a 1 m rod (`C = |x₁ − x₀| − 1`, hard, `α = 0`) from a
//! pinned pivot, released horizontally and stepped for one second at the velocity level
//! (`Δt = 10 ms`, dense Schur solve). Each step solves `J v = −C(x₀)/Δt`, so the rod's
//! length error stays at the `O(Δt²)` drift of one step instead of accumulating:
//!
//! ```
//! # #[cfg(feature = "std")]
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use constraint_core::{DVec3, Distance};
//! use constraint_lagrange::{BaseStep, Constraints, HardSet, KktSolver, VelocityLevel};
//! use constraint_soft::SoftSystem;
//!
//! let x = vec![DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0)];
//! let mut sys = SoftSystem::new(x.clone(), vec![1.0, 1.0])?;
//! sys.pin(0)?;
//! let mut cons = Constraints::new();
//! cons.add(HardSet::hard("rod", vec![Distance::from_rest(0, 1, &x)?]));
//! let mut step = VelocityLevel::new(1e-2, BaseStep::Explicit, KktSolver::DenseSchur)?;
//! let mut worst: f64 = 0.0;
//! for _ in 0..100 {
//!     step.step(&mut sys, &cons)?;
//!     worst = worst.max(((sys.x[1] - sys.x[0]).length() - 1.0).abs());
//! }
//! assert!(worst < 2e-3); // measured 9.8e-4 m
//! # Ok(())
//! # }
//! # #[cfg(not(feature = "std"))]
//! # fn main() {}
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

/// The crate README's example, compiled and run with the doctests so it cannot rot.
#[cfg(all(doctest, feature = "std"))]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctest;

extern crate alloc;

#[cfg(feature = "std")]
pub mod acceleration;
#[cfg(feature = "deformable")]
pub mod deformable;
#[cfg(feature = "std")]
pub mod error;
pub mod kkt;
#[cfg(feature = "std")]
pub mod projection;
#[cfg(feature = "std")]
pub mod rattle;
pub mod rows;
#[cfg(feature = "std")]
pub mod scenes;
pub mod set;
pub mod solve;
#[cfg(feature = "sparse")]
pub mod sparse;
#[cfg(feature = "std")]
mod step;
#[cfg(feature = "std")]
pub mod velocity;
pub mod volume_ring;

#[cfg(feature = "std")]
pub use acceleration::{AccelerationLevel, Baumgarte};
#[cfg(feature = "std")]
pub use error::LagrangeError;
pub use kkt::{solve_kkt, KktError, KktProblem, KktSolver, KktStats, KktWorkspace, MassMatrix};
#[cfg(feature = "std")]
pub use projection::{FastProjection, ProjectedStep, ProjectionStats};
#[cfg(feature = "std")]
pub use rattle::{Rattle, RattleOrder, RattleStats};
pub use rows::ConstraintRows;
pub use set::{Constraints, HardSet, RestScale, RowSet, SetError};
#[cfg(feature = "std")]
pub use velocity::{BaseStep, VelocityLevel};
pub use volume_ring::OneRingVolumes;
