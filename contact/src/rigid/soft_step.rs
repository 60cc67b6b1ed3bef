//! The soft step (Catto, Solver2D 2024; Box2D v3 `solver.c`, `contact_solver.c`):
//! contact rows prepared once per step, then `substeps` rounds of
//!
//! ```text
//! integrate velocities (gravity) → warm start → solve with soft bias
//!   → integrate positions → relax (solve without bias)
//! ```
//!
//! and at the end restitution and the impulses stored for the next step's warm start.
//!
//! Each normal row is the lecture's compliant constraint (Otaduy 2010, "Restricciones",
//! soft constraints `[M Jᵀ; J −α/h²] [v'; λ] = [M v; −β C/h]`) solved one row at a time
//! with Gauss–Seidel: with the row's effective mass `m = (J M⁻¹ Jᵀ)⁻¹`, a spring of
//! angular frequency `ω = 2π·hertz` and damping ratio `ζ` at sub-step `h` give
//!
//! ```text
//! bias_rate     = ω / (2ζ + hω)
//! mass_scale    = hω(2ζ + hω) / (1 + hω(2ζ + hω))
//! impulse_scale = 1 / (1 + hω(2ζ + hω))
//! Δλ = −m · mass_scale · (J v + bias_rate · C) − impulse_scale · λ
//! ```
//!
//! (`C ≤ 0` the penetration, capped at `max_push_velocity`; a separated pair `C > 0`
//! gets the speculative target `C/h` and no softness). The separation `C` is updated
//! each sub-step from the bodies' displacements since the start of the step, with the
//! contact anchors fixed in the bodies (no new collision detection). The relax pass
//! solves the same rows rigidly with no bias, which removes the velocity the position
//! correction added (as split impulses do). Friction: two tangent rows per point,
//! `|λ_t| ≤ μ λ_n` (Coulomb's pyramid), solved after the normal row.
//!
//! Data layout (Box2D v3 style): points as flat arrays built once per step, ordered
//! bottom-up along −gravity; body velocities, displacements and inverse masses in dense
//! arrays indexed by solver slot, with a last, static slot (zero inverse mass) for the
//! ground. Every buffer lives in [`SoftState`] and is reused: a step allocates nothing
//! once the buffers have grown to the scene.

use alloc::vec::Vec;
use core::f64::consts::TAU;

use constraint_core::rigid::rotate_by;
use constraint_core::{DMat3, DQuat, DVec3, Pose};

use super::{path, ContactError, ContactSolver, ContactStats, ContactWorld};
use crate::geometry::BroadScratch;

/// Settings of [`ContactSolver::SoftStep`] (Box2D v3's world definition values by
/// default, except the contact stiffness; see [`SoftStepSettings::default`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoftStepSettings {
    /// Contact stiffness as a frequency (Hz) for two moving bodies; contacts with a
    /// static collider use twice this (Box2D's `staticSoftness`). It is capped at a
    /// quarter of the sub-step rate, as Box2D caps it.
    pub hertz: f64,
    /// Damping ratio `ζ ≥ 0` of the contact spring (10: heavily over-damped).
    pub damping_ratio: f64,
    /// Largest velocity (m/s) at which a penetration is pushed out.
    pub max_push_velocity: f64,
}

impl Default for SoftStepSettings {
    /// Box2D v3's defaults: `hertz` 30, `damping_ratio` 10, `max_push_velocity` 3 m/s.
    /// A soft contact is a spring of stiffness `m ω²` (`m` the row's effective mass):
    /// carrying the weight of `k` unit boxes it settles by about `k g/ω²` (0.28 mm per
    /// box at 30 Hz; half of it against the ground, which gets twice the frequency).
    /// Stiffer contacts need more sub-steps: one Gauss–Seidel pass per sub-step does not
    /// converge a stack's coupling at a quarter of the sub-step rate (a 3-box stack at
    /// 60 Hz with 4 sub-steps of 1/240 s keeps rocking at 0.1 m/s; at 30 Hz it rests).
    fn default() -> Self {
        Self {
            hertz: 30.0,
            damping_ratio: 10.0,
            max_push_velocity: 3.0,
        }
    }
}

/// Soft-constraint coefficients of one row (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Softness {
    /// `ω / (2ζ + hω)` (1/s): the velocity asked per metre of penetration.
    pub bias_rate: f64,
    /// `hω(2ζ + hω) / (1 + hω(2ζ + hω))`.
    pub mass_scale: f64,
    /// `1 / (1 + hω(2ζ + hω))`.
    pub impulse_scale: f64,
}

impl Softness {
    /// Coefficients of a spring of `hertz` and damping ratio `zeta` at time step `h`;
    /// rigid (`mass_scale` 1, `impulse_scale` 0, no bias) when `hertz` is 0.
    pub fn new(hertz: f64, zeta: f64, h: f64) -> Self {
        if hertz == 0.0 {
            return Self {
                bias_rate: 0.0,
                mass_scale: 1.0,
                impulse_scale: 0.0,
            };
        }
        let omega = TAU * hertz;
        let a1 = 2.0 * zeta + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Self {
            bias_rate: omega / a1,
            mass_scale: a2 * a3,
            impulse_scale: a3,
        }
    }
}

/// A previous step's impulses of one point, for warm starting: key, normal impulse
/// per sub-step, tangent impulse per sub-step as a world vector.
type Warm = ((usize, usize, u64), f64, DVec3);

/// Buffers of the soft step, kept by the world between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct SoftState {
    broad: BroadScratch,
    poses: Vec<Pose>,
    // Bodies, by solver slot (the last slot is the static ground).
    inv_mass: Vec<f64>,
    inv_inertia: Vec<DMat3>,
    v: Vec<DVec3>,
    w: Vec<DVec3>,
    dp: Vec<DVec3>,
    dq: Vec<DQuat>,
    /// `Δq` as a matrix (anchors rotate by it in every gap update).
    rot: Vec<DMat3>,
    // Points, in solve order (bottom-up).
    order: Vec<usize>,
    slots: Vec<[usize; 2]>,
    /// Normal then the two tangents.
    dir: Vec<[DVec3; 3]>,
    /// Anchors relative to the body centres at the start of the step.
    anchor: Vec<[DVec3; 2]>,
    /// Per direction `d`: `r_a × d`, `r_b × d`, `I_a⁻¹(r_a × d)`, `I_b⁻¹(r_b × d)`.
    ang: Vec<[[DVec3; 4]; 3]>,
    /// Effective masses `1/(J M⁻¹ Jᵀ)` of the three rows (0 for a row with none).
    mass: Vec<[f64; 3]>,
    /// Gap `nᵀ(p_b − p_a)` at the start of the step minus `nᵀ(r_b − r_a)`.
    base_gap: Vec<f64>,
    soft: Vec<Softness>,
    friction: Vec<f64>,
    restitution: Vec<f64>,
    /// Normal velocity before the step (restitution).
    approach: Vec<f64>,
    impulse: Vec<[f64; 3]>,
    max_normal: Vec<f64>,
    /// Impulses summed over the sub-steps (what [`ContactWorld::impulses`] reports).
    total: Vec<[f64; 3]>,
    warm: Vec<Warm>,
    warm_next: Vec<Warm>,
    /// The previous step's impulses of each contact (natural order; zero if new).
    found: Vec<(f64, DVec3)>,
    /// Sub-step of the impulses in `warm` (they scale with it).
    warm_h: f64,
}

impl ContactWorld {
    /// Rejects soft-step settings out of range (before any state changes).
    fn check_soft(&self, substeps: usize) -> Result<(), ContactError> {
        let s = &self.settings.soft_step;
        let bad = |name, rule| Err(ContactError::InvalidParameter { name, rule });
        if substeps == 0 {
            return bad("substeps", "must be at least 1");
        }
        if !(s.hertz > 0.0) || !s.hertz.is_finite() {
            return bad("soft_step.hertz", "must be positive and finite");
        }
        if !(s.damping_ratio >= 0.0) || !s.damping_ratio.is_finite() {
            return bad("soft_step.damping_ratio", "must be finite and non-negative");
        }
        if !(s.max_push_velocity >= 0.0) || !s.max_push_velocity.is_finite() {
            return bad(
                "soft_step.max_push_velocity",
                "must be finite and non-negative",
            );
        }
        Ok(())
    }

    /// One step of `h` by the soft step with `substeps` sub-steps.
    pub(super) fn soft_step(
        &mut self,
        h: f64,
        substeps: usize,
    ) -> Result<ContactStats, ContactError> {
        self.check_soft(substeps)?;
        let mut stats = ContactStats {
            solver: Some(ContactSolver::SoftStep { substeps }),
            iterations: substeps,
            ..ContactStats::default()
        };
        let mut st = core::mem::take(&mut self.soft);
        // Contacts at the start of the step.
        st.poses.clear();
        st.poses.extend(self.bodies.iter().map(|b| b.pose));
        let mut contacts = core::mem::take(&mut self.contacts);
        // Asleep bodies are left out of the pairs (the sleep module's hook).
        let broad = self.awake_contacts(&st.poses, &mut st.broad, &mut contacts);
        self.contacts = contacts;
        let broad = match broad {
            Ok(b) => b,
            Err(e) => {
                self.soft = st;
                return Err(e);
            }
        };
        stats.pair_tests = broad.tests;
        stats.contacts = self.contacts.len();
        stats.max_penetration = self.contacts.iter().map(|c| c.depth).fold(0.0, f64::max);
        let hs = h / substeps as f64;
        self.load_bodies(&mut st, h);
        self.prepare(&mut st, hs);
        self.path = path::STEPPED
            | if self.contacts.is_empty() {
                path::NO_ROWS
            } else {
                path::SOFT_STEP
            };
        let g = self.gravity;
        for _ in 0..substeps {
            integrate_velocities(&mut st, g, hs);
            warm_start(&mut st);
            solve(&mut st, hs, true, self.settings.soft_step.max_push_velocity);
            integrate_positions(&mut st, hs);
            solve(&mut st, hs, false, 0.0);
            for (t, z) in st.total.iter_mut().zip(&st.impulse) {
                t[0] += z[0];
                t[1] += z[1];
                t[2] += z[2];
            }
        }
        restitution(&mut st, self.settings.restitution_threshold);
        stats.residual = residual(&st, hs);
        self.store(&mut st, hs);
        self.soft = st;
        Ok(stats)
    }

    /// Body slots: inverse masses and world inverse inertias at the start of the step,
    /// velocities after the implicit gyroscopic update over `h`, zero displacements.
    fn load_bodies(&mut self, st: &mut SoftState, h: f64) {
        let n = self.bodies.len() + 1;
        st.inv_mass.clear();
        st.inv_inertia.clear();
        st.v.clear();
        st.w.clear();
        for (i, b) in self.bodies.iter_mut().enumerate() {
            // An asleep body (the sleep module's hook) takes a static slot: at rest, zero
            // inverse mass, not integrated (it is in no contact row either).
            if self.sleep.asleep.get(i).copied().unwrap_or(false) {
                st.inv_mass.push(0.0);
                st.inv_inertia.push(DMat3::ZERO);
                st.v.push(DVec3::ZERO);
                st.w.push(DVec3::ZERO);
                continue;
            }
            b.omega = b.gyroscopic_step(h);
            st.inv_mass.push(1.0 / b.mass());
            st.inv_inertia.push(b.world_inv_inertia());
            st.v.push(b.v);
            st.w.push(b.omega);
        }
        // The static slot.
        st.inv_mass.push(0.0);
        st.inv_inertia.push(DMat3::ZERO);
        st.v.push(DVec3::ZERO);
        st.w.push(DVec3::ZERO);
        st.dp.clear();
        st.dp.resize(n, DVec3::ZERO);
        st.dq.clear();
        st.dq.resize(n, DQuat::IDENTITY);
        st.rot.clear();
        st.rot.resize(n, DMat3::IDENTITY);
    }

    /// Builds the point arrays once per step (bottom-up order), warm-started by
    /// contact key from the previous step.
    fn prepare(&self, st: &mut SoftState, hs: f64) {
        let up = if self.gravity.length() > 0.0 {
            -self.gravity.normalize()
        } else {
            DVec3::Z
        };
        st.order.clear();
        st.order.extend(0..self.contacts.len());
        let contacts = &self.contacts;
        // Unique keys (index tie-break): deterministic without a stable sort's buffer.
        st.order.sort_unstable_by(|&p, &q| {
            contacts[p]
                .point
                .dot(up)
                .total_cmp(&contacts[q].point.dot(up))
                .then(p.cmp(&q))
        });
        let s = self.settings.soft_step;
        let hertz = s.hertz.min(0.25 / hs);
        let dynamic = Softness::new(hertz, s.damping_ratio, hs);
        let fixed = Softness::new(2.0 * hertz, s.damping_ratio, hs);
        let scale = if st.warm_h > 0.0 { hs / st.warm_h } else { 0.0 };
        let nb = self.bodies.len();
        // Warm start by key: the contacts come in pair order `(a, b)` and `warm` is
        // sorted by key, so one forward merge finds every previous point (the same
        // matches as a search per point, reading `warm` once, in order).
        st.found.clear();
        let mut cursor = 0;
        for c in contacts {
            let (a, b, id) = c.key();
            while cursor < st.warm.len() && (st.warm[cursor].0 .0, st.warm[cursor].0 .1) < (a, b) {
                cursor += 1;
            }
            let hit = st.warm[cursor..]
                .iter()
                .take_while(|e| e.0 .0 == a && e.0 .1 == b)
                .find(|e| e.0 .2 == id);
            st.found
                .push(hit.map_or((0.0, DVec3::ZERO), |&(_, zn, ft)| (zn, ft)));
        }
        macro_rules! clear {
            ($($f:ident),*) => { $(st.$f.clear();)* };
        }
        clear!(
            slots,
            dir,
            anchor,
            ang,
            mass,
            base_gap,
            soft,
            friction,
            restitution,
            approach,
            impulse,
            max_normal,
            total
        );
        for &k in &st.order {
            let c = &contacts[k];
            let (ca, cb) = (&self.colliders[c.a], &self.colliders[c.b]);
            let (a, b) = (ca.body.unwrap_or(nb), cb.body.unwrap_or(nb));
            let ra = ca
                .body
                .map_or(DVec3::ZERO, |i| c.point_on_a() - self.bodies[i].pose.x);
            let rb = cb
                .body
                .map_or(DVec3::ZERO, |i| c.point_on_b() - self.bodies[i].pose.x);
            let n = c.normal;
            let (t1, t2) = n.any_orthonormal_pair();
            let dirs = [n, t1, t2];
            let mut ang = [[DVec3::ZERO; 4]; 3];
            let mut mass = [0.0; 3];
            for (r, d) in dirs.iter().enumerate() {
                let (ua, ub) = (ra.cross(*d), rb.cross(*d));
                let (ia, ib) = (st.inv_inertia[a] * ua, st.inv_inertia[b] * ub);
                // k = J M⁻¹ Jᵀ = 1/m_a + 1/m_b + (r_a×d)ᵀI_a⁻¹(r_a×d) + (r_b×d)ᵀI_b⁻¹(r_b×d)
                let k = st.inv_mass[a] + st.inv_mass[b] + ua.dot(ia) + ub.dot(ib);
                mass[r] = if k > 0.0 { 1.0 / k } else { 0.0 };
                ang[r] = [ua, ub, ia, ib];
            }
            // Relative normal velocity before the step: n·(v_b + ω_b×r_b − v_a − ω_a×r_a).
            let vn = n.dot(st.v[b] - st.v[a]) + ang[0][1].dot(st.w[b]) - ang[0][0].dot(st.w[a]);
            let mut z = [0.0; 3];
            if self.settings.warm_start {
                let (zn, ft) = st.found[k];
                z = [zn * scale, ft.dot(t1) * scale, ft.dot(t2) * scale];
            }
            st.slots.push([a, b]);
            st.dir.push(dirs);
            st.anchor.push([ra, rb]);
            st.ang.push(ang);
            st.mass.push(mass);
            st.base_gap.push(-c.depth - n.dot(rb - ra));
            st.soft
                .push(if a == nb || b == nb { fixed } else { dynamic });
            st.friction.push(ca.friction.max(cb.friction));
            st.restitution.push(ca.restitution.max(cb.restitution));
            st.approach.push(vn);
            st.impulse.push(z);
            st.max_normal.push(0.0);

            st.total.push([0.0; 3]);
        }
    }

    /// Writes the bodies back (`x = x₀ + Δx`, `q = Δq q₀`) and keeps the impulses for
    /// the next step's warm start, sorted by contact key.
    fn store(&mut self, st: &mut SoftState, hs: f64) {
        for (i, b) in self.bodies.iter_mut().enumerate() {
            b.pose.x += st.dp[i];
            b.pose.q = (st.dq[i] * b.pose.q).normalize();
            b.v = st.v[i];
            b.omega = st.w[i];
        }
        st.warm_next.clear();
        self.impulses.clear();
        self.impulses.resize(3 * self.contacts.len(), 0.0);
        for (p, &k) in st.order.iter().enumerate() {
            let c = &self.contacts[k];
            let [zn, z1, z2] = st.impulse[p];
            let [_, t1, t2] = st.dir[p];
            st.warm_next.push((c.key(), zn, t1 * z1 + t2 * z2));
            self.impulses[3 * k..3 * k + 3].copy_from_slice(&st.total[p]);
        }
        // Keys are unique: the unstable sort is deterministic.
        st.warm_next.sort_unstable_by_key(|e| e.0);
        core::mem::swap(&mut st.warm, &mut st.warm_next);
        st.warm_h = hs;
    }
}

/// `v += g h` for every moving body (the static slot and asleep bodies, zero inverse
/// mass, stay at rest).
fn integrate_velocities(st: &mut SoftState, g: DVec3, hs: f64) {
    let n = st.v.len() - 1;
    for (v, &m) in st.v[..n].iter_mut().zip(&st.inv_mass) {
        if m > 0.0 {
            *v += g * hs;
        }
    }
}

/// `Δx += v h`, `Δq ← exp(ω h) Δq` (and its matrix) for every moving body (asleep
/// bodies, zero inverse mass, are skipped).
fn integrate_positions(st: &mut SoftState, hs: f64) {
    let n = st.v.len() - 1;
    for i in 0..n {
        if !(st.inv_mass[i] > 0.0) {
            continue; // asleep
        }
        st.dp[i] += st.v[i] * hs;
        st.dq[i] = rotate_by(st.dq[i], st.w[i] * hs);
        st.rot[i] = DMat3::from_quat(st.dq[i]);
    }
}

/// `v += M⁻¹ Jᵀ λ` of the three rows of point `p` with impulses `z`.
#[inline]
fn apply(st: &mut SoftState, p: usize, z: [f64; 3]) {
    let [a, b] = st.slots[p];
    let d = st.dir[p];
    let g = &st.ang[p];
    let lin = d[0] * z[0] + d[1] * z[1] + d[2] * z[2];
    st.v[a] -= lin * st.inv_mass[a];
    st.w[a] -= g[0][2] * z[0] + g[1][2] * z[1] + g[2][2] * z[2];
    st.v[b] += lin * st.inv_mass[b];
    st.w[b] += g[0][3] * z[0] + g[1][3] * z[1] + g[2][3] * z[2];
}

/// Applies the stored impulses of every point (warm start, each sub-step).
fn warm_start(st: &mut SoftState) {
    for p in 0..st.slots.len() {
        let z = st.impulse[p];
        apply(st, p, z);
    }
}

/// Rate `J v` of row `r` of point `p`.
#[inline]
fn rate(st: &SoftState, p: usize, r: usize) -> f64 {
    let [a, b] = st.slots[p];
    let d = st.dir[p][r];
    let g = &st.ang[p][r];
    d.dot(st.v[b] - st.v[a]) + g[1].dot(st.w[b]) - g[0].dot(st.w[a])
}

/// One Gauss–Seidel pass over the points: the normal row (soft with bias when
/// `use_bias`, rigid without), then the two friction rows bounded by `μ λ_n`. Each
/// point loads its two bodies' velocities once, updates them row by row, and stores
/// them back (Box2D v3's `b2SolveContact`).
fn solve(st: &mut SoftState, hs: f64, use_bias: bool, max_push: f64) {
    let inv_h = 1.0 / hs;
    for p in 0..st.slots.len() {
        let [a, b] = st.slots[p];
        let [ra, rb] = st.anchor[p];
        let d = st.dir[p];
        let g = st.ang[p];
        let m = st.mass[p];
        let (ma, mb) = (st.inv_mass[a], st.inv_mass[b]);
        let (mut va, mut wa, mut vb, mut wb) = (st.v[a], st.w[a], st.v[b], st.w[b]);
        // Current gap from the displacements since the start of the step (anchors fixed
        // in the bodies): C = C₀ + nᵀ(Δx_b + Δq_b r_b − Δx_a − Δq_a r_a).
        let gap =
            st.base_gap[p] + d[0].dot((st.dp[b] + st.rot[b] * rb) - (st.dp[a] + st.rot[a] * ra));
        let (bias, mass_scale, impulse_scale) = if gap > 0.0 {
            // Speculative: approach at most to the surface within the sub-step.
            (gap * inv_h, 1.0, 0.0)
        } else if use_bias {
            let s = st.soft[p];
            (
                (s.bias_rate * gap).max(-max_push),
                s.mass_scale,
                s.impulse_scale,
            )
        } else {
            (0.0, 1.0, 0.0)
        };
        let mut z = st.impulse[p];
        // Δλ = −m · mass_scale · (J v + bias) − impulse_scale · λ, then λ ≥ 0.
        let vn = d[0].dot(vb - va) + g[0][1].dot(wb) - g[0][0].dot(wa);
        let new = (z[0] - m[0] * mass_scale * (vn + bias) - impulse_scale * z[0]).max(0.0);
        let dz = new - z[0];
        z[0] = new;
        st.max_normal[p] = st.max_normal[p].max(new);
        va -= d[0] * (ma * dz);
        wa -= g[0][2] * dz;
        vb += d[0] * (mb * dz);
        wb += g[0][3] * dz;
        // Coulomb: |λ_t| ≤ μ λ_n per tangent row (pyramid). `min`/`max`, not `clamp`:
        // NaN bounds must not panic (the step's divergence check rejects the state).
        let bound = st.friction[p] * z[0];
        for r in 1..3 {
            let vt = d[r].dot(vb - va) + g[r][1].dot(wb) - g[r][0].dot(wa);
            let new = (z[r] - m[r] * vt).min(bound).max(-bound);
            let dz = new - z[r];
            z[r] = new;
            va -= d[r] * (ma * dz);
            wa -= g[r][2] * dz;
            vb += d[r] * (mb * dz);
            wb += g[r][3] * dz;
        }
        st.impulse[p] = z;
        // The static slot's inverse mass and inertia are zero: it stays at rest.
        st.v[a] = va;
        st.w[a] = wa;
        st.v[b] = vb;
        st.w[b] = wb;
    }
}

/// Restitution (after the sub-steps, Box2D's `b2ApplyRestitution`): a point that
/// approached faster than `threshold` and carried load gets `J v ≥ −e v_approach`.
fn restitution(st: &mut SoftState, threshold: f64) {
    for p in 0..st.slots.len() {
        let e = st.restitution[p];
        if e == 0.0 || st.approach[p] > -threshold || st.max_normal[p] == 0.0 {
            continue;
        }
        let vn = rate(st, p, 0);
        let z = st.impulse[p][0];
        let new = (z - st.mass[p][0] * (vn + e * st.approach[p])).max(0.0);
        st.impulse[p][0] = new;
        st.total[p][0] += new - z;
        apply(st, p, [new - z, 0.0, 0.0]);
    }
}

/// Natural-map residual of the last sub-step's unbiased problem (the relax pass) at
/// the final velocities and impulses: normal `w = J v + max(C/h, 0)` with `λ ≥ 0`,
/// tangents `w = J v` with `|λ_t| ≤ μ λ_n`, scaled by `max(1, |w|∞)`.
fn residual(st: &SoftState, hs: f64) -> f64 {
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 1.0;
    for p in 0..st.slots.len() {
        let [a, b] = st.slots[p];
        let [ra, rb] = st.anchor[p];
        let n = st.dir[p][0];
        let gap = st.base_gap[p] + n.dot((st.dp[b] + st.rot[b] * rb) - (st.dp[a] + st.rot[a] * ra));
        let z = st.impulse[p];
        let bound = st.friction[p] * z[0];
        for r in 0..3 {
            if !(st.mass[p][r] > 0.0) {
                continue;
            }
            let w = rate(st, p, r) + if r == 0 { (gap / hs).max(0.0) } else { 0.0 };
            let (lo, hi) = if r == 0 {
                (0.0, f64::INFINITY)
            } else {
                (-bound, bound)
            };
            scale = scale.max(w.abs());
            worst = worst.max((z[r] - (z[r] - w).min(hi).max(lo)).abs());
        }
    }
    worst / scale
}
