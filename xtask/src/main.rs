//! Project automation: `cargo xtask <command>` (the alias lives in `.cargo/config.toml`).
//!
//! | command | what it does |
//! |---|---|
//! | `verify [--quick \| --full] [--mujoco]` | fmt, clippy and rustdoc (`-D warnings`, library crates) checks, one release build, the whole test suite, the `no_std` build, `cargo package` of the library crates, the sweeps and the real models; writes `target/verify/report.md` with charts (`--quick`: CI's shorter model runs and 256 proptest cases; `--full`: denser sweeps, 2048 cases, packages built); `--mujoco` also regenerates the MuJoCo references of `scenes/reference/` into `target/verify/mujoco/` and checks them against the committed ones (needs Python) |
//! | `no-std` | builds `constraint-core` (no allocator) and `constraint-lagrange` (`alloc` only) without `std` for `thumbv7em-none-eabihf` |
//! | `package [--no-verify]` | `cargo package` of the six library crates in one run (each packed crate built alone from its `.crate` unless `--no-verify`), after checking each file list holds the crate's README and nothing that reads outside the crate |
//! | `bench [--no-mujoco] [--peers-only] [--only SECTIONS]` | runs the criterion benchmarks and the peer comparisons in one run and writes `target/bench/ratios.md`: ball-joint chains against rapier3d and MuJoCo, contact scenes against rapier3d, every MJCF scene of `scenes/` against MuJoCo (Euler, `mujoco.rollout`), the gymnasium and dm_control models against MuJoCo (`models run`'s timing table), and time per step and growth exponents of the cloth step and KKT solves; SECTIONS: `chains,contact,mjcf,models,cloth` |
//! | `mujoco SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K] [--integrator euler\|implicitfast\|rk4] --out FILE.csv [--timing FILE.json]` | runs an MJCF scene in MuJoCo (virtual environment with a pinned `mujoco` from PyPI in `target/mujoco-venv`, made on first use) and writes the trajectory file of DESIGN.md section 6; `--timing` adds seconds per step in MuJoCo's C loop |
//! | `simulate SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K] [--method M] --out FILE.csv` | runs an MJCF scene with this library (the `simulate` binary of `constraint-scene`, release build; its `--help` lists every option) and writes the same trajectory file; one-line error and non-zero exit on any failure, divergence included |
//! | `compare A.csv B.csv [--tolerance TOL]` | max COM position, orientation and body-origin error between two trajectory files, with time and body (the `compare` binary of `constraint-scene`, release build); exit status 2 beyond `TOL` |
//! | `models fetch \| list \| run [--quick] [--out DIR]` | the gymnasium 1.4.0 and dm_control 1.0.50 MJCF models (pinned wheels from PyPI, extracted into `target/models/`, dm_control's `lqr_2_1` and `swimmer6` generated): `run` times a passive run of each in MuJoCo (`mujoco.rollout`) and in the `simulate` binary and writes `target/models/models.md` and `models.csv`; `list` prints the 33 pinned files |
//!
//! One file per command, as in glam's `tools/ci`. Standard library only, so the task
//! runner itself builds in seconds (MuJoCo runs through Python, never at build time).
//! `clap` (derive) was weighed for this dispatch and the subcommands' arguments: a clean
//! build of clap 4.6 with `derive` took 57 s of CPU (348 s wall on a loaded 2-core
//! machine) against 0.16 s for a std-only binary, paid by every fresh clone before its
//! first `cargo xtask` prints anything; the commands a user runs (`simulate`, `compare`)
//! are `constraint-scene`'s binaries and parse with clap there. The JSON xtask reads
//! (flat objects from its own Python scripts and from `simulate --summary`) is read by
//! key for the same reason, rather than with `serde_json`.

mod bench;
mod bench_cloth;
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

use std::process::ExitCode;

const USAGE: &str = "usage: cargo xtask <command>

commands:
  verify [--ci | --full] [--mujoco]
                     the report: one release build, the state-hash pins, no_std build,
                     packaging, sweeps and the real models; writes target/verify/report.md
                     (aim: ten minutes on a fresh two-core machine);
                     --ci adds fmt, clippy, rustdoc and the whole test suite (what CI runs);
                     --full: denser sweeps, 5 s model runs, 2048 proptest cases, each library
                     crate built from its .crate (implies --ci);
                     --mujoco also regenerates scenes/reference/ in MuJoCo and checks it
  no-std             build constraint-core and constraint-lagrange for thumbv7em-none-eabihf without std
  package [--no-verify]
                     cargo package of the six library crates (each built from its .crate
                     unless --no-verify): target/package/
  bench [--no-mujoco] [--peers-only] [--only chains,contact,mjcf,models,cloth] [CRITERION ARGS]
                     criterion benchmarks and peer comparisons in one run: chains vs rapier3d
                     and MuJoCo, contact scenes vs rapier3d, every MJCF scene vs MuJoCo,
                     cloth step and KKT growth exponents: target/bench/ratios.md
  mujoco SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K]
         [--integrator euler|implicitfast|rk4] --out FILE.csv [--timing FILE.json]
                     run the scene in MuJoCo (pip-installed into target/mujoco-venv on first use)
  simulate SCENE.xml [--keyframe NAME] [--dt DT] --duration T [--every K]
           [--method M] [--qpos V,.. --qvel V,..] [--ctrl FILE.csv] --out FILE.csv
           [--html FILE.html] [--summary FILE.json]
                     run the scene with this library (maximal coordinates) and write its trajectory
  compare A.csv B.csv [--tolerance TOL] [--format table|keys]
                     max COM, orientation and body-origin error between two trajectory files
                     (exit status 2 beyond TOL); both run the binaries of constraint-scene
                     (`cargo install --path scene` gives them to a user): --help lists options
  fuzz [--seconds N] [TARGET...]
                     run the cargo-fuzz targets of fuzz/ for N seconds each (default 60)
  models fetch       download the pinned gymnasium and dm_control wheels (PyPI, no dependencies)
                     and extract their 33 MJCF models into target/models/ (once; stamp file)
  models list        fetch, then print the pinned models with their paths
  models run [--quick] [--out DIR]
                     fetch, then every model in MuJoCo (passive, mujoco.rollout) and in our
                     simulate binary for 5 s (--quick: 0.5 s): models.md and models.csv in DIR
                     (default target/models/)";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("verify") => verify::main(&args[1..]),
        Some("no-std") => no_std::main(&args[1..]).map(|_| ()),
        Some("package") => package::main(&args[1..]),
        Some("bench") => bench::main(&args[1..]),
        Some("mujoco") => mujoco::main(&args[1..]),
        Some("compare") => compare::main(&args[1..]),
        Some("fuzz") => fuzz::main(&args[1..]),
        Some("simulate") => simulate::main(&args[1..]),
        Some("models") => models::main(&args[1..]),
        Some("-h" | "--help" | "help") | None => {
            println!("{USAGE}");
            Ok(())
        }
        Some(other) => Err(format!("unknown command {other:?}\n\n{USAGE}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}
