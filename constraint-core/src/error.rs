//! Typed errors for invalid constraint definitions.

use core::fmt;

/// Why a constraint could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConstraintError {
    /// A position, rest value or parameter was NaN or infinite.
    NonFinite,
    /// The rest length of a distance constraint was zero or negative
    /// (`C = |x_a − x_b|` is not differentiable at zero length).
    ZeroRestLength,
    /// The rest triangle has (numerically) zero area.
    DegenerateTriangle,
    /// The rest tetrahedron is flat: its volume is negligible against its edge lengths.
    FlatTetrahedron,
    /// The rest tetrahedron has negative signed volume (vertex order is inverted).
    InvertedTetrahedron,
    /// A plane normal (or a dihedral hinge edge) had zero length.
    ZeroNormal,
    /// Two stencil entries name the same point.
    RepeatedIndex,
    /// A stencil index is beyond the end of the rest positions given.
    IndexOutOfBounds,
    /// A rigid-body orientation quaternion was not of unit length (to within 1e-6).
    NonUnitQuaternion,
    /// The axes of a compound joint are dependent (two parallel hinges, three coplanar
    /// hinges, dependent slides) or more than three of a kind.
    DependentAxes,
    /// The hinge lines of a compound joint neither pass through one point nor are two
    /// hinges alone (an offset universal joint): MuJoCo's composition of them is not one
    /// of the forms [`crate::Compound`] holds.
    HingesNotConcurrent,
}

impl fmt::Display for ConstraintError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Self::NonFinite => "non-finite input (NaN or infinity)",
            Self::ZeroRestLength => "rest length must be positive and finite",
            Self::DegenerateTriangle => "rest triangle has zero area",
            Self::FlatTetrahedron => "rest tetrahedron is flat (zero volume)",
            Self::InvertedTetrahedron => "rest tetrahedron is inverted (negative volume)",
            Self::ZeroNormal => "normal or hinge edge has zero length",
            Self::RepeatedIndex => "a point appears twice in the stencil",
            Self::IndexOutOfBounds => "a stencil index is out of bounds of the rest positions",
            Self::NonUnitQuaternion => "orientation quaternion is not of unit length",
            Self::DependentAxes => "compound joint axes are dependent (parallel hinges, coplanar hinges or dependent slides)",
            Self::HingesNotConcurrent => "compound joint hinge lines do not meet in one point (only two hinges alone may be on skew lines)",
        };
        f.write_str(s)
    }
}

impl core::error::Error for ConstraintError {}
