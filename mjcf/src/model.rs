//! The loaded model: plain data, world frame at the model's default pose (`qpos0`).
//!
//! Conventions (DESIGN.md §5, §8): SI units, quaternions `[w, x, y, z]`, angles in
//! radians after loading, angular velocities in world coordinates.

/// A loaded MJCF model in maximal-coordinate terms.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// `option timestep` (MuJoCo default 0.002 s).
    pub timestep: f64,
    /// `option gravity` (MuJoCo default `(0, 0, −9.81)`).
    pub gravity: [f64; 3],
    /// `option integrator` as written (`Euler`, `implicitfast`, `RK4`, ...), default `Euler`.
    pub integrator: String,
    /// `option/flag contact="disable"` (or `constraint="disable"`) seen.
    pub contact_disabled: bool,
    /// Bodies in document order, world body excluded.
    pub bodies: Vec<Body>,
    /// Joints in document order.
    pub joints: Vec<Joint>,
    /// Geoms in document order (world geoms have `body == None`).
    pub geoms: Vec<Geom>,
    /// `equality/connect` elements in document order.
    pub connects: Vec<Connect>,
    /// Keyframes in document order.
    pub keyframes: Vec<Keyframe>,
    /// Actuators in document order (MuJoCo's general form, see [`Actuator`]).
    pub actuators: Vec<Actuator>,
    /// Tendons (fixed and spatial) in document order.
    pub tendons: Vec<Tendon>,
    /// `equality/joint` constraints in document order.
    pub joint_equalities: Vec<JointEquality>,
    /// `equality/tendon` constraints in document order (data only).
    pub tendon_equalities: Vec<TendonEquality>,
    /// `equality/weld` constraints in document order (data only).
    pub welds: Vec<Weld>,
    /// `contact/exclude`: body pairs whose geoms never collide.
    pub contact_excludes: Vec<ContactExclude>,
    /// `contact/pair`: explicit geom pairs (data only).
    pub contact_pairs: Vec<ContactPair>,
    /// Sites (massless markers) in document order.
    pub sites: Vec<Site>,
    /// Cameras (name and body only).
    pub cameras: Vec<Marker>,
    /// Lights (name and body only).
    pub lights: Vec<Marker>,
    /// Sensors (data only).
    pub sensors: Vec<Sensor>,
    /// `custom` numeric, text and tuple entries.
    pub custom: Vec<Custom>,
    /// Names of the assets (`texture`, `material`, `mesh`, `hfield`, `skin`).
    pub assets: Assets,
    /// `option` settings beyond timestep, gravity and integrator.
    pub options: Options,
    /// What the file asks for that the model does not carry, one message each (for
    /// example MuJoCo's soft-constraint parameters). The loader never prints; callers do.
    pub warnings: Vec<String>,
}

/// `option` settings read as data (fluid, friction cone, solver details).
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Medium density (`density`, default 0) for MuJoCo's fluid forces.
    pub density: f64,
    /// Medium viscosity (`viscosity`, default 0).
    pub viscosity: f64,
    /// Wind velocity (`wind`, default zero).
    pub wind: [f64; 3],
    /// Magnetic field (`magnetic`, default `0 -0.5 0`).
    pub magnetic: [f64; 3],
    /// Friction cone (`cone`: `pyramidal`, the default, or `elliptic`).
    pub cone: String,
    /// `impratio` (default 1).
    pub impratio: f64,
    /// `noslip_iterations` (default 0).
    pub noslip_iterations: u32,
    /// `solver` as written (default `Newton`).
    pub solver: String,
    /// `iterations` (default 100).
    pub iterations: u32,
    /// Every `flag` attribute as written: name and `true` for `enable`.
    pub flags: Vec<(String, bool)>,
}

impl Options {
    /// Whether `option/flag` turns `name` off (the last `flag` element naming it wins);
    /// `constraint="disable"` turns off every constraint kind (`contact`, `limit`,
    /// `equality`, `frictionloss`), as in MuJoCo.
    pub fn disabled(&self, name: &str) -> bool {
        let last = |n: &str| self.flags.iter().rev().find(|(f, _)| f == n).map(|f| f.1);
        let constraint_off = last("constraint") == Some(false);
        let kind = matches!(name, "contact" | "limit" | "equality" | "frictionloss");
        last(name) == Some(false) || (kind && constraint_off)
    }
}

impl Default for Options {
    fn default() -> Self {
        Options {
            density: 0.0,
            viscosity: 0.0,
            wind: [0.0; 3],
            magnetic: [0.0, -0.5, 0.0],
            cone: "pyramidal".into(),
            impratio: 1.0,
            noslip_iterations: 0,
            solver: "Newton".into(),
            iterations: 100,
            flags: Vec::new(),
        }
    }
}

/// Actuator shortcut as written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActuatorKind {
    /// `motor`: `force = gear·ctrl`.
    Motor,
    /// `position`: `force = kp·ctrl − kp·q − kv·q̇`.
    Position,
    /// `velocity`: `force = kv·ctrl − kv·q̇`.
    Velocity,
    /// `general` with fixed gain, no or affine bias, no activation dynamics.
    General,
}

/// What an actuator drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transmission {
    /// A joint (index in [`Model::joints`]); `length` is its coordinate times the gear.
    Joint(usize),
    /// A tendon (index in [`Model::tendons`]).
    Tendon(usize),
}

/// One actuator in MuJoCo's general form: the scalar actuator force is
/// `gain·ctrl + bias[0] + bias[1]·length + bias[2]·velocity`, then clamped to
/// `forcerange` when `forcelimited`; the generalized force is that times `gear[0]`
/// (for a joint) along the joint's dof. `length = gear[0]·q`, `velocity = gear[0]·q̇`.
#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    /// `name` or `actuator<i>`.
    pub name: String,
    /// The element it was written as.
    pub kind: ActuatorKind,
    /// Joint or tendon driven.
    pub target: Transmission,
    /// `gear` (6 numbers, default `1 0 0 0 0 0`; only the first matters for joints and
    /// tendons).
    pub gear: [f64; 6],
    /// Fixed gain (`gainprm[0]`).
    pub gain: f64,
    /// Affine bias (`biasprm[0..3]`; zero for `biastype="none"`).
    pub bias: [f64; 3],
    /// Control is clamped to `ctrlrange`.
    pub ctrllimited: bool,
    /// `ctrlrange`.
    pub ctrlrange: [f64; 2],
    /// Force is clamped to `forcerange`.
    pub forcelimited: bool,
    /// `forcerange`.
    pub forcerange: [f64; 2],
    /// 1-based line.
    pub line: u32,
}

/// `tendon/fixed`: a linear combination of joint coordinates, `length = Σ coef·q`;
/// `tendon/spatial`: a path through sites, `length = Σ_k |p_{k+1} − p_k|` (straight
/// segments between consecutive sites; wrapping is not read).
#[derive(Clone, Debug, PartialEq)]
pub struct Tendon {
    /// `name` or `tendon<i>`.
    pub name: String,
    /// `(joint index, coef)` in document order (empty for a spatial tendon).
    pub joints: Vec<(usize, f64)>,
    /// A spatial tendon's path: site indices ([`Model::sites`]) in document order, at
    /// least two (empty for a fixed tendon).
    pub sites: Vec<usize>,
    /// `stiffness` (default 0).
    pub stiffness: f64,
    /// `damping` (default 0).
    pub damping: f64,
    /// `frictionloss` (default 0).
    pub frictionloss: f64,
    /// Length limits active (MuJoCo's `limited` rule, as for joints).
    pub limited: bool,
    /// `range`.
    pub range: [f64; 2],
    /// `springlength` as written (default `-1 -1`: MuJoCo then uses the length at
    /// `qpos0`).
    pub springlength: [f64; 2],
    /// 1-based line.
    pub line: u32,
}

/// `equality/joint`: `q2`-polynomial coupling `q1 − q1ref = Σ c_k (q2 − q2ref)^k`.
#[derive(Clone, Debug, PartialEq)]
pub struct JointEquality {
    /// `name` or `equality<i>`.
    pub name: String,
    /// `joint1`.
    pub joint1: usize,
    /// `joint2` (`None`: `joint1` is held at `polycoef[0]` above its reference).
    pub joint2: Option<usize>,
    /// `polycoef` (5 numbers, default `0 1 0 0 0`).
    pub polycoef: [f64; 5],
    /// `active` (default true).
    pub active: bool,
    /// 1-based line.
    pub line: u32,
}

/// `equality/tendon` (data only).
#[derive(Clone, Debug, PartialEq)]
pub struct TendonEquality {
    /// `name` or `equality<i>`.
    pub name: String,
    /// `tendon1`.
    pub tendon1: usize,
    /// `tendon2`.
    pub tendon2: Option<usize>,
    /// `polycoef`.
    pub polycoef: [f64; 5],
    /// `active`.
    pub active: bool,
    /// 1-based line.
    pub line: u32,
}

/// `equality/weld` (data only).
#[derive(Clone, Debug, PartialEq)]
pub struct Weld {
    /// `name` or `equality<i>`.
    pub name: String,
    /// `body1` (`None` = world).
    pub body1: Option<usize>,
    /// `body2` (`None` = world).
    pub body2: Option<usize>,
    /// `anchor` in `body2`'s frame (default zero).
    pub anchor: [f64; 3],
    /// `relpose` (pos, quat) when given with a non-zero quaternion; `None`: the default
    /// pose is kept.
    pub relpose: Option<[f64; 7]>,
    /// `torquescale` (default 1).
    pub torquescale: f64,
    /// `active`.
    pub active: bool,
    /// 1-based line.
    pub line: u32,
}

/// `contact/exclude`.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactExclude {
    /// `name` (empty when absent).
    pub name: String,
    /// `body1` (`None` = world).
    pub body1: Option<usize>,
    /// `body2` (`None` = world).
    pub body2: Option<usize>,
    /// 1-based line.
    pub line: u32,
}

/// `contact/pair` (data only).
#[derive(Clone, Debug, PartialEq)]
pub struct ContactPair {
    /// `name` (empty when absent).
    pub name: String,
    /// `geom1` index.
    pub geom1: usize,
    /// `geom2` index.
    pub geom2: usize,
    /// `condim` (default 3).
    pub condim: u32,
    /// `friction` (5 numbers, default `1 1 0.005 0.0001 0.0001`).
    pub friction: [f64; 5],
    /// 1-based line.
    pub line: u32,
}

/// A site: a massless, collision-free frame on a body.
#[derive(Clone, Debug, PartialEq)]
pub struct Site {
    /// `name` or `site<i>`.
    pub name: String,
    /// Owning body (`None` = world).
    pub body: Option<usize>,
    /// `type` as written (default `sphere`).
    pub kind: String,
    /// `size` (default `0.005 0.005 0.005`).
    pub size: [f64; 3],
    /// Position in the body frame.
    pub pos: [f64; 3],
    /// Orientation in the body frame.
    pub quat: [f64; 4],
    /// 1-based line.
    pub line: u32,
}

/// A camera or light: kept by name and body only.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// `name` (empty when absent).
    pub name: String,
    /// Owning body (`None` = world).
    pub body: Option<usize>,
    /// 1-based line.
    pub line: u32,
}

/// A sensor (data only).
#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    /// `name` (empty when absent).
    pub name: String,
    /// Sensor type: the element name (`touch`, `jointpos`, ...).
    pub kind: String,
    /// The object it reads, as written (`site`, `joint`, `body`, `objname`, ...;
    /// empty when it has none).
    pub target: String,
    /// 1-based line.
    pub line: u32,
}

/// A `custom` entry.
#[derive(Clone, Debug, PartialEq)]
pub struct Custom {
    /// `name`.
    pub name: String,
    /// `numeric`, `text` or `tuple`.
    pub kind: String,
    /// Numbers of a `numeric` (zero-padded to `size`); the `prm` of each tuple element.
    pub data: Vec<f64>,
    /// Text of a `text`; the `objtype:objname` of each tuple element, space-separated.
    pub text: String,
}

/// Asset names (assets themselves are not loaded).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Assets {
    /// Named textures.
    pub textures: Vec<String>,
    /// Materials.
    pub materials: Vec<String>,
    /// Meshes (`name`, else the file name without extension, as MuJoCo names them).
    pub meshes: Vec<String>,
    /// Height fields.
    pub hfields: Vec<String>,
    /// Skins.
    pub skins: Vec<String>,
}

/// One rigid body.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// `name` attribute, or `body<i>` when absent.
    pub name: String,
    /// Index of the parent body in [`Model::bodies`]; `None` for a child of the world.
    pub parent: Option<usize>,
    /// Body frame origin in world coordinates at the default pose (MuJoCo `xpos`).
    pub pos: [f64; 3],
    /// Body frame orientation in world coordinates at the default pose (`xquat`, `[w,x,y,z]`).
    pub quat: [f64; 4],
    /// Mass (kg); from `inertial`, or from the geoms when `inertiafromgeom` applies.
    pub mass: f64,
    /// Centre of mass in the body frame (MuJoCo `ipos`).
    pub com: [f64; 3],
    /// Inertia tensor about the centre of mass, expressed in the body frame (row-major,
    /// symmetric): MuJoCo's principal inertia rotated by `iquat`.
    pub inertia: [[f64; 3]; 3],
    /// 1-based line of the `<body>` element in its file.
    pub line: u32,
}

/// Joint kinds of the subset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// One rotational degree of freedom about `axis` through `pos`.
    Hinge,
    /// Three rotational degrees of freedom about `pos` (MuJoCo `ball`).
    Ball,
    /// One translational degree of freedom along `axis` (MuJoCo `slide`).
    Slide,
    /// Six degrees of freedom: the body is unconstrained (`free` or `<freejoint/>`).
    Free,
}

/// One joint: connects its body to the body's parent.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// `name` attribute, or `joint<i>` when absent.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Index of the body that owns the joint.
    pub body: usize,
    /// Anchor in the body frame (`pos`).
    pub pos: [f64; 3],
    /// Unit axis in the body frame (`axis`, normalised; unused for ball and free).
    pub axis: [f64; 3],
    /// Viscous damping (`damping`, N·m·s/rad or N·s/m).
    pub damping: f64,
    /// Position limits active: `limited="true"`, or `auto` (the default) with
    /// `compiler autolimits="true"` (the default) and a `range` with `range[0] < range[1]`.
    pub limited: bool,
    /// `range` (radians for hinge and ball with `angle="degree"`; for ball only
    /// `range[1]`, the largest rotation angle, matters). Meaningful when `limited`.
    pub range: [f64; 2],
    /// Rotor inertia added to the joint's dofs (`armature`).
    pub armature: f64,
    /// Spring stiffness toward `springref` (`stiffness`).
    pub stiffness: f64,
    /// Spring rest position (`springref`; radians for hinge).
    pub springref: f64,
    /// Dry friction (`frictionloss`).
    pub frictionloss: f64,
    /// Reference position (`ref`; radians for hinge): the joint's `qpos0`. Hinge and
    /// slide positions move the body by `qpos − reference`.
    pub reference: f64,
    /// Offset of this joint's values in `qpos` (hinge, slide 1; ball 4; free 7).
    pub qpos_adr: usize,
    /// Offset of this joint's values in `qvel` (hinge, slide 1; ball 3; free 6).
    pub dof_adr: usize,
    /// 1-based line of the element.
    pub line: u32,
}

/// Geom shapes of the subset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Infinite plane through the geom origin with normal = geom z axis (`size` is visual).
    Plane,
    /// Sphere of the given radius.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// Box with the given half-extents along the geom axes.
    Box {
        /// Half sizes (m).
        half: [f64; 3],
    },
    /// Capsule along the geom z axis.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half length of the cylindrical part (m).
        half_length: f64,
    },
}

/// Geom shapes with MuJoCo's primitive types (exact shape of every geom).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// Plane; `size` as written (half extents for rendering, grid spacing).
    Plane {
        /// `size`.
        size: [f64; 3],
    },
    /// Sphere.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// Capsule along the geom z axis.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half length of the cylindrical part (m).
        half_length: f64,
    },
    /// Cylinder along the geom z axis.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Half height (m).
        half_length: f64,
    },
    /// Box.
    Box {
        /// Half sizes (m).
        half: [f64; 3],
    },
    /// Ellipsoid with semi-axes along the geom axes.
    Ellipsoid {
        /// Semi-axes (m).
        radii: [f64; 3],
    },
}

/// One geom.
#[derive(Clone, Debug, PartialEq)]
pub struct Geom {
    /// `name` attribute or `geom<i>`.
    pub name: String,
    /// Owning body; `None` for world geoms.
    pub body: Option<usize>,
    /// Shape and size in the four-shape subset. A cylinder or an ellipsoid appears here
    /// as its bounding box; [`Geom::primitive`] holds the exact shape.
    pub shape: Shape,
    /// Exact shape and size (MuJoCo's primitive types).
    pub primitive: Primitive,
    /// Mass (kg) of the geom as MuJoCo computes it (`mass`, or density times volume).
    pub mass: f64,
    /// `condim` (1, 3, 4 or 6; default 3).
    pub condim: u32,
    /// `priority` (default 0).
    pub priority: i32,
    /// `margin` (default 0).
    pub margin: f64,
    /// `gap` (default 0).
    pub gap: f64,
    /// `solref` (default `0.02 1`).
    pub solref: [f64; 2],
    /// `solimp` (default `0.9 0.95 0.001 0.5 2`).
    pub solimp: [f64; 5],
    /// `solmix` (default 1).
    pub solmix: f64,
    /// `rgba` (default `0.5 0.5 0.5 1`).
    pub rgba: [f64; 4],
    /// `material` name (empty when absent).
    pub material: String,
    /// `group` (default 0).
    pub group: i32,
    /// `user` numbers.
    pub user: Vec<f64>,
    /// Position in the owning body's frame (world frame for world geoms).
    pub pos: [f64; 3],
    /// Orientation in the owning body's frame (`[w,x,y,z]`; `fromto` sets it).
    pub quat: [f64; 4],
    /// Sliding, torsional, rolling friction (`friction`, default `1 0.005 0.0001`).
    pub friction: [f64; 3],
    /// Density used for its mass when inertia comes from geoms (default 1000).
    pub density: f64,
    /// `contype` (default 1).
    pub contype: u32,
    /// `conaffinity` (default 1).
    pub conaffinity: u32,
    /// 1-based line of the element.
    pub line: u32,
}

/// `equality/connect`: a ball-joint constraint closing a loop.
#[derive(Clone, Debug, PartialEq)]
pub struct Connect {
    /// `name` attribute or `connect<i>`.
    pub name: String,
    /// `body1` index (`None` = world).
    pub body1: Option<usize>,
    /// `body2` index (`None` = world).
    pub body2: Option<usize>,
    /// Anchor in `body1`'s frame (`anchor`).
    pub anchor: [f64; 3],
    /// The same point in `body2`'s frame at the default pose (computed by the loader).
    pub anchor2: [f64; 3],
    /// 1-based line.
    pub line: u32,
}

/// `keyframe/key`: an initial state in MuJoCo's generalized coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Keyframe {
    /// `name` attribute or `key<i>`.
    pub name: String,
    /// `time` (default 0).
    pub time: f64,
    /// Generalized positions (length `nq`; missing → `qpos0`).
    pub qpos: Vec<f64>,
    /// Generalized velocities (length `nv`; missing → 0).
    pub qvel: Vec<f64>,
    /// Controls (length = number of actuators; missing → 0).
    pub ctrl: Vec<f64>,
    /// 1-based line.
    pub line: u32,
}

/// One body's maximal-coordinate state, all in world coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// Body frame origin (`xpos`).
    pub pos: [f64; 3],
    /// Body frame orientation (`xquat`, `[w,x,y,z]`).
    pub quat: [f64; 4],
    /// Centre of mass (`xipos`).
    pub com: [f64; 3],
    /// Linear velocity of the centre of mass.
    pub vel: [f64; 3],
    /// Angular velocity.
    pub omega: [f64; 3],
}
