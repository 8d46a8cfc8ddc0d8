"""Motor torque and boundary conditions at the motor end (paper Sec. 2.3, Sec. 3.2).

* :class:`Motor` — torque M(t) e_z on the hook frame: constant, smoothly ramped on, or a
  piecewise-linear schedule (reversals, steps).
* :class:`Boundary` — first bead anchored (``fixed``), attached to a load sphere of radius a
  moving along z with Stokes drag 6πηa (``sphere``); the hook as the paper's free universal
  joint (``free``), with bending stiffness k about the motor axis (``elastic``,
  E = k(1 − cos ϑ) ≈ kϑ²/2), or clamped along the motor axis (``clamped``, k → ∞).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ParameterError
from .params import check_choice, check_range, check_real, positive


@dataclass(frozen=True)
class Motor:
    """Motor torque M(t) [pN·µm] along +e_z (M > 0: the filament pushes, paper Sec. 3.1.1).

    ``ramp_time`` > 0 ramps the torque on as M (1 − cos(π t/T))/2 for t < T, which avoids
    the violent start of an abrupt switch-on. ``schedule`` = ((t0, M0), (t1, M1), …)
    replaces the constant torque by linear interpolation (held constant outside).
    """

    torque: float = 1.0
    ramp_time: float = 0.0
    schedule: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "torque", check_range("torque", self.torque, -1e3, 1e3, lo_open=False))
        object.__setattr__(self, "ramp_time", check_range("ramp_time", self.ramp_time, 0.0, 1e6, lo_open=False))
        if self.schedule is not None:
            try:
                sched = tuple((check_real("schedule time", float(t)), check_real("schedule torque", float(m)))
                              for t, m in self.schedule)
            except (TypeError, ValueError):
                raise ParameterError("schedule", self.schedule, "a sequence of (time, torque) pairs")
            if len(sched) < 1 or any(b[0] <= a[0] for a, b in zip(sched, sched[1:])):
                raise ParameterError("schedule", self.schedule, "(time, torque) pairs with increasing times")
            object.__setattr__(self, "schedule", sched)

    def __call__(self, t: float) -> float:
        if self.schedule is not None:
            ts, ms = zip(*self.schedule)
            return float(np.interp(t, ts, ms))
        if self.ramp_time > 0 and t < self.ramp_time:
            return self.torque * 0.5 * (1 - math.cos(math.pi * t / self.ramp_time))
        return self.torque

    @property
    def final_torque(self) -> float:
        return self.schedule[-1][1] if self.schedule is not None else self.torque


@dataclass(frozen=True)
class Boundary:
    """Boundary conditions at the motor end."""

    anchor: str = "fixed"
    sphere_radius: float | None = None
    hook: str = "free"
    hook_stiffness: float = 0.0  #: k [pN·µm] for ``hook="elastic"``

    def __post_init__(self):
        check_choice("anchor", self.anchor, ("fixed", "sphere", "free"))
        check_choice("hook", self.hook, ("free", "elastic", "clamped"))
        if self.anchor == "fixed" and self.sphere_radius is not None:  # never silently unused
            raise ParameterError("sphere_radius", self.sphere_radius,
                                 "given only with anchor = 'sphere' or 'free' (anchor is 'fixed')")
        if self.anchor == "sphere":
            if self.sphere_radius is None:
                raise ParameterError("sphere_radius", None, "given (a number > 0) with anchor = 'sphere'")
            object.__setattr__(self, "sphere_radius", positive("sphere_radius", self.sphere_radius, 1e6))
        if self.anchor == "free":  # a free swimmer; radius 0: the filament alone
            a = 0.0 if self.sphere_radius is None else self.sphere_radius
            object.__setattr__(self, "sphere_radius", check_range("sphere_radius", a, 0.0, 1e6, lo_open=False))
        k = check_range("hook_stiffness", self.hook_stiffness, 0.0, 1e6, lo_open=False)
        if self.hook == "elastic" and k == 0:
            raise ParameterError("hook_stiffness", k, "> 0 with hook = 'elastic'")
        object.__setattr__(self, "hook_stiffness", k if self.hook == "elastic" else 0.0)

    @classmethod
    def from_flags(cls, anchor: str | None = None, sphere_radius: float | None = None,
                   hook: str | None = None, hook_stiffness: float | None = None) -> "Boundary":
        """The boundary of the command-line flags and sweep values: an anchor not given is a
        load sphere when ``sphere_radius`` is given (else fixed); a hook not given is elastic
        when ``hook_stiffness`` k > 0 (else free). Given values are kept as they are, and a
        value that the given kind would not use (a radius with a fixed anchor, k > 0 with a
        free or clamped hook) is a :class:`ParameterError`."""
        k = 0.0 if hook_stiffness is None else hook_stiffness
        if hook not in (None, "elastic") and k != 0:  # a flag never silently unused
            raise ParameterError("hook_stiffness", k, f"given only with hook = 'elastic' "
                                                      f"(hook is {hook!r})")
        if anchor is None:
            anchor = "fixed" if sphere_radius is None else "sphere"
        if hook is None:
            hook = "elastic" if k else "free"
        return cls(anchor=anchor, sphere_radius=sphere_radius, hook=hook, hook_stiffness=k)

    def sphere_drag(self, viscosity: float) -> float:
        """Stokes drag 6πηa of the load sphere or of a free swimmer's body [pN·s/µm]."""
        return 6 * math.pi * viscosity * self.sphere_radius if self.anchor != "fixed" else 0.0

    def body_rotation_rate(self, torque: float, viscosity: float) -> float:
        """Counter-rotation of a free swimmer's body about the motor axis, −M/(8πηa³) [rad/s]:
        the motor's reaction torque; a body centred on the hook feels no other torque."""
        if self.anchor != "free" or not self.sphere_radius:
            return math.nan
        return -torque / (8 * math.pi * viscosity * self.sphere_radius ** 3)
