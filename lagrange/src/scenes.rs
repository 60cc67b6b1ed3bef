//! Scenes with hard constraints: a particle pendulum / chain and an inextensible cloth.

use crate::set::{Constraints, HardSet};
use constraint_core::{DVec3, Distance};
use constraint_soft::{Cloth, SoftError, SoftSystem, Softness};

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
/// [`constraint_soft::Cloth`] (1 m, 0.5 kg, two top corners pinned, starting flat and
/// swinging down) whose structural edges (rows and columns) are hard distance
/// constraints, with weak soft springs (`k_shear`, N/m) on all edges for shear and no
/// area term.
///
/// The edges of the top row are left soft: hard, they would form an inextensible
/// chain between the two pinned corners whose rest length equals the corners'
/// distance, a configuration where the chain must be straight and the Jacobian loses
/// rank (Newton then converges only linearly).
///
/// # Errors
/// Soft or constraint errors for bad parameters.
pub fn inextensible_cloth(n: usize, k_shear: f64) -> Result<(SoftSystem, Constraints), SoftError> {
    let cloth = Cloth {
        n,
        spring: Softness::stiff(k_shear),
        area: Softness::stiff(0.0),
        ..Cloth::default()
    };
    let sys = cloth.build()?;
    let mut d = Vec::with_capacity(2 * n * (n - 1));
    for r in 0..n {
        for c in 0..n {
            let i = cloth.index(r, c);
            for j in [
                (r > 0 && c + 1 < n).then(|| i + 1),
                (r + 1 < n).then(|| i + n),
            ]
            .into_iter()
            .flatten()
            {
                let k = d.len();
                d.push(Distance::from_rest(i, j, &sys.x).map_err(|error| {
                    SoftError::Constraint {
                        set: "structural",
                        index: k,
                        error,
                    }
                })?);
            }
        }
    }
    let mut cons = Constraints::new();
    cons.add(HardSet::hard("structural", d));
    Ok((sys, cons))
}
