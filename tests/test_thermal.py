"""Thermal noise: equipartition, tangent correlations, reproducible random stream."""

import numpy as np
import pytest

from flagellum import Filament, Fluid, Params
from flagellum.motor import Motor
from flagellum.simulator import Simulator, SolverOptions

KT = 4.1e-3


def _run(params, t_end, dt, seed=3, every=4):
    sim = Simulator(params, Motor(0.0), thermal=True, seed=seed,
                    solver=SolverOptions(method="implicit", dt=dt, theta=0.5))
    return sim.run(t_end, save_every=every * dt, progress=False)


def test_equipartition_of_the_discrete_rod():
    """No motor: ⟨E⟩ = ½kT per quadratic mode. N joints × (2 bend + 1 twist) + N bonds
    stretching = 4N modes (the remaining 3 are the free rotation about the anchor)."""
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    n = p.filament.n_segments
    tr = _run(p, 0.08, 5e-6)
    e = tr.energy[len(tr.energy) // 5:]
    blocks = np.array([b.mean() for b in np.array_split(e, 10)])
    err = blocks.std(ddof=1) / np.sqrt(10)
    assert e.mean() / (2 * n * KT) == pytest.approx(1.0, abs=max(0.05, 3 * err / (2 * n * KT)))
    bonds = np.linalg.norm(np.diff(tr.positions[len(tr.t) // 5:], axis=1), axis=2)
    stretch = 0.5 * p.filament.stretch_modulus * 0.2 * ((bonds / 0.2 - 1) ** 2).sum(1)
    assert stretch.mean() / (0.5 * n * KT) == pytest.approx(1.0, abs=0.1)


def test_same_seed_same_path_and_different_seed_differs():
    p = Params(Filament(length=2.0), Fluid(kT=KT))
    a = _run(p, 0.002, 5e-5, seed=1)
    b = _run(p, 0.002, 5e-5, seed=1)
    c = _run(p, 0.002, 5e-5, seed=2)
    assert np.array_equal(a.positions, b.positions)
    assert not np.allclose(a.positions, c.positions)


def test_tangent_correlation_of_a_straight_filament():
    """Straight rod, bending energy A/(2h) φ² per joint: ⟨t_i·t_{i+k}⟩ = exp(−k h kT/A)
    (worm-like chain, persistence length A/kT), i.e. 1 − ⟨t_i·t_{i+k}⟩ ≈ k h kT/A."""
    A = 3.5
    p = Params(Filament(kappa0=0.0, tau0=0.0, bend_rigidity=A, twist_rigidity=A, length=2.0),
               Fluid(kT=KT))
    tr = _run(p, 0.05, 5e-6)
    pos = tr.positions[len(tr.t) // 5:]
    t = np.diff(pos, axis=1)
    t /= np.linalg.norm(t, axis=2)[..., None]
    h = 0.2
    for k in (1, 3):
        c = np.einsum("tij,tij->ti", t[:, :-k], t[:, k:]).mean()
        assert (1 - c) == pytest.approx(1 - np.exp(-k * h * KT / A), rel=0.1)


@pytest.mark.parametrize("scheme", ["bdf2", "theta"])
def test_free_axial_diffusion_with_a_load_sphere(scheme):
    """Straight filament on a load sphere: translation along z is a zero mode with friction
    Γ = 6πηa + γ∥L, so z of the sphere diffuses with D = kT/Γ (Einstein), whatever the
    fixed-step scheme (its noise must add up to the right diffusion)."""
    from flagellum.motor import Boundary

    p = Params(Filament(kappa0=0.0, tau0=0.0, length=2.0), Fluid(kT=KT))
    bd = Boundary(anchor="sphere", sphere_radius=0.5)
    dt, lag = 5e-5, 10
    sim = Simulator(p, Motor(0.0), bd, thermal=True, seed=5,
                    solver=SolverOptions(method="implicit", dt=dt, scheme=scheme))
    z = sim.run(4000 * dt, save_every=dt, progress=False).positions[:, 0, 2]
    gamma = bd.sphere_drag(p.fluid.viscosity) + p.gammas[0] * p.filament.length
    dz = z[lag:] - z[:-lag]
    msd = np.mean(dz[::lag] ** 2)  # independent increments
    # 400 Gaussian increments: the sample MSD has a relative standard error √(2/400) ≈ 7 %
    assert msd / (2 * KT / gamma * lag * dt) == pytest.approx(1.0, abs=0.12)


def test_default_thermal_newton_tolerance_is_far_below_the_noise():
    """With noise the Newton tolerance is 2e-3 of a bead's thermal step √(2kTΔt/(γ⊥h))
    (≈ 5e-5 µm at Δt = 5e-5 s). Same noise, 400 steps from rest in the lab frame: the path
    stays within 5 % of one thermal step of a fully converged one (tolerance 1e-9) — errors
    along the stiff modes are damped; along the free rotation they add up like a random walk
    of steps ≈ 2e-3 of the thermal ones — and a 100× looser tolerance deviates more."""
    from flagellum.integrate.brownian import ImplicitStepper
    from flagellum.rod.model import RodModel

    p = Params()
    step = np.sqrt(2 * p.fluid.kT * 5e-5 / (p.gammas[1] * p.filament.segment_length))
    loose_tol = 100 * 2e-3 * step
    finals = {}
    for tol in (None, 1e-9, loose_tol):
        m = RodModel(p, Motor(1.0), omega_frame=0.0)
        st = ImplicitStepper(m, 0.0, m.initial_state(), 5e-5, kT=p.fluid.kT, seed=11, tol=tol,
                             max_iter=200)  # no split steps: the same noise in every run
        if tol is None:
            assert st.tol == pytest.approx(2e-3 * step)
        for k in range(1, 5):
            st.advance(k * 0.005)
            m.rechart(st.y)
            st.reset(st.t, st.y)
        assert st.n_steps == 400
        finals[tol] = st.y[3:].reshape(-1, 4)[:, :3].copy()
    dev = np.abs(finals[None] - finals[1e-9]).max()
    assert dev < 0.05 * step
    assert np.abs(finals[loose_tol] - finals[1e-9]).max() > 3 * dev
