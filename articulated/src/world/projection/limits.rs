//! The projection's joint-limit error without a hinge's angle where the angle cannot
//! have reached a bound since the projection started.
//!
//! A hinge's angle is `q = atan2(u·(n×m), n·m)` (`constraint_core::Hinge::angle`: `n`
//! the parent's reference axis, `u` the child's hinge axis, `m` the child's zero
//! direction, unit vectors with `m ⊥ u`). Rotating the parent by an angle `θ_a` and the
//! child by `θ_b` moves `n` by at most `θ_a` and `m`, `u` by at most `θ_b` (a rotation by
//! `θ` moves a unit vector by `2 sin(θ/2)|v_⊥| ≤ θ`), so the point `p = (n·m, u·(n×m))`
//! moves by at most `D = (θ_a + θ_b) + (θ_a + 2θ_b)` (one term per factor of each
//! product of unit vectors). Its distance from the origin at the start is
//! `r₀ = √(1 − (n·u)²)` (`m` is a unit vector in the plane `⊥ u` spanned by the
//! orthogonal `n − (n·u)u` and `u × n`, both of length `r₀`), with `n·u` the joint's
//! fourth value row. While `D < r₀` the angle turns by at most `asin(D/r₀) ≤ (π/2)D/r₀`.
//! The bodies' turns come from their orientations: for unit quaternions `p`, `q` with
//! `p·q ≥ 0`, `|p − q| = 2 sin(θ/4)`, so `θ ≤ π|p − q|` (`|p + q|` for the other sign).
//!
//! A hinge whose start angle is farther than that reach (plus a rounding slack) from
//! both bounds and from the branch cut at `±π` is inside its range, so its term of
//! `max(lo − q, q − hi, 0)` is the `0` it would be if computed: the error and the
//! violated-limit flag are the same bits.
//!
//! The angles are continuous across `±π` (`branch.rs`): `q₀` may lie past `±π`, and the
//! test against the cut stays only as a conservative bound (such a hinge is evaluated).

use core::f64::consts::{FRAC_PI_2, PI};

use constraint_core::DQuat;

use super::*;

/// Rounding slack (rad) on a hinge's reach: the angles' and the turns' round-off are
/// about 1e-16 rad.
const SLACK: f64 = 1e-12;

/// What the hinges' limits are measured against during one projection.
#[derive(Clone, Debug, Default)]
pub(in crate::world) struct LimitRefs {
    /// The bodies' orientations when the projection started.
    start: Vec<DQuat>,
    /// Per joint: the first coordinate at the start (NaN: not measured).
    q0: Vec<f64>,
    /// Per joint: a hinge's start angle `q₀` and `r₀` (module doc), when measured.
    hinge: Vec<Option<(f64, f64)>>,
    /// The next error evaluation is at the start poses (it records the references).
    recording: bool,
    /// `start` holds this projection's start orientations.
    started: bool,
    /// The projection's tolerance: a limit closer than it to its bound is active.
    tolerance: f64,
}

impl World {
    /// At the start of a projection: the next [`Self::max_limit_violation_tracked`]
    /// (at these poses) records the hinges' angles.
    pub(in crate::world) fn start_limit_refs(&mut self, tolerance: f64) {
        let refs = &mut self.proj.limits;
        refs.tolerance = tolerance;
        refs.q0.clear();
        refs.q0.resize(self.joints.len(), f64::NAN);
        refs.recording = true;
        refs.started = false;
    }

    /// Records the bodies' orientations and the hinges' `(q₀, r₀)` at the start of a
    /// projection, before its first iteration moves them and after its first error
    /// evaluation (a projection that ends at once never needs them).
    pub(in crate::world) fn record_start_orientations(&mut self) {
        let mut refs = core::mem::take(&mut self.proj.limits);
        refs.start.clear();
        refs.start.extend(self.bodies.iter().map(|b| b.pose.q));
        refs.hinge.clear();
        refs.hinge
            .extend((0..self.joints.len()).map(|ji| self.hinge_ref(ji, refs.q0[ji])));
        refs.started = true;
        self.proj.limits = refs;
    }

    /// The largest violation of a joint limit, `max(lo − q, q − hi, 0)` (the same bits
    /// as evaluating every limited joint's coordinates), without the angles of hinges that cannot have
    /// reached a bound since the projection started (module doc). Call after
    /// `hard_separation_keeping_values` at the same poses.
    pub(in crate::world) fn max_limit_violation_tracked(&mut self) -> (f64, bool) {
        let recording = self.proj.limits.recording;
        let tracking = !recording && self.proj.limits.started;
        let mut worst: f64 = 0.0;
        let mut nearest = f64::NEG_INFINITY;
        let tol = self.proj.limits.tolerance;
        self.proj.near.clear();
        for ji in 0..self.joints.len() {
            if self.limits[ji].iter().all(|l| l.is_none()) {
                continue;
            }
            if tracking && self.hinge_inside(ji) {
                continue;
            }
            let Some(q) = self.limit_coordinates(ji) else {
                continue;
            };
            if recording {
                self.proj.limits.q0[ji] = q[0];
            }
            let mut near = false;
            for (d, lim) in self.limits[ji].iter().enumerate() {
                if let Some([lo, hi]) = lim {
                    worst = worst.max(lo - q[d]).max(q[d] - hi);
                    nearest = nearest.max(lo - q[d]).max(q[d] - hi);
                    // `q − lo < tol` or `hi − q < tol`: as `push_violated_limits` tests.
                    near |= q[d] - lo < tol || hi - q[d] < tol;
                }
            }
            if near {
                self.proj.near.push(ji);
            }
        }
        self.proj.limits.recording = false;
        (worst, nearest > -tol)
    }

    /// Joint `ji`'s coordinates for its limits' error: a hard hinge's angle from the
    /// directions its rows' values rotated at these poses (`Scratch::dirs`, the same
    /// operations as [`constraint_core::Hinge::angle`], so the same bits as
    /// [`Self::coordinates_of`]), on its continuous branch; other joints'
    /// from [`Self::coordinates_kept`].
    fn limit_coordinates(&mut self, ji: usize) -> Option<[f64; MAX_DOF]> {
        if let Some(q) = self.kept_hinge_angle(ji) {
            return Some(q);
        }
        self.coordinates_kept(ji)
    }

    /// Joint `ji`'s coordinates for the projection's error at the poses of the last
    /// `hard_separation_keeping_values`: a hard hinge's angle as in
    /// [`Self::limit_coordinates`], other joints' from [`Self::coordinates_of`] (the
    /// same bits; the equalities' error, `max_equality_violation_by`).
    pub(in crate::world) fn error_coordinates(&self, ji: usize) -> Option<[f64; MAX_DOF]> {
        if let Some(q) = self.kept_hinge_angle(ji) {
            return Some(q);
        }
        self.coordinates_of(ji)
    }

    /// A hard hinge's angle (in `q[0]`, on its continuous branch) from the directions
    /// its rows' values rotated at these poses (`Scratch::dirs`, when current): only
    /// `m = R_b m_b` and the `atan2` left to compute. `None` for other joints, a
    /// compliant hinge, or directions not of these poses. (Always inlined: called out
    /// of line, the limits' error cost half_cheetah controlled 0.06 %.)
    #[inline(always)]
    fn kept_hinge_angle(&self, ji: usize) -> Option<[f64; MAX_DOF]> {
        let joint = &self.joints[ji];
        if let JointKind::Hinge(c) = &joint.kind {
            let dirs = self.proj.dirs.get(ji).filter(|_| self.proj.values_current);
            if let (Some(&[n, u]), false) = (dirs, self.is_soft(ji)) {
                let mut q = [0.0; MAX_DOF];
                q[0] = c.angle_from(&self.bodies[joint.child].pose, n, u);
                self.continue_angles(ji, &mut q);
                return Some(q);
            }
        }
        None
    }

    /// `(q₀, r₀)` of hinge `ji` at the current poses, `q₀` its angle there (NaN: not
    /// measured); `None` for other joints and for a compliant hinge (its values are not
    /// kept).
    fn hinge_ref(&self, ji: usize, q0: f64) -> Option<(f64, f64)> {
        if q0.is_nan()
            || !matches!(self.joints[ji].kind, JointKind::Hinge(_))
            || self.is_soft(ji)
            || !self.proj.values_current
        {
            return None;
        }
        let s = self.proj.values.get(ji)?[3];
        Some((q0, libm::sqrt(1.0 - s * s)))
    }

    /// Whether hinge `ji`'s angle is inside its range at the current poses by the
    /// reach of its start angle (module doc); only once the start is recorded.
    fn hinge_inside(&self, ji: usize) -> bool {
        let refs = &self.proj.limits;
        let Some((q0, r0)) = refs.hinge.get(ji).copied().flatten() else {
            return false;
        };
        let Some([lo, hi]) = self.limits[ji][0] else {
            return false;
        };
        let turn = |b: Option<usize>| {
            b.map_or(0.0, |i| {
                let (p, q) = (refs.start[i], self.bodies[i].pose.q);
                let chord = f64::min((p - q).length_squared(), (p + q).length_squared());
                PI * libm::sqrt(chord)
            })
        };
        let joint = &self.joints[ji];
        let (ta, tb) = (turn(joint.parent), turn(Some(joint.child)));
        let d = 2.0 * ta + 3.0 * tb;
        if !(d < 0.5 * r0) {
            return false;
        }
        let reach = FRAC_PI_2 * d / r0 + SLACK;
        let (low, high) = (q0 - reach, q0 + reach);
        let tol = refs.tolerance;
        lo + tol < low && high + tol < hi && -PI < low && high < PI
    }
}
