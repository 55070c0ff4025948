"""HyQ leg design study: the drop test of the 8-bushing leg against the pins' radial bushing
stiffness (the hierarchy sweep of the drop report, seed 001), as a :class:`proleg.study.Study`
with a resumable store and its HTML report (``proleg run hyq-bushing-study``). The drop
report's hierarchy sweep runs the same study (:func:`hierarchy_rows`), with the RMS difference
from the rigid leg's forces as two more outputs.

The stiffness is one scalar k [N/m] for every pin: each bushing's 6×6 stiffness and damping
are the nominal ones scaled by k / k_nominal — the same variant as
:func:`~proleg.papers.hyq_tests.variant_system` (damping proportional to stiffness,
``BUSHING_DAMPING_BETA``), written with jnp so that every variant runs in one vmap batch.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

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


class RmsVsReference:
    """Output: RMS difference [N] between a cylinder's axial force and a reference record of it
    at the same output times (the first ``len(result.t)`` samples of ``reference`` [N])."""

    def __init__(self, side: str, reference):
        self.side, self.reference = side, np.asarray(reference, float)

    def __call__(self, r):
        f = np.asarray(r.element(f"{self.side}_actuator").axial_force)
        if len(self.reference) < len(f):
            raise ValueError(f"the reference {self.side} force has {len(self.reference)} samples, the variant {len(f)}")
        return float(np.sqrt(np.mean((f - self.reference[: len(f)]) ** 2)))


def bushing_study(
    *, t_end: float = SWEEP_T_END, gain: str = "high", drop_height: float = 0.05, k_range=(1e6, 1e10), reference=None, system=None,
) -> Study:
    """The study: 8-bushing HyQ leg drop, ``pin_stiffness`` in a log range, peak cylinder forces.

    ``reference``: optional rigid-leg record (a table with ``hip force [N]`` and ``knee force
    [N]`` at the study's output times, 1 ms from 0): adds the outputs ``rms_hip_vs_rigid`` and
    ``rms_knee_vs_rigid`` [N]. ``system``: the assembled 8-bushing leg, if already built."""
    from ..assembly.assemble import assemble
    from ..robots.hyq_leg import hyq_leg

    if system is None:
        system = assemble(hyq_leg(joints="bushings8", gain=gain, drop_height=drop_height, actuators="drop"))
    outputs = {"peak_hip_force": peak_hip_force, "peak_knee_force": peak_knee_force}
    if reference is not None:
        outputs["rms_hip_vs_rigid"] = RmsVsReference("hip", reference["hip force [N]"])
        outputs["rms_knee_vs_rigid"] = RmsVsReference("knee", reference["knee force [N]"])
    return Study(
        system, space={"pin_stiffness": LogRange(*k_range)},
        outputs=outputs,
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
    table = study.run(design="grid", n=n, executor=executor, store=out, progress=progress, **run_kw)
    table.to_csv(out / "table.csv", index=False)
    table.to_parquet(out / "table.parquet", index=False)
    return study_report(out, out / "report.html")


def hierarchy_rows(stiffness, rigid, *, gain: str = "high", drop_height: float = 0.05, system=None, batch_size: int | None = 2) -> dict:
    """The drop report's hierarchy sweep through the study: {k: {"peak hip force [N]", "peak
    knee force [N]", "RMS Δ hip vs rigid [N]", "RMS Δ knee vs rigid [N]", "steps", "wall time
    [s]"}} for each pin stiffness ``k`` [N/m], against the ``rigid`` leg's channels. Vmap
    batches of ``batch_size`` neighbouring stiffnesses, one batch at a time: a batch steps
    until its slowest variant is done, and the soft pins take ~3× the steps of the stiff ones
    (1,624 at 1e6 N/m, 480 at 1e10 N/m)."""
    st = bushing_study(gain=gain, drop_height=drop_height, reference=rigid, system=system)
    tab = st.run(design={"pin_stiffness": sorted(stiffness)}, workers=1, batch_size=batch_size, progress=False)
    bad = tab[tab["status"] != "success"]
    if len(bad):
        from ..errors import SolverError

        raise SolverError(f"hierarchy sweep: pin stiffness {bad['pin_stiffness'].tolist()} failed: {bad['reason'].tolist()}")
    return {
        float(r["pin_stiffness"]): {
            "peak hip force [N]": r["peak_hip_force"], "peak knee force [N]": r["peak_knee_force"],
            "RMS Δ hip vs rigid [N]": r["rms_hip_vs_rigid"], "RMS Δ knee vs rigid [N]": r["rms_knee_vs_rigid"],
            "steps": int(r["steps"]), "Newton iterations": int(r["newton_iterations"]), "wall time [s]": r["wall_s"],
        }
        for r in tab.to_dict("records")
    }


__all__ = ["bushing_study", "run_bushing_study", "pin_stiffness_apply", "hierarchy_rows"]
