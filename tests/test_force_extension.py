"""Force–extension curves (flagellum.pulling, flagellum.analysis.force_extension): the coiled
form is stress free; a slow pull of a single-state helix follows Kirchhoff's helical spring
both ways; a coiled filament pulled by a trap transforms to the normal form at a threshold
force between the bounds of the landscape's spinodal, with a hysteresis loop that shrinks
with the rate; the loop and threshold analysis against hand-made curves."""

import math

import numpy as np
import pytest

from flagellum import Filament, Params
from flagellum.analysis.force_extension import loop_area, transitions
from flagellum.errors import ParameterError
from flagellum.helix import Helix, discrete_helix
from flagellum.motor import Motor
from flagellum.params import POLYMORPHIC_FORMS, Polymorphism, helix_strains
from flagellum.pulling import pull_cycle, up_down
from flagellum.rod import polymorph as PM
from flagellum.simulator import Simulator
from flagellum.reproduce import force_extension as fe

from test_end_load import discrete_spring_compliance

SHORT = Params(Filament(length=4.0))
CN = ("coiled", "normal")
#: the pulls' landscape (barrier 1 pN, walls 8 pN·µm²): the reproduce target's, docs/polymorphism.md
PULL = fe.LANDSCAPE


def test_coiled_form_is_a_stress_free_equilibrium():
    """Built in the coiled form: zero elastic energy, forces and velocities; a run keeps φ and
    the shape (the form's discrete helix), with zero anchor force. It has the normal form's
    handedness (Calladine's form 1, left-handed like normal)."""
    pm = Polymorphism(forms=CN, initial="coiled")
    sim = Simulator(SHORT, Motor(0.0), polymorphism=pm)
    m = sim.model
    assert m.energy(sim.y) == pytest.approx(0.0, abs=1e-20)
    _, dr, dth, _ = m.gradients(sim.y)
    assert np.abs(dr).max() < 1e-9 and np.abs(dth).max() < 1e-9
    assert np.abs(m.rhs(0.0, sim.y)).max() < 1e-5
    kap, tau = pm.strains(SHORT.filament)
    k, t = helix_strains(*POLYMORPHIC_FORMS["coiled"][:2])
    assert (kap[0], tau[0]) == (k, t) and tau[0] > 0  # right-handed like the default normal
    tr = sim.run(0.01, save_every=2e-3, progress=False)
    assert np.abs(tr.polymorph).max() < 1e-12
    assert np.abs(tr.anchor_force).max() < 1e-8
    np.testing.assert_allclose(tr.positions[-1], tr.positions[0], atol=1e-9)
    dh = discrete_helix(Filament(kappa0=k, tau0=t, length=4.0))
    d = np.linalg.norm(tr.positions[0, -1] - tr.positions[0, 0])
    assert d == pytest.approx(np.linalg.norm(dh.positions[-1] - dh.positions[0]), rel=1e-12)
    assert Helix(k, t, 4.0).pitch == pytest.approx(POLYMORPHIC_FORMS["coiled"][0], rel=1e-12)


def _extension_at(curve, force, branch):
    f, x = curve.force[branch], curve.extension[branch]
    o = np.argsort(f)
    return float(np.interp(force, f[o], x[o]))


def test_slow_pull_of_a_single_state_helix_follows_the_helical_spring_both_ways():
    """A trap (2 pN/µm) moving out at 0.5 µm/s for 1 s and back: the linear response
    c = 2δ(F)/F − δ(2F)/(2F) at F = 0.3 pN (the quadratic stiffening removed, as in
    test_end_load) against the discrete helix' Castigliano compliance (closed form, 1 %),
    the way down on the way up (the drag γ⊥ L v ≈ 6·10⁻³ pN is the only rate effect), and a
    loop area positive and below the drag's work."""
    c = pull_cycle(SHORT, None, trap_stiffness=2.0, schedule=up_down(0.5, 1.0), samples=200)
    dh = discrete_helix(SHORT.filament)
    d0 = float(np.linalg.norm(dh.positions[-1] - dh.positions[0]))
    n = int(np.argmax(c.force))
    up, down = slice(0, n + 1), slice(n, None)
    F = 0.3
    d1, d2 = _extension_at(c, F, up) - d0, _extension_at(c, 2 * F, up) - d0
    assert 2 * d1 / F - d2 / (2 * F) == pytest.approx(discrete_spring_compliance(SHORT.filament), rel=0.01)
    for f in (0.2, 0.4, 0.6, 0.8):
        assert abs(_extension_at(c, f, up) - _extension_at(c, f, down)) < 2e-4  # µm
    # the loop is the drag's work only: positive (dissipation) and below the work of the
    # largest drag on the whole filament, γ⊥ L v, over the way out and back
    span = np.ptp(c.extension)
    assert 0 < loop_area(c.force, c.extension) < 2 * SHORT.gammas[1] * 4.0 * 0.5 * span
    assert np.all(c.rate[:n] == 0.5) and c.rate[-1] == -0.5
    assert c.phi is None and c.positions.shape == (len(c.t), 21, 3)


def _threshold_bounds(curve, pm):
    """At the record of the largest force before the transformation: the spinodal drive
    g* (rod.polymorph.spinodal_drive) against the drive of the end load on a joint,
    g = M·Δ with M the moment of the load about the joint (|M| = F ρ, ρ the joint's distance
    from the load line through the free end) and Δ = (κ', τ') the change of the intrinsic
    strains from coiled to normal (A = C, so Ω − κ = M/A componentwise). Cauchy–Schwarz:
    g ≤ F ρ_max |Δ|, and a joint leaves its well only with g ≥ g* (the wall term only
    holds it back), so F_up ≥ g*/(ρ_max |Δ|): the rigorous lower bound. For a uniform helix
    of radius R and pitch 2πb under an axial load (Love §270), the moment F R splits into a
    twist F R²/ρ and a bend −F R b/ρ (ρ = √(R² + b²)), so g = F R (R τ' − b κ')/ρ and the
    quasi-static threshold is F_s = g* ρ/(R (R τ' − b κ')) at the stretched geometry (R from
    a circle fit of the beads in the xy plane, b/ρ = x/L)."""
    q = curve.fraction()
    j = int(np.argmax(curve.force[:int(np.nonzero(q > 0.5)[0][0]) + 1]))
    pos, F = curve.positions[j], curve.force[j]
    kap, tau = pm.strains(SHORT.filament)
    dk, dt = kap[1] - kap[0], tau[1] - tau[0]
    g = PM.spinodal_drive(pm.barrier, pm.energies[1] - pm.energies[0])
    rho = np.hypot(*(pos[1:-1, :2] - pos[-1, :2]).T)
    lower = g / (rho.max() * math.hypot(dk, dt))
    xy = pos[:, :2]
    sol = np.linalg.lstsq(np.c_[2 * xy, np.ones(len(xy))], (xy ** 2).sum(1), rcond=None)[0]
    R = math.sqrt(sol[2] + sol[0] ** 2 + sol[1] ** 2)
    s = curve.extension[j] / SHORT.filament.length
    rho_h = R / math.sqrt(1 - s * s)
    estimate = g * rho_h / (R * (R * dt - s * rho_h * dk))
    return F, lower, estimate


def test_spinodal_drive_closed_form():
    """g* = k max x(1 − x)(a − x) on [0, a] against a dense grid (equal and unequal wells)."""
    for barrier, de in ((1.0, 0.0), (0.4, 1.0), (2.0, -3.0)):
        k = 64 * barrier
        a = 0.5 + 6 * de / k
        x = np.linspace(0, a, 200001)
        assert PM.spinodal_drive(barrier, de) == pytest.approx(np.max(k * x * (1 - x) * (a - x)), rel=1e-9)
    assert PM.spinodal_drive(1.0) == pytest.approx(64 / (6 * math.sqrt(3)) * 0.5, rel=1e-12)


def test_pulled_coiled_filament_transforms_to_normal_with_a_loop_and_a_threshold_within_bounds():
    """A coiled filament (forms coiled, normal; friction 1 pN·s so that the run is short)
    pulled by a trap of 10 pN/µm at 5 µm/s for 0.8 s and back: it transforms completely,
    the loop ∮F dx is positive,
    and the threshold lies above the rigorous lower bound and above the quasi-static
    estimate (a fast pull overshoots it; see _threshold_bounds). The fully normal filament
    does not transform back: both forms are minima of the landscape at zero load and no
    coiled nucleus is left (no noise)."""
    pm = Polymorphism(forms=CN, initial="coiled", friction=1.0, **PULL)
    c = pull_cycle(SHORT, pm, trap_stiffness=10.0, schedule=up_down(5.0, 0.8), samples=200)
    tr = c.transitions()
    assert tr.fraction_max == 1.0 and tr.t_up < 0.8  # on the way up
    assert math.isnan(tr.force_down)
    F, lower, estimate = _threshold_bounds(c, pm)
    assert F == tr.force_up
    assert lower < estimate < F < 1.5 * estimate
    assert tr.loop_area > 1.0  # pN·µm
    assert c.fraction()[-1] == 1.0


@pytest.mark.slow
@pytest.mark.ci
def test_threshold_and_loop_shrink_with_the_pulling_rate_towards_the_quasi_static_estimate():
    """The same pull at 0.5 and 2 µm/s (friction 1 pN·s): the slower pull transforms at a
    lower force, with a smaller loop, and within 15 % of the quasi-static estimate; after
    its threshold the force drops (the sawtooth of a trap-controlled pull)."""
    pm = Polymorphism(forms=CN, initial="coiled", friction=1.0, **PULL)
    res = {}
    for v in (0.5, 2.0):
        c = pull_cycle(SHORT, pm, trap_stiffness=10.0, schedule=up_down(v, 3.0 / v), samples=200)
        res[v] = (c.transitions(), _threshold_bounds(c, pm))
        if v == 0.5:  # the trap's sawtooth: the force drops as the filament lengthens
            assert c.force[c.t > res[v][0].t_up].min() < 0.5 * res[v][0].force_up
    (slow, (Fs, lo_s, est_s)), (fast, (Ff, lo_f, est_f)) = res[0.5], res[2.0]
    assert slow.force_up < fast.force_up and 0 < slow.loop_area < fast.loop_area
    assert lo_s < slow.force_up and est_s == pytest.approx(slow.force_up, rel=0.15)


def test_transitions_and_loop_area_of_hand_made_curves():
    """A triangle (0, 0) → (1, 1) → (2, 0) → (0, 0) in the (x, F) plane, clockwise: ∮F dx is
    its area, 1 (the trapezoid rule is exact on straight legs). q passes 1/2 just after the
    peak and falls back half way along the bottom leg."""
    s = np.linspace(0, 1, 101)
    x = np.r_[s, 1 + s[1:], 2 - 2 * s[1:]]
    f = np.r_[s, 1 - s[1:], 0 * s[1:]]
    q = np.r_[np.zeros(101), np.ones(100), (2 - 2 * s[1:] > 1.0).astype(float)]
    t = np.arange(len(x), dtype=float)
    tr = transitions(t, f, x, q)
    assert tr.force_up == 1.0 and tr.extension_up == 1.0 and tr.t_up == 101.0
    assert tr.force_down == 0.0 and tr.extension_down == pytest.approx(1.0) and tr.t_down == 250.0
    assert tr.loop_area == pytest.approx(1.0, rel=1e-12)
    assert loop_area(f[::-1], x[::-1]) == pytest.approx(-1.0, rel=1e-12)  # anticlockwise
    assert math.isnan(transitions(t, f, x, np.zeros_like(t)).force_up)


def test_bad_schedules_are_refused():
    for sched, name in (([], "schedule"), ([(1.0,)], "schedule"), ([(-1.0, 1.0)], "schedule duration"),
                        ([(1.0, math.inf)], "pull_rate")):
        with pytest.raises(ParameterError, match=name):
            pull_cycle(SHORT, None, trap_stiffness=1.0, schedule=sched)
    with pytest.raises(ParameterError, match="trap_stiffness"):
        pull_cycle(SHORT, None, trap_stiffness=0.0, schedule=[(1.0, 1.0)])


@pytest.mark.slow
@pytest.mark.ci
def test_reproduce_force_extension_quick(tmp_path, cli):
    """The target from the CLI: figure, data, comparison with Darnton & Berg (2007)'s rows;
    the transformation force from coiled inside their 3–5 pN at the slower rate (their
    abstract; the landscape is the package default, not fitted)."""
    import json

    from flagellum.reproduce.common import pixel_variance

    code, out, err = cli("reproduce", "force-extension", "--out", tmp_path, "--json")
    assert code == 0, err
    res = json.loads(out)
    d = tmp_path / "force-extension"
    assert pixel_variance(d / "force-extension.png") > 2e-3 and (d / "force-extension.pdf").exists()
    assert (d / "curves.csv").read_text(encoding="utf-8").startswith("form,rate [µm/s],t [s],force [pN]")
    assert (d / "force-extension.h5").exists()
    text = (d / "comparison.md").read_text()
    for row in ("transformation force from coiled", "rate dependence", "from normal",
                "reverse transformation"):
        assert row in text
    assert 3.0 < res["force_up_slowest"] < 5.0
    assert res["force_up"] == sorted(res["force_up"])  # faster pulls transform later
    assert all(a > 0 for a in res["loop_area"])
    # the pull from normal goes past Darnton & Berg's 4–7 pN without a transformation
    assert res["normal_force_max"] > 7.0 and res["normal_phi_away_max"] < 0.05


def test_tension_drive_against_the_pulled_rod():
    """The drive of an axial pull on a joint of a stress-free helix towards another form
    (rod.polymorph.tension_drive): the small-load closed form κ (κ τ' − τ κ')/ω³ per pN
    (Love §270's moment F R of an axial load, split into twist and bend) against the drive
    m·Δ = A (Ω2 − κ) κ' + C (Ω3 − τ) τ' measured on the interior joints of the paper's normal
    helix (L = 4 µm) held at F = 0.5 pN (10 %: the helix' stiffening and its ends); at 7 pN
    the measured drive lies between the large-load limit −A κ κ' and the small-load line
    (it saturates). The sign is the model's answer to which form a pull favours: negative
    from normal towards each neighbour, semicoiled, curly-1 and coiled (normal is the least
    curved of them), positive from coiled towards normal."""
    from flagellum.params import EndLoad
    from flagellum.simulator import SolverOptions

    fil = SHORT.filament
    A, C = fil.bend_rigidity, fil.twist_rigidity
    kap, tau = Polymorphism(forms=("normal", "semicoiled", "curly1", "coiled")).strains(fil)
    small = [PM.tension_drive(kap[0], tau[0], kap[m] - kap[0], tau[m] - tau[0]) for m in (1, 2, 3)]
    large = [PM.tension_drive(kap[0], tau[0], kap[m] - kap[0], tau[m] - tau[0], A) for m in (1, 2, 3)]
    assert max(small) < 0 and max(large) < 0
    kc, tc = Polymorphism(forms=CN).strains(fil)
    assert PM.tension_drive(kc[0], tc[0], kc[1] - kc[0], tc[1] - tc[0]) > 0
    assert PM.tension_drive(kc[0], tc[0], kc[1] - kc[0], tc[1] - tc[0], A) > 0
    for F in (0.5, 7.0):
        sim = Simulator(SHORT, Motor(0.0), end_load=EndLoad(force=F), solver=SolverOptions(frame="lab"))
        sim.run(0.3, save_every=0.1, progress=False)
        s = sim.model.joint_strains(sim.y)[2:-2]
        for m, g0, ginf in zip((1, 2, 3), small, large):
            g = np.mean(A * (s[:, 1] - kap[0]) * (kap[m] - kap[0]) + C * (s[:, 2] - tau[0]) * (tau[m] - tau[0]))
            if F == 0.5:
                assert g == pytest.approx(F * g0, rel=0.1)
            else:
                assert max(F * g0, ginf) < g < 0


def test_pulled_normal_filament_does_not_transform_past_the_measured_window():
    """A normal filament between its neighbours in Calladine's sequence (forms coiled,
    normal, semicoiled) and one with curly-1 (forms normal, curly1), a barrier of 0.05 pN
    (spinodal drive 0.15 pN/µm, a fifth of the defaults'), pulled by a trap of 10 pN/µm at
    2 µm/s to above 7 pN, the top of Darnton & Berg's 4–7 pN window for the transformation
    from normal, and back: no joint leaves the normal form's well (|φ − normal| < 0.02, its
    top is at 1/2; measured 0.0065 between two neighbours, where the joint sits at the kink of
    the two pairs' slopes, and below 10⁻³ with one neighbour), the pull
    drives it away from every neighbour (test_tension_drive_against_the_pulled_rod), and the
    curve has no loop beyond the drag's work (as the single-state helix,
    test_slow_pull_of_a_single_state_helix_follows_the_helical_spring_both_ways). A
    prediction of the model, in disagreement with the experiment (docs/polymorphism.md)."""
    for forms in (("coiled", "normal", "semicoiled"), ("normal", "curly1")):
        pm = Polymorphism(forms=forms, initial="normal", barrier=0.05)
        c = pull_cycle(SHORT, pm, trap_stiffness=10.0, schedule=up_down(2.0, 0.75), samples=100)
        assert c.force.max() > 7.0
        assert np.abs(c.phi - forms.index("normal")).max() < (0.02 if len(forms) == 3 else 1e-3)
        assert c.fraction(forms.index("normal")).min() == 1.0
        span = np.ptp(c.extension)
        assert abs(loop_area(c.force, c.extension)) < 2 * SHORT.gammas[1] * 4.0 * 2.0 * span


def test_coiled_threshold_in_the_measured_window_rises_with_the_rate_and_does_not_return():
    """The target's filament (forms coiled, normal; reproduce.force_extension.LANDSCAPE)
    pulled by a trap of 10 pN/µm at 4 and 16 µm/s, out 3 µm and back: the transformation
    force lies in Darnton & Berg's 3–5 pN (their abstract, from coiled) at both rates, the
    faster pull transforms at the higher force (the order parameter's delay; their
    thresholds also rise with the rate), and on unloading the filament stays normal down to
    zero load (no coiled nucleus is left and there is no noise): a hysteresis loop of
    positive area."""
    pm = Polymorphism(forms=CN, initial="coiled", **PULL)
    up = {}
    for v in (4.0, 16.0):
        c = pull_cycle(SHORT, pm, trap_stiffness=10.0, schedule=up_down(v, 3.0 / v), samples=150)
        tr = c.transitions()
        assert fe.DB_COILED[0] < tr.force_up < fe.DB_COILED[1]
        assert math.isnan(tr.force_down) and c.fraction()[-1] == 1.0 and c.force[-1] < 0.5
        assert tr.loop_area > 1.0  # pN·µm
        up[v] = tr.force_up
    assert up[4.0] < up[16.0]
