"""The command line speaks one language: one name per concept across commands (older
spellings still parse, unlisted), help that fits 80 columns, and ``--json`` output that is
only the JSON object."""

from __future__ import annotations

import functools
import json

import click
import pytest
from click.testing import CliRunner

from flagellum.cli import main
from flagellum.cli._options import AliasedOption

#: older spelling → the one name
ALIASES = {"--out": "--output", "--t-end": "--time"}


def _commands(group=main, path=()):
    for name, cmd in sorted(group.commands.items()):
        yield (*path, name), cmd
        if isinstance(cmd, click.Group):
            yield from _commands(cmd, (*path, name))


COMMANDS = list(_commands())


def _help(path) -> str:
    res = CliRunner().invoke(main, [*path, "--help"], terminal_width=80)
    assert res.exit_code == 0, res.output
    return res.output


@pytest.mark.parametrize("path, cmd", COMMANDS, ids=lambda x: " ".join(x) if isinstance(x, tuple) else "")
def test_one_name_per_concept(path, cmd):
    shown = {o for p in cmd.params if isinstance(p, click.Option) for o in p.opts
             if not (isinstance(p, AliasedOption) and o in p.aliases)}
    for old, new in ALIASES.items():
        assert old not in shown, f"flagellum {' '.join(path)} shows {old}; the name is {new}"
        for p in cmd.params:
            if old in p.opts:  # the older spelling is an alias of the one name
                assert new in p.opts and isinstance(p, AliasedOption) and old in p.aliases
    text = _help(path)
    for old in ALIASES:
        assert f"{old} " not in text and f"{old}," not in text, (path, old)


@pytest.mark.parametrize("path, cmd", COMMANDS, ids=lambda x: " ".join(x) if isinstance(x, tuple) else "")
def test_help_fits_80_columns(path, cmd):
    text = _help(path)
    assert max(len(line) for line in text.splitlines()) <= 80
    if isinstance(cmd, click.Group):  # the command list: short help not cut off
        listing = text.split("Commands:", 1)[1].splitlines()
        assert [line for line in listing if line.rstrip().endswith("...")] == []


def test_main_command_list_is_not_cut_off():
    listing = _help(()).split("Commands:", 1)[1].splitlines()
    assert len([line for line in listing if line.strip()]) == len(main.commands)
    assert [line for line in listing if line.rstrip().endswith("...")] == []


@pytest.mark.parametrize("args, key, value", [
    (["simulate", "--out", "x.h5"], "output", "x.h5"),
    (["simulate", "--t-end", "0.2"], "t_end", 0.2),
    (["bifurcations", "--t-end", "0.4", "--out", "b.json"], "t_end", 0.4),
    (["bifurcations", "--time", "0.4", "-o", "b.json"], "out", "b.json"),
    (["sweep", "--t-end", "0.1", "--out", "s.nc"], "time", "0.1"),
    (["sweep", "--time", "0.1", "--output", "s.nc"], "out", "s.nc"),
    (["demo", "--out", "d"], "out_dir", "d"),
    (["reproduce", "fig3", "--out", "r"], "out_dir", "r"),
    (["export", "f.h5", "--out", "v"], "out_dir", "v"),
])
def test_older_spellings_still_parse(args, key, value):
    cmd = main
    while isinstance(cmd, click.Group):
        cmd = cmd.commands[args.pop(0)]
    ctx = cmd.make_context(cmd.name, args)
    assert ctx.params[key] == value


def test_error_messages_name_the_one_name():
    res = CliRunner().invoke(main, ["export", "f.h5"])
    assert res.exit_code == 2 and "'--output'" in res.output and "--out'" not in res.output


def test_demo_json_prints_only_the_json_object(cli, monkeypatch, tmp_path):
    import flagellum.demo as demo
    import flagellum.viz as viz

    def movie(t, positions, path, **kw):
        path.write_bytes(b"")

    monkeypatch.setattr(viz, "movie", movie)
    monkeypatch.setattr(demo, "run_demo", functools.partial(
        demo.run_demo, runs=(("aligned", 0.3, 0.01, 0.01 / 400),), frames=2))
    code, out, err = cli("demo", "--output", tmp_path / "d", "--json")
    assert code == 0, err
    res = json.loads(out)  # nothing but the object on stdout
    assert set(res) == {"aligned"} and res["aligned"]["torque"] == 0.3
    assert err == ""
