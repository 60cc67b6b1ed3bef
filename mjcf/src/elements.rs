//! `joint` and `geom` attribute sets (shared by elements and `default` classes), with
//! MuJoCo's defaults, and their compilation into model data.

use crate::attrs::{Attr, Element};
use crate::error::MjcfError;
use crate::inertia;
use crate::math::{self, normalize3, Q, V3};
use crate::model::{JointKind, Primitive, Shape};
use crate::orientation::{self, AngleConvention, Orientation};

/// `limited`: MuJoCo's tri-state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Limited {
    False,
    True,
    Auto,
}

/// A joint's attributes after defaults (MuJoCo `mjs_defaultJoint`).
#[derive(Clone, Debug)]
pub(crate) struct JointSpec {
    kind: JointKind,
    pos: V3,
    axis: V3,
    axis_attr: Option<Attr>,
    damping: f64,
    limited: (Limited, Option<Attr>),
    range: Option<([f64; 2], Attr)>,
    armature: f64,
    stiffness: f64,
    springref: f64,
    frictionloss: f64,
    reference: f64,
    /// `springdamper` (time constant, damping ratio) and where it was written.
    springdamper: Option<([f64; 2], Attr)>,
}

impl Default for JointSpec {
    fn default() -> Self {
        JointSpec {
            kind: JointKind::Hinge,
            pos: [0.0; 3],
            axis: [0.0, 0.0, 1.0],
            axis_attr: None,
            damping: 0.0,
            limited: (Limited::Auto, None),
            range: None,
            armature: 0.0,
            stiffness: 0.0,
            springref: 0.0,
            frictionloss: 0.0,
            reference: 0.0,
            springdamper: None,
        }
    }
}

/// The compiled joint (without name and indices).
pub(crate) struct JointData {
    pub kind: JointKind,
    pub pos: V3,
    pub axis: V3,
    pub damping: f64,
    pub limited: bool,
    pub range: [f64; 2],
    pub armature: f64,
    pub stiffness: f64,
    pub springref: f64,
    pub frictionloss: f64,
    pub reference: f64,
    /// `springdamper` when both numbers are positive (it then overrides `stiffness`
    /// and `damping`, `crate::springdamper`), with its attribute.
    pub springdamper: Option<([f64; 2], Attr)>,
}

/// Attributes accepted and ignored on `joint`: visual, user data, and the softness of
/// MuJoCo's limit and friction constraints (reported in `Model::warnings`).
const JOINT_IGNORED: [&str; 9] = [
    "group",
    "user",
    "solreflimit",
    "solimplimit",
    "solreffriction",
    "solimpfriction",
    "margin",
    "actuatorfrcrange",
    "actuatorfrclimited",
];

/// Attributes that tune MuJoCo's soft constraints: present anywhere, they earn one
/// warning (the library's constraints are hard).
pub(crate) const SOFTNESS_ATTRS: [&str; 13] = [
    "solref",
    "solimp",
    "solreflimit",
    "solimplimit",
    "solreffriction",
    "solimpfriction",
    "margin",
    "gap",
    "priority",
    "solmix",
    "o_solref",
    "o_solimp",
    "o_margin",
];

impl JointSpec {
    /// Applies one attribute (`name` and `class` are the caller's).
    pub fn apply(&mut self, a: &Attr) -> Result<(), MjcfError> {
        match a.name.as_str() {
            "type" => {
                self.kind = a.keyword(&[
                    ("hinge", JointKind::Hinge),
                    ("slide", JointKind::Slide),
                    ("ball", JointKind::Ball),
                    ("free", JointKind::Free),
                ])?
            }
            "pos" => self.pos = a.exact()?,
            "axis" => {
                self.axis = a.exact()?;
                self.axis_attr = Some(a.clone());
            }
            "damping" => self.damping = a.non_negative()?,
            "armature" => self.armature = a.non_negative()?,
            "stiffness" => self.stiffness = a.non_negative()?,
            "frictionloss" => self.frictionloss = a.non_negative()?,
            "ref" => self.reference = a.scalar()?,
            "springref" => self.springref = a.scalar()?,
            // Stiffness and damping set from the mass matrix at qpos0
            // (`crate::springdamper`), when both numbers are positive.
            "springdamper" => {
                let v: [f64; 2] = a.exact()?;
                if v[0] < 0.0 || v[1] < 0.0 {
                    return Err(a.bad("must not be negative"));
                }
                self.springdamper = (v[0] > 0.0 && v[1] > 0.0).then(|| (v, a.clone()));
            }
            "actuatorgravcomp" => {
                if a.boolean()? {
                    return Err(a.feature("actuatorgravcomp"));
                }
            }
            "limited" => {
                let l = a.keyword(&[
                    ("false", Limited::False),
                    ("true", Limited::True),
                    ("auto", Limited::Auto),
                ])?;
                self.limited = (l, Some(a.clone()));
            }
            "range" => self.range = Some((a.exact()?, a.clone())),
            n if JOINT_IGNORED.contains(&n) => {}
            _ => return Err(a.unsupported()),
        }
        Ok(())
    }

    /// Checks and normalises (`mjCJoint::Compile`): limits resolved with `autolimits`,
    /// angles of hinge (range, ref, springref) and ball (range) converted to radians.
    pub fn finish(
        &self,
        el: &Element,
        conv: AngleConvention,
        autolimits: bool,
    ) -> Result<JointData, MjcfError> {
        let mut range = self.range.as_ref().map_or([0.0; 2], |(r, _)| *r);
        let limit_err = |reason: &str| match (&self.range, &self.limited.1) {
            (Some((_, a)), _) => a.bad(reason),
            (None, Some(a)) => a.bad(reason),
            (None, None) => el.invalid(reason),
        };
        let limited = match (self.kind, self.limited.0) {
            (JointKind::Free, Limited::True) => {
                return Err(limit_err("limits should not be defined in free joint"))
            }
            (JointKind::Free, _) => false,
            (_, Limited::True) => true,
            (_, Limited::False) => false,
            (_, Limited::Auto) => {
                let hasrange = !(range[0] == 0.0 && range[1] == 0.0);
                if !autolimits && hasrange {
                    return Err(limit_err(
                        "joint has `range` but not `limited`: set compiler autolimits=\"true\" or give `limited`",
                    ));
                }
                range[0] < range[1]
            }
        };
        if limited {
            if range[0] >= range[1] && self.kind != JointKind::Ball {
                return Err(limit_err(
                    "range[0] should be smaller than range[1] in joint",
                ));
            }
            if range[0] != 0.0 && self.kind == JointKind::Ball {
                return Err(limit_err("range[0] should be 0 in ball joint"));
            }
            if matches!(self.kind, JointKind::Hinge | JointKind::Ball) {
                range = [conv.radians(range[0]), conv.radians(range[1])];
            }
        }
        let (reference, springref) = if self.kind == JointKind::Hinge {
            (conv.radians(self.reference), conv.radians(self.springref))
        } else {
            (self.reference, self.springref)
        };
        let axis = match self.kind {
            JointKind::Hinge | JointKind::Slide => {
                let mut axis = self.axis;
                if normalize3(&mut axis) < math::EPS {
                    return Err(match &self.axis_attr {
                        Some(a) => a.bad("axis too small"),
                        None => el.invalid("axis too small"),
                    });
                }
                axis
            }
            JointKind::Ball | JointKind::Free => [0.0, 0.0, 1.0],
        };
        // MuJoCo anchors a free joint at the body origin whatever its `pos`.
        let pos = if self.kind == JointKind::Free {
            [0.0; 3]
        } else {
            self.pos
        };
        Ok(JointData {
            kind: self.kind,
            pos,
            axis,
            damping: self.damping,
            limited,
            range,
            armature: self.armature,
            stiffness: self.stiffness,
            springref,
            frictionloss: self.frictionloss,
            reference,
            springdamper: self.springdamper.clone(),
        })
    }
}

/// Geom types of the subset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum GeomType {
    Plane,
    Sphere,
    Box,
    Capsule,
    Cylinder,
    Ellipsoid,
    /// `mesh`, `sdf`, `hfield`: recognised, refused in `finish`.
    Unsupported,
}

/// A geom's attributes after defaults (MuJoCo `mjs_defaultGeom`).
#[derive(Clone, Debug)]
pub(crate) struct GeomSpec {
    kind: GeomType,
    size: [f64; 3],
    size_attr: Option<Attr>,
    fromto: Option<([f64; 6], Attr)>,
    pos: V3,
    orient: Option<(Orientation, Attr)>,
    friction: V3,
    density: f64,
    mass: Option<f64>,
    contype: u32,
    conaffinity: u32,
    type_attr: Option<Attr>,
    mesh: Option<Attr>,
    hfield: Option<Attr>,
    condim: u32,
    priority: i32,
    margin: f64,
    gap: f64,
    solref: [f64; 2],
    solimp: [f64; 5],
    solmix: f64,
    rgba: [f64; 4],
    material: String,
    group: i32,
    user: Vec<f64>,
}

impl Default for GeomSpec {
    fn default() -> Self {
        GeomSpec {
            kind: GeomType::Sphere,
            size: [0.0; 3],
            size_attr: None,
            fromto: None,
            pos: [0.0; 3],
            orient: None,
            friction: [1.0, 0.005, 0.0001],
            density: 1000.0,
            mass: None,
            contype: 1,
            conaffinity: 1,
            type_attr: None,
            mesh: None,
            hfield: None,
            condim: 3,
            priority: 0,
            margin: 0.0,
            gap: 0.0,
            solref: [0.02, 1.0],
            solimp: [0.9, 0.95, 0.001, 0.5, 2.0],
            solmix: 1.0,
            rgba: [0.5, 0.5, 0.5, 1.0],
            material: String::new(),
            group: 0,
            user: Vec::new(),
        }
    }
}

/// The compiled geom (without name and owner).
pub(crate) struct GeomData {
    pub shape: Shape,
    pub primitive: Primitive,
    pub condim: u32,
    pub priority: i32,
    pub margin: f64,
    pub gap: f64,
    pub solref: [f64; 2],
    pub solimp: [f64; 5],
    pub solmix: f64,
    pub rgba: [f64; 4],
    pub material: String,
    pub group: i32,
    pub user: Vec<f64>,
    pub pos: V3,
    pub quat: Q,
    pub friction: V3,
    /// Effective density: `mass / volume` when `mass` was given.
    pub density: f64,
    pub contype: u32,
    pub conaffinity: u32,
    /// Mass and principal inertia (zero for planes and zero density).
    pub mass: f64,
    pub inertia: V3,
}

/// Attributes accepted and ignored on `geom`: fluid-model shape (MuJoCo's default
/// `fluidshape="none"` ignores the geom in the inertia-box fluid model) and mesh fitting.
const GEOM_IGNORED: [&str; 3] = ["fluidshape", "fluidcoef", "fitscale"];

impl GeomSpec {
    /// Applies one attribute (`name` and `class` are the caller's).
    pub fn apply(&mut self, a: &Attr) -> Result<(), MjcfError> {
        match a.name.as_str() {
            "type" => {
                self.kind = a.keyword(&[
                    ("plane", GeomType::Plane),
                    ("sphere", GeomType::Sphere),
                    ("box", GeomType::Box),
                    ("capsule", GeomType::Capsule),
                    ("cylinder", GeomType::Cylinder),
                    ("ellipsoid", GeomType::Ellipsoid),
                    ("mesh", GeomType::Unsupported),
                    ("sdf", GeomType::Unsupported),
                    ("hfield", GeomType::Unsupported),
                ])?;
                self.type_attr = Some(a.clone());
            }
            "mesh" => self.mesh = Some(a.clone()),
            "hfield" => self.hfield = Some(a.clone()),
            "shellinertia" => {
                if a.boolean()? {
                    return Err(a.feature("shell inertia"));
                }
            }
            "priority" => self.priority = a.integer()?,
            "margin" => self.margin = a.non_negative()?,
            "gap" => self.gap = a.non_negative()?,
            "solref" => a.partial(&mut self.solref)?,
            "solimp" => a.partial(&mut self.solimp)?,
            "solmix" => self.solmix = a.non_negative()?,
            "rgba" => a.partial(&mut self.rgba)?,
            "material" => self.material = a.value.trim().to_string(),
            "group" => self.group = a.integer()?,
            "user" => self.user = a.numbers()?,
            "size" => {
                a.partial(&mut self.size)?;
                self.size_attr = Some(a.clone());
            }
            "fromto" => self.fromto = Some((a.exact()?, a.clone())),
            "pos" => self.pos = a.exact()?,
            n if orientation::ORIENTATION_ATTRS.contains(&n) => {
                let o = match n {
                    "quat" => Orientation::Quat(a.exact()?),
                    "axisangle" => Orientation::AxisAngle(a.exact()?),
                    "euler" => Orientation::Euler(a.exact()?),
                    "xyaxes" => Orientation::XyAxes(a.exact()?),
                    _ => Orientation::ZAxis(a.exact()?),
                };
                self.orient = Some((o, a.clone()));
            }
            "friction" => {
                let mut f = self.friction;
                a.partial(&mut f)?;
                if f.iter().any(|x| *x < 0.0) {
                    return Err(a.bad("friction must not be negative"));
                }
                self.friction = f;
            }
            "density" => self.density = a.non_negative()?,
            "mass" => self.mass = Some(a.non_negative()?),
            "contype" => self.contype = a.unsigned()?,
            "conaffinity" => self.conaffinity = a.unsigned()?,
            "condim" => {
                let c = a.unsigned()?;
                if ![1, 3, 4, 6].contains(&c) {
                    return Err(a.bad("condim must be 1, 3, 4 or 6"));
                }
                self.condim = c;
            }
            n if GEOM_IGNORED.contains(&n) => {}
            _ => return Err(a.unsupported()),
        }
        Ok(())
    }

    /// Shape, frame, mass and inertia, as `mjCGeom::Compile` computes them.
    pub fn finish(&self, el: &Element, conv: AngleConvention) -> Result<GeomData, MjcfError> {
        // Meshes and height fields (a geom naming a mesh is a mesh geom, or is fitted
        // to one: both need the mesh).
        if let Some(a) = &self.mesh {
            return Err(a.feature("mesh geom"));
        }
        if let Some(a) = &self.hfield {
            return Err(a.feature("hfield geom"));
        }
        if self.kind == GeomType::Unsupported {
            let t = self.type_attr.as_ref().map_or("", |a| a.value.trim());
            return Err(el.feature(format!("{t} geom")));
        }
        let mut size = self.size;
        let (pos, quat) = if let Some((ft, at)) = &self.fromto {
            if !matches!(
                self.kind,
                GeomType::Capsule | GeomType::Box | GeomType::Cylinder | GeomType::Ellipsoid
            ) {
                return Err(at.bad("fromto requires capsule, cylinder, box or ellipsoid"));
            }
            if self.pos != [0.0; 3] {
                return Err(el.invalid("both pos and fromto defined in geom"));
            }
            // MuJoCo's direction is from - to.
            let mut vec = [ft[0] - ft[3], ft[1] - ft[4], ft[2] - ft[5]];
            let len = normalize3(&mut vec);
            size[1] = len / 2.0;
            if size[1] < math::EPS {
                return Err(at.bad("fromto points too close"));
            }
            if matches!(self.kind, GeomType::Box | GeomType::Ellipsoid) {
                size[2] = size[1];
                size[1] = size[0];
            }
            let pos = [
                (ft[0] + ft[3]) / 2.0,
                (ft[1] + ft[4]) / 2.0,
                (ft[2] + ft[5]) / 2.0,
            ];
            (pos, math::z_to_quat(vec))
        } else {
            let quat = match &self.orient {
                Some((o, at)) => orientation::resolve(o, at, conv)?,
                None => math::QUAT_ID,
            };
            (self.pos, quat)
        };
        let needed = match self.kind {
            GeomType::Plane | GeomType::Unsupported => 0,
            GeomType::Sphere => 1,
            GeomType::Capsule | GeomType::Cylinder => 2,
            GeomType::Box | GeomType::Ellipsoid => 3,
        };
        let size_error = |i: usize| {
            let reason = format!("size {} must be positive", i + 1);
            match &self.size_attr {
                Some(a) => a.bad(reason),
                None => el.invalid(reason),
            }
        };
        if self.kind == GeomType::Plane && !(size[2] > 0.0) {
            return Err(size_error(2));
        }
        for (i, s) in size.iter().enumerate().take(needed) {
            if !(*s > 0.0) {
                return Err(size_error(i));
            }
        }
        let primitive = match self.kind {
            GeomType::Plane | GeomType::Unsupported => Primitive::Plane { size },
            GeomType::Sphere => Primitive::Sphere { radius: size[0] },
            GeomType::Box => Primitive::Box { half: size },
            GeomType::Capsule => Primitive::Capsule {
                radius: size[0],
                half_length: size[1],
            },
            GeomType::Cylinder => Primitive::Cylinder {
                radius: size[0],
                half_length: size[1],
            },
            GeomType::Ellipsoid => Primitive::Ellipsoid { radii: size },
        };
        let shape = match primitive {
            Primitive::Plane { .. } => Shape::Plane,
            Primitive::Sphere { radius } => Shape::Sphere { radius },
            Primitive::Box { half } => Shape::Box { half },
            Primitive::Capsule {
                radius,
                half_length,
            } => Shape::Capsule {
                radius,
                half_length,
            },
            // Bounding boxes (documented on `Geom::shape`).
            Primitive::Cylinder {
                radius,
                half_length,
            } => Shape::Box {
                half: [radius, radius, half_length],
            },
            Primitive::Ellipsoid { radii } => Shape::Box { half: radii },
        };
        let volume = inertia::volume(&primitive);
        let mut density = self.density;
        let mut mass = 0.0;
        match self.mass {
            Some(0.0) => density = 0.0,
            Some(m) => {
                if volume > math::EPS {
                    density = m / volume;
                    mass = m;
                }
            }
            None => mass = density * volume,
        }
        if !mass.is_finite() || !density.is_finite() {
            return Err(el.invalid("geom mass or density overflows"));
        }
        let inertia = inertia::principal(&primitive, mass);
        if inertia.iter().any(|x| !x.is_finite()) {
            return Err(el.invalid("geom inertia overflows"));
        }
        Ok(GeomData {
            shape,
            primitive,
            condim: self.condim,
            priority: self.priority,
            margin: self.margin,
            gap: self.gap,
            solref: self.solref,
            solimp: self.solimp,
            solmix: self.solmix,
            rgba: self.rgba,
            material: self.material.clone(),
            group: self.group,
            user: self.user.clone(),
            pos,
            quat,
            friction: self.friction,
            density,
            contype: self.contype,
            conaffinity: self.conaffinity,
            mass,
            inertia,
        })
    }
}
