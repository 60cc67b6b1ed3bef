//! `cargo xtask models fetch | list | run [--quick] [--out DIR]`: the MuJoCo models people
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
//! step; ours: the `simulate` binary of `constraint-verify` (release), first with duration 0
//! (does it load?), then for the same steps; its one-line error is the reason. Writes
//! `models.md` and `models.csv` to `--out` (default `target/models/`) and prints the table.

use crate::bench::fmt_ratio;
use crate::mujoco::{ensure_venv, last_line, MUJOCO_VERSION};
use crate::run::{cargo, root};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

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
        let num = |k: usize| -> Result<Option<usize>, String> {
            get(k)
                .map(|v| {
                    v.parse()
                        .map_err(|_| format!("line {}: {v:?} is not a count", i + 1))
                })
                .transpose()
        };
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
        });
    }
    Ok((version, rows))
}

/// Our side of one model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ours {
    /// A zero-duration run succeeded (the file loads and the scene builds).
    pub loads: bool,
    /// `None`: ran the whole window; otherwise the binary's one-line reason.
    pub error: Option<String>,
    pub us_per_step: Option<f64>,
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

/// The reason in a failed run's output: the first non-empty line of stderr (then stdout),
/// without the binary's `simulate: ` prefix.
pub fn reason(stderr: &str, stdout: &str) -> String {
    stderr
        .lines()
        .chain(stdout.lines())
        .map(str::trim)
        .find(|l| !l.is_empty())
        .map_or("no output".to_string(), |l| {
            l.strip_prefix("simulate: ").unwrap_or(l).to_string()
        })
}

/// Runs `cmd` with a wall-clock limit; returns (success, stdout, stderr) or why not.
fn run_limited(cmd: &mut Command, limit: Duration) -> Result<(bool, String, String), String> {
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
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(format!("waiting for it: {e}")),
        }
    };
    let (out, err) = (
        out.join().unwrap_or_default(),
        err.join().unwrap_or_default(),
    );
    Ok((status.success(), out, err))
}

/// Our binary on one model: a zero-duration run (loads?), then `steps` steps of `dt`.
fn ours(
    bin: &Path,
    xml: &Path,
    mj: Option<&Mujoco>,
    seconds: f64,
    out: &Path,
    limit: Duration,
) -> Ours {
    let base = |duration: &str, every: u64| {
        let mut c = Command::new(bin);
        c.arg(xml).args([
            "--duration",
            duration,
            "--every",
            &every.to_string(),
            "--out",
        ]);
        c.arg(out);
        c
    };
    match run_limited(&mut base("0", 1), limit) {
        Ok((true, _, _)) => {}
        Ok((false, o, e)) => {
            return Ours {
                error: Some(reason(&e, &o)),
                ..Ours::default()
            }
        }
        Err(e) => {
            return Ours {
                error: Some(e),
                ..Ours::default()
            }
        }
    }
    // The same steps as MuJoCo (its time step, its count); without MuJoCo, the file's.
    let (dt, steps) = match mj.and_then(|m| m.timestep.clone().zip(m.steps)) {
        Some((dt, n)) => (Some(dt), Some(n)),
        None => (None, None),
    };
    let mut cmd = match (&dt, steps) {
        (Some(dt), Some(n)) => {
            let h: f64 = dt.parse().unwrap_or(f64::NAN);
            let mut c = base(&format!("{}", n as f64 * h), n.max(1));
            c.args(["--dt", dt]);
            c
        }
        _ => base(&format!("{seconds}"), 1_000_000_000),
    };
    match run_limited(&mut cmd, limit) {
        Ok((true, _, e)) => Ours {
            loads: true,
            error: None,
            us_per_step: parse_stepping(&e, steps),
        },
        Ok((false, o, e)) => Ours {
            loads: true,
            error: Some(reason(&e, &o)),
            us_per_step: None,
        },
        Err(e) => Ours {
            loads: true,
            error: Some(e),
            us_per_step: None,
        },
    }
}

/// One line of the table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row {
    pub suite: String,
    pub name: String,
    pub mujoco: Mujoco,
    pub ours: Ours,
}

fn opt<T: ToString>(v: &Option<T>) -> String {
    v.as_ref().map_or("–".into(), T::to_string)
}

fn us(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| format!("{t:.2}"))
}

/// A table cell: no pipes or line breaks.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace(['\n', '\r'], " ")
}

/// `ours: loads? / reason`.
fn ours_status(o: &Ours) -> String {
    match (o.loads, &o.error) {
        (true, None) => "yes, ran".into(),
        (true, Some(e)) => format!("yes; failed: {e}"),
        (false, Some(e)) => format!("no: {e}"),
        (false, None) => "no".into(),
    }
}

fn mujoco_cell(m: &Mujoco) -> String {
    match (&m.status[..], m.us_per_step) {
        ("ok", t) => us(t),
        (s, Some(t)) => format!("{} ({s})", us(Some(t))),
        (s, None) => s.to_string(),
    }
}

/// `target/models/models.md`.
pub fn markdown(rows: &[Row], version: Option<&str>, seconds: f64) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# MuJoCo models: MuJoCo against this library\n\n\
         gymnasium {GYMNASIUM_VERSION} and dm_control {DM_CONTROL_VERSION} models, MuJoCo {}. \
         A passive run of {seconds} s from the default pose with zero control at the file's \
         time step. MuJoCo: `mujoco.rollout` (its C loop, one thread), median of 3; counts \
         are MuJoCo's (nbody includes the world body); contacts: most at any step of that \
         run. Ours: the `simulate` binary (release); \"loads\" means a zero-length run \
         succeeded, the reason is its one-line error. Ratio below 1: this library is faster.\n",
        version.unwrap_or("?")
    );
    let _ = writeln!(
        md,
        "| model | suite | nbody | njnt | nu | timestep (s) | integrator | contacts (MuJoCo) | MuJoCo µs/step | ours: loads? / reason | ours µs/step | ours / MuJoCo |"
    );
    let _ = writeln!(
        md,
        "|---|---|---:|---:|---:|---:|---|---:|---:|---|---:|---:|"
    );
    for r in rows {
        let m = &r.mujoco;
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            cell(&r.name),
            r.suite,
            opt(&m.nbody),
            opt(&m.njnt),
            opt(&m.nu),
            opt(&m.timestep),
            opt(&m.integrator),
            opt(&m.max_ncon),
            cell(&mujoco_cell(m)),
            cell(&ours_status(&r.ours)),
            us(r.ours.us_per_step),
            fmt_ratio(r.ours.us_per_step, m.us_per_step),
        );
    }
    let loaded = rows.iter().filter(|r| r.ours.loads).count();
    let ran = rows
        .iter()
        .filter(|r| r.ours.loads && r.ours.error.is_none())
        .count();
    let _ = writeln!(
        md,
        "\n{} models; ours loads {loaded}, runs {ran} to the end.\n\n\
         - `lqr_2_1` and `swimmer6` are generated from dm_control's `lqr.xml` and \
         `swimmer.xml` templates the way `lqr.py` and `swimmer.py` do (lqr's joint \
         stiffnesses: the draws of `numpy.random.RandomState(0)`; dm_control draws new ones \
         on every load). The other files are used as shipped: dm_control's task code \
         edits some of them before loading, not done here: dog (floor size; removes ball, \
         walls), quadruped (floor size; removes walls, ball, the terrain height field and \
         the rangefinders unless a task uses them), manipulator (ball or peg), stacker \
         (number of boxes).\n\
         - MuJoCo's times are one median of 3 short rollouts; on a shared machine expect \
         tens of per cent between runs. Models on RK4 (most gymnasium ones, acrobot, \
         cartpole) pay four evaluations per step.",
        rows.len()
    );
    md
}

/// A CSV field (RFC 4180): quoted when it holds a comma, quote or line break.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

pub const CSV_HEADER: &str = "model,suite,nbody,njnt,nq,nv,nu,timestep,integrator,steps,max_ncon,\
mujoco_status,mujoco_us_per_step,ours_loads,ours_error,ours_us_per_step,ratio";

/// `target/models/models.csv`: the same data, empty fields where there is none.
pub fn csv(rows: &[Row]) -> String {
    let e = |v: Option<String>| v.unwrap_or_default();
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        let m = &r.mujoco;
        let ratio = match (r.ours.us_per_step, m.us_per_step) {
            (Some(a), Some(b)) if b > 0.0 => Some(a / b),
            _ => None,
        };
        let f = [
            r.name.clone(),
            r.suite.clone(),
            e(m.nbody.map(|v| v.to_string())),
            e(m.njnt.map(|v| v.to_string())),
            e(m.nq.map(|v| v.to_string())),
            e(m.nv.map(|v| v.to_string())),
            e(m.nu.map(|v| v.to_string())),
            e(m.timestep.clone()),
            e(m.integrator.clone()),
            e(m.steps.map(|v| v.to_string())),
            e(m.max_ncon.map(|v| v.to_string())),
            m.status.clone(),
            e(m.us_per_step.map(|v| format!("{v:.3}"))),
            r.ours.loads.to_string(),
            e(r.ours.error.clone()),
            e(r.ours.us_per_step.map(|v| format!("{v:.3}"))),
            e(ratio.map(|v| format!("{v:.4}"))),
        ];
        let line: Vec<String> = f.iter().map(|s| csv_field(s)).collect();
        out.push_str(&line.join(","));
        out.push('\n');
    }
    out
}

/// Our `simulate` binary, built once (release).
fn build_simulate() -> Result<PathBuf, String> {
    eprintln!("xtask: cargo build --release -p constraint-verify --bin simulate");
    let ok = cargo()
        .args(["build", "--release", "--quiet", "-p", "constraint-verify"])
        .args(["--bin", "simulate"])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return Err("cargo build --release -p constraint-verify --bin simulate failed".into());
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
}

pub fn parse_run_args(args: &[String]) -> Result<RunArgs, String> {
    let mut a = RunArgs {
        quick: false,
        out: models_dir(),
    };
    let mut it = args.iter();
    while let Some(s) = it.next() {
        match s.as_str() {
            "--quick" => a.quick = true,
            "--out" => a.out = PathBuf::from(it.next().ok_or("--out needs a directory")?),
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    Ok(a)
}

fn run(a: &RunArgs) -> Result<(), String> {
    let t0 = Instant::now();
    let python = fetch()?;
    let dir = models_dir();
    let seconds = if a.quick { QUICK_SECONDS } else { SECONDS };
    let work = dir.join("work");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;

    let list = work.join("list.tsv");
    let text: String = MODELS
        .iter()
        .map(|(s, n)| format!("{s}/{n}\t{}\n", model_path(&dir, s, n).display()))
        .collect();
    std::fs::write(&list, text).map_err(|e| format!("{}: {e}", list.display()))?;
    let tsv = work.join("mujoco.tsv");
    let _ = std::fs::remove_file(&tsv);
    eprintln!(
        "xtask: MuJoCo {MUJOCO_VERSION}: {} models, {seconds} s each (mujoco.rollout, median of 3)",
        MODELS.len()
    );
    let out = Command::new(&python)
        .arg(script("models_mujoco.py", MEASURE)?)
        .arg("--list")
        .arg(&list)
        .args([
            "--duration",
            &seconds.to_string(),
            "--repeats",
            "3",
            "--out",
        ])
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

    let bin = build_simulate()?;
    let limit = Duration::from_secs(if a.quick {
        OURS_TIMEOUT_S / 10
    } else {
        OURS_TIMEOUT_S
    });
    let mut rows = Vec::new();
    for (suite, name) in MODELS {
        let key = format!("{suite}/{name}");
        let m = mj.iter().find(|m| m.name == key);
        let xml = model_path(&dir, suite, name);
        let csv_out = work.join(format!("{suite}_{name}.ours.csv"));
        let o = ours(&bin, &xml, m, seconds, &csv_out, limit);
        eprintln!(
            "xtask: ours {key}: {}{}",
            ours_status(&o),
            o.us_per_step
                .map_or(String::new(), |t| format!(", {t:.2} µs/step"))
        );
        rows.push(Row {
            suite: suite.into(),
            name: name.into(),
            mujoco: m.cloned().unwrap_or_else(|| Mujoco {
                name: key.clone(),
                status: "not measured".into(),
                ..Mujoco::default()
            }),
            ours: o,
        });
    }
    let md = markdown(&rows, version.as_deref(), seconds);
    for (file, text) in [("models.md", md.clone()), ("models.csv", csv(&rows))] {
        let p = a.out.join(file);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    println!("{md}");
    eprintln!(
        "xtask: wrote {} and models.csv ({:.1} s: MuJoCo and fetch {t_mujoco:.1} s)",
        a.out.join("models.md").display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

pub const USAGE: &str = "usage: cargo xtask models fetch | list | run [--quick] [--out DIR]";

pub fn main(args: &[String]) -> Result<(), String> {
    match args.first().map(String::as_str) {
        Some("fetch") if args.len() == 1 => fetch().map(|_| ()),
        Some("list") if args.len() == 1 => {
            fetch()?;
            let dir = models_dir();
            for (s, n) in MODELS {
                println!("{s:<10} {n:<24} {}", model_path(&dir, s, n).display());
            }
            Ok(())
        }
        Some("run") => run(&parse_run_args(&args[1..]).map_err(|e| format!("{e}\n{USAGE}"))?),
        Some("-h" | "--help" | "help") => {
            println!("{USAGE}");
            Ok(())
        }
        _ => Err(USAGE.into()),
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
                ..Mujoco::default()
            }
        );
        assert!(rows[2].status.starts_with("diverged"));

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
        let mj = |name: &str, us: Option<f64>| Mujoco {
            name: name.into(),
            status: "ok".into(),
            nbody: Some(3),
            timestep: Some("0.01".into()),
            steps: Some(500),
            us_per_step: us,
            ..Mujoco::default()
        };
        vec![
            Row {
                suite: "gymnasium".into(),
                name: "b_first".into(),
                mujoco: mj("gymnasium/b_first", Some(10.0)),
                ours: Ours {
                    loads: true,
                    error: None,
                    us_per_step: Some(5.0),
                },
            },
            Row {
                suite: "dm_control".into(),
                name: "a_second".into(),
                mujoco: mj("dm_control/a_second", Some(2.0)),
                ours: Ours {
                    loads: false,
                    error: Some("scene: bad \"x\", a|b, c".into()),
                    us_per_step: None,
                },
            },
            Row {
                suite: "dm_control".into(),
                name: "c_third".into(),
                mujoco: Mujoco {
                    status: "load failed: nope".into(),
                    ..Mujoco::default()
                },
                ours: Ours {
                    loads: true,
                    error: Some("diverged".into()),
                    us_per_step: None,
                },
            },
        ]
    }

    #[test]
    fn the_table_keeps_the_order_and_every_row_has_every_cell() {
        let rows = rows();
        let md = markdown(&rows, Some("4.0.0"), 5.0);
        let cells = |l: &str| l.replace("\\|", "").matches('|').count();
        let table: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
        assert_eq!(table.len(), 2 + rows.len());
        for l in &table {
            assert_eq!(cells(l), cells(table[0]), "{l}");
        }
        for (r, l) in rows.iter().zip(&table[2..]) {
            assert!(
                l.starts_with(&format!("| {} | {} |", r.name, r.suite)),
                "{l}"
            );
        }
        // Ratio only where both engines have a time: ours 5 µs against MuJoCo's 10 µs.
        assert!(table[2].ends_with("| 5.00 | 0.500 |"), "{}", table[2]);
        assert!(table[3].ends_with("| – | – |"), "{}", table[3]);
        assert!(table[3].contains("no: scene: bad"));
        assert!(table[4].contains("yes; failed: diverged"));
        assert!(table[4].contains("load failed: nope"));
        assert!(md.contains("MuJoCo 4.0.0") && md.contains("ours loads 2, runs 1"));
    }

    #[test]
    fn the_csv_has_the_same_rows_and_quotes_what_needs_it() {
        let rows = rows();
        let text = csv(&rows);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 1 + rows.len());
        let header = split_csv(lines[0]);
        for (r, l) in rows.iter().zip(&lines[1..]) {
            let f = split_csv(l);
            assert_eq!(f.len(), header.len(), "{l}");
            let field = |name: &str| &f[header.iter().position(|h| h == name).unwrap()];
            assert_eq!(field("model"), &r.name);
            assert_eq!(field("ours_error"), r.ours.error.as_deref().unwrap_or(""));
            assert_eq!(field("ours_loads"), &r.ours.loads.to_string());
        }
        let f = split_csv(lines[1]);
        assert_eq!(f.last().map(String::as_str), Some("0.5000"));
        assert_eq!(csv_field("plain"), "plain");
    }

    /// Our side end to end on scenes that load today (none of the 33 models does yet).
    #[test]
    #[ignore = "builds the release simulate binary (minutes)"]
    fn our_side_times_a_scene_that_loads_and_gives_the_reason_for_one_that_does_not() {
        let bin = build_simulate().unwrap();
        let dir = root().join("target/xtask/test-models-ours");
        std::fs::create_dir_all(&dir).unwrap();
        let mj = Mujoco {
            timestep: Some("0.001".into()),
            steps: Some(1000),
            ..Mujoco::default()
        };
        let limit = Duration::from_secs(60);
        let out = dir.join("o.csv");
        let o = ours(
            &bin,
            &root().join("scenes/pendulum.xml"),
            Some(&mj),
            1.0,
            &out,
            limit,
        );
        assert!(o.loads && o.error.is_none(), "{o:?}");
        assert!(o.us_per_step.is_some_and(|t| t > 0.0), "{o:?}");
        let bad = dir.join("bad.xml");
        std::fs::write(&bad, "<mujoco><nonsense/></mujoco>").unwrap();
        let o = ours(&bin, &bad, Some(&mj), 1.0, &out, limit);
        assert!(!o.loads && o.us_per_step.is_none(), "{o:?}");
        let e = o.error.unwrap();
        assert!(!e.is_empty() && !e.starts_with("simulate: "), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn run_arguments() {
        let args = |s: &str| s.split_whitespace().map(String::from).collect::<Vec<_>>();
        let a = parse_run_args(&args("--quick --out x")).unwrap();
        assert!(a.quick);
        assert_eq!(a.out, PathBuf::from("x"));
        assert!(!parse_run_args(&[]).unwrap().quick);
        assert!(parse_run_args(&args("--out"))
            .unwrap_err()
            .contains("needs"));
        assert!(parse_run_args(&args("--slow"))
            .unwrap_err()
            .contains("unknown"));
    }
}
