//! # constraint-articulated
//!
//! Articulated rigid bodies in maximal coordinates (Otaduy 2010, "Sólidos Articulados"):
//! every body keeps its own six degrees of freedom and every joint is a constraint
//! between two bodies, enforced with Lagrange multipliers. The lecture's spherical joint
//! `p_a − p_b = R_a r_a + x_a − R_b r_b − x_b = 0` at velocity level, with
//! `ṗ = v + ω × (R r)`, gives the rows `J_va v_a + J_ωa ω_a + J_vb v_b + J_ωb ω_b = −C₀/Δt`.
//!
//! | module | holds |
//! |---|---|
//! | [`body`] | [`RigidBody`]: mass, inertia, pose, twist; implicit gyroscopic update |
//! | [`joint`] | [`Joint`]: spherical, hinge, prismatic, fixed, distance (from `constraint-core`) with damping |
//! | [`tree`] | Baraff's leaves-first block `LDLᵀ` of the KKT matrix: no fill-in, `O(n)`; loop joints by a small Schur complement |
//! | [`world`] | [`World`]: the step, with [`Method`]s velocity level, velocity level + projection, acceleration level + Baumgarte, RATTLE; compliant joints (`World::set_compliance`); what a step did ([`StepStats`]: projection iterations, fallbacks taken) |
//! | `mjcf` | (feature `mjcf`) worlds from MJCF scene files |
//!
//! ## Example
//!
//! A hinge pendulum built from Rust: a 1 kg, 1 m rod hanging from the world at the
//! origin about the `y` axis, released horizontally and stepped for one second with the
//! default method (RATTLE, `Δt = 1 ms`). The hinge stays closed to the projection's
//! tolerance and, the step being symplectic, the energy does not drift.
//!
//! ```
//! use constraint_articulated::world::{Method, World};
//! use constraint_articulated::{Joint, JointKind, RigidBody};
//! use constraint_core::{DMat3, DQuat, DVec3, Hinge, Pose};
//!
//! let mut world = World::new(DVec3::new(0.0, 0.0, -9.81));
//! let pose = Pose { x: DVec3::new(0.5, 0.0, 0.0), q: DQuat::IDENTITY };
//! // A thin rod along x: m L²/12 across.
//! let inertia = DMat3::from_diagonal(DVec3::new(1e-4, 1.0 / 12.0, 1.0 / 12.0));
//! let rod = world.add_body(RigidBody::new(0, 1.0, inertia, pose)?)?;
//! let hinge = Hinge::from_world(&Pose::IDENTITY, &pose, DVec3::ZERO, DVec3::Y)?;
//! world.add_joint(Joint {
//!     parent: None,
//!     child: rod,
//!     kind: JointKind::Hinge(hinge),
//!     damping: 0.0,
//! })?;
//! let e0 = world.energy();
//! for _ in 0..1000 {
//!     world.step(1e-3, Method::default())?;
//! }
//! let e1 = world.energy();
//! let drift = (e1.0 + e1.1) - (e0.0 + e0.1);
//! assert!(world.max_separation() < 1e-10); // measured 3.4e-15 m (projection tolerance 1e-12)
//! assert!(drift.abs() < 1e-4); // measured 1.6e-9 J (at most 2.4e-5 J during the swing)
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

/// The crate README's example, compiled and run with the doctests so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctest;

extern crate alloc;

/// The rigid-body type (it lives in `constraint-core`, shared by every rigid crate).
pub mod body {
    pub use constraint_core::body::*;
}
pub mod error;
pub mod joint;
#[cfg(feature = "mjcf")]
pub mod mjcf;
#[cfg(all(feature = "mjcf", feature = "contact"))]
pub mod mjcf_contact;
pub mod scenes;
pub mod tree;
mod tree_rows;
pub mod world;

pub use constraint_core::{BodyError, RigidBody};
pub use error::ArticulatedError;
pub use joint::{DofDamping, Joint, JointKind};
#[cfg(feature = "mjcf")]
pub use mjcf::MjcfScene;
#[cfg(feature = "contact")]
pub use world::CollisionFilter;
pub use world::{
    Actuator, DofSpring, Equality, Fluid, GeometricStiffness, Method, PathSite, RowSource,
    SpatialTendon, StepStats, Target, Tendon, Terms, UnilateralSettings, UnilateralStats, World,
};
