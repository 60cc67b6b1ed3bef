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

/// What `simulate --summary FILE.json` writes (see `constraint_verify::scene::Summary`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    pub steps: u64,
    pub us_per_step: Option<f64>,
    pub finite: bool,
    pub max_joint_separation: f64,
    pub max_penetration: f64,
    pub settled_penetration: f64,
    pub energy_initial: f64,
    pub max_energy_increase: f64,
    pub max_contacts: usize,
    /// Time of the first state with a contact (s).
    pub first_contact_time: Option<f64>,
    /// Height of the first body's origin at the end (m).
    pub root_height: Option<f64>,
    pub actuators: usize,
    pub colliders: usize,
}

/// Parses the flat JSON object of `simulate --summary` (numbers, booleans, `null`).
/// Errors name the missing or malformed key.
pub fn parse_summary(text: &str) -> Result<Summary, String> {
    let body = text
        .trim()
        .strip_prefix('{')
        .and_then(|s| s.strip_suffix('}'))
        .ok_or("summary: not a JSON object")?;
    let mut fields = Vec::new();
    for kv in body.split(',').filter(|s| !s.trim().is_empty()) {
        let (k, v) = kv
            .split_once(':')
            .ok_or(format!("summary: {kv:?} is not key:value"))?;
        fields.push((k.trim().trim_matches('"').to_string(), v.trim().to_string()));
    }
    let get = |k: &str| {
        fields
            .iter()
            .find(|(n, _)| n == k)
            .map(|(_, v)| v.as_str())
            .ok_or(format!("summary: no {k:?}"))
    };
    let num = |k: &str| -> Result<Option<f64>, String> {
        match get(k)? {
            "null" => Ok(None),
            v => v
                .parse::<f64>()
                .map(Some)
                .map_err(|_| format!("summary: {k}: {v:?} is not a number")),
        }
    };
    // A non-finite figure (`null`) makes the check fail: it becomes infinity.
    let fig = |k: &str| num(k).map(|v| v.unwrap_or(f64::INFINITY));
    let count = |k: &str| {
        get(k)?
            .parse::<u64>()
            .map_err(|_| format!("summary: {k}: not a count"))
    };
    Ok(Summary {
        steps: count("steps")?,
        us_per_step: num("us_per_step")?,
        finite: match get("finite")? {
            "true" => true,
            "false" => false,
            v => return Err(format!("summary: finite: {v:?} is not a boolean")),
        },
        max_joint_separation: fig("max_joint_separation")?,
        max_penetration: fig("max_penetration")?,
        settled_penetration: fig("settled_penetration")?,
        energy_initial: fig("energy_initial")?,
        max_energy_increase: fig("max_energy_increase")?,
        max_contacts: count("max_contacts")? as usize,
        // Optional keys (a summary of an older binary has neither).
        first_contact_time: num("first_contact_time").unwrap_or(None),
        root_height: num("root_height").unwrap_or(None),
        actuators: count("actuators")? as usize,
        colliders: count("colliders")? as usize,
    })
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
            ("[]", "not a JSON object"),
            ("{\"steps\":1}", "no \"us_per_step\""),
            ("{\"steps\":x}", "not a count"),
        ] {
            let e = parse_summary(bad).unwrap_err();
            assert!(e.contains(want), "{bad}: {e}");
        }
        let e = parse_summary(&JSON.replace("true", "yes")).unwrap_err();
        assert!(e.contains("not a boolean"), "{e}");
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
