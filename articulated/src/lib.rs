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
//! | [`world`] | [`World`]: the step, with [`Method`]s velocity level, velocity level + projection, acceleration level + Baumgarte, RATTLE; compliant joints (`World::set_compliance`); the run-time stages of a step (`World::stages`) |
//! | `mjcf` | (feature `mjcf`) worlds from MJCF scene files |
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]

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
    Actuator, DofSpring, Equality, Fluid, GeometricStiffness, Method, RowSource, StepStats, Target,
    Tendon, Terms, UnilateralSettings, UnilateralStats, World,
};
