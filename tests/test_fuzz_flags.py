"""Every flag of every command, read from the CLI itself, gets a set of bad values; each
invocation must keep the one-line contract of ``flagellum.cli.run``: exit 0, or exit 2 with
exactly one line ``flagellum: error: …`` on stderr; never a traceback, an escaped exception,
a hang, or a file left behind by a failed command.

The flags are not listed here: :func:`invocations` walks the click commands of
``flagellum.cli.main`` and derives the bad values from each option's type (float, int,
choice, path, free text, flag, two numbers) and name. Values are drawn with a seeded
generator (``FLAGELLUM_FUZZ_SEED``, default 0; ``FLAGELLUM_FUZZ_VALUES`` values per flag,
default 8, ``0``: every value of its pool), so a failure names a reproducible command line.
Commands that would start long work are stopped where it starts (``no_work``, as in
``test_fuzz_commands.py``): an input that gets that far passed every check.
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import shutil
import signal
from pathlib import Path

import click
import pytest
from conftest import run_cli_subprocess
from test_fuzz_commands import WorkStarted, no_work  # noqa: F401  (fixture)

from flagellum.cli import main, run

SEED = int(os.environ.get("FLAGELLUM_FUZZ_SEED", "0"))
PER_FLAG = int(os.environ.get("FLAGELLUM_FUZZ_VALUES", "8"))
COMBOS = int(os.environ.get("FLAGELLUM_FUZZ_COMBOS", "12"))  # random multi-flag lines per command
TIMEOUT = 30.0  #: seconds one in-process invocation may take before it counts as a hang
PREFIX = "flagellum: error: "

# -- value pools by option kind ---------------------------------------------------------------

FLOATS = ["nan", "-nan", "inf", "-inf", "-1", "0", "-0", "1e308", "-1e308", "1e-320", "-1e-320",
          "5e-324", "1e400", "99999999999999999999999", "-99999999999999999999999", "", " ",
          "abc", "1,2", "1e", "0x10", "--json"]
INTS = ["-1", "0", "-0", "99999999999999999999999", str(2 ** 63), str(-2 ** 63 - 1), "1.5",
        "1e3", "nan", "inf", "", "abc", "-99999999999999999999"]
TEXT = FLOATS + ["1:3:1", "3:1:1", "1:2:0", "1:2:-1", "0:1e9:1e-9", "1:1e308:1e-308", "a,b",
                 "1,nan", "1,,2", ",", ":", "::", "nan:1", "-1,2", "1e400,1", "true", "x=1", "=",
                 "method=", "rtol=nan", "e-coli", "file", "fifo", "/dev/zero", "x" * 300]
#: paths, relative to the scratch directory that :func:`_fill` fills
PATHS = ["", " ", ".", "missing.h5", "missing/sub/x.h5", "fifo", "dir", "file/under", "/dev/zero",
         "/dev/null", "link", "dangling", "a" * 300, "traj.h5", "garbage.h5", "empty",
         "bad.toml", "/proc/none/x"]
FIGURES = ["", "fig9", "../x", "FIG3", "fig3 ", "x" * 300, "all"]
#: option names that take a file or folder although their click type is free text
PATH_NAMES = {"motor_law", "file", "config", "resume_file", "plot", "movie", "snapshots"}

#: the arguments each command needs to get past its required options; the fuzzed flag is
#: appended (click takes an option's last value) or replaces the positional argument
BASE = {
    "rft": [], "demo": [], "info": ["traj.h5"], "bench": [], "simulate": ["--length", "2"],
    "stability": ["--length", "2", "--torque", "0.5"], "critical-torque": ["--length", "2"],
    "bifurcations": ["--length", "2"], "theory buckling": [],
    "theory manifold": ["-o", "m"], "theory rigid-helix": ["--length", "2"],
    "theory effective-rigidity": [], "sweep": ["--torque", "1", "--out", "r.h5"],
    "reproduce": ["fig3"], "render": ["traj.h5", "--snapshots", "s"],
    "export": ["traj.h5", "--out", "e"], "polymorph-thresholds": ["--length", "2"],
}


def commands(group: click.Group = main, path: tuple = ()):
    """(name, command) of every leaf command, e.g. ``("theory buckling", …)``."""
    for name, cmd in group.commands.items():
        if isinstance(cmd, click.Group):
            yield from commands(cmd, (*path, name))
        else:
            yield " ".join((*path, name)), cmd


def pool(param: click.Parameter, command: str) -> list:
    """Bad (and a few valid) values for ``param``: each a list of words (none: a flag)."""
    t = param.type
    if isinstance(param, click.Option) and param.is_flag:
        return [[]]
    if param.name == "figure":
        return [[v] for v in FIGURES]
    if isinstance(t, click.Path) or param.name in PATH_NAMES:
        return [[v] for v in PATHS]
    if param.nargs == 2:
        singles = ["1", "0.5", "nan", "-1", "2", "1e308", "0", "inf"]
        return [[a, b] for a in singles for b in singles]
    if isinstance(t, click.Choice):
        c = list(t.choices)
        return [[v] for v in ["", "x", c[0].upper(), c[0] + " ", "1", "nan", *c]]
    if isinstance(t, click.types.IntParamType):
        return [[v] for v in INTS]
    if isinstance(t, click.types.FloatParamType):
        return [[v] for v in FLOATS]
    return [[v] for v in TEXT]


def with_param(base: list, param: click.Parameter, values: list) -> list:
    """``base`` with ``param`` set to ``values``: an option is appended (click takes its last
    value), the positional argument (each command has at most one) replaces the first word
    of ``base`` when that is one."""
    if isinstance(param, click.Option):
        return [*base, param.opts[0], *values]
    if base and not base[0].startswith("-"):
        return [*values, *base[1:]]
    return [*values, *base]


def invocations(seed: int = SEED, per_flag: int = PER_FLAG, combos: int = COMBOS):
    """Every command line the fuzz runs: (command, argv)."""
    rng = random.Random(seed)
    out = []
    for name, cmd in commands():
        base = BASE[name]
        params = [p for p in cmd.params if p.name not in ("help", "as_json")]
        for p in params:
            values = pool(p, name)
            chosen = values if per_flag <= 0 or per_flag >= len(values) else rng.sample(values, per_flag)
            for v in chosen:
                out.append((name, [*name.split(), *with_param(base, p, v), "--json"]))
        for _ in range(combos):  # several odd values at once (interactions, debris)
            args = list(base)
            for p in rng.sample(params, min(len(params), rng.randint(2, 4))):
                args = with_param(args, p, rng.choice(pool(p, name)))
            out.append((name, [*name.split(), *args, "--json"]))
    return out


# -- the scratch directory every invocation runs in -------------------------------------------

@pytest.fixture(scope="module")
def template(tmp_path_factory):
    """Files the path values refer to; copied into a fresh scratch directory as needed."""
    from flagellum import Params
    from flagellum.motor import Motor
    from flagellum.simulator import Simulator

    d = tmp_path_factory.mktemp("fuzz-template")
    Simulator(Params.from_flat({"length": 2.0}), Motor(0.5)).run(0.004, 1e-3, output=d / "traj.h5",
                                                                  progress=False)
    (d / "garbage.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)))
    (d / "empty").write_bytes(b"")
    (d / "bad.toml").write_text("[filament]\nlength = -1\n[nope]\n")
    (d / "file").write_text("a regular file")
    (d / "dir").mkdir()
    return d


def _fill(template: Path, d: Path) -> None:
    if d.exists():
        shutil.rmtree(d)
    shutil.copytree(template, d, symlinks=True)
    os.mkfifo(d / "fifo")
    os.symlink("file", d / "link")
    os.symlink("nowhere", d / "dangling")


def _snapshot(d: Path) -> dict:
    out = {}
    for p in d.rglob("*"):
        st = p.lstat()
        out[str(p.relative_to(d))] = (st.st_mode, st.st_size, st.st_mtime_ns)
    return out


class Hang(BaseException):
    """An invocation ran past :data:`TIMEOUT` (BaseException: no ``except Exception`` eats it)."""


def _alarm(signum, frame):
    raise Hang


def run_one(argv: list, d: Path, timeout: float = TIMEOUT) -> tuple[str | None, int | None, str]:
    """Run ``argv`` in process in ``d``; return (defect or None, exit code, stderr)."""
    err = io.StringIO()
    cwd = os.getcwd()
    os.chdir(d)
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = run(argv)
    except WorkStarted:
        return None, None, ""
    except Hang:
        return f"no answer within {timeout:g} s", None, err.getvalue()
    except BaseException as exc:  # anything escaping run() is a defect, also SystemExit
        return f"{type(exc).__name__} escaped: {exc}", None, err.getvalue()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
        os.chdir(cwd)
    text = err.getvalue()
    lines = text.strip().splitlines()
    if "Traceback" in text:
        return "traceback", code, text
    if code == 2:
        if len(lines) != 1 or not lines[0].startswith(PREFIX):
            return f"{len(lines)} lines on stderr", code, text
        return None, code, text
    if code != 0:
        return f"exit code {code}", code, text
    if any(line.startswith(PREFIX) for line in lines):
        return "an error line with exit code 0", code, text
    return None, code, text


def fuzz(cases, template: Path, d: Path, timeout: float = TIMEOUT) -> tuple[list, list]:
    """Run ``cases``; return (defects, the failed invocations with their one line)."""
    _fill(template, d)
    clean = _snapshot(d)
    defects, refused = [], []
    for name, argv in cases:
        problem, code, text = run_one(argv, d, timeout)
        now = _snapshot(d)
        if code == 2 and problem is None:
            left = sorted(set(now) - set(clean))
            if left:
                problem = f"left behind {left[:3]}"
            refused.append((name, argv, text.strip()))
        if problem:
            defects.append(f"{' '.join(map(repr, argv))}: {problem}: {text.strip()[:300]}")
        if now != clean:  # a run that wrote (or a defect): start the next from the template
            _fill(template, d)
            clean = _snapshot(d)
    return defects, refused


CASES = invocations()
NAMES = sorted({name for name, _ in CASES})


def test_every_command_and_flag_is_fuzzed():
    """The fuzz reads the commands from the CLI: every leaf command has its base arguments,
    and every one of its parameters appears in some invocation."""
    assert {name for name, _ in commands()} == set(BASE)
    for name, cmd in commands():
        lines = [argv for n, argv in CASES if n == name]
        for p in cmd.params:
            if isinstance(p, click.Option) and p.name not in ("help", "as_json"):
                assert any(p.opts[0] in argv for argv in lines), (name, p.opts[0])
    assert len(CASES) > 2000


@pytest.mark.parametrize("name", NAMES)
def test_every_flag_keeps_the_one_line_contract(name, template, tmp_path, no_work):
    defects, refused = fuzz([c for c in CASES if c[0] == name], template, tmp_path / "scratch")
    assert not defects, f"{len(defects)} defects:\n" + "\n".join(defects[:25])
    assert refused  # the bad values were really refused (otherwise the test proved nothing)


def test_a_sample_keeps_the_contract_in_a_fresh_process(template, tmp_path, no_work):
    """In a real process C-level output (SUNDIALS, HDF5) also reaches stderr: a seeded sample
    of invocations that are refused in process, a few per command, still give exactly one
    line and exit code 2 as ``python -m flagellum``."""
    rng = random.Random(SEED)
    d = tmp_path / "scratch"
    _fill(template, d)
    for name in ["simulate", "sweep", "info", "render", "theory buckling"]:
        candidates = [a for n, a in CASES if n == name]
        rng.shuffle(candidates)
        argv = next(a for a in candidates if run_one(a, d)[1] == 2)
        _fill(template, d)
        r = run_cli_subprocess(*argv, cwd=d, timeout=120)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and "Traceback" not in r.stderr, (argv, r.stderr)
        assert len(lines) == 1 and lines[0].startswith(PREFIX), (argv, r.stderr)
        assert _snapshot(d).keys() == _snapshot(template).keys() | {"fifo", "link", "dangling"}


@pytest.mark.slow
@pytest.mark.ci
def test_a_sample_keeps_the_contract_when_the_work_runs(template, tmp_path):
    """A seeded sample run for real, nothing stopped: short simulations (the fuzzed flag
    after a 3-ms run's settings, so that it wins), movies, snapshots and exports. A failure
    inside the work (CVODE giving up, a blow-up, a write) must keep the contract too."""
    rng = random.Random(SEED + 1)
    short = ["--time", "0.003", "--save-every", "1e-3"]
    sample = []
    for name, k in (("simulate", 16), ("render", 4), ("export", 4)):
        lines = [a for n, a in CASES if n == name]
        for argv in rng.sample(lines, k):
            if name == "simulate":
                argv = [*argv[:3], *short, *argv[3:]]
            sample.append((name, argv))
    defects, _ = fuzz(sample, template, tmp_path / "scratch", timeout=120)
    assert not defects, "\n".join(defects)
