"""Co-design of a 1-DOF hopper: the push law and the body mass together (issue 30).

A body of mass m slides on a vertical prismatic joint. An actuator pushes it with a force
F(ξ) ≥ 0 over a fixed stroke s (ξ = z / s ∈ [0, 1]); beyond the stroke the force is zero and
the body flies. The force law is a chain of STEP5 segments through four knots over the
stroke (:class:`proleg.Step5Chain`), whose knot values are design variables bounded by the
actuator's rating [F_min, F_max]; the body mass m is a hardware variable in [m_min, m_max].

Closed form (energy): the take-off speed obeys ½ m v² = W − m g s with W = ∫₀ˢ F dz the
actuator's work, so v is largest with the full force throughout and the lightest body:
v*² = 2 (F_max / m_min − g) s. With the work limited to W_max < F_max s (an energy budget: a
constraint that binds) v*² = 2 (W_max / m_min − g s); a take-off before t_max larger than the
fastest push (a constraint that does not bind) changes nothing.

Run it: ``python examples/hopper_codesign.py`` (a gradient optimiser through the simulation,
then CMA-ES, both against the closed form).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

import proleg as pl

G = 9.81  # [m/s²]
STROKE = 0.1  # s [m]
F_MIN, F_MAX = 18.0, 30.0  # actuator force range [N] (F_min > m_max g: every design lifts off)
M_MIN, M_MAX = 0.8, 1.2  # body mass range [kg]
W_MAX = 2.4  # energy budget [J] (< F_max s = 3 J: binds)
T_MAX = 0.15  # take-off before [s] (the full-force push of the lightest body takes 0.085 s)
T_END = 0.3  # simulated time [s]: after every design's take-off, before any lands back


def build(knots: int = 4):
    """The hopper System and its push law (module docstring)."""
    model = pl.Model("hopper", gravity=(0, 0, -G))
    body = model.add_part("body", mass=1.0, inertia=(1e-3, 1e-3, 1e-3), position=(0, 0, 0))
    model.add_joint(pl.Prismatic("slide", model.ground, body, at=(0, 0, 0), axis=(0, 0, 1)))
    law = model.add_law(pl.Step5Chain("push", np.linspace(0.0, 1.0, knots), [0.5 * (F_MIN + F_MAX)] * knots, unit="N"))

    def push(t, state):
        z = state.position("body")[2]
        return jnp.stack([0.0, 0.0, jnp.where(z < STROKE, law.at(z / STROKE, state), 0.0)])

    model.add_force(pl.Force("actuator", body, push))
    return pl.assemble(model), law


def work(r):
    """W = ½ m v² + m g z at the end [J]: the actuator's work (the body starts at rest at z = 0)."""
    m = r.system.params["body_mass"][0]
    z, vz = r.part("body").position[-1, 2], r.part("body").velocity[-1, 2]
    return 0.5 * m * vz**2 + m * G * z


def takeoff_speed(r):
    """v at the end of the stroke [m/s], from the energy: ½ m v² = W − m g s."""
    m = r.system.params["body_mass"][0]
    return jnp.sqrt(2.0 * (work(r) / m - G * STROKE))


def takeoff_time(r):
    """First time z reaches the stroke [s], linear between output samples (traceable)."""
    z, t = r.part("body").position[:, 2], jnp.asarray(r.t)
    k = jnp.clip(jnp.argmax(z >= STROKE), 1, z.shape[0] - 1)
    return t[k - 1] + (STROKE - z[k - 1]) / (z[k] - z[k - 1]) * (t[k] - t[k - 1])


def study(knots: int = 4):
    """The co-design study: the push law's knots and the body mass, three outputs."""
    system, law = build(knots)
    space = {**law.space(F_MIN, F_MAX), "body.mass": (M_MIN, M_MAX)}
    outputs = {"takeoff_speed": takeoff_speed, "work": work, "takeoff_time": takeoff_time}
    kw = dict(t_end=T_END, dt_output=2e-3, integrator=pl.GeneralizedAlpha(rtol=1e-8, atol=1e-10))
    return pl.study.Study(system, space, outputs, simulate=kw, name="hopper"), law


def closed_form(w_max: float | None = None) -> float:
    """The optimal take-off speed [m/s] (module docstring)."""
    w = F_MAX * STROKE if w_max is None else min(w_max, F_MAX * STROKE)
    return float(np.sqrt(2.0 * (w / M_MIN - G * STROKE)))


def main():
    st, law = study()
    start = {**{k: 0.5 * (F_MIN + F_MAX) for k in law.variables}, "body.mass": 1.0}
    ref = st.refine(start, "takeoff_speed", direction="maximize", constraints={"takeoff_time": ("<=", T_MAX)})
    print(f"gradient (L-BFGS-B/SLSQP): v = {ref['value']:.5f} m/s, closed form {closed_form():.5f}; binding {ref['binding']}")
    ref = st.refine(start, "takeoff_speed", direction="maximize", constraints={"work": ("<=", W_MAX), "takeoff_time": ("<=", T_MAX)})
    print(f"with W <= {W_MAX} J: v = {ref['value']:.5f} m/s, closed form {closed_form(W_MAX):.5f}; binding {ref['binding']}")
    opt = st.optimize("takeoff_speed", n_trials=128, sampler="cma", direction="maximize", batch=8, executor="vmap", seed=0)
    print(f"CMA-ES: v = {opt.best_value:.5f} m/s, closed form {closed_form():.5f}")


if __name__ == "__main__":
    main()
