//! Contact scenes, this library against rapier3d (f64), in one run.
//!
//! Times one step at dt = 1/60 (after 1 s of simulated warm-up: the stacks are at rest by
//! then) of the 10-box stack (`constraint_contact::scenes::box_stack(10)`), the
//! pyramid with base 20 (`scenes::pyramid(20)`, 210 boxes) and a unit box 10⁴ times
//! heavier than the 0.5 m box it rests on (`scenes::heavy_on_light(1e4)`, `heavy1e4`):
//! `contact_peers/ours_auto/SCENE` (`ContactWorld::step`, default settings,
//! `ContactSolver::Auto`), `contact_peers/ours_si/SCENE` on every scene
//! (`ContactSolver::SequentialImpulses`), `contact_peers/ours_softN/SCENE`
//! (`ContactSolver::SoftStep { substeps: N }`, N = 1, 2, 4, 8, default soft settings)
//! the tuned soft steps of [`TUNED`] (`ours_soft8_90hz`, `ours_soft8_120hz`,
//! `ours_soft8_120hz_anchors`, `ours_soft12_150hz`, `ours_soft16_240hz`: stiffer
//! contacts, which sink less and need more sub-steps, without the spring preload;
//! `_anchors` adds `SoftStepSettings::friction_anchors`; `ours_soft4_oneway`: the
//! default soft step with `one_way_mass_ratio` 100; `ours_soft4_relax2`: the default
//! with two relax passes per sub-step; `ours_soft4_lagged`: the default before
//! `preload_estimate` and `refill_renamed`, preload 0.95 from the previous impulses)
//! and `contact_peers/rapier/SCENE` (one
//! `PhysicsPipeline::step` of the same boxes as cuboid colliders on a half-space ground,
//! default integration parameters, sleeping off).
//!
//! Then, untimed, writes `target/peers/contact_accuracy.tsv`: each engine run for 10 s at
//! 60 Hz from the start — the top box's largest displacement (drift) and its final sink,
//! and the worst displacement of any box.
//!
//! The pile (`scenes::pile(n, 1)`: boxes, spheres and capsules poured into a square
//! container, 8 layers high whatever `n`): after 3 s of pouring and settling,
//! `contact_peers/ours_soft4/pileN` and `ours_soft4_sleep/pileN` (the soft step, sleeping
//! off and on) against `rapier/pileN` and `rapier_sleep/pileN`, for N = 1000 and 10000.
//! Then, untimed by criterion, the growth: mean time per step over 30 steps of each
//! engine and sleep setting at N = 100, 300, 1000, 3000, 10000 (after the same 3 s),
//! the exponent of a least-squares fit `t ∝ N^p` over those sizes, and each run's energy
//! change over the 3 s, deepest penetration at the end and bodies asleep, written to
//! `target/peers/pile_growth.tsv`. `CONTACT_PEERS_PILE=0` skips the pile.
//!
//! `error` is the figure the charts of `cargo xtask bench` plot (`Scene::error`: top-box
//! drift on the stack and the heavy box, worst displacement on the pyramid, the
//! stopping-distance error `|travel − v²/(2μg)|` on the sliding box, a 0.2 m box launched
//! at 3 m/s, which has stopped before the 1 s warm-up ends: its time per step is that of
//! a box at rest).
//!
//! It also writes each box scene as MJCF (`constraint_peers::contact::mjcf`, MuJoCo's
//! defaults, `timestep` 1/60) to `target/peers/contact_mjcf/SCENE.xml`, which
//! `cargo xtask bench` runs in MuJoCo.
//!
//! `cargo bench -p constraint-peers --features rapier --bench contact_peers`
//! (`cargo xtask bench` runs it). `CONTACT_PEERS_ACCURACY=0` skips the accuracy runs.

use constraint_contact::rigid::{ContactError, ContactSolver, ContactWorld, SleepSettings};
use constraint_contact::scenes::pile;
use constraint_peers::contact::{ours, rapier, solvers, ContactRun, Scene, Tracker, DT};
use constraint_peers::out_dir;
use criterion::{BenchmarkId, Criterion};
use std::fmt::Write as _;
use std::time::{Duration, Instant};

const WARM_UP: f64 = 1.0;
const DURATION: f64 = 10.0;

/// A tuned soft step: name, sub-steps, contact frequency (Hz), friction anchors,
/// one-way mass ratio, spring preload, relax passes, and whether the preload comes
/// from the static load estimate with renamed points refilled
/// (`SoftStepSettings::preload_estimate` and `refill_renamed`, the default).
type Tuned = (&'static str, usize, f64, bool, f64, f64, usize, bool);

/// Tuned soft steps. The sink of a soft contact goes as `1/hertz²`, and a stiffer
/// contact needs more sub-steps (the frequency is capped at a quarter of the sub-step
/// rate); the one-way coupling is for the heavy box. The preload (default 0.98, from
/// the static load estimate) is for the 30 Hz default; the stiff settings, tuned
/// before it, turn it off (from the previous impulses it rocked the 10-box stack at
/// 120 Hz with 8 sub-steps: top drift 1.37e-2 m with it, 2.0e-3 m without).
/// `_relax2`: a second relax pass per sub-step. `_lagged`: the previous default
/// (`soft_points`, 10 s at 60 Hz: stack top drift / sink 1.455 / 1.277 mm against
/// 0.570 / 0.511 mm at the default, pyramid worst 30.9 mm against 4.12 mm; callgrind
/// instructions per step, stack 269.8k against 270.8k, pyramid 10.58M against 10.22M).
const TUNED: [Tuned; 8] = [
    ("ours_soft4_oneway", 4, 30.0, false, 100.0, 0.98, 1, true),
    (
        "ours_soft4_relax2",
        4,
        30.0,
        false,
        f64::INFINITY,
        0.98,
        2,
        true,
    ),
    (
        "ours_soft4_lagged",
        4,
        30.0,
        false,
        f64::INFINITY,
        0.95,
        1,
        false,
    ),
    (
        "ours_soft8_90hz",
        8,
        90.0,
        false,
        f64::INFINITY,
        0.0,
        1,
        true,
    ),
    (
        "ours_soft8_120hz",
        8,
        120.0,
        false,
        f64::INFINITY,
        0.0,
        1,
        true,
    ),
    (
        "ours_soft8_120hz_anchors",
        8,
        120.0,
        true,
        f64::INFINITY,
        0.0,
        1,
        true,
    ),
    (
        "ours_soft12_150hz",
        12,
        150.0,
        false,
        f64::INFINITY,
        0.0,
        1,
        true,
    ),
    (
        "ours_soft16_240hz",
        16,
        240.0,
        false,
        f64::INFINITY,
        0.0,
        1,
        true,
    ),
];

/// The scene with a tuned soft step (see [`TUNED`]), at rest after `warm_up` seconds.
fn tuned(
    scene: Scene,
    (_, substeps, hertz, anchors, one_way, preload, relax_passes, estimate): Tuned,
    warm_up: f64,
) -> Result<ContactWorld, ContactError> {
    let mut w = scene.world()?;
    w.settings.solver = ContactSolver::SoftStep { substeps };
    w.settings.soft_step.hertz = hertz;
    w.settings.soft_step.friction_anchors = anchors;
    w.settings.soft_step.one_way_mass_ratio = one_way;
    w.settings.soft_step.preload = preload;
    w.settings.soft_step.relax_passes = relax_passes;
    w.settings.soft_step.preload_estimate = estimate;
    w.settings.soft_step.refill_renamed = estimate;
    for _ in 0..(warm_up / DT).round() as usize {
        w.step(DT)?;
    }
    Ok(w)
}

/// A tuned soft step run for `DURATION` from rest, tracked as `ours::run` does.
fn tuned_run(scene: Scene, setting: Tuned) -> Result<ContactRun, ContactError> {
    let mut w = tuned(scene, setting, 0.0)?;
    let mut t = Tracker::new(ours::centres(&w));
    let mut contacts = None;
    for k in 0..(DURATION / DT).round() as usize {
        match w.step(DT) {
            Ok(s) => contacts = Some(s.contacts),
            Err(_) => {
                let mut r = t.finish(&ours::centres(&w), contacts);
                r.finite = false;
                r.failed_at = Some((k + 1) as f64 * DT);
                return Ok(r);
            }
        }
        t.observe(&ours::centres(&w));
    }
    Ok(t.finish(&ours::centres(&w), contacts))
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("contact_peers");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(20);
    for scene in Scene::BENCH {
        let name = scene.name();
        for (engine, solver) in solvers() {
            // A typed failure (the heavy box defeats some solvers) is reported, not timed:
            // the accuracy run records when it happens.
            let mut w = match ours::world(scene, solver, DT, WARM_UP) {
                Ok(w) => w,
                Err(e) => {
                    println!("{engine} {name}: not timed, warm-up step failed: {e}");
                    continue;
                }
            };
            let mut failed = None;
            g.bench_with_input(BenchmarkId::new(engine, &name), &name, |b, _| {
                b.iter(|| match w.step(DT) {
                    Ok(s) => s.contacts,
                    Err(e) => {
                        failed.get_or_insert(e);
                        0
                    }
                })
            });
            if let Some(e) = failed {
                println!("{engine} {name}: a timed step failed (time not valid): {e}");
            }
        }
        for setting in TUNED {
            let engine = setting.0;
            let mut w = match tuned(scene, setting, WARM_UP) {
                Ok(w) => w,
                Err(e) => {
                    println!("{engine} {name}: not timed, warm-up step failed: {e}");
                    continue;
                }
            };
            let mut failed = None;
            g.bench_with_input(BenchmarkId::new(engine, &name), &name, |b, _| {
                b.iter(|| match w.step(DT) {
                    Ok(s) => s.contacts,
                    Err(e) => {
                        failed.get_or_insert(e);
                        0
                    }
                })
            });
            if let Some(e) = failed {
                println!("{engine} {name}: a timed step failed (time not valid): {e}");
            }
        }
        let start = match scene.world() {
            Ok(w) => w,
            Err(e) => panic!("{name}: {e}"),
        };
        let mut r = match rapier::world(&start, DT, WARM_UP) {
            Ok(r) => r,
            Err(e) => panic!("rapier {name}: {e}"),
        };
        g.bench_with_input(BenchmarkId::new("rapier", &name), &name, |b, _| {
            b.iter(|| r.step())
        });
    }
    g.finish();
}

fn row(out: &mut String, scene: Scene, engine: &str, r: &ContactRun) {
    let _ = writeln!(
        out,
        "{}\t{engine}\t{}\t{DT:e}\t{DURATION}\t{:e}\t{:e}\t{:e}\t{:e}\t{}\t{}\t{}\t{:e}\t{:e}",
        scene.name(),
        scene.boxes(),
        r.top_drift,
        r.top_sink,
        r.worst_displacement,
        r.worst_at_end,
        r.contacts.map_or("-".into(), |c| c.to_string()),
        r.finite,
        r.failed_at.map_or("-".into(), |t| format!("{t}")),
        r.top_travel,
        scene.error(r)
    );
    println!(
        "{:>10} {engine:>10}: top drift {:.2e} m, top sink {:.2e} m, worst displacement {:.2e} m \
         (at end {:.2e} m){}{}",
        scene.name(),
        r.top_drift,
        r.top_sink,
        r.worst_displacement,
        r.worst_at_end,
        r.contacts
            .map_or(String::new(), |c| format!(", {c} contact points")),
        r.failed_at
            .map_or(String::new(), |t| format!(" (step failed at t = {t:.4} s)"))
    );
}

/// Untimed runs: 10 s at 60 Hz from the start, per scene and engine.
fn accuracy() {
    let mut out = String::from(
        "scene\tengine\tboxes\tdt\tduration\ttop_drift\ttop_sink\tworst_displacement\t\
         worst_at_end\tcontacts\tfinite\tfailed_at\ttop_travel\terror\n",
    );
    for scene in Scene::BENCH {
        for (engine, solver) in solvers() {
            match ours::run(scene, solver, DT, DURATION) {
                Ok(r) => row(&mut out, scene, engine, &r),
                Err(e) => panic!("{engine} {}: {e}", scene.name()),
            }
        }
        for setting in TUNED {
            match tuned_run(scene, setting) {
                Ok(r) => row(&mut out, scene, setting.0, &r),
                Err(e) => panic!("{} {}: {e}", setting.0, scene.name()),
            }
        }
        let start = match scene.world() {
            Ok(w) => w,
            Err(e) => panic!("{}: {e}", scene.name()),
        };
        match rapier::run(&start, DT, DURATION) {
            Ok(r) => row(&mut out, scene, "rapier", &r),
            Err(e) => panic!("rapier {}: {e}", scene.name()),
        }
    }
    let dir = out_dir();
    let path = dir.join("contact_accuracy.tsv");
    if let Err(e) = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, out)) {
        panic!("{}: {e}", path.display());
    }
    println!("wrote {}", path.display());
}

/// Simulated pouring time before a pile is timed (s).
const PILE_SETTLE: f64 = 3.0;
/// Pile sizes of the growth fit.
const PILE_SIZES: [usize; 5] = [100, 300, 1000, 3000, 10_000];

/// Ours on the pile: the soft step with 4 sub-steps, sleeping off or on.
fn our_pile(n: usize, sleep: bool) -> ContactWorld {
    let mut w = match pile(n, 1) {
        Ok(w) => w,
        Err(e) => panic!("pile{n}: {e}"),
    };
    w.settings.solver = ContactSolver::SoftStep { substeps: 4 };
    w.settings.sleep = SleepSettings {
        enabled: sleep,
        ..SleepSettings::default()
    };
    w
}

/// One engine on one pile, after [`PILE_SETTLE`] seconds: what the growth table shows.
struct PileRow {
    engine: &'static str,
    n: usize,
    step_s: f64,
    energy_change: f64,
    deepest: f64,
    asleep: usize,
}

/// Steps `step` for the pouring time, then times 30 steps (mean).
fn settle_and_time(mut step: impl FnMut()) -> f64 {
    for _ in 0..(PILE_SETTLE / DT).round() as usize {
        step();
    }
    let t = Instant::now();
    for _ in 0..30 {
        step();
    }
    t.elapsed().as_secs_f64() / 30.0
}

fn pile_rows(n: usize) -> Vec<PileRow> {
    let mut rows = Vec::new();
    for (engine, sleep) in [("ours_soft4", false), ("ours_soft4_sleep", true)] {
        let mut w = our_pile(n, sleep);
        let e0 = w.energy();
        let mut failed = None;
        let step_s = settle_and_time(|| {
            if let Err(e) = w.step(DT) {
                failed.get_or_insert(e);
            }
        });
        if let Some(e) = failed {
            panic!("{engine} pile{n}: {e}");
        }
        rows.push(PileRow {
            engine,
            n,
            step_s,
            energy_change: w.energy() - e0,
            deepest: w.contacts().iter().map(|c| c.depth).fold(0.0, f64::max),
            asleep: (0..n).filter(|&i| w.is_asleep(i)).count(),
        });
    }
    let start = our_pile(n, false);
    for (engine, sleep) in [("rapier", false), ("rapier_sleep", true)] {
        let mut r = match rapier::RapierBoxes::from_world_sleeping(&start, DT, sleep) {
            Ok(r) => r,
            Err(e) => panic!("rapier pile{n}: {e}"),
        };
        let e0 = r.energy();
        let step_s = settle_and_time(|| r.step());
        rows.push(PileRow {
            engine,
            n,
            step_s,
            energy_change: r.energy() - e0,
            deepest: r.deepest(),
            asleep: r.asleep(),
        });
    }
    rows
}

/// Least-squares slope of `ln t` against `ln n`.
fn exponent(points: &[(usize, f64)]) -> f64 {
    let xy: Vec<(f64, f64)> = points
        .iter()
        .map(|&(n, t)| ((n as f64).ln(), t.ln()))
        .collect();
    let m = xy.len() as f64;
    let (sx, sy) = xy.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / m, sy / m);
    let (num, den) = xy.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx) * (p.1 - my), a.1 + (p.0 - mx) * (p.0 - mx))
    });
    num / den
}

/// The growth table and exponents: `target/peers/pile_growth.tsv`.
fn pile_growth() {
    let rows: Vec<PileRow> = PILE_SIZES.iter().flat_map(|&n| pile_rows(n)).collect();
    let mut out = String::from(
        "engine\tbodies\tstep_s\tratio_vs_rapier_same_sleep\tenergy_change_J\tdeepest_m\tasleep\n",
    );
    for r in &rows {
        let peer = if r.engine.ends_with("sleep") {
            "rapier_sleep"
        } else {
            "rapier"
        };
        let base = rows
            .iter()
            .find(|p| p.n == r.n && p.engine == peer)
            .map_or(f64::NAN, |p| p.step_s);
        let _ = writeln!(
            out,
            "{}\t{}\t{:e}\t{:.3}\t{:e}\t{:e}\t{}",
            r.engine,
            r.n,
            r.step_s,
            r.step_s / base,
            r.energy_change,
            r.deepest,
            r.asleep
        );
        println!(
            "pile{:>6} {:>17}: {:9.3} ms/step ({:.2}x {peer}), energy change {:+.3e} J, \
             deepest {:.2e} m, {} asleep",
            r.n,
            r.engine,
            r.step_s * 1e3,
            r.step_s / base,
            r.energy_change,
            r.deepest,
            r.asleep
        );
    }
    for engine in ["ours_soft4", "ours_soft4_sleep", "rapier", "rapier_sleep"] {
        let pts: Vec<(usize, f64)> = rows
            .iter()
            .filter(|r| r.engine == engine)
            .map(|r| (r.n, r.step_s))
            .collect();
        let p = exponent(&pts);
        let _ = writeln!(out, "# exponent\t{engine}\t{p:.3}");
        println!("pile growth exponent {engine}: {p:.3} (fit over {PILE_SIZES:?})");
    }
    let dir = out_dir();
    let path = dir.join("pile_growth.tsv");
    if let Err(e) = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, out)) {
        panic!("{}: {e}", path.display());
    }
    println!("wrote {}", path.display());
}

/// Criterion on the 1000- and 10,000-body piles, both engines, sleeping off and on.
fn pile_bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("contact_peers");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(10);
    let settle = (PILE_SETTLE / DT).round() as usize;
    for n in [1000, 10_000] {
        let name = format!("pile{n}");
        for (engine, sleep) in [("ours_soft4", false), ("ours_soft4_sleep", true)] {
            let mut w = our_pile(n, sleep);
            for _ in 0..settle {
                if let Err(e) = w.step(DT) {
                    panic!("{engine} {name}: {e}");
                }
            }
            g.bench_with_input(BenchmarkId::new(engine, &name), &name, |b, _| {
                b.iter(|| w.step(DT).map_or(0, |s| s.contacts))
            });
        }
        let start = our_pile(n, false);
        for (engine, sleep) in [("rapier", false), ("rapier_sleep", true)] {
            let mut r = match rapier::RapierBoxes::from_world_sleeping(&start, DT, sleep) {
                Ok(r) => r,
                Err(e) => panic!("rapier {name}: {e}"),
            };
            for _ in 0..settle {
                r.step();
            }
            g.bench_with_input(BenchmarkId::new(engine, &name), &name, |b, _| {
                b.iter(|| r.step())
            });
        }
    }
    g.finish();
}

/// Each box scene of [`Scene::BENCH`] but the sliding box (MuJoCo runs
/// `scenes/sliding_box.xml`) as MJCF, into `target/peers/contact_mjcf/`.
fn write_mjcf() {
    let dir = out_dir().join("contact_mjcf");
    for scene in Scene::BENCH {
        if scene == Scene::SlidingBox {
            continue;
        }
        let name = scene.name();
        let xml = match scene.world() {
            Ok(w) => constraint_peers::contact::mjcf(&w, &name, DT),
            Err(e) => Err(e.to_string()),
        };
        let path = dir.join(format!("{name}.xml"));
        let written = xml.and_then(|x| {
            std::fs::create_dir_all(&dir)
                .and_then(|()| std::fs::write(&path, x))
                .map_err(|e| e.to_string())
        });
        match written {
            Ok(()) => println!("wrote {}", path.display()),
            Err(e) => println!("{name}: no MJCF: {e}"),
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c);
    let listing = std::env::args().any(|a| a == "--list");
    let pile_on = !std::env::var("CONTACT_PEERS_PILE").is_ok_and(|v| v == "0");
    if pile_on {
        pile_bench(&mut c);
    }
    c.final_summary();
    if !listing && pile_on {
        pile_growth();
    }
    let skip = std::env::var("CONTACT_PEERS_ACCURACY").is_ok_and(|v| v == "0");
    if !listing && !skip {
        accuracy();
    }
    if !listing {
        write_mjcf();
    }
}
