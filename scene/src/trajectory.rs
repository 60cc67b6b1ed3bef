//! Trajectory files (DESIGN.md §6) and their comparison (§7).
//!
//! CSV with one header row `t,<body>.x,<body>.y,<body>.z,<body>.qw,…,<body>.cz,…` and one
//! row per sample. [`compare`] matches columns by name (the two files may order bodies
//! differently) and rows by time (`|t_a − t_b| ≤ 1e-9·max(1, |t|)`, so a file sampled every
//! 1 ms compares with one sampled every 10 ms at their common times) and reports, each with
//! the time and body where it occurs:
//!
//! - the largest centre-of-mass error `max |c_a − c_b|` over the `cx, cy, cz` columns (m),
//!   the figure DESIGN.md §7 uses (a body frame often sits on its joint, where it barely
//!   moves);
//! - the orientation error, the geodesic angle `2·acos |⟨q_a, q_b⟩|` (rad), computed as
//!   `4·atan2(|q_a − s q_b|, |q_a + s q_b|)` with `s = sign⟨q_a, q_b⟩` ([`rotation_angle`]):
//!   the same angle without `acos`'s loss of precision near 1, which would put a 1e-8 rad
//!   floor under round-off differences;
//! - the body-origin error `max |x_a − x_b|` over the `x, y, z` columns (m);
//! - for each other column both files have (`E_kin`, `E_pot`, `E_tot`, `C_max`, …), the
//!   largest absolute difference.
//!
//! The CSV reader and writer are a few lines by hand rather than the `csv` crate: the
//! format is numbers only (no quoting, no escapes), the writer must keep the committed
//! references of `scenes/reference/` byte-identical (Rust's shortest round-trip `{:?}`),
//! and the reader's errors name the line and column.

use std::fmt::Write as _;

use constraint_articulated::mjcf::PartState;
use constraint_articulated::{RigidBody, World};

/// A trajectory: column names and rows of numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    /// Column names, `t` first.
    pub header: Vec<String>,
    /// Rows, each as long as the header.
    pub rows: Vec<Vec<f64>>,
}

/// The per-body column suffixes of §6, in order.
pub const BODY_COLUMNS: [&str; 10] = ["x", "y", "z", "qw", "qx", "qy", "qz", "cx", "cy", "cz"];

impl Trajectory {
    /// An empty trajectory for the given body names (plus energy columns).
    pub fn for_bodies(names: &[String]) -> Self {
        let mut header = vec!["t".to_string()];
        for n in names {
            for c in BODY_COLUMNS {
                header.push(format!("{n}.{c}"));
            }
        }
        for c in ["E_kin", "E_pot", "E_tot", "C_max"] {
            header.push(c.to_string());
        }
        Self {
            header,
            rows: Vec::new(),
        }
    }

    /// Appends the world's state at time `t`.
    pub fn push(&mut self, t: f64, world: &World) {
        let (k, p) = world.energy();
        self.push_bodies(t, world.bodies(), k, p, world.max_separation());
    }

    /// Appends a row from bodies and the trailing columns (kinetic and potential energy,
    /// largest constraint violation or penetration).
    pub fn push_bodies(&mut self, t: f64, bodies: &[RigidBody], kin: f64, pot: f64, c_max: f64) {
        let mut row = Vec::with_capacity(self.header.len());
        row.push(t);
        for b in bodies {
            let o = b.origin();
            let q = b.orientation();
            row.extend_from_slice(&[
                o.x, o.y, o.z, q.w, q.x, q.y, q.z, b.pose.x.x, b.pose.x.y, b.pose.x.z,
            ]);
        }
        row.extend_from_slice(&[kin, pot, kin + pot, c_max]);
        self.rows.push(row);
    }

    /// Appends a row from MJCF bodies' states (one per body of an
    /// [`constraint_articulated::MjcfScene`], merged bodies included,
    /// [`constraint_articulated::MjcfScene::part_states`]) and the trailing columns.
    pub fn push_parts(&mut self, t: f64, parts: &[PartState], kin: f64, pot: f64, c_max: f64) {
        let mut row = Vec::with_capacity(self.header.len());
        row.push(t);
        for p in parts {
            let (o, q, c) = (p.origin, p.orientation, p.com);
            row.extend_from_slice(&[o.x, o.y, o.z, q.w, q.x, q.y, q.z, c.x, c.y, c.z]);
        }
        row.extend_from_slice(&[kin, pot, kin + pot, c_max]);
        self.rows.push(row);
    }

    /// The CSV text (numbers in shortest round-trip form).
    pub fn to_csv(&self) -> String {
        let mut s = self.header.join(",");
        s.push('\n');
        for r in &self.rows {
            for (i, v) in r.iter().enumerate() {
                if i > 0 {
                    s.push(',');
                }
                let _ = write!(s, "{v:?}");
            }
            s.push('\n');
        }
        s
    }

    /// Parses CSV text. Errors name the line (and column): an empty file, a first column
    /// other than `t`, an empty or repeated column name, a row of another length, a field
    /// that is not a finite number, a time that does not increase, no rows.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, head) = lines.next().ok_or("empty file (no header)")?;
        let header: Vec<String> = head.split(',').map(|s| s.trim().to_string()).collect();
        if header.first().map(String::as_str) != Some("t") {
            return Err(format!(
                "line 1: first column must be `t`, found {:?}",
                header.first().map_or("", String::as_str)
            ));
        }
        for (i, c) in header.iter().enumerate().skip(1) {
            if c.is_empty() {
                return Err(format!("line 1: column {} has an empty name", i + 1));
            }
            if let Some(j) = header[..i].iter().position(|h| h == c) {
                return Err(format!(
                    "line 1: column {c:?} appears twice (columns {} and {})",
                    j + 1,
                    i + 1
                ));
            }
        }
        let mut rows: Vec<Vec<f64>> = Vec::new();
        for (i, l) in lines {
            let line = i + 1;
            let fields: Vec<&str> = l.split(',').map(str::trim).collect();
            if fields.len() != header.len() {
                return Err(format!(
                    "line {line}: {} fields, the header has {}",
                    fields.len(),
                    header.len()
                ));
            }
            let mut row = Vec::with_capacity(fields.len());
            for (v, c) in fields.iter().zip(&header) {
                let x: f64 = v
                    .parse()
                    .map_err(|_| format!("line {line}: column {c:?}: {v:?} is not a number"))?;
                if !x.is_finite() {
                    return Err(format!("line {line}: column {c:?} is not finite ({v})"));
                }
                row.push(x);
            }
            if let Some(prev) = rows.last().map(|r| r[0]) {
                if row[0] <= prev {
                    return Err(format!(
                        "line {line}: time {} does not increase (previous {prev})",
                        row[0]
                    ));
                }
            }
            rows.push(row);
        }
        if rows.is_empty() {
            return Err("no samples after the header".into());
        }
        Ok(Self { header, rows })
    }

    /// Reads and parses a file; errors start with its path.
    pub fn read(path: &std::path::Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Body names (from the `.x` columns).
    pub fn bodies(&self) -> Vec<String> {
        self.header
            .iter()
            .filter_map(|h| h.strip_suffix(".x").map(str::to_string))
            .collect()
    }

    fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }
}

/// The largest differences between two trajectories (see the module docs for each).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Comparison {
    /// Max centre-of-mass distance (m), its time and body.
    pub com: (f64, f64, String),
    /// Max orientation angle (rad), its time and body.
    pub angle: (f64, f64, String),
    /// Max body-origin distance (m), its time and body.
    pub origin: (f64, f64, String),
    /// Per other column both files have (in A's order): its name, the max absolute
    /// difference and its time.
    pub extras: Vec<(String, f64, f64)>,
    /// Samples compared (found in both files).
    pub samples: usize,
    /// Samples in A and in B.
    pub samples_a: usize,
    /// Samples in B.
    pub samples_b: usize,
    /// First and last compared time (s).
    pub t_first: f64,
    /// Last compared time (s).
    pub t_last: f64,
    /// Bodies compared.
    pub bodies: usize,
}

impl Comparison {
    /// Whether every sample of each file found its match.
    pub fn all_matched(&self) -> bool {
        self.samples == self.samples_a && self.samples == self.samples_b
    }

    /// The largest of the COM, body-origin and orientation errors (m and rad together:
    /// the figure a tolerance is checked against).
    pub fn worst(&self) -> f64 {
        self.com.0.max(self.origin.0).max(self.angle.0)
    }

    /// The printed summary of `compare` (one line per figure).
    pub fn report(&self) -> String {
        let mut s = format!(
            "compared {} samples (A has {}, B has {}), {} bodies, t in [{}, {}] s\n",
            self.samples, self.samples_a, self.samples_b, self.bodies, self.t_first, self.t_last
        );
        let line = |what: &str, m: &(f64, f64, String), unit: &str| {
            format!(
                "{what:<24} {:.6e} {unit:<3} at t = {} s, body {}\n",
                m.0, m.1, m.2
            )
        };
        s += &line("max COM position error", &self.com, "m");
        s += &line("max orientation error", &self.angle, "rad");
        s += &line("max body-origin error", &self.origin, "m");
        for (name, d, t) in &self.extras {
            s += &format!(
                "{:<24} {d:.6e}     at t = {t} s\n",
                format!("max |Δ {name}|")
            );
        }
        if !self.all_matched() {
            s += "warning: not every sample has a match in the other file\n";
        }
        s
    }
}

/// Times match when `|t_a − t_b| ≤ TIME_TOL·max(1, |t|)`.
pub const TIME_TOL: f64 = 1e-9;

/// Geodesic angle between the rotations of two quaternions `(w, x, y, z)` (need not be
/// exactly unit): `2·acos |⟨q̂_a, q̂_b⟩|`, evaluated as `4·atan2(|q̂_a − s q̂_b|, |q̂_a + s
/// q̂_b|)`, `s = sign⟨q_a, q_b⟩`, which keeps full precision for tiny angles.
pub fn rotation_angle(a: [f64; 4], b: [f64; 4]) -> f64 {
    let norm = |q: [f64; 4]| q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let (na, nb) = (norm(a), norm(b));
    let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
    let s = if dot < 0.0 { -1.0 } else { 1.0 };
    let (mut dm, mut dp) = (0.0, 0.0);
    for k in 0..4 {
        let (x, y) = (a[k] / na, s * b[k] / nb);
        dm += (x - y) * (x - y);
        dp += (x + y) * (x + y);
    }
    4.0 * dm.sqrt().atan2(dp.sqrt())
}

/// Column indices of a body's ten [`BODY_COLUMNS`].
fn body_cols(t: &Trajectory, body: &str) -> Result<[usize; 10], String> {
    let mut idx = [0; 10];
    for (k, c) in BODY_COLUMNS.iter().enumerate() {
        idx[k] = t
            .col(&format!("{body}.{c}"))
            .ok_or_else(|| format!("body {body:?} has no column {body}.{c}"))?;
    }
    Ok(idx)
}

/// Keeps the largest value (a NaN wins; parsed files hold none) with its time and name.
fn keep_max(slot: &mut (f64, f64, String), v: f64, t: f64, at: &str) {
    if slot.2.is_empty() || !(v <= slot.0) {
        *slot = (v, t, at.to_string());
    }
}

/// Compares `a` against `b` at the times they share (to [`TIME_TOL`]`·max(1, |t|)`),
/// matching bodies by name. Errors: the body sets differ, a body lacks a column, no time
/// in common.
pub fn compare(a: &Trajectory, b: &Trajectory) -> Result<Comparison, String> {
    let bodies = a.bodies();
    let (only_a, only_b): (Vec<String>, Vec<String>) = {
        let bb = b.bodies();
        (
            bodies.iter().filter(|n| !bb.contains(n)).cloned().collect(),
            bb.iter().filter(|n| !bodies.contains(n)).cloned().collect(),
        )
    };
    if !only_a.is_empty() || !only_b.is_empty() {
        return Err(format!(
            "the files hold different bodies (only in A: [{}]; only in B: [{}])",
            only_a.join(", "),
            only_b.join(", ")
        ));
    }
    let cols: Vec<([usize; 10], [usize; 10])> = bodies
        .iter()
        .map(|n| Ok((body_cols(a, n)?, body_cols(b, n)?)))
        .collect::<Result<_, String>>()?;
    let is_body_col = |h: &str| {
        h.rsplit_once('.')
            .is_some_and(|(n, c)| BODY_COLUMNS.contains(&c) && bodies.iter().any(|b| b == n))
    };
    let extra_cols: Vec<(usize, usize)> = a
        .header
        .iter()
        .enumerate()
        .skip(1)
        .filter(|(_, h)| !is_body_col(h))
        .filter_map(|(i, h)| b.col(h).map(|j| (i, j)))
        .collect();
    let mut out = Comparison {
        extras: extra_cols
            .iter()
            .map(|&(i, _)| (a.header[i].clone(), 0.0, 0.0))
            .collect(),
        samples_a: a.rows.len(),
        samples_b: b.rows.len(),
        t_first: f64::NAN,
        t_last: f64::NAN,
        bodies: bodies.len(),
        ..Comparison::default()
    };
    let (mut i, mut j) = (0, 0);
    while i < a.rows.len() && j < b.rows.len() {
        let (ra, rb) = (&a.rows[i], &b.rows[j]);
        let (ta, tb) = (ra[0], rb[0]);
        let tol = TIME_TOL * ta.abs().max(tb.abs()).max(1.0);
        if ta < tb - tol {
            i += 1;
            continue;
        }
        if tb < ta - tol {
            j += 1;
            continue;
        }
        if out.samples == 0 {
            out.t_first = ta;
        }
        out.t_last = ta;
        out.samples += 1;
        for (n, (ca, cb)) in bodies.iter().zip(&cols) {
            let dist = |k: usize| {
                (0..3)
                    .map(|d| (ra[ca[k + d]] - rb[cb[k + d]]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            let quat = |r: &[f64], c: &[usize; 10]| [r[c[3]], r[c[4]], r[c[5]], r[c[6]]];
            keep_max(&mut out.com, dist(7), ta, n);
            keep_max(&mut out.origin, dist(0), ta, n);
            keep_max(
                &mut out.angle,
                rotation_angle(quat(ra, ca), quat(rb, cb)),
                ta,
                n,
            );
        }
        for (slot, &(ia, ib)) in out.extras.iter_mut().zip(&extra_cols) {
            let d = (ra[ia] - rb[ib]).abs();
            if !(d <= slot.1) {
                (slot.1, slot.2) = (d, ta);
            }
        }
        i += 1;
        j += 1;
    }
    if out.samples == 0 {
        let span = |t: &Trajectory| {
            let (first, last) = (t.rows.first(), t.rows.last());
            format!(
                "{} samples in [{}, {}]",
                t.rows.len(),
                first.map_or(f64::NAN, |r| r[0]),
                last.map_or(f64::NAN, |r| r[0])
            )
        };
        return Err(format!(
            "no sample times in common (A: {}; B: {})",
            span(a),
            span(b)
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(bodies: &[&str], extras: &[&str]) -> String {
        let mut h = vec!["t".to_string()];
        for b in bodies {
            h.extend(BODY_COLUMNS.iter().map(|f| format!("{b}.{f}")));
        }
        h.extend(extras.iter().map(|e| e.to_string()));
        h.join(",")
    }

    /// One row: body k at x = (k + t, 0, 0), identity orientation rotated by `angle` about
    /// z, COM offset by `dc` along y; extras all `e`.
    fn row(t: f64, nb: usize, angle: f64, dc: f64, ne: usize, e: f64) -> String {
        let mut v = vec![t];
        for k in 0..nb {
            let x = k as f64 + t;
            v.extend([x, 0.0, 0.0]);
            v.extend([(angle / 2.0).cos(), 0.0, 0.0, (angle / 2.0).sin()]);
            v.extend([x, dc, 0.0]);
        }
        v.extend(std::iter::repeat_n(e, ne));
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(",")
    }

    #[test]
    fn csv_round_trips_byte_for_byte() {
        let text = format!(
            "{}\n{}\n{}\n",
            head(&["a"], &["E_tot"]),
            row(0.0, 1, 0.1, 1e-17, 1, -3.25e300),
            row(0.001, 1, 0.2, 0.1, 1, 2.0 / 3.0)
        );
        let t = Trajectory::parse(&text).unwrap();
        assert_eq!(t.to_csv(), text);
    }

    #[test]
    fn identical_files_compare_to_zero() {
        let text = format!(
            "{}\n{}\n{}\n",
            head(&["a", "b"], &["E_tot"]),
            row(0.0, 2, 0.1, 0.0, 1, 3.0),
            row(0.01, 2, 0.2, 0.0, 1, 3.0)
        );
        let t = Trajectory::parse(&text).unwrap();
        assert_eq!(t.bodies(), ["a", "b"]);
        let r = compare(&t, &t).unwrap();
        assert_eq!(r.samples, 2);
        assert!(r.all_matched());
        // Exactly zero: the same numbers subtracted (the acos form gave ~1e-8 rad here).
        assert_eq!(r.worst(), 0.0);
        assert_eq!(r.extras, [("E_tot".to_string(), 0.0, 0.0)]);
    }

    #[test]
    fn finds_the_max_errors_and_where() {
        let a = Trajectory::parse(&format!(
            "{}\n{}\n{}\n{}\n",
            head(&["a", "b"], &["E_tot"]),
            row(0.0, 2, 0.0, 0.0, 1, 1.0),
            row(0.5, 2, 0.0, 0.0, 1, 1.0),
            row(1.0, 2, 0.0, 0.0, 1, 1.0)
        ))
        .unwrap();
        // B: bodies in the other order, COM off by 0.25 at t = 0.5, rotated by 0.3 rad at
        // t = 1 (both bodies: the first in A's order is reported), E_tot off by 0.5.
        let b = Trajectory::parse(&format!(
            "{}\n{}\n{}\n{}\n",
            head(&["b", "a"], &["E_tot"]),
            row(0.0, 2, 0.0, 0.0, 1, 1.0),
            row(0.5, 2, 0.0, 0.25, 1, 1.5),
            row(1.0, 2, 0.0 + 0.3, 0.0, 1, 1.0)
        ))
        .unwrap();
        // The bodies swap names, so positions differ by one (x_k = k + t) at every sample.
        let r = compare(&a, &b).unwrap();
        assert_eq!(r.samples, 3);
        assert!((r.origin.0 - 1.0).abs() < 1e-15, "{}", r.origin.0); // exact: 1.0
        assert!((r.com.0 - 1.0625f64.sqrt()).abs() < 1e-15, "{}", r.com.0);
        assert_eq!(r.com.1, 0.5);
        // Measured: |0.3 − angle| ≈ 5.6e-17.
        assert!((r.angle.0 - 0.3).abs() < 1e-14, "{}", r.angle.0);
        assert_eq!((r.angle.1, r.angle.2.as_str()), (1.0, "a"));
        assert_eq!(r.extras, [("E_tot".to_string(), 0.5, 0.5)]);
        assert!(r.report().contains("max COM position error"));
    }

    #[test]
    fn rotation_angle_is_accurate_for_tiny_and_sign_flipped_quaternions() {
        let q = |a: f64| [(a / 2.0).cos(), 0.0, (a / 2.0).sin(), 0.0];
        let e = 1e-12;
        let got = rotation_angle(q(1.0), q(1.0 + e));
        // Measured error ≈ 1e-16 rad on 1e-12; `2 acos` would give 0 or ~2e-8.
        assert!((got - e).abs() < 1e-15, "{got}");
        assert!(rotation_angle(q(0.7), q(0.7).map(|x| -x)) < 1e-15);
        assert!((rotation_angle(q(0.0), q(3.0)) - 3.0).abs() < 1e-14);
        // Beyond π the short way round is reported.
        let short = 2.0 * std::f64::consts::PI - 4.0;
        assert!((rotation_angle(q(0.0), q(4.0)) - short).abs() < 1e-14);
    }

    #[test]
    fn rows_match_by_time_across_sampling_rates() {
        let h = head(&["a"], &[]);
        let fine: String = (0..=10)
            .map(|i| row(i as f64 * 0.1, 1, 0.0, 0.0, 0, 0.0) + "\n")
            .collect();
        let coarse: String = (0..=5)
            .map(|i| row(i as f64 * 0.2 + 1e-12, 1, 0.0, 0.0, 0, 0.0) + "\n")
            .collect();
        let a = Trajectory::parse(&format!("{h}\n{fine}")).unwrap();
        let b = Trajectory::parse(&format!("{h}\n{coarse}")).unwrap();
        let r = compare(&a, &b).unwrap();
        assert_eq!(r.samples, 6);
        assert!(!r.all_matched());
        assert_eq!(r.t_last, 1.0);
        assert!(r.report().contains("warning"));
    }

    #[test]
    fn malformed_files_are_errors_naming_the_line() {
        let h = head(&["a"], &[]);
        let ok = row(0.0, 1, 0.0, 0.0, 0, 0.0);
        let cases = [
            (String::new(), "empty"),
            (format!("{h}\n"), "no samples"),
            (format!("x,{}\n{ok}\n", &h[2..]), "first column"),
            (format!("{h}\n{ok},1\n"), "line 2: 12 fields"),
            (
                format!("{h}\n{}\n", ok.replacen("0.0", "abc", 1)),
                "not a number",
            ),
            (
                format!("{h}\n{}\n", ok.replacen("0.0", "NaN", 1)),
                "not finite",
            ),
            (
                format!("{h}\n{ok}\n{ok}\n"),
                "line 3: time 0 does not increase",
            ),
            (format!("{h},a.x\n{ok},0\n"), "twice"),
            ("t,,a.x\n0,1,2\n".to_string(), "empty name"),
        ];
        for (text, want) in cases {
            let e = Trajectory::parse(&text).expect_err(want);
            assert!(e.contains(want), "{want:?} not in {e:?}");
        }
    }

    #[test]
    fn mismatched_bodies_columns_or_times_are_errors() {
        let two = |names: &[&str], t: f64| {
            Trajectory::parse(&format!(
                "{}\n{}\n",
                head(names, &[]),
                row(t, 2, 0.0, 0.0, 0, 0.0)
            ))
            .unwrap()
        };
        let a = two(&["a", "b"], 0.0);
        let e = compare(&a, &two(&["a", "c"], 0.0)).unwrap_err();
        assert!(
            e.contains("only in A: [b]") && e.contains("only in B: [c]"),
            "{e}"
        );
        let e = compare(&a, &two(&["a", "b"], 1.0)).unwrap_err();
        assert!(e.contains("no sample times in common"), "{e}");
        let partial = Trajectory::parse("t,a.x,a.y,a.z\n0,1,2,3\n").unwrap();
        let e = compare(&partial, &partial).unwrap_err();
        assert!(e.contains("no column a.qw"), "{e}");
    }
}
