//! `simulate` (what `cargo xtask simulate` runs) on malformed and hostile scene files
//! and options (issue 7): every case must exit with a non-zero status and exactly one
//! line on stderr naming the reason, within a time limit (no hang), without a panic,
//! and without writing an output file with non-finite numbers. Valid files that
//! diverge must stop with the typed divergence error, not write NaN. `--help` of both
//! binaries lists every option with its default; `compare` (what `cargo xtask compare`
//! runs) keeps the same one-line contract on bad arguments and files.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Each case must finish within this (s); measured: the slowest case takes 0.05 s.
const LIMIT: Duration = Duration::from_secs(20);

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("simulate_cli_{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Runs `simulate` with `args`; returns (success, stderr, wall time).
fn simulate(args: &[&str]) -> (bool, String, Duration) {
    let (code, _, err, t) = run_bin(env!("CARGO_BIN_EXE_simulate"), args);
    (code == Some(0), err, t)
}

/// Runs a binary with `args`; returns (exit code, stdout, stderr, wall time).
fn run_bin(exe: &str, args: &[&str]) -> (Option<i32>, String, String, Duration) {
    let t0 = Instant::now();
    let mut child = Command::new(exe)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    // Outputs here are small (a help text, a report), far below a pipe's buffer.
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            let (mut out, mut err) = (String::new(), String::new());
            use std::io::Read as _;
            if let Some(mut o) = child.stdout.take() {
                let _ = o.read_to_string(&mut out);
            }
            if let Some(mut e) = child.stderr.take() {
                let _ = e.read_to_string(&mut err);
            }
            return (status.code(), out, err, t0.elapsed());
        }
        if t0.elapsed() > LIMIT {
            let _ = child.kill();
            panic!("{exe} {args:?} hung (killed after {LIMIT:?})");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The one-line-failure contract; `out` must not hold non-finite numbers if written.
fn assert_clean_failure(name: &str, args: &[&str], out: &Path) {
    let (ok, err, t) = simulate(args);
    assert!(!ok, "{name}: exit status 0 (stderr {err:?})");
    let lines = one_line(name, "simulate: ", &err);
    assert!(!err.contains("panicked"), "{name}: panic: {err:?}");
    if let Ok(csv) = std::fs::read_to_string(out) {
        for tok in csv
            .split([',', '\n'])
            .skip_while(|t| t.parse::<f64>().is_err())
        {
            if let Ok(v) = tok.trim().parse::<f64>() {
                assert!(v.is_finite(), "{name}: non-finite output {tok}");
            }
        }
    }
    eprintln!("{name}: {} ({:.3} s)", lines[0], t.as_secs_f64());
}

/// Checks that `err` is one line `<prefix><reason>`, no panic; returns the lines.
fn one_line<'a>(name: &str, prefix: &str, err: &'a str) -> Vec<&'a str> {
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{name}: stderr is not one line: {err:?}");
    assert!(
        lines[0].starts_with(prefix) && lines[0].len() > prefix.len() + 3,
        "{name}: {err:?}"
    );
    assert!(!err.contains("panicked"), "{name}: panic: {err:?}");
    lines
}

const PENDULUM: &str = r#"<mujoco model="p">
  <option timestep="0.001" gravity="0 0 -9.81"><flag contact="disable"/></option>
  <worldbody>
    <body name="bob">
      <joint name="hinge" type="hinge" axis="AXIS"/>
      <inertial pos="0 0 -1" mass="MASS" diaginertia="INERTIA"/>
    </body>
  </worldbody>
</mujoco>"#;

fn pendulum(axis: &str, mass: &str, inertia: &str) -> String {
    PENDULUM
        .replace("AXIS", axis)
        .replace("MASS", mass)
        .replace("INERTIA", inertia)
}

fn hostile_files() -> Vec<(&'static str, String)> {
    let deep = format!(
        "<mujoco><worldbody>{}{}</worldbody></mujoco>",
        "<body><geom type=\"sphere\" size=\"0.1\"/>".repeat(10_000),
        "</body>".repeat(10_000)
    );
    let wide = format!(
        "<mujoco><worldbody>{}</worldbody></mujoco>",
        "<unknown/>".repeat(100_000)
    );
    vec![
        ("empty file", String::new()),
        ("not XML", "this is not a scene \u{0}\u{1}".into()),
        ("binary garbage", "\u{7f}ELF\u{2}\u{1}\u{1}".repeat(100)),
        ("unclosed tag", "<mujoco><worldbody>".into()),
        ("wrong root", "<robot/>".into()),
        (
            "unknown element",
            "<mujoco><worldbody><teapot/></worldbody></mujoco>".into(),
        ),
        ("100k unknown elements", wide),
        ("10,000-deep nesting", deep),
        ("missing joint axis value", pendulum("", "1", "1e-4 1e-4 1e-4")),
        ("NaN axis", pendulum("nan 0 0", "1", "1e-4 1e-4 1e-4")),
        ("zero axis", pendulum("0 0 0", "1", "1e-4 1e-4 1e-4")),
        ("huge number", pendulum("0 1 0", "1e400", "1e-4 1e-4 1e-4")),
        ("negative mass", pendulum("0 1 0", "-1", "1e-4 1e-4 1e-4")),
        ("zero mass", pendulum("0 1 0", "0", "0 0 0")),
        ("NaN mass", pendulum("0 1 0", "NaN", "1e-4 1e-4 1e-4")),
        ("infinite mass", pendulum("0 1 0", "inf", "1e-4 1e-4 1e-4")),
        ("triangle inequality", pendulum("0 1 0", "1", "1 1 3")),
        ("two values for three", pendulum("0 1 0", "1", "1 1")),
        (
            "NaN gravity",
            pendulum("0 1 0", "1", "1e-4 1e-4 1e-4").replace("0 0 -9.81", "0 0 nan"),
        ),
        (
            "negative time step",
            pendulum("0 1 0", "1", "1e-4 1e-4 1e-4").replace("0.001", "-0.001"),
        ),
        (
            "unknown attribute",
            pendulum("0 1 0", "1", "1e-4 1e-4 1e-4").replace("<joint ", "<joint bogus=\"1\" "),
        ),
        (
            "duplicate body name",
            "<mujoco><worldbody><body name=\"a\"><freejoint/><geom type=\"sphere\" size=\"1\"/></body>\
             <body name=\"a\"><freejoint/><geom type=\"sphere\" size=\"1\"/></body></worldbody></mujoco>"
                .into(),
        ),
        (
            "keyframe of the wrong length",
            pendulum("0 1 0", "1", "1e-4 1e-4 1e-4")
                .replace("</mujoco>", "<keyframe><key name=\"start\" qpos=\"1 2 3\"/></keyframe></mujoco>"),
        ),
        (
            "NaN in a keyframe",
            pendulum("0 1 0", "1", "1e-4 1e-4 1e-4")
                .replace("</mujoco>", "<keyframe><key name=\"start\" qpos=\"nan\"/></keyframe></mujoco>"),
        ),
        (
            "sphere of negative size",
            "<mujoco><worldbody><geom type=\"plane\" size=\"1 1 1\"/><body pos=\"0 0 1\"><freejoint/>\
             <geom type=\"sphere\" size=\"-0.1\"/></body></worldbody></mujoco>"
                .into(),
        ),
    ]
}

#[test]
fn hostile_scene_files_fail_with_one_line() {
    let d = dir();
    let out = d.join("out.csv");
    let mut n = 0;
    for (name, text) in hostile_files() {
        let path = d.join("scene.xml");
        std::fs::write(&path, text).expect("write scene");
        let _ = std::fs::remove_file(&out);
        let p = path.to_string_lossy().to_string();
        let o = out.to_string_lossy().to_string();
        let mut args = vec![p.as_str(), "--duration", "0.01", "--out", o.as_str()];
        if name.contains("keyframe") {
            args.extend(["--keyframe", "start"]);
        }
        assert_clean_failure(name, &args, &out);
        n += 1;
    }
    eprintln!("{n} hostile files");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_options_fail_with_one_line() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/pendulum.xml");
    let s = scene.to_string_lossy().to_string();
    let d = dir().join("opts");
    std::fs::create_dir_all(&d).expect("dir");
    let out = d.join("out.csv");
    let o = out.to_string_lossy().to_string();
    let missing = d.join("missing.xml").to_string_lossy().to_string();
    let bad_ctrl_path = d.join("bad_ctrl.csv");
    std::fs::write(&bad_ctrl_path, "t,no_such_actuator\n0,1\n").expect("write ctrl");
    let bad_ctrl = bad_ctrl_path.to_string_lossy().to_string();
    let cases: Vec<(&str, Vec<&str>)> = vec![
        ("no arguments", vec![]),
        ("missing duration", vec![&s, "--out", &o]),
        ("missing out", vec![&s, "--duration", "1"]),
        (
            "missing file",
            vec![&missing, "--duration", "1", "--out", &o],
        ),
        (
            "NaN dt",
            vec![&s, "--dt", "nan", "--duration", "1", "--out", &o],
        ),
        (
            "zero dt",
            vec![&s, "--dt", "0", "--duration", "1", "--out", &o],
        ),
        (
            "negative dt",
            vec![&s, "--dt", "-1e-3", "--duration", "1", "--out", &o],
        ),
        (
            "infinite duration",
            vec![&s, "--duration", "inf", "--out", &o],
        ),
        (
            "negative duration",
            vec![&s, "--duration", "-1", "--out", &o],
        ),
        (
            "every 0",
            vec![&s, "--duration", "1", "--every", "0", "--out", &o],
        ),
        (
            "every -1",
            vec![&s, "--duration", "1", "--every", "-1", "--out", &o],
        ),
        (
            "too many steps",
            vec![&s, "--dt", "1e-300", "--duration", "1", "--out", &o],
        ),
        (
            "unknown method",
            vec![&s, "--duration", "1", "--method", "magic", "--out", &o],
        ),
        (
            "unknown keyframe",
            vec![&s, "--duration", "1", "--keyframe", "nope", "--out", &o],
        ),
        (
            "unknown option",
            vec![&s, "--duration", "1", "--frobnicate", "--out", &o],
        ),
        ("two scenes", vec![&s, &s, "--duration", "1", "--out", &o]),
        (
            "qpos too long",
            vec![&s, "--duration", "0.1", "--qpos", "1,2,3", "--out", &o],
        ),
        (
            "qpos NaN",
            vec![&s, "--duration", "0.1", "--qpos", "nan", "--out", &o],
        ),
        (
            "qvel not a number",
            vec![&s, "--duration", "0.1", "--qvel", "x", "--out", &o],
        ),
        (
            "qpos with a keyframe",
            vec![
                &s,
                "--duration",
                "0.1",
                "--qpos",
                "0.5",
                "--keyframe",
                "start",
                "--out",
                &o,
            ],
        ),
        (
            "missing control file",
            vec![&s, "--duration", "0.1", "--ctrl", &missing, "--out", &o],
        ),
        (
            "control file with wrong columns",
            vec![&s, "--duration", "0.1", "--ctrl", &bad_ctrl, "--out", &o],
        ),
        (
            "unwritable output",
            vec![
                &s,
                "--duration",
                "0.01",
                "--out",
                "/nonexistent/dir/out.csv",
            ],
        ),
        (
            "unwritable page",
            vec![
                &s,
                "--duration",
                "0.01",
                "--html",
                "/nonexistent/dir/out.html",
            ],
        ),
        (
            "html without a file",
            vec![&s, "--duration", "0.01", "--html"],
        ),
        (
            "summary without a file",
            vec![&s, "--duration", "0.01", "--out", &o, "--summary"],
        ),
        (
            "unwritable summary",
            vec![
                &s,
                "--duration",
                "0.01",
                "--summary",
                "/nonexistent/dir/s.json",
                "--out",
                &o,
            ],
        ),
    ];
    for (name, args) in &cases {
        let _ = std::fs::remove_file(&out);
        assert_clean_failure(name, args, &out);
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A valid scene driven to blow up (an absurd initial spin at a huge step) stops with
/// the typed divergence error or runs finite; it never writes a non-finite number.
#[test]
fn a_diverging_run_never_writes_non_finite_numbers() {
    let d = dir().join("diverge");
    std::fs::create_dir_all(&d).expect("dir");
    let path = d.join("spin.xml");
    let text = pendulum("0 1 0", "1", "1e-4 1e-4 1e-4").replace(
        "</mujoco>",
        "<keyframe><key name=\"start\" qpos=\"1\" qvel=\"1e200\"/></keyframe></mujoco>",
    );
    std::fs::write(&path, text).expect("write");
    let out = d.join("out.csv");
    let (p, o) = (
        path.to_string_lossy().to_string(),
        out.to_string_lossy().to_string(),
    );
    for method in ["rattle", "velocity"] {
        let _ = std::fs::remove_file(&out);
        let args = [
            p.as_str(),
            "--keyframe",
            "start",
            "--dt",
            "0.1",
            "--duration",
            "10",
            "--method",
            method,
            "--out",
            o.as_str(),
        ];
        let (ok, err, _) = simulate(&args);
        assert!(!err.contains("panicked"), "{method}: {err}");
        if ok {
            let csv = std::fs::read_to_string(&out).expect("output written");
            for tok in csv.lines().skip(1).flat_map(|l| l.split(',')) {
                let v: f64 = tok.trim().parse().expect("number");
                assert!(v.is_finite(), "{method}: non-finite output");
            }
            eprintln!("{method}: ran finite");
        } else {
            assert_clean_failure(method, &args, &out);
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// `--summary FILE.json`: the run's figures as one flat JSON object; on a pendulum (no
/// contact, no actuator, no damping) from 0.5 rad: every step counted, finite, joints
/// at the projection tolerance, energy never above its start.
#[test]
fn the_summary_reports_the_runs_figures() {
    let d = dir().join("summary");
    std::fs::create_dir_all(&d).expect("dir");
    let path = d.join("p.xml");
    std::fs::write(&path, pendulum("0 1 0", "1", "0.01 0.01 0.01")).expect("write");
    let (out, sum) = (d.join("out.csv"), d.join("s.json"));
    let (p, o, j) = (
        path.to_string_lossy().to_string(),
        out.to_string_lossy().to_string(),
        sum.to_string_lossy().to_string(),
    );
    let args = [
        p.as_str(),
        "--qpos",
        "0.5",
        "--dt",
        "0.01",
        "--duration",
        "1",
        "--every",
        "100",
        "--summary",
        j.as_str(),
        "--out",
        o.as_str(),
    ];
    let (ok, err, _) = simulate(&args);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(&sum).expect("summary written");
    let field = |k: &str| -> String {
        let at = text
            .find(&format!("\"{k}\":"))
            .unwrap_or_else(|| panic!("{k} in {text}"));
        text[at + k.len() + 3..]
            .split([',', '}'])
            .next()
            .unwrap_or("")
            .to_string()
    };
    assert!(
        text.trim().starts_with('{') && text.trim().ends_with('}'),
        "{text}"
    );
    assert_eq!(field("steps"), "100");
    assert_eq!(field("finite"), "true");
    assert_eq!(field("max_contacts"), "0");
    assert_eq!(field("first_contact_time"), "null", "no contact");
    // The bob's body origin sits on the hinge at the world origin, to the joint
    // tolerance (measured -4.8e-13 m).
    let num = |k: &str| {
        field(k)
            .parse::<f64>()
            .unwrap_or_else(|_| panic!("{k}: {text}"))
    };
    // RATTLE's SHAKE stops at 1e-12 m; measured 9.99e-13 m.
    assert!(num("max_joint_separation") <= 1e-11, "{text}");
    // Symplectic: the energy error oscillates, bounded; measured rise 0.0 J (the
    // energy ends 1.3e-6 J below its start of -8.609 J).
    assert!(num("max_energy_increase") <= 1e-4, "{text}");
    assert!(num("us_per_step") > 0.0, "{text}");
    assert!(num("root_height").abs() <= 1e-11, "{text}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A `--method` the run does not know is clap's usage error, on one line, naming every
/// accepted value, before the scene file is read (this one does not exist); every name
/// of the run's lists is accepted.
#[test]
fn an_unknown_method_is_a_usage_error_naming_the_methods() {
    let d = dir().join("method");
    std::fs::create_dir_all(&d).expect("dir");
    let out = d.join("out.csv").to_string_lossy().to_string();
    let missing = d.join("missing.xml").to_string_lossy().to_string();
    let args = [
        &missing,
        "--duration",
        "1",
        "--method",
        "magic",
        "--out",
        &out,
    ];
    let (ok, err, _) = simulate(&args);
    assert!(!ok, "{err}");
    let line = one_line("unknown method", "simulate: ", &err)[0];
    assert!(
        line.contains("invalid value 'magic' for '--method <M>'")
            && line.contains("[possible values: velocity, projected, shake, baumgarte,")
            && line.contains("free-contact, soft-step]"),
        "{line}"
    );
    for (m, _) in constraint_scene::run::METHODS
        .iter()
        .chain(&constraint_scene::run::FREE_BODY_METHODS)
    {
        let args = [&missing, "--duration", "1", "--method", m, "--out", &out];
        let (ok, err, _) = simulate(&args);
        assert!(!ok && err.contains("missing.xml"), "{m}: {err}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// `--help` (and `-h`) of `simulate`: exit 0, every option listed with its default (or
/// marked required), and every `--method` name (with its description for `--help`).
#[test]
fn simulate_help_lists_every_option_and_its_default() {
    for flag in ["--help", "-h"] {
        let (code, out, err, _) = run_bin(env!("CARGO_BIN_EXE_simulate"), &[flag]);
        assert_eq!(code, Some(0), "{flag}: {err}");
        for opt in [
            "--keyframe",
            "--qpos",
            "--qvel",
            "--ctrl",
            "--dt",
            "--duration",
            "--every",
            "--method",
            "--out",
            "--html",
            "--summary",
        ] {
            // The option's own paragraph: its line and the indented lines up to the next
            // option or heading (with --help, blank lines and the `- value:` lines of a
            // list of possible values are inside it: the default comes after the list).
            let lines: Vec<&str> = out.lines().collect();
            let at = lines
                .iter()
                .position(|l| l.trim_start().starts_with(&format!("{opt} ")))
                .unwrap_or_else(|| panic!("{flag}: {opt} not listed:\n{out}"));
            let rest = lines[at + 1..].iter().take_while(|l| {
                let t = l.trim_start();
                (l.starts_with("  ") || (flag == "--help" && t.is_empty()))
                    && (!t.starts_with('-') || t.starts_with("- "))
            });
            let para = std::iter::once(&lines[at])
                .chain(rest)
                .copied()
                .collect::<Vec<_>>()
                .join(" ");
            assert!(
                para.contains("default") || para.contains("required"),
                "{flag}: {opt} has no default: {para:?}"
            );
        }
        assert!(out.contains("[default: 1]") && out.contains("[default: rattle]"));
        // clap's list of `--method`'s values: names only with -h, each with its
        // description with --help.
        let methods = constraint_scene::run::METHODS
            .iter()
            .chain(&constraint_scene::run::FREE_BODY_METHODS);
        if flag == "-h" {
            let names: Vec<&str> = methods.map(|m| m.0).collect();
            let list = format!("[possible values: {}]", names.join(", "));
            assert!(out.contains(&list), "{flag}: {list} not in\n{out}");
        } else {
            for (m, about) in methods {
                let line = format!("- {m}:");
                let at = out
                    .lines()
                    .find(|l| l.trim_start().starts_with(&line))
                    .unwrap_or_else(|| panic!("{flag}: method {m} not listed:\n{out}"));
                assert!(at.ends_with(about), "{flag}: {at:?} lacks {about:?}");
            }
        }
    }
}

/// One-body trajectory text: the body at x = t·v, rotated by `angle` about z.
fn traj(times: &[f64], v: f64, angle: f64) -> String {
    let mut s = String::from("t");
    for c in ["x", "y", "z", "qw", "qx", "qy", "qz", "cx", "cy", "cz"] {
        s += &format!(",b.{c}");
    }
    s += ",E_tot\n";
    for &t in times {
        let (c, sn) = ((angle / 2.0).cos(), (angle / 2.0).sin());
        s += &format!("{t:?},{:?},0,0,{c:?},0,0,{sn:?},{:?},0,0,1\n", t * v, t * v);
    }
    s
}

/// `compare A.csv B.csv`: the report on stdout, `--tolerance` decides the exit status
/// (0 within, 2 beyond), `--format keys` prints `key value` lines, and bad arguments or
/// files fail with one line and status 1.
#[test]
fn compare_reports_checks_tolerances_and_fails_with_one_line() {
    let exe = env!("CARGO_BIN_EXE_compare");
    let d = dir().join("compare");
    std::fs::create_dir_all(&d).expect("dir");
    let path = |n: &str| d.join(n).to_string_lossy().to_string();
    let (a, b, bad) = (path("a.csv"), path("b.csv"), path("bad.csv"));
    // B drifts 1e-3 m/s faster and is turned 0.01 rad: COM error 1e-3 m at t = 1 s.
    std::fs::write(&a, traj(&[0.0, 0.5, 1.0], 1.0, 0.0)).expect("write");
    std::fs::write(&b, traj(&[0.0, 0.5, 1.0], 1.001, 0.01)).expect("write");
    std::fs::write(&bad, "t,b.x\n0,nan\n").expect("write");

    let (code, out, err, _) = run_bin(exe, &[&a, &b]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("compared 3 samples"), "{out}");
    assert!(
        out.contains("max COM position error   1.000000e-3 m   at t = 1 s, body b"),
        "{out}"
    );
    assert!(out.contains("max |Δ E_tot|"), "{out}");

    let (code, out, _, _) = run_bin(exe, &[&a, &b, "--format", "keys"]);
    assert_eq!(code, Some(0));
    let key = |k: &str| -> f64 {
        out.lines()
            .find_map(|l| l.strip_prefix(&format!("{k} ")))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{k} in {out}"))
    };
    assert_eq!(key("samples"), 3.0);
    // Measured: COM 1.0000000000000009e-3 m, orientation 0.01 rad (to 1e-17).
    assert!((key("com") - 1e-3).abs() < 1e-15, "{out}");
    assert!((key("orientation") - 0.01).abs() < 1e-15, "{out}");
    assert_eq!(key("worst"), key("orientation"));

    // The worst error is the 0.01 rad turn.
    let (code, _, err, _) = run_bin(exe, &[&a, &b, "--tolerance", "0.02"]);
    assert_eq!(code, Some(0), "{err}");
    let (code, _, err, _) = run_bin(exe, &[&a, &b, "--tolerance", "0.005"]);
    assert_eq!(code, Some(2), "{err}");
    one_line("beyond tolerance", "compare: ", &err);
    assert!(err.contains("exceeds the tolerance"), "{err}");
    // A sample without a match fails a tolerance however small the errors.
    let c = path("c.csv");
    std::fs::write(&c, traj(&[0.0, 0.25, 0.5, 1.0], 1.0, 0.0)).expect("write");
    let (code, _, err, _) = run_bin(exe, &[&a, &c, "--tolerance", "1"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        one_line("unmatched", "compare: ", &err)[0].contains("only 3 samples"),
        "{err}"
    );

    let missing = path("missing.csv");
    let cases: Vec<(&str, Vec<&str>)> = vec![
        ("no arguments", vec![]),
        ("one file", vec![&a]),
        ("three files", vec![&a, &b, &b]),
        ("unknown option", vec![&a, &b, "--frobnicate"]),
        ("tolerance not a number", vec![&a, &b, "--tolerance", "x"]),
        ("unknown format", vec![&a, &b, "--format", "xml"]),
        ("missing file", vec![&a, &missing]),
        ("non-finite number", vec![&a, &bad]),
    ];
    for (name, args) in cases {
        let (code, out, err, _) = run_bin(exe, &args);
        assert_eq!(code, Some(1), "{name}: {err}");
        assert!(out.is_empty(), "{name}: stdout {out:?}");
        let l = one_line(name, "compare: ", &err);
        eprintln!("{name}: {}", l[0]);
    }

    let (code, out, _, _) = run_bin(exe, &["--help"]);
    assert_eq!(code, Some(0));
    for opt in [
        "--tolerance",
        "--format",
        "A.csv",
        "B.csv",
        "[default: table]",
    ] {
        assert!(out.contains(opt), "{opt} not in help:\n{out}");
    }
    let _ = std::fs::remove_dir_all(&d);
}
