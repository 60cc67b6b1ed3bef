//! The one stability map ([`crate::articulated_stability`], [`crate::chain_stability`],
//! [`crate::contact_stability`] are three instances): a [`Map`] is data — time steps,
//! axes ([`MapAxis`]: stiffness or compliance, mass ratio, chain length, initial
//! violation, stack height, overlap, Baumgarte factor …) and formulations — and a
//! [`Runner`] is the scene: it builds a cell from (axis, formulation, value, step), runs
//! and classifies it and writes its CSV row. One skeleton does the rest: the grid
//! ([`Map::grid`]), the parallel run ([`run_grid`], [`crate::par::map_cells`], a panic
//! caught per cell), the cell classes with their table symbols and heat-map legend, the
//! per-formulation tally, and the section writer — per axis a heat map, a Markdown table
//! and CSV rows ([`write_maps`]), then a summary per formulation ([`write_summary`]).
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

/// One axis of a map, paired with the time step: data, not code.
#[derive(Clone, Debug, PartialEq)]
pub struct MapAxis {
    /// Label (tables, headings, the heat map's y axis).
    pub label: &'static str,
    /// File stem of the chart (`{name}_stability_<stem>.svg`) and the CSV's `axis` column.
    pub stem: &'static str,
    /// Values along the axis (rows per formulation).
    pub values: Vec<f64>,
    /// Tick label per value (heat map).
    pub ticks: Vec<String>,
    /// The heat map's note (what the cells ran and what stable means).
    pub note: String,
}

impl MapAxis {
    /// An axis whose ticks are the values' [`tick`]s.
    pub fn new(label: &'static str, stem: &'static str, values: Vec<f64>, note: String) -> Self {
        let ticks = values.iter().map(|&v| tick(v)).collect();
        Self {
            label,
            stem,
            values,
            ticks,
            note,
        }
    }
}

/// A stability map as data: its names, formulations, time steps and axes. What runs a
/// cell is the map's [`Runner`].
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    /// Name in the progress lines (`{name} stability: …`) and the files
    /// (`{name}_stability_<stem>.svg`, `{name}_stability.csv`).
    pub name: &'static str,
    /// Heading of each map, followed by ` × <axis label>`.
    pub heading: &'static str,
    /// Alternative text of each map's image, followed by `, h × <axis label>`.
    pub alt: &'static str,
    /// Heat-map title, followed by ` × <axis label>`.
    pub title: &'static str,
    /// Heat-map panels per row.
    pub columns: usize,
    /// Heading of the summary.
    pub summary: &'static str,
    /// Label of the tables' first column.
    pub first_column: &'static str,
    /// First line of the CSV file (with its newline).
    pub csv_header: &'static str,
    /// The formulations' labels, in result order.
    pub methods: &'static [&'static str],
    /// Time steps (s), the columns.
    pub hs: Vec<f64>,
    /// Every axis, in report order.
    pub axes: Vec<MapAxis>,
}

impl Map {
    /// The layout of the map of `axis` (an index into [`Map::axes`]).
    pub fn layout(&self, axis: usize) -> Layout<'_> {
        Layout {
            methods: self.methods,
            hs: &self.hs,
            values: self.axes.get(axis).map_or(0, |a| a.values.len()),
        }
    }

    /// The cells of the map of `axis`, in [`Layout::index`] order: `runner.cell` of
    /// every formulation, value and step (`None`: the formulation does not run there).
    pub fn grid<R: Runner>(&self, runner: &R, axis: usize) -> Vec<Option<R::Cell>> {
        let Some(a) = self.axes.get(axis) else {
            return Vec::new();
        };
        let mut v = Vec::with_capacity(self.methods.len() * a.values.len() * self.hs.len());
        for m in 0..self.methods.len() {
            for &x in &a.values {
                for &h in &self.hs {
                    v.push(runner.cell(axis, m, x, h));
                }
            }
        }
        v
    }
}

/// What differs between maps: the scene a cell runs, its classification and its CSV row.
pub trait Runner: Sync {
    /// One cell's configuration.
    type Cell: Sync;
    /// What one cell measured.
    type Result: Send;
    /// The cell of formulation `method` at `value` of axis `axis` and step `h`; `None`
    /// where the formulation does not run that value.
    fn cell(&self, axis: usize, method: usize, value: f64, h: f64) -> Option<Self::Cell>;
    /// Work estimate of a cell (cells run longest first).
    fn cost(&self, cell: &Self::Cell) -> f64;
    /// Runs and classifies a cell.
    fn run(&self, cell: &Self::Cell) -> Self::Result;
    /// The result of a cell whose run panicked, from the panic message.
    fn panicked(&self, cell: &Self::Cell, message: String) -> Self::Result;
    /// The class of a result.
    fn class(result: &Self::Result) -> CellClass;
    /// One CSV line (without its newline) of a result on the axis of stem `stem`.
    fn csv_row(stem: &str, result: &Self::Result) -> String;
    /// The label of the table row of formulation `method` at `value` of axis `axis`.
    fn row_label(&self, axis: usize, method: usize, value: f64) -> String {
        let _ = (axis, method);
        tick(value)
    }
}

/// Runs the cells of `grid` on `threads` threads ([`crate::par::map_cells`], longest
/// first, a panic caught per cell); results in grid order, `None` stays `None`.
pub fn run_grid<R: Runner>(
    label: &str,
    runner: &R,
    grid: &[Option<R::Cell>],
    threads: usize,
) -> Vec<Option<R::Result>> {
    let cells: Vec<&R::Cell> = grid.iter().flatten().collect();
    let mut res = crate::par::map_cells(
        label,
        &cells,
        threads,
        |c| runner.cost(c),
        |c| runner.run(c),
        |c, m| runner.panicked(c, m),
    )
    .into_iter();
    grid.iter()
        .map(|c| c.as_ref().and_then(|_| res.next()))
        .collect()
}

/// The results of every map of a [`Map`], per axis in report order.
pub type Maps<R> = Vec<Vec<Option<<R as Runner>::Result>>>;

/// Runs every map of `map` on `threads` threads and writes, per axis: the heat map
/// `{name}_stability_<stem>.svg`, a heading and the image in `md`, a table (a row per
/// formulation and value, rows with no cell run left out; a column per time step; each
/// cell its class symbol, `—` where not run) and the cell count and wall time; then
/// `{name}_stability.csv` (a row per cell run). Returns the results per axis.
///
/// # Errors
/// Writing a file.
pub fn write_maps<R: Runner>(
    map: &Map,
    runner: &R,
    md: &mut String,
    out: &Path,
    threads: usize,
) -> std::io::Result<Maps<R>> {
    let mut csv = String::from(map.csv_header);
    let mut all = Vec::new();
    for (a, axis) in map.axes.iter().enumerate() {
        let label = axis.label;
        let t0 = Instant::now();
        let grid = map.grid(runner, a);
        eprintln!(
            "  {} stability: h × {label}, {} cells on {threads} thread(s)",
            map.name,
            grid.iter().flatten().count()
        );
        let res = run_grid(map.name, runner, &grid, threads);
        let secs = t0.elapsed().as_secs_f64();
        eprintln!("    done in {secs:.1} s");
        let layout = map.layout(a);
        let class = |i: usize| res.get(i).and_then(|r| r.as_ref()).map(R::class);
        let stem = format!("{}_stability_{}", map.name, axis.stem);
        let chart = heat_map(
            &layout,
            format!("{} × {label}", map.title),
            label,
            axis.ticks.clone(),
            map.columns,
            axis.note.clone(),
            class,
        );
        std::fs::write(out.join(format!("{stem}.svg")), chart.to_svg())?;
        let _ = writeln!(
            md,
            "### {} × {label}\n\n![{}, h × {label}]({stem}.svg)\n",
            map.heading, map.alt
        );
        let mut head = format!("| {} | {label} \\ h (s) |", map.first_column);
        let mut sep = String::from("|---|---|");
        for h in &map.hs {
            let _ = write!(head, " {} |", tick(*h));
            sep.push_str("---|");
        }
        let _ = writeln!(md, "{head}\n{sep}");
        for (m, name) in map.methods.iter().enumerate() {
            for (v, x) in axis.values.iter().enumerate() {
                let row: Vec<Option<&str>> = (0..layout.hs.len())
                    .map(|k| class(layout.index(m, v, k)).map(CellClass::symbol))
                    .collect();
                if row.iter().all(Option::is_none) {
                    continue;
                }
                let row: Vec<&str> = row.iter().map(|s| s.unwrap_or("—")).collect();
                let label = runner.row_label(a, m, *x);
                let _ = writeln!(md, "| {name} | {label} | {} |", row.join(" | "));
            }
        }
        let count = res.iter().flatten().count();
        let _ = writeln!(md, "\n({count} cells, {secs:.1} s wall.)\n");
        for r in res.iter().flatten() {
            let _ = writeln!(csv, "{}", R::csv_row(axis.stem, r));
        }
        all.push(res);
    }
    std::fs::write(out.join(format!("{}_stability.csv", map.name)), csv)?;
    Ok(all)
}

/// Writes the summary of the maps `all` ([`write_maps`]): per formulation its [`Tally`]
/// over all maps — with the `extra` columns (header, value per formulation) after `~` —
/// and, per axis, the largest time step at which every row the formulation runs is
/// stable, and at which none is unstable. Returns the tally of all cells.
pub fn write_summary<R: Runner>(
    map: &Map,
    md: &mut String,
    all: &Maps<R>,
    extra: &[(&str, Vec<usize>)],
) -> Tally {
    let class =
        |res: &Vec<Option<R::Result>>, i: usize| res.get(i).and_then(|r| r.as_ref()).map(R::class);
    let mut tally = vec![Tally::default(); map.methods.len()];
    let mut total = Tally::default();
    for (a, res) in all.iter().enumerate() {
        let layout = map.layout(a);
        for (m, t) in tally.iter_mut().enumerate() {
            for v in 0..layout.values {
                for k in 0..layout.hs.len() {
                    if let Some(c) = class(res, layout.index(m, v, k)) {
                        t.add(c);
                        total.add(c);
                    }
                }
            }
        }
    }
    let _ = writeln!(md, "### {}\n", map.summary);
    let mut head = format!("| {} | ✓ | ~ |", map.first_column);
    let mut sep = String::from("|---|---|---|");
    for (name, _) in extra {
        let _ = write!(head, " {name} |");
        sep.push_str("---|");
    }
    head.push_str(" unstable | panics |");
    sep.push_str("---|---|");
    for axis in &map.axes {
        let _ = write!(
            head,
            " largest h stable / bounded on every {} |",
            axis.label
        );
        sep.push_str("---|");
    }
    let _ = writeln!(md, "{head}\n{sep}");
    let hs = &map.hs;
    for (m, name) in map.methods.iter().enumerate() {
        let t = tally[m];
        let mut row = format!("| {name} | {} | {} |", t.stable, t.inaccurate);
        for (_, values) in extra {
            let _ = write!(row, " {} |", values.get(m).copied().unwrap_or(0));
        }
        let _ = write!(row, " {} | {} |", t.unstable, t.panics);
        for (a, res) in all.iter().enumerate() {
            let layout = map.layout(a);
            let largest = |ok: &dyn Fn(CellClass) -> bool| {
                (0..hs.len())
                    .filter(|&k| {
                        (0..layout.values).all(|v| class(res, layout.index(m, v, k)).is_none_or(ok))
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
