"""One set of drive, reversal and body flags for every command (simulate, sweep, stability,
critical-torque, bifurcations), their one-line refusals, and the threshold search under a
speed clamp (``bifurcations --motor-speed``) with a stand-in simulation."""

import json

import pytest

import flagellum.analysis.bifurcations as bif
from flagellum import ParameterError
from flagellum.analysis.bifurcations import bifurcations, scan_torques
from flagellum.grid import parse_values
from flagellum.sweep import PointRun, Sweep, read_sweep


def test_sweep_point_takes_the_body_and_the_reversals():
    run = PointRun.from_values({"body_radius": 1.5, "body_aspect": 2.0, "motor_offset": 30.0,
                                "reversal_times": (0.1, 0.2), "reversal_seed": 3, "time": 0.3})
    assert run.boundary.is_cell and run.boundary.anchor == "free"
    assert (run.boundary.body_radius, run.boundary.body_aspect, run.boundary.motor_offset) == (1.5, 2.0, 30.0)
    assert run.motor.reversals == (0.1, 0.2) and run.motor.reversal_seed == 3
    rates = PointRun.from_values(Sweep.create(fixed={"reversal_rates": "2,5"}).values({})).motor
    assert rates.reversal_rates == (2.0, 5.0)


def test_list_valued_parameters_are_one_value():
    """``a,b`` is one list of reversal times (as in simulate), not two grid points."""
    assert parse_values("reversal_times", "0.1,0.2") == ((0.1, 0.2),)
    assert parse_values("reversal_times", [[0.1], [0.2, 0.3]]) == ((0.1,), (0.2, 0.3))
    with pytest.raises(ParameterError, match="reversal_times"):
        Sweep.create({"reversal_times": [[0.1], [0.2]]})
    with pytest.raises(ParameterError, match="reversal_times"):
        parse_values("reversal_times", "0.1,nan")


@pytest.mark.parametrize("values, name", [
    ({"motor_offset": 10.0}, "motor_offset"),  # without a body
    ({"body_radius": 1.0, "sphere_radius": 1.0}, "body_radius"),
    ({"body_radius": 1.0, "hydrodynamics": "sbt", "thermal": True, "kT": 4e-3, "method": "cvode"},
     "method"),
])
def test_sweep_point_refuses_what_simulate_refuses(values, name):
    with pytest.raises(ParameterError, match=name):
        PointRun.from_values(values)


def test_sweep_cli_cell_with_reversal(tmp_path, cli):
    out = tmp_path / "s.nc"
    code, _, err = cli("sweep", "--torque", "0.5,1", "--body-radius", "1", "--reversal-times", "0.002",
                       "--length", "2", "--time", "0.004", "--workers", "1", "-o", out, "--json")
    assert code == 0, err
    s = read_sweep(out)
    assert list(s.data["status"]) == ["ok", "ok"]
    assert json.loads(s.attrs["fixed"])["reversal_times"] == [0.002]
    assert (s.data["body_velocity"] > 0).all()


@pytest.mark.parametrize("command", ["critical-torque", "bifurcations"])
@pytest.mark.parametrize("flag, value", [("--reversal-times", "0.1"), ("--reversal-rates", "1,2"),
                                         ("--reversal-seed", "1")])
def test_threshold_commands_refuse_reversals(cli, command, flag, value):
    code, _, err = cli(command, "--length", "2", flag, value)
    assert code == 2 and err.count("\n") == 1 and flag.lstrip("-").replace("-", "_") in err


def test_stability_cli_with_a_cell_body(cli):
    code, out, err = cli("stability", "--length", "2", "--torque", "0.5", "--body-radius", "1",
                         "--hook-stiffness", "5", "--json")
    assert code == 0, err
    res = json.loads(out)
    assert res["motor_speed"] > res["omega"]  # the body counter-rotates
    code, _, err = cli("stability", "--length", "2", "--body-radius", "1", "--body-aspect", "2",
                       "--motor-offset", "30")
    assert code == 2 and "motor_offset" in err and err.count("\n") == 1


def test_bifurcation_options_of_the_clamp(cli):
    code, _, err = cli("bifurcations", "--length", "2", "--motor-speed", "--torque-range", "3:5")
    assert code == 2 and "torque_range" in err
    code, _, err = cli("bifurcations", "--length", "2", "--speed-range", "900:1000")
    assert code == 2 and "speed_range" in err
    assert scan_torques("quick", drive="speed") == (900.0, 950.0, 1000.0, 1050.0, 1100.0)
    with pytest.raises(ParameterError, match="speed_range"):
        scan_torques("quick", "950", drive="speed")


class ClampThreshold:
    """Stand-in clamped runs: aligned below ω1, buckled up to ω2, oscillating above."""

    drive = "speed"

    def __init__(self, w1=900.0, w2=1040.0):
        self.w1, self.w2 = w1, w2

    def __call__(self, speed, state=None):
        regime = "aligned" if speed < self.w1 else "buckled" if speed < self.w2 else "oscillating"
        return {"motor_speed": speed, "torque": speed / 850.0, "regime": regime,
                "sigma_over_sigma0": 1.0, "thrust": 1.0}, regime


def test_clamp_thresholds_with_a_stand_in(monkeypatch):
    """ω_c1 confirmed by runs at ω_c1(1 ∓ δ); ω_c2 bracketed and bisected in motor speed."""
    monkeypatch.setattr(bif, "critical", lambda params, boundary, hydrodynamics=None, drive="torque":
                        {"omega_c1": 898.0, "omega_c1_uncertainty": 1.0, "F_c1": 1.0})
    res = bifurcations(drive="speed", confirm_mc1=0.05, tol=1.0, simulate=ClampThreshold(880.0))
    assert res["omega_c1_confirmed"] is True
    assert abs(res["omega_c2"] - 1040.0) <= res["omega_c2_uncertainty"] <= 0.5
    assert res["scan_speeds"] == [900.0, 950.0, 1000.0, 1050.0, 1100.0]
    assert all("motor_speed" in p for p in res["probes"])
    up = bifurcations(drive="speed", tol=1.0, hysteresis=True, simulate=ClampThreshold(880.0))
    assert abs(up["omega_c2_up"] - 1040.0) <= 0.5
    none = bifurcations(drive="speed", simulate=ClampThreshold(880.0, 2000.0))
    assert none["omega_c2"] is None and "no oscillating run" in none["omega_c2_note"]
