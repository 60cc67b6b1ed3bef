//! Stability map of the articulated formulations (issue 6): the ball chain
//! ([`constraint_articulated::scenes::ball_chain`]) stepped by each [`METHODS`] entry
//! over pairs of axes — time step × tip mass ratio, time step × chain length, time step
//! × initial joint violation, time step × joint compliance `α = 1/k` (every joint made
//! compliant by `World::set_compliance`; the stiffness axis) — each cell classified by
//! [`classify`] as stable, inaccurate or unstable. Every cell runs under `catch_unwind`: a panic is its own
//! class, counted, and must never happen.
//!
//! Cells run in parallel over all cores; each run is single-threaded and deterministic,
//! and the results are stored by cell index, so the tables do not depend on the
//! scheduling (only the wall times do).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use constraint_articulated::scenes::ball_chain;
use constraint_articulated::{ArticulatedError, Method, World};
use constraint_scene::formulation::Formulation;

use crate::stability::{self, CellClass, Map, MapAxis, Runner};

/// Link length of the ball chain (m).
pub const LINK: f64 = 0.1;

/// Stable: max joint separation over the second half of the run at most this (m), i.e.
/// 1 % of the link length.
pub const SEPARATION_TOL: f64 = 1e-3;

/// Stable: max over the run of `|E(t) − E_exact| / (M g ℓ)` at most this (`M`: total
/// mass, `ℓ`: the chain's length, `E_exact = 0`: the chain starts at rest, horizontal
/// at `z = 0`, and the joints store no energy).
pub const ENERGY_TOL: f64 = 1e-2;

/// Blow-up: a body farther than this many initial extents (chain length including the
/// initial stretch, plus one link, plus for compliant joints twice the static stretch
/// [`static_stretch`]) from the anchor, or a non-finite energy. (An energy injected by
/// correcting a violation is bounded: it is inaccuracy, not blow-up.)
pub const BLOWUP_EXTENT: f64 = 10.0;

/// Blow-up on the compliance map (α > 0) also: a kinetic energy above this many
/// `M g × extent` (the energy of a fall over that many initial extents). Those cells
/// start at rest with no violation, so such energy can only come from the integrator (an
/// explicit stiff spring makes the links spin at up to 1e9 rad/s while their centres stay
/// in bounds); on the violation map the correction of the initial stretch injects a
/// bounded energy (`~ (δ/h)²`), which stays inaccuracy.
pub const KINETIC_BLOWUP: f64 = 1e3;

/// The formulations: report label, and the [`Method`] at step `h`.
pub const METHODS: [&str; 5] = [
    "velocity (β = 1)",
    "velocity + projection",
    "Baumgarte (τ = 5h)",
    "RATTLE",
    "RATTLE4 (Yoshida)",
];

/// The formulations of [`METHODS`], in the same order (the body side of the shared
/// vocabulary, [`constraint_scene::formulation`]).
pub const FORMULATIONS: [Formulation; 5] = [
    Formulation::Velocity,
    Formulation::VelocityProjection,
    Formulation::AccelerationBaumgarte,
    Formulation::Rattle,
    Formulation::Rattle4,
];

/// The [`Method`] of `METHODS[k]` at step `h` ([`Formulation::body_method`]); an index
/// past the end (or a formulation without a body method, none of [`FORMULATIONS`]) gives
/// `Method::default()` (RATTLE), as the listing of [`crate::deps`] expects a method.
pub fn method(k: usize, h: f64) -> Method {
    FORMULATIONS
        .get(k)
        .and_then(|f| f.body_method(h))
        .unwrap_or_default()
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
    /// Tip mass ratio.
    pub tip_ratio: f64,
    /// Initial stretch of every joint, as a fraction of the link length.
    pub violation: f64,
    /// Compliance `α` of every joint (m/N; 0: hard joints).
    pub compliance: f64,
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
    /// The class: stable when finite, bounded, with separation ≤ [`SEPARATION_TOL`] (hard
    /// joints) and energy error ≤ [`ENERGY_TOL`]; diverged on `ArticulatedError::Diverged`;
    /// failed on another typed error (singular factorization, loop solve).
    pub class: CellClass,
    /// Steps taken (the last one that failed not counted).
    pub steps: u64,
    /// Simulated time covered (s).
    pub simulated: f64,
    /// Max joint separation over the second half of the run (m); NaN if not reached.
    pub separation: f64,
    /// Max `|E − 0| / (M g ℓ)` over the run.
    pub energy: f64,
    /// RATTLE steps redone at the velocity level.
    pub fallbacks: usize,
    /// Wall time (s).
    pub seconds: f64,
    /// The error or panic message, if any (one line).
    pub message: String,
}

/// The chain of `cell`, every joint stretched by `violation × LINK` (body `i` moved by
/// `(i + 1)·violation·LINK` along `−x`, away from the anchor) and given the cell's
/// compliance.
pub fn world(cell: &Cell) -> Result<World, ArticulatedError> {
    let mut w = ball_chain(cell.links, cell.tip_ratio)?;
    if cell.violation != 0.0 {
        for (i, b) in w.bodies_mut().iter_mut().enumerate() {
            b.pose.x.x -= (i as f64 + 1.0) * cell.violation * LINK;
        }
    }
    if cell.compliance != 0.0 {
        for j in 0..w.joints().len() {
            w.set_compliance(j, cell.compliance)?;
        }
    }
    Ok(w)
}

/// The chain's total static stretch hanging at rest, `α g Σ_k (k + 1) m_k` (joint `j`
/// carries the weight of bodies `j…n−1`; m): the compliant joints' share of the
/// blow-up bound.
pub fn static_stretch(w: &World, alpha: f64) -> f64 {
    let g = w.gravity.length();
    alpha
        * g
        * w.bodies()
            .iter()
            .enumerate()
            .map(|(k, b)| (k as f64 + 1.0) * b.mass())
            .sum::<f64>()
}

/// Steps of a cell: `horizon / h` rounded, cut to `max_link_steps / links`, at least 1.
pub fn steps(cell: &Cell) -> u64 {
    let want = (cell.horizon / cell.h).round().max(1.0);
    let cap = (cell.max_link_steps / cell.links as f64).floor().max(1.0);
    want.min(cap) as u64
}

/// Runs one cell (no panic guard; see [`run_cell`]).
pub fn classify(cell: &Cell) -> CellResult {
    let t0 = Instant::now();
    let n = steps(cell);
    let mut r = CellResult {
        cell: *cell,
        class: CellClass::Stable,
        steps: 0,
        simulated: 0.0,
        separation: f64::NAN,
        energy: 0.0,
        fallbacks: 0,
        seconds: 0.0,
        message: String::new(),
    };
    let mut w = match world(cell) {
        Ok(w) => w,
        Err(e) => {
            r.class = CellClass::Failed;
            r.message = e.to_string();
            return r;
        }
    };
    let mass: f64 = w.bodies().iter().map(|b| b.mass()).sum();
    let length = cell.links as f64 * LINK;
    let scale = mass * 9.81 * length;
    let extent = length * (1.0 + cell.violation) + LINK + 2.0 * static_stretch(&w, cell.compliance);
    let m = method(cell.method, cell.h);
    let mut sep = 0.0f64;
    for k in 1..=n {
        match w.step(cell.h, m) {
            Ok(st) => r.fallbacks += st.fallbacks,
            Err(e) => {
                r.class = if matches!(e, ArticulatedError::Diverged { .. }) {
                    CellClass::Diverged
                } else {
                    CellClass::Failed
                };
                r.message = e.to_string();
                break;
            }
        }
        r.steps = k;
        let (kin, pot) = w.energy();
        let e = (kin + pot).abs() / scale;
        r.energy = r.energy.max(if e.is_finite() { e } else { f64::INFINITY });
        let far = w
            .bodies()
            .iter()
            .map(|b| b.pose.x.length())
            .fold(0.0, f64::max);
        let spun = cell.compliance > 0.0 && !(kin <= KINETIC_BLOWUP * mass * 9.81 * extent);
        if !(far <= BLOWUP_EXTENT * extent) || !r.energy.is_finite() || spun {
            r.class = CellClass::BlowUp;
            r.message = format!(
                "blow-up at step {k}: max |x| = {far:.3e} m, energy measure {:.3e}, kinetic {:.3e} J",
                r.energy, kin
            );
            break;
        }
        if 2 * k >= n {
            sep = sep.max(w.max_separation());
            r.separation = sep;
        }
    }
    r.simulated = r.steps as f64 * cell.h;
    // A compliant joint's separation is its spring's stretch, not an error: only the
    // energy (elastic part included) judges those cells.
    let separated = cell.compliance == 0.0 && !(r.separation <= SEPARATION_TOL);
    if r.class == CellClass::Stable && (separated || !(r.energy <= ENERGY_TOL)) {
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
        separation: f64::NAN,
        energy: f64::NAN,
        fallbacks: 0,
        seconds: 0.0,
        message,
    }
}

/// [`classify`] under `catch_unwind`: a panic becomes [`CellClass::Panicked`].
pub fn run_cell(cell: &Cell) -> CellResult {
    catch_unwind(AssertUnwindSafe(|| classify(cell)))
        .unwrap_or_else(|p| panicked(cell, crate::par::panic_message(p.as_ref())))
}

/// Runs `cells` on up to `threads` threads ([`crate::par::map_cells`], longest first);
/// results in the order of `cells`.
pub fn run_all(cells: &[Cell], threads: usize) -> Vec<CellResult> {
    crate::par::map_cells("articulated", cells, threads, cost, run_cell, panicked)
}

/// Work estimate of a cell: link-steps, times a per-method factor.
fn cost(c: &Cell) -> f64 {
    steps(c) as f64 * c.links as f64 * [1.0, 2.0, 2.0, 4.0, 11.0][c.method.min(4)]
}

/// One pair of axes: time step × another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Tip mass ratio (`ball_chain`'s `tip_ratio`).
    MassRatio,
    /// Links.
    Length,
    /// Initial joint stretch (fraction of the link length).
    Violation,
    /// Joint compliance `α = 1/k` (m/N) of every joint.
    Compliance,
}

impl Axis {
    /// Every axis paired with the time step, in report order.
    pub const ALL: [Axis; 4] = [
        Axis::MassRatio,
        Axis::Length,
        Axis::Violation,
        Axis::Compliance,
    ];

    /// Position in [`Axis::ALL`]: the axis's index in the map ([`crate::stability::Map::axes`]).
    pub fn index(self) -> usize {
        Axis::ALL.iter().position(|a| *a == self).unwrap_or(0)
    }

    /// Axis label.
    pub fn label(self) -> &'static str {
        match self {
            Axis::MassRatio => "tip mass ratio",
            Axis::Length => "links",
            Axis::Violation => "initial stretch / link length",
            Axis::Compliance => "joint compliance α (m/N)",
        }
    }

    /// File stem of the chart.
    pub fn stem(self) -> &'static str {
        match self {
            Axis::MassRatio => "mass",
            Axis::Length => "length",
            Axis::Violation => "violation",
            Axis::Compliance => "compliance",
        }
    }
}

/// What one mode of the map runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Time steps (s).
    pub hs: Vec<f64>,
    /// Tip mass ratios.
    pub ratios: Vec<f64>,
    /// Chain lengths (links).
    pub lengths: Vec<usize>,
    /// Initial stretches (fraction of the link length).
    pub violations: Vec<f64>,
    /// Joint compliances `α` (m/N; 0: hard).
    pub compliances: Vec<f64>,
    /// Links of the mass-ratio, violation and compliance maps.
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
                ratios: vec![1.0, 1e2, 1e4, 1e6],
                lengths: vec![10, 100, 1000, 10_000],
                violations: vec![0.0, 1e-2, 0.1, 0.5],
                compliances: vec![0.0, 1e-12, 1e-8, 1e-4, 1.0],
                base_links: 10,
                horizon: 1.0,
                max_link_steps: 2e5,
            }
        } else {
            Self {
                hs: vec![1e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 1.0 / 30.0],
                ratios: vec![1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6],
                lengths: vec![10, 30, 100, 300, 1000, 3000, 10_000],
                violations: vec![0.0, 1e-3, 1e-2, 0.1, 0.3, 1.0],
                compliances: vec![0.0, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2, 1.0],
                base_links: 10,
                horizon: 1.0,
                max_link_steps: 1e6,
            }
        }
    }

    /// Values along `axis` (as numbers) and their tick labels.
    pub fn values(&self, axis: Axis) -> Vec<f64> {
        match axis {
            Axis::MassRatio => self.ratios.clone(),
            Axis::Length => self.lengths.iter().map(|&n| n as f64).collect(),
            Axis::Violation => self.violations.clone(),
            Axis::Compliance => self.compliances.clone(),
        }
    }

    /// The cells of one map: for each method, value and step.
    pub fn cells(&self, axis: Axis) -> Vec<Cell> {
        self.map()
            .grid(self, axis.index())
            .into_iter()
            .flatten()
            .collect()
    }

    /// The map as data: the formulations, the time steps and the axes of [`Axis::ALL`].
    pub fn map(&self) -> Map {
        let axes = Axis::ALL
            .iter()
            .map(|&axis| {
                let note = match axis {
                    Axis::Compliance => format!(
                        "Ball chain of {} links (0.1 m), every joint compliant (α; k = 1/α), released horizontal, {} s per cell.\nStable: max |E|/(M g ℓ) ≤ {ENERGY_TOL:e} with the joints' elastic energy (α = 0: also separation ≤ {SEPARATION_TOL:e} m).",
                        self.base_links, self.horizon
                    ),
                    Axis::Length => format!(
                        "Ball chain, 0.1 m links, released horizontal; {} s or at most {:.0e} link-steps per cell (long chains: shorter runs).\nStable: max joint separation over the run's second half ≤ {SEPARATION_TOL:e} m and max |E|/(M g ℓ) ≤ {ENERGY_TOL:e}.",
                        self.horizon, self.max_link_steps
                    ),
                    _ => format!(
                        "Ball chain of {} links (0.1 m), released horizontal, {} s per cell.\nStable: max joint separation over the run's second half ≤ {SEPARATION_TOL:e} m and max |E|/(M g ℓ) ≤ {ENERGY_TOL:e}.",
                        self.base_links, self.horizon
                    ),
                };
                MapAxis::new(axis.label(), axis.stem(), self.values(axis), note)
            })
            .collect();
        Map {
            name: "articulated",
            heading: "Time step",
            alt: "articulated stability",
            title: "Articulated stability: time step",
            columns: 3,
            summary: "Summary per formulation",
            first_column: "method",
            csv_header: "axis,method,h,links,tip_ratio,violation,compliance,class,steps,simulated_s,separation_m,energy_rel,fallbacks,wall_s,message\n",
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
        let mut c = Cell {
            method,
            h,
            links: self.base_links,
            tip_ratio: 1.0,
            violation: 0.0,
            compliance: 0.0,
            horizon: self.horizon,
            max_link_steps: self.max_link_steps,
        };
        match Axis::ALL.get(axis)? {
            Axis::MassRatio => c.tip_ratio = x,
            Axis::Length => c.links = x as usize,
            Axis::Violation => c.violation = x,
            Axis::Compliance => c.compliance = x,
        }
        Some(c)
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

    fn csv_row(stem: &str, r: &CellResult) -> String {
        let c = &r.cell;
        format!(
            "{},{},{:e},{},{:e},{:e},{:e},{:?},{},{:e},{:e},{:e},{},{:.4},{}",
            stem,
            METHODS.get(c.method).copied().unwrap_or("?"),
            c.h,
            c.links,
            c.tip_ratio,
            c.violation,
            c.compliance,
            r.class,
            r.steps,
            r.simulated,
            r.separation,
            r.energy,
            r.fallbacks,
            r.seconds,
            r.message.replace(',', ";")
        )
    }
}

/// Writes the section (four heat maps `articulated_stability_<axis>.svg`, tables, a
/// summary and `articulated_stability.csv`) and returns the panic count.
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
        "\n## Stability map: articulated formulations\n\n\
         The ball chain of `constraint_articulated::scenes::ball_chain` (0.1 m rods, 34 g, \
         ball joints, hanging from the origin, released at rest along −x) stepped by five \
         formulations over time step × tip mass ratio ({} links), time step × chain length, \
         time step × initial violation (every joint stretched by a fraction of the link length: \
         body i moved by (i + 1)·δ·0.1 m along −x), and time step × joint compliance α = 1/k \
         (the stiffness axis: every joint made compliant by `World::set_compliance`, \
         C(x) = −α λ_f, a spring of stiffness k = 1/α N/m on each of the three rows; α = 0 is the \
         hard joint of the other maps). Methods: velocity level `Velocity {{ β: 1 }}`; \
         velocity level + Newton projection to 1e-10 m (≤ 10 iterations); acceleration level with \
         critically damped Baumgarte gains kx = 1/τ², kv = 2/τ, τ = 5h; RATTLE \
         (`Method::default()`, SHAKE to 1e-12 m, falls back to the velocity level when its \
         projection fails); RATTLE4 (Yoshida triple jump, 1e-12 m). Compliant joints: the two \
         velocity-level methods take them implicitly in the compliant form \
         [M Jᵀ; J −α/h²][v'; λ] = [M v + h f; −C/h] (backward Euler on the spring) and leave them \
         out of the projection (so with every joint compliant, velocity + projection equals the \
         velocity level); Baumgarte, RATTLE and RATTLE4 apply the explicit spring force \
         −(1/α) Jᵀ C (symplectic Euler / Störmer–Verlet in the kicks, rows out of the KKT system \
         and of SHAKE), stable only while h·√(k/m) stays small — RATTLE's fallback to the \
         velocity level (when a body turns by more than 0.5 rad in a step) can rescue a step.\n\n\
         Classes (thresholds exact): **✓ stable**: every step finite, bounded, max joint \
         separation over the second half of the run ≤ {SEPARATION_TOL:e} m (1 % of the link) and \
         max over the run of |E(t)|/(M g ℓ) ≤ {ENERGY_TOL:e} (E = kinetic + gravitational, exactly \
         0 at the start and for the exact motion; M total mass, ℓ chain length); **~ inaccurate**: \
         bounded but above either threshold; on the compliance map (α > 0) the separation \
         threshold does not apply (a compliant joint's stretch is its spring's, about α × the \
         force it carries) and E includes the joints' elastic energy Σ C²/(2α) — so at very stiff \
         α the velocity level's own O(h²) position drift (the hard joint's separation, 1e-7 m at \
         h = 1e-4 on this chain) counts as elastic energy C²/(2α) and such cells are inaccurate \
         though bounded; **✗ unstable**: `ArticulatedError::Diverged` \
         (non-finite or beyond 1e12); **↑ unstable**: blow-up, a body beyond {BLOWUP_EXTENT} × the \
         initial extent (chain length with its stretch, plus a link, plus for α > 0 twice the \
         chain's static stretch α g Σₖ (k + 1) mₖ) from the anchor, or a non-finite \
         energy, or on the compliance map a kinetic energy above {KINETIC_BLOWUP:e} × M g × that \
         extent (those cells start at rest without violation, so such energy is made by the \
         integrator: an explicit stiff spring spins the links up while their centres stay in \
         bounds); **! unstable**: another \
         typed error; **P**: a panic (caught per cell by `catch_unwind`; must be 0). Each cell \
         simulates {} s (long chains: at most {:.0e} link-steps, so fewer steps). Cells run on {threads} \
         thread(s); each run is deterministic.\n",
        plan.base_links,
        plan.horizon,
        plan.max_link_steps
    );
    let map = plan.map();
    let all = stability::write_maps(&map, &plan, md, out, threads)?;
    // Summary: per method, counts and the largest step stable (and not unstable) on
    // every row of each map.
    let total = stability::write_summary::<Plan>(&map, md, &all, &[]);
    let _ = writeln!(
        md,
        "\nPanics: {} (of {} cells). Raw data: `articulated_stability.csv` (class, steps, \
         separation, energy measure, RATTLE fallbacks, wall time and the error message per cell).\n",
        total.panics,
        total.cells()
    );
    Ok(total.panics)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(method: usize, h: f64) -> Cell {
        Cell {
            method,
            h,
            links: 3,
            tip_ratio: 1.0,
            violation: 0.0,
            compliance: 0.0,
            horizon: 0.05,
            max_link_steps: 1e9,
        }
    }

    #[test]
    fn a_short_small_step_run_is_stable_for_every_method() {
        for m in 0..METHODS.len() {
            let r = run_cell(&cell(m, 1e-3));
            assert_eq!(r.class, CellClass::Stable, "{}: {r:?}", METHODS[m]);
            assert_eq!(r.steps, 50);
        }
    }

    #[test]
    fn a_short_small_step_run_of_compliant_joints_is_stable_for_every_method() {
        for m in 0..METHODS.len() {
            let c = Cell {
                compliance: 1e-4,
                ..cell(m, 1e-4)
            };
            let r = run_cell(&c);
            assert_eq!(r.class, CellClass::Stable, "{}: {r:?}", METHODS[m]);
            assert_eq!(r.fallbacks, 0);
        }
        let w = world(&Cell {
            compliance: 1e-4,
            ..cell(0, 1e-4)
        })
        .unwrap();
        assert_eq!(w.compliances(), &[1e-4; 3]);
    }

    #[test]
    fn stretched_joints_start_at_the_violation() {
        let c = Cell {
            violation: 0.1,
            ..cell(0, 1e-3)
        };
        let w = world(&c).unwrap();
        assert!((w.max_separation() - 0.1 * LINK).abs() < 1e-12);
    }

    #[test]
    fn the_horizon_is_cut_to_the_link_step_budget() {
        let c = Cell {
            links: 1000,
            max_link_steps: 5e4,
            ..cell(0, 1e-4)
        };
        assert_eq!(steps(&c), 50);
        assert_eq!(steps(&cell(0, 1.0)), 1);
    }

    /// The quick compliance map alone, printed (`cargo test --release -p
    /// constraint-report --lib compliance_map -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn compliance_map() {
        let plan = Plan::new(true);
        let t0 = Instant::now();
        let res = run_all(&plan.cells(Axis::Compliance), crate::par::threads());
        for r in &res {
            println!(
                "{:24} α {:8.1e} h {:8.1e}: {:?} sep {:.2e} E {:.2e} fb {} {}",
                METHODS[r.cell.method],
                r.cell.compliance,
                r.cell.h,
                r.class,
                r.separation,
                r.energy,
                r.fallbacks,
                r.message
            );
        }
        println!("{:.1} s", t0.elapsed().as_secs_f64());
        // The printout is for reading; the property checked is that no cell panics.
        assert!(res.iter().all(|r| !matches!(r.class, CellClass::Panicked)));
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
            assert_eq!(x.separation.to_bits(), y.separation.to_bits());
        }
    }
}
