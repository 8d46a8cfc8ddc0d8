"""The stepper interface: what :class:`flagellum.simulator.Simulator` needs of an integrator.

A stepper owns the time and state of one integration of a
:class:`~flagellum.rod.model.RodModel` and advances them on request; the simulator decides
where to stop (records, chart checks) and when the right-hand side changes (a re-centred
chart, a new frame rate), and then calls :meth:`Stepper.reset`. :data:`STEPPERS` maps the
``method`` of :class:`~flagellum.simulator.SolverOptions` to the stepper class, and
:func:`make_stepper` is the one place the simulator builds a stepper.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from ..errors import ParameterError
from .bdf import BdfStepper
from .brownian import ImplicitStepper
from .cache import warm_in_background
from .cvode import CvodeStepper


@runtime_checkable
class Stepper(Protocol):
    """Integrator of ``dy/dt = model.rhs(t, y)`` (plus noise, for a thermal scheme).

    Extension contract (what a class registered in :data:`STEPPERS` must provide):

    ``from_options(model, t, y, options, *, kT, seed, rng_state)`` (classmethod)
        Build a stepper at time ``t`` [s] and state ``y`` (copied) for ``model``;
        ``options`` is the run's :class:`~flagellum.simulator.SolverOptions` (read what
        applies: ``rtol``, ``atol``, ``max_steps``, ``dt``, ``scheme``, ``theta``); ``kT`` [pN·µm] is the
        thermal energy (0: deterministic); ``seed`` and ``rng_state`` (a value of
        :attr:`rng_state`, or None) start or restore the random stream.
    ``t``, ``y``
        The current time [s] and state (the model's layout, :func:`~flagellum.rod.model.state_size`).
    ``n_steps``
        Steps taken since construction (an int; the simulator reports the sum).
    ``fixed_step``
        Δt [s] of a fixed-step scheme, None for an adaptive one. The simulator then stops
        only at whole multiples of Δt between records (a shortened step would restart a
        multistep scheme).
    ``rng_state``
        JSON-serializable state of the random stream, or None for a deterministic scheme;
        passed back to ``from_options`` on resume so the stream continues unchanged.
    ``advance(t) -> y``
        Integrate to time ``t`` ≥ ``self.t`` and return the new state (also ``self.y``);
        raise :class:`~flagellum.errors.SimulationError` on failure. The model's charts
        and frame rate do not change during the call. An adaptive scheme fails when one call
        would take more than ``options.max_steps`` internal steps (default
        :data:`~flagellum.integrate.MAX_STEPS_PER_ADVANCE`, the same for every adaptive
        stepper): a collapsed step size is then a failure the simulator can act on (retry
        from re-centred charts, the next method of
        :func:`~flagellum.simulator.run_first_success`), not a run that grinds on.
    ``reset(t, y)``
        Restart at (t, y) forgetting any history (the right-hand side may have changed).
        Reset at equal (t, y) and advancing must give the same result as a fresh stepper
        built there with the current :attr:`rng_state` (resume from a checkpoint relies
        on it).

    Optional: ``tracks_mobility`` (bool)
        True where ``advance`` itself checks and rebuilds a frozen nonlocal ΔM
        (:class:`~flagellum.integrate.frozen.FrozenMobility`, with its secant model between
        renewals);
        the simulator then leaves ΔM alone between restarts. Without it, the simulator
        checks ΔM (:meth:`~flagellum.rod.model.RodModel.refresh_mobility`) before each chunk.
    Optional: ``carry(t, y, transform) -> bool``
        Continue at (t, y) after a smooth change of the state's coordinates (a re-centred
        chart, a change of the frame's rate) with the history mapped by ``transform(times,
        values)`` (rows of states at those times, into the new coordinates), or reset and
        return False where it cannot. The simulator calls it instead of ``reset`` at such
        changes when a stepper has it (:class:`~flagellum.integrate.bdf.BdfStepper`).
    """

    t: float
    y: np.ndarray
    n_steps: int

    @classmethod
    def from_options(cls, model, t: float, y: np.ndarray, options, *, kT: float = 0.0,
                     seed: int = 0, rng_state=None) -> "Stepper": ...

    @property
    def fixed_step(self) -> float | None: ...

    @property
    def rng_state(self) -> Any: ...

    def advance(self, t: float) -> np.ndarray: ...

    def reset(self, t: float, y: np.ndarray) -> None: ...


#: ``SolverOptions.method`` → stepper class (see :class:`Stepper` for the contract)
STEPPERS: dict[str, type] = {"cvode": CvodeStepper, "implicit": ImplicitStepper, "bdf": BdfStepper}


def make_stepper(method: str, model, t: float, y: np.ndarray, options, *, kT: float = 0.0,
                 seed: int = 0, rng_state=None) -> Stepper:
    """The stepper of ``method`` (a key of :data:`STEPPERS`) at (t, y); see :class:`Stepper`."""
    try:
        cls = STEPPERS[method]
    except KeyError:
        raise ParameterError("method", method, f"one of {', '.join(STEPPERS)}") from None
    warm_in_background(exclude=method)  # the other solvers' kernels compile alongside
    return cls.from_options(model, t, y, options, kT=kT, seed=seed, rng_state=rng_state)


__all__ = ["STEPPERS", "Stepper", "make_stepper"]
