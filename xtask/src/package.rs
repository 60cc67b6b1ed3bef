//! `cargo xtask package [--no-verify]`: the library crates as they would be published.
//!
//! Two checks, for each crate of [`CRATES`]:
//! 1. the file list (`cargo package --list`) holds the crate's `README.md`, and no
//!    packaged Rust file reaches outside the crate through `CARGO_MANIFEST_DIR` and a
//!    `"../` path (a test reading the workspace's `scenes/` would fail from the
//!    published crate; such a file belongs in the crate's `exclude` list);
//! 2. `cargo package --allow-dirty` of all of them in one run: cargo packs each crate,
//!    resolves its unpublished siblings through a local registry overlay and (unless
//!    `--no-verify`) builds every packed crate from its `.crate` file alone.
//!
//! The `.crate` files land in `target/package/`. Resolving the third-party
//! dependencies needs the crates.io index (network, or cargo's cache with
//! `CARGO_NET_OFFLINE=true`).

use crate::run::{cargo, output, root, status};

/// The library crates, in dependency order (the tools `constraint-verify`,
/// `constraint-peers` and `xtask` are `publish = false`).
pub const CRATES: [(&str, &str); 6] = [
    ("constraint-core", "constraint-core"),
    ("constraint-soft", "soft"),
    ("constraint-contact", "contact"),
    ("constraint-lagrange", "lagrange"),
    ("constraint-mjcf", "mjcf"),
    ("constraint-articulated", "articulated"),
];

/// Problems in one crate's packaged file list (empty when it is fine).
fn check_file_list(krate: &str, dir: &str) -> Result<Vec<String>, String> {
    let (ok, list) = output(cargo().args(["package", "--list", "--allow-dirty", "-p", krate]));
    if !ok {
        return Err(format!("cargo package --list -p {krate} failed"));
    }
    let mut problems = Vec::new();
    let files: Vec<&str> = list.lines().map(str::trim).collect();
    if !files.contains(&"README.md") {
        problems.push(format!("{krate}: README.md is not packaged"));
    }
    for f in files.iter().filter(|f| f.ends_with(".rs")) {
        // Generated entries (Cargo.toml, .cargo_vcs_info.json) are not .rs files, so
        // every listed .rs file is on disk under the crate directory.
        let path = root().join(dir).join(f);
        let text = std::fs::read_to_string(&path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        if text.contains("CARGO_MANIFEST_DIR") && text.contains("\"../") {
            problems.push(format!(
                "{krate}: {f} reads a path outside the crate (CARGO_MANIFEST_DIR and \"../); \
                 exclude it from the package or move the file it reads into the crate"
            ));
        }
    }
    Ok(problems)
}

/// Runs both checks; `Err` names what failed.
pub fn main(args: &[String]) -> Result<(), String> {
    let no_verify = args.iter().any(|a| a == "--no-verify");
    if let Some(a) = args.iter().find(|a| *a != "--no-verify") {
        return Err(format!("unknown argument {a:?} (expected --no-verify)"));
    }
    let mut problems = Vec::new();
    for (krate, dir) in CRATES {
        problems.extend(check_file_list(krate, dir)?);
    }
    if !problems.is_empty() {
        return Err(format!("packaged files:\n  {}", problems.join("\n  ")));
    }
    eprintln!("  file lists: {} crates, READMEs packaged, nothing read from outside", CRATES.len());
    let mut cmd = cargo();
    cmd.args(["package", "--allow-dirty"]);
    for (krate, _) in CRATES {
        cmd.args(["-p", krate]);
    }
    if no_verify {
        cmd.arg("--no-verify");
    }
    let (ok, secs) = status(&mut cmd);
    if !ok {
        return Err("cargo package failed (see its output above)".into());
    }
    eprintln!(
        "  cargo package{}: {} crates in {secs:.0} s (target/package/)",
        if no_verify { " --no-verify" } else { " (each built from its .crate)" },
        CRATES.len()
    );
    Ok(())
}
