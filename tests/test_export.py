"""render / export: movie frame count, ParaView (VTK) export read back, CLI errors."""

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import assert_one_line_error

from flagellum import Filament, Params
from flagellum.cli import run
from flagellum.export import export_trajectory, export_vtk, read_legacy_vtk
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


def test_vtk_export_reads_back(run_file, tmp_path, capsys):
    from flagellum.io import read_trajectory

    data = read_trajectory(run_file)
    assert run(["export", str(run_file), "--format", "vtk", "--out", str(tmp_path / "vtk"),
                "--every", "5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["frames"] == 6 and out["points_per_frame"] == 11  # records 0, 5, …, 25
    files = sorted((tmp_path / "vtk").glob("frame_*.vtk"))
    assert len(files) == 6
    for f in files:
        k = int(f.stem.split("_")[1])
        d = read_legacy_vtk(f)
        assert d["points"].shape == (11, 3)
        np.testing.assert_allclose(d["points"], data["positions"][k], rtol=1e-8, atol=1e-12)
        assert len(d["lines"]) == 1 and list(d["lines"][0]) == list(range(11))
        assert d["field_data"]["TIME"] == pytest.approx(data["t"][k], rel=1e-10, abs=1e-15)
        assert set(d["point_data"]) == {"arc_length", "curvature", "material_angle", "tangent"}
        assert d["point_data"]["arc_length"][-1] == pytest.approx(2.0, rel=0.02)
        np.testing.assert_allclose(d["point_data"]["material_angle"], data["angles"][k], atol=1e-8)
        # the XML twin
        root = ET.parse(f.with_suffix(".vtp")).getroot()
        piece = root.find("PolyData/Piece")
        assert piece.get("NumberOfPoints") == "11"
        pts = np.array(piece.find("Points/DataArray").text.split(), float).reshape(-1, 3)
        np.testing.assert_allclose(pts, data["positions"][k], rtol=1e-8, atol=1e-12)
    # the indexes: PVD (XML files) and the .vtk.series (legacy files)
    pvd = ET.parse(tmp_path / "vtk" / "run.pvd").getroot()
    ds = pvd.findall("Collection/DataSet")
    assert [d.get("file") for d in ds] == [f.with_suffix(".vtp").name for f in files]
    assert float(ds[-1].get("timestep")) == pytest.approx(data["t"][-1])
    series = json.loads((tmp_path / "vtk" / "run.vtk.series").read_text())
    assert [e["name"] for e in series["files"]] == [f.name for f in files]


def test_vtk_export_reads_back_with_vtk(run_file, tmp_path):
    """VTK's own readers (legacy and XML), when the ``vtk`` package is installed (meshio 5.3
    cannot be used: it does not read legacy POLYDATA)."""
    vtk = pytest.importorskip("vtk")
    res = export_trajectory(run_file, tmp_path, "vtk", every=10)
    for f_vtk, f_vtp in zip(res["vtk"], res["vtp"]):
        r = vtk.vtkPolyDataReader()
        r.SetFileName(str(f_vtk))
        r.ReadAllScalarsOn()
        r.ReadAllVectorsOn()
        r.ReadAllFieldsOn()
        r.Update()
        x = vtk.vtkXMLPolyDataReader()
        x.SetFileName(str(f_vtp))
        x.Update()
        for out in (r.GetOutput(), x.GetOutput()):
            assert out.GetNumberOfPoints() == 11 and out.GetNumberOfLines() == 1
            assert out.GetPointData().GetArray("curvature") is not None
            assert out.GetFieldData().GetArray("TIME") is not None


def test_export_vtk_function_and_last_record_always_included(tmp_path):
    t = np.linspace(0, 1, 7)
    pos = np.zeros((7, 4, 3))
    pos[:, :, 2] = np.arange(4) * 0.2
    res = export_vtk(t, pos, tmp_path, every=4)
    assert res["frames"] == 3  # records 0, 4 and the last one (6)
    assert read_legacy_vtk(res["vtk"][-1])["field_data"]["TIME"] == pytest.approx(1.0)
    assert np.all(read_legacy_vtk(res["vtk"][0])["point_data"]["curvature"] == 0)


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
