"""Export a trajectory to ParaView (``flagellum export run.h5 --format vtk --output DIR``).

Written with plain Python (no VTK library needed). For every exported record ``k``:

* ``frame_KKKKK.vtk`` — legacy VTK ASCII ``POLYDATA``: the N + 1 beads as points, one
  polyline through them (``LINES``), and point data ``arc_length`` [µm], ``curvature``
  [1/µm] (discrete, as in :func:`flagellum.viz.curvature`), ``material_angle`` [rad]
  (the twist angle θ of the bond ending at the bead; 0 at bead 0) and ``tangent`` (unit
  bond tangents, vectors); the time is stored as the field ``TIME``.
* ``frame_KKKKK.vtp`` — the same polydata in VTK's XML format (ASCII).

and two time-series indexes that ParaView opens as one animated data set:

* ``<stem>.pvd`` — the XML ``Collection`` file with ``timestep`` = simulated time [s],
  pointing at the ``.vtp`` files (ParaView's PVD reader only reads XML data files);
* ``<stem>.vtk.series`` — ParaView's JSON file-series index for the legacy ``.vtk`` files.

:func:`read_legacy_vtk` reads the legacy files back (used by the tests; ``meshio`` reads
them too).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .errors import ParameterError

FORMATS = ("vtk",)


def _fmt(values: np.ndarray) -> str:
    return "\n".join(" ".join(f"{v:.9g}" for v in row) for row in np.atleast_2d(values))


def frame_fields(positions: np.ndarray, angles: np.ndarray | None = None) -> dict:
    """Point data of one configuration (n+1, 3): arc length, curvature, material angle, tangent."""
    from .viz import curvature

    pos = np.asarray(positions, float)
    bonds = np.diff(pos, axis=0)
    h = np.linalg.norm(bonds, axis=1)
    t = bonds / np.where(h > 0, h, 1.0)[:, None]
    tangent = np.vstack([t[:1], t])  # bead i carries the tangent of bond i (bead 0: bond 1)
    s = np.concatenate([[0.0], np.cumsum(h)])
    theta = np.zeros(len(pos)) if angles is None else np.asarray(angles, float).reshape(-1)
    if len(theta) != len(pos):
        theta = np.zeros(len(pos))
    return {"arc_length": s, "curvature": curvature(pos) if len(pos) > 2 else np.zeros(len(pos)),
            "material_angle": theta, "tangent": tangent}


def legacy_vtk_text(positions: np.ndarray, fields: dict, time: float, title: str = "flagellum") -> str:
    """Legacy VTK ASCII polydata: points, one polyline, point data, the time as field data."""
    pos = np.asarray(positions, float)
    n = len(pos)
    title = " ".join(str(title).split())[:200] or "flagellum"
    out = ["# vtk DataFile Version 3.0", title, "ASCII", "DATASET POLYDATA",
           "FIELD FieldData 1", "TIME 1 1 double", f"{time:.12g}",
           f"POINTS {n} double", _fmt(pos),
           f"LINES 1 {n + 1}", " ".join(map(str, [n, *range(n)])),
           f"POINT_DATA {n}"]
    for name, val in fields.items():
        val = np.asarray(val, float)
        if val.ndim == 2:
            out += [f"VECTORS {name} double", _fmt(val)]
        else:
            out += [f"SCALARS {name} double 1", "LOOKUP_TABLE default", _fmt(val[:, None])]
    return "\n".join(out) + "\n"


def xml_vtp_text(positions: np.ndarray, fields: dict, time: float) -> str:
    """The same polydata as a VTK XML (``.vtp``) ASCII file."""
    pos = np.asarray(positions, float)
    n = len(pos)

    def arr(name, val, ncomp=1):
        flat = " ".join(f"{v:.9g}" for v in np.asarray(val, float).ravel())
        return (f'        <DataArray type="Float64" Name={quoteattr(name)} '
                f'NumberOfComponents="{ncomp}" format="ascii">{flat}</DataArray>')

    pdata = "\n".join(arr(k, v, 3 if np.ndim(v) == 2 else 1) for k, v in fields.items())
    return "\n".join([
        '<?xml version="1.0"?>',
        '<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian">',
        "  <PolyData>",
        "    <FieldData>",
        f'      <DataArray type="Float64" Name="TIME" NumberOfTuples="1" format="ascii">{time:.12g}</DataArray>',
        "    </FieldData>",
        f'    <Piece NumberOfPoints="{n}" NumberOfVerts="0" NumberOfLines="1" NumberOfStrips="0" NumberOfPolys="0">',
        "      <Points>", arr("Points", pos, 3), "      </Points>",
        '      <PointData Scalars="curvature" Vectors="tangent">', pdata, "      </PointData>",
        "      <Lines>",
        f'        <DataArray type="Int64" Name="connectivity" format="ascii">{" ".join(map(str, range(n)))}</DataArray>',
        f'        <DataArray type="Int64" Name="offsets" format="ascii">{n}</DataArray>',
        "      </Lines>",
        "    </Piece>",
        "  </PolyData>",
        "</VTKFile>", ""])


def pvd_text(entries: list[tuple[float, str]]) -> str:
    rows = "\n".join(f'    <DataSet timestep="{t:.12g}" group="" part="0" file={quoteattr(f)}/>'
                     for t, f in entries)
    return ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
            f'byte_order="LittleEndian">\n  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n')


def export_vtk(t: np.ndarray, positions: np.ndarray, out_dir: str | Path, *,
               angles: np.ndarray | None = None, every: int = 1, stem: str = "flagellum",
               title: str = "flagellum") -> dict:
    """Write one ``.vtk`` and one ``.vtp`` file per exported record plus the indexes.

    Parameters
    ----------
    t : times [s], shape (n_t,).
    positions : bead positions [µm], shape (n_t, N+1, 3).
    out_dir : output directory (created).
    angles : material angles, shape (n_t, N+1) (optional point data).
    every : export every ``every``-th record (the last record is always included).

    Returns
    -------
    dict with ``frames`` (count), ``points`` (per frame), ``vtk`` and ``vtp`` (lists of
    paths), ``pvd`` and ``series`` (index paths).
    """
    from .io import atomic_write_text

    t = np.asarray(t, float)
    positions = np.asarray(positions, float)
    if positions.ndim != 3 or positions.shape[-1] != 3 or len(positions) != len(t) or len(t) == 0:
        raise ParameterError("positions", getattr(positions, "shape", None),
                             "an array (n_t ≥ 1, N+1, 3) matching the times")
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ParameterError("every", every, "an integer ≥ 1")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    idx = list(range(0, len(t), int(every)))
    if idx[-1] != len(t) - 1:
        idx.append(len(t) - 1)
    width = max(5, len(str(len(t) - 1)))
    vtk_files, vtp_files, pvd_entries, series = [], [], [], []
    for k in idx:
        fields = frame_fields(positions[k], None if angles is None else np.asarray(angles)[k])
        name = f"frame_{k:0{width}d}"
        p_vtk, p_vtp = out / f"{name}.vtk", out / f"{name}.vtp"
        atomic_write_text(p_vtk, legacy_vtk_text(positions[k], fields, float(t[k]),
                                                 f"{title} t = {t[k]:.9g} s"))
        atomic_write_text(p_vtp, xml_vtp_text(positions[k], fields, float(t[k])))
        vtk_files.append(p_vtk)
        vtp_files.append(p_vtp)
        pvd_entries.append((float(t[k]), p_vtp.name))
        series.append({"name": p_vtk.name, "time": float(t[k])})
    pvd = out / f"{stem}.pvd"
    atomic_write_text(pvd, pvd_text(pvd_entries))
    ser = out / f"{stem}.vtk.series"
    atomic_write_text(ser, json.dumps({"file-series-version": "1.0", "files": series}, indent=1))
    return {"frames": len(idx), "points": int(positions.shape[1]), "vtk": vtk_files,
            "vtp": vtp_files, "pvd": pvd, "series": ser}


def export_trajectory(path: str | Path, out_dir: str | Path, fmt: str = "vtk",
                      every: int = 1) -> dict:
    """Export an HDF5 trajectory file (``flagellum simulate -o``) for ParaView."""
    from .io import read_trajectory

    if fmt not in FORMATS:
        raise ParameterError("format", fmt, "one of " + ", ".join(FORMATS))
    path = Path(path)
    if not path.is_file():
        raise ParameterError("file", str(path), "an existing flagellum HDF5 trajectory file")
    data = read_trajectory(path)
    if "positions" not in data or len(data.get("t", [])) == 0:
        raise ParameterError("file", str(path), "a trajectory file with at least one record")
    return export_vtk(data["t"], data["positions"], out_dir, angles=data.get("angles"),
                      every=every, stem=path.stem, title=f"flagellum {path.name}")


# -- reading back ---------------------------------------------------------------------------
def read_legacy_vtk(path: str | Path) -> dict:
    """Parse an ASCII legacy VTK polydata file written by :func:`legacy_vtk_text`.

    Returns ``points`` (n, 3), ``lines`` (list of index arrays), ``point_data`` (name →
    array) and ``field_data`` (name → array).
    """
    tokens_lines = Path(path).read_text().splitlines()
    if not tokens_lines or not tokens_lines[0].startswith("# vtk DataFile"):
        raise ValueError(f"{path}: not a legacy VTK file")
    if tokens_lines[2].strip() != "ASCII":
        raise ValueError(f"{path}: only ASCII legacy files are supported")
    toks = " ".join(tokens_lines[3:]).split()
    i = 0
    out = {"points": None, "lines": [], "point_data": {}, "field_data": {}}
    n_points = 0

    def take(k):
        nonlocal i
        vals = toks[i:i + k]
        i += k
        return vals

    while i < len(toks):
        key = toks[i].upper()
        i += 1
        if key == "DATASET":
            take(1)
        elif key == "FIELD":
            _, n_arr = take(2)
            for _ in range(int(n_arr)):
                name, ncomp, ntup, _dtype = take(4)
                vals = np.array(take(int(ncomp) * int(ntup)), float)
                out["field_data"][name] = vals.reshape(int(ntup), int(ncomp)).squeeze()
        elif key == "POINTS":
            n_points, _dtype = int(toks[i]), toks[i + 1]
            i += 2
            out["points"] = np.array(take(3 * n_points), float).reshape(n_points, 3)
        elif key == "LINES":
            n_cells, size = int(toks[i]), int(toks[i + 1])
            i += 2
            flat = list(map(int, take(size)))
            j = 0
            for _ in range(n_cells):
                m = flat[j]
                out["lines"].append(np.array(flat[j + 1:j + 1 + m]))
                j += 1 + m
        elif key == "POINT_DATA":
            take(1)
        elif key == "SCALARS":
            name, _dtype = take(2)
            ncomp = 1
            if i < len(toks) and toks[i].isdigit():
                ncomp = int(take(1)[0])
            if i < len(toks) and toks[i].upper() == "LOOKUP_TABLE":
                take(2)
            vals = np.array(take(ncomp * n_points), float)
            out["point_data"][name] = vals if ncomp == 1 else vals.reshape(n_points, ncomp)
        elif key == "VECTORS":
            name, _dtype = take(2)
            out["point_data"][name] = np.array(take(3 * n_points), float).reshape(n_points, 3)
        else:
            raise ValueError(f"{path}: unexpected keyword {key!r}")
    if out["points"] is None or not math.isfinite(float(np.sum(out["points"]))):
        raise ValueError(f"{path}: no valid POINTS section")
    return out


__all__ = ["export_vtk", "export_trajectory", "read_legacy_vtk", "legacy_vtk_text",
           "xml_vtp_text", "frame_fields", "FORMATS"]
