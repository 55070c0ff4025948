"""URDF foot-friction defaults: integration steps against the answer, for the stiction and
transition velocities (v_stiction, v_friction) of the feet's Coulomb friction.

``load_urdf`` gives feet μ_s = μ_d = 0.8 by default. SphereContact's own transition velocities
(v_stiction = 1e-3, v_friction = 1e-2 m/s, which the papers' models rely on) make a stuck foot a
tangential damper of μ F_n / v_stiction: a stiff element the error control must resolve at
every stick–slip change. This script measures, for a grid of (v_stiction, v_friction) at
μ_s = μ_d = 0.8, the steps a run takes and how far its answer moves from the run with the
smallest velocities (the reference, closest to exact Coulomb friction). Both models are URDF
files written here and loaded with ``proleg.io.load_urdf``; default integrator and tolerances.

``leg``    a planar two-link leg (hip carriage 2 kg on an x slide and a z slide, thigh 0.5 kg and
           shank 0.3 kg of 0.2 m, foot sphere r = 0.02 m; the foot under the hip, thigh 30°
           forward, shank 30° back) dropped from 5 cm; PD servos on hip and knee (kp = 300 N m/rad,
           kd = 2 N m s/rad, 1 kHz) hold the angles. The foot slides as the leg takes the load.
           1 s simulated. Answer: the hip's x and z at 1 s (the slide and the sag).
``leg_stribeck``  the same leg with μ_d = 0.6 < μ_s = 0.8 (friction falling with speed between
           v_stiction and v_friction: negative damping), not run by default.
``slope``  a 4 kg box on four foot spheres (r = 0.01 m at the corners of 0.3 × 0.2 m) standing on a
           10° slope (gravity tilted), released on its feet; 1 s simulated. Exact Coulomb friction
           (μ = 0.8 > tan 10° = 0.18) holds it: the answer is the creep down the slope at 1 s.
           Closed form: below v_stiction the friction coefficient rises from 0 with slope
           1.5 μ / v_stiction (proleg.contact_law), so a stuck foot creeps at about
           v_stiction · tan θ / (1.5 μ) (1.5 mm/s at v_stiction = 0.01 m/s).

Columns: ``steps``/``rejected``/``newton`` of the run; ``wall [s]`` includes compilation (one run
per row: the step counts are what this bench is about); ``Δx``, ``Δz`` [mm] the answer's
distance from the reference row; ``creep [mm]`` the slope case's slide along the slope.

    python bench/urdf_friction.py          # table + bench/results/urdf_friction.md/.json
    python bench/urdf_friction.py --cases leg_stribeck --grid 0 2 --out results/urdf_friction_stribeck
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from common import add_output_args, emit, log

G = 9.81
SLOPE_DEG = 10.0
MU = 0.8
MU_STRIBECK = 0.6  # leg_stribeck: μ_d < μ_s, as SphereContact's users often give (the leg_drop bench)
GRID = [(1e-3, 1e-2), (3e-3, 1.5e-2), (1e-2, 5e-2), (3e-2, 0.15), (0.1, 1.0)]  # (v_stiction, v_friction) [m/s]
T_END, DT_OUT = 1.0, 5e-3

INERT = '<inertial><origin xyz="{c}"/><mass value="{m}"/><inertia ixx="{i}" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>'


def _link(name, m, i, c="0 0 0", extra=""):
    return f'<link name="{name}">{INERT.format(m=m, i=i, c=c)}{extra}</link>'


def _joint(name, kind, parent, child, xyz="0 0 0", axis="0 1 0"):
    lim = '<limit lower="-3" upper="3" effort="100" velocity="10"/>' if kind != "fixed" else ""
    return f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/><origin xyz="{xyz}"/><axis xyz="{axis}"/>{lim}</joint>'


def leg_urdf():
    """Links hang from their joint along −z; the stance angles tilt them (thigh +30°, knee −60°)."""
    sph = '<collision><geometry><sphere radius="0.02"/></geometry></collision>'
    body = [
        _link("rail", 1.0, 0.01), _link("cart", 0.1, 1e-4), _link("hip", 2.0, 0.01),
        _link("thigh", 0.5, 0.5 * 0.2**2 / 12, c="0 0 -0.1"), _link("shank", 0.3, 0.3 * 0.2**2 / 12, c="0 0 -0.1"),
        f'<link name="foot">{sph}</link>',
        _joint("slide_x", "prismatic", "rail", "cart", axis="1 0 0"), _joint("slide_z", "prismatic", "cart", "hip", axis="0 0 1"),
        _joint("hip_joint", "revolute", "hip", "thigh"), _joint("knee", "revolute", "thigh", "shank", xyz="0 0 -0.2"),
        _joint("foot_joint", "fixed", "shank", "foot", xyz="0 0 -0.2"),
    ]
    return '<robot name="leg">' + "".join(body) + "</robot>"


def box_urdf():
    sph = '<collision><geometry><sphere radius="0.01"/></geometry></collision>'
    body = [_link("box", 4.0, 0.03)]
    for k, (x, y) in enumerate([(0.15, 0.1), (0.15, -0.1), (-0.15, 0.1), (-0.15, -0.1)]):
        body += [f'<link name="foot{k}">{sph}</link>', _joint(f"f{k}", "fixed", "box", f"foot{k}", xyz=f"{x} {y} -0.05")]
    return '<robot name="box">' + "".join(body) + "</robot>"


def build(case, v_s, v_f, tmp: Path):
    import proleg as pl
    from proleg.io import load_urdf

    contact = dict(mu_static=MU, mu_dynamic=MU_STRIBECK if case == "leg_stribeck" else MU, v_stiction=v_s, v_friction=v_f)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if case in ("leg", "leg_stribeck"):
            p = tmp / "leg.urdf"
            p.write_text(leg_urdf())
            a = math.radians(30.0)
            h = 0.02 + 2 * 0.2 * math.cos(a)  # hip above the ground with the foot touching
            q0 = {"slide_z": 0.05, "hip_joint": a, "knee": -2 * a}
            m = load_urdf(p, floating_base=False, feet=["foot"], contact=contact, initial_positions=q0, base_position=(0, 0, h))
            for j in ("hip_joint", "knee"):
                m.add_controller(pl.PID(f"{j}.servo", j, kp=300.0, kd=2.0, setpoint=q0[j], period=1e-3))
        else:
            p = tmp / "box.urdf"
            p.write_text(box_urdf())
            th = math.radians(SLOPE_DEG)
            m = load_urdf(p, contact=contact, gravity=(-G * math.sin(th), 0.0, -G * math.cos(th)))
    return m


def run(case, v_s, v_f, tmp):
    import proleg as pl

    system = pl.assemble(build(case, v_s, v_f, tmp))
    t0 = time.perf_counter()
    r = pl.simulate(system, t_end=T_END, dt_output=DT_OUT, progress=False)
    wall = time.perf_counter() - t0
    body = "box" if case == "slope" else "hip"
    p = r.part(body).position
    row = {"case": case, "v_stiction [m/s]": v_s, "v_friction [m/s]": v_f, "steps": r.stats["steps"],
           "rejected": r.stats["rejected"], "newton": r.stats.get("newton_iterations", r.stats.get("newton")), "wall [s]": wall,
           "x [mm]": 1e3 * float(p[-1, 0] - p[0, 0]), "z [mm]": 1e3 * float(p[-1, 2] - p[0, 2])}
    if case == "slope":
        row["creep [mm]"] = -row["x [mm]"]
        row["creep rate 0.5–1 s [mm/s]"] = -1e3 * float(p[-1, 0] - p[len(p) // 2, 0]) / (r.t[-1] - r.t[len(p) // 2])
        row["closed form v_s tanθ/(1.5μ) [mm/s]"] = 1e3 * v_s * math.tan(math.radians(SLOPE_DEG)) / (1.5 * MU)
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", choices=["leg", "slope", "leg_stribeck"], default=["leg", "slope"])
    ap.add_argument("--grid", type=int, nargs="+", default=None, help="indices into GRID (default all)")
    add_output_args(ap, "urdf_friction")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for case in args.cases:
            ref = None
            for v_s, v_f in [GRID[k] for k in (args.grid or range(len(GRID)))]:
                log(f"{case}: v_stiction {v_s}, v_friction {v_f} ...")
                try:
                    row = run(case, v_s, v_f, Path(d))
                except Exception as exc:  # a benchmark reports a failure instead of stopping
                    row = {"case": case, "v_stiction [m/s]": v_s, "v_friction [m/s]": v_f, "status": f"{type(exc).__name__}: {exc}"}
                if ref is None and "x [mm]" in row:
                    ref = row
                if ref is not None and "x [mm]" in row:
                    row["Δx [mm]"] = row["x [mm]"] - ref["x [mm]"]
                    row["Δz [mm]"] = row["z [mm]"] - ref["z [mm]"]
                rows.append(row)
                log(f"  {row}")
    cols = ["case", "v_stiction [m/s]", "v_friction [m/s]", "steps", "rejected", "newton", "wall [s]", "x [mm]", "z [mm]",
            "Δx [mm]", "Δz [mm]", "creep rate 0.5–1 s [mm/s]", "closed form v_s tanθ/(1.5μ) [mm/s]"]
    notes = [
        f"μ_s = μ_d = {MU}; default integrator and tolerances; 1 s simulated, outputs every {DT_OUT * 1e3:g} ms; "
        "wall includes compilation (one run per row).",
        "Δx, Δz: the answer's distance from the first row of its case (the smallest velocities, closest to exact Coulomb friction).",
        "leg: x, z = the hip's slide and sag at 1 s; slope: x = the box's slide at 1 s (negative: down the slope).",
    ]
    emit(args, "URDF foot friction: steps against the answer for (v_stiction, v_friction)", rows, cols,
         {"t_end [s]": T_END, "mu": MU, "slope [deg]": SLOPE_DEG}, notes)


if __name__ == "__main__":
    sys.exit(main())
