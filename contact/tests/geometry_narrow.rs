//! Narrow phase against hand-computed answers, manifold stability, rotational invariance
//! and degenerate inputs.

use constraint_contact::geometry::{
    closest_segments, collide, point_vs, Collider, Contact, GeometryError, Shape,
};
use constraint_core::Pose;
use glam::{DQuat, DVec3};
use proptest::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

static CASES: AtomicUsize = AtomicUsize::new(0);
static POINTS: AtomicUsize = AtomicUsize::new(0);

fn body(shape: Shape) -> Collider {
    Collider::simple(Some(0), shape).unwrap()
}

fn ground() -> Collider {
    Collider::simple(None, Shape::plane(DVec3::Z, 0.0).unwrap()).unwrap()
}

fn at(x: f64, y: f64, z: f64) -> Pose {
    Pose {
        x: DVec3::new(x, y, z),
        q: DQuat::IDENTITY,
    }
}

fn posed(x: DVec3, q: DQuat) -> Pose {
    Pose { x, q }
}

fn run(a: &Collider, pa: &Pose, b: &Collider, pb: &Pose, margin: f64) -> Vec<Contact> {
    let mut out = Vec::new();
    let n = collide((3, 7), a, pa, b, pb, margin, &mut out);
    assert_eq!(n, out.len());
    for c in &out {
        assert_eq!((c.a, c.b), (3, 7));
        assert!(c.point.is_finite() && c.normal.is_finite() && c.depth.is_finite());
        assert!(
            (c.normal.length() - 1.0).abs() < 1e-12,
            "normal not unit: {c:?}"
        );
    }
    out
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).length() <= tol
}

fn sphere(r: f64) -> Shape {
    Shape::sphere(r).unwrap()
}
fn cuboid(x: f64, y: f64, z: f64) -> Shape {
    Shape::cuboid(DVec3::new(x, y, z)).unwrap()
}
fn capsule(r: f64, h: f64) -> Shape {
    Shape::capsule(r, h).unwrap()
}

/// Rotation taking the capsule's local z axis to world x.
fn along_x() -> DQuat {
    DQuat::from_rotation_y(core::f64::consts::FRAC_PI_2)
}

#[test]
fn sphere_plane() {
    let s = body(sphere(0.5));
    let c = run(&ground(), &Pose::IDENTITY, &s, &at(1.0, 2.0, 0.4), 0.0);
    assert_eq!(c.len(), 1);
    let c = c[0];
    assert!((c.depth - 0.1).abs() < 1e-15, "depth {}", c.depth);
    assert!(close(c.normal, DVec3::Z, 1e-15));
    assert!(close(c.point_on_a(), DVec3::new(1.0, 2.0, 0.0), 1e-15));
    assert!(close(c.point_on_b(), DVec3::new(1.0, 2.0, -0.1), 1e-15));
    assert!(close(c.point, DVec3::new(1.0, 2.0, -0.05), 1e-15));
    assert!((c.gap() + 0.1).abs() < 1e-15);
    // Reversed order: normal flips, depth and point stay.
    let r = run(&s, &at(1.0, 2.0, 0.4), &ground(), &Pose::IDENTITY, 0.0)[0];
    assert!(close(r.normal, -DVec3::Z, 1e-15));
    assert!((r.depth - c.depth).abs() < 1e-15);
    assert!(close(r.point, c.point, 1e-15));
    // Speculative contact inside the margin, none beyond it.
    let sp = run(&ground(), &Pose::IDENTITY, &s, &at(0.0, 0.0, 0.55), 0.1);
    assert_eq!(sp.len(), 1);
    assert!((sp[0].depth + 0.05).abs() < 1e-15);
    assert!(run(&ground(), &Pose::IDENTITY, &s, &at(0.0, 0.0, 0.65), 0.1).is_empty());
}

#[test]
fn tilted_offset_plane_on_body() {
    // Solid x + z ≤ −1 written with a non-unit normal; a unit sphere at the origin is
    // 1/√2 from it, so the depth is 1 − 1/√2 = 0.29289.
    let p = Collider::simple(None, Shape::plane(DVec3::new(1.0, 0.0, 1.0), -1.0).unwrap()).unwrap();
    let s = body(sphere(1.0));
    let c = run(&p, &Pose::IDENTITY, &s, &Pose::IDENTITY, 0.0)[0];
    let h = core::f64::consts::FRAC_1_SQRT_2;
    assert!((c.depth - (1.0 - h)).abs() < 1e-15, "depth {}", c.depth);
    assert!(close(c.normal, DVec3::new(h, 0.0, h), 1e-15));
    // The same plane carried by a collider offset pose: local plane z ≥ 0 moved to
    // (−0.5, 0, −0.5) and rotated so its z goes to (1, 0, 1)/√2.
    let q = DQuat::from_rotation_arc(DVec3::Z, DVec3::new(h, 0.0, h));
    let p2 = Collider::simple(Some(1), Shape::plane(DVec3::Z, 0.0).unwrap())
        .unwrap()
        .with_local(DVec3::new(-0.5, 0.0, -0.5), q)
        .unwrap();
    let c2 = run(&p2, &Pose::IDENTITY, &s, &Pose::IDENTITY, 0.0)[0];
    assert!((c2.depth - c.depth).abs() < 1e-15);
    assert!(close(c2.normal, c.normal, 1e-15));
}

#[test]
fn sphere_sphere() {
    let a = body(sphere(1.0));
    let b = body(sphere(0.5));
    let c = run(&a, &at(0.0, 0.0, 0.0), &b, &at(1.2, 0.0, 0.0), 0.0)[0];
    assert!((c.depth - 0.3).abs() < 1e-15, "depth {}", c.depth);
    assert!(close(c.normal, DVec3::X, 1e-15));
    assert!(close(c.point_on_a(), DVec3::new(1.0, 0.0, 0.0), 1e-15));
    assert!(close(c.point_on_b(), DVec3::new(0.7, 0.0, 0.0), 1e-15));
    // Coincident centres: documented fallback (b's outward normal +z at a's centre, so
    // the normal from a to b is −z), depth = r_a + r_b.
    let c = run(&a, &at(1.0, 1.0, 1.0), &b, &at(1.0, 1.0, 1.0), 0.0)[0];
    assert!(close(c.normal, -DVec3::Z, 0.0));
    assert!((c.depth - 1.5).abs() < 1e-15);
}

#[test]
fn sphere_box() {
    let bx = body(cuboid(1.0, 1.0, 1.0));
    let s = body(sphere(0.5));
    // Face region.
    let c = run(&bx, &Pose::IDENTITY, &s, &at(1.3, 0.2, -0.4), 0.0)[0];
    assert!((c.depth - 0.2).abs() < 1e-15, "depth {}", c.depth);
    assert!(close(c.normal, DVec3::X, 1e-15));
    assert!(close(c.point_on_a(), DVec3::new(1.0, 0.2, -0.4), 1e-15));
    // Corner region: distance √3·0.2 = 0.346410, depth 0.153590.
    let c = run(&bx, &Pose::IDENTITY, &s, &at(1.2, 1.2, 1.2), 0.0)[0];
    assert!((c.depth - (0.5 - 0.2 * 3f64.sqrt())).abs() < 1e-15);
    assert!(close(c.normal, DVec3::ONE.normalize(), 1e-15));
    assert!(close(c.point_on_a(), DVec3::ONE, 1e-15));
    // Centre inside the box: leaves through the nearest face (+x at 0.2), depth 0.7.
    let c = run(&bx, &Pose::IDENTITY, &s, &at(0.8, 0.1, 0.0), 0.0)[0];
    assert!((c.depth - 0.7).abs() < 1e-15);
    assert!(close(c.normal, DVec3::X, 1e-15));
    // Rotated box (45° about z): sphere on the +x side of the rotated face.
    let q = DQuat::from_rotation_z(core::f64::consts::FRAC_PI_4);
    let dir = q * DVec3::X;
    let c = run(&bx, &posed(DVec3::ZERO, q), &s, &posed(dir * 1.4, q), 0.0)[0];
    assert!((c.depth - 0.1).abs() < 1e-14, "depth {}", c.depth);
    assert!(close(c.normal, dir, 1e-14));
}

#[test]
fn capsule_plane() {
    // Lying: both end spheres touch, depth 0.05 at x = ±1.
    let cap = body(capsule(0.2, 1.0));
    let c = run(
        &ground(),
        &Pose::IDENTITY,
        &cap,
        &posed(DVec3::new(0.0, 0.0, 0.15), along_x()),
        0.0,
    );
    assert_eq!(c.len(), 2);
    let ids: Vec<u64> = c.iter().map(|c| c.id).collect();
    assert_eq!(ids, vec![0, 1]);
    for c in &c {
        assert!((c.depth - 0.05).abs() < 1e-15, "depth {}", c.depth);
        assert!(close(c.normal, DVec3::Z, 1e-15));
        assert!((c.point.x.abs() - 1.0).abs() < 1e-15);
    }
    // Standing: only the lower end.
    let c = run(&ground(), &Pose::IDENTITY, &cap, &at(0.0, 0.0, 1.15), 0.0);
    assert_eq!(c.len(), 1);
    assert_eq!(c[0].id, 0);
    assert!((c[0].depth - 0.05).abs() < 1e-15);
    // Zero-length axis: one point.
    let ball = body(capsule(0.2, 0.0));
    assert_eq!(
        run(&ground(), &Pose::IDENTITY, &ball, &at(0.0, 0.0, 0.1), 0.0).len(),
        1
    );
}

#[test]
fn capsule_sphere() {
    let cap = body(capsule(0.2, 1.0));
    let s = body(sphere(0.3));
    let c = run(&cap, &Pose::IDENTITY, &s, &at(0.4, 0.0, 0.5), 0.0)[0];
    assert!((c.depth - 0.1).abs() < 1e-15, "depth {}", c.depth);
    assert!(close(c.normal, DVec3::X, 1e-15));
    assert!(close(c.point_on_a(), DVec3::new(0.2, 0.0, 0.5), 1e-15));
    // Beyond the end cap, on the axis.
    let c = run(&cap, &Pose::IDENTITY, &s, &at(0.0, 0.0, 1.4), 0.0)[0];
    assert!((c.depth - 0.1).abs() < 1e-15);
    assert!(close(c.normal, DVec3::Z, 1e-15));
    // Sphere centre on the axis: a normal perpendicular to the axis, depth r_a + r_b.
    let c = run(&cap, &Pose::IDENTITY, &s, &at(0.0, 0.0, 0.3), 0.0)[0];
    assert!(c.normal.dot(DVec3::Z).abs() < 1e-15);
    assert!((c.depth - 0.5).abs() < 1e-15);
}

#[test]
fn capsule_capsule() {
    let a = body(capsule(0.2, 1.0));
    let b = body(capsule(0.2, 1.0));
    // Crossing: a along z, b along x, 0.35 apart in y: depth 0.05, normal +y.
    let c = run(
        &a,
        &Pose::IDENTITY,
        &b,
        &posed(DVec3::new(0.0, 0.35, 0.0), along_x()),
        0.0,
    );
    assert_eq!(c.len(), 1);
    assert!((c[0].depth - 0.05).abs() < 1e-15, "depth {}", c[0].depth);
    assert!(close(c[0].normal, DVec3::Y, 1e-15));
    assert!(close(c[0].point, DVec3::new(0.0, 0.175, 0.0), 1e-15));
    // Parallel, overlapping on x ∈ [−0.5, 1]: two points at the overlap's ends.
    let c = run(
        &a,
        &posed(DVec3::ZERO, along_x()),
        &b,
        &posed(DVec3::new(0.5, 0.0, 0.35), along_x()),
        0.0,
    );
    assert_eq!(c.len(), 2);
    let xs: Vec<f64> = c.iter().map(|c| c.point.x).collect();
    assert!(
        (xs[0] - 1.0).abs() < 1e-12 && (xs[1] + 0.5).abs() < 1e-12
            || (xs[0] + 0.5).abs() < 1e-12 && (xs[1] - 1.0).abs() < 1e-12,
        "{xs:?}"
    );
    for c in &c {
        assert!((c.depth - 0.05).abs() < 1e-12, "depth {}", c.depth);
        assert!(close(c.normal, DVec3::Z, 1e-12));
    }
    // Intersecting axes: common normal of the axes, depth r_a + r_b.
    let c = run(&a, &Pose::IDENTITY, &b, &posed(DVec3::ZERO, along_x()), 0.0);
    assert_eq!(c.len(), 1);
    assert!((c[0].depth - 0.4).abs() < 1e-15);
    assert!(c[0].normal.dot(DVec3::Y).abs() > 1.0 - 1e-15);
    // Collinear and overlapping: a normal perpendicular to the common axis.
    let c = run(&a, &Pose::IDENTITY, &b, &at(0.0, 0.0, 0.5), 0.0);
    assert!(!c.is_empty());
    for c in &c {
        assert!(c.normal.dot(DVec3::Z).abs() < 1e-12);
        assert!((c.depth - 0.4).abs() < 1e-12);
    }
}

#[test]
fn closest_segments_cases() {
    let (s, t, p, q) = closest_segments(
        DVec3::new(-1.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.5, -1.0, 1.0),
        DVec3::new(0.5, 1.0, 1.0),
    );
    assert!((s - 0.75).abs() < 1e-15 && (t - 0.5).abs() < 1e-15);
    assert!(close(p, DVec3::new(0.5, 0.0, 0.0), 1e-15));
    assert!(close(q, DVec3::new(0.5, 0.0, 1.0), 1e-15));
    // Both degenerate.
    let (_, _, p, q) = closest_segments(DVec3::ONE, DVec3::ONE, DVec3::ZERO, DVec3::ZERO);
    assert_eq!((p, q), (DVec3::ONE, DVec3::ZERO));
}

fn ids(c: &[Contact]) -> Vec<u64> {
    let mut v: Vec<u64> = c.iter().map(|c| c.id).collect();
    v.sort_unstable();
    v
}

#[test]
fn box_plane_four_points_stable_ids() {
    let bx = body(cuboid(0.5, 0.5, 0.5));
    let c = run(&ground(), &Pose::IDENTITY, &bx, &at(0.3, -0.2, 0.49), 0.02);
    assert_eq!(c.len(), 4);
    assert_eq!(ids(&c), vec![0, 1, 2, 3]);
    for c in &c {
        assert!((c.depth - 0.01).abs() < 1e-15, "depth {}", c.depth);
        assert!(close(c.normal, DVec3::Z, 0.0));
        assert!((c.point.z + 0.005).abs() < 1e-15);
    }
    // Small motions keep the four ids.
    let mut worst = 0.0f64;
    for k in 0..50 {
        let a = 1e-3 * (k as f64 * 0.7).sin();
        let q = DQuat::from_euler(glam::EulerRot::XYZ, a, -0.8 * a, 0.3 * a);
        let c = run(
            &ground(),
            &Pose::IDENTITY,
            &bx,
            &posed(DVec3::new(0.3 + a, -0.2, 0.49 + a), q),
            0.02,
        );
        assert_eq!(ids(&c), vec![0, 1, 2, 3]);
        for c in &c {
            worst = worst.max((c.depth - 0.01).abs());
        }
    }
    println!("box on plane: ids stable over 50 perturbations of 1e-3; depth spread {worst:.2e} (tol 3e-3)");
    assert!(worst < 3e-3);
    // Tilted onto an edge: the two lowest vertices only (zero margin).
    let q = DQuat::from_rotation_x(0.3);
    let c = run(
        &ground(),
        &Pose::IDENTITY,
        &bx,
        &posed(DVec3::new(0.0, 0.0, 0.6), q),
        0.0,
    );
    assert_eq!(c.len(), 2);
}

#[test]
fn box_box_face_four_points() {
    let a = body(cuboid(1.0, 1.0, 0.5));
    let b = body(cuboid(0.5, 0.5, 0.5));
    let q = DQuat::from_rotation_z(0.3);
    let pb = posed(DVec3::new(0.1, 0.2, 0.99), q);
    let c = run(&a, &Pose::IDENTITY, &b, &pb, 0.0);
    assert_eq!(c.len(), 4, "{c:?}");
    // Expected: B's bottom corners, midway between z = 0.49 and z = 0.5.
    for c in &c {
        assert!((c.depth - 0.01).abs() < 1e-14, "depth {}", c.depth);
        assert!(close(c.normal, DVec3::Z, 1e-14));
        let local = q.inverse() * (c.point - pb.x);
        assert!(
            (local.x.abs() - 0.5).abs() < 1e-12 && (local.y.abs() - 0.5).abs() < 1e-12,
            "{local}"
        );
        assert!((c.point.z - 0.495).abs() < 1e-14);
    }
    let base = ids(&c);
    // Stable ids under small motion.
    for k in 0..50 {
        let e = 1e-3 * (k as f64 * 1.3).sin();
        let q2 = DQuat::from_euler(glam::EulerRot::XYZ, e, 0.5 * e, 0.3 + e);
        let c2 = run(
            &a,
            &Pose::IDENTITY,
            &b,
            &posed(pb.x + DVec3::splat(e), q2),
            0.0,
        );
        assert_eq!(ids(&c2), base, "perturbation {k}");
    }
    // Swapped order: B is now `a`; normals flip, depths equal.
    let r = run(&b, &pb, &a, &Pose::IDENTITY, 0.0);
    assert_eq!(r.len(), 4);
    for c in &r {
        assert!(close(c.normal, -DVec3::Z, 1e-14));
        assert!((c.depth - 0.01).abs() < 1e-14);
    }
}

#[test]
fn box_box_octagon_reduced_to_four() {
    // Equal squares, one turned 45°: the clipped polygon is an octagon; 4 are kept.
    let a = body(cuboid(1.0, 1.0, 0.5));
    let q = DQuat::from_rotation_z(core::f64::consts::FRAC_PI_4);
    let c = run(
        &a,
        &Pose::IDENTITY,
        &a,
        &posed(DVec3::new(0.0, 0.0, 0.99), q),
        0.0,
    );
    assert_eq!(c.len(), 4);
    for c in &c {
        assert!((c.depth - 0.01).abs() < 1e-14);
        assert!(close(c.normal, DVec3::Z, 1e-14));
    }
    // The kept points span the octagon: their convex hull area (a quadrilateral)
    // is at least half the octagon's 8(√2 − 1) = 3.3137.
    let mut p: Vec<DVec3> = c.iter().map(|c| c.point).collect();
    let centre = p.iter().copied().sum::<DVec3>() / 4.0;
    p.sort_by(|u, v| {
        let au = (u.y - centre.y).atan2(u.x - centre.x);
        let av = (v.y - centre.y).atan2(v.x - centre.x);
        au.total_cmp(&av)
    });
    let mut area = 0.0;
    for k in 0..4 {
        let (u, v) = (p[k], p[(k + 1) % 4]);
        area += 0.5 * (u.x * v.y - v.x * u.y);
    }
    println!("octagon reduced to 4 points: hull area {area:.4} of 3.3137");
    assert!(area > 0.5 * 8.0 * (2f64.sqrt() - 1.0));
}

#[test]
fn box_box_edge_edge_one_point() {
    let a = body(cuboid(0.5, 0.5, 0.5));
    let qa = DQuat::from_rotation_x(core::f64::consts::FRAC_PI_4);
    let qb = DQuat::from_rotation_y(core::f64::consts::FRAC_PI_4);
    let top = 0.5 * 2f64.sqrt();
    let pb = posed(DVec3::new(0.0, 0.0, 2.0 * top - 0.01), qb);
    let c = run(&a, &posed(DVec3::ZERO, qa), &a, &pb, 0.0);
    assert_eq!(c.len(), 1, "{c:?}");
    let c = c[0];
    assert!((c.depth - 0.01).abs() < 1e-14, "depth {}", c.depth);
    assert!(close(c.normal, DVec3::Z, 1e-14));
    assert!(
        close(c.point, DVec3::new(0.0, 0.0, top - 0.005), 1e-14),
        "{}",
        c.point
    );
    assert!(c.id >> 20 == 1);
}

#[test]
fn box_box_separated_and_speculative() {
    let a = body(cuboid(0.5, 0.5, 0.5));
    assert!(run(&a, &Pose::IDENTITY, &a, &at(0.0, 0.0, 1.05), 0.01).is_empty());
    let c = run(&a, &Pose::IDENTITY, &a, &at(0.0, 0.0, 1.05), 0.1);
    assert_eq!(c.len(), 4);
    for c in &c {
        assert!((c.depth + 0.05).abs() < 1e-14);
    }
}

#[test]
fn capsule_box() {
    let bx = body(cuboid(1.0, 1.0, 0.5));
    let cap = body(capsule(0.2, 0.5));
    // Lying on the top face: two points at x = ±0.5, depth 0.01.
    let pc = posed(DVec3::new(0.0, 0.3, 0.69), along_x());
    let c = run(&bx, &Pose::IDENTITY, &cap, &pc, 0.0);
    assert_eq!(c.len(), 2, "{c:?}");
    for c in &c {
        assert!((c.depth - 0.01).abs() < 1e-14, "depth {}", c.depth);
        assert!(close(c.normal, DVec3::Z, 1e-14));
        assert!((c.point.x.abs() - 0.5).abs() < 1e-14 && (c.point.z - 0.495).abs() < 1e-14);
    }
    // Longer than the face: clipped to x = ±1.
    let long = body(capsule(0.2, 2.0));
    let c = run(&bx, &Pose::IDENTITY, &long, &pc, 0.0);
    assert_eq!(c.len(), 2);
    for c in &c {
        assert!((c.point.x.abs() - 1.0).abs() < 1e-14);
    }
    // Standing on the face: one point.
    let c = run(&bx, &Pose::IDENTITY, &cap, &at(0.2, 0.0, 1.19), 0.0);
    assert_eq!(c.len(), 1);
    assert!((c[0].depth - 0.01).abs() < 1e-14);
    assert!(close(c[0].normal, DVec3::Z, 1e-14));
    // Against an edge (capsule along y beyond the +x, +z edge), 45° normal.
    let q = DQuat::from_rotation_x(core::f64::consts::FRAC_PI_2);
    let h = core::f64::consts::FRAC_1_SQRT_2;
    let c = run(
        &bx,
        &Pose::IDENTITY,
        &cap,
        &posed(DVec3::new(1.0 + 0.15 * h, 0.0, 0.5 + 0.15 * h), q),
        0.0,
    );
    assert_eq!(c.len(), 1);
    assert!((c[0].depth - 0.05).abs() < 1e-14, "depth {}", c[0].depth);
    assert!(close(c[0].normal, DVec3::new(h, 0.0, h), 1e-14));
    // Core inside the box: depth beyond the radius, finite normal.
    let c = run(
        &bx,
        &Pose::IDENTITY,
        &cap,
        &posed(DVec3::new(0.0, 0.0, 0.3), along_x()),
        0.0,
    );
    assert!(!c.is_empty());
    for c in &c {
        assert!(c.depth > 0.2, "depth {}", c.depth);
    }
    // Order swapped: normal flips.
    let r = run(&cap, &pc, &bx, &Pose::IDENTITY, 0.0);
    assert_eq!(r.len(), 2);
    assert!(close(r[0].normal, -DVec3::Z, 1e-14));
}

#[test]
fn particles() {
    let pose = Pose::IDENTITY;
    // Plane.
    let c = point_vs(&ground(), &pose, DVec3::new(1.0, 2.0, 0.01), 0.02, 0.0).unwrap();
    assert!((c.depth - 0.01).abs() < 1e-15);
    assert!(close(c.surface, DVec3::new(1.0, 2.0, 0.0), 0.0) && close(c.normal, DVec3::Z, 0.0));
    assert!(point_vs(&ground(), &pose, DVec3::new(0.0, 0.0, 0.1), 0.02, 0.05).is_none());
    let c = point_vs(&ground(), &pose, DVec3::new(0.0, 0.0, 0.05), 0.02, 0.05).unwrap();
    assert!((c.depth + 0.03).abs() < 1e-15);
    // Sphere, moved by its body pose.
    let s = body(sphere(1.0));
    let c = point_vs(&s, &at(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, 1.9), 0.0, 0.0).unwrap();
    assert!((c.depth - 0.1).abs() < 1e-15 && close(c.normal, DVec3::Z, 1e-15));
    assert!(close(c.surface, DVec3::new(0.0, 0.0, 2.0), 1e-15));
    let c = point_vs(&s, &pose, DVec3::ZERO, 0.0, 0.0).unwrap();
    assert!((c.depth - 1.0).abs() < 1e-15 && close(c.normal, DVec3::Z, 0.0));
    // Box: inside near +y face, outside near an edge.
    let bx = body(cuboid(1.0, 2.0, 3.0));
    let c = point_vs(&bx, &pose, DVec3::new(0.0, 1.9, 0.0), 0.0, 0.0).unwrap();
    assert!((c.depth - 0.1).abs() < 1e-15 && close(c.normal, DVec3::Y, 0.0));
    let c = point_vs(&bx, &pose, DVec3::new(1.03, 2.04, 0.0), 0.1, 0.0).unwrap();
    assert!((c.depth - 0.05).abs() < 1e-15);
    assert!(close(c.normal, DVec3::new(0.6, 0.8, 0.0), 1e-14));
    // Box centre: ties resolve to the smallest half extent (x), + side.
    let c = point_vs(&bx, &pose, DVec3::ZERO, 0.0, 0.0).unwrap();
    assert!(close(c.normal, DVec3::X, 0.0) && (c.depth - 1.0).abs() < 1e-15);
    // Capsule: side and on the axis.
    let cap = body(capsule(0.5, 1.0));
    let c = point_vs(&cap, &pose, DVec3::new(0.0, 0.45, 0.7), 0.0, 0.0).unwrap();
    assert!((c.depth - 0.05).abs() < 1e-15 && close(c.normal, DVec3::Y, 1e-15));
    let c = point_vs(&cap, &pose, DVec3::new(0.0, 0.0, 0.7), 0.0, 0.0).unwrap();
    assert!((c.depth - 0.5).abs() < 1e-15 && c.normal.dot(DVec3::Z).abs() < 1e-15);
    assert!(point_vs(&cap, &pose, DVec3::new(0.0, 0.0, 2.0), 0.0, 0.0).is_none());
}

#[test]
fn validation() {
    assert_eq!(Shape::sphere(0.0), Err(GeometryError::NonPositiveSize));
    assert_eq!(Shape::sphere(-1.0), Err(GeometryError::NonPositiveSize));
    assert_eq!(Shape::sphere(f64::NAN), Err(GeometryError::NonFinite));
    assert_eq!(
        Shape::cuboid(DVec3::new(1.0, 0.0, 1.0)),
        Err(GeometryError::NonPositiveSize)
    );
    assert_eq!(
        Shape::cuboid(DVec3::new(1.0, f64::INFINITY, 1.0)),
        Err(GeometryError::NonFinite)
    );
    assert_eq!(
        Shape::capsule(0.1, -1.0),
        Err(GeometryError::NonPositiveSize)
    );
    assert_eq!(
        Shape::capsule(0.0, 1.0),
        Err(GeometryError::NonPositiveSize)
    );
    assert!(Shape::capsule(0.1, 0.0).is_ok());
    assert_eq!(
        Shape::plane(DVec3::ZERO, 1.0),
        Err(GeometryError::ZeroNormal)
    );
    assert_eq!(
        Shape::plane(DVec3::Z, f64::NAN),
        Err(GeometryError::NonFinite)
    );
    let raw = Shape::Plane {
        normal: DVec3::new(0.0, 0.0, 2.0),
        offset: 0.0,
    };
    assert_eq!(Collider::simple(None, raw), Err(GeometryError::ZeroNormal));
    let s = sphere(1.0);
    assert_eq!(
        Collider::new(None, s, Pose::IDENTITY, -0.1, 0.0),
        Err(GeometryError::NegativeFriction)
    );
    assert_eq!(
        Collider::new(None, s, Pose::IDENTITY, 0.1, 1.5),
        Err(GeometryError::RestitutionOutOfRange)
    );
    assert_eq!(
        Collider::new(None, s, Pose::IDENTITY, f64::NAN, 0.5),
        Err(GeometryError::NonFinite)
    );
    let bad = Pose {
        x: DVec3::ZERO,
        q: DQuat::from_xyzw(0.0, 0.0, 0.0, 2.0),
    };
    assert_eq!(
        Collider::new(None, s, bad, 0.1, 0.5),
        Err(GeometryError::NonUnitQuaternion)
    );
    let nan = Pose {
        x: DVec3::new(f64::NAN, 0.0, 0.0),
        q: DQuat::IDENTITY,
    };
    assert_eq!(
        Collider::new(None, s, nan, 0.1, 0.5),
        Err(GeometryError::NonFinite)
    );
    assert!(format!(
        "{}",
        GeometryError::BodyOutOfRange {
            collider: 2,
            body: 9
        }
    )
    .contains('9'));
}

#[test]
fn degenerate_configurations_are_finite() {
    let shapes = [
        Shape::plane(DVec3::Z, 0.0).unwrap(),
        sphere(0.5),
        capsule(0.3, 0.0),
        capsule(0.3, 0.7),
        cuboid(0.5, 0.5, 0.5),
        cuboid(1e-3, 2.0, 0.5),
    ];
    let poses = [
        Pose::IDENTITY,
        at(0.0, 0.0, 1e-300),
        posed(
            DVec3::ZERO,
            DQuat::from_rotation_z(core::f64::consts::FRAC_PI_2),
        ),
        posed(
            DVec3::ZERO,
            DQuat::from_rotation_x(core::f64::consts::FRAC_PI_2),
        ),
        at(0.5, 0.5, 0.5),
        at(1.0, 0.0, 0.0),
    ];
    let mut n = 0;
    for sa in &shapes {
        for sb in &shapes {
            for pa in &poses {
                for pb in &poses {
                    // `run` asserts finite points, normals, depths and unit normals.
                    n += run(&body(*sa), pa, &body(*sb), pb, 0.1).len();
                    for p in [pb.x, DVec3::ZERO] {
                        if let Some(c) = point_vs(&body(*sa), pa, p, 0.0, 0.1) {
                            assert!(
                                c.surface.is_finite()
                                    && c.normal.is_finite()
                                    && c.depth.is_finite()
                            );
                            assert!((c.normal.length() - 1.0).abs() < 1e-12);
                        }
                    }
                }
            }
        }
    }
    println!("degenerate sweep: {n} contacts, all finite");
}

fn arb_shape() -> impl Strategy<Value = Shape> {
    prop_oneof![
        Just(Shape::plane(DVec3::Z, 0.0).unwrap()),
        (0.1f64..1.0).prop_map(sphere),
        (0.1f64..0.6, 0.0f64..1.0).prop_map(|(r, h)| capsule(r, h)),
        (0.1f64..1.0, 0.1f64..1.0, 0.1f64..1.0).prop_map(|(x, y, z)| cuboid(x, y, z)),
    ]
}

fn arb_quat() -> impl Strategy<Value = DQuat> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0).prop_filter_map(
        "zero",
        |(x, y, z, w)| {
            let q = DQuat::from_xyzw(x, y, z, w);
            (q.length() > 0.1).then(|| q.normalize())
        },
    )
}

fn arb_vec(r: f64) -> impl Strategy<Value = DVec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(5000))]

    /// Moving and rotating the whole configuration rotates the normals and points and
    /// leaves depths and ids unchanged.
    #[test]
    fn rotational_invariance(
        sa in arb_shape(), sb in arb_shape(),
        xa in arb_vec(0.5), qa in arb_quat(), xb in arb_vec(1.2), qb in arb_quat(),
        gx in arb_vec(10.0), gq in arb_quat(),
    ) {
        let (ca, cb) = (body(sa), body(sb));
        let (pa, pb) = (posed(xa, qa), posed(xb, qb));
        let c1 = run(&ca, &pa, &cb, &pb, 0.05);
        let k = CASES.fetch_add(1, Ordering::Relaxed);
        let m = POINTS.fetch_add(c1.len(), Ordering::Relaxed) + c1.len();
        if (k + 1) % 1000 == 0 {
            println!("rotational invariance: {} cases, {m} contact points compared", k + 1);
        }
        let g = |p: &Pose| posed(gx + gq * p.x, gq * p.q);
        let c2 = run(&ca, &g(&pa), &cb, &g(&pb), 0.05);
        prop_assert_eq!(c1.len(), c2.len(), "{:?}\n{:?}", c1, c2);
        for (u, v) in c1.iter().zip(&c2) {
            prop_assert_eq!(u.id, v.id);
            prop_assert!((u.depth - v.depth).abs() < 1e-9, "depth {} vs {}", u.depth, v.depth);
            prop_assert!(close(gq * u.normal, v.normal, 1e-9), "normal {} vs {}", gq * u.normal, v.normal);
            prop_assert!(close(gx + gq * u.point, v.point, 1e-8), "point {} vs {}", gx + gq * u.point, v.point);
        }
    }

    /// Random close configurations never give NaN, and the deepest point agrees with
    /// the particle query for sphere pairs.
    #[test]
    fn finite_and_consistent(
        sa in arb_shape(), sb in arb_shape(),
        xa in arb_vec(0.3), qa in arb_quat(), xb in arb_vec(0.6), qb in arb_quat(),
    ) {
        let (ca, cb) = (body(sa), body(sb));
        let c = run(&ca, &posed(xa, qa), &cb, &posed(xb, qb), 0.05);
        if let Shape::Sphere { radius } = sb {
            if let Some(p) = point_vs(&ca, &posed(xa, qa), xb, radius, 0.05) {
                prop_assert_eq!(c.len(), 1);
                prop_assert!((c[0].depth - p.depth).abs() < 1e-12);
                prop_assert!(close(c[0].normal, p.normal, 1e-12));
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    /// Resting contact is full of exact ties (equal face separations, vertices on the
    /// side planes); a rigid motion of the whole scene must not change the manifold.
    #[test]
    fn resting_stack_invariant(
        jitter in arb_vec(1e-6),
        tilt in arb_vec(1e-6),gx in arb_vec(10.0), gq in arb_quat(), h in 0.2f64..1.0, sink in 0.0f64..0.01) {
        let bx = body(cuboid(h, h, h));
        let pa = Pose::IDENTITY;
        let pb = at(0.0, 0.0, 2.0 * h - sink);
        let g = |p: &Pose| posed(gx + gq * p.x, gq * p.q);
        let c1 = run(&bx, &pa, &bx, &pb, 0.01);
        let c2 = run(&bx, &g(&pa), &bx, &g(&pb), 0.01);
        prop_assert_eq!(c1.len(), 4);
        prop_assert_eq!(ids(&c1), ids(&c2));
        // Jitter of 1 µm and 1 µrad (a stack in motion) keeps the ids too.
        let pj = posed(pb.x + jitter, DQuat::from_scaled_axis(tilt));
        let c3 = run(&bx, &pa, &bx, &pj, 0.01);
        prop_assert_eq!(ids(&c1), ids(&c3));
        let plane = Collider::simple(Some(1), Shape::plane(DVec3::Z, 0.0).unwrap()).unwrap();
        let pc = at(0.0, 0.0, h - sink);
        let d1 = run(&plane, &pa, &bx, &pc, 0.01);
        let d2 = run(&plane, &g(&pa), &bx, &g(&pc), 0.01);
        prop_assert_eq!(ids(&d1), vec![0, 1, 2, 3]);
        prop_assert_eq!(ids(&d2), vec![0, 1, 2, 3]);
        for c in c2.iter().chain(&d2) {
            prop_assert!((c.depth - sink).abs() < 1e-12, "depth {} vs {}", c.depth, sink);
            prop_assert!(close(c.normal, gq * DVec3::Z, 1e-12));
        }
    }
}
