//! The four formulations on scenes with known answers, solver agreement, redundancy
//! and bad input. `cargo test -p constraint-lagrange --test formulations -- --nocapture`
//! prints the measured values written beside each gate.

use constraint_core::{DVec3, Distance};
use constraint_lagrange::scenes::{chain, inextensible_cloth};
use constraint_lagrange::solve::IterSettings;
use constraint_lagrange::{
    AccelerationLevel, BaseStep, Baumgarte, Constraints, FastProjection, HardSet, KktSolver,
    LagrangeError, ProjectedStep, Rattle, RattleOrder, VelocityLevel,
};
use constraint_soft::{
    ConstraintSet, HessianMode, ImplicitEuler, Integrator, LinearSolver, SoftSystem, Softness,
    SymplecticEuler,
};

const G: f64 = 9.81;

fn solvers() -> Vec<(&'static str, KktSolver)> {
    let it = IterSettings {
        tolerance: 1e-13,
        max_iterations: 10_000,
    };
    vec![
        ("dense Schur", KktSolver::DenseSchur),
        ("sparse Schur", KktSolver::SparseSchur),
        ("MINRES", KktSolver::Minres(it)),
        (
            "GMRES",
            KktSolver::Gmres {
                restart: 40,
                settings: it,
            },
        ),
        ("SVD", KktSolver::Svd { rank_tol: 1e-12 }),
    ]
}

/// Period from upward zero crossings of `x` of the bob.
fn period(xs: &[(f64, f64)]) -> f64 {
    let mut cross = Vec::new();
    for w in xs.windows(2) {
        let ((t0, a), (t1, b)) = (w[0], w[1]);
        if a < 0.0 && b >= 0.0 {
            cross.push(t0 + (t1 - t0) * (-a) / (b - a));
        }
    }
    (cross[cross.len() - 1] - cross[0]) / (cross.len() - 1) as f64
}

#[test]
fn pendulum_period_matches_small_angle_theory() {
    let theta0: f64 = 0.05;
    // T = 2π√(L/g) (1 + θ₀²/16 + …)
    let exact = 2.0 * std::f64::consts::PI * (1.0 / G).sqrt() * (1.0 + theta0 * theta0 / 16.0);
    let h = 1e-3;
    let mut rows = Vec::new();
    let (mut sys, cons) = chain(1, 1.0, 1.0, theta0).expect("scene");
    let mut step = VelocityLevel::new(h, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
    let mut xs = Vec::new();
    let mut cmax: f64 = 0.0;
    for k in 0..8000 {
        step.step(&mut sys, &cons).expect("step");
        xs.push(((k + 1) as f64 * h, sys.x[1].x));
        cmax = cmax.max(((sys.x[1] - sys.x[0]).length() - 1.0).abs());
    }
    let rel = (period(&xs) - exact).abs() / exact;
    rows.push(format!(
        "velocity level: period error {rel:.2e}, max |C| {cmax:.2e}"
    ));
    println!("{}", rows.join("\n"));
    // measured 3.8e-7; gate 4e-6
    assert!(rel < 4e-6, "period error {rel}");
    // measured 1.2e-8 m; gate 1.2e-7 m
    assert!(cmax < 1.2e-7, "max |C| {cmax}");
}

/// Runs a 10-link chain for `secs` and returns max |C| over the run.
fn chain_drift(secs: f64, mut f: impl FnMut(&mut SoftSystem, &Constraints)) -> f64 {
    let (mut sys, cons) = chain(10, 0.1, 0.1, 1.0).expect("scene");
    let h = 1e-3;
    let mut cmax: f64 = 0.0;
    for _ in 0..(secs / h) as usize {
        f(&mut sys, &cons);
        for i in 0..10 {
            cmax = cmax.max(((sys.x[i + 1] - sys.x[i]).length() - 0.1).abs());
        }
    }
    cmax
}

#[test]
fn drift_without_baumgarte_and_its_cures() {
    let h = 1e-3;
    let mut a0 = AccelerationLevel::new(h, Baumgarte::NONE, KktSolver::DenseSchur).expect("h");
    let no_bg = chain_drift(2.0, |s, c| {
        a0.step(s, c).expect("step");
    });
    let mut a1 = AccelerationLevel::new(
        h,
        Baumgarte::critical(0.01).expect("tau"),
        KktSolver::DenseSchur,
    )
    .expect("h");
    let bg = chain_drift(2.0, |s, c| {
        a1.step(s, c).expect("step");
    });
    let mut vl = VelocityLevel::new(h, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
    let vel = chain_drift(2.0, |s, c| {
        vl.step(s, c).expect("step");
    });
    let mut pr = ProjectedStep::new(
        SymplecticEuler::new(h).expect("h"),
        FastProjection::new(1e-12, 20, KktSolver::DenseSchur).expect("tol"),
    );
    let proj = chain_drift(2.0, |s, c| {
        pr.step(s, c).expect("step");
    });
    println!("max |C| over 2 s (m): acceleration {no_bg:.2e}, + Baumgarte {bg:.2e}, velocity {vel:.2e}, projection {proj:.2e}");
    // measured: acceleration 5.6e-3 m (drifts), Baumgarte 5.2e-4, velocity 2.8e-5,
    // projection 7.5e-14 (relative tolerance 1e-12 of 0.1 m links)
    assert!(
        no_bg > 5.0 * bg,
        "Baumgarte must reduce the drift: {no_bg} vs {bg}"
    );
    assert!(bg < 5e-3 && vel < 3e-4, "{bg} {vel}");
    assert!(proj < 1e-12, "{proj}");
}

#[test]
fn every_solver_agrees_with_the_dense_schur_solve() {
    let mut worst = 0.0f64;
    for (name, solver) in solvers() {
        let (mut sa, cons) = chain(12, 0.1, 0.1, 0.7).expect("scene");
        let (mut sb, _) = chain(12, 0.1, 0.1, 0.7).expect("scene");
        let mut ra =
            VelocityLevel::new(1e-2, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
        let mut rb = VelocityLevel::new(1e-2, BaseStep::Explicit, solver).expect("h");
        for _ in 0..20 {
            ra.step(&mut sa, &cons).expect("dense");
            let st = rb.step(&mut sb, &cons).expect("solver");
            // measured ≤ 2e-15 (direct) and ≤ 1e-13 (iterative); gate 1e-11
            assert!(st.residual < 1e-11, "{name}: KKT residual {}", st.residual);
        }
        let dv: f64 =
            sa.v.iter()
                .zip(&sb.v)
                .map(|(a, b)| (*a - *b).length())
                .fold(0.0, f64::max);
        let vmax = sa.v.iter().map(|v| v.length()).fold(0.0, f64::max);
        let l_err = ra
            .multipliers()
            .iter()
            .zip(rb.multipliers())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / ra.multipliers().iter().map(|l| l.abs()).fold(0.0, f64::max);
        let rel = (dv / vmax).max(l_err);
        println!("{name:12} relative difference after 20 steps: {rel:.2e}");
        worst = worst.max(rel);
    }
    // measured 3.2e-12 (iterative solvers, accumulated over 20 steps); gate 1e-10
    assert!(worst < 1e-10, "{worst}");
}

#[test]
fn constraint_impulse_does_no_work_along_the_manifold() {
    // From configurations on the manifold (C = 0 to round-off), the velocity-level
    // solution satisfies J v = 0 and the impulse −Jᵀλ is normal to it: vᵀJᵀλ = 0.
    let mut worst = 0.0f64;
    for k in 0..50 {
        let angle = -1.5 + 3.0 * (k as f64) / 49.0;
        let (mut sys, cons) = chain(5, 0.2, 0.3, angle).expect("scene");
        let v: Vec<DVec3> = (0..6)
            .map(|i| DVec3::new((i as f64 * 0.7 + angle).sin(), 0.3, (i as f64 * 1.3).cos()))
            .collect();
        sys.set_velocities(&v).expect("finite");
        let mut step =
            VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
        step.step(&mut sys, &cons).expect("step");
        let rows = step.rows();
        let mut jv = vec![0.0; rows.len()];
        rows.mul(&sys.v, &mut jv);
        let power: f64 = jv.iter().zip(step.multipliers()).map(|(a, b)| a * b).sum();
        let scale: f64 = step.multipliers().iter().map(|l| l.abs()).sum::<f64>()
            * sys.v.iter().map(|v| v.length()).fold(0.0, f64::max);
        worst = worst.max(power.abs() / scale);
    }
    println!("|vᵀJᵀλ| / (Σ|λ| max|v|) over 50 configurations: {worst:.2e}");
    // measured 4.4e-14; gate 5e-13
    assert!(worst < 5e-13, "{worst}");
}

#[test]
fn compliance_one_over_k_reproduces_the_soft_spring() {
    let k = 3e4;
    let h = 1e-2;
    let x = vec![DVec3::ZERO, DVec3::new(0.3, 0.0, -1.1)];
    let make = || {
        let mut s = SoftSystem::new(x.clone(), vec![1.0, 0.5]).expect("system");
        s.pin(0).expect("pin");
        s
    };
    let spring = Distance::new(0, 1, 1.0).expect("spring");
    let mut soft = make();
    soft.add_set(ConstraintSet::uniform("s", vec![spring], Softness::stiff(k)).expect("set"))
        .expect("add");
    let mut imp =
        ImplicitEuler::new(h, HessianMode::GaussNewton, LinearSolver::SparseLdlt).expect("h");
    let mut hard = make();
    let mut cons = Constraints::new();
    cons.add(HardSet::compliant("s", vec![spring], vec![1.0 / k]).expect("set"));
    let mut vl = VelocityLevel::new(h, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
    let mut worst = 0.0f64;
    for _ in 0..300 {
        imp.step(&mut soft).expect("soft");
        vl.step(&mut hard, &cons).expect("compliant");
        worst = worst.max((soft.x[1] - hard.x[1]).length());
    }
    println!("max |x_soft − x_compliant| over 3 s: {worst:.2e} m");
    // measured 4.4e-15 m; gate 1e-12 m
    assert!(worst < 1e-12, "{worst}");
}

#[test]
fn redundant_constraints_give_finite_minimum_norm_multipliers() {
    // The pendulum link twice: J has two identical rows, J M⁻¹ Jᵀ is singular.
    let (mut a, cons1) = chain(1, 1.0, 1.0, 0.3).expect("scene");
    let (mut b, _) = chain(1, 1.0, 1.0, 0.3).expect("scene");
    let link = Distance::new(0, 1, 1.0).expect("link");
    let mut cons2 = Constraints::new();
    cons2.add(HardSet::hard("twice", vec![link, link]));
    for solver in [
        KktSolver::DenseSchur,
        KktSolver::Svd { rank_tol: 1e-12 },
        KktSolver::DampedLeastSquares { damping: 1e-9 },
    ] {
        let mut s1 =
            VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
        let mut s2 = VelocityLevel::new(1e-3, BaseStep::Explicit, solver).expect("h");
        let (mut a, mut b) = (a.x.clone(), b.x.clone());
        let _ = (&mut a, &mut b);
        let (mut sa, _) = chain(1, 1.0, 1.0, 0.3).expect("scene");
        let (mut sb, _) = chain(1, 1.0, 1.0, 0.3).expect("scene");
        for _ in 0..100 {
            s1.step(&mut sa, &cons1).expect("single");
            let st = s2.step(&mut sb, &cons2).expect("redundant");
            assert!(st.residual < 1e-8, "{solver:?}: residual {}", st.residual);
        }
        let l = s2.multipliers();
        assert!(l.iter().all(|x| x.is_finite()));
        let split = (l[0] - l[1]).abs() / l[0].abs();
        let total = ((l[0] + l[1]) - s1.multipliers()[0]).abs() / s1.multipliers()[0].abs();
        let dx = (sa.x[1] - sb.x[1]).length();
        println!("{solver:?}: λ split {split:.1e}, λ sum vs single {total:.1e}, |Δx| {dx:.1e}");
        // measured split ≤ 1e-15, sum ≤ 1e-12, |Δx| ≤ 1e-15; gates 1e-9, 1e-7, 1e-12
        assert!(
            split < 1e-9 && total < 1e-7 && dx < 1e-12,
            "{split} {total} {dx}"
        );
    }
    let _ = (&mut a, &mut b);
}

#[test]
fn inextensible_cloth_meets_the_strain_tolerance_every_step() {
    let (mut sys, cons) = inextensible_cloth(12, 10.0).expect("scene");
    let h = 1.0 / 60.0;
    let mut step = ProjectedStep::new(
        ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt).expect("h"),
        FastProjection::new(1e-3, 50, KktSolver::SparseSchur).expect("tol"),
    );
    let links = constraint_lagrange::scenes::structural_links(12, &sys.x).expect("links");
    let mut iters = 0;
    let mut worst: f64 = 0.0;
    for _ in 0..60 {
        let st = step.step(&mut sys, &cons).expect("step");
        assert!(st.converged, "projection did not converge: {st:?}");
        iters += st.iterations;
        // Strain measured independently of the projection's own bookkeeping.
        for d in &links {
            let l = (sys.x[d.points[0]] - sys.x[d.points[1]]).length();
            worst = worst.max((l / d.rest_length - 1.0).abs());
        }
    }
    println!(
        "mean iterations {:.2}, worst final strain {worst:.2e}",
        iters as f64 / 60.0
    );
    assert!(worst <= 1e-3);
    // measured mean 1.28 iterations; gate 5 (Goldenthal et al. report a few)
    assert!((iters as f64 / 60.0) <= 5.0, "{iters}");
}

#[test]
fn implicit_soft_base_mixes_with_hard_constraints() {
    // A soft cloth (implicit) whose top row is held by hard links to pinned anchors.
    let (mut sys, cons) = inextensible_cloth(6, 50.0).expect("scene");
    let h = 1e-2;
    let imp = ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt).expect("h");
    let mut step = VelocityLevel::new(
        h,
        BaseStep::Implicit(Box::new(imp)),
        KktSolver::Minres(IterSettings::default()),
    )
    .expect("h");
    let mut cmax: f64 = 0.0;
    for _ in 0..100 {
        let st = step.step(&mut sys, &cons).expect("step");
        assert!(st.converged, "{st:?}");
        cmax = cmax.max(step.rows().max_violation());
    }
    println!("max |C| with implicit soft base + hard rows (MINRES): {cmax:.2e} m");
    // measured 4.2e-3 m (velocity level: O(h²) drift per step); gate 2e-2 m, links 0.2 m
    assert!(cmax < 2e-2, "{cmax}");
    assert!(matches!(
        VelocityLevel::new(
            h,
            BaseStep::Implicit(Box::new(
                ImplicitEuler::new(2.0 * h, HessianMode::Projected, LinearSolver::SparseLdlt)
                    .expect("h")
            )),
            KktSolver::DenseSchur
        ),
        Err(LagrangeError::InvalidTimeStep)
    ));
}

#[test]
fn bad_input_is_a_typed_error() {
    // Every StepError of the one check (constraint_core::StepContext::new) maps to
    // InvalidTimeStep: zero of either sign, negative, NaN, ±inf, below MIN_STEP.
    let bad = [
        0.0,
        -0.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e-160,
    ];
    for h in bad {
        assert!(matches!(
            VelocityLevel::new(h, BaseStep::Explicit, KktSolver::DenseSchur),
            Err(LagrangeError::InvalidTimeStep)
        ));
        assert!(matches!(
            AccelerationLevel::new(h, Baumgarte::NONE, KktSolver::DenseSchur),
            Err(LagrangeError::InvalidTimeStep)
        ));
        for order in [RattleOrder::Second, RattleOrder::Fourth] {
            assert!(matches!(
                Rattle::new(h, order, 1e-10, 40, KktSolver::DenseSchur),
                Err(LagrangeError::InvalidTimeStep)
            ));
        }
    }
    assert!(matches!(
        AccelerationLevel::new(1e-3, Baumgarte { kx: -1.0, kv: 0.0 }, KktSolver::DenseSchur),
        Err(LagrangeError::InvalidParameter(_))
    ));
    assert!(matches!(
        AccelerationLevel::new(
            1e-3,
            Baumgarte {
                kx: 0.0,
                kv: f64::NAN
            },
            KktSolver::DenseSchur
        ),
        Err(LagrangeError::InvalidParameter(_))
    ));
    for t in [0.0, -1.0, f64::NAN] {
        assert!(FastProjection::new(t, 10, KktSolver::DenseSchur).is_err());
    }
    let link = Distance::new(0, 1, 1.0).expect("link");
    assert!(HardSet::compliant("c", vec![link], vec![-1.0]).is_err());
    assert!(HardSet::compliant("c", vec![link], vec![f64::NAN]).is_err());
    assert!(HardSet::compliant("c", vec![link], vec![]).is_err());
    // A constraint naming a particle the system lacks.
    let (mut sys, _) = chain(1, 1.0, 1.0, 0.0).expect("scene");
    let mut cons = Constraints::new();
    cons.add(HardSet::hard(
        "far",
        vec![Distance::new(0, 9, 1.0).expect("c")],
    ));
    let x0 = sys.x.clone();
    let mut step = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
    assert!(matches!(
        step.step(&mut sys, &cons),
        Err(LagrangeError::IndexOutOfBounds { needed: 10, len: 2 })
    ));
    assert_eq!(sys.x, x0);
    // Schur solvers need a diagonal A.
    let (mut sys, cons) = chain(2, 1.0, 1.0, 0.2).expect("scene");
    let imp =
        ImplicitEuler::new(1e-2, HessianMode::Projected, LinearSolver::SparseLdlt).expect("h");
    let mut step = VelocityLevel::new(
        1e-2,
        BaseStep::Implicit(Box::new(imp)),
        KktSolver::DenseSchur,
    )
    .expect("h");
    assert!(matches!(
        step.step(&mut sys, &cons),
        Err(LagrangeError::Kkt(
            constraint_lagrange::KktError::NeedsDiagonalMass
        ))
    ));
    for tau in [0.0, -1.0, f64::NAN, 1e-200] {
        assert!(matches!(
            Baumgarte::critical(tau),
            Err(LagrangeError::InvalidParameter("tau"))
        ));
    }
    // Solver parameters out of range are typed errors at the first solve.
    let bad_solvers = [
        (KktSolver::Svd { rank_tol: -1.0 }, "rank_tol"),
        (
            KktSolver::DampedLeastSquares { damping: f64::NAN },
            "damping",
        ),
        (
            KktSolver::Gmres {
                restart: 0,
                settings: IterSettings::default(),
            },
            "restart",
        ),
        (
            KktSolver::Minres(IterSettings {
                tolerance: 0.0,
                max_iterations: 10,
            }),
            "tolerance",
        ),
    ];
    for (solver, name) in bad_solvers {
        let (mut sys, cons) = chain(2, 0.1, 0.1, 0.2).expect("scene");
        let mut step = VelocityLevel::new(1e-3, BaseStep::Explicit, solver).expect("h");
        assert!(
            matches!(
                step.step(&mut sys, &cons),
                Err(LagrangeError::Kkt(constraint_lagrange::KktError::InvalidSolver(p))) if p == name
            ),
            "{name}"
        );
    }
}

#[test]
fn ill_conditioned_chain_reports_its_residual() {
    // Mass ratio 1e6 along the chain.
    let (mut sys, cons) = chain(8, 0.1, 1.0, 0.5).expect("scene");
    let heavy = SoftSystem::new(
        sys.x.clone(),
        (0..9).map(|i| if i == 8 { 1e6 } else { 1.0 }).collect(),
    )
    .expect("system");
    sys = heavy;
    sys.pin(0).expect("pin");
    let tight = IterSettings {
        tolerance: 1e-14,
        max_iterations: 5,
    };
    let mut step =
        VelocityLevel::new(1e-2, BaseStep::Explicit, KktSolver::Minres(tight)).expect("h");
    let st = step.step(&mut sys, &cons).expect("step");
    println!(
        "MINRES, 5 iterations, mass ratio 1e6: converged {}, residual {:.2e}",
        st.converged, st.residual
    );
    assert!(!st.converged && st.residual > 1e-14);
    let mut direct =
        VelocityLevel::new(1e-2, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
    let st = direct.step(&mut sys, &cons).expect("step");
    println!("dense Schur, mass ratio 1e6: residual {:.2e}", st.residual);
    // measured 1.1e-16; gate 1e-12
    assert!(st.converged && st.residual < 1e-12);
}

#[allow(dead_code)]
fn integrator_name<I: Integrator>(i: &I) -> String {
    i.name()
}

#[test]
fn hard_one_ring_volumes_hold_to_one_part_per_million() {
    let (mut sys, cons, rings) =
        constraint_lagrange::scenes::hard_volume_jelly(100.0).expect("scene");
    let h = 1.0 / 60.0;
    let imp = ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt).expect("h");
    let mut step = ProjectedStep::new(
        imp,
        FastProjection::new(1e-7, 30, KktSolver::SparseSchur).expect("tol"),
    );
    let mut worst = 0.0f64;
    let mut iters = 0;
    let mut sag = 0.0f64;
    for _ in 0..60 {
        let st = step.step(&mut sys, &cons).expect("step");
        assert!(st.converged, "{st:?}");
        iters += st.iterations;
        worst = worst.max(rings.max_relative_error(&sys.x));
        sag = sag.max(-sys.x.iter().map(|x| x.z).fold(f64::INFINITY, f64::min));
    }
    println!(
        "{} rings: worst relative ring-volume error {worst:.2e}, {:.2} projection iterations/step, lowest point {:.2e} m below its start",
        rings.len(),
        iters as f64 / 60.0,
        sag
    );
    // measured 6.1e-8 (projection tolerance 1e-7); gate 1e-6 (the bound)
    assert!(worst <= 1e-6, "{worst}");
    // The block must actually deform: with soft 100 N/m springs it sags (measured
    // 1.2e-2 m over 1 s).
    assert!(sag > 1e-3, "{sag}");
}

#[test]
fn cloth_hinges_cover_every_interior_edge_once() {
    use constraint_lagrange::scenes::{add_bending, cloth_hinges};
    for n in [2usize, 3, 5, 8] {
        let hinges = cloth_hinges(n);
        // A triangulated n×n grid has 3(n−1)² + 2(n−1) edges, 4(n−1) on the boundary.
        assert_eq!(hinges.len(), 3 * (n - 1) * (n - 1) - 2 * (n - 1), "n = {n}");
        let mut edges: Vec<(usize, usize)> = hinges
            .iter()
            .map(|h| (h[0].min(h[1]), h[0].max(h[1])))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        assert_eq!(edges.len(), hinges.len(), "an edge hinged twice (n = {n})");
        let (mut sys, _) = inextensible_cloth(n, 1.0).expect("scene");
        add_bending(&mut sys, n, 1e-2).expect("flat hinges are valid");
    }
}

#[test]
fn auto_solver_picks_by_size_and_structure() {
    let h = 1e-2;
    let mut small = VelocityLevel::new(h, BaseStep::Explicit, KktSolver::Auto).expect("h");
    let (mut sys, cons) = chain(5, 0.1, 0.1, 0.3).expect("scene");
    let st = small.step(&mut sys, &cons).expect("step");
    assert_eq!(st.chosen, Some(KktSolver::DenseSchur));
    let (mut sys, cons) = inextensible_cloth(16, 1.0).expect("scene");
    let mut big = VelocityLevel::new(h, BaseStep::Explicit, KktSolver::Auto).expect("h");
    let st = big.step(&mut sys, &cons).expect("step");
    assert!(cons.rows() > constraint_lagrange::kkt::AUTO_DENSE_ROWS);
    assert_eq!(st.chosen, Some(KktSolver::SparseSchur));
    let (mut sys, cons) = chain(3, 0.1, 0.1, 0.3).expect("scene");
    let imp = ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt).expect("h");
    let mut block =
        VelocityLevel::new(h, BaseStep::Implicit(Box::new(imp)), KktSolver::Auto).expect("h");
    let st = block.step(&mut sys, &cons).expect("step");
    assert!(matches!(st.chosen, Some(KktSolver::Minres(_))));
    // MINRES default tolerance 1e-10 (its converged flag means residual ≤ 1e-10); gate 1e-8
    assert!(st.converged && st.residual < 1e-8, "{st:?}");
}

#[test]
fn nan_states_and_bad_parameters_are_not_reported_as_converged() {
    let (sys, cons) = chain(3, 0.1, 0.1, 0.3).expect("scene");
    let mut x = sys.x.clone();
    x[2].x = f64::NAN;
    let mut p = FastProjection::new(1e-6, 10, KktSolver::DenseSchur).expect("tol");
    // A NaN position is a typed error (it was an `Ok` marked not converged with a NaN
    // residual until the bad-input sweep of issue 7 asked for errors).
    let r = p.project(sys.masses(), sys.pinned(), &cons, &mut x);
    assert!(
        matches!(
            r,
            Err(LagrangeError::Kkt(constraint_lagrange::KktError::Solve(
                constraint_lagrange::solve::SolveError::NonFinite
            )))
        ),
        "{r:?}"
    );
    assert!(matches!(
        FastProjection::new(1e-3, 0, KktSolver::DenseSchur),
        Err(LagrangeError::InvalidParameter("max_iterations"))
    ));
    assert!(constraint_lagrange::scenes::structural_links(0, &[]).is_err());
    assert!(constraint_lagrange::scenes::structural_links(1, &[DVec3::ZERO]).is_err());
    // Resizing the public state away from the particle count is a typed error.
    let (mut sys, cons) = chain(2, 0.1, 0.1, 0.3).expect("scene");
    sys.x.push(DVec3::ZERO);
    let mut step = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
    assert!(matches!(
        step.step(&mut sys, &cons),
        Err(LagrangeError::Soft(
            constraint_soft::SoftError::LengthMismatch
        ))
    ));
    let mut se = SymplecticEuler::new(1e-3).expect("h");
    assert_eq!(
        se.step(&mut sys).unwrap_err(),
        constraint_soft::SoftError::LengthMismatch
    );
}

/// The double pendulum (two equal beads on equal links) released in one of its
/// small-angle normal modes swings at that mode's frequency:
/// `ω² = (2 ∓ √2) g/L` with `θ₂/θ₁ = ±√2`.
#[test]
fn double_pendulum_normal_modes_match_theory() {
    let l = 0.5;
    let amp = 0.01;
    for (sign, name) in [(1.0f64, "slow"), (-1.0, "fast")] {
        let omega2 = (2.0 - sign * 2f64.sqrt()) * G / l;
        let exact = 2.0 * std::f64::consts::PI / omega2.sqrt();
        let (t1, t2) = (amp, sign * 2f64.sqrt() * amp);
        let p1 = DVec3::new(t1.sin(), 0.0, -t1.cos()) * l;
        let p2 = p1 + DVec3::new(t2.sin(), 0.0, -t2.cos()) * l;
        let mut sys = SoftSystem::new(vec![DVec3::ZERO, p1, p2], vec![1.0; 3]).expect("system");
        sys.pin(0).expect("pin");
        let mut cons = Constraints::new();
        cons.add(HardSet::hard(
            "links",
            vec![
                Distance::new(0, 1, l).expect("link"),
                Distance::new(1, 2, l).expect("link"),
            ],
        ));
        let h = 2e-4;
        let mut step = VelocityLevel::new(h, BaseStep::Explicit, KktSolver::DenseSchur).expect("h");
        step.projection = Some(FastProjection::new(1e-13, 10, KktSolver::DenseSchur).expect("tol"));
        let mut xs = Vec::new();
        for k in 0..((4.0 * exact / h) as usize) {
            step.step(&mut sys, &cons).expect("step");
            xs.push(((k + 1) as f64 * h, sys.x[1].x));
        }
        let rel = (period(&xs) - exact).abs() / exact;
        println!("double pendulum, {name} mode: period error {rel:.2e}");
        // measured 8.8e-6 (slow) and 1.9e-4 (fast); gate 2e-3 — the amplitude
        // correction is O(θ²) ≈ 1e-4 and the first-order step adds O(h)
        assert!(rel < 2e-3, "{name}: {rel}");
    }
}

#[test]
fn large_redundant_sparse_systems_fall_back_to_minres_with_minimum_norm_multipliers() {
    // A 200-link chain with every link twice: 400 rows, above the dense-SVD fallback
    // size, so the singular sparse Schur complement goes to MINRES from zero.
    let links = 200;
    let (mut single, cons1) = chain(links, 0.1, 0.1, 0.3).expect("scene");
    let (mut double, _) = chain(links, 0.1, 0.1, 0.3).expect("scene");
    let d: Vec<Distance> = (0..links)
        .flat_map(|i| {
            let l = Distance::new(i, i + 1, 0.1).expect("link");
            [l, l]
        })
        .collect();
    let mut cons2 = Constraints::new();
    cons2.add(HardSet::hard("twice", d));
    assert!(2 * links > constraint_lagrange::kkt::SPARSE_SVD_FALLBACK_ROWS);
    let mut s1 = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::SparseSchur).expect("h");
    let mut s2 = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::SparseSchur).expect("h");
    let mut worst_res: f64 = 0.0;
    for _ in 0..20 {
        s1.step(&mut single, &cons1).expect("single");
        let st = s2.step(&mut double, &cons2).expect("redundant");
        assert!(
            matches!(st.chosen, Some(KktSolver::Minres(_))),
            "{:?}",
            st.chosen
        );
        worst_res = worst_res.max(st.residual);
    }
    let (l1, l2) = (s1.multipliers(), s2.multipliers());
    let (mut split, mut sum) = (0.0f64, 0.0f64);
    let scale = l1.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for i in 0..links {
        split = split.max((l2[2 * i] - l2[2 * i + 1]).abs() / scale);
        sum = sum.max((l2[2 * i] + l2[2 * i + 1] - l1[i]).abs() / scale);
    }
    let dx = single
        .x
        .iter()
        .zip(&double.x)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0f64, f64::max);
    println!("400 redundant rows: residual {worst_res:.1e}, λ split {split:.1e}, sum {sum:.1e}, |Δx| {dx:.1e}");
    // Measured: residual 1.5e-13, split 0, sum 1.2e-11, |Δx| 3.6e-15.
    assert!(worst_res < 1e-8, "{worst_res}");
    assert!(
        split < 1e-8 && sum < 1e-7 && dx < 1e-9,
        "{split} {sum} {dx}"
    );
}
