"""The banded Jacobian of the pruned rod kernel by the chain rule (:mod:`flagellum.rod.jacobian`)
against independent finite differences: a dense central difference of the right-hand side
itself (every column perturbed alone, ±1e-6) at random bent, twisted, off-chart states, for each
anchor, hook and drive the kernel has; the coloured finite differences the integrators used
before; the dispatch to those where the chain rule does not cover the model; and the BDF run
with each Jacobian."""

import types

import numpy as np
import pytest
from numba import njit

from flagellum import Params
from flagellum.integrate import bdf as B
from flagellum.motor import Boundary, Motor, MotorLaw
from flagellum.params import EndLoad, Filament
from flagellum.rod import jacobian as RJ
from flagellum.rod import kernels as K
from flagellum.rod.model import RodModel

CASES = [
    ("anchored", {}, Motor(1.6)),
    ("load sphere", {"anchor": "sphere", "sphere_radius": 0.5}, Motor(2.0)),
    ("elastic hook", {"hook_stiffness": 0.3}, Motor(1.0)),
    ("stiff hook on a sphere", {"hook_stiffness": 5.0, "anchor": "sphere", "sphere_radius": 1.0},
     Motor(-1.0)),
    ("free swimmer", {"anchor": "free", "sphere_radius": 0.5}, Motor(1.0)),
    ("clamped hook", {"hook": "clamped"}, Motor(1.0)),
    ("speed clamp", {}, Motor(drive="speed", speed=500.0)),
    ("motor law", {}, Motor(drive="law", law=MotorLaw.e_coli())),
]


def _state(m, rng, spread=0.04):
    y = m.initial_state()
    y[3:] += rng.normal(0.0, spread, y.size - 3)  # bent, stretched, twisted, off the charts
    y[:3] += rng.normal(0.0, 0.2, 3)
    return y


def _args(m):
    return (m.prm, m.iprm, m.ref_u, m.ref_e, m.ref_m, m._zf, m._zm, m._zh, m._ws)


def _dense(ab, kl, ku):
    ny = ab.shape[0]
    J = np.zeros((ny, ny))
    for j in range(ny):
        for i in range(max(0, j - ku), min(ny, j + kl + 1)):
            J[i, j] = ab[j, kl + ku + i - j]
    return J


def _central(y, args):
    ny = y.size
    J = np.zeros((ny, ny))
    fp, fm = np.zeros(ny), np.zeros(ny)
    for j in range(ny):
        e = 1e-6 * max(1.0, abs(y[j]))
        yp, ym = y.copy(), y.copy()
        yp[j] += e
        ym[j] -= e
        K.rod_rhs(yp, fp, *args)
        K.rod_rhs(ym, fm, *args)
        J[:, j] = (fp - fm) / (2.0 * e)
    return J


def _chain(m, y, scale=1.0):
    kl, ku = m.jacobian_band
    ny = y.size
    ab = np.zeros((ny, 2 * kl + ku + 1))
    f0 = np.zeros(ny)
    K.rod_rhs(y, f0, *_args(m))
    RJ.rod_jacobian(y, f0, *_args(m), kl, ku, ab, scale, np.zeros(ny), np.zeros(ny))
    return ab


def _close(Ja, Jd, rel):
    """|Ja − Jd| ≤ rel · (largest |entry| of the row) + 1e-12 · (largest of the matrix): rows
    that vanish identically (a clamped hook's ω × u0 with ω ∥ u0) carry round-off only."""
    row = np.abs(Jd).max(axis=1, keepdims=True)
    return np.abs(Ja - Jd) <= rel * row + 1e-12 * np.abs(Jd).max()


@pytest.mark.parametrize("name,boundary,motor", CASES, ids=[c[0] for c in CASES])
def test_chain_jacobian_matches_central_differences(name, boundary, motor):
    """Every band entry against the dense central difference (its error ~1e-9 of the row's
    scale; the chain rule's one-sided joint differences ~1e-7) to 1e-6 of the row's largest
    entry, in the rotating frame (Ω = 300 rad/s), at two random states; and the central
    difference is zero outside the band the integrators store (kl, ku = JACOBIAN_BAND)."""
    rng = np.random.default_rng(11)
    m = RodModel(Params(Filament(segment_length=0.5)), motor, Boundary(**boundary))
    m.prm[K.P_OMEGA] = 300.0
    kl, ku = m.jacobian_band
    for _ in range(2):
        y = _state(m, rng)
        Jd = _central(y, _args(m))
        Ja = _dense(_chain(m, y), kl, ku)
        assert _close(Ja, Jd, 1e-6).all(), name
        i, j = np.indices(Jd.shape)
        outside = (i - j > kl) | (j - i > ku)
        assert np.abs(Jd[outside]).max() <= 1e-12 * np.abs(Jd).max()


def test_chain_jacobian_of_a_straight_filament_and_with_external_forces():
    """A nearly straight filament (bend angles below 1e-4: the series branch of the joint), and
    external forces and torques (the thermal scheme's, constants of the Jacobian) with the
    elastic scale prm[P_ELASTIC] ≠ 1 and a scale factor on the band (the implicit scheme's
    −βΔt): against the central difference as above."""
    rng = np.random.default_rng(5)
    m = RodModel(Params(Filament(segment_length=0.5, kappa0=0.0, tau0=0.0)), Motor(0.5))
    kl, ku = m.jacobian_band
    y = m.initial_state()
    y[3:] += rng.normal(0.0, 1e-6, y.size - 3)
    Jd = _central(y, _args(m))
    assert _close(_dense(_chain(m, y), kl, ku), Jd, 1e-6).all()
    m = RodModel(Params(Filament(segment_length=0.5)), Motor(1.2), Boundary(hook_stiffness=0.5))
    m.prm[K.P_ELASTIC], m.prm[K.P_OMEGA] = 0.7, -150.0
    m._zf[:] = rng.normal(0.0, 3.0, m._zf.shape)
    m._zm[:] = rng.normal(0.0, 1.0, m._zm.shape)
    m._zh[:] = rng.normal(0.0, 1.0, 3)
    y = _state(m, rng)
    Jd = _central(y, _args(m))
    assert _close(_dense(_chain(m, y, scale=-2e-5), kl, ku) / -2e-5, Jd, 1e-6).all()


def test_chain_jacobian_agrees_with_the_coloured_differences():
    """Against the coloured one-sided differences of :func:`~flagellum.rod.kernels.colored_jacobian`
    (steps 1e-7 · max(1, |y_j|): their own error ~1e-6 of the row's scale) over the whole band
    storage, N = 50 at the buckled torque."""
    rng = np.random.default_rng(2)
    m = RodModel(Params(Filament(segment_length=0.2)), Motor(1.6))
    m.prm[K.P_OMEGA] = 1000.0
    kl, ku = m.jacobian_band
    y = _state(m, rng, 0.01)
    ny = y.size
    ab = np.zeros((ny, 2 * kl + ku + 1))
    f0 = np.zeros(ny)
    K.rod_rhs(y, f0, *_args(m))
    K.rod_colored_jacobian(y, f0, *_args(m), kl, ku, ab, 1.0, np.zeros(ny), np.zeros(ny),
                           *m.jacobian_colors(kl, ku))
    Jc, Ja = _dense(ab, kl, ku), _dense(_chain(m, y), kl, ku)
    assert _close(Ja, Jc, 1e-5).all()
    assert not _close(Ja, Jc, 1e-9).all()  # (the two are independent computations)


def test_hook_rows_follow_the_right_hand_side():
    """The hook balance :func:`~flagellum.rod.kernels.hook_of` that the chain rule differentiates
    gives the right-hand side's ẏ[0:3] and θ̇0 (the kernel keeps its own inline copy) to
    round-off, for every drive and hook."""
    rng = np.random.default_rng(8)
    for _, boundary, motor in CASES:
        m = RodModel(Params(Filament(segment_length=0.5)), motor, Boundary(**boundary))
        m.prm[K.P_OMEGA] = 200.0
        y = _state(m, rng)
        f = np.zeros(y.size)
        K.rod_rhs(y, f, *_args(m))
        ws = m._ws  # (after the rhs: G_t in ws[5], G_Θ in ws[6])
        w = np.array(_hook_rows(m.prm, m.iprm, y, ws[5], ws[6], m.ref_u, m.ref_e, m._zh))
        ref = np.array([f[0], f[1], f[2], f[6]])
        assert np.allclose(w, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


@njit
def _hook_rows(prm, iprm, y, GT, GTH, ref_u, ref_e, zh):
    return RJ._hook_rows(prm, iprm, prm[K.P_ELASTIC], zh, y[0], y[1], y[2], GT[0, 0], GT[0, 1],
                         GT[0, 2], GTH[0], ref_u, ref_e)


def test_uncovered_models_fall_back_to_the_coloured_differences():
    """An end load or generalized forces (the Itô drift) are not covered:
    :func:`~flagellum.rod.jacobian.model_jacobian` returns the coloured Jacobian bit for bit and
    its cost of one right-hand side per colour; covered models cost one."""
    from flagellum.hydro.options import Hydrodynamics

    rng = np.random.default_rng(4)
    base = RodModel(Params(Filament(segment_length=0.5)), Motor(1.0))
    assert RJ.covered(base.iprm, base.prm)
    models = [RodModel(Params(Filament(segment_length=0.5)), Motor(1.0),
                       end_load=EndLoad(force=2.0))]
    assert RJ.covered(*(lambda m: (m.iprm, m.prm))(
        RodModel(Params(Filament(segment_length=0.5)), Motor(1.0),
                 hydrodynamics=Hydrodynamics(model="sbt"))))
    gen = RodModel(Params(Filament(segment_length=0.5)), Motor(1.0))
    gen.iprm[K.I_GEN] = 1
    models.append(gen)
    for m in models:
        assert not RJ.covered(m.iprm, m.prm)
        kl, ku = m.jacobian_band
        y = _state(m, rng)
        m.refresh_mobility(y, force=True)
        ny = y.size
        color, lo, hi = m.jacobian_colors(kl, ku)
        ab1, ab2 = np.zeros((ny, 2 * kl + ku + 1)), np.zeros((ny, 2 * kl + ku + 1))
        f0 = np.zeros(ny)
        K.model_rhs(K.general_flag(m.iprm), y, f0, *_args(m))
        cost = RJ.model_jacobian(K.general_flag(m.iprm), y, f0, *_args(m), kl, ku, ab1, 1.0,
                                 np.zeros(ny), np.zeros(ny), color, lo, hi)
        K.model_colored_jacobian(K.general_flag(m.iprm), y, f0, *_args(m), kl, ku, ab2, 1.0,
                                 np.zeros(ny), np.zeros(ny), color, lo, hi)
        assert cost == color.max() + 1
        assert np.array_equal(ab1, ab2)
    kl, ku = base.jacobian_band
    y = _state(base, rng)
    ny = y.size
    f0 = np.zeros(ny)
    cost = RJ.model_jacobian(None, y, f0, *_args(base), kl, ku, np.zeros((ny, 2 * kl + ku + 1)),
                             1.0, np.zeros(ny), np.zeros(ny), *base.jacobian_colors(kl, ku))
    assert cost == 1


def _colored_loop():
    j = B._jacobian.py_func
    jac = njit(types.FunctionType(j.__code__, dict(j.__globals__, CHAIN_JACOBIAN=False), j.__name__))
    f = B.bdf_advance.py_func
    return njit(types.FunctionType(f.__code__, dict(f.__globals__, _jacobian=jac), f.__name__))


def test_bdf_run_with_either_jacobian_gives_the_same_motion(monkeypatch):
    """The BDF (rtol 1e-6) with the chain-rule Jacobian and with the coloured one, buckling
    filament (L = 2 µm, M = 1.6) from rest to 0.02 s: Newton converges to the same steps'
    solutions, so the states agree to well within the error tolerance (5e-5 of the filament's
    extent) and the step counts to 10 %."""
    short = Params.from_flat({"length": 2.0})
    out = {}
    for name in ("chain", "colored"):
        if name == "colored":
            monkeypatch.setattr(B, "bdf_advance", _colored_loop())
        m = RodModel(short, Motor(1.6))
        s = B.BdfStepper(m, 0.0, m.initial_state())
        y = s.advance(0.02).copy()
        out[name] = (y, s.stats)
    (ya, sa), (yc, sc) = out["chain"], out["colored"]
    assert np.abs(ya - yc).max() <= 5e-5 * 2.0
    assert abs(sa["steps"] - sc["steps"]) <= 0.1 * sc["steps"]


SBT_CASES = [c for c in CASES if c[0] in ("anchored", "load sphere", "free swimmer", "elastic hook")]


@pytest.mark.parametrize("name,boundary,motor", SBT_CASES, ids=[c[0] for c in SBT_CASES])
def test_chain_jacobian_of_the_frozen_nonlocal_mobility(name, boundary, motor):
    """With a frozen nonlocal ΔM the chain rule differentiates the banded operator (local drag
    plus ΔM's blocks between beads at most ``I_NEAR`` apart), the operator the coloured
    differences perturb: against a dense central difference of that operator's right-hand
    side, N = 25, ΔM built at a state other than the one differentiated (as between
    renewals)."""
    from flagellum.hydro.options import Hydrodynamics

    rng = np.random.default_rng(7)
    m = RodModel(Params(Filament(segment_length=0.4)), motor, Boundary(**boundary),
                 hydrodynamics=Hydrodynamics(model="sbt"))
    m.prm[K.P_OMEGA] = 800.0
    assert RJ.covered(m.iprm, m.prm) and m.iprm[K.I_NEAR] >= 1
    m.refresh_mobility(_state(m, rng), force=True)
    y = _state(m, rng)
    banded = m.iprm.copy()
    banded[K.I_HYDRO] = K.HYDRO_BANDED
    args = list(_args(m))
    args[1] = banded
    Jd = _central(y, tuple(args))
    kl, ku = m.jacobian_band
    Ja = _dense(_chain(m, y), kl, ku)
    # the band holds the whole banded operator's Jacobian
    i, j = np.indices(Jd.shape)
    assert np.abs(Jd[(i - j > kl) | (j - i > ku)]).max() <= 1e-9 * np.abs(Jd).max()
    assert _close(Ja, Jd, 1e-6).all()
    # ΔM's near field is in it: the local model's Jacobian at the same state differs
    loc = m.iprm.copy()
    loc[K.I_HYDRO] = K.HYDRO_LOCAL
    args[1] = loc
    assert not _close(_central(y, tuple(args)), Jd, 1e-3).all()
