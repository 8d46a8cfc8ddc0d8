"""``flagellum rft``: the rigid-helix resistive-force theory."""

from __future__ import annotations

import click

from ._options import param_options, params_from_cli
from ._output import emit_json, emit_table


@click.command(short_help='Rigid-helix resistive-force theory')
@param_options
@click.option("--critical-force", type=float, default=1.0, show_default=True,
              help="F_c1 [pN] for the critical-torque line of the paper's Eq. (16)")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def rft(as_json, critical_force, **kwargs):
    """Rigid-helix resistive-force theory: geometry, friction coefficients, F/M, ω/M."""
    from ..hydro.rft import rft_summary
    from ..params import check_real

    params = params_from_cli(kwargs)
    out = rft_summary(params, check_real("critical_force", critical_force))
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "Rigid-helix RFT (units µm, pN, s)")
