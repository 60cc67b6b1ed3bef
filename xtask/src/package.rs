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
//! The `.crate` files land in `target/package/`. Both run offline first (the
//! third-party dependencies resolve from cargo's cached index, as pinned by
//! `Cargo.lock`: about 4 s for the six crates when nothing changed, against 18 s with
//! the index updated once per crate); only when that fails is the run repeated with
//! the network.

use crate::run::{cargo, output, root, status};

/// The library crates, in dependency order (the tools `constraint-scene`, `constraint-verify`, `constraint-report`,
/// `constraint-peers` and `xtask` are `publish = false`).
pub const CRATES: [(&str, &str); 6] = [
    ("constraint-core", "constraint-core"),
    ("constraint-soft", "soft"),
    ("constraint-contact", "contact"),
    ("constraint-lagrange", "lagrange"),
    ("constraint-mjcf", "mjcf"),
    ("constraint-articulated", "articulated"),
];

/// Whether a Rust file builds a path from the crate directory that climbs out of it:
/// it names `CARGO_MANIFEST_DIR` and holds a string literal starting with `../`
/// (`Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/x.xml")`, also inside
/// `format!`). A heuristic for this workspace's way of reading files, not a parser.
fn reads_outside(text: &str) -> bool {
    text.contains("CARGO_MANIFEST_DIR") && text.contains("\"../")
}

/// Problems in one crate's packaged file list (empty when it is fine).
fn check_file_list(krate: &str, dir: &str) -> Result<Vec<String>, String> {
    let args = ["package", "--list", "--allow-dirty", "-p", krate];
    let (mut ok, mut list) = output(cargo().env("CARGO_NET_OFFLINE", "true").args(args));
    if !ok {
        (ok, list) = output(cargo().args(args));
    }
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
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        if reads_outside(&text) {
            problems.push(format!(
                "{krate}: {f} reads a path outside the crate (CARGO_MANIFEST_DIR and \"../); \
                 exclude it from the package or move the file it reads into the crate"
            ));
        }
    }
    Ok(problems)
}

/// The options of `cargo xtask package`.
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// Pack without building each crate from its .crate (about 2 s instead of minutes)
    /// [default: off, every packed crate is built].
    #[arg(long)]
    pub no_verify: bool,
}

/// Runs both checks; `Err` names what failed.
pub fn main(o: &Options) -> Result<(), String> {
    let no_verify = o.no_verify;
    let mut problems = Vec::new();
    for (krate, dir) in CRATES {
        problems.extend(check_file_list(krate, dir)?);
    }
    if !problems.is_empty() {
        return Err(format!("packaged files:\n  {}", problems.join("\n  ")));
    }
    eprintln!(
        "  file lists: {} crates, READMEs packaged, nothing read from outside",
        CRATES.len()
    );
    let package = || {
        let mut cmd = cargo();
        cmd.args(["package", "--allow-dirty"]);
        for (krate, _) in CRATES {
            cmd.args(["-p", krate]);
        }
        if no_verify {
            cmd.arg("--no-verify");
        }
        cmd
    };
    let (mut ok, mut secs) = status(package().env("CARGO_NET_OFFLINE", "true"));
    if !ok {
        eprintln!("  offline cargo package failed: again with the crates.io index");
        let (again, more) = status(&mut package());
        (ok, secs) = (again, secs + more);
    }
    if !ok {
        return Err("cargo package failed (see its output above)".into());
    }
    eprintln!(
        "  cargo package{}: {} crates in {secs:.0} s (target/package/)",
        if no_verify {
            " --no-verify"
        } else {
            " (each built from its .crate)"
        },
        CRATES.len()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::reads_outside;

    #[test]
    fn a_path_climbing_out_of_the_crate_is_caught() {
        let outside = r#"let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/a.xml");"#;
        let formatted =
            r#"Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.xml"))"#;
        let inside = r#"let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");"#;
        let no_root = r#"let s = "../not a path from the crate";"#;
        assert!(reads_outside(outside) && reads_outside(formatted));
        assert!(!reads_outside(inside) && !reads_outside(no_root));
    }
}
