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
//! Every row is a dot product of [`crate::frame_expr`] vectors, so value, Jacobian and
//! curvature come from the same derivation as the other joints (and are checked the
//! same way). [`Compound::coordinates`] recovers MuJoCo's `qpos` of the composed joints
//! from the two poses, and [`Compound::dof_rows`] the rows of their rates `q̇`.

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
    orient: Orientation,
    /// The rest relative rotation `R_off = A₀ᵀ B₀`.
    rel0: DQuat,
}

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
    let p = from - axis * axis.dot(from);
    let q = to - axis * axis.dot(to);
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

/// Inverse of the `n × n` Gram matrix of `v` applied to get the dual basis `c_k` with
/// `c_k · v_l = δ_kl` (`n ≤ 3`, `v` independent).
fn dual_basis(v: &[DVec3], out: &mut [DVec3]) {
    let n = v.len();
    let mut g = [[0.0; 3]; 3];
    for i in 0..n {
        for j in 0..n {
            g[i][j] = v[i].dot(v[j]);
        }
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
            orient: Orientation::from_world(a, b),
            rel0,
        })
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

    /// Anchor in body `a`'s frame.
    pub fn anchor_a(&self) -> DVec3 {
        self.point.r_a
    }

    /// Anchor in body `b`'s frame.
    pub fn anchor_b(&self) -> DVec3 {
        self.point.r_b
    }

    /// Whether the joint has translation rows (fewer than three slides); their values
    /// are the first [`Self::translation_rows`] entries of the value.
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
                let t = d * e[2];
                let k = e[0].dot(e[1]);
                let (at, be) = (e[0].dot(t), e[1].dot(e[2]));
                let den = 1.0 - k * k;
                let alpha = (at - k * be) / den;
                let beta = (be - k * at) / den;
                let n = e[0].cross(e[1]);
                let g2 = (1.0 - alpha * alpha - beta * beta - 2.0 * alpha * beta * k)
                    / n.length_squared();
                let g = libm::sqrt(g2.max(0.0));
                let mut best = [0.0; 3];
                let mut best_d = f64::INFINITY;
                for sign in [1.0, -1.0] {
                    let c = e[0] * alpha + e[1] * beta + n * (g * sign);
                    let q2 = angle_about(e[1], e[2], c);
                    let q1 = angle_about(e[0], c, t);
                    let rest = (DQuat::from_axis_angle(e[0], q1)
                        * DQuat::from_axis_angle(e[1], q2))
                    .conjugate()
                        * d;
                    let q3 = twist_angle(rest, e[2]);
                    let dist = (q1 - hint[ns]).abs()
                        + (q2 - hint[ns + 1]).abs()
                        + (q3 - hint[ns + 2]).abs();
                    if dist < best_d {
                        best_d = dist;
                        best = [q1, q2, q3];
                    }
                }
                q[ns..ns + 3].copy_from_slice(&best);
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
            let mut m = a.q * self.rel0;
            let mut w = [DVec3::ZERO; 3];
            for k in 0..nh {
                w[k] = m * self.axes[k];
                m *= DQuat::from_axis_angle(self.axes[k], q[ns + k]);
            }
            let mut c = [DVec3::ZERO; 3];
            dual_basis(&w[..nh], &mut c[..nh]);
            for k in 0..nh {
                rows[ns + k] = [DVec3::ZERO, -c[k], DVec3::ZERO, c[k]];
            }
        }
        rows
    }

    /// Value and Jacobian of the `6 − dof` rows (the rest of the arrays zero).
    pub fn jacobian6(&self, a: &Pose, b: &Pose) -> TwistJacobian<MAX_DOF> {
        let mut j = TwistJacobian {
            value: [0.0; MAX_DOF],
            rows: [[DVec3::ZERO; 4]; MAX_DOF],
        };
        let mut r = 0;
        let d = self.point.sep(a, b);
        for k in 0..3 - self.n_slides {
            let na = FrameExpr::dir_a(a, self.normals[k]);
            j.value[r] = na.value.dot(d.value);
            j.rows[r] = dot_grad(&na, &d);
            r += 1;
        }
        match self.n_hinges {
            0 => self
                .orient
                .rows(a, b, &mut j.value[r..r + 3], &mut j.rows[r..r + 3]),
            1 => {
                let ub = FrameExpr::dir_b(b, self.axes[0]);
                for p in &self.perp {
                    let na = FrameExpr::dir_a(a, *p);
                    j.value[r] = na.value.dot(ub.value);
                    j.rows[r] = dot_grad(&na, &ub);
                    r += 1;
                }
            }
            2 => {
                let ea = FrameExpr::dir_a(a, self.e1_a);
                let eb = FrameExpr::dir_b(b, self.axes[1]);
                j.value[r] = ea.value.dot(eb.value) - self.c0;
                j.rows[r] = dot_grad(&ea, &eb);
            }
            _ => {}
        }
        j
    }

    /// `Σ_r w_r ∂²C_r` of the rows (`w` beyond [`Self::rows`] ignored).
    pub fn curvature6(&self, a: &Pose, b: &Pose, w: &[f64; MAX_DOF]) -> TwistCurvature {
        let mut h = TwistCurvature::ZERO;
        let mut r = 0;
        let d = self.point.sep(a, b);
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
        self.jacobian6(a, b).value
    }
    fn jacobian(&self, a: &Pose, b: &Pose) -> TwistJacobian<MAX_DOF> {
        self.jacobian6(a, b)
    }
    fn curvature(&self, a: &Pose, b: &Pose, w: &[f64; MAX_DOF]) -> TwistCurvature {
        self.curvature6(a, b, w)
    }
}
