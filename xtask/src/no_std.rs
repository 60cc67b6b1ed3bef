//! `cargo xtask no-std`: build `constraint-core` (no `std`, no allocator) and
//! `constraint-lagrange` and `constraint-articulated` (no `std`, `alloc` only) for an
//! embedded target.
//!
//! Installs the target with rustup when it is missing; when it cannot be installed
//! (no rustup, no network), falls back to a host build with `--no-default-features`
//! and says so.

use crate::run::{cargo, output, status};
use std::process::Command;

/// The embedded target: Cortex-M4F/M7F, no OS, no allocator.
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// The crates that must build without `std`: the core (no allocator) and the
/// lagrange crate's dense path and the articulated crate (`alloc` only).
pub const CRATES: [&str; 3] = [
    "constraint-core",
    "constraint-lagrange",
    "constraint-articulated",
];

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
pub fn main() -> Result<Outcome, String> {
    if !target_installed() {
        eprintln!("  rustup target add {TARGET}");
        let _ = status(Command::new("rustup").args(["target", "add", TARGET]));
    }
    let embedded = target_installed();
    if !embedded {
        eprintln!(
            "  target {TARGET} unavailable: falling back to a host build without std features"
        );
    }
    for krate in CRATES {
        let mut cmd = cargo();
        cmd.args(["build", "-p", krate, "--no-default-features"]);
        if embedded {
            cmd.args(["--target", TARGET]);
        }
        let (ok, _) = status(&mut cmd);
        if !ok {
            return Err(format!("{krate} failed to build without std"));
        }
        eprintln!(
            "  {krate} builds without std{}",
            if embedded {
                format!(" for {TARGET}")
            } else {
                String::new()
            }
        );
    }
    Ok(if embedded {
        Outcome::Embedded
    } else {
        Outcome::HostFallback
    })
}
