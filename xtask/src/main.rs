//! Project automation: `cargo xtask <command>` (the alias lives in `.cargo/config.toml`).
//!
//! | command | what it does |
//! |---|---|
//! | `verify [--ci \| --full] [--mujoco]` | one release build, the state-hash pins, the `no_std` build, `cargo package` of the library crates, the sweeps and the real models; writes `target/verify/report.md` with charts (`--ci`: also fmt, clippy and rustdoc with `-D warnings` and the whole test suite, what CI runs; `--full`: denser sweeps, 5 s model runs, 2048 proptest cases, packages built, implies `--ci`; `--quick`, the default's old name, is still accepted); `--mujoco` also regenerates the MuJoCo references of `scenes/reference/` into `target/verify/mujoco/` and checks them against the committed ones (needs Python) |
//! | `no-std` | builds `constraint-core` (no allocator) and `constraint-lagrange` (`alloc` only) without `std` for `thumbv7em-none-eabihf` |
//! | `package [--no-verify]` | `cargo package` of the six library crates in one run (each packed crate built alone from its `.crate` unless `--no-verify`), after checking each file list holds the crate's README and nothing that reads outside the crate |
//! | `bench [--no-mujoco] [--peers-only] [--only SECTIONS] [CRITERION ARGS]` | runs the criterion benchmarks and the peer comparisons in one run and writes `target/bench/ratios.md`: ball-joint chains against rapier3d and MuJoCo, contact scenes against rapier3d, every MJCF scene of `scenes/` against MuJoCo (Euler, `mujoco.rollout`), the gymnasium and dm_control models against MuJoCo (`models run`'s timing table), and time per step and growth exponents of the cloth step and KKT solves; SECTIONS: `chains,contact,mjcf,models,cloth` |
//! | `mujoco SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K] [--integrator euler\|implicitfast\|rk4] --out FILE.csv [--timing FILE.json]` | runs an MJCF scene in MuJoCo (virtual environment with a pinned `mujoco` from PyPI in `target/mujoco-venv`, made on first use) and writes the trajectory file of DESIGN.md section 6; `--timing` adds seconds per step in MuJoCo's C loop |
//! | `simulate SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K] [--method M] --out FILE.csv` | runs an MJCF scene with this library (the `simulate` binary of `constraint-scene`, release build; its `--help` lists every option) and writes the same trajectory file; one-line error and non-zero exit on any failure, divergence included |
//! | `compare A.csv B.csv [--tolerance TOL]` | max COM position, orientation and body-origin error between two trajectory files, with time and body (the `compare` binary of `constraint-scene`, release build); exit status 2 beyond `TOL` |
//! | `fuzz [--seconds N] [TARGET...]` | runs the cargo-fuzz targets of `fuzz/` for `N` seconds each (default 60), installing `cargo-fuzz` when it is missing |
//! | `models fetch \| list \| run [--quick] [--out DIR] [--only SUITE/NAME,...]` | the gymnasium 1.4.0 and dm_control 1.0.50 MJCF models (pinned wheels from PyPI, extracted into `target/models/`, dm_control's `lqr_2_1` and `swimmer6` generated): `run` times a passive run of each in MuJoCo (`mujoco.rollout`) and in the `simulate` binary and writes `target/models/models.md` and `models.csv`; `list` prints the 33 pinned files |
//!
//! One file per command, as in glam's `tools/ci`. Each command's options are a clap
//! (derive) struct in its file, parsed once here into [`Cli`]; `cargo xtask --help` lists
//! the commands and `cargo xtask <command> --help` every option with its default (issue
//! 15: well-kept crates instead of hand-written tooling). MuJoCo runs through Python,
//! never at build time; `simulate` and `compare` are `constraint-scene`'s binaries, run
//! with the arguments as given, so their own `--help` lists their options. The JSON
//! xtask reads (cargo's `--message-format=json` lines, criterion's `estimates.json`, the
//! timing files of `mujoco --timing`, `simulate --summary`) is deserialized with
//! `serde_json` into just the fields used, numbers read exactly (`float_roundtrip`).
//!
//! The price is the first `cargo xtask` on a fresh clone, which now compiles clap,
//! serde, serde_json and their proc-macros before printing anything: a fresh `cargo
//! build -p xtask` took 17–20 s wall (10–12 s CPU) std-only and 170–174 s wall (106–109
//! s CPU) with them while the dev profile built every dependency at `opt-level = 2`,
//! proc-macros included, and 61–65 s wall (48 s CPU) with the proc-macros unoptimised
//! (the workspace `Cargo.toml`), on two cores shared with other builds (load 5–7);
//! 8.7 s std-only at load 2.

mod bench;
mod bench_cloth;
mod bench_contact;
mod bench_mjcf;
mod build;
mod compare;
mod fuzz;
mod models;
mod models_checks;
mod mujoco;
mod no_std;
mod package;
mod run;
mod simulate;
mod verify;

use clap::{CommandFactory, Parser, Subcommand};
use std::ffi::OsString;
use std::process::ExitCode;

/// Project automation for the constraint crates: checks, the verification report,
/// benchmarks, scenes in MuJoCo and here, the real models.
#[derive(Parser, Debug, PartialEq)]
#[command(
    name = "cargo xtask",
    bin_name = "cargo xtask",
    // A flag given twice counts once, as the hand parsers took it.
    args_override_self = true,
    after_help = "`cargo xtask <command> --help` lists the command's options with their \
                  defaults; `simulate` and `compare` pass their arguments to the binaries of \
                  constraint-scene, whose `--help` lists theirs."
)]
struct Cli {
    /// The command [default: print this help].
    #[command(subcommand)]
    command: Option<Command>,
}

/// The commands, each with its options.
#[derive(Subcommand, Debug, PartialEq)]
enum Command {
    /// The report: release build, state-hash pins, no_std build, packaging, sweeps and real
    /// models; writes target/verify/report.md
    ///
    /// One release build, the state-hash pins, the no_std build, packaging, the sweeps and
    /// the real models; writes target/verify/report.md and report.html (aim: ten minutes on
    /// a fresh two-core machine). --ci adds what CI runs, --full the dense plan, --mujoco
    /// the MuJoCo references.
    Verify(verify::Options),
    /// Build constraint-core, constraint-lagrange and constraint-articulated for
    /// thumbv7em-none-eabihf without std
    ///
    /// constraint-core without an allocator, constraint-lagrange and constraint-articulated
    /// with alloc only; a host build without default features when the target cannot be
    /// installed.
    #[command(name = "no-std")]
    NoStd,
    /// cargo package of the six library crates (each built from its .crate unless
    /// --no-verify): target/package/
    ///
    /// Checks first that each file list holds the crate's README and nothing that reads
    /// outside the crate.
    Package(package::Options),
    /// Criterion benchmarks and peer comparisons in one run: target/bench/ratios.md
    ///
    /// Chains against rapier3d and MuJoCo, contact scenes against rapier3d, every MJCF
    /// scene and the real models against MuJoCo, the cloth step's and KKT solves' growth
    /// exponents.
    Bench(bench::Options),
    /// Run a scene in MuJoCo (pip-installed into target/mujoco-venv on first use) and write
    /// its trajectory
    ///
    /// The trajectory file of DESIGN.md section 6, as simulate writes it.
    Mujoco(mujoco::RunOptions),
    /// Run a scene with this library and write its trajectory (the simulate binary of
    /// constraint-scene)
    ///
    /// The simulate binary of constraint-scene (release build), its arguments passed as
    /// given: `cargo xtask simulate --help` is its help, every option with its default.
    #[command(
        disable_help_flag = true,
        override_usage = "cargo xtask simulate SCENE.xml [--keyframe NAME] [--dt DT] --duration T \
                          [--every K] [--method M] [--qpos V,.. --qvel V,..] [--ctrl FILE.csv] \
                          --out FILE.csv [--html FILE.html] [--summary FILE.json]"
    )]
    Simulate(Forward),
    /// Max COM, orientation and body-origin error between two trajectory files (the compare
    /// binary of constraint-scene)
    ///
    /// Exit status 2 beyond --tolerance. The compare binary of constraint-scene (release
    /// build), its arguments passed as given: `cargo xtask compare --help` is its help,
    /// every option with its default.
    #[command(
        disable_help_flag = true,
        override_usage = "cargo xtask compare A.csv B.csv [--tolerance TOL] [--format table|keys]"
    )]
    Compare(Forward),
    /// Run the cargo-fuzz targets of fuzz/ for N seconds each
    ///
    /// cargo-fuzz is installed when missing; nightly with AddressSanitizer when installed,
    /// else stable with RUSTC_BOOTSTRAP=1 and no sanitizer.
    Fuzz(fuzz::Options),
    /// The gymnasium and dm_control models: fetch, list, or run each in MuJoCo and here
    ///
    /// The 33 MJCF models of gymnasium 1.4.0 and dm_control 1.0.50 (pinned wheels from
    /// PyPI, extracted into target/models/).
    Models(models::Options),
}

/// The arguments of a command that runs a binary of `constraint-scene`, passed to it
/// as given (`--help` included: the binary's help lists its options).
#[derive(clap::Args, Debug, PartialEq)]
struct Forward {
    /// The binary's arguments, as given (--help: the binary's own help).
    #[arg(
        value_name = "ARGS",
        num_args = 0..,
        trailing_var_arg = true,
        allow_hyphen_values = true
    )]
    args: Vec<OsString>,
}

/// Runs one command.
fn run(command: Command) -> Result<(), String> {
    match command {
        Command::Verify(o) => verify::main(&o),
        Command::NoStd => no_std::main().map(|_| ()),
        Command::Package(o) => package::main(&o),
        Command::Bench(o) => bench::main(&o),
        Command::Mujoco(o) => mujoco::run(&o),
        Command::Simulate(f) => simulate::main(&f.args),
        Command::Compare(f) => compare::main(&f.args),
        Command::Fuzz(o) => fuzz::main(&o),
        Command::Models(o) => models::main(&o),
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // Usage errors exit 1 as the hand parsers did (clap's own code is 2);
            // --help exits 0.
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let result = match cli.command {
        Some(command) => run(command),
        None => Cli::command().print_long_help().map_err(|e| e.to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `cargo xtask LINE` parsed as the command line would be (`LINE` split at spaces).
#[cfg(test)]
fn parse(line: &str) -> Result<Option<Command>, clap::Error> {
    Cli::try_parse_from(std::iter::once("cargo-xtask").chain(line.split_whitespace()))
        .map(|c| c.command)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn the_command_line_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    /// `cargo xtask LINE`, which must parse.
    fn ok(line: &str) -> Command {
        match parse(line) {
            Ok(Some(c)) => c,
            Ok(None) => panic!("{line}: no command"),
            Err(e) => panic!("{line}: {e}"),
        }
    }

    /// The error `cargo xtask LINE` gives, rendered.
    fn err(line: &str) -> String {
        match parse(line) {
            Ok(c) => panic!("{line}: parsed as {c:?}"),
            Err(e) => e.to_string(),
        }
    }

    fn forward(line: &str) -> Forward {
        Forward {
            args: line.split_whitespace().map(OsString::from).collect(),
        }
    }

    /// The verify lines of README.md, .ci/run and verify.rs: the default, --ci, --full,
    /// --mujoco, and --quick, the default's old name (with --full an error).
    #[test]
    fn verify_lines_parse_to_their_options() {
        let v = |ci, full, quick, mujoco| {
            Command::Verify(verify::Options {
                ci,
                full,
                quick,
                mujoco,
            })
        };
        assert_eq!(ok("verify"), v(false, false, false, false));
        assert_eq!(ok("verify --ci"), v(true, false, false, false));
        assert_eq!(ok("verify --full"), v(false, true, false, false));
        assert_eq!(ok("verify --mujoco"), v(false, false, false, true));
        assert_eq!(ok("verify --quick"), v(false, false, true, false));
        assert_eq!(ok("verify --ci --full"), v(true, true, false, false));
        assert_eq!(ok("verify --ci --ci"), v(true, false, false, false));
        assert!(err("verify --quick --full").contains("cannot be used with"));
        assert!(err("verify --fast").contains("--fast"));
    }

    /// README.md's scene lines: simulate and compare pass everything through, help
    /// included; mujoco parses into its options.
    #[test]
    fn scene_lines_parse_to_their_options() {
        let sim = "scenes/chain20.xml --keyframe start --duration 2 --every 40 --out ours.csv";
        assert_eq!(
            ok(&format!("simulate {sim}")),
            Command::Simulate(forward(sim))
        );
        for line in [
            "simulate --help",
            "simulate -h",
            "simulate s.xml --qpos -1,2 --html run.html",
        ] {
            let rest = line.trim_start_matches("simulate");
            assert_eq!(ok(line), Command::Simulate(forward(rest)), "{line}");
        }
        assert_eq!(ok("simulate"), Command::Simulate(forward("")));
        assert_eq!(
            ok("compare ours.csv mujoco.csv --tolerance 1e-6"),
            Command::Compare(forward("ours.csv mujoco.csv --tolerance 1e-6"))
        );
        assert_eq!(
            ok(
                "mujoco scenes/chain20.xml --keyframe start --duration 2 --every 40 \
                --integrator rk4 --out mujoco.csv"
            ),
            Command::Mujoco(mujoco::RunOptions {
                scene: PathBuf::from("scenes/chain20.xml"),
                keyframe: Some("start".into()),
                duration: "2".into(),
                every: 40,
                integrator: Some("rk4".into()),
                out: PathBuf::from("mujoco.csv"),
                ..mujoco::RunOptions::default()
            })
        );
    }

    /// The other commands of README.md and the module docs.
    #[test]
    fn other_lines_parse_to_their_options() {
        assert_eq!(ok("no-std"), Command::NoStd);
        assert!(err("no-std --now").contains("--now"));
        assert_eq!(
            ok("package"),
            Command::Package(package::Options { no_verify: false })
        );
        assert_eq!(
            ok("package --no-verify"),
            Command::Package(package::Options { no_verify: true })
        );
        let fuzz = |seconds, targets: &[&str]| {
            Command::Fuzz(fuzz::Options {
                seconds,
                targets: targets.iter().map(|t| t.to_string()).collect(),
            })
        };
        assert_eq!(ok("fuzz"), fuzz(60, &[]));
        assert_eq!(ok("fuzz --seconds 5"), fuzz(5, &[]));
        assert_eq!(
            ok("fuzz --seconds 5 mjcf_load one_world"),
            fuzz(5, &["mjcf_load", "one_world"])
        );
        assert!(err("fuzz nothing").contains("nothing"));
        assert!(err("fuzz --seconds 1.5").contains("--seconds"));
    }

    /// `cargo xtask` alone parses to no command (the help is printed); an unknown command
    /// is an error; --help is clap's help, listing every command.
    #[test]
    fn no_command_and_unknown_commands() {
        assert_eq!(parse("").ok(), Some(None));
        assert!(err("frobnicate").contains("frobnicate"));
        let help = Cli::command().render_long_help().to_string();
        for c in [
            "verify", "no-std", "package", "bench", "mujoco", "simulate", "compare", "fuzz",
            "models",
        ] {
            assert!(help.contains(&format!("  {c} ")), "{c} not in\n{help}");
        }
    }

    /// Every option of every command (but the hidden and the passed-through ones) says
    /// its default in its help, or is required.
    #[test]
    fn every_option_shows_its_default() {
        fn check(cmd: &clap::Command, path: &str) {
            for a in cmd.get_arguments() {
                let id = a.get_id().as_str();
                if a.is_hide_set() || id == "help" || id == "version" || id == "args" {
                    continue;
                }
                let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
                let shown = !a.get_default_values().is_empty() && a.get_action().takes_values();
                assert!(
                    a.is_required_set() || shown || help.contains("[default: "),
                    "{path} {id}: no default in {help:?}"
                );
                assert!(!help.is_empty(), "{path} {id}: no help");
            }
            for sub in cmd.get_subcommands() {
                check(sub, &format!("{path} {}", sub.get_name()));
            }
        }
        let mut cmd = Cli::command();
        cmd.build();
        check(&cmd, "cargo xtask");
    }
}
