//! Bad input gets a typed error, never a panic or a silent NaN; a rejected call leaves
//! the world unchanged.

use constraint_articulated::{ArticulatedError, Joint, JointKind, Method, RigidBody, World};
use constraint_core::{DMat3, DQuat, DVec3, Pose, Spherical};

fn pose() -> Pose {
    Pose {
        x: DVec3::ZERO,
        q: DQuat::IDENTITY,
    }
}

#[test]
fn bodies_reject_bad_mass_inertia_and_pose() {
    let i = DMat3::IDENTITY;
    for m in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(
                RigidBody::new(0, m, i, pose()),
                Err(constraint_core::BodyError { body: 0, .. })
            ),
            "mass {m}"
        );
    }
    let cases = [
        DMat3::from_diagonal(DVec3::new(1.0, 1.0, 3.0)), // triangle inequality
        DMat3::from_diagonal(DVec3::new(1.0, 0.0, 1.0)), // singular
        DMat3::from_diagonal(DVec3::new(1.0, -1.0, 1.0)), // indefinite
        DMat3::from_cols(
            DVec3::new(1.0, 0.5, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::Z,
        ), // asymmetric
        DMat3::from_diagonal(DVec3::new(1.0, f64::NAN, 1.0)),
    ];
    for c in cases {
        assert!(
            matches!(
                RigidBody::new(0, 1.0, c, pose()),
                Err(constraint_core::BodyError { body: 0, .. })
            ),
            "{c:?}"
        );
    }
    let bad_q = Pose {
        x: DVec3::ZERO,
        q: DQuat::from_xyzw(0.0, 0.0, 0.0, 2.0),
    };
    assert!(RigidBody::new(0, 1.0, i, bad_q).is_err());
    let nan_x = Pose {
        x: DVec3::new(f64::NAN, 0.0, 0.0),
        q: DQuat::IDENTITY,
    };
    assert!(RigidBody::new(0, 1.0, i, nan_x).is_err());
}

#[test]
fn world_rejects_bad_joints_and_parameters_and_stays_unchanged() {
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let p = Pose {
        x: DVec3::new(0.0, 0.0, -1.0),
        q: DQuat::IDENTITY,
    };
    w.add_body(RigidBody::new(0, 1.0, DMat3::IDENTITY * 0.01, p).unwrap())
        .unwrap();
    let s = Spherical::from_world(&Pose::IDENTITY, &p, DVec3::ZERO).unwrap();
    let kind = JointKind::Spherical(s);
    assert!(w
        .add_joint(Joint {
            parent: None,
            child: 5,
            kind,
            damping: 0.0
        })
        .is_err());
    assert!(w
        .add_joint(Joint {
            parent: Some(0),
            child: 0,
            kind,
            damping: 0.0
        })
        .is_err());
    assert!(w
        .add_joint(Joint {
            parent: None,
            child: 0,
            kind,
            damping: -1.0
        })
        .is_err());
    assert!(w
        .add_joint(Joint {
            parent: None,
            child: 0,
            kind,
            damping: f64::NAN
        })
        .is_err());
    w.add_joint(Joint {
        parent: None,
        child: 0,
        kind,
        damping: 0.0,
    })
    .unwrap();
    let mut nan_v = RigidBody::new(1, 1.0, DMat3::IDENTITY, p).unwrap();
    nan_v.v = DVec3::NAN;
    assert!(w.add_body(nan_v).is_err());
    let before = w.bodies().to_vec();
    // The one check of the time step (constraint_core::StepContext::new), under every
    // method, and for the public velocity-level reference solve as well.
    let bad = [
        0.0,
        -0.0,
        -1e-3,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e-160,
        1e160,
    ];
    let methods = [
        Method::Velocity { beta: 1.0 },
        Method::default(),
        Method::Acceleration { kx: 0.0, kv: 0.0 },
        Method::Rattle4 {
            tolerance: 1e-10,
            max_iterations: 3,
        },
    ];
    for h in bad {
        for m in methods {
            assert!(
                matches!(
                    w.step(h, m),
                    Err(ArticulatedError::InvalidParameter { name: "h", .. })
                ),
                "h = {h:e}, {m:?}"
            );
        }
        assert!(
            matches!(
                w.velocity_twists(h, 1.0),
                Err(ArticulatedError::InvalidParameter { name: "h", .. })
            ),
            "velocity_twists h = {h:e}"
        );
    }
    for m in [
        Method::Velocity { beta: 2.0 },
        Method::Velocity { beta: f64::NAN },
        Method::VelocityProjected {
            beta: 1.0,
            tolerance: 0.0,
            max_iterations: 3,
            correct_velocity: false,
        },
        Method::Acceleration { kx: -1.0, kv: 0.0 },
        Method::Rattle {
            tolerance: f64::NAN,
            max_iterations: 3,
        },
        Method::Rattle4 {
            tolerance: -1.0,
            max_iterations: 3,
        },
    ] {
        assert!(
            matches!(
                w.step(1e-3, m),
                Err(ArticulatedError::InvalidParameter { .. })
            ),
            "{m:?}"
        );
    }
    assert_eq!(
        w.bodies(),
        &before[..],
        "a rejected step must leave the state unchanged"
    );
}

/// A state pushed to 1e300 m/s diverges as a typed error naming the step and the body,
/// and the state is left as it was before the step.
#[test]
fn divergence_is_a_typed_error_and_rolls_back() {
    let mut w = World::new(DVec3::ZERO);
    w.add_body(
        RigidBody::new(0, 1.0, DMat3::IDENTITY, pose())
            .unwrap()
            .with_velocity(DVec3::new(1e300, 0.0, 0.0), DVec3::ZERO),
    )
    .unwrap();
    let before = w.bodies().to_vec();
    for m in [
        Method::default(),
        Method::Velocity { beta: 1.0 },
        Method::Acceleration { kx: 0.0, kv: 0.0 },
    ] {
        match w.step(1.0, m) {
            Err(ArticulatedError::Diverged { step, body }) => assert_eq!((step, body), (1, 0)),
            other => panic!("{m:?}: expected divergence, got {other:?}"),
        }
        assert_eq!(w.bodies(), &before[..]);
    }
}

/// The unilateral projection floor takes only positive finite values; a rejected value
/// leaves the setting unchanged.
#[test]
fn unilateral_tolerance_rejects_bad_values() {
    let mut w = World::new(DVec3::ZERO);
    for t in [0.0, -1e-9, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(
                w.set_unilateral_tolerance(t),
                Err(ArticulatedError::InvalidParameter {
                    name: "unilateral_tolerance",
                    ..
                })
            ),
            "{t}"
        );
        assert_eq!(
            w.unilateral_tolerance(),
            World::DEFAULT_UNILATERAL_TOLERANCE
        );
    }
    assert!(w.set_unilateral_tolerance(1e-7).is_ok());
    assert_eq!(w.unilateral_tolerance(), 1e-7);
}
