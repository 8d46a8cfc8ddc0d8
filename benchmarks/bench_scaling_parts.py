"""Per-call cost of the parts of a step against N (docs/benchmarks.md, "Cost against N").

For N = 50, 100, 200, 400 (L = 10 µm) at a perturbed helix: the kernel right-hand side,
the coloured finite-difference Jacobian, the banded LU of I − γJ and its solve, and CVODE's
Jacobian callback (the Jacobian plus the copy of its band into scikit-sundae's n × n array),
best of 5 repeats in one process. Linear parts mean that a super-linear cost per simulated
second comes from the counts (Jacobians per step; benchmarks/bench_scaling.py).

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_scaling_parts.py
Writes benchmarks/bench_scaling_parts.json.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from flagellum import bench as B
from flagellum.integrate.banded import band_factor, band_solve
from flagellum.integrate.cvode import CvodeStepper
from flagellum.motor import Motor
from flagellum.params import Filament, Params
from flagellum.simulator import Simulator

HERE = Path(__file__).parent


def best(f, repeats: int = 5) -> float:
    """Microseconds per call, best of ``repeats`` batches of ≈ 50 ms."""
    f()
    t = time.perf_counter()
    f()
    n = max(1, int(0.05 / max(time.perf_counter() - t, 1e-7)))
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(n):
            f()
        out.append((time.perf_counter() - t) / n * 1e6)
    return min(out)


def main() -> None:
    rows = []
    for n in (50, 100, 200, 400):
        sim = Simulator(Params(Filament(segment_length=10.0 / n)), Motor(1.6))
        m = sim.model
        y = sim.y.copy()
        y[3:] += np.random.default_rng(1).normal(0.0, 0.02, len(y) - 3)
        ny = len(y)
        kl, ku = m.jacobian_band
        args = m.kernel_arrays
        f0 = np.empty(ny)
        m.rhs_kernel(y, f0, *args)
        ab = np.zeros((ny, 2 * kl + ku + 1))
        yw, fw = np.zeros(ny), np.zeros(ny)
        colors = m.jacobian_colors(kl, ku)
        jac = lambda: m.jacobian_kernel(y, f0, *args, kl, ku, ab, 1.0, yw, fw, *colors)  # noqa: E731
        jac()
        pab = -1e-5 * ab
        pab[:, kl + ku] += 1.0
        work, ipiv, backup = pab.copy(), np.zeros(ny, np.int64), np.zeros((ny, kl + ku + 1))

        def lu():
            work[:] = pab
            band_factor(work, kl, ku, ipiv, backup)

        lu()
        piv = band_factor(work, kl, ku, ipiv, backup)[1]
        rhs_vec = np.ones(ny)
        st = CvodeStepper(m, 0.0, y)
        dense = np.zeros((ny, ny))
        row = {"segments": n, "state_size": ny,
               "rhs_us": best(lambda: m.rhs_kernel(y, f0, *args)),
               "RodModel.rhs_us": best(lambda: m.rhs(0.0, y, out=f0)),
               "jacobian_us": best(jac),
               "band_lu_us": best(lu),
               "band_solve_us": best(lambda: band_solve(work, kl, ku, ipiv, rhs_vec, piv)),
               "cvode_jacobian_callback_us": best(lambda: st._jac(0.0, y, f0, dense))}
        row.update({k.replace("_us", "_us_per_segment"): v / n for k, v in list(row.items())
                    if k.endswith("_us")})
        rows.append(row)
        print(json.dumps(row), flush=True)
    out = {"load_average": B.load_average(), "rows": rows}
    (HERE / "bench_scaling_parts.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
