"""Output files describe themselves: xarray (h5netcdf) opens trajectory and sweep files with
named dimensions, coordinates and CF units; ``to_xarray`` and ``open_trajectory`` give the
same; files of the earlier layout still read; the version and revision are recorded."""

import json
import re
import subprocess
import sys
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

import h5py
import numpy as np
import pytest

import flagellum
from flagellum import Params
from flagellum.io import RECORD_FIELDS, RECORD_META, read_trajectory
from flagellum.motor import Motor
from flagellum.simulator import Simulator
from flagellum.trajectory import Trajectory, open_trajectory

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")

ROOT = Path(__file__).resolve().parents[1]
N = 10  #: segments of the runs below (L = 2 µm)


def _sim(**kw):
    return Simulator(Params.from_flat({"length": 2.0}), Motor(0.5), **kw)


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("fmt") / "run.h5"
    tr = _sim(seed=3).run(0.006, save_every=1e-3, output=path, progress=False)
    return path, tr


def _assert_described(ds):
    """Named dimensions only, and units and a long name on every numeric variable."""
    assert not [d for d in ds.dims if str(d).startswith("phony_dim")]
    for name, var in ds.variables.items():
        assert var.attrs.get("long_name"), name
        if var.dtype.kind in "fiu" and name != "final_state":  # (a state of µm and rad)
            assert var.attrs.get("units"), name


def _open(path):
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()


def test_xarray_opens_a_trajectory_with_dimensions_and_units(run_file):
    path, tr = run_file
    ds = _open(path)
    _assert_described(ds)
    n_state = len(read_trajectory(path)["final_state"])
    assert dict(ds.sizes) == {"time": 7, "bead": N + 1, "xyz": 3, "state": n_state}
    assert ds.positions.dims == ("time", "bead", "xyz") and ds.angles.dims == ("time", "bead")
    assert ds.hook_tangent.dims == ds.anchor_force.dims == ("time", "xyz")
    for name, (dims, units, _) in RECORD_META.items():
        var = ds["time" if name == "t" else name]
        assert var.dims == ("time", *dims) and var.attrs["units"] == units, name
    assert ds.time.attrs["units"] == "s" and ds.positions.attrs["units"] == "um"
    assert ds.torque.attrs["units"] == "pN um" and ds.motor_speed.attrs["units"] == "rad/s"
    assert list(ds.xyz.values) == ["x", "y", "z"] and list(ds.bead.values) == list(range(N + 1))
    np.testing.assert_array_equal(ds.time.values, tr.t)
    np.testing.assert_array_equal(ds.positions.sel(xyz="z").values, tr.positions[:, :, 2])
    # the parameters as global attributes
    assert ds.attrs["status"] == "complete" and ds.attrs["seed"] == 3
    assert Params.from_dict(tomllib.loads(ds.attrs["params_toml"])) == Params.from_flat({"length": 2.0})
    assert ds.attrs["thermal"] == 0  # netCDF has no booleans


def test_to_xarray_round_trip_equals_the_trajectory(run_file):
    path, tr = run_file
    ds = tr.to_xarray()
    _assert_described(ds)
    np.testing.assert_array_equal(ds.time.values, tr.t)
    for name in RECORD_FIELDS:
        if name != "t":
            np.testing.assert_array_equal(ds[name].values, getattr(tr, name))
    back = Trajectory.from_records({"t": ds.time.values, **{k: ds[k].values for k in RECORD_FIELDS
                                                            if k != "t"}}, dict(ds.attrs))
    for name in RECORD_FIELDS:
        assert np.array_equal(getattr(back, name), getattr(tr, name)), name
    # the same as the file, variables and their attributes
    xr.testing.assert_identical(ds.drop_attrs(), _open(path).drop_vars("final_state").drop_attrs())


def test_open_trajectory_is_the_file_through_xarray(run_file):
    path, _ = run_file
    xr.testing.assert_identical(flagellum.open_trajectory(path), _open(path))


def test_a_file_of_the_earlier_layout_still_reads(run_file, tmp_path):
    """The earlier writer: one dataset per record field (times in ``t``), no dimensions."""
    path, tr = run_file
    old = tmp_path / "old.h5"
    new = read_trajectory(path)
    with h5py.File(old, "w") as f:
        f.attrs.update(new["attrs"])
        for name in RECORD_FIELDS:
            f[name] = new[name]
        f["final_state"] = new["final_state"]
    data = read_trajectory(old)
    for name in [*RECORD_FIELDS, "final_state"]:
        assert np.array_equal(data[name], new[name]), name
    ds = open_trajectory(old)
    _assert_described(ds)
    np.testing.assert_array_equal(ds.positions.values, tr.positions)
    from flagellum.export import export_trajectory

    pytest.importorskip("vtkmodules.vtkIOXML")
    assert export_trajectory(old, tmp_path / "vtk", every=3)["frames"] == 3


def test_a_running_file_reads_from_its_parts_and_resumes(tmp_path):
    """Killed after its first checkpoint: xarray sees the (empty) main file with its
    dimensions; open_trajectory gives the records of the parts; with a main file of the
    earlier layout, the run resumes to the uninterrupted result."""
    import os
    import signal

    from flagellum.trajectory import RunFiles

    out = tmp_path / "run.h5"
    pid = os.fork()
    if pid == 0:
        try:
            real = RunFiles.write_checkpoint

            def kill_after(self, *a, **kw):
                real(self, *a, **kw)
                os.kill(os.getpid(), signal.SIGKILL)

            RunFiles.write_checkpoint = kill_after
            _sim().run(0.01, save_every=1e-3, checkpoint_every=0.004, output=out, progress=False)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    ds = _open(out)
    assert ds.attrs["status"] == "running" and ds.sizes["time"] == 0 and ds.sizes["bead"] == N + 1
    _assert_described(ds)
    got = open_trajectory(out)
    assert got.sizes["time"] == 5 and got.attrs["status"] == "running"
    # a run killed while its main file had the earlier layout resumes into the new one
    attrs = read_trajectory(out, records=False)["attrs"]
    with h5py.File(out, "w") as f:
        f.attrs.update(attrs)
        for name, (shape, dtype) in RECORD_FIELDS.items():
            f.create_dataset(name, shape=(0, *shape(N)), maxshape=(None, *shape(N)), dtype=dtype)
    assert read_trajectory(out)["t"].shape == (5,)  # from the parts
    Simulator.resume(out, progress=False)
    ref = _sim().run(0.01, save_every=1e-3, checkpoint_every=0.004, output=tmp_path / "ref.h5",
                     progress=False)
    done = _open(out)
    _assert_described(done)
    assert done.attrs["status"] == "complete"
    np.testing.assert_array_equal(done.positions.values, ref.positions)
    np.testing.assert_array_equal(done.time.values, ref.t)


def test_netcdf_library_reads_a_trajectory(run_file):
    """Where the netCDF-C library is installed (netCDF4): the same dimensions and units."""
    netCDF4 = pytest.importorskip("netCDF4")
    path, tr = run_file
    with netCDF4.Dataset(path) as nc:
        assert nc["positions"].dimensions == ("time", "bead", "xyz")
        assert nc.dimensions["time"].isunlimited() and nc["thrust"].units == "pN"
        np.testing.assert_array_equal(nc["thrust"][:], tr.thrust)


def test_xarray_opens_a_sweep_file_with_units(tmp_path):
    from flagellum.grid import PARAMETERS
    from flagellum.sweep import PARAMETER_ATTRS, VARIABLE_ATTRS, VARIABLES, Sweep, read_sweep, run_sweep

    assert set(PARAMETERS) <= set(PARAMETER_ATTRS)  # every sweepable parameter has its units
    assert {*VARIABLES, "key"} <= set(VARIABLE_ATTRS)
    out = tmp_path / "s.nc"
    sweep = Sweep.create({"torque": [0.5, 1.0], "method": ["cvode"], "seed": [0]},
                         {"length": 2.0, "time": 0.002, "thermal": False})
    run_sweep(sweep, out, workers=1)
    for ds in (_open(out), read_sweep(out).to_xarray()):
        assert ds.thrust_mean.dims == ("torque", "method", "seed")
        _assert_described(ds)
        assert ds.torque.attrs["units"] == "pN um" and ds.thrust_mean.attrs["units"] == "pN"
        assert ds.omega_mean.attrs["units"] == "rad/s" and ds.wall_seconds.attrs["units"] == "s"
        assert "units" not in ds.method.attrs and "units" not in ds.regime.attrs  # text
        assert ds.attrs["thermal"] == 0 and json.loads(ds.attrs["fixed"])["thermal"] is False
    read_sweep(out).to_xarray().to_netcdf(tmp_path / "copy.nc", engine="h5netcdf")


# -- version and revision ---------------------------------------------------------------------

def _head():
    try:
        r = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                           timeout=10)
    except OSError:
        return ""
    return r.stdout.strip() if r.returncode == 0 else ""


def test_an_installed_checkout_knows_its_version_and_revision():
    from flagellum._version import __version__, git_revision
    from flagellum.io import provenance

    assert __version__ != "0.0.0+unknown"
    assert re.fullmatch(r"\d+(\.\d+)*((a|b|rc|\.post|\.dev)\d+)*(\+[\w.]+)?", __version__), __version__
    rev = provenance()["git_revision"]
    assert rev == git_revision()
    head = _head()
    if not head:
        pytest.skip("not run from a git checkout")
    assert re.fullmatch(r"[0-9a-f]{7,40}", rev), rev
    if Path(flagellum.__file__).resolve().is_relative_to(ROOT):  # editable: the checkout's HEAD
        assert rev == head
    r = subprocess.run([sys.executable, "-m", "flagellum.cli", "--version"],
                       capture_output=True, text=True, timeout=120)
    assert __version__ in r.stdout


def test_the_revision_of_a_built_package(monkeypatch, tmp_path):
    """Outside a checkout, the revision is the commit that the package was built from."""
    import types

    from flagellum import _version

    monkeypatch.setattr(_version, "__file__", str(tmp_path / "site-packages" / "flagellum" / "_version.py"))
    monkeypatch.setattr(_version, "_built", types.SimpleNamespace(commit_id="g28c1e1f2b"))
    assert _version.git_revision() == "28c1e1f2b"
    monkeypatch.setattr(_version, "_built", None)
    assert _version.git_revision() == ""
