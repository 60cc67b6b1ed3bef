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
