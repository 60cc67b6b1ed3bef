//! A tree-ordered projection of the hard tree joints before the Newton projection
//! (issue 13): the sweep.
//!
//! The velocity level leaves the joints `O(h²)` apart when bodies turn fast (controlled
//! runs: about 2e-4 m), so every step of those runs took a global Newton step (assemble,
//! factor, solve, re-check). The sweep visits the tree's joints parents first; at each
//! hard joint it moves only the joint's tree child `c` (the parent is already
//! corrected and does not move again) by the mass-weighted minimum-norm step of that
//! joint alone,
//!
//! `δ_c = −M_c⁻¹ J_cᵀ (J_c M_c⁻¹ J_cᵀ)⁻¹ C`,
//!
//! `J_c` the joint's hard rows' columns of the child (≤ 6 × 6, factored once by
//! Cholesky), then one chord step with the same factor at the new `C` unless the
//! separation is already below `FINE` of the tolerance. After one sweep every tree joint
//! is satisfied; the projection's error then decides whether the Newton loop still runs
//! (limits, contacts, equalities, tendon ranges, loop joints). A joint whose separation
//! is within the tolerance is not moved, so a projection that would have ended at once
//! ends at once with the same bits.
//!
//! Left to the Newton loop: loop-closing joints (not in the tree), compliant joints
//! (their separation is their spring's; their children are still swept against them
//! as they are), a step whose first move did not decrease the joint's separation (it
//! is taken back), and a joint whose `J_c M_c⁻¹ J_cᵀ` has a non-positive pivot.
//!
//! Trees whose root is a free body are swept only when asked
//! ([`World::set_projection_sweep`]): the root stays and its descendants move, so the
//! tree's centre of mass moves, where the global mass-weighted step keeps it (its
//! `Σ m δx = 0` for joints alone). The whole tree is then translated by minus the
//! mass-weighted mean displacement (joint values do not change under a common
//! translation), which restores the centre of mass and, on velocity-corrected
//! projections, the linear momentum.

use constraint_core::rigid::rotate_by;
use constraint_core::DVec3;

use super::*;
use crate::joint::JointRows;
use crate::tree::NONE;

/// The separation (fraction of the projection's tolerance) below which the first step's
/// result is kept without the chord step (about round-off for the unilateral floor,
/// 1e-8 m · 1e-3).
const FINE: f64 = 1e-3;

/// Which trees the sweep visits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(in crate::world) enum SweepMode {
    /// No sweep (the Newton projection alone).
    #[default]
    Off,
    /// Trees whose root joint is attached to the world.
    Rooted,
    /// Those and trees whose root is a free body (centre of mass restored).
    All,
}

/// The sweep's setting and reused buffers.
#[derive(Clone, Debug, Default)]
pub(in crate::world) struct SweepScratch {
    /// Which trees are swept.
    pub(in crate::world) mode: SweepMode,
    /// Per tree node: its joint (joint nodes) or `NONE`.
    node_joint: Vec<usize>,
    /// Per tree node: the root node of its tree.
    root: Vec<usize>,
    /// Per body: the displacement the sweep gave it.
    moved: Vec<DVec3>,
    /// Per root body of a free tree: `(Σ m, Σ m δx)` of its bodies.
    centre: Vec<(f64, DVec3)>,
}

impl World {
    /// Sets whether the position projection first sweeps the tree joints in tree order
    /// (`projection/sweep.rs`): `rooted` for trees attached to the world, `floating`
    /// also for trees rooted at a free body (their centre of mass restored). Off by
    /// default (the Newton projection alone).
    pub fn set_projection_sweep(&mut self, rooted: bool, floating: bool) {
        self.proj.sweep.mode = match (rooted, floating) {
            (_, true) => SweepMode::All,
            (true, false) => SweepMode::Rooted,
            (false, false) => SweepMode::Off,
        };
    }

    /// Whether the projection sweeps `(rooted trees, floating trees)`
    /// ([`Self::set_projection_sweep`]).
    pub fn projection_sweep(&self) -> (bool, bool) {
        match self.proj.sweep.mode {
            SweepMode::Off => (false, false),
            SweepMode::Rooted => (true, false),
            SweepMode::All => (true, true),
        }
    }

    /// One sweep of the hard tree joints (module doc) at `tolerance`; with `h`, the
    /// velocities get the displacement over `h` (`v += δx/h`, `ω += δθ/h`), as the
    /// Newton projection's velocity-corrected steps. Returns whether a body moved.
    pub(super) fn sweep_tree_joints(&mut self, tolerance: f64, h: Option<f64>) -> bool {
        let mode = self.proj.sweep.mode;
        if mode == SweepMode::Off {
            return false;
        }
        let mut s = core::mem::take(&mut self.proj.sweep);
        let nb = self.bodies.len();
        let n_nodes = self.solver.parent.len();
        s.node_joint.clear();
        s.node_joint.resize(n_nodes, NONE);
        for (j, &n) in self.solver.joint_node.iter().enumerate() {
            if let Some(slot) = s.node_joint.get_mut(n) {
                *slot = j;
            }
        }
        s.root.clear();
        s.root.resize(n_nodes, NONE);
        s.moved.clear();
        s.moved.resize(nb, DVec3::ZERO);
        let mut any = false;
        let mut any_free = false;
        let mut rows = JointRows::new();
        // Parents before children: the elimination order reversed.
        for k in (0..self.solver.order.len()).rev() {
            let node = self.solver.order[k];
            let p = self.solver.parent[node];
            let root = if p == NONE { node } else { s.root[p] };
            s.root[node] = root;
            if node < nb {
                continue;
            }
            let j = s.node_joint[node];
            if j == NONE || self.is_soft(j) {
                continue;
            }
            let free = root < nb;
            if free && mode != SweepMode::All {
                continue;
            }
            let joint = &self.joints[j];
            // The joint's tree child: the body that is not its tree parent.
            let (moved, is_b) = match joint.parent {
                Some(a) if a == joint.child => continue,
                Some(a) if p == joint.child => (a, false),
                _ => (joint.child, true),
            };
            if let Some((dx, dth)) = self.sweep_joint(j, moved, is_b, tolerance, &mut rows) {
                any = true;
                any_free |= free;
                s.moved[moved] += dx;
                if let Some(h) = h {
                    let b = &mut self.bodies[moved];
                    b.v += dx / h;
                    b.omega += dth / h;
                }
            }
        }
        if any_free {
            self.restore_free_centres(&mut s, h);
        }
        self.proj.sweep = s;
        if any {
            self.proj.values_current = false;
        }
        any
    }

    /// Translates each swept free tree by minus its bodies' mass-weighted mean
    /// displacement (module doc); with `h`, the velocities by the same over `h`.
    fn restore_free_centres(&mut self, s: &mut SweepScratch, h: Option<f64>) {
        let nb = self.bodies.len();
        s.centre.clear();
        s.centre.resize(nb, (0.0, DVec3::ZERO));
        for i in 0..nb {
            let r = s.root[i];
            if r < nb {
                let m = self.bodies[i].mass();
                let c = &mut s.centre[r];
                c.0 += m;
                c.1 += s.moved[i] * m;
            }
        }
        for i in 0..nb {
            let r = s.root[i];
            if r >= nb {
                continue;
            }
            let (m, mdx) = s.centre[r];
            if !(m > 0.0) || mdx == DVec3::ZERO {
                continue;
            }
            let shift = mdx / m;
            let b = &mut self.bodies[i];
            b.pose.x -= shift;
            if let Some(h) = h {
                b.v -= shift / h;
            }
        }
    }

    /// Moves body `moved` (the joint's child `b` when `is_b`, else its `a`) so that hard
    /// joint `j` is closed: a Newton step and at most one chord step (module doc).
    /// Returns the displacement `(δx, δθ)`, or `None` when the joint is within
    /// `tolerance` or the step was not taken.
    fn sweep_joint(
        &mut self,
        j: usize,
        moved: usize,
        is_b: bool,
        tolerance: f64,
        rows: &mut JointRows,
    ) -> Option<(DVec3, DVec3)> {
        let joint = &self.joints[j];
        let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
        let b = self.bodies[joint.child].pose;
        joint.rows_into(&a, &b, false, rows);
        let n = rows.n_hard;
        let sep0 = joint.separation_of(&rows.value);
        if !(sep0 > tolerance) {
            return None;
        }
        let body = &self.bodies[moved];
        let (lin, ang) = if is_b { (2, 3) } else { (0, 1) };
        // `M_c⁻¹ J_cᵀ` per row: `(j_lin / m, I_w⁻¹ j_ang)`, `I_w⁻¹ = R I⁻¹ Rᵀ`.
        let r = body.rotation();
        let iinv = r * body.inv_inertia() * r.transpose();
        let inv_m = 1.0 / body.mass();
        let mut w = [[DVec3::ZERO; 2]; MAX_ROWS];
        for k in 0..n {
            w[k] = [rows.rows[k][lin] * inv_m, iinv * rows.rows[k][ang]];
        }
        // `A = J_c M_c⁻¹ J_cᵀ`, lower triangle, then its Cholesky factor in place.
        let mut l = [[0.0; MAX_ROWS]; MAX_ROWS];
        for p in 0..n {
            for q in 0..=p {
                l[p][q] = rows.rows[p][lin].dot(w[q][0]) + rows.rows[p][ang].dot(w[q][1]);
            }
        }
        if !cholesky(&mut l, n) {
            return None;
        }
        let start = self.bodies[moved].pose;
        let mut c = rows.value;
        let (dx, dth) = chol_step(&l, &w, &mut c, n);
        self.bodies[moved].pose.x = start.x + dx;
        self.bodies[moved].pose.q = rotate_by(start.q, dth);
        // The separation after the Newton step: kept, chord step, or taken back.
        let joint = &self.joints[j];
        let a = joint.parent.map_or(Pose::IDENTITY, |i| self.bodies[i].pose);
        let b = self.bodies[joint.child].pose;
        let mut c = joint.value(&a, &b);
        let sep1 = joint.separation_of(&c);
        if !(sep1 < sep0) {
            self.bodies[moved].pose = start;
            return None;
        }
        if sep1 <= FINE * tolerance {
            return Some((dx, dth));
        }
        // Chord step: the same factor and rows at the new `C`.
        let (dx2, dth2) = chol_step(&l, &w, &mut c, n);
        let pose = self.bodies[moved].pose;
        self.bodies[moved].pose.x = pose.x + dx2;
        self.bodies[moved].pose.q = rotate_by(pose.q, dth2);
        Some((dx + dx2, dth + dth2))
    }
}

/// Cholesky factor `A = L Lᵀ` of the `n × n` lower triangle in `l`, in place; `false`
/// when a pivot is not positive and finite.
fn cholesky(l: &mut [[f64; MAX_ROWS]; MAX_ROWS], n: usize) -> bool {
    for p in 0..n {
        for q in 0..=p {
            let mut s = l[p][q];
            for k in 0..q {
                s -= l[p][k] * l[q][k];
            }
            if p == q {
                if !(s > 0.0) || !s.is_finite() {
                    return false;
                }
                l[p][p] = libm::sqrt(s);
            } else {
                l[p][q] = s / l[q][q];
            }
        }
    }
    true
}

/// The step `δ = −M_c⁻¹ J_cᵀ A⁻¹ C` from the factor `l` of `A` and the columns `w` of
/// `M_c⁻¹ J_cᵀ`; `c` is overwritten by the multipliers.
fn chol_step(
    l: &[[f64; MAX_ROWS]; MAX_ROWS],
    w: &[[DVec3; 2]; MAX_ROWS],
    c: &mut [f64; MAX_ROWS],
    n: usize,
) -> (DVec3, DVec3) {
    // L y = −C, then Lᵀ z = y.
    for p in 0..n {
        let mut s = -c[p];
        for k in 0..p {
            s -= l[p][k] * c[k];
        }
        c[p] = s / l[p][p];
    }
    for p in (0..n).rev() {
        let mut s = c[p];
        for k in p + 1..n {
            s -= l[k][p] * c[k];
        }
        c[p] = s / l[p][p];
    }
    let (mut dx, mut dth) = (DVec3::ZERO, DVec3::ZERO);
    for k in 0..n {
        dx += w[k][0] * c[k];
        dth += w[k][1] * c[k];
    }
    (dx, dth)
}
