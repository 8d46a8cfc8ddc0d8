"""The simulator: one object built from the parameter dataclasses, ``run(t_end, save_every)``.

Deterministic runs use CVODE (adaptive BDF with error control, :mod:`.integrate.cvode`);
thermal runs the drift-implicit Euler scheme of :mod:`.integrate.brownian`; both are
:class:`~flagellum.integrate.base.Stepper` objects, built from :data:`~flagellum.integrate.base.STEPPERS`.
Both work in a frame co-rotating with the motor (``frame="auto"``): the aligned steadily
rotating filament is then a fixed point, which the error-controlled integrator crosses in
large steps. Outputs are always reported in the lab frame.

This module holds the integration loop: run planning, advancing between records with chart
checks, the blow-up check, recording, and the frame adaptation (a change of coordinates like
a re-centred chart: a stepper with ``carry`` maps its history into the new coordinates, the
others restart). The records and their files
(parts, checkpoints) are :mod:`flagellum.trajectory`.

Example
-------
>>> sim = Simulator(Params(), Motor(1.0))                    # doctest: +SKIP
>>> traj = sim.run(0.5, save_every=1e-3)                     # doctest: +SKIP
>>> traj.summary().thrust_mean                               # doctest: +SKIP
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from . import io
from ._progress import progress_bar, show_progress
from .errors import ParameterError, SimulationError
from .helix import Helix
from .hydro.body import matrix_rotvec, rotvec_matrix
from .hydro.options import Hydrodynamics
from .hydro.rft import pinned_helix, pinned_omega_per_torque
from .integrate import ATOL_PER_RTOL, MAX_STEPS_PER_ADVANCE, default_method
from .integrate.base import STEPPERS, make_stepper
from .integrate.brownian import nonlocal_dt_limit
from .motor import Boundary, Motor
from .params import EndLoad, Params, Polymorphism, check_choice, check_range, check_real, positive
from .rod import polymorph as PM
from .rod import kernels as K
from .rod.model import RodModel, angles, positions, state_size
from .trajectory import COMPLETE, OutputError, RunFiles, Trajectory

MAX_STRAIN = 0.5  #: a bond stretched or compressed by more than this is a blow-up
MAX_RECORDS = 10**6  #: records per run (memory of the returned trajectory)
MIN_SPAN = 1e-9  #: shortest run [s]: CVODE cannot step across a span at the rounding of t
#: re-centre a chart when t·u falls below this. The reference vector's parallel transport
#: from the pole u turns like 1/(1 + t·u), and tangents left until t·u < −0.5 made both
#: adaptive integrators grind at h ≈ 1e-9–1e-8 s in a whirling lab-frame run (load sphere,
#: M = 4.37 pN·µm: 20 000 steps per 1-ms chunk); re-centred at 90° the same run takes ≤ 200
#: steps per chunk (docs/benchmarks.md, "Stalls")
CHART_LIMIT = 0.0
#: carry an adaptive stepper's history through a re-centred chart or a change of the frame's
#: rate (a smooth change of coordinates, :meth:`RodModel.change_coordinates`) instead of
#: restarting it at order 1 (steppers with a ``carry`` method: the Numba BDF;
#: docs/numerics.md, "Chart and frame changes without a restart")
CARRY_HISTORY = True


@dataclass(frozen=True)
class SolverOptions:
    """Numerical settings.

    method : ``"bdf"`` (the Numba variable-order BDF), ``"cvode"`` (deterministic,
        error-controlled) or ``"implicit"`` (fixed-step drift-implicit scheme; the only choice
        with thermal noise); any key of :data:`flagellum.integrate.base.STEPPERS`. None
        (default): the run's :func:`~flagellum.integrate.default_method`, chosen by the
        :class:`Simulator` (:func:`resolve_method`).
    rtol, atol : CVODE tolerances (positions in µm, angles in rad); ``atol=None`` means
        ``rtol * ATOL_PER_RTOL`` (:data:`flagellum.integrate.ATOL_PER_RTOL`).
    dt : step of the fixed-step scheme [s].
    max_steps : internal steps an adaptive method may take per chunk between chart checks
        before the run fails (:data:`flagellum.integrate.MAX_STEPS_PER_ADVANCE`).
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

    method: str | None = None
    rtol: float = 1e-6
    atol: float | None = None
    dt: float = 5e-5
    theta: float | None = None
    frame: str | float = "auto"
    scheme: str | None = None
    max_steps: int = MAX_STEPS_PER_ADVANCE

    def __post_init__(self):
        if self.method is not None:
            check_choice("method", self.method, tuple(STEPPERS))
        if self.scheme is None:  # giving θ selects the θ-method
            object.__setattr__(self, "scheme", "bdf2" if self.theta is None else "theta")
        check_choice("scheme", self.scheme, ("bdf2", "theta"))
        if self.theta is None:
            object.__setattr__(self, "theta", 1.0)
        object.__setattr__(self, "rtol", check_range("rtol", self.rtol, 1e-14, 0.1))
        if self.atol is None:
            object.__setattr__(self, "atol", self.rtol * ATOL_PER_RTOL)
        object.__setattr__(self, "atol", check_range("atol", self.atol, 0.0, 1.0))
        object.__setattr__(self, "dt", check_range("dt", self.dt, 1e-9, 1e-2, lo_open=False))
        object.__setattr__(self, "max_steps", int(check_range("max_steps", self.max_steps, 1, 1e9,
                                                              lo_open=False)))
        object.__setattr__(self, "theta", check_range("theta", self.theta, 0.5, 1.0, lo_open=False))
        if not isinstance(self.frame, str):
            object.__setattr__(self, "frame", check_range("frame", self.frame, -1e6, 1e6, lo_open=False))
        else:
            check_choice("frame", self.frame, ("auto", "lab"))


@dataclass(frozen=True, eq=False)
class State:
    """A filament state to start a simulator from (:meth:`Simulator.from_state`).

    y : the rod model's state vector (hook tangent u0, then (x, y, z, θ) per bead;
        :func:`flagellum.rod.model.state_size`), in a frame turned by ``frame_angle``
        about e_z from the lab.
    charts : (ref_u (N+1, 3), ref_e (N+1, 3), ref_m (N+1,)), the charts of the rod model
        (:meth:`flagellum.rod.model.RodModel.charts`) in the same frame; the material
        angles in y are measured against them.
    frame_angle : [rad]; 0 when y and the charts are in the lab frame.
    phi : (N,) the polymorphic order parameters of the joints (a polymorphic simulator's
        :meth:`Simulator.state`); None: a polymorphic simulator started from this state
        takes those of its ``polymorphism.initial``.
    """

    y: np.ndarray
    charts: tuple
    frame_angle: float = 0.0
    phi: np.ndarray | None = None


def check_setup(params: Params, solver: SolverOptions, hydrodynamics: Hydrodynamics,
                thermal: bool, seed, boundary: Boundary | None = None) -> None:
    """The checks of a :class:`Simulator`'s arguments that the dataclasses cannot make alone
    (also what a sweep checks of its points before the first runs)."""
    if thermal and params.fluid.kT <= 0:
        raise ParameterError("kT", params.fluid.kT, "> 0 for a thermal run")
    if thermal and solver.method not in (None, "implicit"):
        raise ParameterError("method", solver.method, "'implicit' for a thermal run")
    if thermal and not hydrodynamics.is_local and solver.method in (None, "implicit"):
        h = params.filament.segment_length
        dt_max = nonlocal_dt_limit(params.fluid.kT, params.gammas[1], h)
        if solver.dt > dt_max:
            raise ParameterError("dt", solver.dt, f"<= {dt_max:.3g} s for a thermal run with "
                                 f"{hydrodynamics.model} hydrodynamics (a bead's thermal kick per "
                                 f"step must stay below the bond length h = {h:g} µm)")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))
                             or not 0 <= seed < 2**63):  # an int64 attribute of the files
        raise ParameterError("seed", seed, "an integer in [0, 2**63 - 1]")


def resolve_method(solver: SolverOptions, thermal: bool, hydrodynamics: Hydrodynamics,
                   boundary: Boundary | None, end_load: EndLoad | None,
                   polymorphism: Polymorphism | None, segments: int = 50) -> SolverOptions:
    """``solver`` with its method set: the run's :func:`~flagellum.integrate.default_method`
    where ``solver.method`` is None."""
    if solver.method is not None:
        return solver
    return replace(solver, method=default_method(
        thermal=thermal, local=hydrodynamics.is_local,
        cell=boundary is not None and boundary.is_cell,
        moving_trap=end_load is not None and end_load.active and end_load.pull_rate != 0.0,
        polymorphic=polymorphism is not None,
        unfrozen=not hydrodynamics.is_local and hydrodynamics.refresh == 0.0, segments=segments))


def _rotate_z(v: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    out = np.array(v, float, copy=True)
    out[..., 0], out[..., 1] = c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]
    return out


class Simulator:
    """Motor-driven filament (paper Sec. 2): build from parameters, then :meth:`run`.

    Parameters
    ----------
    params : physical parameters (defaults: the paper's filament).
    motor : motor torque M(t) along +e_z (M > 0 pushes).
    boundary : anchor (fixed or load sphere) and hook (free, elastic, clamped).
    thermal : add thermal noise at ``params.fluid.kT`` (needs ``method="implicit"``).
    seed : seed of the random stream (thermal runs).
    solver : :class:`SolverOptions`.
    hydrodynamics : the filament's mobility (:class:`~flagellum.hydro.dynamics.Hydrodynamics`,
        default local RFT); a nonlocal one is frozen over the chunks between chart checks
        and rebuilt as it says.
    end_load : a force or a moving trap on the free end (:class:`~flagellum.params.EndLoad`).
    polymorphism : a multistable filament (:class:`~flagellum.params.Polymorphism`,
        :mod:`flagellum.rod.polymorph`); None (default): the single-state filament. Its
        order parameters ``phi`` (one per joint) advance between the integration chunks at
        the rod's frozen strains; a thermal run adds their noise.

    Notes
    -----
    The run starts at t = 0 from the stress-free helix turned onto its pinned rotation axis
    (:func:`flagellum.hydro.rft.pinned_helix`); :meth:`from_state` starts from a given state.
    ``t``, ``y`` (computational frame) and ``frame_angle`` are the current time, state and
    angle of the computational frame; :meth:`state` and :meth:`lab_state` return them.
    """

    def __init__(self, params: Params | None = None, motor: Motor | None = None,
                 boundary: Boundary | None = None, *, thermal: bool = False,
                 seed: int | None = None, solver: SolverOptions | None = None,
                 hydrodynamics: Hydrodynamics | None = None, end_load: EndLoad | None = None,
                 polymorphism: Polymorphism | None = None):
        self.params = params or Params()
        self.end_load = end_load if end_load is not None and end_load.active else None
        self.polymorphism = polymorphism
        self.hydrodynamics = hydrodynamics or Hydrodynamics()
        self.motor = motor or Motor()
        self.boundary = boundary or Boundary()
        self.solver = resolve_method(solver or SolverOptions(), thermal, self.hydrodynamics,
                                     self.boundary, self.end_load, polymorphism,
                                     self.params.filament.n_segments)
        self.thermal = bool(thermal)
        check_setup(self.params, self.solver, self.hydrodynamics, self.thermal, seed, self.boundary)
        self.seed = int(seed) if seed is not None else 0
        if self.thermal and self.motor.drive != "torque":
            raise ParameterError("drive", self.motor.drive, "'torque' for a thermal run")
        f = self.solver.frame
        final = self.motor.expected_torque(pinned_omega_per_torque(self.params))
        self._omega_scale = pinned_omega_per_torque(self.params) * max(
            abs(final), abs(self.motor.torque) if self.motor.drive == "torque" else 0.0, 1e-3)
        omega = 0.0 if f == "lab" else (float(f) if not isinstance(f, str) else
                                         pinned_omega_per_torque(self.params) * final)
        self.model = RodModel(self.params, self.motor, self.boundary, omega_frame=omega,
                              hydrodynamics=self.hydrodynamics, end_load=self.end_load,
                              segments=polymorphism is not None)
        self.t = 0.0
        self.frame_angle = 0.0
        self.phi = np.zeros(self.model.n)  #: polymorphic order parameter of each joint
        self._phi_rng = None
        if polymorphism is None:
            self.y = self.model.initial_state(pinned_helix(self.params, self.boundary))
        else:
            self.y = self._polymorphic_start()
        self.model.trap_origin = float(self.y[5 + 4 * self.model.n])  # a trap starts at the free end
        self._rng_state = None
        self._last_motor = None
        self.wall_seconds = 0.0
        self.steps = 0

    # -- polymorphism -------------------------------------------------------------------
    def _polymorphic_start(self) -> np.ndarray:
        """The stress-free rod of the initial forms: the first joint's form as the pinned helix
        (:func:`~flagellum.hydro.rft.pinned_helix`), continued joint by joint."""
        from .helix import DiscreteHelix, discrete_rod

        pm, f = self.polymorphism, self.params.filament
        self.phi = np.array(pm.initial_states(self.model.n), float)
        self._forms = tuple(np.array(v) for v in pm.strains(f))
        kap, tau = self._intrinsic()
        first = self.params.replace(kappa0=float(kap[0]), tau0=abs(float(tau[0])),
                                    handedness="right" if tau[0] >= 0 else "left")
        dh = pinned_helix(first, self.boundary)
        pos, frames = discrete_rod(dh.frames[0], kap, tau, self.model.h, dh.positions[0])
        self.model.set_intrinsic(kap, tau)
        self._phi_rng = np.random.default_rng([self.seed, 20]) if self.thermal else None
        return self.model.initial_state(DiscreteHelix(pos, frames, dh.axis_point, dh.axis_direction,
                                                      dh.radius, dh.pitch, dh.segment_length))

    def _intrinsic(self):
        kap, tau = np.empty(self.model.n), np.empty(self.model.n)
        PM.intrinsic(self.phi, *self._forms, kap, tau)
        return kap, tau

    def _phi_constants(self):
        pm, f = self.polymorphism, self.params.filament
        k = np.array(pm.pair_stiffness())
        return (self.model.h, np.array(pm.energies, float), k, pm.wall_stiffness, pm.friction,
                f.bend_rigidity, f.twist_rigidity)

    @property
    def phi_relaxation_time(self) -> float:
        """ζ/k [s]: the relaxation time of a well (the longest chunk between φ updates; the
        slowest pair's, with a barrier per pair)."""
        return self.polymorphism.friction / min(self.polymorphism.pair_stiffness())

    def _transform(self, y: np.ndarray, dt: float) -> bool:
        """Advance φ by dt at the strains of y; True if the intrinsic shape changed."""
        h, eps, k, D, zeta, A, C = self._phi_constants()
        kap_f, tau_f = self._forms
        sub = PM.stable_substep(h, k, D, zeta, kap_f, tau_f, A, C)
        n_sub = max(1, math.ceil(dt / sub))
        kT = self.params.fluid.kT if self.thermal else 0.0
        normals = (self._phi_rng.standard_normal((n_sub, self.model.n)) if kT > 0
                   else np.zeros((1, 1)))
        old = self.phi.copy()
        PM.advance(self.phi, dt, n_sub, h, eps, k, D, zeta, A, C, self.model.joint_strains(y),
                   kap_f, tau_f, True, kT, normals)
        if np.array_equal(old, self.phi):
            return False
        self.model.set_intrinsic(*self._intrinsic())
        return True

    # -- state ------------------------------------------------------------------------
    @classmethod
    def from_state(cls, state: State, params: Params | None = None, motor: Motor | None = None,
                   boundary: Boundary | None = None, *, t: float = 0.0,
                   omega_frame: float | None = None, thermal: bool = False,
                   seed: int | None = None, solver: SolverOptions | None = None,
                   hydrodynamics: Hydrodynamics | None = None, end_load: EndLoad | None = None,
                   polymorphism: Polymorphism | None = None) -> "Simulator":
        """A simulator (arguments as for :class:`Simulator`) that starts at time ``t`` [s]
        from ``state``: e.g. a relative equilibrium in its co-rotating frame
        (:func:`flagellum.analysis.stability.relative_equilibrium`, with ``omega_frame``
        its rate), or the :meth:`lab_state` of another run.

        ``omega_frame`` [rad/s]: the initial rate of the computational frame (``frame="auto"``
        adapts it from there); None: the one ``solver.frame`` chooses. The motor angle is
        unwrapped afresh from the state's hook frame, and a thermal run's random stream
        starts from ``seed``. A state that does not fit the filament raises
        :class:`~flagellum.errors.ParameterError`. A trap (``end_load``) is centred at the
        state's free end; the order parameters of ``polymorphism`` are the state's ``phi``,
        or (None) those of its ``initial``.
        """
        sim = cls(params, motor, boundary, thermal=thermal, seed=seed, solver=solver,
                  hydrodynamics=hydrodynamics, end_load=end_load, polymorphism=polymorphism)
        sim._place(state, t, omega_frame)
        return sim

    def _place(self, state: State, t: float, omega_frame: float | None) -> None:
        n1 = self.model.n + 1
        want = ((self.model.state_size,), (n1, 3), (n1, 3), (n1,))
        try:
            arrays = [np.array(state.y, float), *(np.array(c, float) for c in state.charts)]
        except (AttributeError, TypeError, ValueError):
            raise ParameterError("state", type(state).__name__, "a State (y, charts)") from None
        got = tuple(a.shape for a in arrays)
        if got != want or not all(np.all(np.isfinite(a)) for a in arrays):
            raise ParameterError("state", f"shapes {got}", f"finite arrays (y, ref_u, ref_e, ref_m) "
                                 f"of shapes {want} for {self.model.n} segments")
        self.t = check_range("t", t, 0.0, 1e6, lo_open=False)
        self.frame_angle = check_real("frame_angle", state.frame_angle)
        if omega_frame is not None:
            self.model.set_omega_frame(check_range("omega_frame", omega_frame, -1e6, 1e6, lo_open=False))
        self.y = arrays[0]
        self.model.set_charts(*arrays[1:])
        # a trap's centre is at the given free end at the start time t (it moves from there)
        rate = self.end_load.pull_rate if self.end_load is not None else 0.0
        self.model.trap_origin = float(self.y[5 + 4 * self.model.n]) + rate * self.t
        phi = getattr(state, "phi", None)
        if phi is not None and self.polymorphism is not None:
            phi = np.array(phi, float)
            if phi.shape != (self.model.n,) or not np.all(np.isfinite(phi)):
                raise ParameterError("state", f"phi of shape {phi.shape}",
                                     f"finite order parameters of shape ({self.model.n},)")
            self.phi = phi
            self.model.set_intrinsic(*self._intrinsic())

    def state(self) -> State:
        """The current state in the computational frame (a copy)."""
        return State(self.y.copy(), self.model.charts(), self.frame_angle, self._phi_copy())

    def _phi_copy(self):
        return self.phi.copy() if self.polymorphism is not None else None

    def lab_state(self) -> State:
        """The current state turned into the lab frame (``frame_angle`` 0)."""
        y, (ref_u, ref_e, ref_m) = self.y.copy(), self.model.charts()
        a = self.frame_angle
        y[:3] = _rotate_z(y[:3], a)
        beads = y[3:3 + 4 * (self.model.n + 1)].reshape(-1, 4)
        beads[:, :3] = _rotate_z(beads[:, :3], a)
        if self.model.cell:  # the body's orientation turned with the frame
            y[-3:] = matrix_rotvec(_rotate_z(rotvec_matrix(y[-3:]).T, a).T)
        return State(y, (_rotate_z(ref_u, a), _rotate_z(ref_e, a), ref_m), phi=self._phi_copy())

    # -- metadata ---------------------------------------------------------------------
    def metadata(self) -> dict:
        """The attributes of an output file: parameters, settings, provenance."""
        return {"params_toml": self.params.to_toml(), "spec": json.dumps(self.spec()),
                "motor": json.dumps(asdict(self.motor)), "boundary": json.dumps(self.boundary.to_dict()),
                "solver": json.dumps(asdict(self.solver)), "thermal": self.thermal, "seed": self.seed,
                "hydrodynamics": self.hydrodynamics.model,
                "helix_radius": Helix.from_filament(self.params.filament).radius,
                "segments": self.model.n,
                "body_rotation_per_torque": self.model.body_rotation_per_torque,
                **({io.POLYMORPH_ATTR: ",".join(self.polymorphism.forms)} if self.polymorphism else {}),
                **io.provenance()}

    def spec(self) -> dict:
        """Everything needed to rebuild this simulator (JSON-serializable)."""
        return {"params": self.params.to_dict(), "motor": asdict(self.motor),
                "boundary": self.boundary.to_dict(), "solver": asdict(self.solver),
                "thermal": self.thermal, "seed": self.seed,
                "hydrodynamics": self.hydrodynamics.to_dict(),
                **({"end_load": asdict(self.end_load)} if self.end_load else {}),
                **({"polymorphism": asdict(self.polymorphism)} if self.polymorphism else {})}

    @classmethod
    def from_spec(cls, spec: dict) -> "Simulator":
        motor = dict(spec["motor"])
        if motor.get("schedule") is not None:
            motor["schedule"] = tuple(tuple(x) for x in motor["schedule"])
        for k in ("reversals", "reversal_rates"):
            if motor.get(k) is not None:
                motor[k] = tuple(motor[k])
        return cls(Params.from_dict(spec["params"]), Motor(**motor), Boundary(**spec["boundary"]),
                   thermal=spec["thermal"], seed=spec["seed"], solver=SolverOptions(**spec["solver"]),
                   hydrodynamics=Hydrodynamics.from_dict(spec.get("hydrodynamics")),
                   end_load=EndLoad(**spec["end_load"]) if spec.get("end_load") else None,
                   polymorphism=Polymorphism(**spec["polymorphism"]) if spec.get("polymorphism") else None)

    # -- stepping ---------------------------------------------------------------------
    def _stepper(self):
        self.model.refresh_mobility(self.y, force=True)
        return make_stepper(self.solver.method, self.model, self.t, self.y, self.solver,
                            kT=self.params.fluid.kT if self.thermal else 0.0, seed=self.seed,
                            rng_state=self._rng_state)

    def _record(self, buf: dict) -> None:
        m, y, t = self.model, self.y, self.t
        m.rhs(t, y)
        c, s = math.cos(self.frame_angle), math.sin(self.frame_angle)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        u = y[:3] / np.linalg.norm(y[:3])
        force = rot @ m.last_force
        pos = positions(y) @ rot.T
        if m.cell:
            b = m.body_motion(t, y)
            body = (rot @ b["position"], rot @ b["axis"], rot @ b["angular_velocity"],
                    matrix_rotvec(rot @ b["orientation"]))
        else:  # the anchor, a load sphere or a centred body sphere (counter-rotating about e_z)
            body = (pos[0], np.array([0.0, 0.0, 1.0]),
                    np.array([0.0, 0.0, -m.body_rotation_per_torque * m.last_torque]), np.zeros(3))
        for k, v in (("t", t), ("positions", pos), ("angles", angles(y)),
                     ("hook_tangent", rot @ u), ("thrust", force[2]), ("anchor_force", force),
                     ("motor_speed", m.last_motor_speed),
                     ("motor_angle", self._motor_angle()), ("torque", m.last_torque),
                     ("energy", m.last_energy), ("frame_angle", self.frame_angle),
                     ("relative_motor_speed", m.last_relative_motor_speed),
                     ("body_position", body[0]), ("body_axis", body[1]),
                     ("body_angular_velocity", body[2]), ("body_orientation", body[3]),
                     ("end_force", m.end_force(t, y)), ("extension", y[5] - y[5 + 4 * self.model.n])):
            buf[k].append(np.array(v, float))
        if self.polymorphism is not None:
            buf["polymorph"].append(self.phi.copy())

    def _advance(self, stepper, t_target: float) -> np.ndarray:
        """Advance to t_target in chunks short enough that no tangent can turn by more than
        ~1/2 rad between chart checks (charts are re-centred only when a tangent has left its
        chart by more than 90°; the stepper carries its history through, :meth:`_carry`)."""
        rate = max(abs(self.model.omega_frame), 100.0)
        if self._last_motor is not None:  # measured motor speed, capped: transients spike it
            rate = max(rate, min(abs(self._last_motor[3]), 3.0 * self._omega_scale))
            # …relative to the frame: a reversal leaves the frame turning the other way
            rate = max(rate, min(abs(self._last_motor[3] - self.model.omega_frame),
                                 3.0 * self._omega_scale))
        chunk = 0.5 / rate
        if self.polymorphism is not None:  # φ follows the rod between chunks: shorter than ζ/k
            chunk = min(chunk, 0.5 * self.phi_relaxation_time)
        step = stepper.fixed_step
        if step:  # whole fixed steps: a shortened step would restart BDF2 with an Euler step
            chunk = step * max(1, math.floor(chunk / step))
        y = stepper.y
        # the drive jumps at a reversal: an adaptive stepper stops there and restarts (CVODE
        # stepping across the jump can stall in the hook's fast spin-up after it)
        switches = () if step else self.motor.switching_times(t_target)
        while stepper.t < t_target:
            t_next = min(t_target, stepper.t + chunk)
            if t_target - t_next < 0.25 * chunk:
                t_next = t_target
            # (a switch within 1 ns of a chunk's end, e.g. a record time, counts as that end)
            switch = next((s for s in switches if stepper.t + 1e-9 < s <= t_next + 1e-9), None)
            if switch is not None and switch < t_next - 1e-9:
                t_next = switch
            if not getattr(stepper, "tracks_mobility", False):
                self.model.refresh_mobility(y)  # a nonlocal mobility: frozen over the chunk
            if self.end_load is not None:  # integrators that call the kernels themselves
                self.model.prm[self.model.iprm[K.I_EXTRA] + K.X_TRAP_Z] = \
                    self.model.trap_centre(0.5 * (stepper.t + t_next))
            t_prev = stepper.t
            y = self._advance_chunk(stepper, t_next)
            reset = self.polymorphism is not None and self._transform(y, t_next - t_prev)
            charts = self.model.charts()
            moved = t_next < t_target and self.model.rechart(y, threshold=CHART_LIMIT)
            if reset or switch is not None:
                if moved:
                    self.model.refresh_mobility(y, force=True)
                stepper.reset(t_next, y)
            elif moved:
                self._carry(stepper, t_next, y, charts, self.model.omega_frame)
        return y

    def _carry(self, stepper, t: float, y: np.ndarray, charts, omega: float) -> None:
        """Continue ``stepper`` at (t, y) after the charts moved from ``charts`` (poles,
        reference vectors, twists) and the frame's rate from ``omega`` to the model's:
        with its history mapped into the new coordinates where it can carry it
        (:data:`CARRY_HISTORY`), else restarted. A past state at time s is turned by
        −(Ω' − Ω)(s − t) about e_z (the frame angle is continuous at t) and its angles are
        measured against the new charts (:meth:`RodModel.change_coordinates`)."""
        m = self.model
        carry = getattr(stepper, "carry", None)
        if not CARRY_HISTORY or carry is None or m.cell:
            m.refresh_mobility(y, force=True)
            stepper.reset(t, y)
            return
        d_omega = m.omega_frame - omega
        moved = np.any(charts[0] != m.ref_u, axis=1) | np.any(charts[1] != m.ref_e, axis=1)
        only = None if d_omega != 0.0 else moved
        carry(t, y, lambda s, ys: m.change_coordinates(ys, charts, -d_omega * (s - t), only),
              frame_turned=d_omega != 0.0)

    def _advance_chunk(self, stepper, t_next: float) -> np.ndarray:
        """One chunk; if the stepper fails, once more from the chunk's start after re-centring
        every chart a tangent has turned past CHART_LIMIT from during the chunk (a fast turn,
        e.g. the free end whipping round while its form changes, can carry a tangent within
        one chunk towards its chart's singular point). A failure with no such chart, or a
        second failure, is the run's failure (raised)."""
        t0, y0 = stepper.t, stepper.y.copy()
        try:
            return stepper.advance(t_next)
        except SimulationError:
            if not self.model.rechart(y0, threshold=CHART_LIMIT):
                raise
            self.model.refresh_mobility(y0, force=True)
            stepper.reset(t0, y0)
            return stepper.advance(t_next)

    def _motor_angle(self) -> float:
        """Accumulated rotation of the hook frame about e_z (lab), continuous in time.

        The hook frame is its chart's reference frame A = [a1, t × a1, t] turned about the
        tangent by the material angle θ0 of the state. θ0 is integrated with the state and
        never wrapped, so it carries the fast motor rotation (and the twist-up of a filament
        started from rest) without aliasing however far apart the records are; only the
        reference frame's twist about z is taken modulo 2π — the swing–twist split
        2 atan2(B10 − B01, 1 + tr B) of B = A diag(1, −1, −1) relative to the rest orientation
        (tangent along −e_z) — and it changes slowly (the reference vector a1 follows the
        tangent by parallel transport and does not turn with the filament), so it is unwrapped
        against its previous value. The angle is that twist − θ0 (θ0 is measured about t,
        i.e. about −e_z at rest) plus the computational frame's angle; its slope is the
        rotation rate about the local helix axis at the motor (paper Sec. 3.1.2).
        """
        fr = self.model.frames()  # at the last rhs call
        (tx, ty, tz), (ax, ay, az) = fr.tangents[0].tolist(), fr.reference[0].tolist()
        # B = [a1, −t × a1, −t] (columns): B10 − B01 = a1_y + (t × a1)_x and
        # tr B = a1_x − (t × a1)_y − t_z, written out (np.cross costs more than the record)
        raw = 2.0 * math.atan2(ay + (ty * az - tz * ay), 1.0 + ax - (tz * ax - tx * az) - tz)
        last = self._last_motor
        if last is None:
            twist = raw
        else:
            t0, raw0, twist0, rate0, angle0 = last
            twist = twist0 + (raw - raw0 + math.pi) % (2 * math.pi) - math.pi
        angle = twist - float(self.y[6]) + self.frame_angle
        if last is None:
            rate = self.model.omega_frame
            if not self.thermal and self.model.omega_frame == 0.0:
                rate = self.model.last_motor_speed
        else:
            rate = (angle - angle0) / (self.t - t0) if self.t > t0 else rate0
        self._last_motor = (self.t, raw, twist, rate, angle)
        return angle

    def _check(self, y: np.ndarray) -> None:
        if not np.all(np.isfinite(y)):
            raise SimulationError(f"non-finite state at t = {self.t:.6g} s")
        bonds = np.linalg.norm(np.diff(positions(y), axis=0), axis=1)
        strain = np.abs(bonds / self.model.h - 1).max()
        if strain > MAX_STRAIN:
            raise SimulationError(f"a bond strained by {strain:.0%} at t = {self.t:.6g} s "
                                  f"(limit {MAX_STRAIN:.0%}): the filament blew up")

    def _adapt_frame(self, buf) -> bool:
        """Co-rotating frame (frame='auto'): follow the motor speed once it has settled; in
        unsteady states (buckled, oscillating) follow its mean roughly (within 25 %), which
        keeps the changes (restarts of the steppers without ``carry``) rare while the filament
        stays slow in that frame."""
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

    # -- running ----------------------------------------------------------------------
    def run(self, t_end: float, save_every: float | None = None, output: str | Path | None = None,
            progress: bool | None = None, checkpoint_every: float | None = None,
            overwrite: bool = False) -> Trajectory:
        """Integrate from the current time to ``t_end`` [s], saving every ``save_every`` s.

        With ``output`` the records go, at each checkpoint (every ``checkpoint_every``
        simulated seconds, by default every 1000 records), to a new part file in
        ``<output>.parts/`` together with an atomically replaced checkpoint ``<output>.ckpt``,
        so memory stays bounded and a run killed at any instant can be continued with
        :meth:`resume`; at the end the parts are gathered into ``output`` (see
        :mod:`flagellum.trajectory`) and the returned :class:`Trajectory` holds the whole run
        read back from it. An existing ``output`` is replaced only with ``overwrite``; a
        second run into the same ``output`` is refused while this one runs.
        A blow-up raises :class:`SimulationError` after saving the last good state.
        """
        if checkpoint_every is not None and output is None:
            raise ParameterError("checkpoint_every", checkpoint_every, "given only with an output file")
        plan = self._plan(t_end, save_every, checkpoint_every)
        files = None
        if output is not None:
            files = RunFiles.create(output, self.model.n, {**self.metadata(), "plan": json.dumps(plan)},
                                    len(self._times(plan)) + 1, overwrite=overwrite)
        return self._loop(plan, 0, files, progress)

    def _plan(self, t_end, save_every, checkpoint_every) -> dict:
        return plan_run(self.t, t_end, save_every, checkpoint_every)

    @staticmethod
    def _times(plan) -> np.ndarray:
        t0, t_end, dt = plan["t0"], plan["t_end"], plan["save_every"]
        n_save = int(math.floor((t_end - t0) / dt + 1e-9))
        times = t0 + dt * np.arange(1, n_save + 1)
        if len(times) == 0 or times[-1] < t_end - 1e-12:
            times = np.append(times, t_end)
        return times

    def _loop(self, plan: dict, start: int, files: RunFiles | None, progress) -> Trajectory:
        """Records ``start`` … of ``plan``; into ``files`` (parts, checkpoints), else kept in memory."""
        try:
            return self._run_records(plan, start, files, progress)
        finally:
            if files is not None:
                files.release()

    def _run_records(self, plan: dict, start: int, files: RunFiles | None, progress) -> Trajectory:
        times = self._times(plan)
        flush_every = plan["flush_every"]
        progress = show_progress(progress)
        fields = io.record_layout(self.metadata() if self.polymorphism else {})[0]
        buf = {k: [] for k in fields}
        kept = {k: [] for k in fields} if files is None else None
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
                charts, omega = self.model.charts(), self.model.omega_frame
                moved = self.model.rechart(self.y, threshold=CHART_LIMIT)
                moved |= self._adapt_frame(buf)
                changed = False
                if bar is not None:
                    bar.update(1)
                if (i + 1) % flush_every == 0 and i + 1 < len(times):
                    self._flush(buf, kept, files, stepper)
                    if files is not None:
                        self._checkpoint(files, plan, i + 1, wall0, self.steps + stepper.n_steps)
                    changed = True  # restart the integrator at checkpoints (resume = identical)
                if changed:
                    self.model.refresh_mobility(self.y, force=True)
                    stepper.reset(self.t, self.y)
                elif moved:
                    self._carry(stepper, self.t, self.y, charts, omega)
        except OutputError:
            raise  # the parts and the last checkpoint stay as they are
        except SimulationError as exc:
            self.t, self.y, self.frame_angle = good
            if files is None:
                raise
            files.finish(buf, self.y, f"failed: {exc}")
            raise SimulationError(f"{exc}; last good state (t = {self.t:.6g} s) saved to {files.path}")
        except KeyboardInterrupt:
            if files is not None:
                files.finish(buf, self.y, "interrupted")
            raise
        finally:
            if bar is not None:
                bar.close()
            self.wall_seconds += time.perf_counter() - wall0
            self.steps += stepper.n_steps
        if files is not None:
            files.finish(buf, self.y, COMPLETE, wall_seconds=self.wall_seconds, steps=self.steps)
            files.tidy()
            return files.read(self.metadata())
        self._flush(buf, kept, files, stepper)
        return Trajectory.from_records(kept, self.metadata())

    def _flush(self, buf, kept, files, stepper):
        if kept is not None:
            for k, v in buf.items():
                kept[k].extend(v)
        elif files is not None:
            files.write_part(buf)
        for v in buf.values():
            v.clear()
        self._rng_state = stepper.rng_state

    # -- checkpoints ------------------------------------------------------------------
    def _checkpoint(self, files: RunFiles, plan: dict, n_done: int, wall0: float, steps: int) -> None:
        ref_u, ref_e, ref_m = self.model.charts()
        files.write_checkpoint(
            {"y": self.y, "ref_u": ref_u, "ref_e": ref_e, "ref_m": ref_m,
             **({"phi": self.phi} if self.polymorphism is not None else {})},
            {"t": self.t, "frame_angle": self.frame_angle, "omega_frame": self.model.omega_frame,
             "n_done": n_done, "n_records": n_done + 1,  # + the initial record
             "plan": json.dumps(plan), "rng_state": json.dumps(self._rng_state),
             "last_motor": json.dumps(self._last_motor),
             "wall_seconds": self.wall_seconds + time.perf_counter() - wall0, "steps": steps,
             "spec": json.dumps(self.spec()), "trap_origin": self.model.trap_origin,
             **({"phi_rng": json.dumps(self._phi_rng.bit_generator.state)} if self._phi_rng else {})})

    @classmethod
    def resume(cls, output: str | Path, progress: bool | None = None) -> tuple["Simulator", Trajectory]:
        """Continue a run from its last checkpoint ``<output>.ckpt``; returns (simulator, trajectory).

        The continued run restarts the integrator exactly where the uninterrupted run did,
        with the same random stream, so the final file is identical (deterministic runs
        bit-for-bit).
        """
        files = RunFiles(output, name="resume")
        attrs = files.attrs()
        files.lock()
        try:
            return cls._resume(files, attrs, progress)
        except BaseException:
            files.release()
            raise

    @classmethod
    def _resume(cls, files: RunFiles, attrs: dict, progress) -> tuple["Simulator", Trajectory]:
        output = files.path
        try:
            if str(attrs.get("status", "")) == COMPLETE:  # killed after writing the file, before tidying up
                files.tidy()
                sim = cls.from_spec(json.loads(attrs["spec"]))
                sim.wall_seconds = float(attrs.get("wall_seconds", 0.0))
                sim.steps = int(attrs.get("steps", 0))
                files.release()
                return sim, files.read(sim.metadata())
            ckpt = files.read_checkpoint()
            if ckpt is not None:
                sim, plan, start = cls._from_checkpoint(*ckpt)
                n_parts = int(ckpt[1]["n_parts"])
            else:  # killed before its first checkpoint: start again (CLI runs start at t = 0)
                plan, start, n_parts = json.loads(attrs.get("plan", "{}")), 0, 0
                if plan.get("t0") != 0.0:
                    raise ParameterError("resume", str(output), "a run with a checkpoint file "
                                         f"{files.checkpoint.name} (none found; the run stopped "
                                         "before its first checkpoint)")
                sim = cls.from_spec(json.loads(attrs["spec"]))
        except (OSError, KeyError, ValueError, TypeError) as exc:
            if isinstance(exc, ParameterError):
                raise
            raise ParameterError("resume", str(output), f"a run with a readable checkpoint ({exc!r})")
        files.reopen(attrs, n_parts, sim.model.n)
        return sim, sim._loop(plan, start, files, progress)

    @classmethod
    def _from_checkpoint(cls, arrays: dict, a: dict) -> tuple["Simulator", dict, int]:
        """The simulator in the state of a checkpoint (datasets, attributes), its plan and
        the records done."""
        sim = cls.from_spec(json.loads(a["spec"]))
        charts = (arrays["ref_u"], arrays["ref_e"], arrays["ref_m"])
        sim._place(State(arrays["y"], charts, float(a["frame_angle"])), float(a["t"]),
                   float(a["omega_frame"]))
        sim._rng_state = json.loads(a["rng_state"])
        sim.model.trap_origin = float(a.get("trap_origin", sim.model.trap_origin))
        if "phi" in arrays:
            sim.phi = np.array(arrays["phi"], float)
            sim.model.set_intrinsic(*sim._intrinsic())
            if "phi_rng" in a:
                sim._phi_rng.bit_generator.state = json.loads(a["phi_rng"])
        last = tuple(json.loads(a["last_motor"]))
        if len(last) == 4:  # (t, raw, angle, rate) of the swing–twist split of the material frame
            t0, _, angle0, rate0 = last
            sim._last_motor = None
            sim.model.rhs(sim.t, sim.y)
            sim._motor_angle()  # the reference frame's twist at the checkpoint's state
            _, raw, twist, _, angle = sim._last_motor
            sim._last_motor = (t0, raw, twist + angle0 - angle, rate0, angle0)
        else:
            sim._last_motor = last
        sim.wall_seconds = float(a["wall_seconds"])
        sim.steps = int(a.get("steps", 0))  # the steps before the checkpoint count too
        return sim, json.loads(a["plan"]), int(a["n_done"])


def plan_run(t0: float, t_end, save_every=None, checkpoint_every=None) -> dict:
    """The records of a run from ``t0`` to ``t_end`` [s] (checked: also what a sweep checks
    of its points before the first runs)."""
    t_end = check_range("time", t_end, t0 + MIN_SPAN, 1e6, lo_open=False)
    save_every = positive("save_every", save_every if save_every is not None
                          else (t_end - t0) / 200, t_end - t0)
    if (t_end - t0) / save_every > MAX_RECORDS:
        raise ParameterError("save_every", save_every, f"at least time/{MAX_RECORDS:.0e} = "
                             f"{(t_end - t0) / MAX_RECORDS:g} s (at most {MAX_RECORDS:.0e} records)")
    if checkpoint_every is not None:
        checkpoint_every = positive("checkpoint_every", checkpoint_every, 1e6)
    flush_every = max(1, int(round(checkpoint_every / save_every))) if checkpoint_every else 1000
    return {"t0": t0, "t_end": t_end, "save_every": save_every, "flush_every": flush_every}


def run_first_success(make, attempts, t_end: float, save_every: float):
    """Run ``make(method, frame)`` for each (method, frame) of ``attempts`` until one run to
    ``t_end`` succeeds (callers list the default method (None) in one or two frames, then
    CVODE, then the fixed-step solver: it does not stall where an adaptive step size
    collapses); a method None is the run's default, and an attempt that resolves to one
    already made is skipped. Returns (trajectory, simulator,
    method, frame, errors), trajectory None if every attempt failed; invalid parameters raise."""
    errors, tried = [], set()
    for method, frame in attempts:
        sim = make(method, frame)
        method = sim.solver.method  # None: the run's default method
        if (method, frame) in tried:  # a default that resolved to a method tried already
            continue
        tried.add((method, frame))
        try:
            return sim.run(t_end, save_every=save_every, progress=False), sim, method, frame, errors
        except ParameterError:
            raise
        except SimulationError as exc:
            errors.append(f"{method}, {frame} frame: {exc}")
        except (ArithmeticError, ValueError, RuntimeError) as exc:  # e.g. raised inside the rhs
            errors.append(f"{method}, {frame} frame: {type(exc).__name__}: {exc}")
    return None, None, None, None, errors


def _progress(total: int, enabled: bool):
    return progress_bar(total=total, unit="save", desc="simulating", leave=False) if enabled else None


__all__ = ["CHART_LIMIT", "MAX_RECORDS", "MAX_STRAIN", "MIN_SPAN", "Simulator", "SolverOptions",
           "State", "check_setup", "plan_run", "run_first_success"]
