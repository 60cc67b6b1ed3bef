//! Time per KKT solve on the inextensible cloth's velocity-level system
//! `[M Jᵀ; J 0][v; λ] = [M v + hF; −C/h]` for N = 32, 64, 128 (structural edges hard):
//! sparse Schur (symbolic analysis reused: the steady-state cost) at every size, MINRES
//! on the whole system up to N = 64, GMRES and the dense Schur (O(m³)) at N = 32.
//!
//! `cargo bench -p constraint-lagrange --bench kkt_solvers` (`KKT_BENCH_SIZES=32,64`).

use constraint_core::DVec3;
use constraint_lagrange::scenes::inextensible_cloth;
use constraint_lagrange::solve::IterSettings;
use constraint_lagrange::{
    solve_kkt, ConstraintRows, KktProblem, KktSolver, KktWorkspace, MassMatrix,
};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::time::Duration;

struct Setup {
    mass: Vec<f64>,
    pinned: Vec<bool>,
    rows: ConstraintRows,
    zeros: Vec<f64>,
    b: Vec<DVec3>,
    c: Vec<f64>,
}

fn setup(n: usize) -> Setup {
    let (sys, cons) = match inextensible_cloth(n, 10.0) {
        Ok(s) => s,
        Err(e) => panic!("scene: {e}"),
    };
    // A state slightly off the constraints, moving: positions jittered by 1 % of a link.
    let dx = 1.0 / (n - 1) as f64;
    let x: Vec<DVec3> = sys
        .x
        .iter()
        .enumerate()
        .map(|(i, p)| {
            *p + DVec3::new(
                (i as f64 * 0.7).sin(),
                (i as f64 * 1.3).cos(),
                (i as f64 * 0.4).sin(),
            ) * (0.01 * dx)
        })
        .collect();
    let mut rows = ConstraintRows::new();
    cons.assemble(&x, &mut rows);
    rows.zero_columns(sys.pinned());
    let h = 1.0 / 60.0;
    let b: Vec<DVec3> = sys
        .masses()
        .iter()
        .zip(sys.pinned())
        .map(|(m, p)| {
            if *p {
                DVec3::ZERO
            } else {
                DVec3::new(0.0, 0.0, -9.81) * (m * h)
            }
        })
        .collect();
    let c = rows.value.iter().map(|v| -v / h).collect();
    Setup {
        mass: sys.masses().to_vec(),
        pinned: sys.pinned().to_vec(),
        zeros: vec![0.0; rows.len()],
        rows,
        b,
        c,
    }
}

fn sizes() -> Vec<usize> {
    std::env::var("KKT_BENCH_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|t| t.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![32, 64, 128])
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("cloth_kkt");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    let it = IterSettings {
        tolerance: 1e-10,
        max_iterations: 20_000,
    };
    for n in sizes() {
        let s = setup(n);
        let p = KktProblem {
            mass: MassMatrix::Diagonal {
                mass: &s.mass,
                pinned: &s.pinned,
            },
            rows: &s.rows,
            compliance: &s.zeros,
            b: &s.b,
            c: &s.c,
        };
        // Unpreconditioned Krylov solvers on the saddle-point system need thousands of
        // iterations here (measured GMRES(50): 2.3 s at N = 32, 9.8 s at N = 64, 42 s at
        // N = 128; MINRES 2.1 s at N = 128): they are timed where that fits a bench run.
        let mut solvers = vec![("sparse_schur", KktSolver::SparseSchur)];
        if n <= 64 {
            solvers.push(("minres", KktSolver::Minres(it)));
        }
        if n <= 32 {
            let gmres = KktSolver::Gmres {
                restart: 50,
                settings: it,
            };
            solvers.push(("gmres", gmres));
            solvers.push(("dense_schur", KktSolver::DenseSchur));
        }
        for (name, solver) in solvers {
            let mut ws = KktWorkspace::default();
            let mut x = vec![DVec3::ZERO; s.mass.len()];
            let mut l = vec![0.0; s.rows.len()];
            g.bench_with_input(BenchmarkId::new(name, n), &n, |bch, _| {
                bch.iter(|| {
                    x.fill(DVec3::ZERO);
                    l.fill(0.0);
                    match solve_kkt(&p, solver, &mut ws, &mut x, &mut l) {
                        Ok(st) => st.residual,
                        Err(e) => panic!("{name}: {e}"),
                    }
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
