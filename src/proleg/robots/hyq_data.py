"""HyQ leg on the HAL test bench: parameters with their sources (seeds 000 and 001).

Every number here cites where it comes from: ``MODEL_DATA §1`` (the cleaned numbers of
``/work/shared/MODEL_DATA.md``, which takes the geometry and mass properties from the public
IIT-DLSLab ``hyq-description`` URDF and kinematics manual V4.0), seed 000 (D'Imperio et al.,
"Modelling legged robot multi-body dynamics using hierarchical virtual prototype design":
Table 2, PID gains, sensors) or seed 001 ("Finite element analysis within component design
process of hydraulic quadruped robot": RCP/FCP bushing models). Values that no source prints
are marked **assumed** and are parameters of :func:`proleg.robots.hyq_leg`, never buried.

Joint-angle convention (used by the cylinder formulas below and by the model): θ1 is the HFE
(hip flexion-extension) angle and θ2 the KFE (knee) angle, HyQ's joint coordinates, both about
the ground +y axis (the sagittal plane is x-z). θ1 = 0 is the upper leg pointing straight down,
θ2 = 0 a straight knee. The nominal bench pose θ1 = −30°, θ2 = 60° puts the foot under the hip
(hind-leg ranges: HFE −70…50°, KFE 20…140°, MODEL_DATA §1).
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from ..units import deg

# ------------------------------------------------------------------------------------------
# Geometry and mass properties (MODEL_DATA §1, hyq-description URDF)
# ------------------------------------------------------------------------------------------
UPPER_LEG_LENGTH = 0.35  # [m] HFE→KFE, MODEL_DATA §1
LOWER_LEG_LENGTH = 0.341  # [m] KFE→foot centre, MODEL_DATA §1 (0.346 with the newer foot)
FOOT_RADIUS = 0.02175  # [m] foot sphere, MODEL_DATA §1

UPPER_LEG_MASS = 2.638  # [kg] MODEL_DATA §1
UPPER_LEG_COM = (0.15074, 0.02625, 0.0)  # [m] in the URDF link frame (x along the link)
# URDF inertia tensor about the COM in link axes [kg m²]; URDF ixy is the tensor entry.
UPPER_LEG_INERTIA = ((0.00368, -0.00302, 0.0), (-0.00302, 0.02719, 0.0), (0.0, 0.0, 0.02811))
LOWER_LEG_MASS = 0.881  # [kg] MODEL_DATA §1
LOWER_LEG_COM = (0.1254, 0.0, 0.0)  # [m] link frame
LOWER_LEG_INERTIA = ((0.00047, 0.0, 0.0), (0.0, 0.01256, 0.0), (0.0, 0.0, 0.01233))

HIP_ASSEMBLY_MASS = 2.93  # [kg] MODEL_DATA §1 (URDF hip assembly): default slider mass
PROTOTYPE_LEG_MASS = 4.5  # [kg] MODEL_DATA §1: the 2010 prototype leg on its slider (Semini, IROS 2010)

HFE_RANGE_DEG = (-70.0, 50.0)  # MODEL_DATA §1, hind leg
KFE_RANGE_DEG = (20.0, 140.0)

# Hydraulic cylinder triangles (MODEL_DATA §1, HyQ kinematics manual)
HIP_A = 0.3219  # [m] a1: HFE axis → cylinder pin on the upper leg
HIP_B = 0.045  # [m] b1: HFE axis → rod pin on the hip (slider) lever
HIP_EPS = 6.24 * deg  # ε11
KNEE_A = 0.3218  # [m] a2: KFE axis → cylinder pin on the upper leg
KNEE_B = 0.045  # [m] b2: KFE axis → rod pin on the lower-leg lever
KNEE_EPS1 = 8.04 * deg  # ε21
KNEE_EPS2 = 6.0 * deg  # ε22

# ------------------------------------------------------------------------------------------
# Actuators and servo (seed 000)
# ------------------------------------------------------------------------------------------
#: Seed 000 Table 2: identified actuator coefficients, k [N/m] and c [N s/m], per test and gain.
#: The drop/high σ are printed identical to the quasi-static/high row (MODEL_DATA §1: probably
#: an extraction repeat); the k and c values themselves differ and are used as printed.
TABLE2 = {
    ("quasi-static", "low"): {"hip_k": 8.30e4, "hip_c": 4.50e5, "knee_k": 4.40e4, "knee_c": 1.93e5},
    ("quasi-static", "high"): {"hip_k": 1.84e5, "hip_c": 2.1e6, "knee_k": 1.16e5, "knee_c": 3.8e5},
    ("drop", "low"): {"hip_k": 8.81e4, "hip_c": 2.2e6, "knee_k": 4.77e4, "knee_c": 5.70e5},
    ("drop", "high"): {"hip_k": 1.75e5, "hip_c": 2.55e5, "knee_k": 8.75e4, "knee_c": 1.50e5},
}
#: Relative standard deviations σ of Table 2 (same keys), used for the synthetic bench variant.
TABLE2_SIGMA = {
    ("quasi-static", "low"): {"hip_k": 0.01, "hip_c": 0.22, "knee_k": 0.08, "knee_c": 0.22},
    ("quasi-static", "high"): {"hip_k": 0.08, "hip_c": 0.22, "knee_k": 0.04, "knee_c": 0.19},
    ("drop", "low"): {"hip_k": 0.0, "hip_c": 0.21, "knee_k": 0.02, "knee_c": 0.25},
    ("drop", "high"): {"hip_k": 0.08, "hip_c": 0.22, "knee_k": 0.04, "knee_c": 0.19},
}
P_GAIN = {"low": 150.0, "high": 300.0}  # [N m/rad] seed 000 §3
D_GAIN = 6.0  # [N m s/rad] seed 000 §3
SERVO_PERIOD = 1e-3  # [s] assumed 1 kHz joint servo (typical for HyQ's controller)

JOINTS = ("rigid", "bushings4", "bushings8")
GAINS = tuple(P_GAIN)
ACTUATOR_TESTS = ("quasi-static", "drop")

# ------------------------------------------------------------------------------------------
# Assumed values (no source prints them); each is a parameter of hyq_leg()
# ------------------------------------------------------------------------------------------
#: Cylinder barrel and rod masses and lengths, **assumed**: a 16 mm bore / 10 mm rod, 80 mm
#: stroke cylinder (the size class of HyQ's actuators); a steel rod Ø10 mm × 0.15 m is 0.09 kg.
#: The URDF upper-leg mass properties are taken to include both cylinders and rods; the model
#: splits them off so that the combined COM and inertia equal the URDF values at the nominal pose.
CYLINDER_MASS = 0.30  # [kg] assumed
CYLINDER_LENGTH = 0.20  # [m] assumed, barrel measured from its pin
ROD_MASS = 0.10  # [kg] assumed
ROD_LENGTH = 0.15  # [m] assumed, rod measured from its pin
CYLINDER_RADIUS = 0.015  # [m] assumed outer radius of the barrel (inertia about its axis only)
ROD_RADIUS = 0.005  # [m] Ø10 mm rod
SLIDER_INERTIA = (0.02, 0.02, 0.02)  # [kg m²] assumed; no effect: the slider cannot rotate
#: Bench pose: θ1 = −30°, θ2 = 60° put the foot under the hip; the servo setpoints, and the pose
#: at which the cylinders are split off the URDF upper-leg mass properties.
NOMINAL_HFE = -30.0 * deg
NOMINAL_KFE = 60.0 * deg
#: Bushing defaults (seed 001: "taken from bearing commercial datasheets", values not printed).
#: Radial 1e8 N/m is the order of a small deep-groove ball bearing (MODEL_DATA §1); axial taken
#: as 1/10 of radial (deep-groove bearings are much softer axially); tilt from two bearings
#: of half the radial stiffness each, ``BEARING_SPAN`` apart: k_tilt = k_r s²/4; free about the pin.
BUSHING_RADIAL_STIFFNESS = 1e8  # [N/m]
BUSHING_AXIAL_RATIO = 0.1  # [-]
BEARING_SPAN = 0.02  # [m] assumed distance between the two bearings of one pin
DOUBLE_PIN_SPAN = 0.04  # [m] assumed distance between the two sides of pins 4 and 5
#: Stiffness-proportional bushing damping C = β K [s] (5 % of critical at 1e4 rad/s), assumed.
BUSHING_DAMPING_BETA = 1e-5
#: Foot–force-plate contact, **assumed**: rubber-covered foot (E ≈ 10 MPa, ν = 0.49) on a steel
#: plate; Hertz stiffness (4/3) E* √R of the 21.75 mm sphere ≈ 2.5e6 N/m^1.5.
FOOT_YOUNGS = 10e6  # [Pa]
FOOT_POISSON = 0.49
PLATE_YOUNGS = 200e9  # [Pa] steel
PLATE_POISSON = 0.3
FOOT_DAMPING = 500.0  # [N s/m] assumed IMPACT damping
FOOT_PENETRATION = 1e-4  # [m] depth of full damping (brief / Adams default order)
MU_STATIC, MU_DYNAMIC = 0.8, 0.6  # rubber on steel, assumed
V_STICTION, V_FRICTION = 1e-3, 1e-2  # [m/s]

# ------------------------------------------------------------------------------------------
# Sensors (seed 000 §3, seed 001)
# ------------------------------------------------------------------------------------------
JOINT_ENCODER_RESOLUTION_DEG = 0.0045  # Avago AEDA-3300, 80000 counts/rev
SLIDER_ENCODER_BITS = 12  # AS5045 absolute, 0.0879° per count
SLIDER_ENCODER_RESOLUTION_DEG = 360.0 / 2**12
SLIDER_WHEEL_RADIUS = 0.03  # [m] assumed: the AS5045 reads the slider through a 30 mm wheel
LOAD_CELL_RANGE = 5000.0  # [N] Burster 8417, 0–5 kN
LOAD_CELL_ACCURACY = 0.005  # ±0.5 % of full scale
FORCE_PLATE_RANGE_XY = 2500.0  # [N] Kistler 9260AA6, ±2.5 kN
FORCE_PLATE_RANGE_Z = 5000.0  # [N] 0–5 kN
FORCE_PLATE_NOISE = 0.5  # [N] rms, assumed (amplifier noise of a piezo plate)


# ------------------------------------------------------------------------------------------
# Cylinder kinematics (MODEL_DATA §1), traceable in JAX
# ------------------------------------------------------------------------------------------
def _lever(a, b, c):
    return a * jnp.sin(jnp.arccos((a * a + c * c - b * b) / (2.0 * a * c)))


def hip_cylinder_length(theta1, a1=HIP_A, b1=HIP_B, eps11=HIP_EPS):
    """c1(θ1) = √(a1² + b1² − 2 a1 b1 cos(π/2 + θ1 + ε11)) [m], θ1 = HFE angle [rad]."""
    return jnp.sqrt(a1 * a1 + b1 * b1 - 2.0 * a1 * b1 * jnp.cos(jnp.pi / 2 + theta1 + eps11))


def hip_lever_arm(theta1, a1=HIP_A, b1=HIP_B, eps11=HIP_EPS):
    """l1(θ1) = a1 sin(acos((a1² + c1² − b1²)/(2 a1 c1))) [m] (> 0): HFE torque = F_cyl · l1."""
    return _lever(a1, b1, hip_cylinder_length(theta1, a1, b1, eps11))


def knee_cylinder_length(theta2, a2=KNEE_A, b2=KNEE_B, eps21=KNEE_EPS1, eps22=KNEE_EPS2):
    """c2(θ2) = √(a2² + b2² − 2 a2 b2 cos(π − θ2 − ε21 − ε22)) [m], θ2 = KFE angle [rad]."""
    return jnp.sqrt(a2 * a2 + b2 * b2 - 2.0 * a2 * b2 * jnp.cos(jnp.pi - theta2 - eps21 - eps22))


def knee_lever_arm(theta2, a2=KNEE_A, b2=KNEE_B, eps21=KNEE_EPS1, eps22=KNEE_EPS2):
    """l2(θ2) [m] (> 0): KFE torque = F_cyl · l2."""
    return _lever(a2, b2, knee_cylinder_length(theta2, a2, b2, eps21, eps22))


def hip_signed_lever(theta1):
    """dc1/dθ1 = +l1(θ1): extending the hip cylinder increases θ1."""
    return hip_lever_arm(theta1)


def knee_signed_lever(theta2):
    """dc2/dθ2 = −l2(θ2): extending the knee cylinder straightens the knee (decreases θ2)."""
    return -knee_lever_arm(theta2)


def actuator_coefficients(actuators: str, gain: str) -> dict:
    """Seed 000 Table 2 row for the test condition and gain: hip_k, hip_c, knee_k, knee_c."""
    return dict(TABLE2[(actuators, gain)])


def foot_stiffness(radius=FOOT_RADIUS, youngs=FOOT_YOUNGS, poisson=FOOT_POISSON) -> float:
    """Hertz sphere–plane stiffness [N/m^1.5] of the foot on the steel force plate (assumed materials)."""
    e_star = 1.0 / ((1.0 - poisson**2) / youngs + (1.0 - PLATE_POISSON**2) / PLATE_YOUNGS)
    return 4.0 / 3.0 * e_star * math.sqrt(radius)


def urdf_link_frame(theta: float) -> np.ndarray:
    """Ground orientation of a URDF leg-link frame at absolute sagittal angle ``theta`` [rad].

    Frame mapping (URDF → ground): link x along the segment (from its joint towards the next
    joint or the foot) = R_y(θ)(0, 0, −1); link z along the joint axis = ground +y; link
    y = z × x. At θ = 0 (segment pointing down) link x = −z, y = −x, z = +y.
    """
    c, s = math.cos(theta), math.sin(theta)
    x = np.array([-s, 0.0, -c])
    z = np.array([0.0, 1.0, 0.0])
    return np.column_stack([x, np.cross(z, x), z])


def sources() -> list[tuple]:
    """(name, value, unit, source) rows of every parameter above, for reports."""
    rows = [
        ("upper leg length HFE→KFE", UPPER_LEG_LENGTH, "m", "MODEL_DATA §1 (hyq-description URDF)"),
        ("lower leg length KFE→foot", LOWER_LEG_LENGTH, "m", "MODEL_DATA §1"),
        ("foot sphere radius", FOOT_RADIUS, "m", "MODEL_DATA §1"),
        ("upper leg mass (incl. both cylinders)", UPPER_LEG_MASS, "kg", "MODEL_DATA §1; cylinders included: assumed"),
        ("upper leg COM (link frame)", list(UPPER_LEG_COM), "m", "MODEL_DATA §1"),
        ("upper leg Ixx, Iyy, Izz, Ixy", [0.00368, 0.02719, 0.02811, -0.00302], "kg m²", "MODEL_DATA §1"),
        ("lower leg mass", LOWER_LEG_MASS, "kg", "MODEL_DATA §1"),
        ("lower leg COM (link frame)", list(LOWER_LEG_COM), "m", "MODEL_DATA §1"),
        ("lower leg Ixx, Iyy, Izz", [0.00047, 0.01256, 0.01233], "kg m²", "MODEL_DATA §1"),
        ("slider mass (default)", HIP_ASSEMBLY_MASS, "kg", "MODEL_DATA §1: URDF hip assembly 2.93 kg"),
        ("hip cylinder a1, b1", [HIP_A, HIP_B], "m", "MODEL_DATA §1"),
        ("hip cylinder ε11", HIP_EPS / deg, "deg", "MODEL_DATA §1"),
        ("knee cylinder a2, b2", [KNEE_A, KNEE_B], "m", "MODEL_DATA §1"),
        ("knee cylinder ε21, ε22", [KNEE_EPS1 / deg, KNEE_EPS2 / deg], "deg", "MODEL_DATA §1"),
        ("P gain low / high", [P_GAIN["low"], P_GAIN["high"]], "N m/rad", "seed 000 §3"),
        ("D gain", D_GAIN, "N m s/rad", "seed 000 §3"),
        ("servo period", SERVO_PERIOD, "s", "assumed (1 kHz)"),
        ("cylinder barrel mass / length", [CYLINDER_MASS, CYLINDER_LENGTH], "kg, m", "assumed"),
        ("cylinder rod mass / length", [ROD_MASS, ROD_LENGTH], "kg, m", "assumed"),
        ("barrel / rod radius", [CYLINDER_RADIUS, ROD_RADIUS], "m", "assumed"),
        ("nominal pose θ1, θ2", [NOMINAL_HFE / deg, NOMINAL_KFE / deg], "deg", "assumed (foot under the hip)"),
        ("bushing radial stiffness", BUSHING_RADIAL_STIFFNESS, "N/m", "bearing datasheet order (MODEL_DATA §1); seed 001"),
        ("bushing axial / radial", BUSHING_AXIAL_RATIO, "-", "assumed"),
        ("bearing span (tilt stiffness k_r s²/4)", BEARING_SPAN, "m", "assumed"),
        ("double-sided pin span (pins 4, 5)", DOUBLE_PIN_SPAN, "m", "assumed; seed 001 footnote"),
        ("bushing damping β (C = β K)", BUSHING_DAMPING_BETA, "s", "assumed"),
        ("foot Hertz stiffness", foot_stiffness(), "N/m^1.5", "Hertz, rubber foot E = 10 MPa on steel: assumed"),
        ("foot contact damping", FOOT_DAMPING, "N s/m", "assumed"),
        ("foot friction μs / μd", [MU_STATIC, MU_DYNAMIC], "-", "assumed"),
        ("joint encoder resolution", JOINT_ENCODER_RESOLUTION_DEG, "deg", "seed 000 §3 (AEDA-3300)"),
        ("slider encoder", SLIDER_ENCODER_BITS, "bit", "seed 000 §3 (AS5045, 0.0879°)"),
        ("slider encoder wheel radius", SLIDER_WHEEL_RADIUS, "m", "assumed"),
        ("load cell range / accuracy", [LOAD_CELL_RANGE, LOAD_CELL_ACCURACY], "N, -", "seed 000 §3 (Burster 8417)"),
        ("force plate range Fx,Fy / Fz", [FORCE_PLATE_RANGE_XY, FORCE_PLATE_RANGE_Z], "N", "seed 000 §3 (Kistler 9260AA6)"),
        ("force plate noise", FORCE_PLATE_NOISE, "N rms", "assumed"),
    ]
    for (test, gain), row in TABLE2.items():
        rows.append(
            (f"actuator k, c ({test}, {gain})", [row["hip_k"], row["hip_c"], row["knee_k"], row["knee_c"]],
             "hip k N/m, hip c N s/m, knee k, knee c", "seed 000 Table 2")
        )
    return rows
