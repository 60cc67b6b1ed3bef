//! `cargo xtask no-std`: build `constraint-core` without `std` for an embedded target.
//!
//! Installs the target with rustup when it is missing; when it cannot be installed
//! (no rustup, no network), falls back to a host build with `--no-default-features`
//! and says so.

use crate::run::{cargo, output, status};
use std::process::Command;

/// The embedded target: Cortex-M4F/M7F, no OS, no allocator.
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// What the check built.
pub enum Outcome {
    /// Built for the embedded target.
    Embedded,
    /// Target unavailable; built on the host without default features.
    HostFallback,
}

fn target_installed() -> bool {
    let (ok, out) = output(Command::new("rustup").args(["target", "list", "--installed"]));
    ok && out.lines().any(|l| l.trim() == TARGET)
}

/// Runs the check; `Err` when the build fails.
pub fn main(_args: &[String]) -> Result<Outcome, String> {
    if !target_installed() {
        eprintln!("  rustup target add {TARGET}");
        let _ = status(Command::new("rustup").args(["target", "add", TARGET]));
    }
    if target_installed() {
        let (ok, _) = status(cargo().args([
            "build",
            "-p",
            "constraint-core",
            "--no-default-features",
            "--target",
            TARGET,
        ]));
        return if ok {
            eprintln!("  constraint-core builds without std for {TARGET}");
            Ok(Outcome::Embedded)
        } else {
            Err(format!("constraint-core failed to build for {TARGET}"))
        };
    }
    eprintln!("  target {TARGET} unavailable: falling back to a host build without std features");
    let (ok, _) = status(cargo().args(["build", "-p", "constraint-core", "--no-default-features"]));
    if ok {
        Ok(Outcome::HostFallback)
    } else {
        Err("constraint-core failed to build with --no-default-features".into())
    }
}
