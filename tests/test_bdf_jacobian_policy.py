"""The Numba BDF's Jacobian policy and its counters (:mod:`flagellum.integrate.bdf`): a
Jacobian is kept across steps and renewed only at a (re)start or after the Newton iteration
failed with a kept one (CVODE's and scipy's policy), and every renewal is counted under one
cause. The policy alternatives (``STALE_MAXITER``, ``PROBE``; benchmarks/bench_jacobian_refresh.py)
keep the rod's observables within the tolerance of an independent integrator."""

import types

import numpy as np
import pytest
from numba import njit

from flagellum import Params
from flagellum.integrate import bdf as B
from flagellum.motor import Motor
from flagellum.rod.model import RodModel
from flagellum.simulator import Simulator, SolverOptions
from test_integrate_bdf import N_LIN, _solve_linear

SHORT = Params.from_flat({"length": 2.0})
CAUSES = ("jacobians_at_start", "jacobians_after_divergence", "jacobians_after_max_iterations",
          "jacobians_ahead")


def test_exact_jacobian_of_a_linear_problem_is_never_renewed():
    """y' = A (y − φ) + φ' with constant A: the kept Jacobian is exact, so modified Newton
    converges with it at every step and it is taken once, at the start (a policy renewing it
    per step or per step change would count one per step)."""
    _, ist = _solve_linear(1e-6)
    assert ist[B.I_STEPS] > 50
    assert ist[B.I_JAC] == ist[B.I_JAC_START] == 1
    assert ist[B.I_JAC_DIVERGED] == ist[B.I_JAC_MAXITER] == ist[B.I_JAC_AHEAD] == 0
    assert ist[B.I_LU] > 1  # …while the iteration matrix I − cJ is refactored as h changes
    assert N_LIN == 12


def test_every_jacobian_of_a_rod_run_has_one_cause():
    """Bookkeeping identity: the renewals by cause add up to the Jacobians taken, and a renewed
    Jacobian's age (steps since it was taken) is at most the steps taken."""
    m = RodModel(SHORT, Motor(1.6))
    s = B.BdfStepper(m, 0.0, m.initial_state())
    s.advance(0.01)
    st = s.stats
    assert st["jacobians"] == sum(st[k] for k in CAUSES)
    assert st["jacobians_at_start"] == 1 and st["jacobians_ahead"] == 0  # shipped: PROBE = 0
    assert 0 <= st["jacobian_age_steps"] <= st["steps"]


def _variant(**consts):
    f = B.bdf_advance.py_func
    return njit(types.FunctionType(f.__code__, dict(f.__globals__, **consts), f.__name__))


@pytest.mark.slow
@pytest.mark.parametrize("consts", [{"PROBE": 4}, {"STALE_MAXITER": 5}])
def test_policy_alternatives_keep_the_buckled_averages(consts, monkeypatch):
    """Buckled filament (M = 1.6, regime iii) from rest: the time-averaged thrust of the second
    half with a policy alternative against CVODE at rtol 1e-9 (an independent BDF), to the
    tolerance test_integrate_bdf.py holds the shipped policy to (2e-4), and the renewals it
    adds are counted as such."""
    out = {}
    monkeypatch.setattr(B, "bdf_advance", _variant(**consts))
    for method, rtol in (("bdf", 1e-6), ("cvode", 1e-9)):
        sim = Simulator(Params(), Motor(1.6), solver=SolverOptions(method=method, rtol=rtol))
        tr = sim.run(0.03, save_every=3e-4, progress=False)
        out[method] = tr.thrust[len(tr.t) // 2:].mean()
    assert out["bdf"] == pytest.approx(out["cvode"], rel=2e-4)
    m = RodModel(SHORT, Motor(1.6))
    s = B.BdfStepper(m, 0.0, m.initial_state())
    s.advance(0.01)
    st = s.stats
    assert st["jacobians"] == sum(st[k] for k in CAUSES)
    if "PROBE" in consts:
        assert st["jacobians_ahead"] > 0
    assert np.isfinite(s.y).all()
