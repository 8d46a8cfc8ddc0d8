"""flagellum: motor-driven bacterial flagella and their buckling instabilities.

Reproduces and extends Vogel & Stark, Eur. Phys. J. E (2012). Units: µm, pN, s.
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("flagellum")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0+unknown"

from .errors import FlagellumError, ParameterError, SimulationError  # noqa: E402
from .params import Filament, Fluid, Friction, Params  # noqa: E402
from .helix import Helix, discrete_helix  # noqa: E402

__all__ = ["Filament", "Fluid", "Friction", "Params", "Helix", "discrete_helix",
           "FlagellumError", "ParameterError", "SimulationError", "__version__"]
