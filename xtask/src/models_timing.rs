//! The interleaved timing of `cargo xtask models run`: per case, our `simulate` and
//! MuJoCo's `mujoco.rollout` timed alternately, `K` repeats each, close together in
//! time (ours first in even repeats, MuJoCo first in odd ones), the ratio ours / MuJoCo
//! taken per repeat ([`Paired`]: its median and spread). The machine's speed drifts
//! over minutes; two runs a few hundred milliseconds apart see about the same machine,
//! so the per-repeat ratio holds where medians timed minutes apart do not (the same
//! idea as `peers/examples/paired_ratio.rs`, across two processes).
//!
//! MuJoCo's side is one long-lived Python process per run ([`Timer`],
//! `xtask/src/models_timing.py`): one request a line, the model loaded and its case
//! built once, so a repeat pays neither the interpreter's start-up nor the load.

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::Duration;

const SERVER: &str = include_str!("models_timing.py");

/// The median of the per-repeat ratios and their spread, with each engine's median
/// µs per step over the same repeats.
#[derive(Clone, Debug, PartialEq)]
pub struct Paired {
    /// Repeats that gave a time on both sides.
    pub repeats: usize,
    /// Median of ours / MuJoCo over the repeats.
    pub ratio: f64,
    /// Lower and upper quartile of the per-repeat ratios ([`quantile`]): the spread
    /// the tables show (a single disturbed repeat moves it little).
    pub ratio_q1: f64,
    pub ratio_q3: f64,
    /// Smallest and largest per-repeat ratio.
    pub ratio_min: f64,
    pub ratio_max: f64,
    /// Each engine's median µs per step over the repeats.
    pub ours_us: f64,
    pub mujoco_us: f64,
}

/// The median of `v` (the mean of the two middle values for an even count); `None`
/// when `v` is empty.
pub fn median(v: &[f64]) -> Option<f64> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(s[n / 2]),
        _ => Some(0.5 * (s[n / 2 - 1] + s[n / 2])),
    }
}

/// The `p`-quantile of `v` (0 ≤ p ≤ 1) by nearest rank: the sorted value at
/// `round((n - 1) p)`, as `peers/examples/paired_ratio.rs` takes its quartiles; `None`
/// when `v` is empty.
pub fn quantile(v: &[f64], p: f64) -> Option<f64> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let i = ((s.len().checked_sub(1)?) as f64 * p.clamp(0.0, 1.0)).round() as usize;
    s.get(i).copied()
}

impl Paired {
    /// From the repeats' `(ours µs, MuJoCo µs)` pairs; `None` without any pair, or when
    /// a time is not positive and finite (no ratio to take).
    pub fn from_pairs(pairs: &[(f64, f64)]) -> Option<Paired> {
        let good = |x: f64| x.is_finite() && x > 0.0;
        if pairs.is_empty() || !pairs.iter().all(|&(a, b)| good(a) && good(b)) {
            return None;
        }
        let ratios: Vec<f64> = pairs.iter().map(|(a, b)| a / b).collect();
        let ours: Vec<f64> = pairs.iter().map(|p| p.0).collect();
        let mujoco: Vec<f64> = pairs.iter().map(|p| p.1).collect();
        Some(Paired {
            repeats: pairs.len(),
            ratio: median(&ratios)?,
            ratio_q1: quantile(&ratios, 0.25)?,
            ratio_q3: quantile(&ratios, 0.75)?,
            ratio_min: ratios.iter().copied().fold(f64::INFINITY, f64::min),
            ratio_max: ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            ours_us: median(&ours)?,
            mujoco_us: median(&mujoco)?,
        })
    }

    /// The spread cell: the quartiles `q1 … q3` of the per-repeat ratios.
    pub fn spread(&self) -> String {
        format!("{:.3} … {:.3}", self.ratio_q1, self.ratio_q3)
    }
}

/// Runs `K` interleaved repeats: `ours()` and `mujoco()` each give one repeat's µs per
/// step; ours first in even repeats, MuJoCo first in odd ones. The first error stops
/// the repeats and is returned.
pub fn interleave(
    k: usize,
    mut ours: impl FnMut() -> Result<f64, String>,
    mut mujoco: impl FnMut() -> Result<f64, String>,
) -> Result<Vec<(f64, f64)>, String> {
    let mut pairs = Vec::with_capacity(k);
    for r in 0..k {
        let pair = if r % 2 == 0 {
            let a = ours().map_err(|e| format!("ours: {e}"))?;
            (a, mujoco().map_err(|e| format!("MuJoCo: {e}"))?)
        } else {
            let b = mujoco().map_err(|e| format!("MuJoCo: {e}"))?;
            (ours().map_err(|e| format!("ours: {e}"))?, b)
        };
        pairs.push(pair);
    }
    Ok(pairs)
}

/// One request line for the timing server: `time`, the model file, the initial
/// positions and velocities and the control file (`-`: none), the step count. A field
/// with a tab or a line break, or a `-` of its own, cannot be sent.
pub fn request(
    xml: &Path,
    qpos: Option<&str>,
    qvel: Option<&str>,
    ctrl: Option<&str>,
    steps: u64,
) -> Result<String, String> {
    let path = xml
        .to_str()
        .ok_or_else(|| format!("{}: not UTF-8", xml.display()))?;
    let mut fields = vec!["time".to_string()];
    for (what, v) in [
        ("model", Some(path)),
        ("qpos", qpos),
        ("qvel", qvel),
        ("ctrl", ctrl),
    ] {
        match v {
            Some(s) if s.is_empty() || s == "-" || s.contains(['\t', '\n', '\r']) => {
                return Err(format!("{what} {s:?} cannot be sent to the timing server"))
            }
            Some(s) => fields.push(s.to_string()),
            None => fields.push("-".into()),
        }
    }
    if steps == 0 {
        return Err("no steps to time".into());
    }
    fields.push(steps.to_string());
    Ok(fields.join("\t"))
}

/// The server's answer: `ok<TAB>µs` (positive, finite) or `error<TAB>reason`.
pub fn parse_reply(line: &str) -> Result<f64, String> {
    let line = line.trim_end_matches(['\n', '\r']);
    match line.split_once('\t') {
        Some(("ok", v)) => v
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && *x > 0.0)
            .ok_or_else(|| format!("timing server: {v:?} is not a time")),
        Some(("error", why)) => Err(why.to_string()),
        _ => Err(format!("timing server: unreadable answer {line:?}")),
    }
}

/// MuJoCo's timing server: the Python process and its answers.
pub struct Timer {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    /// The longest wait for one answer.
    limit: Duration,
    /// MuJoCo's version, from the server's first line.
    pub version: String,
}

impl Timer {
    /// Starts the server with `python` (the script is written to `target/xtask/`);
    /// waits for its `ready` line.
    pub fn start(python: &Path, script_dir: &Path, limit: Duration) -> Result<Timer, String> {
        std::fs::create_dir_all(script_dir)
            .map_err(|e| format!("{}: {e}", script_dir.display()))?;
        // The server imports the measuring script's start state and control hold.
        for (name, text) in [
            ("models_mujoco.py", super::MEASURE),
            ("models_timing.py", SERVER),
        ] {
            let path = script_dir.join(name);
            if std::fs::read_to_string(&path).ok().as_deref() != Some(text) {
                std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            }
        }
        let script = script_dir.join("models_timing.py");
        let mut child = Command::new(python)
            .arg(&script)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("starting MuJoCo's timing server: {e}"))?;
        let stdin = child.stdin.take();
        let stdout = child
            .stdout
            .take()
            .ok_or("the timing server has no stdout")?;
        // A reader thread, so a stuck server is a timeout rather than a hang.
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut t = Timer {
            child,
            stdin,
            lines,
            limit,
            version: String::new(),
        };
        let first = t.answer()?;
        match first.split_once('\t') {
            Some(("ready", v)) => t.version = v.trim().to_string(),
            _ => return Err(format!("timing server: unexpected first line {first:?}")),
        }
        Ok(t)
    }

    fn answer(&mut self) -> Result<String, String> {
        match self.lines.recv_timeout(self.limit) {
            Ok(l) => Ok(l),
            Err(RecvTimeoutError::Timeout) => Err(format!(
                "timing server: no answer in {} s",
                self.limit.as_secs()
            )),
            Err(RecvTimeoutError::Disconnected) => Err("timing server: it exited".into()),
        }
    }

    /// One timed rollout of the request `line` ([`request`]): µs per step.
    pub fn time(&mut self, line: &str) -> Result<f64, String> {
        let stdin = self.stdin.as_mut().ok_or("timing server: stdin closed")?;
        writeln!(stdin, "{line}")
            .and_then(|()| stdin.flush())
            .map_err(|e| format!("timing server: {e}"))?;
        parse_reply(&self.answer()?)
    }
}

impl Drop for Timer {
    /// Closes the server's input (it ends at end of input); kills it if it is stuck.
    fn drop(&mut self) {
        drop(self.stdin.take());
        for _ in 0..200 {
            if matches!(self.child.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_is_the_middle_value_or_the_mean_of_the_two() {
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[3.0]), Some(3.0));
        // Order does not matter; odd: the middle one.
        assert_eq!(median(&[5.0, 1.0, 4.0, 2.0, 3.0]), Some(3.0));
        // Even: the mean of the two middle ones.
        assert_eq!(median(&[4.0, 1.0, 2.0, 10.0]), Some(3.0));
        // One wild value moves it by nothing.
        assert_eq!(median(&[1.0, 1.0, 1.0, 1.0, 1e9]), Some(1.0));
    }

    #[test]
    fn paired_takes_the_ratio_per_repeat() {
        // The machine slows by 3x in the middle of the run: both engines see it, so
        // every per-repeat ratio is 2 while the quotient of the medians is not.
        let pairs = [(2.0, 1.0), (6.0, 3.0), (6.0, 3.0), (2.0, 1.0), (20.0, 10.0)];
        let p = Paired::from_pairs(&pairs).unwrap();
        assert_eq!(p.repeats, 5);
        assert_eq!((p.ratio, p.ratio_min, p.ratio_max), (2.0, 2.0, 2.0));
        assert_eq!((p.ratio_q1, p.ratio_q3), (2.0, 2.0));
        assert_eq!((p.ours_us, p.mujoco_us), (6.0, 3.0));
        // Separate medians of shuffled series give another figure; the pairs do not.
        let q = Paired::from_pairs(&[(2.0, 1.0), (4.5, 1.5), (3.0, 2.0)]).unwrap();
        assert_eq!((q.ratio, q.ratio_min, q.ratio_max), (2.0, 1.5, 3.0));
        assert_eq!((q.ours_us, q.mujoco_us), (3.0, 1.5));
        // Three repeats: the quartiles at ranks round(0.5) = 1 and round(1.5) = 2.
        assert_eq!((q.ratio_q1, q.ratio_q3), (2.0, 3.0));
        assert_eq!(q.spread(), "2.000 … 3.000");
        // The repeat order does not change the figures.
        let r = Paired::from_pairs(&[(3.0, 2.0), (2.0, 1.0), (4.5, 1.5)]).unwrap();
        assert_eq!(q, r);
    }

    #[test]
    fn quartiles_bracket_the_median_and_ignore_one_wild_repeat() {
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(quantile(&[7.0], 0.25), Some(7.0));
        let v: Vec<f64> = (1..=9).rev().map(f64::from).collect();
        assert_eq!(quantile(&v, 0.0), Some(1.0));
        assert_eq!(quantile(&v, 0.25), Some(3.0));
        assert_eq!(quantile(&v, 0.5), median(&v));
        assert_eq!(quantile(&v, 0.75), Some(7.0));
        assert_eq!(quantile(&v, 1.0), Some(9.0));
        // Fifteen repeats at ratio 2 ± 0.1 and one preempted repeat at 12: the
        // quartiles stay within the 0.1, the maximum does not.
        let mut pairs: Vec<(f64, f64)> = (0..15)
            .map(|i| (2.0 + 0.1 * f64::from(i % 3) - 0.1, 1.0))
            .collect();
        pairs.push((12.0, 1.0));
        let p = Paired::from_pairs(&pairs).unwrap();
        assert!(p.ratio_q1 >= 1.9 && p.ratio_q3 <= 2.1 + 1e-12, "{p:?}");
        assert!(p.ratio_q1 <= p.ratio && p.ratio <= p.ratio_q3, "{p:?}");
        assert_eq!(p.ratio_max, 12.0);
    }

    #[test]
    fn paired_needs_positive_finite_times() {
        assert_eq!(Paired::from_pairs(&[]), None);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(Paired::from_pairs(&[(1.0, 1.0), (bad, 1.0)]), None);
            assert_eq!(Paired::from_pairs(&[(1.0, bad)]), None);
        }
    }

    #[test]
    fn interleave_alternates_the_first_engine() {
        let log = std::cell::RefCell::new(String::new());
        let pairs = interleave(
            4,
            || {
                log.borrow_mut().push('o');
                Ok(2.0)
            },
            || {
                log.borrow_mut().push('m');
                Ok(1.0)
            },
        )
        .unwrap();
        assert_eq!(log.into_inner(), "ommoommo");
        assert_eq!(pairs, vec![(2.0, 1.0); 4]);
        // The first error ends the repeats and names the engine.
        let mut n = 0;
        let e = interleave(
            5,
            || {
                n += 1;
                if n == 2 {
                    Err("step 3 diverged".into())
                } else {
                    Ok(1.0)
                }
            },
            || Ok(1.0),
        )
        .unwrap_err();
        assert_eq!((e.as_str(), n), ("ours: step 3 diverged", 2));
        assert_eq!(interleave(0, || Ok(1.0), || Ok(1.0)), Ok(vec![]));
    }

    #[test]
    fn requests_are_one_tab_separated_line() {
        let xml = Path::new("/m/dm_control/walker.xml");
        assert_eq!(
            request(xml, None, None, None, 250).unwrap(),
            "time\t/m/dm_control/walker.xml\t-\t-\t-\t250"
        );
        assert_eq!(
            request(xml, Some("0.1,-0.2"), Some("-1e-3"), Some("w/c.csv"), 7).unwrap(),
            "time\t/m/dm_control/walker.xml\t0.1,-0.2\t-1e-3\tw/c.csv\t7"
        );
        for (q, want) in [("a\tb", "qpos"), ("-", "qpos"), ("", "qpos")] {
            let e = request(xml, Some(q), None, None, 1).unwrap_err();
            assert!(e.starts_with(want), "{e}");
        }
        let e = request(xml, None, None, Some("a\nb"), 1).unwrap_err();
        assert!(e.starts_with("ctrl"), "{e}");
        assert!(request(xml, None, None, None, 0).is_err());
        let e = request(Path::new("a\tb.xml"), None, None, None, 1).unwrap_err();
        assert!(e.starts_with("model"), "{e}");
    }

    /// The server end to end on a scene of this repository: a time per step for a
    /// passive and a perturbed request, a reason for a file that does not load, and
    /// the server still answering after it.
    #[test]
    #[ignore = "needs Python and MuJoCo (target/mujoco-venv)"]
    fn the_server_times_a_scene_and_survives_a_bad_request() {
        let python = crate::mujoco::ensure_venv().unwrap();
        let dir = crate::run::root().join("target/xtask");
        let mut t = Timer::start(&python, &dir, Duration::from_secs(60)).unwrap();
        assert!(!t.version.is_empty());
        let xml = crate::run::root().join("scenes/pendulum.xml");
        let a = t
            .time(&request(&xml, None, None, None, 200).unwrap())
            .unwrap();
        let line = request(&xml, Some("0.3"), Some("-0.1"), None, 200).unwrap();
        let b = t.time(&line).unwrap();
        // A pendulum step in MuJoCo's C loop: microseconds, not milliseconds (measured
        // about 1-3 µs on the shared 2-core machine).
        for us in [a, b] {
            assert!(us > 0.0 && us < 1000.0, "{us}");
        }
        // Controls from a `t,<actuator>...` file, as the controlled case sends them.
        let root = crate::run::root();
        let (xa, ctrl) = (
            root.join("scenes/actuated.xml"),
            root.join("scenes/actuated_ctrl.csv"),
        );
        let line = request(&xa, None, None, ctrl.to_str(), 100).unwrap();
        assert!(t.time(&line).is_ok_and(|us| us > 0.0));
        let bad = dir.join("no-such-model.xml");
        let e = t
            .time(&request(&bad, None, None, None, 10).unwrap())
            .unwrap_err();
        assert!(!e.is_empty(), "{e}");
        let e = t.time(&request(&xml, Some("1,2,3,4"), None, None, 10).unwrap());
        assert!(e.unwrap_err().contains("qpos"));
        assert!(t.time(&line).is_ok(), "the server answers after errors");
        drop(t);
    }

    #[test]
    fn replies_parse_or_say_why() {
        assert_eq!(parse_reply("ok\t12.5\n"), Ok(12.5));
        assert_eq!(parse_reply("ok\t3.0e-1"), Ok(0.3));
        assert_eq!(
            parse_reply("error\tqpos: 40 values, the model has 28"),
            Err("qpos: 40 values, the model has 28".into())
        );
        for bad in ["ok\t0", "ok\t-1", "ok\tnan", "ok\tinf", "ok\tfast"] {
            assert!(
                parse_reply(bad).unwrap_err().contains("not a time"),
                "{bad}"
            );
        }
        for bad in ["", "ok", "12.5", "ready\t4.0.0"] {
            assert!(
                parse_reply(bad).unwrap_err().contains("unreadable"),
                "{bad}"
            );
        }
    }
}
