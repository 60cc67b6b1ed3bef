//! Time per step of this library's soft step against rapier3d (f64) on the same contact
//! scene, measured *interleaved* in one process: `ROUNDS` rounds, each timing `BATCH`
//! steps of ours and then `BATCH` steps of rapier3d (the order alternating between
//! rounds), and the ratio ours / rapier3d taken per round. Needs the `rapier` feature.
//!
//! `cargo run -p constraint-peers --release --features rapier --example paired_ratio -- [SCENE [SUBSTEPS [ROUNDS [BATCH]]]]`
//!
//! `SCENE`: `stack10` (default) or `pyramid20`; `SUBSTEPS`: the soft step's sub-steps
//! (3, `Auto`'s count, by default); `ROUNDS` 41 and `BATCH` 100 (stack) or 10
//! (pyramid) by default. Both worlds are stepped 1 s from rest first, as in the
//! `contact_peers` bench, and keep stepping through the rounds (the stack and the
//! pyramid stay at rest, so every batch times the same work).
//!
//! Why: this machine's wall times drift between runs (rapier3d's stack step measured
//! 25–48 µs in separate criterion runs of the same binary), so two engines timed
//! minutes apart give ratios that wander by ±30 %. Rounds of a few milliseconds see
//! the same machine state for both engines; the median of the per-round ratios is
//! the figure to compare, and its quartiles show how far to trust it. Prints the
//! median ratio, its quartiles, and each engine's median µs per step, then the same as
//! one tab-separated line `paired SCENE SUBSTEPS ROUNDS BATCH MEDIAN Q1 Q3 OURS_US
//! RAPIER_US` (`cargo xtask bench` reads it into `target/bench/ratios.md`).

use constraint_contact::rigid::ContactSolver;
use constraint_peers::contact::{ours, rapier, Scene, DT};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("stack10", String::as_str);
    let scene = Scene::from_name(name).ok_or(format!("unknown scene {name}"))?;
    let substeps: usize = args.get(1).map_or(Ok(3), |s| s.parse())?;
    let rounds: usize = args.get(2).map_or(Ok(41), |s| s.parse())?;
    let default_batch = if matches!(scene, Scene::Stack(_)) {
        100
    } else {
        10
    };
    let batch: usize = args.get(3).map_or(Ok(default_batch), |s| s.parse())?;
    if rounds == 0 || batch == 0 {
        return Err("ROUNDS and BATCH must be positive".into());
    }
    let mut w = ours::world(scene, ContactSolver::SoftStep { substeps }, DT, 1.0)?;
    let mut r = rapier::world(&scene.world()?, DT, 1.0)?;
    let mut time_ours = || -> Result<f64, Box<dyn std::error::Error>> {
        let t = Instant::now();
        for _ in 0..batch {
            w.step(DT)?;
        }
        Ok(t.elapsed().as_secs_f64())
    };
    let mut time_rapier = || {
        let t = Instant::now();
        for _ in 0..batch {
            r.step();
        }
        t.elapsed().as_secs_f64()
    };
    let (mut ratio, mut us_ours, mut us_rapier) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..rounds {
        let (a, b) = if k % 2 == 0 {
            let a = time_ours()?;
            (a, time_rapier())
        } else {
            let b = time_rapier();
            (time_ours()?, b)
        };
        ratio.push(a / b);
        us_ours.push(a / batch as f64 * 1e6);
        us_rapier.push(b / batch as f64 * 1e6);
    }
    let q = |v: &mut Vec<f64>, p: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * p).round() as usize]
    };
    let (m, lo, hi) = (q(&mut ratio, 0.5), q(&mut ratio, 0.25), q(&mut ratio, 0.75));
    let (a, b) = (q(&mut us_ours, 0.5), q(&mut us_rapier, 0.5));
    let name = scene.name();
    println!(
        "{name} soft{substeps} / rapier3d: median {m:.3} (quartiles {lo:.3} … {hi:.3}) over {rounds} rounds of {batch} steps; ours {a:.2} µs/step, rapier3d {b:.2} µs/step (medians)"
    );
    // The same figures for `cargo xtask bench` to read.
    println!("paired\t{name}\t{substeps}\t{rounds}\t{batch}\t{m}\t{lo}\t{hi}\t{a}\t{b}");
    Ok(())
}
