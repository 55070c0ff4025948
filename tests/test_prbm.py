"""PRB 1R model: seed-002 worked example, elastica comparison, model insertion, CLI."""

import json
import math

import numpy as np
import pytest
import typer
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from typer.testing import CliRunner

import proleg
from proleg.errors import ModelError
from proleg.flex import (
    PRBMLink,
    dynamic_prbm,
    elastica_tip,
    prbm_coefficients,
    prbm_static,
    static_prbm,
    tip_position,
)
from proleg.flex.prbm import THETA_MAX_VERTICAL

# seed 002, case 6: 300 x 50 x 3 mm AISI 304 (E = 200 GPa, rho = 7800), P = 30 N, xi = 0.015
L, W, T, P, XI = 0.3, 0.05, 0.003, 30.0, 0.015
EI = 200e9 * W * T**3 / 12
NMM_PER_DEG = 1e-3 / (math.pi / 180)  # 1 N mm/deg in N m/rad


def test_first_bending_frequency_eq3():
    link = PRBMLink.from_gamma(0.7377, L, W, T, "aisi304", XI)
    assert link.omega_1 == pytest.approx(171.3194, abs=5e-5)  # printed digits
    assert link.omega_1 / (2 * math.pi) == pytest.approx(27.2663, abs=5e-5)  # the "27.2663 deg/s" is Hz
    assert math.sqrt(link.K_t / link.J) == pytest.approx(link.omega_1, rel=1e-12)  # Eq. 9
    assert link.C_t / (2 * math.sqrt(link.K_t * link.J)) == pytest.approx(XI, rel=1e-12)  # Eq. 11


def test_worked_example_numbers_from_printed_gamma():
    # gamma is printed to 4 digits; J ~ gamma^3 carries its rounding (0.5e-4 / 0.7377 x 3 = 2e-4)
    link = PRBMLink.from_gamma(0.7377, L, W, T, "aisi304", XI)
    assert link.J == pytest.approx(4226.8e-6, rel=3e-4)
    assert link.K_t == pytest.approx(2165.2 * NMM_PER_DEG, rel=3e-4)
    assert link.C_t == pytest.approx(0.3792 * NMM_PER_DEG, rel=3e-4)


def test_nonlinear_system_reproduces_the_paper():
    # b = 11.82 mm (printed "approximately 12 mm") reproduces every printed digit
    link = dynamic_prbm(L, W, T, "aisi304", load=P, deflection=11.82e-3, damping_ratio=XI)
    assert link.gamma == pytest.approx(0.7377, abs=5e-5)
    assert link.J == pytest.approx(4226.8e-6, rel=5e-5)
    assert link.K_t == pytest.approx(2165.2 * NMM_PER_DEG, rel=5e-5)
    assert link.C_t == pytest.approx(0.3792 * NMM_PER_DEG, rel=2e-4)
    assert link.deflection(P) == pytest.approx(11.82e-3, rel=1e-10)  # Eq. 8 is satisfied
    # the CLI example's 11.8 mm: gamma within 1 %
    assert dynamic_prbm(L, W, T, "aisi304", P, 11.8e-3, XI).gamma == pytest.approx(0.7377, rel=0.01)
    # b = 12.00 mm is the linear P L^3 / (3 E I) and does NOT reproduce the printed gamma
    assert P * L**3 / (3 * EI) == pytest.approx(12e-3, rel=1e-12)
    assert dynamic_prbm(L, W, T, "aisi304", P, 12e-3, XI).gamma == pytest.approx(0.7265, abs=1e-4)


def test_elastica_against_shooting_and_linear_limit():
    # small load: b -> P L^3 / (3 E I), a -> L
    a, b, _ = elastica_tip(0.01, L, EI)
    assert b == pytest.approx(0.01 * L**3 / (3 * EI), rel=1e-6)
    # large load: EI theta'' = -P cos(theta), theta(0) = 0, theta'(L) = 0, by shooting
    load = 3.0 * EI / L**2
    a, b, th0 = elastica_tip(load, L, EI)
    alpha2 = load * L**2 / EI

    def shoot(k0):
        rhs = lambda s, y: [y[1], -alpha2 * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])]  # noqa: E731
        return solve_ivp(rhs, [0, 1], [0, k0, 0, 0], rtol=1e-12, atol=1e-12).y[:, -1]

    y = shoot(brentq(lambda k: shoot(k)[1], 0.0, alpha2))
    assert [a / L, b / L, th0] == pytest.approx([y[2], y[3], y[0]], abs=1e-8)


def test_prbm_path_within_half_percent_of_elastica():
    # Howell's criterion: the PRB tip path (circle of radius gamma L about the pivot) stays within
    # 0.5 % of L of the elastica tip path for Theta up to 64.3 deg (transverse force, n = 0)
    c = prbm_coefficients(0.0)
    worst, theta_max = 0.0, 0.0
    for load in np.geomspace(0.05, 9.0, 60) * EI / L**2:
        a, b, _ = elastica_tip(load, L, EI)
        Theta = math.atan2(b, a - (1 - c.gamma) * L)
        if Theta > THETA_MAX_VERTICAL:
            break
        theta_max = Theta
        worst = max(worst, abs(math.hypot(a - (1 - c.gamma) * L, b) - c.gamma * L) / L)
        ap, bp = tip_position(c.gamma, Theta, L)
        assert math.hypot(ap - a, bp - b) == pytest.approx(abs(math.hypot(a - (1 - c.gamma) * L, b) - c.gamma * L))
    assert theta_max > math.radians(60)
    assert worst < 0.005


def test_prbm_load_deflection_against_elastica():
    # at equal load: K_Theta = 2.65 is a range average (exact small-deflection value 3 gamma = 2.555),
    # so the PRB tip is within 1.6 % of L of the elastica over 0 < Theta <= 64.3 deg
    worst = 0.0
    for load in np.linspace(0.1, 5.5, 40) * EI / L**2:
        Theta, a, b, _ = prbm_static(load, L, EI)
        if Theta > THETA_MAX_VERTICAL:
            break
        ae, be, _ = elastica_tip(load, L, EI)
        worst = max(worst, math.hypot(a - ae, b - be) / L)
    assert worst < 0.016
    # Eq. 2 for the classical link
    link = static_prbm(L, W, T, "aisi304")
    assert link.K_t == pytest.approx(0.8517 * 2.65 * EI / L, rel=1e-12)


def test_load_direction_coefficients():
    c0 = prbm_coefficients(0.0)
    assert (c0.gamma, c0.c_theta, c0.K_Theta) == (0.8517, 1.2385, 2.65)
    # Howell's piecewise gamma fit is continuous at n = -1.8316
    assert prbm_coefficients(-1.8316 + 1e-9).gamma == pytest.approx(prbm_coefficients(-1.8316 - 1e-9).gamma, abs=1e-5)
    assert prbm_coefficients(1.0).c_theta == pytest.approx(1.2467)
    # a compressive axial component (n > 0) bends the beam further under the same transverse load
    load = 1.0 * EI / L**2
    assert prbm_static(load, L, EI, n=1.0)[2] > prbm_static(load, L, EI, n=0.0)[2] > prbm_static(load, L, EI, n=-1.0)[2]
    with pytest.raises(ModelError, match="n = 20"):
        prbm_coefficients(20.0)


def test_to_model_inserts_two_segments_pivot_and_spring():
    link = dynamic_prbm(L, W, T, "aisi304", P, 11.82e-3, XI)
    model = proleg.Model("flegx")
    shank = model.add_part("shank", 0.165, (1e-4, 1e-4, 1e-4), (0, 0, 0.4))
    at = np.array([0.0, 0.0, 0.3])
    out = link.to_model(model, shank, at=at, axis=(0, 1, 0), direction=(0, 0, -1), name="lower")
    base, tip = model.part("lower.base"), model.part("lower.tip")
    m = 7800 * L * W * T
    assert base.mass + tip.mass == pytest.approx(m, rel=1e-12)
    assert tip.mass == pytest.approx(link.gamma * m, rel=1e-12)
    pivot = at + (1 - link.gamma) * L * np.array([0, 0, -1])
    assert np.allclose(model.joint("lower.pivot").at, pivot)
    assert isinstance(out["pivot"], proleg.Revolute) and isinstance(out["clamp"], proleg.Fixed)
    assert np.allclose(tip.position, pivot + 0.5 * link.gamma * L * np.array([0, 0, -1]))
    # the tip segment about the pivot axis has exactly the J of Eq. 10
    d = tip.position - pivot
    assert tip.inertia[1, 1] + tip.mass * (d @ d) == pytest.approx(link.J, rel=1e-12)
    spring = model.force("lower.spring")
    assert isinstance(spring, proleg.RotationalSpringDamper)
    assert (spring.stiffness, spring.damping) == (link.K_t, link.C_t)
    assert spring.joint is model.joint("lower.pivot")
    assert np.allclose(model.marker("lower.tip").position, at - np.array([0, 0, L]))
    with pytest.raises(ModelError, match="perpendicular"):
        link.to_model(model, shank, at=at, axis=(0, 0, 1), name="other")


def test_bad_input_errors():
    with pytest.raises(ModelError, match="thickness"):
        dynamic_prbm(L, W, -T, "aisi304", P, 0.01)
    with pytest.raises(ModelError, match="deflection"):
        dynamic_prbm(L, W, T, "aisi304", P, 11.8)  # mm given as m
    with pytest.raises(ModelError, match="gamma"):
        PRBMLink.from_gamma(1.2, L, W, T, "aisi304")
    with pytest.raises(ModelError, match="Unknown material 'steal'"):
        dynamic_prbm(L, W, T, "steal", P, 0.01)


@pytest.fixture
def cli_app():
    from proleg.cli.prbm import register

    app = typer.Typer()
    register(app)

    @app.command()
    def version():  # a second command so that "prbm" is a subcommand, as in the real app
        pass

    return app


def test_cli_json(cli_app):
    args = ["prbm", "--length", "300mm", "--width", "50 mm", "--thickness", "0.003m", "--material", "aisi304",
            "--load", "30N", "--deflection", "11.82mm", "--damping-ratio", "0.015", "--json"]
    res = CliRunner().invoke(cli_app, args)
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert set(data) == {"gamma", "K_t", "C_t", "J", "omega_1", "K_Theta", "c_theta"}
    assert data["gamma"] == pytest.approx(0.7377, abs=5e-5)
    assert data["K_t"] == pytest.approx(2165.2 * NMM_PER_DEG, rel=5e-5)
    assert data["J"] == pytest.approx(4226.8e-6, rel=5e-5)
    assert data["omega_1"] == pytest.approx(171.3194, abs=5e-5)


def test_cli_table_and_errors(cli_app):
    res = CliRunner().invoke(cli_app, ["prbm", "--length", "300mm", "--width", "50mm", "--thickness", "3mm",
                                       "--deflection", "11.8mm"])
    assert res.exit_code == 0, res.output
    assert "gamma" in res.output and "0.73892" in res.output and "N mm/deg" in res.output
    res = CliRunner().invoke(cli_app, ["prbm", "--length", "300 furlongs", "--width", "50mm", "--thickness", "3mm"])
    assert res.exit_code == 2 and "furlongs" in res.output
