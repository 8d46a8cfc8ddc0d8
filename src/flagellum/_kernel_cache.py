"""Where Numba caches the kernels of an installed package: a cache built with the wheel.

A wheel build (``pip install .``; ``setup.py``, ``build_py``) compiles the solvers' kernels
(:mod:`flagellum.warmup`) into the folder :data:`DIRNAME` inside the built package, which is
installed with it, so that the first run after the install loads them instead of compiling
(docs/benchmarks.md, "Compile pause"). Numba's own locators cannot find such a cache: the
in-tree one keys the cache by the source file's modification time in older Numba versions
(an install writes new times), the user-wide one by the source's absolute path.
:class:`PackageCacheLocator` keys it by what the compiled code depends on and nothing else:

* the cache folder is ``DIRNAME/<subpackage>/`` inside the package, wherever it is installed;
* the source stamp is the SHA-256 of the source file's bytes together with the versions of
  Numba, llvmlite and NumPy: touching a file keeps its cache, editing it or installing
  other versions of these libraries makes Numba recompile (a stale index reads as empty,
  the new code overwrites it); Numba's index adds the CPU (``magic_tuple``), so a package
  built on another CPU recompiles in the same silent way.

It applies only where the package holds that folder (built wheels; an editable install
or a source checkout has none and keeps Numba's default: ``__pycache__`` next to the
source), where ``NUMBA_CACHE_DIR`` is not set (an explicit cache folder wins: the
benchmarks and tests that start from an empty cache use it) and where the folder is
writable (otherwise Numba's defaults: the user-wide cache folder).
"""

from __future__ import annotations

import functools
import hashlib
import os

from numba.core import caching, config

#: the cache folder inside the package, created by the wheel build
DIRNAME = "_numba_cache"
PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
# (Numba 0.68 dropped the underscores of these names)
_BASE = getattr(caching, "_CacheLocator", None) or getattr(caching, "CacheLocator")
_IMPL = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)


@functools.lru_cache(maxsize=None)
def _content_hash(path: str, *stat_key) -> str:
    # (the stat fields only key the memo, so that an edit in a running process is seen;
    # the change time too: an edit that keeps the size and restores the mtime changes it)
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def source_stamp(path: str) -> tuple:
    """The stamp of the kernels compiled from ``path``: its content and the compiler's versions."""
    import llvmlite
    import numba
    import numpy

    st = os.stat(path)
    key = (st.st_mtime_ns, st.st_ctime_ns, st.st_size, st.st_ino)
    return (_content_hash(path, *key), numba.__version__,
            llvmlite.__version__, numpy.__version__)


class PackageCacheLocator(_BASE):
    """The cache of a function defined in this package, in ``DIRNAME`` inside the package."""

    #: the package whose functions this locator serves (a parameter for the tests)
    package_dir = PACKAGE_DIR

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        rel = os.path.relpath(os.path.dirname(os.path.abspath(py_file)), self.package_dir)
        self._cache_path = os.path.normpath(os.path.join(self.package_dir, DIRNAME, rel))

    def get_cache_path(self):
        return self._cache_path

    def get_source_stamp(self):
        return source_stamp(self._py_file)

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if config.CACHE_DIR or not os.path.isdir(os.path.join(cls.package_dir, DIRNAME)):
            return None
        path = os.path.abspath(py_file)
        if not (os.path.isfile(path) and path.startswith(cls.package_dir + os.sep)):
            return None
        self = cls(py_func, py_file)
        try:
            self.ensure_cache_path()
        except OSError:  # a read-only install: Numba's defaults
            return None
        return self


def register() -> None:
    """Put :class:`PackageCacheLocator` first among Numba's locators (once); must run before
    the first ``njit(cache=True)`` of the package (``flagellum._jit`` does it). A Numba whose
    caching module has another layout keeps its own locators."""
    classes = getattr(_IMPL, "_locator_classes", None)
    if isinstance(classes, list) and PackageCacheLocator not in classes:
        classes.insert(0, PackageCacheLocator)
