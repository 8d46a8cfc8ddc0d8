"""The fast paths of the nonlocal mobility (docs/hydrodynamics.md, "Cost"): the constrained
mobility without dense inverses, the turned ΔM, the secant model between renewals, and the
Numba BDF with the frozen ΔM against CVODE."""

import numpy as np
import pytest

from flagellum.helix import discrete_helix
from flagellum.hydro import dynamics as D
from flagellum.hydro import local as L
from flagellum.hydro.options import Hydrodynamics
from flagellum.integrate.frozen import (QUAD_W2, R_ACTIVE, R_HIST, W_HI, FrozenMobility, secant_after,
                                        secant_mobility)
from flagellum.motor import Boundary, Motor
from flagellum.params import Filament, Params
from flagellum.simulator import Simulator, SolverOptions

SHORT = Params.from_flat({"length": 2.0})


def _resistance_form(big, n1, rotation_held):
    """The constrained mobility the textbook way (independent of hydro.dynamics' Lagrange
    form): invert the grand mobility (Ω = 0 held: the bead–sphere block of the inverse;
    torque-free: the inverse of the bead–sphere block), attach the sphere to bead 0
    (V = U_0: Pᵀ R P), remove bead 0's constrained components and invert back."""
    m = 3 * n1
    R = np.linalg.inv(big)[:m + 3, :m + 3] if rotation_held else np.linalg.inv(big[:m + 3, :m + 3])
    P = np.zeros((m + 3, m))
    P[:m] = np.eye(m)
    P[m:, :3] = np.eye(3)
    R = P.T @ R @ P
    free = np.ones(m, bool)
    if rotation_held:
        free[:2] = False
    out = np.zeros((m, m))
    out[np.ix_(free, free)] = np.linalg.inv(R[np.ix_(free, free)])
    return out


@pytest.mark.parametrize("anchor, a", [(L.AXIAL, 1.0), (L.FREE, 0.5)])
def test_constrained_mobility_with_a_sphere_is_the_resistance_form(anchor, a):
    x = discrete_helix(Filament(length=4.0)).positions
    x = x + np.random.default_rng(2).normal(0.0, 0.01, x.shape)
    big = D.grand_mobility(x, 0.01, 1e-3, D.sphere_centre(x, a), a)
    want = _resistance_form(big, len(x), rotation_held=anchor == L.AXIAL)
    got = D.effective_mobility(x, 0.01, 1e-3, anchor, a)
    assert np.abs(got - want).max() < 1e-9 * np.abs(want).max()
    if anchor == L.AXIAL:
        assert np.all(got[:2] == 0) and np.all(got[:, :2] == 0)


def test_turned_correction_is_r_d_rt_per_block():
    rng = np.random.default_rng(3)
    dm = rng.normal(size=(12, 12))
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    want = np.kron(np.eye(4), R) @ dm @ np.kron(np.eye(4), R).T
    assert np.allclose(D.rotate_correction(dm, R), want, rtol=0, atol=1e-14)


def _state(m, x):
    """The initial state of model m with its bead positions replaced by x (n+1, 3)."""
    y = m.initial_state()
    y[3:3 + 4 * (m.n + 1)].reshape(-1, 4)[:, :3] = x
    return y


def test_secant_model_is_exact_at_both_renewals_and_linear_between():
    """ΔM(y) = ΔM_k + w (ΔM_k − ΔM_{k−1}), w = d·(x − x_k)/|d|²: ΔM_k at x_k (w = 0), ΔM_{k−1}
    at x_{k−1} (w = −1), linear along d, held at W_HI beyond; left as it is when off."""
    from flagellum.rod.model import RodModel

    m = RodModel(SHORT, hydrodynamics=Hydrodynamics("sbt"))
    n1 = m.n + 1
    rng = np.random.default_rng(2)
    x_prev = rng.normal(size=(n1, 3))
    d = rng.normal(size=(n1, 3))
    x_k = x_prev + d
    old, new = rng.normal(size=(4, 4)), rng.normal(size=(4, 4))
    base, G = new, new - old
    xu = np.array([x_k.ravel(), d.ravel() / np.sum(d * d)])
    dm = np.zeros((4, 4))
    rp = np.array([1.0, np.nan])
    for x, want in ((x_k, new), (x_prev, old), (x_k + 0.5 * d, new + 0.5 * G),
                    (x_k + 10 * d, new + W_HI * G)):
        secant_mobility(_state(m, x), dm, base, G, xu, rp)
        assert np.allclose(dm, want, rtol=0, atol=1e-12)
    rp[R_ACTIVE] = 0.0
    secant_mobility(_state(m, x_prev), dm, base, G, xu, rp)
    assert np.allclose(dm, new + W_HI * G)  # off: left as it is


@pytest.mark.parametrize("carry", [False, True])
def test_secant_slope_is_the_chord_to_the_quadratic_through_three_renewals(carry):
    """Renewals of a ΔM that is exactly quadratic in the arc s along a straight bead path
    x(s) = x_0 + s d, at unequal intervals s = 0, 0.7, 1.7: one interval on (w = 1, s = 2.7)
    the model equals that quadratic (the chord from its start to the quadratic's value, by
    Newton's divided differences with the renewal before last at w₂ = −1.7), where the new
    model starts from the old one's value (``carry``: the beads went on as before); halfway it
    is the chord's midpoint. Where the new model starts at the renewal instead (the beads did
    not go on as before), without the renewal before last in the history, or with w₂ outside
    QUAD_W2, the model is the secant of the last two renewals (linear extrapolation)."""
    rng = np.random.default_rng(11)
    n1, size = 5, 6
    x0, d = rng.normal(size=3 * n1), rng.normal(size=3 * n1)
    S0, S1, S2 = (rng.normal(size=(size, size)) for _ in range(3))

    def S(s):  # exactly quadratic in s
        return S0 + s * S1 + s * s * S2

    s_older, s_prev, s_new = 0.0, 0.7, 1.7
    C = S(s_new) + rng.normal(size=(size, size)) * 1e-2  # the old model's value there
    w_star = 0.9

    def renew(history, x_older_s):
        dm = S(s_new).copy()
        sample, older = S(s_prev).copy(), S(s_older).copy()
        base = C - w_star * np.ones((size, size))  # so that base + w* G = C with G = 1
        G = np.ones((size, size))
        xu, rp = np.zeros((2, 3 * n1)), np.array([1.0, 0.0, history])
        x_older = x0 + x_older_s * d
        secant_after(dm, sample, base, G, xu, rp, x0 + s_prev * d, x0 + s_new * d, carry,
                     w_star, older, x_older)
        assert np.allclose(sample, S(s_new)) and np.allclose(older, S(s_prev))
        return dm, G, rp

    start = C if carry else S(s_new)
    linear = 2 * S(s_new) - S(s_prev)  # the secant's extrapolation (of S(s_new) at w = 0)
    dm, G, rp = renew(2.0, s_older)
    assert rp[R_HIST] == 3.0 and np.allclose(dm, start)
    want = S(s_new + 1.0) if carry else linear  # w = 1: the quadratic
    assert np.allclose(dm + G, want, rtol=0, atol=1e-10)
    assert np.allclose(dm + 0.5 * G, 0.5 * (start + want), rtol=0, atol=1e-10)
    assert not np.allclose(S(s_new + 1.0), linear, rtol=0, atol=1e-3)  # (the two differ)
    far = s_new + (QUAD_W2[0] - 0.5) * (s_new - s_prev)  # w₂ below QUAD_W2
    for history, s_o in ((1.0, s_older), (2.0, far)):
        dm, G, _ = renew(history, s_o)
        assert np.allclose(dm + G, linear, rtol=0, atol=1e-10)


def test_secant_model_of_the_correction_is_second_order_along_the_path():
    """Along a straight bead path x(s) = x_0 + s d, renewed at s = 0 and s = 1: at s = 1.5,
    half an interval past the last renewal (where the stepper applies it), the secant
    model's error against ΔM built there falls 4× when d is halved (linear extrapolation of
    a smooth function: O(|d|²)), the frozen ΔM_k's only 2× (O(|d|)). The renewals go through
    :class:`FrozenMobility` and the model."""
    from flagellum.rod.model import RodModel, positions

    m = RodModel(SHORT, hydrodynamics=Hydrodynamics("sbt"))
    y0 = m.initial_state()
    x0 = positions(y0)
    rng = np.random.default_rng(5)
    direction = np.r_[[0.0], rng.uniform(0.5, 1.0, m.n)][:, None] * rng.normal(size=x0.shape)
    errors = []
    for size in (0.02, 0.01):
        d = size * direction / np.abs(direction).max()
        m.refresh_mobility(y0, force=True)
        fm = FrozenMobility(m)
        fm.renew(_state(m, x0 + d))  # rebuilt (a deformation, not a turn): secant from x0
        y_mid = _state(m, x0 + 1.5 * d)
        want = D.correction(positions(y_mid), *m.mobility_arguments())
        frozen = fm.arrays[0].copy()
        fm.apply(y_mid)
        dm = m.kernel_arrays[-1][-1]
        errors.append((np.abs(dm - want).max(), np.abs(frozen - want).max()))
    (sec1, fro1), (sec2, fro2) = errors
    # measured: the secant's error 0.20 and 0.082 of the frozen one's; ratios 4.3 and 1.8
    assert sec2 < 0.15 * fro2
    assert sec1 / sec2 == pytest.approx(4.0, rel=0.25)
    assert fro1 / fro2 == pytest.approx(2.0, rel=0.2)


@pytest.mark.parametrize("boundary", [Boundary(), Boundary(anchor="sphere", sphere_radius=1.0)])
def test_bdf_with_the_frozen_mobility_follows_the_unfrozen_splitting(boundary):
    """The default stepper of an SBT run (the Numba BDF, the secant model of ΔM compiled in)
    against the unfrozen splitting (refresh 0: ΔM rebuilt at every right-hand side) on CVODE
    at a tight tolerance, an independent integrator: time averages of thrust and rotation
    rate over the second half of a short run from rest (10 ms, still a transient) within
    2e-3 (measured: thrust 8.5e-4 anchored, 1.0e-3 on the load sphere; with the time ramp
    between builds that this model replaced, 6.1e-4 and 1.4e-3; SBT and RFT differ by 40 %)."""
    out = {}
    for method, rtol, refresh in (("bdf", 1e-6, 0.02), ("cvode", 1e-9, 0.0)):
        sim = Simulator(SHORT, Motor(1.0), boundary, hydrodynamics=Hydrodynamics("sbt", refresh=refresh),
                        solver=SolverOptions(method=method, rtol=rtol))
        tr = sim.run(0.01, save_every=1e-4, progress=False)
        k = len(tr.t) // 2
        out[method] = (np.mean(tr.thrust[k:]),
                       (tr.motor_angle[-1] - tr.motor_angle[k]) / (tr.t[-1] - tr.t[k]))
    assert Simulator(SHORT, hydrodynamics=Hydrodynamics("sbt")).solver.method == "bdf"
    for got, want in zip(out["bdf"], out["cvode"]):
        assert got == pytest.approx(want, rel=2e-3)


@pytest.mark.parametrize("boundary", [Boundary(), Boundary(anchor="sphere", sphere_radius=1.0)])
def test_bdf_compiled_renewals_are_those_of_the_python_loop(boundary):
    """The BDF runs the renewal loop of ``FrozenMobility.advance`` (the one CVODE's Python
    callback drives: sub-targets, limits' use, renewal, next interval) compiled into its
    stepping call. Driven instead through that Python loop, sub-target by sub-target, the
    same stepper takes the same steps and renewals and ends in the same state (the pieces
    are the same compiled functions; the loop around them is the only difference)."""
    from flagellum.integrate.bdf import BdfStepper
    from flagellum.rod.model import RodModel

    out = []
    for compiled in (True, False):
        m = RodModel(SHORT, Motor(1.5), boundary, hydrodynamics=Hydrodynamics("sbt", refresh=0.02))
        y0 = m.initial_state()
        s = BdfStepper(m, 0.0, y0)
        renewals = []
        renew = s._frozen.renew

        def counted(y):
            renewals.append(1)
            renew(y)
        s._frozen.renew = counted
        for t in np.linspace(0.0, 0.0004, 5)[1:]:
            if compiled:
                s.advance(t)
            else:
                s._frozen.advance(s.t, s.y, t, lambda tn: (True, s._advance(tn, renew=False), None))
        out.append((s.y.copy(), s.stats["steps"], s._frozen.last, len(renewals),
                    s.stats["mobility_renewals"]))
    (y1, steps1, last1, _, n_compiled), (y2, steps2, last2, n_python, n_counted) = out
    assert steps1 == steps2 and last1 == last2
    assert n_python > 20  # ΔM renewed many times (the compiled loop's renew is not the wrapper)
    assert n_compiled == n_counted == n_python
    assert np.abs(y1 - y2).max() <= 1e-12 * np.abs(y2).max()


def test_bdf_with_sbt_carries_its_history_through_frame_and_chart_changes(monkeypatch):
    """At M = 3 (buckled, whirling) the co-rotating frame's rate and the charts change many
    times; the BDF carries its history through them with a frozen ΔM too (a chart change
    leaves the positions and ΔM as they are; a frame change rebuilds ΔM at the current
    beads), instead of restarting at order 1 (at M = 3 over 0.1 s that took 8 756 steps
    against 5 702 carried). Time averages over the second half of 30 ms against the
    unfrozen splitting on CVODE (rtol 1e-8): within 1e-3 (thrust) and 2e-4 (rotation rate).
    Measured: 3.0e-4 and 2.6e-5, the same as with a restart at every change (3.0e-4, 2.7e-5)."""
    import flagellum.simulator as S
    from flagellum.integrate import bdf as B

    changes, steppers = [], []
    carry, init = S.Simulator._carry, B.BdfStepper.__init__

    def counted(self, stepper, t, y, charts, omega):
        changes.append(self.model.omega_frame != omega)
        return carry(self, stepper, t, y, charts, omega)

    def kept(self, *a, **k):
        init(self, *a, **k)
        steppers.append(self)
    monkeypatch.setattr(S.Simulator, "_carry", counted)
    monkeypatch.setattr(B.BdfStepper, "__init__", kept)
    out = {}
    for method, rtol, refresh in (("bdf", 1e-6, 0.02), ("cvode", 1e-8, 0.0)):
        sim = Simulator(Params(), Motor(3.0), hydrodynamics=Hydrodynamics("sbt", refresh=refresh),
                        solver=SolverOptions(method=method, rtol=rtol))
        tr = sim.run(0.03, save_every=1e-4, progress=False)
        k = len(tr.t) // 2
        out[method] = (np.mean(tr.thrust[k:]),
                       (tr.motor_angle[-1] - tr.motor_angle[k]) / (tr.t[-1] - tr.t[k]))
        if method == "bdf":
            assert sum(changes) >= 5 and len(changes) > sum(changes)  # frame and chart changes
            assert len(steppers) == 1 and steppers[0].stats["jacobians_at_start"] == 1
    assert out["bdf"][0] == pytest.approx(out["cvode"][0], rel=1e-3)
    assert out["bdf"][1] == pytest.approx(out["cvode"][1], rel=2e-4)


def test_bdf_refactorizes_less_with_a_nonlocal_mobility_and_reaches_the_same_state():
    """With SBT the BDF refactorizes I − cJ only where c changed by more than 30 % (CVODE's
    rule, the Newton step scaled by 2/(1 + c/c_LU) in between): fewer factorizations, and
    the state as close to an rtol = 1e-9 run as refactorizing at every change (modified Newton
    converges to the same root with either matrix). Measured over 0.4 ms from rest: 116 → 80
    factorizations, the largest state error 1.0e-3 → 8.8e-4. RFT keeps its rule (0)."""
    from flagellum.integrate.bdf import REFACTOR_NONLOCAL, S_DGMAX, BdfStepper
    from flagellum.rod.model import RodModel

    out = {}
    for refactor, rtol in ((0.0, 1e-6), (None, 1e-6), (0.0, 1e-9)):
        m = RodModel(SHORT, Motor(1.5), hydrodynamics=Hydrodynamics("sbt"))
        s = BdfStepper(m, 0.0, m.initial_state(), rtol=rtol, refactor=refactor)
        assert s._st[S_DGMAX] == (refactor if refactor is not None else REFACTOR_NONLOCAL)
        for t in np.linspace(0.0, 0.0004, 5)[1:]:
            s.advance(t)
        out[refactor, rtol] = (s.y.copy(), s.stats)
    (y0, st0), (y1, st1), (ref, _) = out[0.0, 1e-6], out[None, 1e-6], out[0.0, 1e-9]
    assert st1["factorizations"] < 0.8 * st0["factorizations"]
    e0, e1 = np.abs(y0 - ref).max(), np.abs(y1 - ref).max()
    assert e1 < 3.0 * e0
    rft = RodModel(SHORT, Motor(1.5))
    assert BdfStepper(rft, 0.0, rft.initial_state())._st[S_DGMAX] == 0.0


def test_cvode_with_the_frozen_mobility_follows_the_unfrozen_splitting():
    """The same comparison for CVODE with the frozen ΔM at a tight tolerance: within 1e-3
    (measured 8.4e-4 thrust, 6.8e-5 rate; the BDF 8.5e-4, 6.9e-5)."""
    out = {}
    for rtol, refresh in ((1e-9, 0.02), (1e-9, 0.0)):
        sim = Simulator(SHORT, Motor(1.0), hydrodynamics=Hydrodynamics("sbt", refresh=refresh),
                        solver=SolverOptions(method="cvode", rtol=rtol))
        tr = sim.run(0.01, save_every=1e-4, progress=False)
        k = len(tr.t) // 2
        out[refresh] = (np.mean(tr.thrust[k:]),
                        (tr.motor_angle[-1] - tr.motor_angle[k]) / (tr.t[-1] - tr.t[k]))
    for got, want in zip(out[0.02], out[0.0]):
        assert got == pytest.approx(want, rel=1e-3)


def test_the_fixed_step_scheme_checks_the_frozen_mobility_every_step():
    """The deterministic BDF2 scheme with SBT against the unfrozen splitting on CVODE
    (rtol 1e-8), N = 50 from the pinned helix at M = 1.6 over 20 ms: the largest thrust
    deviation relative to the largest thrust within 1.2 %. Measured: 0.81 % (the same
    scheme with RFT against CVODE: 0.54 %, its own time step); with ΔM checked only between
    the simulator's chunks it was 1.83 %, set by the first chunk, in which the twisting-up
    beads moved far past the refresh distance."""
    out = {}
    for solver, refresh in ((SolverOptions(method="cvode", rtol=1e-8), 0.0),
                            (SolverOptions(method="implicit"), 0.02)):
        sim = Simulator(Params(), Motor(1.6), hydrodynamics=Hydrodynamics("sbt", refresh=refresh),
                        solver=solver)
        out[refresh] = np.asarray(sim.run(0.02, save_every=2e-4, progress=False).thrust)
        if refresh:
            assert sim._stepper().tracks_mobility
    ref = out[0.0]
    assert np.max(np.abs(out[0.02] - ref)) < 0.012 * np.max(np.abs(ref))


def test_a_rigid_turn_renews_the_last_renewal_turned_and_the_model_does_not_jump():
    """After a renewal at x1 (S1 = ΔM(x1), secant model on), the beads turn rigidly about
    bead 0 (here by about one interval along the secant, w ≈ 1): the renewal S2 is
    R S1 Rᵀ, which is ΔM at the turned beads (Stokes flow is isotropic), taken from S1
    itself, not from the secant model's value at some state. The model goes on from its
    value at the turned beads (no jump) and reaches the secant's extrapolation 2 S2 − S1 one
    interval on: with the renewal before it in the history, the quadratic through the three
    (the chord slope of :func:`secant_after`)."""
    from flagellum.rod.model import RodModel, positions

    m = RodModel(SHORT, hydrodynamics=Hydrodynamics("sbt"))
    y0 = m.initial_state()
    fm = FrozenMobility(m)
    m.refresh_mobility(y0, force=True)
    s0 = m.kernel_arrays[-1][-1].copy()
    c, s_ = np.cos(0.05), np.sin(0.05)
    R = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
    x0 = positions(y0)
    y1 = _state(m, x0 @ R.T)
    fm.renew(y1)  # turned: S1 at x1, the secant from x0
    s1 = D.correction(positions(y1), *m.mobility_arguments())
    y2 = _state(m, positions(y1) @ R.T)
    dm = m.kernel_arrays[-1][-1]
    fm.apply(y2)
    before = dm.copy()  # the secant model's value at y2: not ΔM(x1)
    assert 0.5 <= fm.arrays[3][1] <= 1.5
    fm.renew(y2)  # turned again
    s2 = D.correction(positions(y2), *m.mobility_arguments())
    scale = np.abs(s2).max()
    assert np.abs(fm.work[0] - s2).max() < 1e-9 * scale
    assert np.allclose(fm.arrays[2][0], positions(y2).ravel())
    fm.apply(y2)
    assert np.abs(dm - before).max() < 1e-12 * scale  # no jump
    x0, x1, x2 = x0, positions(y1), positions(y2)
    fm.apply(_state(m, 2 * x2 - x1))  # one interval on along d
    dd = x2 - x1
    w2 = np.sum(dd * (x0 - x2)) / np.sum(dd * dd)  # the renewal before last, about −2
    assert QUAD_W2[0] <= w2 <= QUAD_W2[1]
    quad = 2 * s2 - s1 + 2 * ((s2 - s1) - (s1 - s0) / (-1 - w2)) / (-w2)
    assert np.abs(dm - quad).max() < 1e-9 * scale


def test_a_renewal_off_the_secant_restarts_the_model_at_the_renewed_correction():
    """Where the beads did not go on along the last displacement (w far from 1 at the
    renewal), the old model's error would be carried into the new one undamped (times
    1 − w): the new model starts at the renewed ΔM instead."""
    from flagellum.rod.model import RodModel, positions

    m = RodModel(SHORT, hydrodynamics=Hydrodynamics("sbt"))
    y0 = m.initial_state()
    m.refresh_mobility(y0, force=True)
    fm = FrozenMobility(m)
    x0 = positions(y0)
    rng = np.random.default_rng(6)
    d = np.r_[[0.0], rng.uniform(0.01, 0.02, m.n)][:, None] * rng.normal(size=x0.shape)
    fm.renew(_state(m, x0 + d))
    back = _state(m, x0 + 0.2 * d)  # w = −0.8: the beads went back
    fm.renew(back)
    want = D.correction(positions(back), *m.mobility_arguments())
    assert np.abs(fm.arrays[0] - want).max() < 1e-9 * np.abs(want).max()


def test_bench_reports_the_sbt_regimes_with_their_ratio_to_rft():
    """``flagellum bench --sbt-regimes``: each regime with both models, the same work (the
    RFT run's thrust per torque is the paper's ≈ 0.9 /µm, SBT's ≈ 40 % lower:
    docs/hydrodynamics.md, "The paper's numbers with RFT and SBT")."""
    from flagellum.bench import sbt_regimes

    row = sbt_regimes(quick=True, names=("from_rest_M1",), reference=False)["from_rest_M1"]
    assert row["rft"]["method"] == row["sbt"]["method"] == "bdf"
    assert row["cpu_ratio"] == pytest.approx(row["sbt"]["cpu_seconds"] / row["rft"]["cpu_seconds"])
    assert row["sbt"]["thrust"] < 0.7 * row["rft"]["thrust"]


@pytest.mark.slow
def test_bdf_with_gmres_newton_follows_the_unfrozen_splitting_at_200_segments():
    """At N = 200 (L = 10 µm) the default SBT stepper is the BDF with GMRES inside each
    Newton step (the banded matrix alone let the step collapse there,
    docs/hydrodynamics.md, "Scaling with N"): over 2 ms from rest at M = 1 its time averages
    of thrust and rotation rate agree with the unfrozen splitting (refresh 0) on CVODE, an
    independent integrator, within the 2e-3 of the N = 50 test above, in a step count of the
    order of CVODE's (hundreds, not the collapsed tens of thousands)."""
    p = Params(Filament(segment_length=10.0 / 200))
    out, steps = {}, {}
    for method, rtol, refresh in ((None, 1e-6, 0.02), ("cvode", 1e-8, 0.0)):
        sim = Simulator(p, Motor(1.0), hydrodynamics=Hydrodynamics("sbt", refresh=refresh),
                        solver=SolverOptions(method=method, rtol=rtol))
        tr = sim.run(0.002, save_every=2e-5, progress=False)
        k = len(tr.t) // 2
        out[sim.solver.method] = (np.mean(tr.thrust[k:]),
                                  (tr.motor_angle[-1] - tr.motor_angle[k]) / (tr.t[-1] - tr.t[k]))
        steps[sim.solver.method] = sim.steps
    assert set(out) == {"bdf", "cvode"}
    assert steps["bdf"] < 3 * steps["cvode"]
    for got, want in zip(out["bdf"], out["cvode"]):
        assert got == pytest.approx(want, rel=2e-3)


@pytest.mark.slow
@pytest.mark.ci
def test_bdf_with_gmres_at_400_segments_does_not_accept_an_unconverged_newton_step():
    """At N = 400 the BDF's GMRES (at most ``bdf.KRYLOV_MAX`` iterations with the banded
    preconditioner) often stops short of its tolerance. A truncated GMRES returns a small
    step that is not the Newton step, and reading that as convergence accepted wrong states:
    over 0.5 ms from rest at M = 1 the thrust 0.15–0.45 ms later was off by 11–13 % against
    CVODE (measured once, docs/hydrodynamics.md, "Newton with GMRES above N = 100"). With
    the linear residual in the convergence test the BDF follows CVODE, an independent
    integrator, at every record (within 1 %; 0.1 % measured). With the bond criterion of
    the frozen ΔM, its sub-intervals and the near field over 0.2 µm in the Newton matrix
    (tests/test_sbt_fine.py) the pair of runs takes about 15 s instead of 8 minutes, and the
    bond-scale excursion of the first 50 µs (thrust −26 pN at the first record in both) is
    gone."""
    p = Params(Filament(segment_length=10.0 / 400))
    thrust = {}
    for method in ("bdf", "cvode"):
        sim = Simulator(p, Motor(1.0), hydrodynamics=Hydrodynamics("sbt"),
                        solver=SolverOptions(method=method))
        thrust[method] = sim.run(5e-4, save_every=5e-5, progress=False).thrust
    assert np.asarray(thrust["bdf"][1:]) == pytest.approx(np.asarray(thrust["cvode"][1:]), rel=1e-2)


@pytest.mark.parametrize("anchor, a", [(L.FIXED, 0.0), (L.AXIAL, 1.0), (L.FREE, 0.5), (L.FREE, 0.0)])
@pytest.mark.parametrize("symmetric", [False, True])
def test_compiled_correction_is_the_effective_minus_the_local_mobility(anchor, a, symmetric):
    """The build the simulator calls (one compiled pass, written into the stepper's ΔM) is
    M_eff − M_loc of the two public pieces, each tested on its own against the resistance form
    and the local drag."""
    x = discrete_helix(Filament(length=4.0)).positions
    x = x + np.random.default_rng(5).normal(0.0, 0.01, x.shape)
    h, gammas, zeta = 0.2, (1.6e-3, 2.8e-3, 1.26e-6), 0.0123
    me = D.effective_mobility(x, 0.01, 1e-3, anchor, a)
    if symmetric:
        me = 0.5 * (me + me.T)
    want = me - D.local_mobility(x, h, gammas[0], gammas[1], anchor, zeta)
    out = np.full_like(want, np.nan)
    got = D.correction(x, h, gammas, anchor, zeta, 0.01, 1e-3, a, symmetric=symmetric, out=out)
    assert got is out
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
