//! The dense path's Delassus matrix from forward passes alone, where the factor has no
//! loop rows and no equality rows and every row acts on bodies (no tendon limit):
//! with `H = L D Lᵀ` and `u_i = L⁻¹ g_iᵀ`, non-zero only on row `i`'s paths to the root,
//!
//! ```text
//! A_ik = g_i H⁻¹ g_kᵀ = u_iᵀ D⁺ u_k = Σ u_i s_k   over the unknowns both paths hold,
//! x'   = x_free + H⁻¹ (Gᵀ z)                    (one whole solve),
//! ```
//!
//! (`s_k = D⁺ u_k`, zero at a dropped pivot, as the tree solve drops it;
//! [`TreeSolver::forward_path`]). The columns `Y = H⁻¹ Gᵀ` of the general path (a
//! backward pass over the whole tree per row) are not formed; nothing else reads them.
//! Rows with the same two bodies share their path, and the unknowns two paths share
//! are found once per pair of distinct paths, as runs of contiguous values.
//!
//! Cost per row: the forward pass on its path (as before) and, per row pair, a dot
//! product over the unknowns the paths share, instead of a backward pass over the whole
//! tree and a 12-term gather per pair: quadratic in the rows where the columns were
//! linear, so it gains while the rows are fewer than about the tree's unknowns over the
//! paths' shared length. Measured (issue 13, `World::step` instructions, against the
//! columns): humanoid_CMU controlled 0.5 s 418.84M → 397.88M (this function and its
//! callees 129.8M → 108.9M, the trajectory's other costs unchanged); gymnasium humanoid
//! passive 2 s, the dense solve 28.0M → 21.8M; seven humanoid runs (dm humanoid
//! passive, perturbed, controlled 2 s; gymnasium humanoid passive 2 s; humanoid_CMU
//! passive 2 s, perturbed and controlled 1 s) 5445.3M → 5274.1M, their summaries
//! unchanged. The index buffers are this struct's, kept by the world across steps.

use alloc::vec::Vec;

use constraint_contact::lcp::RowStats;

use super::{gather, URow};
use crate::error::ArticulatedError;
use crate::tree::TreeSolver;
use crate::world::{LoopRows, World};

/// The buffers of one build of `A` by paths (the world's, only grown: no allocation
/// per step once they have grown).
#[derive(Clone, Debug, Default)]
pub(in crate::world) struct PathDelassus {
    /// All rows' path nodes, one row after another.
    nodes: Vec<usize>,
    /// Per row (and one past the last): its first node in `nodes`.
    start: Vec<usize>,
    /// Per row (and one past the last): its first value in `s` and `u`.
    val_start: Vec<usize>,
    /// Per row: its distinct path's index in `reps`.
    path_id: Vec<usize>,
    /// Per distinct path: the first row on it.
    reps: Vec<usize>,
    /// Per node: its value offset on the path being matched (`usize::MAX`: not on it).
    node_slot: Vec<usize>,
    /// Shared runs `(offset on row i's path, offset on row k's path, length)`.
    seg: Vec<(usize, usize, usize)>,
    /// Per pair of distinct paths `(p, q)`: its runs in `seg` (`usize::MAX`: not found yet).
    seg_at: Vec<(usize, usize)>,
    /// Path walk flags (all `false` between rows).
    mark: Vec<bool>,
}

impl PathDelassus {
    /// Writes `A = G H⁻¹ Gᵀ` of `rows` (body rows of bodies in the tree) into
    /// `a[..m²]`, row-major: the lower triangle `A_ik = Σ u_i s_k` (`k ≤ i`, summed node
    /// after node along row `i`'s path, in [`dot_lanes`]' lanes), mirrored. `vals` is
    /// the arena (only grown): `[..size]` the work column, zero on entry and left zero,
    /// then every row's `s = D⁺ L⁻¹ gᵀ` on its path, node after node, then the `u`.
    pub(super) fn build(
        &mut self,
        solver: &TreeSolver,
        rows: &[URow],
        vals: &mut Vec<f64>,
        a: &mut [f64],
    ) {
        let m = rows.len();
        let size = solver.size;
        self.nodes.clear();
        self.start.clear();
        self.val_start.clear();
        self.path_id.clear();
        self.reps.clear();
        self.mark.clear();
        let mut total = 0;
        for (k, r) in rows.iter().enumerate() {
            let first = self.nodes.len();
            self.start.push(first);
            self.val_start.push(total);
            // The index of the row's distinct path, if an earlier row had it.
            let rep = self
                .reps
                .iter()
                .position(|&p| rows[p].a == r.a && rows[p].b == r.b);
            match rep {
                // The same bodies: the same path (copied from its first row, no walk).
                Some(id) => {
                    let p = self.reps[id];
                    let (p0, p1) = (self.start[p], self.start[p + 1]);
                    self.nodes.extend_from_within(p0..p1);
                    total += self.val_start[p + 1] - self.val_start[p];
                }
                None => {
                    solver.row_path([r.a, r.b], &mut self.mark, &mut self.nodes);
                    total += self.nodes[first..]
                        .iter()
                        .map(|&n| solver.node_dim(n))
                        .sum::<usize>();
                }
            }
            self.path_id.push(rep.unwrap_or(self.reps.len()));
            if rep.is_none() {
                self.reps.push(k);
            }
        }
        self.start.push(self.nodes.len());
        self.val_start.push(total);
        if vals.len() < size + 2 * total {
            vals.resize(size + 2 * total, 0.0);
        }
        let (col, rest) = vals.split_at_mut(size);
        let (s, u) = rest.split_at_mut(total);
        for (k, r) in rows.iter().enumerate() {
            place_row(solver, col, r);
            let path = &self.nodes[self.start[k]..self.start[k + 1]];
            solver.forward_path(col, path);
            let v = self.val_start[k]..self.val_start[k + 1];
            solver.take_path_values(col, path, &mut s[v.clone()], &mut u[v]);
        }
        let (s, u) = (&*s, &*u);
        let g = self.reps.len();
        self.seg.clear();
        self.seg_at.clear();
        self.seg_at.resize(g * g, (usize::MAX, 0));
        self.node_slot.clear();
        self.node_slot.resize(solver.parent.len(), usize::MAX);
        for k in 0..m {
            let (vk, q) = (self.val_start[k], self.path_id[k]);
            let path_k = &self.nodes[self.start[k]..self.start[k + 1]];
            let mut slots = false;
            let mut i = k;
            while i < m {
                let (vi, p) = (self.val_start[i], self.path_id[i]);
                if self.seg_at[p * g + q].0 == usize::MAX {
                    if !slots {
                        let mut off = 0;
                        for &n in path_k {
                            self.node_slot[n] = off;
                            off += solver.node_dim(n);
                        }
                        slots = true;
                    }
                    let first = self.seg.len();
                    let mut ra = 0;
                    for &n in &self.nodes[self.start[i]..self.start[i + 1]] {
                        let len = solver.node_dim(n);
                        let ob = self.node_slot[n];
                        if ob != usize::MAX {
                            match self.seg[first..].last_mut() {
                                Some(sg) if sg.0 + sg.2 == ra && sg.1 + sg.2 == ob => sg.2 += len,
                                _ => self.seg.push((ra, ob, len)),
                            }
                        }
                        ra += len;
                    }
                    self.seg_at[p * g + q] = (first, self.seg.len());
                }
                let (s0, s1) = self.seg_at[p * g + q];
                // Four rows on one path (a contact's normal and tangents, the next
                // contact of the same bodies) against row `k` at once: `s_k` read once
                // per four, each row's lanes summed as [`dot_lanes`] sums them.
                if i + 4 <= m && self.path_id[i + 1..i + 4].iter().all(|&r| r == p) {
                    let v = [
                        vi,
                        self.val_start[i + 1],
                        self.val_start[i + 2],
                        self.val_start[i + 3],
                    ];
                    let mut acc = [[0.0; LANES]; 4];
                    for &(ra, rb, len) in &self.seg[s0..s1] {
                        let sk = &s[vk + rb..vk + rb + len];
                        let ui = |t: usize| &u[v[t] + ra..v[t] + ra + len];
                        dot_lanes4(&mut acc, [ui(0), ui(1), ui(2), ui(3)], sk);
                    }
                    for (t, c) in acc.iter().enumerate() {
                        a[(i + t) * m + k] = (c[0] + c[1]) + (c[2] + c[3]);
                    }
                    i += 4;
                    continue;
                }
                let mut acc = [0.0; LANES];
                for &(ra, rb, len) in &self.seg[s0..s1] {
                    let ui = &u[vi + ra..vi + ra + len];
                    let sk = &s[vk + rb..vk + rb + len];
                    dot_lanes(&mut acc, ui, sk);
                }
                a[i * m + k] = (acc[0] + acc[1]) + (acc[2] + acc[3]);
                i += 1;
            }
            if slots {
                for &n in path_k {
                    self.node_slot[n] = usize::MAX;
                }
            }
        }
        for i in 0..m {
            for k in i + 1..m {
                a[i * m + k] = a[k * m + i];
            }
        }
    }
}

/// The lanes of [`dot_lanes`].
const LANES: usize = 4;

/// `acc[l] += Σ_t a[4t + l] b[4t + l]` (the tail's products into lanes `0, 1, 2`): four
/// independent sums in a fixed order, which the compiler keeps in vector lanes (one
/// running sum is a chain of dependent adds it may not reorder); the caller adds the
/// lanes as `(acc₀ + acc₁) + (acc₂ + acc₃)`. Same input, same bits.
#[inline(always)]
fn dot_lanes(acc: &mut [f64; LANES], a: &[f64], b: &[f64]) {
    let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let (ta, tb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..LANES {
            acc[l] += x[l] * y[l];
        }
    }
    for (l, (x, y)) in ta.iter().zip(tb).enumerate() {
        acc[l] += x * y;
    }
}

/// [`dot_lanes`] for four rows `a[r]` against one `b` (each `b.len()` long): row `r`'s
/// lanes in `acc[r]`, each lane's products summed in the same order as `dot_lanes`
/// sums them (so the same bits), `b` read once for the four.
#[inline(always)]
fn dot_lanes4(acc: &mut [[f64; LANES]; 4], a: [&[f64]; 4], b: &[f64]) {
    let n = b.len();
    let full = n - n % LANES;
    let a = a.map(|r| &r[..n]);
    let mut t = 0;
    while t < full {
        let y = &b[t..t + LANES];
        for (r, row) in a.iter().enumerate() {
            let x = &row[t..t + LANES];
            for l in 0..LANES {
                acc[r][l] += x[l] * y[l];
            }
        }
        t += LANES;
    }
    for l in 0..n - full {
        let y = b[full + l];
        for (r, row) in a.iter().enumerate() {
            acc[r][l] += row[full + l] * y;
        }
    }
}

/// `x += gᵀ` on the row's bodies' unknowns (side `a`, then `b`).
fn place_row(solver: &TreeSolver, x: &mut [f64], r: &URow) {
    for (side, body) in [(0usize, r.a), (1usize, r.b)] {
        let Some(body) = body else { continue };
        let o = solver.body_offset(body);
        for c in 0..3 {
            x[o + c] += r.j[2 * side][c];
            x[o + 3 + c] += r.j[2 * side + 1][c];
        }
    }
}

impl World {
    /// Whether [`Self::solve_rows_by_paths`] applies: no loop rows in the factor, no
    /// active equality rows, every row a body row on bodies of the tree, and every node
    /// in the elimination order.
    pub(super) fn rows_on_paths(&self, rows: &[URow], loops: &LoopRows) -> bool {
        loops.0.is_empty()
            && !(self.eq.active && self.eq.len() > 0)
            && self.solver.order.len() == self.solver.parent.len()
            && rows.iter().all(|r| {
                !matches!(r.source, super::RowSource::TendonLimit { .. })
                    && [r.a, r.b]
                        .into_iter()
                        .flatten()
                        .all(|b| b < self.solver.n_bodies)
            })
    }

    /// [`Self::solve_rows_in_factor`] with `A` from forward passes
    /// ([`PathDelassus::build`]) and `x' = x_free + H⁻¹ (Gᵀ z)` by one whole solve, for
    /// the rows [`Self::rows_on_paths`] accepts.
    pub(super) fn solve_rows_by_paths(
        &mut self,
        rows: &[URow],
        z: &mut [f64],
    ) -> Result<(RowStats, f64), ArticulatedError> {
        let m = rows.len();
        let size = self.solver.size;
        let mut col = core::mem::take(&mut self.ucols);
        if col.len() < size {
            col.resize(size, 0.0);
        }
        col[..size].fill(0.0);
        let mut a_buf = core::mem::take(&mut self.udel);
        if a_buf.len() < m * m {
            a_buf.resize(m * m, 0.0);
        }
        let a = &mut a_buf[..m * m];
        let mut paths = core::mem::take(&mut self.upaths);
        paths.mark = core::mem::take(&mut self.umark);
        paths.build(&self.solver, rows, &mut col, a);
        let col_s = &mut col[..size];
        let mut q = core::mem::take(&mut self.uq);
        q.clear();
        for r in rows {
            q.push(gather(&self.solver, &self.tendon_spans, &self.rhs, r) - r.bias);
        }
        let a = &*a;
        let outcome = match self.solve_assembled(rows, a, &q, z) {
            Ok(stats) => {
                // x' = x_free + H⁻¹ (Gᵀ z).
                let mut any = false;
                for (r, zk) in rows.iter().zip(z.iter()) {
                    if *zk != 0.0 {
                        any = true;
                        for (side, body) in [(0usize, r.a), (1usize, r.b)] {
                            let Some(body) = body else { continue };
                            let o = self.solver.body_offset(body);
                            for c in 0..3 {
                                col_s[o + c] += zk * r.j[2 * side][c];
                                col_s[o + 3 + c] += zk * r.j[2 * side + 1][c];
                            }
                        }
                    }
                }
                if any {
                    self.solver.solve(col_s);
                    for (x, y) in self.rhs.iter_mut().zip(col_s.iter()) {
                        *x += y;
                    }
                }
                self.assembled_residual(a, &q, z).map(|r| (stats, r))
            }
            Err(e) => Err(e),
        };
        self.ucols = col;
        self.udel = a_buf;
        self.uq = q;
        self.umark = core::mem::take(&mut paths.mark);
        self.upaths = paths;
        outcome
    }
}

#[cfg(test)]
mod tests {
    use super::super::RowSource;
    use super::*;
    use crate::tree::JointTopo;
    use constraint_contact::lcp::RowBound;
    use constraint_core::{DMat3, DVec3};

    /// A small linear congruential generator in `[-1, 1)` (deterministic).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
        fn below(&mut self, n: usize) -> usize {
            (((self.next() + 1.0) * 0.5 * n as f64) as usize).min(n - 1)
        }
        fn vec(&mut self) -> DVec3 {
            DVec3::new(self.next(), self.next(), self.next())
        }
    }

    /// [`dot_lanes4`] gives each of its four rows the bits [`dot_lanes`] gives it, over
    /// lengths 0 to 13 (every tail length) and two segments in a row (the lanes carried
    /// over, as the build sums a pair's shared runs).
    #[test]
    fn four_rows_at_once_are_the_bits_of_one_row_at_a_time() {
        let mut g = Lcg(7);
        for n in 0..14 {
            let rows: Vec<Vec<f64>> = (0..4)
                .map(|_| (0..2 * n).map(|_| g.next()).collect())
                .collect();
            let b: Vec<f64> = (0..2 * n).map(|_| g.next() * 1e3).collect();
            let mut four = [[0.0; LANES]; 4];
            for seg in [0..n, n..2 * n] {
                let a = [0, 1, 2, 3].map(|r| &rows[r][seg.clone()]);
                dot_lanes4(&mut four, a, &b[seg.clone()]);
            }
            for (r, row) in rows.iter().enumerate() {
                let mut one = [0.0; LANES];
                for seg in [0..n, n..2 * n] {
                    dot_lanes(&mut one, &row[seg.clone()], &b[seg]);
                }
                for l in 0..LANES {
                    assert_eq!(
                        four[r][l].to_bits(),
                        one[l].to_bits(),
                        "n {n} row {r} lane {l}"
                    );
                }
            }
        }
    }

    /// `A` by paths against `G Y` with `Y = H⁻¹ Gᵀ` by one sparse tree solve per row
    /// (the general path's columns), on random trees (branched, several roots on the
    /// world) with random joint and contact rows, one joint holding two equal rows
    /// (a dropped pivot). Relative to the largest entry the two agree to 1e-12
    /// (measured worst 4.2e-15); the dropped pivot is seen (`dinv` zero somewhere).
    #[test]
    fn path_delassus_matches_the_columns() {
        let mut rng = Lcg(7);
        let mut worst: f64 = 0.0;
        for trial in 0..20 {
            let n = 3 + rng.below(14);
            let mut topo = Vec::new();
            for i in 0..n {
                let a = if i == 0 || rng.below(5) == 0 {
                    None
                } else {
                    Some(rng.below(i))
                };
                topo.push(JointTopo {
                    a,
                    b: i,
                    rows: 1 + rng.below(5),
                });
            }
            // The dropped pivot: a joint with two equal rows.
            let dup = rng.below(n);
            topo[dup].rows = topo[dup].rows.max(2);
            let mut t = TreeSolver::new(n, &topo);
            for i in 0..n {
                let m = 1.0 + rng.next().abs();
                let inertia = DMat3::from_diagonal(DVec3::new(
                    0.1 + rng.next().abs(),
                    0.1 + rng.next().abs(),
                    0.1 + rng.next().abs(),
                ));
                t.set_body(i, m, &inertia);
            }
            for (j, tp) in topo.iter().enumerate() {
                let mut rows: Vec<[DVec3; 4]> = (0..tp.rows)
                    .map(|_| [rng.vec(), rng.vec(), rng.vec(), rng.vec()])
                    .collect();
                if j == dup {
                    rows[1] = rows[0];
                }
                t.set_joint(j, tp, &rows, 0, &vec![0.0; tp.rows]);
            }
            t.factor().expect("factor");
            // Contacts of three rows each (normal and tangents: one path), on one body
            // or two.
            let contacts = 1 + rng.below(6);
            let mut rows: Vec<URow> = Vec::new();
            for contact in 0..contacts {
                let b = rng.below(n);
                let a = (rng.below(3) == 0)
                    .then(|| rng.below(n))
                    .filter(|&a| a != b);
                for axis in 0..3 {
                    rows.push(URow {
                        a,
                        b: Some(b),
                        j: [rng.vec(), rng.vec(), rng.vec(), rng.vec()],
                        bias: 0.0,
                        bound: RowBound::Unilateral,
                        source: RowSource::Contact { contact, axis },
                    });
                }
            }
            let m = rows.len();
            let mut vals = vec![0.0; t.size];
            let mut a = vec![f64::NAN; m * m];
            let mut paths = PathDelassus::default();
            paths.build(&t, &rows, &mut vals, &mut a);
            assert!(vals[..t.size].iter().all(|v| *v == 0.0));
            // The general path: Y by sparse solves, then G Y.
            let mut mark = Vec::new();
            let mut y = vec![vec![f64::NAN; t.size]; m];
            for (k, r) in rows.iter().enumerate() {
                t.mark_paths(&mut y[k], [r.a, r.b], &mut mark);
                place_row(&t, &mut y[k], r);
                t.solve_sparse(&mut y[k], &mark);
            }
            let spans = crate::world::equality::Spans::default();
            let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            assert!(scale > 0.0, "trial {trial}");
            for i in 0..m {
                for k in 0..m {
                    let want = gather(&t, &spans, &y[k], &rows[i]);
                    let e = (a[i * m + k] - want).abs() / scale;
                    worst = worst.max(e);
                    assert!(e <= 1e-12, "trial {trial} ({i}, {k}): {e}");
                }
            }
            let dropped = (0..t.blocks.len()).any(|k| {
                let nk = t.node_dim(k);
                (0..nk).any(|r| t.blocks[k].diag[r][r] == 0.0)
            });
            assert!(dropped, "trial {trial}: no dropped pivot");
        }
        eprintln!("worst relative difference {worst:e}");
        assert!(worst < 1e-13, "{worst}");
    }
}
