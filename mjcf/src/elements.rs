//! `joint` and `geom` attribute sets (shared by elements and `default` classes), with
//! MuJoCo's defaults, and their compilation into model data.

use crate::attrs::{Attr, Element};
use crate::error::MjcfError;
use crate::inertia;
use crate::math::{self, normalize3, Q, V3};
use crate::model::{JointKind, Shape};
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
        }
    }
}

/// The compiled joint (without name and indices).
pub(crate) struct JointData {
    pub kind: JointKind,
    pub pos: V3,
    pub axis: V3,
    pub damping: f64,
}

/// Attributes accepted and ignored on `joint` (visual only).
const JOINT_IGNORED: [&str; 1] = ["group"];

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
            "armature" | "stiffness" | "frictionloss" | "ref" | "springref" => a.zero_only()?,
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

    /// Checks and normalises.
    pub fn finish(&self, el: &Element) -> Result<JointData, MjcfError> {
        // Joint limits change the dynamics: only unlimited joints are in the subset.
        match &self.limited {
            (Limited::True, Some(a)) => return Err(a.unsupported()),
            (Limited::Auto, _) => {
                if let Some((r, a)) = &self.range {
                    if r[0] < r[1] {
                        return Err(a.unsupported());
                    }
                }
            }
            _ => {}
        }
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
        }
    }
}

/// The compiled geom (without name and owner).
pub(crate) struct GeomData {
    pub shape: Shape,
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

/// Attributes accepted and ignored on `geom` (visual only).
/// Visual attributes, and `solref` / `solimp` / `margin` / `gap`, which only set how soft
/// MuJoCo's contact is (this library's contact is hard, with its own speculative margin).
const GEOM_IGNORED: [&str; 7] = [
    "rgba", "material", "group", "solref", "solimp", "margin", "gap",
];

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
                ])?
            }
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
                if a.unsigned()? != 3 {
                    return Err(a.unsupported());
                }
            }
            n if GEOM_IGNORED.contains(&n) => {}
            _ => return Err(a.unsupported()),
        }
        Ok(())
    }

    /// Shape, frame, mass and inertia, as `mjCGeom::Compile` computes them.
    pub fn finish(&self, el: &Element, conv: AngleConvention) -> Result<GeomData, MjcfError> {
        let mut size = self.size;
        let (pos, quat) = if let Some((ft, at)) = &self.fromto {
            if !matches!(self.kind, GeomType::Capsule | GeomType::Box) {
                return Err(at.bad("fromto requires a capsule or box geom"));
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
            if self.kind == GeomType::Box {
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
            GeomType::Plane => 0,
            GeomType::Sphere => 1,
            GeomType::Capsule => 2,
            GeomType::Box => 3,
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
        let shape = match self.kind {
            GeomType::Plane => Shape::Plane,
            GeomType::Sphere => Shape::Sphere { radius: size[0] },
            GeomType::Box => Shape::Box { half: size },
            GeomType::Capsule => Shape::Capsule {
                radius: size[0],
                half_length: size[1],
            },
        };
        let volume = inertia::volume(&shape);
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
        let inertia = inertia::principal(&shape, mass);
        if inertia.iter().any(|x| !x.is_finite()) {
            return Err(el.invalid("geom inertia overflows"));
        }
        Ok(GeomData {
            shape,
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
