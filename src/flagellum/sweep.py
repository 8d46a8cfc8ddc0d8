"""Parameter sweeps: a grid of independent simulations written to one labelled HDF5 dataset.

A :class:`Sweep` is *fixed* parameters plus *ranges*, the axes of the grid (in order; the
first axis varies slowest). Each grid point is one task, run by a local process pool
(default) or on a ``dask.distributed`` cluster. Workers only compute and return a
dictionary; the parent process alone writes the output: after every finished point the
whole dataset is written to a temporary file that is renamed onto the output (atomic), so a
killed sweep loses at most the points in flight. ``resume=True`` keeps the finished points
(matched by :func:`point_key`, a stable key of the swept values) and computes only the
others; the dataset is ordered by the grid, so a resumed sweep equals an uninterrupted one.
Failed points count as finished; ``retry_failed=True`` computes them again, and a
``fallback`` of solver settings (e.g. ``{"method": "implicit"}``) is used for every retry,
also at once for a point that fails in the same call.

File layout (HDF5 in the netCDF-4 layout: coordinates are HDF5 dimension scales, which
``xarray.open_dataset(path, engine="h5netcdf")`` reads; CF ``units`` and ``long_name`` on
every variable and coordinate, :data:`VARIABLE_ATTRS`, :data:`PARAMETER_ATTRS`):

* one 1-D dataset per swept parameter (the coordinates, named ``dims`` in the attributes),
* one grid-shaped dataset per variable (:data:`VARIABLES`: the :class:`Summary` fields,
  ``regime``, ``steps``, ``wall_seconds``, ``status``, ``fallback``), plus ``key`` ("" = not
  finished),
* attributes: each fixed parameter, ``fixed`` and ``dims`` (JSON), ``seeds``, ``version``,
  ``git_revision``, ``host``, ``python``, ``created``.

Example
-------
>>> sweep = Sweep.create({"torque": "-2:6:0.25"}, {"time": 0.3})     # doctest: +SKIP
>>> run_sweep(sweep, "results.nc", resume=True)                       # doctest: +SKIP
>>> read_sweep("results.nc").data["thrust_mean"]                      # doctest: +SKIP
"""

from __future__ import annotations

import itertools
import json
import math
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from . import io
from .analysis.observables import Summary
from .errors import FlagellumError, ParameterError
from .grid import MAX_POINTS, MODEL_PARAMETERS, PARAMETERS, canonical_name, convert, parse_values
from .parallel import check_scheduler, check_workers, dask_pool, default_workers, process_pool
from .params import Params, positive, read_toml

if TYPE_CHECKING:
    from .hydro.options import Hydrodynamics
    from .motor import Boundary, Motor
    from .simulator import SolverOptions

#: Per-point variables of the dataset and their storage kinds.
VARIABLES: dict[str, str] = {
    **{f.name: ("i8" if f.type in ("int", int) else "f8") for f in fields(Summary)},
    "regime": "str", "steps": "i8", "wall_seconds": "f8", "status": "str",
    "fallback": "str",  #: JSON of the fallback settings that produced the point ("" = none)
}
#: variables that files of older versions lack (filled in on resume)
_OPTIONAL = {"fallback", "swimming_speed", "torque_mean", "motor_speed_mean", "body_velocity",
             "body_speed", "body_rotation_rate", "wobble_angle_deg", "path_radius", "path_pitch",
             "path_period", "path_axis_x", "path_axis_y", "path_axis_z"}
#: what a fallback may change: solver settings only (the physics of a point stays fixed)
FALLBACK_PARAMETERS = ("method", "rtol", "dt")
_FILL = {"f8": math.nan, "i8": -1, "str": ""}
FORMAT = "flagellum-sweep"

#: CF attributes of the variables: name → (units, long_name); text variables have no units
VARIABLE_ATTRS: dict[str, tuple[str | None, str]] = {
    "thrust_mean": ("pN", "mean thrust (force of the filament on its anchor along e_z)"),
    "thrust_std": ("pN", "standard deviation of the thrust"),
    "thrust_err": ("pN", "standard error of the mean thrust (block averages)"),
    "omega_mean": ("rad/s", "mean rotation rate of the motor (slope of the unwrapped hook angle)"),
    "chi_mean": ("rad/s", "mean precession rate of the filament about the motor axis"),
    "end_to_end_mean": ("um", "mean end-to-end distance"),
    "end_to_end_std": ("um", "standard deviation of the end-to-end distance"),
    "energy_final": ("pN um", "elastic energy at the end of the run"),
    "centroid_offset": ("um", "mean distance of the centroid from the motor axis"),
    "swimming_speed": ("um/s", "mean velocity of bead 0 along e_z"),
    "t_from": ("s", "start of the averaging window"),
    "t_end": ("s", "end of the run"),
    "samples": ("1", "records in the averaging window"),
    "torque_mean": ("pN um", "mean motor torque applied (operating point)"),
    "motor_speed_mean": ("rad/s", "mean motor speed relative to the body (operating point)"),
    "body_velocity": ("um/s", "net swimming speed of the body along its mean swimming direction"),
    "body_speed": ("um/s", "mean speed of the body along its (helical) path"),
    "body_rotation_rate": ("rad/s", "mean rotation rate of the body about its own axis"),
    "wobble_angle_deg": ("degree", "mean angle between the body axis and the mean swimming direction"),
    "path_radius": ("um", "radius of the helix fitted to the path of the body's centre"),
    "path_pitch": ("um", "pitch (advance per turn) of the helical path of the body"),
    "path_period": ("s", "period of one turn of the helical path of the body"),
    "path_axis_x": ("1", "x component of the unit axis of the helical path"),
    "path_axis_y": ("1", "y component of the unit axis of the helical path"),
    "path_axis_z": ("1", "z component of the unit axis of the helical path"),
    "regime": (None, "regime of the run (flagellum.analysis.regimes)"),
    "steps": ("1", "integrator steps"),
    "wall_seconds": ("s", "wall-clock time of the point in its worker"),
    "status": (None, "ok, or the one-line error of a failed point"),
    "fallback": (None, "JSON of the fallback solver settings that produced the point (empty: none)"),
    "key": (None, "stable key of the point: JSON of its swept values (empty: not finished)"),
}
#: CF attributes of the sweepable parameters (the coordinates): name → (units, long_name)
PARAMETER_ATTRS: dict[str, tuple[str | None, str]] = {
    "kappa0": ("1/um", "spontaneous curvature kappa0"),
    "tau0": ("1/um", "spontaneous torsion |tau0|"),
    "handedness": (None, "handedness of the helix"),
    "bend_rigidity": ("pN um^2", "bending rigidity A"),
    "twist_rigidity": ("pN um^2", "twist rigidity C"),
    "stretch_modulus": ("pN", "stretching modulus K"),
    "length": ("um", "contour length L"),
    "segment_length": ("um", "bond length h"),
    "viscosity": ("pN s/um^2", "viscosity of the fluid"),
    "filament_radius": ("um", "filament radius"),
    "kT": ("pN um", "thermal energy kT"),
    "friction": (None, "friction model"),
    "gamma_par": ("pN s/um^2", "parallel friction coefficient per length"),
    "gamma_perp": ("pN s/um^2", "perpendicular friction coefficient per length"),
    "gamma_rot": ("pN s", "rotational friction coefficient per length"),
    "torque": ("pN um", "motor torque M"),
    "motor_speed": ("rad/s", "speed clamp: imposed motor speed relative to the body"),
    "motor_law": (None, "torque-speed law of the motor (e-coli or a table file)"),
    "ramp_time": ("s", "ramp time of the motor torque"),
    "reversal_times": ("s", "times at which the motor reverses (CCW <-> CW)"),
    "reversal_rates": ("1/s", "rates CCW->CW, CW->CCW of random motor reversals"),
    "reversal_seed": ("1", "seed of the random reversal times"),
    "body_radius": ("um", "(equatorial) radius of the cell body"),
    "body_aspect": ("1", "polar / equatorial semi-axis of the cell body"),
    "motor_offset": ("degree", "motor position on the cell body, angle from the rear pole"),
    "anchor": (None, "anchor of bead 0"),
    "sphere_radius": ("um", "radius of the anchoring sphere"),
    "hook": (None, "hook model"),
    "hook_stiffness": ("pN um", "hook stiffness"),
    "hydrodynamics": (None, "filament mobility: rft (local) or sbt (nonlocal slender-body theory)"),
    "hydro_refresh": ("um", "bead displacement that rebuilds the frozen nonlocal mobility"),
    "time": ("s", "simulated time of each run"),
    "save_every": ("s", "interval between records"),
    "average_from": ("s", "start of the averaging window"),
    "thermal": ("1", "thermal noise on (1) or off (0)"),
    "seed": ("1", "random seed"),
    "method": (None, "integrator"),
    "rtol": ("1", "relative tolerance of CVODE"),
    "dt": ("s", "step of the fixed-step scheme"),
}


def _cf_attrs(table: Mapping, name: str) -> dict:
    """``units`` (where the quantity has one) and ``long_name`` of a variable or coordinate."""
    units, long_name = table.get(name, (None, name))
    return {"long_name": long_name, **({"units": units} if units is not None else {})}


# -- grid points ------------------------------------------------------------------------


def point_key(point: Mapping) -> str:
    """Stable key of a grid point: JSON of the swept values, names sorted (floats exact)."""
    return json.dumps({k: point[k] for k in sorted(point)})


# -- the sweep ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Sweep:
    """Fixed parameters and the ranges (axes) of a grid; build with :meth:`create`."""

    fixed: tuple[tuple[str, Any], ...] = ()
    ranges: tuple[tuple[str, tuple], ...] = ()

    @classmethod
    def create(cls, ranges: Mapping | None = None, fixed: Mapping | None = None) -> "Sweep":
        """Validate names and values; a range is a string (see :func:`parse_values`), a list
        or one value (an axis of length 1)."""
        rng = [(canonical_name(k), parse_values(k, v)) for k, v in (ranges or {}).items()]
        for name, values in rng:
            if PARAMETERS[name] is tuple and len(values) > 1:  # a grid axis of lists has no coordinate
                raise ParameterError(name, list(values), "one list of numbers (fixed), not a range")
        fix = [(canonical_name(k), convert(canonical_name(k), v)) for k, v in (fixed or {}).items()]
        names = [n for n, _ in rng + fix]
        dup = next((n for n in names if names.count(n) > 1), None)
        if dup is not None:
            raise ParameterError(dup, "given twice", "given once (as fixed or as a range)")
        sweep = cls(tuple(fix), tuple(rng))
        if sweep.size > MAX_POINTS:
            raise ParameterError("sweep", f"{sweep.size} points", f"at most {MAX_POINTS} points")
        thermal = dict(fix).get("thermal", "kT" in names or "thermal" in dict(rng))
        if len(sweep.coords.get("seed", ())) > 1 and not thermal:
            raise ParameterError("seed", sweep.coords["seed"],
                                 "swept only in thermal runs (give kT or thermal = true)")
        return sweep

    @classmethod
    def from_toml(cls, path: str | Path) -> "Sweep":
        """Read a TOML file with a ``[fixed]`` and a ``[ranges]`` table (docs/sweeps.md)."""
        data = read_toml(path)
        for table, value in data.items():
            if table not in ("fixed", "ranges") or not isinstance(value, dict):
                raise ParameterError(f"config table [{table}]", value,
                                     "a [fixed] or [ranges] table of name = value")
        return cls.create(data.get("ranges"), data.get("fixed"))

    def updated(self, ranges: Mapping | None = None, fixed: Mapping | None = None) -> "Sweep":
        """Copy in which the given names (ranges or fixed) replace their old entries; a
        replaced axis keeps its place, new axes come last."""
        ranges = {canonical_name(n): v for n, v in (ranges or {}).items()}
        fixed = {canonical_name(n): v for n, v in (fixed or {}).items()}
        axes = {n: ranges.pop(n, v) for n, v in self.ranges if n not in fixed}
        return Sweep.create({**axes, **ranges},
                            {**{n: v for n, v in self.fixed if n not in ranges.keys() | axes.keys()},
                             **fixed})

    @property
    def dims(self) -> tuple[str, ...]:
        return tuple(n for n, _ in self.ranges)

    @property
    def coords(self) -> dict[str, tuple]:
        return dict(self.ranges)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for _, v in self.ranges)

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def points(self) -> list[dict]:
        """Swept values of every grid point, in grid (C) order."""
        return [dict(zip(self.dims, combo)) for combo in itertools.product(*(v for _, v in self.ranges))]

    def values(self, point: Mapping) -> dict:
        """All given parameters of a point: fixed ones and the point's swept values."""
        return {**dict(self.fixed), **point}

    @property
    def seeds(self) -> list[int]:
        return list(self.coords.get("seed", (dict(self.fixed).get("seed", 0),)))


# -- one point ----------------------------------------------------------------------------


@dataclass(frozen=True)
class PointRun:
    """Everything one simulation of a sweep needs, validated (built cheaply in the parent)."""

    params: Params
    motor: Motor
    boundary: Boundary
    solver: SolverOptions
    thermal: bool
    seed: int
    time: float
    save_every: float
    average_from: float | None
    hydrodynamics: Hydrodynamics | None = None  #: default local RFT

    @classmethod
    def from_values(cls, v: Mapping) -> "PointRun":
        """Defaults as ``flagellum simulate``: time 0.3 s, save_every time/300, thermal with
        kT, hydrodynamics rft."""
        from .hydro.options import Hydrodynamics
        from .motor import Boundary, Motor
        from .simulator import SolverOptions

        params = Params.from_flat({k: v[k] for k in MODEL_PARAMETERS if k in v})
        params.gammas  # noqa: B018 -- resolves (and so validates) the friction model
        motor = Motor.from_flags(v.get("torque"), v.get("motor_speed"), v.get("motor_law"),
                                 ramp_time=v.get("ramp_time", 0.0),
                                 **{key: v[name] for key, name in (("reversals", "reversal_times"),
                                                                   ("reversal_rates", "reversal_rates"),
                                                                   ("reversal_seed", "reversal_seed"))
                                    if name in v})
        boundary = Boundary.from_flags(**{k: v[k] for k in ("anchor", "sphere_radius", "hook",
                                                            "hook_stiffness", "body_radius",
                                                            "body_aspect", "motor_offset") if k in v})
        thermal = bool(v.get("thermal", "kT" in v))
        solver = {"method": v.get("method"),
                  **({"rtol": v["rtol"]} if "rtol" in v else {}),
                  **({"dt": v["dt"]} if "dt" in v else {})}
        from .hydro.options import Hydrodynamics
        from .simulator import check_setup, plan_run

        t_end = positive("time", v.get("time", 0.3), 1e6)
        save_every = positive("save_every", v.get("save_every", t_end / 300), t_end)
        hydro = Hydrodynamics(**{key: v[name] for key, name in (("model", "hydrodynamics"),
                                                                ("refresh", "hydro_refresh"))
                                 if name in v})
        solver, seed = SolverOptions(**solver), v.get("seed", 0)
        check_setup(params, solver, hydro, thermal, seed, boundary)  # what Simulator would refuse
        plan_run(0.0, t_end, save_every)
        return cls(params, motor, boundary, solver, thermal, seed, t_end, save_every,
                   v.get("average_from"), hydro)

    def simulate(self) -> dict:
        """Run to ``time``; the summary fields, the regime and the integrator steps."""
        from .analysis.regimes import classify, run_frame
        from .helix import Helix
        from .simulator import Simulator

        sim = Simulator(self.params, self.motor, self.boundary, thermal=self.thermal,
                        seed=self.seed, solver=self.solver, hydrodynamics=self.hydrodynamics)
        traj = sim.run(self.time, save_every=self.save_every, progress=False)
        helix = Helix.from_filament(self.params.filament)
        regime = classify(traj.t, traj.thrust, traj.positions, helix.radius, helix.axial_length,
                          self.average_from, traj.kT, **run_frame(traj))
        return {**traj.summary(self.average_from).to_dict(), "regime": regime, "steps": sim.steps}


def _one_line(exc: BaseException) -> str:
    text = str(exc) if isinstance(exc, FlagellumError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())[:500] or type(exc).__name__


def run_point(values: Mapping) -> dict:
    """Simulate one point (the task sent to workers); never raises, a failure is ``status``."""
    t0 = time.perf_counter()
    try:
        out = {**PointRun.from_values(values).simulate(), "status": "ok"}
    except Exception as exc:  # a failed point must not end the sweep
        out = {"status": _one_line(exc)}
    return {**out, "wall_seconds": time.perf_counter() - t0}


# -- the dataset --------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepData:
    """A sweep file read back: coordinates, grid-shaped variables (with ``key``), attributes."""

    dims: tuple[str, ...]
    coords: dict
    data: dict
    attrs: dict

    @property
    def finished(self) -> np.ndarray:
        return self.data["key"] != ""

    def to_xarray(self):
        """As an ``xarray.Dataset`` (needs the optional xarray package)."""
        import xarray as xr

        return xr.Dataset({n: (self.dims, v, _cf_attrs(VARIABLE_ATTRS, n)) for n, v in self.data.items()},
                          coords={d: (d, list(self.coords[d]), _cf_attrs(PARAMETER_ATTRS, d))
                                  for d in self.dims},
                          attrs=io.netcdf_attrs(self.attrs))


def _read(ds) -> np.ndarray:
    import h5py

    if h5py.check_string_dtype(ds.dtype) is not None:
        return np.array(ds.asstr()[()], dtype=object)
    return np.array(ds[()])


def read_sweep(path: str | Path) -> SweepData:
    """Read a sweep file written by :func:`run_sweep`."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT:
                raise OSError("not a sweep file")
            dims = tuple(json.loads(f.attrs["dims"]))
            coords = {d: _read(f[d]) for d in dims}
            data = {n: _read(f[n]) for n in f if n not in dims}
            attrs = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f.attrs.items()}
    except (OSError, KeyError, ValueError) as exc:
        raise ParameterError("file", str(path), f"a readable flagellum sweep file ({exc})") from None
    return SweepData(dims, coords, data, attrs)


class _Store:
    """Grid-shaped results in memory; :meth:`save` rewrites the whole file atomically."""

    def __init__(self, sweep: Sweep, path: Path):
        self.sweep, self.path = sweep, path
        self.data = {n: np.full(sweep.shape, _FILL[k], dtype=object if k == "str" else k)
                     for n, k in VARIABLES.items()}
        self.keys = np.full(sweep.shape, "", dtype=object)
        self.retry: set[int] = set()  #: failed points of the file to compute again
        fixed = dict(sweep.fixed)
        # the mobility is recorded also at its default (not swept, not given: rft)
        model = {} if "hydrodynamics" in sweep.dims else {"hydrodynamics": "rft"}
        self.attrs = {**io.CONVENTIONS, **model, **fixed, "format": FORMAT, "format_version": 1, "dims": json.dumps(sweep.dims),
                      "fixed": json.dumps(fixed, sort_keys=True), "seeds": np.array(sweep.seeds),
                      **io.provenance()}

    @property
    def finished(self) -> np.ndarray:
        return self.keys != ""

    def put(self, index: int, point: Mapping, result: Mapping) -> None:
        idx = np.unravel_index(index, self.sweep.shape)
        for name, kind in VARIABLES.items():
            self.data[name][idx] = result.get(name, _FILL[kind])
        self.keys[idx] = point_key(point)

    def save(self) -> None:
        import h5py

        with io.atomic_path(self.path) as tmp:
            with io.new_hdf5(tmp) as f:
                f.attrs.update(io.netcdf_attrs(self.attrs))
                for name, values in self.sweep.ranges:
                    kind = "str" if PARAMETERS[name] is str else ("i1" if PARAMETERS[name] is bool else None)
                    f.create_dataset(name, data=np.array(values, dtype=object if kind == "str" else kind),
                                     dtype=h5py.string_dtype() if kind == "str" else None)
                    f[name].attrs.update(_cf_attrs(PARAMETER_ATTRS, name))
                    f[name].make_scale(name)
                for name, arr in {**self.data, "key": self.keys}.items():
                    ds = f.create_dataset(name, data=arr, dtype=h5py.string_dtype()
                                          if arr.dtype == object else None)
                    ds.attrs.update(_cf_attrs(VARIABLE_ATTRS, name))
                    for axis, dim in enumerate(self.sweep.dims):
                        ds.dims[axis].attach_scale(f[dim])

    @classmethod
    def open(cls, sweep: Sweep, path: Path, resume: bool, overwrite: bool,
             retry_failed: bool = False) -> "_Store":
        """A new store, holding the finished points of ``path`` when resuming (without the
        failed ones with ``retry_failed``)."""
        store = cls(sweep, path)
        if not path.exists():
            return store
        if not resume:
            if overwrite:
                return store
            raise ParameterError("output", str(path), "a new file (use --resume to continue it "
                                                   "or --overwrite to replace it)")
        old = read_sweep(path)
        if old.attrs.get("fixed") != store.attrs["fixed"] or set(old.dims) != set(sweep.dims) \
                or not set(VARIABLES) - _OPTIONAL <= set(old.data):
            raise ParameterError("resume", str(path), "a sweep file with the same fixed parameters, "
                                                      "swept names and variables")
        done = {k: i for i, k in enumerate(old.data["key"].ravel()) if k}
        points = sweep.points()
        lost = set(done) - {point_key(p) for p in points}
        if lost:
            raise ParameterError("resume", str(path), f"ranges that contain its {len(lost)} "
                                                      f"finished point(s) off the new grid")
        for i, point in enumerate(points):
            j = done.get(point_key(point))
            if j is None:
                continue
            if retry_failed and old.data["status"].ravel()[j] != "ok":
                store.retry.add(i)
            else:
                store.put(i, point, {n: old.data[n].ravel()[j] for n in VARIABLES if n in old.data})
        return store


# -- running ------------------------------------------------------------------------------


def _check_fallback(sweep: Sweep, fallback: Mapping | None) -> dict:
    """Validated fallback settings: solver parameters only, none of them swept."""
    out = {}
    for name, value in (fallback or {}).items():
        key = canonical_name(name)
        if key not in FALLBACK_PARAMETERS or key in sweep.dims:
            raise ParameterError("fallback", name, "one of " + ", ".join(FALLBACK_PARAMETERS)
                                 + " (solver settings that are not swept)")
        out[key] = convert(key, value)
    if out:
        from .simulator import SolverOptions

        SolverOptions(**out)
    return out



@dataclass(frozen=True)
class SweepReport:
    """Outcome of :func:`run_sweep` (counts of grid points)."""

    points: int
    finished: int  #: in the file, failed ones included
    failed: int  #: finished with a status other than "ok"
    computed: int  #: simulated by this call
    skipped: int  #: already finished in the file (resume)
    lost: int  #: whose worker died: not finished, a resume retries them
    retried: int  #: failed points computed again (``retry_failed``, ``fallback``)
    output: str
    wall_seconds: float

    def to_dict(self) -> dict:
        return asdict(self)


def run_sweep(sweep: Sweep, out: str | Path, *, resume: bool = False, overwrite: bool = False,
              workers: int | None = None, scheduler: str | None = None,
              dask_local: int | None = None, progress: bool | None = None,
              retry_failed: bool = False, fallback: Mapping | None = None) -> SweepReport:
    """Run every point of ``sweep`` not yet finished in ``out`` and write the dataset.

    Parameters
    ----------
    sweep : the grid.
    out : output HDF5 file, rewritten atomically after every finished point.
    resume : keep the finished points of an existing ``out`` (same fixed parameters and
        swept names; the new ranges must contain them) and compute only the others.
    overwrite : replace an existing ``out`` (otherwise an error, unless ``resume``).
    workers : size of the local process pool (default
        :func:`flagellum.parallel.default_workers`: ``FLAGELLUM_WORKERS`` or the CPU count).
    scheduler : address of a ``dask.distributed`` scheduler, e.g. ``tcp://host:8786``.
    dask_local : start a local dask cluster of this many single-threaded worker processes.
    progress : tqdm bar on stderr (default: when stderr is a terminal).
    retry_failed : resume, and compute the failed points of ``out`` again.
    fallback : solver settings (:data:`FALLBACK_PARAMETERS`, e.g. ``{"method": "implicit"}``
        or ``{"rtol": 1e-8}``) for retries: the failed points of ``out`` (``retry_failed``)
        and, once, every point that fails in this call. Recorded per point in ``fallback``.
    """
    t0 = time.perf_counter()
    if scheduler is not None and dask_local is not None:
        raise ParameterError("scheduler", scheduler, "not combined with dask_local")
    check_workers("workers", workers)
    check_workers("dask_local", dask_local)
    check_scheduler(scheduler)
    fallback = _check_fallback(sweep, fallback)
    resume = resume or retry_failed
    store = _Store.open(sweep, Path(out), resume, overwrite, retry_failed)
    skipped = int(store.finished.sum())
    points, tasks, invalid = sweep.points(), [], None
    for i, point in enumerate(points):
        if store.finished.flat[i]:
            continue
        fb = i in store.retry and bool(fallback)
        try:  # invalid parameters fail at once, without a worker
            PointRun.from_values({**sweep.values(point), **(fallback if fb else {})})
            tasks.append((i, fb))
        except FlagellumError as exc:
            invalid = invalid or exc
            store.put(i, point, {"status": _one_line(exc), "wall_seconds": 0.0})
    if invalid is not None and not tasks and skipped == 0:
        raise invalid  # no valid point at all: a bad input, not a sweep
    computed = lost = 0
    retried = len(store.retry)
    if not tasks:
        store.save()
    else:
        from ._progress import progress_bar, show_progress

        executor = (process_pool(min(workers or default_workers(), len(tasks)))
                    if scheduler is None and dask_local is None else dask_pool(scheduler, dask_local))
        with executor as (submit, as_completed), \
                progress_bar(total=sweep.size, initial=sweep.size - len(tasks), unit="pt",
                             desc="sweep", disable=not show_progress(progress)) as bar:
            store.save()  # the grid, once the workers are reachable
            while tasks:  # round 1: the points; round 2: their retries with the fallback
                futures = {submit(run_point, {**sweep.values(points[i]), **(fallback if fb else {})}):
                           (i, fb) for i, fb in tasks}
                tasks = []
                for fut in as_completed(futures):
                    i, fb = futures[fut]
                    try:
                        result = fut.result()
                    except Exception:  # the worker died (not the simulation): retried on resume
                        lost += 1
                        continue
                    if result.get("status") != "ok" and fallback and not fb:
                        tasks.append((i, True))
                        retried += 1
                        continue
                    store.put(i, points[i], {**result, "fallback": json.dumps(fallback) if fb else ""})
                    store.save()
                    computed += 1
                    bar.update(1)
    status = store.data["status"][store.finished]
    return SweepReport(points=sweep.size, finished=int(store.finished.sum()),
                       failed=int(np.sum(status != "ok")), computed=computed, skipped=skipped,
                       lost=lost, retried=retried, output=str(out), wall_seconds=time.perf_counter() - t0)


__all__ = ["FALLBACK_PARAMETERS", "PARAMETER_ATTRS", "VARIABLES", "VARIABLE_ATTRS", "Sweep", "SweepData", "SweepReport", "PointRun",
           "point_key", "read_sweep", "run_point", "run_sweep"]
