//! Accuracy against time per step for the contact scenes, this library's solver settings
//! next to other engines' (rapier3d, MuJoCo): one labelled point per setting.
//!
//! The input is plain data, a TSV that `cargo xtask bench` writes
//! (`target/bench/contact_points.tsv`) and `verify-report --contact-points TSV DIR`
//! draws (one chart per scene, `DIR/contact_<scene>.svg`): a header line naming the
//! columns [`COLUMNS`] (any order, more columns allowed), then one line per point.
//! A missing column or an empty file is a [`PointsError`]; a line whose numbers do not
//! parse, or are not positive and finite (they go on log axes), is left off the charts
//! with a note. The verification report's contact charts take the same points
//! ([`PeerPoint`]) as extra series ([`peer_series`]).

use std::fmt::Write as _;
use std::path::Path;

use crate::chart::{LogLogChart, Series};

/// The columns a points file must have.
pub const COLUMNS: [&str; 7] = [
    "scene",
    "scene_label",
    "y_label",
    "engine",
    "setting",
    "seconds_per_step",
    "error",
];

/// One point: an engine's setting on a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct PeerPoint {
    /// Scene id (file names): `stack10`, `pyramid20`, `heavy1e4`, `sliding_box`.
    pub scene: String,
    /// Scene title for the chart.
    pub scene_label: String,
    /// What the error is (the y axis label).
    pub y_label: String,
    /// The engine: one series per engine (`ours`, `rapier3d`, `MuJoCo`, …).
    pub engine: String,
    /// The setting, the point's label.
    pub setting: String,
    /// Time per step (s; x).
    pub seconds: f64,
    /// The scene's error (m; y).
    pub error: f64,
    /// The step the time is for (s), from the optional column `dt`: charts per simulated
    /// second divide by it.
    pub dt: Option<f64>,
}

/// Why a points file cannot be read at all.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PointsError {
    /// No header line.
    Empty,
    /// The header lacks this column.
    MissingColumn(&'static str),
}

impl std::fmt::Display for PointsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PointsError::Empty => write!(f, "empty points file (no header line)"),
            PointsError::MissingColumn(c) => write!(f, "points file has no column {c:?}"),
        }
    }
}

impl std::error::Error for PointsError {}

/// Parses a points file: the points, and a note for each line left off.
pub fn parse(text: &str) -> Result<(Vec<PeerPoint>, Vec<String>), PointsError> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .by_ref()
        .find(|l| !l.trim().is_empty())
        .ok_or(PointsError::Empty)?
        .split('\t')
        .map(str::trim)
        .collect();
    let mut col = [0usize; 7];
    for (slot, name) in col.iter_mut().zip(COLUMNS) {
        *slot = header
            .iter()
            .position(|h| *h == name)
            .ok_or(PointsError::MissingColumn(name))?;
    }
    let dt_col = header.iter().position(|h| *h == "dt");
    let mut points = Vec::new();
    let mut notes = Vec::new();
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.split('\t').map(str::trim).collect();
        let get = |k: usize| f.get(col[k]).copied();
        let num = |k: usize| {
            get(k)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite() && *v > 0.0)
        };
        match (get(0), get(1), get(2), get(3), get(4), num(5), num(6)) {
            (Some(sc), Some(sl), Some(yl), Some(en), Some(se), Some(t), Some(e)) => {
                points.push(PeerPoint {
                    scene: sc.into(),
                    scene_label: sl.into(),
                    y_label: yl.into(),
                    engine: en.into(),
                    setting: se.into(),
                    seconds: t,
                    error: e,
                    dt: dt_col
                        .and_then(|c| f.get(c))
                        .and_then(|v| v.parse::<f64>().ok())
                        .filter(|v| v.is_finite() && *v > 0.0),
                })
            }
            _ => notes.push(format!(
                "line {}: not drawn (missing fields, or a time or error that is not a \
                 positive number): {line:?}",
                i + 2
            )),
        }
    }
    Ok((points, notes))
}

/// Scene ids in the order they first appear.
pub fn scenes(points: &[PeerPoint]) -> Vec<String> {
    crate::chart::first_appearances(points.iter().map(|p| p.scene.as_str()))
}

/// The points of `points` as series, one per engine in order of first appearance, each
/// point apart (a non-finite separator: no line through settings that are not a
/// sequence), with their labels (`setting`) for [`LogLogChart::to_svg_labelled`].
/// `x` maps a point's time per step to the chart's x (e.g. per simulated second).
pub fn peer_series(
    points: &[&PeerPoint],
    x: impl Fn(f64) -> f64,
) -> (Vec<Series>, Vec<Vec<String>>) {
    let mut engines: Vec<&str> = Vec::new();
    for p in points {
        if !engines.contains(&p.engine.as_str()) {
            engines.push(&p.engine);
        }
    }
    let mut series = Vec::new();
    let mut labels = Vec::new();
    for e in engines {
        let mut pts = Vec::new();
        let mut names = Vec::new();
        for p in points.iter().filter(|p| p.engine == e) {
            if !pts.is_empty() {
                pts.push((f64::NAN, f64::NAN));
                names.push(String::new());
            }
            pts.push((x(p.seconds), p.error));
            names.push(p.setting.clone());
        }
        series.push(Series {
            name: e.to_string(),
            points: pts,
        });
        labels.push(names);
    }
    (series, labels)
}

/// The chart of one scene: its points' error against time per step, log–log, each
/// point labelled, the Pareto front marked; with no point, an empty chart whose note
/// says so.
pub fn scene_chart(
    scene: &str,
    points: &[PeerPoint],
    note: &str,
) -> (LogLogChart, Vec<Vec<String>>) {
    let mine: Vec<&PeerPoint> = points.iter().filter(|p| p.scene == scene).collect();
    let (series, labels) = peer_series(&mine, |t| t);
    let (title, y_label) = mine.first().map_or_else(
        || (scene.to_string(), "error (m)".to_string()),
        |p| (p.scene_label.clone(), p.y_label.clone()),
    );
    let mut note = note.to_string();
    if mine.is_empty() {
        if !note.is_empty() {
            note.push('\n');
        }
        let _ = write!(note, "No data for {scene}: nothing measured.");
    }
    (
        LogLogChart {
            title: format!("{title}: accuracy against time per step"),
            x_label: "time per step (s)".into(),
            y_label,
            series,
            note,
            log_x: true,
            pareto: !mine.is_empty(),
        },
        labels,
    )
}

/// What [`write_charts`] wrote: `(scene, file)` per chart, and the notes about lines
/// left off.
pub type Written = (Vec<(String, String)>, Vec<String>);

/// Writes one chart per scene of the points file `tsv` into `dir`
/// (`contact_<scene>.svg`, note `note` under each); returns the files written and the
/// notes about lines left off.
pub fn write_charts(tsv: &Path, dir: &Path, note: &str) -> Result<Written, String> {
    let text = std::fs::read_to_string(tsv).map_err(|e| format!("{}: {e}", tsv.display()))?;
    let (points, notes) = parse(&text).map_err(|e| format!("{}: {e}", tsv.display()))?;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut files = Vec::new();
    for scene in scenes(&points) {
        let (chart, labels) = scene_chart(&scene, &points, note);
        let file = format!("contact_{scene}.svg");
        let path = dir.join(&file);
        std::fs::write(&path, chart.to_svg_labelled(&labels))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        files.push((scene, file));
    }
    Ok((files, notes))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TSV: &str = "scene\tscene_label\ty_label\tengine\tsetting\tseconds_per_step\terror\n\
        stack10\t10-box stack\ttop drift (m)\tours\tAuto\t1.1e-5\t2e-10\n\
        stack10\t10-box stack\ttop drift (m)\tours\tsoft 4\t2e-5\t1e-3\n\
        stack10\t10-box stack\ttop drift (m)\trapier3d\tdefault\t2.2e-5\t5.6e-3\n\
        stack10\t10-box stack\ttop drift (m)\tMuJoCo\t60 Hz\t9e-6\t4e-3\n\
        stack10\t10-box stack\ttop drift (m)\tMuJoCo\t240 Hz\t3.6e-5\t1e-3\n\
        slide\tsliding box\tstop error (m)\tours\tAuto\t1e-6\tnan\n\
        slide\tsliding box\tstop error (m)\tours\tSI\t1e-6\n";

    #[test]
    fn one_labelled_point_per_row() {
        let (points, notes) = parse(TSV).unwrap();
        assert_eq!(points.len(), 5);
        assert_eq!(notes.len(), 2, "{notes:?}");
        let (chart, labels) = scene_chart("stack10", &points, "n");
        assert_eq!(chart.series.len(), 3);
        let svg = chart.to_svg_labelled(&labels);
        assert_eq!(svg.matches(r#"class="label""#).count(), 5);
        for l in ["Auto", "soft 4", "default", "60 Hz", "240 Hz"] {
            assert!(svg.contains(&format!(">{l}</text>")), "{l}");
        }
        // Points apart: no line through one engine's settings.
        assert_eq!(svg.matches("<polyline").count(), 1, "only the Pareto front");
        // 5 points, 3 legend markers.
        assert_eq!(svg.matches(r#"r="3.5""#).count(), 5 + 3);
    }

    #[test]
    fn missing_data_is_a_note_or_a_typed_error() {
        assert_eq!(parse(""), Err(PointsError::Empty));
        assert_eq!(
            parse("scene\tengine\n"),
            Err(PointsError::MissingColumn("scene_label"))
        );
        let (points, _) = parse(TSV).unwrap();
        let (chart, labels) = scene_chart("pyramid20", &points, "");
        assert!(chart.series.is_empty() && labels.is_empty());
        let svg = chart.to_svg_labelled(&labels);
        assert!(svg.contains("No data for pyramid20"));
        let dir = std::env::temp_dir().join(format!("peer_points_{}", std::process::id()));
        let e = write_charts(&dir.join("missing.tsv"), &dir, "").unwrap_err();
        assert!(e.contains("missing.tsv"), "{e}");
    }

    #[test]
    fn writes_a_chart_per_scene() {
        let dir = std::env::temp_dir().join(format!("peer_points_w_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let tsv = dir.join("p.tsv");
        std::fs::write(&tsv, TSV).unwrap();
        let (files, notes) = write_charts(&tsv, &dir, "note").unwrap();
        assert_eq!(
            files,
            vec![("stack10".to_string(), "contact_stack10.svg".to_string())]
        );
        assert_eq!(notes.len(), 2);
        assert!(dir.join("contact_stack10.svg").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
