"""``flagellum reproduce``: the paper's figures."""

from __future__ import annotations

from pathlib import Path

import click

from ._options import hydro_from_cli, hydro_options, output_option
from ._output import emit_json, emit_table


@click.command("reproduce", short_help="The paper's figures, force-extension, tumble")
@click.argument("figure")
@output_option("out_dir", "output directory (one subdirectory per figure)", directory=True,
               default="flagellum-reproduce", show_default=True)
@click.option("--quality", default="quick", show_default=True,
              help="quick (CI-size runs) or full (publication quality)")
@hydro_options
@click.option("--json", "as_json", is_flag=True, help="print the headline numbers as JSON")
def reproduce(figure, out_dir, quality, as_json, **kwargs):
    """Reproduce a figure of the paper: fig3, fig4, fig5, fig6, fig7, fig8 or all; or
    force-extension (a coiled filament pulled by a trap, against Darnton & Berg 2007) or
    tumble (run and tumble of a cell with a polymorphic flagellum); these two are not part of all.

    Writes DIR/FIG/FIG.png and .pdf, the data (CSV, HDF5) and comparison.md (the paper's
    numbers, or the literature's, next to ours).
    """
    from ..reproduce import reproduce as run_target

    echo = None if as_json else (lambda msg: click.echo(msg, err=True))
    res = run_target(figure.lower(), out_dir, quality, echo=echo, hydrodynamics=hydro_from_cli(kwargs))
    if as_json:
        emit_json(_strip(res))
        return
    figs = {figure.lower(): res} if figure.lower() != "all" else \
        {k: v for k, v in res.items() if isinstance(v, dict)}
    for name, r in figs.items():
        emit_table({k: v for k, v in r.items() if k not in ("files", "points", "regimes", "lambda",
                                                            "thermal_points", "m_hat_c1")
                    and not isinstance(v, (list, dict))}, f"{name} (quality {quality}):")
        if isinstance(r.get("critical_line"), dict):
            emit_table(r["critical_line"], "  critical line:")
    click.echo(f"comparison tables: {Path(out_dir)}/*/comparison.md")


def _strip(res: dict) -> dict:
    """Headline numbers without the file lists."""
    out = {}
    for k, v in res.items():
        if k == "files":
            continue
        out[k] = _strip(v) if isinstance(v, dict) else v
    return out
