"""``flagellum simulate``: one run of the motor-driven filament."""

from __future__ import annotations

import math

import click

from ._options import (boundary_from_cli, boundary_options, end_load_from_cli, end_load_options,
                       hydro_from_cli, hydro_options, motor_from_cli, motor_options,
                       output_option, param_options, params_from_cli, polymorph_from_cli,
                       polymorph_options, solver_from_cli, solver_options, time_option)
from ..errors import ParameterError
from ._output import emit_json, emit_table


@click.command(short_help='Simulate the filament: averages and regime')
@param_options
@motor_options
@boundary_options(anchor=True)
@end_load_options
@polymorph_options
@time_option(default=0.3, show_default=True, help="simulated time [s]")
@click.option("--save-every", type=float, default=None, help="save interval [s] (default time/300)")
@click.option("--average-from", type=float, default=None,
              help="average observables from this time on [s] (default: last half)")
@click.option("--thermal", is_flag=True, help="thermal noise at kT (also implied by --kT)")
@click.option("--seed", type=int, default=0, show_default=True, help="random seed (thermal runs)")
@solver_options
@hydro_options
@output_option("output", "HDF5 trajectory file", default=None)
@click.option("--checkpoint-every", type=float, default=None,
              help="write records and a checkpoint every T simulated seconds (with --output)")
@click.option("--overwrite", is_flag=True, help="replace an existing --output file")
@click.option("--resume", "resume_file", type=click.Path(dir_okay=False), default=None,
              help="continue the run in this HDF5 file from its last checkpoint")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object (no progress bar)")
def simulate(t_end, save_every, average_from, thermal, seed, output, checkpoint_every, overwrite,
             resume_file, as_json, **kwargs):
    """Simulate the motor-driven filament and report time-averaged observables."""
    from ..params import check_range
    from ..simulator import Simulator

    if average_from is not None:  # checked before the run, against the run's time if known
        check_range("average_from", average_from, 0.0, math.inf if resume_file else t_end,
                    lo_open=False)
    if resume_file is not None:
        _check_alone(click.get_current_context())
        sim, traj = Simulator.resume(resume_file, progress=False if as_json else None)
        _report_run(sim, traj, average_from, resume_file, as_json)
        return
    thermal = thermal or kwargs.get("kT") is not None
    params = params_from_cli(kwargs)
    motor = motor_from_cli(kwargs)
    boundary = boundary_from_cli(kwargs)
    solver = solver_from_cli(kwargs, thermal)
    end_load, polymorphism = end_load_from_cli(kwargs), polymorph_from_cli(kwargs)
    sim = Simulator(params, motor, boundary, thermal=thermal, seed=seed, solver=solver,
                    hydrodynamics=hydro_from_cli(kwargs), end_load=end_load,
                    polymorphism=polymorphism)
    traj = sim.run(t_end, save_every=save_every if save_every is not None else t_end / 300,
                   output=output, progress=False if as_json else None,
                   checkpoint_every=checkpoint_every, overwrite=overwrite)
    _report_run(sim, traj, average_from, output, as_json)


#: what a resumed run may be given besides --resume: its report (the run is the checkpoint's)
_WITH_RESUME = {"resume_file", "as_json", "average_from"}


def _check_alone(ctx: click.Context) -> None:
    """Refuse flags that a resumed run would ignore: its physics, output and settings are
    those stored in the file."""
    given = [p for p in ctx.command.params if p.name not in _WITH_RESUME
             and ctx.get_parameter_source(p.name) not in (click.core.ParameterSource.DEFAULT, None)]
    if given:
        raise ParameterError("resume", ", ".join(p.opts[0] for p in given),
                             "given alone (the resumed run takes its parameters, output and "
                             "settings from the file; only --json and --average-from combine)")


def _report_run(sim, traj, average_from, output, as_json):
    summary = traj.summary(average_from)
    torque = (sim.motor.final_torque * sim.motor.direction(sim.t) if sim.motor.drive == "torque"
              else summary.torque_mean)
    out = {**summary.to_dict(), "steps": sim.steps,
           "wall_seconds": sim.wall_seconds, "torque": torque,
           "segments": sim.params.filament.n_segments, "hydrodynamics": sim.hydrodynamics.model}
    if sim.boundary.anchor == "free" and sim.boundary.sphere_radius:
        out["body_rotation_rate"] = sim.boundary.body_rotation_rate(torque,
                                                                    sim.params.fluid.viscosity)
    if sim.end_load is not None:
        out.update(traj.load_summary(average_from))
    if sim.polymorphism is not None:
        out.update(traj.polymorph_summary(average_from))
    if sim.boundary.is_cell and len(sim.motor.reversals or ()) >= 2 and sim.motor.reversals[1] < sim.t:
        out.update(traj.tumble_summary().to_dict())
    if output:
        out["output"] = str(output)
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "flagellum simulate (µm, pN, s)")
