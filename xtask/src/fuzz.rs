//! `cargo xtask fuzz [--seconds N] [TARGET...]`: runs every cargo-fuzz target of `fuzz/`
//! (`mjcf_load`, `lcp_solvers`, `kkt_solvers`, `world_step`, `one_world`, `particle_step`)
//! for `N` seconds each (default 60), installing `cargo-fuzz` first when it is missing.
//! `one_world` covers the one rigid world's newer entry points: compound joints, limits,
//! dry friction, armature, springs, tendons, actuators, controls, fluid and colliders on
//! jointed bodies.
//! `particle_step` covers the particle crates: soft systems under every integrator, the
//! lagrange formulations with hard/compliant sets, and the deformable contact step.
//!
//! Toolchain: `cargo +nightly fuzz run` when a nightly toolchain is installed (libFuzzer
//! with AddressSanitizer, cargo-fuzz's default); otherwise the stable toolchain with
//! `RUSTC_BOOTSTRAP=1` and `--sanitizer none` (libFuzzer still needs `-Z` flags; no
//! sanitizer: Rust is memory-safe here, the targets look for panics and non-finite
//! output). The mode used is printed. `fuzz/` is outside the workspace, so nothing here
//! is built by `cargo test --workspace` or CI.
//!
//! Prints executions per target (libFuzzer's `#N DONE` line) and any crash artifact;
//! exits non-zero when a target crashed. A crash becomes a named regression test (see
//! `verify/tests/bad_input_regressions.rs`).

use crate::run::root;
use std::process::{Command, Stdio};

const TARGETS: [&str; 6] = [
    "mjcf_load",
    "lcp_solvers",
    "kkt_solvers",
    "world_step",
    "one_world",
    "particle_step",
];

fn has(cmd: &mut Command) -> bool {
    cmd.stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}

/// Executions from libFuzzer's last `#N` status line.
fn executions(log: &str) -> Option<u64> {
    log.lines()
        .rev()
        .filter_map(|l| l.strip_prefix('#'))
        .find_map(|l| l.split_whitespace().next()?.parse().ok())
}

/// The options of `cargo xtask fuzz`.
#[derive(clap::Args, Clone, Debug, PartialEq, Eq)]
pub struct Options {
    /// Seconds of fuzzing per target.
    #[arg(long, value_name = "N", default_value_t = 60)]
    pub seconds: u64,
    /// The targets to run, in this order [default: all six, in the order listed].
    #[arg(value_name = "TARGET", value_parser = clap::builder::PossibleValuesParser::new(TARGETS))]
    pub targets: Vec<String>,
}

/// Runs each target of `o` for its seconds; `Err` names the targets that crashed.
pub fn main(o: &Options) -> Result<(), String> {
    let seconds = o.seconds;
    let targets: Vec<String> = if o.targets.is_empty() {
        TARGETS.iter().map(|s| s.to_string()).collect()
    } else {
        o.targets.clone()
    };
    let fuzz_dir = root().join("fuzz");

    if !has(Command::new("cargo").args(["fuzz", "--version"])) {
        eprintln!("xtask fuzz: cargo-fuzz missing; cargo install cargo-fuzz");
        let ok = Command::new("cargo")
            .args(["install", "cargo-fuzz"])
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if !ok {
            return Err("cargo install cargo-fuzz failed".into());
        }
    }
    let nightly = has(Command::new("cargo").args(["+nightly", "--version"]));
    let mode = if nightly {
        "nightly toolchain (cargo +nightly fuzz run, AddressSanitizer)"
    } else {
        "stable toolchain with RUSTC_BOOTSTRAP=1 and --sanitizer none (no nightly installed)"
    };
    eprintln!("xtask fuzz: mode: {mode}; {seconds} s per target");

    let mut lines = Vec::new();
    let mut crashed = Vec::new();
    for t in &targets {
        std::fs::create_dir_all(fuzz_dir.join("corpus").join(t)).map_err(|e| e.to_string())?;
        let mut cmd = Command::new("cargo");
        cmd.current_dir(&fuzz_dir);
        if nightly {
            cmd.arg("+nightly");
        } else {
            cmd.env("RUSTC_BOOTSTRAP", "1");
        }
        cmd.args(["fuzz", "run", "-O"]);
        if !nightly {
            cmd.args(["--sanitizer", "none"]);
        }
        cmd.arg(t)
            .arg("--")
            .arg(format!("-max_total_time={seconds}"));
        cmd.arg("-rss_limit_mb=2048");
        eprintln!("xtask fuzz: {t} ...");
        let out = cmd.output().map_err(|e| format!("{t}: {e}"))?;
        let log = String::from_utf8_lossy(&out.stderr).into_owned()
            + &String::from_utf8_lossy(&out.stdout);
        let execs = executions(&log).map_or("?".to_string(), |n| n.to_string());
        let artifact = log
            .lines()
            .find(|l| l.contains("Test unit written to"))
            .map(|l| l.trim().to_string());
        let line = match (&artifact, out.status.success()) {
            (None, true) => format!("{t}: {execs} executions in {seconds} s, no crash"),
            (Some(a), _) => format!("{t}: {execs} executions, CRASH ({a})"),
            (None, false) => {
                let tail: Vec<&str> = log.lines().rev().take(15).collect();
                let tail: Vec<&str> = tail.into_iter().rev().collect();
                format!("{t}: failed to run:\n{}", tail.join("\n"))
            }
        };
        if !out.status.success() {
            crashed.push(t.clone());
        }
        println!("{line}");
        lines.push(line);
    }
    println!("fuzz mode: {mode}");
    if crashed.is_empty() {
        Ok(())
    } else {
        Err(format!("fuzz targets failed: {}", crashed.join(", ")))
    }
}
