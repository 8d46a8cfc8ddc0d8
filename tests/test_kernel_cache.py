"""The cache built with the wheel (flagellum._kernel_cache): keyed by the source's content and
the compiler's versions, not by modification times or the install path, so the copy of the
package that pip installs loads what the build compiled."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numba
from numba.core import config

from flagellum import _kernel_cache as kc

SRC = Path(kc.__file__).parent


def test_stamp_follows_content_not_mtime(tmp_path):
    """Touching a file keeps its stamp (an install writes new times); editing it, even to the
    same size, changes it; the stamp names Numba's version (another Numba recompiles)."""
    f = tmp_path / "mod.py"
    f.write_text("x = 1\n")
    before = kc.source_stamp(str(f))
    os.utime(f, (1e9, 1e9))
    assert kc.source_stamp(str(f)) == before
    f.write_text("x = 2\n")  # same size, other content
    os.utime(f, (1e9, 1e9))
    after = kc.source_stamp(str(f))
    assert after != before
    assert numba.__version__ in after


def _locator(package_dir):
    return type("L", (kc.PackageCacheLocator,), {"package_dir": str(package_dir)})


def test_locator_only_for_a_built_package(tmp_path, monkeypatch):
    """Active only where the package holds the cache folder (a built wheel; a checkout or an
    editable install has none), for its own files, and not when NUMBA_CACHE_DIR is set."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    mod = pkg / "sub" / "mod.py"
    mod.write_text("def f():\n    pass\n")
    outside = tmp_path / "other.py"
    outside.write_text("")
    ns = {}
    exec(compile(mod.read_text(), str(mod), "exec"), ns)
    loc = _locator(pkg)
    monkeypatch.setattr(config, "CACHE_DIR", "")
    assert loc.from_function(ns["f"], str(mod)) is None  # no cache folder: Numba's defaults
    (pkg / kc.DIRNAME).mkdir()
    found = loc.from_function(ns["f"], str(mod))
    assert found is not None
    assert Path(found.get_cache_path()) == pkg / kc.DIRNAME / "sub"
    assert found.get_disambiguator() == "1"
    assert loc.from_function(ns["f"], str(outside)) is None
    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "numba"))
    assert loc.from_function(ns["f"], str(mod)) is None


def test_registered_first():
    import flagellum._jit  # noqa: F401 - registers the locator

    assert kc._IMPL._locator_classes[0] is kc.PackageCacheLocator


PROBE = """
import json
from flagellum import _jit
_jit.atan2(1.0, 2.0)
s = _jit.atan2.stats
print(json.dumps({"hits": sum(s.cache_hits.values()), "misses": sum(s.cache_misses.values()),
                  "path": s.cache_path}))
"""


def _probe(root: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(root)
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, cwd=root, capture_output=True,
                         text=True, check=True, timeout=600)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _copy(src: Path, dst: Path) -> None:
    """Copy the package as an install does: new paths, new modification times."""
    shutil.copytree(src, dst, copy_function=shutil.copyfile,
                    ignore=shutil.ignore_patterns("__pycache__"))


def test_installed_copy_loads_the_built_cache(tmp_path):
    """A package with the cache folder compiles into it ("the build"); a copy of it at another
    path with new file times ("the install") loads that cache without compiling; editing the
    kernel's source there makes Numba compile it again."""
    built = tmp_path / "build" / "flagellum"
    _copy(SRC, built)
    shutil.rmtree(built / kc.DIRNAME, ignore_errors=True)
    (built / kc.DIRNAME).mkdir()
    first = _probe(built.parent)
    assert first["misses"] == 1 and first["hits"] == 0
    assert Path(first["path"]) == built / kc.DIRNAME
    assert list((built / kc.DIRNAME).glob("_jit.atan2-*.nbi"))

    installed = tmp_path / "site" / "flagellum"
    _copy(built, installed)
    for p in installed.rglob("*.py"):
        os.utime(p, (2e9, 2e9))
    second = _probe(installed.parent)
    assert second == {"hits": 1, "misses": 0, "path": str(installed / kc.DIRNAME)}

    jit = installed / "_jit.py"
    jit.write_text(jit.read_text() + "\n# edited\n")
    assert _probe(installed.parent)["misses"] == 1
