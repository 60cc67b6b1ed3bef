//! The contact section of the verification report (issue 5's figures):
//!
//! * **LCP solvers on contact problems of growing size**: the Delassus LCPs of real
//!   contact scenes (box stacks and pyramids after [`Plan::settle`] s of simulation at
//!   1/60 s), built by [`contact_problem`] exactly as the contact world assembles its
//!   next step (normal + two tangent rows per point), solved cold by Lemke and the
//!   Fischer–Burmeister Newton method (normal rows only: both take standard LCPs) and by
//!   projected Gauss–Seidel (normal rows only, and the boxed friction problem) at
//!   several iteration caps; natural-map residual against wall time, one log–log chart
//!   and a table in which typed failures stay visible;
//! * **contact scenes: error against run time**: sphere drop (rest height error),
//!   sliding box (stopping distance error against `v²/(2μg)`), a box stack (top-box
//!   drift) and a pyramid (worst displacement), each over the world's solvers
//!   ([`SCENE_SOLVERS`]) and several steps, one chart and one table per scene.
//!
//! Problems and scenes are deterministic (no random input); only the wall times vary
//! between runs.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use constraint_contact::geometry::generate_contacts;
use constraint_contact::lcp::{
    fischer_newton, lemke, pgs, Lcp, LcpError, LcpSolution, LemkeSettings, NewtonSettings,
    PgsSettings,
};
use constraint_contact::rigid::{ContactSolver, ContactWorld, FrictionModel};
use constraint_contact::scenes::{add_box, box_stack, ground, pyramid, sphere_drop};
use constraint_core::{DMat3, DVec3, Pose};

use crate::chart::{pareto_front, LogLogChart, Series};
use crate::peer_points::{peer_series, PeerPoint};

/// Step of the settling runs and of the LCP the problems are taken from (s).
pub const SETTLE_DT: f64 = 1.0 / 60.0;

/// Floor for errors on the log charts (an exact 0 has no place on a log axis).
pub const ERROR_FLOOR: f64 = 1e-16;

/// What one mode of the section runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Box stacks (number of boxes) whose LCP is measured.
    pub stacks: Vec<usize>,
    /// Pyramids (base) whose LCP is measured.
    pub pyramids: Vec<usize>,
    /// Simulated time before the LCP is taken (s).
    pub settle: f64,
    /// PGS sweep caps.
    pub pgs_caps: Vec<usize>,
    /// Newton step caps (the per-iteration curve).
    pub newton_caps: Vec<usize>,
    /// Timing: repeat a solve while the repeats together stay under this (s), at most 5.
    pub budget: f64,
    /// Steps of the scene sweep (s).
    pub dts: Vec<f64>,
    /// Boxes of the stack scene.
    pub stack: usize,
    /// Base of the pyramid scene.
    pub pyramid: usize,
    /// Horizon of the stack and pyramid scenes (s).
    pub hold_secs: f64,
}

impl Plan {
    /// The small plan (`cargo xtask verify` and CI) or the full one (`--full`).
    pub fn new(quick: bool) -> Self {
        let mut newton_caps: Vec<usize> = (1..=10).collect();
        newton_caps.extend([15, 20, 30, 50, 100]);
        if quick {
            Self {
                stacks: vec![2, 5, 10, 20],
                pyramids: vec![3, 5],
                settle: 0.5,
                pgs_caps: vec![1, 3, 10, 30, 100, 300, 1000],
                newton_caps,
                budget: 0.01,
                dts: vec![1.0 / 30.0, 1.0 / 60.0, 1.0 / 120.0],
                stack: 10,
                pyramid: 5,
                hold_secs: 2.0,
            }
        } else {
            Self {
                stacks: vec![2, 5, 10, 20],
                pyramids: vec![3, 5, 8],
                settle: 0.5,
                pgs_caps: vec![1, 3, 10, 30, 100, 300, 1000, 3000],
                newton_caps,
                budget: 0.05,
                dts: vec![1.0 / 30.0, 1.0 / 60.0, 1.0 / 120.0, 1.0 / 240.0],
                stack: 10,
                pyramid: 10,
                hold_secs: 5.0,
            }
        }
    }
}

/// The contact LCP of a world's next step, as the world assembles it.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactProblem {
    /// E.g. `stack 10`.
    pub name: String,
    /// Contact points.
    pub contacts: usize,
    /// The boxed friction problem: rows `(normal, t1, t2)` per point, `|z_t| ≤ μ z_n`.
    pub full: Lcp,
    /// The normal rows alone (friction impulses zero): a standard LCP.
    pub normal: Lcp,
}

/// The contact LCP `w = A z + q` of `world`'s next step of length `h`: contacts from the
/// world's own contact generation at the current poses (its margin), rows
/// `J = [−d, −r_a×d, d, r_b×d]` for the normal and two tangents `d` of each point,
/// `A = J M⁻¹ Jᵀ`, `q = J v_free − b` with `v_free = v + h g` and `b = gap/h` for a
/// speculative (separated) point, 0 otherwise — the world's rows with split impulses,
/// no restitution, gyroscopic term left out (bodies near rest).
pub fn contact_problem(name: &str, world: &ContactWorld, h: f64) -> Result<ContactProblem, String> {
    struct Row {
        a: Option<usize>,
        b: Option<usize>,
        j: [DVec3; 4],
        mj: [DVec3; 4],
        q: f64,
    }
    let bodies = world.bodies();
    let colliders = world.colliders();
    let poses: Vec<Pose> = bodies.iter().map(|b| b.pose).collect();
    let mut contacts = Vec::new();
    generate_contacts(colliders, &poses, world.settings.margin, &mut contacts)
        .map_err(|e| format!("contact generation: {e:?}"))?;
    let inv: Vec<(f64, DMat3)> = bodies
        .iter()
        .map(|b| (1.0 / b.mass(), b.world_inv_inertia()))
        .collect();
    let vfree: Vec<(DVec3, DVec3)> = bodies
        .iter()
        .map(|b| (b.v + world.gravity * h, b.omega))
        .collect();
    let mut rows = Vec::with_capacity(3 * contacts.len());
    let mut mu = Vec::with_capacity(contacts.len());
    for c in &contacts {
        let (ca, cb) = (&colliders[c.a], &colliders[c.b]);
        mu.push(ca.friction.max(cb.friction));
        let (ia, ib) = (ca.body, cb.body);
        let r_a = ia.map_or(DVec3::ZERO, |i| c.point_on_a() - bodies[i].pose.x);
        let r_b = ib.map_or(DVec3::ZERO, |i| c.point_on_b() - bodies[i].pose.x);
        let n = c.normal;
        let (t1, t2) = n.any_orthonormal_pair();
        let bias = if c.depth < 0.0 { c.depth / h } else { 0.0 };
        for (d, b) in [(n, bias), (t1, 0.0), (t2, 0.0)] {
            let j = [-d, -r_a.cross(d), d, r_b.cross(d)];
            let mut mj = [DVec3::ZERO; 4];
            let mut rate = 0.0;
            if let Some(i) = ia {
                mj[0] = j[0] * inv[i].0;
                mj[1] = inv[i].1 * j[1];
                rate += j[0].dot(vfree[i].0) + j[1].dot(vfree[i].1);
            }
            if let Some(i) = ib {
                mj[2] = j[2] * inv[i].0;
                mj[3] = inv[i].1 * j[3];
                rate += j[2].dot(vfree[i].0) + j[3].dot(vfree[i].1);
            }
            rows.push(Row {
                a: ia,
                b: ib,
                j,
                mj,
                q: rate - b,
            });
        }
    }
    let n = rows.len();
    let mut a = vec![0.0; n * n];
    for (i, ri) in rows.iter().enumerate() {
        for (k, rk) in rows.iter().enumerate().skip(i) {
            let mut s = 0.0;
            for (si, bi) in [(0usize, ri.a), (2usize, ri.b)] {
                let Some(bi) = bi else { continue };
                for (sk, bk) in [(0usize, rk.a), (2usize, rk.b)] {
                    if Some(bi) == bk {
                        s += ri.j[si].dot(rk.mj[sk]) + ri.j[si + 1].dot(rk.mj[sk + 1]);
                    }
                }
            }
            a[i * n + k] = s;
            a[k * n + i] = s;
        }
    }
    let q: Vec<f64> = rows.iter().map(|r| r.q).collect();
    let nc = contacts.len();
    let mut an = Vec::with_capacity(nc * nc);
    for i in 0..nc {
        for k in 0..nc {
            an.push(a[3 * i * n + 3 * k]);
        }
    }
    let qn: Vec<f64> = (0..nc).map(|i| q[3 * i]).collect();
    let full = Lcp::contact(a, q, &mu).map_err(|e| e.to_string())?;
    let normal = Lcp::new(an, qn).map_err(|e| e.to_string())?;
    Ok(ContactProblem {
        name: name.to_string(),
        contacts: nc,
        full,
        normal,
    })
}

/// Runs `world` for `secs` at [`SETTLE_DT`] with its default settings, then takes its
/// contact problem.
pub fn settled_problem(
    name: &str,
    mut world: ContactWorld,
    secs: f64,
) -> Result<ContactProblem, String> {
    let steps = (secs / SETTLE_DT).round() as usize;
    for _ in 0..steps {
        world.step(SETTLE_DT).map_err(|e| e.to_string())?;
    }
    contact_problem(name, &world, SETTLE_DT)
}

/// The plan's problems, stacks then pyramids; a scene that fails to build or settle
/// keeps its name and the reason.
pub fn problems(plan: &Plan) -> Vec<(String, Result<ContactProblem, String>)> {
    let mut out = Vec::new();
    for &n in &plan.stacks {
        let name = format!("stack {n}");
        let p = box_stack(n)
            .map_err(|e| e.to_string())
            .and_then(|w| settled_problem(&name, w, plan.settle));
        out.push((name, p));
    }
    for &b in &plan.pyramids {
        let name = format!("pyramid {b}");
        let p = pyramid(b)
            .map_err(|e| e.to_string())
            .and_then(|w| settled_problem(&name, w, plan.settle));
        out.push((name, p));
    }
    out
}

/// The LCP solvers of the first chart, in legend order.
pub const LCP_SOLVERS: [&str; 4] = [
    "Lemke (normal)",
    "Newton (normal)",
    "PGS (normal)",
    "PGS (boxed friction)",
];

/// One solve: which solver and setting, its wall time and its outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct LcpPoint {
    /// Problem name.
    pub problem: String,
    /// Contact points of the problem.
    pub contacts: usize,
    /// Rows of the problem this solver saw.
    pub rows: usize,
    /// One of [`LCP_SOLVERS`].
    pub solver: &'static str,
    /// Iteration or step cap (`None`: the solver's own limit, Lemke).
    pub cap: Option<usize>,
    /// Wall seconds of the solve (best of the repeats).
    pub seconds: f64,
    /// Residual reached and iterations (pivots, steps, sweeps) — also when a cap stopped
    /// the solver above its tolerance (that is how the curve is traced).
    pub reached: Option<(f64, usize)>,
    /// How the solve ended: `converged`, `cap reached`, or the typed error.
    pub status: String,
}

/// Times `f`: repeated while the runs together stay under `budget` s (at most 5 runs);
/// the best time and the first result.
pub fn time_best<T>(budget: f64, mut f: impl FnMut() -> T) -> (f64, T) {
    let t0 = Instant::now();
    let first = f();
    let mut best = t0.elapsed().as_secs_f64();
    let mut total = best;
    let mut runs = 1;
    while runs < 5 && total < budget {
        let t = Instant::now();
        let _ = f();
        let s = t.elapsed().as_secs_f64();
        best = best.min(s);
        total += s;
        runs += 1;
    }
    (best, first)
}

fn point(
    p: &ContactProblem,
    lcp: &Lcp,
    solver: &'static str,
    cap: Option<usize>,
    budget: f64,
    f: impl FnMut() -> Result<LcpSolution, LcpError>,
) -> LcpPoint {
    let (seconds, r) = time_best(budget, f);
    let (reached, status) = match r {
        Ok(s) => (Some((s.residual, s.iterations)), "converged".to_string()),
        Err(LcpError::IterationLimit {
            iterations,
            residual,
        }) => (Some((residual, iterations)), "cap reached".to_string()),
        Err(e) => (None, format!("failed: {e}")),
    };
    LcpPoint {
        problem: p.name.clone(),
        contacts: p.contacts,
        rows: lcp.n(),
        solver,
        cap,
        seconds,
        reached,
        status,
    }
}

/// Tolerance asked of Newton and PGS (Newton's default): near round-off, so caps rather
/// than the tolerance end the iterative runs. Lemke keeps its default (1e-10).
pub const TOLERANCE: f64 = 1e-12;

/// All solves of one problem: Lemke once (default settings); Newton at each step cap
/// until it converges or fails otherwise; PGS (normal rows, then the boxed problem) at
/// each sweep cap until it converges. Cold starts (`z0 = 0`), residual checked only at
/// the end of a PGS run.
pub fn solve_problem(p: &ContactProblem, plan: &Plan) -> Vec<LcpPoint> {
    let mut out = Vec::new();
    let b = plan.budget;
    let ls = LemkeSettings::default();
    out.push(point(p, &p.normal, LCP_SOLVERS[0], None, b, || {
        lemke(&p.normal, &ls, None)
    }));
    for &k in &plan.newton_caps {
        let ns = NewtonSettings {
            tolerance: TOLERANCE,
            max_iterations: k,
            ..NewtonSettings::default()
        };
        let pt = point(p, &p.normal, LCP_SOLVERS[1], Some(k), b, || {
            fischer_newton(&p.normal, &ns, None)
        });
        let more = pt.status == "cap reached";
        out.push(pt);
        if !more {
            break;
        }
    }
    for (solver, lcp) in [(LCP_SOLVERS[2], &p.normal), (LCP_SOLVERS[3], &p.full)] {
        for &k in &plan.pgs_caps {
            let ps = PgsSettings {
                tolerance: TOLERANCE,
                max_iterations: k,
                check_every: k,
                ..PgsSettings::default()
            };
            let pt = point(p, lcp, solver, Some(k), b, || pgs(lcp, &ps, None));
            let more = pt.status == "cap reached";
            out.push(pt);
            if !more {
                break;
            }
        }
    }
    out
}

/// The residual chart: per solver, one curve per problem (caps in increasing order),
/// curves separated by a non-finite point (see [`Series`]).
pub fn lcp_chart(points: &[LcpPoint], names: &[String], settle: f64) -> LogLogChart {
    let series = LCP_SOLVERS
        .iter()
        .map(|&s| {
            let mut pts = Vec::new();
            for name in names {
                let curve: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| p.solver == s && &p.problem == name)
                    .filter_map(|p| p.reached.map(|(r, _)| (p.seconds, r.max(ERROR_FLOOR))))
                    .collect();
                if !curve.is_empty() {
                    if !pts.is_empty() {
                        pts.push((f64::NAN, f64::NAN));
                    }
                    pts.extend(curve);
                }
            }
            Series {
                name: s.into(),
                points: pts,
            }
        })
        .collect();
    LogLogChart {
        title: "Contact LCPs: residual against run time".into(),
        x_label: "wall time of the solve (s)".into(),
        y_label: "natural-map residual (∞-norm / max(1, |q|∞))".into(),
        series,
        note: format!(
            "Problems: {} (Delassus LCP of the next 1/60 s step after {settle} s); one curve per problem and solver.\n\
             Curves: iteration / Newton-step caps, cold start; Lemke: one point per problem. Floor {ERROR_FLOOR:.0e}.",
            names.join(", ")
        ),
        log_x: true,
        pareto: false,
    }
}

fn lcp_table(md: &mut String, points: &[LcpPoint]) {
    let _ = writeln!(
        md,
        "| problem | contacts | solver | rows | cap | iterations | residual | time (µs) | outcome |\n|---|---|---|---|---|---|---|---|---|"
    );
    for p in points {
        let cap = p.cap.map_or("–".into(), |c| c.to_string());
        let (res, it) = p.reached.map_or(("–".into(), "–".into()), |(r, i)| {
            (format!("{r:.2e}"), i.to_string())
        });
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {cap} | {it} | {res} | {:.1} | {} |",
            p.problem,
            p.contacts,
            p.solver,
            p.rows,
            p.seconds * 1e6,
            p.status
        );
    }
}

/// One contact-world solver configuration of the scene sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSolver {
    /// Legend name.
    pub name: &'static str,
    /// The world's solver.
    pub solver: ContactSolver,
    /// Friction coupling.
    pub friction: FrictionModel,
    /// Sweeps (sequential impulses) or the dense PGS cap's floor (see the world).
    pub iterations: usize,
    /// Dense: assembles `A` (skipped on scenes with more contact points than
    /// [`DENSE_CONTACT_LIMIT`]).
    pub dense: bool,
}

/// The scene sweep's solvers. Everything else is the world's default
/// (`ContactSettings::default()`: tolerance 1e-6, Baumgarte 0.2 with split impulses,
/// 2 cm speculative margin, 2 shock-propagation sweeps, warm start).
pub const SCENE_SOLVERS: [SceneSolver; 5] = [
    SceneSolver {
        name: "Auto",
        solver: ContactSolver::Auto,
        friction: FrictionModel::Staggered { sweeps: 2 },
        iterations: 30,
        dense: false,
    },
    SceneSolver {
        name: "sequential impulses ×10",
        solver: ContactSolver::SequentialImpulses,
        friction: FrictionModel::Staggered { sweeps: 2 },
        iterations: 10,
        dense: false,
    },
    SceneSolver {
        name: "sequential impulses ×30",
        solver: ContactSolver::SequentialImpulses,
        friction: FrictionModel::Staggered { sweeps: 2 },
        iterations: 30,
        dense: false,
    },
    SceneSolver {
        name: "dense PGS (boxed)",
        solver: ContactSolver::Pgs,
        friction: FrictionModel::Boxed,
        iterations: 30,
        dense: true,
    },
    SceneSolver {
        name: "Newton (staggered ×2)",
        solver: ContactSolver::Newton,
        friction: FrictionModel::Staggered { sweeps: 2 },
        iterations: 30,
        dense: true,
    },
];

/// Dense solvers run only on scenes with at most this many contact points (the same
/// limit as `Auto`'s switch to the soft step).
pub const DENSE_CONTACT_LIMIT: usize = constraint_contact::rigid::AUTO_DENSE_CONTACTS;

/// A contact scene of the sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scene {
    /// Sphere of radius 0.1 m dropped from 1 m, 2 s: `|z − r|` at the end.
    SphereDrop,
    /// 0.2 m box (μ 0.5) launched at 3 m/s, 2 s: `|d − v²/(2μg)|`.
    SlidingBox,
    /// Box stack of `n`: max over time of the top box's displacement.
    Stack(usize),
    /// Pyramid of base `n`: max over time and boxes of the displacement.
    Pyramid(usize),
}

/// Stopping distance of the sliding box, `v²/(2μg)` (m).
pub const SLIDE_EXACT: f64 = 9.0 / (2.0 * 0.5 * 9.81);

impl Scene {
    /// Short name (file names, tables).
    pub fn name(&self) -> String {
        match self {
            Scene::SphereDrop => "sphere drop".into(),
            Scene::SlidingBox => "sliding box".into(),
            Scene::Stack(n) => format!("stack of {n}"),
            Scene::Pyramid(n) => format!("pyramid {n}"),
        }
    }

    /// Scene id of the peers' points (the chart's file stem without `contact_`):
    /// `sphere_drop`, `sliding_box`, `stack10`, `pyramid5`.
    pub fn id(&self) -> String {
        let f = self.file();
        f.strip_prefix("contact_").unwrap_or(&f).to_string()
    }

    /// File stem of the chart.
    pub fn file(&self) -> String {
        match self {
            Scene::SphereDrop => "contact_sphere_drop".into(),
            Scene::SlidingBox => "contact_sliding_box".into(),
            Scene::Stack(n) => format!("contact_stack{n}"),
            Scene::Pyramid(n) => format!("contact_pyramid{n}"),
        }
    }

    /// What the error is.
    pub fn error_label(&self) -> &'static str {
        match self {
            Scene::SphereDrop => "rest height error |z − r| (m)",
            Scene::SlidingBox => "stopping distance error |d − v²/(2μg)| (m)",
            Scene::Stack(_) => "max top-box displacement (m)",
            Scene::Pyramid(_) => "max box displacement (m)",
        }
    }

    /// The world at `t = 0`.
    pub fn world(&self) -> Result<ContactWorld, String> {
        let e = |e: constraint_contact::rigid::ContactError| e.to_string();
        match *self {
            Scene::SphereDrop => sphere_drop(0.1, 1.0).map_err(e),
            Scene::SlidingBox => {
                let mut w = ContactWorld::new(DVec3::new(0.0, 0.0, -9.81));
                ground(&mut w, 0.5).map_err(e)?;
                let b = add_box(
                    &mut w,
                    DVec3::splat(0.1),
                    None,
                    DVec3::new(0.0, 0.0, 0.1),
                    0.5,
                )
                .map_err(e)?;
                w.bodies_mut()[b].v = DVec3::new(3.0, 0.0, 0.0);
                Ok(w)
            }
            Scene::Stack(n) => box_stack(n).map_err(e),
            Scene::Pyramid(n) => pyramid(n).map_err(e),
        }
    }

    /// Simulated horizon (s).
    pub fn horizon(&self, plan: &Plan) -> f64 {
        match self {
            Scene::SphereDrop | Scene::SlidingBox => 2.0,
            Scene::Stack(_) | Scene::Pyramid(_) => plan.hold_secs,
        }
    }
}

/// A successful scene run.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneMeasured {
    /// The scene's error (m).
    pub error: f64,
    /// Wall seconds of the run (steps and the cheap error tracking), best of the repeats.
    pub seconds: f64,
    /// Steps taken.
    pub steps: u64,
    /// Most contact points in a step.
    pub max_contacts: usize,
    /// Mean solver iterations per step.
    pub mean_iterations: f64,
    /// Worst natural-map residual of a step's LCP.
    pub worst_residual: f64,
    /// Horizon (s).
    pub horizon: f64,
}

impl SceneMeasured {
    /// Run time per simulated second.
    pub fn cost(&self) -> f64 {
        self.seconds / self.horizon
    }
}

/// One point of the scene sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct ScenePoint {
    /// Solver name (see [`SCENE_SOLVERS`]).
    pub solver: &'static str,
    /// Step (s).
    pub dt: f64,
    /// The measurement, or why the run failed.
    pub outcome: Result<SceneMeasured, String>,
}

fn run_scene(
    scene: Scene,
    cfg: &SceneSolver,
    dt: f64,
    horizon: f64,
) -> Result<SceneMeasured, String> {
    let mut w = scene.world()?;
    w.settings.solver = cfg.solver;
    w.settings.friction = cfg.friction;
    w.settings.iterations = cfg.iterations;
    // The table reports the worst residual: the soft step computes it only on request
    // (`SoftStepSettings::residual`; `None` otherwise, counted as infinite here).
    w.settings.soft_step.residual = true;
    let x0: Vec<DVec3> = w.bodies().iter().map(|b| b.pose.x).collect();
    let steps = (horizon / dt).round() as u64;
    let (mut worst, mut max_contacts, mut iters, mut res) = (0.0f64, 0usize, 0usize, 0.0f64);
    let t0 = Instant::now();
    for k in 1..=steps {
        let s = w
            .step(dt)
            .map_err(|e| format!("t = {:.3} s: {e}", k as f64 * dt))?;
        max_contacts = max_contacts.max(s.contacts);
        iters += s.iterations;
        res = res.max(s.residual.unwrap_or(f64::INFINITY));
        match scene {
            Scene::Stack(n) => {
                worst = worst.max((w.bodies()[n - 1].pose.x - x0[n - 1]).length());
            }
            Scene::Pyramid(_) => {
                for (b, x) in w.bodies().iter().zip(&x0) {
                    worst = worst.max((b.pose.x - *x).length());
                }
            }
            Scene::SphereDrop | Scene::SlidingBox => {}
        }
    }
    let seconds = t0.elapsed().as_secs_f64();
    let error = match scene {
        Scene::SphereDrop => (w.bodies()[0].pose.x.z - 0.1).abs(),
        Scene::SlidingBox => (w.bodies()[0].pose.x.x - SLIDE_EXACT).abs(),
        Scene::Stack(_) | Scene::Pyramid(_) => worst,
    };
    Ok(SceneMeasured {
        error,
        seconds,
        steps,
        max_contacts,
        mean_iterations: iters as f64 / steps.max(1) as f64,
        worst_residual: res,
        horizon,
    })
}

/// Contact points of `scene` at rest (its first step with the default solver), to decide
/// whether the dense solvers apply.
pub fn resting_contacts(scene: Scene) -> Result<usize, String> {
    let mut w = scene.world()?;
    w.step(SETTLE_DT)
        .map(|s| s.contacts)
        .map_err(|e| e.to_string())
}

/// The scene's sweep: every applicable solver at every step; each run timed up to 3
/// times while the runs together stay under 0.5 s (best counts; one run in quick mode).
pub fn sweep_scene(scene: Scene, plan: &Plan, quick: bool) -> (Vec<ScenePoint>, Vec<&'static str>) {
    let horizon = scene.horizon(plan);
    let contacts = resting_contacts(scene).unwrap_or(usize::MAX);
    let mut skipped = Vec::new();
    let mut pts = Vec::new();
    for cfg in &SCENE_SOLVERS {
        if cfg.dense && contacts > DENSE_CONTACT_LIMIT {
            skipped.push(cfg.name);
            continue;
        }
        for &dt in &plan.dts {
            let mut outcome = run_scene(scene, cfg, dt, horizon);
            if let Ok(m) = &mut outcome {
                let (mut total, mut runs) = (m.seconds, 1);
                while !quick && runs < 3 && total < 0.5 {
                    match run_scene(scene, cfg, dt, horizon) {
                        Ok(again) => {
                            m.seconds = m.seconds.min(again.seconds);
                            total += again.seconds;
                        }
                        Err(_) => break,
                    }
                    runs += 1;
                }
            }
            pts.push(ScenePoint {
                solver: cfg.name,
                dt,
                outcome,
            });
        }
    }
    (pts, skipped)
}

/// MuJoCo's runs for the scene charts (`verify-report --contact-mjcf DIR`): the stack
/// and the pyramid of `plan` written as MJCF into `dir`
/// (`constraint_peers::contact::mjcf`, MuJoCo's defaults), the sliding box
/// `scenes/sliding_box.xml` (`root`-relative); one line per run, `id\txml\tdt\tduration`,
/// at each of the plan's steps over the scene's horizon. The sphere drop is left out.
pub fn mujoco_runs(plan: &Plan, dir: &Path, root: &Path) -> Result<Vec<String>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut lines = Vec::new();
    for scene in scenes(plan) {
        let xml = match scene {
            Scene::SphereDrop => continue,
            Scene::SlidingBox => root.join("scenes/sliding_box.xml"),
            Scene::Stack(_) | Scene::Pyramid(_) => {
                let w = scene.world()?;
                let text = constraint_peers::contact::mjcf(&w, &scene.id(), SETTLE_DT)?;
                let path = dir.join(format!("{}.xml", scene.id()));
                std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
                path
            }
        };
        for &dt in &plan.dts {
            lines.push(format!(
                "{}\t{}\t{dt:?}\t{}",
                scene.id(),
                xml.display(),
                scene.horizon(plan)
            ));
        }
    }
    Ok(lines)
}

fn dt_list(dts: &[f64]) -> String {
    let v: Vec<String> = dts.iter().map(|d| format!("1/{:.0}", 1.0 / d)).collect();
    v.join(", ")
}

/// The chart of one scene with other engines' points ([`PeerPoint`]s of this scene's
/// [`Scene::id`], each labelled, time per step over its `dt` (1/60 s when absent) for
/// the run time per simulated second) after ours; the labels for
/// [`LogLogChart::to_svg_labelled`].
pub fn scene_chart_with_peers(
    scene: Scene,
    points: &[ScenePoint],
    plan: &Plan,
    peers: &[PeerPoint],
) -> (LogLogChart, Vec<Vec<String>>) {
    let mut chart = scene_chart(scene, points, plan);
    let id = scene.id();
    // Time per step over the step: run time per simulated second, as ours.
    let mine: Vec<PeerPoint> = peers
        .iter()
        .filter(|p| p.scene == id)
        .map(|p| PeerPoint {
            seconds: p.seconds / p.dt.unwrap_or(SETTLE_DT),
            ..p.clone()
        })
        .collect();
    let refs: Vec<&PeerPoint> = mine.iter().collect();
    let (series, peer_labels) = peer_series(&refs, |t| t);
    let mut labels = vec![Vec::new(); chart.series.len()];
    if !series.is_empty() {
        chart.note.push_str(
            "\nLabelled points: other engines, time per step over their step (see the report).",
        );
    }
    chart.series.extend(series);
    labels.extend(peer_labels);
    (chart, labels)
}

/// The chart of one scene: error against run time per simulated second, one series per
/// solver over the steps, Pareto front marked.
pub fn scene_chart(scene: Scene, points: &[ScenePoint], plan: &Plan) -> LogLogChart {
    let series = SCENE_SOLVERS
        .iter()
        .map(|cfg| Series {
            name: cfg.name.into(),
            points: points
                .iter()
                .filter(|p| p.solver == cfg.name)
                .filter_map(|p| p.outcome.as_ref().ok())
                .map(|m| (m.cost(), m.error.max(ERROR_FLOOR)))
                .collect(),
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    LogLogChart {
        title: format!("{}: error against run time", scene.name()),
        x_label: "run time per simulated second (s)".into(),
        y_label: scene.error_label().into(),
        series,
        note: format!(
            "dt = {} s, {} s simulated; wall time of the whole run, one thread. Floor {ERROR_FLOOR:.0e}.",
            dt_list(&plan.dts),
            scene.horizon(plan)
        ),
        log_x: true,
        pareto: true,
    }
}

fn scene_table(md: &mut String, points: &[ScenePoint], front: &[(f64, f64)]) {
    let _ = writeln!(
        md,
        "| solver | dt (s) | error (m) | run time / simulated s | µs / step | contacts (max) | iterations / step | worst LCP residual | front |\n|---|---|---|---|---|---|---|---|---|"
    );
    for p in points {
        match &p.outcome {
            Ok(m) => {
                let on = front
                    .iter()
                    .any(|&(x, y)| x == m.cost() && y == m.error.max(ERROR_FLOOR));
                let _ = writeln!(
                    md,
                    "| {} | 1/{:.0} | {:.2e} | {:.2e} | {:.1} | {} | {:.1} | {:.1e} | {} |",
                    p.solver,
                    1.0 / p.dt,
                    m.error,
                    m.cost(),
                    m.seconds / m.steps as f64 * 1e6,
                    m.max_contacts,
                    m.mean_iterations,
                    m.worst_residual,
                    if on { "◆" } else { "" }
                );
            }
            Err(e) => {
                let _ = writeln!(
                    md,
                    "| {} | 1/{:.0} | failed: {e} | | | | | | |",
                    p.solver,
                    1.0 / p.dt
                );
            }
        }
    }
}

/// The other engines' points of `scene`, one line each (nothing when none).
fn peer_table(md: &mut String, scene: Scene, peers: &[PeerPoint]) {
    let id = scene.id();
    let mine: Vec<&PeerPoint> = peers.iter().filter(|p| p.scene == id).collect();
    if mine.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "Other engines (on the chart, labelled):\n\n| engine | setting | error (m) | run time / simulated s | µs / step |\n|---|---|---|---|---|"
    );
    for p in mine {
        let dt = p.dt.unwrap_or(SETTLE_DT);
        let _ = writeln!(
            md,
            "| {} | {} | {:.2e} | {:.2e} | {:.1} |",
            p.engine,
            p.setting,
            p.error,
            p.seconds / dt,
            p.seconds * 1e6
        );
    }
    md.push('\n');
}

/// The scenes of a plan, in report order.
pub fn scenes(plan: &Plan) -> Vec<Scene> {
    vec![
        Scene::SphereDrop,
        Scene::SlidingBox,
        Scene::Stack(plan.stack),
        Scene::Pyramid(plan.pyramid),
    ]
}

fn lcp_part(md: &mut String, out: &Path, plan: &Plan) -> Result<Vec<LcpPoint>, String> {
    let t0 = Instant::now();
    let mut names = Vec::new();
    let mut pts = Vec::new();
    let mut failed = Vec::new();
    for (name, p) in problems(plan) {
        match p {
            Ok(p) => {
                pts.extend(solve_problem(&p, plan));
                names.push(name);
            }
            Err(e) => failed.push(format!("{name}: {e}")),
        }
    }
    eprintln!(
        "  contact LCPs: {} problems, {} solves in {:.1} s",
        names.len(),
        pts.len(),
        t0.elapsed().as_secs_f64()
    );
    let chart = lcp_chart(&pts, &names, plan.settle);
    std::fs::write(out.join("contact_lcp_residual.svg"), chart.to_svg())
        .map_err(|e| e.to_string())?;
    let _ = writeln!(
        md,
        "### LCP solvers on contact problems of growing size\n\n![contact LCP residual](contact_lcp_residual.svg)\n"
    );
    let _ = writeln!(
        md,
        "Each problem is the velocity-level contact LCP `w = A z + q` of the next 1/60 s step of a scene \
         (box stacks of {:?} boxes, pyramids of base {:?}) after {} s of simulation with the default \
         solver: rows normal + two tangents per contact point, `A = J M⁻¹ Jᵀ`, `q = J (v + h g) − b` \
         with `b = gap/h` for speculative points (`contact_problem`). Resting box faces give four \
         coplanar points each, so `A` is only positive semidefinite (rank-deficient): the problems \
         are degenerate. Lemke and Newton take the standard LCP of the normal rows; PGS is run on \
         the same normal rows and on the boxed friction problem (`|z_t| ≤ μ z_n`). All solves start \
         cold (`z = 0`); Lemke with its defaults (tolerance 1e-10, at most 50 n pivots), Newton and \
         PGS with tolerance {TOLERANCE:.0e}; the iterative ones are stopped by caps (PGS \
         sweeps {:?}, Newton steps {:?}) to trace residual against time, each cap a separate timed \
         solve (best of up to 5 within {} s); a curve stops at the first cap that converges. \
         \"cap reached\" is the typed `IterationLimit` carrying the residual of the last iterate; \
         any other typed failure is listed as such and has no point on the chart.\n",
        plan.stacks,
        plan.pyramids,
        plan.settle,
        plan.pgs_caps,
        plan.newton_caps,
        plan.budget
    );
    for f in &failed {
        let _ = writeln!(md, "- problem failed to build: {f}");
    }
    // Summary: per problem and solver, the final point.
    let _ = writeln!(
        md,
        "Summary (last point of each solver per problem; the full list follows):\n"
    );
    let _ = writeln!(
        md,
        "| problem | contacts | Lemke (normal) | Newton (normal) | PGS (normal) | PGS (boxed friction) |\n|---|---|---|---|---|---|"
    );
    for name in &names {
        let contacts = pts
            .iter()
            .find(|p| &p.problem == name)
            .map_or(0, |p| p.contacts);
        let cells: Vec<String> = LCP_SOLVERS
            .iter()
            .map(|&s| {
                pts.iter()
                    .rfind(|p| &p.problem == name && p.solver == s)
                    .map_or("–".into(), summary_cell)
            })
            .collect();
        let _ = writeln!(md, "| {name} | {contacts} | {} |", cells.join(" | "));
    }
    let _ = writeln!(md, "\nAll solves:\n");
    lcp_table(md, &pts);
    md.push('\n');
    Ok(pts)
}

fn summary_cell(p: &LcpPoint) -> String {
    match p.reached {
        Some((r, it)) => format!(
            "{r:.1e} in {:.0} µs ({it} it.{})",
            p.seconds * 1e6,
            if p.status == "converged" { "" } else { ", cap" }
        ),
        None => format!("{} ({:.0} µs)", p.status, p.seconds * 1e6),
    }
}

fn lcp_csv(pts: &[LcpPoint]) -> String {
    let mut csv =
        String::from("problem,contacts,solver,rows,cap,iterations,residual,seconds,status\n");
    for p in pts {
        let (r, it) = p.reached.map_or((String::new(), String::new()), |(r, i)| {
            (format!("{r:e}"), i.to_string())
        });
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{it},{r},{:e},{}",
            p.problem,
            p.contacts,
            p.solver,
            p.rows,
            p.cap.map_or(String::new(), |c| c.to_string()),
            p.seconds,
            p.status.replace(',', ";")
        );
    }
    csv
}

/// Writes the whole section to `md`, its charts and `contact_lcp.csv`,
/// `contact_scenes.csv` to `out`. `peers` are other engines' points on the scene charts
/// (see [`scene_chart_with_peers`]; `cargo xtask verify` measures MuJoCo's and takes
/// rapier3d's from an earlier `cargo xtask bench`), `peer_note` says where they come
/// from (printed before the scene charts when not empty).
pub fn section(
    md: &mut String,
    out: &Path,
    quick: bool,
    peers: &[PeerPoint],
    peer_note: &str,
) -> Result<(), String> {
    let plan = Plan::new(quick);
    let _ = writeln!(
        md,
        "\n## Contact: LCP solvers and contact scenes against run time\n"
    );
    let _ = writeln!(
        md,
        "What is measured: (1) the natural-map residual each LCP solver (Lemke, Fischer–Burmeister \
         Newton, projected Gauss–Seidel) reaches against its wall time on the contact LCPs of real \
         stacks and pyramids of growing size; (2) for four contact scenes with a known answer — a \
         dropped sphere's rest height, a sliding box's stopping distance, a stack's and a pyramid's \
         drift — the error of each contact-world solver at several steps against its run time per \
         simulated second. Problems and scenes are deterministic; only the times vary between runs \
         (one thread, this machine).\n"
    );
    let lcp = lcp_part(md, out, &plan)?;
    std::fs::write(out.join("contact_lcp.csv"), lcp_csv(&lcp)).map_err(|e| e.to_string())?;

    let _ = writeln!(md, "### Contact scenes: error against run time\n");
    let _ = writeln!(
        md,
        "Each scene runs with each solver at dt = {} s. Solvers: `Auto` (dense Newton with staggered \
         friction up to {DENSE_CONTACT_LIMIT} contact points, the soft step with 3 sub-steps beyond), matrix-free \
         sequential impulses with 10 and 30 sweeps, dense PGS on the boxed friction LCP (tolerance \
         1e-6, at least 1000 sweeps allowed), dense Newton with two staggered friction sweeps; all \
         with the world's defaults otherwise (split-impulse Baumgarte 0.2, slop 0.1 mm, 2 cm \
         speculative margin, two shock-propagation sweeps, warm start). Dense solvers are skipped \
         on scenes with more than {DENSE_CONTACT_LIMIT} resting contact points. Errors: sphere \
         (r = 0.1 m) dropped from 1 m, |z − r| after 2 s; 0.2 m box launched at 3 m/s on μ = 0.5, \
         |d − v²/(2μg)| after 2 s (exact {SLIDE_EXACT:.5} m); stack of {} unit boxes, max over time \
         of the top box's displacement over {} s; pyramid of base {}, max over time and boxes of \
         the displacement over {} s. Run time: wall clock of the run{}, per simulated second. A \
         failed run (typed error) is listed with the time of the failing step.\n",
        dt_list(&plan.dts),
        plan.stack,
        plan.hold_secs,
        plan.pyramid,
        plan.hold_secs,
        if quick {
            ", one run"
        } else {
            ", best of up to 3 within 0.5 s"
        }
    );
    let mut csv = String::from(
        "scene,solver,dt,error_m,seconds_per_step,max_contacts,iterations_per_step,worst_residual,failure\n",
    );
    if !peer_note.is_empty() {
        let _ = writeln!(md, "Other engines on these charts: {peer_note}\n");
    }
    for scene in scenes(&plan) {
        let t0 = Instant::now();
        let (pts, skipped) = sweep_scene(scene, &plan, quick);
        eprintln!(
            "  contact scene {}: {} runs in {:.1} s",
            scene.name(),
            pts.len(),
            t0.elapsed().as_secs_f64()
        );
        let (chart, labels) = scene_chart_with_peers(scene, &pts, &plan, peers);
        let all: Vec<(f64, f64)> = chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .collect();
        let front = pareto_front(&all);
        let file = format!("{}.svg", scene.file());
        std::fs::write(out.join(&file), chart.to_svg_labelled(&labels))
            .map_err(|e| e.to_string())?;
        let _ = writeln!(
            md,
            "#### {}\n\n![{} error against run time]({file})\n",
            scene.name(),
            scene.name()
        );
        peer_table(md, scene, peers);
        if !skipped.is_empty() {
            let _ = writeln!(
                md,
                "Not run (more than {DENSE_CONTACT_LIMIT} contact points, dense): {}.\n",
                skipped.join(", ")
            );
        }
        let failed = pts.iter().filter(|p| p.outcome.is_err()).count();
        if failed > 0 {
            let _ = writeln!(
                md,
                "{failed} of {} runs failed with a typed error (listed in the table, not on the chart).\n",
                pts.len()
            );
        }
        scene_table(md, &pts, &front);
        md.push('\n');
        for p in &pts {
            match &p.outcome {
                Ok(m) => {
                    let _ = writeln!(
                        csv,
                        "{},{},{:e},{:e},{:e},{},{:e},{:e},",
                        scene.name(),
                        p.solver,
                        p.dt,
                        m.error,
                        m.seconds / m.steps as f64,
                        m.max_contacts,
                        m.mean_iterations,
                        m.worst_residual
                    );
                }
                Err(e) => {
                    let _ = writeln!(
                        csv,
                        "{},{},{:e},,,,,,{}",
                        scene.name(),
                        p.solver,
                        p.dt,
                        e.replace(',', ";")
                    );
                }
            }
        }
    }
    std::fs::write(out.join("contact_scenes.csv"), csv).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_problem_has_three_rows_per_point_and_a_symmetric_psd_diagonal() {
        let w = box_stack(2).unwrap();
        let p = contact_problem("stack 2", &w, SETTLE_DT).unwrap();
        // Two resting faces (ground–box, box–box), four points each.
        assert_eq!(p.contacts, 8);
        assert_eq!(p.full.n(), 24);
        assert_eq!(p.normal.n(), 8);
        let n = p.full.n();
        for i in 0..n {
            assert!(p.full.m_ij(i, i) > 0.0);
            for k in 0..n {
                assert!((p.full.m_ij(i, k) - p.full.m_ij(k, i)).abs() < 1e-15);
            }
        }
        // At rest the free velocity is g h downward for both boxes: the four ground rows
        // approach at g h, the box–box rows not at all.
        let q = p.normal.q();
        assert_eq!(
            q.iter().filter(|&&q| q < -0.9 * 9.81 * SETTLE_DT).count(),
            4
        );
        assert!(q.iter().all(|&q| q < 1e-12));
        // The normal rows of the full problem are the normal problem.
        assert_eq!(p.full.m_ij(3, 6), p.normal.m_ij(1, 2));
    }

    #[test]
    fn solvers_trace_decreasing_residuals_and_keep_failures() {
        let w = box_stack(2).unwrap();
        let p = settled_problem("stack 2", w, 0.1).unwrap();
        let plan = Plan {
            pgs_caps: vec![1, 10, 100],
            newton_caps: vec![1, 2, 3, 50],
            budget: 0.0,
            ..Plan::new(true)
        };
        let pts = solve_problem(&p, &plan);
        assert_eq!(pts[0].solver, LCP_SOLVERS[0]);
        for s in &LCP_SOLVERS[2..] {
            let r: Vec<f64> = pts
                .iter()
                .filter(|q| q.solver == *s)
                .map(|q| q.reached.unwrap().0)
                .collect();
            assert!(
                r.len() >= 2 && r.windows(2).all(|w| w[1] <= w[0]),
                "{s}: {r:?}"
            );
        }
        // Every point either reached a residual or names its typed failure.
        assert!(pts
            .iter()
            .all(|q| q.reached.is_some() || q.status.starts_with("failed: ")));
        let chart = lcp_chart(&pts, &["stack 2".into()], 0.1);
        assert_eq!(chart.series.len(), LCP_SOLVERS.len());
    }

    #[test]
    fn peers_join_the_scene_chart_labelled_per_simulated_second() {
        let plan = Plan::new(true);
        let peer = |engine: &str, setting: &str, dt| PeerPoint {
            scene: "sliding_box".into(),
            scene_label: String::new(),
            y_label: String::new(),
            engine: engine.into(),
            setting: setting.into(),
            seconds: 1e-6,
            error: 1e-3,
            dt,
        };
        let peers = vec![
            peer("MuJoCo", "dt 1/60", Some(1.0 / 60.0)),
            peer("MuJoCo", "dt 1/120", Some(1.0 / 120.0)),
            peer("rapier3d", "bench", None),
            PeerPoint {
                scene: "stack10".into(),
                ..peer("MuJoCo", "other scene", None)
            },
        ];
        let (chart, labels) = scene_chart_with_peers(Scene::SlidingBox, &[], &plan, &peers);
        assert_eq!(chart.series.len(), 2);
        assert_eq!(chart.series[0].points.len(), 3, "two points and a break");
        assert!((chart.series[0].points[2].0 - 120e-6).abs() < 1e-12);
        let svg = chart.to_svg_labelled(&labels);
        assert_eq!(svg.matches(r#"class="label""#).count(), 3);
        let dir = std::env::temp_dir().join(format!("mujoco_runs_{}", std::process::id()));
        let lines = mujoco_runs(&plan, &dir, Path::new("/r")).unwrap();
        assert_eq!(lines.len(), 3 * plan.dts.len());
        assert!(lines[0].starts_with("sliding_box\t/r/scenes/sliding_box.xml\t0.0333"));
        assert!(dir.join("stack10.xml").exists() && dir.join("pyramid5.xml").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn sliding_box_point_is_close_to_the_analytic_distance() {
        let plan = Plan::new(true);
        let si30 = SCENE_SOLVERS[2];
        assert_eq!(si30.solver, ContactSolver::SequentialImpulses);
        let m = run_scene(Scene::SlidingBox, &si30, 1.0 / 120.0, 2.0).unwrap();
        // Measured 1.25e-2 m (1.4 %).
        assert!(m.error < 0.05 * SLIDE_EXACT, "{}", m.error);
        assert_eq!(m.steps, 240);
        assert!(plan.dts.len() < Plan::new(false).dts.len());
    }
}
