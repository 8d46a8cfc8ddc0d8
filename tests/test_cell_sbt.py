"""A cell body with the nonlocal mobility in the fixed-step scheme and with thermal noise
(integrate.brownian, docs/hydrodynamics.md "Thermal noise"): the noise has the covariance of
the coupled mobility of body and filament, the equilibrium statistics do not depend on the
mobility, the body diffuses as Einstein and Perrin say, and the deterministic scheme
converges to CVODE."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flagellum import Filament, Fluid, Params
from flagellum.hydro import body as Bd
from flagellum.hydro.dynamics import Hydrodynamics, cell_local_mobility, cell_mobility
from flagellum.integrate import brownian as BR
from flagellum.integrate.brownian import ImplicitStepper
from flagellum.motor import Boundary, Motor
from flagellum.rod.model import RodModel, positions
from flagellum.simulator import Simulator, SolverOptions
from test_cell_thermal import _diffusion

KT = 4.1e-3
SBT = Hydrodynamics("sbt")


def _slot_map(m, y):
    """K: a cell's slot velocities (V, U_1 … U_n, Ω) to the rates of its bead positions and
    orientation: bead 0 at V + Ω × d, φ̇ = J(φ)⁻¹ Ω (hydro.body.rotvec_rate)."""
    n1 = m.n + 1
    x = positions(y)
    cell = m._cell_body(m._mobility_points(y))
    B = np.zeros((3 * n1 + 3, 3 * n1 + 3))
    B[:3, :3] = np.eye(3)
    d = x[0] - cell.centre
    B[:3, -3:] = -np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])  # Ω × d
    B[3:3 * n1, 3:3 * n1] = np.eye(3 * n1 - 3)
    B[-3:, -3:] = np.array([Bd.rotvec_rate(*y[-3:], *e) for e in np.eye(3)]).T
    return B


def _displacement(b):
    return np.concatenate([positions(b).ravel(), b[-3:]])


@pytest.mark.parametrize("hook", ["free", "clamped"])
def test_cell_noise_has_the_covariance_of_the_coupled_mobility(hook):
    """Fluctuation–dissipation with HI on a cell: over 4000 increments at Δt = 1e-7 s (the
    Itô drift then adds a relative ≈ 1e-4), the beads' and the orientation's displacements
    have the covariance 2kT Δt B M_s Bᵀ, with M_s the symmetric part of
    hydro.dynamics.cell_mobility (body and filament coupled through the body's Stokeslet and
    rotlet) and B the map of its slots (V, U_1 … U_n, Ω) to the state's rates: bead 0 at
    V + Ω × d, φ̇ = J(φ)⁻¹ Ω (hydro.body.rotvec_rate). The noise passes through the kernel's
    local cell motion and ΔM, so this checks that both apply the mobility the noise is drawn
    from. Sampling error of the normalized covariance ≈ 6 % (as in tests/test_hydro_thermal.py);
    bound 10 %; the local (RFT) cell's covariance differs by more than 3× that."""
    p = Params(Filament(length=1.0), Fluid(kT=KT))
    bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, motor_offset=30.0, hook=hook)
    m = RodModel(p, Motor(0.0), bd, hydrodynamics=SBT)
    y = m.initial_state()
    y[-3:] = [0.05, -0.03, 0.02]
    dt = 1e-7
    st = ImplicitStepper(m, 0.0, y, dt, kT=KT, seed=4)
    rng = np.random.default_rng(9)
    bs = np.array([_displacement(st._nonlocal_increment(y.copy(), rng.standard_normal(st._n_normals), dt))
                   for _ in range(4000)])
    cov = bs.T @ bs / len(bs) / (2 * KT * dt)
    x = positions(y)
    cell = m._cell_body(m._mobility_points(y))
    me = cell_mobility(x, p.fluid.filament_radius, p.fluid.viscosity, cell)
    ms = 0.5 * (me + me.T)
    B = _slot_map(m, y)
    expect = B @ ms @ B.T
    rel = np.linalg.norm(cov - expect) / np.linalg.norm(expect)
    assert rel < 0.1
    ml = B @ cell_local_mobility(x, p.filament.segment_length, *p.gammas[:2], p.fluid.viscosity, cell) @ B.T
    assert np.linalg.norm(cov - ml) / np.linalg.norm(ml) > 3 * rel


def _increment_covariance(st, y, dt):
    """The covariance / (2kTΔt) of a cell's thermal increments at y (beads and orientation)
    from the stepper ``st``: they are linear in the slots' normals (V, beads 1 … n, Ω; the
    drift's parts do not depend on them), so it is the product of their columns."""
    n1 = st.model.n + 1
    slots = np.r_[0:3 * n1, 4 * n1 + 6:4 * n1 + 9]
    zero = np.zeros(st._n_normals)
    b0 = _displacement(st._nonlocal_increment(y.copy(), zero, dt))
    cols = []
    for j in slots:
        g = zero.copy()
        g[j] = 1.0
        cols.append(_displacement(st._nonlocal_increment(y.copy(), g, dt)) - b0)
    return np.array(cols).T @ np.array(cols) / (2 * KT * dt)


@pytest.mark.parametrize("hook", ["free", "clamped"])
def test_kept_cell_mobility_has_the_noise_of_the_applied_one(hook, monkeypatch):
    """Between renewals a cell's thermal mobility is kept (integrate.brownian.
    cell_nonlocal_increment): ξ = √(2kT/Δt) L⁻ᵀ g over the slots from L Lᵀ = M_s at the
    renewal's points, corrected in force space to ξ' = (I − ½A + ⅜A²) ξ (A = M_s⁻¹ E,
    E = M_cell,loc(y) − M_cell,loc(y*)) and applied by the kernel through M_s + E and the
    cell's kinematics K. The increments are linear in the slots' normals (the drift's parts
    do not depend on them), so their covariance is the product of their columns. The kept
    mobility turns with the cell: with the best rotation R of the renewal's points onto the
    state's (the tested states turned by 1.9° and 3.0°), E = M_cell,loc(Rᵀ y) − M_cell,loc(y*)
    and the noise ℛ ξ' goes through ℛ (M_s + E) ℛᵀ (ℛ: R on every slot). Closed form
    (algebra): 2kTΔt K P M_s⁻¹ Pᵀ Kᵀ, P = ℛ (M_s + E)(I − ½A + ⅜A²), to roundoff; it differs
    from the applied mobility's K (M_loc(y) + ℛ ΔM ℛᵀ) Kᵀ at third order in A. For scale: at a state
    kept since the renewal whose bonds have turned by 0.3–0.5 of the turn limit (the
    renewal's THERMAL_TURN; ``refresh`` 0.5 µm, so that they decide), K E Kᵀ is 6–14 % of
    the largest entry, the third-order term 0.04–0.7 % (bound 2 %) and the uncorrected
    noise's error K (E + E M_s⁻¹ E) Kᵀ 7–18 % (bound: 5× the third-order term), measured
    with the free and the clamped hook."""
    monkeypatch.setattr(BR, "THERMAL_HOLD", 10 ** 6)
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, motor_offset=30.0, hook=hook)
    m = RodModel(p, Motor(1.0), bd, hydrodynamics=Hydrodynamics("sbt", refresh=0.5))
    dt = 1e-5
    st = ImplicitStepper(m, 0.0, m.initial_state(), dt, kT=KT, seed=3)
    st.advance(2e-4)
    for _ in range(200):  # on to a state kept since the renewal, with most of the limits used
        st.advance(st.t + dt)
        used = min(m.mobility_use(st.y), m.mobility_use(st.y, rotated=True))
        if st._limits[3] >= 2 and 0.3 < used < 0.95 * BR.THERMAL_TURN:
            break
    else:
        pytest.fail("no kept state with 0.3–0.475 of the turn limit used")
    renewals = st.n_renewals
    y = st.y.copy()
    pts, frozen = m._mobility_points(y), m.mobility_points.copy()
    assert np.abs(pts - frozen).max() > 1e-3
    n1 = m.n + 1
    cov = _increment_covariance(st, y, dt)
    assert st.n_renewals == renewals  # all at the kept mobility
    h, (gpar, gperp, _) = m.h, m.gammas

    def local(points):
        return cell_local_mobility(points[:n1], h, gpar, gperp, p.fluid.viscosity,
                                   m._cell_body(points))

    # the kept mobility turned by the best rotation R of the frozen points (identity where
    # that left more): E = M_loc(Rᵀ y) − M_loc(y*), applied as ℛ (M_s + E) ℛᵀ
    rot = m.prm[m._rotation]
    R = rot[:9].reshape(3, 3) if rot[9] else np.eye(3)
    back = frozen[0] + (pts - pts[0]) @ R
    E = local(back) - local(frozen)
    ms = local(frozen) + m.kernel_arrays[-1][-1]
    A = np.linalg.solve(ms, E)
    turn = np.kron(np.eye(len(A) // 3), R)
    P = turn @ (ms + E) @ (np.eye(len(A)) - A / 2 + 3 * A @ A / 8)
    K = _slot_map(m, y)
    expect = K @ P @ np.linalg.solve(ms, P.T) @ K.T
    applied = K @ (local(pts) + turn @ m.kernel_arrays[-1][-1] @ turn.T) @ K.T
    E = turn @ E @ turn.T
    scale = np.abs(applied).max()
    assert np.abs(cov - expect).max() <= 1e-9 * scale
    third = np.abs(expect - applied).max()
    ms = turn @ ms @ turn.T
    raw = K @ (ms + E) @ np.linalg.solve(ms, (ms + E).T) @ K.T  # ξ through M_s + E, uncorrected
    assert np.abs(K @ E @ K.T).max() > 0.05 * scale  # a real test: the first-order term is large
    assert third < 0.02 * scale
    assert np.abs(raw - applied).max() > 5 * third


def test_thermal_sbt_cell_from_the_cli_runs_and_resumes(cli, tmp_path):
    """flagellum simulate --body-radius … --hydrodynamics sbt --thermal: a whole swimming
    cell with HI and noise runs, moves sideways (noise; the deterministic cell swims along
    its axis), and a second run with the same seed is bit-identical."""
    from flagellum.trajectory import open_trajectory

    args = ("simulate", "--body-radius", "0.5", "--hydrodynamics", "sbt", "--thermal", "--torque", "1",
            "--length", "2", "--time", "0.001", "--save-every", "0.00025", "--seed", "4", "--json")
    out = []
    for k in range(2):
        f = tmp_path / f"cell{k}.h5"
        code, _, err = cli(*args, "-o", str(f))
        assert code == 0, err
        out.append(np.asarray(open_trajectory(f)["body_position"]))
    assert out[0].shape == (5, 3) and np.all(np.isfinite(out[0]))
    assert np.ptp(out[0][:, 0]) > 0
    np.testing.assert_array_equal(out[0], out[1])


@pytest.mark.slow
@pytest.mark.ci
def test_fixed_step_sbt_cell_converges_to_cvode():
    """Deterministic cell (spheroid, L = 2 µm, M = 1, 0.01 s) with HI: BDF2 with ΔM rebuilt
    before every step (refresh 0) converges to CVODE with the unfrozen mobility (refresh 0,
    rtol 1e-8). Measured errors of the body's centre: 0.012 µm at Δt = 2.5e-5 s,
    0.0033 µm at 1.25e-5 s (ratio 3.7; with RFT the scheme is second order,
    tests/test_cell_thermal.py), the centre moves 0.23 µm: regression values."""
    bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0)
    exact = Hydrodynamics("sbt", refresh=0.0)

    def centre(**solver):
        sim = Simulator(Params(Filament(length=2.0)), Motor(1.0), bd, hydrodynamics=exact,
                        solver=SolverOptions(**solver))
        return sim.run(0.01, save_every=0.001, progress=False).body_position

    ref = centre(method="cvode", rtol=1e-8)
    e1 = np.abs(centre(method="implicit", dt=2.5e-5) - ref).max()
    e2 = np.abs(centre(method="implicit", dt=1.25e-5) - ref).max()
    assert e1 < 0.03 and e1 / e2 > 2.5


@pytest.mark.slow
@pytest.mark.ci
def test_equipartition_of_the_filament_on_a_cell_with_hi():
    """M = 0, a free hook on a sphere free in 3D, HI between body and filament: ⟨E⟩ = ½kT
    per quadratic mode, 4N (tests/test_cell_thermal.py), whatever the mobility: noise, drift
    and the Itô term of the coupled mobility are consistent."""
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    n = p.filament.n_segments
    sim = Simulator(p, Motor(0.0), Boundary(anchor="free", body_radius=0.5), thermal=True, seed=3,
                    hydrodynamics=SBT, solver=SolverOptions(method="implicit", dt=5e-6, theta=0.5))
    tr = sim.run(0.04, save_every=2e-5, progress=False)
    e = tr.energy[len(tr.energy) // 5:]
    blocks = np.array([b.mean() for b in np.array_split(e, 10)])
    err = blocks.std(ddof=1) / np.sqrt(10)
    assert e.mean() / (2 * n * KT) == pytest.approx(1.0, abs=max(0.05, 3 * err / (2 * n * KT)))


@pytest.mark.slow
@pytest.mark.parametrize("aspect", [1.0, 2.0])
def test_cell_at_rest_diffuses_as_einstein_and_perrin_with_hi(aspect):
    """The Einstein–Perrin test of tests/test_cell_thermal.py with HI: a body with a short
    filament (its drag < 1 % of the body's) diffuses with D = kT/R of the body's resistance
    (Einstein 1905, Perrin 1934). Noise, Itô drift and the orientation's invariant measure
    with the coupled mobility: a missing or doubled noise changes D by 100 %. Δt = 1e-5 s
    (400 lags of 0.2 ms): at 5e-5 s a bead's thermal kick, ≈ 0.06 µm, exceeds these
    0.04-µm bonds, and the step's frozen ΔM loses its positive near field (the chord
    iteration then fails)."""
    measured, expect, n = _diffusion(aspect, 8000, lag=20, dt=1e-5, hydrodynamics=SBT)
    tol = (3.5 * math.sqrt(2 / n), 3.5 * math.sqrt(1 / n)) * 2
    for k, name in enumerate(("D along", "D across", "D_r about", "D_r across")):
        assert measured[k] / expect[k] == pytest.approx(1.0, abs=tol[k]), name


def _rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_turned_cell_mobility_is_the_turned_matrix():
    """A cell's frozen ΔM turned by R in the kernel (forces by Rᵀ, velocities by R:
    RodModel.turn_mobility, the flag in the body's block) is the matrix R ΔM Rᵀ applied
    (hydro.dynamics.rotate_correction, block by block): the same right-hand side to
    roundoff, for a free and a clamped hook. The turn changes it: without it the difference
    is of the order of the nonlocal part."""
    from flagellum.hydro import body as body_model
    from flagellum.hydro.dynamics import rotate_correction

    for hook in ("free", "clamped"):
        bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, motor_offset=30.0, hook=hook)
        m = RodModel(Params(Filament(length=2.0)), Motor(1.0), bd, hydrodynamics=SBT)
        y = m.initial_state()
        y[3:-3] += np.random.default_rng(1).normal(0.0, 0.01, len(y) - 6)
        y[-3:] = [0.1, -0.2, 0.3]
        m.refresh_mobility(y, force=True)
        dm = m.kernel_arrays[-1][-1]
        built = dm.copy()
        R = _rotation(3)
        m.prm[m._rotation] = (*R.ravel(), 1.0)
        turned = m.rhs(0.0, y).copy()
        m.prm[m._rotation] = (*np.eye(3).ravel(), 0.0)
        dm[:] = rotate_correction(built, R)
        direct = m.rhs(0.0, y).copy()
        dm[:] = built
        plain = m.rhs(0.0, y).copy()
        scale = np.abs(direct).max()
        assert np.abs(turned - direct).max() <= 1e-12 * scale
        assert np.abs(plain - direct).max() > 1e-4 * scale
        assert body_model.BLOCK == body_model.ROTATION + 10


def test_turned_cell_mobility_follows_a_rigid_rotation():
    """RodModel.turn_mobility finds the rotation of a rigidly turned cell (all its mobility
    points turned about bead 0): no limit used after the turn, and R ΔM(x) Rᵀ = ΔM(R x) (the
    isotropy of Stokes flow) to roundoff; the raw displacement uses the limits many times."""
    from flagellum.hydro.dynamics import rotate_correction

    bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, motor_offset=30.0)
    m = RodModel(Params(Filament(length=2.0)), Motor(1.0), bd, hydrodynamics=SBT)
    y = m.initial_state()
    m.refresh_mobility(y, force=True)
    x = m.mobility_points.copy()
    R = _rotation(5)
    xr = x[0] + (x - x[0]) @ R.T
    out = np.empty((3, 3))
    args = (m.n + 1, m.hydrodynamics.refresh, m.turn_limit * m.h, out)
    from flagellum.hydro.dynamics import limits_used, rotated_limits_used

    assert rotated_limits_used(xr, x, *args) < 1e-9
    assert np.allclose(out, R, atol=1e-12)
    assert limits_used(xr, x, *args[:3]) > 10
    rebuilt = m.correction_at_points(xr)
    turned = rotate_correction(m.kernel_arrays[-1][-1], R)
    assert np.abs(rebuilt - turned).max() <= 1e-10 * np.abs(rebuilt).max()


def test_swimming_cell_turns_its_mobility_and_follows_the_unfrozen_run(monkeypatch):
    """On CVODE a steadily swimming cell's renewals turn ΔM per right-hand side
    (integrate.frozen.TURN_SHARE: the best rotation of its points took up most of their
    displacement) and the run follows the unfrozen splitting (refresh 0, ΔM rebuilt at
    every right-hand side, rtol 1e-8). E. coli-like cell with a 4-µm filament (spheroid
    2.5 × 0.88 µm, clamped hook, M = 1.3 pN·µm), 0.03 s from rest: the body's centre within
    1e-3 µm of the unfrozen run's (measured 2.8e-4 µm; it swims 0.82 µm), and turning
    intervals among the renewals (measured: all 828)."""
    from flagellum.integrate import frozen as FZ

    modes = []
    renew = FZ.FrozenMobility.renew

    def spy(self, y):
        renew(self, y)
        modes.append(self.turning)

    monkeypatch.setattr(FZ.FrozenMobility, "renew", spy)
    bd = Boundary(anchor="free", body_radius=0.44, body_aspect=2.5 / 0.88, hook="clamped")

    def centre(hyd, **solver):
        sim = Simulator(Params(Filament(length=4.0)), Motor(1.3), bd, hydrodynamics=hyd,
                        solver=SolverOptions(**solver))
        return sim.run(0.03, save_every=0.003, progress=False).body_position

    run = centre(SBT)
    turned = sum(modes)
    ref = centre(Hydrodynamics("sbt", refresh=0.0), method="cvode", rtol=1e-8)
    assert np.abs(run - ref).max() < 1e-3
    assert turned > 0


def _turn_state(m, y, R):
    """The state y turned rigidly by R about bead 0, in charts turned with it (the model's
    reference vectors turned in place: the same material frames, turned)."""
    from scipy.spatial.transform import Rotation

    yr = y.copy()
    x = positions(y)
    yr[:3] = R @ y[:3]
    beads = yr[3:3 + 4 * (m.n + 1)].reshape(-1, 4)
    beads[:, :3] = x[0] + (x - x[0]) @ R.T
    m.ref_u[:] = m.ref_u @ R.T
    m.ref_e[:] = m.ref_e @ R.T
    yr[-3:] = Rotation.from_matrix(R @ Bd.rotvec_matrix(y[-3:])).as_rotvec()
    return yr


@pytest.mark.parametrize("hook", ["free", "clamped"])
def test_kept_cell_mobility_turns_with_the_cell(hook, monkeypatch):
    """A cell's kept thermal mobility turns with the cell (integrate.brownian.
    cell_nonlocal_increment): at a state turned rigidly by R (0.5 rad) since the renewal,
    which used the refresh distance 25 times over, the mobility is still kept, and the
    increments have the covariance 2kTΔt K M_s(y_R) Kᵀ of the turned cell's own symmetric
    mobility (hydro.dynamics.cell_mobility, built there: the isotropy of Stokes flow,
    M_s(Rx) = ℛ M_s(x) ℛᵀ) to roundoff, and the kept Itô drift turns with it: its part of
    the increment moves the beads by R times what it does at the renewal's state."""
    monkeypatch.setattr(BR, "THERMAL_HOLD", 10 ** 6)
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, motor_offset=30.0, hook=hook)
    m = RodModel(p, Motor(1.0), bd, hydrodynamics=Hydrodynamics("sbt"))
    dt = 1e-5
    st = ImplicitStepper(m, 0.0, m.initial_state(), dt, kT=KT, seed=3)
    st.advance(1e-4)  # a generic state
    y = st.y.copy()
    n1 = m.n + 1
    rng = np.random.default_rng(2)
    st.reset(st.t, y)  # renewed at y, with the drift sampled there
    st._nonlocal_increment(y.copy(), rng.standard_normal(st._n_normals), dt)
    renewals = st.n_renewals
    drift = st._fast[3]

    def drift_part(state):
        zero = np.zeros(st._n_normals)
        with_drift = st._nonlocal_increment(state.copy(), zero, dt)
        kept = drift.copy()
        drift[:] = 0.0
        without = st._nonlocal_increment(state.copy(), zero, dt)
        drift[:] = kept
        return positions(with_drift - without)

    at_renewal = drift_part(y)
    R = _rotation(7)
    yr = _turn_state(m, y, R)
    from flagellum.hydro.dynamics import limits_used

    assert limits_used(m._mobility_points(yr), m.mobility_points, n1, m.hydrodynamics.refresh,
                       m.turn_limit * m.h) > 25
    turned = drift_part(yr)
    assert np.abs(at_renewal).max() > 0
    assert np.abs(turned - at_renewal @ R.T).max() <= 1e-9 * np.abs(at_renewal).max()
    cov = _increment_covariance(st, yr, dt)
    assert st.n_renewals == renewals  # all at the kept mobility
    assert m.prm[m._rotation][-1] == 1.0  # applied turned
    x = positions(yr)
    me = cell_mobility(x, p.fluid.filament_radius, p.fluid.viscosity,
                       m._cell_body(m._mobility_points(yr)))
    K = _slot_map(m, yr)
    expect = K @ (0.5 * (me + me.T)) @ K.T
    assert np.abs(cov - expect).max() <= 1e-9 * np.abs(expect).max()


def test_cell_secant_weight_in_the_kernel_is_the_written_matrix():
    """A cell's secant model applied by its weight (prm[P_SECANT] = w: the kernel applies
    DM + w DG, integrate.frozen.FrozenMobility.apply on CVODE) gives the right-hand side of
    the matrix DM + w DG written out, to roundoff: with all of ΔM (the run's operator) and
    with its near-field band (the operator the coloured Jacobian differentiates), for a free
    and a clamped hook. Without the slope the difference is of the order of w DG."""
    from flagellum.rod import kernels as K

    rng = np.random.default_rng(4)
    for hook in ("free", "clamped"):
        bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, motor_offset=30.0, hook=hook)
        m = RodModel(Params(Filament(length=2.0)), Motor(1.0), bd, hydrodynamics=SBT)
        y = m.initial_state()
        y[3:-3] += rng.normal(0.0, 0.01, len(y) - 6)
        y[-3:] = [0.1, -0.2, 0.3]
        m.refresh_mobility(y, force=True)
        ws = m.kernel_arrays[-1]
        dm, dg = ws[-1], ws[-2]
        built = dm.copy()
        dg[:] = 0.05 * rng.normal(size=dg.shape) * np.abs(built).max()
        w = 0.7
        for hydro in (m.iprm[K.I_HYDRO], K.HYDRO_BANDED):
            ip = m.iprm.copy()
            ip[K.I_HYDRO] = hydro

            def rhs():
                f = np.zeros(m.state_size)
                m.rhs_kernel(y, f, m.prm, ip, m.ref_u, m.ref_e, m.ref_m, m._zf, m._zm, m._zh, ws)
                return f

            m.prm[K.P_SECANT] = w
            weighted = rhs()
            m.prm[K.P_SECANT] = 0.0
            dm[:] = built + w * dg
            written = rhs()
            dm[:] = built
            plain = rhs()
            scale = np.abs(written).max()
            assert np.abs(weighted - written).max() <= 1e-12 * scale
            assert np.abs(plain - written).max() > 1e-4 * scale
