"""Linear stability under a speed clamp or a torque–speed law, and of the free swimmer.

Independent references: the fixed point of the clamped dynamics, the chain rule of the
clamp's solved torque (a rank-one change of the constant-torque Jacobian), the anchored
limit of a large body, the force balance of the free swimmer, and direct simulation of a
perturbed state (slow). The free swimmer's full unreduced Jacobian is checked in
tests/test_stability.py.
"""

import math
from functools import lru_cache

import numpy as np
import pytest

from flagellum import Filament, Params, ParameterError
from flagellum.analysis.stability import (_Reduced, critical_speed, critical_torque,
                                          linear_stability, simulated_growth_rate, steady_drive)
from flagellum.motor import Boundary, Motor, MotorLaw

COARSE = Params(Filament(segment_length=0.4))  # N = 25, for the fast checks


@lru_cache(maxsize=None)
def _torque(torque, h=0.4, anchor="fixed", radius=None):
    return linear_stability(Params(Filament(segment_length=h)), torque, Boundary(anchor, radius),
                            n_eigs=1000)


@lru_cache(maxsize=None)
def _clamp(torque, h=0.4):
    """The clamped state at the speed of the constant-torque state at ``torque``."""
    ref = _torque(torque, h)
    return linear_stability(Params(Filament(segment_length=h)), n_eigs=1000,
                            motor=Motor(drive="speed", speed=ref.motor_speed))


# -- speed clamp -----------------------------------------------------------------------------
def test_clamped_state_is_a_fixed_point_needing_the_torque():
    """The clamp at the speed of the torque-M state needs M (the same hook balance, Eq. (12))
    and that state is a fixed point of the clamped dynamics in the co-rotating frame."""
    ref, res = _torque(1.0), _clamp(1.0)
    assert res.drive == "speed" and ref.drive == "torque"
    assert res.torque == pytest.approx(1.0, rel=1e-9)
    assert res.omega == pytest.approx(ref.omega, rel=1e-9)
    m = res.equilibrium.model()
    f = m.rhs(0.0, res.equilibrium.state)
    assert m.last_torque == pytest.approx(1.0, rel=1e-8)  # the kernel's own solve
    assert np.abs(_Reduced(m, res.equilibrium.state).reduce(f)).max() < 1e-6


def test_clamp_jacobian_is_the_torque_jacobian_plus_the_torque_response():
    """Chain rule: with the torque M(ξ) the clamp solves, J_clamp = J_M + (∂f/∂M) (∂M/∂ξ)ᵀ.
    Built here from the constant-torque model alone (∂f/∂M by differences in M) and the
    clamp's solved torque (∂M/∂ξ by differences of ``last_torque``)."""
    res = _clamp(1.0)
    eq = res.equilibrium
    clamp = _Reduced(eq.model(), eq.state)
    torque_eq = _torque(1.0).equilibrium
    const = _Reduced(torque_eq.model(), eq.state)
    j_clamp, j_const = clamp.jacobian(eq.omega), const.jacobian(eq.omega)
    dm = 1e-6
    plus = _Reduced(type(const.model)(COARSE, Motor(1.0 + dm), Boundary()), eq.state)
    minus = _Reduced(type(const.model)(COARSE, Motor(1.0 - dm), Boundary()), eq.state)
    for r in (plus, minus):
        r.model.set_charts(*eq.charts)
    dfdm = (plus.field(eq.state, eq.omega) - minus.field(eq.state, eq.omega)) / (2 * dm)
    grad = np.empty(clamp.size)
    xi = np.zeros(clamp.size)
    for j in range(clamp.size):
        torques = []
        for s in (1e-7, -1e-7):
            xi[j] = s
            clamp.field(clamp.embed(xi), eq.omega)
            torques.append(clamp.model.last_torque)
        xi[j] = 0.0
        grad[j] = (torques[0] - torques[1]) / 2e-7
    expect = j_const + np.outer(dfdm, grad)
    assert np.abs(j_clamp - expect).max() < 1e-5 * np.abs(j_clamp).max()
    assert np.abs(grad).max() > 1e-3  # the clamp does change the hook row: M responds


def test_clamp_changes_the_growth_rate_and_lowers_the_threshold():
    """Near the threshold the clamp destabilizes the buckling mode, λ_clamp > λ_torque (at
    N = 25, M_c1 = 1.216: M = 1.15 gives −2.37 vs −2.64 /s; regression values), so the
    critical rotation rate lies below the speed at M_c1 and λ_clamp(ω_c1) = 0."""
    assert _clamp(1.15).lambda_ > _torque(1.15).lambda_ + 0.1
    ct, cw = critical_torque(COARSE), critical_speed(COARSE)
    assert cw.drive == "speed" and ct.drive == "torque"
    assert cw.motor_speed < ct.motor_speed
    assert cw.critical_torque < ct.critical_torque
    below = linear_stability(COARSE, motor=Motor(drive="speed", speed=cw.motor_speed - 2.0))
    above = linear_stability(COARSE, motor=Motor(drive="speed", speed=cw.motor_speed + 2.0))
    assert below.lambda_ < 0 < above.lambda_
    assert above.frequency > 0  # still a Hopf bifurcation (a complex pair crosses)


def test_speed_bracket_and_torque_bracket_agree():
    a = critical_speed(COARSE, xtol=0.01)
    lo, hi = (_torque(m).motor_speed for m in (0.5, 2.0))
    b = critical_speed(COARSE, bracket=(lo, hi), xtol=0.01)
    assert b.motor_speed == pytest.approx(a.motor_speed, abs=0.05)


def test_law_on_its_plateau_is_the_torque_drive_and_past_the_knee_its_own():
    """On the flat part of a law the torque does not respond to the speed: the spectrum is
    the constant-torque one; on the falling part the law's operating point lies on the law."""
    flat = MotorLaw((0.0, 5000.0, 6000.0), (1.0, 1.0, 0.0))
    res = linear_stability(COARSE, n_eigs=1000, motor=Motor(drive="law", law=flat))
    assert res.drive == "law" and res.torque == pytest.approx(1.0, rel=1e-9)
    assert res.lambda_ == pytest.approx(_torque(1.0).lambda_, rel=1e-6)
    steep = MotorLaw.e_coli(stall_torque=2.0, knee_speed=100.0, zero_load_speed=1500.0)
    res = linear_stability(COARSE, motor=Motor(drive="law", law=steep))
    assert res.torque == pytest.approx(float(steep(res.motor_speed)), rel=1e-9)


@pytest.mark.parametrize("motor,name", [
    (Motor(1.0, reversals=(0.1,)), "reversals"),
    (Motor(1.0, ramp_time=0.1), "ramp_time"),
    (Motor(1.0, schedule=((0.0, 1.0),)), "schedule"),
    (Motor(0.0), "torque"),
])
def test_unsteady_drive_is_refused(motor, name):
    with pytest.raises(ParameterError) as e:
        steady_drive(motor)
    assert e.value.name == name


# -- free swimmer ---------------------------------------------------------------------------
def test_free_swimmer_is_force_free():
    """Force balance of bead 0 with the body sphere (Stokes drag 6πηa, centred on it): the
    filament's elastic force on bead 0 equals [6πηa + (h/2)(γ∥ tt + γ⊥(1 − tt))] v, t the
    first bond's tangent (paper Eqs. (6)–(7)); the body swims forward (v_z > 0 for M > 0)
    and, in the co-rotating frame, also sideways: its lab path is a helix."""
    a = 1.0
    res = _torque(1.0, anchor="free", radius=a)
    m, y = res.equilibrium.model(), res.equilibrium.state
    v = m.rhs(0.0, y)[3:6]  # bead 0 sits on the rotation axis: its lab velocity
    t = y[7:10] - y[3:6]
    t /= np.linalg.norm(t)
    gpar, gperp, _ = COARSE.gammas
    w = COARSE.filament.segment_length / 2
    drag = 6 * math.pi * COARSE.fluid.viscosity * a * np.eye(3) + w * (
        gpar * np.outer(t, t) + gperp * (np.eye(3) - np.outer(t, t)))
    assert m.last_force == pytest.approx(drag @ v, rel=1e-9, abs=1e-12)
    assert res.velocity == pytest.approx(v[2]) and v[2] > 0
    assert np.hypot(v[0], v[1]) > 0.1 * v[2]


def test_large_body_is_the_anchored_filament():
    """a → ∞: the body no longer moves and the free swimmer is the anchored filament."""
    free = _torque(1.0, anchor="free", radius=1e4)
    fixed = _torque(1.0)
    assert free.lambda_ == pytest.approx(fixed.lambda_, rel=1e-3)
    assert free.omega == pytest.approx(fixed.omega, rel=1e-4)


def test_free_swimmer_buckles_below_the_load_sphere():
    """The body free to move sideways lowers M_c1 below the z-only load sphere's (at a = 2
    µm: 1.41 vs 1.55 pN·µm at N = 50, docs/stability.md; regression values, here N = 25)."""
    b_free, b_sphere = Boundary("free", 2.0), Boundary("sphere", 2.0)
    free = critical_torque(COARSE, b_free, (0.8, 3.0))
    sphere = critical_torque(COARSE, b_sphere, (0.8, 3.0))
    fixed = critical_torque(COARSE)
    assert fixed.critical_torque < free.critical_torque < sphere.critical_torque


def test_free_swimmer_speed_clamp_sees_the_body_rotation():
    """The clamp is on the motor speed relative to the counter-rotating body:
    ω_rel = Ω + M/(8πηa³)."""
    a = 1.0
    ref = _torque(1.0, anchor="free", radius=a)
    body = 1.0 / (8 * math.pi * COARSE.fluid.viscosity * a ** 3)
    assert ref.motor_speed == pytest.approx(ref.omega + body, rel=1e-12)
    res = linear_stability(COARSE, boundary=Boundary("free", a),
                           motor=Motor(drive="speed", speed=ref.motor_speed))
    assert res.torque == pytest.approx(1.0, rel=1e-8)


# -- slow: simulation ------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.ci
def test_simulated_clamp_relaxes_at_the_clamped_rate():
    """At M = 1 (N = 50) the clamp's λ (−2.68 /s) differs from the torque drive's (−2.98 /s,
    docs/stability.md); a simulated relaxation under the clamp (the full nonlinear clamped
    model, no Jacobian) gives the clamp's rate."""
    ref = linear_stability(Params(), 1.0)
    res = linear_stability(Params(), motor=Motor(drive="speed", speed=ref.omega))
    assert res.lambda_ - ref.lambda_ > 0.2
    fit = simulated_growth_rate(res.equilibrium, t_end=2.0, amplitude=3e-3, fit_from=0.8)
    assert fit.rate == pytest.approx(res.lambda_, rel=0.02)


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize("torque,kw", [
    (1.5, dict(t_end=1.2, amplitude=3e-3, fit_from=0.4)),  # below M_c1 = 1.67 (λ = −5.36 /s)
    (1.9, dict(t_end=1.0, amplitude=1e-6, fit_from=0.3)),  # above (λ = +7.37 /s)
])
def test_simulated_free_swimmer_gives_the_eigenvalue(torque, kw):
    """a = 1 µm, N = 50: the full nonlinear free swimmer (no Jacobian), perturbed and
    integrated in the co-moving, co-rotating frame, grows or decays at λ."""
    res = linear_stability(Params(), torque, Boundary("free", 1.0))
    fit = simulated_growth_rate(res.equilibrium, **kw)
    assert fit.rate == pytest.approx(res.lambda_, rel=0.03, abs=0.05)
