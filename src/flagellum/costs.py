"""Where a run's wall time goes: the ``limit`` of each benchmark regime (:mod:`flagellum.bench`).

:func:`instrumented` times, during one ordinary run, the calls the run loop makes
(:meth:`Simulator.run <flagellum.simulator.Simulator.run>`): the stepper's ``advance``
(the integrator), its ``carry`` and ``reset`` (chart changes and restarts), the records,
the chart checks and the co-rotating frame's adaptation; the rest of the run's wall time is the loop's
own Python. Nothing in the run's numerics changes: the wrappers are instance attributes
that call the original methods, ~0.2 µs each.

:func:`limit` then splits the integrator's time, which one compiled call per stop hides,
by counts × unit costs: the stepper's counters (steps, right-hand sides, Jacobians,
factorizations, Newton iterations) times the cost of one call of each compiled piece,
timed right after the run at its final state (each piece repeated inside one compiled loop,
so that no Python dispatch is counted in it), plus the fixed cost of a stop (the stepper's
Python and the compiled call's dispatch, timed as a call that takes no step). What is left
of the integrator's time is its bookkeeping (predictor, error control, order and step
changes, the difference array; for the fixed-step scheme also the charts and the Anderson
update). The shares are of the run's wall time and sum to 1. They are grouped by what
their number scales with (:data:`GROUPS`); ``dominant`` is the largest group, ``piece``
the largest share, and ``next_step`` the action :data:`NEXT_STEP` names for that group,
with the run's counts filled in.
"""

from __future__ import annotations

import contextlib
import copy
import math
import time

import numpy as np
from numba import njit

from . import _jit  # noqa: F401  (the kernels' cache settings, before any cache=True kernel)
from .integrate import bdf as B
from .integrate import brownian as BR
from .integrate.banded import band_factor, band_solve
from .rod import kernels as K

#: the pieces of the wall time grouped by what their number scales with: Newton iterations,
#: Jacobian renewals (with their factorizations), steps, and stops and records (the run loop)
GROUPS = {
    "newton_iterations": ("rhs", "solve", "anderson"),
    "jacobians": ("jacobian", "factorization"),
    "steps": ("noise", "charts", "per_step_python", "bookkeeping"),
    "run_loop": ("per_stop", "records", "chart_checks", "frame", "chart_changes", "loop"),
    "integrator": ("integrator",),  # a stepper whose time is not split
}
#: the largest group → the next step named for it ({} filled from the run's counts)
NEXT_STEP = {
    "newton_iterations": "fewer Newton iterations per step (now {iterations_per_step:.2g}): a "
                         "better predictor or a faster-contracting iteration; the largest "
                         "piece is {piece}",
    "jacobians": "fewer Jacobian renewals and refactorizations (now {jacobians_per_step:.2g} "
                 "and {factorizations_per_step:.2g} per step): keep them longer; the largest "
                 "piece is {piece}",
    "steps": "fewer steps (now {steps_per_revolution:.3g} per motor revolution) or less "
             "work per step outside Newton's iteration; the largest piece is {piece}",
    "run_loop": "less Python per record and per chunk (records, chart checks, the frame's "
                "adaptation); the largest piece is {piece}",
    "integrator": "a split of this stepper's cost (only the BDF and BDF2 are split)",
}
#: repetitions of each compiled piece when its unit cost is timed
REPEATS = 200


class Clock:
    """Seconds and calls per key, counted only while ``on``."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self.on = False
        self.stepper = None

    def wrap(self, fn, key):
        def timed(*a, **k):
            if not self.on:
                return fn(*a, **k)
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                self.seconds[key] = self.seconds.get(key, 0.0) + time.perf_counter() - t0
                self.calls[key] = self.calls.get(key, 0) + 1
        return timed


@contextlib.contextmanager
def instrumented(sim):
    """Time the run loop's calls of ``sim`` while the block runs (see module docstring);
    yields the :class:`Clock` (``clock.stepper``: the last run's stepper)."""
    clock = Clock()
    make = sim._stepper
    model = sim.model

    def stepper():
        s = make()
        for name, key in (("advance", "integrator"), ("carry", "chart_changes"),
                          ("reset", "chart_changes")):
            if hasattr(s, name):
                setattr(s, name, clock.wrap(getattr(s, name), key))
        clock.stepper = s
        clock.on = True  # the run's wall time starts after the stepper is built
        return s

    patched = {"_stepper": stepper, "_record": clock.wrap(sim._record, "records"),
               "_adapt_frame": clock.wrap(sim._adapt_frame, "frame")}
    for name, fn in patched.items():
        setattr(sim, name, fn)
    model.rechart = clock.wrap(model.rechart, "chart_checks")
    try:
        yield clock
    finally:
        clock.on = False
        for name in patched:
            delattr(sim, name)
        del model.rechart


# -- unit costs: each compiled piece repeated in one compiled loop -----------------------
@njit(cache=True)
def _repeat_bdf_rhs(k, t, y, f, ka, drive, general):
    for _ in range(k):
        B._fun(t, y, f, ka, drive, general)


@njit(cache=True)
def _repeat_bdf_jacobian(k, t, y, f, ka, drive, kl, ku, jab, yw, fw, color, lo, hi, ist, general):
    for _ in range(k):
        B._jacobian(t, y, f, ka, drive, kl, ku, jab, yw, fw, color, lo, hi, ist, general)


@njit(cache=True)
def _repeat_factor(k, c, jab, lu, kl, ku, ipiv, backup, ist):
    for _ in range(k):
        B._factor(c, jab, lu, kl, ku, ipiv, backup, ist)


@njit(cache=True)
def _repeat_band_factor(k, ab, lu, kl, ku, ipiv, backup):
    for _ in range(k):
        lu[:, :] = ab
        band_factor(lu, kl, ku, ipiv, backup)


@njit(cache=True)
def _repeat_solve(k, lu, kl, ku, ipiv, b0, b, pivoted, work):
    for _ in range(k):
        b[:] = b0  # (solving the same right-hand side: no drift to denormals)
        band_solve(lu, kl, ku, ipiv, b, pivoted, work)


@njit(cache=True)
def _repeat_rhs(k, general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws):
    for _ in range(k):
        K.model_rhs(general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws)


@njit(cache=True)
def _repeat_colored(k, general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws, kl, ku,
                    ab, scale, yw, fw, color, lo, hi, ipiv, backup):
    for _ in range(k):
        K.model_colored_jacobian(general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws,
                                 kl, ku, ab, scale, yw, fw, color, lo, hi)
        for j in range(ab.shape[0]):
            ab[j, kl + ku] += 1.0
        band_factor(ab, kl, ku, ipiv, backup)


@njit(cache=True)
def _repeat_thermal(k, y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, b, yp, ym, f1, f2, zf,
                    zm, zh, xi_f, xi_m, xi_h, general):
    for _ in range(k):
        BR.thermal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, b, yp, ym, f1, f2,
                             zf, zm, zh, xi_f, xi_m, xi_h, zf[:0], general)


@njit(cache=True)
def _repeat_anderson(k, y0, y, d, f_prev, g_prev, df, dg, a, gam, m):
    for _ in range(k):
        y[:] = y0
        BR._anderson(y, d, f_prev, g_prev, df, dg, a, gam, m, m)


@njit(cache=True)
def _repeat_charts(k, y, n, ref_u, ref_e, ws):
    for _ in range(k):
        K.rechart_all(y, n, ref_u, ref_e, ws[0], ws[1], ws[2], ws[3], ws[4], ws[9])


def _seconds(fn, k=REPEATS) -> float:
    """Seconds per repetition of ``fn(k)``: the median of five, after one untimed call (the
    median, not the best: the run it is compared with shared the machine as it was)."""
    fn(1)
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        fn(k)
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) / k


def _copies(arrays):
    return tuple(_copies(a) if isinstance(a, tuple) else
                 (a.copy() if isinstance(a, np.ndarray) else a) for a in arrays)


def _bdf_unit_costs(s) -> tuple[dict, dict]:
    """Unit costs [s] and counts of a :class:`~flagellum.integrate.bdf.BdfStepper` run."""
    m = s.model
    general = K.general_flag(m.iprm)
    ka = _copies(m.kernel_arrays)
    t = float(s._st[B.S_T])
    drive = (s._drive_for(t), s._frozen.arrays)
    y = s.y.copy()
    n = len(y)
    kl, ku = s._kl, s._ku
    color, lo, hi = m.jacobian_colors(kl, ku)
    f, yw, fw = np.zeros(n), np.zeros(n), np.zeros(n)
    jab, lu = s._jab.copy(), s._lu.copy()
    ipiv, backup = s._ipiv.copy(), s._backup.copy()
    ist = np.zeros(B.N_ISTATE, np.int64)
    B._fun(t, y, f, ka, drive, general)
    unit = {"rhs": _seconds(lambda k: _repeat_bdf_rhs(k, t, y, f.copy(), ka, drive, general))}
    jac = _seconds(lambda k: _repeat_bdf_jacobian(k, t, y, f.copy(), ka, drive, kl, ku, jab, yw,
                                                  fw, color, lo, hi, ist, general))
    ist[:] = 0
    B._jacobian(t, y, f.copy(), ka, drive, kl, ku, jab, yw, fw, color, lo, hi, ist, general)
    rhs_per_jacobian = int(ist[B.I_RHS])  # its own f plus the chain rule's (or the colours')
    unit["jacobian"] = max(jac - unit["rhs"], 0.0)  # its f is counted with the rhs
    c = float(s._st[B.S_C]) or 1e-6
    unit["factorization"] = _seconds(lambda k: _repeat_factor(k, c, jab, lu, kl, ku, ipiv, backup, ist))
    pivoted = bool(ist[B.I_PIVOTED])
    b0 = np.random.default_rng(0).standard_normal(n)
    work = np.empty(n + 2 * (kl + ku))
    unit["solve"] = _seconds(lambda k: _repeat_solve(k, lu, kl, ku, ipiv, b0, b0.copy(), pivoted, work))
    # a stop: the stepper's Python and the compiled call, taking no step (interpolation only)
    probe = copy.copy(s)
    t_in = float(s._st[B.S_T])

    def stops(k):
        for _ in range(k):
            probe.t = -math.inf
            probe._advance(t_in, renew=False)
    unit["per_stop"] = _seconds(stops, 50)
    st = s.stats
    starts = st["jacobians_at_start"]
    newton = max(st["rhs"] - 2 * starts - rhs_per_jacobian * st["jacobians"], 0)
    counts = {"steps": st["steps"], "rhs": newton + 2 * starts + st["jacobians"],
              "jacobians": st["jacobians"], "factorizations": st["factorizations"],
              "solves": newton, "newton_iterations": newton, "starts": starts}
    return unit, counts


def _implicit_unit_costs(s) -> tuple[dict, dict]:
    """Unit costs [s] and counts of an :class:`~flagellum.integrate.brownian.ImplicitStepper` run."""
    m = s.model
    general = K.general_flag(m.iprm)
    prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws = _copies(m.kernel_arrays)
    y = s.y.copy()
    n = len(y)
    kl, ku = s._kl, s._ku
    color, lo, hi = m.jacobian_colors(kl, ku)
    f, yw, fw = np.zeros(n), np.zeros(n), np.zeros(n)
    ab, ipiv, backup = s._ab.copy(), s._ipiv.copy(), s._backup.copy()
    unit = {"rhs": _seconds(lambda k: _repeat_rhs(k, general, y, f, prm, iprm, ref_u, ref_e, ref_m,
                                                  zf, zm, zh, ws))}
    # the Jacobian and the factorization of I − βΔtJ come together in this scheme
    both = _seconds(lambda k: _repeat_colored(k, general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf,
                                              zm, zh, ws, kl, ku, ab, -2.0 / 3.0 * s.dt, yw, fw,
                                              color, lo, hi, ipiv, backup))
    ab[:, :] = 0.0
    K.model_colored_jacobian(general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws, kl, ku,
                             ab, -2.0 / 3.0 * s.dt, yw, fw, color, lo, hi)
    for j in range(n):
        ab[j, kl + ku] += 1.0
    lu = ab.copy()
    unit["factorization"] = _seconds(lambda k: _repeat_band_factor(k, ab, lu, kl, ku, ipiv, backup))
    lu[:, :] = ab
    pivoted = bool(band_factor(lu, kl, ku, ipiv, backup)[1])
    unit["jacobian"] = max(both - unit["factorization"], 0.0)
    b0 = np.random.default_rng(0).standard_normal(n)
    work = np.empty(n + kl + ku)
    unit["solve"] = _seconds(lambda k: _repeat_solve(k, lu, kl, ku, ipiv, b0, b0.copy(), pivoted, work))
    counts = {"steps": s.n_steps, "rhs": s.n_iter, "jacobians": s.n_jac,
              "factorizations": s.n_jac, "solves": s.n_iter, "newton_iterations": s.n_iter}
    if s.kT > 0:
        n1 = m.n + 1
        g = np.random.default_rng(1).standard_normal(s._n_normals)
        arrays = [np.zeros(n) for _ in range(5)]
        z3, z1, zhh = np.zeros((n1, 3)), np.zeros(n1), np.zeros(len(zh))
        unit["noise"] = _seconds(lambda k: _repeat_thermal(
            k, y, s.dt, s.kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, *arrays, z3.copy(), z1.copy(),
            zhh.copy(), z3.copy(), z1.copy(), zhh.copy(), general))
        counts["noise"] = s.n_steps
    # per step the charts are centred on the tangents, per iteration that does not converge
    # an Anderson update (timed with a full history: an upper bound)
    unit["charts"] = _seconds(lambda k: _repeat_charts(k, y.copy(), m.n, ref_u.copy(),
                                                       ref_e.copy(), ws))
    counts["charts"] = s.n_steps
    rng0 = np.random.default_rng(2)
    am = 4
    unit["anderson"] = _seconds(lambda k: _repeat_anderson(
        k, y, y.copy(), 1e-6 * rng0.standard_normal(n), np.zeros(n), np.zeros(n),
        1e-6 * rng0.standard_normal((am, n)), 1e-6 * rng0.standard_normal((am, n)),
        np.zeros((am, am)), np.zeros(am), am))
    counts["anderson"] = max(s.n_iter - s.n_steps, 0)
    # per step in Python: the noise draws and the motor's torque at each step's end
    rng = copy.deepcopy(s.rng)
    times = s.t + s.dt * np.arange(1, REPEATS + 1)

    def python_steps(k):
        for _ in range(k):
            if s._n_normals:
                rng.standard_normal((REPEATS, s._n_normals))
            np.array([m.motor(x) for x in times])
    unit["per_step_python"] = _seconds(python_steps, 5) / REPEATS
    counts["per_step_python"] = s.n_steps
    return unit, counts


#: the unit-cost keys of a stepper's time, in the order they are reported → their counts
_PIECES = {"rhs": "rhs", "jacobian": "jacobians", "factorization": "factorizations",
           "solve": "solves", "noise": "noise", "charts": "charts", "anderson": "anderson",
           "per_step_python": "per_step_python", "per_stop": "stops"}


def limit(clock: Clock, wall: float, revolutions: float) -> dict:
    """What limits the instrumented run of ``clock`` (:func:`instrumented`) that took ``wall``
    seconds and turned the motor ``revolutions`` times: the shares of the wall time (module
    docstring) and their groups (:data:`GROUPS`), the largest group (``dominant``, ``share``)
    and piece (``piece``, ``piece_share``), the counts and unit costs [µs] they come from,
    Newton iterations, Jacobians and factorizations per step, steps per revolution and
    ``next_step`` (:data:`NEXT_STEP`)."""
    sec = clock.seconds
    outer = {k: sec.get(k, 0.0) for k in ("records", "chart_checks", "frame", "chart_changes")}
    integ = sec.get("integrator", 0.0)
    s = clock.stepper
    inner, unit, counts = {}, {}, {}
    if isinstance(s, B.BdfStepper):
        unit, counts = _bdf_unit_costs(s)
    elif isinstance(s, BR.ImplicitStepper):
        unit, counts = _implicit_unit_costs(s)
    counts["stops"] = clock.calls.get("integrator", 0)
    counts["chart_changes"] = clock.calls.get("chart_changes", 0)
    counts["records"] = clock.calls.get("records", 0)
    if unit:
        for key, count in _PIECES.items():
            if key in unit:
                inner[key] = counts[count] * unit[key]
        est = sum(inner.values())
        scale = min(1.0, integ / est) if est > 0 else 1.0  # never more than the measured time
        inner = {k: v * scale for k, v in inner.items()}
        inner["bookkeeping"] = max(integ - sum(inner.values()), 0.0)
    else:
        inner["integrator"] = integ
        scale = 1.0
    parts = {**inner, **outer}
    parts["loop"] = max(wall - sum(parts.values()), 0.0)
    total = max(wall, sum(parts.values()), 1e-12)
    shares = {k: round(v / total, 4) for k, v in parts.items()}
    groups = {g: round(sum(shares.get(k, 0.0) for k in keys), 4) for g, keys in GROUPS.items()
              if any(k in shares for k in keys)}
    dominant = max(groups, key=groups.get)
    piece = max(shares, key=shares.get)
    steps = counts.get("steps", getattr(s, "n_steps", 0))
    per_step = 1.0 / max(steps, 1)
    rates = {"iterations_per_step": counts.get("newton_iterations", 0) * per_step,
             "jacobians_per_step": counts.get("jacobians", 0) * per_step,
             "factorizations_per_step": counts.get("factorizations", 0) * per_step,
             "steps_per_revolution": steps / max(revolutions, 1e-12)}
    return {"dominant": dominant, "share": groups[dominant], "groups": groups,
            "piece": piece, "piece_share": shares[piece], "shares": shares,
            "integrator_share": round(integ / total, 4),
            "microseconds_per_step": 1e6 * wall / max(steps, 1), **rates,
            "unit_microseconds": {k: round(1e6 * v, 3) for k, v in unit.items()},
            "counts": counts, "estimate_scale": round(scale, 4),
            "next_step": NEXT_STEP[dominant].format(piece=piece, **rates)}
