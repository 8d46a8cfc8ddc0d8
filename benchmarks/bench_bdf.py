"""The Numba BDF against CVODE on the same work (docs/benchmarks.md, docs/numerics.md).

Every deterministic regime of :data:`flagellum.bench.REGIMES` (N = 50, from rest), one
process, one machine state: a CVODE rtol = 1e-10 reference and its check at 1e-9, then
CVODE and the Numba BDF over rtol, interleaved setting by setting (so that a change of the
machine's load shifts both alike). Each run: wall seconds per simulated second, steps, the
error of the time-averaged thrust, ω and χ (last half) against the reference (a run that
fails is recorded with its message). Writes
``benchmarks/bench_bdf.json`` and the work–precision diagram ``docs/img/work_precision_bdf.png``.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_bdf.py [--quick] [regime ...]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from flagellum import bench as B
from flagellum.errors import SimulationError

QUICK = "--quick" in sys.argv
NAMES = [a for a in sys.argv[1:] if not a.startswith("--")] or [
    k for k, v in B.REGIMES.items() if not v[3]]
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)
HERE = Path(__file__).parent


def main() -> None:
    B.warm_up()
    t_start = time.time()
    out = {"load_average": B.load_average(), "quick": QUICK, "regimes": {}}
    for name in NAMES:
        w = B.REGIMES[name][1] * (0.25 if QUICK else 1.0)
        ref = B.run_regime(name, B._solver("cvode", B.REFERENCE_RTOL), w)
        chk = B.run_regime(name, B._solver("cvode", B.CHECK_RTOL), w)
        rows = []
        for rtol in RTOLS:
            for kind in ("cvode", "bdf"):
                try:
                    r = B.run_regime(name, B._solver(kind, rtol), w)
                except SimulationError as exc:  # reported, not plotted
                    rows.append({"method": kind, "rtol": rtol, "failed": str(exc)})
                    print(name, kind, rtol, "failed:", exc, flush=True)
                    continue
                rows.append({"method": kind, "rtol": rtol, **r, **B.average_errors(r, ref)})
                print(name, kind, rtol, f"{r['wall_per_simulated_second']:.3f}",
                      f"{rows[-1]['error']:.2e}", r["steps"], flush=True)
        out["regimes"][name] = {"window": w, "reference": ref,
                                "reference_check": B.average_errors(chk, ref)["error"],
                                "runs": rows}
        (HERE / ("bench_bdf_quick.json" if QUICK else "bench_bdf.json")).write_text(
            json.dumps(out, indent=1))  # after each regime: a partial run is kept
    out["load_average_end"] = B.load_average()
    out["wall_seconds"] = time.time() - t_start
    (HERE / ("bench_bdf_quick.json" if QUICK else "bench_bdf.json")).write_text(
        json.dumps(out, indent=1))
    if not QUICK:
        B.plot_work_precision(out["regimes"], HERE.parent / "docs" / "img" / "work_precision_bdf.png")


if __name__ == "__main__":
    main()
