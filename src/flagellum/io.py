"""File output: atomic writes, so that no half-written file is ever left behind."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path next to ``path``; on success fsync and rename it onto ``path``.

    On an exception the temporary file is removed and ``path`` is left untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        yield Path(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def atomic_write_text(path: str | Path, text: str) -> None:
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)


# -- trajectories (HDF5) ----------------------------------------------------------------

#: per-record datasets: name → (shape of one record as a function of n, dtype)
RECORD_FIELDS = {
    "t": (lambda n: (), "f8"),
    "positions": (lambda n: (n + 1, 3), "f8"),
    "angles": (lambda n: (n + 1,), "f8"),
    "hook_tangent": (lambda n: (3,), "f8"),
    "thrust": (lambda n: (), "f8"),
    "anchor_force": (lambda n: (3,), "f8"),
    "motor_speed": (lambda n: (), "f8"),
    "motor_angle": (lambda n: (), "f8"),
    "torque": (lambda n: (), "f8"),
    "energy": (lambda n: (), "f8"),
    "frame_angle": (lambda n: (), "f8"),
}


def provenance() -> dict:
    """Package version, git revision (if in a checkout), host and time."""
    import datetime
    import platform
    import subprocess

    from . import __version__

    rev = ""
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5, cwd=Path(__file__).parent).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return {"version": __version__, "git_revision": rev, "host": platform.node(),
            "python": platform.python_version(),
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat()}


def create_trajectory(path, n: int, attrs: dict) -> None:
    """Create an empty, chunked, resizable trajectory file (atomically)."""
    import h5py

    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            for k, v in attrs.items():
                f.attrs[k] = v
            for name, (shape, dt) in RECORD_FIELDS.items():
                s = shape(n)
                f.create_dataset(name, shape=(0,) + s, maxshape=(None,) + s, dtype=dt,
                                 chunks=(max(1, min(1024, 65536 // max(1, int(np.prod(s))))),) + s)


def append_records(path, records: dict, keep: int | None = None) -> int:
    """Append buffered records (dict of arrays with equal first dimension); return the count.

    ``keep`` first truncates the datasets to that many records (resume after a kill).
    """
    import h5py

    with h5py.File(path, "a") as f:
        n_old = f["t"].shape[0] if keep is None else keep
        m = len(records["t"])
        for name in RECORD_FIELDS:
            ds = f[name]
            ds.resize(n_old + m, axis=0)
            if m:
                ds[n_old:] = np.asarray(records[name])
        f.flush()
        return n_old + m


def read_trajectory(path) -> dict:
    """All records and attributes of a trajectory file."""
    import h5py

    from .errors import ParameterError

    try:
        with h5py.File(path, "r") as f:
            out = {name: f[name][()] for name in RECORD_FIELDS if name in f}
            out["attrs"] = dict(f.attrs)
            if "final_state" in f:
                out["final_state"] = f["final_state"][()]
    except (OSError, KeyError) as exc:
        raise ParameterError("file", str(path), f"a readable flagellum HDF5 file ({exc})")
    return out


def write_datasets(path, datasets: dict, attrs: dict | None = None) -> None:
    """Add or replace whole datasets and attributes of an existing file."""
    import h5py

    with h5py.File(path, "a") as f:
        for k, v in datasets.items():
            if k in f:
                del f[k]
            f[k] = v
        for k, v in (attrs or {}).items():
            f.attrs[k] = v
        f.flush()
