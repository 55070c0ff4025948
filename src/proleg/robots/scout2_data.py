"""Scout II parameters (seed 003: ../shared/seeds/003_26a303a01dfc6a70.txt; MODEL_DATA §4).

Every value cites its table; values the paper prints garbled or not at all are marked
**interpreted**, with the reasoning, and stay parameters of :func:`proleg.robots.scout2`.

Per virtual leg: how Table 6 is read (seed 003 §2.3, Table 2, §5.1)
--------------------------------------------------------------------
Table 6 does not print "per physical" or "per virtual" leg; the text around it decides.
The model of §2.3 has virtual legs only:

- §2.3: "Scout II can be considered as a three-body kinematic chain composed of the body and
  the front and back leg pairs, also called the virtual legs (Raibert 1986; see Figure 3). A
  linear spring/damper system models the leg compliance during the stance phase."
- §2.3: "The two-dimensional model presented in Figure 3 can be described by seven
  coordinates [...] The design parameters of the robot are presented in Table 2", and Table 2
  defines "k_i Spring stiffness i-th leg", "b_i Damping constant i-th leg" with i = b, f
  (Eq. 2: "where i = b, f"): one spring and one damper per *virtual* leg.
- §5.1: "Two models were used [...] These models, whose parameters are listed in Table 6, are
  illustrated in Figure 11": Table 6 lists the parameters of that planar three-body model
  (body + two virtual legs), so its leg mass, leg inertia, spring and damping constants are a
  virtual leg's.
- Where the paper means physical legs it says so, and Table 6 has no such note: Table 4, "The
  controller parameters used for each of the physical legs are presented in Table 4" (§3.2);
  Table 5, "the resulting parameter values for the physical legs are presented in Table 5"
  (§4.2). §4.1 likewise models "the two equivalent virtual motors actuating the front and back
  virtual legs" instead of the four physical motors.

So ``scout2(per="virtual")`` (the default) gives each virtual leg Table 6's values as printed:
0.97 kg, 0.01 kg m², 3520 N/m, 55 N s/m (a physical leg is half of each: 1760 N/m,
27.5 N s/m). Tables 4 and 5 stay per physical leg (two of them per virtual leg: twice the
gains, belt stiffness and gear inertias; one equivalent virtual motor of two motors in
parallel: same K_T and K_ω, half R_a, twice the peak current, so Eqs. 3–4 give twice the
torque). Table 5's belt spring 7.0 N m/deg agrees with the "≈ 8° at full torque" of §4.2 for
one motor (α K_T i_max = 51.9 N m / 7.0 N m/deg = 7.4°), consistent with "physical legs".

``per="physical"`` is the other reading (every Table 6 leg value per physical leg, a virtual
leg twice each), kept to show what the choice changes; it was the default before issue 31's
second pass. Its argument was the stance compression: with 3520 N/m per virtual leg the whole
robot's weight (22.8 kg) compresses a single-stance virtual leg by 64 mm (20 % of 0.323 m).
That is large, but the text above, not a plausibility estimate, decides the reading. No value
here is chosen to reach a speed. The damping of the real telescopic legs is partly friction
(§5.2 blames "stiction and nonlinear damping ... inherent in the telescopic leg design"),
which Model II carries as a separate element (below). The body mass and inertia are the whole
body's in either reading.
"""

from __future__ import annotations

from ..units import deg

# Table 6 (basic mechanical properties) ------------------------------------------------------
BODY_MASS = 20.865  # kg
BODY_INERTIA = 1.3  # kg m² (pitch)
LEG_MASS = 0.97  # kg, per virtual leg (see module docstring)
LEG_INERTIA = 0.01  # kg m², per virtual leg, about the leg's COM
LEG_STIFFNESS = 3520.0  # N/m, per virtual leg (Table 2: k_i, i = b, f)
LEG_DAMPING = 55.0  # N s/m, per virtual leg (Table 2: b_i, i = b, f)
TABLE6_READING = "virtual"  # how Table 6's leg values are read (module docstring)
HIP_SEPARATION = 0.552  # m; half spacing L = 0.276 m
LEG_LENGTH = 0.323  # m, nominal (extension stop)

# Table 4 (controller, per physical leg; "SI units, angles in degrees") ----------------------
# Read as: angles in degrees, gains in SI per radian (N m/rad, N m s/rad). Per degree, kp = 250
# N m/deg would saturate the 52 N m motor at 0.2° and kd = 5 N m s/deg = 286 N m s/rad on a
# ~0.05 kg m² leg at 1 kHz is far outside the sampled PD's stability bound (kd T/I < 2).
TOUCHDOWN_FRONT = 21.0 * deg
TOUCHDOWN_BACK = 19.0 * deg
SWEEP_LIMIT_FRONT = 0.0 * deg
SWEEP_LIMIT_BACK = 0.0 * deg
FLIGHT_KP, FLIGHT_KD = 250.0, 5.0  # N m/rad, N m s/rad
BRAKE_KP, BRAKE_KD = 300.0, 5.0  # N m/rad, N m s/rad
CONTROL_PERIOD = 1e-3  # s (1 kHz, §2.2)

# Table 5 (hip unit, Model II; exponents garbled in the extraction: interpreted) -------------
# Drive gear (motor side) inertia "3.5 10°°": read 3.5e-6 kg m². Reflected to the leg through
# β = 102.2 it is 0.037 kg m², about the leg's own inertia about the hip (0.01 + 0.97 · 0.19²
# ≈ 0.045): the "gearbox dynamics" that slow the flight response (§5.2). 3.5e-5 would reflect
# 0.37 kg m², 8× the leg, and the 52 N m motor could not swing the leg through its 21° in a
# 0.1 s flight (needs ≈ 61 N m).
DRIVE_GEAR_INERTIA = 3.5e-6  # kg m², per physical leg, interpreted
# Driven gear (leg side) inertia "1¢": read 1e-4 kg m² (an aluminium pulley of ≈ 60 mm, 0.2 kg:
# ½ m r² ≈ 9e-5). Small against the leg either way.
DRIVEN_GEAR_INERTIA = 1e-4  # kg m², per physical leg, interpreted
JOINT_STICTION = 5.5e-3  # N m (printed 5.5 × 10^-3)
# Joint damping "6.2x 1077 Nm deg's": read 6.2e-4 N m/(deg/s) = 0.0355 N m s/rad (0.7 % of
# the flight kd; 6.2e-7 would be nothing, 6.2e-2 would be 2/3 of the servo's own damping).
JOINT_DAMPING = 6.2e-4 / deg  # N m s/rad, interpreted
BELT_STIFFNESS = 7.0 / deg  # N m/rad (7.0 N m/deg; 51.9 N m → 7.4°, the "≈ 8°" of §4.2)
# Belt damper "4.0 Nm degs^-1": read 4.0e-2 N m s/deg = 2.29 N m s/rad, damping ratio ≈ 0.3 of
# the belt with the leg (c_crit = 2 √(k J) ≈ 8.5 N m s/rad); 4.0 N m s/deg would be 27 × c_crit
# (the belt a rigid dashpot), 4.0e-3 an undamped belt ringing at ≈ 15 Hz.
BELT_DAMPING = 4.0e-2 / deg  # N m s/rad, interpreted

# Model II dissipation the paper names but does not model (§5.2, §5.3) -------------------------
# Not printed in seed 003: engineering estimates with the ranges the report sweeps.
# Telescopic leg: the lower tube slides in bushings in the upper leg. Dry-running plain bearings
# (polymer or PTFE-lined bushings on an aluminium or steel tube) have sliding friction
# coefficients of about 0.05–0.25 (handbook ranges for dry polymer bearings; PTFE ≈ 0.05–0.1,
# filled polymers 0.1–0.25); static friction 1.0–1.5 times that. The bushing overlap and
# position are not given: the lower leg (≈ 0.2 m of travel region below the spring housing)
# is read as sliding in an overlap of 0.04–0.15 m centred 0.15–0.25 m below the hip.
# LEG_MU is the value calibrated on one speed's specific resistance (scout2_calibrate); the
# nominal here is the middle of the range, used before calibration.
LEG_MU = 0.12  # -, range (0.03, 0.3)
LEG_MU_RANGE = (0.03, 0.3)
LEG_MU_STATIC_RATIO = 1.3  # -, range (1.0, 1.5)
LEG_OVERLAP = 0.08  # m, range (0.04, 0.15)
LEG_OVERLAP_RANGE = (0.04, 0.15)
LEG_BEARING = 0.2  # m below the hip, range (0.15, 0.25)
# Gearbox and motor no-load drag at the motor shaft (per motor). The motor's own friction torque
# is K_T times its no-load current (tens of mA for a motor of this size: a few mN m); a
# three-stage planetary adds its churning and seal drag. Range 0–20 mN m Coulomb and
# 0–5e-5 N m s/rad viscous (5 mN m at 100 rad/s more at the motor's ≈ 700 rad/s no-load speed).
# The seed says only that the efficiency "varies dramatically as a function of speed and torque"
# (§5.3, after Maxon Motors 1997) and that 68 % is the maximum.
GEAR_DRAG = 0.005  # N m, range (0, 0.02)
GEAR_DRAG_RANGE = (0.0, 0.02)
GEAR_VISCOUS = 1e-5  # N m s/rad, range (0, 5e-5)
GEAR_VISCOUS_RANGE = (0.0, 5e-5)

# Belt and pulley stage (Table 3: "belt and pulley efficiency 96 %", one number). Model II reads
# it as the efficiency at the drive's full (current-limit) torque and splits it into a
# tension-dependent 97 % and a no-load drag (bending hysteresis, seals) of 1 % of the full leg
# torque: timing-belt catalogues give 94–98 % at rated load and lower at part load (Gates,
# Synchronous belt drive design manual). proleg.drives.belt.scout2_belt builds it.
BELT_NO_LOAD = 0.01  # -, fraction of the full leg torque, range (0, 0.02)
BELT_NO_LOAD_RANGE = (0.0, 0.02)

# Paper results to compare with (§5.2, Fig. 7, Fig. 16) ----------------------------------------
SPEED_MEASURED = 1.286  # m/s, ± 0.04 (10 runs on carpet)
SPEED_MEASURED_SD = 0.04
SPEED_MODEL_I = 1.56  # m/s
SPEED_MODEL_II = 1.43  # m/s
SR_MECHANICAL = 0.47  # at 1.3 m/s (Fig. 7)
SR_ELECTRICAL = 1.4  # ≈, at 1.3 m/s (Fig. 7, §3.3)
SR_LOW_SPEED = (0.85, 0.75, 2.2)  # (speed m/s, mechanical, electrical) (§3.3)
