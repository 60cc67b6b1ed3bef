//! The document walk: sections in MuJoCo's order of effect (`compiler`, `option`,
//! `default`, `asset`, `worldbody`, `contact`, `tendon`, `equality`, `actuator`,
//! `sensor`, `keyframe`, `custom`), bodies depth-first in document order without
//! recursion.

use std::collections::BTreeMap;
use std::path::Path;

use crate::actuator::ActuatorSpec;
use crate::attrs::{Attr, Element};
use crate::defaults::{Class, Defaults, ACTUATORS};
use crate::elements::{GeomSpec, JointSpec, SOFTNESS_ATTRS};
use crate::error::MjcfError;
use crate::inertia::{self, GeomMass};
use crate::math::{self, M3, Q, V3};
use crate::model::{
    Assets, Body, Connect, ContactExclude, ContactPair, Custom, Geom, Joint, JointEquality,
    JointKind, Keyframe, Marker, Model, Options, Sensor, Site, Tendon, TendonEquality, Weld,
};
use crate::orientation::{self, AngleConvention};
use crate::xml::{self, XNode};

/// `compiler inertiafromgeom`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FromGeom {
    False,
    True,
    Auto,
}

/// Top-level sections accepted and not stored: rendering settings, memory sizes,
/// statistics used for visualisation.
const IGNORED_SECTIONS: [&str; 3] = ["size", "visual", "statistic"];
/// Every top-level section the loader reads.
const SECTIONS: [&str; 13] = [
    "compiler",
    "option",
    "default",
    "asset",
    "worldbody",
    "contact",
    "tendon",
    "equality",
    "actuator",
    "sensor",
    "keyframe",
    "custom",
    "extension",
];
/// `option` attributes that only steer MuJoCo's solver or collision detection,
/// accepted and ignored.
const SOLVER_ONLY_OPTIONS: [&str; 16] = [
    "jacobian",
    "tolerance",
    "ls_iterations",
    "ls_tolerance",
    "noslip_tolerance",
    "ccd_iterations",
    "ccd_tolerance",
    "sdf_iterations",
    "sdf_initpoints",
    "apirate",
    "actuatorgroupdisable",
    "o_margin",
    "o_solref",
    "o_solimp",
    "o_friction",
    "sleep_tolerance",
];

/// Parses and compiles a document; `dir` is the base directory for `include`, `main`
/// the main file's path when there is one.
pub(crate) fn load(
    text: &str,
    dir: Option<&Path>,
    main: Option<&Path>,
) -> Result<Model, MjcfError> {
    let root = xml::read(text, dir, main)?;
    if root.name() != "mujoco" {
        return Err(root.el.unsupported());
    }
    root.el.only(&["model"])?;
    let mut loader = Loader::new();
    for s in root.elements() {
        let name = s.name();
        if name == "extension" {
            return Err(s.el.feature("extension (plugins)"));
        }
        if !SECTIONS.contains(&name) && !IGNORED_SECTIONS.contains(&name) {
            return Err(s.el.unsupported());
        }
    }
    let of = |name: &'static str| root.elements().filter(move |n| n.name() == name);
    for n in of("compiler") {
        loader.compiler(n)?;
    }
    for n in of("option") {
        loader.option(n)?;
    }
    for n in of("default") {
        let (conv, autolimits) = (loader.conv, loader.autolimits);
        let check = |c: &Class| -> Result<(), MjcfError> {
            let mut j = JointSpec::default();
            for a in &c.joint {
                j.apply(a)?;
            }
            let mut g = GeomSpec::default();
            for a in &c.geom {
                g.apply(a)?;
            }
            let mut act = ActuatorSpec::default();
            for (kind, attrs) in &c.actuator {
                act.apply(kind, attrs, conv, autolimits)?;
            }
            Ok(())
        };
        loader.defaults.parse(n, &check)?;
    }
    for n in of("asset") {
        loader.asset(n)?;
    }
    for n in of("worldbody") {
        loader.worldbody(n)?;
    }
    loader.check_moving_masses()?;
    loader.total_mass();
    crate::springdamper::apply(&mut loader.model, &loader.springdampers)?;
    for n in of("contact") {
        loader.contact(n)?;
    }
    for n in of("tendon") {
        loader.tendon(n)?;
    }
    for n in of("equality") {
        loader.equality(n)?;
    }
    for n in of("actuator") {
        loader.actuators(n)?;
    }
    for n in of("sensor") {
        loader.sensors(n)?;
    }
    for n in of("keyframe") {
        loader.keyframes(n)?;
    }
    for n in of("custom") {
        loader.custom(n)?;
    }
    if loader.gravity_disabled {
        loader.model.gravity = [0.0; 3];
    }
    let mut soft = Vec::new();
    collect_softness(&root, &mut soft);
    if !soft.is_empty() {
        loader.model.warnings.push(format!(
            "not modelled: hard constraints ({}) are used instead of MuJoCo's soft ones",
            soft.join("/")
        ));
    }
    Ok(loader.model)
}

/// Names of the soft-constraint attributes used anywhere in the tree (iteratively).
fn collect_softness(root: &XNode, out: &mut Vec<&'static str>) {
    let mut stack = vec![root];
    while let Some(n) = stack.pop() {
        for a in &n.el.attrs {
            if let Some(s) = SOFTNESS_ATTRS.iter().find(|s| **s == a.name) {
                if !out.contains(s) {
                    out.push(s);
                }
            }
        }
        stack.extend(n.elements());
    }
    out.sort_by_key(|s| SOFTNESS_ATTRS.iter().position(|x| x == s));
}

/// What the walk keeps per body beyond [`Body`].
struct BodyExtra {
    has_joint: bool,
    children: Vec<usize>,
    /// Mass and principal inertias are all `≥ mjMINVAL`.
    massive: bool,
    /// The `<body>` element (for errors found later).
    el: Element,
}

/// A body waiting on the walk's stack.
struct Pending<'a> {
    node: &'a XNode,
    parent: Option<usize>,
    class: usize,
    pos: V3,
    quat: Q,
    parent_static: bool,
}

struct Loader {
    conv: AngleConvention,
    from_geom: FromGeom,
    autolimits: bool,
    boundmass: f64,
    boundinertia: f64,
    settotalmass: f64,
    inertia_groups: [i32; 2],
    gravity_disabled: bool,
    defaults: Defaults,
    model: Model,
    extra: Vec<BodyExtra>,
    body_names: BTreeMap<String, usize>,
    joint_names: BTreeMap<String, usize>,
    geom_names: BTreeMap<String, usize>,
    site_names: BTreeMap<String, usize>,
    tendon_names: BTreeMap<String, usize>,
    actuator_names: BTreeMap<String, usize>,
    equality_names: BTreeMap<String, usize>,
    /// Joints with `springdamper` on: `(joint, [timeconst, dampratio])`.
    springdampers: Vec<(usize, [f64; 2])>,
    key_names: BTreeMap<String, usize>,
    nq: usize,
    nv: usize,
}

/// Registers an explicit name; a repeat is an error, as in MuJoCo.
fn register(
    names: &mut BTreeMap<String, usize>,
    el: &Element,
    index: usize,
) -> Result<(), MjcfError> {
    if let Some(a) = el.get("name") {
        let name = a.value.trim().to_string();
        if names.contains_key(&name) {
            return Err(el.invalid(format!("repeated name \"{name}\"")));
        }
        names.insert(name, index);
    }
    Ok(())
}

fn name_or(el: &Element, prefix: &str, index: usize) -> String {
    match el.get("name") {
        Some(a) => a.value.trim().to_string(),
        None => format!("{prefix}{index}"),
    }
}

fn name_of(el: &Element) -> String {
    el.get("name")
        .map_or_else(String::new, |a| a.value.trim().to_string())
}

/// Element children of a node that must have none.
fn no_children(node: &XNode) -> Result<(), MjcfError> {
    match node.elements().next() {
        Some(c) => Err(c.el.unsupported()),
        None => Ok(()),
    }
}

/// Looks a name up in `names` (`kind` for the error).
fn lookup(
    names: &BTreeMap<String, usize>,
    a: &Attr,
    kind: &'static str,
) -> Result<usize, MjcfError> {
    names
        .get(a.value.trim())
        .copied()
        .ok_or_else(|| a.unknown(kind))
}

impl Loader {
    fn new() -> Self {
        Loader {
            conv: AngleConvention::default(),
            from_geom: FromGeom::Auto,
            autolimits: true,
            boundmass: 0.0,
            boundinertia: 0.0,
            settotalmass: -1.0,
            inertia_groups: [0, 5],
            gravity_disabled: false,
            defaults: Defaults::new(),
            model: Model {
                timestep: 0.002,
                gravity: [0.0, 0.0, -9.81],
                integrator: "Euler".to_string(),
                contact_disabled: false,
                bodies: Vec::new(),
                joints: Vec::new(),
                geoms: Vec::new(),
                connects: Vec::new(),
                keyframes: Vec::new(),
                actuators: Vec::new(),
                tendons: Vec::new(),
                joint_equalities: Vec::new(),
                tendon_equalities: Vec::new(),
                welds: Vec::new(),
                contact_excludes: Vec::new(),
                contact_pairs: Vec::new(),
                sites: Vec::new(),
                cameras: Vec::new(),
                lights: Vec::new(),
                sensors: Vec::new(),
                custom: Vec::new(),
                assets: Assets::default(),
                options: Options::default(),
                warnings: Vec::new(),
            },
            extra: Vec::new(),
            body_names: BTreeMap::new(),
            joint_names: BTreeMap::new(),
            geom_names: BTreeMap::new(),
            site_names: BTreeMap::new(),
            tendon_names: BTreeMap::new(),
            actuator_names: BTreeMap::new(),
            equality_names: BTreeMap::new(),
            springdampers: Vec::new(),
            key_names: BTreeMap::new(),
            nq: 0,
            nv: 0,
        }
    }

    /// A body attribute naming a body (`world` or absent: `None`).
    fn body_ref(&self, el: &Element, attr: &str) -> Result<Option<usize>, MjcfError> {
        match el.get(attr) {
            None => Ok(None),
            Some(a) if a.value.trim() == "world" => Ok(None),
            Some(a) => match self.body_names.get(a.value.trim()) {
                Some(i) => Ok(Some(*i)),
                None => Err(el.wrap(MjcfError::UnknownBody {
                    element: el.name.clone(),
                    name: a.value.clone(),
                    line: a.line,
                })),
            },
        }
    }

    fn compiler(&mut self, node: &XNode) -> Result<(), MjcfError> {
        let el = &node.el;
        no_children(node)?;
        for a in &el.attrs {
            match a.name.as_str() {
                "angle" => self.conv.degree = a.keyword(&[("degree", true), ("radian", false)])?,
                "inertiafromgeom" => {
                    self.from_geom = a.keyword(&[
                        ("false", FromGeom::False),
                        ("true", FromGeom::True),
                        ("auto", FromGeom::Auto),
                    ])?
                }
                "eulerseq" => {
                    let b = a.value.trim().as_bytes();
                    if b.len() != 3 || !b.iter().all(|c| b"xyzXYZ".contains(c)) {
                        return Err(a.bad("eulerseq must be three of x, y, z, X, Y, Z"));
                    }
                    self.conv.seq = [b[0], b[1], b[2]];
                }
                "autolimits" => self.autolimits = a.boolean()?,
                "boundmass" => self.boundmass = a.non_negative()?,
                "boundinertia" => self.boundinertia = a.non_negative()?,
                "settotalmass" => self.settotalmass = a.scalar()?,
                "inertiagrouprange" => {
                    let [lo, hi] = a.exact::<2>()?;
                    if lo.fract() != 0.0 || hi.fract() != 0.0 {
                        return Err(a.bad("must be two integers"));
                    }
                    self.inertia_groups = [lo as i32, hi as i32];
                }
                // MuJoCo 4 knows only local coordinates.
                "coordinate" => {
                    if a.keyword(&[("local", true), ("global", false)])? {
                    } else {
                        return Err(a.feature("coordinate=\"global\" (removed from MuJoCo)"));
                    }
                }
                // These change bodies or frames in ways the data does not follow.
                "fusestatic" | "alignfree" | "balanceinertia" => {
                    if a.boolean()? {
                        return Err(a.feature(format!("compiler {}", a.name)));
                    }
                }
                "discardvisual" | "strippath" | "usethread" | "saveinertial"
                | "exactmeshinertia" => {
                    a.boolean()?;
                }
                "meshdir" | "texturedir" | "assetdir" | "fitaabb" | "maxhullvert" => {}
                _ => return Err(a.unsupported()),
            }
        }
        Ok(())
    }

    fn option(&mut self, node: &XNode) -> Result<(), MjcfError> {
        let el = &node.el;
        let opts = &mut self.model.options;
        for a in &el.attrs {
            match a.name.as_str() {
                "timestep" => self.model.timestep = a.positive()?,
                "gravity" => self.model.gravity = a.exact()?,
                "integrator" => {
                    let v = a.keyword(&[
                        ("Euler", "Euler"),
                        ("RK4", "RK4"),
                        ("implicit", "implicit"),
                        ("implicitfast", "implicitfast"),
                    ])?;
                    self.model.integrator = v.to_string();
                }
                "density" => opts.density = a.non_negative()?,
                "viscosity" => opts.viscosity = a.non_negative()?,
                "wind" => opts.wind = a.exact()?,
                "magnetic" => opts.magnetic = a.exact()?,
                "cone" => {
                    opts.cone = a
                        .keyword(&[("pyramidal", "pyramidal"), ("elliptic", "elliptic")])?
                        .to_string()
                }
                "impratio" => opts.impratio = a.positive()?,
                "noslip_iterations" => opts.noslip_iterations = a.unsigned()?,
                "iterations" => opts.iterations = a.unsigned()?,
                "solver" => {
                    opts.solver = a
                        .keyword(&[("PGS", "PGS"), ("CG", "CG"), ("Newton", "Newton")])?
                        .to_string()
                }
                n if SOLVER_ONLY_OPTIONS.contains(&n) => {}
                _ => return Err(a.unsupported()),
            }
        }
        for child in node.elements() {
            let ce = &child.el;
            if ce.name != "flag" {
                return Err(ce.unsupported());
            }
            no_children(child)?;
            for a in &ce.attrs {
                let enabled = a.keyword(&[("enable", true), ("disable", false)])?;
                match a.name.as_str() {
                    "contact" => self.model.contact_disabled = !enabled,
                    // Every constraint off, contacts included.
                    "constraint" if !enabled => self.model.contact_disabled = true,
                    "gravity" => self.gravity_disabled = !enabled,
                    _ => {}
                }
                self.model.options.flags.push((a.name.clone(), enabled));
            }
        }
        Ok(())
    }

    /// Asset names; the assets themselves are not loaded.
    fn asset(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        for child in node.elements() {
            let el = &child.el;
            let name = name_of(el);
            let assets = &mut self.model.assets;
            match el.name.as_str() {
                "texture" => {
                    if !name.is_empty() {
                        assets.textures.push(name)
                    }
                }
                "material" => assets.materials.push(name),
                "mesh" => {
                    let n = if name.is_empty() {
                        el.get("file").map_or_else(String::new, |f| {
                            let p = Path::new(f.value.trim());
                            p.file_stem()
                                .map(|s| s.to_string_lossy().into_owned())
                                .unwrap_or_default()
                        })
                    } else {
                        name
                    };
                    assets.meshes.push(n)
                }
                "hfield" => assets.hfields.push(name),
                "skin" => assets.skins.push(name),
                _ => return Err(el.unsupported()),
            }
        }
        Ok(())
    }

    fn worldbody(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        let mut stack = Vec::new();
        let mut bodies = Vec::new();
        for child in node.elements() {
            let ce = &child.el;
            match ce.name.as_str() {
                "body" => bodies.push(child),
                "geom" => {
                    self.geom(child, None, 0)?;
                }
                "site" | "camera" | "light" => self.marker(child, None)?,
                "frame" => return Err(ce.feature("frame")),
                _ => return Err(ce.unsupported()),
            }
        }
        for child in bodies.into_iter().rev() {
            stack.push(Pending {
                node: child,
                parent: None,
                class: 0,
                pos: [0.0; 3],
                quat: math::QUAT_ID,
                parent_static: true,
            });
        }
        while let Some(p) = stack.pop() {
            self.body(p, &mut stack)?;
        }
        Ok(())
    }

    /// `site`, `camera`, `light`: kept as data (their defaults are not applied).
    fn marker(&mut self, node: &XNode, body: Option<usize>) -> Result<(), MjcfError> {
        let el = &node.el;
        if let Some(a) = el.get("class") {
            self.defaults.lookup(a)?;
        }
        match el.name.as_str() {
            "site" => {
                let mut size = [0.005; 3];
                if let Some(a) = el.get("size") {
                    a.partial(&mut size)?;
                }
                let pos = match el.get("pos") {
                    Some(a) => a.exact()?,
                    None => [0.0; 3],
                };
                let quat = match orientation::read(el)? {
                    Some((o, a)) => orientation::resolve(&o, &a, self.conv)?,
                    None => math::QUAT_ID,
                };
                let index = self.model.sites.len();
                register(&mut self.site_names, el, index)?;
                self.model.sites.push(Site {
                    name: name_or(el, "site", index),
                    body,
                    kind: el
                        .get("type")
                        .map_or_else(|| "sphere".to_string(), |a| a.value.trim().to_string()),
                    size,
                    pos,
                    quat,
                    line: el.line,
                });
            }
            "camera" => self.model.cameras.push(Marker {
                name: name_of(el),
                body,
                line: el.line,
            }),
            _ => self.model.lights.push(Marker {
                name: name_of(el),
                body,
                line: el.line,
            }),
        }
        Ok(())
    }

    fn class_of(&self, el: &Element, inherited: usize) -> Result<usize, MjcfError> {
        match el.get("class") {
            Some(a) => self.defaults.lookup(a),
            None => Ok(inherited),
        }
    }

    fn body<'a>(&mut self, p: Pending<'a>, stack: &mut Vec<Pending<'a>>) -> Result<(), MjcfError> {
        let el = &p.node.el;
        el.only(&[
            "name",
            "pos",
            "quat",
            "axisangle",
            "euler",
            "xyaxes",
            "zaxis",
            "childclass",
            "user",
            "mocap",
            "gravcomp",
        ])?;
        if let Some(a) = el.get("mocap") {
            if a.boolean()? {
                return Err(a.feature("mocap body"));
            }
        }
        if let Some(a) = el.get("gravcomp") {
            if a.scalar()? != 0.0 {
                return Err(a.feature("gravity compensation"));
            }
        }
        let class = match el.get("childclass") {
            Some(a) => self.defaults.lookup(a)?,
            None => p.class,
        };
        let local_pos: V3 = match el.get("pos") {
            Some(a) => a.exact()?,
            None => [0.0; 3],
        };
        let local_quat = match orientation::read(el)? {
            Some((o, a)) => orientation::resolve(&o, &a, self.conv)?,
            None => math::QUAT_ID,
        };
        let pos = math::add(p.pos, math::rotate(p.quat, local_pos));
        let quat = math::mul_quat(p.quat, local_quat);
        if pos.iter().any(|x| !x.is_finite()) {
            return Err(el.invalid("world position overflows"));
        }
        let index = self.model.bodies.len();
        if el.get("name").map(|a| a.value.trim() == "world") == Some(true) {
            return Err(el.invalid("the name \"world\" is reserved for the world body"));
        }
        register(&mut self.body_names, el, index)?;

        let mut inertials = Vec::new();
        let mut joints = Vec::new();
        let mut geoms = Vec::new();
        let mut children = Vec::new();
        let mut markers = Vec::new();
        for child in p.node.elements() {
            match child.name() {
                "inertial" => inertials.push(child),
                "joint" | "freejoint" => joints.push(child),
                "geom" => geoms.push(child),
                "body" => children.push(child),
                "site" | "camera" | "light" => markers.push(child),
                "frame" => return Err(child.el.feature("frame")),
                _ => return Err(child.el.unsupported()),
            }
        }
        if let Some(second) = inertials.get(1) {
            return Err(second.el.invalid("a body may hold one inertial"));
        }
        self.model.bodies.push(Body {
            name: name_or(el, "body", index),
            parent: p.parent,
            pos,
            quat,
            mass: 0.0,
            com: [0.0; 3],
            inertia: [[0.0; 3]; 3],
            line: el.line,
        });
        self.extra.push(BodyExtra {
            has_joint: !joints.is_empty(),
            children: Vec::new(),
            massive: false,
            el: el.clone(),
        });
        if let Some(parent) = p.parent {
            self.extra[parent].children.push(index);
        }
        let first_joint = self.model.joints.len();
        for j in &joints {
            self.joint(j, index, class, p.parent)?;
        }
        // MuJoCo: a free joint can only appear by itself.
        let body_joints = &self.model.joints[first_joint..];
        if body_joints.len() > 1 && body_joints.iter().any(|j| j.kind == JointKind::Free) {
            return Err(el.invalid("free joint can only appear by itself"));
        }
        // MuJoCo: a body has at most 6 degrees of freedom.
        let dofs: usize = body_joints
            .iter()
            .map(|j| match j.kind {
                JointKind::Hinge | JointKind::Slide => 1,
                JointKind::Ball => 3,
                JointKind::Free => 6,
            })
            .sum();
        if dofs > 6 {
            return Err(el.invalid("more than 6 dofs in body"));
        }
        for m in markers {
            self.marker(m, Some(index))?;
        }
        let is_static = p.parent_static && joints.is_empty();
        let mut masses = Vec::new();
        for g in geoms {
            let (data, is_plane, group) = self.geom(g, Some(index), class)?;
            if is_plane && !is_static {
                return Err(g.el.invalid("plane only allowed in static bodies"));
            }
            if group >= self.inertia_groups[0] && group <= self.inertia_groups[1] {
                masses.push(data);
            }
        }
        let explicit = match inertials.first() {
            Some(n) => Some(self.inertial(n)?),
            None => None,
        };
        let use_geoms = match self.from_geom {
            FromGeom::True => true,
            FromGeom::Auto => explicit.is_none(),
            FromGeom::False => false,
        };
        let from_geoms = if use_geoms {
            inertia::combine(&masses)
        } else {
            None
        };
        let (mut mass, com, mut tensor) = match (from_geoms, explicit) {
            (Some(m), _) => m,
            (None, Some(m)) => m,
            (None, None) => (0.0, [0.0; 3], [[0.0; 3]; 3]),
        };
        if !mass.is_finite() || tensor.iter().flatten().any(|x| !x.is_finite()) {
            return Err(el.invalid("mass or inertia overflows"));
        }
        // compiler boundmass / boundinertia: lower bounds on mass and principal inertias.
        mass = mass.max(self.boundmass);
        if self.boundinertia > 0.0 {
            let (e, v) = math::sym_eigen(&tensor);
            let bounded = [
                e[0].max(self.boundinertia),
                e[1].max(self.boundinertia),
                e[2].max(self.boundinertia),
            ];
            tensor = math::from_eigen(bounded, &v);
        }
        let eig = math::sym_eigenvalues(&tensor);
        let scale = eig[0].abs();
        if eig[2] < -1e-12 * scale {
            return Err(el.invalid("mass and inertia cannot be negative"));
        }
        if eig[0] > eig[1] + eig[2] + 1e-12 * scale {
            return Err(el.invalid("inertia must satisfy A + B >= C"));
        }
        let body = &mut self.model.bodies[index];
        body.mass = mass;
        body.com = com;
        body.inertia = tensor;
        self.extra[index].massive = mass >= math::MINVAL && eig.iter().all(|e| *e >= math::MINVAL);

        for child in children.into_iter().rev() {
            stack.push(Pending {
                node: child,
                parent: Some(index),
                class,
                pos,
                quat,
                parent_static: is_static,
            });
        }
        Ok(())
    }

    fn joint(
        &mut self,
        node: &XNode,
        body: usize,
        class: usize,
        parent: Option<usize>,
    ) -> Result<(), MjcfError> {
        let el = &node.el;
        no_children(node)?;
        let mut spec = JointSpec::default();
        if el.name == "freejoint" {
            // `freejoint` takes no defaults.
            el.only(&["name", "group", "align"])?;
            if let Some(a) = el.get("align") {
                if a.keyword(&[("false", false), ("auto", false), ("true", true)])? {
                    return Err(a.unsupported());
                }
            }
            spec.apply(&Attr {
                element: el.name.clone(),
                name: "type".into(),
                value: "free".into(),
                line: el.line,
                file: el.file.clone(),
            })?;
        } else {
            let class = self.class_of(el, class)?;
            for a in &self.defaults.classes[class].joint {
                spec.apply(a)?;
            }
            for a in el
                .attrs
                .iter()
                .filter(|a| a.name != "name" && a.name != "class")
            {
                spec.apply(a)?;
            }
        }
        let data = spec.finish(el, self.conv, self.autolimits)?;
        if data.kind == JointKind::Free && parent.is_some() {
            return Err(el.invalid("free joint can only be used on top level"));
        }
        let index = self.model.joints.len();
        register(&mut self.joint_names, el, index)?;
        if let Some((sd, a)) = &data.springdamper {
            if !matches!(data.kind, JointKind::Hinge | JointKind::Slide) {
                return Err(a.feature("springdamper on a ball or free joint"));
            }
            self.springdampers.push((index, *sd));
        }
        let (nq, nv) = match data.kind {
            JointKind::Hinge | JointKind::Slide => (1, 1),
            JointKind::Ball => (4, 3),
            JointKind::Free => (7, 6),
        };
        self.model.joints.push(Joint {
            name: name_or(el, "joint", index),
            kind: data.kind,
            body,
            pos: data.pos,
            axis: data.axis,
            damping: data.damping,
            limited: data.limited,
            range: data.range,
            armature: data.armature,
            stiffness: data.stiffness,
            springref: data.springref,
            frictionloss: data.frictionloss,
            reference: data.reference,
            qpos_adr: self.nq,
            dof_adr: self.nv,
            line: el.line,
        });
        self.nq += nq;
        self.nv += nv;
        Ok(())
    }

    /// Compiles a geom into the model; returns its mass properties, whether it is a
    /// plane, and its group.
    fn geom(
        &mut self,
        node: &XNode,
        body: Option<usize>,
        class: usize,
    ) -> Result<(GeomMass, bool, i32), MjcfError> {
        let el = &node.el;
        no_children(node)?;
        let class = self.class_of(el, class)?;
        let mut spec = GeomSpec::default();
        for a in &self.defaults.classes[class].geom {
            spec.apply(a)?;
        }
        orientation::read(el)?;
        for a in el
            .attrs
            .iter()
            .filter(|a| a.name != "name" && a.name != "class")
        {
            spec.apply(a)?;
        }
        let data = spec.finish(el, self.conv)?;
        let index = self.model.geoms.len();
        register(&mut self.geom_names, el, index)?;
        let is_plane = matches!(data.shape, crate::model::Shape::Plane);
        let group = data.group;
        self.model.geoms.push(Geom {
            name: name_or(el, "geom", index),
            body,
            shape: data.shape,
            primitive: data.primitive,
            mass: data.mass,
            condim: data.condim,
            priority: data.priority,
            margin: data.margin,
            gap: data.gap,
            solref: data.solref,
            solimp: data.solimp,
            solmix: data.solmix,
            rgba: data.rgba,
            material: data.material,
            group: data.group,
            user: data.user,
            pos: data.pos,
            quat: data.quat,
            friction: data.friction,
            density: data.density,
            contype: data.contype,
            conaffinity: data.conaffinity,
            line: el.line,
        });
        Ok((
            GeomMass {
                mass: data.mass,
                pos: data.pos,
                quat: data.quat,
                inertia: data.inertia,
            },
            is_plane,
            group,
        ))
    }

    /// `inertial`: mass, centre of mass and inertia tensor in the body frame.
    fn inertial(&self, node: &XNode) -> Result<(f64, V3, M3), MjcfError> {
        let el = &node.el;
        no_children(node)?;
        el.only(&[
            "pos",
            "quat",
            "axisangle",
            "euler",
            "xyaxes",
            "zaxis",
            "mass",
            "diaginertia",
            "fullinertia",
        ])?;
        let pos: V3 = el.require("pos")?.exact()?;
        let mass = el.require("mass")?.non_negative()?;
        let orient = orientation::read(el)?;
        let diag = match el.get("diaginertia") {
            Some(a) => {
                let d: V3 = a.exact()?;
                if d.iter().any(|x| *x < 0.0) {
                    return Err(a.bad("inertia must not be negative"));
                }
                Some(d)
            }
            None => None,
        };
        let tensor = match el.get("fullinertia") {
            Some(a) => {
                if orient.is_some() {
                    return Err(
                        el.invalid("fullinertia and inertial orientation cannot both be specified")
                    );
                }
                if diag.is_some() {
                    return Err(
                        el.invalid("fullinertia and diagonal inertia cannot both be specified")
                    );
                }
                let f: [f64; 6] = a.exact()?;
                let m = [[f[0], f[3], f[4]], [f[3], f[1], f[5]], [f[4], f[5], f[2]]];
                if math::sym_eigenvalues(&m)[2] < math::EPS {
                    return Err(a.bad("inertia must have positive eigenvalues"));
                }
                m
            }
            None => {
                let q = match orient {
                    Some((o, a)) => orientation::resolve(&o, &a, self.conv)?,
                    None => math::QUAT_ID,
                };
                math::rotate_diag(q, diag.unwrap_or([0.0; 3]))
            }
        };
        Ok((mass, pos, tensor))
    }

    /// MuJoCo: a body with a joint needs mass and inertia `≥ mjMINVAL`, its own or that
    /// of a body welded to it.
    fn check_moving_masses(&self) -> Result<(), MjcfError> {
        for (i, e) in self.extra.iter().enumerate() {
            if !e.has_joint {
                continue;
            }
            let mut stack = vec![i];
            let mut ok = false;
            while let Some(b) = stack.pop() {
                if self.extra[b].massive {
                    ok = true;
                    break;
                }
                stack.extend(
                    self.extra[b]
                        .children
                        .iter()
                        .filter(|c| !self.extra[**c].has_joint),
                );
            }
            if !ok {
                let body = &self.model.bodies[i];
                return Err(e.el.invalid(format!(
                    "mass and inertia of moving body \"{}\" must be at least 1e-15",
                    body.name
                )));
            }
        }
        Ok(())
    }

    /// `compiler settotalmass` (`mj_setTotalmass`): every mass and inertia scaled so the
    /// masses sum to the value.
    fn total_mass(&mut self) {
        if !(self.settotalmass > 0.0) {
            return;
        }
        let total: f64 = self.model.bodies.iter().map(|b| b.mass).sum();
        let scale = math::MINVAL.max(self.settotalmass / math::MINVAL.max(total));
        for b in &mut self.model.bodies {
            b.mass *= scale;
            for row in &mut b.inertia {
                for x in row.iter_mut() {
                    *x *= scale;
                }
            }
        }
    }

    fn contact(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        for child in node.elements() {
            let el = &child.el;
            no_children(child)?;
            match el.name.as_str() {
                "exclude" => {
                    el.only(&["name", "body1", "body2"])?;
                    el.require("body1")?;
                    el.require("body2")?;
                    let body1 = self.body_ref(el, "body1")?;
                    let body2 = self.body_ref(el, "body2")?;
                    self.model.contact_excludes.push(ContactExclude {
                        name: name_of(el),
                        body1,
                        body2,
                        line: el.line,
                    });
                }
                "pair" => {
                    if let Some(a) = el.get("class") {
                        self.defaults.lookup(a)?;
                    }
                    let geom1 = lookup(&self.geom_names, el.require("geom1")?, "geom")?;
                    let geom2 = lookup(&self.geom_names, el.require("geom2")?, "geom")?;
                    let mut condim = 3;
                    let mut friction = [1.0, 1.0, 0.005, 0.0001, 0.0001];
                    for a in &el.attrs {
                        match a.name.as_str() {
                            "condim" => {
                                condim = a.unsigned()?;
                                if ![1, 3, 4, 6].contains(&condim) {
                                    return Err(a.bad("condim must be 1, 3, 4 or 6"));
                                }
                            }
                            "friction" => a.partial(&mut friction)?,
                            "name" | "class" | "geom1" | "geom2" | "solref" | "solreffriction"
                            | "solimp" | "margin" | "gap" => {}
                            _ => return Err(a.unsupported()),
                        }
                    }
                    self.model.contact_pairs.push(ContactPair {
                        name: name_of(el),
                        geom1,
                        geom2,
                        condim,
                        friction,
                        line: el.line,
                    });
                }
                _ => return Err(el.unsupported()),
            }
        }
        Ok(())
    }

    fn tendon(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        for child in node.elements() {
            let el = &child.el;
            let spatial = match el.name.as_str() {
                "fixed" => false,
                "spatial" => true,
                _ => return Err(el.unsupported()),
            };
            let class = self.class_of(el, 0)?;
            let mut stiffness = 0.0;
            let mut damping = 0.0;
            let mut frictionloss = 0.0;
            let mut limited: Option<bool> = None;
            let mut range = [0.0; 2];
            let mut springlength = [-1.0, -1.0];
            let attrs = self.defaults.classes[class].tendon.iter().chain(
                el.attrs
                    .iter()
                    .filter(|a| a.name != "name" && a.name != "class"),
            );
            for a in attrs {
                match a.name.as_str() {
                    "stiffness" => {
                        let mut v = [0.0; 4];
                        a.partial(&mut v)?;
                        if v[1..] != [0.0; 3] {
                            return Err(a.feature("polynomial tendon stiffness"));
                        }
                        if v[0] < 0.0 {
                            return Err(a.bad("must not be negative"));
                        }
                        stiffness = v[0];
                    }
                    "damping" => {
                        let mut v = [0.0; 4];
                        a.partial(&mut v)?;
                        if v[1..] != [0.0; 3] {
                            return Err(a.feature("polynomial tendon damping"));
                        }
                        if v[0] < 0.0 {
                            return Err(a.bad("must not be negative"));
                        }
                        damping = v[0];
                    }
                    "frictionloss" => frictionloss = a.non_negative()?,
                    "limited" => limited = a.tristate()?,
                    "range" => range = a.exact()?,
                    "springlength" => {
                        let v = a.numbers()?;
                        match v.as_slice() {
                            [x] => springlength = [*x, *x],
                            [x, y] => springlength = [*x, *y],
                            _ => return Err(a.bad("expected 1 or 2 numbers")),
                        }
                    }
                    "group" | "width" | "material" | "rgba" | "margin" | "user" | "solreflimit"
                    | "solimplimit" | "solreffriction" | "solimpfriction" | "armature"
                    | "actuatorfrclimited" | "actuatorfrcrange" => {}
                    _ => return Err(a.unsupported()),
                }
            }
            let hasrange = !(range[0] == 0.0 && range[1] == 0.0);
            let limited = match limited {
                Some(l) => l,
                None => {
                    if !self.autolimits && hasrange {
                        return Err(el.invalid(
                            "tendon has `range` but not `limited`: set compiler autolimits=\"true\" or give `limited`",
                        ));
                    }
                    range[0] < range[1]
                }
            };
            if limited && range[0] >= range[1] {
                return Err(el.invalid("range[0] should be smaller than range[1] in tendon"));
            }
            let mut joints = Vec::new();
            let mut sites = Vec::new();
            if spatial {
                sites = self.tendon_path(child)?;
            }
            for j in child.elements().filter(|_| !spatial) {
                let je = &j.el;
                if je.name != "joint" {
                    return Err(je.unsupported());
                }
                no_children(j)?;
                je.only(&["joint", "coef"])?;
                let joint = lookup(&self.joint_names, je.require("joint")?, "joint")?;
                if !matches!(
                    self.model.joints[joint].kind,
                    JointKind::Hinge | JointKind::Slide
                ) {
                    return Err(je.invalid("fixed tendon joints must be hinge or slide"));
                }
                let coef = je.require("coef")?.scalar()?;
                joints.push((joint, coef));
            }
            if joints.is_empty() && !spatial {
                return Err(el.invalid("fixed tendon needs at least one joint"));
            }
            let index = self.model.tendons.len();
            register(&mut self.tendon_names, el, index)?;
            self.model.tendons.push(Tendon {
                name: name_or(el, "tendon", index),
                joints,
                sites,
                stiffness,
                damping,
                frictionloss,
                limited,
                range,
                springlength,
                line: el.line,
            });
        }
        Ok(())
    }

    /// The path of a `tendon/spatial`: its `site` children in order (at least two).
    /// Wrapping over a `geom` and `pulley` branches are named unsupported features.
    fn tendon_path(&self, node: &XNode) -> Result<Vec<usize>, MjcfError> {
        let el = &node.el;
        let mut sites = Vec::new();
        for p in node.elements() {
            let pe = &p.el;
            match pe.name.as_str() {
                "site" => {}
                "geom" => return Err(pe.feature("spatial tendon wrapping over a geom")),
                "pulley" => return Err(pe.feature("spatial tendon pulley")),
                _ => return Err(pe.unsupported()),
            }
            no_children(p)?;
            pe.only(&["site"])?;
            sites.push(lookup(&self.site_names, pe.require("site")?, "site")?);
        }
        if sites.len() < 2 {
            return Err(el.invalid("spatial tendon needs at least two sites"));
        }
        Ok(sites)
    }

    fn equality(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        for child in node.elements() {
            let el = &child.el;
            no_children(child)?;
            let class = self.class_of(el, 0)?;
            // `active` from the class, then the element; `solref` / `solimp` tune the
            // softness of MuJoCo's equality constraints and are ignored (warning).
            let mut active = true;
            for a in self.defaults.classes[class]
                .equality
                .iter()
                .chain(el.attrs.iter())
            {
                match a.name.as_str() {
                    "active" => active = a.boolean()?,
                    "solref" | "solimp" => {
                        a.numbers()?;
                    }
                    _ => {}
                }
            }
            let common = ["name", "class", "active", "solref", "solimp"];
            let allowed = |extra: &[&'static str]| -> Vec<&'static str> {
                common.iter().chain(extra.iter()).copied().collect()
            };
            let index = self.model.connects.len()
                + self.model.joint_equalities.len()
                + self.model.tendon_equalities.len()
                + self.model.welds.len();
            register(&mut self.equality_names, el, index)?;
            let polycoef = |el: &Element| -> Result<[f64; 5], MjcfError> {
                let mut p = [0.0, 1.0, 0.0, 0.0, 0.0];
                if let Some(a) = el.get("polycoef") {
                    a.partial(&mut p)?;
                }
                Ok(p)
            };
            match el.name.as_str() {
                "connect" => {
                    el.only(&allowed(&["body1", "body2", "anchor"]))?;
                    if let Some(a) = el.get("site1") {
                        return Err(a.unsupported());
                    }
                    if !active {
                        let a = el.get("active").unwrap_or(&el.attrs[0]);
                        return Err(a.unsupported());
                    }
                    el.require("body1")?;
                    let body1 = self.body_ref(el, "body1")?;
                    let body2 = self.body_ref(el, "body2")?;
                    let anchor: V3 = el.require("anchor")?.exact()?;
                    let pose = |b: Option<usize>| match b {
                        Some(i) => (self.model.bodies[i].pos, self.model.bodies[i].quat),
                        None => ([0.0; 3], math::QUAT_ID),
                    };
                    let (p1, q1) = pose(body1);
                    let (p2, q2) = pose(body2);
                    let world = math::add(p1, math::rotate(q1, anchor));
                    let anchor2 = math::rotate(math::conj(q2), math::sub(world, p2));
                    if anchor2.iter().any(|x| !x.is_finite()) {
                        return Err(el.invalid("anchor overflows"));
                    }
                    let n = self.model.connects.len();
                    self.model.connects.push(Connect {
                        name: name_or(el, "connect", n),
                        body1,
                        body2,
                        anchor,
                        anchor2,
                        line: el.line,
                    });
                }
                "weld" => {
                    el.only(&allowed(&[
                        "body1",
                        "body2",
                        "anchor",
                        "relpose",
                        "torquescale",
                    ]))?;
                    el.require("body1")?;
                    let body1 = self.body_ref(el, "body1")?;
                    let body2 = self.body_ref(el, "body2")?;
                    let anchor = match el.get("anchor") {
                        Some(a) => a.exact()?,
                        None => [0.0; 3],
                    };
                    let relpose = match el.get("relpose") {
                        Some(a) => {
                            let r: [f64; 7] = a.exact()?;
                            // MuJoCo: a zero quaternion means "keep the default pose".
                            (r[3..] != [0.0; 4]).then_some(r)
                        }
                        None => None,
                    };
                    let torquescale = match el.get("torquescale") {
                        Some(a) => a.scalar()?,
                        None => 1.0,
                    };
                    self.model.welds.push(Weld {
                        name: name_or(el, "equality", index),
                        body1,
                        body2,
                        anchor,
                        relpose,
                        torquescale,
                        active,
                        line: el.line,
                    });
                }
                "joint" => {
                    el.only(&allowed(&["joint1", "joint2", "polycoef"]))?;
                    let joint1 = lookup(&self.joint_names, el.require("joint1")?, "joint")?;
                    let joint2 = match el.get("joint2") {
                        Some(a) => Some(lookup(&self.joint_names, a, "joint")?),
                        None => None,
                    };
                    for j in std::iter::once(joint1).chain(joint2) {
                        if !matches!(
                            self.model.joints[j].kind,
                            JointKind::Hinge | JointKind::Slide
                        ) {
                            return Err(el.invalid("only hinge and slide joints can be coupled"));
                        }
                    }
                    self.model.joint_equalities.push(JointEquality {
                        name: name_or(el, "equality", index),
                        joint1,
                        joint2,
                        polycoef: polycoef(el)?,
                        active,
                        line: el.line,
                    });
                }
                "tendon" => {
                    el.only(&allowed(&["tendon1", "tendon2", "polycoef"]))?;
                    let tendon1 = lookup(&self.tendon_names, el.require("tendon1")?, "tendon")?;
                    let tendon2 = match el.get("tendon2") {
                        Some(a) => Some(lookup(&self.tendon_names, a, "tendon")?),
                        None => None,
                    };
                    self.model.tendon_equalities.push(TendonEquality {
                        name: name_or(el, "equality", index),
                        tendon1,
                        tendon2,
                        polycoef: polycoef(el)?,
                        active,
                        line: el.line,
                    });
                }
                _ => return Err(el.unsupported()),
            }
        }
        Ok(())
    }

    fn actuators(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        for child in node.elements() {
            let el = &child.el;
            if !ACTUATORS.contains(&el.name.as_str()) {
                return Err(match el.name.as_str() {
                    "intvelocity" | "damper" | "cylinder" | "muscle" | "adhesion" | "plugin"
                    | "pid" | "orientation" | "dcmotor" => {
                        el.feature(format!("actuator <{}>", el.name))
                    }
                    _ => el.unsupported(),
                });
            }
            no_children(child)?;
            let class = self.class_of(el, 0)?;
            let mut spec = ActuatorSpec::default();
            for (kind, attrs) in &self.defaults.classes[class].actuator {
                spec.apply(kind, attrs, self.conv, self.autolimits)?;
            }
            let own: Vec<Attr> = el
                .attrs
                .iter()
                .filter(|a| a.name != "name" && a.name != "class")
                .cloned()
                .collect();
            spec.apply(&el.name, &own, self.conv, self.autolimits)?;
            let index = self.model.actuators.len();
            let act = spec.finish(
                el,
                name_or(el, "actuator", index),
                &self.joint_names,
                &self.tendon_names,
                &self.model,
                self.autolimits,
            )?;
            register(&mut self.actuator_names, el, index)?;
            self.model.actuators.push(act);
        }
        Ok(())
    }

    /// Sensors: name, type and the object they read, as written.
    fn sensors(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        const NOT_TARGET: [&str; 8] = [
            "name", "class", "noise", "cutoff", "user", "nsample", "interp", "delay",
        ];
        for child in node.elements() {
            let el = &child.el;
            if el.name == "plugin" {
                return Err(el.feature("sensor plugin"));
            }
            let target = el
                .attrs
                .iter()
                .find(|a| !NOT_TARGET.contains(&a.name.as_str()))
                .map_or_else(String::new, |a| a.value.trim().to_string());
            self.model.sensors.push(Sensor {
                name: name_of(el),
                kind: el.name.clone(),
                target,
                line: el.line,
            });
        }
        Ok(())
    }

    fn keyframes(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        let qpos0 = self.model.qpos0();
        for child in node.elements() {
            let el = &child.el;
            if el.name != "key" {
                return Err(el.unsupported());
            }
            no_children(child)?;
            el.only(&["name", "time", "qpos", "qvel", "ctrl", "act"])?;
            let time = match el.get("time") {
                Some(a) => a.scalar()?,
                None => 0.0,
            };
            // As MuJoCo 4.0 compiles keys: values given fill the front; the rest is
            // qpos0 / zero; more than nq / nv values are an error.
            let read = |attr: &str, fill: &[f64]| -> Result<Vec<f64>, MjcfError> {
                let mut out = fill.to_vec();
                if let Some(a) = el.get(attr) {
                    let v = a.numbers()?;
                    if v.len() > fill.len() {
                        return Err(a.bad(format!(
                            "expected at most {} numbers, found {}",
                            fill.len(),
                            v.len()
                        )));
                    }
                    out[..v.len()].copy_from_slice(&v);
                }
                Ok(out)
            };
            let mut qpos = read("qpos", &qpos0)?;
            let qvel = read("qvel", &vec![0.0; self.nv])?;
            let ctrl = read("ctrl", &vec![0.0; self.model.actuators.len()])?;
            // No actuator has activation state (dyntype none only).
            read("act", &[])?;
            // MuJoCo normalises the quaternions of ball and free joints in key_qpos (a
            // zero quaternion becomes the identity).
            for j in &self.model.joints {
                let a = match j.kind {
                    JointKind::Ball => j.qpos_adr,
                    JointKind::Free => j.qpos_adr + 3,
                    JointKind::Hinge | JointKind::Slide => continue,
                };
                let q = math::normalize4([qpos[a], qpos[a + 1], qpos[a + 2], qpos[a + 3]]);
                qpos[a..a + 4].copy_from_slice(&q);
            }
            let index = self.model.keyframes.len();
            register(&mut self.key_names, el, index)?;
            self.model.keyframes.push(Keyframe {
                name: name_or(el, "key", index),
                time,
                qpos,
                qvel,
                ctrl,
                line: el.line,
            });
        }
        Ok(())
    }

    /// `custom`: `numeric` (zero-padded to `size`), `text`, `tuple`.
    fn custom(&mut self, node: &XNode) -> Result<(), MjcfError> {
        node.el.only(&[])?;
        for child in node.elements() {
            let el = &child.el;
            let name = el.require("name")?.value.trim().to_string();
            let mut entry = Custom {
                name,
                kind: el.name.clone(),
                data: Vec::new(),
                text: String::new(),
            };
            match el.name.as_str() {
                "numeric" => {
                    no_children(child)?;
                    el.only(&["name", "size", "data"])?;
                    let data = match el.get("data") {
                        Some(a) => a.numbers()?,
                        None => Vec::new(),
                    };
                    let size = match el.get("size") {
                        Some(a) => a.unsigned()? as usize,
                        None => data.len(),
                    };
                    if size < data.len() || size > 1 << 20 {
                        return Err(el.invalid("numeric size smaller than its data or too large"));
                    }
                    entry.data = data;
                    entry.data.resize(size, 0.0);
                }
                "text" => {
                    no_children(child)?;
                    el.only(&["name", "data"])?;
                    entry.text = el.require("data")?.value.clone();
                }
                "tuple" => {
                    el.only(&["name"])?;
                    let mut objs = Vec::new();
                    for e in child.elements() {
                        let ee = &e.el;
                        if ee.name != "element" {
                            return Err(ee.unsupported());
                        }
                        no_children(e)?;
                        ee.only(&["objtype", "objname", "prm"])?;
                        let t = ee.require("objtype")?.value.trim().to_string();
                        let n = ee.require("objname")?.value.trim().to_string();
                        objs.push(format!("{t}:{n}"));
                        entry.data.push(match ee.get("prm") {
                            Some(a) => a.scalar()?,
                            None => 0.0,
                        });
                    }
                    entry.text = objs.join(" ");
                }
                _ => return Err(el.unsupported()),
            }
            self.model.custom.push(entry);
        }
        Ok(())
    }
}
