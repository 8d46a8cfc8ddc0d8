"""CLI contract: JSON output, one-line errors with exit code 2, no traceback."""

import json
import subprocess
import sys

import pytest
from conftest import assert_one_line_error, run_cli_subprocess

from flagellum.cli import run
from flagellum.errors import ParameterError


def test_version():
    r = run_cli_subprocess("--version")
    assert r.returncode == 0 and "flagellum" in r.stdout
    r = subprocess.run([sys.executable, "-m", "flagellum.cli", "--version"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and "flagellum" in r.stdout


def test_rft_json_keys_and_values():
    r = run_cli_subprocess("rft", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    for k in ("radius", "pitch", "pitch_angle_deg", "axial_length", "gamma_par", "gamma_perp",
              "gamma_rot", "lighthill", "A_par", "A_perp", "B_par", "C_par",
              "thrust_per_torque", "omega_per_torque", "A_eff", "pinned",
              "critical_torque_line"):
        assert k in d
    assert d["radius"] == pytest.approx(0.213, abs=1e-3)
    assert d["axial_length"] == pytest.approx(8.50, abs=0.01)
    assert set(d["pinned"]) >= {"thrust_per_torque", "omega_per_torque", "axis_tilt_deg"}
    assert set(d["critical_torque_line"]) >= {"intercept", "slope_per_inverse_radius"}


def test_rft_flags_change_values():
    d = json.loads(run_cli_subprocess("rft", "--json", "--handedness", "left", "--friction",
                                      "lighthill").stdout)
    assert d["thrust_per_torque"] < 0
    assert d["gamma_par"] == d["lighthill"]["gamma_par"]


@pytest.mark.parametrize("args,name", [
    (["--length", "-1"], "length"), (["--segment-length", "0.3"], "segment_length"),
    (["--kappa0", "nan"], "kappa0"), (["--viscosity", "0"], "viscosity"),
    (["--length", "abc"], "length"), (["--friction", "magic"], "friction"),
    (["--config", "/nonexistent.toml"], "config"), (["--critical-force", "inf"], "critical_force"),
])
def test_bad_input_one_line_exit_2(args, name, cli):
    code, _, err = cli("rft", *args)
    assert_one_line_error(code, err, name)


def test_bad_input_subprocess_has_no_traceback():
    r = run_cli_subprocess("rft", "--length", "-1")
    assert_one_line_error(r.returncode, r.stderr)


def test_c_level_stdout_does_not_spoil_json():
    """Libraries that write to file descriptor 1 (SUNDIALS' warnings) end up on stderr; the
    results printed by the CLI stay alone on stdout."""
    code = ("import os, sys; from flagellum import cli; from flagellum.cli._output import emit_json; "
            "cli.keep_stdout_for_results(); "
            "os.write(1, b'[WARNING] from C\\n'); emit_json({'a': 1}); sys.stdout.flush(); "
            "os.write(1, b'[WARNING] again\\n')")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(res.stdout) == {"a": 1}
    assert res.stderr.count("[WARNING]") == 2


# -- registration and missing packages ------------------------------------------------------

def _listed_commands(help_text: str) -> set:
    lines = help_text.split("Commands:", 1)[1].splitlines()
    return {line.split()[0] for line in lines if line.startswith("  ") and line.strip()}


def _python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


def test_help_lists_every_command_even_without_numba():
    from flagellum.cli import main

    assert _listed_commands(run_cli_subprocess("--help").stdout) == set(main.commands)
    r = _python("import sys; sys.modules['numba'] = None; from flagellum.cli import run; "
                "sys.exit(run(['--help']))")
    assert r.returncode == 0, r.stderr
    assert _listed_commands(r.stdout) == set(main.commands)


@pytest.mark.parametrize("package,args", [
    ("numba", ["theory", "buckling"]), ("numba", ["stability", "--torque", "1"]),
    ("scipy", ["critical-torque"]), ("h5py", ["info", "run.h5"]),
])
def test_missing_package_is_one_line_naming_it(package, args):
    r = _python(f"import sys; sys.modules[{package!r}] = None; from flagellum.cli import run; "
                f"sys.exit(run({args!r}))")
    assert_one_line_error(r.returncode, r.stderr)
    command = " ".join(a for a in args[:2] if not a.startswith("-") and a != "run.h5")
    assert r.stderr.strip() == (f"flagellum: error: command '{command}' needs the package "
                                f"'{package}' (pip install {package})")


# -- boundary flags: one builder for every command -----------------------------------------

#: the further arguments with which each command that takes boundary flags gets as far as
#: building its Boundary
BOUNDARY_COMMANDS = {
    "simulate": [], "stability": ["--torque", "1"], "critical-torque": [],
    "bifurcations": ["--mc1-only"], "sweep": ["--torque", "1", "--out", "{tmp}/s.nc"],
    "polymorph-thresholds": [],
}


class _Built(Exception):
    """Raised by the first Boundary a command builds, carrying it."""


@pytest.fixture
def first_boundary(monkeypatch):
    from flagellum.motor import Boundary

    post_init = Boundary.__post_init__

    def spy(self):
        post_init(self)
        raise _Built(self)

    monkeypatch.setattr(Boundary, "__post_init__", spy)


def _commands_with(param: str) -> set:
    """Names of the commands (in every group) that take the parameter ``param``."""
    from flagellum.cli import main

    def walk(group):
        for name, cmd in group.commands.items():
            if isinstance(cmd, type(main)):
                yield from walk(cmd)
            elif any(p.name == param for p in cmd.params):
                yield name

    return set(walk(main))


def test_boundary_commands_are_all_tested():
    assert _commands_with("hook_stiffness") == set(BOUNDARY_COMMANDS)


@pytest.mark.parametrize("command", sorted(BOUNDARY_COMMANDS))
@pytest.mark.parametrize("flag,value,expect", [
    ("--hook-stiffness", "0.5", {"hook": "elastic", "hook_stiffness": 0.5, "anchor": "fixed"}),
    ("--sphere-radius", "2", {"anchor": "sphere", "sphere_radius": 2.0, "hook": "free"}),
])
def test_boundary_flag_implies_its_kind(command, flag, value, expect, first_boundary, tmp_path):
    """``--hook-stiffness k`` alone is an elastic hook with that k and ``--sphere-radius a``
    alone a load sphere, in every command."""
    extra = [a.format(tmp=tmp_path) for a in BOUNDARY_COMMANDS[command]]
    with pytest.raises(_Built) as built:
        run([command, flag, value, *extra])
    b = built.value.args[0]
    assert {k: getattr(b, k) for k in expect} == expect


# -- drive flags: one builder for every command --------------------------------------------

#: the drive arguments with which each command that takes ``--motor-speed`` gets as far as
#: building a speed-clamped Motor (the threshold searches take the flag without a value:
#: they look for the critical rotation rate)
DRIVE_COMMANDS = {
    "simulate": ["--motor-speed", "500"], "stability": ["--motor-speed", "500"],
    "sweep": ["--motor-speed", "500", "--out", "{tmp}/s.nc"],
    "critical-torque": ["--motor-speed", "--segment-length", "0.4"],
    "bifurcations": ["--motor-speed", "--mc1-only", "--segment-length", "0.4"],
}


@pytest.fixture
def first_clamp(monkeypatch):
    """Raise _Built with the first speed-clamped Motor built."""
    from flagellum.motor import Motor

    post_init = Motor.__post_init__

    def spy(self):
        post_init(self)
        if self.drive == "speed":
            raise _Built(self)

    monkeypatch.setattr(Motor, "__post_init__", spy)


def test_drive_commands_are_all_tested():
    assert _commands_with("motor_speed") == set(DRIVE_COMMANDS)
    assert _commands_with("motor_law") == set(DRIVE_COMMANDS)


@pytest.mark.parametrize("command", sorted(DRIVE_COMMANDS))
def test_motor_speed_flag_is_a_speed_clamp(command, first_clamp, tmp_path):
    """``--motor-speed`` is a speed clamp in every command (for ``critical-torque`` and
    ``bifurcations``: the clamp whose critical rotation rate they find)."""
    extra = [a.format(tmp=tmp_path) for a in DRIVE_COMMANDS[command]]
    with pytest.raises(_Built) as built:
        run([command, *extra])
    m = built.value.args[0]
    assert m.drive == "speed"
    if command in ("simulate", "stability", "sweep"):
        assert m.speed == 500.0


@pytest.mark.parametrize("command", sorted(DRIVE_COMMANDS))
def test_two_drives_are_one_line_errors(command, cli, tmp_path):
    extra = [a.format(tmp=tmp_path) for a in DRIVE_COMMANDS[command]]
    flag = ["--motor-law", "e-coli"] if command in ("critical-torque", "bifurcations") else \
        ["--torque", "1"]
    code, _, err = cli(command, *extra, *flag)
    assert_one_line_error(code, err)
    assert not (tmp_path / "s.nc").exists()


# -- hydrodynamics flags: every command that builds a model -------------------------------

#: the further arguments with which each command that takes ``--hydrodynamics`` gets as far
#: as building its first model (sweep: its first point, in the parent process)
HYDRO_COMMANDS = {
    "simulate": [], "stability": ["--torque", "1"], "critical-torque": [],
    "bifurcations": ["--mc1-only"], "reproduce": ["fig3", "--output", "{tmp}/r"],
    "sweep": ["--torque", "1", "--out", "{tmp}/s.nc"],
}


@pytest.fixture
def first_hydrodynamics(monkeypatch):
    """Raise _Built with the mobility option of the first RodModel (or sweep point) built."""
    from flagellum import sweep
    from flagellum.rod.model import RodModel

    monkeypatch.setenv("FLAGELLUM_WORKERS", "1")  # reproduce: its runs in this process
    init, point = RodModel.__init__, sweep.PointRun.from_values.__func__

    def spy(self, *args, **kwargs):
        init(self, *args, **kwargs)
        raise _Built(self.hydrodynamics)

    def spy_point(cls, values):
        raise _Built(point(cls, values).hydrodynamics)

    monkeypatch.setattr(RodModel, "__init__", spy)
    monkeypatch.setattr(sweep.PointRun, "from_values", classmethod(spy_point))


#: the theory commands take ``--hydrodynamics`` for the effective rod's friction; they build
#: no RodModel but a :class:`~flagellum.theory.manifold.HelicalRod`
THEORY_HYDRO_COMMANDS = {
    "manifold": ["--out", "{tmp}/m", "--workers", "1"], "effective-rigidity": [],
}


def test_hydro_commands_are_all_tested():
    assert _commands_with("hydrodynamics") == set(HYDRO_COMMANDS) | set(THEORY_HYDRO_COMMANDS)


@pytest.mark.parametrize("command", sorted(THEORY_HYDRO_COMMANDS))
def test_hydrodynamics_flag_reaches_the_effective_rod(command, monkeypatch, tmp_path):
    """``theory … --hydrodynamics sbt`` is the friction model of the effective rod each
    theory command builds; without it the paper's full-turn RFT coefficients."""
    from flagellum.hydro.options import Hydrodynamics
    from flagellum.theory.manifold import HelicalRod

    def spy(cls, params=None, hydrodynamics=None):
        raise _Built(hydrodynamics)

    monkeypatch.setattr(HelicalRod, "from_params", classmethod(spy))
    extra = [a.format(tmp=tmp_path) for a in THEORY_HYDRO_COMMANDS[command]]
    with pytest.raises(_Built) as built:
        run(["theory", command, "--hydrodynamics", "sbt", *extra])
    assert built.value.args[0] == Hydrodynamics("sbt")
    with pytest.raises(_Built) as built:
        run(["theory", command, *extra])
    assert built.value.args[0] in (None, Hydrodynamics())


@pytest.mark.parametrize("command", sorted(HYDRO_COMMANDS))
def test_hydrodynamics_flag_reaches_the_model(command, first_hydrodynamics, tmp_path):
    """``--hydrodynamics sbt --hydro-refresh r`` is the mobility of the model each command
    builds (the linear stability evaluates it unfrozen: refresh 0)."""
    from flagellum.hydro.options import Hydrodynamics

    extra = [a.format(tmp=tmp_path) for a in HYDRO_COMMANDS[command]]
    with pytest.raises(_Built) as built:
        run([command, "--hydrodynamics", "sbt", "--hydro-refresh", "0.01", *extra])
    unfrozen = command in ("stability", "critical-torque", "bifurcations")
    assert built.value.args[0] == Hydrodynamics("sbt", 0.0 if unfrozen else 0.01)
    with pytest.raises(_Built) as built:  # the default: the paper's local drag
        run([command, *extra])
    assert built.value.args[0] == Hydrodynamics()


def test_boundary_from_flags_keeps_given_kinds():
    """Explicit kinds stay; a value the given kind would not use is refused, not dropped."""
    from flagellum.motor import Boundary

    assert Boundary.from_flags(hook_stiffness=0.5) == Boundary(hook="elastic", hook_stiffness=0.5)
    assert Boundary.from_flags(hook="free", hook_stiffness=0.0) == Boundary()
    assert Boundary.from_flags(hook="clamped") == Boundary(hook="clamped")
    for hook in ("free", "clamped"):
        with pytest.raises(ParameterError, match="hook_stiffness"):
            Boundary.from_flags(hook=hook, hook_stiffness=0.5)
    with pytest.raises(ParameterError, match="sphere_radius"):
        Boundary.from_flags(anchor="fixed", sphere_radius=1.0)
    assert Boundary.from_flags(sphere_radius=1.0) == Boundary(anchor="sphere", sphere_radius=1.0)
    assert Boundary.from_flags(anchor="free") == Boundary(anchor="free", sphere_radius=0.0)


def test_stability_hook_stiffness_is_an_elastic_hook(cli):
    """The growth rate with ``--hook-stiffness`` alone is that of the elastic hook, not the
    free one."""
    def lam(*flags):
        code, out, err = cli("stability", "--torque", "1.5", "--segment-length", "0.5",
                             "--n-eigs", "1", "--json", *flags)
        assert code == 0, err
        return json.loads(out)["lambda"]

    implied = lam("--hook-stiffness", "0.5")
    elastic = lam("--hook", "elastic", "--hook-stiffness", "0.5")
    assert implied == elastic
    assert abs(implied - lam()) > 1e-3 * abs(lam())
