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
}

impl RowTree {
    /// Places the rows into the tree's nodes and loads the blocks: `tree`'s assembled
    /// (not yet factored) `H` plus the rows `G_A` with zero diagonal. Returns `false`
    /// when a row does not fit the node it names (its bodies are not that node's
    /// neighbours).
    pub fn assemble(&mut self, tree: &TreeSolver, rows: &[ExtraRow]) -> bool {
        let nn = tree.dim.len();
        let nb = tree.n_bodies;
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
        self.slot.clear();
        self.slot.resize(rows.len(), 0);
        self.fill.clear();
        self.fill.extend_from_slice(&self.start[..nn]);
        for (i, r) in rows.iter().enumerate() {
            self.slot[self.fill[r.node]] = i;
            self.fill[r.node] += 1;
        }
        // Sizes and offsets.
        self.base.clear();
        self.n.clear();
        self.xoff.clear();
        self.dpos.clear();
        self.opos.clear();
        let (mut x, mut d) = (0, 0);
        for k in 0..nn {
            let n = tree.dim[k] + self.start[k + 1] - self.start[k];
            self.base.push(tree.dim[k]);
            self.n.push(n);
            self.xoff.push(x);
            self.dpos.push(d);
            x += n;
            d += n * n;
        }
        let mut o = 0;
        for k in 0..nn {
            self.opos.push(o);
            let p = tree.parent[k];
            if p != NONE {
                o += self.n[k] * self.n[p];
            }
        }
        self.size = x;
        self.diag.clear();
        self.diag.resize(d, 0.0);
        self.off.clear();
        self.off.resize(o, 0.0);
        self.dinv.clear();
        self.dinv.resize(x, 0.0);
        self.pos.clear();
        self.pos.resize(rows.len(), 0);
        // The tree's blocks.
        for k in 0..nn {
            let (b, n, dp) = (self.base[k], self.n[k], self.dpos[k]);
            for r in 0..b {
                for c in 0..b {
                    self.diag[dp + r * n + c] = tree.diag[k][r][c];
                }
            }
            let p = tree.parent[k];
            if p != NONE {
                let (bp, np, op) = (self.base[p], self.n[p], self.opos[k]);
                for r in 0..b {
                    for c in 0..bp {
                        self.off[op + r * np + c] = tree.off[k][r][c];
                    }
                }
            }
        }
        // The extra rows.
        for k in 0..nn {
            let (b, n) = (self.base[k], self.n[k]);
            for e in self.start[k]..self.start[k + 1] {
                let ri = self.slot[e];
                let row = &rows[ri];
                let lr = b + e - self.start[k];
                self.pos[ri] = self.xoff[k] + lr;
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
    pub fn factor(&mut self, tree: &TreeSolver) -> Result<(), ArticulatedError> {
        let nb = tree.n_bodies;
        for &k in &tree.order {
            let (b, n, dp, xo) = (self.base[k], self.n[k], self.dpos[k], self.xoff[k]);
            let blk = &mut self.diag[dp..dp + n * n];
            let dinv = &mut self.dinv[xo..xo + n];
            ldlt_two_segment(blk, n, b, dinv);
            if k < nb && (0..b).any(|r| !(blk[r * n + r] > 0.0) || dinv[r] == 0.0) {
                return Err(ArticulatedError::Singular { node: k });
            }
            let p = tree.parent[k];
            if p == NONE {
                continue;
            }
            let np = self.n[p];
            let (op, dpp) = (self.opos[k], self.dpos[p]);
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
                ($($a:literal, $b:literal);*) => {
                    match (n, np) {
                        $(($a, $b) => update_fixed::<$a, $b>(blk, dinv, w, dpar),)*
                        _ => update_dyn(n, np, blk, dinv, w, dpar),
                    }
                };
            }
            dispatch!(6, 3; 6, 4; 6, 5; 6, 6; 6, 7; 6, 8; 6, 9; 6, 11; 6, 12;
                3, 6; 4, 6; 5, 6; 7, 6; 8, 6; 9, 6; 11, 6; 12, 6);
        }
        Ok(())
    }

    /// Solves the augmented system in place (`x` of length [`Self::size`], laid out
    /// node by node, base rows first): forward `s = d⁻¹ L⁻¹ y`, `y_p −= Wᵀ s`; backward
    /// `x = L⁻ᵀ (s − d⁻¹ W x_p)`.
    pub fn solve(&self, tree: &TreeSolver, x: &mut [f64]) {
        macro_rules! dispatch {
            ($f:ident, $n:expr, $np:expr, $args:expr; $($a:literal, $b:literal);*) => {
                match ($n, $np) {
                    $(($a, $b) => $f::<$a, $b>($args),)*
                    _ => $f::<0, 0>($args),
                }
            };
        }
        for &k in &tree.order {
            let args = self.node_args(tree, k, x);
            dispatch!(forward, args.n, args.np, args;
                6, 0; 6, 3; 6, 4; 6, 5; 6, 6; 6, 7; 6, 8; 6, 9; 6, 12;
                3, 6; 4, 6; 5, 6; 7, 6; 8, 6; 9, 6; 12, 6);
        }
        for &k in tree.order.iter().rev() {
            let args = self.node_args(tree, k, x);
            dispatch!(backward, args.n, args.np, args;
                6, 0; 6, 3; 6, 4; 6, 5; 6, 6; 6, 7; 6, 8; 6, 9; 6, 12;
                3, 6; 4, 6; 5, 6; 7, 6; 8, 6; 9, 6; 12, 6);
        }
    }

    /// [`Self::solve`]'s forward pass (`s = d⁻¹ L⁻¹ y` at each node, `y_p −= Wᵀ s`) at
    /// the nodes marked in `mark` only, in the elimination order. For a right-hand side
    /// zero outside the marked nodes, with the marked set closed under parents (a row's
    /// bodies and their ancestors), the result equals the full pass's: the other nodes
    /// hold zero and send nothing up. `gᵀ H_A⁻¹ g' = Σ_u s_u s'_u / d⁻¹_u` over the
    /// unknowns with [`Self::pivot_inverse`] non-zero then needs only the paths to the
    /// root (`world/active_set.rs`'s Schur rows).
    pub fn forward_marked(&self, tree: &TreeSolver, x: &mut [f64], mark: &[bool]) {
        macro_rules! dispatch {
            ($f:ident, $n:expr, $np:expr, $args:expr; $($a:literal, $b:literal);*) => {
                match ($n, $np) {
                    $(($a, $b) => $f::<$a, $b>($args),)*
                    _ => $f::<0, 0>($args),
                }
            };
        }
        for &k in &tree.order {
            if mark.get(k).copied().unwrap_or(false) {
                let args = self.node_args(tree, k, x);
                dispatch!(forward, args.n, args.np, args;
                    6, 0; 6, 3; 6, 4; 6, 5; 6, 6; 6, 7; 6, 8; 6, 9; 6, 12;
                    3, 6; 4, 6; 5, 6; 7, 6; 8, 6; 9, 6; 12, 6);
            }
        }
    }

    /// Node `k`'s number of unknowns (base and extra rows).
    #[inline]
    pub fn node_len(&self, k: usize) -> usize {
        self.n[k]
    }

    /// Unknown `u`'s inverse pivot `d⁻¹` (zero: dropped).
    #[inline]
    pub fn pivot_inverse(&self, u: usize) -> f64 {
        self.dinv[u]
    }

    /// Node `k`'s blocks and its own and its parent's unknowns, split from `x`.
    fn node_args<'a>(&'a self, tree: &TreeSolver, k: usize, x: &'a mut [f64]) -> NodeArgs<'a> {
        let (n, dp, xo) = (self.n[k], self.dpos[k], self.xoff[k]);
        let p = tree.parent[k];
        let (np, xp, op) = if p == NONE {
            (0, 0, 0)
        } else {
            (self.n[p], self.xoff[p], self.opos[k])
        };
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
#[inline]
fn forward<const N: usize, const NP: usize>(a: NodeArgs<'_>) {
    let (n, np) = if N == 0 { (a.n, a.np) } else { (N, NP) };
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

/// Backward pass at one node: `x = L⁻ᵀ (s − d⁻¹ W x_p)`.
#[inline]
fn backward<const N: usize, const NP: usize>(a: NodeArgs<'_>) {
    let (n, np) = if N == 0 { (a.n, a.np) } else { (N, NP) };
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

/// `W = L⁻¹ W` (`L` the unit lower factor in `blk`) and `D_p −= Wᵀ diag(dinv) W` on
/// the lower triangle, for an `N`-row node under an `NP`-row parent.
#[inline]
fn update_fixed<const N: usize, const NP: usize>(
    blk: &[f64],
    dinv: &[f64],
    w: &mut [f64],
    dpar: &mut [f64],
) {
    let blk = &blk[..N * N];
    let dinv = &dinv[..N];
    let w = &mut w[..N * NP];
    let dpar = &mut dpar[..NP * NP];
    for r in 1..N {
        for t in 0..r {
            let l = blk[r * N + t];
            for c in 0..NP {
                w[r * NP + c] -= l * w[t * NP + c];
            }
        }
    }
    for t in 0..N {
        let dt = dinv[t];
        for r in 0..NP {
            let s = w[t * NP + r] * dt;
            for c in 0..=r {
                dpar[r * NP + c] -= s * w[t * NP + c];
            }
        }
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
}
