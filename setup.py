"""The wheel build compiles the solvers' Numba kernels into the package, so that the first run
after ``pip install .`` loads them instead of compiling (``flagellum._kernel_cache``;
docs/benchmarks.md, "Compile pause"). Everything else is in pyproject.toml.

``FLAGELLUM_BUILD_CACHE=0`` builds without the cache; an editable install never builds one.
A build that cannot compile (a build environment without Numba) warns and ships no cache:
the first run compiles, as without this step.
"""

import os
import shutil
import subprocess
import sys
import time

from setuptools import setup
from setuptools.command.build_py import build_py

# run in the built package: the default solver first, one method per process step
WARM = r"""
import sys
from flagellum import _kernel_cache, warmup
from flagellum.integrate.cache import METHODS
assert _kernel_cache.PACKAGE_DIR.startswith(sys.argv[1]), _kernel_cache.PACKAGE_DIR
done = []
for method in sorted(METHODS, key=lambda m: m != "bdf"):
    try:
        warmup.warm([method])
        done.append(method)
    except Exception as exc:  # a method whose dependencies the build lacks: compiled at first use
        print("flagellum: not compiled:", method, repr(exc), file=sys.stderr)
print("flagellum: compiled the kernels of", *done, file=sys.stderr)
sys.exit(0 if done else 1)
"""


class BuildPyWithKernels(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False) or os.environ.get("FLAGELLUM_BUILD_CACHE") == "0":
            return
        lib = os.path.abspath(self.build_lib)
        cache = os.path.join(lib, "flagellum", "_numba_cache")
        os.makedirs(cache, exist_ok=True)
        # the built package first; pip's isolated build environment (Numba and the rest from
        # build-system.requires) reaches the child through the environment it set up
        path = os.pathsep.join(filter(None, [lib, os.environ.get("PYTHONPATH")]))
        env = dict(os.environ, PYTHONPATH=path,
                   FLAGELLUM_WARMUP="0", PYTHONDONTWRITEBYTECODE="1",
                   OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        env.pop("NUMBA_CACHE_DIR", None)
        t = time.perf_counter()
        res = subprocess.run([sys.executable, "-c", WARM, lib], env=env, cwd=lib)
        if res.returncode != 0:
            print("flagellum: the kernels were not compiled at build time (see above); "
                  "the first run will compile them", file=sys.stderr)
            shutil.rmtree(cache, ignore_errors=True)
        else:
            print(f"flagellum: kernel cache {cache} built in "
                  f"{time.perf_counter() - t:.0f} s", file=sys.stderr)


setup(cmdclass={"build_py": BuildPyWithKernels})
