"""Timing of the buckling theory: the whole Fig. 7 manifold must take < 60 s on 2 cores.

Run:  python benchmarks/bench_theory.py [--workers 2] [--budget 60]

Prints one JSON object with the timings of a single critical point (shooting and
collocation) and of ``compute_manifold`` with the default grid (41 × 41 in (m̂, f̂∥),
13 buckling curves, plane intersections and 21 load spheres, with and without the radius
correction); exits with status 1 if the manifold exceeds the budget.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--budget", type=float, default=60.0, help="seconds allowed for the manifold")
    args = ap.parse_args(argv)

    from flagellum.theory.buckling import BucklingProblem, find_critical, solve
    from flagellum.theory.manifold import compute_manifold

    prob = BucklingProblem(m_hat=2.0, f_par=30.0)
    find_critical(prob)                      # warm-up: numba cache, imports
    t = time.perf_counter()
    cp = find_critical(prob)
    t_find = time.perf_counter() - t
    t = time.perf_counter()
    for _ in range(20):
        solve(prob, guess=[cp.f_perp * 1.01, cp.chi * 0.99])
    t_newton = (time.perf_counter() - t) / 20
    t = time.perf_counter()
    solve(prob, guess=[cp.f_perp, cp.chi], method="collocation")
    t_col = time.perf_counter() - t

    t = time.perf_counter()
    res = compute_manifold(workers=args.workers)
    t_manifold = time.perf_counter() - t
    summary = res.summary()
    out = {"cpu_count": os.cpu_count(), "workers": args.workers,
           "global_search_s": t_find, "newton_solve_s": t_newton, "collocation_solve_s": t_col,
           "manifold_s": t_manifold, "manifold_parts_s": res.timings,
           "anchored_M_c1": summary["without_radius_correction"]["anchored"]["M"],
           "anchored_M_c1_radius_corrected": summary["with_radius_correction"]["anchored"]["M"],
           "budget_s": args.budget, "within_budget": t_manifold < args.budget}
    print(json.dumps(out, indent=2))
    return 0 if t_manifold < args.budget else 1


if __name__ == "__main__":
    sys.exit(main())
