//! The soft step's per-step preparation: the point arrays in colour order, warm-started
//! by contact key, and the static load estimate that seeds new manifolds.

use super::*;

/// Longest manifold (points of one collider pair) whose ids `prepare` checks for
/// being distinct (pairwise): a longer one counts as holding a repeated key, which
/// turns the next step's merge shortcut off (a box face has 4 points).
const UNIQUE_RUN: usize = 8;

/// Whether the ids of `run` (the points of one manifold) are distinct, compared
/// pairwise; false for a run longer than [`UNIQUE_RUN`].
fn distinct_ids(run: &[crate::geometry::Contact]) -> bool {
    if run.len() > UNIQUE_RUN {
        return false;
    }
    let mut ids = [0u64; UNIQUE_RUN];
    for (id, c) in ids.iter_mut().zip(run) {
        *id = c.id;
    }
    let mut distinct = true;
    for q in 1..run.len() {
        for r in 0..q {
            distinct &= ids[q] != ids[r];
        }
    }
    distinct
}

/// A previous step's impulses of one point as `prepare` reads them (normal,
/// tangent vector, preload floor; see [`Warm`]).
type Found = (f64, DVec3, f64);

/// The forward merge of the contacts (in collider-pair order) with the previous
/// step's `warm` (sorted by collider pair): each contact finds the first entry of its
/// pair's run with its id, or none.
///
/// Where `warm`'s keys are unique (`unique`, [`SoftState::warm_unique`]) the entry
/// after the last hit, if it has the contact's key, is the one the search finds: a
/// step whose contacts are the last step's finds every point there, without a
/// search (the search was 1.2 % of the 210-box pyramid's step, callgrind).
struct WarmMerge<'a> {
    warm: &'a [Warm],
    /// The first entry whose pair is not below the last contact's.
    cursor: usize,
    /// The entry after the last hit (`usize::MAX`: no shortcut).
    next: usize,
    unique: bool,
}

impl<'a> WarmMerge<'a> {
    fn new(warm: &'a [Warm], unique: bool) -> Self {
        let next = if unique { 0 } else { usize::MAX };
        Self {
            warm,
            cursor: 0,
            next,
            unique,
        }
    }

    /// The previous impulses of contact `c` (the next in pair order) and their
    /// entry's index in `warm`, if found.
    #[inline(always)]
    fn find(&mut self, c: &crate::geometry::Contact) -> Option<(usize, Found)> {
        let warm = self.warm;
        let key = c.key();
        let hit = match warm.get(self.next) {
            Some(e) if e.0 == key => Some((self.next, e)),
            _ => {
                let (a, b, id) = key;
                let mut cursor = self.cursor;
                while cursor < warm.len() && (warm[cursor].0 .0, warm[cursor].0 .1) < (a, b) {
                    cursor += 1;
                }
                self.cursor = cursor;
                warm[cursor..]
                    .iter()
                    .take_while(|e| e.0 .0 == a && e.0 .1 == b)
                    .position(|e| e.0 .2 == id)
                    .map(|i| (cursor + i, &warm[cursor + i]))
            }
        };
        hit.map(|(i, &(_, zn, ft, fl))| {
            if self.unique {
                self.next = i + 1;
            }
            (i, (zn, ft, fl))
        })
    }
}

/// The warm start of each contact from the previous step's `warm` ([`WarmMerge`]):
/// `found` the impulses (zeros where none), `found_hit` whether found.
#[cfg(test)]
fn merge_warm(
    contacts: &[crate::geometry::Contact],
    warm: &[Warm],
    unique: bool,
    found: &mut [Found],
    found_hit: &mut [bool],
) {
    let none = (0.0, DVec3::ZERO, 0.0);
    let mut merge = WarmMerge::new(warm, unique);
    for (c, (f, h)) in contacts
        .iter()
        .zip(found.iter_mut().zip(found_hit.iter_mut()))
    {
        let hit = merge.find(c);
        *h = hit.is_some();
        *f = hit.map_or(none, |(_, f)| f);
    }
}

/// A manifold's two inverse world inertias side by side: `m[i][c]` holds entry `(i,
/// c)` (row `i`, column `c`) of `I_a⁻¹` in lane 0 and of `I_b⁻¹` in lane 1.
type InertiaLanes = [[f64x2; 3]; 3];

/// The lanes of `I_a⁻¹` and `I_b⁻¹` ([`InertiaLanes`]).
#[inline(always)]
fn inertia_lanes(ia: &DMat3, ib: &DMat3) -> InertiaLanes {
    let (ca, cb) = (ia.to_cols_array_2d(), ib.to_cols_array_2d());
    core::array::from_fn(|i| core::array::from_fn(|c| f64x2::new([ca[c][i], cb[c][i]])))
}

/// One point's angular terms and effective masses: per direction `d` of `dirs` the
/// lanes of `r × d` (`cross`) and of `I⁻¹(r × d)` (`inv`), by axis (x, y, z; body
/// `a` in lane 0, `b` in lane 1: [`ang_of`] makes the point's `ang[r] = [r_a × d,
/// r_b × d, I_a⁻¹(r_a × d), I_b⁻¹(r_b × d)]` of them), and
/// `k = J M⁻¹ Jᵀ = 1/m_a + 1/m_b + (r_a×d)ᵀI_a⁻¹(r_a×d) + (r_b×d)ᵀI_b⁻¹(r_b×d)`,
/// the mass `1/k` (zero where `k ≤ 0`). Bodies `a` and `b` in the two lanes of
/// `f64x2`: each lane does glam's scalar operations in glam's order (`cross`,
/// `mul_vec3` column by column, `dot` left to right, `k` summed left to right), so
/// the bits are the scalar code's, at half the arithmetic instructions. Kept in
/// registers: [`Paired::put`](crate::rigid::soft_lanes::Paired::put) stores `inv`
/// lane by lane, and only a point whose `ang` is kept stores that.
#[inline(always)]
fn angular_terms(
    (ra, rb): (DVec3, DVec3),
    dirs: &[DVec3; 3],
    m: &InertiaLanes,
    im_sum: f64,
    (cross, inv): (&mut [[f64x2; 3]; 3], &mut [[f64x2; 3]; 3]),
) -> [f64; 3] {
    let (rx, ry, rz) = (
        f64x2::new([ra.x, rb.x]),
        f64x2::new([ra.y, rb.y]),
        f64x2::new([ra.z, rb.z]),
    );
    let mut k = [0.0; 3];
    for (((d, out), k), lanes) in dirs.iter().zip(cross).zip(&mut k).zip(inv) {
        let (dx, dy, dz) = (f64x2::splat(d.x), f64x2::splat(d.y), f64x2::splat(d.z));
        // r × d (glam: `self.y * rhs.z - rhs.y * self.z`, …).
        let (ux, uy, uz) = (ry * dz - dy * rz, rz * dx - dz * rx, rx * dy - dx * ry);
        // I⁻¹ u: column x scaled, then y, then z added (glam's `mul_vec3`).
        let row = |i: usize| m[i][0] * ux + m[i][1] * uy + m[i][2] * uz;
        let (ix, iy, iz) = (row(0), row(1), row(2));
        *lanes = [ix, iy, iz];
        *out = [ux, uy, uz];
        let dot = (ux * ix + uy * iy + uz * iz).to_array();
        *k = im_sum + dot[0] + dot[1];
    }
    // The masses `1/k` after the three `k`: the first two divided in one packed
    // division (correctly rounded per lane, as the scalar's).
    let inv = (f64x2::splat(1.0) / f64x2::new([k[0], k[1]])).to_array();
    let inv = [inv[0], inv[1], 1.0 / k[2]];
    core::array::from_fn(|r| if k[r] > 0.0 { inv[r] } else { 0.0 })
}

/// The lanes of a 3-vector by axis (body `a` in lane 0, `b` in lane 1) as the two
/// vectors.
#[inline(always)]
fn unlane([x, y, z]: [f64x2; 3]) -> [DVec3; 2] {
    let (x, y, z) = (x.to_array(), y.to_array(), z.to_array());
    [DVec3::new(x[0], y[0], z[0]), DVec3::new(x[1], y[1], z[1])]
}

/// A point's `ang[r] = [r_a × d, r_b × d, I_a⁻¹(r_a × d), I_b⁻¹(r_b × d)]` from
/// [`angular_terms`]' lanes.
#[inline(always)]
fn ang_of(cross: &[[f64x2; 3]; 3], inv: &[[f64x2; 3]; 3]) -> [[DVec3; 4]; 3] {
    core::array::from_fn(|r| {
        let ([ua, ub], [ia, ib]) = (unlane(cross[r]), unlane(inv[r]));
        [ua, ub, ia, ib]
    })
}

/// One body's load and supports for the static load estimate
/// (`ContactWorld::estimate_loads`), in horizontal coordinates.
#[derive(Clone, Copy, Debug)]
pub(in crate::rigid) struct Pressure {
    /// `Σ f x` of the load: the weight at the centre and the forces passed down.
    moment: [f64; 2],
    /// Supporting points: count, `Σ x`, `Σ x xᵀ` as `[xx, xy, yy]`, and their
    /// bounding box (`lo`, `hi`).
    count: f64,
    sum: [f64; 2],
    second: [f64; 3],
    lo: [f64; 2],
    hi: [f64; 2],
}

impl Default for Pressure {
    /// No load and no points; the bounding box empty, `lo = +∞`, `hi = −∞`, so that
    /// the first point's `min`/`max` make it that point's (read only once a point
    /// was added: `pressure_share` is asked only of a supported body).
    fn default() -> Self {
        Self {
            moment: [0.0; 2],
            count: 0.0,
            sum: [0.0; 2],
            second: [0.0; 3],
            lo: [f64::INFINITY; 2],
            hi: [f64::NEG_INFINITY; 2],
        }
    }
}

impl Pressure {
    /// Adds a supporting point at `x`.
    ///
    /// The sums in `f64x2` lanes (`Σ x` both coordinates at once, `Σ x₀ x` as `[xx,
    /// xy]`): each lane the scalar's operation, the same bits.
    #[inline(always)]
    fn add_point(&mut self, x: [f64; 2]) {
        // From the empty box (`±∞`: see `default`) the first point's `min`/`max` are
        // its coordinates, bit for bit, NaN included (`at_most(+∞, x)` is `x`, as
        // `at_least(−∞, x)`): no branch on the first point (it was one of the
        // 210-box pyramid's simulated mispredicts, 11.4k in 60 steps, cachegrind
        // `--branch-sim`).
        for k in 0..2 {
            self.lo[k] = at_most(self.lo[k], x[k]);
            self.hi[k] = at_least(self.hi[k], x[k]);
        }
        self.count += 1.0;
        let v = f64x2::new(x);
        let sum = f64x2::new(self.sum) + v;
        let second = f64x2::new([self.second[0], self.second[1]]) + f64x2::splat(x[0]) * v;
        self.sum = sum.to_array();
        [self.second[0], self.second[1]] = second.to_array();
        self.second[2] += x[1] * x[1];
    }
}

/// The vertical force on a supporting point at `x` when a body carrying `load`
/// rests on the points of `p` as on equal springs (a rigid body on an elastic
/// foundation): `f(x) = L/N + βᵀ(x − x̄)`, linear over the points, with `Σ f = L`
/// and `Σ f x = Σ L x_c` (the load's centre of pressure `x_c` = moment / `L`):
/// `β = L S⁻¹ (x_c − x̄)`, `S = Σ (x − x̄)(x − x̄)ᵀ` the points' scatter. Points on a
/// line (`det S` below `10⁻⁹ (tr S)²`) take the pseudo-inverse along it, `β = L S (x_c
/// − x̄)/(tr S)²`; a single point takes the whole load. Where the centre of pressure
/// lies so far off centre that a point would pull (the body tips rather than rests),
/// `β` is scaled down until none does, by `t = min(1, (L/N)/B)` with `B = Σ_k |β_k|
/// max(hi_k − x̄_k, x̄_k − lo_k)` over the points' bounding box: every `f` stays in
/// `[0, 2L/N]` and they still sum to `L` (unscaled, a box leaning on one edge of a
/// 1000-body pile was given hundreds of times its weight and was thrown 180 m).
pub(super) fn pressure_share(load: f64, p: &Pressure) -> impl Fn([f64; 2]) -> f64 {
    let n = p.count;
    // Divisions of two lanes in one `f64x2` division (correctly rounded per lane, the
    // scalar's bits): the mean, the centre of pressure and `β`.
    let mean = (f64x2::new(p.sum) / f64x2::splat(n)).to_array();
    let (sxx, sxy, syy) = (
        p.second[0] - n * mean[0] * mean[0],
        p.second[1] - n * mean[0] * mean[1],
        p.second[2] - n * mean[1] * mean[1],
    );
    let mut beta = if load > 0.0 {
        let c = (f64x2::new(p.moment) / f64x2::splat(load) - f64x2::new(mean)).to_array();
        let det = sxx * syy - sxy * sxy;
        let tr = sxx + syy;
        if det > 1e-9 * tr * tr {
            let (c, c_swapped) = (f64x2::new(c), f64x2::new([c[1], c[0]]));
            let s_diag = f64x2::new([syy, sxx]);
            (f64x2::splat(load) * (s_diag * c - f64x2::splat(sxy) * c_swapped) / f64x2::splat(det))
                .to_array()
        } else if tr > 0.0 {
            let k = load / (tr * tr);
            [k * (sxx * c[0] + sxy * c[1]), k * (sxy * c[0] + syy * c[1])]
        } else {
            [0.0, 0.0]
        }
    } else {
        [0.0, 0.0]
    };
    let base = load / n;
    let reach = |k: usize| at_least(p.hi[k] - mean[k], mean[k] - p.lo[k]);
    let bound = beta[0].abs() * reach(0) + beta[1].abs() * reach(1);
    if bound > base {
        let t = base / bound;
        beta = [beta[0] * t, beta[1] * t];
    }
    move |x: [f64; 2]| {
        at_least(
            base + beta[0] * (x[0] - mean[0]) + beta[1] * (x[1] - mean[1]),
            0.0,
        )
    }
}

/// The per-step constants of `prepare`'s per-point loop ([`ContactWorld::fill_points`]).
#[derive(Clone, Copy, Debug)]
pub(in crate::rigid) struct PointConsts {
    /// The unit vector against gravity (`Z` without gravity).
    up: DVec3,
    /// The sub-step.
    hs: f64,
    /// The springs' frequency (`hertz`, capped at a quarter of the sub-step rate).
    hertz: f64,
    /// The softness of a pair of moving bodies, and of a pair with a fixed one.
    dynamic: Softness,
    fixed: Softness,
    /// The warm start's scale (this sub-step over the last step's) and the preload's.
    scale: f64,
    preload: f64,
    /// Whether every manifold was estimated, and whether some manifold is new.
    every: bool,
    new_manifolds: bool,
    /// Whether the colouring is the last step's (the lanes' plan is kept).
    kept: bool,
}

impl ContactWorld {
    /// Builds the point arrays once per step (colour order, see the module docs),
    /// warm-started by contact key from the previous step.
    pub(super) fn prepare(&self, st: &mut SoftState, hs: f64) {
        let up = if self.gravity.length() > 0.0 {
            -self.gravity.normalize()
        } else {
            DVec3::Z
        };
        let contacts = &self.contacts;
        // Colour-major: manifolds ranked bottom-up (along −gravity, index tie-break:
        // deterministic) and coloured greedily, so that a colour's rows touch disjoint
        // bodies (the `colouring` module).
        let nb = self.bodies.len();
        let colliders = &self.colliders;
        let kept = st.colouring.order(
            contacts.len(),
            nb,
            (
                |k| (contacts[k].a, contacts[k].b),
                |k| {
                    let slot = |i: usize| colliders[i].body.unwrap_or(nb);
                    [slot(contacts[k].a), slot(contacts[k].b)]
                },
            ),
            |k| contacts[k].point.dot(up),
        );
        let s = self.settings.soft_step;
        let hertz = s.hertz.min(0.25 / hs);
        let dynamic = Softness::new(hertz, s.damping_ratio, hs);
        let fixed = Softness::new(2.0 * hertz, s.damping_ratio, hs);
        // Warm start by key: the contacts come in pair order `(a, b)` and `warm` is
        // sorted by pair, so one forward merge finds every previous point (the same
        // matches as a search per point, reading `warm` once, in order).
        // Sized once and written by position (as the point arrays below).
        // The anchors' slips apart (read only with anchors on): a contact's entry 40
        // bytes, not 64 (the 210-box pyramid's merge wrote and its point loop read
        // 1.6k and 2.0k D1 misses a step of them, cachegrind).
        let none = (0.0, DVec3::ZERO, 0.0);
        let anchors = s.friction_anchors;
        st.found.resize(contacts.len(), (0.0, DVec3::ZERO, 0.0));
        st.found_hit.resize(contacts.len(), false);
        if anchors {
            st.found_slip.resize(contacts.len(), DVec3::ZERO);
        }
        let mut merge = WarmMerge::new(&st.warm, st.warm_unique);
        let warm_slip = &st.warm_slip;
        let scale = if st.warm_h > 0.0 { hs / st.warm_h } else { 0.0 };
        // Preload: the mean previous normal impulse of each manifold (a run of one
        // collider pair in natural order), the same on each of its points; a new
        // manifold's is its estimate. Sized, and every entry written by position
        // below (an `extend` per manifold cost its length and capacity bookkeeping).
        st.mean.resize(contacts.len(), 0.0);
        // Whether this step's keys are unique (kept with them for the next step's
        // merge), checked manifold by manifold: the ids of a run of one pair are
        // distinct (a run longer than `UNIQUE_RUN` counts as not).
        let mut unique = true;
        // Whether some manifold has no point found (a new manifold).
        let mut fresh = false;
        // The merge walks the contacts in the same pass as their manifolds (runs of one
        // collider pair): each point found, then its manifold's sums.
        let nc = contacts.len();
        let (found, found_hit) = (&mut st.found[..nc], &mut st.found_hit[..nc]);
        let mean = &mut st.mean[..nc];
        let found_slip = if anchors {
            &mut st.found_slip[..nc]
        } else {
            &mut []
        };
        let mut i = 0;
        // Whether the manifolds' pairs ascend (each run's pair above the last run's):
        // the contacts, and the keys `store` keeps in natural order, are then sorted
        // by pair (runs are maximal, so `≥` between runs is out of order).
        let (mut ascending, mut last_pair) = (true, None);
        while i < nc {
            let pair = (contacts[i].a, contacts[i].b);
            ascending &= last_pair < Some(pair);
            last_pair = Some(pair);
            let mut j = i;
            let mut sum = 0.0;
            let mut hits = 0usize;
            // The ids' residues mod 64 as bits: no bit set twice, the ids are distinct.
            let (mut bits, mut clash) = (0u64, false);
            while j < nc && (contacts[j].a, contacts[j].b) == pair {
                let c = &contacts[j];
                let hit = merge.find(c);
                found_hit[j] = hit.is_some();
                let (zn, ft, fl) = hit.map_or(none, |(_, f)| f);
                found[j] = (zn, ft, fl);
                if anchors {
                    // A slip not kept (the last step had anchors off) is zero.
                    let at = |(i, _)| warm_slip.get(i).copied();
                    found_slip[j] = hit.and_then(at).unwrap_or(DVec3::ZERO);
                }
                sum += zn;
                hits += usize::from(found_hit[j]);
                let bit = 1u64 << (c.id % 64);
                clash |= bits & bit != 0;
                bits |= bit;
                j += 1;
            }
            unique &= !clash || distinct_ids(&contacts[i..j]);
            fresh |= hits == 0;
            let mut m = sum / (j - i) as f64;
            // A renamed point of a known manifold: the mean of the points found.
            if s.refill_renamed && hits > 0 && hits < j - i {
                let (mut ft, mut fl) = (DVec3::ZERO, 0.0);
                for q in i..j {
                    ft += found[q].1;
                    fl += found[q].2;
                }
                let share = 1.0 / hits as f64;
                m = sum * share;
                for q in i..j {
                    if !found_hit[q] {
                        found[q] = (m, ft * share, fl * share);
                        if anchors {
                            found_slip[q] = DVec3::ZERO;
                        }
                    }
                }
            }
            mean[i..j].fill(m);
            // From here on `found_hit` marks the points of known manifolds: where no
            // point or every point was found they do already, so only a manifold with
            // points renamed is written (a fill per manifold was 0.15 % of the
            // 210-box pyramid's step, callgrind).
            if hits > 0 && hits < j - i {
                found_hit[i..j].fill(true);
            }
            i = j;
        }
        // A manifold met for the first time starts from the static load estimate
        // instead of zero (see `estimate_loads`).
        // With `preload_estimate` every manifold is estimated, every step.
        let every = self.settings.warm_start && s.preload_estimate;
        st.unique_keys = unique;
        st.pairs_ascending = ascending;
        let new_manifolds =
            self.settings.warm_start && self.estimate_loads(st, up, hs, every, !fresh);
        let preload = if self.settings.warm_start {
            s.preload * scale
        } else {
            0.0
        };
        // The per-point loop: compiled for AVX and AVX-512F/VL where the processor has
        // them (`soft_lanes::fill_points`, the same bits), else here.
        let k = PointConsts {
            up,
            hs,
            hertz,
            dynamic,
            fixed,
            scale,
            preload,
            every,
            new_manifolds,
            kept,
        };
        let bouncy = match crate::rigid::soft_lanes::fill_points(self, st, &k) {
            Some(bouncy) => bouncy,
            None => self.fill_points(st, &k),
        };
        st.bouncy = bouncy;
        if s.block_normal {
            build_blocks(st);
        } else {
            st.blocks.clear();
        }
    }

    /// The point arrays written point by point, manifold by manifold (`prepare`'s
    /// per-point loop, from the constants `k`): returns whether some pair has
    /// restitution. Inlined into `prepare` and into the AVX and AVX-512F/VL builds of
    /// [`fill_points`](crate::rigid::soft_lanes::fill_points) (the same Rust, the same
    /// operations in the same order: the same bits; only the registers differ).
    #[inline(always)]
    pub(in crate::rigid) fn fill_points(&self, st: &mut SoftState, k: &PointConsts) -> bool {
        let PointConsts {
            up,
            hs,
            hertz,
            dynamic,
            fixed,
            scale,
            preload,
            every,
            new_manifolds,
            kept,
        } = *k;
        let s = self.settings.soft_step;
        let nb = self.bodies.len();
        let contacts = &self.contacts;
        // Spring stiffness over the sub-step, `h ω²` per unit effective mass, and the
        // cap's ratio `M γ/(1 − γ)` (`M` times the ratio of preload to spring force at
        // rest: `preload_cap_margin`).
        let omega2 = (TAU * hertz) * (TAU * hertz);
        let omega2_fixed = 4.0 * omega2;
        let kappa = if s.preload < 1.0 {
            s.preload_cap_margin * s.preload / (1.0 - s.preload)
        } else {
            f64::INFINITY
        };
        // The point arrays are sized to the point count (a no-op when it is the last
        // step's) and every entry is written by position below: a `push` per array
        // and point cost its length and capacity bookkeeping (≈ 100 instructions a
        // point over the 18 arrays, 1.7 % of the 210-box pyramid's step, callgrind).
        let np = st.colouring.out.len();
        macro_rules! size {
            ($($f:ident: $z:expr),*) => { $(st.$f.resize(np, $z);)* };
        }
        size!(
            slots: [0; 2],
            dir: [DVec3::ZERO; 3],
            anchor: [DVec3::ZERO; 2],
            ang: [[DVec3::ZERO; 4]; 3],
            mass: [0.0; 3],
            base_gap: 0.0,
            soft: dynamic,
            friction: 0.0,
            restitution: 0.0,
            approach: 0.0,
            impulse: [0.0; 3],
            max_normal: 0.0,
            total: [0.0; 3],
            slip: [0.0; 2],
            im: [0.0; 2],
            preload: 0.0,
            preload_cap: 0.0,
            preload_floor: 0.0,
            gap: 0.0
        );
        // Slices of exactly `np` entries: `p < np` needs no bounds check per write.
        let order = &st.colouring.out[..np];
        let (slots, dir, anchor) = (&mut st.slots[..np], &mut st.dir[..np], &mut st.anchor[..np]);
        let (ang_out, mass_out, im_out) = (&mut st.ang[..np], &mut st.mass[..np], &mut st.im[..np]);
        let (base_gap, soft, friction) = (
            &mut st.base_gap[..np],
            &mut st.soft[..np],
            &mut st.friction[..np],
        );
        let (restitution, approach, impulse) = (
            &mut st.restitution[..np],
            &mut st.approach[..np],
            &mut st.impulse[..np],
        );
        let (max_normal, total, slip) = (
            &mut st.max_normal[..np],
            &mut st.total[..np],
            &mut st.slip[..np],
        );
        let (preload_out, preload_cap, preload_floor) = (
            &mut st.preload[..np],
            &mut st.preload_cap[..np],
            &mut st.preload_floor[..np],
        );
        let gap = &mut st.gap[..np];
        // Every manifold's `ang` kept this step where the last step solved as many
        // points one at a time as this one has, on threads or without the block
        // normal solve (one point at a time), with the residual (it reads them), or
        // where the relax lanes would decline (`inv_h` not positive and finite); else
        // only those that the one-point passes read (see `SoftState::ang_kept`).
        let inv_h = 1.0 / hs;
        let keep_all = st.one_point >= np
            || s.threads > 1
            || !s.block_normal
            || s.residual
            || !(inv_h > 0.0 && inv_h.is_finite());
        st.one_point = 0;
        let manifolds = st.colouring.manifold_start.len().saturating_sub(1);
        st.ang_kept.resize(manifolds, true);
        let ang_kept = &mut st.ang_kept[..manifolds];
        // Grown here with the point arrays, not in the pass that fills it (a step
        // allocates nothing once grown), and never shrunk (entries are read only
        // where that pass wrote them: no zeroing as the point count varies).
        if st.ang_scratch.len() < np {
            st.ang_scratch.resize(np, [[DVec3::ZERO; 4]; 3]);
        }
        // The SIMD lanes' packed rows, written point by point below (their plan, a
        // function of the colouring alone, is the last step's when the colouring is).
        if !kept {
            st.paired.plan(&st.colouring);
        }
        let paired = &mut st.paired;
        paired.begin();
        // One-way coupling off (the default, an infinite ratio): `im[lower] > ∞ ·
        // im[upper]` never holds (∞ · 0 is NaN), so the heights need not be read.
        let one_way = s.one_way_mass_ratio < f64::INFINITY;
        // Manifold by manifold (every point is in one; the points of a manifold
        // share their colliders, bodies, masses, softness and, where their normals
        // are the same bits, their tangents: these are read once a manifold), each
        // point written at its solve position.
        let (mp, mpts) = (
            st.colouring.manifold_start.as_slice(),
            st.colouring.manifold_points.as_slice(),
        );
        let mut bouncy = false;
        // The settings read per point, and the per-contact arrays as slices of
        // exactly `nc` entries (`k < nc` one check for all of them); the estimate
        // exists only where `estimate_loads` ran (`every` or a new manifold).
        let (warm_start, anchors) = (self.settings.warm_start, s.friction_anchors);
        let estimated = every || new_manifolds;
        let nc = contacts.len();
        let (contacts, found, found_hit, mean) = (
            &contacts[..nc],
            &st.found[..nc],
            &st.found_hit[..nc],
            &st.mean[..nc],
        );
        let estimate = if estimated { &st.estimate[..nc] } else { &[] };
        let found_slip = if anchors { &st.found_slip[..nc] } else { &[] };
        for j in 0..mp.len().saturating_sub(1) {
            let pts = &mpts[mp[j]..mp[j + 1]];
            let Some(&first) = pts.first() else {
                continue;
            };
            let c0 = &contacts[order[first]];
            let (ca, cb) = (&self.colliders[c0.a], &self.colliders[c0.b]);
            let (a, b) = (ca.body.unwrap_or(nb), cb.body.unwrap_or(nb));
            let xa = ca.body.map(|i| self.bodies[i].pose.x);
            let xb = cb.body.map(|i| self.bodies[i].pose.x);
            // One-way coupling: the lower of two moving bodies is static for this
            // manifold when the upper is more than `one_way_mass_ratio` times heavier.
            let mut im = [st.inv_mass[a], st.inv_mass[b]];
            // By reference: the two 72-byte matrices are not copied.
            let mut inertia = [&st.inv_inertia[a], &st.inv_inertia[b]];
            if one_way && a != nb && b != nb {
                let (ha, hb) = (self.bodies[a].pose.x.dot(up), self.bodies[b].pose.x.dot(up));
                let (lower, upper) = if ha < hb { (0, 1) } else { (1, 0) };
                if im[lower] > s.one_way_mass_ratio * im[upper] {
                    im[lower] = 0.0;
                    inertia[lower] = &DMat3::ZERO;
                }
            }
            let (lanes, im_sum) = (inertia_lanes(inertia[0], inertia[1]), im[0] + im[1]);
            let mu = ca.friction.max(cb.friction);
            let e = ca.restitution.max(cb.restitution);
            bouncy |= e != 0.0;
            let fixed_pair = a == nb || b == nb;
            let softness = if fixed_pair { fixed } else { dynamic };
            let omega2_pair = if fixed_pair { omega2_fixed } else { omega2 };
            // The tangents of the last normal (by its bits: a signed zero changes them).
            let bits = |n: DVec3| [n.x.to_bits(), n.y.to_bits(), n.z.to_bits()];
            // Seeded with the manifold's first point's, which every point of a
            // box–box manifold shares: the test below then takes the same way at
            // every point (started empty, it missed at each manifold's first point,
            // the 210-box pyramid's largest simulated mispredict, 22.4k in 60 steps,
            // cachegrind `--branch-sim`). The same tangents: computed from the
            // same normal bits.
            let tangents = |n: DVec3| {
                let (t1, t2) = n.any_orthonormal_pair();
                (bits(n), [n, t1, t2])
            };
            let mut last = tangents(c0.normal);
            // The manifold's shared rows, from its first point (every point's where
            // their normals are its bits; where one is not, the point loop below
            // unpacks the manifold's group for this step).
            paired.put_head(first, &last.1, im, mu);
            // Its `ang` kept unless packed with `BLOCK_POINTS` points (then the lane
            // passes and the packed blocks' build read its packed rows) and without
            // restitution (whose pass reads them).
            let keep = keep_all || e != 0.0 || pts.len() != BLOCK_POINTS || !paired.packs(first);
            if let Some(k) = ang_kept.get_mut(j) {
                *k = keep;
            }
            for &p in pts {
                let k = order[p];
                let c = &contacts[k];
                let ra = xa.map_or(DVec3::ZERO, |x| c.point_on_a() - x);
                let rb = xb.map_or(DVec3::ZERO, |x| c.point_on_b() - x);
                let n = c.normal;
                let (now, key) = (bits(n), last.0);
                if (now[0] ^ key[0]) | (now[1] ^ key[1]) | (now[2] ^ key[2]) != 0 {
                    last = tangents(n);
                    paired.unshare(first);
                }
                let dirs = last.1;
                let [_, t1, t2] = dirs;
                let mut cross = [[f64x2::ZERO; 3]; 3];
                let mut inv = [[f64x2::ZERO; 3]; 3];
                let mass = angular_terms((ra, rb), &dirs, &lanes, im_sum, (&mut cross, &mut inv));
                if keep {
                    ang_out[p] = ang_of(&cross, &inv);
                }
                // The point's previous impulses (zeros where not found), whether it
                // starts from the estimate (a new manifold's point), and the estimate
                // (read only where estimated).
                let (zn, ft, fl) = found[k];
                let fresh_point = new_manifolds && !found_hit[k];
                let est = if estimated { estimate[k] } else { 0.0 };
                let z = if !warm_start {
                    [0.0; 3]
                } else if fresh_point {
                    [est, ft.dot(t1) * scale, ft.dot(t2) * scale]
                } else {
                    [zn * scale, ft.dot(t1) * scale, ft.dot(t2) * scale]
                };
                // The anchor's slip, stored as `s₀ − tᵀ(r_b − r_a)`, so that `s₀ + tᵀ
                // Δd` below is the slip (Δd: the anchors' separation vector, as for
                // the gap); read only with anchors on.
                if anchors {
                    let (sl, r) = (found_slip[k], rb - ra);
                    slip[p] = [sl.dot(t1) - t1.dot(r), sl.dot(t2) - t2.dot(r)];
                }
                // The gap at the start of the step, `C₀ = base_gap + nᵀ(r_b − r_a)`
                // (what `update_gaps` gives at zero displacements, where `Δx + Δq r =
                // r`: the same bits, up to the sign of a zero), without a pass over the
                // points.
                let offset = n.dot(rb - ra);
                let base = -c.depth - offset;
                let pre = if (every && est > 0.0) || fresh_point {
                    s.preload * est
                } else {
                    preload * mean[k]
                };
                let cap = kappa * mass[0] * hs * omega2_pair;
                let floor = if !warm_start {
                    0.0
                } else if fresh_point {
                    s.preload * est
                } else {
                    // The floor fades geometrically and, on a resting contact, would
                    // reach subnormal doubles after about 70k steps (stack10: 40 of 40
                    // floors subnormal at 100k steps) and stay there (`x · 0.99` rounds
                    // back to `x` at 50 ulps or fewer), where every product costs a
                    // microcode assist on x86 (the last 10k of 100k steps 1.34x the
                    // first's CPU time). Flushed to 0 once subnormal: below
                    // `f64::MIN_POSITIVE` N·s it is 10⁻³⁰⁰ of any impulse it bounds, and
                    // a floor that is still normal keeps its bits (the same result
                    // wherever the flush does not act).
                    flush_subnormal(fl * scale * PRELOAD_FLOOR_DECAY)
                };
                paired.put(
                    p,
                    PointRows {
                        anchor: [ra, rb],
                        inv,
                        mass,
                        pre: [pre, cap, floor],
                        base_gap: base,
                    },
                );
                slots[p] = [a, b];
                dir[p] = dirs;
                anchor[p] = [ra, rb];
                mass_out[p] = mass;
                im_out[p] = im;
                base_gap[p] = base;
                gap[p] = base + offset;
                soft[p] = softness;
                friction[p] = mu;
                restitution[p] = e;
                // Relative normal velocity before the step, n·(v_b + ω_b×r_b − v_a −
                // ω_a×r_a), read only by restitution where `e` is not zero.
                approach[p] = if e == 0.0 {
                    0.0
                } else {
                    let [ua, ub] = unlane(cross[0]);
                    n.dot(st.v[b] - st.v[a]) + ub.dot(st.w[b]) - ua.dot(st.w[a])
                };
                impulse[p] = z;
                preload_out[p] = pre;
                preload_cap[p] = cap;
                preload_floor[p] = floor;
                max_normal[p] = 0.0;
                total[p] = [0.0; 3];
            }
        }
        // A group whose normals are not shared is solved one point at a time: its
        // manifolds' `ang` rebuilt from their packed rows (the same bits; rare: a
        // point's normal not its manifold's first's, bit for bit).
        if !keep_all && st.paired.any_unshared() {
            for j in 0..mp.len().saturating_sub(1) {
                if st.ang_kept.get(j).copied().unwrap_or(true) {
                    continue;
                }
                for &p in &mpts[mp[j]..mp[j + 1]] {
                    if let Some(g) = rebuild_ang(&st.paired, &st.anchor, &st.dir, p) {
                        st.ang[p] = g;
                    }
                }
                st.ang_kept[j] = true;
            }
        }
        bouncy
    }

    /// Static load estimate of the contacts, for the manifolds met for the first time
    /// (false, having estimated nothing, when every contact was found in the previous
    /// step). A new manifold has no previous impulse to warm start from: from zero, one
    /// Gauss–Seidel pass per sub-step moves a stack's weight down one box per sub-step,
    /// so a freshly built 10-box stack falls for the first sub-steps and its springs
    /// then overshoot (the top box sank 9 mm in the first 4 steps). The estimate is the
    /// weight each manifold carries at rest, found top-down as shock propagation orders
    /// its bodies (Guendelman et al. 2003): a manifold supports its upper body (along
    /// `up`) when `n · up ≥ 1/2` (within 60° of vertical); each moving body's load —
    /// its weight `m |g|` at its centre plus the vertical forces the points it
    /// supports pass down, at those points — is shared by the points of its supports
    /// as a rigid body on equal springs shares it ([`pressure_share`]): the vertical
    /// forces `f_i` vary linearly over the points' horizontal positions `x_i`, with
    /// `Σ f_i` the load and `Σ f_i x_i` its moment (the load's centre of pressure
    /// kept), clamped at zero. A point's normal impulse is `f_i h_s / n·up`, and its
    /// `f_i` goes to the lower body at `x_i` (not where
    /// [`SoftStepSettings::one_way_mass_ratio`] has the lower body not feel the
    /// upper one). Statically indeterminate supports (a box on two boxes) get the
    /// springs' share: exact for the stack, and on the pyramid's flanks, where a box
    /// carries one neighbour above on one side, its supports' unequal share (an
    /// equal force per manifold there over-estimated the outer support, whose
    /// preload then sat on its cap: the pyramid's worst displacement over 600 steps
    /// at 3 sub-steps 33.4 mm with equal forces, 0.69 mm with the share). The
    /// solve corrects the rest. Deterministic: the manifolds are taken by falling
    /// upper-body height, ties by contact index. With `all_manifolds` it estimates
    /// every manifold even when none is new (and still returns whether one was);
    /// `none_new` says whether every manifold has a point found in the previous step
    /// (`prepare`'s merge knows it).
    pub(super) fn estimate_loads(
        &self,
        st: &mut SoftState,
        up: DVec3,
        hs: f64,
        all_manifolds: bool,
        none_new: bool,
    ) -> bool {
        let contacts = &self.contacts;
        if none_new && !all_manifolds {
            return false;
        }
        let nb = self.bodies.len();
        let g = self.gravity.length();
        let ratio = self.settings.soft_step.one_way_mass_ratio;
        // Horizontal coordinates: along two axes normal to `up`.
        let (e1, e2) = up.any_orthonormal_pair();
        // Both dot products at once in `f64x2` lanes, each lane glam's `dot` (`(x e_x +
        // y e_y) + z e_z`): the same bits.
        let (ex, ey, ez) = (
            f64x2::new([e1.x, e2.x]),
            f64x2::new([e1.y, e2.y]),
            f64x2::new([e1.z, e2.z]),
        );
        let flat = |x: DVec3| {
            (f64x2::splat(x.x) * ex + f64x2::splat(x.y) * ey + f64x2::splat(x.z) * ez).to_array()
        };
        // Every entry is written below (each manifold's run; zero where it supports
        // nothing): sized, not cleared (zeroing it and the loads' moments each step
        // was 0.3 % of the 210-box pyramid's step, callgrind).
        st.estimate.resize(contacts.len(), 0.0);
        st.load.clear();
        st.load.extend(
            st.inv_mass
                .iter()
                .map(|&im| if im > 0.0 { g / im } else { 0.0 }),
        );
        // The weights' moments, at the bodies' centres.
        st.pressure.resize(nb + 1, Pressure::default());
        for ((p, b), &load) in st.pressure.iter_mut().zip(&self.bodies).zip(&st.load) {
            let x = flat(b.pose.x);
            *p = Pressure {
                moment: [load * x[0], load * x[1]],
                ..Pressure::default()
            };
        }
        st.pressure[nb] = Pressure::default();
        st.supports.clear();
        // Written for every supporting point below before it is read.
        st.flat.resize(contacts.len(), [0.0; 2]);
        let (by_rank, start) = st.colouring.bottom_up();
        let slot = |k: usize| self.colliders[k].body.unwrap_or(nb);
        for j in 0..by_rank.len() {
            let c = &contacts[start[j]];
            // The normal points from a to b: b is the upper body when n·up > 0.
            let n_up = c.normal.dot(up);
            let (upper, lower, n_up) = if n_up > 0.0 {
                (slot(c.b), slot(c.a), n_up)
            } else {
                (slot(c.a), slot(c.b), -n_up)
            };
            let supports = n_up >= 0.5 && upper != nb && st.inv_mass[upper] > 0.0;
            if supports {
                // The manifold's run sliced once (one bounds check, not one a point).
                let run = start[j]..start[j + 1];
                let pressure = &mut st.pressure[upper];
                for (out, c) in st.flat[run.clone()].iter_mut().zip(&contacts[run]) {
                    let x = flat(c.point);
                    *out = x;
                    pressure.add_point(x);
                }
            }
            st.supports
                .push((upper, lower, if supports { n_up } else { 0.0 }));
        }
        // Top-down (manifolds by falling lowest point): a body's load is complete once
        // the manifolds above it are taken.
        for &j in by_rank.iter().rev() {
            let j = j as usize;
            let (upper, lower, n_up) = st.supports[j];
            if n_up == 0.0 {
                st.estimate[start[j]..start[j + 1]].fill(0.0);
                continue;
            }
            let share = pressure_share(st.load[upper], &st.pressure[upper]);
            // One-way coupling: the lower body does not feel the upper one.
            let one_way = st.inv_mass[lower] > ratio * st.inv_mass[upper];
            let feels = lower != nb && st.inv_mass[lower] > 0.0 && !one_way;
            // The lower body's load and moment summed in locals, in the same order
            // (the same bits), and the run sliced once.
            let (mut load, mut m) = if feels {
                (st.load[lower], st.pressure[lower].moment)
            } else {
                (0.0, [0.0; 2])
            };
            let run = start[j]..start[j + 1];
            for (&x, e) in st.flat[run.clone()].iter().zip(&mut st.estimate[run]) {
                let f = share(x);
                *e = f / n_up * hs;
                if feels {
                    load += f;
                    m[0] += f * x[0];
                    m[1] += f * x[1];
                }
            }
            if feels {
                st.load[lower] = load;
                st.pressure[lower].moment = m;
            }
        }
        !none_new
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Contact;

    fn contact(a: usize, b: usize, id: u64) -> Contact {
        Contact {
            a,
            b,
            point: DVec3::ZERO,
            normal: DVec3::Z,
            depth: 0.0,
            id,
        }
    }

    fn warm(keys: &[(usize, usize, u64)]) -> Vec<Warm> {
        let at = |k: usize| DVec3::splat(k as f64);
        keys.iter()
            .enumerate()
            .map(|(k, &key)| (key, k as f64, at(k), 0.5 * k as f64))
            .collect()
    }

    fn merge(contacts: &[Contact], warm: &[Warm], unique: bool) -> (Vec<Found>, Vec<bool>) {
        let mut found = alloc::vec![(0.0, DVec3::ZERO, 0.0); contacts.len()];
        let mut hit = alloc::vec![false; contacts.len()];
        merge_warm(contacts, warm, unique, &mut found, &mut hit);
        (found, hit)
    }

    /// With unique keys the shortcut finds what the search finds: the same contacts,
    /// points renamed, reordered within a pair, added and removed, pairs gone and new.
    #[test]
    fn the_merge_shortcut_finds_what_the_search_finds() {
        let last = [
            (0, 1, 3),
            (0, 1, 5),
            (0, 1, 7),
            (1, 2, 1),
            (1, 2, 2),
            (2, 3, 9),
        ];
        let w = warm(&last);
        let steps: [&[(usize, usize, u64)]; 4] = [
            &last,
            &[
                (0, 1, 5),
                (0, 1, 3),
                (0, 1, 8),
                (1, 2, 1),
                (1, 2, 2),
                (2, 3, 9),
            ],
            &[
                (0, 1, 3),
                (0, 1, 7),
                (1, 2, 2),
                (1, 3, 4),
                (2, 3, 9),
                (2, 3, 10),
            ],
            &[(0, 2, 1), (1, 2, 1), (1, 2, 2), (1, 2, 3)],
        ];
        for keys in steps {
            let contacts: Vec<Contact> = keys.iter().map(|&(a, b, id)| contact(a, b, id)).collect();
            let (searched, shortcut) = (merge(&contacts, &w, false), merge(&contacts, &w, true));
            assert_eq!(searched, shortcut, "{keys:?}");
        }
        // Every point of the same contacts found, each at its own entry.
        let same: Vec<Contact> = last.iter().map(|&(a, b, id)| contact(a, b, id)).collect();
        let (found, hit) = merge(&same, &w, true);
        assert!(hit.iter().all(|&h| h));
        assert!(found.iter().enumerate().all(|(k, f)| f.0 == k as f64));
    }

    /// A repeated key (the narrow phase does not promise distinct ids): without the
    /// shortcut each contact gets the first entry of its pair's run with its id, as
    /// the search always gave; the shortcut would take the repeat, which is why
    /// `prepare` turns it off for such keys.
    #[test]
    fn a_repeated_key_gets_the_first_entry() {
        let w = warm(&[(0, 1, 3), (0, 1, 5), (0, 1, 3)]);
        let contacts = [contact(0, 1, 5), contact(0, 1, 3)];
        let (found, hit) = merge(&contacts, &w, false);
        assert_eq!(hit, [true, true]);
        assert_eq!((found[0].0, found[1].0), (1.0, 0.0));
        assert!(distinct_ids(&[contact(0, 1, 3), contact(0, 1, 5)]));
        assert!(!distinct_ids(&[
            contact(0, 1, 3),
            contact(0, 1, 5),
            contact(0, 1, 3)
        ]));
        assert!(!distinct_ids(&[contact(0, 1, 0); UNIQUE_RUN + 1]));
    }
}

/// `x`, or `+0` where `x` is subnormal (`0 < |x| < f64::MIN_POSITIVE`): a decaying
/// quantity stopped before the slow subnormal range; every other value (zeros,
/// normal numbers, infinities, NaN) passes with its bits.
#[inline]
pub(super) fn flush_subnormal(x: f64) -> f64 {
    if x.is_subnormal() {
        0.0
    } else {
        x
    }
}

#[cfg(test)]
mod flush_tests {
    use super::{flush_subnormal, PRELOAD_FLOOR_DECAY};

    /// A floor fading by `PRELOAD_FLOOR_DECAY` from 1 N·s: unflushed it sticks in the
    /// subnormal range (`x · 0.99` rounds back to `x` at 50 ulps or fewer); flushed it goes
    /// from the smallest normal range straight to 0, and never holds a subnormal.
    #[test]
    fn a_fading_floor_reaches_zero_without_subnormals() {
        let (mut raw, mut flushed) = (1.0f64, 1.0f64);
        let mut zero_at = None;
        for step in 0..100_000 {
            raw *= PRELOAD_FLOOR_DECAY;
            flushed = flush_subnormal(flushed * PRELOAD_FLOOR_DECAY);
            assert!(!flushed.is_subnormal(), "step {step}: {flushed:e}");
            if flushed == 0.0 && zero_at.is_none() {
                zero_at = Some(step);
            }
        }
        assert!(raw.is_subnormal(), "unflushed {raw:e}"); // measured 2.4e-322 (49 ulps)
        assert_eq!(zero_at, Some(70_484)); // measured: 0-based step n where 0.99ⁿ⁺¹ < 2.2e-308
                                           // Values that are not subnormal keep their bits.
        for x in [0.0, -0.0, f64::MIN_POSITIVE, 1.0, -3.5, f64::INFINITY] {
            assert_eq!(flush_subnormal(x).to_bits(), x.to_bits());
        }
        assert!(flush_subnormal(f64::NAN).is_nan());
        assert_eq!(flush_subnormal(-1e-310).to_bits(), 0.0f64.to_bits());
    }
}
