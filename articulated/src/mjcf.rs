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
//! | no joint | merged into its host (module `weld`: mass, centre of mass and inertia added to the nearest ancestor with a joint; static when that is the world); unmerged ([`MjcfOptions`]): a [`Fixed`] weld to the parent (or the world) |
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

mod weld;
use weld::{parts_of, Layout};
pub use weld::{MjcfOptions, Part, PartState};

/// A world built from an MJCF model, with the model's names and time step.
#[derive(Clone, Debug)]
pub struct MjcfScene {
    /// The world: one body per MJCF body with a joint (the hosts, in document order;
    /// every MJCF body when built unmerged, [`MjcfOptions`]).
    pub world: World,
    /// MJCF body names, in document order (world body excluded): one per entry of
    /// [`Self::parts`], not per world body.
    pub body_names: Vec<String>,
    /// Per MJCF body (same order): its world body and fixed frame ([`Part`]);
    /// [`Self::part_state`] gives its pose and velocity.
    pub parts: Vec<Part>,
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
    /// The map between MJCF bodies and world bodies.
    layout: Layout,
    /// The static bodies' potential energy `−Σ m g·c` (J; `None`: no static body).
    static_potential: Option<f64>,
}

fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn quat(q: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize()
}

/// A body's inertia about its centre of mass in its frame (the loader's rows).
fn inertia_of(b: &constraint_mjcf::Body) -> DMat3 {
    DMat3::from_cols(v3(b.inertia[0]), v3(b.inertia[1]), v3(b.inertia[2]))
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
    /// at rest), jointless bodies merged into their hosts ([`MjcfOptions::default`]).
    pub fn new(model: &Model, key: Option<&str>) -> Result<Self, ArticulatedError> {
        Self::with_options(model, key, MjcfOptions::default())
    }

    /// [`Self::new`] with the given options (`merge_welded: false`: one world body per
    /// MJCF body, jointless ones welded by [`Fixed`] joints). In a hand-built model a
    /// parent index past the last body is an error ([`ArticulatedError::Scene`]); a
    /// parent not before its body is read as the world where merging and the contact
    /// filter look for its host (the loader's kinematics do the same).
    pub fn with_options(
        model: &Model,
        key: Option<&str>,
        options: MjcfOptions,
    ) -> Result<Self, ArticulatedError> {
        let states = model.initial_state(key).map_err(scene_err)?;
        let nb = model.bodies.len();
        if let Some(b) = model
            .bodies
            .iter()
            .find(|b| b.parent.is_some_and(|p| p >= nb))
        {
            return Err(scene_err(format!(
                "body {:?} (line {}): parent {:?} is not a body of the model",
                b.name, b.line, b.parent
            )));
        }
        let mut world = World::new(v3(model.gravity));
        #[allow(unused_mut)]
        let mut warnings = model.warnings.clone();
        let layout = Layout::new(model, options.merge_welded);
        // Bodies at the default pose first: joints are defined there. A host takes its
        // merged bodies' mass, centre of mass and inertia (`weld::combine`).
        let mut default_poses = Vec::with_capacity(layout.mjcf_of.len());
        let mut coms = Vec::with_capacity(layout.mjcf_of.len());
        for (w, &i) in layout.mjcf_of.iter().enumerate() {
            let b = &model.bodies[i];
            let q = quat(b.quat);
            let own = (b.mass, v3(b.com), inertia_of(b));
            let (mass, com, inertia) = if layout.merged[w] {
                let mut parts = alloc::vec![own];
                for (k, bk) in model.bodies.iter().enumerate() {
                    if k != i && layout.host[k] == Some(i) {
                        let (t, r) = weld::relative_frame(model, i, k);
                        parts.push((
                            bk.mass,
                            t + r * v3(bk.com),
                            weld::rotate_inertia(r, inertia_of(bk)),
                        ));
                    }
                }
                weld::combine(&parts).ok_or_else(|| {
                    scene_err(format!(
                        "body {:?} (line {}): the body and the bodies welded to it have no mass",
                        b.name, b.line
                    ))
                })?
            } else {
                own
            };
            let pose = Pose {
                x: v3(b.pos) + q * com,
                q,
            };
            let body = RigidBody::new(w, mass, inertia, pose)
                .map_err(|e| scene_err(format!("body {:?} (line {}): {e}", b.name, b.line)))?
                .with_com(com);
            default_poses.push(pose);
            coms.push(com);
            world.add_body(body)?;
        }
        let parts = parts_of(model, &layout, &coms);
        let g = v3(model.gravity);
        let static_potential = parts
            .iter()
            .zip(&model.bodies)
            .filter(|(p, _)| p.body.is_none())
            .map(|(p, b)| -b.mass * g.dot(p.com))
            .reduce(|a, b| a + b);
        let pose_of = |b: Option<usize>| {
            b.and_then(|i| layout.world_of[i])
                .map_or(Pose::IDENTITY, |w| default_poses[w])
        };
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
            // Merged and static bodies have no joint of their own.
            let Some(child) = layout.world_of[i].filter(|_| layout.host[i] == Some(i)) else {
                continue;
            };
            let pa = pose_of(b.parent);
            let pb = default_poses[child];
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
                parent: b.parent.and_then(|p| layout.world_of[p]),
                child,
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
                add_spatial(model, &mut world, t, &parts, &default_poses)
                    .map_err(|e| at(e.to_string()))?;
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
            let host = |b: Option<usize>| b.and_then(|i| layout.world_of[i]);
            let (parent, child) = match (host(c.body1), host(c.body2)) {
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
        set_body_states(&mut world, &states, &layout)?;
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
            add_colliders(model, &mut world, &mut warnings, &parts, &layout)?;
        }
        Ok(Self {
            world,
            body_names: model.bodies.iter().map(|b| b.name.clone()).collect(),
            parts,
            timestep: model.timestep,
            collision_geoms,
            actuator_names,
            warnings,
            layout,
            static_potential,
        })
    }

    /// [`World::energy`] (kinetic, potential) with the static bodies' constant potential
    /// energy `−Σ m g·c` added, as MuJoCo counts it (merged bodies' energies are in
    /// their hosts'); the world's own when no body is static.
    pub fn energy(&self) -> (f64, f64) {
        let (k, p) = self.world.energy();
        match self.static_potential {
            Some(s) => (k, p + s),
            None => (k, p),
        }
    }

    /// MJCF body `i`'s pose and velocity from its host's state: origin `x + R f`,
    /// orientation `q q_f`, centre of mass `c = x + R c_f` and its velocity
    /// `v + ω × (c − x)` (`x`, `q`, `v`, `ω`: the host's centre of mass, orientation and
    /// twist; `f`, `c_f`: the part's frame and centre of mass, [`Part`]). A body alone in
    /// its world body reads the world body's fields unchanged; a static body its
    /// default pose at rest. `None` when `i` is not a body of the model.
    pub fn part_state(&self, i: usize) -> Option<PartState> {
        let p = self.parts.get(i)?;
        let Some(w) = p.body else {
            return Some(PartState {
                origin: p.frame.x,
                orientation: p.frame.q,
                com: p.com,
                v: DVec3::ZERO,
                omega: DVec3::ZERO,
            });
        };
        let b = self.world.bodies().get(w)?;
        if p.alone {
            return Some(PartState {
                origin: b.origin(),
                orientation: b.orientation(),
                com: b.pose.x,
                v: b.v,
                omega: b.omega,
            });
        }
        let r = b.pose.q * p.com;
        Some(PartState {
            origin: b.pose.point(p.frame.x),
            orientation: b.pose.q * p.frame.q,
            com: b.pose.x + r,
            v: b.v + b.omega.cross(r),
            omega: b.omega,
        })
    }

    /// Every MJCF body's state ([`Self::part_state`]), in document order, into `out`
    /// (cleared first).
    pub fn part_states(&self, out: &mut Vec<PartState>) {
        out.clear();
        out.extend((0..self.parts.len()).filter_map(|i| self.part_state(i)));
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
        set_body_states(&mut self.world, &states, &self.layout)
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
    parts: &[Part],
    default_poses: &[Pose],
) -> Result<(), ArticulatedError> {
    let mut path = Vec::with_capacity(t.sites.len());
    for &k in &t.sites {
        let site = model
            .sites
            .get(k)
            .ok_or_else(|| scene_err(format!("site {k} does not exist")))?;
        let part = site.body.and_then(|b| parts.get(b).map(|p| (b, p)));
        let (body, offset) = match part {
            // A body that is its own host alone: `pos − com` as ever.
            Some((b, p)) if p.alone => (p.body, v3(site.pos) - v3(model.bodies[b].com)),
            // Merged into a host, or static (then `frame` is in the world).
            Some((_, p)) => (p.body, p.frame.point(v3(site.pos))),
            None => (None, v3(site.pos)),
        };
        path.push(PathSite { body, offset });
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
    parts: &[Part],
    layout: &Layout,
) -> Result<(), ArticulatedError> {
    use constraint_contact::geometry::{Collider, Shape};
    use constraint_mjcf::Primitive;

    use crate::world::CollisionFilter;
    // weld[i]: the body whose joint moves body i (None: the world).
    let weld = weld::weld_hosts(model);
    let weld_parent = |w: Option<usize>| {
        w.and_then(|i| model.bodies[i].parent.filter(|p| *p < i))
            .and_then(|p| weld[p])
    };
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
            // Alone in its world body: relative to its own centre of mass.
            (Some(b), _) if parts[b].alone => (
                parts[b].body,
                Pose {
                    x: v3(g.pos) - v3(model.bodies[b].com),
                    q,
                },
            ),
            // Merged: through the body's frame in its host's ([`Part`]).
            (Some(b), _) => {
                let f = parts[b].frame;
                (
                    parts[b].body,
                    Pose {
                        x: f.point(v3(g.pos)),
                        q: f.q * q,
                    },
                )
            }
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
    // Weld-body filtering as excluded body pairs, over the moving (world) bodies that
    // carry colliders (static ones became world colliders above); a world body is a
    // weld body when merged, so only the parent filter is left between them.
    let mut moving: Vec<usize> = world.colliders().iter().filter_map(|c| c.body).collect();
    moving.sort_unstable();
    moving.dedup();
    for (x, &a) in moving.iter().enumerate() {
        for &b in &moving[x + 1..] {
            let (wa, wb) = (weld[layout.mjcf_of[a]], weld[layout.mjcf_of[b]]);
            let same = wa == wb;
            let parent = weld_parent(wa) == wb || weld_parent(wb) == wa;
            if same || parent {
                world.exclude_pair(Some(a), Some(b))?;
            }
        }
    }
    // Exclusions between the world bodies. One naming a static body is not modelled
    // (as before merging): that body's geoms are world geoms, and excluding the world
    // would drop every world geom against the other body, so it is dropped with a
    // warning. One naming a body of a merged group made `Layout` build unmerged.
    for e in &model.contact_excludes {
        for b in [e.body1, e.body2].into_iter().flatten() {
            if weld.get(b).is_some_and(|w| w.is_none()) {
                warnings.push(format!(
                    "contact/exclude {:?} (line {}) with static body {:?}: not modelled",
                    e.name, e.line, model.bodies[b].name
                ));
            }
        }
        let host = |b: Option<usize>| match b {
            None => Some(None),
            Some(i) => layout.world_of[i].map(Some),
        };
        if let (Some(a), Some(b)) = (host(e.body1), host(e.body2)) {
            world.exclude_pair(a, b)?;
        }
    }
    Ok(())
}

/// The bodies at maximal-coordinate states from the loader (keyframes, `qpos`/`qvel`):
/// each world body takes its MJCF body's state; a host with merged bodies has its
/// centre of mass at `x = p + q C` (origin `p`, combined centre `C` in its frame),
/// moving at `v_c + ω × (x − c)` from its own centre `c`'s velocity `v_c`.
fn set_body_states(
    world: &mut World,
    states: &[constraint_mjcf::BodyState],
    layout: &Layout,
) -> Result<(), ArticulatedError> {
    let before: Vec<RigidBody> = world.bodies().to_vec();
    for (w, b) in world.bodies_mut().iter_mut().enumerate() {
        let Some(s) = layout.mjcf_of.get(w).and_then(|&i| states.get(i)) else {
            continue;
        };
        let q = quat(s.quat);
        let omega = v3(s.omega);
        if layout.merged[w] {
            let x = v3(s.pos) + q * b.com;
            b.pose = Pose { x, q };
            b.v = v3(s.vel) + omega.cross(x - v3(s.com));
        } else {
            b.pose = Pose { x: v3(s.com), q };
            b.v = v3(s.vel);
        }
        b.omega = omega;
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
