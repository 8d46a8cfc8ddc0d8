"""Regime detector (paper Sec. 3.1, Figs. 3–4) on constructed time series: the four regimes
and the cases at the edges of each criterion (milliseconds), and two short thermal runs."""

import math

import numpy as np
import pytest

from flagellum.analysis.regimes import (SIGMA_BUCKLED, SIGMA_IV, SWING, classify, count_swings,
                                        decide, measure)

R = 0.2  # helix radius [µm] (paper's filament: R ≈ 0.2, L0 ≈ 8.4)
L0 = 8.4
SIGMA0 = R / math.sqrt(2)
N = 50
T = np.linspace(0.0, 0.3, 601)


def rotating_helix(t, omega=800.0, turns=4, axis_tilt=0.0):
    """Rigid helix (axis along −e_z, integer turns: centroid on the axis) spinning about its axis."""
    s = np.linspace(0.0, 1.0, N + 1)
    phase = 2 * np.pi * turns * s[None, :] + omega * t[:, None]
    pos = np.stack([R * np.cos(phase), R * np.sin(phase), -L0 * s[None, :] + 0 * phase], axis=-1)
    if axis_tilt:
        c, si = math.cos(axis_tilt), math.sin(axis_tilt)
        pos = pos @ np.array([[c, 0, si], [0, 1, 0], [-si, 0, c]]).T
    return pos


def bent(t, r, bulge, direction=None):
    """Beads on a bow from the anchor to a tip at distance r(t) along ``direction`` (default
    −e_z), bulging sideways by ``bulge(t)`` (xy vectors): sets r(t), centroid and tilt."""
    s = np.linspace(0.0, 1.0, N + 1)[None, :, None]
    d = np.array([0.0, 0.0, -1.0]) if direction is None else np.asarray(direction, float)
    d = np.broadcast_to(d / np.linalg.norm(d, axis=-1, keepdims=True), (len(t), 3))
    tip = (np.asarray(r)[:, None] * d)[:, None, :]
    side = np.zeros((len(t), 1, 3))
    side[:, 0, :2] = bulge
    return s * tip + np.sin(np.pi * s) * side


def precessing(t, amp, chi=60.0):
    return amp * np.stack([np.cos(chi * t), np.sin(chi * t)], axis=1)


def sawtooth_collapse(t, period=0.06, r_hi=6.7, r_lo=4.5):
    """Regime (iv) at M = 4.5: r relaxes slowly up, collapses fast (shape of the measured r(t))."""
    ph = (t / period) % 1.0
    return np.where(ph < 0.8, r_lo + (r_hi - r_lo) * ph / 0.8, r_hi - (r_hi - r_lo) * (ph - 0.8) / 0.2)


def regime(thrust, pos, t=T, t_from=None):
    return classify(t, np.broadcast_to(thrust, t.shape), pos, R, L0, t_from)


# -- the four regimes ---------------------------------------------------------------------
def test_aligned_rotating_helix():
    assert regime(1.0, rotating_helix(T)) == "aligned"


def test_reorienting_pulling_filament():
    assert regime(-0.4, rotating_helix(T)) == "reorienting"


def test_reorienting_turned_away_from_the_axis():
    """Regime (i) after the reorientation: perpendicular to the motor axis, thrust ≈ 0⁺."""
    assert regime(0.01, rotating_helix(T, axis_tilt=np.radians(80))) == "reorienting"


def test_buckled_constant_shape_tip_on_a_circle():
    """Regime (iii): a bent shape precessing (χ) while the free end circles with radius R
    (r = ⟨r⟩ + R cos ωt: σ = σ0 exactly, the largest σ of (iii)); thrust oscillating."""
    r = 4.5 + R * np.cos(800 * T)
    th = 0.8 + 0.3 * np.cos(800 * T)
    pos = bent(T, r, precessing(T, 0.5))
    m = measure(T, th, pos, R)
    assert abs(m.sigma_over_sigma0 - 1.0) < 0.01 and m.swings == 0 and m.centroid_offset > 1
    assert decide(m) == "buckled"


def test_oscillating_periodic_collapse():
    """Regime (iv): r collapses by ≈ 11 R and recovers with a period of 0.06 s, the thrust
    drops to ≈ 0 at each collapse (and briefly below)."""
    r = sawtooth_collapse(T)
    th = 1.3 + 1.6 * np.cos(2 * np.pi * T / 0.06)
    pos = bent(T, r, precessing(T, 0.2))
    m = measure(T, th, pos, R)
    assert m.sigma_over_sigma0 > 3 and m.swings >= 4 and m.thrust_mean > 0
    assert decide(m) == "oscillating"


# -- edges of the criteria ------------------------------------------------------------------
@pytest.mark.parametrize("amp,expected", [
    (0.75, "buckled"), (1.0, "buckled"), (1.4, "buckled"),  # transients / largest (iii): below σ_iv
    (1.6, "oscillating"), (3.0, "oscillating"),
])
def test_sigma_margin_for_a_swinging_tip(amp, expected):
    """σ/σ0 = amp for r = ⟨r⟩ + amp·R cos ωt: up to 1.5 (50 % above the paper's maximum of
    regime (iii)) it is buckled; beyond, r swings across ⟨r⟩ ± 1.5 R and it is (iv)."""
    r = 4.5 + amp * R * np.cos(2 * np.pi * T / 0.05)
    m = measure(T, np.ones(len(T)), bent(T, r, precessing(T, 0.5)), R)
    assert m.sigma_over_sigma0 == pytest.approx(amp, rel=0.02)
    assert decide(m) == expected


def test_one_way_drift_is_not_oscillating():
    """A run still buckling in its window: r falls from 8.4 to 4.5 µm (σ/σ0 ≈ 5) but never
    recovers, so it is not a periodic collapse."""
    r = np.linspace(8.4, 4.5, len(T))
    m = measure(T, np.ones(len(T)), bent(T, r, precessing(T, 0.4)), R)
    assert m.sigma_over_sigma0 > SIGMA_IV and m.swings <= 1
    assert decide(m) == "buckled"


def test_single_collapse_and_recovery_is_enough():
    """One collapse and one recovery in the window (long periods near M_c2) count as (iv)."""
    r = 5.5 - 1.0 * np.sin(np.pi * (T - T[0]) / (T[-1] - T[0])) ** 8
    m = measure(T, np.ones(len(T)), bent(T, r, precessing(T, 0.4)), R, t_from=0.0)
    assert m.swings == 2 and m.sigma_over_sigma0 > SIGMA_IV
    assert decide(m) == "oscillating"


def test_negative_thrust_dips_of_regime_iv_are_not_reorienting():
    r = sawtooth_collapse(T)
    th = 0.5 + 1.6 * np.cos(2 * np.pi * T / 0.06)  # below zero for part of each cycle
    assert regime(th, bent(T, r, precessing(T, 0.2))) == "oscillating"


def test_thermal_like_aligned_fluctuations_stay_aligned():
    """σ/σ0 ≈ 0.18 from compressional fluctuations (paper Sec. 3.1.2) is not buckling."""
    rng = np.random.default_rng(1)
    r = L0 + 0.18 * SIGMA0 * rng.standard_normal(len(T))
    m = measure(T, np.ones(len(T)), bent(T, r, np.zeros((len(T), 2))), R)
    assert 0.15 < m.sigma_over_sigma0 < SIGMA_BUCKLED
    assert decide(m) == "aligned"


@pytest.mark.parametrize("offset,thrust_osc,expected", [
    (0.2, 0.0, "aligned"), (0.3, 0.0, "buckled"),  # centroid offset [R] at the 0.25 R threshold
    (0.0, 0.04, "aligned"), (0.0, 0.08, "buckled"),  # thrust std / mean at the 5 % threshold
])
def test_buckled_onset_detection_limits(offset, thrust_osc, expected):
    s = np.linspace(0, 1, N + 1)
    bulge = precessing(T, offset * R / np.mean(np.sin(np.pi * s)))
    th = 1.0 + thrust_osc * math.sqrt(2) * np.cos(800 * T)
    assert regime(th, bent(T, np.full(len(T), L0), bulge)) == expected


def test_window_default_is_the_last_half():
    """Aligned in the first half, collapsing in the second: the default window sees (iv)."""
    r = np.where(T < 0.15, L0, sawtooth_collapse(T))
    pos = bent(T, r, np.zeros((len(T), 2)))
    assert regime(1.0, pos) == "oscillating"
    first = T <= 0.14
    assert classify(T[first], np.ones(first.sum()), pos[first], R) == "aligned"


def test_count_swings():
    band = SWING * R
    assert count_swings(np.array([0.0, 1.0, 0.0, 1.0]), 0.3) == 3
    assert count_swings(np.array([0.0, 0.5, 1.0]), 0.3) == 1
    assert count_swings(np.full(10, 4.0), band) == 0
    assert count_swings(np.array([4.0]), band) == 0
    assert count_swings(4.0 + R * np.cos(np.linspace(0, 20, 400)), band) == 0


@pytest.mark.parametrize("torque,expected", [(0.5, "aligned"), (2.0, "buckled")])
def test_thermal_runs_are_classified_by_their_shape(torque, expected):
    """At room temperature (kT = 4.1e-3 pN·µm) the thrust of an aligned filament fluctuates by
    about twice its mean and its axis tilts by several degrees: that is not buckling. Below
    M_c1 = 1.066 pN·µm (linear stability, Sec. 3.2) the filament is aligned, above it buckled
    (Fig. 3(a)); the deterministic criteria called both thermal runs buckled."""
    from flagellum import Params
    from flagellum.motor import Motor
    from flagellum.simulator import Simulator

    tr = Simulator(Params.from_flat({"kT": 4.1e-3}), Motor(torque), thermal=True, seed=1).run(
        0.3, save_every=1e-3, progress=False)
    assert tr.kT == 4.1e-3
    s = tr.summary()
    assert s.regime == expected, s.regime_note
    m = measure(tr.t, tr.thrust, tr.positions, tr.meta["helix_radius"])  # as if deterministic
    assert decide(m) == "buckled"


def test_thermal_threshold_scales_with_the_noise_amplitude():
    """σ/σ0 of thermal fluctuations grows as √kT (equipartition); without noise the
    deterministic threshold applies."""
    from flagellum.analysis.regimes import KT_ROOM, SIGMA_THERMAL, sigma_buckled

    assert sigma_buckled(0.0) == SIGMA_BUCKLED
    assert sigma_buckled(KT_ROOM) == SIGMA_THERMAL
    assert sigma_buckled(4 * KT_ROOM) == pytest.approx(2 * SIGMA_THERMAL)
    assert sigma_buckled(1e-9) == SIGMA_BUCKLED


# -- free swimmers and runs without a motor torque -----------------------------------------
def wobbling_cell(t, wobble=np.radians(6.0), path_radius=0.3, omega=800.0, spin=60.0):
    """A rigid helix (constant shape: σ = 0 exactly) whose base circles the swimming axis on
    a radius ``path_radius`` while its axis wobbles by ``wobble`` about it and the whole cell
    swims along e_z: the rigid motion of a free cell (docs/motor.md, "Whole cell")."""
    pos = rotating_helix(t, omega)
    c, s = math.cos(wobble), math.sin(wobble)
    tilt = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    out = np.empty_like(pos)
    axes = np.empty((len(t), 3))
    for k, tk in enumerate(t):
        cz, sz = math.cos(spin * tk), math.sin(spin * tk)
        turn = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]) @ tilt
        base = np.array([path_radius * cz, path_radius * sz, 20.0 * tk])
        out[k] = pos[k] @ turn.T + base
        axes[k] = turn[:, 2]
    return out, axes


def test_wobbling_free_cell_is_aligned():
    """A free cell's base circles the axis and its thrust along e_z oscillates with the
    wobble while the shape stays constant: aligned when classified as a free swimmer. The
    anchored criteria (centroid on the lab's axis, steady thrust) call it buckled."""
    pos, axes = wobbling_cell(T)
    thrust = 0.3 * (1 + 0.1 * np.cos(60.0 * T))
    assert classify(T, thrust, pos, R, L0) == "buckled"
    m = measure(T, thrust, pos, R, free=True, motor_axis=axes)
    assert m.sigma_over_sigma0 < 1e-9 and m.tilt_deg < 1.0
    assert decide(m) == "aligned"
    assert classify(T, thrust, pos, R, L0, free=True) == "aligned"


def test_free_cell_buckles_by_its_shape():
    """A bent shape whose free end circles (σ/σ0 ≈ 1, as in regime (iii)) is buckled also
    for a free swimmer; a cell whose filament turned 80° away from its motor axis is
    reorienting (the tilt from the motor axis m(t), not from e_z)."""
    r = L0 - R + R * np.cos(300.0 * T)
    pos = bent(T, r, precessing(T, 0.5))
    assert classify(T, np.full(T.shape, 0.8), pos, R, L0, free=True) == "buckled"
    turned = rotating_helix(T, axis_tilt=np.radians(80))
    along, thrust = np.broadcast_to([0.0, 0.0, 1.0], (len(T), 3)), np.full(T.shape, 0.05)
    assert classify(T, thrust, turned, R, L0, free=True, motor_axis=along) == "reorienting"
    c, s = math.cos(np.radians(80)), math.sin(np.radians(80))
    with_body = np.broadcast_to([s, 0.0, c], (len(T), 3))  # the body turned with it
    assert classify(T, thrust, turned, R, L0, free=True, motor_axis=with_body) == "aligned"


def test_end_load_without_torque_is_aligned():
    """An end load at M = 0 stretches the filament, which the anchor holds: the anchor force
    is −F (the filament pulls on it) although the motor pushes nothing, and the helix at rest
    has its centroid 0.34 R off the axis without bending. The motor's thrust (anchor force +
    load) and M = 0 say: aligned, not reorienting (or buckled)."""
    from flagellum import Filament, Params
    from flagellum.motor import Motor
    from flagellum.params import EndLoad
    from flagellum.simulator import Simulator

    tr = Simulator(Params(Filament(length=2.0)), Motor(0.0), end_load=EndLoad(force=0.3)).run(
        0.01, save_every=2e-4, progress=False)
    assert tr.thrust.mean() == pytest.approx(-0.3, rel=0.05)
    assert classify(tr.t, tr.thrust, tr.positions, R, L0) == "reorienting"  # anchored criteria
    assert tr.summary().regime in ("aligned", "transient")
    from flagellum.analysis.regimes import assess, run_frame
    a = assess(tr.t, tr.thrust, tr.positions, tr.motor_angle, R, **run_frame(tr))
    assert a.window_regime == "aligned"
