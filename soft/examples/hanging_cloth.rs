//! Hangs a cloth from its two top corners and prints its state once per simulated
//! 0.25 s: `cargo run --release -p constraint-soft --example hanging_cloth -- [n] [h]`.

use constraint_soft::{Cloth, HessianMode, ImplicitEuler, Integrator, LinearSolver};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(32);
    let h: f64 = args
        .next()
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(1.0 / 60.0);
    let mut sys = Cloth {
        n,
        ..Cloth::default()
    }
    .build()?;
    let mut step = ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt)?;
    let steps = (2.0 / h).round() as usize;
    let t0 = Instant::now();
    for k in 1..=steps {
        step.step(&mut sys)?;
        if k % ((0.25 / h).round() as usize).max(1) == 0 {
            let low = sys.x.iter().map(|x| x.z).fold(f64::INFINITY, f64::min);
            println!(
                "t = {:5.2} s  lowest z = {:+.4} m  max |C| = {:.3e}  E = {:+.5} J",
                k as f64 * h,
                low,
                sys.max_violation(),
                sys.kinetic_energy() + sys.potential_energy()
            );
        }
    }
    let per = t0.elapsed().as_secs_f64() / steps as f64;
    println!("{} particles, {:.3} ms per step", n * n, per * 1e3);
    Ok(())
}
