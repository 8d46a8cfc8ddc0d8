"""One call for the common run: :func:`simulate` (``flagellum.simulate``).

It builds the :class:`~flagellum.params.Params`, :class:`~flagellum.motor.Motor`,
:class:`~flagellum.motor.Boundary` and :class:`~flagellum.simulator.SolverOptions` of its
keyword arguments, with the defaults and the rules of ``flagellum simulate``, and runs a
:class:`~flagellum.simulator.Simulator`. Build those objects yourself for what it does not
cover (a torque schedule, a start from a given state, resuming a run).
"""

from __future__ import annotations

from pathlib import Path

from .errors import ParameterError
from .motor import Boundary, Motor
from .params import EndLoad, Params, Polymorphism, positive
from .simulator import Simulator, SolverOptions
from .trajectory import Trajectory


def simulate(torque: float = 1.0, time: float = 0.3, *, save_every: float | None = None,
             ramp_time: float = 0.0, anchor: str | None = None, sphere_radius: float | None = None,
             hook: str | None = None, hook_stiffness: float | None = None,
             body_radius: float | None = None, body_aspect: float | None = None,
             motor_offset: float | None = None, thermal: bool = False, kT: float | None = None, seed: int = 0,
             method: str | None = None, rtol: float = 1e-6, dt: float = 5e-5,
             scheme: str | None = None, theta: float | None = None, frame: str | float = "auto",
             output: str | Path | None = None, checkpoint_every: float | None = None,
             overwrite: bool = False, progress: bool | None = None, params: Params | dict | None = None,
             end_load: EndLoad | None = None, polymorphism: Polymorphism | None = None,
             **overrides) -> Trajectory:
    """Simulate the motor-driven filament from the stress-free helix (paper Sec. 2) and
    return its :class:`~flagellum.trajectory.Trajectory` (lab frame).

    >>> import flagellum as fl                                      # doctest: +SKIP
    >>> tr = fl.simulate(torque=1.5, time=0.5)                      # doctest: +SKIP
    >>> s = tr.summary()                                            # doctest: +SKIP
    >>> s.regime, s.thrust_mean, s.omega_mean                       # doctest: +SKIP

    Units: µm, pN, s. Invalid values raise :class:`~flagellum.errors.ParameterError`.

    Parameters
    ----------
    torque : motor torque M [pN·µm] along +e_z; M > 0 pushes (the filament's thrust points
        along +e_z), M < 0 pulls. The paper's filament buckles above M_c1 ≈ 1.04 pN·µm.
    time : simulated time [s] (from t = 0).
    save_every : interval between records [s]; default ``time / 300``.
    ramp_time : switch the torque on smoothly over this time [s] (0: at once).
    anchor : ``"fixed"`` (the first bead held at the origin), ``"sphere"`` (on a load sphere
        moving along e_z) or ``"free"`` (a force- and torque-free swimmer with a body
        sphere); default: ``"sphere"`` when ``sphere_radius`` is given, else ``"fixed"``.
    sphere_radius : radius a of the load sphere or of the swimmer's body [µm].
    hook : ``"free"`` (a free joint, the paper's hook), ``"elastic"`` or ``"clamped"`` (the
        first tangent held along −e_z); default: ``"elastic"`` when ``hook_stiffness`` > 0,
        else ``"free"``.
    hook_stiffness : bending stiffness k of the elastic hook [pN·µm].
    body_radius : a whole cell (implies ``anchor="free"``): a rigid body free in 3D with the
        motor on its surface and the motor axis along the local normal, turning with it; its
        (equatorial) radius a [µm] (:mod:`flagellum.hydro.body`; docs/motor.md, "Whole cell").
    body_aspect : the cell body as a prolate spheroid with polar semi-axis ``body_aspect``·a
        (≥ 1; default 1, a sphere).
    motor_offset : the motor's position on the cell body, eccentric angle from the rear pole
        [deg] (0–180; default 0: at the pole).
    thermal : add thermal noise (Brownian forces and torques at ``kT``); implied by ``kT``.
    kT : thermal energy [pN·µm] (4.1e-3 at room temperature); giving it makes the run thermal.
    seed : seed of the random stream of a thermal run (non-negative integer).
    method : integrator: ``"bdf"`` (the Numba variable-order BDF, adaptive), ``"cvode"``
        (SUNDIALS, adaptive) or ``"implicit"`` (fixed step ``dt``; the only choice with
        noise); default: :func:`~flagellum.integrate.default_method` (``"bdf"`` for the
        deterministic runs it supports, ``"cvode"`` for the others, ``"implicit"`` with noise).
    rtol : relative tolerance of ``"bdf"`` and ``"cvode"`` (positions in µm, angles in rad).
    dt : time step of ``"implicit"`` [s].
    scheme, theta : fixed-step scheme of ``"implicit"``: ``"bdf2"`` (default) or the
        θ-method (``"theta"``, implied by ``theta``; 1 implicit Euler, 0.5 trapezoidal).
    frame : computational frame: ``"auto"`` (co-rotating with the motor), ``"lab"``, or a
        fixed rotation rate [rad/s]; the trajectory is always reported in the lab frame.
    output : HDF5 file to write the run into (parts and checkpoints while it runs,
        resumable with :meth:`~flagellum.simulator.Simulator.resume`); default: memory only.
    checkpoint_every : with ``output``, write the records and a checkpoint every this many
        simulated seconds (default: every 1000 records).
    overwrite : replace an existing ``output`` (otherwise an error).
    progress : show a progress bar (a widget in Jupyter); default: when someone watches (a
        terminal or a notebook).
    params : the filament and fluid (:class:`~flagellum.params.Params`, or a dict of flat
        names as below); default: the paper's filament in water.
    end_load : a force or a moving trap on the free end (:class:`~flagellum.params.EndLoad`).
    polymorphism : a multistable filament (:class:`~flagellum.params.Polymorphism`);
        default: the single-state filament.
    **overrides : parameters by their flat names, as in ``Params.from_flat`` and the CLI
        flags: ``kappa0``, ``tau0`` [1/µm], ``handedness``, ``bend_rigidity``,
        ``twist_rigidity`` [pN·µm²], ``stretch_modulus`` [pN], ``length``,
        ``segment_length``, ``filament_radius`` [µm], ``viscosity`` [pN·s/µm²],
        ``friction`` (``"paper"``, ``"lighthill"``, ``"custom"``), ``gamma_par``,
        ``gamma_perp`` [pN·s/µm²], ``gamma_rot`` [pN·s].
    """
    if params is not None and not isinstance(params, (Params, dict)):
        raise ParameterError("params", type(params).__name__, "a Params or a dict of flat names")
    base = params if isinstance(params, Params) else Params.from_flat(params or {})
    flat = {**overrides, **({"kT": kT} if kT is not None else {})}
    model = Params.from_flat(flat, base=base) if flat else base
    thermal = bool(thermal) or kT is not None
    solver = SolverOptions(method=method, rtol=rtol, dt=dt,
                           scheme=scheme, theta=theta, frame=frame)
    boundary = Boundary.from_flags(anchor=anchor, sphere_radius=sphere_radius, hook=hook,
                                   hook_stiffness=hook_stiffness, body_radius=body_radius,
                                   body_aspect=body_aspect, motor_offset=motor_offset)
    sim = Simulator(model, Motor(torque, ramp_time=ramp_time), boundary, thermal=thermal,
                    seed=seed, solver=solver, end_load=end_load, polymorphism=polymorphism)
    time = positive("time", time, 1e6)
    return sim.run(time, save_every=save_every if save_every is not None else time / 300,
                   output=output, progress=progress, checkpoint_every=checkpoint_every,
                   overwrite=overwrite)


__all__ = ["simulate"]
