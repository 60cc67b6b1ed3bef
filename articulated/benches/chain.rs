//! Time per step of ball-joint chains of 10, 100, 1000 and 10000 links
//! ([`constraint_articulated::scenes::ball_chain`], dt = 1e-3) for the velocity-level
//! step and the velocity-level step followed by projection to 1e-10 m; the chain is
//! first run for 0.2 s so it is moving and bent.
//!
//! `cargo bench -p constraint-articulated --bench chain` (`CHAIN_BENCH_SIZES=10,100`).

use constraint_articulated::scenes::ball_chain;
use constraint_articulated::Method;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::time::Duration;

fn sizes() -> Vec<usize> {
    std::env::var("CHAIN_BENCH_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![10, 20, 100, 1000, 10000])
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("chain_step");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(20);
    let methods = [
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
    ];
    for n in sizes() {
        for (name, m) in methods {
            let mut w = match ball_chain(n, 1.0) {
                Ok(w) => w,
                Err(e) => panic!("{e}"),
            };
            for _ in 0..200 {
                if let Err(e) = w.step(1e-3, m) {
                    panic!("{e}");
                }
            }
            g.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| w.step(1e-3, m).map(|s| s.projection_iterations))
            });
            println!(
                "{name} n={n}: joint separation after the run {:.2e} m",
                w.max_separation()
            );
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
