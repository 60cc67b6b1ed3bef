//! Stability map of the particle formulations (issue 6): a hanging particle chain —
//! particle 0 pinned at the origin, `N` links of [`LINK`] m along −x, released at rest
//! at `z = 0` (the scene of [`constraint_lagrange::scenes::chain`] at angle π/2) —
//! stepped by each [`METHODS`] entry over pairs of axes: time step × stiffness
//! (compliance), × tip mass ratio, × chain length and × initial violation. Each cell is
//! classified by [`classify`] as stable, inaccurate or unstable; every cell runs under
//! `catch_unwind` ([`crate::par::map_cells`]): a panic is its own class, counted, and must
//! never happen. This is the particle counterpart of
//! [`crate::articulated_stability`] (same classes and layout: [`crate::stability`]).
//!
//! The formulations step a [`SoftSystem`]:
//!
//! * **soft springs**, `E = ½ k C²`, `C = |x_a − x_b| − ℓ`, integrated by symplectic
//!   Euler (`v⁺ = v + h M⁻¹F(x)`, `x⁺ = x + h v⁺`) or the linearized backward Euler
//!   `(M − h²∂F/∂x) v⁺ = M v + h F` (sparse LDLᵀ, projected Hessian);
//! * **acceleration level** `[M Jᵀ; J 0][ẍ; λ] = [F; −J̇ẋ − k_x C − k_v Ċ]` with
//!   critically damped Baumgarte gains `k_x = 1/τ²`, `k_v = 2/τ`, `τ = 5h`;
//! * **velocity level** `[M Jᵀ; J 0][v; λ] = [M v₀ + hF; −C(x₀)/h]`;
//! * **compliant velocity level** `[M Jᵀ; J −α/h²][v; λ] = [M v₀ + hF; −C(x₀)/h]`
//!   with `α = 1/k` (`α = 0`: hard);
//! * **velocity level + projection**: then Newton on `C(x) = 0` with
//!   `(h² J M⁻¹ Jᵀ) δλ = C` (Goldenthal et al. 2007) and `v = (x − x₀)/h`;
//! * **fast projection**: a symplectic Euler step without the links, then the same
//!   projection ([`constraint_lagrange::ProjectedStep`], Goldenthal et al.'s Algorithm 1);
//! * **RATTLE** `v½ = v + (h/2)M⁻¹(F − Jᵀλ)`, `x' = x + h v½` on `C(x') = 0` (SHAKE),
//!   `v' = v½ + (h/2)M⁻¹(F' − J'ᵀμ)` on `J(x')v' = 0`, and **RATTLE4** (Yoshida's triple
//!   jump) ([`constraint_lagrange::Rattle`]); each built by [`Formulation::particle_stepper`].
//!
//! Cells run in parallel over all cores; each run is single-threaded and deterministic
//! (the sparse factorizations run sequentially), and the results are stored by cell
//! index, so the tables do not depend on the scheduling (only the wall times do).

use std::time::Instant;

use constraint_core::{DVec3, Distance};
use constraint_lagrange::{Constraints, HardSet, KktSolver, LagrangeError};
pub use constraint_scene::formulation::Links;
use constraint_scene::formulation::{Formulation, SoftIntegrator};
use constraint_soft::{ConstraintSet, SoftError, SoftSystem, Softness};

use crate::heatmap::tick;
use crate::stability::{self, CellClass, Map, MapAxis, Runner};

/// Link length of the chain (m).
pub const LINK: f64 = 0.1;

/// Mass of every particle but the tip (kg); the tip weighs `tip_ratio` times this.
pub const MASS: f64 = 0.1;

/// Gravity (m/s², along −z).
pub const G: f64 = 9.81;

/// Stable, hard links (`k = ∞`, `α = 0`): max link strain `| |x_a − x_b| − ℓ | / ℓ` over
/// the second half of the run at most this (a length error of 1e-4 m on 0.1 m links).
pub const STRAIN_TOL: f64 = 1e-3;

/// Stable: max over the run of `|E(t) − E(0)| / E_s` at most this, with
/// `E = ½ Σ m v² + Σ m g z (+ ½ k Σ C²` for springs and compliant links`)`, exactly
/// conserved by the motion, and the scale `E_s = M g ℓ_c + ½ k Σ C(0)²` (`M`: the free
/// particles' mass, `ℓ_c`: the chain's length; the second term, the energy stored by an
/// initial stretch of springs, is 0 for hard links).
pub const ENERGY_TOL: f64 = 1e-2;

/// Springs and compliant links may stretch: the exact motion's strain is at most about
/// a dynamic factor times the static strain of the top link, `W/(k ℓ)` (`W = M g`, the
/// weight it carries). This is the factor (a pendulum released horizontally pulls with
/// 3 `m g` at the bottom of its swing; the chain's whip more, near its light tip;
/// measured: at most 5.4 times on the stable `h = 1e-5` cells of the full map).
pub const DYNAMIC_FACTOR: f64 = 10.0;

/// Springs of the mass-ratio, length and violation maps: `k = W/(LOAD_STRAIN · ℓ)`, so
/// that the top link stretches statically by this strain whatever the chain's load (a
/// stiff chain standing in for an inextensible one).
pub const LOAD_STRAIN: f64 = 1e-4;

/// Blow-up: a particle farther than this many allowed extents from the anchor (the
/// chain stretched to its allowed strain, plus one link), or a non-finite energy.
pub const BLOWUP_EXTENT: f64 = 10.0;

/// The formulations, report labels.
pub const METHODS: [&str; 9] = [
    "soft springs, symplectic Euler",
    "soft springs, implicit Euler",
    "acceleration + Baumgarte (τ = 5h)",
    "velocity (J v = −C/h)",
    "compliant velocity (α = 1/k)",
    "velocity + projection",
    "fast projection (symplectic + projection)",
    "RATTLE",
    "RATTLE4 (Yoshida)",
];

/// The formulations of [`METHODS`], in the same order (the particle side of the shared
/// vocabulary, [`constraint_scene::formulation`]).
pub const FORMULATIONS: [Formulation; 9] = [
    Formulation::Soft(SoftIntegrator::Symplectic),
    Formulation::Soft(SoftIntegrator::Implicit),
    Formulation::AccelerationBaumgarte,
    Formulation::Velocity,
    Formulation::Compliant,
    Formulation::VelocityProjection,
    Formulation::FastProjection,
    Formulation::Rattle,
    Formulation::Rattle4,
];

/// How `METHODS[m]` models the links ([`Formulation::links`]; hard past the end).
pub fn links_of(m: usize) -> Links {
    FORMULATIONS.get(m).map_or(Links::Hard, |f| f.links())
}

/// One cell's configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Index into [`METHODS`].
    pub method: usize,
    /// Time step (s).
    pub h: f64,
    /// Links.
    pub links: usize,
    /// Tip mass ratio (the last particle weighs this times [`MASS`]).
    pub tip_ratio: f64,
    /// Initial stretch of every link, as a fraction of the link length.
    pub violation: f64,
    /// Link stiffness `k` (N/m) of springs and compliant links (`α = 1/k`);
    /// `f64::INFINITY` for hard links.
    pub stiffness: f64,
    /// Simulated time asked for (s).
    pub horizon: f64,
    /// Most `links × steps` of the run (the horizon is cut to fit).
    pub max_link_steps: f64,
}

/// What one cell measured.
#[derive(Clone, Debug, PartialEq)]
pub struct CellResult {
    /// The configuration.
    pub cell: Cell,
    /// The class: stable when finite, bounded, with the strain within [`allowed_strain`]
    /// over the second half and energy error ≤ [`ENERGY_TOL`]; diverged on
    /// `LagrangeError::Diverged` or `SoftError::Diverged`; failed on another typed error
    /// (a singular or non-finite solve).
    pub class: CellClass,
    /// Steps taken (the last one that failed not counted).
    pub steps: u64,
    /// Simulated time covered (s).
    pub simulated: f64,
    /// Max link strain over the second half of the run; NaN if not reached.
    pub strain: f64,
    /// The strain a stable run may reach ([`allowed_strain`]).
    pub allowed: f64,
    /// Max `|E − E(0)| / E_s` over the run.
    pub energy: f64,
    /// Steps whose projection stopped at its iteration limit (projection methods).
    pub unconverged: usize,
    /// RATTLE sub-steps whose SHAKE iteration switched to Newton with the current
    /// Jacobian.
    pub fallbacks: usize,
    /// Wall time (s).
    pub seconds: f64,
    /// The error or panic message, if any (one line).
    pub message: String,
}

/// Weight carried by the top link, `W = g Σ_{i ≥ 1} m_i` (N).
pub fn weight(links: usize, tip_ratio: f64) -> f64 {
    G * MASS * (links.saturating_sub(1) as f64 + tip_ratio)
}

/// Load-scaled link stiffness, `k = W / (LOAD_STRAIN · ℓ)` (N/m): see [`LOAD_STRAIN`].
pub fn load_stiffness(links: usize, tip_ratio: f64) -> f64 {
    weight(links, tip_ratio) / (LOAD_STRAIN * LINK)
}

/// The strain a stable run may reach over the second half: [`STRAIN_TOL`] for hard
/// links; for springs and compliant links (finite `k`) also the physical stretch,
/// `DYNAMIC_FACTOR · W/(k ℓ) + δ √N` (the second term: the initial stretch energy
/// `N · ½ k (δ ℓ)²`, which the undamped springs keep, gathered in one link).
pub fn allowed_strain(cell: &Cell) -> f64 {
    if cell.stiffness.is_finite() {
        STRAIN_TOL
            + DYNAMIC_FACTOR * weight(cell.links, cell.tip_ratio) / (cell.stiffness * LINK)
            + cell.violation * (cell.links as f64).sqrt()
    } else {
        STRAIN_TOL
    }
}

/// The links of an `links`-link chain, rest length [`LINK`].
fn distances(links: usize) -> Result<Vec<Distance>, SoftError> {
    (0..links)
        .map(|i| {
            Distance::new(i, i + 1, LINK).map_err(|error| SoftError::Constraint {
                set: "links",
                index: i,
                error,
            })
        })
        .collect()
}

/// The chain of `cell`: particle `i` at `x = −i (1 + δ) ℓ`, at rest, particle 0 pinned,
/// the tip `tip_ratio` times heavier; the links as soft springs in the system, or as
/// hard / compliant rows in the returned [`Constraints`], by [`links_of`].
///
/// # Errors
/// Bad parameters (no links, non-positive mass or stiffness).
pub fn scene(cell: &Cell) -> Result<(SoftSystem, Constraints), LagrangeError> {
    let n = cell.links;
    if n == 0 {
        return Err(LagrangeError::InvalidParameter("links"));
    }
    let x: Vec<DVec3> = (0..=n)
        .map(|i| DVec3::new(-(i as f64) * (1.0 + cell.violation) * LINK, 0.0, 0.0))
        .collect();
    let mut m = vec![MASS; n + 1];
    m[n] *= cell.tip_ratio;
    let mut sys = SoftSystem::new(x, m)?;
    sys.pin(0)?;
    let d = distances(n)?;
    let mut cons = Constraints::new();
    match links_of(cell.method) {
        Links::Springs => sys.add_set(ConstraintSet::uniform(
            "links",
            d,
            Softness::stiff(cell.stiffness),
        )?)?,
        Links::Compliant => {
            let alpha = if cell.stiffness.is_finite() {
                1.0 / cell.stiffness
            } else {
                0.0
            };
            cons.add(
                HardSet::compliant("links", d, vec![alpha; n])
                    .map_err(|_| LagrangeError::InvalidParameter("compliance"))?,
            );
        }
        Links::Hard => cons.add(HardSet::hard("links", d)),
    }
    Ok((sys, cons))
}

/// Steps of a cell: `horizon / h` rounded, cut to `max_link_steps / links`, at least 1.
pub fn steps(cell: &Cell) -> u64 {
    let want = (cell.horizon / cell.h).round().max(1.0);
    let cap = (cell.max_link_steps / cell.links as f64).floor().max(1.0);
    want.min(cap) as u64
}

/// The KKT solver for `rows` rows: dense Schur complement up to 64 rows, sparse above.
fn kkt_solver(rows: usize) -> KktSolver {
    if rows <= 64 {
        KktSolver::DenseSchur
    } else {
        KktSolver::SparseSchur
    }
}

/// Largest link strain `| |x_{i+1} − x_i| − ℓ | / ℓ` and the spring energy
/// `½ k Σ C²` (0 for `k = ∞`).
fn strain_and_energy(x: &[DVec3], k: f64) -> (f64, f64) {
    let mut worst = 0.0f64;
    let mut e = 0.0;
    for w in x.windows(2) {
        let c = (w[1] - w[0]).length() - LINK;
        worst = if c.is_nan() {
            f64::NAN
        } else {
            worst.max(c.abs() / LINK)
        };
        e += c * c;
    }
    (worst, if k.is_finite() { 0.5 * k * e } else { 0.0 })
}

/// Kinetic plus gravitational energy.
fn mechanical(sys: &SoftSystem) -> f64 {
    sys.x
        .iter()
        .zip(&sys.v)
        .zip(sys.masses())
        .map(|((x, v), m)| m * (0.5 * v.length_squared() + G * x.z))
        .sum()
}

/// Runs one cell (no panic guard; see [`run_cell`]).
pub fn classify(cell: &Cell) -> CellResult {
    let t0 = Instant::now();
    let n = steps(cell);
    let allowed = allowed_strain(cell);
    let mut r = CellResult {
        cell: *cell,
        class: CellClass::Stable,
        steps: 0,
        simulated: 0.0,
        strain: f64::NAN,
        allowed,
        energy: 0.0,
        unconverged: 0,
        fallbacks: 0,
        seconds: 0.0,
        message: String::new(),
    };
    let built = scene(cell).and_then(|(sys, cons)| {
        FORMULATIONS
            .get(cell.method)
            .ok_or(LagrangeError::InvalidParameter("method"))?
            .particle_stepper(cell.h, kkt_solver(cell.links))
            .map(|s| (sys, cons, s))
    });
    let (mut sys, cons, mut stepper) = match built {
        Ok(b) => b,
        Err(e) => {
            r.class = CellClass::Failed;
            r.message = e.to_string();
            r.seconds = t0.elapsed().as_secs_f64();
            return r;
        }
    };
    let k = cell.stiffness;
    let length = cell.links as f64 * LINK;
    let (_, e0) = strain_and_energy(&sys.x, k);
    let scale = weight(cell.links, cell.tip_ratio) * length + e0;
    let extent = length * (1.0 + allowed.max(cell.violation)) + LINK;
    let mut strain = 0.0f64;
    for step in 1..=n {
        match stepper.step(&mut sys, &cons) {
            Ok(st) => {
                r.unconverged += usize::from(st.unconverged);
                r.fallbacks += st.fallbacks;
            }
            Err(e) => {
                r.class = if matches!(
                    e,
                    LagrangeError::Diverged { .. }
                        | LagrangeError::Soft(SoftError::Diverged { .. })
                ) {
                    CellClass::Diverged
                } else {
                    CellClass::Failed
                };
                r.message = e.to_string().replace('\n', " ");
                break;
            }
        }
        r.steps = step;
        let (s, es) = strain_and_energy(&sys.x, k);
        let e = (mechanical(&sys) + es - e0).abs() / scale;
        r.energy = r.energy.max(if e.is_finite() { e } else { f64::INFINITY });
        let far = sys.x.iter().map(|x| x.length()).fold(0.0, f64::max);
        if !(far <= BLOWUP_EXTENT * extent) || !r.energy.is_finite() {
            r.class = CellClass::BlowUp;
            r.message = format!(
                "blow-up at step {step}: max |x| = {far:.3e} m, energy measure {:.3e}",
                r.energy
            );
            break;
        }
        if 2 * step >= n {
            strain = if s.is_nan() { f64::NAN } else { strain.max(s) };
            r.strain = strain;
        }
    }
    r.simulated = r.steps as f64 * cell.h;
    if r.class == CellClass::Stable && (!(r.strain <= allowed) || !(r.energy <= ENERGY_TOL)) {
        r.class = CellClass::Inaccurate;
    }
    r.seconds = t0.elapsed().as_secs_f64();
    r
}

/// The result of a cell whose run panicked.
fn panicked(cell: &Cell, message: String) -> CellResult {
    CellResult {
        cell: *cell,
        class: CellClass::Panicked,
        steps: 0,
        simulated: 0.0,
        strain: f64::NAN,
        allowed: allowed_strain(cell),
        energy: f64::NAN,
        unconverged: 0,
        fallbacks: 0,
        seconds: 0.0,
        message,
    }
}

/// [`classify`] under `catch_unwind`: a panic becomes [`CellClass::Panicked`].
pub fn run_cell(cell: &Cell) -> CellResult {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| classify(cell)))
        .unwrap_or_else(|p| panicked(cell, crate::par::panic_message(p.as_ref())))
}

/// Relative cost of a step per link, by method (measured on the 10- and 1000-link
/// chains), for scheduling the longest cells first.
const COST: [f64; 9] = [0.3, 3.0, 1.5, 1.0, 1.0, 2.5, 2.5, 3.0, 9.0];

/// Runs `cells` on up to `threads` threads ([`crate::par::map_cells`], longest first);
/// results in the order of `cells`.
pub fn run_all(cells: &[Cell], threads: usize) -> Vec<CellResult> {
    crate::par::map_cells("chain", cells, threads, cost, run_cell, panicked)
}

/// Work estimate of a cell: link-steps times the method's [`COST`].
fn cost(c: &Cell) -> f64 {
    steps(c) as f64 * c.links as f64 * COST[c.method.min(COST.len() - 1)]
}

/// One pair of axes: time step × another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Link stiffness `k` (compliance `α = 1/k`), with `k = ∞` last.
    Stiffness,
    /// Tip mass ratio.
    MassRatio,
    /// Links.
    Length,
    /// Initial link stretch (fraction of the link length).
    Violation,
}

impl Axis {
    /// Every axis paired with the time step, in report order.
    pub const ALL: [Axis; 4] = [
        Axis::Stiffness,
        Axis::MassRatio,
        Axis::Length,
        Axis::Violation,
    ];

    /// Position in [`Axis::ALL`]: the axis's index in the map ([`crate::stability::Map::axes`]).
    pub fn index(self) -> usize {
        Axis::ALL.iter().position(|a| *a == self).unwrap_or(0)
    }

    /// Axis label.
    pub fn label(self) -> &'static str {
        match self {
            Axis::Stiffness => "link stiffness k (N/m), α = 1/k",
            Axis::MassRatio => "tip mass ratio",
            Axis::Length => "links",
            Axis::Violation => "initial stretch / link length",
        }
    }

    /// File stem of the chart.
    pub fn stem(self) -> &'static str {
        match self {
            Axis::Stiffness => "stiffness",
            Axis::MassRatio => "mass",
            Axis::Length => "length",
            Axis::Violation => "violation",
        }
    }
}

/// Tick label of an axis value (`∞` for infinite stiffness, `0` for no violation).
pub fn value_tick(v: f64) -> String {
    if v.is_infinite() {
        "∞".into()
    } else if v == 0.0 {
        "0".into()
    } else {
        tick(v)
    }
}

/// What one mode of the map runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Time steps (s).
    pub hs: Vec<f64>,
    /// Finite link stiffnesses (N/m); the map adds `k = ∞` as its last row.
    pub stiffnesses: Vec<f64>,
    /// Tip mass ratios.
    pub ratios: Vec<f64>,
    /// Chain lengths (links).
    pub lengths: Vec<usize>,
    /// Initial stretches (fraction of the link length).
    pub violations: Vec<f64>,
    /// Links of the stiffness, mass-ratio and violation maps.
    pub base_links: usize,
    /// Simulated time per cell (s).
    pub horizon: f64,
    /// Cap on `links × steps` per cell (the long chains' horizon is cut to fit).
    pub max_link_steps: f64,
}

impl Plan {
    /// The small plan (`cargo xtask verify` and CI) or the full one (`--full`).
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                hs: vec![1e-4, 1e-3, 1e-2, 1.0 / 30.0],
                stiffnesses: vec![1.0, 1e2, 1e4, 1e6, 1e8, 1e10, 1e12],
                ratios: vec![1.0, 1e2, 1e4, 1e6],
                lengths: vec![10, 100, 1000, 10_000],
                violations: vec![0.0, 1e-3, 1e-2, 0.1, 0.5],
                base_links: 10,
                horizon: 1.0,
                max_link_steps: 2e5,
            }
        } else {
            Self {
                hs: vec![1e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 1.0 / 30.0],
                stiffnesses: (0..=12).map(|e| 10f64.powi(e)).collect(),
                ratios: (0..=6).map(|e| 10f64.powi(e)).collect(),
                lengths: vec![10, 30, 100, 300, 1000, 3000, 10_000],
                violations: vec![0.0, 1e-3, 1e-2, 0.1, 0.3, 0.5],
                base_links: 10,
                horizon: 1.0,
                max_link_steps: 1e6,
            }
        }
    }

    /// Values along `axis`; the stiffness axis ends with `f64::INFINITY`.
    pub fn values(&self, axis: Axis) -> Vec<f64> {
        match axis {
            Axis::Stiffness => {
                let mut v = self.stiffnesses.clone();
                v.push(f64::INFINITY);
                v
            }
            Axis::MassRatio => self.ratios.clone(),
            Axis::Length => self.lengths.iter().map(|&n| n as f64).collect(),
            Axis::Violation => self.violations.clone(),
        }
    }

    /// The grid of one map, in (method, value, step) order: `None` where the method
    /// has no such value (hard links at finite `k`, springs at `k = ∞`). Off the
    /// stiffness axis, springs and compliant links take [`load_stiffness`].
    pub fn grid(&self, axis: Axis) -> Vec<Option<Cell>> {
        self.map().grid(self, axis.index())
    }

    /// The map as data: the formulations, the time steps and the axes of [`Axis::ALL`].
    pub fn map(&self) -> Map {
        let stable = format!(
            "Stable: link strain over the run's second half ≤ {STRAIN_TOL:e} (hard) or ≤ {STRAIN_TOL:e} + {DYNAMIC_FACTOR}·W/(kℓ) + δ√N (springs, compliant), and max |E − E(0)|/E_s ≤ {ENERGY_TOL:e}."
        );
        let axes = Axis::ALL
            .iter()
            .map(|&axis| {
                let note = match axis {
                    Axis::Stiffness => format!(
                        "Particle chain of {} links (0.1 m, 0.1 kg), released horizontal, {} s per cell. Hard formulations have no stiffness: one row, k = ∞ (blank elsewhere);\nsoft springs have no k = ∞ (blank); the compliant formulation runs α = 1/k and α = 0 (k = ∞). {stable}",
                        self.base_links, self.horizon
                    ),
                    Axis::Length => format!(
                        "Particle chain, 0.1 m links, released horizontal; {} s or at most {:.0e} link-steps per cell (long chains: shorter runs). Springs: k = W/({LOAD_STRAIN:e}·ℓ).\n{stable}",
                        self.horizon, self.max_link_steps
                    ),
                    _ => format!(
                        "Particle chain of {} links (0.1 m), released horizontal, {} s per cell. Springs and compliant links: k = W/({LOAD_STRAIN:e}·ℓ).\n{stable}",
                        self.base_links, self.horizon
                    ),
                };
                let values = self.values(axis);
                MapAxis {
                    label: axis.label(),
                    stem: axis.stem(),
                    ticks: values.iter().map(|&v| value_tick(v)).collect(),
                    values,
                    note,
                }
            })
            .collect();
        Map {
            name: "chain",
            heading: "Time step",
            alt: "particle chain stability",
            title: "Particle chain stability: time step",
            columns: 5,
            summary: "Summary per formulation",
            first_column: "method",
            csv_header: "axis,method,h,links,tip_ratio,violation,stiffness,class,steps,simulated_s,strain,strain_allowed,energy_rel,unconverged_projections,rattle_fallbacks,wall_s,message\n",
            methods: &METHODS,
            hs: self.hs.clone(),
            axes,
        }
    }
}

impl Runner for Plan {
    type Cell = Cell;
    type Result = CellResult;

    fn cell(&self, axis: usize, method: usize, x: f64, h: f64) -> Option<Cell> {
        let axis = *Axis::ALL.get(axis)?;
        let mut c = Cell {
            method,
            h,
            links: self.base_links,
            tip_ratio: 1.0,
            violation: 0.0,
            stiffness: f64::INFINITY,
            horizon: self.horizon,
            max_link_steps: self.max_link_steps,
        };
        match axis {
            Axis::Stiffness => c.stiffness = x,
            Axis::MassRatio => c.tip_ratio = x,
            Axis::Length => c.links = x as usize,
            Axis::Violation => c.violation = x,
        }
        let links = links_of(method);
        if axis != Axis::Stiffness && links != Links::Hard {
            c.stiffness = load_stiffness(c.links, c.tip_ratio);
        }
        let applies = match (axis, links) {
            (Axis::Stiffness, Links::Springs) => c.stiffness.is_finite(),
            (Axis::Stiffness, Links::Hard) => c.stiffness.is_infinite(),
            _ => true,
        };
        if links == Links::Hard {
            c.stiffness = f64::INFINITY;
        }
        applies.then_some(c)
    }

    fn cost(&self, c: &Cell) -> f64 {
        cost(c)
    }

    fn run(&self, cell: &Cell) -> CellResult {
        classify(cell)
    }

    fn panicked(&self, cell: &Cell, message: String) -> CellResult {
        panicked(cell, message)
    }

    fn class(r: &CellResult) -> CellClass {
        r.class
    }

    /// The value's tick; off the stiffness axis, springs and compliant links also show
    /// their load stiffness, and on it the hard formulations say they have none.
    fn row_label(&self, axis: usize, method: usize, value: f64) -> String {
        let label = value_tick(value);
        let axis = Axis::ALL.get(axis).copied().unwrap_or(Axis::Stiffness);
        if axis != Axis::Stiffness && links_of(method) != Links::Hard {
            let k = load_stiffness(
                if axis == Axis::Length {
                    value as usize
                } else {
                    self.base_links
                },
                if axis == Axis::MassRatio { value } else { 1.0 },
            );
            format!("{label} (k = {})", tick(k))
        } else if axis == Axis::Stiffness && links_of(method) == Links::Hard {
            format!("{label} (no stiffness parameter)")
        } else {
            label
        }
    }

    fn csv_row(stem: &str, r: &CellResult) -> String {
        let c = &r.cell;
        format!(
            "{},{},{:e},{},{:e},{:e},{:e},{:?},{},{:e},{:e},{:e},{:e},{},{},{:.4},{}",
            stem,
            METHODS
                .get(c.method)
                .copied()
                .unwrap_or("?")
                .replace(',', ";"),
            c.h,
            c.links,
            c.tip_ratio,
            c.violation,
            c.stiffness,
            r.class,
            r.steps,
            r.simulated,
            r.strain,
            r.allowed,
            r.energy,
            r.unconverged,
            r.fallbacks,
            r.seconds,
            r.message.replace(',', ";")
        )
    }
}

/// Strain above which an inaccurate (bounded) cell is counted apart in the summary,
/// when also above its [`allowed_strain`]: a link at least twice its rest length.
pub const WILD_STRAIN: f64 = 1.0;

/// Per method, the inaccurate results whose strain exceeds both [`WILD_STRAIN`] and the
/// allowed strain (bounded by the geometry only; a column of the summary).
pub fn wild<'a>(results: impl IntoIterator<Item = &'a CellResult>) -> [usize; METHODS.len()] {
    let mut n = [0; METHODS.len()];
    for r in results {
        if let Some(n) = n.get_mut(r.cell.method) {
            *n += usize::from(
                r.class == CellClass::Inaccurate && r.strain > r.allowed.max(WILD_STRAIN),
            );
        }
    }
    n
}

/// Writes the section (four heat maps `chain_stability_<axis>.svg`, tables, a summary
/// and `chain_stability.csv`) and returns the panic count.
///
/// # Errors
/// Writing a file.
pub fn section(
    md: &mut String,
    out: &std::path::Path,
    quick: bool,
) -> Result<usize, Box<dyn std::error::Error>> {
    use std::fmt::Write as _;
    let plan = Plan::new(quick);
    let threads = crate::par::threads();
    let _ = writeln!(
        md,
        "\n## Stability map: particle chain (soft and Lagrange formulations)\n\n\
         A hanging particle chain (the scene of `constraint_lagrange::scenes::chain`): particle 0 \
         pinned at the origin, N links of 0.1 m along −x, 0.1 kg particles (the tip `ratio` times \
         heavier), released at rest at z = 0, gravity 9.81 m/s². Nine formulations: soft springs \
         (E = ½kC²) under symplectic Euler and under the linearized implicit Euler (sparse LDLᵀ, \
         projected Hessian); the acceleration level with critically damped Baumgarte gains \
         kx = 1/τ², kv = 2/τ, τ = 5h; the velocity level J v = −C/h; the compliant velocity level \
         (compliance α = 1/k, block −α/h² in the KKT matrix; α = 0 is hard); the velocity level \
         followed by Newton projection to strain 1e-10 (≤ 10 iterations, v = (x − x₀)/h); fast \
         projection (a symplectic Euler step without the links, then the same projection; \
         Goldenthal et al. 2007); RATTLE and RATTLE4 (Yoshida triple jump), SHAKE to strain 1e-10 \
         in ≤ 20 iterations per sub-step (not converging is a typed error). KKT systems: dense \
         Schur complement up to 64 rows, sparse Cholesky above. Maps: time step × link stiffness ({} links; the hard formulations have \
         no stiffness parameter and appear once, at k = ∞; the springs have no k = ∞), × tip mass \
         ratio, × chain length, × initial violation (every link stretched by a fraction δ of its \
         length: particle i at x = −i(1 + δ)·0.1 m). Off the stiffness axis, springs and compliant \
         links are stiffened with the load, k = W/({LOAD_STRAIN:e}·ℓ) (W = M g, the weight on the \
         top link: static strain {LOAD_STRAIN:e}), so they stand in for a stiff chain.\n\n\
         Classes (thresholds exact): **✓ stable**: every step finite, bounded, max link strain \
         abs(‖xᵢ₊₁ − xᵢ‖ − ℓ)/ℓ over the second half of the run ≤ {STRAIN_TOL:e} for hard links \
         (1e-4 m; the articulated map allows 1e-3 m) or, for springs and compliant links, ≤ \
         {STRAIN_TOL:e} + {DYNAMIC_FACTOR}·W/(kℓ) + δ√N (the exact motion's stretch: {DYNAMIC_FACTOR} \
         times the static strain of the top link, plus the initial stretch energy gathered in one \
         link), and max over the run of |E(t) − E(0)|/E_s ≤ {ENERGY_TOL:e} (E = kinetic + \
         gravitational + ½kΣC² for springs and compliant links, conserved by the exact motion; \
         E_s = M g ℓ_c + ½kΣC(0)², M the free particles' mass, ℓ_c the chain's length); \
         **~ inaccurate**: bounded but above either threshold; **✗ unstable**: the typed \
         `Diverged` error (`LagrangeError` or `SoftError`: non-finite or beyond 1e12); **↑ \
         unstable**: blow-up, a particle beyond {BLOWUP_EXTENT} × the allowed extent (the chain at \
         its allowed strain, plus a link) from the anchor, or a non-finite energy; **! unstable**: \
         another typed error; **P**: a panic (caught per cell by `catch_unwind`; must be 0). Each \
         cell simulates {} s (long chains: at most {:.0e} link-steps, so fewer steps). Cells run \
         on {threads} thread(s); each run is deterministic.\n",
        plan.base_links,
        plan.horizon,
        plan.max_link_steps
    );
    let map = plan.map();
    let all = stability::write_maps(&map, &plan, md, out, threads)?;
    let results = || all.iter().flat_map(|r| r.iter().flatten());
    // Summary: per method, counts and the largest step stable (and not unstable) on
    // every row the method runs of each map.
    let total = stability::write_summary::<Plan>(
        &map,
        md,
        &all,
        &[(
            "of which strain > 1 (beyond allowance)",
            wild(results()).to_vec(),
        )],
    );
    let panics = total.panics;
    let unconverged: usize = results().map(|r| r.unconverged).sum();
    let fallbacks: usize = results().map(|r| r.fallbacks).sum();
    let _ = writeln!(
        md,
        "\nPanics: {panics} (of {} cells). Projection steps stopped at the iteration limit: \
         {unconverged}; RATTLE sub-steps finished by Newton: {fallbacks}. Raw data: \
         `chain_stability.csv` (class, steps, strain and its allowance, energy measure, \
         unconverged projections, RATTLE Newton fallbacks, wall time and the error message per \
         cell).\n\n\
         Reading the maps: (1) the velocity level, Baumgarte and the projections cannot start \
         from a violated state without turning the violation into velocity (δℓ/h, about δℓ/(5h) \
         for Baumgarte) for at least a step, so on the violation map their energy test fails by \
         construction — the strain column (second half of the run) says whether they recovered \
         (RATTLE's velocity stage, J(x′)v′ = 0, removes that velocity within the step); \
         (2) \"bounded\" only means within {BLOWUP_EXTENT} extents: an inaccurate cell with strain \
         > {WILD_STRAIN} (and above its allowance) has links at least twice their length (counted \
         in the summary) — with a \
         heavy tip the light particles next to it feel a large tension whose transverse \
         (geometric) stiffness the linearized formulations treat explicitly (J at the start of \
         the step), so they whip unless h is small; the implicit soft step includes it (projected \
         Hessian); (3) the compliant formulation's energy includes ½kΣC², so the O(h²) length \
         drift it shares with the velocity level is stored energy in stiff links: at large k it \
         fails the energy test where the hard row (α = 0, no stored energy) passes.\n",
        total.cells()
    );
    Ok(panics)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(method: usize, h: f64) -> Cell {
        let stiffness = if links_of(method) == Links::Hard {
            f64::INFINITY
        } else {
            load_stiffness(3, 1.0)
        };
        Cell {
            method,
            h,
            links: 3,
            tip_ratio: 1.0,
            violation: 0.0,
            stiffness,
            horizon: 0.05,
            max_link_steps: 1e9,
        }
    }

    #[test]
    fn a_short_small_step_run_is_stable_for_every_method() {
        for m in 0..METHODS.len() {
            let r = run_cell(&cell(m, 1e-4));
            assert_eq!(r.class, CellClass::Stable, "{}: {r:?}", METHODS[m]);
            assert_eq!(r.steps, 500);
        }
    }

    #[test]
    fn stretched_links_start_at_the_violation() {
        for m in [0, 3] {
            let c = Cell {
                violation: 0.1,
                ..cell(m, 1e-3)
            };
            let (sys, _) = scene(&c).unwrap();
            let (s, _) = strain_and_energy(&sys.x, c.stiffness);
            assert!((s - 0.1).abs() < 1e-12, "{s}");
        }
    }

    #[test]
    fn a_stiff_explicit_spring_is_a_typed_instability_not_a_panic() {
        let c = Cell {
            stiffness: 1e12,
            ..cell(0, 1e-3)
        };
        let r = run_cell(&c);
        assert!(
            r.class.unstable() && r.class != CellClass::Panicked,
            "{r:?}"
        );
        assert!(r.steps < 50, "{r:?}");
    }

    #[test]
    fn the_stiffness_map_runs_hard_links_once_and_springs_at_finite_k() {
        let plan = Plan::new(true);
        let grid = plan.grid(Axis::Stiffness);
        let nv = plan.values(Axis::Stiffness).len();
        let nh = plan.hs.len();
        for m in 0..METHODS.len() {
            let rows: Vec<bool> = (0..nv).map(|v| grid[(m * nv + v) * nh].is_some()).collect();
            let expect: Vec<bool> = (0..nv)
                .map(|v| match links_of(m) {
                    Links::Springs => v + 1 < nv,
                    Links::Compliant => true,
                    Links::Hard => v + 1 == nv,
                })
                .collect();
            assert_eq!(rows, expect, "{}", METHODS[m]);
        }
    }

    #[test]
    fn the_horizon_is_cut_to_the_link_step_budget() {
        let c = Cell {
            links: 1000,
            max_link_steps: 5e4,
            ..cell(3, 1e-4)
        };
        assert_eq!(steps(&c), 50);
        assert_eq!(steps(&cell(3, 1.0)), 1);
    }

    #[test]
    fn results_keep_the_cell_order_whatever_the_threads() {
        let cells: Vec<Cell> = (0..METHODS.len()).map(|m| cell(m, 2e-3)).collect();
        let a = run_all(&cells, 1);
        let b = run_all(&cells, 3);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.cell, y.cell);
            assert_eq!(x.class, y.class);
            assert_eq!(x.steps, y.steps);
            assert_eq!(x.strain.to_bits(), y.strain.to_bits());
            assert_eq!(x.energy.to_bits(), y.energy.to_bits());
        }
    }
}
