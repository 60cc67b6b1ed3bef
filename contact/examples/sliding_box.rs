//! The sliding box of issue 14 (`constraint-peers`' `Scene::SlidingBox`): a 0.2 m box
//! (density 1000, friction 0.5) launched along `x` at 3 m/s on the ground plane,
//! stepped at `h = 1/60`; it should stop after `v²/(2μg)` = 0.91743 m (g = 9.81).
//! Prints the horizontal travel after `STEPS` steps and its error against that. A
//! fixed run for instruction counts (`valgrind --tool=callgrind`; subtract a shorter
//! run for the count per step).
//!
//! Every solver here steps semi-implicit Euler (`x += h v'`), whose travel under a
//! constant deceleration `a` is `v²/(2a) − v h/2`: at `h = 1/60` a one-step solver ends
//! 2.5e-2 m (2.7 %) short whatever it solves (MuJoCo's Euler 2.43e-2 m), and within
//! 1 % takes sub-steps (`soft3`: 8.4e-3 m, `soft4`: 6.3e-3 m). Measured (callgrind
//! instructions per step over 600 steps, `(N = 600) − (N = 0)`; MuJoCo 4.0.0 on
//! `scenes/sliding_box.xml` at 1/60 through `mujoco.rollout` the same way): MuJoCo
//! 44.2k; `auto` 23.3k (the sequential impulses, which solve this ground-only contact
//! exactly; 79.8k on the dense Newton path: 58.7k at rest, and the 15 steps after the
//! stop 0.88M each, friction PGS at its sweep budget), `si` 21.4k, `newton` 79.8k,
//! `soft3` 31.7k, `soft4` 37.0k.
//!
//! `cargo run -p constraint-contact --release --example sliding_box -- SOLVER STEPS`
//!
//! `SOLVER`: `auto`, `si` (sequential impulses), `newton`, `pgs`, `lemke`, or `softN`
//! (the soft step with `N` sub-steps). `REPEAT=k` runs the whole thing `k` times (for
//! wall-clock timing: the time printed is the fastest run's; the figures, the last run's);
//! `BITS=1` prints the final state in full (checking that a change is bit-identical).

use constraint_contact::rigid::{ContactSolver, ContactWorld};
use constraint_contact::scenes::{add_box, ground};
use constraint_core::DVec3;

/// Launch speed (m/s) and friction, as `constraint_peers::contact`.
const SPEED: f64 = 3.0;
const MU: f64 = 0.5;

fn world(solver: ContactSolver) -> Result<ContactWorld, Box<dyn std::error::Error>> {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
    ground(&mut w, MU)?;
    let b = add_box(
        &mut w,
        DVec3::splat(0.1),
        None,
        DVec3::new(0.0, 0.0, 0.1),
        MU,
    )?;
    w.bodies_mut()[b].v = DVec3::new(SPEED, 0.0, 0.0);
    w.settings.solver = solver;
    Ok(w)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("auto", String::as_str);
    let steps: usize = args.get(1).map_or(Ok(600), |s| s.parse())?;
    let solver = match name {
        "auto" => ContactSolver::Auto,
        "si" => ContactSolver::SequentialImpulses,
        "newton" => ContactSolver::Newton,
        "pgs" => ContactSolver::Pgs,
        "lemke" => ContactSolver::Lemke,
        s if s.starts_with("soft") => ContactSolver::SoftStep {
            substeps: s[4..].parse()?,
        },
        other => return Err(format!("unknown solver {other}").into()),
    };
    let repeat: usize = std::env::var("REPEAT").map_or(Ok(1), |s| s.parse())?;
    let h = 1.0 / 60.0;
    let exact = SPEED * SPEED / (2.0 * MU * 9.81);
    let print = std::env::var("STATS").is_ok();
    let mut w = world(solver)?;
    let mut best = f64::INFINITY;
    for _ in 0..repeat {
        w = world(solver)?;
        let t0 = std::time::Instant::now();
        for k in 0..steps {
            let stats = w.step(h)?;
            if print {
                println!(
                    "{k} contacts {} iterations {} residual {:?} path {:?} vx {:.4e}",
                    stats.contacts,
                    stats.iterations,
                    stats.residual,
                    w.last_path(),
                    w.bodies()[0].v.x
                );
            }
        }
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let x = w.bodies()[0].pose.x;
    let travel = (x.x * x.x + x.y * x.y).sqrt();
    println!(
        "sliding_box {name} {steps} steps: travel {travel:.6} m, error {:.3e} m ({:.3} %), z {:.6e}, {:.3} us/step",
        (travel - exact).abs(),
        100.0 * (travel - exact).abs() / exact,
        x.z - 0.1,
        1e6 * best / steps as f64
    );
    if std::env::var("BITS").is_ok() {
        // The final state's bits, for checking that a change is bit-identical.
        let b = &w.bodies()[0];
        println!(
            "x {:?} q {:?} v {:?} omega {:?}",
            b.pose.x, b.pose.q, b.v, b.omega
        );
    }
    Ok(())
}
