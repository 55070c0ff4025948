"""What ``simulate``'s defaults do with a floating-base robot (issue 43), checked on
example-robot-data's quadrupeds (URDFs through :func:`proleg.io.load_urdf`):

* ``auto`` picks joint coordinates (with the quaternion base) and, for a smooth free flight,
  Tsit5 at its defaults (the floating base's quaternion normalisation is no closed loop:
  solvers/auto.py ``classify``); with contacts and servos, generalized-α with the Newton matrix
  reused and error control on positions and velocities.
* Free flight (no contacts, no stops, joint damping and friction off: smooth) at the defaults
  ends within 1e-6 rad and 1e-6 m of Pinocchio's ABA integrated at rtol 1e-12 (DOP853), every
  part compared by its absolute pose. The comparison maps Pinocchio's joint-space state to
  absolute coordinates with ``proleg.io.urdf_kin.joint_space_state``, itself checked against
  Pinocchio's CRBA/ABA to 1e-8 in tests/test_urdf_pinocchio.py.
* A stand (a PD servo on each joint holding the SRDF pose, foot spheres with friction) holds the
  robot's weight to 2 % after 1 s (slow).
"""

import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip package 'pin') is not installed: pip install -e .[test]")

import proleg as pl  # noqa: E402
from proleg.io.urdf import UrdfWarning, load_urdf  # noqa: E402
from models import robot_path as robot_file  # noqa: E402
from proleg.io.urdf_kin import joint_space_state  # noqa: E402

#: robot: (URDF, SRDF) below example-robot-data's robots/ folder
ROBOTS = {
    "solo12": ("solo_description/robots/solo12.urdf", "solo_description/srdf/solo.srdf"),
    "go1": ("go1_description/urdf/go1.urdf", "go1_description/srdf/go1.srdf"),
    "anymal_c": ("anymal_c_simple_description/urdf/anymal.urdf", "anymal_c_simple_description/srdf/anymal.srdf"),
    "a1": ("a1_description/urdf/a1.urdf", "a1_description/srdf/a1.srdf"),
    "b1": ("b1_description/urdf/b1.urdf", "b1_description/srdf/b1.srdf"),
    "hyq": ("hyq_description/robots/hyq_no_sensors.urdf", "hyq_description/srdf/hyq.srdf"),
}
#: the issue's bound for free flight at the defaults (orientation of every part [rad]; positions [m])
FLIGHT_TOL = 1e-6


def srdf_stand(path) -> dict:
    """Joint positions of the SRDF's "standing" group state (first group state if none)."""
    text = Path(path).read_text()
    blocks = re.findall(r'<group_state name="([^"]+)"[^>]*>(.*?)</group_state>', text, re.S)
    body = dict(blocks).get("standing", blocks[0][1] if blocks else "")
    return {n: float(v) for n, v in re.findall(r'<joint name="([^"]+)" value="([^" ]+)"\s*/>', body)}


def flight_model(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        return load_urdf(robot_file(ROBOTS[name][0]), feet=(), joint_stops=False, joint_damping=False, joint_friction=False,
                         base_position=(0.0, 0.0, 1.0))


def flight_start(model, seed=3):
    """A tumbling start: joints at random within ±0.5 rad of zero (inside every limit of these
    robots), joint rates ~1 rad/s, a base twist of ~1 m/s and ~1 rad/s."""
    rng = np.random.default_rng(seed)
    nj = len(model.urdf.joints)
    qj, vj = rng.uniform(-0.5, 0.5, nj), rng.normal(size=nj)
    nu = np.concatenate([rng.normal(size=3), rng.normal(size=3)])
    bq = np.array([0.9, 0.1, -0.2, 0.3])
    return qj, vj, np.array([0.0, 0.0, 1.0]), bq / np.linalg.norm(bq), nu


def pinocchio_flight(path, model, qj, vj, bp, bq, nu, t_end):
    """Pinocchio's ABA from the same state, integrated by DOP853 at rtol 1e-12: (qj, bp, bq) at t_end."""
    from scipy.integrate import solve_ivp

    pm = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    pm.gravity.linear = np.array([0.0, 0.0, -9.81])
    pd = pm.createData()
    names = model.urdf.joint_names()
    iq = np.array([pm.joints[pm.getJointId(n)].idx_q for n in names])
    iv = np.array([pm.joints[pm.getJointId(n)].idx_v for n in names])
    q = np.zeros(pm.nq)
    q[:3], q[3:7], q[iq] = bp, [bq[1], bq[2], bq[3], bq[0]], qj  # Pinocchio: quaternion x, y, z, w
    v = np.zeros(pm.nv)
    v[:6], v[iv] = nu, vj

    def f(_, y):
        qq, vv = y[: pm.nq].copy(), y[pm.nq :]
        qq[3:7] /= np.linalg.norm(qq[3:7])
        dq = np.zeros(pm.nq)
        x, yq, z, w = qq[3:7]
        R = pin.Quaternion(w, x, yq, z).toRotationMatrix()
        dq[:3] = R @ vv[:3]  # free-flyer velocity in the base frame
        om = vv[3:6]
        dq[3:7] = 0.5 * np.array([w * om[0] + yq * om[2] - z * om[1], w * om[1] + z * om[0] - x * om[2],
                                  w * om[2] + x * om[1] - yq * om[0], -(x * om[0] + yq * om[1] + z * om[2])])
        mask = np.ones(pm.nq, bool)
        mask[:7] = False
        dq[mask] = vv[6:]
        return np.concatenate([dq, pin.aba(pm, pd, qq, vv, np.zeros(pm.nv))])

    sol = solve_ivp(f, (0.0, t_end), np.concatenate([q, v]), method="DOP853", rtol=1e-12, atol=1e-12)
    qe = sol.y[: pm.nq, -1]
    quat = qe[3:7] / np.linalg.norm(qe[3:7])
    return qe[iq], qe[:3], np.array([quat[3], quat[0], quat[1], quat[2]])


def part_errors(q_a, q_b, nb):
    """(max rotation angle [rad], max position difference [m]) between two absolute states, per
    part: the angle of p_a⁻¹ ⊗ p_b from its vector part (2 asin |·|, exact near zero where an
    arccos of the scalar part loses half the digits)."""
    a, b = np.asarray(q_a)[: 7 * nb].reshape(nb, 7), np.asarray(q_b)[: 7 * nb].reshape(nb, 7)
    pa = a[:, 3:] / np.linalg.norm(a[:, 3:], axis=1, keepdims=True)
    pb = b[:, 3:] / np.linalg.norm(b[:, 3:], axis=1, keepdims=True)
    s0, s, t0, t = pa[:, :1], pa[:, 1:], pb[:, :1], pb[:, 1:]
    vec = s0 * t - t0 * s - np.cross(s, t)  # vector part of conj(pa) ⊗ pb
    return float(np.max(2.0 * np.arcsin(np.clip(np.linalg.norm(vec, axis=1), 0.0, 1.0)))), float(np.max(np.abs(a[:, :3] - b[:, :3])))


def check_flight(name, t_end):
    path = robot_file(ROBOTS[name][0])
    model = flight_model(name)
    system = pl.assemble(model)
    qj, vj, bp, bq, nu = flight_start(model)
    q0, v0, _ = joint_space_state(model, qj, vj, base_position=bp, base_quaternion=bq, base_velocity=nu)
    res = pl.simulate(system, t_end, t_end / 4, q0=q0, v0=v0, progress=False)
    assert res.coordinates == "joint" and isinstance(res.integrator, pl.Tsit5), res.stats["integrator_reason"]
    qj_p, bp_p, bq_p = pinocchio_flight(path, model, qj, vj, bp, bq, nu, t_end)
    q_ref, _, _ = joint_space_state(model, qj_p, base_position=bp_p, base_quaternion=bq_p)
    rot, pos = part_errors(res.q[-1], q_ref, system.topo.nbody)
    print(f"{name} free flight {t_end:g} s: max part rotation error {rot:.2e} rad, position {pos:.2e} m, {res.stats['steps']} steps")
    assert rot < FLIGHT_TOL and pos < FLIGHT_TOL, (rot, pos)


@pytest.mark.parametrize("name", ["solo12"])
def test_free_flight_matches_pinocchio_short(name):
    """0.05 s (a quarter of the issue's run) on the smallest robot: the fast suite's share (one
    Tsit5 compile of a 12-joint tree; test_free_flight_matches_pinocchio runs all six, slow)."""
    check_flight(name, 0.05)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(ROBOTS))
def test_free_flight_matches_pinocchio(name):
    check_flight(name, 0.2)


def stand_model(name):
    """The robot on its feet: SRDF standing pose, lowest foot touching the ground, foot spheres
    (Solo12's are meshes: a 1.75 cm sphere at each foot frame) with μ = 0.8 and transition
    velocities 0.1 / 1 m/s, a 1 kHz PD servo per joint with kp = m g l (l: hip to foot), kd =
    kp/20 (bench/whole_robot.py builds the same stand)."""
    urdf, srdf = ROBOTS[name]
    feet = {f"{leg}_FOOT": 0.0175 for leg in ("FL", "FR", "HL", "HR")} if name == "solo12" else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        probe = load_urdf(robot_file(urdf), feet=(), joint_stops=False)
        stance = {j: v for j, v in srdf_stand(robot_file(srdf)).items() if j in probe.urdf.joint_names()}
        model = load_urdf(robot_file(urdf), feet=feet, joint_stops=False, joint_friction=False, initial_positions=stance,
                          contact=dict(mu_static=0.8, mu_dynamic=0.8, v_stiction=0.1, v_friction=1.0))
    mass = sum(p.mass for p in model.parts)
    base = model.parts[0]
    hips = [np.asarray(j.marker_j.position) for j in model.joints if base in (j.marker_i.part, j.marker_j.part)]
    leg = max(min(np.linalg.norm(np.asarray(c.marker.position) - h) for h in hips) for c in model.contacts)
    kp = mass * 9.81 * leg
    for j in model.urdf.joint_names():
        model.add_controller(pl.PID(f"{j}.servo", j, kp=kp, kd=kp / 20.0, setpoint=stance.get(j, 0.0), period=1e-3))
    return model, mass


@pytest.mark.slow
@pytest.mark.parametrize("name", ["go1", "anymal_c", "solo12", "a1", "b1"])
def test_stand_holds_the_weight(name):
    """1 s on its feet at the defaults (joint coordinates, generalized-α with the Newton matrix
    reused): the ground carries the weight to 2 % at the end. 1 s, not the issue's 0.2 s: from
    the zero-gap start the trunk sinks onto its servos and its vertical mode (~2 Hz, damping ratio
    ~0.3 with kd = kp/20) rings for about a second: Go1's feet carried 108 % of its weight at
    0.2 s, 104 % at 0.5 s (measured); the extra 0.8 s cost a few seconds against a compile of
    minutes."""
    model, mass = stand_model(name)
    res = pl.simulate(pl.assemble(model), 1.0, 0.05, progress=False)
    assert res.coordinates == "joint" and isinstance(res.integrator, pl.GeneralizedAlpha) and res.integrator.jacobian_reuse
    fz = np.array([np.asarray(res.contact(c.name)["force"])[:, 2] for c in model.contacts])
    total = fz.sum(0)[-1]
    print(f"{name}: Fz/W at 1 s {total / (mass * 9.81):.4f}, {res.stats['steps']} steps, {res.stats['jacobians']} Jacobians")
    assert total == pytest.approx(mass * 9.81, rel=0.02)
