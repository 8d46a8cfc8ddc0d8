"""``flagellum render``: movies and snapshots of a trajectory file."""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import ParameterError
from ._options import existing_file
from ._output import emit_json, emit_table


def _title(data) -> str:
    """Torque and regime of the run (of its last half, as ``Trajectory.summary()``: a run
    that has not settled says ``transient``)."""
    from ..trajectory import Trajectory

    parts = []
    if len(data["torque"]):
        parts.append(f"M = {float(data['torque'][-1]):g} pN·µm")
    if data["attrs"].get("helix_radius") is not None and len(data["t"]) >= 2:
        parts.append(Trajectory.from_records(data, data["attrs"]).summary().regime)
    return " · ".join(parts)


def _extras(data, keep) -> dict:
    """The segments' forms of a polymorphic run and the cell body of a whole-cell run."""
    import json

    from ..io import POLYMORPH_ATTR

    out = {}
    attrs = data["attrs"]
    if data.get("polymorph") is not None and attrs.get(POLYMORPH_ATTR):
        out.update(polymorph=data["polymorph"][keep], forms=str(attrs[POLYMORPH_ATTR]).split(","))
    boundary = json.loads(str(attrs.get("boundary", "{}")) or "{}")
    if boundary.get("body_radius") and data.get("body_position") is not None:
        out["body"] = {"position": data["body_position"][keep], "axis": data["body_axis"][keep],
                       "radius": float(boundary["body_radius"]),
                       "aspect": float(boundary.get("body_aspect") or 1.0)}
    return out


@click.command("render", short_help="Movie and snapshots of a trajectory file")
@click.argument("file")
@click.option("--movie", type=click.Path(dir_okay=False), default=None,
              help="write an MP4 movie here (and its last frame as a PNG poster next to it)")
@click.option("--snapshots", type=click.Path(file_okay=False), default=None,
              help="write PNG snapshots into this directory")
@click.option("--frames", type=int, default=200, show_default=True, help="largest number of movie frames")
@click.option("--fps", type=int, default=20, show_default=True, help="movie frames per second")
@click.option("--count", type=int, default=4, show_default=True, help="number of snapshots")
@click.option("--view", type=click.Choice(["lab", "corotating"]), default="lab", show_default=True,
              help="lab frame, or co-rotating (the rigid rotation about the anchor removed)")
@click.option("--size", type=click.Choice(["720p", "1080p"]), default="720p", show_default=True,
              help="frame size: 1280×720 or 1920×1080")
@click.option("--start", type=float, default=None, help="first time to show [s] (default: the first record)")
@click.option("--end", type=float, default=None, help="last time to show [s] (default: the last record)")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def render(file, movie, snapshots, frames, fps, count, view, size, start, end, as_json):
    """Render a trajectory file (flagellum simulate -o run.h5) as a movie and/or snapshots.

    In the lab view the motor's rotation (a revolution every few ms) reads only when the
    frames are a fraction of a revolution apart: the title says how many frames fall on one
    revolution; a short --save-every in simulate and a short --start/--end window give
    more. The co-rotating view removes the rotation and shows the change of shape.
    A polymorphic run's segments are coloured by form; a cell body is drawn (lab view).
    """
    import numpy as np

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
    for name, val in (("start", start), ("end", end)):
        if val is not None and not np.isfinite(val):
            raise ParameterError(name, val, "a finite time [s]")
    data = read_trajectory(path)
    if len(data.get("t", [])) == 0:
        raise ParameterError("file", str(path), "a trajectory file with at least one record")
    t = data["t"]
    keep = np.ones(len(t), bool)
    if start is not None:
        keep &= t >= start
    if end is not None:
        keep &= t <= end
    if not keep.any():
        raise ParameterError("start", start, f"a window [--start, --end] holding records of "
                                             f"t in [{t[0]:g}, {t[-1]:g}] s")
    title = _title(data)
    rec = {k: data[k][keep] for k in ("t", "positions", "thrust", "motor_speed")}
    args = dict(title=title, view=view, size=size, thrust=rec["thrust"], motor_speed=rec["motor_speed"],
                **_extras(data, keep))
    out = {"file": str(path), "records": int(len(t)), "view": view, "size": size}
    if movie is not None:
        out["movie"] = str(movie)
        out["poster"] = str(Path(movie).with_suffix(".png"))
        out["frames"] = write_movie(rec["t"], rec["positions"], movie, fps=fps, max_frames=frames, **args)
    if snapshots is not None:
        out["snapshots"] = [str(p) for p in write_snapshots(rec["t"], rec["positions"], snapshots,
                                                            min(count, len(rec["t"])),
                                                            first_record=int(np.argmax(keep)), **args)]
    if as_json:
        emit_json(out)
    else:
        emit_table({k: (", ".join(v) if isinstance(v, list) else v) for k, v in out.items()},
                   "flagellum render")
