//! Lemke's complementary pivoting method (Lemke 1965; Baraff 1994 for its use in contact).
//!
//! The standard LCP `w = M z + q ≥ 0`, `z ≥ 0`, `zᵀw = 0` (the lecture's `λ ≥ 0`,
//! `d λ = 0`) is augmented with an artificial variable `z₀` and covering vector
//! `d` (`d = e = 1` on a cold start):
//!
//! ```text
//! w − M z − d z₀ = q,   w, z, z₀ ≥ 0,   w_i z_i = 0.
//! ```
//!
//! Starting from the basis `{w}` with `z₀ = −min q`, each pivot brings in the complement
//! of the variable that just left, chosen by the minimum-ratio test, until `z₀` leaves
//! (a solution) or the entering column has no positive entry (a secondary ray). Ties in
//! the ratio test are broken by the lexicographic rule on the rows of `[q̄, B⁻¹]`, which
//! keeps every basis lexicographically feasible and so makes cycling impossible even on
//! degenerate problems (Kostreva's example). The tableau is dense: `n × (2n + 1)`.
//!
//! **Warm start**: given a guess of the complementary basis (`basis[i] = true` when `z_i`
//! is basic), the method factors it; if it is feasible, it is the answer (zero pivots);
//! otherwise Lemke runs from that basis with the covering vector `d = B·1`. A singular
//! guess, or a warm run that ends on a ray or the pivot limit, falls back to the cold
//! start; the pivot count then includes the failed attempt.
//!
//! **Polish**: the final basis is solved once more directly (LU); if the answer still
//! misses the tolerance, basic variables that come out negative (degenerate: zero in
//! exact arithmetic, lost to the conditioning of a nearly singular basis) are dropped
//! from the basis one at a time and the smaller basis solved again.
//!
//! Lemke's method solves the standard LCP only ([`Lcp::is_standard`]).

use alloc::vec;
use alloc::vec::Vec;

use super::dense::Lu;
use super::problem::{check_tolerance, Lcp, LcpError, LcpSolution};

/// Settings of [`lemke`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LemkeSettings {
    /// Pivot limit; `None` means `50 n` (at least 50).
    pub max_pivots: Option<usize>,
    /// Natural-map residual the answer must meet (default `1e-10`).
    pub tolerance: f64,
}

impl Default for LemkeSettings {
    fn default() -> Self {
        LemkeSettings {
            max_pivots: None,
            tolerance: 1e-10,
        }
    }
}

/// Solves a standard LCP by Lemke's method; `warm_basis` (length `n`, `true` = `z_i`
/// basic) is an optional starting basis, typically [`LcpSolution::basis`] of the previous
/// step. The solution carries its final basis and the number of pivots.
///
/// Errors: [`LcpError::Unsupported`] for a boxed problem, [`LcpError::RayTermination`]
/// (e.g. the infeasible `M = [[−1]], q = [−1]`, with `proven_infeasible`),
/// [`LcpError::PivotLimit`], [`LcpError::Inaccurate`], bad settings or basis length.
pub fn lemke(
    lcp: &Lcp,
    settings: &LemkeSettings,
    warm_basis: Option<&[bool]>,
) -> Result<LcpSolution, LcpError> {
    check_tolerance(settings.tolerance)?;
    if !lcp.is_standard() {
        return Err(LcpError::Unsupported(
            "Lemke solves the standard LCP only (lo = 0, hi = ∞)",
        ));
    }
    let n = lcp.n();
    if let Some(b) = warm_basis {
        if b.len() != n {
            return Err(LcpError::DimensionMismatch {
                what: "basis",
                expected: n,
                found: b.len(),
            });
        }
    }
    if n == 0 {
        return lcp.finish(Vec::new(), 0, Some(Vec::new()), settings.tolerance);
    }
    let limit = settings.max_pivots.unwrap_or(50 * n).max(1);
    let mut spent = 0;
    if let Some(guess) = warm_basis {
        if let Some(mut t) = Tableau::warm(lcp, guess) {
            match t.run(limit) {
                Ok(p) => {
                    if let Ok(sol) = t.solution(lcp, spent + p, settings.tolerance) {
                        return Ok(sol);
                    }
                    spent += p;
                }
                Err(End::Ray { pivots, .. }) => spent += pivots,
                Err(End::Limit) => spent += limit,
            }
        }
    }
    let mut t = Tableau::cold(lcp);
    match t.run(limit) {
        Ok(p) => t.solution(lcp, spent + p, settings.tolerance),
        Err(End::Ray { pivots, column }) => Err(LcpError::RayTermination {
            pivots: spent + pivots,
            proven_infeasible: t.ray_certifies_infeasibility(lcp, column),
        }),
        Err(End::Limit) => Err(LcpError::PivotLimit { pivots: limit }),
    }
}

enum End {
    Ray { pivots: usize, column: usize },
    Limit,
}

/// Dense tableau `B⁻¹ [I, −M, −d | q]`; variables `w_j = j`, `z_j = n + j`, `z₀ = 2n`.
struct Tableau {
    n: usize,
    cols: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    basic: Vec<usize>,
}

/// Relative tolerance for equal ratios in the lexicographic test.
const TIE: f64 = 1e-12;
/// Relative size below which a column entry is not a pivot candidate.
const PIV: f64 = 1e-11;

impl Tableau {
    fn cold(lcp: &Lcp) -> Tableau {
        let n = lcp.n();
        let cols = 2 * n + 1;
        let mut a = vec![0.0; n * cols];
        for i in 0..n {
            a[i * cols + i] = 1.0;
            for j in 0..n {
                a[i * cols + n + j] = -lcp.m_ij(i, j);
            }
            a[i * cols + 2 * n] = -1.0;
        }
        Tableau {
            n,
            cols,
            a,
            b: lcp.q().to_vec(),
            basic: (0..n).collect(),
        }
    }

    /// `B⁻¹ [I, −M, −B·1 | q]` for the complementary basis `guess`; `None` if singular.
    fn warm(lcp: &Lcp, guess: &[bool]) -> Option<Tableau> {
        let n = lcp.n();
        let cols = 2 * n + 1;
        let mut bm = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                bm[i * n + j] = if guess[j] {
                    -lcp.m_ij(i, j)
                } else if i == j {
                    1.0
                } else {
                    0.0
                };
            }
        }
        let lu = Lu::factor(bm, n)?;
        // B⁻¹ by columns.
        let mut binv = vec![0.0; n * n];
        let mut e = vec![0.0; n];
        for k in 0..n {
            e[k] = 1.0;
            let col = lu.solve(&e);
            e[k] = 0.0;
            for i in 0..n {
                binv[i * n + k] = col[i];
            }
        }
        let mut a = vec![0.0; n * cols];
        for i in 0..n {
            let bi = &binv[i * n..(i + 1) * n];
            let row = &mut a[i * cols..(i + 1) * cols];
            row[..n].copy_from_slice(bi);
            for j in 0..n {
                let mut s = 0.0;
                for k in 0..n {
                    s -= bi[k] * lcp.m_ij(k, j);
                }
                row[n + j] = s;
            }
            row[2 * n] = -1.0;
        }
        let b = lu.solve(lcp.q());
        if b.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let basic = (0..n).map(|j| if guess[j] { n + j } else { j }).collect();
        Some(Tableau {
            n,
            cols,
            a,
            b,
            basic,
        })
    }

    #[inline]
    fn at(&self, i: usize, j: usize) -> f64 {
        self.a[i * self.cols + j]
    }

    fn feasibility_slack(&self) -> f64 {
        let bmax = self.b.iter().fold(1.0_f64, |m, &x| m.max(libm::fabs(x)));
        1e-13 * bmax
    }

    /// Runs the pivots; `Ok(pivots)` once the basis is complementary and feasible.
    fn run(&mut self, limit: usize) -> Result<usize, End> {
        let n = self.n;
        let z0 = 2 * n;
        let slack = self.feasibility_slack();
        if self.b.iter().all(|&x| x >= -slack) {
            return Ok(0);
        }
        // First pivot: z₀ enters at the lexicographically smallest row of [b, B⁻¹].
        let mut r = 0;
        for i in 1..n {
            if self.lex_less(i, r, 1.0, 1.0) {
                r = i;
            }
        }
        let mut leaving = self.basic[r];
        self.pivot(r, z0);
        let mut pivots = 1;
        loop {
            let entering = if leaving < n {
                leaving + n
            } else {
                leaving - n
            };
            if pivots >= limit {
                return Err(End::Limit);
            }
            let Some(r) = self.ratio_test(entering) else {
                return Err(End::Ray {
                    pivots,
                    column: entering,
                });
            };
            leaving = self.basic[r];
            self.pivot(r, entering);
            pivots += 1;
            if leaving == z0 {
                return Ok(pivots);
            }
        }
    }

    /// Whether row `i` of `[b, B⁻¹] / di` is lexicographically smaller than row `k / dk`.
    fn lex_less(&self, i: usize, k: usize, di: f64, dk: f64) -> bool {
        let (ri, rk) = (self.b[i] / di, self.b[k] / dk);
        let tol = TIE * ri.abs().max(rk.abs()).max(1.0);
        if ri < rk - tol {
            return true;
        }
        if ri > rk + tol {
            return false;
        }
        for j in 0..self.n {
            let (si, sk) = (self.at(i, j) / di, self.at(k, j) / dk);
            let tol = TIE * si.abs().max(sk.abs()).max(1.0);
            if si < sk - tol {
                return true;
            }
            if si > sk + tol {
                return false;
            }
        }
        // Numerically equal rows: prefer the larger pivot.
        di.abs() > dk.abs()
    }

    /// Lexicographic minimum-ratio test on column `c`; `None` for a ray.
    fn ratio_test(&self, c: usize) -> Option<usize> {
        let n = self.n;
        let colmax = (0..n).fold(0.0_f64, |m, i| m.max(self.at(i, c).abs()));
        let tol = PIV * colmax;
        let mut best: Option<usize> = None;
        let mut best_ratio = f64::INFINITY;
        for i in 0..n {
            let d = self.at(i, c);
            if d > tol && d > 0.0 {
                let ratio = self.b[i] / d;
                if ratio < best_ratio {
                    best_ratio = ratio;
                }
                match best {
                    None => best = Some(i),
                    Some(k) => {
                        if self.lex_less(i, k, d, self.at(k, c)) {
                            best = Some(i);
                        }
                    }
                }
            }
        }
        // z₀ leaving among the minimum ratios ends the method at once.
        let z0 = 2 * n;
        if let Some(k) = best {
            let rz = (0..n).find(|&i| self.basic[i] == z0);
            if let Some(i) = rz {
                let d = self.at(i, c);
                if i != k && d > tol && d > 0.0 {
                    let ratio = self.b[i] / d;
                    if ratio <= best_ratio + TIE * best_ratio.abs().max(1.0) {
                        return Some(i);
                    }
                }
            }
        }
        best
    }

    fn pivot(&mut self, r: usize, c: usize) {
        let cols = self.cols;
        let p = self.a[r * cols + c];
        {
            let row = &mut self.a[r * cols..(r + 1) * cols];
            for x in row.iter_mut() {
                *x /= p;
            }
            row[c] = 1.0;
        }
        self.b[r] /= p;
        let (br, pivot_row) = (self.b[r], self.a[r * cols..(r + 1) * cols].to_vec());
        for i in 0..self.n {
            if i == r {
                continue;
            }
            let f = self.a[i * cols + c];
            if f == 0.0 {
                continue;
            }
            let row = &mut self.a[i * cols..(i + 1) * cols];
            for (x, &pr) in row.iter_mut().zip(&pivot_row) {
                *x -= f * pr;
            }
            row[c] = 0.0;
            self.b[i] -= f * br;
        }
        self.basic[r] = c;
    }

    /// `z` and basis of the final complementary tableau, polished by one direct solve of
    /// the basis system when that lowers the residual.
    fn solution(&self, lcp: &Lcp, pivots: usize, tolerance: f64) -> Result<LcpSolution, LcpError> {
        let n = self.n;
        let mut z = vec![0.0; n];
        let mut basis = vec![false; n];
        for (i, &v) in self.basic.iter().enumerate() {
            if (n..2 * n).contains(&v) {
                z[v - n] = self.b[i].max(0.0);
                basis[v - n] = true;
            }
        }
        let mut best = z;
        let mut best_residual = lcp.residual(&best);
        if let Some(polished) = solve_basis(lcp, &basis) {
            let r = lcp.residual(&polished);
            if r < best_residual {
                best = polished;
                best_residual = r;
            }
        }
        if best_residual > tolerance {
            if let Some((z, b)) = drop_degenerate(lcp, &basis, best_residual) {
                best = z;
                basis = b;
            }
        }
        lcp.finish(best, pivots, Some(basis), tolerance)
    }

    /// At a ray on column `c`: the direction's `z` part `y ≥ 0` is a Farkas certificate
    /// when `Mᵀy ≤ 0` and `qᵀy < 0` (then no `z ≥ 0` has `M z + q ≥ 0`).
    fn ray_certifies_infeasibility(&self, lcp: &Lcp, c: usize) -> bool {
        let n = self.n;
        let mut y = vec![0.0; n];
        if (n..2 * n).contains(&c) {
            y[c - n] = 1.0;
        }
        for (i, &v) in self.basic.iter().enumerate() {
            if (n..2 * n).contains(&v) {
                y[v - n] = (-self.at(i, c)).max(0.0);
            }
        }
        let ymax = y.iter().fold(0.0_f64, |m, &x| m.max(x));
        if !(ymax > 0.0) {
            return false;
        }
        let mmax = lcp.m().iter().fold(1e-300_f64, |m, &x| m.max(x.abs()));
        let mut qy = 0.0;
        for i in 0..n {
            qy += lcp.q()[i] * y[i] / ymax;
        }
        if !(qy < -1e-10 * lcp.scale()) {
            return false;
        }
        (0..n).all(|j| {
            let s: f64 = (0..n).map(|i| lcp.m_ij(i, j) * y[i] / ymax).sum();
            s <= 1e-10 * mmax
        })
    }
}

/// A degenerate final basis (a basic `z_j` whose value is zero) on a badly
/// conditioned problem — a light body between a heavy one and the ground: impulses
/// `10⁴` times `|q|`, and coplanar contact points, so the basis is nearly singular —
/// leaves that `z_j` at `±κ(B) ε |z|` instead of zero, and clamping it costs `w` up to
/// `|M_ij| κ(B) ε |z|`, far above the tolerance. Such a variable belongs out of the
/// basis: the most negative basic value is made non-basic and the smaller, better
/// conditioned basis solved again, while that lowers the residual (at most `n`
/// rounds). Returns the best answer and its basis when it beats `residual`.
fn drop_degenerate(lcp: &Lcp, basis: &[bool], residual: f64) -> Option<(Vec<f64>, Vec<bool>)> {
    let n = lcp.n();
    let mut basis = basis.to_vec();
    let mut best: Option<(Vec<f64>, Vec<bool>)> = None;
    let mut best_residual = residual;
    for _ in 0..n {
        let Some(x) = basis_values(lcp, &basis) else {
            break;
        };
        // The most negative basic value; none: nothing left to drop.
        let Some(drop) = (0..n)
            .filter(|&j| basis[j] && x[j] < 0.0)
            .min_by(|&i, &j| x[i].total_cmp(&x[j]))
        else {
            break;
        };
        basis[drop] = false;
        if let Some(z) = solve_basis(lcp, &basis) {
            let r = lcp.residual(&z);
            if r < best_residual {
                best_residual = r;
                best = Some((z, basis.clone()));
            }
        }
    }
    best
}

/// The solution `x` of `B x = q` for the complementary basis `basis` (`x_j = z_j` where
/// `z_j` is basic, `w_j` where not); `None` if `B` is singular or `x` not finite.
fn basis_values(lcp: &Lcp, basis: &[bool]) -> Option<Vec<f64>> {
    let n = lcp.n();
    let mut bm = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            bm[i * n + j] = if basis[j] {
                -lcp.m_ij(i, j)
            } else if i == j {
                1.0
            } else {
                0.0
            };
        }
    }
    let x = Lu::factor(bm, n)?.solve(lcp.q());
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Values of the basic variables of the complementary basis `basis` (`true` = `z_i`
/// basic) by a direct LU solve of `B x = q`; `None` if singular or infeasible.
fn solve_basis(lcp: &Lcp, basis: &[bool]) -> Option<Vec<f64>> {
    let x = basis_values(lcp, basis)?;
    let slack = 1e-9 * lcp.scale();
    let mut z = vec![0.0; lcp.n()];
    for (j, (&xj, &b)) in x.iter().zip(basis).enumerate() {
        if xj < -slack {
            return None;
        }
        if b {
            z[j] = xj.max(0.0);
        }
    }
    Some(z)
}
