//! The soft step (`ContactSolver::SoftStep`, Box2D v3's sub-stepped soft contact
//! solver): a stack and a pyramid at rest, the stack's sink against the contact-spring
//! model, Coulomb sliding distance, bad settings as typed errors, energy on a resting
//! stack, determinism, and the ground carrying the stack's weight.
//!
//! Tolerances sit above the values measured on this code (written beside each).

use constraint_contact::rigid::{
    ContactError, ContactSolver, ContactWorld, RowsSolver, SoftStepSettings,
};
use constraint_contact::scenes::{add_box, box_stack, ground, heavy_on_light, pyramid};
use constraint_core::DVec3;

const DT: f64 = 1.0 / 60.0;
const G: f64 = 9.81;

fn soft(mut w: ContactWorld, substeps: usize) -> ContactWorld {
    w.settings.solver = ContactSolver::SoftStep { substeps };
    w
}

/// Runs `steps` steps; returns (top-box drift, top-box sink at the end, worst
/// displacement of any box over the run), in metres.
fn run(w: &mut ContactWorld, steps: usize) -> (f64, f64, f64) {
    let x0: Vec<DVec3> = w.bodies().iter().map(|b| b.pose.x).collect();
    let top = (0..x0.len())
        .max_by(|&i, &j| x0[i].z.total_cmp(&x0[j].z).then(j.cmp(&i)))
        .unwrap();
    let (mut drift, mut worst) = (0.0f64, 0.0f64);
    for _ in 0..steps {
        w.step(DT).unwrap();
        for (i, b) in w.bodies().iter().enumerate() {
            let d = (b.pose.x - x0[i]).length();
            worst = worst.max(d);
            if i == top {
                drift = drift.max(d);
            }
        }
    }
    (drift, x0[top].z - w.bodies()[top].pose.x.z, worst)
}

/// Ten unit boxes (1000 kg) for 10 s at 60 Hz with 4 sub-steps: the stack stands, and
/// it settles by what the contact springs predict. A soft row of effective mass `m`
/// and frequency `ω` is a spring `m ω²`; a corner point between two unit boxes has
/// `m = M/8` (a box–ground corner `M/4`) and carries a quarter of the weight above it,
/// so `k` boxes compress a box–box contact by `2 k g/ω²` and the ten a ground contact
/// (twice the frequency) by `2.5 g/ω²`: the top sinks `(2·45 + 2.5) g/ω²` = 25.5 mm
/// at 30 Hz.
#[test]
fn stack_of_ten_stands_and_settles_as_the_contact_springs_predict() {
    let mut w = soft(box_stack(10).unwrap(), 4);
    let (drift, sink, worst) = run(&mut w, 600);
    let omega = std::f64::consts::TAU * SoftStepSettings::default().hertz;
    let predicted = 92.5 * G / (omega * omega);
    assert!(drift < 4e-2, "top drift {drift:e} m"); // measured 2.79e-2
    assert!(worst < 4e-2, "worst displacement {worst:e} m"); // measured 2.79e-2
    assert!(
        (sink - predicted).abs() < 1e-2 * predicted,
        "sink {sink:e} m, springs predict {predicted:e} m"
    ); // measured 2.5533e-2 against 2.5538e-2 (0.02 %)
}

/// A pyramid with a base of 10 (55 boxes) for 10 s with 4 sub-steps holds.
#[test]
fn pyramid_holds() {
    let mut w = soft(pyramid(10).unwrap(), 4);
    let (_, _, worst) = run(&mut w, 600);
    assert!(worst < 1e-2, "worst displacement {worst:e} m"); // measured 8.30e-3
}

/// A unit box sliding at 3 m/s on μ = 0.5 for 2 s with 4 sub-steps, friction anchors
/// on or off: its final speed and where it stopped.
fn slide(anchors: bool) -> (f64, f64) {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -G));
    ground(&mut w, 0.5).unwrap();
    let b = add_box(
        &mut w,
        DVec3::splat(0.5),
        None,
        DVec3::new(0.0, 0.0, 0.5),
        0.5,
    )
    .unwrap();
    w.bodies_mut()[b].v = DVec3::new(3.0, 0.0, 0.0);
    let mut w = soft(w, 4);
    w.settings.soft_step.friction_anchors = anchors;
    for _ in 0..120 {
        w.step(DT).unwrap();
    }
    (w.bodies()[b].v.length(), w.bodies()[b].pose.x.x)
}

/// A unit box sliding at 3 m/s on μ = 0.5 stops after `v²/(2 μ g)` = 0.917 m.
#[test]
fn sliding_box_stops_at_the_coulomb_distance() {
    let (v, x) = slide(false);
    let expected = 9.0 / (2.0 * 0.5 * G);
    assert!(v < 1e-6, "{v:e}"); // measured 3.2e-12
    assert!(
        (x - expected).abs() < 1e-2 * expected,
        "stopped at {x} m, Coulomb {expected} m"
    ); // measured 0.9112 against 0.9174 (−0.68 %)
}

/// Zero or more than `MAX_SUBSTEPS` sub-steps (`usize::MAX` would never end), a NaN or
/// zero frequency, a negative or NaN damping ratio, a negative
/// push velocity: typed errors naming the setting, the state unchanged.
#[test]
fn bad_settings_are_typed_errors() {
    type Spoil = fn(&mut SoftStepSettings);
    let cases: [(&str, usize, Spoil); 10] = [
        ("substeps", 0, |_| {}),
        (
            "substeps",
            constraint_contact::rigid::MAX_SUBSTEPS + 1,
            |_| {},
        ),
        ("substeps", usize::MAX, |_| {}),
        ("soft_step.hertz", 4, |s| s.hertz = f64::NAN),
        ("soft_step.hertz", 4, |s| s.hertz = 0.0),
        ("soft_step.damping_ratio", 4, |s| s.damping_ratio = -1.0),
        ("soft_step.damping_ratio", 4, |s| s.damping_ratio = f64::NAN),
        ("soft_step.max_push_velocity", 4, |s| {
            s.max_push_velocity = -1.0
        }),
        ("soft_step.one_way_mass_ratio", 4, |s| {
            s.one_way_mass_ratio = 0.5
        }),
        ("soft_step.one_way_mass_ratio", 4, |s| {
            s.one_way_mass_ratio = f64::NAN
        }),
    ];
    for (name, substeps, spoil) in cases {
        let mut w = soft(box_stack(2).unwrap(), substeps);
        spoil(&mut w.settings.soft_step);
        let before: Vec<_> = w.bodies().to_vec();
        match w.step(DT) {
            Err(ContactError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{name}: {other:?}"),
        }
        assert_eq!(w.bodies(), &before[..], "{name}: state changed");
    }
}

/// On a resting stack (after 2 s of settling) the energy does not grow: over the next
/// 8 s it changes by less than 1 J of the stack's 4.9e5 J of potential energy.
#[test]
fn energy_does_not_grow_on_a_resting_stack() {
    let mut w = soft(box_stack(10).unwrap(), 4);
    for _ in 0..120 {
        w.step(DT).unwrap();
    }
    let start = w.energy();
    let mut highest = start;
    for _ in 0..480 {
        w.step(DT).unwrap();
        highest = highest.max(w.energy());
    }
    assert!(highest - start < 1.0, "energy rose {:e} J", highest - start); // measured 0 (never above the start; of 4.89e5 J)
}

/// At rest the ground's normal impulses over one step carry the stack's weight:
/// `Σ λ_n = M g h` (the sum over the sub-steps of each sub-step's impulse).
#[test]
fn the_ground_carries_the_weight() {
    let mut w = soft(box_stack(10).unwrap(), 4);
    for _ in 0..300 {
        w.step(DT).unwrap();
    }
    w.step(DT).unwrap();
    let ground_collider = 0;
    let carried: f64 = w
        .contacts()
        .iter()
        .enumerate()
        .filter(|(_, c)| c.a == ground_collider)
        .map(|(k, _)| w.impulses()[3 * k])
        .sum();
    let weight = 10.0 * 1000.0 * G * DT;
    assert!(
        (carried - weight).abs() < 1e-3 * weight,
        "ground impulse {carried} N·s, weight {weight} N·s"
    ); // measured relative error 1.2e-6
}

/// Same input, same output: two runs of a 21-box pyramid's first second are
/// bit-identical, and the recorded solver path is the soft step.
#[test]
fn deterministic_and_reported() {
    let go = || {
        let mut w = soft(pyramid(6).unwrap(), 4);
        for _ in 0..60 {
            w.step(DT).unwrap();
        }
        w
    };
    let (a, b) = (go(), go());
    assert_eq!(a.bodies(), b.bodies());
    assert_eq!(a.impulses(), b.impulses());
    let path = a.last_path().expect("stepped");
    assert_eq!(path.rows, RowsSolver::SoftStep, "{path:?}");
}

/// Friction anchors (`SoftStepSettings::friction_anchors`) on a stiff stack: ten boxes
/// at 120 Hz with 8 sub-steps for 10 s. Without anchors the stack sways as well as
/// sinks; the anchors pull each sticking pair back to where it stuck, and the top
/// box's largest displacement drops by a third while the sink (the springs'
/// compression) stays.
#[test]
fn friction_anchors_cut_the_sway_of_a_stiff_stack() {
    let go = |anchors: bool| {
        let mut w = soft(box_stack(10).unwrap(), 8);
        w.settings.soft_step.hertz = 120.0;
        w.settings.soft_step.friction_anchors = anchors;
        run(&mut w, 600)
    };
    let (plain, plain_sink, _) = go(false);
    let (anchored, anchored_sink, _) = go(true);
    assert!(plain > 6.5e-3, "without anchors {plain:e} m"); // measured 7.50e-3
    assert!(anchored < 5.5e-3, "with anchors {anchored:e} m"); // measured 4.81e-3
    assert!(
        (anchored_sink - plain_sink).abs() < 5e-4,
        "sink {anchored_sink:e} m against {plain_sink:e} m"
    ); // measured 1.596e-3 against 1.592e-3
}

/// A sliding contact forgets its anchor: with anchors on, the box sliding at 3 m/s
/// still stops at the Coulomb distance `v²/(2 μ g)` and stays there.
#[test]
fn friction_anchors_let_a_box_slide() {
    let (v, x) = slide(true);
    let expected = 9.0 / (2.0 * 0.5 * G);
    assert!(v < 1e-6, "{v:e}"); // measured 3.9e-10
    assert!(
        (x - expected).abs() < 1e-2 * expected,
        "stopped at {x} m, Coulomb {expected} m"
    ); // measured 0.9110 against 0.9174 (−0.70 %)
}

/// The 10⁴:1 box on a 0.5 m box (issue 14's mass-ratio case) for 10 s with 4
/// sub-steps. Without one-way coupling one Gauss–Seidel pass per sub-step cannot stop
/// the heavy box and it crushes the light one (sinks its full 0.5 m); with
/// `one_way_mass_ratio` 100 the light box is static for the rows it shares with the
/// heavy one, every step succeeds and the heavy box sinks by its contact spring only.
/// The price, as documented: the ground carries the light box's weight alone.
#[test]
fn one_way_coupling_holds_a_heavy_box_on_a_light_one() {
    let go = |ratio: f64| {
        let mut w = soft(heavy_on_light(1e4).unwrap(), 4);
        w.settings.soft_step.one_way_mass_ratio = ratio;
        let r = run(&mut w, 600);
        (r, w)
    };
    let ((_, crushed, _), _) = go(f64::INFINITY);
    let ((_, sink, worst), mut w) = go(100.0);
    assert!(crushed > 0.4, "without: sink {crushed:e} m"); // measured 5.00e-1
    assert!(sink.abs() < 1e-3, "with: sink {sink:e} m"); // measured 1.90e-4
    assert!(worst < 1e-3, "with: worst displacement {worst:e} m"); // measured 1.93e-4
    w.step(DT).unwrap();
    let light = 125.0 * G * DT;
    let carried: f64 = w
        .contacts()
        .iter()
        .enumerate()
        .filter(|(_, c)| c.a == 0)
        .map(|(k, _)| w.impulses()[3 * k])
        .sum();
    assert!(
        (carried - light).abs() < 1e-2 * light,
        "ground impulse {carried} N·s, light box's weight {light} N·s"
    ); // measured 20.4375 against 20.4375 N·s (relative error below 1e-15)
}
