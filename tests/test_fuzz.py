"""Property-based: adversarial inputs end in a clear ParameterError (or a valid object),
never a traceback; the CLI answers them with exit 2 and one line."""

import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flagellum import Filament, Fluid, Friction, ParameterError, Params
from flagellum.cli import run
from flagellum.motor import Boundary, Motor
from flagellum.simulator import SolverOptions

weird = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**9, 10**9),
    st.just(0), st.just(-0.0), st.just(1e308), st.just(-1e-308), st.text(max_size=5),
    st.none(), st.booleans(), st.lists(st.floats(), max_size=2))

FIELDS = {Filament: ["kappa0", "tau0", "handedness", "bend_rigidity", "twist_rigidity",
                     "stretch_modulus", "length", "segment_length"],
          Fluid: ["viscosity", "filament_radius", "kT"],
          Motor: ["torque", "ramp_time"],
          SolverOptions: ["rtol", "atol", "dt", "method", "frame"]}


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cls=st.sampled_from(list(FIELDS)), data=st.data())
def test_constructors_raise_parameter_error_or_succeed(cls, data):
    name = data.draw(st.sampled_from(FIELDS[cls]))
    value = data.draw(weird)
    try:
        obj = cls(**{name: value})
    except ParameterError as exc:
        assert name in str(exc) or "config" in str(exc)
        return
    v = getattr(obj, name)
    assert not isinstance(v, float) or math.isfinite(v)


@settings(max_examples=100, deadline=None)
@given(anchor=weird | st.sampled_from(["fixed", "sphere"]), radius=weird,
       hook=weird | st.sampled_from(["free", "elastic", "clamped"]), k=weird)
def test_boundary(anchor, radius, hook, k):
    try:
        b = Boundary(anchor=anchor, sphere_radius=radius, hook=hook, hook_stiffness=k)
    except ParameterError as exc:
        assert exc.name in ("anchor", "sphere_radius", "hook", "hook_stiffness"), exc
        assert exc.name in str(exc) and "\n" not in str(exc)
        return
    # accepted: valid choices, and every number that is used is finite and in range
    assert b.anchor in ("fixed", "sphere", "free") and b.hook in ("free", "elastic", "clamped")
    assert isinstance(b.hook_stiffness, float) and 0 <= b.hook_stiffness <= 1e6
    assert (b.hook_stiffness > 0) == (b.hook == "elastic")
    if b.anchor == "sphere":
        assert isinstance(b.sphere_radius, float) and 0 < b.sphere_radius <= 1e6
    if b.anchor == "free":
        assert isinstance(b.sphere_radius, float) and 0 <= b.sphere_radius <= 1e6


@settings(max_examples=60, deadline=None)
@given(section=st.sampled_from(["filament", "fluid", "friction", "bogus"]),
       key=st.text(max_size=8) | st.sampled_from(["length", "kT", "model"]), value=weird)
def test_from_dict(section, key, value):
    try:
        p = Params.from_dict({section: {key: value}})
    except ParameterError as exc:
        # the message names the section, the key or the config as a whole
        assert section in str(exc) or key in str(exc) or "config" in str(exc), exc
        return
    # accepted: a known section and key, and the result survives a round trip
    assert section in ("filament", "fluid", "friction")
    assert ("model" if (section, key) == ("friction", "friction") else key) in p.to_dict()[section]
    assert Params.from_dict(p.to_dict()) == p


@settings(max_examples=40, deadline=None)
@given(flag=st.sampled_from(["--length", "--kappa0", "--tau0", "--segment-length",
                             "--bend-rigidity", "--viscosity", "--filament-radius", "--kT",
                             "--critical-force", "--gamma-par"]),
       value=st.sampled_from(["nan", "inf", "-inf", "-1", "0", "1e400", "abc", "", "1e-320",
                              "3", "0.2"]))
def test_cli_rft_exit_codes(flag, value):
    import contextlib
    import io
    import json

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = run(["rft", flag, value, "--json"])
    assert code in (0, 2)
    if code == 2:
        lines = err.getvalue().strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in err.getvalue()
    else:  # accepted: the answer is one JSON object with finite F/M
        res = json.loads(out.getvalue())
        assert math.isfinite(res["thrust_per_torque"])


def test_cli_malformed_config(tmp_path):
    cfg = tmp_path / "c.toml"
    for text in ("[filament\nlength=1", "[filament]\nlength = 'x'", "[nope]\na=1", "\x00\x01"):
        cfg.write_text(text)
        assert run(["rft", "--config", str(cfg)]) == 2


def test_cli_corrupt_hdf5(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not an hdf5 file")
    assert run(["info", str(bad)]) == 2
    assert run(["simulate", "--resume", str(bad)]) == 2


import pytest  # noqa: E402
from conftest import assert_one_line_error  # noqa: E402


@pytest.mark.parametrize("args", [
    ["--torque", "nan"], ["--torque", "1e9"], ["--time", "-1"], ["--time", "0"],
    ["--sphere-radius", "-1"], ["--hook", "elastic"], ["--hook-stiffness", "-2"],
    ["--dt", "0"], ["--frame", "sideways"], ["--rtol", "2"], ["--save-every", "-1"],
    ["--seed", "-3", "--kT", "0.004"], ["--kT", "0", "--thermal"], ["--checkpoint-every", "0"],
    ["--output", "/proc/none/x.h5"], ["--length", "0.3"],
    # found by the fuzz (tests/test_fuzz_commands.py): overflow, hang, NaN accepted
    ["--save-every", "1e-320"], ["--save-every", "1e-12"], ["--average-from", "nan"],
    ["--method", "implicit", "--dt", "1e-320"],
])
def test_cli_simulate_bad_input(args, capsys, tmp_path):
    code = run(["simulate", "--length", "2", "--time", "0.001", *args])
    assert_one_line_error(code, capsys.readouterr().err)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("args", [
    ["theory", "rigid-helix", "--time", "1e30"],  # hung
    ["theory", "rigid-helix", "--time", "1e-320"],  # LinAlgError
    ["theory", "rigid-helix", "--torque", "8e-302"],  # TypeError in solve_ivp
    ["demo", "--out", "FILE/sub"],  # NotADirectoryError
])
def test_cli_regressions(args, capsys, tmp_path):
    f = tmp_path / "f"
    f.write_text("not a directory")
    code = run([str(f) if a == "FILE" else a.replace("FILE", str(f)) for a in args])
    assert_one_line_error(code, capsys.readouterr().err)
    assert [p.name for p in tmp_path.iterdir()] == ["f"]
