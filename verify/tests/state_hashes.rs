//! Determinism hashes (issue 7): the full state of every MJCF catalogue scene after 300
//! steps, hashed (FNV-1a over the bits of every body's position, orientation, velocity
//! and angular velocity), for each of this library's main methods.
//!
//! Two properties are checked: (1) two runs in one process give the same hash (same
//! input, same bits); (2) the hash equals the pinned value below — a regression
//! detector, not a correctness claim: any change to the numerics of a step changes it,
//! and such a change must update the pins deliberately (run with
//! `PRINT_STATE_HASHES=1 cargo test -p constraint-verify --test state_hashes -- --nocapture`
//! to print the current values). Float results are identical across optimisation levels
//! (Rust does not reassociate or contract floating point), so debug and release agree.

use std::path::PathBuf;

use constraint_articulated::{Method, MjcfScene, World};

fn fnv1a(hash: &mut u64, v: f64) {
    for b in v.to_bits().to_le_bytes() {
        *hash ^= u64::from(b);
        *hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
}

fn state_hash(w: &World) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in w.bodies() {
        for v in b
            .pose
            .x
            .to_array()
            .into_iter()
            .chain([b.pose.q.w, b.pose.q.x, b.pose.q.y, b.pose.q.z])
        {
            fnv1a(&mut h, v);
        }
        for v in b.v.to_array().into_iter().chain(b.omega.to_array()) {
            fnv1a(&mut h, v);
        }
    }
    h
}

fn run(scene: &str, method: Method) -> u64 {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{scene}.xml"));
    let mut s = MjcfScene::from_file(&path, Some("start")).unwrap();
    for _ in 0..300 {
        s.world.step(1e-3, method).unwrap();
    }
    state_hash(&s.world)
}

const SCENES: [&str; 7] = [
    "pendulum",
    "double_pendulum",
    "spherical_pendulum",
    "four_bar",
    "chain20",
    "chain20_heavy",
    "chain100",
];

fn methods() -> [(&'static str, Method); 2] {
    [
        ("rattle", Method::default()),
        ("velocity", Method::Velocity { beta: 1.0 }),
    ]
}

/// Pinned hashes, `[scene][method]` in the order of `SCENES` and `methods()`.
const PINNED: [[u64; 2]; 7] = [
    [0x45d4b6b34bfb5ffb, 0x1063c5f0ffabd37a],
    [0x16ccd778ec5a67af, 0xc4de9a31505c9dc0],
    [0xf81188bee4fdc302, 0x511b093c05250755],
    [0xa7063baa0dce0861, 0x2c4d83825591c5e4],
    [0x2cc6d5e17e9c9c4f, 0x1e6277fe302666f4],
    [0x4f516b40064a4f26, 0xf847b2398fe63d52],
    [0xe4e98ecde273f20b, 0x77d7f4b09dd091ad],
];

#[test]
fn catalogue_state_hashes_are_deterministic_and_pinned() {
    let print = std::env::var("PRINT_STATE_HASHES").is_ok();
    let mut mismatches = Vec::new();
    for (i, scene) in SCENES.iter().enumerate() {
        for (k, (name, m)) in methods().into_iter().enumerate() {
            let a = run(scene, m);
            let b = run(scene, m);
            assert_eq!(a, b, "{scene} {name}: two runs differ");
            if print {
                println!("{scene} {name}: {a:#018x}");
            }
            if a != PINNED[i][k] {
                mismatches.push(format!(
                    "{scene} {name}: {a:#018x} (pinned {:#018x})",
                    PINNED[i][k]
                ));
            }
        }
    }
    assert!(
        mismatches.is_empty(),
        "state hashes changed:\n{}",
        mismatches.join("\n")
    );
}

/// The MJCF contact scenes (contact world, default solver), 300 steps at the files'
/// steps: same hash twice, and pinned.
#[test]
fn contact_scene_hashes_are_deterministic_and_pinned() {
    use constraint_contact::mjcf::MjcfContactScene;
    let run = |scene: &str, key: Option<&str>| {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{scene}.xml"));
        let mut s = MjcfContactScene::from_file(&path, key).unwrap();
        for _ in 0..300 {
            s.world.step(s.timestep).unwrap();
        }
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for b in s.world.bodies() {
            for v in b
                .pose
                .x
                .to_array()
                .into_iter()
                .chain([b.pose.q.w, b.pose.q.x, b.pose.q.y, b.pose.q.z])
            {
                fnv1a(&mut h, v);
            }
            for v in b.v.to_array().into_iter().chain(b.omega.to_array()) {
                fnv1a(&mut h, v);
            }
        }
        h
    };
    let print = std::env::var("PRINT_STATE_HASHES").is_ok();
    let mut mismatches = Vec::new();
    for (scene, key, pinned) in [
        ("sphere_drop", Some("start"), 0x4b4d2923e0e4b796u64),
        ("sliding_box", Some("start"), 0x1acfdf02e8bbc796),
        ("box_stack", None, 0x2907a46c5aee425b),
    ] {
        let (a, b) = (run(scene, key), run(scene, key));
        assert_eq!(a, b, "{scene}: two runs differ");
        if print {
            println!("{scene}: {a:#018x}");
        }
        if a != pinned {
            mismatches.push(format!("{scene}: {a:#018x} (pinned {pinned:#018x})"));
        }
    }
    assert!(
        mismatches.is_empty(),
        "state hashes changed:\n{}",
        mismatches.join("\n")
    );
}
