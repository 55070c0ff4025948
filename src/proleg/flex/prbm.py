"""Pseudo-rigid-body (PRB 1R) model of a cantilever with an end force, static and dynamic.

Static PRB 1R model (Howell 2001, *Compliant Mechanisms*, §5.3; seed 002, Eqs. 1-8)
---------------------------------------------------------------------------------------
A cantilever of length L is replaced by a rigid link of length gamma L, pinned at the
*characteristic pivot* a distance (1 - gamma) L from the clamp, with a torsion spring

    K_t = gamma K_Theta E I / L                                            (Eq. 2)

For a PRB angle Theta the tip is at (x along the undeformed beam, y transverse)

    a / L = 1 - gamma (1 - cos Theta),   b / L = gamma sin Theta           (Eq. 1)

and the tip slope is theta_0 = c_theta Theta. A non-follower end force with transverse
component P and axial component n P (n > 0 pushes the tip towards the clamp) gives the
tangential load P_t = P (cos Theta + n sin Theta) (Eqs. 5-6, phi = 90 deg for n = 0) and the
moment balance K_t Theta = P_t gamma L, i.e. alpha_t^2 = P_t L^2 / (E I) = K_Theta Theta
(Eqs. 4, 7). For n = 0 this is Eq. 8 of seed 002:

    cos(asin(b / (gamma L))) / asin(b / (gamma L)) = K_t / (gamma P L).    (Eq. 8)

Load-direction dependence (Howell & Midha 1995, J. Mech. Des. 117:156; Howell 2001
Tables 5.1-5.2), n = axial / transverse load ratio:

- gamma(n) = 0.841655 - 0.0067807 n + 0.000438 n^2   (0.5 < n <= 10)
             0.852144 - 0.0182867 n                  (-1.8316 < n <= 0.5)
             0.912364 + 0.0145928 n                  (-5 <= n <= -1.8316)
- K_Theta(n) = 3.024112 + 0.121290 n + 0.003169 n^2                          (-5 < n <= -2.5)
               1.967647 - 2.616021 n - 3.738166 n^2 - 2.649437 n^3
                 - 0.891906 n^4 - 0.113063 n^5                               (-2.5 < n <= -1)
               2.654855 - 0.0509896 n + 0.0126749 n^2 - 0.00142039 n^3
                 + 0.0000584525 n^4                                          (-1 < n <= 10)
- c_theta(n): Howell's tabulated values, interpolated linearly (:data:`C_THETA_TABLE`).

For a purely transverse force (n = 0) the classical values are gamma = 0.8517 (0.85),
c_theta = 1.2385 and K_Theta = 2.65 (the average over the range; seed 002 quotes 1.239 and
2.649), valid for Theta <= 64.3 deg: over that range the PRB tip path stays within 0.5 % of L
of the elastica (tested against :func:`elastica_tip`). K_Theta = 2.65 is a range average: for
very small Theta the exact value is 3 gamma = 2.555, so the PRB load at a given deflection
is up to ~4 % high there.

Dynamic PRBM (seed 002, Eqs. 3, 9-11)
-------------------------------------
Seed 002 gives the PRB link the first bending frequency of the continuous cantilever,

    omega_1 = (beta_1 L)^2 / L^2 sqrt(E I / lambda),  beta_1 L = 1.8751   (Eq. 3)
    J = rho gamma L W t / 3 ((gamma L)^2 + t^2 / 4)                    (Eq. 10, about the pivot)
    K_t = J omega_1^2,  C_t = 2 xi sqrt(K_t J)                          (Eqs. 9, 11)

and solves Eqs. 8, 9, 11 for (gamma, K_t, C_t) given a tip deflection b under a load P.
Interpretation of the seed-002 worked example (case 6, 300 x 50 x 3 mm, E = 200 GPa,
rho = 7800 kg/m^3, xi = 0.015):

- omega_1 = 171.3194 rad/s needs the exact root beta_1 L = 1.87510407 (1.875 gives
  171.300); the printed "27.2663 deg/s" is the frequency in Hz.
- gamma = 0.7377, J = 4226.8 kg mm^2, K_t = 2165.2 N mm/deg, C_t = 0.3792 N mm s/deg are all
  reproduced to the printed digits by b = 11.82 mm (gamma = 0.73766); the printed
  "b approximately equal to 12 mm" is that value rounded. b = 12.00 mm is exactly the linear
  P L^3 / (3 E I) and would give gamma = 0.7265 (-1.5 %); a clamped 3D solid model of the
  strip (plate effect near the clamp) gives ~11.8 mm, which is presumably where the paper's
  value comes from. b = 11.8 mm gives gamma = 0.7389 (+0.2 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, root
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from ..errors import ConvergenceError, ModelError
from ..fem.materials import Material
from ..fem.materials import material as _material

#: first root of cos(bL) cosh(bL) = -1 (cantilever, Eq. 3)
BETA1_L = 1.8751040687
#: Howell's PRB 1R constants for a transverse end force (n = 0)
GAMMA_VERTICAL = 0.8517
C_THETA_VERTICAL = 1.2385
K_THETA_VERTICAL = 2.65
THETA_MAX_VERTICAL = math.radians(64.3)
#: Howell (2001) Table 5.1, c_theta against n
C_THETA_TABLE = np.array([
    [-5.0, -4.0, -3.0, -2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 7.5, 10.0],
    [1.1788, 1.1971, 1.2119, 1.2293, 1.2322, 1.2323, 1.2348, 1.2385, 1.2430, 1.2467, 1.2492, 1.2511, 1.2534,
     1.2548, 1.2557, 1.2570, 1.2578],
])


@dataclass(frozen=True)
class PRBMCoefficients:
    """PRB 1R coefficients for a load ratio n (axial / transverse), dimensionless."""

    n: float
    gamma: float
    c_theta: float
    K_Theta: float


def prbm_coefficients(n: float = 0.0) -> PRBMCoefficients:
    """gamma(n), c_theta(n), K_Theta(n) of Howell's fits (module docstring), -5 <= n <= 10.

    n = 0 returns the classical transverse-force constants 0.8517, 1.2385, 2.65.
    """
    n = float(n)
    if not -5.0 <= n <= 10.0:
        raise ModelError(f"PRBM load ratio n = {n} is outside Howell's fitted range -5 <= n <= 10 "
                         "(n = axial / transverse end-force component, > 0 compressive).")
    if n == 0.0:
        return PRBMCoefficients(0.0, GAMMA_VERTICAL, C_THETA_VERTICAL, K_THETA_VERTICAL)
    if n > 0.5:
        gamma = 0.841655 - 0.0067807 * n + 0.000438 * n**2
    elif n > -1.8316:
        gamma = 0.852144 - 0.0182867 * n
    else:
        gamma = 0.912364 + 0.0145928 * n
    if n <= -2.5:
        k = 3.024112 + 0.121290 * n + 0.003169 * n**2
    elif n <= -1.0:
        k = 1.967647 - 2.616021 * n - 3.738166 * n**2 - 2.649437 * n**3 - 0.891906 * n**4 - 0.113063 * n**5
    else:
        k = 2.654855 - 0.0509896 * n + 0.0126749 * n**2 - 0.00142039 * n**3 + 0.0000584525 * n**4
    c = float(np.interp(n, *C_THETA_TABLE))
    return PRBMCoefficients(n, gamma, c, k)


def tip_position(gamma: float, Theta, length: float = 1.0):
    """PRB tip coordinates (a, b) [units of ``length``] for PRB angle ``Theta`` [rad] (Eq. 1)."""
    Theta = np.asarray(Theta, float)
    return length * (1.0 - gamma * (1.0 - np.cos(Theta))), length * gamma * np.sin(Theta)


def prbm_static(load: float, length: float, EI: float, n: float = 0.0) -> tuple[float, float, float, float]:
    """Static PRB 1R deflection under a non-follower end force.

    Parameters
    ----------
    load : float [N]        transverse component P (>= 0)
    length : float [m]      L
    EI : float [N m^2]      bending stiffness
    n : float               axial / transverse ratio (axial component n P, > 0 compressive)

    Returns
    -------
    Theta [rad], a [m], b [m], theta_0 [rad]  from K_t Theta = P gamma L (cos Theta + n sin Theta).
    """
    c = prbm_coefficients(n)
    if load < 0:
        raise ModelError(f"prbm_static load must be >= 0 [N]; got {load}. Flip the axes for a negative load.")
    if load == 0:
        return 0.0, length, 0.0, 0.0
    Kt = c.gamma * c.K_Theta * EI / length
    f = lambda th: Kt * th - load * c.gamma * length * (np.cos(th) + n * np.sin(th))  # noqa: E731
    Theta = brentq(f, 0.0, math.pi / 2, xtol=1e-14)
    a, b = tip_position(c.gamma, Theta, length)
    return Theta, float(a), float(b), c.c_theta * Theta


def load_deflection(K_t: float, gamma: float, length: float, load: float) -> float:
    """Tip deflection b [m] under a transverse end load ``load`` [N] from Eq. 8 (n = 0).

    Solves cos(Theta) / Theta = K_t / (gamma P L), b = gamma L sin Theta, with K_t [N m/rad].
    """
    if load <= 0:
        return 0.0
    r = K_t / (gamma * load * length)
    Theta = brentq(lambda th: np.cos(th) - r * th, 0.0, math.pi / 2, xtol=1e-15)
    return float(gamma * length * math.sin(Theta))


def elastica_tip(load: float, length: float, EI: float) -> tuple[float, float, float]:
    """Exact large-deflection tip of a cantilever under a transverse non-follower end force.

    Bisshopp & Drucker (1945): with alpha^2 = P L^2 / (E I), tip slope theta_0,
    k^2 = (1 + sin theta_0) / 2 and sin phi_1 = 1 / (k sqrt 2),

        alpha = K(k) - F(phi_1, k),
        a / L = sqrt(2 sin theta_0) / alpha,
        b / L = 1 - 2 (E(k) - E(phi_1, k)) / alpha.

    Returns a [m] (along the undeformed beam), b [m] (transverse), theta_0 [rad].
    """
    if load <= 0:
        return float(length), 0.0, 0.0
    alpha = math.sqrt(load * length**2 / EI)

    def parts(th0):
        m = 0.5 * (1.0 + math.sin(th0))
        p1 = math.asin(1.0 / math.sqrt(2.0 * m))
        return m, p1, ellipk(m) - ellipkinc(p1, m)

    hi = math.pi / 2 - 1e-13
    if parts(hi)[2] <= alpha:
        raise ModelError(f"elastica_tip: load {load} N is too large for a numerically resolved solution "
                         "(the beam is essentially aligned with the force).")
    th0 = brentq(lambda t: parts(t)[2] - alpha, 1e-15, hi, xtol=1e-15)
    m, p1, _ = parts(th0)
    a = math.sqrt(2.0 * math.sin(th0)) / alpha
    b = 1.0 - 2.0 * (ellipe(m) - ellipeinc(p1, m)) / alpha
    return a * length, b * length, th0


def cantilever_first_omega(length: float, E: float, I: float, mass_per_length: float) -> float:
    """First bending frequency of a uniform cantilever [rad/s] (Eq. 3, beta_1 L = 1.87510407)."""
    return BETA1_L**2 / length**2 * math.sqrt(E * I / mass_per_length)


def link_inertia(gamma: float, length: float, width: float, thickness: float, rho: float) -> float:
    """J = rho gamma L W t / 3 ((gamma L)^2 + t^2 / 4) [kg m^2]: the PRB link about the pivot (Eq. 10)."""
    return rho * gamma * length * width * thickness / 3.0 * ((gamma * length) ** 2 + thickness**2 / 4.0)


def _geometry(length, width, thickness):
    vals = []
    for name, v in (("length", length), ("width", width), ("thickness", thickness)):
        v = float(v)
        if not (math.isfinite(v) and v > 0):
            raise ModelError(f"PRBM strip {name} must be a positive length in m; got {v!r}.")
        vals.append(v)
    return vals


@dataclass(frozen=True)
class PRBMLink:
    """A dynamic PRB 1R model of a rectangular strip cantilever (SI units).

    Attributes
    ----------
    gamma : float [-]              characteristic radius factor
    K_t : float [N m/rad]          torsion-spring stiffness
    C_t : float [N m s/rad]        torsion-spring damping
    J : float [kg m^2]             PRB link inertia about the pivot (Eq. 10)
    omega_1 : float [rad/s]        first bending frequency of the continuous cantilever (Eq. 3)
    K_Theta, c_theta : float [-]   stiffness and angle coefficients (Howell, n = 0)
    length, width, thickness : float [m]
    material : Material
    damping_ratio : float [-]
    """

    gamma: float
    K_t: float
    C_t: float
    J: float
    omega_1: float
    K_Theta: float
    c_theta: float
    length: float
    width: float
    thickness: float
    material: Material
    damping_ratio: float

    # -- constructors ------------------------------------------------------------------------
    @classmethod
    def from_gamma(cls, gamma, length, width, thickness, material, damping_ratio=0.015) -> PRBMLink:
        """Dynamic PRB link for a given gamma: J (Eq. 10), K_t = J omega_1^2 (Eq. 9), C_t (Eq. 11)."""
        L, W, t = _geometry(length, width, thickness)
        mat = _material(material)
        if not 0.0 < gamma < 1.0:
            raise ModelError(f"PRBM gamma = {gamma} must lie in (0, 1): the pivot is inside the strip.")
        if not damping_ratio >= 0:
            raise ModelError(f"PRBM damping_ratio must be >= 0; got {damping_ratio}.")
        I = W * t**3 / 12.0
        w1 = cantilever_first_omega(L, mat.E, I, mat.rho * W * t)
        J = link_inertia(gamma, L, W, t, mat.rho)
        K = J * w1**2
        C = 2.0 * damping_ratio * math.sqrt(K * J)
        K_Theta = K * L / (gamma * mat.E * I)  # Eq. 2 solved for K_Theta
        return cls(float(gamma), K, C, J, w1, K_Theta, C_THETA_VERTICAL, L, W, t, mat, float(damping_ratio))

    @property
    def EI(self) -> float:
        """Bending stiffness about the thin direction E W t^3 / 12 [N m^2]."""
        return self.material.E * self.width * self.thickness**3 / 12.0

    @property
    def mass(self) -> float:
        """Strip mass rho L W t [kg]."""
        return self.material.rho * self.length * self.width * self.thickness

    def deflection(self, load: float) -> float:
        """Static tip deflection [m] of this PRB link under a transverse end load [N] (Eq. 8)."""
        return load_deflection(self.K_t, self.gamma, self.length, load)

    def as_dict(self) -> dict:
        """CLI/JSON summary: gamma, K_t [N m/rad], C_t [N m s/rad], J [kg m^2], omega_1 [rad/s], K_Theta, c_theta."""
        return {k: float(getattr(self, k)) for k in ("gamma", "K_t", "C_t", "J", "omega_1", "K_Theta", "c_theta")}

    # -- model insertion ---------------------------------------------------------------------
    def to_model(self, model, parent, at, axis, direction=(0.0, 0.0, -1.0), name: str = "flex_link"):
        """Insert the PRB link into a :class:`proleg.Model` (ground coordinates, modelled pose).

        Creates two rigid box segments of the strip split at the characteristic pivot,
        ``{name}.base`` (clamp to pivot, length (1 - gamma) L) and ``{name}.tip`` (pivot to tip,
        length gamma L), a :class:`proleg.Fixed` ``{name}.clamp`` between ``parent`` and the
        base, a :class:`proleg.Revolute` ``{name}.pivot`` (I = tip segment, J = base segment)
        about ``axis`` at the pivot, a :class:`proleg.RotationalSpringDamper`
        ``{name}.spring`` (K_t, C_t) on that joint, and a marker ``{name}.tip`` on the tip.

        Parameters
        ----------
        model : proleg.Model
        parent : Part            the part the strip is clamped to (or ``model.ground``)
        at : (3,) [m]            clamp point (root of the strip)
        axis : (3,)              bending axis = the strip's width direction, normal to ``direction``
        direction : (3,)         from clamp to tip along the undeformed strip (default -z, hanging)
        name : str               prefix of the created element names

        Returns
        -------
        dict with keys base, tip, clamp, pivot, spring, tip_marker
        """
        from ..model.forces import RotationalSpringDamper
        from ..model.joints import Fixed, Revolute

        at = np.asarray(at, float)
        e1 = np.asarray(direction, float)
        e3 = np.asarray(axis, float)
        if e1.shape != (3,) or e3.shape != (3,) or np.linalg.norm(e1) == 0 or np.linalg.norm(e3) == 0:
            raise ModelError(f"PRBMLink '{name}': direction and axis must be non-zero 3-vectors.")
        e1, e3 = e1 / np.linalg.norm(e1), e3 / np.linalg.norm(e3)
        if abs(e1 @ e3) > 1e-6:
            raise ModelError(f"PRBMLink '{name}': axis {e3.tolist()} must be perpendicular to the strip direction "
                             f"{e1.tolist()} (the bending axis runs along the strip width).")
        R = np.column_stack([e1, np.cross(e3, e1), e3])  # strip axes: length, thickness, width
        L, W, t, rho = self.length, self.width, self.thickness, self.material.rho

        def box(seg_len):
            m = rho * seg_len * W * t
            Ib = m / 12.0 * np.array([t**2 + W**2, seg_len**2 + W**2, seg_len**2 + t**2])
            Ig = R @ np.diag(Ib) @ R.T
            return m, 0.5 * (Ig + Ig.T)

        l1, l2 = (1.0 - self.gamma) * L, self.gamma * L
        pivot = at + l1 * e1
        m1, I1 = box(l1)
        m2, I2 = box(l2)
        base = model.add_part(f"{name}.base", m1, I1, at + 0.5 * l1 * e1)
        tip = model.add_part(f"{name}.tip", m2, I2, pivot + 0.5 * l2 * e1)
        clamp = model.add_joint(Fixed(f"{name}.clamp", base, parent, at=at))
        pin = model.add_joint(Revolute(f"{name}.pivot", tip, base, at=pivot, axis=e3))
        spring = model.add_force(RotationalSpringDamper(f"{name}.spring", joint=pin, stiffness=self.K_t,
                                                        damping=self.C_t))
        marker = model.add_marker(tip, f"{name}.tip", at + L * e1)
        return {"base": base, "tip": tip, "clamp": clamp, "pivot": pin, "spring": spring, "tip_marker": marker}


def dynamic_prbm(length, width, thickness, material="aisi304", load: float = 30.0, deflection: float | None = None,
                 damping_ratio: float = 0.015, gamma_guess: float = GAMMA_VERTICAL) -> PRBMLink:
    """Solve the seed-002 system (Eqs. 8, 9, 11) for gamma, K_t, C_t of a strip cantilever.

    Parameters
    ----------
    length, width, thickness : float [m]   strip L, W, t (bending about the thickness)
    material : str or Material             default AISI 304
    load : float [N]                       transverse tip load P of the calibration case
    deflection : float [m], optional       measured/computed tip deflection b under ``load``;
                                           default: the exact elastica deflection
    damping_ratio : float [-]              xi of Eq. 11
    gamma_guess : float                    initial guess (Howell's 0.85, as in seed 002)

    Solved with ``scipy.optimize.root`` (hybrid Powell) on the dimensionless residuals
    Eq. 8 (as cos Theta - Theta K_t / (gamma P L)), K_t / (J omega_1^2) - 1 and
    C_t / (2 xi sqrt(K_t J)) - 1 in the scaled unknowns (gamma, K_t / K_0, C_t / C_0).
    """
    L, W, t = _geometry(length, width, thickness)
    mat = _material(material)
    if not (math.isfinite(load) and load > 0):
        raise ModelError(f"dynamic_prbm load must be a positive transverse tip force in N; got {load!r}.")
    EI = mat.E * W * t**3 / 12.0
    if deflection is None:
        deflection = elastica_tip(load, L, EI)[1]
    b = float(deflection)
    if not (math.isfinite(b) and 0 < b < L):
        raise ModelError(f"dynamic_prbm deflection must lie in (0, L = {L} m); got {deflection!r} m. "
                         "Give the tip deflection in metres (e.g. 11.8e-3).")
    xi = float(damping_ratio)
    w1 = cantilever_first_omega(L, mat.E, EI / mat.E, mat.rho * W * t)
    J0 = link_inertia(gamma_guess, L, W, t, mat.rho)
    K0 = J0 * w1**2
    C0 = 2 * max(xi, 1e-3) * math.sqrt(K0 * J0)

    def residual(x):
        g, K, C = x[0], x[1] * K0, x[2] * C0
        s = b / (g * L)
        if not (0 < g < 1.5 and 0 < s < 1 and K > 0 and C >= 0):
            return np.full(3, 1e3)
        J = link_inertia(g, L, W, t, mat.rho)
        th = math.asin(s)
        return np.array([
            math.cos(th) - th * K / (g * load * L),       # Eq. 8
            K / (J * w1**2) - 1.0,                        # Eq. 9
            C / C0 - 2 * xi * math.sqrt(K * J) / C0,      # Eq. 11
        ])

    sol = root(residual, np.array([gamma_guess, 1.0, 2 * xi * math.sqrt(K0 * J0) / C0]), method="hybr", tol=1e-12)
    if np.max(np.abs(residual(sol.x))) > 1e-9:  # judge by the residual: hybr may stop at its xtol
        raise ConvergenceError(
            f"dynamic_prbm did not converge for L = {L} m, P = {load} N, b = {b} m ({sol.message}). "
            "Check that the deflection belongs to the load, or pass a different gamma_guess.")
    g = float(sol.x[0])
    if not 0 < g < 1:
        raise ModelError(
            f"dynamic_prbm: the deflection b = {b:.4g} m under P = {load} N needs gamma = {g:.4g}, outside (0, 1): "
            "the strip cannot have that frequency and that static compliance at once. Check the units of "
            "load and deflection.")
    link = PRBMLink.from_gamma(g, L, W, t, mat, xi)
    return link


def static_prbm(length, width, thickness, material="aisi304", damping_ratio: float = 0.015, n: float = 0.0) -> PRBMLink:
    """Classical (Howell) PRB link: gamma(n), K_t = gamma K_Theta E I / L (Eq. 2), J of Eq. 10,
    C_t from the damping ratio with that K_t and J. Its frequency sqrt(K_t / J) is *not* omega_1."""
    L, W, t = _geometry(length, width, thickness)
    mat = _material(material)
    c = prbm_coefficients(n)
    I = W * t**3 / 12.0
    K = c.gamma * c.K_Theta * mat.E * I / L
    J = link_inertia(c.gamma, L, W, t, mat.rho)
    w1 = cantilever_first_omega(L, mat.E, I, mat.rho * W * t)
    return PRBMLink(c.gamma, K, 2 * damping_ratio * math.sqrt(K * J), J, w1, c.K_Theta, c.c_theta, L, W, t, mat,
                    float(damping_ratio))
