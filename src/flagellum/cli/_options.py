"""Flags shared by several commands, and the builders that turn them into validated
:class:`~flagellum.params.Params`, :class:`~flagellum.motor.Motor`,
:class:`~flagellum.motor.Boundary` and :class:`~flagellum.simulator.SolverOptions`.

Each builder pops its flags from the keyword arguments of a command. Also the check of a
trajectory file argument.
"""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import click

from ..errors import ParameterError
from ..motor import Boundary, Motor
from ..params import Filament, Fluid, Params

PARAM_HELP = {
    "kappa0": "spontaneous curvature κ0 [1/µm]",
    "tau0": "spontaneous torsion |τ0| [1/µm]",
    "handedness": "helix handedness",
    "bend_rigidity": "bending rigidity A [pN·µm²]",
    "twist_rigidity": "torsional rigidity C [pN·µm²]",
    "stretch_modulus": "stretching modulus K [pN]",
    "length": "contour length L [µm]",
    "segment_length": "bond length h [µm]",
    "viscosity": "viscosity η [pN·s/µm²]",
    "filament_radius": "filament radius r [µm]",
    "kT": "thermal energy kT [pN·µm]",
    "gamma_par": "override γ∥ [pN·s/µm²]",
    "gamma_perp": "override γ⊥ [pN·s/µm²]",
    "gamma_rot": "override γR [pN·s]",
}
_PARAM_NAMES = [f.name for k in (Filament, Fluid) for f in fields(k)] + [
    "gamma_par", "gamma_perp", "gamma_rot"]


def _add(func, opts):
    for opt in reversed(opts):
        func = opt(func)
    return func


# -- one name per concept -----------------------------------------------------------------

class AliasedOption(click.Option):
    """An option that also parses older spellings (``aliases``), which help and error
    messages leave out: each concept has one name across the commands."""

    def __init__(self, param_decls, aliases=(), **kwargs):
        super().__init__([*param_decls, *aliases], **kwargs)
        self.aliases = tuple(aliases)

    def _shown(self, method, ctx):
        opts = self.opts
        self.opts = [o for o in opts if o not in self.aliases]
        try:
            return method(ctx)
        finally:
            self.opts = opts

    def get_help_record(self, ctx):
        return self._shown(super().get_help_record, ctx)

    def get_error_hint(self, ctx):
        return self._shown(super().get_error_hint, ctx)


def output_option(dest: str, help: str, *, directory: bool = False, **kwargs):
    """``--output``/``-o``: where a command writes (a file, or with ``directory`` a folder);
    ``--out`` still parses."""
    kind = click.Path(file_okay=False) if directory else click.Path(dir_okay=False)

    def named(ctx, param, value):  # click.Path takes '' (the current directory)
        if value is not None and not str(value).strip():
            raise ParameterError("output", value, "a folder name" if directory else "a file name")
        return value

    return click.option("--output", "-o", dest, cls=AliasedOption, aliases=("--out",), type=kind,
                        help=help, callback=named, **kwargs)


def time_option(dest: str = "t_end", **kwargs):
    """``--time``: the simulated time [s]; ``--t-end`` still parses."""
    return click.option("--time", dest, cls=AliasedOption, aliases=("--t-end",), type=float, **kwargs)


# -- model parameters ---------------------------------------------------------------------

def param_options(func):
    """Add one flag per model parameter (same names as the TOML keys) plus ``--config``."""
    opts = [
        click.option("--config", type=click.Path(dir_okay=False), default=None,
                     help="TOML file with [filament], [fluid], [friction] tables"),
        click.option("--friction", type=click.Choice(["paper", "lighthill", "custom"]),
                     default=None, help="friction coefficients: paper's rounded values, "
                                        "Lighthill's formulas, or custom γ's"),
    ]
    for name in _PARAM_NAMES:
        flag = "--" + name.replace("_", "-")
        if name == "handedness":
            opts.append(click.option(flag, type=click.Choice(["right", "left"]), default=None,
                                     help=PARAM_HELP[name]))
        else:
            opts.append(click.option(flag, name, type=float, default=None, help=PARAM_HELP[name]))
    return _add(func, opts)


def params_from_cli(kwargs: dict) -> Params:
    """Pop the parameter flags from ``kwargs`` and build validated :class:`Params`."""
    config = kwargs.pop("config", None)
    base = Params.load_toml(config) if config else Params()
    flat = {name: kwargs.pop(name, None) for name in _PARAM_NAMES + ["friction"]}
    return Params.from_flat(flat, base=base)


# -- motor --------------------------------------------------------------------------------

def motor_options(func):
    """The drive — ``--torque``, ``--motor-speed`` (speed clamp) or ``--motor-law`` (torque–speed
    law) — ``--ramp-time`` and the reversals (``--reversal-times`` or ``--reversal-rates`` with
    ``--reversal-seed``)."""
    return _add(func, [
        click.option("--torque", type=float, default=None,
                     help="motor torque M [pN·µm] (> 0 pushes)  [default: 1.0]"),
        click.option("--motor-speed", type=float, default=None,
                     help="speed clamp: impose the motor speed ω [rad/s] relative to the body "
                          "(the torque is an output)"),
        click.option("--motor-law", type=str, default=None,
                     help="torque–speed law: 'e-coli' (Chen & Berg 2000) or a table FILE "
                          "(two-column CSV speed [rad/s], torque [pN·µm], or TOML speeds/torques)"),
        click.option("--ramp-time", type=float, default=0.0, show_default=True,
                     help="ramp the torque (or the clamped speed) on smoothly over this time [s]"),
        *_reversal_options(),
    ])


def _reversal_options(hidden: bool = False) -> list:
    """``--reversal-times``, ``--reversal-rates``, ``--reversal-seed`` (the defaults None:
    :func:`reversals_from_cli` tells given from not given)."""
    return [
        click.option("--reversal-times", type=str, default=None, hidden=hidden,
                     help="reverse the motor (CCW <-> CW) at these times [s], comma-separated"),
        click.option("--reversal-rates", type=str, default=None, hidden=hidden,
                     help="random reversals: rates CCW->CW,CW->CCW [1/s] (telegraph process)"),
        click.option("--reversal-seed", type=int, default=None, hidden=hidden,
                     help="seed of the random reversal times  [default: 0]"),
    ]


def reversals_from_cli(kwargs: dict) -> dict:
    """Pop the reversal flags: the :class:`Motor` fields they give (``reversals``,
    ``reversal_rates``, ``reversal_seed``), only those given."""
    out = {"reversals": _floats("reversal_times", kwargs.pop("reversal_times", None)),
           "reversal_rates": _floats("reversal_rates", kwargs.pop("reversal_rates", None)),
           "reversal_seed": kwargs.pop("reversal_seed", None)}
    return {k: v for k, v in out.items() if v is not None}


def _floats(name: str, text: str | None) -> tuple | None:
    if text is None:
        return None
    try:
        return tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise ParameterError(name, text, "comma-separated numbers")


def motor_from_cli(kwargs: dict) -> Motor:
    """Pop the motor flags from ``kwargs`` and build a validated :class:`Motor`
    (:meth:`Motor.from_flags`)."""
    return Motor.from_flags(kwargs.pop("torque"), kwargs.pop("motor_speed"), kwargs.pop("motor_law"),
                            ramp_time=kwargs.pop("ramp_time"), **reversals_from_cli(kwargs))


def threshold_drive_options(func):
    """The drive flags of the threshold searches (``critical-torque``, ``bifurcations``):
    the same names as :func:`motor_options`, but ``--motor-speed`` takes no value there — it
    asks for the critical rotation rate of a speed clamp instead of the critical torque —
    and ``--torque`` and ``--motor-law`` are refused with a one-line error
    (:func:`threshold_drive_from_cli`)."""
    return _add(func, [
        click.option("--torque", type=str, default=None, hidden=True),
        click.option("--motor-speed", type=str, is_flag=False, flag_value="", default=None,
                     help="under a speed clamp: find the critical rotation rate ω_c1 [rad/s] "
                          "(then --bracket takes motor speeds ω_lo ω_hi)"),
        click.option("--motor-law", type=str, default=None, hidden=True),
        *_reversal_options(hidden=True),
    ])


def threshold_drive_from_cli(kwargs: dict, command: str) -> str:
    """Pop the threshold drive flags from ``kwargs``: ``"torque"`` (the critical torque
    M_c1) or ``"speed"`` (``--motor-speed``: the critical rotation rate of a speed clamp)."""
    torque, speed, law = kwargs.pop("torque"), kwargs.pop("motor_speed"), kwargs.pop("motor_law")
    for name, value in reversals_from_cli(kwargs).items():  # parsed first: bad text is named
        flag = {"reversals": "reversal_times"}.get(name, name)
        raise ParameterError(flag, value, f"left out: {command} finds the threshold of a steady "
                                          "drive (reversals: flagellum simulate or sweep)")
    if torque is not None:
        raise ParameterError("torque", torque, f"left out: {command} searches the critical "
                                               "torque (give --bracket M_lo M_hi)")
    if law is not None:
        raise ParameterError("motor_law", law, f"left out: {command} finds thresholds, and a "
                                               "law fixes its operating point (its stability: "
                                               "flagellum stability --motor-law)")
    if speed is not None and speed != "":
        raise ParameterError("motor_speed", speed, f"given without a value: {command} finds the "
                                                   "critical rotation rate (give --bracket "
                                                   "ω_lo ω_hi in rad/s)")
    return "torque" if speed is None else "speed"


# -- boundary -----------------------------------------------------------------------------

def boundary_options(anchor: bool):
    """``--sphere-radius``, ``--hook``, ``--hook-stiffness``, and with ``anchor`` also
    ``--anchor`` (fixed, load sphere or free swimmer) and the cell body (``--body-radius``,
    ``--body-aspect``, ``--motor-offset``); without it the anchor is fixed, or a load sphere
    when ``--sphere-radius`` is given."""
    if anchor:
        opts = [
            click.option("--anchor", type=click.Choice(["fixed", "sphere", "free"]),
                         default=None,
                         help="first bead anchored, on a load sphere moving along z, or free "
                              "(force- and torque-free swimmer with a body sphere) [default: "
                              "fixed, sphere with --sphere-radius]"),
            click.option("--sphere-radius", type=float, default=None,
                         help="load sphere / centred body sphere radius a [µm] (free: default "
                              "0, the filament alone)"),
            click.option("--body-radius", type=float, default=None,
                         help="cell body free in 3D with the motor on its surface: its "
                              "(equatorial) radius a [µm] (implies --anchor free)"),
            click.option("--body-aspect", type=float, default=None,
                         help="cell body: prolate spheroid with polar semi-axis = aspect × "
                              "radius (>= 1) [default: 1, a sphere]"),
            click.option("--motor-offset", type=float, default=None,
                         help="cell body: motor position, angle from the rear pole [deg] "
                              "(0..180) [default: 0]"),
            click.option("--hook", type=click.Choice(["free", "elastic", "clamped"]), default=None,
                         help="hook: free joint (paper), elastic, clamped [default: free, "
                              "elastic with --hook-stiffness]"),
            click.option("--hook-stiffness", type=float, default=None, help="hook stiffness k [pN·µm]"),
        ]
    else:
        opts = [
            click.option("--sphere-radius", type=float, default=None,
                         help="attach a load sphere of this radius a [µm] (default: fixed anchor)"),
            click.option("--hook", type=click.Choice(["free", "elastic", "clamped"]), default=None,
                         help="hook: free joint, elastic, or clamped along e_z [default: free, "
                              "elastic with --hook-stiffness]"),
            click.option("--hook-stiffness", type=float, default=None,
                         help="hook bending stiffness k [pN·µm] (with --hook elastic)"),
        ]
    return lambda func: _add(func, opts)


def boundary_from_cli(kwargs: dict) -> Boundary:
    """Pop the boundary flags from ``kwargs`` and build a validated :class:`Boundary`.

    ``--anchor`` and ``--hook`` not given leave the choice to :meth:`Boundary.from_flags`:
    ``--sphere-radius`` then means a load sphere and ``--hook-stiffness`` k > 0 an elastic
    hook; given, a flag the kind does not use is refused there.
    """
    return Boundary.from_flags(anchor=kwargs.pop("anchor", None),
                               sphere_radius=kwargs.pop("sphere_radius"), hook=kwargs.pop("hook"),
                               hook_stiffness=kwargs.pop("hook_stiffness"),
                               body_radius=kwargs.pop("body_radius", None),
                               body_aspect=kwargs.pop("body_aspect", None),
                               motor_offset=kwargs.pop("motor_offset", None))


# -- solver -------------------------------------------------------------------------------

def solver_options(func):
    """``--method``, ``--rtol``, ``--dt``, ``--scheme``, ``--theta``, ``--frame``."""
    return _add(func, [
        click.option("--method", type=click.Choice(["cvode", "implicit", "bdf"]), default=None,
                     help="integrator (default: bdf, the Numba variable-order BDF, where it "
                          "supports the run; cvode with sbt, a cell body, a moving trap or "
                          "polymorphism; implicit for thermal runs)"),
        click.option("--rtol", type=float, default=1e-6, show_default=True,
                     help="relative tolerance (cvode, bdf)"),
        click.option("--dt", type=float, default=5e-5, show_default=True,
                     help="time step of the implicit scheme [s]"),
        click.option("--scheme", type=click.Choice(["bdf2", "theta"]), default=None,
                     help="fixed-step scheme (implicit method): bdf2 (default) or the θ-method"),
        click.option("--theta", type=float, default=None,
                     help="implicitness of the θ-method (implies --scheme theta): 1 implicit "
                          "Euler (default), 0.5 trapezoidal"),
        click.option("--frame", default="auto", show_default=True,
                     help="computational frame: auto (co-rotating), lab, or a rotation rate [rad/s]"),
    ])


def solver_from_cli(kwargs: dict, thermal: bool):
    """Pop the solver flags from ``kwargs`` and build validated ``SolverOptions`` (the
    default method: None, the run's :func:`~flagellum.integrate.default_method`; atol: the
    default of ``SolverOptions`` for this rtol)."""
    from ..integrate import default_method
    from ..simulator import SolverOptions

    frame = kwargs.pop("frame")
    try:
        frame = float(frame)
    except ValueError:
        pass
    method = kwargs.pop("method")
    theta, scheme = kwargs.pop("theta"), kwargs.pop("scheme")
    shown = method or default_method(thermal=thermal)  # only "implicit or not" matters here
    if shown != "implicit" and (scheme is not None or theta is not None):  # never silently unused
        flag, value = ("scheme", scheme) if scheme is not None else ("theta", theta)
        raise ParameterError(flag, value, f"given only with --method implicit (method is {shown!r})")
    if theta is not None and scheme == "bdf2":
        raise ParameterError("theta", theta, "given only with --scheme theta (scheme is 'bdf2')")
    return SolverOptions(method=method, rtol=kwargs.pop("rtol"), dt=kwargs.pop("dt"),
                         theta=theta, scheme=scheme, frame=frame)


# -- hydrodynamics ------------------------------------------------------------------------

def hydro_options(func):
    """``--hydrodynamics`` (rft, sbt) and ``--hydro-refresh``."""
    from ..hydro.options import MODELS, REFRESH

    return _add(func, [
        click.option("--hydrodynamics", type=click.Choice(MODELS), default="rft", show_default=True,
                     help="filament mobility: local resistive-force theory (the paper's) or "
                          "nonlocal slender-body theory (regularized Stokeslet segments)"),
        click.option("--hydro-refresh", type=float, default=REFRESH, show_default=True,
                     help="sbt: rebuild the frozen nonlocal mobility once a bead has moved this "
                          "far [µm]; 0: at every evaluation"),
    ])


def hydro_from_cli(kwargs: dict):
    """Pop the hydrodynamics flags from ``kwargs`` and build a validated ``Hydrodynamics``."""
    from ..hydro.options import Hydrodynamics

    return Hydrodynamics(kwargs.pop("hydrodynamics"), refresh=kwargs.pop("hydro_refresh"))


# -- input files --------------------------------------------------------------------------

def existing_file(path: str) -> Path:
    """The trajectory file argument of ``render`` and ``export``, checked to exist."""
    from ..io import input_file

    return input_file(path, "file")


# -- loads on the free end and polymorphism -------------------------------------------------

def end_load_options(func):
    """``--end-force``, ``--pull-rate``, ``--trap-stiffness``: a load on the free end
    (:class:`~flagellum.params.EndLoad`)."""
    opts = [
        click.option("--end-force", type=float, default=None,
                     help="constant force on the free end along -e_z [pN] (> 0 extends the filament)"),
        click.option("--pull-rate", type=float, default=None,
                     help="speed of the trap's centre along -e_z [µm/s] (needs --trap-stiffness)"),
        click.option("--trap-stiffness", type=float, default=None,
                     help="stiffness of an axial trap on the free end [pN/µm]; its centre starts "
                          "at the free end and moves at --pull-rate"),
    ]
    return _add(func, opts)


def end_load_from_cli(kwargs: dict):
    """Pop the end-load flags; None when none is given."""
    from ..params import EndLoad

    vals = {k: kwargs.pop(f) for k, f in (("force", "end_force"), ("pull_rate", "pull_rate"),
                                          ("trap_stiffness", "trap_stiffness"))}
    given = {k: v for k, v in vals.items() if v is not None}
    return EndLoad(**given) if given else None


def polymorph_options(func):
    """``--polymorphic FORMS`` and the ``--polymorph-*`` parameters of a multistable filament
    (:class:`~flagellum.params.Polymorphism`)."""
    opts = [
        click.option("--polymorphic", type=str, default=None,
                     help="multistable filament with these forms in order, comma-separated "
                          "(normal, semicoiled, curly1, coiled); the first given is φ = 0"),
        click.option("--polymorph-energies", type=str, default=None,
                     help="well energy of each form [pN per µm of filament], comma-separated "
                          "(default all 0)"),
        click.option("--polymorph-barrier", type=str, default=None,
                     help="barrier between neighbouring forms of equal energy [pN]: one number, "
                          "or one per neighbouring pair, comma-separated (default 0.25)"),
        click.option("--polymorph-wall-stiffness", type=float, default=None,
                     help="domain-wall stiffness D [pN·µm²] (default 0.5)"),
        click.option("--polymorph-friction", type=float, default=None,
                     help="friction ζ of the order parameter [pN·s] (default 0.1)"),
        click.option("--polymorph-initial", type=str, default=None,
                     help="initial form, or 'form:count,…' from the motor (default: the first form)"),
    ]
    return _add(func, opts)


def polymorph_from_cli(kwargs: dict):
    """Pop the polymorphism flags; None (the single-state filament) without --polymorphic."""
    from ..params import Polymorphism

    forms = kwargs.pop("polymorphic", None)
    vals = {k: kwargs.pop(f"polymorph_{k}", None) for k in
            ("energies", "barrier", "wall_stiffness", "friction", "initial")}
    if forms is None:
        for k, v in vals.items():
            if v is not None:
                raise ParameterError(f"polymorph_{k}", v,
                                     "given only with --polymorphic")
        return None
    forms = tuple(f.strip() for f in forms.split(","))
    if vals["energies"] is not None:
        vals["energies"] = _floats("polymorph_energies", vals["energies"])
    if vals["barrier"] is not None:
        b = _floats("polymorph_barrier", vals["barrier"])
        if not b:
            raise ParameterError("polymorph_barrier", vals["barrier"], "comma-separated numbers")
        vals["barrier"] = b[0] if len(b) == 1 else b
    return Polymorphism(forms=forms, **{k: v for k, v in vals.items() if v is not None})
