//! Hinges of one body at different `pos` (issue 13): the MJCF adapter maps their lines,
//! not their `pos`, to a compound joint. Lines through one point (dm_control fish's fins)
//! are a joint at that point; two hinges alone on skew lines (humanoid's ankles) an
//! offset universal joint; anything else is a typed error naming the body and its line.
//! The state MuJoCo's `qpos`/`qvel` describe (the loader's `mj_kinematics` and
//! `mj_comVel`) must come back from the joint's coordinates and rate rows.

use constraint_articulated::{JointKind, MjcfScene};
use constraint_core::compound::MAX_DOF;
use constraint_core::{DVec3, Pose};
use constraint_verify::fd::Rng;

fn root() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A body hung from the world with the given joint lines, one `<joint .../>` each.
fn body_with(joints: &str) -> String {
    format!(
        r#"<mujoco>
  <option><flag contact="disable"/></option>
  <worldbody>
    <body name="link" pos="0.1 0.2 0.3" quat="0.9 0.1 -0.3 0.2">
{joints}
      <inertial pos="0.05 0.1 -0.4" mass="1" diaginertia="0.02 0.025 0.01"/>
    </body>
  </worldbody>
</mujoco>"#
    )
}

fn load(xml: &str) -> Result<(constraint_mjcf::Model, MjcfScene), String> {
    let model = constraint_mjcf::load_str(xml).map_err(|e| e.to_string())?;
    let scene = MjcfScene::new(&model, None).map_err(|e| e.to_string())?;
    Ok((model, scene))
}

/// Sets random `qpos`, `qvel` (MuJoCo's) and returns the worst difference to the joint's
/// coordinates and to the rates its rows give, over `n` draws, and the worst row value.
fn round_trip(model: &constraint_mjcf::Model, scene: &mut MjcfScene, n: usize) -> [f64; 3] {
    let mut rng = Rng::new(7);
    let (mut dq, mut dv, mut dc): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let nq = model.nq();
    for _ in 0..n {
        let q: Vec<f64> = (0..nq).map(|_| rng.uniform(-2.0, 2.0)).collect();
        let v: Vec<f64> = (0..nq).map(|_| rng.uniform(-3.0, 3.0)).collect();
        scene.set_generalized(model, &q, &v).unwrap();
        let w = &scene.world;
        let joint = &w.joints()[0];
        let JointKind::Compound(c, _) = &joint.kind else {
            panic!("not a compound joint: {:?}", joint.kind);
        };
        let body = &w.bodies()[joint.child];
        let (got, k) = w.joint_coordinates(0).unwrap();
        assert_eq!(k, nq);
        let rows = c.dof_rows(&Pose::IDENTITY, &body.pose, &got);
        for i in 0..nq {
            dq = dq.max((got[i] - q[i]).abs());
            let rate = rows[i][2].dot(body.v) + rows[i][3].dot(body.omega);
            dv = dv.max((rate - v[i]).abs());
        }
        let value = c.jacobian6(&Pose::IDENTITY, &body.pose).value;
        for x in &value[..MAX_DOF - c.dof()] {
            dc = dc.max(x.abs());
        }
    }
    [dq, dv, dc]
}

/// dm_control fish's fins: `roll` about y through the body origin, then `pitch` about x
/// through (0, .005, 0). The lines meet at (0, .005, 0), the joint's anchor.
#[test]
fn hinge_lines_through_one_point_are_one_anchor() {
    let xml = body_with(
        r#"      <joint name="roll" axis="0 1 0"/>
      <joint name="pitch" axis="1 0 0" pos="0 .005 0"/>"#,
    );
    let (model, mut scene) = load(&xml).unwrap();
    let JointKind::Compound(c, _) = &scene.world.joints()[0].kind else {
        panic!("not a compound joint");
    };
    assert_eq!(c.skew_distance(), None);
    let b = &scene.world.bodies()[0];
    let anchor = b.pose.point(c.anchor_b());
    // The body frame: pos (0.1, 0.2, 0.3), quat normalised; (0, .005, 0) in it.
    let r = constraint_core::DQuat::from_xyzw(0.1, -0.3, 0.2, 0.9).normalize();
    let want = DVec3::new(0.1, 0.2, 0.3) + r * DVec3::new(0.0, 0.005, 0.0);
    let err = (anchor - want).length();
    let [dq, dv, dc] = round_trip(&model, &mut scene, 200);
    println!(
        "fins: anchor error {err:.1e} m, |q − qpos| {dq:.1e}, |q̇ − qvel| {dv:.1e}, |C| {dc:.1e}"
    );
    // Measured: anchor 8.3e-17 m, coordinates 4.4e-16, rates 1.3e-15, rows 3.6e-16.
    assert!(err < 1e-14, "{err}");
    assert!(dq < 1e-12, "{dq}");
    assert!(dv < 1e-12, "{dv}");
    assert!(dc < 1e-14, "{dc}");
}

/// `scenes/offset_universal.xml` (humanoid's ankle: hinges on lines 4.47 cm apart):
/// an offset universal joint whose coordinates and rates are MuJoCo's `qpos`, `qvel`.
#[test]
fn hinges_on_skew_lines_are_an_offset_universal_joint() {
    let xml = std::fs::read_to_string(root().join("scenes/offset_universal.xml")).unwrap();
    let (model, mut scene) = load(&xml).unwrap();
    let JointKind::Compound(c, _) = &scene.world.joints()[0].kind else {
        panic!("not a compound joint");
    };
    // Lines: (0, y, 0) and (0, 0, −0.05) + t (1, 0, .5): distance 0.05 / √1.25.
    let want = 0.05 / 1.25f64.sqrt();
    let delta = c.skew_distance().unwrap();
    let [dq, dv, dc] = round_trip(&model, &mut scene, 200);
    println!(
        "ankle: δ − δ* {:.1e} m, |q − qpos| {dq:.1e}, |q̇ − qvel| {dv:.1e}, |C| {dc:.1e}",
        delta - want
    );
    // Measured: δ 3.5e-17 m, coordinates 4.4e-16, rates 1.3e-15, rows 3.7e-16.
    assert!((delta - want).abs() < 1e-14);
    assert!(dq < 1e-12, "{dq}");
    assert!(dv < 1e-12, "{dv}");
    assert!(dc < 1e-14, "{dc}");
}

/// Compositions the joint cannot hold are typed errors naming the body and its line:
/// three hinges on mutually skew lines (dm_control dog's scapula), a slide after a
/// hinge, a slide before two hinges on skew lines; four hinges are dependent axes.
#[test]
fn uncomposable_hinges_are_errors_naming_the_body() {
    let cases = [
        (
            "three skew hinges",
            r#"      <joint axis="0 0 1" pos="-0.03 -0.02 0"/>
      <joint axis="1 0 0" pos="0 -0.05 -0.07"/>
      <joint axis="0.287 0.958 0" pos="0 0 0"/>"#,
            "not supported",
        ),
        (
            "slide after hinge",
            r#"      <joint axis="0 0 1"/>
      <joint type="slide" axis="1 0 0"/>"#,
            "not supported",
        ),
        (
            "slide then skew hinges",
            r#"      <joint type="slide" axis="1 0 0"/>
      <joint axis="0 1 0"/>
      <joint axis="1 0 0" pos="0 0 -0.05"/>"#,
            "not supported",
        ),
        (
            "four hinges",
            r#"      <joint axis="0 0 1"/>
      <joint axis="1 0 0" pos="0 0 -0.05"/>
      <joint axis="0 1 0" pos="0 0 -0.05"/>
      <joint axis="1 1 0" pos="0 0 -0.05"/>"#,
            "dependent",
        ),
        (
            "parallel hinges at different pos",
            r#"      <joint axis="0 0 1"/>
      <joint axis="0 0 1" pos="0.1 0 0"/>"#,
            "dependent",
        ),
    ];
    for (what, joints, says) in cases {
        let e = load(&body_with(joints)).map(|_| ()).unwrap_err();
        println!("{what}: {e}");
        assert!(e.contains("body \"link\" (line 4)"), "{what}: {e}");
        assert!(e.contains(says), "{what}: {e}");
    }
}

/// The real models with such joints (fetched by `cargo xtask models fetch`, never
/// committed; `MJCF_MODELS_DIR` or `target/models`): dm_control fish (fins on lines
/// meeting off both `pos`) and humanoid (ankles on skew lines) load, and run 5 s with the
/// default method from `qpos0` with every hinge rate drawn in ±1 rad/s (the free root at
/// rest: fish swims in a fluid of density 5000, whose explicit drag on its 29 g torso is
/// unstable at the file's 4 ms step from a 1 m/s start — in MuJoCo's Euler too, which
/// reports a huge qacc at t = 0.012 s and resets), staying finite with the joints held. Run with
/// `cargo test -p constraint-verify --test compound_lines -- --ignored --nocapture`.
#[test]
#[ignore = "needs the models fetched by `cargo xtask models fetch`"]
fn fish_and_humanoid_load_and_run() {
    let dir = std::env::var_os("MJCF_MODELS_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| root().join("target/models"));
    for name in ["fish", "humanoid"] {
        let path = dir.join(format!("dm_control/{name}.xml"));
        let model = constraint_mjcf::load_file(&path).unwrap();
        let mut scene = MjcfScene::new(&model, None).unwrap();
        let mut rng = Rng::new(13);
        let qvel: Vec<f64> = (0..model.nv())
            .map(|k| if k < 6 { 0.0 } else { rng.uniform(-1.0, 1.0) })
            .collect();
        scene.set_generalized(&model, &[], &qvel).unwrap();
        let compound = scene
            .world
            .joints()
            .iter()
            .filter(|j| matches!(j.kind, JointKind::Compound(..)))
            .count();
        let h = scene.timestep;
        let steps = (5.0 / h).round() as usize;
        let mut sep: f64 = 0.0;
        let start = std::time::Instant::now();
        for _ in 0..steps {
            scene
                .world
                .step(h, constraint_articulated::Method::default())
                .unwrap();
            sep = sep.max(scene.world.max_separation());
        }
        let per_step = start.elapsed().as_secs_f64() / steps as f64;
        let finite = scene
            .world
            .bodies()
            .iter()
            .all(|b| b.pose.x.is_finite() && b.v.is_finite() && b.omega.is_finite());
        println!(
            "{name}: {compound} compound joints, {steps} steps of {h} s, {:.1} µs/step, \
             max joint separation {sep:.1e} m, final state finite {finite}",
            per_step * 1e6
        );
        // Measured: fish 2.5e-14 m (58 µs/step), humanoid 9.9e-13 m (782 µs/step; the
        // projection tolerance is 1e-12 m), both finite.
        assert!(finite, "{name}");
        assert!(sep < 1e-9, "{name}: {sep}");
    }
}

/// The curvature bound the velocity level's geometric stiffness screens with,
/// `|Σ λ_r ∂²C_r| ≤ 2 lever Σ|λ_r|` (largest entry), holds for the offset universal joint
/// of `scenes/offset_universal.xml` over random poses near the joint and random weights.
#[test]
fn offset_universal_curvature_is_within_the_lever_bound() {
    let xml = std::fs::read_to_string(root().join("scenes/offset_universal.xml")).unwrap();
    let (model, mut scene) = load(&xml).unwrap();
    let mut rng = Rng::new(21);
    let mut worst: f64 = 0.0;
    for _ in 0..500 {
        let q = [rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)];
        scene.set_generalized(&model, &q, &[]).unwrap();
        let joint = &scene.world.joints()[0];
        let mut b = scene.world.bodies()[0].pose;
        b.x += rng.in_box(DVec3::ZERO, 0.01);
        let mut w = [0.0; constraint_articulated::joint::MAX_ROWS];
        for x in w.iter_mut().take(joint.hard_rows()) {
            *x = rng.uniform(-1.0, 1.0);
        }
        let k = joint.curvature(&Pose::IDENTITY, &b, &w);
        let big = (0..12)
            .flat_map(|i| (0..12).map(move |j| (i, j)))
            .map(|(i, j)| k.entry(i, j).abs())
            .fold(0.0, f64::max);
        let bound = 2.0 * joint.lever() * w.iter().map(|x| x.abs()).sum::<f64>();
        worst = worst.max(big / bound);
    }
    println!("offset universal: worst curvature / lever bound {worst:.2}");
    // Measured: 0.14 (without the skew term in `lever`: 4.93, the bound broken).
    assert!(worst <= 1.0, "{worst}");
}
