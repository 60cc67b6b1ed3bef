//! Running cargo and friends from the workspace root.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

/// The workspace root (the parent of this crate's manifest directory).
pub fn root() -> PathBuf {
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    here.parent().map(PathBuf::from).unwrap_or(here)
}

/// The cargo that invoked us (so `cargo +toolchain xtask` stays on that toolchain).
pub fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    c
}

/// Runs `cmd`, inheriting stdout/stderr; returns success and the seconds it took.
pub fn status(cmd: &mut Command) -> (bool, f64) {
    let t0 = Instant::now();
    let ok = cmd.status().map(|s| s.success()).unwrap_or(false);
    (ok, t0.elapsed().as_secs_f64())
}

/// Runs `cmd` capturing its output; returns success and stdout.
pub fn output(cmd: &mut Command) -> (bool, String) {
    match cmd.output() {
        Ok(o) => (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
        ),
        Err(e) => (false, e.to_string()),
    }
}
