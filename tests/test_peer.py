"""The PyElastica peer of ``flagellum bench --peer`` (flagellum.peer): the regime handed to
it, its frames, and a missing environment. PyElastica itself is not a dependency: the one
test that runs it is skipped without its environment."""

import math

import numpy as np
import pytest

from flagellum import bench, peer
from flagellum.motor import Boundary
from flagellum.params import Params


def test_spec_carries_flagellum_numbers():
    """The peer gets flagellum's own initial positions, rigidities and drag; the sphere's
    drag is Stokes' 6πηa (η = 1e-3 pN·s/µm², a = 1 µm: 0.01885 pN·s/µm)."""
    p = Params()
    s = peer.spec(p, 2.0, Boundary(anchor="sphere", sphere_radius=1.0))
    pos = np.array(s["positions"])
    assert pos.shape == (51, 3) and np.allclose(pos[0], 0.0)
    assert np.allclose(np.linalg.norm(np.diff(pos, axis=0), axis=1), 0.2)  # L/N
    assert s["zeta"] == pytest.approx(6 * math.pi * 1e-3 * 1.0)
    assert (s["A"], s["C"], s["K"]) == (3.5, 3.5, 1000.0)
    assert s["gammas"] == list(p.gammas) and s["anchor"] == "sphere" and s["torque"] == 2.0
    assert peer.spec(p, 1.0, Boundary())["zeta"] == 0.0


def test_frames_orthonormal_and_transported_without_twist():
    """Parallel transport along a planar polygon (zero torsion) keeps the out-of-plane
    director fixed: d2 = ±e_z at every element; d3 is the tangent."""
    phi = np.linspace(0.0, 2.0, 21)
    pos = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)])
    d = peer._frames(pos)
    t = np.diff(pos, axis=1)
    t /= np.linalg.norm(t, axis=0)
    for i in range(d.shape[2]):
        assert np.allclose(d[:, :, i] @ d[:, :, i].T, np.eye(3), atol=1e-12)
        assert np.allclose(d[2, :, i], t[:, i], atol=1e-12)
        assert abs(abs(d[1, 2, i]) - 1.0) < 1e-12
    assert np.all(np.sign(d[1, 2]) == np.sign(d[1, 2, 0]))


def test_missing_environment_gives_null_ratio_with_reason(monkeypatch, tmp_path):
    monkeypatch.setenv(peer.ENV, str(tmp_path / "none"))
    ok, why = peer.available()
    assert not ok and "no PyElastica environment" in why and peer.ENV in why
    monkeypatch.setattr(bench, "REGIMES", {"from_rest_M1": (1.0, 2e-3, Boundary(), False)})
    monkeypatch.setattr(bench, "warm_up", lambda: None)
    row = bench.regimes(quick=True, peer=True)["from_rest_M1"]
    assert row["peer_ratio"] is None and "no PyElastica environment" in row["peer_reason"]


@pytest.mark.slow
@pytest.mark.skipif(not peer.available()[0], reason="no PyElastica environment")
def test_pyelastica_thrust_agrees_with_flagellum_when_anchored():
    """An independent implementation of the same filament (explicit, inertial, shearable
    Cosserat rod): its time-averaged thrust at M = 1 from rest, anchored, over 5 ms, within
    5 % of flagellum's (measured: 0.949 against 0.95 pN)."""
    res = peer.run(peer.spec(Params(), 1.0, Boundary()), dts=(5e-7,), window=5e-3)["tuned"]
    ref = bench.run_regime("from_rest_M1", bench._solver("cvode", 1e-8), 5e-3)
    assert res["thrust"] == pytest.approx(ref["thrust"], rel=0.05)
