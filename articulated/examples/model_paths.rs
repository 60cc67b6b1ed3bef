//! Which path the one-sided rows of an MJCF model's steps take, and the time per step (wall and on-CPU):
//! the model runs passive from `qpos0` (RATTLE, as `simulate`'s default) and each step
//! is counted as joint-only (no rows), sparse (the active set in the tree factor,
//! `world/active_set.rs`) or dense (the Delassus path, `world/unilateral.rs`), with the
//! active set's iterations (largest, and a histogram) and the dense path's rows. Also a convenient target for
//! `perf record`.
//!
//! ```text
//! cargo run --release -p constraint-articulated --features contact --example model_paths -- \
//!     MODEL.xml [MODEL.xml ...] [--duration 2]
//! ```
//!
//! Needs feature `contact` (without it, main only says so).

#[cfg(not(feature = "contact"))]
fn main() {
    eprintln!("model_paths needs --features contact");
}

#[cfg(feature = "contact")]
fn main() {
    let mut files = Vec::new();
    let mut duration = 2.0;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--duration" {
            match args.next().and_then(|v| v.parse::<f64>().ok()) {
                Some(d) if d > 0.0 => duration = d,
                _ => {
                    eprintln!("--duration needs a positive number");
                    std::process::exit(2);
                }
            }
        } else {
            files.push(a);
        }
    }
    if files.is_empty() {
        eprintln!("usage: model_paths MODEL.xml [MODEL.xml ...] [--duration S]");
        std::process::exit(2);
    }
    println!(
        "{:<24} {:>6} {:>9} {:>9} {:>7} {:>7} {:>7} {:>8} {:>9}",
        "model",
        "steps",
        "us/step",
        "cpu us",
        "none%",
        "sparse%",
        "dense%",
        "max its",
        "dense rows"
    );
    for f in files {
        if let Err(e) = run(&f, duration) {
            println!("{f}: {e}");
        }
    }
}

/// Iteration counts above this are counted together.
#[cfg(feature = "contact")]
const MAX_HIST: usize = 40;

#[cfg(feature = "contact")]
fn run(file: &str, duration: f64) -> Result<(), String> {
    use constraint_articulated::mjcf::MjcfScene;
    use constraint_articulated::Method;
    use std::time::Instant;

    let path = std::path::Path::new(file);
    let mut s = MjcfScene::from_file(path, None).map_err(|e| e.to_string())?;
    let h = s.timestep;
    let steps = (duration / h).round() as usize;
    let method = Method::Rattle {
        tolerance: 1e-12,
        max_iterations: 20,
    };
    let (mut none, mut sparse, mut dense, mut its, mut dense_rows) = (0, 0, 0, 0, 0);
    let mut hist = [0usize; MAX_HIST + 1];
    let t0 = Instant::now();
    let c0 = cpu_ns();
    for _ in 0..steps {
        s.world.step(h, method).map_err(|e| e.to_string())?;
        let u = s.world.unilateral_stats();
        if u.rows == 0 {
            none += 1;
        } else if u.sparse {
            sparse += 1;
            hist[u.active_set_iterations.min(MAX_HIST)] += 1;
            its = its.max(u.active_set_iterations);
        } else {
            dense += 1;
            dense_rows = dense_rows.max(u.rows);
        }
    }
    let us = t0.elapsed().as_secs_f64() * 1e6 / steps.max(1) as f64;
    let cpu_us = match (c0, cpu_ns()) {
        (Some(a), Some(b)) => (b - a) as f64 * 1e-3 / steps.max(1) as f64,
        _ => f64::NAN,
    };
    let pct = |k: usize| 100.0 * k as f64 / steps.max(1) as f64;
    let name = path
        .file_name()
        .map_or(file.into(), |n| n.to_string_lossy());
    let suite = path
        .parent()
        .and_then(|p| p.file_name())
        .map_or(String::new(), |p| p.to_string_lossy().into_owned());
    println!(
        "{:<24} {:>6} {:>9.1} {:>9.1} {:>7.1} {:>7.1} {:>7.1} {:>8} {:>9}",
        format!("{suite}/{name}"),
        steps,
        us,
        cpu_us,
        pct(none),
        pct(sparse),
        pct(dense),
        its,
        dense_rows
    );
    let last = hist.iter().rposition(|&k| k > 0).unwrap_or(0);
    println!(
        "  sparse steps by active-set iterations (1, 2, ...): {:?}",
        &hist[1..=last.max(1)]
    );
    Ok(())
}

/// This thread's time on a CPU (ns), from `/proc/thread-self/schedstat` (Linux): less
/// sensitive than wall time to other processes on a loaded machine; `None` elsewhere.
#[cfg(feature = "contact")]
fn cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}
