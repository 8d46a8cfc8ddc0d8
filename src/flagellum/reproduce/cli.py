"""CLI commands ``flagellum reproduce``, ``flagellum render`` and ``flagellum export``
(registered by :mod:`flagellum.cli` from :data:`COMMANDS`)."""

from __future__ import annotations

from pathlib import Path

import click

from ..cli import emit_json, emit_table
from ..errors import ParameterError


@click.command("reproduce")
@click.argument("figure")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="flagellum-reproduce",
              show_default=True, help="output directory (one subdirectory per figure)")
@click.option("--quality", default="quick", show_default=True,
              help="quick (CI-size runs) or full (publication quality)")
@click.option("--json", "as_json", is_flag=True, help="print the headline numbers as JSON")
def reproduce(figure, out_dir, quality, as_json):
    """Reproduce a figure of the paper: fig3, fig4, fig5, fig6, fig7, fig8 or all.

    Writes DIR/FIG/FIG.png and .pdf, the data (CSV, HDF5) and comparison.md (the paper's
    numbers next to ours).
    """
    from . import reproduce as run_target

    echo = None if as_json else (lambda msg: click.echo(msg, err=True))
    res = run_target(figure.lower(), out_dir, quality, echo=echo)
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


def _existing(path: str) -> Path:
    p = Path(path)
    if not p.is_file():
        raise ParameterError("file", path, "an existing flagellum HDF5 trajectory file")
    return p


@click.command("render")
@click.argument("file")
@click.option("--movie", type=click.Path(dir_okay=False), default=None, help="write an MP4 movie here")
@click.option("--snapshots", type=click.Path(file_okay=False), default=None,
              help="write PNG snapshots into this directory")
@click.option("--frames", type=int, default=200, show_default=True, help="largest number of movie frames")
@click.option("--fps", type=int, default=20, show_default=True, help="movie frames per second")
@click.option("--count", type=int, default=4, show_default=True, help="number of snapshots")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def render(file, movie, snapshots, frames, fps, count, as_json):
    """Render a trajectory file (flagellum simulate -o run.h5) as a movie and/or snapshots."""
    from .. import viz
    from ..io import read_trajectory

    path = _existing(file)
    if movie is None and snapshots is None:
        raise ParameterError("movie", None, "given: --movie OUT.mp4 and/or --snapshots DIR")
    for name, val, lo in (("frames", frames, 1), ("fps", fps, 1), ("count", count, 1)):
        if val < lo or val > 100000:
            raise ParameterError(name, val, f"an integer in [{lo}, 100000]")
    if movie is not None and Path(movie).suffix.lower() != ".mp4":
        raise ParameterError("movie", movie, "a file name ending in .mp4")
    data = read_trajectory(path)
    if len(data.get("t", [])) == 0:
        raise ParameterError("file", str(path), "a trajectory file with at least one record")
    t, pos = data["t"], data["positions"]
    title = f"M = {float(data['torque'][-1]):g} pN·µm" if "torque" in data and len(data["torque"]) else ""
    out = {"file": str(path), "records": int(len(t))}
    if movie is not None:
        out["movie"] = str(movie)
        out["frames"] = viz.movie(t, pos, movie, fps=fps, max_frames=frames, title=title)
    if snapshots is not None:
        out["snapshots"] = [str(p) for p in viz.snapshots(t, pos, snapshots, min(count, len(t)), title=title)]
    if as_json:
        emit_json(out)
    else:
        emit_table({k: (", ".join(v) if isinstance(v, list) else v) for k, v in out.items()},
                   "flagellum render")


@click.command("export")
@click.argument("file")
@click.option("--format", "fmt", default="vtk", show_default=True,
              help="vtk: legacy .vtk + XML .vtp polydata per record, a .pvd collection and a .vtk.series index")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), required=True, help="output directory")
@click.option("--every", type=int, default=1, show_default=True, help="export every K-th record")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def export(file, fmt, out_dir, every, as_json):
    """Export a trajectory file for ParaView (open DIR/<name>.pvd or DIR/<name>.vtk.series)."""
    from ..export import export_trajectory

    res = export_trajectory(_existing(file), out_dir, fmt, every)
    out = {"file": str(file), "format": fmt, "out": str(out_dir), "frames": res["frames"],
           "points_per_frame": res["points"], "pvd": str(res["pvd"]), "series": str(res["series"])}
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "flagellum export")


COMMANDS = [reproduce, render, export]
