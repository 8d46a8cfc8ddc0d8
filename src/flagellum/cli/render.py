"""``flagellum render``: movies and snapshots of a trajectory file."""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import ParameterError
from ._options import existing_file
from ._output import emit_json, emit_table


@click.command("render", short_help='Movie and snapshots of a trajectory file')
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
    from ..io import read_trajectory
    from ..viz import movie as write_movie, snapshots as write_snapshots

    path = existing_file(file)
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
        out["frames"] = write_movie(t, pos, movie, fps=fps, max_frames=frames, title=title)
    if snapshots is not None:
        out["snapshots"] = [str(p) for p in write_snapshots(t, pos, snapshots, min(count, len(t)), title=title)]
    if as_json:
        emit_json(out)
    else:
        emit_table({k: (", ".join(v) if isinstance(v, list) else v) for k, v in out.items()},
                   "flagellum render")
