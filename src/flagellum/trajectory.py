"""A run's records: :class:`Trajectory` in memory and :class:`RunFiles` on disk.

A run with an output file writes, at each checkpoint, the records of the interval to a new
part file ``<output>.parts/NNNNNNNN.h5`` and the simulator's state to ``<output>.ckpt``
(both atomically); at the end the main file is written anew from its attributes and all
parts (:func:`flagellum.io.finish_trajectory`). A run killed at any instant therefore leaves
whole files only, readable as they are (:func:`flagellum.io.read_trajectory`) and resumable
from the last checkpoint (:meth:`flagellum.simulator.Simulator.resume`).
"""

from __future__ import annotations

import json
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import io
from .analysis.regimes import RunSummary, run_frame, summarize_run
from .errors import SimulationError

COMPLETE = "complete"  #: ``status`` of a finished run's main file


@dataclass(repr=False, eq=False)
class Trajectory:
    """Saved records of a run (lab frame) with the run's parameters.

    n_t records, N segments (N+1 beads); the fields are those of
    :data:`flagellum.io.RECORD_FIELDS`.

    Attributes
    ----------
    t : (n_t,) time [s].
    positions : (n_t, N+1, 3) bead positions [µm]; bead 0 is the anchor.
    angles : (n_t, N+1) material angles θ_i [rad] of the hook frame (0) and the bond frames
        about their tangents, relative to the charts of the rod model.
    hook_tangent : (n_t, 3) unit tangent of the hook frame.
    thrust : (n_t,) force of the filament on its anchor along e_z [pN] (paper Sec. 3.1).
    anchor_force : (n_t, 3) elastic force on bead 0 [pN].
    motor_speed : (n_t,) instantaneous rate ω_hook·e_z [rad/s]: the lab-frame angular
        velocity of the hook frame projected on the motor axis. At t = 0 the filament is
        stress-free, so the motor torque turns the hook frame against its own rotational
        drag only: the first record is of order M/(γ_R h) (2.8·10⁶ rad/s per pN·µm for the
        paper's filament); the twist spreads along the filament within γ_R L²/C ≈ 40 µs,
        and the following records show the turning filament. Averages should leave out the
        start (the summaries use the last half of the run).
    motor_angle : (n_t,) accumulated (unwrapped) rotation of the hook frame about e_z [rad];
        its slope is ``summary().omega_mean``, the rate at which the hook frame turns. It
        equals the mean of ``motor_speed`` while the hook frame turns about e_z (aligned
        filament); once the filament buckles it turns about its tilted local helix axis
        (angle β to e_z), and the mean of ``motor_speed`` is smaller, by about cos β
        (paper Sec. 3.1.1).
    torque : (n_t,) motor torque applied [pN·µm] (for a speed clamp or a torque–speed law:
        the torque the drive takes, an output).
    energy : (n_t,) elastic energy [pN·µm].
    frame_angle : (n_t,) angle of the computational (co-rotating) frame about e_z [rad].
    relative_motor_speed : (n_t,) motor speed relative to the body [rad/s]: the hook frame's
        rotation rate minus the body's, about the motor axis (the speed a torque–speed law is
        evaluated at). Anchored: ``motor_speed``; a centred body sphere: ``motor_speed`` +
        M/(8πηa³); a cell body: (ω_hook − Ω)·m with its motor axis m.
    body_position : (n_t, 3) centre of the cell body [µm] (its helical path); without a cell
        body: bead 0 (the anchor, the load sphere's or the centred body's centre).
    body_axis : (n_t, 3) unit symmetry axis of the cell body, from the rear (motor) pole to the
        front (for a sphere: the body-fixed axis through the motor's pole position); e_z
        without a cell body.
    body_angular_velocity : (n_t, 3) angular velocity Ω of the body in the lab [rad/s]
        (a centred body sphere: −M/(8πηa³) e_z; anchored: 0).
    body_orientation : (n_t, 3) the cell body's orientation [rad]: the rotation vector
        (|φ| ≤ π) that turns it from its start (motor axis along e_z) to now, lab frame
        (0 without a cell body); with ``body_position`` the body's whole rigid motion.
    end_force : (n_t,) load pulling the free end along −e_z [pN] (:class:`~flagellum.params.EndLoad`;
        0 without one).
    extension : (n_t,) end-to-end extension along the motor axis, z_0 − z_N [µm].
    polymorph : (n_t, N) polymorphic order parameter of each joint of a polymorphic run
        (:mod:`flagellum.rod.polymorph`; its forms in ``meta["polymorph_forms"]``); None for
        a single-state filament.
    meta : the run's metadata (parameters, solver, provenance:
        :meth:`flagellum.simulator.Simulator.metadata`).
    """

    t: np.ndarray
    positions: np.ndarray
    angles: np.ndarray
    hook_tangent: np.ndarray
    thrust: np.ndarray
    anchor_force: np.ndarray
    motor_speed: np.ndarray
    motor_angle: np.ndarray
    torque: np.ndarray
    energy: np.ndarray
    frame_angle: np.ndarray
    relative_motor_speed: np.ndarray | None = None
    body_position: np.ndarray | None = None
    body_axis: np.ndarray | None = None
    body_angular_velocity: np.ndarray | None = None
    body_orientation: np.ndarray | None = None
    end_force: np.ndarray | None = None
    extension: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    #: (n_t, N) or None: set from a polymorphic run's records (not a field of every run)
    polymorph = None

    def __post_init__(self):
        nt = len(np.asarray(self.t).reshape(-1))
        for name, fill in io.ADDED_FIELDS.items():
            if getattr(self, name) is None:
                setattr(self, name, np.full((nt,) + io.RECORD_FIELDS[name][0](0), fill))
        for name in io.RECORD_FIELDS:
            setattr(self, name, np.asarray(getattr(self, name), float if name in io.ADDED_FIELDS else None))
        if np.all(np.isnan(self.relative_motor_speed)) and nt:  # a file of an earlier version
            self.relative_motor_speed = self.motor_speed + float(
                self.meta.get("body_rotation_per_torque", 0.0)) * self.torque

    @classmethod
    def from_records(cls, records: dict, meta: dict) -> "Trajectory":
        """From a dict with (at least) the record fields, e.g. :func:`flagellum.io.read_trajectory`."""
        traj = cls(**{k: records[k] for k in io.RECORD_FIELDS if k in records}, meta=meta)
        if records.get("polymorph") is not None:
            traj.polymorph = np.asarray(records["polymorph"])
        return traj

    @property
    def records(self) -> dict:
        """The record fields as a dict (name → array)."""
        extra = {} if self.polymorph is None else {"polymorph": self.polymorph}
        return {**{k: getattr(self, k) for k in io.RECORD_FIELDS}, **extra}

    @property
    def y(self):
        """Bead positions, shape (n_t, n+1, 3) (scipy-like alias of ``positions``)."""
        return self.positions

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        span = f", t = {self.t[0]:.6g} … {self.t[-1]:.6g} s" if len(self.t) else ""
        segments = f", {self.positions.shape[1] - 1} segments" if self.positions.ndim == 3 else ""
        return f"Trajectory({len(self.t)} records{span}{segments})"

    def to_xarray(self):
        """The records as an ``xarray.Dataset`` laid out as the files are
        (:data:`flagellum.io.RECORD_META`): dimensions ``time``, ``bead``, ``xyz``, their
        coordinates, CF ``units`` and ``long_name`` on every variable, ``meta`` as attributes."""
        import xarray as xr

        n = self.positions.shape[1] - 1 if self.positions.ndim == 3 else int(self.meta.get("segments", 0))
        data = {}
        fields, meta, coordinates = io.record_layout(self.meta if self.polymorph is not None else {})
        for name, (shape, _) in fields.items():
            if name != "t":
                dims, units, long_name = meta[name]
                values = getattr(self, name).reshape((len(self.t), *shape(n)))
                data[name] = ((io.TIME, *dims), values, {"units": units, "long_name": long_name})
        _, units, long_name = io.RECORD_META["t"]
        coords = {io.TIME: (io.TIME, self.t, {"units": units, "long_name": long_name, **io.TIME_ATTRS}),
                  **{c: (c, values(n), attrs) for c, (values, attrs) in coordinates.items()}}
        return xr.Dataset(data, coords=coords, attrs=io.netcdf_attrs({**io.CONVENTIONS, **self.meta}))

    def summary(self, t_from: float | None = None) -> RunSummary:
        """Time averages over t ≥ ``t_from`` [s] (default: the last half of the run) and the
        regime of that window (:func:`flagellum.analysis.regimes.summarize_run`).

        ``omega_mean`` is the slope of ``motor_angle``, the rate at which the hook frame
        turns: the rotation rate about the local helix axis at the motor (paper Sec. 3.1.2),
        also when the hook tilts (buckled: the mean of ``motor_speed``, ω·e_z, is smaller by
        about cos β). ``regime`` is ``"transient"`` when the window has not settled into a
        regime, with the drifting quantities in ``drifting`` and why in ``regime_note``.
        """
        return summarize_run(self.t, self.thrust, self.motor_angle, self.positions, self.energy,
                             self.meta.get("helix_radius", 0.2), t_from, self.torque,
                             self.relative_motor_speed, body=(self.body_position, self.body_axis,
                                                              self.body_angular_velocity),
                             kT=self.kT, **run_frame(self))

    def load_summary(self, t_from: float | None = None) -> dict:
        """Means over t ≥ ``t_from`` (default: the last half) of the end load [pN], the
        extension [µm] and the anchor's force along e_z [pN] (in steady state −end_force)."""
        sel = self._window(t_from)
        return {"end_force_mean": float(np.mean(self.end_force[sel])),
                "extension_mean": float(np.mean(self.extension[sel])),
                "extension_final": float(self.extension[-1])}

    def polymorph_summary(self, t_from: float | None = None) -> dict:
        """The fraction of the joints in each form (``meta["polymorph_forms"]``) and the number
        of domain walls: means over t ≥ ``t_from`` (default: the last half) and at the end;
        the nucleation site, nucleation and transformation times, transformed fraction and
        wall speed (:func:`flagellum.rod.polymorph.transformation_events`, from the first
        record); empty for a single-state run."""
        from .rod.polymorph import domain_walls, fractions, transformation_events

        if self.polymorph is None:
            return {}
        forms = str(self.meta[io.POLYMORPH_ATTR]).split(",")
        sel = self._window(t_from)
        frac = fractions(self.polymorph, len(forms))
        return {"form_fractions": {f: float(np.mean(frac[sel, i])) for i, f in enumerate(forms)},
                "form_fractions_final": {f: float(frac[-1, i]) for i, f in enumerate(forms)},
                "domain_walls_mean": float(np.mean(domain_walls(self.polymorph[sel]))),
                "domain_walls_final": int(domain_walls(self.polymorph[-1])),
                # nucleation, growth and wall speed of the domains leaving the first record's forms
                **transformation_events(self.t, self.polymorph, self._segment_length())}

    def _segment_length(self) -> float:
        """h [µm]: the mean bead spacing of the first record."""
        return float(np.mean(np.linalg.norm(np.diff(self.positions[0], axis=0), axis=1)))

    def tumble_summary(self, reversal: tuple[float, float] | None = None,
                       window: float | None = None):
        """The tumble of a free-swimming cell (:func:`flagellum.analysis.tumble.tumble`):
        the angle between its mean swimming directions before the reversal ``(t_on, t_off)``
        and over the last ``window`` [s] of the run (and over the ``window`` right after the
        filament is wholly back in its first form), the speeds, and for a polymorphic run the
        time course of the transformation. Default ``reversal``: the motor's first two
        switching times; default ``window``: 0.1 s, shortened to the time available."""
        from .analysis.tumble import WINDOW, tumble

        if reversal is None:
            motor = json.loads(str(self.meta.get("motor", "{}")))
            times = [s for s in (motor.get("reversals") or ()) if s <= self.t[-1]]
            if len(times) < 2:
                from .errors import ParameterError

                raise ParameterError("reversal", motor.get("reversals"), "two switching times "
                                     "(t_on, t_off) within the run")
            reversal = (times[0], times[1])
        if window is None:
            window = min(WINDOW, reversal[0] - self.t[0], self.t[-1] - reversal[1])
        forms = (str(self.meta[io.POLYMORPH_ATTR]).split(",") if self.polymorph is not None
                 else None)
        return tumble(self.t, self.body_position, self.body_axis, reversal, window,
                      self.polymorph, forms)

    def _window(self, t_from):
        t0 = self.t[0] + 0.5 * (self.t[-1] - self.t[0]) if t_from is None else t_from
        sel = self.t >= t0
        return sel if sel.any() else np.ones(len(self.t), bool)

    @property
    def kT(self) -> float:
        """Thermal energy of the run's noise [pN·µm]: the parameters' kT for a thermal run,
        0 for a deterministic one (the regime criteria depend on it)."""
        if not int(self.meta.get("thermal", 0)):
            return 0.0
        try:
            return float(json.loads(str(self.meta["spec"]))["params"]["fluid"]["kT"])
        except (KeyError, TypeError, ValueError):  # a thermal run without its parameters
            from .analysis.regimes import KT_ROOM

            return KT_ROOM

    @property
    def body_rotation_rate(self) -> np.ndarray:
        """(n_t,) the body's rotation rate about its own axis, Ω·``body_axis`` [rad/s]."""
        return np.einsum("ij,ij->i", self.body_angular_velocity, self.body_axis)


def open_trajectory(path: str | Path):
    """A trajectory file (``flagellum simulate -o``; also a running or killed run's, and one
    of the earlier layout without dimensions) as an ``xarray.Dataset``, loaded into memory:
    :meth:`Trajectory.to_xarray` of its records, its attributes, and ``final_state`` (along
    ``state``) when the file has one."""
    from .errors import ParameterError

    data = io.read_trajectory(path)
    if "t" not in data:
        raise ParameterError("file", str(path), "a flagellum trajectory file with records")
    ds = Trajectory.from_records(data, data["attrs"]).to_xarray()
    if "final_state" in data:
        ds["final_state"] = (("state",), data["final_state"], dict(io.STATE_ATTRS))
    return ds


# -- files ------------------------------------------------------------------------------
def checkpoint_path(output: str | Path) -> Path:
    output = Path(output)
    return output.with_name(output.name + ".ckpt")


def record_bytes(n: int) -> int:
    """Bytes of one record of a filament with ``n`` segments."""
    return 8 * sum(int(np.prod(shape(n))) for shape, _ in io.RECORD_FIELDS.values())


def checkpoint_digest(arrays: dict, attrs: dict) -> str:
    """SHA-256 of a checkpoint's datasets (name, dtype, shape, bytes) and attributes (as
    JSON), stored in it, so that a damaged or edited checkpoint is refused on resume instead
    of handing the simulator a state it cannot use."""
    import hashlib

    h = hashlib.sha256()
    for k in sorted(arrays):
        a = np.ascontiguousarray(arrays[k])
        h.update(f"{k}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    plain = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in attrs.items()}
    h.update(json.dumps(plain, sort_keys=True, default=str).encode())
    return h.hexdigest()


class OutputError(SimulationError):
    """An output file could not be written (disk full, …)."""


@contextmanager
def writing(output: Path):
    """Report a failed write as one line; the parts and the last checkpoint stay usable."""
    try:
        yield
    except OSError as exc:
        keep = (f"the last checkpoint is kept: free space, then flagellum simulate --resume {output}"
                if checkpoint_path(output).exists() else "no checkpoint had been written")
        raise OutputError(f"cannot write {output} ({exc.strerror or exc}); {keep}") from None


class RunFiles:
    """The files of one run into ``path``: main file, part files and checkpoint.

    Every write is atomic and reports a failure as :class:`OutputError`.
    ``n_parts``: the part files written so far (the next part's index); ``digests``: their
    record counts and SHA-256 checksums, stored in each checkpoint, against which a resume
    verifies the parts (:meth:`read_checkpoint`).
    """

    def __init__(self, path: str | Path, n_parts: int = 0, name: str = "output"):
        self.path = io.output_file(path, name)  # ``name``: the parameter that gave the path
        self.n_parts = int(n_parts)
        self.digests: list[tuple[int, str]] = []
        self._lock = io.OutputLock(self.path, name)

    def lock(self) -> "RunFiles":
        """Hold the run's lock (:class:`flagellum.io.OutputLock`): a second run into the same
        files is refused until :meth:`release`."""
        self._lock.acquire()
        return self

    def release(self) -> None:
        self._lock.release()

    @property
    def checkpoint(self) -> Path:
        return checkpoint_path(self.path)

    @classmethod
    def create(cls, path: str | Path, n_segments: int, attrs: dict, n_records: int,
               overwrite: bool = False) -> "RunFiles":
        """Check that the disk takes ``n_records`` records (twice: the parts and the final
        file exist together for a moment), take the run's lock, remove what an earlier run
        into ``path`` left (an existing ``path`` only with ``overwrite``) and create the
        (empty) main file with ``attrs``; the lock is held until :meth:`release`."""
        from .errors import ParameterError

        files = cls(path)
        io.check_writable(files.path, 2 * n_records * record_bytes(n_segments))
        files.lock()
        try:
            if not overwrite and files.path.exists():
                raise ParameterError("output", str(files.path), "a new file (--overwrite replaces "
                                     "it; --resume continues a stopped run)")
            files.checkpoint.unlink(missing_ok=True)
            io.drop_parts(files.path)
            with writing(files.path):
                io.create_trajectory(files.path, n_segments, {**attrs, "status": io.RUNNING})
        except BaseException:
            files.release()
            raise
        return files

    def write_part(self, records: dict) -> None:
        """The next part file from ``records`` (dict of equally long lists; none if empty)."""
        if records["t"]:
            with writing(self.path):
                io.write_part(self.path, self.n_parts, records)
                self.digests.append((len(records["t"]),
                                     io.file_digest(io.part_path(self.path, self.n_parts))))
            self.n_parts += 1

    def write_checkpoint(self, arrays: dict, attrs: dict) -> None:
        """Atomically replace the checkpoint by ``arrays`` (datasets) and ``attrs`` (plus
        ``n_parts``)."""
        attrs = {**attrs, "n_parts": self.n_parts, "parts": json.dumps(self.digests[:self.n_parts])}
        arrays = {k: np.asarray(v) for k, v in arrays.items()}
        with writing(self.path), io.atomic_path(self.checkpoint) as tmp:
            with io.new_hdf5(tmp) as f:
                for k, v in arrays.items():
                    f[k] = v
                f.attrs.update({**attrs, "digest": checkpoint_digest(arrays, attrs)})

    def finish(self, tail: dict, final_state, status: str, **attrs) -> None:
        """Write the main file from the parts and the records in ``tail`` (atomically)."""
        with writing(self.path):
            io.finish_trajectory(self.path, tail, final_state, {"status": status, **attrs})

    def tidy(self) -> None:
        """Remove the checkpoint and the parts of a complete main file."""
        self.checkpoint.unlink(missing_ok=True)
        io.drop_parts(self.path)

    def read(self, meta: dict) -> Trajectory:
        """The records of the main file (of its parts while running), with ``meta``."""
        return Trajectory.from_records(io.read_trajectory(self.path), meta)

    # -- resume ---------------------------------------------------------------------------
    def attrs(self) -> dict:
        """The main file's attributes (:class:`~flagellum.errors.ParameterError` if unreadable)."""
        return io.read_trajectory(self.path, records=False)["attrs"]

    def read_checkpoint(self) -> tuple[dict, dict] | None:
        """(datasets, attributes) of the checkpoint, None if there is none; first checks that
        the run can be continued here (writable) and removes what killed writes left, then
        that the parts are those the checkpoint wrote (:meth:`verify`)."""
        import h5py

        io.check_writable(self.path)
        for p in (self.path, self.checkpoint):
            io.drop_temps(p)
        if not self.checkpoint.exists():
            return None
        with h5py.File(self.checkpoint, "r") as f:
            arrays, attrs = {k: f[k][()] for k in f}, dict(f.attrs)
        digest = attrs.pop("digest", None)  # (checkpoints of earlier versions have none)
        if digest is not None and str(digest) != checkpoint_digest(arrays, attrs):
            raise self._damaged(f"{self.checkpoint.name} has changed since it was written")
        self.verify(attrs)
        return arrays, attrs

    def _damaged(self, why: str):
        from .errors import ParameterError

        return ParameterError("resume", str(self.path), f"an undamaged run to continue ({why}; "
                              "start it again with --overwrite)")

    def verify(self, ckpt: dict) -> None:
        """Refuse a checkpoint (attributes ``ckpt``) that does not fit the main file and the
        parts: another run's parameters, a part missing or changed, records lost or added."""
        damaged = self._damaged
        main = self.attrs()
        if "spec" in main and str(ckpt.get("spec")) != str(main["spec"]):
            raise damaged(f"the parameters of {self.checkpoint.name} differ from the file's")
        n_parts = int(ckpt["n_parts"])
        have = {int(p.stem): p for p in io.part_files(self.path)}
        missing = [i for i in range(n_parts) if i not in have]
        if missing:
            raise damaged(f"{len(missing)} of its {n_parts} part files are missing, from "
                          f"{io.parts_dir(self.path).name}/{missing[0]:08d}.h5 on")
        digests = [tuple(d) for d in json.loads(ckpt.get("parts", "null")) or []]
        if digests:  # checkpoints of earlier versions have none
            if len(digests) != n_parts:
                raise damaged(f"the checkpoint lists {len(digests)} part files and counts {n_parts}")
            bad = next((i for i, (_, h) in enumerate(digests) if io.file_digest(have[i]) != h), None)
            if bad is not None:
                raise damaged(f"part file {bad:08d}.h5 has changed since the checkpoint")
        n_records, t = int(ckpt["n_done"]) + 1, float(ckpt["t"])  # + the initial record
        if digests and sum(n for n, _ in digests) != n_records:
            raise damaged(f"the parts hold {sum(n for n, _ in digests)} records, the checkpoint "
                          f"counts {n_records}")
        t_last = io.part_last_time(have[n_parts - 1]) if n_parts else 0.0
        if t_last != t:
            raise damaged(f"the parts end at t = {t_last:.9g} s, the checkpoint at {t:.9g} s")
        self.digests = digests

    def reopen(self, attrs: dict, n_parts: int, n_segments: int) -> None:
        """Continue after ``n_parts`` parts: drop later ones, and mark a finished (interrupted
        or failed) main file with ``attrs`` running again (its records are in the parts)."""
        self.n_parts = int(n_parts)
        io.drop_parts(self.path, keep=self.n_parts)
        if str(attrs.get("status", "")) != io.RUNNING:
            with writing(self.path):
                io.create_trajectory(self.path, n_segments, {**attrs, "status": io.RUNNING})


__all__ = ["COMPLETE", "OutputError", "RunFiles", "Trajectory", "checkpoint_path", "open_trajectory",
           "record_bytes"]
