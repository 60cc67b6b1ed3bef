//! `cargo xtask simulate SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K]
//! [--method M] --out FILE.csv`: runs an MJCF scene with this library and writes the
//! trajectory file of DESIGN.md section 6.
//!
//! The work is done by the `simulate` binary of `constraint-scene` (built in release
//! mode on first use), so xtask itself keeps no physics dependency. Paths are taken
//! relative to the directory the command was run from. On any error the binary prints
//! one line and this command exits non-zero without adding another.

use std::process::Command;

use crate::run::root;

/// Runs the simulate binary with `args`, passing its exit status through.
pub fn main(args: &[String]) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["run", "--release", "--quiet", "--manifest-path"])
        .arg(root().join("Cargo.toml"))
        .args(["-p", "constraint-scene", "--bin", "simulate", "--"])
        .args(args)
        .status()
        .map_err(|e| format!("could not run cargo: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        // The binary already said why in one line.
        std::process::exit(status.code().unwrap_or(1));
    }
}
