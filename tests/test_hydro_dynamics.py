"""The nonlocal hydrodynamic model in the time stepper (hydro.dynamics, docs/hydrodynamics.md):
the option, the rigid-helix limit against hydro.sbt, the frozen splitting against the
unfrozen reference, and RFT left as it is."""

import json

import numpy as np
import pytest

from flagellum import Filament, Params
from flagellum.errors import ParameterError
from flagellum.helix import discrete_helix
from flagellum.hydro import local as L
from flagellum.hydro import rft, sbt
from flagellum.hydro.dynamics import Hydrodynamics, effective_mobility, local_mobility
from flagellum.motor import Boundary, Motor
from flagellum.rod import kernels as K
from flagellum.simulator import Simulator, SolverOptions

SBT = Hydrodynamics("sbt")
SHORT = Params(Filament(length=4.0))


def test_option_defaults_validation_and_spec():
    assert Hydrodynamics().model == "rft"
    sim = Simulator(SHORT, Motor(0.5))
    assert sim.model.iprm[K.I_HYDRO] == K.HYDRO_LOCAL and sim.model._ws[-1].size == 0
    with pytest.raises(ParameterError, match="hydrodynamics"):
        Hydrodynamics("stokes")
    with pytest.raises(ParameterError, match="refresh"):
        Hydrodynamics("sbt", refresh=-1.0)
    sim = Simulator(SHORT, Motor(0.5), hydrodynamics=Hydrodynamics("sbt", refresh=0.01))
    spec = json.loads(json.dumps(sim.spec()))
    assert Simulator.from_spec(spec).hydrodynamics == Hydrodynamics("sbt", refresh=0.01)
    del spec["hydrodynamics"]  # files written without the key: the local model
    assert Simulator.from_spec(spec).hydrodynamics.model == "rft"
    assert sim.metadata()["hydrodynamics"] == "sbt"


def test_thermal_runs_take_the_nonlocal_mobility_with_the_implicit_scheme_only():
    # thermal noise with SBT: tests/test_hydro_thermal.py; CVODE has no noise
    sim = Simulator(SHORT, Motor(0.5), thermal=True, hydrodynamics=SBT)
    assert sim.solver.method == "implicit"
    with pytest.raises(ParameterError, match="method"):
        Simulator(SHORT, Motor(0.5), thermal=True, hydrodynamics=SBT,
                  solver=SolverOptions(method="cvode"))


def test_local_mobility_is_the_kernels_drag():
    # the block-diagonal operator subtracted in ΔM is what rod.kernels.rhs applies
    dh = discrete_helix(Filament())
    x = dh.positions
    gp, gn, _ = Params().gammas
    Ml = local_mobility(x, 0.2, gp, gn, L.FREE, 0.0)
    T = np.zeros_like(x)
    T[1:] = np.diff(x, axis=0) / np.linalg.norm(np.diff(x, axis=0), axis=1)[:, None]
    f = np.random.default_rng(1).normal(size=x.shape)
    for i in (0, 7, len(x) - 1):
        tx, ty, tz, zp, zn, mode = L.bead_friction(T, i, len(x) - 1, 0.2, gp, gn, L.FREE, 0.0)
        v = L.bead_velocity(*f[i], tx, ty, tz, zp, zn, mode)
        assert Ml[3 * i:3 * i + 3] @ f.ravel() == pytest.approx(np.array(v), rel=1e-12)


def test_free_filament_mobility_is_sbt_and_anchor_removes_bead_zero():
    x = discrete_helix(Filament(length=4.0)).positions
    M = sbt.mobility(x, 0.01, 1e-3)
    assert np.allclose(effective_mobility(x, 0.01, 1e-3, L.FREE), M, rtol=1e-9, atol=1e-9)
    Mf = effective_mobility(x, 0.01, 1e-3, L.FIXED)
    assert np.all(Mf[:3] == 0) and np.all(Mf[:, :3] == 0)
    # Schur complement: the anchor's reaction is a force on the fluid
    schur = M[3:, 3:] - M[3:, :3] @ np.linalg.solve(M[:3, :3], M[:3, 3:])
    assert np.allclose(Mf[3:, 3:], schur, rtol=1e-8, atol=1e-8 * np.abs(M).max())
    Ma = effective_mobility(x, 0.01, 1e-3, L.AXIAL, sphere_radius=0.5)
    assert np.all(Ma[:2] == 0) and Ma[2, 2] > 0


def test_small_constraint_solve_matches_lapack_and_refuses_a_singular_matrix():
    """The constraints' k×k solve (partial pivoting) against numpy's LAPACK solve, with a zero
    leading pivot that needs a row swap; a singular matrix is refused, not divided by zero."""
    from flagellum.hydro.dynamics import _solve_small

    rng = np.random.default_rng(5)
    for k in (1, 3, 6, 8):
        a = rng.normal(size=(k, k))
        if k > 1:
            a[0, 0] = 0.0
        b = rng.normal(size=(k, 40))
        want = np.linalg.solve(a, b)
        got = _solve_small(a.copy(), b.copy())
        assert np.allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    with pytest.raises(np.linalg.LinAlgError):
        _solve_small(np.zeros((3, 3)), np.ones((3, 2)))


def _pinned_sbt(params):
    """Rigid-helix thrust/torque of the simulator's discrete helix pinned at bead 0 with the
    nonlocal mobility of hydro.sbt (bond spins and hook frame local, as in the simulator and
    in tests/test_simulator.py's RFT line)."""
    dh = discrete_helix(params.filament)
    p = dh.positions
    f = params.fluid
    M = sbt.mobility(p, f.filament_radius, f.viscosity)
    m = sbt.rigid_resistance(M, p, p[0])
    gp, gn, gr = params.gammas
    h = params.filament.segment_length
    t = dh.tangents
    m[3:, 3:] += gr * h * np.einsum("ni,nj->ij", t, t)
    t0 = dh.frames[0][:, 2]
    m[3:, 3:] += gr * h * np.outer(t0, t0) + 0.5 * gn * h**3 * (np.eye(3) - np.outer(t0, t0))
    pin = rft.pinned_rotation(m, dh.axis_direction)
    # the simulator's thrust is the force the first bond transmits to the anchor: the fluid
    # force on beads 1…N (bead 0's own share, nonzero with the nonlocal flow, goes to the pin)
    axis = -pin.axis
    f = np.linalg.solve(M, sbt.rigid_motion_matrix(p, p[0])[:, 3:] @ (axis * pin.omega_per_torque))
    return pin, -(axis @ f.reshape(-1, 3)[1:].sum(0))


def test_nearly_rigid_filament_follows_the_sbt_rigid_helix():
    """A stiff filament (A, C, K × 100, the check of App. B) anchored under a constant torque
    rotates as the rigid helix of hydro.sbt pinned at its first bead: thrust per torque
    0.48 /µm (RFT: 0.77, docs/hydrodynamics.md) and its rotation rate per torque."""
    fil = Filament(bend_rigidity=350.0, twist_rigidity=350.0, stretch_modulus=1e5)
    p = Params(fil)
    M = 1.0
    sim = Simulator(p, Motor(M), solver=SolverOptions(rtol=1e-8), hydrodynamics=SBT)
    s = sim.run(0.05, save_every=1e-3).summary(0.025)
    pin, thrust = _pinned_sbt(p)
    assert 0.45 < pin.thrust_per_torque < 0.5 and 0.45 < thrust < 0.5
    assert s.thrust_mean / M == pytest.approx(thrust, rel=0.005)  # measured: 0.17 %
    assert s.omega_mean / M == pytest.approx(pin.omega_per_torque, rel=0.01)


def test_frozen_splitting_matches_the_unfrozen_reference_when_buckled():
    """Short run at M = 1.6 (regime (ii)): the mobility frozen over chunks (default refresh)
    against the one rebuilt at every right-hand side evaluation."""
    out = {}
    for name, hd in (("frozen", SBT), ("exact", Hydrodynamics("sbt", refresh=0.0))):
        sim = Simulator(SHORT, Motor(1.6), solver=SolverOptions(rtol=1e-7), hydrodynamics=hd)
        tr = sim.run(0.01, save_every=1e-3)
        out[name] = np.asarray(tr.positions), np.asarray(tr.thrust)
    dx = np.abs(out["frozen"][0] - out["exact"][0]).max()
    df = np.abs(out["frozen"][1] - out["exact"][1]).max() / np.abs(out["exact"][1]).max()
    assert dx < 0.01 and df < 0.02


def test_sweep_records_the_mobility(tmp_path):
    """``hydrodynamics`` and ``hydro_refresh`` are sweep parameters; the file records the
    model also at its default."""
    from flagellum.sweep import PointRun, Sweep, _Store

    fixed = _Store(Sweep.create({"torque": [1.0, 2.0]}, {"hydrodynamics": "sbt"}), tmp_path / "a.nc")
    assert fixed.attrs["hydrodynamics"] == "sbt"
    assert _Store(Sweep.create({"torque": [1.0, 2.0]}), tmp_path / "b.nc").attrs["hydrodynamics"] == "rft"
    swept = Sweep.create({"hydrodynamics": "rft,sbt"})
    assert "hydrodynamics" not in _Store(swept, tmp_path / "c.nc").attrs
    assert [p["hydrodynamics"] for p in swept.points()] == ["rft", "sbt"]
    run = PointRun.from_values({"hydrodynamics": "sbt", "hydro_refresh": 0.01})
    assert run.hydrodynamics == Hydrodynamics("sbt", 0.01)
    assert PointRun.from_values({}).hydrodynamics == Hydrodynamics()
    with pytest.raises(ParameterError):
        PointRun.from_values({"hydrodynamics": "bem"})


@pytest.mark.parametrize("boundary", [Boundary("sphere", 1.0), Boundary("free", sphere_radius=0.5),
                                      Boundary("free")], ids=["load sphere", "swimmer", "filament alone"])
def test_fluid_force_on_filament_and_body_balances(boundary):
    """At a deformed, twisted state the bead velocities of the kernel (ΔM built at that state)
    are those of the nonlocal mobility with the sphere attached, and the fluid force on
    filament + sphere that they imply, R U, vanishes: along z on the load sphere (free to
    slide), in every direction for the free swimmer (force-free to round-off)."""
    from flagellum.rod.model import RodModel, positions

    p = SHORT
    m = RodModel(p, Motor(1.0), boundary, hydrodynamics=Hydrodynamics("sbt", refresh=0.0))
    y = m.initial_state()
    rng = np.random.default_rng(3)
    y[3:] += rng.normal(0.0, 0.03, y.size - 3)
    U = positions(m.rhs(0.0, y)).ravel()
    x = positions(y)
    a = boundary.sphere_radius or 0.0
    free = L.FREE if boundary.anchor == "free" else L.AXIAL
    if free == L.FREE:
        M_att = effective_mobility(x, p.fluid.filament_radius, p.fluid.viscosity, L.FREE, a)
        f = np.linalg.solve(M_att, U).reshape(-1, 3)  # force on the fluid per bead (bead 0: + sphere)
    else:  # the load sphere (at x_0 + a e_z) slides with bead 0 and does not turn
        from flagellum.hydro.dynamics import grand_mobility, sphere_centre

        big = grand_mobility(x, p.fluid.filament_radius, p.fluid.viscosity, sphere_centre(x, a), a)
        k = 3 * len(x)
        P = np.zeros((k + 6, k))  # bead velocities → (beads, sphere V = U_0, Ω = 0)
        P[:k], P[k:k + 3, :3] = np.eye(k), np.eye(3)
        f = (P.T @ np.linalg.solve(big, P @ U)).reshape(-1, 3)
    total = f.sum(0)
    scale = np.abs(f).max()
    assert scale > 1e-3
    if free == L.FREE:
        assert np.abs(total).max() < 1e-9 * scale
    else:
        # bead 0 slides along z only: the pin's reaction (x, y) reaches the fluid, z does not
        assert abs(total[2]) < 1e-9 * scale and np.abs(total[:2]).max() > 1e-6 * scale


@pytest.mark.parametrize("thermal", [False, True, "cell"])
def test_sbt_run_killed_after_a_checkpoint_resumes_bit_identical(tmp_path, thermal):
    """A nonlocal run SIGKILLed after its first checkpoint resumes (ΔM rebuilt where the
    integrator restarts) to the records of the run that never stopped; thermal: the
    fixed-step scheme, whose kept thermal mobility (factor, drift) is renewed there too;
    cell: an E. coli-like cell on CVODE, whose ΔM is turned per right-hand side (the
    restart starts without a turn, as a new stepper does)."""
    import os
    import signal

    from flagellum.io import RECORD_FIELDS, read_trajectory

    def new():
        if thermal == "cell":
            return Simulator(Params.from_flat({"length": 2.0}), Motor(1.3),
                             Boundary(anchor="free", body_radius=0.44, body_aspect=2.5 / 0.88,
                                      hook="clamped"), hydrodynamics=SBT)
        if thermal:
            return Simulator(Params.from_flat({"length": 2.0}), Motor(0.5), hydrodynamics=SBT,
                             thermal=True, seed=5, solver=SolverOptions(method="implicit"))
        return Simulator(Params.from_flat({"length": 2.0}), Motor(0.5), hydrodynamics=SBT)

    run = dict(t_end=0.06, save_every=1e-3, checkpoint_every=0.02, progress=False)
    (tmp_path / "ref").mkdir()
    (tmp_path / "run").mkdir()
    ref, out = tmp_path / "ref" / "ref.h5", tmp_path / "run" / "run.h5"
    new().run(output=ref, **run)
    pid = os.fork()
    if pid == 0:  # child: killed right after checkpoint 0 is in place (main, part 0, checkpoint 0)
        try:
            replace, calls = os.replace, [0]

            def replace_then_die(*args, **kwargs):
                replace(*args, **kwargs)
                calls[0] += 1
                if calls[0] == 3:
                    os.kill(os.getpid(), signal.SIGKILL)

            os.replace = replace_then_die
            new().run(output=out, **run)
        finally:
            os._exit(0)
    status = os.waitpid(pid, 0)[1]
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
    assert len(read_trajectory(out)["t"]) < 61
    sim, _ = Simulator.resume(out, progress=False)
    assert sim.hydrodynamics == SBT
    a, b = read_trajectory(ref), read_trajectory(out)
    assert b["attrs"]["status"] == "complete"
    for name in [*RECORD_FIELDS, "final_state"]:
        assert np.array_equal(a[name], b[name]), name


# -- linear stability with the nonlocal mobility ---------------------------------------------
#: the anchored paper filament with SBT (critical_torque, xtol 1e-3; docs/hydrodynamics.md)
SBT_MC1, SBT_FC1 = 1.5845, 0.9031


def test_stability_sees_the_unfrozen_mobility():
    """The aligned state and its spectrum use the nonlocal mobility rebuilt at every
    evaluation; its thrust per torque is SBT's (≈ 40 % below RFT's)."""
    from flagellum.analysis.stability import linear_stability, relative_equilibrium

    eq = relative_equilibrium(SHORT, 1.0, hydrodynamics=SBT)
    assert eq.hydrodynamics == Hydrodynamics("sbt", refresh=0.0)
    assert eq.model().hydrodynamics.refresh == 0.0 and eq.residual < 1e-6
    local = relative_equilibrium(SHORT, 1.0)
    assert 0.45 < eq.thrust / local.thrust < 0.75
    r = linear_stability(equilibrium=eq, n_eigs=2)
    # the leading mode of this short filament is its slow tilt (Im λ ≈ Ω, growing slowly
    # with RFT too: 0.54 /s); with SBT 1.31 /s
    assert r.lambda_ == pytest.approx(1.309, abs=0.01) and abs(r.frequency / r.omega - 1) < 0.05


@pytest.mark.slow
@pytest.mark.ci
def test_sbt_critical_torque_of_the_anchored_filament():
    from flagellum.analysis.stability import critical_torque

    ct = critical_torque(Params(), hydrodynamics=SBT, xtol=1e-3)
    assert ct.critical_torque == pytest.approx(SBT_MC1, abs=2e-3)
    assert ct.critical_force == pytest.approx(SBT_FC1, abs=3e-3)


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize("factor,regime", [(0.9, "aligned"), (1.1, "buckled")])
def test_sbt_critical_torque_confirmed_by_simulation(factor, regime):
    """0.8 s from the stress-free helix (≈ 30 and 50 s): aligned at 0.9 M_c1, buckled at 1.1 M_c1."""
    from flagellum.sweep import PointRun

    run = PointRun.from_values({"torque": factor * SBT_MC1, "time": 0.8, "hydrodynamics": "sbt"})
    assert run.simulate()["regime"] == regime


def test_free_swimmer_speed_matches_the_sbt_rigid_body():
    """Swimming speed and rotation rate of the free swimmer (body a = 0.5 µm) with SBT against
    the force- and torque-free rigid body of hydro.sbt for its instantaneous shape: the
    resistance of filament + body from the nonlocal mobility with the body (centred at x_0 + a e_z) moving with bead 0,
    motor torque M e_z on the filament (the SBT twin of the RFT check in test_simulator.py)."""
    from flagellum.rod.model import positions

    p, a = Params(), 0.5
    sim = Simulator(p, Motor(1.0), Boundary(anchor="free", sphere_radius=a),
                    solver=SolverOptions(rtol=1e-8), hydrodynamics=SBT)
    tr = sim.run(0.1, save_every=0.1 / 50)
    pos = positions(sim.y)
    sim.model.refresh_mobility(sim.y, force=True)  # ΔM at this very shape
    vel = positions(sim.model.rhs(sim.t, sim.y))  # co-rotating frame: v_z as in the lab
    w = np.full(len(pos), p.filament.segment_length)
    w[0] = w[-1] = p.filament.segment_length / 2
    e3 = np.diff(pos, axis=0)
    e3 /= np.linalg.norm(e3, axis=1)[:, None]
    tan = np.vstack([e3[:1], e3[:-1] + e3[1:], e3[-1:]])
    tan /= np.linalg.norm(tan, axis=1)[:, None]
    M_att = effective_mobility(pos, p.fluid.filament_radius, p.fluid.viscosity, L.FREE, a)
    R = sbt.rigid_resistance(M_att, pos, pos[0], tan, w, p.gammas[2])
    U = np.linalg.solve(R, [0, 0, 0, 0, 0, 1.0])
    s = tr.summary()
    assert 0.7 < s.swimming_speed / 35.06 < 0.8  # RFT: 35.06 µm/s
    assert vel[0, 2] == pytest.approx(U[2], rel=0.02)
    assert s.swimming_speed == pytest.approx(U[2], rel=0.005)  # measured: 27.618 against 27.711
    assert s.omega_mean == pytest.approx(U[5], rel=0.01)  # measured: 850.7 against 853.7


@pytest.mark.slow
@pytest.mark.ci
def test_frozen_mobility_converges_to_the_unfrozen_one_with_the_refresh_distance():
    """Anchored filament from the pinned helix at M = 1.6 (N = 50, 0.02 s, the tip swinging
    out): the thrust's deviation from the unfrozen reference (refresh 0) shrinks with the
    refresh distance. Measured, relative to the largest thrust: the mean deviation over the
    second half 3.0e-5 at 0.02 µm and 7.6e-6 at 0.005 µm with the secant model's quadratic
    slope (1.05e-4 and 1.3e-5 with the linear secant), the largest 2.6e-4 and 1.6e-4 (a
    single record in the twist-up; 2.7e-4 and 5.1e-5 linear); a time ramp between builds
    gave 0.25 % and 0.073 % at most, and ΔM checked only between the simulator's chunks
    1.4 % at any refresh distance, the beads having moved further than that within one chunk
    of the start."""
    out = {}
    for r in (0.0, 0.02, 0.005):
        sim = Simulator(Params(), Motor(1.6), hydrodynamics=Hydrodynamics("sbt", refresh=r))
        out[r] = np.asarray(sim.run(0.02, save_every=2e-4, progress=False).thrust)
    scale = np.abs(out[0.0]).max()
    dev = {r: np.abs(out[r] - out[0.0]) / scale for r in (0.02, 0.005)}
    half = len(out[0.0]) // 2
    assert dev[0.02].max() < 0.001
    assert dev[0.005][half:].mean() < 0.5 * dev[0.02][half:].mean()


@pytest.mark.slow
@pytest.mark.ci
def test_fig6_and_fig8_take_the_nonlocal_mobility():
    """Fig. 6 with SBT adds the rigid helix' nonlocal thrust per torque: on the continuum
    helix' Gauss nodes 0.5846 /µm, within 1 % of the converged bead value 0.5875 /µm
    (tests/test_sbt.py, N = 400–800); Fig. 8's jobs pass the mobility to linear stability."""
    from flagellum.analysis.stability import linear_stability
    from flagellum.reproduce import fig6, fig8
    from flagellum.reproduce.shared import Cache

    cache = Cache()
    cache.hydrodynamics = SBT
    q = fig6.compute("quick", cache).quantities
    assert q["sbt_thrust_per_torque"] == pytest.approx(0.5875, rel=0.01)
    assert "sbt_thrust_per_torque" not in fig6.compute("quick").quantities
    v = fig8.VARIANTS["quick"][0]
    job = {"kind": "lambda", "variant": v, "m_hat": -1.0, "torque": -0.5, "hydrodynamics": SBT.to_dict()}
    want = linear_stability(fig8.variant_params(v), -0.5, hydrodynamics=SBT).lambda_
    assert fig8._job(job)["lambda"] == pytest.approx(want, rel=1e-9)


@pytest.mark.slow
@pytest.mark.ci
def test_load_sphere_at_the_filament_end_raises_the_sbt_threshold():
    """With the load sphere at the filament's end (centre x_0 + a e_z, not overlapping the
    filament) the SBT threshold grows with 1/a as the paper's load-sphere line does: at
    M = 1.62 pN·µm, above the anchored M_c1 = 1.585 pN·µm (SBT_MC1, checked by
    test_sbt_critical_torque_*), the aligned state on a sphere of a = 2 µm is stable, so
    M_c1(a = 2 µm) > M_c1(anchored) (critical_torque: 1.6505 pN·µm, docs/hydrodynamics.md).
    One unfrozen λ evaluation, about 20 s of CPU time."""
    from flagellum.analysis.stability import linear_stability

    assert 1.62 > SBT_MC1
    assert linear_stability(Params(), 1.62, Boundary("sphere", sphere_radius=2.0), hydrodynamics=SBT).lambda_ < 0
