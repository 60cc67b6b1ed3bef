"""MuJoCo's timing server for `cargo xtask models run`'s interleaved repeats.

Embedded into xtask (`include_str!`, xtask/src/models_timing.rs) and written to
target/xtask/ at run time; run with the Python of target/mujoco-venv. One long-lived
process per run, so a repeat does not pay the interpreter's start-up or the model's load:

    python models_timing.py

On start it writes `ready<TAB>MUJOCO_VERSION`. Then it reads one request a line on stdin,

    time<TAB>MODEL.xml<TAB>QPOS<TAB>QVEL<TAB>CTRL.csv<TAB>NSTEP

(`-` for a missing QPOS, QVEL or CTRL; QPOS and QVEL comma-separated in MuJoCo's order,
CTRL the `t,<actuator>...` file of `xtask/models/mujoco_models.py`, held as there), runs
NSTEP steps of `mujoco.rollout` (MuJoCo's C loop, one thread) from that state, exactly
the timed rollout of `mujoco_models.py`, and answers one line: `ok<TAB>US_PER_STEP` (wall
time of the rollout call over NSTEP, microseconds, repr) or `error<TAB>REASON`. A
request's model, initial state and controls are built once and kept (keyed by the
request's fields, the last case only); the first request of a key also runs one untimed rollout, so every
timed one finds the model, data and buffers warm. End of input ends the process.
"""

import os
import sys
import time

try:
    import mujoco
    import numpy as np
    from mujoco import rollout
except ImportError as e:  # pragma: no cover - environment problem
    print(f"models_timing: cannot import mujoco/numpy ({e})", file=sys.stderr)
    sys.exit(1)

# The measuring script beside this one (xtask writes both to target/xtask/): the same
# start state and zero-order hold of the controls as the checked runs.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from models_mujoco import hold_controls, initial_state, one_line  # noqa: E402


def numbers(text, n, what):
    """The comma-separated values of QPOS or QVEL (at most n)."""
    v = [float(x) for x in text.split(",")]
    if len(v) > n:
        raise ValueError(f"{what}: {len(v)} values, the model has {n}")
    return v


def controls(m, path, nstep):
    """The (nstep, nu) controls of CTRL.csv, each row held until the next
    (`hold_controls`, as the checked runs build them)."""
    with open(path) as f:
        lines = [line.strip() for line in f if line.strip()]
    header = lines[0].split(",")
    if header[0] != "t":
        raise ValueError(f"{path}: the first column is not t")
    ids = []
    for name in header[1:]:
        if name.startswith("#"):
            i = int(name[1:])
        else:
            i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
        if not 0 <= i < m.nu:
            raise ValueError(f"{path}: no actuator {name!r}")
        ids.append(i)
    times, rows = [], []
    for line in lines[1:]:
        f = [float(x) for x in line.split(",")]
        if len(f) != len(header):
            raise ValueError(f"{path}: a row of {len(f)} fields, the header has {len(header)}")
        times.append(f[0])
        rows.append(f[1:])
    if not rows:
        raise ValueError(f"{path}: no rows")
    return hold_controls(m, ids, times, rows, nstep)


class Case:
    """A request's model, start state, controls and buffers, built once."""

    def __init__(self, models, path, qpos, qvel, ctrl, nstep):
        if path not in models:
            models[path] = mujoco.MjModel.from_xml_path(path)
        m = self.m = models[path]
        q, v = np.array(m.qpos0, dtype=float), np.zeros(m.nv)
        if qpos != "-":
            given = numbers(qpos, m.nq, "qpos")
            q[: len(given)] = given
        if qvel != "-":
            given = numbers(qvel, m.nv, "qvel")
            v[: len(given)] = given
        _, state0 = initial_state(m, q, v)
        self.state0 = state0[None, :]
        if ctrl != "-":
            self.control = controls(m, ctrl, nstep)[None, :, :]
        else:
            self.control = np.zeros((1, 1, m.nu)) if m.nu > 0 else None
        self.nstep = nstep
        self.data = mujoco.MjData(m)
        self.out_state = np.empty((1, nstep, state0.size))
        self.rollout()  # untimed: warms the model, data and buffers

    def rollout(self):
        rollout.rollout(self.m, self.data, self.state0, self.control, nstep=self.nstep,
                        state=self.out_state)

    def time(self):
        t0 = time.perf_counter()
        self.rollout()
        return (time.perf_counter() - t0) / self.nstep * 1e6


def answer(models, cases, line):
    f = line.rstrip("\n").split("\t")
    if len(f) != 6 or f[0] != "time":
        return f"error\tnot a request: {line.strip()!r}"
    key = tuple(f[1:])
    try:
        nstep = int(f[5])
        if nstep < 1:
            raise ValueError(f"NSTEP must be >= 1, got {nstep}")
        if key not in cases:
            cases.clear()  # one case at a time: keep only its buffers
            cases[key] = Case(models, f[1], f[2], f[3], f[4], nstep)
        return f"ok\t{cases[key].time()!r}"
    except Exception as e:  # a failed request is its answer, never the end of the server
        return f"error\t{one_line(e)}"


def main():
    models, cases = {}, {}
    print(f"ready\t{mujoco.__version__}", flush=True)
    for line in sys.stdin:
        if line.strip():
            print(answer(models, cases, line), flush=True)


if __name__ == "__main__":
    main()
