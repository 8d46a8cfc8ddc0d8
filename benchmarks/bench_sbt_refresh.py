"""Accuracy and cost of the frozen splitting against the refresh distance, in the regimes of
``flagellum bench --sbt-regimes`` (docs/hydrodynamics.md, "Cost against RFT").

    python benchmarks/bench_sbt_refresh.py [--refresh 0.02 0.05 0.1] [--names ...] [--quick]
        [--out benchmarks/bench_sbt_refresh.json]

Per regime (N = 50, from rest, the windows of flagellum.bench.REGIMES): the RFT run and the
SBT runs at each refresh distance at their default method (the Numba BDF), one after the
other, with CPU seconds and the SBT/RFT ratio, and the error of the time-averaged thrust, ω
and χ (flagellum.bench.average_errors) against the unfrozen SBT run (refresh 0: ΔM rebuilt
at every right-hand side; CVODE, rtol 1e-8).
"""

from __future__ import annotations

import argparse
import json

from flagellum.bench import (REGIMES, SBT_REGIMES, _solver, average_errors, load_average, run_regime,
                             warm_up_regimes)
from flagellum.hydro.options import Hydrodynamics


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refresh", type=float, nargs="+", default=[0.02, 0.05, 0.1])
    ap.add_argument("--names", nargs="+", default=list(SBT_REGIMES))
    ap.add_argument("--quick", action="store_true", help="windows a quarter as long")
    ap.add_argument("--out", default="benchmarks/bench_sbt_refresh.json")
    a = ap.parse_args(argv)
    warm_up_regimes(a.names, (None, Hydrodynamics("sbt")))
    out = {"load_average_before": load_average(), "regimes": {}}
    for name in a.names:
        w = REGIMES[name][1] * (0.25 if a.quick else 1.0)
        ref = run_regime(name, _solver("cvode", 1e-8), w, hydrodynamics=Hydrodynamics("sbt", refresh=0.0))
        row = {"window": w, "reference": ref, "runs": []}
        for r in a.refresh:
            rft = run_regime(name, window=w)
            sbt = run_regime(name, window=w, hydrodynamics=Hydrodynamics("sbt", refresh=r))
            row["runs"].append({"refresh": r, "rft": rft, "sbt": sbt,
                                "cpu_ratio": sbt["cpu_seconds"] / rft["cpu_seconds"],
                                **average_errors(sbt, ref)})
            print(name, r, json.dumps({k: v for k, v in row["runs"][-1].items() if k not in ("rft", "sbt")}),
                  "cpu", sbt["cpu_seconds"], rft["cpu_seconds"], flush=True)
        out["regimes"][name] = row
        out["load_average_after"] = load_average()
        with open(a.out, "w") as f:
            json.dump(out, f, indent=1)
    return out


if __name__ == "__main__":
    main()
