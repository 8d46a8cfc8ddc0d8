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
positions). One interval on (w = 1) it is the extrapolation of the renewed ΔM's S along
the direction the beads last moved: the quadratic through the last three renewals (S_k at
w = 0, S_k−1 at −1, S_k−2 where its beads project on d), or the secant 2 S_k − S_{k−1} of
the last two where the history is shorter or the beads turned away (:func:`secant_after`);
the model is the chord to that point, linear in w. The quadratic's end point put the
time-averaged errors 2–21 times closer to the unfrozen splitting at the same refresh
distance in the buckled, load-sphere and M = 3 runs; from rest and for the free swimmer
they moved both ways (docs/hydrodynamics.md, "Accuracy and cost of the splitting"). It starts (w = 0) from the old model's value at the renewal, so the
right-hand side does not jump, where the beads went on about as before
(:data:`CONTINUE_W`), else from S_k, with a jump of the extrapolation's error
(:meth:`FrozenMobility.renew`). It is a function of the state alone, with no lag behind
the shape (a time ramp from one ΔM to the next lags by a whole interval). ``w`` is held
within [:data:`W_LO`, :data:`W_HI`]. CVODE's Python
callback writes the model's value into the kernels' ΔM per right-hand side
(:func:`secant_mobility`; for a cell body it sets w, as the BDF does: 7.3 µs per
right-hand side at N = 50 spent writing the matrix); the BDF's compiled right-hand side only sets w
(:func:`secant_weight`, the kernels' prm[P_SECANT]) and the kernel applies B_k F + w (G_k F),
G_k being the kernels' DG: two matrix–vector products instead of writing the matrix (8.7 →
5.2 µs per right-hand side at N = 50). The renewals are compiled too (:func:`renew_secant`),
and the BDF runs their loop (:meth:`FrozenMobility.advance`) compiled.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..hydro.dynamics import bond_change, renew_into
from ..rod.kernels import P_SECANT
from ..rod.model import positions as m_positions

#: the secant parameters (the float array of :func:`secant_mobility`): whether the secant
#: model is on (1; 0: ΔM stays as built), the w it applied last (NaN: none yet), and how
#: many renewals in a row on one trajectory the history holds (the last, and the one before:
#: 2 lets the next renewal fit its quadratic)
R_ACTIVE, R_W, R_HIST = range(3)
#: the range w is held to: w = 0 at the last renewal, −1 at the one before; the next renewal
#: comes near w = 1
W_LO, W_HI = -1.5, 2.5
#: the fraction of the limits (bead displacement over ``refresh``, bond change over the
#: turn limit) that a planned interval uses; past EARLY_USE at the half-way check, ΔM is
#: renewed there; the longest and the shortest next interval relative to the last
TARGET_USE = 1.0
EARLY_USE = 1.5
PLAN_GROWTH, PLAN_SHRINK = 1.25, 0.25
#: the range of the position w₂ of the renewal before last (on the axis of the last
#: displacement, the last renewal at −1) within which the slope takes the quadratic's
#: curvature: roughly the same direction and interval as the last one
QUAD_W2 = (-3.0, -1.25)
#: the range of the old model's w at a renewal within which the new model continues from the
#: old one's value (no jump; the old error carried on, times 1 − w, at most ½)
CONTINUE_W = (0.5, 1.5)
#: a cell body's renewal turns ΔM per right-hand side over the next interval
#: (:meth:`FrozenMobility.apply`) where the best rotation of its points left less than this
#: share of the limits' use since the last renewal (the E. coli-like cell: 0.10 median;
#: on a 1-µm sphere with the paper's free hook, which does not swim steadily, more: there
#: the secant took 2 949 steps in 0.1 s and the turn 4 996, off the unfrozen run by 1.9e-3)
TURN_SHARE = 0.5


@njit(cache=True)
def _secant_w(y, xu):
    """w(y) = xu[1] · (x(y) − xu[0]) (x the bead positions of the state y), held within
    [:data:`W_LO`, :data:`W_HI`]."""
    nb = xu.shape[1] // 3
    w = 0.0
    for i in range(nb):
        for c in range(3):
            w += xu[1, 3 * i + c] * (y[3 + 4 * i + c] - xu[0, 3 * i + c])
    return min(W_HI, max(W_LO, w))


@njit(cache=True)
def secant_weight(y, xu, rp):
    """The model's w at y (0 with the model off): what the kernel's prm[P_SECANT] is set to
    where ΔM is applied as base + w G (:mod:`flagellum.rod.kernels`), as the BDF does."""
    if rp[R_ACTIVE] == 0.0:
        return 0.0
    return _secant_w(y, xu)


@njit(cache=True)
def secant_mobility(y, dm, base, G, xu, rp):
    """ΔM(y) = base + w G with w = xu[1] · (x(y) − xu[0]) (x the bead positions of the
    state y), written into ``dm`` when w has changed (no-op with the model off)."""
    if rp[R_ACTIVE] == 0.0:
        return
    w = _secant_w(y, xu)
    if w == rp[R_W]:
        return
    m = dm.shape[0]
    for i in range(m):
        for j in range(m):
            dm[i, j] = base[i, j] + w * G[i, j]
    rp[R_W] = w


@njit(cache=True)
def secant_before(y, dm, sample, xu, rp):
    """The first half of :meth:`FrozenMobility.renew`, before ΔM is renewed: (carry, w*),
    the old model's w at y and whether the new model continues from its value there (w*
    within :data:`CONTINUE_W`). (Re)started (model off), ``sample`` := ``dm``, the ΔM built
    last: the one a renewal compares with and turns, and the secant's start (a history of
    one)."""
    if rp[R_ACTIVE] == 0.0:
        m = dm.shape[0]
        for i in range(m):
            for j in range(m):
                sample[i, j] = dm[i, j]
        rp[R_HIST] = 1.0
        return False, 0.0
    w = _secant_w(y, xu)
    return CONTINUE_W[0] <= w <= CONTINUE_W[1], w


@njit(cache=True)
def secant_after(dm, sample, base, G, xu, rp, x_prev, x_new, carry, w_star, older, x_older):
    """The second half of :meth:`FrozenMobility.renew`, ΔM renewed in ``dm`` (S_k+1) at the
    beads ``x_new`` (flat), the last renewal S_k (``sample``) at ``x_prev``, the one before,
    S_k−1 (``older``), at ``x_older``, in one pass. The slope is the chord from the model's
    start to the quadratic through the three renewals one interval on: on the axis
    w = d · (x − x_k+1)/|d|² (d = x_k+1 − x_k; S_k at w = −1, S_k−1 at w₂), that quadratic is
    P(w) = S_k+1 + w A + w (w + 1) Q with A = S_k+1 − S_k and
    Q = (A − (S_k − S_k−1)/(−1 − w₂))/(−w₂), so G = P(1) − start = A + 2Q − (start − S_k+1).
    The start is S_k+1, or with ``carry`` the old model's value C = base + w* G at the
    renewal (no jump). Q is taken where the history holds S_k−1 on this trajectory, the old
    model was carried (the beads went on as they did) and w₂ lies within :data:`QUAD_W2`;
    else Q = 0 (the secant of the last two). ``dm`` := the base (the model at w = 0),
    ``sample`` := S_k+1, ``older`` := S_k, (x_k+1, d/|d|²) set and the model on."""
    m = dm.shape[0]
    dd = 0.0
    for i in range(x_new.shape[0]):
        d = x_new[i] - x_prev[i]
        dd += d * d
    cq, cs = 0.0, 0.0  # G += cq (A − cs (S_k − S_k−1)), the 2Q term
    if carry and rp[R_HIST] >= 2.0 and dd > 0.0:
        w2 = 0.0
        for i in range(x_new.shape[0]):
            w2 += (x_new[i] - x_prev[i]) * (x_older[i] - x_new[i])
        w2 /= dd
        if QUAD_W2[0] <= w2 <= QUAD_W2[1]:
            cq, cs = 2.0 / (-w2), 1.0 / (-1.0 - w2)
    for i in range(m):
        for j in range(m):
            s_new = dm[i, j]
            s_old = sample[i, j]
            g = s_new - s_old
            b = s_new
            if carry:
                b = base[i, j] + w_star * G[i, j]
                g -= b - s_new
            if cq != 0.0:
                g += cq * ((s_new - s_old) - cs * (s_old - older[i, j]))
            older[i, j] = s_old
            G[i, j] = g
            sample[i, j] = s_new
            base[i, j] = b
            dm[i, j] = b
    for i in range(x_new.shape[0]):
        x_older[i] = x_prev[i]
        xu[0, i] = x_new[i]
        xu[1, i] = (x_new[i] - x_prev[i]) / dd if dd > 0.0 else 0.0
    rp[R_ACTIVE], rp[R_W] = 1.0, 0.0
    rp[R_HIST] = min(rp[R_HIST] + 1.0, 3.0)


@njit(cache=True)
def renew_secant(y, x, dm, work, secant, frozen, turn, build):
    """:meth:`FrozenMobility.renew` compiled, for a model whose renewal is compiled (no cell
    body; :func:`~flagellum.hydro.dynamics.renew_into` with ``turn`` and ``build``): x the
    bead positions of y, ``work`` (sample, x_prev), ``secant`` (base, G, xu, rp)."""
    sample, x_prev, older, x_older = work
    base, G, xu, rp = secant
    carry, w_star = secant_before(y, dm, sample, xu, rp)
    n1 = frozen.shape[0]
    for i in range(n1):
        for a in range(3):
            x_prev[3 * i + a] = frozen[i, a]
    renew_into(x, frozen, sample, dm, turn, build)  # turned from the last renewal
    secant_after(dm, sample, base, G, xu, rp, x_prev, frozen.ravel(), carry, w_star, older,
                 x_older)


# the plan of renewals: F_LAST the time of the last one, F_PLAN the planned interval to the
# next (0: plan from the bead speeds), F_COUNT the renewals at planned sub-targets so far
F_LAST, F_PLAN, F_COUNT = range(3)


@njit(cache=True)
def next_target(plan, tc, t):
    """(tn, due): the next sub-target after tc towards t (the planned renewal or the half-way
    check before it) and the planned renewal time."""
    due = plan[F_LAST] + plan[F_PLAN]
    return min(t, due, tc + 0.5 * plan[F_PLAN]), due


@njit(cache=True)
def renewal_due(tn, due, used):
    """Whether ΔM is renewed at the sub-target tn: the planned time reached, or the limits
    used past :data:`EARLY_USE`."""
    return tn >= due - 1e-12 * max(1.0, abs(due)) or used > EARLY_USE


@njit(cache=True)
def replan(plan, tn, used):
    """After a renewal at tn, where the limits' use over the interval since the last was
    ``used``: the next interval from this one, scaled to use :data:`TARGET_USE` of the limits
    (within [:data:`PLAN_SHRINK`, :data:`PLAN_GROWTH`] times it)."""
    interval = tn - plan[F_LAST]
    plan[F_LAST] = tn
    plan[F_COUNT] += 1.0
    if used > 0:
        plan[F_PLAN] = min(PLAN_GROWTH, max(PLAN_SHRINK, TARGET_USE / used)) * interval


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
        # the slope G is the kernels' DG: the BDF applies ΔM as DM + w DG (DM = the base)
        G = model.kernel_arrays[-1][-2] if self.active else np.zeros((0, 0))
        self.arrays = (np.zeros((size, size)), G, np.zeros((2, 3 * nb)), np.zeros(3))
        #: the ΔM renewed last (turns and comparisons start from it) and the beads of the
        #: last renewal, the ΔM renewed before it and its beads (work arrays of :meth:`renew`)
        self.work = (np.zeros((size, size)), np.zeros(3 * nb), np.zeros((size, size)),
                     np.zeros(3 * nb))
        #: the plan of renewals (:data:`F_LAST`, :data:`F_PLAN`, :data:`F_COUNT`)
        self.plan = np.zeros(3)
        #: a cell body's ΔM turned per right-hand side in this interval (else the secant)
        self.turning = False
        self._renewal = None  # (renewal_arguments, built at the first renewal)
        self.reset(0.0)

    def renewal_arguments(self) -> tuple:
        """(x, turn, build, refresh, bond) of a compiled renewal (:func:`renew_secant`, the
        BDF's loop): scratch for the bead positions, the arguments of the turn and of the
        build (:meth:`RodModel.turn_arguments <flagellum.rod.model.RodModel.turn_arguments>`,
        :meth:`~flagellum.rod.model.RodModel.build_arguments`) and the renewal limits (a
        displacement and a bond change), all fixed for the model: made once. Not for a cell
        body, whose build is not compiled."""
        if self._renewal is None:
            m = self.model
            self._renewal = (np.empty((m.n + 1, 3)), m.turn_arguments(), m.build_arguments(),
                             float(m.hydrodynamics.refresh), float(m.turn_limit * m.h))
        return self._renewal

    @property
    def renewals(self) -> int:
        """The renewals of ΔM at planned sub-targets since construction."""
        return int(self.plan[F_COUNT])

    @property
    def last(self) -> float:
        """The time of the last renewal."""
        return float(self.plan[F_LAST])

    def reset(self, t0: float) -> None:
        """Start over at t0 (a restarted stepper): the ΔM built last as it is, no secant and
        no turn yet (a resumed run's new stepper starts so too), the next interval planned
        from the bead speeds."""
        self._off()
        self.turning = False
        self.model.unturn_mobility()
        self.plan[F_LAST], self.plan[F_PLAN] = float(t0), 0.0

    def _off(self) -> None:
        """The secant model off: ΔM applied as it is in DM."""
        self.arrays[3][:] = (0.0, np.nan, 0.0)
        self.model.prm[P_SECANT] = 0.0

    def restart_at(self, t: float, y: np.ndarray) -> None:
        """ΔM rebuilt at the beads of y (the stepper's history carried through a change of
        coordinates that moved the past positions) and the secant model off until the next
        renewal starts it from there; the planned interval kept, counted from t."""
        self.model.refresh_mobility(y, force=True)
        self._off()
        self.plan[F_LAST] = float(t)

    def apply(self, y: np.ndarray) -> None:
        """Set the kernel's ΔM to the secant model's value at y; in a cell body's turning
        interval (:attr:`turning`, :data:`TURN_SHARE`): ΔM turned by the best rotation of the
        frozen points onto y's (:meth:`RodModel.turn_mobility
        <flagellum.rod.model.RodModel.turn_mobility>`), no secant. A swimming cell turns as a
        whole, body and filament about their axis, tilted from the frame's e_z as it
        precesses: the turn takes up nine tenths of the beads' displacement between
        renewals (E. coli-like cell, docs/hydrodynamics.md, "Integration")."""
        m = self.model
        if self.turning:
            m.turn_mobility(y)
        elif m.cell:  # the kernel applies DM + w DG (DM holds the base, DG is G), as the BDF's
            m.prm[P_SECANT] = secant_weight(y, self.arrays[2], self.arrays[3])
        elif self.arrays[3][R_ACTIVE]:
            secant_mobility(y, m.kernel_arrays[-1][-1], *self.arrays)

    def renew(self, y: np.ndarray) -> None:
        """Renew ΔM at the beads of y (turned or rebuilt) and set the secant from the last
        renewal to this one. With S_k the ΔM renewed k-th and C the old model's value at y
        (where its w was w*), the new model is C + w (2 S_k+1 − S_k − C): no jump at y, and
        one interval on (w = 1) the secant's extrapolation 2 S_k+1 − S_k. The old model's
        error at y, E = C − S_k+1, then reaches the next renewal as (1 − w*) E, so this is
        done only for w* within :data:`CONTINUE_W` (the beads went on about as they did:
        the error shrinks at least 2×); otherwise the new model starts at S_k+1 (a jump of E,
        and no error carried). One compiled call without a cell body (:func:`renew_secant`,
        which the BDF's compiled loop calls too). A cell body whose points moved mostly as a
        rigid turn since the last renewal (:data:`TURN_SHARE`) has ΔM rebuilt at y and turned
        per right-hand side over the next interval (:meth:`apply`), with no secant."""
        m = self.model
        dm = m.kernel_arrays[-1][-1]
        if m.frozen_beads is None:  # nothing built yet
            m.refresh_mobility(y, force=True)
        m.prm[P_SECANT] = 0.0  # (the model starts at w = 0)
        if not m.cell:
            x, turn, build = self.renewal_arguments()[:3]
            x[:] = m_positions(y)
            renew_secant(y, x, dm, self.work, self.arrays, m.frozen_beads, turn, build)
            return
        # a cell body: turned per right-hand side where the turn took up most of the beads'
        # displacement since the last renewal, else the secant
        raw, turned = m.mobility_use(y), m.mobility_use(y, rotated=True)
        self.turning = turned < TURN_SHARE * raw
        if self.turning:
            m.refresh_mobility(y, force=True)
            self._off()
            return
        sample, x_prev, older, x_older = self.work
        base, G, xu, rp = self.arrays
        active = rp[R_ACTIVE] != 0.0
        carry, w_star = secant_before(y, dm, sample, xu, rp)
        if active:
            dm[:] = sample  # a renewal turns the ΔM renewed last, not the model's value
        x_prev[:] = m.frozen_beads.ravel()
        m.refresh_mobility(y, due=True)
        secant_after(dm, sample, base, G, xu, rp, x_prev,
                     np.ascontiguousarray(m.frozen_beads).ravel(), carry, w_star, older, x_older)

    def begin(self, t_from: float, y_from: np.ndarray, t: float) -> None:
        """Before advancing from (t_from, y_from) towards t: after a (re)start, the first
        interval planned from the bead speeds now (which builds ΔM if none is)."""
        if self.plan[F_PLAN] > 0:
            return
        m = self.model
        refresh, bond = m.hydrodynamics.refresh, m.turn_limit * m.h
        u = m_positions(m.rhs(t_from, y_from))
        rate = max(float(np.max(np.abs(u))) / refresh, bond_change(u) / bond)
        plan = TARGET_USE / rate if rate > 0 else t - t_from
        if bond < 2 * refresh:
            # the bond limit can bind (fine filaments): passing it is unstable, not just
            # less accurate, and from rest the bonds speed up 40-fold within microseconds
            # (N = 400), so begin with a small part and let the intervals grow
            plan *= FIRST_SUB_FRACTION
        self.plan[F_LAST], self.plan[F_PLAN] = min(self.plan[F_LAST], t_from), plan

    def advance(self, t_from: float, y_from: np.ndarray, t: float, step):
        """Advance from (t_from, y_from) to t through sub-targets, ``step(tn)`` returning
        (ok, y at tn, result), renewing ΔM at the planned times. Returns the last ``result``
        (also the failed one). (The BDF runs the same loop compiled: :func:`flagellum.integrate.bdf.bdf_frozen_advance`.)"""
        m = self.model
        self.begin(t_from, y_from, t)
        tc = t_from
        while True:
            tn, due = next_target(self.plan, tc, t)
            ok, y, res = step(tn)
            if not ok:
                return res
            used = m.mobility_use(y, rotated=self.turning)
            if renewal_due(tn, due, used):
                self.renew(y)
                replan(self.plan, tn, used)
            tc = tn
            if tn >= t:
                return res
