"""Regimes of the driven filament (paper Sec. 3.1, Figs. 3–4), detected from observables only.

The four regimes of Fig. 3(a), told apart by what a run shows in its averaging window
(never by the torque value):

(i)   ``reorienting``: the filament pulls on its anchor (mean thrust < 0). The aligned
      state is then unstable and the filament slowly turns away from the motor axis
      (λ ~ 0.1 /s, too slow to see in short runs), or it has already turned: its
      end-to-end vector is tilted by more than 45° on average.
(ii)  ``aligned``: steady rotation about the motor axis: constant thrust, the centroid on
      the axis, r(t) constant (σ ≈ 0; thermal noise alone gives σ/σ0 ≈ 0.15–0.18, Sec. 3.1.2).
(iii) ``buckled``: a bent shape of constant form rotating about its local helix axis and
      precessing about the motor axis (Sec. 3.1.1): the centroid off the axis, the thrust
      oscillating about a positive mean, the free end on a circle of radius R about the
      local axis, so r(t) swings by at most ≈ ±R and σ ≤ σ0 = R/√2 (the paper's definition
      of σ0, Fig. 4(d)).
(iv)  ``oscillating``: the buckled state collapses periodically: it is compressed until
      the fixed end is perpendicular to the motor axis, the fast rotation and the thrust
      stop, the bent filament relaxes and the cycle repeats (Sec. 3.1.1). σ jumps at M_c2
      ("pronounced discontinuity", Fig. 4(d)); we require both signatures:

      * σ/σ0 > :data:`SIGMA_IV` = 1.5, a 50 % margin above the largest σ of regime (iii)
        (transients just above M_c1 reach σ/σ0 ≈ 0.75–1, steady (iii) runs 1.05–1.12; at
        M = 4.5 pN·µm we measure σ/σ0 ≈ 4), and
      * r(t) collapses *and* recovers: it crosses from above r_mid + :data:`SWING`·R to
        below r_mid − SWING·R and back (or the reverse) at least once in the window, with
        r_mid the middle of its range. A constant shape cannot do that (its r stays within
        ⟨r⟩ ± R), nor can a one-way drift of r (a transient that is still buckling), which
        alone can give a large σ. The mid-range, not ⟨r⟩, centres the band, so that one
        brief collapse in a long relaxed window still counts.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .observables import end_to_end

REGIMES = ("reorienting", "aligned", "buckled", "oscillating")

#: σ/σ0 above which a collapsing state is regime (iv) (σ0 = R/√2 is the maximum of (iii))
SIGMA_IV = 1.5
#: half-width, in units of the helix radius R, of the band about the middle of the range of
#: r(t) that a collapse must cross both ways (a constant shape swings by at most ±R)
SWING = 1.5
#: buckled-state signatures: centroid offset [R], thrust std / |mean|, σ/σ0 (above the
#: thermal σ/σ0 ≈ 0.18 of the aligned state, Sec. 3.1.2)
CENTROID_BUCKLED = 0.25
THRUST_BUCKLED = 0.05
SIGMA_BUCKLED = 0.3
#: mean tilt [deg] of the end-to-end vector from −e_z beyond which the filament has turned away
TILT_REORIENTED = 45.0


@dataclass(frozen=True)
class RegimeMetrics:
    """The observables of one window that :func:`decide` uses."""

    thrust_mean: float  #: [pN]
    thrust_std: float  #: [pN]
    sigma_over_sigma0: float  #: σ(r)/σ0, σ0 = R/√2
    r_mean: float  #: ⟨r⟩ [µm]
    centroid_offset: float  #: mean distance of the centroid from the motor axis, in units of R
    tilt_deg: float  #: mean tilt of the end-to-end vector from −e_z [deg]
    swings: int  #: crossings of r(t) through its mid-range ± SWING·R (a collapse or a recovery)
    samples: int

    def to_dict(self) -> dict:
        return asdict(self)


def count_swings(r: np.ndarray, half_width: float) -> int:
    """Crossings of ``r`` from above m + w to below m − w or back (a Schmitt trigger), m the
    middle of the range of ``r``."""
    r = np.asarray(r, float)
    if len(r) < 2:
        return 0
    m = 0.5 * (r.min() + r.max())
    level = np.where(r > m + half_width, 1, np.where(r < m - half_width, -1, 0))
    level = level[level != 0]
    return int(np.count_nonzero(np.diff(level)))


def measure(t, thrust, positions, helix_radius: float, t_from: float | None = None) -> RegimeMetrics:
    """Regime observables over the window t ≥ t_from (default: the last half)."""
    t = np.asarray(t, float)
    if t_from is None:
        t_from = t[0] + 0.5 * (t[-1] - t[0])
    sel = t >= t_from - 1e-12
    if not sel.any():
        sel[-1] = True
    th = np.asarray(thrust, float)[sel]
    pos = np.asarray(positions, float)[sel]
    r = end_to_end(pos)
    tip = pos[:, -1] - pos[:, 0]
    tilt = np.degrees(np.arccos(np.clip(-tip[:, 2] / np.maximum(r, 1e-300), -1, 1)))
    centroid = np.hypot(*pos.mean(axis=1)[:, :2].T)
    return RegimeMetrics(
        thrust_mean=float(th.mean()), thrust_std=float(th.std()),
        sigma_over_sigma0=float(r.std() / (helix_radius / math.sqrt(2))), r_mean=float(r.mean()),
        centroid_offset=float(centroid.mean() / helix_radius), tilt_deg=float(tilt.mean()),
        swings=count_swings(r, SWING * helix_radius), samples=int(sel.sum()))


def decide(m: RegimeMetrics) -> str:
    """The regime of a window from its :class:`RegimeMetrics` (criteria: module docstring)."""
    if m.thrust_mean < 0:
        return "reorienting"
    if m.sigma_over_sigma0 > SIGMA_IV and m.swings >= 2:
        return "oscillating"
    if m.tilt_deg > TILT_REORIENTED:
        return "reorienting"
    if (m.centroid_offset > CENTROID_BUCKLED or m.thrust_std > THRUST_BUCKLED * abs(m.thrust_mean)
            or m.sigma_over_sigma0 > SIGMA_BUCKLED):
        return "buckled"
    return "aligned"


def classify(t, thrust, positions, helix_radius: float, axial_length: float | None = None,
             t_from: float | None = None) -> str:
    """Name the regime of the window t ≥ t_from (default: the last half).

    ``axial_length`` is accepted for compatibility and not used.
    """
    return decide(measure(t, thrust, positions, helix_radius, t_from))
