//! An animated, self-contained HTML viewer of a trajectory (issue 15).
//!
//! Input: a [`ViewScene`] — per body a list of shapes with their pose in the body frame
//! (sphere, capsule, cylinder, box, ellipsoid), static shapes in the world frame
//! (planes included) and triangle meshes (cloth) — and a list of [`ViewFrame`]s, each
//! the time, every body's pose and every mesh's vertex positions. Output: one HTML
//! page with the data inline as JSON and the player inline as JavaScript (no network
//! access at view time). The page draws on a 2D canvas with a perspective camera,
//! Lambert-shaded faces sorted back to front (painter's algorithm), a checkered floor
//! with the bodies' shadows cast straight down on it; it has play/pause, a time
//! slider, a time readout, orbit by mouse drag and zoom by wheel. The URL hash
//! `#t=SECONDS&paused=1` pins the time (`az=`, `el=` in degrees and `zoom=` set the
//! camera), so a test can screenshot a given instant.
//!
//! This module knows nothing of the simulation: it takes plain data. The MJCF and
//! trajectory adapter is [`crate::scene_view`].
//!
//! Output is deterministic: numbers are written with a fixed number of decimals
//! ([`POS_DECIMALS`], [`QUAT_DECIMALS`]), so the same input gives the same bytes.

use std::fmt::Write as _;

/// Decimals written for positions and sizes (m): 10 µm, below a pixel at any sensible
/// zoom.
pub const POS_DECIMALS: usize = 5;
/// Decimals written for quaternion components and colours.
pub const QUAT_DECIMALS: usize = 5;

/// The player: drawing, camera and controls (plain JavaScript, no libraries).
const PLAYER_JS: &str = include_str!("viewer.js");

/// A shape in its own frame (MuJoCo's conventions: capsule and cylinder along z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewShape {
    /// Sphere of radius `r`.
    Sphere {
        /// Radius (m).
        r: f64,
    },
    /// Capsule along z: radius and half-length of the cylindrical part.
    Capsule {
        /// Radius (m).
        r: f64,
        /// Half length of the cylindrical part (m).
        half_length: f64,
    },
    /// Cylinder along z.
    Cylinder {
        /// Radius (m).
        r: f64,
        /// Half height (m).
        half_length: f64,
    },
    /// Box with half-extents along x, y, z.
    Box {
        /// Half sizes (m).
        half: [f64; 3],
    },
    /// Ellipsoid with semi-axes along x, y, z.
    Ellipsoid {
        /// Semi-axes (m).
        radii: [f64; 3],
    },
    /// Plane z = 0 of the part frame, drawn as a checkered square of half-size `half`
    /// (0 or less: sized to the scene) with squares of side `grid` (0 or less: chosen
    /// from the drawn size).
    Plane {
        /// Half size drawn in x and y (m); `≤ 0` for an infinite plane.
        half: [f64; 2],
        /// Checker square side (m); `≤ 0` to let the page choose.
        grid: f64,
    },
}

/// One shape placed in its body's frame (or in the world frame, for statics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewPart {
    /// The shape.
    pub shape: ViewShape,
    /// Position of the shape frame (m).
    pub pos: [f64; 3],
    /// Orientation of the shape frame, `[w, x, y, z]` (normalised by the page).
    pub quat: [f64; 4],
    /// Colour, red, green, blue, alpha in `[0, 1]`.
    pub rgba: [f64; 4],
}

/// A rigid body: a name and its shapes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewBody {
    /// Name (shown on hover-free legends; escaped in the page).
    pub name: String,
    /// Shapes in the body frame.
    pub parts: Vec<ViewPart>,
}

/// A triangle mesh whose vertices move (cloth): the triangles and a colour; the
/// positions come with each [`ViewFrame`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewMesh {
    /// Name.
    pub name: String,
    /// Vertex count (every frame gives this many positions).
    pub vertices: usize,
    /// Triangles as vertex indices.
    pub triangles: Vec<[usize; 3]>,
    /// Colour, red, green, blue, alpha in `[0, 1]`.
    pub rgba: [f64; 4],
}

/// What is drawn: bodies, static shapes, meshes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewScene {
    /// Page title.
    pub title: String,
    /// Moving rigid bodies (their poses come with each frame, same order).
    pub bodies: Vec<ViewBody>,
    /// Shapes fixed in the world frame (floors, walls, fixed obstacles).
    pub statics: Vec<ViewPart>,
    /// Deforming triangle meshes.
    pub meshes: Vec<ViewMesh>,
}

/// A body pose: origin of the body frame and its orientation `[w, x, y, z]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewPose {
    /// Body frame origin in the world (m).
    pub pos: [f64; 3],
    /// Body frame orientation `[w, x, y, z]`.
    pub quat: [f64; 4],
}

/// One sample of the animation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewFrame {
    /// Time (s); strictly increasing over the frames.
    pub t: f64,
    /// One pose per body of [`ViewScene::bodies`].
    pub poses: Vec<ViewPose>,
    /// Per mesh of [`ViewScene::meshes`], its vertex positions (m).
    pub mesh_vertices: Vec<Vec<[f64; 3]>>,
}

/// Why a page could not be written.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewerError {
    /// No frames: nothing to animate.
    NoFrames,
    /// No body has a shape, and there are no static shapes and no meshes.
    NothingToDraw,
    /// A shape has a non-finite or non-positive size, or a non-finite pose or colour.
    BadShape {
        /// The body's name (`"world"` for statics).
        body: String,
        /// Index of the part in its list.
        part: usize,
    },
    /// A mesh triangle refers to a vertex past the mesh's vertex count.
    BadTriangle {
        /// The mesh's name.
        mesh: String,
        /// Index of the triangle.
        triangle: usize,
    },
    /// A frame has the wrong number of poses, meshes or mesh vertices.
    FrameShape {
        /// Index of the frame.
        frame: usize,
    },
    /// A frame holds a non-finite time, position or orientation (or a zero quaternion).
    NonFinite {
        /// Index of the frame.
        frame: usize,
    },
    /// A frame's time is not after the previous one's.
    TimesNotIncreasing {
        /// Index of the frame.
        frame: usize,
    },
    /// The trajectory has no pose columns for a body of the scene.
    MissingBody {
        /// The body's name.
        name: String,
    },
}

impl std::fmt::Display for ViewerError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoFrames => write!(f, "viewer: the trajectory has no samples"),
            Self::NothingToDraw => write!(f, "viewer: the scene has no shape to draw"),
            Self::BadShape { body, part } => write!(
                f,
                "viewer: shape {part} of {body:?} has a non-finite or non-positive size, or a non-finite pose or colour"
            ),
            Self::BadTriangle { mesh, triangle } => write!(
                f,
                "viewer: triangle {triangle} of mesh {mesh:?} refers to a missing vertex"
            ),
            Self::FrameShape { frame } => write!(
                f,
                "viewer: frame {frame} does not match the scene's bodies or meshes"
            ),
            Self::NonFinite { frame } => {
                write!(f, "viewer: frame {frame} holds a non-finite number")
            }
            Self::TimesNotIncreasing { frame } => {
                write!(f, "viewer: frame {frame}'s time is not after the previous one")
            }
            Self::MissingBody { name } => {
                write!(f, "viewer: the trajectory has no pose columns for body {name:?}")
            }
        }
    }
}

impl std::error::Error for ViewerError {}

/// Checks the scene and frames (see [`ViewerError`]) and writes the page.
pub fn page(scene: &ViewScene, frames: &[ViewFrame]) -> Result<String, ViewerError> {
    validate(scene, frames)?;
    let mut json = String::with_capacity(256 + frames.len() * (scene.bodies.len() * 64 + 16));
    write_json(&mut json, scene, frames);
    let title = escape(&scene.title);
    let mut s = String::with_capacity(json.len() + PLAYER_JS.len() + 2048);
    s.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    let _ = writeln!(s, "<title>{title}</title>");
    s.push_str("<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">\n");
    s.push_str(STYLE);
    s.push_str("</head>\n<body>\n");
    s.push_str("<canvas id=\"view\"></canvas>\n");
    let _ = writeln!(s, "<div id=\"title\">{title}</div>");
    s.push_str(
        "<div id=\"bar\"><button id=\"play\" type=\"button\">Pause</button>\
         <input id=\"slider\" type=\"range\" min=\"0\" max=\"1000\" step=\"1\" value=\"0\">\
         <span id=\"clock\"></span></div>\n",
    );
    s.push_str("<div id=\"help\">drag: orbit · wheel: zoom · double-click: reset view · space: play/pause</div>\n");
    s.push_str("<script type=\"application/json\" id=\"scene-data\">");
    s.push_str(&json);
    s.push_str("</script>\n<script>\n");
    s.push_str(PLAYER_JS);
    s.push_str("</script>\n</body>\n</html>\n");
    Ok(s)
}

const STYLE: &str = "<style>\
html,body{margin:0;height:100%;overflow:hidden;background:#e9eef3;font-family:sans-serif}\
#view{display:block;width:100%;height:calc(100% - 40px)}\
#bar{position:absolute;left:0;right:0;bottom:0;height:40px;display:flex;align-items:center;gap:10px;padding:0 10px;background:#2b3440;color:#eee;font-size:14px;box-sizing:border-box}\
#bar button{width:64px}\
#slider{flex:1}\
#clock{font-family:monospace;min-width:150px;text-align:right}\
#title{position:absolute;left:10px;top:8px;color:#2b3440;font-size:15px;font-weight:bold}\
#help{position:absolute;right:10px;top:8px;color:#56606c;font-size:12px}\
</style>\n";

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn check_part(p: &ViewPart, body: &str, part: usize) -> Result<(), ViewerError> {
    let positive = |v: &[f64]| v.iter().all(|&x| x > 0.0 && x.is_finite());
    let size_ok = match p.shape {
        ViewShape::Sphere { r } => positive(&[r]),
        ViewShape::Capsule { r, half_length } => positive(&[r]) && half_length >= 0.0,
        ViewShape::Cylinder { r, half_length } => positive(&[r, half_length]),
        ViewShape::Box { half } => positive(&half),
        ViewShape::Ellipsoid { radii } => positive(&radii),
        ViewShape::Plane { half, grid } => finite(&half) && grid.is_finite(),
    };
    let qn: f64 = p.quat.iter().map(|q| q * q).sum();
    if size_ok && finite(&p.pos) && finite(&p.quat) && qn > 0.0 && finite(&p.rgba) {
        Ok(())
    } else {
        Err(ViewerError::BadShape {
            body: body.to_string(),
            part,
        })
    }
}

fn validate(scene: &ViewScene, frames: &[ViewFrame]) -> Result<(), ViewerError> {
    if frames.is_empty() {
        return Err(ViewerError::NoFrames);
    }
    let shapes = scene.bodies.iter().map(|b| b.parts.len()).sum::<usize>()
        + scene.statics.len()
        + scene
            .meshes
            .iter()
            .map(|m| m.triangles.len())
            .sum::<usize>();
    if shapes == 0 {
        return Err(ViewerError::NothingToDraw);
    }
    for b in &scene.bodies {
        for (i, p) in b.parts.iter().enumerate() {
            check_part(p, &b.name, i)?;
        }
    }
    for (i, p) in scene.statics.iter().enumerate() {
        check_part(p, "world", i)?;
    }
    for m in &scene.meshes {
        for (i, t) in m.triangles.iter().enumerate() {
            if t.iter().any(|&v| v >= m.vertices) {
                return Err(ViewerError::BadTriangle {
                    mesh: m.name.clone(),
                    triangle: i,
                });
            }
        }
    }
    let mut last = f64::NEG_INFINITY;
    for (k, f) in frames.iter().enumerate() {
        let shape_ok = f.poses.len() == scene.bodies.len()
            && f.mesh_vertices.len() == scene.meshes.len()
            && f.mesh_vertices
                .iter()
                .zip(&scene.meshes)
                .all(|(v, m)| v.len() == m.vertices);
        if !shape_ok {
            return Err(ViewerError::FrameShape { frame: k });
        }
        let poses_ok = f.poses.iter().all(|p| {
            finite(&p.pos) && finite(&p.quat) && p.quat.iter().map(|q| q * q).sum::<f64>() > 0.0
        });
        let verts_ok = f.mesh_vertices.iter().flatten().all(|v| finite(v));
        if !f.t.is_finite() || !poses_ok || !verts_ok {
            return Err(ViewerError::NonFinite { frame: k });
        }
        if !(f.t > last) {
            return Err(ViewerError::TimesNotIncreasing { frame: k });
        }
        last = f.t;
    }
    Ok(())
}

/// Writes `v` with `d` decimals, trailing zeros and a negative zero dropped.
fn num(s: &mut String, v: f64, d: usize) {
    let start = s.len();
    let _ = write!(s, "{v:.d$}");
    if s[start..].contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if &s[start..] == "-0" {
        s.truncate(start);
        s.push('0');
    }
}

fn nums(s: &mut String, v: &[f64], d: usize) {
    s.push('[');
    for (i, &x) in v.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        num(s, x, d);
    }
    s.push(']');
}

/// A JSON string literal that is also safe inside a `<script>` element (`<`, `>`, `&`
/// and line separators escaped).
fn string(s: &mut String, v: &str) {
    s.push('"');
    for c in v.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            '<' | '>' | '&' | '\u{2028}' | '\u{2029}' => {
                let _ = write!(s, "\\u{:04x}", c as u32);
            }
            c if (c as u32) < 0x20 => {
                let _ = write!(s, "\\u{:04x}", c as u32);
            }
            c => s.push(c),
        }
    }
    s.push('"');
}

fn part_json(s: &mut String, p: &ViewPart) {
    let (kind, size): (&str, Vec<f64>) = match p.shape {
        ViewShape::Sphere { r } => ("sphere", vec![r]),
        ViewShape::Capsule { r, half_length } => ("capsule", vec![r, half_length]),
        ViewShape::Cylinder { r, half_length } => ("cylinder", vec![r, half_length]),
        ViewShape::Box { half } => ("box", half.to_vec()),
        ViewShape::Ellipsoid { radii } => ("ellipsoid", radii.to_vec()),
        ViewShape::Plane { half, grid } => ("plane", vec![half[0], half[1], grid]),
    };
    let _ = write!(s, "{{\"shape\":\"{kind}\",\"size\":");
    nums(s, &size, POS_DECIMALS);
    s.push_str(",\"pos\":");
    nums(s, &p.pos, POS_DECIMALS);
    s.push_str(",\"quat\":");
    nums(s, &p.quat, QUAT_DECIMALS);
    s.push_str(",\"rgba\":");
    nums(s, &p.rgba, 3);
    s.push('}');
}

fn parts_json(s: &mut String, parts: &[ViewPart]) {
    s.push('[');
    for (i, p) in parts.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        part_json(s, p);
    }
    s.push(']');
}

/// The data block: `{title, bodies:[{name, parts}], statics, meshes:[{name, tris,
/// rgba}], times, poses:[[x,y,z,qw,qx,qy,qz per body] per frame], verts:[[[x,y,z…] per
/// mesh] per frame]}`.
fn write_json(s: &mut String, scene: &ViewScene, frames: &[ViewFrame]) {
    s.push_str("{\"title\":");
    string(s, &scene.title);
    s.push_str(",\n\"bodies\":[");
    for (i, b) in scene.bodies.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        s.push_str("{\"name\":");
        string(s, &b.name);
        s.push_str(",\"parts\":");
        parts_json(s, &b.parts);
        s.push('}');
    }
    s.push_str("],\n\"statics\":");
    parts_json(s, &scene.statics);
    s.push_str(",\n\"meshes\":[");
    for (i, m) in scene.meshes.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        s.push_str("{\"name\":");
        string(s, &m.name);
        s.push_str(",\"rgba\":");
        nums(s, &m.rgba, 3);
        s.push_str(",\"tris\":[");
        for (k, t) in m.triangles.iter().enumerate() {
            if k > 0 {
                s.push(',');
            }
            let _ = write!(s, "{},{},{}", t[0], t[1], t[2]);
        }
        s.push_str("]}");
    }
    s.push_str("],\n\"times\":[");
    for (k, f) in frames.iter().enumerate() {
        if k > 0 {
            s.push(',');
        }
        num(s, f.t, 9);
    }
    s.push_str("],\n\"poses\":[");
    for (k, f) in frames.iter().enumerate() {
        if k > 0 {
            s.push_str(",\n");
        }
        s.push('[');
        for (i, p) in f.poses.iter().enumerate() {
            for (j, &x) in p.pos.iter().enumerate() {
                if i + j > 0 {
                    s.push(',');
                }
                num(s, x, POS_DECIMALS);
            }
            for &q in &p.quat {
                s.push(',');
                num(s, q, QUAT_DECIMALS);
            }
        }
        s.push(']');
    }
    s.push_str("],\n\"verts\":[");
    for (k, f) in frames.iter().enumerate() {
        if k > 0 {
            s.push_str(",\n");
        }
        s.push('[');
        for (m, vs) in f.mesh_vertices.iter().enumerate() {
            if m > 0 {
                s.push(',');
            }
            s.push('[');
            for (j, v) in vs.iter().enumerate() {
                for (d, &x) in v.iter().enumerate() {
                    if j + d > 0 {
                        s.push(',');
                    }
                    num(s, x, POS_DECIMALS);
                }
            }
            s.push(']');
        }
        s.push(']');
    }
    s.push_str("]}");
}

/// The frames to keep so that the page holds about `fps` frames per second of
/// simulated time: for each instant `t₀ + m/fps` of a regular grid, the first frame at
/// or after it (each at most once), and the last frame. `times` must be increasing;
/// `fps ≤ 0` or non-finite keeps all.
pub fn subsample(times: &[f64], fps: f64) -> Vec<usize> {
    let (Some(&t0), Some(last)) = (times.first(), times.len().checked_sub(1)) else {
        return Vec::new();
    };
    if !(fps > 0.0) || !fps.is_finite() {
        return (0..times.len()).collect();
    }
    let gap = 1.0 / fps;
    // A relative slack so that a row at the grid instant up to rounding counts as on it.
    let slack = 1e-9;
    let mut keep: Vec<usize> = Vec::new();
    let mut next = t0;
    for (k, &t) in times.iter().enumerate() {
        if t >= next - slack * gap {
            keep.push(k);
            next = t0 + (((t - t0) / gap + slack).floor() + 1.0) * gap;
        }
    }
    if keep.last() != Some(&last) {
        keep.push(last);
    }
    keep
}

/// Escapes text for HTML element content and attribute values.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            _ => o.push(c),
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere_scene() -> (ViewScene, Vec<ViewFrame>) {
        let scene = ViewScene {
            title: "a <b> & \"c\"".into(),
            bodies: vec![ViewBody {
                name: "ball</script>".into(),
                parts: vec![ViewPart {
                    shape: ViewShape::Sphere { r: 0.1 },
                    pos: [0.0; 3],
                    quat: [1.0, 0.0, 0.0, 0.0],
                    rgba: [0.8, 0.2, 0.2, 1.0],
                }],
            }],
            ..ViewScene::default()
        };
        let frames = (0..3)
            .map(|k| ViewFrame {
                t: k as f64 * 0.1,
                poses: vec![ViewPose {
                    pos: [0.0, 0.0, 1.0 - 0.05 * k as f64],
                    quat: [1.0, 0.0, 0.0, 0.0],
                }],
                mesh_vertices: vec![],
            })
            .collect();
        (scene, frames)
    }

    #[test]
    fn names_cannot_close_the_script() {
        let (scene, frames) = sphere_scene();
        let html = page(&scene, &frames).unwrap();
        // The only `</script>` are the two closing tags the page writes itself.
        assert_eq!(html.matches("</script>").count(), 2);
        assert!(html.contains("ball\\u003c/script\\u003e"));
        assert!(html.contains("<title>a &lt;b&gt; &amp; &quot;c&quot;</title>"));
    }

    #[test]
    fn numbers_are_short_and_fixed() {
        let mut s = String::new();
        for v in [0.0, -0.0, -1e-9, 1.5, 2.0, 0.123456789] {
            num(&mut s, v, 5);
            s.push(' ');
        }
        assert_eq!(s, "0 0 0 1.5 2 0.12346 ");
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (scene, frames) = sphere_scene();
        assert_eq!(page(&scene, &[]), Err(ViewerError::NoFrames));
        let empty = ViewScene {
            bodies: vec![ViewBody::default()],
            ..ViewScene::default()
        };
        let f0 = ViewFrame {
            poses: vec![frames[0].poses[0]],
            ..ViewFrame::default()
        };
        assert_eq!(page(&empty, &[f0]), Err(ViewerError::NothingToDraw));
        let mut bad = scene.clone();
        bad.bodies[0].parts[0].shape = ViewShape::Sphere { r: f64::NAN };
        assert!(matches!(
            page(&bad, &frames),
            Err(ViewerError::BadShape { part: 0, .. })
        ));
        let mut nan = frames.clone();
        nan[1].poses[0].pos[2] = f64::INFINITY;
        assert_eq!(page(&scene, &nan), Err(ViewerError::NonFinite { frame: 1 }));
        let mut back = frames.clone();
        back[2].t = 0.1;
        assert_eq!(
            page(&scene, &back),
            Err(ViewerError::TimesNotIncreasing { frame: 2 })
        );
        let mut short = frames.clone();
        short[0].poses.clear();
        assert_eq!(
            page(&scene, &short),
            Err(ViewerError::FrameShape { frame: 0 })
        );
        let mut mesh = scene.clone();
        mesh.meshes.push(ViewMesh {
            name: "m".into(),
            vertices: 2,
            triangles: vec![[0, 1, 2]],
            rgba: [1.0; 4],
        });
        assert!(matches!(
            page(&mesh, &frames),
            Err(ViewerError::BadTriangle { triangle: 0, .. })
        ));
    }

    #[test]
    fn same_input_same_bytes() {
        let (scene, frames) = sphere_scene();
        let a = page(&scene, &frames).unwrap();
        let b = page(&scene.clone(), &frames.clone()).unwrap();
        assert_eq!(a, b);
        assert!(a.contains("\"times\":[0,0.1,0.2]"), "{a}");
    }

    #[test]
    fn a_mesh_alone_is_drawn_from_its_frames() {
        let scene = ViewScene {
            title: "sheet".into(),
            meshes: vec![ViewMesh {
                name: "sheet".into(),
                vertices: 3,
                triangles: vec![[0, 1, 2]],
                rgba: [0.9, 0.3, 0.3, 1.0],
            }],
            ..ViewScene::default()
        };
        let frame = |t: f64, z: f64| ViewFrame {
            t,
            poses: vec![],
            mesh_vertices: vec![vec![[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]]],
        };
        let html = page(&scene, &[frame(0.0, 0.0), frame(0.5, -0.25)]).unwrap();
        assert!(html.contains("\"tris\":[0,1,2]"), "{html}");
        assert!(
            html.contains("\"verts\":[[[0,0,0,1,0,0,0,1,0]],\n[[0,0,-0.25,1,0,-0.25,0,1,-0.25]]]")
        );
        // A frame that forgets the mesh is refused.
        let mut bad = frame(1.0, 0.0);
        bad.mesh_vertices[0].pop();
        assert_eq!(
            page(&scene, &[frame(0.0, 0.0), bad]),
            Err(ViewerError::FrameShape { frame: 1 })
        );
    }

    #[test]
    fn subsample_keeps_first_last_and_spacing() {
        let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.001).collect();
        let k = subsample(&t, 60.0);
        // 0.1 s at 60 fps: the first rows at or after 0, 1/60, 2/60, … 6/60 s.
        assert_eq!(k, vec![0, 17, 34, 50, 67, 84, 100]);
        // A row at every 0.018 s: each kept once (no grid instant repeats a row).
        let coarse: Vec<f64> = (0..=10).map(|k| k as f64 * 0.018).collect();
        assert_eq!(subsample(&coarse, 60.0), (0..=10).collect::<Vec<_>>());
        assert_eq!(subsample(&t[..1], 60.0), vec![0]);
        assert!(subsample(&[], 60.0).is_empty());
        assert_eq!(subsample(&t, 0.0).len(), 101);
    }
}
