"""The installed version of the package (``0.0.0+unknown`` when run from a source tree)."""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("flagellum")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0+unknown"
