"""Shared test helpers: running the CLI (in process or as a subprocess) and checking the
one-line error contract (one line on stderr naming the parameter, exit code 2, no traceback)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

# no background warm-up of Numba's cache (flagellum.integrate.cache) from test processes:
# the tests of the warm-up start it themselves
os.environ.setdefault("FLAGELLUM_WARMUP", "0")


def run_cli_subprocess(*args, timeout: float = 600, **kw) -> subprocess.CompletedProcess:
    """``python -m flagellum ARGS`` in a fresh interpreter (text mode, output captured)."""
    return subprocess.run([sys.executable, "-m", "flagellum", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, **kw)


def assert_one_line_error(code: int, err: str, name: str | None = None) -> None:
    """Exit code 2, exactly one line on stderr, no traceback, and (if given) the parameter
    ``name`` mentioned in its underscore or dashed spelling."""
    assert code == 2, (code, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    if name is not None:
        assert name in err or name.replace("_", "-") in err, (name, err)


@pytest.fixture
def cli(capsys):
    """Run the CLI in process: ``code, out, err = cli("simulate", "--torque", 1)``."""
    from flagellum.cli import run

    def _run(*args):
        capsys.readouterr()
        code = run([str(a) for a in args])
        cap = capsys.readouterr()
        return code, cap.out, cap.err

    return _run
