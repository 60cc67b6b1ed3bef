//! Bad input gets a typed error, never a panic, and a rejected call leaves state as it
//! was.

use constraint_core::{ConstraintError, DVec3, Distance};
use constraint_soft::{
    CgSettings, Cloth, ConstraintSet, HessianMode, ImplicitEuler, Integrator, Jelly, LinearSolver,
    SoftError, SoftSystem, Softness, SymplecticEuler,
};

fn pair() -> SoftSystem {
    SoftSystem::new(vec![DVec3::ZERO, DVec3::X], vec![1.0, 1.0]).expect("valid")
}

fn spring() -> Distance {
    Distance::new(0, 1, 1.0).expect("valid")
}

#[test]
fn system_rejects_bad_particles() {
    assert_eq!(
        SoftSystem::new(vec![DVec3::ZERO], vec![1.0, 2.0]).unwrap_err(),
        SoftError::LengthMismatch
    );
    assert_eq!(
        SoftSystem::new(vec![DVec3::ZERO, DVec3::NAN], vec![1.0, 1.0]).unwrap_err(),
        SoftError::NonFiniteState { particle: 1 }
    );
    assert_eq!(
        SoftSystem::new(vec![DVec3::INFINITY], vec![1.0]).unwrap_err(),
        SoftError::NonFiniteState { particle: 0 }
    );
    for m in [0.0, -1.0, f64::NAN, f64::INFINITY, -0.0] {
        assert_eq!(
            SoftSystem::new(vec![DVec3::ZERO], vec![m]).unwrap_err(),
            SoftError::InvalidMass { particle: 0 },
            "mass {m}"
        );
    }
}

#[test]
fn pins_and_velocities_are_checked() {
    let mut s = pair();
    assert_eq!(
        s.pin(2).unwrap_err(),
        SoftError::IndexOutOfBounds { index: 2, len: 2 }
    );
    let v0 = s.v.clone();
    assert_eq!(
        s.set_velocities(&[DVec3::X, DVec3::NAN]).unwrap_err(),
        SoftError::NonFiniteState { particle: 1 }
    );
    assert_eq!(s.v, v0, "state unchanged after rejection");
    assert_eq!(
        s.set_velocities(&[DVec3::X]).unwrap_err(),
        SoftError::LengthMismatch
    );
}

#[test]
fn softness_is_checked() {
    for (k, c, want) in [
        (-1.0, 0.0, SoftError::InvalidSoftness { set: "s" }),
        (f64::NAN, 0.0, SoftError::InvalidSoftness { set: "s" }),
        (1.0, -1.0, SoftError::InvalidSoftness { set: "s" }),
        (1.0, f64::NAN, SoftError::InvalidSoftness { set: "s" }),
        (
            f64::INFINITY,
            0.0,
            SoftError::InfiniteStiffness { set: "s" },
        ),
        (
            1.0,
            f64::INFINITY,
            SoftError::InfiniteStiffness { set: "s" },
        ),
    ] {
        let s = Softness {
            stiffness: k,
            damping: c,
        };
        assert_eq!(
            ConstraintSet::uniform("s", vec![spring()], s).unwrap_err(),
            want,
            "k = {k}, c = {c}"
        );
    }
    assert_eq!(
        ConstraintSet::new("s", vec![spring()], vec![]).unwrap_err(),
        SoftError::LengthMismatch
    );
}

#[test]
fn stencils_out_of_range_are_rejected() {
    let mut s = pair();
    let far = Distance::new(0, 5, 1.0).expect("valid constraint");
    let set = ConstraintSet::uniform("far", vec![far], Softness::stiff(1.0)).expect("valid");
    assert_eq!(
        s.add_set(set).unwrap_err(),
        SoftError::IndexOutOfBounds { index: 5, len: 2 }
    );
    assert_eq!(s.sets().count(), 0, "nothing added");
}

#[test]
fn time_steps_are_checked() {
    // Every StepError of constraint_core::StepContext::new is InvalidTimeStep here.
    let bad = [
        0.0,
        -0.0,
        -1e-3,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e-160,
    ];
    for h in bad {
        assert_eq!(
            SymplecticEuler::new(h).unwrap_err(),
            SoftError::InvalidTimeStep
        );
        assert_eq!(
            ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt).unwrap_err(),
            SoftError::InvalidTimeStep
        );
    }
}

#[test]
fn scenes_reject_bad_parameters() {
    let bad = |e: Result<SoftSystem, SoftError>, name: &str| {
        assert!(
            matches!(e, Err(SoftError::InvalidParameter { name: n, .. }) if n == name),
            "{name}"
        )
    };
    bad(
        Cloth {
            n: 1,
            ..Cloth::default()
        }
        .build(),
        "n",
    );
    bad(
        Cloth {
            size: 0.0,
            ..Cloth::default()
        }
        .build(),
        "size",
    );
    bad(
        Cloth {
            size: f64::NAN,
            ..Cloth::default()
        }
        .build(),
        "size",
    );
    bad(
        Jelly {
            cells: [0, 1, 1],
            ..Jelly::default()
        }
        .build(),
        "cells",
    );
    bad(
        Jelly {
            cell: -0.1,
            ..Jelly::default()
        }
        .build(),
        "cell",
    );
    assert_eq!(
        Cloth {
            mass: -1.0,
            ..Cloth::default()
        }
        .build()
        .unwrap_err(),
        SoftError::InvalidMass { particle: 0 }
    );
    assert_eq!(
        Jelly {
            volume: Softness::stiff(f64::INFINITY),
            ..Jelly::default()
        }
        .build()
        .unwrap_err(),
        SoftError::InfiniteStiffness { set: "volumes" }
    );
}

#[test]
fn degenerate_rest_shapes_surface_as_typed_errors() {
    // Coincident points as a spring's rest shape.
    let x = [DVec3::ONE, DVec3::ONE];
    assert_eq!(
        Distance::from_rest(0, 1, &x),
        Err(ConstraintError::ZeroRestLength)
    );
}

/// A stiff spring stepped explicitly far beyond its stability limit must end in the
/// typed divergence error with the last good state kept — never a NaN in the state.
#[test]
fn explicit_blow_up_is_a_typed_error_and_keeps_the_last_good_state() {
    let mut s = pair();
    s.gravity = DVec3::ZERO;
    s.x[1] = DVec3::new(1.5, 0.0, 0.0);
    s.add_set(
        ConstraintSet::uniform("spring", vec![spring()], Softness::stiff(1e9)).expect("valid"),
    )
    .expect("valid");
    let mut step = SymplecticEuler::new(0.1).expect("valid h");
    let mut last = (s.x.clone(), s.v.clone());
    let mut err = None;
    for _ in 0..1000 {
        match step.step(&mut s) {
            Ok(_) => last = (s.x.clone(), s.v.clone()),
            Err(e) => {
                err = Some(e);
                break;
            }
        }
    }
    match err {
        Some(SoftError::Diverged { particle, .. }) => assert!(particle < 2),
        other => panic!("expected Diverged, got {other:?}"),
    }
    assert_eq!(
        (s.x.clone(), s.v.clone()),
        last,
        "state unchanged by the failed step"
    );
    assert!(s.x.iter().chain(&s.v).all(|p| p.is_finite()));
}

/// CG on the exact Hessian of a strongly compressed spring meets an indefinite matrix
/// and says so, instead of returning garbage.
#[test]
fn cg_reports_an_indefinite_matrix() {
    let mut s = pair();
    s.gravity = DVec3::ZERO;
    s.x[1] = DVec3::new(1e-3, 0.0, 0.0);
    s.set_velocities(&[DVec3::Y, -DVec3::Y]).expect("finite");
    s.add_set(
        ConstraintSet::uniform("spring", vec![spring()], Softness::stiff(1e9)).expect("valid"),
    )
    .expect("valid");
    let mut step = ImplicitEuler::new(
        1e-1,
        HessianMode::Exact,
        LinearSolver::ConjugateGradient(CgSettings::default()),
    )
    .expect("valid h");
    let x0 = s.x.clone();
    assert!(matches!(
        step.step(&mut s),
        Err(SoftError::Indefinite { .. })
    ));
    assert_eq!(s.x, x0, "state unchanged");
    // The projected Hessian makes the same step well posed.
    step.mode = HessianMode::Projected;
    assert!(step.step(&mut s).is_ok());
}
