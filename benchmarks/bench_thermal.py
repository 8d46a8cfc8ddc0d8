"""Thermal (fixed-step BDF2) runs: wall time per simulated second, Newton iterations and
Jacobians per step, split (failed) steps.

Cases (all from rest, Δt = 5e-5 s, 200 records per window, seed 1):

* ``paper_M1``: the paper's filament, N = 50, M = 1 pN·µm, 0.05 s (the bench's thermal regime);
* ``soft_free``: a soft straight free filament (A = C = 0.05 pN·µm², actin-like bending
  rigidity; L = 4 µm, N = 20, ``anchor="free"`` without a body), M = 0, 0.02 s.

Usage: ``python benchmarks/bench_thermal.py [OUT.json]``; compare two versions of the
package by running it under each (``PYTHONPATH=…/src``), interleaved, on the same machine.
"""

from __future__ import annotations

import json
import os
import sys
import time

from flagellum import Filament, Params
from flagellum.integrate import brownian as B
from flagellum.motor import Boundary, Motor
from flagellum.simulator import Simulator, SolverOptions

CASES = {
    "paper_M1": (Params(), Boundary(), 1.0, 0.05),
    "soft_free": (Params(Filament(kappa0=0.0, tau0=0.0, bend_rigidity=0.05, twist_rigidity=0.05,
                                  length=4.0)), Boundary(anchor="free"), 0.0, 0.02),
}


def run(name: str, window: float | None = None) -> dict:
    params, boundary, torque, w = CASES[name]
    w = w if window is None else window
    made = []
    init = B.ImplicitStepper.__init__

    def keep(self, *a, **k):  # the simulator's stepper, for its counters
        init(self, *a, **k)
        made.append(self)

    split = B.ImplicitStepper._split_step
    n_split = [0]

    def count(self, *a, **k):
        n_split[0] += 1
        return split(self, *a, **k)

    B.ImplicitStepper.__init__, B.ImplicitStepper._split_step = keep, count
    try:
        sim = Simulator(params, Motor(torque), boundary, thermal=True, seed=1,
                        solver=SolverOptions(method="implicit"))
        t0 = time.perf_counter()
        sim.run(w, save_every=w / 200, progress=False)
        wall = time.perf_counter() - t0
    finally:
        B.ImplicitStepper.__init__, B.ImplicitStepper._split_step = init, split
    st = made[-1]
    return {"case": name, "window": w, "wall_per_simulated_second": wall / w, "steps": st.n_steps,
            "iterations_per_step": st.n_iter / st.n_steps, "jacobians_per_step": st.n_jac / st.n_steps,
            "split_steps": n_split[0]}


def main() -> None:
    for name in CASES:  # compile and warm up
        run(name, window=0.001)
    rows = [run(name) for name in CASES]
    out = {"rows": rows, "load_average": os.getloadavg()}
    text = json.dumps(out, indent=1)
    print(text)
    if len(sys.argv) > 1:
        with open(sys.argv[1], "w") as fh:
            fh.write(text + "\n")


if __name__ == "__main__":
    main()
