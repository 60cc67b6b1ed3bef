//! `compare A.csv B.csv [--tolerance TOL]` — the largest COM position, orientation and
//! body-origin errors between two trajectory files of one scene (DESIGN.md §§6–7), each
//! with the time and body where it occurs, and the largest difference of every other
//! column both files have (`constraint_scene::trajectory::compare`). `cargo xtask compare`
//! calls this.
//!
//! Exit status 0 when the files compare (and, with `--tolerance`, every sample matched
//! and the worst of the three errors is within it); 2 when a tolerance is exceeded; 1
//! with one line `compare: <reason>` on any other error, bad arguments included.
//! `--format keys` prints `key value` lines instead of the table, for scripts.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use constraint_scene::trajectory::{compare, Comparison, Trajectory};

/// Compares two trajectory files of one scene.
#[derive(Parser, Debug)]
#[command(name = "compare", version)]
struct Cli {
    /// The first trajectory (CSV of DESIGN.md §6).
    #[arg(value_name = "A.csv")]
    a: PathBuf,
    /// The second trajectory.
    #[arg(value_name = "B.csv")]
    b: PathBuf,
    /// Fail (exit status 2) unless every sample matched and the worst COM (m),
    /// body-origin (m) and orientation (rad) error is at most TOL [default: no check].
    #[arg(long, value_name = "TOL")]
    tolerance: Option<f64>,
    /// Output: a table for people, or `key value` lines for scripts.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    format: Format,
}

/// What `compare` prints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Format {
    /// One line per figure, with where it occurs.
    Table,
    /// `samples`, `samples_a`, `samples_b`, `t_first`, `t_last`, `bodies`, `extras`
    /// (comma-separated names), `com`, `orientation`, `origin`, `worst`: one `key value`
    /// pair a line.
    Keys,
}

/// The `--format keys` text.
fn keys(c: &Comparison) -> String {
    let extras: Vec<&str> = c.extras.iter().map(|e| e.0.as_str()).collect();
    format!(
        "samples {}\nsamples_a {}\nsamples_b {}\nt_first {:?}\nt_last {:?}\nbodies {}\n\
         extras {}\ncom {:e}\norientation {:e}\norigin {:e}\nworst {:e}\n",
        c.samples,
        c.samples_a,
        c.samples_b,
        c.t_first,
        c.t_last,
        c.bodies,
        extras.join(","),
        c.com.0,
        c.angle.0,
        c.origin.0,
        c.worst()
    )
}

/// A clap error as one line without its `error: ` prefix: the message up to its first
/// blank line, indented continuation lines (the missing arguments) joined with spaces.
fn first_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let msg: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty() && !l.starts_with("Usage:"))
        .map(str::trim)
        .collect();
    let line = msg.join(" ");
    match line.strip_prefix("error: ") {
        Some(rest) => rest.to_string(),
        None if line.is_empty() => "bad arguments".to_string(),
        None => line,
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                print!("{}", e.render());
                return ExitCode::SUCCESS;
            }
            eprintln!("compare: {}", first_line(&e));
            return ExitCode::FAILURE;
        }
    };
    let result = Trajectory::read(&cli.a).and_then(|a| {
        let b = Trajectory::read(&cli.b)?;
        compare(&a, &b).map_err(|e| format!("{} vs {}: {e}", cli.a.display(), cli.b.display()))
    });
    let c = match result {
        Ok(c) => c,
        Err(e) => {
            eprintln!("compare: {e}");
            return ExitCode::FAILURE;
        }
    };
    match cli.format {
        Format::Table => print!("{}", c.report()),
        Format::Keys => print!("{}", keys(&c)),
    }
    match cli.tolerance {
        Some(tol) if !(c.all_matched() && c.worst() <= tol) => {
            if c.all_matched() {
                eprintln!(
                    "compare: worst error {:.3e} exceeds the tolerance {tol:.3e}",
                    c.worst()
                );
            } else {
                eprintln!(
                    "compare: only {} samples matched (A has {}, B has {}); a tolerance needs every sample",
                    c.samples, c.samples_a, c.samples_b
                );
            }
            ExitCode::from(2)
        }
        _ => ExitCode::SUCCESS,
    }
}
