"""Integrators of the rod model: the :class:`~flagellum.integrate.base.Stepper` interface and
its table (:mod:`.base`), CVODE (:mod:`.cvode`), the fixed-step drift-implicit scheme with
thermal noise (:mod:`.brownian`), banded LU (:mod:`.banded`) and an explicit reference
(:mod:`.explicit`, tests only)."""

#: default absolute tolerance per unit relative tolerance of the error-controlled
#: integrators (``atol = rtol * ATOL_PER_RTOL``; the rod's state is in µm and rad)
ATOL_PER_RTOL = 1e-2
