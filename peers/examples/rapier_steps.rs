//! A fixed run of rapier3d (f64) on one of the contact scenes, for instruction counts
//! against this library's soft step on the same scene (`valgrind --tool=callgrind`;
//! subtract a shorter run for the count per step, as with `constraint-contact`'s
//! `soft_points` example). Needs the `rapier` feature.
//!
//! `cargo run -p constraint-peers --release --features rapier --example rapier_steps -- SCENE STEPS`
//!
//! `SCENE`: `stack10` or `pyramid20` (`Scene::Stack(10)`, `Scene::Pyramid(20)`: the
//! scenes of the `contact_peers` bench, rapier's default integration parameters at
//! `dt = 1/60`, sleeping off). Prints the top box's final sink and the worst
//! displacement of any box.

use constraint_peers::contact::rapier::RapierBoxes;
use constraint_peers::contact::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("stack10", String::as_str);
    let scene = Scene::from_name(name).ok_or(format!("unknown scene {name}"))?;
    let steps: usize = args.get(1).map_or(Ok(600), |s| s.parse())?;
    let w = scene.world()?;
    let mut r = RapierBoxes::from_world(&w, 1.0 / 60.0)?;
    let x0 = r.centres();
    let top = (0..x0.len()).fold(0, |t, i| if x0[i][2] > x0[t][2] { i } else { t });
    for _ in 0..steps {
        r.step();
    }
    let x = r.centres();
    let worst = x
        .iter()
        .zip(&x0)
        .map(|(p, q)| {
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max);
    println!(
        "{} rapier3d {steps} steps: top sink {:.3e} m, worst {:.3e} m",
        scene.name(),
        x0[top][2] - x[top][2],
        worst
    );
    Ok(())
}
