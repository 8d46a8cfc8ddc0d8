"""The Numba BDF stepper (``method="bdf"``): the same compiled algorithm on a linear stiff
problem with a closed-form solution, the motor's drive against :class:`Motor`, the rod's
observables against CVODE, and the stepper contract (restarts, checkpoints, resume)."""

import math
import types

import numpy as np
import pytest
from numba import njit

from flagellum import Params
from flagellum.errors import ParameterError
from flagellum.hydro.options import Hydrodynamics
from flagellum.integrate import bdf as B
from flagellum.integrate.base import STEPPERS, Stepper, make_stepper
from flagellum.motor import Boundary, Motor
from flagellum.rod.model import RodModel
from flagellum.simulator import Simulator, SolverOptions

SHORT = Params.from_flat({"length": 2.0})

# -- a linear stiff test problem: y' = A (y − φ(t)) + φ'(t), exact solution y = φ ------------
# A is tridiagonal with eigenvalue-like diagonal −λ_i spread over 1 … 1e6 /s (stiffness ratio
# 1e6, as the rod's twist against its buckling mode) and φ_i(t) = cos(ω_i t + i): started at
# φ(0), the exact solution is φ itself.
N_LIN = 12
LAM = np.logspace(0, 6, N_LIN)
OMEGA = np.linspace(1.0, 3.0, N_LIN)


@njit
def _lin_fun(t, y, out, ka, drive, general=None):
    lam, om = ka
    n = y.shape[0]
    for i in range(n):
        e = y[i] - math.cos(om[i] * t + i)
        out[i] = -lam[i] * e - om[i] * math.sin(om[i] * t + i)
        if i > 0:  # weak coupling to the neighbours (keeps the band structure)
            out[i] += 0.1 * (y[i - 1] - math.cos(om[i - 1] * (t) + i - 1))
    return True


@njit
def _lin_jacobian(t, y, f, ka, drive, kl, ku, jab, yw, fw, color, lo, hi, ist, general=None):
    lam, om = ka
    kv = kl + ku
    jab[:, :] = 0.0
    for j in range(y.shape[0]):
        jab[j, kv] = -lam[j]  # ∂f_j/∂y_j
        if j + 1 < y.shape[0]:
            jab[j, kv + 1] = 0.1  # ∂f_{j+1}/∂y_j
    ist[B.I_JAC] += 1
    ist[B.I_JAC_CUR] = 1
    ist[B.I_JAC_OK] = 1
    ist[B.I_LU_OK] = 0
    return True


def _same_code_on(fun, jac):
    """:func:`bdf_start` and :func:`bdf_advance` compiled from their own bytecode with the
    rod's right-hand side and Jacobian replaced by ``fun`` and ``jac``."""
    out = []
    kry = B._krylov_solve.py_func  # the GMRES Newton solve calls the right-hand side too
    kry = njit(types.FunctionType(kry.__code__, dict(kry.__globals__, _fun=fun), kry.__name__))
    for f in (B.bdf_start, B.bdf_advance):
        g = dict(f.py_func.__globals__, _fun=fun, _jacobian=jac, _krylov_solve=kry)
        out.append(njit(types.FunctionType(f.py_func.__code__, g, f.py_func.__name__)))
    return out


START, ADVANCE = _same_code_on(_lin_fun, _lin_jacobian)


def _solve_linear(rtol, t_out=(0.5, 1.0, 2.0)):
    n = N_LIN
    y0 = np.cos(np.arange(n))  # φ(0)
    D = np.zeros((B.MAX_ORDER + 3, n))
    st, ist = np.zeros(6), np.zeros(B.N_ISTATE, np.int64)
    st[B.S_RTOL], st[B.S_ATOL] = rtol, rtol
    ka = (LAM, OMEGA)
    kl = ku = 1
    assert START(0.0, y0, D, st, ist, ka, None, np.zeros(n), np.zeros(n), None)
    ldab = 2 * kl + ku + 1
    args = (np.zeros((n, ldab)), np.zeros((n, ldab)), np.zeros(n, np.int64),
            np.zeros((n, kl + ku + 1)), np.zeros(n, np.int64), np.zeros(n, np.int64),
            np.zeros(n, np.int64))
    errs = []
    for t in t_out:
        y = np.zeros(n)
        assert ADVANCE(t, y, D, st, ist, ka, None, kl, ku, *args, 100000, None) == 0
        exact = np.cos(OMEGA * t + np.arange(n))
        errs.append(np.abs(y - exact).max())
    return max(errs), ist


def test_linear_stiff_problem_converges_to_its_exact_solution_with_the_tolerance():
    """Tolerance proportionality of a variable-order BDF (Shampine, Numerical Solution of
    ODEs, 1994, Sec. 6.6): the global error falls about as fast as rtol, and stays within a
    modest multiple of it."""
    errs = {}
    for rtol in (1e-4, 1e-6, 1e-8):
        errs[rtol], ist = _solve_linear(rtol)
        assert errs[rtol] < 30 * rtol, rtol
        assert ist[B.I_ORDER] >= 3  # the order rose from 1 on the smooth solution
    slope = math.log10(errs[1e-4] / errs[1e-8]) / 4
    assert 0.7 < slope < 1.3


def test_first_step_is_the_closed_form_ndf1_step():
    """Scalar y' = −λ y: the first step is the first-order NDF of Shampine & Reichelt (1997),
    (y1 − y0) − κ1 (y1 − y0 − h f0) = h f(y1) with κ1 = −0.185, so
    y1 = y0 (1 − κ1 (1 − λh))/(1 − κ1 + λh) (Newton is exact on a linear problem)."""
    lam = 50.0

    @njit
    def fun(t, y, out, ka, drive, general):
        out[0] = -lam * y[0]
        return True

    @njit
    def jac(t, y, f, ka, drive, kl, ku, jab, yw, fw, color, lo, hi, ist, general):
        jab[0, kl + ku] = -lam
        ist[B.I_JAC_CUR] = 1
        ist[B.I_JAC_OK] = 1
        ist[B.I_LU_OK] = 0
        return True

    start, advance = _same_code_on(fun, jac)
    D = np.zeros((B.MAX_ORDER + 3, 1))
    st, ist = np.zeros(6), np.zeros(B.N_ISTATE, np.int64)
    st[B.S_RTOL], st[B.S_ATOL] = 1e-6, 1e-8
    assert start(0.0, np.ones(1), D, st, ist, None, None, np.zeros(1), np.zeros(1), None)
    h = st[B.S_H]
    y = np.zeros(1)
    z = np.zeros((1, 1))
    i0 = np.zeros(1, np.int64)
    assert advance(1e-300, y, D, st, ist, None, None, 0, 0, z, z.copy(), i0, z.copy(),
                   i0, i0, i0, 10, None) == 0
    assert ist[B.I_STEPS] == 1 and st[B.S_T] == pytest.approx(h)
    k1 = -0.1850
    assert D[0, 0] == pytest.approx((1 - k1 * (1 - lam * h)) / (1 - k1 + lam * h), rel=1e-12)
    # and long after: the exact decay within the tolerance
    advance(0.1, y, D, st, ist, None, None, 0, 0, z, z.copy(), i0, z.copy(), i0, i0, i0, 10000,
            None)
    assert y[0] == pytest.approx(math.exp(-lam * 0.1), abs=30 * 1e-6 * 1e-2 + 1e-8)


# -- the motor's drive value --------------------------------------------------------------
@pytest.mark.parametrize("motor", [
    Motor(1.3), Motor(2.0, ramp_time=0.01), Motor(schedule=((0.0, 0.5), (0.01, 2.0), (0.03, 1.0))),
    Motor(drive="speed", speed=300.0, ramp_time=0.005), Motor(1.0, reversals=(0.004, 0.011)),
    Motor(1.0, reversal_rates=(200.0, 300.0), reversal_seed=7)])
def test_drive_value_is_the_motors(motor):
    table = B.drive_table(motor, 0.05)
    for t in np.linspace(0.0, 0.05, 397):
        assert B.drive_value(t, *table) == pytest.approx(motor(t), rel=1e-14, abs=1e-15)


# -- the rod: observables against CVODE, the stepper contract --------------------------------
def test_registered_and_satisfies_the_protocol():
    m = RodModel(SHORT, Motor(0.3))
    s = make_stepper("bdf", m, 0.0, m.initial_state(), SolverOptions(method="bdf"))
    assert type(s) is STEPPERS["bdf"] and isinstance(s, Stepper)
    assert s.fixed_step is None and s.rng_state is None
    y = s.advance(1e-3)
    assert y is s.y and s.t == 1e-3 and s.n_steps > 0 and set(s.stats) >= {"rhs", "jacobians"}


def test_refuses_thermal_and_unfrozen_nonlocal_runs():
    with pytest.raises(ParameterError, match="method"):
        Simulator(SHORT, thermal=True, solver=SolverOptions(method="bdf"))
    # refresh 0 rebuilds ΔM in RodModel.rhs, which the compiled loop does not call
    with pytest.raises(ParameterError, match="method.*cvode"):
        Simulator(SHORT, Motor(0.5), solver=SolverOptions(method="bdf"),
                  hydrodynamics=Hydrodynamics("sbt", refresh=0.0)).run(
                      1e-3, save_every=1e-3, progress=False)
    # the trap's centre moves with time in RodModel.rhs, which the compiled loop does not call
    from flagellum.params import EndLoad

    with pytest.raises(ParameterError, match="method.*pull-rate"):
        Simulator(SHORT, Motor(0.0), solver=SolverOptions(method="bdf"),
                  end_load=EndLoad(trap_stiffness=10.0, pull_rate=0.1)).run(
                      1e-3, save_every=1e-3, progress=False)
    with pytest.raises(ParameterError, match="method"):  # a cell body couples outside the band
        Simulator(SHORT, Motor(0.5), solver=SolverOptions(method="bdf"),
                  boundary=Boundary(anchor="free", body_radius=0.5)).run(
                      1e-3, save_every=1e-3, progress=False)


def test_default_method_is_the_bdf_where_it_supports_the_run():
    """The method of a run that names none: the BDF for a deterministic local run, CVODE where
    the BDF refuses the run (the checks above) or was not measured, the implicit scheme with
    noise; a method that is named is kept."""
    from flagellum.integrate import default_method
    from flagellum.params import EndLoad, Polymorphism

    assert default_method() == "bdf" and default_method(thermal=True) == "implicit"
    assert {default_method(**{k: True}) for k in ("cell", "moving_trap", "polymorphic")} == {"cvode"}
    assert default_method(local=False) == "bdf"
    assert default_method(local=False, unfrozen=True) == "cvode"
    # the BDF with a frozen nonlocal ΔM: measured to work up to N = 200 (GMRES Newton above 100)
    assert default_method(local=False, segments=100) == "bdf" == default_method(
        local=False, segments=200)
    assert default_method(local=False, segments=400) == "cvode" == default_method(
        local=False, segments=200, unfrozen=True)
    assert default_method(segments=400) == "bdf"
    runs = {
        "bdf": [Simulator(SHORT, Motor(0.5)),
                Simulator(SHORT, Motor(0.5), end_load=EndLoad(force=0.1)),
                Simulator(SHORT, Motor(0.5), boundary=Boundary(anchor="free", sphere_radius=0.5)),
                Simulator(SHORT, Motor(0.5), hydrodynamics=Hydrodynamics("sbt"))],
        "cvode": [Simulator(SHORT, Motor(0.5), hydrodynamics=Hydrodynamics("sbt", refresh=0.0)),
                  Simulator(SHORT, Motor(0.0), end_load=EndLoad(trap_stiffness=10.0, pull_rate=0.1)),
                  Simulator(SHORT, Motor(0.5), boundary=Boundary(anchor="free", body_radius=0.5)),
                  Simulator(SHORT, Motor(0.5), polymorphism=Polymorphism()),
                  Simulator(SHORT, Motor(0.5), solver=SolverOptions(method="cvode"))],
        "implicit": [Simulator(SHORT, thermal=True)]}
    assert {k: [s.solver.method for s in v] for k, v in runs.items()} == {
        k: [k] * len(v) for k, v in runs.items()}
    assert SolverOptions().method is None


@pytest.mark.parametrize("torque, t_end, tol", [(0.25, 0.05, 1e-5), (1.6, 0.03, 2e-4)])
def test_time_averages_agree_with_cvode(torque, t_end, tol):
    """Paper filament from rest: small torque (F/M on the pinned rigid-helix line, paper
    Fig. 3) and buckled (regime iii): time-averaged thrust and rotation rate of the second
    half against CVODE at rtol 1e-9 (an independent BDF implementation)."""
    out = {}
    for method, rtol in (("bdf", 1e-6), ("cvode", 1e-9)):
        tr = Simulator(Params(), Motor(torque), solver=SolverOptions(method=method, rtol=rtol)).run(
            t_end, save_every=t_end / 100, progress=False)
        k = len(tr.t) // 2
        w = (tr.motor_angle[-1] - tr.motor_angle[k]) / (tr.t[-1] - tr.t[k])
        out[method] = (tr.thrust[k:].mean(), w)
    (f, w), (f_ref, w_ref) = out["bdf"], out["cvode"]
    assert f == pytest.approx(f_ref, rel=tol)
    assert w == pytest.approx(w_ref, rel=tol)


def test_reset_at_the_same_point_equals_a_fresh_stepper():
    m = RodModel(SHORT, Motor(1.0))
    y0 = m.initial_state()
    a = B.BdfStepper(m, 0.0, y0)
    a.advance(2e-3)
    t1, y1 = a.t, a.y.copy()
    a.reset(t1, y1)
    b = B.BdfStepper(m, t1, y1)
    assert np.array_equal(a.advance(4e-3), b.advance(4e-3))


def test_killed_and_resumed_run_is_bit_identical(tmp_path):
    from test_bad_input import killed_and_resumed_matches_the_whole_run

    killed_and_resumed_matches_the_whole_run(
        tmp_path, lambda: Simulator(SHORT, Motor(1.0), solver=SolverOptions(method="bdf")))
