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
