//! A tetrahedral "jelly" block: `nx × ny × nz` cubes, each split into six tetrahedra
//! along its main diagonal (a conforming Kuhn subdivision), with a spring on every
//! tetrahedron edge and a volume constraint on every tetrahedron (the lecture's
//! "simulación de sólidos: mallar mediante tetraedros y formular restricciones que
//! conserven el volumen", combined with springs).

use super::unique_edges;
use crate::energy::Softness;
use crate::error::SoftError;
use crate::set::ConstraintSet;
use crate::system::SoftSystem;
use constraint_core::{volume::signed_volume, DVec3, Distance, Volume};

/// Which particles are held fixed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum JellyPins {
    /// Nothing: the block falls freely (there is no contact yet).
    #[default]
    None,
    /// The top layer of nodes: the block hangs and sags.
    TopLayer,
}

/// Parameters of the jelly scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jelly {
    /// Cells along x, y, z (each ≥ 1).
    pub cells: [usize; 3],
    /// Cell edge length (m).
    pub cell: f64,
    /// Total mass (kg).
    pub mass: f64,
    /// Edge-spring softness.
    pub spring: Softness,
    /// Volume softness (J/m⁶).
    pub volume: Softness,
    /// Pins.
    pub pins: JellyPins,
}

impl Default for Jelly {
    fn default() -> Self {
        Self {
            cells: [3, 3, 3],
            cell: 0.1,
            mass: 1.0,
            spring: Softness {
                stiffness: 2e3,
                damping: 0.0,
            },
            volume: Softness {
                stiffness: 1e9,
                damping: 0.0,
            },
            pins: JellyPins::TopLayer,
        }
    }
}

impl Jelly {
    /// The rest positions and the tetrahedra (positively oriented) of the block.
    ///
    /// # Errors
    /// `InvalidParameter` for a zero cell count or a cell size that is not positive and
    /// finite.
    pub fn mesh(&self) -> Result<(Vec<DVec3>, Vec<[usize; 4]>), SoftError> {
        let [cx, cy, cz] = self.cells;
        if cx == 0 || cy == 0 || cz == 0 {
            return Err(SoftError::InvalidParameter {
                name: "cells",
                rule: "at least one cell along each axis",
            });
        }
        if !(self.cell > 0.0 && self.cell.is_finite()) {
            return Err(SoftError::InvalidParameter {
                name: "cell",
                rule: "positive and finite",
            });
        }
        let (nx, ny, nz) = (cx + 1, cy + 1, cz + 1);
        let id = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
        let mut x = Vec::with_capacity(nx * ny * nz);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    x.push(DVec3::new(i as f64, j as f64, k as f64) * self.cell);
                }
            }
        }
        // Six tetrahedra per cube: the monotone paths 0 → 7 through the cube's corners.
        const PATHS: [[usize; 2]; 6] = [[1, 3], [1, 5], [2, 3], [2, 6], [4, 5], [4, 6]];
        let mut tets = Vec::new();
        for k in 0..cz {
            for j in 0..cy {
                for i in 0..cx {
                    let corner = |b: usize| id(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
                    for p in PATHS {
                        let mut t = [corner(0), corner(p[0]), corner(p[1]), corner(7)];
                        if signed_volume(&[x[t[0]], x[t[1]], x[t[2]], x[t[3]]]) < 0.0 {
                            t.swap(1, 2);
                        }
                        tets.push(t);
                    }
                }
            }
        }
        Ok((x, tets))
    }

    /// Builds the system.
    ///
    /// # Errors
    /// `InvalidParameter` for a zero cell count or a cell size that is not positive and
    /// finite, `InvalidMass`, softness errors.
    pub fn build(&self) -> Result<SoftSystem, SoftError> {
        let (x, tets) = self.mesh()?;
        let (nx, ny) = (self.cells[0] + 1, self.cells[1] + 1);
        let cz = self.cells[2];
        let id = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
        let mut edges = Vec::new();
        for t in &tets {
            for a in 0..4 {
                for b in a + 1..4 {
                    edges.push((t[a], t[b]));
                }
            }
        }
        let springs = unique_edges(edges)
            .into_iter()
            .enumerate()
            .map(|(k, (a, b))| {
                Distance::from_rest(a, b, &x).map_err(|error| SoftError::Constraint {
                    set: "springs",
                    index: k,
                    error,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let volumes = tets
            .iter()
            .enumerate()
            .map(|(k, t)| {
                Volume::from_rest(*t, &x).map_err(|error| SoftError::Constraint {
                    set: "volumes",
                    index: k,
                    error,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let n = x.len();
        let mut sys = SoftSystem::new(x, vec![self.mass / n as f64; n])?;
        sys.add_set(ConstraintSet::uniform("springs", springs, self.spring)?)?;
        if self.volume.stiffness > 0.0 || self.volume.damping > 0.0 {
            sys.add_set(ConstraintSet::uniform("volumes", volumes, self.volume)?)?;
        } else {
            // Still validate the softness (NaN, negative) as the set would.
            ConstraintSet::uniform("volumes", Vec::<Volume>::new(), self.volume)?;
        }
        if self.pins == JellyPins::TopLayer {
            for j in 0..ny {
                for i in 0..nx {
                    sys.pin(id(i, j, cz))?;
                }
            }
        }
        Ok(sys)
    }
}
