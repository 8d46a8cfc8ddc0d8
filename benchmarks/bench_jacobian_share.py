"""Where the Numba BDF's time goes, per regime (docs/benchmarks.md, "Chain-rule Jacobian").

From rest, N = 50 (buckled M = 1.6, aligned M = 1: 0.1 s; M = 3, M = 5: 0.05 s) and N = 200
(M = 1.6, 0.01 s), one process, each compiled first: the stepper's counters and the share of
the wall time of the Jacobians, the plain right-hand sides, the LU factorizations and the
band solves, each estimated as count × the unit cost timed here on a representative state
(timed through Numba's dispatcher, so slight over-estimates). The json in benchmarks/ was
measured with the coloured Jacobian (``integrate.bdf.CHAIN_JACOBIAN = False``, before). Run:
OPENBLAS_NUM_THREADS=1 python benchmarks/bench_jacobian_share.py [--quick]; writes
benchmarks/bench_jacobian_share.json.
"""
import json, sys, time, numpy as np
from flagellum.motor import Motor
from flagellum.params import Filament, Params
from flagellum.simulator import Simulator, SolverOptions
from flagellum.integrate import bdf as BDF
from flagellum.rod import jacobian as RJ
from flagellum.rod import kernels as K
from flagellum.integrate.banded import band_factor, band_solve

def tm(fn, k):
    fn(); t0 = time.perf_counter()
    for _ in range(k): fn()
    return (time.perf_counter()-t0)/k

def unit_costs(m):
    y = m.initial_state(); y[3:] += np.random.default_rng(1).normal(0, 0.01, y.size-3)
    kl, ku = m.jacobian_band; color, lo, hi = m.jacobian_colors(kl, ku)
    f = np.zeros(y.size); args = (m.prm, m.iprm, m.ref_u, m.ref_e, m.ref_m, m._zf, m._zm, m._zh, m._ws)
    ab = np.zeros((y.size, 2*kl+ku+1)); yw = np.zeros(y.size); fw = np.zeros(y.size)
    if BDF.CHAIN_JACOBIAN:  # the Jacobian the BDF takes (rod.jacobian where it covers the model)
        jac = lambda: RJ.rod_jacobian(y, f, *args, kl, ku, ab, 1.0, yw, fw)
    else:
        jac = lambda: K.rod_colored_jacobian(y, f, *args, kl, ku, ab, 1.0, yw, fw, color, lo, hi)
    jac()
    lu = np.empty_like(ab); ipiv = np.zeros(y.size, np.int64); backup = np.empty((y.size, kl+ku+1))
    def fac():
        lu[:] = -1e-4 * ab; lu[:, kl+ku] += 1.0
        return band_factor(lu, kl, ku, ipiv, backup)
    piv = [fac()[1]]; b = np.ones(y.size); work = np.empty(y.size + 2*(kl+ku))
    k = max(50, 20000 // y.size)
    return dict(colours=int(color.max()+1), rhs_s=tm(lambda: K.rod_rhs(y, f, *args), 40*k),
                jac_s=tm(jac, k), factor_s=tm(fac, k),
                solve_s=tm(lambda: band_solve(lu, kl, ku, ipiv, b.copy(), bool(piv[0]), work), 10*k))

def run(n, M, T, frame="auto"):
    sim = Simulator(Params(Filament(segment_length=10.0/n)), Motor(M), solver=SolverOptions(method="bdf", frame=frame))
    made = []; mk = sim._stepper
    sim._stepper = lambda: made.append(mk()) or made[-1]
    w0 = time.perf_counter(); tr = sim.run(T, save_every=min(5e-4, T/50), progress=False); wall = time.perf_counter()-w0
    st = {}
    for s in made:
        for k, v in s.stats.items(): st[k] = st.get(k, 0) + v
    uc = unit_costs(sim.model)
    per_jac = 2 if BDF.CHAIN_JACOBIAN else uc["colours"] + 1  # right-hand sides counted per Jacobian
    nrhs_plain = st["rhs"] - st["jacobians"] * per_jac
    parts = dict(jacobian=st["jacobians"]*uc["jac_s"], rhs=nrhs_plain*uc["rhs_s"],
                 factor=st["factorizations"]*uc["factor_s"], solve=nrhs_plain*uc["solve_s"])
    return dict(segments=n, torque=M, t_end=T, wall_s=wall, wall_per_simulated_second=wall/T, **st, **uc,
                **{f"share_{k}": v/wall for k, v in parts.items()},
                thrust_mean=float(np.mean(tr.thrust)))

cases = [(50, 1.6, 0.1), (50, 1.0, 0.1), (50, 3.0, 0.05), (50, 5.0, 0.05), (200, 1.6, 0.01)]
if "--quick" in sys.argv: cases = cases[:1]
for c in cases: run(c[0], c[1], min(c[2], 0.005))  # warm (compile) each N
out = []
for c in cases:
    r = run(*c); out.append(r)
    print(json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()}), flush=True)
json.dump(out, open(__import__("pathlib").Path(__file__).with_suffix(".json"), "w"), indent=1)
