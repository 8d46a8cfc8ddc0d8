"""Whether Numba's cache holds the solvers' kernels, and their warm-up in the background.

The kernels are compiled with ``cache=True``. A wheel build compiles them into the package
(:mod:`flagellum._kernel_cache`); where that cache is missing or stale (an editable install,
``NUMBA_CACHE_DIR``, other Numba versions or CPU) the first process compiles them (the CVODE
path, the Numba BDF and the fixed-step implicit scheme each take tens of seconds;
docs/benchmarks.md, "Compile pause"), later processes load them in ≈ 1 s.
:func:`warm_in_background` (called when a run makes its stepper) starts
``python -m flagellum.warmup`` (:func:`flagellum.warmup.warm`) for the solvers whose kernels
are not cached yet, in a detached, low-priority process: while the first run compiles its
own solver the others are compiled alongside, and every later run of any solver starts from
the cache. ``FLAGELLUM_WARMUP=0`` turns it off.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import time

#: the solver methods the warm-up compiles
METHODS = ("cvode", "bdf", "implicit")
ENV = "FLAGELLUM_WARMUP"
LOCK_SECONDS = 600.0  # a warm-up lock older than this is from a warm-up that died
_started = False


def _entry_points() -> dict:
    """The top-level kernel of each method of :data:`METHODS`."""
    from ..rod import kernels
    from . import bdf, brownian

    # (the Jacobian a default CVODE run compiles: without a cell body, the pruned kernel)
    return {"cvode": kernels.rod_colored_jacobian, "bdf": bdf.bdf_advance,
            "implicit": brownian.implicit_steps}


def cold() -> list[str]:
    """The methods of :data:`METHODS` whose top-level kernel has no valid cache index (none
    written yet, or one written for another version of its source file: Numba's own stamp
    check reads it as empty)."""
    out = []
    for method, dispatcher in _entry_points().items():
        try:
            index = dispatcher._cache._cache_file._load_index()
        except Exception:  # noqa: BLE001 - a Numba without this layout: taken as warm
            index = {"unknown": None}
        if not index:
            out.append(method)
    return out


def lock_path() -> str:
    """The lock that lets only one warm-up run per cache (sweep workers start together)."""
    from ..rod import kernels

    where = str(kernels.rhs._cache._cache_path)
    key = hashlib.sha1(where.encode()).hexdigest()[:12]
    return os.path.join(tempfile.gettempdir(), f"flagellum-warmup-{os.getuid() if hasattr(os, 'getuid') else 0}-{key}.lock")


def warm_in_background(exclude: str = "", force: bool = False) -> subprocess.Popen | None:
    """Start the warm-up of the cold methods but ``exclude`` (the one this process is about
    to compile itself), once per process unless ``force``, unless
    ``FLAGELLUM_WARMUP=0``, none is cold or another warm-up of this cache holds the lock;
    returns the process or None. Never raises: a warm-up that cannot start leaves the
    compile to the runs, as without it."""
    global _started
    if (_started and not force) or os.environ.get(ENV, "1") == "0":
        return None
    _started = True
    try:
        methods = [m for m in cold() if m != exclude]
        if not methods:
            return None
        lock = lock_path()
        try:
            if time.time() - os.path.getmtime(lock) > LOCK_SECONDS:
                os.unlink(lock)
        except OSError:
            pass
        try:
            os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return None
        env = dict(os.environ, **{ENV: "0"})  # the warm-up starts no warm-up of its own
        kwargs = {"start_new_session": True} if os.name == "posix" else {}
        return subprocess.Popen([sys.executable, "-m", "flagellum.warmup", "--lock", lock,
                                 *methods], env=env, stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                close_fds=True, **kwargs)
    except Exception:  # noqa: BLE001 - best effort by design
        return None
