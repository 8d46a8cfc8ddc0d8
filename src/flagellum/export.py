"""Export a trajectory to ParaView (``flagellum export run.h5 --format vtk --output DIR``).

Written by VTK's own XML writer (the optional ``vtk`` package, ``pip install vtk``). For
every exported record ``k``:

* ``frame_KKKKK.vtp`` — VTK XML PolyData, binary (zlib-compressed raw appended data,
  32-bit headers: file format version 0.1): the N + 1 beads as points, one polyline through
  them, point data ``arc_length`` [µm], ``curvature`` [1/µm] (discrete, as in
  :func:`flagellum.viz.curvature`), ``material_angle`` [rad] (the twist angle θ of the bond
  ending at the bead; 0 at bead 0) and ``tangent`` (unit bond tangents, vectors); the time
  [s] as the field ``TIME``;

and the index ``<stem>.pvd``, a ParaView collection with ``timestep`` = simulated time [s]
over those files, which ParaView opens as one animated data set.
"""

from __future__ import annotations

import contextlib
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .errors import ParameterError

FORMATS = ("vtk",)


def _vtk():
    """VTK's data model, XML writer and numpy bridge (a missing ``vtk`` names the package)."""
    try:
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
        from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter
    except ModuleNotFoundError as exc:
        raise ModuleNotFoundError(f"the ParaView export needs the vtk package ({exc})",
                                  name="vtk") from exc
    return numpy_to_vtk, vtkPoints, vtkCellArray, vtkPolyData, vtkXMLPolyDataWriter


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


def polydata(positions: np.ndarray, fields: dict, time: float):
    """One configuration as a ``vtkPolyData``: the beads, one polyline, point data ``fields``
    (name → (n,) or (n, 3)), the time as the field data ``TIME``."""
    numpy_to_vtk, vtkPoints, vtkCellArray, vtkPolyData, _ = _vtk()
    pos = np.ascontiguousarray(positions, float)
    out = vtkPolyData()
    points = vtkPoints()
    points.SetData(numpy_to_vtk(pos, deep=True))
    out.SetPoints(points)
    line = vtkCellArray()
    line.InsertNextCell(len(pos))
    for i in range(len(pos)):
        line.InsertCellPoint(i)
    out.SetLines(line)
    for name, values in fields.items():
        arr = numpy_to_vtk(np.ascontiguousarray(values, float), deep=True)
        arr.SetName(name)
        out.GetPointData().AddArray(arr)
    out.GetPointData().SetActiveScalars("curvature")
    out.GetPointData().SetActiveVectors("tangent")
    t = numpy_to_vtk(np.array([float(time)]), deep=True)
    t.SetName("TIME")
    out.GetFieldData().AddArray(t)
    return out


def write_vtp(path: str | Path, data) -> None:
    """Write ``data`` (a ``vtkPolyData``) to ``path`` atomically as binary VTK XML."""
    from .io import atomic_path

    *_, vtkXMLPolyDataWriter = _vtk()
    with atomic_path(path) as tmp:
        writer = vtkXMLPolyDataWriter()
        writer.SetFileName(str(tmp))
        writer.SetInputData(data)
        writer.SetDataModeToAppended()
        writer.EncodeAppendedDataOff()  # raw bytes, not base64
        writer.SetCompressorTypeToZLib()
        writer.SetHeaderTypeToUInt32()  # file version 0.1: read by old and new ParaView alike
        if writer.Write() != 1:
            raise OSError(f"VTK could not write {path}")


def pvd_text(entries: list[tuple[float, str]]) -> str:
    """A ParaView collection (``.pvd``) over ``entries`` of (time [s], file name)."""
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for t, name in entries:
        ET.SubElement(coll, "DataSet", timestep=f"{t:.17g}", group="", part="0", file=name)
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def export_vtk(t: np.ndarray, positions: np.ndarray, out_dir: str | Path, *,
               angles: np.ndarray | None = None, every: int = 1, stem: str = "flagellum") -> dict:
    """Write one ``.vtp`` file per exported record and the ``.pvd`` index.

    Parameters
    ----------
    t : times [s], shape (n_t,).
    positions : bead positions [µm], shape (n_t, N+1, 3).
    out_dir : output directory (created).
    angles : material angles, shape (n_t, N+1) (optional point data).
    every : export every ``every``-th record (the last record is always included).

    Returns
    -------
    dict with ``frames`` (count), ``points`` (per frame), ``vtp`` (list of paths) and
    ``pvd`` (the index). A failed write removes the frames and the folders this call wrote.
    """
    from .io import atomic_write_text

    t = np.asarray(t, float)
    positions = np.asarray(positions, float)
    if positions.ndim != 3 or positions.shape[-1] != 3 or len(positions) != len(t) or len(t) == 0:
        raise ParameterError("positions", getattr(positions, "shape", None),
                             "an array (n_t ≥ 1, N+1, 3) matching the times")
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ParameterError("every", every, "an integer ≥ 1")
    _vtk()  # a missing vtk fails before anything is written
    out = Path(out_dir)
    created = [p for p in (out, *out.parents) if not p.exists()]  # removed again on failure
    out.mkdir(parents=True, exist_ok=True)
    idx = list(range(0, len(t), int(every)))
    if idx[-1] != len(t) - 1:
        idx.append(len(t) - 1)
    width = max(5, len(str(len(t) - 1)))
    files = []
    try:
        for k in idx:
            fields = frame_fields(positions[k], None if angles is None else np.asarray(angles)[k])
            path = out / f"frame_{k:0{width}d}.vtp"
            write_vtp(path, polydata(positions[k], fields, float(t[k])))
            files.append(path)
        pvd = out / f"{stem}.pvd"
        atomic_write_text(pvd, pvd_text([(float(t[k]), p.name) for k, p in zip(idx, files)]))
    except BaseException:
        for p in files:
            p.unlink(missing_ok=True)
        for d in created:  # innermost first; only folders this call made and left empty
            with contextlib.suppress(OSError):
                d.rmdir()
        raise
    return {"frames": len(idx), "points": int(positions.shape[1]), "vtp": files, "pvd": pvd}


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
                      every=every, stem=path.stem)


__all__ = ["FORMATS", "export_trajectory", "export_vtk", "frame_fields", "polydata", "pvd_text",
           "write_vtp"]
