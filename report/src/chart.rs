//! Dependency-free SVG charts with a logarithmic y axis and a logarithmic or linear x
//! axis (work-precision diagrams, error histories).
//!
//! Written by hand rather than with a plotting crate: the output must be byte-for-byte
//! deterministic (the report is diffed between runs) and the crate must not pull font
//! loading into CI. Weighed against `plotters` 0.3.7 (SVG backend, line and point
//! series, no font features) on the same chart, four series of twelve points on log–log
//! axes with a legend: plotters' page is 14,747 bytes against this module's 7,143 (it
//! writes every grid line and label as its own element with full style attributes), it is
//! deterministic too, and it builds in 4.1 s of CPU (five crates). It would not remove
//! this module's own work — the Pareto front, breaking a line at non-finite points,
//! skipping non-positive values on log axes, the decade tick labels — so the hand-written
//! SVG stays and the unused `plotters` entry left `[workspace.dependencies]`.

use std::fmt::Write as _;

/// One named series of `(x, y)` points, drawn as a polyline with markers.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points; non-positive values are skipped (log axes); a non-finite point is not
    /// drawn and breaks the line (several curves in one series, e.g. one per problem).
    pub points: Vec<(f64, f64)>,
}

/// A log–log chart.
#[derive(Clone, Debug, PartialEq)]
pub struct LogLogChart {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// The series.
    pub series: Vec<Series>,
    /// A note printed under the plot (e.g. how the reference was computed); each `\n`
    /// starts a new line and makes the chart taller.
    pub note: String,
    /// Logarithmic x axis (`false`: linear, for time series).
    pub log_x: bool,
    /// Mark the Pareto front over all series (see [`pareto_front`]): a dashed black line
    /// through the non-dominated points, each ringed, with its own legend entry.
    pub pareto: bool,
}

/// The non-dominated points (no other point has both a smaller-or-equal `x` and a
/// smaller-or-equal `y`, one of them strictly), sorted by increasing `x` (hence
/// decreasing `y`). Non-positive and non-finite values are ignored; duplicates kept once.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if front.last().is_none_or(|l| q.1 < l.1) {
            front.push(q);
        }
    }
    front
}

const W: f64 = 760.0;
const H0: f64 = 520.0;
const NOTE_LINE: f64 = 14.0;
const L: f64 = 80.0;
const R: f64 = 230.0;
const T: f64 = 40.0;
const B: f64 = 70.0;
const COLORS: [&str; 10] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
    "#bcbd22", "#7f7f7f",
];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn decades(lo: f64, hi: f64) -> (f64, f64) {
    let a = lo.log10().floor();
    let mut b = hi.log10().ceil();
    if b <= a {
        b = a + 1.0;
    }
    (a, b)
}

impl LogLogChart {
    /// Renders the chart as a standalone SVG document.
    pub fn to_svg(&self) -> String {
        self.render(&[])
    }

    /// [`LogLogChart::to_svg`] with a text label beside each drawn point:
    /// `labels[k][i]` names point `i` of series `k` (missing or empty: no label; a point
    /// that is not drawn is not labelled). Each label is a `<text class="label">`.
    pub fn to_svg_labelled(&self, labels: &[Vec<String>]) -> String {
        self.render(labels)
    }

    fn render(&self, labels: &[Vec<String>]) -> String {
        let notes: Vec<&str> = self.note.split('\n').collect();
        let height = H0 + NOTE_LINE * (notes.len() - 1) as f64;
        let pts = || {
            self.series
                .iter()
                .flat_map(|s| s.points.iter())
                .filter(move |(x, y)| {
                    (*x > 0.0 || !self.log_x) && *y > 0.0 && x.is_finite() && y.is_finite()
                })
        };
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in pts() {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if x0 > x1 {
            (x0, x1, y0, y1) = (1.0, 10.0, 1.0, 10.0);
        }
        let (xa, xb) = if self.log_x {
            decades(x0, x1)
        } else {
            (0.0f64.min(x0), x1.max(x0 + 1.0))
        };
        let log_x = self.log_x;
        let fx = move |x: f64| if log_x { x.log10() } else { x };
        let (ya, yb) = decades(y0, y1);
        let pw = W - L - R;
        let ph = H0 - T - B;
        let sx = |x: f64| L + (fx(x) - xa) / (xb - xa) * pw;
        let sy = |y: f64| T + ph - (y.log10() - ya) / (yb - ya) * ph;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{height}" viewBox="0 0 {W} {height}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect width="{W}" height="{height}" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
            L + pw / 2.0,
            esc(&self.title)
        );
        // Grid and tick labels at every decade.
        let ticks: Vec<(f64, String)> = if log_x {
            let mut v = Vec::new();
            let mut d = xa;
            while d <= xb + 0.5 {
                v.push((10f64.powf(d), format!("1e{d}")));
                d += 1.0;
            }
            v
        } else {
            (0..=5)
                .map(|k| {
                    let x = xa + (xb - xa) * k as f64 / 5.0;
                    (x, format!("{x:.3}"))
                })
                .collect()
        };
        for (xv, label) in ticks {
            let x = sx(xv);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{T}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{label}</text>"##,
                T + ph,
                T + ph + 16.0
            );
        }
        let mut d = ya;
        while d <= yb + 0.5 {
            let y = sy(10f64.powf(d));
            let _ = writeln!(
                s,
                r##"<line x1="{L}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">1e{d}</text>"##,
                L + pw,
                L - 6.0,
                y + 4.0
            );
            d += 1.0;
        }
        let _ = writeln!(
            s,
            r#"<rect x="{L}" y="{T}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            L + pw / 2.0,
            H0 - B + 36.0,
            esc(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate(18 {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            T + ph / 2.0,
            esc(&self.y_label)
        );
        for (k, ser) in self.series.iter().enumerate() {
            let c = COLORS[k % COLORS.len()];
            let keep = |(x, y): &(f64, f64)| {
                (*x > 0.0 || !log_x) && *y > 0.0 && x.is_finite() && y.is_finite()
            };
            let p: Vec<(f64, f64)> = ser.points.iter().copied().filter(keep).collect();
            // A non-finite point lifts the pen: the line restarts after it.
            for piece in ser.points.split(|(x, y)| !x.is_finite() || !y.is_finite()) {
                let piece: Vec<(f64, f64)> = piece.iter().copied().filter(keep).collect();
                if piece.len() < 2 {
                    continue;
                }
                let path: Vec<String> = piece
                    .iter()
                    .map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y)))
                    .collect();
                let _ = writeln!(
                    s,
                    r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="1.5"/>"#,
                    path.join(" ")
                );
            }
            for &(x, y) in &p {
                let _ = writeln!(
                    s,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="3.5" fill="{c}"/>"#,
                    sx(x),
                    sy(y)
                );
            }
            let names = labels.get(k).map_or(&[][..], |v| v.as_slice());
            for (&(x, y), name) in ser.points.iter().zip(names) {
                if name.is_empty() || !keep(&(x, y)) {
                    continue;
                }
                let _ = writeln!(
                    s,
                    r#"<text class="label" x="{:.1}" y="{:.1}" font-size="10" fill="{c}">{}</text>"#,
                    sx(x) + 6.0,
                    sy(y) - 5.0,
                    esc(name)
                );
            }
            let ly = T + 14.0 + 18.0 * k as f64;
            let lx = W - R + 14.0;
            let _ = writeln!(
                s,
                r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{c}" stroke-width="2"/><circle cx="{}" cy="{ly}" r="3.5" fill="{c}"/><text x="{}" y="{}">{}</text>"#,
                lx + 22.0,
                lx + 11.0,
                lx + 28.0,
                ly + 4.0,
                esc(&ser.name)
            );
        }
        if self.pareto {
            self.front_svg(&mut s, sx, sy);
        }
        for (i, line) in notes.iter().enumerate() {
            let _ = writeln!(
                s,
                r##"<text x="{L}" y="{:.1}" font-size="11" fill="#444">{}</text>"##,
                H0 - 12.0 + NOTE_LINE * i as f64,
                esc(line)
            );
        }
        s.push_str("</svg>\n");
        s
    }
}

impl LogLogChart {
    /// The Pareto front's dashed line, rings and legend entry (after the series').
    fn front_svg(&self, s: &mut String, sx: impl Fn(f64) -> f64, sy: impl Fn(f64) -> f64) {
        let all: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|ser| ser.points.iter().copied())
            .collect();
        let front = pareto_front(&all);
        if front.is_empty() {
            return;
        }
        let path: Vec<String> = front
            .iter()
            .map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="black" stroke-width="1" stroke-dasharray="5 3"/>"#,
            path.join(" ")
        );
        for &(x, y) in &front {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="6.5" fill="none" stroke="black" stroke-width="1.2"/>"#,
                sx(x),
                sy(y)
            );
        }
        let ly = T + 14.0 + 18.0 * self.series.len() as f64;
        let lx = W - R + 14.0;
        let _ = writeln!(
            s,
            r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="black" stroke-dasharray="5 3"/><circle cx="{}" cy="{ly}" r="6.5" fill="none" stroke="black"/><text x="{}" y="{}">Pareto front</text>"#,
            lx + 22.0,
            lx + 11.0,
            lx + 28.0,
            ly + 4.0
        );
    }
}

/// The distinct `keys`, in the order they first appear (chart legends and scene
/// lists: a few dozen entries, so a linear search).
pub fn first_appearances<'a>(keys: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for k in keys {
        if !out.iter().any(|o| o == k) {
            out.push(k.to_string());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_one_polyline_per_multi_point_series_and_skips_bad_points() {
        let c = LogLogChart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![
                Series {
                    name: "a<b".into(),
                    points: vec![(1e-3, 1e-2), (1e-2, 1e-4), (0.0, 1.0), (f64::NAN, 1.0)],
                },
                Series {
                    name: "single".into(),
                    points: vec![(1e-1, 1e-1)],
                },
            ],
            note: "n".into(),
            log_x: true,
            pareto: false,
        };
        let s = c.to_svg();
        assert_eq!(s.matches("<polyline").count(), 1);
        assert_eq!(s.matches("<circle").count(), 3 + 2);
        assert!(s.contains("a&lt;b"));
        assert!(s.starts_with("<svg") && s.ends_with("</svg>\n"));
    }

    #[test]
    fn a_non_finite_point_breaks_the_line() {
        let nan = f64::NAN;
        let c = LogLogChart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series {
                name: "a".into(),
                points: vec![
                    (1.0, 1.0),
                    (2.0, 0.5),
                    (nan, nan),
                    (3.0, 0.3),
                    (nan, nan),
                    (4.0, 0.2),
                    (5.0, 0.1),
                ],
            }],
            note: String::new(),
            log_x: true,
            pareto: false,
        };
        let s = c.to_svg();
        assert_eq!(s.matches("<polyline").count(), 2);
        assert_eq!(s.matches("<circle").count(), 5 + 1);
    }

    #[test]
    fn labels_go_beside_drawn_points_only() {
        let c = LogLogChart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series {
                name: "a".into(),
                points: vec![
                    (1e-3, 1e-2),
                    (f64::NAN, f64::NAN),
                    (1e-2, 0.0),
                    (1e-1, 1e-3),
                ],
            }],
            note: String::new(),
            log_x: true,
            pareto: false,
        };
        let labels = vec![vec![
            "p<1".into(),
            "gap".into(),
            "zero".into(),
            String::new(),
        ]];
        let s = c.to_svg_labelled(&labels);
        assert_eq!(s.matches(r#"class="label""#).count(), 1);
        assert!(s.contains(">p&lt;1</text>"));
        assert_eq!(c.to_svg_labelled(&[]), c.to_svg());
    }

    #[test]
    fn pareto_front_keeps_non_dominated_points_in_x_order() {
        let pts = [
            (1.0, 1.0),
            (2.0, 0.5),
            (2.0, 2.0),
            (3.0, 0.5),
            (0.5, 4.0),
            (4.0, 0.1),
            (f64::NAN, 1e-9),
            (1.0, 0.0),
        ];
        assert_eq!(
            pareto_front(&pts),
            vec![(0.5, 4.0), (1.0, 1.0), (2.0, 0.5), (4.0, 0.1)]
        );
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn front_and_multi_line_note_are_drawn() {
        let c = LogLogChart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series {
                name: "a".into(),
                points: vec![(1e-3, 1e-2), (1e-2, 1e-4), (2e-2, 1e-3)],
            }],
            note: "one\ntwo".into(),
            log_x: true,
            pareto: true,
        };
        let s = c.to_svg();
        assert_eq!(s.matches("stroke-dasharray").count(), 2);
        assert_eq!(s.matches(r#"r="6.5""#).count(), 2 + 1);
        assert!(s.contains(">one</text>") && s.contains(">two</text>"));
        assert!(s.contains(r#"height="534""#));
    }
}
