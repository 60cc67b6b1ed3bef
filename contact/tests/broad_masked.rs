//! Contact generation under a fixed pair mask (`generate_contacts_masked`): the same
//! contacts in the same order as the filtered broad phase (`generate_contacts_filtered`)
//! when the mask allows the filter's pairs; typed errors for bad input.

use constraint_contact::geometry::{
    generate_contacts_filtered, generate_contacts_listed, generate_contacts_masked,
    generate_contacts_masked_pairs, BroadScratch, Collider, GeometryError, PairMask, Shape,
};
use constraint_core::Pose;
use glam::{DQuat, DVec3};

mod common;
use common::Rng;

/// `bodies` bodies packed in a cube of side `side` (m) above a ground plane (and a tilted plane
/// when `tilted`), two or three colliders each (spheres, capsules, boxes), plus two
/// static boxes: many overlapping pairs, several colliders per body.
fn scene(bodies: usize, side: f64, tilted: bool, seed: u64) -> (Vec<Collider>, Vec<Pose>) {
    let mut rng = Rng(seed);
    let mut colliders = vec![Collider::simple(None, Shape::plane(DVec3::Z, 0.0).unwrap()).unwrap()];
    if tilted {
        let n = DVec3::new(1.0, 0.3, 1.0).normalize();
        colliders.push(Collider::simple(None, Shape::plane(n, 0.6 * side).unwrap()).unwrap());
    }
    for k in 0..2 {
        colliders.push(
            Collider::simple(None, Shape::cuboid(DVec3::splat(0.2)).unwrap())
                .unwrap()
                .with_local(DVec3::new(0.4 * k as f64, 0.3, 0.1), DQuat::IDENTITY)
                .unwrap(),
        );
    }
    let mut poses = Vec::new();
    for b in 0..bodies {
        poses.push(Pose {
            x: DVec3::new(
                rng.range(0.0, side),
                rng.range(0.0, side),
                rng.range(0.0, side),
            ),
            q: DQuat::from_euler(
                glam::EulerRot::XYZ,
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            ),
        });
        for s in 0..2 + b % 2 {
            let shape = match (b + s) % 3 {
                0 => Shape::sphere(rng.range(0.05, 0.15)).unwrap(),
                1 => Shape::capsule(rng.range(0.03, 0.08), rng.range(0.05, 0.15)).unwrap(),
                _ => Shape::cuboid(DVec3::new(
                    rng.range(0.03, 0.1),
                    rng.range(0.03, 0.1),
                    rng.range(0.03, 0.1),
                ))
                .unwrap(),
            };
            let local = DVec3::new(
                rng.range(-0.1, 0.1),
                rng.range(-0.1, 0.1),
                rng.range(-0.1, 0.1),
            );
            colliders.push(
                Collider::simple(Some(b), shape)
                    .unwrap()
                    .with_local(local, DQuat::IDENTITY)
                    .unwrap(),
            );
        }
    }
    (colliders, poses)
}

/// A fixed pseudo-random filter dropping about a quarter of the pairs.
fn keep(i: usize, j: usize) -> bool {
    (i * 7 + j * 13) % 4 != 0
}

/// The filter's pairs as a mask; `same_body`: also the pairs of one body's colliders
/// (which contact generation must skip by itself); `reversed`: allowed from the last
/// row up (out of order: the mask keeps no pair list, only its bits).
fn mask(colliders: &[Collider], same_body: bool, reversed: bool) -> PairMask {
    let n = colliders.len();
    let mut m = PairMask::new(n);
    for r in 0..n {
        let i = if reversed { n - 1 - r } else { r };
        for j in i + 1..n {
            if (same_body || colliders[i].body != colliders[j].body) && keep(i, j) {
                m.allow(i, j).unwrap();
            }
        }
    }
    m
}

#[test]
fn masked_pairs_give_the_filtered_contacts_in_order() {
    // 12 bodies: under the grid's all-pairs threshold (48 boxes); 40 bodies: over it.
    for (bodies, side, tilted, seed) in [
        (12, 0.5, false, 1),
        (12, 0.5, true, 2),
        (40, 0.75, false, 3),
        (40, 0.75, true, 4),
    ] {
        let (colliders, poses) = scene(bodies, side, tilted, seed);
        let mut scratch = BroadScratch::default();
        let (mut listed, mut filtered) = (Vec::new(), Vec::new());
        // Margins growing, then shrinking (the kept sweep order re-sorted), and both
        // masks (with and without one body's pairs: the same contacts), allowed in
        // order and out of order.
        for (margin, same_body, reversed) in [
            (0.0, false, false),
            (0.01, true, false),
            (0.2, false, true),
            (0.01, false, true),
        ] {
            let m = mask(&colliders, same_body, reversed);
            // Both of the function's paths: every allowed pair tested (at most 16 per
            // collider: the 12-body scenes, measured 11.5 to 12.7) and the sweep (the
            // 40-body scenes, 37.8 to 39.0).
            let per = m.allowed() as f64 / colliders.len() as f64;
            assert_eq!(
                per <= 16.0,
                bodies == 12,
                "{per} allowed pairs per collider"
            );
            let stats =
                generate_contacts_masked(&colliders, &poses, margin, &m, &mut scratch, &mut listed)
                    .unwrap();
            generate_contacts_filtered(&colliders, &poses, margin, keep, &mut filtered).unwrap();
            println!(
                "{} colliders, tilted {tilted}, margin {margin}: {} contacts, {per:.1} allowed pairs per collider, {stats:?}",
                colliders.len(),
                listed.len()
            );
            // Exact equality (same contacts, same order, same bits); the scene is dense
            // enough that there is something to compare (tolerance 50 contacts; measured
            // 87 to 1 499).
            assert_eq!(listed, filtered);
            assert!(listed.len() > 50, "{} contacts", listed.len());
        }
    }
}

/// The pairs a wide generation's sweep met (grown by `extra` more) hold every pair a
/// narrower one meets at poses no collider point left by more than the widening:
/// `generate_contacts_listed` on them gives the masked generation's contacts in order
/// (with and without a tilted plane). A mask tested directly lists nothing.
#[test]
fn listed_pairs_give_the_masked_contacts_after_a_small_move() {
    for (bodies, side, tilted, seed) in [
        (12, 0.5, false, 5),
        (40, 0.75, false, 7),
        (40, 0.75, true, 8),
    ] {
        let (colliders, poses) = scene(bodies, side, tilted, seed);
        let m = mask(&colliders, false, false);
        // Each box grown by `wide / 2 = margin / 2 + 0.005` and listed `extra` = 0.005
        // beyond: a pair's two moves may sum to 0.02.
        let (margin, wide, extra) = (0.02, 0.03, 0.005);
        let mut scratch = BroadScratch::default();
        let (mut first, mut pairs) = (Vec::new(), Vec::new());
        let (_, swept) = generate_contacts_masked_pairs(
            &colliders,
            &poses,
            wide,
            extra,
            &m,
            &mut scratch,
            &mut first,
            &mut pairs,
        )
        .unwrap();
        let mut alone = Vec::new();
        generate_contacts_masked(&colliders, &poses, wide, &m, &mut scratch, &mut alone).unwrap();
        // The listing leaves the contacts as they were.
        assert_eq!(first, alone);
        if bodies == 12 {
            // 11.5 to 12.7 allowed pairs per collider: tested directly, nothing listed.
            assert!(!swept && pairs.is_empty(), "{swept} {}", pairs.len());
            continue;
        }
        assert!(swept);
        // Sorted, distinct, allowed.
        assert!(pairs.windows(2).all(|w| w[0] < w[1]));
        assert!(pairs.iter().all(|&(a, b)| m.allows(a, b)));
        // Each body moved: its colliders' points (within 0.41 m of its origin: offsets
        // up to 0.18 m, bounding radii up to 0.23 m) by at most |Δx| + 2 sin(θ/2) 0.41
        // = 0.004 + 0.0041, so a pair's two moves stay within 0.02.
        let mut rng = Rng(seed + 100);
        let moved: Vec<Pose> = poses
            .iter()
            .map(|p| Pose {
                x: p.x
                    + DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0).normalize()
                        * 0.004,
                q: DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.01) * p.q,
            })
            .collect();
        let (mut listed, mut masked) = (Vec::new(), Vec::new());
        let stats = generate_contacts_listed(
            &colliders,
            &moved,
            margin,
            &pairs,
            &mut scratch,
            &mut listed,
        )
        .unwrap();
        generate_contacts_masked(&colliders, &moved, margin, &m, &mut scratch, &mut masked)
            .unwrap();
        println!(
            "{} colliders, tilted {tilted}: {} pairs listed, {stats:?}, {} contacts",
            colliders.len(),
            pairs.len(),
            listed.len()
        );
        // Exact equality; something to compare (tolerance 50 contacts).
        assert_eq!(listed, masked);
        assert!(listed.len() > 50, "{} contacts", listed.len());
    }
    // A pair naming a collider beyond the scene, a negative extra: typed errors.
    let (colliders, poses) = scene(5, 0.5, false, 9);
    let n = colliders.len();
    let mut out = Vec::new();
    let mut scratch = BroadScratch::default();
    assert_eq!(
        generate_contacts_listed(&colliders, &poses, 0.01, &[(0, n)], &mut scratch, &mut out),
        Err(GeometryError::PairMaskSize {
            mask: n,
            colliders: n
        })
    );
    let m = mask(&colliders, false, false);
    let mut pairs = vec![(0, 1)];
    assert_eq!(
        generate_contacts_masked_pairs(
            &colliders,
            &poses,
            0.01,
            -1.0,
            &m,
            &mut scratch,
            &mut out,
            &mut pairs
        ),
        Err(GeometryError::BadMargin)
    );
    assert!(pairs.is_empty());
}

#[test]
fn masked_errors() {
    let (colliders, poses) = scene(5, 0.5, false, 9);
    let list = mask(&colliders, false, false);
    let mut scratch = BroadScratch::default();
    let mut out = Vec::new();
    let mut call = |poses: &[Pose], margin: f64, list: &PairMask| {
        generate_contacts_masked(&colliders, poses, margin, list, &mut scratch, &mut out)
    };
    assert_eq!(call(&poses, f64::NAN, &list), Err(GeometryError::BadMargin));
    assert_eq!(call(&poses, -0.1, &list), Err(GeometryError::BadMargin));
    let mut bad = poses.clone();
    bad[1].q.x = f64::NAN;
    assert_eq!(call(&bad, 0.01, &list), Err(GeometryError::NonFinite));
    assert!(matches!(
        call(&poses[..2], 0.01, &list),
        Err(GeometryError::BodyOutOfRange { body: 2, .. })
    ));
    let n = colliders.len();
    assert_eq!(
        call(&poses, 0.01, &PairMask::new(n + 1)),
        Err(GeometryError::PairMaskSize {
            mask: n + 1,
            colliders: n
        })
    );
    let mut m = PairMask::new(n);
    assert_eq!(
        m.allow(2, n),
        Err(GeometryError::PairMaskSize {
            mask: n,
            colliders: n
        })
    );
    assert!(!m.allows(2, n) && !m.allows(n, 2) && !m.allows(0, 1));
    m.allow(1, 0).unwrap();
    assert!(m.allows(0, 1) && m.allows(1, 0) && !m.allows(0, 2));
}
