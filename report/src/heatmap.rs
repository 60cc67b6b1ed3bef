//! Dependency-free SVG heat maps of classified cells (the stability maps): a grid of
//! panels, one per method, each a table of coloured cells over two axes, with one
//! legend for all panels.
//!
//! Like [`crate::chart`], written by hand so the output is byte-for-byte deterministic.

use std::fmt::Write as _;

/// A class of cell: its legend entry, fill colour and the symbol printed in the cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Class {
    /// Legend entry.
    pub label: String,
    /// Fill colour (any SVG colour).
    pub color: &'static str,
    /// Short text printed in each cell of the class (may be empty).
    pub symbol: &'static str,
}

/// One panel: a title and its cells, `cells[row][column]`, each an index into
/// [`HeatMap::classes`] (`None`: not run, drawn blank). Row 0 is drawn at the bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// Title above the panel (the method).
    pub title: String,
    /// Class index per cell.
    pub cells: Vec<Vec<Option<usize>>>,
}

/// Panels sharing axes and classes.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatMap {
    /// Title above the figure.
    pub title: String,
    /// Label under every panel's x axis.
    pub x_label: String,
    /// Label beside every panel's y axis.
    pub y_label: String,
    /// Column labels (left to right).
    pub x_ticks: Vec<String>,
    /// Row labels (bottom to top).
    pub y_ticks: Vec<String>,
    /// The classes; the legend lists them in this order.
    pub classes: Vec<Class>,
    /// The panels, laid out left to right, then top to bottom.
    pub panels: Vec<Panel>,
    /// Panels per line of the figure (at least 1).
    pub columns: usize,
    /// Note under the figure; each `\n` starts a new line.
    pub note: String,
}

const CW: f64 = 46.0;
const CH: f64 = 24.0;
const PL: f64 = 70.0;
const PR: f64 = 18.0;
const PT: f64 = 30.0;
const PB: f64 = 48.0;
const TOP: f64 = 36.0;
const LINE: f64 = 14.0;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

impl HeatMap {
    /// Renders the figure as a standalone SVG document.
    pub fn to_svg(&self) -> String {
        let nx = self.x_ticks.len().max(1) as f64;
        let ny = self.y_ticks.len().max(1) as f64;
        let pw = PL + CW * nx + PR;
        let ph = PT + CH * ny + PB;
        let cols = self.columns.max(1);
        let slots = self.panels.len() + 1; // the legend takes one slot
        let lines = slots.div_ceil(cols);
        let legend_h = 20.0 * self.classes.len() as f64 + 10.0;
        let notes: Vec<&str> = if self.note.is_empty() {
            Vec::new()
        } else {
            self.note.split('\n').collect()
        };
        let width = pw * cols.min(slots) as f64;
        let height = TOP + ph.max(legend_h) * lines as f64 + LINE * notes.len() as f64 + 10.0;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">"#
        );
        let _ = writeln!(
            s,
            r#"<rect width="{width}" height="{height}" fill="white"/>"#
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
            width / 2.0,
            esc(&self.title)
        );
        let slot_h = ph.max(legend_h);
        for (k, panel) in self.panels.iter().enumerate() {
            let ox = pw * (k % cols) as f64;
            let oy = TOP + slot_h * (k / cols) as f64;
            self.panel_svg(&mut s, panel, ox, oy);
        }
        // Legend in the slot after the last panel.
        let k = self.panels.len();
        let lx = pw * (k % cols) as f64 + 20.0;
        let ly = TOP + slot_h * (k / cols) as f64 + PT;
        for (i, c) in self.classes.iter().enumerate() {
            let y = ly + 20.0 * i as f64;
            let _ = writeln!(
                s,
                r##"<rect x="{lx}" y="{y}" width="26" height="16" fill="{}" stroke="#666"/><text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text><text x="{:.1}" y="{:.1}">{}</text>"##,
                c.color,
                lx + 13.0,
                y + 12.0,
                esc(c.symbol),
                lx + 34.0,
                y + 12.0,
                esc(&c.label)
            );
        }
        for (i, line) in notes.iter().enumerate() {
            let _ = writeln!(
                s,
                r##"<text x="10" y="{:.1}" fill="#444">{}</text>"##,
                height - 10.0 - LINE * (notes.len() - 1 - i) as f64,
                esc(line)
            );
        }
        s.push_str("</svg>\n");
        s
    }

    fn panel_svg(&self, s: &mut String, panel: &Panel, ox: f64, oy: f64) {
        let ny = self.y_ticks.len();
        let nx = self.x_ticks.len();
        let x0 = ox + PL;
        let y0 = oy + PT;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13">{}</text>"#,
            x0 + CW * nx as f64 / 2.0,
            oy + PT - 10.0,
            esc(&panel.title)
        );
        for r in 0..ny {
            // Row 0 at the bottom.
            let y = y0 + CH * (ny - 1 - r) as f64;
            let _ = writeln!(
                s,
                r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
                x0 - 5.0,
                y + CH / 2.0 + 4.0,
                esc(&self.y_ticks[r])
            );
            for c in 0..nx {
                let x = x0 + CW * c as f64;
                let class = panel
                    .cells
                    .get(r)
                    .and_then(|row| row.get(c))
                    .copied()
                    .flatten()
                    .and_then(|i| self.classes.get(i));
                let (fill, sym) = class.map_or(("#f4f4f4", ""), |k| (k.color, k.symbol));
                let _ = writeln!(
                    s,
                    r##"<rect x="{x:.1}" y="{y:.1}" width="{CW}" height="{CH}" fill="{fill}" stroke="white"/>"##
                );
                if !sym.is_empty() {
                    let _ = writeln!(
                        s,
                        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                        x + CW / 2.0,
                        y + CH / 2.0 + 4.0,
                        esc(sym)
                    );
                }
            }
        }
        for (c, t) in self.x_ticks.iter().enumerate() {
            let x = x0 + CW * (c as f64 + 0.5);
            let _ = writeln!(
                s,
                r#"<text x="{x:.1}" y="{:.1}" text-anchor="middle" font-size="10">{}</text>"#,
                y0 + CH * ny as f64 + 13.0,
                esc(t)
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            x0 + CW * nx as f64 / 2.0,
            y0 + CH * ny as f64 + 30.0,
            esc(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate({:.1} {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            ox + 14.0,
            y0 + CH * ny as f64 / 2.0,
            esc(&self.y_label)
        );
    }
}

/// A tick label for a value on a logarithmic axis: `1e-3`, `3e-5`, `1/30`-style values
/// as `3.3e-2`; integers below 1e5 as themselves.
pub fn tick(v: f64) -> String {
    if (1.0..1e5).contains(&v) && v.fract() == 0.0 {
        return format!("{v}");
    }
    let s = format!("{v:.1e}");
    // 1.0e-3 → 1e-3
    s.replacen(".0e", "e", 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> HeatMap {
        HeatMap {
            title: "t<1>".into(),
            x_label: "h".into(),
            y_label: "k".into(),
            x_ticks: vec!["a".into(), "b".into(), "c".into()],
            y_ticks: vec!["lo".into(), "hi".into()],
            classes: vec![
                Class {
                    label: "good".into(),
                    color: "#0a0",
                    symbol: "✓",
                },
                Class {
                    label: "bad".into(),
                    color: "#a00",
                    symbol: "✗",
                },
            ],
            panels: vec![
                Panel {
                    title: "m1".into(),
                    cells: vec![vec![Some(0), Some(1), None], vec![Some(0); 3]],
                },
                Panel {
                    title: "m2".into(),
                    cells: vec![vec![Some(1); 3]],
                },
            ],
            columns: 2,
            note: "one\ntwo".into(),
        }
    }

    #[test]
    fn every_cell_is_drawn_with_its_class_and_missing_cells_are_blank() {
        let s = map().to_svg();
        assert!(s.starts_with("<svg") && s.ends_with("</svg>\n"));
        // 2 panels × 6 cells + 2 legend boxes + background.
        assert_eq!(s.matches("<rect").count(), 12 + 2 + 1);
        assert_eq!(s.matches(r##"fill="#f4f4f4""##).count(), 1 + 3);
        // ✓: 1 + 3 cells + legend; ✗: 1 + 3 cells + legend.
        assert_eq!(s.matches(">✓<").count(), 5);
        assert_eq!(s.matches(">✗<").count(), 5);
        assert!(s.contains("t&lt;1&gt;"));
        assert!(s.contains(">one</text>") && s.contains(">two</text>"));
    }

    #[test]
    fn output_is_deterministic() {
        assert_eq!(map().to_svg(), map().to_svg());
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(1e-3), "1e-3");
        assert_eq!(tick(3e-5), "3e-5");
        assert_eq!(tick(1.0 / 30.0), "3.3e-2");
        assert_eq!(tick(100.0), "100");
        assert_eq!(tick(1e6), "1e6");
    }
}
