//! The flattened impulses of one force evaluation ([`DofImpulses`]): the actuator,
//! spring and tendon forces `G_kᵀ τ_k` applied to the right-hand side, recorded body
//! side by body side so that the damping flows of a RATTLE step (`rattle.rs`) add
//! them again without walking the joints and their coordinate table.

use constraint_core::compound::MAX_DOF;
use constraint_core::DVec3;

use super::super::*;
use super::DofState;

impl World {
    /// Adds the forces of the last [`Self::add_dof_forces_part`] (`any`: what it
    /// returned) again, over `scale`: `scale · Σ_k G_kᵀ τ_k` with the same `τ` and rows,
    /// for a second right-hand side at the same state (the damping flow's second stage
    /// at `v`, `rattle.rs`), bit for bit what evaluating them again would add.
    pub(in crate::world) fn reapply_dof_forces(&mut self, scale: f64, any: bool) {
        if !any {
            return;
        }
        if self.rattle.impulses.evals == Some(self.dof_evals) {
            // The evaluation's impulses, flattened ([`DofImpulses`]).
            let sides = &self.rattle.impulses.sides;
            for &(body, lin, ang, t) in sides {
                add_impulse(
                    &mut self.rhs,
                    self.solver.body_offset(body),
                    lin,
                    ang,
                    t * scale,
                );
            }
        } else {
            let tau = core::mem::take(&mut self.dof_tau);
            let coords = core::mem::take(&mut self.dof_table);
            self.apply_dof_impulses(&tau, &coords, scale, None);
            self.dof_tau = tau;
            self.dof_table = coords;
        }
        self.apply_path_forces(scale, None);
    }

    /// Adds `scale · G_kᵀ τ_k` for every live entry of `coords` and nonzero `τ_k`, on the
    /// joint's parent's then its child's six entries of the right-hand side. One pass
    /// over the joints with the right-hand side and the solver's offsets borrowed once
    /// (the same products and sums per entry, in the same order, as a lookup per body).
    /// With `record`, the impulses' body sides are also written there, in the order
    /// applied ([`DofImpulses`]).
    pub(super) fn apply_dof_impulses(
        &mut self,
        tau: &[[f64; MAX_DOF]],
        coords: &[Option<DofState>],
        scale: f64,
        mut record: Option<&mut DofImpulses>,
    ) {
        let solver = &self.solver;
        let rhs = &mut self.rhs;
        // `r += g s` on body `i`'s six entries (linear `g[0]`, angular `g[1]`), `s = t
        // scale`.
        let mut add = |i: usize, lin: DVec3, ang: DVec3, t: f64| {
            if let Some(rec) = record.as_deref_mut() {
                rec.sides.push((i, lin, ang, t));
            }
            add_impulse(rhs, solver.body_offset(i), lin, ang, t * scale);
        };
        for ((joint, t), entry) in self.joints.iter().zip(tau).zip(coords) {
            let Some(DofState {
                live: true, rows, ..
            }) = entry
            else {
                continue;
            };
            // Forces act on the joint's own degrees of freedom only (`dofs_of`).
            let dofs = match &joint.kind {
                JointKind::Hinge(_) | JointKind::Prismatic(_) => 1,
                JointKind::Compound(c, _) => c.dof(),
                _ => 0,
            };
            for k in 0..dofs.min(MAX_DOF) {
                if t[k] == 0.0 {
                    continue;
                }
                if let Some(p) = joint.parent {
                    add(p, rows[k][0], rows[k][1], t[k]);
                }
                add(joint.child, rows[k][2], rows[k][3], t[k]);
            }
        }
    }
}

/// `r += (lin, ang) · s` on the six right-hand side entries at `o` (one bounds check;
/// nothing past the end of `rhs`).
#[inline(always)]
fn add_impulse(rhs: &mut [f64], o: usize, lin: DVec3, ang: DVec3, s: f64) {
    let Some(r) = rhs.get_mut(o..o + 6) else {
        return;
    };
    for c in 0..3 {
        r[c] += lin[c] * s;
        r[3 + c] += ang[c] * s;
    }
}

/// The impulses `G_kᵀ τ_k` of the last [`World::add_dof_forces_part`], one entry
/// `(body, linear row, angular row, τ_k)` per body side of each nonzero `τ_k`, in the
/// order [`World::apply_dof_impulses`] adds them: [`World::reapply_dof_forces`] adds
/// `(row) · (τ_k · scale)` from here — the same products and sums in the same order,
/// so the same bits — instead of walking the joints and their coordinate table
/// entries again (issue 13: dm fish perturbed reapplies its forces five times a
/// step, each pass 611 instructions).
#[derive(Clone, Debug, Default)]
pub(in crate::world) struct DofImpulses {
    /// `World::dof_evals` of the evaluation recorded (`None`: none, or its coordinate
    /// table was written since).
    pub(super) evals: Option<u64>,
    /// The body sides, in order.
    sides: Vec<(usize, DVec3, DVec3, f64)>,
    /// Tests: nothing recorded (every reapplication walks the joints).
    #[cfg(test)]
    pub(super) off: bool,
}

impl DofImpulses {
    /// Drops the record.
    pub(super) fn forget(&mut self) {
        self.evals = None;
        self.sides.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::factor_cache::tests::{add_servo_and_spring, hanging_chain};
    use super::super::super::{Fluid, Method, World};
    use super::super::{Actuator, Target, Tendon};
    use constraint_core::DVec3;

    /// Three damped hinge links hanging from the world ([`hanging_chain`]), in a fluid, with a position
    /// actuator, a velocity actuator, a joint spring and a stiff tendon over two
    /// joints: every RATTLE flow reapplies the forces (stage 2, and the next step's
    /// first flow).
    fn driven_chain() -> World {
        let mut w = hanging_chain();
        add_servo_and_spring(&mut w);
        w.add_actuator(Actuator {
            target: Target::Dof { joint: 1, dof: 0 },
            gear: 1.0,
            gain: 0.3,
            bias: [0.0, 0.0, -0.1],
            ctrl_range: Some([-1.0, 1.0]),
            force_range: None,
        })
        .expect("actuator");
        w.add_tendon(Tendon {
            terms: alloc::vec![(1, 0, 0.5), (2, 0, -0.5)],
            stiffness: 0.4,
            damping: 0.0,
            rest_length: 0.05,
        })
        .expect("tendon");
        w.set_fluid(Some(Fluid {
            density: 50.0,
            viscosity: 0.01,
            wind: DVec3::ZERO,
        }))
        .expect("fluid");
        w
    }

    /// The flattened impulses ([`super::DofImpulses`]) add the bits that walking the
    /// joints and their coordinate table adds: a world that never records them steps
    /// to the same state bits over 200 RATTLE steps (controls changing every 25),
    /// and the recording world did reapply from its record.
    #[test]
    fn flattened_impulses_give_the_walked_bits() {
        let method = Method::Rattle {
            tolerance: 1e-12,
            max_iterations: 30,
        };
        let (mut a, mut b) = (driven_chain(), driven_chain());
        b.rattle.impulses.off = true;
        let bits = |w: &World| -> alloc::vec::Vec<u64> {
            w.bodies()
                .iter()
                .flat_map(|r| {
                    let (p, q) = (r.pose.x, r.pose.q);
                    [p.x, p.y, p.z, q.x, q.y, q.z, q.w, r.v.x, r.v.y, r.v.z]
                        .into_iter()
                        .chain(r.omega.to_array())
                        .map(f64::to_bits)
                })
                .collect()
        };
        for step in 0..200 {
            let u = 0.1 * ((step / 25) as f64) - 0.3;
            for w in [&mut a, &mut b] {
                w.set_ctrl(0, u).expect("ctrl");
                w.set_ctrl(1, -u).expect("ctrl");
                w.step(2e-3, method).expect("step");
            }
            assert_eq!(bits(&a), bits(&b), "step {step}");
            // The record is the last evaluation's (a stale one would be walked past).
            assert_eq!(a.rattle.impulses.evals, Some(a.dof_evals), "step {step}");
            assert!(b.rattle.impulses.evals.is_none());
        }
    }
}
