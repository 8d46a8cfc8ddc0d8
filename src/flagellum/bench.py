"""Speed benchmarks (``flagellum bench``): wall time per simulated second, measured here.

* ``steady``: anchored filament, N = 50, M = 1 pN·µm, in steady rotation: after a warm-up
  (untimed) the default solver runs a window of ``window`` simulated seconds; the thrust is
  compared with a tight-tolerance (rtol = 1e-10) run over the same window.
* ``from_rest``: the same from the helix at rest (transient included).
* ``scaling``: N = 50 … 400 (L fixed): cost per simulated second in steady rotation
  (started from the relative equilibrium), and the cost of one step (from rest).
* ``brownian``: thermal run at N = 50 with the drift-implicit scheme, M = 1, over 0.1
  simulated s after a 2-ms ramp (long enough that the fixed cost of starting a run,
  ≈ 15 ms, adds < 3 %).
"""

from __future__ import annotations

import time

import numpy as np

from .motor import Motor
from .params import Filament, Params
from .simulator import Simulator, SolverOptions, State


def _timed(sim: Simulator, t_end: float, save_every: float):
    w0, s0 = sim.wall_seconds, sim.steps
    tr = sim.run(t_end, save_every=save_every, progress=False)
    return tr, sim.wall_seconds - w0, sim.steps - s0


def steady_state(torque: float = 1.0, params: Params | None = None, warmup: float = 0.05) -> Simulator:
    """A simulator started from the relative equilibrium (steady rotation), warmed up briefly."""
    from .analysis.stability import relative_equilibrium

    params = params or Params()
    eq = relative_equilibrium(params, torque)
    sim = Simulator.from_state(State(eq.state, eq.charts), params, Motor(torque), omega_frame=eq.omega)
    sim.run(warmup, save_every=warmup / 50, progress=False)
    return sim


def bench(window: float = 0.2, quick: bool = False) -> dict:
    """Run all benchmarks; returns the JSON-ready dict."""
    out: dict = {"segments": 50, "torque": 1.0, "window": window}
    sim = steady_state(1.0)
    t0, start, frame0 = sim.t, sim.state(), sim.model.omega_frame
    tr, wall, steps = _timed(sim, t0 + window, window / 100)
    ref = Simulator.from_state(start, Params(), Motor(1.0), t=t0, omega_frame=frame0,
                               solver=SolverOptions(rtol=1e-10, atol=1e-12))
    ref_tr = ref.run(t0 + window, save_every=window / 100, progress=False)
    out.update(wall_per_simulated_second=wall / window, steps=steps,
               thrust=float(np.mean(tr.thrust)),
               thrust_error=float(np.abs(tr.thrust - ref_tr.thrust).max()),
               reference_wall_per_simulated_second=ref.wall_seconds / window)
    # from rest, co-rotating frame and lab frame
    for key, frame in (("from_rest", "auto"), ("from_rest_lab_frame", "lab")):
        s = Simulator(Params(), Motor(1.0), solver=SolverOptions(frame=frame))
        w = 0.05 if quick else 0.1
        _, wall, steps = _timed(s, w, w / 50)
        out[key] = {"wall_per_simulated_second": wall / w, "steps": steps}
    scaling = []
    for n in (50, 100) if quick else (50, 100, 200, 400):
        p = Params(Filament(segment_length=10.0 / n))
        s = steady_state(1.0, p, warmup=0.01)
        w = 0.02 if quick else 0.05
        _, wall, steps = _timed(s, s.t + w, w / 10)
        r = Simulator(p, Motor(1.0))  # from rest: many steps, for the cost of one step
        _, wall_r, steps_r = _timed(r, 0.002, 0.001)
        scaling.append({"segments": n, "wall_per_simulated_second": wall / w, "steps": steps,
                        "from_rest_microseconds_per_step": 1e6 * wall_r / max(steps_r, 1),
                        "from_rest_microseconds_per_step_per_segment":
                            1e6 * wall_r / max(steps_r, 1) / n})
    out["scaling"] = scaling
    opts = SolverOptions(method="implicit")
    b = Simulator(Params(), Motor(1.0, ramp_time=0.002), thermal=True, seed=1, solver=opts)
    b.run(0.002, save_every=0.001, progress=False)
    w = 0.02 if quick else 0.1
    _, wall, steps = _timed(b, 0.002 + w, w / 10)
    out["brownian"] = {"segments": 50, "dt": opts.dt, "wall_per_simulated_second": wall / w,
                       "steps": steps}
    return out


def main_timing() -> float:
    """Whole-process helper for farm-bench: one warm steady-state window, returns wall."""
    t = time.perf_counter()
    bench(quick=True)
    return time.perf_counter() - t
