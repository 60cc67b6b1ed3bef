//! The builds `cargo xtask verify` runs from, and the test runs.
//!
//! One release build makes the two tools the later stages run, `verify-report` and
//! `simulate` (one feature resolution for both). By default (a newcomer's first command)
//! the same build makes two test executables of `constraint-verify`, the state-hash pins
//! and the bad-input sweep, so the report keeps their counts without building the test
//! suite twice over; the suite itself is the README's second command. With `--ci` the
//! test suite is built in the dev profile instead, the same artifacts as the README's
//! `cargo test --workspace`, so CI, having run the tests first, compiles nothing again.
//! Later stages run those executables directly: a `cargo run -p …` per tool would resolve
//! features for that package alone and could compile the libraries a second time.

use crate::run::{cargo, output};
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Instant;

/// The executables of the builds that later stages run.
pub struct Built {
    /// The report generator (`constraint-report`'s `verify-report`, release).
    pub verify_report: PathBuf,
    /// The scene runner (`constraint-scene`'s `simulate`, release), for the real models.
    pub simulate: PathBuf,
    /// `verify/tests/bad_input_sweep.rs` (release by default, dev with `--ci`), run again
    /// alone for its summary line.
    pub bad_input_sweep: PathBuf,
    /// The package directory of the verify tests (tests run from their package root).
    pub verify_dir: PathBuf,
    /// `verify/tests/state_hashes.rs` in release, when the test suite is not built.
    pub pins: Option<PathBuf>,
    /// Test executables (unit and integration) of the dev build, for the progress count
    /// of the test run; 0 when the test suite is not built.
    pub tests: usize,
}

/// The release build of the two tools, as cargo arguments.
const TOOLS: [&str; 10] = [
    "build",
    "--release",
    "-p",
    "constraint-report",
    "-p",
    "constraint-scene",
    "--bin",
    "verify-report",
    "--bin",
    "simulate",
];

/// Added to [`TOOLS`] when the test suite is not built: the pins' and the bad-input
/// sweep's test executables, in the same release build.
const RELEASE_TESTS: [&str; 6] = [
    "-p",
    "constraint-verify",
    "--test",
    "state_hashes",
    "--test",
    "bad_input_sweep",
];

/// With `suite`, `cargo test --workspace --no-run` (dev); then the release build of
/// `verify-report` and `simulate` (and without `suite`, of the pins' and the bad-input
/// sweep's tests), each with cargo's own progress; then again with
/// `--message-format=json` (nothing left to build: they only list the executables).
pub fn build(suite: bool) -> Result<Built, String> {
    let t0 = Instant::now();
    if suite {
        eprintln!("  the test suite (dev profile, as `cargo test --workspace`)");
        let ok = cargo()
            .args(["test", "--workspace", "--no-run"])
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            return Err("cargo test --workspace --no-run failed".into());
        }
    }
    let t1 = Instant::now();
    let release = |c: &mut Command| {
        c.args(TOOLS);
        if !suite {
            c.args(RELEASE_TESTS);
        }
    };
    if suite {
        eprintln!("  verify-report and simulate (release)");
    } else {
        eprintln!("  verify-report, simulate, state_hashes and bad_input_sweep (release)");
    }
    let mut c = cargo();
    release(&mut c);
    if !c.status().is_ok_and(|s| s.success()) {
        return Err("cargo build --release (the tools) failed".into());
    }
    let t2 = Instant::now();
    let json = |c: &mut Command| {
        let (ok, text) = output(c.args(["--quiet", "--message-format=json"]));
        if ok {
            Ok(text.lines().filter_map(Artifact::parse).collect::<Vec<_>>())
        } else {
            Err("listing the built executables (--message-format=json) failed".to_string())
        }
    };
    let tests = if suite {
        json(cargo().args(["test", "--workspace", "--no-run"]))?
    } else {
        Vec::new()
    };
    let mut c = cargo();
    release(&mut c);
    let tools = json(&mut c)?;
    let find = |list: &[Artifact], name: &str, test: bool| -> Result<(PathBuf, PathBuf), String> {
        list.iter()
            .find(|a| a.name == name && a.test == test)
            .map(|a| (a.executable.clone(), a.package_dir.clone()))
            .ok_or_else(|| format!("the build has no executable `{name}`"))
    };
    let (bad_input_sweep, verify_dir) =
        find(if suite { &tests } else { &tools }, "bad_input_sweep", true)?;
    let built = Built {
        verify_report: find(&tools, "verify-report", false)?.0,
        simulate: find(&tools, "simulate", false)?.0,
        bad_input_sweep,
        verify_dir,
        pins: if suite {
            None
        } else {
            Some(find(&tools, "state_hashes", true)?.0)
        },
        tests: tests.iter().filter(|a| a.test).count(),
    };
    if suite {
        eprintln!(
            "  built {} test executables in {:.0} s, the tools in {:.0} s",
            built.tests,
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64()
        );
    } else {
        eprintln!("  built in {:.0} s", (t2 - t1).as_secs_f64());
    }
    Ok(built)
}

/// The state-hash pins' release executable, when built: returns success and the test
/// harness's result line (`test result: ok. 7 passed; …`), its output passed through.
pub fn run_pins(built: &Built) -> (bool, String) {
    let Some(exe) = &built.pins else {
        return (false, "not built".to_string());
    };
    let (ok, text) = output(Command::new(exe).current_dir(&built.verify_dir));
    eprint!("{text}");
    let line = text
        .lines()
        .find(|l| l.starts_with("test result:"))
        .map_or_else(
            || "no result line".to_string(),
            |l| {
                // `ok. 7 passed; 0 failed; 0 ignored; …`: the two counts that matter.
                let counts: Vec<&str> = l
                    .split(['.', ';'])
                    .map(str::trim)
                    .filter(|p| p.ends_with(" passed") || p.ends_with(" failed"))
                    .collect();
                format!("{} (release build)", counts.join(", "))
            },
        );
    (ok, line)
}

/// `cargo test --workspace --no-fail-fast` (plus `env`), its output passed
/// through with each test executable and doc-test crate announced as
/// `[k/N, 12 s] …`, so a long run shows where it is. Returns success.
pub fn run_tests(built: &Built, env: &[(&str, &str)]) -> bool {
    let mut c = cargo();
    c.args(["test", "--workspace", "--no-fail-fast"]);
    for (k, v) in env {
        c.env(k, v);
    }
    c.stderr(Stdio::piped());
    let t0 = Instant::now();
    let Ok(mut child) = c.spawn() else {
        return false;
    };
    let (mut k, mut docs) = (0, 0);
    if let Some(err) = child.stderr.take() {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            let t = line.trim_start();
            if let Some(what) = t.strip_prefix("Running ") {
                k += 1;
                // `unittests src/lib.rs (target/debug/deps/x-hash)`: the name is the
                // executable's file name without its hash.
                let exe = what
                    .rsplit_once('(')
                    .map_or(what, |(_, p)| p.trim_end_matches(')'));
                let file = exe.rsplit('/').next().unwrap_or(exe);
                let stem = file.rsplit_once('-').map_or(file, |(s, _)| s);
                let src = what.split(" (").next().unwrap_or(what);
                eprintln!(
                    "[tests {k}/{}, {:.0} s] {stem}: {src}",
                    built.tests,
                    t0.elapsed().as_secs_f64()
                );
            } else if let Some(krate) = t.strip_prefix("Doc-tests ") {
                docs += 1;
                eprintln!(
                    "[doc-tests {docs}, {:.0} s] {krate}",
                    t0.elapsed().as_secs_f64()
                );
            } else {
                eprintln!("{line}");
            }
        }
    }
    child.wait().is_ok_and(|s| s.success())
}

/// The bad-input sweep's executable with `--nocapture`, from its package directory
/// (release by default, dev with `--ci`);
/// returns success and stdout.
pub fn run_bad_input_sweep(built: &Built) -> (bool, String) {
    output(
        Command::new(&built.bad_input_sweep)
            .current_dir(&built.verify_dir)
            .arg("--nocapture"),
    )
}

/// One `compiler-artifact` message of `cargo --message-format=json` that made an
/// executable.
struct Artifact {
    name: String,
    test: bool,
    executable: PathBuf,
    package_dir: PathBuf,
}

/// The fields read of one line of `cargo --message-format=json` (every message kind:
/// the fields a kind lacks are `None`).
#[derive(serde::Deserialize)]
struct Message {
    reason: String,
    target: Option<Target>,
    profile: Option<Profile>,
    executable: Option<PathBuf>,
    manifest_path: Option<PathBuf>,
}

/// The target of a `compiler-artifact` message.
#[derive(serde::Deserialize)]
struct Target {
    name: String,
}

/// The profile of a `compiler-artifact` message.
#[derive(serde::Deserialize)]
struct Profile {
    /// Built as a test harness (the target has a `test` key of its own, which is true
    /// for binaries too).
    test: bool,
}

impl Artifact {
    /// An artifact from one line of cargo's JSON messages: `None` for a line that is not
    /// a `compiler-artifact` message of an executable, or that does not parse.
    fn parse(line: &str) -> Option<Self> {
        let m: Message = serde_json::from_str(line).ok()?;
        if m.reason != "compiler-artifact" {
            return None;
        }
        Some(Self {
            name: m.target?.name,
            test: m.profile?.test,
            executable: m.executable?,
            package_dir: m.manifest_path?.parent()?.to_path_buf(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Artifact;

    #[test]
    fn reads_an_artifact_line() {
        let line = r#"{"reason":"compiler-artifact","package_id":"path+file:///w/verify#constraint-verify@0.1.0","manifest_path":"/w/verify/Cargo.toml","target":{"kind":["test"],"crate_types":["bin"],"name":"bad_input_sweep","src_path":"/w/verify/tests/bad_input_sweep.rs","edition":"2021","doc":false,"doctest":false,"test":true},"profile":{"opt_level":"3","debuginfo":0,"debug_assertions":false,"overflow_checks":false,"test":true},"features":[],"filenames":["/w/target/release/deps/bad_input_sweep-1"],"executable":"/w/target/release/deps/bad_input_sweep-1","fresh":true}"#;
        let a = Artifact::parse(line).expect("parses");
        assert_eq!(a.name, "bad_input_sweep");
        assert!(a.test);
        assert_eq!(
            a.executable.to_str(),
            Some("/w/target/release/deps/bad_input_sweep-1")
        );
        assert_eq!(a.package_dir.to_str(), Some("/w/verify"));
        // A binary: its target says `"test":true` too, its profile does not.
        let bin = line
            .replace(
                "\"overflow_checks\":false,\"test\":true",
                "\"overflow_checks\":false,\"test\":false",
            )
            .replace("bad_input_sweep", "simulate");
        assert!(!Artifact::parse(&bin).expect("parses").test);
        assert!(Artifact::parse(r#"{"reason":"build-finished","success":true}"#).is_none());
        // A library: no executable.
        let lib = line.replace(
            r#""executable":"/w/target/release/deps/bad_input_sweep-1""#,
            r#""executable":null"#,
        );
        assert!(Artifact::parse(&lib).is_none());
        assert!(Artifact::parse("warning: not JSON").is_none());
    }
}
