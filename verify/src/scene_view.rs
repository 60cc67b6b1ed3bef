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

/// The frames of `traj` for the bodies of `scene` (matched by name), keeping at most
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
