//! The MJCF scenes of `scenes/*.xml` with this library, for the comparison with MuJoCo's
//! Euler in `cargo xtask bench` (which runs MuJoCo on the same files, same dt, same
//! window, from the same keyframe).
//!
//! `mjcf_scenes/ENGINE/SCENE` times the first simulated second ([`mjcf::WINDOW`]) from
//! the scene's initial state at the file's time step: one criterion iteration is the
//! whole window, started from a fresh copy of the initial state (the copy is not timed),
//! so the time per step is the median divided by the step count. ENGINE is
//! `ours_velocity` (`Method::Velocity { beta: 1 }`) and `ours_rattle`
//! (`Method::default()`, RATTLE) on the articulated scenes, `ours_auto` (the contact
//! world's defaults) on the contact ones.
//!
//! Before timing, each window is run once untimed; a window with a failed step is not
//! timed. `target/peers/mjcf_scenes.tsv` lists every scene and engine with its dt, step
//! count, keyframe and that run's outcome (RATTLE fallbacks, joint separation at the
//! end, most contact points).
//!
//! `cargo bench -p constraint-peers --bench mjcf_scenes` (`cargo xtask bench` runs it).
//! `MJCF_BENCH_SCENES=pendulum,sphere_drop` picks the scenes.

use constraint_peers::mjcf::{self, Scene, TSV_HEADER};
use constraint_peers::out_dir;
use criterion::{BatchSize, BenchmarkId, Criterion, Throughput};
use std::time::Duration;

fn scenes() -> Vec<String> {
    match std::env::var("MJCF_BENCH_SCENES") {
        Ok(s) => s
            .split(',')
            .map(|v| v.trim().to_string())
            .filter(|v| !v.is_empty())
            .collect(),
        Err(_) => mjcf::scenes().map(String::from).collect(),
    }
}

/// Times every scene and engine; returns the lines of the TSV.
fn bench(c: &mut Criterion) -> Vec<String> {
    let mut lines = Vec::new();
    let mut g = c.benchmark_group("mjcf_scenes");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(10);
    for name in scenes() {
        let scene = match Scene::load(&name) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        let steps = scene.steps();
        g.throughput(Throughput::Elements(steps as u64));
        for engine in scene.engines() {
            let v = engine.validate(&scene);
            lines.push(mjcf::tsv_line(&scene, engine, &v));
            if let Some((t, e)) = &v.failed {
                eprintln!(
                    "mjcf_scenes: {} {name}: a step failed at t = {t} s ({e}); not timed",
                    engine.id()
                );
                continue;
            }
            g.bench_with_input(BenchmarkId::new(engine.id(), &name), &name, |b, _| {
                b.iter_batched_ref(
                    || scene.start.clone(),
                    |w| match engine.run(w, scene.dt, steps) {
                        Ok(n) => n,
                        Err(e) => panic!("{} {name}: {e}", engine.id()),
                    },
                    BatchSize::PerIteration,
                )
            });
        }
    }
    g.finish();
    lines
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let lines = bench(&mut c);
    c.final_summary();
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let mut out = String::from(TSV_HEADER);
    out.push('\n');
    for l in lines {
        out.push_str(&l);
        out.push('\n');
    }
    let dir = out_dir();
    let path = dir.join("mjcf_scenes.tsv");
    if let Err(e) = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, out)) {
        panic!("{}: {e}", path.display());
    }
    println!("wrote {}", path.display());
}
