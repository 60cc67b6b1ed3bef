//! Time per step of the hanging cloth for N = 32, 64, 128: assembly alone, and the whole
//! linearized implicit Euler step with sparse LDLᵀ and with CG.
//!
//! `cargo bench -p constraint-soft --bench cloth_step` (or `cargo xtask bench`).

use constraint_soft::{
    CgSettings, Cloth, HessianMode, ImplicitEuler, Integrator, LinearSolver, SoftSystem,
};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::time::Duration;

const H: f64 = 1.0 / 60.0;

fn cloth(n: usize) -> SoftSystem {
    match (Cloth {
        n,
        ..Cloth::default()
    })
    .build()
    {
        Ok(s) => s,
        Err(e) => panic!("cloth scene: {e}"),
    }
}

fn sizes() -> Vec<usize> {
    std::env::var("CLOTH_BENCH_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|t| t.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![32, 64, 128])
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("cloth_implicit");
    g.sample_size(10).measurement_time(Duration::from_secs(4));
    for n in sizes() {
        let mut sys = cloth(n);
        let mut asm = ImplicitEuler::new(H, HessianMode::Projected, LinearSolver::SparseLdlt)
            .expect("valid step");
        g.bench_with_input(BenchmarkId::new("assemble", n), &n, |b, _| {
            b.iter(|| asm.assemble(&mut sys).expect("assemble"))
        });
        for (name, solver) in [
            ("step_ldlt", LinearSolver::SparseLdlt),
            (
                "step_lagged",
                LinearSolver::LaggedLdlt(constraint_soft::lagged::LaggedSettings::default()),
            ),
            (
                "step_cg",
                LinearSolver::ConjugateGradient(CgSettings::default()),
            ),
        ] {
            let mut sys = cloth(n);
            let mut step =
                ImplicitEuler::new(H, HessianMode::Projected, solver).expect("valid step");
            g.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| step.step(&mut sys).expect("step"))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
