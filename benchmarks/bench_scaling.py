"""Cost per simulated second against the resolution N in the buckled regime (docs/benchmarks.md).

The buckled run of :data:`flagellum.bench.REGIMES` (M = 1.6 pN·µm from the helix at rest)
at N = 50, 100, 200, 400 segments with the filament length fixed at L = 10 µm (segment
length L/N, so N sets the resolution only), with CVODE and with the Numba BDF at their
default tolerances. Each run goes from rest to 0.2 s untimed-apart (the buckling
transient) and is timed over the buckled window 0.2–0.3 s (the window in which the N = 50
run takes ≈ 470 steps per motor revolution); reported per window: wall seconds per
simulated second, steps, right-hand sides and Jacobians where the stepper counts them,
the time-averaged thrust, and the fitted exponent p of cost ∝ N^p (least squares in log–log
over the four N). Interleaved N by N (CVODE then BDF) in one process.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_scaling.py [--quick]
(``--quick``: N = 50, 100 and a 0.05-s buckled window after 0.1 s)
Writes benchmarks/bench_scaling.json (bench_scaling_quick.json with --quick).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from flagellum import bench as B
from flagellum.motor import Motor
from flagellum.params import Filament, Params
from flagellum.simulator import Simulator, SolverOptions

QUICK = "--quick" in sys.argv
NS = (50, 100) if QUICK else (50, 100, 200, 400)
T_BUCKLE, T_END = (0.1, 0.15) if QUICK else (0.2, 0.3)
LENGTH = 10.0  # µm, the default filament's length
HERE = Path(__file__).parent


def counters(sim) -> dict:
    """The last run's stepper's counters (CVODE: Jacobians; BDF: its ``stats``)."""
    st = getattr(sim, "last_stepper", None)
    out = {}
    for name in ("n_jac", "n_steps"):
        if st is not None and hasattr(st, name):
            out[name] = int(getattr(st, name))
    stats = getattr(st, "stats", None)
    if isinstance(stats, dict):
        out.update({k: v for k, v in stats.items() if isinstance(v, (int, float))})
    return out


def one(n: int, method: str) -> dict:
    sim = Simulator(Params(Filament(segment_length=LENGTH / n)), Motor(1.6),
                    solver=SolverOptions(method=method))
    make = sim._stepper

    def keep():  # the stepper of each run, for its counters
        sim.last_stepper = make()
        return sim.last_stepper

    sim._stepper = keep
    w0 = time.perf_counter()
    sim.run(T_BUCKLE, save_every=1e-3, progress=False)
    wall_transient = time.perf_counter() - w0
    wall0, steps0 = sim.wall_seconds, sim.steps
    tr = sim.run(T_END, save_every=5e-4, progress=False)
    wall = sim.wall_seconds - wall0
    c1 = counters(sim)  # a new stepper per run: counts of this window only
    w = T_END - T_BUCKLE
    return {"segments": n, "method": method, "window": [T_BUCKLE, T_END],
            "wall_seconds": wall, "wall_per_simulated_second": wall / w,
            "steps": sim.steps - steps0,
            "counters": c1,
            "wall_transient_0_to_buckle": wall_transient,
            "thrust_mean": float(np.mean(tr.thrust))}


def exponent(ns, values) -> float:
    return float(np.polyfit(np.log(ns), np.log(values), 1)[0])


def main() -> None:
    B.warm_up()
    for n in NS:  # compile each size's shapes out of the timing (Numba types do not
        for m in ("cvode", "bdf"):  # depend on N, but the first call of each is timed)
            Simulator(Params(Filament(segment_length=LENGTH / n)), Motor(1.6),
                      solver=SolverOptions(method=m)).run(2e-4, save_every=1e-4, progress=False)
    out = {"load_average": B.load_average(), "quick": QUICK, "runs": []}
    t0 = time.time()
    for n in NS:
        for m in ("cvode", "bdf"):
            r = one(n, m)
            out["runs"].append(r)
            print(n, m, f"{r['wall_per_simulated_second']:.2f}", r["steps"], r["counters"],
                  flush=True)
            (HERE / ("bench_scaling_quick.json" if QUICK else "bench_scaling.json")).write_text(
                json.dumps(out, indent=1))
    for m in ("cvode", "bdf"):
        rs = [r for r in out["runs"] if r["method"] == m]
        ns = [r["segments"] for r in rs]
        out[f"exponent_wall_{m}"] = exponent(ns, [r["wall_per_simulated_second"] for r in rs])
        out[f"exponent_steps_{m}"] = exponent(ns, [r["steps"] for r in rs])
        out[f"exponent_wall_per_step_{m}"] = exponent(
            ns, [r["wall_seconds"] / r["steps"] for r in rs])
    out["load_average_end"] = B.load_average()
    out["wall_seconds"] = time.time() - t0
    (HERE / ("bench_scaling_quick.json" if QUICK else "bench_scaling.json")).write_text(
        json.dumps(out, indent=1))
    print(json.dumps({k: v for k, v in out.items() if k.startswith("exponent")}, indent=1))


if __name__ == "__main__":
    main()
