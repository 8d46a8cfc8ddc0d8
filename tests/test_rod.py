"""Discrete rod: energy, exact gradients (finite differences), invariances, sign convention."""

import numpy as np
import pytest

from flagellum import Filament, Params
from flagellum.helix import rot_x, rot_z
from flagellum.motor import Boundary, Motor
from flagellum.rod import kernels as K
from flagellum.rod.model import RodModel, angles, positions


def _model(hand="right", **bkw):
    return RodModel(Params(Filament(length=2.0, handedness=hand)),
                    boundary=Boundary(**bkw) if bkw else None)


def _perturbed(m, scale=0.05, seed=0):
    y = m.initial_state()
    return y + scale * np.random.default_rng(seed).normal(size=y.shape)


def _fd(fun, y, idx, eps=1e-6):
    yp, ym = y.copy(), y.copy()
    yp[idx] += eps
    ym[idx] -= eps
    return (fun(yp) - fun(ym)) / (2 * eps)


def _chart_gradient(m, y):
    """∂E/∂r at fixed θ from the gauge-free gradient plus the chart's spin connection."""
    e, dr, dth, _ = m.gradients(y)
    n = m.n
    T, E1, E2, S = (np.zeros((n + 1, 3)) for _ in range(4))
    L = np.zeros(n + 1)
    K.frames(y, n, m.ref_u, m.ref_e, T, E1, E2, L, S, np.zeros((n + 1, 3)))
    out = dr.copy()
    for i in range(1, n + 1):
        g = dth[i] * S[i]
        g = (g - (g @ T[i]) * T[i]) / L[i]
        out[i] += g
        out[i - 1] -= g
    return out, dth


@pytest.mark.parametrize("hand", ["right", "left"])
@pytest.mark.parametrize("hook", [{}, {"hook": "elastic", "hook_stiffness": 0.3}])
def test_gradients_match_finite_differences(hand, hook):
    m = _model(hand, **hook)
    y = _perturbed(m)
    dr, dth = _chart_gradient(m, y)
    num_th = np.array([_fd(m.energy, y, 6 + 4 * i) for i in range(m.n + 1)])
    num_r = np.array([[_fd(m.energy, y, 3 + 4 * i + k) for k in range(3)] for i in range(m.n + 1)])
    assert np.abs(num_th - dth).max() < 1e-7 * np.abs(dth).max()
    assert np.abs(num_r - dr).max() < 1e-7 * np.abs(dr).max()


def test_hook_torque_is_rotation_derivative():
    m = _model()
    y = _perturbed(m, seed=3)
    _, _, dth, gt = m.gradients(y)
    u = y[:3] / np.linalg.norm(y[:3])
    torque = np.cross(u, gt[0]) + dth[0] * u
    n = m.n
    T, E1, E2, S = (np.zeros((n + 1, 3)) for _ in range(4))
    K.frames(y, n, m.ref_u, m.ref_e, T, E1, E2, np.zeros(n + 1), S, np.zeros((n + 1, 3)))

    def rotated(axis, eps):
        # rotate frame 0 rigidly by eps about axis: u → R u, θ0 → θ0 + eps a·t − s·δt
        yy = y.copy()
        R = _rotvec(axis * eps)
        yy[:3] = R @ y[:3]
        t_new = yy[:3] / np.linalg.norm(yy[:3])
        # material e1 rotates rigidly; recover θ0 from the chart
        e1 = R @ E1[0]
        uu, ee = m.ref_u[0], m.ref_e[0]
        c = np.cross(uu, t_new)
        d = uu @ t_new
        a1 = d * ee + np.cross(c, ee) + (c @ ee) / (1 + d) * c
        a2 = np.cross(t_new, a1)
        yy[6] = np.arctan2(e1 @ a2, e1 @ a1)
        return m.energy(yy)

    for k in range(3):
        ax = np.eye(3)[k]
        num = (rotated(ax, 1e-6) - rotated(ax, -1e-6)) / 2e-6
        assert num == pytest.approx(torque[k], rel=1e-6, abs=1e-8 * np.abs(torque).max())


def _rotvec(v):
    th = np.linalg.norm(v)
    if th == 0:
        return np.eye(3)
    k = v / th
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * kx + (1 - np.cos(th)) * kx @ kx


def test_relaxed_helix_stays_put():
    m = RodModel(Params(), motor=Motor(0.0))
    y = m.initial_state()
    assert m.energy(y) < 1e-20
    assert np.abs(m.rhs(0.0, y)).max() < 1e-6  # rad/s and µm/s, numerically zero


def test_rigid_motions_cost_nothing_and_gradient_rotates():
    m = _model()
    y = _perturbed(m, 0.02)
    e0, dr0, dth0, _ = m.gradients(y)
    R = rot_z(0.4) @ rot_x(1.1)
    m2 = _model()
    m2.initial_state()
    m2.set_charts(m.ref_u @ R.T, m.ref_e @ R.T, m.ref_m)
    y2 = y.copy()
    y2[:3] = R @ y[:3]
    p = positions(y) @ R.T + np.array([0.3, -2.0, 5.0])
    y2[3:].reshape(-1, 4)[:, :3] = p
    e2, dr2, dth2, _ = m2.gradients(y2)
    assert e2 == pytest.approx(e0, rel=1e-12)
    assert np.allclose(dr2, dr0 @ R.T, atol=1e-9 * np.abs(dr0).max())
    assert np.allclose(dth2, dth0, atol=1e-9 * np.abs(dth0).max())


def test_force_is_gauge_invariant_under_rechart():
    m = _model()
    y = _perturbed(m, 0.3, seed=5)
    e0, dr0, dth0, _ = m.gradients(y)
    # force every chart to move: poles jump to the current tangents
    assert m.rechart(y, threshold=2.0)
    e1, dr1, dth1, _ = m.gradients(y)
    assert e1 == pytest.approx(e0, rel=1e-12)
    assert np.allclose(dr1, dr0, atol=1e-10 * np.abs(dr0).max())
    assert np.allclose(dth1, dth0, atol=1e-10 * np.abs(dth0).max())


def test_energy_decreases_without_motor():
    from scipy.integrate import solve_ivp

    m = RodModel(Params(Filament(length=2.0)), motor=Motor(0.0))
    y0 = _perturbed(m, 0.02, seed=2)
    sol = solve_ivp(m.rhs, (0, 2e-4), y0, method="BDF", rtol=1e-8, atol=1e-10,
                    t_eval=np.linspace(0, 2e-4, 40))
    e = np.array([m.energy(y) for y in sol.y.T])
    assert np.all(np.diff(e) <= 1e-9 * e[0])
    assert e[-1] < 0.5 * e[0]


@pytest.mark.parametrize("hand,sign", [("right", 1), ("left", -1)])
def test_sign_convention_first_bond(hand, sign):
    """M > 0 pushes for a right-handed helix: the first bond is compressed, F > 0."""
    from scipy.integrate import solve_ivp

    m = RodModel(Params(Filament(handedness=hand)), motor=Motor(0.5), omega_frame=356.0)
    y0 = m.initial_state()
    sol = solve_ivp(m.rhs, (0, 0.01), y0, method="BDF", rtol=1e-5, atol=1e-8)
    y = sol.y[:, -1]
    p = positions(y)
    strain = np.linalg.norm(p[1] - p[0]) / 0.2 - 1
    thrust = m.bead_force(0.01, y)[2]
    assert sign * strain < 0 and sign * thrust > 0
    assert abs(strain) == pytest.approx(abs(thrust) / 1e3, rel=0.5)  # tension/K, order of magnitude


@pytest.mark.parametrize("boundary", [Boundary(), Boundary(hook="clamped"),
                                      Boundary(hook="elastic", hook_stiffness=0.5),
                                      Boundary(anchor="sphere", sphere_radius=1.0),
                                      Boundary(anchor="free", sphere_radius=0.5)])
def test_jacobian_is_banded_and_colouring_is_exact(boundary):
    """Every entry of the full (dense, column-by-column) finite-difference Jacobian at a
    generic state lies inside the band (KL, KU) that the stiff solvers assume, and the
    coloured Jacobian (fewer right-hand sides) equals the plain banded one bit for bit."""
    from flagellum.integrate.cvode import KL, KU

    m = RodModel(Params(Filament(segment_length=0.5)), Motor(1.0), boundary, omega_frame=200.0)
    y = m.initial_state()
    rng = np.random.default_rng(4)
    y[3:] += rng.normal(0.0, 0.03, len(y) - 3)
    ny = len(y)
    f0 = m.rhs(0.0, y).copy()
    dense = np.zeros((ny, ny))
    for j in range(ny):
        yp = y.copy()
        yp[j] += 1e-6
        dense[:, j] = m.rhs(0.0, yp) - f0
    rows, cols = np.nonzero(dense)
    assert (rows - cols).max() <= KL and (cols - rows).max() <= KU
    assert (rows - cols).max() == KL and (cols - rows).max() == KU  # and they are tight
    color, lo, hi = m.jacobian_colors(KL, KU)
    assert color.max() + 1 < KL + KU + 1
    ab1, ab2 = np.zeros((ny, 2 * KL + KU + 1)), np.zeros((ny, 2 * KL + KU + 1))
    args = (*m.kernel_arrays, KL, KU)
    K.band_jacobian(y, f0, *args, ab1, 1.0, np.zeros(ny), np.zeros(ny))
    K.colored_jacobian(y, f0, *args, ab2, 1.0, np.zeros(ny), np.zeros(ny), color, lo, hi)
    assert np.array_equal(ab1, ab2)


def test_fast_atan2_is_accurate_to_two_ulp():
    """The kernels' atan2 (Cephes rational approximation) against numpy's, all quadrants and
    scales, edge cases included."""
    from numba import njit

    from flagellum._jit import atan2

    @njit
    def vec(a, b, out):
        for i in range(a.shape[0]):
            out[i] = atan2(a[i], b[i])

    rng = np.random.default_rng(0)
    for scale in (1e-12, 1e-3, 1.0, 1e4):
        a, b = rng.standard_normal(200_000) * scale, rng.standard_normal(200_000)
        a[:4], b[:4] = (0.0, 1.0, -1.0, 0.0), (1.0, 0.0, 0.0, -1.0)
        out = np.empty_like(a)
        vec(a, b, out)
        ref = np.arctan2(a, b)
        assert np.all(np.abs(out - ref) <= 2 * np.spacing(np.abs(ref))), scale
    out = np.empty(1)
    vec(np.array([np.nan]), np.array([1.0]), out)
    assert np.isnan(out[0])


def test_degenerate_state_gives_non_finite_values_not_an_exception():
    """Two consecutive bonds exactly reversed (a wild trial state of a stiff solver): the
    kernels return inf/NaN, which the integrators treat as a failed step; a Python
    ZeroDivisionError (Numba's default error model) used to end the whole run."""
    m = RodModel(Params(Filament(segment_length=0.5)), Motor(1.0))
    y = m.initial_state()
    p = y[3:].reshape(-1, 4)
    p[2, :3] = p[0, :3]  # bead 2 on bead 0: bond 2 = −bond 1
    out = m.rhs(0.0, y)
    assert not np.all(np.isfinite(out))
