//! Running MJCF scenes with this library (what `cargo xtask simulate` does).

use std::path::Path;

use constraint_articulated::mjcf_contact::MjcfContactScene;
use constraint_articulated::{Method, MjcfScene};

use crate::trajectory::Trajectory;

/// The named step methods of `cargo xtask simulate --method M`.
pub const METHODS: [(&str, &str); 7] = [
    (
        "velocity",
        "velocity level, J v' = −C/h (the lecture's Opción 2)",
    ),
    (
        "projected",
        "velocity level, then Newton projection of positions to 1e-10 m",
    ),
    (
        "shake",
        "velocity level, then projection with the correction added to the velocities (δ/h)",
    ),
    (
        "baumgarte",
        "acceleration level with critically damped Baumgarte gains, time constant 5h",
    ),
    (
        "acceleration",
        "acceleration level without stabilisation (drifts)",
    ),
    (
        "rattle",
        "RATTLE: kick, drift, SHAKE projection to 1e-12 m, kick, velocity projection (second order)",
    ),
    (
        "rattle4",
        "RATTLE composed by Yoshida's triple jump (fourth order, undamped scenes)",
    ),
];

/// The [`Method`] for a name of [`METHODS`] at step `h`.
pub fn method(name: &str, h: f64) -> Result<Method, String> {
    Ok(match name {
        "velocity" => Method::Velocity { beta: 1.0 },
        "projected" | "shake" => Method::VelocityProjected {
            beta: 1.0,
            tolerance: 1e-10,
            max_iterations: 10,
            correct_velocity: name == "shake",
        },
        // Critically damped C̈ + k_v Ċ + k_x C = 0 with time constant 5h.
        "baumgarte" => {
            let tau = 5.0 * h;
            Method::Acceleration {
                kx: 1.0 / (tau * tau),
                kv: 2.0 / tau,
            }
        }
        "acceleration" => Method::Acceleration { kx: 0.0, kv: 0.0 },
        "rattle" => Method::Rattle {
            tolerance: 1e-12,
            max_iterations: 20,
        },
        "rattle4" => Method::Rattle4 {
            tolerance: 1e-12,
            max_iterations: 20,
        },
        other => {
            let names: Vec<&str> = METHODS.iter().map(|m| m.0).collect();
            return Err(format!(
                "unknown method {other:?} (one of {})",
                names.join(", ")
            ));
        }
    })
}

/// Options of one run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Keyframe name (`None`: default pose at rest).
    pub keyframe: Option<String>,
    /// Step (`None`: the file's `option timestep`).
    pub dt: Option<f64>,
    /// Simulated duration (s).
    pub duration: f64,
    /// A row every `every` steps.
    pub every: usize,
    /// Method name (see [`METHODS`]).
    pub method: String,
    /// Initial `qpos` in MuJoCo's generalized coordinates (after the keyframe; missing
    /// values are `qpos0`).
    pub qpos: Option<Vec<f64>>,
    /// Initial `qvel` (missing values zero).
    pub qvel: Option<Vec<f64>>,
    /// Control file: CSV with columns `t, <actuator name>...`, zero-order hold.
    pub ctrl: Option<std::path::PathBuf>,
}

impl Default for RunOptions {
    /// No keyframe, the file's step, zero duration, every step, RATTLE, no state or
    /// control overrides.
    fn default() -> Self {
        Self {
            keyframe: None,
            dt: None,
            duration: 0.0,
            every: 1,
            method: "rattle".into(),
            qpos: None,
            qvel: None,
            ctrl: None,
        }
    }
}

/// A control sequence: times (increasing) and, per row, the controls of the named
/// actuators (`(actuator index, value)`), held until the next row.
#[derive(Clone, Debug, PartialEq)]
pub struct Controls {
    /// Row times (s), strictly increasing.
    pub t: Vec<f64>,
    /// Per row, `(actuator, value)` for every column.
    pub rows: Vec<Vec<(usize, f64)>>,
}

impl Controls {
    /// Parses a control CSV (`t,<actuator>...` header, one row per change) against the
    /// scene's actuator names. Errors name the line: a missing `t` column, an unknown
    /// or repeated actuator, a wrong number of fields, a non-number or non-finite value,
    /// times not strictly increasing.
    pub fn parse(text: &str, actuators: &[String]) -> Result<Self, String> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, header) = lines.next().ok_or("ctrl file: empty")?;
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        if cols.first() != Some(&"t") {
            return Err("ctrl file: the first column must be t".into());
        }
        let mut index = Vec::with_capacity(cols.len() - 1);
        for c in &cols[1..] {
            let Some(i) = actuators.iter().position(|a| a == c) else {
                return Err(format!(
                    "ctrl file: column {c:?} is not an actuator of the scene"
                ));
            };
            if index.contains(&i) {
                return Err(format!("ctrl file: column {c:?} appears twice"));
            }
            index.push(i);
        }
        let mut out = Controls {
            t: Vec::new(),
            rows: Vec::new(),
        };
        for (n, line) in lines {
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            if f.len() != cols.len() {
                return Err(format!(
                    "ctrl file line {}: {} fields, the header has {}",
                    n + 1,
                    f.len(),
                    cols.len()
                ));
            }
            let mut vals = Vec::with_capacity(f.len());
            for x in &f {
                let v: f64 = x
                    .parse()
                    .map_err(|_| format!("ctrl file line {}: not a number: {x:?}", n + 1))?;
                if !v.is_finite() {
                    return Err(format!("ctrl file line {}: non-finite value", n + 1));
                }
                vals.push(v);
            }
            if out.t.last().is_some_and(|&p| !(vals[0] > p)) {
                return Err(format!("ctrl file line {}: times must increase", n + 1));
            }
            out.t.push(vals[0]);
            out.rows.push(
                index
                    .iter()
                    .copied()
                    .zip(vals[1..].iter().copied())
                    .collect(),
            );
        }
        Ok(out)
    }

    /// The row in force at time `t` (the last with `t_row ≤ t`), if any.
    pub fn at(&self, t: f64) -> Option<&[(usize, f64)]> {
        let k = self.t.partition_point(|&r| r <= t + 1e-12);
        k.checked_sub(1).map(|k| self.rows[k].as_slice())
    }
}

/// Loads `path`, runs it and returns the trajectory (first row at `t = 0`, times exact
/// multiples of the step) and the wall time spent stepping (s). Any error, including
/// divergence, is one line of text.
pub fn run(path: &Path, opts: &RunOptions) -> Result<(Trajectory, f64), String> {
    let model = constraint_mjcf::load_file(path).map_err(|e| format!("scene: {e}"))?;
    let collides = !model.contact_disabled
        && model
            .geoms
            .iter()
            .any(|g| g.contype != 0 || g.conaffinity != 0);
    // Free bodies only: the free-body contact world (sequential impulses, shock
    // propagation, split impulses). Everything else — joints with or without contact —
    // runs in the one jointed world with its colliders.
    let all_free = (0..model.bodies.len()).all(|i| {
        let mut js = model.joints.iter().filter(|j| j.body == i);
        matches!((js.next(), js.next()), (Some(j), None) if j.kind == constraint_mjcf::JointKind::Free)
    });
    if collides && all_free {
        return run_contact(&model, opts);
    }
    let mut scene = MjcfScene::new(&model, opts.keyframe.as_deref()).map_err(|e| e.to_string())?;
    warn_once(&scene.warnings);
    if opts.qpos.is_some() || opts.qvel.is_some() {
        let q = opts.qpos.as_deref().unwrap_or(&[]);
        let v = opts.qvel.as_deref().unwrap_or(&[]);
        if opts.keyframe.is_some() {
            return Err("--qpos/--qvel and --keyframe: give one initial state".into());
        }
        scene
            .set_generalized(&model, q, v)
            .map_err(|e| e.to_string())?;
    }
    let controls = match &opts.ctrl {
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
            Some(Controls::parse(&text, &scene.actuator_names)?)
        }
        None => None,
    };
    let h = opts.dt.unwrap_or(scene.timestep);
    let steps = step_count(h, opts)?;
    let m = method(&opts.method, h)?;
    let mut traj = Trajectory::for_bodies(&scene.body_names);
    traj.push(0.0, &scene.world);
    // Only the steps are timed: the clock pauses while a row is recorded.
    let mut start = std::time::Instant::now();
    let mut stepping = 0.0;
    for i in 1..=steps {
        if let Some(row) = controls.as_ref().and_then(|c| c.at((i - 1) as f64 * h)) {
            for &(a, u) in row {
                scene.world.set_ctrl(a, u).map_err(|e| e.to_string())?;
            }
        }
        scene.world.step(h, m).map_err(|e| e.to_string())?;
        if i % opts.every as u64 == 0 {
            stepping += start.elapsed().as_secs_f64();
            traj.push(i as f64 * h, &scene.world);
            start = std::time::Instant::now();
        }
    }
    stepping += start.elapsed().as_secs_f64();
    Ok((traj, stepping))
}

/// The number of steps of `h` in `opts.duration`, after checking the run options.
fn step_count(h: f64, opts: &RunOptions) -> Result<u64, String> {
    if !(h > 0.0) || !h.is_finite() {
        return Err(format!("time step must be positive and finite, got {h}"));
    }
    if !(opts.duration >= 0.0) || !opts.duration.is_finite() {
        return Err(format!(
            "duration must be non-negative and finite, got {}",
            opts.duration
        ));
    }
    if opts.every == 0 {
        return Err("--every must be at least 1".into());
    }
    let steps = (opts.duration / h).round() as u64;
    if steps > 1_000_000_000 {
        return Err(format!("{steps} steps is too many"));
    }
    Ok(steps)
}

/// A scene of free bodies with collision geoms, in a [`ContactWorld`] (the contact crate's
/// defaults; `--method` is ignored). The trailing `C_max` column holds the deepest
/// penetration before each step.
fn run_contact(
    model: &constraint_mjcf::Model,
    opts: &RunOptions,
) -> Result<(Trajectory, f64), String> {
    let mut scene =
        MjcfContactScene::new(model, opts.keyframe.as_deref()).map_err(|e| e.to_string())?;
    let h = opts.dt.unwrap_or(scene.timestep);
    let steps = step_count(h, opts)?;
    let energy = |w: &constraint_contact::rigid::ContactWorld| {
        let k: f64 = w.bodies().iter().map(|b| b.kinetic_energy()).sum();
        (k, w.energy() - k)
    };
    let mut traj = Trajectory::for_bodies(&scene.body_names);
    let (k, p) = energy(&scene.world);
    traj.push_bodies(0.0, scene.world.bodies(), k, p, 0.0);
    let mut start = std::time::Instant::now();
    let mut stepping = 0.0;
    for i in 1..=steps {
        let st = scene.world.step(h).map_err(|e| e.to_string())?;
        if i % opts.every as u64 == 0 {
            stepping += start.elapsed().as_secs_f64();
            let (k, p) = energy(&scene.world);
            traj.push_bodies(i as f64 * h, scene.world.bodies(), k, p, st.max_penetration);
            start = std::time::Instant::now();
        }
    }
    stepping += start.elapsed().as_secs_f64();
    Ok((traj, stepping))
}

/// Prints each distinct loader warning once per process (a sweep runs the same file
/// many times).
fn warn_once(warnings: &[String]) {
    use std::collections::BTreeSet;
    use std::sync::Mutex;
    static SEEN: Mutex<BTreeSet<String>> = Mutex::new(BTreeSet::new());
    let Ok(mut seen) = SEEN.lock() else {
        return;
    };
    for w in warnings {
        if seen.insert(w.clone()) {
            eprintln!("warning: {w}");
        }
    }
}
