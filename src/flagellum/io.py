"""File output: atomic writes, so that no half-written file is ever left behind."""

from __future__ import annotations

import glob
import os
import shutil
import tempfile
from contextlib import ExitStack, contextmanager
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


def csv_text(columns: dict, units: dict | None = None) -> str:
    """``{name: values}`` as CSV text with a header line. Columns may differ in length (short
    ones are padded with empty cells); floats are written with 10 significant digits (``nan``,
    ``inf`` as such), ``None`` as an empty cell, other values as text with ``,`` → ``;``.
    ``units`` ({name: unit}) writes the header of those columns as ``name [unit]``."""
    names = list(columns)
    cols = [list(np.atleast_1d(np.asarray(columns[k], dtype=object))) for k in names]
    n = max((len(c) for c in cols), default=0)
    units = units or {}
    lines = [",".join(f"{k} [{units[k]}]" if units.get(k) else k for k in names)]
    for i in range(n):
        row = []
        for c in cols:
            v = c[i] if i < len(c) else ""
            if isinstance(v, (float, np.floating)):
                row.append(f"{float(v):.10g}")
            elif v is None:
                row.append("")
            else:
                row.append(str(v).replace(",", ";"))
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def write_csv(path: str | Path, columns: dict, units: dict | None = None) -> Path:
    """Write :func:`csv_text` of ``columns`` (headers with ``units``) to ``path`` atomically;
    returns the path."""
    atomic_write_text(path, csv_text(columns, units))
    return Path(path)


# -- trajectories (HDF5) ----------------------------------------------------------------
#
# Crash safety: a trajectory file is never modified in place. While a run is going, each
# checkpoint interval's records go to a new part file ``<output>.parts/NNNNNNNN.h5``, written
# atomically; :func:`finish_trajectory` writes the main file anew (atomically) from its
# attributes and all parts. A kill at any instant therefore leaves whole files only.

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

#: ``status`` of a main file whose records are still in its parts
RUNNING = "running"


def provenance() -> dict:
    """Package version, git revision (if in a checkout), host and time."""
    import datetime
    import platform
    import subprocess

    from ._version import __version__

    rev = ""
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5, cwd=Path(__file__).parent).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return {"version": __version__, "git_revision": rev, "host": platform.node(),
            "python": platform.python_version(),
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat()}


def _init_datasets(f, n: int, attrs: dict) -> None:
    for k, v in attrs.items():
        f.attrs[k] = v
    for name, (shape, dt) in RECORD_FIELDS.items():
        s = shape(n)
        f.create_dataset(name, shape=(0,) + s, maxshape=(None,) + s, dtype=dt,
                         chunks=(max(1, min(1024, 65536 // max(1, int(np.prod(s))))),) + s)


def _append(f, records: dict) -> None:
    n_old, m = f["t"].shape[0], len(records["t"])
    for name in RECORD_FIELDS:
        f[name].resize(n_old + m, axis=0)
        f[name][n_old:] = records[name]


def create_trajectory(path, n: int, attrs: dict) -> None:
    """Create an empty, chunked, resizable trajectory file (atomically)."""
    import h5py

    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            _init_datasets(f, n, attrs)


def parts_dir(path) -> Path:
    path = Path(path)
    return path.with_name(path.name + ".parts")


def part_files(path) -> list[Path]:
    """The complete part files of ``path``, in order."""
    d = parts_dir(path)
    parts = [p for p in d.glob("*.h5") if p.stem.isdigit()] if d.is_dir() else []
    return sorted(parts, key=lambda p: int(p.stem))


def write_part(path, index: int, records: dict) -> None:
    """Write one interval's records (dict of equally long lists) as part ``index`` of ``path``."""
    import h5py

    with atomic_path(parts_dir(path) / f"{index:08d}.h5") as tmp:
        with h5py.File(tmp, "w") as f:
            for name in RECORD_FIELDS:
                f[name] = np.asarray(records[name], float)


def drop_parts(path, keep: int = 0) -> None:
    """Delete the parts from index ``keep`` on (all: also the folder) and any temporary file
    that a killed atomic write left there."""
    d = parts_dir(path)
    if d.is_dir():
        for p in d.iterdir():
            if not (p.suffix == ".h5" and p.stem.isdigit() and int(p.stem) < keep):
                p.unlink()
        if keep == 0:
            d.rmdir()


def drop_temps(path) -> None:
    """Remove the temporary files that killed atomic writes of ``path`` left next to it."""
    path = Path(path)
    pre, suf = f".{path.stem}.", f".tmp{path.suffix}"
    for p in path.parent.glob(f"{glob.escape(pre)}*{glob.escape(suf)}"):
        middle = p.name[len(pre):-len(suf)]
        if len(middle) == 8 and "." not in middle:  # mkstemp's random part
            p.unlink(missing_ok=True)


def finish_trajectory(path, tail: dict | None = None, final_state=None,
                      attrs: dict | None = None) -> None:
    """Atomically rewrite ``path`` with its attributes updated by ``attrs``, the records of
    all its parts, then those ``tail`` records later than the last part, and ``final_state``.

    The parts are kept (a checkpoint may still refer to them); memory holds one part at a time.
    """
    import h5py

    with h5py.File(path, "r") as f:
        old, n = dict(f.attrs), f["angles"].shape[1] - 1
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            _init_datasets(f, n, {**old, **(attrs or {})})
            for p in part_files(path):
                with h5py.File(p, "r") as part:
                    _append(f, {k: part[k][()] for k in RECORD_FIELDS})
            if tail is not None and len(tail["t"]):
                t = np.asarray(tail["t"], float)
                new = t > f["t"][-1] if f["t"].shape[0] else np.ones(len(t), bool)
                _append(f, {k: np.asarray(v, float)[new] for k, v in tail.items()})
            if final_state is not None:
                f["final_state"] = final_state


def read_trajectory(path, records: bool = True) -> dict:
    """All records and attributes of a trajectory file (of a running or killed run: from
    its parts). A file without records (no ``t``), or ``records=False``, yields the
    attributes only."""
    import h5py

    from .errors import ParameterError

    def bad(why):
        return ParameterError("file", str(path), f"a readable flagellum HDF5 file ({why})")

    try:
        with h5py.File(path, "r") as f, ExitStack() as stack:
            out = {"attrs": dict(f.attrs)}
            parts = part_files(path) if str(out["attrs"].get("status", "")) == RUNNING else []
            sources = [stack.enter_context(h5py.File(p, "r")) for p in parts] or [f]
            if records and "t" in f:
                out.update({k: np.concatenate([s[k][()] for s in sources]) for k in RECORD_FIELDS})
            if records and "final_state" in f:
                out["final_state"] = f["final_state"][()]
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise bad(exc) from None
    if "t" in out:
        m, n = len(out["t"]), np.shape(out["positions"])[1:2]
        for name, (shape, _) in RECORD_FIELDS.items():
            if not n or out[name].shape != (m,) + shape(n[0] - 1) or out[name].dtype.kind != "f":
                raise bad(f"dataset {name} has shape {out[name].shape}")
    return out


def check_writable(path: Path, nbytes: int = 0) -> None:
    """Fail before a run if ``path`` cannot be written or its disk lacks ``nbytes``."""
    from .errors import ParameterError

    path = Path(path)
    d = path.parent if str(path.parent) else Path(".")
    if d.exists() and not d.is_dir():
        raise ParameterError("output", str(path), "a path in a writable directory")
    try:
        d.mkdir(parents=True, exist_ok=True)
        probe = d / f".{path.name}.probe"
        probe.write_bytes(b"0")
        probe.unlink()
    except OSError as exc:
        raise ParameterError("output", str(path), f"a path in a writable directory ({exc.strerror})")
    free = shutil.disk_usage(d).free
    if nbytes > free:
        raise ParameterError("output", str(path), f"on a disk with {nbytes / 1e6:.3g} MB free "
                             f"for this run (it has {free / 1e6:.3g} MB)")
