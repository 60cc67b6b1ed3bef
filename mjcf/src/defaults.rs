//! `default` classes: nested classes inherit their parent's joint and geom attributes;
//! an element takes its `class`, else the nearest enclosing body's `childclass`, else
//! the top-level class (`main`).
//!
//! A class is stored as the attribute list of its whole ancestry, outermost first; an
//! element applies that list and then its own attributes in order. Applying in order
//! reproduces MuJoCo's copy-then-override semantics, including partial vectors such as
//! `friction="0.5"` keeping the inherited torsional and rolling coefficients.

use std::collections::BTreeMap;

use crate::attrs::Attr;
use crate::error::MjcfError;
use crate::xml::XNode;

/// One class with its inherited attributes.
#[derive(Clone, Debug, Default)]
pub(crate) struct Class {
    /// Joint attributes, ancestors first.
    pub joint: Vec<Attr>,
    /// Geom attributes, ancestors first.
    pub geom: Vec<Attr>,
    /// Actuator defaults, ancestors first: the shortcut element (`motor`, `position`,
    /// `velocity`, `general`) and its attributes. MuJoCo applies each shortcut to the
    /// one default actuator of the class, in order.
    pub actuator: Vec<(String, Vec<Attr>)>,
    /// Tendon attributes, ancestors first.
    pub tendon: Vec<Attr>,
    /// Equality attributes, ancestors first.
    pub equality: Vec<Attr>,
}

/// All classes; index 0 is the top-level class.
#[derive(Clone, Debug)]
pub(crate) struct Defaults {
    /// Classes by index.
    pub classes: Vec<Class>,
    names: BTreeMap<String, usize>,
    seen_top: bool,
}

/// Elements inside `default` that only style visual or data-only elements.
const IGNORED: [&str; 6] = ["site", "camera", "light", "material", "mesh", "pair"];
/// Actuator shortcuts accepted in `default` (and in `actuator`).
pub(crate) const ACTUATORS: [&str; 4] = ["general", "motor", "position", "velocity"];

impl Defaults {
    /// Only the (empty) top-level class `main`.
    pub fn new() -> Self {
        let mut names = BTreeMap::new();
        names.insert("main".to_string(), 0);
        Defaults {
            classes: vec![Class::default()],
            names,
            seen_top: false,
        }
    }

    /// Index of a class by name.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.names.get(name).copied()
    }

    /// The class an element names in `attr` (`class` or `childclass`).
    pub fn lookup(&self, attr: &Attr) -> Result<usize, MjcfError> {
        self.find(attr.value.trim()).ok_or_else(|| {
            crate::attrs::in_file(
                &attr.file,
                MjcfError::UnknownClass {
                    element: attr.element.clone(),
                    class: attr.value.clone(),
                    line: attr.line,
                },
            )
        })
    }

    /// Reads one top-level `<default>` with its nested classes. `check` validates the
    /// finished class (so a bad value in an unused class is still an error).
    pub fn parse(
        &mut self,
        top: &XNode,
        check: &dyn Fn(&Class) -> Result<(), MjcfError>,
    ) -> Result<(), MjcfError> {
        let el = &top.el;
        if self.seen_top {
            return Err(el.invalid("only one top-level <default> is allowed"));
        }
        self.seen_top = true;
        el.only(&["class"])?;
        if let Some(c) = el.get("class") {
            self.names.insert(c.value.trim().to_string(), 0);
        }
        let mut stack = vec![(top, 0usize)];
        while let Some((node, index)) = stack.pop() {
            let mut nested = Vec::new();
            for child in node.elements() {
                let ce = &child.el;
                let leaf = || -> Result<Vec<Attr>, MjcfError> {
                    if let Some(c) = child.elements().next() {
                        return Err(c.el.unsupported());
                    }
                    Ok(ce.attrs.clone())
                };
                let class = &mut self.classes[index];
                match ce.name.as_str() {
                    "default" => nested.push(child),
                    "joint" => class.joint.extend(leaf()?),
                    "geom" => class.geom.extend(leaf()?),
                    "tendon" => class.tendon.extend(leaf()?),
                    "equality" => class.equality.extend(leaf()?),
                    n if ACTUATORS.contains(&n) => class.actuator.push((n.to_string(), leaf()?)),
                    n if IGNORED.contains(&n) => {}
                    _ => return Err(ce.unsupported()),
                }
            }
            check(&self.classes[index])?;
            let mut created = Vec::new();
            for child in nested {
                let ce = &child.el;
                ce.only(&["class"])?;
                let name = ce.require("class")?.value.trim().to_string();
                if self.names.contains_key(&name) {
                    return Err(ce.invalid(format!("repeated default class name \"{name}\"")));
                }
                let inherited = self.classes[index].clone();
                self.classes.push(inherited);
                let new = self.classes.len() - 1;
                self.names.insert(name, new);
                created.push((child, new));
            }
            // Reverse so that the stack pops sibling classes in document order.
            stack.extend(created.into_iter().rev());
        }
        Ok(())
    }
}
