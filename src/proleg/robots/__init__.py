"""proleg.robots: the built-in models of the source papers.

- :func:`hyq_leg`: the HyQ hydraulic leg on the HAL test bench (seeds 000 and 001), rigid or
  with 4 or 8 pin bushings; virtual bench tests in :mod:`proleg.robots.hyq_tests`.
"""

from .hyq_leg import hyq_leg as hyq_leg
from .sensor_fe import mesh_convergence as torque_sensor_convergence
from .sensor_fe import torque_sensor_analysis as torque_sensor_analysis
from .torso import torso_modal as torso_modal
