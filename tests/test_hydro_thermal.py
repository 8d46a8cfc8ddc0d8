"""Thermal noise with the nonlocal mobility (integrate.brownian, docs/hydrodynamics.md):
the noise covariance is 2kT M_s Δt, equilibrium statistics do not depend on the mobility,
and a stiff rod diffuses with D = kT R⁻¹ of its nonlocal resistance (Einstein)."""

import numpy as np
import pytest
from conftest import assert_one_line_error

from flagellum import Filament, Fluid, Params
from flagellum.hydro import rft, sbt
from flagellum.hydro import dynamics as D
from flagellum.hydro.dynamics import Hydrodynamics, effective_mobility
from flagellum.hydro import local as L
from flagellum.integrate import brownian as BR
from flagellum.integrate.brownian import ImplicitStepper
from flagellum.errors import ParameterError
from flagellum.motor import Boundary, Motor
from flagellum.rod.model import RodModel, positions
from flagellum.simulator import Simulator, SolverOptions

KT = 4.1e-3
SBT = Hydrodynamics("sbt")


def _run(params, t_end, dt, hyd, seed=3, every=4, scheme="theta"):
    sim = Simulator(params, Motor(0.0), thermal=True, seed=seed, hydrodynamics=hyd,
                    solver=SolverOptions(method="implicit", dt=dt, scheme=scheme, theta=0.5))
    return sim.run(t_end, save_every=every * dt, progress=False)


def test_thermal_sbt_run_is_reproducible_and_uses_the_symmetric_mobility():
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    a = _run(p, 5e-4, 5e-5, SBT, seed=1, every=1)
    b = _run(p, 5e-4, 5e-5, SBT, seed=1, every=1)
    c = _run(p, 5e-4, 5e-5, Hydrodynamics(), seed=1, every=1)
    assert np.array_equal(a.positions, b.positions)
    assert not np.allclose(a.positions, c.positions)  # the same stream, another mobility
    m = RodModel(p, hydrodynamics=SBT)
    ImplicitStepper(m, 0.0, m.initial_state(), 5e-5, kT=KT)
    assert m.symmetric_mobility
    assert np.array_equal(m._ws[-1], m._ws[-1].T)


def test_nonlocal_noise_has_the_covariance_of_the_symmetric_mobility():
    """Bead part of the thermal increment: ⟨b bᵀ⟩ = 2kT Δt M_s on the free components
    (fluctuation–dissipation), M_s = (M_eff + M_effᵀ)/2 of hydro.dynamics at the state. At
    Δt = 1e-7 s the random-finite-difference drift adds a relative O(kT Δt |∂M|²/M) ≈ 1e-4.
    The sample covariance of 4000 draws has a relative (Frobenius) error ≈ √(1.5/4000)·15/√(15)
    ≈ 6 % here (entries of similar size, 15 × 15): the bound is 10 %."""
    p = Params(Filament(length=1.0), Fluid(kT=KT))
    m = RodModel(p, hydrodynamics=SBT)
    y = m.initial_state()
    dt = 1e-7
    st = ImplicitStepper(m, 0.0, y, dt, kT=KT, seed=4)
    rng = np.random.default_rng(9)
    bs = np.array([positions(st._nonlocal_increment(y.copy(), rng.standard_normal(st._n_normals), dt)).ravel()
                   for _ in range(4000)])
    x = positions(y)
    me = effective_mobility(x, p.fluid.filament_radius, p.fluid.viscosity, L.FIXED)
    ms = 0.5 * (me + me.T)[3:, 3:]
    cov = bs[:, 3:].T @ bs[:, 3:] / len(bs) / (2 * KT * dt)
    rel = np.linalg.norm(cov - ms) / np.linalg.norm(ms)
    assert rel < 0.1
    assert np.abs(bs[:, :3]).max() == 0.0  # the anchored bead does not move
    # against the local drag: the nonlocal covariance is measurably different
    from flagellum.hydro.dynamics import local_mobility
    ml = local_mobility(x, p.filament.segment_length, *p.gammas[:2], L.FIXED, 0.0)[3:, 3:]
    assert np.linalg.norm(cov - ml) / np.linalg.norm(ml) > 3 * rel


CELLS = [Boundary(anchor="free", body_radius=1.0),
         Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, motor_offset=30.0,
                  hook="clamped")]


@pytest.mark.parametrize("boundary", [Boundary(), Boundary(anchor="sphere", sphere_radius=1.0),
                                      Boundary(anchor="free", sphere_radius=0.5), *CELLS])
def test_compiled_nonlocal_increment_is_the_numpy_one(boundary):
    """The thermal increment of a nonlocal mobility is one compiled call
    (integrate.brownian.nonlocal_increment; a cell body's cell_nonlocal_increment, whose
    Itô drift goes through the kernel as a slot force); the numpy path (ΔM built by the
    model, the drift as state rates from two applications of the mobility) computes the
    same increment, frozen beads and ΔM from the same normals at the same state (a thermal
    state after 10 steps), to roundoff (measured ≤ 2e-17 of the largest entry; with a cell
    body up to 3e-10, see below). Without the clamped hook frame's θ-force on the body the
    cell's drift was 1.7e-6 of b off."""
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    m = RodModel(p, Motor(1.0), boundary, hydrodynamics=SBT)
    st = ImplicitStepper(m, 0.0, m.initial_state(), 5e-5, kT=KT, seed=3)
    st.advance(5e-4)
    y = st.y.copy()
    g = np.random.default_rng(1).standard_normal(st._n_normals)
    out = []
    for compiled in (False, True):
        st.compiled_increment = compiled
        st.reset(st.t, y)  # the next increment renews the mobility
        b = st._nonlocal_increment(y, g, 5e-5)
        out.append((b, m.mobility_points.copy(), m.kernel_arrays[-1][-1].copy()))
        # the same step again keeps the mobility: the kept factor and drift (its bond-angle
        # rates recomputed in the charts, integrate.brownian.add_frozen_drift) give it back
        renewals = st.n_renewals
        again = st._nonlocal_increment(y, g, 5e-5)
        if compiled or not m.cell:  # (the numpy path renews a cell's at every step)
            assert st.n_renewals == renewals
        assert np.abs(again - b).max() <= 1e-13 * np.abs(b).max()
    (b0, f0, d0), (b1, f1, d1) = out
    # a cell's two paths take the drift's difference quotient in another order: their
    # roundoff, divided by the finite difference's δ = 1e-6, is 1e-11–3e-10 of b (measured;
    # the clamped hook's missing θ-force had put it at 1.7e-6)
    assert np.abs(b1 - b0).max() <= (2e-9 if m.cell else 1e-13) * np.abs(b0).max()
    assert np.abs(d1 - d0).max() <= 1e-14 * np.abs(d0).max()
    assert np.abs(f1 - f0).max() <= 1e-15 * np.abs(f0).max()
    assert np.abs(b0).max() > 0


@pytest.mark.parametrize("boundary", [Boundary(), Boundary(anchor="sphere", sphere_radius=1.0),
                                      Boundary(anchor="free", sphere_radius=0.5), *CELLS])
def test_compiled_thermal_steps_are_the_python_loop(boundary):
    """A chunk of thermal steps is one compiled call (integrate.brownian.nonlocal_steps:
    increment, then implicit step, per step); the Python loop over the numpy increment
    takes the same steps: the same renewals and Newton iterations, and after 20 steps
    states equal up to roundoff amplified by the Newton tolerance (measured ≤ 3e-9 µm).
    A cell body's numpy increment renews at every step: compared with refresh 0."""
    out = []
    hyd = Hydrodynamics("sbt", refresh=0.0) if boundary.is_cell else SBT
    for compiled in (True, False):
        m = RodModel(Params(Filament(length=2.0), Fluid(kT=KT)), Motor(1.0), boundary,
                     hydrodynamics=hyd)
        st = ImplicitStepper(m, 0.0, m.initial_state(), 5e-5, kT=KT, seed=3)
        st.compiled_increment = compiled
        st.advance(20 * 5e-5)
        out.append((st.y.copy(), st.n_renewals, st.n_steps, st.n_iter))
    (y0, *c0), (y1, *c1) = out
    assert c0 == c1 and c0[0] > 1
    assert np.abs(y0 - y1).max() < 1e-7


def test_thermal_mobility_is_renewed_by_distance_hold_and_restart():
    """When the thermal mobility is renewed (integrate.brownian): every THERMAL_HOLD steps
    where the beads stay within the limits (a stiff rod, 100× the paper's rigidities,
    refresh 0.5 µm), at every step with refresh 0, after a reset and after a change of the
    frame's rate, but not after a chart moved (carry: the positions, and so the kept
    mobility, are unchanged)."""
    p = Params(Filament(kappa0=0.0, tau0=0.0, bend_rigidity=350.0, twist_rigidity=350.0,
                        length=2.0), Fluid(kT=KT))
    m = RodModel(p, Motor(0.0), hydrodynamics=Hydrodynamics("sbt", refresh=0.5))
    st = ImplicitStepper(m, 0.0, m.initial_state(), 5e-5, kT=KT, seed=2)
    hold = BR.THERMAL_HOLD
    n = 10 * hold + 1  # the last step renewed
    st.advance(n * 5e-5)
    assert st.n_steps == n and st.n_renewals == 11
    r = st.n_renewals
    st.carry(st.t, st.y, None, frame_turned=False)
    st.advance(st.t + 5e-5)
    assert st.n_renewals == r
    st.carry(st.t, st.y, None, frame_turned=True)
    st.advance(st.t + 5e-5)
    assert st.n_renewals == r + 1
    st.reset(st.t, st.y)
    st.advance(st.t + 5e-5)
    assert st.n_renewals == r + 2
    m0 = RodModel(p, Motor(0.0), hydrodynamics=Hydrodynamics("sbt", refresh=0.0))
    st0 = ImplicitStepper(m0, 0.0, m0.initial_state(), 5e-5, kT=KT, seed=2)
    st0.advance(10 * 5e-5)
    assert st0.n_renewals == st0.n_steps == 10


@pytest.mark.parametrize("boundary", [Boundary(), Boundary(anchor="sphere", sphere_radius=1.0)])
def test_kept_thermal_mobility_has_the_noise_of_the_applied_one(boundary, monkeypatch):
    """Between renewals the thermal mobility is kept: ξ = √(2kT/Δt) L⁻ᵀ g from the factor
    L Lᵀ = M_s(y*) at the renewal's beads y*, applied through the step's mobility
    M_s' = M_loc(y) + ΔM(y*) = M_s + E and corrected by −½ E ξ − ⅛ E M_s⁻¹ E ξ
    (integrate.brownian.add_kept_terms): the noise is √(2kT/Δt) L (I + S/2 − S²/8) g,
    S = L⁻¹ E L⁻ᵀ. The bead increments are linear in the bead normals g (the Itô drift is
    kept; the local random finite difference takes the last normals, set to 0), so their
    covariance is B Bᵀ from the columns of B. Closed form (algebra):
    B Bᵀ = 2kTΔt (M_s' − L (S³/8 − S⁴/64) Lᵀ) to roundoff. For scale, uncorrected
    (ξ through M_s') it would be off by E + E M_s⁻¹ E, first order: here, four steps after
    the renewal on a 2-µm filament, a bond has turned by about the turn limit, |E| is
    0.25 of the largest mobility entry and the third-order term ≈ 1 % of it (bonds may turn
    by the whole turn limit here, twice the thermal runs' THERMAL_TURN)."""
    monkeypatch.setattr(BR, "THERMAL_TURN", 1.0)
    monkeypatch.setattr(BR, "THERMAL_HOLD", 10 ** 6)  # kept over all the columns' calls
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    m = RodModel(p, Motor(1.0), boundary, hydrodynamics=Hydrodynamics("sbt", refresh=0.5))
    dt = 5e-5
    st = ImplicitStepper(m, 0.0, m.initial_state(), dt, kT=KT, seed=3)
    st.advance(5e-4)
    st.reset(st.t, st.y)
    st.advance(st.t + 4 * dt)  # renewed at the first of these steps, kept at the others
    assert st.n_renewals >= 1
    renewals = st.n_renewals
    y = st.y.copy()
    x, xs = positions(y), m.frozen_beads.copy()
    assert np.abs(x - xs).max() > 1e-3  # the beads have moved since the renewal
    nb = 3 * (m.n + 1)
    zero = np.zeros(st._n_normals)
    b0 = positions(st._nonlocal_increment(y.copy(), zero, dt)).ravel()
    cols = []
    for j in range(nb):
        g = zero.copy()
        g[j] = 1.0
        cols.append(positions(st._nonlocal_increment(y.copy(), g, dt)).ravel() - b0)
    assert st.n_renewals == renewals  # all at the kept mobility
    B = np.array(cols).T
    ms_now, free = m.mobility_matrix(y)
    h, (gpar, gperp, _) = m.h, m.gammas
    anchor, zeta = m.mobility_arguments()[2:4]
    f = np.ix_(free, free)
    E = (D.local_mobility(x, h, gpar, gperp, anchor, zeta)
         - D.local_mobility(xs, h, gpar, gperp, anchor, zeta))[f]
    ms_now = ms_now[f]
    chol = np.linalg.cholesky(ms_now - E)
    S = np.linalg.solve(chol, np.linalg.solve(chol, E).T).T  # L⁻¹ E L⁻ᵀ (E symmetric)
    S3 = S @ S @ S
    third = chol @ (S3 / 8 - S3 @ S / 64) @ chol.T
    cov = (B @ B.T)[f] / (2 * KT * dt)
    scale = np.abs(ms_now).max()
    assert np.abs(cov - (ms_now - third)).max() <= 1e-9 * scale
    assert np.abs(E).max() > 0.1 * scale  # a real test: the first-order term is large
    assert np.abs(third).max() < 0.02 * scale


@pytest.mark.slow
@pytest.mark.ci
def test_equipartition_with_the_nonlocal_mobility():
    """No motor: ⟨E⟩ = ½kT per quadratic mode, 4N modes (test_thermal.py), whatever the
    mobility: a check that drift, noise and the Itô term of M_s are consistent."""
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    n = p.filament.n_segments
    tr = _run(p, 0.04, 1e-5, SBT)
    e = tr.energy[len(tr.energy) // 5:]
    blocks = np.array([b.mean() for b in np.array_split(e, 10)])
    err = blocks.std(ddof=1) / np.sqrt(10)
    assert e.mean() / (2 * n * KT) == pytest.approx(1.0, abs=max(0.05, 3 * err / (2 * n * KT)))


@pytest.mark.slow
@pytest.mark.ci
def test_tangent_correlation_with_the_nonlocal_mobility():
    """Straight rod: ⟨t_i·t_{i+k}⟩ = exp(−k h kT/A) (worm-like chain), as with RFT, at its
    Δt = 5e-6 s. At 1e-5 s the scheme's own bias is ≈ +6 % in 1 − ⟨t·t⟩ (measured with RFT
    and with SBT renewed every step, three seeds each), which with this run's sampling
    error reached the 10 % bound at k = 3 (seed 3: 1.097 renewed every step, 1.101 kept)."""
    A = 3.5
    p = Params(Filament(kappa0=0.0, tau0=0.0, bend_rigidity=A, twist_rigidity=A, length=2.0),
               Fluid(kT=KT))
    tr = _run(p, 0.03, 5e-6, SBT, every=8)
    pos = tr.positions[len(tr.t) // 5:]
    t = np.diff(pos, axis=1)
    t /= np.linalg.norm(t, axis=2)[..., None]
    for k in (1, 3):
        c = np.einsum("tij,tij->ti", t[:, :-k], t[:, k:]).mean()
        assert (1 - c) == pytest.approx(1 - np.exp(-k * 0.2 * KT / A), rel=0.1)


def _tilt_diffusion(hyd, seed=1, t_end=0.25, dt=5e-5, lag=20):
    """⟨|Δu|²⟩/(4τ) of the end-to-end direction u of a stiff straight rod pinned at bead 0
    (L = 4 µm, A = C = 3500 pN·µm², 1000× the paper's: the tip's bending fluctuation
    L kT/3A ≈ 1.6e-6 rad² per direction adds ≈ 2 % to the lag-τ signal 4Dτ = 3e-4 rad²),
    from all (overlapping) windows of τ = lag·Δt = 1 ms."""
    p = Params(Filament(kappa0=0.0, tau0=0.0, bend_rigidity=3500.0, twist_rigidity=3500.0,
                        length=4.0), Fluid(kT=KT))
    sim = Simulator(p, Motor(0.0), thermal=True, seed=seed, hydrodynamics=hyd,
                    solver=SolverOptions(method="implicit", dt=dt))
    tr = sim.run(t_end, save_every=dt, progress=False)
    e = tr.positions[:, -1] - tr.positions[:, 0]
    u = e / np.linalg.norm(e, axis=1)[:, None]
    du = u[lag:] - u[:-lag]
    return np.mean(np.sum(du ** 2, axis=1)) / (4 * lag * dt), p, tr.positions[0]


def _tilt_resistance(r, x):
    """Rotational resistance of a straight rod about an axis ⟂ to it through bead 0."""
    axis = (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0])
    perp = np.cross(axis, [1.0, 0.0, 0.0])
    perp /= np.linalg.norm(perp)
    return perp @ r[3:, 3:] @ perp


@pytest.mark.slow
@pytest.mark.ci
def test_stiff_rod_tilt_diffusion_is_kT_over_its_nonlocal_resistance():
    """Einstein relation with HI: a rigid rod pinned at one end tilts with D = kT/B⊥, B⊥ the
    rotational resistance about the pin: from hydro.sbt.resistance_matrix with the nonlocal
    mobility, from hydro.rft.resistance_matrix (the paper's γ⊥) with the local one (the
    hook's ½γ⊥h³ adds 3e-4). 5000 steps, windows of 20: sampling error ≈ 5 % each; the same
    random stream in both runs, so their ratio is more precise. RFT's B⊥ is 21 % larger.
    Measured: D·B⊥/kT = 0.949 (SBT), 0.959 (RFT); the ratio 0.989 of the predicted one."""
    d_sbt, p, x = _tilt_diffusion(SBT)
    d_rft = _tilt_diffusion(Hydrodynamics())[0]
    t, w = sbt.centreline_nodes(x)
    b_sbt = _tilt_resistance(sbt.resistance_matrix(x, p.fluid.filament_radius, p.fluid.viscosity,
                                                   origin=x[0]), x)
    b_rft = _tilt_resistance(rft.resistance_matrix(x, t, w, *p.gammas[:2], origin=x[0]), x)
    assert d_sbt / (KT / b_sbt) == pytest.approx(1.0, abs=0.12)
    assert d_rft / (KT / b_rft) == pytest.approx(1.0, abs=0.12)
    assert (d_sbt / d_rft) / (b_rft / b_sbt) == pytest.approx(1.0, abs=0.08)
    assert b_rft / b_sbt > 1.15


@pytest.mark.slow
@pytest.mark.ci
def test_fixed_step_bdf2_with_the_nonlocal_mobility_follows_cvode():
    """Deterministic BDF2 (Δt = 2e-5 s) with SBT against CVODE with SBT (rtol 1e-8): the
    anchored filament at M = 1 from the pinned helix, 0.01 s. The Newton iteration of BDF2
    uses the banded near-field Jacobian (the same operator CVODE preconditions with)."""
    out = {}
    for name, solver in (("bdf2", SolverOptions(method="implicit", dt=2e-5)),
                         ("cvode", SolverOptions(rtol=1e-8, atol=1e-10))):
        sim = Simulator(Params(), Motor(1.0), hydrodynamics=SBT, solver=solver)
        tr = sim.run(0.01, save_every=1e-3, progress=False)
        out[name] = np.asarray(tr.positions), np.asarray(tr.thrust)
    assert np.abs(out["bdf2"][0] - out["cvode"][0]).max() < 2e-3
    assert np.abs(out["bdf2"][1] - out["cvode"][1]).max() < 0.01 * np.abs(out["cvode"][1]).max()


def test_thermal_sbt_step_is_limited_by_the_bond_length(cli, tmp_path):
    """With ΔM frozen over a thermal step, a bead kicked past its bond length makes the step
    fail (measured on 0.04-µm bonds, the short rod of tests/test_cell_sbt.py: a kick of 0.9 h
    ran 1 500 steps, 1.07 h failed within 55, docs/hydrodynamics.md "Step size"), so such a
    Δt is refused up front. The limit is where √(2kTΔt/(γ⊥h)) = h (closed form with γ⊥ of
    the parameters); RFT is not limited."""

    short = Filament(kappa0=0.0, tau0=0.0, length=0.16, segment_length=0.04)
    p = Params(short, Fluid(kT=KT))
    h, gperp = 0.04, p.gammas[1]
    limit = h ** 2 * gperp * h / (2 * KT)
    cell = Boundary(anchor="free", body_radius=2.0)

    def make(dt, hyd=SBT, boundary=cell):
        return Simulator(p, Motor(0.0), boundary, thermal=True, seed=1, hydrodynamics=hyd,
                         solver=SolverOptions(method="implicit", dt=dt))

    make(0.98 * limit)
    make(0.98 * limit, boundary=None)
    make(5e-5, hyd=Hydrodynamics())
    for boundary in (cell, None):
        with pytest.raises(ParameterError, match="dt") as e:
            make(1.02 * limit, boundary=boundary)
        assert f"{limit:.3g}" in str(e.value)
    out = tmp_path / "run.h5"
    code, _, err = cli("simulate", "--length", 0.16, "--segment-length", 0.04, "--kT", KT,
                       "--hydrodynamics", "sbt", "--dt", 5e-5, "--time", 1e-3, "-o", out)
    assert_one_line_error(code, err, "dt")
    assert not out.exists()
