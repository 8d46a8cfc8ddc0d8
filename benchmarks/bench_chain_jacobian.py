"""The rod's Jacobian by the chain rule (:mod:`flagellum.rod.jacobian`) against the coloured
finite differences (docs/benchmarks.md, "Chain-rule Jacobian").

In one process: the cost of one Jacobian of each kind in right-hand sides (N = 50, 100, 200),
then the deterministic BDF with each (``CHAIN_JACOBIAN`` True / False, the loop recompiled
from its own bytecode) from rest, L = 10 µm: buckled (M = 1.6, N = 50, 0.1 s; N = 200,
0.01 s), aligned (M = 1, 0.1 s), M = 3 and M = 5 (0.05 s): steps, Jacobians, right-hand
sides, wall time per simulated second (the fastest of 3 alternating runs) and the time averages
of thrust, ω and χ (second half); then the thermal implicit scheme (paper filament, M = 1,
0.02 s, seed 1) with each (it ships with the coloured one; the chain rule by recompiling it).

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_chain_jacobian.py [--quick]
(``--quick``: the buckled N = 50 run only). Writes benchmarks/bench_chain_jacobian.json.
"""

from __future__ import annotations

import json
import sys
import time
import types
from pathlib import Path

import numpy as np
from numba import njit

from flagellum import bench as FB
from flagellum.integrate import bdf as B
from flagellum.integrate import brownian as BR
from flagellum.motor import Boundary, Motor
from flagellum.params import Filament, Params
from flagellum.rod import jacobian as RJ
from flagellum.rod import kernels as K
from flagellum.rod.model import RodModel
from flagellum.simulator import Simulator, SolverOptions

QUICK = "--quick" in sys.argv
HERE = Path(__file__).parent
LENGTH = 10.0
REPEATS = 3
RUNS = [(50, 1.6, 0.1), (50, 1.0, 0.1), (50, 3.0, 0.05), (50, 5.0, 0.05), (200, 1.6, 0.01)]


def _fd_loop():
    """bdf_advance with CHAIN_JACOBIAN = False (its _jacobian recompiled with the constant)."""
    j = B._jacobian.py_func
    jac = njit(types.FunctionType(j.__code__, dict(j.__globals__, CHAIN_JACOBIAN=False), j.__name__))
    f = B.bdf_advance.py_func
    return njit(types.FunctionType(f.__code__, dict(f.__globals__, _jacobian=jac), f.__name__))


LOOPS = {"chain": B.bdf_advance, "colored": _fd_loop()}


@njit
def _chain_or_colored(general, y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws,
                      kl, ku, ab, scale, y_work, f_work, color, lo, hi):
    RJ.model_jacobian(general, y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws,
                      kl, ku, ab, scale, y_work, f_work, color, lo, hi)


def _chain_thermal():
    """implicit_steps with the chain-rule Jacobian: its ``K`` a copy of rod.kernels whose
    model_colored_jacobian is rod.jacobian.model_jacobian (the shipped scheme keeps the coloured one)."""
    fake = types.ModuleType("kernels_chain")
    fake.__dict__.update({k: v for k, v in K.__dict__.items() if not k.startswith("__")})
    fake.model_colored_jacobian = _chain_or_colored
    f = BR.implicit_steps.py_func
    return njit(types.FunctionType(f.__code__, dict(f.__globals__, K=fake), f.__name__))


THERMAL = {"chain": _chain_thermal(), "colored": BR.implicit_steps}


def thermal(loop: str, t_end: float) -> dict:
    """The thermal paper filament (N = 50, M = 1, kT of the paper, seed 1; the implicit scheme)."""
    BR.implicit_steps = THERMAL[loop]
    made = []
    init = BR.ImplicitStepper.__init__

    def keep(self, *a, **k):
        init(self, *a, **k)
        made.append(self)

    BR.ImplicitStepper.__init__ = keep
    try:
        sim = Simulator(Params(), Motor(1.0), Boundary(), thermal=True, seed=1,
                        solver=SolverOptions(method="implicit"))
        w0 = time.perf_counter()
        tr = sim.run(t_end, save_every=t_end / 200, progress=False)
        wall = time.perf_counter() - w0
    finally:
        BR.implicit_steps, BR.ImplicitStepper.__init__ = THERMAL["colored"], init
    st = made[-1]
    summ = tr.summary()
    return {"case": "thermal M=1 N=50", "t_end": t_end, "jacobian": loop,
            "wall_per_simulated_second": wall / t_end, "steps": st.n_steps,
            "jacobians_per_step": st.n_jac / st.n_steps, "thrust_mean": float(summ.thrust_mean),
            "omega_mean": float(summ.omega_mean)}


def _timed(fn, reps):
    fn()
    t0 = time.perf_counter()
    for _ in range(reps):
        fn()
    return (time.perf_counter() - t0) / reps


def kernel_costs(n: int) -> dict:
    m = RodModel(Params(Filament(segment_length=LENGTH / n)), Motor(1.6), Boundary())
    kl, ku = m.jacobian_band
    color, lo, hi = m.jacobian_colors(kl, ku)
    y = m.initial_state()
    y[3:] += np.random.default_rng(1).normal(0.0, 0.01, y.size - 3)
    a = (m.prm, m.iprm, m.ref_u, m.ref_e, m.ref_m, m._zf, m._zm, m._zh, m._ws)
    ny = y.size
    ab, f0, yw, fw = np.zeros((ny, 2 * kl + ku + 1)), np.zeros(ny), np.zeros(ny), np.zeros(ny)
    reps = max(200, 100000 // ny)
    t_rhs = _timed(lambda: K.rod_rhs(y, f0, *a), 10 * reps)
    t_col = _timed(lambda: K.rod_colored_jacobian(y, f0, *a, kl, ku, ab, 1.0, yw, fw, color, lo, hi), reps)
    t_chain = _timed(lambda: RJ.rod_jacobian(y, f0, *a, kl, ku, ab, 1.0, yw, fw), reps)
    return {"segments": n, "colours": int(color.max() + 1), "rhs_us": t_rhs * 1e6,
            "colored_us": t_col * 1e6, "chain_us": t_chain * 1e6,
            "colored_in_rhs": t_col / t_rhs, "chain_in_rhs": t_chain / t_rhs,
            "chain_over_colored": t_chain / t_col}


def run(n: int, torque: float, t_end: float, loop: str) -> dict:
    B.bdf_advance = LOOPS[loop]  # BdfStepper calls the module's loop
    try:
        sim = Simulator(Params(Filament(segment_length=LENGTH / n)), Motor(torque),
                        solver=SolverOptions(method="bdf"))
        made = []
        make = sim._stepper
        sim._stepper = lambda: made.append(make()) or made[-1]
        w0 = time.perf_counter()
        tr = sim.run(t_end, save_every=t_end / 200, progress=False)
        wall = time.perf_counter() - w0
    finally:
        B.bdf_advance = LOOPS["chain"]
    stats: dict = {}
    for s in made:
        for k, v in s.stats.items():
            stats[k] = stats.get(k, 0) + v
    summ = tr.summary()  # the second half
    return {"segments": n, "torque": torque, "t_end": t_end, "jacobian": loop,
            "wall_per_simulated_second": wall / t_end, "steps": stats["steps"],
            "jacobians": stats["jacobians"], "rhs": stats["rhs"],
            "thrust_mean": float(summ.thrust_mean), "omega_mean": float(summ.omega_mean),
            "chi_mean": float(summ.chi_mean)}


def main() -> None:
    FB.warm_up()
    runs = RUNS[:1] if QUICK else RUNS
    out = {"kernels": [kernel_costs(n) for n in ((50,) if QUICK else (50, 100, 200))], "runs": []}
    for r in out["kernels"]:
        print(json.dumps({k: round(v, 3) if isinstance(v, float) else v for k, v in r.items()}), flush=True)
    for n, torque, t_end in runs:
        for loop in LOOPS:  # compile both loops for this N first
            run(n, torque, min(t_end, 2e-3), loop)
        pair = {}
        for _ in range(REPEATS):  # alternating; the fastest of each (the machine is shared)
            for loop in LOOPS:
                r = run(n, torque, t_end, loop)
                if loop not in pair or r["wall_per_simulated_second"] < pair[loop]["wall_per_simulated_second"]:
                    pair[loop] = r
        pair["chain"]["wall_ratio_chain_over_colored"] = (
            pair["chain"]["wall_per_simulated_second"] / pair["colored"]["wall_per_simulated_second"])
        for r in pair.values():
            out["runs"].append(r)
            print(json.dumps({k: round(v, 6) if isinstance(v, float) else v for k, v in r.items()}), flush=True)
    for loop in THERMAL:
        thermal(loop, 1e-3)
    best: dict = {}
    for _ in range(REPEATS):
        for loop in THERMAL:
            r = thermal(loop, 0.005 if QUICK else 0.02)
            if loop not in best or r["wall_per_simulated_second"] < best[loop]["wall_per_simulated_second"]:
                best[loop] = r
    best["chain"]["wall_ratio_chain_over_colored"] = (
        best["chain"]["wall_per_simulated_second"] / best["colored"]["wall_per_simulated_second"])
    out["thermal"] = list(best.values())
    for r in out["thermal"]:
        print(json.dumps({k: round(v, 6) if isinstance(v, float) else v for k, v in r.items()}), flush=True)
    if not QUICK:
        (HERE / "bench_chain_jacobian.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
