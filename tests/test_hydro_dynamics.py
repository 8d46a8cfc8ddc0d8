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


def test_thermal_runs_refuse_the_nonlocal_mobility():
    with pytest.raises(ParameterError, match="hydrodynamics"):
        Simulator(SHORT, Motor(0.5), thermal=True, hydrodynamics=SBT)


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
