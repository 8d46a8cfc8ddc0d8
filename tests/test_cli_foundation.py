"""CLI contract: JSON output, one-line errors with exit code 2, no traceback."""

import json
import subprocess
import sys

import pytest

from flagellum.cli import run


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flagellum.cli", *args],
                          capture_output=True, text=True, timeout=120)


def test_version():
    r = _cli("--version")
    assert r.returncode == 0 and "flagellum" in r.stdout


def test_rft_json_keys_and_values():
    r = _cli("rft", "--json")
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
    d = json.loads(_cli("rft", "--json", "--handedness", "left", "--friction", "lighthill").stdout)
    assert d["thrust_per_torque"] < 0
    assert d["gamma_par"] == d["lighthill"]["gamma_par"]


@pytest.mark.parametrize("args,name", [
    (["--length", "-1"], "length"), (["--segment-length", "0.3"], "segment_length"),
    (["--kappa0", "nan"], "kappa0"), (["--viscosity", "0"], "viscosity"),
    (["--length", "abc"], "length"), (["--friction", "magic"], "friction"),
    (["--config", "/nonexistent.toml"], "config"), (["--critical-force", "inf"], "critical_force"),
])
def test_bad_input_one_line_exit_2(args, name, capsys):
    code = run(["rft", *args])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert name.replace("_", "-") in err or name in err
    assert "Traceback" not in err


def test_bad_input_subprocess_has_no_traceback():
    r = _cli("rft", "--length", "-1")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_c_level_stdout_does_not_spoil_json():
    """Libraries that write to file descriptor 1 (SUNDIALS' warnings) end up on stderr; the
    results printed by the CLI stay alone on stdout."""
    code = ("import os, sys; from flagellum import cli; cli.keep_stdout_for_results(); "
            "os.write(1, b'[WARNING] from C\\n'); cli.emit_json({'a': 1}); sys.stdout.flush(); "
            "os.write(1, b'[WARNING] again\\n')")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(res.stdout) == {"a": 1}
    assert res.stderr.count("[WARNING]") == 2
