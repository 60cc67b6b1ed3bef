//! Long runs (issue 7): the 1000:1 heavy-tip chain for 10,000 steps, and the energy of
//! an undamped conservative chain over 20,000 steps per integrator, with the measured
//! drift beside each gate.

use constraint_articulated::scenes::ball_chain;
use constraint_articulated::{Method, World};

fn energy(w: &World) -> f64 {
    let (k, p) = w.energy();
    k + p
}

/// 20 links (0.1 m) with a 1000:1 tip, 10,000 steps at 1e-3: joint separation stays
/// below 1e-3 of the link length (1e-4 m), and at round-off with projection.
#[test]
fn heavy_tip_chain_for_ten_thousand_steps() {
    for (name, m, gate) in [
        // Measured: velocity 6.7e-6 m, projected 1.0e-12 m, default (RATTLE, whose
        // fallback steps also project) 9.6e-10 m (8.8e-10 before the projection's chord
        // iterations).
        ("velocity", Method::Velocity { beta: 1.0 }, 1e-4),
        (
            "projected",
            Method::VelocityProjected {
                beta: 1.0,
                tolerance: 1e-12,
                max_iterations: 10,
                correct_velocity: false,
            },
            1e-10,
        ),
        ("rattle (default)", Method::default(), 1e-4),
    ] {
        let mut w = ball_chain(20, 1000.0).unwrap();
        let mut worst: f64 = 0.0;
        for _ in 0..10_000 {
            w.step(1e-3, m).unwrap();
            worst = worst.max(w.max_separation());
        }
        println!("heavy tip, 10,000 steps, {name}: worst joint separation {worst:.2e} m");
        assert!(worst < gate, "{name}: {worst:e}");
    }
}

/// A 10-link chain released horizontally, 20,000 steps at 1e-3 (20 s, undamped):
/// largest |E(t) − E(0)| relative to the potential energy released (m g ℓ summed over
/// links, 0.6 J here) and the drift at the end, per integrator.
#[test]
fn energy_over_twenty_thousand_steps() {
    let scale = {
        let w = ball_chain(10, 1.0).unwrap();
        w.bodies()
            .iter()
            .map(|b| b.mass() * 9.81 * 0.1 * 10.0)
            .sum::<f64>()
    };
    let mut rows = Vec::new();
    for (name, m) in [
        ("rattle", Method::default()),
        (
            "rattle4",
            Method::Rattle4 {
                tolerance: 1e-12,
                max_iterations: 30,
            },
        ),
        ("velocity", Method::Velocity { beta: 1.0 }),
    ] {
        let mut w = ball_chain(10, 1.0).unwrap();
        let e0 = energy(&w);
        let mut worst: f64 = 0.0;
        for _ in 0..20_000 {
            w.step(1e-3, m).unwrap();
            worst = worst.max((energy(&w) - e0).abs());
        }
        let end = (energy(&w) - e0) / scale;
        println!(
            "{name}: max |ΔE|/E_scale {:.2e}, at 20 s {end:+.2e}",
            worst / scale
        );
        rows.push((name, worst / scale, end));
    }
    // Measured: RATTLE max 3.2e-2, −1.35e-2 at 20 s; RATTLE4 max 1.54e-1, −1.54e-1 at 20 s;
    // velocity level −1.8e-1 at 20 s. Between the whip events the symplectic methods hold
    // the energy to ~1e-3 (−6.7e-7 J after 2 s, `dynamics.rs`); the jumps come from single
    // violent steps where the SHAKE chord iteration stops at its cap (RATTLE, t ≈ 9 s) or
    // a step falls back to the dissipative velocity level (RATTLE4, t ≈ 7.1 s). Bounded,
    // and never gaining energy. How much a fallback step dissipates depends on the whip's
    // state there, which the chaotic chain makes sensitive to the last bits: RATTLE4's
    // largest loss over eight starts whose tip velocity differs by k · 1e-14 m/s
    // (k = 0 … 7) ranged 2.0e-3 … 1.46e-1 (5.1e-2 at k = 0) before the projection's chord
    // iterations, which changed the bits of the fallback steps (their projections end
    // within 1e-12 of Newton's) and give 1.54e-1 here; so RATTLE4's gate covers that spread.
    assert!(rows[0].1 < 0.05 && rows[0].2.abs() < 0.03, "{rows:?}");
    assert!(rows[1].1 < 0.2 && rows[1].2.abs() < 0.2, "{rows:?}");
    // The velocity level dissipates (first order): it loses energy, never gains it.
    assert!(rows[2].2 < 0.0 && rows[2].1 < 0.5, "{rows:?}");
    assert!(rows.iter().all(|r| r.2 <= 1e-3), "energy gained: {rows:?}");
}
