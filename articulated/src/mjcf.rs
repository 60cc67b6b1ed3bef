//! Worlds from MJCF scene files (feature `mjcf`; DESIGN.md §8).
//!
//! The loaded [`constraint_mjcf::Model`] is turned into maximal coordinates: every body
//! is a [`RigidBody`] (centre of mass, orientation of the body frame, inertia about the
//! centre of mass in the body frame) and every MuJoCo joint a constraint between the
//! body and its parent, built at the model's default pose (`qpos0`, where MuJoCo's joint
//! frames coincide):
//!
//! | MJCF | here |
//! |---|---|
//! | `hinge` | [`Hinge`] through the joint anchor about its axis, damping on the axis rate; a limited one whose bound lies within 0.1 rad of `±π` (or past it) measured from the middle of its range (`hinge_centres`) |
//! | `ball` | [`Spherical`] at the anchor, damping on the relative angular velocity |
//! | `slide` | [`Prismatic`] along the axis, damping on the sliding rate |
//! | `free` / `freejoint` | no constraint |
//! | no joint | [`Fixed`] weld to the parent (or the world) |
//! | several joints | [`Compound`]: slides, then hinges whose lines meet in one point (up to three) or two hinges alone on skew lines ([`Compound::from_lines`]) |
//! | `equality/connect` | [`Spherical`] between `body1` and `body2` at the anchor |
//! | `equality/joint`, `equality/tendon` | a hard [`Equality`] row (`solref`/`solimp` not modelled) |
//! | `tendon/fixed` | a [`Tendon`] over the joints' coordinates (spring, damping) |
//! | `tendon/spatial` (sites only) | a [`SpatialTendon`] through the sites ([`World::add_spatial_tendon`]) |
//! | tendon `range` (`limited`) | two one-sided rows, [`World::set_tendon_range`] |
//! | `option/flag` `constraint`, `limit`, `equality`, `frictionloss`, `contact` `="disable"` | those rows left out (`constraint`: all of them), as in MuJoCo |
//!
//! The initial state is the keyframe's (MuJoCo's generalized `qpos`/`qvel` converted to
//! body poses and twists by the loader), or the default pose at rest. Geoms only
//! contribute mass here (contact is the contact crate's); a scene whose geoms collide
//! in MuJoCo is reported by [`MjcfScene::collision_geoms`].

use alloc::string::{String, ToString};
use alloc::vec::Vec;

use constraint_core::compound::MAX_DOF;
use constraint_core::{
    Compound, ConstraintError, DMat3, DQuat, DVec3, Fixed, Hinge, Pose, Prismatic, Spherical,
};
use constraint_mjcf::{JointKind as MjKind, Model, Transmission};

use crate::body::RigidBody;
use crate::error::ArticulatedError;
use crate::joint::{Joint, JointKind};
use crate::world::{Actuator, DofSpring, Equality, PathSite, SpatialTendon, Target, Tendon, World};

/// A world built from an MJCF model, with the model's names and time step.
#[derive(Clone, Debug)]
pub struct MjcfScene {
    /// The world (bodies in MJCF document order, world body excluded).
    pub world: World,
    /// Body names, same order.
    pub body_names: Vec<String>,
    /// `option timestep`.
    pub timestep: f64,
    /// Geoms that would collide in MuJoCo (`contype`/`conaffinity` non-zero and contact
    /// not disabled); with the `contact` feature they are the world's colliders.
    pub collision_geoms: usize,
    /// Actuator names, in actuator order (the world's actuator indices).
    pub actuator_names: Vec<String>,
    /// What the file asks for that is read but not modelled (one line each): the
    /// loader's warnings (contact softness) and this adapter's (condim 4 and 6 taken as
    /// 3).
    pub warnings: Vec<String>,
}

fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn quat(q: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize()
}

fn scene_err(e: impl ToString) -> ArticulatedError {
    ArticulatedError::Scene(e.to_string())
}

/// How close (rad) a limited hinge's bound may come to the branch cut of its angle before
/// the loader moves the angle's zero to the middle of the range ([`hinge_centres`]): a
/// limit row holds its joint at the bound to within the projection's tolerance (its
/// speculative row stops the step there), so only a bound at the cut or past it (dm
/// cheetah's `bfoot`, −230°) is in danger; 0.1 rad leaves the bounds 10° from the cut
/// (hopper's hip at −170°, humanoid_CMU's elbows and knees at 170°) as they are.
const BRANCH_CUT_MARGIN: f64 = 0.1;

/// Per MuJoCo joint: the angle `c` (rad) by which the world's hinge measures from the
/// middle of its range instead of from `qpos0` (0: not moved), so that its coordinate is
/// MuJoCo's minus `ref + c` (the loader's *effective reference*).
///
/// A [`Hinge`]'s angle lies in `(−π, π]` (`atan2`, `constraint_core::Hinge::angle`), where
/// MuJoCo's hinge coordinate is unbounded. A range reaching within
/// [`BRANCH_CUT_MARGIN`] of `±π` puts a bound at or next to the cut: humanoid_CMU's
/// `rwristry` (range −180° … 0) crossed −π within a step, read as +π, 3.1 rad past its
/// upper bound, and the projection turned the hand half a turn back to 0 (issue 13: the
/// fingers and thumb, now 1 cm inside each other from both sides, gave a velocity-level
/// problem without a solution). Measured from the range's middle the cut lies
/// `π − (hi − lo)/2` outside both bounds. Single limited hinges only, outside joint
/// equalities (their polynomial is over the coordinates); hinges inside a [`Compound`]
/// keep their zero.
fn hinge_centres(model: &Model, limits: bool) -> Vec<f64> {
    let mut coupled = alloc::vec![false; model.joints.len()];
    for e in &model.joint_equalities {
        for k in core::iter::once(e.joint1).chain(e.joint2) {
            if let Some(c) = coupled.get_mut(k) {
                *c = true;
            }
        }
    }
    let mut per_body = alloc::vec![0usize; model.bodies.len()];
    for j in &model.joints {
        if let Some(n) = per_body.get_mut(j.body) {
            *n += 1;
        }
    }
    model
        .joints
        .iter()
        .zip(&coupled)
        .map(|(j, &coupled)| {
            let lo = j.range[0] - j.reference;
            let hi = j.range[1] - j.reference;
            let alone = per_body.get(j.body) == Some(&1);
            let near_cut = lo.abs().max(hi.abs()) > core::f64::consts::PI - BRANCH_CUT_MARGIN;
            if limits
                && alone
                && !coupled
                && j.limited
                && j.kind == MjKind::Hinge
                && lo.is_finite()
                && hi.is_finite()
                && near_cut
            {
                0.5 * (lo + hi)
            } else {
                0.0
            }
        })
        .collect()
}

impl MjcfScene {
    /// Builds the world of `model` with the state of keyframe `key` (`None`: default pose
    /// at rest).
    pub fn new(model: &Model, key: Option<&str>) -> Result<Self, ArticulatedError> {
        let states = model.initial_state(key).map_err(scene_err)?;
        let mut world = World::new(v3(model.gravity));
        #[allow(unused_mut)]
        let mut warnings = model.warnings.clone();
        // Bodies at the default pose first: joints are defined there.
        let mut default_poses = Vec::with_capacity(model.bodies.len());
        for (i, b) in model.bodies.iter().enumerate() {
            let q = quat(b.quat);
            let com = v3(b.com);
            let pose = Pose {
                x: v3(b.pos) + q * com,
                q,
            };
            let inertia = DMat3::from_cols(v3(b.inertia[0]), v3(b.inertia[1]), v3(b.inertia[2]));
            let body = RigidBody::new(i, b.mass, inertia, pose)
                .map_err(|e| scene_err(format!("body {:?} (line {}): {e}", b.name, b.line)))?
                .with_com(com);
            default_poses.push(pose);
            world.add_body(body)?;
        }
        let pose_of = |b: Option<usize>| b.map_or(Pose::IDENTITY, |i| default_poses[i]);
        reject_unsupported(model)?;
        // The MuJoCo joints of each body, in document order.
        let mut joints_of: Vec<Vec<usize>> = alloc::vec![Vec::new(); model.bodies.len()];
        for (k, j) in model.joints.iter().enumerate() {
            if let Some(slot) = joints_of.get_mut(j.body) {
                slot.push(k);
            }
        }
        // Hinges measured from the middle of their range (`hinge_centres`), and the
        // effective references: MuJoCo's coordinate is ours plus `reference[k]`.
        let centres = hinge_centres(model, !model.options.disabled("limit"));
        let reference: Vec<f64> = model
            .joints
            .iter()
            .zip(&centres)
            .map(|(j, &c)| {
                if c == 0.0 {
                    j.reference
                } else {
                    j.reference + c
                }
            })
            .collect();
        // Where each MuJoCo joint ended up: (world joint, its degree of freedom).
        let mut placed: Vec<Option<(usize, usize)>> = alloc::vec![None; model.joints.len()];
        for (i, b) in model.bodies.iter().enumerate() {
            let pa = pose_of(b.parent);
            let pb = default_poses[i];
            let origin = v3(b.pos);
            let r = quat(b.quat);
            let wrap = |e| scene_err(format!("body {:?} (line {}): {e}", b.name, b.line));
            let js: Vec<&constraint_mjcf::Joint> =
                joints_of[i].iter().map(|&k| &model.joints[k]).collect();
            let (kind, damping) = match js.as_slice() {
                [] => (
                    JointKind::Fixed(Fixed::from_world(&pa, &pb, origin).map_err(wrap)?),
                    0.0,
                ),
                [j] if j.kind == MjKind::Free => continue,
                [j] => {
                    let anchor = origin + r * v3(j.pos);
                    let axis = r * v3(j.axis);
                    let kind = match j.kind {
                        MjKind::Free => continue,
                        MjKind::Hinge => {
                            // Zero at the child turned by `c` about the hinge line: the
                            // default pose reads `−c` (`hinge_centres`).
                            let c = centres[joints_of[i][0]];
                            let rest = if c == 0.0 {
                                pb
                            } else {
                                let turn = DQuat::from_axis_angle(axis.normalize(), c);
                                Pose {
                                    x: anchor + turn * (pb.x - anchor),
                                    q: turn * pb.q,
                                }
                            };
                            JointKind::Hinge(
                                Hinge::from_world(&pa, &rest, anchor, axis).map_err(wrap)?,
                            )
                        }
                        MjKind::Ball => {
                            if j.limited {
                                return Err(scene_err(format!(
                                    "joint {:?} (line {}): ball joint limits are not supported (a cone limit is not a one-dimensional row)",
                                    j.name, j.line
                                )));
                            }
                            JointKind::Spherical(
                                Spherical::from_world(&pa, &pb, anchor).map_err(wrap)?,
                            )
                        }
                        MjKind::Slide => JointKind::Prismatic(
                            Prismatic::from_world(&pa, &pb, anchor, axis).map_err(wrap)?,
                        ),
                    };
                    (kind, j.damping)
                }
                many => {
                    // Slides first, then hinges through one anchor (MuJoCo's order).
                    let first_hinge = many
                        .iter()
                        .position(|j| j.kind == MjKind::Hinge)
                        .unwrap_or(many.len());
                    let shape_ok = many[..first_hinge].iter().all(|j| j.kind == MjKind::Slide)
                        && many[first_hinge..].iter().all(|j| j.kind == MjKind::Hinge);
                    let hinge_pos = many.get(first_hinge).map(|j| v3(j.pos));
                    let shared = many[first_hinge..]
                        .iter()
                        .all(|j| hinge_pos.is_some_and(|p| (v3(j.pos) - p).length() <= 1e-9));
                    let unsupported = || {
                        scene_err(format!(
                            "body {:?} (line {}): this combination of joints is not supported (slides first, then hinges whose lines meet in one point, or two hinges alone on skew lines)",
                            b.name, b.line
                        ))
                    };
                    if !shape_ok {
                        return Err(unsupported());
                    }
                    let slides: Vec<DVec3> =
                        many[..first_hinge].iter().map(|j| v3(j.axis)).collect();
                    let hinges: Vec<DVec3> =
                        many[first_hinge..].iter().map(|j| v3(j.axis)).collect();
                    let c = if shared {
                        let anchor = origin + r * hinge_pos.unwrap_or(DVec3::ZERO);
                        Compound::from_world(&pa, &pb, anchor, &slides, &hinges).map_err(wrap)?
                    } else {
                        // Hinges at different `pos`: their lines (world point, axis in
                        // the body frame) decide the form.
                        let lines: Vec<(DVec3, DVec3)> = many[first_hinge..]
                            .iter()
                            .map(|j| (origin + r * v3(j.pos), v3(j.axis)))
                            .collect();
                        Compound::from_lines(&pa, &pb, &slides, &lines).map_err(|e| match e {
                            ConstraintError::HingesNotConcurrent => unsupported(),
                            e => wrap(e),
                        })?
                    };
                    let mut d = [0.0; MAX_DOF];
                    for (k, j) in many.iter().enumerate() {
                        d[k] = j.damping;
                    }
                    (JointKind::Compound(c, d), 0.0)
                }
            };
            let wj = world.add_joint(Joint {
                parent: b.parent,
                child: i,
                kind,
                damping,
            })?;
            for (dof, &k) in joints_of[i].iter().enumerate() {
                placed[k] = Some((wj, dof));
            }
        }
        // Limits, springs (MuJoCo's coordinate is ours plus `ref`).
        for (k, j) in model.joints.iter().enumerate() {
            let Some((wj, dof)) = placed[k] else {
                continue;
            };
            let at = |e: ArticulatedError| {
                scene_err(format!("joint {:?} (line {}): {e}", j.name, j.line))
            };
            if j.limited
                && matches!(j.kind, MjKind::Hinge | MjKind::Slide)
                && !model.options.disabled("limit")
            {
                world
                    .set_dof_limit(
                        wj,
                        dof,
                        j.range[0] - reference[k],
                        j.range[1] - reference[k],
                    )
                    .map_err(at)?;
            }
            if j.frictionloss > 0.0 && !model.options.disabled("frictionloss") {
                if !matches!(j.kind, MjKind::Hinge | MjKind::Slide) {
                    return Err(scene_err(format!(
                        "joint {:?} (line {}): frictionloss on a ball joint is not supported",
                        j.name, j.line
                    )));
                }
                world
                    .set_frictionloss(wj, dof, j.frictionloss)
                    .map_err(at)?;
            }
            if j.armature > 0.0 {
                let n = if j.kind == MjKind::Ball { 3 } else { 1 };
                for d in 0..n {
                    world.set_armature(wj, dof + d, j.armature).map_err(at)?;
                }
            }
            if j.stiffness > 0.0 && matches!(j.kind, MjKind::Hinge | MjKind::Slide) {
                world
                    .add_dof_spring(DofSpring {
                        joint: wj,
                        dof,
                        stiffness: j.stiffness,
                        reference: j.springref - reference[k],
                    })
                    .map_err(at)?;
            }
        }
        // Fluid drag (MuJoCo's inertia-box model).
        let o = &model.options;
        if o.density > 0.0 || o.viscosity > 0.0 {
            world.set_fluid(Some(crate::world::Fluid {
                density: o.density,
                viscosity: o.viscosity,
                wind: v3(o.wind),
            }))?;
        }
        // Fixed tendons: MuJoCo's length is over its coordinates, ours plus `ref`; the
        // default spring length (−1) is the length at qpos0, where ours are all zero.
        // Spatial tendons: the path's length, the same in both.
        let mut tendon_ref = Vec::with_capacity(model.tendons.len());
        for t in &model.tendons {
            let at = |e: String| scene_err(format!("tendon {:?} (line {}): {e}", t.name, t.line));
            if t.frictionloss != 0.0 {
                return Err(at(
                    "tendon frictionloss is not supported by the world yet".into()
                ));
            }
            if !t.sites.is_empty() {
                add_spatial(model, &mut world, t, &default_poses).map_err(|e| at(e.to_string()))?;
                tendon_ref.push(0.0);
                continue;
            }
            let mut terms = Vec::with_capacity(t.joints.len());
            let mut offset = 0.0;
            for &(k, c) in &t.joints {
                let j = &model.joints[k];
                let Some((wj, dof)) =
                    placed[k].filter(|_| matches!(j.kind, MjKind::Hinge | MjKind::Slide))
                else {
                    return Err(at(format!(
                        "joint {:?}: only hinge and slide joints can be in a fixed tendon",
                        j.name
                    )));
                };
                terms.push((wj, dof, c));
                offset += c * reference[k];
            }
            let rest_length = if t.springlength[0] < 0.0 {
                0.0
            } else {
                t.springlength[0] - offset
            };
            world
                .add_tendon(Tendon {
                    terms,
                    stiffness: t.stiffness,
                    damping: t.damping,
                    rest_length,
                })
                .map_err(|e| at(e.to_string()))?;
            if t.limited && !model.options.disabled("limit") {
                // MuJoCo's length is ours plus `Σ c ref`.
                let wt = world.tendons().len() - 1;
                world
                    .set_tendon_range(wt, t.range[0] - offset, t.range[1] - offset)
                    .map_err(|e| at(e.to_string()))?;
            }
            tendon_ref.push(offset);
        }
        if !model.options.disabled("equality") {
            add_equalities(model, &mut world, &placed, &mut warnings)?;
        }
        // Actuators (MuJoCo's general form; `length = gear q` over MuJoCo's coordinate,
        // ours plus `ref`, folded into the constant bias).
        for a in &model.actuators {
            let at = |e: String| scene_err(format!("actuator {:?} (line {}): {e}", a.name, a.line));
            let (target, offset) = match a.target {
                Transmission::Joint(k) => {
                    let j = &model.joints[k];
                    let Some((wj, dof)) =
                        placed[k].filter(|_| matches!(j.kind, MjKind::Hinge | MjKind::Slide))
                    else {
                        return Err(at("only hinge and slide joints can be actuated".into()));
                    };
                    (Target::Dof { joint: wj, dof }, reference[k])
                }
                Transmission::Tendon(t) => (Target::Tendon(t), tendon_ref[t]),
            };
            let gear = a.gear[0];
            world
                .add_actuator(Actuator {
                    target,
                    gear,
                    gain: a.gain,
                    bias: [a.bias[0] + a.bias[1] * gear * offset, a.bias[1], a.bias[2]],
                    ctrl_range: a.ctrllimited.then_some(a.ctrlrange),
                    force_range: a.forcelimited.then_some(a.forcerange),
                })
                .map_err(|e| at(e.to_string()))?;
        }
        let actuator_names = model.actuators.iter().map(|a| a.name.clone()).collect();
        for c in &model.connects {
            let p1 = pose_of(c.body1);
            let p2 = pose_of(c.body2);
            let o1 = c.body1.map_or(DVec3::ZERO, |i| v3(model.bodies[i].pos));
            let q1 = c
                .body1
                .map_or(DQuat::IDENTITY, |i| quat(model.bodies[i].quat));
            let anchor = o1 + q1 * v3(c.anchor);
            let sph = Spherical::from_world(&p1, &p2, anchor)
                .map_err(|e| scene_err(format!("connect {:?} (line {}): {e}", c.name, c.line)))?;
            let (parent, child) = match (c.body1, c.body2) {
                (a, Some(b)) => (a, b),
                (Some(a), None) => {
                    // Swap so the world is the parent side: C changes sign only.
                    let sph = Spherical::from_world(&p2, &p1, anchor).map_err(|e| {
                        scene_err(format!("connect {:?} (line {}): {e}", c.name, c.line))
                    })?;
                    world.add_joint(Joint {
                        parent: None,
                        child: a,
                        kind: JointKind::Spherical(sph),
                        damping: 0.0,
                    })?;
                    continue;
                }
                (None, None) => {
                    return Err(scene_err(format!(
                        "connect {:?} (line {}) joins the world to itself",
                        c.name, c.line
                    )))
                }
            };
            world.add_joint(Joint {
                parent,
                child,
                kind: JointKind::Spherical(sph),
                damping: 0.0,
            })?;
        }
        // The keyframe's controls (MuJoCo's `mj_resetDataKeyframe` sets them too).
        if let Some(k) = key.and_then(|k| model.keyframes.iter().find(|f| f.name == k)) {
            for (i, &u) in k.ctrl.iter().enumerate() {
                world.set_ctrl(i, u).map_err(|e| {
                    scene_err(format!("keyframe {:?} (line {}) ctrl: {e}", k.name, k.line))
                })?;
            }
        }
        // The keyframe's state.
        set_body_states(&mut world, &states)?;
        let collision_geoms = if model.contact_disabled {
            0
        } else {
            model
                .geoms
                .iter()
                .filter(|g| g.contype != 0 || g.conaffinity != 0)
                .count()
        };
        #[cfg(feature = "contact")]
        if !model.contact_disabled {
            add_colliders(model, &mut world, &mut warnings)?;
        }
        Ok(Self {
            world,
            body_names: model.bodies.iter().map(|b| b.name.clone()).collect(),
            timestep: model.timestep,
            collision_geoms,
            actuator_names,
            warnings,
        })
    }

    /// Puts the world in MuJoCo's generalized state `qpos`, `qvel` of `model` (the model
    /// this scene was built from): the values given fill the front, the rest is `qpos0`
    /// and zero, as MuJoCo compiles a keyframe; ball and free quaternions are
    /// normalised. Errors: more values than `nq`/`nv`, non-finite values or states.
    pub fn set_generalized(
        &mut self,
        model: &Model,
        qpos: &[f64],
        qvel: &[f64],
    ) -> Result<(), ArticulatedError> {
        let (nq, nv) = (model.nq(), model.nv());
        if qpos.len() > nq || qvel.len() > nv {
            return Err(scene_err(format!(
                "qpos/qvel: {} and {} values given, the model has nq = {nq}, nv = {nv}",
                qpos.len(),
                qvel.len()
            )));
        }
        if qpos.iter().chain(qvel).any(|v| !v.is_finite()) {
            return Err(scene_err("qpos/qvel: values must be finite"));
        }
        let mut q = model.qpos0();
        q[..qpos.len()].copy_from_slice(qpos);
        let mut v = alloc::vec![0.0; nv];
        v[..qvel.len()].copy_from_slice(qvel);
        let states = model.body_states(&q, &v).map_err(scene_err)?;
        set_body_states(&mut self.world, &states)
    }

    /// Loads `path` and builds its world (see [`Self::new`]).
    pub fn from_file(path: &std::path::Path, key: Option<&str>) -> Result<Self, ArticulatedError> {
        let model = constraint_mjcf::load_file(path).map_err(scene_err)?;
        Self::new(&model, key)
    }
}

/// A `tendon/spatial` as a [`SpatialTendon`]: each site at its offset from its body's
/// centre of mass (`pos − com` in the body frame; world sites at their position), the
/// default spring length (`springlength` −1) the path's length at `qpos0` (the default
/// poses), and its `range` (when `limited`) as one-sided rows on the length.
fn add_spatial(
    model: &Model,
    world: &mut World,
    t: &constraint_mjcf::Tendon,
    default_poses: &[Pose],
) -> Result<(), ArticulatedError> {
    let mut path = Vec::with_capacity(t.sites.len());
    for &k in &t.sites {
        let site = model
            .sites
            .get(k)
            .ok_or_else(|| scene_err(format!("site {k} does not exist")))?;
        let offset = match site.body {
            Some(b) => v3(site.pos) - v3(model.bodies[b].com),
            None => v3(site.pos),
        };
        path.push(PathSite {
            body: site.body,
            offset,
        });
    }
    let point = |s: &PathSite| {
        s.body
            .map_or(s.offset, |b| default_poses[b].point(s.offset))
    };
    let length0: f64 = path
        .windows(2)
        .map(|w| (point(&w[1]) - point(&w[0])).length())
        .sum();
    let rest_length = if t.springlength[0] < 0.0 {
        length0
    } else {
        t.springlength[0]
    };
    let wt = world.add_spatial_tendon(SpatialTendon {
        path,
        stiffness: t.stiffness,
        damping: t.damping,
        rest_length,
    })?;
    if t.limited && !model.options.disabled("limit") {
        world.set_tendon_range(wt, t.range[0], t.range[1])?;
    }
    Ok(())
}

/// The active `equality/joint` and `equality/tendon` elements as hard [`Equality`] rows:
/// `q₁ − q₁₀ = P(q₂ − q₂₀)` over MuJoCo's coordinates, which are ours plus `ref`
/// (`q₀ = ref`), so `q₁ = P(q₂)` over ours; tendon lengths likewise (`L − L₀` is ours,
/// zero at `qpos0`). Errors name the element and its line: `joint1 == joint2` (or
/// `tendon1 == tendon2`), a joint that is not a hinge or slide, a tendon with no
/// joints, a non-finite `polycoef`. Inactive elements are left out (MuJoCo starts them
/// disabled).
fn add_equalities(
    model: &Model,
    world: &mut World,
    placed: &[Option<(usize, usize)>],
    warnings: &mut Vec<String>,
) -> Result<(), ArticulatedError> {
    let err = |what: &str, name: &str, line: u32, e: &dyn core::fmt::Display| {
        scene_err(format!("equality {what} {name:?} (line {line}): {e}"))
    };
    let coordinate = |k: usize| {
        placed[k]
            .filter(|_| matches!(model.joints[k].kind, MjKind::Hinge | MjKind::Slide))
            .map(|(wj, dof)| alloc::vec![(wj, dof, 1.0)])
    };
    let mut count = 0;
    for e in model.joint_equalities.iter().filter(|e| e.active) {
        let at = |m: &dyn core::fmt::Display| err("joint", &e.name, e.line, m);
        if e.joint2 == Some(e.joint1) {
            return Err(at(&"joint1 and joint2 are the same joint"));
        }
        let side = |k: usize| {
            coordinate(k).ok_or_else(|| {
                at(&format!(
                    "joint {:?}: only hinge and slide joints can be coupled",
                    model.joints[k].name
                ))
            })
        };
        let first = side(e.joint1)?;
        let second = match e.joint2 {
            Some(k) => side(k)?,
            None => Vec::new(),
        };
        world
            .add_equality(Equality {
                first,
                second,
                polycoef: e.polycoef,
            })
            .map_err(|x| at(&x))?;
        count += 1;
    }
    for e in model.tendon_equalities.iter().filter(|e| e.active) {
        let at = |m: &dyn core::fmt::Display| err("tendon", &e.name, e.line, m);
        if e.tendon2 == Some(e.tendon1) {
            return Err(at(&"tendon1 and tendon2 are the same tendon"));
        }
        let side = |t: usize| {
            if !world.tendon_path(t).is_empty() {
                return Err(at(&format!(
                    "tendon {:?} is spatial: an equality on a spatial tendon is not supported",
                    model.tendons.get(t).map_or("?", |t| t.name.as_str())
                )));
            }
            let terms = world.tendons().get(t).map(|t| t.terms.clone());
            match terms {
                Some(terms) if !terms.is_empty() => Ok(terms),
                _ => Err(at(&format!(
                    "tendon {:?} has no joints",
                    model.tendons.get(t).map_or("?", |t| t.name.as_str())
                ))),
            }
        };
        let first = side(e.tendon1)?;
        let second = match e.tendon2 {
            Some(t) => side(t)?,
            None => Vec::new(),
        };
        world
            .add_equality(Equality {
                first,
                second,
                polycoef: e.polycoef,
            })
            .map_err(|x| at(&x))?;
        count += 1;
    }
    // One warning per file: the loader's when the file tunes solref/solimp, else this.
    if count > 0 && !warnings.iter().any(|w| w.contains("solref")) {
        warnings.push(format!(
            "{count} equality row(s) enforced as hard constraints (MuJoCo's solref/solimp softness is not modelled)"
        ));
    }
    Ok(())
}

/// Elements the world does not model yet: a typed error naming the element and line
/// (never a silently different model).
fn reject_unsupported(model: &Model) -> Result<(), ArticulatedError> {
    let no = |what: &str, name: &str, line: u32| {
        Err(scene_err(format!(
            "line {line}: {what} {name:?} is not supported by the world yet"
        )))
    };
    if let Some(e) = model.welds.iter().find(|e| e.active) {
        return no("equality weld", &e.name, e.line);
    }
    if let Some(p) = model.contact_pairs.first() {
        return no("contact pair", &p.name, p.line);
    }
    for j in &model.joints {
        if j.stiffness != 0.0 && !matches!(j.kind, MjKind::Hinge | MjKind::Slide) {
            return no("stiffness of a ball or free joint", &j.name, j.line);
        }
    }
    Ok(())
}

/// The geoms as colliders of the world (feature `contact`), with MuJoCo's pair filter:
/// `contype`/`conaffinity`, `contact/exclude`, and the parent filter on *weld bodies*
/// (a body with no joint moves with its parent): geoms of one weld body never touch,
/// nor those of a weld body and its parent weld body unless the parent is the world.
#[cfg(feature = "contact")]
fn add_colliders(
    model: &Model,
    world: &mut World,
    warnings: &mut Vec<String>,
) -> Result<(), ArticulatedError> {
    use constraint_contact::geometry::{Collider, Shape};
    use constraint_mjcf::Primitive;

    use crate::world::CollisionFilter;
    let nb = model.bodies.len();
    let has_joint: Vec<bool> = (0..nb)
        .map(|i| model.joints.iter().any(|j| j.body == i))
        .collect();
    // weld[i]: the body whose joint moves body i (None: the world).
    let mut weld: Vec<Option<usize>> = alloc::vec![None; nb];
    for i in 0..nb {
        weld[i] = if has_joint[i] {
            Some(i)
        } else {
            model.bodies[i].parent.and_then(|p| weld[p])
        };
    }
    let weld_parent =
        |w: Option<usize>| w.and_then(|i| model.bodies[i].parent).and_then(|p| weld[p]);
    let mut condim_warned = false;
    let mut shape_warned = false;
    for g in &model.geoms {
        if g.contype == 0 && g.conaffinity == 0 {
            continue;
        }
        let at = |what: String| scene_err(format!("geom {:?} (line {}): {what}", g.name, g.line));
        let geometry = |e: constraint_contact::geometry::GeometryError| at(format!("{e:?}"));
        let q = quat(g.quat);
        let mut ellipsoid_turn = DQuat::IDENTITY;
        let shape = match g.primitive {
            Primitive::Plane { .. } => {
                if g.body.is_some_and(|b| weld[b].is_some()) {
                    return Err(at("planes must be static (world) geoms".into()));
                }
                let n = q * DVec3::Z;
                // A plane on a static body: its world pose at the default pose.
                let (pos, nq) = match g.body {
                    None => (v3(g.pos), q),
                    Some(b) => {
                        let bq = quat(model.bodies[b].quat);
                        (v3(model.bodies[b].pos) + bq * v3(g.pos), bq * q)
                    }
                };
                let n = if g.body.is_some() { nq * DVec3::Z } else { n };
                Shape::plane(n, n.dot(pos)).map_err(geometry)?
            }
            Primitive::Sphere { radius } => Shape::sphere(radius).map_err(geometry)?,
            Primitive::Box { half } => Shape::cuboid(v3(half)).map_err(geometry)?,
            Primitive::Capsule {
                radius,
                half_length,
            } => Shape::capsule(radius, half_length).map_err(geometry)?,
            // The contact crate has no cylinder or ellipsoid: documented fallbacks, one
            // warning per file (mass and inertia stay exact, from the loader).
            Primitive::Cylinder {
                radius,
                half_length,
            } => {
                if !shape_warned {
                    warnings.push(format!(
                        "geom {:?} (line {}): cylinders collide as capsules of the same radius and length (rounded rims)",
                        g.name, g.line
                    ));
                    shape_warned = true;
                }
                Shape::capsule(radius, (half_length - radius).max(0.0)).map_err(geometry)?
            }
            Primitive::Ellipsoid { radii } => {
                if !shape_warned {
                    warnings.push(format!(
                        "geom {:?} (line {}): ellipsoids collide as the capsule along their longest axis with the larger other radius",
                        g.name, g.line
                    ));
                    shape_warned = true;
                }
                let k = (0..3).fold(0, |m, i| if radii[i] > radii[m] { i } else { m });
                let r = (0..3)
                    .filter(|&i| i != k)
                    .map(|i| radii[i])
                    .fold(0.0, f64::max);
                ellipsoid_turn = match k {
                    0 => DQuat::from_rotation_y(core::f64::consts::FRAC_PI_2),
                    1 => DQuat::from_rotation_x(-core::f64::consts::FRAC_PI_2),
                    _ => DQuat::IDENTITY,
                };
                Shape::capsule(r, (radii[k] - r).max(0.0)).map_err(geometry)?
            }
        };
        let q = q * ellipsoid_turn;
        let friction = match g.condim {
            1 => 0.0,
            3 => g.friction[0],
            _ => {
                if !condim_warned {
                    warnings.push(format!(
                        "geom {:?} (line {}): condim {} taken as 3 (torsional and rolling friction not modelled)",
                        g.name, g.line, g.condim
                    ));
                    condim_warned = true;
                }
                g.friction[0]
            }
        };
        // Collider pose relative to its body's centre of mass, in the body frame; world
        // geoms (and planes) in the world.
        let (body, local) = match (g.body, g.primitive) {
            (_, Primitive::Plane { .. }) => (None, Pose::IDENTITY),
            (None, _) => (None, Pose { x: v3(g.pos), q }),
            // A body welded to the world is static in MuJoCo: its geoms are world geoms
            // at their default pose (and never tested against each other).
            (Some(b), _) if weld[b].is_none() => {
                let bq = quat(model.bodies[b].quat);
                (
                    None,
                    Pose {
                        x: v3(model.bodies[b].pos) + bq * v3(g.pos),
                        q: bq * q,
                    },
                )
            }
            (Some(b), _) => (
                Some(b),
                Pose {
                    x: v3(g.pos) - v3(model.bodies[b].com),
                    q,
                },
            ),
        };
        let c = Collider::new(body, shape, local, friction, 0.0).map_err(geometry)?;
        world.add_collider_filtered(
            c,
            CollisionFilter {
                contype: g.contype,
                conaffinity: g.conaffinity,
            },
        )?;
    }
    // Weld-body filtering as excluded body pairs, over the moving bodies that carry
    // colliders (static ones became world colliders above).
    let mut moving: Vec<usize> = world.colliders().iter().filter_map(|c| c.body).collect();
    moving.sort_unstable();
    moving.dedup();
    for (x, &a) in moving.iter().enumerate() {
        for &b in &moving[x + 1..] {
            let (wa, wb) = (weld[a], weld[b]);
            let same = wa == wb;
            let parent = weld_parent(wa) == wb || weld_parent(wb) == wa;
            if same || parent {
                world.exclude_pair(Some(a), Some(b))?;
            }
        }
    }
    for e in &model.contact_excludes {
        world.exclude_pair(e.body1, e.body2)?;
    }
    Ok(())
}

/// The bodies at maximal-coordinate states from the loader (keyframes, `qpos`/`qvel`).
fn set_body_states(
    world: &mut World,
    states: &[constraint_mjcf::BodyState],
) -> Result<(), ArticulatedError> {
    let before: Vec<RigidBody> = world.bodies().to_vec();
    for (b, s) in world.bodies_mut().iter_mut().zip(states) {
        b.pose = Pose {
            x: v3(s.com),
            q: quat(s.quat),
        };
        b.v = v3(s.vel);
        b.omega = v3(s.omega);
    }
    if let Some(i) = world
        .bodies()
        .iter()
        .position(|b| !b.pose.x.is_finite() || !b.v.is_finite() || !b.omega.is_finite())
    {
        world.bodies_mut().copy_from_slice(&before);
        return Err(ArticulatedError::InvalidBody {
            body: i,
            reason: "initial state is not finite",
        });
    }
    Ok(())
}
