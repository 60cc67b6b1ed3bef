//! Project automation: `cargo xtask <command>` (the alias lives in `.cargo/config.toml`).
//!
//! | command | what it does |
//! |---|---|
//! | `verify [--quick]` | fmt and clippy checks, the whole test suite, the `no_std` build, the stiffness and work-precision sweeps; writes `target/verify/report.md` with charts |
//! | `no-std` | builds `constraint-core` (no allocator) and `constraint-lagrange` (`alloc` only) without `std` for `thumbv7em-none-eabihf` |
//! | `bench` | runs the criterion benchmarks and prints the time per step and growth exponents |
//!
//! One file per command, as in glam's `tools/ci`. Standard library only, so the task
//! runner itself builds in seconds.

mod bench;
mod no_std;
mod run;
mod verify;

use std::process::ExitCode;

const USAGE: &str = "usage: cargo xtask <command>

commands:
  verify [--quick]   checks, tests, no_std build and sweeps; writes target/verify/report.md
  no-std             build constraint-core and constraint-lagrange for thumbv7em-none-eabihf without std
  bench              criterion benchmarks: implicit cloth step and KKT solvers, N = 32, 64, 128";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("verify") => verify::main(&args[1..]),
        Some("no-std") => no_std::main(&args[1..]).map(|_| ()),
        Some("bench") => bench::main(&args[1..]),
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
