"""Where the time goes in the buckled run (N = 50, M = 1.6 pN·µm from rest, 0.3 s, CVODE
rtol 1e-6), and what each hypothesis for its cost buys, measured without changing the
package (monkeypatched in this process only).

    python benchmarks/profile_buckled.py [--out benchmarks/profile_buckled.json]

1. counts per 0.1 s simulated: CVODE steps, right-hand sides, Jacobians, stops (advance
   calls), integrator restarts by cause (chart re-centred inside a chunk, chart re-centred at
   a record, frame adaptation, checkpoint), steps per motor revolution;
2. cProfile: self time grouped into scikit-sundae's Python layer, the rod kernels (Numba
   dispatch), the model's Python, the simulator loop, numpy and the rest;
3. variants, interleaved A B A B (four rounds): baseline; charts re-centred only at
   t·u < −0.95; frame adaptation off; chunks between chart checks 4× longer; records 10×
   sparser; the twist angles' absolute tolerance 100× looser; each with wall time relative
   to the baseline of the same round (median over rounds), steps, restarts
   and the error of the time averages against an rtol 1e-9 run.
"""

from __future__ import annotations

import argparse
import cProfile
import contextlib
import json
import math
import os
import pstats
import time

import numpy as np

import flagellum.simulator as simmod
from flagellum.bench import average_errors, load_average, warm_up
from flagellum.analysis.observables import summarize
from flagellum.integrate.cvode import CvodeStepper
from flagellum.motor import Motor
from flagellum.params import Params
from flagellum.rod.model import RodModel
from flagellum.simulator import Simulator, SolverOptions

TORQUE, WINDOW, BIN = 1.6, 0.3, 0.1
SAVE = WINDOW / 200


class Counters:
    """Class-level wrappers that count events with the simulated time they happen at."""

    def __init__(self):
        self.events: dict[str, list[float]] = {}
        self.reason = None
        self.t = 0.0

    def add(self, key, t=None):
        self.events.setdefault(key, []).append(self.t if t is None else t)

    @contextlib.contextmanager
    def installed(self):
        c = self
        rhs, jac, reset, advance = RodModel.rhs, CvodeStepper._jac, CvodeStepper.reset, CvodeStepper.advance
        rechart, adapt, checkpoint_flush = RodModel.rechart, Simulator._adapt_frame, Simulator._flush

        def rhs_w(self, t, y, *a, **k):
            c.t = t
            c.add("rhs", t)
            return rhs(self, t, y, *a, **k)

        def jac_w(self, t, y, yp, jj):  # scikit-sundae checks the signature
            c.add("jacobians", t)
            return jac(self, t, y, yp, jj)

        def reset_w(self, t0, y0):
            if hasattr(self, "_solver"):  # not the first initialisation
                c.add(f"restart_{c.reason or 'other'}", t0)
            c.reason = None
            return reset(self, t0, y0)

        def advance_w(self, t):
            c.add("stops", t)
            n = self.n_steps
            y = advance(self, t)
            c.events.setdefault("steps", []).extend([t] * (self.n_steps - n))
            return y

        def rechart_w(self, y, threshold=-0.5):
            moved = rechart(self, y, threshold=threshold)
            if moved:
                c.reason = c.reason or ("chart_in_chunk" if threshold == simmod.CHART_LIMIT
                                        else "chart_at_record")
            return moved

        def adapt_w(self, buf):
            changed = adapt(self, buf)
            if changed:
                c.reason = c.reason or "frame"
            return changed

        def flush_w(self, *a):
            c.reason = c.reason or "checkpoint"
            return checkpoint_flush(self, *a)

        patches = [(RodModel, "rhs", rhs_w), (CvodeStepper, "_jac", jac_w),
                   (CvodeStepper, "reset", reset_w), (CvodeStepper, "advance", advance_w),
                   (RodModel, "rechart", rechart_w), (Simulator, "_adapt_frame", adapt_w),
                   (Simulator, "_flush", flush_w)]
        olds = [(o, n, getattr(o, n)) for o, n, _ in patches]
        for o, n, f in patches:
            setattr(o, n, f)
        try:
            yield self
        finally:
            for o, n, f in olds:
                setattr(o, n, f)


def buckled_run(solver=None, save=SAVE):
    sim = Simulator(Params(), Motor(TORQUE), solver=solver or SolverOptions())
    tr = sim.run(WINDOW, save_every=save, progress=False)
    s = summarize(tr.t, tr.thrust, tr.motor_angle, tr.positions, tr.energy, 0.2)
    rev = abs(tr.motor_angle[-1] - tr.motor_angle[0]) / (2 * math.pi)
    return {"wall": sim.wall_seconds, "steps": sim.steps, "steps_per_revolution": sim.steps / rev,
            "thrust": s.thrust_mean, "omega": s.omega_mean, "chi": s.chi_mean}, tr


def counts():
    c = Counters()
    with c.installed():
        run, tr = buckled_run()
    bins = np.arange(0.0, WINDOW + 1e-9, BIN)
    per_bin = {k: np.histogram(v, bins)[0].tolist() for k, v in sorted(c.events.items())}
    ang = np.interp(bins, tr.t, tr.motor_angle)
    per_bin["revolutions"] = (np.diff(ang) / (2 * math.pi)).round(2).tolist()
    per_bin["steps_per_revolution"] = (np.array(per_bin["steps"]) / np.diff(ang) * 2 * math.pi).round(0).tolist()
    return {"bins_s": bins.tolist(), "per_bin": per_bin, "run": run}


def profile():
    pr = cProfile.Profile()
    pr.enable()
    buckled_run()
    pr.disable()
    st = pstats.Stats(pr)
    groups: dict[str, float] = {}
    top = []
    for (fname, line, func), (_, ncalls, tt, ct, _) in st.stats.items():
        if "sksundae" in fname:
            g = "sksundae (Python layer + SUNDIALS C under it)"
        elif "CPUDispatcher" in func or "numba" in fname:
            g = "numba dispatch"
        elif "flagellum/rod/kernels" in fname or "flagellum/integrate/banded" in fname:
            g = "rod kernels / banded (Numba)"
        elif "flagellum/rod" in fname:
            g = "rod model (Python)"
        elif "flagellum/integrate" in fname:
            g = "integrate/cvode callbacks (Python)"
        elif "flagellum/simulator" in fname or "flagellum/trajectory" in fname:
            g = "simulator loop, records"
        elif "numpy" in fname:
            g = "numpy (Python)"
        elif fname == "~":
            g = "builtins / C calls (" + ("numba kernels" if "built-in method" not in func else "other") + ")"
        else:
            g = "other Python"
        groups[g] = groups.get(g, 0.0) + tt
        top.append((tt, ncalls, f"{os.path.basename(fname)}:{line}:{func}"))
    total = sum(groups.values())
    top.sort(reverse=True)
    return {"total_self_seconds": total,
            "groups": {k: round(v / total, 3) for k, v in sorted(groups.items(), key=lambda x: -x[1])},
            "top": [{"self_s": round(t, 3), "calls": n, "function": f} for t, n, f in top[:20]]}


@contextlib.contextmanager
def variant(name):
    """One hypothesis, monkeypatched for the duration of a run."""
    undo = []
    if name == "chart_limit_-0.95":
        undo.append((simmod, "CHART_LIMIT", simmod.CHART_LIMIT))
        simmod.CHART_LIMIT = -0.95
        rechart = RodModel.rechart
        undo.append((RodModel, "rechart", rechart))
        RodModel.rechart = lambda self, y, threshold=-0.5: rechart(self, y, min(threshold, -0.95))
    elif name == "frame_adaptation_off":
        undo.append((Simulator, "_adapt_frame", Simulator._adapt_frame))
        Simulator._adapt_frame = lambda self, buf: False
    elif name == "atol_angles_x100":
        init = CvodeStepper.__init__
        undo.append((CvodeStepper, "__init__", init))

        def init_w(self, model, t0, y0, rtol=1e-6, atol=1e-8, *a, **k):
            init(self, model, t0, y0, rtol, atol, *a, **k)
            vec = np.full(len(y0), float(atol))
            vec[6::4] *= 100.0  # the twist angles (state: 3 + (x, y, z, φ) per bead)
            self.atol = vec
            self.reset(self.t, self.y)
        CvodeStepper.__init__ = init_w
    elif name == "chunk_x4":
        undo.append((Simulator, "_advance", Simulator._advance))

        def advance4(self, stepper, t_target):
            # Simulator._advance for CVODE and a local mobility, with 4× longer chunks
            rate = max(abs(self.model.omega_frame), 100.0)
            if self._last_motor is not None:
                rate = max(rate, min(abs(self._last_motor[3]), 3.0 * self._omega_scale))
            chunk = 2.0 / rate
            y = stepper.y
            while stepper.t < t_target:
                t_next = min(t_target, stepper.t + chunk)
                if t_target - t_next < 0.25 * chunk:
                    t_next = t_target
                y = stepper.advance(t_next)
                if t_next < t_target and self.model.rechart(y, threshold=simmod.CHART_LIMIT):
                    stepper.reset(t_next, y)
            return y
        Simulator._advance = advance4
    try:
        yield
    finally:
        for obj, attr, old in reversed(undo):
            setattr(obj, attr, old)


VARIANTS = ("baseline", "chart_limit_-0.95", "frame_adaptation_off", "chunk_x4", "records_x0.1",
            "atol_angles_x100")


def hypotheses(rounds=2):
    ref, _ = buckled_run(SolverOptions(rtol=1e-9))
    rows = {v: [] for v in VARIANTS}
    for r in range(rounds):  # interleaved: A B C … A B C …
        for v in VARIANTS:
            c = Counters()
            with variant(v), c.installed():
                run, _ = buckled_run(save=SAVE * 10 if v == "records_x0.1" else SAVE)
            run["restarts"] = sum(len(x) for k, x in c.events.items() if k.startswith("restart"))
            run["stops"] = len(c.events.get("stops", []))
            run.update(average_errors(run, ref))
            rows[v].append(run)
    out = {}
    for v, runs in rows.items():
        ratio = [a["wall"] / b["wall"] for a, b in zip(runs, rows["baseline"])]
        out[v] = {"wall_ratio_median": round(float(np.median(ratio)), 3),
                  "wall_ratio_to_baseline": [round(x, 3) for x in ratio],
                  "wall_s": [round(a["wall"], 3) for a in runs],
                  **{k: runs[0][k] for k in ("steps", "steps_per_revolution", "restarts", "stops",
                                               "error", "thrust_error", "omega_error", "chi_error")}}
    return {"reference_rtol": 1e-9, "variants": out}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/profile_buckled.json")
    ap.add_argument("--rounds", type=int, default=4)
    args = ap.parse_args()
    warm_up()
    res = {"load_average_start": load_average(), "started": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    res["counts"] = counts()
    print(json.dumps(res["counts"], indent=1), flush=True)
    res["profile"] = profile()
    print(json.dumps(res["profile"], indent=1), flush=True)
    res["hypotheses"] = hypotheses(args.rounds)
    print(json.dumps(res["hypotheses"], indent=1), flush=True)
    res["load_average_end"] = load_average()
    with open(args.out, "w") as f:
        json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
