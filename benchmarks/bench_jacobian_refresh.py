"""Why the Numba BDF renews its Jacobian in the buckled regime, against N (docs/benchmarks.md,
"Jacobian refreshes in the buckled run").

The buckled run (M = 1.6 pN·µm from the helix at rest, L = 10 µm, N = 50, 100, 200, 400) is
taken once to t = 0.2 s with the default BDF; from that state the window 0.2–0.25 s is run
with each variant of the Jacobian policy and the stepper's counters are reported: Jacobians
renewed at a (re)start, after the kept Jacobian's Newton iteration diverged or ran out of
iterations, their mean age in steps, factorizations, right-hand sides, steps, and the
window's mean thrust. Variants (the BDF loop recompiled from its own bytecode with other
policy constants, :data:`flagellum.integrate.bdf.STALE_MAXITER` and ``PROBE``):

* ``default`` — the stepper as shipped (kept until Newton fails with it, as CVODE and scipy);
* ``ahead4`` — after a failure with a kept Jacobian, renew it before the Newton iteration in
  the next 4 steps (``PROBE = 4``), saving the doomed first attempt;
* ``iter5`` — with a kept Jacobian up to 5 Newton iterations while the rate is below 0.5
  (``STALE_MAXITER = 5``);
* ``lab`` — the default stepper in the lab frame (``frame="lab"``) instead of the co-rotating one.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_jacobian_refresh.py [--quick]
(``--quick``: N = 50, 100). Writes benchmarks/bench_jacobian_refresh.json.
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
from flagellum.motor import Motor
from flagellum.params import Filament, Params
from flagellum.simulator import Simulator, SolverOptions

QUICK = "--quick" in sys.argv
NS = (50, 100) if QUICK else (50, 100, 200, 400)
T0, T1, LENGTH = 0.2, 0.25, 10.0
HERE = Path(__file__).parent
VARIANTS = {"default": {}, "ahead4": {"PROBE": 4}, "iter5": {"STALE_MAXITER": 5}, "lab": {}}
SHIPPED = B.bdf_advance


def compiled(consts: dict):
    if not consts:
        return SHIPPED
    f = SHIPPED.py_func
    return njit(types.FunctionType(f.__code__, dict(f.__globals__, **consts), f.__name__))


def window(n: int, state, name: str) -> dict:
    st, t, om = state
    lab = name == "lab"
    sim = Simulator.from_state(st, Params(Filament(segment_length=LENGTH / n)), Motor(1.6), t=t,
                               omega_frame=0.0 if lab else om,
                               solver=SolverOptions(method="bdf", frame="lab" if lab else "auto"))
    make = sim._stepper
    made = []
    sim._stepper = lambda: made.append(make()) or made[-1]
    w0 = time.perf_counter()
    tr = sim.run(T1, save_every=5e-4, progress=False)
    wall = time.perf_counter() - w0
    stats: dict = {}
    for s in made:  # a new stepper per run (restarts reset it): sum their counters
        for k, v in s.stats.items():
            stats[k] = stats.get(k, 0) + v
    renewed = stats["jacobians_after_divergence"] + stats["jacobians_after_max_iterations"]
    return {"segments": n, "variant": name, "wall_per_simulated_second": wall / (T1 - T0),
            **stats, "jacobians_per_step": stats["jacobians"] / stats["steps"],
            "mean_age_of_renewed_jacobians": stats["jacobian_age_steps"] / max(renewed, 1),
            "thrust_mean": float(np.mean(tr.thrust))}


def main() -> None:
    FB.warm_up()
    kernels = {k: compiled(v) for k, v in VARIANTS.items()}
    out = {"load_average": FB.load_average(), "window": [T0, T1], "runs": []}
    for n in NS:
        sim = Simulator(Params(Filament(segment_length=LENGTH / n)), Motor(1.6),
                        solver=SolverOptions(method="bdf"))
        sim.run(T0, save_every=1e-3, progress=False)
        state = (sim.state(), sim.t, sim.model.omega_frame)
        for name in VARIANTS:
            B.bdf_advance = kernels[name]
            try:
                if n == NS[0]:  # compile the variant out of the timing
                    window(n, (state[0], state[1], state[2]), name)
                r = window(n, state, name)
            finally:
                B.bdf_advance = SHIPPED
            out["runs"].append(r)
            print(json.dumps(r), flush=True)
            (HERE / "bench_jacobian_refresh.json").write_text(json.dumps(out, indent=1))
    out["load_average_end"] = FB.load_average()
    (HERE / "bench_jacobian_refresh.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
