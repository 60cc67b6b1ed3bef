//! The run-time stages of a contact step, for reports ("what does this scene run"):
//! the narrow-phase shape pairs the colliders can form, the settings, and the solver
//! path the last step actually took (recorded by the step).

use alloc::vec::Vec;

use super::*;
use crate::geometry::Shape;

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

impl ContactWorld {
    /// The stages of a step, in step order, as short `&'static str`s:
    ///
    /// * `gravity` when it is not zero, and the implicit gyroscopic update;
    /// * the broad phase (sweep and prune) and each narrow-phase shape pair the
    ///   colliders can form (two colliders on different bodies, not both static);
    /// * speculative contacts, restitution, Coulomb friction and warm starting when the
    ///   settings and materials use them;
    /// * the solver path: after a step, the one that step took (sequential impulses and
    ///   shock propagation; or the soft step; or the dense Delassus matrix with boxed PGS, or staggered
    ///   projections with the normal-LCP solvers whose answers were accepted and the
    ///   friction solve; or nothing to solve); before any step, the configured one;
    /// * position correction: split impulses when they ran (after a step) or are set
    ///   (before), the soft step's soft bias (relaxed each sub-step), Baumgarte velocity
    ///   bias when split impulses are off.
    pub fn stages(&self) -> Vec<&'static str> {
        let mut out = Vec::with_capacity(16);
        if self.gravity != DVec3::ZERO {
            out.push("gravity");
        }
        out.push("implicit gyroscopic update");
        out.push("broad phase: sweep and prune");
        let mut pairs = 0u16;
        for (i, a) in self.colliders.iter().enumerate() {
            for b in &self.colliders[i + 1..] {
                if a.body != b.body {
                    let (p, q) = (kind(&a.shape), kind(&b.shape));
                    pairs |= 1 << (4 * p.min(q) + p.max(q));
                }
            }
        }
        for a in 0..4 {
            for b in a..4 {
                if pairs & (1 << (4 * a + b)) != 0 {
                    out.extend(pair_stage(a, b));
                }
            }
        }
        let s = &self.settings;
        if s.margin > 0.0 {
            out.push("speculative contacts (margin)");
        }
        if self.colliders.iter().any(|c| c.restitution > 0.0) {
            out.push("restitution");
        }
        if self.colliders.iter().any(|c| c.friction > 0.0) {
            out.push("Coulomb friction (pyramid, two tangent rows)");
        }
        if s.warm_start {
            out.push("warm start");
        }
        let p = if self.path & path::STEPPED != 0 {
            self.path
        } else {
            self.configured_path()
        };
        let has = |bit: u16| p & bit != 0;
        if has(path::NO_ROWS) {
            out.push("no contact rows: nothing to solve");
        }
        if has(path::SEQUENTIAL) {
            out.push("sequential impulses (matrix-free PGS, bottom-up)");
        }
        if has(path::SHOCK) {
            out.push("shock propagation");
        }
        if has(path::SOFT_STEP) {
            out.push("soft step (sub-steps: soft solve, integrate, relax; restitution)");
        }
        if has(path::DENSE) {
            out.push("dense Delassus matrix J M⁻¹ Jᵀ");
            if has(path::BOXED_PGS) {
                out.push("PGS on the boxed LCP (friction in one problem)");
            } else {
                out.push("staggered projections (normal, then friction)");
            }
        }
        if p & path::STEPPED == 0 && s.solver == ContactSolver::Auto {
            out.push("Auto: dense Newton for few contact points, sequential impulses for many");
        }
        for (bit, stage) in [
            (path::NORMAL_NEWTON, "normal LCP: Fischer–Burmeister Newton"),
            (path::NORMAL_LEMKE, "normal LCP: Lemke"),
            (path::NORMAL_PGS, "normal LCP: PGS"),
            (path::FRICTION_PGS, "friction: PGS on the tangent block"),
            (path::FRICTION_BUDGET, "friction: PGS sweep budget kept"),
        ] {
            if has(bit) {
                out.push(stage);
            }
        }
        if has(path::SPLIT) {
            out.push("split impulses (pseudo-velocity position correction)");
        } else if has(path::SOFT_STEP) {
            out.push("soft contact bias (Box2D v3 soft constraints), relaxed each sub-step");
        } else if !s.split_impulse {
            out.push("Baumgarte velocity bias");
        }
        out
    }

    /// The path the settings ask for, before any step ([`path::STEPPED`] clear).
    fn configured_path(&self) -> u16 {
        let s = &self.settings;
        let split = if s.split_impulse { path::SPLIT } else { 0 };
        let shock = if s.shock_propagation > 0 {
            path::SHOCK
        } else {
            0
        };
        let friction = if self.colliders.iter().any(|c| c.friction > 0.0) {
            path::FRICTION_PGS
        } else {
            0
        };
        if let ContactSolver::SoftStep { .. } = s.solver {
            return path::SOFT_STEP;
        }
        split
            | match (s.solver, s.friction) {
                (ContactSolver::Auto, _) => 0,
                (ContactSolver::SoftStep { .. }, _) => path::SOFT_STEP,
                (ContactSolver::SequentialImpulses, _) => path::SEQUENTIAL | shock,
                (ContactSolver::Pgs, FrictionModel::Boxed) => path::DENSE | path::BOXED_PGS,
                (ContactSolver::Pgs, _) => path::DENSE | path::NORMAL_PGS | friction,
                (ContactSolver::Lemke, _) => path::DENSE | path::NORMAL_LEMKE | friction,
                (ContactSolver::Newton, _) => path::DENSE | path::NORMAL_NEWTON | friction,
            }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::{box_stack, sphere_drop};

    #[test]
    fn shape_pairs_and_the_solver_path_taken() {
        let mut w = sphere_drop(0.1, 0.2).expect("scene");
        let st = w.stages();
        assert!(st.contains(&"narrow phase: sphere–plane"));
        assert!(!st.iter().any(|s| s.contains("box")));
        assert!(st.iter().any(|s| s.starts_with("Auto")));
        // Falling, far from the ground: no rows; then resting: Newton (Auto, few points).
        w.step(1e-3).expect("step");
        assert!(w.stages().contains(&"no contact rows: nothing to solve"));
        for _ in 0..400 {
            w.step(1e-3).expect("step");
        }
        let st = w.stages();
        assert!(
            st.contains(&"normal LCP: Fischer–Burmeister Newton"),
            "{st:?}"
        );
        assert!(!st.contains(&"sequential impulses (matrix-free PGS, bottom-up)"));

        let mut s = box_stack(3).expect("stack");
        s.settings.solver = ContactSolver::SequentialImpulses;
        s.step(1.0 / 60.0).expect("step");
        let st = s.stages();
        assert!(st.contains(&"narrow phase: plane–box"));
        assert!(st.contains(&"narrow phase: box–box"));
        assert!(st.contains(&"sequential impulses (matrix-free PGS, bottom-up)"));
        assert!(st.contains(&"shock propagation"));
        assert!(!st.iter().any(|s| s.contains("Delassus")));
        s.settings.solver = ContactSolver::Pgs;
        s.settings.friction = FrictionModel::Boxed;
        s.settings.tolerance = 1e-6;
        let stats = s.step(1.0 / 60.0).expect("step");
        assert_eq!(stats.solver, Some(ContactSolver::Pgs));
        assert!(s
            .stages()
            .contains(&"PGS on the boxed LCP (friction in one problem)"));
    }
}
