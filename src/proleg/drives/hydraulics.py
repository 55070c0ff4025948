"""Valve-controlled hydraulic cylinder with chamber pressures as states (HyQ's actuator class).

Chain: supply (pressure p_s, tank p_t) → 4/3 servo valve (critically lapped, spool x_v in
[−1, 1], orifice law per metering edge, first- or second-order spool dynamics) → differential
cylinder (chambers A, piston side, and B, rod side; compressible oil of bulk modulus β; internal
leakage) → rod force on the mechanism.

Sign conventions
----------------
x [m] is the piston position measured from the fully retracted end (0 ≤ x ≤ stroke); positive
ẋ extends the rod. Flows Q_A, Q_B [m³/s] are positive INTO the chambers. The rod force
F = p_A A_A − p_B A_B [N] is positive pushing the rod out.

Laws (Merritt, *Hydraulic Control Systems*, 1967, §3 and §5; the same as Simscape Fluids'
valve and cylinder blocks, Chrono's ``ChHydraulicActuator2`` and Exudyn's
``HydraulicActuatorSimple``)::

    V_A = V_0A + A_A x,   V_B = V_0B + A_B (stroke − x)
    ṗ_A = β / V_A · (Q_A − A_A ẋ − Q_L),   ṗ_B = β / V_B · (Q_B + A_B ẋ + Q_L),   Q_L = C_L (p_A − p_B)

    x_v ≥ 0:  Q_A = K_v x_v g(p_s − p_A),   Q_B = −K_v x_v g(p_B − p_t)
    x_v < 0:  Q_A = K_v x_v g(p_A − p_t),   Q_B = −K_v x_v g(p_s − p_B)

with the orifice law g(Δp) = Δp / (Δp² + Δp_l²)^¼ → sign(Δp) √|Δp| (turbulent) above the
laminar transition Δp_l, and linear below it (laminar, keeps ∂Q/∂p finite at Δp = 0). The flow
gain K_v = Q_N / √(Δp_N/2) comes from the rated flow Q_N at the rated valve drop Δp_N (the
catalogue convention: Δp_N split over the two metering edges).

The pressure law conserves mass exactly with a density ρ = ρ_0 e^{p/β} (constant β): the chamber
mass m = ρ_0 V e^{p/β} changes only by the mass flow ρ Q, d/dt (V e^{p/β}) = e^{p/β} (Q_in − Q_L).
:func:`integrate_chambers` integrates it in that form, ln(V e^{p/β}), so the piston's volume
change enters exactly and the valve flow implicitly (stiff: β/V · ∂Q/∂p reaches 1e4 1/s).

Power (W, all ≥ 0 but the piston power):
    drawn from the supply     P_s = p_s Q_s − p_t Q_t   (Q_s into the valve, Q_t back to tank)
    lost in the valve          P_v = Σ edges Q_edge Δp_edge
    lost in leakage            P_L = Q_L (p_A − p_B)
    delivered to the chambers  p_A Q_A + p_B Q_B = P_s − P_v   (the port power)

Cavitation floor (the oil cannot be stretched)
----------------------------------------------
Oil saturated with air at the vented tank's atmospheric pressure releases air (gaseous
cavitation), and below its vapour pressure it boils (vaporous cavitation): a chamber that is
expanded faster than the valve fills it does not go to large negative pressures, it forms a
cavity at about the release pressure (Merritt 1967, §2.4; Manring, *Hydraulic Control Systems*,
2005, §2.2; Simscape Fluids' isothermal liquid models the same by a pressure-dependent
density below the vapour pressure). Choice here: an equation of state with a floor. Each
chamber's state is its ln-mass, written as the *liquid-equivalent pressure*
y = β (ln(m/ρ_0) − ln V) (the pressure the chamber would have if all its content were liquid:
exactly the pressure above the floor), and the pressure is the C¹ smooth maximum

    p = P(y) = y                          y ≥ p_c + w
             = p_c + (y − p_c + w)²/(4w)  |y − p_c| < w
             = p_c                        y ≤ p_c − w       (a cavity of volume V (1 − e^{(y−p_c)/β}))

with p_c the cavitation pressure (default 0 Pa gauge: air release at atmospheric pressure, the
tank's; a small absolute pressure could be set, −0.1 MPa gauge is absolute zero) and w a
smoothing width. Mass is conserved exactly as before (y is the mass state); the cavity
collapses when the chamber is refilled or compressed. The stored energy is V Φ(y)/β with
Φ' = P (Φ = y²/2 above the floor: the constant-volume form V p²/2β), :func:`compression_energy`.

Relief valves (the oil cannot be compressed without limit)
----------------------------------------------------------
A chamber trapped by the closed spool and driven by the load (a foot impact) would compress
without bound; each chamber has a direct-acting relief valve to tank (:class:`ReliefValve`),
cracking at p_r = r p_s with the linear flow–pressure (override) law of relief cartridges,
Q_r = G_r ramp(p − p_r), G_r = Q_rN/Δp_o, ramp C¹ over a width w_r. Its throttling loss
Q_r (p − p_t) is a term of the energy balance (``relief`` in :func:`integrate_chambers`).
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp

__all__ = ["Cylinder", "ServoValve", "Supply", "ReliefValve", "orifice", "valve_flows", "relief_flow", "oil_pressure", "oil_state",
           "chamber_rates", "integrate_chambers", "cylinder_force", "required_opening"]

LPM = 1e-3 / 60.0  # [m³/s] per l/min


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Cylinder:
    """Differential hydraulic cylinder; a frozen pytree (every field a differentiable leaf).

    Defaults: HyQ's actuator class, **assumed** where no source prints it (keep them parameters):
    16 mm bore, 10 mm rod, 80 mm stroke (the size class already assumed in ``robots/hyq_data``;
    the HyQ HFE/KFE cylinder triangles of MODEL_DATA §1 travel 78 mm over the joint ranges);
    dead volumes 1 cm³ per chamber (valve mounted on the cylinder, short drillings; assumed);
    effective bulk modulus 1.0 GPa (mineral oil 1.4–1.8 GPa, lowered by entrained air and hose
    compliance: a typical engineering value); internal leakage 0; friction of the seals
    20 N Coulomb + 200 N s/m viscous (typical of small servo cylinders; assumed).

    Parameters
    ----------
    bore, rod : float [m]          piston and rod diameters
    stroke : float [m]
    dead_volume_a, dead_volume_b : float [m³]   volume of chamber A at x = 0, of B at x = stroke
    bulk_modulus : float [Pa]      β
    leakage : float [m³/(s Pa)]    C_L, internal leakage across the piston
    friction : float [N]           Coulomb seal friction (applied as a joint friction by the builders)
    viscous : float [N s/m]        viscous friction
    cavitation_pressure : float [Pa]   p_c, the floor of the chamber pressure (gauge; default 0:
        air release at the vented tank's atmospheric pressure; module docstring)
    cavitation_width : float [Pa]  w, the smoothing width of the floor (default 50 kPa: 0.3 % of
        the supply, a numerical choice; the floor is exact below p_c − w)
    """

    bore: float = 0.016
    rod: float = 0.010
    stroke: float = 0.080
    dead_volume_a: float = 1.0e-6
    dead_volume_b: float = 1.0e-6
    bulk_modulus: float = 1.0e9
    leakage: float = 0.0
    friction: float = 20.0
    viscous: float = 200.0
    cavitation_pressure: float = 0.0
    cavitation_width: float = 5.0e4

    @property
    def area_a(self):
        """A_A = π bore²/4 [m²] (piston side)."""
        return math.pi / 4 * self.bore**2

    @property
    def area_b(self):
        """A_B = π (bore² − rod²)/4 [m²] (rod side)."""
        return math.pi / 4 * (self.bore**2 - self.rod**2)

    def volumes(self, x):
        """(V_A, V_B) [m³] at piston position x [m]."""
        return self.dead_volume_a + self.area_a * x, self.dead_volume_b + self.area_b * (self.stroke - x)

    def hydraulic_stiffness(self, x):
        """β (A_A²/V_A + A_B²/V_B) [N/m]: the oil-column stiffness of the blocked cylinder at x."""
        va, vb = self.volumes(x)
        return self.bulk_modulus * (self.area_a**2 / va + self.area_b**2 / vb)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class ServoValve:
    """4/3 critically lapped servo valve, the Moog E024 class used on HyQ.

    Defaults (**typical values of the class**, kept as parameters): rated flow 2.5 l/min at the
    rated valve drop 7 MPa (Moog's catalogue convention, 3.5 MPa per metering edge; assumed for
    HyQ's mini valve); spool bandwidth 250 Hz (the E024-LA's published bandwidth: "Hydraulic
    Quadruped Uses Mini Servovalves", Power & Motion, 2015); damping ratio 0.7 for the
    second-order form; laminar transition Δp_l = 0.1 MPa (a smoothing choice: below it the
    orifice flow is linear in Δp).

    Parameters
    ----------
    rated_flow : float [m³/s]      Q_N at full opening and the rated drop
    rated_drop : float [Pa]        Δp_N over the valve (both edges)
    bandwidth : float [Hz]         spool: first order τ = 1/(2π f); second order ω_n = 2π f
    damping : float [-]            ζ of the second-order spool
    laminar_drop : float [Pa]      Δp_l of the regularised orifice law
    port_ratio : float [-]         α, the B-port edges' (P→B, B→T) gain over the A-port edges'
        (default 1: a symmetric spool). α = A_B/A_A is the spool matched to a differential
        cylinder (Jelali & Kroll, *Hydraulic Servo-systems*, 2003, §3.4; offered by servo-valve
        makers for differential cylinders): in steady motion both chambers then see the same
        drop, so p_A + p_B = p_s and neither chamber exceeds the supply for any rod force within
        the capacity, where a symmetric spool driving an overrunning load intensifies the
        meter-out chamber past p_s once F > p_s (A_A + A_B³/A_A² − A_B) (Merritt 1967, §5).
    order : int (static), 1 or 2   spool dynamics
    """

    rated_flow: float = 2.5 * LPM
    rated_drop: float = 7.0e6
    bandwidth: float = 250.0
    damping: float = 0.7
    laminar_drop: float = 1.0e5
    port_ratio: float = 1.0
    order: int = dataclasses.field(default=1, metadata=dict(static=True))

    @property
    def flow_gain(self):
        """K_v = Q_N / √(Δp_N / 2) [m³/(s √Pa)] per metering edge at full opening."""
        return self.rated_flow / math.sqrt(self.rated_drop / 2)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Supply:
    """Constant-pressure supply and tank (gauge pressures). HyQ runs on 16 MPa (16–20 MPa class).

    Parameters
    ----------
    pressure : float [Pa]   p_s
    tank : float [Pa]       p_t
    """

    pressure: float = 16.0e6
    tank: float = 0.0


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class ReliefValve:
    """Direct-acting pressure-relief valve from each chamber to tank (one per chamber).

    Q_r = G_r ramp(p − p_r) [m³/s] out of the chamber, p_r = ``cracking_ratio`` · p_s,
    G_r = ``rated_flow`` / ``override``; ramp(u) = 0 (u ≤ 0), u²/(2 w_r) (0 < u < w_r),
    u − w_r/2 (u ≥ w_r): C¹, and exactly closed below the cracking pressure.

    Defaults (**typical values of the class**, kept as parameters): set 10 % above the supply
    (the usual margin of a relief over the working pressure, so that it never opens in normal
    operation: e.g. Parr, *Hydraulics and Pneumatics*, 3rd ed. 2011, ch. 6; Eaton/Vickers
    *Industrial Hydraulics Manual*, ch. 7); a small cartridge (10 l/min class) with a pressure
    override of 2 MPa from cracking to its rated flow; w_r = 0.1 MPa (a smoothing choice).

    Parameters
    ----------
    cracking_ratio : float [-]   p_r / p_s
    rated_flow : float [m³/s]    Q_rN at p_r + Δp_o
    override : float [Pa]        Δp_o
    width : float [Pa]           w_r
    """

    cracking_ratio: float = 1.1
    rated_flow: float = 10.0 * LPM
    override: float = 2.0e6
    width: float = 1.0e5

    @property
    def conductance(self):
        """G_r = Q_rN / Δp_o [m³/(s Pa)]."""
        return self.rated_flow / self.override

    def cracking(self, supply):
        """p_r [Pa] for ``supply``."""
        return self.cracking_ratio * supply.pressure


def orifice(dp, laminar_drop):
    """g(Δp) = Δp / (Δp² + Δp_l²)^¼ [√Pa]: the turbulent √Δp law made linear below Δp_l."""
    return dp / jnp.sqrt(jnp.sqrt(dp * dp + laminar_drop * laminar_drop))


def _dorifice(dp, laminar_drop):
    """g'(Δp) = (Δp²/2 + Δp_l²) / (Δp² + Δp_l²)^(5/4) [1/√Pa] (> 0)."""
    s = dp * dp + laminar_drop * laminar_drop
    return (0.5 * dp * dp + laminar_drop * laminar_drop) / (s * jnp.sqrt(jnp.sqrt(s)))


def _ramp(u, w):
    """C¹ ramp: 0 (u ≤ 0), u²/2w (0 < u < w), u − w/2 (u ≥ w); and its derivative."""
    r = jnp.where(u <= 0.0, 0.0, jnp.where(u < w, 0.5 * u * u / w, u - 0.5 * w))
    d = jnp.clip(u / w, 0.0, 1.0)
    return r, d


def relief_flow(relief: ReliefValve, supply: Supply, p):
    """(Q_r, dQ_r/dp): the relief flow out of a chamber at pressure p [Pa] (:class:`ReliefValve`)."""
    r, d = _ramp(p - relief.cracking(supply), relief.width)
    g = relief.conductance
    return g * r, g * d


def oil_pressure(cyl: Cylinder, y):
    """p = P(y) [Pa]: the chamber pressure of the liquid-equivalent pressure y (the floor law of
    the module docstring), and dP/dy."""
    a, w = cyl.cavitation_pressure, cyl.cavitation_width
    u = y - a + w
    mid = a + u * u / (4 * w)
    p = jnp.where(y >= a + w, y, jnp.where(y <= a - w, a, mid))
    d = jnp.clip(u / (2 * w), 0.0, 1.0)
    return p, d


def oil_state(cyl: Cylinder, p):
    """y = P⁻¹(p) [Pa] for p above the floor (p ≤ p_c gives p_c − w, the onset of the cavity)."""
    a, w = cyl.cavitation_pressure, cyl.cavitation_width
    pn = jnp.asarray(p, jnp.float64)
    mid = a - w + 2.0 * jnp.sqrt(w * jnp.maximum(pn - a, 0.0))
    return jnp.where(pn >= a + w, pn, mid)


def _phi(cyl: Cylinder, y):
    """Φ(y) [Pa²] with Φ' = P(y) and Φ = y²/2 above the floor (the stored-energy density × β)."""
    a, w = cyl.cavitation_pressure, cyl.cavitation_width
    c = 0.5 * (a + w) ** 2 - a * (a + w) - 2.0 * w * w / 3.0
    yc = jnp.clip(y, a - w, a + w)
    mid = c + a * yc + (yc - a + w) ** 3 / (12 * w)
    return jnp.where(y >= a + w, 0.5 * y * y, mid + a * (y - yc))


def valve_flows(valve: ServoValve, xv, pa, pb, supply: Supply):
    """Flows of the 4/3 valve at spool x_v ∈ [−1, 1] (clipped), chamber pressures p_A, p_B [Pa].

    Returns a dict of arrays [m³/s or W]: ``qa``, ``qb`` (into the chambers), ``qs`` (from the
    supply), ``qt`` (to the tank), ``loss`` (Σ Q Δp over the four edges, ≥ 0), ``drawn``
    (p_s Q_s − p_t Q_t)."""
    xv = jnp.clip(xv, -1.0, 1.0)
    kv, dl = valve.flow_gain, valve.laminar_drop
    ps, pt = supply.pressure, supply.tank
    ap, an = jnp.maximum(xv, 0.0), jnp.maximum(-xv, 0.0)
    q_pa = kv * ap * orifice(ps - pa, dl)
    q_bt = kv * valve.port_ratio * ap * orifice(pb - pt, dl)
    q_at = kv * an * orifice(pa - pt, dl)
    q_pb = kv * valve.port_ratio * an * orifice(ps - pb, dl)
    qs, qt = q_pa + q_pb, q_at + q_bt
    loss = q_pa * (ps - pa) + q_bt * (pb - pt) + q_at * (pa - pt) + q_pb * (ps - pb)
    return {"qa": q_pa - q_at, "qb": q_pb - q_bt, "qs": qs, "qt": qt, "loss": loss, "drawn": ps * qs - pt * qt}


def chamber_rates(cyl: Cylinder, valve: ServoValve, supply: Supply, x, xdot, xv, ya, yb, relief: ReliefValve | None = None):
    """(ẏ_A, ẏ_B) [Pa/s] of the liquid-equivalent pressures (= ṗ above the cavitation floor): the
    pressure law of the module docstring with the relief flows."""
    pa, _ = oil_pressure(cyl, ya)
    pb, _ = oil_pressure(cyl, yb)
    f = valve_flows(valve, xv, pa, pb, supply)
    va, vb = cyl.volumes(x)
    ql = cyl.leakage * (pa - pb)
    qra = relief_flow(relief, supply, pa)[0] if relief is not None else 0.0
    qrb = relief_flow(relief, supply, pb)[0] if relief is not None else 0.0
    b = cyl.bulk_modulus
    return b / va * (f["qa"] - cyl.area_a * xdot - ql - qra), b / vb * (f["qb"] + cyl.area_b * xdot + ql - qrb)


def required_opening(cyl: Cylinder, valve: ServoValve, supply: Supply, xdot, force):
    """The spool opening [-] that moves the piston at ẋ [m/s] against the rod force F [N] in
    steady flow (turbulent orifices, no leakage): the valve-sizing law.

    Extending (ẋ > 0): A_A ẋ = K_v u √(p_s − p_A), A_B ẋ = α K_v u √(p_B − p_t) and
    F = p_A A_A − p_B A_B give (ẋ/K_v u)² (A_A³ + A_B³/α²) = D with D = p_s A_A − p_t A_B − F;
    retracting: D = p_s A_B − p_t A_A + F (α: ``valve.port_ratio``). So

        u = |ẋ| / K_v · √((A_A³ + A_B³/α²) / D).

    A value above 1: the valve cannot pass the flow the motion needs at that load (the motion is
    flow-limited); D ≤ 0: the force exceeds the static capacity (returned as inf). At F = 0,
    p_t = 0 and u = 1 this is the free piston's speed K_v √(A_A p_s/(A_A³ + A_B³)).
    """
    aa, ab = cyl.area_a, cyl.area_b
    ps, pt = supply.pressure, supply.tank
    xdot, force = jnp.asarray(xdot, jnp.float64), jnp.asarray(force, jnp.float64)
    d = jnp.where(xdot >= 0, ps * aa - pt * ab - force, ps * ab - pt * aa + force)
    u = jnp.abs(xdot) * jnp.sqrt((aa**3 + ab**3 / valve.port_ratio**2) / jnp.maximum(d, 1e-300)) / valve.flow_gain
    return jnp.where(d > 0, u, jnp.inf)


def cylinder_force(cyl: Cylinder, pa, pb):
    """F = p_A A_A − p_B A_B [N], positive extending."""
    return pa * cyl.area_a - pb * cyl.area_b


def spool_step(valve: ServoValve, xv, vv, u, h):
    """Spool position and rate after h [s] under the held command u (exact for the linear spool,
    then clipped at ±1: the spool's travel stops, its saturation)."""
    u = jnp.clip(u, -1.0, 1.0)
    w = 2.0 * math.pi * valve.bandwidth
    if valve.order == 1:
        a = jnp.exp(-w * h)
        return jnp.clip(u + (xv - u) * a, -1.0, 1.0), jnp.zeros_like(vv)
    # second order: ẍ + 2ζω ẋ + ω² (x − u) = 0, exact step by the matrix exponential (2×2)
    z = valve.damping
    A = jnp.array([[0.0, 1.0], [-w * w, -2 * z * w]])
    E = jax.scipy.linalg.expm(A * h)
    e0, e1 = xv - u, vv
    xn = u + E[0, 0] * e0 + E[0, 1] * e1
    vn = E[1, 0] * e0 + E[1, 1] * e1
    hit = jnp.abs(xn) >= 1.0
    return jnp.clip(xn, -1.0, 1.0), jnp.where(hit, 0.0, vn)


def integrate_chambers(cyl: Cylinder, valve: ServoValve, supply: Supply, ya, yb, xv, vv, u, x0, x1, T, substeps: int = 8,
                       relief: ReliefValve | None = None, newton: int = 4):
    """Advance the chambers and spool over [t, t + T] while the piston moves from x0 to x1.

    ``ya``, ``yb`` [Pa] are the chambers' liquid-equivalent pressures (their mass states; equal to
    the pressures above the cavitation floor, :func:`oil_pressure`). The piston moves linearly in
    time over the interval (the mechanism's motion, known at the end of a sample). Each of the
    ``substeps`` steps h = T/n advances the spool exactly (:func:`spool_step`), then each
    chamber's ln-mass μ = ln V + y/β by implicit Euler,

        μ_{k+1} = μ_k + h (Q(p_{k+1}) ∓ Q_L − Q_r(p_{k+1})) / V_{k+1},   y = β (μ − ln V),  p = P(y),

    (``newton`` iterations on the 2×2 system from the explicit predictor, analytic Jacobian), so
    mass is conserved exactly by the volume change and to the solver tolerance by the flows.
    ``relief``: the chambers' relief valves (None: none).

    Returns (ya, yb, xv, vv, acc) with ``acc`` a dict of interval integrals [J or m³]:
    ``drawn`` (p_s Q_s − p_t Q_t, the relief's return flow included), ``loss`` (valve),
    ``relief`` (Σ Q_r (p − p_t)), ``leak`` (leakage loss), ``port`` (∫ Σ p (Q − Q_r): the power into
    the chambers, = drawn − loss − relief), ``piston`` (∫ p dV: the work the oil does on the
    piston, both chambers), ``mass_a``, ``mass_b`` (the masses over ρ_0 the valve, leakage and
    relief moved, m_k (e^{h Q/V} − 1) per sub-step, → ∫ e^{y/β} Q dt), the last flows
    ``qa, qb, qs, qt, qra, qrb`` and the last pressures ``pa, pb``.
    """
    b = cyl.bulk_modulus
    kv, dl, ps, pt = valve.flow_gain, valve.laminar_drop, supply.pressure, supply.tank
    h = T / substeps
    zero = jnp.zeros_like(ya)
    acc = {k: zero for k in ("drawn", "loss", "relief", "leak", "port", "piston", "mass_a", "mass_b", "qa", "qb", "qs", "qt", "qra", "qrb",
                             "pa", "pb")}
    cl = cyl.leakage

    def rel(p):
        if relief is None:
            return zero, zero
        return relief_flow(relief, supply, p)

    va, vb = cyl.volumes(x0)
    for k in range(substeps):
        xk1 = x0 + (x1 - x0) * (k + 1) / substeps
        xv, vv = spool_step(valve, xv, vv, u, h)
        va1, vb1 = cyl.volumes(xk1)

        ya_k, yb_k = ya, yb
        # explicit predictor (the volume change enters exactly), then Newton on the 2×2 system
        # (analytic Jacobian: each chamber's flows depend on its own pressure, leakage couples)
        ya_n = ya_k + b * jnp.log(va / va1)
        yb_n = yb_k + b * jnp.log(vb / vb1)
        ap, an = jnp.maximum(jnp.clip(xv, -1.0, 1.0), 0.0), jnp.maximum(-jnp.clip(xv, -1.0, 1.0), 0.0)
        ca, cb = h * b / va1, h * b / vb1
        for _ in range(newton):
            pa_n, dpa = oil_pressure(cyl, ya_n)
            pb_n, dpb = oil_pressure(cyl, yb_n)
            f = valve_flows(valve, xv, pa_n, pb_n, supply)
            ql = cl * (pa_n - pb_n)
            qra, dqra = rel(pa_n)
            qrb, dqrb = rel(pb_n)
            ra = ya_n - ya_k - b * jnp.log(va / va1) - ca * (f["qa"] - ql - qra)
            rb = yb_n - yb_k - b * jnp.log(vb / vb1) - cb * (f["qb"] + ql - qrb)
            dqa = -kv * (ap * _dorifice(ps - pa_n, dl) + an * _dorifice(pa_n - pt, dl))
            dqb = -kv * valve.port_ratio * (an * _dorifice(ps - pb_n, dl) + ap * _dorifice(pb_n - pt, dl))
            j11 = 1.0 - ca * (dqa - cl - dqra) * dpa
            j12 = -ca * cl * dpb
            j21 = -cb * cl * dpa
            j22 = 1.0 - cb * (dqb - cl - dqrb) * dpb
            det = j11 * j22 - j12 * j21
            ya_n = ya_n - (j22 * ra - j12 * rb) / det
            yb_n = yb_n - (j11 * rb - j21 * ra) / det
        ya, yb = ya_n, yb_n
        pa, _ = oil_pressure(cyl, ya)
        pb, _ = oil_pressure(cyl, yb)
        f = valve_flows(valve, xv, pa, pb, supply)
        ql = cl * (pa - pb)
        qra, _ = rel(pa)
        qrb, _ = rel(pb)
        dva, dvb = va1 - va, vb1 - vb
        acc["drawn"] = acc["drawn"] + h * (f["drawn"] - pt * (qra + qrb))
        acc["loss"] = acc["loss"] + h * f["loss"]
        acc["relief"] = acc["relief"] + h * (qra * (pa - pt) + qrb * (pb - pt))
        acc["leak"] = acc["leak"] + h * ql * (pa - pb)
        acc["port"] = acc["port"] + h * (pa * (f["qa"] - qra) + pb * (f["qb"] - qrb))
        acc["piston"] = acc["piston"] + pa * dva + pb * dvb
        # the mass moved in this sub-step, m_k (e^{h Q/V} − 1) (→ h e^{y/β} Q as h → 0)
        acc["mass_a"] = acc["mass_a"] + va * jnp.exp(ya_k / b) * jnp.expm1(h * (f["qa"] - ql - qra) / va1)
        acc["mass_b"] = acc["mass_b"] + vb * jnp.exp(yb_k / b) * jnp.expm1(h * (f["qb"] + ql - qrb) / vb1)
        acc.update(qa=f["qa"], qb=f["qb"], qs=f["qs"], qt=f["qt"] + qra + qrb, qra=qra, qrb=qrb, pa=pa, pb=pb)
        va, vb = va1, vb1
    return ya, yb, xv, vv, acc


def chamber_mass(cyl: Cylinder, x, ya, yb):
    """(m_A, m_B)/ρ_0 = V e^{y/β} [m³]: the conserved chamber masses over the reference density
    (y the liquid-equivalent pressures, = p above the cavitation floor)."""
    va, vb = cyl.volumes(x)
    return va * jnp.exp(ya / cyl.bulk_modulus), vb * jnp.exp(yb / cyl.bulk_modulus)


def compression_energy(cyl: Cylinder, x, ya, yb):
    """Σ V Φ(y)/β [J]: the elastic energy stored in the compressed oil (constant-volume form;
    V p²/2β above the cavitation floor, Φ' = P: a cavity stores p_c dV)."""
    va, vb = cyl.volumes(x)
    return (va * _phi(cyl, ya) + vb * _phi(cyl, yb)) / cyl.bulk_modulus
