"""The two bifurcations of the driven filament (paper Sec. 3.1, Fig. 3(a), Fig. 4(d)).

* **M_c1**, the buckling threshold (supercritical Hopf): the root of the growth rate λ(M)
  of the aligned state (:func:`flagellum.analysis.stability.critical_torque`); its
  uncertainty is the tolerance of that root search. Optionally confirmed by two
  simulations, at M_c1(1 ∓ δ), which must be aligned and buckled.
* **M_c2**, where the buckled state itself becomes unstable and starts to collapse
  periodically (regime (iv), paper ≈ 4.2 pN·µm), from simulations classified by
  :func:`flagellum.analysis.regimes.decide` (σ jumps there, Fig. 4(d)): a coarse scan of
  independent runs (in parallel), then k-section (bisection with one worker) between the
  last buckled and the first oscillating torque until the bracket is below ``tol``.
  M_c2 is the bracket's midpoint, its uncertainty half the bracket.
* **Hysteresis** (optional): a sweep up and a sweep down through the scan torques, each
  run continuing from the previous run's final state, each refined by bisection that
  continues from the state on its own branch. M_c2_up ≠ M_c2_down beyond their
  uncertainties means hysteresis.

The simulation is a function ``simulate(torque, state) -> (probe, state)``
(:class:`RunConfig` for the real filament), so the search logic can be tested against a
cheap stand-in. Fresh runs follow the paper's protocol (Sec. 3.1.2) above ``step_from``: rotate
aligned at M = 1 pN·µm, then step to M within 0.01 s; the window is the last half after
the step.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..errors import ParameterError
from ..grid import parse_values
from ..hydro.options import Hydrodynamics
from ..motor import Boundary
from ..paper import PAPER
from ..parallel import check_workers, process_pool, serial_pool
from ..params import Params, check_choice, check_range, positive
from .regimes import decide, measure

#: per quality: scan torques (lo, hi, step) [pN·µm], simulated time after the step [s], tol
SCAN_SETTINGS = {
    "quick": {"torques": (3.0, 5.5, 0.5), "t_end": 0.3, "tol": 0.1},
    "full": {"torques": (2.5, 5.5, 0.25), "t_end": 0.8, "tol": 0.025},
}
#: per quality: motor speeds of the scan under a speed clamp (lo, hi, step) [rad/s] and the
#: bisection tolerance [rad/s] (the clamped filament buckles at ω_c1 ≈ 898 rad/s and winds
#: up above ≈ 975 rad/s, docs/motor.md)
SPEED_SETTINGS = {"quick": {"speeds": (900.0, 1100.0, 50.0), "tol": 10.0},
                  "full": {"speeds": (875.0, 1100.0, 25.0), "tol": 2.5}}
#: the paper's thresholds [pN·µm] (:data:`flagellum.paper.PAPER`)
PAPER_THRESHOLDS = {k: PAPER[k].value for k in ("M_c1", "M_c2")}
LOWER, UPPER = "buckled", "oscillating"  #: the regimes on either side of M_c2
MAX_ROUNDS = 12

#: ``simulate(torque, state) -> (probe dict, final state)``; state None = a fresh run
Simulate = Callable[[float, Any], "tuple[dict, Any]"]


# -- the real simulation ------------------------------------------------------------------
@dataclass(frozen=True)
class RunConfig:
    """One deterministic run at a torque, classified: the ``simulate`` of the search."""

    params: Params = field(default_factory=Params)
    boundary: Boundary = field(default_factory=Boundary)
    t_end: float = 0.3  #: simulated time at the final torque [s]
    step_from: float = 2.0  #: fresh runs at M ≥ this start aligned at M = 1 and step (Sec. 3.1.2)
    t_step: float = 0.05
    window: float = 0.5  #: averaging window: this fraction of the run at the final torque
    samples: int = 600
    rtol: float = 1e-6
    hydrodynamics: Hydrodynamics = field(default_factory=Hydrodynamics)
    #: "torque": the value of a call is the torque M; "speed": a speed clamp ω [rad/s] (every
    #: run starts from the stress-free helix at the clamp; the probe's ``motor_speed`` is ω,
    #: ``torque`` the mean torque the clamp takes)
    drive: str = "torque"

    def __call__(self, torque: float, state: Any = None) -> tuple[dict, Any]:
        from ..helix import Helix
        from ..motor import Motor
        from ..simulator import Simulator, SolverOptions, run_first_success

        M = float(torque)
        speed = check_choice("drive", self.drive, ("torque", "speed")) == "speed"
        if speed:
            motor, t_start = Motor(drive="speed", speed=M), 0.0
        elif state is None and M >= self.step_from:
            motor = Motor(M, schedule=((0.0, 1.0), (self.t_step, 1.0), (self.t_step + 0.01, M)))
            t_start = self.t_step + 0.01
        else:
            motor, t_start = Motor(M), 0.0
        t_total = t_start + self.t_end
        # the co-rotating frame fails with CVODE at large torques (and after a step)
        frames = ("lab", "auto") if (state is not None or M >= self.step_from) else ("auto", "lab")
        attempts = ([(None, f) for f in frames] + [("cvode", f) for f in frames]
                    + [("implicit", "lab")])  # None: the run's default method
        wall0 = time.perf_counter()

        def make(method, frame):  # a continuation starts from the last run's lab-frame state
            opts = SolverOptions(method=method, rtol=self.rtol, frame=frame)
            if state is None:
                return Simulator(self.params, motor, self.boundary, solver=opts,
                                 hydrodynamics=self.hydrodynamics)
            return Simulator.from_state(state, self.params, motor, self.boundary, solver=opts,
                                        hydrodynamics=self.hydrodynamics)

        tr, sim, method, frame, errors = run_first_success(make, attempts, t_total,
                                                           t_total / self.samples)
        err = errors[-1] if tr is None else None
        probe = {("motor_speed" if speed else "torque"): M, "t_end": self.t_end,
                 "continued": state is not None, "wall_seconds": time.perf_counter() - wall0}
        if err is not None:
            return {**probe, "regime": "failed", "error": " ".join(err.split())[:300]}, None
        t_from = t_total - self.window * self.t_end
        m = measure(tr.t, tr.thrust, tr.positions, Helix.from_filament(self.params.filament).radius, t_from)
        sel = tr.t >= t_from - 1e-12
        probe.update({"regime": decide(m), "sigma_over_sigma0": m.sigma_over_sigma0,
                      "thrust": m.thrust_mean, "thrust_min": float(tr.thrust[sel].min()),
                      "thrust_max": float(tr.thrust[sel].max()), "swings": m.swings,
                      "centroid_offset": m.centroid_offset, "frame": frame, "solver": method})
        if speed:
            probe["torque"] = float(np.mean(tr.torque[sel]))
        return probe, sim.lab_state()


# -- the search (independent of the simulation) ------------------------------------------
def _probe_task(arg) -> dict:
    simulate, torque, direction = arg
    return {**simulate(torque, None)[0], "direction": direction}


def _key(simulate) -> str:
    """The probes' key of the scanned drive value: ``torque``, or ``motor_speed`` for a
    speed-clamp :class:`RunConfig`."""
    return "motor_speed" if getattr(simulate, "drive", "torque") == "speed" else "torque"


def _failed(torque, direction, exc, key="torque") -> dict:
    return {key: float(torque), "regime": "failed", "direction": direction,
            "error": f"{type(exc).__name__}: {exc}"[:300]}


def _executor(workers: int):
    """(submit, as_completed): in this process for one worker, else a process pool."""
    return serial_pool() if workers <= 1 else process_pool(workers)


class _Runner:
    """Submits probe tasks, keeps every probe, reports progress and each finished probe."""

    def __init__(self, submit, as_completed, workers: int, bar=None, on_probe=None, key="torque"):
        self.submit, self.as_completed, self.workers = submit, as_completed, workers
        self.bar, self.on_probe, self.probes, self.key = bar, on_probe, [], key

    def start(self, fn, args: list, total: int | None = None) -> dict:
        if self.bar is not None:
            self.bar.total = (self.bar.total or 0) + (len(args) if total is None else total)
            self.bar.refresh()
        return {self.submit(fn, a): (fn, a) for a in args}

    def collect(self, futures: dict, count: Callable[[Any], int] = lambda r: 1) -> list:
        out = {}
        for fut in self.as_completed(futures):
            fn, arg = futures[fut]
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001 - a dead worker, not a simulation failure
                res = (_failed(arg[1], arg[2], exc, self.key) if fn is _probe_task else
                       {"direction": arg[2], "probes": [], "note": f"{type(exc).__name__}: {exc}"})
            out[fut] = res
            for p in res.get("probes", [res]):
                self.probes.append(p)
            if self.bar is not None:  # a chain may run more probes than announced
                self.bar.total = max(self.bar.total, self.bar.n + count(res))
                self.bar.update(count(res))
            if self.on_probe is not None:
                self.on_probe(self.probes)
        return [out[f] for f in futures]

    def probe(self, simulate, torques, direction) -> list[dict]:
        return self.collect(self.start(_probe_task, [(simulate, float(m), direction) for m in torques]))


def bracket(probes: list[dict], key: str = "torque") -> tuple[float | None, float | None, str | None]:
    """(last buckled, first oscillating) torques (``key``: or motor speeds) of a set of
    fresh runs, and a note."""
    upper = sorted(p[key] for p in probes if p["regime"] == UPPER)
    lower = sorted(p[key] for p in probes if p["regime"] == LOWER)
    if not upper:
        return None, None, "no oscillating run (raise the scan range or --time)"
    hi = upper[0]
    below = [m for m in lower if m < hi]
    if not below:
        return None, hi, "no buckled run below the first oscillating one (lower the scan range)"
    above = [m for m in lower if m > hi]
    note = (f"regimes not monotonic in M: buckled at {', '.join(f'{m:g}' for m in above)} above the "
            "first oscillating torque (runs too short?)") if above else None
    return below[-1], hi, note


def refine(runner: _Runner, simulate: Simulate, lo: float, hi: float, tol: float) -> tuple[float, float, str | None]:
    """Shrink [lo, hi] (lo buckled, hi oscillating) by k-section with k = workers until
    hi − lo ≤ tol; stops early when a round decides nothing (failed or other regimes)."""
    for _ in range(MAX_ROUNDS):
        if hi - lo <= tol:
            return lo, hi, None
        k = max(1, runner.workers)
        inner = [lo + (hi - lo) * (i + 1) / (k + 1) for i in range(k)]
        new = runner.probe(simulate, inner, "bisect")
        known = [p for p in new if p["regime"] in (LOWER, UPPER)]
        key = runner.key
        nlo, nhi, _ = bracket([{key: lo, "regime": LOWER}, *known, {key: hi, "regime": UPPER}], key)
        if (nlo, nhi) == (lo, hi):
            return lo, hi, ("refinement stopped: runs at " + ", ".join(f"{p[key]:.4g} ({p['regime']})"
                                                                   for p in new) + " decide nothing")
        lo, hi = nlo, nhi
    return lo, hi, None


def continuation(simulate: Simulate, torques, direction: str, tol: float) -> dict:
    """Sweep ``torques`` in order, each run from the previous final state, then bisect the
    first buckled→oscillating (``up``) or oscillating→buckled (``down``) transition, each
    probe continuing from the last state on the side the sweep came from."""
    src, dst = (LOWER, UPPER) if direction == "up" else (UPPER, LOWER)
    key = _key(simulate)
    probes, state, last_src = [], None, None
    lo = hi = src_state = None
    for M in torques:
        p, s = simulate(float(M), state)
        p = {**p, "direction": direction}
        probes.append(p)
        state = s if p["regime"] != "failed" else state
        if p["regime"] == src:
            last_src = (p[key], s)
        elif p["regime"] == dst and last_src is not None and lo is None:
            (lo, hi), src_state = sorted((last_src[0], p[key])), last_src[1]
    if lo is None:
        return {"direction": direction, "probes": probes, "M_c2": None, "uncertainty": None,
                "bracket": None, "note": f"no {src} → {dst} transition along the sweep"}
    note = None
    for _ in range(MAX_ROUNDS):
        if hi - lo <= tol:
            break
        mid = 0.5 * (lo + hi)
        p, s = simulate(mid, src_state)
        probes.append({**p, "direction": direction})
        if p["regime"] not in (src, dst):
            note = f"bisection stopped: {p['regime']} at M = {mid:.4g}"
            break
        moves_src_side = p["regime"] == src
        if moves_src_side:
            src_state = s
        if (direction == "up") == moves_src_side:
            lo = mid
        else:
            hi = mid
    return {"direction": direction, "probes": probes, "M_c2": 0.5 * (lo + hi),
            "uncertainty": 0.5 * (hi - lo), "bracket": [lo, hi], "note": note}


def _chain_task(arg) -> dict:
    simulate, torques, direction, tol = arg
    return continuation(simulate, torques, direction, tol)


def critical(params: Params, boundary: Boundary, xtol: float = 1e-3,
             hydrodynamics: Hydrodynamics | None = None, drive: str = "torque") -> dict:
    """M_c1 from linear stability, the bracket widened upwards (a load sphere raises M_c1).

    ``drive="speed"``: the critical rotation rate ω_c1 of a speed clamp instead
    (:func:`flagellum.analysis.stability.critical_speed`, to ``xtol`` · 1000 rad/s), with
    the torque the clamp takes there (``M_at_omega_c1``)."""
    from .stability import BRACKETS, critical_speed, critical_torque

    check_choice("drive", drive, ("torque", "speed"))
    (lo, hi), last = BRACKETS[(hydrodynamics or Hydrodynamics()).model], None
    for _ in range(5):
        try:
            if drive == "speed":
                ct = critical_speed(params, boundary, None, 1e3 * xtol, hydrodynamics=hydrodynamics,
                                    torque_bracket=(lo, hi))
                return {"omega_c1": ct.motor_speed, "omega_c1_uncertainty": 1e3 * xtol,
                        "M_at_omega_c1": ct.critical_torque, "F_c1": ct.critical_force}
            ct = critical_torque(params, boundary, (lo, hi), xtol, hydrodynamics=hydrodynamics)
            return {"M_c1": ct.critical_torque, "M_c1_uncertainty": xtol, "F_c1": ct.critical_force}
        except ParameterError as exc:
            if exc.name != "bracket":
                raise
            last, lo, hi = str(exc), hi, 2 * hi
    key = "omega_c1" if drive == "speed" else "M_c1"
    return {key: None, f"{key}_uncertainty": None, "F_c1": None, f"{key}_note": last}


# -- the whole analysis -------------------------------------------------------------------
def scan_torques(quality: str = "quick", torque_range: str | None = None,
                 drive: str = "torque") -> tuple[float, ...]:
    """Torques of the coarse scan: ``lo:hi`` (the quality's step) or ``lo:hi:step``; with
    ``drive="speed"`` the motor speeds of a speed clamp (``torque_range`` then in rad/s)."""
    check_choice("quality", quality, tuple(SCAN_SETTINGS))
    speed = check_choice("drive", drive, ("torque", "speed")) == "speed"
    lo, hi, step = SPEED_SETTINGS[quality]["speeds"] if speed else SCAN_SETTINGS[quality]["torques"]
    name, unit, what = ("speed_range", "rad/s", "speeds") if speed else ("torque_range", "pN·µm", "torques")
    text = torque_range if torque_range is not None else f"{lo}:{hi}:{step}"
    parts = str(text).split(":")
    if len(parts) == 2:
        text = f"{text}:{step}"
    elif len(parts) != 3:
        raise ParameterError(name, torque_range, f"lo:hi or lo:hi:step [{unit}]")
    values = sorted(parse_values("motor_speed" if speed else "torque", text))
    if len(values) < 2:
        raise ParameterError(name, torque_range, f"at least two {what} (lo < hi)")
    for m in values:
        check_range("motor_speed" if speed else "torque", m, 0.0, 1e5 if speed else 1e3)
    return tuple(values)


def bifurcations(params: Params | None = None, boundary: Boundary | None = None, *,
                 quality: str = "quick", torque_range: str | None = None, t_end: float | None = None,
                 tol: float | None = None, hysteresis: bool = False, mc2: bool = True,
                 confirm_mc1: float | None = None, workers: int = 1, progress: bool = False,
                 on_probe: Callable[[list], None] | None = None,
                 simulate: Simulate | None = None,
                 hydrodynamics: Hydrodynamics | None = None, drive: str = "torque") -> dict:
    """M_c1, M_c2 with uncertainties, optional hysteresis, and the regime of every probe.

    ``simulate`` replaces the simulation (tests); ``on_probe(probes)`` is called after
    every finished probe (used to write partial results); ``hydrodynamics`` the filament's
    mobility in the runs and in the linear stability (default local RFT). ``drive="speed"``
    gives the thresholds of a speed clamp instead (``torque_range`` then holds motor speeds
    [rad/s], default :data:`SPEED_SETTINGS`): the critical rotation rate ω_c1 (:func:`critical`),
    the confirmation runs at ω_c1(1 ∓ δ) and ω_c2 (``omega_c2``…) from the scan of clamped
    runs (each from the stress-free helix at the clamp); the probes then carry
    ``motor_speed`` (the clamp) and ``torque`` (the mean torque it took).
    """
    wall0 = time.perf_counter()
    params, boundary = params or Params(), boundary or Boundary()
    hydrodynamics = hydrodynamics or Hydrodynamics()
    q = SCAN_SETTINGS[check_choice("quality", quality, tuple(SCAN_SETTINGS))]
    speed = check_choice("drive", drive, ("torque", "speed")) == "speed"
    torques = scan_torques(quality, torque_range, drive)
    t_end = positive("t_end", q["t_end"] if t_end is None else t_end, 100.0)
    default_tol = SPEED_SETTINGS[quality]["tol"] if speed else q["tol"]
    tol = positive("tol", default_tol if tol is None else tol, 1e3 if speed else 10.0)
    check_workers("workers", workers)
    if confirm_mc1 is not None:
        confirm_mc1 = check_range("confirm_mc1", confirm_mc1, 0.0, 0.9)
    simulate = simulate or RunConfig(params, boundary, t_end, hydrodynamics=hydrodynamics, drive=drive)
    key, c1, c2 = ("motor_speed", "omega_c1", "omega_c2") if speed else ("torque", "M_c1", "M_c2")

    out = {"quality": quality, "sphere_radius": boundary.sphere_radius, "t_end": t_end, "tol": tol,
           ("scan_speeds" if speed else "scan_torques"): list(torques), "paper": PAPER_THRESHOLDS,
           "hydrodynamics": hydrodynamics.model, "drive": drive}
    from .._progress import progress_bar

    n_chain = len(torques) if hysteresis and mc2 else 0
    workers = min(workers, len(torques) + 2)
    with _executor(workers) as (submit, as_completed), \
            progress_bar(total=0, unit="run", desc="bifurcations", disable=not progress) as bar:
        runner = _Runner(submit, as_completed, workers, bar, on_probe, key)
        # independent runs go to the pool first (long chains first); M_c1 meanwhile here
        chains = runner.start(_chain_task, [(simulate, torques, "up", tol), (simulate, torques[::-1], "down", tol)],
                              total=2 * n_chain) if n_chain else {}
        scan = runner.start(_probe_task, [(simulate, float(m), "scan") for m in torques]) if mc2 else {}
        out.update(critical(params, boundary, hydrodynamics=hydrodynamics,
                            **({"drive": drive} if drive != "torque" else {})))
        out["M_c1_method" if drive == "torque" else "omega_c1_method"] = (
            "linear stability: root of λ(M) (uncertainty = root tolerance)" if drive == "torque"
            else "linear stability of the speed clamp: root of λ(ω) (uncertainty = root tolerance)")
        if confirm_mc1 is not None and out[c1] is not None:
            below, above = runner.probe(simulate, [out[c1] * (1 + s * confirm_mc1) for s in (-1, 1)], "confirm")
            out[f"{c1}_confirmed"] = below["regime"] == "aligned" and above["regime"] in (LOWER, UPPER)
        first = runner.collect(scan)
        if mc2:
            lo, hi, note = bracket(first, key)
            if lo is not None:
                lo, hi, note2 = refine(runner, simulate, lo, hi, tol)
                note = "; ".join(n for n in (note, note2) if n) or None
                out.update({c2: 0.5 * (lo + hi), f"{c2}_uncertainty": 0.5 * (hi - lo),
                            f"{c2}_bracket": [lo, hi]})
            else:
                out.update({c2: None, f"{c2}_uncertainty": None, f"{c2}_bracket": None})
            if note:
                out[f"{c2}_note"] = note
            for res in runner.collect(chains, count=lambda r: len(r.get("probes", []))):
                d = res["direction"]
                out[f"{c2}_{d}"], out[f"{c2}_{d}_uncertainty"] = res.get("M_c2"), res.get("uncertainty")
                if res.get("note"):
                    out[f"{c2}_{d}_note"] = res["note"]
            if n_chain:
                up, down = out.get(f"{c2}_up"), out.get(f"{c2}_down")
                out["hysteresis"] = (None if up is None or down is None else
                                     abs(up - down) > out[f"{c2}_up_uncertainty"] + out[f"{c2}_down_uncertainty"])
    order = {"confirm": 0, "scan": 1, "bisect": 1, "up": 2, "down": 3}
    out["probes"] = sorted(runner.probes, key=lambda p: (order.get(p["direction"], 4),
                                                          p.get(key, 0.0) if order.get(p["direction"]) in (0, 1) else 0))
    out["wall_seconds"] = time.perf_counter() - wall0
    return out


__all__ = ["SCAN_SETTINGS", "SPEED_SETTINGS", "RunConfig", "bifurcations", "bracket", "continuation", "critical",
           "refine", "scan_torques"]
