//! The cloth section of `cargo xtask bench`: the cloth_step bench of `constraint-soft`
//! (group `cloth_implicit`) and the kkt_solvers bench of `constraint-lagrange` (group
//! `cloth_kkt`), run in the same `cargo xtask bench`; their criterion medians at N = 32,
//! 64, 128 particles per side as tables of time per call and growth exponents in the
//! number of nodes (slopes between consecutive sizes and the least-squares fit).

use crate::bench::{estimate, fmt_time, slope};
use crate::run::cargo;
use std::fmt::Write as _;

/// Particles per side of the cloth benches.
const CLOTH_SIZES: [usize; 3] = [32, 64, 128];

/// Series of the cloth_step bench (group `cloth_implicit`).
const CLOTH_SERIES: [&str; 4] = ["assemble", "step_ldlt", "step_lagged", "step_cg"];

/// Series of the kkt_solvers bench (group `cloth_kkt`).
const KKT_SERIES: [&str; 4] = ["sparse_schur", "minres", "gmres", "dense_schur"];

/// `(series, median per size of CLOTH_SIZES)`.
pub type Growth = Vec<(String, [Option<f64>; 3])>;

fn read_growth(group: &str, names: &[&str]) -> Growth {
    names
        .iter()
        .map(|name| {
            (
                name.to_string(),
                CLOTH_SIZES.map(|n| estimate(group, name, n)),
            )
        })
        .collect()
}

/// Time per call at each size, then growth exponents in the number of nodes (N²): the
/// slope between consecutive sizes and the least-squares fit over the sizes measured.
fn growth_markdown(md: &mut String, title: &str, series: &Growth) {
    let _ = writeln!(md, "## {title}\n");
    let _ = writeln!(
        md,
        "| series | {} |",
        CLOTH_SIZES
            .map(|n| format!("N = {n} ({} nodes)", n * n))
            .join(" | ")
    );
    let _ = writeln!(md, "|---|---:|---:|---:|");
    for (name, t) in series {
        let _ = writeln!(md, "| {name} | {} |", t.map(fmt_time).join(" | "));
    }
    let _ = writeln!(md, "\nGrowth exponent in nodes (N²):\n");
    let names: Vec<&str> = series.iter().map(|s| s.0.as_str()).collect();
    let _ = writeln!(md, "| sizes | {} |", names.join(" | "));
    let _ = writeln!(md, "|---|{}", "---:|".repeat(names.len()));
    let nodes = CLOTH_SIZES.map(|n| (n * n) as f64);
    for i in 0..CLOTH_SIZES.len() - 1 {
        let cells: Vec<String> = series
            .iter()
            .map(|(_, t)| match (t[i], t[i + 1]) {
                (Some(a), Some(b)) => {
                    format!("{:.2}", (b / a).ln() / (nodes[i + 1] / nodes[i]).ln())
                }
                _ => "–".into(),
            })
            .collect();
        let _ = writeln!(
            md,
            "| {} → {} | {} |",
            CLOTH_SIZES[i],
            CLOTH_SIZES[i + 1],
            cells.join(" | ")
        );
    }
    let fits: Vec<String> = series
        .iter()
        .map(|(_, t)| {
            let pts: Vec<(f64, f64)> = nodes
                .iter()
                .zip(t)
                .filter_map(|(&n, t)| t.map(|t| (n, t)))
                .collect();
            if pts.len() < 3 {
                // Two sizes: the fit is the one slope above; one: none.
                return if pts.len() == 2 {
                    "(one pair)".into()
                } else {
                    "–".into()
                };
            }
            slope(&pts).map_or("–".into(), |s| format!("{s:.2}"))
        })
        .collect();
    let _ = writeln!(md, "| fit, all sizes | {} |\n", fits.join(" | "));
}

/// The cloth section of `target/bench/ratios.md`.
pub fn cloth_markdown(cloth: &Growth, kkt: &Growth) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "\n# Cloth: time per step and growth exponents\n\n\
         Same run, criterion medians, one core; N particles per side, N² nodes. Growth \
         exponent: slope of log(time) against log(nodes) between consecutive sizes, and \
         the least-squares fit over all sizes measured (1 = linear in the number of \
         particles; against N it is twice that).\n\n\
         - `cloth_implicit` (`cargo bench -p constraint-soft --bench cloth_step`): the \
         hanging cloth of `constraint_soft::Cloth` (1 m, 0.5 kg, springs 1e3 N/m, area \
         terms 1e5, two top corners pinned) stepped by the linearized implicit Euler \
         (`ImplicitEuler`, h = 1/60, projected Hessians); the cloth keeps moving through \
         the timed steps. `assemble`: the Hessian and right-hand side alone; `step_ldlt`: \
         the whole step with the sparse LDLᵀ; `step_lagged`: with CG preconditioned by a \
         lagged LDLᵀ factor (`LinearSolver::LaggedLdlt`); `step_cg`: with CG.\n\
         - `cloth_kkt` (`cargo bench -p constraint-lagrange --bench kkt_solvers`): one solve \
         of the velocity-level KKT system `[M Jᵀ; J 0]` of the inextensible cloth \
         (`scenes::inextensible_cloth`, structural edges hard, top edge pinned, h = 1/60): \
         `sparse_schur` (symbolic analysis reused: the steady-state cost) at every size, \
         `minres` up to N = 64, `gmres` and `dense_schur` (O(m³)) at N = 32 only, so \
         those have no exponent.\n"
    );
    growth_markdown(&mut md, "Implicit cloth step (`cloth_implicit`)", cloth);
    growth_markdown(&mut md, "Cloth KKT solve (`cloth_kkt`)", kkt);
    md
}

/// The cloth_step and kkt_solvers benches, then their series.
pub fn run(criterion_args: &[String]) -> Result<(Growth, Growth), String> {
    for (krate, bench) in [
        ("constraint-soft", "cloth_step"),
        ("constraint-lagrange", "kkt_solvers"),
    ] {
        let ok = cargo()
            .args(["bench", "-p", krate, "--bench", bench, "--"])
            .args(criterion_args)
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if !ok {
            return Err(format!("cargo bench -p {krate} --bench {bench} failed"));
        }
    }
    Ok((
        read_growth("cloth_implicit", &CLOTH_SERIES),
        read_growth("cloth_kkt", &KKT_SERIES),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cloth_tables_have_times_and_exponents_in_nodes() {
        let cloth: Growth = vec![
            // Time ∝ nodes: exponent 1.
            ("step_ldlt".into(), [Some(1e-3), Some(4e-3), Some(16e-3)]),
            ("gmres".into(), [Some(2e-3), None, None]),
            ("minres".into(), [Some(1e-3), Some(8e-3), None]),
        ];
        let md = cloth_markdown(&cloth, &Vec::new());
        assert!(
            md.contains(
                "| series | N = 32 (1024 nodes) | N = 64 (4096 nodes) | N = 128 (16384 nodes) |"
            ),
            "{md}"
        );
        assert!(
            md.contains("| step_ldlt | 1.000 ms | 4.000 ms | 16.000 ms |"),
            "{md}"
        );
        assert!(md.contains("| gmres | 2.000 ms | – | – |"), "{md}");
        assert!(md.contains("| 32 → 64 | 1.00 | – | 1.50 |"), "{md}");
        assert!(md.contains("| 64 → 128 | 1.00 | – | – |"), "{md}");
        assert!(
            md.contains("| fit, all sizes | 1.00 | – | (one pair) |"),
            "{md}"
        );
    }
}
