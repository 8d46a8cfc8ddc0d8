"""Run and tumble: the tumble-angle analysis (flagellum.analysis.tumble), the free cell with a
polymorphic flagellum under a reversing motor, and the movies coloured by form (viz)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flagellum.analysis.tumble import angle_deg, angle_distribution, mean_velocity, tumble
from flagellum.errors import ParameterError
from flagellum.motor import Boundary, Motor
from flagellum.params import Params, Polymorphism
from flagellum.rod.model import RodModel

# -- the analysis against synthetic trajectories (closed forms) --------------------------


def _rotation(axis, angle):
    """Rodrigues' rotation matrix."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _swimmer(theta, v=30.0, wobble=0.0, omega=2 * math.pi * 50, t_on=0.2, t_off=0.5,
             t_end=0.8, rate=2000):
    """A body that swims at speed v along d0 = e_z until t_on, stops turning over the
    reversal, and swims along d1 = R(θ about e_x + e_y) d0 after t_off; a helical path of
    radius ``wobble`` at angular frequency ω about each run's direction."""
    t = np.arange(0.0, t_end + 0.5 / rate, 1.0 / rate)
    d0 = np.array([0.0, 0.0, 1.0])
    R = _rotation([1.0, 1.0, 0.0], theta)
    d1 = R @ d0
    e1, e2 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    pos = np.empty((len(t), 3))
    axis = np.empty((len(t), 3))
    x_on = v * t_on * d0
    for i, s in enumerate(t):
        if s <= t_on:
            c, a, b, u = v * s * d0, e1, e2, d0
        elif s < t_off:  # the tumble: the body turns on the spot
            f = (s - t_on) / (t_off - t_on)
            c, a, b, u = x_on, _rotation([1, 1, 0], f * theta) @ e1, _rotation([1, 1, 0], f * theta) @ e2, \
                _rotation([1, 1, 0], f * theta) @ d0
        else:
            c, a, b, u = x_on + v * (s - t_off) * d1, R @ e1, R @ e2, d1
        pos[i] = c + wobble * (math.cos(omega * s) * a + math.sin(omega * s) * b)
        axis[i] = u
    return t, pos, axis


@pytest.mark.parametrize("theta_deg", [0.0, 0.5, 30.0, 68.0, 120.0, 179.5])
def test_tumble_angle_of_a_known_rotation(theta_deg):
    """Straight runs before and after a rotation by θ: the tumble angle is θ (closed form:
    the least-squares velocity of a uniform motion is that motion's velocity), also near
    0° and 180° (atan2 of |u × v| and u·v keeps its accuracy there)."""
    th = math.radians(theta_deg)
    t, pos, axis = _swimmer(th)
    s = tumble(t, pos, axis, (0.2, 0.5), window=0.1)
    assert s.tumble_angle_deg == pytest.approx(theta_deg, abs=1e-7)
    assert s.axis_tumble_angle_deg == pytest.approx(theta_deg, abs=1e-7)
    assert s.speed_before == pytest.approx(30.0, rel=1e-10)
    assert s.speed_after == pytest.approx(30.0, rel=1e-10)
    assert math.isnan(s.transform_time)  # no polymorph given
    # without polymorphic state the recovered window starts at t_off (0.5 … 0.6 s, inside
    # the straight second run)
    assert s.settle_time == 0.0
    assert s.recovered_tumble_angle_deg == pytest.approx(theta_deg, abs=1e-7)


def _wobble_bound(v, r, omega, window):
    """Largest angle [deg] between the least-squares velocity of a run with a helical path
    of radius r at frequency ω and its true direction: the least-squares slope of
    r sin(ωt + ψ) over a window W is at most 12 r/(ω W²) (1 + O(1/(ωW))) (the slope
    12/W³ ∫ (t − W/2) r sin(ωt + ψ) dt over [0, W]; its leading term ∓12 r cos/(ω W²) at
    the window's ends), once per window."""
    return math.degrees(math.atan(12.0 * r / (omega * window ** 2) * (1 + 2 / (omega * window)) / v))


def _lsq_slope(r, omega, a, b):
    """Least-squares slope over [a, b] of the circle r (cos ωt, sin ωt) (continuous, closed
    form): 12/W³ ∫ (t − m) r (cos ωt, sin ωt) dt, W = b − a, m = (a + b)/2."""
    m, w = 0.5 * (a + b), b - a

    def ic(t):
        return (t - m) * math.sin(omega * t) / omega + math.cos(omega * t) / omega ** 2

    def is_(t):
        return -(t - m) * math.cos(omega * t) / omega + math.sin(omega * t) / omega ** 2

    return 12.0 * r / w ** 3 * np.array([ic(b) - ic(a), is_(b) - is_(a)])


def _wobble_bound(v, r, omega, window):
    """Largest tilt [deg] of a run's least-squares velocity by a helical path of radius r at
    frequency ω over a window W: |:func:`_lsq_slope`| ≤ 12 r/(ω W²) (1 + 2/(ωW)) (the
    integrals' boundary terms), against the speed v."""
    return math.degrees(math.atan(12.0 * r / (omega * window ** 2) * (1 + 2 / (omega * window)) / v))


@pytest.mark.parametrize("theta_deg", [0.0, 45.0, 120.0])
def test_tumble_angle_with_wobble_against_the_closed_form(theta_deg):
    """A helical path (r = 0.3 µm at 50 Hz, v = 30 µm/s) tilts each run's least-squares
    velocity by the closed-form slope of :func:`_lsq_slope`; with the windows at different
    phases of the path (t_off = 0.5075 s) the tumble angle is the angle between the tilted
    velocities (to 0.1°: the records are 0.5 ms apart, the closed form is continuous),
    which differs from θ by up to 4° here, within twice :func:`_wobble_bound`."""
    r, omega, v, W = 0.3, 2 * math.pi * 50, 30.0, 0.1
    th = math.radians(theta_deg)
    t, pos, axis = _swimmer(th, v=v, wobble=r, omega=omega, t_off=0.5075, t_end=0.8075)
    s = tumble(t, pos, axis, (0.2, 0.5075), window=W)
    R = _rotation([1.0, 1.0, 0.0], th)
    e1, e2, d0 = np.eye(3)
    c0, c1 = _lsq_slope(r, omega, 0.1, 0.2), _lsq_slope(r, omega, t[-1] - W, t[-1])
    v0 = v * d0 + c0[0] * e1 + c0[1] * e2
    v1 = R @ (v * d0 + c1[0] * e1 + c1[1] * e2)
    expected = angle_deg(v0, v1)
    assert s.tumble_angle_deg == pytest.approx(expected, abs=0.1)
    assert abs(s.tumble_angle_deg - theta_deg) <= 2 * _wobble_bound(v, r, omega, W)
    if theta_deg == 0.0:  # the wobble alone: a small angle the test can tell from 0
        assert 1.0 < expected < 2 * _wobble_bound(v, r, omega, W)


def test_time_course_of_a_synthetic_transformation():
    """A semicoiled domain grows from the hook by one joint every 1/40 s from t_on = 0.2 s and,
    once the motor is forward again at t_off = 0.8 s, shrinks at the same pace: of 20 joints
    fewer than half are normal first with 11 semicoiled joints (t = t_on + 11/40 s), and
    half are normal again with 10 left (t = t_off + 10/40 s)."""
    t, pos, axis = _swimmer(0.3, t_on=0.2, t_off=0.8, t_end=1.4)
    n = 20
    k = np.clip(np.floor((t - 0.2) * 40 + 1e-9), 0, n) - np.clip(np.floor((t - 0.8) * 40 + 1e-9), 0, n)
    phi = (np.arange(n)[None, :] < k[:, None]).astype(float)
    s = tumble(t, pos, axis, (0.2, 0.8), 0.1, phi, ("normal", "semicoiled", "curly1"))
    assert s.transform_time == pytest.approx(11 / 40, abs=1e-3)
    assert s.recovery_time == pytest.approx(10 / 40, abs=1e-3)
    assert s.transformed_fraction_max == 1.0 and s.normal_fraction_final == 1.0
    # wholly normal again when the last of the 20 joints has turned back, t_off + 20/40 s;
    # the window from then on sees the second run's straight motion: the angle is θ
    assert s.settle_time == pytest.approx(20 / 40, abs=1e-3)
    assert s.recovered_tumble_angle_deg == pytest.approx(math.degrees(0.3), abs=1e-7)
    assert s.speed_recovered == pytest.approx(30.0, rel=1e-10)
    assert s.sequence == ("semicoiled",)
    assert s.peak_fractions == {"normal": 1.0, "semicoiled": 1.0, "curly1": 0.0}


def test_analysis_helpers_and_bad_windows():
    assert angle_deg([1, 0, 0], [0, 1, 0]) == pytest.approx(90.0)
    assert math.isnan(angle_deg([0, 0, 0], [1, 0, 0]))
    assert np.all(np.isnan(mean_velocity([0.0, 1.0], np.zeros((2, 3)), 5.0, 6.0)))
    t, pos, axis = _swimmer(0.0)
    with pytest.raises(ParameterError, match="reversal"):
        tumble(t, pos, axis, (0.5, 0.2))
    with pytest.raises(ParameterError, match="window"):
        tumble(t, pos, axis, (0.2, 0.5), window=0.0)
    # a record that ends before the window after the recovery is full has no angle there
    t, pos, axis = _swimmer(0.3, t_end=0.55)
    s = tumble(t, pos, axis, (0.2, 0.5), window=0.1)
    assert math.isnan(s.recovered_tumble_angle_deg) and math.isnan(s.speed_recovered)


def test_angle_distribution_of_random_directions_against_the_closed_form():
    """Directions drawn at random on the sphere: the angle θ between two of them has the
    density sin θ / 2 on [0, π], so the mean is 90°, the standard deviation
    √(π²/4 − 2) = 39.17°, the median 90°, the quartiles arccos(±1/2) = 60° and 120°, ⟨cos θ⟩ = 0,
    and a 20° bin [a, b] holds the fraction (cos a − cos b)/2 (200 000 samples: statistical
    errors ≈ 0.1°, 0.002 in the mean cosine, 0.001 in a bin's fraction)."""
    rng = np.random.default_rng(1)
    u, v = (rng.normal(size=(200_000, 3)) for _ in range(2))
    cosines = np.einsum("ij,ij->i", u, v) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
    ang = np.degrees(np.arccos(np.clip(cosines, -1, 1)))
    assert [angle_deg(a, b) for a, b in zip(u[:100], v[:100])] == pytest.approx(ang[:100], abs=1e-9)
    d = angle_distribution(np.append(ang, np.nan))
    assert d["n"] == len(ang)
    assert d["mean"] == pytest.approx(90.0, abs=0.4)
    assert d["sd"] == pytest.approx(math.degrees(math.sqrt(math.pi ** 2 / 4 - 2)), abs=0.3)
    assert d["median"] == pytest.approx(90.0, abs=0.5)
    assert d["q25"] == pytest.approx(60.0, abs=0.5) and d["q75"] == pytest.approx(120.0, abs=0.5)
    assert d["mean_cos"] == pytest.approx(0.0, abs=0.01)
    edges = np.radians(d["edges"])
    expected = (np.cos(edges[:-1]) - np.cos(edges[1:])) / 2
    assert np.asarray(d["counts"]) / len(ang) == pytest.approx(expected, abs=0.004)
    assert sum(d["counts"]) == len(ang)
    few = angle_distribution([10.0, 30.0, 170.0])
    assert few["counts"][:2] == [1, 1] and few["counts"][-1] == 1
    assert few["mean"] == pytest.approx(70.0) and few["median"] == pytest.approx(30.0)
    empty = angle_distribution([math.nan])
    assert empty["n"] == 0 and math.isnan(empty["mean"]) and sum(empty["counts"]) == 0


# -- the free cell with a polymorphic flagellum ------------------------------------------

LANDSCAPE = {"forms": ("normal", "semicoiled", "curly1"), "barrier": 0.1, "wall_stiffness": 0.5}
CELL = Boundary(anchor="free", body_radius=0.44, body_aspect=2.5 / 0.88, hook="elastic",
                hook_stiffness=5.0)


@pytest.mark.parametrize("t", [0.05, 0.15], ids=["forward", "reversed"])
def test_polymorphic_cell_with_a_reversing_motor_is_force_and_torque_free(t):
    """Stokes flow has no inertia, so the cell is free: the fluid's total force and torque on
    it vanish (summed from the right-hand side's velocities, as in tests/test_cell.py), also
    with a filament of mixed forms (normal | semicoiled | curly-1 joints: per-joint intrinsic
    strains) and the motor reversed (t = 0.15 s lies in its CW interval 0.1–0.2 s)."""
    from test_cell import _balance, _state

    from flagellum.rod import polymorph as PM

    p = Params().replace(length=4.0)
    m = RodModel(p, Motor(1.3, reversals=(0.1, 0.2)), CELL, segments=True)
    pm = Polymorphism(**LANDSCAPE)
    kap_f, tau_f = (np.array(v) for v in pm.strains(p.filament))
    phi = np.concatenate([np.zeros(7), np.full(6, 1.0), np.full(7, 2.0)])
    phi[6:8] = 0.4, 0.9  # and a wall in between
    kap, tau = np.empty(m.n), np.empty(m.n)
    PM.intrinsic(phi, kap_f, tau_f, kap, tau)
    m.set_intrinsic(kap, tau)
    y = _state(m, np.random.default_rng(3))
    F, T, scale, bm, _ = _balance(m, y, t)
    assert bm["torque"] == pytest.approx(1.3 if t < 0.1 else -1.3)
    assert np.abs(F).max() < 1e-11 * scale
    assert np.abs(T).max() < 5e-11 * scale


def _cell_run(reversals, t_end, landscape=LANDSCAPE):
    from flagellum.simulator import Simulator, SolverOptions

    sim = Simulator(Params().replace(length=4.0), Motor(1.3, reversals=reversals), CELL,
                    polymorphism=Polymorphism(**landscape), solver=SolverOptions(frame="lab"))
    return sim.run(t_end, save_every=2e-3, progress=False)


@pytest.mark.slow
@pytest.mark.ci
def test_reversal_transforms_the_cell_s_filament_and_it_recovers():
    """A reversal for 0.3 s (the landscape and set-up of ``reproduce tumble``): a semicoiled
    domain nucleates at the hook and takes the whole filament, curly-1 follows it (the
    sequence of Turner, Ryu & Berg 2000), the forward motor turns it back to normal, and the
    cell swims on at the speed it had (the same forward run, so the same speed: to 5 %; the
    tumble angle is a regression value of this landscape, docs/polymorphism.md, not
    asserted). The run must not fail at the switches (the stepper restarts there)."""
    from flagellum.reproduce.tumble import LANDSCAPE as TARGET, RUN_AFTER, RUN_BEFORE

    tr = _cell_run((RUN_BEFORE, RUN_BEFORE + 0.3), RUN_BEFORE + 0.3 + RUN_AFTER, TARGET)
    s = tr.tumble_summary()
    assert s.reversal_start == pytest.approx(0.15) and s.reversal_end == pytest.approx(0.45)
    assert s.transformed_fraction_max > 0.9
    assert s.peak_fractions["semicoiled"] > 0.9
    assert s.sequence == ("semicoiled", "curly1") and s.peak_fractions["curly1"] > 0.1
    assert s.normal_fraction_final > 0.9
    assert 0.0 < s.transform_time < 0.3 and 0.0 < s.recovery_time < RUN_AFTER - 0.1
    assert s.speed_after == pytest.approx(s.speed_before, rel=0.05)
    assert 0.0 <= s.tumble_angle_deg <= 180.0


@pytest.mark.slow
@pytest.mark.ci
def test_a_wholly_curly1_filament_returns_to_normal():
    """A reversal for 0.7 s (the target's landscape and set-up): the whole filament turns
    curly-1, and at forward torque it returns through semicoiled to normal and the cell swims
    on at its old speed (to 5 %). The return comes from the second pair's barrier of the
    target, 0.1 pN: with 0.25 pN the filament stays curly-1 (one run, docs/polymorphism.md,
    "Run and tumble"; this test then fails on the final share of normal)."""
    from flagellum.reproduce.tumble import LANDSCAPE as TARGET, RUN_AFTER, RUN_BEFORE

    tr = _cell_run((RUN_BEFORE, RUN_BEFORE + 0.7), RUN_BEFORE + 0.7 + RUN_AFTER, TARGET)
    s = tr.tumble_summary()
    assert s.peak_fractions["curly1"] == 1.0
    assert s.normal_fraction_final == 1.0
    assert 0.0 < s.recovery_time < RUN_AFTER - 0.1
    assert s.speed_after == pytest.approx(s.speed_before, rel=0.05)


@pytest.mark.slow
@pytest.mark.ci
def test_run_without_reversal_has_a_wobble_limited_tumble_angle():
    """The same cell without reversal: the 'tumble angle' between two windows of one steady
    run is only the wobble's tilt of each window's least-squares velocity, below the closed
    form of :func:`_wobble_bound` with the path's radius (the body centre's largest distance
    from the window's fitted line) and its angular frequency (the body's rotation rate)."""
    tr = _cell_run(None, 0.55)
    s = tr.tumble_summary(reversal=(0.15, 0.15 + 1e-9), window=0.1)
    assert s.normal_fraction_final == 1.0 and s.transformed_fraction_max == 0.0
    bounds = []
    for t0, t1 in ((0.05, 0.15), (0.45, 0.55)):
        sel = (tr.t >= t0) & (tr.t <= t1)
        x = tr.body_position[sel]
        v = mean_velocity(tr.t, tr.body_position, t0, t1)
        u = v / np.linalg.norm(v)
        line = x[0] + np.outer(tr.t[sel] - tr.t[sel][0], v)
        d = x - line
        r = float(np.max(np.linalg.norm(d - np.outer(d @ u, u), axis=1)))
        omega = float(np.abs(np.mean(tr.body_rotation_rate[sel])))
        bounds.append(_wobble_bound(np.linalg.norm(v), r, omega, 0.1))
    assert s.tumble_angle_deg <= sum(bounds)
    assert s.tumble_angle_deg < 3.0


# -- movies coloured by form -------------------------------------------------------------

def _decoded(path):
    """The frames of an MP4, decoded by imageio (as tests/test_viz.py reads them)."""
    import imageio.v2 as imageio

    reader = imageio.get_reader(str(path), format="FFMPEG")
    frames = [f for f in reader]
    reader.close()
    return frames


def _rgb(hex_colour):
    return np.array([int(hex_colour[i:i + 2], 16) for i in (1, 3, 5)], float)


def _count(img, hex_colour, tol=40.0):
    """Pixels within ``tol`` (per channel, after H.264's colour loss) of a colour."""
    return int(np.sum(np.all(np.abs(img[..., :3].astype(float) - _rgb(hex_colour)) < tol, axis=-1)))


def test_movie_colours_segments_by_form_and_draws_the_body(tmp_path):
    """A filament whose outer half is semicoiled: the movie's frames (decoded from the MP4)
    hold many more pixels of the semicoiled colour than the same movie with all joints
    normal (where it is only the legend's patch), and fewer of the normal colour; the
    body's outline adds grey pixels to the frames of the movie without it."""
    from flagellum.helix import discrete_helix
    from flagellum.viz import FORM_COLORS, movie

    dh = discrete_helix(Params().replace(length=4.0).filament)
    n = len(dh.positions) - 1
    pos = np.repeat(dh.positions[None], 3, axis=0)
    t = np.array([0.0, 0.01, 0.02])
    body = {"position": pos[:, 0] + np.array([0.0, 0.0, 1.3]), "axis": np.tile([0.0, 0.0, 1.0], (3, 1)),
            "radius": 0.44, "aspect": 2.84}
    normal, mixed = np.zeros((3, n)), np.tile((np.arange(n) >= n // 2).astype(float), (3, 1))
    frames = {}
    for label, phi, b in (("normal", normal, body), ("mixed", mixed, body), ("nobody", normal, None)):
        out = tmp_path / f"{label}.mp4"
        assert movie(t, pos, out, max_frames=3, polymorph=phi, forms=LANDSCAPE["forms"], body=b) == 3
        frames[label] = _decoded(out)
        assert len(frames[label]) == 3

    def counts(label, colour, tol=40.0):
        return [_count(f, colour, tol) for f in frames[label]]

    assert min(counts("mixed", FORM_COLORS[1])) > 3 * max(counts("normal", FORM_COLORS[1])) + 200
    assert min(counts("normal", FORM_COLORS[0])) > max(counts("mixed", FORM_COLORS[0])) + 200
    grey = "#595959"  # the outline's colour, 0.35 grey
    assert min(counts("normal", grey, 25)) > max(counts("nobody", grey, 25)) + 100


def test_movie_without_polymorph_keeps_the_curvature_colours(tmp_path):
    """Without ``polymorph`` the frames are coloured by curvature (viridis) as before: no
    pixel of the semicoiled colour (orange) appears."""
    from flagellum.helix import discrete_helix
    from flagellum.viz import FORM_COLORS, movie

    dh = discrete_helix(Params().replace(length=4.0).filament)
    pos = np.repeat(dh.positions[None], 2, axis=0)
    out = tmp_path / "plain.mp4"
    movie(t=np.array([0.0, 0.01]), positions=pos, path=out, max_frames=2)
    frames = _decoded(out)
    assert max(_count(f, FORM_COLORS[1]) for f in frames) < 20


def test_cli_cell_with_reversals_reports_the_tumble_and_renders_by_form(cli, tmp_path):
    """``flagellum simulate`` of a polymorphic cell with two reversal times adds the tumble
    fields to its summary; ``flagellum render`` of its file colours by form and draws the
    body (the movie's frames hold the normal form's colour, which the curvature colouring
    never gives: checked above). A short run (L = 2 µm, 20 ms): the pipeline, not the
    physics."""
    import json

    out = tmp_path / "cell.h5"
    code, stdout, err = cli("simulate", "--body-radius", "0.44", "--body-aspect", "2.84",
                            "--hook-stiffness", "5", "--length", "2", "--torque", "1.3",
                            "--polymorphic", "normal,semicoiled", "--reversal-times", "0.006,0.012",
                            "--time", "0.02", "--save-every", "0.001", "--json", "-o", str(out))
    assert code == 0, err
    d = json.loads(stdout)
    for k in ("tumble_angle_deg", "axis_tumble_angle_deg", "speed_before", "speed_after"):
        assert math.isfinite(d[k]), k
    assert d["reversal_start"] == 0.006 and d["reversal_end"] == 0.012 and d["window"] > 0
    mp4 = tmp_path / "m.mp4"
    code, stdout, err = cli("render", str(out), "--movie", str(mp4), "--frames", "2", "--json")
    assert code == 0, err
    from flagellum.viz import FORM_COLORS

    frames = _decoded(mp4)
    assert len(frames) == 2 and _count(frames[-1], FORM_COLORS[0]) > 200


def test_reproduce_tumble_writes_its_files_and_table(tmp_path, monkeypatch):
    """The target's analyse → plot → write → compare steps on stand-in runs (synthetic
    swimmers turned by known angles, a domain growing and shrinking; the simulations
    themselves are the slow tests above): the mean of the angles, the CSV and HDF5, a
    figure that is not blank, and the table with Berg & Brown's 68°."""
    import flagellum.reproduce.tumble as T
    from flagellum.reproduce import reproduce
    from flagellum.reproduce.common import pixel_variance
    from flagellum.rod.polymorph import fractions

    def fake(job):
        d = job["duration"]
        theta = 40.0 * d / 0.35 if d > 0 else 0.0
        t, pos, axis = _swimmer(math.radians(theta), t_on=T.RUN_BEFORE, t_off=T.RUN_BEFORE + d + 1e-9,
                                t_end=T.RUN_BEFORE + d + T.RUN_AFTER + job.get("extra", 0.0),
                                rate=T.RATE)
        # the longest reversal's filament stays transformed (no run after it: left out)
        back = d < max(T.DURATIONS["quick"])
        k = np.clip(np.floor((t - T.RUN_BEFORE) * 40), 0, 20) * ((t < T.RUN_BEFORE + d + 0.1) | (not back))
        phi = (np.arange(20)[None, :] < k[:, None]).astype(float)
        s = tumble(t, pos, axis, (T.RUN_BEFORE, T.RUN_BEFORE + d + 1e-9), 0.1, phi, T.LANDSCAPE["forms"])
        out = {"duration": d, "phase": job["phase"], **s.to_dict(), "wall_seconds": 0.0}
        out.pop("peak_fractions")
        out.update({f"peak_{f}": v for f, v in s.peak_fractions.items()})
        out["series"] = {"t": t, "torque": np.ones_like(t), "fractions": fractions(phi, 3),
                         "body_position": pos, "body_axis": axis}
        return out

    monkeypatch.setattr(T, "pmap", lambda fun, jobs: [fake(j) for j in jobs])
    res = reproduce("tumble", tmp_path, "quick")
    angles = [40.0 * d / 0.35 for d in T.DURATIONS["quick"]][:-1]
    assert res["runs"] == len(angles) + 1 and res["failed"] == 0 and res["not_recovered"] == 1
    assert res["tumble_angle_mean_deg"] == pytest.approx(np.mean(angles), abs=1e-6)
    assert res["control_angle_deg"] == pytest.approx(0.0, abs=1e-6)
    # the stand-ins are wholly normal again 0.1 s after t_off and swim straight from then on:
    # right after the recovery the angle is already the final one; the straight control
    # has not turned over the same delay
    assert res["settle_time"] == pytest.approx(0.1, abs=2.0 / T.RATE)
    assert res["recovered_angle_mean_deg"] == pytest.approx(np.mean(angles), abs=1e-6)
    assert res["recovered_angles"] == len(angles)
    assert res["control_recovered_angle_deg"] == pytest.approx(0.0, abs=1e-6)
    out = tmp_path / "tumble"
    assert res["tumble_angle_median_deg"] == pytest.approx(np.median(angles), abs=1e-6)
    assert res["tumble_angle_mean_cos"] == pytest.approx(np.mean(np.cos(np.radians(angles))), abs=1e-9)
    assert sum(res["histogram_counts"]) == len(angles)
    for name in ("tumble.png", "tumble.pdf", "tumbles.csv", "tumble_angles.csv", "tumble.h5",
                 "comparison.md"):
        assert (out / name).exists(), name
    assert pixel_variance(out / "tumble.png") > 1e-3
    csv = (out / "tumbles.csv").read_text().splitlines()
    assert csv[0].startswith("duration [s],phase [s],tumble_angle_deg [deg]") and len(csv) == len(angles) + 3
    hist = (out / "tumble_angles.csv").read_text().splitlines()
    assert len(hist) == 1 + len(res["histogram_counts"])  # the header, one row per bin
    table = (out / "comparison.md").read_text()
    assert "Berg & Brown" in table and "| 68 |" in table and "normal → semicoiled" in table
    from flagellum.hydro.options import Hydrodynamics
    from flagellum.reproduce.shared import Cache

    sbt = Cache(hydrodynamics=Hydrodynamics(model="sbt"))
    seen = []
    monkeypatch.setattr(T, "pmap", lambda fun, jobs: seen.extend(jobs) or [fake(j) for j in jobs])
    assert T.compute("quick", sbt).hydrodynamics == "sbt"
    assert all(j["hydrodynamics"]["model"] == "sbt" for j in seen)  # every run gets the mobility
    monkeypatch.setattr(T, "THERMAL", True)  # thermal runs with SBT: the mobility and a seed each
    seen.clear()
    T.compute("quick", sbt)
    assert all(j["hydrodynamics"]["model"] == "sbt" and j["seed"] is not None for j in seen)


def test_the_target_s_runs_are_thermal_with_a_seed_each(monkeypatch):
    """With ``THERMAL`` the sweep runs each setting ``THERMAL_REPEATS`` times and gives every
    run (and the control) its own seed (without,
    none: the default); a run with a seed is a thermal run (the same seed the same path, another seed another path, and no seed the
    deterministic run). Short windows (0.04 s) for speed."""
    import flagellum.reproduce.tumble as T

    seen = []
    monkeypatch.setattr(T, "pmap", lambda fun, jobs: seen.extend(jobs) or [{"error": "-"}] * len(jobs))
    T.compute("quick")
    assert [j["seed"] for j in seen] == [None] * (len(T.DURATIONS["quick"]) + 1)  # the default
    seen.clear()
    monkeypatch.setattr(T, "THERMAL", True)
    T.compute("quick")
    n = len(T.DURATIONS["quick"]) * T.THERMAL_REPEATS  # several runs per setting, then the control
    assert [j["seed"] for j in seen] == list(range(1, n + 2))
    assert [j["duration"] for j in seen[:-1]] == [d for d in T.DURATIONS["quick"]
                                                   for _ in range(T.THERMAL_REPEATS)]
    monkeypatch.setattr(T, "RUN_BEFORE", 0.02)
    monkeypatch.setattr(T, "RUN_AFTER", 0.02)
    runs = [T.run_one({"duration": 0.0, "seed": s, "window": 0.01}) for s in (1, 1, 2, None)]
    assert all("error" not in r for r in runs), runs
    pos = [r["series"]["body_position"] for r in runs]
    assert np.array_equal(pos[0], pos[1])
    assert not np.allclose(pos[0], pos[2]) and not np.allclose(pos[0], pos[3])
    assert runs[0]["seed"] == 1.0 and math.isnan(runs[3]["seed"])


def test_the_target_s_cell_swims_slower_with_slender_body_hydrodynamics(monkeypatch):
    """``reproduce tumble --hydrodynamics sbt``: the runs use the nonlocal mobility, whose
    thrust per torque is lower than RFT's (docs/hydrodynamics.md: about 0.6 against 1.02 /µm
    for the rigid helix), so the same cell at the same torque swims slower (short windows,
    no reversal)."""
    import flagellum.reproduce.tumble as T

    monkeypatch.setattr(T, "RUN_BEFORE", 0.03)
    monkeypatch.setattr(T, "RUN_AFTER", 0.01)
    speed = {}
    for model in ("rft", "sbt"):
        r = T.run_one({"duration": 0.0, "window": 0.02, "hydrodynamics": {"model": model}})
        assert "error" not in r, r
        speed[model] = r["speed_before"]
    assert 0.3 * speed["rft"] < speed["sbt"] < 0.95 * speed["rft"]


def test_control_turn_over_a_lag_of_a_cell_on_a_circle():
    """The control's turn (``reproduce.tumble._control_angle``) on a circular path at the
    angular rate Ω: by symmetry each window's least-squares velocity points along the
    path's tangent at the window's middle, so two windows whose middles are lag + W apart
    differ by Ω (lag + W) (closed form), at every start time along the record."""
    import flagellum.reproduce.tumble as T

    omega, v, w = 0.8, 30.0, 0.1
    t = np.arange(0.0, 2.0 + 1e-9, 1.0 / T.RATE)
    pos = (v / omega) * np.stack([np.cos(omega * t), np.sin(omega * t), 0 * t], axis=1)
    control = {"series": {"t": t, "body_position": pos}, "window": w}
    for lag in (0.3, 0.9):
        assert T._control_angle(control, lag) == pytest.approx(math.degrees(omega * (lag + w)), rel=1e-6)
    assert math.isnan(T._control_angle(control, 1.9))  # no pair of windows fits
