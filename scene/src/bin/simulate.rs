//! `simulate SCENE.xml --duration T (--out FILE.csv | --html FILE.html) [options]` — runs
//! an MJCF scene with this library and writes the trajectory (DESIGN.md §6). `--help`
//! lists every option with its default. `--html` writes an animated, self-contained page
//! of the run (the scene's shapes moving along the trajectory, at most 60 frames per
//! simulated second; play/pause, time slider, orbit camera; `constraint_scene::viewer`).
//! `--summary` also writes the run's figures (steps, µs per step, finite, worst joint
//! separation, penetration, energy increase, contacts; see `constraint_scene::run::Summary`)
//! as one JSON object; `cargo xtask models` reads it. `cargo xtask simulate` calls this.
//!
//! Exit status 1 with one line `simulate: <reason>` on any error, bad arguments included
//! (clap's multi-line usage errors are folded to one line).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::{CommandFactory, FromArgMatches, Parser};
use constraint_scene::run::{run, run_with_summary, RunOptions, FREE_BODY_METHODS, METHODS};
use constraint_scene::scene_view;

/// Runs an MJCF scene with the constraint crates and writes its trajectory.
#[derive(Parser, Debug)]
#[command(name = "simulate", version)]
struct Cli {
    /// The MJCF scene file.
    #[arg(value_name = "SCENE.xml")]
    scene: Option<PathBuf>,
    /// Start from this keyframe of the file [default: the model's qpos0, at rest].
    #[arg(long, value_name = "NAME")]
    keyframe: Option<String>,
    /// Initial positions in MuJoCo's generalized coordinates, comma-separated
    /// [default: qpos0; missing trailing values: qpos0].
    #[arg(long, value_name = "V,V,...", allow_hyphen_values = true)]
    qpos: Option<String>,
    /// Initial velocities in generalized coordinates [default: 0; missing values: 0].
    #[arg(long, value_name = "V,V,...", allow_hyphen_values = true)]
    qvel: Option<String>,
    /// Controls: CSV `t,<actuator>...`, each row held until the next [default: none, zero].
    #[arg(long, value_name = "FILE.csv")]
    ctrl: Option<PathBuf>,
    /// The time step, s [default: the file's option timestep].
    #[arg(long, value_name = "DT", allow_hyphen_values = true)]
    dt: Option<String>,
    /// Simulated time, s (required).
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    duration: Option<String>,
    /// Write every K-th step.
    #[arg(
        long,
        value_name = "K",
        default_value = "1",
        allow_hyphen_values = true
    )]
    every: String,
    /// The formulation: a step method of the one rigid world, or, for files of free
    /// bodies only, the contact crate's world.
    #[arg(
        long,
        value_name = "M",
        default_value = "rattle",
        value_parser = PossibleValuesParser::new(method_values())
    )]
    method: String,
    /// The trajectory as CSV (t, per body x,y,z, qw,qx,qy,qz, cx,cy,cz, energies)
    /// [default: none; --out or --html is required].
    #[arg(long, value_name = "FILE.csv")]
    out: Option<PathBuf>,
    /// An animated page of the run: shapes, play/pause, time slider, orbit camera
    /// (self-contained, at most 60 frames per simulated second; URL #t=S&paused=1)
    /// [default: none].
    #[arg(long, value_name = "FILE.html")]
    html: Option<PathBuf>,
    /// Also write the run's figures as one JSON object: steps, dt, seconds_stepping,
    /// us_per_step, finite, max_joint_separation, max_penetration, settled_penetration
    /// (second half), energy_initial, max_energy_increase, energy_final, max_contacts,
    /// first_contact_time, root_height, actuators, colliders, unconverged_steps and
    /// worst_unconverged_residual (dense one-sided solves that ended above their
    /// tolerance) [default: none].
    #[arg(long, value_name = "FILE.json")]
    summary: Option<PathBuf>,
    /// The floor (m) on the joints' projection tolerance of RATTLE steps that limit or
    /// contact rows send to the velocity level [default: 1e-8, the world's default;
    /// 1e-12 holds joints as tight as the other RATTLE steps].
    #[arg(long, value_name = "TOL", allow_hyphen_values = true)]
    unilateral_tolerance: Option<String>,
    /// Aim RATTLE's velocity-level fallback steps at the start of the step,
    /// `J v' = −C(x)/h`, instead of its end, `J v' = J v − C(x + h v)/h` (the default).
    #[arg(long)]
    start_aim: bool,
}

/// The names `--method` accepts, with their descriptions: the run's [`METHODS`] and
/// [`FREE_BODY_METHODS`], so a name the run does not know is clap's error and `--help`
/// lists them.
fn method_values() -> impl Iterator<Item = PossibleValue> {
    METHODS
        .iter()
        .chain(&FREE_BODY_METHODS)
        .map(|&(name, about)| PossibleValue::new(name).help(about))
}

/// A number of option `name`, with the hand parser's message on failure.
fn num(s: &str, name: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .map_err(|_| format!("{name}: not a number: {s:?}"))
}

/// A comma-separated list of numbers.
fn list(s: &str, name: &str) -> Result<Vec<f64>, String> {
    s.split(',').map(|x| num(x, name)).collect()
}

/// The checked command line: scene, run options and outputs.
struct Args {
    scene: PathBuf,
    opts: RunOptions,
    out: Option<PathBuf>,
    summary: Option<PathBuf>,
    html: Option<PathBuf>,
}

impl Cli {
    /// Checks what clap leaves as text (numbers keep their option-named messages; the
    /// run itself checks ranges: positive step, finite duration; clap checked the method).
    fn check(self) -> Result<Args, String> {
        let scene = self.scene.ok_or("missing SCENE.xml")?;
        if self.out.is_none() && self.html.is_none() {
            return Err("missing --out FILE.csv (or --html FILE.html)".into());
        }
        let duration = num(
            self.duration.as_deref().ok_or("missing --duration T")?,
            "--duration",
        )?;
        let every = self
            .every
            .parse()
            .map_err(|_| format!("--every: not a positive integer: {:?}", self.every))?;
        let opts = RunOptions {
            keyframe: self.keyframe,
            dt: self.dt.as_deref().map(|s| num(s, "--dt")).transpose()?,
            duration,
            every,
            method: self.method,
            qpos: self
                .qpos
                .as_deref()
                .map(|s| list(s, "--qpos"))
                .transpose()?,
            qvel: self
                .qvel
                .as_deref()
                .map(|s| list(s, "--qvel"))
                .transpose()?,
            ctrl: self.ctrl,
            unilateral_tolerance: self
                .unilateral_tolerance
                .as_deref()
                .map(|s| num(s, "--unilateral-tolerance"))
                .transpose()?,
            start_aim: self.start_aim,
        };
        Ok(Args {
            scene,
            opts,
            out: self.out,
            summary: self.summary,
            html: self.html,
        })
    }
}

/// Parses the command line: `Ok(None)` when `--help` or `--version` was printed.
fn parse() -> Result<Option<Args>, String> {
    let cmd = Cli::command().after_help("At least one of --out and --html is required.");
    let matches = match cmd.try_get_matches() {
        Ok(m) => m,
        Err(e) => return one_line(e).map(|()| None),
    };
    let cli = Cli::from_arg_matches(&matches).map_err(|e| first_line(&e))?;
    cli.check().map(Some)
}

/// Prints `--help` / `--version` (success) or folds a usage error to one line.
fn one_line(e: clap::Error) -> Result<(), String> {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            print!("{}", e.render());
            Ok(())
        }
        _ => Err(first_line(&e)),
    }
}

/// A clap error as one line without its `error: ` prefix: the message up to its first
/// blank line, indented continuation lines (the missing arguments) joined with spaces.
fn first_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let msg: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty() && !l.starts_with("Usage:"))
        .map(str::trim)
        .collect();
    let line = msg.join(" ");
    match line.strip_prefix("error: ") {
        Some(rest) => rest.to_string(),
        None if line.is_empty() => "bad arguments".to_string(),
        None => line,
    }
}

fn main() -> ExitCode {
    let result = parse().and_then(|args| args.map_or(Ok(()), simulate));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("simulate: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Runs the scene and writes the asked-for files.
fn simulate(a: Args) -> Result<(), String> {
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
    if let (Some(p), Some(sum)) = (&a.summary, sum) {
        std::fs::write(p, sum.to_json() + "\n").map_err(|e| format!("{}: {e}", p.display()))?;
    }
    let steps = ((opts.duration / opts.dt.unwrap_or(f64::NAN)).round()).max(0.0);
    eprintln!(
        "simulate: wrote {} rows to {} ({secs:.3} s stepping{})",
        traj.rows.len(),
        wrote.join(" and "),
        if steps.is_finite() && steps > 0.0 {
            format!(", {:.2} µs/step", secs / steps * 1e6)
        } else {
            String::new()
        }
    );
    Ok(())
}
