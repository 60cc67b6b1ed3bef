//! Soft-constraint forces and force Jacobians against finite differences, for every
//! stock constraint, over 1000 seeded random configurations each.
//!
//! * `F = −∇E` with `E = ½kC²` (central differences of the energy);
//! * `∂F/∂x = −k(∇C∇Cᵀ + C∂²C/∂x²)` (central differences of the force);
//! * `∂F_d/∂v = −c∇C∇Cᵀ` (central differences of the damped force in `v`);
//! * the projected Hessian is positive semidefinite and equals the exact one whenever
//!   the exact one already is.
//!
//! Errors are normwise, `max|a − b| / max|b|`, because the entries span many orders of
//! magnitude and the structural zeros make entrywise measures meaningless.
//! `VERIFY_TOL_SCALE=0 cargo test -p constraint-verify --test soft_forces -- --nocapture`
//! prints the measured values.

use constraint_core::{Area, DMat3, DVec3, Dihedral, Distance, PointConstraint, Volume};
use constraint_soft::energy::{damping_jacobian, energy, force, force_jacobian, HessianMode};
use constraint_soft::Softness;
use constraint_verify::fd::{exceeds, random_config, Rng, Worst};
use nalgebra::DMatrix;

const CASES: u64 = 1000;

/// Gates for (force vs −∇E, ∂F/∂x, ∂F/∂v, projected min eigenvalue / scale, projected
/// vs exact where exact is PSD): about 10× the worst measured over all four constraints
/// (1.3e-8, 1.9e-8, 5.4e-13, 5.8e-15, 0 — per-constraint values beside each test).
const GATES: [f64; 5] = [2e-7, 2e-7, 6e-12, 6e-14, 1e-12];

fn dense<const N: usize>(b: &[[DMat3; N]; N]) -> DMatrix<f64> {
    DMatrix::from_fn(3 * N, 3 * N, |r, c| b[r / 3][c / 3].col(c % 3)[r % 3])
}

fn max_abs(m: &DMatrix<f64>) -> f64 {
    m.iter().fold(0.0, |a, &v| a.max(v.abs()))
}

#[derive(Default)]
struct Errors {
    force: Worst,
    jac: Worst,
    damp: Worst,
    psd: Worst,
    proj_exact: Worst,
}

fn perturbed<const N: usize>(x: &[DVec3; N], a: usize, h: f64) -> [DVec3; N] {
    let mut y = *x;
    y[a / 3][a % 3] += h;
    y
}

fn check<C, const N: usize>(
    c: &C,
    x: &[DVec3; N],
    s: Softness,
    rng: &mut Rng,
    case: u64,
    e: &mut Errors,
) where
    C: PointConstraint<N, 1>,
{
    let len = constraint_verify::fd::characteristic_length(x);
    let h = 1e-6 * len;
    // Force against −∇E.
    let f = force(c, s, x, None);
    let mut num = 0.0f64;
    let mut den = 0.0f64;
    for a in 0..3 * N {
        let ep = energy(c, s, &perturbed(x, a, h));
        let em = energy(c, s, &perturbed(x, a, -h));
        let fd = -(ep - em) / (2.0 * h);
        num = num.max((fd - f[a / 3][a % 3]).abs());
        den = den.max(f[a / 3][a % 3].abs());
    }
    if den > 0.0 {
        e.force.record(num / den, case);
    }
    // Force Jacobian against central differences of the force.
    let k = dense(&force_jacobian(c, s.stiffness, x, HessianMode::Exact));
    let mut kfd = DMatrix::zeros(3 * N, 3 * N);
    for a in 0..3 * N {
        let fp = force(c, s, &perturbed(x, a, h), None);
        let fm = force(c, s, &perturbed(x, a, -h), None);
        for b in 0..3 * N {
            kfd[(b, a)] = (fp[b / 3][b % 3] - fm[b / 3][b % 3]) / (2.0 * h);
        }
    }
    let scale = max_abs(&k);
    if scale > 0.0 {
        e.jac.record(max_abs(&(&kfd - &k)) / scale, case);
    }
    // Damping Jacobian against differences in v (the damped force is linear in v).
    let v: [DVec3; N] = core::array::from_fn(|_| rng.in_box(DVec3::ZERO, 1.0));
    let d = dense(&damping_jacobian(c, s.damping, x));
    // Damping alone: with the elastic part present the difference would cancel badly.
    let s_damp = Softness {
        stiffness: 0.0,
        damping: s.damping,
    };
    let mut dfd = DMatrix::zeros(3 * N, 3 * N);
    let hv = 1e-3;
    for a in 0..3 * N {
        let fp = force(c, s_damp, x, Some(&perturbed(&v, a, hv)));
        let fm = force(c, s_damp, x, Some(&perturbed(&v, a, -hv)));
        for b in 0..3 * N {
            dfd[(b, a)] = (fp[b / 3][b % 3] - fm[b / 3][b % 3]) / (2.0 * hv);
        }
    }
    let dscale = max_abs(&d);
    if dscale > 0.0 {
        e.damp.record(max_abs(&(&dfd - &d)) / dscale, case);
    }
    // Projection: PSD, and unchanged when already PSD.
    let exact = -k;
    let proj = dense(&constraint_soft::energy::energy_hessian(
        c,
        s.stiffness,
        x,
        HessianMode::Projected,
    ));
    let sym = |m: &DMatrix<f64>| (m + m.transpose()) * 0.5;
    let lam_p = sym(&proj).symmetric_eigenvalues();
    let pscale = max_abs(&proj).max(f64::MIN_POSITIVE);
    e.psd.record((-lam_p.min()).max(0.0) / pscale, case);
    let lam_e = sym(&exact).symmetric_eigenvalues();
    if lam_e.min() >= 1e-12 * max_abs(&exact) {
        e.proj_exact
            .record(max_abs(&(&proj - &exact)) / max_abs(&exact), case);
    }
}

/// A configuration near `rest`: each point moved by up to 30 % of the rest size, so
/// that `C` is of the order of the rest value (as in a simulation) and the energy's
/// central difference does not drown in cancellation against a huge `C`.
fn near<const N: usize>(rest: &[DVec3; N], rng: &mut Rng) -> [DVec3; N] {
    let l = constraint_verify::fd::characteristic_length(rest);
    core::array::from_fn(|i| rest[i] + rng.in_box(DVec3::ZERO, 0.3 * l))
}

fn softness(rng: &mut Rng) -> Softness {
    Softness {
        stiffness: rng.log_uniform(1e-2, 1e6),
        damping: rng.log_uniform(1e-3, 1e2),
    }
}

fn report(name: &str, e: &Errors, gates: [f64; 5]) {
    let labels = [
        "force vs −∇E",
        "∂F/∂x",
        "∂F/∂v",
        "projected min eig",
        "projected = exact when PSD",
    ];
    let ws = [&e.force, &e.jac, &e.damp, &e.psd, &e.proj_exact];
    let mut failed = Vec::new();
    for ((l, w), g) in labels.iter().zip(ws).zip(gates) {
        let line = w.summary(&format!("{name}: {l}"), g);
        println!("{line}");
        if exceeds(w.value, g) {
            failed.push(line);
        }
    }
    assert!(failed.is_empty(), "gates exceeded:\n{}", failed.join("\n"));
}

#[test]
fn distance_forces_and_jacobians() {
    let mut rng = Rng::new(0x5eed_0001);
    let mut e = Errors::default();
    for case in 0..CASES {
        let rest: [DVec3; 2] = random_config(&mut rng);
        let Ok(c) = Distance::from_rest(0, 1, &rest) else {
            continue;
        };
        let x = near(&rest, &mut rng);
        let s = softness(&mut rng);
        check(&c, &x, s, &mut rng, case, &mut e);
    }
    // measured 3.8e-9, 3.4e-9, 4.9e-13, 2.9e-15, 0
    report("distance", &e, GATES);
}

#[test]
fn area_forces_and_jacobians() {
    let mut rng = Rng::new(0x5eed_0002);
    let mut e = Errors::default();
    for case in 0..CASES {
        let rest: [DVec3; 3] = random_config(&mut rng);
        let Ok(c) = Area::from_rest([0, 1, 2], &rest) else {
            continue;
        };
        let x = near(&rest, &mut rng);
        let s = softness(&mut rng);
        check(&c, &x, s, &mut rng, case, &mut e);
    }
    // measured 1.2e-9, 1.8e-9, 5.2e-13, 5.8e-15, 0
    report("area", &e, GATES);
}

#[test]
fn volume_forces_and_jacobians() {
    let mut rng = Rng::new(0x5eed_0003);
    let mut e = Errors::default();
    for case in 0..CASES {
        let mut rest: [DVec3; 4] = random_config(&mut rng);
        if constraint_core::volume::signed_volume(&rest) < 0.0 {
            rest.swap(1, 2);
        }
        let Ok(c) = Volume::from_rest([0, 1, 2, 3], &rest) else {
            continue;
        };
        let x = near(&rest, &mut rng);
        let s = softness(&mut rng);
        check(&c, &x, s, &mut rng, case, &mut e);
    }
    // measured 7.1e-10, 6.9e-10, 4.5e-13, 4.2e-15, 0
    report("volume", &e, GATES);
}

#[test]
fn dihedral_forces_and_jacobians() {
    let mut rng = Rng::new(0x5eed_0004);
    let mut e = Errors::default();
    for case in 0..CASES {
        let rest: [DVec3; 4] = random_config(&mut rng);
        let Ok(c) = Dihedral::from_rest([0, 1, 2, 3], &rest) else {
            continue;
        };
        let x = near(&rest, &mut rng);
        // Keep away from the ±π wrap of the angle, where C jumps.
        if c.value(&x)[0].abs() > 3.0 {
            continue;
        }
        let s = softness(&mut rng);
        check(&c, &x, s, &mut rng, case, &mut e);
    }
    // measured 1.3e-8, 1.9e-8, 5.4e-13, 5.7e-15, 0
    report("dihedral", &e, GATES);
}
