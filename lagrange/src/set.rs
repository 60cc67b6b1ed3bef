//! Lists of hard (or compliant) constraints, type-erased per set like the soft crate's
//! force sets: one virtual call per set and stage, flat arrays inside.

use crate::rows::ConstraintRows;
use alloc::boxed::Box;
use alloc::vec::Vec;
use constraint_core::{Area, DVec3, Dihedral, Distance, PointConstraint, PointOnPlane, Volume};

/// The natural size of a constraint's value, used to turn `|C|` into a relative error
/// (strain `|L − L₀|/L₀` for a distance, `|A − A₀|/A₀` for an area, ...).
pub trait RestScale {
    /// The scale (positive).
    fn rest_scale(&self) -> f64;
}

impl RestScale for Distance {
    fn rest_scale(&self) -> f64 {
        self.rest_length
    }
}
impl RestScale for Area {
    fn rest_scale(&self) -> f64 {
        self.rest_area
    }
}
impl RestScale for Volume {
    fn rest_scale(&self) -> f64 {
        self.rest_volume
    }
}
impl RestScale for Dihedral {
    /// Radians are already relative.
    fn rest_scale(&self) -> f64 {
        1.0
    }
}
impl RestScale for PointOnPlane {
    /// Metres: the distance is reported as is.
    fn rest_scale(&self) -> f64 {
        1.0
    }
}

/// Errors building a hard-constraint set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetError {
    /// Compliance was negative, NaN or infinite.
    InvalidCompliance,
    /// Constraint and compliance lists differ in length.
    LengthMismatch,
}

impl core::fmt::Display for SetError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::InvalidCompliance => "compliance must be finite and ≥ 0",
            Self::LengthMismatch => "constraints and compliances differ in length",
        })
    }
}

impl core::error::Error for SetError {}

/// Constraints of one type, each with a compliance `α ≥ 0` (`α = 0`: hard;
/// `α = 1/k`: the soft spring of stiffness `k`).
#[derive(Clone, Debug)]
pub struct HardSet<C, const N: usize, const R: usize> {
    name: &'static str,
    constraints: Vec<C>,
    compliance: Vec<f64>,
}

impl<C: PointConstraint<N, R>, const N: usize, const R: usize> HardSet<C, N, R> {
    /// Hard constraints (`α = 0`).
    pub fn hard(name: &'static str, constraints: Vec<C>) -> Self {
        let n = constraints.len();
        Self {
            name,
            constraints,
            compliance: alloc::vec![0.0; n],
        }
    }

    /// Constraints with one compliance each.
    ///
    /// # Errors
    /// [`SetError`] for a length mismatch or a compliance that is not finite and ≥ 0.
    pub fn compliant(
        name: &'static str,
        constraints: Vec<C>,
        compliance: Vec<f64>,
    ) -> Result<Self, SetError> {
        if constraints.len() != compliance.len() {
            return Err(SetError::LengthMismatch);
        }
        if !compliance.iter().all(|a| *a >= 0.0 && a.is_finite()) {
            return Err(SetError::InvalidCompliance);
        }
        Ok(Self {
            name,
            constraints,
            compliance,
        })
    }

    /// The constraints.
    pub fn constraints(&self) -> &[C] {
        &self.constraints
    }
}

/// What the formulations need from a set of constraints.
pub trait RowSet: Send + Sync {
    /// The set's name.
    fn name(&self) -> &'static str;
    /// Number of rows.
    fn rows(&self) -> usize;
    /// What kind of constraint the set holds, for reports: the constraint type's short
    /// name (`Distance`, `Area`, …) for a [`HardSet`]; `"custom"` unless an
    /// implementation says otherwise.
    fn kind(&self) -> &'static str {
        "custom"
    }
    /// Whether some row is compliant (`α > 0`). The default collects the compliances
    /// ([`RowSet::push_compliance`]); [`HardSet`] answers without allocating.
    fn compliant(&self) -> bool {
        let mut a = Vec::new();
        self.push_compliance(&mut a);
        a.iter().any(|&a| a > 0.0)
    }
    /// Largest stencil index plus one (0 when empty).
    fn max_index(&self) -> usize;
    /// Appends every constraint's rows at positions `x`.
    fn push_rows(&self, x: &[DVec3], rows: &mut ConstraintRows);
    /// Appends each row's compliance `α`.
    fn push_compliance(&self, out: &mut Vec<f64>);
    /// Appends each row's rest scale (see [`RestScale`]).
    fn push_scales(&self, out: &mut Vec<f64>);
    /// Appends each row's `J̇ v = vᵀ ∇²C_r v` (the velocity term of `C̈`).
    fn push_jdot_v(&self, x: &[DVec3], v: &[DVec3], out: &mut Vec<f64>);
}

impl<C, const N: usize, const R: usize> RowSet for HardSet<C, N, R>
where
    C: PointConstraint<N, R> + RestScale + Send + Sync,
{
    fn name(&self) -> &'static str {
        self.name
    }

    fn rows(&self) -> usize {
        self.constraints.len() * R
    }

    fn kind(&self) -> &'static str {
        let full = core::any::type_name::<C>();
        let base = full.split('<').next().unwrap_or(full);
        base.rsplit("::").next().unwrap_or(base)
    }

    fn compliant(&self) -> bool {
        self.compliance.iter().any(|&a| a > 0.0)
    }

    fn max_index(&self) -> usize {
        self.constraints
            .iter()
            .flat_map(|c| c.stencil())
            .map(|i| i + 1)
            .max()
            .unwrap_or(0)
    }

    fn push_rows(&self, x: &[DVec3], rows: &mut ConstraintRows) {
        for c in &self.constraints {
            rows.push(c, x);
        }
    }

    fn push_compliance(&self, out: &mut Vec<f64>) {
        for &a in &self.compliance {
            out.extend(core::iter::repeat_n(a, R));
        }
    }

    fn push_scales(&self, out: &mut Vec<f64>) {
        for c in &self.constraints {
            out.extend(core::iter::repeat_n(c.rest_scale(), R));
        }
    }

    fn push_jdot_v(&self, x: &[DVec3], v: &[DVec3], out: &mut Vec<f64>) {
        for c in &self.constraints {
            let (Some(xl), Some(vl)) = (c.gather(x), c.gather(v)) else {
                out.extend(core::iter::repeat_n(0.0, R));
                continue;
            };
            for r in 0..R {
                let mut w = [0.0; R];
                w[r] = 1.0;
                let h = c.curvature(&xl, &w);
                let mut s = 0.0;
                for i in 0..N {
                    for j in 0..N {
                        s += vl[i].dot(h.blocks[i][j] * vl[j]);
                    }
                }
                out.push(s);
            }
        }
    }
}

/// All the hard and compliant constraints of a scene.
#[derive(Default)]
pub struct Constraints {
    sets: Vec<Box<dyn RowSet>>,
}

impl core::fmt::Debug for Constraints {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_list()
            .entries(self.sets.iter().map(|s| (s.name(), s.rows())))
            .finish()
    }
}

impl Constraints {
    /// No constraints.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a set.
    pub fn add<C, const N: usize, const R: usize>(&mut self, set: HardSet<C, N, R>)
    where
        C: PointConstraint<N, R> + RestScale + Send + Sync + 'static,
    {
        self.sets.push(Box::new(set));
    }

    /// Adds a set of any kind (for example
    /// [`OneRingVolumes`](crate::volume_ring::OneRingVolumes)).
    pub fn add_rows(&mut self, set: Box<dyn RowSet>) {
        self.sets.push(set);
    }

    /// The sets.
    pub fn sets(&self) -> impl Iterator<Item = &dyn RowSet> {
        self.sets.iter().map(|s| s.as_ref())
    }

    /// Whether some row of some set is compliant (`α > 0`).
    pub fn any_compliant(&self) -> bool {
        self.sets.iter().any(|s| s.compliant())
    }

    /// Total number of rows.
    pub fn rows(&self) -> usize {
        self.sets.iter().map(|s| s.rows()).sum()
    }

    /// Largest stencil index plus one.
    pub fn max_index(&self) -> usize {
        self.sets.iter().map(|s| s.max_index()).max().unwrap_or(0)
    }

    /// Rebuilds `rows` at positions `x`.
    pub fn assemble(&self, x: &[DVec3], rows: &mut ConstraintRows) {
        rows.clear();
        for s in &self.sets {
            s.push_rows(x, rows);
        }
    }

    /// Per-row compliance.
    pub fn compliance(&self, out: &mut Vec<f64>) {
        out.clear();
        for s in &self.sets {
            s.push_compliance(out);
        }
    }

    /// Per-row rest scale.
    pub fn scales(&self, out: &mut Vec<f64>) {
        out.clear();
        for s in &self.sets {
            s.push_scales(out);
        }
    }

    /// Per-row `J̇ v`.
    pub fn jdot_v(&self, x: &[DVec3], v: &[DVec3], out: &mut Vec<f64>) {
        out.clear();
        for s in &self.sets {
            s.push_jdot_v(x, v, out);
        }
    }
}
