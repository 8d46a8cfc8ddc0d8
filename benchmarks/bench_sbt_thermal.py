"""Cost of a thermal run with the nonlocal mobility against local RFT, measured in one run on
this machine (docs/hydrodynamics.md, "Thermal cost").

    python benchmarks/bench_sbt_thermal.py [--window 0.05] [--repeats 2] [--out benchmarks/bench_sbt_thermal.json]

Regimes, N = 50, M = 1 pN·µm, the drift-implicit scheme at its default Δt, seed 1, from rest:
the anchored filament (``thermal_M1`` of flagellum.bench), the same on a load sphere
(a = 1 µm) and as a free swimmer with a sphere (a = 0.5 µm), and a whole cell (free body,
a = 1 µm; its thermal mobility kept and turned with the cell). Each is run with RFT, with SBT
renewed at every step (``refresh`` 0) and with SBT at the default ``refresh`` (the mobility,
its factor and the Itô drift kept between renewals), after an untimed 2-ms run of each.
CPU seconds (``time.process_time``) of the whole ``Simulator.run``, its steps, and the
renewals of the thermal mobility (the steppers' ``n_renewals``); ratios to the RFT run of the
same repeat, and of the best (least) CPU time of each model over the repeats (the machine's
noise only ever adds time).
"""

from __future__ import annotations

import argparse
import json
import platform
import time

from flagellum.bench import load_average
from flagellum.hydro.options import REFRESH, Hydrodynamics
from flagellum.integrate import brownian as BR
from flagellum.motor import Boundary, Motor
from flagellum.params import Params
from flagellum.simulator import Simulator, SolverOptions

BOUNDARIES = {
    "anchored": Boundary(),
    "load_sphere": Boundary(anchor="sphere", sphere_radius=1.0),
    "free_swimmer": Boundary(anchor="free", sphere_radius=0.5),
    "cell": Boundary(anchor="free", body_radius=1.0),
}
MODELS = {"rft": Hydrodynamics(), "sbt_every_step": Hydrodynamics("sbt", refresh=0.0),
          "sbt": Hydrodynamics("sbt", refresh=REFRESH)}

STEPPERS: list = []
_init = BR.ImplicitStepper.__init__


def _spy(self, *a, **k):
    _init(self, *a, **k)
    STEPPERS.append(self)


BR.ImplicitStepper.__init__ = _spy


def run(boundary: Boundary, hyd: Hydrodynamics, window: float) -> dict:
    STEPPERS.clear()
    sim = Simulator(Params(), Motor(1.0), boundary, thermal=True, seed=1, hydrodynamics=hyd,
                    solver=SolverOptions(method="implicit"))
    c0, w0 = time.process_time(), time.perf_counter()
    sim.run(window, progress=False)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    steps = sum(s.n_steps for s in STEPPERS)
    renewals = sum(s.n_renewals for s in STEPPERS)
    return {"cpu_s": cpu, "wall_s": wall, "steps": steps, "renewals": renewals,
            "ms_per_step": 1e3 * cpu / max(steps, 1)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--window", type=float, default=0.05)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--regimes", nargs="*", default=list(BOUNDARIES))
    ap.add_argument("--out", default="benchmarks/bench_sbt_thermal.json")
    a = ap.parse_args()
    out = {"machine": platform.processor() or platform.machine(), "load_before": load_average(),
           "window_s": a.window, "refresh_um": REFRESH, "thermal_turn": BR.THERMAL_TURN,
           "regimes": {}}
    for name in a.regimes:
        for hyd in MODELS.values():
            run(BOUNDARIES[name], hyd, 0.002)
        rows = []
        for _ in range(a.repeats):
            r = {k: run(BOUNDARIES[name], hyd, a.window) for k, hyd in MODELS.items()}
            for k in ("sbt_every_step", "sbt"):
                r[k]["ratio_to_rft"] = r[k]["cpu_s"] / r["rft"]["cpu_s"]
                r[k]["steps_per_renewal"] = r[k]["steps"] / max(r[k]["renewals"], 1)
            rows.append(r)
            print(name, {k: (round(v["ms_per_step"], 3), round(v.get("ratio_to_rft", 1.0), 2),
                             round(v.get("steps_per_renewal", 0.0), 2)) for k, v in r.items()},
                  flush=True)
        best = {k: min(r[k]["cpu_s"] for r in rows) for k in MODELS}
        summary = {k: {"best_ms_per_step": 1e3 * best[k] / max(rows[0][k]["steps"], 1),
                       "best_ratio_to_rft": best[k] / best["rft"],
                       "ratios": [r[k].get("ratio_to_rft", 1.0) for r in rows]}
                   for k in MODELS}
        print(name, "best of", a.repeats, {k: round(v["best_ratio_to_rft"], 2)
                                          for k, v in summary.items()}, flush=True)
        out["regimes"][name] = {"repeats": rows, "summary": summary}
    out["load_after"] = load_average()
    with open(a.out, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
