//! Linear complementarity problems and their solvers.
//!
//! Contact at velocity level (Otaduy 2010) asks for impulses `λ ≥ 0` with separation
//! velocities `d = J v ≥ 0` and `d λ = 0`; with `v = v* + A⁻¹ Jᵀ λ` this is the LCP
//!
//! ```text
//! w = M z + q ≥ 0,   z ≥ 0,   zᵀ w = 0,     M = J A⁻¹ Jᵀ,  z = λ,  w = d.
//! ```
//!
//! Friction turns it into a boxed LCP (`lo ≤ z ≤ hi`, with pyramidal-cone bounds
//! `|z_t| ≤ μ z_n` that move with the normal impulse).
//!
//! | item | what |
//! |---|---|
//! | [`Lcp`] | the problem (dense row-major `M`, `q`, bounds, friction links), validated |
//! | [`Lcp::residual`] | the accuracy measure: natural map `\|z − mid(lo, z − w, hi)\|_∞ / max(1, \|q\|_∞)` |
//! | [`LcpSolution`], [`LcpError`] | what every solver returns; failures are typed, never a wrong `z` |
//! | [`lemke()`] | complementary pivoting (Baraff 1994), lexicographic anti-cycling, warm start from a basis, pivot limit; standard LCP |
//! | [`pgs()`] | projected Gauss–Seidel with over-relaxation and warm start (Erleben 2007, Catto); standard, boxed and frictional |
//! | [`fischer_newton()`] | Fischer–Burmeister semismooth Newton with Armijo line search; standard LCP, high accuracy |
//! | [`solve_rows()`] | one-sided, friction and boxed rows together: staggered projections (Kaufman et al. 2008) over the three, or one boxed PGS |
//! | [`solve_rows_with()`] | [`solve_rows()`] in kept [`RowBuffers`] (no allocation per call) |
//!
//! Every solver checks the natural-map residual of its answer against its tolerance
//! before returning `Ok` (or against the residual's round-off floor,
//! [`Lcp::round_off`], where that is larger: heavy bodies on light ones make impulses so
//! large that `w = M z + q` cannot be evaluated to a fixed tolerance); the empty problem
//! (`n = 0`) is solved trivially.

mod dense;
pub mod lemke;
pub mod newton;
pub mod pgs;
pub mod problem;
pub mod staggered;

pub use lemke::{lemke, LemkeSettings};
pub use newton::{fischer_newton, NewtonSettings};
pub use pgs::{pgs, PgsSettings};
pub use problem::{Lcp, LcpError, LcpSolution, SparseRows};
pub use staggered::{
    row_residual, solve_rows, solve_rows_sparse, solve_rows_with, Coupling, RowBound, RowBuffers,
    RowMethod, RowSettings, RowStats,
};
