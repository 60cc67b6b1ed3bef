//! The per-model checks of `cargo xtask models run`: what our `simulate --summary` writes
//! ([`Summary`]), the tolerances each figure is held to ([`checks`]), which outcomes are
//! regressions that fail the run ([`fatal`]), and the smooth-model trajectory error
//! against MuJoCo ([`smooth_error`]).

use crate::compare::{compare, Trajectory};
use std::path::Path;

/// Worst joint separation allowed at any step (m): the projections hold joints to
/// 1e-12 m; this leaves room for the velocity-level fallback.
pub const JOINT_TOL: f64 = 1e-6;
/// Deepest penetration allowed over the second half of a run (m): the contact slop is
/// 1e-4 m; an initial overlap must have been pushed out by then.
pub const PENETRATION_TOL: f64 = 1e-3;
/// Energy may grow by at most this times `1 + |E(0)|` on a run without control and
/// without contact (RATTLE's energy error oscillates, bounded; damping only removes).
pub const ENERGY_REL_TOL: f64 = 1e-4;

/// What `simulate --summary FILE.json` writes (see `constraint_scene::run::Summary`),
/// the fields the checks read. Every key is required but those an older binary did
/// not write (`first_contact_time`, `root_height`, `unconverged_steps`,
/// `worst_unconverged_residual`); other keys are ignored.
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize)]
pub struct Summary {
    pub steps: u64,
    /// `null` when no step was taken.
    #[serde(deserialize_with = "nullable")]
    pub us_per_step: Option<f64>,
    pub finite: bool,
    #[serde(deserialize_with = "figure")]
    pub max_joint_separation: f64,
    #[serde(deserialize_with = "figure")]
    pub max_penetration: f64,
    #[serde(deserialize_with = "figure")]
    pub settled_penetration: f64,
    #[serde(deserialize_with = "figure")]
    pub energy_initial: f64,
    #[serde(deserialize_with = "figure")]
    pub max_energy_increase: f64,
    pub max_contacts: usize,
    /// Time of the first state with a contact (s).
    #[serde(default)]
    pub first_contact_time: Option<f64>,
    /// Height of the first body's origin at the end (m).
    #[serde(default)]
    pub root_height: Option<f64>,
    /// Steps whose one-sided rows went to the dense path and ended above its tolerance
    /// (the staggered alternations reached their cap or stalled: the answer was kept,
    /// flagged). Reported, not checked: the penetration and energy checks judge it.
    #[serde(default)]
    pub unconverged_steps: Option<u64>,
    /// The largest residual of those steps (0 when none).
    #[serde(default)]
    pub worst_unconverged_residual: Option<f64>,
    pub actuators: usize,
    pub colliders: usize,
}

/// A required number that may be `null` (serde_json writes a non-finite `f64` so).
fn nullable<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    <Option<f64> as serde::Deserialize>::deserialize(d)
}

/// A figure a check holds to a tolerance: `null` (non-finite) becomes infinity, so the
/// check fails.
fn figure<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    nullable(d).map(|v| v.unwrap_or(f64::INFINITY))
}

/// Parses the flat JSON object of `simulate --summary` (numbers, booleans, `null`).
/// Errors name the missing or malformed key.
pub fn parse_summary(text: &str) -> Result<Summary, String> {
    serde_json::from_str(text).map_err(|e| format!("summary: {e}"))
}

/// Whether the energy check applies to a case: no control (`passive`, `perturbed`) and
/// no contact during our run (a hard contact that pushes an overlap out adds energy).
pub fn energy_checked(case: &str, s: &Summary) -> bool {
    case != "controlled" && s.max_contacts == 0
}

/// The checks a finished case fails, one short line each (empty: all pass): finite
/// state, joint separation, settled penetration, energy growth (see [`energy_checked`]).
pub fn checks(case: &str, s: &Summary) -> Vec<String> {
    let mut out = Vec::new();
    if !s.finite {
        out.push("non-finite state".to_string());
    }
    if !(s.max_joint_separation <= JOINT_TOL) {
        out.push(format!(
            "joints {:.1e} m > {JOINT_TOL:.0e}",
            s.max_joint_separation
        ));
    }
    if !(s.settled_penetration <= PENETRATION_TOL) {
        out.push(format!(
            "penetration {:.1e} m > {PENETRATION_TOL:.0e}",
            s.settled_penetration
        ));
    }
    let allowed = ENERGY_REL_TOL * (1.0 + s.energy_initial.abs());
    if energy_checked(case, s) && !(s.max_energy_increase <= allowed) {
        out.push(format!(
            "energy +{:.1e} J > {allowed:.1e}",
            s.max_energy_increase
        ));
    }
    out
}

/// A regression that fails the run (CI): a panic (loading or stepping: library code must
/// not panic on any file), or a model that loads and then ends in a non-finite state or
/// stops with a divergence error. A file that does not load with a typed reason, or a
/// typed error of another kind, is a table entry, not a failure.
pub fn fatal(loads: bool, panicked: bool, error: Option<&str>, summary: Option<&Summary>) -> bool {
    panicked
        || (loads
            && (summary.is_some_and(|s| !s.finite)
                || error.is_some_and(|e| e.contains("diverged") || e.contains("non-finite"))))
}

/// The largest centre-of-mass error (m) of `a` against `reference` over their common
/// samples (`cargo xtask compare`'s figure), with the number of samples matched.
pub fn smooth_error(a: &Path, reference: &Path) -> Result<(f64, usize), String> {
    let a = Trajectory::read(a)?;
    let r = Trajectory::read(reference)?;
    let rep = compare(&a, &r)?;
    if rep.matched == 0 {
        return Err("no common samples".into());
    }
    Ok((rep.com.value, rep.matched))
}

#[cfg(test)]
mod tests {
    use super::*;

    const JSON: &str = "{\"steps\":400,\"dt\":0.0025,\"seconds_stepping\":0.0155,\
        \"us_per_step\":38.9,\"finite\":true,\"max_joint_separation\":1.1e-16,\
        \"max_penetration\":8.8e-12,\"settled_penetration\":8.8e-12,\"energy_initial\":216.2,\
        \"max_energy_increase\":0.0,\"energy_final\":216.2,\"max_contacts\":6,\
        \"first_contact_time\":0.0125,\"root_height\":1.3,\"actuators\":6,\"colliders\":8}\n";

    #[test]
    fn unconverged_dense_steps_are_read_when_written() {
        // An older binary's summary has neither key: both are None.
        let old = parse_summary(JSON).unwrap();
        assert_eq!(old.unconverged_steps, None);
        assert_eq!(old.worst_unconverged_residual, None);
        let new = JSON.replace(
            "\"colliders\":8}",
            "\"colliders\":8,\"unconverged_steps\":565,\"worst_unconverged_residual\":7.2e-3}",
        );
        let s = parse_summary(&new).unwrap();
        assert_eq!(s.unconverged_steps, Some(565));
        assert_eq!(s.worst_unconverged_residual, Some(7.2e-3));
        // Reported, not checked: the same figures with a clean run's checks pass.
        assert!(
            checks("passive", &s).is_empty(),
            "{:?}",
            checks("passive", &s)
        );
    }

    #[test]
    fn the_summary_of_simulate_is_read_by_key() {
        let s = parse_summary(JSON).unwrap();
        assert_eq!(s.steps, 400);
        assert_eq!(s.us_per_step, Some(38.9));
        assert!(s.finite);
        assert_eq!((s.max_contacts, s.actuators, s.colliders), (6, 6, 8));
        assert_eq!(s.settled_penetration, 8.8e-12);
        assert_eq!(
            (s.first_contact_time, s.root_height),
            (Some(0.0125), Some(1.3))
        );
        let none = JSON.replace("0.0125", "null");
        assert_eq!(parse_summary(&none).unwrap().first_contact_time, None);
        // null (a non-finite figure) fails its check.
        let n = JSON.replace(
            "\"max_joint_separation\":1.1e-16",
            "\"max_joint_separation\":null",
        );
        let s = parse_summary(&n).unwrap();
        assert_eq!(s.max_joint_separation, f64::INFINITY);
        assert_eq!(checks("passive", &s).len(), 1);
        for (bad, want) in [
            ("[]", "expected struct Summary"),
            ("{\"steps\":1}", "missing field `us_per_step`"),
            (
                "{\"steps\":1.5}",
                "invalid type: floating point `1.5`, expected u64",
            ),
            ("{\"steps\":x}", "expected value"),
        ] {
            let e = parse_summary(bad).unwrap_err();
            assert!(e.contains(want), "{bad}: {e}");
        }
        let e = parse_summary(&JSON.replace("true", "\"yes\"")).unwrap_err();
        assert!(e.contains("expected a boolean"), "{e}");
        // Numbers are read exactly (serde_json's `float_roundtrip`): without it these
        // two, from real summaries, came out one ulp off.
        let exact = JSON
            .replace("1.1e-16", "9.962517892747503e-13")
            .replace("216.2,\"max", "11.281500000000001,\"max");
        let s = parse_summary(&exact).unwrap();
        assert_eq!(
            s.max_joint_separation,
            "9.962517892747503e-13".parse::<f64>().unwrap()
        );
        assert_eq!(
            s.energy_initial,
            "11.281500000000001".parse::<f64>().unwrap()
        );
        // An older binary's summary, without the two later keys.
        let old = JSON.replace(",\"first_contact_time\":0.0125,\"root_height\":1.3", "");
        let s = parse_summary(&old).unwrap();
        assert_eq!((s.first_contact_time, s.root_height), (None, None));
    }

    #[test]
    fn each_check_fails_just_past_its_tolerance() {
        let ok = parse_summary(JSON).unwrap();
        assert!(checks("passive", &ok).is_empty());
        let mut s = ok.clone();
        s.max_joint_separation = 2.0 * JOINT_TOL;
        assert!(checks("passive", &s)[0].starts_with("joints"));
        let mut s = ok.clone();
        s.settled_penetration = 2.0 * PENETRATION_TOL;
        assert!(checks("passive", &s)[0].starts_with("penetration"));
        let mut s = ok.clone();
        s.finite = false;
        assert_eq!(checks("passive", &s), ["non-finite state"]);
        // Energy: only without contact and without control.
        let mut s = ok.clone();
        s.max_energy_increase = 1.0;
        assert!(checks("passive", &s).is_empty(), "6 contacts: not checked");
        s.max_contacts = 0;
        assert!(checks("passive", &s)[0].starts_with("energy"));
        assert!(checks("perturbed", &s)[0].starts_with("energy"));
        assert!(checks("controlled", &s).is_empty());
        // Within: 1e-4 (1 + 216.2) = 2.2e-2 J.
        s.max_energy_increase = 0.02;
        assert!(checks("passive", &s).is_empty());
    }

    #[test]
    fn a_panic_or_a_loaded_model_that_diverges_is_fatal() {
        let ok = parse_summary(JSON).unwrap();
        let mut bad = ok.clone();
        bad.finite = false;
        assert!(!fatal(
            false,
            false,
            Some("scene: line 3: unsupported"),
            None
        ));
        assert!(!fatal(true, false, None, Some(&ok)));
        assert!(!fatal(
            true,
            false,
            Some("stopped after 30 s (time limit)"),
            None
        ));
        assert!(fatal(true, true, Some("panicked"), None));
        assert!(
            fatal(false, true, Some("panicked at mjcf/src/x.rs"), None),
            "a loader panic"
        );
        assert!(
            !fatal(false, false, Some("step 1 diverged"), None),
            "never loaded"
        );
        assert!(fatal(true, false, None, Some(&bad)));
        assert!(fatal(
            true,
            false,
            Some("step 12 diverged (body 3 non-finite or beyond 1e12)"),
            None
        ));
    }
}
