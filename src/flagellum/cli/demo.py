"""``flagellum demo``: the paper's filament below and above M_c1."""

from __future__ import annotations

import click

from ._output import emit_json


@click.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="flagellum-demo",
              show_default=True, help="output directory")
@click.option("--json", "as_json", is_flag=True, help="print the results as JSON at the end")
@click.option("--movie-size", type=click.Choice(["720p", "1080p"]), default="720p", show_default=True,
              help="movie frame size: 1280×720 or 1920×1080")
def demo(out_dir, as_json, movie_size):
    """Simulate the paper's filament below and above M_c1; write movies and a figure."""
    from ..demo import run_demo
    from ..hydro.rft import rft_summary
    from ..params import Params

    out = rft_summary(Params())
    click.echo(f"Paper's filament: R = {out['radius']:.3f} µm, L0 = {out['axial_length']:.2f} µm, "
               f"rigid-helix thrust/torque {out['pinned']['thrust_per_torque']:.3f} /µm (pinned)")
    res = run_demo(out_dir, progress=None if not as_json else False, size=movie_size)
    if as_json:
        emit_json(res)
