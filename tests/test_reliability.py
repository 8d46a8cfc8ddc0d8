"""Kill a run with SIGKILL mid-way, resume it, and get the uninterrupted result."""

import json
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np

ARGS = ["simulate", "--torque", "0.5", "--length", "2", "--time", "0.4", "--save-every", "1e-3",
        "--checkpoint-every", "0.02", "--json"]


def _cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "flagellum.cli", *args], capture_output=True,
                          text=True, timeout=600, **kw)


def test_sigkill_and_resume_is_bit_identical(tmp_path):
    ref = tmp_path / "ref.h5"
    r = _cli(*ARGS, "--output", str(ref))
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
    r2 = _cli("simulate", "--resume", str(out), "--json")
    assert r2.returncode == 0, r2.stderr
    assert not ckpt.exists()
    with h5py.File(ref) as a, h5py.File(out) as b:
        assert a["t"].shape == b["t"].shape
        for name in ("positions", "thrust", "angles", "motor_angle"):
            assert np.array_equal(a[name][()], b[name][()]), name
    s1, s2 = json.loads(r.stdout), json.loads(r2.stdout)
    for k in s1:
        if k not in ("wall_seconds", "steps", "output"):
            assert s1[k] == s2[k], k
    assert killed  # the kill really happened mid-run (otherwise the test proved nothing)


def test_resume_without_checkpoint_is_one_line_error(tmp_path):
    r = _cli("simulate", "--resume", str(tmp_path / "nothing.h5"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
