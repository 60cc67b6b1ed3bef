"""MuJoCo's work-precision points for the verify report (scenes/reference/mujoco_points.csv).

    target/mujoco-venv/bin/python scenes/reference/mujoco_points.py [--out FILE] [SCENE ...]

Run from the repository root with the pinned MuJoCo 4.0.0 virtual environment that
`cargo xtask mujoco` creates under target/ (run any `cargo xtask mujoco` command once
first). For each scene (default: all twelve) × integrator (euler, implicitfast, rk4) × dt
(4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1e-4) it

1. runs the scene from keyframe `start` over 1 s with `mj_step` and compares it with the
   committed RK4 reference scenes/reference/<scene>.csv: the max over samples and bodies
   of the COM (`xipos`) distance (m) and of the orientation angle `2 acos |<q, q_ref>|`
   (rad). Samples: the reference's rows with t <= 1 s whose time is a whole number of
   steps, thinned to every k-th step where k is the smallest count of steps that is a
   multiple of the reference's sample interval — the same rule `verify-report` uses for
   this library's methods, so both are compared at the same times;
2. times the same steps from the same initial state in MuJoCo's C loop (`mujoco.rollout`,
   one thread, no Python per step): seconds per step, best of 3 rollouts, each of all the
   steps or, where that would take more than about 1 s, of the first ones (chain100).

Writes one comment line (`# mujoco <version>, measured <date> on <machine>`) and then
`scene,integrator,dt,com_error_m,angle_error_rad,seconds_per_step` rows. Deterministic
except for the timings.
"""

import csv
import datetime
import math
import os
import platform
import sys
import time

import mujoco
import numpy as np
from mujoco import rollout

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = ["pendulum", "double_pendulum", "spherical_pendulum", "four_bar", "chain20",
          "chain20_heavy", "chain100", "planar_leg", "two_hinge_pendulum", "pendulum_damped",
          "actuated", "fluid_drag"]
INTEGRATORS = [("euler", mujoco.mjtIntegrator.mjINT_EULER),
               ("implicitfast", mujoco.mjtIntegrator.mjINT_IMPLICITFAST),
               ("rk4", mujoco.mjtIntegrator.mjINT_RK4)]
DTS = [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1e-4]
HORIZON = 1.0
PINNED = "4.0.0"


def sample_every(dt, interval):
    """Smallest step count k with k*dt a whole multiple of the reference interval."""
    for k in range(1, 100001):
        r = k * dt / interval
        if abs(r - round(r)) < 1e-6 and round(r) >= 1:
            return k
    raise SystemExit(f"no common sample time for dt {dt} and interval {interval}")


def load_reference(scene):
    path = os.path.join(ROOT, "scenes", "reference", f"{scene}.csv")
    with open(path) as f:
        rows = list(csv.reader(f))
    head = rows[0]
    data = np.array([[float(v) for v in r] for r in rows[1:] if r], dtype=float)
    return head, data


def body_columns(head, names, suffixes):
    return np.array([[head.index(f"{n}.{s}") for s in suffixes] for n in names])


def body_names(model):
    out = []
    for b in range(1, model.nbody):
        n = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        out.append(n if n else f"body{b - 1}")
    return out


def reference_rows(data, dt, every):
    """{step index: reference row} at the shared sample times."""
    out = {}
    for row in data:
        t = row[0]
        if t > HORIZON + 1e-9:
            break
        k = round(t / dt)
        if abs(k * dt - t) <= 1e-9 * max(1.0, t) and k % every == 0:
            out[k] = row
    return out


def run_scene(model, key, dt, integ, refs, com_cols, quat_cols):
    model.opt.timestep = dt
    model.opt.integrator = integ
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, key)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state0, spec)
    steps = int(round(HORIZON / dt))
    com_err, ang_err, done = 0.0, 0.0, 0
    for k in sorted(refs):
        if k > done:
            mujoco.mj_step(model, data, nstep=k - done)
            done = k
        mujoco.mj_forward(model, data)
        row = refs[k]
        d = np.linalg.norm(np.asarray(data.xipos[1:]) - row[com_cols], axis=1)
        dot = np.abs(np.sum(np.asarray(data.xquat[1:]) * row[quat_cols], axis=1))
        a = 2.0 * np.arccos(np.minimum(dot, 1.0))
        if not (np.all(np.isfinite(d)) and np.all(np.isfinite(a))):
            return math.inf, math.inf, state0, steps
        com_err = max(com_err, float(d.max()))
        ang_err = max(ang_err, float(a.max()))
    return com_err, ang_err, state0, steps


def time_rollout(model, state0, steps):
    """Seconds per step: best of 3 rollouts from state0. A rollout is capped near 1 s of
    wall time (the first `n` steps, `n` estimated from a 20-step rollout) so that the
    expensive cases get 3 repeats too; per-step cost does not depend on the horizon."""
    rdata = mujoco.MjData(model)
    probe = min(steps, 20)
    out_state = np.empty((1, steps, state0.size))
    t0 = time.perf_counter()
    rollout.rollout(model, rdata, state0[None, :], nstep=probe, state=out_state[:, :probe])
    est = (time.perf_counter() - t0) / probe
    n = max(probe, min(steps, int(1.0 / max(est, 1e-9))))
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        rollout.rollout(model, rdata, state0[None, :], nstep=n, state=out_state[:, :n])
        best = min(best, time.perf_counter() - t0)
    return best / n


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.machine()}"


def main(argv):
    out = os.path.join(ROOT, "scenes", "reference", "mujoco_points.csv")
    if "--out" in argv:
        i = argv.index("--out")
        out = argv[i + 1]
        argv = argv[:i] + argv[i + 2:]
    scenes = argv or SCENES
    if mujoco.__version__ != PINNED:
        raise SystemExit(f"mujoco {mujoco.__version__} found, the points are for {PINNED}")
    lines = [f"# mujoco {mujoco.__version__}, measured {datetime.date.today().isoformat()} "
             f"on {machine()}; regenerate: target/mujoco-venv/bin/python "
             f"scenes/reference/mujoco_points.py",
             "scene,integrator,dt,com_error_m,angle_error_rad,seconds_per_step"]
    for scene in scenes:
        model = mujoco.MjModel.from_xml_path(os.path.join(ROOT, "scenes", f"{scene}.xml"))
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "start")
        head, ref = load_reference(scene)
        names = body_names(model)
        com_cols = body_columns(head, names, ("cx", "cy", "cz"))
        quat_cols = body_columns(head, names, ("qw", "qx", "qy", "qz"))
        interval = ref[1, 0] - ref[0, 0]
        for iname, integ in INTEGRATORS:
            for dt in DTS:
                refs = reference_rows(ref, dt, sample_every(dt, interval))
                ce, ae, state0, steps = run_scene(model, key, dt, integ, refs, com_cols,
                                                  quat_cols)
                sps = time_rollout(model, state0, steps)
                line = f"{scene},{iname},{dt!r},{ce!r},{ae!r},{sps!r}"
                print(f"{line}  ({len(refs)} samples)", file=sys.stderr, flush=True)
                lines.append(line)
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
