"""proleg.robots: the built-in models of the source papers (builders and their data).

The papers' reproductions (virtual bench tests, scenario runners, reports, design studies) live
in :mod:`proleg.papers`, which imports these builders; nothing here imports it.

- :func:`hyq_leg`: the HyQ hydraulic leg on the HAL test bench (seeds 000 and 001), rigid or
  with 4 or 8 pin bushings; virtual bench tests in :mod:`proleg.papers.hyq_tests`.

- :func:`scout2`: the Scout II bounding quadruped (seed 003), Model I and Model II; its bounding
  runs and gait metrics are :func:`proleg.papers.scout2_bound`.
- :func:`flegx`: the FLEGX flexible jumping leg (seed 002), rigid / PRBM / Craig-Bampton
  lower leg; its countermovement jump with metrics is :func:`proleg.papers.flegx_jump`.
- :func:`hyq`: the whole HyQ quadruped from its URDF (example-robot-data), PD servos and foot
  contacts (:mod:`proleg.robots.hyq`; its stand scenario, ``proleg run hyq-stand``, is in :mod:`proleg.papers.hyq_stand`).
- :func:`hyq_trot`: the whole HyQ trotting on hydraulic cylinders with chamber pressures or on
  ideal torque sources (:mod:`proleg.robots.hyq_trot`); scenario ``proleg run hyq-trot``.
- :func:`hyq_jump`: the whole HyQ's vertical jump on the cylinders, its height and what limits
  it (:mod:`proleg.robots.hyq_jump`; the push's co-design in :mod:`proleg.papers.hyq_jump`;
  scenario ``proleg run hyq-jump``).
"""

from .hyq_leg import hyq_leg as hyq_leg
from .hyq import hyq as hyq
from .hyq_trot import hyq_trot as hyq_trot
from .hyq_jump import hyq_jump as hyq_jump
from .flegx import flegx as flegx
from .scout2 import scout2 as scout2
from .sensor_fe import mesh_convergence as torque_sensor_convergence
from .sensor_fe import torque_sensor_analysis as torque_sensor_analysis
from .torso import torso_modal as torso_modal
