//! # constraint-mjcf
//!
//! Loads a documented subset of MuJoCo's MJCF into plain data (see [`model`]) and turns
//! MuJoCo generalized coordinates (keyframes) into maximal-coordinate body states.
//!
//! A pendulum bob: its mass comes from the geom (water density, `1000 · 4/3 π r³`), and
//! the keyframe's hinge angle `0.3` about `y` through the pivot `0.5 m` above the body
//! swings the body origin to `(−0.5 sin 0.3, 0, 1.5 − 0.5 cos 0.3)`:
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
//! let bob = &model.bodies[0];
//! assert_eq!((bob.name.as_str(), bob.pos), ("bob", [0.0, 0.0, 1.0]));
//! assert!((bob.mass - 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * 1e-3).abs() < 1e-12); // measured 8.9e-16 kg
//! let state = model.initial_state(Some("swing"))?;
//! let (s, c) = 0.3f64.sin_cos();
//! let expected = [-0.5 * s, 0.0, 1.5 - 0.5 * c];
//! assert!(state[0].pos.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12)); // measured 0
//! # Ok::<(), constraint_mjcf::MjcfError>(())
//! ```
//!
//! ## The subset
//!
//! Everything follows MuJoCo 4.0's conventions and defaults (checked against MuJoCo's
//! compiler source: `user_objects.cc`, `user_model.cc`, `xml_native_reader.cc`,
//! `user_api.cc`, `engine_core_smooth.c`). Each element below is either **modelled**
//! (turned into the data of [`model`]), **data only** (kept as plain data for callers; the
//! loader gives it no dynamics of its own), or a **typed error**.
//!
//! - `mujoco` (`model` ignored). Sections are applied in the order `compiler`, `option`,
//!   `default`, `asset`, `worldbody`, `contact`, `tendon`, `equality`, `actuator`,
//!   `sensor`, `keyframe`, `custom`, wherever they appear. `size`, `visual`, `statistic`
//!   are accepted and not stored.
//! - `include file="..."` anywhere: the included file (root `<mujoco>`) has its top-level
//!   children spliced in place; paths are relative to the including file's directory.
//!   [`load_file`] follows includes; [`load_str`] refuses them ([`MjcfError::Include`]),
//!   [`load_str_with_dir`] resolves them against a directory. Missing files, cycles and a
//!   non-`mujoco` root are [`MjcfError::Include`] (file and line of the `include`); any
//!   error inside an included file is [`MjcfError::InFile`] (that file, the line in it).
//! - `compiler`: `angle` (`degree`, the default, or `radian`), `inertiafromgeom`
//!   (`false`, `true`, `auto` = from geoms when the body has no `inertial`),
//!   `inertiagrouprange` (default `0 5`: geoms of other groups carry no mass), `eulerseq`
//!   (any three of `xyzXYZ`, default `xyz`), `autolimits` (default `true`), `boundmass`,
//!   `boundinertia` (lower bounds on mass and principal inertias), `settotalmass` (all
//!   masses and inertias scaled so the masses sum to it, as `mj_setTotalmass`),
//!   `coordinate="local"` (`global` is a typed error, as in MuJoCo 4); `meshdir`,
//!   `texturedir`, `assetdir`, `discardvisual`, `strippath`, `usethread`, `fitaabb`,
//!   `saveinertial`, `exactmeshinertia`, `maxhullvert` accepted and ignored;
//!   `fusestatic`, `alignfree`, `balanceinertia` only when `false`.
//! - `option`: `timestep`, `gravity`, `integrator` (`Euler`, `RK4`, `implicit`,
//!   `implicitfast`) are modelled; `density`, `viscosity`, `wind`, `magnetic`, `cone`,
//!   `impratio`, `noslip_iterations`, `iterations`, `solver` are data
//!   ([`Model::options`]); other solver settings are accepted and ignored. Child `flag`:
//!   every attribute is kept in [`model::Options::flags`]; `contact="disable"` sets
//!   [`Model::contact_disabled`], `gravity="disable"` zeroes [`Model::gravity`].
//! - `default`: nested classes with `class` inherit their parent's settings. They hold
//!   `joint`, `geom`, `tendon`, `equality` and actuator (`general`, `motor`, `position`,
//!   `velocity`) attributes; actuator shortcuts in a class apply to the class's one
//!   default actuator in order, as in MuJoCo. `site`, `camera`, `light`, `material`,
//!   `mesh`, `pair` defaults are ignored. Elements take `class`, else the nearest
//!   enclosing body's `childclass`, else the top-level class.
//! - `asset`: `texture`, `material`, `mesh`, `hfield`, `skin` kept by name only
//!   ([`Model::assets`]).
//! - `worldbody`: `geom` (world geoms), `body`, `site`, `camera`, `light`.
//! - `body`: `name`, `pos`, `quat` / `axisangle` / `euler` / `xyaxes` / `zaxis` (at most
//!   one), `childclass`, `user`; `mocap` and `gravcomp` only when off. Children
//!   `inertial`, any number of `joint`s (composed in order, see below) or one
//!   `freejoint` / free joint **alone** (MuJoCo's rule), `geom`, `body`, and the data-only
//!   `site` ([`Model::sites`]), `camera`, `light` ([`Model::cameras`], [`Model::lights`]).
//!   A body without joints is welded to its parent. `frame` is a typed error.
//! - `inertial`: `pos` and `mass` (required), an orientation, `diaginertia` or
//!   `fullinertia`.
//! - `joint`: `type` (`hinge` default, `slide`, `ball`, `free`), `pos`, `axis`,
//!   `damping`, `armature`, `stiffness`, `springref`, `frictionloss`, `ref`, `limited`
//!   (`true` / `false` / `auto`: with `autolimits`, limited iff `range[0] < range[1]`),
//!   `range` — all stored in [`Joint`], angles of hinge (`range`, `ref`, `springref`) and
//!   ball (`range`) converted to radians with `angle="degree"`. A limited joint needs
//!   `range[0] < range[1]` (ball: `range[0] = 0`); negative `damping`, `armature`,
//!   `stiffness`, `frictionloss` are errors. `solreflimit`, `solimplimit`,
//!   `solreffriction`, `solimpfriction`, `margin`, `group`, `user`, `actuatorfrcrange`,
//!   `actuatorfrclimited` accepted and ignored; `springdamper` (hinge and slide) sets
//!   `stiffness` and `damping` from the inertia at `qpos0` as MuJoCo 4.0 does
//!   (`springdamper.rs`); `actuatorgravcomp` only when off. A free joint sits on a
//!   child of the world; its anchor is the body origin.
//! - `freejoint`: `name`, `group`, `align` (`false` or `auto`).
//! - `geom`: `type` (`sphere` default, `plane`, `box`, `capsule`, `cylinder`,
//!   `ellipsoid`), `size`, `fromto` (capsule, cylinder, box, ellipsoid), `pos`, an
//!   orientation, `friction`, `density` (default 1000), `mass` (overrides density),
//!   `contype`, `conaffinity`, `group` (modelled: masses, collision filter), and the data
//!   `condim` (1, 3, 4, 6), `priority`, `margin`, `gap`, `solref`, `solimp`, `solmix`,
//!   `rgba`, `material`, `user` (see [`Geom`]; [`Geom::primitive`] holds the exact shape,
//!   [`Geom::shape`] the four-shape view where a cylinder or ellipsoid is its bounding
//!   box). `fluidshape`, `fluidcoef`, `fitscale` ignored. Planes only in static bodies.
//! - `contact`: `exclude` (`body1`, `body2`) and `pair` (`geom1`, `geom2`, `condim`,
//!   `friction`; softness ignored) as data.
//! - `tendon`: `fixed` with `joint` children (`joint`, `coef`, hinge or slide joints),
//!   `stiffness`, `damping`, `frictionloss`, `range` / `limited` (the joint rule),
//!   `springlength`, `class`; `spatial` with the same attributes and `site` children
//!   (`site`; at least two): straight segments between consecutive sites; visual and
//!   softness attributes ignored ([`Tendon`]).
//! - `equality`: `connect` (modelled; `body1`, `body2`, `anchor`, `active` only when
//!   true), `joint` (`joint1`, `joint2`, `polycoef`), `tendon` (`tendon1`, `tendon2`,
//!   `polycoef`) and `weld` (`body1`, `body2`, `anchor`, `relpose`, `torquescale`) as
//!   data, all with `name`, `class`, `active`; `solref` / `solimp` ignored.
//! - `actuator`: `motor`, `position` (`kp`, `kv`, `inheritrange`), `velocity` (`kv`),
//!   `general` (`gaintype="fixed"`, `biastype` `none` / `affine`, `gainprm`, `biasprm`,
//!   `dyntype="none"`), with `joint` or `tendon`, `gear`, `ctrlrange` / `ctrllimited`,
//!   `forcerange` / `forcelimited` (MuJoCo's `auto` rule), `name`, `class`: stored in
//!   MuJoCo's general form ([`Actuator`]). Other actuator types, activation dynamics,
//!   `dampratio`, non-zero `timeconst`, and site / body / slider-crank transmissions are
//!   typed errors.
//! - `sensor`: every child kept as name, type and target ([`Model::sensors`]).
//! - `custom`: `numeric`, `text`, `tuple` as data ([`Model::custom`]).
//! - `keyframe`: `key` with `name`, `time`, `qpos`, `qvel`, `ctrl`. As MuJoCo 4.0
//!   compiles keys: the values given fill the front, the rest is `qpos0` / zero, more
//!   than `nq` / `nv` / `nu` values are an error, and ball / free quaternions are
//!   normalised (a zero quaternion becomes the identity).
//! - Typed errors ([`MjcfError::UnsupportedFeature`], naming element and line): mesh and
//!   sdf geoms (any geom naming a `mesh`), hfield geoms, a spatial tendon's wrapping
//!   `geom` and `pulley`, `frame`,
//!   `extension` / plugins, the actuator features above, `springdamper` on a ball or
//!   free joint. Anything not
//!   listed is [`MjcfError::Unsupported`] or [`MjcfError::UnsupportedAttribute`].
//!
//! Soft-constraint tuning (`solref`, `solimp`, `solreflimit`, `solimplimit`,
//! `solreffriction`, `solimpfriction`, `margin`, `gap`, `priority`, `solmix`,
//! `o_solref`, `o_solimp`, `o_margin`) anywhere in the file earns one message in
//! [`Model::warnings`]: this library's constraints are hard. The loader never prints.
//!
//! Mass and inertia from geoms use MuJoCo's solid formulas: sphere, box, capsule
//! (cylinder plus two hemispheres), cylinder, ellipsoid; several geoms are combined about
//! their common centre of mass with the parallel-axis theorem; planes and geoms of mass
//! `≤ 1e-14` count for nothing. A moving body (one with a joint) needs mass and principal
//! inertias `≥ 1e-15`, its own or those of a body welded to it.
//!
//! ## Generalized coordinates
//!
//! [`Model::nq`], [`Model::nv`], [`Model::qpos0`] (hinge and slide at their `ref`) and
//! [`Model::body_states`] map full `qpos` / `qvel` vectors to body states as
//! `mj_kinematics` and `mj_comVel` do: the joints of a body are applied in order, each
//! about its own anchor and axis in the frame the previous ones left (hinge and slide
//! move by `q − ref`); hinge dofs turn about their anchor and axis, slide dofs translate,
//! ball dofs turn about their anchor along the body's final axes.
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
#![forbid(unsafe_code)]
#![deny(missing_docs)]

/// The crate README's example, compiled and run with the doctests so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctest;

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
mod springdamper;
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
