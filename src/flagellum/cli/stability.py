"""``flagellum stability`` and ``flagellum critical-torque``: linear stability of the aligned
rotating filament."""

from __future__ import annotations

import click

from ._options import (boundary_from_cli, boundary_options, hydro_from_cli, hydro_options,
                       param_options, params_from_cli)
from ._output import emit_json, emit_table


@click.command("stability", short_help='Linear stability of the aligned filament')
@param_options
@boundary_options(anchor=False)
@hydro_options
@click.option("--torque", type=float, required=True, help="motor torque M [pN·µm], nonzero")
@click.option("--n-eigs", type=int, default=6, show_default=True, help="leading eigenvalues to print")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def stability(torque, n_eigs, as_json, **kwargs):
    """Linear stability of the aligned rotating filament at torque M (paper Fig. 4(a)).

    Prints Ω, the thrust, λ (largest real part of the spectrum in the co-rotating frame,
    rotational zero mode removed) and the leading eigenvalues as [re, im] pairs. With
    ``--hydrodynamics sbt`` the mobility is rebuilt at every evaluation (``--hydro-refresh``
    has no effect).
    """
    from ..analysis.stability import linear_stability

    boundary = boundary_from_cli(kwargs)
    params = params_from_cli(kwargs)
    out = linear_stability(params, torque, boundary, n_eigs,
                           hydrodynamics=hydro_from_cli(kwargs)).to_dict()
    if as_json:
        emit_json(out)
    else:
        ev = out.pop("eigenvalues")
        out["eigenvalues"] = ", ".join(f"{re:.6g}{im:+.6g}i" for re, im in ev)
        emit_table(out, "Aligned state: Ω [rad/s], thrust [pN], v [µm/s], eigenvalues [1/s]")


@click.command("critical-torque", short_help='Buckling threshold M_c1, the root of λ(M)')
@param_options
@boundary_options(anchor=False)
@hydro_options
@click.option("--bracket", type=float, nargs=2, default=None,
              help="torques M_lo M_hi [pN·µm] with λ(M_lo) < 0 < λ(M_hi) "
                   "(default 0.5 2 with rft, 1 2.5 with sbt)")
@click.option("--xtol", type=float, default=1e-4, show_default=True, help="tolerance on M_c1 [pN·µm]")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def critical_torque(bracket, xtol, as_json, **kwargs):
    """Buckling threshold M_c1 where λ(M) changes sign, with F_c1 and Ω there (paper Sec. 3.1–3.2).

    With ``--hydrodynamics sbt`` the mobility is rebuilt at every evaluation, as in ``stability``.
    """
    from ..analysis.stability import critical_torque as find

    boundary = boundary_from_cli(kwargs)
    params = params_from_cli(kwargs)
    out = find(params, boundary, tuple(bracket) if bracket else None, xtol,
               hydrodynamics=hydro_from_cli(kwargs)).to_dict()
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "Critical torque (pN·µm), force (pN), Ω (rad/s)")
