//! The document walk: sections in MuJoCo's order of effect (`compiler`, `option`,
//! `default`, `worldbody`, `equality`, `keyframe`), bodies depth-first in document order
//! without recursion.

use std::collections::BTreeMap;

use roxmltree::{Document, Node};

use crate::attrs::{line_at, Element};
use crate::defaults::{Class, Defaults};
use crate::elements::{GeomSpec, JointSpec};
use crate::error::MjcfError;
use crate::inertia::{self, GeomMass};
use crate::math::{self, M3, Q, V3};
use crate::model::{Body, Connect, Geom, Joint, JointKind, Keyframe, Model};
use crate::orientation::{self, AngleConvention};
use crate::MAX_DEPTH;

/// `compiler inertiafromgeom`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FromGeom {
    False,
    True,
    Auto,
}

/// Top-level sections skipped whole: they hold nothing that changes the dynamics of the
/// subset (visual settings, memory sizes, statistics, textures and materials).
const IGNORED_SECTIONS: [&str; 4] = ["size", "visual", "statistic", "asset"];
/// Body children accepted and ignored: massless, collision-free markers and visuals.
const IGNORED_IN_BODY: [&str; 3] = ["site", "camera", "light"];
/// `option` attributes that only steer MuJoCo's solver, accepted and ignored.
const SOLVER_ONLY_OPTIONS: [&str; 7] = [
    // `cone`: MuJoCo's friction cone shape; this library's contact uses the pyramidal
    // Coulomb cone whatever the file says.
    "cone",
    "solver",
    "iterations",
    "ls_iterations",
    "tolerance",
    "ls_tolerance",
    "jacobian",
];

/// Parses and compiles a document.
pub(crate) fn load(xml: &str) -> Result<Model, MjcfError> {
    let options = roxmltree::ParsingOptions {
        allow_dtd: false,
        ..Default::default()
    };
    let doc = Document::parse_with_options(xml, options).map_err(|e| MjcfError::Xml {
        line: e.pos().row,
        message: e.to_string(),
    })?;
    check_depth(&doc)?;
    let root = doc.root_element();
    let el = Element::from_node(&doc, root);
    if el.name != "mujoco" {
        return Err(el.unsupported());
    }
    el.only(&["model"])?;
    let mut loader = Loader::new(&doc);
    let sections: Vec<Node<'_, '_>> = root.children().filter(|n| n.is_element()).collect();
    for s in &sections {
        let name = s.tag_name().name();
        let known = [
            "compiler",
            "option",
            "default",
            "worldbody",
            "equality",
            "keyframe",
        ];
        if !known.contains(&name) && !IGNORED_SECTIONS.contains(&name) {
            return Err(Element::from_node(&doc, *s).unsupported());
        }
    }
    let of = |name: &'static str| {
        sections
            .iter()
            .filter(move |n| n.tag_name().name() == name)
            .copied()
            .collect::<Vec<_>>()
    };
    for n in of("compiler") {
        loader.compiler(n)?;
    }
    for n in of("option") {
        loader.option(n)?;
    }
    for n in of("default") {
        let check = |c: &Class| -> Result<(), MjcfError> {
            let mut j = JointSpec::default();
            for a in &c.joint {
                j.apply(a)?;
            }
            let mut g = GeomSpec::default();
            for a in &c.geom {
                g.apply(a)?;
            }
            Ok(())
        };
        loader.defaults.parse(&doc, n, &check)?;
    }
    for n in of("worldbody") {
        loader.worldbody(n)?;
    }
    loader.check_moving_masses()?;
    for n in of("equality") {
        loader.equality(n)?;
    }
    for n in of("keyframe") {
        loader.keyframes(n)?;
    }
    if loader.gravity_disabled {
        loader.model.gravity = [0.0; 3];
    }
    Ok(loader.model)
}

/// Refuses element nesting deeper than [`MAX_DEPTH`] (iteratively, so hostile nesting
/// cannot exhaust the stack here or later).
fn check_depth(doc: &Document<'_>) -> Result<(), MjcfError> {
    let mut stack = vec![(doc.root_element(), 1usize)];
    while let Some((node, depth)) = stack.pop() {
        if depth > MAX_DEPTH {
            return Err(MjcfError::TooDeep {
                line: line_at(doc, node.range().start),
                limit: MAX_DEPTH,
            });
        }
        stack.extend(
            node.children()
                .filter(|n| n.is_element())
                .map(|n| (n, depth + 1)),
        );
    }
    Ok(())
}

/// What the walk keeps per body beyond [`Body`].
struct BodyExtra {
    has_joint: bool,
    children: Vec<usize>,
    /// Mass and principal inertias are all `≥ mjMINVAL`.
    massive: bool,
}

/// A body waiting on the walk's stack.
struct Pending<'a, 'input> {
    node: Node<'a, 'input>,
    parent: Option<usize>,
    class: usize,
    pos: V3,
    quat: Q,
    parent_static: bool,
}

struct Loader<'a, 'input> {
    doc: &'a Document<'input>,
    conv: AngleConvention,
    from_geom: FromGeom,
    gravity_disabled: bool,
    defaults: Defaults,
    model: Model,
    extra: Vec<BodyExtra>,
    body_names: BTreeMap<String, usize>,
    joint_names: BTreeMap<String, usize>,
    geom_names: BTreeMap<String, usize>,
    connect_names: BTreeMap<String, usize>,
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

impl<'a, 'input> Loader<'a, 'input> {
    fn new(doc: &'a Document<'input>) -> Self {
        Loader {
            doc,
            conv: AngleConvention::default(),
            from_geom: FromGeom::Auto,
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
            },
            extra: Vec::new(),
            body_names: BTreeMap::new(),
            joint_names: BTreeMap::new(),
            geom_names: BTreeMap::new(),
            connect_names: BTreeMap::new(),
            key_names: BTreeMap::new(),
            nq: 0,
            nv: 0,
        }
    }

    fn element(&self, node: Node<'_, '_>) -> Element {
        Element::from_node(self.doc, node)
    }

    /// Child elements of a node that must have none.
    fn no_children(&self, node: Node<'_, '_>) -> Result<(), MjcfError> {
        match node.children().find(|n| n.is_element()) {
            Some(c) => Err(self.element(c).unsupported()),
            None => Ok(()),
        }
    }

    fn compiler(&mut self, node: Node<'_, '_>) -> Result<(), MjcfError> {
        let el = self.element(node);
        self.no_children(node)?;
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
                // Limits are outside the subset (a limited joint is an error), so
                // autolimits cannot matter; asset settings only serve ignored assets.
                "autolimits" | "discardvisual" => {
                    a.boolean()?;
                }
                "meshdir" | "texturedir" | "assetdir" => {}
                _ => return Err(a.unsupported()),
            }
        }
        Ok(())
    }

    fn option(&mut self, node: Node<'_, '_>) -> Result<(), MjcfError> {
        let el = self.element(node);
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
                n if SOLVER_ONLY_OPTIONS.contains(&n) => {}
                _ => return Err(a.unsupported()),
            }
        }
        for child in node.children().filter(|n| n.is_element()) {
            let ce = self.element(child);
            if ce.name != "flag" {
                return Err(ce.unsupported());
            }
            self.no_children(child)?;
            for a in &ce.attrs {
                let enabled = a.keyword(&[("enable", true), ("disable", false)])?;
                match a.name.as_str() {
                    "contact" => self.model.contact_disabled = !enabled,
                    "gravity" => self.gravity_disabled = !enabled,
                    // Only bookkeeping or solver start: no effect on the dynamics.
                    "energy" | "warmstart" => {}
                    _ => return Err(a.unsupported()),
                }
            }
        }
        Ok(())
    }

    fn worldbody(&mut self, node: Node<'a, 'input>) -> Result<(), MjcfError> {
        let el = self.element(node);
        el.only(&[])?;
        let mut stack = Vec::new();
        let mut bodies = Vec::new();
        for child in node.children().filter(|n| n.is_element()) {
            let ce = self.element(child);
            match ce.name.as_str() {
                "body" => bodies.push(child),
                "geom" => {
                    self.geom(child, None, 0)?;
                }
                n if IGNORED_IN_BODY.contains(&n) => {}
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

    fn class_of(&self, el: &Element, inherited: usize) -> Result<usize, MjcfError> {
        match el.get("class") {
            Some(a) => self.defaults.lookup(a),
            None => Ok(inherited),
        }
    }

    fn body(
        &mut self,
        p: Pending<'a, 'input>,
        stack: &mut Vec<Pending<'a, 'input>>,
    ) -> Result<(), MjcfError> {
        let el = self.element(p.node);
        el.only(&[
            "name",
            "pos",
            "quat",
            "axisangle",
            "euler",
            "xyaxes",
            "zaxis",
            "childclass",
        ])?;
        let class = match el.get("childclass") {
            Some(a) => self.defaults.lookup(a)?,
            None => p.class,
        };
        let local_pos: V3 = match el.get("pos") {
            Some(a) => a.exact()?,
            None => [0.0; 3],
        };
        let local_quat = match orientation::read(&el)? {
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
        register(&mut self.body_names, &el, index)?;

        let mut inertials = Vec::new();
        let mut joints = Vec::new();
        let mut geoms = Vec::new();
        let mut children = Vec::new();
        for child in p.node.children().filter(|n| n.is_element()) {
            match child.tag_name().name() {
                "inertial" => inertials.push(child),
                "joint" | "freejoint" => joints.push(child),
                "geom" => geoms.push(child),
                "body" => children.push(child),
                n if IGNORED_IN_BODY.contains(&n) => {}
                _ => return Err(self.element(child).unsupported()),
            }
        }
        if let Some(second) = inertials.get(1) {
            return Err(self
                .element(*second)
                .invalid("a body may hold one inertial"));
        }
        // One joint per body in this subset (each joint is one constraint between a body
        // and its parent).
        if let Some(second) = joints.get(1) {
            return Err(self.element(*second).unsupported());
        }
        self.model.bodies.push(Body {
            name: name_or(&el, "body", index),
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
        });
        if let Some(parent) = p.parent {
            self.extra[parent].children.push(index);
        }
        if let Some(j) = joints.first() {
            self.joint(*j, index, class, p.parent)?;
        }
        let is_static = p.parent_static && joints.is_empty();
        let mut masses = Vec::new();
        for g in geoms {
            let (data, is_plane) = self.geom(g, Some(index), class)?;
            if is_plane && !is_static {
                return Err(self
                    .element(g)
                    .invalid("plane only allowed in static bodies"));
            }
            masses.push(data);
        }
        let explicit = match inertials.first() {
            Some(n) => Some(self.inertial(*n)?),
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
        let (mass, com, tensor) = match (from_geoms, explicit) {
            (Some(m), _) => m,
            (None, Some(m)) => m,
            (None, None) => (0.0, [0.0; 3], [[0.0; 3]; 3]),
        };
        if !mass.is_finite() || tensor.iter().flatten().any(|x| !x.is_finite()) {
            return Err(el.invalid("mass or inertia overflows"));
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
        node: Node<'_, '_>,
        body: usize,
        class: usize,
        parent: Option<usize>,
    ) -> Result<(), MjcfError> {
        let el = self.element(node);
        self.no_children(node)?;
        let mut spec = JointSpec::default();
        if el.name == "freejoint" {
            // `freejoint` takes no defaults.
            el.only(&["name", "group", "align"])?;
            if let Some(a) = el.get("align") {
                if a.keyword(&[("false", false), ("auto", false), ("true", true)])? {
                    return Err(a.unsupported());
                }
            }
            spec.apply(&crate::attrs::Attr {
                element: el.name.clone(),
                name: "type".into(),
                value: "free".into(),
                line: el.line,
            })?;
        } else {
            let class = self.class_of(&el, class)?;
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
        let data = spec.finish(&el)?;
        if data.kind == JointKind::Free && parent.is_some() {
            return Err(el.invalid("free joint can only be used on top level"));
        }
        let index = self.model.joints.len();
        register(&mut self.joint_names, &el, index)?;
        let (nq, nv) = match data.kind {
            JointKind::Hinge | JointKind::Slide => (1, 1),
            JointKind::Ball => (4, 3),
            JointKind::Free => (7, 6),
        };
        self.model.joints.push(Joint {
            name: name_or(&el, "joint", index),
            kind: data.kind,
            body,
            pos: data.pos,
            axis: data.axis,
            damping: data.damping,
            qpos_adr: self.nq,
            dof_adr: self.nv,
            line: el.line,
        });
        self.nq += nq;
        self.nv += nv;
        Ok(())
    }

    /// Compiles a geom into the model; returns its mass properties and whether it is a
    /// plane.
    fn geom(
        &mut self,
        node: Node<'_, '_>,
        body: Option<usize>,
        class: usize,
    ) -> Result<(GeomMass, bool), MjcfError> {
        let el = self.element(node);
        self.no_children(node)?;
        let class = self.class_of(&el, class)?;
        let mut spec = GeomSpec::default();
        for a in &self.defaults.classes[class].geom {
            spec.apply(a)?;
        }
        orientation::read(&el)?;
        for a in el
            .attrs
            .iter()
            .filter(|a| a.name != "name" && a.name != "class")
        {
            spec.apply(a)?;
        }
        let data = spec.finish(&el, self.conv)?;
        let index = self.model.geoms.len();
        register(&mut self.geom_names, &el, index)?;
        let is_plane = matches!(data.shape, crate::model::Shape::Plane);
        self.model.geoms.push(Geom {
            name: name_or(&el, "geom", index),
            body,
            shape: data.shape,
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
        ))
    }

    /// `inertial`: mass, centre of mass and inertia tensor in the body frame.
    fn inertial(&self, node: Node<'_, '_>) -> Result<(f64, V3, M3), MjcfError> {
        let el = self.element(node);
        self.no_children(node)?;
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
        let orient = orientation::read(&el)?;
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
                return Err(MjcfError::Invalid {
                    element: "body".into(),
                    line: body.line,
                    reason: format!(
                        "mass and inertia of moving body \"{}\" must be at least 1e-15",
                        body.name
                    ),
                });
            }
        }
        Ok(())
    }

    fn equality(&mut self, node: Node<'_, '_>) -> Result<(), MjcfError> {
        self.element(node).only(&[])?;
        for child in node.children().filter(|n| n.is_element()) {
            let el = self.element(child);
            if el.name != "connect" {
                return Err(el.unsupported());
            }
            self.no_children(child)?;
            // `solref`/`solimp` only tune how soft MuJoCo's connect is; here a connect is a
            // hard constraint, so they are accepted and ignored (documented in lib.rs).
            el.only(&[
                "name", "body1", "body2", "anchor", "active", "solref", "solimp",
            ])?;
            if let Some(a) = el.get("active") {
                if !a.boolean()? {
                    return Err(a.unsupported());
                }
            }
            let body = |attr: &str| -> Result<Option<usize>, MjcfError> {
                match el.get(attr) {
                    None => Ok(None),
                    Some(a) if a.value.trim() == "world" => Ok(None),
                    Some(a) => match self.body_names.get(a.value.trim()) {
                        Some(i) => Ok(Some(*i)),
                        None => Err(MjcfError::UnknownBody {
                            element: el.name.clone(),
                            name: a.value.clone(),
                            line: a.line,
                        }),
                    },
                }
            };
            el.require("body1")?;
            let body1 = body("body1")?;
            let body2 = body("body2")?;
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
            let index = self.model.connects.len();
            register(&mut self.connect_names, &el, index)?;
            self.model.connects.push(Connect {
                name: name_or(&el, "connect", index),
                body1,
                body2,
                anchor,
                anchor2,
                line: el.line,
            });
        }
        Ok(())
    }

    fn keyframes(&mut self, node: Node<'_, '_>) -> Result<(), MjcfError> {
        self.element(node).only(&[])?;
        let qpos0 = self.model.qpos0();
        for child in node.children().filter(|n| n.is_element()) {
            let el = self.element(child);
            if el.name != "key" {
                return Err(el.unsupported());
            }
            self.no_children(child)?;
            el.only(&["name", "time", "qpos", "qvel"])?;
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
            register(&mut self.key_names, &el, index)?;
            self.model.keyframes.push(Keyframe {
                name: name_or(&el, "key", index),
                time,
                qpos,
                qvel,
                line: el.line,
            });
        }
        Ok(())
    }
}
