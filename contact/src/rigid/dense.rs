//! The dense Delassus matrix, solved by [`crate::lcp::solve_rows`] (staggered
//! friction or one boxed PGS).

use alloc::vec::Vec;

use super::*;
use crate::lcp::staggered::{solve_rows_in, RowScratch};

/// Buffers of the dense path kept between steps (no per-step allocation of the
/// Delassus rows or of the row buckets once they have grown).
#[derive(Clone, Debug, Default)]
pub(super) struct DenseScratch {
    start: Vec<usize>,
    fill: Vec<usize>,
    bucket: Vec<usize>,
    /// `A`'s rows restricted to the columns of rows that share a body with them (the
    /// only possible non-zeros), for the staggered solve.
    sparse: SparseRows,
    /// How each value of `sparse` is computed ([`ContactWorld::plan_into`]).
    plan: Vec<Slot>,
    /// The body pair of each row when the pattern of `sparse` was built (the pattern
    /// is a function of them alone).
    pairs: Vec<(Option<usize>, Option<usize>)>,
    /// The rows' bounds.
    bounds: Vec<RowBound>,
    /// The staggered solve's blocks and couplings.
    rows: RowScratch,
}

/// One entry of `A` to compute: rows `i ≤ j`, its slot `p` in row `i` and its mirror
/// in row `j` (`p` itself on the diagonal), and the one body side of each row the
/// entry's single term takes (`si`, `sj` ∈ {0, 2}), or `si =` [`GENERAL`].
#[derive(Clone, Copy, Debug, Default)]
struct Slot {
    p: usize,
    mirror: usize,
    i: usize,
    j: usize,
    si: u8,
    sj: u8,
}

/// [`Slot::si`] of an entry that is not one term ([`entry`]'s general sum).
const GENERAL: u8 = u8::MAX;

/// `A_ij = Σ_b J_ib M_b⁻¹ J_jbᵀ` over the bodies `b` rows `i` and `j` share, summed in
/// the order of `i`'s bodies then `j`'s (`a` before `b`), from `s = 0`: the bits of
/// the all-pairs assembly (`J_i M⁻¹ J_jᵀ` with every body term; `M⁻¹ J_jᵀ` is kept in
/// `Row::mj`). Row `i` is the lower-indexed one of the pair (the product is not
/// symmetric in floating point).
#[inline]
fn entry(ri: &Row, rj: &Row) -> f64 {
    let term = |si: usize, sj: usize| ri.j[si].dot(rj.mj[sj]) + ri.j[si + 1].dot(rj.mj[sj + 1]);
    let mut s = 0.0;
    if let Some(b) = ri.a {
        if rj.a == Some(b) {
            s += term(0, 0);
        }
        if rj.b == Some(b) {
            s += term(0, 2);
        }
    }
    if let Some(b) = ri.b {
        if rj.a == Some(b) {
            s += term(2, 0);
        }
        if rj.b == Some(b) {
            s += term(2, 2);
        }
    }
    s
}

impl ContactWorld {
    /// Delassus matrix `A = J M⁻¹ Jᵀ` as sparse rows, and `q = J v_free − b`.
    ///
    /// `A_ij = 0` unless rows `i` and `j` share a body (`J_i` and `M⁻¹ J_jᵀ` then have
    /// no body in common), so row `i`'s columns are the union of its bodies' rows: the
    /// rows are bucketed by body (a counting sort, deterministic), and each row's
    /// columns are the merge of its two buckets (both ascending; the rows of one body
    /// pair, the three of a contact and the contacts of one face, share them: merged
    /// once). The entries are then computed straight into those rows, each pair once:
    /// row `i` computes its entries `j ≥ i` ([`entry`] with `i` first) and writes the
    /// mirror `A_ji` at row `j`'s next free lower slot (rows are done in ascending order,
    /// so row `j`'s columns below `j` arrive in ascending order). The work is
    /// `Σ_i deg(i)` entries, no `n × n` array is filled or zeroed (the assembly through
    /// a dense matrix was 22 % of the ten-box stack's step in `perf` samples; 3060
    /// steps took 3.716e9 instructions with it, 3.199e9 without), and every value has
    /// the bits of the all-pairs loop (test `sparse_assembly_equals_all_pairs_bit_for_bit`).
    ///
    /// When every row has the body pair it had at the last call (a resting stack keeps
    /// its contacts), the pattern is the last one and only the values are computed.
    ///
    /// Into kept buffers (`scratch.sparse`); returns `q` and whether the pattern is the
    /// last call's.
    fn delassus_into(&self, scratch: &mut DenseScratch) -> (Vec<f64>, bool) {
        let n = self.rows.len();
        let DenseScratch {
            start,
            fill,
            bucket,
            sparse,
            pairs,
            plan,
            ..
        } = scratch;
        let same = pairs.len() == n
            && sparse.rows() == n
            && pairs.iter().zip(&self.rows).all(|(&p, r)| p == (r.a, r.b));
        if !same {
            pairs.clear();
            pairs.extend(self.rows.iter().map(|r| (r.a, r.b)));
            self.pattern_into(start, fill, bucket, sparse);
            self.plan_into(fill, sparse, plan);
        }
        self.values_into(plan, sparse);
        let q = self
            .rows
            .iter()
            .map(|r| self.row_rate(r) - r.bias)
            .collect();
        (q, same)
    }

    /// The columns of each row of `A` (see [`ContactWorld::delassus_into`]).
    fn pattern_into(
        &self,
        start: &mut Vec<usize>,
        fill: &mut Vec<usize>,
        bucket: &mut Vec<usize>,
        sparse: &mut SparseRows,
    ) {
        // Rows of each body, ascending (counting sort by body: deterministic).
        let nb = self.bodies.len();
        start.clear();
        start.resize(nb + 1, 0);
        for r in &self.rows {
            for b in [r.a, r.b].into_iter().flatten() {
                start[b + 1] += 1;
            }
        }
        for b in 0..nb {
            start[b + 1] += start[b];
        }
        fill.clone_from(start);
        bucket.clear();
        bucket.resize(start[nb], 0);
        for (i, r) in self.rows.iter().enumerate() {
            for b in [r.a, r.b].into_iter().flatten() {
                bucket[fill[b]] = i;
                fill[b] += 1;
            }
        }
        // The pattern: row i's columns are the union of its bodies' buckets (both
        // ascending: a merge).
        sparse.start.clear();
        sparse.cols.clear();
        sparse.start.push(0);
        let empty: &[usize] = &[];
        // Rows of the same body pair (the three rows of a contact, the contacts of one
        // face) have the same columns: merged once, copied for the rest of the run.
        // (body pair, first and one-past-last index of its columns in `sparse.cols`)
        type Run = ((Option<usize>, Option<usize>), usize, usize);
        let mut last: Option<Run> = None;
        for r in &self.rows {
            if let Some((pair, s, e)) = last {
                if pair == (r.a, r.b) {
                    sparse.cols.extend_from_within(s..e);
                    sparse.start.push(sparse.cols.len());
                    continue;
                }
            }
            let begin = sparse.cols.len();
            let of = |b: Option<usize>| b.map_or(empty, |b| &bucket[start[b]..start[b + 1]]);
            let (mut x, mut y) = (of(r.a), of(r.b));
            loop {
                let j = match (x.first(), y.first()) {
                    (Some(&p), Some(&q)) if p == q => {
                        x = &x[1..];
                        y = &y[1..];
                        p
                    }
                    (Some(&p), Some(&q)) if p < q => {
                        x = &x[1..];
                        p
                    }
                    (Some(&p), None) => {
                        x = &x[1..];
                        p
                    }
                    (_, Some(&q)) => {
                        y = &y[1..];
                        q
                    }
                    (None, None) => break,
                };
                sparse.cols.push(j);
            }
            sparse.start.push(sparse.cols.len());
            last = Some(((r.a, r.b), begin, sparse.cols.len()));
        }
    }

    /// The computation plan of `A`'s values on its pattern, each pair once: row `i`'s
    /// entries from its diagonal on, each mirrored into row `j`'s next lower slot
    /// (`fill[j]`, from row `j`'s start; rows in ascending order, so row `j`'s columns
    /// below `j` arrive in order). A pair of rows that share exactly one body side
    /// (`i`'s side `si` and `j`'s side `sj`) is one term, marked with its sides; any
    /// other pair takes [`entry`]'s general sum. A function of the pattern alone: kept
    /// with it.
    fn plan_into(&self, fill: &mut Vec<usize>, sparse: &SparseRows, plan: &mut Vec<Slot>) {
        let n = self.rows.len();
        fill.clear();
        fill.extend_from_slice(&sparse.start[..n]);
        plan.clear();
        for (i, ri) in self.rows.iter().enumerate() {
            for p in fill[i]..sparse.start[i + 1] {
                let j = sparse.cols[p];
                let rj = &self.rows[j];
                let mirror = if j > i {
                    debug_assert_eq!(sparse.cols[fill[j]], i);
                    fill[j] += 1;
                    fill[j] - 1
                } else {
                    p
                };
                // The (si, sj) body sides `entry` adds, in its order.
                let mut sides = [(0u8, 0u8); 4];
                let mut count = 0;
                for (si, bi) in [(0u8, ri.a), (2u8, ri.b)] {
                    for (sj, bj) in [(0u8, rj.a), (2u8, rj.b)] {
                        if bi.is_some() && bi == bj {
                            sides[count] = (si, sj);
                            count += 1;
                        }
                    }
                }
                let (si, sj) = if count == 1 { sides[0] } else { (GENERAL, 0) };
                plan.push(Slot {
                    p,
                    mirror,
                    i,
                    j,
                    si,
                    sj,
                });
            }
        }
    }

    /// `A`'s values by the plan ([`ContactWorld::plan_into`]): a one-term slot is
    /// `0 + J_i,si · M⁻¹J_j,sjᵀ` (the bits of [`entry`], whose sum starts at 0), chosen
    /// by the stored sides instead of `entry`'s four body compares per entry.
    fn values_into(&self, plan: &[Slot], sparse: &mut SparseRows) {
        // Every slot is written below (each pair and its mirror): no zeroing.
        sparse.vals.resize(sparse.cols.len(), 0.0);
        let rows = &self.rows[..];
        let vals = &mut sparse.vals[..];
        for s in plan {
            let (ri, rj) = (&rows[s.i], &rows[s.j]);
            let v = if s.si == GENERAL {
                entry(ri, rj)
            } else {
                let (si, sj) = (usize::from(s.si), usize::from(s.sj));
                0.0 + (ri.j[si].dot(rj.mj[sj]) + ri.j[si + 1].dot(rj.mj[sj + 1]))
            };
            vals[s.p] = v;
            vals[s.mirror] = v;
        }
    }

    pub(super) fn dense(
        &mut self,
        solver: ContactSolver,
        z0: Vec<f64>,
    ) -> Result<(Vec<f64>, usize), ContactError> {
        let n = self.rows.len();
        if n == 0 {
            self.path.rows = RowsSolver::NoRows;
            return Ok((Vec::new(), 0));
        }
        self.path.rows = RowsSolver::Dense;
        let mut scratch = core::mem::take(&mut self.dense);
        let (q, same_pattern) = self.delassus_into(&mut scratch);
        let s = self.settings;
        // Rows 3k: normal; 3k + 1, 3k + 2: friction bounded by μ_k z_3k.
        scratch.bounds.clear();
        scratch.bounds.extend((0..n).map(|i| {
            if i % 3 == 0 {
                RowBound::Unilateral
            } else {
                RowBound::Friction {
                    normal: i - i % 3,
                    mu: self.mu(i / 3),
                }
            }
        }));
        let settings = RowSettings {
            method: match solver {
                ContactSolver::Lemke => RowMethod::Lemke,
                ContactSolver::Newton => RowMethod::Newton,
                _ => RowMethod::Pgs,
            },
            coupling: match s.friction {
                FrictionModel::Boxed => Coupling::Boxed,
                FrictionModel::Staggered { sweeps } => Coupling::Staggered { sweeps },
            },
            tolerance: s.tolerance,
            pgs_iterations: s.iterations.max(10_000),
            friction_tolerance: 1e-8,
            friction_iterations: 10_000,
            // Exactly the configured alternations (the contact world pins its trajectories).
            max_sweeps: 0,
        };
        let mut z = z0;
        let DenseScratch {
            sparse,
            bounds,
            rows,
            ..
        } = &mut scratch;
        // Same body pairs: the same pattern and, with the same number of rows, the
        // same classes (rows 3k one-sided).
        let solved = solve_rows_in(rows, sparse, &q, bounds, &settings, &mut z, same_pattern);
        self.dense = scratch;
        let stats = solved.map_err(ContactError::Lcp)?;
        self.path.boxed_pgs = stats.boxed_pgs;
        self.path.boxed_fallback = stats.boxed_fallback;
        self.path.normal = stats.accepted;
        self.path.friction_pgs = stats.friction_pgs;
        self.path.friction_budget = stats.friction_budget;
        Ok((z, stats.iterations))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::{box_stack, pyramid};
    use alloc::vec;

    /// The all-pairs assembly the sparse one replaced.
    fn all_pairs(w: &ContactWorld) -> Vec<f64> {
        let n = w.rows.len();
        let mut a = vec![0.0; n * n];
        for (i, ri) in w.rows.iter().enumerate() {
            for (j, rj) in w.rows.iter().enumerate().skip(i) {
                let mut s = 0.0;
                for (si, bi) in [(0usize, ri.a), (2usize, ri.b)] {
                    let Some(bi) = bi else { continue };
                    for (sj, bj) in [(0usize, rj.a), (2usize, rj.b)] {
                        if Some(bi) == bj {
                            s += ri.j[si].dot(rj.mj[sj]) + ri.j[si + 1].dot(rj.mj[sj + 1]);
                        }
                    }
                }
                a[i * n + j] = s;
                a[j * n + i] = s;
            }
        }
        a
    }

    #[test]
    fn sparse_assembly_equals_all_pairs_bit_for_bit() {
        for mut w in [box_stack(6).unwrap(), pyramid(4).unwrap()] {
            w.settings.solver = ContactSolver::Newton;
            for _ in 0..5 {
                w.step(1.0 / 60.0).unwrap();
            }
            assert!(w.rows.len() >= 60, "{} rows", w.rows.len());
            let mut scratch = DenseScratch::default();
            w.delassus_into(&mut scratch);
            let reference = all_pairs(&w);
            // The sparse rows list every non-zero with its bits (and the entries they
            // leave out are the all-pairs loop's +0), and only columns of rows that
            // share a body.
            let n = w.rows.len();
            assert!(scratch.sparse.is_valid(n));
            let a = scratch.sparse.to_dense();
            assert!(a
                .iter()
                .zip(&reference)
                .all(|(x, y)| x.to_bits() == y.to_bits()));
            let shares = |i: usize, j: usize| {
                let (ri, rj) = (&w.rows[i], &w.rows[j]);
                [ri.a, ri.b]
                    .into_iter()
                    .flatten()
                    .any(|b| rj.a == Some(b) || rj.b == Some(b))
            };
            for i in 0..n {
                let (cols, _) = scratch.sparse.row(i);
                assert!(cols.iter().all(|&j| shares(i, j)));
                assert_eq!(cols.len(), (0..n).filter(|&j| shares(i, j)).count());
            }
            // Sparse indeed: rows meet only their neighbours' (measured non-zero: 2048 of
            // 5184 entries on the stack, 10080 of 36864 on the pyramid); tolerance half.
            let nonzero = a.iter().filter(|x| **x != 0.0).count();
            println!("{} of {} entries non-zero", nonzero, a.len());
            assert!(2 * nonzero < a.len(), "{nonzero} of {}", a.len());
        }
    }

    /// Reusing the last step's pattern and block split (same body pairs) changes no
    /// bit: a world that rebuilds both every step (fresh buffers) takes the same steps,
    /// through steps whose contacts change and steps whose contacts stay.
    #[test]
    fn pattern_reuse_equals_a_fresh_build_bit_for_bit() {
        use crate::scenes::box_stack;
        for (mut kept, solver) in [
            (box_stack(6).unwrap(), ContactSolver::Newton),
            (pyramid(4).unwrap(), ContactSolver::Newton),
            (box_stack(4).unwrap(), ContactSolver::Lemke),
            (box_stack(4).unwrap(), ContactSolver::Pgs),
        ] {
            kept.settings.solver = solver;
            let mut fresh = kept.clone();
            let (mut reused, mut rebuilt) = (0, 0);
            for step in 0..90 {
                if step == 20 {
                    // Throw the top box up: its contacts go and come back.
                    for w in [&mut kept, &mut fresh] {
                        let up = -w.gravity.normalize();
                        let top = w.bodies().len() - 1;
                        w.bodies_mut()[top].v += 3.0 * up;
                    }
                }
                let before = kept.dense.pairs.clone();
                fresh.dense = DenseScratch::default();
                kept.step(1.0 / 60.0).unwrap();
                fresh.step(1.0 / 60.0).unwrap();
                if kept.dense.pairs == before {
                    reused += 1;
                } else {
                    rebuilt += 1;
                }
                let bits = |w: &ContactWorld| {
                    w.bodies()
                        .iter()
                        .flat_map(|b| {
                            [b.pose.x, b.v, b.omega]
                                .into_iter()
                                .flat_map(|v| v.to_array())
                                .chain(b.pose.q.to_array())
                        })
                        .map(f64::to_bits)
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(&kept), bits(&fresh), "{solver:?}");
            }
            // Both kinds of step happened (measured: 87 reused, 3 rebuilt, in each scene).
            println!("{solver:?}: {reused} steps reused the pattern, {rebuilt} rebuilt it");
            assert!(
                reused > 0 && rebuilt > 0,
                "{reused} reused, {rebuilt} rebuilt"
            );
        }
    }
}
