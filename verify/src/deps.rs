//! What each scene family compiles and runs: the crates and features it declares, the
//! run-time stages active, and the compiled dependency tree from
//! `cargo tree -e normal -p <crate> --no-default-features --features <…>` (run here
//! through [`std::process::Command`]; skipped with a note when cargo cannot be run).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One scene family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Family {
    /// Family name (report label).
    pub name: &'static str,
    /// Scenes of the family in the report.
    pub scenes: &'static str,
    /// The crate the family's scenes are built with.
    pub krate: &'static str,
    /// The smallest feature set it needs (on top of `--no-default-features`).
    pub features: &'static [&'static str],
    /// Run-time stages active in a step.
    pub stages: &'static str,
}

/// The scene families of the report, in report order.
pub const FAMILIES: [Family; 6] = [
    Family {
        name: "soft, springs only (CG)",
        scenes: "a spring-only system (`soft/examples/spring_only.rs`)",
        krate: "constraint-soft",
        features: &[],
        stages: "soft: springs (distance constraints), implicit Euler, conjugate gradient",
    },
    Family {
        name: "soft cloth / jelly",
        scenes: "cloth (stability map, work-precision), jelly",
        krate: "constraint-soft",
        features: &["faer"],
        stages: "soft: springs, triangle area, tetrahedron volume, symplectic Euler or implicit Euler (projected / Gauss–Newton / exact Hessian), LDLᵀ (faer) or CG",
    },
    Family {
        name: "lagrange: chain, inextensible cloth",
        scenes: "particle-chain drift, inextensible cloth, hard one-ring jelly volume",
        krate: "constraint-lagrange",
        features: &["std", "sparse"],
        stages: "lagrange: KKT assembly, acceleration level + Baumgarte, velocity level, compliant rows, fast projection (Goldenthal), dense or sparse (faer) Schur complement; the soft implicit step for the cloth's shear springs",
    },
    Family {
        name: "articulated: MJCF scenes",
        scenes: "pendulum, double and spherical pendulum, four-bar loop, chain20, chain20_heavy, chain100",
        krate: "constraint-articulated",
        features: &["std", "mjcf"],
        stages: "articulated: MJCF load, tree factor (Baraff), loop Schur complement (four-bar), geometric stiffness (Auto), RATTLE / RATTLE4 SHAKE projection, velocity or acceleration level",
    },
    Family {
        name: "articulated: built-in chains",
        scenes: "ball chains of the stability map (`scenes::ball_chain`)",
        krate: "constraint-articulated",
        features: &["std"],
        stages: "articulated: tree factor, geometric stiffness (Auto), projection or RATTLE",
    },
    Family {
        name: "contact: rigid scenes",
        scenes: "sphere drop, sliding box, box stack, pyramid, LCPs",
        krate: "constraint-contact",
        features: &["std", "rigid"],
        stages: "contact: broad and narrow phase, Delassus LCP, Lemke / Fischer–Burmeister Newton / PGS with fallbacks, friction, sequential impulses; articulated bodies",
    },
];

/// The cargo to run: `$CARGO` (set when run by cargo), else `cargo` on the `PATH`.
pub fn cargo() -> PathBuf {
    std::env::var_os("CARGO").map_or_else(|| PathBuf::from("cargo"), PathBuf::from)
}

/// `cargo tree -e normal -p <krate> --no-default-features [--features …]` on the
/// workspace at `root` (offline and locked: the tree of `Cargo.lock`).
///
/// # Errors
/// Cargo could not be started, or failed (its stderr's last line).
pub fn cargo_tree(root: &Path, krate: &str, features: &[&str]) -> Result<String, String> {
    let mut c = Command::new(cargo());
    c.current_dir(root)
        .args(["tree", "-e", "normal", "-p", krate, "--no-default-features"])
        .args(["--offline", "--locked", "--color", "never"]);
    if !features.is_empty() {
        c.args(["--features", &features.join(",")]);
    }
    let out = c
        .output()
        .map_err(|e| format!("cargo not runnable ({}): {e}", cargo().display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(format!(
            "cargo tree failed: {}",
            err.lines().last().unwrap_or("").trim()
        ));
    }
    String::from_utf8(out.stdout).map_err(|e| e.to_string())
}

/// The distinct packages of a `cargo tree` listing (`name vX.Y.Z`), root first, then
/// sorted.
pub fn packages(tree: &str) -> Vec<String> {
    let mut v: Vec<String> = tree
        .lines()
        .filter_map(|l| {
            let t = l.trim_start_matches(|c: char| !c.is_alphanumeric());
            let mut w = t.split_whitespace();
            let name = w.next()?;
            let ver = w.next().filter(|v| v.starts_with('v'))?;
            Some(format!("{name} {ver}"))
        })
        .collect();
    let root = v.first().cloned();
    v.sort();
    v.dedup();
    if let Some(r) = root {
        v.retain(|p| *p != r);
        v.insert(0, r);
    }
    v
}

/// Whether the listing contains the package `name` (exact crate name).
pub fn has_package(tree: &str, name: &str) -> bool {
    packages(tree)
        .iter()
        .any(|p| p.split(' ').next() == Some(name))
}

/// Writes the section: per family, its crate, features, stages, the number of
/// compiled dependencies and the tree.
pub fn section(md: &mut String, root: &Path) {
    let _ = writeln!(md, "\n## What each scene compiles and runs\n");
    let _ = writeln!(
        md,
        "Per scene family: the crate and the smallest feature set it needs, the run-time \
         stages a step goes through, and the compiled (normal, non-dev) dependency tree from \
         `cargo tree -e normal -p <crate> --no-default-features --features <…> --offline --locked`. \
         The test `verify/tests/leave_out.rs` checks that the spring-only build links none of \
         `constraint-lagrange`, `constraint-articulated`, `constraint-contact` or `faer`.\n"
    );
    let _ = writeln!(
        md,
        "| scene family | scenes | crate | features | dependencies | run-time stages |\n|---|---|---|---|---|---|"
    );
    let mut trees = Vec::new();
    for f in FAMILIES {
        let feats = if f.features.is_empty() {
            "(none)".to_string()
        } else {
            f.features.join(", ")
        };
        let tree = cargo_tree(root, f.krate, f.features);
        let count = match &tree {
            Ok(t) => format!("{}", packages(t).len().saturating_sub(1)),
            Err(_) => "–".into(),
        };
        let _ = writeln!(
            md,
            "| {} | {} | `{}` | {feats} | {count} | {} |",
            f.name, f.scenes, f.krate, f.stages
        );
        trees.push((f, feats, tree));
    }
    let _ = writeln!(
        md,
        "\n(dependencies: distinct packages in the tree, the crate itself not counted.)\n"
    );
    for (f, feats, tree) in trees {
        let _ = writeln!(md, "### {} — `{}`, features: {feats}\n", f.name, f.krate);
        match tree {
            Ok(t) => {
                let _ = writeln!(md, "```text\n{}```\n", t);
            }
            Err(e) => {
                let _ = writeln!(md, "Dependency tree skipped: {e}.\n");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TREE: &str = "constraint-soft v0.1.0 (/w/soft)\n├── constraint-core v0.1.0 (/w/core)\n│   └── glam v0.34.3\n│       └── libm v0.2.16\n└── nalgebra v0.35.0\n    ├── approx v0.5.1\n    │   └── num-traits v0.2.19\n    └── num-traits v0.2.19 (*)\n";

    #[test]
    fn packages_are_distinct_with_the_root_first() {
        let p = packages(TREE);
        assert_eq!(p[0], "constraint-soft v0.1.0");
        assert_eq!(p.len(), 7);
        assert!(has_package(TREE, "libm"));
        assert!(!has_package(TREE, "faer"));
        assert!(!has_package(TREE, "constraint"));
    }
}
