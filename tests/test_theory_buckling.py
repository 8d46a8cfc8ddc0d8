"""Buckling theory of the helical rod (paper Sec. 4): classical limits, two methods, trivial mode.

Reference values are literature results (Euler, Greenhill, Ziegler, Wolgemuth et al.) or
closed forms derived independently of the solver; never numbers copied from its output.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import jv

from flagellum.errors import ParameterError
from flagellum.theory.buckling import (BucklingProblem, TrivialSolutionError, characteristic,
                                       collocation_pencil, find_critical, solve,
                                       solve_collocation, solve_path, unstable_count)

END = dict(force_profile="uniform", torque_profile="uniform")


def rel(a, b):
    return abs(a - b) / abs(b)


# ---------------------------------------------------------------- classical limits

@pytest.mark.parametrize("method", ["shooting", "collocation"])
def test_euler_clamped_free_column(method):
    # Euler (1744): clamped base, free top, dead end load: F L²/A = π²/4
    prob = BucklingProblem(base="clamped", top="free", **END)
    cp = solve(prob, ("f_par",), [2.0], method=method)
    assert rel(cp.f_par, math.pi**2 / 4) < (1e-10 if method == "shooting" else 1e-6)


def _column_path(t):
    # gravity: force density −q e_z = q (tangential, compressive) − q (transverse): f∥ = −f⊥ = q
    return np.array([0.0, t, -t, 0.0]), np.array([0.0, 1.0, -1.0, 0.0])


def test_column_under_own_weight_greenhill():
    # Greenhill (1881): q L³/A = 7.8373 = (9/4) j², j the first zero of J_{-1/3}
    j = brentq(lambda x: jv(-1 / 3, x), 1.0, 2.5)
    exact = 9 / 4 * j**2
    assert rel(exact, 7.8373) < 1e-4
    prob = BucklingProblem(base="clamped")
    cp = solve_path(prob, _column_path, 7.0, 0.0)
    assert rel(cp.f_par, 7.8373) < 1e-4
    assert rel(cp.f_par, exact) < 1e-10 and abs(cp.chi) < 1e-8
    # collocation: q is an eigenvalue of the pencil K0 + q (K_f∥ − K_f⊥)
    import scipy.linalg
    K0, Ks = collocation_pencil(prob, 32)
    lam = scipy.linalg.eig(K0, -(Ks[1] - Ks[2]), right=False)
    lam = lam[np.isfinite(lam) & (np.abs(lam.imag) < 1e-6) & (lam.real > 0)].real
    assert rel(lam.min(), exact) < 1e-6


@pytest.mark.parametrize("mu", [0.0, 1.0, 3.0, 5.0, 6.2])
@pytest.mark.parametrize("method", ["shooting", "collocation"])
def test_greenhill_hinged_rod_with_torque(mu, method):
    # Greenhill/Love: F L²/A + (M L/(2A))² = π² for hinged ends, end force and torque
    prob = BucklingProblem(m_hat=mu, base="hinged", top="hinged", **END)
    exact = math.pi**2 - mu**2 / 4
    cp = solve(prob, ("f_par", "chi"), [exact * 1.05 + 0.05, 0.1], method=method)
    assert rel(cp.f_par, exact) < 1e-4
    assert abs(cp.f_par - exact) < (1e-10 if method == "shooting" else 1e-6) * math.pi**2
    assert abs(cp.chi) < 1e-6


def test_greenhill_pure_torque():
    prob = BucklingProblem(base="hinged", top="hinged", **END)
    cp = find_critical(prob, ("m_hat", "chi"))
    assert rel(cp.m_hat, 2 * math.pi) < 1e-10


def test_clamped_clamped_rod_under_torque():
    # Greenhill/Ziegler: clamped ends, axial torque: M L/A = 2x, tan x = x (x = 4.4934)
    x = brentq(lambda x: math.tan(x) - x, 4.4, 4.6)
    prob = BucklingProblem(base="clamped", top="clamped", **END)
    for method in ("shooting", "collocation"):
        cp = solve(prob, ("m_hat", "chi"), [9.2, 0.1], method=method)
        assert rel(cp.m_hat, 8.9868) < 1e-4
        assert rel(cp.m_hat, 2 * x) < (1e-10 if method == "shooting" else 1e-6)


def test_wolgemuth_whirling_of_a_rotated_rod():
    # Wolgemuth, Powers & Goldstein, PRL 84, 1623 (2000): a rod rotated at its clamped end
    # (twist torque decreasing linearly to the free end) whirls above ζr ω L²/A ≈ 8.9
    # with whirling frequency ≈ 22.9 A/(ζ⊥ L⁴); the literature gives 2-3 digits only.
    prob = BucklingProblem(base="clamped")
    cp = find_critical(prob, ("m_hat", "chi"))
    assert abs(cp.m_hat - 8.9) < 0.05
    assert abs(abs(cp.chi) - 22.9) < 0.1
    col = solve(prob, ("m_hat", "chi"), [cp.m_hat, cp.chi], method="collocation")
    assert rel(col.m_hat, cp.m_hat) < 1e-6 and rel(col.chi, cp.chi) < 1e-6


def test_small_torque_tilt_precesses_at_three_m():
    # Rigid tilt of the hinged rod, f∥ = 0, small m: torque m·c balances the precession
    # friction χ ∫ z·(c z) dz = χ c/3, hence χ̂ = 3 m̂ (and f̂⊥ = O(m̂²)).
    m = 0.01
    cp = solve(BucklingProblem(m_hat=m), ("f_perp", "chi"), [0.0, 3 * m])
    assert rel(cp.chi, 3 * m) < 1e-3
    assert abs(cp.f_perp) < 10 * m**2


# ---------------------------------------------------------------- two methods

POINTS = [(2.0, 30.0), (3.0, 24.0), (5.0, 60.0), (10.0, 30.0), (15.0, 60.0), (0.5, 80.0)]


@pytest.mark.parametrize("m,f", POINTS)
def test_shooting_and_collocation_agree(m, f):
    prob = BucklingProblem(m_hat=m, f_par=f)
    shoot = find_critical(prob)
    col = solve_collocation(prob, ("f_perp", "chi"), [shoot.f_perp * 1.001, shoot.chi * 0.999])
    assert rel(col.f_perp, shoot.f_perp) < 1e-6
    assert rel(col.chi, shoot.chi) < 1e-6
    assert shoot.residual < 1e-12


def test_clamped_base_agree():
    prob = BucklingProblem(m_hat=4.0, f_par=20.0, base="clamped")
    shoot = find_critical(prob)
    col = solve(prob, guess=[shoot.f_perp, shoot.chi], method="collocation")
    assert rel(col.f_perp, shoot.f_perp) < 1e-6 and rel(col.chi, shoot.chi) < 1e-6


def test_other_unknown_pairs_are_consistent():
    # solving for (f_par, chi) at the f_perp found for (f_perp, chi) returns the start point
    base = find_critical(BucklingProblem(m_hat=3.0, f_par=40.0))
    back = solve(BucklingProblem(m_hat=3.0, f_perp=base.f_perp), ("f_par", "chi"),
                 [38.0, base.chi * 1.02])
    assert rel(back.f_par, 40.0) < 1e-10
    back_m = solve(BucklingProblem(f_par=40.0, f_perp=base.f_perp), ("m_hat", "chi"),
                   [3.1, base.chi])
    assert rel(back_m.m_hat, 3.0) < 1e-10


def test_torque_reversal_mirrors_precession():
    # X → X, Y → −Y maps (m̂, χ̂) to (−m̂, −χ̂): same f̂⊥, opposite χ̂
    a = find_critical(BucklingProblem(m_hat=4.0, f_par=30.0))
    b = solve(BucklingProblem(m_hat=-4.0, f_par=30.0), guess=[a.f_perp, -a.chi])
    assert rel(b.f_perp, a.f_perp) < 1e-10 and rel(b.chi, -a.chi) < 1e-10


def test_critical_point_is_the_stability_boundary():
    cp = find_critical(BucklingProblem(m_hat=2.0, f_par=30.0))
    above = BucklingProblem(m_hat=2.0, f_par=30.0, f_perp=cp.f_perp + 1e-3)
    below = BucklingProblem(m_hat=2.0, f_par=30.0, f_perp=cp.f_perp - 1e-3)
    assert unstable_count(above) == 0 and unstable_count(below) == 1


def test_mode_satisfies_boundary_conditions():
    m = 2.0
    cp = find_critical(BucklingProblem(m_hat=m, f_par=30.0))
    mode = cp.mode(401)
    V = np.polynomial.Chebyshev.fit(mode.z, mode.X - 1j * mode.Y, 40, domain=[0, 1])
    d1, d2, d3 = V.deriv(1), V.deriv(2), V.deriv(3)
    size = np.max(np.abs(d2(mode.z)))
    assert abs(V(0.0)) < 1e-9 and np.max(np.abs(mode.X - 1j * mode.Y)) == pytest.approx(1.0)
    assert abs(d2(0.0) + 1j * m * d1(0.0)) < 1e-6 * size   # hinged base: V'' = −i m V'
    assert abs(d2(1.0)) < 1e-6 * size and abs(d3(1.0)) < 1e-5 * size   # free end


# ---------------------------------------------------------------- trivial solution

@pytest.mark.parametrize("f", [0.0, 10.0, 50.0, 200.0])
def test_rigid_tilt_solves_torque_free_hinged_rod(f):
    D, _, scale = characteristic(BucklingProblem(f_par=f), with_gradient=True)
    assert abs(D) < 1e-13 * scale


def test_rigid_tilt_is_no_solution_with_torque():
    D, _, scale = characteristic(BucklingProblem(m_hat=1.0, f_par=10.0), with_gradient=True)
    assert abs(D) > 1e-3 * scale


def test_trivial_solution_is_rejected_and_skipped():
    with pytest.raises(TrivialSolutionError):
        solve(BucklingProblem(f_par=10.0), guess=[0.01, 0.01])
    cp = find_critical(BucklingProblem(f_par=10.0))   # m = 0: skips f⊥ = χ = 0
    assert cp.f_perp < -1.0
    mode = cp.mode(201)
    curvature = np.gradient(np.gradient(mode.X - 1j * mode.Y, mode.z), mode.z)
    assert np.max(np.abs(curvature)) > 0.1


# ---------------------------------------------------------------- input validation

@pytest.mark.parametrize("kwargs,name", [
    (dict(base="wobbly"), "base"), (dict(top="loose"), "top"),
    (dict(m_hat=float("nan")), "m_hat"), (dict(force_profile="quadratic"), "force_profile"),
])
def test_invalid_problem(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        BucklingProblem(**kwargs)


@pytest.mark.parametrize("unknowns,guess", [
    (("f_perp", "f_perp"), None), (("omega",), None), (("m_hat", "f_par", "chi"), None),
    (("f_perp",), [1.0]),          # complex problem needs two unknowns
    (("f_par", "f_perp"), None),   # no chi: a guess is required
    (("f_perp", "chi"), [1.0]),    # wrong number of guesses
])
def test_invalid_unknowns(unknowns, guess):
    with pytest.raises(ParameterError):
        solve(BucklingProblem(m_hat=1.0), unknowns, guess)
