//! `cargo xtask bench`: the criterion benchmarks.
//!
//! Runs `cargo bench -p constraint-soft --bench cloth_step` (time per implicit cloth step
//! for N = 32, 64, 128: assembly, step with sparse LDLᵀ, step with CG) and
//! `cargo bench -p constraint-lagrange --bench kkt_solvers` (one KKT solve of the
//! inextensible cloth per solver), then prints tables with the growth exponent of each
//! series, fitted on log time against log N. Peer engines (MuJoCo, rapier) join in a
//! later issue.

use crate::run::{cargo, root};

/// Median (criterion's point estimate) in seconds for `group/name/n`, if present.
fn estimate(group: &str, name: &str, n: usize) -> Option<f64> {
    let p = root()
        .join("target/criterion")
        .join(group)
        .join(name)
        .join(n.to_string())
        .join("new/estimates.json");
    let s = std::fs::read_to_string(p).ok()?;
    // The file is small JSON; read `"median":{..."point_estimate":X`.
    let m = s.find("\"median\"")?;
    let rest = &s[m..];
    let k = rest.find("\"point_estimate\":")? + "\"point_estimate\":".len();
    let num: String = rest[k..]
        .chars()
        .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '-' | '+'))
        .collect();
    num.parse::<f64>().ok().map(|ns| ns * 1e-9)
}

/// Least-squares slope of log t against log n.
fn slope(pts: &[(f64, f64)]) -> Option<f64> {
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (sx, sy) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x.ln(), b + y.ln()));
    let (mx, my) = (sx / n, sy / n);
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in pts {
        num += (x.ln() - mx) * (y.ln() - my);
        den += (x.ln() - mx) * (x.ln() - mx);
    }
    Some(num / den)
}

fn table(group: &str, names: &[&str]) {
    println!("\n{group}: median time per call\n");
    println!("| series | N=32 | N=64 | N=128 | exponent in N |");
    println!("|---|---|---|---|---|");
    for name in names {
        let mut pts = Vec::new();
        let mut cells = Vec::new();
        for n in [32usize, 64, 128] {
            match estimate(group, name, n) {
                Some(t) => {
                    pts.push((n as f64, t));
                    cells.push(format!("{:.3} ms", t * 1e3));
                }
                None => cells.push("–".into()),
            }
        }
        let e = slope(&pts).map_or("–".into(), |s| format!("{s:.2}"));
        println!("| {name} | {} | {e} |", cells.join(" | "));
    }
}

pub fn main(args: &[String]) -> Result<(), String> {
    for (krate, bench) in [
        ("constraint-soft", "cloth_step"),
        ("constraint-lagrange", "kkt_solvers"),
    ] {
        let ok = cargo()
            .args(["bench", "-p", krate, "--bench", bench, "--"])
            .args(args)
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if !ok {
            return Err(format!("cargo bench -p {krate} --bench {bench} failed"));
        }
    }
    table("cloth_implicit", &["assemble", "step_ldlt", "step_cg"]);
    table(
        "cloth_kkt",
        &["sparse_schur", "minres", "gmres", "dense_schur"],
    );
    Ok(())
}
