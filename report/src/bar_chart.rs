//! A dependency-free SVG chart of grouped horizontal bars on a logarithmic axis: one
//! row per category (a model), one bar per series (a case, an engine), with an optional
//! reference line (a ratio of 1). Deterministic output, like [`crate::chart`].

use std::fmt::Write as _;

/// A bar chart: `values[series][category]`, `None` or non-positive values not drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct BarChart {
    /// Title above the plot.
    pub title: String,
    /// Label of the value axis (logarithmic).
    pub x_label: String,
    /// One row of bars per category, top to bottom.
    pub categories: Vec<String>,
    /// `(legend entry, one value per category)`.
    pub series: Vec<(String, Vec<Option<f64>>)>,
    /// A dashed vertical line at this value (e.g. 1 for ratios).
    pub reference: Option<f64>,
    /// A note under the plot; each `\n` starts a new line.
    pub note: String,
}

const W: f64 = 760.0;
const L: f64 = 230.0;
const R: f64 = 130.0;
const T: f64 = 40.0;
const BAR: f64 = 7.0;
const GAP: f64 = 6.0;
const COLORS: [&str; 6] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

impl BarChart {
    /// The values drawn: positive and finite.
    fn drawn(&self) -> impl Iterator<Item = f64> + '_ {
        self.series
            .iter()
            .flat_map(|(_, v)| v.iter().flatten().copied())
            .chain(self.reference)
            .filter(|v| *v > 0.0 && v.is_finite())
    }

    /// Renders the chart as a standalone SVG document.
    pub fn to_svg(&self) -> String {
        let (lo, hi) = self
            .drawn()
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        let (xa, mut xb) = if lo > hi {
            (0.0, 1.0)
        } else {
            (lo.log10().floor(), hi.log10().ceil())
        };
        if xb <= xa {
            xb = xa + 1.0;
        }
        let ns = self.series.len().max(1) as f64;
        let row = ns * BAR + GAP;
        let ph = row * self.categories.len().max(1) as f64;
        let notes: Vec<&str> = self.note.split('\n').filter(|l| !l.is_empty()).collect();
        let height = T + ph + 50.0 + 14.0 * notes.len() as f64;
        let pw = W - L - R;
        let sx = |v: f64| L + (v.log10() - xa) / (xb - xa) * pw;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{height}" viewBox="0 0 {W} {height}" font-family="sans-serif" font-size="11">"#
        );
        let _ = writeln!(s, r#"<rect width="{W}" height="{height}" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
            L + pw / 2.0,
            esc(&self.title)
        );
        let mut d = xa;
        while d <= xb + 0.5 {
            let x = sx(10f64.powf(d));
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{T}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">1e{d}</text>"##,
                T + ph,
                T + ph + 14.0
            );
            d += 1.0;
        }
        for (i, c) in self.categories.iter().enumerate() {
            let y0 = T + GAP / 2.0 + i as f64 * row;
            let _ = writeln!(
                s,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
                L - 6.0,
                y0 + ns * BAR / 2.0 + 4.0,
                esc(c)
            );
            for (k, (_, vals)) in self.series.iter().enumerate() {
                let Some(v) = vals.get(i).copied().flatten() else {
                    continue;
                };
                if !(v > 0.0) || !v.is_finite() {
                    continue;
                }
                let y = y0 + k as f64 * BAR;
                let _ = writeln!(
                    s,
                    r#"<rect x="{L}" y="{y:.1}" width="{:.1}" height="{BAR}" fill="{}"/>"#,
                    (sx(v) - L).max(0.5),
                    COLORS[k % COLORS.len()]
                );
            }
        }
        if let Some(r) = self.reference.filter(|r| *r > 0.0 && r.is_finite()) {
            let x = sx(r);
            let _ = writeln!(
                s,
                r#"<line x1="{x:.1}" y1="{T}" x2="{x:.1}" y2="{:.1}" stroke="black" stroke-dasharray="4 3"/>"#,
                T + ph
            );
        }
        let _ = writeln!(
            s,
            r#"<rect x="{L}" y="{T}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            L + pw / 2.0,
            T + ph + 32.0,
            esc(&self.x_label)
        );
        for (k, (name, _)) in self.series.iter().enumerate() {
            let y = T + 10.0 + 18.0 * k as f64;
            let _ = writeln!(
                s,
                r#"<rect x="{:.1}" y="{:.1}" width="12" height="8" fill="{}"/><text x="{:.1}" y="{:.1}">{}</text>"#,
                L + pw + 12.0,
                y - 8.0,
                COLORS[k % COLORS.len()],
                L + pw + 30.0,
                y,
                esc(name)
            );
        }
        for (k, line) in notes.iter().enumerate() {
            let _ = writeln!(
                s,
                r##"<text x="{L}" y="{:.1}" fill="#555">{}</text>"##,
                T + ph + 50.0 + 14.0 * k as f64,
                esc(line)
            );
        }
        s.push_str("</svg>\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart() -> BarChart {
        BarChart {
            title: "t <1>".into(),
            x_label: "ratio".into(),
            categories: vec!["a".into(), "b".into()],
            series: vec![
                ("s1".into(), vec![Some(0.5), None]),
                ("s2".into(), vec![Some(20.0), Some(-1.0)]),
            ],
            reference: Some(1.0),
            note: "n1\nn2".into(),
        }
    }

    #[test]
    fn only_positive_finite_values_are_drawn_and_the_axis_spans_their_decades() {
        let svg = chart().to_svg();
        // Two bars (0.5 and 20); None and −1 are not drawn.
        assert_eq!(svg.matches("height=\"7\" fill=\"#").count(), 2, "{svg}");
        // Decades 1e-1 … 1e2 around 0.5 … 20.
        for d in ["1e-1", "1e0", "1e1", "1e2"] {
            assert!(svg.contains(&format!(">{d}</text>")), "{d}");
        }
        assert!(!svg.contains(">1e3<") && !svg.contains(">1e-2<"));
        assert!(svg.contains("t &lt;1&gt;") && svg.contains(">n2</text>"));
        assert!(svg.contains("stroke-dasharray"));
        assert_eq!(svg, chart().to_svg(), "deterministic");
    }

    #[test]
    fn an_empty_chart_still_renders() {
        let c = BarChart {
            categories: vec![],
            series: vec![],
            reference: None,
            note: String::new(),
            ..chart()
        };
        let svg = c.to_svg();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
    }
}
