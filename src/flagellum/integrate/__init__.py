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


#: the largest N at which the Numba BDF is the default with a frozen nonlocal mobility, the
#: largest at which it worked: its modified Newton with the banded matrix (local operator plus the near
#: field of ΔM) converges at N = 50 and 100, but at N = 200 the step collapsed (24 863 steps
#: over 0.02 s at M = 1); above N = 100 each Newton step is solved by GMRES with that matrix
#: as preconditioner (:data:`flagellum.integrate.bdf.KRYLOV_MAX`; docs/hydrodynamics.md)
BDF_NONLOCAL_MAX_SEGMENTS = 200


def default_method(*, thermal: bool = False, local: bool = True, cell: bool = False,
                   moving_trap: bool = False, polymorphic: bool = False,
                   unfrozen: bool = False, segments: int = 50) -> str:
    """The integrator of a run that names none (``SolverOptions(method=None)``).

    ``"implicit"`` with thermal noise (the only scheme for it); ``"bdf"`` (the Numba BDF) for
    the deterministic runs it supports and was measured on — the local mobility (RFT), or the
    frozen nonlocal one (SBT) at ``segments`` ≤ :data:`BDF_NONLOCAL_MAX_SEGMENTS`, with no
    cell body, no moving trap, a single-state filament — where at equal rtol it is 1.4–2.1×
    faster than CVODE with RFT (docs/benchmarks.md, "The Numba BDF against CVODE") and
    1.5–1.8× with SBT at N = 50, with the same time averages to ≲ 2e-5
    (docs/hydrodynamics.md, "Cost against RFT"); ``"cvode"`` otherwise (a cell body couples
    outside the BDF's band; a nonlocal mobility rebuilt at every right-hand side,
    ``unfrozen``, and a moving trap's centre are set outside the compiled loop; polymorphic
    runs were not measured).
    """
    if thermal:
        return "implicit"
    if cell or moving_trap or polymorphic:
        return "cvode"
    if not local and (unfrozen or segments > BDF_NONLOCAL_MAX_SEGMENTS):
        return "cvode"
    return "bdf"
