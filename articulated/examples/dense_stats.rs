//! The dense contact path's work on an MJCF model (`world/unilateral.rs`): the model runs
//! passive from `qpos0` (RATTLE, as `simulate`'s default) for `--warm` seconds, then
//! `--steps` steps are counted: dense steps, their staggered alternations (and how many
//! ended at the cap), friction budgets, LCP iterations, the worst residual, and a hash of
//! the final body poses (to compare runs bit for bit). The counted steps run inside
//! `measured0` … `measured3` (one per variant of `DS_VARIANTS`, e.g.
//! `fiter=10,maxsw=30;fiter=20`, each from a clone of the warmed-up world), targets for
//! `valgrind --tool=callgrind --toggle-collect='*measured*'`.
//!
//! ```text
//! cargo run --release -p constraint-articulated --features contact --example dense_stats -- \
//!     MODEL.xml [--warm 1.5] [--steps 100] [--ctrl C.csv] [--print-above R]
//! ```
//!
//! `--ctrl` applies a control file (`t,<actuator>...`, as `simulate --ctrl`) through the
//! warm-up and the counted steps; `--print-above R` prints each counted dense step whose
//! residual exceeds `R` (rows, residual, alternations, iterations).
//!
//! Needs feature `contact` (without it, main only says so).

#[cfg(not(feature = "contact"))]
fn main() {
    eprintln!("dense_stats needs --features contact");
}

#[cfg(feature = "contact")]
fn main() {
    imp::main();
}

#[cfg(feature = "contact")]
mod imp {
    use constraint_articulated::mjcf::MjcfScene;
    use constraint_articulated::{Method, World};

    /// A control file (`t,<actuator>...`): the change times and each row's values by
    /// actuator index.
    #[derive(Default)]
    struct Ctrl {
        t: Vec<f64>,
        rows: Vec<Vec<(usize, f64)>>,
    }

    impl Ctrl {
        fn parse(text: &str, names: &[String]) -> Result<Self, String> {
            let mut lines = text.lines().filter(|l| !l.trim().is_empty());
            let header: Vec<&str> = lines.next().ok_or("empty ctrl")?.split(',').collect();
            let idx: Vec<usize> = header[1..]
                .iter()
                .map(|c| names.iter().position(|n| n == c.trim()))
                .collect::<Option<_>>()
                .ok_or("ctrl: unknown actuator")?;
            let mut c = Ctrl::default();
            for l in lines {
                let v: Vec<f64> = l
                    .split(',')
                    .map(|x| x.trim().parse::<f64>().map_err(|e| e.to_string()))
                    .collect::<Result<_, _>>()?;
                c.t.push(v[0]);
                c.rows
                    .push(idx.iter().copied().zip(v[1..].iter().copied()).collect());
            }
            Ok(c)
        }

        /// Sets the row in force at step `i` (time `i h`), as `simulate` does.
        fn apply(&self, world: &mut World, i: usize, h: f64) {
            let k = self.t.partition_point(|&r| r <= i as f64 * h + 1e-12);
            if let Some(row) = k.checked_sub(1).map(|k| &self.rows[k]) {
                for &(a, u) in row {
                    let _ = world.set_ctrl(a, u);
                }
            }
        }
    }

    /// The counted steps' context: controls, the index of the first counted step, and
    /// the residual above which a dense step is printed.
    struct Extra {
        ctrl: Option<Ctrl>,
        start: usize,
        print_above: f64,
    }

    const METHOD: Method = Method::Rattle {
        tolerance: 1e-12,
        max_iterations: 20,
    };

    /// What the counted steps did.
    #[derive(Default)]
    struct Tally {
        dense: usize,
        sparse: usize,
        at_cap: usize,
        stalled: usize,
        budget: usize,
        guesses: usize,
        sweeps: Vec<usize>,
        iterations: Vec<usize>,
        worst_residual: f64,
        worst_penetration: f64,
        max_rows: usize,
    }

    /// The counted steps (inside the callgrind toggles `measured0` … `measured3`).
    #[inline(always)]
    fn measured(world: &mut World, h: f64, steps: usize, x: &Extra) -> Result<Tally, String> {
        let mut t = Tally::default();
        for k in 0..steps {
            if let Some(c) = &x.ctrl {
                c.apply(world, x.start + k, h);
            }
            world.step(h, METHOD).map_err(|e| e.to_string())?;
            let u = world.unilateral_stats();
            t.worst_penetration = t.worst_penetration.max(u.max_penetration);
            if u.rows == 0 {
                continue;
            }
            if u.sparse {
                t.sparse += 1;
                continue;
            }
            t.dense += 1;
            t.max_rows = t.max_rows.max(u.rows);
            t.at_cap += usize::from(u.solver.capped);
            t.stalled += usize::from(u.solver.stalled);
            t.budget += usize::from(u.solver.friction_budget);
            t.guesses += u.solver.active_set;
            t.sweeps.push(u.solver.sweeps);
            t.iterations.push(u.solver.iterations);
            t.worst_residual = t.worst_residual.max(u.residual);
            if u.residual > x.print_above {
                println!(
                    "step {}: {} rows, residual {:.3e}, sweeps {}, iterations {}, stalled {}",
                    x.start + k,
                    u.rows,
                    u.residual,
                    u.solver.sweeps,
                    u.solver.iterations,
                    u.solver.stalled
                );
            }
        }
        Ok(t)
    }

    fn median(v: &mut [usize]) -> usize {
        v.sort_unstable();
        v.get(v.len() / 2).copied().unwrap_or(0)
    }

    pub fn main() {
        let mut file = None;
        let (mut warm, mut steps) = (1.5, 100usize);
        let (mut ctrl_file, mut print_above) = (None, f64::INFINITY);
        let mut args = std::env::args().skip(1);
        while let Some(a) = args.next() {
            let v = |x: Option<String>| x.and_then(|s| s.parse::<f64>().ok());
            match a.as_str() {
                "--warm" => warm = v(args.next()).unwrap_or(warm),
                "--steps" => steps = v(args.next()).map_or(steps, |s| s as usize),
                "--ctrl" => ctrl_file = args.next(),
                "--print-above" => print_above = v(args.next()).unwrap_or(print_above),
                _ => file = Some(a),
            }
        }
        let Some(file) = file else {
            eprintln!("usage: dense_stats MODEL.xml [--warm S] [--steps N]");
            std::process::exit(2);
        };
        let mut s = match MjcfScene::from_file(std::path::Path::new(&file), None) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{file}: {e}");
                std::process::exit(1);
            }
        };
        let h = s.timestep;
        let ctrl = match ctrl_file.map(|f| {
            std::fs::read_to_string(&f)
                .map_err(|e| e.to_string())
                .and_then(|t| Ctrl::parse(&t, &s.actuator_names))
        }) {
            Some(Err(e)) => {
                eprintln!("ctrl: {e}");
                std::process::exit(1);
            }
            Some(Ok(c)) => Some(c),
            None => None,
        };
        let warm_steps = (warm / h).round() as usize;
        for i in 0..warm_steps {
            if let Some(c) = &ctrl {
                c.apply(&mut s.world, i, h);
            }
            if let Err(e) = s.world.step(h, METHOD) {
                eprintln!("warm-up: {e}");
                std::process::exit(1);
            }
        }
        // Variants: `DS_VARIANTS="fiter=20,maxsw=50;fiter=10"` (keys `fiter`, `maxsw`,
        // `ftol`: the friction sweeps, alternation cap and tolerance), each from a clone
        // of the warmed-up world through its own `measured_k` (callgrind's inclusive cost
        // per variant from one run; a fifth and later share `measured3`); none: the
        // world's own settings.
        let extra = Extra {
            ctrl,
            start: warm_steps,
            print_above,
        };
        let spec = std::env::var("DS_VARIANTS").unwrap_or_default();
        let variants: Vec<&str> = if spec.is_empty() {
            vec![""]
        } else {
            spec.split(';').collect()
        };
        for (k, v) in variants.iter().enumerate() {
            let mut w = s.world.clone();
            for kv in v.split(',').filter(|x| !x.is_empty()) {
                let (key, val) = kv.split_once('=').unwrap_or((kv, "0"));
                let x: f64 = val.parse().unwrap_or(0.0);
                let solver = &mut w.unilateral.solver;
                match key {
                    "fiter" => solver.friction_iterations = x as usize,
                    "maxsw" => solver.max_sweeps = x as usize,
                    "ftol" => solver.friction_tolerance = x,
                    _ => eprintln!("unknown variant key {key}"),
                }
            }
            let run = [measured0, measured1, measured2, measured3][k.min(3)];
            let mut t = match run(&mut w, h, steps, &extra) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("step: {e}");
                    std::process::exit(1);
                }
            };
            report(&file, v, steps, warm, &w, &mut t);
        }
    }

    #[inline(never)]
    fn measured0(w: &mut World, h: f64, steps: usize, x: &Extra) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(0);
        measured(w, h, steps, x)
    }
    #[inline(never)]
    fn measured1(w: &mut World, h: f64, steps: usize, x: &Extra) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(1);
        measured(w, h, steps, x)
    }
    #[inline(never)]
    fn measured2(w: &mut World, h: f64, steps: usize, x: &Extra) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(2);
        measured(w, h, steps, x)
    }
    #[inline(never)]
    fn measured3(w: &mut World, h: f64, steps: usize, x: &Extra) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(3);
        measured(w, h, steps, x)
    }

    fn report(file: &str, variant: &str, steps: usize, warm: f64, world: &World, t: &mut Tally) {
        let mut hash: u64 = 0xcbf29ce484222325;
        for b in world.bodies() {
            for x in b
                .origin()
                .to_array()
                .iter()
                .chain(&b.orientation().to_array())
                .chain(&b.v.to_array())
            {
                hash = (hash ^ x.to_bits()).wrapping_mul(0x100000001b3);
            }
        }
        let total: usize = t.iterations.iter().sum();
        println!(
            "{file} [{variant}]: {steps} steps after {warm} s: dense {} sparse {} (max rows {}), \
             sweeps median {} unconverged {} stalled {}, friction budget {}, one-sided solves by the active-set guess {} of {}, LCP iterations \
             median {} total {total}, worst residual {:.3e}, worst penetration {:.3e} m, \
             energy {:?}, pose hash {hash:016x}",
            t.dense,
            t.sparse,
            t.max_rows,
            median(&mut t.sweeps),
            t.at_cap,
            t.stalled,
            t.budget,
            t.guesses,
            t.sweeps.iter().map(|k| k + 1).sum::<usize>(),
            median(&mut t.iterations),
            t.worst_residual,
            t.worst_penetration,
            world.energy(),
        );
    }
}
