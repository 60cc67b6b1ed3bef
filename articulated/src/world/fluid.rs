//! Fluid drag on the bodies: MuJoCo's inertia-box model (its documentation, "Fluid
//! forces", inertia model), used when `option density` or `viscosity` is positive.
//!
//! Each body is its equivalent inertia box: with mass `m` and principal moments
//! `I_x, I_y, I_z`, the half-sizes are `r_x = √(3/(2m) (I_y + I_z − I_x))` (and
//! cyclically). With `v`, `ω` the velocity of the centre of mass (minus the wind) and
//! the angular velocity in the principal frame, the fluid's force and torque are
//!
//! ```text
//! f_i = −2 ρ r_j r_k |v_i| v_i − 6 β π r_eq v_i
//! g_i = −½ ρ r_i (r_j⁴ + r_k⁴) |ω_i| ω_i − 8 β π r_eq³ ω_i,    r_eq = (r_x + r_y + r_z)/3
//! ```
//!
//! (quadratic drag at high Reynolds number plus Stokes viscous resistance), applied
//! explicitly at the centre of mass, as MuJoCo's Euler and RK4 integrators apply them.

use constraint_core::body::symmetric_eigen;
use constraint_core::{DMat3, DVec3};

use super::*;

/// `x⁴` (no `powi` without `std`).
fn p4(x: f64) -> f64 {
    let x2 = x * x;
    x2 * x2
}

/// One body's inertia box in the fluid: its principal frame and the velocity-free
/// factors of the drag formulas (module documentation), computed once per body and
/// fluid. Each is the leading factor of its product as the formula is evaluated left
/// to right (`(−2 ρ r_j r_k) |v_i| v_i`), so the wrench has the bits of evaluating the
/// whole formula at every call.
#[derive(Clone, Copy, Debug)]
pub(super) struct FluidBox {
    /// Body frame → principal axes.
    axes: DMat3,
    /// `−2 ρ r_j r_k` per principal axis `i`.
    quad_force: [f64; 3],
    /// `6 β π r_eq`.
    lin_force: f64,
    /// `−½ ρ r_i (r_j⁴ + r_k⁴)` per principal axis `i`.
    quad_torque: [f64; 3],
    /// `8 β π r_eq³`.
    lin_torque: f64,
    /// The bits of the body's orientation `q` that `frame` is of (`None`: not yet).
    frame_key: Option<[u64; 4]>,
    /// The principal axes in the world, `R(q) · axes`: kept while the body's
    /// orientation keeps its bits (RATTLE's damping flows evaluate the drag four times
    /// per configuration, `rattle.rs`), the same bits as computing them again.
    frame: DMat3,
}

/// The medium of [`World::fluid`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fluid {
    /// Density `ρ ≥ 0` (kg/m³).
    pub density: f64,
    /// Viscosity `β ≥ 0` (Pa·s).
    pub viscosity: f64,
    /// Wind velocity (m/s, world), subtracted from the bodies' velocities.
    pub wind: DVec3,
}

impl World {
    /// Sets the fluid the bodies move through (`None`: vacuum). Errors: negative or
    /// non-finite density or viscosity, non-finite wind.
    pub fn set_fluid(&mut self, fluid: Option<Fluid>) -> Result<(), ArticulatedError> {
        if let Some(f) = fluid {
            if !(f.density >= 0.0)
                || !(f.viscosity >= 0.0)
                || !f.density.is_finite()
                || !f.viscosity.is_finite()
                || !f.wind.is_finite()
            {
                return Err(ArticulatedError::InvalidParameter {
                    name: "fluid",
                    rule: "density and viscosity finite and >= 0, wind finite",
                });
            }
        }
        self.fluid = fluid;
        self.fluid_boxes.clear();
        Ok(())
    }

    /// The fluid, if any.
    pub fn fluid(&self) -> Option<Fluid> {
        self.fluid
    }

    /// Each body's principal frame (body frame → principal axes) and drag factors, from
    /// its box half-sizes and the fluid `f` (kept until the fluid is set again).
    fn ensure_fluid_boxes(&mut self, f: &Fluid) {
        if self.fluid_boxes.len() == self.bodies.len() {
            return;
        }
        self.fluid_boxes.clear();
        let (rho, beta) = (f.density, f.viscosity);
        let pi = core::f64::consts::PI;
        for b in &self.bodies {
            let (lam, v) = symmetric_eigen(&b.inertia());
            let m = b.mass();
            let half = |i: usize, j: usize, k: usize| {
                libm::sqrt((1.5 / m * (lam[j] + lam[k] - lam[i])).max(0.0))
            };
            let rr = [half(0, 1, 2), half(1, 2, 0), half(2, 0, 1)];
            let req = (rr[0] + rr[1] + rr[2]) / 3.0;
            let mut quad_force = [0.0; 3];
            let mut quad_torque = [0.0; 3];
            for i in 0..3 {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                quad_force[i] = -2.0 * rho * rr[j] * rr[k];
                quad_torque[i] = -0.5 * rho * rr[i] * (p4(rr[j]) + p4(rr[k]));
            }
            self.fluid_boxes.push(FluidBox {
                axes: v,
                quad_force,
                lin_force: 6.0 * beta * pi * req,
                quad_torque,
                lin_torque: 8.0 * beta * pi * req * req * req,
                frame_key: None,
                frame: DMat3::IDENTITY,
            });
        }
    }

    /// Adds `scale ×` the fluid force and torque on every body to the right-hand side
    /// (the wrenches kept for [`Self::reapply_fluid_rhs`]). Tried: each body's wrench
    /// added to the right-hand side in the pass that evaluates it (issue 13, swimmer6
    /// passive 2 s `World::step` 81.88M → 82.18M instructions, against 81.09M with
    /// this evaluation pass and [`Self::reapply_fluid_rhs`]; left out).
    pub(super) fn add_fluid_rhs(&mut self, scale: f64) {
        let mut w = core::mem::take(&mut self.fluid_last);
        w.clear();
        if let Some(f) = self
            .fluid
            .filter(|f| f.density != 0.0 || f.viscosity != 0.0)
        {
            self.ensure_fluid_boxes(&f);
            for (fb, b) in self.fluid_boxes.iter_mut().zip(&self.bodies) {
                let key = b.pose.q.to_array().map(f64::to_bits);
                if fb.frame_key != Some(key) {
                    fb.frame = b.rotation() * fb.axes; // principal axes in the world
                    fb.frame_key = Some(key);
                }
            }
            let boxes = &self.fluid_boxes;
            w.extend(
                self.bodies
                    .iter()
                    .zip(boxes)
                    .map(|(b, fb)| fb.wrench(b, &f)),
            );
        }
        self.fluid_last = w;
        self.reapply_fluid_rhs(scale);
    }

    /// Adds the wrenches of the last [`Self::add_fluid_rhs`] again, over `scale` (a
    /// second right-hand side at the same state: the damping flow's second stage at
    /// `v`, `rattle.rs`), bit for bit what evaluating them again would add.
    pub(super) fn reapply_fluid_rhs(&mut self, scale: f64) {
        for (i, (force, torque)) in self.fluid_last.iter().enumerate() {
            add_scaled(
                &mut self.rhs,
                self.solver.body_offset(i),
                *force,
                *torque,
                scale,
            );
        }
    }
}

/// `r += (force, torque) · scale` on the six entries at `o` (one bounds check; nothing
/// past the end of `rhs`).
#[inline(always)]
fn add_scaled(rhs: &mut [f64], o: usize, force: DVec3, torque: DVec3, scale: f64) {
    let Some(r) = rhs.get_mut(o..o + 6) else {
        return;
    };
    for c in 0..3 {
        r[c] += force[c] * scale;
        r[3 + c] += torque[c] * scale;
    }
}

impl FluidBox {
    /// The fluid's force and torque on body `b` (the formulas of the module
    /// documentation, with this box's factors; its frame is at the body's orientation).
    #[inline]
    fn wrench(&self, b: &RigidBody, f: &Fluid) -> (DVec3, DVec3) {
        // `Fᵀ x` as the three dot products `F_i · x` (glam's `transpose_mul_vec3`: the
        // same products and sums as `F.transpose() * x`, without the copy).
        let frame = self.frame;
        let v = frame.transpose_mul_vec3(b.v - f.wind);
        let w = frame.transpose_mul_vec3(b.omega);
        let mut fl = [0.0; 3];
        let mut tl = [0.0; 3];
        for i in 0..3 {
            let (vi, wi) = (v[i], w[i]);
            fl[i] = self.quad_force[i] * vi.abs() * vi - self.lin_force * vi;
            tl[i] = self.quad_torque[i] * wi.abs() * wi - self.lin_torque * wi;
        }
        (frame * DVec3::from_array(fl), frame * DVec3::from_array(tl))
    }
}
