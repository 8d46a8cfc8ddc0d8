"""Cost of SBT against RFT on an E. coli-like cell, in one run on this machine
(docs/hydrodynamics.md, "Not done yet", "Cost").

    python benchmarks/bench_sbt_ecoli.py [--repeats 3] [--out benchmarks/bench_sbt_ecoli.json]

The paper's filament (N = 50) on a prolate spheroid 2.5 × 0.88 µm with a clamped hook:
deterministic with the E. coli motor law (CVODE, the cell's method) over 0.1 s and 0.2 s
from rest, and thermal at M = 1.3 pN·µm (the fixed-step scheme, seed 1) over 0.05 s. Each
model after an untimed 2-ms run; CPU seconds (``time.process_time``) and steps of each
repeat, and the ratio of the least CPU times.
"""

from __future__ import annotations

import argparse
import json
import time

from flagellum.bench import load_average
from flagellum.hydro.options import Hydrodynamics
from flagellum.motor import Boundary, Motor, MotorLaw
from flagellum.params import Params
from flagellum.simulator import Simulator, SolverOptions

CELL = Boundary(anchor="free", body_radius=0.44, body_aspect=2.5 / 0.88, hook="clamped")


def run(hydrodynamics, thermal: bool, window: float) -> dict:
    motor = Motor(1.3) if thermal else Motor(drive="law", law=MotorLaw.e_coli())
    sim = Simulator(Params(), motor, CELL, thermal=thermal, seed=1 if thermal else None,
                    solver=SolverOptions(method="implicit") if thermal else SolverOptions(),
                    hydrodynamics=hydrodynamics)
    cpu = time.process_time()
    sim.run(window, save_every=window / 100, progress=False)
    return {"cpu_s": time.process_time() - cpu, "steps": sim.steps}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default="benchmarks/bench_sbt_ecoli.json")
    a = ap.parse_args()
    out = {"load_before": load_average(), "cases": {}}
    for name, thermal, window in (("law_0.1s", False, 0.1), ("law_0.2s", False, 0.2),
                                  ("thermal_0.05s", True, 0.05)):
        for h in (None, Hydrodynamics("sbt")):
            run(h, thermal, 2e-3)
        reps = [{"rft": run(None, thermal, window), "sbt": run(Hydrodynamics("sbt"), thermal, window)}
                for _ in range(a.repeats)]
        best = {k: min(r[k]["cpu_s"] for r in reps) for k in ("rft", "sbt")}
        out["cases"][name] = {"window_s": window, "repeats": reps,
                              "ratio_best": best["sbt"] / best["rft"],
                              "ratios": [r["sbt"]["cpu_s"] / r["rft"]["cpu_s"] for r in reps]}
        print(name, round(out["cases"][name]["ratio_best"], 2),
              [round(x, 2) for x in out["cases"][name]["ratios"]], flush=True)
    out["load_after"] = load_average()
    with open(a.out, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
