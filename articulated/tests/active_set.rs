//! The one-sided rows by the active set in the tree factor (`UnilateralSettings::sparse`)
//! against the dense Delassus path (feature `contact`): from the same state, one step
//! of each must give the same velocities and impulses. Every tolerance carries the
//! value measured when it was set.
//!
//! The dense reference iterates the staggered friction to its fixed point (the default
//! dense path stops after two normal/friction alternations, which is the same fixed
//! point only once the warm start has converged): 30 alternations, friction PGS to
//! 1e-13, normal solve to 1e-13.

use constraint_articulated::mjcf::MjcfScene;
use constraint_articulated::scenes::chain_on_floor;
use constraint_articulated::{Joint, JointKind, Method, RigidBody, RowSource, World};
use constraint_contact::lcp::{Coupling, RowSettings};
use constraint_core::{DMat3, DQuat, DVec3, Hinge, Pose};

const H: f64 = 1e-3;
const VELOCITY: Method = Method::Velocity { beta: 1.0 };
const PROJECTED: Method = Method::VelocityProjected {
    beta: 1.0,
    tolerance: 1e-10,
    max_iterations: 20,
    correct_velocity: false,
};

fn dense_reference(w: &mut World) {
    w.unilateral.sparse = false;
    w.unilateral.solver = RowSettings {
        coupling: Coupling::Staggered { sweeps: 30 },
        friction_tolerance: 1e-13,
        friction_iterations: 3_000,
        tolerance: 1e-13,
        ..w.unilateral.solver
    };
}

/// One step of each path from the same state.
struct Compared {
    /// Largest velocity difference over `max(|v|∞, g h)`.
    dv: f64,
    /// Largest impulse difference over the largest impulse.
    dz: f64,
    /// The sparse path solved the step.
    sparse: bool,
    residual: f64,
    rows: usize,
}

/// Largest velocity difference (linear or angular, any body) between `a` and the
/// reference `b`, over the reference's largest speed (at least g·h).
fn relative_dv(a: &World, b: &World, h: f64) -> f64 {
    let mut dv: f64 = 0.0;
    let mut vmax: f64 = 9.81 * h;
    for (x, y) in a.bodies().iter().zip(b.bodies()) {
        dv = dv.max((x.v - y.v).abs().max_element());
        dv = dv.max((x.omega - y.omega).abs().max_element());
        vmax = vmax
            .max(y.v.abs().max_element())
            .max(y.omega.abs().max_element());
    }
    dv / vmax
}

/// The fetched real models: `MJCF_MODELS_DIR`, else `target/models` of the workspace.
fn models_dir() -> std::path::PathBuf {
    std::env::var_os("MJCF_MODELS_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/models")
        })
}

fn compare_one_step(w: &World, m: Method) -> Compared {
    let mut a = w.clone();
    let mut b = w.clone();
    a.unilateral.sparse = true;
    dense_reference(&mut b);
    a.step(H, m).unwrap();
    b.step(H, m).unwrap();
    let s = a.unilateral_stats();
    let dv = relative_dv(&a, &b, H);
    // Impulses; a limit and the dry friction of one degree of freedom act along the same
    // row, so only their sum (lower − upper + dry) is determined: those are compared
    // summed per degree of freedom.
    let net = |w: &World| {
        let mut out: Vec<((usize, usize, usize), f64)> = Vec::new();
        for (src, z) in w.row_impulses() {
            let (key, v) = match src {
                RowSource::Limit { joint, dof, upper } => {
                    ((0, joint, dof), if upper { -z } else { z })
                }
                RowSource::DryFriction { joint, dof } => ((0, joint, dof), z),
                RowSource::Contact { contact, axis } => ((1 + axis as usize, contact, 0), z),
                RowSource::TendonLimit { tendon, upper } => ((9, tendon, upper as usize), z),
            };
            match out.iter_mut().find(|(k, _)| *k == key) {
                Some(e) => e.1 += v,
                None => out.push((key, v)),
            }
        }
        out
    };
    let (za, zb) = (net(&a), net(&b));
    assert_eq!(za.len(), zb.len());
    let zmax = zb.iter().fold(1e-300f64, |m, z| m.max(z.1.abs()));
    let dz = za.iter().zip(&zb).fold(0.0f64, |m, (x, y)| {
        assert_eq!(x.0, y.0);
        m.max((x.1 - y.1).abs())
    });
    Compared {
        dv,
        dz: if za.is_empty() { 0.0 } else { dz / zmax },
        sparse: s.sparse,
        residual: s.residual,
        rows: s.rows,
    }
}

/// Runs `steps` steps (sparse path), comparing every `every` steps with rows; returns
/// (worst dv, worst dz, compared steps, steps the sparse path fell back, most
/// iterations, worst residual).
fn sweep(
    mut w: World,
    m: Method,
    steps: usize,
    every: usize,
) -> (f64, f64, usize, usize, usize, f64) {
    let (mut dv, mut dz, mut n, mut fb, mut its, mut res) = (0.0f64, 0.0f64, 0, 0, 0, 0.0f64);
    for step in 0..steps {
        if step % every == 0 {
            let c = compare_one_step(&w, m);
            if c.rows > 0 && c.sparse {
                dv = dv.max(c.dv);
                dz = dz.max(c.dz);
                res = res.max(c.residual);
                n += 1;
            }
        }
        w.step(H, m).unwrap();
        let s = w.unilateral_stats();
        if s.rows > 0 && !s.sparse {
            fb += 1;
        }
        its = its.max(s.active_set_iterations);
    }
    (dv, dz, n, fb, its, res)
}

/// A chain lying on the floor (every link on the plane, two contacts each), frictionless
/// and with friction μ = 0.5: once settled the active set is the last step's and one
/// factor and solve settle it; velocities and impulses agree with the dense solve.
#[test]
fn resting_chain_matches_dense() {
    for mu in [0.0, 0.5] {
        let mut w = chain_on_floor(10, 0.01, mu).unwrap();
        for _ in 0..50 {
            w.step(H, VELOCITY).unwrap();
        }
        let (dv, dz, n, fb, its, res) = sweep(w, VELOCITY, 250, 25);
        println!(
            "resting mu {mu}: dv {dv:.1e} dz {dz:.1e} n {n} fallbacks {fb} its {its} res {res:.1e}"
        );
        assert_eq!(n, 10);
        assert_eq!(fb, 0);
        assert_eq!(its, 1);
        assert!(dv <= 1e-10, "dv {dv:e}"); // measured 4.3e-12
        assert!(dz <= 1e-9, "dz {dz:e}"); // measured 2.1e-13
        assert!(res <= 1e-10, "residual {res:e}"); // measured 1.3e-15
    }
}

/// Chains dropped 0.3 m onto the floor (impact, sliding and sticking friction, contacts
/// appearing): no step falls back to the dense path and every compared step agrees.
#[test]
fn falling_chain_matches_dense() {
    for (n, mu) in [(10, 0.5), (20, 0.5), (10, 0.0)] {
        let w = chain_on_floor(n, 0.3, mu).unwrap();
        let (dv, dz, k, fb, its, res) = sweep(w, VELOCITY, 400, 5);
        println!("falling n {n} mu {mu}: dv {dv:.1e} dz {dz:.1e} compared {k} fallbacks {fb} its {its} res {res:.1e}");
        assert!(k >= 30, "compared {k}"); // measured 33
        assert_eq!(fb, 0);
        assert!(its <= 5, "iterations {its}"); // measured 3
        assert!(dv <= 1e-10, "dv {dv:e}"); // measured 2.7e-11
        assert!(dz <= 1e-9, "dz {dz:e}"); // measured 2.2e-11
        assert!(res <= 1e-10, "residual {res:e}"); // measured 2.8e-14
    }
}

/// `scenes/chain20_floor.xml` (free root, 20 ball-jointed capsules dropped onto the floor),
/// velocity level and velocity level with projection, 1 s (the drop, the impact and the
/// chain coming to rest).
#[test]
fn chain20_floor_scene_matches_dense() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/chain20_floor.xml");
    for m in [VELOCITY, PROJECTED] {
        let w = MjcfScene::from_file(&path, None).unwrap().world;
        let (dv, dz, k, fb, its, res) = sweep(w, m, 1000, 10);
        println!("chain20_floor: dv {dv:.1e} dz {dz:.1e} compared {k} fallbacks {fb} its {its} res {res:.1e}");
        assert!(k >= 50, "compared {k}"); // measured 76
        assert_eq!(fb, 0);
        // Both answers meet the complementarity residual (sparse 1.0e-13, dense 6.4e-13)
        // on the resting chain's nearly dependent rows: their difference is the
        // problem's conditioning, not a different solution.
        assert!(dv <= 1e-8, "dv {dv:e}"); // measured 4.4e-13 (1.1e-9 before the dense path iterated its friction to 1e-6)
        assert!(dz <= 3e-8, "dz {dz:e}"); // measured 1.4e-8 (8.7e-9 before the dense staggered solve took the active-set guess and checked its friction every 4th sweep; the dense answer is iterated to a residual of 1e-6 only)
        assert!(res <= 1e-10, "residual {res:e}"); // measured 1.0e-13
    }
}

/// A chain of `n` hinge links hanging from the world, link `i` with limits
/// `±lim[i]` and dry friction `f[i]`, initial angular rates `w0[i]` about `y`.
fn hinge_chain(lim: &[f64], f: &[f64], w0: &[f64]) -> World {
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let n = lim.len();
    let mut poses = Vec::new();
    let mut rate = 0.0;
    for i in 0..n {
        let pose = Pose {
            x: DVec3::new(0.0, 0.0, -(i as f64) - 0.5),
            q: DQuat::IDENTITY,
        };
        rate += w0[i];
        let body = RigidBody::new(i, 1.0, DMat3::IDENTITY * 0.1, pose)
            .unwrap()
            .with_velocity(
                DVec3::new(rate * (i as f64 + 0.5), 0.0, 0.0),
                DVec3::new(0.0, rate, 0.0),
            );
        w.add_body(body).unwrap();
        poses.push(pose);
    }
    for i in 0..n {
        let parent = if i == 0 { Pose::IDENTITY } else { poses[i - 1] };
        let anchor = DVec3::new(0.0, 0.0, -(i as f64));
        let hinge = Hinge::from_world(&parent, &poses[i], anchor, DVec3::Y).unwrap();
        w.add_joint(Joint {
            parent: (i > 0).then(|| i - 1),
            child: i,
            kind: JointKind::Hinge(hinge),
            damping: 0.0,
        })
        .unwrap();
        w.set_limit(i, -lim[i], lim[i]).unwrap();
        if f[i] > 0.0 {
            w.set_frictionloss(i, 0, f[i]).unwrap();
        }
    }
    w
}

/// A limited pendulum thrown at its stops (6 rad/s, ±0.5 rad), with and without dry
/// friction: through the impacts the sparse path agrees with the dense one.
#[test]
fn limited_pendulum_matches_dense() {
    for f in [0.0, 0.3] {
        let w = hinge_chain(&[0.5], &[f], &[6.0]);
        let (dv, dz, k, fb, its, res) = sweep(w, VELOCITY, 2000, 1);
        println!("pendulum f {f}: dv {dv:.1e} dz {dz:.1e} compared {k} fallbacks {fb} its {its} res {res:.1e}");
        assert!(k >= 100, "compared {k}"); // measured 403 (f = 0), 2000 (f = 0.3)
        assert_eq!(fb, 0);
        assert!(dv <= 1e-10, "dv {dv:e}"); // measured 2.3e-11
        assert!(dz <= 1e-9, "dz {dz:e}"); // measured 4.7e-12
        assert!(res <= 1e-10, "residual {res:e}"); // measured 7.8e-16
    }
}

/// Random hinge chains (a fixed linear congruential sequence): 2 to 6 links, limits in
/// [0.1, 1] rad, dry friction on some, random initial rates up to 4 rad/s, 1000 steps.
#[test]
fn random_limited_chains_match_dense() {
    let mut s: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut dv, mut dz, mut k, mut fb) = (0.0f64, 0.0f64, 0, 0);
    for _ in 0..6 {
        let n = 2 + (next() * 5.0) as usize;
        let lim: Vec<f64> = (0..n).map(|_| 0.1 + 0.9 * next()).collect();
        let f: Vec<f64> = (0..n)
            .map(|_| if next() < 0.5 { 0.5 * next() } else { 0.0 })
            .collect();
        let w0: Vec<f64> = (0..n).map(|_| 8.0 * next() - 4.0).collect();
        let r = sweep(hinge_chain(&lim, &f, &w0), VELOCITY, 1000, 7);
        dv = dv.max(r.0);
        dz = dz.max(r.1);
        k += r.2;
        fb += r.3;
    }
    println!("random chains: dv {dv:.1e} dz {dz:.1e} compared {k} fallbacks {fb}");
    assert!(k >= 300, "compared {k}"); // measured 858
    assert_eq!(fb, 0);
    assert!(dv <= 1e-10, "dv {dv:e}"); // measured 8.2e-13
    assert!(dz <= 1e-8, "dz {dz:e}"); // measured 1.0e-9 (dense solved to 1e-13)
}

/// The trajectory of the pinned `chain_on_floor projected` state hash
/// (`verify/tests/state_hashes.rs`: 10 links dropped from 6 cm, μ = 0.5, 400 steps),
/// sparse against the default dense path: the largest position difference.
#[test]
fn pinned_floor_trajectory_moves_at_round_off() {
    let run = |sparse: bool| {
        let mut w = chain_on_floor(10, 0.06, 0.5).unwrap();
        w.unilateral.sparse = sparse;
        for _ in 0..400 {
            w.step(1e-3, PROJECTED).unwrap();
        }
        w
    };
    let (a, b) = (run(true), run(false));
    let dx = a.bodies().iter().zip(b.bodies()).fold(0.0f64, |m, (x, y)| {
        m.max((x.pose.x - y.pose.x).abs().max_element())
    });
    println!("pinned floor trajectory: max position difference {dx:.2e} m");
    assert!(dx <= 1e-9, "dx {dx:e}"); // measured 1.54e-13 m
}

/// Two free spheres stacked on the floor: the sphere–sphere contact is between two
/// bodies, which the tree factor cannot take; it is a coupled row, solved by its Schur
/// complement inside the active set. Every step with rows stays on the sparse path and
/// agrees with the dense reference solved to its fixed point.
#[test]
fn body_body_contact_matches_dense() {
    use constraint_contact::geometry::{Collider, Shape};
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let floor = Shape::plane(DVec3::Z, 0.0).unwrap();
    w.add_collider(Collider::new(None, floor, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    for (i, z) in [0.1, 0.3].into_iter().enumerate() {
        let pose = Pose {
            x: DVec3::new(0.01 * i as f64, 0.0, z),
            q: DQuat::IDENTITY,
        };
        let b = w
            .add_body(RigidBody::new(i, 1.0, DMat3::IDENTITY * 4e-3, pose).unwrap())
            .unwrap();
        let ball = Shape::sphere(0.1).unwrap();
        w.add_collider(Collider::new(Some(b), ball, Pose::IDENTITY, 0.5, 0.0).unwrap())
            .unwrap();
    }
    let (dv, dz, k, fb, its, res) = sweep(w, VELOCITY, 300, 5);
    println!("stacked spheres: dv {dv:.1e} dz {dz:.1e} compared {k} fallbacks {fb} its {its} res {res:.1e}");
    assert!(k >= 50, "compared {k}"); // measured 60
    assert_eq!(fb, 0);
    assert!(dv <= 1e-9, "dv {dv:e}"); // measured 3.6e-12
    assert!(dz <= 1e-8, "dz {dz:e}"); // measured 1.2e-11
    assert!(res <= 1e-10, "residual {res:e}"); // measured 4.2e-17
}

/// A box sliding on the floor (μ = 0.5, 1 m/s): its friction rows sit at `μ z_n`
/// while the normals move from step to step, so the set holds and a try can end on
/// the bounds' extrapolation (the iterate moved along the responses to the new
/// normals, `World::extrapolate_bounds`) rather than a checking iterate: 3 of its
/// 150 steps did when this was written (counted). Every step with rows stays on the
/// sparse path and agrees with the dense reference.
#[test]
fn sliding_box_matches_dense() {
    use constraint_contact::geometry::{Collider, Shape};
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let floor = Shape::plane(DVec3::Z, 0.0).unwrap();
    w.add_collider(Collider::new(None, floor, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    let pose = Pose {
        x: DVec3::new(0.0, 0.0, 0.05),
        q: DQuat::from_rotation_z(0.3),
    };
    let mut body = RigidBody::new(0, 1.0, DMat3::IDENTITY * 2e-3, pose).unwrap();
    body.v = DVec3::new(1.0, 0.2, 0.0);
    let b = w.add_body(body).unwrap();
    let cube = Shape::cuboid(DVec3::new(0.1, 0.08, 0.05)).unwrap();
    w.add_collider(Collider::new(Some(b), cube, Pose::IDENTITY, 0.5, 0.0).unwrap())
        .unwrap();
    let (dv, dz, k, fb, its, res) = sweep(w, VELOCITY, 150, 5);
    println!(
        "sliding box: dv {dv:.1e} dz {dz:.1e} compared {k} fallbacks {fb} its {its} res {res:.1e}"
    );
    // The four corners' normal impulses are not unique (four rows hold three
    // freedoms), so the impulses differ between the paths (dz measured 0.87): the
    // velocities and the complementarity residual are compared.
    let _ = dz;
    assert!(k >= 25, "compared {k}"); // measured 30
    assert_eq!(fb, 0);
    assert!(dv <= 1e-9, "dv {dv:e}"); // measured 2.5e-13
    assert!(res <= 1e-10, "residual {res:e}"); // measured 1.0e-17
}

/// `scenes/ragdoll.xml` (a free torso with limited shoulders, hips and knees dropped on
/// the floor, 2 s): every step with rows stays on the sparse path and agrees with the
/// dense reference.
#[test]
fn ragdoll_matches_dense() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/ragdoll.xml");
    let w = MjcfScene::from_file(&path, None).unwrap().world;
    let (dv, dz, k, fb, its, res) = sweep(w, VELOCITY, 2000, 10);
    println!(
        "ragdoll: dv {dv:.1e} dz {dz:.1e} compared {k} fallbacks {fb} its {its} res {res:.1e}"
    );
    assert!(k >= 150, "compared {k}"); // measured 200
    assert_eq!(fb, 0);
    // The active set settles when the friction bounds moved by at most 1e-11 of the
    // largest impulse; a state met at that edge differs from the dense fixed point by
    // about that much. Which states the 2 000-step trajectory meets depends on its
    // round-off: with the pivoted Cholesky Schur solve (its ζ equal to the former
    // eigendecomposition's to 1e-15 at every Schur solve of this run) one compared
    // step settles there (residual 9.5e-11).
    assert!(dv <= 1e-7, "dv {dv:e}"); // measured 1.3e-8 (7.6e-15 on another round-off)
    assert!(dz <= 1e-8, "dz {dz:e}"); // measured 1.8e-9 (1.2e-12)
    assert!(res <= 1e-10, "residual {res:e}"); // measured 9.5e-11 (4.9e-15)
}

/// Real models with feet on the floor (a foot's two contacts with friction under its
/// hinge are more rows than the foot has freedoms: their dropped pivots go through the
/// small Schur complement): every step with rows takes the sparse path (the ant: at
/// least 80%), and where the dense reference converged (residual ≤ 1e-9) the velocities
/// agree.
#[test]
#[ignore = "needs the models fetched by `cargo xtask models fetch` (MJCF_MODELS_DIR)"]
fn real_models_with_feet_match_dense() {
    let dir = models_dir();
    for name in ["hopper", "walker2d", "half_cheetah", "ant"] {
        let path = dir.join("gymnasium").join(format!("{name}.xml"));
        let mut s = MjcfScene::from_file(&path, None).unwrap();
        let h = s.timestep;
        let (mut rows, mut sparse, mut worst, mut compared) = (0, 0, 0.0f64, 0);
        for step in 0..1000 {
            if step % 10 == 0 {
                let mut a = s.world.clone();
                let mut b = s.world.clone();
                dense_reference(&mut b);
                a.step(h, VELOCITY).unwrap();
                b.step(h, VELOCITY).unwrap();
                if a.unilateral_stats().sparse && b.unilateral_stats().residual <= 1e-9 {
                    worst = worst.max(relative_dv(&a, &b, h));
                    compared += 1;
                }
            }
            s.world.step(h, VELOCITY).unwrap();
            let u = s.world.unilateral_stats();
            rows += usize::from(u.rows > 0);
            sparse += usize::from(u.sparse);
        }
        println!("{name}: steps with rows {rows}, sparse {sparse}, compared {compared}, worst dv {worst:.1e}");
        if name == "ant" {
            // Some of the ant's steps cycle between sets (two diagonal pairs of feet in
            // turn) and take the dense path: measured 898 of 1000 sparse (f681f73,
            // before the cycle detection and the bounds' fixed point: 873, which failed
            // the equality this test asked of every model).
            assert!(10 * sparse >= 8 * rows, "{name}: sparse {sparse} of {rows}");
        } else {
            assert_eq!(sparse, rows, "{name}");
        }
        assert!(compared >= 50, "{name}: compared {compared}");
        // measured: hopper 6.0e-11, walker2d 3.5e-8, half_cheetah 1.8e-12, ant 2.0e-12
        assert!(worst <= 1e-7, "{name}: dv {worst:e}");
    }
}

/// The real humanoids (their limbs touch each other: body–body contacts, coupled rows;
/// gymnasium's feet are welded to the shins, so their contacts depend on the joint rows
/// alone): where the sparse path solved the step and the dense reference converged
/// (residual ≤ 1e-9), velocities agree; the share of steps with rows on the sparse
/// path is printed.
#[test]
#[ignore = "needs the models fetched by `cargo xtask models fetch` (MJCF_MODELS_DIR)"]
fn real_humanoids_match_dense() {
    let dir = models_dir();
    for (suite, name) in [("dm_control", "humanoid"), ("gymnasium", "humanoid")] {
        let path = dir.join(suite).join(format!("{name}.xml"));
        let mut s = MjcfScene::from_file(&path, None).unwrap();
        let h = s.timestep;
        let (mut rows, mut sparse, mut coupled, mut worst, mut compared) = (0, 0, 0, 0.0f64, 0);
        for step in 0..600 {
            if step % 5 == 0 {
                let mut a = s.world.clone();
                let mut b = s.world.clone();
                dense_reference(&mut b);
                a.step(h, VELOCITY).unwrap();
                b.step(h, VELOCITY).unwrap();
                let cl = a.colliders();
                let body_body = a
                    .contacts()
                    .iter()
                    .any(|c| cl[c.a].body.is_some() && cl[c.b].body.is_some());
                if a.unilateral_stats().sparse && b.unilateral_stats().residual <= 1e-9 {
                    worst = worst.max(relative_dv(&a, &b, h));
                    compared += 1;
                    coupled += usize::from(body_body);
                }
            }
            s.world.step(h, VELOCITY).unwrap();
            let u = s.world.unilateral_stats();
            rows += usize::from(u.rows > 0);
            sparse += usize::from(u.sparse);
        }
        println!("{suite}/{name}: steps with rows {rows}, sparse {sparse}, compared {compared} (with body-body contacts {coupled}), worst dv {worst:.1e}");
        // measured: dm_control 530 of 560 steps with rows sparse, 96 compared, 11 of
        // them with body-body contacts, dv 1.5e-9; gymnasium 573 of 587, 93, 59,
        // dv 1.3e-7.
        assert!(compared >= 50, "{name}: compared {compared}");
        assert!(coupled >= 5, "{name}: with body-body contacts {coupled}");
        assert!(10 * sparse >= 9 * rows, "{name}: sparse {sparse} of {rows}");
        assert!(worst <= 1e-6, "{name}: dv {worst:e}");
    }
}
