"""Analytical buckling theory of the motor-driven helical filament (paper Sec. 4, App. A–C).

* :mod:`.buckling` — the linearised buckling equations of the helical rod and their
  critical values (shooting and Chebyshev collocation),
* :mod:`.manifold` — the critical manifold, the plane of Eq. (31) and the critical
  torque of the filament with a load sphere (Fig. 7, Fig. 5(a)),
* :mod:`.rigid_helix` — precession of a rigid helix under a constant torque (App. B).
* :mod:`.effective_rigidity` — A_eff of App. C, checked by end moments on the discrete rod.
"""

from .buckling import (BucklingProblem, CriticalPoint, NoConvergenceError,
                       TrivialSolutionError, characteristic, find_critical, solve, spectrum)
from .manifold import HelicalRod, compute_manifold

__all__ = ["BucklingProblem", "CriticalPoint", "NoConvergenceError", "TrivialSolutionError",
           "characteristic", "find_critical", "solve", "spectrum", "HelicalRod",
           "compute_manifold"]
