"""Bad input ends in one line naming the parameter (exit code 2): no traceback, no hang, no
huge allocation, and nothing accepted silently."""

import os

import pytest
from conftest import assert_one_line_error

from flagellum import ParameterError
from flagellum.grid import convert
from flagellum.params import Params, check_real

SHORT = ["--length", "2", "--time", "0.002", "--save-every", "1e-3"]


# -- tracebacks and overflow ------------------------------------------------------------

def test_huge_integers_are_parameter_errors(tmp_path):
    with pytest.raises(ParameterError, match="length"):
        check_real("length", 10**400)
    with pytest.raises(ParameterError, match="torque"):
        convert("torque", 10**400)
    cfg = tmp_path / "big.toml"
    cfg.write_text("[filament]\nlength = " + "1" * 400 + "\n")
    with pytest.raises(ParameterError, match="length"):
        Params.load_toml(cfg)


@pytest.mark.parametrize("args,name", [
    (["simulate", "--seed", "99999999999999999999999", "-o", "{tmp}/s.h5"], "seed"),
    (["simulate", "--config", "{tmp}/big.toml"], "length"),
    (["simulate", "--output", ""], "output"),
    (["simulate", "--resume", ""], "resume"),
    (["simulate", "--length", "10000"], "segment_length"),
    (["simulate", "--config", "/dev/zero"], "config"),
    (["simulate", "--gamma-par", "1e-12", "--gamma-perp", "1e-12", "--gamma-rot", "1e-15"], "gamma_par"),
    (["simulate", "--gamma-rot", "1e-15"], "gamma_rot"),
    (["simulate", "--friction", "lighthill", "--viscosity", "1e-9"], "gamma_par"),
    (["theory", "buckling", "--m-hat", "1e308"], "m_hat"),
    (["theory", "buckling", "--f-par", "1e30"], "f_par"),
    (["theory", "manifold", "--tau0", "0", "-o", "{tmp}/m"], "tau0"),
    (["theory", "effective-rigidity", "--tau0", "0"], "tau0"),
    (["theory", "manifold", "--gamma-par", "1e6", "--m-steps", "5", "--f-par-steps", "2",
      "--inv-a-steps", "2", "--workers", "1", "-o", "{tmp}/m"], "manifold"),
    (["info", "/dev/zero"], "file"),
])
def test_one_line_error_instead_of_a_traceback(args, name, cli, tmp_path):
    (tmp_path / "big.toml").write_text("[filament]\nlength = " + "1" * 400 + "\n")
    code, _, err = cli(*(a.replace("{tmp}", str(tmp_path)) for a in args))
    assert_one_line_error(code, err, name)


def test_a_parameter_error_of_a_worker_process_reaches_the_parent():
    """Pickled back from a worker, it stays itself (else the pool breaks with a traceback)."""
    import pickle

    err = pickle.loads(pickle.dumps(ParameterError("seed", -1, "an integer ≥ 0")))
    assert isinstance(err, ParameterError) and err.name == "seed" and "seed" in str(err)


@pytest.mark.parametrize("command", [["simulate"], ["sweep", "--torque", "1:2"], ["demo"],
                                     ["bifurcations"], ["reproduce", "fig3"],
                                     ["theory", "manifold"]])
def test_an_empty_output_name_is_refused_by_every_command(command, cli):
    assert_one_line_error(*cli(*command, "--output", "")[::2], "output")


@pytest.mark.parametrize("command", [["simulate", "--config"], ["info"]])
def test_a_fifo_is_refused_before_reading(command, cli, tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    code, _, err = cli(*command, fifo)  # reading it would block forever
    assert_one_line_error(code, err)
    assert "regular file" in err


def test_a_huge_config_is_refused(cli, tmp_path):
    cfg = tmp_path / "huge.toml"
    cfg.write_text("# " + "x" * (2 << 20) + "\n")
    assert_one_line_error(*cli("simulate", "--config", cfg)[::2], "config")


def test_hdf5_messages_become_one_line(cli, tmp_path):
    (tmp_path / "bad.h5").write_bytes(b"not an HDF5 file\n" * 10)
    assert_one_line_error(*cli("info", tmp_path / "bad.h5")[::2], "file")


@pytest.mark.parametrize("kind", ["symlink", "device", "directory"])
def test_output_onto_a_non_regular_file_is_refused(kind, cli, tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("precious")
    out = {"symlink": tmp_path / "link.h5", "device": "/dev/null", "directory": tmp_path}[kind]
    if kind == "symlink":
        out.symlink_to(target)
    code, _, err = cli("simulate", *SHORT, "--output", out)
    assert_one_line_error(code, err, "output")
    assert target.read_text() == "precious"
    if kind == "symlink":
        assert out.is_symlink()


# -- nothing accepted silently ----------------------------------------------------------

@pytest.mark.parametrize("args,name", [
    (["simulate", "--resume", "{tmp}/x.h5", "--torque", "2", "--output", "{tmp}/y.h5"], "--torque, --output"),
    (["simulate", "--resume", "{tmp}/x.h5", "--config", "{tmp}/c.toml"], "--config"),
    (["simulate", "--resume", "{tmp}/x.h5", "--kT", "0.004"], "--kT"),
    (["simulate", "--hook", "clamped", "--hook-stiffness", "5"], "hook_stiffness"),
    (["simulate", "--hook", "free", "--hook-stiffness", "5"], "hook_stiffness"),
    (["simulate", "--theta", "0.5", "--method", "cvode"], "theta"),
    (["simulate", "--theta", "0.5", "--scheme", "bdf2", "--method", "implicit"], "theta"),
    (["simulate", "--scheme", "theta"], "scheme"),
    (["simulate", "--anchor", "fixed", "--sphere-radius", "1"], "sphere_radius"),
    (["simulate", "--checkpoint-every", "0.1"], "checkpoint_every"),
    (["simulate", "--time", "1e-320"], "time"),
    (["bench", "--window", "1e-320"], "window"),
    (["sweep", "--torque", "1:2", "--seed", "-1", "-o", "{tmp}/s.h5"], "seed"),
    (["sweep", "--torque", "1:2", "--kT", "0", "-o", "{tmp}/s.h5"], "kT"),
    (["sweep", "--torque", "1:2", "--save-every", "1e-320", "-o", "{tmp}/s.h5"], "save_every"),
])
def test_refused_instead_of_silently_ignored(args, name, cli, tmp_path):
    code, _, err = cli(*(a.replace("{tmp}", str(tmp_path)) for a in args))
    assert_one_line_error(code, err, name)
    assert not (tmp_path / "s.h5").exists()


def test_boundary_refuses_unused_values():
    from flagellum.motor import Boundary

    with pytest.raises(ParameterError, match="sphere_radius"):
        Boundary(anchor="fixed", sphere_radius="abc")
    with pytest.raises(ParameterError, match="hook_stiffness"):
        Boundary.from_flags(hook="clamped", hook_stiffness=5.0)
    # the documented defaults of the flags: a radius alone is a load sphere, k alone elastic
    assert Boundary.from_flags(sphere_radius=1.0).anchor == "sphere"
    assert Boundary.from_flags(hook_stiffness=5.0).hook == "elastic"


def test_sweep_points_are_checked_before_the_first_runs():
    from flagellum.sweep import PointRun

    for values, name in (({"seed": -1}, "seed"), ({"kT": 0.0}, "kT"),
                         ({"save_every": 1e-320}, "save_every"), ({"time": 1e-320}, "time")):
        with pytest.raises(ParameterError, match=name):
            PointRun.from_values(values)


def test_checkpoint_every_needs_an_output():
    from flagellum.simulator import Simulator

    with pytest.raises(ParameterError, match="checkpoint_every"):
        Simulator(Params.from_flat({"length": 2.0})).run(0.01, checkpoint_every=0.005)


# -- nothing overwritten ------------------------------------------------------------------

RUN = dict(t_end=0.02, save_every=1e-3, checkpoint_every=0.005, progress=False)


def _sim():
    from flagellum.simulator import Simulator

    return Simulator(Params.from_flat({"length": 2.0}))


def test_an_existing_output_is_kept_without_overwrite(cli, tmp_path):
    out = tmp_path / "run.h5"
    assert cli("simulate", *SHORT, "--output", out)[0] == 0
    before = out.read_bytes()
    code, _, err = cli("simulate", *SHORT, "--torque", "2", "--output", out)
    assert_one_line_error(code, err, "overwrite")
    assert out.read_bytes() == before
    assert cli("simulate", *SHORT, "--torque", "2", "--output", out, "--overwrite")[0] == 0
    assert out.read_bytes() != before
    assert sorted(os.listdir(tmp_path)) == ["run.h5"]  # no lock, part or checkpoint left


def test_a_second_writer_of_the_same_output_is_refused(tmp_path):
    from flagellum.trajectory import RunFiles

    out = tmp_path / "run.h5"
    first = RunFiles.create(out, 10, {}, 10)  # a run in progress holds the lock
    try:
        with pytest.raises(ParameterError, match="no other run"):
            _sim().run(output=out, overwrite=True, **RUN)
        with pytest.raises(ParameterError, match="no other run"):
            type(_sim()).resume(out)
    finally:
        first.release()
    _sim().run(output=out, overwrite=True, **RUN)  # released: the next run may write
    assert sorted(os.listdir(tmp_path)) == ["run.h5"]


def test_a_killed_runs_lock_does_not_block_its_resume(tmp_path):
    import signal

    from flagellum.io import read_trajectory
    from flagellum.trajectory import RunFiles

    out = tmp_path / "run.h5"
    pid = os.fork()
    if pid == 0:  # child: killed right after its first checkpoint, holding the lock
        try:
            orig = RunFiles.write_checkpoint

            def write_and_die(self, *a, **kw):
                orig(self, *a, **kw)
                os.kill(os.getpid(), signal.SIGKILL)

            RunFiles.write_checkpoint = write_and_die
            _sim().run(output=out, **RUN)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    assert (tmp_path / "run.h5.lock").exists() and (tmp_path / "run.h5.ckpt").exists()
    type(_sim()).resume(out, progress=False)
    assert read_trajectory(out)["attrs"]["status"] == "complete"
    assert sorted(os.listdir(tmp_path)) == ["run.h5"]


def test_a_failed_probe_leaves_no_file(tmp_path, monkeypatch):
    import errno
    from pathlib import Path

    from flagellum.io import check_writable

    real = Path.write_bytes

    def full(self, data):
        real(self, b"")  # created, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Path, "write_bytes", full)
    with pytest.raises(ParameterError, match="output"):
        check_writable(tmp_path / "run.h5")
    assert os.listdir(tmp_path) == []


# -- damaged checkpoints ------------------------------------------------------------------

def _killed_after_checkpoints(out, n, make=None):
    """A run (of the simulator ``make()``, default ``_sim()``) into ``out`` SIGKILLed right
    after its n-th checkpoint."""
    import signal

    from flagellum.trajectory import RunFiles

    pid = os.fork()
    if pid == 0:
        try:
            orig, calls = RunFiles.write_checkpoint, [0]

            def write_and_maybe_die(self, *a, **kw):
                orig(self, *a, **kw)
                calls[0] += 1
                if calls[0] == n:
                    os.kill(os.getpid(), signal.SIGKILL)

            RunFiles.write_checkpoint = write_and_maybe_die
            (make or _sim)().run(output=out, **RUN)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)


def _edit_checkpoint(ckpt, **attrs):
    import h5py

    with h5py.File(ckpt, "r+") as f:
        for k, v in attrs.items():
            f.attrs[k] = v(f.attrs[k]) if callable(v) else v


def _edit_spec(spec):
    import json

    d = json.loads(spec)
    d["motor"]["torque"] = 3.0
    return json.dumps(d)


@pytest.mark.parametrize("damage", ["parts deleted", "one part deleted", "one part changed",
                                    "n_done altered", "spec edited"])
def test_a_damaged_checkpoint_is_refused_not_resumed(damage, tmp_path):
    import shutil

    from flagellum.io import part_path, parts_dir, read_trajectory

    out, ckpt = tmp_path / "run.h5", tmp_path / "run.h5.ckpt"
    _killed_after_checkpoints(out, 3)
    if damage == "parts deleted":
        shutil.rmtree(parts_dir(out))
    elif damage == "one part deleted":
        part_path(out, 1).unlink()
    elif damage == "one part changed":
        import h5py

        with h5py.File(part_path(out, 1), "r+") as f:
            f["thrust"][0] += 1.0
    elif damage == "n_done altered":
        _edit_checkpoint(ckpt, n_done=lambda n: n + 3)
    else:
        _edit_checkpoint(ckpt, spec=_edit_spec)
    with pytest.raises(ParameterError, match="resume") as err:
        type(_sim()).resume(out, progress=False)
    assert "\n" not in str(err.value)
    assert read_trajectory(out)["attrs"]["status"] != "complete"
    assert not (tmp_path / "run.h5.lock").exists()


# -- thermal resume ------------------------------------------------------------------------

def test_thermal_kill_and_resume_with_step_splits_is_bit_identical(tmp_path, monkeypatch):
    """A resumed thermal run draws the noise of its split steps (Brownian bridge) as the
    uninterrupted run did, and counts all steps."""
    from flagellum.integrate.brownian import ImplicitStepper
    from flagellum.simulator import Simulator

    splits = []
    orig = ImplicitStepper._steps

    def failing(self, t0, k, dt, times, normals):  # a full step at every 37th step time fails
        if dt > 0.75 * self.dt and round(t0 / self.dt) % 37 == 5:
            splits.append(t0)
            return 0
        return orig(self, t0, k, dt, times, normals)

    monkeypatch.setattr(ImplicitStepper, "_steps", failing)

    def sim():
        return Simulator(Params.from_flat({"length": 2.0, "kT": 4.1e-3}), thermal=True, seed=3)

    killed_and_resumed_matches_the_whole_run(tmp_path, sim)
    assert splits


def killed_and_resumed_matches_the_whole_run(tmp_path, sim):
    """The run of ``sim()`` SIGKILLed after its second checkpoint and resumed gives the
    records, final state and step count of the run that never stopped."""
    import numpy as np

    from flagellum.io import RECORD_FIELDS, read_trajectory
    from flagellum.simulator import Simulator

    ref, out = tmp_path / "ref.h5", tmp_path / "run.h5"
    sim().run(output=ref, **RUN)
    _killed_after_checkpoints(out, 2, sim)
    resumed, _ = Simulator.resume(out, progress=False)
    a, b = read_trajectory(ref), read_trajectory(out)
    for name in [*RECORD_FIELDS, "final_state"]:
        assert np.array_equal(a[name], b[name]), name
    assert a["attrs"]["steps"] == b["attrs"]["steps"] == resumed.steps


def test_warnings_before_an_error_leave_one_line(cli, monkeypatch):
    import warnings

    import flagellum.cli.simulate as command

    def warn_then_fail(kwargs):
        warnings.warn("overflow encountered in multiply", RuntimeWarning)
        raise ParameterError("length", -1.0, "> 0")

    monkeypatch.setattr(command, "params_from_cli", warn_then_fail)
    assert_one_line_error(*cli("simulate")[::2], "length")


def test_warnings_of_a_successful_command_are_still_shown(cli, monkeypatch):
    import warnings

    def warn_and_read(path, **kw):
        warnings.warn("something to know", UserWarning)
        return {"attrs": {"status": "complete"}}

    monkeypatch.setattr("flagellum.io.read_trajectory", warn_and_read)
    with pytest.warns(UserWarning, match="something to know"):
        code, out, _ = cli("info", "any.h5")
    assert code == 0 and "complete" in out
