"""proleg.drives: actuator and transmission laws (pure JAX functions and frozen pytrees).

- :mod:`.dcmotor`  battery–amplifier–DC motor–gear drive of Scout II (seed 003, Eqs. 3–14)
- :mod:`.gears`    gear trains with power-flow-dependent efficiency; FLEGX worm gear (seed 002)
- :mod:`.belt`     belt and pulley stage with load- and speed-dependent losses (Scout II, Model II)
- :mod:`.backlash` rotational spring-damper with a dead band (Scout II hip unit, Model II)
"""

from .backlash import backlash_torque as backlash_torque
from .backlash import backlash_torque_smooth as backlash_torque_smooth
from .backlash import deadband as deadband
from .backlash import deadband_smooth as deadband_smooth
from .belt import BeltLoss as BeltLoss
from .dcmotor import DCMotorDrive as DCMotorDrive
from .dcmotor import DriveOutput as DriveOutput
from .dcmotor import delivered_torque as delivered_torque
from .dcmotor import specific_resistance as specific_resistance
from .dcmotor import torque_speed_limits as torque_speed_limits
from .dcmotor import torque_speed_line as torque_speed_line
from .gears import GearTrain as GearTrain
from .gears import WormGear as WormGear
from .gears import input_torque as input_torque
from .gears import output_torque as output_torque
