//! The real gymnasium and dm_control models (fetched by `cargo xtask models fetch` into
//! `target/models/`, never committed): each that loads runs 5 s passive (zero control)
//! from `qpos0` with the default method, and must stay finite, keep its joints at
//! tolerance, not sink into its floor beyond the slop plus the Baumgarte residue, and —
//! without actuators, springs or contact — not gain energy. Ignored by default (the files
//! are downloaded); run with
//! `cargo xtask models fetch && cargo test -p constraint-verify --test real_models -- --ignored --nocapture`.

use std::path::PathBuf;

use constraint_articulated::{Method, MjcfScene};

fn models_dir() -> PathBuf {
    std::env::var_os("MJCF_MODELS_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/models"))
}

#[test]
#[ignore = "needs the models fetched by `cargo xtask models fetch`"]
fn real_models_run_passive_and_stay_sane() {
    let dir = models_dir();
    let mut files: Vec<PathBuf> = ["gymnasium", "dm_control"]
        .iter()
        .flat_map(|s| std::fs::read_dir(dir.join(s)).into_iter().flatten())
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "xml"))
        // dm_control's templates are replaced by the generated lqr_2_1 and swimmer6.
        .filter(|p| {
            let dm = p.to_string_lossy().contains("dm_control");
            !(dm && (p.ends_with("lqr.xml") || p.ends_with("swimmer.xml")))
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no models in {}", dir.display());
    let mut ran = 0;
    let mut failures = Vec::new();
    println!("| model | steps | max joint separation (m) | max penetration (m) | final penetration (m) | energy change (J) | passive, no contact |");
    println!("|---|---:|---:|---:|---:|---:|---|");
    for path in &files {
        let name = format!(
            "{}/{}",
            path.parent()
                .and_then(|p| p.file_name())
                .map_or("".into(), |s| s.to_string_lossy()),
            path.file_stem().map_or("".into(), |s| s.to_string_lossy())
        );
        let Ok(mut scene) = MjcfScene::from_file(path, None) else {
            continue;
        };
        let h = scene.timestep;
        let steps = (5.0 / h).round() as usize;
        let w = &mut scene.world;
        let passive = w.actuators().is_empty() && w.colliders().is_empty();
        let e0 = {
            let (k, p) = w.energy();
            k + p
        };
        let (mut sep, mut pen): (f64, f64) = (0.0, 0.0);
        let mut prev = e0;
        let mut result = Ok(());
        for _ in 0..steps {
            if let Err(e) = w.step(h, Method::default()) {
                result = Err(e.to_string());
                break;
            }
            sep = sep.max(w.max_separation());
            pen = pen.max(w.unilateral_stats().max_penetration);
            let (k, p) = w.energy();
            prev = k + p;
        }
        let finite = w
            .bodies()
            .iter()
            .all(|b| b.pose.x.is_finite() && b.v.is_finite() && b.omega.is_finite());
        let last_pen = w.unilateral_stats().max_penetration;
        println!(
            "| {name} | {steps} | {sep:.1e} | {pen:.1e} | {last_pen:.1e} | {:.2e} | {passive} |",
            prev - e0
        );
        ran += 1;
        if let Err(e) = result {
            failures.push(format!("{name}: {e}"));
            continue;
        }
        // Gates: joints at the projection tolerance (RATTLE's SHAKE to 1e-12 m; the
        // velocity-level fallback steps project to the same), penetration within 1 cm
        // at the end (slop 0.1 mm plus the Baumgarte residue; an initial overlap, as
        // humanoidstandup's 3.6 cm lying in the floor at qpos0, is corrected over the
        // run), finite state.
        if !finite {
            failures.push(format!("{name}: non-finite state"));
        }
        if sep > 1e-6 {
            failures.push(format!("{name}: joint separation {sep:e} m"));
        }
        if last_pen > 1e-2 {
            failures.push(format!("{name}: penetration {last_pen:e} m at the end"));
        }
        // No actuators, no contact: energy may only be lost (damping) or kept (RATTLE is
        // symplectic; its energy error oscillates, bounded).
        if passive && prev - e0 > 1e-4 * (1.0 + e0.abs()) {
            failures.push(format!("{name}: energy grew by {:e} J", prev - e0));
        }
    }
    println!("{ran} models ran");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// dm_control's `manipulator` and `stacker` (issue 13): a tendon equality couples the
/// fingers (`coupling`), with contact, actuators (zero control) and joint limits. Each
/// runs 5 s from `qpos0` at the velocity level and with the default method (RATTLE,
/// whose steps with contact or limit rows run at the velocity level with projection),
/// passive and
/// with the grasp motor closing (velocity level) or opening (default), and reports
/// time per step, the worst equality violation, joint separation and the final
/// penetration. Run with
/// `cargo test --release -p constraint-verify --test real_models -- --ignored equality --nocapture`.
#[test]
#[ignore = "needs the models fetched by `cargo xtask models fetch`"]
fn manipulator_and_stacker_hold_their_equalities() {
    let dir = models_dir().join("dm_control");
    println!("| model | method | steps | us/step | max equality violation | max joint separation (m) | final penetration (m) | equality fallbacks | grasp tendon moved |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for name in ["manipulator", "stacker"] {
        let path = dir.join(format!("{name}.xml"));
        let scene =
            MjcfScene::from_file(&path, None).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(scene.world.equalities().len(), 1, "{name}");
        let grasp = scene
            .actuator_names
            .iter()
            .position(|n| n == "grasp")
            .expect("grasp actuator");
        for (label, method, ctrl) in [
            ("velocity", Method::Velocity { beta: 1.0 }, 0.0),
            ("default", Method::default(), 0.0),
            ("velocity, grasp = 1", Method::Velocity { beta: 1.0 }, 1.0),
            ("default, grasp = -1", Method::default(), -1.0),
        ] {
            let mut w = scene.world.clone();
            w.set_ctrl(grasp, ctrl).expect("ctrl");
            // The coupling tendon (the second) and the grasp tendon (the first).
            let grasp0 = w.tendon_length(0).expect("grasp tendon").0;
            let h = scene.timestep;
            let steps = (5.0 / h).round() as usize;
            let (mut eq, mut sep, mut fallbacks) = (0.0f64, 0.0f64, 0usize);
            let start = std::time::Instant::now();
            for i in 0..steps {
                let s = w
                    .step(h, method)
                    .unwrap_or_else(|e| panic!("{name} {label} step {i}: {e}"));
                fallbacks += s.equality_fallbacks;
                eq = eq.max(w.max_equality_violation());
                sep = sep.max(w.max_separation());
            }
            let us = start.elapsed().as_secs_f64() / steps as f64 * 1e6;
            let pen = w.unilateral_stats().max_penetration;
            let moved = (w.tendon_length(0).expect("grasp tendon").0 - grasp0).abs();
            println!("| {name} | {label} | {steps} | {us:.0} | {eq:.1e} | {sep:.1e} | {pen:.1e} | {fallbacks} | {moved:.3} |");
            if ctrl != 0.0 {
                // The motor closes or opens the fingers while the coupling holds.
                assert!(moved > 0.05, "{name} {label}: grasp tendon moved {moved}");
            }
            assert!(
                w.bodies()
                    .iter()
                    .all(|b| b.pose.x.is_finite() && b.v.is_finite()),
                "{name} {label}: non-finite"
            );
            // Measured (both models, all four runs): equality ≤ 4.4e-16 (the coupling
            // is linear in two hinges on one body), separation ≤ 4.8e-6 m (manipulator,
            // velocity level; 1.2e-13 default), final penetration ≤ 9.8e-8 m; the
            // grasp motor moves its tendon by 0.644 (closing) and 0.175 (opening).
            assert!(eq <= 1e-10, "{name} {label}: equality violation {eq:e}");
            assert!(sep <= 1e-5, "{name} {label}: joint separation {sep:e}");
            assert!(pen <= 1e-4, "{name} {label}: final penetration {pen:e}");
        }
    }
}
