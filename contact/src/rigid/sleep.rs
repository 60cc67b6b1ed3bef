//! Islands and sleeping (Box2D: Catto, "Islands", 2023; `b2_timeToSleep` 0.5 s).
//!
//! After each step the moving bodies are joined into islands by union-find over the
//! step's contact pairs (static colliders join nothing; unions in contact order and
//! the root the smaller body index, so the islands do not depend on anything but the
//! contacts). A body whose fastest point moves slower than [`SleepSettings::velocity`]
//! (Box2D v3's test `max(|v|, r |ω|)`, `r` the distance from the body's centre to the
//! farthest point of its colliders) accumulates rest time; an island whose
//! every body has rested [`SleepSettings::time`] goes to sleep: velocities set to zero,
//! and from then on its bodies are in no contact pair with each other or with static
//! colliders (the broad phase pairs them as static, [`generate_contacts_awake`]), take
//! no part in the solve, and keep their state bit for bit (a step restores an asleep
//! body from the step's start). A contact between an awake body and an asleep one wakes
//! the asleep body's whole island before the solve (the contacts are then generated
//! again with the island awake), as Box2D wakes a solver set when a contact begins.

use alloc::vec::Vec;

use constraint_core::Pose;

use super::{ContactError, ContactWorld};
use crate::geometry::{generate_contacts_awake, BroadScratch, BroadStats, Contact};

/// When bodies go to sleep ([`super::ContactSettings::sleep`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SleepSettings {
    /// Whether islands at rest go to sleep.
    pub enabled: bool,
    /// Speed (m/s) below which a body counts as resting: its centre's speed and its
    /// farthest point's speed of rotation `r |ω|` both below it.
    pub velocity: f64,
    /// Rest time (s) after which an island whose bodies all rest goes to sleep.
    pub time: f64,
}

impl Default for SleepSettings {
    /// Off, with Box2D v3's figures for when it is turned on: 0.05 m/s
    /// (`sleepThreshold`, also rapier's `normalized_linear_threshold`) and 0.5 s
    /// (`b2_timeToSleep`, rapier's `time_until_sleep`). Off by default: the contact world is this library's accurate
    /// reference (its stacks are measured for drift over 10 s, and its trajectories are
    /// pinned); a game-style user turns it on.
    fn default() -> Self {
        Self {
            enabled: false,
            velocity: 0.05,
            time: 0.5,
        }
    }
}

impl SleepSettings {
    /// Rejects thresholds that are negative or not finite.
    pub(super) fn check(&self) -> Result<(), ContactError> {
        let ok = |v: f64| v >= 0.0 && v.is_finite();
        if !(ok(self.velocity) && ok(self.time)) {
            return Err(ContactError::InvalidParameter {
                name: "sleep",
                rule: "velocity and time must be finite and non-negative",
            });
        }
        Ok(())
    }
}

/// Per-body sleep state, kept by the world (grown with the bodies, reused).
#[derive(Clone, Debug, Default)]
pub(super) struct SleepState {
    /// Whether body `i` is asleep.
    pub(super) asleep: Vec<bool>,
    /// Rest time of body `i` (s).
    rest: Vec<f64>,
    /// Island of an asleep body (its root's index when it fell asleep).
    island: Vec<usize>,
    /// Distance from body `i`'s centre to the farthest point of its colliders (m).
    reach: Vec<f64>,
    /// Colliders counted in `reach` (recomputed when colliders are added).
    reach_colliders: usize,
    /// Union-find parents (scratch).
    parent: Vec<usize>,
    /// Smallest rest time per root (scratch).
    island_rest: Vec<f64>,
    /// Islands to wake (scratch, sorted).
    wake: Vec<usize>,
}

/// Root of `i` with path halving.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

impl SleepState {
    /// Grows the per-body arrays to `n` bodies (new bodies awake, no rest).
    pub(super) fn grow(&mut self, n: usize) {
        self.asleep.resize(n, false);
        self.rest.resize(n, 0.0);
        self.island.resize(n, usize::MAX);
    }

    /// Wakes every body.
    pub(super) fn wake_all(&mut self) {
        self.asleep.iter_mut().for_each(|a| *a = false);
        self.rest.iter_mut().for_each(|r| *r = 0.0);
    }

    /// Wakes every asleep body whose island is in `islands` (sorted).
    fn wake_islands(&mut self, islands: &[usize]) {
        for i in 0..self.asleep.len() {
            if self.asleep[i] && islands.binary_search(&self.island[i]).is_ok() {
                self.asleep[i] = false;
                self.rest[i] = 0.0;
            }
        }
    }

    /// Number of asleep bodies.
    pub(super) fn count(&self) -> usize {
        self.asleep.iter().filter(|&&a| a).count()
    }
}

impl ContactWorld {
    /// Whether body `i` is asleep (false for an unknown index).
    pub fn is_asleep(&self, i: usize) -> bool {
        self.sleep.asleep.get(i).copied().unwrap_or(false)
    }

    /// Wakes the island of body `i` (nothing for an unknown or awake body).
    pub fn wake(&mut self, i: usize) {
        if self.is_asleep(i) {
            let island = self.sleep.island[i];
            self.sleep.wake_islands(&[island]);
        }
    }

    /// The step's contacts, asleep bodies left out of pairs among themselves and with
    /// static colliders: [`generate_contacts_awake`], then, if an awake body touches an
    /// asleep one, its island is woken and the contacts are generated again.
    pub(super) fn awake_contacts(
        &mut self,
        poses: &[Pose],
        broad: &mut BroadScratch,
        out: &mut Vec<Contact>,
    ) -> Result<BroadStats, ContactError> {
        self.sleep.grow(self.bodies.len());
        let margin = self.settings.margin;
        let run = |asleep: &[bool], broad: &mut BroadScratch, out: &mut Vec<Contact>| {
            generate_contacts_awake(
                &self.colliders,
                poses,
                margin,
                |_, _| true,
                asleep,
                broad,
                out,
            )
            .map_err(ContactError::Geometry)
        };
        let stats = run(&self.sleep.asleep, broad, out)?;
        // No body asleep (sleeping off, or nothing at rest yet): nothing to wake, and
        // the walk over every contact below is skipped (44 k instructions of the
        // 210-box pyramid's step, callgrind).
        if !self.sleep.asleep.contains(&true) {
            return Ok(stats);
        }
        let mut wake = core::mem::take(&mut self.sleep.wake);
        wake.clear();
        for c in out.iter() {
            let (a, b) = (self.colliders[c.a].body, self.colliders[c.b].body);
            for (x, y) in [(a, b), (b, a)] {
                if let (Some(x), Some(y)) = (x, y) {
                    if self.sleep.asleep[x] && !self.sleep.asleep[y] {
                        wake.push(self.sleep.island[x]);
                    }
                }
            }
        }
        if wake.is_empty() {
            self.sleep.wake = wake;
            return Ok(stats);
        }
        wake.sort_unstable();
        wake.dedup();
        self.sleep.wake_islands(&wake);
        self.sleep.wake = wake;
        run(&self.sleep.asleep, broad, out)
    }

    /// After a successful step: asleep bodies get their state from the start of the
    /// step back (`saved`), then rest times and islands are updated and islands at rest
    /// go to sleep. Nothing happens with sleeping off (every body stays awake).
    pub(super) fn update_sleep(&mut self, h: f64, saved: &[super::SavedState]) {
        let s = self.settings.sleep;
        let n = self.bodies.len();
        self.sleep.grow(n);
        if !s.enabled {
            if self.sleep.asleep.iter().any(|&a| a) {
                self.sleep.wake_all();
            }
            return;
        }
        if self.sleep.reach_colliders != self.colliders.len() || self.sleep.reach.len() != n {
            self.sleep.reach.clear();
            self.sleep.reach.resize(n, 0.0);
            for c in &self.colliders {
                if let Some(b) = c.body {
                    let r = c.local.x.length() + c.shape.bounding_radius();
                    if r.is_finite() {
                        self.sleep.reach[b] = self.sleep.reach[b].max(r);
                    }
                }
            }
            self.sleep.reach_colliders = self.colliders.len();
        }
        let st = &mut self.sleep;
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if st.asleep[i] {
                if let Some(b0) = saved.get(i) {
                    b0.restore(b);
                }
                continue;
            }
            // Box2D v3 (`b2FinalizeBodiesTask`): max(|v|, r |ω|) below the threshold.
            let resting = b.v.length().max(st.reach[i] * b.omega.length()) < s.velocity;
            st.rest[i] = if resting { st.rest[i] + h } else { 0.0 };
        }
        // Islands of the awake bodies over the step's contacts.
        st.parent.clear();
        st.parent.extend(0..n);
        for c in &self.contacts {
            let (Some(a), Some(b)) = (self.colliders[c.a].body, self.colliders[c.b].body) else {
                continue;
            };
            if st.asleep[a] || st.asleep[b] {
                continue;
            }
            let (ra, rb) = (find(&mut st.parent, a), find(&mut st.parent, b));
            if ra != rb {
                let (lo, hi) = (ra.min(rb), ra.max(rb));
                st.parent[hi] = lo;
            }
        }
        st.island_rest.clear();
        st.island_rest.resize(n, f64::INFINITY);
        for i in 0..n {
            if !st.asleep[i] {
                let r = find(&mut st.parent, i);
                st.island_rest[r] = st.island_rest[r].min(st.rest[i]);
            }
        }
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if st.asleep[i] {
                continue;
            }
            let r = find(&mut st.parent, i);
            if st.island_rest[r] >= s.time {
                st.asleep[i] = true;
                st.island[i] = r;
                b.v = constraint_core::DVec3::ZERO;
                b.omega = constraint_core::DVec3::ZERO;
            }
        }
    }
}
