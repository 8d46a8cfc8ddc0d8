"""Timing of the sweep engine: a 32-point torque sweep of the paper's filament (docs/sweeps.md).

M from −2 to 6 pN·µm (32 values), N = 50, each point run to ``--time`` (default 0.3 s) on
the local process pool (all cores), target ≤ 10 minutes on the 2-core reference machine.
The default integrator is the fixed-step implicit scheme (``--method cvode`` to compare).

Prints one JSON object per line: one per point (torque, regime, thrust, σ, status, wall
seconds), then the total. Run (takes minutes):
OPENBLAS_NUM_THREADS=1 python benchmarks/bench_sweep.py [--quick] [--time T] [--method M]
    [--workers N] [--dask-local N] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

from flagellum.helix import Helix
from flagellum.params import Filament
from flagellum.sweep import Sweep, read_sweep, run_sweep

TARGET_SECONDS = 600.0


def emit(**row):
    print(json.dumps(row), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 points to 0.02 s (smoke test)")
    ap.add_argument("--time", type=float, default=0.3, help="simulated time per point [s]")
    ap.add_argument("--method", default="implicit", choices=["implicit", "cvode"])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--dask-local", type=int, default=None)
    ap.add_argument("--out", default=None, help="keep the dataset here (default: a temp dir)")
    args = ap.parse_args()
    n, t_end = (4, 0.02) if args.quick else (32, args.time)
    torques = [float(m) for m in np.linspace(-2.0, 6.0, n)]
    sweep = Sweep.create({"torque": torques}, {"time": t_end, "method": args.method})
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.out or Path(tmp) / "bench_sweep.nc")
        report = run_sweep(sweep, out, overwrite=True, workers=args.workers,
                           dask_local=args.dask_local, progress=True)
        d = read_sweep(out)
    sigma0 = Helix.from_filament(Filament()).radius / math.sqrt(2)
    for i, m in enumerate(torques):
        emit(torque=m, regime=d.data["regime"][i], thrust=d.data["thrust_mean"][i],
             sigma_over_sigma0=d.data["end_to_end_std"][i] / sigma0,
             steps=int(d.data["steps"][i]), wall_seconds=d.data["wall_seconds"][i],
             status=d.data["status"][i])
    regimes = {r: int(np.sum(d.data["regime"] == r)) for r in sorted(set(d.data["regime"]) - {""})}
    emit(case=f"torque sweep {n} points N=50 to {t_end} s ({args.method})",
         wall_seconds=report.wall_seconds, target_seconds=TARGET_SECONDS,
         ok=report.wall_seconds <= TARGET_SECONDS, points=report.points, failed=report.failed,
         regimes=regimes, workers=args.dask_local or args.workers or os.cpu_count(),
         cpu_seconds_in_points=float(np.nansum(d.data["wall_seconds"])))


if __name__ == "__main__":
    main()
