//! Joint `springdamper="timeconst dampratio"`: MuJoCo 4.0 sets the joint's stiffness
//! and damping so that the joint, alone against the rest of the model at `qpos0`, is a
//! mass–spring–damper with that time constant and damping ratio (`mj_setConst`):
//!
//! ```text
//! m = 1 / (M⁻¹)_ii   (M the joint-space inertia at qpos0, armature included),
//! k = m / (timeconst · dampratio)²,   d = 2 m / timeconst,
//! ```
//!
//! so `√(k/m) = 1/(timeconst · dampratio)` and `d / (2√(k m)) = dampratio`; `m` is
//! MuJoCo's `1/dof_invweight0`. Both numbers must be positive to take effect (the
//! loader keeps the written stiffness and damping otherwise).
//!
//! `M = Σ_b J_bᵀ diag(m_b, I_b) J_b + diag(armature)` with `J_b` the velocity of body
//! `b`'s centre of mass and its angular velocity per unit rate of each degree of
//! freedom: a hinge about `a` through `p` moves every body below it with `ω = a`,
//! `v = a × (c − p)`; a slide along `a` with `v = a`; a ball or free joint with three
//! such rotations (and three translations) about world axes — the diagonal of `M⁻¹`
//! for the other joints does not depend on which basis spans a joint's motions.

use crate::error::MjcfError;
use crate::math::{self, V3};
use crate::model::{JointKind, Model};

/// One column of the body Jacobians: the motion of each body per unit rate.
type Column = Vec<(V3, V3)>;

/// Sets `stiffness` and `damping` of each `(joint, [timeconst, dampratio])` of `model`
/// (hinge or slide joints; its masses final) from the inertia at `qpos0`. Errors: a
/// singular joint-space inertia (a joint that moves no mass and has no armature),
/// naming the first such joint.
pub(crate) fn apply(model: &mut Model, joints: &[(usize, [f64; 2])]) -> Result<(), MjcfError> {
    if joints.is_empty() {
        return Ok(());
    }
    let cols = columns(model);
    let n = cols.len();
    // M = Σ_b (m v_i·v_k + ω_iᵀ I_w ω_k) + armature on the diagonal.
    let inertia: Vec<[[f64; 3]; 3]> = model
        .bodies
        .iter()
        .map(|b| {
            let r = math::quat_to_mat(b.quat);
            math::mat_mul(&math::mat_mul(&r, &b.inertia), &math::transpose(&r))
        })
        .collect();
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        for k in 0..=i {
            let mut s = 0.0;
            for (b, body) in model.bodies.iter().enumerate() {
                let ((vi, wi), (vk, wk)) = (cols[i][b], cols[k][b]);
                s += body.mass * math::dot(vi, vk) + math::dot(wi, math::mat_vec(&inertia[b], wk));
            }
            m[i * n + k] = s;
            m[k * n + i] = s;
        }
    }
    for j in &model.joints {
        let dofs = match j.kind {
            JointKind::Hinge | JointKind::Slide => 1,
            JointKind::Ball => 3,
            JointKind::Free => 6,
        };
        for d in j.dof_adr..j.dof_adr + dofs {
            m[d * n + d] += j.armature;
        }
    }
    let l = cholesky(&mut m, n);
    for &(ji, [timeconst, dampratio]) in joints {
        let joint = &model.joints[ji];
        let singular = || {
            MjcfError::Invalid {
            element: "joint".into(),
            line: joint.line,
            reason: format!(
                "springdamper: the joint-space inertia at qpos0 is singular (joint {:?} moves no mass)",
                joint.name
            ),
        }
        };
        if !l {
            return Err(singular());
        }
        // (M⁻¹)_ii = |L⁻¹ e_i|².
        let i = joint.dof_adr;
        let mut y = vec![0.0; n];
        y[i] = 1.0;
        for r in i..n {
            let s: f64 = (i..r).map(|c| m[r * n + c] * y[c]).sum();
            y[r] = (y[r] - s) / m[r * n + r];
        }
        let inv: f64 = y.iter().map(|v| v * v).sum();
        let mass = 1.0 / inv;
        if !mass.is_finite() || !(mass > 0.0) {
            return Err(singular());
        }
        let joint = &mut model.joints[ji];
        joint.stiffness = mass / (timeconst * dampratio * timeconst * dampratio);
        joint.damping = 2.0 * mass / timeconst;
    }
    Ok(())
}

/// The motion columns of every degree of freedom (in `qvel` order), each with a
/// `(v, ω)` per body.
fn columns(model: &Model) -> Vec<Column> {
    let com: Vec<V3> = model
        .bodies
        .iter()
        .map(|b| math::add(b.pos, math::rotate(b.quat, b.com)))
        .collect();
    // Whether body `b` is `root` or below it.
    let below = |b: usize, root: usize| {
        let mut at = Some(b);
        while let Some(x) = at {
            if x == root {
                return true;
            }
            at = model.bodies[x].parent;
        }
        false
    };
    let mut cols = Vec::new();
    let units = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for j in &model.joints {
        let body = &model.bodies[j.body];
        let anchor = math::add(body.pos, math::rotate(body.quat, j.pos));
        let axis = math::rotate(body.quat, j.axis);
        let rotation = |a: V3| -> Column {
            (0..model.bodies.len())
                .map(|b| {
                    if below(b, j.body) {
                        (math::cross(a, math::sub(com[b], anchor)), a)
                    } else {
                        ([0.0; 3], [0.0; 3])
                    }
                })
                .collect()
        };
        let translation = |a: V3| -> Column {
            (0..model.bodies.len())
                .map(|b| {
                    if below(b, j.body) {
                        (a, [0.0; 3])
                    } else {
                        ([0.0; 3], [0.0; 3])
                    }
                })
                .collect()
        };
        match j.kind {
            JointKind::Hinge => cols.push(rotation(axis)),
            JointKind::Slide => cols.push(translation(axis)),
            JointKind::Ball => cols.extend(units.iter().map(|&u| rotation(u))),
            JointKind::Free => {
                cols.extend(units.iter().map(|&u| translation(u)));
                cols.extend(units.iter().map(|&u| rotation(u)));
            }
        }
    }
    cols
}

/// In-place Cholesky `M = L Lᵀ` (lower triangle of `m`, row-major `n × n`); false when
/// `M` is not positive definite.
fn cholesky(m: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let d = m[j * n + j] - (0..j).map(|k| m[j * n + k] * m[j * n + k]).sum::<f64>();
        if !(d > 0.0) || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        m[j * n + j] = d;
        for i in j + 1..n {
            let s = m[i * n + j] - (0..j).map(|k| m[i * n + k] * m[j * n + k]).sum::<f64>();
            m[i * n + j] = s / d;
        }
    }
    true
}
