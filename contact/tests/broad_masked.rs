//! Contact generation under a fixed pair mask (`generate_contacts_masked`): the same
//! contacts in the same order as the filtered broad phase (`generate_contacts_filtered`)
//! when the mask allows the filter's pairs; typed errors for bad input.

use constraint_contact::geometry::{
    generate_contacts_filtered, generate_contacts_masked, BroadScratch, Collider, GeometryError,
    PairMask, Shape,
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
