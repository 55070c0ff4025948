"""Files in and out: YAML model files (``load_model``, ``dump_model``), URDF (``load_urdf``, with
``add_servos`` for a PD servo on every joint and ``set_initial_velocity`` for joint rates and the
base twist)."""

from .modelfile import dump_model as dump_model
from .modelfile import load_model as load_model
from .modelfile import load_model_file as load_model_file
from .modelfile import model_from_dict as model_from_dict
from .modelfile import model_to_dict as model_to_dict
from .urdf import load_urdf as load_urdf
from .urdf_kin import set_initial_velocity as set_initial_velocity
from .urdf_servos import add_servos as add_servos
