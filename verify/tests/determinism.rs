//! Same input, same bits: two runs of each scene with each integrator end in
//! bit-identical states (no hash-map order, no uncontrolled parallelism in a step). The
//! pinned state hashes of every catalogue scene are in `state_hashes.rs`; the report's
//! parallel sweeps are checked on 1 and 4 threads in `constraint-report`'s
//! `tests/sweep_threads.rs`.

use constraint_scene::soft::Method;
use constraint_soft::{Cloth, Jelly, SoftSystem};

fn bits(sys: &SoftSystem) -> Vec<u64> {
    sys.x
        .iter()
        .chain(&sys.v)
        .flat_map(|p| p.to_array())
        .map(f64::to_bits)
        .collect()
}

fn run(make: fn() -> SoftSystem, method: Method, h: f64, steps: usize) -> Vec<u64> {
    let mut sys = make();
    let mut integ = method.build(h).expect("valid h");
    for _ in 0..steps {
        integ.step(&mut sys).expect("step");
    }
    bits(&sys)
}

fn cloth() -> SoftSystem {
    Cloth {
        n: 8,
        ..Cloth::default()
    }
    .build()
    .expect("cloth")
}

fn jelly() -> SoftSystem {
    Jelly {
        cells: [2, 2, 2],
        ..Jelly::default()
    }
    .build()
    .expect("jelly")
}

#[test]
fn repeated_runs_are_bit_identical() {
    for (name, make) in [("cloth", cloth as fn() -> SoftSystem), ("jelly", jelly)] {
        for method in Method::ALL {
            let h = if method == Method::Symplectic {
                2e-4
            } else {
                1e-2
            };
            let a = run(make, method, h, 60);
            let b = run(make, method, h, 60);
            assert!(a == b, "{name} / {}: runs differ", method.label());
            let moved = run(make, method, h, 0);
            assert!(
                a != moved,
                "{name} / {}: the state did not change",
                method.label()
            );
        }
    }
}

/// Bits of every body's pose and velocity.
fn contact_bits(w: &constraint_contact::rigid::ContactWorld) -> Vec<u64> {
    w.bodies()
        .iter()
        .flat_map(|b| {
            let p = b.pose;
            [p.x.to_array(), b.v.to_array(), b.omega.to_array()]
                .into_iter()
                .flatten()
                .chain(p.q.to_array())
                .collect::<Vec<_>>()
        })
        .map(f64::to_bits)
        .collect()
}

/// The soft step on several threads (issue 14, feature `parallel`): a pile of 400
/// mixed bodies poured for 1.5 s (90 steps at 60 Hz, 4 sub-steps, with friction
/// anchors so every pass is exercised) ends in the same bits on 1, 2, 3 and 4 threads.
/// Thread count 1 runs the one-thread loop, so this also checks the threaded passes
/// against it. The scene has more than `PARALLEL_MIN_POINTS` points from the first
/// contacts on (measured: 1,354 points at the end), so the threads do run.
#[test]
fn the_threaded_soft_step_gives_the_same_bits_on_any_thread_count() {
    use constraint_contact::rigid::{ContactSolver, PARALLEL_MIN_POINTS};
    let run = |threads: usize| {
        let mut w = constraint_contact::scenes::pile(400, 7).expect("pile");
        w.settings.solver = ContactSolver::SoftStep { substeps: 4 };
        w.settings.soft_step.friction_anchors = true;
        w.settings.soft_step.threads = threads;
        let mut most = 0;
        for _ in 0..90 {
            w.step(1.0 / 60.0).expect("step");
            most = most.max(w.contacts().len());
        }
        (contact_bits(&w), most)
    };
    let (one, most) = run(1);
    assert!(
        most >= PARALLEL_MIN_POINTS,
        "{most} points: the threads never ran"
    );
    for threads in [2, 3, 4] {
        let (bits, _) = run(threads);
        assert!(bits == one, "{threads} threads differ from one");
    }
    let (start, _) = {
        let w = constraint_contact::scenes::pile(400, 7).expect("pile");
        (contact_bits(&w), 0)
    };
    assert!(one != start, "the pile did not move");
}
