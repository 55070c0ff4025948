"""Unit factors: multiply a value in by its unit, divide a value out by it.

Everything inside proleg is SI (m, kg, s, N, rad). ``30 * mm`` is 0.03 m and
``angle / deg`` is an angle in degrees.
"""

import math

m = 1.0
mm = 1e-3
cm = 1e-2
km = 1e3
kg = 1.0
g = 1e-3
s = 1.0
ms = 1e-3
N = 1.0
kN = 1e3
Pa = 1.0
kPa = 1e3
MPa = 1e6
GPa = 1e9
bar = 1e5
rad = 1.0
deg = math.pi / 180.0
rpm = 2.0 * math.pi / 60.0
Nm = 1.0
Nmm = 1e-3
kg_mm2 = 1e-6
g_gravity = 9.80665
