//! Scenes with hard constraints: a particle pendulum / chain and an inextensible cloth.

use crate::set::{Constraints, HardSet};
use crate::volume_ring::OneRingVolumes;
use constraint_core::{DVec3, Dihedral, Distance};
use constraint_soft::{Cloth, ConstraintSet, SoftError, SoftSystem, Softness};

/// A chain of `links` particles hanging from a pinned point at the origin by
/// inextensible links of length `link` (m), each particle of mass `mass` (kg), started
/// straight at `angle` (rad) from the downward vertical in the `x–z` plane, at rest.
/// One link is the simple pendulum, whose small-angle period is `2π√(L/g)`.
///
/// # Errors
/// Soft or constraint errors for non-positive lengths or masses.
pub fn chain(
    links: usize,
    link: f64,
    mass: f64,
    angle: f64,
) -> Result<(SoftSystem, Constraints), SoftError> {
    let dir = DVec3::new(angle.sin(), 0.0, -angle.cos());
    let x: Vec<DVec3> = (0..=links).map(|i| dir * (link * i as f64)).collect();
    let mut sys = SoftSystem::new(x, vec![mass; links + 1])?;
    sys.pin(0)?;
    let mut d = Vec::with_capacity(links);
    for i in 0..links {
        d.push(
            Distance::new(i, i + 1, link).map_err(|error| SoftError::Constraint {
                set: "links",
                index: i,
                error,
            })?,
        );
    }
    let mut cons = Constraints::new();
    cons.add(HardSet::hard("links", d));
    Ok((sys, cons))
}

/// Goldenthal et al.'s inextensible cloth: the `n × n` cloth of
/// [`constraint_soft::Cloth`] (1 m, 0.5 kg) hung by its whole top edge, starting flat
/// and swinging down, whose structural edges (rows and columns) are hard distance
/// constraints, with weak soft springs (`k_shear`, N/m) on all edges for shear and no
/// area term.
///
/// The top row's own edges are left out (both ends pinned: nothing to solve). Hanging
/// the cloth by two corners instead makes the first hard row an inextensible chain
/// whose ends are (nearly) as far apart as its length: it must stay straight, the
/// Jacobian loses rank there and the projection stops converging — the measured reason
/// this scene pins the edge.
pub fn inextensible_cloth(n: usize, k_shear: f64) -> Result<(SoftSystem, Constraints), SoftError> {
    tilted_inextensible_cloth(n, k_shear, core::f64::consts::FRAC_PI_2)
}

/// [`inextensible_cloth`] rotated about its pinned top edge (the `x` axis) so that it
/// starts at `tilt` rad from hanging straight down (`π/2`: flat, the cloth falls and
/// folds; smaller angles: it swings like a pendulum, the gentler test of Goldenthal et
/// al.'s hanging cloths).
///
/// # Errors
/// As [`inextensible_cloth`].
pub fn tilted_inextensible_cloth(
    n: usize,
    k_shear: f64,
    tilt: f64,
) -> Result<(SoftSystem, Constraints), SoftError> {
    let cloth = Cloth {
        n,
        spring: Softness::stiff(k_shear),
        area: Softness::stiff(0.0),
        pins: constraint_soft::ClothPins::TopEdge,
        ..Cloth::default()
    };
    let mut sys = cloth.build()?;
    // Row r sits at y = −r·dx; rotate about x so it sits at angle `tilt` from −z.
    let (s, c) = tilt.sin_cos();
    for x in &mut sys.x {
        let d = -x.y;
        *x = DVec3::new(x.x, -d * s, -d * c);
    }
    let d = structural_links(n, &sys.x)?;
    let mut cons = Constraints::new();
    cons.add(HardSet::hard("structural", d));
    Ok((sys, cons))
}

/// The structural edges (rows below the top one, and columns) of an `n × n` cloth
/// laid out by [`constraint_soft::Cloth`], as distance constraints at rest in `x`.
///
/// # Errors
/// Constraint errors for coincident rest points.
pub fn structural_links(n: usize, x: &[DVec3]) -> Result<Vec<Distance>, SoftError> {
    if n < 2 || x.len() < n * n {
        return Err(SoftError::InvalidParameter {
            name: "n",
            rule: "at least 2, with n² positions",
        });
    }
    let mut d = Vec::with_capacity(2 * n * (n - 1));
    for r in 0..n {
        for c in 0..n {
            let i = r * n + c;
            for j in [
                (r > 0 && c + 1 < n).then(|| i + 1),
                (r + 1 < n).then(|| i + n),
            ]
            .into_iter()
            .flatten()
            {
                let k = d.len();
                d.push(
                    Distance::from_rest(i, j, x).map_err(|error| SoftError::Constraint {
                        set: "structural",
                        index: k,
                        error,
                    })?,
                );
            }
        }
    }
    Ok(d)
}

/// Dihedral hinges `[a, b, c, d]` (shared edge `a–b`, wings `c`, `d`) of the cloth's
/// triangulation: every pair of triangles of [`constraint_soft::Cloth`] that share an
/// edge. Deterministic (sorted, no hash map).
pub fn cloth_hinges(n: usize) -> Vec<[usize; 4]> {
    let mut tris = Vec::new();
    for r in 0..n.saturating_sub(1) {
        for c in 0..n - 1 {
            let i = r * n + c;
            tris.push([i, i + n, i + 1]);
            tris.push([i + 1, i + n, i + n + 1]);
        }
    }
    // (edge key, triangle, opposite vertex), edges as sorted pairs.
    let mut edges: Vec<((usize, usize), usize, usize)> = Vec::new();
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b, o) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            edges.push(((a.min(b), a.max(b)), t, o));
        }
    }
    edges.sort_unstable();
    let mut hinges = Vec::new();
    for w in edges.windows(2) {
        if w[0].0 == w[1].0 {
            // Orient the edge as it runs in the first triangle (a → b with wing c).
            let tri = tris[w[0].1];
            let (e0, e1) = w[0].0;
            let k = (0..3).find(|&k| tri[k] == e0 || tri[k] == e1).unwrap_or(0);
            let (a, b) = if tri[(k + 1) % 3] == e0 || tri[(k + 1) % 3] == e1 {
                (tri[k], tri[(k + 1) % 3])
            } else {
                (tri[(k + 2) % 3], tri[k])
            };
            hinges.push([a, b, w[0].2, w[1].2]);
        }
    }
    hinges
}

/// Adds soft bending (dihedral angle, rest angle from the current flat shape) of
/// stiffness `k_bend` (N·m/rad²) to a cloth built by [`tilted_inextensible_cloth`].
///
/// # Errors
/// Constraint errors for degenerate hinges, soft errors for bad stiffness.
pub fn add_bending(sys: &mut SoftSystem, n: usize, k_bend: f64) -> Result<(), SoftError> {
    let hinges = cloth_hinges(n)
        .into_iter()
        .enumerate()
        .map(|(k, h)| {
            Dihedral::from_rest(h, &sys.x).map_err(|error| SoftError::Constraint {
                set: "bending",
                index: k,
                error,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    sys.add_set(ConstraintSet::uniform(
        "bending",
        hinges,
        Softness::stiff(k_bend),
    )?)
}

/// The soft crate's default jelly block (3×3×3 cells of 10 cm, 1 kg, top layer pinned)
/// with edge springs of stiffness `k_spring` (N/m; soft ones give large deformation) and
/// its volume enforced hard per node (one-ring volumes, Irving et al. 2007) instead of
/// by soft per-tetrahedron volume springs.
///
/// # Errors
/// Soft or constraint errors for bad parameters.
pub fn hard_volume_jelly(
    k_spring: f64,
) -> Result<(SoftSystem, Constraints, OneRingVolumes), SoftError> {
    let jelly = constraint_soft::Jelly {
        spring: Softness::stiff(k_spring),
        volume: Softness::stiff(0.0),
        ..constraint_soft::Jelly::default()
    };
    let (x, tets) = jelly.mesh()?;
    let sys = jelly.build()?;
    let rings =
        OneRingVolumes::new(&tets, &x, sys.pinned()).map_err(|error| SoftError::Constraint {
            set: "one-ring volumes",
            index: 0,
            error,
        })?;
    let mut cons = Constraints::new();
    cons.add_rows(Box::new(rings.clone()));
    Ok((sys, cons, rings))
}
