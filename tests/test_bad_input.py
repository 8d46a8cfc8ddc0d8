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
    (["info", "/dev/zero"], "file"),
])
def test_one_line_error_instead_of_a_traceback(args, name, cli, tmp_path):
    (tmp_path / "big.toml").write_text("[filament]\nlength = " + "1" * 400 + "\n")
    code, _, err = cli(*(a.replace("{tmp}", str(tmp_path)) for a in args))
    assert_one_line_error(code, err, name)


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
