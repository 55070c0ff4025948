"""proleg.robots: the built-in models of the source papers.

- :func:`hyq_leg`: the HyQ hydraulic leg on the HAL test bench (seeds 000 and 001), rigid or
  with 4 or 8 pin bushings; virtual bench tests in :mod:`proleg.robots.hyq_tests`.
- :func:`flegx`: the FLEGX flexible jumping leg (seed 002), rigid / PRBM / Craig-Bampton
  lower leg; :func:`flegx_jump` its countermovement jump with metrics.
"""

from .hyq_leg import hyq_leg as hyq_leg
from .flegx import flegx as flegx
from .flegx_jump import flegx_jump as flegx_jump
