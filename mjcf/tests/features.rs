//! The elements added for the gymnasium and dm_control models: several joints per body,
//! joint limits and spring data, include, actuator / tendon / equality defaults,
//! compiler mass settings, cylinders and ellipsoids, actuators in general form, fixed
//! tendons, equalities, contact data, data-only elements, warnings, options.

mod common;

use common::{close, close_mat, fail, load, same_rotation, world};
use constraint_mjcf::{
    load_file, load_str, load_str_with_dir, ActuatorKind, JointKind, MjcfError, Primitive, Shape,
    Transmission,
};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

#[test]
fn planar_root_slide_slide_hinge_composes_in_order() {
    let m = load(&world(
        r#"<body pos="0 0 1">
             <joint name="x" type="slide" axis="1 0 0"/>
             <joint name="z" type="slide" axis="0 0 1"/>
             <joint name="ry" axis="0 1 0" pos="0 0 0.5"/>
             <geom size="0.1"/>
           </body>"#,
    ));
    assert_eq!((m.nq(), m.nv()), (3, 3));
    let addr: Vec<_> = m.joints.iter().map(|j| (j.qpos_adr, j.dof_adr)).collect();
    assert_eq!(addr, [(0, 0), (1, 1), (2, 2)]);
    let (a, b, th) = (0.3, -0.2, 0.7);
    let (va, vb, w) = (1.5, -0.5, 2.0);
    let s = m.body_states(&[a, b, th], &[va, vb, w]).unwrap()[0];
    close(
        s.pos,
        [a - 0.5 * th.sin(), 0.0, 1.5 + b - 0.5 * th.cos()],
        1e-14,
    );
    same_rotation(
        s.quat,
        [(th / 2.0).cos(), 0.0, (th / 2.0).sin(), 0.0],
        1e-14,
    );
    close(s.omega, [0.0, w, 0.0], 1e-14);
    // The time derivative of the position above.
    close(
        s.vel,
        [va - 0.5 * w * th.cos(), 0.0, vb + 0.5 * w * th.sin()],
        1e-14,
    );
}

#[test]
fn joint_order_matters_hinge_then_slide() {
    let m = load(&world(
        r#"<body>
             <joint axis="0 0 1"/>
             <joint type="slide" axis="1 0 0"/>
             <geom size="0.1"/>
           </body>"#,
    ));
    let (th, s) = (0.4, 2.0);
    let st = m.body_states(&[th, s], &[1.0, 0.5]).unwrap()[0];
    // The slide axis is turned by the hinge before it.
    close(st.pos, [s * th.cos(), s * th.sin(), 0.0], 1e-14);
    // d/dt (s cos θ, s sin θ) with θ̇ = 1, ṡ = 0.5.
    close(
        st.vel,
        [
            0.5 * th.cos() - s * th.sin(),
            0.5 * th.sin() + s * th.cos(),
            0.0,
        ],
        1e-14,
    );
}

#[test]
fn two_hinges_at_a_hip_and_ball_with_hinge() {
    let m = load(&world(
        r#"<body pos="0 0 1">
             <joint axis="1 0 0"/>
             <joint axis="0 1 0"/>
             <geom size="0.1" pos="0 0 -0.5"/>
             <body pos="0 0 -1">
               <joint type="ball"/>
               <joint axis="0 0 1" pos="0 0 0.1"/>
               <geom size="0.1"/>
             </body>
           </body>"#,
    ));
    assert_eq!((m.nq(), m.nv()), (7, 6));
    let mut qpos = m.qpos0();
    qpos[0] = 0.3;
    qpos[1] = -0.4;
    qpos[2..6].copy_from_slice(&[0.9, 0.1, 0.2, 0.3]);
    qpos[6] = 0.5;
    let st = m.body_states(&qpos, &[0.0; 6]).unwrap();
    // First body: rotation x then y (body frame), about the origin.
    let rx = [(0.15f64).cos(), (0.15f64).sin(), 0.0, 0.0];
    let ry = [(-0.2f64).cos(), 0.0, (-0.2f64).sin(), 0.0];
    same_rotation(st[0].quat, mul(rx, ry), 1e-14);
    assert!(m.initial_state(None).is_ok());
}

fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

#[test]
fn joint_attributes_are_data_with_mujoco_units() {
    let m = load(&world(
        r#"<body>
             <joint name="h" range="-90 45" armature="0.1" stiffness="2" springref="30"
                    ref="60" frictionloss="0.3" damping="0.4"/>
             <joint name="s" type="slide" axis="1 0 0" range="-1 2" limited="false" ref="0.5"/>
             <joint name="free_range" range="1 -1"/>
             <geom size="0.1"/>
           </body>"#,
    ));
    let h = &m.joints[0];
    assert!(h.limited);
    close(h.range, [-PI / 2.0, PI / 4.0], 1e-15);
    assert_eq!(
        (h.armature, h.stiffness, h.frictionloss, h.damping),
        (0.1, 2.0, 0.3, 0.4)
    );
    assert!((h.springref - PI / 6.0).abs() < 1e-15);
    assert!((h.reference - PI / 3.0).abs() < 1e-15);
    let s = &m.joints[1];
    assert!(!s.limited);
    assert_eq!((s.range, s.reference), ([-1.0, 2.0], 0.5));
    // `auto` with an empty range: not limited.
    assert!(!m.joints[2].limited);
    // qpos0 holds the references, and the default pose is the compiled pose.
    let q0 = m.qpos0();
    assert!((q0[0] - PI / 3.0).abs() < 1e-15 && q0[1] == 0.5);
    let st = m.initial_state(None).unwrap()[0];
    close(st.pos, m.bodies[0].pos, 1e-15);
    same_rotation(st.quat, m.bodies[0].quat, 1e-15);
}

#[test]
fn radians_and_autolimits_false() {
    let m = load(
        r#"<mujoco><compiler angle="radian"/><worldbody><body>
             <joint range="-1 1"/><joint type="ball" range="0 0.5"/><geom size="1"/>
           </body></worldbody></mujoco>"#,
    );
    assert_eq!(m.joints[0].range, [-1.0, 1.0]);
    assert!(m.joints[1].limited && m.joints[1].range == [0.0, 0.5]);
    let e = fail(
        r#"<mujoco><compiler autolimits="false"/><worldbody><body>
             <joint range="-1 1"/><geom size="1"/></body></worldbody></mujoco>"#,
    );
    assert!(
        matches!(e, MjcfError::BadValue { ref attribute, .. } if attribute == "range"),
        "{e:?}"
    );
    let m = load(
        r#"<mujoco><compiler autolimits="false"/><worldbody><body>
             <joint range="-1 1" limited="true"/><geom size="1"/></body></worldbody></mujoco>"#,
    );
    assert!(m.joints[0].limited);
}

#[test]
fn bad_joint_limits_and_negative_coefficients_are_typed_errors() {
    for (body, attr) in [
        (r#"<joint limited="true" range="1 -1"/>"#, "range"),
        (r#"<joint limited="true"/>"#, "limited"),
        (r#"<joint type="ball" range="-1 1"/>"#, "range"),
        (r#"<joint armature="-1"/>"#, "armature"),
        (r#"<joint stiffness="-1"/>"#, "stiffness"),
        (r#"<joint frictionloss="-1"/>"#, "frictionloss"),
        (r#"<joint damping="-1"/>"#, "damping"),
    ] {
        let xml = world(&format!("<body>\n{body}<geom size=\"1\"/></body>"));
        match fail(&xml) {
            MjcfError::BadValue {
                element,
                attribute,
                line,
                ..
            } => assert_eq!(
                (element.as_str(), attribute.as_str(), line),
                ("joint", attr, 4)
            ),
            e => panic!("{xml}: {e:?}"),
        }
    }
    let e = fail(&world(
        r#"<body><joint range="nan 1"/><geom size="1"/></body>"#,
    ));
    assert!(matches!(e, MjcfError::BadNumber { .. }), "{e:?}");
    let e = fail(&world(
        r#"<body><freejoint/><geom size="1"/></body><body><joint type="free" limited="true"/><geom size="1"/></body>"#,
    ));
    assert!(matches!(e, MjcfError::BadValue { .. }), "{e:?}");
}

#[test]
fn include_splices_files_relative_to_the_including_file() {
    let m = load_file(&data("include_main.xml")).unwrap();
    let names: Vec<_> = m.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(names, ["arm", "hand"]);
    // The included default applies to joints in other included files.
    assert!(m.joints.iter().all(|j| j.damping == 0.5));
    close(m.bodies[1].pos, [0.0, 0.0, 0.5], 1e-15);
    // The same text with a base directory.
    let text = std::fs::read_to_string(data("include_main.xml")).unwrap();
    let m2 = load_str_with_dir(&text, &data("")).unwrap();
    assert_eq!(m, m2);
}

#[test]
fn include_errors_name_file_and_line() {
    // No base directory.
    match load_str("<mujoco>\n<include file=\"x.xml\"/></mujoco>") {
        Err(MjcfError::Include { file, line, .. }) => {
            assert_eq!((file, line), (PathBuf::from("x.xml"), 2))
        }
        other => panic!("{other:?}"),
    }
    // Missing file.
    match load_str_with_dir(
        "<mujoco>\n\n<include file=\"nope.xml\"/></mujoco>",
        &data(""),
    ) {
        Err(MjcfError::Include { file, line, reason }) => {
            assert_eq!((file.file_name().unwrap(), line), ("nope.xml".as_ref(), 3));
            assert!(reason.contains("cannot open"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    // A cycle a -> b -> a: reported at b's include (line 3 of cycle_b.xml).
    let e = load_file(&data("inc/cycle_a.xml")).unwrap_err();
    let MjcfError::InFile { file, error } = &e else {
        panic!("{e:?}")
    };
    assert!(file.ends_with("cycle_b.xml"), "{file:?}");
    match error.as_ref() {
        MjcfError::Include { line, reason, .. } => {
            assert_eq!(*line, 3);
            assert!(reason.contains("cycle"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("cycle_b.xml"), "{e}");
    // An error inside an included file names that file and the line in it.
    let e = load_str_with_dir(
        "<mujoco><include file=\"inc/bad.xml\"/></mujoco>",
        &data(""),
    )
    .unwrap_err();
    match e {
        MjcfError::InFile { file, error } => {
            assert!(file.ends_with("bad.xml"));
            assert!(
                matches!(*error, MjcfError::BadValue { line: 3, .. }),
                "{error:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    // The included root must be <mujoco>.
    let e = load_str_with_dir(
        "<mujoco><include file=\"inc/not_mujoco.xml\"/></mujoco>",
        &data(""),
    )
    .unwrap_err();
    assert!(matches!(e, MjcfError::Include { line: 1, .. }), "{e:?}");
}

#[test]
fn actuator_defaults_nest_and_shortcuts_convert_to_general_form() {
    let m = load(
        r#"<mujoco>
          <default>
            <motor ctrlrange="-1 1" gear="50"/>
            <default class="servo">
              <position kp="10" kv="2"/>
            </default>
            <default class="vel">
              <velocity kv="3" forcerange="-5 5"/>
            </default>
          </default>
          <worldbody><body>
            <joint name="a" range="-0.5 1.5" limited="true"/>
            <joint name="b" type="slide"/>
            <geom size="0.1"/>
          </body></worldbody>
          <actuator>
            <motor name="m" joint="a"/>
            <position name="p" joint="a" class="servo"/>
            <position name="p2" joint="b" kp="4"/>
            <velocity name="v" joint="b" class="vel"/>
            <general name="g" joint="b" gainprm="7" biastype="affine" biasprm="1 2 3"
                     ctrllimited="false" ctrlrange="-2 2"/>
            <position name="inherit" joint="a" kp="1" ctrlrange="0 0" inheritrange="0.5"/>
          </actuator>
        </mujoco>"#,
    );
    let a = &m.actuators;
    assert_eq!(a.len(), 6);
    // motor: gain 1, no bias, class ctrlrange and gear.
    assert_eq!(a[0].kind, ActuatorKind::Motor);
    assert_eq!((a[0].gain, a[0].bias, a[0].gear[0]), (1.0, [0.0; 3], 50.0));
    assert!(a[0].ctrllimited && a[0].ctrlrange == [-1.0, 1.0] && !a[0].forcelimited);
    assert_eq!(a[0].target, Transmission::Joint(0));
    // position: gain kp, bias (0, -kp, -kv); inherits the motor class settings too.
    assert_eq!(
        (a[1].gain, a[1].bias, a[1].gear[0]),
        (10.0, [0.0, -10.0, -2.0], 50.0)
    );
    // A position without kv keeps the inherited bias[2] (0 here).
    assert_eq!((a[2].gain, a[2].bias), (4.0, [0.0, -4.0, 0.0]));
    // velocity: gain kv, bias (0, 0, -kv); forcerange makes it force-limited (autolimits).
    assert_eq!((a[3].gain, a[3].bias), (3.0, [0.0, 0.0, -3.0]));
    assert!(a[3].forcelimited && a[3].forcerange == [-5.0, 5.0]);
    // general: gain and affine bias as written; ctrllimited false wins over the range.
    assert_eq!((a[4].gain, a[4].bias), (7.0, [1.0, 2.0, 3.0]));
    assert!(!a[4].ctrllimited);
    // inheritrange: half the joint range about its middle.
    // (The joint range is in degrees: -0.5° to 1.5°.)
    close(a[5].ctrlrange, [0.0, PI / 180.0], 1e-15);
    assert!(a[5].ctrllimited);
}

#[test]
fn actuator_errors_are_typed() {
    let body = r#"<worldbody><body><joint name="j"/><geom size="0.1"/></body></worldbody>"#;
    let act = |a: &str| format!("<mujoco>{body}<actuator>\n{a}</actuator></mujoco>");
    match fail(&act(r#"<motor joint="nope"/>"#)) {
        MjcfError::UnknownObject {
            element,
            kind,
            name,
            line,
        } => assert_eq!(
            (element.as_str(), kind, name.as_str(), line),
            ("motor", "joint", "nope", 2)
        ),
        e => panic!("{e:?}"),
    }
    match fail(&act(
        r#"<general joint="j" dyntype="filter" dynprm="0.1"/>"#,
    )) {
        MjcfError::UnsupportedFeature { feature, line, .. } => {
            assert_eq!(line, 2);
            assert!(feature.contains("dyntype"), "{feature}");
        }
        e => panic!("{e:?}"),
    }
    for bad in [
        r#"<general joint="j" gaintype="muscle"/>"#,
        r#"<muscle joint="j"/>"#,
        r#"<motor site="s"/>"#,
        r#"<position joint="j" timeconst="0.1"/>"#,
    ] {
        let e = fail(&act(bad));
        assert!(
            matches!(e, MjcfError::UnsupportedFeature { line: 2, .. }),
            "{bad}: {e:?}"
        );
    }
    for bad in [
        r#"<motor joint="j" ctrllimited="true" ctrlrange="1 -1"/>"#,
        r#"<motor/>"#,
        r#"<position joint="j" inheritrange="1"/>"#,
    ] {
        let e = fail(&act(bad));
        assert!(
            matches!(e, MjcfError::Invalid { line: 2, .. }),
            "{bad}: {e:?}"
        );
    }
    let e = fail(&act(r#"<motor joint="j" gainprm="2"/>"#));
    assert!(matches!(e, MjcfError::UnsupportedAttribute { .. }), "{e:?}");
    let e = fail(&act(r#"<position joint="j" kv="-1"/>"#));
    assert!(matches!(e, MjcfError::BadValue { .. }), "{e:?}");
    // Zero gear is accepted, as in MuJoCo (the actuator then has no effect).
    let m = load(&act(r#"<motor joint="j" gear="0"/>"#));
    assert_eq!(m.actuators[0].gear[0], 0.0);
}

#[test]
fn compiler_mass_settings() {
    let two = r#"<worldbody>
        <body><joint/><geom size="0.1" mass="1"/></body>
        <body><joint/><geom size="0.1" mass="3"/></body>
      </worldbody>"#;
    let m = load(&format!(
        "<mujoco><compiler settotalmass=\"8\"/>{two}</mujoco>"
    ));
    assert_eq!((m.bodies[0].mass, m.bodies[1].mass), (2.0, 6.0));
    let i = 2.0 * 2.0 * 0.01 / 5.0;
    close_mat(
        m.bodies[0].inertia,
        [[i, 0.0, 0.0], [0.0, i, 0.0], [0.0, 0.0, i]],
        1e-15,
    );
    let m = load(&format!(
        "<mujoco><compiler boundmass=\"2\" boundinertia=\"0.5\"/>{two}</mujoco>"
    ));
    assert_eq!((m.bodies[0].mass, m.bodies[1].mass), (2.0, 3.0));
    close_mat(
        m.bodies[0].inertia,
        [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.5]],
        1e-15,
    );
    // Geoms outside inertiagrouprange do not count.
    let m = load(
        r#"<mujoco><compiler inertiagrouprange="0 2"/><worldbody><body><joint/>
             <geom size="0.1" mass="1"/><geom size="0.1" mass="5" group="3"/>
           </body></worldbody></mujoco>"#,
    );
    assert_eq!(m.bodies[0].mass, 1.0);
}

#[test]
fn cylinder_and_ellipsoid_mass_and_fromto() {
    let m = load(&world(
        r#"<body><joint/>
             <geom type="cylinder" size="0.1 0.3" density="1000"/>
           </body>
           <body><joint/>
             <geom type="ellipsoid" size="0.1 0.2 0.3" mass="2"/>
           </body>
           <body><joint/>
             <geom type="cylinder" fromto="0 0 0 0.6 0 0" size="0.1"/>
           </body>
           <body><joint/>
             <geom type="ellipsoid" fromto="0 0 0 0 0 0.4" size="0.1"/>
           </body>"#,
    ));
    let (r, h) = (0.1f64, 0.6f64);
    let mc = 1000.0 * PI * r * r * h;
    assert!((m.bodies[0].mass - mc).abs() < 1e-12);
    let ixx = mc * (3.0 * r * r + h * h) / 12.0;
    close_mat(
        m.bodies[0].inertia,
        [
            [ixx, 0.0, 0.0],
            [0.0, ixx, 0.0],
            [0.0, 0.0, mc * r * r / 2.0],
        ],
        1e-14,
    );
    assert!(matches!(
        m.geoms[0].primitive,
        Primitive::Cylinder { radius, half_length } if radius == 0.1 && half_length == 0.3
    ));
    // The four-shape view is the bounding box.
    assert_eq!(
        m.geoms[0].shape,
        Shape::Box {
            half: [0.1, 0.1, 0.3]
        }
    );
    assert_eq!(m.bodies[1].mass, 2.0);
    close_mat(
        m.bodies[1].inertia,
        [
            [2.0 * (0.04 + 0.09) / 5.0, 0.0, 0.0],
            [0.0, 2.0 * (0.01 + 0.09) / 5.0, 0.0],
            [0.0, 0.0, 2.0 * (0.01 + 0.04) / 5.0],
        ],
        1e-15,
    );
    // fromto: cylinder along x with half length 0.3 centred at 0.3.
    assert!((m.bodies[2].mass - mc).abs() < 1e-12);
    close(m.geoms[2].pos, [0.3, 0.0, 0.0], 1e-15);
    // fromto ellipsoid: radii (0.1, 0.1, 0.2).
    assert_eq!(
        m.geoms[3].primitive,
        Primitive::Ellipsoid {
            radii: [0.1, 0.1, 0.2]
        }
    );
}

#[test]
fn geom_contact_and_visual_data() {
    let m = load(&world(
        r#"<body><joint/>
             <geom size="0.1" condim="6" contype="2" conaffinity="4" priority="2" margin="0.01"
                   gap="0.005" solref="0.01 0.5" solimp="0.8" solmix="0.5" friction="0.7"
                   rgba="1 0 0 1" material="red" group="2" user="1 2 3"/>
           </body>"#,
    ));
    let g = &m.geoms[0];
    assert_eq!(
        (g.condim, g.contype, g.conaffinity, g.priority),
        (6, 2, 4, 2)
    );
    assert_eq!((g.margin, g.gap, g.solmix), (0.01, 0.005, 0.5));
    assert_eq!(g.solref, [0.01, 0.5]);
    assert_eq!(g.solimp, [0.8, 0.95, 0.001, 0.5, 2.0]);
    assert_eq!(g.friction, [0.7, 0.005, 0.0001]);
    assert_eq!(
        (g.rgba, g.material.as_str(), g.group),
        ([1.0, 0.0, 0.0, 1.0], "red", 2)
    );
    assert_eq!(g.user, [1.0, 2.0, 3.0]);
    assert_eq!(m.warnings.len(), 1);
    assert!(
        m.warnings[0].starts_with("not modelled: hard constraints"),
        "{:?}",
        m.warnings
    );
    assert!(m.warnings[0].contains("solref"), "{:?}", m.warnings);
    // Without softness attributes: no warning.
    assert!(load(&world("<body><geom size=\"1\"/></body>"))
        .warnings
        .is_empty());
}

/// Two bodies with sites `a` and `b` and a geom `g`, and a spatial tendon whose path
/// is `path` (its path starts on line 7).
fn spatial_path(path: &str) -> String {
    format!(
        "<mujoco><worldbody>\n<body><freejoint/><geom name=\"g\" size=\"0.1\"/><site name=\"a\"/></body>\n\
         <body pos=\"1 0 0\"><freejoint/><geom size=\"0.1\"/><site name=\"b\"/></body>\n\
         </worldbody>\n<tendon>\n<spatial>\n{path}</spatial></tendon></mujoco>"
    )
}

#[test]
fn mesh_hfield_and_tendon_wrapping_are_named_unsupported_features() {
    let cases = [
        (
            world("<body>\n<geom type=\"mesh\" mesh=\"m\"/></body>"),
            "geom",
            4,
            "mesh geom",
        ),
        (
            world("<body>\n<geom type=\"capsule\" mesh=\"m\"/></body>"),
            "geom",
            4,
            "mesh geom",
        ),
        (
            "<mujoco><worldbody>\n<geom type=\"hfield\" hfield=\"h\"/></worldbody></mujoco>"
                .to_string(),
            "geom",
            2,
            "hfield geom",
        ),
        (
            spatial_path("<site site=\"a\"/>\n<geom geom=\"g\"/><site site=\"b\"/>"),
            "geom",
            8,
            "spatial tendon wrapping over a geom",
        ),
        (
            spatial_path("<site site=\"a\"/>\n<pulley divisor=\"2\"/><site site=\"b\"/>"),
            "pulley",
            8,
            "spatial tendon pulley",
        ),
    ];
    for (xml, element, line, what) in cases {
        let e = fail(&xml);
        assert_eq!(
            e,
            MjcfError::UnsupportedFeature {
                element: element.into(),
                line,
                feature: what.into()
            }
        );
        assert!(
            e.to_string().contains(&format!("unsupported: {what}")),
            "{e}"
        );
    }
}

/// `springdamper` (`tests/data/springdamper.xml`): stiffness and damping from the
/// inertia at `qpos0` (`m = 1/(M⁻¹)_ii`, armature included), against MuJoCo 4.0.0's
/// compiled `jnt_stiffness` and `dof_damping` of the same file; a joint without it
/// keeps its own; negative values are errors.
#[test]
fn springdamper_sets_stiffness_and_damping_as_mujoco() {
    let m = load_file(&data("springdamper.xml")).expect("springdamper.xml");
    // MuJoCo 4.0.0 (`mujoco.MjModel.from_xml_path`, repr of jnt_stiffness, dof_damping).
    let mujoco = [
        (16.37781134764022, 8.025127560343705),
        (38.63002965364612, 34.76702668828151),
        (15.505197192100823, 1.4884989304416791),
        (2.0, 3.0),
    ];
    let mut worst: f64 = 0.0;
    for (j, (k, d)) in m.joints.iter().zip(mujoco) {
        worst = worst
            .max((j.stiffness - k).abs() / k)
            .max((j.damping - d).abs() / d);
    }
    println!("springdamper vs MuJoCo: worst relative {worst:e}");
    // measured 4.4e-16
    assert!(worst < 1e-12, "relative error {worst:e}");
    let e = fail(&world(
        "<body><joint\n springdamper=\"-1 1\"/><geom size=\"1\"/></body>",
    ));
    assert!(matches!(e, MjcfError::BadValue { line: 4, .. }), "{e:?}");
    // Off (a zero) keeps the written values.
    let m = load(&world(
        "<body><joint springdamper=\"0 1\" stiffness=\"3\"/><geom size=\"1\"/></body>",
    ));
    assert_eq!(m.joints[0].stiffness, 3.0);
}

/// `tendon/spatial` (`tests/data/spatial_tendon.xml`): the path's sites in order, the
/// attributes of fixed tendons (a default class's among them), an actuator on it; a
/// path of one site and an unknown site are typed errors.
#[test]
fn spatial_tendons_keep_their_site_paths() {
    let m = load_file(&data("spatial_tendon.xml")).expect("spatial_tendon.xml");
    let names: Vec<&str> = m.sites.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["anchor", "ring", "knot"]);
    let (t, slack) = (&m.tendons[0], &m.tendons[1]);
    assert_eq!(
        (t.name.as_str(), t.sites.as_slice()),
        ("string", &[0, 1, 2][..])
    );
    assert!(t.joints.is_empty());
    assert_eq!(
        (t.stiffness, t.damping, t.limited, t.range, t.springlength),
        (40.0, 0.5, true, [0.0, 0.9], [0.6, 0.6])
    );
    assert_eq!(slack.sites, [1, 2]);
    assert_eq!(
        (slack.stiffness, slack.damping, slack.limited),
        (0.0, 0.0, false)
    );
    assert_eq!(m.actuators[0].target, Transmission::Tendon(0));
    let one = spatial_path("<site site=\"a\"/>");
    assert!(
        matches!(fail(&one), MjcfError::Invalid { line: 6, .. }),
        "{:?}",
        fail(&one)
    );
    let unknown = spatial_path("<site site=\"a\"/><site site=\"nowhere\"/>");
    assert!(
        matches!(
            fail(&unknown),
            MjcfError::UnknownObject {
                kind: "site",
                line: 7,
                ..
            }
        ),
        "{:?}",
        fail(&unknown)
    );
}

#[test]
fn tendons_equalities_and_contact_data() {
    let m = load(
        r#"<mujoco>
          <default><tendon stiffness="3"/><equality active="false"/></default>
          <worldbody>
            <body name="a"><joint name="j1"/><geom name="ga" size="0.1"/>
              <body name="b"><joint name="j2" type="slide"/><geom name="gb" size="0.1"/></body>
            </body>
          </worldbody>
          <contact>
            <exclude body1="a" body2="b"/>
            <pair geom1="ga" geom2="gb" condim="1" friction="0.5"/>
          </contact>
          <tendon>
            <fixed name="t" range="-1 1" springlength="0.2" damping="0.1">
              <joint joint="j1" coef="1"/>
              <joint joint="j2" coef="-0.5"/>
            </fixed>
          </tendon>
          <equality>
            <joint joint1="j1" joint2="j2" polycoef="0 2"/>
            <weld body1="b" relpose="0 0 0 0 0 0 0"/>
            <tendon tendon1="t"/>
          </equality>
          <actuator><motor tendon="t"/></actuator>
        </mujoco>"#,
    );
    let t = &m.tendons[0];
    assert_eq!(t.joints, [(0, 1.0), (1, -0.5)]);
    assert_eq!(
        (t.stiffness, t.damping, t.limited, t.range),
        (3.0, 0.1, true, [-1.0, 1.0])
    );
    assert_eq!(t.springlength, [0.2, 0.2]);
    let e = &m.joint_equalities[0];
    assert_eq!(
        (e.joint1, e.joint2, e.polycoef),
        (0, Some(1), [0.0, 2.0, 0.0, 0.0, 0.0])
    );
    assert!(!e.active);
    assert_eq!(
        (m.welds[0].body1, m.welds[0].body2, m.welds[0].relpose),
        (Some(1), None, None)
    );
    assert_eq!(m.tendon_equalities[0].tendon1, 0);
    assert_eq!(
        (m.contact_excludes[0].body1, m.contact_excludes[0].body2),
        (Some(0), Some(1))
    );
    let p = &m.contact_pairs[0];
    assert_eq!((p.geom1, p.geom2, p.condim, p.friction[0]), (0, 1, 1, 0.5));
    assert_eq!(m.actuators[0].target, Transmission::Tendon(0));
    // Unknown names are typed errors.
    let e =
        fail("<mujoco><tendon><fixed>\n<joint joint=\"x\" coef=\"1\"/></fixed></tendon></mujoco>");
    assert!(
        matches!(
            e,
            MjcfError::UnknownObject {
                kind: "joint",
                line: 2,
                ..
            }
        ),
        "{e:?}"
    );
    let e = fail("<mujoco><contact>\n<exclude body1=\"x\" body2=\"world\"/></contact></mujoco>");
    assert!(matches!(e, MjcfError::UnknownBody { line: 2, .. }), "{e:?}");
}

#[test]
fn data_only_elements_are_kept() {
    let m = load(
        r#"<mujoco>
          <size njmax="100"/>
          <visual><global offwidth="800"/></visual>
          <statistic extent="2"/>
          <asset>
            <texture name="sky" type="skybox" builtin="gradient" width="8" height="8"/>
            <texture type="2d" builtin="checker" width="8" height="8"/>
            <material name="red" rgba="1 0 0 1"/>
            <mesh file="parts/foot.stl"/>
          </asset>
          <option density="1.2" viscosity="1e-5" wind="1 0 0" cone="elliptic" impratio="10"
                  noslip_iterations="3">
            <flag contact="disable" energy="enable" warmstart="disable"/>
          </option>
          <worldbody>
            <light name="top" pos="0 0 3"/>
            <camera name="cam" pos="0 -2 1"/>
            <site name="origin" size="0.01"/>
            <body name="b"><joint name="j"/><geom size="0.1"/>
              <site name="tip" pos="0 0 1" type="box" size="0.1 0.2 0.3"/>
            </body>
          </worldbody>
          <sensor>
            <jointpos name="jp" joint="j"/>
            <touch site="tip"/>
            <accelerometer name="acc" site="tip" noise="0.1"/>
          </sensor>
          <custom>
            <numeric name="n" size="3" data="1 2"/>
            <text name="t" data="hello"/>
            <tuple name="tu"><element objtype="body" objname="b" prm="2"/></tuple>
          </custom>
        </mujoco>"#,
    );
    assert_eq!(m.assets.textures, ["sky"]);
    assert_eq!(m.assets.materials, ["red"]);
    assert_eq!(m.assets.meshes, ["foot"]);
    let o = &m.options;
    assert_eq!(
        (o.density, o.viscosity, o.wind),
        (1.2, 1e-5, [1.0, 0.0, 0.0])
    );
    assert_eq!(
        (o.cone.as_str(), o.impratio, o.noslip_iterations),
        ("elliptic", 10.0, 3)
    );
    assert_eq!(o.flags.len(), 3);
    assert!(m.contact_disabled);
    assert_eq!((m.lights[0].name.as_str(), m.lights[0].body), ("top", None));
    assert_eq!(
        (m.cameras[0].name.as_str(), m.cameras[0].body),
        ("cam", None)
    );
    assert_eq!(m.sites.len(), 2);
    assert_eq!(
        (m.sites[1].name.as_str(), m.sites[1].body),
        ("tip", Some(0))
    );
    assert_eq!(
        (m.sites[1].kind.as_str(), m.sites[1].size),
        ("box", [0.1, 0.2, 0.3])
    );
    assert_eq!(m.sites[0].size, [0.01, 0.005, 0.005]);
    let s: Vec<_> = m
        .sensors
        .iter()
        .map(|s| (s.name.as_str(), s.kind.as_str(), s.target.as_str()))
        .collect();
    assert_eq!(
        s,
        [
            ("jp", "jointpos", "j"),
            ("", "touch", "tip"),
            ("acc", "accelerometer", "tip")
        ]
    );
    assert_eq!(m.custom[0].data, [1.0, 2.0, 0.0]);
    assert_eq!(m.custom[1].text, "hello");
    assert_eq!(
        (m.custom[2].text.as_str(), m.custom[2].data.as_slice()),
        ("body:b", &[2.0][..])
    );
}

#[test]
fn joints_with_kinds_are_counted_as_mujoco_does() {
    let m = load(&world(
        r#"<body><freejoint/><geom size="0.1"/>
             <body><joint type="ball"/><joint type="slide"/><geom size="0.1"/></body>
           </body>"#,
    ));
    let kinds: Vec<_> = m.joints.iter().map(|j| j.kind).collect();
    assert_eq!(kinds, [JointKind::Free, JointKind::Ball, JointKind::Slide]);
    assert_eq!((m.nq(), m.nv()), (12, 10));
    assert_eq!(m.joints[2].qpos_adr, 11);
    assert_eq!(m.joints[2].dof_adr, 9);
}

#[test]
fn hostile_new_elements_never_panic() {
    let docs = [
        "<mujoco><actuator><general joint=\"\"/></actuator></mujoco>",
        "<mujoco><actuator><motor gear=\"nan\"/></actuator></mujoco>",
        "<mujoco><tendon><fixed/></tendon></mujoco>",
        "<mujoco><custom><numeric name=\"n\" size=\"99999999999\"/></custom></mujoco>",
        "<mujoco><custom><numeric name=\"n\" size=\"1\" data=\"1 2\"/></custom></mujoco>",
        "<mujoco><equality><joint joint1=\"a\"/></equality></mujoco>",
        "<mujoco><contact><pair geom1=\"a\"/></contact></mujoco>",
        "<mujoco><compiler settotalmass=\"1e308\"/><worldbody><body><joint/><geom size=\"1e100\"/></body></worldbody></mujoco>",
        "<mujoco><sensor><touch/></sensor><keyframe><key ctrl=\"1 2\"/></keyframe></mujoco>",
        "<mujoco><include/></mujoco>",
        "<mujoco><include file=\"\"/></mujoco>",
    ];
    for d in docs {
        let _ = load_str(d);
        let _ = load_str_with_dir(d, &data(""));
    }
}
