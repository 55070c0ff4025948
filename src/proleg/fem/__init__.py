"""proleg.fem: small finite-element library (beams, tetrahedral solids, Craig-Bampton reduction).

numpy/scipy throughout; scikit-fem and gmsh are imported only inside the solid-model functions.
"""

from .beam import CANTILEVER_BETA_L as CANTILEVER_BETA_L
from .beam import BeamModel as BeamModel
from .beam import Section as Section
from .beam import cantilever_omega as cantilever_omega
from .beam import element_matrices as element_matrices
from .craig_bampton import ReducedBody as ReducedBody
from .craig_bampton import craig_bampton as craig_bampton
from .craig_bampton import inertia_invariants as inertia_invariants
from .craig_bampton import rigid_body_modes as rigid_body_modes
from .craig_bampton import solve_modes as solve_modes
from .craig_bampton import solve_static as solve_static
from .materials import Material as Material
from .materials import material as material
from .materials import material_names as material_names
from .solid import SolidModel as SolidModel
from .solid import StressResult as StressResult
from .solid import mesh_box as mesh_box
from .lumped import LumpedModel as LumpedModel
from .mesh import axial_rotation as axial_rotation
from .mesh import mesh_occ as mesh_occ
from .mesh import rotation_field as rotation_field
from .mesh import torque_load as torque_load
