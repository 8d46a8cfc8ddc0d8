"""``flagellum stability`` and ``flagellum critical-torque``: linear stability of the aligned
rotating filament."""

from __future__ import annotations

import click

from ._options import (boundary_from_cli, boundary_options, hydro_from_cli, hydro_options,
                       motor_from_cli, motor_options, param_options, params_from_cli,
                       threshold_drive_from_cli, threshold_drive_options)
from ._output import emit_json, emit_table


@click.command("stability", short_help='Linear stability of the aligned filament')
@param_options
@boundary_options(anchor=True)
@hydro_options
@motor_options
@click.option("--n-eigs", type=int, default=6, show_default=True, help="leading eigenvalues to print")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def stability(n_eigs, as_json, **kwargs):
    """Linear stability of the aligned rotating filament (paper Fig. 4(a)) under the drive:
    a torque M (``--torque``), a speed clamp (``--motor-speed``: linearized with the clamp,
    the torque is an output) or a torque–speed law (``--motor-law``, at its operating point).

    Prints Ω, the thrust, λ (largest real part of the spectrum in the co-rotating frame,
    rotational zero mode removed) and the leading eigenvalues as [re, im] pairs. A free
    swimmer (``--anchor free``) is linearized in the frame that moves with its body (the
    rigid translations quotiented out). With ``--hydrodynamics sbt`` the mobility is rebuilt
    at every evaluation (``--hydro-refresh`` has no effect).
    """
    from ..analysis.stability import linear_stability

    boundary = boundary_from_cli(kwargs)
    params = params_from_cli(kwargs)
    motor = motor_from_cli(kwargs)
    out = linear_stability(params, boundary=boundary, n_eigs=n_eigs, motor=motor,
                           hydrodynamics=hydro_from_cli(kwargs)).to_dict()
    if as_json:
        emit_json(out)
    else:
        ev = out.pop("eigenvalues")
        out["eigenvalues"] = ", ".join(f"{re:.6g}{im:+.6g}i" for re, im in ev)
        emit_table(out, "Aligned state: Ω [rad/s], thrust [pN], v [µm/s], eigenvalues [1/s]")


@click.command("critical-torque", short_help='Buckling threshold M_c1, the root of λ(M)')
@param_options
@boundary_options(anchor=True)
@hydro_options
@threshold_drive_options
@click.option("--bracket", type=float, nargs=2, default=None,
              help="torques M_lo M_hi [pN·µm] with λ(M_lo) < 0 < λ(M_hi) (default: found "
                   "automatically, widened from 0.5 2 with rft, 1 2.5 with sbt until λ changes "
                   "sign within 0.25–10); motor speeds [rad/s] with --motor-speed")
@click.option("--xtol", type=float, default=None,
              help="tolerance on M_c1 [pN·µm] (default 1e-4), on ω_c1 [rad/s] with --motor-speed (default 0.1)")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def critical_torque(bracket, xtol, as_json, **kwargs):
    """Buckling threshold M_c1 where λ(M) changes sign, with F_c1 and Ω there (paper Sec. 3.1–3.2).

    With ``--motor-speed`` (no value) the threshold of a speed clamp: the critical rotation
    rate ω_c1 (``motor_speed``) where λ of the clamped aligned state changes sign, and the
    torque the clamp takes there. With ``--hydrodynamics sbt`` the mobility is rebuilt at
    every evaluation, as in ``stability``.
    """
    from ..analysis.stability import critical_speed, critical_torque as find

    drive = threshold_drive_from_cli(kwargs, "critical-torque")
    boundary = boundary_from_cli(kwargs)
    params = params_from_cli(kwargs)
    search = find if drive == "torque" else critical_speed
    more = {} if xtol is None else {"xtol": xtol}
    out = search(params, boundary, tuple(bracket) if bracket else None,
                 hydrodynamics=hydro_from_cli(kwargs), **more).to_dict()
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "Critical torque (pN·µm), force (pN), Ω and motor speed (rad/s)")
