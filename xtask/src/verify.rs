//! `cargo xtask verify [--quick]`: everything CI checks, and the report.
//!
//! Stages, each timed and shown as it runs:
//! 1. `cargo fmt --all -- --check`
//! 2. `cargo clippy --workspace --all-targets -- -D warnings`
//! 3. `cargo doc --no-deps` of the library crates with `RUSTDOCFLAGS=-D warnings`, with
//!    default and with all features (broken intra-doc links, missing docs)
//! 4. `cargo test --workspace` (full mode: `PROPTEST_CASES=2048`)
//! 5. the `no_std` build of `constraint-core` (see `no_std.rs`)
//! 6. `cargo xtask package` (see `package.rs`): every library crate packed and, in full
//!    mode, built from its `.crate` alone (about 6 s once built; the first time in a
//!    target directory it builds the dependencies at the published crates' own profile,
//!    8 minutes on two loaded cores); `--quick` packs with `--no-verify` (about 2 s)
//! 7. the sweeps (`verify-report` binary, release build): cloth stability map and
//!    work-precision chart
//!
//! 8. the real models (`cargo xtask models run`, `--quick`: 0.5 s runs, one repeat):
//!    the 33 gymnasium and dm_control models in MuJoCo and here, per-model checks, the
//!    "Real models" section and its charts (see `models.rs`,
//!    `constraint_verify::models_report`). Fails on a panic, when a model that loads
//!    diverges, or when the suite cannot run; a model that does not load is a table entry.
//!    Skipped, with the reason in the report, only when MuJoCo itself cannot be
//!    installed (no Python, no PyPI); once MuJoCo is there, a failed model download is
//!    a failure.
//! 9. with `--mujoco` only: every MuJoCo reference of `scenes/reference/` regenerated into
//!    `target/verify/mujoco/` and compared with the committed file (COM, body origin and
//!    orientation within 1e-9; needs Python, see `mujoco.rs`)
//!
//! and writes `target/verify/report.md`. A failing stage does not stop the later ones;
//! the exit status is non-zero if any failed.

use crate::no_std;
use crate::run::{cargo, root, status};
use std::fmt::Write as _;
use std::process::Command;

struct Stage {
    name: &'static str,
    ok: bool,
    secs: f64,
    note: String,
}

fn git_head() -> String {
    let (ok, out) = crate::run::output(Command::new("git").current_dir(root()).args([
        "rev-parse",
        "--short",
        "HEAD",
    ]));
    if ok {
        out.trim().to_string()
    } else {
        "unknown".into()
    }
}

pub fn main(args: &[String]) -> Result<(), String> {
    let quick = args.iter().any(|a| a == "--quick");
    let with_mujoco = args.iter().any(|a| a == "--mujoco");
    if let Some(a) = args.iter().find(|a| *a != "--quick" && *a != "--mujoco") {
        return Err(format!(
            "unknown argument {a:?} (expected --quick, --mujoco)"
        ));
    }
    let out = root().join("target/verify");
    std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
    let total = if with_mujoco { 9 } else { 8 };
    let mut stages: Vec<Stage> = Vec::new();
    let begin = |k: usize, name: &str| eprintln!("\n[{k}/{total}] {name}");

    begin(1, "format (cargo fmt --check)");
    let (ok, secs) = status(cargo().args(["fmt", "--all", "--", "--check"]));
    stages.push(Stage {
        name: "cargo fmt --check",
        ok,
        secs,
        note: String::new(),
    });

    begin(2, "lint (cargo clippy -D warnings)");
    let (ok, secs) = status(cargo().args([
        "clippy",
        "--workspace",
        "--all-targets",
        "--",
        "-D",
        "warnings",
    ]));
    stages.push(Stage {
        name: "cargo clippy --workspace --all-targets -D warnings",
        ok,
        secs,
        note: String::new(),
    });

    begin(3, "docs (cargo doc of the library crates, -D warnings)");
    let t0 = std::time::Instant::now();
    let mut ok = true;
    // Default features, then all: a link can resolve under one set and not the other.
    for all in [false, true] {
        let mut doc = cargo();
        doc.args(["doc", "--no-deps"]);
        for (c, _) in crate::package::CRATES {
            doc.args(["-p", c]);
        }
        if all {
            doc.arg("--all-features");
        }
        doc.env("RUSTDOCFLAGS", "-D warnings");
        ok &= status(&mut doc).0;
    }
    stages.push(Stage {
        name: "cargo doc (library crates) -D warnings",
        ok,
        secs: t0.elapsed().as_secs_f64(),
        note: "default and all features".to_string(),
    });

    begin(4, "tests (cargo test --workspace)");
    let mut test = cargo();
    test.args(["test", "--workspace"]);
    if !quick {
        test.env("PROPTEST_CASES", "2048");
    }
    let (ok, secs) = status(&mut test);
    let note = if quick {
        "proptest: 256 cases".to_string()
    } else {
        "proptest: 2048 cases".to_string()
    };
    stages.push(Stage {
        name: "cargo test --workspace",
        ok,
        secs,
        note,
    });

    begin(5, "no_std build of constraint-core");
    let t0 = std::time::Instant::now();
    let (ok, note) = match no_std::main(&[]) {
        Ok(no_std::Outcome::Embedded) => (true, format!("built for {}", no_std::TARGET)),
        Ok(no_std::Outcome::HostFallback) => (
            true,
            format!(
                "{} not installable here: host build with --no-default-features",
                no_std::TARGET
            ),
        ),
        Err(e) => (false, e),
    };
    stages.push(Stage {
        name: "no_std build",
        ok,
        secs: t0.elapsed().as_secs_f64(),
        note,
    });

    begin(6, "packaging (cargo xtask package)");
    let t0 = std::time::Instant::now();
    let package_args = if quick {
        vec!["--no-verify".to_string()]
    } else {
        Vec::new()
    };
    let (ok, note) = match crate::package::main(&package_args) {
        Ok(()) if quick => (true, "--no-verify (packed, not built)".to_string()),
        Ok(()) => (true, "each crate built from its .crate".to_string()),
        // One table cell: the list of problems on one line.
        Err(e) => (false, e.replace('\n', "; ")),
    };
    stages.push(Stage {
        name: "cargo package (library crates)",
        ok,
        secs: t0.elapsed().as_secs_f64(),
        note,
    });

    begin(
        7,
        "sweeps: stability map and work-precision (release build)",
    );
    let mut sweep = verify_report(false);
    if quick {
        sweep.arg("--quick");
    }
    sweep.arg("--out").arg(&out);
    let (ok, secs) = status(&mut sweep);
    stages.push(Stage {
        name: "sweeps (verify-report)",
        ok,
        secs,
        note: String::new(),
    });

    begin(
        8,
        "real models: gymnasium and dm_control in MuJoCo and here",
    );
    let t0 = std::time::Instant::now();
    let (ok, note, models_md) = real_models(quick, &out);
    stages.push(Stage {
        name: "real models (cargo xtask models run)",
        ok,
        secs: t0.elapsed().as_secs_f64(),
        note,
    });

    if with_mujoco {
        begin(
            9,
            "MuJoCo references regenerated and compared with scenes/reference/",
        );
        let t0 = std::time::Instant::now();
        let (ok, note) = match crate::mujoco::check_references(&out.join("mujoco"), 1e-9) {
            Ok(lines) => (true, format!("{} scenes within 1e-9", lines.len())),
            Err(e) => (false, e),
        };
        stages.push(Stage {
            name: "MuJoCo references (verify --mujoco)",
            ok,
            secs: t0.elapsed().as_secs_f64(),
            note,
        });
    }

    let mut md = String::new();
    let _ = writeln!(md, "# Verification report\n");
    let _ = writeln!(
        md,
        "Commit `{}`, mode `{}`. Reproduce with `cargo xtask verify{}{}`.\n",
        git_head(),
        if quick { "quick" } else { "full" },
        if quick { " --quick" } else { "" },
        if with_mujoco { " --mujoco" } else { "" }
    );
    let _ = writeln!(
        md,
        "## Checks\n\n| stage | result | time (s) | note |\n|---|---|---|---|"
    );
    for s in &stages {
        let _ = writeln!(
            md,
            "| {} | {} | {:.1} | {} |",
            s.name,
            if s.ok { "pass" } else { "FAIL" },
            s.secs,
            s.note
        );
    }
    md.push('\n');
    match std::fs::read_to_string(out.join("sweeps.md")) {
        Ok(s)
            if stages
                .iter()
                .any(|s| s.name == "sweeps (verify-report)" && s.ok) =>
        {
            md.push_str(&s)
        }
        _ => md.push_str("Sweeps did not complete; see the console output.\n"),
    }
    md.push('\n');
    md.push_str(&models_md);
    let report = out.join("report.md");
    std::fs::write(&report, md).map_err(|e| e.to_string())?;
    let sweep_ok = bad_input_sweep(&report);
    // The same report as one self-contained HTML page, charts inline.
    let mut html = verify_report(true);
    html.arg("--html");
    html.arg(&report).arg(out.join("report.html"));
    let (html_ok, _) = status(&mut html);
    if !html_ok {
        eprintln!("warning: report.html was not written (the markdown report is complete)");
    }

    eprintln!("\nsummary:");
    for s in &stages {
        eprintln!(
            "  {:4}  {:>7.1} s  {}",
            if s.ok { "ok" } else { "FAIL" },
            s.secs,
            s.name
        );
    }
    eprintln!("report: {}", report.display());
    if html_ok {
        eprintln!("        {}", out.join("report.html").display());
    }
    let mut failed: Vec<&str> = stages.iter().filter(|s| !s.ok).map(|s| s.name).collect();
    if !sweep_ok {
        failed.push("bad-input sweep");
    }
    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!("failed: {}", failed.join(", ")))
    }
}

/// Stage 7: the real-models suite into `out/models/`, then its report section (written by
/// `verify-report --models`, charts beside the report). Returns (passed, the note for
/// the checks table, the section's Markdown).
fn real_models(quick: bool, out: &std::path::Path) -> (bool, String, String) {
    let how = if quick {
        "`cargo xtask verify --quick`: `cargo xtask models run --quick` (0.5 s runs, one repeat)"
    } else {
        "`cargo xtask verify`: `cargo xtask models run` (5 s passive and perturbed, 2 s controlled, MuJoCo median of 3)"
    };
    let heading = "## Real models (gymnasium and dm_control)\n\n";
    if let Err(e) = crate::mujoco::ensure_venv() {
        let why = format!(
            "skipped: MuJoCo could not be installed ({e}); the real models need Python and \
             PyPI (`pip install mujoco=={}`, then the gymnasium and dm-control wheels)",
            crate::mujoco::MUJOCO_VERSION
        );
        eprintln!("xtask verify: real models {why}");
        return (true, why.clone(), format!("{heading}Not run: {why}.\n"));
    }
    let args = crate::models::RunArgs {
        quick,
        out: out.join("models"),
    };
    let suite = match crate::models::run_suite(&args) {
        Ok(s) => s,
        Err(e) => return (false, e.clone(), format!("{heading}Did not run: {e}.\n")),
    };
    let loaded = suite.rows.iter().filter(|r| r.loads()).count();
    let mut note = format!("{} models, {loaded} load", suite.rows.len());
    if !suite.fatal.is_empty() {
        let _ = write!(note, "; panicked or diverged: {}", suite.fatal.join(", "));
    }
    let mut section = verify_report(true);
    section.arg("--models");
    section.arg(args.out.join("models.csv")).arg(out).arg(how);
    let (section_ok, _) = status(&mut section);
    let md = std::fs::read_to_string(out.join("models_section.md"))
        .ok()
        .filter(|_| section_ok)
        .unwrap_or_else(|| {
            format!(
                "{heading}The section was not written (verify-report --models failed); the \
                 table is in {}.\n",
                args.out.join("models.md").display()
            )
        });
    (suite.fatal.is_empty() && section_ok, note, md)
}

/// Issue 7's bad-input sweep (`verify/tests/bad_input_sweep.rs`): runs that one test,
/// prints its `bad-input sweep: N cases, P panics, F non-finite` line and appends it to
/// the report as a last section. Returns whether the test passed.
fn bad_input_sweep(report: &std::path::Path) -> bool {
    eprintln!("\n[+] bad-input sweep (cargo test --test bad_input_sweep)");
    let (ok, stdout) = crate::run::output(cargo().args([
        "test",
        "-p",
        "constraint-verify",
        "--test",
        "bad_input_sweep",
        "--",
        "--nocapture",
    ]));
    let line = stdout
        .lines()
        .find(|l| l.starts_with("bad-input sweep:"))
        .map_or_else(
            || "bad-input sweep: did not run (see cargo test output)".to_string(),
            str::to_string,
        );
    let open: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("NONFINITE (open finding"))
        .collect();
    println!("{line}");
    let mut md = String::new();
    let _ = writeln!(md, "\n## Bad-input sweep\n");
    let _ = writeln!(
        md,
        "Every public constructor, builder, setter and step of every crate with NaN, ±∞, \
         −1, 0, 1e300 and subnormals in each slot, plus structural bad cases and hostile \
         MJCF (`verify/tests/bad_input_sweep.rs`, test {}):\n",
        if ok { "passed" } else { "FAILED" }
    );
    let _ = writeln!(md, "    {line}\n");
    if !open.is_empty() {
        let _ = writeln!(
            md,
            "{} of the non-finite results are open library findings (listed in the test's \
             `OPEN_FINDINGS`, reported on issue 7).",
            open.len()
        );
    }
    let appended = std::fs::OpenOptions::new()
        .append(true)
        .open(report)
        .and_then(|mut f| std::io::Write::write_all(&mut f, md.as_bytes()));
    if let Err(e) = appended {
        eprintln!("xtask verify: could not append the sweep to the report: {e}");
    }
    ok
}

/// `cargo run --release [--quiet] -p constraint-report --bin verify-report --`, for the
/// caller to add the report's arguments.
fn verify_report(quiet: bool) -> Command {
    let mut c = cargo();
    c.args(["run", "--release"]);
    if quiet {
        c.arg("--quiet");
    }
    c.args(["-p", "constraint-report", "--bin", "verify-report", "--"]);
    c
}
