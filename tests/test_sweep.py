"""Sweep engine: range syntax, TOML configs, the dataset, local pool, dask, kill and resume.

The engine runs a tiny model (L = 2 µm, N = 10, 5 ms simulated: well under a second per
point). One grid is used throughout: 6 real simulations, 6 points that blow up in the worker
(stretch modulus 0.01 pN) and 2 with an invalid torque (rejected in the parent).
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import assert_one_line_error

from flagellum.cli import run
from flagellum.errors import ParameterError
from flagellum.grid import parse_values
from flagellum.sweep import VARIABLES, Sweep, point_key, read_sweep, run_point, run_sweep

TINY = {"length": 2.0, "time": 0.005}
GRID = {"torque": [-1.0, 0.5, 1.5, 2.5, 3.0, 4.0, 2000.0], "stretch_modulus": [1000.0, 0.01]}
CONFIG = """\
[fixed]
length = 2.0
time = 1.0          # overridden by --time on the command line

[ranges]
torque = [-1.0, 0.5, 1.5, 2.5, 3.0, 4.0, 2000.0]
stretch_modulus = "1000,0.01"
"""


def identical(x, y) -> bool:
    """Same dtype, shape and values, bit for bit."""
    same = x.dtype == y.dtype and x.shape == y.shape
    return same and (x.tolist() == y.tolist() if x.dtype == object else x.tobytes() == y.tobytes())


def assert_same(a, b):
    """Identical datasets, wall_seconds excepted."""
    assert a.dims == b.dims
    assert all(identical(a.coords[d], b.coords[d]) for d in a.dims)
    assert set(a.data) == set(b.data) == set(VARIABLES) | {"key"}
    for name in set(VARIABLES) - {"wall_seconds"} | {"key"}:
        assert identical(a.data[name], b.data[name]), name


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The grid, uninterrupted, on the local pool with 2 workers."""
    path = tmp_path_factory.mktemp("ref") / "ref.nc"
    report = run_sweep(Sweep.create(GRID, TINY), path, workers=2, progress=False)
    return report, read_sweep(path)


# -- parsing ------------------------------------------------------------------------------


@pytest.mark.parametrize("name,spec,expected", [
    ("torque", "-2:6:0.25", [-2 + 0.25 * i for i in range(33)]),
    ("torque", "0:1:0.3", [0.0, 0.3, 0.6, 0.9]),
    ("torque", "6:4:-1", [6.0, 5.0, 4.0]),
    ("seed", "1:8", list(range(1, 9))),
    ("sphere-radius", "1,2.5, 4", [1.0, 2.5, 4.0]),
    ("t_end", "0.1", [0.1]),
    ("hook", "free,elastic", ["free", "elastic"]),
    ("thermal", "true,false", [True, False]),
    ("torque", [1, 2.5], [1.0, 2.5]),
    ("seed", 3, [3]),
])
def test_range_syntax(name, spec, expected):
    assert list(parse_values(name, spec)) == expected


def test_grid_values_are_the_decimal_literals():
    assert parse_values("torque", "0:0.3:0.1") == (0.0, 0.1, 0.2, 0.3)  # not 0.30000000000000004


@pytest.mark.parametrize("name,spec", [
    ("torque", "1:2:0"), ("torque", "2:1:1"), ("torque", "a:b"), ("torque", "1:2:3:4"),
    ("torque", "nan"), ("torque", ""), ("torque", "1,1"), ("torque", "1:1e9:1e-3"),
    ("torque", True), ("hook", "1:2"), ("seed", "1.5"), ("seed", "1:2:0.5"),
    ("thermal", "maybe"), ("torq", "1"), ("torque", []),
])
def test_bad_values_raise_one_line_parameter_error(name, spec):
    with pytest.raises(ParameterError) as exc:
        parse_values(name, spec)
    assert "\n" not in str(exc.value)


def test_sweep_grid_order_and_keys():
    s = Sweep.create({"torque": "1:2", "sphere_radius": "3,4,5"}, {"length": 2})
    assert s.dims == ("torque", "sphere_radius") and s.shape == (2, 3) and s.size == 6
    pts = s.points()
    assert pts[1] == {"torque": 1.0, "sphere_radius": 4.0} and pts[3]["torque"] == 2.0
    assert point_key(pts[1]) == point_key({"sphere_radius": 4.0, "torque": 1.0})
    assert s.values(pts[0]) == {"length": 2.0, "torque": 1.0, "sphere_radius": 3.0}
    assert s.updated(fixed={"torque": 5}).coords == {"sphere_radius": (3.0, 4.0, 5.0)}


@pytest.mark.parametrize("ranges,fixed", [
    ({"torque": "1,2"}, {"torque": 3}), ({"time": "1,2", "t_end": "3,4"}, {}),
    ({"seed": "1:4"}, {}), ({"seed": "1:4"}, {"kT": 4e-3, "thermal": False}),
    ({"bogus": "1"}, {}), ({}, {"length": "abc"}),
])
def test_bad_sweeps(ranges, fixed):
    with pytest.raises(ParameterError):
        Sweep.create(ranges, fixed)


def test_seeds_need_thermal():
    assert Sweep.create({"seed": "1:3"}, {"kT": 4e-3}).seeds == [1, 2, 3]
    assert Sweep.create({"torque": "1,2"}, {}).seeds == [0]


def test_toml_config(tmp_path):
    cfg = tmp_path / "s.toml"
    cfg.write_text(CONFIG)
    s = Sweep.from_toml(cfg).updated(fixed={"time": 0.005})
    assert s == Sweep.create(GRID, TINY)
    for text in ("[fixed\nx=1", "[other]\na = 1", "ranges = 3", "[ranges]\ntorque = '1:2:0'"):
        cfg.write_text(text)
        with pytest.raises(ParameterError):
            Sweep.from_toml(cfg)
    with pytest.raises(ParameterError):
        Sweep.from_toml(tmp_path / "missing.toml")


@pytest.mark.parametrize("args,word", [
    (["--torque", "1:2:0"], "torque"), (["--torque", "1,2", "--length", "-1"], "length"),
    (["--seed", "1:3"], "seed"), ([], "CONFIG"), (["/nonexistent.toml"], "config"),
    (["--torque", "1,2", "--scheduler", "tcp://127.0.0.1:1", "--dask-local", "1"], "scheduler"),
    (["--torque", "1,2", "--workers", "0"], "workers"),
])
def test_cli_bad_input_one_line_exit_2(tmp_path, cli, args, word):
    code, _, err = cli("sweep", *args, "--out", tmp_path / "x.nc", "--json")
    assert_one_line_error(code, err, word)
    assert not (tmp_path / "x.nc").exists()


def test_run_point_never_raises():  # (a blow-up in a worker: see test_reference_dataset)
    out = run_point({"friction": "lighthill", "kappa0": 0.0})
    assert out["status"].startswith("invalid kappa0") and out["wall_seconds"] >= 0
    assert run_point(None)["status"].startswith("TypeError: ")


# -- running ------------------------------------------------------------------------------


def test_reference_dataset(reference):
    report, d = reference
    assert (report.points, report.finished, report.failed, report.computed, report.lost) == (14, 14, 8, 12, 0)
    assert d.dims == ("torque", "stretch_modulus") and d.data["thrust_mean"].shape == (7, 2)
    assert d.finished.all()
    status = d.data["status"]
    assert (status[:6, 0] == "ok").all()
    assert all("blew up" in s for s in status[:6, 1])
    assert all(s.startswith("invalid torque") for s in status[6])
    ok = status == "ok"
    assert np.isfinite(d.data["thrust_mean"][ok]).all() and np.isnan(d.data["thrust_mean"][~ok]).all()
    assert (d.data["steps"][ok] > 0).all() and (d.data["steps"][~ok] == -1).all()
    assert list(d.data["regime"][:2, 0]) == ["reorienting", "aligned"]
    assert np.all(np.diff(d.data["thrust_mean"][:6, 0]) > 0)  # thrust grows with torque
    assert d.attrs["length"] == 2.0 and d.attrs["time"] == 0.005 and list(d.attrs["seeds"]) == [0]
    assert d.attrs["version"] and json.loads(d.attrs["fixed"]) == TINY
    keys = d.data["key"].ravel()
    assert len(set(keys)) == keys.size
    assert json.loads(d.data["key"][2, 1]) == {"stretch_modulus": 0.01, "torque": 1.5}


def test_one_worker_gives_the_same_dataset(reference, tmp_path):
    path = tmp_path / "one.nc"
    run_sweep(Sweep.create(GRID, TINY), path, workers=1, progress=False)
    assert_same(read_sweep(path), reference[1])


def test_resume_rules(reference, tmp_path):
    path = tmp_path / "r.nc"
    shutil.copy(reference[0].output, path)
    sweep = Sweep.create(GRID, TINY)
    with pytest.raises(ParameterError, match="new file"):
        run_sweep(sweep, path)
    for bad in (sweep.updated(fixed={"length": 2.2}), sweep.updated(ranges={"torque": "0.5,1.5"}),
                Sweep.create({"torque": GRID["torque"]}, {**TINY, "stretch_modulus": 1000.0})):
        with pytest.raises(ParameterError, match="resume"):
            run_sweep(bad, path, resume=True)
    # an extended grid keeps every finished point; the new (invalid) torque needs no worker
    bigger = sweep.updated(ranges={"torque": GRID["torque"] + [3000.0]})
    report = run_sweep(bigger, path, resume=True)
    assert (report.skipped, report.computed, report.finished, report.failed) == (14, 0, 16, 10)
    d, ref = read_sweep(path), reference[1]
    assert [n for n in VARIABLES if not identical(d.data[n][:7], ref.data[n])] == []
    assert run_sweep(bigger, path, resume=True).computed == 0
    with pytest.raises(ParameterError):
        read_sweep(tmp_path / "missing.nc")


# -- retries of failed points --------------------------------------------------------------


@pytest.fixture
def flaky(monkeypatch):
    """Points run in-process (one thread instead of the spawned pool, so that patches apply)
    and the point at torque 1.5 fails deterministically with the default method (``None``:
    the run's :func:`~flagellum.integrate.default_method`, an adaptive one), not with the
    implicit scheme. Returns the (torque, method) of every simulation."""
    import concurrent.futures
    from contextlib import contextmanager

    import flagellum.sweep as engine
    from flagellum.errors import SimulationError

    @contextmanager
    def pool(workers):
        with concurrent.futures.ThreadPoolExecutor(1) as ex:
            yield ex.submit, concurrent.futures.as_completed

    real, calls = engine.PointRun.simulate, []

    def simulate(self):
        calls.append((self.motor.torque, self.solver.method))
        if self.motor.torque == 1.5 and self.solver.method is None:
            raise SimulationError("injected failure of the default method")
        return real(self)

    monkeypatch.setattr(engine, "process_pool", pool)
    monkeypatch.setattr(engine.PointRun, "simulate", simulate)
    return calls


def test_retry_failed_on_resume_with_a_fallback(flaky, tmp_path):
    path, sweep = tmp_path / "f.nc", Sweep.create({"torque": [0.5, 1.5]}, TINY)
    first = run_sweep(sweep, path, progress=False)
    assert (first.failed, first.retried) == (1, 0)
    before = read_sweep(path)
    assert before.data["status"][1] == "injected failure of the default method" and before.data["fallback"][1] == ""
    assert run_sweep(sweep, path, resume=True).computed == 0  # a plain resume keeps failures
    again = run_sweep(sweep, path, retry_failed=True)  # same solver: fails again
    assert (again.computed, again.retried, again.failed) == (1, 1, 1)
    fixed = run_sweep(sweep, path, retry_failed=True, fallback={"method": "implicit"})
    assert (fixed.computed, fixed.retried, fixed.failed, fixed.skipped) == (1, 1, 0, 1)
    d = read_sweep(path)
    assert list(d.data["status"]) == ["ok", "ok"] and np.isfinite(d.data["thrust_mean"]).all()
    assert d.data["fallback"][1] == json.dumps({"method": "implicit"}) and d.data["fallback"][0] == ""
    assert [n for n in VARIABLES if not identical(d.data[n][:1], before.data[n][:1])] == []
    assert flaky == [(0.5, None), (1.5, None), (1.5, None), (1.5, "implicit")]


def test_fallback_retries_a_failure_at_once(flaky, tmp_path):
    report = run_sweep(Sweep.create({"torque": [0.5, 1.5]}, TINY), tmp_path / "g.nc",
                       fallback={"rtol": 1e-7, "method": "implicit"})
    assert (report.computed, report.retried, report.failed) == (2, 1, 0)
    assert sorted(flaky, key=str) == sorted([(0.5, None), (1.5, None), (1.5, "implicit")], key=str)


@pytest.mark.parametrize("fallback", [{"torque": 1.0}, {"method": "bogus"}, {"rtol": -1},
                                      {"kappa0": 1.0}, {"nonsense": 1}])
def test_bad_fallback(tmp_path, fallback):
    with pytest.raises(ParameterError):
        run_sweep(Sweep.create({"torque": [0.5, 1.5]}, TINY), tmp_path / "h.nc", fallback=fallback)
    assert not (tmp_path / "h.nc").exists()


def test_cli_retry_failed(flaky, tmp_path, capsys):
    out = tmp_path / "c.nc"
    args = ["sweep", "--torque", "0.5,1.5", "--length", "2", "--time", "0.005", "--out", str(out), "--json"]
    assert run(args) == 0 and json.loads(capsys.readouterr().out)["failed"] == 1
    assert run(args + ["--retry-failed", "--fallback", "method=implicit"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert (rep["failed"], rep["retried"], rep["skipped"]) == (0, 1, 1)
    for bad in (["--fallback", "torque=1"], ["--fallback", "method"]):
        assert run(args + ["--retry-failed", *bad]) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_resume_a_file_without_the_fallback_variable(flaky, tmp_path):
    """Files of previous formats (no ``fallback``, no ``swimming_speed``) resume; the
    variables are filled in."""
    import h5py

    path, sweep = tmp_path / "old.nc", Sweep.create({"torque": [0.5, 1.5]}, TINY)
    run_sweep(sweep, path)
    with h5py.File(path, "a") as f:
        del f["fallback"]
        del f["swimming_speed"]
    report = run_sweep(sweep, path, retry_failed=True, fallback={"method": "implicit"})
    assert (report.skipped, report.computed, report.failed) == (1, 1, 0)
    assert list(read_sweep(path).data["fallback"]) == ["", json.dumps({"method": "implicit"})]


def test_dask_cluster_on_loopback(reference, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        path = tmp_path / "dask.nc"
        report = run_sweep(Sweep.create(GRID, TINY), path, scheduler=address, progress=True)
    assert "100%" in capsys.readouterr().err
    assert (report.finished, report.computed, report.lost) == (14, 12, 0)
    assert_same(read_sweep(path), reference[1])


def test_dask_local_option(tmp_path, capsys):
    pytest.importorskip("distributed")
    code = run(["sweep", "--torque", "1,2", "--stretch-modulus", "0.01", *sum(
        ([f"--{k}", str(v)] for k, v in TINY.items()), []), "--dask-local", "1",
        "--out", str(tmp_path / "d.nc"), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and (out["points"], out["finished"], out["failed"]) == (2, 2, 2)
    assert all("blew up" in s for s in read_sweep(tmp_path / "d.nc").data["status"])


def _finished(path) -> int:
    try:
        return int(read_sweep(path).finished.sum())
    except ParameterError:  # not written yet
        return 0


def _dead(psutil, p) -> bool:
    try:
        return p.status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


def test_kill_and_resume_loses_and_duplicates_nothing(reference, tmp_path):
    psutil = pytest.importorskip("psutil")
    cfg, path = tmp_path / "s.toml", tmp_path / "killed.nc"
    cfg.write_text(CONFIG)
    cmd = [sys.executable, "-m", "flagellum.cli", "sweep", str(cfg), "--time", "0.005",
           "--out", str(path), "--workers", "2"]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen(cmd + ["--json"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while _finished(path) < 4 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)  # the 2 invalid points are written at once; wait for 2 computed
        assert proc.poll() is None, "the sweep ended before it could be killed"
        workers = psutil.Process(proc.pid).children(recursive=True)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 10  # the workers notice that the sweep died and exit
        while not all(_dead(psutil, p) for p in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert all(_dead(psutil, p) for p in workers)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    before = read_sweep(path)
    n_done = int(before.finished.sum())
    assert 4 <= n_done < 14, "the sweep was not killed while it ran"
    r = subprocess.run(cmd + ["--resume", "--json"], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert (summary["points"], summary["finished"], summary["skipped"], summary["computed"]) == \
        (14, 14, n_done, 14 - n_done)
    assert set(summary) >= {"failed", "output", "wall_seconds", "lost"}
    after = read_sweep(path)
    assert_same(after, reference[1])
    keys = after.data["key"].ravel()
    assert len(set(keys)) == 14 and "" not in keys
    # finished points were kept, not recomputed
    done = before.finished
    assert after.data["wall_seconds"][done].tobytes() == before.data["wall_seconds"][done].tobytes()
