//! # constraint-core
//!
//! The `no_std` heart of the workspace: a property to keep is a scalar function that
//! must vanish, `C(x) = 0` (Otaduy 2010, slide "Concepto de Restricción"). This crate
//! gives that idea one abstraction, [`PointConstraint`], which supplies for a stencil of
//! `N` points and `R` rows
//!
//! * the value `C(x)`,
//! * the Jacobian `J = ∂C/∂x` (one [`DVec3`] block per point and row; `∇C = Jᵀ`),
//! * the curvature `Σ_r w_r ∂²C_r/∂x²` for caller-chosen row weights `w`,
//!
//! and the stock constraints of the lecture with analytic derivatives:
//!
//! | module | constraint | lecture |
//! |---|---|---|
//! | [`spring`] | `C = |x_a − x_b| − L₀` | "Energía de Restricción: longitud de un muelle" |
//! | [`area`] | `C = A(x) − A₀` | "restricciones que conserven el área de los triángulos" |
//! | [`volume`] | `C = V(x) − V₀` | "restricciones que conserven el volumen de los tetraedros" |
//! | [`dihedral`] | `C = θ(x) − θ₀` | bending, Bridson et al. 2003 |
//! | [`plane`] | `C = nᵀx − d` | "Contacto mediante restricciones" (`d_i = nᵀ(p_i − p)`) |
//!
//! It also holds the rigid-body type every rigid crate shares, [`RigidBody`] (mass
//! properties checked once and kept private; pose and twist plain data), and the body
//! stencils of the joints ([`rigid`], [`joint`]), and the step context every world
//! builds once per step from its time step `h` ([`StepContext`]: `h`, `1/h`, `h²`, `h/2`,
//! validated in one place).
//!
//! Everything else — soft energies `½kC²`, forces `−kC∇C`, force Jacobians, KKT rows —
//! is derived generically from this trait in the other crates.
//!
//! The crate needs neither `std` nor an allocator: build it with
//! `--no-default-features` for embedded targets such as `thumbv7em-none-eabihf`.
//!
//! ## Degenerate input
//!
//! Constructors validate the rest shape and return [`ConstraintError`] for non-finite
//! input, zero rest lengths, zero-area triangles and flat or inverted tetrahedra.
//! Evaluation at a degenerate *current* shape (coincident points, a collapsed triangle)
//! never panics and never returns NaN: each module documents the finite value it
//! returns there (the gradient and curvature are set to zero where the direction is
//! undefined).
//!
//! ## Example
//!
//! The lecture's spring `C = |x_a − x_b| − L₀` on a 3-4-5 triangle: its value, its
//! gradient `∇C = (n, −n)` with `n` the unit direction from `b` to `a`, checked against
//! a central difference.
//!
//! ```
//! use constraint_core::{Distance, DVec3, PointConstraint};
//!
//! let spring = Distance::new(0, 1, 1.0)?;
//! let x = [DVec3::new(3.0, 4.0, 0.0), DVec3::ZERO];
//! let j = spring.jacobian(&x);
//! assert_eq!(j.value, [4.0]); // |x_a − x_b| − L₀ = 5 − 1
//! assert!((j.grad[0][0] - DVec3::new(0.6, 0.8, 0.0)).length() < 1e-15); // measured 0
//! assert_eq!(j.grad[0][1], -j.grad[0][0]);
//!
//! // ∂C/∂x_a · e_y against (C(x + εe_y) − C(x − εe_y)) / 2ε.
//! let eps = 1e-6;
//! let shifted = |s: f64| spring.value(&[x[0] + DVec3::Y * s, x[1]])[0];
//! let fd = (shifted(eps) - shifted(-eps)) / (2.0 * eps);
//! assert!((fd - j.grad[0][0].y).abs() < 1e-8); // measured 2.3e-11
//! # Ok::<(), constraint_core::ConstraintError>(())
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

/// The crate README's example, compiled and run with the doctests so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctest;

pub mod area;
pub mod body;
pub mod compound;
pub mod constraint;
pub mod dihedral;
pub mod error;
mod frame_expr;
pub mod joint;
pub mod math;
pub mod plane;
pub mod rigid;
pub mod spring;
pub mod step;
pub mod volume;

pub use area::Area;
pub use body::{BodyError, RigidBody};
pub use compound::Compound;
pub use constraint::{Curvature, Jacobian, PointConstraint};
pub use dihedral::Dihedral;
pub use error::ConstraintError;
pub use frame_expr::BlockBounds;
pub use glam::{DMat3, DQuat, DVec3};
pub use joint::{DistanceJoint, Fixed, Hinge, Prismatic, Spherical};
pub use plane::PointOnPlane;
pub use rigid::{BodyConstraint, Pose, TwistCurvature, TwistJacobian};
pub use spring::Distance;
pub use step::{StepContext, StepError};
pub use volume::Volume;
