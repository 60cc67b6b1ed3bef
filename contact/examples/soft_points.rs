//! One measured point of the soft step (`ContactSolver::SoftStep`): runs a scene for a
//! number of steps at `h = 1/60` from the start and prints the figures the peer
//! comparison records (`constraint-peers`' `Tracker`): the top box's largest
//! displacement from its start (drift), its final sink, and the worst displacement of
//! any box. A fixed run for instruction counts (`valgrind --tool=callgrind`; subtract a
//! shorter run for the count per step).
//!
//! `cargo run -p constraint-contact --release --example soft_points -- SCENE STEPS SUBSTEPS [KEY=VALUE ...]`
//!
//! `SCENE`: `stack10` (`scenes::box_stack(10)`), `pyramid20` (`scenes::pyramid(20)`),
//! `pyramid6` (`scenes::pyramid(6)`, the allocation test's),
//! `heavy1e4` (`scenes::heavy_on_light(1e4)`) or `pile1000`; keys: `hertz`, `zeta`, `push`,
//! `anchors` (0/1), `oneway` (the one-way mass ratio), `block` (0/1), `preload`,
//! `relax` (relax passes), `residual` (0/1), `threads`, `estimate` (0/1:
//! `preload_estimate`), `refill` (0/1: `refill_renamed`), `margin` (`preload_cap_margin`) (the
//! `SoftStepSettings` fields);
//! `pile1000` (`scenes::pile(1000, 1)`) prints the deepest penetration of the last
//! step. `TRACE=1` prints the top box's displacement every 20 steps (and each of the
//! first 20; `ALL=1`: every step), `BOX=i` traces box `i` instead of the top box (its
//! drift and sink are then box `i`'s), `COUNT=1` the contacts and deepest penetration of
//! every step, `LEVELS=1` the mean and lowest vertical displacement of the boxes by start
//! height at the end, `WORST=1` the five most displaced boxes at the end, `BITS=1` an
//! FNV-1a hash of every body's pose and twist bits at the end (the bit-identity check
//! of a change that must not move the trajectory: the printed figures have 4 digits),
//! and one of the last step's contact impulses (`ContactWorld::impulses`); `SUBNORMAL=1`
//! counts the subnormal values (`x != 0`, `|x| < f64::MIN_POSITIVE`) in the carried
//! warm-start state (`ContactWorld::soft_warm_values`) and the last impulses at the end;
//! `SPLIT=K` the thread's CPU time a step over the first and the last `K` steps (Linux).

use constraint_contact::rigid::{ContactSolver, ContactWorld};
use constraint_contact::scenes::{box_stack, heavy_on_light, pile, pyramid};

fn centres(w: &ContactWorld) -> Vec<[f64; 3]> {
    w.bodies().iter().map(|b| b.pose.x.to_array()).collect()
}

/// FNV-1a over the bits of every body's position, orientation, velocity and angular
/// velocity, in body order.
fn state_bits(w: &ContactWorld) -> u64 {
    let mut words = Vec::new();
    for b in w.bodies() {
        let q = b.pose.q;
        words.extend(b.pose.x.to_array().into_iter().chain([q.x, q.y, q.z, q.w]));
        words.extend(b.v.to_array().into_iter().chain(b.omega.to_array()));
    }
    fnv(&words)
}

/// This thread's CPU time in nanoseconds (the first field of Linux's
/// `/proc/thread-self/schedstat`; 0 where it cannot be read).
fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or(0)
}

/// FNV-1a of the bits of `words`.
fn fnv(words: &[f64]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for x in words {
        for byte in x.to_bits().to_le_bytes() {
            h = (h ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = args.first().map_or("stack10", String::as_str);
    let steps: usize = args.get(1).map_or(Ok(600), |s| s.parse())?;
    let substeps: usize = args.get(2).map_or(Ok(4), |s| s.parse())?;
    let mut w = match scene {
        "stack10" => box_stack(10)?,
        "pyramid20" => pyramid(20)?,
        "pyramid6" => pyramid(6)?,
        "heavy1e4" => heavy_on_light(1e4)?,
        "pile1000" => pile(1000, 1)?,
        other => return Err(format!("unknown scene {other}").into()),
    };
    w.settings.solver = ContactSolver::SoftStep { substeps };
    let s = &mut w.settings.soft_step;
    for kv in args.iter().skip(3) {
        let (k, v) = kv.split_once('=').ok_or("expected KEY=VALUE")?;
        let x: f64 = v.parse()?;
        match k {
            "hertz" => s.hertz = x,
            "zeta" => s.damping_ratio = x,
            "push" => s.max_push_velocity = x,
            "anchors" => s.friction_anchors = x != 0.0,
            "oneway" => s.one_way_mass_ratio = x,
            "block" => s.block_normal = x != 0.0,
            "preload" => s.preload = x,
            "relax" => s.relax_passes = x as usize,
            "residual" => s.residual = x != 0.0,
            "threads" => s.threads = x as usize,
            "estimate" => s.preload_estimate = x != 0.0,
            "refill" => s.refill_renamed = x != 0.0,
            "margin" => s.preload_cap_margin = x,
            other => return Err(format!("unknown key {other}").into()),
        }
    }
    let x0 = centres(&w);
    let top = (0..x0.len()).fold(0, |t, i| if x0[i][2] > x0[t][2] { i } else { t });
    let top = match std::env::var("BOX") {
        Ok(b) => b.parse()?,
        Err(_) => top,
    };
    let (mut drift, mut worst) = (0.0f64, 0.0f64);
    let h = 1.0 / 60.0;
    // The environment is read once, not per step (a `getenv` per step was ≈ 900 of
    // the 10-box stack's ≈ 206k instructions a step, counted as the step's).
    let trace = std::env::var("TRACE").is_ok();
    let count = std::env::var("COUNT").is_ok();
    let all = std::env::var("ALL").is_ok();
    let mut depth = 0.0;
    // Kept between steps: no allocation per step in the harness.
    let mut now = Vec::with_capacity(x0.len());
    // `SPLIT=K`: this thread's CPU time over the first and the last `K` steps (marks
    // at steps `K` and `steps − K`; `usize::MAX` where off, never met).
    let split: Option<usize> = std::env::var("SPLIT").ok().map(|s| s.parse()).transpose()?;
    let (mark_a, mark_b) = split.map_or((usize::MAX, usize::MAX), |k| (k, steps.saturating_sub(k)));
    let mut cpu = [cpu_ns(), 0, 0];
    for k in 0..steps {
        if k == mark_a || k == mark_b {
            cpu[if k == mark_a { 1 } else { 2 }] = cpu_ns();
        }
        let stats = w.step(h)?;
        depth = stats.max_penetration;
        if count {
            println!("{k} contacts {} deepest {:.3e}", stats.contacts, depth);
        }
        if trace && (k < 20 || k % 20 == 0 || all) {
            let x = w.bodies()[top].pose.x;
            println!(
                "{k} top {:.4e} {:.4e} {:.4e}",
                x.x - x0[top][0],
                x.y - x0[top][1],
                x.z - x0[top][2]
            );
        }
        now.clear();
        now.extend(w.bodies().iter().map(|b| b.pose.x.to_array()));
        for (i, (p, p0)) in now.iter().zip(&x0).enumerate() {
            let d = distance(*p, *p0);
            let d = if d.is_finite() { d } else { f64::INFINITY };
            worst = worst.max(d);
            if i == top {
                drift = drift.max(d);
            }
        }
    }
    if std::env::var("LEVELS").is_ok() {
        // Mean and lowest vertical displacement per start height (pyramid level).
        let x = centres(&w);
        let mut rows: Vec<(f64, f64, f64, f64)> = Vec::new();
        for (p, p0) in x.iter().zip(&x0) {
            let dz = p[2] - p0[2];
            match rows.iter_mut().find(|r| (r.0 - p0[2]).abs() < 1e-9) {
                Some(r) => {
                    r.1 += dz;
                    r.2 = r.2.min(dz);
                    r.3 += 1.0;
                }
                None => rows.push((p0[2], dz, dz, 1.0)),
            }
        }
        for r in rows {
            print!("{:.1}:{:.2}/{:.2} ", r.0, 1e3 * r.1 / r.3, 1e3 * r.2);
        }
        println!();
    }
    if std::env::var("WORST").is_ok() {
        let x = centres(&w);
        let mut v: Vec<(f64, usize)> = x
            .iter()
            .zip(&x0)
            .enumerate()
            .map(|(i, (p, p0))| (distance(*p, *p0), i))
            .collect();
        v.sort_by(|a, b| b.0.total_cmp(&a.0));
        for &(d, i) in v.iter().take(5) {
            println!(
                "box {i} at {:?}: end displacement {d:.3e} = {:.3e} {:.3e} {:.3e}",
                x0[i],
                x[i][0] - x0[i][0],
                x[i][1] - x0[i][1],
                x[i][2] - x0[i][2]
            );
        }
    }
    if let Some(k) = split {
        let per = |ns: u64| ns as f64 / k as f64 / 1e3;
        println!(
            "cpu per step: first {k} {:.3} us, last {k} {:.3} us",
            per(cpu[1] - cpu[0]),
            per(cpu_ns() - cpu[2])
        );
    }
    if std::env::var("SUBNORMAL").is_ok() {
        let tiny = |x: f64| x != 0.0 && x.abs() < f64::MIN_POSITIVE;
        let warm: Vec<f64> = w.soft_warm_values().collect();
        let floors = warm.iter().skip(4).step_by(5);
        let impulses = w.impulses().iter().filter(|x| tiny(**x)).count();
        println!(
            "subnormal: warm {} of {} (floors {} of {}), impulses {} of {}",
            warm.iter().filter(|x| tiny(**x)).count(),
            warm.len(),
            floors.clone().filter(|x| tiny(**x)).count(),
            floors.count(),
            impulses,
            w.impulses().len()
        );
    }
    if std::env::var("BITS").is_ok() {
        println!("state bits {:016x}", state_bits(&w));
        println!("impulse bits {:016x}", fnv(w.impulses()));
    }
    let sink = x0[top][2] - w.bodies()[top].pose.x.z;
    println!("{scene} {steps} steps soft{substeps}: drift {drift:.3e} m, sink {sink:.3e} m, worst {worst:.3e} m, deepest at the end {depth:.3e} m");
    Ok(())
}
