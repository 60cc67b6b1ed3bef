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
//! All share [`kkt::solve_kkt`] and its solvers ([`kkt::KktSolver`]). Each formulation
//! lists the run-time stages it goes through ([`stages`], for reports).
//!
//! Without the default `std` feature the crate needs only `alloc`: the rows, the KKT
//! problem and its dense Schur, SVD, MINRES and GMRES solvers run on embedded targets;
//! the formulations, which step a `constraint_soft::SoftSystem`, need `std`.
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]

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
pub mod stages;
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
