"""URDF quadrupeds standing on the servo helper's defaults: the gains it picks and how well the
stand carries the weight.

Each robot of example-robot-data is loaded with ``proleg.io.load_urdf`` at its SRDF "standing"
pose (feet found by load_urdf: spheres, or fitted to Go2's and Solo12's foot meshes; default
foot friction), given ``proleg.io.urdf_servos.add_servos(model)`` (4 Hz critically damped,
gravity-compensated setpoints, 1 kHz), put down on its feet (lowest foot touching, at rest) and
simulated 0.2 s at the defaults. Columns: the robot's mass, the legs' effective vertical lever
sqrt(S_f) (urdf_servos), kp, kd, the ground's vertical force over the weight at 0.1 s and
0.2 s, the steps and the wall time of the run (compilation included: one run per robot).

    python bench/urdf_stand.py            # table + bench/results/urdf_stand.md/.json
"""

from __future__ import annotations

import argparse
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from common import add_output_args, emit, log

ROBOTS = {
    "go1": ("go1_description/urdf/go1.urdf", "go1_description/srdf/go1.srdf"),
    "go2": ("go2_description/urdf/go2.urdf", "go2_description/srdf/go2.srdf"),
    "a1": ("a1_description/urdf/a1.urdf", "a1_description/srdf/a1.srdf"),
    "anymal_c": ("anymal_c_simple_description/urdf/anymal.urdf", "anymal_c_simple_description/srdf/anymal.srdf"),
    "solo12": ("solo_description/robots/solo12.urdf", "solo_description/srdf/solo.srdf"),
}
T_END = 0.2


def erd() -> Path:
    for base in sys.path:
        p = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if p.is_dir():
            return p
    raise SystemExit("example-robot-data is not installed: pip install 'proleg[robots]'")


def srdf_stand(path: Path) -> dict:
    """Joint positions of the SRDF's "standing" group state (first group state if none; {} without a file)."""
    if not path.is_file():
        return {}
    blocks = re.findall(r'<group_state name="([^"]+)"[^>]*>(.*?)</group_state>', path.read_text(), re.S)
    body = dict(blocks).get("standing", blocks[0][1] if blocks else "")
    return {n: float(v) for n, v in re.findall(r'<joint name="([^"]+)" value="([^" ]+)"\s*/>', body)}


def run(name):
    import proleg as pl
    from proleg.io import load_urdf
    from proleg.io.urdf_servos import add_servos

    urdf, srdf = (erd() / p for p in ROBOTS[name])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        probe = load_urdf(urdf, feet=())
        stance = {j: v for j, v in srdf_stand(srdf).items() if j in probe.urdf.joint_names()}
        model = load_urdf(urdf, initial_positions=stance)
    g = add_servos(model)
    t0 = time.perf_counter()
    r = pl.simulate(pl.assemble(model), T_END, 0.01, progress=False)
    wall = time.perf_counter() - t0
    fz = sum(np.asarray(r.contact(c.name).normal_force) for c in model.contacts) / (g.mass * 9.81)
    return {
        "robot": name, "feet": len(model.urdf.feet), "foot r [mm]": 1e3 * float(np.mean([c.radius for c in model.contacts])),
        "stance from SRDF": bool(stance), "mass [kg]": g.mass, "lever [mm]": 1e3 * float(np.mean(list(g.levers.values()))),
        "kp [N m/rad]": g.kp, "kd [N m s/rad]": g.kd, "Fz/W 0.1 s": float(fz[len(fz) // 2]), "Fz/W 0.2 s": float(fz[-1]),
        "steps": r.stats["steps"], "rejected": r.stats["rejected"], "wall [s]": wall,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", nargs="+", choices=list(ROBOTS), default=list(ROBOTS))
    add_output_args(ap, "urdf_stand")
    args = ap.parse_args(argv)
    rows = []
    for name in args.robots:
        log(f"{name} ...")
        try:
            row = run(name)
        except Exception as exc:  # a benchmark reports a failure instead of stopping
            row = {"robot": name, "status": f"{type(exc).__name__}: {exc}"}
        rows.append(row)
        log(f"  {row}")
    cols = ["robot", "feet", "foot r [mm]", "stance from SRDF", "mass [kg]", "lever [mm]", "kp [N m/rad]", "kd [N m s/rad]",
            "Fz/W 0.1 s", "Fz/W 0.2 s", "steps", "rejected", "wall [s]"]
    notes = [
        "add_servos defaults: 4 Hz, damping ratio 1, gravity compensation, 1 kHz; load_urdf defaults (feet, μ = 0.8, "
        "v_stiction 0.01, v_friction 0.05 m/s); simulate defaults; wall includes compilation.",
        "Fz/W: the ground's vertical force over the robot's weight; the issue's target is 1 ± 0.02 at 0.2 s.",
    ]
    emit(args, f"URDF quadrupeds standing {T_END:g} s on add_servos' default gains", rows, cols, {"t_end [s]": T_END}, notes)


if __name__ == "__main__":
    sys.exit(main())
