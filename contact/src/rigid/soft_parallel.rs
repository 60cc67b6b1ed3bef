//! The soft step's sub-steps on several threads (feature `parallel`;
//! [`super::SoftStepSettings::threads`], from [`super::PARALLEL_MIN_POINTS`] points).
//!
//! The colouring gives the parallelism: the points of one colour touch disjoint moving
//! bodies, so their Gauss–Seidel updates commute and may run at once (Box2D v3's
//! solver stages over graph colours; Catto, "Solver2D", 2024). Each pass over the
//! points runs group by group — one place of one colour: the first points of the
//! colour's manifolds, then their second points, … (two points of one manifold share
//! both bodies) — each group cut into one contiguous chunk per thread, and all threads
//! meet at a barrier before the next group. The per-body
//! stages (gravity, positions) are cut the same way over the bodies, and the points'
//! gaps at the new positions over the points. The overflow
//! colour, whose manifolds may share bodies, is solved in order by one thread. With
//! block normal solves ([`super::SoftStepSettings::block_normal`]) the biased pass
//! runs colour by colour over whole manifolds instead ([`solve_manifold`], the
//! one-thread pass's order), each colour's manifolds cut into one chunk per thread.
//!
//! **Same bits on any thread count.** Every point and body is updated by exactly the
//! arithmetic of the one-thread passes (the same [`solve_point`], [`solve_manifold`], [`apply_point`],
//! [`integrate_velocity`], [`integrate_position`]) on the same values: inside a group
//! no point reads what another writes, and between groups the barrier orders them, in
//! the one-thread order. So
//! the result does not depend on the thread count or on which thread takes which chunk
//! (`verify/tests/determinism.rs` checks 1, 2, 3 and 4 threads bit for bit).
//!
//! **No `unsafe`.** What the threads write (body velocities and displacements, the
//! points' impulses) lives during the sub-steps in arrays of `AtomicU64` holding the
//! `f64` bits, loaded and stored with relaxed ordering (plain moves on x86-64 and
//! AArch64); the barrier's acquire/release orders one stage's stores before the next
//! stage's loads. They are copied in before the sub-steps and out after them (a few
//! words per body and point, into kept buffers: no allocation once grown). The threads
//! are scoped to one step (`std::thread::scope`: nothing runs between steps).

use alloc::vec::Vec;
use core::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use constraint_core::{DMat3, DQuat, DVec3};

use super::soft_step::{
    apply_point, gap_of, integrate_position, integrate_velocity, solve_manifold, solve_point,
    Bodies, Pass, PointImpulses, SoftState,
};

/// A barrier the threads spin on (then yield): a colour's pass takes microseconds, too
/// short to sleep and wake.
struct SpinBarrier {
    arrived: AtomicUsize,
    generation: AtomicUsize,
    threads: usize,
}

impl SpinBarrier {
    fn new(threads: usize) -> Self {
        Self {
            arrived: AtomicUsize::new(0),
            generation: AtomicUsize::new(0),
            threads,
        }
    }

    /// Returns once every thread has called it (stores before it are seen by loads
    /// after it, on every thread).
    fn wait(&self) {
        let generation = self.generation.load(Ordering::Acquire);
        if self.arrived.fetch_add(1, Ordering::AcqRel) + 1 == self.threads {
            self.arrived.store(0, Ordering::Relaxed);
            self.generation.fetch_add(1, Ordering::Release);
            return;
        }
        let mut spins = 0u32;
        while self.generation.load(Ordering::Acquire) == generation {
            if spins < 256 {
                core::hint::spin_loop();
                spins += 1;
            } else {
                std::thread::yield_now();
            }
        }
    }
}

/// `f64`s shared between the threads, as bits in relaxed atomics.
#[derive(Debug, Default)]
pub(super) struct Shared(Vec<AtomicU64>);

impl Shared {
    /// Makes it `n` values long (keeps its buffer).
    fn fill_from(&mut self, values: impl Iterator<Item = f64>) {
        let mut k = 0;
        for x in values {
            if k < self.0.len() {
                self.0[k].store(x.to_bits(), Ordering::Relaxed);
            } else {
                self.0.push(AtomicU64::new(x.to_bits()));
            }
            k += 1;
        }
        self.0.truncate(k);
    }

    #[inline(always)]
    fn get(&self, k: usize) -> f64 {
        f64::from_bits(self.0[k].load(Ordering::Relaxed))
    }

    #[inline(always)]
    fn set(&self, k: usize, x: f64) {
        self.0[k].store(x.to_bits(), Ordering::Relaxed);
    }

    #[inline(always)]
    fn vec3(&self, i: usize) -> DVec3 {
        DVec3::new(self.get(3 * i), self.get(3 * i + 1), self.get(3 * i + 2))
    }

    #[inline(always)]
    fn set_vec3(&self, i: usize, v: DVec3) {
        self.set(3 * i, v.x);
        self.set(3 * i + 1, v.y);
        self.set(3 * i + 2, v.z);
    }
}

/// The buffers of the threaded sub-steps, kept in [`SoftState`] between steps.
#[derive(Debug, Default)]
pub(super) struct ParallelState {
    /// Per body slot: `v` (3), `ω` (3), `Δx` (3), `Δq` (4: x, y, z, w), `Δq` as a
    /// column-major matrix (9).
    v: Shared,
    w: Shared,
    dp: Shared,
    dq: Shared,
    rot: Shared,
    /// Per point: impulses (3), largest normal impulse, impulse totals (3), gap.
    impulse: Shared,
    max_normal: Shared,
    total: Shared,
    gap: Shared,
}

impl Clone for ParallelState {
    /// Buffers only: a clone starts empty (they are filled at each step).
    fn clone(&self) -> Self {
        Self::default()
    }
}

/// [`Bodies`] over the shared buffers.
struct SharedBodies<'a>(&'a ParallelState);

impl Bodies for SharedBodies<'_> {
    #[inline(always)]
    fn velocity(&self, i: usize) -> (DVec3, DVec3) {
        (self.0.v.vec3(i), self.0.w.vec3(i))
    }
    #[inline(always)]
    fn set_velocity(&mut self, i: usize, v: DVec3, w: DVec3) {
        self.0.v.set_vec3(i, v);
        self.0.w.set_vec3(i, w);
    }
    #[inline(always)]
    fn displacement(&self, i: usize) -> (DVec3, DMat3) {
        let r = &self.0.rot;
        let col = |c: usize| {
            DVec3::new(
                r.get(9 * i + 3 * c),
                r.get(9 * i + 3 * c + 1),
                r.get(9 * i + 3 * c + 2),
            )
        };
        (self.0.dp.vec3(i), DMat3::from_cols(col(0), col(1), col(2)))
    }
}

/// [`PointImpulses`] over the shared buffers.
struct SharedImpulses<'a>(&'a ParallelState);

impl PointImpulses for SharedImpulses<'_> {
    #[inline(always)]
    fn get(&self, p: usize) -> ([f64; 3], f64) {
        (self.0.impulse.vec3(p).to_array(), self.0.max_normal.get(p))
    }
    #[inline(always)]
    fn set(&mut self, p: usize, z: [f64; 3], max_normal: f64) {
        self.0.impulse.set_vec3(p, DVec3::from_array(z));
        self.0.max_normal.set(p, max_normal);
    }
    #[inline(always)]
    fn gap(&self, p: usize) -> f64 {
        self.0.gap.get(p)
    }
}

/// The `t`-th of `threads` contiguous chunks of `lo..hi`.
fn chunk(lo: usize, hi: usize, t: usize, threads: usize) -> core::ops::Range<usize> {
    let n = hi - lo;
    lo + n * t / threads..lo + n * (t + 1) / threads
}

/// What the sub-step loop needs besides the state.
#[derive(Clone, Copy)]
pub(super) struct Plan {
    pub(super) substeps: usize,
    pub(super) hs: f64,
    pub(super) gravity: DVec3,
    pub(super) biased: Pass,
    pub(super) relax: Pass,
    /// Relax passes per sub-step.
    pub(super) relax_passes: usize,
}

/// The point groups of a step (the colouring's `ranges`) and the threads' barrier.
struct Colours<'a> {
    ranges: &'a [usize],
    /// The first group to run in order on thread 0 (the overflow colour).
    serial_from: usize,
    threads: usize,
    barrier: SpinBarrier,
}

impl Colours<'_> {
    /// Thread `t`'s share of one pass over the points: group by group (one place of
    /// one colour: no two of its points share a moving body), its chunk of each group,
    /// each group followed by the barrier; the overflow colour's groups all on thread
    /// 0, in order, then one barrier.
    #[inline(always)]
    fn each_point(&self, t: usize, mut f: impl FnMut(usize)) {
        let groups = self.ranges.len().saturating_sub(1);
        let parallel = self.serial_from.min(groups);
        for g in 0..parallel {
            for p in chunk(self.ranges[g], self.ranges[g + 1], t, self.threads) {
                f(p);
            }
            self.barrier.wait();
        }
        if parallel < groups {
            if t == 0 {
                for p in self.ranges[parallel]..self.ranges[groups] {
                    f(p);
                }
            }
            self.barrier.wait();
        }
    }
}

/// Thread `t`'s share of one pass over the manifolds (block normal solves): colour by
/// colour, its chunk of each colour's manifolds, each colour followed by the barrier;
/// the overflow colour (the last if `serial`) all on thread 0, in order.
#[inline(always)]
fn each_manifold(
    colour_start: &[usize],
    serial: bool,
    t: usize,
    threads: usize,
    barrier: &SpinBarrier,
    mut f: impl FnMut(usize),
) {
    let colours = colour_start.len().saturating_sub(1);
    for c in 0..colours {
        let (lo, hi) = (colour_start[c], colour_start[c + 1]);
        if serial && c + 1 == colours {
            if t == 0 {
                (lo..hi).for_each(&mut f);
            }
        } else {
            chunk(lo, hi, t, threads).for_each(&mut f);
        }
        barrier.wait();
    }
}

/// Runs the sub-steps of [`super::ContactWorld::soft_step`] on `threads` threads: per
/// sub-step gravity, warm start, the biased pass, positions, the relax pass and the
/// impulse totals, as the one-thread loop does, with the same bits.
pub(super) fn run(st: &mut SoftState, threads: usize, plan: Plan) {
    let mut par = core::mem::take(&mut st.parallel);
    copy_in(&mut par, st);
    let slots = st.v.len();
    let points = st.slots.len();
    let colours = Colours {
        ranges: &st.colouring.ranges,
        serial_from: st.colouring.serial_from,
        threads,
        barrier: SpinBarrier::new(threads),
    };
    let rows = st.rows();
    let inv_mass = &st.inv_mass;
    let blocks = &st.blocks;
    let cl = &st.colouring;
    // The overflow colour is in use when some group is serial.
    let serial = cl.serial_from + 1 < cl.ranges.len();
    let par_ref = &par;
    let worker = |t: usize| {
        let shared = par_ref;
        let moving = slots - 1;
        let pass = |pass: Pass| {
            colours.each_point(t, |p| {
                let mut z = [
                    shared.impulse.get(3 * p),
                    shared.impulse.get(3 * p + 1),
                    shared.impulse.get(3 * p + 2),
                ];
                let mut m = shared.max_normal.get(p);
                let gap = shared.gap.get(p);
                solve_point(
                    &rows,
                    p,
                    gap,
                    &mut z,
                    &mut m,
                    &mut SharedBodies(shared),
                    pass,
                );
                shared.impulse.set_vec3(p, DVec3::from_array(z));
                shared.max_normal.set(p, m);
            });
        };
        for _ in 0..plan.substeps {
            for i in chunk(0, moving, t, threads) {
                let mut v = shared.v.vec3(i);
                integrate_velocity(&mut v, inv_mass[i], plan.gravity, plan.hs);
                shared.v.set_vec3(i, v);
            }
            colours.barrier.wait();
            colours.each_point(t, |p| {
                let z = shared.impulse.vec3(p).to_array();
                apply_point(&rows, p, z, &mut SharedBodies(shared));
            });
            if blocks.is_empty() {
                pass(plan.biased);
            } else {
                each_manifold(
                    &cl.colour_start,
                    serial,
                    t,
                    threads,
                    &colours.barrier,
                    |j| {
                        let pts =
                            &cl.manifold_points[cl.manifold_start[j]..cl.manifold_start[j + 1]];
                        let mut io = SharedImpulses(shared);
                        solve_manifold(
                            &rows,
                            &blocks[j],
                            pts,
                            &mut io,
                            &mut SharedBodies(shared),
                            plan.biased,
                        );
                    },
                );
            }
            for i in chunk(0, moving, t, threads) {
                let (mut dp, rot) = SharedBodies(shared).displacement(i);
                let mut rot = rot;
                let q = &shared.dq;
                let mut dq = DQuat::from_xyzw(
                    q.get(4 * i),
                    q.get(4 * i + 1),
                    q.get(4 * i + 2),
                    q.get(4 * i + 3),
                );
                let (v, w) = SharedBodies(shared).velocity(i);
                integrate_position(&mut dp, &mut dq, &mut rot, (v, w, inv_mass[i]), plan.hs);
                shared.dp.set_vec3(i, dp);
                for (k, x) in dq.to_array().into_iter().enumerate() {
                    q.set(4 * i + k, x);
                }
                for (k, x) in rot.to_cols_array().into_iter().enumerate() {
                    shared.rot.set(9 * i + k, x);
                }
            }
            colours.barrier.wait();
            // The gaps at the new positions (each point its own: no conflicts).
            for p in chunk(0, points, t, threads) {
                shared.gap.set(p, gap_of(&rows, p, &SharedBodies(shared)));
            }
            colours.barrier.wait();
            for _ in 0..plan.relax_passes {
                pass(plan.relax);
            }
            for p in chunk(0, points, t, threads) {
                let (tot, z) = (shared.total.vec3(p), shared.impulse.vec3(p));
                shared.total.set_vec3(p, tot + z);
            }
            // No barrier: the next stage (gravity) touches only `v`, which this one
            // does not, and the next writer of the impulses comes after a barrier.
        }
    };
    std::thread::scope(|s| {
        for t in 1..threads {
            let worker = &worker;
            s.spawn(move || worker(t));
        }
        worker(0);
    });
    copy_out(&par, st);
    st.parallel = par;
}

/// The state's bodies and points into the shared buffers.
fn copy_in(par: &mut ParallelState, st: &SoftState) {
    par.v.fill_from(st.v.iter().flat_map(|x| x.to_array()));
    par.w.fill_from(st.w.iter().flat_map(|x| x.to_array()));
    par.dp.fill_from(st.dp.iter().flat_map(|x| x.to_array()));
    par.dq.fill_from(st.dq.iter().flat_map(|x| x.to_array()));
    par.rot
        .fill_from(st.rot.iter().flat_map(|x| x.to_cols_array()));
    par.impulse.fill_from(st.impulse.iter().flatten().copied());
    par.max_normal.fill_from(st.max_normal.iter().copied());
    par.total.fill_from(st.total.iter().flatten().copied());
    par.gap.fill_from(st.gap.iter().copied());
}

/// The shared buffers back into the state.
fn copy_out(par: &ParallelState, st: &mut SoftState) {
    for i in 0..st.v.len() {
        st.v[i] = par.v.vec3(i);
        st.w[i] = par.w.vec3(i);
        st.dp[i] = par.dp.vec3(i);
        let q = &par.dq;
        st.dq[i] = DQuat::from_xyzw(
            q.get(4 * i),
            q.get(4 * i + 1),
            q.get(4 * i + 2),
            q.get(4 * i + 3),
        );
        let mut m = [0.0; 9];
        for (k, x) in m.iter_mut().enumerate() {
            *x = par.rot.get(9 * i + k);
        }
        st.rot[i] = DMat3::from_cols_array(&m);
    }
    for p in 0..st.impulse.len() {
        st.impulse[p] = par.impulse.vec3(p).to_array();
        st.max_normal[p] = par.max_normal.get(p);
        st.total[p] = par.total.vec3(p).to_array();
    }
}
