"""Whole quadrupeds standing, at proleg's defaults, beside MuJoCo on the same URDF (issue 43).

Each robot of example-robot-data (Go1, ANYmal C, Solo12, A1, B1) and the whole HyQ is loaded from
its URDF with :func:`proleg.io.load_urdf` (HyQ: :func:`proleg.robots.hyq`, which adds its own
servos and contact). The stand: the SRDF's "standing" joint positions, the base placed so that
the lowest foot sphere touches the ground (zero gap), a PD servo on every joint holding that
pose (sampled at 1 kHz; gains from mass and leg length: kp = m g l [N m/rad], kd = kp/20
[N m s/rad], with m the robot's mass and l the hip-to-foot distance in the stance), foot
spheres from the URDF (Solo12's feet are meshes: a 1.75 cm sphere at each foot frame) on the
ground z = 0, Hertz contact k = 1e6 N/m^1.5 with damping 1e3 N s/m over 0.1 mm (SphereContact's
defaults), friction μ = 0.8 with v_stiction 0.1 m/s and v_friction 1 m/s (the whole HyQ's
choice, proleg/robots/hyq.py), joint stops off, URDF joint damping on, joint friction off.

proleg modes:

* ``defaults`` — ``simulate(system, t_end)``: what ``integrator="auto"``/``coordinates="auto"``
  pick (``result.stats["integrator_reason"]`` is printed);
* ``positions`` — the defaults with the α-method's error estimate on positions only
  (``Auto(error_on="positions")``);
* ``before`` — the choice ``auto`` made before issue 43: generalized-α on absolute coordinates
  with a fresh Newton matrix every step (``GeneralizedAlpha()``, ``coordinates="absolute"``).

``first [s]`` is the first ``simulate`` of 0.2 s in a fresh process (compile included; proleg's
persistent compile cache off unless ``--warm-cache``). Then three untimed runs of ``--t-end``
(1 s; one for the ``before`` mode), the first with one of its outputs read: a run with a new
number of outputs compiles its output processing once, and after a cold compile XLA's compiler
threads stay busy for a second or two (gdb: an ``llvm-worker`` verifying MLIR while the loop
ran), so the first runs share the two cores with them (Go1: 0.2–0.7 s where the later runs take
0.13 s). That is a fresh process's start, not the step loop's speed. ``warm [s]`` is the median of the next
``--repeat`` (5) runs of ``--t-end`` in the same process, each paired with a MuJoCo run of the
same length (the load of a shared machine drifts; pairs keep the ratio fair), ``warm min [s]``
their fastest, ``us/step`` = warm / accepted steps, ``× MuJoCo`` the ratio of the medians.
Warm runs of one compiled loop on a 2-core VM vary by up to 2× between runs even when it is
quiet: the median of several is the figure, the minimum what the machine can do. Accuracy:
``Fz/W`` the total vertical ground force over the weight at the end (1.000 when the stand has
settled), ``z [m]`` the base height at the end, ``|Δq|`` the largest joint-position difference
[rad] at the end from the ``before`` run (same problem, same tolerances: the two choices'
answers) or, for MuJoCo, from proleg's ``defaults`` run.

MuJoCo (``pip install -e .[bench]``): the same URDF (visuals and meshes dropped, fixed links
kept as bodies; massless links given 1e-6 kg and 1e-9 kg m², inertias that break the triangle
inequality balanced — ANYmal C's camera frames — and
Go1's singular dummy base inertia its diagonal), a free joint on the root, the same foot spheres (colliding with the floor
only), a PD servo per joint as a ``general`` actuator (gain kp, bias −kp q − kd q̇, the setpoint
as control), joint limits and frictionloss off, URDF damping kept, 1 ms steps (Euler, its
default), contact at MuJoCo's defaults with μ = 0.8. ``warm`` times ``mj_step`` for 1 s after one
untimed 1 s run (the median of the paired runs).

    python bench/whole_robot.py                                  # all robots, both modes, MuJoCo
    python bench/whole_robot.py --robots go1 anymal_c --modes defaults --no-mujoco
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from common import add_output_args, emit, log

COLUMNS = ["robot", "engine", "mode", "coordinates", "integrator", "first [s]", "warm [s]", "warm min [s]", "steps", "rejected", "jacobians",
           "us/step", "× MuJoCo", "Fz/W", "z [m]", "|Δq| [rad]", "status"]

#: robot: (URDF, SRDF, feet for load_urdf (None: the URDF's spheres))
ROBOTS = {
    "go1": ("go1_description/urdf/go1.urdf", "go1_description/srdf/go1.srdf", None),
    "anymal_c": ("anymal_c_simple_description/urdf/anymal.urdf", "anymal_c_simple_description/srdf/anymal.srdf", None),
    "solo12": ("solo_description/robots/solo12.urdf", "solo_description/srdf/solo.srdf",
               {"FL_FOOT": 0.0175, "FR_FOOT": 0.0175, "HL_FOOT": 0.0175, "HR_FOOT": 0.0175}),
    "a1": ("a1_description/urdf/a1.urdf", "a1_description/srdf/a1.srdf", None),
    "b1": ("b1_description/urdf/b1.urdf", "b1_description/srdf/b1.srdf", None),
    "hyq": ("hyq_description/robots/hyq_no_sensors.urdf", "hyq_description/srdf/hyq.srdf", None),
}
CONTACT = dict(mu_static=0.8, mu_dynamic=0.8, v_stiction=0.1, v_friction=1.0)
G = 9.81


def erd(rel) -> Path:
    for base in sys.path:
        p = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / rel
        if p.is_file():
            return p
    raise SystemExit(f"example-robot-data is not installed (no {rel}): pip install -e .[robots]")


def srdf_stand(path) -> dict:
    """Joint positions of the SRDF's "standing" group state."""
    text = Path(path).read_text()
    blocks = dict(re.findall(r'<group_state name="([^"]+)"[^>]*>(.*?)</group_state>', text, re.S))
    body = blocks.get("standing", next(iter(blocks.values()), ""))
    return {n: float(v) for n, v in re.findall(r'<joint name="([^"]+)" value="([^" ]+)"\s*/>', body)}


def stand_model(name):
    """(model, stance {joint: rad}, kp, kd, mass [kg]) of the robot's stand (module docstring)."""
    import proleg as pl
    from proleg.io.urdf import UrdfWarning, load_urdf

    if name == "hyq":  # the built-in model: its servos (300 / 30), contact and stance
        from proleg.robots.hyq import hyq, stance_positions

        model = hyq(drop=0.0)
        return model, stance_positions(), 300.0, 30.0, sum(p.mass for p in model.parts)
    urdf, srdf, feet = ROBOTS[name]
    path = erd(urdf)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        probe = load_urdf(path, feet=(), joint_stops=False)
        stance = {j: v for j, v in srdf_stand(erd(srdf)).items() if j in probe.urdf.joint_names()}
        model = load_urdf(path, feet=feet, contact=CONTACT, joint_stops=False, joint_friction=False, initial_positions=stance)
    mass = sum(p.mass for p in model.parts)
    kp = mass * G * _leg_length(model)
    kd = kp / 20.0
    for j in model.urdf.joint_names():
        model.add_controller(pl.PID(f"{j}.servo", j, kp=kp, kd=kd, setpoint=stance.get(j, 0.0), period=1e-3))
    return model, stance, kp, kd, mass


def _leg_length(model) -> float:
    """Largest distance [m] from a foot sphere's centre to the nearest joint on the base part (hip to foot)."""
    base = model.parts[0]
    hips = [np.asarray(j.marker_j.position, float) for j in model.joints if base in (j.marker_i.part, j.marker_j.part)]
    feet = [np.asarray(c.marker.position, float) for c in model.contacts]
    if not hips or not feet:
        return 0.3
    return float(max(min(np.linalg.norm(f - h) for h in hips) for f in feet))


def run_proleg(name, mode, t_end, with_mujoco=False, repeat=5):
    """One robot, one mode, in this (fresh) process: the row's figures and the end state."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import proleg as pl

    model, stance, kp, kd, mass = stand_model(name)
    system = pl.assemble(model)
    kw = {"defaults": {}, "before": dict(integrator=pl.GeneralizedAlpha(), coordinates="absolute"),
          "positions": dict(integrator=pl.Auto(error_on="positions"))}[mode]
    warnings.simplefilter("ignore")
    t = time.perf_counter()
    pl.simulate(system, 0.2, 1e-2, progress=False, **kw)
    first = time.perf_counter() - t
    # untimed: three runs of the timed length, the first with one of its outputs read (which waits
    # for the output processing of this length, compiled in the background; module docstring)
    pl.simulate(system, t_end, 1e-2, progress=False, **kw).part(model.parts[0].name).position
    if mode != "before":
        for _ in range(2):
            pl.simulate(system, t_end, 1e-2, progress=False, **kw)
    mjs = None
    if with_mujoco:
        try:
            mjs = MujocoStand(name)
            mjs.run(t_end)  # untimed
        except ImportError:
            mjs = None
    walls, mj_walls = [], []
    for _ in range(repeat):  # proleg and MuJoCo in turn: the ratio of the medians
        t = time.perf_counter()
        r = pl.simulate(system, t_end, 1e-2, progress=False, **kw)
        walls.append(time.perf_counter() - t)
        if mjs is not None:
            mj_walls.append(mjs.run(t_end))
    warm = float(np.median(walls))
    st = r.stats
    fz = sum(float(np.asarray(r.contact(c.name)["force"])[-1][2]) for c in model.contacts)
    qj = [float(r.joint(j).angle[-1]) for j in model.urdf.joint_names()]
    rows = []
    if mjs is not None:
        mj_row = mjs.row(t_end, float(np.median(mj_walls)), qj)
        mj_row["warm min [s]"] = min(mj_walls)
        rows.append(mj_row)
    return rows + [{
        "robot": name, "engine": "proleg", "mode": mode, "coordinates": r.coordinates,
        "× MuJoCo": warm / mj_row["warm [s]"] if mjs is not None else None,
        "integrator": st["integrator"], "why": st["integrator_reason"], "first [s]": first, "warm [s]": warm, "warm min [s]": min(walls),
        "steps": int(st["steps"]), "rejected": int(st["rejected"]), "jacobians": int(st["jacobians"]),
        "us/step": 1e6 * warm / max(int(st["steps"]), 1), "Fz/W": fz / (mass * G), "z [m]": float(r.part(model.parts[0].name).position[-1][2]),
        "qj": qj, "kp": kp, "kd": kd, "mass": mass, "status": str(r.status.name if hasattr(r.status, "name") else r.status),
    }][::-1]


def _mujoco_xml(name):
    """(URDF text for MuJoCo, foot spheres [(link, centre (3,), radius)]) of the stand."""
    import xml.etree.ElementTree as ET

    urdf, _, feet = ROBOTS[name]
    root = ET.parse(erd(urdf)).getroot()
    spheres = []
    for link in root.findall("link"):
        ine = link.find("inertial/inertia")
        if ine is not None:  # Go1's dummy "base" (1e-6 everywhere, singular): MuJoCo refuses it, keep its diagonal
            I = np.array([[float(ine.get(a, 0)) for a in row] for row in (("ixx", "ixy", "ixz"), ("ixy", "iyy", "iyz"), ("ixz", "iyz", "izz"))])
            if np.min(np.linalg.eigvalsh(I)) <= 0:
                for a in ("ixy", "ixz", "iyz"):
                    ine.set(a, "0")
        for col in link.findall("collision"):
            sph = col.find("geometry/sphere")
            if sph is not None and feet is None:
                org = col.find("origin")
                xyz = np.array([float(x) for x in org.get("xyz", "0 0 0").split()]) if org is not None else np.zeros(3)
                spheres.append((link.get("name"), xyz, float(sph.get("radius"))))
        for tag in ("visual", "collision"):
            for el in link.findall(tag):
                link.remove(el)
    for lk, r in (feet or {}).items():
        spheres.append((lk, np.zeros(3), r))
    mj = ET.SubElement(root, "mujoco")
    ET.SubElement(mj, "compiler", {"fusestatic": "false", "discardvisual": "true", "boundmass": "1e-6", "boundinertia": "1e-9", "balanceinertia": "true"})
    return ET.tostring(root, encoding="unicode"), spheres


class MujocoStand:
    """MuJoCo on the same URDF, feet and gains as :func:`stand_model` (module docstring)."""

    def __init__(self, name):
        import mujoco

        self.mujoco = mujoco
        model_pl, stance, kp, kd, mass = stand_model(name)
        self.name, self.mass, self.base = name, mass, model_pl.parts[0].name
        xml, spheres = _mujoco_xml(name)
        spec = mujoco.MjSpec.from_string(xml)
        spec.worldbody.first_body().add_freejoint()
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], contype=0, conaffinity=1, friction=[0.8, 0.005, 0.0001])
        bodies = {b.name: b for b in spec.bodies}
        for lk, c, r in spheres:
            bodies[lk].add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0], pos=c, contype=1, conaffinity=0, friction=[0.8, 0.005, 0.0001])
        self.joints = model_pl.urdf.joint_names()
        for j in spec.joints:
            j.frictionloss = 0.0
            j.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        for jn in self.joints:
            spec.add_actuator(name=f"{jn}.servo", target=jn, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                              gaintype=mujoco.mjtGain.mjGAIN_FIXED, gainprm=[kp] + [0] * 9,
                              biastype=mujoco.mjtBias.mjBIAS_AFFINE, biasprm=[0, -kp, -kd] + [0] * 7)
        spec.option.timestep = 1e-3
        self.m = m = spec.compile()
        self.d = d = mujoco.MjData(m)
        from proleg.spatial.rotation import p_from_matrix

        X = model_pl.urdf.base_pose  # the root link frame at the modelled pose (proleg's start)
        d.qpos[:3] = X[:3, 3]
        d.qpos[3:7] = np.asarray(p_from_matrix(X[:3, :3]))
        self.adr = [m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, jn)] for jn in self.joints]
        for jn, a in zip(self.joints, self.adr):
            d.qpos[a] = stance.get(jn, 0.0)
        d.ctrl[:] = [stance.get(jn, 0.0) for jn in self.joints]
        self.start = (d.qpos.copy(), d.qvel.copy(), d.ctrl.copy())

    def run(self, t_end) -> float:
        """Wall time [s] of ``t_end`` from the start."""
        mj, m, d = self.mujoco, self.m, self.d
        mj.mj_resetData(m, d)
        d.qpos[:], d.qvel[:], d.ctrl[:] = self.start
        mj.mj_forward(m, d)
        n = int(round(t_end / m.opt.timestep))
        t = time.perf_counter()
        mj.mj_step(m, d, n)
        return time.perf_counter() - t

    def row(self, t_end, warm, ref):
        mj, m, d = self.mujoco, self.m, self.d
        fz, f6 = 0.0, np.zeros(6)
        for i in range(d.ncon):
            mj.mj_contactForce(m, d, i, f6)
            fz += float((np.asarray(d.contact[i].frame).reshape(3, 3).T @ f6[:3])[2])  # contact frame → world, z
        qj = [float(d.qpos[a]) for a in self.adr]
        b = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, self.base)
        n = int(round(t_end / m.opt.timestep))
        return {
            "robot": self.name, "engine": f"MuJoCo {mj.__version__}", "mode": "1 ms steps", "coordinates": "joint",
            "integrator": "Euler (its default)", "first [s]": None, "warm [s]": warm, "steps": n, "rejected": 0, "jacobians": None,
            "us/step": 1e6 * warm / n, "Fz/W": fz / (self.mass * G), "z [m]": float(d.xpos[b][2]) if b >= 0 else float(d.qpos[2]),
            "|Δq| [rad]": float(np.max(np.abs(np.subtract(qj, ref)))) if ref is not None else None, "status": "ok",
        }


def _worker(argv):
    name, mode, t_end, with_mj, repeat = argv[0], argv[1], float(argv[2]), argv[3] == "1", int(argv[4])
    for row in run_proleg(name, mode, t_end, with_mujoco=with_mj, repeat=repeat):
        print("ROW " + json.dumps(row))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", nargs="+", default=["go1", "anymal_c", "solo12", "hyq"], choices=list(ROBOTS))
    ap.add_argument("--modes", nargs="+", default=["defaults", "before"], choices=["defaults", "before", "positions"])
    ap.add_argument("--no-mujoco", dest="mujoco", action="store_false", help="time proleg alone")
    ap.add_argument("--t-end", type=float, default=1.0)
    add_output_args(ap, "whole_robot")
    ap.set_defaults(repeat=5)  # timed runs per robot (the before mode: one)
    args = ap.parse_args(argv)
    rows = []
    for name in args.robots:
        got = {}
        for k, mode in enumerate(args.modes):
            cmd = [sys.executable, __file__, "--worker", name, mode, str(args.t_end), "1" if (k == 0 and args.mujoco) else "0",
                   str(1 if mode == "before" else args.repeat)]
            env = dict(os.environ)  # PROLEG_CACHE_DIR="" unless --warm-cache (bench/common.py): cold compiles
            log(f"{name} {mode} ...")
            t0 = time.perf_counter()
            out = subprocess.run(cmd, capture_output=True, text=True, env=env)
            lines = [json.loads(ln[4:]) for ln in out.stdout.splitlines() if ln.startswith("ROW ")]
            if not lines:
                lines = [{"robot": name, "engine": "proleg", "mode": mode, "status": (out.stderr.strip().splitlines() or ["no output"])[-1][:120]}]
            for row in lines:
                got[mode if row.get("engine") == "proleg" else "mujoco"] = row
                log(f"   {time.perf_counter() - t0:.1f} s: {({k: v for k, v in row.items() if k != 'qj'})}")
        if "defaults" in got and "before" in got and "qj" in got["before"] and "qj" in got["defaults"]:
            got["defaults"]["|Δq| [rad]"] = float(np.max(np.abs(np.subtract(got["defaults"]["qj"], got["before"]["qj"]))))
        rows += [r for r in got.values()]
    import platform

    notes = [
        f"{args.t_end:g} s of standing; first = the first 0.2 s run in a fresh process (compile included); warm = the median of "
        f"{args.repeat} runs of {args.t_end:g} s after three untimed ones (before: one of each), warm min = their fastest",
        "× MuJoCo = warm / MuJoCo's warm, the medians of runs timed in turn in the first mode's process (the load drifts)",
        f"environment: XLA_FLAGS={os.environ.get('XLA_FLAGS', '')!r}, PJRT_NPROC={os.environ.get('PJRT_NPROC', '')!r} "
        "(proleg adds its XLA-CPU defaults at import unless set here: proleg/__init__.py)",
        "|Δq|: defaults against before (the two choices' answers at the same tolerances); MuJoCo against proleg's defaults (different contact models)",
        "why (proleg defaults): " + "; ".join(f"{r['robot']}: {r.get('why', '')}" for r in rows if r.get("mode") == "defaults"),
        f"load average at the start {os.getloadavg()[0]:.1f} ({platform.node()})",
    ]
    emit(args, "Whole robots standing: proleg at its defaults beside MuJoCo (issue 43)", rows, COLUMNS, notes=notes)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        _worker(sys.argv[2:])
    else:
        main()
