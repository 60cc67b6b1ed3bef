//! # constraint-soft
//!
//! Soft constraints (Otaduy 2010, "Restricciones Débiles: Energías y fuerzas"): any
//! [`PointConstraint`](constraint_core::PointConstraint) `C(x) = 0` becomes an energy
//! `E = ½kC²`, a force `F = −kC∇C` and a force Jacobian
//! `∂F/∂x = −k(∇C∇Cᵀ + C ∂²C/∂x²)` ([`energy`]), gathered into flat per-type
//! [`ConstraintSet`]s inside a [`SoftSystem`] and integrated with
//! [`SymplecticEuler`] or the lecture's linearized backward Euler [`ImplicitEuler`]:
//!
//! ```text
//! (M − h ∂F/∂v − h² ∂F/∂x) v(t+h) = (M − h ∂F/∂v) v(t) + h F(x(t), v(t))
//! ```
//!
//! solved by conjugate gradients or (feature `faer`, on by default) a sparse LDLᵀ
//! factorization whose symbolic analysis is reused every step.
//!
//! ```
//! use constraint_soft::{ConstraintSet, Integrator, ImplicitEuler, HessianMode,
//!                       LinearSolver, CgSettings, Softness, SoftSystem};
//! use constraint_core::{Distance, DVec3};
//!
//! // A 1 kg bob on a 1 m spring hanging from a pinned point.
//! let x = vec![DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0)];
//! let mut sys = SoftSystem::new(x.clone(), vec![1.0, 1.0])?;
//! sys.pin(0)?;
//! let spring = Distance::from_rest(0, 1, &x)?;
//! sys.add_set(ConstraintSet::uniform("spring", vec![spring], Softness::stiff(1e4))?)?;
//! let mut step = ImplicitEuler::new(
//!     1e-2,
//!     HessianMode::Projected,
//!     LinearSolver::ConjugateGradient(CgSettings::default()),
//! )?;
//! for _ in 0..100 {
//!     step.step(&mut sys)?;
//! }
//! // Static stretch m g / k ≈ 1 mm.
//! assert!((sys.x[1].z + 1.0 + 9.81e-4).abs() < 1e-9); // measured 1.0e-16 m
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

/// The crate README's example, compiled and run with the doctests so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctest;

pub mod bsr;
pub mod cg;
#[cfg(feature = "faer")]
pub mod direct;
mod eigen;
pub mod energy;
pub mod error;
pub mod integrate;
#[cfg(feature = "faer")]
pub mod lagged;
pub mod ordering;
pub mod project;
pub mod scenes;
pub mod set;
pub mod system;

pub use cg::{CgSettings, SolveStats};
pub use energy::{HessianMode, Softness};
pub use error::SoftError;
pub use integrate::{ImplicitEuler, Integrator, LinearSolver, Scheme, SymplecticEuler};
pub use scenes::cloth::{Cloth, ClothPins};
pub use scenes::jelly::{Jelly, JellyPins};
pub use set::{ConstraintSet, ForceSet};
pub use system::{SoftSystem, GRAVITY};
