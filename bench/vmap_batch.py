"""A batch of 1,000 model variants with ``jax.vmap`` against 1,000 sequential simulations.

Model: a 2-link pendulum (0.15 m / 0.1 kg rods, revolute hinges, released 30° below the
horizontal) with a SpringDamper "spring" from a ground point above the pivot to the tip of
link 2; the batch sweeps ``spring.stiffness`` over ``--batch`` values in [10, 1000] N/m, each
simulated for ``--t-end`` s (default 1 s, outputs every 10 ms). The quantity returned is the
final position of link 2.

* vmap batch: ``jax.jit(jax.vmap(lambda k: simulate(system.with_params({"spring.stiffness": k}),
  ...).part("link2").position[-1]))``, compiled ahead of time (``.lower(ks).compile()``, the
  compile column), then one timed call. Where ``simulate`` has ``jacobian_refresh``, the batch
  passes ``jacobian_refresh=False`` (its documented setting for vmap: under vmap the in-step
  refresh ``lax.cond`` becomes a select that rebuilds the Jacobian every Newton iteration);
  ``--vmap-refresh`` keeps the default.
* sequential: ``--seq`` (default 20) plain ``proleg.simulate`` calls with different stiffness
  values (same System structure, so no recompilation after the first), timed and extrapolated
  linearly to the batch size. Also a jitted single-variant function called sequentially, the
  fastest one-at-a-time loop.

* ``proleg.sweep``: the same variants through the library's sweep (analyses/sweep.py): the
  free-running driver, in batches of at most 256 run concurrently, one per core (``workers``).

Target: the vmap batch of 1,000 at >= 20x the throughput of 1,000 sequential runs.
"""

from __future__ import annotations

import argparse
import inspect
import sys
import time
import traceback

import numpy as np

from common import add_output_args, build_chain, emit, log, timed, timed_cpu

TARGET = 20.0
COLUMNS = ["case", "variants", "timed", "compile [s]", "wall [s]", "per variant [ms]", "cpu per variant [ms]", "variants/s", "speed-up", "note"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--batch", type=int, default=1000, help="number of variants (default 1000)")
    ap.add_argument("--seq", type=int, default=20, help="sequential runs actually timed (default 20)")
    ap.add_argument("--t-end", type=float, default=1.0, help="simulated time [s] (default 1)")
    ap.add_argument(
        "--vmap-refresh", action="store_true",
        help="keep simulate's default in-step Jacobian refresh in the vmap batch (a select under vmap)",
    )
    add_output_args(ap, "vmap_batch")
    args = ap.parse_args(argv)

    import jax
    import jax.numpy as jnp

    import proleg as pl

    system = pl.assemble(build_chain(2, spring=100.0))
    ks = np.linspace(10.0, 1000.0, args.batch)
    kw = dict(t_end=args.t_end, dt_output=0.01, progress=False)
    rows, notes = [], []

    # -- sequential, plain simulate calls ------------------------------------------------------
    log(f"sequential: {args.seq} plain simulate calls ...")
    k_seq = ks[np.linspace(0, args.batch - 1, args.seq).astype(int)]
    _, t_c = timed(pl.simulate, system.with_params({"spring.stiffness": k_seq[0]}), **kw)  # compile
    steps, finals = [], []
    c0, t0 = time.process_time(), time.perf_counter()
    for k in k_seq:
        r = pl.simulate(system.with_params({"spring.stiffness": k}), **kw)
        steps.append(r.stats["steps"])
        finals.append(np.asarray(r.q[-1]))
    t_seq, c_seq = time.perf_counter() - t0, time.process_time() - c0
    per_seq = t_seq / args.seq
    rows.append({
        "case": "sequential simulate()", "variants": args.batch, "timed": args.seq, "compile [s]": t_c - per_seq,
        "wall [s]": per_seq * args.batch, "per variant [ms]": 1e3 * per_seq, "cpu per variant [ms]": 1e3 * c_seq / args.seq, "variants/s": 1.0 / per_seq, "speed-up": 1.0,
        "note": f"extrapolated from {args.seq} runs; {np.mean(steps):.0f} steps per run",
    })
    log(f"  {rows[-1]}")

    # -- sequential, one jitted single-variant function -----------------------------------------
    def final_position(k):
        res = pl.simulate(system.with_params({"spring.stiffness": k}), **kw)
        return res.part("link2").position[-1]

    log("sequential: jitted single-variant function ...")
    per_jit = None
    try:
        f1 = jax.jit(final_position)
        _, t_c1 = timed(f1, jnp.asarray(k_seq[0]))
        c0, t0 = time.process_time(), time.perf_counter()
        for k in k_seq:
            jax.block_until_ready(f1(jnp.asarray(k)))
        per_jit = (time.perf_counter() - t0) / args.seq
        cpu_jit = (time.process_time() - c0) / args.seq
        rows.append({
            "case": "sequential jit(f)(k)", "variants": args.batch, "timed": args.seq, "compile [s]": t_c1 - per_jit,
            "wall [s]": per_jit * args.batch, "per variant [ms]": 1e3 * per_jit, "cpu per variant [ms]": 1e3 * cpu_jit, "variants/s": 1.0 / per_jit,
            "speed-up": per_seq / per_jit, "note": f"extrapolated from {args.seq} runs",
        })
    except Exception as exc:
        rows.append({"case": "sequential jit(f)(k)", "variants": args.batch, "note": f"FAILED: {type(exc).__name__}: {exc}"})
        log(traceback.format_exc())
    log(f"  {rows[-1]}")

    # -- vmap batch ------------------------------------------------------------------------------
    # Under vmap a data-dependent lax.cond becomes a select (both branches run); simulate's
    # ``jacobian_refresh=False`` (where this proleg has it) keeps one Jacobian per step instead.
    vkw = dict(kw)
    if "jacobian_refresh" in inspect.signature(pl.simulate).parameters and not args.vmap_refresh:
        vkw["jacobian_refresh"] = False

    def final_position_b(k):
        res = pl.simulate(system.with_params({"spring.stiffness": k}), **vkw)
        return res.part("link2").position[-1]

    log(f"vmap batch of {args.batch} ({', '.join(f'{k}={v}' for k, v in vkw.items() if k not in kw) or 'simulate defaults'}) ...")
    try:
        kb = jnp.asarray(ks)
        # Ahead-of-time compile, then one timed run (a batch run can take minutes on 2 cores).
        fb, t_compile = timed(lambda: jax.jit(jax.vmap(final_position_b)).lower(kb).compile())
        out2, t_batch, c_batch = timed_cpu(fb, kb)
        out2 = np.asarray(out2)
        # Check the batch against the sequential runs it shares variants with.
        idx = np.linspace(0, args.batch - 1, args.seq).astype(int)
        seq_pos = np.array([f[7:10] for f in finals])  # link2 COM = q[7:10]
        dev = float(np.max(np.abs(out2[idx] - seq_pos)))
        rows.append({
            "case": "jit(vmap(f))(ks)", "variants": args.batch, "timed": args.batch, "compile [s]": t_compile,
            "wall [s]": t_batch, "per variant [ms]": 1e3 * t_batch / args.batch,
            "cpu per variant [ms]": 1e3 * c_batch / args.batch, "variants/s": args.batch / t_batch,
            "speed-up": per_seq * args.batch / t_batch,
            "note": f"max |batch - sequential| final position {dev:.2g} m"
            + ("; jacobian_refresh=False" if "jacobian_refresh" in vkw else ""),
        })
        ratio = rows[-1]["speed-up"]
        notes.append(
            f"vmap throughput = {ratio:.1f}x sequential simulate() ({'meets' if ratio >= TARGET else 'misses'} the >= {TARGET:g}x target)"
            + (f", {per_jit * args.batch / t_batch:.1f}x the jitted one-at-a-time loop." if per_jit else ".")
        )
    except Exception as exc:
        err = f"{type(exc).__name__}: {exc}"
        rows.append({"case": "jit(vmap(f))(ks)", "variants": args.batch, "note": "FAILED: " + err.splitlines()[0][:300]})
        notes.append("vmap through simulate failed with: " + err)
        log(traceback.format_exc())
    log(f"  {rows[-1]}")

    # -- proleg.sweep: the same batch through the library's sweep (CPU batch compiler options,
    # free-running driver: lanes do not wait for each other at every output time) ------------
    if hasattr(pl, "sweep"):
        log(f"proleg.sweep of {args.batch} ...")
        try:
            sw = pl.sweep(system, {"spring.stiffness": ks}, **{k: v for k, v in vkw.items() if k != "progress"})
            fin = np.asarray(sw.q[:, -1, 7:10])
            idx = np.linspace(0, args.batch - 1, args.seq).astype(int)
            dev = float(np.max(np.abs(fin[idx] - np.array([f[7:10] for f in finals]))))
            rows.append({
                "case": "proleg.sweep(system, {k: ks})", "variants": args.batch, "timed": args.batch,
                "compile [s]": sw.compile_time, "wall [s]": sw.wall_time, "per variant [ms]": 1e3 * sw.wall_time / args.batch,
                "variants/s": args.batch / sw.wall_time, "speed-up": per_seq * args.batch / sw.wall_time,
                "note": f"max |sweep - sequential| final position {dev:.2g} m; "
                f"{pl.analyses.sweep.default_workers()} workers (concurrent batches of <= {pl.analyses.sweep.CPU_BATCH_CAP} on the CPU); "
                f"steps per variant {int(np.min(sw.stats['steps']))}..{int(np.max(sw.stats['steps']))}",
            })
            ratio = rows[-1]["speed-up"]
            notes.append(f"proleg.sweep throughput = {ratio:.1f}x sequential simulate() ({'meets' if ratio >= TARGET else 'misses'} the >= {TARGET:g}x target).")
        except Exception as exc:
            rows.append({"case": "proleg.sweep(system, {k: ks})", "variants": args.batch, "note": f"FAILED: {type(exc).__name__}: {exc}"[:300]})
            log(traceback.format_exc())
        log(f"  {rows[-1]}")

    notes.insert(0, f"Sequential wall times are extrapolated linearly from {args.seq} timed runs to {args.batch}; "
                    "compile = first call minus one run; speed-up = throughput relative to sequential simulate().")
    emit(args, f"vmap batch vs sequential, 2-link pendulum + spring, {args.t_end:g} s simulated", rows, COLUMNS,
         {"batch": args.batch, "t_end [s]": args.t_end, "stiffness [N/m]": f"{ks[0]:g}..{ks[-1]:g}"}, notes)


if __name__ == "__main__":
    sys.exit(main())
