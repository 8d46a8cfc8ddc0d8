"""The public API: the package face (lazy, every name resolves), ``flagellum.simulate`` and
the regime in ``Trajectory.summary()``, including runs too short to have settled."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import flagellum as fl
from flagellum.analysis.regimes import REGIMES, TRANSIENT, assess, summarize_run
from flagellum.errors import ParameterError

HEAVY = ("numba", "scipy", "h5py", "matplotlib", "sksundae")


# -- the package face ---------------------------------------------------------------------
def test_import_flagellum_loads_no_heavy_dependency():
    code = ("import sys, flagellum, flagellum.cli; "
            f"print([m for m in {HEAVY!r} if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def test_every_public_name_resolves():
    assert len(set(fl.__all__)) == len(fl.__all__)
    for name in fl.__all__:
        assert getattr(fl, name) is not None, name
        assert name in dir(fl)
    assert fl.Simulator.__module__ == "flagellum.simulator"
    assert fl.errors.ParameterError is fl.ParameterError
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        fl.nonexistent  # noqa: B018


def test_public_names_are_the_documented_ones():
    wanted = {"Params", "Filament", "Fluid", "Friction", "Motor", "Boundary", "Simulator",
              "SolverOptions", "Trajectory", "Helix", "discrete_helix", "errors", "critical_torque",
              "linear_stability", "relative_equilibrium", "Sweep", "run_sweep", "read_sweep",
              "simulate"}
    assert wanted <= set(fl.__all__)


# -- simulate() ---------------------------------------------------------------------------
SHORT = {"length": 2.0}  # a short filament: milliseconds per run


def test_simulate_builds_the_run_of_its_keywords():
    tr = fl.simulate(torque=0.3, time=0.01, save_every=1e-3, sphere_radius=0.5, hook_stiffness=2.0,
                     **SHORT)
    assert isinstance(tr, fl.Trajectory) and len(tr) == 11
    spec = json.loads(tr.meta["spec"])
    assert spec["boundary"] == {"anchor": "sphere", "sphere_radius": 0.5, "hook": "elastic",
                                "hook_stiffness": 2.0}
    assert spec["params"]["filament"]["length"] == 2.0 and spec["motor"]["torque"] == 0.3
    # the default method of a deterministic local run (flagellum.integrate.default_method)
    assert spec["solver"]["method"] == "bdf" and not spec["thermal"]
    assert math.isfinite(tr.summary().thrust_mean)


def test_simulate_thermal_from_kT_and_params_dict():
    tr = fl.simulate(torque=0.3, time=0.002, save_every=1e-3, kT=4.1e-3, seed=3,
                     params={"length": 2.0})
    spec = json.loads(tr.meta["spec"])
    assert spec["thermal"] and spec["seed"] == 3 and spec["solver"]["method"] == "implicit"
    assert spec["params"]["fluid"]["kT"] == 4.1e-3 and spec["params"]["filament"]["length"] == 2.0


def test_simulate_default_save_interval_is_time_over_300():
    assert len(fl.simulate(torque=0.2, time=0.003, **SHORT)) == 301


@pytest.mark.parametrize("kwargs, name", [
    ({"time": -1.0}, "time"), ({"time": "long"}, "time"), ({"bend_stiffness": 1.0}, "parameter"),
    ({"params": 3}, "params"), ({"length": -2.0}, "length"), ({"hook": "loose"}, "hook"),
    ({"method": "euler"}, "method"),
])
def test_simulate_rejects_bad_input_with_parameter_error(kwargs, name):
    with pytest.raises(ParameterError) as exc:
        fl.simulate(**{"torque": 0.2, "time": 0.002, **SHORT, **kwargs})
    assert name in str(exc.value)


# -- regime of a window: synthetic series -------------------------------------------------
R, L0, N = 0.2, 8.4, 50


def _helix_run(t, centroid, thrust, omega=800.0):
    """A helix rotating about e_z whose centroid sits ``centroid(t)`` (in R) off the axis."""
    s = np.linspace(0.0, 1.0, N + 1)
    phase = 2 * np.pi * 4 * s[None, :] + omega * t[:, None]
    pos = np.stack([R * np.cos(phase), R * np.sin(phase), -L0 * s[None, :] + 0 * phase], axis=-1)
    pos[:, :, 0] += (R * centroid * np.cos(60 * t))[:, None] * np.sin(np.pi * s)[None, :] * np.pi / 2
    pos[:, :, 1] += (R * centroid * np.sin(60 * t))[:, None] * np.sin(np.pi * s)[None, :] * np.pi / 2
    return pos, np.broadcast_to(thrust, t.shape), omega * t


def test_relaxing_centroid_is_transient_not_buckled():
    """The centroid relaxes onto the axis and crosses the buckled threshold (0.25 R) inside
    the window: the window alone says buckled, the trend says the run is still settling."""
    t = np.linspace(0.0, 0.3, 301)
    pos, th, ang = _helix_run(t, 0.6 * np.exp(-t / 0.3), 0.9)
    a = assess(t, th, pos, ang, R)
    assert a.window_regime == "buckled"
    assert a.regime == TRANSIENT and "centroid_offset" in a.drifting and not a.steady
    assert "lead to aligned" in a.note


def test_regime_near_its_threshold_while_drifting_is_transient():
    """Just above the threshold (0.25 R) and falling slowly: the linear trend stays above it
    one window on, but a regime resting on a metric that close while it moves is not sure."""
    t = np.linspace(0.0, 0.2, 301)
    centroid = 0.365 - 5.5 * (t - 0.1).clip(0) ** 2  # window [0.1, 0.2]: 0.365 → 0.31
    pos, th, ang = _helix_run(t, centroid, 0.9)
    a = assess(t, th, pos, ang, R)
    assert a.window_regime == "buckled" and a.regime == TRANSIENT
    assert a.drifting == ("centroid_offset",) and "near their thresholds" in a.note


def test_regime_near_its_threshold_but_settled_is_kept():
    t = np.linspace(0.0, 1.0, 301)
    pos, th, ang = _helix_run(t, np.full_like(t, 0.3), 0.9)
    assert assess(t, th, pos, ang, R).regime == "buckled"


def test_settled_states_keep_their_regime():
    t = np.linspace(0.0, 1.0, 301)
    for centroid, label in ((0.05, "aligned"), (2.0, "buckled")):
        pos, th, ang = _helix_run(t, np.full_like(t, centroid), 0.9 + 0.1 * np.cos(900 * t) * (label == "buckled"))
        a = assess(t, th, pos, ang, R)
        assert (a.regime, a.window_regime, a.steady, a.drifting, a.note) == (label, label, True, (), "")


def test_noise_alone_is_no_trend():
    """White noise on a settled aligned state: no significant trend, no transient."""
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 1.0, 301)
    pos, _, ang = _helix_run(t, np.full_like(t, 0.05), 0.0)
    flagged = 0
    for _ in range(20):
        th = 0.9 + 0.01 * rng.standard_normal(len(t))
        a = assess(t, th, pos + 1e-3 * rng.standard_normal(pos.shape), ang, R)
        assert a.regime == "aligned"
        flagged += not a.steady
    assert flagged <= 4  # a 95 % test on three averages


def test_drifting_average_is_not_steady_but_keeps_a_sure_regime():
    t = np.linspace(0.0, 1.0, 301)
    pos, _, ang = _helix_run(t, np.full_like(t, 0.05), 0.0)
    a = assess(t, 0.9 * (1 + 0.1 * t), pos, ang, R)  # thrust still rising by 4 % per window
    assert a.regime == "aligned" and not a.steady and a.drifting == ("thrust_mean",)
    assert "thrust_mean" in a.note


def test_too_short_a_window_is_not_steady():
    t = np.linspace(0.0, 0.01, 11)
    pos, th, ang = _helix_run(t, np.full_like(t, 0.05), 0.9)
    a = assess(t, th, pos, ang, R)
    assert a.regime == "aligned" and not a.steady and a.drifting == ("samples",)


def test_summary_carries_the_regime():
    t = np.linspace(0.0, 0.3, 301)
    pos, th, ang = _helix_run(t, 0.6 * np.exp(-t / 0.3), 0.9)
    s = summarize_run(t, th, ang, pos, np.zeros_like(t), R)
    d = s.to_dict()
    assert d["regime"] == TRANSIENT and d["drifting"] == ("centroid_offset",) and not d["steady"]
    assert math.isclose(d["omega_mean"], 800.0) and d["regime_note"]


# -- regime of real runs (the paper's filament, simulate's default sampling) ----------------
@pytest.mark.parametrize("torque, time, allowed", [
    (1.0, 0.2, {"transient", "aligned"}),  # below M_c1, still relaxing: never "buckled"
    (1.0, 0.3, {"transient", "aligned"}),
    (1.6, 0.5, {"buckled"}),
    (0.5, 1.0, {"aligned"}),
])
def test_regime_of_short_runs(torque, time, allowed):
    s = fl.simulate(torque=torque, time=time, progress=False).summary()
    assert s.regime in allowed, s
    assert s.regime in REGIMES + (TRANSIENT,)


def test_cli_simulate_json_reports_the_regime(cli):
    code, out, err = cli("simulate", "--torque", 0.3, "--length", 2, "--time", 0.02, "--json")
    assert code == 0, err
    res = json.loads(out)
    assert res["regime"] in REGIMES + (TRANSIENT,)
    assert {"steady", "drifting", "regime_note"} <= set(res)
