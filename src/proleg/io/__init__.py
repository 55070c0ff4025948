"""Files in and out: YAML model files (``load_model``, ``dump_model``), URDF (``load_urdf``)."""

from .modelfile import dump_model as dump_model
from .modelfile import load_model as load_model
from .modelfile import load_model_file as load_model_file
from .modelfile import model_from_dict as model_from_dict
from .modelfile import model_to_dict as model_to_dict
from .urdf import load_urdf as load_urdf
