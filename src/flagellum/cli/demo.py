"""``flagellum demo``: the paper's filament below and above M_c1."""

from __future__ import annotations

import click

from ._options import output_option
from ._output import emit_json


@click.command(short_help="The paper's filament below and above M_c1")
@output_option("out_dir", "output directory", directory=True, default="flagellum-demo",
               show_default=True)
@click.option("--json", "as_json", is_flag=True, help="print only the results, as one JSON object")
@click.option("--movie-size", type=click.Choice(["720p", "1080p"]), default="720p", show_default=True,
              help="movie frame size: 1280×720 or 1920×1080")
def demo(out_dir, as_json, movie_size):
    """Simulate the paper's filament below and above M_c1; write movies and a figure."""
    from ..demo import run_demo
    from ..hydro.rft import rft_summary
    from ..params import Params

    out = rft_summary(Params())
    if not as_json:
        click.echo(f"Paper's filament: R = {out['radius']:.3f} µm, L0 = {out['axial_length']:.2f} µm, "
                   f"rigid-helix thrust/torque {out['pinned']['thrust_per_torque']:.3f} /µm (pinned)")
    res = run_demo(out_dir, progress=None if not as_json else False, quiet=as_json, size=movie_size)
    if as_json:
        emit_json(res)
