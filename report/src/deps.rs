//! What each scene of the report compiles and runs (issue 6, "leave out what a scene
//! does not need").
//!
//! Every scene declares the crate it is built with and the smallest feature set it
//! needs ([`SCENES`]). [`catalogue`] builds each scene, runs a few steps with every
//! method the report uses on it, and collects the run-time stages the steps actually
//! went through. The libraries return plain data — their configuration and what their
//! steps record ([`Integrator::scheme`], [`VelocityLevel::last_solver`],
//! [`ContactWorld::last_path`], …) — and [`words`] names the stages: soft forces and
//! integrator, hard sets, formulation and the KKT solver used, rigid bodies, tree,
//! loops, damping, compliance and method, broad and narrow phase and the contact solver
//! path taken.
//! [`section`] writes them with the compiled
//! dependency tree of each crate + feature set, from
//! `cargo tree -e normal -p <crate> --no-default-features --features <…>` (run through
//! [`std::process::Command`]; skipped with a note when cargo cannot be run), each
//! distinct tree printed once and named.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use constraint_articulated::{Method as Articulated, MjcfScene, World};
use constraint_contact::rigid::ContactWorld;
use constraint_lagrange::scenes::{hard_volume_jelly, structural_links, tilted_inextensible_cloth};
use constraint_lagrange::{
    BaseStep, Constraints, FastProjection, HardSet, KktSolver, ProjectedStep, VelocityLevel,
};
use constraint_soft::{
    CgSettings, ConstraintSet, HessianMode, ImplicitEuler, Integrator, Jelly, LinearSolver,
    SoftSystem, Softness,
};

use crate::{articulated_report, articulated_stability, contact_report, particle_report};

pub mod words;
use constraint_scene::run as scene;

/// A scene of the report: its name, the crate it is built with and the smallest feature
/// set it needs (on top of `--no-default-features`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneDecl {
    /// Scene name (report label).
    pub name: &'static str,
    /// Where the report uses it.
    pub used_in: &'static str,
    /// The crate the scene is built and stepped with.
    pub krate: &'static str,
    /// The smallest feature set it needs.
    pub features: &'static [&'static str],
}

const SOFT: &str = "constraint-soft";
const LAGRANGE: &str = "constraint-lagrange";
const ARTICULATED: &str = "constraint-articulated";
const CONTACT: &str = "constraint-contact";

/// The scenes of the report, in report order. Each needs only its crate: the soft
/// scenes' LDLᵀ is the soft crate's `faer`; the Lagrange formulations need `std` (they
/// step a soft system; it pulls in the soft crate with `faer` for the implicit base
/// step), the sparse Schur solves `sparse`; the MJCF scenes `mjcf`; the built-in ball
/// chains nothing (the articulated crate is `no_std` + `alloc`); the rigid contact
/// scenes `rigid` (they are built in Rust, not from MJCF).
pub const SCENES: [SceneDecl; 8] = [
    SceneDecl {
        name: "spring-only bob",
        used_in: "`soft/examples/spring_only.rs` (the leave-out test)",
        krate: SOFT,
        features: &[],
    },
    SceneDecl {
        name: "cloth 10×10",
        used_in: "cloth stability map and work-precision",
        krate: SOFT,
        features: &["faer"],
    },
    SceneDecl {
        name: "jelly",
        used_in: "jelly work-precision, soft volume",
        krate: SOFT,
        features: &["faer"],
    },
    SceneDecl {
        name: "particle chain",
        used_in: "chain work-precision and drift",
        krate: LAGRANGE,
        features: &["std"],
    },
    SceneDecl {
        name: "inextensible cloth 10×10",
        used_in: "soft versus hard: strain against run time",
        krate: LAGRANGE,
        features: &["sparse"],
    },
    SceneDecl {
        name: "hard-volume jelly",
        used_in: "jelly: hard volume next to soft volume",
        krate: LAGRANGE,
        features: &["sparse"],
    },
    SceneDecl {
        name: "MJCF scene",
        used_in: "articulated work-precision and drift (`scenes/*.xml`)",
        krate: ARTICULATED,
        features: &["mjcf"],
    },
    SceneDecl {
        name: "ball chain",
        used_in: "articulated stability maps (`scenes::ball_chain`)",
        krate: ARTICULATED,
        features: &[],
    },
];

/// The contact scenes' declaration (one row per scene of
/// [`contact_report::scenes`]).
pub const CONTACT_SCENES: SceneDecl = SceneDecl {
    name: "contact scene",
    used_in: "contact work-precision (`constraint_contact::scenes`)",
    krate: CONTACT,
    features: &["rigid"],
};

/// One method run on a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// The method, as the report names it.
    pub method: String,
    /// The stages observed over the steps, in first-seen order.
    pub stages: Vec<String>,
    /// Why the run stopped early, if it did (the stages seen until then are kept).
    pub failure: Option<String>,
}

/// A scene, what it declares, and what its runs went through.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneStages {
    /// Scene name.
    pub scene: String,
    /// The declaration.
    pub decl: SceneDecl,
    /// The scene's size where its stages do not say it (bodies, joints, colliders).
    pub content: Option<String>,
    /// One run per method the report uses on the scene (empty when the scene could not
    /// be built: see `failure`).
    pub runs: Vec<Run>,
    /// Why the scene could not be built, if it could not.
    pub failure: Option<String>,
}

impl SceneStages {
    fn new(scene: impl Into<String>, decl: SceneDecl) -> Self {
        Self {
            scene: scene.into(),
            decl,
            content: None,
            runs: Vec::new(),
            failure: None,
        }
    }

    /// The runs grouped by identical stages and failure: the methods of each group
    /// (in run order) and one run standing for them.
    pub fn groups(&self) -> Vec<(Vec<&str>, &Run)> {
        let mut out: Vec<(Vec<&str>, &Run)> = Vec::new();
        for r in &self.runs {
            match out
                .iter_mut()
                .find(|g| g.1.stages == r.stages && g.1.failure == r.failure)
            {
                Some(g) => g.0.push(&r.method),
                None => out.push((vec![&r.method], r)),
            }
        }
        out
    }

    /// The stages every run went through (order of the first run); empty unless the
    /// runs went through at least two different stage lists.
    pub fn common(&self) -> Vec<String> {
        let groups = self.groups();
        let Some(((_, first), rest)) = groups.split_first() else {
            return Vec::new();
        };
        if rest.is_empty() {
            return Vec::new();
        }
        first
            .stages
            .iter()
            .filter(|s| rest.iter().all(|(_, r)| r.stages.contains(s)))
            .cloned()
            .collect()
    }
}

/// Appends the stages of `new` not yet in `out`.
fn observe<S: Into<String>>(out: &mut Vec<String>, new: impl IntoIterator<Item = S>) {
    for s in new {
        let s = s.into();
        if !out.contains(&s) {
            out.push(s);
        }
    }
}

/// Steps of each run: enough for the solvers' choices (KKT solver, contact path) to be
/// observed, few enough for the section to take seconds.
const STEPS: usize = 5;

/// Step of the soft scenes' runs: small enough for symplectic Euler on the jelly.
const SOFT_H: f64 = 1e-4;

/// A soft integrator on a soft system.
fn soft_run(method: String, mut sys: SoftSystem, mut integ: Box<dyn Integrator>) -> Run {
    let mut failure = None;
    for k in 1..=STEPS {
        if let Err(e) = integ.step(&mut sys) {
            failure = Some(format!("step {k}: {e}"));
            break;
        }
    }
    let mut stages = words::soft_system(&sys);
    observe(&mut stages, words::integrator(integ.as_ref()));
    Run {
        method,
        stages,
        failure,
    }
}

/// What the report's particle formulations share: a step and its stages ([`words`]).
trait Formulation {
    fn step(&mut self, sys: &mut SoftSystem, cons: &Constraints) -> Result<(), String>;
    fn stages(&self, cons: &Constraints) -> Vec<&'static str>;
}

impl Formulation for VelocityLevel {
    fn step(&mut self, sys: &mut SoftSystem, cons: &Constraints) -> Result<(), String> {
        VelocityLevel::step(self, sys, cons)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
    fn stages(&self, cons: &Constraints) -> Vec<&'static str> {
        words::velocity(self, cons)
    }
}

impl Formulation for ProjectedStep<ImplicitEuler> {
    fn step(&mut self, sys: &mut SoftSystem, cons: &Constraints) -> Result<(), String> {
        ProjectedStep::step(self, sys, cons)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
    fn stages(&self, cons: &Constraints) -> Vec<&'static str> {
        words::projected(self, cons)
    }
}

impl Formulation for ImplicitEuler {
    fn step(&mut self, sys: &mut SoftSystem, _: &Constraints) -> Result<(), String> {
        Integrator::step(self, sys)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
    fn stages(&self, _: &Constraints) -> Vec<&'static str> {
        words::integrator(self)
    }
}

/// A particle formulation on a system with hard constraints: the system's force
/// stages, the hard sets, then the formulation's, after every step.
fn particle_run(
    method: &str,
    mut sys: SoftSystem,
    cons: &Constraints,
    f: &mut dyn Formulation,
) -> Run {
    let mut stages = Vec::new();
    let mut failure = None;
    for k in 1..=STEPS {
        if let Err(e) = f.step(&mut sys, cons) {
            failure = Some(format!("step {k}: {e}"));
            break;
        }
        observe(&mut stages, words::soft_system(&sys));
        observe(&mut stages, words::constraints(cons));
        observe(&mut stages, f.stages(cons));
    }
    if stages.is_empty() {
        observe(&mut stages, words::soft_system(&sys));
        observe(&mut stages, words::constraints(cons));
        observe(&mut stages, f.stages(cons));
    }
    Run {
        method: method.into(),
        stages,
        failure,
    }
}

/// `1 body`, `n bodies`.
fn bodies(n: usize) -> String {
    if n == 1 {
        "1 body".into()
    } else {
        format!("{n} bodies")
    }
}

/// Bodies and joints of a world, by joint kind (`3 bodies, 2 hinge, 1 spherical`).
fn world_content(w: &World) -> String {
    let mut kinds: Vec<(&'static str, usize)> = Vec::new();
    for j in 0..w.joints().len() {
        let k = w.joint_kind_name(j);
        match kinds.iter_mut().find(|(n, _)| *n == k) {
            Some((_, c)) => *c += 1,
            None => kinds.push((k, 1)),
        }
    }
    let mut s = bodies(w.bodies().len());
    for (k, c) in kinds {
        let _ = write!(s, ", {c} {k}");
    }
    s
}

/// An articulated method on a world, stepped at `h`.
fn articulated_run(label: &str, mut w: World, method: Articulated, h: f64) -> Run {
    let mut failure = None;
    for k in 1..=STEPS {
        if let Err(e) = w.step(h, method) {
            failure = Some(format!("step {k}: {e}"));
            break;
        }
    }
    let stages = words::world(&mut w, method)
        .into_iter()
        .map(String::from)
        .collect();
    Run {
        method: label.into(),
        stages,
        failure,
    }
}

/// A contact solver on a contact world, stepped at `h` for `steps` steps: the stages
/// after every step (the solver path may change as contacts come and go).
fn contact_run(label: &str, mut w: ContactWorld, h: f64, steps: usize) -> Run {
    let mut stages = Vec::new();
    let mut failure = None;
    for k in 1..=steps {
        let stepped = w.step(h);
        // After a failed step too: the path it took until it failed.
        observe(&mut stages, words::contact(&w));
        if let Err(e) = stepped {
            failure = Some(format!("step {k}: {e}"));
            break;
        }
    }
    Run {
        method: label.into(),
        stages,
        failure,
    }
}

fn soft_scenes(out: &mut Vec<SceneStages>) {
    use crate::sweeps::{sweep_cloth, Method};
    // The spring-only example.
    let mut s = SceneStages::new(SCENES[0].name, SCENES[0]);
    let bob = || -> Result<SoftSystem, String> {
        let x = vec![
            constraint_core::DVec3::ZERO,
            constraint_core::DVec3::new(0.0, 0.0, -1.0),
        ];
        let mut sys = SoftSystem::new(x.clone(), vec![1.0, 1.0]).map_err(|e| e.to_string())?;
        sys.pin(0).map_err(|e| e.to_string())?;
        let spring = constraint_core::Distance::from_rest(0, 1, &x).map_err(|e| e.to_string())?;
        let set = ConstraintSet::uniform("spring", vec![spring], Softness::stiff(1e4))
            .map_err(|e| e.to_string())?;
        sys.add_set(set).map_err(|e| e.to_string())?;
        Ok(sys)
    };
    let cg = ImplicitEuler::new(
        1e-2,
        HessianMode::Projected,
        LinearSolver::ConjugateGradient(CgSettings::default()),
    );
    match (bob(), cg) {
        (Ok(sys), Ok(cg)) => s.runs.push(soft_run(
            "implicit Euler, CG, Projected".into(),
            sys,
            Box::new(cg),
        )),
        (Err(e), _) => s.failure = Some(e),
        (_, Err(e)) => s.failure = Some(e.to_string()),
    }
    out.push(s);
    // Cloth and jelly: every soft integrator configuration of the report.
    let k = constraint_soft::Cloth::default().spring.stiffness;
    type Build<'a> = &'a dyn Fn() -> Result<SoftSystem, constraint_soft::SoftError>;
    let builds: [(SceneDecl, Build); 2] = [
        (SCENES[1], &|| sweep_cloth(10, k)),
        (SCENES[2], &|| Jelly::default().build()),
    ];
    for (decl, build) in builds {
        let mut s = SceneStages::new(decl.name, decl);
        for m in Method::ALL {
            match (build(), m.build(SOFT_H)) {
                (Ok(sys), Ok(integ)) => s.runs.push(soft_run(m.label(), sys, integ)),
                (Err(e), _) | (_, Err(e)) => s.failure = Some(e.to_string()),
            }
        }
        out.push(s);
    }
}

fn lagrange_scenes(out: &mut Vec<SceneStages>) {
    // The particle chain: every formulation of the work-precision chart (the drift
    // chart's are among them).
    let mut s = SceneStages::new(SCENES[3].name, SCENES[3]);
    for (m, label) in particle_report::CHAIN_METHODS.iter().enumerate() {
        let (stages, failure) = match particle_report::chain_stages(m, 1.0 / 240.0, STEPS) {
            Ok(st) => (st, None),
            Err(e) => (Vec::new(), Some(e.to_string())),
        };
        s.runs.push(Run {
            method: (*label).into(),
            stages,
            failure,
        });
    }
    out.push(s);

    // The inextensible cloth: the three configurations of
    // `hard::cloth_strain_vs_time` (n = 10, h = 1/60, sparse-LDLᵀ soft steps).
    let mut s = SceneStages::new(SCENES[4].name, SCENES[4]);
    let (n, h) = (10, 1.0 / 60.0);
    let cloth = || {
        tilted_inextensible_cloth(n, crate::hard::K_SHEAR, 1.0)
            .and_then(|(sys, cons)| structural_links(n, &sys.x).map(|l| (sys, cons, l)))
            .map_err(|e| e.to_string())
    };
    let run = |label: &str, f: &dyn Fn() -> Result<Run, String>| {
        f().unwrap_or_else(|e| Run {
            method: label.into(),
            stages: Vec::new(),
            failure: Some(e),
        })
    };
    s.runs.push(run("fast projection", &|| {
        let (sys, cons, _) = cloth()?;
        let imp = ImplicitEuler::new(h, HessianMode::GaussNewton, LinearSolver::SparseLdlt)
            .map_err(str_err)?;
        let proj = FastProjection::new(1e-6, 100, KktSolver::SparseSchur).map_err(str_err)?;
        let mut step = ProjectedStep::new(imp, proj);
        Ok(particle_run("fast projection", sys, &cons, &mut step))
    }));
    s.runs.push(run("soft springs (implicit)", &|| {
        let (mut sys, _, links) = cloth()?;
        let set =
            ConstraintSet::uniform("structural", links, Softness::stiff(1e5)).map_err(str_err)?;
        sys.add_set(set).map_err(str_err)?;
        let mut step = ImplicitEuler::new(h, HessianMode::GaussNewton, LinearSolver::SparseLdlt)
            .map_err(str_err)?;
        let none = Constraints::new();
        Ok(particle_run(
            "soft springs (implicit)",
            sys,
            &none,
            &mut step,
        ))
    }));
    s.runs.push(run("compliant (velocity level)", &|| {
        let (sys, _, links) = cloth()?;
        let m = links.len();
        let mut cons = Constraints::new();
        cons.add(HardSet::compliant("structural", links, vec![1e-6; m]).map_err(str_err)?);
        let mut step =
            VelocityLevel::new(h, BaseStep::Explicit, KktSolver::SparseSchur).map_err(str_err)?;
        Ok(particle_run(
            "compliant (velocity level)",
            sys,
            &cons,
            &mut step,
        ))
    }));
    out.push(s);

    // The hard-volume jelly of `hard::jelly_hard_vs_soft`.
    let mut s = SceneStages::new(SCENES[5].name, SCENES[5]);
    s.runs.push(run("fast projection, tol 1e-7", &|| {
        let (sys, cons, _) = hard_volume_jelly(100.0).map_err(str_err)?;
        let imp = ImplicitEuler::new(h, HessianMode::Projected, LinearSolver::SparseLdlt)
            .map_err(str_err)?;
        let proj = FastProjection::new(1e-7, 30, KktSolver::SparseSchur).map_err(str_err)?;
        let mut step = ProjectedStep::new(imp, proj);
        Ok(particle_run(
            "fast projection, tol 1e-7",
            sys,
            &cons,
            &mut step,
        ))
    }));
    out.push(s);
}

fn str_err(e: impl ToString) -> String {
    e.to_string()
}

fn articulated_scenes(root: &Path, out: &mut Vec<SceneStages>) {
    let h = 1e-3;
    for name in articulated_report::scenes() {
        let mut s = SceneStages::new(format!("{name}.xml"), SCENES[6]);
        let path = root.join(format!("scenes/{name}.xml"));
        let scene = constraint_mjcf::load_file(&path)
            .map_err(|e| e.to_string())
            .and_then(|m| MjcfScene::new(&m, Some("start")).map_err(|e| e.to_string()));
        let world = match scene {
            Ok(sc) => sc.world,
            Err(e) => {
                s.failure = Some(e);
                out.push(s);
                continue;
            }
        };
        s.content = Some(world_content(&world));
        let mut methods: Vec<&'static str> = articulated_report::CHART_METHODS.to_vec();
        for m in articulated_report::DRIFT_METHODS {
            if name == "chain20" && !methods.contains(&m) {
                methods.push(m);
            }
        }
        for m in methods {
            match scene::method(m, h) {
                Ok(method) => s.runs.push(articulated_run(m, world.clone(), method, h)),
                Err(e) => s.failure = Some(e),
            }
        }
        out.push(s);
    }
    // The stability maps' ball chain (10 links), hard and with compliant joints.
    for (label, alpha) in [
        ("ball chain, 10 links", 0.0),
        ("ball chain, compliant joints", 1e-6),
    ] {
        let mut s = SceneStages::new(label, SCENES[7]);
        let world = constraint_articulated::scenes::ball_chain(10, 1.0).and_then(|mut w| {
            for j in 0..w.joints().len() {
                if alpha > 0.0 {
                    w.set_compliance(j, alpha)?;
                }
            }
            Ok(w)
        });
        match world {
            Ok(w) => {
                s.content = Some(world_content(&w));
                for (k, m) in articulated_stability::METHODS.iter().enumerate() {
                    let method = articulated_stability::method(k, h);
                    s.runs.push(articulated_run(m, w.clone(), method, h));
                }
            }
            Err(e) => s.failure = Some(e.to_string()),
        }
        out.push(s);
    }
}

fn contact_scenes(out: &mut Vec<SceneStages>) {
    let plan = contact_report::Plan::new(false);
    let h = contact_report::SETTLE_DT;
    for scene in contact_report::scenes(&plan) {
        let mut s = SceneStages::new(scene.name(), CONTACT_SCENES);
        if let Ok(w) = scene.world() {
            s.content = Some(format!(
                "{}, {} colliders",
                bodies(w.bodies().len()),
                w.colliders().len()
            ));
        }
        let contacts = contact_report::resting_contacts(scene).unwrap_or(usize::MAX);
        // One simulated second: the sphere lands within it.
        let steps = (1.0 / h).round() as usize;
        for cfg in &contact_report::SCENE_SOLVERS {
            if cfg.dense && contacts > contact_report::DENSE_CONTACT_LIMIT {
                continue;
            }
            match scene.world() {
                Ok(mut w) => {
                    w.settings.solver = cfg.solver;
                    w.settings.friction = cfg.friction;
                    w.settings.iterations = cfg.iterations;
                    s.runs.push(contact_run(cfg.name, w, h, steps));
                }
                Err(e) => s.failure = Some(e),
            }
        }
        out.push(s);
    }
}

/// Every scene of the report with its declaration and the stages its runs went through
/// (scenes read from `root/scenes/` where they are MJCF files). Takes a few seconds:
/// each run is a handful of steps (one simulated second for the contact scenes).
pub fn catalogue(root: &Path) -> Vec<SceneStages> {
    let mut out = Vec::new();
    soft_scenes(&mut out);
    lagrange_scenes(&mut out);
    articulated_scenes(root, &mut out);
    contact_scenes(&mut out);
    out
}

/// The cargo to run: `$CARGO` (set when run by cargo), else `cargo` on the `PATH`.
pub fn cargo() -> PathBuf {
    std::env::var_os("CARGO").map_or_else(|| PathBuf::from("cargo"), PathBuf::from)
}

/// `cargo tree -e normal -p <krate> --no-default-features [--features …]` on the
/// workspace at `root` (offline and locked: the tree of `Cargo.lock`).
///
/// # Errors
/// Cargo could not be started, or failed (its stderr's last line).
pub fn cargo_tree(root: &Path, krate: &str, features: &[&str]) -> Result<String, String> {
    let mut c = Command::new(cargo());
    c.current_dir(root)
        .args(["tree", "-e", "normal", "-p", krate, "--no-default-features"])
        .args(["--offline", "--locked", "--color", "never"]);
    if !features.is_empty() {
        c.args(["--features", &features.join(",")]);
    }
    let out = c
        .output()
        .map_err(|e| format!("cargo not runnable ({}): {e}", cargo().display()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(format!(
            "cargo tree failed: {}",
            err.lines().last().unwrap_or("").trim()
        ));
    }
    String::from_utf8(out.stdout).map_err(|e| e.to_string())
}

/// The distinct packages of a `cargo tree` listing (`name vX.Y.Z`), root first, then
/// sorted.
pub fn packages(tree: &str) -> Vec<String> {
    let mut v: Vec<String> = tree
        .lines()
        .filter_map(|l| {
            let t = l.trim_start_matches(|c: char| !c.is_alphanumeric());
            let mut w = t.split_whitespace();
            let name = w.next()?;
            let ver = w.next().filter(|v| v.starts_with('v'))?;
            Some(format!("{name} {ver}"))
        })
        .collect();
    let root = v.first().cloned();
    v.sort();
    v.dedup();
    if let Some(r) = root {
        v.retain(|p| *p != r);
        v.insert(0, r);
    }
    v
}

/// Whether the listing contains the package `name` (exact crate name).
pub fn has_package(tree: &str, name: &str) -> bool {
    packages(tree)
        .iter()
        .any(|p| p.split(' ').next() == Some(name))
}

/// `a, b` or `(none)`.
fn feature_list(features: &[&str]) -> String {
    if features.is_empty() {
        "(none)".into()
    } else {
        features.join(", ")
    }
}

/// Markdown-safe table cell: `|` escaped.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// The distinct dependency trees of `scenes`, in order of first use: crate, features,
/// the tree (or why it is missing), and the scenes using it.
type Trees = Vec<(
    &'static str,
    &'static [&'static str],
    Result<String, String>,
    Vec<String>,
)>;

fn trees(root: &Path, scenes: &[SceneStages]) -> Trees {
    let mut out: Trees = Vec::new();
    for s in scenes {
        let (k, f) = (s.decl.krate, s.decl.features);
        match out.iter_mut().find(|t| t.0 == k && t.1 == f) {
            Some(t) => t.3.push(s.scene.clone()),
            None => out.push((k, f, cargo_tree(root, k, f), vec![s.scene.clone()])),
        }
    }
    out
}

/// Scenes that share declaration and runs (same methods, same stages, no failure), as
/// one entry: each scene's name with its content, and the first of them.
fn merged(scenes: &[SceneStages]) -> Vec<(Vec<String>, &SceneStages)> {
    let label = |s: &SceneStages| match &s.content {
        Some(c) => format!("{} ({c})", s.scene),
        None => s.scene.clone(),
    };
    let mut out: Vec<(Vec<String>, &SceneStages)> = Vec::new();
    for s in scenes {
        let same = |t: &&SceneStages| {
            t.decl == s.decl && t.runs == s.runs && t.failure.is_none() && s.failure.is_none()
        };
        match out.iter_mut().find(|(_, t)| same(t)) {
            Some((names, _)) => names.push(label(s)),
            None => out.push((vec![label(s)], s)),
        }
    }
    out
}

/// Writes the section: per scene, its crate, features, dependency tree (by name) and
/// the stages each method's run went through (stages shared by every method first);
/// then each distinct dependency tree once.
pub fn section(md: &mut String, root: &Path) {
    let scenes = catalogue(root);
    let trees = trees(root, &scenes);
    let tree_of = |s: &SceneStages| {
        trees
            .iter()
            .position(|t| t.0 == s.decl.krate && t.1 == s.decl.features)
            .map_or((String::from("–"), String::from("–")), |i| {
                let count = trees[i].2.as_ref().map_or("–".into(), |t| {
                    packages(t).len().saturating_sub(1).to_string()
                });
                (format!("T{}", i + 1), count)
            })
    };
    let _ = writeln!(md, "\n## What each scene compiles and runs\n");
    let _ = writeln!(
        md,
        "Per scene of the report: the crate it is built with and the smallest feature set \
         it needs (on top of `--no-default-features`), its compiled (normal, non-dev) \
         dependency tree (named T1, T2, … and listed once below, from `cargo tree -e normal \
         -p <crate> --no-default-features --features <…> --offline --locked`; deps: distinct \
         packages, the crate itself not counted), and the run-time stages observed: each \
         scene is built and stepped a few times ({STEPS} steps; the contact scenes one \
         simulated second at 1/60 s) with every method the report uses on it, and the \
         report names the stages from what each library returns as data (its \
         configuration and its steps' statistics) — soft sets and integrator \
         (`SoftSystem::sets`, `Integrator::scheme`), hard sets, formulation and the KKT \
         solver used (`Constraints::sets`, `VelocityLevel::last_solver`, …), rigid bodies, \
         tree, loops, damping, compliance and method (`World::loop_joints`, \
         `World::compliances`, …), broad and narrow phase and the contact solver path \
         taken (`ContactWorld::last_path`). Where a scene \
         runs several methods, the first row (\"every method\") holds the stages they all \
         share and each method's row the rest; methods with identical stages share a row, \
         and scenes with identical runs share an entry. The test `report/tests/leave_out.rs` checks \
         that the spring-only build links none of `constraint-lagrange`, \
         `constraint-articulated`, `constraint-contact` or `faer`.\n"
    );
    let _ = writeln!(
        md,
        "| scene | crate | features | tree (deps) | method | stages |\n|---|---|---|---|---|---|"
    );
    for (names, s) in merged(&scenes) {
        let (tree, count) = tree_of(s);
        let head = format!(
            "| {} | `{}` | {} | {tree} ({count}) |",
            cell(&names.join("; ")),
            s.decl.krate,
            feature_list(s.decl.features)
        );
        if let Some(e) = &s.failure {
            let _ = writeln!(md, "{head} – | scene not built: {} |", cell(e));
            if s.runs.is_empty() {
                continue;
            }
        }
        let common = s.common();
        let mut first = true;
        let mut row = |method: &str, stages: &[String], failure: Option<&String>| {
            let mut text = stages.join(" · ");
            if let Some(f) = failure {
                let _ = write!(text, " — stopped: {f}");
            }
            let lead = if first { head.as_str() } else { "| | | | |" };
            first = false;
            let _ = writeln!(md, "{lead} {} | {} |", cell(method), cell(&text));
        };
        if !common.is_empty() {
            row("every method", &common, None);
        }
        for (methods, r) in s.groups() {
            let own: Vec<String> = r
                .stages
                .iter()
                .filter(|st| !common.contains(st))
                .cloned()
                .collect();
            row(&methods.join(", "), &own, r.failure.as_ref());
        }
    }
    let _ = writeln!(md, "\nWhere the scenes are used:\n");
    let mut seen: Vec<&str> = Vec::new();
    for s in &scenes {
        if !seen.contains(&s.decl.name) {
            seen.push(s.decl.name);
            let _ = writeln!(md, "* {}: {}", s.decl.name, s.decl.used_in);
        }
    }
    let _ = writeln!(md, "\n### Dependency trees\n");
    for (i, (krate, features, tree, users)) in trees.iter().enumerate() {
        let _ = writeln!(
            md,
            "#### T{} — `{krate}`, features: {} — {}\n",
            i + 1,
            feature_list(features),
            users.join(", ")
        );
        match tree {
            Ok(t) => {
                let _ = writeln!(md, "```text\n{t}```\n");
            }
            Err(e) => {
                let _ = writeln!(md, "Dependency tree skipped: {e}.\n");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TREE: &str = "constraint-soft v0.1.0 (/w/soft)\n├── constraint-core v0.1.0 (/w/core)\n│   └── glam v0.34.3\n│       └── libm v0.2.16\n└── nalgebra v0.35.0\n    ├── approx v0.5.1\n    │   └── num-traits v0.2.19\n    └── num-traits v0.2.19 (*)\n";

    #[test]
    fn packages_are_distinct_with_the_root_first() {
        let p = packages(TREE);
        assert_eq!(p[0], "constraint-soft v0.1.0");
        assert_eq!(p.len(), 7);
        assert!(has_package(TREE, "libm"));
        assert!(!has_package(TREE, "faer"));
        assert!(!has_package(TREE, "constraint"));
    }

    #[test]
    fn common_stages_are_those_every_run_shares() {
        let run = |m: &str, st: &[&str]| Run {
            method: m.into(),
            stages: st.iter().map(|s| s.to_string()).collect(),
            failure: None,
        };
        let mut s = SceneStages::new("x", SCENES[0]);
        s.runs.push(run("a", &["gravity", "springs", "CG"]));
        assert!(s.common().is_empty());
        s.runs.push(run("b", &["LDLT", "springs", "gravity"]));
        assert_eq!(s.common(), ["gravity", "springs"]);
    }

    /// The observed stages differ where the scenes do: loops only on the four-bar,
    /// compliance only on the compliant chain, LDLᵀ only where a method uses it, the
    /// contact solver path as the scene's size makes `Auto` choose.
    #[test]
    fn the_catalogue_observes_what_each_scene_runs() {
        let scenes = catalogue(&articulated_report::root());
        let find = |name: &str| {
            scenes
                .iter()
                .find(|s| s.scene == name)
                .unwrap_or_else(|| panic!("{name} missing"))
        };
        let has = |s: &SceneStages, needle: &str| {
            s.runs
                .iter()
                .any(|r| r.stages.iter().any(|st| st.contains(needle)))
        };
        for s in &scenes {
            assert!(s.failure.is_none(), "{}: {:?}", s.scene, s.failure);
            assert!(!s.runs.is_empty(), "{}", s.scene);
        }
        let loop_stage = "loop closure";
        assert!(has(find("four_bar.xml"), loop_stage));
        assert!(!has(find("chain20.xml"), loop_stage));
        assert!(has(
            find("ball chain, compliant joints"),
            "compliant joints"
        ));
        assert!(!has(find("ball chain, 10 links"), "compliant joints"));
        let bob = find("spring-only bob");
        assert!(!has(bob, "LDLᵀ") && has(bob, "block-Jacobi CG"));
        assert!(has(find("cloth 10×10"), "areas: "));
        assert!(has(find("jelly"), "Volume"));
        assert!(has(find("particle chain"), "hard links: 5 × Distance"));
        assert!(has(find("hard-volume jelly"), "one-ring volume"));
        assert!(has(
            find("inextensible cloth 10×10"),
            "compliant structural"
        ));
        let drop = find("sphere drop");
        assert!(has(drop, "narrow phase: sphere–plane") && !has(drop, "box–box"));
        assert!(has(find("stack of 10"), "narrow phase: box–box"));
        let md = {
            let mut md = String::new();
            section(&mut md, &articulated_report::root());
            md
        };
        assert!(
            md.contains("| four_bar.xml (3 bodies, 3 hinge, 1 spherical) |"),
            "{md}"
        );
        // Each distinct crate + feature set is listed once.
        assert_eq!(md.matches("#### T").count(), 7, "{md}");
        if std::env::var_os("DEPS_SECTION_OUT").is_some() {
            eprintln!("{md}");
        }
    }
}
