//! Tendon ranges in the position projection (issue 12): `scenes/tendon_range.xml`'s
//! lower link swings into its tendon's upper bound `ha + hb ≤ 0.4`. The one-sided row
//! holds it at the velocity level to `O(h²)`; the projection (after
//! `Method::VelocityProjected`, and after the default RATTLE's fallback to the velocity
//! level when a one-sided row is active) takes a violated tendon range as an equality at
//! its bound, as it does a violated joint limit.

#![cfg(feature = "mjcf")]

use constraint_articulated::{Method, MjcfScene};

/// The largest overshoot `max(L − 0.4, −0.4 − L, 0)` of the tendon over 1 s at 1 ms,
/// and the largest `L` (that the swing reaches the bound at all).
fn worst_overshoot(method: Method) -> (f64, f64) {
    // Reads ../scenes (excluded from the package in Cargo.toml).
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/tendon_range.xml");
    let mut s = MjcfScene::from_file(&path, Some("start")).expect("scene");
    let [lo, hi] = s.world.tendon_ranges()[0].expect("range");
    let (mut worst, mut top): (f64, f64) = (0.0, f64::NEG_INFINITY);
    for _ in 0..1000 {
        s.world.step(1e-3, method).expect("step");
        let (l, _) = s.world.tendon_length(0).expect("tendon");
        worst = worst.max(l - hi).max(lo - l);
        top = top.max(l);
    }
    (worst, top)
}

#[test]
fn projection_holds_the_tendon_range() {
    let projected = Method::VelocityProjected {
        beta: 1.0,
        tolerance: 1e-10,
        max_iterations: 20,
        correct_velocity: false,
    };
    let (p, p_top) = worst_overshoot(projected);
    let (r, r_top) = worst_overshoot(Method::default());
    println!(
        "tendon overshoot: velocity projected {p:.3e} (max L {p_top:.6}), \
         rattle {r:.3e} (max L {r_top:.6})"
    );
    // The swing reaches the bound 0.4 (else the test could not fail).
    assert!(p_top > 0.4 - 1e-6 && r_top > 0.4 - 1e-6, "{p_top} {r_top}");
    // Without the tendon rows in the projection both overshot by 1.379e-4 rad.
    // Gate: the projection tolerance (1e-10), measured 5.6e-16.
    assert!(p <= 1e-10, "velocity projected {p:e}");
    // Gate: the projection tolerance of RATTLE's steps with a one-sided row active,
    // the unilateral floor `World::DEFAULT_UNILATERAL_TOLERANCE` (1e-8), measured
    // 8.4e-9 (4.4e-16 when RATTLE projected these steps to 1e-12; 8.2e-8 at 1e-7).
    assert!(r <= 1e-8, "rattle {r:e}");
}
