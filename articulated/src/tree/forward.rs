//! The forward pass alone along a row's paths to the root: the half of a solve that
//! gives `g H⁻¹ g'ᵀ` without the backward pass.
//!
//! With the factor `H = L D Lᵀ` (leaves first, [`TreeSolver::factor`]) and a row
//! `g` on one or two bodies, `u = L⁻¹ gᵀ` is non-zero only on those bodies and their
//! ancestors (eliminating a node sends its right-hand side to its parent alone), so
//!
//! ```text
//! g H⁻¹ g'ᵀ = uᵀ D⁺ u' = Σ u_r s'_r    (s' = D⁺ u', D⁺: 0 at a dropped pivot)
//! ```
//!
//! summed over the unknowns the two rows' paths share. The forward pass writes
//! `s = d⁻¹ u` ([`super::forward()`]); `u = d s` is taken back with the node's pivot `d`
//! (zero at a dropped pivot, where `s` is zero too).

use alloc::vec::Vec;

use super::{forward as node_forward, TreeSolver, NONE};

impl TreeSolver {
    /// Appends to `path` the nodes of `bodies` and their ancestors, each once, in an
    /// order in which every node comes after its children on the path (the second
    /// body's nodes below the first body's path, then the first body's path up to the
    /// root): the order [`Self::forward_path`] needs. `mark` (one flag per node, all
    /// `false` on entry) is left all `false`. Bodies beyond the tree are skipped.
    pub(crate) fn row_path(
        &self,
        bodies: [Option<usize>; 2],
        mark: &mut Vec<bool>,
        path: &mut Vec<usize>,
    ) {
        if mark.len() < self.dim.len() {
            mark.resize(self.dim.len(), false);
        }
        let first = path.len();
        let mut split = first;
        for (side, body) in bodies.into_iter().enumerate() {
            let Some(mut i) = body else { continue };
            if side == 1 {
                split = path.len();
            }
            while i != NONE && i < self.dim.len() && !mark[i] {
                mark[i] = true;
                path.push(i);
                i = self.parent[i];
            }
        }
        // The second body's own nodes (below where its walk met the first's path)
        // first: they send their right-hand side into that path.
        let second = path.len() - split;
        path[first..].rotate_right(second);
        for &k in &path[first..] {
            mark[k] = false;
        }
    }

    /// The forward pass (`u = L_i⁻¹ y_i`, `s = d⁻¹ u` stored, `y_p −= Wᵀ s`) at the
    /// nodes of `path` only, in its order ([`Self::row_path`]). For a right-hand side
    /// zero outside those nodes (a row placed on the path's bodies), `x` then holds on
    /// the path the full forward pass's `s = D⁺ L⁻¹ b`, and elsewhere is untouched.
    pub(crate) fn forward_path(&self, x: &mut [f64], path: &[usize]) {
        macro_rules! dispatch {
            ($n:expr, $np:expr, $call:tt; $($a:literal, $b:literal);*) => {
                match ($n, $np) {
                    $(($a, $b) => node_forward::<$a, $b> $call,)*
                    _ => node_forward::<6, 6> $call,
                }
            };
        }
        for &i in path {
            let (n, oi) = (self.dim[i], self.offset[i]);
            let p = self.parent[i];
            let (np, op) = if p == NONE {
                (0, 0)
            } else {
                (self.dim[p], self.offset[p])
            };
            let b = &self.blocks[i];
            let args = (&b.diag, &b.dinv, &b.off, &b.off_t, oi, op, n, np);
            // The common shape by one test, as in `solve_marked`.
            if n == 6 && np == 6 {
                node_forward::<6, 6>(args, x);
                continue;
            }
            dispatch!(n, np, (args, x);
                6, 0; 6, 1; 6, 2; 6, 3; 6, 4; 6, 5; 1, 6; 2, 6; 3, 6; 4, 6; 5, 6;
                1, 0; 2, 0; 3, 0; 4, 0; 5, 0);
        }
    }

    /// Moves [`Self::forward_path`]'s `s` on `path` out of `x` (leaving zeros) into
    /// `s_out`, node after node in `path`'s order, and `u = d s` beside it into `u_out`
    /// (`d` the node's pivot, zero where dropped); both at least as long as the path's
    /// unknowns.
    pub(crate) fn take_path_values(
        &self,
        x: &mut [f64],
        path: &[usize],
        s_out: &mut [f64],
        u_out: &mut [f64],
    ) {
        let mut at = 0;
        for &i in path {
            let (n, o) = (self.dim[i], self.offset[i]);
            let d = &self.blocks[i].diag;
            let (so, uo) = (&mut s_out[at..at + n], &mut u_out[at..at + n]);
            for (r, xv) in x[o..o + n].iter_mut().enumerate() {
                let s = core::mem::take(xv);
                so[r] = s;
                uo[r] = d[r][r] * s;
            }
            at += n;
        }
    }

    /// Node `k`'s number of unknowns.
    #[inline]
    pub(crate) fn node_dim(&self, k: usize) -> usize {
        self.dim[k]
    }
}

#[cfg(test)]
mod tests {
    use super::super::JointTopo;
    use super::*;
    use constraint_core::{DMat3, DVec3};

    /// A branched chain: a forward pass on a two-body row's path leaves the rest of
    /// `x` untouched, and `Σ u s'` over the shared unknowns equals `g' · H⁻¹ gᵀ` from
    /// a whole solve (measured 3.7e-14 relative apart; tolerance 1e-12).
    #[test]
    fn path_forward_pass_gives_the_row_coupling() {
        let n = 9;
        let mut topo = vec![JointTopo {
            a: None,
            b: 0,
            rows: 3,
        }];
        for i in 1..n {
            let a = if i == 6 { 2 } else { i - 1 };
            topo.push(JointTopo {
                a: Some(a),
                b: i,
                rows: 3,
            });
        }
        let mut t = TreeSolver::new(n, &topo);
        for i in 0..n {
            t.set_body(i, 1.0 + 0.2 * i as f64, &(DMat3::IDENTITY * 0.02));
        }
        for (j, tp) in topo.iter().enumerate() {
            let r = DVec3::new(0.1, 0.03 * j as f64, -0.05);
            let mut rows = [[DVec3::ZERO; 4]; 3];
            for (k, row) in rows.iter_mut().enumerate() {
                let e = DVec3::AXES[k];
                *row = [-e, -r.cross(e) * 0.5, e, r.cross(e)];
            }
            t.set_joint(j, tp, &rows, 0, &[0.0; 3]);
        }
        t.factor().expect("factor");
        let g = |b: usize, k: f64| -> Vec<f64> {
            let mut v = vec![0.0; t.size];
            let o = t.body_offset(b);
            for c in 0..6 {
                v[o + c] = k * (0.4 + c as f64) - 1.1;
            }
            v
        };
        let (g1, g2) = (g(8, 1.0), g(4, -0.7));
        let mut mark = Vec::new();
        let mut vals: [(Vec<usize>, Vec<f64>, Vec<f64>); 2] = Default::default();
        for (k, (b, gv)) in [(8usize, &g1), (4usize, &g2)].into_iter().enumerate() {
            let mut x = gv.clone();
            let mut path = Vec::new();
            t.row_path([Some(b), None], &mut mark, &mut path);
            t.forward_path(&mut x, &path);
            let len: usize = path.iter().map(|&k| t.node_dim(k)).sum();
            let mut s = vec![f64::NAN; len];
            let mut u = vec![f64::NAN; len];
            t.take_path_values(&mut x, &path, &mut s, &mut u);
            assert!(x.iter().all(|v| *v == 0.0));
            vals[k] = (path, s, u);
        }
        let mut a12 = 0.0;
        let (p1, _, u1) = &vals[0];
        let (p2, s2, _) = &vals[1];
        let mut at1 = 0;
        for &k in p1 {
            let nk = t.node_dim(k);
            let mut at2 = 0;
            for &l in p2 {
                if l == k {
                    for r in 0..nk {
                        a12 += u1[at1 + r] * s2[at2 + r];
                    }
                }
                at2 += t.node_dim(l);
            }
            at1 += nk;
        }
        let mut y = g2.clone();
        t.solve(&mut y);
        let want: f64 = g1.iter().zip(&y).map(|(a, b)| a * b).sum();
        assert!(want.abs() > 1e-3, "{want}");
        let rel = (a12 - want).abs() / want.abs();
        eprintln!("relative difference {rel:e}");
        assert!(rel <= 1e-12, "{a12} {want}");
        assert!(mark.iter().all(|m| !m));
    }
}
