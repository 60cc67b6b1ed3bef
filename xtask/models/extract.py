"""Extract the MJCF models of the gymnasium and dm_control wheels; generate lqr_2_1 and swimmer6.

Embedded into xtask (`include_str!`) and written to target/xtask/ at run time; `cargo xtask
models fetch` runs it with the Python of target/mujoco-venv. Standard library only (a fresh
machine has no `unzip`, and dm_control itself cannot be imported: its dependencies are not
installed), so it can also be run by hand:

    python extract.py --gymnasium GYM.whl --dm-control DMC.whl --out target/models [--check]

Writes OUT/gymnasium/*.xml (gymnasium/envs/mujoco/assets/) and OUT/dm_control/ (the *.xml of
dm_control/suite/, its common/ directory that their <include>s need, and every directory
holding a file a model references, e.g. dog_assets/). Then writes OUT/dm_control/lqr_2_1.xml
and OUT/dm_control/swimmer6.xml the way dm_control/suite/lqr.py and swimmer.py build them.
`--check` loads both generated files in MuJoCo and checks their sizes against what
dm_control's code gives (EXPECTED); it needs `mujoco`.
"""

import argparse
import os
import posixpath
import sys
import xml.etree.ElementTree as ET
import zipfile

GYM_DIR = "gymnasium/envs/mujoco/assets/"
DMC_DIR = "dm_control/suite/"

# Sizes dm_control's code gives (MuJoCo counts; nbody includes the world body).
#  lqr_2_1: lqr.xml has no body; _make_model(2, 1) nests body_0 > body_1, one slide joint
#  each (the default class), a motor on joint_0 only, one spatial tendon site_0 -> site_1.
#  swimmer6: swimmer.xml has the head (rootx, rooty slide + rootz hinge); _make_model(6)
#  nests segment_0..segment_4 under it, one hinge and one motor each.
EXPECTED = {
    "lqr_2_1": {"nbody": 3, "njnt": 2, "nq": 2, "nv": 2, "nu": 1, "ntendon": 1},
    "swimmer6": {"nbody": 7, "njnt": 8, "nq": 8, "nv": 8, "nu": 5, "ntendon": 0},
}

# lqr.py draws each joint's stiffness and damping from a numpy RandomState; dm_control
# seeds it afresh on every load unless given `random`. We use the draws of
# `numpy.random.RandomState(LQR_SEED)` (what `suite.load("lqr", "lqr_2_1",
# task_kwargs={"random": 0})` builds), reproduced by MT19937 below.
LQR_SEED = 0


def fail(msg):
    print(f"extract: {msg}", file=sys.stderr)
    sys.exit(1)


class RandomState:
    """numpy.random.RandomState(seed).uniform for an integer seed: MT19937 seeded by
    init_genrand, doubles from two 32-bit draws (genrand_res53)."""

    def __init__(self, seed):
        self.mt = [0] * 624
        self.mt[0] = seed & 0xFFFFFFFF
        for i in range(1, 624):
            prev = self.mt[i - 1]
            self.mt[i] = (1812433253 * (prev ^ (prev >> 30)) + i) & 0xFFFFFFFF
        self.index = 624

    def _next(self):
        if self.index >= 624:
            mt = self.mt
            for i in range(624):
                y = (mt[i] & 0x80000000) | (mt[(i + 1) % 624] & 0x7FFFFFFF)
                mt[i] = mt[(i + 397) % 624] ^ (y >> 1) ^ (0x9908B0DF if y & 1 else 0)
            self.index = 0
        y = self.mt[self.index]
        self.index += 1
        y ^= y >> 11
        y ^= (y << 7) & 0x9D2C5680
        y ^= (y << 15) & 0xEFC60000
        y ^= y >> 18
        return y

    def uniform(self, low, high):
        a, b = self._next() >> 5, self._next() >> 6
        return low + (high - low) * ((a * 67108864.0 + b) / 9007199254740992.0)


def parse(path):
    # Keep comments, as lxml does.
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    try:
        return ET.parse(path, parser)
    except (ET.ParseError, OSError) as e:
        fail(f"{path}: {e}")


def write(tree, path):
    ET.indent(tree)
    tree.write(path, encoding="unicode")
    with open(path, "a") as f:
        f.write("\n")


def make_lqr(template, n_bodies, n_actuators, random,
             stiffness_range=(15, 25), damping_range=(0, 0)):
    """dm_control/suite/lqr.py `_make_model`, on ElementTree instead of lxml."""
    mjcf = parse(template)
    root = mjcf.getroot()
    parent = mjcf.find("./worldbody")
    actuator = ET.SubElement(root, "actuator")
    tendon = ET.SubElement(root, "tendon")
    for body in range(n_bodies):
        # _make_body
        child = ET.Element("body", name=f"body_{body}")
        child.set("pos", ".25 0 0")
        joint = ET.SubElement(child, "joint", name=f"joint_{body}")
        child.append(ET.Element("geom", name=f"geom_{body}"))
        joint.set("stiffness", str(random.uniform(*stiffness_range)))
        joint.set("damping", str(random.uniform(*damping_range)))
        site_name = f"site_{body}"
        child.append(ET.Element("site", name=site_name))
        if body == 0:
            child.set("pos", ".25 0 .1")
        if body < n_actuators:
            actuator.append(ET.Element("motor", name=f"motor_{body}", joint=f"joint_{body}"))
        if body < n_bodies - 1:
            spatial = ET.SubElement(tendon, "spatial", name=f"tendon_{body}")
            spatial.append(ET.Element("site", site=site_name))
            spatial.append(ET.Element("site", site=f"site_{body + 1}"))
        parent.append(child)
        parent = child
    return mjcf


def make_swimmer(template, n_bodies):
    """dm_control/suite/swimmer.py `_make_model`, on ElementTree instead of lxml."""
    mjcf = parse(template)
    root = mjcf.getroot()
    head_body = mjcf.find("./worldbody/body")
    actuator = ET.SubElement(root, "actuator")
    sensor = ET.SubElement(root, "sensor")
    parent = head_body
    for i in range(n_bodies - 1):
        site_name = f"site_{i}"
        # _make_body
        child = ET.Element("body", name=f"segment_{i}")
        child.set("pos", "0 .1 0")
        ET.SubElement(child, "geom", {"class": "visual", "name": f"visual_{i}"})
        ET.SubElement(child, "geom", {"class": "inertial", "name": f"inertial_{i}"})
        child.append(ET.Element("site", name=site_name))
        joint_limit = 360.0 / n_bodies
        child.append(ET.Element("joint", {"name": f"joint_{i}",
                                          "range": f"{-joint_limit} {joint_limit}"}))
        actuator.append(ET.Element("motor", name=f"motor_{i}", joint=f"joint_{i}"))
        sensor.append(ET.Element("velocimeter", name=f"velocimeter_{i}", site=site_name))
        sensor.append(ET.Element("gyro", name=f"gyro_{i}", site=site_name))
        parent.append(child)
        parent = child
    scale = n_bodies / 6.0
    for cam in mjcf.findall("./worldbody/body/camera"):
        if cam.get("mode") == "trackcom":
            cam.set("pos", " ".join(str(float(d) * scale) for d in cam.get("pos").split(" ")))
    return mjcf


def extract(zf, names, prefix, dest):
    """Writes each member `names[i]` (under `prefix`) to `dest/<name minus prefix>`."""
    for n in names:
        rel = n[len(prefix):]
        out = os.path.join(dest, *rel.split("/"))
        os.makedirs(os.path.dirname(out), exist_ok=True)
        with zf.open(n) as src, open(out, "wb") as f:
            f.write(src.read())


def referenced_dirs(zf, members, prefix, xml_rel, seen):
    """Directories (relative to `prefix`) holding the files the model `xml_rel` and its
    includes reference (<mesh file>, <texture file>, <skin file>, <hfield file>, ...)."""
    if xml_rel in seen:
        return set()
    seen.add(xml_rel)
    try:
        root = ET.fromstring(zf.read(prefix + xml_rel))
    except (KeyError, ET.ParseError) as e:
        fail(f"{prefix + xml_rel}: {e}")
    base = posixpath.dirname(xml_rel)
    dirs = {}
    for c in root.iter("compiler"):
        for k in ("assetdir", "meshdir", "texturedir"):
            if c.get(k) is not None:
                dirs[k] = c.get(k)
    out = set()
    for el in root.iter():
        f = el.get("file")
        if f is None:
            continue
        if el.tag == "include":
            out |= referenced_dirs(zf, members, prefix,
                                   posixpath.normpath(posixpath.join(base, f)), seen)
            continue
        sub = dirs.get("texturedir" if el.tag == "texture" else "meshdir", dirs.get("assetdir", ""))
        for cand in (posixpath.join(base, sub, f), posixpath.join(base, f)):
            cand = posixpath.normpath(cand)
            if prefix + cand in members:
                out.add(posixpath.dirname(cand))
                break
        else:
            fail(f"{prefix + xml_rel}: <{el.tag} file={f!r}> is not in the wheel")
    return out


def extract_models(wheel, prefix, dest, extra_dirs=()):
    """Extracts prefix*.xml, the directories `extra_dirs`, and the directories of every
    file those models reference; returns the model files' names."""
    try:
        zf = zipfile.ZipFile(wheel)
    except (OSError, zipfile.BadZipFile) as e:
        fail(f"{wheel}: {e}")
    with zf:
        members = set(zf.namelist())
        xmls = sorted(n for n in members
                      if n.startswith(prefix) and n.endswith(".xml") and "/" not in n[len(prefix):])
        if not xmls:
            fail(f"{wheel}: no {prefix}*.xml")
        dirs = set(extra_dirs)
        seen = set()
        for n in xmls:
            dirs |= referenced_dirs(zf, members, prefix, n[len(prefix):], seen)
        wanted = set(xmls)
        for d in dirs:
            if d:
                wanted |= {n for n in members if n.startswith(prefix + d + "/") and not n.endswith("/")}
        extract(zf, sorted(wanted), prefix, dest)
    return [posixpath.basename(n) for n in xmls]


def check(path, want):
    try:
        import mujoco
    except ImportError as e:
        fail(f"--check needs mujoco ({e})")
    try:
        m = mujoco.MjModel.from_xml_path(path)
    except Exception as e:
        fail(f"{path} does not load in MuJoCo: {str(e).strip().splitlines()[0]}")
    got = {k: int(getattr(m, k)) for k in want}
    if got != want:
        fail(f"{path}: MuJoCo gives {got}, dm_control's code gives {want}")
    print(f"extract: {os.path.basename(path)} loads in MuJoCo {mujoco.__version__}: {got}",
          file=sys.stderr)


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gymnasium", required=True)
    p.add_argument("--dm-control", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--check", action="store_true")
    a = p.parse_args(argv)
    gym = extract_models(a.gymnasium, GYM_DIR, os.path.join(a.out, "gymnasium"))
    dmc_dir = os.path.join(a.out, "dm_control")
    dmc = extract_models(a.dm_control, DMC_DIR, dmc_dir, extra_dirs=["common"])
    for template in ("lqr.xml", "swimmer.xml"):
        if template not in dmc:
            fail(f"{a.dm_control}: no {DMC_DIR}{template}")
    generated = {
        "lqr_2_1": make_lqr(os.path.join(dmc_dir, "lqr.xml"), 2, 1, RandomState(LQR_SEED)),
        "swimmer6": make_swimmer(os.path.join(dmc_dir, "swimmer.xml"), 6),
    }
    for name, tree in generated.items():
        path = os.path.join(dmc_dir, name + ".xml")
        write(tree, path)
        if a.check:
            check(path, EXPECTED[name])
    print(f"extract: {len(gym)} gymnasium and {len(dmc)} dm_control files, "
          f"generated {', '.join(generated)}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
