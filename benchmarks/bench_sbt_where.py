"""Where an SBT run's time goes (docs/hydrodynamics.md, "Where the time goes"): for each named
regime of flagellum.bench (N = 50, from rest, default refresh), the RFT and the SBT run in one
process (after an untimed 10-ms run of each), CPU seconds, steps, right-hand sides and
factorizations of the BDF, the renewals of ΔM (``stats["mobility_renewals"]``), one build of
ΔM timed at the final state, and the builds' share of SBT's CPU time.

    python benchmarks/bench_sbt_where.py from_rest_M1 buckled_M1.6 load_sphere_M2 free_swimmer_M2 M3
        [results in benchmarks/bench_sbt_where.json]
"""
import sys, time, json, numpy as np
from flagellum.bench import REGIMES, run_regime
from flagellum.simulator import Simulator
from flagellum.params import Params
from flagellum.motor import Motor
from flagellum.hydro.options import Hydrodynamics
from flagellum.hydro import dynamics as D
from flagellum.rod.model import positions
from flagellum.integrate import bdf as B
inst = []
_init = B.BdfStepper.__init__
def init(self, *a, **k):
    _init(self, *a, **k); inst.append(self)
B.BdfStepper.__init__ = init
rows = {}
for name in sys.argv[1:]:
    torque, w, boundary, thermal = REGIMES[name]
    for hd in (None, Hydrodynamics("sbt")):
        run_regime(name, window=0.01, hydrodynamics=hd)
    out = {}
    for hd in (None, Hydrodynamics("sbt")):
        inst.clear()
        sim = Simulator(Params(), Motor(torque), boundary, hydrodynamics=hd)
        c0 = time.process_time()
        sim.run(w, save_every=w / 200, progress=False)
        cpu = time.process_time() - c0
        sts = [i.stats for i in inst]
        st = {k: sum(d[k] for d in sts) for k in sts[0]}
        out["rft" if hd is None else "sbt"] = (cpu, st)
    m = sim.model
    x = np.ascontiguousarray(positions(sim.y)); dm = np.empty_like(m._ws[-1]); args = m.build_arguments()
    D._correction_into(x, *args, dm)
    k = 2000; t0 = time.perf_counter()
    for _ in range(k): D._correction_into(x, *args, dm)
    tb = (time.perf_counter() - t0) / k
    (cr, sr), (cs, ss) = out["rft"], out["sbt"]
    rows[name] = {"rft_cpu": round(cr, 3), "sbt_cpu": round(cs, 3), "ratio": round(cs / cr, 2),
                  "rft_steps": sr["steps"], "sbt_steps": ss["steps"], "rft_rhs": sr["rhs"], "sbt_rhs": ss["rhs"],
                  "renewals": ss["mobility_renewals"], "build_ms": round(tb * 1e3, 4),
                  "builds_share": round(ss["mobility_renewals"] * tb / cs, 3),
                  "sbt_factorizations": ss["factorizations"], "rft_factorizations": sr["factorizations"]}
    print(name, json.dumps(rows[name]), flush=True)
with open("benchmarks/bench_sbt_where.json", "w") as f:
    json.dump(rows, f, indent=1)
