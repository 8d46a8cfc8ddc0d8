"""The compile pause: the first run after an install against later runs (docs/benchmarks.md).

Every case starts fresh interpreters with their own ``NUMBA_CACHE_DIR`` (a new, empty folder:
the state right after ``pip install``) and times, in each, the import and the first 0.01-s
run (N = 50, M = 1 pN·µm from rest) of each solver named, then a second run of the same
(the run itself, the kernels loaded):

* ``cold``: empty cache, background warm-up off (``FLAGELLUM_WARMUP=0``): CVODE, then the
  Numba BDF, then the implicit scheme in one process — each first run compiles;
* ``cold_with_warmup``: empty cache, warm-up on: a first CVODE run (its stepper starts
  ``python -m flagellum.warmup bdf implicit`` in the background); once that has finished, a
  new process runs the BDF and the implicit scheme;
* ``cached``: the cache filled: a new process runs each solver (the loads from the cache);
* ``default``: what a user meets: an empty cache and the default method (``simulate`` with
  no method: the Numba BDF), the first process's import + first run against a later
  process's, with every Numba compile event timed per function (self time: nested compiles
  subtracted) in the first; ``--src DIR`` runs another copy of the package's source (its
  ``src`` folder) the same way, alternately with this one, for a paired comparison;
* ``installed`` (``--installed``, run with the interpreter of an environment where
  ``pip install .`` installed the package): the same two processes with no
  ``NUMBA_CACHE_DIR``, so the first one after the install finds the cache the wheel build
  compiled into the package (``flagellum._kernel_cache``); then, for scale, the ``default``
  case with the same package (an empty ``NUMBA_CACHE_DIR``: what the first run compiles).

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_compile.py
Writes benchmarks/bench_compile.json.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).parent
CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
from flagellum import Motor, Params, Simulator, SolverOptions
out = {"import": time.perf_counter() - t0}
for method in sys.argv[1:]:
    for k in ("first", "second"):
        t = time.perf_counter()
        sim = Simulator(Params(), Motor(1.0), thermal=method == "implicit",
                        seed=1 if method == "implicit" else None,
                        solver=SolverOptions(method=method))
        sim.run(0.01, save_every=1e-3, progress=False)
        out[f"{method}_{k}"] = time.perf_counter() - t
print(json.dumps(out))
"""


# the default run with Numba's compile events timed per function (self time)
EVENTS = r"""
import json, sys, time
from numba.core import event as ev
stack, self_time = [], {}
class Timer(ev.Listener):
    def on_start(self, event):
        stack.append([time.perf_counter(), 0.0])
    def on_end(self, event):
        t0, inner = stack.pop()
        dt = time.perf_counter() - t0
        if stack:
            stack[-1][1] += dt
        d = event.data["dispatcher"]
        name = d.py_func.__module__.replace("flagellum.", "") + "." + d.py_func.__qualname__
        self_time[name] = self_time.get(name, 0.0) + dt - inner
ev.register("numba:compile", Timer())
t0 = time.perf_counter()
from flagellum import Motor, Params, Simulator
out = {"import": time.perf_counter() - t0}
for k in ("first", "second"):
    t = time.perf_counter()
    sim = Simulator(Params(), Motor(1.0))
    sim.run(0.01, save_every=1e-3, progress=False)
    out[k] = time.perf_counter() - t
out["method"] = sim.solver.method
out["compile_self_seconds"] = dict(sorted(self_time.items(), key=lambda kv: -kv[1]))
print(json.dumps(out))
"""


def child(cache: str | None, methods, warmup: bool, code: str = CHILD,
          src: str | None = None) -> dict:
    env = dict(os.environ, FLAGELLUM_WARMUP="1" if warmup else "0")
    env.pop("NUMBA_CACHE_DIR", None)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    if src:
        env["PYTHONPATH"] = src
    t = time.perf_counter()
    res = subprocess.run([sys.executable, "-c", code, *methods], env=env, capture_output=True,
                         text=True, check=True)
    out = json.loads(res.stdout.strip().splitlines()[-1])
    out["process"] = time.perf_counter() - t
    return out


def wait_for_warmup(cache: str, limit: float = 900.0) -> float:
    """Seconds until the background warm-up of ``cache`` has released its lock."""
    code = ("from flagellum.integrate.cache import lock_path; print(lock_path())")
    lock = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, NUMBA_CACHE_DIR=cache),
                          capture_output=True, text=True, check=True).stdout.strip()
    t = time.perf_counter()
    while os.path.exists(lock) and time.perf_counter() - t < limit:
        time.sleep(0.5)
    return time.perf_counter() - t


def load_average() -> float:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


def default_case(src: str | None = None) -> dict:
    """The ``default`` case (module docstring) on the source ``src`` (None: the installed)."""
    with tempfile.TemporaryDirectory() as cache:
        first = child(cache, (), warmup=False, code=EVENTS, src=src)
        later = child(cache, (), warmup=False, code=EVENTS, src=src)
    return {"first_process": first, "later_process": later,
            "ratio_first_run": first["first"] / later["first"],
            "ratio_import_and_first_run": (first["import"] + first["first"])
            / (later["import"] + later["first"])}


def installed_case() -> dict:
    """The ``installed`` case (module docstring): this interpreter's installed package."""
    info = subprocess.run([sys.executable, "-c", "import os, flagellum._kernel_cache as k; "
                           "print(k.PACKAGE_DIR, os.path.isdir(os.path.join(k.PACKAGE_DIR, k.DIRNAME)))"],
                          capture_output=True, text=True, check=True, cwd=HERE).stdout.split()
    first = child(None, (), warmup=False, code=EVENTS)
    later = child(None, (), warmup=False, code=EVENTS)
    return {"package": info[0], "has_built_cache": info[1] == "True",
            "first_process": first, "later_process": later,
            "ratio_first_run": first["first"] / later["first"],
            "ratio_import_and_first_run": (first["import"] + first["first"])
            / (later["import"] + later["first"])}


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--default-only", action="store_true", help="only the default case")
    ap.add_argument("--src", default=None, help="another source tree to pair with (its src/)")
    ap.add_argument("--installed", action="store_true",
                    help="only the installed case (an environment after `pip install .`)")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--out", default=str(HERE / "bench_compile.json"))
    args = ap.parse_args()
    out = {"load_average": load_average(), "run": "N = 50, M = 1, 0.01 s from rest"}
    if args.installed:
        out["installed"] = installed_case()
        print("installed", {k: v for k, v in out["installed"].items() if k.startswith("ratio")},
              flush=True)
        out["empty_cache"] = default_case()  # the same package with an empty cache, for scale
        print("empty_cache", {k: v for k, v in out["empty_cache"].items()
                              if k.startswith("ratio")}, flush=True)
        out["load_average_end"] = load_average()
        Path(args.out).write_text(json.dumps(out, indent=1))
        return
    rounds = []
    for _ in range(args.rounds):  # alternately: this code, the other (paired)
        r = {"this": default_case()}
        print("default", {k: v for k, v in r["this"].items() if k.startswith("ratio")},
              r["this"]["first_process"]["first"], flush=True)
        if args.src:
            r["other"] = default_case(args.src)
            print("other", {k: v for k, v in r["other"].items() if k.startswith("ratio")},
                  r["other"]["first_process"]["first"], flush=True)
        rounds.append(r)
    out["default"] = rounds
    if args.default_only:
        out["load_average_end"] = load_average()
        Path(args.out).write_text(json.dumps(out, indent=1))
        return
    with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
        out["cold"] = child(a, ("cvode", "bdf", "implicit"), warmup=False)
        print("cold", out["cold"], flush=True)
        first = child(b, ("cvode",), warmup=True)
        waited = wait_for_warmup(b)
        later = child(b, ("bdf", "implicit"), warmup=True)
        out["cold_with_warmup"] = {"first_process": first, "waited_for_warmup_after_it": waited,
                                   "next_process": later}
        print("cold_with_warmup", out["cold_with_warmup"], flush=True)
        out["cached"] = {m: child(a, (m,), warmup=False) for m in ("cvode", "bdf", "implicit")}
        print("cached", out["cached"], flush=True)
    out["load_average_end"] = load_average()
    Path(args.out).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
