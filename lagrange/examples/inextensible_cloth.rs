//! Goldenthal-style inextensible cloth: implicit soft step + fast projection.
//! `cargo run --release -p constraint-lagrange --example inextensible_cloth -- [n] [tol]`

use constraint_lagrange::scenes::{add_bending, tilted_inextensible_cloth};
use constraint_lagrange::{BaseStep, FastProjection, KktSolver, ProjectedStep, VelocityLevel};
use constraint_soft::{HessianMode, ImplicitEuler, LinearSolver};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(64);
    let tol: f64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(1e-3);
    let h: f64 = std::env::var("H")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0 / 60.0);
    let tilt: f64 = std::env::var("TILT")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let (mut sys, cons) = tilted_inextensible_cloth(n, 10.0, tilt)?;
    let kb: f64 = std::env::var("KB")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.0);
    if kb > 0.0 {
        add_bending(&mut sys, n, kb)?;
    }
    let mut step = ProjectedStep::new(
        ImplicitEuler::new(h, HessianMode::GaussNewton, LinearSolver::SparseLdlt)?,
        FastProjection::new(tol, 50, KktSolver::SparseSchur)?,
    );
    let steps = (1.0 / h).round() as usize;
    let (mut iters, mut worst) = (0, 0.0f64);
    let velocity_first = std::env::var("VEL").is_ok();
    let mut vl = VelocityLevel::new(
        h,
        BaseStep::Implicit(Box::new(ImplicitEuler::new(
            h,
            HessianMode::GaussNewton,
            LinearSolver::SparseLdlt,
        )?)),
        KktSolver::Minres(Default::default()),
    )?;
    vl.projection = Some(FastProjection::new(tol, 50, KktSolver::SparseSchur)?);
    let t0 = Instant::now();
    for _ in 0..steps {
        let st = if velocity_first {
            vl.step(&mut sys, &cons)?;
            vl.last_projection.unwrap_or_default()
        } else {
            step.step(&mut sys, &cons)?
        };
        if std::env::var("DBG").is_ok() {
            println!("{:?}", st);
        }
        iters += st.iterations;
        worst = worst.max(st.r#final);
    }
    let ms = t0.elapsed().as_secs_f64() * 1e3 / steps as f64;
    println!(
        "n = {n}: {ms:.2} ms/step, {:.2} projection iterations/step, worst strain {worst:.2e} (tolerance {tol:.0e})",
        iters as f64 / steps as f64
    );
    Ok(())
}
