"""``flagellum bifurcations``: the M_c2 search logic against a cheap stand-in for the
simulation (milliseconds), continuation of a real run, the CLI, and (slow tier) a coarse
torque sweep of the paper's filament through the aligned, buckled and oscillating regimes.
"""

import json
import math

import pytest
from conftest import assert_one_line_error

from flagellum.analysis import bifurcations as bif
from flagellum.analysis.bifurcations import (RunConfig, bifurcations, bracket, continuation,
                                             refine, scan_torques)
from flagellum.cli import run
from flagellum.errors import ParameterError


class Threshold:
    """Stand-in simulation: buckled below ``up``, oscillating above; a run continued from an
    oscillating state stays oscillating down to ``down`` (hysteresis when down < up)."""

    def __init__(self, up=4.23, down=None, mc1=1.1, fail_at=()):
        self.up, self.down, self.mc1, self.fail_at = up, up if down is None else down, mc1, fail_at
        self.calls = []

    def __call__(self, torque, state=None):
        self.calls.append((torque, state))
        if any(abs(torque - f) < 1e-9 for f in self.fail_at):
            return {"torque": torque, "regime": "failed", "error": "injected"}, None
        if torque < self.mc1:
            regime = "aligned"
        elif torque > self.up or (state == "oscillating" and torque > self.down):
            regime = "oscillating"
        else:
            regime = "buckled"
        sig = {"aligned": 0.0, "buckled": 0.9, "oscillating": 4.0}[regime]
        return {"torque": torque, "regime": regime, "sigma_over_sigma0": sig, "thrust": 1.0}, regime


@pytest.fixture(autouse=True)
def fast_mc1(monkeypatch):
    """M_c1 from linear stability takes seconds: replaced here (tested in test_stability.py)."""
    monkeypatch.setattr(bif, "critical", lambda params, boundary, xtol=1e-3, hydrodynamics=None:
                        {"M_c1": 1.1, "M_c1_uncertainty": xtol, "F_c1": 1.0})


def _runner(workers=1):
    from concurrent.futures import Future, as_completed

    def submit(fn, arg):
        f = Future()
        f.set_result(fn(arg))
        return f

    return bif._Runner(submit, as_completed, workers)


# -- search logic ---------------------------------------------------------------------------
@pytest.mark.parametrize("threshold", [3.01, 4.23, 4.5, 5.49])
def test_scan_and_bisection_find_the_threshold(threshold):
    fake = Threshold(threshold)
    res = bifurcations(torque_range="3:5.5:0.5", tol=0.01, simulate=fake)
    assert abs(res["M_c2"] - threshold) <= res["M_c2_uncertainty"] <= 0.005
    lo, hi = res["M_c2_bracket"]
    assert lo <= threshold <= hi and hi - lo <= 0.01
    assert res["M_c1"] == 1.1 and res["M_c1_uncertainty"] == 1e-3
    assert "hysteresis" not in res and "M_c2_up" not in res
    scan = [p for p in res["probes"] if p["direction"] == "scan"]
    assert [p["torque"] for p in scan] == [3.0, 3.5, 4.0, 4.5, 5.0, 5.5]
    for p in res["probes"]:
        assert {"torque", "regime", "sigma_over_sigma0", "thrust", "direction"} <= set(p)
    assert all(s is None for _, s in fake.calls)  # scan and bisection runs start fresh


def test_k_section_uses_every_worker_and_converges():
    fake = Threshold(4.23)
    runner = _runner(workers=3)
    lo, hi, note = refine(runner, fake, 4.0, 4.5, 0.01)
    assert note is None and lo <= 4.23 <= hi and hi - lo <= 0.01
    assert len(runner.probes) % 3 == 0 and len(runner.probes) <= 3 * 3  # 0.5/4³ < 0.01
    one = _runner(workers=1)
    refine(one, Threshold(4.23), 4.0, 4.5, 0.01)
    assert len(one.probes) == 6  # plain bisection: 0.5/2⁶ < 0.01


def test_bracket_rules():
    P = lambda m, r: {"torque": m, "regime": r}  # noqa: E731
    assert bracket([P(3, "buckled"), P(4, "buckled"), P(5, "oscillating")])[:2] == (4, 5)
    assert bracket([P(3, "buckled"), P(4, "failed"), P(5, "oscillating")])[:2] == (3, 5)
    lo, hi, note = bracket([P(3, "buckled"), P(4, "oscillating"), P(5, "buckled"), P(6, "oscillating")])
    assert (lo, hi) == (3, 4) and "not monotonic" in note
    assert bracket([P(3, "buckled"), P(4, "buckled")])[0] is None
    lo, hi, note = bracket([P(3, "oscillating"), P(4, "oscillating")])
    assert lo is None and "no buckled run below" in note


@pytest.mark.parametrize("fake,word", [
    (Threshold(6.0), "no oscillating run"), (Threshold(2.0), "no buckled run below"),
])
def test_unresolved_m_c2_is_reported_not_guessed(fake, word):
    res = bifurcations(torque_range="3:5.5:0.5", simulate=fake)
    assert res["M_c2"] is None and res["M_c2_uncertainty"] is None and word in res["M_c2_note"]


def test_failed_runs_stop_the_bisection_with_a_note():
    fake = Threshold(4.23, fail_at=(4.25,))  # the first midpoint of [4.0, 4.5]
    res = bifurcations(torque_range="3:5.5:0.5", tol=0.01, simulate=fake)
    assert res["M_c2_bracket"] == [4.0, 4.5] and res["M_c2"] == 4.25
    assert "decide nothing" in res["M_c2_note"]
    assert any(p["regime"] == "failed" for p in res["probes"])


def test_hysteresis_by_continuation():
    fake = Threshold(up=4.4, down=3.9)
    res = bifurcations(torque_range="3:5.5:0.5", tol=0.01, hysteresis=True, simulate=fake)
    assert abs(res["M_c2_up"] - 4.4) <= res["M_c2_up_uncertainty"] <= 0.005
    assert abs(res["M_c2_down"] - 3.9) <= res["M_c2_down_uncertainty"] <= 0.005
    assert abs(res["M_c2"] - 4.4) <= 0.005  # fresh runs see the upper threshold
    assert res["hysteresis"] is True
    up = [p["torque"] for p in res["probes"] if p["direction"] == "up"]
    down = [p["torque"] for p in res["probes"] if p["direction"] == "down"]
    assert up[:6] == [3.0, 3.5, 4.0, 4.5, 5.0, 5.5] and down[:6] == up[:6][::-1]
    # every continued run starts from the previous state; only the first of a chain is fresh
    assert sum(s is None for _, s in fake.calls) == 6 + 2 + sum(p["direction"] == "bisect" for p in res["probes"])

    same = bifurcations(torque_range="3:5.5:0.5", tol=0.01, hysteresis=True, simulate=Threshold(4.23))
    assert same["hysteresis"] is False and abs(same["M_c2_up"] - same["M_c2_down"]) <= 0.01


def test_continuation_without_transition():
    res = continuation(Threshold(9.0), [3.0, 4.0], "up", 0.01)
    assert res["M_c2"] is None and "no buckled → oscillating" in res["note"]


def test_pool_of_two_workers_gives_the_same_answer():
    res = bifurcations(torque_range="3:5.5:0.5", tol=0.02, hysteresis=True, workers=2,
                       simulate=Threshold(up=4.4, down=3.9))
    assert abs(res["M_c2"] - 4.4) <= 0.01 and res["hysteresis"] is True
    assert res["M_c2_up_uncertainty"] <= 0.01 and abs(res["M_c2_down"] - 3.9) <= 0.01


@pytest.mark.parametrize("kwargs", [
    {"torque_range": "5:3"}, {"torque_range": "a:b"}, {"torque_range": "3"}, {"torque_range": "-1:2"},
    {"torque_range": "3:3.1:0.5"}, {"tol": 0}, {"t_end": -1}, {"quality": "best"}, {"workers": 0},
    {"confirm_mc1": 2.0},
])
def test_bad_input_raises_parameter_error(kwargs):
    with pytest.raises(ParameterError):
        bifurcations(simulate=Threshold(), **kwargs)


def test_scan_torques_defaults():
    assert scan_torques("quick") == (3.0, 3.5, 4.0, 4.5, 5.0, 5.5)
    assert scan_torques("full", "4:5") == (4.0, 4.25, 4.5, 4.75, 5.0)


def test_confirm_mc1():
    res = bifurcations(torque_range="3:5.5:0.5", confirm_mc1=0.2, mc2=False, simulate=Threshold(mc1=1.1))
    assert res["M_c1_confirmed"] is True and "M_c2" not in res
    assert [p["direction"] for p in res["probes"]] == ["confirm", "confirm"]
    assert bifurcations(confirm_mc1=0.2, mc2=False, simulate=Threshold(mc1=2.0))["M_c1_confirmed"] is False


# -- continuation of a real run (tiny filament) -------------------------------------------
def test_run_config_probe_and_state():
    from flagellum.params import Params

    cfg = RunConfig(Params.from_flat({"length": 2.0}), t_end=0.004, samples=40)
    probe, state = cfg(0.5)
    assert probe["regime"] in ("aligned", "buckled") and math.isfinite(probe["sigma_over_sigma0"])
    probe2, _ = cfg(0.6, state)
    assert probe2["continued"] and probe2["frame"] == "lab"


# -- CLI --------------------------------------------------------------------------------------
def test_cli_json_and_out(tmp_path, capsys, monkeypatch):
    fake = Threshold(4.23)
    monkeypatch.setattr(RunConfig, "__call__", lambda self, torque, state=None: fake(torque, state))
    out = tmp_path / "bif.json"
    code = run(["bifurcations", "--torque-range", "3:5.5:0.5", "--tol", "0.05", "--workers", "1",
                "--json", "--out", str(out)])
    assert code == 0
    res = json.loads(capsys.readouterr().out)
    for key in ("M_c1", "M_c1_uncertainty", "M_c2", "M_c2_uncertainty", "probes"):
        assert key in res
    assert abs(res["M_c2"] - 4.23) <= res["M_c2_uncertainty"] <= 0.025
    assert json.loads(out.read_text())["complete"] is True
    code = run(["bifurcations", "--torque-range", "3:5", "--tol", "0.2", "--workers", "1",
                "--hysteresis", "--json"])
    res = json.loads(capsys.readouterr().out)
    assert code == 0 and res["hysteresis"] is False and {"M_c2_up", "M_c2_down"} <= set(res)
    assert {p["direction"] for p in res["probes"]} >= {"scan", "up", "down"}
    code = run(["bifurcations", "--torque-range", "3:5", "--workers", "1"])  # table output
    assert code == 0 and "M_c2" in capsys.readouterr().out


@pytest.mark.parametrize("args,word", [
    (["--torque-range", "5:3"], "torque"), (["--torque-range", "x"], "torque_range"),
    (["--tol", "-1"], "tol"), (["--t-end", "0"], "t_end"), (["--sphere-radius", "-1"], "sphere_radius"),
    (["--workers", "0"], "workers"), (["--quality", "best"], "quality"),
])
def test_cli_bad_input_one_line_exit_2(cli, args, word):
    code, _, err = cli("bifurcations", *args, "--json")
    assert_one_line_error(code, err, word)


# -- slow tier: the real filament ------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.ci
def test_coarse_sweep_finds_aligned_buckled_oscillating_in_order(monkeypatch):
    """M = 0.5, 3, 5.5 pN·µm, 0.4 s each after the step (≈ 1 min on 2 cores): regimes
    (ii), (iii), (iv) of Fig. 3 in this order, so M_c2 lies in (3, 5.5). The top probe is
    not 4.5: that lies in the bistable window 4.4–4.6 of docs/sweeps.md and may stay buckled.
    References: the paper's regimes and M_c1 ≈ 1.1 pN·µm (Sec. 3.1.1, Fig. 3(a))."""
    monkeypatch.undo()  # the real M_c1 as well
    res = bifurcations(torque_range="0.5:5.5:2.5", t_end=0.4, tol=3.0, workers=2)
    scan = sorted((p for p in res["probes"] if p["direction"] == "scan"), key=lambda p: p["torque"])
    assert [p["regime"] for p in scan] == ["aligned", "buckled", "oscillating"], scan
    assert res["M_c2_bracket"] == [3.0, 5.5] and abs(res["M_c1"] - 1.1) < 0.2
