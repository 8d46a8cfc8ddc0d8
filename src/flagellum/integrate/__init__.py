"""Integrators of the rod model: the :class:`~flagellum.integrate.base.Stepper` interface and
its table (:mod:`.base`), CVODE (:mod:`.cvode`), the Numba variable-order BDF (:mod:`.bdf`),
the fixed-step drift-implicit scheme with thermal noise (:mod:`.brownian`), banded LU
(:mod:`.banded`) and an explicit reference (:mod:`.explicit`, tests only)."""

#: default absolute tolerance per unit relative tolerance of the error-controlled
#: integrators (``atol = rtol * ATOL_PER_RTOL``; the rod's state is in µm and rad)
ATOL_PER_RTOL = 1e-2


def default_method(*, thermal: bool = False, local: bool = True, cell: bool = False,
                   moving_trap: bool = False, polymorphic: bool = False,
                   unfrozen: bool = False) -> str:
    """The integrator of a run that names none (``SolverOptions(method=None)``).

    ``"implicit"`` with thermal noise (the only scheme for it); ``"bdf"`` (the Numba BDF) for
    the deterministic runs it supports and was measured on — the local mobility (RFT) or the
    frozen nonlocal one (SBT), no cell body, no moving trap, a single-state filament — where
    at equal rtol it is 1.4–2.1× faster than CVODE with RFT (docs/benchmarks.md, "The Numba
    BDF against CVODE") and 1.5–2.5× with SBT, whose time averages it reproduces to
    ≤ 1e-4 (docs/hydrodynamics.md, "Cost against RFT"); ``"cvode"`` otherwise (a cell body
    couples outside the BDF's band; a nonlocal mobility rebuilt at every right-hand side,
    ``unfrozen``, and a moving trap's centre are set outside the compiled loop; polymorphic
    runs were not measured). ``local``: the mobility is local (both kinds run on the BDF,
    a nonlocal one unless ``unfrozen``).
    """
    if thermal:
        return "implicit"
    if not (cell or moving_trap or polymorphic or (unfrozen and not local)):
        return "bdf"
    return "cvode"
