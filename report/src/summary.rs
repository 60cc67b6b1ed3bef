//! The one screen that opens `report.html`: read back from the files a report run left
//! in its folder, so that the page converted from `report.md` (written by
//! `cargo xtask verify`) and the sweeps' own page open the same way.
//!
//! * the fastest method at each error level per scene family, from the work-precision
//!   CSVs (`work_precision.csv`: the cloth; `particle_work_precision.csv` and
//!   `articulated_work_precision.csv`, `contact_scenes.csv`: one family per scene), cost
//!   in run time per simulated second;
//! * the stability verdicts: per map (`stability.csv`: the cloth;
//!   `{chain,articulated,contact}_stability.csv`) the cells by class and the formulation
//!   with the most stable cells;
//! * the checks: passed and failed stages of the report's `## Checks` table, the
//!   bad-input sweep's line, and the number of pinned state hashes
//!   (`verify/tests/state_hashes.rs`);
//! * the benchmark ratios: the first table of `../bench/ratios.md` when a
//!   `cargo xtask bench` run left one;
//! * a table of contents of the level-2 headings.
//!
//! Every number is read, none is computed anew; a missing file leaves its part saying so.
//! The text depends only on the files (no dates, no map iteration order).

use std::fmt::Write as _;
use std::path::Path;

use crate::heatmap::tick;
use crate::html::headings;

/// Error levels (m) of the fastest-method table.
pub const LEVELS: [f64; 4] = [1e-1, 1e-2, 1e-3, 1e-5];

/// One work-precision point read back.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Scene family (`cloth`, or the scene column).
    pub family: String,
    /// Method label.
    pub method: String,
    /// Time step (s).
    pub h: f64,
    /// Run time per simulated second (s/s).
    pub cost: f64,
    /// Error (m).
    pub error: f64,
}

/// Splits `line` into `n` fields, the first `lead` from the left and the rest from the
/// right, so that the one free-text field between them (a method label) may hold
/// commas. `None` when there are too few.
fn fields(line: &str, lead: usize, n: usize) -> Option<Vec<&str>> {
    let mut left: Vec<&str> = line.splitn(lead + 1, ',').collect();
    let rest = left.pop()?;
    if left.len() != lead {
        return None;
    }
    let mut right: Vec<&str> = rest.rsplitn(n - lead, ',').collect();
    if right.len() != n - lead {
        return None;
    }
    right.reverse();
    left.extend(right);
    Some(left)
}

/// Work-precision points of the CSV text `csv` in the layout of `file` (failed runs and
/// unreadable lines left out).
pub fn parse_points(file: &str, csv: &str) -> Vec<Point> {
    let num = |s: &str| s.trim().parse::<f64>().ok().filter(|x| x.is_finite());
    csv.lines()
        .skip(1)
        .filter_map(|line| match file {
            // method,h,cost_s_per_s,error_m,failure
            "work_precision.csv" => {
                let f = fields(line, 0, 5)?;
                Some(Point {
                    family: "cloth".into(),
                    method: f[0].into(),
                    h: num(f[1])?,
                    cost: num(f[2])?,
                    error: num(f[3])?,
                })
            }
            // scene,method,h,cost_s_per_s,error_m,failure
            "particle_work_precision.csv" => {
                let f = fields(line, 1, 6)?;
                Some(Point {
                    family: f[0].into(),
                    method: f[1].into(),
                    h: num(f[2])?,
                    cost: num(f[3])?,
                    error: num(f[4])?,
                })
            }
            // scene,method,dt,com_error_m,seconds_per_step,c_max_m,failure
            "articulated_work_precision.csv" => {
                let f = fields(line, 1, 7)?;
                let h = num(f[2])?;
                Some(Point {
                    family: f[0].into(),
                    method: f[1].into(),
                    h,
                    cost: num(f[4])? / h,
                    error: num(f[3])?,
                })
            }
            // scene,solver,dt,error_m,seconds_per_step,max_contacts,iterations_per_step,
            // worst_residual,failure
            "contact_scenes.csv" => {
                let f = fields(line, 1, 9)?;
                let h = num(f[2])?;
                Some(Point {
                    family: f[0].into(),
                    method: f[1].into(),
                    h,
                    cost: num(f[4])? / h,
                    error: num(f[3])?,
                })
            }
            _ => None,
        })
        .collect()
}

/// The cheapest point of `family` with error at most `level` (ties: the first).
pub fn fastest<'a>(points: &'a [Point], family: &str, level: f64) -> Option<&'a Point> {
    points
        .iter()
        .filter(|p| p.family == family && p.error <= level)
        .fold(None, |best: Option<&Point>, p| match best {
            Some(b) if b.cost <= p.cost => Some(b),
            _ => Some(p),
        })
}

/// Cells by class of one stability map read back.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Verdict {
    /// Map name.
    pub map: String,
    /// Per formulation (in first-seen order): stable, inaccurate, unstable, panics.
    pub methods: Vec<(String, [usize; 4])>,
}

impl Verdict {
    /// Totals over the formulations.
    pub fn total(&self) -> [usize; 4] {
        let mut t = [0; 4];
        for (_, c) in &self.methods {
            for k in 0..4 {
                t[k] += c[k];
            }
        }
        t
    }
}

/// The column of a class name: 0 stable, 1 inaccurate (the cloth's CG iteration limit,
/// `NotConverged`, included), 2 unstable, 3 panic.
fn class_column(class: &str) -> usize {
    match class.trim() {
        "Stable" => 0,
        "Inaccurate" | "NotConverged" => 1,
        "Panicked" => 3,
        _ => 2,
    }
}

/// The verdict of the map `name` from its CSV text: the cloth's `stability.csv`
/// (`method,k,h,outcome`) or a `{name}_stability.csv` (method second, class eighth).
pub fn parse_verdict(name: &str, csv: &str) -> Verdict {
    let mut v = Verdict {
        map: name.into(),
        methods: Vec::new(),
    };
    for line in csv.lines().skip(1) {
        let (method, class) = if name == "cloth" {
            match fields(line, 0, 4) {
                Some(f) => (f[0].to_string(), f[3].to_string()),
                None => continue,
            }
        } else {
            let f: Vec<&str> = line.split(',').collect();
            match (f.get(1), f.get(7)) {
                (Some(m), Some(c)) => (m.to_string(), c.to_string()),
                _ => continue,
            }
        };
        let col = class_column(&class);
        match v.methods.iter_mut().find(|(m, _)| *m == method) {
            Some((_, c)) => c[col] += 1,
            None => {
                let mut c = [0; 4];
                c[col] = 1;
                v.methods.push((method, c));
            }
        }
    }
    v
}

/// The stages of a `## Checks` table (`| stage | result | …`): (name, passed).
pub fn checks(md: &str) -> Vec<(String, bool)> {
    let mut inside = false;
    let mut out = Vec::new();
    for line in md.lines() {
        let t = line.trim();
        if t.starts_with("## ") {
            inside = t == "## Checks";
            continue;
        }
        if !inside || !t.starts_with('|') {
            continue;
        }
        let c: Vec<&str> = t.trim_matches('|').split('|').map(str::trim).collect();
        if c.len() >= 2 && (c[1] == "pass" || c[1] == "FAIL") {
            out.push((c[0].to_string(), c[1] == "pass"));
        }
    }
    out
}

/// The first pipe table of `md`, verbatim.
fn first_table(md: &str) -> Option<String> {
    let lines: Vec<&str> = md.lines().collect();
    let start = lines.iter().position(|l| l.trim().starts_with('|'))?;
    let rows: Vec<&str> = lines[start..]
        .iter()
        .take_while(|l| l.trim().starts_with('|'))
        .copied()
        .collect();
    Some(rows.join("\n"))
}

/// Pinned state hashes: the 64-bit hexadecimal literals (`0x` and 16 digits) of `src`.
pub fn count_pins(src: &str) -> usize {
    src.match_indices("0x")
        .filter(|(i, _)| {
            let digits = &src[i + 2..];
            digits.len() >= 16
                && digits.as_bytes()[..16].iter().all(u8::is_ascii_hexdigit)
                && !digits.as_bytes().get(16).is_some_and(u8::is_ascii_hexdigit)
        })
        .count()
}

/// The summary section and table of contents for the report `md` whose files lie in
/// `dir` (the pins are counted in `root`'s `verify/tests/state_hashes.rs`).
pub fn section(md: &str, dir: &Path, root: &Path) -> String {
    let read = |p: &Path| std::fs::read_to_string(p).ok();
    let mut s = String::from("## At a glance\n\n");

    // Checks.
    let stages = checks(md);
    let failed: Vec<&str> = stages
        .iter()
        .filter(|(_, ok)| !ok)
        .map(|(n, _)| n.as_str())
        .collect();
    if stages.is_empty() {
        s.push_str("- **Checks**: no checks table in this report (the sweeps' own page).\n");
    } else if failed.is_empty() {
        let _ = writeln!(s, "- **Checks**: all {} stages pass.", stages.len());
    } else {
        let _ = writeln!(
            s,
            "- **Checks**: {} of {} stages pass; FAILED: {}.",
            stages.len() - failed.len(),
            stages.len(),
            failed.join(", ")
        );
    }
    match md
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("bad-input sweep:"))
    {
        Some(l) => {
            let _ = writeln!(
                s,
                "- **Bad input**: {}",
                l.trim_start_matches("bad-input sweep:").trim()
            );
        }
        None => s.push_str("- **Bad input**: the sweep's line is not in this report.\n"),
    }
    match read(&root.join("verify/tests/state_hashes.rs")) {
        Some(src) => {
            let _ = writeln!(
                s,
                "- **Pins**: {} state hashes pinned in `verify/tests/state_hashes.rs` (checked by the pins stage, or by the tests stage with `--ci`).",
                count_pins(&src)
            );
        }
        None => s.push_str("- **Pins**: `verify/tests/state_hashes.rs` not found.\n"),
    }
    s.push('\n');

    // Stability verdicts.
    let maps = [
        ("cloth", "stability.csv"),
        ("chain", "chain_stability.csv"),
        ("articulated", "articulated_stability.csv"),
        ("contact", "contact_stability.csv"),
    ];
    let verdicts: Vec<Verdict> = maps
        .iter()
        .filter_map(|(name, file)| read(&dir.join(file)).map(|csv| parse_verdict(name, &csv)))
        .collect();
    s.push_str("### Stability verdicts\n\n");
    if verdicts.is_empty() {
        s.push_str("No stability map in this folder.\n\n");
    } else {
        s.push_str("| map | cells | ✓ stable | ~ inaccurate | unstable | panics | most stable cells |\n|---|---|---|---|---|---|---|\n");
        for v in &verdicts {
            let t = v.total();
            let best = v
                .methods
                .iter()
                .fold(None, |b: Option<&(String, [usize; 4])>, m| match b {
                    Some(b) if b.1[0] >= m.1[0] => Some(b),
                    _ => Some(m),
                })
                .map_or("—".to_string(), |(m, c)| format!("{m} ({})", c[0]));
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {best} |",
                v.map,
                t.iter().sum::<usize>(),
                t[0],
                t[1],
                t[2],
                t[3]
            );
        }
        s.push('\n');
    }

    // Fastest method per error level.
    let mut points = Vec::new();
    for file in [
        "work_precision.csv",
        "particle_work_precision.csv",
        "articulated_work_precision.csv",
        "contact_scenes.csv",
    ] {
        if let Some(csv) = read(&dir.join(file)) {
            points.extend(parse_points(file, &csv));
        }
    }
    let mut families: Vec<&str> = Vec::new();
    for p in &points {
        if !families.contains(&p.family.as_str()) {
            families.push(&p.family);
        }
    }
    s.push_str("### Fastest method at each error level\n\n");
    if families.is_empty() {
        s.push_str("No work-precision data in this folder.\n\n");
    } else {
        s.push_str("Cheapest run (method, step, run time per simulated second) whose max error is at most the level; — where none reaches it.\n\n| scene |");
        let mut sep = String::from("|---|");
        for l in LEVELS {
            let _ = write!(s, " error ≤ {} m |", tick(l));
            sep.push_str("---|");
        }
        let _ = writeln!(s, "\n{sep}");
        for f in &families {
            let _ = write!(s, "| {f} |");
            for l in LEVELS {
                match fastest(&points, f, l) {
                    Some(p) => {
                        let _ = write!(
                            s,
                            " {} (h = {}): {:.2e} s/s |",
                            p.method.replace('|', "\\|"),
                            tick(p.h),
                            p.cost
                        );
                    }
                    None => s.push_str(" — |"),
                }
            }
            s.push('\n');
        }
        s.push('\n');
    }

    // Benchmarks.
    s.push_str("### Benchmark ratios\n\n");
    match dir
        .parent()
        .and_then(|p| read(&p.join("bench/ratios.md")))
        .and_then(|r| first_table(&r))
    {
        Some(t) => {
            let _ = writeln!(s, "From `target/bench/ratios.md` (`cargo xtask bench`):\n\n{t}\n");
        }
        None => s.push_str(
            "No benchmark run beside this report (`cargo xtask bench` writes `target/bench/ratios.md`).\n\n",
        ),
    }

    s
}

/// `md` with [`section`] and a table of contents (the level-2 headings after it, linked
/// by the ids the page gives them, [`headings`]) inserted before its first level-2
/// heading (at the end when it has none).
pub fn with_summary(md: &str, dir: &Path, root: &Path) -> String {
    let summary = section(md, dir, root);
    let mut at = md.len();
    let mut offset = 0;
    let mut fenced = false;
    for line in md.split_inclusive('\n') {
        let t = line.trim();
        if t.starts_with("```") {
            fenced = !fenced;
        } else if !fenced && t.starts_with("## ") {
            at = offset;
            break;
        }
        offset += line.len();
    }
    let mut head = String::with_capacity(md.len() + summary.len() + 1);
    head.push_str(&md[..at]);
    if !head.is_empty() && !head.ends_with("\n\n") {
        head.push('\n');
    }
    head.push_str(&summary);
    head.push_str("### Contents\n\n");
    // The ids as the page will give them: the contents' bullets are no headings, so
    // adding them changes none.
    let before = headings(&head).len();
    let all = headings(&format!("{head}{}", &md[at..]));
    for h in all.iter().skip(before).filter(|h| h.level == 2) {
        let _ = writeln!(head, "- [{}](#{})", h.text, h.id);
    }
    head.push('\n');
    head.push_str(&md[at..]);
    head
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_with_commas_parse_from_both_ends() {
        let csv = "method,h,cost_s_per_s,error_m,failure\nsoft, implicit,1e-2,3e-1,2e-3,\nx,1e-3,1e0,,diverged\n";
        let p = parse_points("work_precision.csv", csv);
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!(p[0].method, "soft, implicit");
        assert_eq!((p[0].h, p[0].cost, p[0].error), (1e-2, 3e-1, 2e-3));
        let a = "scene,method,dt,com_error_m,seconds_per_step,c_max_m,failure\nchain20,RATTLE,1e-3,2e-4,5e-6,1e-9,\n";
        let p = parse_points("articulated_work_precision.csv", a);
        // 5e-6 s per step at 1e-3 s: 5e-3 s per simulated second (to rounding).
        assert!((p[0].cost - 5e-3).abs() < 1e-15, "{p:?}");
        let c = "scene,solver,dt,error_m,seconds_per_step,max_contacts,iterations_per_step,worst_residual,failure\n\
                 stack,Newton,1e-2,3e-3,2e-4,12,4e0,1e-11,\nstack,Lemke,1e-2,,,,,,singular\n";
        let p = parse_points("contact_scenes.csv", c);
        assert_eq!(p.len(), 1, "{p:?}");
        // 2e-4 s per step at 1e-2 s: 2e-2 s per simulated second (to rounding).
        assert!(
            (p[0].cost - 2e-2).abs() < 1e-15 && p[0].error == 3e-3,
            "{p:?}"
        );
    }

    #[test]
    fn the_fastest_point_is_the_cheapest_within_the_level() {
        let pt = |m: &str, cost, error| Point {
            family: "f".into(),
            method: m.into(),
            h: 1e-3,
            cost,
            error,
        };
        let pts = [pt("a", 1.0, 1e-2), pt("b", 0.5, 1e-1), pt("c", 2.0, 1e-4)];
        assert_eq!(
            fastest(&pts, "f", 1e-1).map(|p| p.method.as_str()),
            Some("b")
        );
        assert_eq!(
            fastest(&pts, "f", 1e-2).map(|p| p.method.as_str()),
            Some("a")
        );
        assert_eq!(
            fastest(&pts, "f", 1e-3).map(|p| p.method.as_str()),
            Some("c")
        );
        assert!(fastest(&pts, "f", 1e-5).is_none());
        assert!(fastest(&pts, "g", 1.0).is_none());
    }

    #[test]
    fn verdicts_count_classes_per_method() {
        let csv = "axis,method,h,links,tip_ratio,violation,stiffness,class,steps\n\
                   mass,RATTLE,1e-3,10,1,0,inf,Stable,5\n\
                   mass,RATTLE,1e-2,10,1,0,inf,Diverged,5\n\
                   mass,velocity,1e-3,10,1,0,inf,Inaccurate,5\n";
        let v = parse_verdict("chain", csv);
        assert_eq!(
            v.methods,
            [
                ("RATTLE".to_string(), [1, 0, 1, 0]),
                ("velocity".to_string(), [0, 1, 0, 0])
            ]
        );
        let cloth = parse_verdict(
            "cloth",
            "method,k,h,outcome\nimplicit, CG,1e1,1e-3,NotConverged\n",
        );
        assert_eq!(cloth.methods, [("implicit, CG".to_string(), [0, 1, 0, 0])]);
    }

    #[test]
    fn checks_pins_and_placement() {
        let md = "# R\n\nintro\n\n## Checks\n\n| stage | result | time (s) | note |\n|---|---|---|---|\n| fmt | pass | 1 | |\n| tests | FAIL | 2 | |\n\n## Next\n";
        assert_eq!(
            checks(md),
            [("fmt".to_string(), true), ("tests".to_string(), false)]
        );
        assert_eq!(
            count_pins("(\"a\", 0x0123456789abcdef), 0x12, 0x0123456789abcdef0"),
            1
        );
        let dir = Path::new("/nonexistent-report-dir");
        let page = with_summary(md, dir, dir);
        let glance = page.find("## At a glance").unwrap_or(usize::MAX);
        assert!(page.find("intro").unwrap_or(usize::MAX) < glance);
        assert!(glance < page.find("## Checks").unwrap_or(0));
        assert!(page.contains("1 of 2 stages pass; FAILED: tests."));
        assert!(page.contains("- [Checks](#checks)\n- [Next](#next)\n"));
    }
}
