//! The dense Delassus matrix and the dense LCP solvers with staggered friction.

use alloc::vec;
use alloc::vec::Vec;

use super::*;

impl ContactWorld {
    /// Delassus matrix `A = J M⁻¹ Jᵀ` (dense, row-major) and `q = J v_free − b`.
    pub(super) fn delassus(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.rows.len();
        let mut a = vec![0.0; n * n];
        for (i, ri) in self.rows.iter().enumerate() {
            for (j, rj) in self.rows.iter().enumerate().skip(i) {
                let mut s = 0.0;
                for (si, bi) in [(0usize, ri.a), (2usize, ri.b)] {
                    let Some(bi) = bi else { continue };
                    for (sj, bj) in [(0usize, rj.a), (2usize, rj.b)] {
                        if Some(bi) == bj {
                            s += ri.j[si].dot(rj.mj[sj]) + ri.j[si + 1].dot(rj.mj[sj + 1]);
                        }
                    }
                }
                a[i * n + j] = s;
                a[j * n + i] = s;
            }
        }
        let q = self
            .rows
            .iter()
            .map(|r| self.row_rate(r) - r.bias)
            .collect();
        (a, q)
    }

    pub(super) fn dense(
        &mut self,
        solver: ContactSolver,
        z0: Vec<f64>,
    ) -> Result<(Vec<f64>, usize), ContactError> {
        let n = self.rows.len();
        if n == 0 {
            self.path |= path::NO_ROWS;
            return Ok((Vec::new(), 0));
        }
        self.path |= path::DENSE;
        let (a, q) = self.delassus();
        let mu: Vec<f64> = (0..self.contacts.len()).map(|c| self.mu(c)).collect();
        let s = self.settings;
        let pgs_settings = PgsSettings {
            tolerance: s.tolerance,
            max_iterations: s.iterations.max(10_000),
            ..PgsSettings::default()
        };
        if solver == ContactSolver::Pgs && s.friction == FrictionModel::Boxed {
            self.path |= path::BOXED_PGS;
            let lcp = Lcp::contact(a, q, &mu).map_err(ContactError::Lcp)?;
            let sol = pgs(&lcp, &pgs_settings, Some(&z0)).map_err(ContactError::Lcp)?;
            return Ok((sol.z, sol.iterations));
        }
        let sweeps = match s.friction {
            FrictionModel::Staggered { sweeps } => sweeps.max(1),
            FrictionModel::Boxed => 1,
        };
        // Staggered projections: normal rows 3k, friction rows 3k+1, 3k+2.
        let nc = self.contacts.len();
        let normal: Vec<usize> = (0..nc).map(|k| 3 * k).collect();
        let tangent: Vec<usize> = (0..nc).flat_map(|k| [3 * k + 1, 3 * k + 2]).collect();
        let mut z = z0;
        let mut iterations = 0;
        let sub = |rows: &[usize], cols: &[usize]| -> Vec<f64> {
            let mut m = Vec::with_capacity(rows.len() * cols.len());
            for &i in rows {
                for &j in cols {
                    m.push(a[i * n + j]);
                }
            }
            m
        };
        let ann = sub(&normal, &normal);
        let att = sub(&tangent, &tangent);
        let frictionless = mu.iter().all(|m| *m == 0.0);
        for _ in 0..sweeps {
            // Normal LCP with the friction impulses fixed.
            let qn: Vec<f64> = normal
                .iter()
                .map(|&i| q[i] + tangent.iter().map(|&j| a[i * n + j] * z[j]).sum::<f64>())
                .collect();
            let lcp = Lcp::new(ann.clone(), qn).map_err(ContactError::Lcp)?;
            let zn0: Vec<f64> = normal.iter().map(|&i| z[i]).collect();
            let lemke_settings = LemkeSettings {
                tolerance: s.tolerance,
                ..LemkeSettings::default()
            };
            let newton_settings = NewtonSettings {
                tolerance: s.tolerance,
                max_iterations: 200,
                ..NewtonSettings::default()
            };
            // The requested solver first; where it fails (Newton stalls and Lemke loses
            // accuracy on the semi-definite Delassus matrix of coplanar contact points),
            // the others in turn, so a step fails only when all three do (the last
            // error is returned). `ContactStats::residual` reports the accepted answer.
            let order = match solver {
                ContactSolver::Lemke => [
                    ContactSolver::Lemke,
                    ContactSolver::Newton,
                    ContactSolver::Pgs,
                ],
                ContactSolver::Newton => [
                    ContactSolver::Newton,
                    ContactSolver::Lemke,
                    ContactSolver::Pgs,
                ],
                _ => [
                    ContactSolver::Pgs,
                    ContactSolver::Newton,
                    ContactSolver::Lemke,
                ],
            };
            let mut result = Err(LcpError::BadSettings("no solver ran"));
            for which in order {
                result = match which {
                    ContactSolver::Lemke => lemke(&lcp, &lemke_settings, None),
                    ContactSolver::Newton => fischer_newton(&lcp, &newton_settings, Some(&zn0)),
                    _ => pgs(&lcp, &pgs_settings, Some(&zn0)),
                };
                if result.is_ok() {
                    self.path |= match which {
                        ContactSolver::Lemke => path::NORMAL_LEMKE,
                        ContactSolver::Newton => path::NORMAL_NEWTON,
                        _ => path::NORMAL_PGS,
                    };
                    break;
                }
            }
            let sol = result.map_err(ContactError::Lcp)?;
            iterations += sol.iterations;
            for (k, &i) in normal.iter().enumerate() {
                // The solvers return z ≥ 0 up to round-off; clamp so the friction bounds
                // ±μ z_n stay ordered.
                z[i] = sol.z[k].max(0.0);
            }
            if frictionless {
                break;
            }
            // Boxed friction problem with the normal impulses fixed: projected
            // Gauss–Seidel on the dense friction block to 1e-8. Its Delassus block is only
            // semi-definite when a face touches at four coplanar points, where PGS can
            // converge slowly; when it runs out of sweeps, a last budget of sweeps from
            // the warm start is kept instead of failing the step (the whole LCP's residual
            // is reported in `ContactStats`).
            let qt: Vec<f64> = tangent
                .iter()
                .map(|&i| q[i] + normal.iter().map(|&j| a[i * n + j] * z[j]).sum::<f64>())
                .collect();
            let lo: Vec<f64> = tangent.iter().map(|&i| -mu[i / 3] * z[i - i % 3]).collect();
            let hi: Vec<f64> = lo.iter().map(|v| -v).collect();
            let zt0: Vec<f64> = tangent.iter().map(|&i| z[i]).collect();
            let friction_settings = PgsSettings {
                tolerance: 1e-8,
                max_iterations: 10_000,
                ..PgsSettings::default()
            };
            let lcp = Lcp::boxed(att.clone(), qt.clone(), lo, hi).map_err(ContactError::Lcp)?;
            self.path |= path::FRICTION_PGS;
            match pgs(&lcp, &friction_settings, Some(&zt0)) {
                Ok(sol) => {
                    iterations += sol.iterations;
                    for (k, &i) in tangent.iter().enumerate() {
                        z[i] = sol.z[k];
                    }
                }
                Err(LcpError::IterationLimit { .. }) => {
                    self.path |= path::FRICTION_BUDGET;
                    let nt = tangent.len();
                    for _ in 0..10_000 {
                        for (k, &i) in tangent.iter().enumerate() {
                            let d = att[k * nt + k];
                            if !(d > 0.0) {
                                continue;
                            }
                            let mut w = qt[k];
                            for (l, &j) in tangent.iter().enumerate() {
                                w += att[k * nt + l] * z[j];
                            }
                            let bound = mu[i / 3] * z[i - i % 3];
                            z[i] = (z[i] - w / d).min(bound).max(-bound); // NaN-safe, see sequential.rs
                        }
                        iterations += 1;
                    }
                }
                Err(e) => return Err(ContactError::Lcp(e)),
            }
        }
        Ok((z, iterations))
    }
}
