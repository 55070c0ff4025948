"""HyQ leg design study: the drop test of the 8-bushing leg against the pins' radial bushing
stiffness (the hierarchy sweep of the drop report, seed 001), as a :class:`proleg.study.Study`
with a resumable store and its HTML report (``proleg run hyq-bushing-study``).

The stiffness is one scalar k [N/m] for every pin: each bushing's 6×6 stiffness and damping
are the nominal ones scaled by k / k_nominal — the same variant as
:func:`~proleg.robots.hyq_tests.variant_system` (damping proportional to stiffness,
``BUSHING_DAMPING_BETA``), written with jnp so that every variant runs in one vmap batch.
"""

from __future__ import annotations

from pathlib import Path

from ..study import LogRange, Study

SWEEP_T_END = 0.35  # [s] first impact and the rebound (hyq_report.SWEEP_T_END)


def pin_stiffness_apply(system, values):
    """Traceable: ``system`` with every pin bushing at radial stiffness ``pin_stiffness`` [N/m]
    (stiffness and damping matrices scaled from the nominal ones) and any other values by name."""
    import jax.numpy as jnp

    values = dict(values)
    k = values.pop("pin_stiffness")
    k0 = system.params["bushing_stiffness"][0, 0, 0]
    s = jnp.asarray(k, jnp.float64) / k0
    upd = {"bushing_stiffness": system.params["bushing_stiffness"] * s, "bushing_damping": system.params["bushing_damping"] * s, **values}
    return system.with_params(upd)


def peak_hip_force(r):
    """Peak |hip cylinder axial force| [N]."""
    return abs(r.element("hip_actuator").axial_force).max()


def peak_knee_force(r):
    """Peak |knee cylinder axial force| [N]."""
    return abs(r.element("knee_actuator").axial_force).max()


def bushing_study(*, t_end: float = SWEEP_T_END, gain: str = "high", drop_height: float = 0.05, k_range=(1e6, 1e10)) -> Study:
    """The study: 8-bushing HyQ leg drop, ``pin_stiffness`` in a log range, peak cylinder forces."""
    from ..assembly.assemble import assemble
    from .hyq_leg import hyq_leg

    system = assemble(hyq_leg(joints="bushings8", gain=gain, drop_height=drop_height, actuators="drop"))
    return Study(
        system, space={"pin_stiffness": LogRange(*k_range)},
        outputs={"peak_hip_force": peak_hip_force, "peak_knee_force": peak_knee_force},
        # the drop test's solver options (hyq_tests.drop_test)
        simulate=dict(t_end=t_end, dt_output=1e-3, dt_max=1e-3, rtol=1e-6, atol=1e-7),
        apply=pin_stiffness_apply, name="hyq-bushing-study",
    )


def run_bushing_study(out_dir="results/hyq-bushing-study", progress: bool = True, *, n: int = 9, executor: str = "vmap", **run_kw) -> Path:
    """Run (or resume) the study on a log grid of ``n`` stiffnesses from 1e6 to 1e10 N/m into
    ``out_dir`` (store + report.html); returns the report path."""
    from ..study.report import study_report

    out = Path(out_dir)
    study = bushing_study()
    # One batch at a time: two concurrent vmap batches of this model hung (every thread waiting
    # on a futex, no CPU) in sweep's threaded path on the 2-core VM; one batch runs.
    run_kw.setdefault("workers", 1)
    table = study.run(design="grid", n=n, executor=executor, store=out, progress=progress, **run_kw)
    table.to_csv(out / "table.csv", index=False)
    return study_report(out, out / "report.html")


__all__ = ["bushing_study", "run_bushing_study", "pin_stiffness_apply"]
