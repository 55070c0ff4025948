"""FE analysis of a torque-sensor design: both load cases, both directions, gauge metrics.

See :mod:`proleg.robots.torque_sensor` for the concepts, the envelope, the load cases and the
bidirectionality model. Outputs (``SensorResult.metrics``):

stiffness [N m/deg], twist [deg] at the torque (case A), max_von_mises [Pa] and where, over
both cases and directions (the averaged vertex stress, :meth:`proleg.fem.SolidModel.vertex_stress`), excluding a band ``interface_band`` [m] next to the bolted interface
faces (where the idealised clamp gives a stress singularity), safety_factor = yield / max vM,
gauge_strain [-] (largest magnitude over the gauges, CW and CCW, both cases),
strain_in_range (min_gauge_strain <= gauge_strain <= max_gauge_strain), gauge_planar,
gauge_reachable, gauge_flatness [m], gauge_clearance [m], calibration_ccw / calibration_cw
[mV/V per N m], calibration_mismatch [-] = |c_ccw - c_cw| / mean, reaction_torque_error [-].
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..errors import ConvergenceError, ModelError
from .torque_sensor import FILLET_SIZE, GRID, sensor_design


@dataclass
class SensorResult:
    """Outcome of :func:`torque_sensor_analysis`: ``metrics`` (dict), ``gauges`` (DataFrame, one
    row per gauge, case and direction), the ``model`` (SolidModel), ``design`` and the
    displacement fields ``solutions[(case, direction)]`` (ndof,) [m]."""

    metrics: dict
    gauges: pd.DataFrame
    model: object
    design: object
    solutions: dict = field(default_factory=dict)
    von_mises: dict = field(default_factory=dict)  # (case, dir) -> (ne, nq) [Pa]
    qp_coordinates: np.ndarray | None = None


def _facets_on(model, predicate):
    f = model.mesh.boundary_facets()
    v = model.mesh.p[:, model.mesh.facets[:, f]]  # (3, 3 vertices, nf)
    ok = np.all(predicate(v[0], v[1], v[2]), axis=0)
    return f[ok]


def _geometric_stiffness(model, u):
    """K_sigma = int sigma_ij du_k/dx_i dv_k/dx_j dV for the stress of displacement u."""
    from skfem import BilinearForm, asm

    G = model.basis.interpolate(u).grad  # (3, 3, ne, nq): G[k, i] = du_k/dx_i
    eps = 0.5 * (G + np.swapaxes(G, 0, 1))
    lam, mu = model.material.lame
    tr = eps[0, 0] + eps[1, 1] + eps[2, 2]
    S = 2 * mu * eps + lam * tr * np.eye(3)[:, :, None, None]

    @BilinearForm
    def kg(uu, vv, w):
        return np.einsum("ij...,ki...,kj...->...", w["S"], uu.grad, vv.grad)

    return asm(kg, model.basis, S=S).tocsr()


def _von_mises_qp(model, u):
    from ..fem.solid import hooke_stress, von_mises

    return von_mises(hooke_stress(model.basis.interpolate(u).grad, model.material))


def _all(flags):
    """all() of booleans, None when the checks were not run."""
    flags = list(flags)
    return None if any(f is None for f in flags) else all(flags)


def _geometry_checks(design, clearance, flatness_tol):
    """Per gauge: flatness [m] of the true (CAD) surface under the grid, and the free distance [m]
    in front of it (up to ``clearance``), from gmsh's OpenCASCADE model."""
    from ..fem.solid import gmsh_model

    with gmsh_model("sensor_check") as gmsh:
        design.build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        vol = gmsh.model.getEntities(3)[0][1]
        surfaces = [t for _, t in gmsh.model.getEntities(2)]
        out = []
        for g in design.gauges:
            c, dvec, n = g.center, g.direction, g.normal
            e2 = np.cross(n, dvec)
            s = np.linspace(-0.5, 0.5, 5)
            pts = np.array([c + a * GRID["grid_length"] * dvec + b * GRID["grid_width"] * e2 for a in s for b in s])
            # the face under the gauge centre: the surface whose closest point is the centre
            best, tag = np.inf, None
            for t in surfaces:
                p = np.asarray(gmsh.model.getClosestPoint(2, t, c)[0])
                dd = np.linalg.norm(p - c)
                if dd < best - 1e-12 and gmsh.model.isInside(2, t, p):
                    best, tag = dd, t
            proj = np.array([gmsh.model.getClosestPoint(2, tag, p)[0] for p in pts])
            onface = gmsh.model.isInside(2, tag, proj.ravel())
            centroid = proj.mean(0)
            _, _, vt = np.linalg.svd(proj - centroid)
            flat = float(np.ptp((proj - centroid) @ vt[2]))
            planar = gmsh.model.getType(2, tag) == "Plane" and onface == len(pts) and flat <= flatness_tol
            # free space: the grid's centre and corners pushed out along the normal in 0.5 mm
            # steps; the first step that enters the solid bounds the clearance (gmsh's isInside
            # costs ~8 ms a point, so 5 points x 12 steps, not the full 5 x 5 grid)
            free = clearance
            probe = proj[[0, 4, 12, 20, 24]]
            for dist in np.linspace(clearance / 12, clearance, 12):
                if gmsh.model.isInside(3, vol, (probe + (dist + 1e-6) * n).ravel()):
                    free = float(dist - clearance / 12)
                    break
            out.append(dict(flatness=flat, planar=bool(planar), clearance=free, reachable=free >= clearance))
        return out


def torque_sensor_analysis(concept: str = "final", torque: float = 140.0, mesh_size: float | None = None, *,
                           material="al7075-t6", min_gauge_strain: float = 2e-4, max_gauge_strain: float = 6e-4,
                           gauge_factor: float = 2.0, clearance: float = 0.006, flatness_tol: float = 5e-6,
                           interface_band: float = 0.002, stress_stiffening: bool = True, refine_gauges: bool = True,
                           interface: str = "rigid", cases: tuple = ("A", "B"), geometry_checks: bool = True,
                           curvature_points: int = 0, fillet_size: float | None = None, layers: int | None = None,
                           envelope: dict | None = None, **dimensions) -> SensorResult:
    """FE analysis of one torque-sensor design (seed 001 Problem 2).

    Parameters
    ----------
    concept : "hollow" | "spokes" | "tension_links" | "final"
    torque : float [N m]          magnitude of the torque (seed 001: ~140 N m), non-zero
    mesh_size : float [m]         element size (default per concept, 3 mm; gauge regions at half)
    min_gauge_strain, max_gauge_strain : [-]   the measurable range at the gauge (the text: <= 0.06 %)
    gauge_factor : [-]            strain-gauge factor for the calibration (2.0: constantan foil)
    clearance : [m]               free space needed in front of a gauge face (bonding clamp, wiring)
    flatness_tol : [m]            peak-to-valley flatness under the grid for "planar"
    interface_band : [m]          band next to the interface faces excluded from max von Mises
    stress_stiffening : bool      solve each direction with its geometric stiffness (see module doc)
    interface : "rigid" | "traction"   how the torque enters the loaded face: "rigid" (default), the face
                                  turns as a rigid body (a bolted flange or a keyed shaft; Nastran's RBE2) and
                                  the torque is its reaction; "traction", a shear traction proportional to the
                                  radius on a face free to deform (a soft flange: the ring then bends between
                                  the links and the gauges see up to ~1.6x more strain)
    cases : subset of ("A", "B")  load cases to solve (A must be one). With ``interface="rigid"`` B is the
                                  same linear problem as A plus a rigid rotation (opposite strains; ~1 % apart
                                  with stress stiffening), so a linear search may solve A alone
    curvature_points : int        hollow concept only: gmsh elements per 2 pi of curvature (0: sizes from
                                  mesh_size and h_min = mesh_size / 4 only)
    fillet_size : [-]             disc concepts: element size at the fillets as a fraction of their radius
                                  (swept mesh, :func:`proleg.fem.mesh.mesh_extruded`; default per concept,
                                  :data:`proleg.robots.torque_sensor.FILLET_SIZE`: 0.35, three P2 elements
                                  along a quarter arc, or 0.175 for the final concept's 2 mm fillets; see the
                                  mesh convergence)
    layers : int                  disc concepts: element layers through the thickness (default
                                  max(1, round(thickness / (2 mesh_size))))
    geometry_checks : bool        run the gauge-face planarity / clearance checks (gmsh, ~2 s); False
                                  reports them as NaN / None
    envelope : dict or None       overrides the assumed envelope (:data:`proleg.robots.torque_sensor.ENVELOPE`:
                                  r_out, thickness max, r_bore min [m])
    **dimensions : [m]            concept dimensions (:data:`proleg.robots.torque_sensor.DEFAULTS`)
    """
    from ..fem import SolidModel
    from ..fem.craig_bampton import _factorize
    from ..fem.mesh import axial_rotation, mesh_extruded, mesh_occ, rotation_field, torque_load

    if not (isinstance(torque, int | float) and math.isfinite(torque) and torque != 0):
        raise ModelError(f"torque_sensor_analysis torque = {torque!r} must be a non-zero finite number [N m] "
                         "(e.g. 140.0).")
    if interface not in ("rigid", "traction"):
        raise ModelError(f"torque_sensor_analysis interface = {interface!r}; use 'rigid' or 'traction'.")
    if "A" not in cases or not set(cases) <= {"A", "B"}:
        raise ModelError(f"torque_sensor_analysis cases = {cases!r}; use ('A', 'B') or ('A',).")
    T = abs(float(torque))
    design = sensor_design(concept, mesh_size, envelope=envelope, **dimensions)
    if fillet_size is None:
        fillet_size = FILLET_SIZE[concept]
    if not (isinstance(fillet_size, int | float) and math.isfinite(fillet_size) and fillet_size > 0):
        raise ModelError(f"torque_sensor_analysis fillet_size = {fillet_size!r} must be a positive fraction of the "
                         "fillet radius (e.g. 0.35).")
    t0 = time.perf_counter()
    h = design.mesh_size
    refine = [(g.center, 0.004, h / 2) for g in design.gauges] if refine_gauges else None
    if concept == "hollow":
        mesh = mesh_occ(design.build, h, refine=refine, h_min=h / 4, curvature_points=curvature_points)
    else:  # a plate part: the swept mesh resolves every fillet at any h (see the mesh convergence)
        mesh = mesh_extruded(design.build, h, design.dims["thickness"], refine=refine, h_min=h / 4,
                             fillet_radius=design.dims.get("fillet", 0.0), fillet_size=fillet_size, layers=layers)
    model = SolidModel(*mesh, material, order=2)
    t_mesh = time.perf_counter() - t0
    rot = rotation_field(model)
    cases = {c: {"A": (design.motor_face, design.hd_face), "B": (design.hd_face, design.motor_face)}[c] for c in cases}
    sols, vms, rows, lin = {}, {}, [], {}
    react_err, twist_deg = 0.0, None
    X = model.basis.mapping.F(model.basis.X)  # (3, ne, nq)
    for case, (loaded, fixed) in cases.items():
        lf, ff = _facets_on(model, loaded), _facets_on(model, fixed)
        if lf.size == 0 or ff.size == 0:
            raise ModelError(f"torque sensor {concept}: no mesh facet found on the interface faces; refine the mesh.")
        fixed_dofs = model.basis.get_dofs(ff).all()
        loaded_dofs = model.basis.get_dofs(lf).all()
        held = np.union1d(fixed_dofs, loaded_dofs) if interface == "rigid" else fixed_dofs
        free = np.setdiff1d(np.arange(model.ndof), held)
        lu = _factorize(model.K[free][:, free], f"torque sensor {concept}: the fixed face does not hold the part.",
                        symmetric=True)
        if interface == "rigid":  # unit rigid rotation of the loaded face; the torque is its reaction
            p = np.zeros(model.ndof)
            p[loaded_dofs] = rot[loaded_dofs]
            base = -(model.K @ p)
        else:  # unit torque as shear traction on the loaded face
            p, base = np.zeros(model.ndof), torque_load(model, lf, 1.0)

        def solve(Kg=None, p=p, base=base, lu=lu, free=free, case=case):
            u = p.copy()
            u[free] = lu.solve(base[free])
            if Kg is None:
                return u
            for it in range(60):  # (K + Kg) u = f by fixed point on K's factors
                new = lu.solve(base[free] - (Kg @ u)[free])
                dn = np.linalg.norm(new - u[free])
                u[free] = new
                if dn <= 1e-11 * np.linalg.norm(new):
                    return u
                if not np.isfinite(dn):
                    break
            raise ConvergenceError(
                f"torque sensor {concept}: the stress-stiffened solve did not converge at {T:g} N m (case {case}): "
                "the links are near buckling. Reduce torque or stiffen the links (link_width, neck_width), or "
                "pass stress_stiffening=False.")

        def reaction(u, dofs):  # moment about the axis of the reactions on ``dofs`` [N m]
            return float(rot[dofs] @ (model.K @ u)[dofs])

        u1 = solve()
        if interface == "rigid":
            m_loaded = reaction(u1, loaded_dofs)  # torsional stiffness [N m/rad]
            react_err = max(react_err, abs(reaction(u1, fixed_dofs) + m_loaded) / m_loaded)
            u1 = u1 / m_loaded  # per N m
            case_twist = 1.0 / m_loaded
        else:
            react_err = max(react_err, abs(rot @ (model.K @ u1 - base) + 1.0))
            case_twist = axial_rotation(model, u1, np.unique(model.mesh.facets[:, lf]))
        if case == "A":
            twist_deg = math.degrees(case_twist) * T
        Kg1 = _geometric_stiffness(model, T * u1) if stress_stiffening else None
        for direction, sgn in (("CCW", 1.0), ("CW", -1.0)):
            u = sgn * T * u1
            if stress_stiffening:
                u = solve(sgn * Kg1)
                if interface == "rigid":  # scale the unit rotation to the torque, now with K + Kg
                    u *= sgn * T / float(rot[loaded_dofs] @ ((model.K + sgn * Kg1) @ u)[loaded_dofs])
                else:
                    u *= sgn * T
            sols[(case, direction)] = u
            vm = _von_mises_qp(model, u)
            vms[(case, direction)] = vm
            inward = 2e-5 if concept != "hollow" else 1.2 * h**2 / (8 * design.dims["r_out"]) + 2e-5
            s = np.linspace(-0.4, 0.4, 5) * GRID["grid_length"]
            P = np.vstack([g.center[None, :] + s[:, None] * g.direction[None, :] - inward * g.normal[None, :]
                           for g in design.gauges])
            strain = model.stress_at(u, P).strain.reshape(len(design.gauges), s.size, 3, 3)
            for gi, g in enumerate(design.gauges):
                e = float(np.mean(np.einsum("i,kij,j->k", g.direction, strain[gi], g.direction)))
                rows.append(dict(case=case, direction=direction, gauge=gi, sign=g.sign, strain=e,
                                 x_mm=g.center[0] * 1e3, y_mm=g.center[1] * 1e3, z_mm=g.center[2] * 1e3))
    t_solve = time.perf_counter() - t0 - t_mesh
    gauges = pd.DataFrame(rows)
    vm_max, where = 0.0, None
    P = model.points.T
    band = design.interface_distance(P[0], P[1], P[2]) < interface_band
    for key, u in sols.items():  # averaged vertex stress: converges to the surface peak at a fillet
        vm = np.where(band, 0.0, model.vertex_stress(u)[1])
        i = int(np.argmax(vm))
        if vm[i] > vm_max:
            vm_max, where = float(vm[i]), (key, model.points[i])
    bridge = gauges.assign(s=gauges.sign * gauges.strain).groupby(["case", "direction"])["s"].mean()
    cal = {dr: 1e3 * gauge_factor * abs(bridge.loc[("A", dr)]) / T for dr in ("CCW", "CW")}
    checks = (_geometry_checks(design, clearance, flatness_tol) if geometry_checks
              else [dict(flatness=math.nan, planar=None, clearance=math.nan, reachable=None)])
    mat = model.material
    gstrain = float(np.abs(gauges.strain).max())
    metrics = dict(
        concept=concept, torque=T, mesh_size=h, n_dofs=int(model.ndof), n_elements=int(model.tets.shape[0]),
        stiffness=T / twist_deg, twist=twist_deg,
        max_von_mises=vm_max, max_von_mises_at_mm=None if where is None else (where[1] * 1e3).round(3).tolist(),
        max_von_mises_radius_mm=None if where is None else float(np.hypot(*where[1][:2]) * 1e3),
        max_von_mises_case=None if where is None else f"{where[0][0]}/{where[0][1]}",
        safety_factor=mat.yield_strength / vm_max if vm_max > 0 else math.inf,
        gauge_strain=gstrain, gauge_strain_bridge=float(np.abs(bridge).max()),
        strain_in_range=bool(min_gauge_strain <= gstrain <= max_gauge_strain),
        gauge_planar=_all(c["planar"] for c in checks), gauge_flatness=max(c["flatness"] for c in checks),
        gauge_reachable=_all(c["reachable"] for c in checks), gauge_clearance=min(c["clearance"] for c in checks),
        calibration_ccw=cal["CCW"], calibration_cw=cal["CW"],
        calibration_mismatch=abs(cal["CCW"] - cal["CW"]) / (0.5 * (cal["CCW"] + cal["CW"])),
        case_mismatch=(float(abs(abs(bridge.loc[("A", "CCW")]) - abs(bridge.loc[("B", "CCW")]))
                             / abs(bridge.loc[("A", "CCW")])) if "B" in cases else math.nan),
        reaction_torque_error=float(react_err), mass=float(model.mass),
        time_mesh=t_mesh, time_solve=t_solve,
    )
    return SensorResult(metrics, gauges, model, design, sols, vms, X)


def mesh_convergence(concept: str = "final", sizes=(0.006, 0.005, 0.004, 0.003), *, fillet_sizes=None,
                     verbose: bool = False, **kw) -> pd.DataFrame:
    """Gauge strain, max von Mises, stiffness and calibration on a sequence of meshes (coarse to
    fine); columns ``*_rel`` are the differences from the finest mesh [-]. ``fillet_sizes``: one
    per size (the fillet element size as a fraction of the fillet radius, refined with h), else the
    default. ``verbose`` prints each row as it is done; ``kw`` go to :func:`torque_sensor_analysis`."""
    rows = []
    for i, h in enumerate(sizes):
        if fillet_sizes is not None:
            kw["fillet_size"] = fillet_sizes[i]
        m = torque_sensor_analysis(concept, mesh_size=h, **kw).metrics
        rows.append({"fillet_size": kw.get("fillet_size", FILLET_SIZE.get(concept, math.nan))} | {k: m[k] for k in ("mesh_size", "n_dofs", "gauge_strain", "max_von_mises", "max_von_mises_radius_mm",
                                       "stiffness", "calibration_ccw", "time_mesh", "time_solve")})
        if verbose:
            print(rows[-1], flush=True)
    df = pd.DataFrame(rows)
    for k in ("gauge_strain", "max_von_mises", "stiffness", "calibration_ccw"):
        df[k + "_rel"] = df[k] / df[k].iloc[-1] - 1.0
    return df
