//! Arbitrary small KKT problems `[A Jᵀ; J −D][x; λ] = [b; c]` — rank-deficient `J`
//! (repeated and zero rows), singular or non-positive masses, non-finite entries,
//! mismatched lengths — through every `KktSolver`: a typed error or a finite solution.
#![no_main]

use arbitrary::Arbitrary;
use constraint_core::DVec3;
use constraint_lagrange::solve::IterSettings;
use constraint_lagrange::{
    solve_kkt, ConstraintRows, KktProblem, KktSolver, KktWorkspace, MassMatrix,
};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Row {
    value: f64,
    entries: Vec<(u8, [f64; 3])>,
    repeat: bool,
}

#[derive(Arbitrary, Debug)]
struct Input {
    mass: Vec<f64>,
    pinned: Vec<bool>,
    rows: Vec<Row>,
    compliance: Vec<f64>,
    b: Vec<[f64; 3]>,
    c: Vec<f64>,
    solver: u8,
    param: f64,
}

fuzz_target!(|inp: Input| {
    let n = inp.mass.len().min(6);
    let mass = &inp.mass[..n];
    let pinned: Vec<bool> = (0..n)
        .map(|i| inp.pinned.get(i).copied().unwrap_or(false))
        .collect();
    let mut rows = ConstraintRows::new();
    for r in inp.rows.iter().take(8) {
        let e: Vec<(usize, DVec3)> = r
            .entries
            .iter()
            .take(3)
            .map(|(i, g)| (*i as usize % (n + 1), DVec3::from_array(*g)))
            .collect();
        rows.push_row(r.value, &e);
        if r.repeat {
            rows.push_row(r.value, &e);
        }
    }
    let m = rows.len();
    let fit = |v: &[f64], k: usize| -> Vec<f64> {
        (0..k).map(|i| v.get(i).copied().unwrap_or(0.0)).collect()
    };
    let compliance = fit(&inp.compliance, m);
    let c = fit(&inp.c, m);
    let b: Vec<DVec3> = (0..n)
        .map(|i| DVec3::from_array(inp.b.get(i).copied().unwrap_or([0.0; 3])))
        .collect();
    let it = IterSettings {
        tolerance: 1e-10,
        max_iterations: 200,
    };
    let solver = match inp.solver % 8 {
        0 => KktSolver::Auto,
        1 => KktSolver::DenseSchur,
        2 => KktSolver::SparseSchur,
        3 => KktSolver::Minres(it),
        4 => KktSolver::Gmres {
            restart: 10,
            settings: it,
        },
        5 => KktSolver::Svd {
            rank_tol: inp.param,
        },
        6 => KktSolver::DampedLeastSquares { damping: inp.param },
        _ => KktSolver::Minres(IterSettings {
            tolerance: inp.param,
            max_iterations: 50,
        }),
    };
    let p = KktProblem {
        mass: MassMatrix::Diagonal {
            mass,
            pinned: &pinned,
        },
        rows: &rows,
        compliance: &compliance,
        b: &b,
        c: &c,
    };
    let mut ws = KktWorkspace::default();
    let mut x = vec![DVec3::ZERO; n];
    let mut lambda = vec![0.0; m];
    if solve_kkt(&p, solver, &mut ws, &mut x, &mut lambda).is_ok() {
        // `solve_kkt` checks its inputs and outputs for finiteness: an `Ok` is finite
        // whatever the input (non-finite, zero, overflowing or ill-scaled).
        assert!(x.iter().all(|v| v.is_finite()), "non-finite x on Ok");
        assert!(
            lambda.iter().all(|v| v.is_finite()),
            "non-finite lambda on Ok"
        );
    }
});
