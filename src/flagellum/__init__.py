"""flagellum: motor-driven bacterial flagella and their buckling instabilities.

Reproduces and extends Vogel & Stark, Eur. Phys. J. E (2012). Units: µm, pN, s.

The common path::

    import flagellum as fl
    tr = fl.simulate(torque=1.5, time=0.5)   # a Trajectory (lab frame)
    tr.summary()                              # time averages and the regime

The public names below are imported on first use (PEP 562), so that ``import flagellum``
and ``flagellum --help`` stay fast and load neither Numba nor SciPy.
"""

from __future__ import annotations

import importlib

from ._version import __version__

#: public name → module (below ``flagellum``) that defines it
_EXPORTS = {
    "simulate": "api",
    "Params": "params", "Filament": "params", "Fluid": "params", "Friction": "params",
    "EndLoad": "params", "Polymorphism": "params", "pull_cycle": "pulling",
    "Motor": "motor", "Boundary": "motor",
    "Simulator": "simulator", "SolverOptions": "simulator",
    "Trajectory": "trajectory", "open_trajectory": "trajectory",
    "Helix": "helix", "discrete_helix": "helix",
    "critical_torque": "analysis.stability", "linear_stability": "analysis.stability",
    "relative_equilibrium": "analysis.stability", "critical_speed": "analysis.stability",
    "torque_thresholds": "analysis.polymorph",
    "tumble": "analysis.tumble", "TumbleSummary": "analysis.tumble",
    "Sweep": "sweep", "run_sweep": "sweep", "read_sweep": "sweep",
    "FlagellumError": "errors", "ParameterError": "errors", "SimulationError": "errors",
}
#: public submodules
_MODULES = ("errors",)

__all__ = [*_EXPORTS, *_MODULES, "__version__"]


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    elif name in _MODULES:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'flagellum' has no attribute {name!r}")
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
