//! Small 3-D helpers on plain arrays, written to match MuJoCo's own formulas
//! (`engine_util_spatial.c`, `user_util.cc`) operation for operation.
//!
//! Quaternions are `[w, x, y, z]`; matrices are row-major `[[f64; 3]; 3]`.

/// A 3-vector.
pub type V3 = [f64; 3];
/// A quaternion `[w, x, y, z]`.
pub type Q = [f64; 4];
/// A row-major 3×3 matrix.
pub type M3 = [[f64; 3]; 3];

/// MuJoCo's `mjEPS` (user side): smallest norm of an axis, smallest geom mass counted.
pub const EPS: f64 = 1e-14;
/// MuJoCo's `mjMINVAL`: smallest mass or principal inertia of a moving body.
pub const MINVAL: f64 = 1e-15;

/// Identity rotation.
pub const QUAT_ID: Q = [1.0, 0.0, 0.0, 0.0];

pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// Normalise in place like `mjuu_normvec`: returns the old norm; leaves the vector
/// unchanged when the norm is below [`EPS`].
pub fn normalize3(a: &mut V3) -> f64 {
    let n = norm(*a);
    if n >= EPS {
        *a = scale(*a, 1.0 / n);
    }
    n
}

/// Normalise a quaternion like `mju_normalize4`: a (near) zero quaternion becomes the
/// identity.
pub fn normalize4(q: Q) -> Q {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n < MINVAL {
        QUAT_ID
    } else {
        [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
    }
}

/// Hamilton product `a * b` (apply `b`, then `a`).
pub fn mul_quat(a: Q, b: Q) -> Q {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// Conjugate (inverse of a unit quaternion).
pub fn conj(q: Q) -> Q {
    [q[0], -q[1], -q[2], -q[3]]
}

/// Rotation matrix of a unit quaternion (`mju_quat2Mat`).
pub fn quat_to_mat(q: Q) -> M3 {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    let (ww, xx, yy, zz) = (w * w, x * x, y * y, z * z);
    let (xy, xz, yz, wx, wy, wz) = (x * y, x * z, y * z, w * x, w * y, w * z);
    [
        [ww + xx - yy - zz, 2.0 * (xy - wz), 2.0 * (xz + wy)],
        [2.0 * (xy + wz), ww - xx + yy - zz, 2.0 * (yz - wx)],
        [2.0 * (xz - wy), 2.0 * (yz + wx), ww - xx - yy + zz],
    ]
}

/// `m v`.
pub fn mat_vec(m: &M3, v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// Rotate `v` by the unit quaternion `q`.
pub fn rotate(q: Q, v: V3) -> V3 {
    mat_vec(&quat_to_mat(q), v)
}

/// Quaternion of a rotation by `angle` about the unit `axis`.
pub fn axis_angle(axis: V3, angle: f64) -> Q {
    let (s, c) = (angle / 2.0).sin_cos();
    [c, s * axis[0], s * axis[1], s * axis[2]]
}

/// `mjuu_z2quat`: the rotation that takes `(0, 0, 1)` onto the direction of `vec`.
pub fn z_to_quat(vec: V3) -> Q {
    let mut a = cross([0.0, 0.0, 1.0], vec);
    let s = normalize3(&mut a);
    if s < 1e-10 {
        a = [1.0, 0.0, 0.0];
    }
    let ang = s.atan2(vec[2]);
    let (sn, cs) = (ang / 2.0).sin_cos();
    [cs, a[0] * sn, a[1] * sn, a[2] * sn]
}

/// `mjuu_frame2quat`: quaternion of the rotation whose matrix columns are `x, y, z`.
pub fn frame_to_quat(x: V3, y: V3, z: V3) -> Q {
    let mat = [x, y, z]; // mat[c][r]
    let q = if mat[0][0] + mat[1][1] + mat[2][2] > 0.0 {
        let w = 0.5 * (1.0 + mat[0][0] + mat[1][1] + mat[2][2]).sqrt();
        [
            w,
            0.25 * (mat[1][2] - mat[2][1]) / w,
            0.25 * (mat[2][0] - mat[0][2]) / w,
            0.25 * (mat[0][1] - mat[1][0]) / w,
        ]
    } else if mat[0][0] > mat[1][1] && mat[0][0] > mat[2][2] {
        let x1 = 0.5 * (1.0 + mat[0][0] - mat[1][1] - mat[2][2]).sqrt();
        [
            0.25 * (mat[1][2] - mat[2][1]) / x1,
            x1,
            0.25 * (mat[1][0] + mat[0][1]) / x1,
            0.25 * (mat[2][0] + mat[0][2]) / x1,
        ]
    } else if mat[1][1] > mat[2][2] {
        let y1 = 0.5 * (1.0 - mat[0][0] + mat[1][1] - mat[2][2]).sqrt();
        [
            0.25 * (mat[2][0] - mat[0][2]) / y1,
            0.25 * (mat[1][0] + mat[0][1]) / y1,
            y1,
            0.25 * (mat[2][1] + mat[1][2]) / y1,
        ]
    } else {
        let z1 = 0.5 * (1.0 - mat[0][0] - mat[1][1] + mat[2][2]).sqrt();
        [
            0.25 * (mat[0][1] - mat[1][0]) / z1,
            0.25 * (mat[2][0] + mat[0][2]) / z1,
            0.25 * (mat[2][1] + mat[1][2]) / z1,
            z1,
        ]
    };
    normalize4(q)
}

/// `a b` for 3×3 matrices.
pub fn mat_mul(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    c
}

/// `mᵀ`.
pub fn transpose(m: &M3) -> M3 {
    [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]
}

/// `R diag(d) Rᵀ` with `R` the rotation of `q`: a principal inertia expressed in the
/// parent frame.
pub fn rotate_diag(q: Q, d: V3) -> M3 {
    let r = quat_to_mat(q);
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] =
                r[i][0] * d[0] * r[j][0] + r[i][1] * d[1] * r[j][1] + r[i][2] * d[2] * r[j][2];
        }
    }
    out
}

/// Eigenvalues of a symmetric 3×3 matrix, descending (cyclic Jacobi; exact enough for
/// the physical-validity checks it serves).
pub fn sym_eigenvalues(m: &M3) -> V3 {
    let (mut e, _) = sym_eigen(m);
    e.sort_by(|x, y| y.total_cmp(x));
    e
}

/// Eigenvalues (any order) and eigenvectors (the columns of the returned matrix) of a
/// symmetric 3×3 matrix, by cyclic Jacobi.
pub fn sym_eigen(m: &M3) -> (V3, M3) {
    let mut a = *m;
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if !(off > 1e-40 * diag) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            let mut j = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            j[p][p] = c;
            j[q][q] = c;
            j[p][q] = s;
            j[q][p] = -s;
            a = mat_mul(&transpose(&j), &mat_mul(&a, &j));
            v = mat_mul(&v, &j);
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

/// `V diag(e) Vᵀ`.
pub fn from_eigen(e: V3, v: &M3) -> M3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = v[i][0] * e[0] * v[j][0] + v[i][1] * e[1] * v[j][1] + v[i][2] * e[2] * v[j][2];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_of_a_rotated_diagonal() {
        let q = normalize4([0.9, 0.3, -0.2, 0.4]);
        let m = rotate_diag(q, [3.0, 1.0, 2.0]);
        let e = sym_eigenvalues(&m);
        for (got, want) in e.iter().zip([3.0, 2.0, 1.0]) {
            assert!((got - want).abs() < 1e-12, "{e:?}");
        }
    }

    #[test]
    fn z_to_quat_maps_z_onto_the_direction() {
        for v in [
            [1.0, 2.0, 3.0],
            [0.0, 0.0, -2.0],
            [0.0, 0.0, 5.0],
            [-1.0, 0.0, 0.0],
        ] {
            let q = z_to_quat(v);
            let z = rotate(q, [0.0, 0.0, 1.0]);
            let n = norm(v);
            for k in 0..3 {
                assert!((z[k] - v[k] / n).abs() < 1e-12, "{v:?} -> {z:?}");
            }
        }
    }

    #[test]
    fn frame_to_quat_inverts_quat_to_mat() {
        for q in [
            [0.9, 0.3, -0.2, 0.4],
            [0.1, 0.9, 0.3, -0.2],
            [0.0, 0.1, 0.2, 0.9],
        ] {
            let q = normalize4(q);
            let m = quat_to_mat(q);
            let cols = transpose(&m);
            let p = frame_to_quat(cols[0], cols[1], cols[2]);
            let s = if p[0] * q[0] + p[1] * q[1] + p[2] * q[2] + p[3] * q[3] < 0.0 {
                -1.0
            } else {
                1.0
            };
            for k in 0..4 {
                assert!((p[k] * s - q[k]).abs() < 1e-12, "{q:?} -> {p:?}");
            }
        }
    }
}
