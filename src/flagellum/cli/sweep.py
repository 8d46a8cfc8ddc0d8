"""``flagellum sweep``: a grid of simulations."""

from __future__ import annotations

import click

from ..errors import ParameterError
from ..sweep import FALLBACK_PARAMETERS, PARAMETERS, Sweep, parse_values, run_sweep
from ._options import PARAM_HELP, AliasedOption, output_option
from ._output import emit_json, emit_table

_HELP = {
    **PARAM_HELP,
    "friction": "friction model: paper, lighthill, custom",
    "torque": "motor torque M [pN·µm] (> 0 pushes)",
    "motor_speed": "speed clamp: motor speed ω [rad/s] relative to the body (not with --torque)",
    "motor_law": "torque–speed law: e-coli or a table FILE (not with --torque)",
    "ramp_time": "ramp the torque (or the clamped speed) on over this time [s]",
    "reversal_times": "reverse the motor (CCW <-> CW) at these times [s], comma-separated (one list)",
    "reversal_rates": "random reversals: rates CCW->CW,CW->CCW [1/s] (one list)",
    "reversal_seed": "seed of the random reversal times (default 0)",
    "anchor": "fixed, sphere (implied by --sphere-radius) or free (implied by --body-radius)",
    "body_radius": "cell body free in 3D with the motor on its surface: its (equatorial) radius a [µm]",
    "body_aspect": "cell body: prolate spheroid, polar semi-axis = aspect × radius (>= 1)",
    "motor_offset": "cell body: motor position, angle from the rear pole [deg] (0..180)",
    "sphere_radius": "load sphere radius a [µm]",
    "hook": "free, elastic (implied by --hook-stiffness), clamped",
    "hook_stiffness": "hook stiffness k [pN·µm]",
    "hydrodynamics": "filament mobility: rft (local, the paper's) or sbt (nonlocal)",
    "hydro_refresh": "sbt: rebuild the frozen nonlocal mobility once a bead moved this far [µm]",
    "time": "simulated time per point [s] (default 0.3)",
    "save_every": "save interval [s] (default time/300)",
    "average_from": "average from this time on [s] (default: last half)",
    "thermal": "true or false (default: true when kT is given)",
    "seed": "random seed of thermal runs (default 0)",
    "method": "integrator: bdf, cvode or implicit (default: the run's default method)",
    "rtol": "relative tolerance of cvode",
    "dt": "time step of the implicit scheme [s]",
}


def parameter_options(func):
    """One option per sweepable parameter taking ``start:stop[:step]``, ``a,b,c`` or a value."""
    for name in reversed(PARAMETERS):
        func = click.option("--" + name.replace("_", "-"), name, type=str, default=None,
                            metavar="RANGE", help=_HELP[name], cls=AliasedOption,
                            aliases=("--t-end",) if name == "time" else ())(func)
    return func


@click.command("sweep", short_help='A grid of simulations into one dataset')
@click.argument("config", required=False, type=click.Path(dir_okay=False))
@parameter_options
@output_option("out", "output HDF5 dataset (e.g. results.nc)", required=True)
@click.option("--resume", is_flag=True, help="keep the finished points of --output, compute the rest")
@click.option("--overwrite", is_flag=True, help="replace an existing --output")
@click.option("--retry-failed", is_flag=True, help="resume, computing the failed points again")
@click.option("--fallback", multiple=True, metavar="NAME=VALUE",
              help="solver setting for retries (" + ", ".join(FALLBACK_PARAMETERS) + "; repeatable), "
                   "e.g. method=implicit: failed points are run once more with it")
@click.option("--workers", type=int, default=None, help="local worker processes (default: all cores)")
@click.option("--scheduler", default=None, help="run on this dask scheduler (tcp://host:port)")
@click.option("--dask-local", type=int, default=None, help="run on a local dask cluster of N workers")
@click.option("--json", "as_json", is_flag=True, help="no progress bar; print one JSON object")
@click.pass_context
def sweep(ctx, config, out, resume, overwrite, retry_failed, fallback, workers, scheduler,
          dask_local, as_json, **kwargs):
    """Run a grid of simulations (CONFIG: TOML with [fixed] and [ranges]; flags override it).

    Each parameter flag takes a range start:stop:step (stop included when on the grid), a
    list a,b,c, or one value (fixed). Results: one HDF5 dataset, written after each point.
    """
    given = {k: v for k, v in kwargs.items() if v is not None}
    if config is None and not given:
        raise click.UsageError("give a CONFIG file or at least one parameter (e.g. --torque 1:3:1)")
    ranges, fixed = {}, {}
    for name, text in given.items():
        values = parse_values(name, text)
        (ranges if len(values) > 1 else fixed)[name] = values if len(values) > 1 else values[0]
    base = Sweep.from_toml(config) if config is not None else Sweep()
    settings = {}
    for item in fallback:
        name, eq, value = item.partition("=")
        if not eq or not name.strip():
            raise ParameterError("fallback", item, "NAME=VALUE, e.g. method=implicit")
        settings[name.strip()] = value
    report = run_sweep(base.updated(ranges, fixed), out, resume=resume, overwrite=overwrite,
                       workers=workers, scheduler=scheduler, dask_local=dask_local,
                       progress=False if as_json else None, retry_failed=retry_failed,
                       fallback=settings)
    if as_json:
        emit_json(report.to_dict())
    else:
        emit_table(report.to_dict(), "flagellum sweep")
    if report.lost:
        click.echo(f"flagellum: {report.lost} point(s) lost with their workers; "
                   f"rerun with --resume", err=True)
        ctx.exit(1)

