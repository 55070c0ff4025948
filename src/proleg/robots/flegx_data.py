"""FLEGX flexible jumping leg: parameters with their sources (seed 002, MODEL_DATA §3).

Seed 002 = D'Imperio et al., "Towards multi-body analyses for advanced flexible robotic
systems" (IDETC 2017), ``/work/shared/seeds/002_b21a0442cbf8e289.txt``. Every number either
cites the seed (section / equation / table) or is marked **assumed** (the paper is silent) and
is a parameter of :func:`proleg.robots.flegx`.

Joint-angle convention (as HyQ, ``hyq_data``): the sagittal plane is x-z, z up, every pin
axis along ground +y. θ1 (hip) is the upper leg's angle from the downward vertical,
u1 = R_y(θ1)(0, 0, −1): θ1 < 0 swings the upper leg forward (+x). θ2 (knee) is the lower
leg relative to the upper leg, u2 = R_y(θ1 + θ2)(0, 0, −1): θ2 > 0 bends the knee backwards.

Mass split of Table I (seed 002 prints only the totals 8.77, 9.57, 7.35, 7.97 kg)
-------------------------------------------------------------------------------------
Each configuration's total is split as

    total = guide assembly + upper leg (+ motors carried by it) + knee flange
            + [knee wheel crank + 2 tendons: No. 4 only] + strip (link case 2, 0.4095 kg)

with the upper-leg masses and the motor placements of §IV / Fig. 2 (assumed values below),
and the **guide assembly** (carbon plate, four SKF bearing units, and whatever motors sit on
the plate) taking the remainder, so that the model's total moving mass equals Table I's with
the 250×70×3 link exactly. With another link case the guide keeps its mass and the total
changes by the strip's mass difference. A motor + gearhead + worm set is taken as
``MOTOR_UNIT_MASS`` = 1.0 kg (assumed: a 100 W class BLDC with a planetary head).

====== ============================================ ======================================
No.    upper leg (Fig. 2)                           where the motors are
====== ============================================ ======================================
1      HyQ-like aluminium segment, 0.80 kg          hip motor on the guide at the hip; knee
                                                    motor on the upper leg at the knee
2      Ø90 mm tube, 0.25 kg                         both motors on the upper leg close to
                                                    the hip, axes along the leg
3      semimonocoque, 0.30 kg                       hip motor on the guide plate; knee motor
                                                    inside the upper leg (mid-length)
4      Ø75/71 mm tube 180 mm, 0.165 kg (§II) + hubs both on the guide plate (§II); knee
       0.135 kg = 0.30 kg                           through the tendons
====== ============================================ ======================================
"""

from __future__ import annotations

import math

from ..units import deg

# ------------------------------------------------------------------------------------------
# Link cases and material (seed 002 §II; MODEL_DATA §3)
# ------------------------------------------------------------------------------------------
#: Link cases (L, W, t) [m], seed 002 §II ("Case 1 - 200,50,3; ...").
LINK_CASES = {
    1: (0.200, 0.050, 0.003),
    2: (0.250, 0.070, 0.003),
    3: (0.250, 0.050, 0.003),
    4: (0.250, 0.070, 0.002),
    5: (0.250, 0.050, 0.002),
    6: (0.300, 0.050, 0.003),
}
MATERIAL = "aisi304"  # E = 200 GPa, rho = 7800 kg/m^3, nu = 0.3 (MODEL_DATA §3)
ULTIMATE_STRENGTH = (510e6, 530e6)  # [Pa] von Mises limit band, seed 002 §IV
PRBM_DAMPING_RATIO = 0.015  # seed 002 §III.A
PRBM_CALIBRATION_LOAD = 30.0  # [N] seed 002 §III.A worked example (P = 30 N)

# ------------------------------------------------------------------------------------------
# Configurations and Table I (seed 002 §IV, Table I, link 250×70×3)
# ------------------------------------------------------------------------------------------
CONFIGURATIONS = (1, 2, 3, 4)
#: Table I: configuration -> (total mass [kg], jump height [mm], max stress [MPa]).
TABLE_I = {1: (8.77, 70.88, 522.90), 2: (9.57, 59.80, 523.62), 3: (7.35, 108.1, 514.62), 4: (7.97, 104.1, 530.68)}
#: Machinery-model run (seed 002 Fig. 4): 50 mm jump, max stress 447 MPa, tip displacement ≈ 32 mm.
MACHINERY_JUMP = 0.050
MACHINERY_MAX_STRESS = 447e6
MACHINERY_TIP_DISPLACEMENT = 0.032
#: PRBM vs LFM take-off (seed 002 §III.A): 60 mm vs 50 mm.
PRBM_VS_LFM_JUMP = (0.060, 0.050)

MOTOR_UNIT_MASS = 1.0  # [kg] motor + gearhead + worm set, **assumed**

#: Upper leg per configuration (**assumed** except No. 4's tube): structure mass [kg],
#: number of motor units carried by the upper leg, and where along the hip→knee axis they sit
#: (fraction of the hip-knee distance); ``knee_drive`` says how the knee is driven.
UPPER_LEG = {
    1: dict(structure=0.80, motors=1, motor_at=1.0, knee_drive="direct"),
    2: dict(structure=0.25, motors=2, motor_at=0.15, knee_drive="direct"),
    3: dict(structure=0.30, motors=1, motor_at=0.5, knee_drive="direct"),
    4: dict(structure=0.30, motors=0, motor_at=0.0, knee_drive="tendon"),
}
TUBE_NO4 = dict(outer=0.075, inner=0.071, length=0.180, mass=0.165)  # seed 002 §II

# ------------------------------------------------------------------------------------------
# Geometry (seed 002 §II; the rest assumed)
# ------------------------------------------------------------------------------------------
TENDON_LENGTH = 0.266  # [m] seed 002 §II
TENDON_DIAMETER = 0.007  # [m] seed 002 §II
STEEL_DENSITY = 7850.0  # [kg/m^3] tendon rods
#: Hip–knee distance [m], **assumed** = tendon length: the tendons, wheel crank and knee
#: flange lever form a parallelogram, so the knee wheel's angle is the lower leg's absolute
#: angle (a 1:1 "tendon-like" transmission, §II); the 180 mm tube sits between the housings.
HIP_KNEE = TENDON_LENGTH
CRANK_RADIUS = 0.040  # [m] wheel crank pin and knee flange lever radius, **assumed**
CRANK_ANGLE = 25.0 * deg  # [rad] lever direction relative to the lower leg, **assumed** (keeps
#                                the parallelogram away from its flat, singular pose)
TENDON_SPAN = 0.045  # [m] the two tendons run at y = ±45 mm, beside the Ø75 tube, **assumed**
FLANGE_MASS = 0.15  # [kg] knee flange + clamp of the strip, **assumed**
FLANGE_OFFSET = 0.015  # [m] knee axis → clamped end of the strip, **assumed**
WHEEL_CRANK_MASS = 0.25  # [kg] floating knee worm wheel + crank (No. 4), **assumed**
FOOT_RADIUS = 0.010  # [m] massless rigid cylinder at the link tip (seed 002 §III.B), **assumed**

# ------------------------------------------------------------------------------------------
# Worm drives (seed 002 §II, §III.C, Eqs. 16-17)
# ------------------------------------------------------------------------------------------
WORM = dict(starts=3, wheel_teeth=29, module=2.5e-3, centre_distance=53e-3, pressure_angle=15.0 * deg)
WORM_FRICTION_STATIC = 0.14  # seed 002 §IV (η = 0.60)
WORM_FRICTION_DYNAMIC = 0.13  # seed 002 §IV
WORM_OUTPUT_TORQUE_LIMIT = 77.0  # [N m] with mineral grease, seed 002 §III.C
#: wheel speed [rad/s] over which the friction coefficient passes from static to dynamic, **assumed**
WORM_FRICTION_TRANSITION = 0.05
#: Dynamic worm mesh (``gears="worm"``, :func:`proleg.drives.gears.worm_mesh`), all **assumed**
#: (seed 002 §IV: "a lack of information in the literature for parameters like the stiffness or
#: the dynamic friction transition velocity"): torsional mesh stiffness and damping referred to
#: the wheel, sliding speeds of the static → dynamic friction transition, and the worm-side
#: rotor inertia (BLDC rotor + gearhead + worm shaft, referred to the worm).
WORM_MESH_STIFFNESS = 2.0e4  # [N m/rad] at the wheel (3 mrad at 60 N m)
WORM_MESH_DAMPING = 20.0  # [N m s/rad] at the wheel (ζ ≈ 0.2 against the leg about the hip)
WORM_V_STATIC = 2e-3  # [m/s] sliding speed below which μ is the static f (regularised stiction)
WORM_V_DYNAMIC = 2e-2  # [m/s] sliding speed above which μ is the dynamic f
WORM_INERTIA = 1e-4  # [kg m²] rotor inertia at the worm

# ------------------------------------------------------------------------------------------
# Joint ranges (**assumed**: the strip must not fold onto the upper leg)
# ------------------------------------------------------------------------------------------
HIP_RANGE_DEG = (-80.0, 40.0)
KNEE_RANGE_DEG = (5.0, 150.0)

# ------------------------------------------------------------------------------------------
# Foot contact (IMPACT, seed 002 §III.B; values **assumed**)
# ------------------------------------------------------------------------------------------
CONTACT_STIFFNESS = 1e7  # [N/m^1.5]
CONTACT_EXPONENT = 1.5
CONTACT_DAMPING = 2e3  # [N s/m]
CONTACT_PENETRATION = 1e-4  # [m]


def link_case(case) -> tuple[float, float, float]:
    """(L, W, t) [m] of link case 1-6 (seed 002 §II); ModelError naming the valid range."""
    from ..errors import ModelError

    if isinstance(case, bool) or case not in LINK_CASES:
        raise ModelError(
            f"flegx: unknown link_case {case!r}; valid link cases are 1-6 (seed 002 §II: "
            + ", ".join(f"{k}: {v[0]*1e3:g}x{v[1]*1e3:g}x{v[2]*1e3:g} mm" for k, v in LINK_CASES.items())
            + "), or give link_geometry=(L, W, t) in m.")
    return LINK_CASES[case]


def tendon_mass() -> float:
    """One Ø7 × 266 mm steel rod [kg]."""
    return STEEL_DENSITY * math.pi * TENDON_DIAMETER**2 / 4 * TENDON_LENGTH


def sources() -> list[tuple]:
    """Parameter table rows (name, value, unit, source) for the report."""
    return [
        ("link cases (L, W, t)", {k: [round(x * 1e3, 3) for x in v] for k, v in LINK_CASES.items()}, "mm", "seed 002 §II"),
        ("material", "AISI 304, E = 200 GPa, ρ = 7800 kg/m³", "-", "seed 002 §II; MODEL_DATA §3"),
        ("ultimate strength (von Mises)", [510, 530], "MPa", "seed 002 §IV"),
        ("PRBM damping ratio ξ", PRBM_DAMPING_RATIO, "-", "seed 002 §III.A"),
        ("PRBM calibration load P", PRBM_CALIBRATION_LOAD, "N", "seed 002 §III.A (b from the elastica)"),
        ("Table I totals", {k: v[0] for k, v in TABLE_I.items()}, "kg", "seed 002 Table I"),
        ("motor + gearhead + worm unit", MOTOR_UNIT_MASS, "kg", "assumed"),
        ("upper leg No. 4 tube", "Ø75/71 × 180 mm, 0.165 kg", "-", "seed 002 §II"),
        ("tendons", "2 × Ø7 × 266 mm steel, spherical ends", "-", "seed 002 §II"),
        ("hip-knee distance", HIP_KNEE, "m", "assumed = tendon length (parallelogram)"),
        ("crank / lever radius", CRANK_RADIUS, "m", "assumed"),
        ("knee flange mass", FLANGE_MASS, "kg", "assumed"),
        ("knee wheel + crank mass", WHEEL_CRANK_MASS, "kg", "assumed"),
        ("worm set", "3 starts, 29 teeth, m = 2.5 mm, 15°, a = 53 mm (9.67:1)", "-", "seed 002 §II, §III.C"),
        ("worm friction static / dynamic", [WORM_FRICTION_STATIC, WORM_FRICTION_DYNAMIC], "-", "seed 002 §IV (η ≈ 0.60)"),
        ("wheel torque rating (grease)", WORM_OUTPUT_TORQUE_LIMIT, "N m", "seed 002 §III.C"),
        ("worm mesh k, c at the wheel; v_static, v_dynamic; rotor J", [WORM_MESH_STIFFNESS, WORM_MESH_DAMPING, WORM_V_STATIC,
         WORM_V_DYNAMIC, WORM_INERTIA], "N m/rad, N m s/rad, m/s, m/s, kg m²", "assumed (seed 002 §IV: uncertain)"),
        ("foot cylinder radius", FOOT_RADIUS, "m", "assumed (massless, seed 002 §III.B)"),
        ("IMPACT k, e, c, d", [CONTACT_STIFFNESS, CONTACT_EXPONENT, CONTACT_DAMPING, CONTACT_PENETRATION],
         "N/m^e, -, N s/m, m", "assumed (IMPACT: seed 002 §III.B)"),
        ("hip / knee range", [list(HIP_RANGE_DEG), list(KNEE_RANGE_DEG)], "deg", "assumed"),
    ]
