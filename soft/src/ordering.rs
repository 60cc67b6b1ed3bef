//! Fill-reducing orderings of a [`BlockPattern`] for the sparse direct solver.
//!
//! [`nested_dissection`] orders the points (block rows) by recursive coordinate
//! bisection (George 1973; the geometric variant of Miller, Teng, Thurston & Vavasis
//! 1998): the points of a subgraph are split at the median of the coordinate axis that
//! yields the smaller vertex separator; the separator is the boundary of one half (the
//! points with a neighbour in the other half, whichever side is smaller), and the order
//! is *left half, right half, separator*, recursively, down to small leaves kept in
//! point order. On a mesh of `n` points this gives the classical `O(n log n)` fill and
//! `O(n^{3/2})` factorization work for a surface (`O(n^{4/3})` fill, `O(n²)` work for a
//! volume), with separators that are dense blocks for the supernodal factorization.
//!
//! Everything is deterministic: sorts are by `(coordinate, index)` with
//! [`f64::total_cmp`], ties are broken towards the lower axis and the left side, and no
//! hash maps are used. The ordering is a pure function of the pattern and positions;
//! positions only steer the quality of the separators, never their validity (any
//! boundary set separates), so crumpled or degenerate geometry is safe.

use crate::bsr::BlockPattern;
use crate::error::SoftError;
use constraint_core::DVec3;

/// Subgraphs of at most this many points are not dissected further (on the cloth, 4,
/// 8 and 16 give factorizations within 3 % of each other in operations; larger leaves
/// cost more).
const LEAF: usize = 8;

/// Nested-dissection order of the points of `pattern`, guided by their positions `x`:
/// entry `k` is the point eliminated `k`-th.
///
/// # Errors
/// [`SoftError::LengthMismatch`] if `x.len()` differs from the pattern's size.
pub fn nested_dissection(pattern: &BlockPattern, x: &[DVec3]) -> Result<Vec<usize>, SoftError> {
    let n = pattern.len();
    if x.len() != n {
        return Err(SoftError::LengthMismatch);
    }
    let mut nd = Dissection {
        pattern,
        x,
        side: vec![0; n],
        order: Vec::with_capacity(n),
    };
    let mut all: Vec<u32> = (0..n as u32).collect();
    nd.dissect(&mut all);
    Ok(nd.order.into_iter().map(|i| i as usize).collect())
}

/// Expands a point order to the scalar order of `3` degrees of freedom per point and
/// returns `(forward, inverse)`: `forward[k]` is the scalar unknown eliminated `k`-th
/// and `inverse[forward[k]] = k`.
pub fn expand_to_scalars(order: &[usize]) -> (Vec<usize>, Vec<usize>) {
    let forward: Vec<usize> = order
        .iter()
        .flat_map(|&p| [3 * p, 3 * p + 1, 3 * p + 2])
        .collect();
    let mut inverse = vec![0; forward.len()];
    for (k, &i) in forward.iter().enumerate() {
        inverse[i] = k;
    }
    (forward, inverse)
}

/// `true` when `order` is a permutation of `0..n`.
pub fn is_permutation(order: &[usize], n: usize) -> bool {
    if order.len() != n {
        return false;
    }
    let mut seen = vec![false; n];
    for &i in order {
        match seen.get_mut(i) {
            Some(s) if !*s => *s = true,
            _ => return false,
        }
    }
    true
}

struct Dissection<'a> {
    pattern: &'a BlockPattern,
    x: &'a [DVec3],
    /// Membership during a split: 0 outside the current subgraph, 1 left, 2 right.
    side: Vec<u8>,
    order: Vec<u32>,
}

impl Dissection<'_> {
    fn dissect(&mut self, idx: &mut [u32]) {
        if idx.len() <= LEAF {
            idx.sort_unstable();
            self.order.extend_from_slice(idx);
            return;
        }
        // Pick the axis whose median split has the smallest separator.
        let mut best: Option<(usize, usize, bool)> = None; // (size, axis, from_left)
        for axis in 0..3 {
            self.sort_along(idx, axis);
            let (left, right) = self.boundaries(idx);
            let (size, from_left) = if left <= right {
                (left, true)
            } else {
                (right, false)
            };
            if best.is_none_or(|(s, _, _)| size < s) {
                best = Some((size, axis, from_left));
            }
        }
        let Some((_, axis, from_left)) = best else {
            return;
        };
        self.sort_along(idx, axis);
        let mid = idx.len() / 2;
        self.mark(idx, mid);
        // Partition into left', right', separator, each keeping the sorted order.
        let mut sep = Vec::new();
        let (mut left, mut right) = (Vec::with_capacity(mid), Vec::with_capacity(mid + 1));
        for (k, &v) in idx.iter().enumerate() {
            let is_left = k < mid;
            let on_boundary = is_left == from_left && self.touches_other_side(v);
            if on_boundary {
                sep.push(v);
            } else if is_left {
                left.push(v);
            } else {
                right.push(v);
            }
        }
        for &v in idx.iter() {
            self.side[v as usize] = 0;
        }
        self.dissect(&mut left);
        self.dissect(&mut right);
        sep.sort_unstable();
        self.order.extend_from_slice(&sep);
    }

    fn sort_along(&self, idx: &mut [u32], axis: usize) {
        let x = self.x;
        idx.sort_unstable_by(|&a, &b| {
            x[a as usize][axis]
                .total_cmp(&x[b as usize][axis])
                .then(a.cmp(&b))
        });
    }

    fn mark(&mut self, idx: &[u32], mid: usize) {
        for (k, &v) in idx.iter().enumerate() {
            self.side[v as usize] = if k < mid { 1 } else { 2 };
        }
    }

    /// Whether `v` has a neighbour on the other side of the current split.
    fn touches_other_side(&self, v: u32) -> bool {
        let s = self.side[v as usize];
        let (cols, _) = self.pattern.row(v as usize);
        cols.iter().any(|&w| {
            let t = self.side[w as usize];
            t != 0 && t != s
        })
    }

    /// Sizes of the left and right boundaries of the median split of the sorted `idx`.
    fn boundaries(&mut self, idx: &[u32]) -> (usize, usize) {
        let mid = idx.len() / 2;
        self.mark(idx, mid);
        let (mut left, mut right) = (0, 0);
        for (k, &v) in idx.iter().enumerate() {
            if self.touches_other_side(v) {
                if k < mid {
                    left += 1;
                } else {
                    right += 1;
                }
            }
        }
        for &v in idx {
            self.side[v as usize] = 0;
        }
        (left, right)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> (BlockPattern, Vec<DVec3>) {
        let mut stencils: Vec<[usize; 2]> = Vec::new();
        for r in 0..n {
            for c in 0..n {
                let i = r * n + c;
                if c + 1 < n {
                    stencils.push([i, i + 1]);
                }
                if r + 1 < n {
                    stencils.push([i, i + n]);
                }
                if r + 1 < n && c + 1 < n {
                    stencils.push([i, i + n + 1]);
                    stencils.push([i + 1, i + n]);
                }
            }
        }
        let p = BlockPattern::from_stencils(n * n, stencils.iter().map(|s| &s[..]));
        let x = (0..n * n)
            .map(|k| DVec3::new((k % n) as f64, -((k / n) as f64), 0.0))
            .collect();
        (p, x)
    }

    #[test]
    fn nested_dissection_is_a_deterministic_permutation() {
        for n in [1, 2, 5, 17, 40] {
            let (p, x) = grid(n);
            let o = nested_dissection(&p, &x).unwrap();
            assert!(is_permutation(&o, n * n), "n = {n}");
            assert_eq!(o, nested_dissection(&p, &x).unwrap());
            let (f, i) = expand_to_scalars(&o);
            assert!(is_permutation(&f, 3 * n * n));
            assert!(f.iter().enumerate().all(|(k, &j)| i[j] == k));
        }
        assert!(!is_permutation(&[0, 0], 2));
        assert!(!is_permutation(&[0, 2], 2));
        let (p, x) = grid(3);
        assert_eq!(
            nested_dissection(&p, &x[..4]),
            Err(SoftError::LengthMismatch)
        );
    }

    #[test]
    fn top_separator_splits_the_grid() {
        // The last points eliminated form one grid line (a 40-point separator): removing
        // them leaves no edge between the two halves ordered before them.
        let n = 40;
        let (p, x) = grid(n);
        let o = nested_dissection(&p, &x).unwrap();
        let mut pos = vec![0; n * n];
        for (k, &v) in o.iter().enumerate() {
            pos[v] = k;
        }
        // Split at the median (800 points); the separator is the left boundary.
        let sep = n;
        let half = n * n / 2 - sep;
        for v in 0..n * n {
            for &w in p.row(v).0 {
                let (a, b) = (pos[v], pos[w as usize]);
                if a < n * n - sep && b < n * n - sep {
                    assert_eq!(a < half, b < half, "edge {v}-{w} crosses the separator");
                }
            }
        }
    }

    #[test]
    fn degenerate_positions_still_give_a_permutation() {
        let (p, _) = grid(12);
        let x = vec![DVec3::ZERO; 144];
        assert!(is_permutation(&nested_dissection(&p, &x).unwrap(), 144));
        let mut y = vec![DVec3::ONE; 144];
        y[5] = DVec3::splat(f64::NAN);
        assert!(is_permutation(&nested_dissection(&p, &y).unwrap(), 144));
    }
}
