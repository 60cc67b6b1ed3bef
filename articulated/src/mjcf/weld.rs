//! Welded bodies merged into their hosts (issue 13).
//!
//! In MuJoCo a body without a joint has no degrees of freedom: it moves with its parent.
//! Every MJCF body therefore gets a *host*: itself when it has a joint (`free` included),
//! else its parent's host; a body whose chain of jointless ancestors reaches the world
//! is *static* (host: the world). The world's bodies are the hosts only, in document
//! order; a merged body's mass, centre of mass and inertia are added to its host's
//! (`merge`), and everything that names it (joints, sites, geoms, connects, states)
//! goes through the host with the body's fixed pose relative to it ([`Part`]).

use alloc::vec::Vec;

use constraint_core::{DMat3, DQuat, DVec3, Pose};
use constraint_mjcf::Model;

/// How [`super::MjcfScene::with_options`] builds the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MjcfOptions {
    /// Merge every body without a joint into its host (default `true`): one world body
    /// per moving MuJoCo weld body, none for bodies welded to the world. `false` keeps
    /// one world body per MJCF body, a jointless one held to its parent (or the world)
    /// by a six-row [`constraint_core::Fixed`] weld. Merging is also skipped (the whole
    /// model built unmerged) when fluid drag is on and a body has no joint (MuJoCo's
    /// inertia-box drag is per body, from its own mass and inertia), or when an
    /// `equality/connect` or a `contact/exclude` names a body of a merged group: a body
    /// merged into another, a host with bodies merged into it, or a static body.
    /// Exclusions and the world's filter on joined bodies (a connect's included) are per
    /// world body here, and would then cover the group's other geoms, where MuJoCo
    /// filters by each geom's own body (and does not filter on connects); merged, a
    /// connect could also join a host to itself or the world to itself.
    pub merge_welded: bool,
}

impl Default for MjcfOptions {
    fn default() -> Self {
        Self { merge_welded: true }
    }
}

/// Where one MJCF body lives in the world: the world body that carries it (`None`: the
/// body is static, fixed in the world) and its frame relative to that body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Part {
    /// The world body (its host), or `None` for a static body.
    pub body: Option<usize>,
    /// The MJCF body frame (origin, orientation) in the host's centre-of-mass frame
    /// (`x` from the host's centre of mass, in the host's body frame; `q` the part's
    /// orientation in the host frame: it maps part coordinates to host coordinates, so
    /// the part's world orientation is `q_host q`); in the world for a static body.
    pub frame: Pose,
    /// The body's own centre of mass in the same frame as [`Self::frame`].
    pub com: DVec3,
    /// Whether the world body is this body alone (nothing merged into it): `frame` is
    /// then `(−com, identity)` and the world body's own state is reported as is.
    pub alone: bool,
}

/// One MJCF body's state, from its host's ([`super::MjcfScene::part_state`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartState {
    /// Body frame origin (MuJoCo `xpos`).
    pub origin: DVec3,
    /// Body frame orientation (`xquat`).
    pub orientation: DQuat,
    /// The body's own centre of mass (`xipos`).
    pub com: DVec3,
    /// Velocity of that centre of mass, `v + ω × r` from the host's (m/s).
    pub v: DVec3,
    /// Angular velocity (the host's, rad/s).
    pub omega: DVec3,
}

/// The map between MJCF bodies and world bodies.
#[derive(Clone, Debug, Default)]
pub(crate) struct Layout {
    /// Per MJCF body: its host MJCF body (`None`: static).
    pub host: Vec<Option<usize>>,
    /// Per MJCF body: its host's world body (`None`: static).
    pub world_of: Vec<Option<usize>>,
    /// Per world body: its MJCF body.
    pub mjcf_of: Vec<usize>,
    /// Per world body: whether other bodies were merged into it.
    pub merged: Vec<bool>,
}

impl Layout {
    /// The hosts of `model`'s bodies; `merge == false` (or a model [`MjcfOptions`] keeps
    /// unmerged) makes every body its own host.
    pub fn new(model: &Model, merge: bool) -> Self {
        let nb = model.bodies.len();
        let weld = weld_hosts(model);
        let fluid = model.options.density > 0.0 || model.options.viscosity > 0.0;
        let jointless = weld.iter().enumerate().any(|(i, h)| *h != Some(i));
        let merge = merge && !(fluid && jointless);
        let mut host: Vec<Option<usize>> = (0..nb).map(Some).collect();
        if merge {
            host = weld;
            if names_a_group(model, &host) {
                host = (0..nb).map(Some).collect();
            }
        }
        let mut world_of = alloc::vec![None; nb];
        let mut mjcf_of = Vec::new();
        let mut merged = Vec::new();
        for i in 0..nb {
            if host[i] == Some(i) {
                world_of[i] = Some(mjcf_of.len());
                mjcf_of.push(i);
                merged.push(false);
            }
        }
        for i in 0..nb {
            if let Some(h) = host[i] {
                world_of[i] = world_of[h];
                if h != i {
                    if let Some(w) = world_of[h] {
                        merged[w] = true;
                    }
                }
            }
        }
        Self {
            host,
            world_of,
            mjcf_of,
            merged,
        }
    }
}

/// Whether a `connect` or a `contact/exclude` names a body of a merged group: one
/// merged into another (or static, `host` `None`), or a host with bodies merged into
/// it. Merged, such a connect can join a host to itself or the world to itself, and
/// an exclusion or the world's filter on the connect's joint (per world body) would
/// cover the group's other geoms, where MuJoCo filters by each geom's own body.
fn names_a_group(model: &Model, host: &[Option<usize>]) -> bool {
    let grouped = |b: Option<usize>| {
        b.is_some_and(|b| match host.get(b).copied().flatten() {
            Some(h) if h == b => host
                .iter()
                .enumerate()
                .any(|(k, hk)| k != b && *hk == Some(b)),
            _ => true,
        })
    };
    let connects = model.connects.iter().map(|c| (c.body1, c.body2));
    let excludes = model.contact_excludes.iter().map(|e| (e.body1, e.body2));
    connects
        .chain(excludes)
        .any(|(a, b)| grouped(a) || grouped(b))
}

/// MuJoCo's weld bodies: per MJCF body, the body whose joint moves it — itself when it
/// has a joint (`free` included), else its parent's (`None`: the world; the body is
/// static). A parent index not before the body (a hand-built model) cannot be read
/// here: the body is then taken as static, as `kinematics` does.
pub(crate) fn weld_hosts(model: &Model) -> Vec<Option<usize>> {
    let nb = model.bodies.len();
    let mut has_joint = alloc::vec![false; nb];
    for j in &model.joints {
        if let Some(h) = has_joint.get_mut(j.body) {
            *h = true;
        }
    }
    let mut host: Vec<Option<usize>> = alloc::vec![None; nb];
    for i in 0..nb {
        host[i] = if has_joint[i] {
            Some(i)
        } else {
            model.bodies[i]
                .parent
                .filter(|p| *p < i)
                .and_then(|p| host[p])
        };
    }
    host
}

/// Mass, centre of mass and inertia of a rigid union of parts, each given as (mass,
/// centre of mass, inertia about that centre), all in one frame: `M = Σ mᵢ`,
/// `C = Σ mᵢ cᵢ / M`, `I = Σ (Iᵢ + mᵢ (|dᵢ|² E − dᵢ dᵢᵀ))` with `dᵢ = cᵢ − C` (the
/// parallel-axis theorem, Steiner; e.g. Featherstone, *Rigid Body Dynamics Algorithms*,
/// 2008, eq. 2.63). `None` when the total mass is not positive.
pub(crate) fn combine(parts: &[(f64, DVec3, DMat3)]) -> Option<(f64, DVec3, DMat3)> {
    let m: f64 = parts.iter().map(|p| p.0).sum();
    if !(m > 0.0) {
        return None;
    }
    let c = parts.iter().fold(DVec3::ZERO, |s, p| s + p.1 * p.0) / m;
    let inertia = parts.iter().fold(DMat3::ZERO, |s, p| {
        let d = p.1 - c;
        let shift = DMat3::from_diagonal(DVec3::splat(d.length_squared()))
            - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        s + p.2 + shift * p.0
    });
    Some((m, c, inertia))
}

/// MJCF body `i`'s frame at the default pose relative to body `h`'s frame: (origin in
/// `h`'s frame, `i`'s orientation in `h`'s frame, mapping `i` coordinates to `h` ones),
/// from the world poses `xpos`, `xquat`: `t = q_h⁻¹ (p_i − p_h)`, `R = q_h⁻¹ q_i`.
pub(crate) fn relative_frame(model: &Model, h: usize, i: usize) -> (DVec3, DQuat) {
    let (bh, bi) = (&model.bodies[h], &model.bodies[i]);
    let qh = super::quat(bh.quat);
    let qi = super::quat(bi.quat);
    let inv = qh.inverse();
    (
        inv * (super::v3(bi.pos) - super::v3(bh.pos)),
        (inv * qi).normalize(),
    )
}

/// The inertia `I` of a part turned into its host's frame by `R`: `R I Rᵀ`.
pub(crate) fn rotate_inertia(r: DQuat, inertia: DMat3) -> DMat3 {
    let m = DMat3::from_quat(r);
    m * inertia * m.transpose()
}

/// Every MJCF body's [`Part`], given each world body's centre of mass `coms` (host
/// frame): a host's own frame is `(−C, identity)`, a merged body's `(t − C, R)`
/// ([`relative_frame`]), a static body's its default world pose.
pub(crate) fn parts_of(model: &Model, layout: &Layout, coms: &[DVec3]) -> Vec<Part> {
    model
        .bodies
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let own_com = super::v3(b.com);
            match (layout.host[i], layout.world_of[i]) {
                (Some(h), Some(w)) => {
                    let c = coms[w];
                    let alone = h == i && !layout.merged[w];
                    let (t, r) = if h == i {
                        (DVec3::ZERO, DQuat::IDENTITY)
                    } else {
                        relative_frame(model, h, i)
                    };
                    Part {
                        body: Some(w),
                        frame: Pose { x: t - c, q: r },
                        com: t + r * own_com - c,
                        alone,
                    }
                }
                _ => {
                    let frame = Pose {
                        x: super::v3(b.pos),
                        q: super::quat(b.quat),
                    };
                    Part {
                        body: None,
                        frame,
                        com: frame.point(own_com),
                        alone: false,
                    }
                }
            }
        })
        .collect()
}
