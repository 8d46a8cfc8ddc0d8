"""Rigid helix under a constant torque (App. B): Euler's equations and precession."""

import numpy as np
import pytest

from flagellum.errors import ParameterError
from flagellum.helix import rot_x, rot_y
from flagellum.theory.rigid_helix import euler_rates, rotate, rotational_resistance


def test_symmetric_top_precesses_at_M_over_B1():
    # symmetric top (Landau & Lifshitz §33): the axis precesses about L at L/I₁
    B = np.diag([4.0, 4.0, 0.5])
    run = rotate(B, [0.0, 0.0, 2.0], 30.0, R0=rot_x(0.7), n_out=3001)
    assert run.precession_rate() == pytest.approx(2.0 / 4.0, rel=1e-8)
    tilt = np.degrees(np.arccos(run.axis[:, 2]))
    assert np.ptp(tilt) < 1e-7   # the cone angle is fixed


def test_conserved_quantities_and_euler_equations():
    B = rotational_resistance()
    vals, vecs = np.linalg.eigh(B)
    vecs[:, 2] *= np.linalg.det(vecs)   # Euler's equations need a right-handed eigenframe
    run = rotate(B, [0.3, 0.0, 1.0], 0.4, R0=rot_y(0.4) @ rot_x(0.3), n_out=16001)
    m2, p = run.torque_squared, run.dissipation
    assert np.ptp(m2) < 1e-10 * m2[0] and np.ptp(p) < 1e-7 * p[0]
    assert m2[0] == pytest.approx(1.09, rel=1e-12)
    w = run.omega_body @ vecs   # components in the eigenframe of B
    dw = np.gradient(w, run.t, axis=0, edge_order=2)
    pred = np.array([euler_rates(vals, x) for x in w])
    inner = slice(10, -10)
    assert np.max(np.abs(dw[inner] - pred[inner])) < 1e-3 * np.max(np.abs(pred))


def test_long_helix_resistance_nearly_axisymmetric():
    # App. B: B₁ ≈ B₂ ∝ L³ ≫ B₃ ∝ L for the normal-form filament
    vals = np.linalg.eigvalsh(rotational_resistance())
    assert vals[0] < 0.01 * vals[1]
    assert vals[2] == pytest.approx(vals[1], rel=0.01)


@pytest.mark.parametrize("B", [np.eye(2), np.array([[1.0, 2.0, 0], [0, 1.0, 0], [0, 0, 1.0]]),
                               -np.eye(3)])
def test_invalid_resistance(B):
    with pytest.raises(ParameterError):
        rotate(B, [0, 0, 1.0], 1.0)
