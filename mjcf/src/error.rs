//! The loader's typed error: every variant that comes from the file names the element
//! and the 1-based line where it starts.

use core::fmt;
use std::path::PathBuf;

/// Why a file could not be loaded (or a state could not be built from a loaded model).
#[derive(Clone, Debug, PartialEq)]
pub enum MjcfError {
    /// The text is not well-formed XML (or uses a DTD, which is refused).
    Xml {
        /// 1-based line of the problem.
        line: u32,
        /// The XML parser's message.
        message: String,
    },
    /// The file could not be read.
    Io {
        /// The path that failed.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// Elements nest deeper than [`crate::MAX_DEPTH`] levels.
    TooDeep {
        /// 1-based line of the first element past the limit.
        line: u32,
        /// The limit.
        limit: usize,
    },
    /// An element outside the supported subset (or in a place where it is not allowed).
    Unsupported {
        /// Element name.
        element: String,
        /// 1-based line.
        line: u32,
    },
    /// An attribute outside the supported subset, or one whose value would change the
    /// dynamics in a way the subset does not model (for example `gainprm` on a `motor`).
    UnsupportedAttribute {
        /// Element name.
        element: String,
        /// Attribute name.
        attribute: String,
        /// 1-based line.
        line: u32,
    },
    /// A required attribute is absent.
    MissingAttribute {
        /// Element name.
        element: String,
        /// Attribute name.
        attribute: String,
        /// 1-based line.
        line: u32,
    },
    /// A value is not a finite number (garbage, NaN, infinity, overflow) or not an integer
    /// where one is needed.
    BadNumber {
        /// Element name.
        element: String,
        /// Attribute name.
        attribute: String,
        /// The offending value as written.
        value: String,
        /// 1-based line.
        line: u32,
    },
    /// A value that parses but is not allowed: wrong count of numbers, unknown keyword,
    /// negative mass or size, zero axis, ...
    BadValue {
        /// Element name.
        element: String,
        /// Attribute name.
        attribute: String,
        /// The offending value as written.
        value: String,
        /// 1-based line.
        line: u32,
        /// What is wrong.
        reason: String,
    },
    /// An element whose attributes are fine one by one but not together, or whose
    /// compiled result is not physical (inertia violating the triangle inequality, a
    /// moving body without mass, a free joint beside another joint, ...).
    Invalid {
        /// Element name.
        element: String,
        /// 1-based line.
        line: u32,
        /// What is wrong.
        reason: String,
    },
    /// `class="..."` or `childclass="..."` names no `default` class.
    UnknownClass {
        /// Element name.
        element: String,
        /// The class name.
        class: String,
        /// 1-based line.
        line: u32,
    },
    /// A body name (for example in `connect body1`) that no body has.
    UnknownBody {
        /// Element name.
        element: String,
        /// The body name.
        name: String,
        /// 1-based line.
        line: u32,
    },
    /// A joint, tendon, site or other named object (in an actuator, tendon, equality or
    /// contact element) that does not exist.
    UnknownObject {
        /// Element name.
        element: String,
        /// What kind of object was looked up (`"joint"`, `"tendon"`, ...).
        kind: &'static str,
        /// The name as written.
        name: String,
        /// 1-based line.
        line: u32,
    },
    /// A MuJoCo feature this loader recognises but does not model (meshes, height
    /// fields, tendon wrapping, frames, actuator dynamics, ...).
    UnsupportedFeature {
        /// Element name.
        element: String,
        /// 1-based line.
        line: u32,
        /// What is not supported, e.g. `"mesh geom"`.
        feature: String,
    },
    /// An `<include>` that cannot be followed: missing file, cycle, no base directory,
    /// or an included file whose root is not `<mujoco>`.
    Include {
        /// The included file as resolved (or as written when it cannot be resolved).
        file: PathBuf,
        /// 1-based line of the `<include>` element in the including file.
        line: u32,
        /// What is wrong.
        reason: String,
    },
    /// An error inside an included file: `file` is that file, `error` carries the element
    /// and the line within it.
    InFile {
        /// The included file.
        file: PathBuf,
        /// The error, with lines counted in `file`.
        error: Box<MjcfError>,
    },
    /// [`crate::Model::keyframe`] or [`crate::Model::initial_state`] with a name no
    /// keyframe has.
    UnknownKeyframe(String),
    /// A generalized-coordinate vector handed to [`crate::Model::body_states`] has the
    /// wrong length.
    StateLength {
        /// `"qpos"` or `"qvel"`.
        what: &'static str,
        /// Required length (`nq` or `nv`).
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// A generalized-coordinate vector handed to [`crate::Model::body_states`] holds a
    /// NaN or an infinity (`what` = `"qpos"` / `"qvel"`), or a computed body state
    /// overflows (`what` = `"body state"`).
    NonFiniteState {
        /// `"qpos"`, `"qvel"` or `"body state"`.
        what: &'static str,
        /// Index of the first non-finite entry, or of the body.
        index: usize,
    },
}

impl fmt::Display for MjcfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MjcfError::Xml { line, message } => write!(f, "line {line}: XML error: {message}"),
            MjcfError::Io { path, message } => {
                write!(f, "cannot read {}: {message}", path.display())
            }
            MjcfError::TooDeep { line, limit } => {
                write!(f, "line {line}: elements nest deeper than {limit} levels")
            }
            MjcfError::Unsupported { element, line } => {
                write!(f, "line {line}: element <{element}> is not supported here")
            }
            MjcfError::UnsupportedAttribute {
                element,
                attribute,
                line,
            } => write!(
                f,
                "line {line}: attribute `{attribute}` of <{element}> is not supported (or not with this value)"
            ),
            MjcfError::MissingAttribute {
                element,
                attribute,
                line,
            } => write!(
                f,
                "line {line}: <{element}> needs the attribute `{attribute}`"
            ),
            MjcfError::BadNumber {
                element,
                attribute,
                value,
                line,
            } => write!(
                f,
                "line {line}: <{element} {attribute}=\"{value}\">: not a finite number"
            ),
            MjcfError::BadValue {
                element,
                attribute,
                value,
                line,
                reason,
            } => write!(
                f,
                "line {line}: <{element} {attribute}=\"{value}\">: {reason}"
            ),
            MjcfError::Invalid {
                element,
                line,
                reason,
            } => write!(f, "line {line}: <{element}>: {reason}"),
            MjcfError::UnknownClass {
                element,
                class,
                line,
            } => write!(
                f,
                "line {line}: <{element}> refers to default class \"{class}\", which does not exist"
            ),
            MjcfError::UnknownBody {
                element,
                name,
                line,
            } => write!(
                f,
                "line {line}: <{element}> refers to body \"{name}\", which does not exist"
            ),
            MjcfError::UnknownObject {
                element,
                kind,
                name,
                line,
            } => write!(
                f,
                "line {line}: <{element}> refers to {kind} \"{name}\", which does not exist"
            ),
            MjcfError::UnsupportedFeature {
                element,
                line,
                feature,
            } => write!(f, "line {line}: <{element}>: unsupported: {feature}"),
            MjcfError::Include { file, line, reason } => {
                write!(f, "line {line}: <include file=\"{}\">: {reason}", file.display())
            }
            MjcfError::InFile { file, error } => write!(f, "in {}: {error}", file.display()),
            MjcfError::UnknownKeyframe(name) => write!(f, "no keyframe named \"{name}\""),
            MjcfError::StateLength {
                what,
                expected,
                got,
            } => write!(f, "{what} has {got} entries, the model needs {expected}"),
            MjcfError::NonFiniteState { what, index } => {
                write!(f, "{what}[{index}] is not finite")
            }
        }
    }
}

impl std::error::Error for MjcfError {}
