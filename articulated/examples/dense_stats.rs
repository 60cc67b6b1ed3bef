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
//!     MODEL.xml [--warm 1.5] [--steps 100]
//! ```
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
    fn measured(world: &mut World, h: f64, steps: usize) -> Result<Tally, String> {
        let mut t = Tally::default();
        for _ in 0..steps {
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
        let mut args = std::env::args().skip(1);
        while let Some(a) = args.next() {
            let v = |x: Option<String>| x.and_then(|s| s.parse::<f64>().ok());
            match a.as_str() {
                "--warm" => warm = v(args.next()).unwrap_or(warm),
                "--steps" => steps = v(args.next()).map_or(steps, |s| s as usize),
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
        for _ in 0..(warm / h).round() as usize {
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
            let mut t = match run(&mut w, h, steps) {
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
    fn measured0(w: &mut World, h: f64, steps: usize) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(0);
        measured(w, h, steps)
    }
    #[inline(never)]
    fn measured1(w: &mut World, h: f64, steps: usize) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(1);
        measured(w, h, steps)
    }
    #[inline(never)]
    fn measured2(w: &mut World, h: f64, steps: usize) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(2);
        measured(w, h, steps)
    }
    #[inline(never)]
    fn measured3(w: &mut World, h: f64, steps: usize) -> Result<Tally, String> {
        // Distinct bodies, so that the linker does not fold the four into one symbol.
        std::hint::black_box(3);
        measured(w, h, steps)
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
