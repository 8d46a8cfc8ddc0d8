"""``flagellum polymorph-thresholds``: the threshold torques of the torque-driven
polymorphic transformations and their hysteresis (docs/polymorphism.md)."""

from __future__ import annotations

import click

from ._options import (boundary_from_cli, boundary_options, param_options, params_from_cli,
                       polymorph_from_cli, polymorph_options, time_option)
from ._output import emit_json, emit_table


@click.command("polymorph-thresholds", short_help="Torque thresholds of the polymorphic forms")
@param_options
@boundary_options(anchor=False)
@polymorph_options
@click.option("--bracket-down", type=float, nargs=2, default=(-0.3, -2.0), show_default=True,
              help="torques [pN·µm] without and with normal → next form (both < 0)")
@click.option("--bracket-up", type=float, nargs=2, default=(0.1, 2.0), show_default=True,
              help="torques [pN·µm] without and with the way back (both > 0)")
@time_option(default=0.05, show_default=True, help="simulated time of each run [s]")
@click.option("--tol", type=float, default=0.05, show_default=True,
              help="stop bisecting when the bracket is this narrow [pN·µm]")
@click.option("--min-fraction", type=float, default=0.1, show_default=True,
              help="fraction of the joints out of the starting form that counts as transformed")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def polymorph_thresholds(bracket_down, bracket_up, t_end, tol, min_fraction, as_json, **kwargs):
    """Threshold torques of the first two forms of ``--polymorphic`` (default
    normal,semicoiled) by bisection of constant-torque runs from the stress-free filament:
    down (first → second form at M < 0) and up (back at M > 0), their hysteresis, the
    nucleation site [µm from the hook] and wall speed [µm/s] at each threshold.
    """
    from ..analysis.polymorph import torque_thresholds

    from ..errors import ParameterError

    boundary = boundary_from_cli(kwargs)
    if kwargs.get("polymorph_initial") is not None:  # each run sets its starting form
        raise ParameterError("polymorph_initial", kwargs["polymorph_initial"],
                             "not given here (the runs start in the first and second form)")
    kwargs["polymorphic"] = kwargs.get("polymorphic") or "normal,semicoiled"
    pm = polymorph_from_cli(kwargs)
    params = params_from_cli(kwargs)
    out = torque_thresholds(params, pm, boundary, bracket_down=bracket_down,
                            bracket_up=bracket_up, t_run=t_end, tol=tol,
                            min_fraction=min_fraction).to_dict()
    if as_json:
        emit_json(out)
    else:
        out.pop("runs")
        out["forms"] = ",".join(out["forms"])
        emit_table(out, "Torque thresholds [pN·µm], nucleation sites [µm], wall speeds [µm/s]")
