"""Command-line interface: ``flagellum COMMAND`` (one module per command or command group).

Every invalid input ends in one line on stderr and exit code 2 (see :func:`run`). Commands
import their heavy dependencies when they run, so that each command is listed by
``flagellum --help`` even where a package is missing; running it then names the package.
"""

from __future__ import annotations

import functools
import sys

import click

from .._version import __version__
from ..errors import FlagellumError
from . import (bench, bifurcations, demo, export, info, polymorph, render, reproduce, rft,
               simulate, stability, sweep, theory)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="flagellum")
def main():
    """Motor-driven bacterial flagella and their buckling instabilities (Vogel & Stark 2012).

    Units: µm, pN, s.
    """


COMMANDS = [rft.rft, demo.demo, simulate.simulate, info.info, bench.bench, stability.stability,
            stability.critical_torque, bifurcations.bifurcations, theory.theory, sweep.sweep,
            reproduce.reproduce, render.render, export.export, polymorph.polymorph_thresholds]

#: pip names of the packages whose import name differs
_PIP_NAMES = {"sksundae": "scikit-sundae", "imageio_ffmpeg": "imageio-ffmpeg",
              "distributed": "dask[distributed]", "yaml": "pyyaml"}


class MissingPackage(click.ClickException):
    """A command needs a package that is not installed."""

    def __init__(self, command: str, module: str):
        pip = _PIP_NAMES.get(module, module)
        super().__init__(f"command '{command}' needs the package '{pip}' (pip install {pip})")


def _needs_packages(cmd: click.Command, path: str) -> None:
    """Report a package missing at run time of ``cmd`` (and of its subcommands)."""
    if isinstance(cmd, click.Group):
        for name, sub in cmd.commands.items():
            _needs_packages(sub, f"{path} {name}")
    callback = cmd.callback
    if callback is None:
        return

    @functools.wraps(callback)
    def wrapped(*args, **kwargs):
        try:
            return callback(*args, **kwargs)
        except ModuleNotFoundError as exc:
            top = (exc.name or "").partition(".")[0]
            if not top or top == "flagellum":  # not a missing third-party package
                raise
            raise MissingPackage(path, top) from exc

    cmd.callback = wrapped


for _cmd in COMMANDS:
    _needs_packages(_cmd, _cmd.name)
    main.add_command(_cmd)


def run(argv=None) -> int:
    """Entry point: run the CLI, turning every user error into one line and exit code 2.

    Python warnings (numpy's of an overflow inside a rejected trial step, say) are shown
    after a command that succeeds; a command that fails prints its one line only."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        code = _run(argv)
    if code == 0:
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    return code


def _run(argv) -> int:
    try:
        main.main(args=argv, prog_name="flagellum", standalone_mode=False)
    except FlagellumError as exc:
        click.echo(f"flagellum: error: {' '.join(str(exc).split())}", err=True)  # one line
        return 2
    except click.exceptions.Abort:
        click.echo("flagellum: aborted", err=True)
        return 130
    except click.ClickException as exc:
        msg = " ".join(exc.format_message().split())
        click.echo(f"flagellum: error: {msg}", err=True)
        return 2
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except OSError as exc:  # the file system refused: not a directory, unwritable, disk full
        where = f": {exc.filename}" if exc.filename else ""
        click.echo(f"flagellum: error: {exc.strerror or exc}{where}", err=True)
        return 2
    return 0


def keep_stdout_for_results() -> None:
    """Route file descriptor 1 to stderr and give Python's stdout a private copy of the real
    stdout: C libraries write there (SUNDIALS prints its warnings, e.g. "t + h = t", to fd 1
    and is not told otherwise through scikit-sundae), which made ``--json`` output
    unparseable. Child processes inherit the routing."""
    import os

    try:
        if sys.stdout.fileno() != 1:
            return
    except (AttributeError, OSError, ValueError):  # replaced stdout (tests, notebooks)
        return
    sys.stdout.flush()
    real = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = open(real, "w", encoding=sys.stdout.encoding, errors=sys.stdout.errors)


def entry():  # console script
    keep_stdout_for_results()
    sys.exit(run())
