"""Cost of the nonlocal mobility (``--hydrodynamics sbt``) against local RFT, measured in one
run on this machine (docs/hydrodynamics.md, "Cost").

    python benchmarks/bench_sbt.py [--n 50 100 200 400] [--torques 1 2] [--window 0.02] [--out benchmarks/bench_sbt.json]

For each N (L = 10 µm, h = 10 µm/N; anchored filament, CVODE rtol 1e-6, co-rotating frame)
and each regime — aligned M = 1 pN·µm, buckled M = 2 pN·µm (above M_c1 of both models) —
the run starts from the pinned helix, is warmed up over ``warmup`` simulated seconds
(untimed), then timed over ``window``, each model at its default method (the Numba BDF):
CPU and wall seconds per simulated second, steps, right-hand sides, rebuilds of ΔM
(``correction`` calls and the steppers' compiled renewals, each timed as one build at the
final state) and their share of the time, and the SBT/RFT ratio of the same run. CPU time (``time.process_time``) is the one to read on a
shared machine. Then the stability analysis: M_c1 of the anchored filament (N = 50) with
each model, and a lab-frame run at rtol 1e-8 (which the rebuild jumps used to break).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import flagellum.rod.model as rod_model
from flagellum.bench import load_average
from flagellum.hydro.options import Hydrodynamics
from flagellum.motor import Motor
from flagellum.params import Filament, Params
from flagellum.simulator import Simulator, SolverOptions

COUNT = {"builds": 0, "build_s": 0.0}
_correction = rod_model.correction


def _counted_correction(*a, **k):
    t0 = time.process_time()
    out = _correction(*a, **k)
    COUNT["builds"] += 1
    COUNT["build_s"] += time.process_time() - t0
    return out


rod_model.correction = _counted_correction


def timed_run(n: int, torque: float, model: str, warmup: float, window: float, frame="auto",
              rtol=1e-6, method=None) -> dict:
    p = Params(Filament(segment_length=10.0 / n))
    sim = Simulator(p, Motor(torque), hydrodynamics=Hydrodynamics(model),
                    solver=SolverOptions(rtol=rtol, frame=frame, method=method))
    steppers = []
    make = sim._stepper

    def spy():  # the stepper of each chunk of records: its counters (the BDF's)
        steppers.append(make())
        return steppers[-1]

    sim._stepper = spy
    if warmup > 0:
        sim.run(warmup, save_every=warmup / 10, progress=False)
    for k in COUNT:
        COUNT[k] = 0
    steppers.clear()
    c0, w0, s0, t0 = time.process_time(), time.perf_counter(), sim.steps, sim.t
    tr = sim.run(t0 + window, save_every=window / 20, progress=False)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    rhs = sum(st.stats["rhs"] for st in steppers) if all(hasattr(st, "stats") for st in steppers) else None
    # the steppers' renewals of ΔM are compiled calls (not `correction`): counted by the
    # frozen mobility, each timed as one build at the final state
    renewals = sum(st._frozen.renewals for st in steppers if hasattr(st, "_frozen"))
    build_s = COUNT["build_s"] + renewals * _unit_build(sim.model, sim.y)
    return {"n": n, "torque": torque, "model": model, "method": sim.solver.method,
            "cpu_per_simulated_second": cpu / window,
            "wall_per_simulated_second": wall / window, "steps": sim.steps - s0,
            "rhs": rhs, "rebuilds": COUNT["builds"] + renewals,
            "rebuild_share": build_s / cpu if cpu else 0.0,
            "thrust_over_torque": float(np.mean(tr.thrust) / torque)}


def _unit_build(m, y) -> float:
    """CPU seconds of one compiled build of ΔM at state y (0 for the local model)."""
    if m.hydrodynamics.is_local:
        return 0.0
    from flagellum.hydro.dynamics import _correction_into
    from flagellum.rod.model import positions

    x = np.ascontiguousarray(positions(y))
    dm, args = np.empty_like(m.kernel_arrays[-1][-1]), m.build_arguments()
    _correction_into(x, *args, dm)
    k = max(5, int(0.2 / max(1e-6, 4e-8 * len(x) ** 2)))
    c0 = time.process_time()
    for _ in range(k):
        _correction_into(x, *args, dm)
    return (time.process_time() - c0) / k


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[50, 100, 200, 400])
    ap.add_argument("--window", type=float, default=0.02)
    ap.add_argument("--warmup", type=float, default=0.02)
    ap.add_argument("--no-stability", action="store_true")
    ap.add_argument("--no-lab", action="store_true", help="skip the lab-frame run and the stability analysis")
    ap.add_argument("--only-stability", action="store_true")
    ap.add_argument("--torques", type=float, nargs="+", default=[1.0, 2.0])
    ap.add_argument("--out", default="benchmarks/bench_sbt.json")
    a = ap.parse_args(argv)
    timed_run(20, 1.0, "sbt", 0.0, 0.001)  # compile everything first
    timed_run(20, 1.0, "rft", 0.0, 0.001)
    out: dict = {"load_average_before": load_average(), "window": a.window, "warmup": a.warmup,
                 "runs": []}
    for n in ([] if a.only_stability else a.n):
        for torque in a.torques:
            pair = {m: timed_run(n, torque, m, a.warmup, a.window) for m in ("rft", "sbt")}
            pair["sbt"]["cpu_ratio_to_rft"] = (pair["sbt"]["cpu_per_simulated_second"]
                                               / pair["rft"]["cpu_per_simulated_second"])
            out["runs"] += [pair["rft"], pair["sbt"]]
            print(json.dumps(pair["sbt"]), flush=True)
            _save(a.out, out)
    if a.no_lab:
        return _save(a.out, out)
    if not a.only_stability:
        try:
            out["lab_frame_rtol_1e-8"] = timed_run(50, 1.0, "sbt", 0.0, 0.01, frame="lab", rtol=1e-8)
        except Exception as exc:  # noqa: BLE001 - a benchmark reports failures
            out["lab_frame_rtol_1e-8"] = {"error": str(exc)}
        print(json.dumps(out["lab_frame_rtol_1e-8"]), flush=True)
    if not a.no_stability:
        from flagellum.analysis.stability import critical_torque

        for model in ("rft", "sbt"):
            c0, w0 = time.process_time(), time.perf_counter()
            ct = critical_torque(Params(), hydrodynamics=Hydrodynamics(model))
            out[f"critical_torque_{model}"] = {
                "M_c1": ct.critical_torque, "F_c1": ct.critical_force,
                "cpu_seconds": time.process_time() - c0, "wall_seconds": time.perf_counter() - w0}
            print(model, json.dumps(out[f"critical_torque_{model}"]), flush=True)
    return _save(a.out, out)


def _save(path: str, out: dict) -> dict:
    out["load_average_after"] = load_average()
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    return out


if __name__ == "__main__":
    main()
