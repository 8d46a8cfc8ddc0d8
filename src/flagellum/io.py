"""File output: atomic writes, so that no half-written file is ever left behind; CSV;
provenance; the HDF5 (netCDF-4) trajectory files."""

from __future__ import annotations

import glob
import math
import os
import shutil
import stat
import tempfile
from contextlib import ExitStack, contextmanager
from pathlib import Path

import numpy as np


MAX_CONFIG_BYTES = 1 << 20  #: largest TOML file read (a parameter file is a few hundred bytes)


def input_file(path, name: str = "file", max_bytes: int | None = None) -> Path:
    """``path`` checked, before anything reads it, to be an existing regular file (a FIFO or
    a device would block or never end the read) of at most ``max_bytes``."""
    from .errors import ParameterError

    if not str(path).strip():
        raise ParameterError(name, str(path), "a file name")
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ParameterError(name, str(path), f"an existing file ({exc.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        raise ParameterError(name, str(path), "a regular file (not a directory, FIFO or device)")
    if max_bytes is not None and st.st_size > max_bytes:
        raise ParameterError(name, str(path), f"a file of at most {max_bytes} bytes")
    return Path(path)


def read_text(path, name: str = "file", max_bytes: int = MAX_CONFIG_BYTES) -> str:
    """The text of a small input file (a parameter file, a motor-law table), read only after
    :func:`input_file` checked it; a file that is not UTF-8 text is a
    :class:`~flagellum.errors.ParameterError` naming ``name``."""
    from .errors import ParameterError

    try:
        return input_file(path, name, max_bytes).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else "not UTF-8 text"
        raise ParameterError(name, str(path), f"a readable text file ({why})") from None


def output_file(path, name: str = "output") -> Path:
    """``path`` checked as a file to (re)place: a name, and a regular file where something
    is there already (a rename would replace a symlink, directory entry or device)."""
    from .errors import ParameterError

    if not str(path).strip():
        raise ParameterError(name, str(path), "a file name")
    try:
        st = os.lstat(path)
    except OSError:  # nothing there (or unreachable: the write reports it)
        return Path(path)
    if not stat.S_ISREG(st.st_mode):
        raise ParameterError(name, str(path), "a regular file or a new name (not a symlink, "
                                              "directory or device)")
    return Path(path)


class OutputLock:
    """An exclusive lock on ``<path>.lock`` (``flock``), held by one run of ``path`` (its main
    file, parts and checkpoint) for its lifetime. The kernel drops the lock of a process that
    dies, so a killed run's lock file blocks nobody; :meth:`release` removes the file."""

    def __init__(self, path, name: str = "output"):
        self.path = Path(path).with_name(Path(path).name + ".lock")
        self.name, self._fd = name, None

    def acquire(self) -> "OutputLock":
        import fcntl

        from .errors import ParameterError

        self.path.parent.mkdir(parents=True, exist_ok=True)  # (the run's output folder)
        while self._fd is None:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
                os.close(fd)
                raise ParameterError(self.name, str(self.path)[:-5], "a file that no other run is "
                                     f"writing (process {holder} holds {self.path.name})") from None
            try:
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:  # removed by the run that held it just now
                same = False
            if same:
                os.ftruncate(fd, 0)
                os.pwrite(fd, str(os.getpid()).encode(), 0)
                self._fd = fd
            else:
                os.close(fd)
        return self

    def release(self) -> None:
        if self._fd is not None:
            self.path.unlink(missing_ok=True)  # while still held: no one locks a removed file
            os.close(self._fd)
            self._fd = None


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path next to ``path``; on success fsync and rename it onto ``path``.

    On an exception the temporary file is removed and ``path`` is left untouched. ``path``
    must be a regular file or a new name (:func:`output_file`).
    """
    path = output_file(path)
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


class _WriteGuard:
    """A file object for HDF5 that keeps the first failed write (a full disk) instead of
    letting HDF5 see it: HDF5 fails badly on a write error while it closes a file (h5py
    crashes with a segmentation fault in its object teardown), so the error is raised only
    after the file was closed (:func:`new_hdf5`)."""

    def __init__(self, fh):
        self._fh, self.error = fh, None

    def write(self, data):
        view = memoryview(data).cast("B")
        done = 0
        while self.error is None and done < len(view):  # (an unbuffered write may be partial)
            try:
                done += self._fh.write(view[done:])
            except OSError as exc:
                self.error = exc
        return len(view)

    def truncate(self, size=None):
        if self.error is None:
            try:
                return self._fh.truncate(size)
            except OSError as exc:
                self.error = exc
        return size

    def __getattr__(self, name):  # read, readinto, seek, tell, flush
        return getattr(self._fh, name)


@contextmanager
def new_hdf5(path):
    """Yield a new ``h5py.File`` at ``path`` (normally a temporary file of
    :func:`atomic_path`), written through :class:`_WriteGuard`: a failed write is raised as
    the ``OSError`` it was, after HDF5 has closed the file, never inside HDF5."""
    import h5py

    with open(path, "w+b", buffering=0) as fh:  # unbuffered: errors come from write, nowhere else
        guard = _WriteGuard(fh)
        try:
            with h5py.File(guard, "w") as f:
                yield f
        except Exception:
            if guard.error is not None:  # what HDF5 made of the lost write: the write's error
                raise guard.error from None
            raise
        if guard.error is not None:
            raise guard.error


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


# -- trajectories (HDF5 in the netCDF-4 layout) --------------------------------------------
#
# Crash safety: a trajectory file is never modified in place. While a run is going, each
# checkpoint interval's records go to a new part file ``<output>.parts/NNNNNNNN.h5``, written
# atomically; :func:`finish_trajectory` writes the main file anew (atomically) from its
# attributes and all parts. A kill at any instant therefore leaves whole files only.
#
# The main file is a netCDF-4 file (an HDF5 file whose dimensions are HDF5 dimension
# scales): ``xarray.open_dataset(path, engine="h5netcdf")`` and netCDF tools see the named
# dimensions time, bead, xyz (and state), their coordinates, CF ``units`` and ``long_name``
# on every variable, and the run's parameters as global attributes. Part files are plain
# HDF5 (one dataset per record field), internal to a running run.

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
    "relative_motor_speed": (lambda n: (), "f8"),
    "body_position": (lambda n: (3,), "f8"),
    "body_axis": (lambda n: (3,), "f8"),
    "body_angular_velocity": (lambda n: (3,), "f8"),
    "body_orientation": (lambda n: (3,), "f8"),
    "end_force": (lambda n: (), "f8"),
    "extension": (lambda n: (), "f8"),
}
#: record fields that files written before they existed lack: read as these values
#: (:class:`flagellum.trajectory.Trajectory` fills ``relative_motor_speed`` from the others)
ADDED_FIELDS = {"relative_motor_speed": math.nan, "body_position": math.nan,
                "body_axis": math.nan, "body_angular_velocity": math.nan,
                "body_orientation": math.nan, "end_force": 0.0, "extension": math.nan}
#: the record fields of a polymorphic run only (its files have the attribute POLYMORPH_ATTR)
POLYMORPH_FIELDS = {"polymorph": (lambda n: (n,), "f8")}
POLYMORPH_ATTR = "polymorph_forms"

#: the record fields in a file: name → (dimensions of one record, CF units, long_name); the
#: first dimension of every field is ``time``. Units are UDUNITS strings (µm, pN, s, rad).
RECORD_META = {
    "t": ((), "s", "simulated time"),
    "positions": (("bead", "xyz"), "um", "bead position in the lab frame (bead 0: at the motor)"),
    "angles": (("bead",), "rad", "material angle about the tangent: hook frame at bead 0, "
                                 "bond i (from bead i-1 to bead i) at bead i"),
    "hook_tangent": (("xyz",), "1", "unit tangent of the hook frame"),
    "thrust": ((), "pN", "force of the filament on its anchor along e_z"),
    "anchor_force": (("xyz",), "pN", "elastic force on bead 0"),
    "motor_speed": ((), "rad/s", "rotation rate of the hook frame about e_z"),
    "motor_angle": ((), "rad", "accumulated (unwrapped) rotation of the hook frame about e_z"),
    "torque": ((), "pN um", "motor torque applied (an output of a speed clamp or a motor law)"),
    "energy": ((), "pN um", "elastic energy of the filament"),
    "frame_angle": ((), "rad", "angle of the co-rotating computational frame about e_z"),
    "relative_motor_speed": ((), "rad/s", "motor speed relative to the body: rotation rate of "
                                          "the hook frame minus the body's, about the motor axis"),
    "body_position": (("xyz",), "um", "centre of the cell body (anchored or centred body: bead 0)"),
    "body_axis": (("xyz",), "1", "unit symmetry axis of the cell body, rear (motor) pole to "
                                 "front (e_z without a cell body)"),
    "body_angular_velocity": (("xyz",), "rad/s", "angular velocity of the cell body in the lab frame"),
    "body_orientation": (("xyz",), "rad", "orientation of the cell body: rotation vector (|.| <= pi) "
                                          "from its start, motor axis along e_z (0 without a cell body)"),
    "end_force": ((), "pN", "load pulling the free end along -e_z (extending the filament)"),
    "extension": ((), "um", "end-to-end extension along the motor axis, z(bead 0) - z(last bead)"),
}
POLYMORPH_META = {
    "polymorph": (("segment",), "1", "polymorphic order parameter of each joint (integers: the "
                                    "forms of the attribute polymorph_forms in order, 0 the first)"),
}
#: the time coordinate's name in a file (``t`` in the records)
TIME = "time"
#: coordinate variables other than time: name → (values for n segments, attributes)
COORDINATES = {
    "bead": (lambda n: np.arange(n + 1), {"units": "1", "long_name": "bead index (0: at the motor)"}),
    "xyz": (lambda n: np.array(["x", "y", "z"]),
            {"long_name": "Cartesian component in the lab frame (e_z: the motor axis)"}),
}
POLYMORPH_COORDINATES = {
    "segment": (lambda n: np.arange(1, n + 1), {"units": "1", "long_name": "joint index: joint j "
                                                "sets bond j relative to bond j-1 (bond 0: the hook frame)"}),
}


def record_layout(attrs: dict) -> tuple[dict, dict, dict]:
    """(fields, meta, coordinates) of the records of a file with attributes ``attrs``: those
    of every run, plus the polymorphic state where ``attrs`` name the forms."""
    if POLYMORPH_ATTR in attrs:
        return ({**RECORD_FIELDS, **POLYMORPH_FIELDS}, {**RECORD_META, **POLYMORPH_META},
                {**COORDINATES, **POLYMORPH_COORDINATES})
    return RECORD_FIELDS, RECORD_META, COORDINATES


TIME_ATTRS = {"standard_name": "time", "axis": "T"}
#: ``final_state``: the simulator's state vector (no single unit: µm and rad)
STATE_ATTRS = {"long_name": "simulator state at the end of the run (bead 0's position, then "
                            "position and material angle of each further bead: um and rad)"}
#: global attribute that names the conventions followed
CONVENTIONS = {"Conventions": "CF-1.8"}
#: HDF5 dimension-scale name of a netCDF-4 dimension without a coordinate variable
_NOT_A_VARIABLE = "This is a netCDF dimension but not a netCDF variable."

#: ``status`` of a main file whose records are still in its parts
RUNNING = "running"


def provenance() -> dict:
    """Package version, git revision, host and time: the revision of the checkout the
    package runs from (editable install), else the one it was built from."""
    import datetime
    import platform

    from ._version import __version__, git_revision

    return {"version": __version__, "git_revision": git_revision(), "host": platform.node(),
            "python": platform.python_version(),
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat()}


def netcdf_attrs(attrs: dict) -> dict:
    """``attrs`` as netCDF attributes: booleans as 0/1 (netCDF has no boolean type)."""
    return {k: np.int8(v) if isinstance(v, (bool, np.bool_)) else v for k, v in attrs.items()}


def _stored(name: str) -> str:
    """A record field's dataset name in a main file."""
    return TIME if name == "t" else name


def _init_datasets(f, n: int, attrs: dict) -> None:
    import h5py

    f.attrs.update(netcdf_attrs({**CONVENTIONS, **attrs}))
    fields, meta, coordinates = record_layout(attrs)
    for name, (shape, dt) in fields.items():
        s = shape(n)
        ds = f.create_dataset(_stored(name), shape=(0,) + s, maxshape=(None,) + s, dtype=dt,
                              chunks=(max(1, min(1024, 65536 // max(1, int(np.prod(s))))),) + s)
        _, units, long_name = meta[name]
        ds.attrs.update({"units": units, "long_name": long_name, **(TIME_ATTRS if name == "t" else {})})
    for name, (values, coord_attrs) in coordinates.items():
        v = values(n)
        if v.dtype.kind == "U":
            f.create_dataset(name, data=v.astype(object), dtype=h5py.string_dtype())
        else:
            f.create_dataset(name, data=v)
        f[name].attrs.update(coord_attrs)
    for dim in (TIME, *coordinates):
        f[dim].make_scale(dim)
    for name in fields:
        if name != "t":
            for axis, dim in enumerate((TIME, *meta[name][0])):
                f[name].dims[axis].attach_scale(f[dim])


def _write_state(f, state) -> None:
    """``final_state`` along the netCDF-4 dimension ``state`` (one without coordinates)."""
    state = np.asarray(state, float)
    f.create_dataset("state", shape=state.shape, dtype=">f4")
    f["state"].make_scale(f"{_NOT_A_VARIABLE}{len(state):10d}")
    f["final_state"] = state
    f["final_state"].attrs.update(STATE_ATTRS)
    f["final_state"].dims[0].attach_scale(f["state"])


def _append(f, records: dict) -> None:
    n_old, m = f[TIME].shape[0], len(records["t"])
    for name in records:
        ds = f[_stored(name)]
        ds.resize(n_old + m, axis=0)
        ds[n_old:] = records[name]


def create_trajectory(path, n: int, attrs: dict) -> None:
    """Create an empty, chunked, resizable trajectory file (atomically)."""
    with atomic_path(path) as tmp:
        with new_hdf5(tmp) as f:
            _init_datasets(f, n, attrs)


def parts_dir(path) -> Path:
    path = Path(path)
    return path.with_name(path.name + ".parts")


def part_files(path) -> list[Path]:
    """The complete part files of ``path``, in order."""
    d = parts_dir(path)
    parts = [p for p in d.glob("*.h5") if p.stem.isdigit()] if d.is_dir() else []
    return sorted(parts, key=lambda p: int(p.stem))


def part_path(path, index: int) -> Path:
    """Part file ``index`` of ``path``."""
    return parts_dir(path) / f"{index:08d}.h5"


def part_last_time(part) -> float:
    """The time of a part file's last record [s]."""
    import h5py

    with h5py.File(part, "r") as f:
        return float(f["t"][-1])


def write_part(path, index: int, records: dict) -> None:
    """Write one interval's records (dict of equally long lists) as part ``index`` of ``path``."""
    with atomic_path(part_path(path, index)) as tmp:
        with new_hdf5(tmp) as f:
            for name in records:
                f[name] = np.asarray(records[name], float)


def file_digest(path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


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


def _n_segments(f) -> int:
    """Segments of a main file (of this layout or the earlier one without dimensions)."""
    return f["angles"].shape[1] - 1


def finish_trajectory(path, tail: dict | None = None, final_state=None,
                      attrs: dict | None = None) -> None:
    """Atomically rewrite ``path`` with its attributes updated by ``attrs``, the records of
    all its parts, then those ``tail`` records later than the last part, and ``final_state``.

    The parts are kept (a checkpoint may still refer to them); memory holds one part at a time.
    """
    import h5py

    with h5py.File(path, "r") as f:
        old, n = dict(f.attrs), _n_segments(f)
    fields = record_layout(old)[0]
    with atomic_path(path) as tmp:
        with new_hdf5(tmp) as f:
            _init_datasets(f, n, {**old, **(attrs or {})})
            for p in part_files(path):
                with h5py.File(p, "r") as part:
                    m = part["t"].shape[0]
                    _append(f, {k: part[k][()] if k in part else
                                np.full((m, *fields[k][0](n)), ADDED_FIELDS[k])
                                for k in fields})
            if tail is not None and len(tail["t"]):
                t = np.asarray(tail["t"], float)
                new = t > f[TIME][-1] if f[TIME].shape[0] else np.ones(len(t), bool)
                _append(f, {k: np.asarray(v, float)[new] for k, v in tail.items()})
            if final_state is not None:
                _write_state(f, final_state)


def read_trajectory(path, records: bool = True) -> dict:
    """All records and attributes of a trajectory file (of a running or killed run: from
    its parts). A file without records (no ``time``), or ``records=False``, yields the
    attributes only. Reads files of this layout and of the earlier one (datasets without
    dimensions, the times in ``t``)."""
    import h5py

    from .errors import ParameterError

    def bad(why):  # HDF5's messages span lines
        return ParameterError("file", str(path), "a readable flagellum HDF5 file "
                              f"({' '.join(str(why).split())})")

    input_file(path)
    try:
        with h5py.File(path, "r") as f, ExitStack() as stack:
            out = {"attrs": {k: v for k, v in f.attrs.items() if k not in CONVENTIONS}}
            parts = part_files(path) if str(out["attrs"].get("status", "")) == RUNNING else []
            sources = [stack.enter_context(h5py.File(p, "r")) for p in parts]
            old_layout = "t" in f and TIME not in f
            if records and (old_layout or TIME in f):
                name = (lambda k: k) if sources or old_layout else _stored  # parts: plain names
                have = [s for s in sources or [f]]
                out.update({k: np.concatenate([s[name(k)][()] for s in have])
                            for k in record_layout(out["attrs"])[0] if k not in ADDED_FIELDS
                            or all(name(k) in s for s in have)})
            if records and "final_state" in f:
                out["final_state"] = f["final_state"][()]
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise bad(exc) from None
    if "t" in out:
        m, n = len(out["t"]), np.shape(out["positions"])[1:2]
        for k, fill in ADDED_FIELDS.items():  # a file from before these fields
            if k not in out and n:
                out[k] = np.full((m, *RECORD_FIELDS[k][0](n[0] - 1)), fill)
        for name, (shape, _) in record_layout(out["attrs"])[0].items():
            if not n or out[name].shape != (m,) + shape(n[0] - 1) or out[name].dtype.kind != "f":
                raise bad(f"dataset {name} has shape {out[name].shape}")
    return out


def check_writable(path: Path, nbytes: int = 0) -> None:
    """Fail before a run if ``path`` cannot be written or its disk lacks ``nbytes``. Creates
    nothing: folders that ``path`` still needs are judged by the nearest existing one."""
    from .errors import ParameterError

    path = output_file(path)
    d = path.parent if str(path.parent) else Path(".")
    while not d.exists() and d != d.parent:  # folders still to create: the write creates them;
        d = d.parent                          # the nearest existing one must take them
    if not d.is_dir():
        raise ParameterError("output", str(path), "a path in a writable directory")
    probe = d / f".{path.name}.probe"
    try:
        try:
            probe.write_bytes(b"0")
        finally:  # also when the write fails (a full disk): leave nothing behind
            probe.unlink(missing_ok=True)
    except OSError as exc:
        raise ParameterError("output", str(path), f"a path in a writable directory ({exc.strerror})")
    free = shutil.disk_usage(d).free
    if nbytes > free:
        raise ParameterError("output", str(path), f"on a disk with {nbytes / 1e6:.3g} MB free "
                             f"for this run (it has {free / 1e6:.3g} MB)")
