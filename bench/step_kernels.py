"""XLA kernels per integrator step of a whole robot, by what launched them (issue 43).

On XLA-CPU a step costs about a third of a microsecond per kernel launch on this machine class
(bench/README.md, "Where the time goes"), so a robot's step is as fast as its kernel count is
small. This script counts them with XLA's own per-kernel trace: each robot of
bench/whole_robot.py stands for ``--t-end`` seconds at proleg's defaults in a fresh process
with ``XLA_FLAGS=--xla_cpu_enable_xprof_traceme=true`` under ``jax.profiler.trace``; the
optimized HLO of the step loop (``--xla_dump_to``) names each kernel's Python source through
its stack frames, and each kernel is put in the first group whose function is on its stack:

* ``residual`` — the Newton iterations' residual (galpha.step's ``residual``);
* ``Newton matrix`` — building and factoring it (``iteration_matrix``, ``fresh_factors``);
* ``solves`` — the triangular solves per iteration (``lu_apply``);
* ``controller tick`` — a controller sample and the restart after it, with the step's powers in
  joint coordinates (driver ``_tick_joint``, ``_sample_update``, ``_restart``);
* ``powers`` — the step's powers (energy bookkeeping) otherwise;
* ``step, other`` — the rest of galpha.step (predictor, convergence tests, error estimate);
* ``driver`` — the step-size control, output blocks and loop plumbing (copies of the loop
  state included).

Counts are per accepted step, from one run; durations under the trace are inflated by the
tracing itself (about 1 µs an event), so only the counts are tabulated. Run it with
``PYTHONPATH=<another checkout>/src`` to count another version (before/after tables).

    python bench/step_kernels.py --robots go1 hyq --out bench/results/step_kernels.md
"""

from __future__ import annotations

import argparse
import collections
import glob
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import add_output_args, emit, log

GROUPS = [
    ("residual", {"residual"}),
    ("Newton matrix", {"iteration_matrix", "fresh_factors", "_lu_factors_augmented", "_lu_factors_square", "lu_factors"}),
    ("solves", {"lu_apply"}),
    ("controller tick", {"_tick_joint", "_sample_update", "_restart"}),
    ("powers", {"power_terms", "plain", "with_power"}),
    ("step, other", {"step"}),
]
COLUMNS = ["robot", "proleg", "steps", "newton/step", "kernels/step", "kernels/iteration (residual)"] + [g for g, _ in GROUPS] + ["driver"]
#: trace events that are the tracer's own, not kernels
NOT_KERNELS = ("ThreadpoolListener", "end:", "Transpose", "ThunkExecutor", "while", "cond")


def _frames(hlo: str):
    """{stack frame id: [function names, innermost first]} from the module's stack-frame tables."""
    sec, cur = {}, None
    for line in hlo.split("\n"):
        if line in ("FileNames", "FunctionNames", "FileLocations", "StackFrames"):
            cur = line
            sec[cur] = {}
            continue
        m = re.match(r"^(\d+) (.*)$", line) if cur else None
        if m:
            sec[cur][int(m.group(1))] = m.group(2)
        elif cur and not line.strip():
            cur = None
    funcs = {k: v.strip('"').split(".")[-1] for k, v in sec.get("FunctionNames", {}).items()}
    locs = {k: funcs[int(re.search(r"function_name_id=(\d+)", v).group(1))] for k, v in sec.get("FileLocations", {}).items()}
    par = {k: tuple(int(x) for x in re.search(r"file_location_id=(\d+) parent_frame_id=(\d+)", v).groups())
           for k, v in sec.get("StackFrames", {}).items()}

    def stack(fid):
        out, seen = [], set()
        while fid in par and fid not in seen:
            seen.add(fid)
            loc, p = par[fid]
            out.append(locs.get(loc, "?"))
            fid = p - 1 if p > 0 else 0
        return out

    return stack


def _group(names) -> str:
    for g, fns in GROUPS:
        if any(n in fns for n in names):
            return g
    return "driver"


def _measure(robot: str, t_end: float) -> dict:
    """In this (fresh) process: the robot's per-step kernel counts (module docstring)."""
    import warnings

    import jax

    jax.config.update("jax_enable_x64", True)
    import proleg as pl
    from jax._src.lib import _profile_data
    from whole_robot import stand_model

    warnings.simplefilter("ignore")
    model = stand_model(robot)[0]
    system = pl.assemble(model)
    pl.simulate(system, t_end, 1e-2, progress=False)  # compile
    trace = tempfile.mkdtemp(prefix="proleg_kernels_")
    with jax.profiler.trace(trace):
        r = pl.simulate(system, t_end, 1e-2, progress=False)
    pd = _profile_data.ProfileData.from_file(glob.glob(f"{trace}/**/*.xplane.pb", recursive=True)[0])
    count = collections.Counter()
    for plane in pd.planes:
        for line in plane.lines:
            if "XLAEigen" not in line.name:
                continue
            for ev in line.events:
                if not ev.name.startswith(NOT_KERNELS):
                    count[ev.name] += 1
    dumps = sorted(glob.glob(os.path.join(os.environ["PROLEG_KERNEL_DUMP"], "*jit_advance.cpu_after_optimizations.txt")))
    hlo = Path(dumps[-1]).read_text()
    stack = _frames(hlo)
    frame_of = {m.group(1): int(m.group(2)) for m in re.finditer(r"\n\s*(?:ROOT )?%?([\w.\-]+) = [^\n]*stack_frame_id=(\d+)", hlo)}
    by = collections.Counter()
    for name, c in count.items():
        by[_group(stack(frame_of[name]) if name in frame_of else [])] += c
    steps = int(r.stats["steps"])
    newton = int(r.stats["newton_iterations"])
    row = {"robot": robot, "steps": steps, "newton/step": newton / steps, "kernels/step": sum(by.values()) / steps,
           "kernels/iteration (residual)": by["residual"] / max(newton, 1)}
    row.update({g: by[g] / steps for g, _ in GROUPS})
    row["driver"] = by["driver"] / steps
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", nargs="+", default=["go1", "anymal_c", "solo12", "hyq"])
    ap.add_argument("--t-end", type=float, default=0.3)
    ap.add_argument("--label", default=None, help="the proleg column (default: its git commit)")
    ap.add_argument("--worker", nargs=2, metavar=("ROBOT", "JSON"), help=argparse.SUPPRESS)
    add_output_args(ap, "step_kernels")
    a = ap.parse_args(argv)
    if a.worker:
        Path(a.worker[1]).write_text(json.dumps(_measure(a.worker[0], a.t_end)))
        return
    import proleg

    src = Path(proleg.__file__).resolve().parents[2]
    commit = subprocess.run(["git", "-C", str(src), "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain", "--untracked-files=no", "src"], capture_output=True, text=True).stdout.strip()
    label = a.label or (commit + ("+changes" if dirty else ""))
    rows = []
    for robot in a.robots:
        with tempfile.TemporaryDirectory() as dump:
            out = Path(dump) / "row.json"
            env = dict(os.environ, PROLEG_KERNEL_DUMP=dump, PROLEG_CACHE_DIR="",  # cache off: the loop is compiled and dumped here
                       XLA_FLAGS=(os.environ.get("XLA_FLAGS", "") + f" --xla_cpu_enable_xprof_traceme=true --xla_dump_to={dump}"
                                  " --xla_dump_hlo_as_text --xla_dump_hlo_module_re=.*advance.*").strip())
            t = time.perf_counter()
            p = subprocess.run([sys.executable, __file__, "--t-end", str(a.t_end), "--worker", robot, str(out)], env=env,
                               capture_output=True, text=True)
            if p.returncode or not out.exists():
                log(f"{robot}: failed\n{p.stderr[-2000:]}")
                continue
            row = json.loads(out.read_text())
            row["proleg"] = label
            rows.append(row)
            log(f"{robot}: {row['kernels/step']:.0f} kernels/step ({time.perf_counter() - t:.0f} s)")
    emit(a, "XLA kernels per step, whole robots standing at the defaults (bench/step_kernels.py)", rows, COLUMNS,
         notes=[f"{a.t_end:g} s of standing per robot (bench/whole_robot.py's stand), counts per accepted step from one traced run",
                "groups: the first of residual, Newton matrix, solves, controller tick, powers, step other, driver whose function "
                "is on the kernel's stack (module docstring)"])


if __name__ == "__main__":
    main()
