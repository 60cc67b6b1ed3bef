//! Benchmark code only: ball-joint chains in this library and in peer engines, built
//! the same way so that time per step and joint separation can be compared in one run.
//!
//! The chain is [`constraint_articulated::scenes::ball_chain`]: `links` rods of 0.1 m,
//! radius 0.01 m, density 1000 kg/m³ (solid-cylinder inertia), hanging by a ball joint
//! from the world at the origin, laid out along `−x`, released at rest under
//! `(0, 0, −9.81)`; the last link's mass and inertia are multiplied by `tip_ratio`.
//!
//! [`ours`] steps it with this library; `rapier` (feature `rapier`) builds the same
//! chain as rapier3d (f64) rigid bodies joined by spherical impulse joints. The criterion
//! bench `benches/chain_peers.rs` times both and writes the accuracy figures that
//! `cargo xtask bench` puts next to the times (MuJoCo's side runs through xtask).
//!
//! [`contact`] does the same for contact scenes (the 10-box stack, the pyramid with
//! base 20 and the 10⁴:1 heavy box of [`constraint_contact::scenes`], and a sliding
//! box), timed by `benches/contact_peers.rs`, and writes the box scenes as MJCF
//! ([`contact::mjcf`]) for MuJoCo's side.
//!
//! [`mjcf`] loads the MJCF scenes of `scenes/*.xml` into this library's worlds, timed by
//! `benches/mjcf_scenes.rs` against MuJoCo's Euler on the same files (MuJoCo's side runs
//! through xtask).

use std::path::PathBuf;

pub mod contact;
pub mod mjcf;

/// Link length (m).
pub const LINK_LENGTH: f64 = 0.1;
/// Link radius (m).
pub const LINK_RADIUS: f64 = 0.01;
/// Link density (kg/m³).
pub const DENSITY: f64 = 1000.0;
/// Gravity along `z` (m/s²).
pub const GRAVITY_Z: f64 = -9.81;

/// Mass of one link (kg): a solid cylinder.
pub fn link_mass() -> f64 {
    DENSITY * std::f64::consts::PI * LINK_RADIUS * LINK_RADIUS * LINK_LENGTH
}

/// Principal inertia of one link about its centre, `(along, across, across)` with the
/// link along its body `x` axis (kg m²).
pub fn link_inertia() -> [f64; 3] {
    let (m, r, l) = (link_mass(), LINK_RADIUS, LINK_LENGTH);
    let across = m * (3.0 * r * r + l * l) / 12.0;
    [m * r * r / 2.0, across, across]
}

/// Centre of link `i` at the start (m).
pub fn link_centre(i: usize) -> [f64; 3] {
    [-(i as f64 + 0.5) * LINK_LENGTH, 0.0, 0.0]
}

/// Where the files of this crate's runs go: `<target>/peers/` (`CARGO_TARGET_DIR` if
/// set, else the workspace's `target/`).
pub fn out_dir() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
            here.parent().unwrap_or(&here).join("target")
        });
    target.join("peers")
}

/// Outcome of a run used for accuracy, not timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeparationRun {
    /// Largest joint separation at the end of the run (m).
    pub at_end: f64,
    /// Largest joint separation over every step of the run (m).
    pub max_over_run: f64,
    /// Whether every step succeeded with a finite state.
    pub finite: bool,
    /// Simulated time (s) at which a step returned an error (divergence), if one did.
    pub failed_at: Option<f64>,
}

impl SeparationRun {
    /// The chain "holds": every step finite and the separation stayed below `bound` (m).
    pub fn holds(&self, bound: f64) -> bool {
        self.finite && self.max_over_run < bound
    }
}

/// This library's side.
pub mod ours {
    use super::SeparationRun;
    use constraint_articulated::scenes::ball_chain;
    use constraint_articulated::{ArticulatedError, Method, World};

    /// The velocity-level step (`β = 1`).
    pub const VELOCITY: Method = Method::Velocity { beta: 1.0 };

    /// The velocity-level step followed by Newton projection to 1e-10 m.
    pub const PROJECTED: Method = Method::VelocityProjected {
        beta: 1.0,
        tolerance: 1e-10,
        max_iterations: 10,
        correct_velocity: false,
    };

    /// The chain, run for `warm_up` seconds at `dt` (so it is moving and bent).
    pub fn chain(
        links: usize,
        tip_ratio: f64,
        method: Method,
        dt: f64,
        warm_up: f64,
    ) -> Result<World, ArticulatedError> {
        let mut w = ball_chain(links, tip_ratio)?;
        for _ in 0..steps_for(warm_up, dt) {
            w.step(dt, method)?;
        }
        Ok(w)
    }

    /// Runs the chain from rest for `duration` seconds at `dt`, tracking joint
    /// separation. A failed step (divergence) ends the run with `finite = false`.
    pub fn separation_run(
        links: usize,
        tip_ratio: f64,
        method: Method,
        dt: f64,
        duration: f64,
    ) -> Result<SeparationRun, ArticulatedError> {
        let mut w = ball_chain(links, tip_ratio)?;
        let mut max_over_run: f64 = 0.0;
        for k in 0..steps_for(duration, dt) {
            if w.step(dt, method).is_err() {
                return Ok(SeparationRun {
                    at_end: f64::INFINITY,
                    max_over_run: f64::INFINITY,
                    finite: false,
                    failed_at: Some((k + 1) as f64 * dt),
                });
            }
            max_over_run = max_over_run.max(w.max_separation());
        }
        let at_end = w.max_separation();
        Ok(SeparationRun {
            at_end,
            max_over_run,
            finite: at_end.is_finite(),
            failed_at: None,
        })
    }

    pub(crate) fn steps_for(duration: f64, dt: f64) -> usize {
        (duration / dt).round() as usize
    }
}

/// rapier3d's side (f64): the same chain as dynamic rigid bodies joined by spherical
/// impulse joints, default integration parameters except `dt`, no colliders.
#[cfg(feature = "rapier")]
pub mod rapier {
    use super::{link_centre, link_inertia, link_mass, SeparationRun, GRAVITY_Z, LINK_LENGTH};
    use rapier3d_f64::prelude::*;

    /// A rapier world holding one chain, stepped by [`PhysicsPipeline::step`].
    pub struct RapierChain {
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
        /// `(parent, child, anchor in parent frame, anchor in child frame)`.
        joints: Vec<(RigidBodyHandle, RigidBodyHandle, Vector, Vector)>,
    }

    impl RapierChain {
        /// The chain of [`constraint_articulated::scenes::ball_chain`]`(links, tip_ratio)`
        /// stepped at `dt`. The first joint attaches the first link to a fixed body at the
        /// origin.
        pub fn new(links: usize, tip_ratio: f64, dt: f64) -> Self {
            let mut bodies = RigidBodySet::new();
            let mut impulse_joints = ImpulseJointSet::new();
            let ground = bodies.insert(RigidBodyBuilder::fixed());
            let [ia, ic, _] = link_inertia();
            let half = Vector::new(0.5 * LINK_LENGTH, 0.0, 0.0);
            let mut joints = Vec::with_capacity(links);
            let mut parent = ground;
            for i in 0..links {
                let s = if i + 1 == links { tip_ratio } else { 1.0 };
                let [x, y, z] = link_centre(i);
                let mprops = MassProperties::new(
                    Vector::ZERO,
                    link_mass() * s,
                    Vector::new(ia * s, ic * s, ic * s),
                );
                let body = bodies.insert(
                    RigidBodyBuilder::dynamic()
                        .translation(Vector::new(x, y, z))
                        .additional_mass_properties(mprops)
                        .can_sleep(false),
                );
                // Parent anchor: the origin for the ground, the parent's −x end otherwise.
                let a1 = if i == 0 { Vector::ZERO } else { -half };
                let a2 = half;
                impulse_joints.insert(
                    parent,
                    body,
                    SphericalJointBuilder::new()
                        .local_anchor1(a1)
                        .local_anchor2(a2),
                    true,
                );
                joints.push((parent, body, a1, a2));
                parent = body;
            }
            let params = IntegrationParameters {
                dt,
                ..IntegrationParameters::default()
            };
            Self {
                pipeline: PhysicsPipeline::new(),
                params,
                islands: IslandManager::new(),
                broad_phase: DefaultBroadPhase::default(),
                narrow_phase: NarrowPhase::new(),
                bodies,
                colliders: ColliderSet::new(),
                impulse_joints,
                multibody_joints: MultibodyJointSet::new(),
                soft_bodies: SoftBodySet::new(),
                ccd: CCDSolver::new(),
                joints,
            }
        }

        /// One `PhysicsPipeline::step`.
        pub fn step(&mut self) {
            self.pipeline.step(
                Vector::new(0.0, 0.0, GRAVITY_Z),
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

        /// Largest joint separation (m): distance between each joint's two anchors in
        /// the world, from the body poses.
        pub fn max_separation(&self) -> f64 {
            self.joints
                .iter()
                .map(|&(a, b, ra, rb)| {
                    let pa = self.bodies[a].position().transform_point(ra);
                    let pb = self.bodies[b].position().transform_point(rb);
                    (pa - pb).length()
                })
                .fold(0.0, f64::max)
        }

        /// Whether every body's position and velocity are finite.
        pub fn finite(&self) -> bool {
            self.bodies.iter().all(|(_, b)| {
                b.translation().is_finite() && b.linvel().is_finite() && b.angvel().is_finite()
            })
        }
    }

    /// [`RapierChain::new`] then `warm_up` seconds of steps.
    pub fn chain(links: usize, tip_ratio: f64, dt: f64, warm_up: f64) -> RapierChain {
        let mut c = RapierChain::new(links, tip_ratio, dt);
        for _ in 0..super::ours::steps_for(warm_up, dt) {
            c.step();
        }
        c
    }

    /// Runs the chain from rest for `duration` seconds at `dt`, tracking joint
    /// separation.
    pub fn separation_run(links: usize, tip_ratio: f64, dt: f64, duration: f64) -> SeparationRun {
        let mut c = RapierChain::new(links, tip_ratio, dt);
        let mut max_over_run: f64 = 0.0;
        for _ in 0..super::ours::steps_for(duration, dt) {
            c.step();
            let s = c.max_separation();
            // NaN compares false: keep it visible.
            max_over_run = if s.is_finite() {
                max_over_run.max(s)
            } else {
                f64::INFINITY
            };
        }
        SeparationRun {
            at_end: c.max_separation(),
            max_over_run,
            finite: c.finite(),
            failed_at: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_figures_match_the_articulated_scene() {
        let w = constraint_articulated::scenes::ball_chain(3, 1.0).unwrap();
        let b = &w.bodies()[1];
        assert!((b.mass() - link_mass()).abs() < 1e-15);
        let [x, y, z] = link_centre(1);
        assert!((b.pose.x.x - x).abs() < 1e-15 && b.pose.x.y == y && b.pose.x.z == z);
        let ii = link_inertia();
        for k in 0..3 {
            assert!((b.inertia().col(k)[k] - ii[k]).abs() < 1e-18);
        }
    }

    #[test]
    fn a_short_run_keeps_the_joints_together() {
        let r = ours::separation_run(5, 1.0, ours::PROJECTED, 1e-3, 0.05).unwrap();
        assert!(r.holds(1e-9), "{r:?}");
    }
}
