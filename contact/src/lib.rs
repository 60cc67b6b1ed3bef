//! # constraint-contact
//!
//! Contact through constraints (Otaduy 2010, "Contacto mediante restricciones"): a
//! contact point `i` with normal `n` keeps `d_i = nᵀ(p_i − p) ≥ 0` with a force
//! `F_i = λ_i n`, `λ_i ≥ 0`, `d_i λ_i = 0`. At velocity level the contacts of a scene
//! form the linear complementarity problem `w = M z + q ≥ 0`, `z ≥ 0`, `zᵀw = 0`.
//!
//! | module | holds |
//! |---|---|
//! | [`lcp`] | the LCP type, its natural-map residual, and the solvers |
//! | [`geometry`] | shapes, narrow phase (points, normals, depths, ids), broad phase (sweep and prune; the uniform grid kept sorted between steps that contact generation uses) |
//! | `rigid` | (feature `rigid`) rigid bodies in contact: the contact LCP per step, solved matrix-free (sequential impulses, or Box2D v3's sub-stepped soft step) or by the dense solvers, with friction, restitution, warm starting and shock propagation; islands and sleeping (off by default) |
//! | `scenes` | (feature `rigid`) stacks, pyramids, a heavy box on a light one, a dropped sphere, and a pile of boxes, spheres and capsules poured into a container |
//!
//! ## Example
//!
//! A 2×2 LCP by Lemke's method, `M = [[2, 1], [1, 2]]`, `q = (−1, 3)`: the first unknown
//! is pushed until its slack vanishes while the second stays at zero with a positive
//! slack, `z = (½, 0)`, `w = M z + q = (0, 3.5)`.
//!
//! ```
//! use constraint_contact::lcp::{lemke, Lcp, LemkeSettings};
//!
//! let lcp = Lcp::new(vec![2.0, 1.0, 1.0, 2.0], vec![-1.0, 3.0])?;
//! let sol = lemke(&lcp, &LemkeSettings::default(), None)?;
//! assert!((sol.z[0] - 0.5).abs() < 1e-12 && sol.z[1].abs() < 1e-12); // measured 0, 0
//! assert!(sol.w[0].abs() < 1e-12 && (sol.w[1] - 3.5).abs() < 1e-12); // measured 0, 0
//! // Complementarity: z ≥ 0, w ≥ 0, z_i w_i = 0.
//! for (z, w) in sol.z.iter().zip(&sol.w) {
//!     assert!(*z >= 0.0 && *w >= -1e-12 && (z * w).abs() < 1e-12); // measured z·w = 0
//! }
//! # Ok::<(), constraint_contact::lcp::LcpError>(())
//! ```
//!
//! With the default feature `rigid`: a 0.1 m sphere dropped from 1 m onto the ground
//! plane comes to rest at its radius (`Δt = 10 ms`, two seconds).
//!
//! ```
//! # #[cfg(feature = "rigid")]
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use constraint_contact::geometry::{Collider, Shape};
//! use constraint_contact::rigid::ContactWorld;
//! use constraint_core::{DMat3, DQuat, DVec3, Pose, RigidBody};
//!
//! let mut world = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
//! world.add_collider(Collider::simple(None, Shape::plane(DVec3::Z, 0.0)?)?)?;
//! let (r, m) = (0.1, 4.19); // a water-dense ball: 1000 · 4/3 π r³ kg
//! let pose = Pose { x: DVec3::new(0.0, 0.0, 1.0), q: DQuat::IDENTITY };
//! let inertia = DMat3::from_diagonal(DVec3::splat(0.4 * m * r * r));
//! let ball = world.add_body(RigidBody::new(0, m, inertia, pose)?)?;
//! world.add_collider(Collider::simple(Some(ball), Shape::sphere(r)?)?)?;
//! for _ in 0..200 {
//!     world.step(1e-2)?;
//! }
//! let b = &world.bodies()[ball];
//! // measured: 9.9e-13 m above the radius, 9.9e-11 m/s
//! assert!((b.pose.x.z - r).abs() < 1e-6 && b.v.length() < 1e-6);
//! # Ok(())
//! # }
//! # #[cfg(not(feature = "rigid"))]
//! # fn main() {}
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
// Denied, not forbidden: the one exception is the soft step's AVX lanes
// (`rigid::soft_lanes::avx`, the intrinsics behind a run-time CPU feature check).
#![deny(unsafe_code)]
#![deny(missing_docs)]

/// The crate README's example, compiled and run with the doctests so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctest;

extern crate alloc;

pub mod geometry;
pub mod lcp;
#[cfg(feature = "rigid")]
pub mod rigid;
#[cfg(feature = "rigid")]
pub mod scenes;
