//! The words of [`super::section`]: each library's configuration and the statistics its
//! steps record (plain data: [`Scheme`], [`VelocityLevel::last_solver`],
//! [`SolverPath`], …) turned into short stage names, in step order. The libraries keep
//! no report text; this module is where the vocabulary lives.

use constraint_articulated::{GeometricStiffness, Method, World};
use constraint_contact::geometry::Shape;
use constraint_contact::lcp::RowMethod;
use constraint_contact::rigid::{
    ContactSolver, ContactWorld, FrictionModel, RowsSolver, SolverPath,
};
use constraint_core::DVec3;
use constraint_lagrange::{
    AccelerationLevel, BaseStep, Baumgarte, Constraints, FastProjection, KktSolver, ProjectedStep,
    Rattle, RattleOrder, VelocityLevel,
};
use constraint_soft::{HessianMode, Integrator, LinearSolver, Scheme, SoftSystem};

/// The force stages a step of `sys` evaluates: `gravity` when it is not zero, `pins`
/// when a particle is pinned, then one entry per non-empty constraint set,
/// `name: count Kind` with `, damped` when some constraint of the set has damping (for
/// example `springs: 144 Distance`).
pub fn soft_system(sys: &SoftSystem) -> Vec<String> {
    let mut out = Vec::new();
    if sys.gravity != DVec3::ZERO {
        out.push("gravity".to_string());
    }
    if sys.pinned().iter().any(|&p| p) {
        out.push("pins".to_string());
    }
    for s in sys.sets().filter(|s| !s.is_empty()) {
        let damped = if s.damped() { ", damped" } else { "" };
        out.push(format!("{}: {} {}{damped}", s.name(), s.len(), s.kind()));
    }
    out
}

/// Appends the stages of an integrator's [`Scheme`] (nothing for [`Scheme::Other`]).
pub fn scheme(scheme: Scheme, out: &mut Vec<&'static str>) {
    match scheme {
        Scheme::SymplecticEuler => out.push("symplectic Euler (explicit forces)"),
        Scheme::ImplicitEuler { mode, solver } => {
            out.push("implicit Euler assembly (M − h∂F/∂v − h²∂F/∂x)");
            out.push(match mode {
                HessianMode::Exact => "exact Hessian",
                HessianMode::GaussNewton => "Gauss–Newton Hessian",
                HessianMode::Projected => "per-element projected Hessian",
            });
            out.push(match solver {
                LinearSolver::ConjugateGradient(_) => "block-Jacobi CG",
                LinearSolver::SparseLdlt => "sparse LDLᵀ (faer)",
                LinearSolver::LaggedLdlt(_) => "lagged-LDLᵀ-preconditioned CG (faer)",
            });
        }
        Scheme::Other => {}
    }
}

/// The stages of an integrator's step ([`Integrator::scheme`]).
pub fn integrator(integ: &dyn Integrator) -> Vec<&'static str> {
    let mut out = Vec::new();
    scheme(integ.scheme(), &mut out);
    out
}

/// The sets a step assembles: one entry per set with rows, `hard name: rows × Kind` or
/// `compliant name: rows × Kind` (for example `hard links: 5 × Distance`).
pub fn constraints(cons: &Constraints) -> Vec<String> {
    cons.sets()
        .filter(|s| s.rows() > 0)
        .map(|s| {
            let level = if s.compliant() { "compliant" } else { "hard" };
            format!("{level} {}: {} × {}", s.name(), s.rows(), s.kind())
        })
        .collect()
}

/// A KKT solver's name.
pub fn kkt(solver: KktSolver) -> &'static str {
    match solver {
        KktSolver::Auto => "KKT solver chosen at the solve (Auto)",
        KktSolver::DenseSchur => "dense Schur complement (Cholesky, SVD if singular)",
        KktSolver::SparseSchur => "sparse Schur complement (faer Cholesky)",
        KktSolver::Minres(_) => "MINRES on the KKT matrix",
        KktSolver::Gmres { .. } => "restarted GMRES on the KKT matrix",
        KktSolver::Svd { .. } => "minimum-norm SVD of the Schur complement",
        KktSolver::DampedLeastSquares { .. } => "damped least squares on the Schur complement",
    }
}

/// The KKT solver of a solve with a diagonal `A`: the recorded one, else the one
/// `requested` resolves to for `cons` ([`KktSolver::resolve`]).
fn kkt_of(recorded: Option<KktSolver>, requested: KktSolver, cons: &Constraints) -> &'static str {
    kkt(recorded.unwrap_or_else(|| requested.resolve(true, cons.rows())))
}

/// The stages of an acceleration-level step under `cons`: the KKT system, the `J̇ẋ` term
/// when included, Baumgarte stabilisation when its gains are not zero, the KKT solver
/// (recorded by the last step) and the symplectic Euler update.
pub fn acceleration(a: &AccelerationLevel, cons: &Constraints) -> Vec<&'static str> {
    let mut out = vec!["acceleration level [M Jᵀ; J 0][ẍ; λ] = [F; −J̇ẋ − k_x C − k_v Ċ]"];
    if a.velocity_term {
        out.push("velocity term J̇ẋ (constraint curvature)");
    }
    if a.baumgarte != Baumgarte::NONE {
        out.push("Baumgarte stabilisation");
    }
    out.push(kkt_of(a.last_solver(), a.solver, cons));
    out.push("symplectic Euler update");
    out
}

/// The stages of a velocity-level step under `cons`: the KKT system, its base step
/// (explicit `A = M`, or the implicit step's scheme), compliant rows when some set is
/// compliant, the KKT solver (recorded by the last step, else as `Auto` would resolve),
/// and the position projection when set.
pub fn velocity(v: &VelocityLevel, cons: &Constraints) -> Vec<&'static str> {
    let mut out = vec!["velocity level [A Jᵀ; J −α/h²][v; λ] = [b; −C/h]"];
    let diagonal = match &v.base {
        BaseStep::Explicit => {
            out.push("explicit base (A = M, b = M v + h F)");
            true
        }
        BaseStep::Implicit(imp) => {
            out.push("implicit base (the soft linearized backward Euler A, b)");
            scheme(imp.scheme(), &mut out);
            false
        }
    };
    if cons.any_compliant() {
        out.push("compliant rows (−α/h² block)");
    }
    out.push(kkt(v
        .last_solver()
        .unwrap_or_else(|| v.solver.resolve(diagonal, cons.rows()))));
    if let Some(p) = &v.projection {
        projection(p, cons, &mut out);
    }
    out
}

/// Appends a fast projection's stages: the Newton iterations and their KKT solver.
fn projection(p: &FastProjection, cons: &Constraints, out: &mut Vec<&'static str>) {
    out.push("fast projection (Goldenthal): Newton on C(x) = 0");
    out.push(kkt_of(None, p.solver, cons));
    out.push("velocities from positions (x − x₀)/h");
}

/// The stages of a projected step under `cons`: the base integrator's, then the
/// projection's.
pub fn projected<I: Integrator>(p: &ProjectedStep<I>, cons: &Constraints) -> Vec<&'static str> {
    let mut out = Vec::new();
    scheme(p.base.scheme(), &mut out);
    projection(&p.projection, cons, &mut out);
    out
}

/// The stages of a RATTLE step under `cons`: the kicks and drift, SHAKE, the velocity
/// projection, their KKT solver, and Yoshida's composition for RATTLE4.
pub fn rattle(r: &Rattle, cons: &Constraints) -> Vec<&'static str> {
    let mut out = vec![
        "RATTLE kick–drift–kick (Störmer–Verlet)",
        "SHAKE position projection (chord, Newton fallback)",
        "velocity projection J v = 0",
        kkt_of(None, r.solver, cons),
    ];
    if r.order == RattleOrder::Fourth {
        out.push("Yoshida triple jump (RATTLE4)");
    }
    out
}

/// The stages a step of `w` with `method` goes through: gravity when not zero; the
/// rotation update (implicit gyroscopic step at the velocity level, explicit torque at
/// the acceleration level, angular-momentum drift for RATTLE); Baraff's tree
/// factorization, the loop closure when some joint closes a loop
/// ([`World::loop_joints`]), the equality rows when some are present; damping and
/// compliance when some joint has them; geometric stiffness for the velocity methods;
/// the method's own stages.
pub fn world(w: &mut World, method: Method) -> Vec<&'static str> {
    let mut out = Vec::new();
    if w.gravity != DVec3::ZERO {
        out.push("gravity");
    }
    let velocity = matches!(
        method,
        Method::Velocity { .. } | Method::VelocityProjected { .. }
    );
    let explicit = matches!(method, Method::Acceleration { .. });
    out.push(if velocity {
        "implicit gyroscopic update (one Newton step)"
    } else if explicit {
        "explicit gyroscopic torque"
    } else {
        "angular-momentum drift (implicit-midpoint ω)"
    });
    out.push("tree KKT factorization (Baraff, leaves first)");
    if w.loop_joints() > 0 {
        out.push("loop closure: Schur complement (SVD)");
    }
    if !w.equalities().is_empty() {
        out.push("equality rows: Schur complement over the tree (SVD)");
    }
    if w.joints().iter().any(|j| j.damping_rows() > 0) {
        out.push(if explicit {
            "joint damping forces (explicit)"
        } else {
            "joint damping rows (implicit)"
        });
    }
    if w.compliances().iter().any(|&a| a > 0.0) {
        out.push(if velocity {
            "compliant joints (implicit −α/h² rows)"
        } else {
            "compliant joints (explicit spring force −(1/α) JᵀC)"
        });
    }
    if velocity {
        match w.geometric_stiffness {
            GeometricStiffness::Off => {}
            GeometricStiffness::Always => out.push("geometric stiffness (every body)"),
            GeometricStiffness::Auto { .. } => {
                out.push("geometric stiffness (Auto: bodies past the (hω)² threshold)")
            }
        }
    }
    match method {
        Method::Velocity { .. } => out.push("velocity level [M Jᵀ; J −C][v'; λ]"),
        Method::VelocityProjected {
            correct_velocity, ..
        } => {
            out.push("velocity level [M Jᵀ; J −C][v'; λ]");
            out.push("Newton position projection");
            if correct_velocity {
                out.push("projection correction into velocities (δ/h)");
            }
        }
        Method::Acceleration { kx, kv } => {
            out.push("acceleration level [M Jᵀ; J 0][a; λ]");
            if kx > 0.0 || kv > 0.0 {
                out.push("Baumgarte stabilisation");
            }
            out.push("symplectic Euler update");
        }
        Method::Rattle { .. } | Method::Rattle4 { .. } => {
            out.extend([
                "RATTLE kick–drift–kick",
                "SHAKE position projection",
                "velocity projection J v = 0",
            ]);
            if matches!(method, Method::Rattle4 { .. }) {
                out.push("Yoshida triple jump (RATTLE4)");
            }
        }
    }
    out
}

/// Index of a shape kind in the narrow phase's order (sphere, plane, capsule, box).
fn kind(s: &Shape) -> usize {
    match s {
        Shape::Sphere { .. } => 0,
        Shape::Plane { .. } => 1,
        Shape::Capsule { .. } => 2,
        Shape::Box { .. } => 3,
    }
}

/// The narrow-phase routine of a pair of kinds (`a ≤ b`); `None` for plane–plane (no
/// contacts).
fn pair_stage(a: usize, b: usize) -> Option<&'static str> {
    Some(match (a, b) {
        (0, 0) => "narrow phase: sphere–sphere",
        (0, 1) => "narrow phase: sphere–plane",
        (0, 2) => "narrow phase: sphere–capsule",
        (0, 3) => "narrow phase: sphere–box",
        (1, 2) => "narrow phase: plane–capsule",
        (1, 3) => "narrow phase: plane–box",
        (2, 2) => "narrow phase: capsule–capsule",
        (2, 3) => "narrow phase: capsule–box",
        (3, 3) => "narrow phase: box–box",
        _ => return None,
    })
}

/// The path the settings ask for, before any step (what [`contact`] says then).
fn configured_path(w: &ContactWorld) -> SolverPath {
    let s = &w.settings;
    let mut p = SolverPath::default();
    if let ContactSolver::SoftStep { .. } = s.solver {
        p.rows = RowsSolver::SoftStep;
        return p;
    }
    p.split = s.split_impulse;
    let friction = w.colliders().iter().any(|c| c.friction > 0.0);
    match (s.solver, s.friction) {
        (ContactSolver::Auto | ContactSolver::SoftStep { .. }, _) => {}
        (ContactSolver::SequentialImpulses, _) => {
            p.rows = RowsSolver::Sequential;
            p.shock = s.shock_propagation > 0;
        }
        (ContactSolver::Pgs, FrictionModel::Boxed) => {
            p.rows = RowsSolver::Dense;
            p.boxed_pgs = true;
        }
        (solver, _) => {
            p.rows = RowsSolver::Dense;
            p.normal = Some(match solver {
                ContactSolver::Lemke => RowMethod::Lemke,
                ContactSolver::Newton => RowMethod::Newton,
                _ => RowMethod::Pgs,
            });
            p.friction_pgs = friction;
        }
    }
    p
}

/// The stages of a contact step: gravity and the gyroscopic update; the broad phase
/// and each narrow-phase shape pair the colliders can form (two colliders on different
/// bodies); speculative contacts, restitution, friction and warm starting when the
/// settings and materials use them; the solver path the last step recorded
/// ([`ContactWorld::last_path`]; before any step, the configured one); the position
/// correction.
pub fn contact(w: &ContactWorld) -> Vec<&'static str> {
    let mut out = Vec::new();
    if w.gravity != DVec3::ZERO {
        out.push("gravity");
    }
    out.push("implicit gyroscopic update");
    out.push("broad phase: sweep and prune");
    let mut pairs = [[false; 4]; 4];
    let colliders = w.colliders();
    for (i, a) in colliders.iter().enumerate() {
        for b in &colliders[i + 1..] {
            if a.body != b.body {
                let (p, q) = (kind(&a.shape), kind(&b.shape));
                pairs[p.min(q)][p.max(q)] = true;
            }
        }
    }
    for a in 0..4 {
        for b in a..4 {
            if pairs[a][b] {
                out.extend(pair_stage(a, b));
            }
        }
    }
    let s = &w.settings;
    if s.margin > 0.0 {
        out.push("speculative contacts (margin)");
    }
    if colliders.iter().any(|c| c.restitution > 0.0) {
        out.push("restitution");
    }
    if colliders.iter().any(|c| c.friction > 0.0) {
        out.push("Coulomb friction (pyramid, two tangent rows)");
    }
    if s.warm_start {
        out.push("warm start");
    }
    let stepped = w.last_path();
    let p = stepped.unwrap_or_else(|| configured_path(w));
    let configured_auto = stepped.is_none() && s.solver == ContactSolver::Auto;
    match p.rows {
        RowsSolver::NoRows if !configured_auto => out.push("no contact rows: nothing to solve"),
        RowsSolver::NoRows => {}
        RowsSolver::Sequential => out.push("sequential impulses (matrix-free PGS, bottom-up)"),
        RowsSolver::SoftStep => {
            out.push("soft step (sub-steps: soft solve, integrate, relax; restitution)")
        }
        RowsSolver::Dense => out.push("dense Delassus matrix J M⁻¹ Jᵀ"),
    }
    if p.shock {
        out.push("shock propagation");
    }
    if p.rows == RowsSolver::Dense {
        out.push(if p.boxed_pgs {
            "PGS on the boxed LCP (friction in one problem)"
        } else if p.boxed_fallback {
            "PGS on the boxed LCP out of sweeps: staggered projections answered"
        } else {
            "staggered projections (normal, then friction)"
        });
    }
    if configured_auto {
        out.push("Auto: dense Newton for few contact points, the soft step for many");
    }
    out.extend(match p.normal {
        Some(RowMethod::Newton) => Some("normal LCP: Fischer–Burmeister Newton"),
        Some(RowMethod::Lemke) => Some("normal LCP: Lemke"),
        Some(RowMethod::Pgs) => Some("normal LCP: PGS"),
        None => None,
    });
    if p.friction_pgs {
        out.push("friction: PGS on the tangent block");
    }
    if p.friction_budget {
        out.push("friction: PGS sweep budget kept");
    }
    if p.split {
        out.push("split impulses (pseudo-velocity position correction)");
    } else if p.rows == RowsSolver::SoftStep {
        out.push("soft contact bias (Box2D v3 soft constraints), relaxed each sub-step");
    } else if !s.split_impulse {
        out.push("Baumgarte velocity bias");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use constraint_contact::scenes::{box_stack, sphere_drop};

    /// Before a step the words follow the settings; after it, the path the step
    /// recorded.
    #[test]
    fn contact_words_follow_the_configuration_then_the_recorded_path() {
        let mut w = sphere_drop(0.1, 0.2).expect("scene");
        let st = contact(&w);
        assert!(st.contains(&"narrow phase: sphere–plane"));
        assert!(!st.iter().any(|s| s.contains("box")));
        assert!(st.iter().any(|s| s.starts_with("Auto")), "{st:?}");
        assert!(
            !st.iter().any(|s| s.starts_with("no contact rows")),
            "{st:?}"
        );
        w.step(1e-3).expect("step");
        let st = contact(&w);
        assert!(st.contains(&"no contact rows: nothing to solve"), "{st:?}");
        assert!(!st.iter().any(|s| s.starts_with("Auto")), "{st:?}");

        let mut s = box_stack(3).expect("stack");
        s.settings.solver = ContactSolver::SequentialImpulses;
        let configured = contact(&s);
        s.step(1.0 / 60.0).expect("step");
        let stepped = contact(&s);
        for st in [&configured, &stepped] {
            assert!(st.contains(&"narrow phase: box–box"), "{st:?}");
            assert!(st.contains(&"sequential impulses (matrix-free PGS, bottom-up)"));
            assert!(st.contains(&"shock propagation"));
            assert!(!st.iter().any(|s| s.contains("Delassus")));
        }
        s.settings.solver = ContactSolver::Lemke;
        let st = contact(&s);
        // Still the recorded path of the last step, not the new setting.
        assert!(!st.contains(&"normal LCP: Lemke"), "{st:?}");
        s.step(1.0 / 60.0).expect("step");
        let st = contact(&s);
        assert!(st.contains(&"dense Delassus matrix J M⁻¹ Jᵀ"), "{st:?}");
        assert!(st.contains(&"staggered projections (normal, then friction)"));
    }

    /// Boxed PGS that runs out of sweeps under a 10⁴:1 box says the staggered solve
    /// answered on the steps where it did (33 of 120 at h = 1/60, `contact/tests/scenes.rs`).
    #[test]
    fn contact_words_name_the_boxed_fallback() {
        let mut w = constraint_contact::scenes::heavy_on_light(1e4).expect("scene");
        w.settings.solver = ContactSolver::Pgs;
        w.settings.friction = FrictionModel::Boxed;
        let mut seen = (0, 0);
        for _ in 0..120 {
            w.step(1.0 / 60.0).expect("step");
            let st = contact(&w);
            let fell = w.last_path().is_some_and(|p| p.boxed_fallback);
            let says =
                st.contains(&"PGS on the boxed LCP out of sweeps: staggered projections answered");
            assert_eq!(fell, says, "{st:?}");
            assert_eq!(
                !fell,
                st.contains(&"PGS on the boxed LCP (friction in one problem)"),
                "{st:?}"
            );
            seen.0 += usize::from(fell);
            seen.1 += 1;
        }
        assert!(seen.0 > 0 && seen.0 < seen.1, "{seen:?}"); // measured 33 of 120
    }
}
