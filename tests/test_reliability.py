"""Kill a run (SIGKILL) at any instant, interrupt it, fill its disk: it resumes to the result
of a run that never stopped, and no half-written file is left."""

import errno
import json
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from conftest import assert_one_line_error, run_cli_subprocess

from flagellum import ParameterError, Params, SimulationError
from flagellum.cli import run as cli
from flagellum.io import RECORD_FIELDS, read_trajectory
from flagellum.motor import Motor
from flagellum.simulator import Simulator

ARGS = ["simulate", "--torque", "0.5", "--length", "2", "--time", "0.4", "--save-every", "1e-3",
        "--checkpoint-every", "0.02", "--json"]
#: in-process runs: 60 records, checkpoints after 20 and 40 → atomic writes: main file,
#: part 0, checkpoint 0, part 1, checkpoint 1, final main file
RUN = dict(t_end=0.06, save_every=1e-3, checkpoint_every=0.02, progress=False)
N_REPLACES = 6


def _new_sim():
    return Simulator(Params.from_flat({"length": 2.0}), Motor(0.5))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    path = tmp_path_factory.mktemp("ref") / "ref.h5"
    _new_sim().run(output=path, **RUN)
    data = read_trajectory(path)
    assert len(data["t"]) == 61 and data["attrs"]["status"] == "complete"
    return data


def _same_as_reference(path, ref):
    data = read_trajectory(path)
    assert data["attrs"]["status"] == "complete"
    for name in [*RECORD_FIELDS, "final_state"]:
        assert np.array_equal(data[name], ref[name]), name
    assert sorted(os.listdir(path.parent)) == [path.name]  # no checkpoint, part or temp file


def _prefix_of_reference(path, ref):
    """A killed/interrupted file reads back as the reference's first records."""
    data = read_trajectory(path)
    m = len(data["t"])
    for name in RECORD_FIELDS:
        assert np.array_equal(data[name], ref[name][:m]), name
    return m


def _run_killed(path, patch):
    """Run in a forked child that ``patch`` makes SIGKILL itself; return its exit status."""
    pid = os.fork()
    if pid == 0:  # child: never return into pytest
        try:
            patch(lambda: os.kill(os.getpid(), signal.SIGKILL))
            _new_sim().run(output=path, **RUN)
        finally:
            os._exit(0)
    return os.waitpid(pid, 0)[1]


def _on_call(targets, k, action, after=False, set_=setattr):
    """Patch the methods ``targets`` [(obj, name), …] to call ``action`` just before (or
    after) the k-th call of any of them."""
    calls = [0]

    def wrap(orig):
        def wrapper(*a, **kw):
            calls[0] += 1
            n = calls[0]
            if n == k and not after:
                action()
            out = orig(*a, **kw)
            if n == k and after:
                action()
            return out
        return wrapper

    for obj, name in targets:
        set_(obj, name, wrap(getattr(obj, name)))


KILL_POINTS = (
    [("before rename", k) for k in range(1, N_REPLACES + 1)]
    + [("after rename", k) for k in range(1, N_REPLACES + 1)]
    # k-th HDF5 dataset write: inside part 0, inside checkpoint 0, inside the final file
    + [("mid-write", k) for k in (3, 14, 40)])


@pytest.mark.parametrize("where,k", KILL_POINTS)
def test_sigkill_at_any_instant_then_resume_is_bit_identical(where, k, reference, tmp_path):
    def patch(kill):
        if where == "mid-write":
            _on_call([(h5py.Group, "__setitem__"), (h5py.Dataset, "__setitem__")], k, kill)
        else:
            _on_call([(os, "replace")], k, kill, after=where == "after rename")

    out = tmp_path / "run.h5"
    status = _run_killed(out, patch)
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL  # killed there
    if where == "before rename" and k == 1:  # the file was never created: nothing to resume
        with pytest.raises(ParameterError):
            Simulator.resume(out, progress=False)
        return
    _prefix_of_reference(out, reference)  # readable while killed (info, render)
    Simulator.resume(out, progress=False)
    _same_as_reference(out, reference)


def test_ctrl_c_leaves_a_usable_file_and_resumes(reference, tmp_path, monkeypatch):
    out = tmp_path / "run.h5"

    def interrupt():
        raise KeyboardInterrupt

    _on_call([(Simulator, "_record")], 33, interrupt, set_=monkeypatch.setattr)  # after checkpoint 0
    with pytest.raises(KeyboardInterrupt):
        _new_sim().run(output=out, **RUN)
    monkeypatch.undo()
    data = read_trajectory(out)
    assert data["attrs"]["status"] == "interrupted" and "final_state" in data
    assert _prefix_of_reference(out, reference) == 32  # every record up to the interrupt
    Simulator.resume(out, progress=False)
    _same_as_reference(out, reference)


@pytest.mark.parametrize("k", [2, 4, N_REPLACES])  # part 0, part 1, the final file
def test_disk_full_is_one_error_keeps_the_checkpoint_and_resumes(k, reference, tmp_path, monkeypatch):
    out = tmp_path / "run.h5"

    def full():
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    _on_call([(os, "fsync")], k, full, set_=monkeypatch.setattr)  # each atomic write fsyncs
    with pytest.raises(SimulationError, match="No space left on device") as exc:
        _new_sim().run(output=out, **RUN)
    monkeypatch.undo()
    n_parts = (k - 1) // 2  # parts written (each followed by its checkpoint)
    assert len(str(exc.value).splitlines()) == 1
    assert ("--resume" in str(exc.value)) == (n_parts > 0)
    files = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file())
    assert files == sorted(["run.h5", *(["run.h5.ckpt"] if n_parts else []),
                            *(f"run.h5.parts/{i:08d}.h5" for i in range(n_parts))])
    assert _prefix_of_reference(out, reference) == (20 * n_parts + 1 if n_parts else 0)
    Simulator.resume(out, progress=False)
    _same_as_reference(out, reference)


def test_disk_full_on_the_cli_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    out = tmp_path / "run.h5"
    assert cli(["simulate", "--length", "2", "--time", "0.001", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("flagellum: error: cannot write")
    assert "No space left" in err[0]
    assert not list(tmp_path.iterdir())  # not even the main file could be created


def test_full_or_unwritable_directory_is_reported_before_the_run(tmp_path, monkeypatch, capsys):
    import shutil
    from collections import namedtuple

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9 - 1000, 1000))
    args = ["simulate", "--length", "2", "--time", "0.01", "--save-every", "1e-3"]
    assert cli([*args, "-o", str(tmp_path / "a.h5")]) == 2
    err = capsys.readouterr().err
    assert "MB free" in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())
    monkeypatch.undo()
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    if os.access(ro, os.W_OK):
        pytest.skip("running as root: permissions are not enforced")
    assert cli([*args, "-o", str(ro / "a.h5")]) == 2
    assert "writable directory" in capsys.readouterr().err
    assert not list(ro.iterdir()) and [p.name for p in tmp_path.iterdir()] == ["ro"]


def test_sigkill_and_resume_is_bit_identical(tmp_path):
    """The real thing: a CLI process killed by a signal at an arbitrary moment."""
    ref = tmp_path / "ref.h5"
    r = run_cli_subprocess(*ARGS, "--output", str(ref))
    assert r.returncode == 0, r.stderr
    out = tmp_path / "run.h5"
    ckpt = tmp_path / "run.h5.ckpt"
    proc = subprocess.Popen([sys.executable, "-m", "flagellum.cli", *ARGS, "--output", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.time() + 300
    while not ckpt.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    killed = proc.poll() is None
    if killed:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    r2 = run_cli_subprocess("simulate", "--resume", str(out), "--json")
    assert r2.returncode == 0, r2.stderr
    assert sorted(os.listdir(tmp_path)) == ["ref.h5", "run.h5"]
    with h5py.File(ref) as a, h5py.File(out) as b:
        assert a["time"].shape == b["time"].shape
        for name in ("positions", "thrust", "angles", "motor_angle"):
            assert np.array_equal(a[name][()], b[name][()]), name
    s1, s2 = json.loads(r.stdout), json.loads(r2.stdout)
    for k in s1:
        if k not in ("wall_seconds", "steps", "output"):
            assert s1[k] == s2[k], k
    assert killed  # the kill really happened mid-run (otherwise the test proved nothing)


def test_resume_without_checkpoint_is_one_line_error(tmp_path):
    r = run_cli_subprocess("simulate", "--resume", str(tmp_path / "nothing.h5"))
    assert_one_line_error(r.returncode, r.stderr)
