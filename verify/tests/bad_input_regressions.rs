//! Named regression tests for the panics found by the bad-input sweep and the fuzzers
//! (issue 7). Each one panicked before its fix; each must now return a typed error and
//! leave the state unchanged.

use constraint_articulated::RigidBody;
use constraint_contact::geometry::{Collider, Shape};
use constraint_contact::rigid::{ContactSolver, ContactWorld};
use constraint_core::{DMat3, DQuat, DVec3, Distance, Pose};
use constraint_lagrange::deformable::{DeformableContact, DeformableSettings};
use constraint_soft::{
    ConstraintSet, HessianMode, ImplicitEuler, LinearSolver, SoftSystem, Softness,
};

fn box_on_ground() -> ContactWorld {
    let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
    w.add_collider(Collider::simple(None, Shape::plane(DVec3::Z, 0.0).unwrap()).unwrap())
        .unwrap();
    let pose = Pose {
        x: DVec3::new(0.0, 0.0, 0.499),
        q: DQuat::IDENTITY,
    };
    let b = w
        .add_body(
            RigidBody::new(0, 1.0, DMat3::from_diagonal(DVec3::splat(1.0 / 6.0)), pose).unwrap(),
        )
        .unwrap();
    w.add_collider(Collider::simple(Some(b), Shape::cuboid(DVec3::splat(0.5)).unwrap()).unwrap())
        .unwrap();
    w.settings.solver = ContactSolver::SequentialImpulses;
    w
}

/// Sweep case `ContactWorld::step SequentialImpulses gravity x=NaN`: NaN gravity reached
/// `f64::clamp` with NaN bounds in the sequential-impulse friction rows (a panic).
#[test]
fn contact_step_with_nan_gravity_is_rejected() {
    for g in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut w = box_on_ground();
        w.gravity = DVec3::new(g, 0.0, -9.81);
        let before = w.bodies().to_vec();
        assert!(w.step(1e-2).is_err(), "gravity {g}");
        assert_eq!(w.bodies(), before.as_slice());
    }
}

/// Sweep case `ContactWorld::step SequentialImpulses v x=NaN`: a non-finite velocity set
/// through `bodies_mut` panicked the same way.
#[test]
fn contact_step_with_nan_velocity_is_rejected() {
    for v in [f64::NAN, f64::INFINITY] {
        let mut w = box_on_ground();
        w.bodies_mut()[0].v = DVec3::new(v, 0.0, 0.0);
        let before: Vec<_> = w.bodies().iter().map(|b| format!("{b:?}")).collect();
        assert!(w.step(1e-2).is_err(), "v {v}");
        let after: Vec<_> = w.bodies().iter().map(|b| format!("{b:?}")).collect();
        assert_eq!(after, before);
    }
}

/// Sweep case `DeformableContact::step x resized`: a position array longer than the
/// particle count indexed past `pinned()` (a panic); now `LengthMismatch`.
#[test]
fn deformable_step_with_resized_positions_is_rejected() {
    let x = vec![DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0)];
    let mut sys = SoftSystem::new(x.clone(), vec![1.0, 1.0]).unwrap();
    let spring = Distance::from_rest(0, 1, &x).unwrap();
    sys.add_set(ConstraintSet::uniform("s", vec![spring], Softness::stiff(1e3)).unwrap())
        .unwrap();
    sys.x.push(DVec3::ZERO);
    let ground = Collider::simple(None, Shape::plane(DVec3::Z, -2.0).unwrap()).unwrap();
    let mut dc = DeformableContact::new(vec![ground], DeformableSettings::default()).unwrap();
    let mut imp =
        ImplicitEuler::new(1e-3, HessianMode::Projected, LinearSolver::SparseLdlt).unwrap();
    assert!(dc.step(&mut sys, &mut imp).is_err());
    assert_eq!(sys.x.len(), 3);
}

/// Fuzz crash `world_step` crash-0c30798a (cargo xtask fuzz): a finite but huge contact
/// state (speeds 2.4e35 m/s, gravity 2.4e35, h = 9.6e289 s) overflowed to NaN friction
/// bounds and `f64::clamp` panicked in the sequential impulses. Now the step returns a
/// typed error (divergence, state rolled back) or a finite state.
#[test]
fn contact_step_with_overflowing_state_does_not_panic() {
    let big = 2.417370521746097e35;
    for solver in [
        ContactSolver::SequentialImpulses,
        ContactSolver::Pgs,
        ContactSolver::Newton,
        ContactSolver::Lemke,
        ContactSolver::Auto,
    ] {
        let mut w = ContactWorld::new(DVec3::splat(big));
        w.settings.solver = solver;
        w.add_collider(Collider::simple(None, Shape::plane(DVec3::Z, 0.0).unwrap()).unwrap())
            .unwrap();
        let pose = Pose {
            x: DVec3::new(2.3079303e-317, 2.4173705200226903e35, big),
            q: DQuat::from_xyzw(0.5, 0.5, 0.5, 0.5),
        };
        let inertia = DMat3::from_diagonal(DVec3::new(big, 2.417371660650933e35, big));
        let b = RigidBody::new(0, big, inertia, pose)
            .unwrap()
            .with_velocity(
                DVec3::new(big, big, -6.8e-229),
                DVec3::new(4.8e-82, 0.0, 0.0),
            );
        let b = w.add_body(b).unwrap();
        w.add_collider(Collider::simple(Some(b), Shape::sphere(big).unwrap()).unwrap())
            .unwrap();
        for _ in 0..3 {
            let before: Vec<String> = w.bodies().iter().map(|b| format!("{b:?}")).collect();
            match w.step(9.583017123249968e289) {
                Ok(_) => assert!(w
                    .bodies()
                    .iter()
                    .all(|b| b.v.is_finite() && b.pose.x.is_finite())),
                Err(_) => {
                    let after: Vec<String> = w.bodies().iter().map(|b| format!("{b:?}")).collect();
                    assert_eq!(after, before);
                    break;
                }
            }
        }
    }
}

/// Fuzz crash `kkt_solvers` crash-56c7c419: one empty row with compliance 8.6e-308 and
/// `c = 1.1e45` gives `λ = c/D = ∞`, returned as `Ok` by `solve_kkt` (Auto → dense
/// Schur). Fixed: `solve_kkt` now checks its inputs' and its output's finiteness and
/// returns `KktError::Solve(SolveError::NonFinite)`.
#[test]
fn kkt_tiny_compliance_overflows_lambda() {
    use constraint_lagrange::{
        solve_kkt, ConstraintRows, KktProblem, KktSolver, KktWorkspace, MassMatrix,
    };
    let mut rows = ConstraintRows::new();
    rows.push_row(1.725719624415102e-82, &[]);
    let p = KktProblem {
        mass: MassMatrix::Diagonal {
            mass: &[],
            pinned: &[],
        },
        rows: &rows,
        compliance: &[8.610159193605102e-308],
        b: &[],
        c: &[1.1195670988083561e45],
    };
    let mut lambda = [0.0];
    let r = solve_kkt(
        &p,
        KktSolver::Auto,
        &mut KktWorkspace::default(),
        &mut [],
        &mut lambda,
    );
    assert!(
        r.is_err() || lambda[0].is_finite(),
        "lambda = {}",
        lambda[0]
    );
}

/// Fuzz crash `particle_step` crash-dc02bef6 (cargo xtask fuzz): a NaN position written
/// through the public `SoftSystem::x` went through `DeformableContact::step` (no
/// colliders, implicit Euler, Gauss–Newton, sparse LDLᵀ) and came back `Ok` with the NaN
/// still there; the step also wrote positions before the velocity check that could fail.
/// Fixed: the new state is built aside and committed only when finite and bounded, else
/// `Soft(Diverged)` with the state unchanged.
#[test]
fn deformable_step_with_nan_position_is_rejected() {
    let mut sys = SoftSystem::new(vec![DVec3::ZERO], vec![2.82932772e-315]).unwrap();
    sys.x[0] = DVec3::new(f64::NAN, 6.150994174457306e-304, 1.3906722225545867e-308);
    sys.v[0] = DVec3::new(
        2.9043552100789517e-144,
        2.9043552100789517e-144,
        2.904355210078967e-144,
    );
    let mut dc = DeformableContact::new(Vec::new(), DeformableSettings::default()).unwrap();
    let mut imp =
        ImplicitEuler::new(1e-3, HessianMode::GaussNewton, LinearSolver::SparseLdlt).unwrap();
    let before = format!("{:?} {:?} {}", sys.x, sys.v, sys.steps);
    for _ in 0..2 {
        assert!(dc.step(&mut sys, &mut imp).is_err());
        assert_eq!(format!("{:?} {:?} {}", sys.x, sys.v, sys.steps), before);
    }
}

/// Fuzz crash `particle_step` crash-cbb5069e (bare `FastProjection::project`): with no constraint
/// touching it, a NaN position left the largest relative violation at 0, so the
/// projection returned `Ok` (converged) with the NaN in place. Fixed: positions are
/// checked for finiteness before the tolerance; now `Kkt(Solve(NonFinite))`.
#[test]
fn projection_of_unconstrained_nan_positions_is_rejected() {
    use constraint_lagrange::{Constraints, FastProjection, KktSolver};
    let mut p = FastProjection::new(6.078577631456752e199, 14, KktSolver::Auto).unwrap();
    let mut x = [DVec3::new(-2.9740338169555658e284, 3.288e-320, f64::NAN)];
    let r = p.project(&[1.3029477597e-314], &[], &Constraints::new(), &mut x);
    assert!(r.is_err(), "{r:?}");
}

/// Fuzz crash `particle_step` crash-63f1f2e0 (acceleration level, Baumgarte `k_x = 1e-9`):
/// a position `(2.3e-106, NaN, −1.6e-219)` written through the public `x` was committed:
/// the lagrange steps' divergence check `|x|.max_element() < 1e12` skips a NaN in the x or y
/// component (glam's `max_element` is `if a > b { a } else { b }`). Fixed in the shared
/// commit and in RATTLE's velocity check (`is_finite` first); every formulation now
/// returns `Diverged` (or another typed error) and leaves the state unchanged.
#[test]
fn lagrange_steps_reject_nan_position_component() {
    use constraint_lagrange::{
        AccelerationLevel, BaseStep, Baumgarte, Constraints, HardSet, KktSolver, Rattle,
        RattleOrder, VelocityLevel,
    };
    for axis in 0..3 {
        let mut sys = SoftSystem::new(vec![DVec3::ZERO; 2], vec![1.0, 1.0]).unwrap();
        let mut x = [2.3158748340166987e-106, 0.5, -1.64430875895095e-219];
        x[axis] = f64::NAN;
        sys.x[0] = DVec3::from_array(x);
        sys.v[0] = DVec3::new(-3.28832457827217e-219, -3.28832457827217e-219, 7.96e-310);
        let empty = Constraints::new();
        // One spring on the other particle, so the KKT solves have a row.
        let mut one = Constraints::new();
        one.add(HardSet::hard(
            "s",
            vec![Distance {
                points: [1, 1],
                rest_length: 1.0,
            }],
        ));
        for cons in [&empty, &one] {
            let before = format!("{:?} {:?} {}", sys.x, sys.v, sys.steps);
            let same = |sys: &SoftSystem| {
                assert_eq!(
                    format!("{:?} {:?} {}", sys.x, sys.v, sys.steps),
                    before,
                    "axis {axis}"
                )
            };
            let b = Baumgarte {
                kx: 1e-9,
                kv: 3.918e-320,
            };
            let mut acc = AccelerationLevel::new(1e-3, b, KktSolver::Auto).unwrap();
            assert!(
                acc.step(&mut sys, cons).is_err(),
                "acceleration, axis {axis}"
            );
            same(&sys);
            let mut vel = VelocityLevel::new(1e-3, BaseStep::Explicit, KktSolver::Auto).unwrap();
            assert!(vel.step(&mut sys, cons).is_err(), "velocity, axis {axis}");
            same(&sys);
            for order in [RattleOrder::Second, RattleOrder::Fourth] {
                let mut r = Rattle::new(1e-3, order, 1e-9, 20, KktSolver::Auto).unwrap();
                assert!(r.step(&mut sys, cons).is_err(), "{order:?}, axis {axis}");
                same(&sys);
            }
        }
    }
}
