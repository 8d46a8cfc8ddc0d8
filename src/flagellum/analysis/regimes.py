"""Regimes of the driven filament (paper §3.1, Fig. 3), detected from observables.

(i)   ``reorienting``: the filament pulls on its anchor (mean thrust < 0), where the aligned
      state is unstable and the filament slowly turns away from the motor axis (λ ~ 0.1 /s,
      too slow to see in short runs), or it is already tilted by more than 45°;
(ii)  ``aligned``: steady rotation about the motor axis, constant thrust, σ ≈ 0;
(iii) ``buckled``: bent shape precessing about the motor axis, the centroid off the axis,
      thrust oscillating about a non-zero mean, σ ≤ σ0 = R/√2;
(iv)  ``oscillating``: buckled state that collapses and recovers periodically, σ > σ0 with
      strong thrust oscillations.
"""

from __future__ import annotations

import math

import numpy as np

from .observables import end_to_end

REGIMES = ("reorienting", "aligned", "buckled", "oscillating")


def classify(t, thrust, positions, helix_radius: float, axial_length: float,
             t_from: float | None = None) -> str:
    """Name the regime of the window t ≥ t_from (default: the last half)."""
    t = np.asarray(t, float)
    if t_from is None:
        t_from = t[0] + 0.5 * (t[-1] - t[0])
    sel = t >= t_from
    th = np.asarray(thrust, float)[sel]
    pos = np.asarray(positions, float)[sel]
    r = end_to_end(pos)
    sigma0 = helix_radius / math.sqrt(2)
    tip = pos[:, -1] - pos[:, 0]
    tilt = np.degrees(np.arccos(np.clip(-tip[:, 2] / np.linalg.norm(tip, axis=1), -1, 1)))
    centroid = np.hypot(*pos.mean(axis=1)[:, :2].T)
    mean_th = float(np.mean(th))
    if mean_th < 0 or tilt[-1] > 45:  # pulling: the aligned state is unstable (λ > 0)
        return "reorienting"
    if float(np.std(r)) > sigma0:
        return "oscillating"
    if centroid.mean() > 0.25 * helix_radius or np.std(th) > 0.05 * abs(mean_th):
        return "buckled"
    return "aligned"
