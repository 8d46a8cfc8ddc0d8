"""One line for errors that C libraries and a full disk used to make messy, a damaged
checkpoint refused, and the same bits in every process (compiled or cached kernels)."""

import errno
import io as io_module
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from conftest import assert_one_line_error
from test_bad_input import _killed_after_checkpoints

from flagellum import ParameterError
from flagellum.integrate.cvode import SundialsOutput
from flagellum.simulator import Simulator

# -- SUNDIALS output ---------------------------------------------------------------------

def test_sundials_output_is_caught_at_the_file_descriptors(capfd):
    """SUNDIALS' logger writes warnings to C's stdout (fd 1), scikit-sundae prints errors to
    Python's stdout: inside catch() neither reaches the terminal, and both are parsed."""
    out = SundialsOutput()
    with out.catch():
        os.write(1, b"[WARNING][rank 0][cvode.c:1516][CVode] Internal t = 1 and h = 1e-21 "
                    b"are such that t + h = t on the next step.\n")
        os.write(2, b"[ERROR][rank 0][cvode.c:9][CVode] from fd 2\n")
        print("\n[CVode, Error: -1] At t = 0.0001, mxstep steps taken before reaching tout.\n")
    captured = capfd.readouterr()
    assert captured.out == captured.err == ""
    assert out.warnings == ["Internal t = 1 and h = 1e-21 are such that t + h = t on the next step."]
    assert out.errors == ["from fd 2", "At t = 0.0001, mxstep steps taken before reaching tout."]
    assert "\n" not in out.summary() and "mxstep" in out.summary() and "1 warning" in out.summary()
    print("after")  # the descriptors are restored
    assert capfd.readouterr().out == "after\n"


FAIL_CVODE = textwrap.dedent("""
    import sys
    import numpy as np
    from flagellum.rod.model import RodModel
    orig = RodModel.rhs
    def failing(self, t, y, *args, out=None, **kw):  # NaN from t = 2e-4 s on: CVODE gives up
        r = orig(self, t, y, *args, out=out, **kw)
        if t > 2e-4:
            (out if out is not None else r)[:] = np.nan
        return r
    RodModel.rhs = failing
    from flagellum.cli import entry
    sys.argv = ["flagellum", *sys.argv[1:]]
    entry()
""")


def test_a_failing_cvode_run_is_one_line_in_a_real_process(tmp_path):
    """CVODE's warnings (t + h = t, fd 1 routed to stderr by the console script) and its
    error (scikit-sundae's print) used to come before our line; now they are in it."""
    r = subprocess.run([sys.executable, "-c", FAIL_CVODE, "simulate", "--length", "2",
                        "--time", "0.01", "--method", "cvode", "--json"],  # not the default BDF
                       capture_output=True, text=True, timeout=300,
                       cwd=tmp_path)
    assert_one_line_error(r.returncode, r.stderr)
    assert r.stderr.startswith("flagellum: error: CVODE failed at t = ") and "SUNDIALS:" in r.stderr
    assert r.stdout == ""


# -- disk full, damaged checkpoint ----------------------------------------------------------

def test_a_full_disk_while_hdf5_closes_a_file_is_an_oserror_not_a_crash(tmp_path, monkeypatch):
    """HDF5 writes a file's metadata when it closes it; a write error there made h5py crash
    (segmentation fault) in a real full disk. Every write fails here from the first on."""
    from flagellum import io

    class FullDisk(io_module.FileIO):
        def write(self, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(io, "open", lambda path, mode, buffering=-1: FullDisk(path, "w+"),
                        raising=False)
    with pytest.raises(OSError) as exc:
        with io.atomic_path(tmp_path / "x.h5") as tmp, io.new_hdf5(tmp) as f:
            f.create_dataset("a", shape=(0, 3), maxshape=(None, 3), dtype="f8", chunks=(64, 3))
            f["a"].resize(1000, axis=0)
            f["a"][:] = 1.0
    assert exc.value.errno == errno.ENOSPC
    assert os.listdir(tmp_path) == []  # and the temporary file is gone


def _mount_tmpfs(where, size: str) -> bool:
    try:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                           capture_output=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return False
    return r.returncode == 0


def test_a_really_full_disk_during_the_final_write_is_one_line_and_resumes(tmp_path):
    """On a 700 kB tmpfs: the run's checks pass, its parts fit, the final file does not.
    Needs permission to mount (skipped otherwise); the mocked ENOSPC tests in
    test_reliability.py cover the same path everywhere."""
    d = tmp_path / "small"
    d.mkdir()
    if not _mount_tmpfs(d, "700k"):
        pytest.skip("cannot mount a tmpfs here")
    try:
        out = d / "r.h5"
        args = [sys.executable, "-m", "flagellum", "simulate", "--length", "2", "--time", "0.06",
                "--save-every", "1e-4", "--checkpoint-every", "0.01", "-o", str(out), "--json"]
        r = subprocess.run(args, capture_output=True, text=True, timeout=300)
        assert_one_line_error(r.returncode, r.stderr)
        assert "No space left on device" in r.stderr and "--resume" in r.stderr
        assert sorted(os.listdir(d)) == ["r.h5", "r.h5.ckpt", "r.h5.parts"]  # no temp, no lock
        subprocess.run(["mount", "-o", "remount,size=4M", str(d)], check=True, timeout=30)
        r = subprocess.run([sys.executable, "-m", "flagellum", "simulate", "--resume", str(out),
                            "--json"], capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        assert os.listdir(d) == ["r.h5"]
    finally:
        subprocess.run(["umount", str(d)], timeout=30)


@pytest.mark.parametrize("damage", ["state too short", "state 2-D", "state text", "charts",
                                    "motor angle", "plan", "random stream"])
def test_a_checkpoint_with_a_damaged_state_is_refused(damage, tmp_path, cli):
    """A state of the wrong shape reached the kernels (a segmentation fault); damaged
    attributes reached the run loop (a traceback). The checkpoint's digest refuses both."""
    import json

    import h5py

    out = tmp_path / "run.h5"
    _killed_after_checkpoints(out, 1)
    with h5py.File(str(out) + ".ckpt", "r+") as f:
        y = f["y"][()]
        if damage.startswith("state"):
            del f["y"]
            f["y"] = {"state too short": y[:-5], "state 2-D": np.stack([y, y]),
                      "state text": np.array([b"a", b"b"])}[damage]
        elif damage == "charts":
            r = f["ref_u"][()]
            del f["ref_u"]
            f["ref_u"] = r[:3]
        elif damage == "motor angle":
            f.attrs["last_motor"] = json.dumps([1, 2])
        elif damage == "plan":
            f.attrs["plan"] = json.dumps({**json.loads(f.attrs["plan"]), "flush_every": 0})
        else:
            f.attrs["rng_state"] = "{}"
    before = sorted(p for p in os.listdir(tmp_path) if p != "run.h5.lock")  # (the killed run's)
    code, _, err = cli("simulate", "--resume", out, "--json")
    assert_one_line_error(code, err, "resume")
    assert "has changed since it was written" in err
    assert sorted(os.listdir(tmp_path)) == before  # the files stay as they were
    with pytest.raises(ParameterError, match="resume"):
        Simulator.resume(out, progress=False)


# -- the same bits in every process ------------------------------------------------------------

SEEDED_RUNS = textwrap.dedent("""
    import hashlib
    import numpy as np
    from flagellum import Params
    from flagellum.motor import Motor
    from flagellum.simulator import Simulator, SolverOptions
    out = []
    for kw in (dict(thermal=True, seed=3), dict(), dict(solver=SolverOptions(method="implicit"))):
        sim = Simulator(Params.from_flat({"length": 2.0, "kT": 4.1e-3}), Motor(2.0), **kw)
        tr = sim.run(0.005, save_every=1e-3, progress=False)
        h = hashlib.sha256()
        for k in ("positions", "angles", "thrust", "motor_angle", "energy"):
            h.update(np.ascontiguousarray(getattr(tr, k)).tobytes())
        out.append(h.hexdigest())
    print(" ".join(out))
""")


def test_the_same_seed_gives_the_same_bits_with_compiled_and_cached_kernels(tmp_path):
    """The first process after an install compiles the kernels; later ones load Numba's
    cache. A thermal run (fixed-step implicit with noise), a CVODE run and a deterministic
    implicit run must give the same bits in both."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}

    def hashes():
        r = subprocess.run([sys.executable, "-c", SEEDED_RUNS], capture_output=True, text=True,
                           timeout=600, env=env)
        assert r.returncode == 0, r.stderr
        return r.stdout.split()

    compiled = hashes()
    assert list((tmp_path / "numba").rglob("*.nbi"))  # the first process wrote the cache
    cached = hashes()
    assert compiled == cached
    assert len(set(compiled)) == 3
