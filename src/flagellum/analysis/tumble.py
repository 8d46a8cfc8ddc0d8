"""Run and tumble of a free-swimming cell: the tumble angle and the time course of a reversal.

A cell swims (run), its motor reverses for a while (the flagellum pulls, and a polymorphic
filament transforms), then turns forward again (the filament recovers and the cell runs on).
The *tumble angle* is the angle between the mean swimming directions of the two runs, as a
tracking microscope measures it (H. C. Berg & D. A. Brown, Nature 239, 500 (1972): the
change of direction between the runs before and after a tumble). A run's mean swimming
direction is that of the least-squares velocity of the body's centre over a window (several
turns of its helical path, which averages the wobble out; the same velocity as
:func:`flagellum.analysis.observables.body_motion`).

Windows: before the reversal, ``[t_on − window, t_on]``; after recovery, the last ``window``
of the record (the run must go on long enough after the motor turns forward again for the
filament to recover; ``recovery_time`` says when it did); and, for runs with thermal noise,
in which the body's Brownian rotation over the rest of the record adds to the tumble, the
first ``window`` after the first form holds every joint again (``settle_time``; right after
t_off for a record without polymorphic state). numpy only.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

#: default averaging window [s] of each run's swimming direction
WINDOW = 0.1
#: the share of the joints that marks a transformation (and a recovery) as done
HALF = 0.5


def mean_velocity(t, position, t0: float, t1: float) -> np.ndarray:
    """Least-squares velocity [µm/s] of ``position`` (n_t, 3) over t0 ≤ t ≤ t1 (NaN with
    fewer than two records there)."""
    t, position = np.asarray(t, float), np.asarray(position, float)
    sel = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
    if sel.sum() < 2:
        return np.full(3, math.nan)
    return np.polyfit(t[sel] - t[sel][0], position[sel], 1)[0]


def angle_deg(u, v) -> float:
    """Angle [deg] between two vectors (NaN if either vanishes or is not finite)."""
    u, v = np.asarray(u, float), np.asarray(v, float)
    nu, nv = np.linalg.norm(u), np.linalg.norm(v)
    if not (nu > 0 and nv > 0 and math.isfinite(nu) and math.isfinite(nv)):
        return math.nan
    # atan2 of |u × v| and u·v: accurate at small angles too (acos is not)
    return math.degrees(math.atan2(np.linalg.norm(np.cross(u, v)), float(u @ v)))


@dataclass(frozen=True)
class TumbleSummary:
    """One tumble (times in s, speeds in µm/s, angles in degrees; NaN where undefined)."""

    tumble_angle_deg: float  #: between the mean swimming directions before and after
    axis_tumble_angle_deg: float  #: the same for the mean body axis of the two windows
    speed_before: float  #: net swimming speed |V̄| before the reversal
    speed_after: float  #: … and after recovery
    reversal_start: float  #: t_on, the motor turns CW
    reversal_end: float  #: t_off, the motor turns CCW again
    window: float  #: averaging window of each run
    transform_time: float  #: t − t_on at which the first form has fallen below half the joints
    recovery_time: float  #: t − t_off at which it holds half the joints again
    transformed_fraction_max: float  #: largest share of joints not in the first form
    normal_fraction_final: float  #: share of joints in the first form at the end
    settle_time: float = math.nan  #: t − t_off at which the first form holds every joint again
    recovered_tumble_angle_deg: float = math.nan  #: before against the window from t_off + settle_time
    speed_recovered: float = math.nan  #: net swimming speed over that window
    peak_fractions: dict | None = None  #: form → largest share of the joints during the tumble
    sequence: tuple = ()  #: the forms in order of first appearance after t_on

    def to_dict(self) -> dict:
        d = asdict(self)
        d["sequence"] = ",".join(self.sequence)
        return d


def tumble(t, position, axis, reversal: tuple[float, float], window: float = WINDOW,
           polymorph=None, forms=None) -> TumbleSummary:
    """Analyse one tumble from a trajectory's ``body_position`` and ``body_axis`` (n_t, 3);
    ``reversal`` = (t_on, t_off) the motor's CW interval. With ``polymorph`` (n_t, n) the
    order parameters and their ``forms`` the time course of the transformation."""
    from ..errors import ParameterError
    from ..rod.polymorph import fractions

    t = np.asarray(t, float)
    t_on, t_off = (float(x) for x in reversal)
    if not t[0] <= t_on < t_off <= t[-1]:
        raise ParameterError("reversal", (t_on, t_off), f"t_on < t_off within the record "
                                                        f"{t[0]:g} … {t[-1]:g} s")
    window = float(window)
    if not window > 0:
        raise ParameterError("window", window, "> 0 s")
    before = (max(t[0], t_on - window), t_on)
    after = (max(t_off, t[-1] - window), t[-1])
    v0, v1 = mean_velocity(t, position, *before), mean_velocity(t, position, *after)
    ax = np.asarray(axis, float)
    a0, a1 = (ax[s].mean(axis=0) if s.any() else np.full(3, math.nan)
              for s in ((t >= before[0]) & (t <= before[1]), (t >= after[0]) & (t <= after[1])))
    extra = dict(transform_time=math.nan, recovery_time=math.nan,
                 transformed_fraction_max=math.nan, normal_fraction_final=math.nan)
    peaks, sequence = None, ()
    settle = 0.0
    if polymorph is not None:
        phi = np.asarray(polymorph, float)
        names = list(forms) if forms is not None else [str(i) for i in range(int(np.ceil(phi.max())) + 1)]
        frac = fractions(phi, len(names))
        normal = frac[:, 0]
        during = t >= t_on
        down = np.flatnonzero(during & (normal < HALF))
        up = np.flatnonzero((t >= t_off) & (normal >= HALF))
        extra.update(transformed_fraction_max=float(1.0 - normal[during].min()),
                     normal_fraction_final=float(normal[-1]))
        if len(down):
            extra["transform_time"] = float(t[down[0]] - t_on)
            rec = up[t[up] > t[down[0]]] if len(up) else up
            if len(rec):
                extra["recovery_time"] = float(t[rec[0]] - t_off)
        # wholly back in the first form: the first record from t_off on with every joint in it
        back = np.flatnonzero((t >= t_off) & (normal >= 1.0))
        settle = float(t[back[0]] - t_off) if len(back) else math.nan
        peaks = {f: float(frac[during, i].max()) for i, f in enumerate(names)}
        first = {}
        n = phi.shape[1]
        for i, f in enumerate(names[1:], 1):
            seen = np.flatnonzero(during & (frac[:, i] * n >= 0.5))
            if len(seen):
                first[f] = t[seen[0]]
        sequence = tuple(sorted(first, key=first.get))
    t_rec = t_off + settle
    v2 = (mean_velocity(t, position, t_rec, t_rec + window)
          if t_rec + window <= t[-1] + 1e-12 else np.full(3, math.nan))
    return TumbleSummary(angle_deg(v0, v1), angle_deg(a0, a1), float(np.linalg.norm(v0)),
                         float(np.linalg.norm(v1)), t_on, t_off, window, **extra,
                         settle_time=settle, recovered_tumble_angle_deg=angle_deg(v0, v2),
                         speed_recovered=float(np.linalg.norm(v2)),
                         peak_fractions=peaks, sequence=sequence)


#: bin edges [deg] of the tumble-angle histogram (20° wide: the sweeps hold a few tens of runs)
BINS = tuple(range(0, 181, 20))


def angle_distribution(angles_deg, bins=BINS) -> dict:
    """Statistics of a set of tumble angles [deg] (NaNs dropped): count, mean, sample standard
    deviation, median, quartiles, the mean cosine ⟨cos θ⟩ (the persistence of direction
    over a tumble: 0 for directions drawn at random on the sphere, whose angles then have
    the mean 90° and the standard deviation √(π²/4 − 2) = 39.2°) and the histogram
    (``edges`` [deg], ``counts``)."""
    a = np.asarray(angles_deg, float).ravel()
    a = a[np.isfinite(a)]
    edges = np.asarray(bins, float)
    out = {"n": int(a.size), "edges": edges.tolist(),
           "counts": np.histogram(a, bins=edges)[0].astype(int).tolist()}
    if a.size == 0:
        return {**out, **dict.fromkeys(("mean", "sd", "median", "q25", "q75", "mean_cos"), math.nan)}
    q25, med, q75 = np.percentile(a, (25, 50, 75))
    return {**out, "mean": float(a.mean()), "sd": float(a.std(ddof=1)) if a.size > 1 else math.nan,
            "median": float(med), "q25": float(q25), "q75": float(q75),
            "mean_cos": float(np.cos(np.radians(a)).mean())}


__all__ = ["BINS", "HALF", "TumbleSummary", "WINDOW", "angle_deg", "angle_distribution",
           "mean_velocity", "tumble"]
