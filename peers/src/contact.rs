//! Contact scenes in this library and in rapier3d, built from the same description so
//! that time per step and resting accuracy can be compared in one run.
//!
//! The scenes are [`constraint_contact::scenes::box_stack`] (`n` unit boxes, 1 m, density
//! 1000 kg/m³, friction 0.5, each resting exactly on the one below, on the ground plane
//! `z = 0`), [`constraint_contact::scenes::pyramid`] (rows of unit boxes in the x–z
//! plane at 1.1 m pitch, `base − k` boxes at level `k`) and
//! [`constraint_contact::scenes::heavy_on_light`] (a unit box 10⁴ times heavier than the
//! 0.5 m box it rests on); also a 0.2 m box launched at 3 m/s on μ 0.5
//! ([`Scene::SlidingBox`], `scenes/sliding_box.xml`'s scene). [`Scene::world`] builds ours;
//! `rapier::RapierBoxes::from_world` (feature `rapier`) turns that very world into
//! rapier3d (f64) rigid bodies and colliders, so both engines start from identical poses.
//!
//! Accuracy ([`ContactRun`]) is measured on the box centres: the top box (highest at the
//! start) — its largest displacement over the run (drift) and how far it went down by
//! the end (sink) — and the largest displacement of any box over the run, and the top
//! box's horizontal travel; [`Scene::error`] is the one figure the charts of `cargo
//! xtask bench` plot per scene. [`mjcf`] writes a scene as MJCF for MuJoCo.

use constraint_contact::rigid::{ContactError, ContactSolver, ContactWorld};
use constraint_contact::scenes;

use crate::ours::steps_for;

/// Time step of the contact scenes (s): 60 Hz.
pub const DT: f64 = 1.0 / 60.0;

/// A contact scene of the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scene {
    /// [`scenes::box_stack`]`(n)`: `n` unit boxes stacked on the ground.
    Stack(usize),
    /// [`scenes::pyramid`]`(base)`: `base (base + 1) / 2` unit boxes.
    Pyramid(usize),
    /// [`scenes::heavy_on_light`]`(1e4)`: a unit box 10⁴ times heavier than the 0.5 m
    /// box under it.
    HeavyOnLight,
    /// A 0.2 m box (density 1000, friction 0.5) launched along `x` at
    /// [`SLIDE_SPEED`] on the ground: it stops after `v²/(2μg)` ([`slide_exact`]).
    SlidingBox,
}

/// Launch speed of the sliding box (m/s).
pub const SLIDE_SPEED: f64 = 3.0;

/// Friction coefficient of the sliding box and its ground.
pub const SLIDE_MU: f64 = 0.5;

/// The sliding box's exact stopping distance `v²/(2μg)` (m), g = 9.81.
pub fn slide_exact() -> f64 {
    SLIDE_SPEED * SLIDE_SPEED / (2.0 * SLIDE_MU * 9.81)
}

impl Scene {
    /// The scenes of the benchmark: the 10-box stack, the pyramid with base 20, the
    /// 10⁴:1 heavy box on a light one and the sliding box.
    pub const BENCH: [Scene; 4] = [
        Scene::Stack(10),
        Scene::Pyramid(20),
        Scene::HeavyOnLight,
        Scene::SlidingBox,
    ];

    /// Short name used in benchmark ids and files: `stack10`, `pyramid20`, `heavy1e4`,
    /// `sliding_box`.
    pub fn name(&self) -> String {
        match self {
            Scene::Stack(n) => format!("stack{n}"),
            Scene::Pyramid(b) => format!("pyramid{b}"),
            Scene::HeavyOnLight => "heavy1e4".into(),
            Scene::SlidingBox => "sliding_box".into(),
        }
    }

    /// The scene named `name` as [`Scene::name`] writes it (`stack10`, `pyramid20`,
    /// `heavy1e4`, `sliding_box`; any `stackN` or `pyramidN` with N ≥ 1), or `None`.
    pub fn from_name(name: &str) -> Option<Scene> {
        let count = |n: &str| n.parse::<usize>().ok().filter(|&n| n > 0);
        match name {
            "heavy1e4" => Some(Scene::HeavyOnLight),
            "sliding_box" => Some(Scene::SlidingBox),
            _ => {
                if let Some(n) = name.strip_prefix("stack") {
                    count(n).map(Scene::Stack)
                } else {
                    count(name.strip_prefix("pyramid")?).map(Scene::Pyramid)
                }
            }
        }
    }

    /// Number of boxes.
    pub fn boxes(&self) -> usize {
        match *self {
            Scene::Stack(n) => n,
            Scene::Pyramid(b) => b * (b + 1) / 2,
            Scene::HeavyOnLight => 2,
            Scene::SlidingBox => 1,
        }
    }

    /// This library's world for the scene, default settings.
    pub fn world(&self) -> Result<ContactWorld, ContactError> {
        match *self {
            Scene::Stack(n) => scenes::box_stack(n),
            Scene::Pyramid(b) => scenes::pyramid(b),
            Scene::HeavyOnLight => scenes::heavy_on_light(1e4),
            Scene::SlidingBox => {
                let mut w = ContactWorld::new(constraint_core::DVec3::new(0.0, 0.0, -9.81));
                scenes::ground(&mut w, SLIDE_MU)?;
                let half = constraint_core::DVec3::splat(0.1);
                let x = constraint_core::DVec3::new(0.0, 0.0, 0.1);
                let b = scenes::add_box(&mut w, half, None, x, SLIDE_MU)?;
                w.bodies_mut()[b].v = constraint_core::DVec3::new(SLIDE_SPEED, 0.0, 0.0);
                Ok(w)
            }
        }
    }

    /// The accuracy figure the charts plot for this scene (m): the top box's drift on
    /// the stack and the heavy box, the worst box displacement on the pyramid, the
    /// stopping-distance error `|travel − v²/(2μg)|` on the sliding box.
    pub fn error(&self, r: &ContactRun) -> f64 {
        match self {
            Scene::Stack(_) | Scene::HeavyOnLight => r.top_drift,
            Scene::Pyramid(_) => r.worst_displacement,
            Scene::SlidingBox => (r.top_travel - slide_exact()).abs(),
        }
    }
}

/// Accuracy of one untimed run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactRun {
    /// Largest distance of the top box from its start over the run (m).
    pub top_drift: f64,
    /// Start height minus final height of the top box (m; positive = it went down).
    pub top_sink: f64,
    /// Largest distance of any box from its start, over all boxes and steps (m).
    pub worst_displacement: f64,
    /// Largest distance of any box from its start at the end of the run (m).
    pub worst_at_end: f64,
    /// Horizontal distance of the top box from its start at the end of the run (m): the
    /// sliding box's stopping distance.
    pub top_travel: f64,
    /// Contact points at the last step (ours only).
    pub contacts: Option<usize>,
    /// Whether every step succeeded with a finite state.
    pub finite: bool,
    /// Simulated time (s) at which a step returned an error, if one did.
    pub failed_at: Option<f64>,
}

/// Follows the box centres during a run: start poses, the top box, running maxima.
#[derive(Clone, Debug)]
pub struct Tracker {
    start: Vec<[f64; 3]>,
    top: usize,
    top_drift: f64,
    worst: f64,
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl Tracker {
    /// Starts from the box centres `x0`; the top box is the highest one (the first of
    /// equals).
    pub fn new(x0: Vec<[f64; 3]>) -> Self {
        let top = x0
            .iter()
            .enumerate()
            .fold(None::<(usize, f64)>, |best, (i, x)| match best {
                Some((_, z)) if z >= x[2] => best,
                _ => Some((i, x[2])),
            })
            .map_or(0, |b| b.0);
        Self {
            start: x0,
            top,
            top_drift: 0.0,
            worst: 0.0,
        }
    }

    /// Index of the top box.
    pub fn top(&self) -> usize {
        self.top
    }

    /// Records the centres after a step. A non-finite position makes the maxima infinite.
    pub fn observe(&mut self, x: &[[f64; 3]]) {
        for (i, (p, p0)) in x.iter().zip(&self.start).enumerate() {
            let d = distance(*p, *p0);
            // NaN compares false: keep it visible.
            let d = if d.is_finite() { d } else { f64::INFINITY };
            self.worst = self.worst.max(d);
            if i == self.top {
                self.top_drift = self.top_drift.max(d);
            }
        }
    }

    /// The run's figures from the final centres.
    pub fn finish(&self, x: &[[f64; 3]], contacts: Option<usize>) -> ContactRun {
        let finite = x.iter().all(|p| p.iter().all(|c| c.is_finite()));
        let worst_at_end = x
            .iter()
            .zip(&self.start)
            .map(|(p, p0)| distance(*p, *p0))
            .fold(0.0, f64::max);
        let (a, b) = (x[self.top], self.start[self.top]);
        ContactRun {
            top_drift: self.top_drift,
            top_sink: self.start[self.top][2] - x[self.top][2],
            top_travel: ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt(),
            worst_displacement: self.worst,
            worst_at_end,
            contacts,
            finite,
            failed_at: None,
        }
    }
}

/// This library's side.
pub mod ours {
    use super::{steps_for, ContactRun, Scene, Tracker};
    use constraint_contact::rigid::{ContactError, ContactSolver, ContactWorld};

    /// Box centres of a world, in body order.
    pub fn centres(w: &ContactWorld) -> Vec<[f64; 3]> {
        w.bodies()
            .iter()
            .map(|b| [b.pose.x.x, b.pose.x.y, b.pose.x.z])
            .collect()
    }

    /// The scene with `solver` (other settings default), run for `warm_up` seconds at `dt`.
    pub fn world(
        scene: Scene,
        solver: ContactSolver,
        dt: f64,
        warm_up: f64,
    ) -> Result<ContactWorld, ContactError> {
        let mut w = scene.world()?;
        w.settings.solver = solver;
        for _ in 0..steps_for(warm_up, dt) {
            w.step(dt)?;
        }
        Ok(w)
    }

    /// Runs the scene from rest for `duration` seconds at `dt`. A failed step ends the
    /// run with `finite = false` and the time of the failure.
    pub fn run(
        scene: Scene,
        solver: ContactSolver,
        dt: f64,
        duration: f64,
    ) -> Result<ContactRun, ContactError> {
        let mut w = scene.world()?;
        w.settings.solver = solver;
        let mut t = Tracker::new(centres(&w));
        let mut contacts = None;
        for k in 0..steps_for(duration, dt) {
            match w.step(dt) {
                Ok(s) => contacts = Some(s.contacts),
                Err(_) => {
                    let mut r = t.finish(&centres(&w), contacts);
                    r.finite = false;
                    r.failed_at = Some((k + 1) as f64 * dt);
                    return Ok(r);
                }
            }
            t.observe(&centres(&w));
        }
        Ok(t.finish(&centres(&w), contacts))
    }
}

/// The scene of `w` (at its start) as MJCF for MuJoCo: one body with a free joint per
/// body, at the same pose, with one box geom of the same half extents, mass (MuJoCo
/// then gives it the uniform box's inertia, as ours) and sliding friction; each static
/// plane a plane geom; MuJoCo's defaults otherwise (Euler, Newton solver, pyramidal
/// cone, `solref` 0.02 1: soft contacts), `timestep` `dt`. A keyframe `start` holds the
/// bodies' velocities (`qvel`; the position is the bodies' own). Bodies are named
/// `box0`, `box1`, … in our body order. Spheres, capsules, colliders offset from their
/// body, a body with several colliders and a plane on a body are errors.
pub fn mjcf(w: &ContactWorld, model: &str, dt: f64) -> Result<String, String> {
    use constraint_contact::geometry::Shape;
    use std::fmt::Write as _;
    let mut ground = String::new();
    let mut geoms: Vec<Option<String>> = vec![None; w.bodies().len()];
    for (k, c) in w.colliders().iter().enumerate() {
        if c.local.x.length() > 0.0 || c.local.q.to_scaled_axis().length() > 0.0 {
            return Err(format!("collider {k}: offset from its body"));
        }
        let friction = format!("{:e} 0.005 0.0001", c.friction);
        match (c.body, c.shape) {
            (None, Shape::Plane { normal, offset }) => {
                let p = normal * offset;
                // MuJoCo's plane normal is its frame's z: rotate z onto `normal`.
                let q =
                    constraint_core::DQuat::from_rotation_arc(constraint_core::DVec3::Z, normal);
                let _ = writeln!(
                    ground,
                    r#"    <geom name="ground{k}" type="plane" size="0 0 1" pos="{:e} {:e} {:e}" quat="{:e} {:e} {:e} {:e}" friction="{friction}"/>"#,
                    p.x, p.y, p.z, q.w, q.x, q.y, q.z
                );
            }
            (Some(b), Shape::Box { half }) => {
                let slot = geoms
                    .get_mut(b)
                    .ok_or_else(|| format!("collider {k}: no body {b}"))?;
                if slot.is_some() {
                    return Err(format!("body {b}: more than one collider"));
                }
                *slot = Some(format!(
                    r#"<geom type="box" size="{:e} {:e} {:e}" mass="{:e}" friction="{friction}"/>"#,
                    half.x,
                    half.y,
                    half.z,
                    w.bodies()[b].mass()
                ));
            }
            (_, s) => return Err(format!("collider {k}: {s:?} not supported")),
        }
    }
    let mut s = String::new();
    let g = w.gravity;
    let _ = writeln!(
        s,
        "<!-- Written by constraint_peers::contact::mjcf from this library's scene: the same \
         bodies at the same poses; MuJoCo's default solver and soft contacts. -->\n\
         <mujoco model=\"{model}\">\n  <option timestep=\"{dt:e}\" gravity=\"{:e} {:e} {:e}\"/>\n  <worldbody>",
        g.x, g.y, g.z
    );
    s.push_str(&ground);
    let mut qpos = Vec::new();
    let mut qvel = Vec::new();
    for (i, (b, geom)) in w.bodies().iter().zip(&geoms).enumerate() {
        let geom = geom
            .as_ref()
            .ok_or_else(|| format!("body {i}: no box collider"))?;
        let (x, q) = (b.pose.x, b.pose.q);
        let _ = writeln!(
            s,
            r#"    <body name="box{i}" pos="{:e} {:e} {:e}" quat="{:e} {:e} {:e} {:e}"><freejoint/>{geom}</body>"#,
            x.x, x.y, x.z, q.w, q.x, q.y, q.z
        );
        qpos.extend([x.x, x.y, x.z, q.w, q.x, q.y, q.z]);
        // MuJoCo's free-joint angular velocity is in the body frame.
        let om = q.inverse() * b.omega;
        qvel.extend([b.v.x, b.v.y, b.v.z, om.x, om.y, om.z]);
    }
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:e}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let _ = writeln!(
        s,
        "  </worldbody>\n  <keyframe>\n    <key name=\"start\" qpos=\"{}\" qvel=\"{}\"/>\n  </keyframe>\n</mujoco>",
        list(&qpos),
        list(&qvel)
    );
    Ok(s)
}

/// Sub-step counts of the soft step in the bench (`ours_soft{n}`), so that accuracy
/// can be drawn against time; 3 is `Auto`'s ([`constraint_contact::rigid::AUTO_SUBSTEPS`]),
/// 4 Box2D v3's.
pub const SOFT_SUBSTEPS: [usize; 5] = [1, 2, 3, 4, 8];

/// The solvers of ours that the bench runs on every scene: `Auto` (on the pyramid, beyond
/// 200 points, that is the soft step with `AUTO_SUBSTEPS` = 3 sub-steps; on the sliding box, whose only
/// contact is the static ground, the sequential impulses where they solve the contact
/// LCP to the tolerance, the dense Newton solve otherwise), `SequentialImpulses`, and the
/// soft step with each of [`SOFT_SUBSTEPS`]
/// (`ours_soft1`, `ours_soft2`, `ours_soft3`, `ours_soft4`, `ours_soft8`; default soft
/// settings).
pub fn solvers() -> Vec<(&'static str, ContactSolver)> {
    let mut v = vec![
        ("ours_auto", ContactSolver::Auto),
        ("ours_si", ContactSolver::SequentialImpulses),
    ];
    let names = [
        "ours_soft1",
        "ours_soft2",
        "ours_soft3",
        "ours_soft4",
        "ours_soft8",
    ];
    for (name, substeps) in names.into_iter().zip(SOFT_SUBSTEPS) {
        v.push((name, ContactSolver::SoftStep { substeps }));
    }
    v
}

/// rapier3d's side (f64).
#[cfg(feature = "rapier")]
pub mod rapier {
    use super::{steps_for, ContactRun, Tracker};
    use constraint_contact::geometry::Shape;
    use constraint_contact::rigid::ContactWorld;
    use rapier3d_f64::na::Unit;
    use rapier3d_f64::prelude::*;

    /// Density of the boxes (kg/m³), as in the scenes.
    pub const DENSITY: f64 = 1000.0;

    /// A rapier world of boxes on a ground, stepped by [`PhysicsPipeline::step`].
    pub struct RapierBoxes {
        pipeline: PhysicsPipeline,
        params: IntegrationParameters,
        islands: IslandManager,
        broad_phase: BroadPhaseBvh,
        narrow_phase: NarrowPhase,
        bodies: RigidBodySet,
        colliders: ColliderSet,
        impulse_joints: ImpulseJointSet,
        multibody_joints: MultibodyJointSet,
        soft_bodies: SoftBodySet,
        ccd: CCDSolver,
        gravity: Vector,
        /// Our body `i` is rapier's `handles[i]`.
        handles: Vec<RigidBodyHandle>,
    }

    impl RapierBoxes {
        /// The same scene as `w` (which must be at its start): each of our bodies becomes
        /// a dynamic rapier body at the same pose (sleeping off, so it is simulated every
        /// step as ours is), each box collider a cuboid with the same half extents,
        /// friction and restitution and the density that gives our body's mass
        /// ([`DENSITY`] for the unit boxes of the stack and pyramid); each static plane a
        /// half-space on a fixed body. Default integration parameters except `dt`.
        /// Fails on colliders offset from their body and on a plane attached to a body.
        pub fn from_world(w: &ContactWorld, dt: f64) -> Result<Self, String> {
            Self::from_world_sleeping(w, dt, false)
        }

        /// [`RapierBoxes::from_world`] with rapier's sleeping on or off (`can_sleep`),
        /// and spheres and capsules (`ball`, `capsule_z`) besides boxes, each with the
        /// density that gives our body's mass.
        pub fn from_world_sleeping(
            w: &ContactWorld,
            dt: f64,
            sleeping: bool,
        ) -> Result<Self, String> {
            let mut bodies = RigidBodySet::new();
            let mut colliders = ColliderSet::new();
            let handles: Vec<RigidBodyHandle> = w
                .bodies()
                .iter()
                .map(|b| {
                    let (x, r) = (b.pose.x, b.pose.q.to_scaled_axis());
                    bodies.insert(
                        RigidBodyBuilder::dynamic()
                            .translation(Vector::new(x.x, x.y, x.z))
                            .rotation(Vector::new(r.x, r.y, r.z))
                            .linvel(Vector::new(b.v.x, b.v.y, b.v.z))
                            .angvel(Vector::new(b.omega.x, b.omega.y, b.omega.z))
                            .can_sleep(sleeping),
                    )
                })
                .collect();
            for (k, c) in w.colliders().iter().enumerate() {
                let local = c.local;
                if local.x.length() > 0.0 || local.q.to_scaled_axis().length() > 0.0 {
                    return Err(format!("collider {k}: offset from its body"));
                }
                let pi = std::f64::consts::PI;
                let density = match (c.body, c.shape) {
                    (Some(b), Shape::Box { half }) => {
                        w.bodies()[b].mass() / (8.0 * half.x * half.y * half.z)
                    }
                    (Some(b), Shape::Sphere { radius: r }) => {
                        w.bodies()[b].mass() / (4.0 / 3.0 * pi * r * r * r)
                    }
                    (
                        Some(b),
                        Shape::Capsule {
                            radius: r,
                            half_length: hl,
                        },
                    ) => w.bodies()[b].mass() / (pi * r * r * (2.0 * hl + 4.0 / 3.0 * r)),
                    _ => DENSITY,
                };
                let material = |b: ColliderBuilder| {
                    b.friction(c.friction)
                        .restitution(c.restitution)
                        .density(density)
                };
                match (c.body, c.shape) {
                    (None, Shape::Plane { normal, offset }) => {
                        let p = normal * offset;
                        let ground = bodies.insert(
                            RigidBodyBuilder::fixed().translation(Vector::new(p.x, p.y, p.z)),
                        );
                        let n = Unit::new_unchecked(Vector::new(normal.x, normal.y, normal.z));
                        colliders.insert_with_parent(
                            material(ColliderBuilder::halfspace(n)),
                            ground,
                            &mut bodies,
                        );
                    }
                    (Some(b), Shape::Box { half }) => {
                        colliders.insert_with_parent(
                            material(ColliderBuilder::cuboid(half.x, half.y, half.z)),
                            handles[b],
                            &mut bodies,
                        );
                    }
                    (Some(b), Shape::Sphere { radius }) => {
                        colliders.insert_with_parent(
                            material(ColliderBuilder::ball(radius)),
                            handles[b],
                            &mut bodies,
                        );
                    }
                    (
                        Some(b),
                        Shape::Capsule {
                            radius,
                            half_length,
                        },
                    ) => {
                        colliders.insert_with_parent(
                            material(ColliderBuilder::capsule_z(half_length, radius)),
                            handles[b],
                            &mut bodies,
                        );
                    }
                    (_, s) => return Err(format!("collider {k}: {s:?} not supported")),
                }
            }
            let g = w.gravity;
            Ok(Self {
                pipeline: PhysicsPipeline::new(),
                params: IntegrationParameters {
                    dt,
                    ..IntegrationParameters::default()
                },
                islands: IslandManager::new(),
                broad_phase: DefaultBroadPhase::default(),
                narrow_phase: NarrowPhase::new(),
                bodies,
                colliders,
                impulse_joints: ImpulseJointSet::new(),
                multibody_joints: MultibodyJointSet::new(),
                soft_bodies: SoftBodySet::new(),
                ccd: CCDSolver::new(),
                gravity: Vector::new(g.x, g.y, g.z),
                handles,
            })
        }

        /// One `PhysicsPipeline::step`.
        pub fn step(&mut self) {
            self.pipeline.step(
                self.gravity,
                &self.params,
                &mut self.islands,
                &mut self.broad_phase,
                &mut self.narrow_phase,
                &mut self.bodies,
                &mut self.colliders,
                &mut self.impulse_joints,
                &mut self.multibody_joints,
                &mut self.soft_bodies,
                &mut self.ccd,
                &(),
                &(),
            );
        }

        /// Box centres in our body order.
        pub fn centres(&self) -> Vec<[f64; 3]> {
            self.handles
                .iter()
                .map(|&h| {
                    let x = self.bodies[h].translation();
                    [x.x, x.y, x.z]
                })
                .collect()
        }

        /// Kinetic plus gravitational potential energy (J), as
        /// `ContactWorld::energy` counts it.
        pub fn energy(&self) -> f64 {
            self.handles
                .iter()
                .map(|&h| {
                    let b = &self.bodies[h];
                    b.kinetic_energy() - b.mass() * self.gravity.dot(b.translation())
                })
                .sum()
        }

        /// Deepest penetration among the current contact points (m; 0 when none).
        pub fn deepest(&self) -> f64 {
            self.narrow_phase
                .contact_pairs()
                .flat_map(|p| p.manifolds().iter())
                .flat_map(|m| m.points.iter())
                .map(|pt| -pt.dist)
                .fold(0.0, f64::max)
        }

        /// Bodies rapier has put to sleep.
        pub fn asleep(&self) -> usize {
            self.handles
                .iter()
                .filter(|&&h| self.bodies[h].is_sleeping())
                .count()
        }

        /// Masses in our body order (kg), from the colliders' density.
        pub fn masses(&self) -> Vec<f64> {
            self.handles
                .iter()
                .map(|&h| self.bodies[h].mass())
                .collect()
        }
    }

    /// [`RapierBoxes::from_world`] then `warm_up` seconds of steps.
    pub fn world(w: &ContactWorld, dt: f64, warm_up: f64) -> Result<RapierBoxes, String> {
        let mut r = RapierBoxes::from_world(w, dt)?;
        for _ in 0..steps_for(warm_up, dt) {
            r.step();
        }
        Ok(r)
    }

    /// Runs the scene of `w` from its start for `duration` seconds at `dt`.
    pub fn run(w: &ContactWorld, dt: f64, duration: f64) -> Result<ContactRun, String> {
        let mut r = RapierBoxes::from_world(w, dt)?;
        let mut t = Tracker::new(r.centres());
        for _ in 0..steps_for(duration, dt) {
            r.step();
            t.observe(&r.centres());
        }
        Ok(t.finish(&r.centres(), None))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_names_read_back() {
        for s in Scene::BENCH
            .into_iter()
            .chain([Scene::Stack(40), Scene::Pyramid(1)])
        {
            assert_eq!(Scene::from_name(&s.name()), Some(s));
        }
        for bad in [
            "stack0",
            "stack",
            "pyramid-3",
            "pyramidx",
            "pile1000",
            "",
            "Stack10",
        ] {
            assert_eq!(Scene::from_name(bad), None, "{bad}");
        }
    }

    #[test]
    fn scenes_have_their_boxes_and_the_tracker_finds_the_top() {
        for s in Scene::BENCH {
            let w = s.world().unwrap();
            assert_eq!(w.bodies().len(), s.boxes(), "{s:?}");
            let x0 = ours::centres(&w);
            let t = Tracker::new(x0.clone());
            let zmax = x0.iter().map(|x| x[2]).fold(f64::MIN, f64::max);
            assert_eq!(x0[t.top()][2], zmax);
        }
        let t = Tracker::new(vec![[0.0, 0.0, 0.5], [0.0, 0.0, 1.5]]);
        let r = t.finish(&[[0.0, 0.0, 0.5], [0.0, 0.0, 1.25]], None);
        assert_eq!(r.top_sink, 0.25);
        assert_eq!(r.worst_at_end, 0.25);
    }

    #[test]
    fn mjcf_has_a_body_per_box_at_its_pose_and_the_keyframe_velocity() {
        let w = Scene::Stack(3).world().unwrap();
        let x = mjcf(&w, "stack3", DT).unwrap();
        assert_eq!(x.matches("<freejoint/>").count(), 3);
        assert_eq!(x.matches(r#"type="plane""#).count(), 1);
        assert!(
            x.contains(r#"<body name="box2" pos="0e0 0e0 2.5e0""#),
            "{x}"
        );
        assert!(x.contains(r#"mass="1e3""#), "{x}");
        let s = mjcf(&Scene::SlidingBox.world().unwrap(), "slide", DT).unwrap();
        assert!(s.contains(r#"qvel="3e0 0e0 0e0 0e0 0e0 0e0""#), "{s}");
        // A sphere is not a box: an error, not a panic.
        let drop = constraint_contact::scenes::sphere_drop(0.1, 1.0).unwrap();
        assert!(mjcf(&drop, "drop", DT)
            .unwrap_err()
            .contains("not supported"));
    }

    #[test]
    fn the_sliding_box_error_is_against_the_stopping_distance() {
        let r = ours::run(Scene::SlidingBox, ContactSolver::Auto, DT, 1.0).unwrap();
        assert!(r.finite, "{r:?}");
        let e = Scene::SlidingBox.error(&r);
        assert!(e < 0.05 * slide_exact(), "{e} {r:?}");
    }

    #[test]
    fn a_short_stack_run_stays_put() {
        let r = ours::run(Scene::Stack(3), ContactSolver::Auto, DT, 0.5).unwrap();
        assert!(r.finite && r.top_drift < 1e-3, "{r:?}");
    }

    #[cfg(feature = "rapier")]
    #[test]
    fn the_rapier_scene_has_the_same_boxes() {
        let w = Scene::Stack(3).world().unwrap();
        let r = rapier::RapierBoxes::from_world(&w, DT).unwrap();
        assert_eq!(r.centres(), ours::centres(&w));
        for (m, b) in r.masses().iter().zip(w.bodies()) {
            assert!(
                (m - b.mass()).abs() < 1e-9 * b.mass(),
                "{m} vs {}",
                b.mass()
            );
        }
        // The pile's spheres and capsules: rapier's masses from the densities it gets.
        let p = constraint_contact::scenes::pile(30, 1).unwrap();
        let r = rapier::RapierBoxes::from_world_sleeping(&p, DT, true).unwrap();
        assert_eq!(r.centres(), ours::centres(&p));
        for (m, b) in r.masses().iter().zip(p.bodies()) {
            assert!(
                (m - b.mass()).abs() < 1e-9 * b.mass(),
                "{m} vs {}",
                b.mass()
            );
        }
        let run = rapier::run(&w, DT, 0.5).unwrap();
        assert!(run.finite && run.top_drift < 0.05, "{run:?}");
    }
}
