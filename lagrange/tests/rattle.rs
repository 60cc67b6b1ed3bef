//! RATTLE and RATTLE4 on particle chains: order of convergence, constraints at every
//! step, bounded energy, and clean failures.

use constraint_core::DVec3;
use constraint_lagrange::scenes::chain;
use constraint_lagrange::{KktSolver, LagrangeError, Rattle, RattleOrder};
use constraint_soft::SoftSystem;

const TOL: f64 = 1e-13;

fn method(h: f64, order: RattleOrder) -> Rattle {
    Rattle::new(h, order, TOL, 40, KktSolver::DenseSchur).expect("valid")
}

/// Positions after `t` seconds of a 3-link chain released at 1 rad.
fn run(h: f64, order: RattleOrder, t: f64) -> Vec<DVec3> {
    let (mut sys, cons) = chain(3, 0.1, 0.1, 1.0).expect("chain");
    let mut r = method(h, order);
    for _ in 0..(t / h).round() as usize {
        r.step(&mut sys, &cons).expect("step");
    }
    sys.x
}

fn max_diff(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0, f64::max)
}

#[test]
fn rattle_is_second_order_and_rattle4_fourth() {
    let t = 0.5;
    let reference = run(1.25e-4, RattleOrder::Fourth, t);
    let e = |h: f64, o| max_diff(&run(h, o, t), &reference);
    let (e2a, e2b) = (e(4e-3, RattleOrder::Second), e(2e-3, RattleOrder::Second));
    let (e4a, e4b) = (e(4e-3, RattleOrder::Fourth), e(2e-3, RattleOrder::Fourth));
    let (r2, r4) = (e2a / e2b, e4a / e4b);
    eprintln!("RATTLE {e2a:.2e} → {e2b:.2e} (ratio {r2:.2}); RATTLE4 {e4a:.2e} → {e4b:.2e} (ratio {r4:.2})");
    // Measured: ratio 4.01 (second order) and 16.2 (fourth order).
    assert!((3.5..4.5).contains(&r2), "RATTLE ratio {r2}");
    assert!((13.0..19.0).contains(&r4), "RATTLE4 ratio {r4}");
    // Measured: RATTLE4 at 2e-3 is 1.2e-7 m off, RATTLE 2.2e-5 m.
    assert!(e4b < 1e-6 && e2b < 2e-4, "{e4b:e} {e2b:e}");
}

#[test]
fn constraints_hold_at_every_step_and_energy_stays_bounded() {
    let (mut sys, cons) = chain(10, 0.1, 0.1, 1.0).expect("chain");
    let e0 = sys.kinetic_energy() + sys.potential_energy();
    let scale = 11.0 * 0.1 * 9.81 * 1.0; // M g ℓ
    let mut r = method(1e-3, RattleOrder::Second);
    let (mut worst_c, mut worst_jv, mut worst_e) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..5000 {
        r.step(&mut sys, &cons).expect("step");
        for i in 0..10 {
            let d = sys.x[i + 1] - sys.x[i];
            worst_c = worst_c.max((d.length() - 0.1).abs());
            let u = d.normalize();
            worst_jv = worst_jv.max((u.dot(sys.v[i + 1] - sys.v[i])).abs());
        }
        let e = sys.kinetic_energy() + sys.potential_energy();
        worst_e = worst_e.max((e - e0).abs() / scale);
    }
    eprintln!("5000 steps: |C| ≤ {worst_c:.1e} m, |Jv| ≤ {worst_jv:.1e} m/s, |ΔE|/(M g ℓ) ≤ {worst_e:.1e}");
    // Measured: |C| 1.0e-14 m (tolerance 1e-13 relative to 0.1 m), |Jv| 1.1e-15 m/s.
    assert!(
        worst_c <= 2e-14 && worst_jv < 1e-12,
        "{worst_c:e} {worst_jv:e}"
    );
    // Measured: 2.7e-6 of M g ℓ over 5 s.
    assert!(worst_e < 1e-4, "energy error {worst_e:e}");
}

#[test]
fn bad_parameters_and_failures_leave_the_state_unchanged() {
    let solver = KktSolver::DenseSchur;
    for (h, tol, it) in [
        (0.0, 1e-10, 10),
        (f64::NAN, 1e-10, 10),
        (1e-3, 0.0, 10),
        (1e-3, f64::INFINITY, 10),
        (1e-3, 1e-10, 1),
    ] {
        assert!(Rattle::new(h, RattleOrder::Second, tol, it, solver).is_err());
    }
    // A step far too large for its iteration budget: SHAKE does not converge, the
    // error is typed and the state is untouched.
    let (mut sys, cons) = chain(10, 0.1, 0.1, 1.0).expect("chain");
    sys.v.iter_mut().enumerate().for_each(|(i, v)| {
        *v = DVec3::new(0.0, 30.0 * i as f64, 0.0);
    });
    let before = (sys.x.clone(), sys.v.clone(), sys.steps);
    let mut r = Rattle::new(0.5, RattleOrder::Fourth, 1e-14, 2, solver).expect("valid");
    let e = r
        .step(&mut sys, &cons)
        .expect_err("cannot converge in 2 iterations");
    assert!(matches!(e, LagrangeError::Kkt(_)), "{e}");
    assert_eq!((sys.x.clone(), sys.v.clone(), sys.steps), before);
    // Non-finite gravity is rejected before anything moves.
    sys.gravity = DVec3::new(0.0, 0.0, f64::NAN);
    assert!(r.step(&mut sys, &cons).is_err());
    assert_eq!((sys.x.clone(), sys.v.clone(), sys.steps), before);
}

#[test]
fn a_pinned_pendulum_keeps_its_small_angle_period() {
    // One link of 1 m released at 0.05 rad: period 2π√(L/g)(1 + θ₀²/16).
    let (mut sys, cons): (SoftSystem, _) = chain(1, 1.0, 1.0, 0.05).expect("chain");
    let h = 1e-3;
    let mut r = method(h, RattleOrder::Second);
    let (mut t, mut last_x, mut crossings) = (0.0, sys.x[1].x, Vec::new());
    while crossings.len() < 3 {
        r.step(&mut sys, &cons).expect("step");
        t += h;
        let x = sys.x[1].x;
        if last_x > 0.0 && x <= 0.0 {
            crossings.push(t - h * x / (x - last_x));
        }
        last_x = x;
    }
    let period = crossings[2] - crossings[1];
    let exact =
        2.0 * std::f64::consts::PI * (1.0f64 / 9.81).sqrt() * (1.0 + 0.05f64.powi(2) / 16.0);
    let rel = (period - exact).abs() / exact;
    eprintln!("period {period:.9} s, exact {exact:.9} s, relative error {rel:.1e}");
    // Measured: 3.9e-7 (the O(h²) error and the series' next term, 11θ₀⁴/3072 ≈ 2.2e-8).
    assert!(rel < 1e-6, "{rel:e}");
}
