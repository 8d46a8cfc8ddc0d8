"""Compare stiff integrators on the same problem (docs/numerics.md).

Problem: anchored filament, N = 50, M = 1 pN·µm, from the helix at rest, 0.05 s, in the
lab frame and in a frame co-rotating at Ω = 845 rad/s. Reported: wall seconds per simulated
second, and the largest thrust deviation from a CVODE rtol = 1e-10 reference (100 samples).

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/compare_integrators.py [--quick]
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.sparse import diags

from flagellum.integrate.brownian import ImplicitStepper
from flagellum.integrate.cvode import KL, KU, CvodeStepper
from flagellum.motor import Motor
from flagellum.params import Params
from flagellum.rod.model import RodModel
from flagellum.simulator import pinned_helix

T = 0.02 if "--quick" in sys.argv else 0.05
TS = np.linspace(0, T, 101)[1:]


def model(frame):
    m = RodModel(Params(), Motor(1.0), omega_frame=frame)
    y0 = m.initial_state(pinned_helix(Params()))
    return m, y0


def thrusts(m, ys):
    return np.array([m.bead_force(t, y)[2] for t, y in zip(TS, ys)])


def run_stepper(make, frame):
    m, y0 = model(frame)
    st = make(m, y0)
    t0 = time.perf_counter()
    ys = [st.advance(t).copy() for t in TS]
    return time.perf_counter() - t0, thrusts(m, ys)


def run_scipy(method, frame, rtol=1e-6):
    m, y0 = model(frame)
    n = len(y0)
    kw = {}
    if method == "LSODA":
        kw = {"lband": KL, "uband": KU}
    else:
        kw = {"jac_sparsity": diags([np.ones(n - abs(k)) for k in range(-KL, KU + 1)],
                                    list(range(-KL, KU + 1)))}
    t0 = time.perf_counter()
    sol = solve_ivp(m.rhs, (0, T), y0, method=method, t_eval=TS, rtol=rtol, atol=rtol * 1e-2, **kw)
    wall = time.perf_counter() - t0
    return wall, thrusts(m, sol.y.T)


def run_cvode_python_jac(frame, rtol=1e-6):
    from sksundae.cvode import CVODE

    m, y0 = model(frame)
    s = CVODE(lambda t, y, yp: m.rhs(t, y, out=yp), linsolver="band", lband=KL, uband=KU,
              rtol=rtol, atol=rtol * 1e-2, max_num_steps=10**6)
    t0 = time.perf_counter()
    sol = s.solve(np.r_[0.0, TS], y0)
    return time.perf_counter() - t0, thrusts(m, sol.y[1:])


def main():
    results = []
    for frame in (0.0, 845.0):
        _, ref = run_stepper(lambda m, y0: CvodeStepper(m, 0.0, y0, 1e-10, 1e-12), frame)
        cases = {
            "CVODE band, Numba Jacobian (default)": lambda: run_stepper(
                lambda m, y0: CvodeStepper(m, 0.0, y0, 1e-6, 1e-8), frame),
            "CVODE band, CVODE's own FD Jacobian": lambda: run_cvode_python_jac(frame),
            "implicit Euler, dt = 2e-5, Numba Newton": lambda: run_stepper(
                lambda m, y0: ImplicitStepper(m, 0.0, y0, 2e-5), frame),
            "scipy LSODA (banded)": lambda: run_scipy("LSODA", frame),
            "scipy BDF (sparse Jacobian)": lambda: run_scipy("BDF", frame),
        }
        if "--quick" not in sys.argv:
            cases["scipy Radau (sparse Jacobian)"] = lambda: run_scipy("Radau", frame)
        for name, fn in cases.items():
            fn() if frame == 0.0 and name.startswith("CVODE band, N") else None  # JIT warm-up
            wall, th = fn()
            results.append({"integrator": name, "frame": "lab" if frame == 0 else "co-rotating",
                            "wall_per_simulated_second": wall / T,
                            "max_thrust_error": float(np.abs(th - ref).max())})
            print(json.dumps(results[-1]), flush=True)
    return results


if __name__ == "__main__":
    main()
