"""The package's version and git revision.

Both are set by setuptools-scm when the package is built from a git checkout (``pip
install .``: the version from ``git describe``, written with the commit to
``_scm_version.py``); an sdist carries them in its metadata, a tree without git gets the
``fallback_version`` of pyproject.toml.
"""

from __future__ import annotations

import subprocess
from importlib.metadata import PackageNotFoundError, version as _version
from pathlib import Path

try:
    from . import _scm_version as _built
except ImportError:  # built by a tool that wrote no version file, or a bare source tree
    _built = None

if _built is not None:
    __version__: str = _built.__version__
else:
    try:
        __version__ = _version("flagellum")
    except PackageNotFoundError:
        __version__ = "0.0.0+unknown"


def git_revision() -> str:
    """The commit the package runs from: HEAD of its checkout (an editable install, which
    may have moved on since it was built), else the commit it was built from ("" if unknown)."""
    root = Path(__file__).resolve().parents[2]
    if (root / "pyproject.toml").is_file() and (root / ".git").exists():
        try:
            rev = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                                 timeout=5, cwd=root).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            rev = ""
        if rev:
            return rev
    built = str(getattr(_built, "commit_id", None) or "")
    return built[1:] if built.startswith("g") else built  # git describe's "g<hash>"
