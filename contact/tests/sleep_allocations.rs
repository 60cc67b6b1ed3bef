//! Heap allocations of soft steps with sleeping on, counted by a global allocator: a
//! 1000-body pile (the grid broad phase, islands, rest timers) and a stack that falls
//! asleep and is woken by a dropped box (the wake list, the second contact pass)
//! allocate nothing once the buffers have grown to the scene.
//!
//! The counter is per thread: the harness runs tests (and its own bookkeeping) on
//! other threads.

use constraint_contact::rigid::{ContactSolver, ContactWorld, SleepSettings};
use constraint_contact::scenes::{box_stack, pile};
use constraint_core::DVec3;

mod counting;
use counting::allocations;

const DT: f64 = 1.0 / 60.0;

fn sleeping(mut w: ContactWorld) -> ContactWorld {
    w.settings.solver = ContactSolver::SoftStep { substeps: 4 };
    w.settings.sleep = SleepSettings {
        enabled: true,
        ..SleepSettings::default()
    };
    w
}

#[test]
fn a_sleeping_pile_steps_without_allocating() {
    let mut w = sleeping(pile(1000, 3).unwrap());
    // The pile is poured and settling: contact counts still change, so let the
    // buffers grow for 5 s first (after 2 s the soft step's colouring buffers still
    // grew 4 times in the next 30 steps as manifolds kept forming).
    for _ in 0..300 {
        w.step(DT).unwrap();
    }
    let before = allocations();
    let mut contacts = 0;
    for _ in 0..30 {
        contacts = w.step(DT).unwrap().contacts;
    }
    let n = allocations() - before;
    // Measured 0 (buffers kept by the world: grid order, islands, wake list).
    assert_eq!(n, 0, "{n} allocations in 30 steps ({contacts} contacts)");
}

#[test]
fn falling_asleep_and_waking_do_not_allocate() {
    let mut w = sleeping(box_stack(4).unwrap());
    // The dropped box exists from the start (far above), so the world's arrays have
    // their final size; it falls onto the stack after the stack has slept.
    constraint_contact::scenes::add_box(
        &mut w,
        DVec3::splat(0.5),
        None,
        DVec3::new(0.0, 0.0, 30.0),
        0.5,
    )
    .unwrap();
    let start = w.bodies().to_vec();
    // Grow the buffers: the stack sleeps, is woken by the box (it lands at about
    // 2.3 s) and sleeps again with it.
    let cycle = |w: &mut ContactWorld| {
        let mut woken_after_sleep = false;
        let mut slept = false;
        for _ in 0..400 {
            w.step(DT).unwrap();
            slept |= w.is_asleep(0);
            woken_after_sleep |= slept && !w.is_asleep(0);
        }
        assert!(woken_after_sleep, "the stack never slept and woke");
        assert!(
            (0..5).all(|i| w.is_asleep(i)),
            "the stack did not sleep again"
        );
    };
    cycle(&mut w);
    // Again from the start (bodies_mut wakes every body), counting.
    w.bodies_mut().copy_from_slice(&start);
    let before = allocations();
    cycle(&mut w);
    let n = allocations() - before;
    // Measured 0.
    assert_eq!(
        n, 0,
        "{n} allocations in 400 steps of sleeping, waking, sleeping"
    );
}
