//! Loads every `*.xml` in `$MJCF_MODELS_DIR` (for example the gymnasium and dm_control
//! models, which are not part of this repository) and prints, per file, what loaded or
//! the error. With `MJCF_PRINT_MASS=1` it also prints each body's mass and inertia
//! tensor (`MASS <file> <body> <mass> <9 entries>`) for cross-checking against MuJoCo.
//!
//! `MJCF_MODELS_DIR=/path cargo test -p constraint-mjcf --test models -- --ignored --nocapture`

use constraint_mjcf::{load_file, MjcfError};

#[test]
#[ignore = "needs MJCF_MODELS_DIR"]
fn load_every_model_in_dir() {
    let Ok(dir) = std::env::var("MJCF_MODELS_DIR") else {
        eprintln!("MJCF_MODELS_DIR not set");
        return;
    };
    let print_mass = std::env::var("MJCF_PRINT_MASS").is_ok();
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("MJCF_MODELS_DIR is not a directory")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "xml"))
        .collect();
    files.sort();
    let (mut ok, mut failed) = (0, 0);
    for path in &files {
        let file = path.file_name().unwrap_or_default().to_string_lossy();
        match load_file(path) {
            Ok(m) => {
                ok += 1;
                println!(
                    "{file}: loaded: {} bodies, {} joints (nq {}, nv {}), {} actuators, {} tendons, {} warnings",
                    m.bodies.len(),
                    m.joints.len(),
                    m.nq(),
                    m.nv(),
                    m.actuators.len(),
                    m.tendons.len(),
                    m.warnings.len()
                );
                // Every keyframe (and the default pose) converts to body states.
                m.initial_state(None).expect("default state");
                for k in &m.keyframes {
                    m.initial_state(Some(&k.name)).expect("keyframe state");
                }
                if print_mass {
                    // A deterministic pose and velocity: qpos0 + 0.3 sin(1.7k + 0.4),
                    // qvel 0.5 cos(1.3k + 0.2) (quaternions normalised by body_states).
                    let mut qpos = m.qpos0();
                    for (k, q) in qpos.iter_mut().enumerate() {
                        *q += 0.3 * (1.7 * k as f64 + 0.4).sin();
                    }
                    let qvel: Vec<f64> = (0..m.nv())
                        .map(|k| 0.5 * (1.3 * k as f64 + 0.2).cos())
                        .collect();
                    for (i, a) in m.actuators.iter().enumerate() {
                        println!(
                            "ACT {file} {i} {:e} {:e} {:e} {:e} {} {:e} {:e} {} {:e} {:e} {:e}",
                            a.gain,
                            a.bias[0],
                            a.bias[1],
                            a.bias[2],
                            a.ctrllimited as u8,
                            a.ctrlrange[0],
                            a.ctrlrange[1],
                            a.forcelimited as u8,
                            a.forcerange[0],
                            a.forcerange[1],
                            a.gear[0]
                        );
                    }
                    for (i, j) in m.joints.iter().enumerate() {
                        println!(
                            "JNT {file} {i} {} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e}",
                            j.limited as u8,
                            j.range[0],
                            j.range[1],
                            j.armature,
                            j.damping,
                            j.stiffness,
                            j.frictionloss,
                            j.springref,
                            j.reference
                        );
                    }
                    let states = m.body_states(&qpos, &qvel).expect("states");
                    for (b, s) in m.bodies.iter().zip(&states) {
                        let v: Vec<String> = s
                            .pos
                            .iter()
                            .chain(&s.quat)
                            .chain(&s.com)
                            .chain(&s.vel)
                            .chain(&s.omega)
                            .map(|x| format!("{x:.17e}"))
                            .collect();
                        println!("STATE {file} {} {}", b.name, v.join(" "));
                    }
                    for b in &m.bodies {
                        let t = b.inertia;
                        println!(
                            "MASS {file} {} {:.17e} {:.17e} {:.17e} {:.17e} {:.17e} {:.17e} {:.17e} {:.17e} {:.17e} {:.17e}",
                            b.name, b.mass, t[0][0], t[0][1], t[0][2], t[1][0], t[1][1], t[1][2], t[2][0], t[2][1], t[2][2]
                        );
                    }
                }
            }
            Err(e) => {
                failed += 1;
                let typed = matches!(
                    e,
                    MjcfError::UnsupportedFeature { .. } | MjcfError::InFile { .. }
                );
                println!("{file}: error{}: {e}", if typed { "" } else { " (other)" });
            }
        }
    }
    println!("{ok} loaded, {failed} failed");
}
