//! Momentum of free soft bodies under every integrator (no pins, no gravity).
//!
//! * Linear momentum: internal forces sum to zero and the implicit matrix's
//!   translation null space is preserved, so every integrator conserves `Σ m v` up to
//!   round-off (and, for CG, up to its residual).
//! * Angular momentum: symplectic Euler conserves `Σ m x × v` exactly in exact
//!   arithmetic (`L⁺ = L + h Σ x × F(x)` and internal torques vanish), so it is checked
//!   to round-off. The linearized implicit step does not conserve it; its drift is
//!   printed and gated only as a regression bound, not as a conservation law — except
//!   with the Gauss–Newton Hessian, whose rows `k∇C∇Cᵀv` exert no torque, so that
//!   step conserves angular momentum as well (measured, and gated to round-off).
//!
//! `cargo test -p constraint-verify --test momentum -- --nocapture` prints the drifts.

use constraint_scene::soft::{free_cloth, free_jelly, momentum_drift};
use constraint_soft::{
    CgSettings, HessianMode, ImplicitEuler, Integrator, LinearSolver, SoftSystem, SymplecticEuler,
};
use constraint_verify::fd::exceeds;

fn integrators() -> Vec<Box<dyn Integrator>> {
    let cg = LinearSolver::ConjugateGradient(CgSettings {
        tolerance: 1e-13,
        max_iterations: 10_000,
    });
    vec![
        Box::new(SymplecticEuler::new(2e-4).expect("h")),
        Box::new(
            ImplicitEuler::new(1e-2, HessianMode::Projected, LinearSolver::SparseLdlt).expect("h"),
        ),
        Box::new(
            ImplicitEuler::new(1e-2, HessianMode::Exact, LinearSolver::SparseLdlt).expect("h"),
        ),
        Box::new(ImplicitEuler::new(1e-2, HessianMode::GaussNewton, cg).expect("h")),
        Box::new(ImplicitEuler::new(1e-2, HessianMode::Projected, cg).expect("h")),
    ]
}

fn run(scene: &str, make: fn(u64) -> SoftSystem, seed: u64, gates: &[(f64, f64)]) {
    let mut failed = Vec::new();
    for (k, mut integ) in integrators().into_iter().enumerate() {
        let (dp, dl) = momentum_drift(make(seed), integ.as_mut(), 0.5).expect("steps");
        let (gp, gl) = gates[k];
        let line = format!(
            "{scene:6} {:42} linear drift {dp:.2e} (gate {gp:.0e})  angular drift {dl:.2e} (gate {gl:.0e})",
            integ.name()
        );
        println!("{line}");
        if exceeds(dp, gp) || exceeds(dl, gl) {
            failed.push(line);
        }
    }
    assert!(failed.is_empty(), "gates exceeded:\n{}", failed.join("\n"));
}

// Gates per integrator, in the order of `integrators()`: (linear, angular). Linear is a
// conservation law for all; angular only for symplectic Euler (first row), the others
// are regression bounds on a reported drift.
#[test]
fn cloth_momentum() {
    run(
        "cloth",
        |seed| free_cloth(6, seed).expect("cloth"),
        11,
        &[
            // measured 1.9e-16, 4.2e-16: both conserved
            (2e-15, 5e-15),
            // measured 4.6e-15, 3.5e-2 (angular drift reported, not conserved)
            (5e-14, 0.1),
            // measured 9.6e-9, 3.4e1: the exact, indefinite Hessian makes this step
            // unstable on the cloth (|b| grows to 3e7; see the stability map). Linear
            // momentum then holds only to the accuracy of LDLᵀ on a growing, badly
            // conditioned system, which depends on rounding (1.2e-4 when the ordering
            // was forced to nested dissection); angular momentum is deliberately not
            // gated here — the divergence itself is what the stability map reports
            (1e-7, f64::INFINITY),
            // measured 2.7e-13, 1.7e-13: Gauss–Newton keeps only ∇C∇Cᵀ, whose rows exert
            // no torque, so this step conserves angular momentum too
            (3e-12, 2e-12),
            // measured 3.5e-13, 3.5e-2
            (4e-12, 0.1),
        ],
    );
}

#[test]
fn jelly_momentum() {
    run(
        "jelly",
        |seed| free_jelly(seed).expect("jelly"),
        12,
        &[
            // measured 5.2e-16, 2.9e-15
            (5e-15, 3e-14),
            // measured 2.3e-15, 4.6e-2
            (4e-14, 0.1),
            // measured 3.1e-15, 8.3e-2
            (4e-14, 0.2),
            // measured 1.6e-13, 2.9e-13
            (2e-12, 3e-12),
            // measured 3.7e-14, 4.6e-2
            (4e-13, 0.1),
        ],
    );
}
