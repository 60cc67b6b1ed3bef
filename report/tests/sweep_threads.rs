//! The report's parallel sweeps (`par::map_cells`: the articulated stability map and
//! the cloth stability sweep) give the same results on 1 and on 4 threads.

use constraint_scene::soft::Method;

/// Thread counts: the articulated stability map runs its cells in parallel
/// (`constraint_report::par::map_cells`). A small cell set — the quick plan's
/// tip-mass-ratio and initial-stretch maps at `h ≥ 1e-3`, cut to 0.2 s — run on 1 and
/// on 4 threads must give bit-identical results, field by field: every field of
/// `CellResult` but the wall time `seconds` (the destructuring is exhaustive, so a new
/// field fails to compile here until it is compared); the cell itself through its
/// `Debug` text (Rust prints an `f64` in the shortest form that parses back to the same
/// bits).
#[test]
fn articulated_stability_cells_are_bit_identical_on_1_and_4_threads() {
    use constraint_report::articulated_stability::{run_all, Axis, CellResult, Plan, METHODS};

    fn bits(r: &CellResult) -> (String, String, u64, [u64; 3], usize, String) {
        let CellResult {
            cell,
            class,
            steps,
            simulated,
            separation,
            energy,
            fallbacks,
            seconds: _,
            message,
        } = r;
        (
            format!("{cell:?}"),
            format!("{class:?}"),
            *steps,
            [simulated.to_bits(), separation.to_bits(), energy.to_bits()],
            *fallbacks,
            message.clone(),
        )
    }

    let plan = Plan::new(true);
    let cells: Vec<_> = [Axis::MassRatio, Axis::Violation]
        .into_iter()
        .flat_map(|axis| plan.cells(axis))
        .filter(|c| c.h >= 1e-3)
        .map(|mut c| {
            c.horizon = 0.2;
            c
        })
        .collect();
    let one = run_all(&cells, 1);
    let four = run_all(&cells, 4);
    assert_eq!(one.len(), cells.len());
    assert_eq!(four.len(), cells.len());
    let mut classes = std::collections::BTreeMap::new();
    for (k, (a, b)) in one.iter().zip(&four).enumerate() {
        assert_eq!(a.cell, cells[k], "cell {k} out of order");
        assert_eq!(
            bits(a),
            bits(b),
            "cell {k} ({}) differs",
            METHODS[a.cell.method]
        );
        *classes.entry(format!("{:?}", a.class)).or_insert(0) += 1;
    }
    println!(
        "articulated stability: {} cells, 1 vs 4 threads bit-identical; classes {classes:?}",
        cells.len()
    );
    // The set must exercise more than the happy path. Measured: 120 cells, 52 stable,
    // 65 inaccurate, 3 blow-up.
    assert!(classes.len() >= 2, "{classes:?}");
}

/// Thread counts, soft side: the cloth stability sweep (`sweeps::stability_sweep_on`,
/// also through `par::map_cells`) on a 6×6 cloth, two stiffnesses × two steps × every
/// method, 0.2 s per cell: the same rows (method, stiffness bits, outcome per step) on
/// 1 and 4 threads.
#[test]
fn cloth_stability_sweep_is_identical_on_1_and_4_threads() {
    use constraint_report::sweeps::{stability_sweep_on, StabilityRow};

    fn bits(r: &StabilityRow) -> (String, u64, String) {
        let StabilityRow {
            method,
            k,
            outcomes,
        } = r;
        (method.label(), k.to_bits(), format!("{outcomes:?}"))
    }

    let (ks, hs) = ([1e2, 1e5], [1e-3, 2e-2]);
    let one = stability_sweep_on(6, &ks, &hs, 0.2, 1);
    let four = stability_sweep_on(6, &ks, &hs, 0.2, 4);
    assert_eq!(one.len(), Method::ALL.len() * ks.len());
    assert_eq!(one.len(), four.len());
    let mut outcomes = std::collections::BTreeMap::new();
    for (a, b) in one.iter().zip(&four) {
        assert_eq!(bits(a), bits(b));
        for o in &a.outcomes {
            *outcomes.entry(format!("{o:?}")).or_insert(0) += 1;
        }
    }
    println!(
        "cloth stability: {} cells, 1 vs 4 threads identical; outcomes {outcomes:?}",
        one.len() * hs.len()
    );
    // The set must hold more than one outcome. Measured: 20 cells, 16 stable, 1
    // energy growth, 3 diverged.
    assert!(outcomes.len() >= 2, "{outcomes:?}");
}
