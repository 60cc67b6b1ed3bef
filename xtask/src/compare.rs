//! `cargo xtask compare A.csv B.csv`: trajectory error between two files of the same
//! scene (DESIGN.md sections 6 and 7).
//!
//! Columns are matched by header name, so the two files may order bodies differently, but
//! they must hold the same set of bodies. Rows are matched by time (`|t_a − t_b| ≤
//! 1e-9·max(1, t)`), so a file sampled every 1 ms compares with one sampled every 10 ms at
//! their common times. Reported, each with the time and body where it occurs:
//!
//! - COM position error `max |c_a − c_b|` over the `cx, cy, cz` columns (m), the figure
//!   DESIGN.md section 7 uses (a body frame often sits on its joint, where it barely moves);
//! - orientation error: the geodesic angle `2·acos(|⟨q_a, q_b⟩|)` (rad), computed as
//!   `4·atan2(|q_a − s q_b|, |q_a + s q_b|)` with `s = sign⟨q_a, q_b⟩` — the same angle
//!   without `acos`'s loss of precision near 1 (that would put a 1e-8 rad floor under
//!   round-off differences);
//! - body-origin error `max |x_a − x_b|` over the `x, y, z` columns (m);
//! - for each extra column both files have (`E_kin`, `E_pot`, `E_tot`, `C_max`, …), the
//!   max absolute difference.
//!
//! Standard library only, so that it can be lifted into a library crate unchanged.

use std::collections::BTreeMap;

/// The per-body fields of a trajectory file, in file order.
pub const FIELDS: [&str; 10] = ["x", "y", "z", "qw", "qx", "qy", "qz", "cx", "cy", "cz"];

/// Times match when `|t_a − t_b| ≤ TIME_TOL·max(1, |t|)`.
pub const TIME_TOL: f64 = 1e-9;

/// A parsed trajectory file.
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// Body names in file order.
    pub bodies: Vec<String>,
    /// Names of the columns that are neither `t` nor a body field, in file order.
    pub extras: Vec<String>,
    /// Sample times, strictly increasing.
    pub times: Vec<f64>,
    /// Per sample, per body (in `bodies` order): the ten `FIELDS` values.
    pub body_rows: Vec<Vec<[f64; 10]>>,
    /// Per sample, the `extras` values.
    pub extra_rows: Vec<Vec<f64>>,
}

impl Trajectory {
    /// Parses the CSV text of DESIGN.md section 6. Errors name the line.
    pub fn parse(text: &str) -> Result<Trajectory, String> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, head) = lines.next().ok_or("empty file (no header)")?;
        let cols: Vec<&str> = head.split(',').map(str::trim).collect();
        if cols.first() != Some(&"t") {
            return Err(format!(
                "line 1: first column must be `t`, found {:?}",
                cols.first().unwrap_or(&"")
            ));
        }
        // Body fields: column index per (body, field); everything else is an extra column.
        let mut bodies: Vec<String> = Vec::new();
        let mut slots: BTreeMap<String, [Option<usize>; 10]> = BTreeMap::new();
        let mut extras: Vec<String> = Vec::new();
        let mut extra_idx: Vec<usize> = Vec::new();
        let mut seen: BTreeMap<&str, usize> = BTreeMap::new();
        for (i, c) in cols.iter().enumerate().skip(1) {
            if c.is_empty() {
                return Err(format!("line 1: column {} has an empty name", i + 1));
            }
            if let Some(j) = seen.insert(c, i) {
                return Err(format!(
                    "line 1: column {c:?} appears twice (columns {} and {})",
                    j + 1,
                    i + 1
                ));
            }
            let field = c
                .rsplit_once('.')
                .and_then(|(b, f)| FIELDS.iter().position(|x| *x == f).map(|k| (b, k)));
            match field {
                Some((body, k)) if !body.is_empty() => {
                    let entry = slots.entry(body.to_string()).or_insert_with(|| {
                        bodies.push(body.to_string());
                        [None; 10]
                    });
                    entry[k] = Some(i);
                }
                _ => {
                    extras.push(c.to_string());
                    extra_idx.push(i);
                }
            }
        }
        let mut body_idx: Vec<[usize; 10]> = Vec::with_capacity(bodies.len());
        for b in &bodies {
            let s = &slots[b];
            let mut idx = [0; 10];
            for (k, slot) in s.iter().enumerate() {
                idx[k] = slot
                    .ok_or_else(|| format!("line 1: body {b:?} has no column {b}.{}", FIELDS[k]))?;
            }
            body_idx.push(idx);
        }

        let mut times = Vec::new();
        let mut body_rows = Vec::new();
        let mut extra_rows = Vec::new();
        for (n, line) in lines {
            let lineno = n + 1;
            let vals: Vec<&str> = line.split(',').map(str::trim).collect();
            if vals.len() != cols.len() {
                return Err(format!(
                    "line {lineno}: {} fields, the header has {}",
                    vals.len(),
                    cols.len()
                ));
            }
            let mut nums = Vec::with_capacity(vals.len());
            for (v, c) in vals.iter().zip(&cols) {
                let x: f64 = v
                    .parse()
                    .map_err(|_| format!("line {lineno}: column {c:?}: {v:?} is not a number"))?;
                if !x.is_finite() {
                    return Err(format!("line {lineno}: column {c:?} is not finite ({v})"));
                }
                nums.push(x);
            }
            let t = nums[0];
            if let Some(&prev) = times.last() {
                if t <= prev {
                    return Err(format!(
                        "line {lineno}: time {t} does not increase (previous {prev})"
                    ));
                }
            }
            times.push(t);
            body_rows.push(
                body_idx
                    .iter()
                    .map(|idx| idx.map(|i| nums[i]))
                    .collect::<Vec<_>>(),
            );
            extra_rows.push(extra_idx.iter().map(|&i| nums[i]).collect());
        }
        if times.is_empty() {
            return Err("no samples after the header".into());
        }
        Ok(Trajectory {
            bodies,
            extras,
            times,
            body_rows,
            extra_rows,
        })
    }

    /// Reads and parses a file; errors start with its path.
    pub fn read(path: &std::path::Path) -> Result<Trajectory, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Trajectory::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// A maximum with where it occurs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Max {
    pub value: f64,
    pub t: f64,
    /// Body (or column) name; empty when nothing was compared.
    pub at: String,
}

impl Max {
    fn update(&mut self, value: f64, t: f64, at: &str) {
        // NaN-propagating: a NaN error wins (cannot happen with parsed files, which are finite).
        if self.at.is_empty() || value > self.value || (value.is_nan() && !self.value.is_nan()) {
            self.value = value;
            self.t = t;
            self.at = at.to_string();
        }
    }
}

/// The result of comparing two trajectories.
#[derive(Clone, Debug)]
pub struct Report {
    /// Samples found in both files.
    pub matched: usize,
    /// Samples in A and in B.
    pub samples_a: usize,
    pub samples_b: usize,
    /// First and last matched time.
    pub t_first: f64,
    pub t_last: f64,
    pub bodies: usize,
    /// Max COM (`cx, cy, cz`) distance, m.
    pub com: Max,
    /// Max geodesic angle between orientations, rad.
    pub orientation: Max,
    /// Max body-origin (`x, y, z`) distance, m.
    pub origin: Max,
    /// Max absolute difference per extra column both files have (in A's order).
    pub extras: Vec<Max>,
}

impl Report {
    /// Whether every sample of each file found its match.
    pub fn all_matched(&self) -> bool {
        self.matched == self.samples_a && self.matched == self.samples_b
    }
}

fn dist3(a: &[f64], b: &[f64]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Geodesic angle between the rotations of two quaternions `(w, x, y, z)` (need not be
/// exactly unit): `2·acos(|⟨q̂_a, q̂_b⟩|)`, evaluated stably.
pub fn rotation_angle(a: &[f64], b: &[f64]) -> f64 {
    let norm = |q: &[f64]| q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let (na, nb) = (norm(a), norm(b));
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let s = if dot < 0.0 { -1.0 } else { 1.0 };
    let (mut dm, mut dp) = (0.0, 0.0);
    for k in 0..4 {
        let (x, y) = (a[k] / na, s * b[k] / nb);
        dm += (x - y) * (x - y);
        dp += (x + y) * (x + y);
    }
    4.0 * dm.sqrt().atan2(dp.sqrt())
}

/// Compares two trajectories of the same scene.
pub fn compare(a: &Trajectory, b: &Trajectory) -> Result<Report, String> {
    let pos_b: BTreeMap<&str, usize> = b
        .bodies
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i))
        .collect();
    let only_a: Vec<&str> = a
        .bodies
        .iter()
        .filter(|n| !pos_b.contains_key(n.as_str()))
        .map(String::as_str)
        .collect();
    let only_b: Vec<&str> = b
        .bodies
        .iter()
        .filter(|n| !a.bodies.contains(n))
        .map(String::as_str)
        .collect();
    if !only_a.is_empty() || !only_b.is_empty() {
        return Err(format!(
            "the files hold different bodies (only in A: [{}]; only in B: [{}])",
            only_a.join(", "),
            only_b.join(", ")
        ));
    }
    let map: Vec<usize> = a.bodies.iter().map(|n| pos_b[n.as_str()]).collect();
    let extra_map: Vec<(usize, usize)> = a
        .extras
        .iter()
        .enumerate()
        .filter_map(|(i, n)| b.extras.iter().position(|m| m == n).map(|j| (i, j)))
        .collect();

    let mut rep = Report {
        matched: 0,
        samples_a: a.times.len(),
        samples_b: b.times.len(),
        t_first: f64::NAN,
        t_last: f64::NAN,
        bodies: a.bodies.len(),
        com: Max::default(),
        orientation: Max::default(),
        origin: Max::default(),
        extras: extra_map
            .iter()
            .map(|&(i, _)| Max {
                value: 0.0,
                t: 0.0,
                at: a.extras[i].clone(),
            })
            .collect(),
    };
    let (mut i, mut j) = (0, 0);
    while i < a.times.len() && j < b.times.len() {
        let (ta, tb) = (a.times[i], b.times[j]);
        let tol = TIME_TOL * 1f64.max(ta.abs().max(tb.abs()));
        if ta < tb - tol {
            i += 1;
            continue;
        }
        if tb < ta - tol {
            j += 1;
            continue;
        }
        if rep.matched == 0 {
            rep.t_first = ta;
        }
        rep.t_last = ta;
        rep.matched += 1;
        for (k, name) in a.bodies.iter().enumerate() {
            let ra = &a.body_rows[i][k];
            let rb = &b.body_rows[j][map[k]];
            rep.origin.update(dist3(&ra[0..3], &rb[0..3]), ta, name);
            rep.orientation
                .update(rotation_angle(&ra[3..7], &rb[3..7]), ta, name);
            rep.com.update(dist3(&ra[7..10], &rb[7..10]), ta, name);
        }
        for (m, &(ia, ib)) in extra_map.iter().enumerate() {
            let d = (a.extra_rows[i][ia] - b.extra_rows[j][ib]).abs();
            let name = rep.extras[m].at.clone();
            rep.extras[m].update(d, ta, &name);
        }
        i += 1;
        j += 1;
    }
    if rep.matched == 0 {
        return Err(format!(
            "no sample times in common (A: {} samples in [{}, {}]; B: {} in [{}, {}])",
            a.times.len(),
            a.times[0],
            a.times[a.times.len() - 1],
            b.times.len(),
            b.times[0],
            b.times[b.times.len() - 1]
        ));
    }
    Ok(rep)
}

/// The printed summary (also what `verify --mujoco` shows per scene).
pub fn format_report(rep: &Report) -> String {
    let mut s = format!(
        "compared {} samples (A has {}, B has {}), {} bodies, t in [{}, {}] s\n",
        rep.matched, rep.samples_a, rep.samples_b, rep.bodies, rep.t_first, rep.t_last
    );
    let line = |what: &str, m: &Max, unit: &str| {
        format!(
            "{what:<24} {:.6e} {unit:<3} at t = {} s, body {}\n",
            m.value, m.t, m.at
        )
    };
    s += &line("max COM position error", &rep.com, "m");
    s += &line("max orientation error", &rep.orientation, "rad");
    s += &line("max body-origin error", &rep.origin, "m");
    for e in &rep.extras {
        s += &format!(
            "{:<24} {:.6e}     at t = {} s\n",
            format!("max |Δ {}|", e.at),
            e.value,
            e.t
        );
    }
    if !rep.all_matched() {
        s += "warning: not every sample has a match in the other file\n";
    }
    s
}

pub fn main(args: &[String]) -> Result<(), String> {
    let [a, b] = args else {
        return Err("usage: cargo xtask compare A.csv B.csv".into());
    };
    let ta = Trajectory::read(std::path::Path::new(a))?;
    let tb = Trajectory::read(std::path::Path::new(b))?;
    let rep = compare(&ta, &tb).map_err(|e| format!("{a} vs {b}: {e}"))?;
    print!("{}", format_report(&rep));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(bodies: &[&str], extras: &[&str]) -> String {
        let mut h = vec!["t".to_string()];
        for b in bodies {
            h.extend(FIELDS.iter().map(|f| format!("{b}.{f}")));
        }
        h.extend(extras.iter().map(|e| e.to_string()));
        h.join(",")
    }

    /// One row: body k at x = (k + t, 0, 0), identity orientation rotated by `angle` about z,
    /// COM offset by `dc` along y; extras all `e`.
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
    fn parses_and_compares_identical_files_to_zero() {
        let text = format!(
            "{}\n{}\n{}\n",
            head(&["a", "b"], &["E_tot"]),
            row(0.0, 2, 0.1, 0.0, 1, 3.0),
            row(0.01, 2, 0.2, 0.0, 1, 3.0)
        );
        let t = Trajectory::parse(&text).unwrap();
        assert_eq!(t.bodies, ["a", "b"]);
        assert_eq!(t.extras, ["E_tot"]);
        assert_eq!(t.times, [0.0, 0.01]);
        let r = compare(&t, &t).unwrap();
        assert_eq!(r.matched, 2);
        assert!(r.all_matched());
        assert_eq!(r.com.value, 0.0);
        assert_eq!(r.orientation.value, 0.0);
        assert_eq!(r.origin.value, 0.0);
        assert_eq!(r.extras[0].value, 0.0);
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
        // t = 1 (for both bodies: the first in A's order is reported), E_tot off by 0.5.
        let hb = head(&["b", "a"], &["E_tot"]);
        let b = Trajectory::parse(&format!(
            "{hb}\n{}\n{}\n{}\n",
            row(0.0, 2, 0.0, 0.0, 1, 1.0),
            row(0.5, 2, 0.0, 0.25, 1, 1.5),
            row(1.0, 2, 0.3, 0.0, 1, 1.0)
        ))
        .unwrap();
        // The bodies swap names, so positions differ by one (x_k = k + t) at every sample.
        let r = compare(&a, &b).unwrap();
        assert_eq!(r.matched, 3);
        assert!((r.origin.value - 1.0).abs() < 1e-15);
        assert!((r.com.value - (1.0f64 + 0.0625).sqrt()).abs() < 1e-15);
        assert_eq!(r.com.t, 0.5);
        assert!(
            (r.orientation.value - 0.3).abs() < 1e-14,
            "{}",
            r.orientation.value
        );
        assert_eq!(r.orientation.t, 1.0);
        assert_eq!(r.orientation.at, "a");
        assert_eq!(r.extras[0].value, 0.5);
        assert_eq!(r.extras[0].t, 0.5);
        assert!(format_report(&r).contains("max COM position error"));
    }

    #[test]
    fn rotation_angle_is_accurate_for_tiny_and_sign_flipped_quaternions() {
        let q = |a: f64| [(a / 2.0).cos(), 0.0, (a / 2.0).sin(), 0.0];
        let e = 1e-12;
        let got = rotation_angle(&q(1.0), &q(1.0 + e));
        assert!((got - e).abs() < 1e-15, "{got}");
        let neg: Vec<f64> = q(0.7).iter().map(|x| -x).collect();
        assert!(rotation_angle(&q(0.7), &neg) < 1e-15);
        assert!((rotation_angle(&q(0.0), &q(3.0)) - 3.0).abs() < 1e-14);
        // Beyond pi the short way round is reported.
        assert!(
            (rotation_angle(&q(0.0), &q(4.0)) - (2.0 * std::f64::consts::PI - 4.0)).abs() < 1e-14
        );
    }

    #[test]
    fn matches_rows_by_time_across_sampling_rates() {
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
        assert_eq!(r.matched, 6);
        assert!(!r.all_matched());
        assert_eq!(r.t_last, 1.0);
        assert!(format_report(&r).contains("warning"));
    }

    #[test]
    fn malformed_files_are_errors() {
        let h = head(&["a"], &[]);
        let ok = row(0.0, 1, 0.0, 0.0, 0, 0.0);
        let cases = [
            ("".to_string(), "empty"),
            (format!("{h}\n"), "no samples"),
            (format!("x,{}\n{ok}\n", &h[2..]), "first column"),
            (format!("{h}\n{ok},1\n"), "fields"),
            (
                format!("{h}\n{}\n", ok.replacen("0.0", "abc", 1)),
                "not a number",
            ),
            (
                format!("{h}\n{}\n", ok.replacen("0.0", "NaN", 1)),
                "not finite",
            ),
            (format!("{h}\n{ok}\n{ok}\n"), "does not increase"),
            (format!("{},a.x\n{ok},0\n", h), "twice"),
            (format!("{}\n0,1,2,3\n", "t,a.x,a.y,a.z"), "no column a.qw"),
        ];
        for (text, want) in cases {
            let e = Trajectory::parse(&text).expect_err(want);
            assert!(e.contains(want), "{want:?} not in {e:?}");
        }
    }

    #[test]
    fn mismatched_bodies_or_times_are_errors() {
        let a = Trajectory::parse(&format!(
            "{}\n{}\n",
            head(&["a", "b"], &[]),
            row(0.0, 2, 0.0, 0.0, 0, 0.0)
        ))
        .unwrap();
        let b = Trajectory::parse(&format!(
            "{}\n{}\n",
            head(&["a", "c"], &[]),
            row(0.0, 2, 0.0, 0.0, 0, 0.0)
        ))
        .unwrap();
        let e = compare(&a, &b).unwrap_err();
        assert!(
            e.contains("only in A: [b]") && e.contains("only in B: [c]"),
            "{e}"
        );
        let c = Trajectory::parse(&format!(
            "{}\n{}\n",
            head(&["a", "b"], &[]),
            row(1.0, 2, 0.0, 0.0, 0, 0.0)
        ))
        .unwrap();
        assert!(compare(&a, &c)
            .unwrap_err()
            .contains("no sample times in common"));
    }
}
