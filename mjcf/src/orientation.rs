//! Frame orientations: `quat`, `axisangle`, `euler`, `xyaxes`, `zaxis`, resolved to a
//! unit quaternion exactly as MuJoCo's `ResolveOrientation` does.

use crate::attrs::{Attr, Element};
use crate::error::MjcfError;
use crate::math::{self, normalize3, Q, V3};

/// How angles are written (`compiler angle`, `compiler eulerseq`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct AngleConvention {
    /// `angle="degree"` (MuJoCo's default) rather than `radian`.
    pub degree: bool,
    /// `eulerseq`: three of `xyzXYZ`; lower case = rotating axes, upper = fixed axes.
    pub seq: [u8; 3],
}

impl Default for AngleConvention {
    fn default() -> Self {
        AngleConvention {
            degree: true,
            seq: *b"xyz",
        }
    }
}

impl AngleConvention {
    /// An angle as written, in radians.
    pub fn radians(&self, a: f64) -> f64 {
        if self.degree {
            a / 180.0 * std::f64::consts::PI
        } else {
            a
        }
    }
}

/// One orientation specifier as written.
#[derive(Clone, Debug)]
pub(crate) enum Orientation {
    Quat([f64; 4]),
    AxisAngle([f64; 4]),
    Euler([f64; 3]),
    XyAxes([f64; 6]),
    ZAxis([f64; 3]),
}

/// Names of the orientation attributes.
pub(crate) const ORIENTATION_ATTRS: [&str; 5] = ["quat", "axisangle", "euler", "xyaxes", "zaxis"];

/// Reads the orientation of one element (at most one specifier, as MuJoCo requires).
pub(crate) fn read(el: &Element) -> Result<Option<(Orientation, Attr)>, MjcfError> {
    let mut found: Option<(Orientation, Attr)> = None;
    for a in el.attrs.iter() {
        let o = match a.name.as_str() {
            "quat" => Orientation::Quat(a.exact()?),
            "axisangle" => Orientation::AxisAngle(a.exact()?),
            "euler" => Orientation::Euler(a.exact()?),
            "xyaxes" => Orientation::XyAxes(a.exact()?),
            "zaxis" => Orientation::ZAxis(a.exact()?),
            _ => continue,
        };
        if found.is_some() {
            return Err(el.invalid("multiple orientation specifiers are not allowed"));
        }
        found = Some((o, a.clone()));
    }
    Ok(found)
}

/// The unit quaternion of an orientation.
pub(crate) fn resolve(o: &Orientation, at: &Attr, conv: AngleConvention) -> Result<Q, MjcfError> {
    match *o {
        Orientation::Quat(q) => {
            let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
            if n < math::EPS {
                return Err(at.bad("quaternion has zero norm"));
            }
            Ok([q[0] / n, q[1] / n, q[2] / n, q[3] / n])
        }
        Orientation::AxisAngle(aa) => {
            let mut axis = [aa[0], aa[1], aa[2]];
            if normalize3(&mut axis) < math::EPS {
                return Err(at.bad("axisangle too small"));
            }
            Ok(math::axis_angle(axis, conv.radians(aa[3])))
        }
        Orientation::Euler(e) => {
            let mut q = math::QUAT_ID;
            for (i, &c) in conv.seq.iter().enumerate() {
                let (s, co) = (conv.radians(e[i]) / 2.0).sin_cos();
                let r = match c.to_ascii_lowercase() {
                    b'x' => [co, s, 0.0, 0.0],
                    b'y' => [co, 0.0, s, 0.0],
                    _ => [co, 0.0, 0.0, s],
                };
                q = if c.is_ascii_lowercase() {
                    math::mul_quat(q, r) // moving axes: post-multiply
                } else {
                    math::mul_quat(r, q) // fixed axes: pre-multiply
                };
            }
            Ok(math::normalize4(q))
        }
        Orientation::XyAxes(v) => {
            let mut x: V3 = [v[0], v[1], v[2]];
            if normalize3(&mut x) < math::EPS {
                return Err(at.bad("xaxis too small"));
            }
            let mut y: V3 = [v[3], v[4], v[5]];
            let d = math::dot(x, y);
            y = math::sub(y, math::scale(x, d));
            if normalize3(&mut y) < math::EPS {
                return Err(at.bad("yaxis too small"));
            }
            let mut z = math::cross(x, y);
            if normalize3(&mut z) < math::EPS {
                return Err(at.bad("cross(xaxis, yaxis) too small"));
            }
            Ok(math::frame_to_quat(x, y, z))
        }
        Orientation::ZAxis(z) => {
            let mut z = z;
            if normalize3(&mut z) < math::EPS {
                return Err(at.bad("zaxis too small"));
            }
            Ok(math::z_to_quat(z))
        }
    }
}
