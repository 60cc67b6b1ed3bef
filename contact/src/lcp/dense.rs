//! Dense LU with partial pivoting, shared by Lemke's warm start and the Newton step.

use alloc::vec::Vec;

/// `max_i |a_i|` over the non-NaN entries (0 if none): the value of the serial fold
/// `m = max(m, |a_i|)` from `m = 0` (a maximum does not depend on the order, and
/// `f64::max` passes NaN over in any order), with four independent accumulators so
/// that the pass is not one chain of dependent `max` latencies.
fn max_abs(a: &[f64]) -> f64 {
    let mut m = [0.0_f64; 4];
    let mut chunks = a.chunks_exact(4);
    for c in &mut chunks {
        for (m, &x) in m.iter_mut().zip(c) {
            *m = m.max(libm::fabs(x));
        }
    }
    for &x in chunks.remainder() {
        m[0] = m[0].max(libm::fabs(x));
    }
    m[0].max(m[1]).max(m[2].max(m[3]))
}

/// `P A = L U` of a row-major `n × n` matrix, stored in place.
pub(crate) struct Lu {
    n: usize,
    a: Vec<f64>,
    perm: Vec<usize>,
}

impl Lu {
    /// Factors `a`; `None` when a pivot is below `1e-13 · max|a_ij|` (numerically singular).
    ///
    /// Row-by-row elimination `a_ij ← a_ij − f a_kj` (`f = a_ik / a_kk`, `j > k`) over
    /// each row's profile only: `hi[r]`, the last column of row `r` that may not be
    /// `+0`, is kept through the swaps and the updates (an update of row `i` by row `k`
    /// runs to `max(hi[i], hi[k])` and leaves that as `hi[i]`). Past both profiles the
    /// update is `+0 − f·(+0) = +0` for finite `f`, so skipping it changes no bit; a
    /// non-finite `f` runs the whole row as before. A Newton matrix of contacts is
    /// banded (a contact couples with those of its two bodies; on the ten-box stack's
    /// 40 × 40 one-sided block `hi[k] ≈ k + 8`, where the whole factor was 6.5 % of the
    /// step's `perf` samples).
    pub(crate) fn factor(mut a: Vec<f64>, n: usize) -> Option<Lu> {
        debug_assert_eq!(a.len(), n * n);
        let amax = max_abs(&a);
        if !(amax > 0.0) && n > 0 {
            return None;
        }
        let tiny = 1e-13 * amax;
        let mut perm: Vec<usize> = (0..n).collect();
        // Each row's profile `(hi[r], lo[r])`, in one allocation:
        // hi[r]: every a[r][j] with j > hi[r] is +0 (bit pattern 0); `None` if all are.
        // lo[r]: every a[r][j] with j < lo[r] is +0 (n if all are). A row is updated
        // only at a column k ≥ lo[r] (its multiplier a_rk ≠ 0) and only to the right of
        // k, so while k < lo[r] its entry a_rk is still +0: the pivot search passes it
        // (|+0| > best never holds) and its multiplier is +0 / a_kk, a zero of the
        // pivot's sign, stored without the division.
        let mut profile: Vec<(Option<usize>, usize)> = (0..n)
            .map(|r| {
                let row = &a[r * n..(r + 1) * n];
                (
                    row.iter().rposition(|x| x.to_bits() != 0),
                    row.iter().position(|x| x.to_bits() != 0).unwrap_or(n),
                )
            })
            .collect();
        for k in 0..n {
            let mut p = k;
            let mut best = libm::fabs(a[k * n + k]);
            for i in k + 1..n {
                if profile[i].1 > k {
                    continue;
                }
                let v = libm::fabs(a[i * n + k]);
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best > tiny) {
                return None;
            }
            if p != k {
                // p > k: row k lies in the first part.
                let (top, bottom) = a.split_at_mut(p * n);
                top[k * n..(k + 1) * n].swap_with_slice(&mut bottom[..n]);
                perm.swap(k, p);
                profile.swap(k, p);
            }
            let piv = a[k * n + k];
            let hk = profile[k].0;
            let zero = 0.0 / piv;
            // Row k above the rows it updates: borrowed apart, so that the update of
            // a row is one pass over two disjoint slices (each entry one `a − f·b`, in
            // any order the same bits; the compiler then pairs them in vector lanes).
            let (top, below) = a.split_at_mut((k + 1) * n);
            let row_k = &top[k * n..];
            for (r, row) in below.chunks_exact_mut(n).enumerate() {
                let i = k + 1 + r;
                if profile[i].1 > k {
                    row[k] = zero;
                    continue;
                }
                let f = row[k] / piv;
                row[k] = f;
                if f != 0.0 {
                    let upper = if f.is_finite() {
                        hk.max(profile[i].0).unwrap_or(0)
                    } else {
                        n - 1
                    };
                    if upper > k {
                        let span = k + 1..upper + 1;
                        for (x, &y) in row[span.clone()].iter_mut().zip(&row_k[span]) {
                            *x -= f * y;
                        }
                    }
                    profile[i].0 = profile[i].0.max(Some(upper));
                }
            }
        }
        Some(Lu { n, a, perm })
    }

    /// The factor's storage back (its values are the factors, not `A`), for the next
    /// matrix of the same size to reuse.
    pub(crate) fn into_matrix(self) -> Vec<f64> {
        self.a
    }

    /// Solves `A x = b`, returning `x`.
    pub(crate) fn solve(&self, b: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut x: Vec<f64> = self.perm.iter().map(|&p| b[p]).collect();
        for i in 0..n {
            let mut s = x[i];
            for j in 0..i {
                s -= self.a[i * n + j] * x[j];
            }
            x[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = x[i];
            for j in i + 1..n {
                s -= self.a[i * n + j] * x[j];
            }
            x[i] = s / self.a[i * n + i];
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec;

    /// The elimination over every column (before the row profiles).
    fn reference(mut a: Vec<f64>, n: usize) -> Option<(Vec<f64>, Vec<usize>)> {
        let amax = a.iter().fold(0.0_f64, |m, &x| m.max(libm::fabs(x)));
        if !(amax > 0.0) && n > 0 {
            return None;
        }
        let tiny = 1e-13 * amax;
        let mut perm: Vec<usize> = (0..n).collect();
        for k in 0..n {
            let mut p = k;
            let mut best = libm::fabs(a[k * n + k]);
            for i in k + 1..n {
                let v = libm::fabs(a[i * n + k]);
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best > tiny) {
                return None;
            }
            if p != k {
                // p > k: row k lies in the first part.
                let (top, bottom) = a.split_at_mut(p * n);
                top[k * n..(k + 1) * n].swap_with_slice(&mut bottom[..n]);
                perm.swap(k, p);
            }
            let piv = a[k * n + k];
            for i in k + 1..n {
                let f = a[i * n + k] / piv;
                a[i * n + k] = f;
                if f != 0.0 {
                    for j in k + 1..n {
                        a[i * n + j] -= f * a[k * n + j];
                    }
                }
            }
        }
        Some((a, perm))
    }

    /// The profile-limited factor has the full elimination's bits (factor, pivots and
    /// solution), on banded matrices whose pivoting swaps rows (small diagonals), with
    /// signed zeros inside the band and negative pivots.
    #[test]
    fn profile_factor_equals_full_elimination_bit_for_bit() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut swapped = 0;
        for case in 0..200 {
            let n = 5 + case % 23;
            let band = 1 + case % 5;
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                for j in i.saturating_sub(band)..(i + band + 1).min(n) {
                    let v = next();
                    a[i * n + j] = match case % 4 {
                        // Small diagonal: the pivot search swaps rows.
                        0 if i == j => 1e-3 * v,
                        1 if (i + j) % 5 == 0 => -0.0,
                        _ => v,
                    };
                }
            }
            let b: Vec<f64> = (0..n).map(|_| next()).collect();
            let full = reference(a.clone(), n);
            let fast = Lu::factor(a, n);
            match (full, fast) {
                (None, None) => {}
                (Some((fa, fp)), Some(lu)) => {
                    swapped += usize::from(fp.iter().enumerate().any(|(i, &p)| i != p));
                    assert_eq!(fp, lu.perm, "case {case}");
                    assert!(fa
                        .iter()
                        .zip(&lu.a)
                        .all(|(x, y)| x.to_bits() == y.to_bits()));
                    let reference = Lu { n, a: fa, perm: fp };
                    let (x, y) = (reference.solve(&b), lu.solve(&b));
                    assert!(x.iter().zip(&y).all(|(x, y)| x.to_bits() == y.to_bits()));
                }
                _ => panic!("case {case}: one factor failed"),
            }
        }
        // Pivoting happened (measured: in all 200 cases); tolerance a tenth.
        println!("{swapped} of 200 cases swapped rows");
        assert!(swapped >= 20, "{swapped} cases swapped rows");
    }
}
