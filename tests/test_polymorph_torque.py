"""Torque-driven transformations (docs/polymorphism.md): the event measurement against the
Nagumo front, nucleation near the hook under a reversed motor and the reversion at forward
torque, the threshold search and its bad input."""

import math

import numpy as np
import pytest

from flagellum import Filament, Params
from flagellum.analysis.polymorph import torque_thresholds
from flagellum.errors import ParameterError
from flagellum.motor import Motor
from flagellum.params import Polymorphism
from flagellum.rod import polymorph as PM
from flagellum.simulator import Simulator

from conftest import assert_one_line_error

SHORT = Params(Filament(length=4.0))
#: the default landscape (docs/polymorphism.md: barrier fitted to Hotani's −1.1 pN·µm)
TWO = Polymorphism(forms=("normal", "semicoiled"))
#: a landscape in which the semicoiled domain runs the whole filament (semicoiled 3 pN
#: below normal at zero stress; barrier 1 pN, wall width 0.5 µm): docs/polymorphism.md
RUNNING = Polymorphism(forms=("normal", "semicoiled"), barrier=1.0, energies=(0.0, -3.0),
                       wall_stiffness=8.0)


@pytest.mark.parametrize("start, fronts", [("end", 1), ("inside", 2)])
def test_events_measure_the_wall_speed_of_the_nagumo_front(start, fronts):
    """The order parameter alone (rod decoupled), form 0 higher by 0.3 pN: a domain of form
    1 grows at the closed-form Nagumo speed c = √(Dk/2)(1 − 2a)/ζ per front (one front for a
    domain at the end, two inside); transformation_events recovers c to 2 % and the
    nucleation site."""
    n, h, barrier, zeta = 800, 0.05, 1.0, 0.1  # 40 µm: the fronts stay far from the ends
    k = 64 * barrier
    D = 0.5 * k  # wall width 1 µm ≫ h
    x = h * np.arange(n)
    w = PM.wall_width(barrier, D)
    if start == "end":
        phi = 1.0 / (1.0 + np.exp((x - 5.0) / w))
    else:
        phi = 1.0 / (1.0 + np.exp((x - 25.0) / w)) - 1.0 / (1.0 + np.exp((x - 15.0) / w))
    eps = np.array([0.0, -0.3])
    sub = PM.stable_substep(h, k, D, zeta, np.zeros(2), np.zeros(2), 0.0, 0.0)
    args = (h, eps, np.full(1, k), D, zeta, 0.0, 0.0, np.zeros((n, 3)), np.zeros(2), np.zeros(2), False,
            0.0, np.zeros((1, 1)))
    PM.advance(phi, 0.05, math.ceil(0.05 / sub), *args)  # settle the profile
    phi0 = phi.copy()
    ts, rec = [0.0], [phi.copy()]
    dt = 0.01
    for i in range(10):
        PM.advance(phi, dt, math.ceil(dt / sub), *args)
        ts.append((i + 1) * dt)
        rec.append(phi.copy())
    ev = PM.transformation_events(np.array(ts), np.array(rec), h)
    c = -PM.front_speed(barrier, D, zeta, -0.3)  # front_speed counts into form 1: sign flip
    assert ev["wall_speed"] == pytest.approx(c, rel=0.02)
    # the first joint to change lies ahead of a front of the starting domain, within the
    # front's travel over one record interval (c dt) and a joint
    front = x[np.nonzero(np.diff(np.rint(phi0)))[0]] + h
    assert np.min(np.abs(front - ev["nucleation_site"])) <= c * dt + h
    assert ev["transformed_final"] > 0


def test_reversed_torque_nucleates_near_the_hook_and_forward_torque_reverts():
    """A normal filament (default landscape) stays normal at M = −0.8 pN·µm (above the
    threshold −1.1 pN·µm of Hotani 1982 that the barrier is fitted to) and forms a semicoiled
    domain at M = −1.3 pN·µm within the first µm from the hook (the motor's stress is
    largest there); the motor reversed to +1.3 pN·µm returns it to normal."""
    below = Simulator(SHORT, Motor(-0.8), polymorphism=TWO).run(0.05, save_every=5e-3,
                                                                  progress=False)
    assert np.all(PM.forms_of(below.polymorph) == 0)
    sim = Simulator(SHORT, Motor(-1.3, reversals=(0.05,)), polymorphism=TWO)
    tr = sim.run(0.1, save_every=2.5e-3, progress=False)
    half = tr.t <= 0.05
    s = tr.polymorph_summary()
    assert np.any(PM.forms_of(tr.polymorph[half]) == 1)
    assert s["nucleation_site"] <= 1.0
    assert s["nucleation_time"] < 0.05
    assert np.all(PM.forms_of(tr.polymorph[-1]) == 0)  # back to normal
    assert s["domain_walls_final"] == 0


def test_a_domain_from_the_hook_runs_the_filament_slower_than_the_nagumo_front():
    """Landscape RUNNING at M = −1.1 pN·µm: the domain nucleates within the first µm and the
    whole filament turns semicoiled. Energy balance: the landscape's energy difference is
    dissipated by the order parameter's friction ζ (the Nagumo front alone, speed c) and by
    the drag on the filament that the wall reshapes, so the wall is slower than c but of
    its order (measured 64 µm/s against c = 90 µm/s with the forms of
    params.POLYMORPHIC_FORMS; regression value)."""
    from flagellum.analysis.polymorph import transformation_run

    r = transformation_run(SHORT, RUNNING, -1.1, "normal", 0.15, save_every=3e-3)
    c = -PM.front_speed(1.0, 8.0, 0.1, -3.0)
    assert r["transformed_final"] == 1.0 and r["nucleation_site"] <= 1.0
    assert 0.3 * c < r["wall_speed"] < c
    assert r["wall_speed"] == pytest.approx(63.8, rel=0.1)  # regression value of this code


@pytest.mark.slow
@pytest.mark.ci
def test_thresholds_bracket_hotanis_torques_with_hysteresis():
    """torque_thresholds with the default landscape: normal → semicoiled near −1.1 pN·µm
    (Hotani 1982; the barrier is fitted to it: −1.08 at tol 0.05) and back near +0.4
    (Hotani; this model: +0.56, not fitted), a hysteresis > 1 pN·µm, nucleation within the
    first µm. Coarse bisection (tol 0.15) to stay short."""
    r = torque_thresholds(SHORT, TWO, bracket_down=(-0.8, -1.4), bracket_up=(0.3, 0.9),
                          tol=0.15, t_run=0.05)
    assert -1.25 < r.threshold_down < -0.95
    assert 0.35 < r.threshold_up < 0.75
    assert r.hysteresis > 1.0
    assert r.nucleation_site_down <= 1.0 and r.nucleation_site_up <= 1.0
    assert {x["direction"] for x in r.runs} == {"down", "up"}


def test_bad_threshold_input_is_refused():
    with pytest.raises(ParameterError, match="bracket_down"):
        torque_thresholds(SHORT, TWO, bracket_down=(0.5, 1.0))
    with pytest.raises(ParameterError, match="bracket_up"):
        torque_thresholds(SHORT, TWO, bracket_down=(-0.2, -1.3), bracket_up=(1.0, 0.5),
                          t_run=0.01)
    with pytest.raises(ParameterError, match="polymorphic"):
        torque_thresholds(SHORT, Polymorphism(forms=("normal",)))
    with pytest.raises(ParameterError, match="min_fraction"):
        torque_thresholds(SHORT, TWO, min_fraction=0.0)


def test_cli_polymorph_thresholds(cli, monkeypatch):
    """The command passes its flags to torque_thresholds and prints its result; bad input is
    one line naming the flag."""
    import flagellum.analysis.polymorph as AP

    seen = {}

    def fake(params, pm, boundary, **kw):
        seen.update(kw, forms=pm.forms, barrier=pm.barrier, length=params.filament.length)
        return AP.TorqueThresholds(("normal", "semicoiled"), -1.1, 0.4, 1.5, 0.8, 0.6, 0.1,
                                   0.2, kw["t_run"])

    monkeypatch.setattr(AP, "torque_thresholds", fake)
    code, text, err = cli("polymorph-thresholds", "--length", 4, "--bracket-down", -0.5, -2,
                          "--time", 0.02, "--polymorph-barrier", 0.3, "--json")
    assert code == 0, err
    import json

    res = json.loads(text)
    assert res["hysteresis"] == 1.5 and res["forms"] == ["normal", "semicoiled"]
    assert seen["bracket_down"] == (-0.5, -2.0) and seen["t_run"] == 0.02
    assert seen["forms"] == ("normal", "semicoiled") and seen["barrier"] == 0.3
    assert seen["length"] == 4.0
    monkeypatch.undo()
    code, _, err = cli("polymorph-thresholds", "--bracket-up", 1, 0.5)
    assert_one_line_error(code, err, "bracket_up")
    code, _, err = cli("polymorph-thresholds", "--polymorph-initial", "normal")
    assert_one_line_error(code, err, "polymorph_initial")
