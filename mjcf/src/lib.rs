//! # constraint-mjcf
//!
//! Loads a documented subset of MuJoCo's MJCF into plain data (see [`model`]) and turns
//! MuJoCo generalized coordinates (keyframes) into maximal-coordinate body states.
//!
//! ```
//! let model = constraint_mjcf::load_str(r#"
//!   <mujoco>
//!     <worldbody>
//!       <body name="bob" pos="0 0 1">
//!         <joint type="hinge" axis="0 1 0" pos="0 0 0.5"/>
//!         <geom type="sphere" size="0.1"/>
//!       </body>
//!     </worldbody>
//!     <keyframe><key name="swing" qpos="0.3" qvel="1"/></keyframe>
//!   </mujoco>"#)?;
//! let state = model.initial_state(Some("swing"))?;
//! assert_eq!(state.len(), 1);
//! # Ok::<(), constraint_mjcf::MjcfError>(())
//! ```
//!
//! ## The subset
//!
//! Everything follows MuJoCo's conventions and defaults (checked against MuJoCo's
//! compiler source: `user_objects.cc`, `engine_core_smooth.c`).
//!
//! - `mujoco` (`model` ignored). Sections are applied in the order `compiler`, `option`,
//!   `default`, `worldbody`, `equality`, `keyframe`, wherever they appear.
//! - `compiler`: `angle` (`degree`, the default, or `radian`), `inertiafromgeom`
//!   (`false`, `true`, `auto` = from geoms when the body has no `inertial`), `eulerseq`
//!   (any three of `xyzXYZ`, default `xyz`: lower case rotating axes, upper case fixed);
//!   `autolimits`, `discardvisual`, `meshdir`, `texturedir`, `assetdir` are accepted and
//!   ignored (limits are outside the subset; assets are ignored).
//! - `option`: `timestep`, `gravity`, `integrator` (`Euler`, `RK4`, `implicit`,
//!   `implicitfast`); the solver-only settings `solver`, `iterations`, `ls_iterations`,
//!   `tolerance`, `ls_tolerance`, `jacobian` are accepted and ignored. Child `flag`:
//!   `contact` (sets [`Model::contact_disabled`]), `gravity` (`disable` sets
//!   [`Model::gravity`] to zero), `energy` and `warmstart` (accepted, ignored).
//! - `size`, `visual`, `statistic`, `asset`: skipped whole (nothing in them changes the
//!   dynamics of the subset; materials and textures only colour geoms).
//! - `default`: nested classes with `class`; they hold `joint` and `geom` attributes
//!   (`site`, `camera`, `light`, `material`, `mesh` defaults are ignored). Elements take
//!   `class`, else the nearest enclosing body's `childclass`, else the top-level class.
//! - `worldbody`: `geom` (world geoms), `body`.
//! - `body`: `name`, `pos`, `quat` / `axisangle` / `euler` / `xyaxes` / `zaxis` (at most
//!   one), `childclass`; children `inertial`, `joint` or `freejoint` (**at most one joint
//!   per body**; a body without joint is welded to its parent), `geom`, `body`; `site`,
//!   `camera`, `light` are accepted and ignored.
//! - `inertial`: `pos` and `mass` (required), an orientation, `diaginertia` or
//!   `fullinertia`.
//! - `joint`: `type` (`hinge` default, `slide`, `ball`, `free`), `pos`, `axis`,
//!   `damping`; `armature`, `stiffness`, `frictionloss`, `ref`, `springref` only when 0;
//!   `limited` / `range` only when they leave the joint unlimited (a limited joint is an
//!   error); `group` ignored. A free joint must sit on a child of the world; its anchor
//!   is the body origin (its `pos` is ignored, as in MuJoCo).
//! - `freejoint`: `name`, `group`, `align` (`false` or `auto`).
//! - `geom`: `type` (`sphere` default, `plane`, `box`, `capsule`), `size`, `fromto`
//!   (capsule, box), `pos`, an orientation, `friction`, `density` (default 1000),
//!   `mass` (overrides density: stored as the effective density `mass / volume`),
//!   `contype`, `conaffinity`, `condim` only when 3; `name`, `rgba`, `material`, `group`
//!   are visual and ignored; `solref`, `solimp`, `margin`, `gap` (and `option cone`) only
//!   tune MuJoCo's soft contact and are ignored (this library's contact is hard). Planes only in static bodies, as MuJoCo requires.
//! - `equality`: `connect` with `body1` (required), `body2` (default world), `anchor`
//!   (required), `name`, `active` only when true; `solref` / `solimp` accepted and ignored
//!   (they set the softness of MuJoCo's connect; this library enforces it as a hard constraint).
//! - `keyframe`: `key` with `name`, `time`, `qpos`, `qvel`. As MuJoCo 4.0 compiles
//!   keys: the values given fill the front, the rest is `qpos0` / zero, more than
//!   `nq` / `nv` values are an error, and ball / free quaternions are normalised (a zero
//!   quaternion becomes the identity).
//! - Not supported (typed error naming element and line): `include`, `contact`,
//!   `tendon`, `actuator`, `sensor`, `frame`, `site`-based connects, cylinders,
//!   ellipsoids, meshes, joint limits, and anything else not listed.
//!
//! Mass and inertia from geoms use MuJoCo's solid formulas:
//! sphere, box, capsule (cylinder plus two hemispheres); several geoms are combined about
//! their common centre of mass with the parallel-axis theorem; planes and geoms of mass
//! `≤ 1e-14` count for nothing. A moving body (one with a joint) needs mass and principal
//! inertias `≥ 1e-15`, its own or those of a body welded to it.
//!
//! ## Order and addresses
//!
//! Bodies, joints and geoms are numbered as MuJoCo numbers them: bodies depth-first in
//! document order (world excluded), joints and geoms body by body in that order (world
//! geoms first), in document order within a body. `qpos_adr` / `dof_adr` are running
//! sums over the joints in that order.
//!
//! ## Hostile input
//!
//! Loading never panics: malformed XML, DTDs, non-finite or overflowing numbers, negative
//! masses or sizes, nesting deeper than [`MAX_DEPTH`] are all typed [`MjcfError`]s.
#![deny(missing_docs)]

mod actuator;
mod attrs;
mod defaults;
mod elements;
pub mod error;
mod inertia;
mod kinematics;
mod math;
pub mod model;
mod orientation;
mod parse;
mod xml;

use std::path::Path;

pub use error::MjcfError;
pub use model::{
    Actuator, ActuatorKind, Assets, Body, BodyState, Connect, ContactExclude, ContactPair, Custom,
    Geom, Joint, JointEquality, JointKind, Keyframe, Marker, Model, Options, Primitive, Sensor,
    Shape, Site, Tendon, TendonEquality, Transmission, Weld,
};

/// Deepest element nesting accepted (the `mujoco` root is level 1).
pub const MAX_DEPTH: usize = 1000;

/// Loads a model from MJCF text. An `<include>` is an [`MjcfError::Include`] error
/// (there is no directory to resolve it against): use [`load_str_with_dir`] or
/// [`load_file`].
pub fn load_str(xml: &str) -> Result<Model, MjcfError> {
    parse::load(xml, None, None)
}

/// Loads a model from MJCF text whose `<include file="...">` paths are relative to
/// `dir`.
pub fn load_str_with_dir(xml: &str, dir: &Path) -> Result<Model, MjcfError> {
    parse::load(xml, Some(dir), None)
}

/// Loads a model from an MJCF file, following `include`s relative to the including
/// file's directory.
pub fn load_file(path: &Path) -> Result<Model, MjcfError> {
    let text = std::fs::read_to_string(path).map_err(|e| MjcfError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    parse::load(&text, Some(&dir), Some(path))
}
