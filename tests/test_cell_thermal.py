"""Thermal noise and the fixed-step scheme with a cell body free in 3D: the body's Brownian
force and torque (flagellum.integrate.brownian.body_noise), the invariant measure of its
orientation, and the Einstein relations of the swimming cell at M = 0."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flagellum import Filament, Fluid, Params
from flagellum.hydro import body as Bd
from flagellum.integrate import brownian as Br
from flagellum.motor import Boundary, Motor
from flagellum.rod.model import RodModel
from flagellum.simulator import Simulator, SolverOptions

KT = 4.1e-3
#: a short straight filament (4 bonds of 0.04 µm) on the body: its drag is < 1 % of a body
#: of radius 2 µm (γ⊥L = 4.5e-4 pN·s/µm against 6πηa = 0.038), so the cell diffuses as the
#: body alone to well within the statistical tolerances below
SHORT = Filament(kappa0=0.0, tau0=0.0, length=0.16, segment_length=0.04)


def test_body_noise_has_the_covariance_of_its_resistance():
    """Fluctuation–dissipation: the body's thermal force and torque have the covariance
    2kT R/Δt with R = Q diag(R∥, R⊥) Qᵀ its resistance turned with the body (Kim & Karrila,
    Microhydrodynamics, Table 3.4, via hydro.body.body_resistance), and are uncorrelated
    (no translation–rotation coupling about the centre of a spheroid)."""
    bd = Boundary(anchor="free", body_radius=0.5, body_aspect=3.0, motor_offset=40.0)
    m = RodModel(Params(Filament(length=1.0)), Motor(0.0), bd)
    y = m.initial_state()
    y[-3:] = [0.4, -1.1, 0.7]
    c = math.sqrt(2 * KT / 5e-5)
    rng = np.random.default_rng(0)
    n = 40000
    xs = np.empty((n, 6))
    xi = np.zeros(9)
    for k in range(n):
        Br.body_noise(y, m.prm, m.iprm, c, rng.standard_normal(9), xi)
        xs[k] = xi[3:]
    cov = xs.T @ xs / n
    r = Bd.body_resistance(0.5, 3.0, Params().fluid.viscosity)
    Q = Bd.rotvec_matrix(y[-3:])
    ax = Q @ Bd.body_geometry(0.5, 3.0, 40.0).axis
    expect = np.zeros((6, 6))
    for j, (par, perp) in enumerate(((r[0], r[1]), (r[2], r[3]))):
        expect[3 * j:3 * j + 3, 3 * j:3 * j + 3] = c * c * (perp * np.eye(3) + (par - perp) * np.outer(ax, ax))
    scale = np.sqrt(np.outer(np.diag(expect), np.diag(expect)))
    # 40000 samples: each normalized entry has a standard error ≤ √(2/40000) ≈ 0.007
    np.testing.assert_allclose(cov / scale, expect / scale, atol=0.035)
    assert r[0] < r[1] and r[2] < r[3]  # a prolate body: the test sees the anisotropy


def test_invariant_measure_and_generalized_torque_of_the_orientation():
    """The density of SO(3)'s Haar measure in exponential coordinates is
    det J(φ) = 2(1 − cos θ)/θ² (e.g. G. S. Chirikjian, Stochastic Models, Information Theory,
    and Lie Groups, Vol. 2 (2012), Sec. 10.6): haar_gradient is its log's gradient (finite
    differences here). rotvec_torque is J⁻ᵀ: the torque T of a generalized force f does
    the same virtual work, T·(J δφ) = f·δφ, with J the inverse of rotvec_rate's matrix."""
    def logdet(p):
        t = np.linalg.norm(p)  # 2(1 − cos θ)/θ² = (sin(θ/2)/(θ/2))², without cancellation
        return 2 * math.log(math.sin(t / 2) / (t / 2))

    for p in (np.array([0.3, -0.2, 0.5]), np.array([1.5, 2.0, -0.4]), np.array([1e-3, 2e-3, -1e-3])):
        num = np.array([(logdet(p + 1e-6 * e) - logdet(p - 1e-6 * e)) / 2e-6 for e in np.eye(3)])
        np.testing.assert_allclose(Bd.haar_gradient(*p), num, rtol=1e-5, atol=1e-9)
        jinv = np.array([Bd.rotvec_rate(*p, *e) for e in np.eye(3)]).T
        f, dphi = np.array([0.7, -0.3, 1.1]), np.array([-0.2, 0.9, 0.4])
        T = np.array(Bd.rotvec_torque(*p, *f))
        assert T @ (np.linalg.solve(jinv, dphi)) == pytest.approx(f @ dphi, rel=1e-12)


def test_a_cell_draws_six_normals_more_per_step():
    """The body's force and torque take 6 normals of their own per step (after the hook's);
    the layout of the rod without a body is unchanged (the same stream as before)."""
    bd = Boundary(anchor="free", body_radius=1.0)
    p = Params(SHORT, Fluid(kT=KT))
    m = RodModel(p, Motor(0.0), bd)
    st = Br.ImplicitStepper(m, 0.0, m.initial_state(), 5e-5, kT=KT, seed=2)
    assert st._n_normals == 4 * (m.n + 1) + 3 + 6 + m.state_size
    a = RodModel(p, Motor(0.0))
    assert Br.ImplicitStepper(a, 0.0, a.initial_state(), 5e-5, kT=KT)._n_normals == 4 * (a.n + 1) + 3 + a.state_size


def _diffusion(aspect, steps, lag=10, dt=5e-5, seed=3, hydrodynamics=None):
    a = 2.0 / aspect ** (1 / 3)  # about the same volume
    sim = Simulator(Params(SHORT, Fluid(kT=KT)), Motor(0.0),
                    Boundary(anchor="free", body_radius=a, body_aspect=aspect), thermal=True,
                    seed=seed, solver=SolverOptions(method="implicit", dt=dt),
                    **({} if hydrodynamics is None else {"hydrodynamics": hydrodynamics}))
    tr = sim.run(steps * dt, save_every=lag * dt, progress=False)
    Q = np.array([Bd.rotvec_matrix(f) for f in tr.body_orientation])
    dX = np.diff(tr.body_position, axis=0)
    par = np.einsum("ti,ti->t", dX, tr.body_axis[:-1])
    # rotation over each lag in the body frame: Qᵀ(t) Q(t + τ)
    rel = np.array([Bd.matrix_rotvec(Q[i].T @ Q[i + 1]) for i in range(len(Q) - 1)])
    rpar = rel @ Bd.body_geometry(a, aspect, 0.0).axis
    tau = lag * dt
    measured = (np.mean(par ** 2) / (2 * tau), np.mean((dX ** 2).sum(1) - par ** 2) / (4 * tau),
                np.mean(rpar ** 2) / (2 * tau), np.mean((rel ** 2).sum(1) - rpar ** 2) / (4 * tau))
    r = Bd.body_resistance(a, aspect, Params().fluid.viscosity)
    return np.array(measured), KT / np.array(r), len(dX)


@pytest.mark.slow
@pytest.mark.parametrize("aspect", [1.0, 2.0])
def test_cell_at_rest_diffuses_as_einstein_and_perrin(aspect):
    """M = 0, a body with a short filament: over independent lags, the centre's displacement
    along and across the body axis and the body-frame rotation about and across it have the
    Einstein diffusivities D = kT/R of the body's resistance R — for a sphere
    D = kT/(6πηa), D_r = kT/(8πηa³) (A. Einstein, Ann. Phys. 17, 549 (1905); P. Debye,
    Polar Molecules (1929)), for the prolate spheroid F. Perrin's (J. Phys. Radium 5, 497
    (1934); tests/test_cell.py checks body_resistance against his closed forms). Noise,
    the Itô drift and the orientation's invariant measure must all be right: a missing or
    doubled noise changes D by 100 %."""
    measured, expect, n = _diffusion(aspect, 4000)
    # n = 400 increments: relative standard error √(2/n) ≈ 7 % along (one component),
    # √(1/n) = 5 % across (two); filament drag < 1 %
    tol = (3.5 * math.sqrt(2 / n), 3.5 * math.sqrt(1 / n)) * 2
    for k, name in enumerate(("D along", "D across", "D_r about", "D_r across")):
        assert measured[k] / expect[k] == pytest.approx(1.0, abs=tol[k]), name


def test_thermal_cell_run_from_the_cli_writes_its_records(cli, tmp_path):
    """flagellum simulate --body-radius 1 --thermal --torque 1: a whole swimming cell with
    thermal noise runs with the fixed-step scheme and records the body."""
    from flagellum.trajectory import open_trajectory

    out = tmp_path / "cell.h5"
    code, stdout, err = cli("simulate", "--body-radius", "1", "--thermal", "--torque", "1",
                            "--length", "2", "--time", "0.002", "--save-every", "0.0005", "--seed",
                            "4", "--json", "-o", str(out))
    assert code == 0, err
    ds = open_trajectory(out)
    pos = np.asarray(ds["body_position"])
    assert pos.shape == (5, 3) and np.all(np.isfinite(pos))
    assert np.all(np.isfinite(np.asarray(ds["body_angular_velocity"])))
    assert np.ptp(pos[:, 0]) > 0  # moved sideways: noise (the deterministic cell swims along z)


def test_thermal_cell_run_resumes_bit_identically(tmp_path, monkeypatch):
    """A thermal cell run interrupted after its first checkpoint and resumed from it gives
    the same records as the uninterrupted run (the random stream and the body's orientation
    are checkpointed; as for the anchored thermal runs, tests/test_bad_input.py)."""
    from flagellum.io import read_trajectory

    def make():
        return Simulator(Params(Filament(length=1.0), Fluid(kT=KT)), Motor(1.0),
                         Boundary(anchor="free", body_radius=0.5, body_aspect=2.0), thermal=True, seed=7)

    run = dict(t_end=0.004, save_every=0.0005, checkpoint_every=0.002, progress=False)
    make().run(output=tmp_path / "ref.h5", **run)
    calls = [0]
    orig = Simulator._record

    def record(self, buf):
        calls[0] += 1
        if calls[0] == 6:
            raise KeyboardInterrupt
        return orig(self, buf)

    monkeypatch.setattr(Simulator, "_record", record)
    with pytest.raises(KeyboardInterrupt):
        make().run(output=tmp_path / "run.h5", **run)
    monkeypatch.undo()
    Simulator.resume(tmp_path / "run.h5", progress=False)
    a, b = read_trajectory(tmp_path / "ref.h5"), read_trajectory(tmp_path / "run.h5")
    for k in ("positions", "body_position", "body_axis", "body_angular_velocity", "final_state"):
        np.testing.assert_array_equal(a[k], b[k])


@pytest.mark.slow
def test_fixed_step_cell_converges_to_cvode_at_second_order():
    """Deterministic cell (spheroid, L = 2 µm, M = 1, 0.01 s): the fixed-step BDF2 scheme,
    whose chord iteration takes the rod's band without the orientation's coupling, converges
    to CVODE's solution (rtol 1e-8) at second order in Δt (Buckwar & Winkler 2006; the
    measured errors of the body's centre are 0.022 µm at Δt = 5e-5 s and 0.0066 µm at
    2.5e-5 s, a regression value; the centre moves 0.46 µm)."""
    bd = Boundary(anchor="free", body_radius=0.5, body_aspect=2.0)

    def centre(**solver):
        sim = Simulator(Params(Filament(length=2.0)), Motor(1.0), bd, solver=SolverOptions(**solver))
        return sim.run(0.01, save_every=0.001, progress=False).body_position

    ref = centre(method="cvode", rtol=1e-8)
    e1 = np.abs(centre(method="implicit") - ref).max()
    e2 = np.abs(centre(method="implicit", dt=2.5e-5) - ref).max()
    assert e1 < 0.05 and e1 / e2 > 2.5


@pytest.mark.slow
def test_equipartition_of_the_filament_on_a_cell():
    """M = 0, a free hook on a sphere free in 3D: the equilibrium statistics do not depend on
    the mobility, so ⟨E⟩ = ½kT per quadratic mode as on the anchor (tests/test_thermal.py):
    N joints × (2 bend + 1 twist) + N bonds = 4N modes; the body's 6 rigid motions and the
    hook frame's turning cost nothing. Stretching alone: ½kT per bond."""
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    n = p.filament.n_segments
    sim = Simulator(p, Motor(0.0), Boundary(anchor="free", body_radius=0.5), thermal=True, seed=3,
                    solver=SolverOptions(method="implicit", dt=5e-6, theta=0.5))
    tr = sim.run(0.08, save_every=2e-5, progress=False)
    e = tr.energy[len(tr.energy) // 5:]
    blocks = np.array([b.mean() for b in np.array_split(e, 10)])
    err = blocks.std(ddof=1) / np.sqrt(10)
    assert e.mean() / (2 * n * KT) == pytest.approx(1.0, abs=max(0.05, 3 * err / (2 * n * KT)))
    bonds = np.linalg.norm(np.diff(tr.positions[len(tr.t) // 5:], axis=1), axis=2)
    stretch = 0.5 * p.filament.stretch_modulus * 0.2 * ((bonds / 0.2 - 1) ** 2).sum(1)
    assert stretch.mean() / (0.5 * n * KT) == pytest.approx(1.0, abs=0.1)
