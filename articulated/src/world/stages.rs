//! The run-time stages of a step, for reports ("what does this scene run"): derived
//! from the world's content (loop joints, damped joints, compliant joints, gravity) and
//! configuration (geometric stiffness) and from the [`Method`].

use alloc::vec::Vec;

use super::*;

impl World {
    /// The stages a step with `method` goes through, in step order, as short
    /// `&'static str`s:
    ///
    /// * `gravity` when it is not zero;
    /// * the rigid-body rotation update: implicit gyroscopic step (velocity methods),
    ///   explicit gyroscopic torque (acceleration level), or the angular-momentum drift
    ///   with the implicit-midpoint `ω` (RATTLE);
    /// * Baraff's tree factorization of the KKT matrix, always; the loop-closure Schur
    ///   complement only when some joint closes a loop;
    /// * the equality rows' complement only when [`World::add_equality`] was used (an
    ///   acceleration-level step then runs at the velocity level);
    /// * damping rows (implicit) or damping forces (explicit, acceleration level) only
    ///   when some joint is damped;
    /// * compliant joints only when some [`World::compliances`] entry is `> 0`:
    ///   implicit `−α/h²` rows at the velocity level, the explicit spring force otherwise;
    /// * geometric stiffness for the velocity methods, per [`GeometricStiffness`] mode;
    /// * the method's own stages.
    pub fn stages(&self, method: Method) -> Vec<&'static str> {
        let mut out = Vec::with_capacity(10);
        if self.gravity != DVec3::ZERO {
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
        if self.loop_count() > 0 {
            out.push("loop closure: Schur complement (SVD)");
        }
        if !self.equalities.is_empty() {
            out.push("equality rows: Schur complement over the tree (SVD)");
        }
        if self.joints.iter().any(|j| j.damping_rows() > 0) {
            out.push(if explicit {
                "joint damping forces (explicit)"
            } else {
                "joint damping rows (implicit)"
            });
        }
        if self.compliance.iter().any(|&a| a > 0.0) {
            out.push(if velocity {
                "compliant joints (implicit −α/h² rows)"
            } else {
                "compliant joints (explicit spring force −(1/α) JᵀC)"
            });
        }
        if velocity {
            match self.geometric_stiffness {
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

    /// Loop-closure joints, without building the solver: the built solver's count when
    /// it is current, else a union-find over the joints (world included) — a joint
    /// whose two sides are already connected closes a loop.
    fn loop_count(&self) -> usize {
        if !self.solver_stale {
            return self.solver.loops.len();
        }
        let world = self.bodies.len();
        let mut parent: Vec<usize> = (0..=world).collect();
        let find = |p: &mut Vec<usize>, mut i: usize| {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        };
        let mut loops = 0;
        for j in &self.joints {
            let a = find(&mut parent, j.parent.unwrap_or(world));
            let b = find(&mut parent, j.child);
            if a == b {
                loops += 1;
            } else {
                parent[a] = b;
            }
        }
        loops
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::ball_chain;
    use constraint_core::Spherical;

    const RATTLE: Method = Method::Rattle {
        tolerance: 1e-12,
        max_iterations: 20,
    };

    /// A ball chain of two links whose tip is also held by a ball joint to the world:
    /// a closed loop (a four-bar-like linkage through the world).
    fn closed_chain() -> World {
        let mut w = ball_chain(2, 1.0).expect("chain");
        let tip = w.bodies()[1].pose;
        let anchor = tip.x + DVec3::new(-0.05, 0.0, 0.0);
        let sph = Spherical::from_world(&Pose::IDENTITY, &tip, anchor).expect("joint");
        w.add_joint(Joint {
            parent: None,
            child: 1,
            kind: JointKind::Spherical(sph),
            damping: 0.0,
        })
        .expect("loop joint");
        w
    }

    #[test]
    fn a_tree_reports_no_loop_stage_and_a_loop_does() {
        let mut w = ball_chain(3, 1.0).expect("chain");
        let loop_stage = "loop closure: Schur complement (SVD)";
        assert!(!w.stages(RATTLE).contains(&loop_stage));
        let mut c = closed_chain();
        assert!(c.stages(RATTLE).contains(&loop_stage));
        // The same answer from the union-find (stale solver) and the built solver.
        assert_eq!(c.loop_joints(), 1);
        assert!(c.stages(RATTLE).contains(&loop_stage));
        w.step(1e-3, RATTLE).expect("step");
        assert!(!w.stages(RATTLE).contains(&loop_stage));
    }

    #[test]
    fn damping_compliance_and_method_stages_only_when_present() {
        let mut w = ball_chain(3, 1.0).expect("chain");
        let vel = Method::Velocity { beta: 1.0 };
        let st = w.stages(vel);
        assert!(!st
            .iter()
            .any(|s| s.contains("damping") || s.contains("compliant")));
        assert!(st.contains(&"geometric stiffness (Auto: bodies past the (hω)² threshold)"));
        assert!(!w.stages(RATTLE).iter().any(|s| s.contains("geometric")));
        w.geometric_stiffness = GeometricStiffness::Off;
        assert!(!w.stages(vel).iter().any(|s| s.contains("geometric")));

        w.set_compliance(1, 1e-6).expect("compliance");
        assert!(w
            .stages(vel)
            .contains(&"compliant joints (implicit −α/h² rows)"));
        assert!(w
            .stages(RATTLE)
            .contains(&"compliant joints (explicit spring force −(1/α) JᵀC)"));

        let src = ball_chain(2, 1.0).expect("chain");
        let mut d = World::new(src.gravity);
        for b in src.bodies() {
            d.add_body(*b).expect("body");
        }
        for j in src.joints() {
            d.add_joint(Joint { damping: 0.1, ..*j })
                .expect("damped joint");
        }
        assert_eq!(d.loop_count(), 0);
        let acc = Method::Acceleration { kx: 0.0, kv: 0.0 };
        let st = d.stages(acc);
        assert!(st.contains(&"joint damping forces (explicit)"));
        assert!(!st.contains(&"Baumgarte stabilisation"));
        assert!(d.stages(vel).contains(&"joint damping rows (implicit)"));
        let r4 = Method::Rattle4 {
            tolerance: 1e-12,
            max_iterations: 20,
        };
        assert!(d.stages(r4).contains(&"Yoshida triple jump (RATTLE4)"));
        assert!(!d.stages(RATTLE).contains(&"Yoshida triple jump (RATTLE4)"));
    }
}
