//! Compound joint: several slide and hinge joints in one body, composed as MuJoCo
//! composes them, as one constraint between the body and its parent (maximal
//! coordinates).
//!
//! MuJoCo places a body `b` with joints `j₁ … j_k` (in document order) at
//! `B = A R_off J₁(q₁) ⋯ J_k(q_k)`: each joint acts in the body frame as moved by the
//! joints before it. With the `n_s ≤ 3` slides first and then `n_h ≤ 3` hinges through
//! one common anchor `p` (the planar root slide–slide–hinge of hopper, walker and
//! cheetah; two or three hinges at a hip or shoulder; a slide followed by a hinge),
//! this is exactly:
//!
//! * the slide axes `s_i` are fixed in the parent `a` (no rotation precedes them), so
//!   the anchor `p_b` fixed in `b` stays on `p_a + span(R_a s_i)`:
//!   `3 − n_s` rows `C = (R_a n_k) · (p_b − p_a)` with `n_k ⊥ s_i` fixed in `a`;
//! * the first hinge axis `e₁` is fixed in `a` and the last `e_{n_h}` in `b` (a rotation
//!   leaves its own axis unchanged), so the relative rotation is held by
//!   `n_h = 0`: the three orientation rows of a weld, `n_h = 1`: two rows
//!   `(R_a n_k) · (R_b e₁) = 0`, `n_h = 2`: one row `(R_a e₁) · (R_b e₂) = e₁ · e₂`
//!   (a universal joint), `n_h = 3`: none (a ball joint).
//!
//! The hinges need not share their MuJoCo `pos`: what matters is their lines. When the
//! lines pass through one point (the least-squares point of the lines,
//! [`Compound::from_lines`]) that point is the anchor. Two hinges alone on **skew** lines
//! (an offset universal joint, dm_control humanoid's ankle) compose as
//! `B = Rot(L₁, q₁) Rot(L₂, q₂) B₀`: `L₁` is fixed in `a` (nothing moves it), `L₂` in
//! `b` (a rotation leaves its own line in place). With `P₁` (on `L₁`, in `a`) and `p₂`
//! (on `L₂`, in `b`) the feet of their common perpendicular at rest, `A₁` and `a₂` the
//! axes, `d = (x_b + R_b p₂) − (x_a + R_a P₁)` and `δ = |d|` at rest, the motion keeps
//! `d ⊥ L₁`, `d ⊥ L₂`, `|d| = δ` and the angle between the lines: four rows
//! `(R_a A₁)·d`, `d·(R_b a₂)`, `(d·d − δ²)/(2δ)`, `(R_a A₁)·(R_b a₂) − A₁·a₂` (the
//! first three in metres, the third scaled to a unit gradient). The relative rotation is
//! the universal joint's, so the coordinates and rate rows are the same.
//!
//! Every row is a dot product of frame-expression vectors (the private `frame_expr`
//! module), so value, Jacobian and curvature come from the same derivation as the other
//! joints (and are checked the same way). [`Compound::coordinates`] recovers MuJoCo's
//! `qpos` of the composed joints from the two poses, and [`Compound::dof_rows`] the rows
//! of their rates `q̇`.

use glam::{DQuat, DVec3};

use crate::frame_expr::{add_dot_hessian, dot_grad, FrameExpr};
use crate::joint::{unit, Orientation, Point};
use crate::rigid::{BodyConstraint, Pose, TwistCurvature, TwistJacobian};
use crate::ConstraintError;

/// Most degrees of freedom of a compound joint (and most rows).
pub const MAX_DOF: usize = 6;

/// Slides (first) then hinges through one anchor, composed as MuJoCo composes the joints
/// of one body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compound {
    point: Point,
    n_slides: usize,
    /// Slide axes, unit, in `a`'s frame.
    slides: [DVec3; 3],
    /// Unit normals of the slide span, in `a`'s frame (`3 − n_slides` of them).
    normals: [DVec3; 3],
    n_hinges: usize,
    /// Hinge axes in `b`'s frame (MuJoCo's `jnt_axis`, unit).
    axes: [DVec3; 3],
    /// The first hinge axis in `a`'s frame (at rest).
    e1_a: DVec3,
    /// One hinge: two directions ⊥ the axis in `a`'s frame.
    perp: [DVec3; 2],
    /// Two hinges: `e₁ · e₂`.
    c0: f64,
    /// Three hinges ([`Self::coordinates`]'s constants, the same operations on the
    /// same axes as evaluating them there): `e₂ · e₃`, `e₁ × e₂`, `|e₁ × e₂|²` and
    /// `e₃ − e₂ (e₂ · e₃)` (`e₃` projected on the plane ⊥ `e₂`).
    c12: f64,
    n12: DVec3,
    n12_sq: f64,
    e3_perp: DVec3,
    orient: Orientation,
    /// The rest relative rotation `R_off = A₀ᵀ B₀`.
    rel0: DQuat,
    /// Two hinges on skew lines: the rest distance `δ > 0` between them (then
    /// `point.r_a` is the foot `P₁` on the first line, in `a`, and `point.r_b` the foot
    /// `p₂` on the second, in `b`); `None` for hinges through one anchor.
    skew: Option<f64>,
}

/// Relative tolerance on the lines meeting in one point (of the spread of the points
/// given on them).
pub const CONCURRENT_TOL: f64 = 1e-9;

/// Orthonormal complement of independent unit vectors `v[..n]` (Gram–Schmidt), or `None`
/// when they are dependent.
fn complement(v: &[DVec3]) -> Option<[DVec3; 3]> {
    let mut basis: [DVec3; 3] = [DVec3::ZERO; 3];
    let mut m = 0;
    for &x in v {
        let mut y = x;
        for b in &basis[..m] {
            y -= *b * b.dot(y);
        }
        if !(y.length() > 1e-6) {
            return None;
        }
        basis[m] = y.normalize();
        m += 1;
    }
    let mut out = [DVec3::ZERO; 3];
    let mut k = 0;
    for e in [DVec3::X, DVec3::Y, DVec3::Z] {
        if m + k == 3 {
            break;
        }
        let mut y = e;
        for b in basis[..m].iter().chain(&out[..k]) {
            y -= *b * b.dot(y);
        }
        if y.length() > 1e-3 {
            out[k] = y.normalize();
            k += 1;
        }
    }
    Some(out)
}

/// Signed angle about unit `axis` taking `from` to `to` (both projected on the plane ⊥
/// `axis`), in `(−π, π]`.
fn angle_about(axis: DVec3, from: DVec3, to: DVec3) -> f64 {
    angle_between(axis, perp(axis, from), perp(axis, to))
}

/// `v` projected on the plane ⊥ unit `axis`, `v − axis (axis · v)`.
#[inline(always)]
fn perp(axis: DVec3, v: DVec3) -> DVec3 {
    v - axis * axis.dot(v)
}

/// [`angle_about`] from the projections `p`, `q` of `from`, `to` ([`perp`]).
#[inline(always)]
fn angle_between(axis: DVec3, p: DVec3, q: DVec3) -> f64 {
    libm::atan2(axis.dot(p.cross(q)), p.dot(q))
}

/// The angle of the rotation `r` about unit `axis` (its twist part), in `(−π, π]`.
fn twist_angle(r: DQuat, axis: DVec3) -> f64 {
    let s = DVec3::new(r.x, r.y, r.z).dot(axis);
    let a = 2.0 * libm::atan2(s, r.w);
    if a > core::f64::consts::PI {
        a - 2.0 * core::f64::consts::PI
    } else if a <= -core::f64::consts::PI {
        a + 2.0 * core::f64::consts::PI
    } else {
        a
    }
}

/// Of two solutions `(q₁, q₂, p)` (`p = |q₁ − h₁| + |q₂ − h₂|`, the distance to the hint
/// so far), the one whose whole distance `d = p + |q₃ − h₃|` (`whole`) is least, the
/// first on a tie: the bits of evaluating both and keeping the first unless the second
/// is strictly nearer (`d < d_best`, `d_best` starting at `∞`). A solution's rounded `d`
/// is at least its `p` (adding `|q₃ − h₃| ≥ 0` rounds to no less), so the one whose `p`
/// is already past the other's whole `d` is not evaluated: it cannot win (the first
/// needs `p₁ > d₂` to lose, the second `p₂ ≥ d₁`). Non-finite `p`: both are evaluated.
fn nearest(
    one: (f64, f64, f64),
    two: (f64, f64, f64),
    whole: impl Fn((f64, f64, f64)) -> ([f64; 3], f64),
) -> [f64; 3] {
    // The loop this replaces: each solution in turn, kept when strictly nearer.
    let keep = |(q, d): ([f64; 3], f64), (best, best_d): ([f64; 3], f64)| {
        if d < best_d {
            (q, d)
        } else {
            (best, best_d)
        }
    };
    let none = ([0.0; 3], f64::INFINITY);
    if one.2.is_finite() && two.2.is_finite() {
        if one.2 <= two.2 {
            let w1 = whole(one);
            if w1.1.is_finite() && two.2 >= w1.1 {
                return w1.0;
            }
            return keep(whole(two), keep(w1, none)).0;
        }
        let w2 = whole(two);
        if w2.1.is_finite() && one.2 > w2.1 {
            return w2.0;
        }
        return keep(w2, keep(whole(one), none)).0;
    }
    keep(whole(two), keep(whole(one), none)).0
}

/// Inverse of the `n × n` Gram matrix of `v` applied to get the dual basis `c_k` with
/// `c_k · v_l = δ_kl` (`n ≤ 3`, `v` independent).
fn dual_basis(v: &[DVec3], out: &mut [DVec3]) {
    dual_basis_damped(v, 0.0, out);
}

/// Where the hinge axes' dual basis starts to be damped: the Gram determinant
/// `det(WᵀW)` below `SINGULAR_GRAM` (three unit axes with `w₂ ⊥ w₁, w₃`, as Euler
/// angles compose them: `det = cos² q₂`, so within `asin(0.1) ≈ 5.7°` of the lock).
pub const SINGULAR_GRAM: f64 = 1e-2;

/// The damping `λ₀²` at the lock itself (`det(WᵀW) = 0`): the rows' length is then at
/// most `1/(2λ₀) = 50`.
pub const SINGULAR_DAMPING: f64 = 1e-4;

/// [`dual_basis`] with `λ²` added to the Gram matrix's diagonal:
/// `c_k = Σ_l v_l [(VᵀV + λ² I)⁻¹]_kl`, the damped least-squares (singularity-robust)
/// inverse of Nakamura & Hanafusa (1986): each singular value `σ` of `V` maps to
/// `σ/(σ² + λ²) ≤ 1/(2λ)` instead of `1/σ`. `λ² = 0` gives the exact dual basis.
fn dual_basis_damped(v: &[DVec3], lambda2: f64, out: &mut [DVec3]) {
    // The body once per count with the count a constant (its loops unroll): the same
    // operations in the same order as with the runtime count.
    match v.len() {
        1 => dual_basis_sized(v, lambda2, out, 1),
        2 => dual_basis_sized(v, lambda2, out, 2),
        3 => dual_basis_sized(v, lambda2, out, 3),
        n => dual_basis_sized(v, lambda2, out, n),
    }
}

/// [`dual_basis_damped`] of the first `n ≤ 3` vectors of `v` (inlined at each
/// constant `n`).
#[inline(always)]
fn dual_basis_sized(v: &[DVec3], lambda2: f64, out: &mut [DVec3], n: usize) {
    let (v, out) = (&v[..n], &mut out[..n]);
    let mut g = [[0.0; 3]; 3];
    for i in 0..n {
        for j in 0..n {
            g[i][j] = v[i].dot(v[j]);
        }
        g[i][i] += lambda2;
    }
    // Gauss–Jordan on the small SPD Gram matrix.
    let mut inv = [[0.0; 3]; 3];
    for i in 0..n {
        inv[i][i] = 1.0;
    }
    for c in 0..n {
        let p = g[c][c];
        if !(p.abs() > 1e-300) {
            for o in out.iter_mut().take(n) {
                *o = DVec3::ZERO;
            }
            return;
        }
        for j in 0..n {
            g[c][j] /= p;
            inv[c][j] /= p;
        }
        for r in 0..n {
            if r != c {
                let f = g[r][c];
                for j in 0..n {
                    g[r][j] -= f * g[c][j];
                    inv[r][j] -= f * inv[c][j];
                }
            }
        }
    }
    for k in 0..n {
        let mut c = DVec3::ZERO;
        for l in 0..n {
            c += v[l] * inv[k][l];
        }
        out[k] = c;
    }
}

impl Compound {
    /// A compound joint for bodies at rest poses `a` (parent; [`Pose::IDENTITY`] for the
    /// world) and `b`, with slide axes `slides` and hinge axes `hinges`, all in `b`'s
    /// frame (MuJoCo's `axis`; at rest, before any joint moves, the slide axes are the
    /// same in `a`), the hinges through the world point `anchor` (for slides alone, any
    /// point fixed in `b`). Errors: non-finite input, a zero axis, more than three of a
    /// kind, dependent slide axes or dependent hinge axes (two parallel hinges; three
    /// coplanar).
    pub fn from_world(
        a: &Pose,
        b: &Pose,
        anchor: DVec3,
        slides: &[DVec3],
        hinges: &[DVec3],
    ) -> Result<Self, ConstraintError> {
        let point = Point::from_world(a, b, anchor)?;
        if slides.len() > 3 || hinges.len() > 3 {
            return Err(ConstraintError::DependentAxes);
        }
        let rel0 = (a.q.conjugate() * b.q).normalize();
        let mut s_a = [DVec3::ZERO; 3];
        for (k, s) in slides.iter().enumerate() {
            s_a[k] = rel0 * unit(*s)?;
        }
        let normals = complement(&s_a[..slides.len()]).ok_or(ConstraintError::DependentAxes)?;
        let mut axes = [DVec3::ZERO; 3];
        for (k, e) in hinges.iter().enumerate() {
            axes[k] = unit(*e)?;
        }
        let nh = hinges.len();
        match nh {
            2 if !(axes[0].cross(axes[1]).length() > 1e-6) => {
                return Err(ConstraintError::DependentAxes)
            }
            3 if !(axes[0].cross(axes[1]).dot(axes[2]).abs() > 1e-6) => {
                return Err(ConstraintError::DependentAxes)
            }
            _ => {}
        }
        let e1_a = rel0 * axes[0];
        let (p1, p2) = e1_a.any_orthonormal_pair();
        Ok(Self {
            point,
            n_slides: slides.len(),
            slides: s_a,
            normals,
            n_hinges: nh,
            axes,
            e1_a,
            perp: [p1, p2],
            c0: axes[0].dot(axes[1]),
            c12: axes[1].dot(axes[2]),
            n12: axes[0].cross(axes[1]),
            n12_sq: axes[0].cross(axes[1]).length_squared(),
            e3_perp: perp(axes[1], axes[2]),
            orient: Orientation::from_world(a, b),
            rel0,
            skew: None,
        })
    }

    /// A compound joint whose hinges are given as lines: `hinges[k] = (x_k, e_k)` with
    /// `x_k` a world point on the line at rest and `e_k` the axis in `b`'s frame
    /// (MuJoCo's `pos` and `axis`, `pos` taken to the world). When every `x_k` is the same
    /// point this is [`Self::from_world`] at it (bit for bit). Otherwise the anchor is
    /// the least-squares point of the lines, `p = (Σ (I − u_k u_kᵀ))⁻¹ Σ (I − u_k u_kᵀ)
    /// x_k` (`u_k = R_b e_k`), accepted when every line passes within
    /// [`CONCURRENT_TOL`] × `max_k |x_k − x_1|` of it; failing that, two hinges without
    /// slides make an offset universal joint (module documentation). No hinges: the
    /// anchor is `b`'s centre. Errors: as [`Self::from_world`], and
    /// [`ConstraintError::HingesNotConcurrent`] for lines that meet in no point (more
    /// than two hinges, or slides before them).
    pub fn from_lines(
        a: &Pose,
        b: &Pose,
        slides: &[DVec3],
        hinges: &[(DVec3, DVec3)],
    ) -> Result<Self, ConstraintError> {
        if hinges.len() > 3 {
            return Err(ConstraintError::DependentAxes);
        }
        let mut axes = [DVec3::ZERO; 3];
        for (k, (x, e)) in hinges.iter().enumerate() {
            if !x.is_finite() {
                return Err(ConstraintError::NonFinite);
            }
            axes[k] = *e;
        }
        let axes = &axes[..hinges.len()];
        let Some(&(x1, _)) = hinges.first() else {
            return Self::from_world(a, b, b.x, slides, &[]);
        };
        if hinges.iter().all(|(x, _)| *x == x1) {
            return Self::from_world(a, b, x1, slides, axes);
        }
        // Validates poses and axes (parallel or coplanar hinges) before the geometry.
        let base = Self::from_world(a, b, x1, slides, axes)?;
        let mut m = glam::DMat3::ZERO;
        let mut rhs = DVec3::ZERO;
        let mut u = [DVec3::ZERO; 3];
        let mut spread: f64 = 0.0;
        for (k, (x, e)) in hinges.iter().enumerate() {
            u[k] = b.q * unit(*e)?;
            let p = glam::DMat3::IDENTITY - crate::math::outer(u[k], u[k]);
            m += p;
            rhs += p * *x;
            spread = spread.max((*x - x1).length());
        }
        let det = m.determinant();
        if !(det.abs() > 1e-12) || !(spread.is_finite()) {
            return Err(ConstraintError::DependentAxes);
        }
        let p = m.inverse() * rhs;
        let miss = hinges
            .iter()
            .zip(&u)
            .map(|((x, _), u)| {
                let r = p - *x;
                (r - *u * u.dot(r)).length()
            })
            .fold(0.0, f64::max);
        if miss <= CONCURRENT_TOL * spread {
            return Self::from_world(a, b, p, slides, axes);
        }
        if !slides.is_empty() || hinges.len() != 2 {
            return Err(ConstraintError::HingesNotConcurrent);
        }
        // Feet of the common perpendicular: (P₂ − P₁) ⊥ u₁, u₂.
        let (x2, w0) = (hinges[1].0, x1 - hinges[1].0);
        let k = u[0].dot(u[1]);
        let (dd, ee) = (u[0].dot(w0), u[1].dot(w0));
        let den = 1.0 - k * k;
        let p1 = x1 + u[0] * ((k * ee - dd) / den);
        let p2 = x2 + u[1] * ((ee - k * dd) / den);
        let point = Point {
            r_a: a.to_local(p1),
            r_b: b.to_local(p2),
        };
        let delta = point.sep(a, b).value.length();
        if !(delta > 0.0) || !delta.is_finite() {
            return Err(ConstraintError::HingesNotConcurrent);
        }
        Ok(Self {
            point,
            skew: Some(delta),
            ..base
        })
    }

    /// The rest distance between the two hinge lines of an offset universal joint
    /// ([`Self::from_lines`]); `None` when the hinges share one anchor.
    pub fn skew_distance(&self) -> Option<f64> {
        self.skew
    }

    /// Number of slides.
    pub fn slides(&self) -> usize {
        self.n_slides
    }

    /// Number of hinges.
    pub fn hinges(&self) -> usize {
        self.n_hinges
    }

    /// Degrees of freedom `n_s + n_h`.
    pub fn dof(&self) -> usize {
        self.n_slides + self.n_hinges
    }

    /// Number of constraint rows, `6 − dof`.
    pub fn rows(&self) -> usize {
        MAX_DOF - self.dof()
    }

    /// Anchor in body `a`'s frame (hinges on skew lines: the foot `P₁` on the first).
    pub fn anchor_a(&self) -> DVec3 {
        self.point.r_a
    }

    /// Anchor in body `b`'s frame (hinges on skew lines: the foot `p₂` on the second).
    pub fn anchor_b(&self) -> DVec3 {
        self.point.r_b
    }

    /// Whether the joint has translation rows (fewer than three slides); their values
    /// are the first [`Self::translation_rows`] entries of the value (hinges on skew
    /// lines: the three rows in metres, `d ⊥ L₁`, `d ⊥ L₂`, `|d| = δ`).
    pub fn translation_rows(&self) -> usize {
        3 - self.n_slides
    }

    /// The joint coordinates `q` (slides in m, then hinges in rad, in order), zero at the
    /// rest poses: the slides' displacement of the anchor along their axes and the
    /// hinge angles of the relative rotation `R_offᵀ R_aᵀ R_b = J₁ ⋯ J_{n_h}`. With
    /// three hinges the angles have two solutions; the one nearest `hint` (the
    /// previous coordinates, or zeros) is returned.
    pub fn coordinates(&self, a: &Pose, b: &Pose, hint: &[f64; MAX_DOF]) -> [f64; MAX_DOF] {
        let mut q = [0.0; MAX_DOF];
        let ns = self.n_slides;
        if ns > 0 {
            let sep = a.q.conjugate() * (b.point(self.point.r_b) - a.point(self.point.r_a));
            let mut dual = [DVec3::ZERO; 3];
            dual_basis(&self.slides[..ns], &mut dual[..ns]);
            for k in 0..ns {
                q[k] = dual[k].dot(sep);
            }
        }
        let d = (self.rel0.conjugate() * a.q.conjugate() * b.q).normalize();
        let e = &self.axes;
        match self.n_hinges {
            1 => q[ns] = twist_angle(d, e[0]),
            2 => {
                // D e₂ = J₁ e₂: the first angle turns e₂ into D e₂ about e₁.
                let q1 = angle_about(e[0], e[1], d * e[1]);
                let rest = DQuat::from_axis_angle(e[0], q1).conjugate() * d;
                q[ns] = q1;
                q[ns + 1] = twist_angle(rest, e[1]);
            }
            3 => {
                // D e₃ = J₁ J₂ e₃ (Paden–Kahan subproblem 2): c = J₂ e₃ = J₁ᵀ D e₃ has
                // e₁ · c = e₁ · t and e₂ · c = e₂ · e₃, |c| = 1.
                // The axes' constants are the joint's (`c0 = e₁ · e₂`, `c12`, `n12`,
                // `n12_sq`, `e3_perp`: the values these expressions had here), and
                // `t`'s projection ⊥ e₁ is shared by both solutions' first angle.
                let t = d * e[2];
                let k = self.c0;
                let (at, be) = (e[0].dot(t), self.c12);
                let den = 1.0 - k * k;
                let alpha = (at - k * be) / den;
                let beta = (be - k * at) / den;
                let n = self.n12;
                let g2 = (1.0 - alpha * alpha - beta * beta - 2.0 * alpha * beta * k) / self.n12_sq;
                let g = libm::sqrt(g2.max(0.0));
                // `perp(e₁, t)`: `t − e₁ (e₁ · t)`, with `e₁ · t` the `at` above.
                let t_perp = t - e[0] * at;
                // The two solutions' first angles and their distance to the hint so far.
                let h = [hint[ns], hint[ns + 1], hint[ns + 2]];
                let first = |sign: f64| {
                    let c = e[0] * alpha + e[1] * beta + n * (g * sign);
                    let q2 = angle_between(e[1], self.e3_perp, perp(e[1], c));
                    let q1 = angle_between(e[0], perp(e[0], c), t_perp);
                    (q1, q2, (q1 - h[0]).abs() + (q2 - h[1]).abs())
                };
                // The third angle and the whole distance `Σ |q_k − hint_k|`.
                let whole = |(q1, q2, part): (f64, f64, f64)| {
                    let rest = (DQuat::from_axis_angle(e[0], q1)
                        * DQuat::from_axis_angle(e[1], q2))
                    .conjugate()
                        * d;
                    let q3 = twist_angle(rest, e[2]);
                    ([q1, q2, q3], part + (q3 - h[2]).abs())
                };
                q[ns..ns + 3].copy_from_slice(&nearest(first(1.0), first(-1.0), whole));
            }
            _ => {}
        }
        q
    }

    /// The rows of the coordinate rates, `q̇_k = row_k · (v_a, ω_a, v_b, ω_b)` at
    /// coordinates `q` (from [`Self::coordinates`]), exact on the joint manifold. Slides:
    /// the dual basis `d_k` of the world slide axes applied to the anchor's velocity
    /// relative to `a`'s frame, `[−d, −(p_b − x_a) × d, d, (p_b − x_b) × d]`; hinges:
    /// the dual basis `c_k` of the current world hinge axes
    /// `w_k = R_a R_off J₁ ⋯ J_{k−1} e_k`, `[0, −c_k, 0, c_k]`.
    pub fn dof_rows(&self, a: &Pose, b: &Pose, q: &[f64; MAX_DOF]) -> [[DVec3; 4]; MAX_DOF] {
        let mut rows = [[DVec3::ZERO; 4]; MAX_DOF];
        let ns = self.n_slides;
        if ns > 0 {
            let mut w = [DVec3::ZERO; 3];
            for k in 0..ns {
                w[k] = a.q * self.slides[k];
            }
            let mut d = [DVec3::ZERO; 3];
            dual_basis(&w[..ns], &mut d[..ns]);
            let pb = b.point(self.point.r_b);
            for k in 0..ns {
                let dk = d[k];
                rows[k] = [-dk, -(pb - a.x).cross(dk), dk, (pb - b.x).cross(dk)];
            }
        }
        let nh = self.n_hinges;
        if nh > 0 {
            let w = self.world_hinge_axes(a, q);
            // Three hinges lose a degree of freedom where the first and last axes
            // line up (gimbal lock, `q₂ = ±90°` for orthogonal axes: humanoid_CMU's
            // shoulders have their limit there); the exact rows grow as `1/cos q₂`
            // and with the rate rows' armature and damping the tree factor lost all
            // precision (joint error 1e-4 m). Near the lock the dual basis is damped
            // with Nakamura's variable damping `λ² = λ₀² (1 − det/ε²)` (Nakamura &
            // Hanafusa 1986; Chiaverini 1997): exact for `det(WᵀW) ≥ ε²`, continuous,
            // bounded by `1/(2λ₀)` at the lock.
            let mut lambda2 = 0.0;
            if nh == 3 {
                // det(WᵀW) = (w₁ · w₂ × w₃)² (`powi` is not in `core`).
                let triple = w[0].dot(w[1].cross(w[2]));
                let det = triple * triple;
                if det < SINGULAR_GRAM {
                    lambda2 = SINGULAR_DAMPING * (1.0 - det / SINGULAR_GRAM);
                }
            }
            let mut c = [DVec3::ZERO; 3];
            dual_basis_damped(&w[..nh], lambda2, &mut c[..nh]);
            for k in 0..nh {
                rows[ns + k] = [DVec3::ZERO, -c[k], DVec3::ZERO, c[k]];
            }
        }
        rows
    }

    /// The current world hinge axes `w_k = R_a R_off J₁ ⋯ J_{k−1} e_k` at coordinates
    /// `q` (zero past the hinges). The last hinge's own turn `J_{n_h}` moves no axis, so
    /// it is not formed (a `sin_cos` and a product per call that nothing read).
    fn world_hinge_axes(&self, a: &Pose, q: &[f64; MAX_DOF]) -> [DVec3; 3] {
        let (ns, nh) = (self.n_slides, self.n_hinges);
        let mut m = a.q * self.rel0;
        let mut w = [DVec3::ZERO; 3];
        for k in 0..nh {
            w[k] = m * self.axes[k];
            if k + 1 < nh {
                m *= DQuat::from_axis_angle(self.axes[k], q[ns + k]);
            }
        }
        w
    }

    /// The Gram determinant `det(WᵀW)` of the current world hinge axes
    /// `w_k = R_a R_off J₁ ⋯ J_{k−1} e_k` at coordinates `q` (1 without hinges): `cos² q₂`
    /// for three orthogonal hinges, zero at their gimbal lock. Below [`SINGULAR_GRAM`]
    /// with three hinges, [`Self::dof_rows`] damps the hinges' rows (exact above).
    pub fn hinge_gram(&self, a: &Pose, q: &[f64; MAX_DOF]) -> f64 {
        let nh = self.n_hinges;
        let w = self.world_hinge_axes(a, q);
        match nh {
            0 => 1.0,
            1 => w[0].length_squared(),
            2 => w[0].cross(w[1]).length_squared(),
            _ => {
                let triple = w[0].dot(w[1].cross(w[2]));
                triple * triple
            }
        }
    }

    /// Value and Jacobian of the `6 − dof` rows (the rest of the arrays zero).
    pub fn jacobian6(&self, a: &Pose, b: &Pose) -> TwistJacobian<MAX_DOF> {
        let mut j = TwistJacobian {
            value: [0.0; MAX_DOF],
            rows: [[DVec3::ZERO; 4]; MAX_DOF],
        };
        self.jacobian6_into(a, b, &mut j.value, &mut j.rows);
        j
    }

    /// [`Self::jacobian6`]'s first [`Self::rows`] values and rows written into `value`
    /// and `rows` (the same operations, so the same bits; the other entries are left as
    /// they were), for a caller that keeps the rows in place (no copy of a returned
    /// [`TwistJacobian`]).
    #[inline]
    pub fn jacobian6_into(
        &self,
        a: &Pose,
        b: &Pose,
        value: &mut [f64; MAX_DOF],
        rows: &mut [[DVec3; 4]; MAX_DOF],
    ) {
        let mut r = 0;
        let d = self.point.sep(a, b);
        if let Some(delta) = self.skew {
            let ea = FrameExpr::dir_a(a, self.e1_a);
            let eb = FrameExpr::dir_b(b, self.axes[1]);
            let s = 0.5 / delta;
            value[0] = ea.value.dot(d.value);
            rows[0] = dot_grad(&ea, &d);
            value[1] = d.value.dot(eb.value);
            rows[1] = dot_grad(&d, &eb);
            value[2] = (d.value.dot(d.value) - delta * delta) * s;
            rows[2] = dot_grad(&d, &d).map(|g| g * s);
            value[3] = ea.value.dot(eb.value) - self.c0;
            rows[3] = dot_grad(&ea, &eb);
            return;
        }
        for k in 0..3 - self.n_slides {
            let na = FrameExpr::dir_a(a, self.normals[k]);
            value[r] = na.value.dot(d.value);
            rows[r] = dot_grad(&na, &d);
            r += 1;
        }
        match self.n_hinges {
            0 => self
                .orient
                .rows(a, b, &mut value[r..r + 3], &mut rows[r..r + 3]),
            1 => {
                let ub = FrameExpr::dir_b(b, self.axes[0]);
                for p in &self.perp {
                    let na = FrameExpr::dir_a(a, *p);
                    value[r] = na.value.dot(ub.value);
                    rows[r] = dot_grad(&na, &ub);
                    r += 1;
                }
            }
            2 => {
                let ea = FrameExpr::dir_a(a, self.e1_a);
                let eb = FrameExpr::dir_b(b, self.axes[1]);
                value[r] = ea.value.dot(eb.value) - self.c0;
                rows[r] = dot_grad(&ea, &eb);
            }
            _ => {}
        }
    }

    /// The values of the `6 − dof` rows of [`Self::jacobian6`] alone (the rest zero):
    /// the same dot products of the same frame vectors, so the same bits, without the
    /// Jacobian rows (`dot_grad`), for callers that need `C` only (SHAKE's residual,
    /// the separation checks).
    pub fn value6(&self, a: &Pose, b: &Pose) -> [f64; MAX_DOF] {
        let mut v = [0.0; MAX_DOF];
        let mut r = 0;
        let d = self.point.sep_value(a, b);
        if let Some(delta) = self.skew {
            let ea = a.q * self.e1_a;
            let eb = b.q * self.axes[1];
            let s = 0.5 / delta;
            v[0] = ea.dot(d);
            v[1] = d.dot(eb);
            v[2] = (d.dot(d) - delta * delta) * s;
            v[3] = ea.dot(eb) - self.c0;
            return v;
        }
        for k in 0..3 - self.n_slides {
            v[r] = (a.q * self.normals[k]).dot(d);
            r += 1;
        }
        match self.n_hinges {
            0 => self.orient.values(a, b, &mut v[r..r + 3]),
            1 => {
                let ub = b.q * self.axes[0];
                for p in &self.perp {
                    v[r] = (a.q * *p).dot(ub);
                    r += 1;
                }
            }
            2 => {
                let ea = a.q * self.e1_a;
                let eb = b.q * self.axes[1];
                v[r] = ea.dot(eb) - self.c0;
            }
            _ => {}
        }
        v
    }

    /// `Σ_r w_r ∂²C_r` of the rows (`w` beyond [`Self::rows`] ignored).
    pub fn curvature6(&self, a: &Pose, b: &Pose, w: &[f64; MAX_DOF]) -> TwistCurvature {
        let mut h = TwistCurvature::ZERO;
        let mut r = 0;
        let d = self.point.sep(a, b);
        if let Some(delta) = self.skew {
            let ea = FrameExpr::dir_a(a, self.e1_a);
            let eb = FrameExpr::dir_b(b, self.axes[1]);
            add_dot_hessian(&ea, &d, w[0], &mut h);
            add_dot_hessian(&d, &eb, w[1], &mut h);
            add_dot_hessian(&d, &d, w[2] * 0.5 / delta, &mut h);
            add_dot_hessian(&ea, &eb, w[3], &mut h);
            return h;
        }
        for k in 0..3 - self.n_slides {
            add_dot_hessian(&FrameExpr::dir_a(a, self.normals[k]), &d, w[r], &mut h);
            r += 1;
        }
        match self.n_hinges {
            0 => self.orient.curvature(a, b, &w[r..r + 3], &mut h),
            1 => {
                let ub = FrameExpr::dir_b(b, self.axes[0]);
                for p in &self.perp {
                    add_dot_hessian(&FrameExpr::dir_a(a, *p), &ub, w[r], &mut h);
                    r += 1;
                }
            }
            2 => {
                let ea = FrameExpr::dir_a(a, self.e1_a);
                let eb = FrameExpr::dir_b(b, self.axes[1]);
                add_dot_hessian(&ea, &eb, w[r], &mut h);
            }
            _ => {}
        }
        h
    }
}

/// The rows padded to six (unused rows zero), so the generic derivative checks apply.
impl BodyConstraint<MAX_DOF> for Compound {
    fn value(&self, a: &Pose, b: &Pose) -> [f64; MAX_DOF] {
        self.value6(a, b)
    }
    fn jacobian(&self, a: &Pose, b: &Pose) -> TwistJacobian<MAX_DOF> {
        self.jacobian6(a, b)
    }
    fn curvature(&self, a: &Pose, b: &Pose, w: &[f64; MAX_DOF]) -> TwistCurvature {
        self.curvature6(a, b, w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `value6` gives the bits of `jacobian6`'s value for every slide and hinge count
    /// and for hinges on skew lines, at poses off the manifold.
    #[test]
    fn value6_is_jacobian6_value_bit_for_bit() {
        let a0 = Pose::new(DVec3::new(0.1, -0.2, 0.3), DQuat::from_rotation_y(0.3)).unwrap();
        let b0 = Pose::new(DVec3::new(0.4, 0.1, -0.2), DQuat::from_rotation_x(-0.7)).unwrap();
        let a = Pose::new(
            a0.x + DVec3::new(0.01, 0.02, -0.03),
            (DQuat::from_rotation_z(0.2) * a0.q).normalize(),
        )
        .unwrap();
        let b = Pose::new(
            b0.x + DVec3::new(-0.02, 0.05, 0.01),
            (DQuat::from_rotation_x(0.4) * DQuat::from_rotation_y(-0.3) * b0.q).normalize(),
        )
        .unwrap();
        let axes = [
            DVec3::X,
            DVec3::new(0.0, 1.0, 0.2).normalize(),
            DVec3::new(0.3, 0.1, 1.0).normalize(),
        ];
        let anchor = DVec3::new(0.2, 0.0, 0.1);
        let check = |j: &Compound| {
            let (v, jac) = (j.value6(&a, &b), j.jacobian6(&a, &b).value);
            assert_eq!(v.map(f64::to_bits), jac.map(f64::to_bits));
            assert!(v[..j.rows()].iter().any(|x| *x != 0.0) || j.rows() == 0);
        };
        for ns in 0..=3 {
            for nh in 0..=3 - ns {
                check(&Compound::from_world(&a0, &b0, anchor, &axes[..ns], &axes[..nh]).unwrap());
            }
        }
        let skew = Compound::from_lines(
            &a0,
            &b0,
            &[],
            &[
                (anchor, axes[0]),
                (anchor + DVec3::new(0.0, 0.1, 0.05), axes[1]),
            ],
        )
        .unwrap();
        assert!(skew.skew_distance().is_some());
        check(&skew);
    }

    /// `nearest` keeps the bits of the loop over both solutions (the first kept unless
    /// the second is strictly nearer) for solutions either side of each other, ties
    /// and non-finite distances; each case is exact (bit for bit).
    #[test]
    fn nearest_is_the_loop_over_both_solutions() {
        let whole = |(q1, q2, p): (f64, f64, f64)| {
            let q3 = 0.5 * q1 - q2;
            ([q1, q2, q3], p + q3.abs())
        };
        let looped = |one, two| {
            let (mut best, mut best_d) = ([0.0; 3], f64::INFINITY);
            for s in [one, two] {
                let (q, d) = whole(s);
                if d < best_d {
                    (best, best_d) = (q, d);
                }
            }
            best
        };
        let sol = |q1: f64, q2: f64| (q1, q2, q1.abs() + q2.abs());
        let cases = [
            (sol(0.1, 0.2), sol(3.0, -2.9)),
            (sol(3.0, -2.9), sol(0.1, 0.2)),
            (sol(0.3, 0.0), sol(0.0, 0.3)),
            (sol(0.2, 0.1), sol(0.2, 0.1)),
            (sol(0.0, 0.0), sol(0.0, 0.0)),
            (sol(0.1, 1.0), sol(0.9, -0.05)),
            (sol(f64::NAN, 0.1), sol(0.2, 0.3)),
            (sol(0.2, 0.3), sol(f64::INFINITY, 0.1)),
            (sol(0.2, f64::NAN), sol(f64::NAN, 0.1)),
        ];
        for (one, two) in cases {
            let got = nearest(one, two, whole).map(f64::to_bits);
            assert_eq!(got, looped(one, two).map(f64::to_bits), "{one:?} {two:?}");
        }
    }

    /// Three hinges z, y, x (humanoid_CMU's shoulder) at `q₂ = π/2 − δ`: away from the
    /// gimbal lock (`det = sin² δ ≥ SINGULAR_GRAM`) the rate rows are the exact dual
    /// basis of the world hinge axes (`c_k · w_l = δ_kl`); at the lock they stay bounded
    /// by `1/(2λ₀)` (the exact ones grow as `1/sin δ`).
    #[test]
    fn three_hinge_rows_are_exact_away_from_the_lock_and_bounded_at_it() {
        let axes = [DVec3::Z, DVec3::Y, DVec3::X];
        let j = Compound::from_world(&Pose::IDENTITY, &Pose::IDENTITY, DVec3::ZERO, &[], &axes)
            .unwrap();
        let rows_at = |delta: f64| {
            let q = [
                0.3,
                core::f64::consts::FRAC_PI_2 - delta,
                -0.4,
                0.0,
                0.0,
                0.0,
            ];
            let r = DQuat::from_rotation_z(q[0])
                * DQuat::from_rotation_y(q[1])
                * DQuat::from_rotation_x(q[2]);
            let b = Pose::new(DVec3::ZERO, r).unwrap();
            let w = [
                DVec3::Z,
                DQuat::from_rotation_z(q[0]) * DVec3::Y,
                DQuat::from_rotation_z(q[0]) * DQuat::from_rotation_y(q[1]) * DVec3::X,
            ];
            (j.dof_rows(&Pose::IDENTITY, &b, &q), w)
        };
        // δ = 0.2: det = sin² 0.2 = 0.039, undamped.
        let (rows, w) = rows_at(0.2);
        let mut worst: f64 = 0.0;
        for k in 0..3 {
            for (l, wl) in w.iter().enumerate() {
                let want = if k == l { 1.0 } else { 0.0 };
                worst = worst.max((rows[k][3].dot(*wl) - want).abs());
            }
        }
        // Measured 1.1e-15.
        assert!(worst < 1e-12, "{worst}");
        // δ from 1e-8 to 0.1 (exact rows would reach 1e8 in length): the longest row is
        // `max_σ σ/(σ² + λ²)` with `λ² = λ₀² (1 − σ²/ε²)`, `1/(2λ₀ √(1 − λ₀²/ε²))` =
        // 50.25 at `σ ≈ λ₀`.
        let mut longest: f64 = 0.0;
        for i in 0..=140 {
            let delta = 1e-8 * libm::pow(10.0, i as f64 / 20.0);
            let (rows, _) = rows_at(delta);
            for r in &rows[..3] {
                longest = longest.max(r[3].length());
            }
        }
        // Measured 35.7 (the sweep's points miss the peak) against the bound 50.3.
        assert!(longest < 50.3, "{longest}");
        let (rows, w) = rows_at(1e-7);
        // The middle hinge's rate (its axis ⊥ the other two) is still kept to λ₀²:
        // c₂ · w₂ = 1/(1 + λ²).
        let c2 = rows[1][3].dot(w[1]);
        // Measured 1 − 1.0e-4 (λ₀² at the lock).
        assert!((c2 - 1.0).abs() < 2e-4, "{c2}");
    }
}
