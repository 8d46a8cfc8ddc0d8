"""CLI commands ``flagellum stability`` and ``flagellum critical-torque`` (registered by
:mod:`flagellum.cli` from :data:`COMMANDS`)."""

from __future__ import annotations

import click

from ..cli import emit_json, emit_table, param_options, params_from_cli
from ..motor import Boundary


def boundary_options(func):
    """``--sphere-radius``, ``--hook``, ``--hook-stiffness``."""
    func = click.option("--hook-stiffness", type=float, default=None,
                        help="hook bending stiffness k [pN·µm] (with --hook elastic)")(func)
    func = click.option("--hook", type=click.Choice(["free", "elastic", "clamped"]), default="free",
                        show_default=True, help="hook: free joint, elastic, or clamped along e_z")(func)
    func = click.option("--sphere-radius", type=float, default=None,
                        help="attach a load sphere of this radius a [µm] (default: fixed anchor)")(func)
    return func


def boundary_from_cli(kwargs: dict) -> Boundary:
    """Pop the boundary flags from ``kwargs`` and build a validated :class:`Boundary`."""
    a = kwargs.pop("sphere_radius")
    hook, k = kwargs.pop("hook"), kwargs.pop("hook_stiffness")
    return Boundary(anchor="fixed" if a is None else "sphere", sphere_radius=a, hook=hook,
                    hook_stiffness=0.0 if k is None else k)


@click.command("stability")
@param_options
@boundary_options
@click.option("--torque", type=float, required=True, help="motor torque M [pN·µm], nonzero")
@click.option("--n-eigs", type=int, default=6, show_default=True, help="leading eigenvalues to print")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def stability(torque, n_eigs, as_json, **kwargs):
    """Linear stability of the aligned rotating filament at torque M (paper Fig. 3a).

    Prints Ω, the thrust, λ (largest real part of the spectrum in the co-rotating frame,
    rotational zero mode removed) and the leading eigenvalues as [re, im] pairs.
    """
    from .stability import linear_stability

    boundary = boundary_from_cli(kwargs)
    params = params_from_cli(kwargs)
    out = linear_stability(params, torque, boundary, n_eigs).to_dict()
    if as_json:
        emit_json(out)
    else:
        ev = out.pop("eigenvalues")
        out["eigenvalues"] = ", ".join(f"{re:.6g}{im:+.6g}i" for re, im in ev)
        emit_table(out, "Aligned state: Ω [rad/s], thrust [pN], v [µm/s], eigenvalues [1/s]")


@click.command("critical-torque")
@param_options
@boundary_options
@click.option("--bracket", type=float, nargs=2, default=(0.5, 2.0), show_default=True,
              help="torques M_lo M_hi [pN·µm] with λ(M_lo) < 0 < λ(M_hi)")
@click.option("--xtol", type=float, default=1e-4, show_default=True, help="tolerance on M_c1 [pN·µm]")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def critical_torque(bracket, xtol, as_json, **kwargs):
    """Buckling threshold M_c1 where λ(M) changes sign, with F_c1 and Ω there (paper §3.1–3.2)."""
    from .stability import critical_torque as find

    boundary = boundary_from_cli(kwargs)
    params = params_from_cli(kwargs)
    out = find(params, boundary, tuple(bracket), xtol).to_dict()
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "Critical torque (pN·µm), force (pN), Ω (rad/s)")


COMMANDS = [stability, critical_torque]
