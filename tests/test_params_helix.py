"""Parameters, validation and helix geometry against closed forms and direct measurement."""

import math

import numpy as np
import pytest

from flagellum import Filament, Fluid, Friction, Params, ParameterError
from flagellum.helix import Helix, discrete_helix
from flagellum.params import lighthill_friction


def test_defaults_are_the_papers():
    p = Params()
    assert p.filament.n_segments == 50
    assert p.gammas == (1.6e-3, 2.8e-3, 1.26e-6)


@pytest.mark.parametrize("name,value", [
    ("length", -1.0), ("length", 0.0), ("length", float("nan")), ("length", float("inf")),
    ("kappa0", -0.1), ("bend_rigidity", 0.0), ("twist_rigidity", -3.0),
    ("segment_length", 0.3), ("segment_length", 5.0), ("stretch_modulus", 0.0),
    ("handedness", "up"), ("length", "ten"), ("length", True),
])
def test_filament_validation_names_parameter(name, value):
    with pytest.raises(ParameterError) as exc:
        Filament(**{name: value})
    assert name in str(exc.value) and "must be" in str(exc.value)


@pytest.mark.parametrize("name,value", [("viscosity", 0.0), ("filament_radius", -1.0), ("kT", -1e-3)])
def test_fluid_validation(name, value):
    with pytest.raises(ParameterError, match=name):
        Fluid(**{name: value})


def test_friction_models():
    f, fl = Filament(), Fluid()
    assert Friction("paper").resolve(f, fl) == (1.6e-3, 2.8e-3, 1.26e-6)
    with pytest.raises(ParameterError, match="gamma_par"):
        Friction("custom")
    assert Friction("custom", 1.0, 2.0, 3.0).resolve(f, fl) == (1.0, 2.0, 3.0)
    assert Friction("paper", gamma_par=1.0).resolve(f, fl)[0] == 1.0


def test_lighthill_close_to_papers_rounded_values():
    gp, gn, gr = lighthill_friction(Filament(), Fluid())
    # Independent evaluation of App. A: q = 0.09 Λ, Λ = 2πR/cos α.
    R = 1.3 / (1.3**2 + 2.1**2)
    cos_a = 1.3 / math.hypot(1.3, 2.1)
    log = math.log(2 * 0.09 * 2 * math.pi * R / cos_a / 0.01)
    assert gp == pytest.approx(2 * math.pi * 1e-3 / log, rel=1e-12)
    # literature: Sec. 2.4 quotes the Lighthill values rounded, γ∥ = 1.6e-3, γ⊥ = 2.8e-3 pN·s/µm²,
    # γR = 1.26e-6 pN·s (its filament radius "about 20 nm" is not exact: hence 5 %)
    assert gp == pytest.approx(1.6e-3, rel=0.05)
    assert gn == pytest.approx(2.8e-3, rel=0.05)
    assert gr == pytest.approx(1.26e-6, rel=0.01)


def test_toml_round_trip(tmp_path):
    p = Params(Filament(length=5.0, handedness="left"), Fluid(kT=0.0), Friction("lighthill"))
    path = tmp_path / "p.toml"
    p.save_toml(path)
    assert Params.load_toml(path) == p
    assert p.replace(length=6.0).filament.length == 6.0


def test_toml_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[filament]\nlenght = 3\n")
    with pytest.raises(ParameterError, match="lenght"):
        Params.load_toml(bad)
    bad.write_text("[filament\n")
    with pytest.raises(ParameterError, match="TOML"):
        Params.load_toml(bad)
    with pytest.raises(ParameterError, match="config"):
        Params.load_toml(tmp_path / "missing.toml")


def test_continuum_helix_measured():
    h = Helix(1.3, 2.1, 10.0)
    s = np.linspace(0, h.length, 2001)
    r = h.positions(s)
    assert np.allclose(np.hypot(r[:, 0], r[:, 1]), h.radius)
    assert h.radius == pytest.approx(0.213, abs=5e-4)  # closed form R = κ/(κ² + τ²)
    assert h.axial_length == pytest.approx(r[-1, 2] - r[0, 2])
    assert h.axial_length == pytest.approx(8.50, abs=5e-3)  # closed form L sin α
    # pitch: axial rise over one turn of contour length
    assert h.positions(h.turn_length)[2] == pytest.approx(h.pitch)
    assert math.tan(h.pitch_angle) == pytest.approx(h.pitch / (2 * math.pi * h.radius))
    # unit speed, curvature and torsion from finite differences
    t = h.tangents(s)
    assert np.allclose(np.linalg.norm(t, axis=1), 1)
    d = np.gradient(r, s, axis=0)
    assert np.allclose(d[1:-1], t[1:-1], atol=1e-4)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_discrete_helix_geometry(hand):
    f = Filament(handedness=hand)
    dh = discrete_helix(f)
    bonds = np.diff(dh.positions, axis=0)
    assert np.allclose(np.linalg.norm(bonds, axis=1), f.segment_length)
    for D in dh.frames:
        assert np.allclose(D.T @ D, np.eye(3), atol=1e-12)
        assert np.linalg.det(D) == pytest.approx(1.0)
    assert np.allclose(bonds / f.segment_length, dh.tangents)
    rel = dh.positions - dh.axis_point
    perp = rel - np.outer(rel @ dh.axis_direction, dh.axis_direction)
    assert np.allclose(np.linalg.norm(perp, axis=1), dh.radius)
    assert np.allclose(dh.positions[0], 0)
    assert np.allclose(dh.axis_direction, [0, 0, -1])
    # handedness: sign of the triple product of consecutive bonds
    trip = np.einsum("ij,ij->i", np.cross(bonds[:-2], bonds[1:-1]), bonds[2:])
    assert np.all(np.sign(trip) == (1 if hand == "right" else -1))


def test_discrete_helix_converges_like_h_squared():
    errs = []
    cont = Helix(1.3, 2.1, 10.0)
    for h in (0.2, 0.1, 0.05):
        dh = discrete_helix(Filament(segment_length=h))
        errs.append(abs(dh.radius - cont.radius))
    assert errs[0] / errs[1] == pytest.approx(4, rel=0.05)
    assert errs[1] / errs[2] == pytest.approx(4, rel=0.05)


def test_discrete_helix_origin_on_axis():
    dh = discrete_helix(Filament(), origin="axis", axis=(0, 0, 1))
    assert np.allclose(np.hypot(dh.positions[:, 0], dh.positions[:, 1]), dh.radius)


def test_straight_rod_geometry():
    h = Helix(0.0, 0.0, 2.0)
    assert h.radius == 0 and h.axial_length == pytest.approx(2.0) and h.n_turns == 0
    dh = discrete_helix(Filament(kappa0=0.0, tau0=0.0, length=2.0))
    assert np.allclose(dh.positions[:, :2], 0) and dh.axial_length == pytest.approx(2.0)
