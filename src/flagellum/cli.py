"""Command-line interface: ``flagellum COMMAND``.

Every invalid input ends in one line on stderr and exit code 2 (see :func:`run`).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import fields

import click
import numpy as np

from ._version import __version__
from .errors import FlagellumError
from .params import Filament, Fluid, Friction, Params

_FLAG_HELP = {
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


def param_options(func):
    """Add one flag per model parameter (same names as the TOML keys) plus ``--config``."""
    for name in reversed(_PARAM_NAMES):
        flag = "--" + name.replace("_", "-")
        if name == "handedness":
            func = click.option(flag, type=click.Choice(["right", "left"]), default=None,
                                help=_FLAG_HELP[name])(func)
        else:
            func = click.option(flag, name, type=float, default=None, help=_FLAG_HELP[name])(func)
    func = click.option("--friction", type=click.Choice(["paper", "lighthill", "custom"]),
                        default=None, help="friction coefficients: paper's rounded values, "
                                           "Lighthill's formulas, or custom γ's")(func)
    func = click.option("--config", type=click.Path(dir_okay=False), default=None,
                        help="TOML file with [filament], [fluid], [friction] tables")(func)
    return func


def params_from_cli(kwargs: dict) -> Params:
    """Pop the parameter flags from ``kwargs`` and build validated :class:`Params`."""
    config = kwargs.pop("config", None)
    base = Params.load_toml(config) if config else Params()
    flat = {name: kwargs.pop(name, None) for name in _PARAM_NAMES + ["friction"]}
    return Params.from_flat(flat, base=base)


def _jsonable(obj):  # moved: flagellum._util.jsonable
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def emit_json(obj) -> None:
    click.echo(json.dumps(_jsonable(obj), indent=2))


def emit_table(rows: dict, title: str | None = None) -> None:
    if title:
        click.echo(title)
    width = max(len(k) for k in rows)
    for k, v in rows.items():
        if isinstance(v, dict):
            click.echo(f"{k}:")
            for k2, v2 in v.items():
                click.echo(f"  {k2:<{width}}  {_fmt(v2)}")
        else:
            click.echo(f"{k:<{width + 2}}  {_fmt(v)}")


def _fmt(v) -> str:
    return f"{v:.6g}" if isinstance(v, (float, np.floating)) else str(v)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="flagellum")
def main():
    """Motor-driven bacterial flagella and their buckling instabilities (Vogel & Stark 2012).

    Units: µm, pN, s.
    """


@main.command()
@param_options
@click.option("--critical-force", type=float, default=1.0, show_default=True,
              help="F_c1 [pN] for the critical-torque line of eq. (25)")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def rft(as_json, critical_force, **kwargs):
    """Rigid-helix resistive-force theory: geometry, friction coefficients, F/M, ω/M."""
    from .hydro.rft import rft_summary
    from .params import check_real

    params = params_from_cli(kwargs)
    out = rft_summary(params, check_real("critical_force", critical_force))
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "Rigid-helix RFT (units µm, pN, s)")


@main.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="flagellum-demo",
              show_default=True, help="output directory")
@click.option("--json", "as_json", is_flag=True, help="print the results as JSON at the end")
def demo(out_dir, as_json):
    """Simulate the paper's filament below and above M_c1; write movies and a figure."""
    from .demo import run_demo
    from .hydro.rft import rft_summary

    out = rft_summary(Params())
    click.echo(f"Paper's filament: R = {out['radius']:.3f} µm, L0 = {out['axial_length']:.2f} µm, "
               f"rigid-helix thrust/torque {out['pinned']['thrust_per_torque']:.3f} /µm (pinned)")
    res = run_demo(out_dir, progress=None if not as_json else False)
    if as_json:
        emit_json(res)


def motor_boundary_options(func):
    """Flags of the motor torque and the boundary conditions."""
    opts = [
        click.option("--torque", type=float, default=1.0, show_default=True,
                     help="motor torque M [pN·µm] (> 0 pushes)"),
        click.option("--ramp-time", type=float, default=0.0, show_default=True,
                     help="ramp the torque on smoothly over this time [s]"),
        click.option("--anchor", type=click.Choice(["fixed", "sphere", "free"]), default="fixed",
                     show_default=True, help="first bead anchored, on a load sphere moving along z, "
                     "or free (force- and torque-free swimmer with a body sphere)"),
        click.option("--sphere-radius", type=float, default=None,
                     help="load sphere / body radius a [µm] (free: default 0, the filament alone)"),
        click.option("--hook", type=click.Choice(["free", "elastic", "clamped"]), default="free",
                     show_default=True, help="hook: free joint (paper), elastic, clamped"),
        click.option("--hook-stiffness", type=float, default=0.0, help="hook stiffness k [pN·µm]"),
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


def motor_boundary_from_cli(kwargs: dict):
    from .motor import Boundary, Motor

    motor = Motor(kwargs.pop("torque"), ramp_time=kwargs.pop("ramp_time"))
    anchor, radius = kwargs.pop("anchor"), kwargs.pop("sphere_radius")
    if radius is not None and anchor == "fixed":
        anchor = "sphere"
    hook, k = kwargs.pop("hook"), kwargs.pop("hook_stiffness")
    if k and hook == "free":
        hook = "elastic"
    return motor, Boundary(anchor=anchor, sphere_radius=radius, hook=hook, hook_stiffness=k)


@main.command()
@param_options
@motor_boundary_options
@click.option("--time", "t_end", type=float, default=0.3, show_default=True, help="simulated time [s]")
@click.option("--save-every", type=float, default=None, help="save interval [s] (default time/300)")
@click.option("--average-from", type=float, default=None,
              help="average observables from this time on [s] (default: last half)")
@click.option("--thermal", is_flag=True, help="thermal noise at kT (also implied by --kT)")
@click.option("--seed", type=int, default=0, show_default=True, help="random seed (thermal runs)")
@click.option("--method", type=click.Choice(["cvode", "implicit"]), default=None,
              help="integrator (default: cvode, implicit for thermal runs)")
@click.option("--rtol", type=float, default=1e-6, show_default=True, help="relative tolerance (cvode)")
@click.option("--dt", type=float, default=5e-5, show_default=True, help="time step of the implicit scheme [s]")
@click.option("--scheme", type=click.Choice(["bdf2", "theta"]), default=None,
              help="fixed-step scheme (implicit method): bdf2 (default) or the θ-method")
@click.option("--theta", type=float, default=None,
              help="implicitness of the θ-method (implies --scheme theta): 1 implicit Euler "
                   "(default), 0.5 trapezoidal")
@click.option("--frame", default="auto", show_default=True,
              help="computational frame: auto (co-rotating), lab, or a rotation rate [rad/s]")
@click.option("--output", "-o", type=click.Path(dir_okay=False), default=None, help="HDF5 trajectory file")
@click.option("--checkpoint-every", type=float, default=None,
              help="write records and a checkpoint every T simulated seconds (with --output)")
@click.option("--resume", "resume_file", type=click.Path(dir_okay=False), default=None,
              help="continue the run in this HDF5 file from its last checkpoint")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object (no progress bar)")
def simulate(t_end, save_every, average_from, thermal, seed, method, rtol, dt, scheme, theta, frame,
             output, checkpoint_every, resume_file, as_json, **kwargs):
    """Simulate the motor-driven filament and report time-averaged observables."""
    from .params import check_range
    from .simulator import Simulator, SolverOptions

    if average_from is not None:  # checked before the run, against the run's time if known
        check_range("average_from", average_from, 0.0, math.inf if resume_file else t_end,
                    lo_open=False)
    if resume_file is not None:
        sim, traj = Simulator.resume(resume_file, progress=False if as_json else None)
        _report_run(sim, traj, average_from, resume_file, as_json)
        return
    thermal = thermal or kwargs.get("kT") is not None
    params = params_from_cli(kwargs)
    motor, boundary = motor_boundary_from_cli(kwargs)
    try:
        frame = float(frame)
    except ValueError:
        pass
    solver = SolverOptions(method=method or ("implicit" if thermal else "cvode"), rtol=rtol,
                           atol=rtol * 1e-2, dt=dt, theta=theta, scheme=scheme, frame=frame)
    sim = Simulator(params, motor, boundary, thermal=thermal, seed=seed, solver=solver)
    traj = sim.run(t_end, save_every=save_every if save_every is not None else t_end / 300,
                   output=output, progress=False if as_json else None,
                   checkpoint_every=checkpoint_every)
    _report_run(sim, traj, average_from, output, as_json)


def _report_run(sim, traj, average_from, output, as_json):
    out = {**traj.summary(average_from).to_dict(), "steps": sim.steps,
           "wall_seconds": sim.wall_seconds, "torque": sim.motor.final_torque,
           "segments": sim.params.filament.n_segments}
    if sim.boundary.anchor == "free" and sim.boundary.sphere_radius:
        out["body_rotation_rate"] = sim.boundary.body_rotation_rate(sim.motor.final_torque,
                                                                    sim.params.fluid.viscosity)
    if output:
        out["output"] = str(output)
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "flagellum simulate (µm, pN, s)")


@main.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def info(file, as_json):
    """Provenance of an output file: parameters, version, git revision, seed, status."""
    from .io import read_trajectory

    data = read_trajectory(file)
    attrs = {k: (v.item() if hasattr(v, "item") else v) for k, v in data["attrs"].items()}
    attrs["records"] = int(len(data.get("t", [])))
    if as_json:
        emit_json(attrs)
    else:
        for k, v in attrs.items():
            click.echo(f"{k}:" + ("\n  " + str(v).replace("\n", "\n  ") if "\n" in str(v) else f" {v}"))


@main.command()
@click.option("--quick", is_flag=True, help="shorter windows (a rough number in seconds)")
@click.option("--window", type=float, default=0.2, show_default=True,
              help="simulated time of the steady-state window [s]")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def bench(quick, window, as_json):
    """Speed benchmarks: wall seconds per simulated second, scaling with N, Brownian."""
    from .bench import bench as run_bench
    from .params import positive

    out = run_bench(positive("window", window, 10.0), quick=quick)
    if as_json:
        emit_json(out)
    else:
        emit_table({k: v for k, v in out.items() if k != "scaling"}, "flagellum bench")
        for row in out["scaling"]:
            click.echo("  " + ", ".join(f"{k} {_fmt(v)}" for k, v in row.items()))


def _register_optional():
    """Commands that live next to their subject (theory, stability)."""
    import importlib

    for module, names in ((".theory.cli", ("theory",)), (".analysis.stability_cli", ("COMMANDS",)), (".analysis.bifurcations_cli", ("COMMANDS",)), (".sweep_cli", ("COMMANDS",)), (".reproduce.cli", ("COMMANDS",))):
        try:
            mod = importlib.import_module(module, __package__)
        except ImportError:  # not part of this build
            continue
        for name in names:
            obj = getattr(mod, name, None)
            for cmd in (obj if isinstance(obj, (list, tuple)) else [obj]):
                if cmd is not None:
                    main.add_command(cmd)


_register_optional()


def run(argv=None) -> int:
    """Entry point: run the CLI, turning every user error into one line and exit code 2."""
    try:
        main.main(args=argv, prog_name="flagellum", standalone_mode=False)
    except FlagellumError as exc:
        click.echo(f"flagellum: error: {exc}", err=True)
        return 2
    except click.exceptions.Abort:
        click.echo("flagellum: aborted", err=True)
        return 130
    except click.ClickException as exc:
        msg = " ".join(exc.format_message().split())
        click.echo(f"flagellum: error: {msg}", err=True)
        return 2
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except OSError as exc:  # the file system refused: not a directory, unwritable, disk full
        where = f": {exc.filename}" if exc.filename else ""
        click.echo(f"flagellum: error: {exc.strerror or exc}{where}", err=True)
        return 2
    return 0


def keep_stdout_for_results() -> None:
    """Route file descriptor 1 to stderr and give Python's stdout a private copy of the real
    stdout: C libraries write there (SUNDIALS prints its warnings, e.g. "t + h = t", to fd 1
    and is not told otherwise through scikit-sundae), which made ``--json`` output
    unparseable. Child processes inherit the routing."""
    import os

    try:
        if sys.stdout.fileno() != 1:
            return
    except (AttributeError, OSError, ValueError):  # replaced stdout (tests, notebooks)
        return
    sys.stdout.flush()
    real = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = open(real, "w", encoding=sys.stdout.encoding, errors=sys.stdout.errors)


def entry():  # console script
    keep_stdout_for_results()
    sys.exit(run())


if __name__ == "__main__":
    entry()
