//! From MuJoCo's generalized coordinates to maximal coordinates: positions as in
//! `mj_kinematics`, velocities as in `mj_comVel`.
//!
//! Generalized coordinates, per joint in [`Model::joints`] order (`qpos_adr`, `dof_adr`).
//! The joints of one body are applied in order, each about its own anchor and axis in the
//! frame the previous ones left:
//! - hinge: angle (rad) about the joint axis through the anchor, measured from `ref`
//!   (the body turns by `q − ref`); rate (rad/s);
//! - slide: displacement (m) along the axis, from `ref`; rate (m/s);
//! - ball: quaternion `[w, x, y, z]` of the child relative to the frame before it, about
//!   the anchor; angular velocity (rad/s) in the **child body's** final frame;
//! - free: world position of the body frame origin and orientation quaternion; linear
//!   velocity of the body frame origin in **world** coordinates, then angular velocity
//!   in the **body** frame (MuJoCo's `cdof` for free joints).
//!
//! Quaternions in `qpos` are normalised as MuJoCo does (a zero quaternion counts as the
//! identity).

use crate::error::MjcfError;
use crate::math::{self, Q, V3};
use crate::model::{BodyState, Joint, JointKind, Keyframe, Model};

impl Model {
    /// Number of generalized positions (hinge, slide 1; ball 4; free 7).
    pub fn nq(&self) -> usize {
        self.joints.iter().map(|j| qpos_len(j.kind)).sum()
    }

    /// Number of generalized velocities (hinge, slide 1; ball 3; free 6).
    pub fn nv(&self) -> usize {
        self.joints.iter().map(|j| dof_len(j.kind)).sum()
    }

    /// MuJoCo's `qpos0`: hinge and slide at their `ref` ([`Joint::reference`]), ball
    /// identity, free joint at the body's default pose.
    pub fn qpos0(&self) -> Vec<f64> {
        let mut q = vec![0.0; self.nq()];
        for j in &self.joints {
            let a = j.qpos_adr;
            // (`get_mut` keeps a hand-built model with bad addresses from panicking;
            // `body_states` reports those.)
            match (j.kind, q.get_mut(a..a.saturating_add(qpos_len(j.kind)))) {
                (JointKind::Hinge | JointKind::Slide, Some(s)) => s[0] = j.reference,
                (JointKind::Ball, Some(s)) => s[0] = 1.0,
                (JointKind::Free, Some(s)) => {
                    if let Some(b) = self.bodies.get(j.body) {
                        s[..3].copy_from_slice(&b.pos);
                        s[3..].copy_from_slice(&b.quat);
                    }
                }
                _ => {}
            }
        }
        q
    }

    /// The keyframe called `name`.
    pub fn keyframe(&self, name: &str) -> Result<&Keyframe, MjcfError> {
        self.keyframes
            .iter()
            .find(|k| k.name == name)
            .ok_or_else(|| MjcfError::UnknownKeyframe(name.to_string()))
    }

    /// Every body's world state for keyframe `key`, or the default pose at rest
    /// (`qpos0`, zero velocity) for `None`.
    pub fn initial_state(&self, key: Option<&str>) -> Result<Vec<BodyState>, MjcfError> {
        match key {
            Some(name) => {
                let k = self.keyframe(name)?;
                self.body_states(&k.qpos, &k.qvel)
            }
            None => self.body_states(&self.qpos0(), &vec![0.0; self.nv()]),
        }
    }

    /// Every body's world state (in [`Model::bodies`] order) for the generalized
    /// positions `qpos` (length [`Model::nq`]) and velocities `qvel` (length
    /// [`Model::nv`]). `vel` is the velocity of each body's centre of mass.
    ///
    /// Errors: [`MjcfError::StateLength`] or [`MjcfError::NonFiniteState`] (`what` =
    /// `"qpos"` / `"qvel"`) for bad input; `NonFiniteState` with `what = "body state"`
    /// and `index` = the body when a result overflows (huge but finite input);
    /// [`MjcfError::Invalid`] for a hand-built model with inconsistent joint addresses.
    pub fn body_states(&self, qpos: &[f64], qvel: &[f64]) -> Result<Vec<BodyState>, MjcfError> {
        check_vector("qpos", qpos, self.nq())?;
        check_vector("qvel", qvel, self.nv())?;
        self.check_joints()?;
        let mut joints_of: Vec<Vec<&Joint>> = vec![Vec::new(); self.bodies.len()];
        for j in &self.joints {
            if let Some(slot) = joints_of.get_mut(j.body) {
                slot.push(j);
            }
        }
        // World pose and twist (angular velocity, velocity of the body frame origin).
        let mut pose: Vec<(V3, Q)> = Vec::with_capacity(self.bodies.len());
        let mut twist: Vec<(V3, V3)> = Vec::with_capacity(self.bodies.len());
        let mut out = Vec::with_capacity(self.bodies.len());
        for (i, body) in self.bodies.iter().enumerate() {
            // Parents precede children (depth-first document order); anything else is
            // treated as a child of the world rather than indexed out of range.
            let parent = body.parent.filter(|p| *p < i);
            let (default_ppos, default_pquat, ppos, pquat, pomega, pvel) = match parent {
                Some(p) => {
                    let pb = &self.bodies[p];
                    (
                        pb.pos, pb.quat, pose[p].0, pose[p].1, twist[p].0, twist[p].1,
                    )
                }
                None => (
                    [0.0; 3],
                    math::QUAT_ID,
                    [0.0; 3],
                    math::QUAT_ID,
                    [0.0; 3],
                    [0.0; 3],
                ),
            };
            // The body's fixed frame in its parent, recovered from the default pose.
            let local_quat = math::mul_quat(math::conj(default_pquat), body.quat);
            let local_pos =
                math::rotate(math::conj(default_pquat), math::sub(body.pos, default_ppos));

            let mut xpos;
            let mut xquat;
            let omega;
            let vel;
            match joints_of[i].as_slice() {
                [j] if j.kind == JointKind::Free => {
                    let a = j.qpos_adr;
                    let d = j.dof_adr;
                    xpos = [qpos[a], qpos[a + 1], qpos[a + 2]];
                    xquat = math::normalize4([qpos[a + 3], qpos[a + 4], qpos[a + 5], qpos[a + 6]]);
                    vel = [qvel[d], qvel[d + 1], qvel[d + 2]];
                    omega = math::rotate(xquat, [qvel[d + 3], qvel[d + 4], qvel[d + 5]]);
                }
                joints => {
                    // mj_kinematics: each joint in order, about its own anchor and axis
                    // in the frame the previous joints left.
                    xpos = math::add(ppos, math::rotate(pquat, local_pos));
                    xquat = math::mul_quat(pquat, local_quat);
                    // Per joint: its world anchor and axis at its stage (MuJoCo's
                    // xanchor, xaxis).
                    let mut stages = Vec::with_capacity(joints.len());
                    for j in joints {
                        let a = j.qpos_adr;
                        let xaxis = math::rotate(xquat, j.axis);
                        let xanchor = math::add(math::rotate(xquat, j.pos), xpos);
                        match j.kind {
                            JointKind::Slide => {
                                xpos = math::add(xpos, math::scale(xaxis, qpos[a] - j.reference));
                            }
                            JointKind::Hinge | JointKind::Ball => {
                                let qloc = if j.kind == JointKind::Hinge {
                                    math::axis_angle(j.axis, qpos[a] - j.reference)
                                } else {
                                    math::normalize4([
                                        qpos[a],
                                        qpos[a + 1],
                                        qpos[a + 2],
                                        qpos[a + 3],
                                    ])
                                };
                                xquat = math::mul_quat(xquat, qloc);
                                xpos = math::sub(xanchor, math::rotate(xquat, j.pos));
                            }
                            // Rejected by check_joints (a free joint must be alone).
                            JointKind::Free => {}
                        }
                        stages.push((j, xanchor, xaxis));
                    }
                    // mj_comVel: the parent's twist carried to the body origin, plus each
                    // dof's motion (hinge about its anchor and axis, slide along its
                    // axis, ball about its anchor along the body's final axes).
                    let final_quat = math::normalize4(xquat);
                    let mut w = pomega;
                    let mut v = math::add(pvel, math::cross(pomega, math::sub(xpos, ppos)));
                    for (j, xanchor, xaxis) in stages {
                        let d = j.dof_adr;
                        match j.kind {
                            JointKind::Slide => v = math::add(v, math::scale(xaxis, qvel[d])),
                            JointKind::Hinge | JointKind::Ball => {
                                let rel = if j.kind == JointKind::Hinge {
                                    math::scale(xaxis, qvel[d])
                                } else {
                                    math::rotate(final_quat, [qvel[d], qvel[d + 1], qvel[d + 2]])
                                };
                                v = math::add(v, math::cross(rel, math::sub(xpos, xanchor)));
                                w = math::add(w, rel);
                            }
                            JointKind::Free => {}
                        }
                    }
                    omega = w;
                    vel = v;
                }
            }
            xquat = math::normalize4(xquat);
            let com = math::add(xpos, math::rotate(xquat, body.com));
            let com_vel = math::add(vel, math::cross(omega, math::sub(com, xpos)));
            let all = [xpos, com, com_vel, omega];
            if all.iter().flatten().chain(&xquat).any(|x| !x.is_finite()) {
                return Err(MjcfError::NonFiniteState {
                    what: "body state",
                    index: i,
                });
            }
            pose.push((xpos, xquat));
            twist.push((omega, vel));
            out.push(BodyState {
                pos: xpos,
                quat: xquat,
                com,
                vel: com_vel,
                omega,
            });
        }
        Ok(out)
    }
}

impl Model {
    /// Joint addresses and bodies consistent with `nq`, `nv` and the body list (always
    /// true for a loaded model; checked for hand-built ones).
    fn check_joints(&self) -> Result<(), MjcfError> {
        let (nq, nv) = (self.nq(), self.nv());
        let mut owner = vec![0usize; self.bodies.len()];
        for j in &self.joints {
            let bad = |reason: &str| MjcfError::Invalid {
                element: "joint".into(),
                line: j.line,
                reason: format!("joint \"{}\": {reason}", j.name),
            };
            if j.qpos_adr.saturating_add(qpos_len(j.kind)) > nq
                || j.dof_adr.saturating_add(dof_len(j.kind)) > nv
            {
                return Err(bad("qpos_adr or dof_adr out of range"));
            }
            match owner.get_mut(j.body) {
                None => return Err(bad("body index out of range")),
                Some(n) => *n += 1,
            }
        }
        for j in &self.joints {
            if j.kind == JointKind::Free && owner[j.body] > 1 {
                return Err(MjcfError::Invalid {
                    element: "joint".into(),
                    line: j.line,
                    reason: format!("joint \"{}\": free joint can only appear by itself", j.name),
                });
            }
        }
        Ok(())
    }
}

fn qpos_len(kind: JointKind) -> usize {
    match kind {
        JointKind::Hinge | JointKind::Slide => 1,
        JointKind::Ball => 4,
        JointKind::Free => 7,
    }
}

fn dof_len(kind: JointKind) -> usize {
    match kind {
        JointKind::Hinge | JointKind::Slide => 1,
        JointKind::Ball => 3,
        JointKind::Free => 6,
    }
}

fn check_vector(what: &'static str, v: &[f64], expected: usize) -> Result<(), MjcfError> {
    if v.len() != expected {
        return Err(MjcfError::StateLength {
            what,
            expected,
            got: v.len(),
        });
    }
    if let Some(index) = v.iter().position(|x| !x.is_finite()) {
        return Err(MjcfError::NonFiniteState { what, index });
    }
    Ok(())
}
