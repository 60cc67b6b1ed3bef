//! Time per step of a ball-joint chain lying on the floor
//! ([`constraint_articulated::scenes::chain_on_floor`]`(n, 0.01, 0.5)`) against the same
//! chain swinging free ([`constraint_articulated::scenes::ball_chain`]`(n, 1.0)`), both
//! after 200 settling steps at h = 1e-3, and the 20-link chain falling from z0 = 0.3
//! (2 s). Prints medians of individually timed steps, the contact points and one-sided
//! rows per step, the LCP's iterations and residual, penetration and joint separation,
//! and the least-squares growth exponents of time against n. Also a convenient target
//! for `perf record` / `valgrind --tool=callgrind` (`profile N [steps]`). The floor
//! rows go by the active set in the tree factor (`world/active_set.rs`), whose
//! iterations the "LCP iters" column then shows.
//!
//! ```text
//! cargo run --release -p constraint-articulated --features contact --example floor_profile -- \
//!     table [sizes=10,20,50,100] [cap_s=1.0] [budget_s=2.0]
//! cargo run ... --example floor_profile -- fall
//! cargo run ... --example floor_profile -- profile 200 [timed_steps=20] [velocity|projected]
//! ```
//!
//! Needs feature `contact` (without it, main only says so).

#[cfg(not(feature = "contact"))]
fn main() {
    eprintln!("floor_profile needs --features contact");
}

#[cfg(feature = "contact")]
fn main() {
    imp::main();
}

#[cfg(feature = "contact")]
mod imp {
    use constraint_articulated::scenes::{ball_chain, chain_on_floor};
    use constraint_articulated::{Method, World};
    use std::time::Instant;

    const H: f64 = 1e-3;

    fn projected() -> Method {
        Method::VelocityProjected {
            beta: 1.0,
            tolerance: 1e-10,
            max_iterations: 10,
            correct_velocity: false,
        }
    }

    fn method(name: &str) -> Method {
        match name {
            "projected" => projected(),
            _ => Method::Velocity { beta: 1.0 },
        }
    }

    fn median(v: &mut [f64]) -> f64 {
        v.sort_by(f64::total_cmp);
        let k = v.len();
        if k % 2 == 1 {
            v[k / 2]
        } else {
            0.5 * (v[k / 2 - 1] + v[k / 2])
        }
    }

    /// Least-squares slope of ln t against ln n.
    fn slope(pts: &[(f64, f64)]) -> f64 {
        let k = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0.ln()).sum::<f64>() / k;
        let my = pts.iter().map(|p| p.1.ln()).sum::<f64>() / k;
        let (mut num, mut den) = (0.0, 0.0);
        for (x, y) in pts {
            num += (x.ln() - mx) * (y.ln() - my);
            den += (x.ln() - mx).powi(2);
        }
        num / den
    }

    struct Measured {
        /// Median seconds per step (None: capped).
        t: Option<f64>,
        steps: usize,
        contacts: usize,
        rows: usize,
        iterations: usize,
        residual: f64,
        penetration: f64,
        separation: f64,
        note: String,
    }

    fn step(w: &mut World, m: Method) {
        if let Err(e) = w.step(H, m) {
            panic!("step failed: {e}");
        }
    }

    /// Settles `settle` steps (giving up when one step takes more than `cap_s`), then
    /// times steps one by one for about `budget_s` (at least 5, at most 400).
    fn measure(mut w: World, m: Method, settle: usize, cap_s: f64, budget_s: f64) -> Measured {
        let mut note = String::new();
        let t0 = Instant::now();
        step(&mut w, m);
        let first = t0.elapsed().as_secs_f64();
        let mut settled = 1;
        if first > cap_s {
            note = format!("capped: first step {first:.2} s");
        } else {
            // Settle, but never longer than ~60 s of wall clock.
            let start = Instant::now();
            while settled < settle {
                step(&mut w, m);
                settled += 1;
                if start.elapsed().as_secs_f64() > 60.0 {
                    note = format!("settled only {settled} steps (60 s)");
                    break;
                }
            }
        }
        let mut times = Vec::new();
        if note.starts_with("capped") {
            times.push(first);
        } else {
            let start = Instant::now();
            while times.len() < 400 && (times.len() < 5 || start.elapsed().as_secs_f64() < budget_s)
            {
                let t = Instant::now();
                step(&mut w, m);
                times.push(t.elapsed().as_secs_f64());
            }
        }
        let s = w.unilateral_stats();
        let steps = times.len();
        let t = median(&mut times);
        Measured {
            t: (!note.starts_with("capped")).then_some(t),
            steps,
            contacts: s.contacts,
            rows: s.rows,
            iterations: s.solver.iterations,
            residual: s.residual,
            penetration: s.max_penetration,
            separation: w.max_separation(),
            note: if note.is_empty() {
                format!("{settled}+{steps} steps")
            } else {
                format!("{note}; first step {:.3e} s", first)
            },
        }
    }

    fn table(args: &[String]) {
        let sizes: Vec<usize> = args
            .first()
            .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
            .unwrap_or_else(|| vec![10, 20, 50, 100, 200, 500, 1000]);
        let cap_s: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1.0);
        let budget_s: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2.0);
        let mut pts: [Vec<(f64, f64)>; 4] = Default::default();
        println!(
            "| n | scene | method | µs/step | contacts | rows | LCP iters | residual | max pen (m) | max sep (m) | note |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|");
        for &n in &sizes {
            let runs: [(&str, &str, Method); 4] = [
                ("free", "velocity", Method::Velocity { beta: 1.0 }),
                ("free", "projected", projected()),
                ("floor", "velocity", Method::Velocity { beta: 1.0 }),
                ("floor", "projected", projected()),
            ];
            for (k, (scene, mname, m)) in runs.into_iter().enumerate() {
                let w = match scene {
                    "free" => ball_chain(n, 1.0),
                    _ => chain_on_floor(n, 0.01, 0.5),
                }
                .unwrap_or_else(|e| panic!("{e}"));
                let r = measure(w, m, 200, cap_s, budget_s);
                if let Some(t) = r.t {
                    pts[k].push((n as f64, t));
                }
                println!(
                    "| {n} | {scene} | {mname} | {} | {} | {} | {} | {:.1e} | {:.2e} | {:.2e} | {} |",
                    r.t.map_or("—".into(), |t| format!("{:.1}", t * 1e6)),
                    r.contacts,
                    r.rows,
                    r.iterations,
                    r.residual,
                    r.penetration,
                    r.separation,
                    r.note
                );
                let _ = r.steps;
            }
        }
        let names = [
            "free velocity",
            "free projected",
            "floor velocity",
            "floor projected",
        ];
        for (k, name) in names.iter().enumerate() {
            if pts[k].len() >= 2 {
                println!(
                    "exponent {name}: {:.3} over n = {:?}",
                    slope(&pts[k]),
                    pts[k].iter().map(|p| p.0 as usize).collect::<Vec<_>>()
                );
            }
        }
    }

    /// The 20-link chain dropped from z0 = 0.3: 2 s at h = 1e-3, velocity level.
    fn fall() {
        for mname in ["velocity", "projected"] {
            let m = method(mname);
            let mut w = chain_on_floor(20, 0.3, 0.5).unwrap_or_else(|e| panic!("{e}"));
            let mut times = Vec::with_capacity(2000);
            let (mut max_pen, mut max_res, mut max_sep) = (0.0f64, 0.0f64, 0.0f64);
            let mut first_contact = None;
            let start = Instant::now();
            for i in 0..2000 {
                let t = Instant::now();
                step(&mut w, m);
                times.push(t.elapsed().as_secs_f64());
                let s = w.unilateral_stats();
                if s.contacts > 0 && first_contact.is_none() {
                    first_contact = Some(i);
                }
                max_pen = max_pen.max(s.max_penetration);
                max_res = max_res.max(s.residual);
                max_sep = max_sep.max(w.max_separation());
            }
            let total = start.elapsed().as_secs_f64();
            let s = w.unilateral_stats();
            let mean = times.iter().sum::<f64>() / times.len() as f64;
            let tmax = times.iter().cloned().fold(0.0, f64::max);
            let med = median(&mut times);
            let zmax = w
                .bodies()
                .iter()
                .map(|b| b.pose.x.z)
                .fold(f64::NEG_INFINITY, f64::max);
            let vmax = w.bodies().iter().map(|b| b.v.length()).fold(0.0, f64::max);
            println!(
                "fall 20 links z0=0.3 {mname}: mean {:.1} µs/step, median {:.1} µs, max {:.1} µs, total {:.3} s; \
                 first contact at step {:?}; end: contacts {} rows {} residual {:.1e} pen {:.2e} m sep {:.2e} m, \
                 highest link z {:.4} m, max |v| {:.2e} m/s; over the run: max pen {:.2e} m, max residual {:.1e}, max sep {:.2e} m",
                mean * 1e6,
                med * 1e6,
                tmax * 1e6,
                total,
                first_contact,
                s.contacts,
                s.rows,
                s.residual,
                s.max_penetration,
                w.max_separation(),
                zmax,
                vmax,
                max_pen,
                max_res,
                max_sep
            );
        }
    }

    /// Settles chain_on_floor(n) and times `steps` more: the target for a profiler.
    fn profile(args: &[String]) {
        let n: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(200);
        let steps: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(20);
        let m = method(args.get(2).map_or("velocity", String::as_str));
        let settle: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(200);
        let mut w = chain_on_floor(n, 0.01, 0.5).unwrap_or_else(|e| panic!("{e}"));
        let t = Instant::now();
        for _ in 0..settle {
            step(&mut w, m);
        }
        let ts = t.elapsed().as_secs_f64();
        let t = Instant::now();
        for _ in 0..steps {
            step(&mut w, m);
        }
        let tt = t.elapsed().as_secs_f64();
        let s = w.unilateral_stats();
        println!(
            "profile n={n}: settle {settle} steps {:.3} s, then {steps} steps {:.1} µs/step; contacts {} rows {} iters {} residual {:.1e}",
            ts,
            tt / steps as f64 * 1e6,
            s.contacts,
            s.rows,
            s.solver.iterations,
            s.residual
        );
    }

    pub fn main() {
        let args: Vec<String> = std::env::args().skip(1).collect();
        match args.first().map(String::as_str) {
            Some("fall") => fall(),
            Some("profile") => profile(&args[1..]),
            Some("table") => table(&args[1..]),
            _ => table(&args),
        }
    }
}
