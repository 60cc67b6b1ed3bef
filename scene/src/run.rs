//! Running MJCF scenes with this library (what `cargo xtask simulate` does).
//!
//! One world runs every file — jointed or free bodies, with or without contact — with
//! the formulation of [`METHODS`]. The free-body contact world of `constraint-contact`
//! (its own solvers: the soft step, sequential impulses, dense LCPs) is there for files of
//! free bodies only, by name ([`FREE_BODY_METHODS`]): the user picks it, the file does
//! not.

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

/// The free-body contact world's solvers by name (`--method M`, files whose bodies are
/// all free only).
pub const FREE_BODY_METHODS: [(&str, &str); 2] = [
    (
        "free-contact",
        "free bodies only: the contact crate's world and defaults (dense Newton with staggered friction up to 200 points, the soft step with 3 sub-steps beyond)",
    ),
    (
        "soft-step",
        "free bodies only: the contact crate's world, Box2D v3 soft step with 4 sub-steps (the fast path)",
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
            let names: Vec<&str> = METHODS
                .iter()
                .chain(&FREE_BODY_METHODS)
                .map(|m| m.0)
                .collect();
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
    /// The floor on the projection tolerance of RATTLE's steps with one-sided rows
    /// (`World::set_unilateral_tolerance`, m; `None`: the world's default,
    /// `World::DEFAULT_UNILATERAL_TOLERANCE`).
    pub unilateral_tolerance: Option<f64>,
    /// RATTLE's velocity-level fallback aimed at the start of the step instead of its
    /// end (`World::set_end_of_step_aim(false)`).
    pub start_aim: bool,
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
            unilateral_tolerance: None,
            start_aim: false,
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
    /// scene's actuator names; a column `#k` is the actuator of index `k` (MuJoCo's
    /// order; how an actuator without a name is addressed). Errors name the line: a missing `t` column, an unknown
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
            // `#k`: the actuator of index k (0-based), for actuators without a name.
            let by_index = c
                .strip_prefix('#')
                .and_then(|k| k.parse::<usize>().ok())
                .filter(|&k| k < actuators.len());
            let Some(i) = by_index.or_else(|| actuators.iter().position(|a| a == c)) else {
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

/// Figures of a whole run, gathered after every step outside the timed part
/// (`simulate --summary`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Steps taken.
    pub steps: u64,
    /// The step (s).
    pub dt: f64,
    /// Wall time spent stepping (s).
    pub seconds_stepping: f64,
    /// Every body's position, velocity and angular velocity finite at the end.
    pub finite: bool,
    /// Largest joint separation at any step, `max_t World::max_separation` (m).
    pub max_joint_separation: f64,
    /// Deepest contact penetration at the start of any step (m).
    pub max_penetration: f64,
    /// Deepest penetration over the second half of the run, once settled (m).
    pub settled_penetration: f64,
    /// Total energy `E_kin + E_pot` at the start (J).
    pub energy_initial: f64,
    /// `max_t (E(t) − E(0))`, zero if the energy never rose above its start (J).
    pub max_energy_increase: f64,
    /// Total energy at the end (J).
    pub energy_final: f64,
    /// Most contact points at any step.
    pub max_contacts: usize,
    /// Time (s) of the first state with a contact (the start of the first step that
    /// found one); `None`: no contact.
    pub first_contact_time: Option<f64>,
    /// Height (z, m) of the first body's origin at the end (the root of a walker).
    pub root_height: f64,
    /// Actuators and collision geoms of the world (energy may only fall without the
    /// first, and without the second unless contacts push bodies apart).
    pub actuators: usize,
    /// Colliders of the world.
    pub colliders: usize,
    /// Steps whose one-sided rows went to the dense path and ended above its tolerance
    /// (`RowStats::capped`: the staggered alternations reached their cap or stalled).
    pub unconverged_steps: u64,
    /// The largest residual of those steps (`UnilateralStats::residual`; 0: none).
    pub worst_unconverged_residual: f64,
}

impl Summary {
    /// The end-of-run figures: steps, stepping time, and from the final bodies whether
    /// the state is finite and the root body's height.
    fn finish(&mut self, steps: u64, stepping: f64, bodies: &[constraint_articulated::RigidBody]) {
        self.steps = steps;
        self.seconds_stepping = stepping;
        self.finite = bodies
            .iter()
            .all(|b| b.pose.x.is_finite() && b.v.is_finite() && b.omega.is_finite());
        self.root_height = bodies.first().map_or(f64::NAN, |b| b.origin().z);
    }

    /// One flat JSON object: the fields in order, then `us_per_step` (`serde_json`:
    /// numbers in shortest round-trip form; a non-finite number, or no first contact,
    /// written as `null`).
    pub fn to_json(&self) -> String {
        /// The fields and the time per step derived from two of them.
        #[derive(serde::Serialize)]
        struct Json<'a> {
            #[serde(flatten)]
            summary: &'a Summary,
            us_per_step: f64,
        }
        let us_per_step = if self.steps > 0 {
            self.seconds_stepping / self.steps as f64 * 1e6
        } else {
            f64::NAN
        };
        let json = Json {
            summary: self,
            us_per_step,
        };
        // Plain numbers, bools and an option cannot fail to serialise; the fallback keeps
        // the library free of a panic path all the same.
        serde_json::to_string(&json).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }
}

/// Loads `path`, runs it and returns the trajectory (first row at `t = 0`, times exact
/// multiples of the step) and the wall time spent stepping (s). Any error, including
/// divergence, is one line of text.
pub fn run(path: &Path, opts: &RunOptions) -> Result<(Trajectory, f64), String> {
    run_inner(path, opts, false).map(|(t, s, _)| (t, s))
}

/// [`run`], and the run's [`Summary`] (its figures are gathered after every step with
/// the clock paused, so the time per step is the same as [`run`]'s).
pub fn run_with_summary(
    path: &Path,
    opts: &RunOptions,
) -> Result<(Trajectory, f64, Summary), String> {
    run_inner(path, opts, true)
}

fn run_inner(
    path: &Path,
    opts: &RunOptions,
    collect: bool,
) -> Result<(Trajectory, f64, Summary), String> {
    let model = constraint_mjcf::load_file(path).map_err(|e| format!("scene: {e}"))?;
    // The one world runs every file; the free-body contact world only when asked for
    // by name (its loader rejects anything but free bodies with a typed error).
    if FREE_BODY_METHODS.iter().any(|m| m.0 == opts.method) {
        return run_contact(&model, opts, collect);
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
    if let Some(t) = opts.unilateral_tolerance {
        scene
            .world
            .set_unilateral_tolerance(t)
            .map_err(|e| format!("--unilateral-tolerance {t}: {e}"))?;
    }
    if opts.start_aim {
        scene.world.set_end_of_step_aim(false);
    }
    let h = opts.dt.unwrap_or(scene.timestep);
    let steps = step_count(h, opts)?;
    let m = method(&opts.method, h)?;
    // One entry per MJCF body, merged ones included (`MjcfScene::part_states`).
    let mut traj = Trajectory::for_bodies(&scene.body_names);
    let mut parts = Vec::with_capacity(scene.parts.len());
    let push = |traj: &mut Trajectory, t: f64, scene: &MjcfScene, parts: &mut Vec<_>| {
        let (k, p) = scene.energy();
        scene.part_states(parts);
        traj.push_parts(t, parts, k, p, scene.world.max_separation());
    };
    push(&mut traj, 0.0, &scene, &mut parts);
    let total = |s: &MjcfScene| {
        let (k, p) = s.energy();
        k + p
    };
    let e0 = total(&scene);
    let mut sum = Summary {
        dt: h,
        energy_initial: e0,
        energy_final: e0,
        max_joint_separation: scene.world.max_separation(),
        actuators: scene.world.actuators().len(),
        colliders: scene.world.colliders().len(),
        ..Summary::default()
    };
    // Only the steps are timed: the clock pauses while a row is recorded or the summary
    // gathered.
    let mut start = std::time::Instant::now();
    let mut stepping = 0.0;
    for i in 1..=steps {
        if let Some(row) = controls.as_ref().and_then(|c| c.at((i - 1) as f64 * h)) {
            for &(a, u) in row {
                scene.world.set_ctrl(a, u).map_err(|e| e.to_string())?;
            }
        }
        scene.world.step(h, m).map_err(|e| e.to_string())?;
        let record = i % opts.every as u64 == 0;
        if record || collect {
            stepping += start.elapsed().as_secs_f64();
            if collect {
                let w = &scene.world;
                let st = w.unilateral_stats();
                sum.max_joint_separation = sum.max_joint_separation.max(w.max_separation());
                sum.max_penetration = sum.max_penetration.max(st.max_penetration);
                if 2 * i > steps {
                    sum.settled_penetration = sum.settled_penetration.max(st.max_penetration);
                }
                sum.max_contacts = sum.max_contacts.max(st.contacts);
                if !st.sparse && st.solver.capped {
                    sum.unconverged_steps += 1;
                    sum.worst_unconverged_residual =
                        sum.worst_unconverged_residual.max(st.residual);
                }
                if st.contacts > 0 && sum.first_contact_time.is_none() {
                    sum.first_contact_time = Some((i - 1) as f64 * h);
                }
                sum.energy_final = total(&scene);
                sum.max_energy_increase = sum.max_energy_increase.max(sum.energy_final - e0);
            }
            if record {
                push(&mut traj, i as f64 * h, &scene, &mut parts);
            }
            start = std::time::Instant::now();
        }
    }
    stepping += start.elapsed().as_secs_f64();
    sum.finish(steps, stepping, scene.world.bodies());
    // The root is the first MJCF body (a world body only when it has a joint).
    sum.root_height = scene.part_state(0).map_or(f64::NAN, |p| p.origin.z);
    Ok((traj, stepping, sum))
}

/// The number of steps of `h` in `opts.duration`, after checking the run options.
fn step_count(h: f64, opts: &RunOptions) -> Result<u64, String> {
    // The same check the world's step makes (the one place a time step is validated).
    if let Err(e) = constraint_core::StepContext::new(h) {
        return Err(format!("{e}, got {h}"));
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

/// A scene of free bodies with collision geoms, in a [`ContactWorld`]: the contact crate's
/// defaults (`free-contact`) or its soft step with 4 sub-steps (`soft-step`). The
/// trailing `C_max` column holds the deepest penetration before each step.
fn run_contact(
    model: &constraint_mjcf::Model,
    opts: &RunOptions,
    collect: bool,
) -> Result<(Trajectory, f64, Summary), String> {
    let mut scene =
        MjcfContactScene::new(model, opts.keyframe.as_deref()).map_err(|e| e.to_string())?;
    if opts.method == "soft-step" {
        scene.world.settings.solver =
            constraint_contact::rigid::ContactSolver::SoftStep { substeps: 4 };
    }
    let h = opts.dt.unwrap_or(scene.timestep);
    let steps = step_count(h, opts)?;
    let energy = |w: &constraint_contact::rigid::ContactWorld| {
        let k: f64 = w.bodies().iter().map(|b| b.kinetic_energy()).sum();
        (k, w.energy() - k)
    };
    let mut traj = Trajectory::for_bodies(&scene.body_names);
    let (k, p) = energy(&scene.world);
    traj.push_bodies(0.0, scene.world.bodies(), k, p, 0.0);
    let e0 = k + p;
    let mut sum = Summary {
        dt: h,
        energy_initial: e0,
        energy_final: e0,
        colliders: model.geoms.len(),
        ..Summary::default()
    };
    let mut start = std::time::Instant::now();
    let mut stepping = 0.0;
    for i in 1..=steps {
        let st = scene.world.step(h).map_err(|e| e.to_string())?;
        let record = i % opts.every as u64 == 0;
        if record || collect {
            stepping += start.elapsed().as_secs_f64();
            let (k, p) = energy(&scene.world);
            if collect {
                sum.max_penetration = sum.max_penetration.max(st.max_penetration);
                if 2 * i > steps {
                    sum.settled_penetration = sum.settled_penetration.max(st.max_penetration);
                }
                sum.energy_final = k + p;
                sum.max_energy_increase = sum.max_energy_increase.max(k + p - e0);
            }
            if record {
                traj.push_bodies(i as f64 * h, scene.world.bodies(), k, p, st.max_penetration);
            }
            start = std::time::Instant::now();
        }
    }
    stepping += start.elapsed().as_secs_f64();
    sum.finish(steps, stepping, scene.world.bodies());
    Ok((traj, stepping, sum))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `to_json` is valid JSON with every field by name, `us_per_step` derived, and
    /// non-finite numbers and a missing first contact as `null` (never `NaN`, which JSON
    /// has no word for).
    #[test]
    fn the_summary_json_parses_back_with_nulls_for_non_finite() {
        let s = Summary {
            steps: 400,
            dt: 0.0025,
            seconds_stepping: 0.0155,
            finite: true,
            max_joint_separation: 1.1e-16,
            energy_final: f64::NAN,
            max_contacts: 6,
            root_height: f64::INFINITY,
            colliders: 8,
            ..Summary::default()
        };
        let text = s.to_json();
        let v: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
        assert_eq!(v["steps"], 400);
        assert_eq!(v["dt"], 0.0025);
        assert_eq!(v["finite"], true);
        assert_eq!(v["max_joint_separation"], 1.1e-16);
        // 0.0155 s / 400 steps = 38.75 µs (to round-off: measured 38.75000000000001).
        let per = v["us_per_step"].as_f64().expect("number");
        assert!((per - 38.75).abs() < 1e-12, "{per}");
        assert!(v["energy_final"].is_null() && v["root_height"].is_null());
        assert!(v["first_contact_time"].is_null());
        assert_eq!(v.as_object().map(|o| o.len()), Some(18), "{text}");
        assert!(Summary::default()
            .to_json()
            .contains("\"us_per_step\":null"));
    }
}
