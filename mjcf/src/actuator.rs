//! Actuators: the shortcuts `motor`, `position`, `velocity` and `general`, applied to
//! one `mjsActuator`-like spec in order (class defaults first, ancestors first, then the
//! element), as MuJoCo's `OneActuator` and `mjs_setTo*` do, then compiled to the
//! general form `force = gain·ctrl + bias0 + bias1·length + bias2·velocity`.

use std::collections::BTreeMap;

use crate::attrs::{Attr, Element};
use crate::error::MjcfError;
use crate::model::{Actuator, ActuatorKind, Model, Transmission};
use crate::orientation::AngleConvention;

/// MuJoCo's `mjNGAIN`, `mjNBIAS`, `mjNDYN`.
const NPRM: usize = 10;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum GainType {
    Fixed,
    Other,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BiasType {
    None,
    Affine,
    Other,
}

/// An actuator's attributes after defaults (MuJoCo `mjs_defaultActuator`).
#[derive(Clone, Debug)]
pub(crate) struct ActuatorSpec {
    kind: ActuatorKind,
    gaintype: (GainType, Option<Attr>),
    biastype: (BiasType, Option<Attr>),
    /// `dyntype` other than `none` (the attribute that set it).
    dyntype: Option<Attr>,
    gainprm: [f64; NPRM],
    biasprm: [f64; NPRM],
    gear: [f64; 6],
    ctrllimited: Option<bool>,
    forcelimited: Option<bool>,
    ctrlrange: [f64; 2],
    forcerange: [f64; 2],
    inheritrange: f64,
    joint: Option<Attr>,
    tendon: Option<Attr>,
}

impl Default for ActuatorSpec {
    fn default() -> Self {
        let mut gainprm = [0.0; NPRM];
        gainprm[0] = 1.0;
        ActuatorSpec {
            kind: ActuatorKind::General,
            gaintype: (GainType::Fixed, None),
            biastype: (BiasType::None, None),
            dyntype: None,
            gainprm,
            biasprm: [0.0; NPRM],
            gear: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ctrllimited: None,
            forcelimited: None,
            ctrlrange: [0.0; 2],
            forcerange: [0.0; 2],
            inheritrange: 0.0,
            joint: None,
            tendon: None,
        }
    }
}

/// Attributes of every actuator element that do not change the general form here.
const IGNORED: [&str; 7] = [
    "group",
    "user",
    "lengthrange",
    "actearly",
    "velrange",
    "ffrange",
    "interp",
];

impl ActuatorSpec {
    /// Applies one shortcut element (`kind` = its tag) with its attributes (`name` and
    /// `class` are the caller's).
    pub fn apply(
        &mut self,
        kind: &str,
        attrs: &[Attr],
        _conv: AngleConvention,
        _autolimits: bool,
    ) -> Result<(), MjcfError> {
        let general = kind == "general";
        let get = |n: &str| attrs.iter().find(|a| a.name == n);
        // Shared attributes (MuJoCo's kGeneralAttrs table, read first).
        for a in attrs {
            match a.name.as_str() {
                "ctrlrange" => self.ctrlrange = a.exact()?,
                "forcerange" => self.forcerange = a.exact()?,
                "ctrllimited" => self.ctrllimited = a.tristate()?,
                "forcelimited" => self.forcelimited = a.tristate()?,
                "gear" => a.partial(&mut self.gear)?,
                "joint" => {
                    self.joint = Some(a.clone());
                    self.tendon = None;
                }
                "tendon" => {
                    self.tendon = Some(a.clone());
                    self.joint = None;
                }
                "site" | "body" | "cranksite" | "jointinparent" | "refsite" | "slidersite"
                | "cranklength" => {
                    return Err(a.feature(format!("actuator transmission `{}`", a.name)))
                }
                "actlimited" | "actrange" | "actdim" => {
                    return Err(a.feature("actuator activation"));
                }
                "delay" | "nsample" => {
                    if a.scalar()? != 0.0 {
                        return Err(a.feature("actuator delay"));
                    }
                }
                "armature" => {
                    if a.scalar()? != 0.0 {
                        return Err(a.feature("actuator armature"));
                    }
                }
                "damping" => {
                    if a.numbers()?.iter().any(|x| *x != 0.0) {
                        return Err(a.feature("actuator damping"));
                    }
                }
                "gainprm" | "biasprm" | "dynprm" | "gaintype" | "biastype" | "dyntype"
                    if !general =>
                {
                    return Err(a.unsupported())
                }
                "gainprm" => a.partial(&mut self.gainprm)?,
                "biasprm" => a.partial(&mut self.biasprm)?,
                "dynprm" => {
                    a.partial(&mut [0.0; NPRM])?;
                }
                "gaintype" => {
                    let t = a.keyword(&[
                        ("fixed", GainType::Fixed),
                        ("affine", GainType::Other),
                        ("muscle", GainType::Other),
                        ("user", GainType::Other),
                    ])?;
                    self.gaintype = (t, Some(a.clone()));
                }
                "biastype" => {
                    let t = a.keyword(&[
                        ("none", BiasType::None),
                        ("affine", BiasType::Affine),
                        ("muscle", BiasType::Other),
                        ("user", BiasType::Other),
                    ])?;
                    self.biastype = (t, Some(a.clone()));
                }
                "dyntype" => {
                    let none = a.keyword(&[
                        ("none", true),
                        ("integrator", false),
                        ("filter", false),
                        ("filterexact", false),
                        ("muscle", false),
                        ("user", false),
                    ])?;
                    self.dyntype = if none { None } else { Some(a.clone()) };
                }
                "kp" | "kv" if kind == "position" => {}
                "kv" if kind == "velocity" => {}
                "inheritrange" if kind == "position" => {}
                "timeconst" | "dampratio" if kind == "position" => {}
                n if IGNORED.contains(&n) => {}
                _ => return Err(a.unsupported()),
            }
        }
        match kind {
            "motor" => {
                self.kind = ActuatorKind::Motor;
                self.gainprm[0] = 1.0;
                self.dyntype = None;
                self.gaintype = (GainType::Fixed, None);
                self.biastype = (BiasType::None, None);
            }
            "position" => {
                self.kind = ActuatorKind::Position;
                let kp = match get("kp") {
                    Some(a) => a.scalar()?,
                    None => self.gainprm[0],
                };
                if let Some(a) = get("dampratio") {
                    return Err(a.feature("position dampratio"));
                }
                if let Some(a) = get("timeconst") {
                    let t = a.non_negative()?;
                    if t != 0.0 {
                        return Err(a.feature("actuator dynamics (timeconst)"));
                    }
                    self.dyntype = None;
                }
                self.gainprm[0] = kp;
                self.biasprm[1] = -kp;
                if let Some(a) = get("kv") {
                    let kv = a.non_negative()?;
                    self.biasprm[2] = -kv;
                }
                if let Some(a) = get("inheritrange") {
                    self.inheritrange = a.non_negative()?;
                }
                self.gaintype = (GainType::Fixed, None);
                self.biastype = (BiasType::Affine, None);
            }
            "velocity" => {
                self.kind = ActuatorKind::Velocity;
                let kv = match get("kv") {
                    Some(a) => a.scalar()?,
                    None => self.gainprm[0],
                };
                self.biasprm = [0.0; NPRM];
                self.gainprm[0] = kv;
                self.biasprm[2] = -kv;
                self.dyntype = None;
                self.gaintype = (GainType::Fixed, None);
                self.biastype = (BiasType::Affine, None);
            }
            _ => self.kind = ActuatorKind::General,
        }
        Ok(())
    }

    /// Compiles (`mjCActuator::Compile`): transmission, gain and bias types, limits.
    pub fn finish(
        &self,
        el: &Element,
        name: String,
        joints: &BTreeMap<String, usize>,
        tendons: &BTreeMap<String, usize>,
        model: &Model,
        autolimits: bool,
    ) -> Result<Actuator, MjcfError> {
        if let Some(a) = &self.dyntype {
            return Err(a.feature(format!("actuator dyntype \"{}\"", a.value.trim())));
        }
        if self.gaintype.0 != GainType::Fixed {
            return Err(match &self.gaintype.1 {
                Some(a) => a.feature(format!("actuator gaintype \"{}\"", a.value.trim())),
                None => el.feature("actuator gaintype"),
            });
        }
        if self.biastype.0 == BiasType::Other {
            return Err(match &self.biastype.1 {
                Some(a) => a.feature(format!("actuator biastype \"{}\"", a.value.trim())),
                None => el.feature("actuator biastype"),
            });
        }
        let (target, target_range) = match (&self.joint, &self.tendon) {
            (Some(a), _) => {
                let j = joints
                    .get(a.value.trim())
                    .copied()
                    .ok_or_else(|| a.unknown("joint"))?;
                let joint = &model.joints[j];
                let range = joint.limited.then_some(joint.range);
                (Transmission::Joint(j), range)
            }
            (None, Some(a)) => {
                let t = tendons
                    .get(a.value.trim())
                    .copied()
                    .ok_or_else(|| a.unknown("tendon"))?;
                let tendon = &model.tendons[t];
                (
                    Transmission::Tendon(t),
                    tendon.limited.then_some(tendon.range),
                )
            }
            (None, None) => return Err(el.invalid("actuator needs a joint or tendon target")),
        };
        let mut ctrlrange = self.ctrlrange;
        if self.inheritrange > 0.0 {
            if ctrlrange != [0.0; 2] {
                return Err(el.invalid("ctrlrange and inheritrange cannot both be defined"));
            }
            let r = target_range.unwrap_or([0.0; 2]);
            if r[0] == r[1] {
                return Err(el.invalid("inheritrange used but the target has no range"));
            }
            let mean = 0.5 * (r[1] + r[0]);
            let radius = 0.5 * (r[1] - r[0]) * self.inheritrange;
            ctrlrange = [mean - radius, mean + radius];
        }
        let resolve = |limited: Option<bool>, range: [f64; 2], what: &str| {
            let hasrange = !(range[0] == 0.0 && range[1] == 0.0);
            let on = match limited {
                Some(l) => l,
                None => {
                    if !autolimits && hasrange {
                        return Err(el.invalid(format!(
                            "actuator has `{what}range` but not `{what}limited`: set compiler autolimits=\"true\" or give `{what}limited`"
                        )));
                    }
                    range[0] < range[1]
                }
            };
            if on && range[0] >= range[1] {
                return Err(el.invalid(format!("invalid {what} range for actuator")));
            }
            Ok(on)
        };
        let forcelimited = resolve(self.forcelimited, self.forcerange, "force")?;
        let ctrllimited = resolve(self.ctrllimited, ctrlrange, "ctrl")?;
        let bias = match self.biastype.0 {
            BiasType::Affine => [self.biasprm[0], self.biasprm[1], self.biasprm[2]],
            _ => [0.0; 3],
        };
        Ok(Actuator {
            name,
            kind: self.kind,
            target,
            gear: self.gear,
            gain: self.gainprm[0],
            bias,
            ctrllimited,
            ctrlrange,
            forcelimited,
            forcerange: self.forcerange,
            line: el.line,
        })
    }
}
