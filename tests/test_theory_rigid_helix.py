"""Rigid helix under a constant torque (App. B): Euler's equations and precession."""

import numpy as np
import pytest

from flagellum.errors import ParameterError
from flagellum.helix import rot_x, rot_y
from flagellum.theory.rigid_helix import euler_rates, rotate, rotational_resistance


def test_symmetric_top_precesses_at_M_over_B1():
    # symmetric top (Landau & Lifshitz, Sec. 33): the axis precesses about L at L/I₁
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
    assert m2[0] == pytest.approx(1.09, rel=1e-12)  # |M|² = 0.3² + 1² of the given torque
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


def _stiff_filament_vs_rigid(stiffness: float, t_end: float = 0.05) -> float:
    """Max distance between the simulated and the rigid-body (App. B) centroid, relative to
    its distance from the pivot, for the paper's filament with A and C × ``stiffness``,
    pinned at bead 0 and started 0.5 rad off its steady axis (it precesses)."""
    from flagellum import Filament, Params
    from flagellum.helix import DiscreteHelix, discrete_helix
    from flagellum.hydro import rft
    from flagellum.motor import Motor
    from flagellum.rod.model import RodModel
    from flagellum.simulator import Simulator, SolverOptions, State

    p = Params(Filament(bend_rigidity=3.5 * stiffness, twist_rigidity=3.5 * stiffness))
    dh = discrete_helix(p.filament)
    R0 = rot_x(0.5)
    dh = DiscreteHelix(dh.positions @ R0.T, np.einsum("ij,njk->nik", R0, dh.frames),
                       R0 @ dh.axis_point, R0 @ dh.axis_direction, dh.radius, dh.pitch,
                       dh.segment_length)
    start = RodModel(p)
    y0 = start.initial_state(dh)  # sets the charts to the helix' frames
    sim = Simulator.from_state(State(y0, start.charts()), p, Motor(1.0),
                               solver=SolverOptions(frame="lab", rtol=1e-8, atol=1e-10))
    tr = sim.run(t_end, save_every=t_end / 50)
    B = rft.resistance_matrix(*rft.bead_nodes(dh), *p.gammas, origin=dh.positions[0])[3:, 3:]
    rig = rotate(B, [0.0, 0.0, 1.0], t_end, n_out=51)
    c0 = (dh.positions - dh.positions[0]).mean(axis=0)
    c_sim = (tr.positions - tr.positions[:, :1]).mean(axis=1)
    c_rig = np.einsum("nij,j->ni", rig.R, c0)
    assert np.degrees(np.arccos(-c_rig[-1, 2] / np.linalg.norm(c_rig[-1]))) < 28.0  # it moves
    return float(np.abs(c_sim - c_rig).max() / np.linalg.norm(c0))


def test_very_stiff_filament_moves_like_the_rigid_helix():
    """App. B against the simulator: a filament 100× stiffer than the paper's follows the
    rigid-body rotation ω = R B⁻¹ Rᵀ M (tilt and precession of the axis) to 0.5 %, and the
    deviation shrinks as the filament stiffens (elastic deformation ∝ 1/A)."""
    e100 = _stiff_filament_vs_rigid(100.0)
    e10 = _stiff_filament_vs_rigid(10.0)
    assert e100 < 5e-3
    assert e10 > 5 * e100


def test_axis_along_the_torque_does_not_precess():
    B = np.diag([1.0, 1.0, 0.1])
    assert rotate(B, [0.0, 0.0, 1.0], 1.0, n_out=11).precession_rate() == 0.0
