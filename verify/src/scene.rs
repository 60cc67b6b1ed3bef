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
    let h = opts.dt.unwrap_or(scene.timestep);
    let steps = step_count(h, opts)?;
    let m = method(&opts.method, h)?;
    let mut traj = Trajectory::for_bodies(&scene.body_names);
    traj.push(0.0, &scene.world);
    // Only the steps are timed: the clock pauses while a row is recorded.
    let mut start = std::time::Instant::now();
    let mut stepping = 0.0;
    for i in 1..=steps {
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
