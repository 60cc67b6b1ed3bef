//! # constraint-mjcf
//!
//! Loads a documented subset of MuJoCo's MJCF into plain data (see [`model`]).
#![deny(missing_docs)]

pub mod model;

pub use model::{Body, BodyState, Connect, Geom, Joint, JointKind, Keyframe, Model, Shape};
