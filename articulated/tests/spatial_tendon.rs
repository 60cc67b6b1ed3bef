//! Spatial tendons from MJCF (`mjcf/tests/data/spatial_tendon.xml`: a string from a
//! world site through a ring on a swinging arm to a ball on two slides, and a second,
//! slack string from the ring to the ball): lengths at `qpos0`, the rate against finite
//! differences over random states, the range as a rope, the spring's energy.

#![cfg(feature = "mjcf")]

use constraint_articulated::{Method, MjcfScene, RowSource};
use constraint_mjcf::Model;

fn text() -> String {
    // Reads ../mjcf/tests/data (excluded from the package in Cargo.toml).
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../mjcf/tests/data/spatial_tendon.xml");
    std::fs::read_to_string(path).expect("spatial_tendon.xml")
}

fn scene(xml: &str) -> (Model, MjcfScene) {
    let model = constraint_mjcf::load_str(xml).expect("model");
    let scene = MjcfScene::new(&model, None).expect("scene");
    (model, scene)
}

fn lcg(s: &mut u64) -> f64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

#[test]
fn lengths_at_qpos0_and_spring_lengths() {
    let (_, s) = scene(&text());
    let w = &s.world;
    assert_eq!(w.tendons().len(), 2);
    assert_eq!((w.tendon_path(0).len(), w.tendon_path(1).len()), (3, 2));
    // anchor (0 0 1.2) → ring (0.4 0 1) → knot (0.4 0 0.65): √0.2 + 0.35.
    let (l, rate) = w.tendon_length(0).expect("string");
    let expected = 0.2f64.sqrt() + 0.35;
    assert!((l - expected).abs() < 1e-12, "L {l}"); // measured 0
    assert_eq!(rate, 0.0);
    assert!((w.tendon_length(1).expect("slack").0 - 0.35).abs() < 1e-12);
    // `springlength="0.6"`; the slack string's default rest length is its length at
    // qpos0.
    assert_eq!(w.tendons()[0].rest_length, 0.6);
    assert!((w.tendons()[1].rest_length - 0.35).abs() < 1e-12);
    assert_eq!(
        (w.tendons()[0].stiffness, w.tendons()[0].damping),
        (40.0, 0.5)
    );
    assert_eq!(w.tendon_ranges()[0], Some([0.0, 0.9]));
}

/// `L̇ = J v` against central differences of `L` along the generalized velocity, over
/// 200 random states (arm angle, ball position and their rates).
#[test]
fn tendon_rate_matches_finite_differences() {
    let (model, mut s) = scene(&text());
    let mut seed = 17u64;
    let eps = 1e-6;
    let (mut worst, mut count) = (0.0f64, 0);
    for _ in 0..200 {
        let q = [
            2.0 * lcg(&mut seed),
            0.3 * lcg(&mut seed),
            0.3 * lcg(&mut seed),
        ];
        let v = [3.0 * lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)];
        let mut at = |h: f64, vel: &[f64]| {
            let qs: Vec<f64> = q.iter().zip(&v).map(|(a, b)| a + h * b).collect();
            s.set_generalized(&model, &qs, vel).expect("state");
            [0, 1].map(|t| s.world.tendon_length(t).expect("tendon"))
        };
        let mid = at(0.0, &v);
        let (plus, minus) = (at(eps, &[]), at(-eps, &[]));
        for t in 0..2 {
            let fd = (plus[t].0 - minus[t].0) / (2.0 * eps);
            worst = worst.max((fd - mid[t].1).abs() / (1.0 + fd.abs()));
            count += 1;
        }
    }
    println!("spatial tendon rate vs FD over {count} states: {worst:e}");
    // measured 3.2e-10 (central differences at ε = 1e-6)
    assert!(worst < 1e-8, "L̇ vs FD: {worst:e}");
}

/// Without its spring the string is a rope of length 0.9: the ball falls until the
/// range's upper row catches it, then hangs on it.
#[test]
fn range_holds_the_string_as_a_rope() {
    let xml = text().replace(
        r#"<tendon stiffness="40" damping="0.5"/>"#,
        r#"<tendon stiffness="0" damping="0"/>"#,
    );
    // Gates: the velocity level leaves the path's curvature over a step (a bent string
    // on a swinging arm, `O(h² v²/L)`), RATTLE projects the violated range away.
    for (method, gate) in [
        (Method::Velocity { beta: 1.0 }, 1e-3),
        // RATTLE's steps with the range row active project to the unilateral floor
        // (`World::DEFAULT_UNILATERAL_TOLERANCE`, 1e-8 m).
        (Method::default(), 1e-8),
    ] {
        let (_, mut s) = scene(&xml);
        assert_eq!(s.world.tendons()[0].stiffness, 0.0);
        let (mut top, mut pulled) = (f64::NEG_INFINITY, 0.0f64);
        for _ in 0..1500 {
            s.world.step(0.002, method).expect("step");
            top = top.max(s.world.tendon_length(0).expect("string").0);
            for (src, z) in s.world.row_impulses() {
                if let RowSource::TendonLimit {
                    tendon: 0,
                    upper: true,
                } = src
                {
                    pulled = pulled.max(z);
                }
            }
        }
        let (l, _) = s.world.tendon_length(0).expect("string");
        println!("{method:?}: highest L {top:.12}, final L {l:.12}, largest pull {pulled:e}");
        // The ball reached the rope's length (it falls from L = 0.80) ...
        assert!(top > 0.9 - 1e-3, "{method:?}: L never reached 0.9 ({top})");
        // ... and the row held it there (measured overshoot 5.2e-4 m at the velocity
        // level, 9.1e-9 m with RATTLE's projection at the 1e-8 m floor (1e-12 m at a
        // floor of 1e-12); joint separation 1.8e-6 and 1.2e-13 m).
        assert!(top <= 0.9 + gate, "{method:?}: overshoot {}", top - 0.9);
        assert!(pulled > 0.0, "{method:?}: the row never pulled");
        let sep = s.world.max_separation();
        println!("{method:?}: joint separation {sep:e} m");
        assert!(sep < 10.0 * gate, "{method:?}: joint separation {sep:e} m");
    }
}

/// The spring along the path conserves energy under RATTLE (undamped): the force
/// `Jᵀ f` is minus the gradient of `½ k (L − L₀)²`, which `World::energy` counts, so
/// the energy error is RATTLE's bounded, second-order one (a force that were not the
/// gradient would drift at first order).
#[test]
fn the_path_spring_conserves_energy() {
    let xml = text()
        .replace(r#"damping="0.5""#, r#"damping="0""#)
        .replace(r#"damping="0.1""#, r#"damping="0""#)
        .replace(r#"range="0 0.9""#, r#"range="0 5""#);
    let run = |h: f64| {
        let (_, mut s) = scene(&xml);
        let e0 = {
            let (k, p) = s.world.energy();
            k + p
        };
        let (mut worst, mut swing, mut stretch) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..(5.0 / h).round() as usize {
            s.world.step(h, Method::default()).expect("step");
            let (k, p) = s.world.energy();
            worst = worst.max((k + p - e0).abs());
            swing = swing.max(s.world.joint_position(0).expect("arm").abs());
            stretch = stretch.max(s.world.tendon_length(0).expect("string").0 - 0.6);
        }
        println!(
            "h {h}: energy error {worst:e} J (E0 {e0:.3} J) over 5 s, arm swing {swing:.3} rad, \
             stretch {stretch:.3} m"
        );
        // It moves: the arm swings and the spring stretches.
        assert!(swing > 0.1 && stretch > 0.1, "{swing} {stretch}");
        worst
    };
    let (coarse, fine) = (run(0.002), run(0.001));
    // measured 1.6e-3 J at h = 2 ms
    assert!(coarse < 5e-3, "energy error {coarse:e} J");
    // measured 3.4 (1.6e-3 / 4.8e-4 J; a first-order drift would halve, ratio 2)
    assert!(
        coarse > 2.8 * fine,
        "not second order: {coarse:e} vs {fine:e}"
    );
}

/// An `equality/tendon` on a spatial tendon is a typed error naming it (the equality
/// rows are sums of joint coordinates).
#[test]
fn an_equality_on_a_spatial_tendon_is_a_typed_error() {
    let xml = text().replace(
        "</tendon>",
        "</tendon>\n  <equality><tendon tendon1=\"string\"/></equality>",
    );
    let model = constraint_mjcf::load_str(&xml).expect("model");
    let e = MjcfScene::new(&model, None).expect_err("equality on a spatial tendon");
    let msg = e.to_string();
    assert!(
        msg.contains("\"string\" is spatial") && msg.contains("line 34"),
        "{msg}"
    );
}

/// A motor on the string (`gear="2"`) pulls along the path as a spring of the same
/// force would: one velocity-level step from the same state with the motor at
/// `ctrl = u` (no spring) and with a unit spring whose rest length is `L₀ + 2u` (no
/// control) gives the same state (both forces are explicit at the start of the step).
#[test]
fn a_motor_on_the_string_pulls_along_the_path() {
    let l0 = 0.2f64.sqrt() + 0.35;
    // u > 0: the rest length L₀ + 2u stays positive (a negative one means "the length
    // at qpos0").
    let u = 0.7;
    let free = text().replace(
        r#"<tendon stiffness="40" damping="0.5"/>"#,
        r#"<tendon stiffness="0" damping="0"/>"#,
    );
    let spring = text()
        .replace(
            r#"<tendon stiffness="40" damping="0.5"/>"#,
            r#"<tendon stiffness="1" damping="0"/>"#,
        )
        .replace(
            r#"springlength="0.6""#,
            &format!(r#"springlength="{:?}""#, l0 + 2.0 * u),
        );
    let (_, mut motor) = scene(&free);
    motor.world.set_ctrl(0, u).expect("ctrl");
    let (_, mut sprung) = scene(&spring);
    assert_eq!(sprung.world.tendons()[0].stiffness, 1.0);
    let (_, mut idle) = scene(&free);
    let m = Method::Velocity { beta: 1.0 };
    for w in [&mut motor.world, &mut sprung.world, &mut idle.world] {
        w.step(0.002, m).expect("step");
    }
    let (mut diff, mut moved): (f64, f64) = (0.0, 0.0);
    for ((a, b), c) in motor
        .world
        .bodies()
        .iter()
        .zip(sprung.world.bodies())
        .zip(idle.world.bodies())
    {
        diff = diff
            .max((a.v - b.v).length())
            .max((a.omega - b.omega).length());
        moved = moved.max((a.v - c.v).length());
    }
    println!("motor vs spring after one step: {diff:e} m/s (the motor changed v by {moved:e})");
    // The motor acts (measured 5.3e-3 m/s against no control) ...
    assert!(moved > 1e-3, "the motor did nothing: {moved:e}");
    // ... exactly as the spring of the same force (measured 0).
    assert!(diff < 1e-12, "motor vs spring: {diff:e} m/s");
}
