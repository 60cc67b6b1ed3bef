//! The MJCF scenes of `scenes/*.xml` with this library, for the comparison with MuJoCo
//! (`benches/mjcf_scenes.rs`; `cargo xtask bench` runs MuJoCo on the same files).
//!
//! A scene whose geoms collide (contact not disabled, some geom with a non-zero
//! `contype` or `conaffinity`) is loaded into a [`ContactWorld`] through
//! [`MjcfContactScene`] and stepped with the contact crate's defaults
//! (`ContactSolver::Auto`); any other into an articulated [`World`] through
//! [`MjcfScene`], stepped with [`VELOCITY`] (the velocity level, first order like
//! MuJoCo's semi-implicit Euler) and with [`Method::default`] (RATTLE, second order).
//! (`cargo xtask simulate` runs every file in the one world and takes the contact world
//! only by name, `--method free-contact` or `soft-step`; this bench times the contact
//! crate's own world on the free-body files, as its peers comparison did.) Every scene
//! starts from its keyframe `start` when it has one, else from the default pose at rest
//! (MuJoCo does the same), and runs at the file's `option timestep`.
//!
//! [`Engine::validate`] runs a scene's timed window once, untimed, and reports whether
//! every step succeeded; the bench times only the windows that do.

use std::path::{Path, PathBuf};

use constraint_articulated::mjcf_contact::MjcfContactScene;
use constraint_articulated::{Method, MjcfScene, World};
use constraint_contact::rigid::ContactWorld;

/// The velocity-level step (`β = 1`).
pub const VELOCITY: Method = Method::Velocity { beta: 1.0 };

/// The scenes of the comparison, file stems in `scenes/` (`constraint_scene::catalogue`):
/// the joint-only ones (MuJoCo RK4 references in `scenes/reference/`), then the free-body
/// contact ones.
pub fn scenes() -> impl Iterator<Item = &'static str> {
    use constraint_scene::catalogue::{family, Family};
    family(Family::Joints).chain(family(Family::FreeBodyContact))
}

/// Simulated seconds of the timed window: every engine steps the first second from the
/// initial state, and the time per step is the mean over that window (the contact
/// scenes' cost depends on the state: free flight, impact, rest).
pub const WINDOW: f64 = 1.0;

/// `scenes/<name>.xml` of the workspace.
pub fn scene_path(name: &str) -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    here.parent()
        .unwrap_or(here)
        .join("scenes")
        .join(format!("{name}.xml"))
}

/// Which of this library's worlds runs a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Joints, no contact: [`MjcfScene`].
    Articulated,
    /// Free bodies with collision geoms: [`MjcfContactScene`].
    Contact,
}

impl Kind {
    /// `articulated` or `contact`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Articulated => "articulated",
            Kind::Contact => "contact",
        }
    }
}

/// A loaded scene at its initial state (boxed: the worlds differ in size).
#[derive(Clone, Debug)]
pub enum Loaded {
    Articulated(Box<World>),
    Contact(Box<ContactWorld>),
}

/// A scene file, loaded.
#[derive(Clone, Debug)]
pub struct Scene {
    /// File stem (`pendulum`).
    pub name: String,
    /// The file.
    pub path: PathBuf,
    /// Keyframe used (`start` when the file has one).
    pub keyframe: Option<String>,
    /// `option timestep` (s).
    pub dt: f64,
    /// Bodies (world excluded).
    pub bodies: usize,
    /// The world at the initial state.
    pub start: Loaded,
}

impl Scene {
    /// Loads `scenes/<name>.xml`.
    pub fn load(name: &str) -> Result<Scene, String> {
        Scene::load_file(name, &scene_path(name))
    }

    /// Loads `path`, calling the scene `name`.
    pub fn load_file(name: &str, path: &Path) -> Result<Scene, String> {
        let model =
            constraint_mjcf::load_file(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let keyframe = model
            .keyframes
            .iter()
            .any(|k| k.name == "start")
            .then(|| "start".to_string());
        let collides = !model.contact_disabled
            && model
                .geoms
                .iter()
                .any(|g| g.contype != 0 || g.conaffinity != 0);
        let (start, dt) = if collides {
            let s = MjcfContactScene::new(&model, keyframe.as_deref())
                .map_err(|e| format!("{name}: {e}"))?;
            (Loaded::Contact(Box::new(s.world)), s.timestep)
        } else {
            let s =
                MjcfScene::new(&model, keyframe.as_deref()).map_err(|e| format!("{name}: {e}"))?;
            (Loaded::Articulated(Box::new(s.world)), s.timestep)
        };
        Ok(Scene {
            name: name.to_string(),
            path: path.to_path_buf(),
            keyframe,
            dt,
            bodies: model.bodies.len(),
            start,
        })
    }

    /// Articulated or contact.
    pub fn kind(&self) -> Kind {
        match self.start {
            Loaded::Articulated(_) => Kind::Articulated,
            Loaded::Contact(_) => Kind::Contact,
        }
    }

    /// Steps of `dt` in [`WINDOW`].
    pub fn steps(&self) -> usize {
        (WINDOW / self.dt).round() as usize
    }

    /// The engines of this library that run the scene.
    pub fn engines(&self) -> Vec<Engine> {
        match self.kind() {
            Kind::Articulated => vec![Engine::Velocity, Engine::Rattle],
            Kind::Contact => vec![Engine::ContactAuto],
        }
    }
}

/// One of this library's step methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// Articulated, [`VELOCITY`].
    Velocity,
    /// Articulated, [`Method::default`] (RATTLE, 1e-12 m, 30 iterations).
    Rattle,
    /// Contact world, default settings (`ContactSolver::Auto`).
    ContactAuto,
}

/// What the untimed run of a window found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Validation {
    /// Steps that succeeded.
    pub steps: usize,
    /// Simulated time (s) of the step that failed, and its error.
    pub failed: Option<(f64, String)>,
    /// RATTLE steps redone at the velocity level ([`constraint_articulated::StepStats`]).
    pub fallbacks: usize,
    /// Largest joint separation at the end (m), articulated scenes.
    pub separation: Option<f64>,
    /// Most contact points in a step, contact scenes.
    pub contacts: Option<usize>,
}

impl Engine {
    /// Benchmark id: `ours_velocity`, `ours_rattle`, `ours_auto`.
    pub fn id(self) -> &'static str {
        match self {
            Engine::Velocity => "ours_velocity",
            Engine::Rattle => "ours_rattle",
            Engine::ContactAuto => "ours_auto",
        }
    }

    fn method(self) -> Method {
        match self {
            Engine::Rattle => Method::default(),
            _ => VELOCITY,
        }
    }

    /// Steps `world` `steps` times at `dt` (the timed loop: no bookkeeping). The result is
    /// only for [`std::hint::black_box`]; a failed step is an error.
    pub fn run(self, world: &mut Loaded, dt: f64, steps: usize) -> Result<usize, String> {
        let mut acc = 0;
        match world {
            Loaded::Articulated(w) => {
                let m = self.method();
                for _ in 0..steps {
                    acc += w
                        .step(dt, m)
                        .map_err(|e| e.to_string())?
                        .projection_iterations;
                }
            }
            Loaded::Contact(w) => {
                for _ in 0..steps {
                    acc += w.step(dt).map_err(|e| e.to_string())?.contacts;
                }
            }
        }
        Ok(acc)
    }

    /// Runs the window of `scene` once from its start, recording failures and statistics.
    pub fn validate(self, scene: &Scene) -> Validation {
        let mut v = Validation::default();
        let (dt, steps) = (scene.dt, scene.steps());
        match scene.start.clone() {
            Loaded::Articulated(mut w) => {
                let m = self.method();
                for k in 0..steps {
                    match w.step(dt, m) {
                        Ok(s) => v.fallbacks += s.fallbacks,
                        Err(e) => {
                            v.failed = Some(((k + 1) as f64 * dt, e.to_string()));
                            return v;
                        }
                    }
                    v.steps += 1;
                }
                v.separation = Some(w.max_separation());
            }
            Loaded::Contact(mut w) => {
                let mut most = 0;
                for k in 0..steps {
                    match w.step(dt) {
                        Ok(s) => most = most.max(s.contacts),
                        Err(e) => {
                            v.failed = Some(((k + 1) as f64 * dt, e.to_string()));
                            return v;
                        }
                    }
                    v.steps += 1;
                }
                v.contacts = Some(most);
            }
        }
        v
    }
}

/// Header of `target/peers/mjcf_scenes.tsv` (one line per scene and engine).
pub const TSV_HEADER: &str =
    "scene\tkind\tengine\tbodies\tdt\tsteps\tkeyframe\tstatus\tfallbacks\tseparation\tcontacts";

/// One line of `target/peers/mjcf_scenes.tsv`: `status` is `ok` or `failed at t = …: …`.
pub fn tsv_line(scene: &Scene, engine: Engine, v: &Validation) -> String {
    let status = match &v.failed {
        None => "ok".to_string(),
        Some((t, e)) => format!("failed at t = {t:.4} s: {}", e.replace(['\t', '\n'], " ")),
    };
    format!(
        "{}\t{}\t{}\t{}\t{:e}\t{}\t{}\t{status}\t{}\t{}\t{}",
        scene.name,
        scene.kind().name(),
        engine.id(),
        scene.bodies,
        scene.dt,
        scene.steps(),
        scene.keyframe.as_deref().unwrap_or("-"),
        v.fallbacks,
        v.separation.map_or("-".into(), |s| format!("{s:e}")),
        v.contacts.map_or("-".into(), |c| c.to_string()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scene_loads_with_its_kind_and_a_whole_window() {
        for name in scenes() {
            let s = Scene::load(name).unwrap_or_else(|e| panic!("{e}"));
            let contact = matches!(name, "sphere_drop" | "sliding_box" | "box_stack");
            assert_eq!(s.kind() == Kind::Contact, contact, "{name}");
            assert_eq!(s.keyframe.is_some(), name != "box_stack", "{name}");
            assert!((s.steps() as f64 * s.dt - WINDOW).abs() < 1e-9, "{name}");
            assert_eq!(s.engines().len(), if contact { 1 } else { 2 });
        }
    }

    #[test]
    fn a_short_window_validates_and_writes_a_line() {
        let s = Scene::load("pendulum").unwrap();
        let mut short = s.clone();
        short.dt = 0.25;
        let v = Engine::Rattle.validate(&short);
        assert_eq!(v.steps, 4);
        assert!(v.failed.is_none());
        assert!(v.separation.unwrap() < 1e-9);
        let line = tsv_line(&short, Engine::Rattle, &v);
        assert!(
            line.starts_with("pendulum\tarticulated\tours_rattle\t1\t2.5e-1\t4\tstart\tok\t"),
            "{line}"
        );
        assert_eq!(line.split('\t').count(), TSV_HEADER.split('\t').count());
        let d = Scene::load("sphere_drop").unwrap();
        let mut w = d.start.clone();
        assert!(Engine::ContactAuto.run(&mut w, d.dt, 10).is_ok());
    }
}
