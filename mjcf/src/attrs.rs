//! Attribute values: numbers, vectors, keywords, with errors that name element,
//! attribute and line.

use std::path::PathBuf;
use std::sync::Arc;

use crate::error::MjcfError;

/// The included file an element comes from (`None`: the main text).
pub(crate) type FileRef = Option<Arc<PathBuf>>;

/// Wraps an error from an included file in [`MjcfError::InFile`].
pub(crate) fn in_file(file: &FileRef, e: MjcfError) -> MjcfError {
    match file {
        Some(f) => MjcfError::InFile {
            file: f.as_ref().clone(),
            error: Box::new(e),
        },
        None => e,
    }
}

/// One attribute as written, with where it was written.
#[derive(Clone, Debug)]
pub(crate) struct Attr {
    /// Element the attribute sits on (for error messages).
    pub element: String,
    /// Attribute name.
    pub name: String,
    /// Raw value.
    pub value: String,
    /// 1-based line of the attribute.
    pub line: u32,
    /// Included file the attribute comes from.
    pub file: FileRef,
}

/// One element's name, line and attributes.
#[derive(Clone, Debug)]
pub(crate) struct Element {
    /// Tag name.
    pub name: String,
    /// 1-based line of the start tag.
    pub line: u32,
    /// Attributes in document order.
    pub attrs: Vec<Attr>,
    /// Included file the element comes from.
    pub file: FileRef,
}

impl Element {
    /// Reads a tree node.
    pub fn from_node(
        doc: &roxmltree::Document<'_>,
        node: roxmltree::Node<'_, '_>,
        file: &FileRef,
    ) -> Element {
        let name = node.tag_name().name().to_string();
        let line = line_at(doc, node.range().start);
        let attrs = node
            .attributes()
            .map(|a| Attr {
                element: name.clone(),
                name: a.name().to_string(),
                value: a.value().to_string(),
                line: line_at(doc, a.range().start),
                file: file.clone(),
            })
            .collect();
        Element {
            name,
            line,
            attrs,
            file: file.clone(),
        }
    }

    /// The attribute `name`, if present.
    pub fn get(&self, name: &str) -> Option<&Attr> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// The attribute `name`, or [`MjcfError::MissingAttribute`].
    pub fn require(&self, name: &str) -> Result<&Attr, MjcfError> {
        self.get(name).ok_or_else(|| {
            self.wrap(MjcfError::MissingAttribute {
                element: self.name.clone(),
                attribute: name.to_string(),
                line: self.line,
            })
        })
    }

    /// Every attribute must be in `allowed`.
    pub fn only(&self, allowed: &[&str]) -> Result<(), MjcfError> {
        match self
            .attrs
            .iter()
            .find(|a| !allowed.contains(&a.name.as_str()))
        {
            Some(a) => Err(a.unsupported()),
            None => Ok(()),
        }
    }

    /// [`MjcfError::Invalid`] for this element.
    pub fn invalid(&self, reason: impl Into<String>) -> MjcfError {
        self.wrap(MjcfError::Invalid {
            element: self.name.clone(),
            line: self.line,
            reason: reason.into(),
        })
    }

    /// [`MjcfError::Unsupported`] for this element.
    pub fn unsupported(&self) -> MjcfError {
        self.wrap(MjcfError::Unsupported {
            element: self.name.clone(),
            line: self.line,
        })
    }

    /// [`MjcfError::UnsupportedFeature`] for this element.
    pub fn feature(&self, what: impl Into<String>) -> MjcfError {
        self.wrap(MjcfError::UnsupportedFeature {
            element: self.name.clone(),
            line: self.line,
            feature: what.into(),
        })
    }

    /// Wraps an error about this element when it comes from an included file.
    pub fn wrap(&self, e: MjcfError) -> MjcfError {
        in_file(&self.file, e)
    }
}

/// 1-based line of a byte offset: a binary search in the document's line starts,
/// computed once per document (roxmltree's own `text_pos_at` rescans from the start
/// every call, which made a file of 100k elements take minutes).
pub(crate) fn line_at(doc: &roxmltree::Document<'_>, pos: usize) -> u32 {
    thread_local! {
        static LINES: std::cell::RefCell<(usize, usize, Vec<usize>)> =
            const { std::cell::RefCell::new((0, 0, Vec::new())) };
    }
    let text = doc.input_text();
    let key = (text.as_ptr() as usize, text.len());
    LINES.with(|cell| {
        let mut c = cell.borrow_mut();
        if (c.0, c.1) != key {
            c.2.clear();
            c.2.push(0);
            c.2.extend(text.match_indices('\n').map(|(i, _)| i + 1));
            c.0 = key.0;
            c.1 = key.1;
        }
        let line = match c.2.binary_search(&pos) {
            Ok(i) => i + 1,
            Err(i) => i,
        };
        u32::try_from(line).unwrap_or(u32::MAX)
    })
}

impl Attr {
    /// [`MjcfError::UnsupportedAttribute`] for this attribute.
    pub fn unsupported(&self) -> MjcfError {
        in_file(
            &self.file,
            MjcfError::UnsupportedAttribute {
                element: self.element.clone(),
                attribute: self.name.clone(),
                line: self.line,
            },
        )
    }

    /// [`MjcfError::BadValue`] for this attribute.
    pub fn bad(&self, reason: impl Into<String>) -> MjcfError {
        in_file(
            &self.file,
            MjcfError::BadValue {
                element: self.element.clone(),
                attribute: self.name.clone(),
                value: self.value.clone(),
                line: self.line,
                reason: reason.into(),
            },
        )
    }

    /// [`MjcfError::UnsupportedFeature`] named by this attribute.
    pub fn feature(&self, what: impl Into<String>) -> MjcfError {
        in_file(
            &self.file,
            MjcfError::UnsupportedFeature {
                element: self.element.clone(),
                line: self.line,
                feature: what.into(),
            },
        )
    }

    /// [`MjcfError::UnknownObject`]: this attribute names a `kind` that does not exist.
    pub fn unknown(&self, kind: &'static str) -> MjcfError {
        in_file(
            &self.file,
            MjcfError::UnknownObject {
                element: self.element.clone(),
                kind,
                name: self.value.clone(),
                line: self.line,
            },
        )
    }

    fn bad_number(&self) -> MjcfError {
        in_file(
            &self.file,
            MjcfError::BadNumber {
                element: self.element.clone(),
                attribute: self.name.clone(),
                value: self.value.clone(),
                line: self.line,
            },
        )
    }

    /// A signed integer.
    pub fn integer(&self) -> Result<i32, MjcfError> {
        self.value
            .trim()
            .parse::<i32>()
            .map_err(|_| self.bad_number())
    }

    /// `true`, `false` or `auto` (MuJoCo's `limited` tri-state): `None` for `auto`.
    pub fn tristate(&self) -> Result<Option<bool>, MjcfError> {
        self.keyword(&[("false", Some(false)), ("true", Some(true)), ("auto", None)])
    }

    /// All whitespace-separated finite numbers.
    pub fn numbers(&self) -> Result<Vec<f64>, MjcfError> {
        self.value
            .split_ascii_whitespace()
            .map(|t| match t.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(self.bad_number()),
            })
            .collect()
    }

    /// Exactly `N` numbers.
    pub fn exact<const N: usize>(&self) -> Result<[f64; N], MjcfError> {
        let v = self.numbers()?;
        if v.len() != N {
            return Err(self.bad(format!("expected {N} numbers, found {}", v.len())));
        }
        let mut out = [0.0; N];
        out.copy_from_slice(&v);
        Ok(out)
    }

    /// One to `N` numbers overwriting the first entries of `into` (MuJoCo's non-strict
    /// read: `size`, `friction`).
    pub fn partial<const N: usize>(&self, into: &mut [f64; N]) -> Result<(), MjcfError> {
        let v = self.numbers()?;
        if v.is_empty() || v.len() > N {
            return Err(self.bad(format!("expected 1 to {N} numbers, found {}", v.len())));
        }
        into[..v.len()].copy_from_slice(&v);
        Ok(())
    }

    /// One finite number.
    pub fn scalar(&self) -> Result<f64, MjcfError> {
        Ok(self.exact::<1>()?[0])
    }

    /// One finite number `≥ 0`.
    pub fn non_negative(&self) -> Result<f64, MjcfError> {
        let x = self.scalar()?;
        if x < 0.0 {
            return Err(self.bad("must not be negative"));
        }
        Ok(x)
    }

    /// One finite number `> 0`.
    pub fn positive(&self) -> Result<f64, MjcfError> {
        let x = self.scalar()?;
        if !(x > 0.0) {
            return Err(self.bad("must be positive"));
        }
        Ok(x)
    }

    /// A non-negative integer.
    pub fn unsigned(&self) -> Result<u32, MjcfError> {
        let t = self.value.trim();
        t.parse::<u32>().map_err(|_| {
            if t.parse::<i64>().is_ok() {
                self.bad("must be a non-negative integer")
            } else {
                self.bad_number()
            }
        })
    }

    /// One of `choices` (exact, case-sensitive, as MuJoCo).
    pub fn keyword<T: Copy>(&self, choices: &[(&str, T)]) -> Result<T, MjcfError> {
        let t = self.value.trim();
        choices
            .iter()
            .find(|(k, _)| *k == t)
            .map(|(_, v)| *v)
            .ok_or_else(|| {
                let names: Vec<&str> = choices.iter().map(|(k, _)| *k).collect();
                self.bad(format!("expected one of: {}", names.join(", ")))
            })
    }

    /// `true` or `false`.
    pub fn boolean(&self) -> Result<bool, MjcfError> {
        self.keyword(&[("true", true), ("false", false)])
    }
}
