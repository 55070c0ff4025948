"""proleg.robots: the built-in models of the source papers.

- :func:`hyq_leg`: the HyQ hydraulic leg on the HAL test bench (seeds 000 and 001), rigid or
  with 4 or 8 pin bushings; virtual bench tests in :mod:`proleg.robots.hyq_tests`.
- :func:`hyq`: the whole HyQ quadruped from its URDF (example-robot-data), PD servos and foot
  contacts; ``proleg run hyq-stand`` in :mod:`proleg.robots.hyq`.
"""

from .hyq_leg import hyq_leg as hyq_leg
from .hyq import hyq as hyq
