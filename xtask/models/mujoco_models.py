"""MuJoCo's side of `cargo xtask models run`: sizes, timing, contacts and limits per model and case.

Embedded into xtask (`include_str!`) and written to target/xtask/ at run time; run with the
Python of target/mujoco-venv (pinned `mujoco`). One process for all models:

    python mujoco_models.py --list LIST.tsv --duration T [--ctrl-duration TC] [--repeats 3]
        [--seed S] --work DIR --out OUT.tsv

LIST.tsv: one model a line, `name<TAB>path`. Each model runs up to three cases, each of
N = round(duration / timestep) steps at the file's step and integrator:
  * `passive`: from the default pose (qpos0, zero velocity) with zero control, T s;
  * `perturbed`: zero control, T s, from qpos0 plus a seeded perturbation of every hinge
    (uniform in +-0.2 rad) and slide (+-0.02 m) coordinate, kept inside the joint's range
    shrunk by a tenth of its width (offsets from qpos0 halved until every limited
    tendon's length is inside its range), and a seeded velocity of those dofs (+-0.2
    rad/s or m/s); free and ball joints keep qpos0 and zero velocity. The state is written to the
    row (`qpos`, `qvel`, comma-separated repr, MuJoCo's order) for the other engine;
  * `controlled` (models with actuators): from qpos0 under a seeded control
    sequence, a new value every 0.05 s (zero-order hold) uniform in the actuator's
    ctrlrange (in [-1, 1] where it has none), TC s; written to DIR/<name>.ctrl.csv
    (`t,<actuator>...`, the format `simulate --ctrl` and `mujoco_run.py --ctrl` read; an
    actuator without a name is the column `#k`, k its index).
The random draws are numpy.random.RandomState(S + crc32(name)) (S default 13), so the
same model gets the same state and controls on every machine.

Per case: an untimed Python loop of mj_step records the most contacts (d.ncon) and joint
or tendon limit rows (efc type LIMIT) at any step, the time of the first state with a
contact, the height of the first body's origin at the end (`root_z`), and whether the
state stayed finite without MuJoCo's bad-qacc/qpos/qvel warnings; then `mujoco.rollout` (MuJoCo's C loop, one
thread) runs the same N steps `--repeats` times; us_per_step is the median of those wall
times over N.

OUT.tsv: a `#mujoco_version<TAB>V` line, a header, one row per model and case in list
order. A model that fails to load gets one row (case `passive`) with a `status` other than
`ok` (tabs and newlines removed); a case that diverges gets `diverged ...`: never a stop of
the whole run.
"""

import argparse
import bisect
import math
import os
import zlib
import statistics
import sys
import time

COLUMNS = ["name", "case", "status", "nbody", "njnt", "nq", "nv", "nu", "timestep",
           "integrator", "steps", "us_per_step", "max_ncon", "max_nlimit", "first_contact",
           "root_z", "qpos", "qvel", "ctrl"]
HOLD = 0.05


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


def initial_state(m, qpos, qvel):
    """MjData at (qpos, qvel) after mj_forward, and its full physics state (the state
    `mujoco.rollout` starts from)."""
    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    d.qpos[:] = qpos
    d.qvel[:] = qvel
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state0, spec)
    return d, state0


def hold_controls(m, ids, times, rows, nstep):
    """The (nstep, nu) control before each step: row j of `rows` (actuators `ids`) from
    time t_j on, held until the next (step k at k*dt + 1e-12)."""
    dt = float(m.opt.timestep)
    ctrl = np.zeros((nstep, m.nu))
    for k in range(nstep):
        j = max(0, bisect.bisect_right(times, k * dt + 1e-12) - 1)
        for i, u in zip(ids, rows[j]):
            ctrl[k, i] = u
    return ctrl


def perturbed_state(m, rng):
    """qpos0 plus the seeded hinge/slide perturbation, and the seeded dof velocities."""
    qpos = np.array(m.qpos0, dtype=float)
    qvel = np.zeros(m.nv)
    hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
    for j in range(m.njnt):
        kind = int(m.jnt_type[j])
        if kind not in (hinge, slide):
            continue
        amp = 0.2 if kind == hinge else 0.02
        a, v = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        q = qpos[a] + rng.uniform(-amp, amp)
        if m.jnt_limited[j]:
            lo, hi = float(m.jnt_range[j][0]), float(m.jnt_range[j][1])
            pad = 0.1 * (hi - lo)
            q = min(max(q, lo + pad), hi - pad)
        qpos[a] = q
        qvel[v] = rng.uniform(-amp, amp)
    # A limited tendon must start inside its range too (ball_in_cup's string): halve
    # the position offsets from qpos0 until every limited tendon length is (no new
    # draws, so the other models' states do not change).
    base = np.array(m.qpos0, dtype=float)
    for _ in range(40):
        if tendons_inside(m, qpos):
            break
        qpos = base + 0.5 * (qpos - base)
    return qpos, qvel


def tendons_inside(m, qpos):
    """Whether every limited tendon's length at qpos lies inside its range."""
    if m.ntendon == 0 or not np.any(m.tendon_limited):
        return True
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    for t in range(m.ntendon):
        lo, hi = float(m.tendon_range[t][0]), float(m.tendon_range[t][1])
        if m.tendon_limited[t] and not lo <= float(d.ten_length[t]) <= hi:
            return False
    return True


def control_sequence(m, rng, duration):
    """(header names, actuator ids, times, rows) of the seeded zero-order-hold controls;
    an actuator without a name is column `#k` (its index), as both readers accept."""
    ids, names = [], []
    for i in range(m.nu):
        n = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i)
        ids.append(i)
        names.append(n if n else f"#{i}")
    times = [k * HOLD for k in range(max(1, int(math.ceil(duration / HOLD - 1e-9))))]
    rows = []
    for _ in times:
        row = []
        for i in ids:
            if m.actuator_ctrllimited[i]:
                lo, hi = float(m.actuator_ctrlrange[i][0]), float(m.actuator_ctrlrange[i][1])
            else:
                lo, hi = -1.0, 1.0
            row.append(rng.uniform(lo, hi))
        rows.append(row)
    return names, ids, times, rows


def write_controls(path, names, times, rows):
    with open(path, "w") as f:
        f.write(",".join(["t"] + names) + "\n")
        for t, row in zip(times, rows):
            f.write(",".join(repr(float(v)) for v in [t] + row) + "\n")


def run_case(m, qpos, qvel, ctrl, nstep, repeats):
    """Untimed pass (contacts, limits, divergence), then the timed rollouts. `ctrl`:
    None, or an (nstep, nu) array of the control before each step."""
    row = {"status": "ok"}
    d, state0 = initial_state(m, qpos, qvel)
    limit = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)
    tendon_limit = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_TENDON)
    max_ncon = max_nlimit = 0
    first_contact = None
    for k in range(nstep):
        if ctrl is not None:
            d.ctrl[:] = ctrl[k]
        mujoco.mj_step(m, d)
        max_ncon = max(max_ncon, int(d.ncon))
        if d.ncon > 0 and first_contact is None:
            first_contact = k * float(m.opt.timestep)
        types = d.efc_type[: d.nefc]
        max_nlimit = max(max_nlimit, int(np.sum((types == limit) | (types == tendon_limit))))
    row["max_ncon"] = max_ncon
    row["max_nlimit"] = max_nlimit
    row["first_contact"] = "-" if first_contact is None else repr(first_contact)
    # mj_step leaves xpos at the state before the last step: recompute it.
    mujoco.mj_forward(m, d)
    if m.nbody > 1 and np.isfinite(d.xpos[1][2]):
        row["root_z"] = repr(float(d.xpos[1][2]))
    if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
        row["status"] = "diverged (non-finite state)"
    for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
              mujoco.mjtWarning.mjWARN_BADQVEL):
        if d.warning[int(w)].number > 0:
            row["status"] = f"diverged (MuJoCo warning {w.name})"

    # Timed: the same steps in MuJoCo's C loop.
    rdata = mujoco.MjData(m)
    if ctrl is not None:
        control = ctrl[None, :, :]
    else:
        control = np.zeros((1, 1, m.nu)) if m.nu > 0 else None
    out_state = np.empty((1, nstep, state0.size))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rollout.rollout(m, rdata, state0[None, :], control, nstep=nstep, state=out_state)
        times.append(time.perf_counter() - t0)
    row["us_per_step"] = repr(statistics.median(times) / nstep * 1e6)
    return row


def measure(name, path, duration, ctrl_duration, repeats, seed, work):
    """The rows of one model: one per case."""
    try:
        m = mujoco.MjModel.from_xml_path(path)
    except Exception as e:  # mujoco raises ValueError with the parser's message
        return [{"case": "passive", "status": f"load failed: {one_line(e)}"}]
    dt = float(m.opt.timestep)
    sizes = dict(nbody=m.nbody, njnt=m.njnt, nq=m.nq, nv=m.nv, nu=m.nu, timestep=repr(dt),
                 integrator=mujoco.mjtIntegrator(int(m.opt.integrator)).name
                 .removeprefix("mjINT_"))
    rng = np.random.RandomState((seed + zlib.crc32(name.encode())) % (2**32))
    qpos_p, qvel_p = perturbed_state(m, rng)
    names, ids, times, rows = control_sequence(m, rng, ctrl_duration)
    nstep = max(1, int(round(duration / dt)))
    cases = [("passive", np.array(m.qpos0), np.zeros(m.nv), None, nstep, {}),
             ("perturbed", qpos_p, qvel_p, None, nstep,
              {"qpos": ",".join(repr(float(v)) for v in qpos_p),
               "qvel": ",".join(repr(float(v)) for v in qvel_p)})]
    if ids:
        csv = os.path.join(work, name.replace("/", "_") + ".ctrl.csv")
        write_controls(csv, names, times, rows)
        nc = max(1, int(round(ctrl_duration / dt)))
        ctrl = hold_controls(m, ids, times, rows, nc)
        cases.append(("controlled", np.array(m.qpos0), np.zeros(m.nv), ctrl, nc,
                      {"ctrl": csv}))
    out = []
    for case, q, v, u, n, extra in cases:
        try:
            row = run_case(m, q, v, u, n, repeats)
        except Exception as e:  # a MuJoCo error in one case is that case's status
            row = {"status": f"failed: {one_line(e)}"}
        row.update(sizes, case=case, steps=n, **extra)
        out.append(row)
    return out


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--list", required=True)
    p.add_argument("--duration", type=float, required=True)
    p.add_argument("--ctrl-duration", type=float, default=2.0)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--seed", type=int, default=13)
    p.add_argument("--work", required=True)
    p.add_argument("--out", required=True)
    a = p.parse_args(argv)
    for flag, v in (("--duration", a.duration), ("--ctrl-duration", a.ctrl_duration)):
        if not (v > 0 and math.isfinite(v)):
            fail(f"{flag} must be positive, got {v!r}")
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
        rows = measure(name, path, a.duration, a.ctrl_duration, a.repeats, a.seed, a.work)
        for row in rows:
            row["name"] = name
            row["status"] = row["status"].replace("\t", " ")
            lines.append("\t".join(str(row.get(c, "-")) for c in COLUMNS))
        print(f"mujoco_models: {name}: " + ", ".join(
            f"{r['case']} {r['status']} {r.get('us_per_step', '-')} us/step" for r in rows)
              + f" ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    with open(a.out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
