//! Every error variant from a malformed file, with element and line; hostile input
//! (deep nesting, huge numbers, NaN, truncated and mangled files) never panics.

mod common;

use common::{fail, load, world};
use constraint_mjcf::{load_file, load_str, MjcfError, MAX_DEPTH};
use std::path::Path;

fn unsupported(element: &str, line: u32) -> MjcfError {
    MjcfError::Unsupported {
        element: element.into(),
        line,
    }
}

fn unsupported_attr(element: &str, attribute: &str, line: u32) -> MjcfError {
    MjcfError::UnsupportedAttribute {
        element: element.into(),
        attribute: attribute.into(),
        line,
    }
}

fn bad_number(element: &str, attribute: &str, value: &str, line: u32) -> MjcfError {
    MjcfError::BadNumber {
        element: element.into(),
        attribute: attribute.into(),
        value: value.into(),
        line,
    }
}

/// Element, attribute and line of a `BadValue`.
fn bad_value_at(e: &MjcfError) -> (&str, &str, u32) {
    match e {
        MjcfError::BadValue {
            element,
            attribute,
            line,
            ..
        } => (element, attribute, *line),
        other => panic!("expected BadValue, got {other:?}"),
    }
}

/// Element and line of an `Invalid`, and its reason.
fn invalid_at(e: &MjcfError) -> (&str, u32, &str) {
    match e {
        MjcfError::Invalid {
            element,
            line,
            reason,
        } => (element, *line, reason),
        other => panic!("expected Invalid, got {other:?}"),
    }
}

#[test]
fn malformed_xml() {
    let e = fail("<mujoco>\n<worldbody>\n</mujoco>");
    assert!(matches!(e, MjcfError::Xml { line: 3, .. }), "{e:?}");
    assert!(e.to_string().starts_with("line 3: XML error"));
    // DTDs (entity expansion) are refused.
    let e = fail("<!DOCTYPE m [<!ENTITY a \"aaaa\">]>\n<mujoco/>");
    assert!(matches!(e, MjcfError::Xml { .. }), "{e:?}");
    assert!(matches!(fail(""), MjcfError::Xml { .. }));
}

fn feature(element: &str, line: u32, what: &str) -> MjcfError {
    MjcfError::UnsupportedFeature {
        element: element.into(),
        line,
        feature: what.into(),
    }
}

#[test]
fn unknown_elements() {
    assert_eq!(fail("<robot/>"), unsupported("robot", 1));
    assert_eq!(
        fail("<mujoco>\n  <deformable/>\n</mujoco>"),
        unsupported("deformable", 2)
    );
    assert_eq!(
        fail(&world("<body>\n<frame/>\n</body>")),
        feature("frame", 4, "frame")
    );
    assert_eq!(
        fail(&world("<body><geom size=\"1\"><foo/></geom></body>")),
        unsupported("foo", 3)
    );
    assert_eq!(
        fail("<mujoco><default>\n<muscle/></default></mujoco>"),
        unsupported("muscle", 2)
    );
    assert_eq!(
        fail("<mujoco><equality>\n<flex flex=\"a\"/></equality></mujoco>"),
        unsupported("flex", 2)
    );
    assert_eq!(
        fail("<mujoco><option><flags/></option></mujoco>"),
        unsupported("flags", 1)
    );
    assert_eq!(fail(&world("<joint/>")), unsupported("joint", 3));
}

#[test]
fn a_free_joint_must_be_alone_in_its_body() {
    let e = fail(&world(
        "<body>\n<freejoint/>\n<joint/>\n<geom size=\"1\"/></body>",
    ));
    let (el, line, reason) = invalid_at(&e);
    assert_eq!((el, line), ("body", 3));
    assert!(
        reason.contains("free joint can only appear by itself"),
        "{reason}"
    );
}

#[test]
fn unknown_or_unmodelled_attributes() {
    assert_eq!(
        fail(&world("<body>\n<geom size=\"1\" foo=\"1\"/></body>")),
        unsupported_attr("geom", "foo", 4)
    );
    assert_eq!(
        fail(&world(
            "<body><joint type=\"ball\"\n springdamper=\"1 1\"/><geom size=\"1\"/></body>"
        )),
        feature("joint", 4, "springdamper on a ball or free joint")
    );
    assert_eq!(
        fail(&world("<body mocap=\"true\"><geom size=\"1\"/></body>")),
        feature("body", 3, "mocap body")
    );
    assert_eq!(
        fail("<mujoco><compiler fusestatic=\"true\"/></mujoco>"),
        feature("compiler", 1, "compiler fusestatic")
    );
    assert_eq!(
        fail("<mujoco><compiler coordinate=\"global\"/></mujoco>"),
        feature("compiler", 1, "coordinate=\"global\" (removed from MuJoCo)")
    );
    assert_eq!(
        fail("<mujoco><option foo=\"1 0 0\"/></mujoco>"),
        unsupported_attr("option", "foo", 1)
    );
    // Attribute errors in a default class point at the class's line.
    assert_eq!(
        fail("<mujoco>\n<default>\n<geom foo=\"1\"/>\n</default></mujoco>"),
        unsupported_attr("geom", "foo", 3)
    );
    // A keyframe ctrl longer than the number of actuators.
    let e = fail("<mujoco><keyframe><key ctrl=\"1\"/></keyframe></mujoco>");
    assert_eq!(bad_value_at(&e), ("key", "ctrl", 1));
    assert_eq!(
        fail("<mujoco><worldbody/><equality><connect body1=\"world\" anchor=\"0 0 0\" site1=\"s\"/></equality></mujoco>"),
        unsupported_attr("connect", "site1", 1)
    );
}

#[test]
fn missing_required_attributes() {
    let e = fail(&world(
        "<body><joint/>\n<inertial pos=\"0 0 0\" diaginertia=\"1 1 1\"/></body>",
    ));
    assert_eq!(
        e,
        MjcfError::MissingAttribute {
            element: "inertial".into(),
            attribute: "mass".into(),
            line: 4
        }
    );
    let e = fail("<mujoco><worldbody><body name=\"a\"><geom size=\"1\"/></body></worldbody>\n<equality><connect body1=\"a\"/></equality></mujoco>");
    assert_eq!(
        e,
        MjcfError::MissingAttribute {
            element: "connect".into(),
            attribute: "anchor".into(),
            line: 2
        }
    );
    let e = fail("<mujoco><default><default/></default></mujoco>");
    assert!(matches!(e, MjcfError::MissingAttribute { ref attribute, .. } if attribute == "class"));
}

#[test]
fn bad_numbers() {
    assert_eq!(
        fail(&world("<body pos=\"1 x 3\"><geom size=\"1\"/></body>")),
        bad_number("body", "pos", "1 x 3", 3)
    );
    assert_eq!(
        fail(&world(
            "<body><joint/><geom size=\"1\" mass=\"NaN\"/></body>"
        )),
        bad_number("geom", "mass", "NaN", 3)
    );
    assert_eq!(
        fail(&world("<body><geom size=\"inf\"/></body>")),
        bad_number("geom", "size", "inf", 3)
    );
    assert_eq!(
        fail(&world("<body><geom size=\"1e999\"/></body>")),
        bad_number("geom", "size", "1e999", 3)
    );
    assert_eq!(
        fail("<mujoco><option\n timestep=\"fast\"/></mujoco>"),
        bad_number("option", "timestep", "fast", 2)
    );
    assert_eq!(
        fail(&world("<body><geom size=\"1\" contype=\"1.5\"/></body>")),
        bad_number("geom", "contype", "1.5", 3)
    );
    assert_eq!(
        fail("<mujoco><keyframe><key time=\"-nan\"/></keyframe></mujoco>"),
        bad_number("key", "time", "-nan", 1)
    );
}

#[test]
fn bad_values() {
    let cases = [
        (world("<body><joint/><geom size=\"1\" mass=\"-1\"/></body>"), "geom", "mass"),
        (world("<body><joint/>\n<inertial pos=\"0 0 0\" mass=\"-2\"/></body>"), "inertial", "mass"),
        (world("<body><joint/><inertial pos=\"0 0 0\" mass=\"1\" diaginertia=\"1 -1 1\"/></body>"), "inertial", "diaginertia"),
        (world("<body><geom size=\"-0.1\"/></body>"), "geom", "size"),
        (world("<body><geom type=\"box\" size=\"0.1 0.1\"/></body>"), "geom", "size"),
        (world("<body><geom type=\"cone\" size=\"0.1 0.1\"/></body>"), "geom", "type"),
        (world("<body><geom type=\"cylinder\" size=\"0.1\"/></body>"), "geom", "size"),
        (world("<body><geom type=\"ellipsoid\" size=\"0.1 0.2\"/></body>"), "geom", "size"),
        (world("<body><geom size=\"1\" condim=\"2\"/></body>"), "geom", "condim"),
        (world("<body><geom size=\"1\" friction=\"-1\"/></body>"), "geom", "friction"),
        (world("<body><geom size=\"1\" density=\"-1\"/></body>"), "geom", "density"),
        (world("<body><geom size=\"1\" contype=\"-1\"/></body>"), "geom", "contype"),
        (world("<body pos=\"1 2\"><geom size=\"1\"/></body>"), "body", "pos"),
        (world("<body quat=\"0 0 0 0\"><geom size=\"1\"/></body>"), "body", "quat"),
        (world("<body><joint axis=\"0 0 0\"/><geom size=\"1\"/></body>"), "joint", "axis"),
        (world("<body><joint type=\"universal\"/><geom size=\"1\"/></body>"), "joint", "type"),
        (world("<body><joint damping=\"-1\"/><geom size=\"1\"/></body>"), "joint", "damping"),
        (world("<body><geom type=\"sphere\" fromto=\"0 0 0 1 0 0\" size=\"1\"/></body>"), "geom", "fromto"),
        (world("<body><geom type=\"capsule\" fromto=\"1 0 0 1 0 0\" size=\"1\"/></body>"), "geom", "fromto"),
        (world("<body><joint/><inertial pos=\"0 0 0\" mass=\"1\" fullinertia=\"1 1 1 2 0 0\"/></body>"), "inertial", "fullinertia"),
        ("<mujoco><compiler angle=\"grad\"/></mujoco>".to_string(), "compiler", "angle"),
        ("<mujoco><compiler eulerseq=\"xyw\"/></mujoco>".to_string(), "compiler", "eulerseq"),
        ("<mujoco><option timestep=\"0\"/></mujoco>".to_string(), "option", "timestep"),
        ("<mujoco><option integrator=\"euler\"/></mujoco>".to_string(), "option", "integrator"),
    ];
    for (xml, element, attribute) in &cases {
        let e = fail(xml);
        let (el, at, _) = bad_value_at(&e);
        assert_eq!((el, at), (*element, *attribute), "{xml}");
    }
    // The line is the attribute's.
    let e = fail(&world(
        "<body>\n<joint/>\n<geom size=\"1\"\n mass=\"-1\"/></body>",
    ));
    assert_eq!(bad_value_at(&e), ("geom", "mass", 6));
}

#[test]
fn invalid_combinations_and_unphysical_results() {
    let cases: [(String, &str, &str); 9] = [
        (world("<body>\n<geom size=\"1\" quat=\"1 0 0 0\" euler=\"0 0 0\"/></body>"), "geom", "multiple orientation"),
        (world("<body><joint/>\n<inertial pos=\"0 0 0\" mass=\"1\" diaginertia=\"1 1 5\"/></body>"), "body", "A + B >= C"),
        (world("<body>\n<joint/></body>"), "body", "moving body"),
        (world("<body><joint/>\n<geom type=\"plane\" size=\"1 1 1\"/></body>"), "geom", "plane"),
        (world("<body><geom size=\"1\"/><body>\n<freejoint/><geom size=\"1\"/></body></body>"), "freejoint", "top level"),
        (world("<body>\n<geom type=\"capsule\" pos=\"1 0 0\" fromto=\"0 0 0 1 0 0\" size=\"1\"/></body>"), "geom", "both pos and fromto"),
        (world("<body name=\"a\"><geom size=\"1\"/></body>\n<body name=\"a\"><geom size=\"1\"/></body>"), "body", "repeated name"),
        (world("<body><joint/><inertial pos=\"0 0 0\" mass=\"1\" fullinertia=\"1 1 1 0 0 0\"\n euler=\"0 0 1\"/></body>"), "inertial", "fullinertia"),
        ("<mujoco><default/>\n<default/></mujoco>".to_string(), "default", "top-level"),
    ];
    for (xml, element, reason) in &cases {
        let e = fail(xml);
        let (el, line, why) = invalid_at(&e);
        assert_eq!(el, *element, "{xml}: {e}");
        assert!(why.contains(reason), "{xml}: {e}");
        assert!(
            line >= 3 || el == "inertial" || el == "default",
            "{xml}: {e}"
        );
    }
    // Lines point at the offending element.
    let (_, line, _) = invalid_at(&fail(&cases[3].0)).to_owned();
    assert_eq!(line, 4);
    let (_, line, _) = invalid_at(&fail(&cases[2].0)).to_owned();
    assert_eq!(line, 3);
}

#[test]
fn zero_mass_moving_body_is_fine_when_a_welded_child_carries_mass() {
    let m = load(&world(
        "<body><joint/><body><geom size=\"1\"/></body></body>",
    ));
    assert_eq!(m.bodies[0].mass, 0.0);
}

#[test]
fn unknown_names() {
    assert_eq!(
        fail(&world("<body>\n<geom class=\"nope\" size=\"1\"/></body>")),
        MjcfError::UnknownClass {
            element: "geom".into(),
            class: "nope".into(),
            line: 4
        }
    );
    assert!(matches!(
        fail(&world(
            "<body childclass=\"nope\"><geom size=\"1\"/></body>"
        )),
        MjcfError::UnknownClass { line: 3, .. }
    ));
    assert_eq!(
        fail("<mujoco><worldbody><body name=\"a\"><geom size=\"1\"/></body></worldbody>\n<equality>\n<connect body1=\"a\" body2=\"b\" anchor=\"0 0 0\"/></equality></mujoco>"),
        MjcfError::UnknownBody {
            element: "connect".into(),
            name: "b".into(),
            line: 3
        }
    );
    let m = load("<mujoco><keyframe><key name=\"a\"/></keyframe></mujoco>");
    assert!(m.keyframe("a").is_ok());
    assert_eq!(m.keyframe("b"), Err(MjcfError::UnknownKeyframe("b".into())));
    assert_eq!(
        m.initial_state(Some("b")),
        Err(MjcfError::UnknownKeyframe("b".into()))
    );
    assert_eq!(
        MjcfError::UnknownKeyframe("b".into()).to_string(),
        "no keyframe named \"b\""
    );
}

#[test]
fn keyframe_vectors_longer_than_nq_or_nv_are_errors() {
    // MuJoCo 4.0 pads short keys with qpos0 / zeros and rejects long ones.
    let body = "<worldbody><body><joint type=\"ball\"/><geom size=\"1\"/></body></worldbody>";
    for key in ["<key qpos=\"1 0 0 0 0\"/>", "<key qvel=\"1 2 3 4\"/>"] {
        let e = fail(&format!(
            "<mujoco>{body}<keyframe>\n{key}</keyframe></mujoco>"
        ));
        let (el, _, line) = bad_value_at(&e);
        assert_eq!((el, line), ("key", 2), "{key}");
    }
}

#[test]
fn io_error_names_the_path() {
    let e = load_file(Path::new("/nonexistent/scene.xml")).expect_err("no file");
    assert!(
        matches!(e, MjcfError::Io { ref path, .. } if path == Path::new("/nonexistent/scene.xml"))
    );
    assert!(e.to_string().contains("/nonexistent/scene.xml"));
}

#[test]
fn deep_nesting_is_a_typed_error_not_a_stack_overflow() {
    let n = 10_000;
    let mut xml = String::from("<mujoco><worldbody>\n");
    for _ in 0..n {
        xml.push_str("<body>");
    }
    for _ in 0..n {
        xml.push_str("</body>");
    }
    xml.push_str("</worldbody></mujoco>");
    match load_str(&xml) {
        Err(MjcfError::TooDeep { line, limit }) => {
            assert_eq!(limit, MAX_DEPTH);
            assert_eq!(line, 2);
        }
        other => panic!("expected TooDeep, got {other:?}"),
    }
    // Just under the limit loads (a chain of welded bodies).
    let n = MAX_DEPTH - 3; // mujoco, worldbody, bodies, geom
    let mut xml = String::from("<mujoco><worldbody>");
    for _ in 0..n {
        xml.push_str("<body pos=\"0 0 -0.1\">");
    }
    xml.push_str("<geom size=\"0.01\"/>");
    for _ in 0..n {
        xml.push_str("</body>");
    }
    xml.push_str("</worldbody></mujoco>");
    let m = load(&xml);
    assert_eq!(m.bodies.len(), n);
    assert!((m.bodies[n - 1].pos[2] + 0.1 * n as f64).abs() < 1e-9);
}

#[test]
fn huge_values_overflowing_mass_are_errors() {
    let e = fail(&world("<body><freejoint/><geom size=\"1e300\"/></body>"));
    assert!(matches!(e, MjcfError::Invalid { .. }), "{e:?}");
}

#[test]
fn every_error_displays_its_line() {
    for xml in [
        "<mujoco>\n<tendon><spatial/></tendon></mujoco>".to_string(),
        "<mujoco>\n<option foo=\"1\"/></mujoco>".to_string(),
        "<mujoco>\n<option timestep=\"x\"/></mujoco>".to_string(),
        "<mujoco>\n<option timestep=\"-1\"/></mujoco>".to_string(),
    ] {
        let e = fail(&xml);
        assert!(e.to_string().starts_with("line 2: "), "{e}");
        let _: &dyn std::error::Error = &e;
    }
}

/// Truncating a valid file at every character and flipping bytes never panics.
#[test]
fn truncated_and_mangled_files_never_panic() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let text = std::fs::read_to_string(dir.join("ball_chain.xml")).expect("data file");
    for (i, _) in text.char_indices() {
        let _ = load_str(&text[..i]);
    }
    let bytes = text.as_bytes();
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let replacements = b"<>/=\" 0-.9e\nxNa";
    for _ in 0..3000 {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let pos = (seed >> 33) as usize % bytes.len();
        let with = replacements[(seed >> 20) as usize % replacements.len()];
        let mut mangled = bytes.to_vec();
        mangled[pos] = with;
        if let Ok(s) = String::from_utf8(mangled) {
            if let Ok(m) = load_str(&s) {
                for k in 0..m.keyframes.len() {
                    let name = m.keyframes[k].name.clone();
                    let _ = m.initial_state(Some(&name));
                }
            }
        }
    }
}

#[test]
fn overflowing_poses_and_states_are_errors() {
    let e = fail(&world("<body pos=\"1e308 0 0\"><geom size=\"1\"/><body pos=\"1e308 0 0\"><geom size=\"1\"/></body></body>"));
    assert!(matches!(e, MjcfError::Invalid { line: 3, .. }), "{e:?}");
    let m = load(&world(
        "<body><freejoint/><geom size=\"1\" pos=\"1e308 0 0\"/></body>",
    ));
    let e = m
        .body_states(&[1e308, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], &[0.0; 6])
        .expect_err("overflow");
    assert_eq!(
        e,
        MjcfError::NonFiniteState {
            what: "body state",
            index: 0
        }
    );
}
