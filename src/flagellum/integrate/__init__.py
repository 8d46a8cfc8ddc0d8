"""Integrators of the rod model: the :class:`~flagellum.integrate.base.Stepper` interface and
its table (:mod:`.base`), CVODE (:mod:`.cvode`), the Numba variable-order BDF (:mod:`.bdf`),
the fixed-step drift-implicit scheme with thermal noise (:mod:`.brownian`), banded LU
(:mod:`.banded`) and an explicit reference (:mod:`.explicit`, tests only)."""

#: default absolute tolerance per unit relative tolerance of the error-controlled
#: integrators (``atol = rtol * ATOL_PER_RTOL``; the rod's state is in µm and rad)
ATOL_PER_RTOL = 1e-2

#: internal steps an error-controlled integrator may take in one ``advance`` before it
#: reports failure (CVODE's ``mxstep``; the same for every adaptive stepper). The simulator
#: advances in chunks of at most 0.5 rad of motor rotation (≤ 5 ms), which take 7–14 steps
#: (median) and ≤ ~200 in the stiffest healthy runs measured (docs/benchmarks.md, "Stalls"), so
#: a chunk that needs more has a step size collapsed to < 1e-6 of a chunk: it fails fast,
#: and the simulator's retry from re-centred charts or the next method of a fallback chain
#: takes over instead of the run grinding on
MAX_STEPS_PER_ADVANCE = 5000


def default_method(*, thermal: bool = False, local: bool = True, cell: bool = False,
                   moving_trap: bool = False, polymorphic: bool = False) -> str:
    """The integrator of a run that names none (``SolverOptions(method=None)``).

    ``"implicit"`` with thermal noise (the only scheme for it); ``"bdf"`` (the Numba BDF) for
    the deterministic runs it supports and was measured on — the local mobility (RFT), no cell
    body, no moving trap, a single-state filament — where at equal rtol it is 1.4–2.1× faster
    than CVODE with an equal or smaller error of the time-averaged thrust, ω and χ
    (docs/benchmarks.md, "The Numba BDF against CVODE"); ``"cvode"`` otherwise (a nonlocal
    mobility or a cell body couples outside the BDF's band; a moving trap's centre is set
    outside the compiled loop; polymorphic runs were not measured).
    """
    if thermal:
        return "implicit"
    if local and not cell and not moving_trap and not polymorphic:
        return "bdf"
    return "cvode"
