"""Closed form of the spoke torque sensor: each spoke an Euler–Bernoulli beam clamped in a rigid
hub and a rigid ring (seed 001 Problem 2, the hub-and-spokes concepts of Fig. 13a).

The hub (outer radius a = ``r_hub``) turns by θ relative to the ring (inner radius b =
``r_ring``); a spoke of length L = b − a, width w (``spoke_width``, in the plane of the disc, the
bending depth) and thickness t (along the axis) has its hub end moved by v = θ a tangentially and
turned by θ, its ring end held. The beam's end forces (stiffness matrix of a clamped-clamped
Euler–Bernoulli element, I = t w³ / 12):

    F_h = E I θ (12 a + 6 L) / L³,    M_h = E I θ (6 a + 4 L) / L²,

so the torque on the hub is T = n (F_h a + M_h) and the torsional stiffness

    k = T / θ = 4 n E I (3 a² + 3 a L + L²) / L³                         [N m/rad].

The bending moment along the spoke, x from the hub, is M(x) = M_h − F_h x: largest at the hub
root, zero at x₀ = L (3 a + 2 L) / (6 a + 3 L) (the inflection), −E I θ (6 a + 2 L) / L² at the
ring. The surface strain on the spoke's side face is ε(x) = M(x) w / (2 E I); the gauge reads
its mean over the grid (the FE model's 5 points over ±0.4 of the grid length,
:func:`proleg.robots.sensor_fe.torque_sensor_analysis`). The largest bending stress is
σ = 6 |M_h| / (t w²).

Not modelled (the FE has them): shear deformation (Timoshenko, a fraction 2(1 + ν)/κ (w/L)² of
the compliance), the compliance of the clamped roots in hub and ring, their fillets (stiffer,
and a stress concentration), the plate effect of a spoke thicker than wide (E / (1 − ν²) as
t/w grows) and the hub and ring's own deformation.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from .torque_sensor import DEFAULTS, GRID


def spoke_gauge_x(dims: dict) -> float:
    """Radial coordinate [m] of the gauge grid's centre on a spoke, as placed by
    :func:`proleg.robots.torque_sensor.sensor_design` from ``gauge_position``."""
    w, f = dims["spoke_width"], dims["fillet"]
    x0 = math.sqrt(max(dims["r_hub"] ** 2 - (w / 2) ** 2, 0.0)) + f + GRID["grid_length"] / 2 + 0.5e-3
    x1 = math.sqrt(dims["r_ring"] ** 2 - (w / 2) ** 2) - f - GRID["grid_length"] / 2 - 0.5e-3
    return x0 + dims["gauge_position"] * (x1 - x0)


def spoke_beam(torque: float = 140.0, *, E: float = 71.7e9, **dimensions) -> dict:
    """Stiffness, twist, peak bending stress and gauge strain of the spoke concept in closed form
    (module docstring). ``dimensions`` as for ``sensor_design("spokes", ...)`` [m]; ``E`` [Pa]
    (Ergal 7075-T6, MODEL_DATA §2).

    Returns {stiffness [N m/deg], twist [deg], max_stress [Pa], gauge_strain [-] (mean over the
    grid, magnitude), peak_strain [-] (hub root), inflection [m] (x₀ from the hub)}.
    """
    d = {**DEFAULTS["spokes"], **dimensions}
    n, w, t, a, b = int(d["n_spokes"]), d["spoke_width"], d["thickness"], d["r_hub"], d["r_ring"]
    if not (0 < a < b and w > 0 and t > 0 and n >= 1):
        raise ModelError(f"spoke_beam: need 0 < r_hub < r_ring and positive spoke_width, thickness, n_spokes; got {d}.")
    L = b - a
    EI = E * t * w**3 / 12.0
    k = 4.0 * n * EI * (3 * a * a + 3 * a * L + L * L) / L**3  # [N m/rad]
    theta = abs(torque) / k
    Fh = EI * theta * (12 * a + 6 * L) / L**3
    Mh = EI * theta * (6 * a + 4 * L) / L**2
    xg = spoke_gauge_x(d) - a
    s = np.linspace(-0.4, 0.4, 5) * GRID["grid_length"]
    eps = float(np.mean((Mh - Fh * (xg + s)) * w / (2 * EI)))
    return dict(stiffness=math.radians(1.0) * k, twist=math.degrees(theta), max_stress=6 * Mh / (t * w * w),
                gauge_strain=abs(eps), peak_strain=Mh * w / (2 * EI), inflection=L * (3 * a + 2 * L) / (6 * a + 3 * L))
