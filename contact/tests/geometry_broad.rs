//! Broad phase: sort-and-sweep equals the all-pairs reference and tests far fewer pairs;
//! whole-scene contact generation.

use constraint_contact::geometry::{
    brute_force, generate_contacts, sweep_and_prune, Aabb, Collider, GeometryError, Shape,
};
use constraint_core::Pose;
use glam::{DQuat, DVec3};
use proptest::prelude::*;

mod common;
use common::Rng;

fn random_boxes(n: usize, extent: DVec3, size: (f64, f64), seed: u64) -> Vec<Aabb> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let c = DVec3::new(
                rng.range(0.0, extent.x),
                rng.range(0.0, extent.y),
                rng.range(0.0, extent.z),
            );
            let h = DVec3::new(
                rng.range(size.0, size.1),
                rng.range(size.0, size.1),
                rng.range(size.0, size.1),
            );
            Aabb::new(c - h, c + h)
        })
        .collect()
}

#[test]
fn thousand_boxes_equal_brute_force_with_fewer_tests() {
    for (name, extent, seed) in [
        ("cube 40 m", DVec3::splat(40.0), 1),
        (
            "slab 200 x 200 x 2 m (sweep picks x or y)",
            DVec3::new(200.0, 200.0, 2.0),
            2,
        ),
        (
            "column 2 x 2 x 400 m (sweep picks z)",
            DVec3::new(2.0, 2.0, 400.0),
            3,
        ),
    ] {
        let boxes = random_boxes(1000, extent, (0.2, 1.5), seed);
        let (mut sap, mut all) = (Vec::new(), Vec::new());
        let t0 = std::time::Instant::now();
        let s = sweep_and_prune(&boxes, &mut sap);
        let t_sap = t0.elapsed();
        let t0 = std::time::Instant::now();
        let b = brute_force(&boxes, &mut all);
        let t_all = t0.elapsed();
        assert_eq!(sap, all, "{name}");
        assert!(sap.windows(2).all(|w| w[0] < w[1]));
        println!(
            "{name}: {} pairs; sweep axis {} tests {} ({:.2?}), brute force tests {} ({:.2?}); ratio {:.1}x",
            s.pairs,
            s.axis,
            s.tests,
            t_sap,
            b.tests,
            t_all,
            b.tests as f64 / s.tests as f64
        );
        assert_eq!(b.tests, 1000 * 999 / 2);
        assert!(s.pairs > 0);
        // Tolerance: at least 10× fewer tests than all pairs.
        assert!(s.tests * 10 < b.tests, "{name}: {} tests", s.tests);
    }
    // The column is swept along z (largest variance).
    let col = random_boxes(1000, DVec3::new(2.0, 2.0, 400.0), (0.2, 1.5), 3);
    assert_eq!(sweep_and_prune(&col, &mut Vec::new()).axis, 2);
}

#[test]
fn planes_nan_empty_and_touching() {
    let mut out = vec![(9, 9)];
    assert_eq!(sweep_and_prune(&[], &mut out).pairs, 0);
    assert!(out.is_empty());
    let unit = |x: f64| Aabb::new(DVec3::new(x, 0.0, 0.0), DVec3::new(x + 1.0, 1.0, 1.0));
    // Touching boxes overlap (closed boxes).
    let boxes = vec![
        unit(0.0),
        unit(1.0),
        unit(3.0),
        // A ground plane z ≤ 0 (unbounded below and sideways).
        Aabb::new(
            DVec3::splat(f64::NEG_INFINITY),
            DVec3::new(f64::INFINITY, f64::INFINITY, 0.0),
        ),
        // A NaN box overlaps nothing.
        Aabb::new(DVec3::splat(f64::NAN), DVec3::splat(f64::NAN)),
        unit(5.0),
    ];
    let mut all = Vec::new();
    sweep_and_prune(&boxes, &mut out);
    brute_force(&boxes, &mut all);
    assert_eq!(out, all);
    assert_eq!(out, vec![(0, 1), (0, 3), (1, 3), (2, 3), (3, 5)]);
}

fn arb_boxes() -> impl Strategy<Value = Vec<Aabb>> {
    prop::collection::vec(
        (
            -10.0f64..10.0,
            -10.0f64..10.0,
            -3.0f64..3.0,
            0.0f64..2.0,
            0.0f64..2.0,
            0.0f64..2.0,
        )
            .prop_map(|(x, y, z, a, b, c)| {
                let centre = DVec3::new(x, y, z);
                let h = DVec3::new(a, b, c);
                Aabb::new(centre - h, centre + h)
            }),
        0..120,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn sweep_equals_brute_force(boxes in arb_boxes()) {
        let (mut sap, mut all) = (Vec::new(), Vec::new());
        let s = sweep_and_prune(&boxes, &mut sap);
        brute_force(&boxes, &mut all);
        prop_assert_eq!(&sap, &all);
        prop_assert!(s.tests <= boxes.len() * boxes.len().saturating_sub(1) / 2);
        // Deterministic: a second pass gives the same bits.
        let mut again = Vec::new();
        sweep_and_prune(&boxes, &mut again);
        prop_assert_eq!(sap, again);
    }
}

fn stack_scene() -> (Vec<Collider>, Vec<Pose>) {
    let mut colliders = vec![Collider::simple(None, Shape::plane(DVec3::Z, 0.0).unwrap()).unwrap()];
    let mut poses = Vec::new();
    for k in 0..5 {
        colliders
            .push(Collider::simple(Some(k), Shape::cuboid(DVec3::splat(0.5)).unwrap()).unwrap());
        poses.push(Pose {
            x: DVec3::new(0.0, 0.0, 0.5 + k as f64 * 0.999 - 0.001),
            q: DQuat::IDENTITY,
        });
    }
    // A second collider on body 4 (overlaps its own body: must be skipped).
    colliders.push(
        Collider::simple(Some(4), Shape::sphere(0.6).unwrap())
            .unwrap()
            .with_local(DVec3::new(0.0, 0.0, 0.3), DQuat::IDENTITY)
            .unwrap(),
    );
    (colliders, poses)
}

#[test]
fn stack_of_boxes_scene() {
    let (colliders, poses) = stack_scene();
    let mut out = Vec::new();
    let stats = generate_contacts(&colliders, &poses, 0.01, &mut out).unwrap();
    // Ground–box 0 and box k–box k+1: 4 points each, depth 0.001.
    let pairs: Vec<(usize, usize)> = out.iter().map(|c| (c.a, c.b)).collect();
    println!("stack: {} contacts, broad phase {stats:?}", out.len());
    for p in [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5)] {
        assert_eq!(pairs.iter().filter(|&&q| q == p).count(), 4, "{p:?}");
    }
    // The sphere on body 4 overlaps box 4 (same body: skipped) and stays 0.2 m above box 3.
    assert!(pairs.iter().all(|&(a, b)| a < b && !(a == 5 && b == 6)));
    for c in out.iter().filter(|c| c.b <= 5) {
        assert!((c.depth - 0.001).abs() < 1e-12, "depth {}", c.depth);
        assert!((c.normal - DVec3::Z).length() < 1e-12);
    }
    // Same input, same output.
    let mut again = Vec::new();
    generate_contacts(&colliders, &poses, 0.01, &mut again).unwrap();
    assert_eq!(out, again);
}

#[test]
fn scene_errors() {
    let (colliders, poses) = stack_scene();
    let mut out = Vec::new();
    assert_eq!(
        generate_contacts(&colliders, &poses[..3], 0.01, &mut out),
        Err(GeometryError::BodyOutOfRange {
            collider: 4,
            body: 3
        })
    );
    assert_eq!(
        generate_contacts(&colliders, &poses, -1.0, &mut out),
        Err(GeometryError::BadMargin)
    );
    assert_eq!(
        generate_contacts(&colliders, &poses, f64::NAN, &mut out),
        Err(GeometryError::BadMargin)
    );
    let mut bad = poses.clone();
    bad[2].x.y = f64::INFINITY;
    assert_eq!(
        generate_contacts(&colliders, &bad, 0.01, &mut out),
        Err(GeometryError::NonFinite)
    );
}

#[test]
fn thousand_spheres_scene() {
    // 1000 spheres on a grid with jitter plus a ground plane: contacts from the sweep
    // equal those from testing every pair.
    let mut rng = Rng(7);
    let mut colliders = vec![Collider::simple(None, Shape::plane(DVec3::Z, 0.0).unwrap()).unwrap()];
    let mut poses = Vec::new();
    for k in 0..1000 {
        let (i, j, l) = (k % 10, (k / 10) % 10, k / 100);
        poses.push(Pose {
            x: DVec3::new(
                i as f64 + rng.range(-0.05, 0.05),
                j as f64 + rng.range(-0.05, 0.05),
                0.5 + l as f64 + rng.range(-0.05, 0.05),
            ),
            q: DQuat::IDENTITY,
        });
        colliders.push(Collider::simple(Some(k), Shape::sphere(0.5).unwrap()).unwrap());
    }
    let mut out = Vec::new();
    let t0 = std::time::Instant::now();
    let stats = generate_contacts(&colliders, &poses, 0.01, &mut out).unwrap();
    let t = t0.elapsed();
    // Reference: every pair through the narrow phase.
    let mut reference = Vec::new();
    let t0 = std::time::Instant::now();
    for a in 0..colliders.len() {
        for b in a + 1..colliders.len() {
            let pose = |c: &Collider| c.body.map_or(Pose::IDENTITY, |k| poses[k]);
            constraint_contact::geometry::collide(
                (a, b),
                &colliders[a],
                &pose(&colliders[a]),
                &colliders[b],
                &pose(&colliders[b]),
                0.01,
                &mut reference,
            );
        }
    }
    let t_ref = t0.elapsed();
    assert_eq!(out, reference);
    println!(
        "1000 spheres + plane: {} contacts; sweep tests {} of {} pairs ({:.2?} vs all-pairs narrow phase {:.2?})",
        out.len(),
        stats.tests,
        1001 * 1000 / 2,
        t,
        t_ref
    );
    // A one-axis sweep over a cubic lattice tests each 10 × 10 layer against its
    // neighbours (about n^(5/3) tests): tolerance 4× fewer than all pairs.
    assert!(stats.tests * 4 < 1001 * 1000 / 2);
}

/// A tilted plane's box is unbounded, so the grid pairs it with every collider and the
/// broad phase skips the pairs whose box lies beyond the plane by more than the margin
/// (`broad.rs`, `beyond_plane`). The contacts must be exactly those of the narrow phase
/// over every pair: 400 shapes of each kind placed at signed distances within
/// ±3 margins of the plane (boxes just inside and just outside the skip threshold).
#[test]
fn tilted_plane_skip_keeps_every_contact() {
    let margin = 0.01;
    let normal = DVec3::new(1.0, 0.3, 1.0).normalize();
    let offset = 0.2;
    let mut colliders =
        vec![Collider::simple(None, Shape::plane(normal, offset).unwrap()).unwrap()];
    let mut poses = Vec::new();
    let mut rng = Rng(26);
    let shapes = [
        Shape::sphere(0.05).unwrap(),
        Shape::capsule(0.02, 0.08).unwrap(),
        Shape::cuboid(DVec3::new(0.03, 0.05, 0.02)).unwrap(),
    ];
    for k in 0..1200 {
        let q = DQuat::from_euler(
            glam::EulerRot::XYZ,
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        );
        // A point in the plane, then moved along the normal by the shape's reach (so
        // its nearest surface is near the plane) plus up to ±3 margins.
        let t = DVec3::new(
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
        );
        let on_plane = t - normal * (normal.dot(t) - offset);
        let reach = [0.05, 0.1, 0.062][k % 3];
        let x = on_plane + normal * (reach * rng.next() + rng.range(-3.0, 3.0) * margin);
        colliders.push(Collider::simple(Some(k), shapes[k % 3]).unwrap());
        poses.push(Pose { x, q });
    }
    let mut out = Vec::new();
    generate_contacts(&colliders, &poses, margin, &mut out).unwrap();
    let mut all = Vec::new();
    for j in 1..colliders.len() {
        let b = &colliders[j];
        let pose_b = poses[b.body.unwrap()];
        constraint_contact::geometry::collide(
            (0, j),
            &colliders[0],
            &Pose::IDENTITY,
            b,
            &pose_b,
            margin,
            &mut all,
        );
    }
    // The plane's pairs are compared (shapes far apart rarely touch each other).
    let plane_contacts: Vec<_> = out.iter().filter(|c| c.a == 0).cloned().collect();
    let touching = (1..colliders.len())
        .filter(|&j| all.iter().any(|c| c.b == j))
        .count();
    println!(
        "tilted plane: {} contacts, {touching} of {} shapes within the margin",
        all.len(),
        poses.len()
    );
    // Both sides of the threshold are exercised (measured: 997 of 1200 shapes within
    // the margin, 1646 contacts).
    assert!(touching > 0 && touching < poses.len());
    assert_eq!(plane_contacts, all);
}
