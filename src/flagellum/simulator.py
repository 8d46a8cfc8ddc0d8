"""The simulator: one object built from the parameter dataclasses, ``run(t_end, save_every)``.

Deterministic runs use CVODE (adaptive BDF with error control, :mod:`.integrate.cvode`);
thermal runs the drift-implicit Euler scheme of :mod:`.integrate.brownian`. Both work in a
frame co-rotating with the motor (``frame="auto"``): the aligned steadily rotating
filament is then a fixed point, which the error-controlled integrator crosses in large
steps. Outputs are always reported in the lab frame.

Example
-------
>>> sim = Simulator(Params(), Motor(1.0))                    # doctest: +SKIP
>>> traj = sim.run(0.5, save_every=1e-3)                     # doctest: +SKIP
>>> traj.summary().thrust_mean                               # doctest: +SKIP
"""

from __future__ import annotations

import json
import math
import sys
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from . import io
from .analysis.observables import Summary, summarize
from .errors import ParameterError, SimulationError
from .helix import DiscreteHelix, discrete_helix, rotation_between
from .hydro import rft
from .motor import Boundary, Motor
from .params import Params, check_choice, check_range, positive
from .rod.model import RodModel, angles, positions

MAX_STRAIN = 0.5  #: a bond stretched or compressed by more than this is a blow-up
MAX_RECORDS = 10**6  #: records per run (memory of the returned trajectory)
CHART_LIMIT = -0.8  #: re-centre a chart (and restart the integrator) when t·u falls below this


@dataclass(frozen=True)
class SolverOptions:
    """Numerical settings.

    method : ``"cvode"`` (deterministic, error-controlled) or ``"implicit"`` (fixed-step
        drift-implicit scheme; the only choice with thermal noise).
    rtol, atol : CVODE tolerances (positions in µm, angles in rad).
    dt : step of the fixed-step scheme [s].
    scheme : fixed-step scheme: ``"bdf2"`` (default: second order, L-stable, damps the stiff
        bond-scale modes without damping the slow buckling mode) or ``"theta"`` (the default
        when ``theta`` is given).
    theta : implicitness of the θ-method (scheme ``"theta"``): 1 = implicit Euler (damps the
        stiff modes, but also the buckling mode: at Δt = 5e-5 s it keeps the filament aligned
        up to M ≈ 3 pN·µm in the co-rotating frame), 1/2 = trapezoidal (exact stationary
        variance of every harmonic mode, needed for bond-scale equipartition, with
        Δt ≲ 5e-6 s; its stiff modes ring, so the force on the anchor fluctuates strongly).
    frame : ``"auto"`` (co-rotating with the motor, rate adapted on the fly), ``"lab"``,
        or a fixed rotation rate [rad/s].
    """

    method: str = "cvode"
    rtol: float = 1e-6
    atol: float = 1e-8
    dt: float = 5e-5
    theta: float | None = None
    frame: str | float = "auto"
    scheme: str | None = None

    def __post_init__(self):
        check_choice("method", self.method, ("cvode", "implicit"))
        if self.scheme is None:  # giving θ selects the θ-method
            object.__setattr__(self, "scheme", "bdf2" if self.theta is None else "theta")
        check_choice("scheme", self.scheme, ("bdf2", "theta"))
        if self.theta is None:
            object.__setattr__(self, "theta", 1.0)
        object.__setattr__(self, "rtol", check_range("rtol", self.rtol, 1e-14, 0.1))
        object.__setattr__(self, "atol", check_range("atol", self.atol, 0.0, 1.0))
        object.__setattr__(self, "dt", check_range("dt", self.dt, 1e-9, 1e-2, lo_open=False))
        object.__setattr__(self, "theta", check_range("theta", self.theta, 0.5, 1.0, lo_open=False))
        if not isinstance(self.frame, str):
            object.__setattr__(self, "frame", check_range("frame", self.frame, -1e6, 1e6, lo_open=False))
        else:
            check_choice("frame", self.frame, ("auto", "lab"))


def pinned_helix(params: Params, boundary: Boundary | None = None) -> DiscreteHelix:
    """The discrete helix turned so that its pinned rigid-body rotation axis is −e_z.

    A rigid helix pinned at bead 0 rotates steadily only about the least-resistance
    eigen-axis of its rotational resistance matrix (:func:`flagellum.hydro.rft.pinned_rotation`);
    starting there avoids a long precessing transient.
    """
    dh = discrete_helix(params.filament)
    if boundary is not None and boundary.hook == "clamped":
        return dh
    gp, gn, gr = params.gammas
    pin = rft.pinned_rotation(rft.resistance_matrix(*rft.bead_nodes(dh), gp, gn, gr), dh.axis_direction)
    rot = rotation_between(pin.axis, np.array([0.0, 0.0, -1.0]))
    return DiscreteHelix(dh.positions @ rot.T, np.einsum("ij,njk->nik", rot, dh.frames),
                         rot @ dh.axis_point, rot @ dh.axis_direction, dh.radius, dh.pitch,
                         dh.segment_length)


def pinned_omega_per_torque(params: Params) -> float:
    dh = discrete_helix(params.filament)
    gp, gn, gr = params.gammas
    return rft.pinned_rotation(rft.resistance_matrix(*rft.bead_nodes(dh), gp, gn, gr),
                               dh.axis_direction).omega_per_torque


class Trajectory:
    """Saved records of a run (lab frame) with the run's parameters."""

    def __init__(self, records: dict, meta: dict):
        self.records = {k: np.asarray(v) for k, v in records.items()}
        self.meta = meta

    def __getattr__(self, name):
        try:
            return self.__dict__["records"][name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def y(self):
        """Bead positions, shape (n_t, n+1, 3) (scipy-like alias of ``positions``)."""
        return self.records["positions"]

    def summary(self, t_from: float | None = None) -> Summary:
        """Time averages (:func:`flagellum.analysis.observables.summarize`). ω is the slope of
        the unwrapped hook angle: the rotation rate about the local helix axis at the motor
        (paper §3.1.2), also when the hook tilts (buckled: ω·e_z is smaller by cos β)."""
        return summarize(self.t, self.thrust, self.motor_angle, self.positions, self.energy,
                         self.meta.get("helix_radius", 0.2), t_from)


class Simulator:
    """Motor-driven filament (paper §2): build from parameters, then :meth:`run`.

    Parameters
    ----------
    params : physical parameters (defaults: the paper's filament).
    motor : motor torque M(t) along +e_z (M > 0 pushes).
    boundary : anchor (fixed or load sphere) and hook (free, elastic, clamped).
    thermal : add thermal noise at ``params.fluid.kT`` (needs ``method="implicit"``).
    seed : seed of the random stream (thermal runs).
    solver : :class:`SolverOptions`.
    """

    def __init__(self, params: Params | None = None, motor: Motor | None = None,
                 boundary: Boundary | None = None, *, thermal: bool = False,
                 seed: int | None = None, solver: SolverOptions | None = None):
        self.params = params or Params()
        self.motor = motor or Motor()
        self.boundary = boundary or Boundary()
        self.solver = solver or SolverOptions(method="implicit" if thermal else "cvode")
        self.thermal = bool(thermal)
        if self.thermal and self.params.fluid.kT <= 0:
            raise ParameterError("kT", self.params.fluid.kT, "> 0 for a thermal run")
        if self.thermal and self.solver.method != "implicit":
            raise ParameterError("method", self.solver.method, "'implicit' for a thermal run")
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
            raise ParameterError("seed", seed, "a non-negative integer")
        self.seed = int(seed) if seed is not None else 0
        f = self.solver.frame
        self._omega_scale = pinned_omega_per_torque(self.params) * max(
            abs(self.motor.final_torque), abs(self.motor.torque), 1e-3)
        omega = 0.0 if f == "lab" else (float(f) if not isinstance(f, str) else
                                         pinned_omega_per_torque(self.params) * self.motor.final_torque)
        self.model = RodModel(self.params, self.motor, self.boundary, omega_frame=omega)
        self.t = 0.0
        self.frame_angle = 0.0
        self.y = self.model.initial_state(pinned_helix(self.params, self.boundary))
        self._rng_state = None
        self._last_motor = None
        self.wall_seconds = 0.0
        self.steps = 0

    # -- metadata ---------------------------------------------------------------------
    def metadata(self) -> dict:
        from .helix import Helix

        return {"params_toml": self.params.to_toml(), "spec": json.dumps(self.spec()),
                "motor": json.dumps(asdict(self.motor)), "boundary": json.dumps(asdict(self.boundary)),
                "solver": json.dumps(asdict(self.solver)), "thermal": self.thermal, "seed": self.seed,
                "helix_radius": Helix.from_filament(self.params.filament).radius,
                "segments": self.model.n, **io.provenance()}

    # -- stepping ---------------------------------------------------------------------
    def _stepper(self):
        if self.solver.method == "cvode":
            from .integrate.cvode import CvodeStepper

            return CvodeStepper(self.model, self.t, self.y, self.solver.rtol, self.solver.atol)
        from .integrate.brownian import ImplicitStepper

        return ImplicitStepper(self.model, self.t, self.y, self.solver.dt,
                               kT=self.params.fluid.kT if self.thermal else 0.0,
                               seed=self.seed, rng_state=self._rng_state,
                               theta=self.solver.theta if self.solver.scheme == "theta" else None)

    def _record(self, buf: dict) -> None:
        m, y, t = self.model, self.y, self.t
        m.rhs(t, y)
        c, s = math.cos(self.frame_angle), math.sin(self.frame_angle)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        u = y[:3] / np.linalg.norm(y[:3])
        force = rot @ m.last_force
        for k, v in (("t", t), ("positions", positions(y) @ rot.T), ("angles", angles(y)),
                     ("hook_tangent", rot @ u), ("thrust", force[2]), ("anchor_force", force),
                     ("motor_speed", m.last_motor_speed),
                     ("motor_angle", self._motor_angle()), ("torque", m.motor(t)),
                     ("energy", m.last_energy), ("frame_angle", self.frame_angle)):
            buf[k].append(np.array(v, float))

    def _advance(self, stepper, t_target: float) -> np.ndarray:
        """Advance to t_target in chunks short enough that no tangent can turn by more than
        ~1/2 rad between chart checks (charts are re-centred, and the integrator restarted,
        only when a tangent has left its chart by more than 90°)."""
        rate = max(abs(self.model.omega_frame), 100.0)
        if self._last_motor is not None:  # measured motor speed, capped: transients spike it
            rate = max(rate, min(abs(self._last_motor[3]), 3.0 * self._omega_scale))
        chunk = 0.5 / rate
        step = getattr(stepper, "dt", None)
        if step:  # whole fixed steps: a shortened step would restart BDF2 with an Euler step
            chunk = step * max(1, math.floor(chunk / step))
        y = stepper.y
        while stepper.t < t_target:
            t_next = min(t_target, stepper.t + chunk)
            if t_target - t_next < 0.25 * chunk:
                t_next = t_target
            y = stepper.advance(t_next)
            if t_next < t_target and self.model.rechart(y, threshold=CHART_LIMIT):
                stepper.reset(t_next, y)
        return y

    def _motor_angle(self) -> float:
        """Accumulated rotation of the hook frame about e_z (lab), continuous in time.

        The twist about z of the hook frame relative to its rest orientation (tangent along
        −e_z): the swing–twist split 2 atan2(R10 − R01, 1 + tr R) of R = D diag(1, −1, −1),
        D = [e1 e2 t] (singular only for a hook turned to +e_z; the split of D itself is
        singular at the rest orientation). It is defined modulo 2π and unwrapped against the
        rotation predicted from the last measured rate (at first the frame rate; capped at
        3× the rigid-helix rate, so a noisy interval cannot lock the unwrapping onto an alias
        one turn per record away); records may be several turns apart as long as the rate
        changes by less than π per interval.
        """
        T, E1, E2 = self.model._ws[0], self.model._ws[1], self.model._ws[2]
        d = np.stack([E1[0], -E2[0], -T[0]], axis=1)  # D diag(1, −1, −1), at the last rhs call
        raw = 2.0 * math.atan2(d[1, 0] - d[0, 1], 1.0 + np.trace(d)) + self.frame_angle
        last = self._last_motor
        if last is None:
            angle, rate = raw, self.model.omega_frame
        else:
            t0, raw0, angle0, rate0 = last
            dt = self.t - t0
            cap = 3.0 * self._omega_scale
            pred = min(max(rate0, -cap), cap) * dt
            angle = angle0 + pred + (raw - raw0 - pred + math.pi) % (2 * math.pi) - math.pi
            rate = (angle - angle0) / dt if dt > 0 else rate0
        if not self.thermal and self.model.omega_frame == 0.0 and last is None:
            rate = self.model.last_motor_speed
        self._last_motor = (self.t, raw, angle, rate)
        return angle

    def _check(self, y: np.ndarray) -> None:
        if not np.all(np.isfinite(y)):
            raise SimulationError(f"non-finite state at t = {self.t:.6g} s")
        bonds = np.linalg.norm(np.diff(positions(y), axis=0), axis=1)
        strain = np.abs(bonds / self.model.h - 1).max()
        if strain > MAX_STRAIN:
            raise SimulationError(f"a bond strained by {strain:.0%} at t = {self.t:.6g} s "
                                  f"(limit {MAX_STRAIN:.0%}): the filament blew up")

    def run(self, t_end: float, save_every: float | None = None, output: str | Path | None = None,
            progress: bool | None = None, checkpoint_every: float | None = None) -> Trajectory:
        """Integrate from the current time to ``t_end`` [s], saving every ``save_every`` s.

        With ``output`` the records go, at each checkpoint (every ``checkpoint_every``
        simulated seconds, by default every 1000 records), to a new part file in
        ``<output>.parts/`` together with an atomically replaced checkpoint ``<output>.ckpt``,
        so memory stays bounded and a run killed at any instant can be continued with
        :meth:`resume`; at the end the parts are gathered into ``output`` (see
        :mod:`flagellum.io`) and the returned :class:`Trajectory` holds the whole run read
        back from it.
        A blow-up raises :class:`SimulationError` after saving the last good state.
        """
        t_end = check_range("time", t_end, self.t, 1e6)
        save_every = positive("save_every", save_every if save_every is not None
                              else (t_end - self.t) / 200, t_end - self.t)
        if (t_end - self.t) / save_every > MAX_RECORDS:
            raise ParameterError("save_every", save_every, f"at least time/{MAX_RECORDS:.0e} = "
                                 f"{(t_end - self.t) / MAX_RECORDS:g} s (at most {MAX_RECORDS:.0e} records)")
        if checkpoint_every is not None:
            checkpoint_every = positive("checkpoint_every", checkpoint_every, 1e6)
        flush_every = max(1, int(round(checkpoint_every / save_every))) if checkpoint_every else 1000
        plan = {"t0": self.t, "t_end": t_end, "save_every": save_every, "flush_every": flush_every}
        if output is not None:
            output = Path(output)
            n_records = len(self._times(plan)) + 1
            io.check_writable(output, 2 * n_records * _record_bytes(self.model.n))  # parts + file
            self._start_output(output, plan)
        return self._loop(plan, 0, output, progress)

    def _start_output(self, output: Path, plan: dict) -> None:
        """Remove what an earlier run into ``output`` left, create the (empty) main file."""
        checkpoint_path(output).unlink(missing_ok=True)
        io.drop_parts(output)
        with _writing(output):
            io.create_trajectory(output, self.model.n, {**self.metadata(), "status": io.RUNNING,
                                                        "plan": json.dumps(plan)})
        self._n_parts = 0

    @staticmethod
    def _times(plan) -> np.ndarray:
        t0, t_end, dt = plan["t0"], plan["t_end"], plan["save_every"]
        n_save = int(math.floor((t_end - t0) / dt + 1e-9))
        times = t0 + dt * np.arange(1, n_save + 1)
        if len(times) == 0 or times[-1] < t_end - 1e-12:
            times = np.append(times, t_end)
        return times

    def _loop(self, plan: dict, start: int, output: Path | None, progress) -> Trajectory:
        times = self._times(plan)
        flush_every = plan["flush_every"]
        if progress is None:
            progress = sys.stderr.isatty()
        buf = {k: [] for k in io.RECORD_FIELDS}
        all_buf = {k: [] for k in io.RECORD_FIELDS} if output is None else None
        if start == 0:
            self._record(buf)
        stepper = self._stepper()
        bar = _progress(len(times), progress)
        if bar is not None:
            bar.update(start)
        wall0 = time.perf_counter()
        good = (self.t, self.y.copy(), self.frame_angle)
        try:
            for i in range(start, len(times)):
                tk = times[i]
                y = self._advance(stepper, tk)
                self._check(y)
                self.frame_angle += self.model.omega_frame * (tk - self.t)
                self.t, self.y = float(tk), y
                good = (self.t, self.y.copy(), self.frame_angle)
                self._record(buf)
                changed = self.model.rechart(self.y)
                changed |= self._adapt_frame(buf)
                if bar is not None:
                    bar.update(1)
                if (i + 1) % flush_every == 0 and i + 1 < len(times):
                    self._flush(buf, all_buf, output, stepper)
                    if output is not None:
                        self._checkpoint(output, plan, i + 1, wall0)
                    changed = True  # restart the integrator at checkpoints (resume = identical)
                if changed:
                    stepper.reset(self.t, self.y)
        except OutputError:
            raise  # the parts and the last checkpoint stay as they are
        except SimulationError as exc:
            self.t, self.y, self.frame_angle = good
            if output is None:
                raise
            self._finish(output, buf, f"failed: {exc}")
            raise SimulationError(f"{exc}; last good state (t = {self.t:.6g} s) saved to {output}")
        except KeyboardInterrupt:
            if output is not None:
                self._finish(output, buf, "interrupted")
            raise
        finally:
            if bar is not None:
                bar.close()
            self.wall_seconds += time.perf_counter() - wall0
            self.steps += getattr(stepper, "n_steps", 0)
        if output is not None:
            self._finish(output, buf, "complete", wall_seconds=self.wall_seconds, steps=self.steps)
            checkpoint_path(output).unlink(missing_ok=True)
            io.drop_parts(output)
            data = io.read_trajectory(output)
            return Trajectory({k: data[k] for k in io.RECORD_FIELDS}, self.metadata())
        self._flush(buf, all_buf, output, stepper)
        return Trajectory({k: np.array(v) for k, v in all_buf.items()}, self.metadata())

    # -- checkpoints ----------------------------------------------------------------------
    def _checkpoint(self, output: Path, plan: dict, n_done: int, wall0: float) -> None:
        import h5py

        n_records = n_done + 1  # the initial record
        with _writing(output), io.atomic_path(checkpoint_path(output)) as tmp:
            with h5py.File(tmp, "w") as f:
                f["y"] = self.y
                f["ref_u"], f["ref_e"], f["ref_m"] = self.model.charts()
                f.attrs.update({"t": self.t, "frame_angle": self.frame_angle,
                                "omega_frame": self.model.omega_frame, "n_done": n_done,
                                "n_records": n_records, "n_parts": self._n_parts,
                                "plan": json.dumps(plan),
                                "rng_state": json.dumps(self._rng_state),
                                "last_motor": json.dumps(self._last_motor),
                                "wall_seconds": self.wall_seconds + time.perf_counter() - wall0,
                                "spec": json.dumps(self.spec())})

    def spec(self) -> dict:
        """Everything needed to rebuild this simulator (JSON-serializable)."""
        return {"params": self.params.to_dict(), "motor": asdict(self.motor),
                "boundary": asdict(self.boundary), "solver": asdict(self.solver),
                "thermal": self.thermal, "seed": self.seed}

    @classmethod
    def from_spec(cls, spec: dict) -> "Simulator":
        motor = dict(spec["motor"])
        if motor.get("schedule") is not None:
            motor["schedule"] = tuple(tuple(x) for x in motor["schedule"])
        return cls(Params.from_dict(spec["params"]), Motor(**motor), Boundary(**spec["boundary"]),
                   thermal=spec["thermal"], seed=spec["seed"], solver=SolverOptions(**spec["solver"]))

    @classmethod
    def resume(cls, output: str | Path, progress: bool | None = None) -> tuple["Simulator", Trajectory]:
        """Continue a run from its last checkpoint ``<output>.ckpt``; returns (simulator, trajectory).

        The continued run restarts the integrator exactly where the uninterrupted run did,
        with the same random stream, so the final file is identical (deterministic runs
        bit-for-bit).
        """
        output = Path(output)
        ckpt = checkpoint_path(output)
        attrs = io.read_trajectory(output, records=False)["attrs"]
        status = str(attrs.get("status", ""))
        try:
            if status == "complete":  # killed after writing the file, before tidying up
                ckpt.unlink(missing_ok=True)
                io.drop_parts(output)
                data = io.read_trajectory(output)
                sim = cls.from_spec(json.loads(attrs["spec"]))
                sim.wall_seconds = float(attrs.get("wall_seconds", 0.0))
                sim.steps = int(attrs.get("steps", 0))
                return sim, Trajectory({k: data[k] for k in io.RECORD_FIELDS}, sim.metadata())
            io.check_writable(output)
            for p in (output, ckpt):
                io.drop_temps(p)
            if ckpt.exists():
                sim, plan, start = cls._from_checkpoint(ckpt)
            else:  # killed before its first checkpoint: start again (CLI runs start at t = 0)
                plan, start = json.loads(attrs.get("plan", "{}")), 0
                if plan.get("t0") != 0.0:
                    raise ParameterError("resume", str(output), "a run with a checkpoint file "
                                         f"{ckpt.name} (none found; the run stopped before its "
                                         "first checkpoint)")
                sim = cls.from_spec(json.loads(attrs["spec"]))
                sim._n_parts = 0
        except (OSError, KeyError, ValueError, TypeError) as exc:
            if isinstance(exc, ParameterError):
                raise
            raise ParameterError("resume", str(output), f"a run with a readable checkpoint ({exc!r})")
        io.drop_parts(output, keep=sim._n_parts)  # parts written after the checkpoint
        if status != io.RUNNING:  # interrupted or failed: its records are in the parts again
            with _writing(output):
                io.create_trajectory(output, sim.model.n, {**attrs, "status": io.RUNNING})
        return sim, sim._loop(plan, start, output, progress)

    @classmethod
    def _from_checkpoint(cls, ckpt: Path) -> tuple["Simulator", dict, int]:
        """The simulator in the state of checkpoint ``ckpt``, its plan and the records done."""
        import h5py

        with h5py.File(ckpt, "r") as f:
            a = dict(f.attrs)
            y, charts = f["y"][()], (f["ref_u"][()], f["ref_e"][()], f["ref_m"][()])
        sim = cls.from_spec(json.loads(a["spec"]))
        sim.t, sim.y, sim.frame_angle = float(a["t"]), y, float(a["frame_angle"])
        sim.model.set_omega_frame(float(a["omega_frame"]))
        sim.model.set_charts(*charts)
        sim._rng_state = json.loads(a["rng_state"])
        sim._last_motor = tuple(json.loads(a["last_motor"]))
        sim.wall_seconds = float(a["wall_seconds"])
        sim._n_parts = int(a["n_parts"])
        return sim, json.loads(a["plan"]), int(a["n_done"])

    def _flush(self, buf, all_buf, output, stepper):
        if all_buf is not None:
            for k, v in buf.items():
                all_buf[k].extend(v)
        elif output is not None and buf["t"]:
            with _writing(output):
                io.write_part(output, self._n_parts, buf)
            self._n_parts += 1
        for v in buf.values():
            v.clear()
        self._rng_state = getattr(stepper, "rng_state", None)

    def _finish(self, output: Path, buf: dict, status: str, **attrs) -> None:
        """Write the main file from the parts and the records in ``buf`` (atomically)."""
        with _writing(output):
            io.finish_trajectory(output, buf, self.y, {"status": status, **attrs})

    def _adapt_frame(self, buf) -> bool:
        """Co-rotating frame (frame='auto'): follow the motor speed once it has settled; in
        unsteady states (buckled, oscillating) follow its mean roughly (within 25 %), which
        keeps the integrator restarts rare while the filament stays slow in that frame."""
        if self.solver.frame != "auto" or len(buf["motor_angle"]) < 5:
            return False
        t = np.array(buf["t"][-5:])
        key = "motor_angle" if self.thermal else "motor_speed"
        vals = np.array(buf[key][-5:])
        rates = np.diff(vals) / np.diff(t) if self.thermal else vals
        target = float(np.clip(np.median(rates), -3 * self._omega_scale, 3 * self._omega_scale))
        spread = float(np.ptp(rates))  # transients spike the instantaneous speed: median, capped
        cur = self.model.omega_frame
        steady = spread < 0.02 * abs(target) + 1.0
        tol = 0.01 * abs(cur) + 1.0 if steady else 0.25 * abs(target) + 1.0
        if abs(target - cur) > tol:
            self.model.set_omega_frame(target)
            return True
        return False


def run_first_success(make, attempts, t_end: float, save_every: float):
    """Run ``make(method, frame)`` for each (method, frame) of ``attempts`` until one run to
    ``t_end`` succeeds (callers list CVODE in one or two frames, then the fixed-step solver:
    it does not stall where CVODE's step size collapses). Returns (trajectory, simulator,
    method, frame, errors), trajectory None if every attempt failed; invalid parameters raise."""
    errors = []
    for method, frame in attempts:
        sim = make(method, frame)
        try:
            return sim.run(t_end, save_every=save_every, progress=False), sim, method, frame, errors
        except ParameterError:
            raise
        except SimulationError as exc:
            errors.append(f"{method}, {frame} frame: {exc}")
        except (ArithmeticError, ValueError, RuntimeError) as exc:  # e.g. raised inside the rhs
            errors.append(f"{method}, {frame} frame: {type(exc).__name__}: {exc}")
    return None, None, None, None, errors


def checkpoint_path(output: str | Path) -> Path:
    output = Path(output)
    return output.with_name(output.name + ".ckpt")


class OutputError(SimulationError):
    """An output file could not be written (disk full, …)."""


@contextmanager
def _writing(output: Path):
    """Report a failed write as one line; the parts and the last checkpoint stay usable."""
    try:
        yield
    except OSError as exc:
        keep = (f"the last checkpoint is kept: free space, then flagellum simulate --resume {output}"
                if checkpoint_path(output).exists() else "no checkpoint had been written")
        raise OutputError(f"cannot write {output} ({exc.strerror or exc}); {keep}") from None


def _record_bytes(n: int) -> int:
    return 8 * sum(int(np.prod(shape(n))) for shape, _ in io.RECORD_FIELDS.values())


def _progress(total: int, enabled: bool):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="save", desc="simulating", leave=False, dynamic_ncols=True)
