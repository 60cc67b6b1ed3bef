//! `cargo xtask bench [--no-mujoco] [--peers-only] [--only SECTIONS] [CRITERION ARGS]`:
//! the criterion benchmarks and the peer comparisons, in one run, into
//! `target/bench/ratios.md`. SECTIONS is a comma-separated subset of `chains`,
//! `contact`, `mjcf`, `models`, `cloth` (default: all; `--peers-only` drops `cloth`); a section not
//! run says so in the report. CRITERION ARGS (`--quick`, a filter, …) go to every bench.
//!
//! - `cloth`: `cargo bench -p constraint-soft --bench cloth_step` (time per implicit cloth
//!   step for N = 32, 64, 128: assembly, step with sparse LDLᵀ, with lagged LDLᵀ, with CG)
//!   and `cargo bench -p constraint-lagrange --bench kkt_solvers` (one KKT solve of the
//!   inextensible cloth per solver); tables of time per call and growth exponents
//!   (slopes of log time against log nodes between sizes, least-squares fit), read from
//!   criterion's `estimates.json` (median).
//! - `chains`: `cargo bench -p constraint-peers --features rapier --bench chain_peers`
//!   times one step of ball-joint chains (10 … 10000 links, dt = 1e-3) with this library
//!   (velocity level, velocity level + projection) and rapier3d (f64, spherical impulse
//!   joints) in one run and writes joint separations to `target/peers/accuracy.tsv`; the
//!   same chains as MJCF (`scenes/generate_chains.py --ball-chain`, into
//!   `target/peers/mjcf/`) are timed in MuJoCo's C loop (Euler, `mujoco.rollout`) through
//!   [`crate::mujoco::run`] when Python is available (skipped with a note otherwise, or
//!   with `--no-mujoco`). Tables: time per step per engine and size, the ratios
//!   ours/rapier3d and ours/MuJoCo, joint separation after 2 s, growth exponents, and the
//!   heavy-tip outcome.
//! - `contact`: `cargo bench -p constraint-peers --features rapier --bench contact_peers`
//!   times one step at dt = 1/60 of the 10-box stack and the pyramid with base 20 with
//!   this library (`ContactSolver::Auto`, and sequential impulses on the stack) and
//!   rapier3d in one run, and writes the 10 s accuracy runs (top-box drift and sink, worst
//!   box displacement; the sliding box's stopping distance) to
//!   `target/peers/contact_accuracy.tsv`; then `cargo run -p constraint-peers --features
//!   rapier --example paired_ratio` on the stack and the pyramid (the soft step and
//!   rapier3d timed in alternating rounds in one process, a ratio that holds when the
//!   machine's speed drifts between criterion's series); then MuJoCo on the same scenes
//!   ([`crate::bench_contact`], left out with `--no-mujoco`) and one chart per scene,
//!   accuracy against time per step (`target/bench/contact_<scene>.svg`, from
//!   `target/bench/contact_points.tsv`, drawn by `verify-report --contact-points`).
//! - `mjcf`: every MJCF scene of `scenes/` (articulated and contact) with this library
//!   (`cargo bench -p constraint-peers --bench mjcf_scenes`) and MuJoCo's Euler on the same
//!   files, same dt, same one-second window ([`crate::bench_mjcf`]).
//! - `models`: the 33 gymnasium and dm_control models of `cargo xtask models run`
//!   ([`crate::models::run_suite`], fetched on first use): its time-per-step table (ours,
//!   MuJoCo, ratio, per model, passive case); its full report goes to
//!   `target/bench/models/`. Left out with `--no-mujoco`.
//!
//! Only criterion estimates written during this run are read (older `estimates.json`
//! files, e.g. of a series a filter left out, show as "–").

use crate::bench_cloth::{self, cloth_markdown};
use crate::bench_contact;
use crate::bench_mjcf;
use crate::models;
use crate::mujoco::{ensure_venv, run as run_mujoco, RunOptions};
use crate::run::{cargo, output, root};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::SystemTime;

/// When this `cargo xtask bench` started: estimates written before are stale.
static RUN_START: OnceLock<SystemTime> = OnceLock::new();

/// Median (criterion's point estimate) in seconds for `group/name/param`, if present
/// (and, once [`RUN_START`] is set, written during this run).
pub(crate) fn estimate(group: &str, name: &str, param: impl std::fmt::Display) -> Option<f64> {
    let p = root()
        .join("target/criterion")
        .join(group)
        .join(name)
        .join(param.to_string())
        .join("new/estimates.json");
    if let Some(t0) = RUN_START.get() {
        let written = std::fs::metadata(&p).and_then(|m| m.modified()).ok()?;
        if written < *t0 {
            return None;
        }
    }
    let s = std::fs::read_to_string(p).ok()?;
    let e: Estimates = serde_json::from_str(&s).ok()?;
    Some(e.median.point_estimate * 1e-9)
}

/// The part of criterion's `estimates.json` read here: the median's point estimate (ns).
#[derive(serde::Deserialize)]
struct Estimates {
    median: Estimate,
}

/// One estimate of criterion's `estimates.json`.
#[derive(serde::Deserialize)]
struct Estimate {
    point_estimate: f64,
}

/// Least-squares slope of log t against log n.
pub(crate) fn slope(pts: &[(f64, f64)]) -> Option<f64> {
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (sx, sy) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x.ln(), b + y.ln()));
    let (mx, my) = (sx / n, sy / n);
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in pts {
        num += (x.ln() - mx) * (y.ln() - my);
        den += (x.ln() - mx) * (x.ln() - mx);
    }
    Some(num / den)
}

/// Chain sizes of the peer comparison.
const CHAIN_SIZES: [usize; 5] = [10, 20, 100, 1000, 10000];

/// MuJoCo runs per chain size: simulated seconds for the trajectory and the timed
/// rollout (dt = 1e-3). Its mass matrix is dense for a chain (about 1.6–3 s per step at
/// 1000 links, and loading that MJCF takes about half a minute), so the big chain gets
/// one step; 10000 links (about 1000× that per step) is left out.
const MUJOCO_RUNS: [(usize, &str); 4] = [(10, "1"), (20, "1"), (100, "0.2"), (1000, "0.001")];

/// What the peer runs measured.
#[derive(Default)]
struct Peers {
    /// `(engine, links) → s/step` for engines `ours_velocity`, `ours_projected`, `rapier`,
    /// `mujoco`.
    time: Vec<(String, usize, f64)>,
    /// `(engine, links) → joint separation (m) after 2 s`.
    separation: Vec<(String, usize, f64)>,
    /// `(engine, max separation over 10 s, holds, time of a failed step)` for the heavy
    /// tip at dt = 1/60.
    heavy_tip: Vec<(String, f64, bool, Option<f64>)>,
    /// Notes for the report (skipped runs, versions).
    notes: Vec<String>,
}

impl Peers {
    fn time(&self, engine: &str, n: usize) -> Option<f64> {
        self.time
            .iter()
            .find(|(e, k, _)| e == engine && *k == n)
            .map(|t| t.2)
    }

    fn separation(&self, engine: &str, n: usize) -> Option<f64> {
        self.separation
            .iter()
            .find(|(e, k, _)| e == engine && *k == n)
            .map(|t| t.2)
    }
}

/// Reads `target/peers/accuracy.tsv` written by the chain_peers bench.
fn read_accuracy(p: &mut Peers) {
    let path = root().join("target/peers/accuracy.tsv");
    let Ok(text) = std::fs::read_to_string(&path) else {
        p.notes
            .push(format!("{}: missing, no joint separations", path.display()));
        return;
    };
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() < 8 {
            continue;
        }
        let (Ok(n), Ok(at_end), Ok(max)) = (
            f[2].parse::<usize>(),
            f[5].parse::<f64>(),
            f[6].parse::<f64>(),
        ) else {
            continue;
        };
        match f[0] {
            "separation_2s" => p.separation.push((f[1].into(), n, at_end)),
            "heavy_tip" => p.heavy_tip.push((
                f[1].into(),
                max,
                f[7] == "true",
                f.get(8).and_then(|t| t.parse().ok()),
            )),
            _ => {}
        }
    }
}

/// The fields read of a timing file of `cargo xtask mujoco --timing` (JSON written by
/// `xtask/mujoco_run.py`); a key that is missing is `None`.
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize)]
pub(crate) struct Timing {
    /// Steps of the timed rollout.
    pub steps: Option<usize>,
    /// Best time per step in MuJoCo's C loop (s).
    pub seconds_per_step: Option<f64>,
    /// MuJoCo's version.
    pub mujoco_version: Option<String>,
}

impl Timing {
    /// Parses a timing file's text; a file that is not such JSON has no fields.
    pub(crate) fn parse(text: &str) -> Timing {
        serde_json::from_str(text).unwrap_or_default()
    }
}

/// The MuJoCo side: generate the MJCF chains and time each in MuJoCo's C loop.
fn mujoco_chains(p: &mut Peers) {
    let python = match ensure_venv() {
        Ok(py) => py,
        Err(e) => {
            p.notes.push(format!("MuJoCo skipped: {e}"));
            eprintln!("xtask: MuJoCo skipped: {e}");
            return;
        }
    };
    let dir = root().join("target/peers/mjcf");
    let sizes: Vec<String> = MUJOCO_RUNS.iter().map(|(n, _)| n.to_string()).collect();
    let ok = std::process::Command::new(&python)
        .arg(root().join("scenes/generate_chains.py"))
        .arg("--ball-chain")
        .args(&sizes)
        .arg("--out")
        .arg(&dir)
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        p.notes
            .push("MuJoCo skipped: scenes/generate_chains.py --ball-chain failed".to_string());
        return;
    }
    let mut version = None;
    for (n, duration) in MUJOCO_RUNS {
        let scene = dir.join(format!("ball_chain{n}.xml"));
        let timing = dir.join(format!("ball_chain{n}.timing.json"));
        let steps = (duration.parse::<f64>().unwrap_or(0.0) / 1e-3).round() as usize;
        eprintln!(
            "xtask: MuJoCo Euler dt 1e-3, {n} links, {steps} steps (timed by mujoco.rollout)"
        );
        let t0 = std::time::Instant::now();
        let res = run_mujoco(&RunOptions {
            scene: scene.clone(),
            keyframe: Some("start".into()),
            dt: Some("1e-3".into()),
            duration: duration.into(),
            every: steps.max(1),
            integrator: Some("euler".into()),
            out: dir.join(format!("ball_chain{n}.csv")),
            timing: Some(timing.clone()),
            ..RunOptions::default()
        });
        let text = res.and_then(|()| {
            std::fs::read_to_string(&timing).map_err(|e| format!("{}: {e}", timing.display()))
        });
        match text {
            Ok(text) => match Timing::parse(&text).seconds_per_step {
                Some(t) => {
                    eprintln!(
                        "  {n} links: {:.3e} s/step ({:.0} s with loading)",
                        t,
                        t0.elapsed().as_secs_f64()
                    );
                    p.time.push(("mujoco".into(), n, t));
                    version = version.or_else(|| Timing::parse(&text).mujoco_version);
                }
                None => p
                    .notes
                    .push(format!("MuJoCo {n} links: no seconds_per_step")),
            },
            Err(e) => p.notes.push(format!("MuJoCo {n} links failed: {e}")),
        }
    }
    p.notes.push(format!(
        "MuJoCo {} (PyPI), Euler, dt = 1e-3, from rest (its cost does not depend on the \
         configuration here: no contacts), timed over {} in MuJoCo's C loop (`mujoco.rollout`, \
         best of at least 3 repeats); 10000 links not run (dense mass matrix: about 1000× the \
         1000-link step). Joint separation is zero by construction (reduced coordinates).",
        version.as_deref().unwrap_or("?"),
        MUJOCO_RUNS
            .iter()
            .map(|(n, d)| format!("{d} s for {n} links"))
            .collect::<Vec<_>>()
            .join(", ")
    ));
}

/// `version` of `name` in Cargo.lock.
fn locked_version(name: &str) -> Option<String> {
    let lock = std::fs::read_to_string(root().join("Cargo.lock")).ok()?;
    let key = format!("name = \"{name}\"\nversion = \"");
    let rest = &lock[lock.find(&key)? + key.len()..];
    Some(rest[..rest.find('"')?].to_string())
}

pub(crate) fn fmt_time(t: Option<f64>) -> String {
    match t {
        Some(t) if t < 1e-3 => format!("{:.2} µs", t * 1e6),
        Some(t) if t < 1.0 => format!("{:.3} ms", t * 1e3),
        Some(t) => format!("{t:.2} s"),
        None => "–".into(),
    }
}

pub(crate) fn fmt_ratio(a: Option<f64>, b: Option<f64>) -> String {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => {
            let r = a / b;
            if r < 0.01 {
                format!("{r:.1e}")
            } else {
                format!("{r:.3}")
            }
        }
        _ => "–".into(),
    }
}

fn fmt_sep(s: Option<f64>) -> String {
    s.map_or("–".into(), |s| format!("{s:.1e} m"))
}

const ENGINES: [(&str, &str); 4] = [
    ("ours_velocity", "ours (velocity)"),
    ("ours_projected", "ours (projected)"),
    ("rapier", "rapier3d"),
    ("mujoco", "MuJoCo (Euler)"),
];

/// The Markdown of `target/bench/ratios.md`.
fn ratios_markdown(p: &Peers) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Ball-joint chains: time per step, this library against peers\n\n\
         One run of `cargo xtask bench`. Chains of `constraint_articulated::scenes::ball_chain(n, 1.0)` \
         (0.1 m solid-cylinder links, radius 0.01, density 1000, hanging from the origin, \
         released horizontally at rest), dt = 1e-3, one core. Ours and rapier3d are \
         criterion medians after 0.2 s of simulated warm-up (`cargo bench -p constraint-peers \
         --features rapier`); ours (velocity) is `Method::Velocity {{ beta: 1 }}`, ours \
         (projected) `Method::VelocityProjected` to 1e-10 m; rapier3d {} (f64) uses \
         spherical impulse joints with default integration parameters and no colliders. \
         A ratio below 1 means this library is faster.\n",
        locked_version("rapier3d-f64").as_deref().unwrap_or("?")
    );
    let _ = writeln!(md, "## Time per step and ratios\n");
    let _ = writeln!(
        md,
        "| links | ours (velocity) | ours (projected) | rapier3d | MuJoCo (Euler) | \
         velocity / rapier3d | projected / rapier3d | velocity / MuJoCo | projected / MuJoCo |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for n in CHAIN_SIZES {
        let [v, pr, r, m] = ENGINES.map(|(e, _)| p.time(e, n));
        let _ = writeln!(
            md,
            "| {n} | {} | {} | {} | {} | {} | {} | {} | {} |",
            fmt_time(v),
            fmt_time(pr),
            fmt_time(r),
            fmt_time(m),
            fmt_ratio(v, r),
            fmt_ratio(pr, r),
            fmt_ratio(v, m),
            fmt_ratio(pr, m)
        );
    }
    let _ = writeln!(
        md,
        "\n## Joint separation after 2 s (from rest, dt = 1e-3)\n\n\
         Largest distance between the two anchors of any joint at t = 2 s (rapier3d: from \
         the body poses and the joint anchors). MuJoCo works in reduced coordinates: its \
         joints cannot separate.\n"
    );
    let _ = writeln!(
        md,
        "| links | ours (velocity) | ours (projected) | rapier3d | MuJoCo |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|");
    for n in CHAIN_SIZES {
        let _ = writeln!(
            md,
            "| {n} | {} | {} | {} | {} |",
            fmt_sep(p.separation("ours_velocity", n)),
            fmt_sep(p.separation("ours_projected", n)),
            fmt_sep(p.separation("rapier", n)),
            if p.time("mujoco", n).is_some() {
                "0 (reduced coordinates)"
            } else {
                "–"
            }
        );
    }
    let _ = writeln!(
        md,
        "\n## Growth exponents\n\n\
         Slope of log(time per step) against log(links) between consecutive sizes, and the \
         least-squares fit over all sizes measured (1 = linear).\n"
    );
    let _ = writeln!(
        md,
        "| sizes | {} |",
        ENGINES.map(|(_, label)| label).join(" | ")
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|");
    for w in CHAIN_SIZES.windows(2) {
        let cells = ENGINES.map(|(e, _)| match (p.time(e, w[0]), p.time(e, w[1])) {
            (Some(a), Some(b)) => format!("{:.2}", (b / a).ln() / (w[1] as f64 / w[0] as f64).ln()),
            _ => "–".into(),
        });
        let _ = writeln!(md, "| {} → {} | {} |", w[0], w[1], cells.join(" | "));
    }
    let fits = ENGINES.map(|(e, _)| {
        let pts: Vec<(f64, f64)> = CHAIN_SIZES
            .iter()
            .filter_map(|&n| p.time(e, n).map(|t| (n as f64, t)))
            .collect();
        slope(&pts).map_or("–".into(), |s| format!("{s:.2}"))
    });
    let _ = writeln!(md, "| fit, all sizes | {} |", fits.join(" | "));
    let _ = writeln!(
        md,
        "\n## Heavy tip at dt = 1/60\n\n\
         `ball_chain(20, 1000.0)` (last link 1000× heavier), 10 s at dt = 1/60 from rest; \
         holds if every joint stays within 1 cm at every step.\n"
    );
    let _ = writeln!(md, "| engine | largest separation over 10 s | holds |");
    let _ = writeln!(md, "|---|---:|---|");
    for (e, label) in &ENGINES[..3] {
        if let Some((_, max, holds, failed)) = p.heavy_tip.iter().find(|h| h.0 == *e) {
            let (sep, verdict) = match failed {
                Some(t) => (
                    "–".to_string(),
                    format!("no: a step failed (typed divergence error) at t = {t:.4} s"),
                ),
                None if *holds => (fmt_sep(Some(*max)), "yes".to_string()),
                None => (fmt_sep(Some(*max)), "no, comes apart".to_string()),
            };
            let _ = writeln!(md, "| {label} | {sep} | {verdict} |");
        }
    }
    if !p.notes.is_empty() {
        let _ = writeln!(md, "\n## Notes\n");
        for n in &p.notes {
            let _ = writeln!(md, "- {n}");
        }
    }
    md
}

/// Contact scenes of the contact_peers bench: `(id, label)`.
const CONTACT_SCENES: [(&str, &str); 4] = [
    ("stack10", "10-box stack"),
    ("pyramid20", "pyramid, base 20 (210 boxes)"),
    ("heavy1e4", "10⁴:1 box on a small one"),
    ("sliding_box", "sliding box (3 m/s, μ 0.5)"),
];

/// Engines of the contact scenes: `(id, label)`; the contact_peers bench's, then
/// MuJoCo's settings ([`bench_contact::BOX_SETTINGS`], [`bench_contact::SLIDE_SETTINGS`]).
const CONTACT_ENGINES: [(&str, &str); 19] = [
    ("ours_auto", "ours (Auto)"),
    ("ours_si", "ours (SI)"),
    ("ours_soft1", "ours (soft step, 1 sub-step)"),
    ("ours_soft2", "ours (soft step, 2 sub-steps)"),
    ("ours_soft3", "ours (soft step, 3 sub-steps: Auto's)"),
    ("ours_soft4", "ours (soft step, 4 sub-steps)"),
    ("ours_soft8", "ours (soft step, 8 sub-steps)"),
    (
        "ours_soft4_oneway",
        "ours (soft step, 4 sub-steps, one-way above 100:1)",
    ),
    (
        "ours_soft4_relax2",
        "ours (soft step, 4 sub-steps, 2 relax passes)",
    ),
    (
        "ours_soft4_lagged",
        "ours (soft step, 4 sub-steps, the previous default: preload 0.95 of the last step's load)",
    ),
    (
        "ours_soft8_90hz",
        "ours (soft step, 8 sub-steps, 90 Hz, no preload)",
    ),
    (
        "ours_soft8_120hz",
        "ours (soft step, 8 sub-steps, 120 Hz, no preload)",
    ),
    (
        "ours_soft8_120hz_anchors",
        "ours (soft step, 8 sub-steps, 120 Hz, friction anchors, no preload)",
    ),
    (
        "ours_soft12_150hz",
        "ours (soft step, 12 sub-steps, 150 Hz, no preload)",
    ),
    (
        "ours_soft16_240hz",
        "ours (soft step, 16 sub-steps, 240 Hz, no preload)",
    ),
    ("rapier", "rapier3d"),
    ("mujoco", "MuJoCo (dt = 1/60)"),
    ("mujoco_240hz", "MuJoCo (dt = 1/240)"),
    ("mujoco_1khz", "MuJoCo (dt = 1 ms)"),
];

/// A point's label on a chart: the setting, short.
fn short_label(engine: &str) -> String {
    match engine {
        "ours_auto" => "Auto".into(),
        "ours_si" => "SI".into(),
        "rapier" => "default".into(),
        "mujoco" => "dt 1/60".into(),
        "mujoco_240hz" => "dt 1/240".into(),
        "mujoco_1khz" => "dt 1 ms".into(),
        e => match e.strip_prefix("ours_soft") {
            // ours_soft8_120hz_anchors → soft 8, 120hz, anchors
            Some(rest) => format!("soft {}", rest.replace('_', ", ")),
            None => e.to_string(),
        },
    }
}

/// The chart series an engine id belongs to.
fn engine_group(engine: &str) -> &'static str {
    if engine.starts_with("ours") {
        "ours"
    } else if engine.starts_with("rapier") {
        "rapier3d"
    } else {
        "MuJoCo"
    }
}

/// One line of `target/peers/contact_accuracy.tsv`.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct ContactAccuracy {
    pub(crate) top_drift: f64,
    pub(crate) top_sink: f64,
    pub(crate) worst_displacement: f64,
    pub(crate) contacts: Option<usize>,
    pub(crate) failed_at: Option<f64>,
    /// Horizontal distance of the top box from its start at the end (column 13; older
    /// files lack it).
    pub(crate) top_travel: Option<f64>,
}

/// What the contact_peers bench (and MuJoCo on the same scenes) measured.
struct ContactPeers {
    /// `(engine, scene) → s/step`.
    time: Vec<(String, String, f64)>,
    /// `(engine, scene) → 10 s accuracy run`.
    accuracy: Vec<(String, String, ContactAccuracy)>,
    /// The interleaved ratios of `paired_ratio` ([`Paired`]), one per scene measured.
    paired: Vec<Paired>,
    /// Notes for the report.
    notes: Vec<String>,
    /// The charts written (`(scene, file)` under `target/bench/`), or why none were.
    charts: Result<Vec<(String, String)>, String>,
}

impl Default for ContactPeers {
    fn default() -> Self {
        Self {
            time: Vec::new(),
            accuracy: Vec::new(),
            paired: Vec::new(),
            notes: Vec::new(),
            charts: Err("not drawn".into()),
        }
    }
}

impl ContactPeers {
    fn time(&self, engine: &str, scene: &str) -> Option<f64> {
        self.time
            .iter()
            .find(|(e, s, _)| e == engine && s == scene)
            .map(|t| t.2)
    }

    fn accuracy(&self, engine: &str, scene: &str) -> Option<&ContactAccuracy> {
        self.accuracy
            .iter()
            .find(|(e, s, _)| e == engine && s == scene)
            .map(|t| &t.2)
    }

    /// The chart's figure of `engine` on `scene` (see [`bench_contact::scene_error`]);
    /// `None` for a failed run.
    fn error(&self, engine: &str, scene: &str) -> Option<f64> {
        let a = self.accuracy(engine, scene)?;
        if a.failed_at.is_some() {
            return None;
        }
        bench_contact::scene_error(scene, a.top_drift, a.worst_displacement, a.top_travel)
    }

    /// The charts' points: every scene and engine with a time and an error.
    fn points(&self) -> Vec<bench_contact::PointRow> {
        let mut rows = Vec::new();
        for (scene, _) in CONTACT_SCENES {
            for (engine, _) in CONTACT_ENGINES {
                if let (Some(t), Some(e)) = (self.time(engine, scene), self.error(engine, scene)) {
                    rows.push((
                        scene.to_string(),
                        engine_group(engine),
                        short_label(engine),
                        t,
                        e,
                    ));
                }
            }
        }
        rows
    }
}

/// Parses `target/peers/contact_accuracy.tsv` (header line first).
pub(crate) fn parse_contact_accuracy(text: &str) -> Vec<(String, String, ContactAccuracy)> {
    let mut out = Vec::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() < 12 {
            continue;
        }
        let (Ok(top_drift), Ok(top_sink), Ok(worst_displacement)) =
            (f[5].parse(), f[6].parse(), f[7].parse())
        else {
            continue;
        };
        out.push((
            f[1].to_string(),
            f[0].to_string(),
            ContactAccuracy {
                top_drift,
                top_sink,
                worst_displacement,
                contacts: f[9].parse().ok(),
                failed_at: f[11].parse().ok(),
                top_travel: f.get(12).and_then(|t| t.parse().ok()),
            },
        ));
    }
    out
}

fn fmt_len(x: Option<f64>) -> String {
    x.map_or("–".into(), |x| format!("{x:.1e} m"))
}

/// One interleaved measurement of the soft step against rapier3d (`cargo run -p
/// constraint-peers --features rapier --example paired_ratio`): the two engines timed
/// in alternating rounds in one process, the ratio taken per round.
#[derive(Clone, Debug, PartialEq)]
struct Paired {
    scene: String,
    substeps: usize,
    rounds: usize,
    batch: usize,
    /// Median of the per-round ratios ours / rapier3d, and its quartiles.
    median: f64,
    q1: f64,
    q3: f64,
    /// Each engine's median µs per step over the rounds.
    ours_us: f64,
    rapier_us: f64,
}

/// The `paired\t…` line of `paired_ratio`'s output, if there is one and it parses.
fn parse_paired(out: &str) -> Option<Paired> {
    let line = out.lines().find_map(|l| l.strip_prefix("paired\t"))?;
    let f: Vec<&str> = line.split('\t').collect();
    if f.len() != 9 {
        return None;
    }
    let x = |i: usize| f[i].parse::<f64>().ok().filter(|v| v.is_finite());
    Some(Paired {
        scene: f[0].to_string(),
        substeps: f[1].parse().ok()?,
        rounds: f[2].parse().ok()?,
        batch: f[3].parse().ok()?,
        median: x(4)?,
        q1: x(5)?,
        q3: x(6)?,
        ours_us: x(7)?,
        rapier_us: x(8)?,
    })
}

/// Runs `paired_ratio` on each scene of [`PAIRED_SCENES`]; a failed run becomes a note.
fn run_paired(p: &mut ContactPeers) {
    for scene in PAIRED_SCENES {
        let (ok, out) = output(cargo().args([
            "run",
            "--release",
            "-q",
            "-p",
            "constraint-peers",
            "--features",
            "rapier",
            "--example",
            "paired_ratio",
            "--",
            scene,
        ]));
        match parse_paired(&out).filter(|_| ok) {
            Some(r) => p.paired.push(r),
            None => p.notes.push(format!(
                "paired_ratio {scene}: no result (run failed or output unreadable)"
            )),
        }
    }
}

/// Scenes timed interleaved by `paired_ratio`: the two of issue 14's speed targets.
const PAIRED_SCENES: [&str; 2] = ["stack10", "pyramid20"];

/// The interleaved-ratio table of the contact section.
fn paired_markdown(md: &mut String, p: &ContactPeers) {
    if p.paired.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\n## Interleaved: soft step against rapier3d in one process\n\n\
         `cargo run --release -p constraint-peers --features rapier --example paired_ratio -- SCENE`: \
         both engines stepped 1 s from rest, then timed in alternating rounds (ours first in \
         even rounds, rapier3d first in odd ones), the ratio ours / rapier3d taken per round. \
         Rounds of a few milliseconds see one machine state for both engines, so this ratio \
         holds where criterion's medians of separate series drift apart (on a shared machine \
         the same binary's series differ by up to ±30 % between runs). The default fast \
         path: `ContactSolver::SoftStep` with 3 sub-steps (what `Auto` runs on the \
         pyramid).\n"
    );
    let _ = writeln!(
        md,
        "| scene | sub-steps | ours / rapier3d (median of rounds) | quartiles | ours µs/step | rapier3d µs/step | rounds × steps |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|");
    for r in &p.paired {
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} … {:.3} | {:.2} | {:.2} | {} × {} |",
            r.scene, r.substeps, r.median, r.q1, r.q3, r.ours_us, r.rapier_us, r.rounds, r.batch
        );
    }
}

/// The contact section appended to `target/bench/ratios.md`.
fn contact_markdown(p: &ContactPeers) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "\n# Contact scenes: time per step and resting accuracy, this library against rapier3d\n\n\
         Same run (`cargo bench -p constraint-peers --features rapier --bench contact_peers`). \
         Scenes of `constraint_contact::scenes`: `box_stack(10)` (unit boxes, 1 m, density \
         1000, friction 0.5, on the ground plane z = 0, each resting exactly on the one \
         below) and `pyramid(20)` (210 unit boxes, rows in the x–z plane at 1.1 m pitch). \
         dt = 1/60, one core. Time per step: criterion median after 1 s of simulated \
         warm-up (the stacks are at rest by then). Accuracy: a separate untimed run of 10 s \
         at 60 Hz from the start; drift is the top box's largest distance from its start \
         over the run, sink its start height minus its final height, worst displacement \
         the largest distance of any box from its start over the run. The sliding box \
         (`scenes/sliding_box.xml`'s: a 0.2 m box launched at 3 m/s on μ 0.5) is timed at \
         rest too (it stops after 0.61 s); its accuracy is the stopping-distance error \
         `|d − v²/(2μg)|`. The last column is what the charts plot: the top box's drift \
         (stack, heavy box), the worst displacement (pyramid), the stopping-distance error \
         (sliding box). MuJoCo's rows: the same scenes in MuJoCo (notes below), its time \
         per 1/60 s. A ratio below 1 means this library is faster.\n"
    );
    let _ = writeln!(
        md,
        "| scene | engine | time per step | ours / rapier3d | top-box drift (max over 10 s) | \
         top-box sink (at 10 s) | worst box displacement (max over 10 s) | contact points | \
         chart's accuracy |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for (scene, scene_label) in CONTACT_SCENES {
        let rapier = p.time("rapier", scene);
        for (engine, label) in CONTACT_ENGINES {
            let t = p.time(engine, scene);
            let a = p.accuracy(engine, scene);
            if t.is_none() && a.is_none() {
                continue;
            }
            let ratio = if !engine.starts_with("ours") {
                "–".to_string()
            } else {
                fmt_ratio(t, rapier)
            };
            let (drift, sink, worst) = match a {
                Some(a) if a.failed_at.is_some() => {
                    let f = format!("step failed at t = {:.3} s", a.failed_at.unwrap_or(0.0));
                    (f.clone(), f.clone(), f)
                }
                Some(a) => (
                    fmt_len(Some(a.top_drift)),
                    fmt_len(Some(a.top_sink)),
                    fmt_len(Some(a.worst_displacement)),
                ),
                None => ("–".into(), "–".into(), "–".into()),
            };
            let contacts = a
                .and_then(|a| a.contacts)
                .map_or("–".into(), |c| c.to_string());
            let _ = writeln!(
                md,
                "| {scene_label} | {label} | {} | {ratio} | {drift} | {sink} | {worst} | {contacts} | {} |",
                fmt_time(t),
                fmt_len(p.error(engine, scene))
            );
        }
    }
    let _ = writeln!(md, "\n## Notes (contact)\n");
    let auto_pyramid = p
        .accuracy("ours_auto", "pyramid20")
        .and_then(|a| a.contacts)
        .map_or(String::new(), |c| {
            format!(
                " On the pyramid ({c} contact points at the end) `Auto` is the soft step with 3 sub-steps."
            )
        });
    let mut notes = vec![
        format!(
            "ours (Auto) is `ContactSolver::Auto` with default `ContactSettings`: dense \
             Fischer–Burmeister Newton with staggered friction up to 200 contact points, \
             the soft step with 3 sub-steps beyond.{auto_pyramid} ours (SI) forces \
             `ContactSolver::SequentialImpulses` (30 sweeps, 2 shock-propagation sweeps, \
             split impulses). ours (soft step, N sub-steps) is \
             `ContactSolver::SoftStep {{ substeps: N }}` (Box2D v3's soft step, default \
             `SoftStepSettings`: 30 Hz, damping ratio 10, push-out capped at 3 m/s)."
        ),
        format!(
            "rapier3d {} (f64): the same bodies at the same poses (built from our scene), \
             cuboid colliders of half extent 0.5, friction 0.5, restitution 0, density 1000, \
             a half-space ground on a fixed body, default `IntegrationParameters` with dt = \
             1/60 and the default solver; sleeping is off (`can_sleep(false)`) so that, like \
             ours, every body is simulated every step (a resting stack would otherwise fall \
             asleep and cost almost nothing). Contact points: ours only.",
            locked_version("rapier3d-f64").as_deref().unwrap_or("?")
        ),
    ];
    notes.extend(p.notes.iter().cloned());
    for n in notes {
        let _ = writeln!(md, "- {n}");
    }
    paired_markdown(&mut md, p);
    charts_section(&mut md, p);
    pile_section(&mut md, p);
    md
}

/// The charts: accuracy against time per step per scene, linked from `ratios.md`.
fn charts_section(md: &mut String, p: &ContactPeers) {
    let _ = writeln!(
        md,
        "\n## Accuracy against time per step\n\n\
         One chart per scene: the table's last column (log y) against its time per step \
         (log x), one labelled point per setting of ours (`soft N` is the soft step with N \
         sub-steps, then its contact frequency, friction anchors or one-way coupling), \
         rapier3d's and MuJoCo's; the dashed line is the Pareto front. A failed run has \
         no point.\n"
    );
    match &p.charts {
        Ok(files) if !files.is_empty() => {
            for (scene, file) in files {
                let label = CONTACT_SCENES
                    .iter()
                    .find(|s| s.0 == scene)
                    .map_or(scene.as_str(), |s| s.1);
                let _ = writeln!(md, "- [{label}]({file})\n\n  ![{label}]({file})\n");
            }
        }
        Ok(_) => {
            let _ = writeln!(md, "No chart: no scene has both a time and an accuracy.");
        }
        Err(e) => {
            let _ = writeln!(md, "No chart: {e}.");
        }
    }
}

/// The piles (issue 14): criterion's time per step on 1000 and 10,000 mixed bodies,
/// sleeping off and on, each against rapier3d with the same sleeping; then the growth
/// table `target/peers/pile_growth.tsv` (time per step over 100 … 10,000 bodies, energy,
/// depth, bodies asleep) as the bench wrote it, with its fitted exponents.
fn pile_section(md: &mut String, p: &ContactPeers) {
    let sizes = [1000usize, 10000];
    let pairs = [
        (
            "ours_soft4",
            "rapier",
            "ours (soft step, 4 sub-steps), sleeping off",
        ),
        (
            "ours_soft4_sleep",
            "rapier_sleep",
            "ours (soft step, 4 sub-steps), sleeping on",
        ),
        ("rapier", "rapier", "rapier3d, sleeping off"),
        ("rapier_sleep", "rapier_sleep", "rapier3d, sleeping on"),
    ];
    let any = sizes.iter().any(|n| {
        pairs
            .iter()
            .any(|(e, _, _)| p.time(e, &format!("pile{n}")).is_some())
    });
    let growth = std::fs::read_to_string(root().join("target/peers/pile_growth.tsv")).ok();
    if !any && growth.is_none() {
        return;
    }
    let _ = writeln!(
        md,
        "\n## Piles: boxes, spheres and capsules poured into a container\n\n\
         `constraint_contact::scenes::pile(n, 1)`, timed after the pour settles; the ratio is \
         against rapier3d with the same sleeping setting (a ratio below 1: this library is \
         faster).\n\n| bodies | engine | time per step | ratio |\n|---:|---|---:|---:|"
    );
    for n in sizes {
        let scene = format!("pile{n}");
        for (engine, peer, label) in pairs {
            let t = p.time(engine, &scene);
            if t.is_none() {
                continue;
            }
            let ratio = if engine.starts_with("rapier") {
                "–".to_string()
            } else {
                fmt_ratio(t, p.time(peer, &scene))
            };
            let _ = writeln!(md, "| {n} | {label} | {} | {ratio} |", fmt_time(t));
        }
    }
    if let Some(g) = growth {
        let _ = writeln!(
            md,
            "\nGrowth (`target/peers/pile_growth.tsv`; the bench prints the fitted exponent of \
             time per step against bodies):\n\n```\n{}```",
            g
        );
    }
}

/// The contact scenes: the contact_peers bench and its accuracy file, MuJoCo on the same
/// scenes (unless `mujoco` is false), then the charts into `target/bench/`.
fn contact_peers(criterion_args: &[String], mujoco: bool) -> Result<ContactPeers, String> {
    let path = root().join("target/peers/contact_accuracy.tsv");
    // A stale accuracy file must not pass for this run's.
    let _ = std::fs::remove_file(&path);
    let ok = cargo()
        .args([
            "bench",
            "-p",
            "constraint-peers",
            "--features",
            "rapier",
            "--bench",
            "contact_peers",
            "--",
        ])
        .args(criterion_args)
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !ok {
        return Err(
            "cargo bench -p constraint-peers --features rapier --bench contact_peers failed".into(),
        );
    }
    let mut p = ContactPeers::default();
    for (engine, _) in CONTACT_ENGINES {
        for (scene, _) in CONTACT_SCENES {
            if let Some(t) = estimate("contact_peers", engine, scene) {
                p.time.push((engine.to_string(), scene.to_string(), t));
            }
        }
    }
    for engine in ["ours_soft4", "ours_soft4_sleep", "rapier", "rapier_sleep"] {
        for scene in ["pile1000", "pile10000"] {
            if let Some(t) = estimate("contact_peers", engine, scene) {
                p.time.push((engine.to_string(), scene.to_string(), t));
            }
        }
    }
    run_paired(&mut p);
    match std::fs::read_to_string(&path) {
        Ok(text) => p.accuracy = parse_contact_accuracy(&text),
        Err(_) => p
            .notes
            .push(format!("{}: missing, no accuracy figures", path.display())),
    }
    if mujoco {
        let (points, notes) = bench_contact::run_mujoco();
        for m in points {
            p.time.push((
                m.setting.engine.into(),
                m.scene.clone(),
                m.seconds_per_60hz_step,
            ));
            let f = &m.figures;
            p.accuracy.push((
                m.setting.engine.into(),
                m.scene,
                ContactAccuracy {
                    top_drift: f.top_drift,
                    top_sink: f.top_sink,
                    worst_displacement: f.worst_displacement,
                    contacts: None,
                    failed_at: None,
                    top_travel: Some(f.top_travel),
                },
            ));
        }
        p.notes.extend(notes);
    } else {
        p.notes
            .push("MuJoCo skipped on the contact scenes (--no-mujoco)".into());
    }
    p.charts = contact_charts(&p);
    Ok(p)
}

/// Writes `target/bench/contact_points.tsv` and draws its charts.
fn contact_charts(p: &ContactPeers) -> Result<Vec<(String, String)>, String> {
    let dir = root().join("target/bench");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let tsv = dir.join("contact_points.tsv");
    let label = |s: &str| {
        CONTACT_SCENES
            .iter()
            .find(|c| c.0 == s)
            .map_or(s.to_string(), |c| c.1.to_string())
    };
    std::fs::write(&tsv, bench_contact::points_tsv(&p.points(), label))
        .map_err(|e| format!("{}: {e}", tsv.display()))?;
    let note = "ours, rapier3d: criterion median of one step at dt = 1/60 after 1 s; MuJoCo: its C loop, time per 1/60 s.\n\
                Accuracy: 10 s from the start at 60 Hz (cargo xtask bench, target/bench/ratios.md).";
    let (files, notes) = bench_contact::draw_charts(&tsv, &dir, note)?;
    for n in notes {
        eprintln!("xtask: contact charts: {n}");
    }
    Ok(files)
}

/// The chains: the chain_peers bench, then MuJoCo on the same chains.
fn chains(criterion_args: &[String], mujoco: bool) -> Result<Peers, String> {
    // A stale accuracy file must not pass for this run's.
    let _ = std::fs::remove_file(root().join("target/peers/accuracy.tsv"));
    let ok = cargo()
        .args([
            "bench",
            "-p",
            "constraint-peers",
            "--features",
            "rapier",
            "--bench",
            "chain_peers",
            "--",
        ])
        .args(criterion_args)
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !ok {
        return Err("cargo bench -p constraint-peers --features rapier failed".into());
    }
    let mut p = Peers::default();
    for (engine, _) in &ENGINES[..3] {
        for n in CHAIN_SIZES {
            if let Some(t) = estimate("chain_peers", engine, n) {
                p.time.push((engine.to_string(), n, t));
            }
        }
    }
    read_accuracy(&mut p);
    if mujoco {
        mujoco_chains(&mut p);
    } else {
        p.notes.push("MuJoCo skipped (--no-mujoco)".into());
    }
    Ok(p)
}

/// The `models` section: the time-per-step table of `cargo xtask models run`
/// ([`models::timing_table`], each model's passive case) from the same runner, whose
/// full report (checks, smooth comparisons) goes to `target/bench/models/models.md`.
fn models_markdown(s: &models::Suite) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "\n# MuJoCo models: time per step\n\n\
         gymnasium {} and dm_control {} models (`cargo xtask models run`'s runner), MuJoCo {}, \
         each from its default pose with zero control for {} s at the file's time step and \
         integrator; MuJoCo timed by `mujoco.rollout` (its C loop), ours by the `simulate` \
         binary (release, default method), the two timed alternately in repeats (the ratio is \
         the median of the per-repeat ratios, quartiles beside it). Ratio below 1: this library \
         is faster. Checks and the other cases: `target/bench/models/models.md`.\n",
        models::GYMNASIUM_VERSION,
        models::DM_CONTROL_VERSION,
        s.version.as_deref().unwrap_or("?"),
        s.seconds
    );
    md.push_str(&models::timing_table(&s.rows));
    md
}

fn write_report(dir: &Path, md: &str) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join("ratios.md");
    std::fs::write(&path, md).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

/// The sections of a run, in the report's order.
const SECTIONS: [&str; 5] = ["chains", "contact", "mjcf", "models", "cloth"];

/// The options of `cargo xtask bench`: its own flags first, then everything for
/// criterion.
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// Leave MuJoCo out: the chains and the MJCF scenes run ours only, the real models
    /// not at all [default: off, MuJoCo runs (pip-installed on first use)].
    #[arg(long)]
    pub no_mujoco: bool,
    /// The peer comparisons only: every section but cloth [default: off].
    #[arg(long)]
    pub peers_only: bool,
    /// The sections to run, comma-separated, from chains, contact, mjcf, models, cloth
    /// (given twice, the last counts) [default: all of them].
    #[arg(
        long,
        value_name = "SECTIONS",
        value_delimiter = ',',
        action = clap::ArgAction::Set,
        value_parser = section
    )]
    pub only: Vec<&'static str>,
    /// Passed to every criterion bench, after xtask's own options (`--quick`, a filter, …)
    /// [default: none].
    #[arg(
        value_name = "CRITERION ARGS",
        num_args = 0..,
        trailing_var_arg = true,
        allow_hyphen_values = true
    )]
    pub criterion_args: Vec<String>,
}

/// A section name of `--only` ([`SECTIONS`]), spaces around it ignored.
fn section(s: &str) -> Result<&'static str, String> {
    let s = s.trim();
    SECTIONS
        .into_iter()
        .find(|x| *x == s)
        .ok_or_else(|| format!("unknown section (sections: {})", SECTIONS.join(", ")))
}

/// What a run of `cargo xtask bench` does, from its [`Options`].
#[derive(Debug, PartialEq)]
struct Plan {
    mujoco: bool,
    /// Sections to run, a subset of [`SECTIONS`] in its order.
    sections: Vec<&'static str>,
}

impl Plan {
    /// The sections `o` selects, in the report's order. xtask's own flags go before
    /// criterion's arguments (clap passes everything from the first argument it does
    /// not know to criterion): one found among them is an error, not criterion's.
    fn of(o: &Options) -> Result<Plan, String> {
        if let Some(a) = o.criterion_args.iter().find(|a| {
            ["--no-mujoco", "--peers-only", "--only"].contains(&a.as_str())
                || a.starts_with("--only=")
        }) {
            return Err(format!(
                "{a} comes after criterion's arguments ({}): give xtask's options first",
                o.criterion_args[0]
            ));
        }
        let sections = SECTIONS
            .into_iter()
            .filter(|s| o.only.is_empty() || o.only.contains(s))
            .filter(|s| !(o.peers_only && *s == "cloth"))
            .collect();
        Ok(Plan {
            mujoco: !o.no_mujoco,
            sections,
        })
    }
}

/// Runs the sections of `opts` and writes `target/bench/ratios.md`.
pub fn main(opts: &Options) -> Result<(), String> {
    let o = Plan::of(opts)?;
    let _ = RUN_START.set(SystemTime::now());
    let args = &opts.criterion_args;
    let run = |s: &str| o.sections.contains(&s);
    let cloth = if run("cloth") {
        Some(bench_cloth::run(args)?)
    } else {
        None
    };
    let chains = if run("chains") {
        Some(chains(args, o.mujoco)?)
    } else {
        None
    };
    let contact = if run("contact") {
        Some(contact_peers(args, o.mujoco)?)
    } else {
        None
    };
    let mjcf = if run("mjcf") {
        Some(bench_mjcf::run(args, o.mujoco)?)
    } else {
        None
    };
    // The real models need MuJoCo for their reference time: left out with --no-mujoco.
    let models = if run("models") && o.mujoco {
        let out = root().join("target/bench/models");
        // Without Python or PyPI the section says why instead of failing the bench.
        Some(models::run_suite(&models::RunArgs {
            quick: false,
            out,
            simulate: None,
        }))
    } else {
        None
    };
    let mut md = String::new();
    if let Some(p) = &chains {
        md.push_str(&ratios_markdown(p));
    }
    if let Some(c) = &contact {
        md.push_str(&contact_markdown(c));
    }
    if let Some(m) = &mjcf {
        md.push_str(&bench_mjcf::markdown(m));
    }
    if let Some(m) = &models {
        match m {
            Ok(m) => md.push_str(&models_markdown(m)),
            Err(e) => {
                let _ = writeln!(md, "\n# MuJoCo models\n\nNot run: {e}.");
            }
        }
    } else if run("models") {
        md.push_str("\n# MuJoCo models\n\nLeft out: `--no-mujoco`.\n");
    }
    if let Some((c, k)) = &cloth {
        md.push_str(&cloth_markdown(c, k));
    }
    let skipped: Vec<&str> = SECTIONS
        .into_iter()
        .filter(|s| !o.sections.contains(s))
        .collect();
    if !skipped.is_empty() {
        let _ = writeln!(
            md,
            "\n# Not run\n\nSections left out of this run (`--peers-only` or `--only`): {}.",
            skipped.join(", ")
        );
    }
    let md = md.trim_start();
    println!("\n{md}");
    let path = write_report(&root().join("target/bench"), md)?;
    println!("wrote {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_numbers_and_strings_from_the_timing_json() {
        // As xtask/mujoco_run.py writes it (json.dump, indent 2).
        let j = "{\n  \"scene\": \"a.xml\",\n  \"integrator\": \"euler\",\n  \"dt\": 0.001,\n  \
                 \"steps\": 1000,\n  \"seconds_per_step\": 2.5e-05,\n  \"repeats\": 3,\n  \
                 \"mujoco_version\": \"4.0.0\"\n}\n";
        let t = Timing::parse(j);
        assert_eq!(t.seconds_per_step, Some(2.5e-5));
        assert_eq!(t.steps, Some(1000));
        assert_eq!(t.mujoco_version.as_deref(), Some("4.0.0"));
        let missing = Timing::parse("{\"scene\": \"a.xml\"}");
        assert_eq!((missing.seconds_per_step, missing.steps), (None, None));
        assert_eq!(Timing::parse("not json"), Timing::default());
    }

    #[test]
    fn reads_paired_ratios_line_and_refuses_broken_ones() {
        let out = "stack10 soft3 / rapier3d: median 0.556 (quartiles 0.551 … 0.562) over 41 \
                   rounds of 100 steps; ours 28.68 µs/step, rapier3d 51.65 µs/step (medians)\n\
                   paired\tstack10\t3\t41\t100\t0.556\t0.551\t0.562\t28.68\t51.65\n";
        let r = parse_paired(out).expect("the line parses");
        assert_eq!(
            (r.scene.as_str(), r.substeps, r.rounds, r.batch),
            ("stack10", 3, 41, 100)
        );
        assert_eq!((r.median, r.q1, r.q3), (0.556, 0.551, 0.562));
        assert_eq!((r.ours_us, r.rapier_us), (28.68, 51.65));
        // A short line, a NaN and no line at all give nothing, not a row of zeros.
        assert_eq!(parse_paired("paired\tstack10\t3\t41\n"), None);
        assert_eq!(
            parse_paired("paired\tstack10\t3\t41\t100\tNaN\t0.5\t0.6\t1\t2\n"),
            None
        );
        assert_eq!(parse_paired("median 0.5\n"), None);
        let mut p = ContactPeers::default();
        p.paired.push(r);
        let mut md = String::new();
        paired_markdown(&mut md, &p);
        assert!(md.contains("| stack10 | 3 | 0.556 | 0.551 … 0.562 | 28.68 | 51.65 | 41 × 100 |"));
    }

    #[test]
    fn reads_the_median_of_criterions_estimates() {
        let j = r#"{"mean":{"confidence_interval":{"confidence_level":0.95,"lower_bound":1.0,"upper_bound":3.0},"point_estimate":2.0,"standard_error":0.1},"median":{"confidence_interval":{"confidence_level":0.95,"lower_bound":1400.0,"upper_bound":1600.0},"point_estimate":1500.0,"standard_error":5.0},"median_abs_dev":{"confidence_interval":{"confidence_level":0.95,"lower_bound":1.0,"upper_bound":2.0},"point_estimate":1.5,"standard_error":0.1},"slope":null,"std_dev":{"confidence_interval":{"confidence_level":0.95,"lower_bound":1.0,"upper_bound":2.0},"point_estimate":1.5,"standard_error":0.1}}"#;
        let e: Estimates = serde_json::from_str(j).unwrap();
        assert_eq!(e.median.point_estimate, 1500.0);
    }

    /// `cargo xtask bench LINE`'s options and plan, or the error rendered.
    fn parse_args(line: &str) -> Result<(Options, Plan), String> {
        match crate::parse(&format!("bench {line}")) {
            Ok(Some(crate::Command::Bench(o))) => Plan::of(&o).map(|p| (o, p)),
            Ok(other) => panic!("{line}: parsed as {other:?}"),
            Err(e) => Err(e.to_string()),
        }
    }

    #[test]
    fn parses_sections_and_passes_the_rest_to_criterion() {
        let (o, p) = parse_args("--no-mujoco --quick").unwrap();
        assert_eq!(p.sections, SECTIONS);
        assert!(!p.mujoco);
        assert_eq!(o.criterion_args, ["--quick"]);
        let (_, p) = parse_args("--peers-only --only cloth,mjcf").unwrap();
        assert_eq!(p.sections, ["mjcf"]);
        assert!(p.mujoco);
        let (o, p) = parse_args("--only=cloth,chains filter").unwrap();
        assert_eq!(p.sections, ["chains", "cloth"]);
        assert_eq!(o.criterion_args, ["filter"]);
        let (o, p) = parse_args("--only mjcf --only cloth --warm-up-time 1 x").unwrap();
        assert_eq!(p.sections, ["cloth"], "the last --only counts");
        assert_eq!(o.criterion_args, ["--warm-up-time", "1", "x"]);
        let (o, p) = parse_args("").unwrap();
        assert_eq!((p.sections.len(), p.mujoco), (5, true));
        assert!(o.criterion_args.is_empty());
        assert!(parse_args("--only rigid")
            .unwrap_err()
            .contains("unknown section"));
        assert!(parse_args("--only").is_err());
        // xtask's options after criterion's are an error, not criterion's.
        let e = parse_args("--quick --no-mujoco").unwrap_err();
        assert!(e.contains("give xtask's options first"), "{e}");
        assert!(parse_args("filter --only=cloth").is_err());
    }

    #[test]
    fn the_ratio_table_has_a_row_per_size_and_exponents() {
        let mut p = Peers::default();
        for (e, base) in [("ours_velocity", 1e-7), ("rapier", 1e-6), ("mujoco", 1e-6)] {
            for n in CHAIN_SIZES {
                p.time.push((e.into(), n, base * n as f64));
            }
        }
        p.heavy_tip.push(("rapier".into(), 3.0, false, None));
        p.heavy_tip
            .push(("ours_velocity".into(), f64::INFINITY, false, Some(0.5)));
        let md = ratios_markdown(&p);
        assert!(
            md.contains("| 100 | 10.00 µs | – | 100.00 µs | 100.00 µs | 0.100 |"),
            "{md}"
        );
        assert!(md.contains("| 10 → 20 | 1.00 | – | 1.00 | 1.00 |"), "{md}");
        assert!(
            md.contains("| rapier3d | 3.0e0 m | no, comes apart |"),
            "{md}"
        );
    }

    #[test]
    fn the_contact_table_has_times_ratios_and_accuracy() {
        let tsv = "scene\tengine\tboxes\tdt\tduration\ttop_drift\ttop_sink\tworst_displacement\t\
                   worst_at_end\tcontacts\tfinite\tfailed_at\n\
                   stack10\tours_auto\t10\t1.6e-2\t10\t2e-10\t2.5e-11\t3e-10\t3e-10\t40\ttrue\t-\n\
                   stack10\trapier\t10\t1.6e-2\t10\t5.6e-3\t2.5e-2\t5.6e-3\t5e-3\t-\ttrue\t-\n\
                   pyramid20\tours_auto\t210\t1.6e-2\t10\t1e-2\t1e-3\t2e-2\t2e-2\t800\tfalse\t2.5\n";
        let mut p = ContactPeers {
            accuracy: parse_contact_accuracy(tsv),
            ..ContactPeers::default()
        };
        assert_eq!(p.accuracy.len(), 3);
        p.time.push(("ours_auto".into(), "stack10".into(), 11e-6));
        p.time.push(("rapier".into(), "stack10".into(), 22e-6));
        let md = contact_markdown(&p);
        assert!(
            md.contains(
                "| 10-box stack | ours (Auto) | 11.00 µs | 0.500 | 2.0e-10 m | 2.5e-11 m | 3.0e-10 m | 40 |"
            ),
            "{md}"
        );
        assert!(
            md.contains("| 10-box stack | rapier3d | 22.00 µs | – | 5.6e-3 m | 2.5e-2 m |"),
            "{md}"
        );
        assert!(md.contains("step failed at t = 2.500 s"), "{md}");
        assert!(md.contains("(800 contact points at the end)"), "{md}");
        assert!(!md.contains("(210 boxes) | ours (SI)"), "{md}");
        assert!(md.contains("No chart: not drawn."), "{md}");
        // The chart's points: a time and an accuracy, failed runs left off.
        let pts = p.points();
        assert_eq!(pts.len(), 2, "{pts:?}");
        assert_eq!(
            pts[0],
            ("stack10".into(), "ours", "Auto".into(), 11e-6, 2e-10)
        );
        assert_eq!(pts[1].1, "rapier3d");
        p.charts = Ok(vec![("stack10".into(), "contact_stack10.svg".into())]);
        let md = contact_markdown(&p);
        assert!(md.contains("![10-box stack](contact_stack10.svg)"), "{md}");
    }

    #[test]
    fn mujoco_rows_and_the_sliding_box_error() {
        let tsv = "scene\tengine\tboxes\tdt\tduration\ttop_drift\ttop_sink\tworst_displacement\t\
                   worst_at_end\tcontacts\tfinite\tfailed_at\ttop_travel\terror\n\
                   sliding_box\tours_auto\t1\t1.6e-2\t10\t0.9\t1e-4\t0.9\t0.9\t4\ttrue\t-\t0.92\t2.6e-3\n";
        let mut p = ContactPeers {
            accuracy: parse_contact_accuracy(tsv),
            ..ContactPeers::default()
        };
        p.time
            .push(("ours_auto".into(), "sliding_box".into(), 1e-6));
        p.time.push(("mujoco".into(), "sliding_box".into(), 2e-6));
        p.accuracy.push((
            "mujoco".into(),
            "sliding_box".into(),
            ContactAccuracy {
                top_travel: Some(0.9),
                ..ContactAccuracy::default()
            },
        ));
        let e = p.error("ours_auto", "sliding_box").unwrap();
        assert!((e - (0.92 - bench_contact::SLIDE_EXACT)).abs() < 1e-15);
        let md = contact_markdown(&p);
        assert!(
            md.contains("| sliding box (3 m/s, μ 0.5) | MuJoCo (dt = 1/60) | 2.00 µs | – |"),
            "{md}"
        );
        assert_eq!(
            short_label("ours_soft8_120hz_anchors"),
            "soft 8, 120hz, anchors"
        );
        assert_eq!(engine_group("mujoco_240hz"), "MuJoCo");
        assert_eq!(p.points().len(), 2);
    }
}
