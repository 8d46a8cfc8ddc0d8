"""Compile (fill Numba's cache with) the kernels of every solver: ``python -m flagellum.warmup
[METHOD ...]``. Started in the background by :func:`flagellum.integrate.cache.warm_in_background`
when a run finds the cache cold; see there."""

from __future__ import annotations

import contextlib
import os
import sys

from .integrate.cache import METHODS

#: simulated time of each warm-up run [s]
WARM_TIME = 2e-3


def warm(methods=None, segments: int = 20) -> list[str]:
    """Compile (or load) the kernels of ``methods`` (default: all of
    :data:`~flagellum.integrate.cache.METHODS`) by a few steps of each on a filament of
    ``segments`` segments (the kernels' Numba types do not depend on the size); returns the
    methods run."""
    from .hydro.options import Hydrodynamics
    from .motor import Boundary, Motor
    from .params import Filament, Params
    from .simulator import Simulator, SolverOptions

    chosen = [m for m in METHODS if methods is None or m in methods]
    params = Params(Filament(segment_length=10.0 / segments))
    for method in chosen:
        thermal = method == "implicit"
        sim = Simulator(params, Motor(1.0), thermal=thermal, seed=1 if thermal else None,
                        solver=SolverOptions(method=method))
        # 20 records over 2 ms: the co-rotating frame adapts and the charts move, so the
        # stepper's history carry through them (a first run's compile otherwise) is cached too
        sim.run(WARM_TIME, save_every=WARM_TIME / 20, progress=False)
        if method == "bdf":  # its nonlocal path (SBT's default): ΔM's builds, the secant
            for boundary in (Boundary(), Boundary(anchor="sphere", sphere_radius=1.0)):
                Simulator(params, Motor(1.0), boundary, solver=SolverOptions(method=method),
                          hydrodynamics=Hydrodynamics("sbt")).run(
                    WARM_TIME, save_every=WARM_TIME / 20, progress=False)
        if method == "implicit":  # a thermal SBT run: its compiled increment (5 s otherwise)
            Simulator(params, Motor(1.0), thermal=True, seed=1, solver=SolverOptions(method=method),
                      hydrodynamics=Hydrodynamics("sbt")).run(
                WARM_TIME, save_every=WARM_TIME / 20, progress=False)
    return chosen


def main(argv: list[str]) -> None:
    lock = None
    if argv[:1] == ["--lock"]:
        lock, argv = argv[1], argv[2:]
    if hasattr(os, "nice"):
        with contextlib.suppress(OSError):
            os.nice(10)  # behind the user's own run
    try:
        warm(argv or None)
    finally:
        if lock:
            with contextlib.suppress(OSError):
                os.unlink(lock)


if __name__ == "__main__":
    main(sys.argv[1:])
