"""The polymorphic filament (flagellum.rod.polymorph): stress-free forms, domain walls
against the Nagumo front, detailed balance with noise, the single-state limit, the flags."""

import json
import math

import numpy as np
import pytest

from flagellum import Filament, Params
from flagellum.errors import ParameterError
from flagellum.helix import Helix, discrete_helix, discrete_rod
from flagellum.motor import Motor
from flagellum.params import POLYMORPHIC_FORMS, Polymorphism, helix_strains
from flagellum.rod import polymorph as PM
from flagellum.rod.model import RodModel
from flagellum.simulator import Simulator, SolverOptions

from conftest import assert_one_line_error

SHORT = Params(Filament(length=4.0))
FORMS = ("normal", "semicoiled", "curly1")


def test_pitch_and_diameter_convert_to_curvature_and_torsion_and_back():
    """κ = R/(R² + b²), τ = b/(R² + b²) (b = P/2π) inverts the helix geometry of Eq. (37)."""
    for name, (pitch, diameter, _) in POLYMORPHIC_FORMS.items():
        k, t = helix_strains(pitch, diameter)
        hx = Helix(k, t, 10.0)
        assert hx.pitch == pytest.approx(pitch, rel=1e-12)
        assert 2 * hx.radius == pytest.approx(diameter, rel=1e-12)
    # handedness relative to the normal form (Hotani 1982: normal left, semicoiled and curly
    # right-handed); the package's normal form has the filament's handedness
    kap, tau = Polymorphism().strains(SHORT.filament)
    assert (kap[0], tau[0]) == (SHORT.filament.kappa0, SHORT.filament.torsion)
    assert tau[0] > 0 and tau[1] < 0 and tau[2] < 0
    left = Params(Filament(handedness="left"))
    assert np.sign(Polymorphism().strains(left.filament)[1]).tolist() == [-1, 1, 1]


@pytest.mark.parametrize("form", FORMS)
def test_each_form_is_a_stress_free_equilibrium(form):
    """A filament built in one form has zero elastic energy, zero force on every bead and
    zero velocity; in a run it stays in that form (φ at the form's integer to rounding) with
    zero anchor force."""
    pm = Polymorphism(initial=form)
    sim = Simulator(SHORT, Motor(0.0), polymorphism=pm)
    m = sim.model
    assert m.energy(sim.y) == pytest.approx(0.0, abs=1e-20)
    e, dr, dth, _ = m.gradients(sim.y)
    assert np.abs(dr).max() < 1e-9 and np.abs(dth).max() < 1e-9
    assert np.abs(m.rhs(0.0, sim.y)).max() < 1e-5  # µm/s, rad/s
    helix = Helix(*[v[FORMS.index(form)] for v in pm.strains(SHORT.filament)], 4.0)
    tr = sim.run(0.01, save_every=2e-3, progress=False)
    assert np.abs(tr.polymorph - FORMS.index(form)).max() < 1e-12  # rounding of the strains
    assert np.abs(tr.anchor_force).max() < 1e-8
    np.testing.assert_allclose(tr.positions[-1], tr.positions[0], atol=1e-9)
    # the stress-free shape is the form's discrete helix: its end-to-end distance
    dh = discrete_helix(Filament(kappa0=helix.curvature, tau0=abs(helix.torsion), length=4.0,
                                 handedness="right" if helix.torsion > 0 else "left"))
    d = np.linalg.norm(tr.positions[0, -1] - tr.positions[0, 0])
    assert d == pytest.approx(np.linalg.norm(dh.positions[-1] - dh.positions[0]), rel=1e-12)


def _chain(n, h, phi0):
    return np.array(phi0, float), np.zeros((n, 3)), np.zeros(3), np.zeros(3)


def _wall_position(phi, h):
    """Where φ crosses 1/2 (linear interpolation between joints) [µm from joint 0]."""
    j = int(np.nonzero(np.diff(np.sign(phi - 0.5)))[0][0])
    return h * (j + (0.5 - phi[j]) / (phi[j + 1] - phi[j]))


@pytest.mark.parametrize("de", [0.0, 0.3, -0.3])
def test_a_domain_wall_moves_towards_the_higher_energy_form_at_the_nagumo_speed(de):
    """The order parameter alone (rod decoupled): a wall between forms 0 and 1 whose well
    energies differ by de travels at the speed of the continuum Nagumo front,
    c = √(Dk/2)(1 − 2a)/ζ, a = 1/2 + 6 de/k (Zeldovich/Nagumo closed form), into the
    higher-energy form; with equal wells it stays. Wall width √(2D/k) = 1 µm ≫ h = 0.05 µm."""
    n, h, barrier, zeta = 400, 0.05, 1.0, 0.1
    k = 64 * barrier
    D = 0.5 * k * 1.0 ** 2  # width 1 µm
    x = h * np.arange(n)
    phi = 1.0 / (1.0 + np.exp((x - 10.0) / PM.wall_width(barrier, D)))  # form 1 | form 0
    eps = np.array([0.0, -de])  # ε1 − ε0 = −de: form 0 is higher for de > 0
    sub = PM.stable_substep(h, k, D, zeta, np.zeros(2), np.zeros(2), 0.0, 0.0)
    z = np.zeros((n, 3))
    PM.advance(phi, 0.05, math.ceil(0.05 / sub), h, eps, np.full(1, k), D, zeta, 0.0, 0.0, z, np.zeros(2),
               np.zeros(2), False, 0.0, np.zeros((1, 1)))  # settle the profile
    x0 = _wall_position(phi, h)
    T = 0.2
    PM.advance(phi, T, math.ceil(T / sub), h, eps, np.full(1, k), D, zeta, 0.0, 0.0, z, np.zeros(2),
               np.zeros(2), False, 0.0, np.zeros((1, 1)))
    v = (_wall_position(phi, h) - x0) / T  # > 0: form 1 (left) grows, into form 0
    expected = PM.front_speed(barrier, D, zeta, -de)  # into form 1 when positive: sign flip
    if de == 0.0:
        assert abs(v) < 1e-6
    else:
        assert np.sign(v) == np.sign(de)  # towards the higher-energy form
        assert -v == pytest.approx(expected, rel=0.01)


def test_domain_wall_in_the_rod_moves_towards_the_higher_energy_form():
    """The coupled filament (barrier 1 pN, D = 8 pN·µm²: wall width 0.5 µm = 2.5 h):
    normal | semicoiled; with
    the semicoiled well 1 pN higher the wall runs into the semicoiled domain, with it 1 pN
    lower the other way, at ≈ 20 µm/s (continuum Nagumo front 30 µm/s: the wall spans only
    2.5 joints); with equal wells it creeps at ≈ 1 µm/s (the elastic mismatch at the wall)."""
    def speed(energies):
        pm = Polymorphism(forms=("normal", "semicoiled"), energies=energies,
                          initial="normal:10,semicoiled:10", barrier=1.0, wall_stiffness=8.0)
        sim = Simulator(SHORT, Motor(0.0), polymorphism=pm)
        tr = sim.run(0.02, save_every=2e-3, progress=False)
        pos = [_wall_position(p, 0.2) for p in tr.polymorph]
        assert PM.domain_walls(tr.polymorph[-1]) == 1
        assert tr.polymorph.shape == (len(tr.t), 20)
        return np.polyfit(tr.t[2:], pos[2:], 1)[0]

    up, level, down = speed((0.0, 1.0)), speed((0.0, 0.0)), speed((0.0, -1.0))
    c = PM.front_speed(1.0, 8.0, 0.1, 1.0)  # 30 µm/s
    assert 0.4 * c < up < 1.1 * c and -1.1 * c < down < -0.4 * c
    assert abs(level) < 0.1 * up


def test_noise_samples_the_boltzmann_weight_of_the_landscape():
    """Detailed balance: independent joints (D = 0) with noise kT in a two-well landscape
    (barrier 1.5 kT, wells 0.5 kT apart); the fraction of joints past the barrier top
    (x = a) against ∫ exp(−h v/kT) over that basin (quadrature of the landscape, independent
    of the dynamics; φ lives on [0, 1], the forms, with reflecting ends). Euler–Maruyama at
    a tenth of the stability step (≈ 1/20 of a well's relaxation time): ≈ 90 hops per
    joint, statistical error ≈ 0.005."""
    n, h, kT, barrier, zeta = 200, 1.0, 1.0, 1.5, 1.0
    k = 64 * barrier
    eps = np.array([0.0, 0.5])
    a = 0.5 + 6 * (eps[1] - eps[0]) / k
    rng = np.random.default_rng(3)
    phi = rng.integers(0, 2, n).astype(float)
    sub = 0.2 * PM.stable_substep(h, k, 0.0, zeta, np.zeros(2), np.zeros(2), 0.0, 0.0)
    z = np.zeros((n, 3))
    frac = []
    steps = 100
    for _ in range(1000):
        PM.advance(phi, steps * sub, steps, h, eps, np.full(1, k), 0.0, zeta, 0.0, 0.0, z, np.zeros(2),
                   np.zeros(2), False, kT, rng.standard_normal((steps, n)))
        frac.append(np.mean(phi > a))
    assert np.all((phi >= 0.0) & (phi <= 1.0))
    grid = np.linspace(0.0, 1.0, 4001)
    w = np.exp(-h * np.array([PM.landscape(p, eps, k)[0] for p in grid]) / kT)
    expected = np.trapezoid(w * (grid > a), grid) / np.trapezoid(w, grid)
    assert np.mean(frac[100:]) == pytest.approx(expected, abs=0.015)
    assert 0.2 < expected < 0.45  # the wells' weights differ: the test can tell them apart


def test_one_form_is_the_single_state_filament():
    """Polymorphism with the normal form alone: the same run as without (the per-joint
    curvatures equal κ0, τ0; only the chunking of the run differs)."""
    solver = SolverOptions(rtol=1e-8, atol=1e-10)
    a = Simulator(SHORT, Motor(0.5), solver=solver).run(0.01, save_every=2e-3, progress=False)
    b = Simulator(SHORT, Motor(0.5), solver=solver, polymorphism=Polymorphism(forms=("normal",))
                  ).run(0.01, save_every=2e-3, progress=False)
    np.testing.assert_allclose(b.positions, a.positions, atol=1e-6)
    assert np.all(b.polymorph == 0.0) and a.polymorph is None and a.polymorph_summary() == {}


def test_landscape_wells_barrier_and_rod_drive():
    eps, k = np.array([0.0, 0.5, 0.2]), 64.0
    for m, e in enumerate(eps):
        v, dv = PM.landscape(float(m), eps, k)
        assert v == pytest.approx(e) and dv == pytest.approx(0.0, abs=1e-12)
    v, _ = PM.landscape(0.5, np.array([0.0, 0.0]), k)
    assert v == pytest.approx(1.0)  # barrier = k/64 for equal wells
    # the rod's drive is −∂E_rod/∂φ: finite difference of the rod energy at frozen shape
    m = RodModel(SHORT, segments=True)
    y = m.initial_state()
    kap, tau = Polymorphism().strains(SHORT.filament)
    phi = np.full(m.n, 0.3)
    strains = m.joint_strains(y)
    rate = np.empty(m.n)
    PM.phi_rate(phi, m.h, np.zeros(3), np.full(2, k), 0.0, 1.0, 3.5, 3.5, strains, np.array(kap),
                np.array(tau), True, rate)
    rate0 = np.empty(m.n)
    PM.phi_rate(phi, m.h, np.zeros(3), np.full(2, k), 0.0, 1.0, 3.5, 3.5, strains, np.array(kap),
                np.array(tau), False, rate0)

    def energy(p):
        kk, tt = np.empty(m.n), np.empty(m.n)
        PM.intrinsic(p, np.array(kap), np.array(tau), kk, tt)
        m.set_intrinsic(kk, tt)
        return m.energy(y)

    j, d = 7, 1e-6
    p1, p2 = phi.copy(), phi.copy()
    p1[j] += d
    p2[j] -= d
    dE = (energy(p1) - energy(p2)) / (2 * d)
    assert -(rate[j] - rate0[j]) * m.h == pytest.approx(dE, rel=1e-6)


@pytest.mark.parametrize("kw, name", [({"forms": ("normal", "straight")}, "polymorphic"),
                                      ({"energies": (0.0, 10.0, 0.0)}, "polymorph_energies"),
                                      ({"barrier": 0.0}, "polymorph_barrier"),
                                      ({"initial": "normal:3"}, "polymorph_initial")])
def test_bad_polymorphism_is_refused(kw, name):
    with pytest.raises(ParameterError, match=name):
        pm = Polymorphism(**kw)
        pm.initial_states(20)


def test_cli_polymorphic_flags(cli, tmp_path):
    out = tmp_path / "p.h5"
    code, text, err = cli("simulate", "--length", 4, "--torque", 0, "--time", 0.004,
                          "--polymorphic", "normal,semicoiled", "--polymorph-initial",
                          "normal:12,semicoiled:8", "--polymorph-energies", "0,1", "-o", out, "--json")
    assert code == 0, err
    res = json.loads(text)
    assert set(res["form_fractions"]) == {"normal", "semicoiled"} and res["domain_walls_final"] == 1
    import xarray as xr

    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds["polymorph"].dims == ("time", "segment") and ds["polymorph"].attrs["units"] == "1"
        assert ds["end_force"].attrs["units"] == "pN" and ds["extension"].attrs["units"] == "um"
    code, _, err = cli("simulate", "--time", 0.004, "--polymorph-barrier", 2)
    assert_one_line_error(code, err, "polymorph_barrier")
    code, _, err = cli("simulate", "--time", 0.004, "--polymorphic", "normal,spiral")
    assert_one_line_error(code, err, "polymorphic")


@pytest.mark.parametrize("thermal", [False, True])
def test_interrupted_polymorphic_run_resumes_bit_identically(thermal, tmp_path, monkeypatch):
    """The order parameters and their random stream are in the checkpoint: a run stopped
    after a checkpoint and resumed writes the same file as one run through."""
    pm = Polymorphism(forms=("normal", "semicoiled"), energies=(0.0, 1.0),
                      initial="normal:10,semicoiled:10")
    kw = dict(thermal=thermal, seed=5, polymorphism=pm,
              solver=SolverOptions(method="implicit", dt=2e-5) if thermal else None)
    run = dict(t_end=0.004, save_every=2e-4, checkpoint_every=1e-3, progress=False)
    ref = Simulator(SHORT, Motor(0.3), **kw).run(output=tmp_path / "ref.h5", **run)
    calls = {"n": 0}
    real = Simulator._record

    def record(self, buf):
        calls["n"] += 1
        if calls["n"] == 8:  # after the first checkpoint (records 0 … 5)
            raise KeyboardInterrupt
        real(self, buf)

    monkeypatch.setattr(Simulator, "_record", record)
    out = tmp_path / "run.h5"
    with pytest.raises(KeyboardInterrupt):
        Simulator(SHORT, Motor(0.3), **kw).run(output=out, **run)
    monkeypatch.undo()
    _, tr = Simulator.resume(out, progress=False)
    np.testing.assert_array_equal(tr.polymorph, ref.polymorph)
    np.testing.assert_array_equal(tr.positions, ref.positions)
    assert tr.meta["polymorph_forms"] == "normal,semicoiled"


def test_a_state_carries_the_order_parameters_into_the_next_stage():
    """Protocols in stages (pull up then down, reverse then forward): from_state continues
    with the order parameters of the state, exactly as one run through."""
    pm = Polymorphism(forms=("normal", "semicoiled"), energies=(0.0, 1.0),
                      initial="normal:10,semicoiled:10")
    one = Simulator(SHORT, Motor(0.0), polymorphism=pm)
    whole = one.run(0.004, save_every=1e-3, progress=False)
    first = Simulator(SHORT, Motor(0.0), polymorphism=pm)
    first.run(0.002, save_every=1e-3, progress=False)
    st = first.state()
    assert st.phi is not None and not np.array_equal(st.phi, pm.initial_states(20))
    second = Simulator.from_state(st, SHORT, Motor(0.0), t=0.002, polymorphism=pm)
    rest = second.run(0.004, save_every=1e-3, progress=False)
    np.testing.assert_allclose(rest.polymorph[-1], whole.polymorph[-1], atol=1e-6)
    assert Simulator(SHORT, Motor(0.0)).state().phi is None


def test_a_barrier_per_pair_of_forms():
    """``barrier`` as one number per neighbouring pair: each pair's equal-well barrier is
    its own (v(m + 1/2) − v(m) = barrier_m, the landscape's closed form), the end wells'
    parabolas take their pair's stiffness, and equal numbers are the scalar barrier bit for
    bit (landscape, and a polymorphic run)."""
    eps = np.zeros(4)
    pm = Polymorphism(forms=("coiled", "normal", "semicoiled", "curly1"), barrier=(1.0, 0.25, 0.05))
    kk = np.array(pm.pair_stiffness())
    assert pm.pair_barriers() == (1.0, 0.25, 0.05)
    for m, b in enumerate(pm.barrier):
        assert PM.pair_landscape(m + 0.5, eps, kk)[0] - PM.pair_landscape(float(m), eps, kk)[0] \
            == pytest.approx(b, rel=1e-12)
    # the parabolas beyond the first and the last form: curvature k a = k/2 (equal wells)
    assert PM.pair_landscape(-0.1, eps, kk)[1] == pytest.approx(-0.1 * 64.0 * 0.5)
    assert PM.pair_landscape(3.1, eps, kk)[1] == pytest.approx(0.1 * 64.0 * 0.05 * 0.5)
    same = Polymorphism(forms=FORMS, barrier=(0.25, 0.25))
    for p in np.linspace(-0.5, 2.5, 31):
        assert PM.pair_landscape(p, eps[:3], np.array(same.pair_stiffness())) == \
            PM.landscape(p, eps[:3], 64.0 * 0.25)
    runs = [Simulator(SHORT, Motor(-1.5), polymorphism=Polymorphism(forms=FORMS, barrier=b))
            .run(5e-3, save_every=1e-3, progress=False) for b in (0.25, (0.25, 0.25))]
    assert np.array_equal(runs[0].polymorph, runs[1].polymorph)
    assert np.array_equal(runs[0].positions, runs[1].positions)
    assert np.any(runs[0].polymorph != 0.0)  # the stress moved φ: the comparison has content
    with pytest.raises(ParameterError, match="polymorph_barrier"):
        Polymorphism(forms=FORMS, barrier=(0.25, 0.25, 0.25))
    with pytest.raises(ParameterError, match="polymorph_barrier"):
        Polymorphism(forms=FORMS, barrier=(0.25, -1.0))


def test_lattice_pinning_of_a_wall_is_negligible_at_the_default_width():
    """Peierls–Nabarro pinning of a discrete wall falls off exponentially with its width
    over the lattice spacing: at the defaults (barrier 0.25 pN, D = 0.5 pN·µm², width
    0.25 µm = 1.25 h at h = 0.2 µm), a wall under a tilt of 10⁻³ of the spinodal drive still
    moves at the continuum Nagumo speed (to 5 %); with a wall 0.4 h wide the lattice pins it
    under a tilt of 0.1 g* (it moves < 1 % of the continuum distance)."""
    h, zeta, n = 0.2, 0.1, 60
    x = (np.arange(n) - n / 2 + 0.5) * h
    z = np.zeros((n, 3))

    def speed(barrier, D, de, T):
        k = np.full(1, 64.0 * barrier)
        phi = 0.5 * (1 - np.tanh(x / PM.wall_width(barrier, D)))
        sub = PM.stable_substep(h, k, D, zeta, np.zeros(2), np.zeros(2), 0.0, 0.0)
        PM.advance(phi, 0.2, math.ceil(0.2 / sub), h, np.zeros(2), k, D, zeta, 0.0, 0.0, z,
                   np.zeros(2), np.zeros(2), False, 0.0, np.zeros((1, 1)))  # relax the wall
        x0 = h * np.sum(phi)
        PM.advance(phi, T, math.ceil(T / sub), h, np.array([0.0, de]), k, D, zeta, 0.0, 0.0, z,
                   np.zeros(2), np.zeros(2), False, 0.0, np.zeros((1, 1)))
        return (h * np.sum(phi) - x0) / T  # > 0: form 1 (left) grows

    de = -1e-3 * PM.spinodal_drive(0.25)  # ε1 < ε0: form 1 grows
    c = -PM.front_speed(0.25, 0.5, zeta, de)  # front_speed counts into form 1: sign flip
    assert speed(0.25, 0.5, de, 4 * h / c) == pytest.approx(c, rel=0.05)
    de = -0.1 * PM.spinodal_drive(0.25)
    c = -PM.front_speed(0.25, 0.05, zeta, de)
    assert abs(speed(0.25, 0.05, de, 20 * h / c)) < 0.01 * c


def test_cli_barrier_per_pair(cli):
    """``--polymorph-barrier`` takes one number or one per neighbouring pair; a wrong count
    or no number is a one-line error naming the flag."""
    code, text, err = cli("simulate", "--length", 4, "--torque", 0, "--time", 0.004,
                          "--polymorphic", "normal,semicoiled,curly1", "--polymorph-barrier",
                          "0.25,0.1", "--json")
    assert code == 0, err
    assert set(json.loads(text)["form_fractions"]) == {"normal", "semicoiled", "curly1"}
    for bad in ("0.25,0.1,0.1", ","):
        code, _, err = cli("simulate", "--length", 4, "--time", 0.004, "--polymorphic",
                           "normal,semicoiled,curly1", "--polymorph-barrier", bad)
        assert_one_line_error(code, err, "polymorph_barrier")


def test_a_joint_pushed_past_the_last_form_returns_under_the_opposite_stress():
    """Beyond the last form the strains are held (no drive), so φ must stay within the
    forms: a joint pushed outwards by a stress that wants an even more curled form sits at
    curly-1 (φ = 2 exactly), and one that had got past it (φ = 2 + 1e-3) returns all the way
    to normal once the rod, held in the normal shape, drives it back (the drive exceeds
    the barriers: the normal helix stores A(Δκ)²/2 + C(Δτ)²/2 ≈ 70 pN in
    curly-1’s intrinsic shape, the barriers are 0.25 pN). Without the bound the joint relaxes
    back to φ = 2 from outside, where it feels no drive, and never crosses."""
    pm = Polymorphism(forms=FORMS)
    kap, tau = map(np.array, pm.strains(SHORT.filament))
    n, h, A, C = 20, 0.2, 3.5, 3.5
    eps, kk = np.zeros(3), np.array(pm.pair_stiffness())
    sub = 0.5 * PM.stable_substep(h, kk.max(), pm.wall_stiffness, pm.friction, kap, tau, A, C)

    def run(phi0, kappa, torsion):
        strains = np.zeros((n, 3))
        strains[:, 1], strains[:, 2] = kappa, torsion
        phi = np.full(n, phi0)
        PM.advance(phi, 2000 * sub, 2000, h, eps, kk, pm.wall_stiffness, pm.friction, A, C,
                   strains, kap, tau, True, 0.0, np.zeros((1, n)))
        return phi

    beyond = run(1.9, 3 * kap[2] - 2 * kap[1], 3 * tau[2] - 2 * tau[1])
    assert np.all(beyond == 2.0)
    back = run(2.0 + 1e-3, kap[0], tau[0])
    assert np.all(back < 1e-6)  # normal again (the well at φ = 0)
    # with noise the walls reflect: φ never leaves [0, 2]
    rng = np.random.default_rng(1)
    phi = np.full(n, 1.99)
    strains = np.zeros((n, 3))
    PM.advance(phi, 200 * sub, 200, h, eps, kk, pm.wall_stiffness, pm.friction, A, C, strains,
               kap, tau, False, 0.05, rng.standard_normal((200, n)))
    assert np.all((phi >= 0.0) & (phi <= 2.0))
