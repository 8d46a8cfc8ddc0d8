"""The benchmark's report (``flagellum bench``): its keys and the work–precision diagram.
No timings are asserted (the machine is shared)."""

import json

import pytest

from flagellum import bench, costs
from flagellum.cli import run

ROW_KEYS = {"torque", "window", "wall_per_simulated_second", "steps", "steps_per_revolution",
            "thrust", "omega", "chi", "error", "peer_ratio", "limit"}


def _short(monkeypatch, window=2e-3):
    """Every regime over a few ms: the report's shape, not its numbers."""
    monkeypatch.setattr(bench, "REGIMES", {k: (m, window, b, th) for k, (m, _, b, th)
                                           in bench.REGIMES.items()})


def test_average_errors_relative_and_chi_against_omega():
    ref = {"thrust": 2.0, "omega": 1000.0, "chi": 0.0}
    e = bench.average_errors({"thrust": 2.002, "omega": 1001.0, "chi": 5.0}, ref)
    assert e["thrust_error"] == pytest.approx(1e-3)
    assert e["omega_error"] == pytest.approx(1e-3)
    assert e["chi_error"] == pytest.approx(5e-3)  # χ ≈ 0 when aligned: scaled by ω
    assert e["error"] == pytest.approx(5e-3)


def test_work_precision_rows_and_plot(monkeypatch, tmp_path):
    _short(monkeypatch)
    monkeypatch.setattr(bench, "warm_up", lambda: None)
    data = bench.work_precision(quick=True, names=("from_rest_M1",))
    runs = data["from_rest_M1"]["runs"]
    assert {r["method"] for r in runs} == {"cvode", "bdf", "bdf2"}
    assert all(r["error"] >= 0 and r["steps"] > 0 for r in runs)
    bench.plot_work_precision(data, tmp_path / "wp.png")
    assert (tmp_path / "wp.png").stat().st_size > 1000


@pytest.mark.slow
@pytest.mark.ci
def test_bench_quick_json_has_regimes(monkeypatch, capsys):
    _short(monkeypatch)
    assert run(["bench", "--quick", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["regimes"]) == set(bench.REGIMES)
    for name, row in out["regimes"].items():
        assert ROW_KEYS <= set(row), name
        if not bench.REGIMES[name][3]:
            assert row["reference_check"] >= 0 and row["error"] >= 0
    assert {"from_rest", "scaling", "brownian", "wall_per_simulated_second"} <= set(out)


def test_regimes_run_with_the_chosen_stepper(monkeypatch):
    _short(monkeypatch)
    monkeypatch.setattr(bench, "warm_up", lambda: None)
    rows = bench.regimes(quick=True, names=("from_rest_M1", "thermal_M1"),
                         solver=bench.SolverOptions(method="bdf", rtol=1e-4))
    assert rows["from_rest_M1"]["method"] == "bdf" and rows["from_rest_M1"]["rtol"] == 1e-4
    assert rows["from_rest_M1"]["error"] < 1e-2  # against the CVODE reference
    assert rows["thermal_M1"]["method"] == "implicit"


def test_regimes_default_to_each_runs_default_method(monkeypatch):
    """Without a solver every deterministic regime runs the default method of its run
    (:func:`flagellum.integrate.default_method`: the BDF), the thermal one the implicit scheme."""
    _short(monkeypatch)
    assert {name: bench.run_regime(name)["method"] for name in bench.REGIMES} == {
        name: "implicit" if th else "bdf" for name, (_, _, _, th) in bench.REGIMES.items()}


LIMIT_KEYS = {"dominant", "share", "groups", "piece", "piece_share", "shares", "integrator_share",
              "steps_per_revolution", "iterations_per_step", "microseconds_per_step",
              "unit_microseconds", "counts", "next_step"}


def _check_limit(lim, row):
    assert LIMIT_KEYS <= set(lim)
    shares = lim["shares"]
    assert all(v >= 0 for v in shares.values())
    assert sum(shares.values()) <= 1.0 + 1e-3  # shares of one run's wall time (rounded to 1e-4)
    assert lim["piece"] == max(shares, key=shares.get) and lim["piece_share"] == shares[lim["piece"]]
    groups = lim["groups"]  # every piece in one group, the groups' shares its sums
    assert sorted(k for g in groups for k in costs.GROUPS[g] if k in shares) == sorted(shares)
    assert sum(groups.values()) == pytest.approx(sum(shares.values()), abs=1e-3)
    assert lim["dominant"] == max(groups, key=groups.get) and lim["share"] == groups[lim["dominant"]]
    assert lim["next_step"].startswith(costs.NEXT_STEP[lim["dominant"]].split("{")[0])
    # the stepper's own counters: the steps of the row, one Newton solve per iteration
    assert lim["counts"]["steps"] == row["steps"] > 0
    assert lim["counts"]["solves"] == lim["counts"]["newton_iterations"] > 0
    assert lim["steps_per_revolution"] == pytest.approx(row["steps_per_revolution"])
    # the integrator's parts add up to its measured share (what the unit costs miss is
    # "bookkeeping"; they are scaled down if they over-explain it)
    inner = sum(v for k, v in shares.items()
                if k not in ("records", "chart_checks", "frame", "chart_changes", "loop"))
    assert inner == pytest.approx(lim["integrator_share"], abs=2e-3)


def test_limit_of_a_bdf_and_a_thermal_run(monkeypatch):
    """``limit`` of the BDF (from rest, M = 1) and of the thermal BDF2 regime, a few ms each:
    its structure, shares of the wall time that sum to ≤ 1, the counters of the stepper."""
    _short(monkeypatch)
    for name in ("from_rest_M1", "thermal_M1"):
        row = bench.run_regime(name, with_limit=True)
        _check_limit(row["limit"], row)
        unit = row["limit"]["unit_microseconds"]
        assert {"rhs", "jacobian", "factorization", "solve"} <= set(unit)
        assert all(v > 0 for v in unit.values())
    assert "noise" in unit  # the thermal increment, timed only with noise


def test_instrumented_run_is_the_same_run(monkeypatch):
    """The timers change no numbers: the same averages and steps with and without them."""
    _short(monkeypatch)
    a = bench.run_regime("free_swimmer_M2", with_limit=True)
    b = bench.run_regime("free_swimmer_M2")
    assert (a["thrust"], a["omega"], a["chi"], a["steps"]) == (b["thrust"], b["omega"], b["chi"],
                                                               b["steps"])


def test_limit_shares_from_the_clock():
    """A run whose clock holds 0.6 s in the stepper (no split for an unknown stepper) and
    0.3 s of records out of 1 s of wall: those shares, the loop the remaining 0.1."""
    clock = costs.Clock()
    clock.seconds = {"integrator": 0.6, "records": 0.3}
    clock.calls = {"integrator": 10, "records": 10}
    lim = costs.limit(clock, 1.0, revolutions=2.0)
    assert lim["shares"] == {"integrator": 0.6, "records": 0.3, "chart_checks": 0.0,
                             "frame": 0.0, "chart_changes": 0.0, "loop": 0.1}
    assert lim["groups"] == {"run_loop": 0.4, "integrator": 0.6}
    assert lim["dominant"] == lim["piece"] == "integrator" and lim["share"] == 0.6
    assert lim["next_step"] == costs.NEXT_STEP["integrator"]
