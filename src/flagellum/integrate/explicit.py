"""Explicit reference integrator (tests only): classical 4th-order Runge–Kutta, fixed step.

The rod is very stiff (twist relaxes at ~3e8 /s at h = 0.2 µm), so explicit stepping needs
Δt ≲ 5e-9 s: about a million steps per motor revolution. It exists as an independent check
of the implicit integrators on short windows, not for production runs.
"""

from __future__ import annotations

import numpy as np


def rk4(fun, t0: float, y0: np.ndarray, t_end: float, dt: float) -> np.ndarray:
    """Integrate y' = fun(t, y) from t0 to t_end with fixed steps (the last one shortened)."""
    y = np.array(y0, float)
    t = float(t0)
    while t < t_end - 1e-15:
        h = min(dt, t_end - t)
        k1 = fun(t, y)
        k2 = fun(t + h / 2, y + h / 2 * k1)
        k3 = fun(t + h / 2, y + h / 2 * k2)
        k4 = fun(t + h, y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t += h
    return y
