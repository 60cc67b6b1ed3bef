//! Small dense symmetric eigen-solvers on fixed-size stack arrays, for the per-element
//! PSD projection ([`crate::project`]): a closed-form 2×2 Jacobi rotation, a Cholesky
//! positive-definiteness test, EISPACK's `tred2`/`tql2` (Householder tridiagonalisation
//! and implicit QL, Golub & Van Loan §8.3) for the general `D × D` case, and a cyclic
//! Jacobi iteration run on [`BATCH`] 4×4 matrices in lock step.

use crate::project::BATCH;

/// QL iterations per eigenvalue before giving up (two or three suffice).
const MAX_QL_ITERATIONS: usize = 60;

/// Sweeps of the batched Jacobi iteration before giving up (four or five suffice).
const MAX_SWEEPS: usize = 50;

/// Eigen-decomposition of a symmetric 2×2 matrix by one (exact) Jacobi rotation:
/// eigenvalues and eigenvectors (as columns). A positive semidefinite matrix is
/// returned as its diagonal and the identity without rotating: callers use only the
/// negative eigenpairs.
pub(crate) fn eigen2(k: &[[f64; 2]; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
    let (a, b, d) = (k[0][0], 0.5 * (k[0][1] + k[1][0]), k[1][1]);
    if b == 0.0 || (a >= 0.0 && d >= 0.0 && a * d >= b * b) {
        // Diagonal, or PSD: only the signs of the eigenvalues are used.
        return ([a, d], [[1.0, 0.0], [0.0, 1.0]]);
    }
    let theta = (d - a) / (2.0 * b);
    // tan of the rotation angle: the root of t² + 2θt − 1 = 0 of smaller magnitude.
    let t = if theta.abs() > 1e150 {
        0.5 / theta
    } else {
        let t = 1.0 / (theta.abs() + (theta * theta + 1.0).sqrt());
        if theta < 0.0 {
            -t
        } else {
            t
        }
    };
    let c = 1.0 / (t * t + 1.0).sqrt();
    let s = t * c;
    ([a - t * b, d + t * b], [[c, s], [-s, c]])
}

/// Cholesky test: `true` when every pivot of `k = L D Lᵀ` is positive.
pub(crate) fn is_positive_definite<const D: usize>(k: &[[f64; D]; D]) -> bool {
    let mut l = *k;
    for j in 0..D {
        let mut d = l[j][j];
        for p in 0..j {
            d -= l[j][p] * l[j][p];
        }
        if !(d > 0.0) {
            return false;
        }
        let s = d.sqrt();
        l[j][j] = s;
        let inv = 1.0 / s;
        for i in j + 1..D {
            let mut x = l[i][j];
            for p in 0..j {
                x -= l[i][p] * l[j][p];
            }
            l[i][j] = x * inv;
        }
    }
    true
}

/// Householder tridiagonalisation and implicit QL iteration (EISPACK `tred2`/`tql2`,
/// Bowdler, Martin, Reinsch & Wilkinson 1968, in the 0-based form of JAMA): on return
/// `d` holds the eigenvalues of the symmetric `a` (unsorted) and the columns of `v`
/// the eigenvectors. `false` if an eigenvalue needed more than [`MAX_QL_ITERATIONS`]
/// iterations (which does not happen for finite input).
pub(crate) fn sym_eigen<const D: usize>(
    a: &[[f64; D]; D],
    d: &mut [f64; D],
    v: &mut [[f64; D]; D],
) -> bool {
    let n = D;
    let mut e = [0.0f64; D];
    *v = *a;
    // tred2: Householder reduction to tridiagonal form.
    d.copy_from_slice(&v[n - 1]);
    for i in (1..n).rev() {
        let mut scale = 0.0;
        let mut h = 0.0;
        for k in 0..i {
            scale += d[k].abs();
        }
        if scale == 0.0 {
            e[i] = d[i - 1];
            for j in 0..i {
                d[j] = v[i - 1][j];
                v[i][j] = 0.0;
                v[j][i] = 0.0;
            }
        } else {
            for k in 0..i {
                d[k] /= scale;
                h += d[k] * d[k];
            }
            let mut f = d[i - 1];
            let mut g = h.sqrt();
            if f > 0.0 {
                g = -g;
            }
            e[i] = scale * g;
            h -= f * g;
            d[i - 1] = f - g;
            for ej in e.iter_mut().take(i) {
                *ej = 0.0;
            }
            for j in 0..i {
                f = d[j];
                v[j][i] = f;
                g = e[j] + v[j][j] * f;
                for k in j + 1..i {
                    g += v[k][j] * d[k];
                    e[k] += v[k][j] * f;
                }
                e[j] = g;
            }
            f = 0.0;
            for j in 0..i {
                e[j] /= h;
                f += e[j] * d[j];
            }
            let hh = f / (h + h);
            for j in 0..i {
                e[j] -= hh * d[j];
            }
            for j in 0..i {
                f = d[j];
                g = e[j];
                for k in j..i {
                    v[k][j] -= f * e[k] + g * d[k];
                }
                d[j] = v[i - 1][j];
                v[i][j] = 0.0;
            }
        }
        d[i] = h;
    }
    // Accumulate the transformations.
    for i in 0..n - 1 {
        v[n - 1][i] = v[i][i];
        v[i][i] = 1.0;
        let h = d[i + 1];
        if h != 0.0 {
            for k in 0..=i {
                d[k] = v[k][i + 1] / h;
            }
            for j in 0..=i {
                let mut g = 0.0;
                for k in 0..=i {
                    g += v[k][i + 1] * v[k][j];
                }
                for k in 0..=i {
                    v[k][j] -= g * d[k];
                }
            }
        }
        for k in 0..=i {
            v[k][i + 1] = 0.0;
        }
    }
    for j in 0..n {
        d[j] = v[n - 1][j];
        v[n - 1][j] = 0.0;
    }
    v[n - 1][n - 1] = 1.0;
    e[0] = 0.0;

    // tql2: implicit QL on the tridiagonal (d, e).
    for i in 1..n {
        e[i - 1] = e[i];
    }
    e[n - 1] = 0.0;
    let mut f = 0.0;
    let mut tst1 = 0.0f64;
    for l in 0..n {
        tst1 = tst1.max(d[l].abs() + e[l].abs());
        let mut m = l;
        while m < n - 1 && e[m].abs() > f64::EPSILON * tst1 {
            m += 1;
        }
        if m > l {
            let mut iter = 0;
            loop {
                iter += 1;
                if iter > MAX_QL_ITERATIONS {
                    return false;
                }
                // Implicit shift.
                let mut g = d[l];
                let mut p = (d[l + 1] - g) / (2.0 * e[l]);
                let mut r = (p * p + 1.0).sqrt();
                if p < 0.0 {
                    r = -r;
                }
                d[l] = e[l] / (p + r);
                d[l + 1] = e[l] * (p + r);
                let dl1 = d[l + 1];
                let mut h = g - d[l];
                for di in d.iter_mut().skip(l + 2) {
                    *di -= h;
                }
                f += h;
                // Implicit QL transformation.
                p = d[m];
                let mut c = 1.0;
                let mut c2 = c;
                let mut c3 = c;
                let el1 = e[l + 1];
                let mut s = 0.0;
                let mut s2 = 0.0;
                for i in (l..m).rev() {
                    c3 = c2;
                    c2 = c;
                    s2 = s;
                    g = c * e[i];
                    h = c * p;
                    r = (p * p + e[i] * e[i]).sqrt();
                    e[i + 1] = s * r;
                    s = e[i] / r;
                    c = p / r;
                    p = c * d[i] - s * g;
                    d[i + 1] = h + s * (c * g + s * d[i]);
                    for row in v.iter_mut() {
                        let vh = row[i + 1];
                        row[i + 1] = s * row[i] + c * vh;
                        row[i] = c * row[i] - s * vh;
                    }
                }
                p = -s * s2 * c3 * el1 * e[l] / dl1;
                e[l] = s * p;
                d[l] = c * p;
                if !(e[l].abs() > f64::EPSILON * tst1) {
                    break;
                }
            }
        }
        d[l] += f;
        e[l] = 0.0;
    }
    true
}

/// Cyclic Jacobi eigen-decomposition of [`BATCH`] symmetric 4×4 matrices at once
/// (lane `l` of every entry belongs to matrix `l`): on return the diagonal of `a`
/// holds the eigenvalues and the columns of `v` the eigenvectors. Each lane stops
/// rotating (exact identity rotations) once its off-diagonal part is below round-off
/// of its norm, so every lane's result is independent of the others. The flag is
/// `false` for a lane that did not converge within [`MAX_SWEEPS`] sweeps.
pub(crate) fn jacobi4_lanes(a: &mut [[Lanes; 4]; 4], v: &mut [[Lanes; 4]; 4]) -> [bool; BATCH] {
    for (p, row) in v.iter_mut().enumerate() {
        for (q, x) in row.iter_mut().enumerate() {
            *x = [if p == q { 1.0 } else { 0.0 }; BATCH];
        }
    }
    let mut tol = [0.0; BATCH];
    for (l, t) in tol.iter_mut().enumerate() {
        let frob: f64 = a.iter().flatten().map(|x| x[l] * x[l]).sum();
        *t = frob * (f64::EPSILON * f64::EPSILON);
    }
    let mut done = [false; BATCH];
    for _ in 0..MAX_SWEEPS {
        for l in 0..BATCH {
            let mut off = 0.0;
            for p in 0..4 {
                for q in p + 1..4 {
                    off += a[p][q][l] * a[p][q][l];
                }
            }
            done[l] = 2.0 * off <= tol[l];
        }
        if done.iter().all(|&d| d) {
            break;
        }
        // Each round of two rotations on disjoint pairs can run in parallel.
        rotate_lanes::<0, 1, 2, 3>(a, v, &done);
        rotate_lanes::<2, 3, 0, 1>(a, v, &done);
        rotate_lanes::<0, 2, 1, 3>(a, v, &done);
        rotate_lanes::<1, 3, 0, 2>(a, v, &done);
        rotate_lanes::<0, 3, 1, 2>(a, v, &done);
        rotate_lanes::<1, 2, 0, 3>(a, v, &done);
    }
    done
}

/// One lane of every 4×4 entry.
pub(crate) type Lanes = [f64; BATCH];

/// The Jacobi rotation zeroing `(P, Q)` in every lane not `done`; `R1`, `R2` are the
/// other two indices.
#[inline(always)]
fn rotate_lanes<const P: usize, const Q: usize, const R1: usize, const R2: usize>(
    a: &mut [[Lanes; 4]; 4],
    v: &mut [[Lanes; 4]; 4],
    done: &[bool; BATCH],
) {
    let mut c = [1.0; BATCH];
    let mut s = [0.0; BATCH];
    let mut t = [0.0; BATCH];
    for l in 0..BATCH {
        let apq = a[P][Q][l];
        let theta = (a[Q][Q][l] - a[P][P][l]) / (2.0 * apq);
        // tan of the rotation angle: the root of t² + 2θt − 1 = 0 of smaller magnitude
        // (1/(2θ) for huge θ, where θ² overflows); 0 (no rotation) for a finished lane.
        let tl = 1.0 / (theta.abs() + (theta * theta + 1.0).sqrt());
        let tl = if theta < 0.0 { -tl } else { tl };
        let tl = if theta.abs() > 1e150 { 0.5 / theta } else { tl };
        let tl = if done[l] || apq == 0.0 { 0.0 } else { tl };
        t[l] = tl;
        c[l] = 1.0 / (tl * tl + 1.0).sqrt();
        s[l] = tl * c[l];
    }
    for l in 0..BATCH {
        let apq = a[P][Q][l];
        a[P][P][l] -= t[l] * apq;
        a[Q][Q][l] += t[l] * apq;
        let z = if t[l] == 0.0 { apq } else { 0.0 };
        a[P][Q][l] = z;
        a[Q][P][l] = z;
    }
    for r in [R1, R2] {
        for l in 0..BATCH {
            let (arp, arq) = (a[r][P][l], a[r][Q][l]);
            let np = c[l] * arp - s[l] * arq;
            let nq = s[l] * arp + c[l] * arq;
            a[r][P][l] = np;
            a[P][r][l] = np;
            a[r][Q][l] = nq;
            a[Q][r][l] = nq;
        }
    }
    for row in v.iter_mut() {
        for l in 0..BATCH {
            let (vp, vq) = (row[P][l], row[Q][l]);
            row[P][l] = c[l] * vp - s[l] * vq;
            row[Q][l] = s[l] * vp + c[l] * vq;
        }
    }
}
