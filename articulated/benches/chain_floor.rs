//! Time per step of a ball-joint chain lying on the floor
//! ([`constraint_articulated::scenes::chain_on_floor`]`(n, 0.01, 0.5)`: every capsule
//! link touches the plane, two contact points and six one-sided rows per link) against
//! the same chain swinging free ([`constraint_articulated::scenes::ball_chain`]`(n, 1.0)`),
//! dt = 1e-3, velocity level and velocity level with projection; each world first runs
//! 200 steps (`CHAIN_FLOOR_SETTLE` for the floor chains above 100 links, default 200).
//! The floor rows are solved by the active set in the tree factor (`O(n)` per step,
//! `world/active_set.rs`); `CHAIN_FLOOR_DENSE=1` times the dense Delassus path instead
//! (quadratic in n: keep `CHAIN_FLOOR_MAX` small then).
//! Also the 20-link chain dropped from z0 = 0.3 m, timed as 2 s of simulation.
//!
//! `cargo bench -p constraint-articulated --features contact --bench chain_floor`
//! (`CHAIN_FLOOR_SIZES=10,30,100`, default 10,30,100,300,1000; floor sizes above
//! `CHAIN_FLOOR_MAX`, default 1000, are skipped).

use constraint_articulated::scenes::{ball_chain, chain_on_floor};
use constraint_articulated::{Method, World};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::time::Duration;

fn env_list(name: &str, default: &[usize]) -> Vec<usize> {
    std::env::var(name)
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_else(|| default.to_vec())
}

fn env_usize(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(default)
}

const H: f64 = 1e-3;

fn methods() -> [(&'static str, Method); 2] {
    [
        ("velocity", Method::Velocity { beta: 1.0 }),
        (
            "projected",
            Method::VelocityProjected {
                beta: 1.0,
                tolerance: 1e-10,
                max_iterations: 10,
                correct_velocity: false,
            },
        ),
    ]
}

fn settle(w: &mut World, m: Method, steps: usize) {
    for _ in 0..steps {
        if let Err(e) = w.step(H, m) {
            panic!("{e}");
        }
    }
}

fn bench(c: &mut Criterion) {
    let sizes = env_list("CHAIN_FLOOR_SIZES", &[10, 30, 100, 300, 1000]);
    let floor_max = env_usize("CHAIN_FLOOR_MAX", 1000);
    let dense = std::env::var("CHAIN_FLOOR_DENSE").is_ok_and(|v| v == "1");
    let mut g = c.benchmark_group("chain_floor_step");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(10);
    for n in sizes {
        for (name, m) in methods() {
            let mut free = ball_chain(n, 1.0).unwrap_or_else(|e| panic!("{e}"));
            settle(&mut free, m, 200);
            g.bench_with_input(BenchmarkId::new(format!("free_{name}"), n), &n, |b, _| {
                b.iter(|| free.step(H, m).map(|s| s.projection_iterations))
            });
            if n > floor_max {
                println!("floor n={n} skipped (CHAIN_FLOOR_MAX={floor_max})");
                continue;
            }
            let mut floor = chain_on_floor(n, 0.01, 0.5).unwrap_or_else(|e| panic!("{e}"));
            floor.unilateral.sparse = !dense;
            let settle_steps = if n > 100 {
                env_usize("CHAIN_FLOOR_SETTLE", 200)
            } else {
                200
            };
            settle(&mut floor, m, settle_steps);
            g.bench_with_input(BenchmarkId::new(format!("floor_{name}"), n), &n, |b, _| {
                b.iter(|| floor.step(H, m).map(|s| s.projection_iterations))
            });
            let s = floor.unilateral_stats();
            println!(
                "floor {name} n={n}: contacts {} rows {} sparse {} iterations {} residual {:.1e} \
                 penetration {:.2e} m joint separation {:.2e} m",
                s.contacts,
                s.rows,
                s.sparse,
                s.solver.iterations,
                s.residual,
                s.max_penetration,
                floor.max_separation()
            );
        }
    }
    g.finish();

    // The 20-link chain dropped from 0.3 m: one iteration is 2 s of simulation (2000
    // steps at 1e-3), free fall then impact and rest on the floor.
    let mut g = c.benchmark_group("chain_floor_fall");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5))
        .sample_size(10);
    let m = Method::Velocity { beta: 1.0 };
    g.bench_function("velocity_20_2s", |b| {
        b.iter(|| {
            let mut w = chain_on_floor(20, 0.3, 0.5).unwrap_or_else(|e| panic!("{e}"));
            settle(&mut w, m, 2000);
            w.unilateral_stats().residual
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
