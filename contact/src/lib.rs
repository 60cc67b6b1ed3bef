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
//! | [`geometry`] | shapes, narrow phase (points, normals, depths, ids), broad phase |
//! | `rigid` | (feature `rigid`) rigid bodies in contact: the contact LCP per step, solved matrix-free (sequential impulses, or Box2D v3's sub-stepped soft step) or by the dense solvers, with friction, restitution, warm starting and shock propagation |
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]

extern crate alloc;

pub mod geometry;
pub mod lcp;
#[cfg(feature = "rigid")]
pub mod rigid;
#[cfg(feature = "rigid")]
pub mod scenes;
