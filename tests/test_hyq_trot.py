"""HyQ trot (robots/hyq_trot.py, control/gait.py): the cylinder mounting against the lever
geometry, the gait schedule, and a short trot of the whole robot (diagonal feet alternate, the
trunk stays up). The full 8 s runs and their figures are in bench/hyq_trot.py and
``proleg run hyq-trot``."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("yourdfpy", reason="yourdfpy is not installed: pip install -e .[test]")

from proleg.control.gait import LEG_OFFSET, Trot  # noqa: E402
from proleg.errors import ModelError  # noqa: E402
from proleg.robots import hyq_data as D  # noqa: E402
from proleg.robots.hyq_trot import piston_kinematics  # noqa: E402


def test_piston_kinematics_is_the_lever_geometry():
    """x(q) stays inside the 80 mm stroke over the URDF ranges (front legs mirrored), and
    dx/dq is its derivative (jax.grad vs the closed-form lever arm ±l(θ) of MODEL_DATA §1)."""
    names = ["lf_hfe_joint", "lf_kfe_joint", "lh_hfe_joint", "lh_kfe_joint"]
    piston = piston_kinematics(names, 0.080)
    lo = np.deg2rad([-50.0, -140.0, -70.0, 20.0])  # URDF ranges: front HFE −50…70°, KFE −140…−20°; hind mirrored
    hi = np.deg2rad([70.0, -20.0, 50.0, 140.0])
    for q in (lo, hi, 0.5 * (lo + hi)):
        x, dx = piston(jnp.asarray(q))
        assert np.all(np.asarray(x) >= 0.001 - 1e-6) and np.all(np.asarray(x) <= 0.079 + 1e-6)
        g = jax.jacfwd(lambda q: piston(q)[0])(jnp.asarray(q))
        np.testing.assert_allclose(np.diag(np.asarray(g)), np.asarray(dx), rtol=1e-9)
        th = np.array([-q[0], -q[1], q[2], q[3]])
        lever = np.array([D.hip_lever_arm(th[0]), D.knee_lever_arm(th[1]), D.hip_lever_arm(th[2]), D.knee_lever_arm(th[3])])
        np.testing.assert_allclose(np.abs(np.asarray(dx)), lever, rtol=1e-12)
    with pytest.raises(ModelError, match="stroke"):
        piston_kinematics(names, 0.05)


def test_trot_schedule_pairs_and_duty():
    g = Trot(period=0.5, duty=0.6, t_start=0.5, ramp=2.0)
    t = np.linspace(0.5, 2.5, 4001)
    st = {leg: np.array([bool(g.phase(tt, LEG_OFFSET[leg])[0]) for tt in t]) for leg in LEG_OFFSET}
    assert np.array_equal(st["lf"], st["rh"]) and np.array_equal(st["rf"], st["lh"])
    assert st["lf"].mean() == pytest.approx(0.6, abs=2e-3)
    assert not np.any(~st["lf"] & ~st["rf"])  # a pair always stands (duty > 0.5)
    assert all(bool(g.phase(0.2, LEG_OFFSET[leg])[0]) for leg in LEG_OFFSET)  # all stand before t_start
    assert float(g.commanded_speed(0.4)) == 0.0 and float(g.commanded_speed(1.5)) == pytest.approx(0.5) and float(g.commanded_speed(9.0)) == 1.0


def _check_trot(run, t_from, min_checked=2, min_advance=0.05):
    """Diagonal feet alternate: in mid-swing of each pair (schedule), its feet carry < 2 % of the
    weight and the other pair's feet more than a quarter each; the trunk stays up and goes forward."""
    res, g = run.result, run.gait
    t = np.asarray(res.t)
    fz = {leg: np.asarray(res.contact(f"{leg}_foot.contact")["normal_force"]) for leg in LEG_OFFSET}
    weight = res.system.topo.model.trot["mass"] * 9.81
    checked = {0: 0, 1: 0}
    for k, tk in enumerate(t):
        if tk < t_from:
            continue
        for ip, (pair, other) in enumerate(((("lf", "rh"), ("rf", "lh")), (("rf", "lh"), ("lf", "rh")))):
            stance, _, s_sw = g.phase(tk, LEG_OFFSET[pair[0]])
            if not bool(stance) and 0.4 < float(s_sw) < 0.6:
                checked[ip] += 1
                assert all(fz[leg][k] < 0.02 * weight for leg in pair), (tk, pair, [fz[leg][k] for leg in pair])
                assert all(fz[leg][k] > 0.25 * weight for leg in other), (tk, other, [fz[leg][k] for leg in other])
    assert min(checked.values()) >= min_checked, checked  # mid-swing samples checked, of each pair
    m = run.metrics
    assert not m["fell"] and m["base_height_min"] > 0.5
    assert np.asarray(res.part("base_link").position)[-1, 0] - np.asarray(res.part("base_link").position)[0, 0] > min_advance


def test_short_trot_torque_sources():
    """Reduced trot, fast-suite size (0.7 s: 0.1 s standing, then one stride of 0.5 s, each
    diagonal pair swinging once, the speed ramped over 0.5 s; outputs every 10 ms): ideal torque
    sources. Diagonal feet alternate and the trunk stays up (the compile, ~50 s at load 0, is
    most of its time; the 1.2 s run is test_short_trot_torque_sources_long, slow)."""
    from proleg.robots.hyq_trot import hyq_trot

    run = hyq_trot(t_end=0.7, actuators="torque", gait=Trot(t_start=0.1, ramp=0.5), dt_output=0.01)
    _check_trot(run, 0.15, min_advance=0.02)
    assert run.metrics["max_joint_torque"] <= 150.0 + 1e-9


@pytest.mark.slow
def test_short_trot_torque_sources_long():
    """Reduced trot (1.2 s: 0.2 s standing, then stepping with the speed ramp): ideal torque sources."""
    from proleg.robots.hyq_trot import hyq_trot

    run = hyq_trot(t_end=1.2, actuators="torque", gait=Trot(t_start=0.2, ramp=1.0))
    _check_trot(run, 0.3)
    assert run.metrics["max_joint_torque"] <= 150.0 + 1e-9


@pytest.mark.slow
def test_short_trot_hydraulic():
    """The same reduced trot on the hydraulic cylinders: chamber pressures within [0, p_s]."""
    from proleg.robots.hyq_trot import hyq_trot

    run = hyq_trot(t_end=1.2, actuators="hydraulic", gait=Trot(t_start=0.2, ramp=1.0))
    _check_trot(run, 0.3)
    m = run.metrics
    assert 0.0 <= m["min_chamber_pressure"] and m["max_chamber_pressure"] <= m["supply_pressure"]


def test_trot_report_pressure_figures_show_all_eight_cylinders():
    """The trot report's pressure and flow figures have one panel per leg and joint (4 × 2), each
    with the A and B chambers of its cylinder (item 3 of issue 33: it showed two cylinders)."""
    import matplotlib

    matplotlib.use("Agg")
    from types import SimpleNamespace

    from proleg.papers.hyq_trot_report import pressure_figures
    from proleg.report import Report
    from proleg.robots.hyq import LEGS

    names = [f"{leg}_{k}_joint" for leg in LEGS for k in ("hfe", "kfe")]
    t = np.linspace(0.0, 1.0, 11)
    ho = {k: np.outer(t, np.arange(1.0, 9.0)) * 1e6 for k in ("pressure_a", "pressure_b")}
    ho.update({k: np.outer(t, np.arange(1.0, 9.0)) * 1e-5 for k in ("flow_a", "flow_b", "supply_flow")})
    ho.update(supply=SimpleNamespace(pressure=16e6), cylinder=SimpleNamespace(cavitation_pressure=0.0))
    rep, seen = Report("t"), []
    rep.add_figure = lambda fig, caption="": seen.append(([ax.get_title() for ax in fig.axes], [len(ax.lines) for ax in fig.axes]))
    pressure_figures(rep, t, ho, names)
    titles, lines = seen[0]
    assert sorted(titles) == sorted(f"{leg} {k}" for leg in LEGS for k in ("HFE", "KFE"))
    assert all(n == 4 for n in lines)  # p_A, p_B, the supply and the cavitation floor
    assert len(seen[1][0]) == 8 and all(n == 2 for n in seen[1][1])  # Q_A, Q_B
