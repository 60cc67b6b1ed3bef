//! Matrix-free projected Gauss–Seidel (sequential impulses), shock propagation and
//! split-impulse pseudo velocities.

use alloc::vec;
use alloc::vec::Vec;

use super::*;

impl ContactWorld {
    /// Matrix-free projected Gauss–Seidel: for each contact, friction rows then the
    /// normal row, `z_i ← clamp(z_i − (J_i v − b_i)/k_i)`, the change applied at once.
    pub(super) fn sequential_impulses(
        &mut self,
        mut z: Vec<f64>,
        inv: &[(f64, DMat3)],
    ) -> (Vec<f64>, usize) {
        self.path.rows = if self.rows.is_empty() {
            RowsSolver::NoRows
        } else {
            RowsSolver::Sequential
        };
        for (r, zi) in self.rows.iter().zip(&z) {
            apply(&mut self.bodies, r, *zi);
        }
        // Sweep order: contacts from the ground up (along −gravity), so a stack's weight
        // reaches the ground within one sweep (Gauss–Seidel in gravity order).
        let up = if self.gravity.length() > 0.0 {
            -self.gravity.normalize()
        } else {
            DVec3::Z
        };
        let mut by_height: Vec<usize> = (0..self.contacts.len()).collect();
        by_height.sort_by(|&p, &q| {
            let hp = self.contacts[p].point.dot(up);
            let hq = self.contacts[q].point.dot(up);
            hp.total_cmp(&hq).then(p.cmp(&q))
        });
        let order: Vec<usize> = by_height
            .iter()
            .flat_map(|&k| [3 * k + 1, 3 * k + 2, 3 * k])
            .collect();
        let iterations = self.settings.iterations;
        // Flat copies for the inner loop (Box2D style): velocities in one array with a
        // last, static slot (its `M⁻¹Jᵀ` blocks are zero, so it stays at rest), and per
        // row the two slots, the friction coefficient and the normal row it is bounded by.
        let nb = self.bodies.len();
        let mut vel: Vec<[DVec3; 2]> = self.bodies.iter().map(|b| [b.v, b.omega]).collect();
        vel.push([DVec3::ZERO; 2]);
        let slot = |b: Option<usize>| b.unwrap_or(nb);
        let mu: Vec<f64> = (0..self.contacts.len()).map(|c| self.mu(c)).collect();
        // One sweep; whether it changed any impulse.
        let sweep = |rows: &[Row], order: &[usize], vel: &mut [[DVec3; 2]], z: &mut [f64]| {
            let mut changed = false;
            for &i in order {
                let r = &rows[i];
                if !(r.k > 0.0) {
                    continue;
                }
                let (a, b) = (slot(r.a), slot(r.b));
                let rate = r.j[0].dot(vel[a][0])
                    + r.j[1].dot(vel[a][1])
                    + r.j[2].dot(vel[b][0])
                    + r.j[3].dot(vel[b][1]);
                let (lo, hi) = if i % 3 == 0 {
                    (0.0, f64::INFINITY)
                } else {
                    let m = mu[i / 3] * z[i - i % 3];
                    (-m, m)
                };
                // `min`/`max`, not `clamp`: an overflowing state gives NaN bounds, and `clamp`
                // panics on those (fuzz crash world_step-0c30798a); the divergence check
                // of `step` then rejects the state.
                let new = (z[i] - (rate - r.bias) / r.k).min(hi).max(lo);
                let dz = new - z[i];
                if dz != 0.0 {
                    changed = true;
                    z[i] = new;
                    vel[a][0] += r.mj[0] * dz;
                    vel[a][1] += r.mj[1] * dz;
                    vel[b][0] += r.mj[2] * dz;
                    vel[b][1] += r.mj[3] * dz;
                }
            }
            changed
        };
        // A sweep that changes no impulse writes nothing (`dz = 0` skips the row), so
        // every later sweep would repeat it exactly: stopping there gives the bits of all
        // `iterations` sweeps (a resting or steadily sliding contact gets there within a
        // few sweeps: on the sliding box, 1–7 of the 30 in 586 of 600 steps).
        for _ in 0..iterations {
            if !sweep(&self.rows, &order, &mut vel, &mut z) {
                break;
            }
        }
        // Shock propagation: bottom-up sweeps with the lower body of each contact frozen.
        if self.settings.shock_propagation > 0 && !self.contacts.is_empty() {
            self.path.shock = true;
            let frozen: Vec<Row> = self
                .rows
                .iter()
                .map(|r| self.frozen_row(r, up, inv))
                .collect();
            for _ in 0..self.settings.shock_propagation {
                if !sweep(&frozen, &order, &mut vel, &mut z) {
                    break;
                }
            }
        }
        for (b, v) in self.bodies.iter_mut().zip(&vel) {
            b.v = v[0];
            b.omega = v[1];
        }
        (z, iterations)
    }

    /// The row with the lower of its two bodies given infinite mass.
    pub(super) fn frozen_row(&self, r: &Row, up: DVec3, inv: &[(f64, DMat3)]) -> Row {
        let h = |b: Option<usize>| b.map_or(f64::NEG_INFINITY, |i| self.bodies[i].pose.x.dot(up));
        let mut f = *r;
        let _ = inv;
        if let (Some(_), Some(_)) = (r.a, r.b) {
            if h(r.a) < h(r.b) {
                f.mj[0] = DVec3::ZERO;
                f.mj[1] = DVec3::ZERO;
            } else {
                f.mj[2] = DVec3::ZERO;
                f.mj[3] = DVec3::ZERO;
            }
            f.k = f.j[0].dot(f.mj[0])
                + f.j[1].dot(f.mj[1])
                + f.j[2].dot(f.mj[2])
                + f.j[3].dot(f.mj[3]);
        }
        f
    }

    /// Split impulses: Gauss–Seidel on the normal rows for pseudo velocities `(u, ψ)`
    /// from zero with `J (u, ψ) ≥ push`, `z ≥ 0`; they move positions this step only.
    pub(super) fn pseudo_velocities(&self) -> Vec<(DVec3, DVec3)> {
        let mut p = vec![(DVec3::ZERO, DVec3::ZERO); self.bodies.len()];
        if self.rows.iter().all(|r| r.push == 0.0) {
            return p;
        }
        let mut z = vec![0.0; self.contacts.len()];
        for _ in 0..self.settings.iterations {
            for (k, zk) in z.iter_mut().enumerate() {
                let r = &self.rows[3 * k];
                if !(r.k > 0.0) {
                    continue;
                }
                let mut rate = 0.0;
                if let Some(i) = r.a {
                    rate += r.j[0].dot(p[i].0) + r.j[1].dot(p[i].1);
                }
                if let Some(i) = r.b {
                    rate += r.j[2].dot(p[i].0) + r.j[3].dot(p[i].1);
                }
                let new = (*zk - (rate - r.push) / r.k).max(0.0);
                let dz = new - *zk;
                *zk = new;
                if let Some(i) = r.a {
                    p[i].0 += r.mj[0] * dz;
                    p[i].1 += r.mj[1] * dz;
                }
                if let Some(i) = r.b {
                    p[i].0 += r.mj[2] * dz;
                    p[i].1 += r.mj[3] * dz;
                }
            }
        }
        p
    }
}
