//! Leave out what a scene does not need (issue 6): the soft crate built with the
//! smallest feature set — springs and conjugate gradient, no LDLᵀ — compiles none of
//! the lagrange, articulated or contact crates, nor faer; and the spring-only example
//! (`soft/examples/spring_only.rs`) builds, links and runs in that configuration.
//!
//! Both shell out to cargo (`$CARGO`, offline and locked); where cargo cannot be run the
//! tests say so and pass.

use std::path::{Path, PathBuf};
use std::process::Command;

use constraint_report::deps::{cargo, cargo_tree, has_package, packages};

const FORBIDDEN: [&str; 4] = [
    "constraint-lagrange",
    "constraint-articulated",
    "constraint-contact",
    "faer",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn cargo_runs() -> bool {
    Command::new(cargo())
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn spring_only_soft_tree_has_none_of_the_heavy_crates() {
    if !cargo_runs() {
        eprintln!("cargo not runnable here: skipped");
        return;
    }
    let small = cargo_tree(&root(), "constraint-soft", &[]).expect("cargo tree");
    for name in FORBIDDEN {
        assert!(
            !has_package(&small, name),
            "{name} in the spring-only tree:\n{small}"
        );
    }
    assert!(has_package(&small, "constraint-core"));
    // Measured beside it: the LDLᵀ build, which does pull faer in.
    let full = cargo_tree(&root(), "constraint-soft", &["faer"]).expect("cargo tree");
    assert!(has_package(&full, "faer"));
    let (n_small, n_full) = (packages(&small).len() - 1, packages(&full).len() - 1);
    eprintln!(
        "constraint-soft dependencies: {n_small} without default features, {n_full} with faer"
    );
    assert!(n_small < n_full);
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from)
}

fn contains(hay: &[u8], needle: &str) -> bool {
    hay.windows(needle.len()).any(|w| w == needle.as_bytes())
}

#[test]
fn spring_only_example_builds_links_and_runs_without_them() {
    if !cargo_runs() {
        eprintln!("cargo not runnable here: skipped");
        return;
    }
    let target = target_dir();
    let out = Command::new(cargo())
        .current_dir(root())
        .args([
            "build",
            "-p",
            "constraint-soft",
            "--no-default-features",
            "--example",
            "spring_only",
            "--offline",
            "--locked",
            "--message-format",
            "short",
        ])
        .arg("--target-dir")
        .arg(&target)
        .output()
        .expect("cargo build");
    assert!(
        out.status.success(),
        "build failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let exe = target
        .join("debug/examples")
        .join(format!("spring_only{}", std::env::consts::EXE_SUFFIX));
    let bin = std::fs::read(&exe).unwrap_or_else(|e| panic!("{}: {e}", exe.display()));
    // Symbol and path strings of every crate whose code is linked in.
    assert!(contains(&bin, "constraint_soft"));
    for name in FORBIDDEN {
        let sym = name.replace('-', "_");
        assert!(!contains(&bin, &sym), "{sym} linked into {}", exe.display());
    }
    let run = Command::new(&exe).output().expect("run spring_only");
    assert!(run.status.success());
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(text.starts_with("bob at z = -1.00"), "{text}");
    eprintln!(
        "spring_only: {} bytes ({})",
        bin.len(),
        Path::new(&exe).display()
    );
}
