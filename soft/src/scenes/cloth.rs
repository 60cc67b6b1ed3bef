//! A square cloth of `n × n` particles: structural and shear springs plus one area
//! constraint per triangle (the lecture's "simulación de ropa: mallar mediante
//! triángulos y formular restricciones que conserven el área", combined with springs).
//!
//! The cloth starts flat in the `x–y` plane at `z = 0` (row `r` at `y = −r·dx`) and,
//! held by its pins along the row `r = 0`, swings down under gravity `−z`.

use super::unique_edges;
use crate::energy::Softness;
use crate::error::SoftError;
use crate::set::ConstraintSet;
use crate::system::SoftSystem;
use constraint_core::{Area, DVec3, Distance};

/// Which particles are held fixed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ClothPins {
    /// The two top corners.
    #[default]
    TopCorners,
    /// The whole top edge.
    TopEdge,
    /// Nothing (free fall).
    None,
}

/// Parameters of the cloth scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cloth {
    /// Particles per side (`n ≥ 2`).
    pub n: usize,
    /// Side length (m).
    pub size: f64,
    /// Total mass (kg), spread evenly over the particles.
    pub mass: f64,
    /// Spring stiffness and damping (N/m, N·s/m).
    pub spring: Softness,
    /// Area stiffness (J/m⁴) and damping.
    pub area: Softness,
    /// Pins.
    pub pins: ClothPins,
}

impl Default for Cloth {
    fn default() -> Self {
        Self {
            n: 16,
            size: 1.0,
            mass: 0.5,
            spring: Softness {
                stiffness: 1e3,
                damping: 0.0,
            },
            area: Softness {
                stiffness: 1e5,
                damping: 0.0,
            },
            pins: ClothPins::TopCorners,
        }
    }
}

impl Cloth {
    /// Index of the particle in row `r` (from the top) and column `c`.
    pub fn index(&self, r: usize, c: usize) -> usize {
        r * self.n + c
    }

    /// Builds the system.
    ///
    /// # Errors
    /// [`SoftError::InvalidParameter`] for `n < 2` or a size that is not positive and
    /// finite, `InvalidMass` for a bad mass, softness errors.
    pub fn build(&self) -> Result<SoftSystem, SoftError> {
        let n = self.n;
        if n < 2 {
            return Err(SoftError::InvalidParameter {
                name: "n",
                rule: "at least 2 particles per side",
            });
        }
        if !(self.size > 0.0 && self.size.is_finite()) {
            return Err(SoftError::InvalidParameter {
                name: "size",
                rule: "positive and finite",
            });
        }
        let dx = self.size / (n - 1) as f64;
        let x: Vec<DVec3> = (0..n * n)
            .map(|k| DVec3::new((k % n) as f64 * dx, -((k / n) as f64) * dx, 0.0))
            .collect();
        let m = self.mass / (n * n) as f64;
        let mut sys = SoftSystem::new(x.clone(), vec![m; n * n])?;

        let mut edges = Vec::new();
        let mut tris = Vec::new();
        for r in 0..n {
            for c in 0..n {
                let i = self.index(r, c);
                if c + 1 < n {
                    edges.push((i, i + 1));
                }
                if r + 1 < n {
                    edges.push((i, i + n));
                }
                if r + 1 < n && c + 1 < n {
                    edges.push((i, i + n + 1));
                    edges.push((i + 1, i + n));
                    tris.push([i, i + n, i + 1]);
                    tris.push([i + 1, i + n, i + n + 1]);
                }
            }
        }
        let wrap =
            |set: &'static str| move |(index, error)| SoftError::Constraint { set, index, error };
        let springs = unique_edges(edges)
            .into_iter()
            .enumerate()
            .map(|(k, (a, b))| Distance::from_rest(a, b, &x).map_err(|e| (k, e)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(wrap("springs"))?;
        let areas = tris
            .into_iter()
            .enumerate()
            .map(|(k, t)| Area::from_rest(t, &x).map_err(|e| (k, e)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(wrap("areas"))?;
        sys.add_set(ConstraintSet::uniform("springs", springs, self.spring)?)?;
        if self.area.stiffness > 0.0 || self.area.damping > 0.0 {
            sys.add_set(ConstraintSet::uniform("areas", areas, self.area)?)?;
        }
        match self.pins {
            ClothPins::TopCorners => {
                sys.pin(0)?;
                sys.pin(n - 1)?;
            }
            ClothPins::TopEdge => {
                for c in 0..n {
                    sys.pin(c)?;
                }
            }
            ClothPins::None => {}
        }
        Ok(sys)
    }
}
