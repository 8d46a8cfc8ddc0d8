"""Linear stability of the aligned rotating filament against independent results.

Independent references: rigid-helix RFT of the discrete helix (small-torque limit, anchored
and with a load sphere), the full unreduced Jacobian of the rod model, mirror symmetry,
the paper's qualitative findings (Sec. 3.1–3.2), Eq. (16) for the load sphere, and direct
simulation of a perturbed state (slow).
"""

import json
import math
from functools import lru_cache

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import assert_one_line_error

from flagellum import Filament, Params, ParameterError, discrete_helix
from flagellum.analysis.stability import (critical_torque, linear_stability, relative_equilibrium,
                                          simulated_growth_rate, stability_curve)
from flagellum.cli.stability import critical_torque as critical_torque_cmd
from flagellum.cli.stability import stability as stability_cmd
from flagellum.helix import Helix
from flagellum.hydro import rft
from flagellum.motor import Boundary
from flagellum.rod.model import positions

COARSE = Params(Filament(segment_length=0.4))  # N = 25, for the fast end-to-end checks


@lru_cache(maxsize=None)
def _stability(torque, hand="right", radius=None, hook="free", k=0.0, h=0.2):
    params = Params(Filament(handedness=hand, segment_length=h))
    b = Boundary("fixed" if radius is None else "sphere", radius, hook, k)
    return linear_stability(params, torque, b, n_eigs=1000)


def _rigid_rotation(params, zeta=math.inf):
    """Rigid discrete helix pinned at bead 0, free to slide along its rotation axis against
    a drag ζ: rotates about the axis m with B_eff m = b m, B_eff = B − (Cᵀm)(Cᵀm)ᵀ/(mᵀAm + ζ)
    (App. A resistance matrix). Returns (ω/M, v/M)."""
    dh = discrete_helix(params.filament)
    res = rft.resistance_matrix(*rft.bead_nodes(dh), *params.gammas)
    A, C, B = res[:3, :3], res[:3, 3:], res[3:, 3:]
    m = -np.asarray(dh.axis_direction)
    for _ in range(100):
        c = C.T @ m
        b_eff = B if zeta == math.inf else B - np.outer(c, c) / (m @ A @ m + zeta)
        vec = np.linalg.eigh(b_eff)[1][:, 0]
        m = vec * np.sign(vec @ m)
    omega = 1.0 / (m @ b_eff @ m)
    v = 0.0 if zeta == math.inf else -(m @ C @ m) * omega / (m @ A @ m + zeta)
    return omega, v


# -- relative equilibrium ------------------------------------------------------------------
@pytest.mark.parametrize("torque", [0.01, -0.01])
def test_small_torque_is_the_rigid_pinned_helix(torque):
    params = Params()
    pin = rft.pinned_rotation(rft.resistance_matrix(*rft.bead_nodes(discrete_helix(params.filament)),
                                                    *params.gammas), (0.0, 0.0, -1.0))
    eq = relative_equilibrium(params, torque)
    assert eq.omega / torque == pytest.approx(pin.omega_per_torque, rel=3e-3)
    assert eq.thrust / torque == pytest.approx(pin.thrust_per_torque, rel=3e-3)
    assert eq.velocity == 0.0


def test_small_torque_load_sphere_is_the_rigid_helix():
    params, a, torque = Params(), 1.0, 0.01
    omega, v = _rigid_rotation(params, 6 * math.pi * params.fluid.viscosity * a)
    eq = relative_equilibrium(params, torque, Boundary("sphere", a))
    assert eq.omega / torque == pytest.approx(omega, rel=3e-3)
    assert eq.velocity / torque == pytest.approx(v, rel=3e-3)
    assert _rigid_rotation(params)[0] == pytest.approx(  # the helper's anchored limit
        rft.pinned_rotation(rft.resistance_matrix(*rft.bead_nodes(discrete_helix(params.filament)),
                                                  *params.gammas), (0, 0, -1)).omega_per_torque)


@pytest.mark.parametrize("radius", [None, 1.0])
def test_state_is_a_fixed_point_of_the_full_dynamics(radius):
    eq = _stability(0.5, radius=radius).equilibrium
    m = eq.model()
    f = m.rhs(0.0, eq.state)
    body = f[3:].reshape(-1, 4)
    scale = abs(eq.omega) * np.abs(positions(eq.state)).max()
    assert np.abs(positions(eq.state)[0]).max() == 0.0
    assert np.abs(body[:, :2]).max() < 1e-8 * scale  # x, y, θ stationary
    assert np.abs(body[:, 3]).max() < 1e-8 * abs(eq.omega)
    assert np.abs(body[:, 2] - eq.velocity).max() < 1e-8 * scale  # all beads move with v
    assert np.abs(f[:3]).max() < 1e-8 * abs(eq.omega)
    assert (eq.velocity > 0) == (radius is not None)  # pushed forward along +z
    assert eq.thrust == pytest.approx(m.bead_force(0.0, eq.state)[2])


def test_mirror_image_has_the_same_spectrum():
    """Reflection x → −x turns a right-handed helix into a left-handed one and M into −M."""
    r, l = _stability(0.5), _stability(-0.5, hand="left")
    assert l.omega == pytest.approx(-r.omega, rel=1e-7)
    assert l.thrust == pytest.approx(r.thrust, rel=1e-7)
    assert l.lambda_ == pytest.approx(r.lambda_, rel=1e-4)
    assert np.allclose(np.sort_complex(l.eigenvalues[:6].conj()), np.sort_complex(r.eigenvalues[:6]),
                       rtol=1e-5)


# -- spectrum ------------------------------------------------------------------------------
@pytest.mark.parametrize("anchor", ["fixed", "free"])
def test_reduced_spectrum_is_the_full_one_minus_trivial_modes(anchor):
    """Free swimmer (body a = 1 µm): its three rigid translations are quotiented out; they
    take the places of the anchored bead's three modes (axial 0, lateral ±iΩ in the
    co-rotating frame)."""
    res = _stability(1.0) if anchor == "fixed" else linear_stability(
        Params(), 1.0, Boundary("free", 1.0), n_eigs=1000)
    eq = res.equilibrium
    m, y = eq.model(), eq.state
    n = len(y)
    J = np.empty((n, n))
    for j in range(n):  # independent: plain central differences of the full state
        e = np.zeros(n)
        e[j] = 1e-7
        J[:, j] = (m.rhs(0.0, y + e) - m.rhs(0.0, y - e)) / 2e-7
    full = list(np.linalg.eigvals(J))
    assert len(full) == len(res.eigenvalues) + 5
    for lam in res.eigenvalues:  # greedy matching
        k = int(np.argmin([abs(f - lam) for f in full]))
        assert abs(full[k] - lam) < 1e-6 * abs(lam) + 1e-4
        full.pop(k)
    # left over: |u0|, bead 0 (z, and x ± iy turning at −Ω), rotation about e_z
    left = sorted(full, key=lambda z: z.imag)
    want = [-1j * eq.omega, 0, 0, 0, 1j * eq.omega]
    assert np.allclose(left, want, atol=1e-5 * abs(eq.omega))


def test_stability_follows_the_paper():
    """Sec. 3.1: aligned state unstable for M < 0, stable at M = 0.5, buckled (Hopf) at 1.5."""
    neg, mid, high = _stability(-0.5), _stability(0.5), _stability(1.5)
    assert neg.lambda_ > 0 and mid.lambda_ < 0 and high.lambda_ > 0
    assert high.frequency > 0  # a complex pair crosses: Hopf bifurcation
    assert 0 < high.lab_frequency < 0.1 * high.omega  # slow precession χ ≪ ω (Fig. 3b)
    assert np.all(np.diff(high.eigenvalues.real) <= 0)


def test_critical_torque_is_the_root_of_lambda():
    c = critical_torque(COARSE)
    assert 0.8 < c.critical_torque < 1.5  # paper: M_c1 ≈ 1.1 pN·µm
    below = linear_stability(COARSE, c.critical_torque - 0.01)
    above = linear_stability(COARSE, c.critical_torque + 0.01)
    assert below.lambda_ < 0 < above.lambda_
    assert c.critical_force == pytest.approx(0.5 * (below.thrust + above.thrust), rel=1e-2)
    assert c.omega == pytest.approx(0.5 * (below.omega + above.omega), rel=1e-2)


def test_stability_curve_is_the_cold_start_at_each_torque():
    """One continuation branch through all torques (warm starts) against a separate
    linear_stability call per torque (each continued from the rigid helix): the same aligned
    state to the Newton tolerance (1e-10 on the residual), so the same ω and thrust to 1e-9;
    λ comes from a finite-difference Jacobian (FD_STEP) of states that differ at that level
    and in their charts, so it agrees to ~1e-7 (λ is printed to 4 digits)."""
    torques = (1.2, -0.7, 0.3, -0.2, 0.9)
    curve = stability_curve(COARSE, torques)
    for M, r in zip(torques, curve):
        cold = linear_stability(COARSE, M)
        assert r.torque == M
        assert r.lambda_ == pytest.approx(cold.lambda_, rel=1e-5, abs=1e-6)
        assert r.frequency == pytest.approx(cold.frequency, rel=1e-5, abs=1e-6)
        assert r.thrust == pytest.approx(cold.thrust, rel=1e-9)
        assert r.omega == pytest.approx(cold.omega, rel=1e-9)


def test_stability_curve_errors():
    with pytest.raises(ParameterError, match="errors"):
        stability_curve(COARSE, (0.5,), errors="ignore")
    with pytest.raises(ParameterError, match="torque"):
        stability_curve(COARSE, (0.5, 0.0))


@pytest.mark.parametrize("kwargs,name", [
    ({"torque": 0.0}, "torque"), ({"torque": math.nan}, "torque"), ({"torque": 0.5, "n_eigs": 0}, "n_eigs"),
])
def test_invalid_input(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        linear_stability(Params(), **kwargs)


@pytest.mark.parametrize("bracket", [(0.5, 0.6), (1.0, 0.5), (-1.0, 1.0), ("a", 1)])
def test_bad_bracket(bracket):
    with pytest.raises(ParameterError, match="bracket"):
        critical_torque(COARSE, bracket=bracket)


def test_sign_change_widens_towards_the_root():
    """The automatic bracket: widened by WIDEN per step from the start, upwards while λ < 0 at
    both ends, downwards while λ > 0 at both, keeping the end already on the right side
    (a linear λ(M) = M − M* with a known root M*)."""
    from flagellum.analysis.stability import SEARCH_RANGE, WIDEN, _sign_change

    for root in (0.3, 0.9, 3.0, 7.0):
        lo, hi = _sign_change(lambda m: m - root, 1.0, 2.5)
        assert lo < root < hi and (hi / lo == pytest.approx(WIDEN) or (lo, hi) == (1.0, 2.5))
    for lam, what in ((lambda m: -1.0, "stable"), (lambda m: 1.0, "unstable"),
                      (lambda m: 2.0 - m, "falls")):
        with pytest.raises(ParameterError, match=f"bracket.*{what}"):
            _sign_change(lam, 1.0, 2.5)
    with pytest.raises(ParameterError, match=f"{SEARCH_RANGE[1]:g}"):
        _sign_change(lambda m: m - 2 * SEARCH_RANGE[1], 1.0, 2.5)


def test_automatic_bracket_finds_a_threshold_above_the_default():
    """A small load sphere (a = 0.5 µm: M_c1 ≈ 2.9 pN·µm at N = 50, docs/stability.md, higher at N = 25) puts
    M_c1 above the default bracket (0.5, 2): the automatic search finds the root that an
    explicit bracket around it gives."""
    b = Boundary("sphere", 0.5)
    auto = critical_torque(COARSE, b, xtol=1e-4)
    given = critical_torque(COARSE, b, (2.0, 6.0), xtol=1e-4)
    assert auto.critical_torque > 2.0
    assert auto.critical_torque == pytest.approx(given.critical_torque, abs=2e-4)


def test_automatic_bracket_reports_no_sign_change(cli):
    """The paper's free hook on a free cell body of a = 1 µm: λ > 0 at every torque
    (docs/stability.md, "Free-swimming cell"), so the widened search ends in one line."""
    code, _, err = cli("critical-torque", "--segment-length", "0.4", "--body-radius", "1")
    assert_one_line_error(code, err, "bracket")
    assert "unstable" in err and "0.25" in err


# -- CLI -----------------------------------------------------------------------------------
def test_cli_json_matches_api():
    r = CliRunner().invoke(stability_cmd, ["--torque", "0.5", "--segment-length", "0.4", "--json",
                                         "--n-eigs", "3"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    api = linear_stability(COARSE, 0.5)
    assert d["lambda"] == pytest.approx(api.lambda_, rel=1e-6)
    assert d["omega"] == pytest.approx(api.omega, rel=1e-9)
    assert len(d["eigenvalues"]) == 3 and d["eigenvalues"][0] == pytest.approx(
        [api.eigenvalues[0].real, api.eigenvalues[0].imag], rel=1e-6)
    r = CliRunner().invoke(critical_torque_cmd, ["--segment-length", "0.4", "--json"])
    assert r.exit_code == 0, r.output
    assert set(json.loads(r.output)) >= {"critical_torque", "critical_force", "omega", "wall_seconds"}


@pytest.mark.parametrize("args,name", [
    (["stability", "--torque", "nan"], "torque"), (["stability", "--torque", "0"], "torque"),
    (["stability", "--torque", "1", "--hook", "elastic"], "hook_stiffness"),
    (["stability", "--torque", "1", "--sphere-radius", "-1"], "sphere_radius"),
    (["critical-torque", "--segment-length", "0.4", "--bracket", "0.5", "0.6"], "bracket"),
])
def test_cli_bad_input_one_line_exit_2(args, name, cli):
    code, _, err = cli(*args)
    assert_one_line_error(code, err, name)


# -- slow: simulation, convergence, boundaries ---------------------------------------------
@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize("torque,kw", [
    (1.2, dict(t_end=1.5, amplitude=1e-6, fit_from=0.6)),  # growing buckling mode
    (1.0, dict(t_end=2.0, amplitude=3e-3, fit_from=0.8)),  # decaying buckling mode
    (-0.5, dict(t_end=15.0, amplitude=1e-4, fit_from=3.0, observable="tip_radius",
                samples=60000)),  # slow tilt mode: F changes only at second order
    (0.15, dict(t_end=30.0, amplitude=1e-4, fit_from=3.0, observable="tip_radius",
                samples=20000, rtol=1e-10, atol=1e-14)),  # weakly unstable tilt, λ ~ 1e-3 /s
])
def test_simulation_gives_the_eigenvalue(torque, kw):
    # independent: a fit to a simulated relaxation (the full nonlinear model, no Jacobian)
    res = _stability(torque)
    fit = simulated_growth_rate(res.equilibrium, **kw)
    assert fit.rate == pytest.approx(res.lambda_, rel=0.02)


@pytest.mark.slow
@pytest.mark.ci
def test_load_sphere_follows_eq_25():
    """Paper Eq. (16): M_c1 grows linearly in 1/a with slope (C∥ − A∥B∥/C∥) F_c1/(6πη)."""
    params = Params()
    fixed = critical_torque(params)
    big = critical_torque(params, Boundary("sphere", 5.0))
    coeffs = rft.full_turn_coefficients(Helix.from_filament(params.filament), *params.gammas[:2])
    slope = rft.critical_torque_line(coeffs, fixed.critical_force, params.fluid.viscosity)
    # 10 %: Eq. (16) takes App. A's full-turn coefficients of the rigid helix on its axis; the
    # filament (3.93 turns, pinned at bead 0, deformed) has an F/M 7 % below App. A's at M_c1
    # (0.951 vs 1.021 /µm, tests/test_theory_manifold.py)
    assert (big.critical_torque - fixed.critical_torque) / 0.2 == pytest.approx(
        slope["slope_per_inverse_radius"], rel=0.1)
    assert big.critical_force == pytest.approx(fixed.critical_force, rel=0.03)  # F_c1 ~ const


@pytest.mark.slow
@pytest.mark.ci
def test_stiff_elastic_hook_approaches_clamped():
    clamped = _stability(1.0, hook="clamped")
    stiff = _stability(1.0, hook="elastic", k=1e4)
    assert stiff.omega == pytest.approx(clamped.omega, rel=1e-3)
    assert stiff.lambda_ == pytest.approx(clamped.lambda_, rel=1e-3)
    assert clamped.equilibrium.state[:3] / np.linalg.norm(clamped.equilibrium.state[:3]) == \
        pytest.approx([0, 0, -1])


@pytest.mark.slow
@pytest.mark.ci
def test_critical_torque_converges_with_resolution():
    mc = [critical_torque(Params(Filament(segment_length=h))).critical_torque for h in (0.4, 0.2, 0.1)]
    assert abs(mc[2] - mc[1]) < 0.5 * abs(mc[1] - mc[0])
    assert abs(mc[2] - 1.1) < 0.15  # paper: M_c1 ≈ 1.1 pN·µm
