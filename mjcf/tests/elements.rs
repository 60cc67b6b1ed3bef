//! Each supported element and attribute, angle conventions and default classes.

mod common;

use common::{close, close_mat, load, same_rotation, world};
use constraint_mjcf::{load_file, JointKind, Shape};
use std::f64::consts::{FRAC_1_SQRT_2, PI};
use std::path::Path;

#[test]
fn mujoco_defaults_when_nothing_is_said() {
    let m = load("<mujoco model=\"empty\"/>");
    assert_eq!(m.timestep, 0.002);
    assert_eq!(m.gravity, [0.0, 0.0, -9.81]);
    assert_eq!(m.integrator, "Euler");
    assert!(!m.contact_disabled);
    assert!(m.bodies.is_empty() && m.joints.is_empty() && m.geoms.is_empty());
    assert_eq!((m.nq(), m.nv()), (0, 0));
}

#[test]
fn option_and_flags() {
    let m = load(
        r#"<mujoco>
             <option timestep="0.005" gravity="0 -1 -2" integrator="implicitfast"
                     solver="Newton" iterations="50" tolerance="1e-10">
               <flag contact="disable" energy="enable"/>
             </option>
           </mujoco>"#,
    );
    assert_eq!(m.timestep, 0.005);
    assert_eq!(m.gravity, [0.0, -1.0, -2.0]);
    assert_eq!(m.integrator, "implicitfast");
    assert!(m.contact_disabled);
    let m = load(r#"<mujoco><option><flag gravity="disable" contact="enable"/></option></mujoco>"#);
    assert_eq!(m.gravity, [0.0; 3]);
    assert!(!m.contact_disabled);
}

#[test]
fn ignored_sections_and_visual_attributes() {
    let m = load(
        r#"<mujoco model="m">
             <size njmax="100"/>
             <visual><global offwidth="800"/></visual>
             <statistic extent="2"/>
             <asset><material name="red" rgba="1 0 0 1"/><texture name="t" type="2d" builtin="checker" width="8" height="8"/></asset>
             <worldbody>
               <light pos="0 0 3"/>
               <camera name="c" pos="0 0 3"/>
               <site name="s" pos="1 0 0"/>
               <geom name="floor" type="plane" size="1 1 0.1" rgba="1 1 1 1" material="red" group="2"/>
             </worldbody>
           </mujoco>"#,
    );
    assert_eq!(m.geoms.len(), 1);
    assert_eq!(m.geoms[0].name, "floor");
    assert_eq!(m.geoms[0].body, None);
    assert_eq!(m.geoms[0].shape, Shape::Plane);
}

#[test]
fn body_frames_compose_and_names_default() {
    let m = load(&world(
        r#"<body pos="1 0 0" euler="0 0 90">
             <geom size="0.1"/>
             <body name="child" pos="1 0 0">
               <geom size="0.1"/>
             </body>
           </body>
           <body name="second" pos="0 0 5"><geom size="0.1"/></body>"#,
    ));
    assert_eq!(m.bodies.len(), 3);
    assert_eq!(m.bodies[0].name, "body0");
    assert_eq!(m.bodies[1].name, "child");
    assert_eq!(m.bodies[2].name, "second");
    assert_eq!(m.bodies[1].parent, Some(0));
    assert_eq!(m.bodies[2].parent, None);
    assert_eq!(m.bodies[0].line, 3);
    // Rotated 90° about z, so the child's x offset points along world y.
    close(m.bodies[1].pos, [1.0, 1.0, 0.0], 1e-15);
    same_rotation(
        m.bodies[1].quat,
        [FRAC_1_SQRT_2, 0.0, 0.0, FRAC_1_SQRT_2],
        1e-15,
    );
    assert_eq!(m.geoms[1].body, Some(1));
}

#[test]
fn degrees_are_the_default_and_radians_on_request() {
    let deg = load(&world(r#"<body euler="90 0 0"><geom size="1"/></body>"#));
    let rad = load(&format!(
        "<mujoco><compiler angle=\"radian\"/><worldbody><body euler=\"{} 0 0\"><geom size=\"1\"/></body></worldbody></mujoco>",
        PI / 2.0
    ));
    let want = [FRAC_1_SQRT_2, FRAC_1_SQRT_2, 0.0, 0.0];
    same_rotation(deg.bodies[0].quat, want, 1e-15);
    same_rotation(rad.bodies[0].quat, want, 1e-15);
    let aa = load(&world(
        r#"<body axisangle="1 0 0 90"><geom size="1"/></body>"#,
    ));
    same_rotation(aa.bodies[0].quat, want, 1e-15);
}

#[test]
fn orientation_alternatives_agree() {
    // 90° about x: y -> z, z -> -y.
    let want = [FRAC_1_SQRT_2, FRAC_1_SQRT_2, 0.0, 0.0];
    for spec in [
        r#"quat="1 1 0 0""#,
        r#"axisangle="2 0 0 90""#,
        r#"euler="90 0 0""#,
        r#"xyaxes="1 0 0 0 0 1""#,
        r#"zaxis="0 -1 0""#,
    ] {
        let m = load(&world(&format!("<body {spec}><geom size=\"1\"/></body>")));
        same_rotation(m.bodies[0].quat, want, 1e-15);
    }
}

#[test]
fn euler_sequence_rotating_and_fixed_axes() {
    // Rotating xyz: q = qx(a) qy(b); fixed XYZ: q = qy(b) qx(a).
    let h = (PI / 4.0).sin();
    let qx = [h, h, 0.0, 0.0];
    let qy = [h, 0.0, h, 0.0];
    let mul = |a: [f64; 4], b: [f64; 4]| {
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    };
    let body = r#"<worldbody><body euler="90 90 0"><geom size="1"/></body></worldbody>"#;
    let moving = load(&format!("<mujoco>{body}</mujoco>"));
    same_rotation(moving.bodies[0].quat, mul(qx, qy), 1e-15);
    let fixed = load(&format!(
        "<mujoco><compiler eulerseq=\"XYZ\"/>{body}</mujoco>"
    ));
    same_rotation(fixed.bodies[0].quat, mul(qy, qx), 1e-15);
}

#[test]
fn joints_of_each_kind_and_addresses() {
    let m = load(&world(
        r#"<body name="a"><joint name="h" axis="0 2 0" pos="0 0 1" damping="0.5"/><geom size="0.1"/>
             <body name="b"><joint type="ball"/><geom size="0.1"/>
               <body name="c"><joint type="slide" axis="1 0 0"/><geom size="0.1"/></body>
             </body>
           </body>
           <body name="d"><freejoint/><geom size="0.1"/></body>
           <body name="e"><joint type="free" damping="1"/><geom size="0.1"/></body>"#,
    ));
    let kinds: Vec<JointKind> = m.joints.iter().map(|j| j.kind).collect();
    assert_eq!(
        kinds,
        [
            JointKind::Hinge,
            JointKind::Ball,
            JointKind::Slide,
            JointKind::Free,
            JointKind::Free
        ]
    );
    let qadr: Vec<usize> = m.joints.iter().map(|j| j.qpos_adr).collect();
    let vadr: Vec<usize> = m.joints.iter().map(|j| j.dof_adr).collect();
    assert_eq!(qadr, [0, 1, 5, 6, 13]);
    assert_eq!(vadr, [0, 1, 4, 5, 11]);
    assert_eq!((m.nq(), m.nv()), (20, 17));
    assert_eq!(m.joints[0].name, "h");
    assert_eq!(m.joints[1].name, "joint1");
    assert_eq!(m.joints[0].axis, [0.0, 1.0, 0.0]); // normalised
    assert_eq!(m.joints[0].pos, [0.0, 0.0, 1.0]);
    assert_eq!(m.joints[0].damping, 0.5);
    assert_eq!(m.joints[4].damping, 1.0);
    assert_eq!(
        m.joints.iter().map(|j| j.body).collect::<Vec<_>>(),
        [0, 1, 2, 3, 4]
    );
    // qpos0: hinge 0, ball identity, slide 0, free at the body pose.
    let q0 = m.qpos0();
    assert_eq!(&q0[1..5], &[1.0, 0.0, 0.0, 0.0]);
    assert_eq!(&q0[6..13], &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
}

#[test]
fn zero_valued_dynamics_attributes_and_unlimited_ranges_are_accepted() {
    let m = load(&world(
        r#"<body><joint armature="0" stiffness="0" frictionloss="0" ref="0" springref="0"
                        limited="false" range="-1 1" group="1"/><geom size="0.1"/></body>
           <body><joint range="0 0"/><geom size="0.1"/></body>"#,
    ));
    assert_eq!(m.joints.len(), 2);
}

#[test]
fn geoms_shapes_and_contact_attributes() {
    let m = load(&world(
        r#"<body>
             <freejoint/>
             <geom name="s" type="sphere" size="0.5" friction="0.3" contype="2" conaffinity="5" condim="3"/>
             <geom type="box" size="0.1 0.2 0.3" pos="1 2 3" quat="0 0 0 1"/>
             <geom type="capsule" size="0.1 0.4" friction="0.5 0.1 0.01"/>
             <geom type="capsule" fromto="0 0 0 0 0 2" size="0.05"/>
             <geom type="box" fromto="0 0 0 2 0 0" size="0.1 0.2"/>
           </body>"#,
    ));
    let g = &m.geoms;
    assert_eq!(g[0].shape, Shape::Sphere { radius: 0.5 });
    assert_eq!(g[0].friction, [0.3, 0.005, 0.0001]);
    assert_eq!((g[0].contype, g[0].conaffinity), (2, 5));
    assert_eq!(g[0].density, 1000.0);
    assert_eq!(
        g[1].shape,
        Shape::Box {
            half: [0.1, 0.2, 0.3]
        }
    );
    assert_eq!(g[1].pos, [1.0, 2.0, 3.0]);
    assert_eq!(g[1].quat, [0.0, 0.0, 0.0, 1.0]);
    assert_eq!(g[2].friction, [0.5, 0.1, 0.01]);
    // fromto: midpoint, half length |b − a|/2, z axis along (from − to) as in MuJoCo.
    assert_eq!(
        g[3].shape,
        Shape::Capsule {
            radius: 0.05,
            half_length: 1.0
        }
    );
    assert_eq!(g[3].pos, [0.0, 0.0, 1.0]);
    same_rotation(g[3].quat, [0.0, 1.0, 0.0, 0.0], 1e-15);
    assert_eq!(
        g[4].shape,
        Shape::Box {
            half: [0.1, 0.1, 1.0]
        }
    );
    assert_eq!(g[4].pos, [1.0, 0.0, 0.0]);
    same_rotation(g[4].quat, [FRAC_1_SQRT_2, 0.0, -FRAC_1_SQRT_2, 0.0], 1e-15);
    assert_eq!(g[4].line, 9);
}

#[test]
fn geom_mass_becomes_effective_density() {
    let m = load(&world(
        r#"<body><freejoint/><geom type="box" size="0.5 0.5 0.5" mass="3"/></body>"#,
    ));
    assert_eq!(m.geoms[0].density, 3.0);
    assert_eq!(m.bodies[0].mass, 3.0);
}

#[test]
fn default_classes_nest_and_childclass_applies_to_descendants() {
    let m = load(
        r#"<mujoco>
             <default>
               <geom type="box" size="0.1 0.1 0.1" friction="0.8 0.01 0.001"/>
               <joint damping="0.2"/>
               <default class="round">
                 <geom type="sphere" friction="0.4"/>
                 <default class="slippery">
                   <geom friction="0.1"/>
                   <joint type="slide" axis="1 0 0"/>
                 </default>
               </default>
             </default>
             <worldbody>
               <body><joint/><geom/>
                 <body childclass="round"><joint/><geom/>
                   <body><joint class="slippery"/><geom class="slippery"/><geom class="main"/></body>
                 </body>
               </body>
             </worldbody>
           </mujoco>"#,
    );
    let g = &m.geoms;
    assert_eq!(
        g[0].shape,
        Shape::Box {
            half: [0.1, 0.1, 0.1]
        }
    );
    assert_eq!(g[0].friction, [0.8, 0.01, 0.001]);
    // Partial friction keeps the inherited torsional and rolling coefficients.
    assert_eq!(g[1].shape, Shape::Sphere { radius: 0.1 });
    assert_eq!(g[1].friction, [0.4, 0.01, 0.001]);
    assert_eq!(g[2].friction, [0.1, 0.01, 0.001]);
    assert_eq!(
        g[3].shape,
        Shape::Box {
            half: [0.1, 0.1, 0.1]
        }
    );
    assert_eq!(m.joints[0].kind, JointKind::Hinge);
    assert_eq!(m.joints[0].damping, 0.2);
    assert_eq!(m.joints[1].kind, JointKind::Hinge);
    assert_eq!(m.joints[2].kind, JointKind::Slide);
    assert_eq!(m.joints[2].axis, [1.0, 0.0, 0.0]);
    assert_eq!(m.joints[2].damping, 0.2);
}

#[test]
fn inertial_overrides_geoms_under_auto_and_not_under_true() {
    let body = r#"<worldbody><body><joint/>
                    <inertial pos="0 0 1" mass="2" diaginertia="1 2 3"/>
                    <geom size="0.1"/>
                  </body></worldbody>"#;
    let auto = load(&format!("<mujoco>{body}</mujoco>"));
    assert_eq!(auto.bodies[0].mass, 2.0);
    assert_eq!(auto.bodies[0].com, [0.0, 0.0, 1.0]);
    close_mat(
        auto.bodies[0].inertia,
        [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]],
        0.0,
    );
    let forced = load(&format!(
        "<mujoco><compiler inertiafromgeom=\"true\"/>{body}</mujoco>"
    ));
    let sphere = 4.0 / 3.0 * PI * 1e-3 * 1000.0; // 4.18879 kg
    assert!((forced.bodies[0].mass - sphere).abs() < 1e-12);
    assert_eq!(forced.bodies[0].com, [0.0; 3]);
    let no_geoms = load(
        r#"<mujoco><compiler inertiafromgeom="false"/><worldbody>
             <body><geom size="0.1"/></body></worldbody></mujoco>"#,
    );
    assert_eq!(no_geoms.bodies[0].mass, 0.0);
}

#[test]
fn inertial_orientation_and_full_inertia() {
    let m = load(&world(
        r#"<body><joint/><inertial pos="0 0 0" mass="1" diaginertia="1 2 3" euler="0 0 90"/></body>
           <body><joint/><inertial pos="0 0 0" mass="1" fullinertia="2 3 4 0.1 0.2 0.3"/></body>"#,
    ));
    // 90° about z swaps the x and y principal moments.
    close_mat(
        m.bodies[0].inertia,
        [[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 3.0]],
        1e-15,
    );
    close_mat(
        m.bodies[1].inertia,
        [[2.0, 0.1, 0.2], [0.1, 3.0, 0.3], [0.2, 0.3, 4.0]],
        0.0,
    );
}

#[test]
fn connect_anchor_in_the_second_body() {
    let m = load(
        r#"<mujoco><worldbody>
             <body name="a" pos="0 0 1"><joint/><geom size="0.1"/>
               <body name="b" pos="1 0 0" euler="0 0 90"><joint/><geom size="0.1"/></body>
             </body>
           </worldbody>
           <equality>
             <connect name="c" body1="a" body2="b" anchor="1 1 0"/>
             <connect body1="b" anchor="0 0 0"/>
             <connect body1="world" body2="a" anchor="0 0 2"/>
           </equality></mujoco>"#,
    );
    let c = &m.connects;
    assert_eq!(c[0].name, "c");
    assert_eq!((c[0].body1, c[0].body2), (Some(0), Some(1)));
    // World point (1, 1, 1); b sits at (1, 0, 1) turned 90° about z: local (1, 0, 0).
    close(c[0].anchor2, [1.0, 0.0, 0.0], 1e-15);
    assert_eq!(c[1].name, "connect1");
    assert_eq!(c[1].body2, None);
    close(c[1].anchor2, [1.0, 0.0, 1.0], 1e-15);
    assert_eq!(c[2].body1, None);
    close(c[2].anchor2, [0.0, 0.0, 1.0], 1e-15);
}

#[test]
fn keyframes_fill_absent_vectors_like_mujoco() {
    let m = load(
        r#"<mujoco><worldbody>
             <body pos="1 2 3"><freejoint/><geom size="0.1"/></body>
             <body><joint type="ball"/><geom size="0.1"/></body>
           </worldbody>
           <keyframe>
             <key name="a" time="1.5" qvel="1 2 3 4 5 6 7 8 9"/>
             <key qpos="0 0 0 1 0 0 0 0 1 0 0"/>
           </keyframe></mujoco>"#,
    );
    let a = m.keyframe("a").expect("key a");
    assert_eq!(a.time, 1.5);
    assert_eq!(
        a.qpos,
        vec![1.0, 2.0, 3.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    );
    assert_eq!(a.qvel.len(), 9);
    let b = m.keyframe("key1").expect("key1");
    assert_eq!(b.qvel, vec![0.0; 9]);
    assert_eq!(b.time, 0.0);
}

#[test]
fn short_keys_are_padded_and_quaternions_normalised_like_mujoco() {
    // Values checked against MuJoCo 4.0.0 (`m.key_qpos`, `m.key_qvel`).
    let m = load(
        r#"<mujoco><worldbody>
             <body pos="1 2 3" euler="0 0 90"><freejoint/><geom size="1"/></body>
             <body pos="0 0 1"><joint type="ball"/><geom size="1"/></body>
           </worldbody>
           <keyframe>
             <key qpos="5"/>
             <key qpos="5 6 7 0 0 0 2  0 0 0 0" qvel="1"/>
             <key qpos="" qvel=""/>
           </keyframe></mujoco>"#,
    );
    let h = FRAC_1_SQRT_2;
    let k = &m.keyframes;
    close(
        k[0].qpos[..].try_into().expect("11"),
        [5.0, 2.0, 3.0, h, 0.0, 0.0, h, 1.0, 0.0, 0.0, 0.0],
        1e-15,
    );
    assert_eq!(
        k[1].qpos,
        vec![5.0, 6.0, 7.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    );
    assert_eq!(k[1].qvel, vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(k[2].qpos, m.qpos0());
    assert_eq!(k[2].qvel, vec![0.0; 9]);
}

#[test]
fn sample_files_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    for (file, bodies, nq, nv) in [
        ("pendulum.xml", 1, 1, 1),
        ("ball_chain.xml", 3, 12, 9),
        ("free_body.xml", 2, 8, 7),
        ("explicit_inertia.xml", 3, 2, 2),
    ] {
        let m = load_file(&dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!((m.bodies.len(), m.nq(), m.nv()), (bodies, nq, nv), "{file}");
    }
}
