"""Run an MJCF scene in MuJoCo and write its trajectory (DESIGN.md section 6).

Embedded into xtask (`include_str!`) and written to target/ at run time; `cargo xtask
mujoco` calls it inside the virtual environment it manages. It can also be run by hand:

    python mujoco_run.py SCENE.xml --duration T --out FILE.csv [--keyframe NAME]
        [--dt DT] [--every K] [--integrator euler|implicitfast|rk4] [--timing FILE.json]

CSV layout: `t`, then for every body in document order (world excluded)
`<b>.x,<b>.y,<b>.z` (xpos), `<b>.qw,<b>.qx,<b>.qy,<b>.qz` (xquat),
`<b>.cx,<b>.cy,<b>.cz` (xipos), then `E_kin,E_pot,E_tot`. An unnamed body is called
`body<i>`, i its 0-based index among the non-world bodies. The first row is t = 0, then a
row every K steps; t is written as (step index) * dt, never accumulated. Values are
printed with repr (shortest string that round-trips the double).

`--timing FILE.json` also runs the same number of steps from the same initial state
through `mujoco.rollout` (MuJoCo's C loop, one thread, no Python per step) and writes
the wall seconds per step (best of a few repeats).
"""

import argparse
import bisect
import json
import math
import sys
import time


def fail(msg):
    print(f"mujoco_run: {msg}", file=sys.stderr)
    sys.exit(1)


try:
    import mujoco
    import numpy as np
except ImportError as e:  # pragma: no cover - environment problem
    fail(f"cannot import mujoco/numpy ({e}); install with `pip install mujoco`")

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scene")
    p.add_argument("--keyframe")
    p.add_argument("--dt", type=float)
    p.add_argument("--duration", type=float, required=True)
    p.add_argument("--every", type=int, default=1)
    p.add_argument("--integrator", choices=sorted(INTEGRATORS))
    p.add_argument("--out", required=True)
    p.add_argument("--timing")
    p.add_argument("--qpos", help="initial qpos, comma-separated (front of the vector)")
    p.add_argument("--qvel", help="initial qvel, comma-separated (front of the vector)")
    p.add_argument("--ctrl", help="control CSV: t,<actuator>..., each row held until the next")
    return p.parse_args(argv)


def read_controls(path, model):
    """(times, rows) of a control CSV; rows are lists of (actuator id, value)."""
    with open(path) as f:
        lines = [l.strip() for l in f if l.strip()]
    if not lines:
        fail(f"{path}: empty control file")
    cols = [c.strip() for c in lines[0].split(",")]
    if cols[0] != "t":
        fail(f"{path}: the first column must be t")
    ids = []
    for c in cols[1:]:
        # `#k`: the actuator of index k (0-based), for actuators without a name.
        if c.startswith("#") and c[1:].isdigit() and int(c[1:]) < model.nu:
            ids.append(int(c[1:]))
            continue
        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, c)
        if i < 0:
            fail(f"{path}: column {c!r} is not an actuator of the model")
        ids.append(i)
    times, rows = [], []
    for n, line in enumerate(lines[1:], start=2):
        try:
            vals = [float(x) for x in line.split(",")]
        except ValueError:
            fail(f"{path} line {n}: not a number")
        if len(vals) != len(cols) or not all(math.isfinite(v) for v in vals):
            fail(f"{path} line {n}: {len(vals)} finite fields expected {len(cols)}")
        if times and not vals[0] > times[-1]:
            fail(f"{path} line {n}: times must increase")
        times.append(vals[0])
        rows.append(list(zip(ids, vals[1:])))
    return times, rows


def body_names(model):
    names = []
    for b in range(1, model.nbody):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        names.append(name if name else f"body{b - 1}")
    if len(set(names)) != len(names):
        fail("body names are not unique after naming unnamed bodies body<i>")
    return names


def header(names):
    cols = ["t"]
    for n in names:
        cols += [f"{n}.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz", "cx", "cy", "cz")]
    cols += ["E_kin", "E_pot", "E_tot"]
    return ",".join(cols)


def row(model, data, t):
    vals = [t]
    for b in range(1, model.nbody):
        vals += list(data.xpos[b]) + list(data.xquat[b]) + list(data.xipos[b])
    e_pot, e_kin = float(data.energy[0]), float(data.energy[1])
    vals += [e_kin, e_pot, e_kin + e_pot]
    for v in vals:
        if not math.isfinite(v):
            fail(f"non-finite state at t = {t!r} (diverged)")
    return ",".join(repr(float(v)) for v in vals)


def main(argv):
    a = parse_args(argv)
    try:
        model = mujoco.MjModel.from_xml_path(a.scene)
    except Exception as e:  # mujoco raises ValueError with the parser's message
        fail(f"cannot load {a.scene}: {str(e).strip().splitlines()[0] if str(e).strip() else e}")
    if a.dt is not None:
        if not (a.dt > 0 and math.isfinite(a.dt)):
            fail(f"--dt must be positive, got {a.dt!r}")
        model.opt.timestep = a.dt
    if a.integrator is not None:
        model.opt.integrator = INTEGRATORS[a.integrator]
    model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    dt = float(model.opt.timestep)
    if not (a.duration >= 0 and math.isfinite(a.duration)):
        fail(f"--duration must be non-negative, got {a.duration!r}")
    if a.every < 1:
        fail(f"--every must be >= 1, got {a.every}")
    steps = int(round(a.duration / dt))
    if abs(steps * dt - a.duration) > 1e-9 * max(1.0, a.duration):
        fail(f"--duration {a.duration!r} is not a whole number of steps of {dt!r}")

    data = mujoco.MjData(model)
    if a.keyframe is not None:
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, a.keyframe)
        if key < 0:
            fail(f"no keyframe named {a.keyframe!r} in {a.scene}")
        mujoco.mj_resetDataKeyframe(model, data, key)
    for name, vec, size in (("qpos", a.qpos, model.nq), ("qvel", a.qvel, model.nv)):
        if vec is None:
            continue
        vals = [float(x) for x in vec.split(",")]
        if len(vals) > size or not all(math.isfinite(v) for v in vals):
            fail(f"--{name}: {len(vals)} finite values, the model has {size}")
        getattr(data, name)[: len(vals)] = vals
    if a.qpos is not None:
        mujoco.mj_normalizeQuat(model, data.qpos)
    controls = read_controls(a.ctrl, model) if a.ctrl else None
    # The initial state, before any step, for the timing rollout.
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state0, spec)

    names = body_names(model)
    with open(a.out, "w") as f:
        f.write(header(names) + "\n")
        # mj_step leaves xpos/xquat/xipos/energy at the state *before* the step, so each
        # sample recomputes them with mj_forward (which does not change the state).
        mujoco.mj_forward(model, data)
        f.write(row(model, data, 0.0) + "\n")
        done = 0
        while done < steps:
            n = min(a.every, steps - done)
            if controls is None:
                mujoco.mj_step(model, data, nstep=n)
            else:
                # Zero-order hold: before each step, the row in force at its start time.
                times, rows = controls
                for k in range(n):
                    t = (done + k) * dt
                    j = bisect.bisect_right(times, t + 1e-12) - 1
                    if j >= 0:
                        for i, u in rows[j]:
                            data.ctrl[i] = u
                    mujoco.mj_step(model, data)
            done += n
            if n == a.every:
                mujoco.mj_forward(model, data)
                f.write(row(model, data, done * dt) + "\n")
    if not np.all(np.isfinite(data.qpos)) or not np.all(np.isfinite(data.qvel)):
        fail("simulation diverged (non-finite state)")
    # MuJoCo resets the state (and only warns) when accelerations blow up: refuse that.
    for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
              mujoco.mjtWarning.mjWARN_BADQVEL):
        if data.warning[int(w)].number > 0:
            fail(f"simulation diverged (MuJoCo warning {w.name})")

    if a.timing:
        from mujoco import rollout

        rdata = mujoco.MjData(model)
        nstep = max(steps, 1)
        best = math.inf
        total = 0.0
        repeats = 0
        out_state = np.empty((1, nstep, state0.size))
        while repeats < 3 or (total < 2.0 and repeats < 50):
            t0 = time.perf_counter()
            rollout.rollout(model, rdata, state0[None, :], nstep=nstep, state=out_state)
            el = time.perf_counter() - t0
            best = min(best, el)
            total += el
            repeats += 1
        integ = mujoco.mjtIntegrator(int(model.opt.integrator)).name
        for k, v in INTEGRATORS.items():
            if int(v) == int(model.opt.integrator):
                integ = k
        info = {
            "scene": a.scene,
            "integrator": integ,
            "dt": dt,
            "steps": nstep,
            "seconds_per_step": best / nstep,
            "repeats": repeats,
            "mujoco_version": mujoco.__version__,
        }
        with open(a.timing, "w") as f:
            json.dump(info, f, indent=2)
            f.write("\n")


if __name__ == "__main__":
    main(sys.argv[1:])
