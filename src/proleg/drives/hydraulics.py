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

Cavitation is not modelled: a chamber pressure may fall below the tank pressure (then the
result shows it; keep the supply and loads in the range where it does not).
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp

__all__ = ["Cylinder", "ServoValve", "Supply", "orifice", "valve_flows", "chamber_rates", "integrate_chambers", "cylinder_force"]

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
    order : int (static), 1 or 2   spool dynamics
    """

    rated_flow: float = 2.5 * LPM
    rated_drop: float = 7.0e6
    bandwidth: float = 250.0
    damping: float = 0.7
    laminar_drop: float = 1.0e5
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


def orifice(dp, laminar_drop):
    """g(Δp) = Δp / (Δp² + Δp_l²)^¼ [√Pa]: the turbulent √Δp law made linear below Δp_l."""
    return dp / jnp.sqrt(jnp.sqrt(dp * dp + laminar_drop * laminar_drop))


def _dorifice(dp, laminar_drop):
    """g'(Δp) = (Δp²/2 + Δp_l²) / (Δp² + Δp_l²)^(5/4) [1/√Pa] (> 0)."""
    s = dp * dp + laminar_drop * laminar_drop
    return (0.5 * dp * dp + laminar_drop * laminar_drop) / (s * jnp.sqrt(jnp.sqrt(s)))


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
    q_bt = kv * ap * orifice(pb - pt, dl)
    q_at = kv * an * orifice(pa - pt, dl)
    q_pb = kv * an * orifice(ps - pb, dl)
    qs, qt = q_pa + q_pb, q_at + q_bt
    loss = q_pa * (ps - pa) + q_bt * (pb - pt) + q_at * (pa - pt) + q_pb * (ps - pb)
    return {"qa": q_pa - q_at, "qb": q_pb - q_bt, "qs": qs, "qt": qt, "loss": loss, "drawn": ps * qs - pt * qt}


def chamber_rates(cyl: Cylinder, valve: ServoValve, supply: Supply, x, xdot, xv, pa, pb):
    """(ṗ_A, ṗ_B) [Pa/s]: the pressure law of the module docstring."""
    f = valve_flows(valve, xv, pa, pb, supply)
    va, vb = cyl.volumes(x)
    ql = cyl.leakage * (pa - pb)
    b = cyl.bulk_modulus
    return b / va * (f["qa"] - cyl.area_a * xdot - ql), b / vb * (f["qb"] + cyl.area_b * xdot + ql)


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


def integrate_chambers(cyl: Cylinder, valve: ServoValve, supply: Supply, pa, pb, xv, vv, u, x0, x1, T, substeps: int = 8):
    """Advance the chambers and spool over [t, t + T] while the piston moves from x0 to x1.

    The piston moves linearly in time over the interval (the mechanism's motion, known at the
    end of a sample). Each of the ``substeps`` steps h = T/n advances the spool exactly
    (:func:`spool_step`), then each chamber's ln-mass μ = ln V + p/β by implicit Euler,

        μ_{k+1} = μ_k + h (Q(p_{k+1}) ∓ Q_L) / V_{k+1},   p = β (μ − ln V),

    (two Newton iterations on the scalar equation, from the explicit predictor), so mass is
    conserved exactly by the volume change and to the solver tolerance by the flows.

    Returns (pa, pb, xv, vv, acc) with ``acc`` a dict of interval integrals [J or m³]:
    ``drawn``, ``loss`` (valve), ``leak`` (leakage loss), ``port`` (∫ p_A Q_A + p_B Q_B),
    ``piston`` (∫ p dV: the work the oil does on the piston, both chambers), ``mass_a``,
    ``mass_b`` (the masses over ρ_0 the valve and leakage moved, m_k (e^{h Q/V} − 1) per
    sub-step, → ∫ e^{p/β} Q dt), and the last flows ``qa, qb, qs, qt``.
    """
    b = cyl.bulk_modulus
    kv, dl, ps, pt = valve.flow_gain, valve.laminar_drop, supply.pressure, supply.tank
    h = T / substeps
    zero = jnp.zeros_like(pa)
    acc = {k: zero for k in ("drawn", "loss", "leak", "port", "piston", "mass_a", "mass_b", "qa", "qb", "qs", "qt")}
    va, vb = cyl.volumes(x0)
    for k in range(substeps):
        xk1 = x0 + (x1 - x0) * (k + 1) / substeps
        xv, vv = spool_step(valve, xv, vv, u, h)
        va1, vb1 = cyl.volumes(xk1)

        pa_k, pb_k = pa, pb
        # explicit predictor (the volume change enters exactly), then Newton on the 2×2 system
        # (analytic Jacobian: each chamber's flow depends on its own pressure, leakage couples)
        pa_n = pa_k + b * jnp.log(va / va1)
        pb_n = pb_k + b * jnp.log(vb / vb1)
        ap, an = jnp.maximum(jnp.clip(xv, -1.0, 1.0), 0.0), jnp.maximum(-jnp.clip(xv, -1.0, 1.0), 0.0)
        for _ in range(3):
            f = valve_flows(valve, xv, pa_n, pb_n, supply)
            ql = cyl.leakage * (pa_n - pb_n)
            ra = pa_n - pa_k - b * jnp.log(va / va1) - h * b * (f["qa"] - ql) / va1
            rb = pb_n - pb_k - b * jnp.log(vb / vb1) - h * b * (f["qb"] + ql) / vb1
            dqa = -kv * (ap * _dorifice(ps - pa_n, dl) + an * _dorifice(pa_n - pt, dl))
            dqb = -kv * (an * _dorifice(ps - pb_n, dl) + ap * _dorifice(pb_n - pt, dl))
            ca, cb = h * b / va1, h * b / vb1
            j11 = 1.0 - ca * (dqa - cyl.leakage)
            j12 = -ca * cyl.leakage
            j21 = -cb * cyl.leakage
            j22 = 1.0 - cb * (dqb - cyl.leakage)
            det = j11 * j22 - j12 * j21
            pa_n = pa_n - (j22 * ra - j12 * rb) / det
            pb_n = pb_n - (j11 * rb - j21 * ra) / det
        pa, pb = pa_n, pb_n
        f = valve_flows(valve, xv, pa, pb, supply)
        ql = cyl.leakage * (pa - pb)
        dva, dvb = va1 - va, vb1 - vb
        acc["drawn"] = acc["drawn"] + h * f["drawn"]
        acc["loss"] = acc["loss"] + h * f["loss"]
        acc["leak"] = acc["leak"] + h * ql * (pa - pb)
        acc["port"] = acc["port"] + h * (pa * f["qa"] + pb * f["qb"])
        acc["piston"] = acc["piston"] + pa * dva + pb * dvb
        # the mass the valve moved in this sub-step, m_k (e^{h Q/V} − 1) (→ h e^{p/β} Q as h → 0)
        acc["mass_a"] = acc["mass_a"] + va * jnp.exp(pa_k / b) * jnp.expm1(h * (f["qa"] - ql) / va1)
        acc["mass_b"] = acc["mass_b"] + vb * jnp.exp(pb_k / b) * jnp.expm1(h * (f["qb"] + ql) / vb1)
        acc.update(qa=f["qa"], qb=f["qb"], qs=f["qs"], qt=f["qt"])
        va, vb = va1, vb1
    return pa, pb, xv, vv, acc


def chamber_mass(cyl: Cylinder, x, pa, pb):
    """(m_A, m_B)/ρ_0 = V e^{p/β} [m³]: the conserved chamber masses over the reference density."""
    va, vb = cyl.volumes(x)
    return va * jnp.exp(pa / cyl.bulk_modulus), vb * jnp.exp(pb / cyl.bulk_modulus)


def compression_energy(cyl: Cylinder, x, pa, pb):
    """Σ V p²/(2β) [J]: the elastic energy stored in the compressed oil (constant-volume form)."""
    va, vb = cyl.volumes(x)
    return (va * pa * pa + vb * pb * pb) / (2.0 * cyl.bulk_modulus)
