//! Hinge angles continuous across `±π` (issue 13).
//!
//! A hinge's angle from `atan2` lies in `(−π, π]`; MuJoCo's hinge coordinate is
//! unbounded. Each hinge angle (a hinge joint's, and each hinge coordinate of a compound
//! joint) is therefore taken on the branch nearest the joint's last recorded angle
//! `q_prev`: `q = θ + 2πk`, `k = round((q_prev − θ)/2π)`, so a hinge turning past `π`
//! reads `π + ε` rather than `−π + ε`, and its limits (the projection's limit error and
//! rows), springs and actuators see the angle the joint turned to.
//!
//! `k = 0` whenever `|q_prev − θ| ≤ π` (and before anything is recorded, `q_prev` NaN):
//! then `θ` itself is returned, the same bits as before, so a run in which no angle
//! crosses `±π` is unchanged.
//!
//! The angles are recorded at the start of a step ([`World::record_turned_angles`]), and
//! only when they may have moved far: a joint's angle turns by at most the sum of its
//! bodies' turns, and a body's turn since the last record is bounded by its orientation's
//! chord, `θ ≤ π|p − q|` (unit quaternions with `p·q ≥ 0`; `|p + q|` otherwise,
//! `projection/limits.rs`). While both chords are below `1/(2π)` the angle is within
//! 1 rad of the recorded one, and a step turns it by far less than the `π − 1` left, so
//! the recorded angle still picks the continuous branch. A hinge whose limits keep it in
//! a range narrower than [`WIDE`], away from the cut, is not recorded at all: any two of
//! its angles are within `π` of each other and read `atan2`'s values.

use alloc::vec::Vec;
use core::f64::consts::{PI, TAU};

use constraint_core::compound::MAX_DOF;
use constraint_core::DQuat;

use super::*;

/// Widest range (rad) of a hinge whose angle is not recorded: two angles in a range this
/// wide, each at most `(π − WIDE)/2 ≈ 0.17` rad past a bound, are within `π` of each
/// other.
const WIDE: f64 = 2.8;

/// Margin (rad) of such a range from the cut at `±π`: inside it `atan2`'s angle, read
/// without any record (NaN), is the continuous one.
const CUT_MARGIN: f64 = 0.2;

/// Largest squared orientation chord `|p − q|²` of each body of a joint since its last
/// record that skips a new one: `π(√c_a + √c_b) < 1` rad (module doc).
const TURNED: f64 = 1.0 / (4.0 * PI * PI);

/// The last recorded coordinates of each joint (NaN: none recorded), the branch
/// reference of its hinge angles, and its bodies' orientations then.
#[derive(Clone, Debug, Default)]
pub(in crate::world) struct AngleBranches {
    prev: Vec<[f64; MAX_DOF]>,
    at: Vec<[DQuat; 2]>,
    /// Per joint: whether its angles are recorded (the last step's classification).
    tracked: Vec<bool>,
}

impl AngleBranches {
    /// Whether joint `ji`'s angles are recorded (else never: its angles are `atan2`'s).
    #[inline]
    pub(in crate::world) fn tracks(&self, ji: usize) -> bool {
        self.tracked.get(ji).copied().unwrap_or(false)
    }

    /// `θ` (an angle in `(−π, π]`) on the branch nearest the last recorded value of
    /// coordinate `d` of joint `ji`: `θ + 2πk`, `k = round((q_prev − θ)/2π)`; `θ` itself
    /// (same bits) when `|q_prev − θ| ≤ π` or nothing is recorded.
    #[inline]
    pub(in crate::world) fn continuous(&self, ji: usize, d: usize, theta: f64) -> f64 {
        let Some(prev) = self.prev.get(ji) else {
            return theta;
        };
        let gap = prev[d] - theta;
        // NaN (nothing recorded) fails the comparison: `θ` as it is.
        if !(gap.abs() > PI) {
            return theta;
        }
        theta + TAU * libm::round(gap / TAU)
    }
}

/// Squared chord between two orientations, the nearer of `q` and `−q`.
fn chord(p: DQuat, q: DQuat) -> f64 {
    f64::min((p - q).length_squared(), (p + q).length_squared())
}

impl World {
    /// At the start of a step: records the hinge angles (a hinge joint's, a compound
    /// joint's hinge coordinates) that may cross `±π` — unlimited, or limited to a range
    /// wider than [`WIDE`] or within [`CUT_MARGIN`] of `±π` — when the joint's bodies
    /// turned far enough since the last record (module doc). A first record starts from
    /// the reference angle: the middle of a finite range, else 0.
    pub(in crate::world) fn record_turned_angles(&mut self) {
        let n = self.joints.len();
        if self.proj.branch.prev.len() != n {
            self.proj.branch.prev.resize(n, [f64::NAN; MAX_DOF]);
            self.proj.branch.at.resize(n, [DQuat::IDENTITY; 2]);
            self.proj.branch.tracked.resize(n, false);
        }
        for ji in 0..n {
            let j = &self.joints[ji];
            let (first, count) = match &j.kind {
                JointKind::Hinge(_) => (0, 1),
                JointKind::Compound(c, _) => (c.slides(), c.hinges()),
                _ => (0, 0),
            };
            let narrow = |l: &Option<[f64; 2]>| {
                l.is_some_and(|[lo, hi]| {
                    hi - lo <= WIDE && -PI + CUT_MARGIN < lo && hi < PI - CUT_MARGIN
                })
            };
            let limits = self.limits[ji].get(first..first + count).unwrap_or(&[]);
            let tracked = count > 0 && !limits.iter().all(narrow);
            self.proj.branch.tracked[ji] = tracked;
            if !tracked {
                continue;
            }
            let qa = j.parent.map_or(DQuat::IDENTITY, |i| self.bodies[i].pose.q);
            let qb = self.bodies[j.child].pose.q;
            let branch = &mut self.proj.branch;
            let [pa, pb] = branch.at[ji];
            if branch.prev[ji][first].is_nan() {
                for (d, l) in limits.iter().enumerate() {
                    branch.prev[ji][first + d] = match l {
                        Some([lo, hi]) if lo.is_finite() && hi.is_finite() => 0.5 * (lo + hi),
                        _ => 0.0,
                    };
                }
            } else if chord(pa, qa) < TURNED && chord(pb, qb) < TURNED {
                continue;
            }
            let Some(q) = self.coordinates_of(ji) else {
                continue;
            };
            let branch = &mut self.proj.branch;
            branch.prev[ji][first..first + count].copy_from_slice(&q[first..first + count]);
            branch.at[ji] = [qa, qb];
        }
    }
}
