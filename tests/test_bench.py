"""The benchmark's report (``flagellum bench``): its keys and the work–precision diagram.
No timings are asserted (the machine is shared)."""

import json

import pytest

from flagellum import bench
from flagellum.cli import run

ROW_KEYS = {"torque", "window", "wall_per_simulated_second", "steps", "steps_per_revolution",
            "thrust", "omega", "chi", "error", "peer_ratio"}


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
