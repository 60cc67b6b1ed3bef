//! Jointless MJCF bodies merged into their hosts (`MjcfScene`, `MjcfOptions`): a hinge
//! chain whose second link carries a welded `tip` (with a welded `tip2` inside), a
//! `post` welded to the world, a spatial tendon from the post to the tip, and a connect
//! from tip2 to a free box hanging from it. Merged and unmerged builds agree; the merged
//! host's mass, centre of mass and inertia match a hand computation; sites and the
//! connect's anchor ride on their hosts.

#![cfg(feature = "mjcf")]

use constraint_articulated::mjcf::{MjcfOptions, PartState};
use constraint_articulated::{Method, MjcfScene};
use constraint_core::{DQuat, DVec3};

const CHAIN: &str = r#"
<mujoco>
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="post" pos="0.3 0 0.5" euler="0 0 30">
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
      <site name="s_post" pos="0 0 0.1"/>
    </body>
    <body name="link1" pos="0 0 1">
      <joint name="j1" type="hinge" axis="0 1 0" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" mass="1"/>
      <body name="link2" pos="0.4 0 0" euler="20 0 10">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.7"/>
        <body name="tip" pos="0.3 0 0" euler="0 40 15">
          <geom type="box" size="0.05 0.02 0.03" pos="0.05 0.01 0" mass="0.5"/>
          <site name="s_tip" pos="0.1 0 0.02"/>
          <body name="tip2" pos="0.1 0.02 0" euler="30 0 0">
            <geom type="sphere" size="0.03" pos="0.02 0 0" mass="0.2"/>
          </body>
        </body>
      </body>
    </body>
    <body name="link3" pos="0.75 0.05 0.95">
      <freejoint name="j3"/>
      <geom type="box" size="0.04 0.05 0.06" mass="0.3"/>
    </body>
  </worldbody>
  <equality>
    <connect name="c" body1="tip2" body2="link3" anchor="0.05 0 0"/>
  </equality>
  <tendon>
    <spatial name="t" stiffness="20" damping="0.5">
      <site site="s_post"/>
      <site site="s_tip"/>
    </spatial>
  </tendon>
</mujoco>
"#;

fn build(xml: &str, merge: bool) -> (constraint_mjcf::Model, MjcfScene) {
    let model = constraint_mjcf::load_str(xml).expect("model");
    let s = MjcfScene::with_options(
        &model,
        None,
        MjcfOptions {
            merge_welded: merge,
        },
    )
    .expect("scene");
    (model, s)
}

fn states(s: &MjcfScene) -> Vec<PartState> {
    let mut out = Vec::new();
    s.part_states(&mut out);
    out
}

fn body(model: &constraint_mjcf::Model, name: &str) -> usize {
    model
        .bodies
        .iter()
        .position(|b| b.name == name)
        .expect("body")
}

fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn quat(q: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize()
}

/// Six MJCF bodies: merged, four world bodies (post static, tip and tip2 in link2) and
/// three hinges plus the connect; unmerged, six bodies and three `Fixed` welds more.
#[test]
fn body_and_joint_counts() {
    let (model, m) = build(CHAIN, true);
    let (_, u) = build(CHAIN, false);
    assert_eq!(model.bodies.len(), 6);
    assert_eq!((m.world.bodies().len(), m.world.joints().len()), (3, 3));
    assert_eq!((u.world.bodies().len(), u.world.joints().len()), (6, 6));
    assert_eq!((m.parts.len(), m.body_names.len()), (6, 6));
    let link2 = m.parts[body(&model, "link2")].body;
    assert_eq!(link2, Some(1));
    assert_eq!(m.parts[body(&model, "tip")].body, link2);
    assert_eq!(m.parts[body(&model, "tip2")].body, link2);
    assert_eq!(m.parts[body(&model, "post")].body, None);
    assert!(m.parts[body(&model, "link1")].alone && !m.parts[body(&model, "link2")].alone);
}

/// A host of mass 2 (inertia diag(0.1, 0.2, 0.3)) with a jointless child of mass 1 at
/// x = 1, turned 90° about z (inertia diag(0.01, 0.02, 0.03) in its frame). By hand:
/// M = 3, C = (1/3, 0, 0); the child's inertia in the host frame is diag(0.02, 0.01,
/// 0.03); parallel axes add 2·(1/3)² and 1·(2/3)² to I_yy and I_zz: I = diag(0.12,
/// 0.21 + 2/3, 0.33 + 2/3).
#[test]
fn merged_mass_com_and_inertia_by_hand() {
    let xml = r#"
<mujoco>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint/>
      <inertial pos="0 0 0" mass="2" diaginertia="0.1 0.2 0.3"/>
      <body name="w" pos="1 0 0" euler="0 0 90">
        <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.02 0.03"/>
      </body>
    </body>
  </worldbody>
</mujoco>"#;
    let (_, s) = build(xml, true);
    assert_eq!(s.world.bodies().len(), 1);
    let b = &s.world.bodies()[0];
    assert!((b.mass() - 3.0).abs() < 1e-15, "M {}", b.mass()); // measured 0
    let c_err = (b.com - DVec3::new(1.0 / 3.0, 0.0, 0.0)).length();
    assert!(c_err < 1e-15, "C {:?}", b.com); // measured 0
    let expected = [0.12, 0.21 + 2.0 / 3.0, 0.33 + 2.0 / 3.0];
    let i = b.inertia();
    let mut worst = 0.0f64;
    for r in 0..3 {
        for c in 0..3 {
            let want = if r == c { expected[r] } else { 0.0 };
            worst = worst.max((i.col(c)[r] - want).abs());
        }
    }
    // Round-off of the 90° turn (cos 90° ≈ 6e-17) only: measured 1.1e-16.
    assert!(worst < 1e-15, "inertia off by {worst:e}: {i:?}");
    // The centre of mass in the world: origin (0, 0, 1) plus C.
    let x_err = (b.pose.x - DVec3::new(1.0 / 3.0, 0.0, 1.0)).length();
    assert!(x_err < 1e-15, "{:?}", b.pose.x); // measured 0
}

/// Sites and the connect's anchor at the default pose: every MJCF body's reported frame
/// is its `xpos`/`xquat`, the tendon's path points are the sites' world positions, and
/// after 1 s the connect still joins tip2's anchor and link3's.
#[test]
fn sites_and_anchor_ride_on_their_hosts() {
    let (model, mut s) = build(CHAIN, true);
    let p0 = states(&s);
    let mut worst_frame = 0.0f64;
    for (p, b) in p0.iter().zip(&model.bodies) {
        worst_frame = worst_frame.max((p.origin - v3(b.pos)).length());
        worst_frame = worst_frame.max(p.orientation.angle_between(quat(b.quat)));
    }
    assert!(worst_frame < 1e-14, "frames off by {worst_frame:e}"); // measured 1.2e-16
    let site_world = |s: &MjcfScene, k: usize| {
        let site = &model.sites[k];
        let p = s.part_state(site.body.expect("on a body")).expect("part");
        p.origin + p.orientation * v3(site.pos)
    };
    let path_point = |s: &MjcfScene, k: usize| {
        let ps = s.world.tendon_path(0)[k];
        ps.body
            .map_or(ps.offset, |b| s.world.bodies()[b].pose.point(ps.offset))
    };
    let e_site = (0..2)
        .map(|k| (site_world(&s, k) - path_point(&s, k)).length())
        .fold(0.0, f64::max);
    assert!(e_site < 1e-14, "sites at qpos0 off by {e_site:e}"); // measured 1.4e-17
                                                                 // tip2's anchor (its frame) and link3's (fixed at qpos0 in link3's frame).
    let (tip2, link3) = (body(&model, "tip2"), body(&model, "link3"));
    let anchor = DVec3::new(0.05, 0.0, 0.0);
    let w0 = p0[tip2].origin + p0[tip2].orientation * anchor;
    let in3 = p0[link3].orientation.inverse() * (w0 - p0[link3].origin);
    for _ in 0..500 {
        s.world.step(s.timestep, Method::default()).expect("step");
    }
    let p1 = states(&s);
    let gap = (p1[tip2].origin + p1[tip2].orientation * anchor
        - (p1[link3].origin + p1[link3].orientation * in3))
        .length();
    // Round-off of the projected connect: measured 3.7e-13 m.
    assert!(gap < 1e-9, "connect gap {gap:e} m after 1 s");
    let e_site = (0..2)
        .map(|k| (site_world(&s, k) - path_point(&s, k)).length())
        .fold(0.0, f64::max);
    assert!(e_site < 1e-14, "sites after 1 s off by {e_site:e}"); // measured 6.9e-18
                                                                  // The chain moved (gravity and the tendon): not a trivial agreement.
    assert!((p1[tip2].com - p0[tip2].com).length() > 0.05);
}

/// Merged and unmerged builds agree: the initial states from a perturbed `qpos`/`qvel`
/// (the loader's per-body states against the host's moved to each part) and the
/// energies to round-off, and runs of 1 s from `qpos0` with the hinges moving to the
/// step's discretization error.
#[test]
fn merged_and_unmerged_trajectories_agree() {
    let (model, mut m) = build(CHAIN, true);
    let (_, mut u) = build(CHAIN, false);
    for s in [&mut m, &mut u] {
        s.set_generalized(&model, &[0.4, -0.7], &[1.5, -2.0])
            .expect("state");
    }
    let diff = |a: &[PartState], b: &[PartState]| {
        a.iter().zip(b).fold([0.0f64; 3], |w, (x, y)| {
            [
                w[0].max((x.com - y.com).length().max((x.origin - y.origin).length())),
                w[1].max(x.orientation.angle_between(y.orientation)),
                w[2].max((x.v - y.v).length().max((x.omega - y.omega).length())),
            ]
        })
    };
    let d0 = diff(&states(&m), &states(&u));
    assert!(d0.iter().all(|&d| d < 1e-14), "initial states {d0:?}"); // measured [1.1e-16, 0, 7.9e-17]
    let (em, eu) = (m.energy(), u.energy());
    let de = (em.0 - eu.0).abs().max((em.1 - eu.1).abs());
    assert!(de < 1e-12, "energies {em:?} {eu:?}"); // measured 5.6e-17
                                                   // The run: from qpos0 (the connect closed) with the hinges moving.
    for s in [&mut m, &mut u] {
        s.set_generalized(&model, &[], &[1.5, -2.0]).expect("state");
    }
    let mut worst = [0.0f64; 3];
    for _ in 0..500 {
        m.world.step(m.timestep, Method::default()).expect("step");
        u.world.step(u.timestep, Method::default()).expect("step");
        let d = diff(&states(&m), &states(&u));
        for k in 0..3 {
            worst[k] = worst[k].max(d[k]);
        }
    }
    // The unmerged welds hold to ~1e-13 m throughout; what differs is the first-order
    // step's error on one rigid body against three welded ones (each with its own
    // gyroscopic term), grown by the swinging chain. Measured: position 4.8e-6 m,
    // angle 5.5e-5 rad (the hanging box), velocity 8.1e-4 (m/s or rad/s).
    assert!(
        worst[0] < 1e-4 && worst[1] < 1e-3 && worst[2] < 1e-2,
        "{worst:?}"
    );
    let moved = (states(&m)[1].com - d_com(&model, 1)).length();
    assert!(moved > 0.05, "link2 moved {moved} m");
}

fn d_com(model: &constraint_mjcf::Model, i: usize) -> DVec3 {
    let b = &model.bodies[i];
    v3(b.pos) + quat(b.quat) * v3(b.com)
}

/// Fluid drag is per body in MuJoCo: with fluid on and a jointless body the model is
/// built unmerged (six world bodies).
#[test]
fn fluid_keeps_the_model_unmerged() {
    let xml = CHAIN.replace(
        r#"<option timestep="0.002" gravity="0 0 -9.81"/>"#,
        r#"<option timestep="0.002" gravity="0 0 -9.81" density="1.2"/>"#,
    );
    let (_, s) = build(&xml, true);
    assert_eq!(s.world.bodies().len(), 6);
    assert!(s.parts.iter().all(|p| p.body.is_some()));
}

/// A `contact/exclude` naming a moving jointless body keeps the model unmerged (an
/// exclusion is per world body; merged, it would cover the host's other geoms too); one
/// naming a static body does not.
#[test]
fn an_exclude_on_a_moving_welded_body_keeps_the_model_unmerged() {
    let with = |pair: &str| {
        CHAIN.replace(
            "<equality>",
            &format!("<contact><exclude {pair}/></contact>\n  <equality>"),
        )
    };
    let (_, s) = build(&with(r#"body1="tip" body2="link1""#), true);
    assert_eq!(s.world.bodies().len(), 6);
    let (_, s) = build(&with(r#"body1="post" body2="link1""#), true);
    assert_eq!(s.world.bodies().len(), 3);
}

/// MuJoCo's pair filter with merged bodies (feature `contact`): a sphere of radius 0.35
/// on `tip` (merged into `link2`) reaches into `link1`'s capsule, the parent weld body's,
/// and into the box hung from `tip2` by the connect; neither pair touches (MuJoCo filters
/// the first, ours the second through the connect's joint), so a step makes no contact.
#[cfg(feature = "contact")]
#[test]
fn merged_geoms_keep_the_parent_filter() {
    let xml = CHAIN
        .replace(
            r#"<default><geom contype="0" conaffinity="0"/></default>"#,
            "",
        )
        .replace(
            r#"<site name="s_tip" pos="0.1 0 0.02"/>"#,
            r#"<site name="s_tip" pos="0.1 0 0.02"/>
          <geom type="sphere" size="0.35" mass="0.01"/>"#,
        );
    let (model, mut s) = build(&xml, true);
    assert_eq!(s.world.bodies().len(), 3);
    let p = states(&s);
    let (tip, link1) = (body(&model, "tip"), body(&model, "link1"));
    // The sphere's centre (tip's origin) to link1's far end: measured 0.30 m < 0.35 + 0.03.
    let end = p[link1].origin + p[link1].orientation * DVec3::new(0.4, 0.0, 0.0);
    let d = (p[tip].origin - end).length();
    assert!(d < 0.35, "{d}");
    assert!(s.world.colliders().iter().any(|c| c.body.is_none()));
    s.world.step(s.timestep, Method::default()).expect("step");
    assert_eq!(s.world.contacts().len(), 0);
}
