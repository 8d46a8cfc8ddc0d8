"""Loads on the free end: a helix stretched by a small force against Kirchhoff's helical
spring, the force balance of the anchor, a moving trap in series with the helix, the flags."""

import math

import numpy as np
import pytest

from flagellum import Filament, Params
from flagellum.errors import ParameterError
from flagellum.helix import Helix, discrete_helix
from flagellum.motor import Motor
from flagellum.params import EndLoad
from flagellum.simulator import Simulator, SolverOptions

from conftest import assert_one_line_error

SHORT = Params(Filament(length=4.0))


def helical_spring_compliance(f: Filament) -> float:
    """Axial compliance [µm/pN] of a Kirchhoff helix (the continuum helix of Eq. (37)) loaded
    at its two ends by opposite forces along the line through the ends, ends free to turn
    (Castigliano's theorem, linear in the load; Love, *A Treatise on the Mathematical Theory
    of Elasticity*, §270–271): with m(s) = (r(s) − r(0)) × e the moment arm of the unit load,
    1/k = ∫ [(m·t)²/C + (m·n)²/A + (m·b)²/A] ds + ∫ (e·t)²/K ds. Independent of the rod code:
    the continuum helix and a trapezoid rule on a fine grid."""
    hx = Helix.from_filament(f)
    s = np.linspace(0.0, f.length, 20001)
    r, t = hx.positions(s), hx.tangents(s)
    e = (r[-1] - r[0]) / np.linalg.norm(r[-1] - r[0])
    m = np.cross(r - r[0], e)
    mt = np.einsum("ij,ij->i", m, t)
    bend = np.einsum("ij,ij->i", m, m) - mt ** 2  # the normal and binormal parts, both /A
    integrand = mt ** 2 / f.twist_rigidity + bend / f.bend_rigidity
    integrand += np.einsum("ij,j->i", t, e) ** 2 / f.stretch_modulus
    return float(np.trapezoid(integrand, s)), float(np.linalg.norm(r[-1] - r[0]))


def discrete_spring_compliance(f: Filament) -> float:
    """The same for the stress-free discrete helix (:func:`~flagellum.helix.discrete_helix`)
    with A = C: a moment m at joint j turns the outer part by h m/A, so
    1/k = Σ_j h |(r_j − r_0) × e|²/A + Σ_i h (e·t_i)²/K (joints at beads 1 … N−1, bonds i)."""
    assert f.bend_rigidity == f.twist_rigidity
    dh = discrete_helix(f)
    r, h = dh.positions, f.segment_length
    e = (r[-1] - r[0]) / np.linalg.norm(r[-1] - r[0])
    m = np.cross(r[1:-1] - r[0], e)
    return float(h * np.sum(m * m) / f.bend_rigidity
                 + h * np.sum((dh.tangents @ e) ** 2) / f.stretch_modulus)


def _run(load, t_end, params=SHORT):
    sim = Simulator(params, Motor(0.0), end_load=load,
                    solver=SolverOptions(rtol=1e-8, atol=1e-10, frame="lab"))
    return sim, sim.run(t_end, save_every=t_end / 100, progress=False)


def test_small_end_force_stretches_the_helix_as_kirchhoffs_helical_spring_and_the_anchor_balances_it():
    F = 0.3  # pN: the extension is ≈ 0.6 % of the axial length
    comp, l0 = helical_spring_compliance(SHORT.filament)
    _, tr = _run(EndLoad(force=F), 0.4)
    _, tr2 = _run(EndLoad(force=2 * F), 0.4)
    # extension along the load once the end-to-end line has turned onto it (the rigid
    # rotation costs no energy), from the stress-free discrete helix' end-to-end distance
    # (it differs from the continuum one by O((kh)²))
    dh = discrete_helix(SHORT.filament)
    d0 = float(np.linalg.norm(dh.positions[-1] - dh.positions[0]))
    stretch, stretch2 = tr.extension[-1] - d0, tr2.extension[-1] - d0
    # linear response: δ = c F + b F² → c = 2 δ(F)/F − δ(2F)/(2F) (the helix stiffens by
    # ≈ 10 % per pN as it straightens)
    c = 2 * stretch / F - stretch2 / (2 * F)
    assert c == pytest.approx(discrete_spring_compliance(SHORT.filament), rel=0.01)
    # the continuum helix (kh = 0.49): O((kh)²) ≈ 2 % apart
    assert c == pytest.approx(comp, rel=0.05)
    assert d0 == pytest.approx(l0, rel=0.01)
    # force balance: the anchor holds the load, thrust (force on the anchor along e_z) = −F
    assert tr.anchor_force[-1] == pytest.approx([0.0, 0.0, -F], abs=2e-3 * F)
    assert tr.end_force[-1] == F
    assert np.ptp(tr.extension[-10:]) < 1e-4 * stretch  # settled


def test_moving_trap_pulls_through_the_helix_as_two_springs_in_series():
    """Slow pulling (the drag ≈ γL v ≈ 3e-3 pN is negligible): on top of a constant force F0
    that has turned the end-to-end line onto the axis, the trap adds k_s v t with
    1/k_s = 1/k_trap + 1/k_helix; its centre starts at the free end of the given state."""
    F0, k_trap, v, t_end = 0.3, 20.0, 0.1, 0.4
    comp, _ = helical_spring_compliance(SHORT.filament)
    pre, _ = _run(EndLoad(force=F0), 0.4)
    sim = Simulator.from_state(pre.state(), SHORT, Motor(0.0),
                               end_load=EndLoad(force=F0, pull_rate=v, trap_stiffness=k_trap),
                               solver=SolverOptions(rtol=1e-8, atol=1e-10, frame="lab"))
    tr = sim.run(t_end, save_every=t_end / 100, progress=False)
    k_s = 1.0 / (1.0 / k_trap + comp)
    assert tr.end_force[0] == pytest.approx(F0, abs=1e-9)
    # (rel 0.05: the helix' compliance over this range of forces is within ±3 % of its
    # linear response, see the test above)
    assert tr.end_force[-1] - F0 == pytest.approx(k_s * v * t_end, rel=0.05)
    assert tr.anchor_force[-1, 2] == pytest.approx(-tr.end_force[-1], rel=0.01)
    summary = tr.load_summary()
    assert summary["end_force_mean"] > 0 and summary["extension_final"] == tr.extension[-1]


def test_without_a_load_the_records_say_so():
    tr = Simulator(SHORT, Motor(0.5)).run(0.002, save_every=1e-3, progress=False)
    assert np.all(tr.end_force == 0.0)
    z = tr.positions[:, :, 2]
    np.testing.assert_allclose(tr.extension, z[:, 0] - z[:, -1])


@pytest.mark.parametrize("kw, name", [({"force": math.inf}, "end_force"),
                                      ({"trap_stiffness": -1.0}, "trap_stiffness"),
                                      ({"pull_rate": 1.0}, "pull_rate")])
def test_bad_end_loads_are_refused(kw, name):
    with pytest.raises(ParameterError, match=name):
        EndLoad(**kw)


def test_cli_end_load_flags(cli):
    code, out, err = cli("simulate", "--length", 4, "--torque", 0, "--time", 0.004,
                         "--end-force", 0.5, "--json")
    assert code == 0, err
    import json

    res = json.loads(out)
    assert res["end_force_mean"] == 0.5 and res["extension_mean"] > 0
    code, _, err = cli("simulate", "--time", 0.004, "--pull-rate", 1.0)
    assert_one_line_error(code, err, "pull_rate")


def test_a_trap_continued_from_a_state_at_a_later_time_starts_at_its_free_end():
    """from_state(..., t=t0) with a moving trap: its centre is at the state's free end at t0
    (the load starts at the constant part F0, not at F0 + k v t0), so a protocol in stages
    (pull out, then back) continues the load without a jump."""
    F0, k, v, t0 = 0.3, 20.0, 0.1, 5.0
    pre, _ = _run(EndLoad(force=F0), 0.05)
    sim = Simulator.from_state(pre.state(), SHORT, Motor(0.0), t=t0,
                               end_load=EndLoad(force=F0, pull_rate=v, trap_stiffness=k),
                               solver=SolverOptions(rtol=1e-8, atol=1e-10, frame="lab"))
    tr = sim.run(t0 + 0.01, save_every=0.005, progress=False)
    assert tr.end_force[0] == pytest.approx(F0, abs=1e-9)
    assert 0 < tr.end_force[-1] - F0 < k * v * 0.01
