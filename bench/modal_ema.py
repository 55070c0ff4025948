"""Experimental modal analysis (``proleg.identify.modal``) on four synthetic records (issue 35):

1. a grounded 3-mass chain (m = 1 kg, k = 1e4 N/m: 7.08 / 19.85 / 28.68 Hz, 2 % damping), one
   1 ms hammer hit at the free end, three accelerometers at 2 kHz for 4 s, 0.5 % noise;
2. the torso-modal scenario's synthetic hammer test of main e754ddf (its nominal model and its
   prototype: foam +20 %, mounts -10 %, tube wall 2.85 mm; its damping by mode kind; 5 hits,
   11 accelerometers, 1024 Hz, 32 s per hit), scored against the prototype's own modes (each
   identified mode against its best-MAC true mode), FE-guided as the scenario was;
3. a close pair 2 % apart with different damping (50 / 51 Hz, 0.5 % / 2 %) and a mode at 80 Hz;
4. a noise-only record (a hammer hit, accelerometers that see only noise).

Each case runs in a child process with a wall limit (``--limit``, default 120 s): a case that
does not finish is reported as such, not waited for.

    PYTHONPATH=src python bench/modal_ema.py [--limit 120] [--cases chain3,torso,pair,noise]

Prints one table and writes bench/results/modal_ema.md: the time of a modal() call (the second of
the process) and of the first, which also imports pyFRF and pyEMA (matplotlib, pyuff).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
from pathlib import Path

import numpy as np


def chain3_record(seed=0):
    from proleg.identify.hammer import synthetic_hammer_test

    k, m = 1e4, 1.0
    K = k * np.array([[2, -1, 0], [-1, 2, -1], [0, -1, 1]], float)
    w2, phi = np.linalg.eigh(K / m)
    f = np.sqrt(w2) / (2 * np.pi)
    phi = phi / np.sqrt(m)
    z = np.full(3, 0.02)
    t, F, A = synthetic_hammer_test(f, z, phi, phi[2], fs=2000.0, block=4.0, n_hits=1, pulse=0.001,
                                    noise_force=0.005, noise_acc=0.005, seed=seed)
    return (t, F, A), f, z


def pair_record(seed=0):
    from proleg.identify.hammer import synthetic_hammer_test

    f = np.array([50.0, 51.0, 80.0])
    z = np.array([0.005, 0.02, 0.01])
    phi = np.array([[1.0, 0.8, 0.5], [0.6, -1.0, 0.7], [-0.4, 0.9, 1.0], [0.9, 0.4, -0.8]])
    t, F, A = synthetic_hammer_test(f, z, phi, np.array([1.0, 0.9, 0.8]), fs=1024.0, block=8.0, n_hits=3,
                                    noise_acc=1e-3, seed=seed)
    return (t, F, A), f, z


def noise_record(seed=0):
    rng = np.random.default_rng(seed)
    fs, n = 2000.0, 8000
    t = np.arange(n) / fs
    F = 0.5 * rng.standard_normal(n)
    F[40:42] += 200.0
    A = rng.standard_normal((n, 3))
    return (t, F, A), np.array([]), np.array([])


TORSO_NOMINAL_E754DDF = dict(mount_stiffness=1.1e5, mount_rot_stiffness=50.0, pad_stiffness=1150.0,
                             pad_shear_stiffness=575.0)  # torso defaults of main e754ddf (then tuned to Table 2)
TORSO_PROTOTYPE_E754DDF = dict(TORSO_NOMINAL_E754DDF, pad_stiffness=1380.0, pad_shear_stiffness=690.0,
                               mount_stiffness=0.99e5, tube_wall=0.00285)


def _damping_e754ddf(r, zetas=(0.05, 0.03, 0.01)):
    """Modal damping by e754ddf's mode kinds (support below 10 Hz, frame when over half the kinetic
    energy is in the frame, else heavy masses), so the record is the one e754ddf identified."""
    nb = r.frame.ndof
    ke = np.einsum("ij,ij->j", r.shapes[:nb], r.frame.M @ r.shapes[:nb])
    return np.where(r.frequencies < 10, zetas[0], np.where(ke > 0.5, zetas[2], zetas[1]))


def torso_record(seed=0):
    """The record and FE guesses of run_torso_modal on main e754ddf (its identification inputs)."""
    from proleg.identify.hammer import synthetic_hammer_test
    from proleg.robots.torso import table2_modes, torso_modal
    from proleg.papers.torso_report import HAMMER, _channel_dofs

    f_max = 200.0
    fe = torso_modal(n_modes=40, **TORSO_NOMINAL_E754DDF)
    proto = torso_modal(n_modes=40, **TORSO_PROTOTYPE_E754DDF)
    dofs, _ = _channel_dofs(proto)
    hit = proto.frame.node_dof_table[proto.frame.node_at([*HAMMER, 0.0], tol=1e-6), 2]
    band = proto.frequencies < 1.3 * f_max
    z = _damping_e754ddf(proto)[band]
    t, F, A = synthetic_hammer_test(proto.frequencies[band], z, proto.shapes[dofs][:, band],
                                    proto.shapes[hit, band], block=32.0, n_hits=5, seed=seed)
    fe_dofs, _ = _channel_dofs(fe)
    fhit = fe.frame.node_dof_table[fe.frame.node_at([*HAMMER, 0.0], tol=1e-6), 2]
    zfe = _damping_e754ddf(fe)
    strength = np.abs(fe.shapes[fhit] * fe.shapes[fe_dofs]).max(axis=0) / (2 * zfe)
    cand = [i for i in np.argsort(strength)[::-1] if 1.0 < fe.frequencies[i] < f_max
            and strength[i] >= 0.02 * strength.max()]
    guess = [int(i) for i in table2_modes(fe) if fe.frequencies[i] < f_max]
    for i in cand:
        if all(abs(fe.frequencies[i] / fe.frequencies[j] - 1) > 0.04 for j in guess):
            guess.append(i)
    truth_f = proto.frequencies[band]
    return (t, F, A), truth_f, z, proto.shapes[dofs][:, band], np.sort(fe.frequencies[guess])


def _score(found_f, found_z, true_f, true_z, f_tol=0.01):
    """For each true mode, the nearest identified one; counts those within f_tol."""
    rows = []
    for ft, zt in zip(true_f, true_z, strict=True):
        if found_f.size == 0:
            rows.append((ft, np.nan, np.nan, np.nan))
            continue
        i = int(np.argmin(np.abs(found_f / ft - 1)))
        rows.append((ft, 100 * (found_f[i] / ft - 1), 100 * (found_z[i] / zt - 1), found_f[i]))
    return rows


def _case(name, q):
    from proleg.identify import hammer

    cold = {"t": None}

    def modal(*a, **k):  # time the call; the first call of the process also imports pyFRF/pyEMA
        t1 = time.perf_counter()
        r = hammer.modal(*a, **k)
        if cold["t"] is None:
            cold["t"] = time.perf_counter() - t1
            t1 = time.perf_counter()
            r = hammer.modal(*a, **k)
        cold["warm"] = time.perf_counter() - t1
        return r

    t0 = time.perf_counter()
    try:
        if name == "chain3":
            rec, f, z = chain3_record()
            r = modal(*rec, f_range=(1.0, 100.0))
        elif name == "pair":
            rec, f, z = pair_record()
            r = modal(*rec, f_range=(20.0, 150.0))
        elif name == "noise":
            rec, f, z = noise_record()
            r = modal(*rec, f_range=(1.0, 400.0))
        elif name == "torso":
            rec, f, z, shapes, guess = torso_record()
            t1 = time.perf_counter()
            r = modal(*rec, f_range=(1.0, 200.0), f_guess=guess, band=0.12)
            t0 = t1
        wall = cold["warm"]
        if name == "torso":  # score as the scenario does: each identified mode against its best-MAC true mode
            from proleg.identify.hammer import comparison_table

            tab, _ = comparison_table(f, shapes, r.frequencies, r.shapes)
            ferr = 100 * (r.frequencies / tab["numerical [Hz]"].to_numpy() - 1)
            zt = z[tab["FE mode"].to_numpy() - 1]
            zerr = 100 * (r.damping / zt - 1)
            q.put(dict(case=name, wall=wall, cold=cold["t"], n_found=r.frequencies.size, n_true=f.size,
                       max_f_err=float(np.abs(ferr).max()) if ferr.size else np.nan,
                       max_z_err=float(np.abs(zerr).max()) if zerr.size else np.nan,
                       detail="; ".join(f"{a:.2f} Hz {b:+.2f}%/{c:+.0f}%" for a, b, c in
                                        zip(r.frequencies, ferr, zerr, strict=True))))
            return
        rows = _score(np.asarray(r.frequencies), np.asarray(r.damping), f, z)
        ferr = np.array([abs(x[1]) for x in rows]) if rows else np.array([])
        zerr = np.array([abs(x[2]) for x in rows]) if rows else np.array([])
        q.put(dict(case=name, wall=wall, cold=cold["t"], n_found=len(r.frequencies), n_true=len(f),
                   max_f_err=float(ferr.max()) if ferr.size else np.nan,
                   max_z_err=float(zerr.max()) if zerr.size else np.nan,
                   detail=("; ".join(f"{a:.2f} Hz" for a in r.frequencies) or "no modes")
                   + (f" | {getattr(r, 'message', '')}" if getattr(r, "message", "") else "")))
    except Exception as e:  # noqa: BLE001 - the bench reports any failure as a row
        q.put(dict(case=name, wall=time.perf_counter() - t0, cold=np.nan, n_found=-1, n_true=-1, max_f_err=np.nan,
                   max_z_err=np.nan, detail=f"{type(e).__name__}: {e}"[:200]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--limit", type=float, default=120.0)
    ap.add_argument("--cases", default="chain3,torso,pair,noise")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "modal_ema.md"))
    a = ap.parse_args()
    rows = []
    ctx = mp.get_context("spawn")
    for name in a.cases.split(","):
        q = ctx.Queue()
        p = ctx.Process(target=_case, args=(name, q))
        t0 = time.perf_counter()
        p.start()
        p.join(a.limit)
        if p.is_alive():
            p.terminate()
            p.join()
            rows.append(dict(case=name, wall=time.perf_counter() - t0, cold=np.nan, n_found=-1, n_true=-1, max_f_err=np.nan,
                             max_z_err=np.nan, detail=f"did not finish within {a.limit:.0f} s"))
        else:
            rows.append(q.get())
        print(rows[-1], flush=True)
    head = "| case | modal() [s] | first call, with imports [s] | modes found / true | max freq err [%] | max damping err [%] | detail |\n|---|---|---|---|---|---|---|\n"
    body = "".join(f"| {r['case']} | {r['wall']:.2f} | {r['cold']:.2f} | {r['n_found']} / {r['n_true']} | {r['max_f_err']:.3f} | "
                   f"{r['max_z_err']:.1f} | {r['detail']} |\n" for r in rows)
    print(head + body)
    Path(a.out).parent.mkdir(exist_ok=True, parents=True)
    Path(a.out).write_text(head + body)


if __name__ == "__main__":
    main()
