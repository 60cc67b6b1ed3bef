//! Analytic derivatives of the stock constraints against finite differences.
//!
//! For every constraint, 1000 seeded regular configurations ([`fd::random_config`]:
//! points uniform in a box whose size is log-uniform in `[1e-2, 1e2)`, centred within
//! `±10` box sizes of the origin) and 1000 seeded near-degenerate ones per family (the
//! generators of `constraint_verify::fd`, degeneracy ratio log-uniform in
//! `[1e-6, 1e-2)`):
//!
//! | constraint | near-degenerate family |
//! |---|---|
//! | `Distance` | endpoints `1e-6 … 1e-2` of the rest length apart |
//! | `Area` | sliver triangles (caps, needles, obtuse), height `ratio · size` |
//! | `Volume` | nearly flat tetrahedra, apex height `ratio · size` |
//! | `PointOnPlane` | point within `ratio · size` of the plane, up to `1e3 · size` from its origin (the plane is linear: only round-off can degenerate) |
//! | `Dihedral` | nearly flat hinges (open, θ ≈ 0, and folded shut, θ ≈ ±π), and hinges with one sliver wing |
//!
//! At each configuration [`fd::check_derivatives`] measures (see [`FdReport`])
//!
//! * `grad`, `curv`: worst entrywise corrected relative error (MuJoCo's measure, `atol`
//!   = estimated round-off of the difference quotient) of the Jacobian against central
//!   differences of the value, and of the curvature for random row weights against
//!   central differences of the weighted gradient;
//! * `grad (normwise)`, `curv (normwise)`: the same without `atol`, relative to the
//!   largest entry — these always show the residual round-off and truncation;
//! * `fwd/central`: forward against central differences, `O(h/ℓ)` by construction;
//! * `consistency`: asymmetry of the curvature, and `jacobian().value` against
//!   `value()`;
//! * `resolution`: the round-off floor relative to the largest entry. It guards the
//!   guard: a step so small that round-off swamps the quotient would make every
//!   corrected error zero.
//!
//! Regular configurations take the step relative to their size (`h = 1e-6 ℓ`, `ℓ` =
//! largest pairwise distance). Near-degenerate ones take it relative to their small
//! feature length, balanced against the round-off of the cancelling value
//! ([`FdOptions::for_feature`]). **The near-degenerate gates are separate and about
//! 100× looser** than the regular ones: a sliver's cross product cancels to
//! `ratio · size²` from terms of size `size²`, so the value carries a relative
//! round-off of `ε/ratio`, and no step resolves the derivatives better than about
//! `(ε/ratio)^{2/3}` (`≈ 4e-7` at `ratio = 1e-6`).
//!
//! Each gate is about ten times the worst value measured over the 1000 cases, rounded
//! up; the measured value is noted beside it. Where nothing was measured (`0`: every
//! entry within the round-off floor, or an exactly linear function) the gate is the
//! floor of its group: `1e-8` for regular and `1e-6` for near-degenerate families.
//! Every gate is multiplied by `VERIFY_TOL_SCALE`; with `VERIFY_TOL_SCALE=0` the tests
//! only print what they measure (`VERIFY_TOL_SCALE=0 cargo test -p constraint-verify
//! --test derivatives -- --nocapture`). A failing case prints its seed, index,
//! constraint, configuration and report; case `i` of a family is re-created from
//! `Rng::new(seed_base + i)` and the family's closure.

use constraint_core::{
    Area, Curvature, DVec3, Dihedral, Distance, Jacobian, PointConstraint, PointOnPlane, Volume,
};
use constraint_verify::fd::{self, check_derivatives, exceeds, FdOptions, FdReport, Rng, Worst};
use std::fmt::Debug;

/// Configurations per family.
const CASES: u64 = 1000;

/// Largest admissible [`FdReport::resolution`]: the round-off floor `atol` relative to
/// the largest entry. Above it the comparison could not see an error of that relative
/// size, so the check would be vacuous.
const RESOLUTION_GATE: f64 = 2e-5; // measured 1.5e-6 (dihedral/flat-hinge); gate 2e-5

/// Gate on the curvature's asymmetry and on `jacobian().value` against `value()`, for
/// every family. Both are exact up to a few ulps (`atol = 4ε·max|H|` resp. `ε|C|`).
const CONSISTENCY_GATE: f64 = 1e-12; // measured 0 in every family; gate 1e-12

/// Gates for one family, each multiplied by `VERIFY_TOL_SCALE`.
#[derive(Clone, Copy, Debug)]
struct Gates {
    /// Entrywise corrected relative error of the Jacobian ([`FdReport::grad`]).
    grad: f64,
    /// Entrywise corrected relative error of the curvature ([`FdReport::curv`]).
    curv: f64,
    /// Normwise relative error of the Jacobian, no `atol` ([`FdReport::grad_norm`]).
    grad_norm: f64,
    /// Normwise relative error of the curvature, no `atol` ([`FdReport::curv_norm`]).
    curv_norm: f64,
    /// Forward against central differences ([`FdReport::fwd_central`]).
    fwd_central: f64,
    /// Curvature asymmetry and `jacobian().value` against `value()`.
    consistency: f64,
}

/// One case: the constraint, its configuration and the checker options.
struct Case<C, const N: usize> {
    c: C,
    x: [DVec3; N],
    opts: FdOptions,
}

/// Runs `CASES` seeded cases of one family; seed of case `i` is `seed_base + i`.
fn run_family<C, const N: usize, const R: usize>(
    name: &str,
    seed_base: u64,
    gates: Gates,
    make: impl Fn(&mut Rng) -> Case<C, N>,
) where
    C: PointConstraint<N, R> + Debug,
{
    let labels = [
        "grad",
        "curv",
        "grad (normwise)",
        "curv (normwise)",
        "fwd/central",
        "consistency",
        "resolution",
    ];
    let limits = [
        gates.grad,
        gates.curv,
        gates.grad_norm,
        gates.curv_norm,
        gates.fwd_central,
        gates.consistency,
        RESOLUTION_GATE,
    ];
    let mut worst = [Worst::default(); 7];
    let mut failures = Vec::new();
    for i in 0..CASES {
        let seed = seed_base + i;
        let mut rng = Rng::new(seed);
        let case = make(&mut rng);
        let w = rng.weights::<R>();
        let rep: FdReport = check_derivatives(&case.c, &case.x, &w, &case.opts);
        let measured = [
            rep.grad,
            rep.curv,
            rep.grad_norm,
            rep.curv_norm,
            rep.fwd_central(),
            rep.curv_asymmetry.max(rep.value_mismatch),
            rep.resolution(),
        ];
        let mut failed = !rep.is_finite();
        for k in 0..measured.len() {
            worst[k].record(measured[k], i);
            failed |= exceeds(measured[k], limits[k]);
        }
        if failed {
            failures.push(format!(
                "{name}: case {i} (seed {seed}) over a gate\n  constraint {:?}\n  x = {:?}\n  \
                 w = {w:?}\n  {rep:?}",
                case.c, case.x
            ));
        }
    }
    let mut out = format!("{name} ({CASES} cases):\n");
    for k in 0..labels.len() {
        out += &format!("  {}\n", worst[k].summary(labels[k], limits[k]));
    }
    println!("{out}");
    for f in failures.iter().take(5) {
        eprintln!("{f}");
    }
    assert!(
        failures.is_empty(),
        "{name}: {} of {CASES} cases over a gate (first ones printed above)",
        failures.len()
    );
}

/// Degeneracy ratio of a near-degenerate case: log-uniform in `[1e-6, 1e-2)`.
fn ratio(rng: &mut Rng) -> f64 {
    rng.log_uniform(1e-6, 1e-2)
}

/// Overall size of a near-degenerate case: log-uniform in `[1e-2, 1e2)`.
fn size(rng: &mut Rng) -> f64 {
    rng.log_uniform(1e-2, 1e2)
}

// ---------------------------------------------------------------------------------------
// Distance
// ---------------------------------------------------------------------------------------

#[test]
fn distance_regular() {
    let gates = Gates {
        grad: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        curv: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        grad_norm: 3e-9,   // measured 2.1e-10; gate 3e-9
        curv_norm: 3e-9,   // measured 2.1e-10; gate 3e-9
        fwd_central: 9e-6, // measured 8.4e-7; gate 9e-6
        consistency: CONSISTENCY_GATE,
    };
    run_family("distance/regular", 0x1000_0000, gates, |rng| {
        let x = fd::random_config::<2>(rng);
        let l0 = fd::characteristic_length(&x) * rng.uniform(0.5, 2.0);
        Case {
            c: Distance::new(0, 1, l0).unwrap(),
            x,
            opts: FdOptions::default(),
        }
    });
}

#[test]
fn distance_near_coincident() {
    let gates = Gates {
        grad: 1e-6,        // measured 0 (within the round-off floor); gate 1e-6
        curv: 4e-6,        // measured 3.4e-7; gate 4e-6
        grad_norm: 3e-6,   // measured 2.1e-7; gate 3e-6
        curv_norm: 2e-6,   // measured 1.8e-7; gate 2e-6
        fwd_central: 5e-3, // measured 4.4e-4; gate 5e-3
        consistency: CONSISTENCY_GATE,
    };
    run_family("distance/near-coincident", 0x1100_0000, gates, |rng| {
        let (l0, r) = (size(rng), ratio(rng));
        let d = fd::near_coincident_pair(rng, l0, r);
        Case {
            c: Distance::new(0, 1, l0).unwrap(),
            x: d.x,
            opts: FdOptions::for_feature(d.feature, d.length),
        }
    });
}

// ---------------------------------------------------------------------------------------
// Area
// ---------------------------------------------------------------------------------------

#[test]
fn area_regular() {
    let gates = Gates {
        grad: 3e-8,        // measured 2.2e-9; gate 3e-8
        curv: 3e-7,        // measured 2.4e-8; gate 3e-7
        grad_norm: 2e-8,   // measured 1.4e-9; gate 2e-8
        curv_norm: 6e-8,   // measured 5.6e-9; gate 6e-8
        fwd_central: 8e-4, // measured 7.1e-5; gate 8e-4
        consistency: CONSISTENCY_GATE,
    };
    run_family("area/regular", 0x2000_0000, gates, |rng| {
        let x = fd::random_config::<3>(rng);
        let l = fd::characteristic_length(&x);
        Case {
            c: Area::new([0, 1, 2], 0.5 * l * l * rng.uniform(0.1, 1.0)).unwrap(),
            x,
            opts: FdOptions::default(),
        }
    });
}

#[test]
fn area_sliver() {
    let gates = Gates {
        grad: 1e-6,        // measured 0 (within the round-off floor); gate 1e-6
        curv: 2e-6,        // measured 1.0e-7; gate 2e-6
        grad_norm: 2e-6,   // measured 2.0e-7; gate 2e-6
        curv_norm: 7e-6,   // measured 6.9e-7; gate 7e-6
        fwd_central: 1e-2, // measured 9.7e-4; gate 1e-2
        consistency: CONSISTENCY_GATE,
    };
    run_family("area/sliver", 0x2100_0000, gates, |rng| {
        let (l, r) = (size(rng), ratio(rng));
        let d = fd::sliver_triangle(rng, l, r);
        Case {
            c: Area::new([0, 1, 2], 0.5 * l * l * rng.uniform(0.1, 1.0)).unwrap(),
            x: d.x,
            opts: FdOptions::for_feature(d.feature, d.length),
        }
    });
}

// ---------------------------------------------------------------------------------------
// Volume
// ---------------------------------------------------------------------------------------

#[test]
fn volume_regular() {
    let gates = Gates {
        grad: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        curv: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        grad_norm: 9e-9,   // measured 8.5e-10; gate 9e-9
        curv_norm: 3e-9,   // measured 2.0e-10; gate 3e-9
        fwd_central: 1e-8, // measured 0 (within the round-off floor); gate 1e-8
        consistency: CONSISTENCY_GATE,
    };
    run_family("volume/regular", 0x3000_0000, gates, |rng| {
        let x = fd::random_config::<4>(rng);
        let l = fd::characteristic_length(&x);
        Case {
            c: Volume::new([0, 1, 2, 3], l * l * l * rng.uniform(0.01, 0.2)).unwrap(),
            x,
            opts: FdOptions::default(),
        }
    });
}

#[test]
fn volume_flat() {
    let gates = Gates {
        grad: 1e-6,        // measured 0 (within the round-off floor); gate 1e-6
        curv: 1e-6,        // measured 0 (within the round-off floor); gate 1e-6
        grad_norm: 3e-6,   // measured 2.5e-7; gate 3e-6
        curv_norm: 4e-6,   // measured 3.1e-7; gate 4e-6
        fwd_central: 1e-6, // measured 0 (within the round-off floor); gate 1e-6
        consistency: CONSISTENCY_GATE,
    };
    run_family("volume/flat", 0x3100_0000, gates, |rng| {
        let (l, r) = (size(rng), ratio(rng));
        let d = fd::flat_tet(rng, l, r);
        Case {
            c: Volume::new([0, 1, 2, 3], l * l * l * rng.uniform(0.01, 0.2)).unwrap(),
            x: d.x,
            opts: FdOptions::for_feature(d.feature, d.length),
        }
    });
}

// ---------------------------------------------------------------------------------------
// Point on plane
// ---------------------------------------------------------------------------------------

#[test]
fn point_on_plane_regular() {
    let gates = Gates {
        grad: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        curv: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        grad_norm: 3e-9,   // measured 2.1e-10; gate 3e-9
        curv_norm: 1e-8,   // measured 0 (within the round-off floor); gate 1e-8
        fwd_central: 1e-8, // measured 0 (within the round-off floor); gate 1e-8
        consistency: CONSISTENCY_GATE,
    };
    run_family("point-on-plane/regular", 0x4000_0000, gates, |rng| {
        let [x, origin] = fd::random_config::<2>(rng);
        let normal = rng.unit_vector() * rng.log_uniform(1e-3, 1e3);
        Case {
            c: PointOnPlane::new(0, origin, normal).unwrap(),
            x: [x],
            opts: FdOptions::default(),
        }
    });
}

/// The plane is linear, so its only "degenerate" regime is numerical: a point within
/// `ratio · ℓ` of the plane, far (up to `1e3 ℓ`) from the plane's origin, where
/// `nᵀx − nᵀp` cancels.
#[test]
fn point_on_plane_grazing() {
    let gates = Gates {
        grad: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        curv: 1e-8,        // measured 0 (within the round-off floor); gate 1e-8
        grad_norm: 2e-9,   // measured 1.5e-10; gate 2e-9
        curv_norm: 1e-8,   // measured 0 (within the round-off floor); gate 1e-8
        fwd_central: 1e-8, // measured 0 (within the round-off floor); gate 1e-8
        consistency: CONSISTENCY_GATE,
    };
    run_family("point-on-plane/grazing", 0x4100_0000, gates, |rng| {
        let (l, r) = (size(rng), ratio(rng));
        let origin = rng.in_box(DVec3::ZERO, 10.0 * l);
        let n = rng.unit_vector();
        let (t1, _) = n.any_orthonormal_pair();
        let x = origin + t1 * l * rng.log_uniform(1.0, 1e3) + n * (rng.sign() * r * l);
        Case {
            c: PointOnPlane::new(0, origin, n).unwrap(),
            x: [x],
            opts: FdOptions::default(),
        }
    });
}

// ---------------------------------------------------------------------------------------
// Dihedral
// ---------------------------------------------------------------------------------------

mod dihedral {
    use super::*;

    /// A dihedral constraint whose rest angle is taken from a random regular hinge
    /// (`from_rest` rejects sliver rest triangles; retry until it accepts).
    fn random_dihedral(rng: &mut Rng) -> Dihedral {
        loop {
            let rest = fd::random_config::<4>(rng);
            if let Ok(d) = Dihedral::from_rest([0, 1, 2, 3], &rest) {
                return d;
            }
        }
    }

    #[test]
    fn dihedral_regular() {
        let gates = Gates {
            grad: 3e-8,        // measured 2.8e-9; gate 3e-8
            curv: 2e-6,        // measured 1.5e-7; gate 2e-6
            grad_norm: 5e-8,   // measured 4.3e-9; gate 5e-8
            curv_norm: 2e-7,   // measured 1.0e-8; gate 2e-7
            fwd_central: 2e-3, // measured 1.1e-4; gate 2e-3
            consistency: CONSISTENCY_GATE,
        };
        run_family("dihedral/regular", 0x5000_0000, gates, |rng| {
            let c = random_dihedral(rng);
            let x = fd::random_config::<4>(rng);
            Case {
                c,
                x,
                opts: FdOptions::default(),
            }
        });
    }

    #[test]
    fn dihedral_flat_hinge() {
        let gates = Gates {
            grad: 8e-6,        // measured 7.6e-7; gate 8e-6
            curv: 1e-6,        // measured 0 (within the round-off floor); gate 1e-6
            grad_norm: 1e-5,   // measured 9.7e-7; gate 1e-5
            curv_norm: 5e-6,   // measured 4.1e-7; gate 5e-6
            fwd_central: 1e-5, // measured 9.3e-7; gate 1e-5
            consistency: CONSISTENCY_GATE,
        };
        run_family("dihedral/flat-hinge", 0x5100_0000, gates, |rng| {
            let c = random_dihedral(rng);
            let (l, r) = (size(rng), ratio(rng));
            let folded = rng.chance(0.5);
            let d = fd::flat_hinge(rng, l, r, folded);
            Case {
                c,
                x: d.x,
                opts: FdOptions::for_feature(d.feature, d.length),
            }
        });
    }

    #[test]
    fn dihedral_thin_wing() {
        let gates = Gates {
            grad: 1e-6,        // measured 0 (within the round-off floor); gate 1e-6
            curv: 2e-6,        // measured 1.3e-7; gate 2e-6
            grad_norm: 3e-6,   // measured 2.5e-7; gate 3e-6
            curv_norm: 6e-6,   // measured 5.2e-7; gate 6e-6
            fwd_central: 9e-3, // measured 8.0e-4; gate 9e-3
            consistency: CONSISTENCY_GATE,
        };
        run_family("dihedral/thin-wing", 0x5200_0000, gates, |rng| {
            let c = random_dihedral(rng);
            let (l, r) = (size(rng), ratio(rng));
            let d = fd::thin_wing_hinge(rng, l, r);
            Case {
                c,
                x: d.x,
                opts: FdOptions::for_feature(d.feature, d.length),
            }
        });
    }
}

// ---------------------------------------------------------------------------------------
// The gates bite: planted derivative errors are caught
// ---------------------------------------------------------------------------------------

/// How a [`Planted`] constraint corrupts its inner constraint's derivatives.
#[derive(Clone, Copy, Debug)]
enum Plant {
    /// The gradient block of point 1 scaled by `1 + δ` (breaks translation invariance).
    Grad(f64),
    /// The curvature scaled by `1 + δ`.
    Curv(f64),
    /// `δ · max|H|` added to one off-diagonal entry only (breaks symmetry).
    Skew(f64),
}

/// A stock constraint with a small planted derivative error.
#[derive(Debug)]
struct Planted<C> {
    inner: C,
    plant: Plant,
}

impl<C: PointConstraint<N, R>, const N: usize, const R: usize> PointConstraint<N, R>
    for Planted<C>
{
    fn stencil(&self) -> [usize; N] {
        self.inner.stencil()
    }
    fn value(&self, x: &[DVec3; N]) -> [f64; R] {
        self.inner.value(x)
    }
    fn jacobian(&self, x: &[DVec3; N]) -> Jacobian<N, R> {
        let mut j = self.inner.jacobian(x);
        if let Plant::Grad(d) = self.plant {
            for row in &mut j.grad {
                row[1] *= 1.0 + d;
            }
        }
        j
    }
    fn curvature(&self, x: &[DVec3; N], w: &[f64; R]) -> Curvature<N> {
        let mut h = self.inner.curvature(x, w);
        match self.plant {
            Plant::Curv(d) => h = h.scaled(1.0 + d),
            Plant::Skew(d) => {
                let m = (0..3 * N)
                    .flat_map(|a| (0..3 * N).map(move |b| (a, b)))
                    .fold(0.0_f64, |m, (a, b)| m.max(h.entry(a, b).abs()));
                h.blocks[0][1].x_axis.y += d * m;
            }
            Plant::Grad(_) => {}
        }
        h
    }
}

/// Runs 100 cases of a planted family and asserts that `pick(report)` exceeds `gate`
/// in every one of them (skipped in measure mode).
fn assert_caught<C, const N: usize, const R: usize>(
    name: &str,
    gate: f64,
    pick: impl Fn(&FdReport) -> f64,
    make: impl Fn(&mut Rng) -> Case<C, N>,
) where
    C: PointConstraint<N, R> + Debug,
{
    let mut least = f64::INFINITY;
    for i in 0..100 {
        let mut rng = Rng::new(0x9000_0000 + i);
        let case = make(&mut rng);
        let w = rng.weights::<R>();
        let rep = check_derivatives(&case.c, &case.x, &w, &case.opts);
        let m = pick(&rep);
        least = least.min(m);
        assert!(
            fd::measure_only() || exceeds(m, gate),
            "{name}: planted error not caught in case {i}: {m:e} <= gate {gate:e}\n  {:?}\n  \
             x = {:?}\n  {rep:?}",
            case.c,
            case.x
        );
    }
    println!("{name}: smallest measured {least:.3e} against gate {gate:.1e}");
}

#[test]
fn planted_errors_are_caught() {
    // A 1e-6 relative gradient error on regular springs (gate 1e-8, normwise 3e-9).
    assert_caught(
        "distance/regular, grad ×(1+1e-6)",
        1e-8,
        |r| r.grad,
        |rng| {
            let x = fd::random_config::<2>(rng);
            Case {
                c: Planted {
                    inner: Distance::new(0, 1, 1.0).unwrap(),
                    plant: Plant::Grad(1e-6),
                },
                x,
                opts: FdOptions::default(),
            }
        },
    );
    // A 1e-6 relative curvature error on regular triangles (gate 3e-7).
    assert_caught(
        "area/regular, curv ×(1+1e-6)",
        3e-7,
        |r| r.curv,
        |rng| {
            let x = fd::random_config::<3>(rng);
            Case {
                c: Planted {
                    inner: Area::new([0, 1, 2], 1.0).unwrap(),
                    plant: Plant::Curv(1e-6),
                },
                x,
                opts: FdOptions::default(),
            }
        },
    );
    // A 1e-4 relative curvature error on slivers (gate 2e-6).
    assert_caught(
        "area/sliver, curv ×(1+1e-4)",
        2e-6,
        |r| r.curv,
        |rng| {
            let (l, r) = (size(rng), ratio(rng));
            let d = fd::sliver_triangle(rng, l, r);
            Case {
                c: Planted {
                    inner: Area::new([0, 1, 2], l * l).unwrap(),
                    plant: Plant::Curv(1e-4),
                },
                x: d.x,
                opts: FdOptions::for_feature(d.feature, d.length),
            }
        },
    );
    // A 1e-9 asymmetry in the tetrahedron's curvature (consistency gate 1e-12).
    assert_caught(
        "volume/regular, asymmetry 1e-9",
        CONSISTENCY_GATE,
        |r| r.curv_asymmetry,
        |rng| Case {
            c: Planted {
                inner: Volume::new([0, 1, 2, 3], 1.0).unwrap(),
                plant: Plant::Skew(1e-9),
            },
            x: fd::random_config::<4>(rng),
            opts: FdOptions::default(),
        },
    );
    // A 1e-4 relative gradient error on a thin-winged hinge (gate 1e-6).
    assert_caught(
        "dihedral/thin-wing, grad ×(1+1e-4)",
        1e-6,
        |r| r.grad,
        |rng| {
            let (l, r) = (size(rng), ratio(rng));
            let d = fd::thin_wing_hinge(rng, l, r);
            Case {
                c: Planted {
                    inner: Dihedral::new([0, 1, 2, 3], 0.3).unwrap(),
                    plant: Plant::Grad(1e-4),
                },
                x: d.x,
                opts: FdOptions::for_feature(d.feature, d.length),
            }
        },
    );
}
