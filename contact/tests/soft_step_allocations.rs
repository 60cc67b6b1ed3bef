//! Heap allocations inside a soft step, counted by a global allocator: once the world
//! has taken a few steps (buffers grown to the scene), further steps of the 10-box
//! stack and of a 21-box pyramid allocate nothing (broad phase, narrow phase, row
//! preparation, sub-steps, warm-start store, rollback copy).
//!
//! The counter is per thread: the harness runs tests (and its own bookkeeping) on
//! other threads.

use constraint_contact::rigid::{ContactSolver, ContactWorld};
use constraint_contact::scenes::{box_stack, pyramid};

mod counting;
use counting::allocations;

/// Allocations of `steps` steps of 1/60 s after `warm_up` steps.
fn allocations_in(mut w: ContactWorld, warm_up: usize, steps: usize) -> usize {
    w.settings.solver = ContactSolver::SoftStep { substeps: 4 };
    for _ in 0..warm_up {
        w.step(1.0 / 60.0).expect("warm-up step");
    }
    let before = allocations();
    for _ in 0..steps {
        w.step(1.0 / 60.0).expect("step");
    }
    allocations() - before
}

#[test]
fn soft_steps_do_not_allocate() {
    // The contact count settles within the first steps (boxes start exactly touching).
    let stack = allocations_in(box_stack(10).expect("stack"), 10, 100);
    assert_eq!(stack, 0, "10-box stack: {stack} allocations in 100 steps");
    let pyr = allocations_in(pyramid(6).expect("pyramid"), 10, 100);
    assert_eq!(pyr, 0, "21-box pyramid: {pyr} allocations in 100 steps");
}

/// With friction anchors the slips ride along with the warm-start impulses, in the
/// same kept buffers: still no allocation per step.
#[test]
fn anchored_soft_steps_do_not_allocate() {
    let mut w = box_stack(10).expect("stack");
    w.settings.soft_step.friction_anchors = true;
    let stack = allocations_in(w, 10, 100);
    assert_eq!(
        stack, 0,
        "10-box stack, anchors: {stack} allocations in 100 steps"
    );
}

/// The counter sees allocations (the test above could not pass by counting nothing):
/// a world's first soft step grows its buffers.
#[test]
fn the_counter_counts() {
    let before = allocations();
    let v: Vec<u64> = Vec::with_capacity(16);
    drop(v);
    assert_eq!(allocations() - before, 1);
    let mut w = box_stack(3).expect("stack");
    w.settings.solver = ContactSolver::SoftStep { substeps: 4 };
    let before = allocations();
    w.step(1.0 / 60.0).expect("step");
    assert!(allocations() > before);
}
