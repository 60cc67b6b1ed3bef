//! `cargo xtask simulate SCENE.xml --duration T --out FILE.csv [options]`: runs an MJCF
//! scene with this library and writes the trajectory file of DESIGN.md section 6
//! (`cargo xtask simulate --help` lists every option with its default).
//!
//! The work is done by the `simulate` binary of `constraint-scene` (built in release
//! mode on first use), so xtask itself keeps no physics dependency. Paths are taken
//! relative to the directory the command was run from. On any error the binary prints
//! one line and this command exits non-zero without adding another.

use crate::compare::scene_bin;
use std::ffi::OsString;

/// Runs the simulate binary with `args`, passing its exit status through.
pub fn main(args: &[OsString]) -> Result<(), String> {
    let status = scene_bin("simulate")
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
