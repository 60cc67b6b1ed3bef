//! Ball-joint chains, this library against rapier3d (f64), in one run.
//!
//! Times one step at dt = 1e-3 (after 0.2 s of simulated warm-up, so the chain is moving
//! and bent) for chains of 10, 20, 100, 1000 and 10000 links:
//! `chain_peers/ours_velocity/N` (`World::step`, `Method::Velocity { beta: 1 }`),
//! `chain_peers/ours_projected/N` (`Method::VelocityProjected`, 1e-10 m, ≤ 10 Newton
//! iterations) and `chain_peers/rapier/N` (one `PhysicsPipeline::step`, spherical impulse
//! joints, default integration parameters, no colliders).
//!
//! Then, untimed, writes `target/peers/accuracy.tsv`: the largest joint separation after
//! 2 s from rest at dt = 1e-3 for each engine and size, and the heavy-tip chain
//! (`ball_chain(20, 1000.0)`, tip ×1000) at dt = 1/60 for 10 s (holds if every joint stays
//! within 1 cm).
//!
//! `cargo bench -p constraint-peers --features rapier` (`cargo xtask bench` runs it).
//! `CHAIN_PEERS_SIZES=10,100` picks the sizes; `CHAIN_PEERS_RAPIER_MAX=1000` leaves rapier
//! out above that size; `CHAIN_PEERS_ACCURACY=0` skips the accuracy runs.

use constraint_peers::{ours, out_dir, rapier, SeparationRun};
use criterion::{BenchmarkId, Criterion};
use std::fmt::Write as _;
use std::time::Duration;

const DT: f64 = 1e-3;
const WARM_UP: f64 = 0.2;

fn env_sizes(name: &str, default: &[usize]) -> Vec<usize> {
    std::env::var(name)
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_else(|| default.to_vec())
}

fn sizes() -> Vec<usize> {
    env_sizes("CHAIN_PEERS_SIZES", &[10, 20, 100, 1000, 10000])
}

fn rapier_max() -> usize {
    std::env::var("CHAIN_PEERS_RAPIER_MAX")
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(usize::MAX)
}

fn ours_methods() -> [(&'static str, constraint_articulated::Method); 2] {
    [
        ("ours_velocity", ours::VELOCITY),
        ("ours_projected", ours::PROJECTED),
    ]
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("chain_peers");
    for n in sizes() {
        g.warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2))
            .sample_size(if n >= 10000 { 10 } else { 20 });
        for (name, m) in ours_methods() {
            let mut w = match ours::chain(n, 1.0, m, DT, WARM_UP) {
                Ok(w) => w,
                Err(e) => panic!("{name} n={n}: {e}"),
            };
            g.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| w.step(DT, m).map(|s| s.projection_iterations))
            });
        }
        if n <= rapier_max() {
            let mut r = rapier::chain(n, 1.0, DT, WARM_UP);
            g.bench_with_input(BenchmarkId::new("rapier", n), &n, |b, _| {
                b.iter(|| r.step())
            });
        }
    }
    g.finish();
}

fn row(out: &mut String, kind: &str, engine: &str, n: usize, dt: f64, t: f64, r: &SeparationRun) {
    let holds = r.holds(1e-2);
    let _ = writeln!(
        out,
        "{kind}\t{engine}\t{n}\t{dt:e}\t{t}\t{:e}\t{:e}\t{holds}\t{}",
        r.at_end,
        r.max_over_run,
        r.failed_at.map_or("-".into(), |t| format!("{t}"))
    );
    println!(
        "{kind:>13} {engine:>14} n={n:<5} dt={dt:.3e} t={t}: separation at end {:.2e} m, max {:.2e} m{}",
        r.at_end,
        r.max_over_run,
        match (kind, holds, r.failed_at) {
            (_, _, Some(t)) => format!(" (step failed, diverged, at t = {t:.4} s)"),
            ("heavy_tip", true, _) => " (holds)".into(),
            ("heavy_tip", false, _) => " (comes apart)".into(),
            _ => String::new(),
        }
    );
}

/// Untimed runs: separation after 2 s at dt = 1e-3, heavy tip at dt = 1/60 for 10 s.
fn accuracy() {
    let mut out =
        String::from("kind\tengine\tlinks\tdt\tduration\tat_end\tmax_over_run\tholds\tfailed_at\n");
    for n in sizes() {
        for (name, m) in ours_methods() {
            match ours::separation_run(n, 1.0, m, DT, 2.0) {
                Ok(r) => row(&mut out, "separation_2s", name, n, DT, 2.0, &r),
                Err(e) => panic!("{name} n={n}: {e}"),
            }
        }
        if n <= rapier_max() {
            let r = rapier::separation_run(n, 1.0, DT, 2.0);
            row(&mut out, "separation_2s", "rapier", n, DT, 2.0, &r);
        }
    }
    let h = 1.0 / 60.0;
    for (name, m) in ours_methods() {
        match ours::separation_run(20, 1000.0, m, h, 10.0) {
            Ok(r) => row(&mut out, "heavy_tip", name, 20, h, 10.0, &r),
            Err(e) => panic!("heavy tip {name}: {e}"),
        }
    }
    let r = rapier::separation_run(20, 1000.0, h, 10.0);
    row(&mut out, "heavy_tip", "rapier", 20, h, 10.0, &r);
    let dir = out_dir();
    let path = dir.join("accuracy.tsv");
    if let Err(e) = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, out)) {
        panic!("{}: {e}", path.display());
    }
    println!("wrote {}", path.display());
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c);
    c.final_summary();
    let listing = std::env::args().any(|a| a == "--list");
    let skip = std::env::var("CHAIN_PEERS_ACCURACY").is_ok_and(|v| v == "0");
    if !listing && !skip {
        accuracy();
    }
}
