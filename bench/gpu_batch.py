"""Batched simulation throughput with ``jax.vmap`` on whatever device JAX finds (CPU or GPU).

Model: a double pendulum (1 m, 1 kg links) with a tip spring to ground; the batch sweeps the
spring stiffness over [10, 100] N/m; 1 s simulated, fixed step 1 ms (so every variant takes the
same steps: the batched while-loop does no wasted work), one Newton Jacobian per step
(``jacobian_refresh=False``: a ``lax.cond`` under vmap would become a select).

    python bench/gpu_batch.py --batch 1 100 1000 10000 [--json] [--out PATH]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import proleg as pl


def build():
    m = pl.Model("double_pendulum_spring", gravity=(0, 0, -9.81))
    up = m.add_part("upper", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(0.5, 0, 0))
    lo = m.add_part("lower", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(1.5, 0, 0))
    m.add_joint(pl.Revolute("shoulder", m.ground, up, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_joint(pl.Revolute("elbow", up, lo, at=(1, 0, 0), axis=(0, 1, 0)))
    tip = m.add_marker(lo, "tip", (2, 0, 0))
    anchor = m.add_marker(m.ground, "anchor", (2, 0, -1))
    m.add_force(pl.SpringDamper("spring", tip, anchor, stiffness=50.0, damping=0.5, free_length=1.0))
    return pl.assemble(m)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--batch", type=int, nargs="+", default=[1, 100, 1000])
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    system = build()

    def final_x(k):
        r = pl.simulate(system.with_params({"spring.stiffness": k}), t_end=a.t_end, dt_output=0.1, integrator=pl.GeneralizedAlpha(fixed_step=1e-3), progress=False)
        return r.part("lower").position[-1]

    rows = []
    for n in a.batch:
        ks = jnp.linspace(10.0, 100.0, n)
        f = jax.jit(jax.vmap(final_x))
        t0 = time.perf_counter()
        out = f(ks).block_until_ready()
        t1 = time.perf_counter()
        out = f(ks + 1e-9).block_until_ready()
        t2 = time.perf_counter()
        rows.append({"batch": n, "first call [s]": round(t1 - t0, 2), "run [s]": round(t2 - t1, 4), "variants/s": round(n / (t2 - t1), 1), "steps/s (all variants)": round(n * a.t_end / 1e-3 / (t2 - t1))})
    dev = jax.devices()[0]
    table = {"device": f"{dev.platform}: {getattr(dev, 'device_kind', '')}", "machine": platform.processor() or platform.machine(), "jax": jax.__version__, "rows": rows}
    if a.json:
        print(json.dumps(table))
    else:
        print(f"# vmap batch throughput on {table['device']} (jax {jax.__version__})\n")
        print("| " + " | ".join(rows[0]) + " |\n|" + "---:|" * len(rows[0]))
        for r in rows:
            print("| " + " | ".join(str(v) for v in r.values()) + " |")
    if a.out:
        Path(a.out).write_text(json.dumps(table, indent=1))


if __name__ == "__main__":
    main()
