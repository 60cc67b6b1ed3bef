//! The one-sided rows by an active set inside the tree factor: `O(n)` per iteration
//! where the dense path ([`super::unilateral`]) costs one tree solve per row, a dense
//! Delassus matrix and a dense complementarity solve.
//!
//! Each row is *active* (held as an equality `w = G v' − bias = 0`, a row of the
//! augmented tree factor of [`crate::tree_rows`]), *inactive* (`z = 0`) or *at a
//! bound* (`z = lo` or `hi`, moved to the right-hand side as a known impulse `Gᵀ z`).
//! One iteration factors and solves
//!
//! ```text
//! [H    G_Aᵀ] [x ]   [b + G_Fᵀ z_F]
//! [G_A   0  ] [−z_A] = [bias_A     ]       (F: the rows at a bound)
//! ```
//!
//! and updates the set by the signs of the natural map (the primal–dual active set, a
//! semismooth Newton step on `z = mid(lo, z − w, hi)`): an active one-sided row with
//! `z < 0` leaves, an inactive one with `w < 0` enters; an active boxed or friction
//! row beyond its bound goes to it, one at its bound whose `w` turned against the
//! bound (`w > 0` at `hi`, `w < 0` at `lo`) comes back. Friction bounds `±μ z_n` use
//! the normal impulse of the previous iteration (the staggered coupling of
//! [`constraint_contact::lcp::Coupling::Staggered`], iterated here to its fixed
//! point: the step ends when the set is unchanged and every bound moved by less than
//! `1e-11` of the largest impulse). The set starts from the last step's, matched by
//! row identity (limit: joint, degree of freedom, side; contact: collider pair and
//! feature id, axis).
//!
//! Active rows whose pivot the factor drops (more rows at a node than its subtree has
//! freedoms) are solved by their Schur complement after each factor solve, as loop
//! rows are; rows still unsatisfied after it are dependent and checked by value.
//!
//! Eligible rows keep the tree a tree ([`crate::tree_rows`]): limits and dry friction
//! of tree joints, contacts with the static world. A step with another row (a
//! body–body contact, a row of a loop joint), with loop joints, or whose set does not
//! settle within [`MAX_ITERATIONS`], or where a dependent row's value cannot be held,
//! goes to the dense path unchanged (counted in [`super::UnilateralStats`]).

use alloc::vec::Vec;

use constraint_contact::lcp::RowBound;
use constraint_core::DVec3;
use constraint_lagrange::solve::svd::SvdSolver;
use constraint_lagrange::solve::DenseMatrix;

use super::unilateral::{RowSource, URow};
use super::*;
use crate::tree::NONE;
use crate::tree_rows::{ExtraRow, RowTree};

/// Iterations of the active set before the step goes to the dense path.
pub const MAX_ITERATIONS: usize = 20;

/// Most rows with dropped pivots solved by their Schur complement in one iteration.
const MAX_DROPPED: usize = 48;

/// A row's state in the active set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RowStatus {
    /// `z = 0`.
    Inactive,
    /// `w = 0`, `z` free (within its bounds).
    Active,
    /// `z` at its lower bound.
    Lo,
    /// `z` at its upper bound.
    Hi,
}

/// A row's identity across steps: kind (0 limit, 1 dry friction, 2 + axis contact) and
/// what names it.
type RowKey = (u8, usize, usize, u64);

/// Scratch of the active-set solve, kept across steps.
#[derive(Clone, Debug, Default)]
pub(super) struct ActiveSet {
    factor: RowTree,
    /// Per row: its tree node, status, impulse, value `w`, key.
    node: Vec<usize>,
    status: Vec<RowStatus>,
    z: Vec<f64>,
    w: Vec<f64>,
    keys: Vec<RowKey>,
    /// The active rows of the current iteration and their row indices.
    rows: Vec<ExtraRow>,
    map: Vec<usize>,
    /// The augmented unknowns.
    x: Vec<f64>,
    /// Active rows whose pivot the factor dropped (indices into `map`) and their
    /// columns `H_A⁻¹ Gᵀ`.
    dropped: Vec<usize>,
    ycols: Vec<f64>,
    /// The last step's rows in their order: key, status, impulse.
    warm: Vec<(RowKey, RowStatus, f64)>,
    /// `warm`'s indices sorted by key (built on the first lookup that misses the
    /// same-position guess; `sorted_ok` says it is current).
    sorted: Vec<usize>,
    sorted_ok: bool,
}

impl World {
    fn row_key(&self, r: &URow) -> RowKey {
        match r.source {
            RowSource::Limit { joint, dof, upper } => (0, joint, 2 * dof + upper as usize, 0),
            RowSource::DryFriction { joint, dof } => (1, joint, dof, 0),
            RowSource::TendonLimit { tendon, upper } => (5, tendon, upper as usize, 0),
            RowSource::Contact { contact, axis } => {
                #[cfg(feature = "contact")]
                {
                    let (a, b, id) = self.contacts[contact].key();
                    (2 + axis, a, b, id)
                }
                #[cfg(not(feature = "contact"))]
                {
                    (2 + axis, contact, 0, 0)
                }
            }
        }
    }

    /// The tree node a row joins, or `None` when it would not keep the tree a tree.
    fn row_node(&self, r: &URow) -> Option<usize> {
        let s = &self.solver;
        match r.source {
            RowSource::Limit { joint, .. } | RowSource::DryFriction { joint, .. } => {
                let n = *s.joint_node.get(joint)?;
                (n != NONE).then_some(n)
            }
            // A tendon spans several joints: not a row of one node.
            RowSource::TendonLimit { .. } => None,
            RowSource::Contact { .. } => match (r.a, r.b) {
                (None, Some(i)) | (Some(i), None) if i < s.n_bodies => {
                    let p = s.parent[i];
                    Some(if p == NONE { i } else { p })
                }
                _ => None,
            },
        }
    }

    /// Solves the one-sided rows with the assembled (not yet factored) joint system by
    /// the active set; on success the solution is in `self.rhs` (the tree's layout) and
    /// the impulses in `self.uz`. `false`: not eligible or not settled, and neither
    /// `self.rhs` nor the solver was touched (the dense path follows).
    pub(super) fn solve_unilateral_sparse(&mut self) -> bool {
        let mut st = core::mem::take(&mut self.aset);
        let ok = self.active_set_solve(&mut st);
        self.aset = st;
        ok
    }

    fn active_set_solve(&mut self, st: &mut ActiveSet) -> bool {
        let m = self.urows.len();
        st.node.clear();
        st.keys.clear();
        for r in &self.urows {
            let Some(n) = self.row_node(r) else {
                return false;
            };
            st.node.push(n);
            st.keys.push(self.row_key(r));
        }
        self.ustats.rows = m;
        self.ustats.limit_rows = self
            .urows
            .iter()
            .filter(|r| matches!(r.source, RowSource::Limit { .. }))
            .count();
        // Warm start: the last step's status and impulse of the row with the same key
        // (first guess: the same position, where the rows came in the same order), else
        // a guess from the row's target (a row asked to push apart, bias ≥ 0, starts
        // active) and z = 0.
        st.z.clear();
        st.status.clear();
        for (i, r) in self.urows.iter().enumerate() {
            let key = st.keys[i];
            let hit = match st.warm.get(i) {
                Some(w) if w.0 == key => Some(i),
                _ => {
                    if !st.sorted_ok {
                        st.sorted.clear();
                        st.sorted.extend(0..st.warm.len());
                        let warm = &st.warm;
                        st.sorted.sort_unstable_by_key(|&k| warm[k].0);
                        st.sorted_ok = true;
                    }
                    st.sorted
                        .binary_search_by(|&k| st.warm[k].0.cmp(&key))
                        .ok()
                        .map(|p| st.sorted[p])
                }
            };
            let (s, z) = match hit {
                Some(p) => (st.warm[p].1, st.warm[p].2),
                None => (
                    match r.bound {
                        RowBound::Unilateral if r.bias >= 0.0 => RowStatus::Active,
                        RowBound::Unilateral => RowStatus::Inactive,
                        RowBound::Friction { .. } => RowStatus::Inactive,
                        RowBound::Boxed { .. } => RowStatus::Active,
                    },
                    0.0,
                ),
            };
            st.status.push(s);
            st.z.push(z);
        }
        let bias_scale = self.urows.iter().fold(1.0f64, |s, r| s.max(r.bias.abs()));
        let tol_w = self.unilateral.solver.tolerance * bias_scale;
        let mut iterations = 0;
        let mut settled = false;
        while iterations < MAX_ITERATIONS {
            iterations += 1;
            // Impulses of the rows off the factor (bounds from the current normals).
            for i in 0..m {
                st.z[i] = match st.status[i] {
                    RowStatus::Inactive => 0.0,
                    RowStatus::Active => st.z[i],
                    RowStatus::Lo => bounds(&self.urows[i].bound, &st.z).0,
                    RowStatus::Hi => bounds(&self.urows[i].bound, &st.z).1,
                };
            }
            st.rows.clear();
            st.map.clear();
            for (i, r) in self.urows.iter().enumerate() {
                if st.status[i] == RowStatus::Active {
                    st.rows.push(ExtraRow {
                        node: st.node[i],
                        a: r.a,
                        b: r.b,
                        j: r.j,
                    });
                    st.map.push(i);
                }
            }
            if !st.factor.assemble(&self.solver, &st.rows)
                || st.factor.factor(&self.solver).is_err()
            {
                return false;
            }
            // Right-hand side: the tree's, the known impulses, the active rows' targets.
            let f = &st.factor;
            st.x.clear();
            st.x.resize(f.size, 0.0);
            for k in 0..self.solver.dim.len() {
                let (o, n, xo) = (self.solver.offset[k], self.solver.dim[k], f.node_offset(k));
                st.x[xo..xo + n].copy_from_slice(&self.rhs[o..o + n]);
            }
            for (i, r) in self.urows.iter().enumerate() {
                if matches!(st.status[i], RowStatus::Lo | RowStatus::Hi) && st.z[i] != 0.0 {
                    scatter(f, &mut st.x, r, st.z[i]);
                }
            }
            for (k, &i) in st.map.iter().enumerate() {
                st.x[f.row_position(k)] = self.urows[i].bias;
            }
            f.solve(&self.solver, &mut st.x);
            if !self.dropped_rows_schur(st, tol_w) {
                return false;
            }
            let f = &st.factor;
            let mut zmax: f64 = 0.0;
            for (k, &i) in st.map.iter().enumerate() {
                st.z[i] = -st.x[f.row_position(k)];
            }
            for i in 0..m {
                zmax = zmax.max(st.z[i].abs());
            }
            st.w.clear();
            for r in &self.urows {
                st.w.push(gather(f, &st.x, r) - r.bias);
            }
            // Rows dependent on the others (the Schur complement's truncated directions)
            // hold only if the others imply it: a one-sided one that does not cannot be
            // mended here; a boxed or friction one slides, to the bound against its rate.
            let mut changed = false;
            for (k, &i) in st.map.iter().enumerate() {
                if !st.dropped.is_empty() && st.dropped.contains(&k) {
                    let w = st.w[i];
                    match self.urows[i].bound {
                        RowBound::Unilateral if w < -tol_w => return false,
                        RowBound::Unilateral => {}
                        _ if w.abs() > tol_w => {
                            st.status[i] = if w < 0.0 {
                                RowStatus::Hi
                            } else {
                                RowStatus::Lo
                            };
                            changed = true;
                        }
                        _ => {}
                    }
                }
            }
            let tz = 1e-12 * zmax;
            let mut drift: f64 = 0.0;
            for i in 0..m {
                let (z, w) = (st.z[i], st.w[i]);
                let old = st.status[i];
                let new = match self.urows[i].bound {
                    RowBound::Unilateral => match old {
                        RowStatus::Active if z < -tz => RowStatus::Inactive,
                        RowStatus::Inactive if w < -tol_w => RowStatus::Active,
                        s => s,
                    },
                    b => {
                        let (lo, hi) = bounds(&b, &st.z);
                        if lo == 0.0 && hi == 0.0 {
                            RowStatus::Inactive
                        } else {
                            match old {
                                RowStatus::Active if z > hi + tz => RowStatus::Hi,
                                RowStatus::Active if z < lo - tz => RowStatus::Lo,
                                RowStatus::Hi if w > tol_w => RowStatus::Active,
                                RowStatus::Lo if w < -tol_w => RowStatus::Active,
                                // z = 0 inside the bounds holds while w = 0.
                                RowStatus::Inactive if w.abs() > tol_w => RowStatus::Active,
                                s => {
                                    // A bound that moved with its normal.
                                    let target = match s {
                                        RowStatus::Hi => hi,
                                        RowStatus::Lo => lo,
                                        _ => z,
                                    };
                                    drift = drift.max((target - z).abs());
                                    s
                                }
                            }
                        }
                    }
                };
                if new != old {
                    changed = true;
                    st.status[i] = new;
                }
            }
            if !changed && drift <= 1e-11 * zmax {
                settled = true;
                break;
            }
        }
        self.ustats.active_set_iterations = iterations;
        if !settled {
            return false;
        }
        // The solution in the tree's layout, the impulses, the statistics.
        let f = &st.factor;
        for k in 0..self.solver.dim.len() {
            let (o, n, xo) = (self.solver.offset[k], self.solver.dim[k], f.node_offset(k));
            self.rhs[o..o + n].copy_from_slice(&st.x[xo..xo + n]);
        }
        self.mu.clear();
        self.uz.clear();
        self.uz.extend_from_slice(&st.z);
        self.ustats.sparse = true;
        self.ustats.solver.iterations = iterations;
        let mut worst: f64 = 0.0;
        for i in 0..m {
            let (lo, hi) = bounds(&self.urows[i].bound, &st.z);
            let (z, w) = (st.z[i], st.w[i]);
            worst = worst.max((z - (z - w).min(hi).max(lo)).abs());
        }
        self.ustats.residual = worst / bias_scale;
        remember(st, &self.uz);
        true
    }

    /// The active rows whose pivot the tree factor dropped: a row of a node beyond the
    /// rank its child's unknowns give it (a foot's contacts under its hinge, more rows
    /// than the foot has freedoms) is not dependent in the whole system, only in the
    /// subtree below it. They are solved as loop rows are ([`crate::tree`]): with
    /// `Y = H_A⁻¹ G_Dᵀ` (one solve of the factor without them per row),
    /// `(G_D Y) ζ_D = G_D x_A − bias_D` by SVD for the minimum-norm `ζ_D` (singular
    /// values below `1e-10 ×` the rows' scale without joints, `max g M⁻¹ gᵀ`, are
    /// truncated: those directions are dependent and keep `ζ = 0`), then
    /// `x = x_A − Y ζ_D`; skipped when the other rows already hold every dropped one
    /// (`|w| ≤ tol_w`). `false` when the small solve fails or too many rows dropped
    /// (more than [`MAX_DROPPED`]: the dense path is as cheap).
    fn dropped_rows_schur(&self, st: &mut ActiveSet, tol_w: f64) -> bool {
        st.dropped.clear();
        let f = &st.factor;
        for k in 0..st.map.len() {
            if f.dropped(f.row_position(k)) {
                st.dropped.push(k);
            }
        }
        let d = st.dropped.len();
        // Rows the others already hold (|w| ≤ tol) need nothing more.
        let held = st.dropped.iter().all(|&k| {
            let r = &self.urows[st.map[k]];
            (gather(f, &st.x, r) - r.bias).abs() <= tol_w
        });
        if held {
            return true;
        }
        if d > MAX_DROPPED {
            return false;
        }
        let size = f.size;
        st.ycols.clear();
        st.ycols.resize(d * size, 0.0);
        let mut free_scale: f64 = 0.0;
        for (c, &k) in st.dropped.iter().enumerate() {
            let r = &self.urows[st.map[k]];
            let col = &mut st.ycols[c * size..(c + 1) * size];
            scatter(f, col, r, 1.0);
            f.solve(&self.solver, col);
            let mut g = 0.0;
            for (side, body) in [(0usize, r.a), (1usize, r.b)] {
                if let Some(i) = body {
                    let b = &self.bodies[i];
                    g += r.j[2 * side].length_squared() / b.mass()
                        + r.j[2 * side + 1].dot(b.world_inv_inertia() * r.j[2 * side + 1]);
                }
            }
            free_scale = free_scale.max(g);
        }
        let row = |a: usize| &self.urows[st.map[st.dropped[a]]];
        let s = DenseMatrix::from_fn(d, d, |a, b| {
            let y = &st.ycols[b * size..(b + 1) * size];
            0.5 * (gather(f, y, row(a)) + {
                let ya = &st.ycols[a * size..(a + 1) * size];
                gather(f, ya, row(b))
            })
        });
        let rhs: Vec<f64> = (0..d)
            .map(|a| gather(f, &st.x, row(a)) - row(a).bias)
            .collect();
        if !s.is_finite() || rhs.iter().any(|v| !v.is_finite()) {
            return false;
        }
        let Ok(svd) = SvdSolver::new(&s, 1e-10) else {
            return false;
        };
        let smax = svd.singular_values().first().copied().unwrap_or(0.0);
        let floor = 1e-10 * free_scale;
        let mut zeta = alloc::vec![0.0; d];
        if smax > floor {
            let svd = if floor > 1e-10 * smax {
                match SvdSolver::new(&s, floor / smax) {
                    Ok(v) => v,
                    Err(_) => return false,
                }
            } else {
                svd
            };
            if svd.solve_min_norm(&rhs, &mut zeta).is_err() {
                return false;
            }
        }
        for (c, z) in zeta.iter().enumerate() {
            if *z != 0.0 {
                let col = &st.ycols[c * size..(c + 1) * size];
                for (x, y) in st.x.iter_mut().zip(col) {
                    *x -= z * y;
                }
            }
        }
        for (c, &k) in st.dropped.iter().enumerate() {
            st.x[f.row_position(k)] = zeta[c];
        }
        true
    }

    /// After a dense solve: the statuses its impulses imply, for the next step's warm
    /// start of the active set.
    pub(super) fn remember_dense_statuses(&mut self) {
        let mut st = core::mem::take(&mut self.aset);
        st.keys.clear();
        st.status.clear();
        for (i, r) in self.urows.iter().enumerate() {
            st.keys.push(self.row_key(r));
            let z = self.uz.get(i).copied().unwrap_or(0.0);
            let (lo, hi) = bounds(&r.bound, &self.uz);
            let tol = 1e-9 * hi.abs().max(lo.abs());
            let s = match r.bound {
                RowBound::Unilateral if z > 0.0 => RowStatus::Active,
                RowBound::Unilateral => RowStatus::Inactive,
                _ if lo == 0.0 && hi == 0.0 => RowStatus::Inactive,
                _ if z >= hi - tol => RowStatus::Hi,
                _ if z <= lo + tol => RowStatus::Lo,
                _ => RowStatus::Active,
            };
            st.status.push(s);
        }
        remember(&mut st, &self.uz);
        self.aset = st;
    }
}

/// Keeps the rows' keys, statuses and impulses in row order for the next step.
fn remember(st: &mut ActiveSet, z: &[f64]) {
    st.warm.clear();
    for (i, (k, s)) in st.keys.iter().zip(&st.status).enumerate() {
        st.warm.push((*k, *s, z.get(i).copied().unwrap_or(0.0)));
    }
    st.sorted_ok = false;
}

/// The row's bounds `(lo, hi)` at the impulses `z` (friction: `±μ max(z_n, 0)`).
fn bounds(b: &RowBound, z: &[f64]) -> (f64, f64) {
    match *b {
        RowBound::Unilateral => (0.0, f64::INFINITY),
        RowBound::Friction { normal, mu } => {
            let m = mu * z.get(normal).copied().unwrap_or(0.0).max(0.0);
            (-m, m)
        }
        RowBound::Boxed { lo, hi } => (lo, hi),
    }
}

/// `x += s · Gᵀ` on the row's bodies' unknowns in the augmented layout.
fn scatter(f: &RowTree, x: &mut [f64], r: &URow, s: f64) {
    for (side, body) in [(0usize, r.a), (1usize, r.b)] {
        let Some(body) = body else { continue };
        let o = f.node_offset(body);
        for c in 0..3 {
            x[o + c] += s * r.j[2 * side][c];
            x[o + 3 + c] += s * r.j[2 * side + 1][c];
        }
    }
}

/// `G x` on the row's bodies' unknowns in the augmented layout.
fn gather(f: &RowTree, x: &[f64], r: &URow) -> f64 {
    let mut s = 0.0;
    for (side, body) in [(0usize, r.a), (1usize, r.b)] {
        let Some(body) = body else { continue };
        let o = f.node_offset(body);
        s += r.j[2 * side].dot(DVec3::new(x[o], x[o + 1], x[o + 2]))
            + r.j[2 * side + 1].dot(DVec3::new(x[o + 3], x[o + 4], x[o + 5]));
    }
    s
}
