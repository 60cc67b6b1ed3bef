//! Baraff's linear-time factorization of the KKT matrix of a tree of bodies and joints
//! (Baraff 1996, "Linear-time dynamics using Lagrange multipliers").
//!
//! The KKT matrix
//!
//! ```text
//! H = [M   Jᵀ]
//!     [J  −C ]
//! ```
//!
//! (`M` block-diagonal 6×6 per body, `J` one block per joint and body it touches, `C`
//! the joint rows' compliance, zero for hard rows) is the adjacency structure of a
//! graph whose nodes are bodies and joints. When that graph is a forest, ordering the
//! nodes so that every node comes before its parent (leaves first) makes block `LDLᵀ`
//! produce no fill-in: eliminating a node touches only its parent. Factor and solve
//! are then `O(n)` in the number of bodies, with dense work only on the ≤ 6×6 blocks:
//!
//! ```text
//! factor, for i in order:  D_i = H_ii − Σ_{c child of i} H_ciᵀ D_c⁻¹ H_ci   (= L_i d_i L_iᵀ)
//!                          W_i = L_i⁻¹ H_{i,parent(i)}
//! solve:   forward  (order):    s_i = d_i⁻¹ L_i⁻¹ (b_i − Σ_c W_cᵀ s_c)
//!          backward (reverse):  x_i = L_i⁻ᵀ (s_i − d_i⁻¹ W_i x_parent(i))
//! ```
//!
//! Body pivots `D_i` are symmetric positive definite (mass plus the positive
//! semi-definite contribution of eliminated joints), joint pivots negative definite, so
//! the block `LDLᵀ` without pivoting is stable (the matrix is quasi-definite). Joints
//! that would close a cycle — including a cycle through the world, such as the last bar
//! of a four-bar linkage — are not tree nodes: they become *loop rows* `G`, handled as
//! in Baraff's paper by the Schur complement `(G H⁻¹ Gᵀ + C_G) μ = G H⁻¹ r − r_G`
//! (one tree solve per loop row), solved by SVD for the minimum-norm `μ` so that a
//! redundant closing constraint (a planar four-bar closes with one dependent row) gives
//! finite multipliers.
//!
//! A zero pivot inside a *joint* block (two rows of one joint that are dependent at the
//! current configuration) is dropped: that row gets `λ = 0`. A zero or negative pivot
//! in a *body* block is an error ([`ArticulatedError::Singular`]).

use alloc::vec;
use alloc::vec::Vec;
use core::sync::atomic::{AtomicUsize, Ordering};

use constraint_core::DVec3;

use crate::error::ArticulatedError;

mod forward;
mod loops;
#[cfg(test)]
use loops::min_norm_truncated;
pub(crate) use loops::{LoopClosure, LoopScratch};

/// A ≤ 6×6 dense block, row-major.
pub(crate) type Blk = [[f64; 6]; 6];
const ZERO: Blk = [[0.0; 6]; 6];

/// One node's blocks, side by side (the solve reads all three of a node at once: one
/// index, one bounds check, one cache neighbourhood).
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeBlocks {
    /// `H_ii` on entry, then the factored `D_i` (unit-lower `L` below the diagonal, `d`
    /// on it).
    pub(crate) diag: Blk,
    /// `H_{i,parent(i)}` (`dim_i × dim_parent`) on assembly; after
    /// [`TreeSolver::factor`], `W_i = L_i⁻¹ H_{i,parent(i)}` (`L_i` the unit lower
    /// factor of `D_i`).
    pub(crate) off: Blk,
    /// `Wᵀ` (`dim_parent × dim_i`), written by [`TreeSolver::factor`] beside `W`: the
    /// backward pass's `W x_p` reads it a column of `W` at a time, so that the sums of
    /// neighbouring rows share vector lanes (contiguous in `Wᵀ`, not in `W`).
    off_t: Blk,
    /// `1/d` of the node's pivots (0 for dropped pivots).
    dinv: [f64; 6],
}

const ZERO_NODE: NodeBlocks = NodeBlocks {
    diag: ZERO,
    off: ZERO,
    off_t: ZERO,
    dinv: [0.0; 6],
};
pub(crate) const NONE: usize = usize::MAX;

/// The source of [`TreeSolver::stamp`]: each solver takes its stamps from ranges of
/// [`STAMP_RANGE`] values it reserves here, so every state of any solver's blocks has
/// a value no other state had (a solver and its clone share one only while their
/// blocks are equal).
static BLOCK_STAMPS: AtomicUsize = AtomicUsize::new(1);

/// The stamps a solver reserves at once: one locked increment of [`BLOCK_STAMPS`] per
/// this many changes of its blocks instead of one per change (an assembly changes them
/// once per body and joint: 14 locked read-modify-writes a step on dm swimmer6, 23 on
/// dm fish, each draining the store buffer; invisible to instruction counts).
const STAMP_RANGE: usize = 1024;

/// A solver's stamp and the end of its reserved range (`stamp < end`: the values
/// `stamp + 1 .. end` are this solver's alone, still unused).
#[derive(Debug)]
struct Stamps {
    stamp: usize,
    end: usize,
}

impl Stamps {
    /// A fresh stamp at the start of a newly reserved range.
    fn new() -> Self {
        let base = BLOCK_STAMPS.fetch_add(STAMP_RANGE, Ordering::Relaxed);
        Self {
            stamp: base,
            end: base.wrapping_add(STAMP_RANGE),
        }
    }

    /// Moves to a stamp no earlier state of any solver's blocks had: the next of the
    /// reserved range, else the start of a new range.
    #[inline]
    fn next(&mut self) {
        let n = self.stamp.wrapping_add(1);
        if n != self.end {
            self.stamp = n;
        } else {
            *self = Self::new();
        }
    }
}

impl Clone for Stamps {
    /// The same stamp (the clone's blocks are equal until either changes), with no
    /// values left of the range: the clone's next change reserves a range of its own,
    /// so the two never hand out the same value for different blocks.
    fn clone(&self) -> Self {
        Self {
            stamp: self.stamp,
            end: self.stamp.wrapping_add(1),
        }
    }
}

/// The structure of the tree (built once per topology) and the factor (per step).
#[derive(Clone, Debug)]
pub(crate) struct TreeSolver {
    pub n_bodies: usize,
    /// Node dimension: 6 for bodies, rows for joints.
    pub(crate) dim: Vec<usize>,
    /// Offset of each node's unknowns in the solution vector.
    pub(crate) offset: Vec<usize>,
    pub(crate) parent: Vec<usize>,
    /// Elimination order: every node before its parent.
    pub(crate) order: Vec<usize>,
    /// The solve kernels' shapes per node in elimination order: `[node, n, offset,
    /// n_parent, parent offset]` (`0, 0` for a root), read once per node instead of from
    /// the `dim`, `offset` and `parent` tables.
    schedule: Vec<[usize; 5]>,
    /// Per node: `false` for a body without children (a leaf of the tree), `true`
    /// otherwise — the forward pass's flags ([`Self::solve_marked`]) of a right-hand
    /// side zero on every body ([`Self::solve_zero_bodies`]), and the factor's leaf
    /// bodies, whose mass blocks factor as two halves ([`ldlt_split`]); empty when the
    /// tree has no such body.
    forward_nodes: Vec<bool>,
    /// Per node: its diagonal block, its block to the parent and its inverse pivots
    /// (the factor once [`Self::factor`] ran; a dropped pivot is a zero `1/d`).
    pub(crate) blocks: Vec<NodeBlocks>,
    /// For joint `j`: its node, or `NONE` for a loop joint.
    pub joint_node: Vec<usize>,
    /// Loop joints, in joint order.
    pub loops: Vec<usize>,
    /// Total unknowns of the tree system.
    pub size: usize,
    /// `Y = H⁻¹ Gᵀ` and the SVD of the loop rows' Schur complement for the current
    /// factor (`tree/loops.rs`); dropped by every change of `blocks`.
    closure: LoopClosure,
    /// Identifies the current contents of `blocks`: a new value ([`Stamps::next`]) at
    /// every change of them, so equal stamps mean equal blocks (the augmented factor's
    /// reuse, `tree_rows.rs`).
    stamp: Stamps,
}

/// The storage of one factor of the tree matrix ([`TreeSolver`]'s `blocks`), kept
/// aside so that a factor can be set away and brought back by swapping buffers
/// ([`TreeSolver::swap_factor`]) instead of being computed again.
#[derive(Clone, Debug, Default)]
pub(crate) struct FactorStore {
    blocks: Vec<NodeBlocks>,
    /// The loop closure built with that factor (swapped along with it).
    closure: LoopClosure,
}

/// Per-joint topology the solver needs: its bodies and number of rows.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JointTopo {
    pub a: Option<usize>,
    pub b: usize,
    pub rows: usize,
}

fn find(uf: &mut [usize], mut i: usize) -> usize {
    while uf[i] != i {
        uf[i] = uf[uf[i]];
        i = uf[i];
    }
    i
}

impl TreeSolver {
    /// Builds the spanning forest (world included as a union-find node), the node
    /// parents and the leaves-first order.
    pub fn new(n_bodies: usize, joints: &[JointTopo]) -> Self {
        let world = n_bodies;
        let mut uf: Vec<usize> = (0..=n_bodies).collect();
        let mut joint_node = vec![NONE; joints.len()];
        let mut node_joint: Vec<usize> = vec![NONE; n_bodies];
        let mut loops = Vec::new();
        let mut dim: Vec<usize> = vec![6; n_bodies];
        // adjacency: for each body, its tree joints
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n_bodies];
        for (j, t) in joints.iter().enumerate() {
            let ra = find(&mut uf, t.a.unwrap_or(world));
            let rb = find(&mut uf, t.b);
            if ra == rb {
                loops.push(j);
                continue;
            }
            uf[ra] = rb;
            joint_node[j] = dim.len();
            node_joint.push(j);
            dim.push(t.rows);
            adj[t.b].push(j);
            if let Some(a) = t.a {
                adj[a].push(j);
            }
        }
        let n_nodes = dim.len();
        let mut parent = vec![NONE; n_nodes];
        let mut order = Vec::with_capacity(n_nodes);
        let mut visited = vec![false; n_bodies];
        // Roots: a joint to the world is the root of its component (as a leaf its pivot
        // would be the zero block of a hard joint; as the root it is eliminated last,
        // with pivot −J D⁻¹ Jᵀ). Components without one are rooted at a body.
        let mut roots: Vec<usize> = Vec::new();
        for (j, t) in joints.iter().enumerate() {
            if joint_node[j] != NONE && t.a.is_none() {
                roots.push(joint_node[j]);
            }
        }
        roots.extend(0..n_bodies);
        // Iterative DFS producing a post-order (children before parents).
        let mut stack: Vec<(usize, bool)> = Vec::new();
        for &r in &roots {
            if r < n_bodies {
                if visited[r] {
                    continue;
                }
                visited[r] = true;
            }
            stack.push((r, false));
            while let Some((node, expanded)) = stack.pop() {
                if expanded {
                    order.push(node);
                    continue;
                }
                stack.push((node, true));
                if node < n_bodies {
                    for &j in &adj[node] {
                        let jn = joint_node[j];
                        if jn == parent[node] {
                            continue;
                        }
                        parent[jn] = node;
                        stack.push((jn, false));
                    }
                } else {
                    // joint node: its bodies other than its parent are its children
                    let t = joints[node_joint[node]];
                    for body in [Some(t.b), t.a].into_iter().flatten() {
                        if body != parent[node] && !visited[body] {
                            visited[body] = true;
                            parent[body] = node;
                            stack.push((body, false));
                        }
                    }
                }
            }
        }
        let mut offset = Vec::with_capacity(n_nodes);
        let mut size = 0;
        for &d in &dim {
            offset.push(size);
            size += d;
        }
        let schedule = order
            .iter()
            .map(|&i| {
                let p = parent[i];
                let (np, op) = if p == NONE {
                    (0, 0)
                } else {
                    (dim[p], offset[p])
                };
                [i, dim[i], offset[i], np, op]
            })
            .collect();
        // Bodies that are no node's parent (joints only have bodies as children and
        // bodies only joints, so a body without children is a leaf).
        let mut forward_nodes = vec![true; n_nodes];
        for i in 0..n_bodies {
            forward_nodes[i] = false;
        }
        for &p in &parent {
            if p != NONE && p < n_bodies {
                forward_nodes[p] = true;
            }
        }
        if forward_nodes.iter().all(|v| *v) {
            forward_nodes.clear();
        }
        Self {
            n_bodies,
            dim,
            offset,
            parent,
            order,
            schedule,
            forward_nodes,
            blocks: vec![ZERO_NODE; n_nodes],
            joint_node,
            loops,
            size,
            closure: LoopClosure::default(),
            stamp: Stamps::new(),
        }
    }

    /// The stamp of the blocks' current contents (equal stamps: equal blocks).
    #[inline]
    pub(crate) fn stamp(&self) -> usize {
        self.stamp.stamp
    }

    /// Exchanges the solver's factor storage with `store` (a buffer swap, no copy):
    /// the factor in the solver goes to `store` and `store`'s comes in, each with the
    /// loop closure built with it. A store of
    /// another size (a new topology, or the empty default) is first sized to this tree,
    /// its contents zero.
    pub fn swap_factor(&mut self, store: &mut FactorStore) {
        let n = self.dim.len();
        if store.blocks.len() != n {
            store.blocks.clear();
            store.blocks.resize(n, ZERO_NODE);
            store.closure.forget();
        }
        core::mem::swap(&mut self.blocks, &mut store.blocks);
        core::mem::swap(&mut self.closure, &mut store.closure);
        self.stamp.next();
    }

    /// Offset of body `i`'s 6 unknowns `(v, ω)`.
    #[inline]
    pub fn body_offset(&self, i: usize) -> usize {
        self.offset[i]
    }

    /// Body `i`'s six entries of a solution `x` of this tree's system, `(v, ω)` (or a
    /// correction `(δx, δθ)`), read in place: the callers' per-body loops (RATTLE's
    /// stages, drift and SHAKE, about 60 reads a step on swimmer6) read them without a
    /// call and a copy through memory each.
    #[inline(always)]
    pub(crate) fn body_twist(&self, x: &[f64], i: usize) -> (DVec3, DVec3) {
        let o = self.offset[i];
        let b = &x[o..o + 6];
        (DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]))
    }

    /// Offset of tree joint `j`'s rows (`None` for a loop joint).
    #[inline]
    pub fn joint_offset(&self, j: usize) -> Option<usize> {
        let n = self.joint_node[j];
        (n != NONE).then(|| self.offset[n])
    }

    /// Sets body `i`'s mass block `diag(m, m, m) ⊕ I_world`.
    pub fn set_body(&mut self, i: usize, mass: f64, inertia: &constraint_core::DMat3) {
        self.closure.forget();
        self.stamp.next();
        let d = &mut self.blocks[i].diag;
        *d = ZERO;
        for k in 0..3 {
            d[k][k] = mass;
            for l in 0..3 {
                d[3 + k][3 + l] = inertia.col(l)[k];
            }
        }
    }

    /// Adds `xx` and `θθ` blocks to body `i`'s mass block (after [`Self::set_body`]).
    pub fn add_body_blocks(
        &mut self,
        i: usize,
        xx: &constraint_core::DMat3,
        tt: &constraint_core::DMat3,
    ) {
        self.closure.forget();
        self.stamp.next();
        let d = &mut self.blocks[i].diag;
        for k in 0..3 {
            for l in 0..3 {
                d[k][l] += xx.col(l)[k];
                d[3 + k][3 + l] += tt.col(l)[k];
            }
        }
    }

    /// Sets tree joint `j`'s blocks: its rows' Jacobian (`rows[r] = [v_a, ω_a, v_b, ω_b]`;
    /// rows beyond `rows.len()` up to `topo.rows`, and rows `r` with bit `r` of `zero`
    /// set, are zero) and compliance (`−C` on the diagonal).
    pub fn set_joint(
        &mut self,
        j: usize,
        topo: &JointTopo,
        rows: &[[DVec3; 4]],
        zero: u8,
        compliance: &[f64],
    ) {
        self.closure.forget();
        self.stamp.next();
        let node = self.joint_node[j];
        let m = topo.rows;
        // The node's rows of its diagonal block: `−C` on the diagonal, zeros elsewhere
        // (the rows past the node's `m` are never read: no `memset` of the whole block).
        let d = &mut self.blocks[node].diag;
        for r in 0..m {
            d[r] = [0.0; 6];
            d[r][r] = -compliance[r];
        }
        let given = rows.len();
        let p = self.parent[node];
        // The body whose blocks are H_{joint, parent} and the child body's H_{child, joint}.
        for (side, body) in [(0usize, topo.a), (1usize, Some(topo.b))] {
            let Some(body) = body else { continue };
            // Row r's six entries on this body, `[v; ω]` (zero beyond the given rows).
            let blk = |r: usize| {
                if r < given && zero & (1 << r) == 0 {
                    let (v, w) = (rows[r][2 * side], rows[r][2 * side + 1]);
                    [v.x, v.y, v.z, w.x, w.y, w.z]
                } else {
                    [0.0; 6]
                }
            };
            if body == p {
                let o = &mut self.blocks[node].off;
                for r in 0..m {
                    o[r] = blk(r);
                }
            } else {
                // body is the joint's child: H_{body, joint} = Jᵀ
                let o = &mut self.blocks[body].off;
                for r in 0..m {
                    let row = blk(r);
                    for c in 0..6 {
                        o[c][r] = row[c];
                    }
                }
            }
        }
    }

    /// Block LDLᵀ of the whole tree, leaves first. With `D_i = L_i d_i L_iᵀ` and
    /// `W_i = L_i⁻¹ H_{i,p}`, the parent's pivot update is
    /// `D_p −= H_{i,p}ᵀ D_i⁻¹ H_{i,p} = W_iᵀ d_i⁻¹ W_i` (lower triangle only: the block
    /// factorization reads no more).
    pub fn factor(&mut self) -> Result<(), ArticulatedError> {
        self.closure.forget();
        self.stamp.next();
        self.factor_blocks()
    }

    /// [`Self::factor`]'s elimination (kept out of line: the body as it was before the
    /// loop closure's drop was added in front of it).
    #[inline(never)]
    fn factor_blocks(&mut self) -> Result<(), ArticulatedError> {
        for k in 0..self.order.len() {
            let i = self.order[k];
            let n = self.dim[i];
            let is_body = i < self.n_bodies;
            let bi = &mut self.blocks[i];
            // A leaf body's block is its mass block `(m 1 + X) ⊕ (I + T)` as assembled
            // (no child updates it): its two 3×3 halves factor apart, the same bits.
            let leaf = is_body && self.forward_nodes.get(i).is_some_and(|f| !f);
            let mask = if leaf && n == 6 && split_halves(&bi.diag) {
                ldlt_split(&mut bi.diag)
            } else {
                ldlt_in_place(&mut bi.diag, n)
            };
            if is_body && (mask != 0 || (0..n).any(|r| !(bi.diag[r][r] > 0.0))) {
                return Err(ArticulatedError::Singular { node: i });
            }
            let d = &bi.diag;
            let mut dinv = [0.0; 6];
            for r in 0..n {
                dinv[r] = if mask & (1 << r) != 0 {
                    0.0
                } else {
                    1.0 / d[r][r]
                };
            }
            bi.dinv = dinv;
            let p = self.parent[i];
            if p == NONE {
                continue;
            }
            let np = self.dim[p];
            let (bi, bp) = pair_mut(&mut self.blocks, i, p);
            // W overwrites H_{i,p} in place (set again at every assembly).
            let (di, w, wt, dp) = (&bi.diag, &mut bi.off, &mut bi.off_t, &mut bp.diag);
            // Fixed-size kernels for the shapes of body/joint pairs (the loops unroll).
            macro_rules! dispatch {
                ($($a:literal, $b:literal);*) => {
                    match (n, np) {
                        $(($a, $b) => update::<$a, $b>(di, &dinv, w, wt, dp),)*
                        _ => update_dyn(n, np, di, &dinv, w, wt, dp),
                    }
                };
            }
            dispatch!(6, 1; 6, 2; 6, 3; 6, 4; 6, 5; 6, 6; 1, 6; 2, 6; 3, 6; 4, 6; 5, 6);
        }
        Ok(())
    }

    /// Solves `H x = b` in place with the factor:
    /// forward (leaves first) `u_i = L_i⁻¹ y_i`, `s_i = d_i⁻¹ u_i`, `y_p −= W_iᵀ s_i`;
    /// backward (root first) `x_i = L_i⁻ᵀ (s_i − d_i⁻¹ W_i x_p)`.
    pub fn solve(&self, x: &mut [f64]) {
        self.solve_marked(x, None);
    }

    /// [`Self::solve`] for a right-hand side whose bodies' entries are all `+0.0`
    /// (SHAKE's corrections: only joint rows carry `−C`): the forward pass skips the
    /// bodies without children. At such a leaf it would compute `u = L⁻¹ 0 = +0`
    /// (`+0 − d·(±0) = +0`), `s = d⁻¹ u = +0` (a body's pivots are positive) and take
    /// `Wᵀ s = +0` (sums from `+0`) off its parent, which leaves every bit of the
    /// parent's entries as it was (`y − (+0) = y`, also for `y = −0`); the backward
    /// pass then reads `s = +0` there, as the skipped node's zero right-hand side. So
    /// the solution is [`Self::solve`]'s to the bit (for a finite factor).
    pub fn solve_zero_bodies(&self, x: &mut [f64]) {
        if self.forward_nodes.is_empty() {
            self.solve_marked(x, None);
        } else {
            self.solve_marked(x, Some(&self.forward_nodes));
        }
    }

    /// Flags in `mark` (scratch, one flag per node, kept by the caller) the nodes of
    /// `bodies` and their ancestors, and clears `x` on their unknowns: the set-up of
    /// [`Self::solve_sparse`] for a right-hand side then placed on those bodies'
    /// unknowns ([`Self::scatter`]). The other entries of `x` are left as they are
    /// (the sparse solve neither reads them nor needs them cleared), unless some node
    /// is outside the elimination order (not the case for a tree built by
    /// [`Self::new`]): then all of `x` is cleared.
    pub fn mark_paths(&self, x: &mut [f64], bodies: [Option<usize>; 2], mark: &mut Vec<bool>) {
        mark.clear();
        mark.resize(self.dim.len(), false);
        let whole = self.schedule.len() != self.dim.len();
        if whole {
            x.fill(0.0);
        }
        for mut i in bodies.into_iter().flatten() {
            while i != NONE && i < mark.len() && !mark[i] {
                mark[i] = true;
                if !whole {
                    let o = self.offset[i];
                    if let Some(xi) = x.get_mut(o..o + self.dim[i]) {
                        xi.fill(0.0);
                    }
                }
                i = self.parent[i];
            }
        }
    }

    /// [`Self::solve`] for a right-hand side that is zero outside the unknowns of the
    /// nodes `mark` flags ([`Self::mark_paths`]): the forward pass visits only those
    /// nodes (elsewhere it would carry zeros), the backward pass every node, taking
    /// the unflagged nodes' right-hand side as zero without reading it (so `x` needs
    /// no clearing there; every entry is written). Same values as [`Self::solve`] (up
    /// to the sign of zeros).
    pub fn solve_sparse(&self, x: &mut [f64], mark: &[bool]) {
        self.solve_marked(x, Some(mark));
    }

    /// [`Self::solve`] with the forward pass restricted to the nodes `mark` flags (all
    /// without it) and the backward pass reading the right-hand side of those nodes
    /// only (zero elsewhere): one body for both, so the node kernels keep a single
    /// call site each (and stay inlined).
    ///
    /// The backward pass's `W x_p` reads the copy `Wᵀ` the factor writes, its sums
    /// stored into `x` and read back ([`backward_sized`]): only with that store did the
    /// compiler pair the rows' sums in vector lanes (an earlier try with the copy
    /// alone, swimmer6 controlled 121.84M → 122.44M, gained nothing in the pass).
    /// Tried and left out (issue 13, `World::step` instructions, the same bits):
    /// the same store reading `W` itself (a gather of two rows' entries per pair):
    /// humanoid_CMU controlled 0.1 s 81.47M → 83.00M against the copy; the node kernel
    /// chosen by its shape's index kept in the schedule (one jump) instead of the match
    /// on `(n, np)`: swimmer6 122.00M, dm hopper 72.43M → 72.51M; the dense contact
    /// path's columns of one contact (normal and tangents, the same bodies and marks)
    /// through one multi-column pass, each node's kernel on the three columns in turn
    /// (humanoid_CMU controlled 0.5 s 617.17M → 617.97M, gymnasium humanoid passive
    /// 2 s 444.70M → 444.77M: the node kernels' arithmetic is the cost, not the walk);
    /// the forward `L⁻¹` by columns from a copy `Lᵀ` written by the factor (the same
    /// terms in the same order, contiguous rows): swimmer6 passive 2 s, this function
    /// 20.03M → 19.67M but `factor_blocks` 11.22M → 13.76M for the copy (`World::step`
    /// 81.87M → 84.04M in all, left out).
    fn solve_marked(&self, x: &mut [f64], mark: Option<&[bool]>) {
        // Fixed-size kernels for the node shapes of body/joint pairs (loops unroll);
        // `NP = 0` is a root.
        macro_rules! dispatch {
            ($f:ident, $n:expr, $np:expr, $call:tt; $($a:literal, $b:literal);*) => {
                match ($n, $np) {
                    $(($a, $b) => $f::<$a, $b> $call,)*
                    _ => $f::<6, 6> $call,
                }
            };
        }
        for &[i, n, oi, np, op] in &self.schedule {
            if mark.is_some_and(|m| !m[i]) {
                continue;
            }
            let b = &self.blocks[i];
            let args = (&b.diag, &b.dinv, &b.off, &b.off_t, oi, op, n, np);
            // The common shape first, by one test (two jump tables otherwise).
            if n == 6 && np == 6 {
                forward::<6, 6>(args, x);
                continue;
            }
            dispatch!(forward, n, np, (args, x);
                6, 0; 6, 1; 6, 2; 6, 3; 6, 4; 6, 5; 1, 6; 2, 6; 3, 6; 4, 6; 5, 6;
                1, 0; 2, 0; 3, 0; 4, 0; 5, 0);
        }
        let Some(mark) = mark else {
            for &[i, n, oi, np, op] in self.schedule.iter().rev() {
                let b = &self.blocks[i];
                let args = (&b.diag, &b.dinv, &b.off, &b.off_t, oi, op, n, np);
                if n == 6 && np == 6 {
                    backward::<6, 6>(args, x, true);
                    continue;
                }
                dispatch!(backward, n, np, (args, x, true);
                    6, 0; 6, 1; 6, 2; 6, 3; 6, 4; 6, 5; 1, 6; 2, 6; 3, 6; 4, 6; 5, 6;
                    1, 0; 2, 0; 3, 0; 4, 0; 5, 0);
            }
            return;
        };
        for &[i, n, oi, np, op] in self.schedule.iter().rev() {
            let b = &self.blocks[i];
            let args = (&b.diag, &b.dinv, &b.off, &b.off_t, oi, op, n, np);
            if mark[i] && n == 6 && np == 6 {
                backward::<6, 6>(args, x, true);
            } else if mark[i] {
                dispatch!(backward, n, np, (args, x, true);
                    6, 0; 6, 1; 6, 2; 6, 3; 6, 4; 6, 5; 1, 6; 2, 6; 3, 6; 4, 6; 5, 6;
                    1, 0; 2, 0; 3, 0; 4, 0; 5, 0);
            } else {
                // Unflagged: a zero right-hand side (the forward pass left it so).
                dispatch!(backward, n, np, (args, x, false);
                    6, 1; 6, 2; 6, 3; 6, 4; 6, 5; 6, 6; 1, 6; 2, 6; 3, 6; 4, 6; 5, 6);
            }
        }
    }

    /// `x += s · Gᵀ_row` (the row's blocks placed on its bodies' unknowns).
    pub fn scatter(&self, x: &mut [f64], a: Option<usize>, b: usize, row: &[DVec3; 4], s: f64) {
        for (side, body) in [(0usize, a), (1usize, Some(b))] {
            let Some(body) = body else { continue };
            let o = self.offset[body];
            for c in 0..3 {
                x[o + c] += s * row[2 * side][c];
                x[o + 3 + c] += s * row[2 * side + 1][c];
            }
        }
    }
}

/// In-place `LDLᵀ` of the leading `n×n` block (no pivoting): `L` below the diagonal,
/// `d` on it. Pivots below `1e-12 ·` the largest diagonal magnitude are dropped
/// (returned as a bit mask, their `d` set to 0 and their column of `L` to 0). The body
/// is inlined once per node size with the size as a constant (loops unrolled), the same
/// operations in the same order as with a runtime size.
fn ldlt_in_place(a: &mut Blk, n: usize) -> u8 {
    match n {
        6 => ldlt_fixed::<6>(a),
        5 => ldlt_fixed::<5>(a),
        4 => ldlt_fixed::<4>(a),
        3 => ldlt_fixed::<3>(a),
        2 => ldlt_fixed::<2>(a),
        1 => ldlt_fixed::<1>(a),
        _ => ldlt_sized(a, n),
    }
}

/// Whether the lower-left 3×3 block of a 6×6 block is `+0.0` in every entry (the
/// lower triangle [`ldlt_split`] factors as two 3×3 halves).
#[inline(always)]
fn split_halves(a: &Blk) -> bool {
    a[3..6]
        .iter()
        .all(|row| row[0].to_bits() | row[1].to_bits() | row[2].to_bits() == 0)
}

/// [`ldlt_fixed`]`::<6>` of a block whose lower-left 3×3 block is `+0.0`
/// ([`split_halves`]): the halves `a[0..3][0..3]` and `a[3..6][3..6]` factor apart
/// (the tolerance from all six diagonal entries, as there). The same bits wherever the
/// pivots are positive, as they are for a body that factors (else the caller's
/// error): in the 6×6 elimination the lower-left entries stay `+0` (`+0/d = +0`,
/// `+0 − (±0) = +0`) and take `+0` off the lower-right ones (`a − (+0) = a`), so it
/// computes exactly the halves' operations besides. 9 divisions and 27 updates fewer.
/// Out of line: inlined, it made the elimination loop dearer at every node.
#[inline(never)]
fn ldlt_split(a: &mut Blk) -> u8 {
    let scale = (0..6).map(|i| a[i][i].abs()).fold(0.0f64, f64::max);
    let tol = 1e-12 * scale;
    let mut mask = 0u8;
    ldlt_column_at::<0, 0, 3>(a, tol, &mut mask);
    ldlt_column_at::<0, 1, 3>(a, tol, &mut mask);
    ldlt_column_at::<0, 2, 3>(a, tol, &mut mask);
    ldlt_column_at::<3, 0, 3>(a, tol, &mut mask);
    ldlt_column_at::<3, 1, 3>(a, tol, &mut mask);
    ldlt_column_at::<3, 2, 3>(a, tol, &mut mask);
    mask
}

/// [`ldlt_column`] on the `N×N` block at row and column `O` (mask bit `O + J`).
#[inline(always)]
fn ldlt_column_at<const O: usize, const J: usize, const N: usize>(
    a: &mut Blk,
    tol: f64,
    mask: &mut u8,
) {
    if J >= N {
        return;
    }
    let (j, e) = (O + J, O + N);
    let d = a[j][j];
    if !(d.abs() > tol) {
        *mask |= 1 << j;
        a[j][j] = 0.0;
        for i in j + 1..e {
            a[i][j] = 0.0;
        }
    } else {
        for i in j + 1..e {
            a[i][j] /= d;
        }
    }
    for k in j + 1..e {
        a[k][k] -= a[k][j] * a[k][j] * a[j][j];
        for i in k + 1..e {
            a[i][k] -= a[i][j] * a[k][j] * a[j][j];
        }
    }
}

/// [`ldlt_sized`] for `N ≤ 6`, one column at a time with the column a constant, so
/// that every loop has a constant trip count and unrolls (with a runtime size, or the
/// size alone a constant, the triangular loops stayed loops: about 800 instructions
/// for a 6×6 block). The same operations in the same order.
#[inline(always)]
fn ldlt_fixed<const N: usize>(a: &mut Blk) -> u8 {
    let scale = (0..N).map(|i| a[i][i].abs()).fold(0.0f64, f64::max);
    let tol = 1e-12 * scale;
    let mut mask = 0u8;
    ldlt_column::<0, N>(a, tol, &mut mask);
    ldlt_column::<1, N>(a, tol, &mut mask);
    ldlt_column::<2, N>(a, tol, &mut mask);
    ldlt_column::<3, N>(a, tol, &mut mask);
    ldlt_column::<4, N>(a, tol, &mut mask);
    ldlt_column::<5, N>(a, tol, &mut mask);
    mask
}

/// Column `J` of [`ldlt_sized`] on an `N×N` block (nothing when `J ≥ N`), right-looking:
/// on entry `a_JJ` and `a_iJ` (`i > J`) have had every earlier column's terms taken
/// off, so `d = a_JJ`, dropped below `tol`, else `a_iJ /= d`; then this column's terms
/// come off the later columns, `a_KK −= a_KJ² d`, `a_iK −= a_iJ a_KJ d` (`i > K > J`).
/// Each entry takes [`ldlt_sized`]'s terms, `a_ik a_Jk d_k`, in the same `k` order, so
/// the same bits; unrolled, fewer values are live at once than column by column.
#[inline(always)]
fn ldlt_column<const J: usize, const N: usize>(a: &mut Blk, tol: f64, mask: &mut u8) {
    if J >= N {
        return;
    }
    let d = a[J][J];
    if !(d.abs() > tol) {
        *mask |= 1 << J;
        a[J][J] = 0.0;
        for i in J + 1..N {
            a[i][J] = 0.0;
        }
    } else {
        for i in J + 1..N {
            a[i][J] /= d;
        }
    }
    for k in J + 1..N {
        a[k][k] -= a[k][J] * a[k][J] * a[J][J];
        for i in k + 1..N {
            a[i][k] -= a[i][J] * a[k][J] * a[J][J];
        }
    }
}

/// [`ldlt_in_place`] of the leading `n×n` block.
#[inline(always)]
fn ldlt_sized(a: &mut Blk, n: usize) -> u8 {
    let scale = (0..n).map(|i| a[i][i].abs()).fold(0.0f64, f64::max);
    let tol = 1e-12 * scale;
    let mut mask = 0u8;
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k] * a[k][k];
        }
        if !(d.abs() > tol) {
            mask |= 1 << j;
            a[j][j] = 0.0;
            for i in j + 1..n {
                a[i][j] = 0.0;
            }
            continue;
        }
        a[j][j] = d;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k] * a[k][k];
            }
            a[i][j] = s / d;
        }
    }
    mask
}

/// Two distinct elements of a slice, mutably.
fn pair_mut(v: &mut [NodeBlocks], i: usize, p: usize) -> (&mut NodeBlocks, &mut NodeBlocks) {
    if i < p {
        let (lo, hi) = v.split_at_mut(p);
        (&mut lo[i], &mut hi[0])
    } else {
        let (lo, hi) = v.split_at_mut(i);
        (&mut hi[0], &mut lo[p])
    }
}

/// `W = L⁻¹ W` (unit lower `L` in `d`'s strict lower triangle), its transpose into
/// `wt`, and `D_p −= Wᵀ diag(dinv) W` on the lower triangle, for an `N`-node under an
/// `NP`-parent.
#[inline]
fn update<const N: usize, const NP: usize>(
    d: &Blk,
    dinv: &[f64; 6],
    w: &mut Blk,
    wt: &mut Blk,
    dp: &mut Blk,
) {
    // `W = L⁻¹ W` column of `L` by column (right-looking): each `w_rc` takes its
    // `l_rt w_tc` in `t` order as row by row did, the same operations; the unrolled
    // code spills less (gymnasium humanoid passive: factor_blocks 5.07M -> 5.04M).
    for t in 0..N {
        for r in t + 1..N {
            let l = d[r][t];
            for c in 0..NP {
                w[r][c] -= l * w[t][c];
            }
        }
    }
    // `d⁻¹ W` with every entry in both lanes of a pair: [`update_rows`] multiplies two
    // rows' `w` by it as one vector read from memory, not a scalar broadcast each time
    // (gymnasium humanoid passive: factor_blocks 5.20M -> 5.07M instructions).
    let mut sw = [[[0.0; 2]; 6]; 6];
    for t in 0..N {
        for c in 0..NP {
            let s = w[t][c] * dinv[t];
            sw[t][c] = [s, s];
            wt[c][t] = w[t][c];
        }
    }
    update_rows::<0, N, NP>(w, &sw, dp);
    update_rows::<2, N, NP>(w, &sw, dp);
    update_rows::<4, N, NP>(w, &sw, dp);
}

/// Rows `R0` and `R0 + 1` of [`update`]'s `D_p −= Wᵀ (d⁻¹ W)` (lower triangle), with
/// `sw = d⁻¹ W` (each entry twice, `[s, s]`): `(Wᵀ d⁻¹ W)_rc = Σ_t w_tr sw_tc`, each
/// sum from 0 in `t` order. The two rows side by side (`w_{t,R0}` and `w_{t,R0+1}`
/// are neighbours: the two sums of a column share vector lanes); row `R0`'s column
/// `R0 + 1` is computed and not stored. Nothing when `R0 ≥ NP`; row `R0` alone when it is the last.
#[inline(always)]
fn update_rows<const R0: usize, const N: usize, const NP: usize>(
    w: &Blk,
    sw: &[[[f64; 2]; 6]; 6],
    dp: &mut Blk,
) {
    if R0 >= NP {
        return;
    }
    if R0 + 1 >= NP {
        for c in 0..=R0 {
            let mut s = 0.0;
            for t in 0..N {
                s += w[t][R0] * sw[t][c][0];
            }
            dp[R0][c] -= s;
        }
        return;
    }
    let mut acc = [[0.0; 2]; 6];
    for t in 0..N {
        let (a0, a1) = (w[t][R0], w[t][R0 + 1]);
        for c in 0..=R0 + 1 {
            let b = sw[t][c];
            acc[c][0] += a0 * b[0];
            acc[c][1] += a1 * b[1];
        }
    }
    for c in 0..=R0 {
        dp[R0][c] -= acc[c][0];
    }
    for c in 0..=R0 + 1 {
        dp[R0 + 1][c] -= acc[c][1];
    }
}

/// [`update`] for any shape.
fn update_dyn(
    n: usize,
    np: usize,
    d: &Blk,
    dinv: &[f64; 6],
    w: &mut Blk,
    wt: &mut Blk,
    dp: &mut Blk,
) {
    for r in 1..n {
        for t in 0..r {
            let l = d[r][t];
            for c in 0..np {
                w[r][c] -= l * w[t][c];
            }
        }
    }
    for t in 0..n {
        for c in 0..np {
            wt[c][t] = w[t][c];
        }
    }
    for r in 0..np {
        for c in 0..=r {
            let mut s = 0.0;
            for t in 0..n {
                s += w[t][r] * dinv[t] * w[t][c];
            }
            dp[r][c] -= s;
        }
    }
}

/// One node's data for the solve kernels: `(D factor, 1/d, W, Wᵀ, offset, parent
/// offset, n, n_parent)`.
type NodeArgs<'a> = (
    &'a Blk,
    &'a [f64; 6],
    &'a Blk,
    &'a Blk,
    usize,
    usize,
    usize,
    usize,
);

/// Forward pass at one node: `u = L⁻¹ y`, `s = d⁻¹ u` (stored), `y_p −= Wᵀ s`.
/// `N`/`NP` are the compile-time shapes when they match the runtime ones (the generic
/// fallback instance `<6, 6>` uses the runtime sizes): the body is inlined once with
/// the constants, so its loops unroll and its copies are moves rather than `memcpy`
/// calls, and once with the runtime sizes — the same operations in the same order.
#[inline]
fn forward<const N: usize, const NP: usize>(args: NodeArgs<'_>, x: &mut [f64]) {
    let (n_rt, np_rt) = (args.6, args.7);
    if N == n_rt && NP == np_rt {
        forward_sized(args, x, N, NP);
    } else {
        forward_sized(args, x, n_rt, np_rt);
    }
}

/// [`forward()`] for `n` rows under a parent of `np` (0: a root).
#[inline(always)]
fn forward_sized(args: NodeArgs<'_>, x: &mut [f64], n: usize, np: usize) {
    let (d, dinv, w, _, oi, op, _, _) = args;
    let mut u = [0.0; 6];
    let xi = &mut x[oi..oi + n];
    for r in 0..n {
        let mut s = xi[r];
        for t in 0..r {
            s -= d[r][t] * u[t];
        }
        u[r] = s;
    }
    for r in 0..n {
        u[r] *= dinv[r];
    }
    xi.copy_from_slice(&u[..n]);
    // `(Wᵀ s)_c = Σ_t w_tc s_t`, each sum from 0 in `t` order, accumulated a row of `W`
    // at a time (contiguous columns: the sums of two columns share vector lanes).
    let mut acc = [0.0; 6];
    for t in 0..n {
        let ut = u[t];
        for c in 0..np {
            acc[c] += w[t][c] * ut;
        }
    }
    let xp = &mut x[op..op + np];
    for c in 0..np {
        xp[c] -= acc[c];
    }
}

/// Backward pass at one node: `x_i = L⁻ᵀ (s − d⁻¹ W x_p)` (shapes as in [`forward()`]);
/// `s` read from `x` when `read`, else zero (a node the forward pass skipped).
#[inline]
fn backward<const N: usize, const NP: usize>(args: NodeArgs<'_>, x: &mut [f64], read: bool) {
    let (n_rt, np_rt) = (args.6, args.7);
    if N == n_rt && NP == np_rt {
        backward_sized(args, x, N, NP, read);
    } else {
        backward_sized(args, x, n_rt, np_rt, read);
    }
}

/// [`backward`] for `n` rows under a parent of `np` (0: a root).
#[inline(always)]
fn backward_sized(args: NodeArgs<'_>, x: &mut [f64], n: usize, np: usize, read: bool) {
    let (d, dinv, _, wt, oi, op, _, _) = args;
    let mut s = [0.0; 6];
    if read {
        s[..n].copy_from_slice(&x[oi..oi + n]);
    }
    if np > 0 {
        let mut xp = [0.0; 6];
        xp[..np].copy_from_slice(&x[op..op + np]);
        // `(W x_p)_r = Σ_c w_rc x_c`, each sum from 0 in `c` order, accumulated a row of
        // `Wᵀ` (a column of `W`: two rows' sums side by side, contiguous), stored into
        // `x` (the node's entries, overwritten below) and read back for
        // `s −= d⁻¹ W x_p`. The store is what lets the compiler pair the sums in vector
        // lanes (each lane the scalar sum, same order): with the sums kept in
        // registers, or stored only as `s − d⁻¹ W x_p`, they stayed scalar (issue 13,
        // humanoid_CMU controlled 0.1 s, this function 17.31M → 17.46M / 17.65M
        // instructions, against 15.51M with this store).
        let mut acc = [0.0; 6];
        for c in 0..np {
            let xc = xp[c];
            for r in 0..n {
                acc[r] += wt[c][r] * xc;
            }
        }
        let xi = &mut x[oi..oi + n];
        xi.copy_from_slice(&acc[..n]);
        for r in 0..n {
            s[r] -= dinv[r] * xi[r];
        }
    }
    for r in (0..n).rev() {
        let mut v = s[r];
        for t in r + 1..n {
            v -= d[t][r] * s[t];
        }
        s[r] = v;
    }
    x[oi..oi + n].copy_from_slice(&s[..n]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use constraint_core::DMat3;
    use constraint_lagrange::solve::svd::SvdSolver;
    use constraint_lagrange::solve::DenseMatrix;

    /// The branched trees of the tests below, factored: `n` bodies, body 0 hung from
    /// the world, body `i` from `parent(i)`, by ball joints (the first `rows(i)` of
    /// their three rows) at the child's origin offset by `r`.
    fn branched_tree(
        n: usize,
        parent: impl Fn(usize) -> usize,
        rows: impl Fn(usize) -> usize,
    ) -> (Vec<JointTopo>, TreeSolver) {
        let mut topo = vec![JointTopo {
            a: None,
            b: 0,
            rows: 3,
        }];
        for i in 1..n {
            topo.push(JointTopo {
                a: Some(parent(i)),
                b: i,
                rows: rows(i),
            });
        }
        let mut t = TreeSolver::new(n, &topo);
        for i in 0..n {
            let m = 1.0 + 0.1 * i as f64;
            t.set_body(i, m, &(DMat3::IDENTITY * (0.01 + 0.001 * i as f64)));
        }
        for (j, tp) in topo.iter().enumerate() {
            // Ball joint at the child's origin offset by r: v_b + ω_b × r_b − … = 0.
            let r = DVec3::new(0.1, 0.02 * j as f64, -0.05);
            let mut rows = [[DVec3::ZERO; 4]; 3];
            for (k, row) in rows.iter_mut().enumerate() {
                let e = DVec3::AXES[k];
                *row = [-e, -r.cross(e) * 0.5, e, r.cross(e)];
            }
            t.set_joint(j, tp, &rows[..tp.rows], 0, &[0.0; 3][..tp.rows]);
        }
        t.factor().expect("factor");
        (topo, t)
    }

    /// A branched tree (a chain of 8 bodies hung from the world, with a second chain of
    /// 4 on body 2) held by 3-row ball joints: a column `Gᵀ` of a contact row on one
    /// or two bodies gives the same solution by [`TreeSolver::solve_sparse`] (forward
    /// pass on the bodies' paths to the root only, a column left NaN outside them) as
    /// by [`TreeSolver::solve`], to the bit (`==`, which equates the two zeros).
    #[test]
    fn sparse_forward_pass_gives_the_full_solve() {
        let (_, t) = branched_tree(12, |i| if i == 8 { 2 } else { i - 1 }, |_| 3);
        let mut mark = Vec::new();
        for bodies in [[Some(5), None], [Some(10), Some(4)], [Some(0), Some(11)]] {
            let mut full = vec![0.0; t.size];
            for (s, b) in bodies.iter().enumerate() {
                if let Some(b) = b {
                    let o = t.body_offset(*b);
                    for c in 0..6 {
                        full[o + c] = (1 + s) as f64 * (0.3 + c as f64) * 0.7;
                    }
                }
            }
            // The sparse column starts as garbage (NaN): `mark_paths` clears the
            // marked nodes, the rest is never read.
            let mut sparse = vec![f64::NAN; t.size];
            t.mark_paths(&mut sparse, bodies, &mut mark);
            for b in bodies.into_iter().flatten() {
                let o = t.body_offset(b);
                sparse[o..o + 6].copy_from_slice(&full[o..o + 6]);
            }
            t.solve(&mut full);
            t.solve_sparse(&mut sparse, &mark);
            assert!(full.iter().any(|v| *v != 0.0));
            assert_eq!(full, sparse, "bodies {bodies:?}");
        }
    }

    /// A right-hand side zero on every body and nonzero on the joints (SHAKE's
    /// corrections) gives the same solution by [`TreeSolver::solve_zero_bodies`] (the
    /// forward pass skipping the childless bodies: here bodies 7 and 11 of the
    /// branched tree of the test above, and body 12 hung by a 1-row joint) as by
    /// [`TreeSolver::solve`], to the bit (compared as bits, so also the signs of
    /// zeros; one joint's right-hand side `−0.0`, one row `+0.0`).
    #[test]
    fn zero_body_solve_gives_the_full_solve_to_the_bit() {
        let n = 13;
        let parent = |i| match i {
            8 => 2,
            12 => 5,
            _ => i - 1,
        };
        let (topo, t) = branched_tree(n, parent, |i| if i == 12 { 1 } else { 3 });
        let leaves: Vec<usize> = (0..n).filter(|&i| !t.forward_nodes[i]).collect();
        assert_eq!(leaves, [7, 11, 12]);
        let mut full = vec![0.0; t.size];
        for (j, tp) in topo.iter().enumerate() {
            let o = t.joint_offset(j).expect("tree joint");
            for r in 0..tp.rows {
                full[o + r] = match (j, r) {
                    (3, _) => -0.0,
                    (4, 1) => 0.0,
                    _ => libm::sin(1.3 * j as f64 + 0.7 * r as f64) * 1e-3,
                };
            }
        }
        let mut skipped = full.clone();
        t.solve(&mut full);
        t.solve_zero_bodies(&mut skipped);
        assert!(full.iter().any(|v| *v != 0.0));
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&full), bits(&skipped));
    }

    /// The truncation of one SVD at a larger tolerance gives the bits of a second
    /// decomposition at that tolerance: a 4×4 matrix with singular values (measured)
    /// 2.45, 1.32, 7.2e-4, 4.5e-8, tolerances that keep 4, 3, 2, 1 and 0 of them
    /// (`==` on the solutions).
    #[test]
    fn truncated_min_norm_matches_a_second_decomposition() {
        let a = DenseMatrix::from_fn(4, 4, |i, j| {
            let d = [1.0, 1e-3, 1e-7, 1e-14][i.min(j)];
            d * (1.0 + 0.1 * (i as f64) - 0.05 * (j as f64))
        });
        let b = [0.3, -1.2, 0.7, 2.5];
        let svd = SvdSolver::new(&a, 1e-16).expect("svd");
        for (tol, kept) in [(1e-9, 4), (1e-6, 3), (1e-2, 2), (0.7, 1), (2.0, 0)] {
            let mut want = [0.0; 4];
            let again = SvdSolver::new(&a, tol).expect("svd");
            assert_eq!(again.rank(), kept, "tol {tol}");
            again.solve_min_norm(&b, &mut want).expect("solve");
            let mut got = [f64::NAN; 4];
            assert!(min_norm_truncated(&svd, tol, &b, &mut got));
            assert_eq!(got, want, "tol {tol}");
        }
        assert!(!min_norm_truncated(&svd, f64::NAN, &b, &mut [0.0; 4]));
        assert!(!min_norm_truncated(&svd, 1e-9, &b[..3], &mut [0.0; 4]));
    }

    /// Every change of a solver's blocks gives a stamp no earlier state had, across
    /// several reserved ranges (3 000 changes, ranges of 1 024); a clone keeps the
    /// stamp until either changes, and then the two take different values.
    #[test]
    fn stamps_are_new_at_every_change() {
        let mut s = TreeSolver::new(1, &[]);
        let mut seen = alloc::collections::BTreeSet::new();
        assert!(seen.insert(s.stamp()));
        for k in 0..3000 {
            s.set_body(0, 1.0 + k as f64, &DMat3::IDENTITY);
            assert!(seen.insert(s.stamp()), "stamp repeated at change {k}");
        }
        let mut c = s.clone();
        assert_eq!(c.stamp(), s.stamp());
        s.set_body(0, 2.0, &DMat3::IDENTITY);
        c.set_body(0, 3.0, &DMat3::IDENTITY);
        assert_ne!(c.stamp(), s.stamp());
        assert!(seen.insert(s.stamp()) && seen.insert(c.stamp()));
        // The clone's next changes stay apart from the original's too.
        for _ in 0..5 {
            s.factor().expect("a positive mass block factors");
            c.factor().expect("a positive mass block factors");
            assert!(seen.insert(s.stamp()) && seen.insert(c.stamp()));
        }
    }

    /// The unrolled [`ldlt_fixed`] gives [`ldlt_sized`]'s factor to the bit, on
    /// symmetric blocks of every size 1..6, one with a dependent row (a dropped pivot,
    /// the mask compared too). Bits, not a tolerance: the step's results depend on it.
    #[test]
    fn split_ldlt_of_a_mass_block_matches_the_whole_to_the_bit() {
        // A body's mass block `(m 1 + X) ⊕ (I + T)`: symmetric positive definite halves
        // with signed entries (negative zeros among them), the lower-left block `+0`.
        for k in 0..8 {
            let mut a = ZERO;
            for half in [0usize, 3] {
                for i in 0..3 {
                    for j in 0..=i {
                        let v = libm::sin(0.4 + 1.3 * (i + half) as f64 + 0.7 * (j + k) as f64);
                        let v = if (i + j + k) % 5 == 0 { -0.0 } else { v };
                        a[half + i][half + j] = v;
                        a[half + j][half + i] = v;
                    }
                    a[half + i][half + i] = 4.0 + 0.5 * (i + k) as f64;
                }
            }
            assert!(split_halves(&a));
            let (mut split, mut whole) = (a, a);
            let (m_split, m_whole) = (ldlt_split(&mut split), ldlt_fixed::<6>(&mut whole));
            assert_eq!((m_split, m_whole), (0, 0), "case {k}");
            for i in 0..6 {
                for j in 0..=i {
                    assert_eq!(
                        split[i][j].to_bits(),
                        whole[i][j].to_bits(),
                        "case {k} ({i}, {j})"
                    );
                }
            }
        }
        let mut coupled = ZERO;
        coupled[4][1] = 1e-300;
        assert!(!split_halves(&coupled), "a coupled block is not split");
        coupled[4][1] = -0.0;
        assert!(
            !split_halves(&coupled),
            "nor one with a negative zero there"
        );
    }

    #[test]
    fn unrolled_ldlt_matches_the_loop_to_the_bit() {
        for n in 1..=6 {
            for dependent in [false, true] {
                let mut a = ZERO;
                for i in 0..n {
                    for j in 0..=i {
                        let v = libm::sin(0.3 + 1.7 * i as f64 + 0.9 * j as f64);
                        a[i][j] = v;
                        a[j][i] = v;
                    }
                    a[i][i] += if i % 2 == 0 { 3.0 } else { -3.0 };
                }
                if dependent && n > 1 {
                    // Row n−1 a copy of row 0 (and so the column): a zero pivot.
                    for j in 0..n {
                        a[n - 1][j] = a[0][j];
                        a[j][n - 1] = a[j][0];
                    }
                    a[n - 1][n - 1] = a[0][0];
                }
                let (mut fixed, mut looped) = (a, a);
                let m_fixed = ldlt_in_place(&mut fixed, n);
                let m_loop = ldlt_sized(&mut looped, n);
                assert_eq!(m_fixed, m_loop, "n {n}");
                if dependent && n > 1 {
                    assert_ne!(m_loop, 0, "n {n}: the dependent row is dropped");
                }
                for i in 0..n {
                    for j in 0..n {
                        assert_eq!(fixed[i][j].to_bits(), looped[i][j].to_bits(), "n {n}");
                    }
                }
            }
        }
    }
}
