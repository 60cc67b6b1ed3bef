//! Steps the ten-box stack on the dense exact path (`ContactSolver::Auto`, which
//! resolves to Newton with staggered friction at this size) for a fixed number of
//! steps at `h = 1/60` and prints the top box's drift: a fixed run for CPU-time
//! measurements (`perf stat -e task-clock`).
//!
//! `cargo run -p constraint-contact --release --example stack_steps -- [STEPS] [SUBSTEPS]`
//! (`SUBSTEPS` given: the soft step, `ContactSolver::SoftStep`, with that many
//! sub-steps and default soft settings, instead of the dense path).

use constraint_contact::rigid::ContactSolver;
use constraint_contact::scenes::box_stack;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let steps: usize = match std::env::args().nth(1) {
        Some(s) => s.parse()?,
        None => 3060,
    };
    let mut w = box_stack(10)?;
    w.settings.solver = match std::env::args().nth(2) {
        Some(s) => ContactSolver::SoftStep {
            substeps: s.parse()?,
        },
        None => ContactSolver::Auto,
    };
    let z0 = w.bodies()[w.bodies().len() - 1].pose.x.z;
    let h = 1.0 / 60.0;
    // One second to settle, then the measured drift.
    for _ in 0..60 {
        w.step(h)?;
    }
    let top = w.bodies().len() - 1;
    let x0 = w.bodies()[top].pose.x;
    for _ in 60..steps {
        w.step(h)?;
    }
    let d = (w.bodies()[top].pose.x - x0).length();
    let sink = z0 - w.bodies()[top].pose.x.z;
    println!("{steps} steps, top-box drift {d:.3e} m after the first second, sink {sink:.3e} m from the start");
    Ok(())
}
