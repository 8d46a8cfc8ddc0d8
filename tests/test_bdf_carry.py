"""The Numba BDF's history carried through a change of coordinates (a re-centred chart, a
change of the rotating frame's rate) instead of a restart: the change of coordinates keeps
the physical state, the carried differences equal those of the same trajectory written in
the new coordinates by an independent construction (Rodrigues' parallel transport), and a
run that carries its history follows the restarted run and CVODE."""

import math

import numpy as np
import pytest

from flagellum import Params
from flagellum import simulator as S
from flagellum.integrate import bdf as B
from flagellum.motor import Motor
from flagellum.simulator import Simulator, SolverOptions

SHORT = Params.from_flat({"length": 2.0})


def _transport(u, e, t):
    """e carried from u to t by the rotation about u × t (Rodrigues), independent of the kernels."""
    c = np.cross(u, t)
    s, d = np.linalg.norm(c), float(np.dot(u, t))
    if s < 1e-15:
        return e.copy()
    k = c / s
    ang = math.atan2(s, d)
    return e * math.cos(ang) + np.cross(k, e) * math.sin(ang) + k * np.dot(k, e) * (1 - math.cos(ang))


def _state(pos, u0, e1, charts):
    """The state vector of beads ``pos``, hook tangent ``u0`` and material vectors ``e1``
    (row 0: the hook frame) in ``charts`` (poles, reference vectors)."""
    n = len(pos) - 1
    y = np.zeros(3 + 4 * (n + 1))
    y[:3] = u0
    tang = [u0 / np.linalg.norm(u0)] + [(pos[i] - pos[i - 1]) / np.linalg.norm(pos[i] - pos[i - 1])
                                        for i in range(1, n + 1)]
    for i in range(n + 1):
        y[3 + 4 * i:6 + 4 * i] = pos[i]
        a1 = _transport(charts[0][i], charts[1][i], tang[i])
        y[6 + 4 * i] = math.atan2(np.dot(e1[i], np.cross(tang[i], a1)), np.dot(e1[i], a1))
    return y


def _charts_near(tangents, seed):
    """Random charts (poles, reference vectors ⟂ poles) with poles ≈ 30–60° from ``tangents``."""
    rng = np.random.default_rng(seed)
    poles = tangents + rng.normal(size=tangents.shape)
    poles /= np.linalg.norm(poles, axis=1)[:, None]
    poles[np.einsum("ij,ij->i", poles, tangents) < 0] *= -1  # within 90° of the tangent
    refs = np.cross(poles, rng.normal(size=poles.shape))
    return poles, refs / np.linalg.norm(refs, axis=1)[:, None]


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _trajectory(sim, omega, tilt):
    """A smooth known motion of the simulator's initial filament (lab frame): turning at
    ``omega`` about e_z and at ``tilt`` about e_x; (positions, u0, e1) at time s."""
    fr = sim.model.frames(sim.y)
    pos0 = sim.y[3:].reshape(-1, 4)[:, :3].copy()
    u00, e10 = sim.y[:3].copy(), fr.e1.copy()

    def at(s):
        c, si = math.cos(tilt * s), math.sin(tilt * s)
        r = _rz(omega * s) @ np.array([[1.0, 0, 0], [0, c, -si], [0, si, c]])
        return pos0 @ r.T, r @ u00, e10 @ r.T
    return at


def _wrap_near(theta, ref):
    return ref + (theta - ref + np.pi) % (2 * np.pi) - np.pi


def test_change_of_coordinates_keeps_the_material_frames():
    """Re-centred charts and a turned frame: the same tangents and material vectors e1
    (turned with the coordinates), to rounding."""
    sim = Simulator(SHORT, Motor(1.0), solver=SolverOptions(method="bdf", frame="lab"))
    m = sim.model
    y = sim.y.copy()
    y[3:].reshape(-1, 4)[:, :3] @= _rz(0.3).T  # (any state; a turned copy of the start)
    y[:3] = _rz(0.3) @ y[:3]
    before = m.frames(y)
    old = m.charts()
    m.set_charts(*_charts_near(before.tangents, seed=4))
    angle = 0.7
    y2 = m.change_coordinates(y, old, angle)
    after = m.frames(y2)
    assert np.allclose(after.tangents, before.tangents @ _rz(angle).T, atol=1e-12)
    assert np.allclose(after.e1, before.e1 @ _rz(angle).T, atol=1e-12)
    assert np.max(np.abs(y2[6::4] - y[6::4])) < np.pi  # the branch nearest the old angle
    # identity: same charts, no turn
    assert np.allclose(m.change_coordinates(y2, m.charts(), 0.0), y2, rtol=0, atol=1e-13)


@pytest.mark.parametrize("d_omega", [0.0, 40.0])
def test_carried_history_equals_the_history_in_the_new_coordinates(d_omega):
    """A smooth known trajectory (the filament turning about e_z and e_x) written in the old
    charts and frame: its differences at the BDF's points t_n − j h, carried through a
    re-centring of every chart to the tangents at t_c (and a change Δ of the frame's rate),
    equal the differences of the same trajectory written directly in the new charts and frame
    (:func:`_state`, Rodrigues' transport), to rounding."""
    sim = Simulator(SHORT, Motor(1.0), solver=SolverOptions(method="bdf", frame="lab"))
    m = sim.model
    at = _trajectory(sim, omega=60.0, tilt=25.0)
    order, h, tn, tc = 4, 2e-4, 0.0105, 0.01
    m.set_charts(*_charts_near(m.frames(sim.y).tangents, seed=5))  # old charts: poles ≲ 60° off
    old = m.charts()
    times = tn - h * np.arange(order + 2)

    def written(s, charts, frame_turn):
        pos, u0, e1 = at(s)
        r = _rz(-frame_turn)
        return _state(pos @ r.T, r @ u0, e1 @ r.T, charts)

    # old coordinates: the frame turning at Ω (angle Ω s); new: at Ω + Δ from t_c on
    omega = 30.0
    vals_old = np.array([written(s, old, omega * s) for s in times])
    for j in range(1, len(times)):  # the angles of one trajectory lie on one branch
        vals_old[j, 6::4] = _wrap_near(vals_old[j, 6::4], vals_old[j - 1, 6::4])
    st = B.BdfStepper(m, tc, sim.y)
    st._ist[B.I_STARTED], st._ist[B.I_ORDER] = 1, order
    st._st[B.S_T], st._st[B.S_H] = tn, h
    P = B._difference_matrix(order + 2)
    st._D[:order + 2] = P @ vals_old
    # re-centre every chart at the tangents at t_c (old coordinates, the kernels' transport)
    y_c = written(tc, old, omega * tc)
    fr = m.frames(y_c)
    m.set_charts(fr.tangents, fr.reference)
    new = m.charts()
    st.carry(tc, y_c, lambda s, ys: m.change_coordinates(ys, old, -d_omega * (s - tc)))
    vals_new = np.array([written(s, new, omega * s + d_omega * (s - tc)) for s in times])
    vals_new[:, 6::4] = _wrap_near(vals_new[:, 6::4], vals_old[:, 6::4])
    assert np.max(np.abs(vals_new - vals_old)[:, 6::4]) > 1e-3  # the charts did change θ
    assert np.allclose(st._D[:order + 2], P @ vals_new, rtol=0, atol=1e-11)


#: M = 1 pN·µm, doubled over 10–12 ms: the co-rotating frame's rate follows
MOTOR = Motor(1.0, schedule=((0.0, 1.0), (0.01, 1.0), (0.012, 2.0)))


def _final(carry, method="bdf", frame="lab", t_end=0.025, limit=0.9):
    S.CARRY_HISTORY = carry
    old_limit, S.CHART_LIMIT = S.CHART_LIMIT, limit
    try:
        sim = Simulator(SHORT, MOTOR, solver=SolverOptions(method=method, frame=frame, rtol=1e-8))
        omega0 = sim.model.omega_frame
        made = []
        make = sim._stepper
        sim._stepper = lambda: made.append(make()) or made[-1]
        sim.run(t_end, save_every=t_end / 50, progress=False)
        assert frame == "lab" or sim.model.omega_frame != omega0  # the frame did change
        return sim.lab_state().y, made[-1]
    finally:
        S.CARRY_HISTORY, S.CHART_LIMIT = True, old_limit


@pytest.mark.parametrize("frame", ["lab", "auto"])
def test_carried_run_follows_the_restarted_run_and_cvode(frame):
    """From rest, M = 1 → 2 pN·µm, charts re-centred at 25° (t·u < 0.9, so they change every
    few steps) and, co-rotating, the frame's rate adapted: with the history carried through
    every change the final lab-frame positions agree with the run that restarts there and
    with CVODE (rtol 1e-8 each) to 1e-5 µm (the filament moves by > 0.01 µm)."""
    y_carry, st_carry = _final(True, frame=frame)
    y_reset, st_reset = _final(False, frame=frame)
    y_cvode, _ = _final(False, method="cvode", frame=frame)
    pos = lambda y: y[3:].reshape(-1, 4)[:, :3]
    assert np.max(np.abs(pos(y_carry) - pos(y_reset))) < 1e-5
    assert np.max(np.abs(pos(y_carry) - pos(y_cvode))) < 1e-5
    start = Simulator(SHORT, MOTOR, solver=SolverOptions(method="bdf")).lab_state().y
    assert np.max(np.abs(pos(y_carry) - pos(start))) > 1e-2
    assert st_carry.stats["jacobians_at_start"] == 1  # never restarted
    assert st_reset.stats["jacobians_at_start"] > (5 if frame == "lab" else 1)


def test_not_started_or_frozen_stepper_restarts_instead():
    sim = Simulator(SHORT, Motor(1.0), solver=SolverOptions(method="bdf", frame="lab"))
    st = B.BdfStepper(sim.model, 0.0, sim.y)
    assert not st.carry(0.0, sim.y, lambda s, ys: ys)  # nothing to carry yet
    st.advance(1e-4)
    assert st.carry(st.t, st.y, lambda s, ys: ys)
    assert st.stats["jacobians_at_start"] == 1
