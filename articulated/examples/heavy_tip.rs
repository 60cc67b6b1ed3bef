//! Heavy-tip chain (20 links, tip 1000× a link) at a chosen step and method: prints the
//! joint separation and energy every simulated second.
//!
//! `cargo run --release -p constraint-articulated --example heavy_tip -- [dt] [method]`
//! `[tip ratio] [beta]` with method `velocity` (default) or `projected`.

use constraint_articulated::scenes::ball_chain;
use constraint_articulated::Method;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dt: f64 = args
        .get(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0 / 60.0);
    let tip: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1000.0);
    let beta: f64 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let method = match args.get(2).map(String::as_str) {
        Some("projected") => Method::VelocityProjected {
            beta,
            tolerance: 1e-10,
            max_iterations: 10,
            correct_velocity: false,
        },
        _ => Method::Velocity { beta },
    };
    let mut w = match ball_chain(20, tip) {
        Ok(w) => w,
        Err(e) => return eprintln!("{e}"),
    };
    let steps = (10.0 / dt).round() as usize;
    let per_s = (1.0 / dt).round() as usize;
    for i in 1..=steps {
        let stats = match w.step(dt, method) {
            Ok(s) => s,
            Err(e) => return eprintln!("step {i}: {e}"),
        };
        let verbose = std::env::var("VERBOSE").is_ok() && i < 60;
        if verbose {
            let (k, p) = w.energy();
            println!(
                "step {i}: iterations {} separation {:.2e} energy {:.4}",
                stats.projection_iterations,
                w.max_separation(),
                k + p
            );
        }
        if i % per_s == 0 || i < 5 {
            let (k, p) = w.energy();
            println!(
                "t = {:6.3} s  separation {:.2e} m  energy {:.4} J",
                i as f64 * dt,
                w.max_separation(),
                k + p
            );
        }
    }
}
