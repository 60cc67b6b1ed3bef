//! Joints between two bodies (or a body and the world) as rows of the KKT system.
//!
//! A [`Joint`] wraps one stock constraint of `constraint-core` ([`JointKind`]) with the
//! indices of its bodies and an optional viscous damping. Damping is not a force added
//! to the right-hand side but extra *compliant* rows of the same joint (velocity level):
//! the relative rate `J_d v` of the free coordinate(s) with compliance `1/(h d)`,
//! `J_d v' − λ_d/(h d) = 0`, which is exactly the implicit damping force
//! `−d J_dᵀ J_d v'`; keeping it on the joint keeps the KKT graph a tree (a damping
//! force between two bodies would couple their mass blocks directly).

use constraint_core::compound::MAX_DOF;
use constraint_core::{
    BlockBounds, BodyConstraint, Compound, DVec3, DistanceJoint, Fixed, Hinge, Pose, Prismatic,
    Spherical, TwistCurvature,
};

/// Largest number of rows a joint contributes (hard plus damping).
pub const MAX_ROWS: usize = 6;

/// The constraint a joint enforces.
// The compound joint is the largest variant (about 400 bytes); joints live once in the
// world's array, so plain `Copy` data is worth more than the bytes a `Box` would save.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointKind {
    /// Ball joint, 3 rows (damping: 3 rows on the relative angular velocity).
    Spherical(Spherical),
    /// Revolute joint, 5 rows (damping: 1 row on the rate about the axis).
    Hinge(Hinge),
    /// Slider, 5 rows (damping: 1 row on the sliding rate).
    Prismatic(Prismatic),
    /// Weld, 6 rows (no damping).
    Fixed(Fixed),
    /// Rod between two points, 1 row (damping: 1 row along the rod).
    Distance(DistanceJoint),
    /// Slides then hinges composed in one body as MuJoCo composes them, `6 − dof` rows
    /// (damping: one row per degree of freedom, on its rate `q̇_k`, with the
    /// per-dof coefficient `dof_damping[k]` plus [`Joint::damping`]).
    Compound(Compound, DofDamping),
}

/// Per-degree-of-freedom viscous damping of a [`JointKind::Compound`] (slides then
/// hinges, as the compound's coordinates), `≥ 0`.
pub type DofDamping = [f64; MAX_DOF];

/// A joint between `parent` (`None` = the world) and `child`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Joint {
    /// Body `a` of the constraint; `None` is the world (pose identity, infinite mass).
    pub parent: Option<usize>,
    /// Body `b` of the constraint.
    pub child: usize,
    /// The constraint.
    pub kind: JointKind,
    /// Viscous damping of the free coordinate(s) (N·m·s/rad or N·s/m), `≥ 0`.
    pub damping: f64,
}

/// A joint's coordinates at one configuration ([`crate::world::World`]'s coordinate
/// cache): the bits of the parent's and the child's poses (`x`, `q`, as the rows cache
/// keys them), the coordinates `q` (zeros past the joint's degrees of freedom) and, when
/// `has_rows`, their rate rows `G` (`q̇ = G v`). The coordinates are a function of the
/// joint (fixed once added) and these bits alone (every caller passes the zero hint of
/// [`Compound::coordinates`]), so an entry whose key matches the current poses holds the
/// bits a computation would give.
#[derive(Clone, Copy, Debug)]
pub(crate) struct KeptCoords {
    /// Bits of the parent's and the child's `x` and `q`.
    pub key: [u64; 14],
    /// Coordinates `q`.
    pub q: [f64; MAX_DOF],
    /// Whether `rows` holds the rate rows at `q`.
    pub has_rows: bool,
    /// Rate rows `G` (a compound joint's [`Compound::dof_rows`]).
    pub rows: [[DVec3; 4]; MAX_DOF],
}

/// How the rate rows use the coordinate cache ([`KeptCoords`]).
pub(crate) enum Kept<'k> {
    /// Computed, not kept.
    None,
    /// The entry of the current poses (the caller matched its key).
    Read(&'k KeptCoords),
    /// The poses' key and the joint's entry: taken from it when its key matches, else
    /// computed and written there.
    Write(&'k [u64; 14], &'k mut Option<KeptCoords>),
}

/// A joint's rows at one configuration.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JointRows {
    /// Number of hard rows (first) and of all rows.
    pub n_hard: usize,
    pub n: usize,
    /// `C` for hard rows (0 for damping rows).
    pub value: [f64; MAX_ROWS],
    /// Jacobian rows `[v_a, ω_a, v_b, ω_b]`.
    pub rows: [[DVec3; 4]; MAX_ROWS],
}

impl JointRows {
    /// No rows (`n = 0`), every entry zero.
    pub(crate) fn new() -> Self {
        Self {
            n_hard: 0,
            n: 0,
            value: [0.0; MAX_ROWS],
            rows: [[DVec3::ZERO; 4]; MAX_ROWS],
        }
    }

    fn push_hard<const R: usize>(&mut self, j: constraint_core::TwistJacobian<R>) {
        for r in 0..R {
            self.value[self.n] = j.value[r];
            self.rows[self.n] = j.rows[r];
            self.n += 1;
        }
        self.n_hard = self.n;
    }

    fn push_rate(&mut self, row: [DVec3; 4]) {
        self.value[self.n] = 0.0;
        self.rows[self.n] = row;
        self.n += 1;
    }
}

impl Joint {
    /// A bound on the scale of the joint's curvature per unit multiplier: the longer of
    /// the two anchor lever arms (m), plus 1 for joints with orientation rows (dot
    /// products of unit vectors), so that `|Σ λ_r ∂²C_r| ≤ 2 lever Σ|λ_r|`; a compound
    /// joint on skew hinge lines `δ` apart adds `(1 + arm)²/δ`.
    pub fn lever(&self) -> f64 {
        let (a, b) = match &self.kind {
            JointKind::Spherical(c) => (c.anchor_a(), c.anchor_b()),
            JointKind::Hinge(c) => (c.anchor_a(), c.anchor_b()),
            JointKind::Prismatic(c) => (c.anchor_a(), c.anchor_b()),
            JointKind::Fixed(c) => (c.anchor_a(), c.anchor_b()),
            JointKind::Distance(c) => (c.anchor_a(), c.anchor_b()),
            JointKind::Compound(c, _) => (c.anchor_a(), c.anchor_b()),
        };
        let arm = a.length().max(b.length());
        // Hinges on skew lines: the distance row (d·d − δ²)/(2δ) curves as
        // (JᵀJ + H_d[d])/δ, |JᵀJ| ≤ 2(1 + arm)².
        if let JointKind::Compound(c, _) = &self.kind {
            if let Some(delta) = c.skew_distance() {
                return arm + 1.0 + (1.0 + arm) * (1.0 + arm) / delta;
            }
        }
        match self.kind {
            JointKind::Spherical(_) | JointKind::Distance(_) => arm,
            _ => arm + 1.0,
        }
    }

    /// Number of hard rows.
    pub fn hard_rows(&self) -> usize {
        match self.kind {
            JointKind::Spherical(_) => 3,
            JointKind::Hinge(_) | JointKind::Prismatic(_) => 5,
            JointKind::Fixed(_) => 6,
            JointKind::Distance(_) => 1,
            JointKind::Compound(c, _) => c.rows(),
        }
    }

    /// Damping coefficient of degree of freedom `k` (compound joints: per dof plus
    /// [`Self::damping`]; others: [`Self::damping`]).
    pub fn dof_damping(&self, k: usize) -> f64 {
        match &self.kind {
            JointKind::Compound(_, d) => self.damping + d.get(k).copied().unwrap_or(0.0),
            _ => self.damping,
        }
    }

    /// Number of damping rows (0 when `damping == 0`).
    pub fn damping_rows(&self) -> usize {
        if let JointKind::Compound(c, d) = &self.kind {
            let any = self.damping > 0.0 || d[..c.dof()].iter().any(|v| *v > 0.0);
            return if any { c.dof() } else { 0 };
        }
        if !(self.damping > 0.0) {
            return 0;
        }
        match self.kind {
            JointKind::Spherical(_) => 3,
            JointKind::Hinge(_) | JointKind::Prismatic(_) | JointKind::Distance(_) => 1,
            JointKind::Fixed(_) => 0,
            JointKind::Compound(..) => 0,
        }
    }

    /// Number of rate rows the joint has when any of its coordinates is damped or has
    /// armature: one per degree of freedom (3 for a ball joint, the rod rate for a
    /// distance joint, none for a weld).
    pub fn rate_rows(&self) -> usize {
        match &self.kind {
            JointKind::Spherical(_) => 3,
            JointKind::Hinge(_) | JointKind::Prismatic(_) | JointKind::Distance(_) => 1,
            JointKind::Fixed(_) => 0,
            JointKind::Compound(c, _) => c.dof(),
        }
    }

    /// Value and Jacobian of the hard rows, then (when `with_damping` and the joint is
    /// damped) the damping rows.
    pub(crate) fn rows(&self, a: &Pose, b: &Pose, with_damping: bool) -> JointRows {
        self.rows_with(a, b, with_damping && self.damping_rows() > 0)
    }

    /// Value and Jacobian of the hard rows, then (when `rates`) the rate rows of every
    /// degree of freedom ([`Self::rate_rows`]).
    pub(crate) fn rows_with(&self, a: &Pose, b: &Pose, rates: bool) -> JointRows {
        let mut out = JointRows::new();
        self.rows_into(a, b, rates, &mut out);
        out
    }

    /// [`Self::rows_with`] written into `out`: the same bits in its first `out.n`
    /// entries, the ones every reader reads (`..n_hard` or `..n`); entries past `n` are
    /// left as they were (not cleared: the 640-byte memset per joint and assembly read
    /// nothing). A caller keeping the rows in place (the assembly's row cache) skips
    /// the copy of the rows a return by value costs.
    pub(crate) fn rows_into(&self, a: &Pose, b: &Pose, rates: bool, out: &mut JointRows) {
        self.rows_into_kept(a, b, rates, Kept::None, out);
    }

    /// [`Self::rows_into`] with the coordinate cache's entry of this joint ([`Kept`]): a
    /// compound joint's rate rows take the entry's coordinates (and rows) when it is of
    /// these poses, else computed (and, with [`Kept::Write`], written there); the same
    /// bits either way ([`KeptCoords`]).
    pub(crate) fn rows_into_kept(
        &self,
        a: &Pose,
        b: &Pose,
        rates: bool,
        kept: Kept<'_>,
        out: &mut JointRows,
    ) {
        out.n = 0;
        out.n_hard = 0;
        match &self.kind {
            JointKind::Spherical(c) => out.push_hard(c.jacobian(a, b)),
            // In place (the same bits as `jacobian`, without its 520-byte copy);
            // `MAX_ROWS ≥ 5`: the chunks always exist.
            JointKind::Hinge(c) => {
                if let (Some(v), Some(r)) =
                    (out.value.first_chunk_mut(), out.rows.first_chunk_mut())
                {
                    c.jacobian_into(a, b, v, r);
                }
                out.n = 5;
                out.n_hard = 5;
            }
            JointKind::Prismatic(c) => out.push_hard(c.jacobian(a, b)),
            JointKind::Fixed(c) => out.push_hard(c.jacobian(a, b)),
            JointKind::Distance(c) => out.push_hard(c.jacobian(a, b)),
            JointKind::Compound(c, _) => {
                // In place, as the hinge's (`MAX_ROWS ≥ MAX_DOF`).
                if let (Some(v), Some(r)) =
                    (out.value.first_chunk_mut(), out.rows.first_chunk_mut())
                {
                    c.jacobian6_into(a, b, v, r);
                }
                out.n = c.rows();
                out.n_hard = out.n;
            }
        }
        if rates {
            let first = out.rows[0];
            self.push_rates(a, b, first, kept, out);
        }
    }

    /// The rate rows alone, as [`Self::rows_with`] gives them (the same bits), after
    /// `hard_rows()` zero hard rows (value 0, Jacobian 0): for a right-hand side that
    /// reads only the rate rows, without the cost of the hard rows' Jacobian; a compound
    /// joint's through the coordinate cache (`kept`, as in [`Self::rows_into_kept`]).
    pub(crate) fn rate_rows_only_kept(&self, a: &Pose, b: &Pose, kept: Kept<'_>) -> JointRows {
        let mut out = JointRows::new();
        out.n = self.hard_rows();
        out.n_hard = out.n;
        // A distance joint's rate row is its hard row.
        let first = match &self.kind {
            JointKind::Distance(c) => c.jacobian(a, b).rows[0],
            _ => [DVec3::ZERO; 4],
        };
        self.push_rates(a, b, first, kept, &mut out);
        out
    }

    /// Appends the rate rows (one per degree of freedom) to `out`; `first` is the first
    /// hard row (a distance joint's rate row); `kept` as in [`Self::rows_into_kept`].
    fn push_rates(
        &self,
        a: &Pose,
        b: &Pose,
        first: [DVec3; 4],
        kept: Kept<'_>,
        out: &mut JointRows,
    ) {
        match &self.kind {
            JointKind::Spherical(_) => {
                for e in [DVec3::X, DVec3::Y, DVec3::Z] {
                    out.push_rate([DVec3::ZERO, -e, DVec3::ZERO, e]);
                }
            }
            JointKind::Hinge(c) => {
                let u = b.q * c.axis_b();
                out.push_rate([DVec3::ZERO, -u, DVec3::ZERO, u]);
            }
            JointKind::Prismatic(c) => out.push_rate(c.displacement_row(a, b)),
            JointKind::Distance(_) => out.push_rate(first),
            JointKind::Fixed(_) => {}
            JointKind::Compound(c, _) => {
                let rows = match kept {
                    Kept::Read(e) if e.has_rows => e.rows,
                    Kept::Read(e) => c.dof_rows(a, b, &e.q),
                    Kept::Write(key, Some(e)) if crate::world::same_key(&e.key, key) => {
                        if !e.has_rows {
                            e.rows = c.dof_rows(a, b, &e.q);
                            e.has_rows = true;
                        }
                        e.rows
                    }
                    Kept::Write(key, slot) => {
                        let q = c.coordinates(a, b, &[0.0; MAX_DOF]);
                        let rows = c.dof_rows(a, b, &q);
                        *slot = Some(KeptCoords {
                            key: *key,
                            q,
                            has_rows: true,
                            rows,
                        });
                        rows
                    }
                    Kept::None => {
                        let q = c.coordinates(a, b, &[0.0; MAX_DOF]);
                        c.dof_rows(a, b, &q)
                    }
                };
                for row in rows.iter().take(c.dof()) {
                    out.push_rate(*row);
                }
            }
        }
    }

    /// The hard rows' values `C` (first [`Self::hard_rows`] entries).
    pub fn value(&self, a: &Pose, b: &Pose) -> [f64; MAX_ROWS] {
        let mut v = [0.0; MAX_ROWS];
        match &self.kind {
            JointKind::Spherical(c) => v[..3].copy_from_slice(&c.value(a, b)),
            JointKind::Hinge(c) => v[..5].copy_from_slice(&c.value(a, b)),
            JointKind::Prismatic(c) => v[..5].copy_from_slice(&c.value(a, b)),
            JointKind::Fixed(c) => v[..6].copy_from_slice(&c.value(a, b)),
            JointKind::Distance(c) => v[..1].copy_from_slice(&c.value(a, b)),
            JointKind::Compound(c, _) => {
                let n = c.rows();
                v[..n].copy_from_slice(&c.value6(a, b)[..n]);
            }
        }
        v
    }

    /// [`Self::value`] written into `v` (the same bits in its first
    /// [`Self::hard_rows`] entries; the others are left as they were), without the
    /// zeroed array and its copy; a hinge also returns the directions `[n, u]` its
    /// orientation rows rotated ([`Hinge::value_and_dirs`]), from which
    /// [`Hinge::angle_from`] gives its angle at these poses without rotating them again.
    /// (Kept beside [`Self::value`] rather than under it: `value` written as a call of
    /// this one cost half_cheetah controlled about 33k more `World::step` instructions
    /// over 2 s, RATTLE's drift no longer inlining it.)
    pub fn value_into(&self, a: &Pose, b: &Pose, v: &mut [f64; MAX_ROWS]) -> Option<[DVec3; 2]> {
        match &self.kind {
            JointKind::Spherical(c) => v[..3].copy_from_slice(&c.value(a, b)),
            // `MAX_ROWS ≥ 5`: the first five entries always exist.
            JointKind::Hinge(c) => return v.first_chunk_mut().map(|h| c.value_and_dirs(a, b, h)),
            JointKind::Prismatic(c) => v[..5].copy_from_slice(&c.value(a, b)),
            JointKind::Fixed(c) => v[..6].copy_from_slice(&c.value(a, b)),
            JointKind::Distance(c) => v[..1].copy_from_slice(&c.value(a, b)),
            JointKind::Compound(c, _) => {
                let n = c.rows();
                v[..n].copy_from_slice(&c.value6(a, b)[..n]);
            }
        }
        None
    }

    /// Largest separation of the joint's anchor points (m): the norm of the three
    /// position rows for spherical, hinge and fixed joints, the two sliding-plane rows
    /// for a prismatic joint, `|C|` for a distance joint.
    pub fn separation(&self, a: &Pose, b: &Pose) -> f64 {
        self.separation_of(&self.value(a, b))
    }

    /// [`Self::separation`] from the hard rows' values `v` ([`Self::value`] at the same
    /// poses), bit for bit: for a caller that needs both without evaluating `C` twice.
    pub fn separation_of(&self, v: &[f64; MAX_ROWS]) -> f64 {
        match &self.kind {
            JointKind::Prismatic(_) => libm::sqrt(v[0] * v[0] + v[1] * v[1]),
            JointKind::Distance(_) => v[0].abs(),
            JointKind::Compound(c, _) => {
                let n = c.translation_rows();
                libm::sqrt(v[..n].iter().map(|x| x * x).sum::<f64>())
            }
            _ => libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]),
        }
    }

    /// Upper bounds on the Frobenius norms of the angular diagonal blocks `(θ_a, θ_a)`
    /// and `(θ_b, θ_b)` of [`Self::curvature`] (exact arithmetic), for a hinge or a weld
    /// ([`Hinge::angular_curvature_bounds`], [`Fixed::angular_curvature_bounds`]);
    /// `None` for the other kinds.
    pub fn angular_curvature_bounds(
        &self,
        a: &Pose,
        b: &Pose,
        w: &[f64; MAX_ROWS],
    ) -> Option<[f64; 2]> {
        match &self.kind {
            JointKind::Hinge(c) => {
                Some(c.angular_curvature_bounds(a, b, &[w[0], w[1], w[2], w[3], w[4]]))
            }
            JointKind::Fixed(c) => Some(c.angular_curvature_bounds(a, b, w)),
            _ => None,
        }
    }

    /// Tighter upper bounds than [`Self::angular_curvature_bounds`] on the angular
    /// diagonal blocks of [`Self::curvature`] as computed (round-off included): their
    /// Frobenius norms and the largest eigenvalues of their positive semi-definite
    /// parts ([`BlockBounds`]), for a hinge or a weld ([`Hinge::angular_block_bounds`],
    /// [`Fixed::angular_block_bounds`]: a few rotations, not the curvature); `None` for
    /// the other kinds.
    pub fn angular_block_bounds(
        &self,
        a: &Pose,
        b: &Pose,
        w: &[f64; MAX_ROWS],
    ) -> Option<[BlockBounds; 2]> {
        match &self.kind {
            JointKind::Hinge(c) => {
                Some(c.angular_block_bounds(a, b, &[w[0], w[1], w[2], w[3], w[4]]))
            }
            JointKind::Fixed(c) => Some(c.angular_block_bounds(a, b, w)),
            _ => None,
        }
    }

    /// `Σ_r w_r ∂²C_r` of the hard rows (`w` beyond [`Self::hard_rows`] ignored).
    pub fn curvature(&self, a: &Pose, b: &Pose, w: &[f64; MAX_ROWS]) -> TwistCurvature {
        match &self.kind {
            JointKind::Spherical(c) => c.curvature(a, b, &[w[0], w[1], w[2]]),
            JointKind::Hinge(c) => c.curvature(a, b, &[w[0], w[1], w[2], w[3], w[4]]),
            JointKind::Prismatic(c) => c.curvature(a, b, &[w[0], w[1], w[2], w[3], w[4]]),
            JointKind::Fixed(c) => c.curvature(a, b, w),
            JointKind::Distance(c) => c.curvature(a, b, &[w[0]]),
            JointKind::Compound(c, _) => c.curvature6(a, b, w),
        }
    }
}
