//! The projection's tree-ordered sweep (`world/projection/sweep.rs`): on a chain rooted
//! at the world it closes the joints without Newton iterations and follows the Newton
//! projection's motion; on a free chain it keeps the centre of mass where the Newton
//! projection keeps it; a velocity-corrected projection is not swept.

use constraint_articulated::scenes::ball_chain;
use constraint_articulated::world::{Method, World};
use constraint_articulated::{Joint, JointKind, RigidBody};
use constraint_core::{DMat3, DQuat, DVec3, Pose, Spherical};

/// Velocity level without stabilisation (`β = 0`, so the joints drift by `O(h²)` a
/// step), the positions projected (the sweep's case).
const PROJECTED: Method = Method::VelocityProjected {
    beta: 0.0,
    tolerance: 1e-10,
    max_iterations: 20,
    correct_velocity: false,
};

/// Sets each link spinning about a tilted axis (out of the chain's plane), so the
/// velocity level leaves the joints apart by far more than the tolerance.
fn spin(w: &mut World) {
    for (i, b) in w.bodies_mut().iter_mut().enumerate() {
        let k = i as f64;
        b.omega = DVec3::new(3.0 + k, -2.0 * k, 5.0 - k);
    }
}

fn centre(w: &World) -> (DVec3, DVec3) {
    let (mut m, mut mx, mut p) = (0.0, DVec3::ZERO, DVec3::ZERO);
    for b in w.bodies() {
        m += b.mass();
        mx += b.pose.x * b.mass();
        p += b.v * b.mass();
    }
    (mx / m, p)
}

/// A chain like [`ball_chain`] without its joint to the world, in free fall.
fn free_chain(links: usize) -> World {
    let (len, r, rho) = (0.1, 0.01, 1000.0);
    let m = rho * core::f64::consts::PI * r * r * len;
    let across = m * (3.0 * r * r + len * len) / 12.0;
    let along = m * r * r / 2.0;
    let mut w = World::new(DVec3::ZERO);
    let poses: Vec<Pose> = (0..links)
        .map(|i| Pose {
            x: DVec3::new(-(i as f64 + 0.5) * len, 0.0, 0.0),
            q: DQuat::IDENTITY,
        })
        .collect();
    for (i, &pose) in poses.iter().enumerate() {
        let inertia = DMat3::from_diagonal(DVec3::new(along, across, across));
        w.add_body(RigidBody::new(i, m, inertia, pose).unwrap())
            .unwrap();
    }
    for i in 1..links {
        let anchor = DVec3::new(-(i as f64) * len, 0.0, 0.0);
        let sph = Spherical::from_world(&poses[i - 1], &poses[i], anchor).unwrap();
        w.add_joint(Joint {
            parent: Some(i - 1),
            child: i,
            kind: JointKind::Spherical(sph),
            damping: 0.0,
        })
        .unwrap();
    }
    w
}

#[test]
fn the_sweep_is_on_for_rooted_trees_by_default_and_set_per_kind_of_tree() {
    let mut w = ball_chain(3, 1.0).unwrap();
    assert_eq!(w.projection_sweep(), (true, false));
    w.set_projection_sweep(true, false);
    assert_eq!(w.projection_sweep(), (true, false));
    w.set_projection_sweep(false, true);
    assert_eq!(w.projection_sweep(), (true, true));
    w.set_projection_sweep(false, false);
    assert_eq!(w.projection_sweep(), (false, false));
}

#[test]
fn the_limbs_setting_is_a_third_option_and_off_by_default() {
    let mut w = ball_chain(3, 1.0).unwrap();
    assert!(!w.projection_sweep_limbs());
    w.set_projection_sweep_limbs(true);
    assert!(w.projection_sweep_limbs());
    assert_eq!(w.projection_sweep(), (true, false));
    w.set_projection_sweep_limbs(false);
    assert!(!w.projection_sweep_limbs());
    assert_eq!(w.projection_sweep(), (true, false));
    // Turning it off leaves another setting as it is.
    w.set_projection_sweep(false, true);
    w.set_projection_sweep_limbs(false);
    assert_eq!(w.projection_sweep(), (true, true));
    // `set_projection_sweep` replaces it.
    w.set_projection_sweep_limbs(true);
    w.set_projection_sweep(false, false);
    assert!(!w.projection_sweep_limbs());
    assert_eq!(w.projection_sweep(), (false, false));
}

/// Without contacts every joint of a free chain is a limb: the sweep closes them all
/// (the root stays; the centre of mass is not restored, unlike `(true, true)`).
#[test]
fn limbs_of_a_free_chain_without_contacts_are_all_swept() {
    let h = 5e-3;
    let mut w = free_chain(5);
    w.set_projection_sweep_limbs(true);
    spin(&mut w);
    let mut iterations = 0;
    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        iterations += w.step(h, PROJECTED).unwrap().projection_iterations;
        worst = worst.max(w.max_separation());
    }
    println!("Newton iterations {iterations}, separation {worst:e} m");
    // Measured: 0 Newton iterations in 100 steps, separation 6.5e-17 m.
    assert_eq!(iterations, 0);
    assert!(worst <= 1e-10);
}

#[test]
fn sweep_closes_a_rooted_chain_without_newton_steps() {
    let h = 5e-3;
    let mut newton = ball_chain(6, 1.0).unwrap();
    let mut swept = ball_chain(6, 1.0).unwrap();
    newton.set_projection_sweep(false, false);
    swept.set_projection_sweep(true, false);
    spin(&mut newton);
    spin(&mut swept);
    let (mut it_newton, mut it_swept) = (0, 0);
    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        it_newton += newton.step(h, PROJECTED).unwrap().projection_iterations;
        it_swept += swept.step(h, PROJECTED).unwrap().projection_iterations;
        worst = worst.max(swept.max_separation());
    }
    println!("iterations Newton {it_newton}, sweep {it_swept}; separation {worst:e}");
    // Measured: 290 Newton iterations in 100 steps; with the sweep 0 (each ball
    // joint closed by its own Newton step and chord steps).
    assert!(it_newton >= 100);
    assert_eq!(it_swept, 0);
    // Measured 9.1e-14 m.
    assert!(worst <= 1e-10);
    // The two projections reach different points of the manifold (the sweep's step
    // is not the global minimum-norm one); both are first-order methods, measured
    // against the same run at `h/10`: tip 2.05e-2 m off with the Newton projection,
    // 2.76e-2 m with the sweep, 0.5 s of a chain turning at ~6 rad/s.
    let mut fine = ball_chain(6, 1.0).unwrap();
    fine.set_projection_sweep(false, false);
    spin(&mut fine);
    for _ in 0..1000 {
        fine.step(h / 10.0, PROJECTED).unwrap();
    }
    let tip = |w: &World| w.bodies()[5].pose.x;
    let (en, es) = (
        (tip(&newton) - tip(&fine)).length(),
        (tip(&swept) - tip(&fine)).length(),
    );
    println!("tip off the h/10 run: Newton {en:e} m, sweep {es:e} m");
    assert!(es < 2.0 * en);
}

#[test]
fn a_velocity_corrected_projection_is_not_swept() {
    let corrected = Method::VelocityProjected {
        beta: 0.0,
        tolerance: 1e-10,
        max_iterations: 20,
        correct_velocity: true,
    };
    let mut newton = ball_chain(4, 1.0).unwrap();
    let mut swept = ball_chain(4, 1.0).unwrap();
    newton.set_projection_sweep(false, false);
    swept.set_projection_sweep(true, true);
    spin(&mut newton);
    spin(&mut swept);
    for _ in 0..50 {
        newton.step(5e-3, corrected).unwrap();
        swept.step(5e-3, corrected).unwrap();
    }
    for (a, b) in newton.bodies().iter().zip(swept.bodies()) {
        assert_eq!(a.pose.x.to_array(), b.pose.x.to_array());
        assert_eq!(a.v.to_array(), b.v.to_array());
    }
}

#[test]
fn sweep_of_a_free_chain_keeps_its_centre_and_momentum() {
    let h = 5e-3;
    let mut newton = free_chain(5);
    let mut swept = free_chain(5);
    newton.set_projection_sweep(false, false);
    swept.set_projection_sweep(true, true);
    spin(&mut newton);
    spin(&mut swept);
    let (c0, p0) = centre(&swept);
    let mut worst_c: f64 = 0.0;
    let mut worst_p: f64 = 0.0;
    let mut worst_sep: f64 = 0.0;
    for k in 1..=100 {
        newton.step(h, PROJECTED).unwrap();
        swept.step(h, PROJECTED).unwrap();
        let (c, p) = centre(&swept);
        let (cn, pn) = centre(&newton);
        // No force: the centre moves with the momentum `p0` (zero here).
        let expect = c0 + p0 * (k as f64 * h);
        worst_c = worst_c.max((c - expect).length()).max((c - cn).length());
        worst_p = worst_p.max((p - p0).length()).max((p - pn).length());
        worst_sep = worst_sep.max(swept.max_separation());
    }
    println!("centre {worst_c:e} m, momentum {worst_p:e} kg m/s, separation {worst_sep:e}");
    assert!(worst_c < 1e-12); // measured 2.5e-16 m
    assert!(worst_p < 1e-12); // measured 2.7e-17 kg·m/s
    assert!(worst_sep <= 1e-10); // measured 1.1e-16 m
}
