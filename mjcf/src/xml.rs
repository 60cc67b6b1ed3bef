//! The document as an owned tree of [`Element`]s, with `<include>` expanded.
//!
//! MuJoCo splices the top-level children of an included file (whose root is `<mujoco>`)
//! in place of the `<include>` element, wherever it appears. Paths are relative to the
//! directory of the including file. Missing files, cycles and an `include` without a base
//! directory are [`MjcfError::Include`]; errors inside an included file come wrapped in
//! [`MjcfError::InFile`].

use std::path::{Path, PathBuf};
use std::sync::Arc;

use roxmltree::{Document, Node};

use crate::attrs::{in_file, line_at, Element, FileRef};
use crate::error::MjcfError;
use crate::MAX_DEPTH;

/// One element with its children (includes already spliced in).
#[derive(Clone, Debug)]
pub(crate) struct XNode {
    /// The element.
    pub el: Element,
    /// Child elements in document order.
    pub children: Vec<XNode>,
}

impl XNode {
    /// Tag name.
    pub fn name(&self) -> &str {
        &self.el.name
    }

    /// Child elements.
    pub fn elements(&self) -> impl Iterator<Item = &XNode> {
        self.children.iter()
    }
}

/// Largest number of files one load may read through `include` (guards against
/// include bombs that fan out without a cycle).
const MAX_INCLUDES: usize = 1000;

/// State shared by one load's includes.
struct Reader {
    /// Canonical paths of the files being included, outermost first (cycle check).
    chain: Vec<PathBuf>,
    /// Files read so far.
    count: usize,
}

/// Parses the main text and expands its includes relative to `dir`; `main` is the
/// main file's path when it came from one (so that including it again is a cycle).
pub(crate) fn read(
    text: &str,
    dir: Option<&Path>,
    main: Option<&Path>,
) -> Result<XNode, MjcfError> {
    let mut reader = Reader {
        chain: main
            .and_then(|p| std::fs::canonicalize(p).ok())
            .into_iter()
            .collect(),
        count: 0,
    };
    reader.document(text, None, dir, 1)
}

impl Reader {
    fn document(
        &mut self,
        text: &str,
        file: FileRef,
        dir: Option<&Path>,
        depth0: usize,
    ) -> Result<XNode, MjcfError> {
        let options = roxmltree::ParsingOptions {
            allow_dtd: false,
            ..Default::default()
        };
        let doc = Document::parse_with_options(text, options).map_err(|e| {
            in_file(
                &file,
                MjcfError::Xml {
                    line: e.pos().row,
                    message: e.to_string(),
                },
            )
        })?;
        check_depth(&doc, &file, depth0)?;
        let root = doc.root_element();
        self.convert(&doc, root, &file, dir, depth0)
    }

    /// Converts one node; `depth` is its nesting level in the combined document.
    fn convert(
        &mut self,
        doc: &Document<'_>,
        node: Node<'_, '_>,
        file: &FileRef,
        dir: Option<&Path>,
        depth: usize,
    ) -> Result<XNode, MjcfError> {
        let el = Element::from_node(doc, node, file);
        let mut children = Vec::new();
        for child in node.children().filter(|n| n.is_element()) {
            if child.tag_name().name() == "include" {
                let inc = Element::from_node(doc, child, file);
                let spliced = self.include(doc, child, &inc, dir, depth + 1)?;
                children.extend(spliced);
            } else {
                children.push(self.convert(doc, child, file, dir, depth + 1)?);
            }
        }
        Ok(XNode { el, children })
    }

    /// The top-level children of the file an `<include>` names.
    fn include(
        &mut self,
        doc: &Document<'_>,
        node: Node<'_, '_>,
        inc: &Element,
        dir: Option<&Path>,
        depth: usize,
    ) -> Result<Vec<XNode>, MjcfError> {
        inc.only(&["file"])?;
        if let Some(c) = node.children().find(|n| n.is_element()) {
            return Err(Element::from_node(doc, c, &inc.file).unsupported());
        }
        let written = inc.require("file")?.value.clone();
        let err = |file: PathBuf, reason: String| {
            inc.wrap(MjcfError::Include {
                file,
                line: inc.line,
                reason,
            })
        };
        let Some(dir) = dir else {
            return Err(err(
                PathBuf::from(&written),
                "include needs a base directory (use load_file or load_str_with_dir)".into(),
            ));
        };
        let path = dir.join(&written);
        let canonical = std::fs::canonicalize(&path)
            .map_err(|e| err(path.clone(), format!("cannot open: {e}")))?;
        if self.chain.contains(&canonical) {
            return Err(err(path, "include cycle".into()));
        }
        self.count += 1;
        if self.count > MAX_INCLUDES {
            return Err(err(path, format!("more than {MAX_INCLUDES} includes")));
        }
        let text = std::fs::read_to_string(&canonical)
            .map_err(|e| err(path.clone(), format!("cannot read: {e}")))?;
        let file: FileRef = Some(Arc::new(path.clone()));
        let sub_dir = canonical.parent().map(Path::to_path_buf);
        self.chain.push(canonical);
        // The included root stands where the include stood; its children one deeper.
        let root = self.document(&text, file, sub_dir.as_deref(), depth)?;
        self.chain.pop();
        if root.name() != "mujoco" {
            return Err(err(
                path,
                format!(
                    "the included file's root is <{}>, not <mujoco>",
                    root.name()
                ),
            ));
        }
        root.el.only(&["model"])?;
        Ok(root.children)
    }
}

/// Refuses element nesting deeper than [`MAX_DEPTH`] (iteratively, so hostile nesting
/// cannot exhaust the stack here or later). `depth0` is the root's level.
fn check_depth(doc: &Document<'_>, file: &FileRef, depth0: usize) -> Result<(), MjcfError> {
    let mut stack = vec![(doc.root_element(), depth0)];
    while let Some((node, depth)) = stack.pop() {
        if depth > MAX_DEPTH {
            return Err(in_file(
                file,
                MjcfError::TooDeep {
                    line: line_at(doc, node.range().start),
                    limit: MAX_DEPTH,
                },
            ));
        }
        stack.extend(
            node.children()
                .filter(|n| n.is_element())
                .map(|n| (n, depth + 1)),
        );
    }
    Ok(())
}
