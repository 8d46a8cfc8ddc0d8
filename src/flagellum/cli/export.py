"""``flagellum export``: a trajectory file for ParaView."""

from __future__ import annotations

import click

from ._options import existing_file, output_option
from ._output import emit_json, emit_table


@click.command("export", short_help='Export a trajectory file for ParaView')
@click.argument("file")
@click.option("--format", "fmt", default="vtk", show_default=True,
              help="vtk: one binary VTK XML polydata file (.vtp) per record and a .pvd collection "
                   "(needs the vtk package)")
@output_option("out_dir", "output directory", directory=True, required=True)
@click.option("--every", type=int, default=1, show_default=True, help="export every K-th record")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def export(file, fmt, out_dir, every, as_json):
    """Export a trajectory file for ParaView (open DIR/<name>.pvd)."""
    from ..export import export_trajectory

    res = export_trajectory(existing_file(file), out_dir, fmt, every)
    out = {"file": str(file), "format": fmt, "out": str(out_dir), "frames": res["frames"],
           "points_per_frame": res["points"], "pvd": str(res["pvd"])}
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "flagellum export")
