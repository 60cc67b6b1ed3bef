//! Trajectory files (DESIGN.md §6) and their comparison (§7).
//!
//! CSV with one header row `t,<body>.x,<body>.y,<body>.z,<body>.qw,…,<body>.cz,…` and one
//! row per sample. [`compare`] matches columns by name and rows by time and reports the
//! largest centre-of-mass error (m), orientation error (geodesic angle
//! `2 acos |⟨q_a, q_b⟩|`, rad) and body-origin error, each with where it occurs.

use std::fmt::Write as _;

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

    /// Parses CSV text. Errors name the line.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, head) = lines.next().ok_or("empty file")?;
        let header: Vec<String> = head.split(',').map(|s| s.trim().to_string()).collect();
        if header.first().map(String::as_str) != Some("t") {
            return Err("first column must be `t`".into());
        }
        let mut rows = Vec::new();
        for (i, l) in lines {
            let row: Result<Vec<f64>, _> = l.split(',').map(|s| s.trim().parse::<f64>()).collect();
            let row = row.map_err(|e| format!("line {}: {e}", i + 1))?;
            if row.len() != header.len() {
                return Err(format!(
                    "line {}: {} fields, header has {}",
                    i + 1,
                    row.len(),
                    header.len()
                ));
            }
            rows.push(row);
        }
        Ok(Self { header, rows })
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

/// The largest differences between two trajectories.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Comparison {
    /// Max centre-of-mass distance (m), its time and body.
    pub com: (f64, f64, String),
    /// Max orientation angle (rad), its time and body.
    pub angle: (f64, f64, String),
    /// Max body-origin distance (m), its time and body.
    pub origin: (f64, f64, String),
    /// Samples compared.
    pub samples: usize,
}

/// Compares `a` against `b` at the times they share (to `1e-9 max(1, t)`). Errors: body
/// sets differ, no common time, missing columns.
pub fn compare(a: &Trajectory, b: &Trajectory) -> Result<Comparison, String> {
    let bodies = a.bodies();
    if bodies != b.bodies() {
        return Err(format!(
            "different bodies: {:?} vs {:?}",
            bodies,
            b.bodies()
        ));
    }
    let cols = |t: &Trajectory, n: &str| -> Result<Vec<usize>, String> {
        BODY_COLUMNS
            .iter()
            .map(|c| {
                t.col(&format!("{n}.{c}"))
                    .ok_or(format!("missing column {n}.{c}"))
            })
            .collect()
    };
    let mut out = Comparison::default();
    let mut j = 0;
    for ra in &a.rows {
        let t = ra[0];
        while j < b.rows.len() && b.rows[j][0] < t - 1e-9 * t.abs().max(1.0) {
            j += 1;
        }
        let Some(rb) = b.rows.get(j) else { break };
        if (rb[0] - t).abs() > 1e-9 * t.abs().max(1.0) {
            continue;
        }
        out.samples += 1;
        for n in &bodies {
            let (ca, cb) = (cols(a, n)?, cols(b, n)?);
            let dist = |k: usize| {
                ((0..3)
                    .map(|d| (ra[ca[k + d]] - rb[cb[k + d]]).powi(2))
                    .sum::<f64>())
                .sqrt()
            };
            let dot: f64 = (0..4).map(|d| ra[ca[3 + d]] * rb[cb[3 + d]]).sum();
            let angle = 2.0 * dot.abs().min(1.0).acos();
            for (slot, v) in [
                (&mut out.com, dist(7)),
                (&mut out.origin, dist(0)),
                (&mut out.angle, angle),
            ] {
                if !(v <= slot.0) {
                    *slot = (v, t, n.clone());
                }
            }
        }
    }
    if out.samples == 0 {
        return Err("no common sample times".into());
    }
    Ok(out)
}
