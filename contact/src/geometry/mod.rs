//! Shapes and contact generation.
//!
//! | module | holds |
//! |---|---|
//! | [`shape`] | [`Shape`] (plane, sphere, box, capsule), [`Collider`] (a shape on a body with its offset pose, friction, restitution), [`Aabb`], [`GeometryError`] |
//! | [`contact`] | [`Contact`] (pair, point, normal from `a` to `b`, depth = −gap, feature id) and [`ParticleContact`] |
//! | [`narrow`] | [`collide`] for any pair of colliders, [`point_vs`] for particles, [`closest_point`], [`closest_segments`] |
//! | [`broad`] | sort-and-sweep [`sweep_and_prune`], the all-pairs reference [`brute_force`], and [`generate_contacts`] for a whole scene ([`generate_contacts_with`] reuses a [`BroadScratch`]; [`generate_contacts_awake`] leaves out pairs of asleep bodies) |
//! | [`masked`] | [`generate_contacts_masked`]: contact generation under a fixed [`PairMask`] (which collider pairs may touch), sort-and-sweep with its order kept |
//! | [`grid`] | [`grid_pairs`]: the uniform-grid broad phase of [`generate_contacts`], its sorted order and candidate pairs kept between steps ([`GridScratch`]) |

pub mod broad;
pub mod contact;
pub mod grid;
pub mod masked;
pub mod narrow;
pub mod shape;

pub use broad::{
    brute_force, generate_contacts, generate_contacts_awake, generate_contacts_filtered,
    generate_contacts_with, sweep_and_prune, sweep_and_prune_masked, BroadScratch, BroadStats,
};
pub use contact::{Contact, ParticleContact};
pub use grid::{grid_pairs, GridScratch};
pub use masked::{
    generate_contacts_listed, generate_contacts_masked, generate_contacts_masked_pairs, PairMask,
};
pub use narrow::{closest_point, closest_segments, collide, point_vs, Closest};
pub use shape::{Aabb, Collider, GeometryError, Shape};
