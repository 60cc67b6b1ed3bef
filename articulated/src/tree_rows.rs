//! Baraff's tree factorization ([`crate::tree`]) with extra equality rows folded into
//! the tree's nodes, so that one-sided rows held as equalities (an active set of joint
//! limits, dry friction and contacts with the static world) cost one `O(n)` factor and
//! solve instead of one tree solve per row and a dense Delassus matrix.
//!
//! The augmented KKT system of the joint tree `H` and the extra rows `G_A`,
//!
//! ```text
//! [H    G_Aᵀ] [x]   [b]
//! [G_A   0  ] [ζ] = [r]
//! ```
//!
//! keeps the tree's graph when every extra row acts on the bodies of one tree node's
//! neighbourhood:
//!
//! * a row on the two bodies of tree joint `j` (a limit, dry friction) is one more row
//!   of joint `j`'s node;
//! * a row on body `i` alone (a contact with the static world) is one more row of the
//!   joint node above `i` (`parent(i)`, whose child `i` is): the node's block row then
//!   touches `i` and the parent body only, as before. A root body (no joint above it)
//!   takes the row into its own node, after its six unknowns.
//!
//! Each node's unknowns are its base rows (body twist or joint rows) followed by the
//! extra rows, and the node block `D_k` is factored `LDLᵀ` without pivoting in that
//! order, so the extra rows are eliminated after the rows they share a node with: the
//! pivot of a contact row is `−G D⁻¹ Gᵀ` through the joint above it (negative definite,
//! as a joint's). An extra row whose pivot is zero is dropped (`ζ = 0`, the factor is
//! that of the system without it): either it depends on the rows before it, or — the
//! usual case — the node has more rows than its child subtree has freedoms (a foot's
//! contacts under its hinge), so it is dependent only within the subtree; the caller
//! solves the dropped rows by their small Schur complement (`world/active_set.rs`).
//! The joints' base rows come first, so they stay hard. No fill-in appears:
//! eliminating a node still touches only its parent. Node blocks have any size (`base + extra` rows), held in
//! flat arenas reused across steps.
//!
//! Tolerances: a base pivot is dropped below `1e-12 ×` the largest base diagonal of its
//! node (as in [`crate::tree`]); an extra pivot below `1e-12 ×` the largest diagonal of
//! its node's extra rows before the node's elimination (`|g D_c⁻¹ gᵀ|` through the
//! child subtree), so a contact's pivot is measured against the contacts, not against
//! the body's mass, and a row the joint rows fully determine (a contact on a welded
//! body) is dropped; an extra pivot of the wrong sign (positive: it is `−g D⁻¹ gᵀ`) is
//! round-off of a dependent row and dropped too.
//!
//! The active set refactors when its set of rows changes, on the same tree matrix
//! within a step; the nodes below no change are then taken from the last factor
//! ([`Reuse`], the same bits) and not loaded. Measured (issue 13, callgrind
//! `World::step` instructions, `simulate` 2 s, humanoid_CMU 0.5 s): dm humanoid
//! controlled 359.95M → 347.58M, perturbed 585.30M → 577.89M, passive 544.91M →
//! 541.46M; humanoid_CMU controlled 566.32M → 563.05M, passive 234.66M → 234.20M;
//! swimmer6, dm hopper, pusher and the cheetahs within ±0.2 % (swimmer6 controlled
//! +0.1 %, the cheetahs −0.6 % to −1.1 %).
//!
//! The assembly and the solve's bookkeeping (issue 13, the small models, where the
//! active set factors about 1.6 times and solves about 4.3 times a step: gymnasium's
//! half_cheetah controlled, 2 s, 168 tries, 297 iterations, 272 factors, 719 factor
//! solves). Cut with the same bits: the solve kernels picked by a per-node index into
//! one jump table ([`KERNEL_SHAPES`], where `(n, np)` was compared with 32 shapes at
//! every node of every pass), the tree blocks' rows copied by fixed-length loops per
//! row length (no `memcpy` call per hinge row), the sizes, offsets, runs and schedule
//! written into sized tables along iterators, the extra rows placed a row at a time.
//! `instr34` (`World::step` instructions): half_cheetah 36.16M → 35.61M (−1.5 %),
//! dm cheetah −1.6 %, walker −1.6 %, pusher −1.4 %, dm hopper −1.3 %, swimmer6
//! −0.6 %, the humanoids −0.8 % to −1.5 %, fish and reacher unchanged. Tried and left
//! out (each measured worse, the compiler's inlining moving): the Schur correction's
//! forward pass on its rows' paths only (`0 · d⁻¹` elsewhere, the same bits), with
//! the backward pass out of line (half_cheetah +0.04 %, dm humanoid +0.44 %); the
//! Schur rows' values gathered once for the hold test and `S ζ = r`, and the base
//! pivots' check by iterators (half_cheetah +0.23 %, every run worse).
//!
//! Tried and left out (issue 13, session 41, the same bits): a copy `Wᵀ` written by
//! the factor beside `W` (and kept with it across refactors) for the backward pass's
//! `W x_p`, read a contiguous column at a time as `tree.rs` does. half_cheetah
//! controlled: `RowTree::solve` 2.06M → 1.96M and `solve_sparse` 1.61M → 1.52M, but
//! `update_fixed` 1.68M → 1.83M and `factor` 0.61M → 0.66M for the copy (2.6 solves
//! per factor there); `World::step` 32.53M → 32.63M, dm cheetah 32.78M → 32.91M,
//! pusher_v5 33.04M → 33.28M, manipulator 570.89M → 572.55M.

use alloc::vec::Vec;

use constraint_core::DVec3;

use crate::error::ArticulatedError;
use crate::tree::{TreeSolver, NONE};

/// One extra equality row: the node it joins, its bodies and its Jacobian
/// `[v_a, ω_a, v_b, ω_b]` (`None`: the world).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ExtraRow {
    /// The tree node the row is appended to.
    pub node: usize,
    /// First body (`None`: the world).
    pub a: Option<usize>,
    /// Second body (`None`: the world).
    pub b: Option<usize>,
    /// `[v_a, ω_a, v_b, ω_b]`.
    pub j: [DVec3; 4],
}

/// The augmented factor (structure per active set, blocks per factor); every buffer is
/// kept across calls and only grows.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowTree {
    /// Per node: base dimension, total dimension, offset of its unknowns, of its
    /// diagonal block and of its off-diagonal block (to its parent).
    base: Vec<usize>,
    n: Vec<usize>,
    xoff: Vec<usize>,
    dpos: Vec<usize>,
    opos: Vec<usize>,
    /// Extra rows grouped by node: node `k`'s are `slot[start[k]..start[k + 1]]`, each
    /// an index into the caller's row list.
    start: Vec<usize>,
    slot: Vec<usize>,
    /// Position of each of the caller's rows among the unknowns.
    pos: Vec<usize>,
    diag: Vec<f64>,
    off: Vec<f64>,
    dinv: Vec<f64>,
    /// Total unknowns.
    pub size: usize,
    /// Next free slot per node while grouping.
    fill: Vec<usize>,
    /// Per node in elimination order, its shape and offsets ([`NodeShape`]), read once
    /// per node by the factor and the solve instead of from six tables.
    schedule: Vec<NodeShape>,
    /// Per node: its index in `schedule` (for [`Self::forward_steps`]).
    step_of: Vec<usize>,
    /// The tree's unknowns in runs contiguous in both layouts, `(tree offset, offset
    /// here, length)`: a run ends at a node with extra rows (built by
    /// [`Self::assemble`]; [`Self::copy_from_tree`], [`Self::copy_to_tree`]).
    runs: Vec<(usize, usize, usize)>,
    /// This assembly's rows (the caller's order; `slot` groups them by node), kept for
    /// the next assembly's comparison ([`Reuse`]).
    rows: Vec<ExtraRow>,
    /// The arenas hold the factor of the last assembly (of the tree blocks `stamp`).
    factored: bool,
    stamp: usize,
    /// The last factor, kept for the next factor of the same tree matrix ([`Reuse`]).
    prev: Reuse,
    /// Per node: whether [`Self::factor`] computes it (else it takes `prev`'s), when
    /// `incremental`.
    dirty: Vec<bool>,
    incremental: bool,
}

/// The last factor's blocks and layout, for the next factor of the same tree matrix
/// (the active set's next iteration: only its set of rows changed).
///
/// A node's blocks before elimination read the tree's blocks (the same for the same
/// [`TreeSolver::stamp`]), its own extra rows (its diagonal block, a root body's; its
/// block to the parent) and its parent's extra rows (a joint node's rows on its child
/// body fill that body's block to it). A node whose rows and whose parent's rows are
/// those of the last factor (bit for bit, in order), with every node below it so too,
/// gets the same `D_k`, `d⁻¹` and `W_k` — the same operations on the same bits — so
/// they are copied from the last factor instead of computed; its update of its parent's
/// block, `D_p −= Wᵀ d⁻¹ W`, is applied from them when the parent is computed (the same
/// operations, in the same order of children). Every other node is computed as before.
#[derive(Clone, Debug, Default)]
struct Reuse {
    /// Holds a factor, of the tree blocks `stamp`.
    valid: bool,
    stamp: usize,
    n: Vec<usize>,
    start: Vec<usize>,
    slot: Vec<usize>,
    rows: Vec<ExtraRow>,
    xoff: Vec<usize>,
    dpos: Vec<usize>,
    opos: Vec<usize>,
    diag: Vec<f64>,
    off: Vec<f64>,
    dinv: Vec<f64>,
}

/// Whether two extra rows are the same bit for bit (node, bodies and Jacobian).
fn same_row(p: &ExtraRow, q: &ExtraRow) -> bool {
    p.node == q.node
        && p.a == q.a
        && p.b == q.b
        && p.j.iter().zip(&q.j).all(|(u, v)| {
            u.x.to_bits() == v.x.to_bits()
                && u.y.to_bits() == v.y.to_bits()
                && u.z.to_bits() == v.z.to_bits()
        })
}

/// One node's shape and offsets in the flat arenas, built by [`RowTree::assemble`]
/// (`np = 0`, `xp = op = 0` for a root).
#[derive(Clone, Copy, Debug, Default)]
struct NodeShape {
    /// The tree node.
    k: usize,
    /// Base rows (the tree's node dimension).
    base: usize,
    /// Total rows (base plus extra).
    n: usize,
    /// The parent's total rows (0: a root).
    np: usize,
    /// Offset of the diagonal block in `diag`.
    dp: usize,
    /// Offset of the node's unknowns.
    xo: usize,
    /// Offset of the parent's unknowns.
    xp: usize,
    /// Offset of the off-diagonal block in `off`.
    op: usize,
    /// The solve kernel of the shape `(n, np)`: its index in [`KERNEL_SHAPES`] (0: the
    /// runtime-sized one), so that the passes pick it by one jump table
    /// (`kernel_dispatch!`) rather than by comparing `(n, np)` with each shape.
    kind: u8,
}

/// The node shapes `(n, np)` with fixed-size solve kernels, by kernel index; index 0
/// (`(0, 0)`) is the runtime-sized kernel for every other shape. `kernel_dispatch!`
/// lists the same shapes in the same order.
#[cfg_attr(not(test), allow(dead_code))]
const KERNEL_SHAPES: [(usize, usize); 33] = [
    (0, 0),
    (6, 0),
    (6, 3),
    (6, 4),
    (6, 5),
    (6, 6),
    (6, 7),
    (6, 8),
    (6, 9),
    (6, 10),
    (6, 11),
    (6, 12),
    (6, 13),
    (6, 14),
    (6, 15),
    (3, 6),
    (4, 6),
    (5, 6),
    (7, 6),
    (8, 6),
    (9, 6),
    (10, 6),
    (11, 6),
    (12, 6),
    (13, 6),
    (14, 6),
    (15, 6),
    (3, 0),
    (4, 0),
    (5, 0),
    (7, 0),
    (8, 0),
    (9, 0),
];

/// The kernel index of the shape `(n, np)` ([`KERNEL_SHAPES`]; 0 for a shape without a
/// fixed kernel), by arithmetic on the table's runs (a search of the table cost about
/// 60 instructions a node and assembly).
fn kernel_of(n: usize, np: usize) -> u8 {
    let i = match (n, np) {
        (6, 0) => 1,
        (6, 3..=15) => 2 + (np - 3),
        (3..=5, 6) => 15 + (n - 3),
        (7..=15, 6) => 18 + (n - 7),
        (3..=5, 0) => 27 + (n - 3),
        (7..=9, 0) => 30 + (n - 7),
        _ => 0,
    };
    i as u8
}

/// `$f::<N, NP>($args)` for the kernel `$kind` ([`KERNEL_SHAPES`]' order; any other
/// index: the runtime-sized `$f::<0, 0>`). `$args` is a macro called with the shape, so
/// that the arguments are built for it.
macro_rules! kernel_dispatch {
    ($kind:expr, $f:ident, $args:ident) => {
        match $kind {
            1 => $f::<6, 0>($args!(6, 0)),
            2 => $f::<6, 3>($args!(6, 3)),
            3 => $f::<6, 4>($args!(6, 4)),
            4 => $f::<6, 5>($args!(6, 5)),
            5 => $f::<6, 6>($args!(6, 6)),
            6 => $f::<6, 7>($args!(6, 7)),
            7 => $f::<6, 8>($args!(6, 8)),
            8 => $f::<6, 9>($args!(6, 9)),
            9 => $f::<6, 10>($args!(6, 10)),
            10 => $f::<6, 11>($args!(6, 11)),
            11 => $f::<6, 12>($args!(6, 12)),
            12 => $f::<6, 13>($args!(6, 13)),
            13 => $f::<6, 14>($args!(6, 14)),
            14 => $f::<6, 15>($args!(6, 15)),
            15 => $f::<3, 6>($args!(3, 6)),
            16 => $f::<4, 6>($args!(4, 6)),
            17 => $f::<5, 6>($args!(5, 6)),
            18 => $f::<7, 6>($args!(7, 6)),
            19 => $f::<8, 6>($args!(8, 6)),
            20 => $f::<9, 6>($args!(9, 6)),
            21 => $f::<10, 6>($args!(10, 6)),
            22 => $f::<11, 6>($args!(11, 6)),
            23 => $f::<12, 6>($args!(12, 6)),
            24 => $f::<13, 6>($args!(13, 6)),
            25 => $f::<14, 6>($args!(14, 6)),
            26 => $f::<15, 6>($args!(15, 6)),
            27 => $f::<3, 0>($args!(3, 0)),
            28 => $f::<4, 0>($args!(4, 0)),
            29 => $f::<5, 0>($args!(5, 0)),
            30 => $f::<7, 0>($args!(7, 0)),
            31 => $f::<8, 0>($args!(8, 0)),
            32 => $f::<9, 0>($args!(9, 0)),
            _ => $f::<0, 0>($args!(0, 0)),
        }
    };
}

impl RowTree {
    /// Sets the last factor aside ([`Reuse`]; buffer swaps, no copy) when the arenas
    /// hold one: the assembly that follows rebuilds every table and arena it swaps in.
    #[inline(never)]
    fn set_aside(&mut self) {
        self.incremental = false;
        if self.factored {
            let p = &mut self.prev;
            core::mem::swap(&mut self.n, &mut p.n);
            core::mem::swap(&mut self.start, &mut p.start);
            core::mem::swap(&mut self.slot, &mut p.slot);
            core::mem::swap(&mut self.rows, &mut p.rows);
            core::mem::swap(&mut self.xoff, &mut p.xoff);
            core::mem::swap(&mut self.dpos, &mut p.dpos);
            core::mem::swap(&mut self.opos, &mut p.opos);
            core::mem::swap(&mut self.diag, &mut p.diag);
            core::mem::swap(&mut self.off, &mut p.off);
            core::mem::swap(&mut self.dinv, &mut p.dinv);
            p.valid = true;
            p.stamp = self.stamp;
        }
        self.factored = false;
    }

    /// Places the rows into the tree's nodes and loads the blocks: `tree`'s assembled
    /// (not yet factored) `H` plus the rows `G_A` with zero diagonal. Returns `false`
    /// when a row does not fit the node it names (its bodies are not that node's
    /// neighbours).
    pub fn assemble(&mut self, tree: &TreeSolver, rows: &[ExtraRow]) -> bool {
        let nn = tree.dim.len();
        let nb = tree.n_bodies;
        self.set_aside();
        // Group the rows by node (counting sort: rows keep their order within a node).
        self.start.clear();
        self.start.resize(nn + 1, 0);
        for r in rows {
            if r.node >= nn {
                return false;
            }
            self.start[r.node + 1] += 1;
        }
        for k in 0..nn {
            self.start[k + 1] += self.start[k];
        }
        // `slot` is a permutation of the rows (every entry written below), so it is
        // only resized, not zero-filled first.
        self.slot.resize(rows.len(), 0);
        self.fill.clear();
        self.fill.extend_from_slice(&self.start[..nn]);
        for (i, r) in rows.iter().enumerate() {
            self.slot[self.fill[r.node]] = i;
            self.fill[r.node] += 1;
        }
        // Sizes and offsets (the tables sized, then written along zipped iterators:
        // a push per entry checked the capacity each time).
        self.base.clone_from(&tree.dim);
        self.n.resize(nn, 0);
        self.xoff.resize(nn, 0);
        self.dpos.resize(nn, 0);
        self.opos.resize(nn, 0);
        let (mut x, mut d) = (0, 0);
        let sizes = self.n.iter_mut().zip(&mut self.xoff).zip(&mut self.dpos);
        for (((nk, xo), dp), (&b, w)) in sizes.zip(tree.dim.iter().zip(self.start.windows(2))) {
            let n = b + w[1] - w[0];
            *nk = n;
            *xo = x;
            *dp = d;
            x += n;
            d += n * n;
        }
        let mut o = 0;
        for ((op, &nk), &p) in self.opos.iter_mut().zip(&self.n).zip(&tree.parent) {
            *op = o;
            if let Some(&npar) = self.n.get(p) {
                o += nk * npar;
            }
        }
        self.size = x;
        // The nodes the factor computes, against the last factor ([`Reuse`]): the
        // others' blocks are not loaded (the factor copies its own), nor their rows.
        self.mark_dirty(tree, rows);
        let reuse = self.incremental;
        // Every element of `diag` and `off` is written below (the tree's block, zeros
        // elsewhere), so the arenas are only resized, not cleared and zero-filled first.
        self.diag.resize(d, 0.0);
        self.off.resize(o, 0.0);
        // `dinv` is written whole by `factor` (every node's `n` pivots, the schedule
        // holding every node) before `dropped` reads it, and `pos` is written for every
        // row below when this returns `true`: both only resized, not zero-filled.
        self.dinv.resize(x, 0.0);
        self.pos.resize(rows.len(), 0);
        // The tree's blocks, zero-padded to the node's (and its parent's) total rows. A
        // node without extra rows (and, for the off-diagonal block, a parent without
        // any) is copied row by row; otherwise the block is zeroed once and the tree's
        // rows copied in (one `memset` a block, where a fill per padded row and per
        // extra row called it about 40 times an assembly: dm cheetah, 8 280 calls in
        // 209 assemblies).
        for k in 0..nn {
            if reuse && !self.dirty[k] {
                continue;
            }
            let (b, n, dp) = (self.base[k], self.n[k], self.dpos[k]);
            let blk = &mut self.diag[dp..dp + n * n];
            if n != b {
                blk.fill(0.0);
            }
            copy_rows(blk, n, &tree.blocks[k].diag, b, b);
            let p = tree.parent[k];
            if p != NONE {
                let (bp, np, op) = (self.base[p], self.n[p], self.opos[k]);
                let blk = &mut self.off[op..op + n * np];
                if n != b || np != bp {
                    blk.fill(0.0);
                }
                copy_rows(blk, np, &tree.blocks[k].off, b, bp);
            }
        }
        // The base unknowns' runs, node order (both layouts place the nodes in it); the
        // run being extended is kept aside, pushed when the next one starts.
        self.runs.clear();
        let mut run: Option<(usize, usize, usize)> = None;
        for ((&o, &xo), &b) in tree.offset.iter().zip(&self.xoff).zip(&self.base) {
            match &mut run {
                Some(r) if r.0 + r.2 == o && r.1 + r.2 == xo => r.2 += b,
                _ => {
                    if let Some(r) = run {
                        self.runs.push(r);
                    }
                    run = Some((o, xo, b));
                }
            }
        }
        if let Some(r) = run {
            self.runs.push(r);
        }
        // The schedule the factor and the solve walk (sized, then written in order).
        self.schedule.resize(tree.order.len(), NodeShape::default());
        self.step_of.clear();
        self.step_of.resize(nn, usize::MAX);
        for (i, (s, &k)) in self.schedule.iter_mut().zip(&tree.order).enumerate() {
            if let Some(v) = self.step_of.get_mut(k) {
                *v = i;
            }
            let p = tree.parent[k];
            let (np, xp, op) = if p == NONE {
                (0, 0, 0)
            } else {
                (self.n[p], self.xoff[p], self.opos[k])
            };
            let n = self.n[k];
            *s = NodeShape {
                k,
                base: self.base[k],
                n,
                np,
                dp: self.dpos[k],
                xo: self.xoff[k],
                xp,
                op,
                kind: kernel_of(n, np),
            };
        }
        // The extra rows, in `slot` order (node after node), a row at a time (not a
        // node at a time: most nodes have none).
        for e in 0..rows.len() {
            let ri = self.slot[e];
            let row = &rows[ri];
            let k = row.node;
            let (b, n) = (self.base[k], self.n[k]);
            {
                let lr = b + e - self.start[k];
                self.pos[ri] = self.xoff[k] + lr;
                // A kept node's rows are the last assembly's (which placed them), and
                // they fill its own blocks and its children's, all kept.
                if reuse && !self.dirty[k] {
                    continue;
                }
                for (side, body) in [(0usize, row.a), (1usize, row.b)] {
                    let Some(body) = body else { continue };
                    let blk = |c: usize| row.j[2 * side + c / 3][c % 3];
                    if k < nb {
                        // A root body's own row: in its diagonal block.
                        if body != k {
                            return false;
                        }
                        let dp = self.dpos[k];
                        for c in 0..6 {
                            self.diag[dp + lr * n + c] += blk(c);
                            self.diag[dp + c * n + lr] += blk(c);
                        }
                    } else if body == tree.parent[k] {
                        // H_{k, parent}: row lr, the parent body's six columns.
                        let (np, op) = (self.n[body], self.opos[k]);
                        for c in 0..6 {
                            self.off[op + lr * np + c] += blk(c);
                        }
                    } else if body < nb && tree.parent[body] == k {
                        // H_{child, k} = Gᵀ: the child body's six rows, column lr.
                        let op = self.opos[body];
                        for c in 0..6 {
                            self.off[op + c * n + lr] += blk(c);
                        }
                    } else {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Which nodes [`Self::factor`] computes against the last factor ([`Reuse`]):
    /// those whose rows or whose parent's rows changed, and every node above one; keeps
    /// `rows` for the next assembly's comparison. Out of line: inlined, the assembly's
    /// own loops took about 40 more instructions a node (humanoid_CMU, slice indexing).
    #[inline(never)]
    fn mark_dirty(&mut self, tree: &TreeSolver, rows: &[ExtraRow]) {
        self.rows.clear();
        self.rows.extend_from_slice(rows);
        let nn = tree.dim.len();
        let p = &self.prev;
        if !(p.valid
            && p.stamp == tree.stamp()
            && p.n.len() == nn
            && p.start.len() == nn + 1
            && p.slot.len() == p.rows.len())
        {
            return;
        }
        // `dirty[k]` first holds whether node k's own rows are unchanged.
        self.dirty.clear();
        self.dirty.extend((0..nn).map(|k| {
            let (now, was) = (
                &self.slot[self.start[k]..self.start[k + 1]],
                &p.slot[p.start[k]..p.start[k + 1]],
            );
            self.n[k] == p.n[k]
                && now.len() == was.len()
                && now
                    .iter()
                    .zip(was)
                    .all(|(&u, &v)| same_row(&self.rows[u], &p.rows[v]))
        }));
        for &k in &tree.order {
            // Children before parents: `dirty[parent]` still holds its own rows' test.
            let parent = tree.parent[k];
            let same = self.dirty[k] && (parent == NONE || self.dirty[parent]);
            self.dirty[k] = !same;
        }
        // Children before parents: a computed node's parent is computed.
        for &k in &tree.order {
            let parent = tree.parent[k];
            if self.dirty[k] && parent != NONE {
                self.dirty[parent] = true;
            }
        }
        self.incremental = true;
    }

    /// Copies the tree's unknowns `src` (the tree's layout) to their places in `dst`
    /// (this layout; the extra rows' entries untouched), a run at a time.
    pub fn copy_from_tree(&self, src: &[f64], dst: &mut [f64]) {
        for &(o, xo, n) in &self.runs {
            dst[xo..xo + n].copy_from_slice(&src[o..o + n]);
        }
    }

    /// [`Self::copy_from_tree`]'s inverse: the tree's unknowns of `src` (this layout)
    /// into `dst` (the tree's layout).
    pub fn copy_to_tree(&self, src: &[f64], dst: &mut [f64]) {
        for &(o, xo, n) in &self.runs {
            dst[o..o + n].copy_from_slice(&src[xo..xo + n]);
        }
    }

    /// Where caller row `i` sits among the unknowns (after [`Self::assemble`]).
    #[inline]
    pub fn row_position(&self, i: usize) -> usize {
        self.pos[i]
    }

    /// Offset of tree node `k`'s unknowns (its base rows first).
    #[inline]
    pub fn node_offset(&self, k: usize) -> usize {
        self.xoff[k]
    }

    /// Whether unknown `u`'s pivot was dropped (a dependent row, `ζ = 0`).
    #[inline]
    pub fn dropped(&self, u: usize) -> bool {
        self.dinv[u] == 0.0
    }

    /// Block `LDLᵀ` leaves first, as [`TreeSolver::factor`] with node blocks of any
    /// size: `D_k = L d Lᵀ`, `W_k = L⁻¹ H_{k,p}`, `D_p −= W_kᵀ d⁻¹ W_k`. A body's six
    /// base pivots must be positive ([`ArticulatedError::Singular`] otherwise).
    ///
    /// After an assembly of the same tree matrix whose rows changed at some nodes only,
    /// the nodes below no change are taken from the last factor ([`Reuse`]): the same
    /// bits.
    pub fn factor(&mut self, tree: &TreeSolver) -> Result<(), ArticulatedError> {
        if self.incremental && self.dirty.len() == tree.dim.len() {
            self.factor_nodes::<true>(tree)?;
        } else {
            self.factor_nodes::<false>(tree)?;
        }
        self.factored = true;
        self.stamp = tree.stamp();
        Ok(())
    }

    /// [`Self::factor`]'s elimination; with `REUSE` the nodes `dirty` leaves out are
    /// taken from the last factor (without it the code is the whole factor's alone).
    #[inline(always)]
    fn factor_nodes<const REUSE: bool>(
        &mut self,
        tree: &TreeSolver,
    ) -> Result<(), ArticulatedError> {
        let nb = tree.n_bodies;
        for &NodeShape {
            k,
            base: b,
            n,
            np,
            dp,
            xo,
            op,
            ..
        } in &self.schedule
        {
            // A node below no change: its `D_k`, `d⁻¹` and `W_k` are the last factor's.
            let kept = REUSE && !self.dirty[k];
            if kept {
                let p = &self.prev;
                let (pd, px) = (p.dpos[k], p.xoff[k]);
                self.diag[dp..dp + n * n].copy_from_slice(&p.diag[pd..pd + n * n]);
                self.dinv[xo..xo + n].copy_from_slice(&p.dinv[px..px + n]);
                if np > 0 {
                    let po = p.opos[k];
                    self.off[op..op + n * np].copy_from_slice(&p.off[po..po + n * np]);
                }
            } else {
                let blk = &mut self.diag[dp..dp + n * n];
                let dinv = &mut self.dinv[xo..xo + n];
                ldlt_two_segment(blk, n, b, dinv);
                if k < nb && (0..b).any(|r| !(blk[r * n + r] > 0.0) || dinv[r] == 0.0) {
                    return Err(ArticulatedError::Singular { node: k });
                }
            }
            if np == 0 {
                continue;
            }
            // A kept node's parent is kept as well unless something changed below it;
            // a computed parent takes the kept node's update `D_p −= Wᵀ d⁻¹ W`.
            if kept && !self.dirty[tree.parent[k]] {
                continue;
            }
            let dpp = self.dpos[tree.parent[k]];
            let w = &mut self.off[op..op + n * np];
            let (blk, dpar) = if dp < dpp {
                let (lo, hi) = self.diag.split_at_mut(dpp);
                (&lo[dp..dp + n * n], &mut hi[..np * np])
            } else {
                let (lo, hi) = self.diag.split_at_mut(dp);
                (&hi[..n * n], &mut lo[dpp..dpp + np * np])
            };
            let dinv = &self.dinv[xo..xo + n];
            // Fixed-size kernels for the shapes of a chain's nodes (loops unroll).
            macro_rules! dispatch {
                ($fixed:ident, $args:tt, $dyn:expr; $($a:literal, $b:literal);*) => {
                    match (n, np) {
                        $(($a, $b) => $fixed::<$a, $b> $args,)*
                        _ => $dyn,
                    }
                };
            }
            if kept {
                dispatch!(update_parent_fixed, (dinv, w, dpar),
                    update_parent_dyn(n, np, dinv, w, dpar);
                    6, 3; 6, 4; 6, 5; 6, 6; 6, 7; 6, 8; 6, 9; 6, 10; 6, 11; 6, 12;
                    6, 13; 6, 14; 6, 15;
                    3, 6; 4, 6; 5, 6; 7, 6; 8, 6; 9, 6; 10, 6; 11, 6; 12, 6; 13, 6; 14, 6;
                    15, 6);
            } else {
                dispatch!(update_fixed, (blk, dinv, w, dpar),
                    update_dyn(n, np, blk, dinv, w, dpar);
                    6, 3; 6, 4; 6, 5; 6, 6; 6, 7; 6, 8; 6, 9; 6, 10; 6, 11; 6, 12;
                    6, 13; 6, 14; 6, 15;
                    3, 6; 4, 6; 5, 6; 7, 6; 8, 6; 9, 6; 10, 6; 11, 6; 12, 6; 13, 6; 14, 6;
                    15, 6);
            }
        }
        Ok(())
    }

    /// Solves the augmented system in place (`x` of length [`Self::size`], laid out
    /// node by node, base rows first): forward `s = d⁻¹ L⁻¹ y`, `y_p −= Wᵀ s`; backward
    /// `x = L⁻ᵀ (s − d⁻¹ W x_p)`. The tree's structure is read from the schedule
    /// [`Self::assemble`] built from `_tree` (the same tree).
    pub fn solve(&self, _tree: &TreeSolver, x: &mut [f64]) {
        for s in &self.schedule {
            macro_rules! args {
                ($a:literal, $b:literal) => {
                    self.node_args::<$a, $b>(s, x)
                };
            }
            kernel_dispatch!(s.kind, forward, args);
        }
        self.backward_pass(x);
    }

    /// [`Self::solve`] for a right-hand side zero at most nodes (the Schur rows'
    /// `Gᵀ ζ`, on a few bodies, `world/active_set.rs`): the forward pass skips a node
    /// whose unknowns are all zero when it is reached (nothing below it sent it
    /// anything), the backward pass is whole (every unknown is read). At such a node
    /// the full pass computes `s = d⁻¹ L⁻¹ 0 = ±0` and sends `y_p −= Wᵀ (±0)`, which
    /// changes no value (at most a zero's sign), so the result equals
    /// [`Self::solve`]'s. Measured on dm_control's humanoid (31 nodes, 2 s passive):
    /// about a fifth of the nodes are skipped (the Schur rows' paths together cover
    /// most of the tree); the controlled runs skip more.
    pub fn solve_sparse(&self, _tree: &TreeSolver, x: &mut [f64]) {
        for s in &self.schedule {
            macro_rules! args {
                ($a:literal, $b:literal) => {
                    self.node_args::<$a, $b>(s, x)
                };
            }
            kernel_dispatch!(s.kind, forward_nonzero, args);
        }
        self.backward_pass(x);
    }

    /// The backward pass of [`Self::solve`] and [`Self::solve_sparse`] over every node,
    /// root first: `x = L⁻ᵀ (s − d⁻¹ W x_p)` (always inlined, as each solve's own loop
    /// was).
    #[inline(always)]
    fn backward_pass(&self, x: &mut [f64]) {
        for s in self.schedule.iter().rev() {
            macro_rules! args {
                ($a:literal, $b:literal) => {
                    self.node_args::<$a, $b>(s, x)
                };
            }
            kernel_dispatch!(s.kind, backward, args);
        }
    }

    /// Node `k`'s index in the elimination order ([`Self::forward_steps`]).
    #[inline]
    pub fn step_of(&self, k: usize) -> usize {
        self.step_of.get(k).copied().unwrap_or(usize::MAX)
    }

    /// [`Self::solve`]'s forward pass (`s = d⁻¹ L⁻¹ y` at each node, `y_p −= Wᵀ s`) at
    /// the nodes `steps` only (their indices in the elimination order,
    /// [`Self::step_of`], ascending). For a right-hand side zero outside those nodes,
    /// with the set closed under parents (a row's bodies and their ancestors), the
    /// result equals the full pass's: the other nodes hold zero and send nothing up.
    /// `gᵀ H_A⁻¹ g' = Σ_u s_u s'_u / d⁻¹_u` over the unknowns with
    /// [`Self::pivot_inverses`] non-zero then needs only the paths to the root
    /// (`world/active_set.rs`'s Schur rows). It walked the whole schedule, testing a
    /// mark per node, before: a fifth of the pass on dm_control's humanoid, whose
    /// Schur rows' paths hold about 9 of its nodes.
    pub fn forward_steps(&self, x: &mut [f64], steps: &[usize]) {
        // (A step past the schedule, `usize::MAX` from `step_of` of a node it does
        // not hold, is no node's: skipped, as the marked walk would have.)
        for &i in steps {
            let Some(s) = self.schedule.get(i) else {
                continue;
            };
            macro_rules! args {
                ($a:literal, $b:literal) => {
                    self.node_args::<$a, $b>(s, x)
                };
            }
            kernel_dispatch!(s.kind, forward, args);
        }
    }

    /// Node `k`'s number of unknowns (base and extra rows).
    #[inline]
    pub fn node_len(&self, k: usize) -> usize {
        self.n[k]
    }

    /// Unknowns `o..o + n`'s inverse pivots `d⁻¹` (zero: dropped), as one slice.
    #[inline]
    pub fn pivot_inverses(&self, o: usize, n: usize) -> &[f64] {
        &self.dinv[o..o + n]
    }

    /// Node `s`'s blocks and its own and its parent's unknowns, split from `x`
    /// (inlined into both passes: a call per node cost a fifth of the solve). `N`,
    /// `NP`: the node's shape when the caller's kernel has it as constants (`0, 0`:
    /// the runtime one), so the slices' lengths are constants too (no multiply, and
    /// the fixed kernels' re-slicing to `N`, `NP` needs no check).
    #[inline(always)]
    fn node_args<'a, const N: usize, const NP: usize>(
        &'a self,
        s: &NodeShape,
        x: &'a mut [f64],
    ) -> NodeArgs<'a> {
        let NodeShape {
            n,
            np,
            dp,
            xo,
            xp,
            op,
            ..
        } = *s;
        let (n, np) = if N != 0 { (N, NP) } else { (n, np) };
        // A parent's unknowns never overlap its child's.
        let (xi, xpar) = if np == 0 {
            (&mut x[xo..xo + n], &mut [][..])
        } else if xo < xp {
            let (lo, hi) = x.split_at_mut(xp);
            (&mut lo[xo..xo + n], &mut hi[..np])
        } else {
            let (lo, hi) = x.split_at_mut(xo);
            (&mut hi[..n], &mut lo[xp..xp + np])
        };
        NodeArgs {
            n,
            np,
            d: &self.diag[dp..dp + n * n],
            dinv: &self.dinv[xo..xo + n],
            w: &self.off[op..op + n * np],
            xi,
            xp: xpar,
        }
    }
}

/// The first `rows` rows of a tree block, `len` entries each, into the first `len`
/// columns of the row-major `dst` of `stride` columns (the rest already zero). Each
/// length a node has (1 to 6: a body's 6, a hinge's 5, …) is copied by a loop of its
/// own, of fixed-size rows (moves, not a `memcpy` call: with the joints' rows of 5
/// copied by slice, the assembly called `memcpy` about 20 times, 2 940 of 7 085 calls
/// on gymnasium's half_cheetah controlled, 2 s).
#[inline(always)]
fn copy_rows(dst: &mut [f64], stride: usize, src: &[[f64; 6]; 6], rows: usize, len: usize) {
    #[inline(always)]
    fn fixed<const L: usize>(dst: &mut [f64], stride: usize, src: &[[f64; 6]; 6], rows: usize) {
        for (d, s) in dst.chunks_exact_mut(stride).zip(src).take(rows) {
            d[..L].copy_from_slice(&s[..L]);
        }
    }
    match len {
        6 => fixed::<6>(dst, stride, src, rows),
        5 => fixed::<5>(dst, stride, src, rows),
        4 => fixed::<4>(dst, stride, src, rows),
        3 => fixed::<3>(dst, stride, src, rows),
        2 => fixed::<2>(dst, stride, src, rows),
        1 => fixed::<1>(dst, stride, src, rows),
        _ => {
            for (d, s) in dst.chunks_exact_mut(stride).zip(src).take(rows) {
                d[..len].copy_from_slice(&s[..len]);
            }
        }
    }
}

/// One node's data for the solve kernels.
struct NodeArgs<'a> {
    n: usize,
    np: usize,
    d: &'a [f64],
    dinv: &'a [f64],
    w: &'a [f64],
    xi: &'a mut [f64],
    xp: &'a mut [f64],
}

/// Forward pass at one node: `s = d⁻¹ L⁻¹ y` (stored), `y_p −= Wᵀ s`; `N`/`NP` the
/// compile-time shapes (`0, 0`: the runtime ones).
#[inline(always)]
fn forward<const N: usize, const NP: usize>(a: NodeArgs<'_>) {
    if N != 0 {
        forward_fixed::<N, NP>(a);
        return;
    }
    let (n, np) = (a.n, a.np);
    let (d, dinv, w) = (&a.d[..n * n], &a.dinv[..n], &a.w[..n * np]);
    let (xi, xp) = (&mut a.xi[..n], &mut a.xp[..np]);
    for r in 0..n {
        let mut s = xi[r];
        for t in 0..r {
            s -= d[r * n + t] * xi[t];
        }
        xi[r] = s;
    }
    for r in 0..n {
        xi[r] *= dinv[r];
    }
    for t in 0..n {
        let s = xi[t];
        for c in 0..np {
            xp[c] -= w[t * np + c] * s;
        }
    }
}

/// [`forward`] at a node with a non-zero unknown; nothing at one whose unknowns are
/// all `±0` (every bit but the sign clear: one OR per unknown, unrolled for the
/// compile-time shapes), where [`forward`] would only write zeros.
#[inline(always)]
fn forward_nonzero<const N: usize, const NP: usize>(a: NodeArgs<'_>) {
    let n = if N != 0 { N } else { a.n };
    let bits = a.xi[..n].iter().fold(0u64, |acc, v| acc | v.to_bits());
    if bits << 1 != 0 {
        forward::<N, NP>(a);
    }
}

/// [`forward`] for the compile-time shape `N`, `NP`: the node's and the parent's
/// unknowns worked on in local arrays (registers; the slices' stores would be reloaded,
/// and the parent's update `y_p −= w_t s_t` row by row then shares vector lanes), the
/// same operations in the same order.
#[inline(always)]
fn forward_fixed<const N: usize, const NP: usize>(a: NodeArgs<'_>) {
    let (d, dinv, w) = (&a.d[..N * N], &a.dinv[..N], &a.w[..N * NP]);
    let (xi, xp) = (&mut a.xi[..N], &mut a.xp[..NP]);
    let mut u = [0.0; N];
    u.copy_from_slice(xi);
    for r in 0..N {
        let mut s = u[r];
        for t in 0..r {
            s -= d[r * N + t] * u[t];
        }
        u[r] = s;
    }
    for r in 0..N {
        u[r] *= dinv[r];
    }
    xi.copy_from_slice(&u);
    let mut y = [0.0; NP];
    y.copy_from_slice(xp);
    for t in 0..N {
        let s = u[t];
        for c in 0..NP {
            y[c] -= w[t * NP + c] * s;
        }
    }
    xp.copy_from_slice(&y);
}

/// Backward pass at one node: `x = L⁻ᵀ (s − d⁻¹ W x_p)` (always inlined: with two
/// solves calling it, `#[inline]` left it a call per node, 14.6M of dm_control's
/// humanoid's 2 s).
#[inline(always)]
fn backward<const N: usize, const NP: usize>(a: NodeArgs<'_>) {
    if N != 0 {
        backward_fixed::<N, NP>(a);
        return;
    }
    let (n, np) = (a.n, a.np);
    let (d, dinv, w) = (&a.d[..n * n], &a.dinv[..n], &a.w[..n * np]);
    let (xi, xp) = (&mut a.xi[..n], &a.xp[..np]);
    for r in 0..n {
        let mut acc = 0.0;
        for c in 0..np {
            acc += w[r * np + c] * xp[c];
        }
        xi[r] -= dinv[r] * acc;
    }
    for r in (0..n).rev() {
        let mut v = xi[r];
        for t in r + 1..n {
            v -= d[t * n + r] * xi[t];
        }
        xi[r] = v;
    }
}

/// [`backward`] for the compile-time shape `N`, `NP`, on local arrays (as
/// [`forward_fixed`]), the same operations in the same order.
#[inline(always)]
fn backward_fixed<const N: usize, const NP: usize>(a: NodeArgs<'_>) {
    let (d, dinv, w) = (&a.d[..N * N], &a.dinv[..N], &a.w[..N * NP]);
    let (xi, xp) = (&mut a.xi[..N], &a.xp[..NP]);
    let mut u = [0.0; N];
    u.copy_from_slice(xi);
    let mut y = [0.0; NP];
    y.copy_from_slice(xp);
    // `(W x_p)_r = Σ_c w_rc y_c`, each sum from 0 in `c` order, a column of `W` at a
    // time, stored into `xi` and read back (as in `tree.rs`'s backward pass: the store
    // lets the compiler pair two rows' sums in vector lanes, each the scalar sum).
    let mut acc = [0.0; N];
    for c in 0..NP {
        let yc = y[c];
        for r in 0..N {
            acc[r] += w[r * NP + c] * yc;
        }
    }
    xi.copy_from_slice(&acc);
    for r in 0..N {
        u[r] -= dinv[r] * xi[r];
    }
    for r in (0..N).rev() {
        let mut v = u[r];
        for t in r + 1..N {
            v -= d[t * N + r] * u[t];
        }
        u[r] = v;
    }
    xi.copy_from_slice(&u);
}

/// `W = L⁻¹ W` (`L` the unit lower factor in `blk`) and `D_p −= Wᵀ diag(dinv) W` on
/// the lower triangle, for an `N`-row node under an `NP`-row parent.
#[inline]
fn update_fixed<const N: usize, const NP: usize>(
    blk: &[f64],
    dinv: &[f64],
    w: &mut [f64],
    dpar: &mut [f64],
) {
    // `update_rows` below covers parent rows 0..16.
    const { assert!(NP <= 16) };
    let blk = &blk[..N * N];
    let dinv = &dinv[..N];
    let w = &mut w[..N * NP];
    let dpar = &mut dpar[..NP * NP];
    // Row `r`'s running value in a local accumulator (registers: stored once, not
    // after each of its `t` terms), the same operations in the same order.
    for r in 1..N {
        let mut acc = [0.0; NP];
        acc.copy_from_slice(&w[r * NP..(r + 1) * NP]);
        for t in 0..r {
            let l = blk[r * N + t];
            for c in 0..NP {
                acc[c] -= l * w[t * NP + c];
            }
        }
        w[r * NP..(r + 1) * NP].copy_from_slice(&acc);
    }
    update_parent_fixed::<N, NP>(dinv, w, dpar);
}

/// The second half of [`update_fixed`], `D_p −= Wᵀ d⁻¹ W` from `W = L⁻¹ H_{k,p}` (a
/// node kept from the last factor, `RowTree::factor`, has it already).
#[inline(always)]
fn update_parent_fixed<const N: usize, const NP: usize>(dinv: &[f64], w: &[f64], dpar: &mut [f64]) {
    const { assert!(NP <= 16) };
    let dinv = &dinv[..N];
    let w = &w[..N * NP];
    let dpar = &mut dpar[..NP * NP];
    // `sw_tr = w_tr d_t⁻¹`; `D_p −= Wᵀ d⁻¹ W` two rows of `D_p` at a time
    // ([`update_rows`]).
    let mut sw = [[0.0; NP]; N];
    for t in 0..N {
        for r in 0..NP {
            sw[t][r] = w[t * NP + r] * dinv[t];
        }
    }
    update_rows::<0, N, NP>(w, &sw, dpar);
    update_rows::<2, N, NP>(w, &sw, dpar);
    update_rows::<4, N, NP>(w, &sw, dpar);
    update_rows::<6, N, NP>(w, &sw, dpar);
    update_rows::<8, N, NP>(w, &sw, dpar);
    update_rows::<10, N, NP>(w, &sw, dpar);
    update_rows::<12, N, NP>(w, &sw, dpar);
    update_rows::<14, N, NP>(w, &sw, dpar);
}

/// Rows `R0` and `R0 + 1` of [`update_fixed`]'s `D_p −= Wᵀ d⁻¹ W` (lower triangle):
/// `d_rc −= Σ_t sw_tr w_tc` (`sw = d⁻¹ W`), one term at a time in `t` order from the
/// stored value, as the row-by-row update. The two rows side by side in local
/// accumulators (the two rows' terms of a column share vector lanes); row `R0`'s
/// column `R0 + 1` is computed and not stored. Nothing when `R0 ≥ NP`; row `R0` alone
/// when it is the last. `NP ≤ 16`.
#[inline(always)]
fn update_rows<const R0: usize, const N: usize, const NP: usize>(
    w: &[f64],
    sw: &[[f64; NP]; N],
    dpar: &mut [f64],
) {
    if R0 >= NP {
        return;
    }
    if R0 + 1 >= NP {
        let mut acc = [0.0; NP];
        acc[..=R0].copy_from_slice(&dpar[R0 * NP..R0 * NP + R0 + 1]);
        for t in 0..N {
            let s = sw[t][R0];
            for c in 0..=R0 {
                acc[c] -= s * w[t * NP + c];
            }
        }
        dpar[R0 * NP..R0 * NP + R0 + 1].copy_from_slice(&acc[..=R0]);
        return;
    }
    let mut acc = [[0.0; 2]; NP];
    for c in 0..=R0 {
        acc[c][0] = dpar[R0 * NP + c];
    }
    for c in 0..=R0 + 1 {
        acc[c][1] = dpar[(R0 + 1) * NP + c];
    }
    for t in 0..N {
        let (s0, s1) = (sw[t][R0], sw[t][R0 + 1]);
        for c in 0..=R0 + 1 {
            let b = w[t * NP + c];
            acc[c][0] -= s0 * b;
            acc[c][1] -= s1 * b;
        }
    }
    for c in 0..=R0 {
        dpar[R0 * NP + c] = acc[c][0];
    }
    for c in 0..=R0 + 1 {
        dpar[(R0 + 1) * NP + c] = acc[c][1];
    }
}

/// [`update_fixed`] for any shape.
fn update_dyn(n: usize, np: usize, blk: &[f64], dinv: &[f64], w: &mut [f64], dpar: &mut [f64]) {
    for r in 1..n {
        for t in 0..r {
            let l = blk[r * n + t];
            if l != 0.0 {
                for c in 0..np {
                    w[r * np + c] -= l * w[t * np + c];
                }
            }
        }
    }
    update_parent_dyn(n, np, dinv, w, dpar);
}

/// The second half of [`update_dyn`] (as [`update_parent_fixed`] of [`update_fixed`]).
fn update_parent_dyn(n: usize, np: usize, dinv: &[f64], w: &[f64], dpar: &mut [f64]) {
    for t in 0..n {
        let dt = dinv[t];
        if dt == 0.0 {
            continue;
        }
        let wt = &w[t * np..(t + 1) * np];
        for r in 0..np {
            let s = wt[r] * dt;
            if s == 0.0 {
                continue;
            }
            for c in 0..=r {
                dpar[r * np + c] -= s * wt[c];
            }
        }
    }
}

/// Most negative pivots one node's block can have: the unknowns of one rigid body
/// ([`ldlt_two_segment`]'s rank cap).
const MAX_NEGATIVE_PIVOTS: usize = 6;

/// In-place `LDLᵀ` of an `n × n` row-major block, no pivoting (`L` strictly below the
/// diagonal, `d` on it, `dinv = 1/d` or 0 for a dropped pivot, whose column of `L` is
/// zeroed). Pivots `0..base` are dropped below `1e-12 ×` the largest `|a_ii|` among
/// them; pivots `base..n` below `1e-12 ×` the largest of their diagonal values before
/// any elimination at this node, when positive (see below), and once the node holds
/// [`MAX_NEGATIVE_PIVOTS`] negative pivots.
///
/// The rank cap: every negative pivot of a node is a direction of `−G D⁻¹ Gᵀ` through
/// the six unknowns of one body (a joint node's child body, into which its subtree is
/// condensed; a root body's own twist for the rows on it), so a node has at most six.
/// Beyond them a pivot is the round-off of a row that depends on the ones kept (in
/// exact arithmetic zero); it can come out above the relative tolerance (a foot's
/// ground contacts under a two-hinge ankle: its four joint rows leave room for two
/// contact rows, and a third one's pivot is round-off only), and kept,
/// its inverse scales the parent body's block by orders of magnitude until that body's
/// own pivots fail the tolerance (`ArticulatedError::Singular`: dm_control's
/// humanoid_CMU lying on the floor, 46 of the active set's tries in its 5 s passive
/// run, each sending its step to the dense path and up to 15 more by the back-off).
fn ldlt_two_segment(a: &mut [f64], n: usize, base: usize, dinv: &mut [f64]) {
    // The body inlined once per common node size with the size a constant (loops
    // unroll, bounds checks fold), the same operations in the same order as with the
    // runtime size.
    match n {
        3 => ldlt_two_segment_fixed::<3>(a, base, dinv),
        4 => ldlt_two_segment_fixed::<4>(a, base, dinv),
        5 => ldlt_two_segment_fixed::<5>(a, base, dinv),
        6 => ldlt_two_segment_fixed::<6>(a, base, dinv),
        7 => ldlt_two_segment_fixed::<7>(a, base, dinv),
        8 => ldlt_two_segment_fixed::<8>(a, base, dinv),
        9 => ldlt_two_segment_fixed::<9>(a, base, dinv),
        10 => ldlt_two_segment_fixed::<10>(a, base, dinv),
        11 => ldlt_two_segment_fixed::<11>(a, base, dinv),
        12 => ldlt_two_segment_fixed::<12>(a, base, dinv),
        _ => ldlt_two_segment_sized(a, n, base, dinv),
    }
}

/// [`ldlt_two_segment`] for `N ≤ 12`, one column at a time with the column a constant
/// (every loop a constant trip count, unrolled; with the size alone a constant the
/// triangular loops stayed loops). The same operations in the same order as
/// [`ldlt_two_segment_sized`].
#[inline(always)]
fn ldlt_two_segment_fixed<const N: usize>(a: &mut [f64], base: usize, dinv: &mut [f64]) {
    let (a, dinv) = (&mut a[..N * N], &mut dinv[..N]);
    let scale = (0..base).map(|i| a[i * N + i].abs()).fold(0.0f64, f64::max);
    let mut st = TwoSegment {
        base,
        tol: 1e-12 * scale,
        negative: 0,
    };
    two_segment_column::<0, N>(a, dinv, &mut st);
    two_segment_column::<1, N>(a, dinv, &mut st);
    two_segment_column::<2, N>(a, dinv, &mut st);
    two_segment_column::<3, N>(a, dinv, &mut st);
    two_segment_column::<4, N>(a, dinv, &mut st);
    two_segment_column::<5, N>(a, dinv, &mut st);
    two_segment_column::<6, N>(a, dinv, &mut st);
    two_segment_column::<7, N>(a, dinv, &mut st);
    two_segment_column::<8, N>(a, dinv, &mut st);
    two_segment_column::<9, N>(a, dinv, &mut st);
    two_segment_column::<10, N>(a, dinv, &mut st);
    two_segment_column::<11, N>(a, dinv, &mut st);
}

/// The running state of [`ldlt_two_segment_fixed`]: the base size, the current
/// pivot tolerance and the negative pivots kept so far.
struct TwoSegment {
    base: usize,
    tol: f64,
    negative: usize,
}

/// Column `J` of [`ldlt_two_segment_sized`] on an `N × N` block (nothing when
/// `J ≥ N`), the loop body of that function with `j = J`.
#[inline(always)]
fn two_segment_column<const J: usize, const N: usize>(
    a: &mut [f64],
    dinv: &mut [f64],
    st: &mut TwoSegment,
) {
    if J >= N {
        return;
    }
    let base = st.base;
    if J == base && base < N {
        // The extra rows' scale (see `ldlt_two_segment_sized`).
        let s = (base..N).map(|i| a[i * N + i].abs()).fold(0.0f64, f64::max);
        st.tol = 1e-12 * s;
    }
    let mut d = a[J * N + J];
    for k in 0..J {
        d -= a[J * N + k] * a[J * N + k] * a[k * N + k];
    }
    let wrong_sign = J >= base && d > 0.0;
    let beyond_rank = J >= base && st.negative >= MAX_NEGATIVE_PIVOTS;
    if !(d.abs() > st.tol) || wrong_sign || beyond_rank {
        dinv[J] = 0.0;
        a[J * N + J] = 0.0;
        for i in J + 1..N {
            a[i * N + J] = 0.0;
        }
        return;
    }
    if d < 0.0 {
        st.negative += 1;
    }
    a[J * N + J] = d;
    dinv[J] = 1.0 / d;
    for i in J + 1..N {
        let mut s = a[i * N + J];
        for k in 0..J {
            s -= a[i * N + k] * a[J * N + k] * a[k * N + k];
        }
        a[i * N + J] = s / d;
    }
}

/// [`ldlt_two_segment`] of an `n × n` block (any size).
fn ldlt_two_segment_sized(a: &mut [f64], n: usize, base: usize, dinv: &mut [f64]) {
    let (a, dinv) = (&mut a[..n * n], &mut dinv[..n]);
    let scale = (0..base).map(|i| a[i * n + i].abs()).fold(0.0f64, f64::max);
    let mut tol = 1e-12 * scale;
    let mut negative = 0usize;
    for j in 0..n {
        if j == base && base < n {
            // The extra rows' scale: their diagonal before any elimination at this
            // node, `|g D_c⁻¹ gᵀ|` through the child subtree alone (no joint rows).
            // Their partial pivots with the base rows eliminated would not do: on a
            // welded body every extra row depends on the joint rows, all partial
            // pivots are round-off (1e-17), and one of them kept would scale the
            // parent body's block by 1e16 (gymnasium's humanoid feet).
            let s = (base..n).map(|i| a[i * n + i].abs()).fold(0.0f64, f64::max);
            tol = 1e-12 * s;
        }
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k] * a[k * n + k];
        }
        // An extra row's pivot is `−g D⁻¹ gᵀ` with the rows before it eliminated
        // (D positive definite on the subtree): never positive. A positive one is the
        // round-off of a dependent row; kept, its inverse would flip the sign of the
        // parent's update and make the parent body's block indefinite.
        let wrong_sign = j >= base && d > 0.0;
        let beyond_rank = j >= base && negative >= MAX_NEGATIVE_PIVOTS;
        if !(d.abs() > tol) || wrong_sign || beyond_rank {
            dinv[j] = 0.0;
            a[j * n + j] = 0.0;
            for i in j + 1..n {
                a[i * n + j] = 0.0;
            }
            continue;
        }
        if d < 0.0 {
            negative += 1;
        }
        a[j * n + j] = d;
        dinv[j] = 1.0 / d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k] * a[k * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tree::JointTopo;
    use constraint_core::DMat3;

    /// A branched tree of 12 bodies (a chain hung from the world, a second branch from
    /// body 2), ball joints of 3 rows, assembled (not factored), and its joint nodes.
    fn branched_tree(mass_scale: f64) -> (TreeSolver, Vec<usize>) {
        let n = 12;
        let mut topo = alloc::vec![JointTopo {
            a: None,
            b: 0,
            rows: 3,
        }];
        for i in 1..n {
            let a = if i == 8 { 2 } else { i - 1 };
            topo.push(JointTopo {
                a: Some(a),
                b: i,
                rows: 3,
            });
        }
        let mut t = TreeSolver::new(n, &topo);
        for i in 0..n {
            let m = (1.0 + 0.1 * i as f64) * mass_scale;
            t.set_body(i, m, &(DMat3::IDENTITY * (0.01 + 0.001 * i as f64)));
        }
        for (j, tp) in topo.iter().enumerate() {
            let r = DVec3::new(0.1, 0.02 * j as f64, -0.05);
            let mut rows = [[DVec3::ZERO; 4]; 3];
            for (k, row) in rows.iter_mut().enumerate() {
                let e = DVec3::AXES[k];
                *row = [-e, -r.cross(e) * 0.5, e, r.cross(e)];
            }
            t.set_joint(j, tp, &rows, 0, &[0.0; 3]);
        }
        let nodes = (0..n).map(|j| t.joint_node[j]).collect();
        (t, nodes)
    }

    /// A limit-like row on joint `j`'s two bodies (its node), or a contact-like row on
    /// body `i` alone (the node above it), with a Jacobian seeded by `s`.
    fn limit_row(nodes: &[usize], j: usize, s: f64) -> ExtraRow {
        let a = if j == 0 {
            None
        } else {
            Some(if j == 8 { 2 } else { j - 1 })
        };
        let u = DVec3::new(libm::sin(s), libm::cos(2.0 * s), 0.3);
        ExtraRow {
            node: nodes[j],
            a,
            b: Some(j),
            j: [DVec3::ZERO, -u, DVec3::ZERO, u],
        }
    }
    fn contact_row(t: &TreeSolver, i: usize, s: f64) -> ExtraRow {
        let n = DVec3::new(0.1 * s, 1.0, -0.2);
        ExtraRow {
            node: t.parent[i],
            a: None,
            b: Some(i),
            j: [
                DVec3::ZERO,
                DVec3::ZERO,
                n,
                DVec3::new(0.05, -0.02 * s, 0.1).cross(n),
            ],
        }
    }

    /// The factor's blocks, pivots and a solve, as bits.
    fn factor_bits(f: &RowTree, t: &TreeSolver) -> Vec<u64> {
        let mut x: Vec<f64> = (0..f.size).map(|k| libm::sin(0.3 + k as f64)).collect();
        f.solve(t, &mut x);
        f.diag
            .iter()
            .chain(&f.off)
            .chain(&f.dinv)
            .chain(&x)
            .map(|v| v.to_bits())
            .collect()
    }

    /// `g H_A⁻¹ g'ᵀ` of two rows outside the factor (contacts on bodies 5 and 10, on
    /// two branches that share bodies 2 to 0) from [`RowTree::forward_steps`] over
    /// each row's path alone, `Σ u s'` over the kept pivots (`u = s / d⁻¹`, the Schur
    /// rows' formula in `world/active_set.rs`), against `g x'` of a whole solve
    /// `x' = H_A⁻¹ g'ᵀ`; and the pass leaves the unknowns off the path zero.
    #[test]
    fn forward_steps_on_a_path_give_the_rows_coupling() {
        let (t, nodes) = branched_tree(1.0);
        let rows = alloc::vec![limit_row(&nodes, 3, 0.1), contact_row(&t, 11, 0.3)];
        let mut f = RowTree::default();
        assert!(f.assemble(&t, &rows));
        f.factor(&t).expect("factor");
        let column = |r: &ExtraRow| {
            let mut x = alloc::vec![0.0; f.size];
            for (side, body) in [(0usize, r.a), (1usize, r.b)] {
                if let Some(b) = body {
                    let o = f.node_offset(b);
                    for c in 0..3 {
                        x[o + c] += r.j[2 * side][c];
                        x[o + 3 + c] += r.j[2 * side + 1][c];
                    }
                }
            }
            x
        };
        // A body's path: it and its ancestors, in the elimination order.
        let path = |body: usize| {
            let (mut k, mut steps, mut on) = (body, Vec::new(), alloc::vec![false; f.size]);
            while k != NONE {
                steps.push(f.step_of(k));
                let o = f.node_offset(k);
                on[o..o + f.node_len(k)].iter_mut().for_each(|v| *v = true);
                k = t.parent[k];
            }
            steps.sort_unstable();
            (steps, on)
        };
        let (g0, g1) = (contact_row(&t, 5, 0.7), contact_row(&t, 10, -0.4));
        let ((p0, on0), (p1, _)) = (path(5), path(10));
        let (mut s0, mut s1) = (column(&g0), column(&g1));
        f.forward_steps(&mut s0, &p0);
        f.forward_steps(&mut s1, &p1);
        assert!(s0.iter().zip(&on0).all(|(v, on)| *on || *v == 0.0));
        let coupling: f64 = (0..f.size)
            .filter(|&u| f.dinv[u] != 0.0)
            .map(|u| s0[u] / f.dinv[u] * s1[u])
            .sum();
        let mut x1 = column(&g1);
        f.solve(&t, &mut x1);
        let want: f64 = column(&g0).iter().zip(&x1).map(|(a, b)| a * b).sum();
        // Measured: g x' = 1.774e-2, the two differ by 7.8e-16 relative (round-off of
        // the two summation orders).
        assert!(want.abs() > 1e-3, "{want}");
        assert!(
            (coupling - want).abs() <= 1e-12 * want.abs(),
            "{coupling} vs {want}"
        );
    }

    /// [`RowTree::solve_sparse`] of a right-hand side on two bodies of one branch
    /// (contacts on bodies 5 and 4, the other branch's nodes zero until the root)
    /// gives [`RowTree::solve`]'s values: equal as numbers (a zero's sign may differ),
    /// and every non-zero one bit for bit.
    #[test]
    fn sparse_solve_matches_the_whole_solve() {
        let (t, nodes) = branched_tree(1.0);
        let rows = alloc::vec![limit_row(&nodes, 3, 0.1), contact_row(&t, 11, 0.3)];
        let mut f = RowTree::default();
        assert!(f.assemble(&t, &rows));
        f.factor(&t).expect("factor");
        let mut x = alloc::vec![0.0; f.size];
        for (body, s) in [(5usize, 0.7), (4usize, -0.4)] {
            let g = contact_row(&t, body, s);
            let o = f.node_offset(body);
            for c in 0..3 {
                x[o + c] += g.j[2][c];
                x[o + 3 + c] += g.j[3][c];
            }
        }
        let zeros = x.iter().filter(|v| **v == 0.0).count();
        // All but the two bodies' twelve unknowns start zero.
        assert_eq!(zeros, f.size - 12);
        let (mut whole, mut sparse) = (x.clone(), x);
        f.solve(&t, &mut whole);
        f.solve_sparse(&t, &mut sparse);
        assert!(whole.iter().any(|v| v.abs() > 1e-6));
        for (a, b) in whole.iter().zip(&sparse) {
            assert!(
                a == b && (*a == 0.0 || a.to_bits() == b.to_bits()),
                "{a} vs {b}"
            );
        }
    }

    /// An active set's sequence of row sets on one tree matrix: each factor after the
    /// first keeps the nodes below no change ([`Reuse`]) and gives the bits of a fresh
    /// factor of the same rows (blocks, pivots and a solve); a changed tree matrix (a
    /// new body mass) is factored whole, and matches a fresh factor too.
    #[test]
    fn a_factor_reusing_the_last_one_gives_a_fresh_factors_bits() {
        let (t, nodes) = branched_tree(1.0);
        let a = alloc::vec![
            limit_row(&nodes, 3, 0.1),
            limit_row(&nodes, 9, 0.2),
            contact_row(&t, 11, 0.3),
        ];
        // One row added (joint 6), one removed (joint 9), one changed (the contact).
        let b = alloc::vec![
            limit_row(&nodes, 3, 0.1),
            limit_row(&nodes, 6, 0.4),
            contact_row(&t, 11, 0.5),
        ];
        let mut f = RowTree::default();
        let mut kept_any = false;
        for (round, rows) in [&a, &b, &b, &a].into_iter().enumerate() {
            assert!(f.assemble(&t, rows));
            let reused = f.incremental;
            kept_any |= reused && f.dirty.iter().any(|d| !d);
            f.factor(&t).expect("factor");
            let mut fresh = RowTree::default();
            assert!(fresh.assemble(&t, rows));
            fresh.factor(&t).expect("fresh factor");
            assert_eq!(
                factor_bits(&f, &t),
                factor_bits(&fresh, &t),
                "round {round}"
            );
            assert_eq!(reused, round > 0, "round {round}");
        }
        assert!(kept_any);
        // Another tree matrix (the stamp changed): no reuse, the fresh bits.
        let (t2, _) = branched_tree(1.5);
        assert!(f.assemble(&t2, &b));
        assert!(!f.incremental);
        f.factor(&t2).expect("factor");
        let mut fresh = RowTree::default();
        assert!(fresh.assemble(&t2, &b));
        fresh.factor(&t2).expect("fresh factor");
        assert_eq!(factor_bits(&f, &t2), factor_bits(&fresh, &t2));
    }

    /// A joint node's block `−G D⁻¹ Gᵀ` with eight rows on one body (four joint rows of
    /// a two-hinge joint, then four contact rows: rank six), plus a symmetric round-off
    /// of `1e-10` relative: [`ldlt_two_segment`] keeps six pivots and drops the last
    /// two (they depend on the others). Without the rank cap the seventh pivot passed
    /// the `1e-12` tolerance and was kept (measured: its inverse −1.8e7 against at
    /// most −154 for the six real ones; this test then fails with 7 kept).
    #[test]
    fn rank_cap_drops_pivots_beyond_one_body() {
        let n = 8;
        // G: 8 × 6, rows a deterministic spread; D⁻¹ = diag of a body's inverse
        // mass and inertia.
        let mut g = [[0.0f64; 6]; 8];
        for (r, row) in g.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = libm::sin(1.0 + 0.7 * r as f64 + 1.3 * c as f64 + 0.1 * (r * c) as f64);
            }
        }
        let dinv_body = [1.0, 1.0, 1.0, 4.0, 5.0, 6.0];
        let mut a = alloc::vec![0.0f64; n * n];
        for i in 0..n {
            for j in 0..n {
                let mut s = 0.0;
                for c in 0..6 {
                    s -= g[i][c] * dinv_body[c] * g[j][c];
                }
                a[i * n + j] = s;
            }
        }
        // Symmetric round-off, relative 1e-10.
        for i in 0..n {
            for j in 0..=i {
                let e = 1e-10 * libm::cos(3.0 * i as f64 + 5.0 * j as f64) * a[i * n + i].abs();
                a[i * n + j] += e;
                if i != j {
                    a[j * n + i] += e;
                }
            }
        }
        let mut dinv = alloc::vec![0.0f64; n];
        ldlt_two_segment(&mut a, n, 4, &mut dinv);
        let kept = dinv.iter().filter(|d| **d != 0.0).count();
        assert_eq!(kept, 6, "dinv {dinv:?}");
        assert!(dinv[..6].iter().all(|d| *d < 0.0), "dinv {dinv:?}");
        assert_eq!(&dinv[6..], &[0.0, 0.0]);
    }

    /// The fixed-shape [`update_fixed`] (two parent rows at a time) gives the
    /// row-by-row [`update_dyn`]'s `W` and parent block to the bit, for every shape
    /// the factor dispatches to it (entries all non-zero, so that `update_dyn`'s
    /// skipped zero terms do not arise). Bits, not a tolerance: the step's results
    /// depend on it.
    #[test]
    fn fixed_update_matches_the_row_by_row_update_to_the_bit() {
        fn check<const N: usize, const NP: usize>() {
            let v = |k: usize| 0.3 + 0.5 * libm::sin(0.7 + 1.9 * k as f64);
            let blk: Vec<f64> = (0..N * N).map(|k| v(k) * 0.4).collect();
            let dinv: Vec<f64> = (0..N).map(|k| -1.0 / (1.0 + v(k + 50))).collect();
            let w0: Vec<f64> = (0..N * NP).map(|k| v(k + 100)).collect();
            let d0: Vec<f64> = (0..NP * NP).map(|k| 2.0 + v(k + 400)).collect();
            let (mut wf, mut df) = (w0.clone(), d0.clone());
            let (mut wd, mut dd) = (w0, d0);
            update_fixed::<N, NP>(&blk, &dinv, &mut wf, &mut df);
            update_dyn(N, NP, &blk, &dinv, &mut wd, &mut dd);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&wf), bits(&wd), "W, shape {N}×{NP}");
            assert_eq!(bits(&df), bits(&dd), "D_p, shape {N}×{NP}");
        }
        check::<6, 3>();
        check::<6, 4>();
        check::<6, 5>();
        check::<6, 6>();
        check::<6, 7>();
        check::<6, 8>();
        check::<6, 9>();
        check::<6, 10>();
        check::<6, 11>();
        check::<6, 12>();
        check::<6, 13>();
        check::<6, 14>();
        check::<6, 15>();
        check::<3, 6>();
        check::<4, 6>();
        check::<5, 6>();
        check::<7, 6>();
        check::<8, 6>();
        check::<9, 6>();
        check::<10, 6>();
        check::<11, 6>();
        check::<12, 6>();
        check::<13, 6>();
        check::<14, 6>();
        check::<15, 6>();
    }

    /// Every kernel index dispatches to the kernel of its shape in [`KERNEL_SHAPES`],
    /// and [`kernel_of`] maps each listed shape to its index, any other to 0.
    #[test]
    fn kernel_indices_name_their_shapes() {
        fn shape<const N: usize, const NP: usize>(_: ()) -> (usize, usize) {
            (N, NP)
        }
        macro_rules! unit {
            ($a:literal, $b:literal) => {
                ()
            };
        }
        for (i, &want) in KERNEL_SHAPES.iter().enumerate() {
            assert_eq!(kernel_dispatch!(i as u8, shape, unit), want, "kernel {i}");
            assert_eq!(kernel_of(want.0, want.1) as usize, i, "shape {want:?}");
        }
        assert_eq!(kernel_dispatch!(200u8, shape, unit), (0, 0));
        assert_eq!(kernel_of(6, 1), 0);
        assert_eq!(kernel_of(16, 6), 0);
    }

    /// The unrolled [`ldlt_two_segment_fixed`] gives [`ldlt_two_segment_sized`]'s
    /// factor and inverse pivots to the bit, on blocks of every unrolled size 3..8 and
    /// every split `base` (positive definite base rows, then extra rows of the
    /// `−g D⁻¹ gᵀ` sign, one of them dependent on the first: a dropped pivot).
    #[test]
    fn unrolled_two_segment_matches_the_loop_to_the_bit() {
        for n in 3..=12 {
            for base in 1..=n {
                let mut a = alloc::vec![0.0f64; n * n];
                for i in 0..n {
                    for j in 0..=i {
                        let v = 0.2 * libm::sin(0.4 + 1.3 * i as f64 + 0.7 * j as f64);
                        a[i * n + j] = v;
                        a[j * n + i] = v;
                    }
                    a[i * n + i] += if i < base { 4.0 } else { -4.0 };
                }
                if base + 1 < n {
                    // The last extra row a copy of the first extra row.
                    let (r, c) = (n - 1, base);
                    for j in 0..n {
                        a[r * n + j] = a[c * n + j];
                        a[j * n + r] = a[j * n + c];
                    }
                    a[r * n + r] = a[c * n + c];
                }
                let (mut fixed, mut looped) = (a.clone(), a);
                let (mut dinv_f, mut dinv_l) = (alloc::vec![0.0; n], alloc::vec![0.0; n]);
                ldlt_two_segment(&mut fixed, n, base, &mut dinv_f);
                ldlt_two_segment_sized(&mut looped, n, base, &mut dinv_l);
                if base + 1 < n {
                    assert_eq!(dinv_l[n - 1], 0.0, "n {n} base {base}: dependent row kept");
                }
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&fixed), bits(&looped), "n {n} base {base}");
                assert_eq!(bits(&dinv_f), bits(&dinv_l), "n {n} base {base}");
            }
        }
    }
}
