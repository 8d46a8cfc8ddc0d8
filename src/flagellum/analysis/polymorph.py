"""Threshold torques of the polymorphic transformations (docs/polymorphism.md).

A torque-driven transformation leaves the starting form when a domain of the next form
nucleates (at the hook, where the motor's stress enters) and grows. Its threshold is found
by a bracket of constant-torque runs: each run starts from the stress-free filament in one
form and runs at a constant motor torque M for ``t_run``; it *transforms* when at least
``min_fraction`` of the filament has left its starting form at the end
(:func:`flagellum.rod.polymorph.transformed_length`). Bisection between a torque that does
not transform and one that does gives the threshold to ``tol``. Both directions:

* ``down`` — from the first form (normal) at reversed torque M < 0 (the motor's CW, which
  turns a normal filament semicoiled; Hotani, J. Mol. Biol. 156, 791 (1982)),
* ``up`` — from the second form (semicoiled) at forward torque M > 0 (back to normal).

The hysteresis is M_up − M_down (> 0: a window of torques where either form persists).
Bisection assumes one crossing in the bracket; the runs of every torque tried are
returned, so a bracket with more than one crossing shows up there.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

from ..errors import ParameterError
from ..motor import Boundary, Motor
from ..params import Params, Polymorphism, check_range, check_real
from ..rod import polymorph as PM


@dataclass
class TorqueThresholds:
    """The threshold torques [pN·µm] of the transformations down (first → second form at
    M < 0) and up (second → first form at M > 0), their hysteresis, and every run tried
    (``runs``: direction, torque, transformed fraction and the events of
    :func:`flagellum.rod.polymorph.transformation_events`)."""

    forms: tuple
    threshold_down: float
    threshold_up: float
    hysteresis: float
    nucleation_site_down: float
    nucleation_site_up: float
    wall_speed_down: float
    wall_speed_up: float
    t_run: float
    runs: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return asdict(self)


def transformation_run(params: Params, polymorphism: Polymorphism, torque: float,
                       initial: str, t_run: float, boundary: Boundary | None = None,
                       save_every: float | None = None) -> dict:
    """One constant-torque run from the stress-free filament in form ``initial``: the
    transformed fraction at the end and :func:`~flagellum.rod.polymorph.transformation_events`."""
    from ..simulator import Simulator

    pm = replace(polymorphism, initial=initial)
    sim = Simulator(params, Motor(torque), boundary or Boundary(), polymorphism=pm)
    tr = sim.run(t_run, save_every=save_every or t_run / 50, progress=False)
    ev = PM.transformation_events(tr.t, tr.polymorph, sim.model.h)
    return {"torque": float(torque), "initial": initial, **ev}


def torque_thresholds(params: Params | None = None, polymorphism: Polymorphism | None = None,
                      boundary: Boundary | None = None, *, bracket_down=(-0.3, -2.0),
                      bracket_up=(0.1, 2.0), t_run: float = 0.05, tol: float = 0.05,
                      min_fraction: float = 0.1) -> TorqueThresholds:
    """Threshold torques of the first two forms of ``polymorphism`` by bisection of
    constant-torque runs (module docstring). ``bracket_down`` = (M without, M with a
    transformation), both < 0; ``bracket_up`` likewise, both > 0; ``tol`` [pN·µm] the
    bracket width at which bisection stops (the threshold is its midpoint);
    ``min_fraction`` in (0, 1] the fraction of the filament that must have left the
    starting form; ``t_run`` [s] in (0, 100] (errors name it ``time``, the CLI's flag). Raises :class:`ParameterError` for a bracket that does not bracket."""
    params = params or Params()
    polymorphism = polymorphism or Polymorphism(forms=("normal", "semicoiled"))
    if len(polymorphism.forms) < 2:
        raise ParameterError("polymorphic", ",".join(polymorphism.forms), "at least two forms")
    t_run = check_range("time", t_run, 0.0, 100.0)  # the CLI's --time
    tol = check_range("tol", tol, 0.0, 10.0)
    min_fraction = check_range("min_fraction", min_fraction, 0.0, 1.0, hi_open=False)
    first, second = polymorphism.forms[:2]
    runs: list[dict] = []

    def transforms(M: float, initial: str) -> bool:
        r = transformation_run(params, polymorphism, M, initial, t_run, boundary)
        r["direction"] = "down" if initial == first else "up"
        runs.append(r)
        return r["transformed_final"] >= min_fraction

    def parse(bracket, sign: int, name: str):
        try:
            lo, hi = (check_real(name, float(b)) for b in bracket)
        except (TypeError, ValueError):
            raise ParameterError(name, bracket, "two torques (M without, M with a transformation)")
        if not (sign * lo > 0 and sign * hi > sign * lo):
            raise ParameterError(name, tuple(bracket), ("both > 0" if sign > 0 else "both < 0")
                                 + ", the second farther from 0")
        return lo, hi, name

    def threshold(bracket, initial: str):
        lo, hi, name = bracket
        bracket = (lo, hi)
        if transforms(lo, initial):
            raise ParameterError(name, tuple(bracket), f"the first torque without a transformation in {t_run:g} s "
                                 f"(one at {lo:g} pN·µm: move it towards 0)")
        if not transforms(hi, initial):
            raise ParameterError(name, tuple(bracket), f"the second torque with a transformation in {t_run:g} s "
                                 f"(none at {hi:g} pN·µm: a larger torque or t_run)")
        while abs(hi - lo) > tol:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if transforms(mid, initial) else (mid, hi)
        at = [r for r in runs if r["initial"] == initial and r["torque"] == hi][-1]
        return 0.5 * (lo + hi), at

    down, up = parse(bracket_down, -1, "bracket_down"), parse(bracket_up, +1, "bracket_up")
    m_down, r_down = threshold(down, first)
    m_up, r_up = threshold(up, second)
    return TorqueThresholds(forms=(first, second), threshold_down=m_down, threshold_up=m_up,
                            hysteresis=m_up - m_down,
                            nucleation_site_down=r_down["nucleation_site"],
                            nucleation_site_up=r_up["nucleation_site"],
                            wall_speed_down=r_down["wall_speed"],
                            wall_speed_up=r_up["wall_speed"], t_run=t_run, runs=runs)


__all__ = ["TorqueThresholds", "torque_thresholds", "transformation_run"]
