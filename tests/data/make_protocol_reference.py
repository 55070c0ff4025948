"""Reference outputs of every method before the protocol refactor (main e754ddf)."""
import json, sys
import numpy as np
import proleg as pl

def models():
    m = pl.Model("proto_dp", gravity=(0.0, 0.0, -9.81))
    up = m.add_part("upper", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(0.5, 0, 0))
    lo = m.add_part("lower", mass=1.0, inertia=(0.01, 0.09, 0.09), position=(1.5, 0, 0))
    m.add_joint(pl.Revolute("shoulder", m.ground, up, at=(0, 0, 0), axis=(0, 1, 0)))
    m.add_joint(pl.Revolute("elbow", up, lo, at=(1, 0, 0), axis=(0, 1, 0)))
    tip, anc = m.add_marker(lo, "tip", (2, 0, 0)), m.add_marker(m.ground, "anchor", (2, 0, -1))
    m.add_force(pl.SpringDamper("spring", tip, anc, stiffness=50.0, damping=0.5, free_length=1.0))
    return pl.assemble(m)

s = models()
out = {}
for name, ig in [("GeneralizedAlpha", pl.GeneralizedAlpha(rtol=1e-7, atol=1e-8)), ("HHT", pl.HHT(-0.1, rtol=1e-7, atol=1e-8)),
                 ("Tsit5", pl.Tsit5(rtol=1e-8, atol=1e-9)), ("Dopri5", pl.Dopri5(rtol=1e-8, atol=1e-9)),
                 ("Kvaerno5", pl.Kvaerno5(rtol=1e-7, atol=1e-8)), ("Radau5", pl.Radau5(rtol=1e-7, atol=1e-8))]:
    r = pl.simulate(s, 0.5, 0.05, integrator=ig, progress=False)
    out[name] = dict(q=np.asarray(r.q).tolist(), v=np.asarray(r.v).tolist(), steps=int(r.stats["steps"]))
    print(name, r.stats["steps"], flush=True)
json.dump(out, open(sys.argv[1], "w"))
