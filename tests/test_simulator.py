"""Simulator: physics checks against independent results (rigid-helix RFT, step halving)."""

import json
import math

import numpy as np
import pytest

import flagellum as fl
from flagellum import Filament, Params
from flagellum.errors import ParameterError, SimulationError
from flagellum.helix import discrete_helix
from flagellum.hydro import rft
from flagellum.motor import Boundary, Motor
from flagellum.simulator import Simulator, SolverOptions

SHORT = Params(Filament(length=4.0))


def _pinned_line(params):
    """Rigid-helix thrust/torque of the same discrete helix pinned at bead 0 (bead drag,
    bond spin and hook-frame friction as in the simulator)."""
    dh = discrete_helix(params.filament)
    gp, gn, gr = params.gammas
    m = rft.resistance_matrix(*rft.bead_nodes(dh), gp, gn, 0.0)
    h = params.filament.segment_length
    t = dh.tangents
    m[3:, 3:] += gr * h * np.einsum("ni,nj->ij", t, t)  # spin of bonds 1..N
    t0 = dh.frames[0][:, 2]
    m[3:, 3:] += gr * h * np.outer(t0, t0) + 0.5 * gn * h**3 * (np.eye(3) - np.outer(t0, t0))
    return rft.pinned_rotation(m, dh.axis_direction)


def test_small_torque_lies_on_pinned_rigid_helix_line():
    M = 0.01
    sim = Simulator(Params(), Motor(M), solver=SolverOptions(rtol=1e-8, atol=1e-10))
    s = sim.run(0.2, save_every=1e-3).summary()
    pin = _pinned_line(Params())
    assert s.thrust_mean / M == pytest.approx(pin.thrust_per_torque, rel=0.01)
    assert s.omega_mean / M == pytest.approx(pin.omega_per_torque, rel=0.01)
    # and clearly off the unpinned line −C∥/B∥ (≈ 1.02 /µm)
    assert s.thrust_mean / M < 0.85


def test_pushing_torque_winds_up_and_raises_thrust():
    sim = Simulator(Params(), Motor(1.0))
    s = sim.run(0.1, save_every=1e-3).summary()
    assert s.thrust_mean > 1.05 * _pinned_line(Params()).thrust_per_torque


def test_handedness_flips_thrust():
    """Mirror symmetry: a left-handed helix at +M is the mirror image of a right-handed one
    at −M (torque is axial, force polar), so F_left(M) = F_right(−M) exactly."""
    out = {}
    for hand, M in (("right", 0.3), ("left", 0.3), ("right", -0.3)):
        p = Params(Filament(length=4.0, handedness=hand))
        out[hand, M] = Simulator(p, Motor(M)).run(0.02, save_every=5e-4).summary().thrust_mean
    assert out["right", 0.3] > 0 > out["left", 0.3]
    assert out["left", 0.3] == pytest.approx(out["right", -0.3], rel=1e-4)


def test_cvode_and_implicit_agree_and_converge():
    res = {}
    for name, opt in (("cvode", SolverOptions(rtol=1e-7, atol=1e-9)),
                      ("impl", SolverOptions(method="implicit", dt=1e-5, theta=1.0)),
                      ("impl2", SolverOptions(method="implicit", dt=5e-6, theta=1.0))):
        res[name] = Simulator(SHORT, Motor(0.5), solver=opt).run(0.01, save_every=1e-3).thrust
    e1 = np.abs(res["impl"] - res["cvode"]).max()
    e2 = np.abs(res["impl2"] - res["cvode"]).max()
    assert e1 < 1e-3
    assert e2 < 0.7 * e1  # implicit Euler, first order: halving the step halves the error


def test_load_sphere_moves_with_stokes_drag():
    a = 1.0
    sim = Simulator(SHORT, Motor(0.5), Boundary(anchor="sphere", sphere_radius=a))
    tr = sim.run(0.02, save_every=1e-3)
    z0 = tr.positions[:, 0, 2]
    v = np.polyfit(tr.t[10:], z0[10:], 1)[0]
    drag = 6 * math.pi * 1e-3 * a
    assert v > 0  # pushed forward (+z)
    assert np.mean(tr.thrust[10:]) == pytest.approx(drag * v, rel=0.05)


def test_clamped_and_elastic_hook_run():
    for b in (Boundary(hook="clamped"), Boundary(hook="elastic", hook_stiffness=1.0)):
        s = Simulator(SHORT, Motor(0.3), b).run(0.005, save_every=1e-3).summary()
        assert s.thrust_mean > 0


def test_blow_up_is_reported_with_last_good_state(tmp_path):
    p = Params(Filament(length=4.0, stretch_modulus=1e-3))
    sim = Simulator(p, Motor(50.0), solver=SolverOptions(method="implicit", dt=1e-5))
    out = tmp_path / "run.h5"
    with pytest.raises(SimulationError, match="saved"):
        sim.run(0.05, save_every=1e-4, output=out)
    import h5py

    with h5py.File(out) as f:
        assert f.attrs["status"].startswith("failed")
        assert np.all(np.isfinite(f["final_state"][()]))


def test_output_file_is_self_describing(tmp_path):
    out = tmp_path / "r.h5"
    tr = Simulator(SHORT, Motor(0.2), seed=3).run(0.002, save_every=1e-3, output=out)
    from flagellum.io import read_trajectory

    d = read_trajectory(out)
    assert d["attrs"]["status"] == "complete"
    assert Params.from_dict(__import__("tomllib").loads(d["attrs"]["params_toml"])) == SHORT
    assert len(d["t"]) == len(tr.t) == 3


def test_bad_run_arguments():
    sim = Simulator(SHORT, Motor(0.2))
    with pytest.raises(ParameterError, match="save_every"):
        sim.run(0.01, save_every=-1)
    with pytest.raises(ParameterError, match="kT"):
        Simulator(Params(SHORT.filament, __import__("flagellum").Fluid(kT=0.0)), thermal=True)
    with pytest.raises(ParameterError, match="output"):
        sim.run(0.01, output="/proc/forbidden/run.h5")


def test_cli_simulate_json(tmp_path):
    from click.testing import CliRunner

    from flagellum.cli import main

    r = CliRunner().invoke(main, ["simulate", "--torque", "0.3", "--time", "0.004", "--length", "4",
                                  "--json", "--output", str(tmp_path / "x.h5")])
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    for k in ("thrust_mean", "thrust_std", "omega_mean", "chi_mean", "end_to_end_mean",
              "end_to_end_std", "energy_final", "steps", "wall_seconds"):
        assert k in d
    r2 = CliRunner().invoke(main, ["info", str(tmp_path / "x.h5"), "--json"])
    assert r2.exit_code == 0 and json.loads(r2.output)["records"] > 0


def test_motor_speed_survives_sparse_sampling():
    """Records several turns apart (ω Δt ≈ 17 rad) still give the motor speed."""
    dense = Simulator(SHORT, Motor(0.5)).run(0.2, save_every=2e-4).summary().omega_mean
    sparse = Simulator(SHORT, Motor(0.5)).run(0.2, save_every=1e-2).summary().omega_mean
    assert dense > 0
    assert sparse == pytest.approx(dense, rel=0.01)


def test_cvode_matches_explicit_rk4_reference():
    """Short window from rest: CVODE (tight) against explicit RK4 at Δt = 1e-9 s."""
    from flagellum.integrate.cvode import CvodeStepper
    from flagellum.integrate.explicit import rk4
    from flagellum.rod.model import RodModel

    p = Params(Filament(length=1.0))
    m = RodModel(p, Motor(0.3), omega_frame=0.0)
    y0 = m.initial_state()
    t_end = 2e-6
    y_rk = rk4(m.rhs, 0.0, y0, t_end, 1e-9)
    st = CvodeStepper(m, 0.0, y0, rtol=1e-10, atol=1e-12)
    y_cv = st.advance(t_end)
    assert np.abs(y_cv - y_rk).max() < 1e-7
    assert np.abs(y_rk - y0).max() > 1e-4  # something happened


def test_fixed_step_schemes_converge_at_their_order():
    """BDF2 (default fixed-step scheme) converges at second order, implicit Euler at first,
    against a tight CVODE reference of the ramp-up from rest."""
    T = 0.004

    def final(**kw):
        s = Simulator(Params(), Motor(1.0, ramp_time=0.002), solver=SolverOptions(**kw))
        return s.run(T, save_every=T).positions[-1]

    ref = final(rtol=1e-10, atol=1e-12)
    for scheme, order in (("bdf2", 2), ("theta", 1)):
        errs = [np.abs(final(method="implicit", dt=dt, scheme=scheme) - ref).max()
                for dt in (4e-5, 2e-5, 1e-5)]
        rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
        assert np.all(np.abs(rates - order) < 0.25), (scheme, errs)


@pytest.mark.slow
@pytest.mark.ci
def test_bdf2_keeps_the_buckling_mode_that_implicit_euler_damps():
    """At M = 1.6 pN·µm (λ ≈ +25 /s) implicit Euler at Δt = 5e-5 s in the co-rotating frame
    damps the buckling mode (numerical damping ν²Δt/2 ≈ 46 /s at ν ≈ 1360 rad/s) and stays
    aligned; BDF2 buckles like the error-controlled reference."""
    def thrust(**kw):
        s = Simulator(Params(), Motor(1.6), solver=SolverOptions(**kw))
        tr = s.run(0.4, save_every=0.4 / 60)
        return tr.summary(t_from=0.28).thrust_mean

    ref = thrust()
    assert ref < 1.1  # buckled (aligned thrust ≈ 1.57 pN)
    assert abs(thrust(method="implicit", dt=5e-5) - ref) < 0.05 * ref
    assert thrust(method="implicit", dt=5e-5, theta=1.0) > 1.4


def _free_swimmer(a: float, t_end: float = 0.1):
    sim = Simulator(Params(), Motor(1.0), Boundary(anchor="free", sphere_radius=a),
                    solver=SolverOptions(frame="lab", rtol=1e-9, atol=1e-11))
    tr = sim.run(t_end, save_every=t_end / 50)
    from flagellum.rod.model import positions

    pos = positions(sim.y)
    vel = sim.model.rhs(sim.t, sim.y)[3:].reshape(-1, 4)[:, :3]
    w = np.full(len(pos), 0.2)  # bead lengths: h, h/2 at the ends (paper Sec. 2.2)
    w[0] = w[-1] = 0.1
    e3 = np.diff(pos, axis=0)
    e3 /= np.linalg.norm(e3, axis=1)[:, None]
    tan = np.vstack([e3[:1], e3[:-1] + e3[1:], e3[-1:]])
    tan /= np.linalg.norm(tan, axis=1)[:, None]
    return tr, pos, vel, tan, w


def test_free_swimmer_is_force_free():
    """No anchor: the drag on the beads (w[γ∥tt + γ⊥(1 − tt)] v) and on the body (6πηa v0)
    add up to zero at every instant (the elastic forces are internal)."""
    gp, gn, _ = Params().gammas
    for a in (0.0, 0.5):
        tr, pos, vel, tan, w = _free_swimmer(a, 0.02)
        tt = tan[:, :, None] * tan[:, None, :]
        drag = np.einsum("nij,nj->ni", w[:, None, None] * (gp * tt + gn * (np.eye(3) - tt)), vel)
        total = drag.sum(axis=0) + 6 * math.pi * 1e-3 * a * vel[0]
        assert np.abs(total).max() < 1e-12 * np.abs(drag).max() * len(drag)


def test_free_swimmer_speed_matches_rigid_resistive_force_theory():
    """Swimming speed and rotation rate of the free swimmer (body a = 0.5 µm) against the
    force- and torque-free rigid-body RFT solution for its instantaneous shape (6×6
    resistance about bead 0 plus the body's 6πηa, motor torque M e_z on the filament)."""
    p = Params()
    tr, pos, vel, tan, w = _free_swimmer(0.5)
    R = rft.resistance_matrix(pos, tan, w, *p.gammas, origin=pos[0])
    R[:3, :3] += 6 * math.pi * p.fluid.viscosity * 0.5 * np.eye(3)
    U = np.linalg.solve(R, [0, 0, 0, 0, 0, 1.0])
    s = tr.summary()
    assert s.swimming_speed > 0  # pushed forward, body first (+z)
    assert vel[0, 2] == pytest.approx(U[2], rel=0.02)
    assert s.swimming_speed == pytest.approx(U[2], rel=0.03)
    assert s.omega_mean == pytest.approx(U[5], rel=0.03)


def test_free_swimmer_boundary_and_limits():
    b = Boundary(anchor="free")
    assert b.sphere_radius == 0.0 and b.sphere_drag(1e-3) == 0.0
    assert math.isnan(b.body_rotation_rate(1.0, 1e-3))
    b = Boundary(anchor="free", sphere_radius=1.0)
    assert b.body_rotation_rate(1.0, 1e-3) == pytest.approx(-1.0 / (8 * math.pi * 1e-3))
    with pytest.raises(ParameterError, match="sphere_radius"):
        Boundary(anchor="free", sphere_radius=-1.0)
    # the stability analysis takes the free swimmer (its translations quotiented out,
    # tests/test_stability_drive.py): a pushing motor makes the body swim forward
    from flagellum.analysis.stability import relative_equilibrium
    assert relative_equilibrium(Params(Filament(segment_length=0.4)), 1.0, b).velocity > 0


def test_motor_angle_follows_the_motor_speed_when_buckled():
    """The unwrapped hook angle (used for ω of thermal runs and their co-rotating frame)
    stays consistent with the instantaneous motor speed ω·e_z in the buckled state, where
    the hook tilts by β ≈ 45°: the twist about z runs at the hook's spin s, and
    ω·e_z ≈ s cos β + O(χ), so s cos β ≤ ω·e_z ≤ s. (The twist was once taken from a
    swing–twist split that is singular at the hook's rest orientation along −e_z; it gave
    3884 rad/s here, and aliased by one turn per record in thermal runs.)"""
    tr = Simulator(Params(), Motor(1.6)).run(0.3, save_every=1e-3)
    sel = tr.t > 0.15
    slope = np.polyfit(tr.t[sel], tr.motor_angle[sel], 1)[0]
    cos_beta = -tr.hook_tangent[sel][:, 2].mean()
    assert tr.summary().centroid_offset > 0.3 and cos_beta < 0.9  # buckled, hook tilted
    assert slope * cos_beta <= tr.motor_speed[sel].mean() <= slope
    assert tr.summary(t_from=0.1505).omega_mean == pytest.approx(slope, rel=0.02)  # paper's ω
    th = Simulator(Params(), Motor(3.0), thermal=True, seed=2).run(0.05, save_every=0.05 / 300)
    rigid = 3.0 * 700.0  # ≈ ω/M of the pinned rigid helix × M
    assert 0.3 * rigid < th.summary(t_from=0.025).omega_mean < 2 * rigid


def test_fixed_step_runs_take_whole_steps():
    """The chart-check chunks of an implicit run are whole multiples of Δt, so every step
    has the requested size (a shortened step would also restart BDF2 with an Euler step)."""
    sim = Simulator(SHORT, Motor(1.0), solver=SolverOptions(method="implicit", dt=5e-5))
    sim.run(0.02, save_every=2e-3)
    assert sim.steps == 400


def test_cvode_failure_prints_nothing_on_stdout(capsys):
    """scikit-sundae prints CVODE's error messages with print(); they are caught, so that
    ``--json`` results on stdout stay parseable and stderr holds one line, and they become
    part of the SimulationError's message."""
    from flagellum.errors import SimulationError
    from flagellum.integrate.cvode import CvodeStepper
    from flagellum.rod.model import RodModel

    m = RodModel(SHORT, Motor(1.0))
    st = CvodeStepper(m, 0.0, m.initial_state(), 1e-6, 1e-8, max_num_steps=3)
    with pytest.raises(SimulationError, match="SUNDIALS: At t = .*mxstep steps taken"):
        st.advance(0.01)
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""


# -- public state access: from_state, state, lab_state ----------------------------------------
def test_lab_state_continues_a_co_rotating_run():
    """A fresh simulator (either frame) started from the lab-frame state of a co-rotating
    run continues where it stopped: same lab positions, thrust and energy."""
    p = Params.from_flat({"length": 2.0})
    sim = Simulator(p, Motor(1.0), solver=SolverOptions(frame="auto"))
    tr = sim.run(0.01, save_every=0.001, progress=False)
    assert sim.frame_angle != 0.0
    state = sim.lab_state()
    assert state.frame_angle == 0.0
    for frame in ("lab", "auto"):
        new = Simulator.from_state(state, p, Motor(1.0), solver=SolverOptions(frame=frame))
        assert new.t == 0.0 and new.frame_angle == 0.0
        t2 = new.run(0.001, save_every=0.001, progress=False)
        assert np.abs(t2.positions[0] - tr.positions[-1]).max() < 1e-12
        assert abs(t2.thrust[0] - tr.thrust[-1]) < 1e-9 and abs(t2.energy[0] - tr.energy[-1]) < 1e-12


def test_run_continued_from_lab_state_matches_the_uninterrupted_run():
    p = Params.from_flat({"length": 2.0})
    opts = SolverOptions(rtol=1e-10, atol=1e-12)
    whole = Simulator(p, Motor(1.0), solver=opts).run(0.02, save_every=0.001, progress=False)
    first = Simulator(p, Motor(1.0), solver=opts)
    first.run(0.01, save_every=0.001, progress=False)
    rest = Simulator.from_state(first.lab_state(), p, Motor(1.0), t=first.t, solver=opts)
    tail = rest.run(0.02, save_every=0.001, progress=False)
    assert np.allclose(tail.t, whole.t[10:], rtol=0, atol=1e-15)
    assert np.abs(tail.positions - whole.positions[10:]).max() < 1e-7
    assert np.abs(tail.thrust - whole.thrust[10:]).max() < 1e-7 * np.abs(whole.thrust).max()
    # the computational-frame state with its frame angle and rate continues the same way
    again = Simulator.from_state(first.state(), p, Motor(1.0), t=first.t,
                                 omega_frame=first.model.omega_frame, solver=opts)
    assert again.frame_angle == first.frame_angle
    assert np.abs(again.run(0.02, save_every=0.001, progress=False).positions
                  - whole.positions[10:]).max() < 1e-7


def test_from_state_relative_equilibrium_stays_put():
    """bench.steady_state: the relative equilibrium, started in its co-rotating frame at its
    rate, is a fixed point there (the state hardly moves, the thrust is steady)."""
    from flagellum.analysis.stability import relative_equilibrium
    from flagellum.simulator import State

    p = Params.from_flat({"length": 2.0})
    eq = relative_equilibrium(p, 0.5)
    sim = Simulator.from_state(State(eq.state, eq.charts), p, Motor(0.5), omega_frame=eq.omega)
    assert sim.model.omega_frame == eq.omega
    tr = sim.run(0.005, save_every=0.001, progress=False)
    assert np.abs(sim.y - eq.state).max() < 1e-5
    assert np.ptp(tr.thrust) < 1e-6


def test_from_state_rejects_a_state_that_does_not_fit():
    from flagellum.simulator import State

    p = Params.from_flat({"length": 2.0})
    other = Simulator(Params.from_flat({"length": 3.0}), Motor(1.0)).lab_state()
    good = Simulator(p, Motor(1.0)).lab_state()
    bad_y = good.y.copy()
    bad_y[5] = np.nan
    for state in (other, State(good.y[:-1], good.charts), State(good.y, good.charts[:2]),
                  State(bad_y, good.charts), State(good.y, good.charts, math.inf), "y"):
        with pytest.raises(ParameterError, match="state|frame_angle"):
            Simulator.from_state(state, p, Motor(1.0))
    with pytest.raises(ParameterError, match="omega_frame"):
        Simulator.from_state(good, p, Motor(1.0), omega_frame=math.nan)
    with pytest.raises(ParameterError, match="invalid t"):
        Simulator.from_state(good, p, Motor(1.0), t=-1.0)


# -- Trajectory -------------------------------------------------------------------------------
def test_trajectory_fields_are_documented_attributes():
    import dataclasses

    from flagellum.io import RECORD_FIELDS
    from flagellum.trajectory import Trajectory

    sim = Simulator(SHORT, Motor(0.3))
    tr = sim.run(0.002, save_every=1e-3, progress=False)
    assert isinstance(tr, Trajectory)
    fields = [f.name for f in dataclasses.fields(Trajectory)]
    assert fields == [*RECORD_FIELDS, "meta"]
    n = sim.model.n
    for name, (shape, _) in RECORD_FIELDS.items():
        assert name in vars(tr) and f"{name} :" in Trajectory.__doc__  # documented
        assert getattr(tr, name).shape == (3,) + shape(n)
    assert tr.y is tr.positions and set(tr.records) == set(RECORD_FIELDS)
    assert tr.meta["segments"] == n and len(tr) == 3
    assert repr(tr) == f"Trajectory(3 records, t = 0 … 0.002 s, {n} segments)"
    with pytest.raises(AttributeError):
        tr.no_such_field
    s = tr.summary()
    assert s.thrust_mean == pytest.approx(np.mean(tr.thrust), rel=0.5)


# -- the stepper interface ---------------------------------------------------------------------
def test_both_steppers_satisfy_the_stepper_protocol():
    from flagellum.integrate.base import STEPPERS, Stepper, make_stepper
    from flagellum.rod.model import RodModel

    m = RodModel(SHORT, Motor(0.3))
    y0 = m.initial_state()
    cv = make_stepper("cvode", m, 0.0, y0, SolverOptions())
    im = make_stepper("implicit", m, 0.0, y0, SolverOptions(method="implicit", dt=1e-5), kT=0.0041, seed=4)
    assert set(STEPPERS) == {"cvode", "implicit", "bdf"}
    assert type(cv) is STEPPERS["cvode"] and type(im) is STEPPERS["implicit"]
    assert isinstance(cv, Stepper) and isinstance(im, Stepper)
    assert not isinstance(object(), Stepper)
    assert cv.fixed_step is None and cv.rng_state is None
    assert im.fixed_step == 1e-5 and json.loads(json.dumps(im.rng_state)) == im.rng_state
    y = im.advance(1e-4)
    assert y is im.y and im.t == 1e-4 and im.n_steps == 10
    im.reset(0.0, y0)
    assert im.t == 0.0 and np.array_equal(im.y, y0)
    with pytest.raises(ParameterError, match="method"):
        make_stepper("euler", m, 0.0, y0, SolverOptions())


def test_a_registered_stepper_is_used(monkeypatch):
    from flagellum.integrate import base
    from flagellum.integrate.cvode import CvodeStepper

    calls = []

    class Recording(CvodeStepper):
        def advance(self, t):
            calls.append(t)
            return super().advance(t)

    monkeypatch.setitem(base.STEPPERS, "recording", Recording)
    ref = Simulator(SHORT, Motor(0.3), solver=SolverOptions(method="cvode")).run(
        0.002, save_every=1e-3, progress=False)  # the class Recording extends
    sim = Simulator(SHORT, Motor(0.3), solver=SolverOptions(method="recording"))
    tr = sim.run(0.002, save_every=1e-3, progress=False)
    assert calls and calls[-1] == 0.002 and sim.steps > 0
    assert np.array_equal(tr.positions, ref.positions)
    with pytest.raises(ParameterError, match="method"):
        SolverOptions(method="nonesuch")


def test_atol_defaults_to_a_fixed_fraction_of_rtol():
    from flagellum.integrate import ATOL_PER_RTOL

    assert SolverOptions().atol == 1e-8 == SolverOptions().rtol * ATOL_PER_RTOL
    assert SolverOptions(rtol=1e-9).atol == 1e-9 * ATOL_PER_RTOL
    assert SolverOptions(rtol=1e-9, atol=1e-3).atol == 1e-3


@pytest.mark.parametrize("save_every", [1e-3, 5e-4])
def test_motor_angle_does_not_alias_with_sparse_records(save_every):
    # M = 3 pN·µm from rest: the hook twists up by ~ML/C ≈ 9 rad within ~40 µs and then
    # turns at 1000–3500 rad/s, more than π per record at these spacings. The rotation rate
    # (slope of the motor angle) must not depend on the record spacing: the reference is a
    # run with records 3× denser than the motor's half-turn time (unwrapping the material
    # frame's own twist between records aliases here: −5000 and −11 000 rad/s)
    ref = fl.simulate(torque=3.0, time=0.1, save_every=1e-4).summary().omega_mean
    om = fl.simulate(torque=3.0, time=0.1, save_every=save_every).summary().omega_mean
    assert ref > 0
    assert om == pytest.approx(ref, rel=0.02)
