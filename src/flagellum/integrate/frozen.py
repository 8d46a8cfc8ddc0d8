"""The frozen nonlocal mobility ΔM inside an adaptive stepper (docs/hydrodynamics.md,
"Integration in the time stepper"): when it is renewed, and what the kernel applies between
two renewals.

**When.** Both adaptive steppers (CVODE, the Numba BDF) advance to sub-targets and renew ΔM
(:meth:`RodModel.refresh_mobility <flagellum.rod.model.RodModel.refresh_mobility>` with
``due``: turned if the beads moved rigidly, else rebuilt) at planned times: each one when the
fastest bead will have moved about ``refresh`` since the last renewal, or a bond changed by
its turn limit, whichever comes first (:meth:`RodModel.mobility_use
<flagellum.rod.model.RodModel.mobility_use>`), planned from the interval just passed (at
most 1.25 times longer, at least a quarter of it). A check half-way renews early where
the beads have gone past 1.5 times either limit. Renewals at regular intervals, always at
the beads' true positions, make the sequence of ΔM smooth in time; renewals at the first
check past the limits, or turns that keep the residual of a rigid fit, make it jagged, and
each kink of what the kernel applies costs the BDF rejected steps and its high orders
(docs/hydrodynamics.md, "Why planned renewals and a secant").

**What.** Between renewals the kernel applies the secant model

    ΔM(y) = B_k + w(y) G_k,   w(y) = d · (x(y) − x_k) / |d|²,

d = x_k − x_{k−1} the beads' displacement between the last two renewals (x the bead
positions). One interval on (w = 1) it is the secant's extrapolation 2 S_k − S_{k−1} of the
renewed ΔM's S: ΔM's first-order change along the direction the beads last moved. It starts
(w = 0) from the old model's value at the renewal, so the right-hand side does not jump,
where the beads went on about as before (:data:`CONTINUE_W`), else from S_k, with a jump of
the secant's second-order error (:meth:`FrozenMobility.renew`). It is a function of the
state alone, with no lag behind the shape (a time ramp from one ΔM to the next lags by a
whole interval). ``w`` is held within [:data:`W_LO`, :data:`W_HI`]. The model is
:func:`secant_mobility`, called per right-hand side: from Python by CVODE's callback, from
the compiled loop by the BDF.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..hydro.dynamics import bond_change
from ..rod.model import positions as m_positions

#: the secant parameters (the float array of :func:`secant_mobility`): whether the secant
#: model is on (1; 0: ΔM stays as built), and the w it applied last (NaN: none yet)
R_ACTIVE, R_W = range(2)
#: the range w is held to: w = 0 at the last renewal, −1 at the one before; the next renewal
#: comes near w = 1
W_LO, W_HI = -1.5, 2.5
#: the fraction of the limits (bead displacement over ``refresh``, bond change over the
#: turn limit) that a planned interval uses; past EARLY_USE at the half-way check, ΔM is
#: renewed there; the longest and the shortest next interval relative to the last
TARGET_USE = 1.0
EARLY_USE = 1.5
PLAN_GROWTH, PLAN_SHRINK = 1.25, 0.25
#: the range of the old model's w at a renewal within which the new model continues from the
#: old one's value (no jump; the old error carried on, times 1 − w, at most ½)
CONTINUE_W = (0.5, 1.5)


@njit(cache=True)
def secant_mobility(y, dm, base, G, xu, rp):
    """ΔM(y) = base + w G with w = xu[1] · (x(y) − xu[0]) (x the bead positions of the
    state y), written into ``dm`` when w has changed (no-op with the model off)."""
    if rp[R_ACTIVE] == 0.0:
        return
    nb = xu.shape[1] // 3
    w = 0.0
    for i in range(nb):
        for c in range(3):
            w += xu[1, 3 * i + c] * (y[3 + 4 * i + c] - xu[0, 3 * i + c])
    w = min(W_HI, max(W_LO, w))
    if w == rp[R_W]:
        return
    m = dm.shape[0]
    for i in range(m):
        for j in range(m):
            dm[i, j] = base[i, j] + w * G[i, j]
    rp[R_W] = w


@njit(cache=True)
def _start_secant(dm, sample, current, base, G, carry):
    """One pass over the renewed ΔM S_k+1 (in ``dm``) and the last one S_k (``sample``): the
    new model's slope G = S_k+1 − S_k, and with ``carry`` − (C − S_k+1), its base C
    (``current``) or S_k+1, written to ``base`` and ``dm``; ``sample`` becomes S_k+1."""
    m = dm.shape[0]
    for i in range(m):
        for j in range(m):
            s_new = dm[i, j]
            g = s_new - sample[i, j]
            b = s_new
            if carry:
                b = current[i, j]
                g -= b - s_new
            G[i, j] = g
            sample[i, j] = s_new
            base[i, j] = b
            dm[i, j] = b


#: the first planned interval after a (re)start where the bond limit can bind, as a fraction
#: of the one the current speeds give
FIRST_SUB_FRACTION = 1 / 32


class FrozenMobility:
    """The renewals and the secant model of a model's frozen ΔM for one stepper.

    ``active``: a nonlocal mobility with ``refresh`` > 0 (with ``refresh`` = 0 the model
    rebuilds ΔM at every :meth:`RodModel.rhs` call instead). :attr:`arrays` (base, G, xu, rp)
    are what :func:`secant_mobility` reads: B_k, G_k, (x_k, d/|d|²) and the parameters.
    """

    def __init__(self, model):
        self.model = model
        self.active = (not model.hydrodynamics.is_local) and model.hydrodynamics.refresh > 0
        size = model.kernel_arrays[-1][-1].shape[0] if self.active else 0
        nb = model.n + 1 if self.active else 0
        self.arrays = (np.zeros((size, size)), np.zeros((size, size)), np.zeros((2, 3 * nb)),
                       np.zeros(2))
        #: the ΔM renewed last (turns and comparisons start from it), and the old model's
        #: value at a renewal (work arrays of :meth:`renew`)
        self._sample, self._current = np.zeros((size, size)), np.zeros((size, size))
        self.reset(0.0)

    def reset(self, t0: float) -> None:
        """Start over at t0 (a restarted stepper): the ΔM built last as it is, no secant yet,
        the next interval planned from the bead speeds."""
        self.arrays[3][:] = (0.0, np.nan)
        self.last = float(t0)  #: the time of the last renewal
        self.plan = 0.0  #: the planned interval to the next one (0: plan from the speeds)

    def apply(self, y: np.ndarray) -> None:
        """Set the kernel's ΔM to the secant model's value at y."""
        if self.arrays[3][R_ACTIVE]:
            secant_mobility(y, self.model.kernel_arrays[-1][-1], *self.arrays)

    def renew(self, y: np.ndarray) -> None:
        """Renew ΔM at the beads of y (turned or rebuilt) and set the secant from the last
        renewal to this one. With S_k the ΔM renewed k-th and C the old model's value at y
        (where its w was w*), the new model is C + w (2 S_k+1 − S_k − C): no jump at y, and
        one interval on (w = 1) the secant's extrapolation 2 S_k+1 − S_k. The old model's
        error at y, E = C − S_k+1, then reaches the next renewal as (1 − w*) E, so this is
        done only for w* within :data:`CONTINUE_W` (the beads went on about as they did:
        the error shrinks at least 2×); otherwise the new model starts at S_k+1 (a jump of E,
        and no error carried)."""
        m = self.model
        dm = m.kernel_arrays[-1][-1]
        base, G, xu, rp = self.arrays
        carry = False
        if rp[R_ACTIVE]:
            rp[R_W] = np.nan
            secant_mobility(y, self._current, *self.arrays)  # C
            carry = CONTINUE_W[0] <= rp[R_W] <= CONTINUE_W[1]
            # the model compares with, and turns, the ΔM it renewed last (its frozen beads
            # are that renewal's), not the secant's value at some state
            dm[:] = self._sample
        else:  # (re)started: the ΔM built last as it is
            if m.frozen_beads is None:  # nothing built yet
                m.refresh_mobility(y, force=True)
            self._sample[:] = dm
        x_prev = m.frozen_beads.ravel().copy()
        m.refresh_mobility(y, due=True)
        x_new = m.frozen_beads.ravel()
        d = x_new - x_prev
        dd = float(d @ d)
        _start_secant(dm, self._sample, self._current, base, G, carry)
        xu[0] = x_new
        xu[1] = d / dd if dd > 0.0 else 0.0
        rp[:] = (1.0, 0.0)  # dm holds the model's value at w = 0

    def advance(self, t_from: float, y_from: np.ndarray, t: float, step):
        """Advance from (t_from, y_from) to t through sub-targets, ``step(tn)`` returning
        (ok, y at tn, result), renewing ΔM at the planned times. Returns the last ``result``
        (also the failed one)."""
        m = self.model
        refresh, bond = m.hydrodynamics.refresh, m.turn_limit * m.h
        tc = t_from
        if self.plan <= 0:  # first call after a (re)start: from the bead speeds now
            u = m_positions(m.rhs(tc, y_from))
            rate = max(float(np.max(np.abs(u))) / refresh, bond_change(u) / bond)
            self.plan = TARGET_USE / rate if rate > 0 else t - tc
            if bond < 2 * refresh:
                # the bond limit can bind (fine filaments): passing it is unstable, not just
                # less accurate, and from rest the bonds speed up 40-fold within microseconds
                # (N = 400), so begin with a small part and let the intervals grow
                self.plan *= FIRST_SUB_FRACTION
            self.last = min(self.last, tc)
        while True:
            due = self.last + self.plan
            tn = min(t, due, tc + 0.5 * self.plan)
            ok, y, res = step(tn)
            if not ok:
                return res
            used = m.mobility_use(y)
            if tn >= due - 1e-12 * max(1.0, abs(due)) or used > EARLY_USE:
                interval = tn - self.last
                self.renew(y)
                self.last = tn
                if used > 0:
                    self.plan = min(PLAN_GROWTH, max(PLAN_SHRINK, TARGET_USE / used)) * interval
            tc = tn
            if tn >= t:
                return res
