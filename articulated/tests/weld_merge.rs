//! Jointless MJCF bodies merged into their hosts (`MjcfScene`, `MjcfOptions`): a hinge
//! chain whose second link carries a welded `tip` (with a welded `tip2` inside), a
//! `post` welded to the world, a spatial tendon from the post to the tip, and a free box
//! hung from the world by a connect. Merged and unmerged builds agree; the merged host's
//! mass, centre of mass and inertia match a hand computation; sites and the connect's
//! anchor ride on their bodies; a connect or exclude naming a body of a merged group
//! keeps the model unmerged; the pair filter is MuJoCo's in both builds.

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
    <connect name="c" body1="link3" anchor="0.05 0 0"/>
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
/// after 1 s link3's anchor is still at its world point (the connect to the world).
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

    // link3's anchor in its frame and in the world at qpos0.
    let link3 = body(&model, "link3");
    let anchor = DVec3::new(0.05, 0.0, 0.0);
    let w0 = p0[link3].origin + p0[link3].orientation * anchor;
    for _ in 0..500 {
        s.world.step(s.timestep, Method::default()).expect("step");
    }
    let p1 = states(&s);
    let gap = (p1[link3].origin + p1[link3].orientation * anchor - w0).length();
    // Round-off of the projected connect: measured 2.2e-16 m.
    assert!(gap < 1e-9, "connect gap {gap:e} m after 1 s");
    let e_site = (0..2)
        .map(|k| (site_world(&s, k) - path_point(&s, k)).length())
        .fold(0.0, f64::max);
    assert!(e_site < 1e-14, "sites after 1 s off by {e_site:e}"); // measured 1.1e-16

    // The chain moved (gravity and the tendon): not a trivial agreement.
    let tip2 = body(&model, "tip2");
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
    // gyroscopic term), grown by the swinging chain. Measured: position 3.9e-6 m,
    // angle 1.0e-5 rad, velocity 1.5e-4 (m/s or rad/s).
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

/// CHAIN with `extra` put before `<equality>` (a `<contact>` block, say) and the
/// connect replaced by `connect` (empty: none).
fn chain_with(extra: &str, connect: &str) -> String {
    CHAIN
        .replace("<equality>", &format!("{extra}\n  <equality>"))
        .replace(
            r#"<connect name="c" body1="link3" anchor="0.05 0 0"/>"#,
            connect,
        )
}

/// A connect naming a body of a merged group builds the model unmerged (six world
/// bodies): one on a merged body (tip2 to link3), one whose two bodies share a host (tip
/// to tip2: merged, a joint of link2 to itself), one on a static body (post to the
/// world: merged, the world to itself) and one on a host with merged bodies (link2).
/// One between bodies alone in their world bodies (link1 to link3) keeps it merged.
#[test]
fn a_connect_on_a_merged_group_keeps_the_model_unmerged() {
    for (c, n) in [
        (
            r#"<connect body1="tip2" body2="link3" anchor="0.05 0 0"/>"#,
            6,
        ),
        (
            r#"<connect body1="tip" body2="tip2" anchor="0.1 0.02 0"/>"#,
            6,
        ),
        (r#"<connect body1="post" anchor="0 0 0"/>"#, 6),
        (
            r#"<connect body1="link2" body2="link3" anchor="0.3 0 0"/>"#,
            6,
        ),
        (
            r#"<connect body1="link1" body2="link3" anchor="0.4 0 0"/>"#,
            3,
        ),
    ] {
        let (_, s) = build(&chain_with("", c), true);
        assert_eq!(s.world.bodies().len(), n, "{c}");
    }
}

/// A `contact/exclude` naming a body of a merged group builds the model unmerged (an
/// exclusion is per world body; merged, it would cover the group's other geoms, where
/// MuJoCo excludes by each geom's own body): a merged body (tip), a host with merged
/// bodies (link2), a static body (post, then also warned about: its geoms are world
/// geoms, and the exclusion is not modelled, as before merging). One between bodies
/// alone in their world bodies (link1, link3) keeps it merged.
#[test]
fn an_exclude_on_a_merged_group_keeps_the_model_unmerged() {
    let with = |pair: &str| chain_with(&format!("<contact><exclude {pair}/></contact>"), "");
    for (pair, n) in [
        (r#"body1="tip" body2="link1""#, 6),
        (r#"body1="link2" body2="link3""#, 6),
        (r#"body1="post" body2="link1""#, 6),
        (r#"body1="link1" body2="link3""#, 3),
    ] {
        let (_, s) = build(&with(pair), true);
        assert_eq!(s.world.bodies().len(), n, "{pair}");
    }
    #[cfg(feature = "contact")]
    {
        let (_, s) = build(&with(r#"body1="post" body2="link1""#), true);
        let warned = s
            .warnings
            .iter()
            .filter(|w| w.contains("static body"))
            .count();
        assert_eq!(warned, 1, "{:?}", s.warnings);
    }
}

/// A hand-built model whose `tip` names a bad parent builds without a panic. One past
/// the last body (6): a typed error, merged or not. Itself (3) or a later body (tip2,
/// 4): merged, `Layout` reads it as the world, so tip and tip2 are static (three world
/// bodies); unmerged, tip's joint to itself is refused (3), or tip is welded to tip2 as
/// before merging (4).
#[test]
fn a_bad_parent_index_does_not_panic() {
    let scene = |bad: usize, merge: bool| {
        let mut model = constraint_mjcf::load_str(&chain_with("", "")).expect("model");
        let tip = body(&model, "tip");
        assert_eq!(tip, 3);
        model.bodies[tip].parent = Some(bad);
        MjcfScene::with_options(
            &model,
            None,
            MjcfOptions {
                merge_welded: merge,
            },
        )
    };
    for merge in [true, false] {
        let e = scene(6, merge).expect_err("parent past the last body");
        assert!(e.to_string().contains("not a body of the model"), "{e}");
    }
    for bad in [3, 4] {
        let s = scene(bad, true).expect("merged");
        assert_eq!(s.world.bodies().len(), 3);
        assert_eq!((s.parts[3].body, s.parts[4].body), (None, None));
    }
    assert!(scene(3, false).is_err());
    assert_eq!(scene(4, false).expect("unmerged").world.bodies().len(), 6);
}

/// MuJoCo's pair filter with merged bodies (feature `contact`), without connects: a
/// sphere of radius 0.35 on `tip` (merged into `link2`) reaches into `link1`'s capsule
/// (the parent weld body's: filtered) and into link3's box (not related: a contact).
/// Merged and unmerged builds make the same contact pairs in their first step: one
/// (sphere, box) pair, none with link1.
#[cfg(feature = "contact")]
#[test]
fn merged_and_unmerged_builds_filter_the_same_pairs() {
    let c = r#"contype="1" conaffinity="1""#;
    let xml = chain_with("", "")
        .replace(
            r#"<site name="s_tip" pos="0.1 0 0.02"/>"#,
            &format!(
                r#"<site name="s_tip" pos="0.1 0 0.02"/>
          <geom type="sphere" size="0.35" mass="0.01" {c}/>"#
            ),
        )
        .replace(
            r#"<geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" mass="1"/>"#,
            &format!(r#"<geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" mass="1" {c}/>"#),
        )
        .replace(
            r#"<geom type="box" size="0.04 0.05 0.06" mass="0.3"/>"#,
            &format!(r#"<geom type="box" size="0.04 0.05 0.06" mass="0.3" {c}/>"#),
        );
    let (model, mut m) = build(&xml, true);
    let (_, mut u) = build(&xml, false);
    assert_eq!((m.world.bodies().len(), u.world.bodies().len()), (3, 6));
    // Three colliders, in geom order in both: link1's capsule, the sphere, link3's box.
    assert_eq!(m.world.colliders().len(), 3);
    assert_eq!(u.world.colliders().len(), 3);
    let p = states(&m);
    let (tip, link1, link3) = (
        body(&model, "tip"),
        body(&model, "link1"),
        body(&model, "link3"),
    );
    // The sphere's centre (tip's origin) to link1's far end: measured 0.300 m < 0.35 + 0.03.
    let end = p[link1].origin + p[link1].orientation * DVec3::new(0.4, 0.0, 0.0);
    let d1 = (p[tip].origin - end).length();
    // ... and to link3's box centre: measured 0.087 m < 0.35.
    let d3 = (p[tip].origin - p[link3].com).length();
    assert!(d1 < 0.35 && d3 < 0.35, "{d1} {d3}");
    let pairs = |s: &mut MjcfScene| {
        s.world.step(s.timestep, Method::default()).expect("step");
        let mut v: Vec<(usize, usize)> = s
            .world
            .contacts()
            .iter()
            .map(|c| (c.a.min(c.b), c.a.max(c.b)))
            .collect();
        v.sort_unstable();
        (s.world.contacts().len(), v)
    };
    // Measured: one contact, colliders (1, 2), in both.
    let (pm, pu) = (pairs(&mut m), pairs(&mut u));
    assert_eq!(pm, pu);
    assert!(
        pm.0 > 0 && pm.1.iter().all(|&(a, b)| (a, b) == (1, 2)),
        "{pm:?}"
    );
}
