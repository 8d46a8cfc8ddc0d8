"""Rigid-helix RFT: closed forms (App. A) against independent quadrature and symmetries."""

import math

import numpy as np
import pytest

from flagellum import Filament, Params
from flagellum.helix import Helix, discrete_helix, rot_z
from flagellum.hydro import rft

from closed_forms import app_a_thrust_per_torque

GP, GN, GR = 1.6e-3, 2.8e-3, 1.26e-6  # γ∥, γ⊥ [pN·s/µm²], γR [pN·s]: Sec. 2.4 of the paper
K = math.hypot(1.3, 2.1)  # κ0 = 1.3, τ0 = 2.1 /µm (Sec. 2.4)

#: regression values: produced by this code (``rft.rft_summary(Params())``: the rigid
#: continuum helix, L = 10 µm, pinned at its first point, with spin friction γR); they
#: detect change, not correctness. App. A states only that the simulations' helix has a
#: non-integer number of turns and a rotation axis shifted against the helical axis.
REGRESSION = {"pinned_thrust_per_torque": 0.8004,  # [1/µm] (docs/validation.md: 0.800)
              "pinned_axis_tilt_deg": 2.229}


@pytest.mark.parametrize("chi", [1, -1])
@pytest.mark.parametrize("turns", [1, 3, 4])
def test_full_turn_formulas_match_quadrature(chi, turns):
    h = Helix(1.3, chi * 2.1, turns * 2 * math.pi / K)
    c = rft.full_turn_coefficients(h, GP, GN)
    m = rft.resistance_matrix(*rft.helix_nodes(h), GP, GN)
    assert m[0, 0] == pytest.approx(c["A_perp"], rel=1e-6)
    assert m[1, 1] == pytest.approx(c["A_perp"], rel=1e-6)
    assert m[2, 2] == pytest.approx(c["A_par"], rel=1e-6)
    assert m[5, 5] == pytest.approx(c["B_par"], rel=1e-6)
    assert m[2, 5] == pytest.approx(c["C_par"], rel=1e-6)
    assert np.allclose(m, m.T)


def test_A_par_holds_for_partial_turns():
    h = Helix(1.3, 2.1, 10.0)
    m = rft.resistance_matrix(*rft.helix_nodes(h), GP, GN)
    assert m[2, 2] == pytest.approx(rft.full_turn_coefficients(h, GP, GN)["A_par"], rel=1e-6)


def test_quadrature_against_brute_force_force_sum():
    # independent: sum the local force densities of a rotating helix on a fine grid
    h = Helix(1.3, 2.1, 10.0)
    s = (np.arange(200000) + 0.5) * h.length / 200000
    r, t = h.positions(s), h.tangents(s)
    w = np.array([0.3, -0.2, 1.0])
    v = np.array([0.1, 0.5, -0.2])
    u = v + np.cross(w, r)
    f = GN * u + (GP - GN) * np.einsum("ij,ij->i", t, u)[:, None] * t
    F = f.sum(0) * h.length / len(s)
    M = np.cross(r, f).sum(0) * h.length / len(s)
    m = rft.resistance_matrix(*rft.helix_nodes(h), GP, GN)
    assert np.allclose(m @ np.r_[v, w], np.r_[F, M], rtol=1e-6, atol=1e-12)


def test_rotation_about_z_covariance():
    # symmetry: rotating the nodes by Q rotates the 6×6 resistance matrix by diag(Q, Q)
    dh = discrete_helix(Filament())
    p, t, w = rft.bead_nodes(dh)
    m = rft.resistance_matrix(p, t, w, GP, GN, GR)
    Q = rot_z(0.7)
    m2 = rft.resistance_matrix(p @ Q.T, t @ Q.T, w, GP, GN, GR)
    Q6 = np.kron(np.eye(2), Q)
    assert np.allclose(m2, Q6 @ m @ Q6.T)


def test_handedness_flips_thrust():
    # symmetry: the mirror image reverses the thrust at equal torque, keeps |ω|
    out = {}
    for hand in ("right", "left"):
        out[hand] = rft.rft_summary(Params(Filament(handedness=hand)))
    for key in ("thrust_per_torque",):
        assert out["right"][key] > 0
        assert out["left"][key] == pytest.approx(-out["right"][key])
        assert out["left"]["pinned"][key] == pytest.approx(-out["right"]["pinned"][key])
    assert out["left"]["omega_per_torque"] == pytest.approx(out["right"]["omega_per_torque"])


def test_anchored_unpinned_and_pinned_lines():
    s = rft.rft_summary(Params())
    assert s["thrust_per_torque"] == pytest.approx(1.02, abs=0.01)
    # closed form, App. A Eqs. (38)–(39), full turns: F/M = −C∥/B∥
    assert s["thrust_per_torque"] == pytest.approx(app_a_thrust_per_torque(1.3, 2.1, GP, GN),
                                                   rel=1e-12)
    p = s["pinned"]
    assert 0.75 < p["thrust_per_torque"] < 0.85  # ≈ 20 % below the unpinned line
    assert 0.5 < p["axis_tilt_deg"] < 10
    assert p["thrust_per_torque"] == pytest.approx(REGRESSION["pinned_thrust_per_torque"],
                                                   rel=1e-4)
    assert p["axis_tilt_deg"] == pytest.approx(REGRESSION["pinned_axis_tilt_deg"], rel=1e-3)


def test_pinned_rotation_is_steady_and_thrust_matches_force_sum():
    h = Helix(1.3, 2.1, 10.0)
    pts, tan, w = rft.helix_nodes(h)
    pts = pts - pts[0]
    m = rft.resistance_matrix(pts, tan, w, GP, GN)
    pin = rft.pinned_rotation(m, (0, 0, 1))
    motor = -pin.axis
    omega = np.linalg.solve(m[3:, 3:], motor)  # unit torque along the motor axis
    assert np.allclose(np.cross(omega, motor), 0, atol=1e-9 * np.linalg.norm(omega))
    f = GN * np.cross(omega, pts)
    f += (GP - GN) * np.einsum("ij,ij->i", tan, np.cross(omega, pts))[:, None] * tan
    # f is the force the helix applies to the fluid, the pivot supplies it: the helix
    # pushes on the pivot with −Σf
    force_on_pivot = -(f * w[:, None]).sum(0)
    assert force_on_pivot @ motor == pytest.approx(pin.thrust_per_torque, rel=1e-9)


def test_load_sphere_limits_and_critical_line():
    # closed-form limits: a huge sphere is the anchored helix (F/M = −C∥/B∥, ω/M = 1/B∥), a
    # tiny one the force-free helix (A∥v + C∥ω = 0); Eq. (16) gives F = F_c1 on its line
    c = rft.full_turn_coefficients(Helix(1.3, 2.1, 10.0), GP, GN)
    big = rft.load_sphere(c, 1.0, 1e12, 1e-3)
    assert big["thrust"] == pytest.approx(rft.anchored_helix(c)["thrust_per_torque"], rel=1e-6)
    assert big["omega"] == pytest.approx(1 / c["B_par"], rel=1e-6)
    tiny = rft.load_sphere(c, 1.0, 1e-12, 1e-3)
    assert tiny["velocity"] == pytest.approx(-c["C_par"] * tiny["omega"] / c["A_par"], rel=1e-6)
    line = rft.critical_torque_line(c, 1.0, 1e-3)
    for a in (0.5, 1.0, 2.0):
        M = line["intercept"] + line["slope_per_inverse_radius"] / a
        assert rft.load_sphere(c, M, a, 1e-3)["thrust"] == pytest.approx(1.0, rel=1e-9)


def test_effective_rigidity_against_energy_integral():
    # App. C: energy of a unit perpendicular torque along the Frenet frame, by quadrature
    A, C = 3.5, 2.0
    h = Helix(1.3, 2.1, 200 * 2 * math.pi / K)
    s = np.linspace(0, h.length, 400001)
    t = h.tangents(s)
    n = -np.stack([np.cos(K * s), np.sin(K * s), 0 * s], -1)
    b = np.cross(t, n)
    Mx = np.array([1.0, 0, 0])
    dens = 0.5 * ((n @ Mx) ** 2 / A + (b @ Mx) ** 2 / A + (t @ Mx) ** 2 / C)
    energy = np.trapezoid(dens, s)
    a_eff_num = 0.5 * h.axial_length / energy
    assert rft.effective_bending_rigidity(h, A, C) == pytest.approx(a_eff_num, rel=1e-3)
    assert rft.effective_bending_rigidity(h, 3.5, 3.5) == pytest.approx(3.5 * math.sin(h.pitch_angle))
