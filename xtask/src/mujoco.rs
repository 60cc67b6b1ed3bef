//! `cargo xtask mujoco SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K]
//! [--integrator euler|implicitfast|rk4] --out FILE.csv [--timing FILE.json]`
//!
//! Runs an MJCF scene in MuJoCo and writes the trajectory file of DESIGN.md section 6.
//! On first use it creates a virtual environment in `target/mujoco-venv` (`python3 -m venv`)
//! and installs `mujoco==MUJOCO_VERSION` from PyPI into it; the Python side is
//! `xtask/mujoco_run.py`, embedded here and written to `target/xtask/` at run time.
//! `--timing FILE.json` also times the same rollout in MuJoCo's C loop (`mujoco.rollout`)
//! and writes seconds per step.
//!
//! `REFERENCES` lists the committed MuJoCo exports in `scenes/reference/` and how each
//! was made; `cargo xtask verify --mujoco` regenerates them (`check_references`).

use crate::compare::{compare, format_report, Trajectory};
use crate::run::root;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The MuJoCo release the references were made with (PyPI `mujoco`).
pub const MUJOCO_VERSION: &str = "4.0.0";

const SCRIPT: &str = include_str!("../mujoco_run.py");

/// Integrators `--integrator` accepts.
pub const INTEGRATORS: [&str; 3] = ["euler", "implicitfast", "rk4"];

/// One MuJoCo run: the options of `cargo xtask mujoco`. Every value is taken as given,
/// a leading minus sign included (`--qvel -1,2`), and passed to the Python script as
/// written.
#[derive(clap::Args, Clone, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// The MJCF scene file.
    #[arg(value_name = "SCENE.xml")]
    pub scene: PathBuf,
    /// Start from this keyframe of the file [default: the model's qpos0, at rest].
    #[arg(long, value_name = "NAME", allow_hyphen_values = true)]
    pub keyframe: Option<String>,
    /// The time step, s, overriding the file's [default: the file's option timestep].
    #[arg(long, value_name = "DT", allow_hyphen_values = true, value_parser = positive)]
    pub dt: Option<String>,
    /// Simulated time, s (required).
    #[arg(long, value_name = "T", allow_hyphen_values = true, value_parser = non_negative)]
    pub duration: String,
    /// Write every K-th step.
    #[arg(
        long,
        value_name = "K",
        default_value_t = 1,
        allow_hyphen_values = true,
        value_parser = at_least_one
    )]
    pub every: usize,
    /// MuJoCo's integrator [default: the file's option integrator].
    #[arg(
        long,
        value_name = "I",
        allow_hyphen_values = true,
        value_parser = clap::builder::PossibleValuesParser::new(INTEGRATORS)
    )]
    pub integrator: Option<String>,
    /// The trajectory as CSV (required).
    #[arg(long, value_name = "FILE.csv", allow_hyphen_values = true)]
    pub out: PathBuf,
    /// Also time the same rollout in MuJoCo's C loop (mujoco.rollout) and write seconds
    /// per step as JSON [default: none].
    #[arg(long, value_name = "FILE.json", allow_hyphen_values = true)]
    pub timing: Option<PathBuf>,
    /// Initial positions in MuJoCo's generalized coordinates, comma-separated, after the
    /// keyframe [default: the keyframe's or qpos0; missing trailing values: unchanged].
    #[arg(long, value_name = "V,V,...", allow_hyphen_values = true)]
    pub qpos: Option<String>,
    /// Initial velocities, comma-separated [default: the keyframe's or 0; missing
    /// trailing values: unchanged].
    #[arg(long, value_name = "V,V,...", allow_hyphen_values = true)]
    pub qvel: Option<String>,
    /// Controls: CSV `t,<actuator>...`, each row held until the next, as `simulate --ctrl`
    /// [default: none, zero].
    #[arg(long, value_name = "FILE.csv", allow_hyphen_values = true)]
    pub ctrl: Option<PathBuf>,
}

/// A committed reference export: `scenes/reference/<scene>.csv`, MuJoCo RK4 from
/// keyframe `start`.
pub struct Reference {
    pub scene: &'static str,
    pub dt: &'static str,
    pub duration: &'static str,
    pub every: usize,
}

/// The committed references (scenes/reference/README.md gives their error figures).
pub const REFERENCES: [Reference; 8] = [
    Reference {
        scene: "pendulum",
        dt: "1e-5",
        duration: "2",
        every: 1000,
    },
    Reference {
        scene: "double_pendulum",
        dt: "1e-5",
        duration: "2",
        every: 1000,
    },
    Reference {
        scene: "spherical_pendulum",
        dt: "1e-5",
        duration: "2",
        every: 1000,
    },
    Reference {
        scene: "four_bar",
        dt: "1e-5",
        duration: "2",
        every: 1000,
    },
    Reference {
        scene: "chain20",
        dt: "1e-5",
        duration: "2",
        every: 4000,
    },
    Reference {
        scene: "chain20_heavy",
        dt: "1e-5",
        duration: "2",
        every: 4000,
    },
    Reference {
        scene: "chain100",
        dt: "1e-4",
        duration: "1",
        every: 1000,
    },
    Reference {
        scene: "coupled_pendulums",
        dt: "1e-4",
        duration: "2",
        every: 100,
    },
];

impl Reference {
    /// The run that produces this reference, writing to `out`.
    pub fn options(&self, out: PathBuf) -> RunOptions {
        RunOptions {
            scene: root().join("scenes").join(format!("{}.xml", self.scene)),
            keyframe: Some("start".into()),
            dt: Some(self.dt.into()),
            duration: self.duration.into(),
            every: self.every,
            integrator: Some("rk4".into()),
            out,
            timing: None,
            ..RunOptions::default()
        }
    }
}

fn venv_dir() -> PathBuf {
    root().join("target/mujoco-venv")
}

fn venv_python() -> PathBuf {
    if cfg!(windows) {
        venv_dir().join("Scripts/python.exe")
    } else {
        venv_dir().join("bin/python")
    }
}

/// The last non-empty line of a process's stderr (or stdout), for one-line reasons.
pub fn last_line(out: &std::process::Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr);
    let std = String::from_utf8_lossy(&out.stdout);
    err.lines()
        .chain(std.lines())
        .rev()
        .find(|l| !l.trim().is_empty())
        .map(|l| l.trim().to_string())
        .unwrap_or_else(|| format!("exit status {}", out.status))
}

/// Creates `target/mujoco-venv` with `mujoco==MUJOCO_VERSION` unless it is already there;
/// returns its Python.
pub fn ensure_venv() -> Result<PathBuf, String> {
    let python = venv_python();
    let marker = venv_dir().join("xtask-mujoco-version");
    if python.exists() && std::fs::read_to_string(&marker).is_ok_and(|v| v.trim() == MUJOCO_VERSION)
    {
        return Ok(python);
    }
    if !python.exists() {
        let system = ["python3", "python"]
            .into_iter()
            .find(|p| {
                Command::new(p)
                    .args(["-c", "import sys; assert sys.version_info >= (3, 9)"])
                    .output()
                    .is_ok_and(|o| o.status.success())
            })
            .ok_or(
                "python3 (3.9 or newer) not found on PATH: MuJoCo runs need it \
                 (Debian/Ubuntu: apt-get install python3 python3-venv)",
            )?;
        eprintln!(
            "xtask: creating {} (first use of MuJoCo)",
            venv_dir().display()
        );
        let out = Command::new(system)
            .args(["-m", "venv"])
            .arg(venv_dir())
            .output()
            .map_err(|e| format!("{system} -m venv: {e}"))?;
        if !out.status.success() || !python.exists() {
            let _ = std::fs::remove_dir_all(venv_dir());
            return Err(format!(
                "{system} -m venv failed (venv/ensurepip missing? Debian/Ubuntu: apt-get install \
                 python3-venv): {}",
                last_line(&out)
            ));
        }
    }
    let pip_ok = Command::new(&python)
        .args(["-m", "pip", "--version"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !pip_ok {
        let _ = std::fs::remove_dir_all(venv_dir());
        return Err(
            "pip is missing from the virtual environment (Debian/Ubuntu: apt-get install \
             python3-pip python3-venv)"
                .into(),
        );
    }
    eprintln!("xtask: pip install mujoco=={MUJOCO_VERSION} into target/mujoco-venv");
    let out = Command::new(&python)
        .args(["-m", "pip", "install", "--disable-pip-version-check", "-q"])
        .arg(format!("mujoco=={MUJOCO_VERSION}"))
        .output()
        .map_err(|e| format!("pip install: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "pip install mujoco=={MUJOCO_VERSION} failed: {}",
            last_line(&out)
        ));
    }
    std::fs::write(&marker, MUJOCO_VERSION).map_err(|e| format!("{}: {e}", marker.display()))?;
    Ok(python)
}

/// Writes the embedded script to `target/xtask/mujoco_run.py` (if changed); returns its path.
fn script_path() -> Result<PathBuf, String> {
    let dir = root().join("target/xtask");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join("mujoco_run.py");
    if std::fs::read_to_string(&path).ok().as_deref() != Some(SCRIPT) {
        std::fs::write(&path, SCRIPT).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(path)
}

/// Runs MuJoCo on `o`; stderr of the script is shown on success, its last line is the
/// error on failure.
pub fn run(o: &RunOptions) -> Result<(), String> {
    if !o.scene.is_file() {
        return Err(format!("{}: no such scene file", o.scene.display()));
    }
    if let Some(parent) = o.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
    }
    let python = ensure_venv()?;
    let script = script_path()?;
    let mut cmd = Command::new(python);
    cmd.arg(script).arg(&o.scene);
    if let Some(k) = &o.keyframe {
        cmd.args(["--keyframe", k]);
    }
    // `--flag=value`: a value that starts with a minus sign is not an option to argparse.
    if let Some(q) = &o.qpos {
        cmd.arg(format!("--qpos={q}"));
    }
    if let Some(v) = &o.qvel {
        cmd.arg(format!("--qvel={v}"));
    }
    if let Some(c) = &o.ctrl {
        cmd.arg("--ctrl").arg(c);
    }
    if let Some(dt) = &o.dt {
        cmd.args(["--dt", dt]);
    }
    cmd.args(["--duration", &o.duration]);
    cmd.args(["--every", &o.every.to_string()]);
    if let Some(i) = &o.integrator {
        cmd.args(["--integrator", i]);
    }
    cmd.arg("--out").arg(&o.out);
    if let Some(t) = &o.timing {
        cmd.arg("--timing").arg(t);
    }
    let out = cmd
        .output()
        .map_err(|e| format!("running MuJoCo's Python: {e}"))?;
    if !out.status.success() {
        let line = last_line(&out);
        return Err(line
            .strip_prefix("mujoco_run: ")
            .map(str::to_string)
            .unwrap_or(line));
    }
    eprint!("{}", String::from_utf8_lossy(&out.stderr));
    Ok(())
}

/// `--dt`: a positive finite number, kept as written.
fn positive(v: &str) -> Result<String, String> {
    match v.parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() => Ok(v.to_string()),
        _ => Err("not a positive number".into()),
    }
}

/// `--duration`: a finite number >= 0, kept as written.
fn non_negative(v: &str) -> Result<String, String> {
    match v.parse::<f64>() {
        Ok(x) if x >= 0.0 && x.is_finite() => Ok(v.to_string()),
        _ => Err("not a number >= 0".into()),
    }
}

/// `--every`: a whole number >= 1.
fn at_least_one(v: &str) -> Result<usize, String> {
    v.parse()
        .ok()
        .filter(|&k: &usize| k >= 1)
        .ok_or_else(|| "not a whole number >= 1".into())
}

/// Regenerates every reference into `dir` and compares each with the committed
/// `scenes/reference/<scene>.csv`; fails if any COM, body-origin or orientation difference
/// exceeds `tol` or a sample is missing. Returns one summary line per scene.
pub fn check_references(dir: &Path, tol: f64) -> Result<Vec<String>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut lines = Vec::new();
    let mut failed = Vec::new();
    for r in &REFERENCES {
        let committed = root()
            .join("scenes/reference")
            .join(format!("{}.csv", r.scene));
        let fresh = dir.join(format!("{}.csv", r.scene));
        let t0 = std::time::Instant::now();
        eprintln!(
            "xtask: MuJoCo RK4 dt {} for {} s: {}",
            r.dt, r.duration, r.scene
        );
        let res = run(&r.options(fresh.clone())).and_then(|()| {
            let a = Trajectory::read(&committed)?;
            let b = Trajectory::read(&fresh)?;
            compare(&a, &b)
        });
        let line = match res {
            Ok(rep) => {
                let worst = rep
                    .com
                    .value
                    .max(rep.origin.value)
                    .max(rep.orientation.value);
                let ok = rep.all_matched() && worst <= tol;
                if !ok {
                    failed.push(r.scene);
                    eprint!("{}", format_report(&rep));
                }
                format!(
                    "{} {}: COM {:.3e} m, origin {:.3e} m, orientation {:.3e} rad over {} samples ({:.1} s)",
                    if ok { "ok  " } else { "FAIL" },
                    r.scene,
                    rep.com.value,
                    rep.origin.value,
                    rep.orientation.value,
                    rep.matched,
                    t0.elapsed().as_secs_f64()
                )
            }
            Err(e) => {
                failed.push(r.scene);
                format!("FAIL {}: {e}", r.scene)
            }
        };
        eprintln!("  {line}");
        lines.push(line);
    }
    if failed.is_empty() {
        Ok(lines)
    } else {
        Err(format!(
            "MuJoCo references differ from the committed ones by more than {tol:e} (or failed): {}",
            failed.join(", ")
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `cargo xtask mujoco LINE`'s options, or clap's error rendered.
    fn parse_args(line: &str) -> Result<RunOptions, String> {
        match crate::parse(&format!("mujoco {line}")) {
            Ok(Some(crate::Command::Mujoco(o))) => Ok(o),
            Ok(other) => panic!("{line}: parsed as {other:?}"),
            Err(e) => Err(e.to_string()),
        }
    }

    #[test]
    fn parses_a_full_command_line() {
        let o = parse_args(
            "scenes/chain20.xml --keyframe start --dt 1e-3 --duration 2 --every 10 \
             --integrator rk4 --out a.csv --timing a.json",
        )
        .unwrap();
        assert_eq!(o.scene, PathBuf::from("scenes/chain20.xml"));
        assert_eq!(o.keyframe.as_deref(), Some("start"));
        assert_eq!(o.dt.as_deref(), Some("1e-3"));
        assert_eq!(o.duration, "2");
        assert_eq!(o.every, 10);
        assert_eq!(o.integrator.as_deref(), Some("rk4"));
        assert_eq!(o.out, PathBuf::from("a.csv"));
        assert_eq!(o.timing, Some(PathBuf::from("a.json")));
        // The defaults: every step, no keyframe, the file's step and integrator.
        let o = parse_args("s.xml --duration 1 --out a.csv").unwrap();
        assert_eq!(o.every, 1);
        assert_eq!((o.keyframe, o.dt, o.integrator), (None, None, None));
    }

    /// The command lines of scenes/reference/README.md (the committed references), the
    /// actuated one with a negative velocity.
    #[test]
    fn parses_the_reference_command_lines() {
        let o = parse_args(
            "scenes/actuated.xml --qpos 0.1,0.5 --qvel 0.2,-1 --ctrl scenes/actuated_ctrl.csv \
             --dt 1e-5 --duration 2 --every 1000 --integrator rk4 \
             --out scenes/reference/actuated_ctrl.csv",
        )
        .unwrap();
        assert_eq!(o.qpos.as_deref(), Some("0.1,0.5"));
        assert_eq!(o.qvel.as_deref(), Some("0.2,-1"));
        assert_eq!(o.ctrl, Some(PathBuf::from("scenes/actuated_ctrl.csv")));
        assert_eq!((o.dt.as_deref(), o.every), (Some("1e-5"), 1000));
        let o = parse_args(
            "scenes/box_stack.xml --duration 2 --every 20 --integrator euler \
             --out scenes/reference/contact/box_stack.csv",
        )
        .unwrap();
        assert_eq!(o.integrator.as_deref(), Some("euler"));
        assert_eq!(o.keyframe, None);
        // Each committed reference, as `verify --mujoco` runs it, spelled as a command line.
        for r in &REFERENCES {
            let line = format!(
                "scenes/{0}.xml --keyframe start --dt {1} --duration {2} --every {3} \
                 --integrator rk4 --out {0}.csv",
                r.scene, r.dt, r.duration, r.every
            );
            let out = PathBuf::from(format!("{}.csv", r.scene));
            let mut want = r.options(out);
            want.scene = PathBuf::from(format!("scenes/{}.xml", r.scene));
            assert_eq!(parse_args(&line).unwrap(), want, "{line}");
        }
    }

    #[test]
    fn rejects_bad_command_lines() {
        for (line, want) in [
            ("s.xml --out a.csv", "--duration <T>"),
            ("s.xml --duration 1", "--out <FILE.csv>"),
            ("--duration 1 --out a.csv", "<SCENE.xml>"),
            (
                "s.xml --duration 1 --out a.csv --dt 0",
                "not a positive number",
            ),
            (
                "s.xml --duration 1 --out a.csv --dt -1e-3",
                "not a positive number",
            ),
            ("s.xml --duration -1 --out a.csv", "not a number >= 0"),
            ("s.xml --duration inf --out a.csv", "not a number >= 0"),
            (
                "s.xml --duration 1 --out a.csv --every 0",
                "not a whole number >= 1",
            ),
            (
                "s.xml --duration 1 --out a.csv --integrator rk45",
                "possible values",
            ),
            (
                "s.xml --duration 1 --out a.csv --bogus",
                "unexpected argument '--bogus'",
            ),
            (
                "s.xml t.xml --duration 1 --out a.csv",
                "unexpected argument 't.xml'",
            ),
            ("s.xml --duration", "a value is required"),
        ] {
            let e = parse_args(line).expect_err(line);
            assert!(e.contains(want), "{line}: {want:?} not in {e:?}");
        }
    }

    #[test]
    fn every_reference_scene_exists_and_samples_divide_the_horizon() {
        for r in &REFERENCES {
            let scene = root().join("scenes").join(format!("{}.xml", r.scene));
            assert!(scene.is_file(), "{}", scene.display());
            let dt: f64 = r.dt.parse().unwrap();
            let t: f64 = r.duration.parse().unwrap();
            let steps = (t / dt).round();
            assert!((steps * dt - t).abs() < 1e-12);
            assert_eq!(steps as usize % r.every, 0, "{}", r.scene);
        }
    }

    /// The regression check of `cargo xtask verify --mujoco`, runnable alone with
    /// `cargo test -p xtask -- --ignored` (about 2 minutes).
    #[test]
    #[ignore = "needs Python and MuJoCo (pip); cargo xtask verify --mujoco runs the same"]
    fn regenerated_references_match_the_committed_ones() {
        let lines = check_references(&root().join("target/verify/mujoco"), 1e-9).unwrap();
        assert_eq!(lines.len(), REFERENCES.len());
    }

    #[test]
    fn committed_references_parse() {
        for r in &REFERENCES {
            let path = root()
                .join("scenes/reference")
                .join(format!("{}.csv", r.scene));
            // Read as text (the CSV reader is constraint-scene's; its tests parse these).
            let text = std::fs::read_to_string(&path).unwrap();
            let mut lines = text.lines();
            let header = lines.next().unwrap();
            assert!(header.starts_with("t,"), "{}", r.scene);
            assert!(header.ends_with(",E_kin,E_pot,E_tot"), "{}", r.scene);
            let times: Vec<f64> = lines
                .map(|l| l.split(',').next().unwrap().parse().unwrap())
                .collect();
            assert_eq!(times[0], 0.0);
            let dur: f64 = r.duration.parse().unwrap();
            assert!((times[times.len() - 1] - dur).abs() < 1e-9);
            let dt: f64 = r.dt.parse().unwrap();
            let step = dt * r.every as f64;
            assert_eq!(
                times.len(),
                (dur / step).round() as usize + 1,
                "{}",
                r.scene
            );
            // Under ~300 KB each, so the repository stays small.
            assert!(
                std::fs::metadata(&path).unwrap().len() < 300_000,
                "{}",
                r.scene
            );
        }
    }
}
