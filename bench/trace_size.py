"""Size of simulate's traced graphs (issue 20 item 2, "one compile from model to table").

A cold ``simulate`` spends its time tracing (Python), lowering and in XLA's CPU compiler, all
roughly proportional to the number of operations traced. This script counts them, a measure
that does not depend on the machine's load: the leaf equations of the jaxprs (equations of
nested jaxprs — loops, conds, custom rules — counted inside, not the nesting equation) of the
four functions a first ``simulate`` + ``to_frame`` compiles:

``advance``         solvers/driver.py, the integration loop (steps, Newton, dense output,
                    absolute-coordinate outputs: ``advance_absolute``)
``_ic``             solvers/initial.py, the initial-conditions analysis
``_post_one``       analyses/result.py, the outputs' post-processing (vmapped as post_batch;
                    traced here for one output)
``_reduced_start``  solvers/driver.py, the start in planar/joint coordinates (absolute: none)

on three models: the README double pendulum (planar coordinates), the 7-link chain
(common.build_chain(7)) and the HyQ leg drop (hyq_leg(joints="rigid", actuators="drop") through
hyq_tests.drop_test; ``hyq_b8``: the same with eight bushings, make run's largest model). The
arguments are captured from a real ``simulate`` call, which is stopped before the integration
loop compiles (only ``_ic`` and ``_reduced_start`` run). The pendulum and the chain run with
``GeneralizedAlpha()``: these functions are the α-methods' (the default ``integrator="auto"``
may give them to Diffrax, whose loop is not counted here).

``--compile`` also times each function's trace, lowering and XLA compile (cold, proleg's XLA
options of that function; load-sensitive: give ``uptime`` with the numbers and repeat).
``--top N`` prints, per function and model, the N proleg functions with the most equations
(inclusive: an equation counts for every proleg function on its traceback).

    PYTHONPATH=src python bench/trace_size.py [--compile] [--top 20] [--models pendulum,chain7,hyq]

Writes bench/results/trace_size.csv (and .md/.json through common.emit).
"""

from __future__ import annotations

import argparse
import collections
import csv
import time

from common import RESULTS_DIR, add_output_args, build_chain, emit, log, readme_model

import jax  # noqa: E402
import jax.extend  # noqa: E402

FUNCS = ("advance", "_ic", "_post_one", "_reduced_start")


class _Stop(Exception):
    """Raised by the spy on ``advance`` once its arguments are captured."""


def pendulum():
    import proleg as pl

    system = pl.assemble(readme_model())
    return lambda: pl.simulate(system, t_end=2.0, dt_output=1e-3, integrator=pl.GeneralizedAlpha())


def chain7():
    import proleg as pl

    system = pl.assemble(build_chain(7))
    return lambda: pl.simulate(system, t_end=1.0, dt_output=0.01, progress=False, integrator=pl.GeneralizedAlpha())


def hyq():
    from proleg import assemble
    from proleg.robots.hyq_leg import hyq_leg
    from proleg.papers.hyq_tests import drop_test

    system = assemble(hyq_leg(joints="rigid", actuators="drop"))
    return lambda: drop_test(system=system)


def hyq_b8():
    from proleg import assemble
    from proleg.robots.hyq_leg import hyq_leg
    from proleg.papers.hyq_tests import drop_test

    system = assemble(hyq_leg(joints="bushings8", actuators="drop"))
    return lambda: drop_test(system=system)


MODELS = {"pendulum": pendulum, "chain7": chain7, "hyq": hyq, "hyq_b8": hyq_b8}


def capture(run):
    """The arguments (and traceable functions) of the four compiled functions of one ``simulate``."""
    import proleg.analyses.simulate as S
    import proleg.solvers.initial as I
    from proleg.analyses.result import _post_one
    from proleg.solvers import driver

    got = {}
    orig = {"adv": driver.advance_absolute, "ic": I._ic, "rs": driver._reduced_start, "post": S._compile_post}

    def spy_ic(*a):
        out = orig["ic"](*a)
        got.setdefault("_ic", (orig["ic"].fn, (4,), a, out))
        return out

    def spy_rs(*a):
        got.setdefault("_reduced_start", (orig["rs"].fn, (), a))
        return orig["rs"](*a)

    def spy_adv(*a):
        got["advance"] = (orig["adv"].fn, (1, 2, 7), a)  # the loop with its absolute-coordinate outputs
        raise _Stop

    def restore():
        driver.advance_absolute, I._ic, driver._reduced_start = orig["adv"], orig["ic"], orig["rs"]
        S._compile_post = orig["post"]

    driver.advance_absolute, I._ic, driver._reduced_start, S._compile_post = spy_adv, spy_ic, spy_rs, lambda *a: None
    try:
        run()
    except _Stop:
        pass
    finally:
        restore()
    fn, sa, a, out = got.pop("_ic")
    got["_ic"] = (fn, sa, a)
    q, v, z, t0 = out[0], out[1], out[4], a[3]
    system = a[0]
    one = lambda x: jax.numpy.asarray(x)[None]  # noqa: E731
    post = jax.vmap(_post_one, in_axes=(None, 0, 0, 0, 0))
    got["_post_one"] = (post, (), (system, one(q), one(v), one(t0), one(z)))
    return got


def _subjaxprs(eqn):
    for p in eqn.params.values():
        for x in p if isinstance(p, (tuple, list)) else [p]:
            if isinstance(x, jax.extend.core.ClosedJaxpr):
                yield x.jaxpr
            elif isinstance(x, jax.extend.core.Jaxpr):
                yield x


def count(jaxpr):
    """(leaf equations, inclusive Counter of proleg functions on their tracebacks)."""
    inner = collections.Counter()

    def walk(j):
        n = 0
        for e in j.eqns:
            subs = list(_subjaxprs(e))
            if subs:
                n += sum(walk(s) for s in subs)
                continue
            n += 1
            tb = e.source_info.traceback
            if tb is not None:
                names = {(f.file_name.split("/proleg/")[1], f.function_name) for f in tb.frames if "/proleg/" in f.file_name}
                inner.update(f"{a}:{b}" for a, b in names)
        return n

    return walk(jaxpr), inner


def compile_times(fn, static, args, xla):
    """(trace, lower, XLA) seconds of a cold compile of ``fn`` with proleg's options ``xla``."""
    from proleg.compile_cache import xla_options

    jf = jax.jit(fn, static_argnums=static)
    t0 = time.perf_counter()
    tr = jf.trace(*args)
    t1 = time.perf_counter()
    lo = tr.lower()
    t2 = time.perf_counter()
    lo.compile(compiler_options=xla_options(xla))
    t3 = time.perf_counter()
    return t1 - t0, t2 - t1, t3 - t2


XLA_KIND = {"advance": "loop", "_ic": "once", "_post_one": "loop", "_reduced_start": "once"}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", default="pendulum,chain7,hyq")
    ap.add_argument("--compile", action="store_true", help="also time trace / lower / XLA compile of each function (cold)")
    ap.add_argument("--top", type=int, default=0, help="print the N proleg functions with most equations per function")
    ap.add_argument("--csv", default=str(RESULTS_DIR / "trace_size.csv"), help="CSV output ('' to skip)")
    add_output_args(ap, "trace_size")
    args = ap.parse_args()
    rows = []
    for name in args.models.split(","):
        log(f"{name}: capturing")
        got = capture(MODELS[name]())
        for fname in FUNCS:
            if fname not in got:
                rows.append({"model": name, "function": fname, "eqns": 0})
                continue
            fn, static, a = got[fname]
            row = {"model": name, "function": fname}
            if args.compile:  # first: a trace made by make_jaxpr would be reused by jit (cached)
                row["trace_s"], row["lower_s"], row["xla_s"] = compile_times(fn, static, a, XLA_KIND[fname])
            jx = jax.make_jaxpr(fn, static_argnums=static)(*a)
            n, inner = count(jx.jaxpr)
            row["eqns"] = n
            rows.append(row)
            log(f"  {fname}: {n} leaf eqns" + (f", trace {row['trace_s']:.2f} lower {row['lower_s']:.2f} xla {row['xla_s']:.2f} s" if args.compile else ""))
            if args.top:
                for k, c in inner.most_common(args.top):
                    log(f"      {c:6d} {k}")
    for name in args.models.split(","):
        rows.append({"model": name, "function": "total", "eqns": sum(r["eqns"] for r in rows if r["model"] == name),
                     **({k: sum(r.get(k, 0.0) for r in rows if r["model"] == name) for k in ("trace_s", "lower_s", "xla_s")} if args.compile else {})})
    cols = ["model", "function", "eqns"] + (["trace_s", "lower_s", "xla_s"] if args.compile else [])
    emit(args, "Leaf jaxpr equations of simulate's compiled functions", rows, cols,
         notes=["eqns: leaf equations (nested jaxprs counted inside); seconds: one cold compile each, load-sensitive"])
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, cols)
            w.writeheader()
            w.writerows({k: (f"{v:.3f}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows)
        log(f"wrote {args.csv}")


if __name__ == "__main__":
    main()
