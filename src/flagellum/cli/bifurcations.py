"""``flagellum bifurcations``: the bifurcation torques M_c1 and M_c2."""

from __future__ import annotations

import click

from .._progress import interactive
from ..errors import ParameterError
from ..analysis.bifurcations import SCAN_SETTINGS
from ._options import (boundary_from_cli, boundary_options, hydro_from_cli, hydro_options,
                       output_option, param_options, params_from_cli, threshold_drive_from_cli,
                       threshold_drive_options, time_option)
from ._output import emit_json, emit_table, write_json


@click.command("bifurcations", short_help='Bifurcation torques M_c1 and M_c2 (Sec. 3.1)')
@param_options
@boundary_options(anchor=True)
@hydro_options
@threshold_drive_options
@click.option("--torque-range", default=None, metavar="LO:HI[:STEP]",
              help="torques of the coarse M_c2 scan [pN·µm] (default quick 3:5.5:0.5, full 2.5:5.5:0.25)")
@click.option("--speed-range", default=None, metavar="LO:HI[:STEP]",
              help="with --motor-speed: motor speeds of the coarse ω_c2 scan [rad/s] "
                   "(default quick 900:1100:50, full 875:1100:25)")
@time_option(default=None,
             help="simulated time per run after the torque step [s] (default quick 0.3, full 0.8)")
@click.option("--quality", type=click.Choice(list(SCAN_SETTINGS)), default="quick", show_default=True)
@click.option("--tol", type=float, default=None,
              help="stop bisecting when the M_c2 bracket is this narrow [pN·µm] (default quick 0.1, "
                   "full 0.025; with --motor-speed in rad/s, default 10, 2.5)")
@click.option("--hysteresis", is_flag=True,
              help="also sweep up and down by continuation and compare M_c2_up with M_c2_down")
@click.option("--confirm-mc1", type=float, default=None, metavar="DELTA",
              help="simulate at M_c1(1 ∓ DELTA), expecting aligned and buckled")
@click.option("--mc1-only", is_flag=True, help="only M_c1 (linear stability, seconds)")
@click.option("--workers", type=int, default=None, help="worker processes (default: all cores)")
@output_option("out", "write the JSON result here (atomically, also after every run)", default=None)
@click.option("--json", "as_json", is_flag=True, help="print one JSON object (no progress bar)")
def bifurcations(torque_range, speed_range, t_end, quality, tol, hysteresis, confirm_mc1, mc1_only,
                 workers, out, as_json, **kwargs):
    """Bifurcation torques: M_c1 (buckling) and M_c2 (oscillating buckled state), paper Sec. 3.1.

    M_c1 from linear stability; M_c2 from a scan of simulations classified by regime,
    refined by bisection (uncertainty: half the final bracket). Prints the regime found at
    every torque probed. With ``--motor-speed`` (no value) the same under a speed clamp:
    the critical rotation rate ω_c1, the confirmation runs at ω_c1(1 ∓ DELTA) and ω_c2
    from a scan of clamped runs over ``--speed-range``.
    """
    import os

    from ..analysis.bifurcations import bifurcations as find

    drive = threshold_drive_from_cli(kwargs, "bifurcations")
    if drive == "speed" and torque_range is not None:
        raise ParameterError("torque_range", torque_range, "left out with --motor-speed (the "
                                                           "scan's speeds: --speed-range)")
    if drive == "torque" and speed_range is not None:
        raise ParameterError("speed_range", speed_range, "given only with --motor-speed")
    boundary = boundary_from_cli(kwargs)
    params = params_from_cli(kwargs)
    hydrodynamics = hydro_from_cli(kwargs)
    head = {"quality": quality, "sphere_radius": boundary.sphere_radius,
            "hydrodynamics": hydrodynamics.model}
    partial = None
    if out:
        from ..io import check_writable

        check_writable(out)

        def partial(probes):  # the partial result, after every finished probe
            write_json(out, {**head, "complete": False, "probes": probes})

    res = find(params, boundary, quality=quality,
               torque_range=speed_range if drive == "speed" else torque_range, t_end=t_end, tol=tol,
               hysteresis=hysteresis, mc2=not mc1_only, confirm_mc1=confirm_mc1,
               workers=workers if workers is not None else (os.cpu_count() or 1),
               progress=not as_json and interactive(), on_probe=partial, hydrodynamics=hydrodynamics,
               drive=drive)
    if out:
        write_json(out, {**res, "complete": True})
    if as_json:
        emit_json(res)
        return
    probes = res.pop("probes")
    emit_table({k: v for k, v in res.items() if k not in ("paper", "scan_torques", "scan_speeds")},
               "flagellum bifurcations (pN·µm, rad/s; paper: M_c1 ≈ 1.1, M_c2 ≈ 4.2)")
    speed = drive == "speed"
    click.echo("probes: " + ("motor speed  " if speed else "") + "torque  regime  σ/σ0  thrust [pN]  direction")
    for p in probes:
        w = f"  {p.get('motor_speed', float('nan')):9.2f}" if speed else ""
        click.echo(f"{w}  {p.get('torque', float('nan')):8.4f}  {p['regime']:<12} "
                   f"{p.get('sigma_over_sigma0', float('nan')):6.3f}"
                   f"  {p.get('thrust', float('nan')):8.4f}  {p['direction']}")
