//! The MJCF scenes of `scenes/*.xml`, this library against MuJoCo, for `cargo xtask bench`.
//!
//! Runs `cargo bench -p constraint-peers --bench mjcf_scenes` (criterion: one iteration
//! is the first simulated second of a scene from its keyframe at the file's time step,
//! with `Method::Velocity { beta: 1 }` and RATTLE on the articulated scenes, the contact
//! world's defaults on the contact ones), which also writes
//! `target/peers/mjcf_scenes.tsv` (scene, engine, dt, step count, keyframe, outcome of an
//! untimed run of the same window). Then MuJoCo runs each scene listed there through
//! [`crate::mujoco::run`] with the same dt, step count and keyframe, Euler, and times the
//! same window in its C loop (`mujoco.rollout`). [`markdown`] is the section of
//! `target/bench/ratios.md`.

use crate::bench::{estimate, fmt_ratio, fmt_time, Timing};
use crate::mujoco::{run as run_mujoco, RunOptions};
use crate::run::{cargo, root};
use std::fmt::Write as _;

/// One line of `target/peers/mjcf_scenes.tsv`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row {
    pub scene: String,
    /// `articulated` or `contact`.
    pub kind: String,
    /// `ours_velocity`, `ours_rattle`, `ours_auto`.
    pub engine: String,
    pub bodies: usize,
    /// The time step as written (`1e-3`), passed to MuJoCo as is.
    pub dt: String,
    pub steps: usize,
    pub keyframe: Option<String>,
    /// `ok` or `failed at t = …: …`.
    pub status: String,
    pub fallbacks: usize,
    pub separation: Option<f64>,
    pub contacts: Option<usize>,
}

/// Parses `target/peers/mjcf_scenes.tsv` (header line first; columns found by name).
pub fn parse_tsv(text: &str) -> Result<Vec<Row>, String> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("empty file")?.split('\t').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or(format!("no column {name:?}"))
    };
    let (scene, kind, engine, bodies) =
        (col("scene")?, col("kind")?, col("engine")?, col("bodies")?);
    let (dt, steps, keyframe, status) =
        (col("dt")?, col("steps")?, col("keyframe")?, col("status")?);
    let (fallbacks, separation, contacts) =
        (col("fallbacks")?, col("separation")?, col("contacts")?);
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() < header.len() {
            return Err(format!("line {}: {} fields", i + 2, f.len()));
        }
        let num = |k: usize| {
            f[k].parse::<usize>()
                .map_err(|_| format!("line {}: {:?} is not a count", i + 2, f[k]))
        };
        rows.push(Row {
            scene: f[scene].to_string(),
            kind: f[kind].to_string(),
            engine: f[engine].to_string(),
            bodies: num(bodies)?,
            dt: f[dt].to_string(),
            steps: num(steps)?,
            keyframe: (f[keyframe] != "-").then(|| f[keyframe].to_string()),
            status: f[status].to_string(),
            fallbacks: num(fallbacks)?,
            separation: f[separation].parse().ok(),
            contacts: f[contacts].parse().ok(),
        });
    }
    Ok(rows)
}

/// MuJoCo's side of one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct MujocoTime {
    pub scene: String,
    pub seconds_per_step: f64,
    pub steps: usize,
}

/// What the comparison measured.
#[derive(Default)]
pub struct MjcfResults {
    pub rows: Vec<Row>,
    /// `(engine, scene) → s/step`, ours (criterion median of the window / steps).
    pub ours: Vec<(String, String, f64)>,
    pub mujoco: Vec<MujocoTime>,
    pub mujoco_version: Option<String>,
    /// Whether MuJoCo was asked to run (false with `--no-mujoco`).
    pub mujoco_run: bool,
    pub notes: Vec<String>,
}

impl MjcfResults {
    fn ours(&self, engine: &str, scene: &str) -> Option<f64> {
        self.ours
            .iter()
            .find(|(e, s, _)| e == engine && s == scene)
            .map(|t| t.2)
    }

    fn row(&self, engine: &str, scene: &str) -> Option<&Row> {
        self.rows
            .iter()
            .find(|r| r.engine == engine && r.scene == scene)
    }

    fn mujoco(&self, scene: &str) -> Option<f64> {
        self.mujoco
            .iter()
            .find(|m| m.scene == scene)
            .map(|m| m.seconds_per_step)
    }

    /// Scenes in file order, each once, with the first row that names it.
    fn scenes(&self, kind: &str) -> Vec<&Row> {
        let mut out: Vec<&Row> = Vec::new();
        for r in &self.rows {
            if r.kind == kind && !out.iter().any(|o| o.scene == r.scene) {
                out.push(r);
            }
        }
        out
    }
}

/// Runs the bench, reads its file and estimates, then MuJoCo on every scene (unless
/// `mujoco` is false).
pub fn run(criterion_args: &[String], mujoco: bool) -> Result<MjcfResults, String> {
    let tsv = root().join("target/peers/mjcf_scenes.tsv");
    // A stale file must not pass for this run's.
    let _ = std::fs::remove_file(&tsv);
    let ok = cargo()
        .args([
            "bench",
            "-p",
            "constraint-peers",
            "--bench",
            "mjcf_scenes",
            "--",
        ])
        .args(criterion_args)
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return Err("cargo bench -p constraint-peers --bench mjcf_scenes failed".into());
    }
    let text = std::fs::read_to_string(&tsv).map_err(|e| format!("{}: {e}", tsv.display()))?;
    let mut res = MjcfResults {
        rows: parse_tsv(&text).map_err(|e| format!("{}: {e}", tsv.display()))?,
        mujoco_run: mujoco,
        ..MjcfResults::default()
    };
    for r in &res.rows {
        if r.status != "ok" || r.steps == 0 {
            continue;
        }
        if let Some(t) = estimate("mjcf_scenes", &r.engine, &r.scene) {
            res.ours
                .push((r.engine.clone(), r.scene.clone(), t / r.steps as f64));
        }
    }
    if mujoco {
        mujoco_scenes(&mut res);
    }
    Ok(res)
}

/// MuJoCo, Euler, on every scene of `res.rows`: the same window (dt, steps, keyframe).
fn mujoco_scenes(res: &mut MjcfResults) {
    let dir = root().join("target/peers/mjcf_scenes");
    let mut scenes: Vec<Row> = Vec::new();
    for r in &res.rows {
        if !scenes.iter().any(|s| s.scene == r.scene) {
            scenes.push(r.clone());
        }
    }
    for r in scenes {
        let Ok(dt) = r.dt.parse::<f64>() else {
            res.notes
                .push(format!("MuJoCo {}: bad dt {:?}", r.scene, r.dt));
            continue;
        };
        let duration = format!("{}", r.steps as f64 * dt);
        eprintln!(
            "xtask: MuJoCo Euler dt {}, {}: {} steps from {} (timed by mujoco.rollout)",
            r.dt,
            r.scene,
            r.steps,
            r.keyframe.as_deref().unwrap_or("the default pose")
        );
        let timing = dir.join(format!("{}.timing.json", r.scene));
        let _ = std::fs::remove_file(&timing);
        let out = run_mujoco(&RunOptions {
            scene: root().join("scenes").join(format!("{}.xml", r.scene)),
            keyframe: r.keyframe.clone(),
            dt: Some(r.dt.clone()),
            duration,
            every: r.steps.max(1),
            integrator: Some("euler".into()),
            out: dir.join(format!("{}.csv", r.scene)),
            timing: Some(timing.clone()),
            ..RunOptions::default()
        })
        .and_then(|()| {
            std::fs::read_to_string(&timing).map_err(|e| format!("{}: {e}", timing.display()))
        });
        match out {
            Ok(text) => {
                let timing = Timing::parse(&text);
                let steps = timing.steps;
                match timing.seconds_per_step {
                    Some(t) if steps == Some(r.steps) => {
                        eprintln!("  {}: {t:.3e} s/step", r.scene);
                        res.mujoco.push(MujocoTime {
                            scene: r.scene.clone(),
                            seconds_per_step: t,
                            steps: r.steps,
                        });
                        if res.mujoco_version.is_none() {
                            res.mujoco_version = timing.mujoco_version.clone();
                        }
                    }
                    Some(_) => res.notes.push(format!(
                        "MuJoCo {}: timed {steps:?} steps, ours {}; left out",
                        r.scene, r.steps
                    )),
                    None => res
                        .notes
                        .push(format!("MuJoCo {}: no seconds_per_step", r.scene)),
                }
            }
            Err(e) => {
                eprintln!("xtask: MuJoCo {} failed: {e}", r.scene);
                res.notes.push(format!("MuJoCo {} failed: {e}", r.scene));
            }
        }
    }
}

/// Our time per step, or why there is none.
fn ours_cell(res: &MjcfResults, engine: &str, scene: &str) -> String {
    match res.row(engine, scene) {
        Some(r) if r.status != "ok" => r.status.clone(),
        Some(_) => fmt_time(res.ours(engine, scene)),
        None => "–".into(),
    }
}

fn fmt_dt(dt: &str) -> String {
    dt.parse::<f64>().map_or(dt.to_string(), |d| format!("{d}"))
}

fn fmt_sep(s: Option<f64>) -> String {
    s.map_or("–".into(), |s| format!("{s:.1e} m"))
}

/// The section of `target/bench/ratios.md`.
pub fn markdown(res: &MjcfResults) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "\n# MJCF scenes: time per step, this library against MuJoCo\n\n\
         Same run. Every scene of `scenes/*.xml`, loaded from the same file by both \
         engines, started from its keyframe `start` (box_stack, which has none: the \
         default pose at rest, as MuJoCo does), stepped at the file's `option timestep` \
         for the first simulated second; time per step is the time of that window divided \
         by its step count, one core. **Ours**: a criterion bench (`cargo bench -p \
         constraint-peers --bench mjcf_scenes`; one iteration is the whole window from a \
         fresh copy of the initial state, the copy untimed; median of the iterations). \
         **MuJoCo**: the same window in its C loop (`mujoco.rollout` from the same \
         initial state), Euler at the same dt, best of at least 3 rollouts. A ratio below \
         1 means this library is faster.\n"
    );
    let _ = writeln!(md, "## Articulated scenes\n");
    let _ = writeln!(
        md,
        "| scene | bodies | dt (s) | ours, velocity level | ours, RATTLE | MuJoCo (Euler) | \
         velocity / MuJoCo | RATTLE / MuJoCo | joint separation at 1 s, velocity / RATTLE |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut fallbacks = Vec::new();
    for r in res.scenes("articulated") {
        let s = r.scene.as_str();
        let (v, ra, m) = (
            res.ours("ours_velocity", s),
            res.ours("ours_rattle", s),
            res.mujoco(s),
        );
        let sep = |e: &str| fmt_sep(res.row(e, s).and_then(|r| r.separation));
        if let Some(f) = res.row("ours_rattle", s).filter(|r| r.fallbacks > 0) {
            fallbacks.push(format!("{s}: {} of {}", f.fallbacks, f.steps));
        }
        let _ = writeln!(
            md,
            "| {s} | {} | {} | {} | {} | {} | {} | {} | {} / {} |",
            r.bodies,
            fmt_dt(&r.dt),
            ours_cell(res, "ours_velocity", s),
            ours_cell(res, "ours_rattle", s),
            fmt_time(m),
            fmt_ratio(v, m),
            fmt_ratio(ra, m),
            sep("ours_velocity"),
            sep("ours_rattle"),
        );
    }
    let _ = writeln!(md, "\n## Contact scenes\n");
    let _ = writeln!(
        md,
        "| scene | bodies | dt (s) | ours (Auto) | MuJoCo (Euler) | ours / MuJoCo | most contact points (ours) |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|");
    for r in res.scenes("contact") {
        let s = r.scene.as_str();
        let (o, m) = (res.ours("ours_auto", s), res.mujoco(s));
        let _ = writeln!(
            md,
            "| {s} | {} | {} | {} | {} | {} | {} |",
            r.bodies,
            fmt_dt(&r.dt),
            ours_cell(res, "ours_auto", s),
            fmt_time(m),
            fmt_ratio(o, m),
            res.row("ours_auto", s)
                .and_then(|r| r.contacts)
                .map_or("–".into(), |c| c.to_string()),
        );
    }
    let _ = writeln!(md, "\n## Notes (MJCF scenes)\n");
    let mut notes = vec![
        "Ours, articulated (`constraint_articulated::MjcfScene`, maximal coordinates): \
         velocity level is `Method::Velocity { beta: 1 }`, first order like MuJoCo's \
         semi-implicit Euler (the like-for-like column); RATTLE is `Method::default()` \
         (second order, SHAKE projection to 1e-12 m, at most 30 Newton iterations), \
         the accurate one (its trajectory errors against MuJoCo RK4 are in the verify \
         report). Joint separation: the largest distance between a joint's two anchors \
         after the timed window, from an untimed run of it; MuJoCo's tree joints cannot \
         separate (reduced coordinates), its four_bar loop closure is a soft `connect`."
            .to_string(),
        "Ours, contact (`constraint_articulated::mjcf_contact::MjcfContactScene`): free bodies, hard \
         contact, default `ContactSettings` (`ContactSolver::Auto`: dense \
         Fischer–Burmeister Newton at these sizes). MuJoCo's contact is soft (`solref`, \
         `solimp`), so the two engines solve different problems on the same scene; the \
         window holds the sphere's fall and impact, the box's slide to rest, the stack at \
         rest."
            .to_string(),
    ];
    if !fallbacks.is_empty() {
        notes.push(format!(
            "RATTLE steps redone at the velocity level (projection did not converge): {}.",
            fallbacks.join(", ")
        ));
    }
    if res.mujoco_run {
        notes.push(format!(
            "MuJoCo {} (PyPI, `cargo xtask mujoco`'s pinned virtual environment), \
             `mjINT_EULER`; a rollout is one Python call, whose overhead (tens of µs) is \
             in its time: a few per cent of the 1000-step window of the smallest scenes.",
            res.mujoco_version.as_deref().unwrap_or("?")
        ));
    } else {
        notes.push("MuJoCo skipped (--no-mujoco).".into());
    }
    notes.extend(res.notes.iter().cloned());
    for n in notes {
        let _ = writeln!(md, "- {n}");
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    const TSV: &str = "scene\tkind\tengine\tbodies\tdt\tsteps\tkeyframe\tstatus\tfallbacks\tseparation\tcontacts\n\
        pendulum\tarticulated\tours_velocity\t1\t1e-3\t1000\tstart\tok\t0\t1.6e-7\t-\n\
        pendulum\tarticulated\tours_rattle\t1\t1e-3\t1000\tstart\tok\t0\t1.9e-14\t-\n\
        chain20_heavy\tarticulated\tours_velocity\t20\t1e-3\t1000\tstart\tok\t0\t7.7e-7\t-\n\
        chain20_heavy\tarticulated\tours_rattle\t20\t1e-3\t1000\tstart\tfailed at t = 0.5000 s: diverged\t3\t-\t-\n\
        box_stack\tcontact\tours_auto\t5\t2e-3\t500\t-\tok\t0\t-\t20\n";

    #[test]
    fn parses_the_bench_file() {
        let rows = parse_tsv(TSV).unwrap();
        assert_eq!(rows.len(), 5);
        assert_eq!(rows[4].keyframe, None);
        assert_eq!(rows[4].contacts, Some(20));
        assert_eq!(rows[4].steps, 500);
        assert_eq!(rows[0].keyframe.as_deref(), Some("start"));
        assert_eq!(rows[1].separation, Some(1.9e-14));
        assert_eq!(rows[3].fallbacks, 3);
        assert!(parse_tsv("scene\tkind\n").is_err());
    }

    #[test]
    fn the_tables_have_times_ratios_and_failures() {
        let mut res = MjcfResults {
            rows: parse_tsv(TSV).unwrap(),
            mujoco_run: true,
            mujoco_version: Some("4.0.0".into()),
            ..MjcfResults::default()
        };
        res.ours
            .push(("ours_velocity".into(), "pendulum".into(), 0.5e-6));
        res.ours
            .push(("ours_rattle".into(), "pendulum".into(), 2e-6));
        res.ours
            .push(("ours_auto".into(), "box_stack".into(), 30e-6));
        for (scene, t) in [("pendulum", 1e-6), ("box_stack", 10e-6)] {
            res.mujoco.push(MujocoTime {
                scene: scene.into(),
                seconds_per_step: t,
                steps: 1000,
            });
        }
        let md = markdown(&res);
        assert!(
            md.contains(
                "| pendulum | 1 | 0.001 | 0.50 µs | 2.00 µs | 1.00 µs | 0.500 | 2.000 | 1.6e-7 m / 1.9e-14 m |"
            ),
            "{md}"
        );
        assert!(
            md.contains(
                "| chain20_heavy | 20 | 0.001 | – | failed at t = 0.5000 s: diverged | – |"
            ),
            "{md}"
        );
        assert!(
            md.contains("| box_stack | 5 | 0.002 | 30.00 µs | 10.00 µs | 3.000 | 20 |"),
            "{md}"
        );
        assert!(md.contains("chain20_heavy: 3 of 1000"), "{md}");
        assert!(md.contains("MuJoCo 4.0.0"), "{md}");
    }
}
