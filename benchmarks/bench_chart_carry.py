"""The Numba BDF with its history carried through chart changes and frame-rate changes
against restarting it there (docs/benchmarks.md, "Carrying the BDF history").

One process, the two variants (:data:`flagellum.simulator.CARRY_HISTORY` off / on) run
alternately (off, on, on, off, …) on the unsteady regimes of :data:`flagellum.bench.REGIMES`
(N = 50, from rest, default method and rtol), each against a CVODE rtol = 1e-10 reference
over the same window (:func:`flagellum.bench.average_errors`: thrust, ω, χ over the last
half); then the whirling lab-frame load-sphere run of Fig. 5 (a = 1/3 µm, M = 4.373 pN·µm,
step protocol, 0.4 s; tests/test_step_limit.py) with each variant. Per run: wall and CPU
seconds, steps, the stepper's counters (Jacobians, factorizations, right-hand sides,
starts), restarts and carries. Writes ``benchmarks/bench_chart_carry.json``.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_chart_carry.py [--rounds R] [regime ...]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from flagellum import bench as B
from flagellum import simulator as S
from flagellum.integrate import bdf
from flagellum.motor import Boundary, Motor
from flagellum.params import Params

ARGS = sys.argv[1:]
ROUNDS = int(ARGS[ARGS.index("--rounds") + 1]) if "--rounds" in ARGS else 2
NAMES = [a for a in ARGS if not a.startswith("--") and not a.isdigit()] or [
    "buckled_M1.6", "M3", "oscillating_M5", "from_rest_M1"]
HERE = Path(__file__).parent
COUNTS = {"reset": 0, "carry": 0}
STEPPERS = []


def _counting():
    """Count the BDF's restarts and carries, and keep the steppers the simulator makes."""
    reset, carry, make = bdf.BdfStepper.reset, bdf.BdfStepper.carry, S.Simulator._stepper

    def counted_reset(self, *a, **k):
        COUNTS["reset"] += 1
        return reset(self, *a, **k)

    def counted_carry(self, *a, **k):
        COUNTS["carry"] += 1
        return carry(self, *a, **k)

    def kept(self):
        st = make(self)
        STEPPERS.append(st)
        return st

    bdf.BdfStepper.reset, bdf.BdfStepper.carry, S.Simulator._stepper = (
        counted_reset, counted_carry, kept)


def _run(fn, carry: bool) -> dict:
    S.CARRY_HISTORY = carry
    COUNTS.update(reset=0, carry=0)
    STEPPERS.clear()
    r = fn()
    stats = getattr(STEPPERS[-1], "stats", {}) if STEPPERS else {}
    return {**r, "carry": carry, "restarts": COUNTS["reset"], "carries": COUNTS["carry"],
            "stats": stats}


def fig5_case(t_end: float = 0.4) -> dict:
    M = 4.373
    motor = Motor(M, schedule=((0.0, 1.0), (0.05, 1.0), (0.06, M)))
    sim = S.Simulator(Params(), motor, Boundary(anchor="sphere", sphere_radius=1 / 3),
                      solver=S.SolverOptions(method="bdf", frame="lab"))
    cpu0 = time.process_time()
    tr = sim.run(t_end, save_every=t_end / 200, progress=False)
    return {"reached": float(tr.t[-1]), "wall_seconds": sim.wall_seconds,
            "cpu_seconds": time.process_time() - cpu0, "steps": sim.steps,
            "thrust": float(tr.thrust[len(tr.t) // 2:].mean())}


def main() -> None:
    _counting()
    B.warm_up()
    for carry in (False, True):  # compile both paths
        _run(lambda: B.run_regime("buckled_M1.6", window=0.003), carry)
    out = {"load_average": B.load_average(), "rounds": ROUNDS, "regimes": {}}
    t_start = time.time()
    path = HERE / "bench_chart_carry.json"
    for name in NAMES:
        w = B.REGIMES[name][1]
        ref = B.run_regime(name, B._solver("cvode", B.REFERENCE_RTOL), w)
        rows = []
        for k in range(ROUNDS):
            for carry in ((False, True) if k % 2 == 0 else (True, False)):
                r = _run(lambda: B.run_regime(name), carry)
                r.update(B.average_errors(r, ref))
                rows.append(r)
                print(name, carry, f"wall {r['wall_seconds']:.2f} cpu {r['cpu_seconds']:.2f}",
                      r["steps"], f"err {r['error']:.2e}", r["restarts"], r["carries"], flush=True)
        out["regimes"][name] = {"window": w, "reference": ref, "runs": rows}
        path.write_text(json.dumps(out, indent=1))
    rows = []
    for carry in (False, True):
        r = _run(fig5_case, carry)
        rows.append(r)
        print("fig5", carry, r, flush=True)
    out["fig5_whirling_lab_frame"] = rows
    out["load_average_end"] = B.load_average()
    out["wall_seconds"] = time.time() - t_start
    path.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
