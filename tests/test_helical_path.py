"""The helix fitted to the path of a swimming body (``fit_helical_path``, the ``path_*``
summary fields): against closed-form helices, and against the relative equilibrium of a
simulated cell with its motor off the pole (a steady swimmer moves on an exact helix about
the rotation axis of its relative equilibrium)."""

import math

import numpy as np
import pytest

from flagellum import Filament, Params, Simulator
from flagellum.analysis.observables import fit_helical_path
from flagellum.analysis.stability import _Branch
from flagellum.helix import rotation_between
from flagellum.motor import Boundary, Motor


def _helix(t, radius, pitch, period, axis, hand=1, phase=0.3, start=(1.0, -2.0, 0.5)):
    """x(t) = c + (pitch/period) t â + R (cos ωt e1 + hand·sin ωt e2), e1 × e2 = â."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    rot = rotation_between(np.array([0.0, 0.0, 1.0]), axis)
    e1, e2 = rot[:, 0], rot[:, 1]
    w = 2 * math.pi / period
    ang = w * t + phase
    return (np.asarray(start) + np.outer(t * pitch / period, axis)
            + radius * (np.outer(np.cos(ang), e1) + hand * np.outer(np.sin(ang), e2)))


@pytest.mark.parametrize("hand", [1, -1])
def test_closed_form_helix(hand):
    """A tilted helix over 7.3 turns (not a whole number) is recovered to round-off."""
    t = np.linspace(0.0, 0.0913, 1500)
    axis = (0.3, -0.5, 0.8)
    fit = fit_helical_path(t, _helix(t, 0.07, 0.4, 0.0125, axis, hand))
    assert fit.radius == pytest.approx(0.07, rel=1e-8)
    assert fit.pitch == pytest.approx(0.4, rel=1e-8)
    assert fit.period == pytest.approx(0.0125, rel=1e-8)
    assert fit.axis == pytest.approx(np.array(axis) / np.linalg.norm(axis), abs=1e-9)
    assert fit.handedness == hand
    assert fit.residual < 1e-7 * 0.07  # the ω search stops at ~1e-9 relative


def test_noisy_helix_and_straight_path():
    """Noise of 1 % of the radius moves the fit by about that much; a straight path has no
    turn (R = 0, NaN period), and too few records give NaN."""
    rng = np.random.default_rng(1)
    t = np.linspace(0.0, 0.2, 4000)
    x = _helix(t, 0.1, 0.3, 0.01, (0, 0, 1)) + 1e-3 * rng.normal(size=(len(t), 3))
    fit = fit_helical_path(t, x)
    assert fit.radius == pytest.approx(0.1, rel=0.01)
    assert fit.period == pytest.approx(0.01, rel=1e-4)
    assert fit.residual == pytest.approx(math.sqrt(3) * 1e-3, rel=0.05)
    line = fit_helical_path(t, np.outer(t, [1.0, 2.0, 2.0]))
    assert line.radius == 0.0 and math.isnan(line.period)
    assert line.axial_speed == pytest.approx(3.0)
    assert math.isnan(fit_helical_path(t[:5], x[:5]).radius)


def test_simulated_off_centre_cell_swims_on_the_equilibrium_helix():
    """A cell (sphere a = 1 µm, motor 40° off the pole, elastic hook k = 5 pN·µm, M = 1,
    N = 25; its aligned state is stable, λ ≈ −16 /s) simulated from the stress-free helix
    settles on the helix of its relative equilibrium: period 2π/Ω, pitch 2π v/Ω, and radius
    the distance of the body's centre from the screw axis (through p, with the rotating
    frame's velocity of bead 0 u = v e_z − Ω e_z × p)."""
    params = Params(Filament(segment_length=0.4))
    b = Boundary(anchor="free", body_radius=1.0, hook="elastic", hook_stiffness=5.0, motor_offset=40.0)
    eq = _Branch(params, b).at(1.0)
    m = eq.model()
    u = m.rhs(0.0, eq.state)[3:6]  # bead 0 sits at the origin
    p = np.cross([0.0, 0.0, 1.0], u) / eq.omega
    centre = m.body_motion(0.0, eq.state)["position"] - p
    tr = Simulator(params, Motor(1.0), b).run(0.5, save_every=2e-4, progress=False)
    sel = tr.t >= 0.3
    fit = fit_helical_path(tr.t[sel], tr.body_position[sel])
    assert fit.period == pytest.approx(2 * math.pi / eq.omega, rel=1e-5)
    assert fit.pitch == pytest.approx(2 * math.pi * u[2] / eq.omega, rel=1e-5)
    assert fit.radius == pytest.approx(math.hypot(centre[0], centre[1]), rel=1e-4)
    assert fit.handedness == (1 if eq.omega * u[2] > 0 else -1)
    s = tr.summary(0.3)
    assert (s.path_radius, s.path_pitch, s.path_period) == (fit.radius, fit.pitch, fit.period)
    assert np.array([s.path_axis_x, s.path_axis_y, s.path_axis_z]) == pytest.approx(fit.axis)
