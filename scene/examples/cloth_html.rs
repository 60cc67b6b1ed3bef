//! `cargo run -p constraint-scene --example cloth_html -- [OUT.html]` — the soft
//! crate's 16 × 16 cloth (springs plus one area constraint per triangle, pinned at its
//! two top corners) falling and swinging for 3 s under linearized implicit Euler
//! (projected Hessian, sparse LDLᵀ, h = 1/240 s), written as a viewer page: the
//! cloth's triangles move with the particles; the pins are drawn as small spheres.

use constraint_scene::soft::Method;
use constraint_scene::viewer::{self, ViewFrame, ViewMesh, ViewPart, ViewScene, ViewShape};
use constraint_soft::{Cloth, HessianMode};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "cloth.html".into());
    let cloth = Cloth::default();
    let mut sys = cloth.build()?;
    let h = 1.0 / 240.0;
    let mut integ = Method::ImplicitLdlt(HessianMode::Projected).build(h)?;
    let n = cloth.n;
    // The cloth's triangles, as Cloth::build meshes them (two per grid square).
    let mut triangles = Vec::with_capacity(2 * (n - 1) * (n - 1));
    for r in 0..n - 1 {
        for c in 0..n - 1 {
            let i = cloth.index(r, c);
            triangles.push([i, i + n, i + 1]);
            triangles.push([i + 1, i + n, i + n + 1]);
        }
    }
    let pins: Vec<ViewPart> = (0..sys.len())
        .filter(|&i| sys.pinned()[i])
        .map(|i| ViewPart {
            shape: ViewShape::Sphere { r: 0.02 },
            pos: sys.x[i].to_array(),
            quat: [1.0, 0.0, 0.0, 0.0],
            rgba: [0.3, 0.3, 0.35, 1.0],
        })
        .collect();
    let scene = ViewScene {
        title: "cloth 16 × 16, implicit Euler".into(),
        statics: pins,
        meshes: vec![ViewMesh {
            name: "cloth".into(),
            vertices: sys.len(),
            triangles,
            rgba: [0.85, 0.35, 0.3, 1.0],
        }],
        ..ViewScene::default()
    };
    let frame = |t: f64, x: &[constraint_core::DVec3]| ViewFrame {
        t,
        poses: Vec::new(),
        mesh_vertices: vec![x.iter().map(|p| p.to_array()).collect()],
    };
    let mut frames = vec![frame(0.0, &sys.x)];
    // 3 s, a frame every 4 steps (60 per second).
    for k in 1..=720 {
        integ.step(&mut sys)?;
        if k % 4 == 0 {
            frames.push(frame(k as f64 * h, &sys.x));
        }
    }
    std::fs::write(&out, viewer::page(&scene, &frames)?)?;
    eprintln!("cloth_html: wrote {} frames to {out}", frames.len());
    Ok(())
}
