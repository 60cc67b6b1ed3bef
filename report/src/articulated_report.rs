//! The articulated-bodies section of the verification report (issue 4's figures, issue
//! 6's work-precision report on the MJCF scenes):
//!
//! * per scene of `scenes/`, a log–log chart of trajectory error (max centre-of-mass
//!   distance to the committed MuJoCo RK4 export over 1 s from keyframe `start`) against
//!   run time per simulated second, for each method of [`CHART_METHODS`] over several
//!   steps, with MuJoCo's points (Euler, implicitfast, RK4 at the same steps) read from
//!   `scenes/reference/mujoco_points.csv` and the Pareto front marked; and a table;
//! * a summary: per scene, the fastest of our methods reaching an error level, next to
//!   MuJoCo's fastest for the same level;
//! * the drift of joint separation over time on the 20-link chain.
//!
//! Our points are measured in the run (wall time of the steps alone, best of up to 3
//! runs); MuJoCo's come from the committed CSV (see `scenes/reference/README.md`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use constraint_articulated::MjcfScene;

use crate::chart::{pareto_front, LogLogChart, Series};
use constraint_scene::run::{self as scene, RunOptions};
use constraint_scene::trajectory::{compare, Trajectory};

/// Every MJCF scene the report charts against MuJoCo's committed reference, in report
/// order (`constraint_scene::catalogue`: the seven joint-only scenes, then the one
/// world's smooth scenes — a planar root with a hinged leg, two hinges in one body, a
/// damped hinge, a motor-driven prismatic joint at zero control, fluid drag).
pub fn scenes() -> impl Iterator<Item = &'static str> {
    constraint_scene::catalogue::charted_scenes()
}

/// Our methods on the work-precision charts: every name of [`scene::METHODS`] except
/// `acceleration` (unstabilised, it drifts; it is on the drift chart).
pub const CHART_METHODS: [&str; 6] = [
    "velocity",
    "projected",
    "shake",
    "baumgarte",
    "rattle",
    "rattle4",
];

/// The methods of the drift chart.
pub const DRIFT_METHODS: [&str; 4] = ["velocity", "projected", "baumgarte", "acceleration"];

/// MuJoCo's integrators, as named in `mujoco_points.csv`.
pub const MUJOCO_INTEGRATORS: [&str; 3] = ["euler", "implicitfast", "rk4"];

/// Steps of the full sweep (s); the MuJoCo CSV has the same ones.
pub const FULL_DTS: [f64; 6] = [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1e-4];

/// Steps of the quick sweep (s).
pub const QUICK_DTS: [f64; 3] = [4e-3, 1e-3, 2.5e-4];

/// Simulated horizon of the work-precision runs (s).
pub const HORIZON: f64 = 1.0;

/// Error levels of the summary table (m).
pub const TOLERANCES: [f64; 2] = [1e-3, 1e-6];

/// The MuJoCo points file, relative to the workspace root.
pub const MUJOCO_POINTS: &str = "scenes/reference/mujoco_points.csv";

/// What one mode of the report runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Scenes (chain100 only in the full mode).
    pub scenes: Vec<&'static str>,
    /// Steps (s).
    pub dts: Vec<f64>,
    /// Drift run length (s).
    pub drift_secs: f64,
    /// Drift run step (s).
    pub drift_dt: f64,
    /// Drift chart window: max separation over each window (s).
    pub drift_window: f64,
}

impl Plan {
    /// The small plan (`cargo xtask verify` and CI) or the full one (`--full`).
    pub fn new(quick: bool) -> Self {
        let scenes = scenes().filter(|s| !quick || *s != "chain100").collect();
        Self {
            scenes,
            dts: if quick {
                QUICK_DTS.to_vec()
            } else {
                FULL_DTS.to_vec()
            },
            drift_secs: if quick { 2.0 } else { 10.0 },
            drift_dt: 1e-3,
            drift_window: 0.05,
        }
    }
}

/// The workspace root (scenes are found from it whatever the working directory).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Smallest step count `k` with `k·dt` a whole multiple of `interval` (the reference's
/// sample spacing): our run records a row every `k` steps and is compared at those
/// times. `mujoco_points.py` applies the same rule.
pub fn sample_every(dt: f64, interval: f64) -> usize {
    (1..=100_000)
        .find(|&k| {
            let r = k as f64 * dt / interval;
            r.round() >= 1.0 && (r - r.round()).abs() < 1e-6
        })
        .unwrap_or(1)
}

/// A successful run of one of our methods.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    /// Max COM distance to the reference (m).
    pub com_error: f64,
    /// Wall seconds of stepping over [`HORIZON`], best of the repeats.
    pub seconds: f64,
    /// Steps taken.
    pub steps: u64,
    /// Max joint separation over the recorded rows (m; the `C_max` column).
    pub c_max: f64,
    /// Runs timed.
    pub repeats: usize,
}

impl Measured {
    /// Run time per simulated second.
    pub fn cost(&self) -> f64 {
        self.seconds / HORIZON
    }

    /// Microseconds per step.
    pub fn us_per_step(&self) -> f64 {
        self.seconds / self.steps as f64 * 1e6
    }
}

/// One point of our sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Method name (see [`scene::METHODS`]).
    pub method: &'static str,
    /// Step (s).
    pub dt: f64,
    /// The measurement, or why the run failed (one line).
    pub outcome: Result<Measured, String>,
}

/// The committed reference trajectory of `scene`.
pub fn load_reference(scene: &str) -> Result<Trajectory, String> {
    let path = root().join(format!("scenes/reference/{scene}.csv"));
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let t = Trajectory::parse(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    if t.rows.len() < 2 {
        return Err(format!("{}: fewer than two rows", path.display()));
    }
    Ok(t)
}

fn c_max(t: &Trajectory) -> f64 {
    let Some(k) = t.header.iter().position(|h| h == "C_max") else {
        return f64::NAN;
    };
    t.rows.iter().map(|r| r[k]).fold(0.0, f64::max)
}

/// Runs `scene` with `method` at `dt` over [`HORIZON`] and compares it with `reference`.
/// Timed up to 3 times while the runs together stay under a second; the best counts.
pub fn measure(scene: &str, method: &'static str, dt: f64, reference: &Trajectory) -> Point {
    let interval = reference.rows[1][0] - reference.rows[0][0];
    let opts = RunOptions {
        keyframe: Some("start".into()),
        dt: Some(dt),
        duration: HORIZON,
        every: sample_every(dt, interval),
        method: method.into(),
        ..RunOptions::default()
    };
    let path = root().join(format!("scenes/{scene}.xml"));
    let outcome = (|| {
        let (traj, first) = scene::run(&path, &opts)?;
        let cmp = compare(&traj, reference)?;
        let (mut best, mut total, mut repeats) = (first, first, 1);
        while repeats < 3 && total < 1.0 {
            let secs = scene::run(&path, &opts)?.1;
            best = best.min(secs);
            total += secs;
            repeats += 1;
        }
        Ok(Measured {
            com_error: cmp.com.0,
            seconds: best,
            steps: (HORIZON / dt).round() as u64,
            c_max: c_max(&traj),
            repeats,
        })
    })();
    Point {
        method,
        dt,
        outcome,
    }
}

/// One row of `mujoco_points.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct MujocoPoint {
    /// Scene name.
    pub scene: String,
    /// `euler`, `implicitfast` or `rk4`.
    pub integrator: String,
    /// Step (s).
    pub dt: f64,
    /// Max COM distance to the reference (m); `inf` if it diverged.
    pub com_error: f64,
    /// Max orientation angle to the reference (rad).
    pub angle_error: f64,
    /// Seconds per step inside MuJoCo's C loop.
    pub seconds_per_step: f64,
}

impl MujocoPoint {
    /// Run time per simulated second.
    pub fn cost(&self) -> f64 {
        self.seconds_per_step / self.dt
    }
}

/// The parsed `mujoco_points.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct MujocoPoints {
    /// The comment line (`mujoco <version>, measured <date> on <machine>`), without `# `
    /// and without what follows its first `;`.
    pub provenance: String,
    /// The rows, in file order.
    pub points: Vec<MujocoPoint>,
}

/// The header `mujoco_points.csv` must have.
pub const MUJOCO_HEADER: &str = "scene,integrator,dt,com_error_m,angle_error_rad,seconds_per_step";

/// Parses `mujoco_points.csv`: `#` lines are comments (the first is the provenance),
/// then [`MUJOCO_HEADER`], then rows. Errors name the line.
pub fn parse_mujoco_points(text: &str) -> Result<MujocoPoints, String> {
    let mut provenance = String::new();
    let mut header = false;
    let mut points = Vec::new();
    for (i, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        if let Some(c) = line.strip_prefix('#') {
            if provenance.is_empty() {
                provenance = c.split(';').next().unwrap_or("").trim().to_string();
            }
        } else if !header {
            if line.trim() != MUJOCO_HEADER {
                return Err(format!("line {}: header must be `{MUJOCO_HEADER}`", i + 1));
            }
            header = true;
        } else {
            points.push(parse_mujoco_row(line).map_err(|e| format!("line {}: {e}", i + 1))?);
        }
    }
    if !header {
        return Err("no header".into());
    }
    Ok(MujocoPoints { provenance, points })
}

fn parse_mujoco_row(line: &str) -> Result<MujocoPoint, String> {
    let f: Vec<&str> = line.split(',').map(str::trim).collect();
    if f.len() != 6 {
        return Err(format!("{} fields, expected 6", f.len()));
    }
    let num = |k: usize| f[k].parse::<f64>().map_err(|e| format!("{:?}: {e}", f[k]));
    Ok(MujocoPoint {
        scene: f[0].to_string(),
        integrator: f[1].to_string(),
        dt: num(2)?,
        com_error: num(3)?,
        angle_error: num(4)?,
        seconds_per_step: num(5)?,
    })
}

/// Reads [`MUJOCO_POINTS`] from the workspace.
pub fn load_mujoco_points() -> Result<MujocoPoints, String> {
    let path = root().join(MUJOCO_POINTS);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse_mujoco_points(&text)
}

fn same_dt(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// MuJoCo's points for `scene` at the plan's steps, in file order.
pub fn mujoco_for<'a>(mj: &'a MujocoPoints, scene: &str, dts: &[f64]) -> Vec<&'a MujocoPoint> {
    mj.points
        .iter()
        .filter(|p| p.scene == scene && dts.iter().any(|&d| same_dt(d, p.dt)))
        .collect()
}

/// The fastest of our successful points with error ≤ `tol` (first in sweep order on a
/// tie).
pub fn fastest_ours(points: &[Point], tol: f64) -> Option<(&Point, &Measured)> {
    points
        .iter()
        .filter_map(|p| p.outcome.as_ref().ok().map(|m| (p, m)))
        .filter(|(_, m)| m.com_error <= tol)
        .min_by(|a, b| a.1.cost().total_cmp(&b.1.cost()))
}

/// MuJoCo's fastest point with error ≤ `tol`.
pub fn fastest_mujoco<'a>(points: &[&'a MujocoPoint], tol: f64) -> Option<&'a MujocoPoint> {
    points
        .iter()
        .copied()
        .filter(|p| p.com_error <= tol)
        .min_by(|a, b| a.cost().total_cmp(&b.cost()))
}

/// Our measurements for one scene over the plan's methods and steps.
pub fn sweep_scene(scene: &str, dts: &[f64]) -> Result<Vec<Point>, String> {
    let reference = load_reference(scene)?;
    let mut pts = Vec::new();
    for &method in &CHART_METHODS {
        for &dt in dts {
            pts.push(measure(scene, method, dt, &reference));
        }
    }
    Ok(pts)
}

fn ours_series(points: &[Point]) -> Vec<Series> {
    CHART_METHODS
        .iter()
        .map(|&m| Series {
            name: format!("ours: {m}"),
            points: points
                .iter()
                .filter(|p| p.method == m)
                .filter_map(|p| p.outcome.as_ref().ok())
                .map(|r| (r.cost(), r.com_error))
                .collect(),
        })
        .collect()
}

fn mujoco_series(mj: &[&MujocoPoint]) -> Vec<Series> {
    MUJOCO_INTEGRATORS
        .iter()
        .map(|&i| Series {
            name: format!("MuJoCo {i}"),
            points: mj
                .iter()
                .filter(|p| p.integrator == i)
                .map(|p| (p.cost(), p.com_error))
                .collect(),
        })
        .filter(|s| !s.points.is_empty())
        .collect()
}

fn dt_list(dts: &[f64]) -> String {
    let v: Vec<String> = dts.iter().map(|d| format!("{d:e}")).collect();
    v.join(", ")
}

/// The work-precision chart of one scene.
pub fn scene_chart(
    scene: &str,
    points: &[Point],
    mj: &[&MujocoPoint],
    provenance: &str,
    dts: &[f64],
) -> LogLogChart {
    let mut series = ours_series(points);
    series.extend(mujoco_series(mj));
    let mj_note = if mj.is_empty() {
        "No MuJoCo points (scenes/reference/mujoco_points.csv missing or without this scene)."
            .to_string()
    } else {
        format!("MuJoCo points: {provenance}; not in this run.")
    };
    LogLogChart {
        title: format!("{scene}: error against run time"),
        x_label: "run time per simulated second (s)".into(),
        y_label: "max COM error vs MuJoCo RK4 reference (m)".into(),
        series,
        note: format!(
            "Error: max COM distance (bodies, samples) to the committed MuJoCo RK4 export, {HORIZON} s from keyframe start.\n\
             dt = {} s. Ours: wall time of the steps in this run, best of up to 3, one thread.\n{mj_note}",
            dt_list(dts)
        ),
        log_x: true,
        pareto: true,
    }
}

fn on_front(front: &[(f64, f64)], x: f64, y: f64) -> bool {
    front.iter().any(|&(a, b)| a == x && b == y)
}

fn all_points(chart: &LogLogChart) -> Vec<(f64, f64)> {
    chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .collect()
}

/// Table of our points: method, dt, error, µs/step, run time per simulated second,
/// max joint separation, whether on the chart's Pareto front.
pub fn ours_table(md: &mut String, points: &[Point], front: &[(f64, f64)]) {
    let _ = writeln!(
        md,
        "| method | dt (s) | COM error (m) | µs / step | run time / simulated s | max joint separation (m) | front |\n|---|---|---|---|---|---|---|"
    );
    for p in points {
        match &p.outcome {
            Ok(m) => {
                let mark = if on_front(front, m.cost(), m.com_error) {
                    "◆"
                } else {
                    ""
                };
                let _ = writeln!(
                    md,
                    "| {} | {:.1e} | {:.2e} | {:.2} | {:.2e} | {:.1e} | {mark} |",
                    p.method,
                    p.dt,
                    m.com_error,
                    m.us_per_step(),
                    m.cost(),
                    m.c_max
                );
            }
            Err(e) => {
                let _ = writeln!(md, "| {} | {:.1e} | failed: {e} | | | | |", p.method, p.dt);
            }
        }
    }
}

/// Compact table of MuJoCo's points: one row per dt, "error / µs per step" per integrator.
pub fn mujoco_table(md: &mut String, mj: &[&MujocoPoint], dts: &[f64], front: &[(f64, f64)]) {
    if mj.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\n| MuJoCo: dt (s) | Euler: error (m) / µs per step | implicitfast | RK4 |\n|---|---|---|---|"
    );
    for &dt in dts {
        let cells: Vec<String> = MUJOCO_INTEGRATORS
            .iter()
            .map(|&i| {
                mj.iter()
                    .find(|p| p.integrator == i && same_dt(p.dt, dt))
                    .map_or("–".into(), |p| {
                        if p.com_error == 0.0 {
                            return format!("0 (the reference) / {:.2}", p.seconds_per_step * 1e6);
                        }
                        let mark = if on_front(front, p.cost(), p.com_error) {
                            " ◆"
                        } else {
                            ""
                        };
                        format!(
                            "{:.2e} / {:.2}{mark}",
                            p.com_error,
                            p.seconds_per_step * 1e6
                        )
                    })
            })
            .collect();
        let _ = writeln!(md, "| {dt:.1e} | {} |", cells.join(" | "));
    }
}

/// One row of the summary: a scene and an error level.
#[derive(Clone, Debug, PartialEq)]
pub struct SummaryRow {
    /// Scene.
    pub scene: &'static str,
    /// Error level (m).
    pub tol: f64,
    /// Our fastest: method, dt, run time per simulated second.
    pub ours: Option<(&'static str, f64, f64)>,
    /// MuJoCo's fastest: integrator, dt, run time per simulated second.
    pub mujoco: Option<(String, f64, f64)>,
}

/// The summary rows of one scene.
pub fn summary_rows(scene: &'static str, points: &[Point], mj: &[&MujocoPoint]) -> Vec<SummaryRow> {
    TOLERANCES
        .iter()
        .map(|&tol| SummaryRow {
            scene,
            tol,
            ours: fastest_ours(points, tol).map(|(p, m)| (p.method, p.dt, m.cost())),
            mujoco: fastest_mujoco(mj, tol).map(|p| (p.integrator.clone(), p.dt, p.cost())),
        })
        .collect()
}

/// Writes the summary table.
pub fn summary_table(md: &mut String, rows: &[SummaryRow]) {
    let _ = writeln!(
        md,
        "| scene | error ≤ (m) | ours: fastest (dt) | ours: run time / simulated s | MuJoCo: fastest (dt) | MuJoCo: run time / simulated s | ours / MuJoCo |\n|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let (om, oc) = r.ours.as_ref().map_or(("none".into(), "–".into()), |o| {
            (format!("{} ({:.1e})", o.0, o.1), format!("{:.2e}", o.2))
        });
        let (mm, mc) = r.mujoco.as_ref().map_or(("none".into(), "–".into()), |o| {
            (format!("{} ({:.1e})", o.0, o.1), format!("{:.2e}", o.2))
        });
        let ratio = match (&r.ours, &r.mujoco) {
            (Some(o), Some(m)) => format!("{:.2}", o.2 / m.2),
            _ => "–".into(),
        };
        let _ = writeln!(
            md,
            "| {} | {:.0e} | {om} | {oc} | {mm} | {mc} | {ratio} |",
            r.scene, r.tol
        );
    }
}

/// Max joint separation of chain20 over each `window` (s) of a `secs` run at `dt` with
/// `method`; on a failed step, the series so far and the reason.
pub fn chain_drift(
    method: &str,
    dt: f64,
    secs: f64,
    window: f64,
) -> (Vec<(f64, f64)>, Option<String>) {
    let path = root().join("scenes/chain20.xml");
    let mut pts = Vec::new();
    let setup = MjcfScene::from_file(&path, Some("start"))
        .map_err(|e| e.to_string())
        .and_then(|s| Ok((s, scene::method(method, dt)?)));
    let (mut sc, m) = match setup {
        Ok(v) => v,
        Err(e) => return (pts, Some(e)),
    };
    let per = (window / dt).round().max(1.0) as u64;
    let steps = (secs / dt).round() as u64;
    let mut worst: f64 = 0.0;
    for k in 1..=steps {
        if let Err(e) = sc.world.step(dt, m) {
            return (pts, Some(format!("t = {:.3} s: {e}", k as f64 * dt)));
        }
        worst = worst.max(sc.world.max_separation());
        if k % per == 0 {
            pts.push((k as f64 * dt, worst.max(1e-17)));
            worst = 0.0;
        }
    }
    (pts, None)
}

fn drift_section(md: &mut String, out: &Path, plan: &Plan) -> Result<(), String> {
    let (dt, secs) = (plan.drift_dt, plan.drift_secs);
    eprintln!("  articulated drift: chain20, {secs} s, {DRIFT_METHODS:?}");
    let _ = writeln!(md, "\n### Joint drift: chain20\n");
    let _ = writeln!(md, "![chain20 drift](articulated_chain20_drift.svg)\n");
    let _ = writeln!(
        md,
        "chain20 (20 ball-jointed capsule links) from keyframe `start`, dt = {dt} s, {secs} s; max joint \
         separation (m) over each {} s window. The acceleration level without stabilisation imposes only \
         C̈ = 0, so the errors in C and Ċ accumulate and the joints drift apart; Baumgarte feeds C and Ċ \
         back (k_x = 1/(5h)², k_v = 2/(5h)); the velocity level (J v' = −C/h) corrects C every step; the \
         projection holds it at its tolerance (1e-10 m). A run whose step fails (typed divergence error) \
         ends its series there; the note gives the time.\n",
        plan.drift_window
    );
    let _ = writeln!(
        md,
        "| method | max separation, first second (m) | max separation, whole run (m) | note |\n|---|---|---|---|"
    );
    let mut series = Vec::new();
    for &name in &DRIFT_METHODS {
        let (pts, failure) = chain_drift(name, dt, secs, plan.drift_window);
        let first = pts
            .iter()
            .filter(|p| p.0 <= 1.0 + 1e-9)
            .map(|p| p.1)
            .fold(0.0, f64::max);
        let all = pts.iter().map(|p| p.1).fold(0.0, f64::max);
        let note = failure.map_or(String::new(), |e| format!("stopped: {e}"));
        let _ = writeln!(md, "| {name} | {first:.2e} | {all:.2e} | {note} |");
        series.push(Series {
            name: name.into(),
            points: pts,
        });
    }
    let chart = LogLogChart {
        title: "chain20: joint separation over time".into(),
        x_label: "time (s)".into(),
        y_label: "max joint separation (m)".into(),
        series,
        note: format!(
            "20-link ball chain, dt = {dt} s; max over joints and over each {} s window; floor 1e-17.",
            plan.drift_window
        ),
        log_x: false,
        pareto: false,
    };
    std::fs::write(out.join("articulated_chain20_drift.svg"), chart.to_svg())
        .map_err(|e| e.to_string())
}

fn raw_csv(csv: &mut String, scene: &str, points: &[Point]) {
    for p in points {
        match &p.outcome {
            Ok(m) => {
                let _ = writeln!(
                    csv,
                    "{scene},{},{:e},{:e},{:e},{:e},",
                    p.method,
                    p.dt,
                    m.com_error,
                    m.seconds / m.steps as f64,
                    m.c_max
                );
            }
            Err(e) => {
                let _ = writeln!(
                    csv,
                    "{scene},{},{:e},,,,{}",
                    p.method,
                    p.dt,
                    e.replace(',', ";")
                );
            }
        }
    }
}

fn intro(md: &mut String, plan: &Plan, mj: &Result<MujocoPoints, String>) {
    let _ = writeln!(
        md,
        "\n## Articulated bodies: work-precision on the MJCF scenes\n"
    );
    let _ = writeln!(
        md,
        "Each scene of `scenes/` runs from keyframe `start` for {HORIZON} s with each of our methods ({}) at \
         dt = {}. Error: max over bodies and over the reference's samples (those that fall on a whole number \
         of steps) of the centre-of-mass distance to the committed MuJoCo RK4 export \
         (`scenes/reference/<scene>.csv`, RK4 at dt = 1e-5, chain100 at 1e-4). Run time: wall clock of the \
         steps alone in this run (recording rows excluded), one thread, best of up to 3 runs, per simulated \
         second. The dashed line and rings mark the Pareto front over all points (ours and MuJoCo's).\n",
        CHART_METHODS.join(", "),
        dt_list(&plan.dts)
    );
    for (name, what) in scene::METHODS {
        if CHART_METHODS.contains(&name) {
            let _ = writeln!(md, "- `{name}`: {what}");
        }
    }
    md.push('\n');
    match mj {
        Ok(m) => {
            let _ = writeln!(
                md,
                "MuJoCo's points (Euler, implicitfast, RK4 at the same dt; error against the same reference \
                 over the same samples; seconds per step inside MuJoCo's C loop via `mujoco.rollout`, best of \
                 up to 3) are read from `{MUJOCO_POINTS}`: {}. They were **not measured in this run** \
                 (regenerate with `target/mujoco-venv/bin/python scenes/reference/mujoco_points.py`, see \
                 `scenes/reference/README.md`); compare run times across the two only on the same machine kind.\n",
                m.provenance
            );
        }
        Err(e) => {
            let _ = writeln!(md, "MuJoCo's points are missing: {e}.\n");
        }
    }
}

/// Writes the whole section to `md` and its charts and `articulated_work_precision.csv`
/// to `out`.
pub fn section(md: &mut String, out: &Path, quick: bool) -> Result<(), String> {
    let plan = Plan::new(quick);
    let mj = load_mujoco_points();
    intro(md, &plan, &mj);
    let empty = MujocoPoints {
        provenance: String::new(),
        points: Vec::new(),
    };
    let mjp = mj.as_ref().unwrap_or(&empty);
    let mut summary = Vec::new();
    let mut csv = String::from("scene,method,dt,com_error_m,seconds_per_step,c_max_m,failure\n");
    for &scene in &plan.scenes {
        let t0 = std::time::Instant::now();
        let pts = sweep_scene(scene, &plan.dts)?;
        eprintln!(
            "  articulated work-precision: {scene}, {} points in {:.1} s",
            pts.len(),
            t0.elapsed().as_secs_f64()
        );
        let theirs = mujoco_for(mjp, scene, &plan.dts);
        let chart = scene_chart(scene, &pts, &theirs, &mjp.provenance, &plan.dts);
        let front = pareto_front(&all_points(&chart));
        let file = format!("articulated_{scene}.svg");
        std::fs::write(out.join(&file), chart.to_svg()).map_err(|e| e.to_string())?;
        let _ = writeln!(md, "### {scene}\n\n![{scene} work-precision]({file})\n");
        ours_table(md, &pts, &front);
        mujoco_table(md, &theirs, &plan.dts, &front);
        md.push('\n');
        raw_csv(&mut csv, scene, &pts);
        summary.extend(summary_rows(scene, &pts, &theirs));
    }
    std::fs::write(out.join("articulated_work_precision.csv"), csv).map_err(|e| e.to_string())?;
    let _ = writeln!(md, "### Summary: fastest method reaching an error level\n");
    let _ = writeln!(
        md,
        "Per scene and error level, the fastest of our methods (at the dt above) whose error is at or below \
         the level, and MuJoCo's fastest for the same level (\"none\": no point of the sweep reaches it). \
         The lecture's methods (velocity, projected, shake, baumgarte) are first order, the error falling \
         like dt, so they reach 1e-6 m at none of these steps; only the second-order `rattle` and the \
         fourth-order `rattle4` can. MuJoCo's run times come from the committed CSV, not this run. Last column: our run time over MuJoCo's (< 1: ours \
         faster).\n"
    );
    summary_table(md, &summary);
    drift_section(md, out, &plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_every_finds_a_common_multiple() {
        assert_eq!(sample_every(1e-3, 0.01), 10);
        assert_eq!(sample_every(4e-3, 0.01), 5);
        assert_eq!(sample_every(2.5e-4, 0.04), 160);
        assert_eq!(sample_every(4e-3, 0.1), 25);
        assert_eq!(sample_every(1e-4, 0.1), 1000);
    }

    #[test]
    fn mujoco_points_parse_and_reject_bad_input() {
        let text = "# mujoco 4.0.0, measured 2026-01-01 on a box; regenerate: x\n\
                    scene,integrator,dt,com_error_m,angle_error_rad,seconds_per_step\n\
                    pendulum,euler,0.001,0.0015,0.0015,1e-6\n";
        let m = parse_mujoco_points(text).unwrap();
        assert_eq!(m.provenance, "mujoco 4.0.0, measured 2026-01-01 on a box");
        assert_eq!(m.points.len(), 1);
        assert!((m.points[0].cost() - 1e-3).abs() < 1e-15);
        assert!(parse_mujoco_points("a,b\n").is_err());
        assert!(parse_mujoco_points(&format!("{MUJOCO_HEADER}\nx,y,1\n"))
            .unwrap_err()
            .starts_with("line 2"));
    }

    #[test]
    fn committed_mujoco_points_cover_every_scene_integrator_and_dt() {
        let m = load_mujoco_points().unwrap();
        assert!(m.provenance.starts_with("mujoco 4.0.0, measured "));
        for scene in scenes() {
            let pts = mujoco_for(&m, scene, &FULL_DTS);
            assert_eq!(pts.len(), 3 * FULL_DTS.len(), "{scene}");
            assert!(pts
                .iter()
                .all(|p| p.seconds_per_step > 0.0 && p.com_error >= 0.0));
        }
    }

    #[test]
    fn fastest_picks_cheapest_point_under_the_level() {
        let mk = |method, dt, err, secs| Point {
            method,
            dt,
            outcome: Ok(Measured {
                com_error: err,
                seconds: secs,
                steps: 10,
                c_max: 0.0,
                repeats: 1,
            }),
        };
        let pts = vec![
            mk("velocity", 1e-3, 2e-3, 0.1),
            mk("velocity", 1e-4, 2e-4, 1.0),
            mk("projected", 1e-3, 5e-4, 0.3),
            Point {
                method: "shake",
                dt: 1e-3,
                outcome: Err("diverged".into()),
            },
        ];
        let (p, m) = fastest_ours(&pts, 1e-3).unwrap();
        assert_eq!((p.method, m.seconds), ("projected", 0.3));
        assert!(fastest_ours(&pts, 1e-6).is_none());
    }

    #[test]
    fn pendulum_point_is_first_order_accurate_and_timed() {
        let r = load_reference("pendulum").unwrap();
        let p = measure("pendulum", "velocity", 1e-3, &r);
        let m = p.outcome.unwrap();
        // Measured 1.50e-3 m (verify/tests/mujoco_reference.rs gates the same number).
        assert!(m.com_error > 1e-3 && m.com_error < 2e-3, "{}", m.com_error);
        assert!(m.seconds > 0.0 && m.steps == 1000 && m.repeats >= 1);
    }
}
