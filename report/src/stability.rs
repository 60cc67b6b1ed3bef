//! What the stability maps share ([`crate::articulated_stability`],
//! [`crate::chain_stability`], [`crate::contact_stability`]): the cell classes with their
//! table symbols and heat-map legend, the per-method tally, and the writer of a map
//! section — per axis pair a heat map, a Markdown table and CSV rows ([`write_maps`]),
//! then a summary per method ([`write_summary`]). Each map keeps its own scene, methods,
//! thresholds and classification, and describes itself to the writer through
//! [`StabilityMap`].
//!
//! Every map stores its results in (method, value, step) order, the time step fastest
//! ([`Layout::index`]).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use crate::heatmap::{tick, Class, HeatMap, Panel};

/// A cell's class.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellClass {
    /// Finite, bounded and within the map's accuracy thresholds.
    Stable,
    /// Finite and bounded, but above one of the map's accuracy thresholds.
    Inaccurate,
    /// The step returned the typed divergence error (non-finite or beyond 1e12).
    Diverged,
    /// Finite but beyond the map's blow-up bound (counted as unstable).
    BlowUp,
    /// Another typed error (counted as unstable).
    Failed,
    /// The step panicked (a bug: must never happen).
    Panicked,
}

impl CellClass {
    /// Every class, in legend order.
    pub const ALL: [CellClass; 6] = [
        CellClass::Stable,
        CellClass::Inaccurate,
        CellClass::Diverged,
        CellClass::BlowUp,
        CellClass::Failed,
        CellClass::Panicked,
    ];

    /// One-character cell for tables.
    pub fn symbol(self) -> &'static str {
        match self {
            CellClass::Stable => "✓",
            CellClass::Inaccurate => "~",
            CellClass::Diverged => "✗",
            CellClass::BlowUp => "↑",
            CellClass::Failed => "!",
            CellClass::Panicked => "P",
        }
    }

    /// Whether the class counts as unstable.
    pub fn unstable(self) -> bool {
        !matches!(self, CellClass::Stable | CellClass::Inaccurate)
    }

    /// Index of the class in [`CellClass::ALL`] and [`CellClass::legend`].
    pub fn index(self) -> usize {
        CellClass::ALL.iter().position(|c| *c == self).unwrap_or(0)
    }

    /// The heat-map classes, in [`CellClass::ALL`] order.
    pub fn legend() -> Vec<Class> {
        let c = |label: &str, color, symbol| Class {
            label: label.into(),
            color,
            symbol,
        };
        vec![
            c("stable", "#8fd18f", "✓"),
            c("inaccurate (bounded)", "#f3d36b", "~"),
            c("unstable: Diverged", "#e06666", "✗"),
            c("unstable: blow-up", "#c0504d", "↑"),
            c("unstable: other typed error", "#a64d79", "!"),
            c("panic (must not happen)", "#222222", "P"),
        ]
    }
}

/// Counts of cells by class (one method's over all maps, or all of them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    /// Stable cells.
    pub stable: usize,
    /// Inaccurate cells.
    pub inaccurate: usize,
    /// Unstable cells (diverged, blow-up, other typed error).
    pub unstable: usize,
    /// Panics.
    pub panics: usize,
}

impl Tally {
    /// Counts one cell of class `class`.
    pub fn add(&mut self, class: CellClass) {
        match class {
            CellClass::Stable => self.stable += 1,
            CellClass::Inaccurate => self.inaccurate += 1,
            CellClass::Panicked => self.panics += 1,
            _ => self.unstable += 1,
        }
    }

    /// Cells counted.
    pub fn cells(&self) -> usize {
        self.stable + self.inaccurate + self.unstable + self.panics
    }
}

/// The shape of one map: per method a block of rows (the values along the other axis),
/// per row a cell per time step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout<'a> {
    /// Method labels, in result order.
    pub methods: &'a [&'a str],
    /// Time steps (s), the columns.
    pub hs: &'a [f64],
    /// Values along the other axis (rows per method).
    pub values: usize,
}

impl Layout<'_> {
    /// Index of the cell of method `method`, value `value` and step `step`.
    pub fn index(&self, method: usize, value: usize, step: usize) -> usize {
        (method * self.values + value) * self.hs.len() + step
    }
}

/// The heat map of one map: a panel per method, cell `i` ([`Layout::index`]) drawn in the
/// colour of `class(i)` (`None`: not run, blank), the time steps along x and `y_ticks`
/// (the values) along y, the [`CellClass::legend`].
pub fn heat_map(
    layout: &Layout,
    title: String,
    y_label: &str,
    y_ticks: Vec<String>,
    columns: usize,
    note: String,
    class: impl Fn(usize) -> Option<CellClass>,
) -> HeatMap {
    let nh = layout.hs.len();
    let panels = layout
        .methods
        .iter()
        .enumerate()
        .map(|(m, name)| Panel {
            title: (*name).into(),
            cells: (0..layout.values)
                .map(|v| {
                    (0..nh)
                        .map(|k| class(layout.index(m, v, k)).map(CellClass::index))
                        .collect()
                })
                .collect(),
        })
        .collect();
    HeatMap {
        title,
        x_label: "h (s)".into(),
        y_label: y_label.into(),
        x_ticks: layout.hs.iter().map(|&h| tick(h)).collect(),
        y_ticks,
        classes: CellClass::legend(),
        panels,
        columns,
        note,
    }
}

/// What a stability map tells [`write_maps`] and [`write_summary`]: its names, axes and
/// methods, how to run one map, draw it, label its rows and write a cell's CSV row.
pub trait StabilityMap {
    /// One pair of axes: time step × another.
    type Axis: Copy + 'static;
    /// What one map stores per cell of its [`Layout`] (a cell's result, or an `Option` of
    /// it where some methods do not run some values).
    type Result;

    /// Name in the progress lines (`{NAME} stability: …`) and the files
    /// (`{NAME}_stability_<axis stem>.svg`, `{NAME}_stability.csv`).
    const NAME: &'static str;
    /// Heading of each map, followed by ` × <axis label>`.
    const HEADING: &'static str;
    /// Alternative text of each map's image, followed by `, h × <axis label>`.
    const ALT: &'static str;
    /// Heading of the summary.
    const SUMMARY: &'static str;
    /// Label of the tables' first column.
    const FIRST_COLUMN: &'static str;
    /// First line of the CSV file (with its newline).
    const CSV_HEADER: &'static str;
    /// The methods, in result order.
    const METHODS: &'static [&'static str];
    /// Every axis pair, in report order.
    const AXES: &'static [Self::Axis];

    /// Label of `axis`.
    fn axis_label(axis: Self::Axis) -> &'static str;
    /// File stem of `axis`'s chart.
    fn axis_stem(axis: Self::Axis) -> &'static str;
    /// Time steps (s).
    fn hs(&self) -> &[f64];
    /// Values along `axis`.
    fn axis_values(&self, axis: Self::Axis) -> Vec<f64>;
    /// Runs the map of `axis` on `threads` threads, calling `announce` with the number of
    /// cells before running them; results in [`Layout::index`] order.
    fn run(
        &self,
        axis: Self::Axis,
        threads: usize,
        announce: &mut dyn FnMut(usize),
    ) -> Vec<Self::Result>;
    /// The heat map of `axis` from its results.
    fn heat_map(&self, axis: Self::Axis, results: &[Self::Result]) -> HeatMap;
    /// The class of a stored result (`None`: not run).
    fn class(result: &Self::Result) -> Option<CellClass>;
    /// One CSV line (without its newline) of a stored result (`None`: not run).
    fn csv_row(axis: Self::Axis, result: &Self::Result) -> Option<String>;
    /// The label of the table row of method `method` at `value` of `axis`.
    fn row_label(&self, axis: Self::Axis, method: usize, value: f64) -> String {
        let _ = (axis, method);
        tick(value)
    }

    /// The layout of the map of `axis`.
    fn layout(&self, axis: Self::Axis) -> Layout<'_> {
        Layout {
            methods: Self::METHODS,
            hs: self.hs(),
            values: self.axis_values(axis).len(),
        }
    }
}

/// The results of every map of a [`StabilityMap`], per axis pair in report order.
pub type Maps<M> = Vec<(<M as StabilityMap>::Axis, Vec<<M as StabilityMap>::Result>)>;

/// Runs every map of `map` on `threads` threads and writes, per axis pair: the heat map
/// `{NAME}_stability_<stem>.svg`, a heading and the image in `md`, a table (a row per
/// method and value, rows with no cell run left out; a column per time step; each cell
/// its class symbol, `—` where not run) and the cell count and wall time; then
/// `{NAME}_stability.csv` (a row per cell run). Returns the results per axis pair.
///
/// # Errors
/// Writing a file.
pub fn write_maps<M: StabilityMap>(
    map: &M,
    md: &mut String,
    out: &Path,
    threads: usize,
) -> std::io::Result<Maps<M>> {
    let mut csv = String::from(M::CSV_HEADER);
    let mut all = Vec::new();
    for &axis in M::AXES {
        let label = M::axis_label(axis);
        let t0 = Instant::now();
        let res = map.run(axis, threads, &mut |n| {
            eprintln!(
                "  {} stability: h × {label}, {n} cells on {threads} thread(s)",
                M::NAME
            );
        });
        let secs = t0.elapsed().as_secs_f64();
        eprintln!("    done in {secs:.1} s");
        let stem = format!("{}_stability_{}", M::NAME, M::axis_stem(axis));
        std::fs::write(
            out.join(format!("{stem}.svg")),
            map.heat_map(axis, &res).to_svg(),
        )?;
        let _ = writeln!(
            md,
            "### {} × {label}\n\n![{}, h × {label}]({stem}.svg)\n",
            M::HEADING,
            M::ALT
        );
        let mut head = format!("| {} | {label} \\ h (s) |", M::FIRST_COLUMN);
        let mut sep = String::from("|---|---|");
        for h in map.hs() {
            let _ = write!(head, " {} |", tick(*h));
            sep.push_str("---|");
        }
        let _ = writeln!(md, "{head}\n{sep}");
        let layout = map.layout(axis);
        let vals = map.axis_values(axis);
        for (m, name) in M::METHODS.iter().enumerate() {
            for (v, x) in vals.iter().enumerate() {
                let row: Vec<Option<&str>> = (0..layout.hs.len())
                    .map(|k| {
                        res.get(layout.index(m, v, k))
                            .and_then(M::class)
                            .map(CellClass::symbol)
                    })
                    .collect();
                if row.iter().all(Option::is_none) {
                    continue;
                }
                let row: Vec<&str> = row.iter().map(|s| s.unwrap_or("—")).collect();
                let label = map.row_label(axis, m, *x);
                let _ = writeln!(md, "| {name} | {label} | {} |", row.join(" | "));
            }
        }
        let count = res.iter().filter(|r| M::class(r).is_some()).count();
        let _ = writeln!(md, "\n({count} cells, {secs:.1} s wall.)\n");
        for r in &res {
            if let Some(row) = M::csv_row(axis, r) {
                let _ = writeln!(csv, "{row}");
            }
        }
        all.push((axis, res));
    }
    std::fs::write(out.join(format!("{}_stability.csv", M::NAME)), csv)?;
    Ok(all)
}

/// Writes the summary of the maps `all` ([`write_maps`]): per method its [`Tally`] over
/// all maps — with the `extra` columns (header, value per method) after `~` — and, per
/// axis pair, the largest time step at which every row the method runs is stable, and
/// at which none is unstable. Returns the tally of all cells.
pub fn write_summary<M: StabilityMap>(
    map: &M,
    md: &mut String,
    all: &Maps<M>,
    extra: &[(&str, Vec<usize>)],
) -> Tally {
    let mut tally = vec![Tally::default(); M::METHODS.len()];
    let mut total = Tally::default();
    for (axis, res) in all {
        let layout = map.layout(*axis);
        for (m, t) in tally.iter_mut().enumerate() {
            for v in 0..layout.values {
                for k in 0..layout.hs.len() {
                    if let Some(c) = res.get(layout.index(m, v, k)).and_then(M::class) {
                        t.add(c);
                        total.add(c);
                    }
                }
            }
        }
    }
    let _ = writeln!(md, "### {}\n", M::SUMMARY);
    let mut head = format!("| {} | ✓ | ~ |", M::FIRST_COLUMN);
    let mut sep = String::from("|---|---|---|");
    for (name, _) in extra {
        let _ = write!(head, " {name} |");
        sep.push_str("---|");
    }
    head.push_str(" unstable | panics |");
    sep.push_str("---|---|");
    for &axis in M::AXES {
        let _ = write!(
            head,
            " largest h stable / bounded on every {} |",
            M::axis_label(axis)
        );
        sep.push_str("---|");
    }
    let _ = writeln!(md, "{head}\n{sep}");
    let hs = map.hs();
    for (m, name) in M::METHODS.iter().enumerate() {
        let t = tally[m];
        let mut row = format!("| {name} | {} | {} |", t.stable, t.inaccurate);
        for (_, values) in extra {
            let _ = write!(row, " {} |", values[m]);
        }
        let _ = write!(row, " {} | {} |", t.unstable, t.panics);
        for (axis, res) in all {
            let layout = map.layout(*axis);
            let largest = |ok: &dyn Fn(CellClass) -> bool| {
                (0..hs.len())
                    .filter(|&k| {
                        (0..layout.values).all(|v| {
                            res.get(layout.index(m, v, k))
                                .and_then(M::class)
                                .is_none_or(ok)
                        })
                    })
                    .map(|k| hs[k])
                    .fold(None, |a: Option<f64>, h| Some(a.map_or(h, |a| a.max(h))))
                    .map_or("none".to_string(), tick)
            };
            let _ = write!(
                row,
                " {} / {} |",
                largest(&|c| c == CellClass::Stable),
                largest(&|c| !c.unstable())
            );
        }
        let _ = writeln!(md, "{row}");
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_follows_the_class_order_and_symbols() {
        let legend = CellClass::legend();
        assert_eq!(legend.len(), CellClass::ALL.len());
        for (k, c) in CellClass::ALL.iter().enumerate() {
            assert_eq!(c.index(), k);
            assert_eq!(legend[k].symbol, c.symbol());
        }
        let unstable: Vec<bool> = CellClass::ALL.iter().map(|c| c.unstable()).collect();
        assert_eq!(unstable, [false, false, true, true, true, true]);
    }

    #[test]
    fn a_tally_counts_every_class() {
        let mut t = Tally::default();
        for c in CellClass::ALL {
            t.add(c);
        }
        assert_eq!(
            t,
            Tally {
                stable: 1,
                inaccurate: 1,
                unstable: 3,
                panics: 1
            }
        );
        assert_eq!(t.cells(), 6);
    }
}
