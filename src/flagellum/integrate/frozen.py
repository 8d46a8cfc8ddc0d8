"""The frozen nonlocal mobility ΔM inside an adaptive stepper (docs/hydrodynamics.md,
"Integration in the time stepper"): when it is checked, and how a rebuilt one takes over.

Both adaptive steppers (CVODE, the Numba BDF) advance to sub-targets that the fastest bead
takes about half of ``refresh`` to reach (and the fastest-changing bond half of its turn
limit), check ΔM there (:meth:`RodModel.refresh_mobility
<flagellum.rod.model.RodModel.refresh_mobility>`: rebuilt, turned or kept) and, after a
rebuild at time t, let the ΔM that the kernel applies go over linearly in time from its value
at t to the new one, over the time the last interval between builds took, so that the
right-hand side has no jump (a jump costs the stepper a run of rejected, shortened steps).
The ramp is :func:`ramp_mobility`, called per right-hand side: from Python by CVODE's
callback, from the compiled loop by the BDF.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..rod.model import positions as m_positions

#: ramp parameters (the float array of :func:`ramp_mobility`): start, duration, the fraction
#: applied last (−1: none yet), and whether a ramp is active (1) or ΔM stays as it is (0)
R_T0, R_TAU, R_S, R_ACTIVE = range(4)


@njit(cache=True)
def ramp_mobility(t, dm, frm, delta, rp):
    """ΔM(t) = frm + s delta with s = (t − t0)/τ clipped to [0, 1], written into ``dm`` when
    s has changed since the last call (no-op without an active ramp)."""
    if rp[R_ACTIVE] == 0.0:
        return
    s = min(1.0, max(0.0, (t - rp[R_T0]) / rp[R_TAU]))
    if s == rp[R_S]:
        return
    m = dm.shape[0]
    for i in range(m):
        for j in range(m):
            dm[i, j] = frm[i, j] + s * delta[i, j]
    rp[R_S] = s


#: the first sub-interval after a (re)start where the bond limit can bind, as a fraction of
#: the one the current speeds give
FIRST_SUB_FRACTION = 1 / 32


def _bond_change(dx: np.ndarray) -> float:
    """The largest change of a bond vector for bead displacements (or velocities) dx."""
    return float(np.max(np.abs(np.diff(dx, axis=0))))


class FrozenMobility:
    """The checks and the ramp of a model's frozen ΔM for one stepper.

    ``active``: a nonlocal mobility with ``refresh`` > 0 (with ``refresh`` = 0 the model
    rebuilds ΔM at every :meth:`RodModel.rhs` call instead). ``smooth``: ramp after a
    rebuild (else ΔM jumps). :attr:`arrays` (frm, delta, rp) are what
    :func:`ramp_mobility` reads.
    """

    def __init__(self, model, smooth: bool = True):
        self.model = model
        self.smooth = smooth
        self.active = (not model.hydrodynamics.is_local) and model.hydrodynamics.refresh > 0
        size = model.kernel_arrays[-1][-1].shape[0] if self.active else 0
        self.arrays = (np.zeros((size, size)), np.zeros((size, size)), np.zeros(4))
        self.reset(0.0)

    def reset(self, t0: float) -> None:
        """Start over at t0 (a restarted stepper): no ramp, sub-interval from the bead speeds."""
        self.arrays[2][:] = (0.0, 1.0, -1.0, 0.0)
        self._target = None  #: the ΔM built (or turned) last: where the ramp goes
        self.last_build = float(t0)
        self.sub = 0.0

    def apply(self, t: float) -> None:
        """Set the kernel's ΔM to its ramped value at t."""
        if self.arrays[2][R_ACTIVE]:
            ramp_mobility(t, self.model.kernel_arrays[-1][-1], *self.arrays)

    def check(self, t: float, y: np.ndarray, start: float | None = None) -> None:
        """Rebuild (or turn) ΔM if the beads of y (at t) have moved too far, and start the
        ramp at ``start`` (default t): the stepper's own time, which is past t when it
        interpolated y there (a ramp begun at t would make the right-hand side jump)."""
        m = self.model
        dm = m.kernel_arrays[-1][-1]
        frm, delta, rp = self.arrays
        t0 = t if start is None else max(t, start)
        if rp[R_ACTIVE]:  # the value applied at t0
            rp[R_S] = -1.0
            ramp_mobility(t0, dm, frm, delta, rp)
        current = dm.copy() if self.smooth else None
        if rp[R_ACTIVE]:
            # the model compares with, and turns, the ΔM it built last (its frozen beads are
            # that build's), not the ramp's blend: a blend turned as the new target would
            # drop the rest of the ramp and keep part of an older build
            dm[:] = self._target
        if not m.refresh_mobility(y):
            if rp[R_ACTIVE]:
                dm[:] = current
            return
        self._target = dm.copy()
        if self.smooth and t > self.last_build:
            frm[:] = current
            np.subtract(dm, current, out=delta)
            rp[:] = (t0, t - self.last_build, -1.0, 1.0)
        else:
            rp[R_ACTIVE] = 0.0
        self.last_build = t

    def advance(self, t_from: float, y_from: np.ndarray, t: float, step):
        """Advance from (t_from, y_from) to t through sub-targets, ``step(tn)`` returning
        (ok, y at tn, result, the stepper's own time); ΔM is checked after each. Returns the
        last ``result`` (also the failed one)."""
        m = self.model
        refresh, bond = m.hydrodynamics.refresh, m.turn_limit * m.h
        tc, xc = t_from, m_positions(y_from)
        if self.sub <= 0:  # first call: from the bead speeds now
            u = m_positions(m.rhs(tc, y_from))
            rate = max(float(np.max(np.abs(u))) / refresh, _bond_change(u) / bond)
            self.sub = 0.5 / rate if rate > 0 else t - tc
            if bond < 2 * refresh:
                # the bond limit can bind (fine filaments): passing it is unstable, not just
                # less accurate, and from rest the bonds speed up 40-fold within microseconds
                # (N = 400), so begin with a small part and let the sub-intervals grow
                self.sub *= FIRST_SUB_FRACTION
        while True:
            tn = min(t, tc + self.sub)
            if t - tn < 0.25 * self.sub:
                tn = t
            ok, y, res, t_own = step(tn)
            if not ok:
                return res
            xn = m_positions(y)
            # the fraction of either limit used: the beads' refresh distance and the bonds'
            # turn limit (RodModel.refresh_mobility)
            used = max(float(np.max(np.abs(xn - xc))) / refresh, _bond_change(xn - xc) / bond)
            if used > 0:
                self.sub = min(2.0, max(0.25, 0.5 / used)) * (tn - tc)
            self.check(tn, y, t_own)
            tc, xc = tn, xn
            if tn >= t:
                return res
