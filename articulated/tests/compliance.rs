//! Compliant joints (`World::set_compliance`): `C(x) = −α λ_f`, a spring of stiffness
//! `1/α` per hard row. The velocity methods treat it implicitly (`[M Jᵀ; J −α/h²]`),
//! the acceleration level and RATTLE as an explicit spring force.

use constraint_articulated::scenes::ball_chain;
use constraint_articulated::{
    ArticulatedError, GeometricStiffness, Joint, JointKind, Method, RigidBody, World,
};
use constraint_core::{DMat3, DQuat, DVec3, Pose, Spherical};

/// A 2 kg body hanging 0.5 m straight below a compliant ball joint at the origin.
fn hanging(alpha: f64) -> World {
    let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
    let pose = Pose {
        x: DVec3::new(0.0, 0.0, -0.5),
        q: DQuat::IDENTITY,
    };
    w.add_body(RigidBody::new(0, 2.0, DMat3::IDENTITY * 0.05, pose).unwrap())
        .unwrap();
    let ball = Spherical::from_world(&Pose::IDENTITY, &pose, DVec3::ZERO).unwrap();
    let j = w
        .add_joint(Joint {
            parent: None,
            child: 0,
            kind: JointKind::Spherical(ball),
            damping: 0.0,
        })
        .unwrap();
    w.set_compliance(j, alpha).unwrap();
    w
}

const METHODS: [Method; 5] = [
    Method::Velocity { beta: 1.0 },
    Method::VelocityProjected {
        beta: 1.0,
        tolerance: 1e-10,
        max_iterations: 10,
        correct_velocity: false,
    },
    Method::Acceleration { kx: 0.0, kv: 0.0 },
    Method::Rattle {
        tolerance: 1e-12,
        max_iterations: 30,
    },
    Method::Rattle4 {
        tolerance: 1e-12,
        max_iterations: 20,
    },
];

/// The static stretch is `α m g`: the velocity level (implicit, dissipative) settles
/// there; the explicit methods oscillate about it between 0 and `2 α m g` (released at
/// zero stretch) and keep the energy, elastic part included.
#[test]
fn a_hanging_body_stretches_its_joint_by_alpha_m_g() {
    let alpha = 1e-4; // k = 1e4 N/m, ω = √(k/m) ≈ 71 rad/s, hω = 0.07 at h = 1e-3.
    let stretch = alpha * 2.0 * 9.81;
    for (k, m) in METHODS.iter().enumerate() {
        let mut w = hanging(alpha);
        let (k0, p0) = w.energy();
        let (mut lo, mut hi, mut drift) = (f64::INFINITY, 0.0f64, 0.0f64);
        for _ in 0..3000 {
            w.step(1e-3, *m).unwrap();
            let s = w.max_separation();
            lo = lo.min(s);
            hi = hi.max(s);
            let (kin, pot) = w.energy();
            drift = drift.max(((kin + pot) - (k0 + p0)).abs());
        }
        let last = w.max_separation();
        println!(
            "method {k}: stretch {last:.4e} (static {stretch:.4e}), range [{lo:.3e}, {hi:.3e}], energy drift {drift:.2e} J"
        );
        if k < 2 {
            assert!((last - stretch).abs() < 1e-2 * stretch, "{k}: {last}");
        } else {
            assert!(hi < 2.05 * stretch && hi > 1.9 * stretch, "{k}: {hi}");
            // Elastic energy scale ½ k (2 α m g)² = 2 α (m g)² ≈ 7.7e-2 J.
            assert!(drift < 2e-3, "{k}: energy drift {drift}");
        }
    }
}

/// `α = 0` is the hard joint, bit for bit; at the velocity level a tiny `α` is close to
/// it (with projection it is not: compliant joints are left out of the projection).
#[test]
fn zero_compliance_is_the_hard_joint() {
    for m in METHODS {
        let mut hard = ball_chain(4, 3.0).unwrap();
        let mut zero = ball_chain(4, 3.0).unwrap();
        let mut tiny = ball_chain(4, 3.0).unwrap();
        for j in 0..4 {
            zero.set_compliance(j, 0.0).unwrap();
            tiny.set_compliance(j, 1e-12).unwrap();
        }
        for _ in 0..200 {
            hard.step(1e-3, m).unwrap();
            zero.step(1e-3, m).unwrap();
        }
        for (a, b) in hard.bodies().iter().zip(zero.bodies()) {
            assert_eq!(a.pose.x, b.pose.x);
        }
        if matches!(m, Method::Velocity { .. }) {
            let mut hard = ball_chain(4, 3.0).unwrap();
            for _ in 0..200 {
                hard.step(1e-3, m).unwrap();
                tiny.step(1e-3, m).unwrap();
            }
            let d = hard
                .bodies()
                .iter()
                .zip(tiny.bodies())
                .map(|(a, b)| (a.pose.x - b.pose.x).length())
                .fold(0.0, f64::max);
            assert!(d < 1e-6, "{m:?}: {d}");
        }
    }
}

/// The tree factorization with compliant rows matches the dense KKT solve.
#[test]
fn compliant_rows_match_the_dense_solve() {
    let mut w = ball_chain(6, 10.0).unwrap();
    // The dense system has no geometric stiffness (the tree adds it from the impulses of
    // the previous solve).
    w.geometric_stiffness = GeometricStiffness::Off;
    for (j, a) in [1e-6, 0.0, 1e-3, 1e-9, 0.0, 1.0].into_iter().enumerate() {
        w.set_compliance(j, a).unwrap();
    }
    for (i, b) in w.bodies_mut().iter_mut().enumerate() {
        b.pose.x += DVec3::new(0.01 * i as f64, -0.02, 0.005);
        b.v = DVec3::new(0.1, 0.2 * i as f64, -0.3);
    }
    for h in [1e-4, 1e-2] {
        let (m, rhs) = w.dense_velocity_system(h, 1.0);
        let n = rhs.len();
        let a = nalgebra::DMatrix::from_fn(n, n, |i, j| m[i][j]);
        let x = a
            .lu()
            .solve(&nalgebra::DVector::from_column_slice(&rhs))
            .unwrap();
        let tw = w.velocity_twists(h, 1.0).unwrap();
        let scale = x
            .iter()
            .take(6 * tw.len())
            .fold(1e-12f64, |s, v| s.max(v.abs()));
        let mut err: f64 = 0.0;
        for (i, (v, om)) in tw.iter().enumerate() {
            for k in 0..3 {
                err = err
                    .max((v[k] - x[6 * i + k]).abs())
                    .max((om[k] - x[6 * i + 3 + k]).abs());
            }
        }
        assert!(err / scale < 1e-10, "h = {h}: {:e}", err / scale);
    }
}

#[test]
fn bad_compliance_is_rejected() {
    let mut w = hanging(0.0);
    for a in [-1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            w.set_compliance(0, a),
            Err(ArticulatedError::InvalidJoint { joint: 0, .. })
        ));
    }
    assert!(w.set_compliance(1, 1e-3).is_err());
    assert_eq!(w.compliances(), &[0.0]);
}
