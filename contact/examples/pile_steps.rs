//! Pours a pile of `N` mixed bodies (`scenes::pile`) with the soft step (4 sub-steps)
//! for a fixed number of steps at `h = 1/60` on `THREADS` threads, and prints the time
//! per step and a hash of the final state (the same on any thread count): a fixed run
//! for timing the threaded soft step.
//!
//! `cargo run -p constraint-contact --release --features parallel --example pile_steps -- [N] [STEPS] [THREADS] [SETTLE] [SLEEP]`
//!
//! `SETTLE` steps (default 0) run first, untimed; `SLEEP` 1 turns sleeping on
//! (`SleepSettings::enabled`, default 0). It then also prints the bodies asleep: the
//! growth of the sleeping pile's time per step is that of the awake bodies it has.

use constraint_contact::rigid::ContactSolver;
use constraint_contact::scenes::pile;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |i: usize, default: usize| -> Result<usize, Box<dyn std::error::Error>> {
        Ok(match std::env::args().nth(i) {
            Some(s) => s.parse()?,
            None => default,
        })
    };
    let (n, steps, threads) = (arg(1, 10_000)?, arg(2, 120)?, arg(3, 1)?);
    let (settle, sleep) = (arg(4, 0)?, arg(5, 0)? == 1);
    let mut w = pile(n, 1)?;
    w.settings.solver = ContactSolver::SoftStep { substeps: 4 };
    w.settings.soft_step.threads = threads;
    w.settings.sleep.enabled = sleep;
    for _ in 0..settle {
        w.step(1.0 / 60.0)?;
    }
    let start = Instant::now();
    let (mut points, mut asleep) = (0, 0);
    for _ in 0..steps {
        let stats = w.step(1.0 / 60.0)?;
        points = w.contacts().len();
        asleep = stats.asleep;
    }
    let per_step = start.elapsed().as_secs_f64() / steps as f64;
    // FNV-1a over the bits of every pose and velocity.
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for b in w.bodies() {
        for x in b
            .pose
            .x
            .to_array()
            .into_iter()
            .chain(b.pose.q.to_array())
            .chain(b.v.to_array())
            .chain(b.omega.to_array())
        {
            hash ^= x.to_bits();
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    println!(
        "{n} bodies, {steps} steps, {threads} threads: {:.3} ms per step, {points} points and {asleep} bodies asleep at the end, state hash {hash:016x}",
        per_step * 1e3
    );
    Ok(())
}
