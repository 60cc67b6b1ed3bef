//! Projection of small symmetric block matrices onto the positive semidefinite cone.
//!
//! [`project_psd`] replaces `H = Q Λ Qᵀ` by `Q max(Λ, 0) Qᵀ` (Teran, Sifakis, Irving &
//! Fedkiw 2005, "Robust quasistatic finite elements and flesh simulation"), computed as
//! `H − Σ_{λ<0} λ q qᵀ`: the positive part is kept as it is, and PSD input comes back
//! bit for bit. Everything is on the stack (stencils of up to four points, 12×12);
//! nothing allocates.
//!
//! The result is always the projection of the full `3N × 3N` matrix, up to round-off
//! (verified against a dense eigen-decomposition in the tests); the following only
//! make it cheaper.
//!
//! * **Translation-invariant elements are projected in `3(N−1)` dimensions.** Every
//!   internal constraint (spring, area, volume, dihedral) depends only on differences
//!   of positions, so its Hessian annihilates rigid translations: each block row sums
//!   to zero. Then `H = W K Wᵀ` with `W = U ⊗ I₃`, `U` the `N × (N−1)` orthonormal
//!   Helmert basis of the complement of `(1, …, 1)`, and `K = Wᵀ H W`. Since `W` has
//!   orthonormal columns, the nonzero eigenpairs of `H` are `(λ, W q)` for the
//!   eigenpairs `(λ, q)` of `K`, so `proj(H) = H − Σ_{λ<0} λ (W q)(W q)ᵀ` is *exactly*
//!   the projection of `H`, from a 3×3 (spring), 6×6 (area) or 9×9 (volume, dihedral)
//!   eigenproblem instead of a 6×6, 9×9 or 12×12 one. This is deliberately not the
//!   edge-space shortcut `Pᵀ proj(H_e) P` (project the block `H_e = H[1..N][1..N]` of
//!   the edges `e_i = x_i − x_0` and lift with
//!   [`lift_edge_hessian`](constraint_core::math::lift_edge_hessian)): that is PSD and
//!   as cheap, and equal to `proj(H)` when `H` is already PSD, but a different
//!   approximation when `H` is indefinite, because the lift `P` is not orthogonal. The
//!   orthonormal basis gives the true projection at the same price. Invariance is
//!   detected numerically — every block row sum at most `10⁻¹⁴` times the largest
//!   entry, so the part left unprojected is below round-off — and anything else (a
//!   point-on-plane constraint) is projected in full.
//! * **Rotation-invariant two- and three-point elements split further**
//!   ([`project_psd_at`], which knows the points). A function of two points that is
//!   also invariant under rotations depends on `|e|²` only, one of three points on the
//!   Gram matrix of its two edges only; its Hessian then has no coupling between
//!   displacements along the line (in the plane) of the points and displacements
//!   across it, since the latter change the invariants only at second order. In a
//!   frame adapted to the points the reduced `K` is block diagonal, 1 + 2 (spring) or
//!   4 + 2 (triangle) instead of 3 or 6, and the blocks are projected separately: the
//!   same eigenpairs at a fraction of the cost (the 1×1 and 2×2 ones in closed form).
//!   The split is taken only when the measured coupling is below `10⁻¹⁴` of the largest
//!   entry of `K`, so its exactness never rests on the constraint's symmetry; anything
//!   else takes the general path.
//! * **Positive definite input is returned unchanged** after a Cholesky test
//!   (`≈ D³/6` flops), skipping the eigen-decomposition altogether.
//! * **Eigen-decompositions**: the 4×4 in-plane blocks of triangles go through a
//!   cyclic Jacobi iteration run on [`BATCH`] elements at once, lane by lane
//!   ([`project_psd_at_many`]; each lane's arithmetic is exactly that of a lone run, so
//!   batching changes no bit); the general `D × D` path uses EISPACK's `tred2`/`tql2`
//!   (Householder tridiagonalisation and implicit QL).
//!
//! A constraint whose curvature weights are all zero needs no projection at all (its
//! Hessian is the Gram matrix `k ∇C∇Cᵀ`); [`crate::energy`] skips the call then.

use crate::eigen::{eigen2, is_positive_definite, jacobi4_lanes, sym_eigen};
use constraint_core::{DMat3, DVec3};

/// Relative size of a block row sum below which a stencil counts as translation
/// invariant.
const TRANSLATION_TOL: f64 = 1e-14;

/// Relative size of the along/across coupling below which a two- or three-point element
/// is split (see the module documentation).
const SPLIT_TOL: f64 = 1e-14;

/// Number of elements [`project_psd_at_many`] diagonalises together: their 4×4
/// in-plane blocks go through one Jacobi iteration in lock step, which keeps the
/// floating-point units busy where a single iteration would wait on each rotation.
pub const BATCH: usize = 4;

/// Replaces the symmetric `3N × 3N` block matrix `h` (N ≤ 4) by its projection onto the
/// positive semidefinite cone (see the module documentation). Non-finite input is left
/// unchanged (the stepping watchdog reports it), as is any `N > 4`.
pub fn project_psd<const N: usize>(h: &mut [[DMat3; N]; N]) {
    // Without positions nothing is split, so nothing is left over; finish regardless.
    if let Prepared::Plane(job) = prepare(h, None) {
        let mut jobs = [None; BATCH];
        jobs[0] = Some(job);
        finish_plane_jobs(core::slice::from_mut(h), &jobs);
    }
}

/// [`project_psd`] for the Hessian of a constraint on the points `x`: the same result,
/// cheaper for rotation-invariant two- and three-point constraints (the points give the
/// frame in which their Hessian splits).
pub fn project_psd_at<const N: usize>(h: &mut [[DMat3; N]; N], x: &[DVec3; N]) {
    project_psd_at_many(core::slice::from_mut(h), core::slice::from_ref(x));
}

/// [`project_psd_at`] for many elements (`h[e]` on the points `x[e]`; extra entries of
/// the longer slice are ignored). Bit for bit the same as one call per element — the
/// batched iteration keeps each element's arithmetic separate — only faster.
pub fn project_psd_at_many<const N: usize>(h: &mut [[[DMat3; N]; N]], x: &[[DVec3; N]]) {
    for (hc, xc) in h.chunks_mut(BATCH).zip(x.chunks(BATCH)) {
        project_batch(hc, xc, &[true; BATCH]);
    }
}

/// Projects the elements `h[l]` (on the points `x[l]`) with `selected[l]`, for up to
/// [`BATCH`] elements.
pub(crate) fn project_batch<const N: usize>(
    h: &mut [[[DMat3; N]; N]],
    x: &[[DVec3; N]],
    selected: &[bool; BATCH],
) {
    let mut jobs: [Option<PlaneJob>; BATCH] = [None; BATCH];
    let mut any = false;
    for (((he, xe), job), &sel) in h.iter_mut().zip(x).zip(jobs.iter_mut()).zip(selected) {
        if sel {
            if let Prepared::Plane(j) = prepare(he, Some(xe)) {
                *job = Some(j);
                any = true;
            }
        }
    }
    if any {
        finish_plane_jobs(h, &jobs);
    }
}

/// What [`prepare`] left to do.
// Lives on the stack for one call; boxing the job would allocate per element.
#[allow(clippy::large_enum_variant)]
enum Prepared {
    /// `h` is projected.
    Done,
    /// `h` still needs the negative part of the in-plane block of a three-point element.
    Plane(PlaneJob),
}

/// The in-plane block of a split three-point element, awaiting its eigen-decomposition.
#[derive(Clone, Copy)]
struct PlaneJob {
    /// In-plane block, scaled by `1/scale`, index `2a + component`.
    kin: [[f64; 4]; 4],
    /// Frame-to-world rotation.
    rt: DMat3,
    scale: f64,
}

/// Projects `h`, except for the in-plane eigenproblem of a split three-point element,
/// which is returned.
fn prepare<const N: usize>(h: &mut [[DMat3; N]; N], x: Option<&[DVec3; N]>) -> Prepared {
    let mut finite = true;
    let mut scale = 0.0f64;
    for b in h.iter().flatten() {
        finite &= b.is_finite();
        scale = scale.max(max_abs(b));
    }
    if !finite || scale == 0.0 {
        return Prepared::Done;
    }
    let reduced = N >= 2 && rows_sum_to_zero(h, scale);
    if reduced {
        if let Some(x) = x {
            match project_split(h, x) {
                Split::NotApplicable => {}
                Split::Done => return Prepared::Done,
                Split::Plane(job) => return Prepared::Plane(job),
            }
        }
    }
    match (N, reduced) {
        (1, _) | (2, true) => project_dim::<N, 3>(h, reduced),
        (2, false) | (3, true) => project_dim::<N, 6>(h, reduced),
        (3, false) | (4, true) => project_dim::<N, 9>(h, reduced),
        (4, false) => project_dim::<N, 12>(h, reduced),
        _ => {}
    }
    Prepared::Done
}

/// Diagonalises the in-plane blocks of `jobs` together and subtracts their negative
/// parts from the matching `h`.
fn finish_plane_jobs<const N: usize>(h: &mut [[[DMat3; N]; N]], jobs: &[Option<PlaneJob>; BATCH]) {
    let mut a = [[[0.0f64; BATCH]; 4]; 4];
    for (l, job) in jobs.iter().enumerate() {
        if let Some(job) = job {
            for p in 0..4 {
                for q in 0..4 {
                    a[p][q][l] = job.kin[p][q];
                }
            }
        }
    }
    let mut v = [[[0.0f64; BATCH]; 4]; 4];
    let converged = jacobi4_lanes(&mut a, &mut v);
    for (l, (he, job)) in h.iter_mut().zip(jobs).enumerate() {
        let Some(job) = job else { continue };
        if !converged[l] {
            // Cannot happen for finite input: fall back to the zero matrix, which is
            // PSD; the Gauss–Newton part is added by the caller.
            for b in he.iter_mut().flatten() {
                *b = DMat3::ZERO;
            }
            continue;
        }
        for e in 0..4 {
            let lam = a[e][e][l];
            if lam < 0.0 {
                let f = [
                    DVec3::new(v[0][e][l], v[1][e][l], 0.0),
                    DVec3::new(v[2][e][l], v[3][e][l], 0.0),
                ];
                subtract_mode(he, lam * job.scale, &job.rt, f);
            }
        }
    }
}

/// `true` when every block row sum of `h` is at most [`TRANSLATION_TOL`]` · scale`.
#[inline]
fn rows_sum_to_zero<const N: usize>(h: &[[DMat3; N]; N], scale: f64) -> bool {
    h.iter()
        .all(|row| max_abs(&row.iter().copied().sum::<DMat3>()) <= TRANSLATION_TOL * scale)
}

/// Largest absolute entry.
#[inline]
fn max_abs(m: &DMat3) -> f64 {
    let a = m.abs();
    a.x_axis.max(a.y_axis).max(a.z_axis).max_element()
}

/// `true` when every block row of `h` sums to (numerically) zero, i.e. `h` annihilates
/// rigid translations.
pub fn is_translation_invariant<const N: usize>(h: &[[DMat3; N]; N]) -> bool {
    let scale = h.iter().flatten().map(max_abs).fold(0.0, f64::max);
    rows_sum_to_zero(h, scale)
}

/// `1/√((a+1)(a+2))` for `a = 0, 1, 2`.
const HELMERT_SCALE: [f64; 3] = [
    core::f64::consts::FRAC_1_SQRT_2,
    0.408_248_290_463_863_1,
    0.288_675_134_594_812_9,
];

/// Entry `(i, a)` of the `N × (N−1)` Helmert basis (`N ≤ 4`): column `a` is
/// `(1, …, 1, −(a+1), 0, …) / √((a+1)(a+2))` with `a + 1` leading ones.
#[inline]
fn helmert(i: usize, a: usize) -> f64 {
    let s = HELMERT_SCALE[a];
    if i <= a {
        s
    } else if i == a + 1 {
        -((a + 1) as f64) * s
    } else {
        0.0
    }
}

/// Entry `(r, c)` of a block.
#[inline]
fn entry(b: &DMat3, r: usize, c: usize) -> f64 {
    b.col(c)[r]
}

/// Projects `h` through a `D`-dimensional eigenproblem: `D = 3N` (full) or
/// `D = 3(N−1)` (`reduced`, for a translation-invariant `h`).
fn project_dim<const N: usize, const D: usize>(h: &mut [[DMat3; N]; N], reduced: bool) {
    let nb = D / 3;
    // k = Wᵀ h W (reduced) or h itself, as a dense D × D array.
    let mut k = [[0.0f64; D]; D];
    if reduced {
        // t = h W: N × (N−1) blocks.
        let mut t = [[DMat3::ZERO; N]; N];
        for i in 0..N {
            for b in 0..nb {
                let mut acc = DMat3::ZERO;
                for j in 0..=(b + 1) {
                    acc += h[i][j] * helmert(j, b);
                }
                t[i][b] = acc;
            }
        }
        for a in 0..nb {
            for b in 0..nb {
                let mut acc = DMat3::ZERO;
                for i in 0..=(a + 1) {
                    acc += t[i][b] * helmert(i, a);
                }
                for r in 0..3 {
                    for c in 0..3 {
                        k[3 * a + r][3 * b + c] = entry(&acc, r, c);
                    }
                }
            }
        }
    } else {
        for (p, row) in k.iter_mut().enumerate() {
            for (q, v) in row.iter_mut().enumerate() {
                *v = entry(&h[p / 3][q / 3], p % 3, q % 3);
            }
        }
    }
    // Symmetrise against round-off and scale to unit max-norm (no overflow below,
    // whatever the stiffness).
    let mut scale = 0.0f64;
    for p in 0..D {
        for q in 0..p {
            let m = 0.5 * (k[p][q] + k[q][p]);
            k[p][q] = m;
            k[q][p] = m;
        }
        for q in 0..=p {
            scale = scale.max(k[p][q].abs());
        }
    }
    if !(scale > 0.0) {
        return;
    }
    let inv = 1.0 / scale;
    for x in k.iter_mut().flatten() {
        *x *= inv;
    }
    if is_positive_definite(&k) {
        return;
    }
    let mut v = [[0.0f64; D]; D];
    let mut lambda = [0.0f64; D];
    if !sym_eigen(&k, &mut lambda, &mut v) {
        // Did not converge (cannot happen for finite input): fall back to the zero
        // matrix, which is PSD; the Gauss–Newton part is added by the caller.
        for b in h.iter_mut().flatten() {
            *b = DMat3::ZERO;
        }
        return;
    }
    for e in 0..D {
        if !(lambda[e] < 0.0) {
            continue;
        }
        let lam = lambda[e] * scale;
        let q: [f64; D] = core::array::from_fn(|p| v[p][e]);
        // w = W q (reduced) or q, as N vectors of 3.
        let mut w = [DVec3::ZERO; N];
        for (i, wi) in w.iter_mut().enumerate() {
            if reduced {
                for a in i.saturating_sub(1)..nb {
                    *wi += DVec3::new(q[3 * a], q[3 * a + 1], q[3 * a + 2]) * helmert(i, a);
                }
            } else {
                *wi = DVec3::new(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
            }
        }
        for i in 0..N {
            let wi = w[i] * lam;
            for j in 0..N {
                let wj = w[j];
                // h_ij −= λ w_i w_jᵀ (column c of the outer product is w_i w_j[c]).
                h[i][j] -= DMat3::from_cols(wi * wj.x, wi * wj.y, wi * wj.z);
            }
        }
    }
}

/// Orthonormal frame adapted to a stencil of two or three points, as the rows of a
/// rotation: (line, across, across) for two points, (in plane, in plane, normal) for
/// three; `None` for coincident or collinear points, or any other `N`.
fn adapted_frame<const N: usize>(x: &[DVec3; N]) -> Option<DMat3> {
    let (a, b, c) = match N {
        2 => {
            let t = (x[1] - x[0]).try_normalize()?;
            // The coordinate axis least aligned with t gives the first normal.
            let abs = t.abs();
            let axis = if abs.x <= abs.y && abs.x <= abs.z {
                DVec3::X
            } else if abs.y <= abs.z {
                DVec3::Y
            } else {
                DVec3::Z
            };
            let n1 = t.cross(axis).try_normalize()?;
            (t, n1, t.cross(n1))
        }
        3 => {
            let e1 = x[1] - x[0];
            let e2 = x[2] - x[0];
            let u = e1.cross(e2);
            if !(u.length() > 1e-12 * e1.length() * e2.length()) {
                return None;
            }
            let n = u.try_normalize()?;
            let t1 = e1.try_normalize()?;
            (t1, n.cross(t1), n)
        }
        _ => return None,
    };
    Some(DMat3::from_cols(a, b, c).transpose())
}

/// Subtracts `λ p pᵀ` from `h`, where `p_i = Σ_a U_ia Rᵀ f_a` is the point-space
/// vector of the frame vectors `f` (one per Helmert vector `a`).
#[inline]
fn subtract_mode<const N: usize>(h: &mut [[DMat3; N]; N], lambda: f64, rt: &DMat3, f: [DVec3; 2]) {
    let w = [*rt * f[0], *rt * f[1]];
    let mut p = [DVec3::ZERO; N];
    for (i, pi) in p.iter_mut().enumerate() {
        for (a, wa) in w.iter().enumerate().take(N - 1) {
            if i <= a + 1 {
                *pi += *wa * helmert(i, a);
            }
        }
    }
    for i in 0..N {
        let li = p[i] * lambda;
        for j in 0..N {
            let pj = p[j];
            h[i][j] -= DMat3::from_cols(li * pj.x, li * pj.y, li * pj.z);
        }
    }
}

/// Outcome of [`project_split`].
#[allow(clippy::large_enum_variant)] // as for `Prepared`
enum Split {
    /// The element does not split; `h` is untouched.
    NotApplicable,
    /// `h` is projected.
    Done,
    /// Only the in-plane block of a three-point element remains.
    Plane(PlaneJob),
}

/// Projection of a translation-invariant two- or three-point element split into its
/// along-the-line/in-the-plane and across parts (module documentation). The across
/// part (and the whole of a two-point element) is projected here; a three-point
/// element's in-plane 4×4 block is returned unless it is positive definite.
fn project_split<const N: usize>(h: &mut [[DMat3; N]; N], x: &[DVec3; N]) -> Split {
    // Components per Helmert vector that stay "inside": 1 on a line, 2 in a plane.
    let inside = match N {
        2 => 1,
        3 => 2,
        _ => return Split::NotApplicable,
    };
    let Some(r) = adapted_frame(x) else {
        return Split::NotApplicable;
    };
    let rt = r.transpose();
    let nb = N - 1;
    // kf_ab = R (Σ_ij U_ia U_jb h_ij) Rᵀ for the Helmert vectors a, b < N − 1.
    let mut t = [[DMat3::ZERO; 2]; N];
    for (i, ti) in t.iter_mut().enumerate() {
        for (b, tib) in ti.iter_mut().enumerate().take(nb) {
            for j in 0..=(b + 1) {
                *tib += h[i][j] * helmert(j, b);
            }
        }
    }
    let mut kf = [[DMat3::ZERO; 2]; 2];
    for a in 0..nb {
        for b in a..nb {
            let mut k = DMat3::ZERO;
            for (i, ti) in t.iter().enumerate().take(a + 2) {
                k += ti[b] * helmert(i, a);
            }
            kf[a][b] = r * k * rt;
        }
    }
    // Symmetrise against round-off.
    for a in 0..nb {
        kf[a][a] = (kf[a][a] + kf[a][a].transpose()) * 0.5;
        for b in a + 1..nb {
            kf[b][a] = kf[a][b].transpose();
        }
    }
    let mut scale = 0.0f64;
    for a in 0..nb {
        for b in 0..nb {
            scale = scale.max(max_abs(&kf[a][b]));
        }
    }
    if !(scale > 0.0) {
        return Split::NotApplicable;
    }
    let tol = SPLIT_TOL * scale;
    for a in 0..nb {
        for b in 0..nb {
            for p in 0..inside {
                for q in inside..3 {
                    if !(entry(&kf[a][b], p, q).abs() <= tol) {
                        return Split::NotApplicable;
                    }
                }
            }
        }
    }
    let inv = 1.0 / scale;
    if inside == 1 {
        // Two points: the line part is 1×1, the across part 2×2.
        let along = entry(&kf[0][0], 0, 0);
        let kout = [
            [entry(&kf[0][0], 1, 1) * inv, entry(&kf[0][0], 1, 2) * inv],
            [entry(&kf[0][0], 2, 1) * inv, entry(&kf[0][0], 2, 2) * inv],
        ];
        let (lam, v) = eigen2(&kout);
        if along < 0.0 {
            subtract_mode(h, along, &rt, [DVec3::X, DVec3::ZERO]);
        }
        for e in 0..2 {
            if lam[e] < 0.0 {
                let f = DVec3::new(0.0, v[0][e], v[1][e]);
                subtract_mode(h, lam[e] * scale, &rt, [f, DVec3::ZERO]);
            }
        }
    } else {
        // Three points: the in-plane part is 4×4, the across (normal) part 2×2.
        let mut kin = [[0.0f64; 4]; 4];
        for a in 0..2 {
            for b in 0..2 {
                for p in 0..2 {
                    for q in 0..2 {
                        kin[2 * a + p][2 * b + q] = entry(&kf[a][b], p, q) * inv;
                    }
                }
            }
        }
        let kout = [
            [entry(&kf[0][0], 2, 2) * inv, entry(&kf[0][1], 2, 2) * inv],
            [entry(&kf[1][0], 2, 2) * inv, entry(&kf[1][1], 2, 2) * inv],
        ];
        let (lam, v) = eigen2(&kout);
        for e in 0..2 {
            if lam[e] < 0.0 {
                let f = [DVec3::new(0.0, 0.0, v[0][e]), DVec3::new(0.0, 0.0, v[1][e])];
                subtract_mode(h, lam[e] * scale, &rt, f);
            }
        }
        if !is_positive_definite(&kin) {
            return Split::Plane(PlaneJob { kin, rt, scale });
        }
    }
    Split::Done
}

#[cfg(test)]
mod tests {
    use super::*;
    use constraint_core::DVec3;
    use nalgebra::{DMatrix, SymmetricEigen};

    fn dense<const N: usize>(h: &[[DMat3; N]; N]) -> DMatrix<f64> {
        DMatrix::from_fn(3 * N, 3 * N, |a, b| h[a / 3][b / 3].col(b % 3)[a % 3])
    }

    /// The reference: full eigen-decomposition, negative eigenvalues clamped.
    fn reference<const N: usize>(h: &[[DMat3; N]; N]) -> DMatrix<f64> {
        let m = dense(h);
        let m = (&m + m.transpose()) * 0.5;
        let e = SymmetricEigen::new(m);
        let lam = e.eigenvalues.map(|l| l.max(0.0));
        &e.eigenvectors * DMatrix::from_diagonal(&lam) * e.eigenvectors.transpose()
    }

    fn max_abs(m: &DMatrix<f64>) -> f64 {
        m.iter().fold(0.0, |a, &v| a.max(v.abs()))
    }

    fn block_max(m: DMat3) -> f64 {
        m.to_cols_array().iter().fold(0.0, |a, &v| a.max(v.abs()))
    }

    struct Lcg(f64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = (self.0 * 7.31 + 0.17).fract();
            self.0 - 0.5
        }
    }

    fn random_symmetric<const N: usize>(rng: &mut Lcg) -> [[DMat3; N]; N] {
        let mut h = [[DMat3::ZERO; N]; N];
        for i in 0..N {
            for j in 0..=i {
                let b = DMat3::from_cols_array(&core::array::from_fn(|_| rng.next()));
                h[i][j] = if i == j { (b + b.transpose()) * 0.5 } else { b };
                h[j][i] = h[i][j].transpose();
            }
        }
        h
    }

    /// A random translation-invariant matrix `Pᵀ E P` (E random symmetric in edge space).
    fn random_invariant<const N: usize>(rng: &mut Lcg) -> [[DMat3; N]; N] {
        let mut e = random_symmetric::<N>(rng);
        for i in 0..N {
            e[0][i] = DMat3::ZERO;
            e[i][0] = DMat3::ZERO;
        }
        constraint_core::math::lift_edge_hessian(&e)
    }

    fn check_against_reference<const N: usize>(h: [[DMat3; N]; N]) -> f64 {
        let mut p = h;
        project_psd(&mut p);
        let r = reference(&h);
        let err = max_abs(&(dense(&p) - &r)) / max_abs(&dense(&h));
        let lam = SymmetricEigen::new(dense(&p)).eigenvalues.min();
        assert!(lam > -1e-13 * max_abs(&dense(&h)), "min eigenvalue {lam}");
        err
    }

    /// Exact energy Hessians of a spring and a triangle area at jittered, stretched and
    /// compressed configurations, with their points.
    /// An element Hessian with its points.
    type Element<const N: usize> = ([[DMat3; N]; N], [DVec3; N]);

    fn constraint_hessians() -> (Vec<Element<2>>, Vec<Element<3>>) {
        use crate::energy::{energy_hessian, HessianMode};
        use constraint_core::{Area, Distance};
        let mut rng = Lcg(0.42);
        let mut springs = Vec::new();
        let mut tris = Vec::new();
        let rest2 = [DVec3::ZERO, DVec3::new(1.0, 0.2, -0.1)];
        let rest3 = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.1, 0.0),
            DVec3::new(0.2, 0.9, 0.1),
        ];
        let spring = Distance::from_rest(0, 1, &rest2).unwrap();
        let area = Area::from_rest([0, 1, 2], &rest3).unwrap();
        for case in 0..60 {
            let s = [0.6, 1.0, 1.5][case % 3];
            let jitter = |rng: &mut Lcg| DVec3::new(rng.next(), rng.next(), rng.next()) * 0.3;
            let x2 = [
                rest2[0] * s + jitter(&mut rng),
                rest2[1] * s + jitter(&mut rng),
            ];
            let x3 = [
                rest3[0] * s + jitter(&mut rng),
                rest3[1] * s + jitter(&mut rng),
                rest3[2] * s + jitter(&mut rng),
            ];
            springs.push((energy_hessian(&spring, 1e3, &x2, HessianMode::Exact), x2));
            tris.push((energy_hessian(&area, 1e5, &x3, HessianMode::Exact), x3));
        }
        (springs, tris)
    }

    #[test]
    fn split_projection_of_constraint_hessians_matches_reference() {
        let (springs, tris) = constraint_hessians();
        let mut worst = 0.0f64;
        let mut indefinite = 0;
        for (h, x) in &springs {
            let mut p = *h;
            assert!(!matches!(project_split(&mut p, x), Split::NotApplicable));
            let mut p = *h;
            project_psd_at(&mut p, x);
            let r = reference(h);
            indefinite += usize::from(dense(&p) != dense(h));
            worst = worst.max(max_abs(&(dense(&p) - &r)) / max_abs(&dense(h)));
        }
        for (h, x) in &tris {
            let mut p = *h;
            assert!(!matches!(project_split(&mut p, x), Split::NotApplicable));
            let mut p = *h;
            project_psd_at(&mut p, x);
            let r = reference(h);
            indefinite += usize::from(dense(&p) != dense(h));
            worst = worst.max(max_abs(&(dense(&p) - &r)) / max_abs(&dense(h)));
            let lam = SymmetricEigen::new(dense(&p)).eigenvalues.min();
            assert!(lam > -1e-14 * max_abs(&dense(h)), "min eigenvalue {lam}");
        }
        assert!(indefinite > 40, "{indefinite}");
        // measured ≈ 4e-15 (92 of 120 elements indefinite); gate 1e-13
        assert!(worst < 1e-13, "{worst}");
    }

    #[test]
    fn batched_projection_equals_one_at_a_time() {
        let (_, tris) = constraint_hessians();
        let mut hs: Vec<[[DMat3; 3]; 3]> = tris.iter().map(|t| t.0).collect();
        let mut xs: Vec<[DVec3; 3]> = tris.iter().map(|t| t.1).collect();
        // Odd ones out in the batches: PSD, zero, non-finite, not translation invariant.
        let spd = DMat3::from_diagonal(DVec3::new(1.0, 2.0, 3.0));
        hs[1] = [
            [spd * 2.0, -spd, -spd],
            [-spd, spd, DMat3::ZERO],
            [-spd, DMat3::ZERO, spd],
        ];
        hs[5] = [[DMat3::ZERO; 3]; 3];
        hs[6][1][2].x_axis.y = f64::NAN;
        hs[9] = random_symmetric::<3>(&mut Lcg(0.9));
        xs.truncate(hs.len() - 1);
        let mut one = hs.clone();
        for (h, x) in one.iter_mut().zip(&xs) {
            project_psd_at(h, x);
        }
        let mut many = hs.clone();
        project_psd_at_many(&mut many, &xs);
        // The last element has no points and is left alone.
        assert_eq!(many.last(), hs.last());
        let n = xs.len();
        assert!(one[..n].iter().zip(&many[..n]).all(|(a, b)| a
            .iter()
            .flatten()
            .zip(b.iter().flatten())
            .all(|(a, b)| {
                a.to_cols_array().map(f64::to_bits) == b.to_cols_array().map(f64::to_bits)
            })));
    }

    #[test]
    fn non_invariant_three_point_matrix_takes_the_general_path() {
        let mut rng = Lcg(0.123);
        let x = [DVec3::ZERO, DVec3::X, DVec3::Y];
        for _ in 0..20 {
            let h = random_symmetric::<3>(&mut rng);
            let mut p = h;
            assert!(
                matches!(project_split(&mut p, &x), Split::NotApplicable)
                    || !is_translation_invariant(&h)
            );
            let mut p = h;
            project_psd_at(&mut p, &x);
            let err = max_abs(&(dense(&p) - reference(&h))) / max_abs(&dense(&h));
            assert!(err < 1e-12, "{err}");
        }
    }

    #[test]
    fn psd_input_is_unchanged_and_negative_part_removed() {
        let mut h = [[DMat3::from_diagonal(DVec3::new(1.0, -2.0, 3.0))]];
        project_psd(&mut h);
        assert_eq!(h[0][0], DMat3::from_diagonal(DVec3::new(1.0, 0.0, 3.0)));
        let spd = DMat3::from_diagonal(DVec3::new(1.0, 2.0, 3.0));
        let mut h2 = [[spd, -spd], [-spd, spd]];
        project_psd(&mut h2);
        assert_eq!(h2[0][0], spd);
        // A spring with negative lateral stiffness keeps only its axial part.
        let b = DMat3::from_diagonal(DVec3::new(4.0, -1.0, -1.0));
        let mut h3 = [[b, -b], [-b, b]];
        project_psd(&mut h3);
        let bp = DMat3::from_diagonal(DVec3::new(4.0, 0.0, 0.0));
        for (row, sign) in h3.iter().zip([1.0, -1.0]) {
            assert!(block_max(row[0] - bp * sign) < 1e-14);
            assert!(block_max(row[1] + bp * sign) < 1e-14);
        }
    }

    #[test]
    fn general_four_point_projection_has_no_negative_eigenvalues() {
        let mut h = [[DMat3::ZERO; 4]; 4];
        let mut s = 1.0f64;
        for i in 0..4 {
            for j in 0..=i {
                s = (s * 7.31 + 0.17).fract();
                let b = DMat3::from_cols_array(&[s, s - 0.5, 0.2, s - 0.5, -s, 0.1, 0.2, 0.1, s]);
                h[i][j] = if i == j { (b + b.transpose()) * 0.5 } else { b };
                h[j][i] = h[i][j].transpose();
            }
        }
        project_psd(&mut h);
        let m = dense(&h);
        let e = SymmetricEigen::new(m);
        // measured min eigenvalue ≈ −1e-16; gate −1e-12
        assert!(e.eigenvalues.min() > -1e-12, "{}", e.eigenvalues.min());
    }

    #[test]
    fn full_projection_matches_reference() {
        let mut rng = Lcg(0.3);
        let mut worst = 0.0f64;
        for _ in 0..50 {
            worst = worst.max(check_against_reference(random_symmetric::<1>(&mut rng)));
            worst = worst.max(check_against_reference(random_symmetric::<2>(&mut rng)));
            worst = worst.max(check_against_reference(random_symmetric::<3>(&mut rng)));
            worst = worst.max(check_against_reference(random_symmetric::<4>(&mut rng)));
        }
        // measured ≲ 7e-15; gate 1e-12
        assert!(worst < 1e-12, "{worst}");
    }

    #[test]
    fn reduced_projection_is_exact_and_translation_invariant() {
        let mut rng = Lcg(0.7);
        let mut worst = 0.0f64;
        for _ in 0..50 {
            let h2 = random_invariant::<2>(&mut rng);
            let h3 = random_invariant::<3>(&mut rng);
            let h4 = random_invariant::<4>(&mut rng);
            assert!(is_translation_invariant(&h2));
            assert!(is_translation_invariant(&h3));
            assert!(is_translation_invariant(&h4));
            worst = worst.max(check_against_reference(h2));
            worst = worst.max(check_against_reference(h3));
            worst = worst.max(check_against_reference(h4));
            let mut p = h4;
            project_psd(&mut p);
            let scale = max_abs(&dense(&h4));
            for row in &p {
                let sum: DMat3 = row.iter().copied().sum();
                assert!(block_max(sum) < 1e-13 * scale);
            }
        }
        // measured ≲ 7e-15; gate 1e-12
        assert!(worst < 1e-12, "{worst}");
        // A non-invariant matrix is not mistaken for one.
        assert!(!is_translation_invariant(&random_symmetric::<3>(&mut rng)));
    }

    #[test]
    fn psd_reduced_input_is_returned_unchanged() {
        // E = Gᵀ G + I is SPD in edge space, so the lifted matrix is PSD.
        let mut rng = Lcg(0.11);
        let g = random_symmetric::<3>(&mut rng);
        let mut e = [[DMat3::ZERO; 3]; 3];
        for i in 1..3 {
            for j in 1..3 {
                e[i][j] = (1..3).map(|k| g[k][i].transpose() * g[k][j]).sum::<DMat3>();
                if i == j {
                    e[i][j] += DMat3::IDENTITY;
                }
            }
        }
        let h = constraint_core::math::lift_edge_hessian(&e);
        let mut p = h;
        project_psd(&mut p);
        assert_eq!(p, h);
    }

    #[test]
    fn non_finite_and_zero_input_are_left_alone() {
        let mut h = [[DMat3::ZERO; 3]; 3];
        project_psd(&mut h);
        assert_eq!(h, [[DMat3::ZERO; 3]; 3]);
        h[1][1] = DMat3::from_diagonal(DVec3::new(f64::NAN, -1.0, 1.0));
        let before = h;
        project_psd(&mut h);
        assert!(h[1][1].x_axis.x.is_nan());
        assert_eq!(h[1][1].y_axis, before[1][1].y_axis);
    }
}
