"""flagellum: motor-driven bacterial flagella and their buckling instabilities.

Reproduces and extends Vogel & Stark, Eur. Phys. J. E (2012). Units: µm, pN, s.
"""

from ._version import __version__

from .errors import FlagellumError, ParameterError, SimulationError  # noqa: E402
from .params import Filament, Fluid, Friction, Params  # noqa: E402
from .helix import Helix, discrete_helix  # noqa: E402

__all__ = ["Filament", "Fluid", "Friction", "Params", "Helix", "discrete_helix",
           "FlagellumError", "ParameterError", "SimulationError", "__version__", "open_trajectory"]

#: names imported on first use (name → module below flagellum)
_LAZY = {"open_trajectory": "trajectory"}


def __getattr__(name):
    if name in _LAZY:
        from importlib import import_module

        return getattr(import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
