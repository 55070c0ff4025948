"""Local error estimates of generalized-α and HHT (solvers/galpha.py, "Velocity error").

The coefficients are checked against the scheme's own local error on q̈ = f(t) (the update is
then explicit, so the exact local error of one step is available), and the velocity term is
checked to buy accuracy on the undamped double pendulum.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import proleg as pl
from proleg.errors import ModelError

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
from common import build_chain  # noqa: E402


def _alpha_method(integrator):
    """(α_m, α_f, γ, β) of the α-method form (1 − α_m) a₊ + α_m a = (1 − α_f) q̈₊ + α_f q̈."""
    am, af, gamma, beta = integrator.coefficients
    if integrator.hht:  # HHT: α_m = 0, α_f = −α (accelerations at t + αh)
        return 0.0, -integrator.alpha, gamma, beta
    return am, af, gamma, beta


def _local_errors(integrator, h, t_check=1.0):
    """One step of the α-method on q(t) = exp(sin t) (q̈ = f(t) prescribed), started from the exact
    (q, v) at t_check with the scheme's own acceleration history (f does not depend on q, so
    the a sequence is that of the scheme; started at t = 0 with a₀ = q̈(0), its transient has
    decayed by t_check). Returns (position error, velocity error, q⃛ h³, q⁗ h³, the jerk of
    this step and of the last, (a₊ − a)/h)."""
    am, af, gamma, beta = _alpha_method(integrator)

    def q(t):
        return math.exp(math.sin(t))

    def d(k, t, eps=1e-3):  # k-th derivative by a 9-point central stencil (enough for a ratio)
        from numpy.polynomial import polynomial as P

        ts = t + eps * np.arange(-4, 5)
        c = P.polyfit(ts - t, [q(s) for s in ts], 8)
        return math.factorial(k) * c[k]

    n = int(round(t_check / h))
    a, t = d(2, 0.0), 0.0
    jerks = []
    for _ in range(n + 1):
        a1 = (-am * a + (1 - af) * d(2, t + h) + af * d(2, t)) / (1 - am)
        jerks.append((a1 - a) / h)
        if len(jerks) == n + 1:
            break
        a, t = a1, t + h
    qn, vn = q(t), d(1, t)
    q1 = qn + h * vn + h * h * ((0.5 - beta) * a + beta * a1)
    v1 = vn + h * ((1 - gamma) * a + gamma * a1)
    return q(t + h) - q1, d(1, t + h) - v1, d(3, t) * h**3, d(4, t) * h**3, jerks[-1], jerks[-2]


@pytest.mark.parametrize(
    "integrator", [pl.GeneralizedAlpha(0.8), pl.GeneralizedAlpha(0.5), pl.HHT(-0.05), pl.HHT(-0.3)], ids=["ga0.8", "ga0.5", "hht0.05", "hht0.3"]
)
def test_error_coefficients_are_the_schemes_local_errors(integrator):
    """Position error = −C h³q⃛ (the estimate e = C h²(a₊ − a)) and velocity error = C_v h³q⁗
    to O(h⁴); and the divided difference of two jerks, h³·2(j₊ − j)/(2h),
    estimates h³q⁗. Tolerance 3 % at h = 2e-3: the O(h) remainder of each ratio."""
    h = 2e-3
    eq, ev, q3, q4, j1, j0 = _local_errors(integrator, h)
    assert abs(eq) == pytest.approx(abs(integrator.error_coefficient * q3), rel=0.03)
    assert ev == pytest.approx(integrator.velocity_error_coefficient * q4, rel=0.03)
    assert h**3 * (j1 - j0) / h == pytest.approx(q4, rel=0.03)


def test_velocity_term_is_third_order():
    """The velocity local error falls as h³ (ratio 8 per halving, within 3 %)."""
    ga = pl.GeneralizedAlpha(0.8)
    e1 = _local_errors(ga, 4e-3)[1]
    e2 = _local_errors(ga, 2e-3)[1]
    assert e1 / e2 == pytest.approx(8.0, rel=0.03)


def test_error_on_is_validated():
    with pytest.raises(ModelError, match="error_on"):
        pl.GeneralizedAlpha(error_on="velocities")
    with pytest.raises(ModelError, match="velocity_time_scale"):
        pl.HHT(velocity_time_scale=0.0)


def test_velocity_term_reduces_the_energy_error_of_the_double_pendulum():
    """Undamped double pendulum (planar coordinates, an index-3 DAE), 2 s at rtol 1e-5: the
    velocity term (projected on the constraints) gives a smaller energy error than positions
    alone, by more than 3× (measured ~5–10× at 10 s, bench/galpha_error.py), without failing."""
    system = pl.assemble(build_chain(2))

    def energy_error(mode):
        ig = pl.GeneralizedAlpha(rtol=1e-5, atol=1e-6, error_on=mode)
        r = pl.simulate(system, t_end=2.0, dt_output=0.01, integrator=ig, progress=False)
        E = np.asarray(r.energy["kinetic"]) + np.asarray(r.energy["potential"])
        return np.abs(E - E[0]).max() / np.asarray(r.energy["kinetic"]).max(), r.stats["steps"]

    (ep, sp), (ev, sv) = energy_error("positions"), energy_error("positions+velocities")
    assert ev < ep / 3
    assert sv < 4 * sp
