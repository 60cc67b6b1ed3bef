//! Volume conservation per node (Irving, Schroeder & Fedkiw 2007, "Volume conserving
//! finite element simulations of deformable models", from the lecture's applications
//! slide).
//!
//! One hard constraint per node `i`: the volume of its one-ring (the tetrahedra that
//! contain it) keeps its rest value,
//!
//! ```text
//! C_i(x) = Σ_{t ∋ i} V_t(x) − Σ_{t ∋ i} V_t(x₀),     ∇C_i = Σ_{t ∋ i} ∇V_t
//! ```
//!
//! With one constraint per tetrahedron a mesh has more constraints than free degrees
//! of freedom and locks; with one per node (about five times fewer on a Kuhn mesh)
//! it keeps its volume locally and still moves. Rings whose vertices are all pinned
//! are left out (their rows would be zero).

use crate::rows::ConstraintRows;
use crate::set::RowSet;
use alloc::vec::Vec;
use constraint_core::{volume::signed_volume, DVec3, PointConstraint, Volume};

/// One node's ring: its tetrahedra, the ring's vertices and its rest volume.
#[derive(Clone, Debug, PartialEq)]
struct Ring {
    tets: Vec<usize>,
    stencil: Vec<usize>,
    rest: f64,
}

/// The one-ring volume constraints of a tetrahedral mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct OneRingVolumes {
    tets: Vec<Volume>,
    rings: Vec<Ring>,
}

impl OneRingVolumes {
    /// Builds one constraint per node that lies in at least one tetrahedron and has a
    /// free (unpinned) vertex in its ring.
    ///
    /// # Errors
    /// The tetrahedron's [`constraint_core::ConstraintError`] for a flat, inverted or
    /// out-of-range rest tetrahedron.
    pub fn new(
        tets: &[[usize; 4]],
        rest: &[DVec3],
        pinned: &[bool],
    ) -> Result<Self, constraint_core::ConstraintError> {
        let vols = tets
            .iter()
            .map(|t| Volume::from_rest(*t, rest))
            .collect::<Result<Vec<_>, _>>()?;
        // (node, tet) incidences, sorted: deterministic, no hash map.
        let mut inc: Vec<(usize, usize)> = tets
            .iter()
            .enumerate()
            .flat_map(|(k, t)| t.iter().map(move |&i| (i, k)))
            .collect();
        inc.sort_unstable();
        let mut rings = Vec::new();
        let mut a = 0;
        while a < inc.len() {
            let node = inc[a].0;
            let mut b = a;
            while b < inc.len() && inc[b].0 == node {
                b += 1;
            }
            let ring_tets: Vec<usize> = inc[a..b].iter().map(|p| p.1).collect();
            let mut stencil: Vec<usize> = ring_tets.iter().flat_map(|&k| tets[k]).collect();
            stencil.sort_unstable();
            stencil.dedup();
            let free = stencil
                .iter()
                .any(|&i| !pinned.get(i).copied().unwrap_or(false));
            if free {
                let rest_volume = ring_tets.iter().map(|&k| vols[k].rest_volume).sum();
                rings.push(Ring {
                    tets: ring_tets,
                    stencil,
                    rest: rest_volume,
                });
            }
            a = b;
        }
        Ok(Self { tets: vols, rings })
    }

    /// Number of rings (rows).
    pub fn len(&self) -> usize {
        self.rings.len()
    }

    /// `true` when there are no rings.
    pub fn is_empty(&self) -> bool {
        self.rings.is_empty()
    }

    /// Largest `|V_ring − V_ring,0| / V_ring,0` at `x`.
    pub fn max_relative_error(&self, x: &[DVec3]) -> f64 {
        self.rings
            .iter()
            .map(|r| {
                let v: f64 = r
                    .tets
                    .iter()
                    .filter_map(|&k| self.tets[k].gather(x))
                    .map(|xl| signed_volume(&xl))
                    .sum();
                ((v - r.rest) / r.rest).abs()
            })
            .fold(0.0, crate::rows::nan_max)
    }
}

impl RowSet for OneRingVolumes {
    fn name(&self) -> &'static str {
        "one-ring volumes"
    }

    fn kind(&self) -> &'static str {
        "one-ring volume"
    }

    fn compliant(&self) -> bool {
        false
    }

    fn rows(&self) -> usize {
        self.rings.len()
    }

    fn max_index(&self) -> usize {
        self.rings
            .iter()
            .flat_map(|r| r.stencil.iter())
            .map(|i| i + 1)
            .max()
            .unwrap_or(0)
    }

    fn push_rows(&self, x: &[DVec3], rows: &mut ConstraintRows) {
        let mut entries: Vec<(usize, DVec3)> = Vec::new();
        for r in &self.rings {
            entries.clear();
            entries.extend(r.stencil.iter().map(|&i| (i, DVec3::ZERO)));
            let mut value = -r.rest;
            for &k in &r.tets {
                let t = &self.tets[k];
                let Some(xl) = t.gather(x) else { continue };
                let j = t.jacobian(&xl);
                value += j.value[0] + t.rest_volume;
                for (&i, g) in t.points.iter().zip(j.grad[0]) {
                    if let Ok(p) = r.stencil.binary_search(&i) {
                        entries[p].1 += g;
                    }
                }
            }
            rows.push_row(value, &entries);
        }
    }

    fn push_compliance(&self, out: &mut Vec<f64>) {
        out.extend(core::iter::repeat_n(0.0, self.rings.len()));
    }

    fn push_scales(&self, out: &mut Vec<f64>) {
        out.extend(self.rings.iter().map(|r| r.rest));
    }

    fn push_jdot_v(&self, x: &[DVec3], v: &[DVec3], out: &mut Vec<f64>) {
        for r in &self.rings {
            let mut s = 0.0;
            for &k in &r.tets {
                let t = &self.tets[k];
                let (Some(xl), Some(vl)) = (t.gather(x), t.gather(v)) else {
                    continue;
                };
                let h = t.curvature(&xl, &[1.0]);
                for i in 0..4 {
                    for j in 0..4 {
                        s += vl[i].dot(h.blocks[i][j] * vl[j]);
                    }
                }
            }
            out.push(s);
        }
    }
}
