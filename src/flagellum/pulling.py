"""Force–extension protocol: the free end pulled by a moving axial trap, up then down (or
along a given schedule of rates), the motor idle (M = 0), recording the load, the extension
and the polymorphic state (docs/polymorphism.md, "Force–extension curves").

Each stage of the schedule is a run of :class:`~flagellum.simulator.Simulator` continued
from the state of the one before (:meth:`~flagellum.simulator.Simulator.from_state`, with
the order parameters); the trap keeps its centre across stages: a stage starts with the
load the last one ended with (the constant part of its :class:`~flagellum.params.EndLoad`)
and moves the centre at its own rate from there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .analysis.force_extension import Transitions, transitions
from .errors import ParameterError
from .params import EndLoad, Params, Polymorphism, check_range


@dataclass(frozen=True)
class PullCurve:
    """Records of a pull cycle: time t [s], the load F on the free end along −e_z [pN],
    the extension x [µm] (z of bead 0 minus z of the last bead), the trap's rate of each
    record's stage [µm/s], the order parameter of each joint (records × joints; None for a
    single-state filament), the forms and the bead positions [µm] (records × beads × 3, lab
    frame)."""

    t: np.ndarray
    force: np.ndarray
    extension: np.ndarray
    rate: np.ndarray
    phi: np.ndarray | None
    forms: tuple
    positions: np.ndarray | None = None

    def fraction(self, form: int = -1) -> np.ndarray:
        """Fraction of joints in form ``form`` (default: the last) per record."""
        from .rod.polymorph import fractions

        if self.phi is None:
            return np.zeros_like(self.t)
        return fractions(self.phi, len(self.forms))[:, form]

    def transitions(self, level: float = 0.5) -> Transitions:
        """Thresholds and loop area (:func:`flagellum.analysis.force_extension.transitions`)
        for the transformation into the last form."""
        return transitions(self.t, self.force, self.extension, self.fraction(), level)


def up_down(pull_rate: float, duration: float) -> tuple:
    """The schedule of a cycle: ``duration`` [s] at +``pull_rate``, the same back."""
    return ((duration, pull_rate), (duration, -pull_rate))


def pull_cycle(params: Params | None = None, polymorphism: Polymorphism | None = None, *,
               trap_stiffness: float, schedule, samples: int = 200, solver=None,
               thermal: bool = False, seed: int | None = None) -> PullCurve:
    """Pull the free end with a trap of stiffness ``trap_stiffness`` [pN/µm] whose centre
    moves along −e_z (away from the motor) at the rates of ``schedule``, a sequence of
    (duration [s], rate [µm/s]) stages (:func:`up_down` for up then down), starting from
    the stress-free filament (the first form of ``polymorphism``). ``samples`` records per
    stage; ``solver`` default CVODE in the lab frame (the load acts on z in any frame)."""
    from .motor import Motor
    from .simulator import Simulator, SolverOptions

    params = params or Params()
    check_range("trap_stiffness", trap_stiffness, 0.0, 1e5)
    try:
        pairs = [(float(d), float(v)) for d, v in schedule]
    except (TypeError, ValueError):
        raise ParameterError("schedule", schedule, "a sequence of (duration, rate) pairs") from None
    stages = [(check_range("schedule duration", d, 0.0, 1e6), check_range("pull_rate", v, -1e4, 1e4))
              for d, v in pairs]
    if not stages:
        raise ParameterError("schedule", schedule, "at least one (duration, rate) stage")
    solver = solver or SolverOptions(frame="lab")
    motor = Motor(0.0)
    parts, state, t0, force = [], None, 0.0, 0.0
    for d, v in stages:
        load = EndLoad(force=force, pull_rate=v, trap_stiffness=trap_stiffness)
        kw = dict(end_load=load, polymorphism=polymorphism, solver=solver, thermal=thermal,
                  seed=None if seed is None else seed + len(parts))
        sim = (Simulator(params, motor, **kw) if state is None
               else Simulator.from_state(state, params, motor, t=t0, **kw))
        tr = sim.run(t0 + d, save_every=d / samples, progress=False)
        first = 0 if not parts else 1  # the stage's first record is the last one's end
        parts.append((tr.t[first:], tr.end_force[first:], tr.extension[first:],
                      np.full(len(tr.t) - first, v),
                      None if tr.polymorph is None else tr.polymorph[first:], tr.positions[first:]))
        state, t0, force = sim.state(), float(tr.t[-1]), float(tr.end_force[-1])
    cols = list(zip(*parts))
    phi = None if cols[4][0] is None else np.concatenate(cols[4])
    return PullCurve(*(np.concatenate(c) for c in cols[:4]), phi,
                     tuple(polymorphism.forms) if polymorphism is not None else (),
                     np.concatenate(cols[5]))


__all__ = ["PullCurve", "pull_cycle", "up_down"]
