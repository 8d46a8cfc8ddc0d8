"""render / export: movie frame count, ParaView (VTK) export read back with VTK, CLI errors."""

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import assert_one_line_error

from flagellum import Filament, Params
from flagellum.cli import run
from flagellum.export import export_trajectory, export_vtk
from flagellum.motor import Motor
from flagellum.simulator import Simulator


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    """A tiny simulation (L = 2 µm, 0.005 s) written to HDF5: 11 beads, 26 records."""
    path = tmp_path_factory.mktemp("run") / "run.h5"
    sim = Simulator(Params(Filament(length=2.0)), Motor(0.5))
    sim.run(0.005, save_every=2e-4, output=path, progress=False)
    return path


def _one_line_exit_2(args, capsys):
    code = run(args)
    err = capsys.readouterr().err
    assert_one_line_error(code, err)
    return err


def test_movie_has_the_right_frame_count(run_file, tmp_path, capsys):
    import imageio.v2 as imageio

    mp4 = tmp_path / "out.mp4"
    snaps = tmp_path / "snaps"
    assert run(["render", str(run_file), "--movie", str(mp4), "--frames", "12",
                "--snapshots", str(snaps), "--count", "3", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["records"] == 26 and out["frames"] == 12
    reader = imageio.get_reader(str(mp4), format="FFMPEG")
    n = sum(1 for _ in reader)
    reader.close()
    assert n == 12
    pngs = sorted(snaps.glob("*.png"))
    assert len(pngs) == 3 and all(p.stat().st_size > 5000 for p in pngs)


def test_movie_frames_capped_by_records(run_file, tmp_path, capsys):
    assert run(["render", str(run_file), "--movie", str(tmp_path / "m.mp4"), "--frames", "500",
                "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["frames"] == 26


def _read_vtp(path):
    """Points, polylines, point data and TIME of a ``.vtp`` file, read by VTK's own reader."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    r = vtkXMLPolyDataReader()
    r.SetFileName(str(path))
    r.Update()
    out = r.GetOutput()
    pd = out.GetPointData()
    lines = out.GetLines()
    return {"points": vtk_to_numpy(out.GetPoints().GetData()),
            "lines": np.split(vtk_to_numpy(lines.GetConnectivityArray()),
                              vtk_to_numpy(lines.GetOffsetsArray())[1:-1]),
            "point_data": {pd.GetArrayName(i): vtk_to_numpy(pd.GetArray(i))
                           for i in range(pd.GetNumberOfArrays())},
            "TIME": vtk_to_numpy(out.GetFieldData().GetArray("TIME"))}


def test_vtk_export_reads_back(run_file, tmp_path, capsys):
    """Binary VTK XML files, one per exported record and no other, read back with VTK
    give the positions, the polyline and the point data."""
    pytest.importorskip("vtkmodules.vtkIOXML")
    from flagellum.io import read_trajectory

    data = read_trajectory(run_file)
    assert run(["export", str(run_file), "--format", "vtk", "--out", str(tmp_path / "vtk"),
                "--every", "5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["frames"] == 6 and out["points_per_frame"] == 11  # records 0, 5, …, 25
    files = sorted((tmp_path / "vtk").glob("frame_*"))
    assert [f.suffix for f in files] == [".vtp"] * 6  # each frame once
    written = sorted(p.name for p in (tmp_path / "vtk").iterdir())
    assert written == sorted([*(f.name for f in files), "run.pvd"])
    for f in files:
        k = int(f.stem.split("_")[1])
        head = f.read_bytes()[:400].decode("latin-1")
        assert 'format="appended"' in head and "vtkZLibDataCompressor" in head  # binary, compressed
        d = _read_vtp(f)
        assert d["points"].shape == (11, 3)
        np.testing.assert_array_equal(d["points"], data["positions"][k])
        assert len(d["lines"]) == 1 and list(d["lines"][0]) == list(range(11))
        assert d["TIME"][0] == data["t"][k]
        assert set(d["point_data"]) == {"arc_length", "curvature", "material_angle", "tangent"}
        assert d["point_data"]["arc_length"][-1] == pytest.approx(2.0, rel=0.02)
        assert d["point_data"]["tangent"].shape == (11, 3)
        np.testing.assert_array_equal(d["point_data"]["material_angle"], data["angles"][k])
    pvd = ET.parse(tmp_path / "vtk" / "run.pvd").getroot()
    ds = pvd.findall("Collection/DataSet")
    assert [d.get("file") for d in ds] == [f.name for f in files]
    assert [float(d.get("timestep")) for d in ds] == list(data["t"][[0, 5, 10, 15, 20, 25]])


def test_export_vtk_function_and_last_record_always_included(tmp_path):
    pytest.importorskip("vtkmodules.vtkIOXML")
    t = np.linspace(0, 1, 7)
    pos = np.zeros((7, 4, 3))
    pos[:, :, 2] = np.arange(4) * 0.2
    res = export_vtk(t, pos, tmp_path, every=4)
    assert res["frames"] == 3  # records 0, 4 and the last one (6)
    assert _read_vtp(res["vtp"][-1])["TIME"][0] == 1.0
    assert np.all(_read_vtp(res["vtp"][0])["point_data"]["curvature"] == 0)


def test_export_without_vtk_is_one_line_naming_it(run_file, tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "vtkmodules.vtkIOXML", None)
    err = _one_line_exit_2(["export", str(run_file), "--out", str(tmp_path / "o")], capsys)
    assert "needs the package 'vtk'" in err
    assert not (tmp_path / "o").exists()


def test_a_failed_export_leaves_no_frames(run_file, tmp_path, monkeypatch):
    pytest.importorskip("vtkmodules.vtkIOXML")
    import flagellum.export as ex

    real, calls = ex.write_vtp, []

    def fail_third(path, data):
        calls.append(path)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        real(path, data)

    monkeypatch.setattr(ex, "write_vtp", fail_third)
    with pytest.raises(OSError):
        export_trajectory(run_file, tmp_path / "o" / "p", "vtk", every=5)
    assert not (tmp_path / "o").exists()  # neither frames nor the folders it made
    (tmp_path / "kept").mkdir()
    calls.clear()
    with pytest.raises(OSError):
        export_trajectory(run_file, tmp_path / "kept", "vtk", every=5)
    assert list((tmp_path / "kept").iterdir()) == []  # a folder that was there stays


@pytest.mark.parametrize("args", [
    ["render", "/nonexistent/run.h5", "--movie", "x.mp4"],
    ["export", "/nonexistent/run.h5", "--format", "vtk", "--out", "x"],
])
def test_missing_file_exits_2_with_one_line(args, capsys):
    err = _one_line_exit_2(args, capsys)
    assert "file" in err


def test_bad_arguments_exit_2(run_file, tmp_path, capsys):
    _one_line_exit_2(["render", str(run_file)], capsys)  # neither --movie nor --snapshots
    _one_line_exit_2(["render", str(run_file), "--movie", str(tmp_path / "m.gif")], capsys)
    _one_line_exit_2(["render", str(run_file), "--snapshots", str(tmp_path), "--count", "0"], capsys)
    _one_line_exit_2(["export", str(run_file), "--format", "xdmf", "--out", str(tmp_path)], capsys)
    _one_line_exit_2(["export", str(run_file), "--out", str(tmp_path), "--every", "0"], capsys)
    not_h5 = tmp_path / "junk.h5"
    not_h5.write_text("not hdf5")
    _one_line_exit_2(["export", str(not_h5), "--out", str(tmp_path / "o")], capsys)
    _one_line_exit_2(["render", str(not_h5), "--movie", str(tmp_path / "m.mp4")], capsys)
