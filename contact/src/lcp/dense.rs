//! Dense LU with partial pivoting, shared by Lemke's warm start and the Newton step.

use alloc::vec::Vec;

/// `P A = L U` of a row-major `n × n` matrix, stored in place.
pub(crate) struct Lu {
    n: usize,
    a: Vec<f64>,
    perm: Vec<usize>,
}

impl Lu {
    /// Factors `a`; `None` when a pivot is below `1e-13 · max|a_ij|` (numerically singular).
    pub(crate) fn factor(mut a: Vec<f64>, n: usize) -> Option<Lu> {
        debug_assert_eq!(a.len(), n * n);
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
                for j in 0..n {
                    a.swap(k * n + j, p * n + j);
                }
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
        Some(Lu { n, a, perm })
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
