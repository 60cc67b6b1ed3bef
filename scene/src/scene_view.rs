//! An MJCF model and its trajectory as a [`crate::viewer`] page (what
//! `simulate --html` writes).
//!
//! Every geom becomes a shape of its body (world geoms are statics) with its pose in
//! the body frame; the trajectory's `<body>.x,y,z,qw,qx,qy,qz` columns (the body-frame
//! origin and orientation, MuJoCo's `xpos` and `xquat`, DESIGN.md §6) become the frames.
//! Geoms MuJoCo hides by default (`rgba` alpha 0, or `group` above 2) are left out.
//! A geom with MuJoCo's default grey `rgba` on a body takes the body's colour from
//! [`PALETTE`], so that neighbouring links are told apart.

use constraint_mjcf::{Model, Primitive};

use crate::trajectory::Trajectory;
use crate::viewer::{self, ViewBody, ViewFrame, ViewPart, ViewPose, ViewScene, ViewShape};

/// Body colours for geoms left at MuJoCo's default grey, by body index (cycled).
pub const PALETTE: [[f64; 4]; 8] = [
    [0.86, 0.42, 0.24, 1.0],
    [0.25, 0.55, 0.80, 1.0],
    [0.40, 0.70, 0.35, 1.0],
    [0.90, 0.72, 0.25, 1.0],
    [0.60, 0.42, 0.75, 1.0],
    [0.30, 0.70, 0.70, 1.0],
    [0.85, 0.45, 0.60, 1.0],
    [0.55, 0.55, 0.60, 1.0],
];

/// MuJoCo's default geom colour.
const DEFAULT_RGBA: [f64; 4] = [0.5, 0.5, 0.5, 1.0];

/// Frames per second of simulated time kept in a page by [`page`] (a 60 Hz screen).
pub const PAGE_FPS: f64 = 60.0;

fn shape(p: &Primitive) -> ViewShape {
    match *p {
        Primitive::Plane { size } => ViewShape::Plane {
            half: [size[0], size[1]],
            grid: size[2],
        },
        Primitive::Sphere { radius } => ViewShape::Sphere { r: radius },
        Primitive::Capsule {
            radius,
            half_length,
        } => ViewShape::Capsule {
            r: radius,
            half_length,
        },
        Primitive::Cylinder {
            radius,
            half_length,
        } => ViewShape::Cylinder {
            r: radius,
            half_length,
        },
        Primitive::Box { half } => ViewShape::Box { half },
        Primitive::Ellipsoid { radii } => ViewShape::Ellipsoid { radii },
    }
}

/// The shapes of `model`: one [`ViewBody`] per body (document order, the order of the
/// trajectory's columns) and the world geoms as statics.
pub fn scene(model: &Model, title: &str) -> ViewScene {
    let mut out = ViewScene {
        title: title.to_string(),
        bodies: model
            .bodies
            .iter()
            .map(|b| ViewBody {
                name: b.name.clone(),
                parts: Vec::new(),
            })
            .collect(),
        ..ViewScene::default()
    };
    for g in &model.geoms {
        if !(g.rgba[3] > 0.0) || g.group > 2 {
            continue;
        }
        let mut part = ViewPart {
            shape: shape(&g.primitive),
            pos: g.pos,
            quat: g.quat,
            rgba: g.rgba,
        };
        match g.body.and_then(|b| out.bodies.get_mut(b).map(|v| (b, v))) {
            Some((b, body)) => {
                if g.rgba == DEFAULT_RGBA {
                    part.rgba = PALETTE[b % PALETTE.len()];
                }
                body.parts.push(part);
            }
            None => out.statics.push(part),
        }
    }
    out
}

/// The frames of `traj` for the bodies of `scene` (matched by name), keeping about
/// `fps` frames per second of simulated time (see [`viewer::subsample`]). Errors: a
/// body without its seven pose columns, a row shorter or longer than the header.
pub fn frames(
    traj: &Trajectory,
    scene: &ViewScene,
    fps: f64,
) -> Result<Vec<ViewFrame>, viewer::ViewerError> {
    let mut cols = Vec::with_capacity(scene.bodies.len());
    for b in &scene.bodies {
        let at = |c: &str| {
            let name = format!("{}.{c}", b.name);
            traj.header.iter().position(|h| *h == name)
        };
        let idx: Option<Vec<usize>> = ["x", "y", "z", "qw", "qx", "qy", "qz"]
            .iter()
            .map(|c| at(c))
            .collect();
        cols.push(idx.ok_or_else(|| viewer::ViewerError::MissingBody {
            name: b.name.clone(),
        })?);
    }
    if let Some(k) = traj
        .rows
        .iter()
        .position(|r| r.is_empty() || r.len() != traj.header.len())
    {
        return Err(viewer::ViewerError::FrameShape { frame: k });
    }
    let times: Vec<f64> = traj.rows.iter().map(|r| r[0]).collect();
    Ok(viewer::subsample(&times, fps)
        .into_iter()
        .map(|k| {
            let r = &traj.rows[k];
            ViewFrame {
                t: r[0],
                poses: cols
                    .iter()
                    .map(|c| ViewPose {
                        pos: [r[c[0]], r[c[1]], r[c[2]]],
                        quat: [r[c[3]], r[c[4]], r[c[5]], r[c[6]]],
                    })
                    .collect(),
                mesh_vertices: Vec::new(),
            }
        })
        .collect())
}

/// The page of `model` moving along `traj` ([`scene`], [`frames`] at [`PAGE_FPS`]).
pub fn page(model: &Model, traj: &Trajectory, title: &str) -> Result<String, viewer::ViewerError> {
    let s = scene(model, title);
    let f = frames(traj, &s, PAGE_FPS)?;
    viewer::page(&s, &f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::{run, RunOptions};
    use std::path::Path;

    fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
        // v' = v + 2w (u × v) + 2 u × (u × v), u = (x, y, z), q normalised.
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        let (w, u) = (q[0] / n, [q[1] / n, q[2] / n, q[3] / n]);
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let t = cross(u, v).map(|c| 2.0 * c);
        let ut = cross(u, t);
        [0, 1, 2].map(|i| v[i] + w * t[i] + ut[i])
    }

    fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    }

    /// Lowest z of every drawn capsule and sphere of a frame: the body pose applied to
    /// the part pose, as the page does.
    fn lowest(scene: &ViewScene, f: &ViewFrame) -> f64 {
        let mut low = f64::INFINITY;
        for (b, p) in scene.bodies.iter().zip(&f.poses) {
            for part in &b.parts {
                let c = rotate(p.quat, part.pos);
                let centre = [0, 1, 2].map(|i| p.pos[i] + c[i]);
                let axis = rotate(mul(p.quat, part.quat), [0.0, 0.0, 1.0]);
                let z = match part.shape {
                    ViewShape::Sphere { r } => centre[2] - r,
                    ViewShape::Capsule { r, half_length } => {
                        centre[2] - half_length * axis[2].abs() - r
                    }
                    _ => panic!("the ragdoll has capsules and a sphere only"),
                };
                low = low.min(z);
            }
        }
        low
    }

    #[test]
    fn ragdoll_shapes_follow_the_bodies_onto_the_floor() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/ragdoll.xml");
        let model = constraint_mjcf::load_file(&path).unwrap();
        let opts = RunOptions {
            keyframe: Some("start".into()),
            duration: 2.0,
            ..RunOptions::default()
        };
        let (traj, _) = run(&path, &opts).unwrap();
        let scene = scene(&model, "ragdoll");
        // 9 bodies, 10 body geoms (the torso holds the head), the floor a static plane.
        assert_eq!(scene.bodies.len(), 9);
        assert_eq!(
            scene.bodies.iter().map(|b| b.parts.len()).sum::<usize>(),
            10
        );
        assert!(matches!(
            scene.statics.as_slice(),
            [ViewPart {
                shape: ViewShape::Plane { .. },
                ..
            }]
        ));
        let frames = frames(&traj, &scene, PAGE_FPS).unwrap();
        // 2 s at 60 frames per second from 1001 rows: 121 frames, the last at t = 2.
        assert_eq!(frames.len(), 121);
        assert_eq!(frames.last().map(|f| f.t), Some(2.0));
        let (start, end) = (lowest(&scene, &frames[0]), lowest(&scene, &frames[120]));
        // The keyframe holds the torso origin at 1.36 m, tilted 20° about y: the shins'
        // far ends sit 0.3 + 0.42 + 0.32 = 1.04 m below it along the torso axis, so the
        // feet's lowest point is at 1.36 − 1.04 cos 20° − 0.05 = 0.332720 m; measured
        // 0.3327197 m.
        let expect = 1.36 - 1.04 * 20f64.to_radians().cos() - 0.05;
        assert!(
            (start - expect).abs() < 1e-5,
            "lowest point at t = 0: {start}"
        );
        println!("lowest point: {start} m at t = 0, {end} m at t = 2");
        // At rest on the floor after 2 s: the drawn shapes touch z = 0 to within the
        // contact penetration; measured -1.6e-5 m.
        assert!(end.abs() < 1e-3, "lowest point at t = 2: {end}");
        let page = page(&model, &traj, "ragdoll").unwrap();
        assert!(page.contains("\"name\":\"right_shin\""));
    }

    #[test]
    fn a_trajectory_without_a_body_is_a_typed_error() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/pendulum.xml");
        let model = constraint_mjcf::load_file(&path).unwrap();
        let mut traj = Trajectory::for_bodies(&["other".to_string()]);
        traj.rows.push(vec![0.0; traj.header.len()]);
        let name = model.bodies[0].name.clone();
        assert_eq!(
            page(&model, &traj, "p"),
            Err(viewer::ViewerError::MissingBody { name })
        );
        let mut short = Trajectory::for_bodies(&[model.bodies[0].name.clone()]);
        short.rows.push(vec![0.0]);
        assert_eq!(
            page(&model, &short, "p"),
            Err(viewer::ViewerError::FrameShape { frame: 0 })
        );
    }
}
