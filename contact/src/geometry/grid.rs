//! Broad phase for many bodies: a uniform grid kept sorted between steps.
//!
//! The cell size `s` is the largest extent of a moving collider's bounding box (times
//! `1 + 1e-6`, so rounding never loses a touching pair). Every box no larger than `s`
//! on each axis is filed under the cell of its lower corner,
//! `(⌊min_z/s⌋, ⌊min_y/s⌋, ⌊min_x/s⌋)`; two such boxes can overlap only if their cells
//! differ by at most one on every axis (`|min_a − min_b| ≤ s` on each axis when they
//! overlap). The filed boxes are kept in a list sorted by (cell, index); between steps
//! bodies rarely change cell, so the list is re-sorted by insertion sort on the previous
//! order (linear on a nearly sorted list; past a budget of moves it finishes with a
//! full sort, which gives the same order since the keys are unique). The sweep walks the
//! sorted list once; each box meets the later boxes of its own row of cells (up to the
//! cell `x + 1`) and those of the four `(z, y)` rows after it (`(z, y + 1)`,
//! `(z + 1, y − 1 ..= y + 1)`), one cursor per row (the four rows before it hold only
//! earlier boxes, which paired with it already): each cursor only moves forward,
//! because the row `(z + dz, y + dy)` starting at `x − 1` grows with the cell in
//! lexicographic order. Boxes larger than a cell (the
//! ground plane, container walls, a huge static box) and boxes with non-finite bounds
//! are tested against every other box.
//!
//! The pairs the sweep tests (its candidates) depend only on which boxes are filed and
//! their cells, so they are kept, sorted, with the cells they were found for: while no
//! box changes cell (a resting pile, from step to step) the next call only files the
//! boxes again and tests the kept candidates' boxes, in their sorted order, without
//! re-sorting or sweeping; the result is the same pairs in the same order.
//!
//! The cell follows the largest moving box, so one moving box much larger than the
//! rest (a long plank among pebbles) makes cells coarse and the sweep tests more pairs
//! per cell; the pairs stay exact.
//!
//! The result is the set of overlapping pairs, `(i, j)` with `i < j`, sorted: the same
//! pairs in the same order as [`super::sweep_and_prune_masked`], in time linear in the
//! number of boxes for scenes of similar-sized bodies (the sweep and prune along one
//! axis tests every box against the whole slab it spans: about `n^1.5` tests for a pile
//! spread over a floor). Ericson, *Real-Time Collision Detection* (2005), §7.1
//! (uniform grids; the lower-corner cell and the neighbour test); the kept, insertion-
//! sorted order is Baraff's (1992) incremental sweep and prune applied to cell keys.

use alloc::vec::Vec;

use super::broad::BroadStats;
use super::shape::Aabb;

/// Cell coordinates `(z, y, x)` packed into one integer, `(z + B) 2^84 + (y + B) 2^42 +
/// (x + B)` with `B = 2^41`: every coordinate lies within `±(2^40 + 1)` (clamped to
/// [`CELL_LIMIT`], a neighbour one further), so each field stays in `[0, 2^42)` and
/// the integer order is the lexicographic order of `(z, y, x)` (rows of `x`); a
/// neighbour's cell is the key plus `dz 2^84 + dy 2^42 + dx`. One integer comparison
/// where the tuple took three.
type Cell = i128;

/// Largest cell coordinate magnitude (keys are clamped to it; clamping is monotone, so
/// overlapping boxes stay within one cell of each other).
const CELL_LIMIT: i64 = 1 << 40;

/// The offset `B` of each packed coordinate ([`Cell`]).
const CELL_BIAS: i64 = 1 << 41;

/// The packed cell `(z, y, x)` ([`Cell`]), `|z|, |y|, |x| ≤ CELL_LIMIT`.
#[inline]
fn pack(z: i64, y: i64, x: i64) -> Cell {
    (i128::from(z + CELL_BIAS) << 84)
        | (i128::from(y + CELL_BIAS) << 42)
        | i128::from(x + CELL_BIAS)
}

/// The packed offset of the neighbouring row `(dz, dy)` ([`Cell`]).
const fn row_offset(dz: i128, dy: i128) -> Cell {
    dz * (1 << 84) + dy * (1 << 42)
}

/// At most this many boxes are paired by testing every pair (`n (n − 1) / 2` box tests,
/// about 15 instructions each) instead of through the grid: filing, sorting and the
/// nine-cursor sweep cost about 1 200 instructions per box on the dm_control models
/// (the manipulator's 31 colliders: 37 000 instructions a call for the grid, about 7 000
/// for every pair), so the grid pays off only beyond some 60 boxes (48: a margin). The
/// five-row sweep and packed cells since cost less (the 210-box pyramid: 990
/// instructions per box a step, 1 700 before); the threshold was not measured again.
/// Either side of it gives the same pairs.
const BRUTE_FORCE_MAX: usize = 48;

/// The grid's buffers, kept between steps (no allocation once grown to the scene).
#[derive(Clone, Debug, Default)]
pub struct GridScratch {
    /// Cell of each box (meaningful for filed boxes only).
    cell: Vec<Cell>,
    /// Whether box `i` is filed in the grid (else tested against everything).
    filed: Vec<bool>,
    /// Whether box `i` was in `sorted` after the previous step.
    was_filed: Vec<bool>,
    /// Filed boxes sorted by (cell, index): the order kept between steps.
    sorted: Vec<usize>,
    /// Boxes tested against everything, ascending.
    large: Vec<usize>,
    /// The cells of `sorted`, in its order.
    keys: Vec<Cell>,
    /// Counts, then slots, per first index ([`sort_pairs`]).
    first: Vec<usize>,
    /// The pairs being sorted ([`sort_pairs`]).
    spare: Vec<(usize, usize)>,
    /// The row cursors of the sweep, one per entry of [`ROWS`].
    cursor: [usize; ROWS.len()],
    /// The pairs the sweep tested (its candidates), `(i, j)`, `i < j`, sorted.
    candidates: Vec<(usize, usize)>,
    /// The cells (`cell`) the candidates were found for: while every box keeps its
    /// cell (and `was_filed` its filing), the sweep would test the same pairs.
    candidate_cells: Vec<Cell>,
    /// Slots of the overlap test's branch-free compaction (at least as long as
    /// `candidates`; its head, the overlapping ones, copied out).
    hits: Vec<(usize, usize)>,
}

/// The neighbouring rows `(dz, dy)` (their packed offsets, [`Cell`]) the sweep walks
/// with cursors: those after the box's own row `(z, y)` in the sorted order (the own
/// row is walked from the box on; the other four hold only earlier boxes).
const ROWS: [Cell; 4] = [
    row_offset(0, 1),
    row_offset(1, -1),
    row_offset(1, 0),
    row_offset(1, 1),
];

/// The cell of a lower corner at cell size `s`.
#[inline]
fn cell_of(aabb: &Aabb, s: f64) -> Cell {
    pack(
        cell_coordinate(aabb.min.z / s),
        cell_coordinate(aabb.min.y / s),
        cell_coordinate(aabb.min.x / s),
    )
}

/// `⌊q⌋` clamped to `±CELL_LIMIT` (NaN: 0), exactly: the saturating truncation `t` of
/// `q` is exact wherever `|q| < 2^63` (below `2^53` it fits the mantissa, above it `q`
/// is an integer), and `⌊q⌋ = t − 1` where `t > q`. The same integers as
/// `libm::floor(q).clamp(±2^40) as i64`, for a few instructions instead of a call of
/// about 25.
#[inline]
fn cell_coordinate(q: f64) -> i64 {
    let t = q as i64;
    // `t − [t > q]`: the comparison's 0 or 1 subtracted, not a branch on it (the
    // sign of a coordinate's fraction is data: 4.2k of the 210-box pyramid's
    // simulated mispredicts in 60 steps, cachegrind `--branch-sim`).
    let f = t.saturating_sub(i64::from((t as f64) > q));
    f.clamp(-CELL_LIMIT, CELL_LIMIT)
}

/// Overlapping pairs `(i, j)`, `i < j`, sorted, into `out` (cleared first); pairs of two
/// boxes marked in `fixed` (a shorter mask marks the rest moving) are left out, as in
/// [`super::sweep_and_prune_masked`]. The cell size comes from the moving boxes (all
/// boxes when none moves). `tests` counts box–box comparisons; `axis` is 0.
pub fn grid_pairs(
    aabbs: &[Aabb],
    fixed: &[bool],
    g: &mut GridScratch,
    out: &mut Vec<(usize, usize)>,
) -> BroadStats {
    out.clear();
    let n = aabbs.len();
    let is_fixed = |i: usize| fixed.get(i).copied().unwrap_or(false);
    if n <= BRUTE_FORCE_MAX {
        // Few boxes: every pair, in (i, j) order, so already sorted; the same set as
        // the grid's (the grid's kept order is left as it was: it is only a sorting
        // aid and any order gives the same pairs).
        let mut tests = 0;
        for i in 0..n {
            for j in i + 1..n {
                tests += 1;
                if !(is_fixed(i) && is_fixed(j)) && aabbs[i].overlaps(&aabbs[j]) {
                    out.push((i, j));
                }
            }
        }
        return BroadStats {
            tests,
            pairs: out.len(),
            axis: 0,
        };
    }
    let finite = |b: &Aabb| b.min.is_finite() && b.max.is_finite();
    let extent = |b: &Aabb| (b.max - b.min).max_element();
    // Cell size: the largest moving box (then all boxes), never zero.
    let mut s: f64 = 0.0;
    for pass in 0..2 {
        for (i, b) in aabbs.iter().enumerate() {
            if (pass == 1 || !is_fixed(i)) && finite(b) {
                s = s.max(extent(b));
            }
        }
        if s > 0.0 {
            break;
        }
    }
    let s = if s > 0.0 && s.is_finite() {
        s * (1.0 + 1e-6)
    } else {
        1.0
    };
    g.cell.clear();
    g.filed.clear();
    g.large.clear();
    for (i, b) in aabbs.iter().enumerate() {
        let small = finite(b) && extent(b) <= s;
        g.filed.push(small);
        g.cell.push(if small { cell_of(b, s) } else { 0 });
        if !small {
            g.large.push(i);
        }
    }
    // The candidates depend only on which boxes are filed and their cells (the sweep
    // order is the (cell, index) order; large boxes meet every box): kept when neither
    // changed since they were found, as in a resting pile from step to step.
    if g.cell != g.candidate_cells || g.filed != g.was_filed {
        sweep_candidates(n, g);
    }
    // The candidates that overlap, in the candidates' sorted order: every candidate
    // written at the next free slot and the slot advanced by whether it overlaps (a
    // branch-free compaction: whether a candidate overlaps is data, and the `push`
    // behind `if` was the 210-box pyramid's largest broad-phase mispredict, 25k of
    // 60 steps' simulated mispredicts, cachegrind `--branch-sim`).
    // The slots are a kept scratch, grown (never cleared) to the candidates' count:
    // sizing `out` itself per step zeroed it first, ≈ 14k instructions a step.
    if g.hits.len() < g.candidates.len() {
        g.hits.resize(g.candidates.len(), (0, 0));
    }
    let mut kept = 0;
    for (&(i, j), k) in g.candidates.iter().zip(0..) {
        let hit = !(is_fixed(i) & is_fixed(j)) & aabbs[i].overlaps(&aabbs[j]);
        // `kept ≤ k`: in bounds.
        if let Some(slot) = g.hits.get_mut(kept.min(k)) {
            *slot = (i, j);
        }
        kept += usize::from(hit);
    }
    out.extend_from_slice(g.hits.get(..kept).unwrap_or_default());
    BroadStats {
        tests: g.candidates.len(),
        pairs: out.len(),
        axis: 0,
    }
}

/// The grid's candidate pairs for the cells `g.cell` of the filed boxes `g.filed` (the
/// others, `g.large`, meet every box), sorted, into `g.candidates`; the kept order
/// re-sorted to the cells, which `g.candidate_cells` and `g.was_filed` record.
fn sweep_candidates(n: usize, g: &mut GridScratch) {
    // The kept order: drop boxes no longer filed (or gone), append newly filed ones.
    let GridScratch {
        cell,
        filed,
        was_filed,
        sorted,
        large,
        keys,
        first,
        spare,
        cursor,
        candidates,
        candidate_cells,
        hits: _,
    } = g;
    sorted.retain(|&i| i < n && filed[i]);
    was_filed.resize(n, false);
    for i in 0..n {
        if filed[i] && !was_filed[i] {
            sorted.push(i);
        }
    }
    insertion_sort(sorted, cell);
    was_filed.clear();
    was_filed.extend_from_slice(filed);

    // The cells in sorted order, contiguous for the sweep's comparisons.
    keys.clear();
    keys.extend(sorted.iter().map(|&i| cell[i]));
    candidates.clear();
    let mut test = |i: usize, j: usize| {
        candidates.push(if i < j { (i, j) } else { (j, i) });
    };
    // Filed against filed: the neighbouring rows `(z + dz, y + dy)`, `|dz|, |dy| ≤ 1`,
    // each pair once (from its earlier box in sorted order). Rows with `dz = −1` or
    // `(dz, dy) = (0, −1)` hold only cells below `(z, y, x − 1)`, so only earlier boxes:
    // they are not swept. In the box's own row the later boxes are those after it up
    // to the cell `(z, y, x + 1)`; the four rows of [`ROWS`] come after the own row,
    // so every box a cursor finds in them is a later one.
    *cursor = [0; ROWS.len()];
    for p in 0..sorted.len() {
        let i = sorted[p];
        let key = keys[p];
        let own = key + 1;
        for q in p + 1..keys.len() {
            if keys[q] > own {
                break;
            }
            test(i, sorted[q]);
        }
        for (cur, &row) in cursor.iter_mut().zip(ROWS.iter()) {
            let lo = key + row - 1;
            let hi = key + row + 1;
            while *cur < keys.len() && keys[*cur] < lo {
                *cur += 1;
            }
            let mut q = *cur;
            while q < keys.len() && keys[q] <= hi {
                test(i, sorted[q]);
                q += 1;
            }
        }
    }
    // Large boxes against every other box (large pairs once).
    for &i in large.iter() {
        for j in 0..n {
            if j == i || (!filed[j] && j < i) {
                continue;
            }
            test(i, j);
        }
    }
    sort_pairs(candidates, n, first, spare);
    candidate_cells.clone_from(cell);
}

/// Sorts the distinct pairs `(i, j)`, `i < j < n`, of `out` as `sort_unstable` would
/// (the order is unique): a counting sort on `i` (Cormen et al., *Introduction to
/// Algorithms*, 8.2) into `spare`, then an insertion sort on `j` within each `i`
/// (a few pairs each), and `out` and `spare` swapped. Linear in `n` and the number of
/// pairs where a comparison sort of the 400 pairs of the 210-box pyramid was 68 000
/// instructions a step (callgrind).
fn sort_pairs(
    out: &mut Vec<(usize, usize)>,
    n: usize,
    first: &mut Vec<usize>,
    spare: &mut Vec<(usize, usize)>,
) {
    first.clear();
    first.resize(n + 1, 0);
    for &(i, _) in out.iter() {
        first[i + 1] += 1;
    }
    for k in 0..n {
        first[k + 1] += first[k];
    }
    spare.clear();
    spare.resize(out.len(), (0, 0));
    for &(i, j) in out.iter() {
        spare[first[i]] = (i, j);
        first[i] += 1;
    }
    // The pairs are grouped by ascending `i` (stable within a group): one insertion
    // sort over the whole list moves each pair only within its short group.
    for k in 1..spare.len() {
        let v = spare[k];
        let mut m = k;
        while m > 0 && spare[m - 1] > v {
            spare[m] = spare[m - 1];
            m -= 1;
        }
        spare[m] = v;
    }
    core::mem::swap(out, spare);
}

/// Sorts `order` by `(cell[i], i)` in place: insertion sort on the previous order
/// (linear when nearly sorted), finished by a full sort past `4 n + 64` moves. The keys
/// are unique, so both give the same order.
fn insertion_sort(order: &mut [usize], cell: &[Cell]) {
    let key = |i: usize| (cell[i], i);
    let budget = 4 * order.len() + 64;
    let mut moves = 0;
    for k in 1..order.len() {
        let v = order[k];
        let kv = key(v);
        let mut m = k;
        while m > 0 && key(order[m - 1]) > kv {
            order[m] = order[m - 1];
            m -= 1;
            moves += 1;
        }
        order[m] = v;
        if moves > budget {
            order.sort_unstable_by_key(|&i| key(i));
            return;
        }
    }
}
