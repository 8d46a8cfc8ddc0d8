"""``flagellum theory``: JSON output, one-line errors with exit code 2."""

import json
import math

import pytest
from conftest import assert_one_line_error

from flagellum.cli import run


def _json(capsys, *args):
    assert run(["theory", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_buckling_json(capsys):
    d = _json(capsys, "buckling", "--m-hat", "2", "--f-par", "30", "--samples", "11")
    assert set(d) >= {"m_hat", "f_par", "f_perp", "chi", "mode"}
    assert d["m_hat"] == 2 and d["f_par"] == 30
    assert len(d["mode"]["z"]) == len(d["mode"]["X"]) == len(d["mode"]["Y"]) == 11
    assert d["mode"]["X"][0] == 0 and d["mode"]["Y"][0] == 0


def test_buckling_greenhill_via_cli(capsys):
    d = _json(capsys, "buckling", "--m-hat", "2", "--base", "hinged", "--top", "hinged",
              "--force-profile", "uniform", "--torque-profile", "uniform",
              "--solve", "f_par,chi", "--guess", "9,0.1")
    assert d["f_par"] == pytest.approx(math.pi**2 - 1.0, rel=1e-10)


def test_buckling_table(capsys):
    assert run(["theory", "buckling", "--m-hat", "2", "--f-par", "30"]) == 0
    out = capsys.readouterr().out
    assert "f_perp" in out and "mode" in out


def test_effective_rigidity_json(capsys):
    d = _json(capsys, "effective-rigidity")
    for name, (k, t) in {"normal": (1.3, 2.1), "monotrichous": (2.2, 2.5)}.items():
        alpha = math.atan2(t, k)
        g = d[name]
        assert g["A_eff"] == pytest.approx(3.5 * math.sin(alpha), rel=1e-12)   # A = C
        assert g["A_eff_over_L0"] == pytest.approx(3.5 / 10.0, rel=1e-12)
        assert g["rate_scale"] == pytest.approx(3 * g["A_eff"] / (g["L0"] ** 3 * g["A_perp"]))
    assert d["A_eff"] == d["normal"]["A_eff"]
    d2 = _json(capsys, "effective-rigidity", "--twist-rigidity", "7.0")
    alpha = math.atan2(2.1, 1.3)
    expect = 2 * 3.5 * math.sin(alpha) / (1 + math.sin(alpha) ** 2 + 0.5 * math.cos(alpha) ** 2)
    assert d2["A_eff"] == pytest.approx(expect, rel=1e-12)
    assert "A_eff_measured" not in d2


def test_effective_rigidity_measured(capsys):
    d = _json(capsys, "effective-rigidity", "--measure")
    assert d["A_eff_measured"] == pytest.approx(d["A_eff"], rel=0.01)   # measured −0.3 %


def test_rigid_helix_json(capsys):
    d = _json(capsys, "rigid-helix", "--torque", "1.0", "--tilt", "20")
    assert d["precession_rate"] == pytest.approx(d["precession_rate_predicted"], rel=5e-3)
    assert d["M2_relative_drift"] < 1e-9 and d["P_relative_drift"] < 1e-6


@pytest.mark.parametrize("args,name", [
    (["buckling", "--base", "wobbly"], "base"),
    (["buckling", "--m-hat", "nan"], "m_hat"),
    (["buckling", "--solve", "omega"], "unknowns"),
    (["buckling", "--samples", "0"], "samples"),
    (["buckling", "--guess", "a,b"], "guess"),
    (["buckling", "--m-hat", "abc"], "m-hat"),
    (["rigid-helix", "--torque", "0"], "torque"),
    (["effective-rigidity", "--length", "-1"], "length"),
    (["manifold", "--m-steps", "1"], "m_steps"),
])
def test_bad_input_one_line_exit_2(args, name, cli):
    code, _, err = cli("theory", *args)
    assert_one_line_error(code, err, name)


@pytest.mark.slow
@pytest.mark.ci
def test_manifold_cli_writes_files(tmp_path, capsys):
    d = _json(capsys, "manifold", "--out", str(tmp_path), "--m-max", "6", "--m-steps", "4",
              "--f-par-max", "40", "--f-par-steps", "4", "--inv-a-max", "1", "--inv-a-steps", "2")
    assert (tmp_path / "manifold.png").exists() and (tmp_path / "surface.csv").exists()
    assert d["without_radius_correction"]["anchored"]["M"] > 0


def test_effective_rigidity_with_the_nonlocal_friction(capsys):
    """``--hydrodynamics sbt`` gives the rod the rigid helix' nonlocal friction: A_eff (elastic)
    is unchanged, the rate scale A_eff/(L0³A⊥/3) scales with 1/A⊥ (App. C)."""
    from flagellum.hydro.options import Hydrodynamics
    from flagellum.theory.manifold import HelicalRod

    rft_, sbt_ = _json(capsys, "effective-rigidity"), _json(capsys, "effective-rigidity",
                                                            "--hydrodynamics", "sbt")
    assert sbt_["A_eff"] == rft_["A_eff"]
    ratio = HelicalRod.from_params().a_perp / HelicalRod.from_params(
        hydrodynamics=Hydrodynamics("sbt")).a_perp
    f, g = rft_["filament"], sbt_["filament"]
    assert g["rate_scale"] == pytest.approx(f["rate_scale"] * ratio, rel=1e-12)
    assert g["A_perp"] < f["A_perp"]  # the turns shield each other (docs/hydrodynamics.md)
