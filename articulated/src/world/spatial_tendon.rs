//! Spatial tendons (MuJoCo's `tendon/spatial` with straight paths): a string through
//! sites fixed on bodies, whose length is the sum of the straight segments between
//! consecutive sites.
//!
//! Site `k` sits on body `b_k` (or the world) at `r_k` from the body's centre of mass in
//! the body frame, so its world point and velocity are `p_k = x + R r_k` and
//! `ṗ_k = v + ω × (R r_k)`. With `d_k = p_{k+1} − p_k` and `u_k = d_k / |d_k|`
//! (MuJoCo's `mj_tendon`, `engine_core_smooth.c`, for a path of sites only),
//!
//! ```text
//! L  = Σ_k |d_k|,
//! L̇  = Σ_k u_k · (ṗ_{k+1} − ṗ_k) = J v,
//! J  : segment k gives  [u_k, (R r_{k+1}) × u_k]  on b_{k+1}  and  [−u_k, −(R r_k) × u_k]  on b_k
//! ```
//!
//! (`u · (ω × a) = ω · (a × u)`). A tendon force `f` along `L` (spring `−k (L − L₀)`,
//! damping `−d L̇`, an actuator) acts on the bodies as the wrench `Jᵀ f`: each segment
//! pulls its two sites towards each other with equal and opposite forces `±f u_k` on
//! one line, so the forces and their moments about any point sum to zero. A tendon
//! range is the one-sided row `±J` ([`World::set_tendon_range`], as for a fixed
//! tendon), so a string of length `hi` holds like a rope.
//!
//! A segment of zero length has no direction; it adds nothing to `J` (and no force),
//! a documented fallback (MuJoCo's `mju_normalize3` picks an arbitrary axis there).
//! A tendon may have both joint terms ([`Tendon::terms`]) and a path; its length is the
//! sum of both. Wrapping over geoms and pulleys are not modelled (the loader names them
//! unsupported).

use alloc::vec::Vec;

use constraint_core::DVec3;

use super::equality::Seg;
use super::*;

/// A point of a spatial tendon's path: a site fixed on a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSite {
    /// The body (`None`: the world).
    pub body: Option<usize>,
    /// The site's offset from the body's centre of mass in the body frame (m; for the
    /// world, its world position).
    pub offset: DVec3,
}

/// A spatial tendon: a straight path through at least two sites, with a spring
/// `−k (L − L₀)` and viscous damping `−d L̇` along its length ([`World::add_spatial_tendon`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialTendon {
    /// The sites in path order.
    pub path: Vec<PathSite>,
    /// Stiffness `k ≥ 0` (N/m).
    pub stiffness: f64,
    /// Damping `d ≥ 0` (N·s/m).
    pub damping: f64,
    /// Rest length `L₀` of the spring (m).
    pub rest_length: f64,
}

/// The paths of the world's tendons and the scratch of their forces.
#[derive(Clone, Debug, Default)]
pub(super) struct Paths {
    /// Per tendon, its path (empty: a fixed tendon; shorter than the tendon list when
    /// the last tendons are fixed).
    sites: Vec<Vec<PathSite>>,
    /// The force along each tendon's length to apply through its path (scratch).
    pub(super) force: Vec<f64>,
    /// Segments of one path (scratch).
    segs: Vec<Seg>,
}

impl Paths {
    /// Whether any tendon has a path.
    pub(super) fn any(&self) -> bool {
        self.sites.iter().any(|p| !p.is_empty())
    }
}

impl World {
    /// Adds a spatial tendon; returns its tendon index (shared with the fixed tendons
    /// of [`World::add_tendon`]: actuators, ranges and equalities name it the same way).
    /// Errors ([`ArticulatedError::InvalidParameter`]): fewer than two sites, a site on
    /// an unknown body, a non-finite offset, negative or non-finite stiffness or
    /// damping, non-finite rest length.
    pub fn add_spatial_tendon(&mut self, t: SpatialTendon) -> Result<usize, ArticulatedError> {
        let bad = |rule| ArticulatedError::InvalidParameter {
            name: "spatial tendon",
            rule,
        };
        if t.path.len() < 2 {
            return Err(bad("the path needs at least two sites"));
        }
        if t.path
            .iter()
            .any(|s| s.body.is_some_and(|b| b >= self.bodies.len()) || !s.offset.is_finite())
        {
            return Err(bad("sites must be on existing bodies at finite offsets"));
        }
        let index = self.add_tendon(Tendon {
            terms: Vec::new(),
            stiffness: t.stiffness,
            damping: t.damping,
            rest_length: t.rest_length,
        })?;
        self.paths.sites.resize(self.tendons.len(), Vec::new());
        self.paths.sites[index] = t.path;
        Ok(index)
    }

    /// Tendon `t`'s path (empty for a fixed tendon or an unknown index).
    pub fn tendon_path(&self, t: usize) -> &[PathSite] {
        self.paths.sites.get(t).map_or(&[], |p| p.as_slice())
    }

    /// A site's world point and its lever arm `R r` from the body's centre of mass
    /// (zero for the world).
    fn site_point(&self, s: &PathSite) -> (DVec3, DVec3) {
        match s.body {
            Some(b) => {
                let pose = &self.bodies[b].pose;
                let arm = pose.q * s.offset;
                (pose.x + arm, arm)
            }
            None => (s.offset, DVec3::ZERO),
        }
    }

    /// A site's velocity `v + ω × (R r)` (zero on the world).
    fn site_velocity(&self, s: &PathSite, arm: DVec3) -> DVec3 {
        s.body.map_or(DVec3::ZERO, |b| {
            let body = &self.bodies[b];
            body.v + body.omega.cross(arm)
        })
    }

    /// Length and rate `(L, L̇)` of tendon `t`'s path at the current state (`(0, 0)`
    /// without a path; no allocation).
    pub(super) fn path_state(&self, t: usize) -> (f64, f64) {
        let path = self.tendon_path(t);
        let (mut l, mut rate) = (0.0, 0.0);
        for w in path.windows(2) {
            let (pa, arm_a) = self.site_point(&w[0]);
            let (pb, arm_b) = self.site_point(&w[1]);
            let d = pb - pa;
            l += d.length();
            let u = d.normalize_or_zero();
            rate += u.dot(self.site_velocity(&w[1], arm_b) - self.site_velocity(&w[0], arm_a));
        }
        (l, rate)
    }

    /// Pushes the two-body segments `scale · J` of tendon `t`'s path (module docs);
    /// returns the path's length (0 without a path).
    pub(super) fn push_path(&self, segs: &mut Vec<Seg>, t: usize, scale: f64) -> f64 {
        let path = self.tendon_path(t);
        let mut l = 0.0;
        for w in path.windows(2) {
            let (pa, arm_a) = self.site_point(&w[0]);
            let (pb, arm_b) = self.site_point(&w[1]);
            let d = pb - pa;
            l += d.length();
            let u = d.normalize_or_zero() * scale;
            if u == DVec3::ZERO {
                continue;
            }
            let (ga, gb) = ([-u, -arm_a.cross(u)], [u, arm_b.cross(u)]);
            match (w[0].body, w[1].body) {
                (_, Some(b)) => segs.push((w[0].body, b, [ga[0], ga[1], gb[0], gb[1]])),
                (Some(a), None) => {
                    segs.push((None, a, [DVec3::ZERO, DVec3::ZERO, ga[0], ga[1]]));
                }
                // Both sites on the world: a constant length.
                (None, None) => {}
            }
        }
        l
    }

    /// Adds `scale · Jᵀ f_t` for every tendon path with a force `f_t` in
    /// `self.paths.force` to the bodies' right-hand side (impulses), or to `wrench`
    /// (forces per body) when given.
    pub(super) fn apply_path_forces(
        &mut self,
        scale: f64,
        mut wrench: Option<&mut [(DVec3, DVec3)]>,
    ) {
        let mut segs = core::mem::take(&mut self.paths.segs);
        for t in 0..self.paths.sites.len().min(self.paths.force.len()) {
            let f = self.paths.force[t] * scale;
            if f == 0.0 || self.paths.sites[t].is_empty() {
                continue;
            }
            segs.clear();
            self.push_path(&mut segs, t, f);
            for (a, b, g) in &segs {
                for (side, body) in [(0usize, *a), (1usize, Some(*b))] {
                    let Some(i) = body else { continue };
                    match wrench.as_deref_mut() {
                        Some(w) => {
                            w[i].0 += g[2 * side];
                            w[i].1 += g[2 * side + 1];
                        }
                        None => {
                            let o = self.solver.body_offset(i);
                            for c in 0..3 {
                                self.rhs[o + c] += g[2 * side][c];
                                self.rhs[o + 3 + c] += g[2 * side + 1][c];
                            }
                        }
                    }
                }
            }
        }
        self.paths.segs = segs;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use constraint_core::{DMat3, DQuat, Pose};

    fn lcg(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    fn vec3(s: &mut u64, scale: f64) -> DVec3 {
        DVec3::new(lcg(s), lcg(s), lcg(s)) * scale
    }

    /// Three free bodies and a path world → 0 → 1 → 2 → 2 (two sites on the last body),
    /// at a random state.
    fn random_world(seed: &mut u64) -> World {
        let mut w = World::new(DVec3::ZERO);
        for i in 0..3 {
            let q = DQuat::from_scaled_axis(vec3(seed, 2.0));
            let pose = Pose {
                x: vec3(seed, 1.0) + DVec3::X * i as f64,
                q,
            };
            let inertia = DMat3::from_diagonal(DVec3::new(0.1, 0.2, 0.3));
            let b = RigidBody::new(i, 1.0 + i as f64, inertia, pose)
                .expect("body")
                .with_velocity(vec3(seed, 1.0), vec3(seed, 2.0));
            w.add_body(b).expect("add");
        }
        let site = |body, offset| PathSite { body, offset };
        let path = vec![
            site(None, vec3(seed, 1.0)),
            site(Some(0), vec3(seed, 0.3)),
            site(Some(1), vec3(seed, 0.3)),
            site(Some(2), vec3(seed, 0.3)),
            site(Some(2), vec3(seed, 0.3)),
        ];
        w.add_spatial_tendon(SpatialTendon {
            path,
            stiffness: 10.0,
            damping: 0.0,
            rest_length: 0.5,
        })
        .expect("tendon");
        w
    }

    /// Advances every body along its twist by `s` seconds (exact rigid motion).
    fn moved(w: &World, s: f64) -> World {
        let mut m = w.clone();
        for b in m.bodies_mut() {
            b.pose.x += b.v * s;
            b.pose.q = (DQuat::from_scaled_axis(b.omega * s) * b.pose.q).normalize();
        }
        m
    }

    /// The rate `L̇ = J v` and the segments' `J v` against central differences of `L`
    /// along the bodies' motion, over 200 random configurations.
    #[test]
    fn path_rate_matches_finite_differences() {
        let mut seed = 11u64;
        let eps = 1e-6;
        let (mut worst_rate, mut worst_segs): (f64, f64) = (0.0, 0.0);
        for _ in 0..200 {
            let w = random_world(&mut seed);
            let (l, rate) = w.path_state(0);
            let fd =
                (moved(&w, eps).path_state(0).0 - moved(&w, -eps).path_state(0).0) / (2.0 * eps);
            worst_rate = worst_rate.max((fd - rate).abs() / (1.0 + fd.abs()));
            let mut segs = Vec::new();
            let l2 = w.push_path(&mut segs, 0, 1.0);
            assert_eq!(l, l2);
            let jv = w.span_rate(&segs);
            worst_segs = worst_segs.max((jv - rate).abs());
        }
        println!("path rate vs FD {worst_rate:e}, J v vs rate {worst_segs:e}");
        // measured 1.3e-10 (central differences at ε = 1e-6)
        assert!(worst_rate < 1e-8, "L̇ vs FD: {worst_rate:e}");
        // measured 4.4e-16 (the same sums in another order)
        assert!(worst_segs < 1e-12, "J v vs L̇: {worst_segs:e}");
    }

    /// `Jᵀ f` on free bodies is balanced: the forces sum to zero and so do their moments
    /// about the origin, once the world's share (the first site's pull) is included.
    #[test]
    fn path_forces_are_balanced() {
        let mut seed = 5u64;
        let mut worst: f64 = 0.0;
        for _ in 0..100 {
            let mut w = random_world(&mut seed);
            // Take the world site out: a path over free bodies only.
            let path = w.tendon_path(0)[1..].to_vec();
            w.paths.sites[0] = path;
            let f = 3.0 * lcg(&mut seed);
            w.paths.force = vec![f];
            let mut wrench = vec![(DVec3::ZERO, DVec3::ZERO); 3];
            w.apply_path_forces(1.0, Some(&mut wrench));
            let (mut force, mut moment) = (DVec3::ZERO, DVec3::ZERO);
            for (b, (fb, tb)) in w.bodies().iter().zip(&wrench) {
                force += *fb;
                moment += *tb + b.pose.x.cross(*fb);
            }
            // The wrench does work L̇ f: the power balance against the rate.
            let power: f64 = w
                .bodies()
                .iter()
                .zip(&wrench)
                .map(|(b, (fb, tb))| fb.dot(b.v) + tb.dot(b.omega))
                .sum();
            let (_, rate) = w.path_state(0);
            worst = worst
                .max(force.length())
                .max(moment.length())
                .max((power - f * rate).abs());
        }
        println!("path forces: worst imbalance {worst:e}");
        // measured 8.9e-16 N (forces, moments and power alike)
        assert!(worst < 1e-12, "unbalanced by {worst:e}");
    }

    #[test]
    fn bad_spatial_tendons_are_typed_errors() {
        let mut seed = 3u64;
        let mut w = random_world(&mut seed);
        let site = |body, offset| PathSite { body, offset };
        let t = |path: Vec<PathSite>, k: f64| SpatialTendon {
            path,
            stiffness: k,
            damping: 0.0,
            rest_length: 0.0,
        };
        let bad = |r: Result<usize, ArticulatedError>| {
            matches!(r, Err(ArticulatedError::InvalidParameter { .. }))
        };
        let ok = vec![site(Some(0), DVec3::ZERO), site(Some(1), DVec3::ZERO)];
        assert!(bad(w.add_spatial_tendon(t(ok[..1].to_vec(), 0.0))));
        assert!(bad(w.add_spatial_tendon(t(
            vec![site(Some(0), DVec3::ZERO), site(Some(7), DVec3::ZERO)],
            0.0
        ))));
        assert!(bad(w.add_spatial_tendon(t(
            vec![site(Some(0), DVec3::NAN), site(Some(1), DVec3::ZERO)],
            0.0
        ))));
        assert!(bad(w.add_spatial_tendon(t(ok.clone(), -1.0))));
        assert!(bad(w.add_spatial_tendon(t(ok.clone(), f64::NAN))));
        assert_eq!(w.tendons().len(), 1);
        // A zero-length segment (two sites at one point) adds no row and no force.
        let same = vec![site(Some(0), DVec3::ZERO), site(Some(0), DVec3::ZERO)];
        let i = w.add_spatial_tendon(t(same, 5.0)).expect("tendon");
        let mut segs = Vec::new();
        assert_eq!(w.push_path(&mut segs, i, 1.0), 0.0);
        assert!(segs.is_empty());
        assert_eq!(w.path_state(i), (0.0, 0.0));
        assert!(w.tendon_path(99).is_empty());
    }
}
