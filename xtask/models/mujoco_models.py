"""MuJoCo's side of `cargo xtask models run`: sizes, passive-run timing and contacts per model.

Embedded into xtask (`include_str!`) and written to target/xtask/ at run time; run with the
Python of target/mujoco-venv (pinned `mujoco`). One process for all models:

    python mujoco_models.py --list LIST.tsv --duration T [--repeats 3] --out OUT.tsv

LIST.tsv: one model a line, `name<TAB>path`. For each, from the default pose (qpos0, zero
velocity) with zero control, N = round(T / timestep) steps:
  * an untimed Python loop of mj_step records the most contacts at any step (d.ncon) and
    whether the state stayed finite without MuJoCo's bad-qacc/qpos/qvel warnings;
  * `mujoco.rollout` (MuJoCo's C loop, one thread) runs the same N steps `--repeats`
    times; us_per_step is the median of those wall times over N.
OUT.tsv: a `#mujoco_version<TAB>V` line, a header, one row per model in list order. A model
that fails to load or diverges gets a `status` other than `ok` (tabs and newlines removed),
never a stop of the whole run.
"""

import argparse
import math
import statistics
import sys
import time

COLUMNS = ["name", "status", "nbody", "njnt", "nq", "nv", "nu", "timestep", "integrator",
           "steps", "us_per_step", "max_ncon"]


def fail(msg):
    print(f"mujoco_models: {msg}", file=sys.stderr)
    sys.exit(1)


try:
    import mujoco
    import numpy as np
    from mujoco import rollout
except ImportError as e:  # pragma: no cover - environment problem
    fail(f"cannot import mujoco/numpy ({e}); install with `pip install mujoco`")


def one_line(e):
    s = str(e).strip()
    s = s.splitlines()[0] if s else type(e).__name__
    return " ".join(s.split())


def measure(path, duration, repeats):
    row = {"status": "ok"}
    try:
        m = mujoco.MjModel.from_xml_path(path)
    except Exception as e:  # mujoco raises ValueError with the parser's message
        row["status"] = f"load failed: {one_line(e)}"
        return row
    dt = float(m.opt.timestep)
    nstep = max(1, int(round(duration / dt)))
    row.update(nbody=m.nbody, njnt=m.njnt, nq=m.nq, nv=m.nv, nu=m.nu,
               timestep=repr(dt), steps=nstep,
               integrator=mujoco.mjtIntegrator(int(m.opt.integrator)).name.removeprefix("mjINT_"))

    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state0, spec)

    # Untimed pass: contacts and divergence (d.ctrl is zero after mj_resetData).
    max_ncon = 0
    for _ in range(nstep):
        mujoco.mj_step(m, d)
        max_ncon = max(max_ncon, int(d.ncon))
    row["max_ncon"] = max_ncon
    if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
        row["status"] = "diverged (non-finite state)"
    for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
              mujoco.mjtWarning.mjWARN_BADQVEL):
        if d.warning[int(w)].number > 0:
            row["status"] = f"diverged (MuJoCo warning {w.name})"

    # Timed: the same steps in MuJoCo's C loop.
    rdata = mujoco.MjData(m)
    control = np.zeros((1, 1, m.nu)) if m.nu > 0 else None
    out_state = np.empty((1, nstep, state0.size))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rollout.rollout(m, rdata, state0[None, :], control, nstep=nstep, state=out_state)
        times.append(time.perf_counter() - t0)
    row["us_per_step"] = repr(statistics.median(times) / nstep * 1e6)
    return row


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--list", required=True)
    p.add_argument("--duration", type=float, required=True)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", required=True)
    a = p.parse_args(argv)
    if not (a.duration > 0 and math.isfinite(a.duration)):
        fail(f"--duration must be positive, got {a.duration!r}")
    if a.repeats < 1:
        fail(f"--repeats must be >= 1, got {a.repeats}")
    try:
        with open(a.list) as f:
            models = [line.rstrip("\n").split("\t") for line in f if line.strip()]
    except OSError as e:
        fail(f"{a.list}: {e}")
    if any(len(m) != 2 for m in models):
        fail(f"{a.list}: every line must be name<TAB>path")
    lines = [f"#mujoco_version\t{mujoco.__version__}", "\t".join(COLUMNS)]
    for name, path in models:
        t0 = time.perf_counter()
        row = measure(path, a.duration, a.repeats)
        row["name"] = name
        row["status"] = row["status"].replace("\t", " ")
        print(f"mujoco_models: {name}: {row['status']}, "
              f"{row.get('us_per_step', '-')} us/step ({time.perf_counter() - t0:.1f} s)",
              file=sys.stderr)
        lines.append("\t".join(str(row.get(c, "-")) for c in COLUMNS))
    with open(a.out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
