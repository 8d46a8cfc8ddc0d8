"""Motor drives (docs/motor.md): speed clamp, torque–speed law, reversals; the torque of a
clamp or a law solved exactly from the hook balance Eq. (12) inside the kernel."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import assert_one_line_error
from flagellum.errors import ParameterError, SimulationError
from flagellum.hydro.rft import pinned_omega_per_torque
from flagellum.motor import Boundary, Motor, MotorLaw
from flagellum.params import Params
from flagellum.rod import kernels as K
from flagellum.rod.model import RodModel
from flagellum.simulator import Simulator

SLOPED = MotorLaw.e_coli(stall_torque=1.0, knee_speed=2 * math.pi * 50, zero_load_speed=2 * math.pi * 200)


def _state(model, rng):
    y = model.initial_state()
    y[3:] += rng.normal(0, 0.01, len(y) - 3)
    y[:3] += rng.normal(0, 0.1, 3)
    return y


# -- laws and motors ----------------------------------------------------------------------

def test_e_coli_law_defaults():
    law = MotorLaw.e_coli()
    assert law.stall_torque == 1.3
    assert law.speeds == (0.0, 2 * math.pi * 170, 2 * math.pi * 300)
    assert law(2 * math.pi * 100) == 1.3 and law(2 * math.pi * 400) == 0.0
    assert law(2 * math.pi * 235) == pytest.approx(0.65)


@pytest.mark.parametrize("speeds, torques", [
    ((0.0,), (1.0,)), ((0.0, 1.0), (1.0, 2.0)), ((1.0, 0.5), (1.0, 0.0)), ((-1.0, 1.0), (1.0, 0.0)),
    ((0.0, 1.0), (0.0, 0.0)), ((0.0, 1.0), (1.0, 1.0)), ((0.0, 1.0), (1.0, -0.5)), ((0.0, 1.0, 2.0), (1.0, 0.0)),
])
def test_bad_laws_are_rejected(speeds, torques):
    with pytest.raises(ParameterError, match="law"):
        MotorLaw(speeds, torques)


def test_law_tables_from_files(tmp_path):
    csv = tmp_path / "law.csv"
    csv.write_text("# measured\nspeed,torque\n0, 1.2\n1000, 1.1\n2000, 0\n")
    toml = tmp_path / "law.toml"
    toml.write_text("speeds = [0.0, 1000.0, 2000.0]\ntorques = [1.2, 1.1, 0.0]\n")
    assert MotorLaw.from_file(csv) == MotorLaw.from_file(toml) == MotorLaw((0, 1000, 2000), (1.2, 1.1, 0))
    bad = tmp_path / "bad.csv"
    bad.write_text("0 1 2\n")
    with pytest.raises(ParameterError, match="motor_law"):
        MotorLaw.from_file(bad)


def test_operating_point_on_a_load_line():
    for b in (100.0, 800.0, 5000.0):
        m, w = SLOPED.operating_point(b)
        assert w == pytest.approx(m * b) and m == pytest.approx(float(SLOPED(w)), abs=1e-12)
        assert m == pytest.approx(brentq(lambda x: x - SLOPED(x * b), 0.0, 2.0), abs=1e-12)


@pytest.mark.parametrize("kw, name", [
    (dict(drive="speed"), "speed"), (dict(drive="law"), "law"), (dict(law=SLOPED), "law"),
    (dict(drive="fast"), "drive"), (dict(reversals=(1.0, 0.5)), "reversals"),
    (dict(reversal_rates=(1.0,)), "reversal_rates"), (dict(reversal_rates=(1.0, 0.0)), "reversal_rates"),
    (dict(reversals=(1.0,), reversal_rates=(1.0, 1.0)), "reversals"),
    (dict(drive="law", law=SLOPED, ramp_time=1.0), "ramp_time"),
    (dict(drive="speed", speed=1.0, schedule=((0, 1),)), "schedule"), (dict(reversal_seed=-1), "reversal_seed"),
])
def test_bad_motors_are_rejected(kw, name):
    with pytest.raises(ParameterError, match=name):
        Motor(**kw)


def test_reversal_schedule_and_telegraph():
    m = Motor(0.5, reversals=(1.0, 2.0))
    assert [m(t) for t in (0.5, 1.5, 2.5)] == [0.5, -0.5, 0.5]
    assert Motor(drive="speed", speed=10.0, reversals=(1.0,))(1.5) == -10.0
    assert Motor(drive="law", law=SLOPED, reversals=(1.0,))(1.5) == -1.0
    a = Motor(1.0, reversal_rates=(2.0, 5.0), reversal_seed=7)
    b = Motor(1.0, reversal_rates=(2.0, 5.0), reversal_seed=7)
    long, short = a.switching_times(50.0), b.switching_times(10.0)
    assert long[:len(short)] == short and len(long) > len(short) > 10  # independent of t_end
    assert a.switching_times(10.0) == short
    assert Motor(1.0, reversal_rates=(2.0, 5.0), reversal_seed=8).switching_times(10.0) != short
    gaps = np.diff((0.0,) + long)  # mean dwell times 1/k of CCW and CW
    assert np.mean(gaps[0::2]) == pytest.approx(0.5, rel=0.3)
    assert np.mean(gaps[1::2]) == pytest.approx(0.2, rel=0.3)
    assert a(long[0] + 1e-9) == -1.0 and a(long[0] - 1e-9) == 1.0


# -- kernel -------------------------------------------------------------------------------

@pytest.mark.parametrize("boundary", [Boundary(), Boundary(anchor="free", sphere_radius=0.5),
                                      Boundary(hook="clamped"), Boundary(hook="elastic", hook_stiffness=1.0)])
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_kernel_solves_the_hook_balance_exactly(boundary, direction):
    rng = np.random.default_rng(3)
    p = Params()
    clamp = RodModel(p, Motor(drive="speed", speed=700.0 * direction), boundary, omega_frame=200.0)
    y = _state(clamp, rng)
    clamp.rhs(0.0, y)
    assert clamp.last_relative_motor_speed == pytest.approx(700.0 * direction, rel=1e-9)
    # the torque drive with the clamp's torque gives the same right-hand side
    const = RodModel(p, Motor(float(clamp.last_torque)), boundary, omega_frame=200.0)
    const.set_charts(*clamp.charts())
    np.testing.assert_allclose(const.rhs(0.0, y), clamp.rhs(0.0, y), rtol=1e-9, atol=1e-6)
    cw = MotorLaw((0.0, 300.0, 900.0), (0.7, 0.6, 0.0))
    law = RodModel(p, Motor(drive="law", law=SLOPED, cw_law=cw, reversals=(1.0,)), boundary,
                   omega_frame=200.0)
    law.set_charts(*clamp.charts())
    law.rhs(0.0 if direction > 0 else 2.0, y)
    w = law.last_relative_motor_speed
    branch = SLOPED if direction > 0 else cw  # the CW branch in its own sense
    assert direction * law.last_torque == pytest.approx(float(branch(direction * w)), abs=1e-9)
    assert clamp.body_rotation_per_torque == (
        1 / (8 * math.pi * p.fluid.viscosity * 0.5 ** 3) if boundary.anchor == "free" else 0.0)


def test_no_operating_point_is_a_simulation_error():
    m = RodModel(Params(), Motor(drive="speed", speed=100.0), Boundary(hook="clamped"))
    y = m.initial_state()
    y[:3] = (1.0, 0.0, 0.0)  # a clamped hook across the motor axis cannot turn about it
    m.set_charts(np.tile([1.0, 0.0, 0.0], (m.n + 1, 1)), np.tile([0.0, 1.0, 0.0], (m.n + 1, 1)))
    with pytest.raises(SimulationError, match="no operating point"):
        m.rhs(0.0, y)


def test_thermal_runs_take_the_torque_drive():
    with pytest.raises(ParameterError, match="drive"):
        Simulator(Params(), Motor(drive="speed", speed=100.0), thermal=True, solver=None)


# -- validation by simulation ---------------------------------------------------------------

def _run(motor, t_end=0.03, boundary=None):
    tr = Simulator(Params(), motor, boundary or Boundary()).run(t_end, save_every=t_end / 60)
    return tr.summary()


def test_speed_clamp_needs_the_torque_of_the_constant_torque_run():
    for m0 in (0.5, -0.5):
        const = _run(Motor(m0))
        clamp = _run(Motor(drive="speed", speed=const.motor_speed_mean))
        assert clamp.motor_speed_mean == pytest.approx(const.motor_speed_mean, rel=1e-6)
        assert clamp.torque_mean == pytest.approx(m0, rel=2e-3)
        assert clamp.thrust_mean == pytest.approx(const.thrust_mean, rel=5e-3)


def test_law_operating_point_lies_on_the_law_and_the_load_line():
    (m1, w1), (m2, w2) = [(s.torque_mean, s.motor_speed_mean) for s in (_run(Motor(0.4)), _run(Motor(0.8)))]
    slope = (w2 - w1) / (m2 - m1)
    load = lambda m: w1 + slope * (m - m1)  # noqa: E731
    m_star = brentq(lambda m: m - SLOPED(load(m)), 0.0, 1.0)
    s = _run(Motor(drive="law", law=SLOPED))
    assert s.torque_mean == pytest.approx(float(SLOPED(s.motor_speed_mean)), abs=1e-9)
    assert s.torque_mean == pytest.approx(m_star, rel=3e-3)
    assert s.motor_speed_mean == pytest.approx(load(m_star), rel=3e-3)
    assert s.torque_mean == pytest.approx(SLOPED.operating_point(pinned_omega_per_torque(Params()))[0], rel=0.1)


def test_reversal_flips_the_thrust():
    sim = Simulator(Params(), Motor(0.5, reversals=(0.03,)), Boundary())
    tr = sim.run(0.06, save_every=0.001)
    before, after = (tr.t > 0.015) & (tr.t < 0.03), tr.t > 0.045
    f_before, f_after = tr.thrust[before].mean(), tr.thrust[after].mean()
    assert f_before > 0.2 and f_after < -0.2
    assert set(tr.torque[before]) == {0.5} and set(tr.torque[after]) == {-0.5}
    assert f_after == pytest.approx(-f_before, rel=0.15)  # pulling: the free hook tilts a little


def test_spec_and_restart_keep_the_drive():
    motor = Motor(drive="law", law=SLOPED, cw_law=MotorLaw((0.0, 500.0), (0.8, 0.0)),
                  reversal_rates=(200.0, 300.0), reversal_seed=3)
    sim = Simulator(Params(), motor, Boundary())
    again = Simulator.from_spec(json.loads(json.dumps(sim.spec())))
    assert again.motor == motor
    assert again.motor.switching_times(0.1) == motor.switching_times(0.1)
    whole = Simulator(Params(), motor, Boundary()).run(0.02, save_every=0.001)
    split = Simulator(Params(), motor, Boundary())
    split.run(0.01, save_every=0.001)
    second = split.run(0.02, save_every=0.001)  # the same reversals after a restart
    assert np.sign(second.torque[-1]) == np.sign(whole.torque[-1]) == motor.direction(0.02)
    np.testing.assert_allclose(second.torque[-1], whole.torque[-1], rtol=1e-3)


def test_free_swimmer_law_sees_the_speed_relative_to_the_body():
    s = _run(Motor(drive="law", law=SLOPED), boundary=Boundary(anchor="free", sphere_radius=0.5))
    assert s.torque_mean == pytest.approx(float(SLOPED(s.motor_speed_mean)), abs=1e-9)


# -- command line ---------------------------------------------------------------------------

@pytest.mark.parametrize("args, name", [
    (("--torque", "1", "--motor-speed", "100"), "drive"), (("--motor-speed", "1", "--motor-law", "e-coli"), "drive"),
    (("--motor-speed", "0"), "speed"), (("--motor-law", "missing.csv"), "motor_law"),
    (("--reversal-rates", "1"), "reversal_rates"), (("--reversal-times", "a,b"), "reversal_times"),
    (("--reversal-times", "1", "--reversal-rates", "1,1"), "reversals"),
    (("--motor-law", "e-coli", "--ramp-time", "0.1"), "ramp_time"),
    (("--motor-speed", "100", "--thermal"), "drive"),
])
def test_cli_bad_motor_flags(cli, args, name):
    code, _, err = cli("simulate", "--t-end", "0.001", *args)
    assert_one_line_error(code, err, name)


def test_cli_drives(cli):
    import json

    code, out, _ = cli("simulate", "--t-end", "0.01", "--json", "--motor-law", "e-coli")
    d = json.loads(out)
    assert code == 0 and d["torque_mean"] == pytest.approx(float(MotorLaw.e_coli()(d["motor_speed_mean"])), abs=1e-9)
    code, out, _ = cli("simulate", "--t-end", "0.01", "--json", "--motor-speed", "300")
    assert code == 0 and json.loads(out)["motor_speed_mean"] == pytest.approx(300.0, rel=1e-6)
