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
    /// `option/flag contact="disable"` seen.
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

/// One geom.
#[derive(Clone, Debug, PartialEq)]
pub struct Geom {
    /// `name` attribute or `geom<i>`.
    pub name: String,
    /// Owning body; `None` for world geoms.
    pub body: Option<usize>,
    /// Shape and size.
    pub shape: Shape,
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
