//! Arbitrary small particle systems (positions, velocities, masses including zero,
//! negative, NaN and huge; pins; gravity) with arbitrary soft constraint sets (springs,
//! triangle areas, tetrahedron volumes, dihedral hinges, point-on-plane; indices
//! out of range or repeated; stiffness and damping including ∞, NaN and negative),
//! stepped a few times by one of: symplectic Euler, implicit Euler (every Hessian mode ×
//! conjugate gradients, sparse LDLᵀ, lagged LDLᵀ), the lagrange formulations with
//! arbitrary hard/compliant sets (acceleration level with Baumgarte, velocity level
//! explicit/implicit with and without projection, projected steps, RATTLE, RATTLE4, a bare
//! fast projection with arbitrary mass and pin slices), or the deformable contact step
//! against static colliders.
//!
//! Checked after every call: a typed error, or a finite state (every position and
//! velocity); a rejected call leaves the state (positions, velocities, step count, bit
//! for bit) unchanged.
#![no_main]

use arbitrary::Arbitrary;
use constraint_lagrange::deformable::{DeformableContact, DeformableSettings};
use constraint_contact::geometry::{Collider, Shape};
use constraint_core::{Area, DQuat, DVec3, Dihedral, Distance, PointOnPlane, Pose, Volume};
use constraint_lagrange::solve::IterSettings;
use constraint_lagrange::{
    AccelerationLevel, BaseStep, Baumgarte, Constraints, FastProjection, HardSet, KktSolver,
    ProjectedStep, Rattle, RattleOrder, VelocityLevel,
};
use constraint_soft::lagged::LaggedSettings;
use constraint_soft::{
    CgSettings, ConstraintSet, HessianMode, ImplicitEuler, Integrator, LinearSolver, SoftSystem,
    Softness, SymplecticEuler,
};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Particle {
    x: [f64; 3],
    v: [f64; 3],
    mass: f64,
    pin: bool,
}

#[derive(Arbitrary, Debug)]
struct Con {
    /// Distance, area, volume, dihedral, point-on-plane.
    kind: u8,
    idx: [u8; 4],
    /// 0: `from_rest` at the input positions, 1: `new` with `rest`, 2: a struct literal
    /// (public fields; no validation: repeated indices, any rest value).
    build: u8,
    rest: f64,
    normal: [f64; 3],
    /// `None`: a sane value.
    stiffness: Option<f64>,
    damping: Option<f64>,
    compliance: Option<f64>,
    /// Goes to the hard constraints instead of the soft ones.
    hard: bool,
}

#[derive(Arbitrary, Debug)]
struct Obstacle {
    kind: u8,
    normal: [f64; 3],
    size: [f64; 3],
    offset: f64,
    friction: Option<f64>,
}

#[derive(Arbitrary, Debug)]
struct Input {
    particles: Vec<Particle>,
    cons: Vec<Con>,
    /// Write positions and velocities straight into the public fields (NaN allowed).
    raw_state: bool,
    extra_pin: Option<u16>,
    gravity: Option<[f64; 3]>,
    method: u8,
    mode: u8,
    solver: u8,
    kkt: u8,
    h: Option<f64>,
    param: Option<f64>,
    tol: Option<f64>,
    iters: u8,
    steps: u8,
    flag: bool,
    proj_mass: Vec<f64>,
    proj_pinned: Vec<bool>,
    obstacles: Vec<Obstacle>,
    settings: Option<(f64, f64, f64, u8)>,
}

fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn state(sys: &SoftSystem) -> (Vec<u64>, u64) {
    let bits = sys
        .x
        .iter()
        .chain(&sys.v)
        .flat_map(|p| p.to_array())
        .map(f64::to_bits)
        .collect();
    (bits, sys.steps)
}

fn finite(sys: &SoftSystem) -> bool {
    sys.x.iter().chain(&sys.v).all(|p| p.is_finite())
}

fn check<T, E: core::fmt::Debug>(
    sys: &SoftSystem,
    before: &(Vec<u64>, u64),
    r: &Result<T, E>,
) -> bool {
    match r {
        Ok(_) => {
            assert!(finite(sys), "non-finite state after an accepted step");
            true
        }
        Err(_) => {
            assert_eq!(
                &state(sys),
                before,
                "a rejected step changed the state: {r:?}",
                r = r.as_ref().err()
            );
            false
        }
    }
}

fn kkt_solver(k: u8, param: f64) -> KktSolver {
    let it = IterSettings {
        tolerance: 1e-10,
        max_iterations: 200,
    };
    match k % 8 {
        0 => KktSolver::Auto,
        1 => KktSolver::DenseSchur,
        2 => KktSolver::SparseSchur,
        3 => KktSolver::Minres(it),
        4 => KktSolver::Gmres {
            restart: 10,
            settings: it,
        },
        5 => KktSolver::Svd { rank_tol: param },
        6 => KktSolver::DampedLeastSquares { damping: param },
        _ => KktSolver::Minres(IterSettings {
            tolerance: param,
            max_iterations: 50,
        }),
    }
}

fn mode_of(m: u8) -> HessianMode {
    match m % 3 {
        0 => HessianMode::Exact,
        1 => HessianMode::GaussNewton,
        _ => HessianMode::Projected,
    }
}

fn linear_solver(s: u8, tol: f64, iters: usize, param: f64) -> LinearSolver {
    match s % 3 {
        0 => LinearSolver::ConjugateGradient(CgSettings {
            tolerance: tol,
            max_iterations: iters,
        }),
        1 => LinearSolver::SparseLdlt,
        _ => LinearSolver::LaggedLdlt(LaggedSettings {
            tolerance: tol,
            max_iterations: iters,
            factor_cost: param,
        }),
    }
}

/// One kind of constraint, soft and hard lists with their softness and compliance.
struct Lists<C> {
    soft: Vec<C>,
    softness: Vec<Softness>,
    hard: Vec<C>,
    compliance: Vec<f64>,
}

impl<C> Default for Lists<C> {
    fn default() -> Self {
        Self {
            soft: Vec::new(),
            softness: Vec::new(),
            hard: Vec::new(),
            compliance: Vec::new(),
        }
    }
}

impl<C: Clone> Lists<C> {
    fn push(&mut self, c: C, con: &Con) {
        if con.hard {
            self.hard.push(c);
            self.compliance.push(con.compliance.unwrap_or(0.0));
        } else {
            self.soft.push(c);
            self.softness.push(Softness {
                stiffness: con.stiffness.unwrap_or(100.0),
                damping: con.damping.unwrap_or(0.0),
            });
        }
    }
}

fn sane(v: f64) -> f64 {
    if v.is_finite() {
        v.abs()
    } else {
        1.0
    }
}

macro_rules! add_sets {
    ($sys:expr, $hard:expr, $lists:expr, $name:literal) => {{
        let l = $lists;
        let set = ConstraintSet::new($name, l.soft.clone(), l.softness.clone()).or_else(|_| {
            let s = l
                .softness
                .iter()
                .map(|s| Softness {
                    stiffness: sane(s.stiffness),
                    damping: sane(s.damping),
                })
                .collect();
            ConstraintSet::new($name, l.soft.clone(), s)
        });
        if let Ok(set) = set {
            let _ = $sys.add_set(set);
        }
        let hs = HardSet::compliant($name, l.hard.clone(), l.compliance.clone())
            .unwrap_or_else(|_| HardSet::hard($name, l.hard.clone()));
        $hard.add(hs);
    }};
}

fuzz_target!(|inp: Input| {
    let ps = &inp.particles[..inp.particles.len().min(8)];
    let n = ps.len();
    let x: Vec<DVec3> = ps.iter().map(|p| v3(p.x)).collect();
    let m: Vec<f64> = ps.iter().map(|p| p.mass).collect();
    let mut sys = match SoftSystem::new(x.clone(), m.clone()) {
        Ok(s) => s,
        Err(_) => {
            let x = x
                .iter()
                .map(|p| if p.is_finite() { *p } else { DVec3::ZERO })
                .collect();
            let m = m
                .iter()
                .map(|&m| if m > 0.0 && m.is_finite() { m } else { 1.0 })
                .collect();
            SoftSystem::new(x, m).expect("sanitised system")
        }
    };
    let v: Vec<DVec3> = ps.iter().map(|p| v3(p.v)).collect();
    let _ = sys.set_velocities(&v);
    for (i, p) in ps.iter().enumerate() {
        if p.pin {
            sys.pin(i).expect("pin in range");
        }
    }
    if let Some(i) = inp.extra_pin {
        let _ = sys.pin(i as usize);
    }
    if inp.raw_state {
        sys.x.clone_from(&x);
        sys.v.clone_from(&v);
    }
    if let Some(g) = inp.gravity {
        sys.gravity = v3(g);
    }

    // Constraints.
    let mut dist = Lists::<Distance>::default();
    let mut area = Lists::<Area>::default();
    let mut vol = Lists::<Volume>::default();
    let mut dih = Lists::<Dihedral>::default();
    let mut plane = Lists::<PointOnPlane>::default();
    for c in inp.cons.iter().take(12) {
        let i = c.idx.map(|i| i as usize % (n + 2));
        let b = c.build % 3;
        match c.kind % 5 {
            0 => {
                let r = match b {
                    0 => Distance::from_rest(i[0], i[1], &x).ok(),
                    1 => Distance::new(i[0], i[1], c.rest).ok(),
                    _ => Some(Distance {
                        points: [i[0], i[1]],
                        rest_length: c.rest,
                    }),
                };
                if let Some(r) = r {
                    dist.push(r, c);
                }
            }
            1 => {
                let p = [i[0], i[1], i[2]];
                let r = match b {
                    0 => Area::from_rest(p, &x).ok(),
                    1 => Area::new(p, c.rest).ok(),
                    _ => Some(Area {
                        points: p,
                        rest_area: c.rest,
                    }),
                };
                if let Some(r) = r {
                    area.push(r, c);
                }
            }
            2 => {
                let r = match b {
                    0 => Volume::from_rest(i, &x).ok(),
                    1 => Volume::new(i, c.rest).ok(),
                    _ => Some(Volume {
                        points: i,
                        rest_volume: c.rest,
                    }),
                };
                if let Some(r) = r {
                    vol.push(r, c);
                }
            }
            3 => {
                let r = match b {
                    0 => Dihedral::from_rest(i, &x).ok(),
                    1 => Dihedral::new(i, c.rest).ok(),
                    _ => Some(Dihedral {
                        points: i,
                        rest_angle: c.rest,
                    }),
                };
                if let Some(r) = r {
                    dih.push(r, c);
                }
            }
            _ => {
                let r = match b {
                    0 | 1 => PointOnPlane::new(i[0], DVec3::splat(c.rest), v3(c.normal)).ok(),
                    _ => Some(PointOnPlane {
                        point: i[0],
                        normal: v3(c.normal),
                        offset: c.rest,
                    }),
                };
                if let Some(r) = r {
                    plane.push(r, c);
                }
            }
        }
    }
    let mut hard = Constraints::new();
    add_sets!(sys, hard, &dist, "springs");
    add_sets!(sys, hard, &area, "areas");
    add_sets!(sys, hard, &vol, "volumes");
    add_sets!(sys, hard, &dih, "hinges");
    add_sets!(sys, hard, &plane, "planes");

    let h = inp.h.unwrap_or(1e-3);
    let param = inp.param.unwrap_or(1e-9);
    let tol = inp.tol.unwrap_or(1e-9);
    let iters = (inp.iters % 64) as usize;
    let ls = linear_solver(inp.solver, tol, iters, param);
    let mode = mode_of(inp.mode);
    let kkt = kkt_solver(inp.kkt, param);
    let steps = (inp.steps % 6) as usize;
    let implicit = || ImplicitEuler::new(h, mode, ls);

    macro_rules! run {
        ($call:expr) => {
            for _ in 0..steps {
                let before = state(&sys);
                let r = $call;
                if !check(&sys, &before, &r) {
                    break;
                }
            }
        };
    }

    match inp.method % 12 {
        0 => {
            if let Ok(mut s) = SymplecticEuler::new(h) {
                run!(s.step(&mut sys));
            }
        }
        1 => {
            if let Ok(mut s) = implicit() {
                run!(s.step(&mut sys));
            }
        }
        2 => {
            let b = Baumgarte { kx: param, kv: tol };
            if let Ok(mut s) = AccelerationLevel::new(h, b, kkt) {
                s.velocity_term = inp.flag;
                run!(s.step(&mut sys, &hard));
            }
        }
        3 | 4 => {
            let base = if inp.method % 12 == 3 {
                BaseStep::Explicit
            } else {
                match implicit() {
                    Ok(i) => BaseStep::Implicit(Box::new(i)),
                    Err(_) => return,
                }
            };
            if let Ok(mut s) = VelocityLevel::new(h, base, kkt) {
                if inp.flag {
                    s.projection = FastProjection::new(tol, iters, kkt).ok();
                }
                run!(s.step(&mut sys, &hard));
            }
        }
        5 => {
            if let (Ok(b), Ok(p)) = (
                SymplecticEuler::new(h),
                FastProjection::new(tol, iters, kkt),
            ) {
                let mut s = ProjectedStep::new(b, p);
                run!(s.step(&mut sys, &hard));
            }
        }
        6 => {
            if let (Ok(b), Ok(p)) = (implicit(), FastProjection::new(tol, iters, kkt)) {
                let mut s = ProjectedStep::new(b, p);
                run!(s.step(&mut sys, &hard));
            }
        }
        7 | 8 => {
            let order = if inp.method % 12 == 7 {
                RattleOrder::Second
            } else {
                RattleOrder::Fourth
            };
            if let Ok(mut s) = Rattle::new(h, order, tol, iters, kkt) {
                run!(s.step(&mut sys, &hard));
            }
        }
        9 => {
            // A bare projection with mass and pin slices of any length.
            if let Ok(mut p) = FastProjection::new(tol, iters, kkt) {
                let mass: Vec<f64> = if inp.flag {
                    inp.proj_mass.iter().take(10).copied().collect()
                } else {
                    sys.masses().to_vec()
                };
                let pinned: Vec<bool> = if inp.flag {
                    inp.proj_pinned.iter().take(10).copied().collect()
                } else {
                    sys.pinned().to_vec()
                };
                let mut x = sys.x.clone();
                if p.project(&mass, &pinned, &hard, &mut x).is_ok() {
                    assert!(
                        x.iter().all(|p| p.is_finite()),
                        "non-finite positions after an accepted projection"
                    );
                }
            }
        }
        10 => {
            let mut colliders = Vec::new();
            for o in inp.obstacles.iter().take(3) {
                let shape = match o.kind % 4 {
                    0 => Shape::plane(v3(o.normal), o.offset),
                    1 => Shape::sphere(o.size[0]),
                    2 => Shape::cuboid(v3(o.size)),
                    _ => Shape::capsule(o.size[0], o.size[1]),
                };
                let Ok(shape) = shape else { continue };
                let local = Pose {
                    x: if o.kind % 4 == 0 {
                        DVec3::ZERO
                    } else {
                        v3(o.normal)
                    },
                    q: DQuat::IDENTITY,
                };
                if let Ok(c) = Collider::new(None, shape, local, o.friction.unwrap_or(0.5), 0.0) {
                    colliders.push(c);
                }
            }
            let mut settings = DeformableSettings::default();
            if let Some((r, mg, t, it)) = inp.settings {
                settings = DeformableSettings {
                    radius: r,
                    margin: mg,
                    tolerance: t,
                    max_active_set_iterations: it as usize,
                };
            }
            let dc = DeformableContact::new(colliders.clone(), settings);
            let mut dc = match dc {
                Ok(dc) => dc,
                Err(_) => {
                    let Ok(mut dc) =
                        DeformableContact::new(colliders, DeformableSettings::default())
                    else {
                        return;
                    };
                    if inp.flag {
                        // The settings are public: unvalidated values reach the step.
                        dc.settings = settings;
                    }
                    dc
                }
            };
            if let Ok(mut imp) = implicit() {
                run!(dc.step(&mut sys, &mut imp));
            }
        }
        _ => {
            // Two different integrators on one system, alternately (topology caches).
            if let (Ok(mut a), Ok(mut b)) = (implicit(), SymplecticEuler::new(h)) {
                let mut k = 0;
                run!({
                    k += 1;
                    if k % 2 == 0 {
                        a.step(&mut sys)
                    } else {
                        b.step(&mut sys)
                    }
                });
                // Changing pins (topology) between implicit steps.
                let _ = sys.pin(0);
                run!(a.step(&mut sys));
            }
        }
    }
});
