//! `cargo xtask models fetch | list | run [--quick] [--out DIR] [--only SUITE/NAME,...]`:
//! the MuJoCo models people
//! use (the gymnasium and dm_control suites), run through MuJoCo and through this library.
//!
//! `fetch` (done first by the other two) downloads the pinned wheels `gymnasium==1.4.0` and
//! `dm-control==1.0.50` (no dependencies) with the pip of `target/mujoco-venv` into
//! `target/models/wheels/`, and `xtask/models/extract.py` (standard library) extracts their
//! MJCF files into `target/models/gymnasium/` and `target/models/dm_control/` (with
//! `common/` and the asset directories the models reference) and generates dm_control's
//! procedural `lqr_2_1` and `swimmer6` from the `lqr.xml` and `swimmer.xml` templates, checked
//! in MuJoCo. A stamp file (`target/models/stamp`) with the pins makes it a no-op next time.
//!
//! `run` measures every model of [`MODELS`] (order fixed): MuJoCo (`xtask/models/
//! mujoco_models.py`, one process): sizes, µs per step of a passive run from the default pose
//! with zero control in its C loop (`mujoco.rollout`, median of 3), most contacts at any
//! step; ours: the `simulate` binary of `constraint-scene` (release), first with duration 0
//! (does it load?), then for the same steps; its one-line error is the reason. Then, per
//! case both finished, the interleaved timing ([`timing`], `--repeats K`): the two engines
//! alternately, K runs each, the ratio the median of the per-repeat ratios; those are the
//! tables' times and ratios. Writes `models.md` and `models.csv` to `--out` (default
//! `target/models/`) and prints the table. `--only` runs the named models alone (e.g.
//! `--only gymnasium/ant,dm_control/humanoid`).

use crate::bench::fmt_ratio;
use crate::models_checks::{
    checks, energy_checked, fatal, parse_summary, smooth_error, Summary, ENERGY_REL_TOL, JOINT_TOL,
    PENETRATION_TOL,
};
use crate::mujoco::{ensure_venv, last_line, RunOptions as MjRun, MUJOCO_VERSION};
use crate::run::{cargo, root};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
pub use timing::Paired;

#[path = "models_timing.rs"]
pub mod timing;

pub const GYMNASIUM_VERSION: &str = "1.4.0";
pub const DM_CONTROL_VERSION: &str = "1.0.50";

const EXTRACT: &str = include_str!("../models/extract.py");
const MEASURE: &str = include_str!("../models/mujoco_models.py");

/// The models, pinned: `(suite, name)`, the file is `target/models/<suite>/<name>.xml`.
/// gymnasium: every file of `gymnasium/envs/mujoco/assets/` (1.4.0). dm_control: the
/// suite's models (1.0.50), with the generated `lqr_2_1` and `swimmer6` in place of the
/// `lqr.xml` and `swimmer.xml` templates.
pub const MODELS: [(&str, &str); 33] = [
    ("gymnasium", "ant"),
    ("gymnasium", "half_cheetah"),
    ("gymnasium", "hopper"),
    ("gymnasium", "humanoid"),
    ("gymnasium", "humanoidstandup"),
    ("gymnasium", "inverted_double_pendulum"),
    ("gymnasium", "inverted_pendulum"),
    ("gymnasium", "point"),
    ("gymnasium", "pusher"),
    ("gymnasium", "pusher_v5"),
    ("gymnasium", "reacher"),
    ("gymnasium", "swimmer"),
    ("gymnasium", "walker2d"),
    ("gymnasium", "walker2d_v5"),
    ("dm_control", "acrobot"),
    ("dm_control", "ball_in_cup"),
    ("dm_control", "cartpole"),
    ("dm_control", "cheetah"),
    ("dm_control", "dog"),
    ("dm_control", "finger"),
    ("dm_control", "fish"),
    ("dm_control", "hopper"),
    ("dm_control", "humanoid"),
    ("dm_control", "humanoid_CMU"),
    ("dm_control", "lqr_2_1"),
    ("dm_control", "manipulator"),
    ("dm_control", "pendulum"),
    ("dm_control", "point_mass"),
    ("dm_control", "quadruped"),
    ("dm_control", "reacher"),
    ("dm_control", "stacker"),
    ("dm_control", "swimmer6"),
    ("dm_control", "walker"),
];

/// Simulated seconds of a run (`--quick`: [`QUICK_SECONDS`]).
pub const SECONDS: f64 = 5.0;
pub const QUICK_SECONDS: f64 = 0.5;
/// Simulated seconds of the controlled case (`--quick`: [`QUICK_SECONDS`]).
pub const CTRL_SECONDS: f64 = 2.0;
/// Our binary is stopped after this many wall seconds per model (quick: a tenth).
const OURS_TIMEOUT_S: u64 = 300;

fn models_dir() -> PathBuf {
    root().join("target/models")
}

/// `target/models/<suite>/<name>.xml`.
pub fn model_path(dir: &Path, suite: &str, name: &str) -> PathBuf {
    dir.join(suite).join(format!("{name}.xml"))
}

/// The stamp: the pins and a hash of the extraction script, so either change re-extracts.
fn stamp_text() -> String {
    // FNV-1a: enough to notice an edited script.
    let hash = EXTRACT.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    format!(
        "gymnasium=={GYMNASIUM_VERSION}\ndm-control=={DM_CONTROL_VERSION}\nextract.py {hash:016x}\n"
    )
}

/// The pinned files that are not in `dir`.
pub fn missing(dir: &Path) -> Vec<PathBuf> {
    MODELS
        .iter()
        .map(|(s, n)| model_path(dir, s, n))
        .filter(|p| !p.is_file())
        .collect()
}

/// Writes an embedded script to `target/xtask/<name>` (if changed); returns its path.
fn script(name: &str, text: &str) -> Result<PathBuf, String> {
    let dir = root().join("target/xtask");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join(name);
    if std::fs::read_to_string(&path).ok().as_deref() != Some(text) {
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(path)
}

/// The wheel in `dir` whose file name starts with `prefix` (`gymnasium-1.4.0-`).
fn wheel(dir: &Path, prefix: &str) -> Result<PathBuf, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(prefix) && n.ends_with(".whl"))
        })
        .ok_or_else(|| format!("no {prefix}*.whl in {} after pip download", dir.display()))
}

/// Downloads and extracts the models unless the stamp says they are there; returns the
/// Python of the MuJoCo virtual environment.
pub fn fetch() -> Result<PathBuf, String> {
    let dir = models_dir();
    let stamp = dir.join("stamp");
    let python = ensure_venv()?;
    if std::fs::read_to_string(&stamp).ok() == Some(stamp_text()) && missing(&dir).is_empty() {
        return Ok(python);
    }
    let t0 = Instant::now();
    let wheels = dir.join("wheels");
    eprintln!(
        "xtask: pip download gymnasium=={GYMNASIUM_VERSION} dm-control=={DM_CONTROL_VERSION} \
         (no dependencies) into {}",
        wheels.display()
    );
    let out = Command::new(&python)
        .args(["-m", "pip", "download", "--disable-pip-version-check", "-q"])
        .args(["--no-deps", "--only-binary=:all:", "-d"])
        .arg(&wheels)
        .arg(format!("gymnasium=={GYMNASIUM_VERSION}"))
        .arg(format!("dm-control=={DM_CONTROL_VERSION}"))
        .output()
        .map_err(|e| format!("pip download: {e}"))?;
    if !out.status.success() {
        return Err(format!("pip download failed: {}", last_line(&out)));
    }
    let gym = wheel(&wheels, &format!("gymnasium-{GYMNASIUM_VERSION}-"))?;
    let dmc = wheel(&wheels, &format!("dm_control-{DM_CONTROL_VERSION}-"))?;
    let _ = std::fs::remove_file(&stamp);
    for suite in ["gymnasium", "dm_control"] {
        let d = dir.join(suite);
        if d.exists() {
            std::fs::remove_dir_all(&d).map_err(|e| format!("{}: {e}", d.display()))?;
        }
    }
    let out = Command::new(&python)
        .arg(script("models_extract.py", EXTRACT)?)
        .arg("--gymnasium")
        .arg(&gym)
        .arg("--dm-control")
        .arg(&dmc)
        .arg("--out")
        .arg(&dir)
        .arg("--check")
        .output()
        .map_err(|e| format!("running the extraction script: {e}"))?;
    if !out.status.success() {
        let line = last_line(&out);
        return Err(line
            .strip_prefix("extract: ")
            .map_or(line.clone(), str::to_string));
    }
    eprint!("{}", String::from_utf8_lossy(&out.stderr));
    let gone = missing(&dir);
    if !gone.is_empty() {
        let list: Vec<String> = gone.iter().map(|p| p.display().to_string()).collect();
        return Err(format!(
            "pinned model files missing after extraction: {}",
            list.join(", ")
        ));
    }
    std::fs::write(&stamp, stamp_text()).map_err(|e| format!("{}: {e}", stamp.display()))?;
    eprintln!(
        "xtask: {} models in {} ({:.1} s)",
        MODELS.len(),
        dir.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(python)
}

/// MuJoCo's figures for one model (a row of the script's TSV).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mujoco {
    pub name: String,
    /// `ok`, `load failed: …` or `diverged …`.
    pub status: String,
    pub nbody: Option<usize>,
    pub njnt: Option<usize>,
    pub nq: Option<usize>,
    pub nv: Option<usize>,
    pub nu: Option<usize>,
    /// As Python's repr wrote it, passed on to our binary as is.
    pub timestep: Option<String>,
    /// MuJoCo's name without `mjINT_`: `EULER`, `RK4`, `IMPLICITFAST`, …
    pub integrator: Option<String>,
    pub steps: Option<u64>,
    pub us_per_step: Option<f64>,
    pub max_ncon: Option<usize>,
    /// `passive` (qpos0, zero control), `perturbed` (the seeded state in `qpos`/`qvel`,
    /// zero control) or `controlled` (qpos0, the control file `ctrl`); a TSV without the
    /// column is all `passive`.
    pub case: String,
    /// Most joint and tendon limit rows active at any step.
    pub max_nlimit: Option<usize>,
    /// Time (s) of the first state with a contact; `None`: none.
    pub first_contact: Option<f64>,
    /// Height of the first body's origin at the end (m).
    pub root_z: Option<f64>,
    /// The initial state of the case (comma-separated, MuJoCo's order), as written.
    pub qpos: Option<String>,
    pub qvel: Option<String>,
    /// The control CSV of the case.
    pub ctrl: Option<String>,
}

/// Parses the script's TSV: an optional `#mujoco_version\tV` line, a header, rows;
/// columns by name; `-` is a missing value. Returns the version and the rows.
pub fn parse_mujoco(text: &str) -> Result<(Option<String>, Vec<Mujoco>), String> {
    let mut version = None;
    let mut lines = text.lines().enumerate().filter(|(_, l)| {
        if let Some(v) = l.strip_prefix("#mujoco_version\t") {
            version = Some(v.trim().to_string());
        }
        !l.starts_with('#') && !l.trim().is_empty()
    });
    let header: Vec<&str> = lines
        .next()
        .ok_or("no header line")?
        .1
        .split('\t')
        .collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or(format!("no column {name:?}"))
    };
    let cols: Vec<usize> = [
        "name",
        "status",
        "nbody",
        "njnt",
        "nq",
        "nv",
        "nu",
        "timestep",
        "steps",
        "us_per_step",
        "max_ncon",
        "integrator",
    ]
    .iter()
    .map(|c| col(c))
    .collect::<Result<_, _>>()?;
    let opt_col = |name: &str| header.iter().position(|h| *h == name);
    let extra: Vec<Option<usize>> = [
        "case",
        "max_nlimit",
        "qpos",
        "qvel",
        "ctrl",
        "first_contact",
        "root_z",
    ]
    .iter()
    .map(|c| opt_col(c))
    .collect();
    let real = |v: &str, i: usize| -> Result<f64, String> {
        v.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or(format!("line {}: {v:?} is not a number", i + 1))
    };
    let mut rows = Vec::new();
    for (i, line) in lines {
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() != header.len() {
            return Err(format!(
                "line {}: {} fields, header has {}",
                i + 1,
                f.len(),
                header.len()
            ));
        }
        let get = |k: usize| Some(f[cols[k]]).filter(|v| *v != "-");
        let get_x = |k: usize| extra[k].map(|c| f[c]).filter(|v| *v != "-");
        let count = |v: &str| -> Result<usize, String> {
            v.parse()
                .map_err(|_| format!("line {}: {v:?} is not a count", i + 1))
        };
        let num = |k: usize| get(k).map(count).transpose();
        let us = get(9)
            .map(|v| {
                v.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite() && *x >= 0.0)
                    .ok_or(format!("line {}: {v:?} is not a time", i + 1))
            })
            .transpose()?;
        let timestep = get(7)
            .map(|v| match v.parse::<f64>() {
                Ok(x) if x > 0.0 && x.is_finite() => Ok(v.to_string()),
                _ => Err(format!("line {}: {v:?} is not a time step", i + 1)),
            })
            .transpose()?;
        let case = get_x(0).unwrap_or("passive").to_string();
        if !CASES.contains(&case.as_str()) {
            return Err(format!("line {}: unknown case {case:?}", i + 1));
        }
        rows.push(Mujoco {
            name: f[cols[0]].to_string(),
            status: f[cols[1]].to_string(),
            nbody: num(2)?,
            njnt: num(3)?,
            nq: num(4)?,
            nv: num(5)?,
            nu: num(6)?,
            timestep,
            steps: num(8)?.map(|s| s as u64),
            us_per_step: us,
            max_ncon: num(10)?,
            integrator: get(11).map(str::to_string),
            case,
            max_nlimit: get_x(1).map(count).transpose()?,
            qpos: get_x(2).map(str::to_string),
            qvel: get_x(3).map(str::to_string),
            ctrl: get_x(4).map(str::to_string),
            first_contact: get_x(5).map(|v| real(v, i)).transpose()?,
            root_z: get_x(6).map(|v| real(v, i)).transpose()?,
        });
    }
    Ok((version, rows))
}

/// The cases of one model, in table order (see `xtask/models/mujoco_models.py`).
pub const CASES: [&str; 3] = ["passive", "perturbed", "controlled"];

/// Our side of one case.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ours {
    /// A zero-duration run succeeded (the file loads and the scene builds).
    pub loads: bool,
    /// `None`: ran the whole window; otherwise the binary's one-line reason.
    pub error: Option<String>,
    pub us_per_step: Option<f64>,
    /// The run's figures (`simulate --summary`), when it finished.
    pub summary: Option<Summary>,
    /// The binary panicked (exit status 101 or a panic message).
    pub panicked: bool,
}

/// Our binary's µs per step from its success line: `… (S s stepping, U µs/step)`, or the
/// seconds over `steps` when the µs are not printed.
pub fn parse_stepping(stderr: &str, steps: Option<u64>) -> Option<f64> {
    let line = stderr.lines().rev().find(|l| l.contains(" s stepping"))?;
    if let Some(us) = line
        .split(", ")
        .find_map(|p| p.trim_end_matches(')').strip_suffix(" µs/step"))
    {
        return us.trim().parse().ok();
    }
    let secs: f64 = line
        .split(" s stepping")
        .next()?
        .rsplit('(')
        .next()?
        .trim()
        .parse()
        .ok()?;
    steps.filter(|&s| s > 0).map(|s| secs / s as f64 * 1e6)
}

/// The reason in a failed run's output: the first non-empty line of stderr (then stdout)
/// that is not a loader warning, without the binary's `simulate: ` prefix; a panic is
/// named by its message line.
pub fn reason(stderr: &str, stdout: &str) -> String {
    let lines = || {
        stderr
            .lines()
            .chain(stdout.lines())
            .map(str::trim)
            .filter(|l| !l.is_empty())
    };
    if let Some(p) = lines().find(|l| l.contains("panicked at")) {
        return p.to_string();
    }
    lines()
        .find(|l| !l.starts_with("warning: "))
        .or_else(|| lines().next())
        .map_or("no output".to_string(), |l| {
            l.strip_prefix("simulate: ").unwrap_or(l).to_string()
        })
}

/// What a finished child process left: exit code (`None`: killed by a signal), stdout,
/// stderr.
struct Finished {
    code: Option<i32>,
    out: String,
    err: String,
}

impl Finished {
    fn ok(&self) -> bool {
        self.code == Some(0)
    }

    /// Rust's panic exit status, or a panic message.
    fn panicked(&self) -> bool {
        self.code == Some(101) || self.err.contains("panicked at")
    }
}

/// Runs `cmd` with a wall-clock limit; returns what it left, or why not.
fn run_limited(cmd: &mut Command, limit: Duration) -> Result<Finished, String> {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start: {e}"))?;
    // Readers on threads, so a chatty child cannot block on a full pipe.
    let take = |p: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = Vec::new();
            if let Some(mut p) = p {
                let _ = p.read_to_end(&mut s);
            }
            String::from_utf8_lossy(&s).into_owned()
        })
    };
    let out = take(child.stdout.take().map(|p| Box::new(p) as _));
    let err = take(child.stderr.take().map(|p| Box::new(p) as _));
    let t0 = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break s,
            Ok(None) if t0.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("stopped after {} s (time limit)", limit.as_secs()));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(5)),
            Err(e) => return Err(format!("waiting for it: {e}")),
        }
    };
    Ok(Finished {
        code: status.code(),
        out: out.join().unwrap_or_default(),
        err: err.join().unwrap_or_default(),
    })
}

/// Does the file load in our binary (a zero-duration run)? `Err`: the reason, and whether
/// it panicked.
fn loads(bin: &Path, xml: &Path, out: &Path, limit: Duration) -> Result<(), (String, bool)> {
    let mut c = Command::new(bin);
    c.arg(xml).args(["--duration", "0", "--out"]).arg(out);
    match run_limited(&mut c, limit) {
        Ok(f) if f.ok() => Ok(()),
        Ok(f) => Err((reason(&f.err, &f.out), f.panicked())),
        Err(e) => Err((e, false)),
    }
}

/// Our binary's command line for one case: MuJoCo's step and step count (the file's
/// step and `seconds` without them), its initial state and control file, a trajectory
/// row every `every` steps (0: only the last) into `out`, the summary into `summary`.
/// Returns the command and the step count (`None`: MuJoCo gave none).
fn ours_command(
    bin: &Path,
    xml: &Path,
    mj: &Mujoco,
    seconds: f64,
    every: u64,
    out: &Path,
    summary: &Path,
) -> (Command, Option<u64>) {
    let mut c = Command::new(bin);
    c.arg(xml);
    let steps = match (&mj.timestep, mj.steps) {
        (Some(dt), Some(n)) => {
            let h: f64 = dt.parse().unwrap_or(f64::NAN);
            c.args(["--dt", dt, "--duration", &format!("{}", n as f64 * h)]);
            Some(n)
        }
        _ => {
            c.args(["--duration", &format!("{seconds}")]);
            None
        }
    };
    let every = if every == 0 {
        steps.unwrap_or(1_000_000_000).max(1)
    } else {
        every
    };
    c.args(["--every", &every.to_string()]);
    if let Some(q) = &mj.qpos {
        c.args(["--qpos", q]);
    }
    if let Some(v) = &mj.qvel {
        c.args(["--qvel", v]);
    }
    if let Some(u) = &mj.ctrl {
        c.args(["--ctrl", u]);
    }
    c.arg("--summary").arg(summary).arg("--out").arg(out);
    (c, steps)
}

/// One case of a model that loads, in our binary ([`ours_command`]; the summary into
/// `out` with `.json`); run `repeats` times, the median time per step.
#[allow(clippy::too_many_arguments)]
fn ours_case(
    bin: &Path,
    xml: &Path,
    mj: &Mujoco,
    seconds: f64,
    every: u64,
    repeats: usize,
    out: &Path,
    limit: Duration,
) -> Ours {
    let summary = out.with_extension("json");
    let _ = std::fs::remove_file(&summary);
    let (mut c, steps) = ours_command(bin, xml, mj, seconds, every, out, &summary);
    let first = ours_run(&mut c, &summary, steps, limit);
    // Further runs of a case that finished only time it again (the same bits: the step
    // is deterministic); the time per step is the median, as MuJoCo's.
    let mut times: Vec<f64> = first.us_per_step.into_iter().collect();
    for _ in 1..repeats.max(1) {
        if first.error.is_some() {
            break;
        }
        if let Some(t) = ours_run(&mut c, &summary, steps, limit).us_per_step {
            times.push(t);
        }
    }
    times.sort_by(f64::total_cmp);
    Ours {
        us_per_step: times.get(times.len() / 2).copied(),
        ..first
    }
}

/// The interleaved timing of a case both engines finished ([`timing`]): `k` repeats,
/// ours a run of the same case with only its last row written (to
/// `work/<stem>.timing.csv`, the first run's files stay as they are), MuJoCo one rollout
/// in `timer`. `Err`: why there is no figure.
#[allow(clippy::too_many_arguments)]
fn paired_case(
    timer: &mut timing::Timer,
    bin: &Path,
    xml: &Path,
    mj: &Mujoco,
    seconds: f64,
    k: usize,
    work: &Path,
    stem: &str,
    limit: Duration,
) -> Result<Paired, String> {
    let steps = mj.steps.ok_or("MuJoCo gave no step count")?;
    let request = timing::request(
        xml,
        mj.qpos.as_deref(),
        mj.qvel.as_deref(),
        mj.ctrl.as_deref(),
        steps,
    )?;
    let out = work.join(format!("{stem}.timing.csv"));
    let summary = work.join(format!("{stem}.timing.json"));
    let (mut c, steps) = ours_command(bin, xml, mj, seconds, 0, &out, &summary);
    let ours = || {
        let _ = std::fs::remove_file(&summary);
        let o = ours_run(&mut c, &summary, steps, limit);
        match (o.error, o.us_per_step) {
            (Some(e), _) => Err(e),
            (None, Some(t)) => Ok(t),
            (None, None) => Err("no time per step in the summary".into()),
        }
    };
    let pairs = timing::interleave(k, ours, || timer.time(&request))?;
    Paired::from_pairs(&pairs).ok_or_else(|| "no positive times to take a ratio of".into())
}

/// One run of our binary for [`ours_case`].
fn ours_run(c: &mut Command, summary: &Path, steps: Option<u64>, limit: Duration) -> Ours {
    match run_limited(c, limit) {
        Ok(f) if f.ok() => {
            let sum = std::fs::read_to_string(summary)
                .map_err(|e| format!("{}: {e}", summary.display()))
                .and_then(|t| parse_summary(&t));
            match sum {
                Ok(s) => Ours {
                    loads: true,
                    error: None,
                    us_per_step: s.us_per_step.or_else(|| parse_stepping(&f.err, steps)),
                    summary: Some(s),
                    panicked: false,
                },
                Err(e) => Ours {
                    loads: true,
                    error: Some(e),
                    ..Ours::default()
                },
            }
        }
        Ok(f) => Ours {
            loads: true,
            error: Some(reason(&f.err, &f.out)),
            panicked: f.panicked(),
            ..Ours::default()
        },
        Err(e) => Ours {
            loads: true,
            error: Some(e),
            ..Ours::default()
        },
    }
}

/// One case of one model: both engines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Case {
    pub mujoco: Mujoco,
    pub ours: Ours,
    /// The interleaved timing ([`timing`]); `None`: not timed so, see `timing_note`.
    pub paired: Option<Paired>,
    /// Why the case has no interleaved timing (`None` when it has one, or with
    /// `--repeats 0`).
    pub timing_note: Option<String>,
}

impl Case {
    /// Ours and MuJoCo's µs per step and the ratio: the interleaved medians where the
    /// case has them, else the separate runs' figures (timed minutes apart).
    pub fn times(&self) -> (Option<f64>, Option<f64>, Option<f64>) {
        match &self.paired {
            Some(p) => (Some(p.ours_us), Some(p.mujoco_us), Some(p.ratio)),
            None => {
                let (a, b) = (self.ours.us_per_step, self.mujoco.us_per_step);
                (a, b, separate_ratio(a, b))
            }
        }
    }

    /// The spread cell: the per-repeat ratios' quartiles `q1 … q3`, or `–`.
    pub fn spread(&self) -> String {
        self.paired.as_ref().map_or("–".into(), Paired::spread)
    }

    /// The checks this case fails (empty: passes, or did not run).
    pub fn failed_checks(&self) -> Vec<String> {
        self.ours
            .summary
            .as_ref()
            .map_or_else(Vec::new, |s| checks(&self.mujoco.case, s))
    }

    /// A regression that fails the run (see [`fatal`]).
    pub fn fatal(&self) -> bool {
        fatal(
            self.ours.loads,
            self.ours.panicked,
            self.ours.error.as_deref(),
            self.ours.summary.as_ref(),
        )
    }
}

/// The smooth-model comparison: centre-of-mass error (m) against MuJoCo RK4 at a tenth
/// of the file's step, ours at the file's step and MuJoCo Euler at the file's step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Smooth {
    pub ours: Option<f64>,
    pub euler: Option<f64>,
    /// Why a figure is missing.
    pub note: Option<String>,
}

/// One model: its cases (passive first), and the smooth comparison where it applies.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row {
    pub suite: String,
    pub name: String,
    pub cases: Vec<Case>,
    pub smooth: Option<Smooth>,
}

impl Row {
    /// The passive case (every model has one, if only to say why it did not load).
    pub fn passive(&self) -> Case {
        self.case("passive").cloned().unwrap_or_default()
    }

    pub fn case(&self, name: &str) -> Option<&Case> {
        self.cases.iter().find(|c| c.mujoco.case == name)
    }

    pub fn loads(&self) -> bool {
        self.cases.iter().any(|c| c.ours.loads)
    }
}

/// A smooth model: MuJoCo's perturbed passive run met no contact and no limit, and
/// ours none either.
pub fn is_smooth(row: &Row) -> bool {
    row.case("perturbed").is_some_and(|c| {
        c.mujoco.status == "ok"
            && c.mujoco.max_ncon == Some(0)
            && c.mujoco.max_nlimit == Some(0)
            && c.ours.summary.as_ref().is_some_and(|s| s.max_contacts == 0)
    })
}

/// Ours over MuJoCo's, where both have a time.
fn separate_ratio(ours: Option<f64>, mujoco: Option<f64>) -> Option<f64> {
    match (ours, mujoco) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

fn opt<T: ToString>(v: &Option<T>) -> String {
    v.as_ref().map_or("–".into(), T::to_string)
}

fn us(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| format!("{t:.2}"))
}

fn secs(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| format!("{t:.3}"))
}

fn height(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| format!("{t:.4}"))
}

fn sci(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| format!("{t:.1e}"))
}

/// A table cell: no pipes or line breaks.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace(['\n', '\r'], " ")
}

/// `ours: loads? / reason`.
fn ours_status(o: &Ours) -> String {
    match (o.loads, &o.error) {
        (true, None) => "yes, ran".into(),
        (true, Some(e)) if o.panicked => format!("yes; PANIC: {e}"),
        (true, Some(e)) => format!("yes; failed: {e}"),
        (false, Some(e)) => format!("no: {e}"),
        (false, None) => "no".into(),
    }
}

/// MuJoCo's cell: its time per step `t` (the interleaved median or its separate
/// run's), with its status where that is not `ok`.
fn mujoco_cell(m: &Mujoco, t: Option<f64>) -> String {
    match (&m.status[..], t) {
        ("ok", t) => us(t),
        (s, Some(t)) => format!("{} ({s})", us(Some(t))),
        (s, None) => s.to_string(),
    }
}

/// A ratio cell.
fn ratio_cell(r: Option<f64>) -> String {
    fmt_ratio(r, Some(1.0))
}

/// How the time columns are measured: the note under [`timing_table`].
pub const TIMING_NOTE: &str = "Times per step and the ratio come from interleaved \
     repeats: per case, after the checked runs, our `simulate` (only its last row written; \
     µs per step measured inside its step loop) and MuJoCo's `mujoco.rollout` (one \
     long-lived Python process, the model loaded once, one untimed warm-up rollout) each \
     run the case's steps K times, alternately and close together (ours first in even \
     repeats, MuJoCo first in odd ones), so both see the same machine state; ours / \
     MuJoCo is the median of the per-repeat ratios, the spread their quartiles (nearest \
     rank; smallest and largest in models.csv), \
     the µs columns each engine's median over the same repeats (K: `--repeats`, \
     `timing_repeats` in models.csv). A spread of – marks a case not timed so (it did not \
     finish in one engine): its figures are the separate runs', timed minutes apart.";

/// The checks cell of a case: `ok`, what failed, or why it did not run.
fn checks_cell(c: &Case) -> String {
    match (&c.ours.summary, &c.ours.error) {
        (Some(_), _) => {
            let f = c.failed_checks();
            if f.is_empty() {
                "ok".into()
            } else {
                f.join("; ")
            }
        }
        (None, Some(_)) if c.ours.loads => "did not finish".into(),
        _ => "–".into(),
    }
}

/// `target/models/models.md`.
/// The time-per-step table of [`markdown`] (one row per model, its passive case: counts,
/// MuJoCo's µs per step, whether ours loads, ours µs per step and the ratio), also the
/// `models` section of `cargo xtask bench`'s `ratios.md`.
pub fn timing_table(rows: &[Row]) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "| model | suite | nbody | njnt | nu | timestep (s) | integrator | contacts / limits (MuJoCo) | MuJoCo µs/step | ours: loads? / reason | ours µs/step | ours / MuJoCo | spread |"
    );
    let _ = writeln!(
        md,
        "|---|---|---:|---:|---:|---:|---|---:|---:|---|---:|---:|---:|"
    );
    for r in rows {
        let c = r.passive();
        let m = &c.mujoco;
        let p = r.case("perturbed").map(|c| &c.mujoco);
        let (ours, theirs, ratio) = c.times();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {} |",
            cell(&r.name),
            r.suite,
            opt(&m.nbody),
            opt(&m.njnt),
            opt(&m.nu),
            opt(&m.timestep),
            opt(&m.integrator),
            opt(&p.and_then(|p| p.max_ncon)),
            opt(&p.and_then(|p| p.max_nlimit)),
            cell(&mujoco_cell(m, theirs)),
            cell(&ours_status(&c.ours)),
            us(ours),
            ratio_cell(ratio),
            c.spread(),
        );
    }
    let _ = writeln!(md, "\n{TIMING_NOTE}");
    md
}

pub fn markdown(rows: &[Row], version: Option<&str>, seconds: f64, ctrl_seconds: f64) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# MuJoCo models: MuJoCo against this library\n\n\
         gymnasium {GYMNASIUM_VERSION} and dm_control {DM_CONTROL_VERSION} models, MuJoCo {}, \
         at the file's time step. Cases: **passive** {seconds} s from the default pose with \
         zero control; **perturbed** {seconds} s, zero control, from qpos0 plus a seeded \
         perturbation (hinges ±0.2 rad, slides ±0.02 m, inside their ranges, limited \
         tendons inside theirs; those dofs' velocities ±0.2), the same state given to both \
         engines with `--qpos/--qvel`; **controlled** {ctrl_seconds} s from qpos0 under one \
         seeded control sequence (a new value every 0.05 s, uniform in ctrlrange; \
         `target/models/work/*.ctrl.csv`). MuJoCo: `mujoco.rollout` (its C loop, one \
         thread); counts \
         are MuJoCo's (nbody includes the world body); contacts and limits: most at any step \
         of the perturbed run. Ours: the `simulate` binary (release, default method); \
         \"loads\" means a zero-length run succeeded, the reason is its one-line error. \
         Ratio below 1: this library is faster.\n",
        version.unwrap_or("?")
    );
    md.push_str(&timing_table(rows));
    let _ = writeln!(
        md,
        "\n## Checks (ours)\n\n\
         Per case: worst joint separation at any step (tolerance {JOINT_TOL:.0e} m), deepest \
         penetration over the second half of the run (settled; {PENETRATION_TOL:.0e} m), most \
         contacts, largest rise of the total energy above its start (checked, within \
         {ENERGY_REL_TOL:.0e}·(1 + |E₀|), on the runs without control and without contact), \
         time of the first contact and height of the first (root) body at the end in both \
         engines (what both must agree on when their contacts differ: MuJoCo's are soft, \
         ours hard), time per step against MuJoCo's on the same case, and the steps whose \
         contact solve went to the dense path and ended above its tolerance (the staggered \
         alternations capped or stalled; the answer is kept and counted here, and the \
         penetration and energy checks judge it).\n"
    );
    let _ = writeln!(
        md,
        "| model | case | ours: ran? | ours µs/step | MuJoCo µs/step | ours / MuJoCo | spread | joints (m) | settled penetration (m) | contacts | first contact (s), ours / MuJoCo | root z at the end (m), ours / MuJoCo | energy rise (J) | unconverged dense steps (worst residual) | checks |"
    );
    let _ = writeln!(
        md,
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
    );
    for r in rows.iter().filter(|r| r.loads()) {
        for c in &r.cases {
            let s = c.ours.summary.as_ref();
            let (ours, theirs, ratio) = c.times();
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} / {} | {} / {} | {} | {} | {} |",
                cell(&format!("{}/{}", r.suite, r.name)),
                c.mujoco.case,
                cell(&ours_status(&c.ours)),
                us(ours),
                cell(&mujoco_cell(&c.mujoco, theirs)),
                ratio_cell(ratio),
                c.spread(),
                sci(s.map(|s| s.max_joint_separation)),
                sci(s.map(|s| s.settled_penetration)),
                opt(&s.map(|s| s.max_contacts)),
                secs(s.and_then(|s| s.first_contact_time)),
                secs(c.mujoco.first_contact),
                height(s.and_then(|s| s.root_height)),
                height(c.mujoco.root_z),
                sci(s.map(|s| s.max_energy_increase)),
                unconverged(s),
                cell(&checks_cell(c)),
            );
        }
    }
    let smooth: Vec<&Row> = rows.iter().filter(|r| r.smooth.is_some()).collect();
    let _ = writeln!(
        md,
        "\n## Smooth models: trajectory error\n\n\
         The models whose perturbed passive run meets no contact and no limit (in MuJoCo and \
         here): largest centre-of-mass error over the run (m, every step of the file's step \
         compared) against MuJoCo RK4 at a tenth of the file's step, from the perturbed \
         state. Ours (default method) and MuJoCo Euler both at the file's step.\n\n\
         | model | timestep (s) | ours (m) | MuJoCo Euler (m) | ours / Euler | note |\n\
         |---|---:|---:|---:|---:|---|"
    );
    for r in &smooth {
        let Some(s) = &r.smooth else { continue };
        let _ = writeln!(
            md,
            "| {}/{} | {} | {} | {} | {} | {} |",
            r.suite,
            cell(&r.name),
            opt(&r.passive().mujoco.timestep),
            sci(s.ours),
            sci(s.euler),
            fmt_ratio(s.ours, s.euler),
            cell(s.note.as_deref().unwrap_or(""))
        );
    }
    let loaded = rows.iter().filter(|r| r.loads()).count();
    let ran = rows
        .iter()
        .filter(|r| r.loads() && r.cases.iter().all(|c| c.ours.error.is_none()))
        .count();
    let clean = rows
        .iter()
        .filter(|r| {
            r.loads()
                && r.cases
                    .iter()
                    .all(|c| c.ours.summary.is_some() && c.failed_checks().is_empty())
        })
        .count();
    let fatal: Vec<String> = fatal_cases(rows);
    let _ = writeln!(
        md,
        "\n{} models; ours loads {loaded}, runs every case to the end on {ran}, passes every \
         check on {clean}; {} smooth; {} regressions (a panic, or a loaded model that \
         diverges){}.\n\n\
         - `lqr_2_1` and `swimmer6` are generated from dm_control's `lqr.xml` and \
         `swimmer.xml` templates the way `lqr.py` and `swimmer.py` do (lqr's joint \
         stiffnesses: the draws of `numpy.random.RandomState(0)`; dm_control draws new ones \
         on every load). The other files are used as shipped: dm_control's task code \
         edits some of them before loading, not done here: dog (floor size; removes ball, \
         walls), quadruped (floor size; removes walls, ball, the terrain height field and \
         the rangefinders unless a task uses them), manipulator (ball or peg), stacker \
         (number of boxes).\n\
         - Each engine's time alone moves by tens of per cent between runs on a shared \
         machine (its speed drifts over minutes); the interleaved ratio moves less, and \
         its spread says how far to trust it. A repeat of a few milliseconds that the \
         scheduler interrupts (more cores' worth of other work than cores) inflates that \
         repeat's ratio: the median resists it while fewer than half are hit, the upper \
         quartile shows it. Models on RK4 (most gymnasium ones, acrobot, \
         cartpole) pay four evaluations per step.\n\
         - Contact-rich models part from MuJoCo after the first impact (MuJoCo's contacts \
         are soft, ours hard): only the checks above are compared for them, not \
         trajectories.",
        rows.len(),
        smooth.len(),
        fatal.len(),
        if fatal.is_empty() {
            String::new()
        } else {
            format!(": {}", fatal.join(", "))
        }
    );
    md
}

/// `suite/model case` of every case that is a regression (see [`fatal`]).
pub fn fatal_cases(rows: &[Row]) -> Vec<String> {
    rows.iter()
        .flat_map(|r| {
            r.cases
                .iter()
                .filter(|c| c.fatal())
                .map(move |c| format!("{}/{} {}", r.suite, r.name, c.mujoco.case))
        })
        .collect()
}

/// A CSV field (RFC 4180): quoted when it holds a comma, quote or line break.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The dense steps that ended above their tolerance, with the worst residual: `0`,
/// `N (r)`, or `–` where the binary did not report them.
fn unconverged(s: Option<&Summary>) -> String {
    match s.and_then(|s| {
        s.unconverged_steps
            .map(|n| (n, s.worst_unconverged_residual))
    }) {
        None => "–".into(),
        Some((0, _)) => "0".into(),
        Some((n, r)) => format!("{n} ({})", sci(r)),
    }
}

pub const CSV_HEADER: &str = "model,suite,case,nbody,njnt,nq,nv,nu,timestep,integrator,steps,\
max_ncon,max_nlimit,mujoco_status,mujoco_us_per_step,ours_loads,ours_error,ours_panicked,\
ours_us_per_step,ratio,finite,max_joint_separation,max_penetration,settled_penetration,\
energy_initial,max_energy_increase,ours_max_contacts,energy_checked,checks,fatal,\
smooth_ours_com,smooth_euler_com,smooth_note,ours_first_contact,mujoco_first_contact,\
ours_root_z,mujoco_root_z,ours_unconverged_steps,ours_worst_unconverged_residual,\
ratio_q1,ratio_q3,ratio_min,ratio_max,timing_repeats,timing_note,ours_us_per_step_separate,\
mujoco_us_per_step_separate,ratio_separate";

/// `models.csv`: one line per model and case (the smooth figures on the perturbed line),
/// empty fields where there is none. `constraint_verify::models_report` reads it.
/// `ours_us_per_step`, `mujoco_us_per_step` and `ratio` are the interleaved figures
/// ([`Case::times`]; `ratio`: the median per-repeat ratio, `ratio_q1`/`ratio_q3` its
/// quartiles, `ratio_min`/`ratio_max` its extremes); the `*_separate` columns keep the separate runs' figures (timed minutes
/// apart), as the columns held before the interleaved timing.
pub fn csv(rows: &[Row]) -> String {
    let e = |v: Option<String>| v.unwrap_or_default();
    let g = |v: Option<f64>| e(v.map(|v| format!("{v:e}")));
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        for c in &r.cases {
            let m = &c.mujoco;
            let s = c.ours.summary.as_ref();
            let (ours_us, mujoco_us, ratio) = c.times();
            let p = c.paired.as_ref();
            let smooth = r.smooth.as_ref().filter(|_| m.case == "perturbed");
            let f = [
                r.name.clone(),
                r.suite.clone(),
                m.case.clone(),
                e(m.nbody.map(|v| v.to_string())),
                e(m.njnt.map(|v| v.to_string())),
                e(m.nq.map(|v| v.to_string())),
                e(m.nv.map(|v| v.to_string())),
                e(m.nu.map(|v| v.to_string())),
                e(m.timestep.clone()),
                e(m.integrator.clone()),
                e(m.steps.map(|v| v.to_string())),
                e(m.max_ncon.map(|v| v.to_string())),
                e(m.max_nlimit.map(|v| v.to_string())),
                m.status.clone(),
                e(mujoco_us.map(|v| format!("{v:.3}"))),
                c.ours.loads.to_string(),
                e(c.ours.error.clone()),
                c.ours.panicked.to_string(),
                e(ours_us.map(|v| format!("{v:.3}"))),
                e(ratio.map(|v| format!("{v:.4}"))),
                e(s.map(|s| s.finite.to_string())),
                g(s.map(|s| s.max_joint_separation)),
                g(s.map(|s| s.max_penetration)),
                g(s.map(|s| s.settled_penetration)),
                g(s.map(|s| s.energy_initial)),
                g(s.map(|s| s.max_energy_increase)),
                e(s.map(|s| s.max_contacts.to_string())),
                e(s.map(|s| energy_checked(&m.case, s).to_string())),
                e(s.map(|_| c.failed_checks().join("; "))),
                c.fatal().to_string(),
                g(smooth.and_then(|s| s.ours)),
                g(smooth.and_then(|s| s.euler)),
                e(smooth.and_then(|s| s.note.clone())),
                g(s.and_then(|s| s.first_contact_time)),
                g(m.first_contact),
                g(s.and_then(|s| s.root_height)),
                g(m.root_z),
                e(s.and_then(|s| s.unconverged_steps).map(|v| v.to_string())),
                g(s.and_then(|s| s.worst_unconverged_residual)),
                e(p.map(|p| format!("{:.4}", p.ratio_q1))),
                e(p.map(|p| format!("{:.4}", p.ratio_q3))),
                e(p.map(|p| format!("{:.4}", p.ratio_min))),
                e(p.map(|p| format!("{:.4}", p.ratio_max))),
                e(p.map(|p| p.repeats.to_string())),
                e(c.timing_note.clone()),
                e(c.ours.us_per_step.map(|v| format!("{v:.3}"))),
                e(m.us_per_step.map(|v| format!("{v:.3}"))),
                e(separate_ratio(c.ours.us_per_step, m.us_per_step).map(|v| format!("{v:.4}"))),
            ];
            let line: Vec<String> = f.iter().map(|s| csv_field(s)).collect();
            out.push_str(&line.join(","));
            out.push('\n');
        }
    }
    out
}

/// Our `simulate` binary, built once (release).
fn build_simulate() -> Result<PathBuf, String> {
    eprintln!("xtask: cargo build --release -p constraint-scene --bin simulate");
    let ok = cargo()
        .args(["build", "--release", "--quiet", "-p", "constraint-scene"])
        .args(["--bin", "simulate"])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return Err("cargo build --release -p constraint-scene --bin simulate failed".into());
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map_or_else(|| root().join("target"), |t| root().join(t));
    let bin = target
        .join("release")
        .join(format!("simulate{}", std::env::consts::EXE_SUFFIX));
    if bin.is_file() {
        Ok(bin)
    } else {
        Err(format!("{}: not found after the build", bin.display()))
    }
}

/// Options of `run`.
#[derive(Debug, PartialEq)]
pub struct RunArgs {
    pub quick: bool,
    pub out: PathBuf,
    /// A `simulate` executable already built (`cargo xtask verify` passes the one of its
    /// release build); `None`: `cargo build --release -p constraint-scene` first.
    pub simulate: Option<PathBuf>,
}

/// What a whole run produced.
pub struct Suite {
    pub rows: Vec<Row>,
    /// MuJoCo's version, as its script reported it.
    pub version: Option<String>,
    /// Simulated seconds of the passive and perturbed cases.
    pub seconds: f64,
    /// `models.md`'s text.
    pub markdown: String,
    /// The regressions ([`fatal_cases`]).
    pub fatal: Vec<String>,
}

/// The smooth comparison of one model: MuJoCo RK4 at `h/10` (every 10th step kept) and
/// Euler at `h`, from the perturbed state, against our perturbed run `ours_csv`.
fn smooth(xml: &Path, mj: &Mujoco, ours_csv: &Path, work: &Path, stem: &str) -> Smooth {
    let (Some(dt), Some(n)) = (mj.timestep.as_deref(), mj.steps) else {
        return Smooth {
            note: Some("no time step from MuJoCo".into()),
            ..Smooth::default()
        };
    };
    let h: f64 = dt.parse().unwrap_or(f64::NAN);
    let duration = format!("{}", n as f64 * h);
    let mjrun = |integrator: &str, dt: String, every: usize, out: PathBuf| {
        let o = MjRun {
            scene: xml.to_path_buf(),
            dt: Some(dt),
            duration: duration.clone(),
            every,
            integrator: Some(integrator.into()),
            out: out.clone(),
            qpos: mj.qpos.clone(),
            qvel: mj.qvel.clone(),
            ..MjRun::default()
        };
        crate::mujoco::run(&o).map(|()| out)
    };
    let reference = mjrun(
        "rk4",
        format!("{:?}", h / 10.0),
        10,
        work.join(format!("{stem}.rk4.csv")),
    );
    let euler = mjrun(
        "euler",
        dt.to_string(),
        1,
        work.join(format!("{stem}.euler.csv")),
    );
    let mut notes = Vec::new();
    let mut err = |who: &str, a: Result<PathBuf, String>| -> Option<f64> {
        let r = reference.as_ref().map_err(|e| format!("MuJoCo RK4: {e}"));
        match a.and_then(|a| smooth_error(&a, r.as_ref().map_err(|e| e.clone())?)) {
            Ok((v, _)) => Some(v),
            Err(e) => {
                notes.push(format!("{who}: {e}"));
                None
            }
        }
    };
    let ours = err("ours", Ok(ours_csv.to_path_buf()));
    let euler = err("MuJoCo Euler", euler);
    notes.dedup();
    Smooth {
        ours,
        euler,
        note: (!notes.is_empty()).then(|| notes.join("; ")),
    }
}

/// Runs the suite: MuJoCo's side (one Python process), then ours per model and case, the
/// smooth comparisons; writes `models.md` and `models.csv` into `a.out`. `Err` only when
/// the suite could not run at all (MuJoCo missing, the download failed, the build failed).
pub fn run_suite(a: &RunArgs) -> Result<Suite, String> {
    run_models(a, &MODELS, default_repeats(a.quick))
}

/// Interleaved repeats per case of a full run ([`timing`]).
pub const REPEATS: usize = 15;
/// Interleaved repeats per case of a `--quick` run (what `cargo xtask verify` runs).
pub const QUICK_REPEATS: usize = 5;

/// The interleaved repeats per case without `--repeats`.
pub fn default_repeats(quick: bool) -> usize {
    if quick {
        QUICK_REPEATS
    } else {
        REPEATS
    }
}

/// [`run_suite`] on `models` only (a subset of [`MODELS`], `run --only`), with `k`
/// interleaved repeats per case (0: none).
fn run_models(a: &RunArgs, models: &[(&str, &str)], k: usize) -> Result<Suite, String> {
    let t0 = Instant::now();
    let python = fetch()?;
    let dir = models_dir();
    let (seconds, ctrl_seconds, repeats) = if a.quick {
        (QUICK_SECONDS, QUICK_SECONDS, 1)
    } else {
        (SECONDS, CTRL_SECONDS, 3)
    };
    let work = dir.join("work");
    if work.exists() {
        std::fs::remove_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    }
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;

    let list = work.join("list.tsv");
    let text: String = models
        .iter()
        .map(|(s, n)| format!("{s}/{n}\t{}\n", model_path(&dir, s, n).display()))
        .collect();
    std::fs::write(&list, text).map_err(|e| format!("{}: {e}", list.display()))?;
    let tsv = work.join("mujoco.tsv");
    eprintln!(
        "xtask: MuJoCo {MUJOCO_VERSION}: {} models, passive and perturbed {seconds} s, \
         controlled {ctrl_seconds} s (mujoco.rollout, median of {repeats})",
        models.len()
    );
    let out = Command::new(&python)
        .arg(script("models_mujoco.py", MEASURE)?)
        .arg("--list")
        .arg(&list)
        .args(["--duration", &seconds.to_string()])
        .args(["--ctrl-duration", &ctrl_seconds.to_string()])
        .args(["--repeats", &repeats.to_string()])
        .arg("--work")
        .arg(&work)
        .arg("--out")
        .arg(&tsv)
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("running MuJoCo's Python: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "MuJoCo measurements failed (exit status {})",
            out.status
        ));
    }
    let tsv_text = std::fs::read_to_string(&tsv).map_err(|e| format!("{}: {e}", tsv.display()))?;
    let (version, mj) = parse_mujoco(&tsv_text).map_err(|e| format!("{}: {e}", tsv.display()))?;
    let t_mujoco = t0.elapsed().as_secs_f64();

    let bin = match &a.simulate {
        Some(b) => b.clone(),
        None => build_simulate()?,
    };
    let limit = Duration::from_secs(if a.quick {
        OURS_TIMEOUT_S / 10
    } else {
        OURS_TIMEOUT_S
    });
    // MuJoCo's side of the interleaved repeats; without it the cases keep the separate
    // runs' figures, each with the reason.
    let mut timer = if k > 0 {
        let script_dir = root().join("target/xtask");
        timing::Timer::start(&python, &script_dir, limit).map_err(|e| {
            eprintln!("xtask: no interleaved timing: {e}");
            e
        })
    } else {
        Err(String::new())
    };
    let mut rows = Vec::new();
    for &(suite, name) in models {
        let key = format!("{suite}/{name}");
        let stem = format!("{suite}_{name}");
        let xml = model_path(&dir, suite, name);
        let mut cases: Vec<Mujoco> = mj.iter().filter(|m| m.name == key).cloned().collect();
        if cases.is_empty() {
            cases.push(Mujoco {
                name: key.clone(),
                status: "not measured".into(),
                case: "passive".into(),
                ..Mujoco::default()
            });
        }
        let mut row = Row {
            suite: suite.into(),
            name: name.into(),
            ..Row::default()
        };
        let loaded = loads(&bin, &xml, &work.join(format!("{stem}.load.csv")), limit);
        for m in cases {
            let ours = match &loaded {
                Err((e, panicked)) => Ours {
                    error: Some(e.clone()),
                    panicked: *panicked,
                    ..Ours::default()
                },
                Ok(()) => {
                    // The perturbed run of a model that may be smooth keeps every step.
                    let candidate = m.case == "perturbed"
                        && m.status == "ok"
                        && m.max_ncon == Some(0)
                        && m.max_nlimit == Some(0);
                    let out = work.join(format!("{stem}.{}.csv", m.case));
                    ours_case(
                        &bin,
                        &xml,
                        &m,
                        seconds,
                        u64::from(candidate),
                        repeats,
                        &out,
                        limit,
                    )
                }
            };
            let mut case = Case {
                mujoco: m,
                ours,
                ..Case::default()
            };
            if k > 0 {
                let timed = match (&mut timer, &case) {
                    (Err(e), _) => Err(e.clone()),
                    (_, c) if c.mujoco.status != "ok" || c.mujoco.us_per_step.is_none() => {
                        Err("MuJoCo's run did not finish".into())
                    }
                    (_, c) if !c.ours.loads => Err("ours does not load".into()),
                    (_, c) if c.ours.error.is_some() || c.ours.us_per_step.is_none() => {
                        Err("our run did not finish".into())
                    }
                    (Ok(t), c) => {
                        let stem = format!("{stem}.{}", c.mujoco.case);
                        paired_case(t, &bin, &xml, &c.mujoco, seconds, k, &work, &stem, limit)
                    }
                };
                match timed {
                    Ok(p) => case.paired = Some(p),
                    Err(e) => case.timing_note = Some(e),
                }
            }
            row.cases.push(case);
        }
        if is_smooth(&row) {
            if let Some(c) = row.case("perturbed") {
                let ours_csv = work.join(format!("{stem}.perturbed.csv"));
                row.smooth = Some(smooth(&xml, &c.mujoco, &ours_csv, &work, &stem));
            }
        }
        let p = row.passive();
        eprintln!(
            "xtask: ours {key}: {}{}{}{}",
            ours_status(&p.ours),
            p.ours
                .us_per_step
                .map_or(String::new(), |t| format!(", {t:.2} µs/step")),
            p.paired.as_ref().map_or(String::new(), |q| format!(
                "; interleaved: ours {:.2} µs/step, MuJoCo {:.2} µs/step, ours / MuJoCo {:.3} \
                 ({}, {} repeats)",
                q.ours_us,
                q.mujoco_us,
                q.ratio,
                q.spread(),
                q.repeats
            )),
            row.smooth.as_ref().map_or(String::new(), |s| format!(
                ", smooth: ours {} m, MuJoCo Euler {} m",
                sci(s.ours),
                sci(s.euler)
            ))
        );
        rows.push(row);
    }
    let md = markdown(&rows, version.as_deref(), seconds, ctrl_seconds);
    for (file, text) in [("models.md", md.clone()), ("models.csv", csv(&rows))] {
        let p = a.out.join(file);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    eprintln!(
        "xtask: wrote {} and models.csv ({:.1} s: MuJoCo and fetch {t_mujoco:.1} s)",
        a.out.join("models.md").display(),
        t0.elapsed().as_secs_f64()
    );
    let fatal = fatal_cases(&rows);
    Ok(Suite {
        rows,
        version,
        seconds,
        markdown: md,
        fatal,
    })
}

/// A model of [`MODELS`]: `(suite, name)`.
type Model = (&'static str, &'static str);

/// A model of `--only`: `SUITE/NAME` of [`MODELS`].
fn model(key: &str) -> Result<Model, String> {
    MODELS
        .iter()
        .find(|(s, n)| format!("{s}/{n}") == key)
        .copied()
        .ok_or_else(|| "no such model (see `cargo xtask models list`)".into())
}

/// The options of `cargo xtask models`.
#[derive(clap::Args, Clone, Debug, PartialEq)]
pub struct Options {
    /// What to do with the models.
    #[command(subcommand)]
    pub command: Subcommand,
}

/// The subcommands of `cargo xtask models`.
#[derive(clap::Subcommand, Clone, Debug, PartialEq)]
pub enum Subcommand {
    /// Download the pinned gymnasium and dm_control wheels (PyPI, no dependencies) and
    /// extract their 33 MJCF models into target/models/ (once; stamp file)
    Fetch,
    /// Fetch, then print the pinned models with their paths
    List,
    /// Fetch, then run every model in MuJoCo and in our simulate binary: models.md and
    /// models.csv
    ///
    /// Each model passive from qpos0 and from a seeded perturbed state, and under a seeded
    /// control sequence, in MuJoCo (mujoco.rollout) and in the simulate binary of
    /// constraint-scene, with per-model checks and time per step.
    Run(RunOptions),
}

/// The options of `cargo xtask models run`.
#[derive(clap::Args, Clone, Debug, PartialEq)]
pub struct RunOptions {
    /// 0.5 s runs, one separate repeat, 5 interleaved [default: off: 5 s passive and
    /// perturbed, 2 s controlled, MuJoCo's separate median of 3, 15 interleaved].
    #[arg(long)]
    pub quick: bool,
    /// Where models.md and models.csv go.
    #[arg(long, value_name = "DIR", default_value_os_t = models_dir())]
    pub out: PathBuf,
    /// Run these models alone, SUITE/NAME comma-separated or repeated, e.g.
    /// gymnasium/ant,dm_control/humanoid [default: all 33].
    #[arg(long, value_name = "SUITE/NAME,...", value_delimiter = ',', value_parser = model)]
    pub only: Vec<Model>,
    /// Interleaved timing repeats per case: ours and MuJoCo alternately, K runs each,
    /// the ratio the median of the per-repeat ratios; 0: none (the separate runs'
    /// figures) [default: 15; with --quick 5].
    #[arg(long, value_name = "K")]
    pub repeats: Option<usize>,
}

impl RunOptions {
    /// The run's arguments (our `simulate` built by the run).
    pub fn args(&self) -> RunArgs {
        RunArgs {
            quick: self.quick,
            out: self.out.clone(),
            simulate: None,
        }
    }

    /// The models of `--only`, each once, in [`MODELS`]' order (all without it).
    pub fn models(&self) -> Vec<Model> {
        MODELS
            .iter()
            .filter(|m| self.only.is_empty() || self.only.contains(m))
            .copied()
            .collect()
    }

    /// The interleaved repeats per case: `--repeats`, or [`default_repeats`].
    pub fn repeats(&self) -> usize {
        self.repeats.unwrap_or(default_repeats(self.quick))
    }
}

fn run(a: &RunArgs, models: &[(&str, &str)], k: usize) -> Result<(), String> {
    let suite = run_models(a, models, k)?;
    println!("{}", suite.markdown);
    if suite.fatal.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} loaded model case(s) panicked or diverged: {}",
            suite.fatal.len(),
            suite.fatal.join(", ")
        ))
    }
}

/// Runs `cargo xtask models <subcommand>`.
pub fn main(o: &Options) -> Result<(), String> {
    match &o.command {
        Subcommand::Fetch => fetch().map(|_| ()),
        Subcommand::List => {
            fetch()?;
            let dir = models_dir();
            for (s, n) in MODELS {
                println!("{s:<10} {n:<24} {}", model_path(&dir, s, n).display());
            }
            Ok(())
        }
        Subcommand::Run(r) => run(&r.args(), &r.models(), r.repeats()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pinned_list_is_both_suites_with_the_templates_replaced() {
        let count = |s: &str| MODELS.iter().filter(|(x, _)| *x == s).count();
        assert_eq!(count("gymnasium"), 14);
        assert_eq!(count("dm_control"), 19);
        assert_eq!(count("gymnasium") + count("dm_control"), MODELS.len());
        for (i, a) in MODELS.iter().enumerate() {
            assert!(!MODELS[..i].contains(a), "{a:?} twice");
            assert!(
                !a.1.is_empty() && !a.1.contains(['/', '\\', '.']),
                "{a:?} is not a file stem"
            );
        }
        for generated in ["lqr_2_1", "swimmer6"] {
            assert!(MODELS.contains(&("dm_control", generated)));
        }
        for template in ["lqr", "swimmer"] {
            assert!(!MODELS.contains(&("dm_control", template)));
        }
        // The generated files are what the extraction script writes.
        assert!(EXTRACT.contains("\"lqr_2_1\": make_lqr("));
        assert!(EXTRACT.contains("\"swimmer6\": make_swimmer("));
    }

    #[test]
    fn missing_names_exactly_the_absent_files() {
        let dir = root().join("target/xtask/test-models-missing");
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(missing(&dir).len(), MODELS.len());
        for (s, n) in MODELS.iter().step_by(2) {
            let p = model_path(&dir, s, n);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, "<mujoco/>").unwrap();
        }
        let gone = missing(&dir);
        assert_eq!(gone.len(), MODELS.len() / 2);
        for (i, (s, n)) in MODELS.iter().enumerate() {
            assert_eq!(gone.contains(&model_path(&dir, s, n)), i % 2 == 1);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn mujoco_rows_are_read_by_column_name() {
        // Columns in another order than the script writes them, a failed load, a
        // diverged run.
        let text = "#mujoco_version\t9.9.9\n\
            integrator\tmax_ncon\tus_per_step\tsteps\ttimestep\tnu\tnv\tnq\tnjnt\tnbody\tstatus\tname\n\
            RK4\t4\t23.5\t500\t0.01\t8\t14\t15\t9\t14\tok\tgymnasium/ant\n\
            -\t-\t-\t-\t-\t-\t-\t-\t-\t-\tload failed: XML Error\tdm_control/x\n\
            EULER\t0\t1.5\t10\t0.5\t0\t1\t1\t1\t2\tdiverged (MuJoCo warning mjWARN_BADQACC)\ty\n";
        let (v, rows) = parse_mujoco(text).unwrap();
        assert_eq!(v.as_deref(), Some("9.9.9"));
        assert_eq!(rows.len(), 3);
        let ant = &rows[0];
        assert_eq!(ant.name, "gymnasium/ant");
        assert_eq!(
            (ant.nbody, ant.njnt, ant.nq, ant.nv, ant.nu),
            (Some(14), Some(9), Some(15), Some(14), Some(8))
        );
        assert_eq!(ant.timestep.as_deref(), Some("0.01"));
        assert_eq!(
            (ant.steps, ant.us_per_step, ant.max_ncon),
            (Some(500), Some(23.5), Some(4))
        );
        assert_eq!(ant.integrator.as_deref(), Some("RK4"));
        assert_eq!(rows[2].integrator.as_deref(), Some("EULER"));
        assert_eq!(rows[1].status, "load failed: XML Error");
        assert_eq!(
            rows[1],
            Mujoco {
                name: "dm_control/x".into(),
                status: rows[1].status.clone(),
                case: "passive".into(),
                ..Mujoco::default()
            }
        );
        assert!(rows[2].status.starts_with("diverged"));

        // The script's columns of today: cases, limits, the perturbed state, controls.
        let text = "name\tcase\tstatus\tnbody\tnjnt\tnq\tnv\tnu\ttimestep\tintegrator\tsteps\t\
            us_per_step\tmax_ncon\tmax_nlimit\tqpos\tqvel\tctrl\n\
            p\tperturbed\tok\t2\t1\t1\t1\t1\t0.02\tEULER\t25\t8.9\t0\t0\t-0.18\t0.11\t-\n\
            p\tcontrolled\tok\t2\t1\t1\t1\t1\t0.02\tEULER\t25\t8.1\t0\t1\t-\t-\tw/p.ctrl.csv\n";
        let (_, rows) = parse_mujoco(text).unwrap();
        assert_eq!(rows[0].case, "perturbed");
        assert_eq!(
            (
                rows[0].qpos.as_deref(),
                rows[0].qvel.as_deref(),
                rows[0].ctrl.as_deref()
            ),
            (Some("-0.18"), Some("0.11"), None)
        );
        assert_eq!(
            (rows[1].max_nlimit, rows[1].ctrl.as_deref()),
            (Some(1), Some("w/p.ctrl.csv"))
        );
        let bad = text.replace("controlled", "sideways");
        assert!(parse_mujoco(&bad).unwrap_err().contains("unknown case"));

        let header =
            "name\tstatus\tnbody\tnjnt\tnq\tnv\tnu\ttimestep\tsteps\tus_per_step\tmax_ncon\tintegrator\n";
        for (bad, want) in [
            ("", "no header"),
            ("name\tstatus\n", "no column"),
            ("a\tok\t1\t1\t1\t1\t1\t0.1\t1\t1\t1\n", "fields"),
            ("a\tok\tx\t1\t1\t1\t1\t0.1\t1\t1\t1\tRK4\n", "not a count"),
            ("a\tok\t1\t1\t1\t1\t1\t0\t1\t1\t1\tRK4\n", "time step"),
            ("a\tok\t1\t1\t1\t1\t1\t0.1\t1\tNaN\t1\tRK4\n", "not a time"),
        ] {
            let text = if want == "no header" || want == "no column" {
                bad.to_string()
            } else {
                format!("{header}{bad}")
            };
            let e = parse_mujoco(&text).expect_err(bad);
            assert!(e.contains(want), "{bad:?}: {want:?} not in {e:?}");
        }
    }

    #[test]
    fn our_time_per_step_and_reason_come_from_the_binarys_lines() {
        let ok = "simulate: wrote 2 rows to a.csv (0.012 s stepping, 4.80 µs/step)\n";
        assert_eq!(parse_stepping(ok, Some(2500)), Some(4.8));
        // Without --dt the binary prints only seconds: divided by the steps.
        let secs = "simulate: wrote 2 rows to a.csv (0.500 s stepping)\n";
        assert_eq!(parse_stepping(secs, Some(1000)), Some(500.0));
        assert_eq!(parse_stepping(secs, None), None);
        assert_eq!(parse_stepping("garbage\n", Some(10)), None);
        assert_eq!(
            reason(
                "\nsimulate: scene: line 3: element <include> is not supported here\nmore\n",
                ""
            ),
            "scene: line 3: element <include> is not supported here"
        );
        assert_eq!(reason("", "  only stdout  "), "only stdout");
        // Loader warnings come first on stderr; the reason is the error after them.
        assert_eq!(
            reason("warning: not modelled: x\nsimulate: step 4 diverged\n", ""),
            "step 4 diverged"
        );
        let p = "warning: w\nthread 'main' panicked at verify/src/x.rs:1:2:\nboom\n";
        assert!(reason(p, "").starts_with("thread 'main' panicked at"));
        assert_eq!(reason("", ""), "no output");
    }

    /// Splits one CSV line (RFC 4180, no line breaks inside fields).
    fn split_csv(line: &str) -> Vec<String> {
        let (mut out, mut cur, mut quoted, mut chars) =
            (Vec::new(), String::new(), false, line.chars().peekable());
        while let Some(c) = chars.next() {
            match (c, quoted) {
                ('"', true) if chars.peek() == Some(&'"') => {
                    cur.push('"');
                    chars.next();
                }
                ('"', _) => quoted = !quoted,
                (',', false) => out.push(std::mem::take(&mut cur)),
                (c, _) => cur.push(c),
            }
        }
        out.push(cur);
        out
    }

    fn rows() -> Vec<Row> {
        let mj = |name: &str, case: &str, us: Option<f64>| Mujoco {
            name: name.into(),
            case: case.into(),
            status: "ok".into(),
            nbody: Some(3),
            timestep: Some("0.01".into()),
            steps: Some(500),
            us_per_step: us,
            max_ncon: Some(0),
            max_nlimit: Some(0),
            ..Mujoco::default()
        };
        let summary = Summary {
            steps: 500,
            us_per_step: Some(5.0),
            finite: true,
            max_joint_separation: 1e-13,
            energy_initial: 1.0,
            ..Summary::default()
        };
        let ran = |us: f64, s: Summary| Ours {
            loads: true,
            us_per_step: Some(us),
            summary: Some(s),
            ..Ours::default()
        };
        vec![
            Row {
                suite: "gymnasium".into(),
                name: "b_first".into(),
                cases: vec![
                    // Timed interleaved: its figures replace the separate runs' 5 / 10.
                    Case {
                        mujoco: mj("gymnasium/b_first", "passive", Some(10.0)),
                        ours: ran(5.0, summary.clone()),
                        paired: Some(Paired {
                            repeats: 5,
                            ratio: 0.7,
                            ratio_q1: 0.65,
                            ratio_q3: 0.8,
                            ratio_min: 0.6,
                            ratio_max: 0.9,
                            ours_us: 6.0,
                            mujoco_us: 8.0,
                        }),
                        timing_note: None,
                    },
                    Case {
                        mujoco: mj("gymnasium/b_first", "perturbed", Some(10.0)),
                        ours: ran(
                            20.0,
                            Summary {
                                max_joint_separation: 1e-3,
                                ..summary.clone()
                            },
                        ),
                        ..Case::default()
                    },
                ],
                smooth: Some(Smooth {
                    ours: Some(1e-4),
                    euler: Some(1e-2),
                    note: None,
                }),
            },
            Row {
                suite: "dm_control".into(),
                name: "a_second".into(),
                cases: vec![Case {
                    mujoco: mj("dm_control/a_second", "passive", Some(2.0)),
                    ours: Ours {
                        error: Some("scene: bad \"x\", a|b, c".into()),
                        ..Ours::default()
                    },
                    paired: None,
                    timing_note: Some("our run did not finish".into()),
                }],
                smooth: None,
            },
            Row {
                suite: "dm_control".into(),
                name: "c_third".into(),
                cases: vec![Case {
                    mujoco: Mujoco {
                        status: "load failed: nope".into(),
                        case: "passive".into(),
                        ..Mujoco::default()
                    },
                    ours: Ours {
                        loads: true,
                        error: Some("step 3 diverged (body 1 non-finite or beyond 1e12)".into()),
                        ..Ours::default()
                    },
                    ..Case::default()
                }],
                smooth: None,
            },
        ]
    }

    #[test]
    fn the_tables_keep_the_order_and_every_row_has_every_cell() {
        let rows = rows();
        let md = markdown(&rows, Some("4.0.0"), 5.0, 2.0);
        let cells = |l: &str| l.replace("\\|", "").matches('|').count();
        let tables: Vec<Vec<&str>> = md
            .split("\n\n")
            .map(|b| b.lines().filter(|l| l.starts_with('|')).collect::<Vec<_>>())
            .filter(|t| !t.is_empty())
            .collect();
        assert_eq!(tables.len(), 3, "{md}");
        for t in &tables {
            for l in t {
                assert_eq!(cells(l), cells(t[0]), "{l}");
            }
        }
        // The bench report's models section is this table.
        assert!(md.contains(&timing_table(&rows)));
        let (main, checks, smooth) = (&tables[0], &tables[1], &tables[2]);
        assert_eq!(main.len(), 2 + rows.len());
        for (r, l) in rows.iter().zip(&main[2..]) {
            assert!(
                l.starts_with(&format!("| {} | {} |", r.name, r.suite)),
                "{l}"
            );
        }
        // The interleaved figures where the case has them (ours 6 µs, MuJoCo 8 µs, the
        // median per-repeat ratio 0.7 with its spread), not the separate runs' 5 / 10.
        assert!(
            main[2].ends_with("| 8.00 | yes, ran | 6.00 | 0.700 | 0.650 … 0.800 |"),
            "{}",
            main[2]
        );
        // Ratio only where both engines have a time.
        assert!(main[3].ends_with("| – | – | – |"), "{}", main[3]);
        assert!(main[3].contains("no: scene: bad"));
        assert!(main[4].contains("yes; failed: step 3 diverged"));
        assert!(main[4].contains("load failed: nope"));
        // Checks: one line per case of a loaded model (2 + 1); the perturbed case's
        // joints fail at 1e-3 m.
        assert_eq!(checks.len(), 2 + 3);
        assert!(checks[2].ends_with("| ok |"), "{}", checks[2]);
        assert!(
            checks[2].contains("| 6.00 | 8.00 | 0.700 | 0.650 … 0.800 |"),
            "{}",
            checks[2]
        );
        // Not timed interleaved: the separate runs' 20 / 10, spread –.
        assert!(
            checks[3].contains("| 20.00 | 10.00 | 2.000 | – |"),
            "{}",
            checks[3]
        );
        assert!(
            checks[3].contains("joints 1.0e-3 m > 1e-6"),
            "{}",
            checks[3]
        );
        assert!(checks[4].contains("did not finish"), "{}", checks[4]);
        assert_eq!(smooth.len(), 2 + 1);
        assert!(
            smooth[2].contains("| 1.0e-4 | 1.0e-2 | 0.010 |"),
            "{}",
            smooth[2]
        );
        assert!(md.contains("MuJoCo 4.0.0") && md.contains("ours loads 2, runs every case"));
        assert!(md.contains("1 regressions") && md.contains("dm_control/c_third passive"));
        assert_eq!(fatal_cases(&rows), ["dm_control/c_third passive"]);
    }

    #[test]
    fn the_csv_has_a_line_per_case_and_quotes_what_needs_it() {
        let rows = rows();
        let text = csv(&rows);
        let lines: Vec<&str> = text.lines().collect();
        let cases: Vec<(&Row, &Case)> = rows
            .iter()
            .flat_map(|r| r.cases.iter().map(move |c| (r, c)))
            .collect();
        assert_eq!(lines.len(), 1 + cases.len());
        let header = split_csv(lines[0]);
        let field =
            |f: &[String], name: &str| f[header.iter().position(|h| h == name).unwrap()].clone();
        for ((r, c), l) in cases.iter().zip(&lines[1..]) {
            let f = split_csv(l);
            assert_eq!(f.len(), header.len(), "{l}");
            assert_eq!(field(&f, "model"), r.name);
            assert_eq!(field(&f, "case"), c.mujoco.case);
            assert_eq!(
                field(&f, "ours_error"),
                c.ours.error.as_deref().unwrap_or("")
            );
            assert_eq!(field(&f, "ours_loads"), c.ours.loads.to_string());
            assert_eq!(field(&f, "fatal"), c.fatal().to_string());
        }
        // The interleaved figures in the old columns, the separate runs' kept beside.
        let first = split_csv(lines[1]);
        assert_eq!(field(&first, "ratio"), "0.7000");
        assert_eq!(
            (field(&first, "ratio_q1"), field(&first, "ratio_q3")),
            ("0.6500".into(), "0.8000".into())
        );
        assert_eq!(
            (field(&first, "ratio_min"), field(&first, "ratio_max")),
            ("0.6000".into(), "0.9000".into())
        );
        assert_eq!(field(&first, "timing_repeats"), "5");
        assert_eq!(field(&first, "ours_us_per_step"), "6.000");
        assert_eq!(field(&first, "mujoco_us_per_step"), "8.000");
        assert_eq!(field(&first, "ratio_separate"), "0.5000");
        assert_eq!(field(&first, "ours_us_per_step_separate"), "5.000");
        assert_eq!(field(&first, "mujoco_us_per_step_separate"), "10.000");
        let third = split_csv(lines[3]);
        assert_eq!(field(&third, "timing_note"), "our run did not finish");
        assert_eq!(field(&third, "ratio_min"), "");
        assert_eq!(
            field(&first, "smooth_ours_com"),
            "",
            "smooth only on perturbed"
        );
        let second = split_csv(lines[2]);
        assert_eq!(field(&second, "ratio"), field(&second, "ratio_separate"));
        assert_eq!(field(&second, "ratio"), "2.0000");
        assert_eq!(field(&second, "timing_repeats"), "");
        assert_eq!(field(&second, "smooth_ours_com"), "1e-4");
        assert_eq!(field(&second, "smooth_euler_com"), "1e-2");
        assert!(field(&second, "checks").starts_with("joints"));
        assert_eq!(csv_field("plain"), "plain");
        assert_eq!(csv_field("a,\"b\""), "\"a,\"\"b\"\"\"");
    }

    #[test]
    fn a_model_is_smooth_only_without_contact_and_limits_in_both_engines() {
        let mut r = rows().remove(0);
        assert!(is_smooth(&r));
        r.cases[1].mujoco.max_nlimit = Some(1);
        assert!(!is_smooth(&r));
        let mut r = rows().remove(0);
        r.cases[1].ours.summary.as_mut().unwrap().max_contacts = 2;
        assert!(!is_smooth(&r));
        let mut r = rows().remove(0);
        r.cases.truncate(1);
        assert!(!is_smooth(&r), "no perturbed case");
    }

    /// Our side end to end on scenes of this repository: a file that loads runs a case
    /// and writes its summary; one that does not gives its reason.
    #[test]
    #[ignore = "builds the release simulate binary (minutes)"]
    fn our_side_runs_a_case_and_gives_the_reason_for_a_file_that_does_not_load() {
        let bin = build_simulate().unwrap();
        let dir = root().join("target/xtask/test-models-ours");
        std::fs::create_dir_all(&dir).unwrap();
        let mj = Mujoco {
            case: "perturbed".into(),
            timestep: Some("0.001".into()),
            steps: Some(1000),
            qpos: Some("-0.3".into()),
            qvel: Some("0.1".into()),
            ..Mujoco::default()
        };
        let limit = Duration::from_secs(60);
        let xml = root().join("scenes/pendulum.xml");
        let out = dir.join("o.csv");
        assert!(loads(&bin, &xml, &out, limit).is_ok());
        let o = ours_case(&bin, &xml, &mj, 1.0, 0, 3, &out, limit);
        assert!(o.loads && o.error.is_none() && !o.panicked, "{o:?}");
        assert!(o.us_per_step.is_some_and(|t| t > 0.0), "{o:?}");
        let s = o.summary.unwrap();
        assert_eq!(s.steps, 1000);
        assert!(s.finite && s.max_joint_separation < JOINT_TOL, "{s:?}");
        let bad = dir.join("bad.xml");
        std::fs::write(&bad, "<mujoco><nonsense/></mujoco>").unwrap();
        let (e, panicked) = loads(&bin, &bad, &out, limit).unwrap_err();
        assert!(
            !panicked && !e.is_empty() && !e.starts_with("simulate: "),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// `cargo xtask models LINE`'s options, or the error rendered.
    fn parse(line: &str) -> Result<Subcommand, String> {
        match crate::parse(&format!("models {line}")) {
            Ok(Some(crate::Command::Models(o))) => Ok(o.command),
            Ok(other) => panic!("{line}: parsed as {other:?}"),
            Err(e) => Err(e.to_string()),
        }
    }

    /// `cargo xtask models run LINE`'s options.
    fn run_options(line: &str) -> RunOptions {
        match parse(&format!("run {line}")) {
            Ok(Subcommand::Run(r)) => r,
            other => panic!("{line}: {other:?}"),
        }
    }

    #[test]
    fn only_selects_models_in_suite_order() {
        let r = run_options("--quick --only dm_control/humanoid,gymnasium/ant --out x");
        assert!(r.quick);
        assert_eq!(r.out, PathBuf::from("x"));
        assert_eq!(
            r.models(),
            [("gymnasium", "ant"), ("dm_control", "humanoid")]
        );
        // Repeated, and a model named twice, runs once.
        let r = run_options("--only dm_control/humanoid --only gymnasium/ant,gymnasium/ant");
        assert_eq!(
            r.models(),
            [("gymnasium", "ant"), ("dm_control", "humanoid")]
        );
        assert_eq!(run_options("--quick").models().len(), MODELS.len());
        assert!(parse("run --only gymnasium/nothing")
            .unwrap_err()
            .contains("no such model"));
        assert!(parse("run --only").is_err());
    }

    /// README.md's and verify's `models` lines, the defaults, and what is refused.
    #[test]
    fn run_arguments() {
        let r = run_options("--quick --out x");
        assert!(r.quick);
        assert_eq!(r.out, PathBuf::from("x"));
        let r = run_options("");
        assert!(!r.quick);
        assert_eq!(r.out, models_dir());
        assert_eq!(
            r.args(),
            RunArgs {
                quick: false,
                out: models_dir(),
                simulate: None
            }
        );
        // Interleaved repeats: 5 for a full run, 3 quick, or as given (0: none).
        assert_eq!(run_options("").repeats(), REPEATS);
        assert_eq!(run_options("--quick").repeats(), QUICK_REPEATS);
        assert_eq!(run_options("--quick --repeats 7").repeats(), 7);
        assert_eq!(run_options("--repeats 0").repeats(), 0);
        assert!(parse("run --repeats -1").is_err());
        assert!(parse("run --repeats many").is_err());
        assert_eq!(parse("fetch"), Ok(Subcommand::Fetch));
        assert_eq!(parse("list"), Ok(Subcommand::List));
        assert!(parse("run --out")
            .unwrap_err()
            .contains("a value is required"));
        assert!(parse("run --slow").unwrap_err().contains("--slow"));
        assert!(parse("fetch now").is_err());
        assert!(parse("").is_err());
    }
}
