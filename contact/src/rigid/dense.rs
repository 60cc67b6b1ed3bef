//! The dense Delassus matrix, solved by [`crate::lcp::solve_rows`] (staggered
//! friction or one boxed PGS).

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
        let s = self.settings;
        // Rows 3k: normal; 3k + 1, 3k + 2: friction bounded by μ_k z_3k.
        let bounds: Vec<RowBound> = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    RowBound::Unilateral
                } else {
                    RowBound::Friction {
                        normal: i - i % 3,
                        mu: self.mu(i / 3),
                    }
                }
            })
            .collect();
        let settings = RowSettings {
            method: match solver {
                ContactSolver::Lemke => RowMethod::Lemke,
                ContactSolver::Newton => RowMethod::Newton,
                _ => RowMethod::Pgs,
            },
            coupling: match s.friction {
                FrictionModel::Boxed => Coupling::Boxed,
                FrictionModel::Staggered { sweeps } => Coupling::Staggered { sweeps },
            },
            tolerance: s.tolerance,
            pgs_iterations: s.iterations.max(10_000),
            friction_tolerance: 1e-8,
            friction_iterations: 10_000,
            // Exactly the configured alternations (the contact world pins its trajectories).
            max_sweeps: 0,
        };
        let mut z = z0;
        let stats = solve_rows(&a, &q, &bounds, &settings, &mut z).map_err(ContactError::Lcp)?;
        if stats.boxed_pgs {
            self.path |= path::BOXED_PGS;
        }
        self.path |= match stats.accepted {
            Some(RowMethod::Lemke) => path::NORMAL_LEMKE,
            Some(RowMethod::Newton) => path::NORMAL_NEWTON,
            Some(RowMethod::Pgs) => path::NORMAL_PGS,
            None => 0,
        };
        if stats.friction_pgs {
            self.path |= path::FRICTION_PGS;
        }
        if stats.friction_budget {
            self.path |= path::FRICTION_BUDGET;
        }
        Ok((z, stats.iterations))
    }
}
