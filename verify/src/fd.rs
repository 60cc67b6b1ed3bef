//! Finite-difference checking of constraint derivatives.
//!
//! Three groups of tools live here:
//!
//! * **The checker.** [`check_derivatives`] compares, at one configuration, the analytic
//!   Jacobian of any [`PointConstraint`] against central differences of
//!   [`PointConstraint::value`], and the analytic curvature `Σ_r w_r ∂²C_r/∂x²` against
//!   central differences of the analytic weighted gradient `Σ_r w_r ∇C_r`. It also
//!   compares forward against central differences (they differ by `O(h)`, so that
//!   check needs a looser gate) and reports the worst errors in an [`FdReport`] rather
//!   than a verdict: the caller owns the gates.
//! * **Tolerance handling.** Every gate in the tests is multiplied by the environment
//!   variable [`TOL_SCALE_VAR`] (`VERIFY_TOL_SCALE`, default `1`); see [`tol_scale`],
//!   [`exceeds`] and [`Worst`].
//! * **Seeded configurations.** A small self-contained generator, [`Rng`]
//!   (xoshiro256\*\* seeded through splitmix64, so results are identical on every
//!   platform and need no dependency), random points in a box ([`random_points`],
//!   [`random_config`]) and near-degenerate families ([`near_coincident_pair`],
//!   [`sliver_triangle`], [`flat_tet`], [`flat_hinge`], [`thin_wing_hinge`]) that come
//!   close to, but never reach, the singular shapes of the stock constraints.
//!
//! ## Error measure
//!
//! Errors are MuJoCo's *corrected relative error* ([`corrected_rel_error`]),
//! `max(0, |a − b| − atol) / (|a| + |b| + atol)`, taken entry by entry and maximised.
//! `atol` is the checker's estimate of the round-off in the finite difference itself
//! (see [`FdOptions::noise_factor`]), so the measure is blind to differences the
//! difference quotient cannot resolve and is a plain relative error for entries well
//! above that floor. Any error that is not round-off or truncation — a wrong sign, a
//! missing term — shows up as an `O(1)` value.
//!
//! ## Step size
//!
//! The step is `h = rel_step · ℓ` ([`FdOptions::rel_step`], default `1e-6`), where `ℓ`
//! is a length: [`FdOptions::length`] when given, otherwise the
//! [`characteristic_length`] of the configuration (its largest pairwise distance). For
//! near-degenerate shapes the derivatives vary on the small *feature* length (the
//! height of a sliver, the gap between two nearly coincident points), and the step
//! must be taken relative to it; the near-degenerate generators return that length in
//! [`NearDegenerate::feature`], and [`FdOptions::for_feature`] picks a step that
//! balances truncation on the feature length against the round-off of the cancelling
//! value. [`FdReport::resolution`] tells whether a step left the check any power.

use constraint_core::{DMat3, DVec3, PointConstraint};

/// MuJoCo's corrected relative error between `a` and `b`:
/// `max(0, |a − b| − atol) / (|a| + |b| + atol)`.
///
/// `atol ≥ 0` is an absolute tolerance (the expected noise in `a` and `b`); the result
/// is `0` when the two agree to within it, about half the relative error
/// `|a − b| / |a|` when both are far above it, and never more than `1` (reached for
/// opposite signs, or one value zero and `atol = 0`). Returns `0` when both are zero,
/// and NaN if either input is NaN.
#[inline]
pub fn corrected_rel_error(a: f64, b: f64, atol: f64) -> f64 {
    let num = ((a - b).abs() - atol).max(0.0);
    if num == 0.0 && !(a.is_nan() || b.is_nan()) {
        return 0.0;
    }
    num / (a.abs() + b.abs() + atol)
}

/// Settings of [`check_derivatives`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FdOptions {
    /// The step relative to the length scale: `h = rel_step · ℓ`. Default `1e-6`, near
    /// the optimum `ε^{1/3} ≈ 6e-6` for central differences of smooth functions.
    pub rel_step: f64,
    /// The length scale `ℓ` of the step; `None` (the default) takes the
    /// [`characteristic_length`] of the configuration. Pass the small feature length of
    /// a near-degenerate shape here.
    pub length: Option<f64>,
    /// Multiplier of the round-off estimate used as `atol` in
    /// [`corrected_rel_error`]. The estimate for a difference quotient of `f` with step
    /// `h` is `ε (|f| + L |∂f|) / h`, with `L` the characteristic length and `|∂f|` the
    /// largest entry of the analytic derivative (a proxy for the size of the terms that
    /// cancel inside `f`). Default `1`.
    pub noise_factor: f64,
}

impl Default for FdOptions {
    fn default() -> Self {
        Self {
            rel_step: 1e-6,
            length: None,
            noise_factor: 1.0,
        }
    }
}

impl FdOptions {
    /// Default options with the step taken relative to `length`.
    pub fn with_length(length: f64) -> Self {
        Self {
            length: Some(length),
            ..Self::default()
        }
    }

    /// Options for a near-degenerate shape of overall size `size` whose derivatives
    /// vary on the small length `feature ≤ size`.
    ///
    /// The step balances truncation against round-off. The truncation error of a
    /// central difference relative to the derivative is about `(h/ℓ)²` with
    /// `ℓ = feature`; the round-off is about `ε · size / h`, because the value is computed
    /// from terms of the overall size that cancel (a sliver's cross product, a
    /// squeezed spring's `|d| − L₀`). Equating them gives
    /// `h = ℓ · (ε · size/ℓ)^{1/3}`, i.e. `rel_step = (ε · size/ℓ)^{1/3}` relative to
    /// `ℓ`, clamped to `[1e-6, 1e-2]`; for a well-shaped configuration
    /// (`feature = size`) it is the default `≈ 1e-6` up to the clamp.
    pub fn for_feature(feature: f64, size: f64) -> Self {
        let rel = (f64::EPSILON * size / feature).cbrt().clamp(1e-6, 1e-2);
        Self {
            rel_step: rel,
            length: Some(feature),
            ..Self::default()
        }
    }
}

/// What [`check_derivatives`] measured at one configuration. All errors are worst-case
/// [`corrected_rel_error`]s over the entries compared.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FdReport {
    /// The step `h` used (before rounding to the representable perturbation).
    pub step: f64,
    /// The length scale `ℓ` the step was taken relative to.
    pub length: f64,
    /// Analytic Jacobian against central differences of the value.
    pub grad: f64,
    /// Analytic weighted curvature against central differences of the analytic
    /// weighted gradient.
    pub curv: f64,
    /// Normwise relative error of the Jacobian against central differences,
    /// `max |a − b| / max(|a|, |b|)` over all entries, without any `atol`
    /// (informative: round-off shows up here rather than being absorbed).
    pub grad_norm: f64,
    /// Normwise relative error of the curvature against central differences (as
    /// [`FdReport::grad_norm`]); `0` when both are exactly zero.
    pub curv_norm: f64,
    /// Forward against central differences of the value, normwise: the largest
    /// difference less `2·atol`, over the largest central difference plus `2·atol`.
    /// It is `O(h/ℓ)` by construction, so gate it loosely; a large value means the
    /// step is not in the asymptotic range.
    pub grad_fwd_central: f64,
    /// Forward against central differences of the weighted gradient, normwise (as
    /// [`FdReport::grad_fwd_central`]).
    pub curv_fwd_central: f64,
    /// Asymmetry of the analytic curvature: entry `(a, b)` against `(b, a)`.
    pub curv_asymmetry: f64,
    /// The value returned by `jacobian` against the one returned by `value`.
    pub value_mismatch: f64,
    /// The largest `atol` used for the gradient comparison.
    pub grad_atol: f64,
    /// The largest `atol` used for the curvature comparison.
    pub curv_atol: f64,
    /// `grad_atol` relative to the largest gradient entry: the smallest relative
    /// difference the gradient check can see. Near `1` the check is vacuous (the step
    /// is too small for the round-off); keep it small.
    pub grad_resolution: f64,
    /// `curv_atol` relative to the largest curvature entry (analytic or finite
    /// difference; `0` when both are exactly zero), as [`FdReport::grad_resolution`].
    pub curv_resolution: f64,
}

impl FdReport {
    /// The larger of the two forward-against-central disagreements.
    pub fn fwd_central(&self) -> f64 {
        self.grad_fwd_central.max(self.curv_fwd_central)
    }

    /// The larger of the two resolutions ([`FdReport::grad_resolution`],
    /// [`FdReport::curv_resolution`]).
    pub fn resolution(&self) -> f64 {
        self.grad_resolution.max(self.curv_resolution)
    }

    /// `true` when every measured quantity is finite (a NaN anywhere means a
    /// constraint returned NaN).
    pub fn is_finite(&self) -> bool {
        [
            self.grad,
            self.curv,
            self.grad_fwd_central,
            self.curv_fwd_central,
            self.curv_asymmetry,
            self.value_mismatch,
        ]
        .iter()
        .all(|v| v.is_finite())
    }
}

/// The largest pairwise distance of the points, or `max(1, max |x_i|)` for a single
/// point (or when all points coincide).
pub fn characteristic_length<const N: usize>(x: &[DVec3; N]) -> f64 {
    let mut l: f64 = 0.0;
    for i in 0..N {
        for j in 0..i {
            l = l.max((x[i] - x[j]).length());
        }
    }
    if l > 0.0 {
        l
    } else {
        x.iter().fold(1.0_f64, |m, p| m.max(p.abs().max_element()))
    }
}

/// Weighted gradient `Σ_r w_r ∇C_r` as one vector per point.
fn weighted_gradient<C, const N: usize, const R: usize>(
    c: &C,
    x: &[DVec3; N],
    w: &[f64; R],
) -> [DVec3; N]
where
    C: PointConstraint<N, R>,
{
    let j = c.jacobian(x);
    let mut g = [DVec3::ZERO; N];
    for (row, &wr) in j.grad.iter().zip(w.iter()) {
        for (gi, ri) in g.iter_mut().zip(row.iter()) {
            *gi += wr * *ri;
        }
    }
    g
}

/// A configuration with coordinate `a = 3·point + axis` set to `v`.
#[inline]
fn with_coord<const N: usize>(x: &[DVec3; N], a: usize, v: f64) -> [DVec3; N] {
    let mut y = *x;
    y[a / 3][a % 3] = v;
    y
}

/// The largest absolute entry of a slice of vectors.
fn max_abs(v: &[DVec3]) -> f64 {
    v.iter().fold(0.0, |m, p| m.max(p.abs().max_element()))
}

/// Checks the analytic derivatives of `c` at `x` by finite differences.
///
/// * Jacobian: for every row `r` and coordinate `a`, `∂C_r/∂x_a` against
///   `(C_r(x + h e_a) − C_r(x − h e_a)) / 2h` and against the forward quotient.
/// * Curvature: `Σ_r w_r ∂²C_r/∂x_b∂x_a` against central (and forward) differences of
///   the analytic weighted gradient `Σ_r w_r ∂C_r/∂x_b` along `x_a`. Pick `w` at random
///   (e.g. [`Rng::weights`]) so that no row can hide behind a zero weight.
/// * Consistency: symmetry of the analytic curvature, and the value returned by
///   `jacobian` against `value`.
///
/// The perturbation actually applied is the representable one, `(x + h) − x`, so large
/// coordinates do not bias the quotient. See the module docs for the error measure and
/// the step.
pub fn check_derivatives<C, const N: usize, const R: usize>(
    c: &C,
    x: &[DVec3; N],
    w: &[f64; R],
    opts: &FdOptions,
) -> FdReport
where
    C: PointConstraint<N, R>,
{
    let eps = f64::EPSILON;
    let big_l = characteristic_length(x);
    let length = opts.length.unwrap_or(big_l);
    let step = opts.rel_step * length;
    let mut rep = FdReport {
        step,
        length,
        ..FdReport::default()
    };

    let jac = c.jacobian(x);
    let val = c.value(x);
    for (&a, &b) in jac.value.iter().zip(val.iter()) {
        rep.value_mismatch = rep
            .value_mismatch
            .max(corrected_rel_error(a, b, eps * b.abs()));
    }
    let gw = weighted_gradient(c, x, w);
    let curv = c.curvature(x, w);
    let gmax: [f64; R] = core::array::from_fn(|r| max_abs(&jac.grad[r]));
    let gw_max = max_abs(&gw);
    let mut hmax: f64 = 0.0;
    for a in 0..3 * N {
        for b in 0..3 * N {
            hmax = hmax.max(curv.entry(a, b).abs());
        }
    }
    for a in 0..3 * N {
        for b in 0..a {
            let (p, q) = (curv.entry(a, b), curv.entry(b, a));
            let atol = 4.0 * eps * hmax;
            rep.curv_asymmetry = rep.curv_asymmetry.max(corrected_rel_error(p, q, atol));
        }
    }

    // Normwise accumulators: (largest |a − b|, largest |a|, largest |b|).
    let mut g_norm = [0.0_f64; 3];
    let mut h_norm = [0.0_f64; 3];
    // Forward against central: (largest |f − c|, largest |c|), and the atol used.
    let mut g_fc = [0.0_f64; 2];
    let mut h_fc = [0.0_f64; 2];
    let acc = |m: &mut [f64; 3], a: f64, b: f64| {
        m[0] = m[0].max((a - b).abs());
        m[1] = m[1].max(a.abs());
        m[2] = m[2].max(b.abs());
    };
    let acc_fc = |m: &mut [f64; 2], f: f64, c: f64| {
        m[0] = m[0].max((f - c).abs());
        m[1] = m[1].max(c.abs());
    };

    for a in 0..3 * N {
        let x0 = x[a / 3][a % 3];
        let xp_coord = x0 + step;
        let xm_coord = x0 - step;
        let hp = xp_coord - x0;
        let hm = x0 - xm_coord;
        let xp = with_coord(x, a, xp_coord);
        let xm = with_coord(x, a, xm_coord);

        // Gradient.
        let vp = c.value(&xp);
        let vm = c.value(&xm);
        for r in 0..R {
            let central = (vp[r] - vm[r]) / (hp + hm);
            let forward = (vp[r] - val[r]) / hp;
            let analytic = jac.grad[r][a / 3][a % 3];
            let noise = eps * (val[r].abs() + big_l * gmax[r]) / step;
            let atol = opts.noise_factor * noise;
            rep.grad_atol = rep.grad_atol.max(atol);
            rep.grad = rep.grad.max(corrected_rel_error(analytic, central, atol));
            acc(&mut g_norm, analytic, central);
            acc_fc(&mut g_fc, forward, central);
        }

        // Curvature: column a.
        let gp = weighted_gradient(c, &xp, w);
        let gm = weighted_gradient(c, &xm, w);
        let noise = eps * (gw_max + big_l * hmax) / step;
        let atol = opts.noise_factor * noise;
        rep.curv_atol = rep.curv_atol.max(atol);
        for b in 0..3 * N {
            let (i, k) = (b / 3, b % 3);
            let central = (gp[i][k] - gm[i][k]) / (hp + hm);
            let forward = (gp[i][k] - gw[i][k]) / hp;
            let analytic = curv.entry(b, a);
            rep.curv = rep.curv.max(corrected_rel_error(analytic, central, atol));
            acc(&mut h_norm, analytic, central);
            acc_fc(&mut h_fc, forward, central);
        }
    }
    let normwise = |m: [f64; 3]| {
        let scale = m[1].max(m[2]);
        if m[0] == 0.0 && scale == 0.0 {
            0.0
        } else {
            m[0] / scale
        }
    };
    let resolution = |atol: f64, m: [f64; 3]| {
        let scale = m[1].max(m[2]);
        if scale == 0.0 {
            0.0
        } else {
            atol / scale
        }
    };
    rep.grad_resolution = resolution(rep.grad_atol, g_norm);
    rep.curv_resolution = resolution(rep.curv_atol, h_norm);
    rep.grad_norm = normwise(g_norm);
    rep.curv_norm = normwise(h_norm);
    let fc = |m: [f64; 2], atol: f64| {
        let num = (m[0] - 2.0 * atol).max(0.0);
        if num == 0.0 {
            0.0
        } else {
            num / (m[1] + 2.0 * atol)
        }
    };
    rep.grad_fwd_central = fc(g_fc, rep.grad_atol);
    rep.curv_fwd_central = fc(h_fc, rep.curv_atol);
    rep
}

// ---------------------------------------------------------------------------------------
// Tolerances
// ---------------------------------------------------------------------------------------

/// Name of the environment variable that scales every gate: `VERIFY_TOL_SCALE`.
///
/// * unset or empty: `1`, the gates as written;
/// * a positive number `s`: every gate is multiplied by `s` (e.g. `10` on an unusual
///   platform, `0.1` to see how much head-room is left);
/// * `0`: **measure mode** — tests print the measured residuals (run with
///   `cargo test -p constraint-verify -- --nocapture` to see them) and never fail on a
///   gate. Non-finite results (NaN) still fail.
pub const TOL_SCALE_VAR: &str = "VERIFY_TOL_SCALE";

/// The gate multiplier read from [`TOL_SCALE_VAR`] (default `1`).
///
/// # Panics
/// When the variable is set to something that is not a finite number `≥ 0`.
pub fn tol_scale() -> f64 {
    match std::env::var(TOL_SCALE_VAR) {
        Ok(s) if !s.trim().is_empty() => match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => v,
            _ => panic!("{TOL_SCALE_VAR}={s:?}: expected a finite number >= 0"),
        },
        _ => 1.0,
    }
}

/// `true` in measure mode (`VERIFY_TOL_SCALE=0`): report, do not fail.
pub fn measure_only() -> bool {
    tol_scale() == 0.0
}

/// `true` when `measured` is over `gate · tol_scale()` and gates are enforced, or when
/// `measured` is NaN (in any mode). Always `false` otherwise in measure mode.
pub fn exceeds(measured: f64, gate: f64) -> bool {
    if measured.is_nan() {
        return true;
    }
    let s = tol_scale();
    s > 0.0 && measured > gate * s
}

/// Running maximum of a measured error together with the case that produced it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Worst {
    /// The largest value recorded so far (`0` initially).
    pub value: f64,
    /// The case index (or seed) of that value; `None` before the first positive value.
    pub case: Option<u64>,
}

impl Worst {
    /// Records `value` for `case`; returns `true` when it is a new maximum.
    pub fn record(&mut self, value: f64, case: u64) -> bool {
        if value > self.value || (value.is_nan() && !self.value.is_nan()) {
            self.value = value;
            self.case = Some(case);
            true
        } else {
            false
        }
    }

    /// One line for test output: `label: worst 1.2e-9 (case 17); gate 1e-8`.
    pub fn summary(&self, label: &str, gate: f64) -> String {
        match self.case {
            Some(c) => format!(
                "{label}: worst {:.3e} (case {c}); gate {gate:.1e}",
                self.value
            ),
            None => format!("{label}: worst 0; gate {gate:.1e}"),
        }
    }
}

// ---------------------------------------------------------------------------------------
// Random numbers
// ---------------------------------------------------------------------------------------

pub use constraint_scene::rng::Rng;

// ---------------------------------------------------------------------------------------
// Configurations
// ---------------------------------------------------------------------------------------

/// `N` points uniform in the box `center ± half_extent`.
pub fn random_points<const N: usize>(rng: &mut Rng, center: DVec3, half_extent: f64) -> [DVec3; N] {
    core::array::from_fn(|_| rng.in_box(center, half_extent))
}

/// A generic ("regular") configuration: a scale `s` log-uniform in `[1e-2, 1e2)`, a
/// box centre uniform in `±10 s`, and `N` points uniform in the box `centre ± s`.
///
/// Uniform points are usually well shaped but occasionally thin; the near-degenerate
/// families below cover thin shapes on purpose.
pub fn random_config<const N: usize>(rng: &mut Rng) -> [DVec3; N] {
    let s = rng.log_uniform(1e-2, 1e2);
    let center = rng.in_box(DVec3::ZERO, 10.0 * s);
    random_points(rng, center, s)
}

/// A near-degenerate configuration: the points, the overall size and the small
/// feature length on which the derivatives vary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearDegenerate<const N: usize> {
    /// The points.
    pub x: [DVec3; N],
    /// The overall size (the `length` the generator was asked for).
    pub length: f64,
    /// The small length scale of the degeneracy (gap, height, …): take the finite
    /// difference step relative to it ([`FdOptions::with_length`]).
    pub feature: f64,
}

/// A random placement: centre within `±10·length` and a random orientation.
fn placement(rng: &mut Rng, length: f64) -> (DVec3, DMat3) {
    (rng.in_box(DVec3::ZERO, 10.0 * length), rng.rotation())
}

/// Two points at distance `ratio · length` (`ratio > 0`), e.g. a spring of rest
/// length `length` squeezed to `1e-4` of it. Random position and direction.
pub fn near_coincident_pair(rng: &mut Rng, length: f64, ratio: f64) -> NearDegenerate<2> {
    let c = rng.in_box(DVec3::ZERO, 10.0 * length);
    let d = ratio * length * rng.unit_vector();
    NearDegenerate {
        x: [c + 0.5 * d, c - 0.5 * d],
        length,
        feature: ratio * length,
    }
}

/// A thin triangle: base edge `x₀x₁` of length `length`, apex `x₂` at height
/// `ratio · length` above the base line (`ratio > 0`), its foot at parameter
/// `t ∈ [−0.5, 1.5)` along the base. With `t ∈ (0, 1)` this is a cap (one angle near
/// π), near `0` or `1` a needle (two corners nearly coincident), outside an obtuse
/// sliver. Random placement; `feature` is the height.
pub fn sliver_triangle(rng: &mut Rng, length: f64, ratio: f64) -> NearDegenerate<3> {
    let (c, rot) = placement(rng, length);
    let t = rng.uniform(-0.5, 1.5);
    let h = ratio * length;
    let local = [
        DVec3::ZERO,
        DVec3::new(length, 0.0, 0.0),
        DVec3::new(t * length, h, 0.0),
    ];
    NearDegenerate {
        x: local.map(|p| c + rot * p),
        length,
        feature: h,
    }
}

/// A nearly flat tetrahedron: a well-shaped base triangle `x₀x₁x₂` of size `length`,
/// and `x₃` at height `±ratio · length` above its plane (`ratio > 0`), its foot
/// anywhere within `±length` of the base (inside: a "cap"; outside: a "sliver").
/// Random placement and sign; `feature` is the height.
pub fn flat_tet(rng: &mut Rng, length: f64, ratio: f64) -> NearDegenerate<4> {
    let (c, rot) = placement(rng, length);
    let h = rng.sign() * ratio * length;
    // Base: an equilateral-ish triangle with random perturbations (stays well shaped).
    let base = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.5, 0.866, 0.0),
    ]
    .map(|p| length * (p + 0.15 * DVec3::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), 0.0)));
    let foot = DVec3::new(
        rng.uniform(-0.5, 1.5) * length,
        rng.uniform(-0.5, 1.4) * length,
        0.0,
    );
    let local = [base[0], base[1], base[2], foot + DVec3::new(0.0, 0.0, h)];
    NearDegenerate {
        x: local.map(|p| c + rot * p),
        length,
        feature: ratio * length,
    }
}

/// A nearly flat hinge for a dihedral stencil `(x₀, x₁, x₂, x₃)`, triangles
/// `(x₀, x₁, x₂)` and `(x₁, x₀, x₃)` sharing the hinge edge `x₀x₁` of length `length`.
///
/// The wings `x₂`, `x₃` lie at distance `≈ length` from the hinge line, one of them
/// lifted out of the plane of the other by `±ratio · length` (`ratio > 0`). With
/// `folded = false` the wings are on opposite sides of the hinge (an almost flat sheet,
/// dihedral angle near 0); with `folded = true` on the same side (closed almost
/// completely, angle near ±π). Random placement; `feature` is the lift.
pub fn flat_hinge(rng: &mut Rng, length: f64, ratio: f64, folded: bool) -> NearDegenerate<4> {
    let (c, rot) = placement(rng, length);
    let lift = rng.sign() * ratio * length;
    let s2 = rng.uniform(-0.3, 1.3) * length;
    let s3 = rng.uniform(-0.3, 1.3) * length;
    let d2 = rng.uniform(0.5, 1.5) * length;
    let d3 = rng.uniform(0.5, 1.5) * length;
    let side3 = if folded { 1.0 } else { -1.0 };
    let local = [
        DVec3::ZERO,
        DVec3::new(length, 0.0, 0.0),
        DVec3::new(s2, d2, 0.0),
        DVec3::new(s3, side3 * d3, lift),
    ];
    NearDegenerate {
        x: local.map(|p| c + rot * p),
        length,
        feature: ratio * length,
    }
}

/// A hinge with one thin wing: hinge edge `x₀x₁` of length `length`, wing `x₂` at
/// distance `ratio · length` from the hinge line (`ratio > 0`; triangle `(x₀, x₁, x₂)`
/// is a sliver, so `∂θ/∂x₂ ∝ 1/distance`), wing `x₃` well away from it, and a random
/// dihedral angle in `[−0.9π, 0.9π]`. Random placement; `feature` is the wing's
/// distance.
pub fn thin_wing_hinge(rng: &mut Rng, length: f64, ratio: f64) -> NearDegenerate<4> {
    let (c, rot) = placement(rng, length);
    let h = ratio * length;
    let angle = rng.uniform(-0.9, 0.9) * core::f64::consts::PI;
    let d3 = rng.uniform(0.5, 1.5) * length;
    // Wing x₂ along +y; x₃ along −y rotated about the hinge (x axis) by `angle`.
    let local = [
        DVec3::ZERO,
        DVec3::new(length, 0.0, 0.0),
        DVec3::new(rng.uniform(-0.3, 1.3) * length, h, 0.0),
        DVec3::new(
            rng.uniform(-0.3, 1.3) * length,
            -d3 * angle.cos(),
            -d3 * angle.sin(),
        ),
    ];
    NearDegenerate {
        x: local.map(|p| c + rot * p),
        length,
        feature: h,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corrected_rel_error_basics() {
        assert_eq!(corrected_rel_error(1.0, 1.0, 0.0), 0.0);
        assert_eq!(corrected_rel_error(0.0, 0.0, 0.0), 0.0);
        assert_eq!(corrected_rel_error(1.0, 1.1, 0.2), 0.0);
        let e = corrected_rel_error(1.0, 1.001, 0.0);
        assert!((e - 0.001 / 2.001).abs() < 1e-15);
        assert!(corrected_rel_error(f64::NAN, 1.0, 0.0).is_nan());
    }

    #[test]
    fn rng_is_deterministic_and_uniformish() {
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        let mut mean = 0.0;
        for _ in 0..10_000 {
            let x = a.next_f64();
            assert_eq!(x, b.next_f64());
            assert!((0.0..1.0).contains(&x));
            mean += x / 10_000.0;
        }
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
        let r = a.rotation();
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        assert!((r.transpose() * r - DMat3::IDENTITY)
            .abs()
            .to_cols_array()
            .iter()
            .all(|v| *v < 1e-12));
    }

    #[test]
    fn generators_hit_their_feature_sizes() {
        let mut rng = Rng::new(1);
        let p = near_coincident_pair(&mut rng, 2.0, 1e-4);
        assert!(((p.x[0] - p.x[1]).length() - 2e-4).abs() < 1e-12);
        let t = sliver_triangle(&mut rng, 2.0, 1e-4);
        let e = t.x[1] - t.x[0];
        let height = e.cross(t.x[2] - t.x[0]).length() / e.length();
        assert!((height - 2e-4).abs() < 1e-9, "{height}");
        let v = flat_tet(&mut rng, 2.0, 1e-4);
        let n = (v.x[1] - v.x[0]).cross(v.x[2] - v.x[0]).normalize();
        assert!(((v.x[3] - v.x[0]).dot(n).abs() - 2e-4).abs() < 1e-9);
        let h = flat_hinge(&mut rng, 2.0, 1e-4, false);
        assert!(characteristic_length(&h.x) > 1.0);
    }
}
