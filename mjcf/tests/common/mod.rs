//! Helpers shared by the integration tests.
#![allow(dead_code)]

use constraint_mjcf::{load_str, MjcfError, Model};

/// `<mujoco>` around `body` placed inside `<worldbody>`.
pub fn world(body: &str) -> String {
    format!("<mujoco>\n<worldbody>\n{body}\n</worldbody>\n</mujoco>")
}

/// Loads `xml`, panicking with the error's message on failure.
pub fn load(xml: &str) -> Model {
    match load_str(xml) {
        Ok(m) => m,
        Err(e) => panic!("load failed: {e}\n{xml}"),
    }
}

/// Loads `xml`, which must fail.
pub fn fail(xml: &str) -> MjcfError {
    match load_str(xml) {
        Ok(_) => panic!("loaded, but should not:\n{xml}"),
        Err(e) => e,
    }
}

/// `|a − b| ≤ tol` entrywise.
#[track_caller]
pub fn close<const N: usize>(a: [f64; N], b: [f64; N], tol: f64) {
    for k in 0..N {
        assert!(
            (a[k] - b[k]).abs() <= tol,
            "entry {k}: {a:?} vs {b:?} (tol {tol:e})"
        );
    }
}

/// Same rotation (`q` or `−q`).
#[track_caller]
pub fn same_rotation(a: [f64; 4], b: [f64; 4], tol: f64) {
    let s = if a.iter().zip(&b).map(|(x, y)| x * y).sum::<f64>() < 0.0 {
        -1.0
    } else {
        1.0
    };
    close([a[0] * s, a[1] * s, a[2] * s, a[3] * s], b, tol);
}

/// `|a − b| ≤ tol` for matrices.
#[track_caller]
pub fn close_mat(a: [[f64; 3]; 3], b: [[f64; 3]; 3], tol: f64) {
    for r in 0..3 {
        close(a[r], b[r], tol);
    }
}
