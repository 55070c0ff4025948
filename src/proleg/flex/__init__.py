"""proleg.flex: flexible links (pseudo-rigid-body models; modal bodies come from proleg.fem)."""

from .prbm import PRBMCoefficients as PRBMCoefficients
from .prbm import PRBMLink as PRBMLink
from .prbm import cantilever_first_omega as cantilever_first_omega
from .prbm import dynamic_prbm as dynamic_prbm
from .prbm import elastica_tip as elastica_tip
from .prbm import link_inertia as link_inertia
from .prbm import load_deflection as load_deflection
from .prbm import prbm_coefficients as prbm_coefficients
from .prbm import prbm_static as prbm_static
from .prbm import static_prbm as static_prbm
from .prbm import tip_position as tip_position
