"""``proleg run torso-modal``: FE modes of the torso, a synthetic hammer test, identification,
seed 001 Table 2-style comparison with MAC, HTML report + Parquet/JSON (seed 001 Problem 3).

The "prototype" hammered here is the torso model with perturbed parameters (the foam 20 %
stiffer, the mounts 10 % softer, the frame tubes 5 % softer: what a real build differs by), so the
comparison looks like Table 2 (differences of a few per cent); the identification itself is
checked against the prototype's own modes (its error should be below 1 % in frequency).

Measured (the scenario's identification on its synthetic test, replaying run_torso_modal):
11 modes identified, every one within 0.45 % of the prototype's mode (the bounce
1.982 Hz -0.03 %, the heavy masses' vertical modes 31.12 and 37.43 Hz +0.02 / +0.03 %, the frame
modes up to 191 Hz) and its damping within 12.4 % (the requirement: 1 % and 20 %). The spurious pick
of the previous version (67.9 Hz at 9 % damping standing in for the prototype's 72.8 and 79.3 Hz
modes, +11.7 % from the 63.5 Hz FE mode it was paired with) is gone: the fitted poles are now bounded
to their group's band and the model order grows only where the residual shows a missed mode. Weak
modes in a strong mode's shadow (60.8 Hz next to 62.3 Hz, 72.8 Hz) are not found rather than
mis-placed.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

PROTOTYPE = dict(pad_stiffness=1380.0, pad_shear_stiffness=690.0, mount_stiffness=0.99e5, tube_wall=0.00285)
CHANNELS = [(0.5, 0.25), (0.5, -0.25), (-0.5, 0.25), (-0.5, -0.25), (0.0, 0.25), (0.0, -0.25), (0.25, 0.25),
            (-0.25, -0.25)]  # accelerometers (z) on the frame [m]
HAMMER = (0.5, 0.25)


def _channel_dofs(r):
    fr = r.frame
    dofs = [fr.node_dof_table[fr.node_at([x, y, 0.0], tol=1e-6), 2] for x, y in CHANNELS]
    dofs += [r.model.bodies[b]["dofs"][2] for b in ("motor", "pump", "tank")]
    names = [f"frame z ({x:+.2f}, {y:+.2f})" for x, y in CHANNELS] + ["motor z", "pump z", "tank z"]
    return np.array(dofs), names


def _damping(r, zetas):
    return np.array([zetas[0] if k.startswith("support") else zetas[1] if k.startswith("heavy") else zetas[2]
                     for k in r.kind])


def mode_figure(r, n=6):
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(11, 6.5))
    fr = r.frame
    X = fr.node_coordinates
    for j in range(n):
        ax = fig.add_subplot(2, 3, j + 1, projection="3d")
        u = r.shapes[: fr.ndof, j].reshape(-1, 6)[:, :3]
        body_u = [r.shapes[b["dofs"][:3], j] for b in r.model.bodies.values()]
        s = 0.08 / max(np.abs(u).max(), max(np.abs(b).max() for b in body_u), 1e-12)
        for a, b in fr.elements:
            ax.plot(*X[[a, b]].T, color="0.75", lw=0.8)
            ax.plot(*(X[[a, b]] + s * u[[a, b]]).T, color="C0", lw=1.4)
        for (name, bd), bu in zip(r.model.bodies.items(), body_u, strict=True):
            ax.scatter(*(bd["center"] + s * bu), s=30 * bd["mass"] ** 0.5, color="C3")
        ax.set_title(f"mode {j + 1}: {r.frequencies[j]:.2f} Hz\n{r.kind[j]}", fontsize=8)
        ax.set_zlim(-0.3, 0.3)
        ax.set_axis_off()
    fig.tight_layout()
    return fig


def frf_figure(ident, fe_freqs):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    m = (ident.freq > 0.5) & (ident.freq < 220)
    ax[0].semilogy(ident.freq[m], np.abs(ident.frf[m]), lw=0.7)
    for f in ident.frequencies:
        ax[0].axvline(f, color="k", lw=0.5, ls="--")
    for f in fe_freqs:
        ax[0].axvline(f, color="C3", lw=0.5, ls=":")
    ax[0].set_ylabel("|H1| [(m/s²)/N]")
    ax[1].plot(ident.freq[m], ident.coherence[m], lw=0.7)
    ax[1].set_ylabel("coherence")
    ax[1].set_xlabel("frequency [Hz]")
    ax[0].set_title("H1 accelerances (dashed: identified, dotted: FE)")
    fig.tight_layout()
    return fig


def mac_figure(M, f_num, f_exp):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 5))
    im = ax.imshow(M, vmin=0, vmax=1, cmap="viridis")
    ax.set_yticks(range(len(f_num)), [f"{f:.1f}" for f in f_num], fontsize=7)
    ax.set_xticks(range(len(f_exp)), [f"{f:.1f}" for f in f_exp], fontsize=7, rotation=90)
    ax.set_ylabel("FE mode [Hz]")
    ax.set_xlabel("identified mode [Hz]")
    fig.colorbar(im, label="MAC")
    fig.tight_layout()
    return fig


def run_torso_modal(out_dir="results/torso-modal", *, n_hits: int = 5, f_max: float = 200.0, seed: int = 0) -> Path:
    """The torso-modal scenario; returns the HTML report path."""
    from ..identify.hammer import comparison_table, modal, synthetic_hammer_test
    from ..report.html import Report
    from ..robots.torso import TORSO_DEFAULTS, table2_comparison, table2_modes, torso_modal

    t0 = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fe = torso_modal(n_modes=40)
    proto = torso_modal(n_modes=40, **PROTOTYPE)
    dofs, names = _channel_dofs(proto)
    hit = proto.frame.node_dof_table[proto.frame.node_at([*HAMMER, 0.0], tol=1e-6), 2]
    band = proto.frequencies < 1.3 * f_max
    z = _damping(proto, TORSO_DEFAULTS["damping"])[band]
    t, F, A = synthetic_hammer_test(proto.frequencies[band], z, proto.shapes[dofs][:, band],
                                    proto.shapes[hit, band], block=32.0, n_hits=n_hits, seed=seed)
    # pre-test analysis: guess the FE modes the hammer point and the accelerometers see well (peak
    # accelerance >= 2 % of the largest) and that stand >= 4 % apart from a stronger one
    fe_dofs, _ = _channel_dofs(fe)
    fhit = fe.frame.node_dof_table[fe.frame.node_at([*HAMMER, 0.0], tol=1e-6), 2]
    zfe = _damping(fe, TORSO_DEFAULTS["damping"])
    strength = np.abs(fe.shapes[fhit] * fe.shapes[fe_dofs]).max(axis=0) / (2 * zfe)
    cand = [i for i in np.argsort(strength)[::-1] if fe.frequencies[i] < f_max and fe.frequencies[i] > 1.0
            and strength[i] >= 0.02 * strength.max()]
    # plus the modes of seed 001 Table 2 (the bounce and the heavy masses' vertical modes are weak
    # in accelerance: mass-normalised over 35 kg, against a few kg of frame) -- what the test looks for
    guess = [int(i) for i in table2_modes(fe) if fe.frequencies[i] < f_max]
    for i in cand:
        if all(abs(fe.frequencies[i] / fe.frequencies[j] - 1) > 0.04 for j in guess):
            guess.append(i)
    ident = modal(t, F, A, f_range=(1.0, f_max), f_guess=np.sort(fe.frequencies[guess]), band=0.12)
    fband = fe.frequencies < f_max
    table, M = comparison_table(fe.frequencies[fband], fe.shapes[fe_dofs][:, fband], ident.frequencies, ident.shapes)
    truth, Mt = comparison_table(proto.frequencies[band], proto.shapes[dofs][:, band], ident.frequencies, ident.shapes)
    table["kind"] = [fe.kind[i - 1] for i in table["FE mode"]]
    table["identified damping [%]"] = 100 * ident.damping
    table["true damping [%]"] = [100 * z[i - 1] for i in truth["FE mode"]]
    table["identification error [%]"] = 100 * (ident.frequencies / truth["numerical [Hz]"].to_numpy() - 1)

    fe.effective_mass.to_parquet(out / "fe_modes.parquet")
    table.to_parquet(out / "comparison.parquet")
    pd.DataFrame({"time": t, "force": F, **{n: A[:, i] for i, n in enumerate(names)}}).to_parquet(out / "hammer_test.parquet")
    summary = {"fe_frequencies_hz": fe.frequencies[:12].tolist(), "identified_hz": ident.frequencies.tolist(),
               "identified_damping": ident.damping.tolist(), "total_mass_kg": fe.effective_mass.attrs["total_mass"],
               "max_identification_error_pct": float(np.abs(table["identification error [%]"]).max()),
               "table2": table2_comparison(fe)[["FE [Hz]", "paper numerical [Hz]", "paper experimental [Hz]"]]
               .to_dict("list"),
               "wall_s": time.perf_counter() - t0}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))

    rep = Report("HyQ torso: FE modal analysis and a (synthetic) hammer test",
                 "seed 001 Problem 3, Table 2 and Figs. 14-15; proleg.robots.torso + proleg.identify.hammer")
    rep.add_heading("Model")
    rep.add_text(
        "A welded aluminium frame of HyQ's size (1.0 m x 0.5 m, square 40 x 3 mm tubes, 3D Timoshenko beams) carries "
        "the electric motor, hydraulic pump and oil tank as rigid bodies on elastic mounts and rests on four foam "
        "pads (the hammer test's soft support). Beams rather than shells or solids: the frame's global modes with a "
        "few hundred DOFs; local panel/joint flexibility is not modelled. Masses, mount and pad stiffnesses are not "
        "printed in seed 001: they are chosen parameters (proleg.robots.torso.TORSO_DEFAULTS).")
    rep.add_key_values({k: v for k, v in fe.params.items()}, "Parameters (SI)")
    rep.add_heading("FE modes")
    rep.add_table(fe.effective_mass.head(20), "First 20 modes: frequency, effective modal masses about the centre of "
                  "mass, and what moves (support: rigid torso on the foam; heavy masses on mounts; frame).",
                  float_format="{:.4g}")
    rep.add_figure(mode_figure(fe), "First six mode shapes (grey undeformed frame, blue deformed, red heavy masses).")
    rep.add_heading("Synthetic hammer test and identification")
    rep.add_text(
        f"The prototype (foam +20 %, mounts -10 %, tube wall 2.85 mm) is hit {n_hits} times at the frame corner "
        f"{HAMMER} m (z); {len(names)} accelerometers (z) on the frame and the heavy masses; 1024 Hz, 32 s per hit, "
        "noise 1e-4 of full scale. H1 with averaging over the hits, peak picking on the detrended mode indicator, "
        "least-squares modal fit (proleg.identify.modal).")
    rep.add_figure(frf_figure(ident, fe.frequencies[fband]), "H1 FRFs and coherence.")
    t2 = table2_comparison(fe)
    t2.to_parquet(out / "table2_comparison.parquet")
    rep.add_table(t2, "The nominal FE model against seed 001 Table 2: its numerical column (the paper's tetrahedral "
                  "model) and its experimental column (the hammer test); FE modes paired by kind "
                  "(proleg.robots.torso.table2_modes).", float_format="{:.4g}")
    rep.add_table(table, "Table 2-style comparison: FE (nominal model) against the identified modes of the prototype, "
                  "paired by MAC; the identification error is against the prototype's true modes.",
                  float_format="{:.4g}")
    rep.add_figure(mac_figure(M, fe.frequencies[fband], ident.frequencies), "MAC between FE and identified shapes "
                   "(at the accelerometer DOFs).")
    rep.add_key_values({"wall time [s]": f"{time.perf_counter() - t0:.1f}", "output": str(out)}, "Run")
    return rep.save(out / "torso_modal_report.html")
