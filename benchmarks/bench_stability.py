"""Timing and resolution study of the linear stability analysis (docs/stability.md).

* ``critical-torque`` at N = 50 (anchored, free hook), target ≤ 20 s, through the CLI
  command (in-process) and the API;
* one ``linear_stability`` evaluation (continuation from the rigid helix included) and
  M_c1 at N = 25, 50, 100 (and 200 with ``--full``);
* λ(M) at N = 50 over the torques of the docs' table.

Prints one JSON object per line. Run:
OPENBLAS_NUM_THREADS=1 python benchmarks/bench_stability.py [--quick] [--full]
"""

from __future__ import annotations

import json
import sys
import time

from click.testing import CliRunner

from flagellum.analysis.stability import critical_torque, linear_stability
from flagellum.cli.stability import critical_torque as cli_critical_torque
from flagellum.params import Filament, Params

QUICK, FULL = "--quick" in sys.argv, "--full" in sys.argv
TARGET_SECONDS = 20.0


def emit(**row):
    print(json.dumps(row), flush=True)


def main():
    linear_stability(Params(Filament(segment_length=0.4)), 0.5)  # JIT warm-up, untimed
    t0 = time.perf_counter()
    r = CliRunner().invoke(cli_critical_torque, ["--json"])
    wall = time.perf_counter() - t0
    d = json.loads(r.output)
    emit(case="cli critical-torque N=50", wall_seconds=wall, target_seconds=TARGET_SECONDS,
         ok=wall <= TARGET_SECONDS, critical_torque=d["critical_torque"],
         critical_force=d["critical_force"], omega=d["omega"])
    if QUICK:
        return
    for h in (0.4, 0.2, 0.1) + ((0.05,) if FULL else ()):
        p = Params(Filament(segment_length=h))
        t0 = time.perf_counter()
        s = linear_stability(p, 1.0)
        t1 = time.perf_counter()
        c = critical_torque(p)
        emit(case="resolution", segments=p.filament.n_segments, segment_length=h,
             lambda_at_1=s.lambda_, seconds_one_lambda=t1 - t0,
             critical_torque=c.critical_torque, critical_force=c.critical_force,
             omega=c.omega, lab_frequency=c.lab_frequency, evaluations=c.evaluations,
             critical_torque_seconds=c.wall_seconds)
    for m in (-1.0, -0.5, -0.25, 0.1, 0.2, 0.25, 0.5, 0.75, 0.9, 1.0, 1.1, 1.2, 1.5):
        s = linear_stability(Params(), m)
        emit(case="lambda(M) N=50", torque=m, omega=s.omega, thrust=s.thrust, lambda_=s.lambda_,
             frequency=s.frequency, lab_frequency=s.lab_frequency)


if __name__ == "__main__":
    main()
