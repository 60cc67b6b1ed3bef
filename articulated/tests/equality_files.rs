//! Hostile MJCF files for the equality rows and tendon ranges (issue 13): each bad
//! `equality/joint`, `equality/tendon` or tendon `range` is a typed error that names the
//! element and its line — from the loader (names, joint kinds, numbers) or from the
//! adapter (what the world rejects) — never a panic or a silently different model.

#![cfg(feature = "mjcf")]

use constraint_articulated::MjcfScene;

/// Two hinged bodies, a ball-jointed body, a free body and two tendons; `@EQ@` is the
/// equality section (line 12), `@T@` extra tendon content (line 10). The loader
/// rejects unknown names, joint kinds, non-finite numbers, empty fixed tendons and bad
/// ranges with the line; the adapter rejects what the loader lets through (a joint or
/// tendon coupled to itself) naming the element and line.
const BASE: &str = r#"<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="a"><joint name="ha" axis="0 1 0"/><geom size="0.1" pos="0 0 -0.5"/></body>
    <body name="b" pos="1 0 0"><joint name="hb" axis="0 1 0"/><geom size="0.1" pos="0 0 -0.5"/></body>
    <body name="c" pos="2 0 0"><joint name="bc" type="ball"/><geom size="0.1" pos="0 0 -0.5"/></body>
    <body name="d" pos="3 0 0"><freejoint name="fd"/><geom size="0.1"/></body>
  </worldbody>
  <tendon><fixed name="t1"><joint joint="ha" coef="1"/></fixed><fixed name="t2"><joint joint="hb" coef="2"/></fixed>
  @T@</tendon>
  <equality>
    @EQ@
  </equality>
</mujoco>"#;

fn load(eq: &str, tendon: &str) -> Result<MjcfScene, String> {
    let xml = BASE.replace("@EQ@", eq).replace("@T@", tendon);
    let model = constraint_mjcf::load_str(&xml).map_err(|e| e.to_string())?;
    MjcfScene::new(&model, None).map_err(|e| e.to_string())
}

#[test]
fn good_equalities_and_ranges_load() {
    let s = load(
        r#"<joint name="m" joint1="ha" joint2="hb" polycoef="0 -1"/><tendon name="f" tendon1="t1" tendon2="t2"/>"#,
        r#"<fixed name="t3" range="-0.5 0.5"><joint joint="ha" coef="1"/><joint joint="hb" coef="-1"/></fixed>"#,
    )
    .expect("loads");
    assert_eq!(s.world.equalities().len(), 2);
    assert_eq!(s.world.tendon_ranges().get(2), Some(&Some([-0.5, 0.5])));
    // The second equality's sides are the tendons' terms.
    assert_eq!(s.world.equalities()[1].first, s.world.tendons()[0].terms);
    assert_eq!(s.world.equalities()[1].second, s.world.tendons()[1].terms);
}

#[test]
fn bad_equalities_name_the_element_and_line() {
    let eq_line = "line 12";
    let cases: [(&str, &str, &str, &[&str]); 9] = [
        (
            "unknown joint",
            r#"<joint name="e" joint1="nope" joint2="hb"/>"#,
            "",
            &["nope", eq_line],
        ),
        (
            "unknown tendon",
            r#"<tendon name="e" tendon1="nope"/>"#,
            "",
            &["nope", eq_line],
        ),
        (
            "joint1 == joint2",
            r#"<joint name="e" joint1="ha" joint2="ha"/>"#,
            "",
            &["\"e\"", eq_line, "same joint"],
        ),
        (
            "tendon1 == tendon2",
            r#"<tendon name="e" tendon1="t1" tendon2="t1"/>"#,
            "",
            &["\"e\"", eq_line, "same tendon"],
        ),
        (
            "NaN polycoef",
            r#"<joint name="e" joint1="ha" joint2="hb" polycoef="0 nan"/>"#,
            "",
            &[eq_line],
        ),
        (
            "infinite polycoef",
            r#"<joint name="e" joint1="ha" polycoef="inf"/>"#,
            "",
            &[eq_line],
        ),
        (
            "equality on a ball joint",
            r#"<joint name="e" joint1="bc"/>"#,
            "",
            &[eq_line],
        ),
        (
            "equality on a free joint",
            r#"<joint name="e" joint1="ha" joint2="fd"/>"#,
            "",
            &[eq_line],
        ),
        (
            "tendon with no joints",
            r#"<tendon name="e" tendon1="t1" tendon2="t0"/>"#,
            r#"<fixed name="t0"/>"#,
            &["line 10", "at least one joint"],
        ),
    ];
    for (label, eq, tendon, needles) in cases {
        let e = match load(eq, tendon) {
            Ok(_) => panic!("{label}: accepted"),
            Err(e) => e,
        };
        println!("{label}: {e}");
        for n in needles {
            assert!(e.contains(n), "{label}: {e:?} lacks {n:?}");
        }
    }
}

#[test]
fn bad_tendon_ranges_name_the_element_and_line() {
    for (label, tendon) in [
        (
            "range with lo > hi",
            r#"<fixed name="r" limited="true" range="0.5 -0.5"><joint joint="ha" coef="1"/></fixed>"#,
        ),
        (
            "range with NaN",
            r#"<fixed name="r" limited="true" range="nan 1"><joint joint="ha" coef="1"/></fixed>"#,
        ),
        (
            "range on a tendon with no joints",
            r#"<fixed name="r" limited="true" range="-1 1"/>"#,
        ),
    ] {
        let e = match load("", tendon) {
            Ok(_) => panic!("{label}: accepted"),
            Err(e) => e,
        };
        println!("{label}: {e}");
        assert!(e.contains("line 10"), "{label}: {e:?} lacks the line");
    }
}
