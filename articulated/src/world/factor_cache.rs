//! Reuse of the tree factor between solves of the same matrix.
//!
//! RATTLE factors the KKT matrix `[M Jᵀ; J −C]` ([`crate::tree`]) several times per
//! step, and some of these matrices are equal. With damping or velocity-dependent forces
//! a step is `B_{h/2} ∘ C⁰_h ∘ B_{h/2}` (`rattle.rs`), four factorizations:
//!
//! ```text
//! B_{h/2} at x_n      (damping rows, compliance 1/(γ h/2 · d))   = the previous step's last
//! kick 1  at x_n      (armature rows only, |h|/2)                 = the previous step's kick 2
//!                     (looked up for SHAKE; not solved after the flow, `rattle.rs`)
//! kick 2  at x_{n+1}  (the same assembly)                         new
//! B_{h/2} at x_{n+1}                                              new
//! ```
//!
//! (SHAKE's iterations and each flow's second stage reuse the factor they follow, as
//! before.) Between one step's end and the next step's start only the velocities
//! change, and the matrix does not read them. Without damping the step is `C_h`, two
//! factorizations, the first equal to the previous step's second.
//!
//! The matrix of an assembly is a function of: the bodies' poses (the joints' Jacobians,
//! the world inertias `R I Rᵀ`), masses and body-frame inertias; the joints, which do
//! not change after [`World::add_joint`] (adding one rebuilds the solver and drops the
//! kept factors); the joints' compliances and armatures; and the assembly's `h`, its
//! rate rows ([`Rates`]) and its treatment of compliant rows ([`Soft`]). A
//! [`FactorKey`] holds the bits of all of them. The world keeps the factor in the solver
//! and one factor set aside, each with its key; an assembly whose key equals a kept
//! one's bit for bit takes that factor instead of computing it — the same operations on
//! the same bits would give the same factor — so every result is unchanged to the bit.
//! Assemblies without a key (the velocity level, whose matrix also reads the joint
//! impulses through the geometric stiffness, the projection, the acceleration level)
//! mark the solver's factor unknown.
//!
//! The first flow of a RATTLE step is at the poses where the last step's final flow
//! looked up its factor, kept its rows and inertias and evaluated its forces. Where
//! nothing has been assembled or written since (`World::flow_end`: the step count and
//! the rows' pose epoch of that flow, cleared by `bodies_mut`, `add_body`, `add_joint`,
//! `set_compliance` and `set_armature`), the flow takes them without comparing keys
//! ([`World::reuse_factor_unmoved`], `CachedRows::seen`, `KeptInertia::Trust`) and
//! applies the kept actuator and spring forces again (`rattle::DofFlow`). Issue 13
//! (callgrind, `World::step`, 2 s, with the rows' pose epochs): dm swimmer6 passive
//! 75.12M → 72.87M instructions, dm fish perturbed 44.37M → 43.05M; the same bits.

use alloc::vec::Vec;

use crate::body::RigidBody;
use crate::tree::FactorStore;
use constraint_core::compound::MAX_DOF;
use constraint_core::DMat3;

use super::{Rates, Soft, World};

/// Bits of one body's part of the matrix: position (3), orientation (4), mass (1) and
/// body-frame inertia (9).
type BodyBits = [u64; 17];

/// A body's [`BodyBits`]: what its part of the matrix reads, bit for bit (also a part of
/// the equality complement's key in `eq_cache`).
pub(super) fn body_bits(b: &RigidBody) -> BodyBits {
    let (x, q, m) = (b.pose.x, b.pose.q, b.inertia());
    let (c0, c1, c2) = (m.x_axis, m.y_axis, m.z_axis);
    [
        x.x,
        x.y,
        x.z,
        q.x,
        q.y,
        q.z,
        q.w,
        b.mass(),
        c0.x,
        c0.y,
        c0.z,
        c1.x,
        c1.y,
        c1.z,
        c2.x,
        c2.y,
        c2.z,
    ]
    .map(f64::to_bits)
}

/// Whether `b`'s [`BodyBits`] are `k`: the differences of all 17 words or-ed, one test
/// per body (the array comparison called `memcmp` once per body).
#[inline]
fn same_bits(k: &BodyBits, b: &RigidBody) -> bool {
    let now = body_bits(b);
    let mut d = 0u64;
    for (a, c) in k.iter().zip(&now) {
        d |= a ^ c;
    }
    d == 0
}

/// Bits of what a body's rotation `R` and world inertia `R I Rᵀ` read: orientation (4)
/// and body-frame inertia (9).
type InertiaBits = [u64; 13];

/// A body's [`InertiaBits`].
#[inline]
fn inertia_bits(b: &RigidBody) -> InertiaBits {
    let (q, m) = (b.pose.q, b.inertia());
    let (c0, c1, c2) = (m.x_axis, m.y_axis, m.z_axis);
    [
        q.x, q.y, q.z, q.w, c0.x, c0.y, c0.z, c1.x, c1.y, c1.z, c2.x, c2.y, c2.z,
    ]
    .map(f64::to_bits)
}

/// The bodies' rotations `R` as [`World::body_rhs_with`] last computed them (with the
/// world inertias `R I Rᵀ` it keeps in `World::body_iw`), each with the bits it was
/// computed from. RATTLE assembles at one configuration four times (the second kick
/// and the damping flow at `x_{n+1}`, the next step's damping flow and first kick at
/// the same `x_{n+1}`); the three assemblies that reuse the factor take the kept
/// rotations and inertias of the bodies whose bits are unchanged — the same
/// operations on the same bits would give the same values.
#[derive(Clone, Debug, Default)]
pub(super) struct KeptInertias {
    keys: Vec<InertiaBits>,
    rotations: Vec<DMat3>,
}

impl KeptInertias {
    /// Body `i`'s kept rotation when it was computed from `b`'s bits (the world
    /// inertia kept beside it is then `b`'s too).
    #[inline]
    pub(super) fn rotation(&self, i: usize, b: &RigidBody) -> Option<DMat3> {
        let k = self.keys.get(i)?;
        let now = inertia_bits(b);
        let mut d = 0u64;
        for (a, c) in k.iter().zip(&now) {
            d |= a ^ c;
        }
        (d == 0).then(|| self.rotations[i])
    }

    /// [`Self::rotation`], not inlined.
    #[inline(never)]
    pub(super) fn rotation_out_of_line(&self, i: usize, b: &RigidBody) -> Option<DMat3> {
        self.rotation(i, b)
    }

    /// Body `i`'s kept rotation, its bits not compared (the caller knows the body has
    /// not moved since it was kept).
    #[inline]
    pub(super) fn rotation_kept(&self, i: usize) -> Option<DMat3> {
        self.keys.get(i).map(|_| self.rotations[i])
    }

    /// Records body `i`'s rotation `r`, computed from `b`'s bits (`i` at most the
    /// number kept).
    #[inline]
    pub(super) fn keep(&mut self, i: usize, b: &RigidBody, r: DMat3) {
        let key = inertia_bits(b);
        if i < self.keys.len() {
            self.keys[i] = key;
            self.rotations[i] = r;
        } else {
            self.keys.push(key);
            self.rotations.push(r);
        }
    }

    /// Keeps the first `n` bodies' entries only.
    pub(super) fn truncate(&mut self, n: usize) {
        self.keys.truncate(n);
        self.rotations.truncate(n);
    }
}

/// The inputs of one assembly's matrix, as bits (see the module documentation).
#[derive(Clone, Debug, Default)]
pub(super) struct FactorKey {
    /// Whether the key describes a factor (false: the storage holds none known).
    valid: bool,
    /// The assembly's `h`, rate rows and treatment of compliant rows.
    assembly: Option<(u64, Rates, Soft)>,
    bodies: Vec<BodyBits>,
    compliance: Vec<u64>,
    armature: Vec<[u64; MAX_DOF]>,
}

impl FactorKey {
    /// Fills the key from an assembly's inputs (buffers reused; marks it valid).
    fn fill(
        &mut self,
        assembly: (f64, Rates, Soft),
        bodies: &[RigidBody],
        compliance: &[f64],
        armature: &[[f64; MAX_DOF]],
    ) {
        self.valid = true;
        self.assembly = Some((assembly.0.to_bits(), assembly.1, assembly.2));
        self.bodies.clear();
        self.bodies.extend(bodies.iter().map(body_bits));
        self.compliance.clear();
        self.compliance
            .extend(compliance.iter().map(|a| a.to_bits()));
        self.armature.clear();
        self.armature
            .extend(armature.iter().map(|a| a.map(f64::to_bits)));
    }

    /// Copies `other` into this key, field by field into the buffers already grown
    /// (the derived `clone_from` would allocate a new key).
    fn copy_from(&mut self, other: &FactorKey) {
        self.valid = other.valid;
        self.assembly = other.assembly;
        self.bodies.clone_from(&other.bodies);
        self.compliance.clone_from(&other.compliance);
        self.armature.clone_from(&other.armature);
    }

    /// The key valid and equal bit for bit to the one [`Self::fill`] would build from
    /// these inputs, compared without building it (most lookups hit the solver's
    /// factor, and then no key is written; the first differing body ends the scan).
    fn matches_inputs(
        &self,
        assembly: (f64, Rates, Soft),
        bodies: &[RigidBody],
        compliance: &[f64],
        armature: &[[f64; MAX_DOF]],
    ) -> bool {
        self.valid
            && self.assembly == Some((assembly.0.to_bits(), assembly.1, assembly.2))
            && self.bodies.len() == bodies.len()
            && self.bodies.iter().zip(bodies).all(|(k, b)| same_bits(k, b))
            && self.compliance.len() == compliance.len()
            && self
                .compliance
                .iter()
                .zip(compliance)
                .all(|(k, c)| *k == c.to_bits())
            && self.armature.len() == armature.len()
            && self
                .armature
                .iter()
                .zip(armature)
                .all(|(k, a)| *k == a.map(f64::to_bits))
    }
}

/// The kept factors: the key of the factor in the solver, a factor set aside with its
/// key, and the key of the assembly being looked up (scratch: no allocation once the
/// buffers have grown to the world's size).
#[derive(Clone, Debug, Default)]
pub(super) struct FactorCache {
    /// Key of the factor in the solver's storage.
    current: FactorKey,
    /// Key of `spare`.
    spare_key: FactorKey,
    /// A factor set aside (swapped with the solver's storage, never copied).
    spare: FactorStore,
    /// The key of the assembly being looked up.
    probe: FactorKey,
    /// The bodies' rotations with the bits they were computed from.
    pub(super) inertias: KeptInertias,
    /// `current`'s and `spare_key`'s keys (when both valid) hold the same bodies,
    /// compliances and armatures, bit for bit, and differ at most in their assembly:
    /// set by a miss of [`World::reuse_factor_unmoved`] (the new key is the one set
    /// aside with another assembly), kept by hits and swaps, cleared by every other
    /// miss.
    twin: bool,
}

impl FactorCache {
    /// Forgets the solver's factor (its storage is about to be overwritten by an
    /// assembly without a key).
    pub(super) fn forget_current(&mut self) {
        self.current.valid = false;
    }
}

impl World {
    /// Looks up the factor of the assembly `(h, rates, soft)` at the current bodies:
    /// `true` when the solver now holds it (it was there, or set aside and swapped in),
    /// so the assembly writes only its right-hand side and the solve skips the
    /// factorization ([`World::solve_reusing`]). On `false` the solver's factor, if
    /// known, is set aside (replacing the one there) and the assembly writes and factors
    /// into the other storage.
    ///
    /// The kept keys are compared with the inputs directly; the probe's key is built
    /// only on a miss (for [`Self::keep_factor`]). Measured (issue 13, swimmer6 2 s
    /// passive, 1 000 steps, 4 000 lookups of which 2 999 hit): building every probe
    /// and comparing the keys cost 3.70M instructions of `World::step`'s 99.36M.
    pub(super) fn reuse_factor(&mut self, h: f64, rates: Rates, soft: Soft) -> bool {
        let c = &mut self.factors;
        let inputs = (
            (h, rates, soft),
            &self.bodies[..],
            &self.compliance[..],
            &self.armature[..],
        );
        let matches = |k: &FactorKey| k.matches_inputs(inputs.0, inputs.1, inputs.2, inputs.3);
        if matches(&c.current) {
            return true;
        }
        let spare_hit = matches(&c.spare_key);
        if !spare_hit {
            c.probe.fill(inputs.0, inputs.1, inputs.2, inputs.3);
        }
        if spare_hit || c.current.valid {
            self.solver.swap_factor(&mut c.spare);
            core::mem::swap(&mut c.current, &mut c.spare_key);
        }
        if !spare_hit {
            c.current.valid = false;
            c.twin = false;
        }
        spare_hit
    }

    /// [`Self::reuse_factor`] where the caller knows that the bodies have not moved
    /// since the solver's factor was looked up or computed at them (RATTLE: a first
    /// kick right after the damping flow's solves, a damping flow right after the
    /// second kick; only velocities changed in between). The compliances and armatures
    /// do not change within a step, so the solver's factor (its key valid) is this
    /// assembly's exactly when its key has the same `(h, rates, soft)`, the set-aside
    /// one when it is the solver's twin (`FactorCache::twin`) with that assembly, and on
    /// a miss the new key is the solver's with this assembly — copied, not built from
    /// the bodies (a twin after the swap). Without a valid key, the full lookup.
    ///
    /// A RATTLE step with damping looks up four factors (`factor_cache.rs` above): the
    /// first kick (twin of the flow's factor at `x_n`) now hits without comparing the
    /// bodies, and the second flow's key is copied. The two lookups of a RATTLE step
    /// that this serves compared every body's 17 words (issue 13, swimmer6 controlled:
    /// about 600 instructions each).
    pub(super) fn reuse_factor_unmoved(&mut self, h: f64, rates: Rates, soft: Soft) -> bool {
        let c = &mut self.factors;
        if !c.current.valid {
            return self.reuse_factor(h, rates, soft);
        }
        let assembly = Some((h.to_bits(), rates, soft));
        if c.current.assembly == assembly {
            return true;
        }
        let spare_hit = if c.twin {
            c.spare_key.valid && c.spare_key.assembly == assembly
        } else {
            c.spare_key.matches_inputs(
                (h, rates, soft),
                &self.bodies,
                &self.compliance,
                &self.armature,
            )
        };
        if !spare_hit {
            // The current key's bodies, compliances and armatures are the inputs'.
            c.probe.copy_from(&c.current);
            c.probe.assembly = assembly;
        }
        self.solver.swap_factor(&mut c.spare);
        core::mem::swap(&mut c.current, &mut c.spare_key);
        if !spare_hit {
            c.current.valid = false;
            // After `keep_factor` the solver's key is the probe, the one set aside
            // the key it was copied from.
            c.twin = true;
        }
        spare_hit
    }

    /// Records the factor just computed for the assembly last looked up by
    /// [`Self::reuse_factor`] as the solver's.
    pub(super) fn keep_factor(&mut self) {
        let c = &mut self.factors;
        core::mem::swap(&mut c.current, &mut c.probe);
    }

    /// Drops every kept factor (a new solver: another topology).
    pub(super) fn drop_factors(&mut self) {
        self.factors.current.valid = false;
        self.factors.spare_key.valid = false;
        self.factors.twin = false;
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::{Actuator, DofSpring, Joint, JointKind, Method, Target, World};
    use crate::body::RigidBody;
    use constraint_core::{DMat3, DQuat, DVec3, Hinge, Pose};

    /// Three damped hinge links (masses 1, 0.8, 0.6 kg, 0.5 m, tilted 0.4, 0.7 and
    /// 1.0 rad about y) hanging from the world under gravity: the chain of this module's
    /// tests and of the flattened impulses' (`actuator/impulses.rs`).
    pub(in crate::world) fn hanging_chain() -> World {
        let mut w = World::new(DVec3::new(0.0, 0.0, -9.81));
        let mut top = DVec3::ZERO;
        let mut parent = None;
        for i in 0..3 {
            let q = DQuat::from_rotation_y(0.4 + 0.3 * i as f64);
            let down = q * DVec3::new(0.0, 0.0, -0.5);
            let pose = Pose {
                x: top + down * 0.5,
                q,
            };
            let inertia = DMat3::from_diagonal(DVec3::new(0.02, 0.02, 1e-3));
            let b = RigidBody::new(i, 1.0 - 0.2 * i as f64, inertia, pose).expect("body");
            w.add_body(b).expect("add body");
            let a = parent.map_or(Pose::IDENTITY, |p: usize| w.bodies()[p].pose);
            let hinge = Hinge::from_world(&a, &pose, top, DVec3::Y).expect("hinge");
            w.add_joint(Joint {
                parent,
                child: i,
                kind: JointKind::Hinge(hinge),
                damping: 0.05 * (1 + i) as f64,
            })
            .expect("add joint");
            parent = Some(i);
            top += down;
        }
        w
    }

    /// A position actuator (`kp` 0.3, control range ±1) on [`hanging_chain`]'s first
    /// hinge and a joint spring (0.2 N m/rad about 0.1 rad) on its last.
    pub(in crate::world) fn add_servo_and_spring(w: &mut World) {
        let kp = 0.3;
        w.add_actuator(Actuator {
            target: Target::Dof { joint: 0, dof: 0 },
            gear: 1.0,
            gain: kp,
            bias: [0.0, -kp, 0.0],
            ctrl_range: Some([-1.0, 1.0]),
            force_range: None,
        })
        .expect("actuator");
        w.add_dof_spring(DofSpring {
            joint: 2,
            dof: 0,
            stiffness: 0.2,
            reference: 0.1,
        })
        .expect("spring");
    }

    /// A chain of three damped hinge links hanging from the world, the middle hinge
    /// with armature (so the kicks and the damping flows have different factors).
    fn chain() -> World {
        let mut w = hanging_chain();
        w.set_armature(1, 0, 2e-3).expect("armature");
        w
    }

    /// The first kick's lookup through the twin flag (no comparison of the bodies)
    /// takes the factor the full comparison takes: a world whose flag is cleared
    /// before every step (so the kick compares the set-aside key with the bodies)
    /// records the same state bits over 200 RATTLE steps, also across a change of the
    /// armature and of a compliance between steps. The flag is set after each step of
    /// the other world (the path is taken).
    #[test]
    fn twin_lookup_gives_the_compared_lookup_bits() {
        let method = Method::Rattle {
            tolerance: 1e-12,
            max_iterations: 30,
        };
        let (mut a, mut b) = (chain(), chain());
        for step in 0..200 {
            if step == 80 {
                for w in [&mut a, &mut b] {
                    w.set_armature(1, 0, 5e-3).expect("armature");
                }
            }
            if step == 140 {
                for w in [&mut a, &mut b] {
                    w.set_compliance(2, 1e-6).expect("compliance");
                }
            }
            b.factors.twin = false;
            a.step(2e-3, method).expect("step a");
            b.step(2e-3, method).expect("step b");
            assert!(a.factors.twin, "step {step}: twin path unused");
            assert_eq!(state_bits(&a), state_bits(&b), "step {step}");
        }
    }

    /// The first flow of a step applies the actuator and spring forces that the last
    /// step's final flow evaluated at the same poses (`rattle::DofFlow`) instead of
    /// evaluating them: a world whose record is made stale before every step (so each
    /// flow evaluates) records the same bits over 200 RATTLE steps with a position
    /// actuator and a joint spring, also across control changes (the record is not
    /// reused then) and steps that keep the control.
    #[test]
    fn reapplied_flow_forces_give_the_evaluated_bits() {
        let method = Method::Rattle {
            tolerance: 1e-12,
            max_iterations: 30,
        };
        let build = || {
            let mut w = chain();
            add_servo_and_spring(&mut w);
            w
        };
        let (mut a, mut b) = (build(), build());
        let before = a.dof_evals;
        for step in 0..200 {
            // A new control every 25 steps (the same value set again in between).
            let u = 0.1 * ((step / 25) as f64) - 0.3;
            a.set_ctrl(0, u).expect("ctrl");
            b.set_ctrl(0, u).expect("ctrl");
            b.dof_evals = b.dof_evals.wrapping_add(1);
            a.step(2e-3, method).expect("step a");
            b.step(2e-3, method).expect("step b");
            assert_eq!(state_bits(&a), state_bits(&b), "step {step}");
        }
        // One evaluation per step (its last flow's), plus the first flows of the first
        // step and of the 7 steps with a new control: 208 (against 400 with every
        // flow evaluating).
        assert_eq!(a.dof_evals - before, 208);
    }

    /// Every body's pose, velocity and angular velocity, as bits.
    fn state_bits(w: &World) -> alloc::vec::Vec<u64> {
        w.bodies()
            .iter()
            .flat_map(|r: &RigidBody| {
                let (p, q) = (r.pose.x, r.pose.q);
                [
                    p.x, p.y, p.z, q.x, q.y, q.z, q.w, r.v.x, r.v.y, r.v.z, r.omega.x, r.omega.y,
                    r.omega.z,
                ]
                .map(f64::to_bits)
            })
            .collect()
    }

    /// The first damping flow of a step takes the last step's factor, rows and
    /// inertias without comparing keys when that step ended with its flow and nothing
    /// was assembled or written since (`World::flow_end`): a world whose token is
    /// dropped before every step (so the flow's lookups compare) records the same bits
    /// over 200 RATTLE steps, also across a pose written between steps and a change of
    /// armature and compliance (each of which drops the token).
    #[test]
    fn flow_end_token_gives_the_compared_lookup_bits() {
        let method = Method::Rattle {
            tolerance: 1e-12,
            max_iterations: 30,
        };
        let (mut a, mut b) = (chain(), chain());
        let (mut ended_with_flow, mut fallbacks) = (0, 0);
        for step in 0..200 {
            if step == 60 {
                for w in [&mut a, &mut b] {
                    w.bodies_mut()[2].pose.x.z += 1e-7;
                    assert!(w.flow_end.is_none(), "bodies_mut keeps the token");
                }
            }
            if step == 100 {
                for w in [&mut a, &mut b] {
                    w.set_armature(1, 0, 4e-3).expect("armature");
                    assert!(w.flow_end.is_none(), "set_armature keeps the token");
                }
            }
            if step == 150 {
                for w in [&mut a, &mut b] {
                    w.set_compliance(0, 1e-6).expect("compliance");
                    assert!(w.flow_end.is_none(), "set_compliance keeps the token");
                }
            }
            b.flow_end = None;
            let stats = a.step(2e-3, method).expect("step a");
            b.step(2e-3, method).expect("step b");
            fallbacks += stats.fallbacks + stats.unilateral_fallbacks;
            // The token is set by a step that ended with its flow (not a fallback,
            // whether RATTLE's own or a step taken at the velocity level).
            if a.flow_end == Some((a.steps, a.rows_epoch)) {
                ended_with_flow += 1;
            }
            assert_eq!(state_bits(&a), state_bits(&b), "step {step}");
        }
        // Every step but the fallbacks sets it (measured: 184 steps, 16 fallbacks).
        assert_eq!(ended_with_flow + fallbacks, 200, "{fallbacks} fallbacks");
        assert!(
            ended_with_flow >= 150,
            "token set by {ended_with_flow} steps"
        );
    }
}
