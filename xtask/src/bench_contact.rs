//! MuJoCo on the contact scenes of `cargo xtask bench`, and the accuracy-against-time
//! charts of those scenes.
//!
//! The contact_peers bench writes each box scene as MJCF
//! (`target/peers/contact_mjcf/SCENE.xml`: the same bodies at the same poses, MuJoCo's
//! defaults); the sliding box is `scenes/sliding_box.xml`. [`run_mujoco`] runs each in
//! MuJoCo ([`crate::mujoco::run`], `--timing`) for the accuracy run's 10 s at each of
//! its [`Setting`]s and reads the same figures as the bench's accuracy runs from the
//! trajectory ([`accuracy_from_csv`]): the top box's drift and sink, the worst
//! displacement, the top box's horizontal travel. [`points_tsv`] and [`draw_charts`]
//! turn a run's times and errors into one chart per scene (`verify-report
//! --contact-points`, the report crate's chart writer).

use crate::mujoco::{run as run_mujoco_scene, RunOptions};
use crate::run::{cargo, root};
use std::fmt::Write as _;
use std::path::Path;

/// Length of the accuracy runs (s), as the bench's.
pub(crate) const DURATION: f64 = 10.0;

/// The sliding box's exact stopping distance `v²/(2μg)` (m): 3 m/s, μ 0.5, g 9.81.
pub(crate) const SLIDE_EXACT: f64 = 9.0 / (2.0 * 0.5 * 9.81);

/// One MuJoCo setting: engine id (in `ratios.md` and the points file), label, time step
/// as passed to MuJoCo, steps per trajectory row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Setting {
    pub engine: &'static str,
    pub label: &'static str,
    pub dt: &'static str,
    pub every: usize,
}

impl Setting {
    /// The time step (s).
    pub fn dt(&self) -> f64 {
        self.dt.parse().unwrap_or(f64::NAN)
    }
}

/// MuJoCo's settings on the box scenes: its defaults at the scene's dt = 1/60, and the
/// same at 1/240 (four steps per 1/60 s).
pub(crate) const BOX_SETTINGS: [Setting; 2] = [
    Setting {
        engine: "mujoco",
        label: "MuJoCo (defaults, dt = 1/60)",
        dt: "0.016666666666666666",
        every: 1,
    },
    Setting {
        engine: "mujoco_240hz",
        label: "MuJoCo (defaults, dt = 1/240)",
        dt: "0.004166666666666667",
        every: 4,
    },
];

/// MuJoCo's settings on `scenes/sliding_box.xml`: the scene's dt = 1/60 and the file's
/// own 1 ms.
pub(crate) const SLIDE_SETTINGS: [Setting; 2] = [
    Setting {
        engine: "mujoco",
        label: "MuJoCo (sliding_box.xml, dt = 1/60)",
        dt: "0.016666666666666666",
        every: 1,
    },
    Setting {
        engine: "mujoco_1khz",
        label: "MuJoCo (sliding_box.xml, dt = 1 ms)",
        dt: "1e-3",
        every: 10,
    },
];

/// The figures of one trajectory, as the bench's accuracy runs measure them on box
/// centres (body origins).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Figures {
    /// Largest distance of the top body (highest at the start) from its start (m).
    pub top_drift: f64,
    /// Start height minus final height of the top body (m).
    pub top_sink: f64,
    /// Largest distance of any body from its start, over bodies and rows (m).
    pub worst_displacement: f64,
    /// Horizontal distance of the top body from its start at the end (m).
    pub top_travel: f64,
}

/// Reads a trajectory of `cargo xtask mujoco` (`t`, then `<body>.x,<body>.y,<body>.z`
/// among other columns per body) into [`Figures`]. Bodies are the names with all three
/// columns; a file without bodies or rows, a short row or a value that is not a finite
/// number is an error.
pub(crate) fn accuracy_from_csv(text: &str) -> Result<Figures, String> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines.next().ok_or("empty trajectory")?.split(',').collect();
    let mut bodies: Vec<[usize; 3]> = Vec::new();
    for (i, h) in header.iter().enumerate() {
        let Some(name) = h.strip_suffix(".x") else {
            continue;
        };
        let find = |c: &str| header.iter().position(|k| *k == format!("{name}.{c}"));
        if let (Some(y), Some(z)) = (find("y"), find("z")) {
            bodies.push([i, y, z]);
        }
    }
    if bodies.is_empty() {
        return Err("no body columns (<body>.x, .y, .z)".into());
    }
    let mut start: Vec<[f64; 3]> = Vec::new();
    let mut last: Vec<[f64; 3]> = Vec::new();
    let mut top = 0;
    let mut f = Figures::default();
    for (n, line) in lines.enumerate() {
        let v: Vec<&str> = line.split(',').collect();
        let mut x = Vec::with_capacity(bodies.len());
        for cols in &bodies {
            let mut p = [0.0; 3];
            for (slot, &c) in p.iter_mut().zip(cols) {
                *slot = v
                    .get(c)
                    .and_then(|s| s.trim().parse::<f64>().ok())
                    .filter(|s| s.is_finite())
                    .ok_or_else(|| {
                        format!("row {}: column {} is not a finite number", n + 2, c + 1)
                    })?;
            }
            x.push(p);
        }
        if start.is_empty() {
            // The top body: the highest at the start, the first of equals.
            for (i, p) in x.iter().enumerate() {
                if p[2] > x[top][2] {
                    top = i;
                }
            }
            start = x.clone();
        }
        for (i, (p, p0)) in x.iter().zip(&start).enumerate() {
            let d = dist(*p, *p0);
            f.worst_displacement = f.worst_displacement.max(d);
            if i == top {
                f.top_drift = f.top_drift.max(d);
            }
        }
        last = x;
    }
    if last.is_empty() {
        return Err("no rows".into());
    }
    let (a, b) = (last[top], start[top]);
    f.top_sink = b[2] - a[2];
    f.top_travel = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    Ok(f)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The figure a scene's chart plots (m): the top box's drift on the stack and the heavy
/// box, the worst displacement on the pyramid, `|travel − v²/(2μg)|` on the sliding box
/// (`None` without the travel). The same choice as `constraint_peers::contact::Scene::error`.
pub(crate) fn scene_error(
    scene: &str,
    top_drift: f64,
    worst: f64,
    top_travel: Option<f64>,
) -> Option<f64> {
    match scene {
        "pyramid20" => Some(worst),
        "sliding_box" => top_travel.map(|t| (t - SLIDE_EXACT).abs()),
        _ => Some(top_drift),
    }
}

/// What the y axis of a scene's chart is.
pub(crate) fn error_label(scene: &str) -> &'static str {
    match scene {
        "pyramid20" => "worst box displacement, max over 10 s (m)",
        "sliding_box" => "stopping distance error |d − v²/(2μg)| (m)",
        "heavy1e4" => "heavy box drift, max over 10 s (m)",
        _ => "top-box drift, max over 10 s (m)",
    }
}

/// One MuJoCo run's outcome on a scene.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MujocoPoint {
    pub scene: String,
    pub setting: Setting,
    /// MuJoCo's time for 1/60 s of simulation (its steps per 1/60 s), in its C loop (s).
    pub seconds_per_60hz_step: f64,
    pub figures: Figures,
}

/// Runs every contact scene in MuJoCo at each of its settings; points and notes (a
/// missing file or a failed run is a note).
pub(crate) fn run_mujoco() -> (Vec<MujocoPoint>, Vec<String>) {
    let mut points = Vec::new();
    let mut notes = Vec::new();
    if let Err(e) = crate::mujoco::ensure_venv() {
        notes.push(format!("MuJoCo skipped on the contact scenes: {e}"));
        return (points, notes);
    }
    let dir = root().join("target/peers/contact_mjcf");
    let runs: Vec<(&str, std::path::PathBuf, &[Setting])> = vec![
        ("stack10", dir.join("stack10.xml"), &BOX_SETTINGS),
        ("pyramid20", dir.join("pyramid20.xml"), &BOX_SETTINGS),
        ("heavy1e4", dir.join("heavy1e4.xml"), &BOX_SETTINGS),
        (
            "sliding_box",
            root().join("scenes/sliding_box.xml"),
            &SLIDE_SETTINGS,
        ),
    ];
    let mut version = None;
    for (scene, xml, settings) in runs {
        if !xml.exists() {
            notes.push(format!(
                "MuJoCo not run on {scene}: {} missing (written by the contact_peers bench)",
                xml.display()
            ));
            continue;
        }
        for s in settings {
            let stem = format!("{scene}.{}", s.engine);
            let (csv, timing) = (
                dir.join(format!("{stem}.csv")),
                dir.join(format!("{stem}.timing.json")),
            );
            eprintln!("xtask: MuJoCo {scene}, {}", s.label);
            let res = run_mujoco_scene(&RunOptions {
                scene: xml.clone(),
                keyframe: Some("start".into()),
                dt: Some(s.dt.into()),
                duration: format!("{DURATION}"),
                every: s.every,
                integrator: None,
                out: csv.clone(),
                timing: Some(timing.clone()),
                ..RunOptions::default()
            })
            .and_then(|()| {
                let t = std::fs::read_to_string(&timing)
                    .map_err(|e| format!("{}: {e}", timing.display()))?;
                let t = crate::bench::Timing::parse(&t);
                let c =
                    std::fs::read_to_string(&csv).map_err(|e| format!("{}: {e}", csv.display()))?;
                let f = accuracy_from_csv(&c).map_err(|e| format!("{}: {e}", csv.display()))?;
                let sps = t.seconds_per_step.ok_or("no seconds_per_step")?;
                version = version.clone().or(t.mujoco_version);
                Ok((sps, f))
            });
            match res {
                Ok((sps, figures)) => points.push(MujocoPoint {
                    scene: scene.into(),
                    setting: *s,
                    seconds_per_60hz_step: sps * (1.0 / 60.0) / s.dt(),
                    figures,
                }),
                Err(e) => notes.push(format!("MuJoCo {scene} ({}): {e}", s.label)),
            }
        }
    }
    notes.push(format!(
        "MuJoCo {} (PyPI) on the contact scenes: its contacts are soft (a spring–damper \
         `solref` 0.02 1, `solimp` defaults; the sliding box's file sets `solref` 0.005 1 \
         and the pyramidal cone), so a resting box sinks into its support by design. Box \
         scenes: MJCF written from our scenes by the contact_peers bench \
         (`target/peers/contact_mjcf/`: the same boxes, masses, poses and friction 0.5), \
         MuJoCo's defaults (Euler, Newton solver, pyramidal cone, 100 iterations, \
         tolerance 1e-8) at dt = 1/60 and at dt = 1/240; the sliding box \
         `scenes/sliding_box.xml` at dt = 1/60 and at its own 1 ms. Each runs 10 s from \
         the start (figures from the trajectory sampled at 60 Hz, 100 Hz for 1 ms); the \
         time is MuJoCo's C loop over the same 10 s (`mujoco.rollout`, best of at least 3) \
         per 1/60 s of simulation (4 steps at 1/240, 16.7 at 1 ms), where ours and \
         rapier3d are timed on one step after 1 s of warm-up. With MuJoCo's default \
         `margin` 0, two boxes that touch exactly make no contact until they overlap, so \
         at the start the boxes above the bottom one fall together and the stack is \
         compressed from below one contact at a time: on the 10-box stack at dt = 1/60 \
         the top box drops 0.12 m in the first 0.15 s and comes back to within 4 mm, \
         which is its drift; a smaller step shortens that fall (dt = 1/240).",
        version.as_deref().unwrap_or("?")
    ));
    (points, notes)
}

/// One row of the points file: scene, engine group, setting label, time, error.
pub(crate) type PointRow = (String, &'static str, String, f64, f64);

/// The points file `verify-report --contact-points` reads: a header of
/// `constraint_report::peer_points::COLUMNS`, one line per row with a scene label from
/// `scene_label`.
pub(crate) fn points_tsv(rows: &[PointRow], scene_label: impl Fn(&str) -> String) -> String {
    let mut s =
        String::from("scene\tscene_label\ty_label\tengine\tsetting\tseconds_per_step\terror\n");
    for (scene, engine, setting, t, e) in rows {
        let _ = writeln!(
            s,
            "{scene}\t{}\t{}\t{engine}\t{setting}\t{t:e}\t{e:e}",
            scene_label(scene),
            error_label(scene)
        );
    }
    s
}

/// Draws one chart per scene of `tsv` into `dir` with the report crate's chart writer
/// (`cargo run --release -p constraint-report --bin verify-report -- --contact-points`);
/// returns `(scene, file)` per chart and the notes it printed.
pub(crate) fn draw_charts(tsv: &Path, dir: &Path, note: &str) -> Result<ChartList, String> {
    let out = cargo()
        .args([
            "run",
            "--release",
            "-q",
            "-p",
            "constraint-report",
            "--bin",
            "verify-report",
            "--",
            "--contact-points",
        ])
        .arg(tsv)
        .arg(dir)
        .arg(note)
        .output()
        .map_err(|e| format!("cargo run verify-report: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "verify-report --contact-points failed: {}",
            crate::mujoco::last_line(&out)
        ));
    }
    Ok(parse_chart_list(&String::from_utf8_lossy(&out.stdout)))
}

/// The charts drawn, `(scene, file)` each, and the notes about points left off.
pub(crate) type ChartList = (Vec<(String, String)>, Vec<String>);

/// The lines `verify-report --contact-points` prints: `scene\tfile` per chart,
/// `note\t…` per note.
pub(crate) fn parse_chart_list(text: &str) -> ChartList {
    let mut files = Vec::new();
    let mut notes = Vec::new();
    for line in text.lines() {
        match line.split_once('\t') {
            Some(("note", n)) => notes.push(n.to_string()),
            Some((scene, file)) if file.ends_with(".svg") => {
                files.push((scene.to_string(), file.to_string()))
            }
            _ => {}
        }
    }
    (files, notes)
}

/// One MuJoCo run of the verification report's contact charts, as `verify-report
/// --contact-mjcf` prints it: `id\txml\tdt\tduration`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ReportRun {
    pub scene: String,
    pub xml: std::path::PathBuf,
    /// As printed (passed to MuJoCo as is).
    pub dt: String,
    pub duration: String,
}

/// Parses the lines of `verify-report --contact-mjcf`; a line that is not four fields
/// with a positive step is an error naming it.
pub(crate) fn parse_report_runs(text: &str) -> Result<Vec<ReportRun>, String> {
    let mut runs = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split('\t').collect();
        let ok = f.len() == 4
            && f[2].parse::<f64>().is_ok_and(|d| d > 0.0 && d.is_finite())
            && f[3].parse::<f64>().is_ok_and(|d| d > 0.0 && d.is_finite());
        if !ok {
            return Err(format!("not a run line: {line:?}"));
        }
        runs.push(ReportRun {
            scene: f[0].into(),
            xml: f[1].into(),
            dt: f[2].into(),
            duration: f[3].into(),
        });
    }
    Ok(runs)
}

/// The report's error for scene id `scene` (its charts' y): the top box's largest
/// displacement on a stack, the largest of any box on a pyramid, the stopping-distance
/// error on the sliding box.
fn report_error(scene: &str, f: &Figures) -> f64 {
    if scene.starts_with("pyramid") {
        f.worst_displacement
    } else if scene == "sliding_box" {
        (f.top_travel - SLIDE_EXACT).abs()
    } else {
        f.top_drift
    }
}

/// For `cargo xtask verify`: other engines' points on the report's contact scene charts,
/// written to `out/contact_peers.tsv`: MuJoCo on the runs `verify_report --contact-mjcf`
/// lists (`full`: the dense plan), and rapier3d's stack of 10 and sliding box from an
/// earlier `cargo xtask bench` (`target/peers/contact_accuracy.tsv` and criterion's
/// estimates) when there is one. Returns the file (when written) and a note for the
/// report saying what is on the charts and why anything is missing. Nothing here fails
/// the stage.
pub(crate) fn verify_points(
    verify_report: &Path,
    full: bool,
    out: &Path,
) -> (Option<std::path::PathBuf>, String) {
    let t0 = std::time::Instant::now();
    let dir = out.join("contact_mujoco");
    let mut rows: Vec<(String, &'static str, String, f64, f64, f64)> = Vec::new();
    let mut notes = Vec::new();
    let mut cmd = std::process::Command::new(verify_report);
    cmd.current_dir(root()).arg("--contact-mjcf").arg(&dir);
    if full {
        cmd.arg("--full");
    }
    let runs = match cmd.output() {
        Ok(o) if o.status.success() => parse_report_runs(&String::from_utf8_lossy(&o.stdout)),
        Ok(o) => Err(crate::mujoco::last_line(&o)),
        Err(e) => Err(e.to_string()),
    };
    match (runs, crate::mujoco::ensure_venv()) {
        (Err(e), _) => notes.push(format!(
            "MuJoCo not run (verify-report --contact-mjcf: {e})"
        )),
        (_, Err(e)) => notes.push(format!("MuJoCo not run: {e}")),
        (Ok(runs), Ok(_)) => {
            let mut version = None;
            let mut failed = Vec::new();
            for (k, r) in runs.iter().enumerate() {
                let csv = dir.join(format!("run{k}.csv"));
                let timing = dir.join(format!("run{k}.timing.json"));
                let res = run_mujoco_scene(&RunOptions {
                    scene: r.xml.clone(),
                    keyframe: Some("start".into()),
                    dt: Some(r.dt.clone()),
                    duration: r.duration.clone(),
                    every: 1,
                    out: csv.clone(),
                    timing: Some(timing.clone()),
                    ..RunOptions::default()
                })
                .and_then(|()| {
                    let t = std::fs::read_to_string(&timing).map_err(|e| e.to_string())?;
                    let t = crate::bench::Timing::parse(&t);
                    let c = std::fs::read_to_string(&csv).map_err(|e| e.to_string())?;
                    let f = accuracy_from_csv(&c)?;
                    version = version.clone().or(t.mujoco_version);
                    Ok((t.seconds_per_step.ok_or("no seconds_per_step")?, f))
                });
                let dt: f64 = r.dt.parse().unwrap_or(f64::NAN);
                match res {
                    Ok((sps, f)) => rows.push((
                        r.scene.clone(),
                        "MuJoCo",
                        format!("dt 1/{:.0}", 1.0 / dt),
                        sps,
                        report_error(&r.scene, &f),
                        dt,
                    )),
                    Err(e) => failed.push(format!("{} at dt {}: {e}", r.scene, r.dt)),
                }
            }
            notes.push(format!(
                "MuJoCo {} (its defaults: soft contacts, Euler, Newton solver, pyramidal cone; \
                 the stack and the pyramid written as MJCF from these scenes, the sliding box \
                 `scenes/sliding_box.xml` with its `solref` 0.005) at each step of the chart \
                 (with its default `margin` 0, boxes that touch exactly make no contact until \
                 they overlap: the upper boxes of the stack first fall together, which is \
                 most of its drift), \
                 run time from its C loop (`mujoco.rollout`) per simulated second; {} runs in \
                 {:.1} s with Python's start-up{}",
                version.as_deref().unwrap_or("?"),
                rows.len(),
                t0.elapsed().as_secs_f64(),
                if failed.is_empty() {
                    String::new()
                } else {
                    format!("; failed: {}", failed.join("; "))
                }
            ));
        }
    }
    // rapier3d from an earlier `cargo xtask bench`, where the report has the same scene.
    let acc = root().join("target/peers/contact_accuracy.tsv");
    let text = std::fs::read_to_string(&acc).ok();
    let mut rapier = 0;
    let accuracy = crate::bench::parse_contact_accuracy(text.as_deref().unwrap_or(""));
    for (engine, scene, a) in &accuracy {
        if engine != "rapier" || !["stack10", "sliding_box"].contains(&scene.as_str()) {
            continue;
        }
        let (Some(travel), Some(t)) = (
            a.top_travel,
            crate::bench::estimate("contact_peers", "rapier", scene),
        ) else {
            continue;
        };
        let figures = Figures {
            top_drift: a.top_drift,
            worst_displacement: a.worst_displacement,
            top_travel: travel,
            ..Figures::default()
        };
        rows.push((
            scene.clone(),
            "rapier3d",
            "bench, 10 s".into(),
            t,
            report_error(scene, &figures),
            1.0 / 60.0,
        ));
        rapier += 1;
    }
    notes.push(if rapier > 0 {
        format!(
            "rapier3d (labelled `bench, 10 s`) from an earlier `cargo xtask bench` \
             ({}, criterion's medians in `target/criterion/contact_peers/rapier/`): one \
             step at dt = 1/60 after 1 s at rest, the error over its 10 s run (this \
             report's stack runs {} s; the sliding box has stopped long before); on the \
             stack of 10 and the sliding box only (the bench's pyramid has base 20)",
            acc.display(),
            if full { 5 } else { 2 }
        )
    } else {
        format!(
            "rapier3d not shown: no earlier `cargo xtask bench` with its contact section \
             ({} and criterion's estimates; rapier stays out of this build)",
            acc.display()
        )
    });
    let mut tsv =
        String::from("scene\tscene_label\ty_label\tengine\tsetting\tseconds_per_step\terror\tdt\n");
    for (scene, engine, setting, t, e, dt) in &rows {
        let _ = writeln!(
            tsv,
            "{scene}\t{scene}\terror (m)\t{engine}\t{setting}\t{t:e}\t{e:e}\t{dt:e}"
        );
    }
    let path = out.join("contact_peers.tsv");
    let written = std::fs::create_dir_all(out).and_then(|()| std::fs::write(&path, tsv));
    let note = notes.join(". ") + ".";
    match written {
        Ok(()) => (Some(path), note),
        Err(e) => (None, format!("{note} (points not written: {e})")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_drift_sink_worst_and_travel_from_a_trajectory() {
        let csv = "t,a.x,a.y,a.z,a.qw,a.cx,b.x,b.y,b.z,E_kin\n\
                   0,0,0,0.5,1,0,0,0,1.5,0\n\
                   0.1,0,0,0.49,1,0,0.3,0,1.4,0\n\
                   0.2,0,0,0.5,1,0,0.4,0.3,1.45,0\n";
        let f = accuracy_from_csv(csv).unwrap();
        assert!((f.top_drift - (0.4f64.powi(2) + 0.09 + 0.0025).sqrt()).abs() < 1e-12);
        assert!((f.top_sink - 0.05).abs() < 1e-12);
        assert_eq!(f.worst_displacement, f.top_drift);
        assert!((f.top_travel - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_bad_trajectory_is_an_error() {
        assert!(accuracy_from_csv("").is_err());
        assert!(accuracy_from_csv("t,E\n0,1\n")
            .unwrap_err()
            .contains("no body"));
        assert!(accuracy_from_csv("t,a.x,a.y,a.z\n")
            .unwrap_err()
            .contains("no rows"));
        let e = accuracy_from_csv("t,a.x,a.y,a.z\n0,0,0,nan\n").unwrap_err();
        assert!(e.contains("row 2"), "{e}");
        assert!(accuracy_from_csv("t,a.x,a.y,a.z\n0,0,0\n").is_err());
    }

    #[test]
    fn report_runs_parse_and_bad_lines_are_errors() {
        let r = parse_report_runs("stack10\t/x/stack10.xml\t0.016666666666666666\t2\n\n").unwrap();
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].dt, "0.016666666666666666");
        assert!(parse_report_runs("stack10\t/x.xml\t0\t2\n").is_err());
        assert!(parse_report_runs("stack10\t/x.xml\n").is_err());
        let f = Figures {
            top_drift: 1.0,
            worst_displacement: 2.0,
            top_travel: 1.0,
            top_sink: 0.0,
        };
        assert_eq!(report_error("stack10", &f), 1.0);
        assert_eq!(report_error("pyramid5", &f), 2.0);
        assert!((report_error("sliding_box", &f) - (1.0 - SLIDE_EXACT)).abs() < 1e-15);
    }

    #[test]
    fn the_chart_error_follows_the_scene() {
        assert_eq!(scene_error("stack10", 1.0, 2.0, None), Some(1.0));
        assert_eq!(scene_error("pyramid20", 1.0, 2.0, None), Some(2.0));
        assert_eq!(scene_error("sliding_box", 1.0, 2.0, None), None);
        let e = scene_error("sliding_box", 0.0, 0.0, Some(1.0)).unwrap();
        assert!((e - (1.0 - SLIDE_EXACT)).abs() < 1e-15);
        assert!((BOX_SETTINGS[1].dt() * 240.0 - 1.0).abs() < 1e-15);
    }

    #[test]
    fn the_points_file_has_a_line_per_row_and_the_chart_list_parses() {
        let rows = vec![
            (
                "stack10".to_string(),
                "ours",
                "Auto".to_string(),
                1e-5,
                2e-10,
            ),
            (
                "stack10".to_string(),
                "MuJoCo",
                "dt 1/60".to_string(),
                9e-6,
                4e-3,
            ),
        ];
        let t = points_tsv(&rows, |s| format!("<{s}>"));
        assert_eq!(t.lines().count(), 3);
        assert!(
            t.contains(
                "stack10\t<stack10>\ttop-box drift, max over 10 s (m)\tMuJoCo\tdt 1/60\t9e-6\t4e-3"
            ),
            "{t}"
        );
        let (files, notes) =
            parse_chart_list("stack10\tcontact_stack10.svg\nnote\tline 3: x\ngarbage\n");
        assert_eq!(files, [("stack10".into(), "contact_stack10.svg".into())]);
        assert_eq!(notes, ["line 3: x"]);
    }
}
