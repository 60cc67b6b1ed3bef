//! `cargo xtask compare A.csv B.csv [--tolerance TOL] [--format table|keys]`: trajectory
//! error between two files of one scene (DESIGN.md sections 6 and 7).
//!
//! The work is done by the `compare` binary of `constraint-scene` (release build on
//! first use, as `simulate`), so one trajectory reader and one comparer remain:
//! `constraint_scene::trajectory`. xtask's own checks (`verify --mujoco`, `models run`)
//! call [`compare`], which runs that binary with `--format keys` and reads its `key
//! value` lines into a [`Report`]; xtask keeps no physics or CSV code of its own and
//! builds in seconds.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::run::root;

/// `cargo run --release` of a `constraint-scene` binary (`simulate`, `compare`), ready
/// for its arguments.
pub fn scene_bin(name: &str) -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.args(["run", "--release", "--quiet", "--manifest-path"])
        .arg(root().join("Cargo.toml"))
        .args(["-p", "constraint-scene", "--bin", name, "--"]);
    c
}

/// A trajectory file, read and compared by the `compare` binary.
#[derive(Clone, Debug)]
pub struct Trajectory {
    path: PathBuf,
}

impl Trajectory {
    /// The file at `path`; errors when there is no such file (its contents are checked
    /// when compared).
    pub fn read(path: &Path) -> Result<Trajectory, String> {
        if path.is_file() {
            Ok(Trajectory {
                path: path.to_path_buf(),
            })
        } else {
            Err(format!("{}: no such file", path.display()))
        }
    }
}

/// A largest error (what xtask's checks read of the binary's report).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Max {
    /// The value (m or rad).
    pub value: f64,
}

/// The comparison of two trajectories, as `compare --format keys` prints it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// Samples found in both files.
    pub matched: usize,
    /// Samples in A.
    pub samples_a: usize,
    /// Samples in B.
    pub samples_b: usize,
    /// First and last matched time (s).
    pub t_first: f64,
    /// Last matched time (s).
    pub t_last: f64,
    /// Names of the compared columns other than the bodies' (`E_kin`, …).
    pub extras: Vec<String>,
    /// Max COM distance (m).
    pub com: Max,
    /// Max geodesic angle between orientations (rad).
    pub orientation: Max,
    /// Max body-origin distance (m).
    pub origin: Max,
    /// The two files, for [`format_report`].
    files: [PathBuf; 2],
}

impl Report {
    /// Whether every sample of each file found its match.
    pub fn all_matched(&self) -> bool {
        self.matched == self.samples_a && self.matched == self.samples_b
    }

    /// Reads the `key value` lines of `compare --format keys`.
    fn parse_keys(text: &str) -> Result<Report, String> {
        let get = |k: &str| -> Result<&str, String> {
            text.lines()
                .find_map(|l| l.strip_prefix(k)?.strip_prefix(' '))
                .or_else(|| text.lines().any(|l| l == k).then_some(""))
                .ok_or_else(|| format!("compare printed no {k:?}: {text:?}"))
        };
        let num = |k: &str| -> Result<f64, String> {
            get(k)?
                .parse()
                .map_err(|_| format!("compare: {k} is not a number: {text:?}"))
        };
        let count = |k: &str| -> Result<usize, String> {
            get(k)?
                .parse()
                .map_err(|_| format!("compare: {k} is not a count: {text:?}"))
        };
        Ok(Report {
            matched: count("samples")?,
            samples_a: count("samples_a")?,
            samples_b: count("samples_b")?,
            t_first: num("t_first")?,
            t_last: num("t_last")?,
            extras: get("extras")?
                .split(',')
                .filter(|s| !s.is_empty())
                .map(String::from)
                .collect(),
            com: Max { value: num("com")? },
            orientation: Max {
                value: num("orientation")?,
            },
            origin: Max {
                value: num("origin")?,
            },
            files: Default::default(),
        })
    }
}

/// Runs the `compare` binary on two files; its one-line error on failure.
fn run_compare(a: &Path, b: &Path, format: &str) -> Result<String, String> {
    let out = scene_bin("compare")
        .arg(a)
        .arg(b)
        .args(["--format", format])
        .output()
        .map_err(|e| format!("could not run cargo: {e}"))?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    if out.status.success() {
        Ok(stdout)
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        Err(err.trim().trim_start_matches("compare: ").to_string())
    }
}

/// Compares two trajectories of the same scene (the `compare` binary's figures).
pub fn compare(a: &Trajectory, b: &Trajectory) -> Result<Report, String> {
    let text = run_compare(&a.path, &b.path, "keys")?;
    let mut rep = Report::parse_keys(&text)?;
    rep.files = [a.path.clone(), b.path.clone()];
    Ok(rep)
}

/// The printed summary of the `compare` binary for the two files of `rep` (what
/// `verify --mujoco` shows for a failing scene).
pub fn format_report(rep: &Report) -> String {
    let [a, b] = &rep.files;
    run_compare(a, b, "table").unwrap_or_else(|e| format!("compare: {e}\n"))
}

/// `cargo xtask compare ARGS`: the `compare` binary, its exit status passed through.
pub fn main(args: &[std::ffi::OsString]) -> Result<(), String> {
    let status = scene_bin("compare")
        .args(args)
        .status()
        .map_err(|e| format!("could not run cargo: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        // The binary already said why in one line.
        std::process::exit(status.code().unwrap_or(1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `compare --format keys` prints (scene/src/bin/compare.rs), read back.
    #[test]
    fn reads_the_keys_of_the_compare_binary() {
        let text = "samples 6\nsamples_a 11\nsamples_b 6\nt_first 0.0\nt_last 1.0\nbodies 1\n\
                    extras E_kin,E_tot\ncom 1.0000000000000009e-3\norientation 1e-2\n\
                    origin 0e0\nworst 1e-2\n";
        let r = Report::parse_keys(text).unwrap();
        assert_eq!((r.matched, r.samples_a, r.samples_b), (6, 11, 6));
        assert!(!r.all_matched());
        assert_eq!((r.t_first, r.t_last), (0.0, 1.0));
        assert_eq!(r.extras, ["E_kin", "E_tot"]);
        assert_eq!(r.com.value, 1.0000000000000009e-3);
        assert_eq!(r.orientation.value, 0.01);
        assert_eq!(r.origin.value, 0.0);
        // No extra columns: an empty value.
        let none = text.replace("extras E_kin,E_tot", "extras ");
        assert!(Report::parse_keys(&none).unwrap().extras.is_empty());
        let none = text.replace("extras E_kin,E_tot", "extras");
        assert!(Report::parse_keys(&none).unwrap().extras.is_empty());
    }

    #[test]
    fn a_missing_or_malformed_key_is_an_error() {
        let e = Report::parse_keys("samples 1\n").unwrap_err();
        assert!(e.contains("samples_a"), "{e}");
        let e = Report::parse_keys(
            "samples x\nsamples_a 1\nsamples_b 1\nt_first 0\nt_last 0\nextras \ncom 0\n\
             orientation 0\norigin 0\n",
        )
        .unwrap_err();
        assert!(e.contains("samples is not a count"), "{e}");
        assert!(Trajectory::read(Path::new("/nonexistent/a.csv")).is_err());
    }
}
