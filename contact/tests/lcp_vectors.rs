//! LCP test vectors with known solutions or known failures (issue 5, "Verification").
//!
//! Measured values (this machine, `cargo test -p constraint-contact --test lcp_vectors
//! -- --nocapture`) are written beside each tolerance.

use constraint_contact::lcp::{
    fischer_newton, lemke, pgs, Lcp, LcpError, LemkeSettings, NewtonSettings, PgsSettings,
};

fn lemke_default(lcp: &Lcp) -> Result<constraint_contact::lcp::LcpSolution, LcpError> {
    lemke(lcp, &LemkeSettings::default(), None)
}

fn pgs_tight() -> PgsSettings {
    PgsSettings {
        tolerance: 1e-12,
        max_iterations: 100_000,
        ..PgsSettings::default()
    }
}

fn assert_close(a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{a:?} vs {b:?} (tol {tol:e})");
    }
}

/// Trivial diagonal: `M = diag(2, 3, 4)`, `q = (−2, 3, −8)` → `z = (1, 0, 2)`,
/// `w = (0, 3, 0)`. Measured: Lemke 3 pivots, residual 0; PGS 1 sweep; Newton 6 steps.
#[test]
fn trivial_diagonal() {
    let lcp = Lcp::new(
        vec![2.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 4.0],
        vec![-2.0, 3.0, -8.0],
    )
    .unwrap();
    let want = [1.0, 0.0, 2.0];
    let l = lemke_default(&lcp).unwrap();
    assert_close(&l.z, &want, 1e-14);
    assert_close(&l.w, &[0.0, 3.0, 0.0], 1e-14);
    assert_eq!(l.basis.as_deref(), Some(&[true, false, true][..]));
    let p = pgs(&lcp, &pgs_tight(), None).unwrap();
    assert_close(&p.z, &want, 1e-12);
    let f = fischer_newton(&lcp, &NewtonSettings::default(), None).unwrap();
    assert_close(&f.z, &want, 1e-12);
    println!(
        "diagonal: lemke {} pivots r={:.1e}; pgs {} sweeps r={:.1e}; newton {} steps r={:.1e}",
        l.iterations, l.residual, p.iterations, p.residual, f.iterations, f.residual
    );
}

/// `q ≥ 0`: `z = 0` is the solution; zero pivots, zero sweeps, zero Newton steps.
#[test]
fn nonnegative_q_needs_no_pivots() {
    let lcp = Lcp::new(vec![2.0, 1.0, 1.0, 2.0], vec![1.0, 0.0]).unwrap();
    let l = lemke_default(&lcp).unwrap();
    assert_eq!(l.iterations, 0);
    assert_eq!(l.z, vec![0.0, 0.0]);
    assert_eq!(l.residual, 0.0);
    assert_eq!(l.basis.as_deref(), Some(&[false, false][..]));
    let p = pgs(&lcp, &PgsSettings::default(), None).unwrap();
    assert_eq!((p.iterations, p.z.clone()), (0, vec![0.0, 0.0]));
    let f = fischer_newton(&lcp, &NewtonSettings::default(), None).unwrap();
    assert_eq!((f.iterations, f.z.clone()), (0, vec![0.0, 0.0]));
}

/// Kostreva's cycling example `M = [[1,2,0],[0,1,2],[2,0,1]]`, `q = (−1,−1,−1)`: M is a
/// P-matrix (all principal minors > 0, det 9), so the unique solution is
/// `z = (⅓, ⅓, ⅓)`, `w = 0`. Lemke with the lexicographic rule must not cycle (the pivot
/// limit is set to 10 so a cycle would fail). Measured: Lemke 4 pivots, residual 0;
/// Newton 6 steps, residual 0. PGS (M non-symmetric) cycles around the solution and must report
/// `IterationLimit`, not a wrong answer.
#[test]
fn kostreva_cycling_example() {
    let lcp = Lcp::new(
        vec![1.0, 2.0, 0.0, 0.0, 1.0, 2.0, 2.0, 0.0, 1.0],
        vec![-1.0, -1.0, -1.0],
    )
    .unwrap();
    let third = [1.0 / 3.0; 3];
    let l = lemke(
        &lcp,
        &LemkeSettings {
            max_pivots: Some(10),
            ..LemkeSettings::default()
        },
        None,
    )
    .unwrap();
    assert_close(&l.z, &third, 1e-14);
    assert!(l.residual <= 1e-15, "{}", l.residual);
    let f = fischer_newton(&lcp, &NewtonSettings::default(), None).unwrap();
    assert_close(&f.z, &third, 1e-12);
    let p = pgs(
        &lcp,
        &PgsSettings {
            max_iterations: 1000,
            ..PgsSettings::default()
        },
        None,
    );
    println!(
        "kostreva: lemke {} pivots r={:.1e}; newton {} steps r={:.1e}; pgs {:?}",
        l.iterations, l.residual, f.iterations, f.residual, p
    );
    match p {
        Ok(s) => assert_close(&s.z, &third, 1e-6),
        Err(e) => assert!(matches!(e, LcpError::IterationLimit { .. }), "{e}"),
    }
}

/// Degenerate PSD: `M = [[1,−1],[−1,1]]`, `q = (1,−1)`. `w₁ + w₂ = 0` forces `w = 0`,
/// so the solutions are the ray `z = (t, 1 + t)`, `t ≥ 0`.
#[test]
fn degenerate_psd() {
    let lcp = Lcp::new(vec![1.0, -1.0, -1.0, 1.0], vec![1.0, -1.0]).unwrap();
    let check = |z: &[f64], w: &[f64], tol: f64| {
        assert!(z[0] >= 0.0 && (z[1] - z[0] - 1.0).abs() <= tol, "{z:?}");
        assert!(w.iter().all(|x| x.abs() <= tol), "{w:?}");
    };
    let l = lemke_default(&lcp).unwrap();
    check(&l.z, &l.w, 1e-14);
    let p = pgs(&lcp, &pgs_tight(), None).unwrap();
    check(&p.z, &p.w, 1e-11);
    let f = fischer_newton(&lcp, &NewtonSettings::default(), None).unwrap();
    check(&f.z, &f.w, 1e-11);
    println!(
        "degenerate PSD: lemke z={:?} ({} pivots); pgs z={:?} ({} sweeps); newton z={:?} ({} steps)",
        l.z, l.iterations, p.z, p.iterations, f.z, f.iterations
    );
}

/// Infeasible 1×1: `M = [[−1]]`, `q = (−1)`: `w = −z − 1 < 0` for every `z ≥ 0`. Every
/// solver reports a typed failure and no `z` (the caller applies `z = 0`). Measured: Lemke
/// ray after 1 pivot with a Farkas certificate; Newton `IterationLimit` (residual 0.5).
#[test]
fn infeasible_one_by_one() {
    let lcp = Lcp::new(vec![-1.0], vec![-1.0]).unwrap();
    let e = lemke_default(&lcp).unwrap_err();
    assert_eq!(
        e,
        LcpError::RayTermination {
            pivots: 1,
            proven_infeasible: true
        }
    );
    let e = pgs(&lcp, &PgsSettings::default(), None).unwrap_err();
    assert_eq!(e, LcpError::NonPositiveDiagonal { index: 0 });
    let e = fischer_newton(&lcp, &NewtonSettings::default(), None).unwrap_err();
    assert!(
        matches!(
            e,
            LcpError::Stalled { .. } | LcpError::IterationLimit { .. }
        ),
        "{e}"
    );
    println!("infeasible: newton {e}");
}

/// `n = 0` is valid and solved by every solver without work.
#[test]
fn empty_problem() {
    for lcp in [Lcp::empty(), Lcp::new(vec![], vec![]).unwrap()] {
        let l = lemke_default(&lcp).unwrap();
        assert!(l.z.is_empty() && l.iterations == 0 && l.residual == 0.0);
        let p = pgs(&lcp, &PgsSettings::default(), None).unwrap();
        assert!(p.z.is_empty() && p.iterations == 0);
        let f = fischer_newton(&lcp, &NewtonSettings::default(), None).unwrap();
        assert!(f.z.is_empty() && f.iterations == 0);
        assert_eq!(lcp.residual(&[]), 0.0);
    }
}

#[test]
fn dimension_mismatch() {
    assert_eq!(
        Lcp::new(vec![1.0; 3], vec![1.0, 2.0]).unwrap_err(),
        LcpError::DimensionMismatch {
            what: "m",
            expected: 4,
            found: 3
        }
    );
    assert!(matches!(
        Lcp::boxed(vec![1.0], vec![1.0], vec![0.0, 0.0], vec![1.0]),
        Err(LcpError::DimensionMismatch { what: "lo", .. })
    ));
    assert!(matches!(
        Lcp::contact(vec![1.0; 9], vec![1.0; 3], &[0.5, 0.5]),
        Err(LcpError::DimensionMismatch { what: "q", .. })
    ));
    let lcp = Lcp::new(vec![1.0, 0.0, 0.0, 1.0], vec![-1.0, -1.0]).unwrap();
    assert!(matches!(
        lemke(&lcp, &LemkeSettings::default(), Some(&[true])),
        Err(LcpError::DimensionMismatch { what: "basis", .. })
    ));
    assert!(matches!(
        pgs(&lcp, &PgsSettings::default(), Some(&[0.0; 3])),
        Err(LcpError::DimensionMismatch { what: "z0", .. })
    ));
    assert!(matches!(
        fischer_newton(&lcp, &NewtonSettings::default(), Some(&[0.0])),
        Err(LcpError::DimensionMismatch { what: "z0", .. })
    ));
    assert_eq!(lcp.residual(&[0.0]), f64::INFINITY);
}

#[test]
fn non_finite_and_bad_input() {
    assert_eq!(
        Lcp::new(vec![1.0, f64::NAN, 0.0, 1.0], vec![1.0, 1.0]).unwrap_err(),
        LcpError::NonFinite {
            what: "m",
            index: 1
        }
    );
    assert_eq!(
        Lcp::new(vec![1.0], vec![f64::INFINITY]).unwrap_err(),
        LcpError::NonFinite {
            what: "q",
            index: 0
        }
    );
    assert_eq!(
        Lcp::boxed(vec![1.0], vec![1.0], vec![2.0], vec![1.0]).unwrap_err(),
        LcpError::BadBounds { index: 0 }
    );
    assert_eq!(
        Lcp::boxed(vec![1.0], vec![1.0], vec![f64::NAN], vec![1.0]).unwrap_err(),
        LcpError::BadBounds { index: 0 }
    );
    let lcp = Lcp::new(vec![1.0, 0.0, 0.0, 1.0], vec![-1.0, -1.0]).unwrap();
    assert_eq!(
        lcp.clone()
            .with_friction(vec![Some((0, 0.5)), Some((0, 0.5))])
            .unwrap_err(),
        LcpError::BadFriction { index: 0 }
    );
    assert_eq!(
        lcp.clone()
            .with_friction(vec![None, Some((0, -1.0))])
            .unwrap_err(),
        LcpError::BadFriction { index: 1 }
    );
    assert!(matches!(
        pgs(&lcp, &PgsSettings::default(), Some(&[f64::NAN, 0.0])),
        Err(LcpError::NonFinite { what: "z0", .. })
    ));
    assert_eq!(lcp.residual(&[f64::NAN, 1.0]), f64::INFINITY);
    for omega in [0.0, 2.0, f64::NAN] {
        let s = PgsSettings {
            omega,
            ..PgsSettings::default()
        };
        assert!(matches!(pgs(&lcp, &s, None), Err(LcpError::BadSettings(_))));
    }
    let s = LemkeSettings {
        tolerance: 0.0,
        ..LemkeSettings::default()
    };
    assert!(matches!(
        lemke(&lcp, &s, None),
        Err(LcpError::BadSettings(_))
    ));
    // Errors print and are std errors.
    let e: Box<dyn std::error::Error> = Box::new(LcpError::IterationLimit {
        iterations: 3,
        residual: 0.5,
    });
    assert!(e.to_string().contains("3 iterations"));
}

/// A boxed 1×1 and 2×2: `M = [[2]]`, `q = −10`, `z ∈ [−1, 1]` → `z = 1` at the upper
/// bound with `w = −8 ≤ 0`. Lemke and Newton refuse boxed problems (typed).
#[test]
fn boxed_problems() {
    let lcp = Lcp::boxed(vec![2.0], vec![-10.0], vec![-1.0], vec![1.0]).unwrap();
    let p = pgs(&lcp, &PgsSettings::default(), None).unwrap();
    assert_eq!(p.z, vec![1.0]);
    assert_eq!(p.w, vec![-8.0]);
    assert!(matches!(lemke_default(&lcp), Err(LcpError::Unsupported(_))));
    assert!(matches!(
        fischer_newton(&lcp, &NewtonSettings::default(), None),
        Err(LcpError::Unsupported(_))
    ));
    // Interior solution of a free variable: M = [[2,1],[1,2]], q = (1, −4), z₀ free.
    let lcp = Lcp::boxed(
        vec![2.0, 1.0, 1.0, 2.0],
        vec![1.0, -4.0],
        vec![f64::NEG_INFINITY, 0.0],
        vec![f64::INFINITY, f64::INFINITY],
    )
    .unwrap();
    let p = pgs(&lcp, &pgs_tight(), None).unwrap();
    // 2 z0 + z1 = −1, z0 + 2 z1 = 4 → z = (−2, 3).
    assert_close(&p.z, &[-2.0, 3.0], 1e-11);
}

/// One sliding contact on a unit point mass (M = I): normal push `q_n = −1`, tangential
/// drive `q_t = (−2, 0.1)`, `μ = 0.5` → `z_n = 1`, `z_t1 = μ z_n = 0.5` at the bound
/// (`w_t1 = −1.5 ≤ 0`), `z_t2 = −0.1` inside (`w_t2 = 0`).
#[test]
fn friction_single_contact() {
    let mut m = vec![0.0; 9];
    for i in 0..3 {
        m[i * 3 + i] = 1.0;
    }
    let lcp = Lcp::contact(m, vec![-1.0, -2.0, 0.1], &[0.5]).unwrap();
    let p = pgs(&lcp, &pgs_tight(), None).unwrap();
    assert_close(&p.z, &[1.0, 0.5, -0.1], 1e-12);
    assert_close(&p.w, &[0.0, -1.5, 0.0], 1e-12);
    assert_eq!(lcp.bounds(1, &p.z), (-0.5, 0.5));
}

/// Warm start: re-solving from the returned basis takes 0 pivots; a nearby `q` from the
/// old basis takes fewer pivots than cold and gives the same `z`; a singular guess
/// falls back to the cold start.
#[test]
fn lemke_warm_start() {
    let n = 12;
    let mut m = vec![0.0; n * n];
    let mut q = vec![0.0; n];
    for i in 0..n {
        for j in 0..n {
            m[i * n + j] = if i == j {
                4.0
            } else if i.abs_diff(j) == 1 {
                -1.0
            } else {
                0.0
            };
        }
        q[i] = if i % 3 == 0 {
            1.0
        } else {
            -1.0 - 0.1 * i as f64
        };
    }
    let lcp = Lcp::new(m.clone(), q.clone()).unwrap();
    let cold = lemke_default(&lcp).unwrap();
    let basis = cold.basis.clone().unwrap();
    let again = lemke(&lcp, &LemkeSettings::default(), Some(&basis)).unwrap();
    assert_eq!(again.iterations, 0);
    assert_close(&again.z, &cold.z, 1e-13);

    let mut q2 = q.clone();
    q2[3] = -0.2; // contact 3 closes: one more active row
    q2[7] = 0.5; // contact 7 opens
    let lcp2 = Lcp::new(m.clone(), q2).unwrap();
    let cold2 = lemke_default(&lcp2).unwrap();
    let warm2 = lemke(&lcp2, &LemkeSettings::default(), Some(&basis)).unwrap();
    assert_close(&warm2.z, &cold2.z, 1e-12);
    println!(
        "warm start: cold {} pivots, same q warm {} pivots, perturbed q cold {} / warm {} pivots",
        cold.iterations, again.iterations, cold2.iterations, warm2.iterations
    );
    assert!(warm2.iterations < cold2.iterations);

    // Singular guess: M = [[1,1],[1,1]] with both z basic.
    let lcp = Lcp::new(vec![1.0, 1.0, 1.0, 1.0], vec![-1.0, -1.0]).unwrap();
    let s = lemke(&lcp, &LemkeSettings::default(), Some(&[true, true])).unwrap();
    assert!(s.residual <= 1e-14);
    assert!((s.z[0] + s.z[1] - 1.0).abs() < 1e-14);
}

/// The pivot limit is typed.
#[test]
fn lemke_pivot_limit() {
    let lcp = Lcp::new(
        vec![1.0, 2.0, 0.0, 0.0, 1.0, 2.0, 2.0, 0.0, 1.0],
        vec![-1.0, -1.0, -1.0],
    )
    .unwrap();
    let s = LemkeSettings {
        max_pivots: Some(2),
        ..LemkeSettings::default()
    };
    assert_eq!(
        lemke(&lcp, &s, None).unwrap_err(),
        LcpError::PivotLimit { pivots: 2 }
    );
}

/// PGS warm start from the solution returns at once; over-relaxation (ω = 1.3) converges
/// on an SPD problem in fewer sweeps than ω = 1 (measured: see output).
#[test]
fn pgs_warm_start_and_relaxation() {
    let n = 20;
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            m[i * n + j] = if i == j {
                2.0
            } else if i.abs_diff(j) == 1 {
                -0.95
            } else {
                0.0
            };
        }
    }
    let q: Vec<f64> = (0..n)
        .map(|i| if i % 5 == 0 { 0.3 } else { -1.0 })
        .collect();
    let lcp = Lcp::new(m, q).unwrap();
    let tight = pgs_tight();
    let plain = pgs(&lcp, &tight, None).unwrap();
    let sor = pgs(
        &lcp,
        &PgsSettings {
            omega: 1.3,
            ..tight
        },
        None,
    )
    .unwrap();
    let warm = pgs(&lcp, &PgsSettings::default(), Some(&plain.z)).unwrap();
    println!(
        "pgs: ω=1 {} sweeps, ω=1.3 {} sweeps, warm {} sweeps",
        plain.iterations, sor.iterations, warm.iterations
    );
    assert_eq!(warm.iterations, 0);
    assert!(sor.iterations < plain.iterations);
    let l = lemke_default(&lcp).unwrap();
    assert_close(&plain.z, &l.z, 1e-9);
    assert_close(&sor.z, &l.z, 1e-9);
}

/// The normal LCP of issue 14's heavy box (`scenes::heavy_on_light(1e4)`, first step at
/// h = 1/60, as the contact world assembles it): four ground rows under the 125 kg box
/// and four rows between it and the 1.25e6 kg box on top. The two faces touch at four
/// coplanar points each, so `M` is singular, and the impulses are 10⁵ times `|q|`.
/// Lemke's final basis keeps a degenerate variable (zero, computed as −1.1e-6) whose
/// clamp cost a residual of 9.5e-9 (`Inaccurate` against 1e-10); dropping it from the
/// basis and solving again gives the exact answer. Physical check: the top rows carry
/// the heavy box's weight over the step, `m g h`, and the ground rows both boxes'.
#[test]
fn heavy_box_on_a_light_one_degenerate_basis() {
    let m = vec![
        0.032,
        0.008,
        0.008,
        -0.016000000000000004,
        -0.0320024,
        -0.008000000000000004,
        0.0160024,
        -0.008,
        0.008,
        0.032,
        -0.016000000000000004,
        0.008,
        -0.008,
        -0.0320024,
        -0.008000000000000004,
        0.016002400000000003,
        0.008,
        -0.016000000000000004,
        0.032,
        0.008,
        -0.008,
        0.0160024,
        -0.007999999999999997,
        -0.0320024,
        -0.016000000000000004,
        0.008,
        0.008,
        0.032,
        0.016002400000000003,
        -0.007999999999999997,
        -0.0320024,
        -0.008,
        -0.0320024,
        -0.008,
        -0.008,
        0.016002400000000003,
        0.032006200360006,
        0.008000800000000004,
        -0.016004600360005998,
        0.0080008,
        -0.008000000000000004,
        -0.0320024,
        0.0160024,
        -0.007999999999999997,
        0.008000800000000004,
        0.032006200360005996,
        0.008000800000000002,
        -0.016004600360005998,
        0.0160024,
        -0.008000000000000004,
        -0.007999999999999997,
        -0.0320024,
        -0.016004600360005998,
        0.008000800000000002,
        0.032006200360005996,
        0.008000799999999999,
        -0.008,
        0.016002400000000003,
        -0.0320024,
        -0.008,
        0.0080008,
        -0.016004600360005998,
        0.008000799999999999,
        0.032006200360006,
    ];
    let lcp = Lcp::new(
        m,
        vec![-0.1635, -0.1635, -0.1635, -0.1635, 0.0, 0.0, 0.0, 0.0],
    )
    .unwrap();
    let sol = lemke_default(&lcp).unwrap();
    println!(
        "heavy box: Lemke residual {:e}, z {:?}",
        sol.residual, sol.z
    );
    // measured 3.4e-13
    assert!(sol.residual <= 1e-10, "{:e}", sol.residual);
    // The residual's round-off floor is real: `w = M z + q` summed forwards and
    // backwards differs, and by less than the floor (measured 2.3e-13 apart, floor
    // 5.8e-11); on a unit-scaled problem the floor is far below any tolerance.
    let floor = lcp.round_off(&sol.z);
    let apart = (0..8)
        .map(|i| {
            let row = &lcp.m()[8 * i..8 * i + 8];
            let fwd = lcp.q()[i] + row.iter().zip(&sol.z).map(|(m, z)| m * z).sum::<f64>();
            let rev = lcp.q()[i]
                + row
                    .iter()
                    .zip(&sol.z)
                    .rev()
                    .map(|(m, z)| m * z)
                    .sum::<f64>();
            (fwd - rev).abs()
        })
        .fold(0.0, f64::max);
    println!("heavy box: w forwards vs backwards {apart:e}, floor {floor:e}");
    assert!(apart <= floor && floor < 1e-8, "{apart:e} {floor:e}");
    let unit = Lcp::new(vec![2.0, 1.0, 1.0, 2.0], vec![-1.0, 3.0]).unwrap();
    let unit_floor = unit.round_off(&[0.5, 0.0]);
    println!("unit problem floor {unit_floor:e}");
    assert!(unit_floor < 1e-14); // measured 7.8e-16
    let h = 1.0 / 60.0;
    let top: f64 = sol.z[4..].iter().sum();
    let ground: f64 = sol.z[..4].iter().sum();
    let (heavy, light) = (1.25e6 * 9.81 * h, 125.0 * 9.81 * h);
    // measured: 204375.000000 and 204395.437500 N·s (relative error below 1e-14)
    assert!((top - heavy).abs() <= 1e-9 * heavy, "{top} vs {heavy}");
    assert!(
        (ground - heavy - light).abs() <= 1e-9 * heavy,
        "{ground} vs {}",
        heavy + light
    );
}

/// The round-off floor never accepts an answer that overflowed: `M = diag(1e300,
/// 1e-300)`, `q = (−1, −1e300)` has `z₂ = 1e600`, beyond `f64`. Lemke must answer with
/// an error (found by the bad-input sweep's "lemke mixed scale" case when the floor first
/// accepted `residual ≤ ∞`), and `accepts` turns down a non-finite floor.
#[test]
fn the_round_off_floor_accepts_no_overflowed_answer() {
    let lcp = Lcp::new(vec![1e300, 0.0, 0.0, 1e-300], vec![-1.0, -1e300]).unwrap();
    let r = lemke(&lcp, &LemkeSettings::default(), None);
    assert!(
        r.as_ref()
            .map_or(true, |s| s.z.iter().all(|z| z.is_finite())),
        "{r:?}"
    );
    assert!(r.is_err(), "{r:?}");
    assert!(!lcp.round_off(&[1e-300, f64::INFINITY]).is_finite());
    assert!(!lcp.accepts(&[1e-300, f64::INFINITY], f64::INFINITY, 1e-10));
    assert!(!lcp.accepts(&[1e-300, 1e308], 1.0, 1e-10));
}

/// A friction row whose `normal` is out of range or not a one-sided row is a typed
/// error from both row solvers (it panicked on the index before; bad-input sweep).
#[test]
fn a_friction_row_needs_a_unilateral_normal() {
    use constraint_contact::lcp::{
        solve_rows, solve_rows_sparse, RowBound, RowSettings, SparseRows,
    };
    let a = [2.0, 0.1, 0.1, 1.0];
    let q = [-1.0, 0.5];
    for normal in [1, 7] {
        let b = [RowBound::Unilateral, RowBound::Friction { normal, mu: 0.5 }];
        let mut z = [0.0; 2];
        let dense = solve_rows(&a, &q, &b, &RowSettings::default(), &mut z);
        assert!(matches!(dense, Err(LcpError::BadSettings(_))), "{dense:?}");
        let rows = SparseRows::from_dense(&a, 2);
        let sparse = solve_rows_sparse(&rows, &q, &b, &RowSettings::default(), &mut z);
        assert!(
            matches!(sparse, Err(LcpError::BadSettings(_))),
            "{sparse:?}"
        );
    }
    let b = [
        RowBound::Unilateral,
        RowBound::Friction { normal: 0, mu: 0.5 },
    ];
    let mut z = [0.0; 2];
    assert!(solve_rows(&a, &q, &b, &RowSettings::default(), &mut z).is_ok());
}

/// `row_residual` checks what the solvers check (it indexed past short arrays and a bad
/// friction normal before) and does not return a silent NaN. Measured: 6.25e-4 after the
/// default two alternations (bounds 1e-6 … 1e-3), 9.8e-9 alternating to the friction
/// tolerance (bound 1e-8).
#[test]
fn row_residual_checks_its_shapes_and_values() {
    use constraint_contact::lcp::{row_residual, solve_rows, RowBound, RowSettings};
    let a = [2.0, 0.1, 0.1, 1.0];
    let q = [-1.0, 0.5];
    let b = [
        RowBound::Unilateral,
        RowBound::Friction { normal: 0, mu: 0.5 },
    ];
    // The default two alternations stop short (measured 6.25e-4, the documented cost of a
    // fixed staggered budget); alternating to the friction tolerance reaches it.
    let mut z = [0.0; 2];
    solve_rows(&a, &q, &b, &RowSettings::default(), &mut z).unwrap();
    let two = row_residual(&a, &q, &b, &z).unwrap();
    assert!(two > 1e-6 && two < 1e-3, "{two:e}");
    let settings = RowSettings {
        max_sweeps: 100,
        ..RowSettings::default()
    };
    solve_rows(&a, &q, &b, &settings, &mut z).unwrap();
    let r = row_residual(&a, &q, &b, &z).unwrap();
    println!("residual: two alternations {two:e}, converged {r:e}");
    assert!(r <= 1e-8, "{r:e}");
    let short = row_residual(&a[..3], &q, &b, &z);
    assert!(
        matches!(short, Err(LcpError::DimensionMismatch { what: "a", .. })),
        "{short:?}"
    );
    let short = row_residual(&a, &q, &b, &z[..1]);
    assert!(
        matches!(short, Err(LcpError::DimensionMismatch { what: "z", .. })),
        "{short:?}"
    );
    let bad = [
        RowBound::Unilateral,
        RowBound::Friction { normal: 7, mu: 0.5 },
    ];
    assert!(matches!(
        row_residual(&a, &q, &bad, &z),
        Err(LcpError::BadSettings(_))
    ));
    let nan = row_residual(&a, &[f64::NAN, 0.5], &b, &z);
    assert!(
        matches!(
            nan,
            Err(LcpError::NonFinite {
                what: "q",
                index: 0
            })
        ),
        "{nan:?}"
    );
}
