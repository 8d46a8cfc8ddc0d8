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

With thermal noise (a run at kT > 0) two of the buckled-state signatures no longer tell the
regimes apart: the instantaneous thrust fluctuates by about twice its mean (the thermal
forces on the beads next to the anchor), and the centroid leaves the motor axis because the
whole aligned filament tilts thermally about its free hook joint (by 5–9° for the paper's
filament at room temperature, against 1.5° without noise). A thermal window is therefore
called buckled by its change of shape alone: σ/σ0 above :func:`sigma_buckled`, the level of
the thermal fluctuations of r scaled with √(kT) (equipartition: every mode's amplitude grows
as √kT). The other regimes keep their criteria (the mean thrust, the tilt beyond 45°, the
collapses of (iv)).

A **free swimmer** (``anchor="free"``: a centred body sphere or a cell body) carries its motor
axis with it, and its base wobbles and circles the swimming axis: the centroid leaves the lab's
e_z axis and the force on bead 0 along e_z oscillates while the filament keeps its shape (a
free cell with the paper's filament, a = 0.5 µm, M = 1 pN·µm: centroid 0.32 R off the axis and
a thrust std of 11 % of its mean after 0.02 s, at σ/σ0 = 0.09). A free swimmer's window is
therefore called buckled by its change of shape alone, σ/σ0 above :data:`SIGMA_BUCKLED`, as a
thermal one, and its tilt is measured from the body's motor axis m(t) (the initial e_z turned
with the body), not from e_z.

With an **end load** (:class:`~flagellum.params.EndLoad`, pulling the free end along −e_z) the
force on the anchor carries the load (−end_force in steady state), so the sign test of regime
(i) uses the motor's own thrust, the anchor force plus the end load. A window in which the
motor applies **no torque** (M = 0 throughout: a filament at rest or stretched by a load) has
no regime of the driven filament; it is aligned unless its shape changes (σ/σ0) or it turns
away (the tilt): neither the sign of a vanishing thrust (round-off) nor the centroid of a helix
that does not rotate (0.34 R off the axis for the 4-µm filament at rest) says anything.

A run that has not settled can look like another regime: the filament starts from the
stress-free helix, and its relaxation (the centroid drifting onto the motor axis, the thrust
settling) takes longer than a short run. :func:`assess` therefore also tests the window
itself: it measures the observables on the four quarters of the window, extrapolates their
significant linear trends over one more window of the same length, and calls the run
``transient`` when the regime of that extrapolation differs from the regime of the window
(the trend that flips it is named in ``drifting``). It also reports whether the averages
(thrust, ⟨r⟩, ω) have settled (``steady``). A slow instability whose growth is not yet
visible in the window (M just above M_c1) cannot be seen this way; linear stability
(:func:`flagellum.analysis.stability.linear_stability`) answers that.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .observables import Summary, end_to_end, summarize

REGIMES = ("reorienting", "aligned", "buckled", "oscillating")
#: the label of a run whose regime is not settled in its averaging window (:func:`assess`)
TRANSIENT = "transient"

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
#: thermal energy [pN·µm] at which :data:`SIGMA_THERMAL` was measured (room temperature, the
#: paper's kT)
KT_ROOM = 4.1e-3
#: σ/σ0 above which a thermal window is buckled at kT = KT_ROOM. Thermal runs of the paper's
#: filament (0.3 s, last half, seeds 1 and 2) give 0.20–0.39 aligned (M = 0.5–1.0 pN·µm, up
#: to 0.94 M_c1; the paper's 0.15–0.18, Sec. 3.1.2, further below M_c1) and 1.0–1.6 buckled
#: (M = 1.3–3): the threshold lies a factor 1.5 above the one and 1.7 below the other
SIGMA_THERMAL = 0.6
#: mean tilt [deg] of the end-to-end vector from −e_z beyond which the filament has turned away
TILT_REORIENTED = 45.0
#: a quarter-to-quarter trend counts when its slope exceeds this many standard errors
#: (Student's t at 95 % for the 2 degrees of freedom of a line through four points)
T_TREND = 4.3
#: an average has settled when its trend changes it by less than this fraction over one window
DRIFT_TOL = 0.02
#: fewest records of a window that :func:`assess` can test (four quarters of four)
MIN_SAMPLES = 16
#: a regime resting on a metric within this factor of its threshold is not sure while the
#: metric still changes across the window by more than CREEP times the threshold
MARGIN = 2.0
CREEP = 0.1


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
    kT: float = 0.0  #: thermal energy of the run's noise [pN·µm] (0: deterministic)
    free: bool = False  #: a free swimmer: buckled by σ/σ0 alone (module docstring)
    idle: bool = False  #: the motor applies no torque in the window (module docstring)

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


def _window(t, t_from: float | None) -> np.ndarray:
    """Records of the window t ≥ t_from (default: the last half; at least the last record)."""
    if t_from is None:
        t_from = t[0] + 0.5 * (t[-1] - t[0])
    sel = t >= t_from - 1e-12
    if not sel.any():
        sel[-1] = True
    return sel


def measure(t, thrust, positions, helix_radius: float, t_from: float | None = None,
            kT: float = 0.0, *, motor_axis=None, free: bool = False,
            end_force=None, motor_torque=None) -> RegimeMetrics:
    """Regime observables over the window t ≥ t_from (default: the last half) of a run with
    thermal noise at ``kT`` [pN·µm] (0: deterministic). ``motor_axis`` (n_t, 3): the motor
    axis of each record (default e_z), from which the tilt is measured; ``free``: a free
    swimmer; ``end_force`` (n_t,): an end load [pN], added to ``thrust``; ``motor_torque`` (n_t,):
    the motor torque [pN·µm], zero throughout the window: ``idle`` (module docstring)."""
    t = np.asarray(t, float)
    sel = _window(t, t_from)
    th = np.asarray(thrust, float)
    if end_force is not None:
        th = th + np.asarray(end_force, float)
    th = th[sel]
    pos = np.asarray(positions, float)[sel]
    r = end_to_end(pos)
    tip = pos[:, -1] - pos[:, 0]
    axis = np.array([0.0, 0.0, 1.0]) if motor_axis is None else np.asarray(motor_axis, float)[sel]
    along = tip[:, 2] if motor_axis is None else np.einsum("ij,ij->i", tip, axis)
    tilt = np.degrees(np.arccos(np.clip(-along / np.maximum(r, 1e-300), -1, 1)))
    centroid = np.hypot(*pos.mean(axis=1)[:, :2].T)
    return RegimeMetrics(
        thrust_mean=float(th.mean()), thrust_std=float(th.std()),
        sigma_over_sigma0=float(r.std() / (helix_radius / math.sqrt(2))), r_mean=float(r.mean()),
        centroid_offset=float(centroid.mean() / helix_radius), tilt_deg=float(tilt.mean()),
        swings=count_swings(r, SWING * helix_radius), samples=int(sel.sum()), kT=float(kT),
        free=bool(free),
        idle=motor_torque is not None and not np.any(np.asarray(motor_torque, float)[sel]))


def sigma_buckled(kT: float = 0.0) -> float:
    """σ/σ0 above which a window is buckled: :data:`SIGMA_BUCKLED` without noise, else
    :data:`SIGMA_THERMAL` scaled with √(kT/KT_ROOM) (never below SIGMA_BUCKLED)."""
    if kT <= 0:
        return SIGMA_BUCKLED
    return max(SIGMA_BUCKLED, SIGMA_THERMAL * math.sqrt(kT / KT_ROOM))


def decide(m: RegimeMetrics) -> str:
    """The regime of a window from its :class:`RegimeMetrics` (criteria: module docstring;
    a thermal window, kT > 0, and a free swimmer's are buckled by σ/σ0 alone)."""
    if m.thrust_mean < 0 and not m.idle:
        return "reorienting"
    if m.sigma_over_sigma0 > SIGMA_IV and m.swings >= 2:
        return "oscillating"
    if m.tilt_deg > TILT_REORIENTED:
        return "reorienting"
    if m.sigma_over_sigma0 > sigma_buckled(m.kT):
        return "buckled"
    if m.kT <= 0 and not (m.free or m.idle) and (m.centroid_offset > CENTROID_BUCKLED
                      or m.thrust_std > THRUST_BUCKLED * abs(m.thrust_mean)):
        return "buckled"
    return "aligned"


def classify(t, thrust, positions, helix_radius: float, axial_length: float | None = None,
             t_from: float | None = None, kT: float = 0.0, **frame) -> str:
    """Name the regime of the window t ≥ t_from (default: the last half) of a run with
    thermal noise at ``kT`` [pN·µm] (0: deterministic); ``frame``: the keywords of
    :func:`measure` (:func:`run_frame` of a trajectory).

    ``axial_length`` is accepted for compatibility and not used. The window is taken as it
    is; :func:`assess` also tests whether it has settled.
    """
    return decide(measure(t, thrust, positions, helix_radius, t_from, kT, **frame))


def run_frame(traj) -> dict:
    """The keywords of :func:`measure` that a :class:`~flagellum.trajectory.Trajectory`
    implies: ``free`` for a free anchor, the motor axis m(t) = R(φ(t)) e_z of a cell body
    (its ``body_orientation`` φ), the end load and the motor torque."""
    import json

    from ..hydro.body import rotvec_matrix

    boundary = traj.meta.get("boundary", "{}")
    boundary = json.loads(boundary) if isinstance(boundary, str) else dict(boundary)
    out = {"free": boundary.get("anchor") == "free"}
    phi = getattr(traj, "body_orientation", None)
    if phi is not None and np.any(np.asarray(phi) != 0):
        out["motor_axis"] = np.array([rotvec_matrix(p)[:, 2] for p in np.asarray(phi, float)])
    load = getattr(traj, "end_force", None)
    if load is not None and np.any(np.asarray(load) != 0):
        out["end_force"] = np.asarray(load, float)
    if getattr(traj, "torque", None) is not None:
        out["motor_torque"] = np.asarray(traj.torque, float)
    return out


# -- settled or transient -------------------------------------------------------------------

#: the criteria of :func:`decide`: the metric each one reads and its threshold (a criterion
#: holds above it; ``thrust_mean``: below it)
_CRITERIA = (
    ("thrust_mean", lambda m: 0.0),
    ("sigma_over_sigma0", lambda m: SIGMA_IV),
    ("tilt_deg", lambda m: TILT_REORIENTED),
    ("centroid_offset", lambda m: CENTROID_BUCKLED),
    ("thrust_std", lambda m: THRUST_BUCKLED * abs(m.thrust_mean)),
    ("sigma_over_sigma0", lambda m: sigma_buckled(m.kT)),
)
#: averages whose settling :func:`assess` tests, with the smallest scale a drift is judged by
_AVERAGES = {"thrust_mean": 1e-3, "end_to_end_mean": 1e-3, "omega_mean": 1.0}  # pN, µm, rad/s


def _trend(values) -> tuple[float, float, float]:
    """(slope per quarter, its standard error, fitted value one window on) of four values at
    the quarters 0…3 of a window; the next window's middle is at quarter 5.5."""
    x = np.arange(4.0)
    b, a = np.polyfit(x, np.asarray(values, float), 1)
    resid = np.asarray(values, float) - (a + b * x)
    se = math.sqrt(float(resid @ resid) / 2 / float(((x - 1.5) ** 2).sum()))
    return float(b), se, float(a + 5.5 * b)


def _with(m: RegimeMetrics, **values) -> RegimeMetrics:
    return RegimeMetrics(**{**m.to_dict(), **values})


def _unsure(whole: RegimeMetrics, quarters: list[RegimeMetrics]) -> list[str]:
    """Metrics that decide the regime of ``whole`` from within a factor :data:`MARGIN` of
    their threshold while they drift (monotonically over the quarters) across the window by
    more than :data:`CREEP` of it."""
    label, found = decide(whole), []
    for name, threshold in _CRITERIA[1:]:  # the sign of the thrust has no scale
        v, th = getattr(whole, name), threshold(whole)
        if not (th > 0 and th / MARGIN <= v <= th * MARGIN):
            continue
        steps = np.diff([getattr(q, name) for q in quarters])
        monotonic = bool(np.all(steps > 0) or np.all(steps < 0))  # a drift, not noise
        across = _with(whole, **{name: th / MARGIN if v > th else th * MARGIN})
        if (monotonic and abs(steps.sum()) > CREEP * th and decide(across) != label
                and name not in found):
            found.append(name)
    return found


@dataclass(frozen=True)
class Assessment:
    """The regime of a window and whether the window has settled (:func:`assess`)."""

    regime: str  #: one of :data:`REGIMES`, or ``"transient"`` when the window's regime is not settled
    window_regime: str  #: the regime of the window as it is (:func:`decide`)
    steady: bool  #: the regime and the averages (thrust, ⟨r⟩, ω) have settled
    drifting: tuple[str, ...]  #: the quantities that have not settled
    note: str  #: why the run is transient or not steady ("" when steady)


def assess(t, thrust, positions, motor_angle, helix_radius: float,
           t_from: float | None = None, kT: float = 0.0, *, motor_axis=None, free: bool = False,
           end_force=None, motor_torque=None) -> Assessment:
    """Regime of the window t ≥ t_from (default: the last half) and whether it has settled
    (``kT``: the thermal energy of the run's noise [pN·µm], 0 for a deterministic run;
    ``motor_axis``, ``free``, ``end_force``, ``motor_torque`` as for :func:`measure`).

    The observables of :func:`measure` and the averages thrust, ⟨r⟩ and ω (slope of the
    unwrapped ``motor_angle``) are measured on the four quarters of the window. The regime is
    ``"transient"`` when

    * a trend of a metric (its slope over the quarters larger than :data:`T_TREND` standard
      errors), extrapolated to the middle of one more window, changes the regime, or
    * the regime rests on a metric within a factor :data:`MARGIN` of its threshold that
      drifts (monotonically over the quarters) across the window by more than :data:`CREEP`
      of that threshold.

    The run is ``steady`` when its regime is not transient and no average drifts (a
    significant trend) by more than :data:`DRIFT_TOL` over one window. A window of fewer
    than :data:`MIN_SAMPLES` records keeps its regime and is not ``steady``.
    """
    t = np.asarray(t, float)
    thrust, positions = np.asarray(thrust, float), np.asarray(positions, float)
    if end_force is not None:  # the motor's own thrust (module docstring)
        thrust = thrust + np.asarray(end_force, float)
    motor_angle = np.asarray(motor_angle, float)
    sel = _window(t, t_from)
    axis = None if motor_axis is None else np.asarray(motor_axis, float)
    torque = None if motor_torque is None else np.asarray(motor_torque, float)

    def metrics(i):
        return measure(t[i], thrust[i], positions[i], helix_radius, -math.inf, kT,
                       motor_axis=None if axis is None else axis[i], free=free,
                       motor_torque=None if torque is None else torque[i])

    whole = metrics(sel)
    label = decide(whole)
    if whole.samples < MIN_SAMPLES:
        return Assessment(label, label, False, ("samples",),
                          f"{whole.samples} records in the averaging window, too few "
                          f"(< {MIN_SAMPLES}) to test that it has settled")
    idx = np.array_split(np.flatnonzero(sel), 4)
    quarters = [metrics(i) for i in idx]
    ahead = {}
    for name in dict.fromkeys(n for n, _ in _CRITERIA):
        slope, se, next_value = _trend([getattr(q, name) for q in quarters])
        if abs(slope) > T_TREND * se and slope != 0:
            ahead[name] = max(next_value, 0.0) if name != "thrust_mean" else next_value
    heading = decide(_with(whole, **ahead))
    drifting, notes = [], []
    if heading != label:
        drifting = [n for n in ahead if decide(_with(whole, **{n: ahead[n]})) != label] or list(ahead)
        notes.append(f"the window looks {label} but its trends lead to {heading}")
    drifting += [n for n in _unsure(whole, quarters) if n not in drifting]
    if drifting and heading == label:
        notes.append(f"the window looks {label}, but that rests on metrics near their "
                     "thresholds that are still changing")
    if drifting:
        notes[-1] += ": " + ", ".join(f"{n} {getattr(quarters[0], n):.3g} → "
                                      f"{getattr(quarters[-1], n):.3g} from the first to the "
                                      "last quarter" for n in drifting)
    transient = bool(drifting)
    averages = {"thrust_mean": [float(thrust[i].mean()) for i in idx],
                "end_to_end_mean": [float(end_to_end(positions[i]).mean()) for i in idx],
                "omega_mean": [float(np.polyfit(t[i], motor_angle[i], 1)[0]) for i in idx]}
    unsettled = []
    for name, values in averages.items():
        slope, se, _ = _trend(values)
        scale = max(abs(float(np.mean(values))), _AVERAGES[name])
        if abs(slope) > T_TREND * se and abs(4 * slope) > DRIFT_TOL * scale:
            unsettled.append(name)
    if unsettled:
        notes.append(f"averages still drifting by more than {DRIFT_TOL:.0%} per window: "
                     + ", ".join(unsettled))
        drifting += [n for n in unsettled if n not in drifting]
    if notes:
        notes.append("run longer or average later (t_from)")
    return Assessment(TRANSIENT if transient else label, label, not notes, tuple(drifting),
                      "; ".join(notes))


@dataclass(frozen=True)
class RunSummary(Summary):
    """:class:`~flagellum.analysis.observables.Summary` with the regime of the window
    (:func:`assess`)."""

    regime: str = ""  #: one of :data:`REGIMES`, or ``"transient"``
    steady: bool = False  #: the regime and the averages have settled in the window
    drifting: tuple[str, ...] = ()  #: quantities that have not settled
    regime_note: str = ""  #: why the run is transient or not steady ("" when steady)


def summarize_run(t, thrust, motor_angle, positions, energy, helix_radius: float,
                  t_from: float | None = None, torque=None, motor_speed=None, body=None,
                  kT: float = 0.0, **frame) -> RunSummary:
    """:func:`~flagellum.analysis.observables.summarize` plus :func:`assess` of the same window
    (``kT``: the thermal energy of the run's noise, 0 for a deterministic run; ``frame``: the
    keywords of :func:`measure`, :func:`run_frame`)."""
    s = summarize(t, thrust, motor_angle, positions, energy, helix_radius, t_from, torque, motor_speed,
                  body)
    a = assess(t, thrust, positions, motor_angle, helix_radius, s.t_from, kT, **frame)
    return RunSummary(**s.to_dict(), regime=a.regime, steady=a.steady, drifting=a.drifting,
                      regime_note=a.note)
