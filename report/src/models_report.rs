//! The "Real models" section of the verification report: the gymnasium and dm_control
//! models as `cargo xtask models run` measured them (its `models.csv`, one line per
//! model and case), as a per-model table and two charts — our time per step over
//! MuJoCo's per model and case, and the smooth models' trajectory error, ours against
//! MuJoCo Euler (both at the file's step, against MuJoCo RK4 at a tenth of it).
//!
//! Which models load is read from the file, never assumed here.

use std::fmt::Write as _;

use crate::bar_chart::BarChart;

/// One line of `models.csv`: a model and a case, fields by column name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CaseLine {
    fields: Vec<(String, String)>,
}

impl CaseLine {
    /// The field of column `name` (empty when absent).
    pub fn get(&self, name: &str) -> &str {
        self.fields
            .iter()
            .find(|(k, _)| k == name)
            .map_or("", |(_, v)| v.as_str())
    }

    /// The field as a number (`None`: empty or not a number).
    pub fn num(&self, name: &str) -> Option<f64> {
        self.get(name).parse().ok()
    }

    fn flag(&self, name: &str) -> bool {
        self.get(name) == "true"
    }
}

/// Splits one CSV line (RFC 4180, no line breaks inside fields).
fn split_csv(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quoted, mut chars) =
        (Vec::new(), String::new(), false, line.chars().peekable());
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            (c, _) => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// Parses `models.csv`. Errors: no header, no `model`/`case` column, a line with a
/// different number of fields (named by line).
pub fn parse(text: &str) -> Result<Vec<CaseLine>, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let header = split_csv(lines.next().ok_or("models.csv: empty")?.1);
    for need in ["model", "suite", "case"] {
        if !header.iter().any(|h| h == need) {
            return Err(format!("models.csv: no column {need:?}"));
        }
    }
    lines
        .map(|(i, l)| {
            let f = split_csv(l);
            if f.len() != header.len() {
                return Err(format!(
                    "models.csv line {}: {} fields, the header has {}",
                    i + 1,
                    f.len(),
                    header.len()
                ));
            }
            Ok(CaseLine {
                fields: header.iter().cloned().zip(f).collect(),
            })
        })
        .collect()
}

/// One model: its lines in file order.
struct Model<'a> {
    key: String,
    lines: Vec<&'a CaseLine>,
}

impl Model<'_> {
    fn case(&self, c: &str) -> Option<&CaseLine> {
        self.lines.iter().copied().find(|l| l.get("case") == c)
    }

    fn loads(&self) -> bool {
        self.lines.iter().any(|l| l.flag("ours_loads"))
    }

    /// The worst of a figure over the finished cases.
    fn worst(&self, col: &str, only: impl Fn(&CaseLine) -> bool) -> Option<f64> {
        self.lines
            .iter()
            .filter(|l| only(l))
            .filter_map(|l| l.num(col))
            .reduce(f64::max)
    }
}

fn models(lines: &[CaseLine]) -> Vec<Model<'_>> {
    let mut out: Vec<Model> = Vec::new();
    for l in lines {
        let key = format!("{}/{}", l.get("suite"), l.get("model"));
        match out.iter_mut().find(|m| m.key == key) {
            Some(m) => m.lines.push(l),
            None => out.push(Model {
                key,
                lines: vec![l],
            }),
        }
    }
    out
}

fn sci(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| format!("{t:.1e}"))
}

fn fixed(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| format!("{t:.2}"))
}

fn ratio(v: Option<f64>) -> String {
    v.map_or("–".into(), |t| {
        if t < 0.01 {
            format!("{t:.1e}")
        } else {
            format!("{t:.2}")
        }
    })
}

/// `first contact ours / MuJoCo; root z ours / MuJoCo` of a finished passive case.
fn agree(p: &CaseLine) -> String {
    if p.get("finite").is_empty() {
        return "–".into();
    }
    let t = |c: &str| p.num(c).map_or("none".into(), |v| format!("{v:.3}"));
    let z = |c: &str| p.num(c).map_or("–".into(), |v| format!("{v:.3}"));
    format!(
        "{} / {}; {} / {}",
        t("ours_first_contact"),
        t("mujoco_first_contact"),
        z("ours_root_z"),
        z("mujoco_root_z")
    )
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace(['\n', '\r'], " ")
}

/// The time-ratio chart [`section`] writes, relative to the report.
pub const TIME_CHART: &str = "models_time_ratio.svg";
/// The smooth-model error chart [`section`] writes, relative to the report.
pub const SMOOTH_CHART: &str = "models_smooth_error.svg";

/// The report section (Markdown) and the charts `(file name, SVG)`. `how`: the command
/// that produced the file and its run lengths, quoted in the section.
pub fn section(lines: &[CaseLine], how: &str) -> (String, Vec<(String, String)>) {
    let ms = models(lines);
    let mut md = String::new();
    let _ = writeln!(md, "## Real models (gymnasium and dm_control)\n");
    let _ = writeln!(
        md,
        "{how}. Each model runs in MuJoCo and here, at the file's time step, in three \
         cases: **passive** (qpos0, zero control), **perturbed** (zero control, from qpos0 \
         plus a seeded perturbation of every hinge and slide coordinate and velocity, the \
         same `--qpos/--qvel` given to both engines) and **controlled** (one seeded \
         piecewise-constant control sequence in ctrlrange, the same CSV fed to both). \
         Ours: the `simulate` binary, default method. Checks: finite state, worst joint \
         separation ≤ 1e-6 m, settled penetration (second half of the run) ≤ 1e-3 m, energy \
         rise ≤ 1e-4·(1 + |E₀|) on the runs without control and without contact. MuJoCo's \
         contacts are soft and ours hard, so contact-rich models part after the first \
         impact: for them the table compares what both must agree on, the time of the first \
         contact and the height of the root body at the end of the passive run. A model \
         that does not load is a table entry with its typed reason; a panic (loading or \
         stepping), or a loaded model that diverges, fails the run. Times: the two engines \
         timed alternately in repeats, the ratio the median of the per-repeat ratios \
         (`models.csv` has its quartiles). Time ratio below 1: this library is faster.\n"
    );
    let _ = writeln!(
        md,
        "| model | ours: loads? / reason | ours µs/step | MuJoCo µs/step | ours / MuJoCo (passive, perturbed, controlled) | worst joints (m) | settled penetration (m) | energy rise, checked runs (J) | passive: first contact (s), root z at the end (m), ours / MuJoCo | smooth: ours / MuJoCo Euler (m) | checks |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---|---:|---:|---:|---|---|---|");
    let mut failing = Vec::new();
    for m in &ms {
        let Some(p) = m.case("passive").or(m.lines.first().copied()) else {
            continue;
        };
        let status = if !m.loads() {
            format!("no: {}", p.get("ours_error"))
        } else {
            let errs: Vec<String> = m
                .lines
                .iter()
                .filter(|l| !l.get("ours_error").is_empty())
                .map(|l| format!("{}: {}", l.get("case"), l.get("ours_error")))
                .collect();
            if errs.is_empty() {
                "yes".into()
            } else {
                format!("yes; failed {}", errs.join("; "))
            }
        };
        let ratios: Vec<String> = ["passive", "perturbed", "controlled"]
            .iter()
            .map(|c| ratio(m.case(c).and_then(|l| l.num("ratio"))))
            .collect();
        let checked = |l: &CaseLine| l.flag("energy_checked");
        let smooth = m.case("perturbed").filter(|l| {
            !l.get("smooth_ours_com").is_empty() || !l.get("smooth_euler_com").is_empty()
        });
        let checks: Vec<String> = m
            .lines
            .iter()
            .filter(|l| !l.get("checks").is_empty())
            .map(|l| format!("{}: {}", l.get("case"), l.get("checks")))
            .collect();
        let finished = m.lines.iter().any(|l| !l.get("finite").is_empty());
        let checks_cell = if !finished {
            "–".to_string()
        } else if checks.is_empty() {
            "ok".to_string()
        } else {
            checks.join("; ")
        };
        if m.lines.iter().any(|l| l.flag("fatal")) {
            failing.push(m.key.clone());
        }
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            cell(&m.key),
            cell(&status),
            fixed(p.num("ours_us_per_step")),
            fixed(p.num("mujoco_us_per_step")),
            ratios.join(", "),
            sci(m.worst("max_joint_separation", |_| true)),
            sci(m.worst("settled_penetration", |_| true)),
            sci(m.worst("max_energy_increase", checked)),
            agree(p),
            smooth.map_or("–".into(), |l| format!(
                "{} / {}",
                sci(l.num("smooth_ours_com")),
                sci(l.num("smooth_euler_com"))
            )),
            cell(&checks_cell),
        );
    }
    let loaded = ms.iter().filter(|m| m.loads()).count();
    let clean = ms
        .iter()
        .filter(|m| {
            m.loads()
                && m.lines
                    .iter()
                    .all(|l| !l.get("finite").is_empty() && l.get("checks").is_empty())
        })
        .count();
    let smooth: Vec<&Model> = ms
        .iter()
        .filter(|m| {
            m.case("perturbed")
                .is_some_and(|l| l.num("smooth_ours_com").is_some())
        })
        .collect();
    let better = smooth
        .iter()
        .filter(|m| {
            m.case("perturbed").is_some_and(|l| {
                matches!((l.num("smooth_ours_com"), l.num("smooth_euler_com")),
                    (Some(a), Some(b)) if a <= b)
            })
        })
        .count();
    let _ = writeln!(
        md,
        "\n{} models: ours loads {loaded}, passes every check on every case on {clean}; \
         smooth models {}, ours at most MuJoCo Euler's error on {better}; regressions \
         (a panic, or loaded and then diverged): {}.\n",
        ms.len(),
        smooth.len(),
        if failing.is_empty() {
            "none".to_string()
        } else {
            failing.join(", ")
        }
    );

    let loaded_models: Vec<&Model> = ms.iter().filter(|m| m.loads()).collect();
    let time = BarChart {
        title: "Real models: our time per step over MuJoCo's".into(),
        x_label: "ours / MuJoCo µs per step (log; below 1: ours faster)".into(),
        categories: loaded_models.iter().map(|m| m.key.clone()).collect(),
        series: ["passive", "perturbed", "controlled"]
            .iter()
            .map(|c| {
                (
                    c.to_string(),
                    loaded_models
                        .iter()
                        .map(|m| m.case(c).and_then(|l| l.num("ratio")))
                        .collect(),
                )
            })
            .collect(),
        reference: Some(1.0),
        note: "Same file, same case, same run; MuJoCo timed in its C loop (mujoco.rollout).".into(),
    };
    let err = BarChart {
        title: "Smooth models: trajectory error against MuJoCo RK4 at h/10".into(),
        x_label: "largest centre-of-mass error over the run (m, log)".into(),
        categories: smooth.iter().map(|m| m.key.clone()).collect(),
        series: [
            ("ours", "smooth_ours_com"),
            ("MuJoCo Euler", "smooth_euler_com"),
        ]
        .iter()
        .map(|(n, col)| {
            (
                n.to_string(),
                smooth
                    .iter()
                    .map(|m| m.case("perturbed").and_then(|l| l.num(col)))
                    .collect(),
            )
        })
        .collect(),
        reference: None,
        note: "Ours (default method) and MuJoCo Euler both at the file's step, from the perturbed state, zero control.".into(),
    };
    let _ = writeln!(md, "![Real models: time ratio]({TIME_CHART})\n");
    let _ = writeln!(md, "![Smooth models: trajectory error]({SMOOTH_CHART})\n");
    (
        md,
        vec![
            (TIME_CHART.to_string(), time.to_svg()),
            (SMOOTH_CHART.to_string(), err.to_svg()),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "model,suite,case,ours_loads,ours_error,ours_us_per_step,mujoco_us_per_step,ratio,finite,max_joint_separation,settled_penetration,max_energy_increase,energy_checked,checks,fatal,smooth_ours_com,smooth_euler_com\n\
        pendulum,dm_control,passive,true,,4.6,2.4,1.9,true,1e-13,0,0,true,,false,,\n\
        pendulum,dm_control,perturbed,true,,4.8,2.4,2.0,true,9e-13,0,2e-3,true,,false,9.4e-5,1.4e-2\n\
        pendulum,dm_control,controlled,true,,5.0,2.5,2.0,true,5e-13,0,7.0,false,,false,,\n\
        quadruped,dm_control,passive,false,\"scene: line 84: <geom>: unsupported: hfield, geom\",,67.4,,,,,,,,false,,\n\
        walker,dm_control,passive,true,,51,10.6,4.8,true,1e-16,2e-3,0,false,penetration 2.0e-3 m > 1e-3,false,,\n\
        walker,dm_control,controlled,true,step 9 diverged (body 1 non-finite),,,,,,,,,,true,,\n";

    #[test]
    fn the_section_has_one_row_per_model_and_reads_what_loads_from_the_file() {
        let lines = parse(CSV).unwrap();
        assert_eq!(lines.len(), 6);
        assert_eq!(
            lines[3].get("ours_error"),
            "scene: line 84: <geom>: unsupported: hfield, geom"
        );
        let (md, charts) = section(&lines, "cargo xtask models run");
        let rows: Vec<&str> = md
            .lines()
            .filter(|l| l.starts_with("| dm_control/"))
            .collect();
        assert_eq!(rows.len(), 3, "{md}");
        assert!(rows[0].contains("| yes |") && rows[0].contains("1.90, 2.00, 2.00"));
        // The energy rise shown is over the checked runs only (2e-3, not 7).
        assert!(rows[0].contains("| 2.0e-3 |") && rows[0].contains("9.4e-5 / 1.4e-2"));
        assert!(rows[0].contains("| none / none; – / – |"), "{}", rows[0]);
        assert!(rows[1].contains("no: scene: line 84"));
        assert!(rows[2].contains("controlled: step 9 diverged"));
        assert!(rows[2].contains("passive: penetration"));
        assert!(md.contains("ours loads 2, passes every check on every case on 1"));
        assert!(md.contains("smooth models 1, ours at most MuJoCo Euler's error on 1"));
        assert!(
            md.contains("regressions (a panic, or loaded and then diverged): dm_control/walker")
        );
        assert_eq!(charts.len(), 2);
        // Time chart: the two loaded models; smooth chart: the pendulum only.
        assert!(charts[0].1.contains(">dm_control/walker<"));
        assert!(!charts[0].1.contains(">dm_control/quadruped<"));
        assert!(charts[1].1.contains(">dm_control/pendulum<"));
        assert!(!charts[1].1.contains(">dm_control/walker<"));
        assert!(md.contains(&format!("]({TIME_CHART})")));
    }

    #[test]
    fn malformed_files_are_errors_naming_the_line() {
        assert!(parse("").unwrap_err().contains("empty"));
        assert!(parse("a,b\n").unwrap_err().contains("no column"));
        let e = parse("model,suite,case\nx,y\n").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
    }
}
