//! The catalogue of the scene files in `scenes/`: one list, with each file's family and
//! whether MuJoCo's reference trajectory is committed beside it
//! (`scenes/reference/<name>.csv`), from which the tests, the report and the benchmarks
//! take the scenes they need (instead of each keeping its own list of names).

use std::path::{Path, PathBuf};

/// What a scene file exercises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Joint-only chains and loops, smooth (no contact, no limits hit): the lecture's
    /// hard-constraint formulations compared with MuJoCo's RK4.
    Joints,
    /// The one world's smooth scenes: compound joints, passive terms, actuators, fluid
    /// drag, equality rows.
    OneWorld,
    /// Free bodies on the ground only (the contact crate's scenes in MJCF).
    FreeBodyContact,
    /// Joints and contact, or limits and tendon ranges, in the same step.
    JointsAndContact,
}

/// One file of `scenes/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneFile {
    /// File stem: `scenes/<name>.xml`.
    pub name: &'static str,
    /// What it exercises.
    pub family: Family,
    /// Whether `scenes/reference/<name>.csv` (MuJoCo RK4) is committed.
    pub reference: bool,
    /// Whether the report charts its error against run time next to MuJoCo's.
    pub charted: bool,
}

const fn file(name: &'static str, family: Family, reference: bool) -> SceneFile {
    SceneFile {
        name,
        family,
        reference,
        charted: false,
    }
}

const fn charted(name: &'static str, family: Family) -> SceneFile {
    SceneFile {
        name,
        family,
        reference: true,
        charted: true,
    }
}

/// Every file of `scenes/`, families in this order, and within a family in the order
/// the report shows them.
pub const CATALOGUE: [SceneFile; 20] = [
    charted("pendulum", Family::Joints),
    charted("double_pendulum", Family::Joints),
    charted("spherical_pendulum", Family::Joints),
    charted("four_bar", Family::Joints),
    charted("chain20", Family::Joints),
    charted("chain20_heavy", Family::Joints),
    charted("chain100", Family::Joints),
    charted("planar_leg", Family::OneWorld),
    charted("two_hinge_pendulum", Family::OneWorld),
    charted("pendulum_damped", Family::OneWorld),
    charted("actuated", Family::OneWorld),
    charted("fluid_drag", Family::OneWorld),
    file("coupled_pendulums", Family::OneWorld, true),
    file("offset_universal", Family::OneWorld, true),
    file("sphere_drop", Family::FreeBodyContact, false),
    file("sliding_box", Family::FreeBodyContact, false),
    file("box_stack", Family::FreeBodyContact, false),
    file("chain20_floor", Family::JointsAndContact, false),
    file("ragdoll", Family::JointsAndContact, false),
    file("tendon_range", Family::JointsAndContact, false),
];

/// The names of one family, in catalogue order.
pub fn family(f: Family) -> impl Iterator<Item = &'static str> {
    CATALOGUE
        .iter()
        .filter(move |s| s.family == f)
        .map(|s| s.name)
}

/// The scenes the report charts against MuJoCo, in catalogue order.
pub fn charted_scenes() -> impl Iterator<Item = &'static str> {
    CATALOGUE.iter().filter(|s| s.charted).map(|s| s.name)
}

/// The entry named `name`, if the catalogue has it.
pub fn find(name: &str) -> Option<&'static SceneFile> {
    CATALOGUE.iter().find(|s| s.name == name)
}

/// `scenes/` of this workspace (the crate is one folder below the root).
pub fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

/// `scenes/<name>.xml` of this workspace.
pub fn path(name: &str) -> PathBuf {
    scenes_dir().join(format!("{name}.xml"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The catalogue and the folder agree both ways, and the reference flags match the
    /// committed files: a new scene file cannot be left out of the list.
    #[test]
    fn the_catalogue_is_the_folder() {
        let mut on_disk: Vec<String> = std::fs::read_dir(scenes_dir())
            .unwrap()
            .filter_map(|e| {
                let p = e.ok()?.path();
                (p.extension()? == "xml").then(|| p.file_stem()?.to_str().map(String::from))?
            })
            .collect();
        on_disk.sort();
        let mut listed: Vec<String> = CATALOGUE.iter().map(|s| s.name.to_string()).collect();
        listed.sort();
        assert_eq!(listed, on_disk);
        for s in CATALOGUE {
            let r = scenes_dir()
                .join(format!("reference/{}.csv", s.name))
                .exists();
            assert_eq!(r, s.reference, "{}: reference flag", s.name);
        }
        assert_eq!(family(Family::Joints).count(), 7);
        assert_eq!(charted_scenes().count(), 12);
        assert_eq!(
            find("ragdoll").map(|s| s.family),
            Some(Family::JointsAndContact)
        );
        assert!(find("nope").is_none());
    }
}
