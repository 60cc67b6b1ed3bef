//! The products `S_ab = Σ u_a s_b` of the Schur rows' Gram matrix
//! ([`super::World::schur_columns`]), one row `b` against one or four rows `a` on
//! one path at a time.
//!
//! Every sum is added one product after another in index order, from the value
//! passed in, whatever the number of rows: the same operations on the same bits as
//! one row at a time (no reassociation, no fused multiply-add). Against several rows
//! `s_b` is loaded once per index and the sums sit side by side in vector lanes
//! (the multiplies and adds of two rows in one instruction each, each lane's sum
//! still sequential): dm_control's humanoid, 2 s passive, 3.6M products in 90K
//! pairs, 17 instructions per four products one row at a time.

/// `v + Σ a_i b_i` (`a`, `b` of one length), the products added one after another
/// in `i` order (four to a loop turn: the same sums, fewer loop instructions).
#[inline(always)]
pub(super) fn dot_on(mut v: f64, a: &[f64], b: &[f64]) -> f64 {
    let (mut ca, mut cb) = (a.chunks_exact(4), b.chunks_exact(4));
    for (x, y) in (&mut ca).zip(&mut cb) {
        v += x[0] * y[0];
        v += x[1] * y[1];
        v += x[2] * y[2];
        v += x[3] * y[3];
    }
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        v += x * y;
    }
    v
}

/// [`dot_on`] of four rows against one: `v_t + Σ_i a_t[i] b_i` for `t = 0..4` (each
/// `a_t` at least as long as `b`). Not inlined, so that its loop is compiled as here
/// alone (inlined into the Gram loop, the lanes were not formed: 16 instructions per
/// four products, 12 alone).
#[inline(never)]
pub(super) fn dot4_on(v: [f64; 4], a: [&[f64]; 4], b: &[f64]) -> [f64; 4] {
    let n = b.len();
    let (a0, a1, a2, a3) = (&a[0][..n], &a[1][..n], &a[2][..n], &a[3][..n]);
    let [mut x0, mut x1, mut x2, mut x3] = v;
    for i in 0..n {
        let s = b[i];
        x0 += a0[i] * s;
        x1 += a1[i] * s;
        x2 += a2[i] * s;
        x3 += a3[i] * s;
    }
    [x0, x1, x2, x3]
}

#[cfg(test)]
mod tests {
    use super::{dot4_on, dot_on};
    use alloc::vec::Vec;

    /// The kernels of several rows give each row's sum bit for bit as [`dot_on`] does
    /// (lengths 0 to 13, start values zero and not, cancelling terms).
    #[test]
    fn several_rows_sum_as_one_row() {
        let mut seed = 11u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((seed >> 11) as f64) / ((1u64 << 53) as f64) * 2e3 - 1e3
        };
        for n in 0..14 {
            let rows: Vec<Vec<f64>> = (0..4)
                .map(|_| (0..n + 2).map(|_| next()).collect())
                .collect();
            let b: Vec<f64> = (0..n).map(|_| next()).collect();
            let v0 = [0.0, next(), -0.0, next()];
            let one: Vec<f64> = (0..4).map(|t| dot_on(v0[t], &rows[t][..n], &b)).collect();
            let one_bits: Vec<u64> = one.iter().map(|x| x.to_bits()).collect();
            let four = dot4_on(v0, [&rows[0], &rows[1], &rows[2], &rows[3]], &b);
            assert_eq!(four.map(f64::to_bits).to_vec(), one_bits, "n {n}");
        }
    }
}
