"""Nonlocal hydrodynamics (flagellum.hydro.sbt): regularized Stokeslet segments against
quadrature, exact and asymptotic drag of slender bodies, local RFT, and the rotating-helix
experiments of Rodenborn et al., PNAS 110, E338 (2013)."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from flagellum import Filament, Params
from flagellum.errors import ParameterError
from flagellum.helix import Helix, discrete_helix, rot_z
from flagellum.hydro import rft, sbt

ETA, R_FIL = 1e-3, 0.01  # the paper's water and filament radius (Sec. 2.4)


def _line(z):
    x = np.zeros((len(z), 3))
    x[:, 2] = z
    return x


def _cosine_grid(length, n):
    """Beads clustered at the ends, where the force density varies fastest."""
    return 0.5 * length * (1 - np.cos(np.linspace(0.0, math.pi, n + 1)))


def _spheroid_exact(a, b, eta=1.0):
    """Exact drag of a prolate spheroid (semi-axes a > b) along and across its axis
    (Chwang & Wu, J. Fluid Mech. 67, 787 (1975): a line of Stokeslets and doublets between
    the foci); e → 0 gives 6πηa."""
    e = math.sqrt(1 - (b / a) ** 2)
    lg = math.log((1 + e) / (1 - e))
    return (16 * math.pi * eta * a * e**3 / ((1 + e * e) * lg - 2 * e),
            32 * math.pi * eta * a * e**3 / (2 * e + (3 * e * e - 1) * lg))


def _spheroid_drag(a, b, z, radius_scale=1.0):
    x = _line(z - a)
    rad = radius_scale * b * np.sqrt(np.clip(1 - ((z - a) / a) ** 2, 0.0, None))
    R = sbt.resistance_matrix(x, rad, 1.0)
    return R[2, 2], R[0, 0]


def test_segment_integrals_match_adaptive_quadrature():
    # independent: scipy's adaptive quadrature of the regularized Stokeslet of Cortez et al.
    # (2005) times the hat weights, on a random polyline with targets on and off the segments;
    # block (i, k) of the kernel sums the segments on either side of bead k
    x = np.cumsum(np.random.default_rng(1).normal(size=(6, 3)) * 0.3, axis=0)
    eps = 0.05
    flat = np.zeros((18, 18))
    sbt._segment_kernel(x, np.full(5, eps), -1.0, flat, np.ones(6))
    got = flat.reshape(6, 3, 6, 3).transpose(0, 2, 1, 3)
    want = np.zeros_like(got)

    def kernel(r):
        r2 = r @ r
        return ((r2 + 2 * eps * eps) * np.eye(3) + np.outer(r, r)) / (r2 + eps * eps) ** 1.5

    for i in range(6):
        for j in range(5):
            p, d = x[j], x[j + 1] - x[j]
            ell = np.linalg.norm(d)
            for a in range(3):
                for b in range(3):
                    f = lambda s, wgt: kernel(x[i] - p - d * s / ell)[a, b] * wgt(s)  # noqa: E731
                    va = quad(f, 0, ell, args=(lambda s: 1 - s / ell,), epsabs=1e-13, limit=200)[0]
                    vb = quad(f, 0, ell, args=(lambda s: s / ell,), epsabs=1e-13, limit=200)[0]
                    want[i, j, a, b] += va
                    want[i, j + 1, a, b] += vb
    assert np.abs(got - want).max() < 2e-11  # each hat block: the sum of two segments' integrals


@pytest.mark.parametrize("aspect", [20, 1000])
def test_prolate_spheroid_exact_drag(aspect):
    # exact closed form (Chwang & Wu 1975); a line of regularized Stokeslets with the local
    # radius r(s) and ε = √e r reproduces it (measured: ≤ 0.16 % at a/b = 20, ≤ 0.01 % at 1000)
    a, b = 1.0, 1.0 / aspect
    fpar, fperp = _spheroid_exact(a, b)
    z = _cosine_grid(2 * a, 200)
    gpar, gperp = _spheroid_drag(a, b, z)
    tol = 3e-3 if aspect == 20 else 5e-4
    assert gpar == pytest.approx(fpar, rel=tol)
    assert gperp == pytest.approx(fperp, rel=tol)


def test_calibration_constant_matters():
    # the same line with ε = r instead of √e r misses the exact drag by ≈ 1/(2 ln(2a/b)):
    # the test above would fail with that choice
    a, b = 1.0, 1e-3
    fpar, fperp = _spheroid_exact(a, b)
    gpar, gperp = _spheroid_drag(a, b, _cosine_grid(2 * a, 200), radius_scale=1 / sbt.EPS_PER_RADIUS)
    assert abs(gpar / fpar - 1) > 0.05 and abs(gperp / fperp - 1) > 0.03


def test_convergence_on_uniform_beads():
    # uniform beads as in the simulator: the error against the exact spheroid drag falls
    # with N; measured 0.95, 0.43, 0.19, 0.08 % (order ≈ 1.2, set by the tips)
    a, b = 1.0, 1e-3
    fpar, _ = _spheroid_exact(a, b)
    ns = [50, 100, 200, 400]
    err = [abs(_spheroid_drag(a, b, np.linspace(0, 2 * a, n + 1))[0] / fpar - 1) for n in ns]
    assert all(e2 < e1 for e1, e2 in zip(err, err[1:]))
    order = -np.polyfit(np.log(ns), np.log(err), 1)[0]
    assert 0.9 < order < 2.0
    assert err[-1] < 2e-3


@pytest.mark.parametrize("aspect, n", [(100, 50), (1000, 200), (10000, 200)])
def test_straight_cylinder_against_cox(aspect, n):
    # Cox, J. Fluid Mech. 44, 791 (1970), a cylinder of length L and radius r, first terms in
    # ε = 1/ln(L/r) (Batchelor, J. Fluid Mech. 44, 419 (1970), carries them further):
    #   F∥ = 2πηLU / (ln(L/r) − 3/2 + ln 2),   F⊥ = 4πηLU / (ln(L/r) − 1/2 + ln 2).
    # Constant-radius SBT and these differ at relative order ε² (the order they neglect;
    # measured: 4.2/3.4 % at L/r = 100, 1.2/0.9 % at 10³, 0.4/0.3 % at 10⁴). At L/r = 100
    # only 50 segments: on 200 cosine-spaced ones the end beads lie 6e-4 µm apart against a
    # blob of ε = 0.16 µm, the mobility's condition number is 2e16 and its inverse noise.
    L = 10.0
    r = L / aspect
    lg = math.log(aspect)
    R = sbt.resistance_matrix(_line(_cosine_grid(L, n)), r, ETA, origin=(0, 0, L / 2))
    cox_par = 2 * math.pi * ETA * L / (lg - 1.5 + math.log(2))
    cox_perp = 4 * math.pi * ETA * L / (lg - 0.5 + math.log(2))
    for got, want in ((R[2, 2], cox_par), (R[0, 0], cox_perp), (R[1, 1], cox_perp)):
        assert 0 < got / want - 1 < 1 / lg**2


def test_spin_torque_of_a_rotating_rod():
    # a rod spinning about its axis: torque 4πηr²Lω (exact for an infinite cylinder,
    # Batchelor 1970); it comes only from the local spin friction
    L, n = 10.0, 50
    model = sbt.SlenderBody(R_FIL, ETA)
    R = model.resistance_matrix(_line(np.linspace(0, L, n + 1)))
    assert R[5, 5] == pytest.approx(4 * math.pi * ETA * R_FIL**2 * L, rel=1e-12)
    assert model.resistance_matrix(_line(np.linspace(0, L, n + 1)), spin=False)[5, 5] == 0.0
    # the paper's γR (Sec. 2.4, PAPER_FRICTION) is this 4πηr², rounded
    assert model.gamma_rot == pytest.approx(Params().gammas[2], rel=0.01)


def _paper_helix_matrix(n):
    h = Helix.from_filament(Filament())
    x = h.positions(np.linspace(0, h.length, n + 1))
    return sbt.SlenderBody(R_FIL, ETA).resistance_matrix(x)  # about the origin, on the axis


def test_paper_helix_held_on_its_axis():
    # RFT with the paper's γ (rft.full_turn_coefficients, App. A): F/M = −C∥/B∥ = 1.02 /µm.
    # SBT for this helix: ≈ 0.6 /µm (the value the nonlocal model is expected to give);
    # measured here 0.573, 0.585, 0.587, 0.588 /µm at N = 50, 100, 200, 400, and ω/M
    # 833 … 859 /(pN·µm·s) against RFT's 1/B∥ = 892 (−4 %)
    fil = Filament()
    gp, gn, _ = Params().gammas
    c = rft.full_turn_coefficients(Helix.from_filament(fil), gp, gn)
    rft_thrust = rft.anchored_helix(c)["thrust_per_torque"]
    assert rft_thrust == pytest.approx(1.02, abs=0.01)
    vals = []
    for n in (50, 100, 200):
        R = _paper_helix_matrix(n)
        vals.append((-R[2, 5] / R[5, 5], 1 / R[5, 5]))
    thrust, omega = vals[-1]
    assert 0.55 < thrust < 0.62
    assert thrust < 0.6 * rft_thrust
    assert omega == pytest.approx(1 / c["B_par"], rel=0.06)
    d1, d2 = abs(vals[1][0] - vals[0][0]), abs(vals[2][0] - vals[1][0])
    assert d2 < d1 / 4  # converges faster than first order on this smooth filament


def test_simulator_helix_pinned_and_anchored():
    # the simulator's discrete helix (N = 50 beads, bead nodes of rft.bead_nodes): the same
    # drop from RFT; pinned at its first bead as in rft.rft_summary (RFT: 0.77–0.80 /µm)
    dh = discrete_helix(Filament(), axis=(0.0, 0.0, 1.0), origin="axis")
    p, t, w = rft.bead_nodes(dh)
    model = sbt.SlenderBody(R_FIL, ETA)
    R = sbt.resistance_matrix(p, R_FIL, ETA, model.gamma_rot, tangents=t, weights=w)
    assert 0.54 < -R[2, 5] / R[5, 5] < 0.6
    Rp = sbt.resistance_matrix(p - p[0], R_FIL, ETA, model.gamma_rot, tangents=t, weights=w)
    pinned = rft.pinned_rotation(Rp, dh.axis_direction)
    gp, gn, gr = Params().gammas
    pinned_rft = rft.pinned_rotation(rft.resistance_matrix(p - p[0], t, w, gp, gn, gr),
                                     dh.axis_direction)
    assert 0.75 < pinned_rft.thrust_per_torque < 0.8
    assert 0.4 < pinned.thrust_per_torque < 0.55
    assert pinned.omega_per_torque == pytest.approx(pinned_rft.omega_per_torque, rel=0.05)


def test_block_diagonal_mobility_reproduces_rft():
    # the rigid-body assembly Jᵀ M⁻¹ J with the local bead mobility of hydro.local equals
    # rft.resistance_matrix (Eqs. (32)–(35)) to rounding
    dh = discrete_helix(Filament())
    p, t, w = rft.bead_nodes(dh)
    gp, gn, gr = Params().gammas
    M = np.zeros((3 * len(p), 3 * len(p)))
    for k in range(len(p)):
        tt = np.outer(t[k], t[k])
        M[3 * k:3 * k + 3, 3 * k:3 * k + 3] = (tt / gp + (np.eye(3) - tt) / gn) / w[k]
    R = sbt.rigid_resistance(M, p, p[0], t, w, gr)
    np.testing.assert_allclose(R, rft.resistance_matrix(p, t, w, gp, gn, gr, origin=p[0]),
                               rtol=1e-10, atol=1e-14)


def test_local_limit_recovers_rft():
    # keeping only the kernel within Lighthill's q = 0.09 Λ (paper App. A) of each bead turns
    # the model into RFT with γ⊥ = 4πη/(ln(2q/r) + ½) (Lighthill's γ⊥ exactly) and
    # γ∥ = 2πη/(ln(2q/r) − ½); the helix numbers then follow RFT (measured: 0.796 vs 0.807 /µm;
    # the rest is the one-sided kernel near the two ends) and not the nonlocal 0.588
    h = Helix.from_filament(Filament())
    q = 0.09 * h.turn_length
    gpar, gperp = sbt.local_friction(q, R_FIL, ETA)
    lg = math.log(2 * q / R_FIL)
    assert gperp == pytest.approx(4 * math.pi * ETA / (lg + 0.5), rel=2e-3)
    assert gpar == pytest.approx(2 * math.pi * ETA / (lg - 0.5), rel=2e-3)
    assert Params().gammas[1] == pytest.approx(gperp, rel=0.05)  # paper's rounded γ⊥
    x = h.positions(np.linspace(0, h.length, 201))
    t, w = sbt.centreline_nodes(x)
    gr = 4 * math.pi * ETA * R_FIL**2
    Rl = sbt.resistance_matrix(x, R_FIL, ETA, gr, cutoff=q)
    Rr = rft.resistance_matrix(x, t, w, gpar, gperp, gr)
    assert -Rl[2, 5] / Rl[5, 5] == pytest.approx(-Rr[2, 5] / Rr[5, 5], rel=0.02)
    assert Rl[5, 5] == pytest.approx(Rr[5, 5], rel=0.04)
    assert Rl[2, 2] == pytest.approx(Rr[2, 2], rel=0.04)
    Rn = sbt.resistance_matrix(x, R_FIL, ETA, gr)
    assert -Rn[2, 5] / Rn[5, 5] < 0.8 * (-Rl[2, 5] / Rl[5, 5])


# Rodenborn et al. 2013, Fig. 2: helix radius R = 6.3 mm, axial length L = 130 mm, filament
# radius a = 0.397 mm, rotated about its axis (thrust F and torque T at U = 0) or towed along
# it (drag D at Ω = 0); measured F/(ηΩR²), T/(ηΩR³), D/(ηUR) at five λ/R. The values are read
# off that figure by Djutanta et al. (PNAS 120, e2220033120 (2023)), in the public repository
# fdjutant/flagella3D, scripts/2022_07_04_rodenborn_abd_results.py (commit 3764945);
# reading error a few %. At λ/R = 9.811 the same file gives Johnson's SBT from Rodenborn's
# program: 9.156, 66.43, 32.88.
RODENBORN = {  # λ/R: (thrust, torque, drag)
    2.226: (6.264, 131.93, 52.06),
    3.677: (9.598, 100.80, 46.96),
    6.509: (11.034, 81.93, 39.41),
    9.811: (9.569, 72.69, 35.29),
    15.241: (7.845, 68.07, 34.12),
}


def _rodenborn_helix(lam_over_r):
    R, axial, a = 1.0, 130 / 6.3, 0.397 / 6.3
    k = 1 / math.hypot(R, lam_over_r / (2 * math.pi))
    kappa, tau = R * k * k, lam_over_r * k * k / (2 * math.pi)
    return Helix(kappa, tau, axial * k / tau), a


@pytest.mark.parametrize("lam", sorted(RODENBORN))
def test_rodenborn_rotating_helices(lam):
    # SBT/BEM agree with these experiments within 10–15 % (Rodenborn et al. 2013); measured
    # here: thrust −4…−11 %, torque −8…+1 %, drag −11…+1 % (worst at λ/R = 15.2).
    # Lighthill's RFT (his γ's with q = 0.09 Λ) misses the thrust by +26…+370 %.
    helix, a = _rodenborn_helix(lam)
    thrust, torque, drag = RODENBORN[lam]
    x = helix.positions(np.linspace(0, helix.length, 101))
    R = sbt.resistance_matrix(x, a, 1.0, 4 * math.pi * a * a)
    assert -helix.chirality * R[2, 5] == pytest.approx(thrust, rel=0.15)
    assert R[5, 5] == pytest.approx(torque, rel=0.15)
    assert R[2, 2] == pytest.approx(drag, rel=0.15)
    lg = math.log(0.18 * helix.turn_length / a)
    Rr = rft.resistance_matrix(*rft.helix_nodes(helix), 2 * math.pi / lg, 4 * math.pi / (lg + 0.5))
    assert -helix.chirality * Rr[2, 5] > 1.2 * thrust
    if lam == 9.811:
        for got, johnson in zip((-R[2, 5], R[5, 5], R[2, 2]), (9.156, 66.43, 32.88)):
            assert got == pytest.approx(johnson, rel=0.05)


def test_mobility_structure():
    h = Helix.from_filament(Filament())
    x = h.positions(np.linspace(0, h.length, 51))
    M = sbt.mobility(x, R_FIL, ETA)
    # positive definite symmetric part (dissipation); collocation leaves an asymmetry only
    # at the end beads (hat lengths h/2 there)
    assert np.linalg.eigvalsh(0.5 * (M + M.T)).min() > 0
    inner = slice(6, -6)
    asym = np.abs(M - M.T)[inner, inner].max() / np.abs(M).max()
    assert asym < 1e-2
    # rigid rotations and translations of the filament act on M as Q M Qᵀ
    Q = rot_z(0.7) @ np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    M2 = sbt.mobility(x @ Q.T + [1.0, -2.0, 3.0], R_FIL, ETA)
    Q3 = np.kron(np.eye(len(x)), Q)
    np.testing.assert_allclose(M2, Q3 @ M @ Q3.T, atol=1e-9 * np.abs(M).max())
    # far beads see the Stokeslet 1/(8πη d)(1 + d̂d̂) of the bead force (interior beads: the
    # hat function is centred on its bead; an end bead's force sits h/3 inwards)
    d = x[-2] - x[1]
    dist = np.linalg.norm(d)
    st = (np.eye(3) + np.outer(d, d) / dist**2) / (8 * math.pi * ETA * dist)
    np.testing.assert_allclose(M[-6:-3, 3:6], st, rtol=0, atol=2e-3 * st.max())


@pytest.mark.parametrize("kwargs, name", [
    ({"positions": np.zeros((1, 3))}, "positions"),
    ({"positions": np.zeros((3, 3))}, "positions"),
    ({"radius": -1.0}, "radius"),
    ({"radius": np.ones(3)}, "radius"),
    ({"radius": np.zeros(6)}, "radius"),
    ({"viscosity": 0.0}, "viscosity"),
    ({"cutoff": 0.0}, "cutoff"),
    ({"weights": np.ones(3)}, "weights"),
])
def test_bad_input_names_the_parameter(kwargs, name):
    args = {"positions": _line(np.linspace(0, 1, 6)), "radius": 0.01, "viscosity": 1e-3, **kwargs}
    with pytest.raises(ParameterError) as err:
        sbt.mobility(**args)
    assert name in str(err.value)
    with pytest.raises(ParameterError):
        sbt.SlenderBody(0.0, 1e-3)
