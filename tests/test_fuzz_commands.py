"""Property-based fuzz of every CLI command: adversarial values and files end in exit 0, or
exit 2 with one line ``flagellum: error: …`` on stderr, never a traceback, a hang or a file
left behind. Commands that would run long are stopped where their work starts (the
simulation loop, the sweep's workers, a figure, the manifold grid, the bisection): every
input must be rejected before that or be valid."""

import contextlib
import io
import os
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flagellum.cli import main, run

#: examples per test: few in CI; FLAGELLUM_FUZZ_EXAMPLES=1000 for a deep search
EXAMPLES = int(os.environ.get("FLAGELLUM_FUZZ_EXAMPLES", "20"))
FAST = settings(max_examples=EXAMPLES, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

#: numbers as typed on a command line: non-finite, negative, zero, huge, tiny, not a number
NUMBERS = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "-1", "0", "-0", "1e400", "1e308", "-1e308", "1e-320",
                     "abc", "", " ", "0x10", "1,2", "1:2", "--json", "3", "0.5", "2", "1e-3"]),
    st.floats().map(repr), st.integers(-10**12, 10**12).map(str), st.text(max_size=6))
PARAM_FLAGS = ["--kappa0", "--tau0", "--bend-rigidity", "--twist-rigidity", "--stretch-modulus",
               "--length", "--segment-length", "--viscosity", "--filament-radius", "--kT",
               "--gamma-par", "--gamma-perp", "--gamma-rot"]
CHOICE_FLAGS = {"--handedness": ["right", "left"], "--friction": ["paper", "lighthill", "custom"]}
TOML = st.one_of(
    st.text(max_size=40),
    st.builds(lambda sec, key, val: f"[{sec}]\n{key} = {val}\n",
              st.sampled_from(["filament", "fluid", "friction", "bogus", "fixed", "ranges"]),
              st.sampled_from(["length", "kT", "friction", "model", "torque", "nope", "time"]),
              st.sampled_from(["nan", "inf", "-1", "0", "1e400", "'x'", "[1, 2]", "{}", "true",
                               "'1:0:1'", "'a,b'", "2"])))


class WorkStarted(Exception):
    """Raised where a long command's real work would begin (its input was accepted)."""


def _stop(*a, **kw):
    raise WorkStarted


@pytest.fixture
def no_work(monkeypatch):
    """Stop every long-running computation where it starts."""
    import flagellum.analysis.stability as stability
    import flagellum.reproduce as reproduce
    import flagellum.sweep as sweep
    import flagellum.theory.manifold as manifold
    from flagellum.simulator import Simulator

    monkeypatch.setattr(Simulator, "_loop", _stop)  # simulate, demo, bench
    monkeypatch.setattr(sweep, "process_pool", _stop)
    monkeypatch.setattr(sweep, "dask_pool", _stop)
    monkeypatch.setattr(manifold, "compute_manifold", _stop)
    monkeypatch.setattr(stability, "_Branch", _stop)  # critical-torque
    monkeypatch.setattr(reproduce, "Timer", _stop)  # reproduce: after its checks
    import flagellum.analysis.bifurcations as bifurcations
    import flagellum.export as export
    import flagellum.theory.effective_rigidity as effective_rigidity
    import flagellum.viz as viz

    monkeypatch.setattr(bifurcations, "_executor", _stop)  # the M_c2 scan
    monkeypatch.setattr(viz, "_frames", _stop)  # render: drawing the frames
    monkeypatch.setattr(export, "write_vtp", _stop)  # export: writing the frames
    monkeypatch.setattr(effective_rigidity, "measured_bending_rigidity", _stop)  # --measure


def _files(d: Path) -> set:
    return {str(p.relative_to(d)) for p in d.rglob("*")}


def check(args, workdir: Path, allow_work=False):
    """Run the CLI; assert exit 0, or 2 with one clean line and no new file. Returns the code."""
    before = _files(workdir)
    err = io.StringIO()
    cwd = os.getcwd()
    os.chdir(workdir)  # default output folders land in the scratch directory
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = run(args)
    except WorkStarted:
        assert allow_work, args
        return 0
    finally:
        os.chdir(cwd)
    text = err.getvalue()
    assert "Traceback" not in text, (args, text)
    assert code in (0, 2), (args, code, text)
    if code == 2:
        lines = text.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("flagellum: error: "), (args, text)
        assert _files(workdir) == before, (args, "left behind", _files(workdir) - before)
    return code


def _scratch():
    return tempfile.TemporaryDirectory(prefix="fuzz-")


def flags(names, values=NUMBERS, max_size=3):
    return st.lists(st.tuples(st.sampled_from(names), values), min_size=1, max_size=max_size)


def _flat(pairs):
    return [x for pair in pairs for x in pair]


def test_every_command_is_fuzzed():
    """A new command must be added to this file."""
    fuzzed = {"rft", "info", "demo", "bench", "simulate", "stability", "critical-torque", "sweep",
              "reproduce", "render", "export", "theory", "bifurcations", "polymorph-thresholds"}
    assert set(main.commands) == fuzzed
    assert set(main.commands["theory"].commands) == {"buckling", "manifold", "rigid-helix",
                                                     "effective-rigidity"}


# -- parameter layer: cheap commands run in full ------------------------------------------

@FAST
@given(cmd=st.sampled_from([["rft"], ["theory", "effective-rigidity"],
                            ["stability", "--length", "2", "--torque", "0.5"]]),
       pairs=flags(PARAM_FLAGS), choice=st.sampled_from(sorted(CHOICE_FLAGS)),
       choice_value=st.text(max_size=6) | st.sampled_from(["right", "custom", "lighthill"]),
       config=st.none() | TOML)
def test_parameter_flags_and_config(cmd, pairs, choice, choice_value, config):
    with _scratch() as d:
        extra = []
        if config is not None:
            (Path(d) / "c.toml").write_text(config)
            extra = ["--config", "c.toml"]
        check([*cmd, *_flat(pairs), choice, choice_value, *extra, "--json"], Path(d))


@FAST
@given(pairs=flags(["--torque", "--n-eigs", "--sphere-radius", "--hook-stiffness", "--hook"],
                   NUMBERS | st.sampled_from(["free", "elastic", "clamped"])))
def test_stability(pairs):
    with _scratch() as d:
        check(["stability", "--length", "2", "--torque", "0.5", *_flat(pairs), "--json"], Path(d))


@FAST
@given(lo=NUMBERS, hi=NUMBERS, xtol=NUMBERS, more=st.lists(NUMBERS, max_size=1))
def test_critical_torque(no_work, lo, hi, xtol, more):
    with _scratch() as d:
        check(["critical-torque", "--length", "2", "--bracket", lo, hi, *more, "--xtol", xtol],
              Path(d), allow_work=True)


@FAST
@given(lo=NUMBERS, hi=NUMBERS,
       pairs=flags(["--time", "--tol", "--min-fraction", "--polymorph-barrier",
                    "--polymorph-energies", "--polymorphic", "--polymorph-initial"],
                   NUMBERS | st.sampled_from(["normal", "normal,semicoiled", "curly1,normal",
                                              "0,1", "0,0.1"])),
       which=st.sampled_from(["--bracket-down", "--bracket-up"]))
def test_polymorph_thresholds(no_work, lo, hi, pairs, which):
    with _scratch() as d:
        check(["polymorph-thresholds", "--length", "2", which, lo, hi, *_flat(pairs)],
              Path(d), allow_work=True)


@FAST
@given(pairs=flags(["--torque-range", "--t-end", "--tol", "--confirm-mc1", "--workers",
                    "--sphere-radius", "--quality", "--length"],
                   NUMBERS | st.sampled_from(["1:3", "3:1", "1:2:0", "quick", "full", "x:y"])),
       out=st.sampled_from([[], ["-o", "r.json"], ["-o", "f/r.json"], ["-o", "d"]]),
       mc1_only=st.booleans())
def test_bifurcations(no_work, pairs, out, mc1_only):
    with _scratch() as d:
        (Path(d) / "f").write_text("a file")
        (Path(d) / "d").mkdir()
        check(["bifurcations", *_flat(pairs), *out, *["--mc1-only"] * mc1_only, "--json"],
              Path(d), allow_work=True)


# -- theory -----------------------------------------------------------------------------

@FAST
@given(pairs=flags(["--m-hat", "--f-par", "--f-perp", "--chi", "--samples"]),
       words=flags(["--base", "--top", "--force-profile", "--torque-profile", "--solve",
                    "--guess", "--method"],
                   st.sampled_from(["hinged", "clamped", "free", "linear", "uniform", "m_hat",
                                    "f_perp,chi", "chi", "f_par", "shooting", "collocation",
                                    "1,2", "nan,1", "", "x,y,z"]) | st.text(max_size=5),
                   max_size=2))
def test_theory_buckling(pairs, words):
    with _scratch() as d:
        check(["theory", "buckling", *_flat(pairs), *_flat(words), "--json"], Path(d))


@FAST
@given(pairs=flags(["--torque", "--tilt", "--time", "--origin"],
                   NUMBERS | st.sampled_from(["center", "end"])))
def test_theory_rigid_helix(pairs):
    with _scratch() as d:
        check(["theory", "rigid-helix", "--length", "2", *_flat(pairs), "--json"], Path(d))


@FAST
@given(pairs=flags(["--m-max", "--m-steps", "--f-par-max", "--f-par-steps", "--inv-a-max",
                    "--inv-a-steps", "--base", "--workers", *PARAM_FLAGS[:4]]))
def test_theory_manifold(no_work, pairs):
    with _scratch() as d:
        check(["theory", "manifold", "--out", "m", *_flat(pairs)], Path(d), allow_work=True)


# -- simulate, demo, bench: everything up to the simulation loop --------------------------

SIMULATE_FLAGS = ["--torque", "--ramp-time", "--sphere-radius", "--hook-stiffness", "--time",
                  "--save-every", "--average-from", "--seed", "--rtol", "--dt", "--theta",
                  "--frame", "--checkpoint-every", *PARAM_FLAGS]
WORDS = st.sampled_from(["fixed", "sphere", "free", "elastic", "clamped", "cvode", "implicit",
                         "auto", "lab", "x"])


@FAST
@given(pairs=flags(SIMULATE_FLAGS),
       words=flags(["--anchor", "--hook", "--method", "--frame"], WORDS, max_size=2),
       thermal=st.booleans(), output=st.sampled_from([None, "o.h5", "sub/o.h5", "f/o.h5", "d"]))
def test_simulate(no_work, pairs, words, thermal, output):
    with _scratch() as d:
        (Path(d) / "f").write_text("a file")
        (Path(d) / "d").mkdir()
        args = ["simulate", "--length", "2", *_flat(pairs), *_flat(words)]
        args += ["--thermal"] * thermal + (["-o", output] if output else [])
        check(args, Path(d), allow_work=True)


@FAST
@given(out=st.sampled_from(["f", "f/sub", "/proc/none", "ok"]), window=NUMBERS)
def test_demo_and_bench(no_work, out, window):
    with _scratch() as d:
        (Path(d) / "f").write_text("a file")
        check(["demo", "--out", out, "--json"], Path(d), allow_work=True)
        check(["bench", "--window", window, "--json"], Path(d), allow_work=True)


# -- sweep, reproduce ----------------------------------------------------------------------

SWEEP_FLAGS = ["--torque", "--length", "--time", "--save-every", "--seed", "--kT", "--dt",
               "--hook", "--method", "--thermal", "--friction"]
RANGES = NUMBERS | st.sampled_from(["1:3:1", "3:1:1", "1:2:0", "1:2:-1", "0:1e9:1e-9", "1,1",
                                    "a,b", "1,nan", ":", "1:", "::", "true", "yes", "cvode",
                                    "elastic"])


@FAST
@given(pairs=flags(SWEEP_FLAGS, RANGES, max_size=2), config=st.none() | TOML,
       opts=st.lists(st.sampled_from(["--resume", "--overwrite", "--workers=0", "--workers=-1",
                                      "--dask-local=0", "--scheduler=tcp://nowhere:1"]),
                     max_size=2))
def test_sweep(no_work, pairs, config, opts):
    with _scratch() as d:
        cfg = []
        if config is not None:
            (Path(d) / "s.toml").write_text(config)
            cfg = ["s.toml"]
        check(["sweep", *cfg, *_flat(pairs), *opts, "--out", "r.h5", "--json"], Path(d),
              allow_work=True)


@FAST
@given(fig=st.sampled_from(["fig3", "FIG5", "all", "fig9", "", "../x"]) | st.text(max_size=4),
       quality=st.sampled_from(["quick", "full", "medium", ""]), out=st.sampled_from(["o", "f", "f/x"]))
def test_reproduce(no_work, fig, quality, out):
    with _scratch() as d:
        (Path(d) / "f").write_text("a file")
        check(["reproduce", fig, "--quality", quality, "--out", out, "--json"], Path(d),
              allow_work=True)


# -- files: info, render, export, simulate --resume ------------------------------------

@pytest.fixture(scope="module")
def trajectory(tmp_path_factory):
    from flagellum import Params
    from flagellum.motor import Motor
    from flagellum.simulator import Simulator

    path = tmp_path_factory.mktemp("traj") / "t.h5"
    Simulator(Params.from_flat({"length": 2.0}), Motor(0.5)).run(0.004, 1e-3, output=path,
                                                                  progress=False)
    return path


def _h5_with(path, name, value):
    with h5py.File(path, "w") as f:
        f[name] = value
        f.attrs["status"] = "running"


FILES = st.one_of(
    st.just(("missing",)), st.just(("dir",)), st.just(("valid",)),
    st.tuples(st.just("bytes"), st.binary(max_size=64)),
    st.tuples(st.just("truncated"), st.floats(0, 1)),
    st.tuples(st.just("h5"), st.sampled_from(["t", "positions", "final_state", "x"]),
              st.sampled_from([np.zeros(3), np.zeros((2, 3)), np.array([b"a", b"b"]), np.float64(1),
                               np.zeros((0,)), np.full(4, np.nan)])))


def _make(kind, d: Path, trajectory: Path) -> Path:
    p, data = d / "in.h5", trajectory.read_bytes()
    if kind[0] == "dir":
        p.mkdir()
    elif kind[0] == "valid":
        p.write_bytes(data)
    elif kind[0] == "bytes":
        p.write_bytes(kind[1])
    elif kind[0] == "truncated":
        p.write_bytes(data[:int(kind[1] * len(data))])
    elif kind[0] == "h5":
        _h5_with(p, kind[1], kind[2])
    return p


@FAST
@given(kind=FILES, every=NUMBERS, fmt=st.sampled_from(["vtk", "csv", ""]),
       out=st.sampled_from(["e", "in.h5", "f/x"]))
def test_info_export_and_resume(trajectory, kind, every, fmt, out):
    with _scratch() as d:
        d = Path(d)
        (d / "f").write_text("a file")
        p = _make(kind, d, trajectory)
        check(["info", str(p), "--json"], d)
        check(["export", str(p), "--out", out, "--every", every, "--format", fmt, "--json"], d)
        if kind[0] != "valid":  # (a finished run resumes to itself)
            check(["simulate", "--resume", str(p), "--json"], d)


@settings(FAST, max_examples=max(1, EXAMPLES // 2))
@given(kind=FILES, pairs=flags(["--frames", "--fps", "--count"], max_size=2),
       dest=st.sampled_from([["--snapshots", "s"], ["--snapshots", "f"], ["--movie", "m.avi"],
                             ["--movie", "f/m.mp4"], []]))
def test_render(trajectory, kind, pairs, dest):
    with _scratch() as d:
        d = Path(d)
        (d / "f").write_text("a file")
        p = _make(kind, d, trajectory)
        check(["render", str(p), *_flat(pairs), *dest, "--json"], d)
