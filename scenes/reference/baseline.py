"""Regenerates the MuJoCo reference exports and measures the peer baseline.

    python3 scenes/reference/baseline.py [--regenerate] [SCENE ...]

Standard library only; drives `cargo xtask mujoco` and `cargo xtask compare`. For each
scene (default: all of them):

1. with --regenerate, rewrites scenes/reference/<scene>.csv (MuJoCo RK4, keyframe start);
2. RK4 at twice the reference step, compared with the reference: the reference's
   self-convergence error (RK4's error at dt is about 1/15 of it);
3. MuJoCo's Euler, implicitfast and RK4 at dt = 1e-3, compared with the reference, and
   their seconds per step timed in MuJoCo's C loop (`mujoco.rollout`, one thread).

Prints the markdown table of scenes/reference/README.md. Scratch files go to
target/mujoco-baseline/.
"""

import json
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# Must agree with REFERENCES in xtask/src/mujoco.rs: (scene, dt, horizon, every).
REFERENCES = [
    ("pendulum", "1e-5", "2", 1000),
    ("double_pendulum", "1e-5", "2", 1000),
    ("spherical_pendulum", "1e-5", "2", 1000),
    ("four_bar", "1e-5", "2", 1000),
    ("chain20", "1e-5", "2", 4000),
    ("chain20_heavy", "1e-5", "2", 4000),
    ("chain100", "1e-4", "1", 1000),
]
PEER_DT = "1e-3"
PEER_EVERY = 10  # 10 ms samples; compared at the times the reference has
SCRATCH = os.path.join(ROOT, "target", "mujoco-baseline")


def xtask(*args):
    cmd = ["cargo", "xtask", *args]
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        return None, (r.stderr.strip().splitlines() or ["failed"])[-1]
    return r.stdout, None


def mujoco(scene, dt, duration, every, integrator, out, timing=None):
    args = ["mujoco", f"scenes/{scene}.xml", "--keyframe", "start", "--dt", dt,
            "--duration", duration, "--every", str(every), "--integrator", integrator,
            "--out", out]
    if timing:
        args += ["--timing", timing]
    return xtask(*args)[1]


def com_error(a, b):
    out, err = xtask("compare", a, b)
    if err:
        return None, err
    m = re.search(r"max COM position error\s+(\S+)", out)
    return float(m.group(1)), None


def fmt(x):
    return "—" if x is None else f"{x:.2e}"


def main(argv):
    regenerate = "--regenerate" in argv
    wanted = [a for a in argv if not a.startswith("--")]
    os.makedirs(SCRATCH, exist_ok=True)
    rows = []
    for scene, dt, horizon, every in REFERENCES:
        if wanted and scene not in wanted:
            continue
        ref = os.path.join(ROOT, "scenes", "reference", f"{scene}.csv")
        if regenerate:
            err = mujoco(scene, dt, horizon, every, "rk4", ref)
            if err:
                sys.exit(f"{scene}: {err}")
        dt2 = repr(2 * float(dt))
        half = os.path.join(SCRATCH, f"{scene}_rk4_2dt.csv")
        err = mujoco(scene, dt2, horizon, every // 2, "rk4", half)
        self_err = None if err else com_error(ref, half)[0]
        peers = []
        for integ in ("euler", "implicitfast", "rk4"):
            out = os.path.join(SCRATCH, f"{scene}_{integ}.csv")
            tim = os.path.join(SCRATCH, f"{scene}_{integ}.json")
            err = mujoco(scene, PEER_DT, horizon, PEER_EVERY, integ, out, tim)
            if err:
                peers.append((None, None, err))
                continue
            e, cerr = com_error(ref, out)
            with open(tim) as f:
                sps = json.load(f)["seconds_per_step"]
            peers.append((e, sps, cerr))
        rows.append((scene, dt, horizon, every, self_err, peers))
        print(f"{scene}: self {fmt(self_err)}; "
              + "; ".join(f"{fmt(e)} m {fmt(s)} s/step {c or ''}" for e, s, c in peers),
              file=sys.stderr)
    print("| scene | dt | every | horizon (s) | RK4 self-error vs 2 dt (m) "
          "| Euler error (m) | implicitfast error (m) | RK4 error (m) "
          "| Euler s/step | implicitfast s/step | RK4 s/step |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for scene, dt, horizon, every, self_err, peers in rows:
        errs = " | ".join(fmt(e) if not c else f"failed: {c}" for e, _, c in peers)
        secs = " | ".join(fmt(s) for _, s, _ in peers)
        print(f"| {scene} | {dt} | {every} | {horizon} | {fmt(self_err)} | {errs} | {secs} |")


if __name__ == "__main__":
    main(sys.argv[1:])
