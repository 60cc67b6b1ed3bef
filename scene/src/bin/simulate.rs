//! `simulate SCENE.xml [--keyframe NAME | --qpos V,.. --qvel V,..] [--ctrl FILE.csv]
//! [--dt DT] --duration T [--every K] [--method M] [--summary FILE.json]
//! [--out FILE.csv] [--html FILE.html]` — runs an MJCF scene with this library and
//! writes the trajectory (DESIGN.md §6; at least one of `--out` and `--html`).
//! `--html` writes an animated, self-contained page of the run (the scene's shapes
//! moving along the trajectory, at most 60 frames per simulated second; play/pause,
//! time slider, orbit camera; `constraint_scene::viewer`). `cargo xtask simulate`
//! calls this. Exit status 1 with a one-line
//! reason on any error. `--summary` also writes the run's figures (steps, µs per step,
//! finite, worst joint separation, penetration, energy increase, contacts; see
//! `constraint_scene::run::Summary`) as one JSON object; `cargo xtask models` reads it.

use std::path::PathBuf;
use std::process::ExitCode;

use constraint_scene::run::{run, run_with_summary, RunOptions, FREE_BODY_METHODS, METHODS};
use constraint_scene::scene_view;

/// The command line.
struct Args {
    scene: PathBuf,
    opts: RunOptions,
    /// Trajectory CSV.
    out: Option<PathBuf>,
    /// Summary JSON.
    summary: Option<PathBuf>,
    /// Viewer page.
    html: Option<PathBuf>,
}

fn parse(args: &[String]) -> Result<Args, String> {
    let mut scene = None;
    let mut out = None;
    let mut summary = None;
    let mut html = None;
    let mut opts = RunOptions {
        duration: f64::NAN,
        ..RunOptions::default()
    };
    let list = |s: String, name: &str| -> Result<Vec<f64>, String> {
        s.split(',')
            .map(|x| {
                x.trim()
                    .parse::<f64>()
                    .map_err(|_| format!("{name}: not a number: {x:?}"))
            })
            .collect()
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut val = |name: &str| it.next().cloned().ok_or(format!("{name} needs a value"));
        let num = |s: String, name: &str| {
            s.parse::<f64>()
                .map_err(|_| format!("{name}: not a number: {s:?}"))
        };
        match a.as_str() {
            "--keyframe" => opts.keyframe = Some(val("--keyframe")?),
            "--dt" => opts.dt = Some(num(val("--dt")?, "--dt")?),
            "--duration" => opts.duration = num(val("--duration")?, "--duration")?,
            "--every" => {
                let v = val("--every")?;
                opts.every = v
                    .parse()
                    .map_err(|_| format!("--every: not a positive integer: {v:?}"))?;
            }
            "--method" => opts.method = val("--method")?,
            "--qpos" => opts.qpos = Some(list(val("--qpos")?, "--qpos")?),
            "--qvel" => opts.qvel = Some(list(val("--qvel")?, "--qvel")?),
            "--ctrl" => opts.ctrl = Some(PathBuf::from(val("--ctrl")?)),
            "--out" => out = Some(PathBuf::from(val("--out")?)),
            "--summary" => summary = Some(PathBuf::from(val("--summary")?)),
            "--html" => html = Some(PathBuf::from(val("--html")?)),
            s if s.starts_with("--") => return Err(format!("unknown option {s}")),
            s => {
                if scene.replace(PathBuf::from(s)).is_some() {
                    return Err("more than one scene file given".into());
                }
            }
        }
    }
    let scene = scene.ok_or("missing SCENE.xml")?;
    if out.is_none() && html.is_none() {
        return Err("missing --out FILE.csv (or --html FILE.html)".into());
    }
    if opts.duration.is_nan() {
        return Err("missing --duration T".into());
    }
    Ok(Args {
        scene,
        opts,
        out,
        summary,
        html,
    })
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "-h" || a == "--help") {
        println!("usage: simulate SCENE.xml [--keyframe NAME | --qpos V,V,... --qvel V,V,...] [--ctrl FILE.csv] [--dt DT] --duration T [--every K] [--method M] [--summary FILE.json] [--out FILE.csv] [--html FILE.html]");
        println!("  --qpos, --qvel  initial state in MuJoCo's generalized coordinates (missing values: qpos0, 0)");
        println!("  --ctrl FILE     controls: CSV `t,<actuator>...`, each row held until the next");
        println!("  --out FILE      the trajectory as CSV (t, per body x,y,z, qw,qx,qy,qz, cx,cy,cz, energies)");
        println!("  --html FILE     an animated page of the run: shapes, play/pause, time slider, orbit camera");
        println!("                  (self-contained, at most 60 frames per simulated second; URL #t=S&paused=1)");
        println!(
            "  --summary FILE  also write the run's figures as JSON: steps, us_per_step, finite,"
        );
        println!("                  max_joint_separation, max_penetration, settled_penetration (second half),");
        println!("                  energy_initial, max_energy_increase, energy_final, max_contacts, actuators, colliders");
        for (n, d) in METHODS.iter().chain(&FREE_BODY_METHODS) {
            println!("  --method {n:<13} {d}");
        }
        return ExitCode::SUCCESS;
    }
    let result = parse(&args).and_then(|a| {
        let (scene, opts) = (&a.scene, &a.opts);
        // The summary's figures are gathered only when asked for (they cost a pass over
        // the joints per step, outside the timed part).
        let (traj, secs, sum) = match &a.summary {
            Some(_) => run_with_summary(scene, opts).map(|(t, s, m)| (t, s, Some(m)))?,
            None => run(scene, opts).map(|(t, s)| (t, s, None))?,
        };
        let mut wrote = Vec::new();
        if let Some(out) = &a.out {
            std::fs::write(out, traj.to_csv()).map_err(|e| format!("{}: {e}", out.display()))?;
            wrote.push(out.display().to_string());
        }
        if let Some(p) = &a.html {
            // The run already loaded this file, so a second load only fails if it changed.
            let model = constraint_mjcf::load_file(scene).map_err(|e| format!("scene: {e}"))?;
            let title = scene
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            let page = scene_view::page(&model, &traj, &title).map_err(|e| e.to_string())?;
            std::fs::write(p, page).map_err(|e| format!("{}: {e}", p.display()))?;
            wrote.push(p.display().to_string());
        }
        let (out, summary) = (wrote.join(" and "), &a.summary);
        if let (Some(p), Some(sum)) = (&summary, sum) {
            std::fs::write(p, sum.to_json() + "\n").map_err(|e| format!("{}: {e}", p.display()))?;
        }
        let steps = ((opts.duration / opts.dt.unwrap_or(f64::NAN)).round()).max(0.0);
        eprintln!(
            "simulate: wrote {} rows to {out} ({secs:.3} s stepping{})",
            traj.rows.len(),
            if steps.is_finite() && steps > 0.0 {
                format!(", {:.2} µs/step", secs / steps * 1e6)
            } else {
                String::new()
            }
        );
        Ok(())
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("simulate: {e}");
            ExitCode::FAILURE
        }
    }
}
