"""Belt and pulley stage with load- and speed-dependent losses (issue 31; seed 003 Table 3, §4.2).

Convention as :mod:`proleg.drives.gears`: the stage has an input (driving pulley) and an output
(driven pulley, the leg); ω_in = ratio · ω_out. ``tau_in`` is the torque the stage receives at
its input *referred to the output* (ratio · torque at the driving pulley), so the law below is
written at the output shaft, speed ω = ω_out.

Loss law (the two loss mechanisms of a belt drive):

- **tension-dependent**: bearing friction of the pulley shafts and tooth/flank friction grow
  with the belt tension, and the tension with the transmitted torque: a fraction (1 − η) of the
  transmitted power, taken the Coulomb way (as :class:`~proleg.drives.gears.GearTrain`: the
  output gets η τ_in when the input drives, and the input gets η of the output's power when the
  load back-drives it);
- **no-load drag**: bending hysteresis of the belt around the pulleys and seal drag, present at
  zero load and growing with speed: τ_0 tanh(ω / ω_s) + c_v ω at the output shaft, opposing
  the motion whatever the direction of power flow.

Forward (τ_in ω ≥ 0, the input drives)::      τ_out = η τ_in − τ_d(ω)
Backward (τ_in ω < 0, the load back-drives)::  τ_out = τ_in / η − τ_d(ω)

The power the stage takes, τ_in ω − τ_out ω = (1 − η) τ_in ω + τ_d ω (forward) or
(1/η − 1)(−τ_in ω) + τ_d ω (backward), is never negative. The effective efficiency
τ_out / τ_in = η − τ_d / τ_in (forward) rises with the load towards η and falls with speed.

Values for Scout II (seed 003 Table 3: "belt and pulley efficiency 96 %", one number): timing-belt
catalogues give 94–98 % at rated load (e.g. Gates, *Synchronous belt drive design manual*:
"95–98 %"). 
:func:`scout2_belt` reads the 96 % as the efficiency at the drive's full torque and
splits it into 97 % tension-dependent and 1 % of the full leg torque as no-load drag (an
estimate, range 0–2 %); at part load the stage is then less efficient than 96 %, as catalogue
curves show.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from ..errors import ModelError

__all__ = ["BeltLoss", "BELT_NUMBERS", "belt_output_torque", "belt_input_torque", "belt_loss_power", "scout2_belt"]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class BeltLoss:
    """Losses of a belt stage, at its output shaft (see the module docstring for the law).

    A frozen pytree; every field is a leaf (differentiable, vmappable, identifiable).

    Parameters
    ----------
    efficiency : float [-]      η in (0, 1], the tension-dependent (load-proportional) part
    drag : float [N m]          τ_0 ≥ 0, no-load Coulomb drag at the output shaft
    viscous : float [N m s/rad] c_v ≥ 0, no-load viscous drag at the output shaft
    drag_speed : float [rad/s]  ω_s > 0, output speed over which the Coulomb drag is smoothed
        (tanh), default 0.05 rad/s. Choosing values: small against the leg's working speeds
        (several rad/s) so the drag is Coulomb-like; not so small that the implicit integrator
        must resolve a jump at every reversal.
    """

    efficiency: float = 1.0
    drag: float = 0.0
    viscous: float = 0.0
    drag_speed: float = 0.05

    def __post_init__(self):
        for name, lo in (("efficiency", None), ("drag", 0.0), ("viscous", 0.0), ("drag_speed", None)):
            v = getattr(self, name)
            if isinstance(v, (int, float)):
                bad = not (v == v) or (lo is not None and v < lo) or (name == "drag_speed" and v <= 0) or (name == "efficiency" and not 0 < v <= 1)
                if bad:
                    want = {"efficiency": "in (0, 1]", "drag_speed": "> 0 [rad/s]"}.get(name, "≥ 0")
                    raise ModelError(f"BeltLoss {name} = {v!r}; expected {want}. Give the belt stage's {name} at its output shaft (proleg.drives.belt).")

    def drag_torque(self, speed):
        """τ_d(ω) [N m]: no-load drag at the output shaft, opposing ω [rad/s]."""
        return self.drag * jnp.tanh(speed / self.drag_speed) + self.viscous * speed


#: The fields of :class:`BeltLoss` (all numbers of its law); an assembled model carries them as
#: parameters ``joint_actuator_belt_<field>`` (issue 42, as :data:`~proleg.drives.dcmotor.DRIVE_NUMBERS`).
BELT_NUMBERS = tuple(f.name for f in dataclasses.fields(BeltLoss))


def _forward(tau_in, speed):
    return tau_in * speed >= 0.0


def belt_output_torque(belt: BeltLoss, tau_in, speed):
    """Torque τ_out [N m] the stage delivers at its output for input torque τ_in [N m] (referred to
    the output) at output speed ω [rad/s]; forward or backward by the sign of τ_in ω."""
    gain = jnp.where(_forward(tau_in, speed), belt.efficiency, 1.0 / belt.efficiency)
    return gain * tau_in - belt.drag_torque(speed)


def belt_input_torque(belt: BeltLoss, tau_out, speed):
    """Inverse of :func:`belt_output_torque`: the input torque (referred to the output) that
    delivers τ_out [N m] at speed ω. The map is monotone in τ_in, and τ_in has the sign of
    τ_out + τ_d(ω), which selects the branch."""
    m = tau_out + belt.drag_torque(speed)
    gain = jnp.where(_forward(m, speed), belt.efficiency, 1.0 / belt.efficiency)
    return m / gain


def belt_loss_power(belt: BeltLoss, tau_in, speed):
    """Power the stage takes [W] (≥ 0): τ_in ω − τ_out ω, in closed form (module docstring)."""
    p = tau_in * speed
    fwd = _forward(tau_in, speed)
    mesh = jnp.where(fwd, (1.0 - belt.efficiency) * p, (1.0 / belt.efficiency - 1.0) * (-p))
    return mesh + belt.drag_torque(speed) * speed


def scout2_belt(full_leg_torque: float, efficiency_at_full: float = 0.96, no_load_fraction: float = 0.01) -> BeltLoss:
    """Scout II's belt stage (module docstring): ``efficiency_at_full`` (Table 3: 96 %) at
    ``full_leg_torque`` [N m] (the current-limit torque at the leg), of which
    ``no_load_fraction`` of that torque is no-load drag and the rest tension-dependent."""
    if not 0 <= no_load_fraction < efficiency_at_full <= 1:
        raise ModelError(f"scout2_belt: need 0 ≤ no_load_fraction ({no_load_fraction}) < efficiency_at_full ({efficiency_at_full}) ≤ 1.")
    if not full_leg_torque > 0:
        raise ModelError(f"scout2_belt: full_leg_torque must be positive [N m], got {full_leg_torque}.")
    return BeltLoss(efficiency=efficiency_at_full + no_load_fraction, drag=no_load_fraction * full_leg_torque)

