"""Force–extension curves of a pulled filament: the transformation thresholds on the way up
and down and the hysteresis loop (numpy only).

A pull cycle (:func:`flagellum.pulling.pull_cycle`) records the load on the free end F(t)
[pN], the extension x(t) [µm] and the fraction of joints in the later of two forms, q(t).
On the way up (the load rising) a transformation shows as q crossing ``level`` from below;
its force is the largest load before that crossing (the peak before the drop of a
trap-controlled pull, Darnton & Berg, Biophys. J. 92, 2230 (2007)); on the way down the
reverse transformation is q falling back below ``level``, at the load of that record. The
loop area ∮ F dx [pN·µm] is the work done on the filament over the cycle: the energy
dissipated (zero for an elastic, rate-independent curve).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Transitions:
    """Thresholds of one pull cycle (NaN where a transformation did not happen)."""

    force_up: float  #: [pN] largest load before the forward transformation
    extension_up: float  #: [µm] extension at that load
    t_up: float  #: [s] when q first exceeded ``level``
    force_down: float  #: [pN] load when q fell back below ``level`` (reverse transformation)
    extension_down: float  #: [µm]
    t_down: float  #: [s]
    loop_area: float  #: [pN·µm] ∮ F dx over the record (the dissipated work)
    fraction_max: float  #: largest fraction of joints in the later form

    def as_dict(self) -> dict:
        return asdict(self)


def loop_area(force, extension) -> float:
    """∮ F dx [pN·µm] along the recorded path (trapezoid rule): positive when the way up
    runs at larger loads than the way down (work dissipated in the cycle)."""
    f, x = np.asarray(force, float), np.asarray(extension, float)
    if len(f) < 2:
        return math.nan
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))


def transitions(t, force, extension, fraction, level: float = 0.5) -> Transitions:
    """The thresholds and the loop of a pull cycle from its records (``fraction``: the
    fraction of joints in the later form, per record)."""
    t, f, x, q = (np.asarray(a, float) for a in (t, force, extension, fraction))
    nan = math.nan
    up = np.nonzero(q > level)[0]
    fu = xu = tu = fd = xd = td = nan
    if len(up):
        i = int(up[0])
        j = int(np.argmax(f[:i + 1]))
        fu, xu, tu = float(f[j]), float(x[j]), float(t[i])
        back = np.nonzero(q[i:] <= level)[0]
        if len(back):
            k = i + int(back[0])
            fd, xd, td = float(f[k]), float(x[k]), float(t[k])
    return Transitions(fu, xu, tu, fd, xd, td, loop_area(f, x), float(q.max()) if len(q) else nan)


__all__ = ["Transitions", "loop_area", "transitions"]
