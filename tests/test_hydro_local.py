"""The local drag kernels (flagellum.hydro.local): the friction the right-hand side divides by
is the friction the thermal forces are drawn from (fluctuation–dissipation), bead by bead and
for every anchor; and the rigid-helix bead quadrature uses the same nodes."""

import numpy as np
import pytest

from flagellum import Params
from flagellum.helix import discrete_helix
from flagellum.hydro import local as L
from flagellum.hydro.rft import bead_nodes


def _bond_tangents(n=6, seed=0):
    t = np.random.default_rng(seed).normal(size=(n + 1, 3))
    return t / np.linalg.norm(t, axis=1)[:, None]


@pytest.mark.parametrize("anchor", [L.FIXED, L.AXIAL, L.FREE])
@pytest.mark.parametrize("bead", [0, 3, 6])
def test_noise_covariance_is_the_inverse_mobility(anchor, bead):
    # closed form: thermal force ξ = c R^{1/2} g with g ~ N(0, 1) has ⟨ξξᵀ⟩ = c² R, and the
    # velocity is v = R⁻¹ f (on the directions the bead can move), so R_noise · M = P (projector)
    T, n, h, gpar, gperp, zeta, c = _bond_tangents(), 6, 0.2, 1.6e-3, 2.8e-3, 9.4e-3, 3.0
    tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, bead, n, h, gpar, gperp, anchor, zeta)
    S = np.array([L.bead_noise(c, *e, tx, ty, tz, zpar, zperp, mode) for e in np.eye(3)]).T
    M = np.array([L.bead_velocity(*e, tx, ty, tz, zpar, zperp, mode) for e in np.eye(3)]).T
    P = np.array([L.bead_directions(mode, *e) for e in np.eye(3)]).T
    np.testing.assert_allclose(S @ S.T / c**2 @ M, P, atol=1e-12)
    if bead > 0 or anchor == L.FREE:  # the anisotropic RFT friction w[γ∥tt + γ⊥(1 − tt)] (+ ζ)
        t = np.array([tx, ty, tz])
        w = h * (0.5 if bead in (0, n) else 1.0)
        extra = zeta if bead == 0 else 0.0
        R = w * (gpar * np.outer(t, t) + gperp * (np.eye(3) - np.outer(t, t))) + extra * np.eye(3)
        np.testing.assert_allclose(np.linalg.inv(M), R, rtol=1e-12)


def test_load_sphere_bead_moves_along_z_with_sphere_drag_added():
    # Sec. 3.3: the load sphere adds 6πηa to the axial friction of bead 0 and holds it on z
    T, h, gpar, gperp, zeta = _bond_tangents(), 0.2, 1.6e-3, 2.8e-3, 9.4e-3
    tx, ty, tz, zpar, _, mode = L.bead_friction(T, 0, 6, h, gpar, gperp, L.AXIAL, zeta)
    assert mode == L.AXIAL
    assert zpar == pytest.approx(0.5 * h * (gpar * tz**2 + gperp * (1 - tz**2)) + zeta, rel=1e-14)
    assert L.bead_velocity(1.0, 2.0, 3.0, tx, ty, tz, zpar, 0.0, mode) == (0.0, 0.0, 3.0 / zpar)


def test_hook_friction_clamped_has_no_perpendicular_rotation():
    # a bond of length h turning about its end: ½γ⊥h³ across the tangent, γR h about it
    assert L.hook_friction(0.2, 2.8e-3, 1.26e-6, False) == pytest.approx((1.26e-6 * 0.2, 0.5 * 2.8e-3 * 0.2**3))
    assert L.hook_friction(0.2, 2.8e-3, 1.26e-6, True)[1] == 0.0


def test_rigid_helix_bead_nodes_are_the_kernel_nodes():
    # weights sum to the contour length (end beads h/2); interior tangents are the normalized
    # averages of the two adjacent bonds (paper Sec. 2.2)
    dh = discrete_helix(Params().filament)
    pts, t, w = bead_nodes(dh)
    e3 = dh.tangents
    assert w.sum() == pytest.approx(Params().filament.length, rel=1e-12)
    assert w[0] == w[-1] == pytest.approx(dh.segment_length / 2)
    mid = (e3[:-1] + e3[1:]) / np.linalg.norm(e3[:-1] + e3[1:], axis=1)[:, None]
    np.testing.assert_allclose(t[1:-1], mid, atol=1e-14)
    np.testing.assert_allclose(t[0], e3[0]), np.testing.assert_allclose(t[-1], e3[-1])
