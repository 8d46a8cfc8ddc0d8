"""Documentation: relative links resolve, the tutorial names real commands and options, and
the MkDocs site (with the API reference from the docstrings) builds.

Fast tier: link check and tutorial commands (no build). Slow tier: ``mkdocs build --strict``
into a temporary directory (skipped when the ``docs`` extra is not installed).
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.glob("*.md")) + [ROOT / "README.md"]
TUTORIAL = DOCS / "tutorial.md"

_FENCE = re.compile(r"^(```|~~~).*?^\1[ \t]*$", re.S | re.M)
_INLINE_CODE = re.compile(r"`[^`\n]*`")
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_BLOCK = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def _links(text: str) -> list[str]:
    """Markdown link targets outside code blocks and code spans."""
    prose = _INLINE_CODE.sub("", _FENCE.sub("", text))
    return _LINK.findall(prose)


def test_link_extraction_ignores_code():
    text = "see [a](a.md) and `[b](b.md)`\n\n```\n[c](c.md)\n```\n![img](x/y.png \"t\")"
    assert _links(text) == ["a.md", "x/y.png"]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_relative_links_point_to_existing_files(page):
    missing = []
    for target in _links(page.read_text(encoding="utf-8")):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I) or target.startswith("#"):
            continue  # http:, https:, mailto:, … and anchors within the page
        path = target.split("#", 1)[0].split("?", 1)[0]
        if not (page.parent / path).exists():
            missing.append(target)
    assert not missing, f"{page.name}: broken links {missing}"


def test_every_page_is_reachable_from_the_index():
    linked = {t.split("#", 1)[0] for t in _links((DOCS / "index.md").read_text(encoding="utf-8"))}
    pages = {p.name for p in DOCS.glob("*.md")} - {"index.md"}
    assert pages <= linked, f"pages not linked from docs/index.md: {sorted(pages - linked)}"


def _tutorial_command_lines() -> list[list[str]]:
    """``flagellum …`` command lines of the tutorial's bash blocks, as argument lists."""
    lines = []
    for lang, body in _BLOCK.findall(TUTORIAL.read_text(encoding="utf-8")):
        if lang not in ("bash", "sh", "shell", "console", ""):
            continue
        for line in body.splitlines():
            line = line.split(" #", 1)[0].strip().rstrip("&").strip()
            for part in re.split(r"&&|;|\|", line):
                if not part.strip().startswith("flagellum "):
                    continue
                words = shlex.split(part, comments=True)
                cut = next((i for i, w in enumerate(words) if re.match(r"^\d*[<>]", w)), None)
                lines.append(words[1:cut])  # without redirections
    return lines


def _resolve(args: list[str]) -> tuple[click.Command, list[str], list[str]]:
    """The (sub)command that ``flagellum ARGS`` runs, its path and its remaining arguments."""
    from flagellum.cli import main

    cmd, path, rest = main, [], list(args)
    while isinstance(cmd, click.Group) and rest and not rest[0].startswith("-"):
        name = rest.pop(0)
        assert name in cmd.commands, f"'flagellum {' '.join(path + [name])}' is not a command"
        cmd, path = cmd.commands[name], path + [name]
    return cmd, path, rest


def test_tutorial_commands_exist_in_the_cli():
    from flagellum.cli import main

    text = TUTORIAL.read_text(encoding="utf-8")
    # every "flagellum <word>" in code (blocks and spans) must be a subcommand
    # shell and output blocks and code spans (Python blocks say "from flagellum import …")
    code = "\n".join([body for lang, body in _BLOCK.findall(text) if lang not in ("python", "toml")]
                     + _INLINE_CODE.findall(_FENCE.sub("", text)))
    named = set(re.findall(r"\bflagellum ([a-z][a-z-]*)\b", code))
    assert named, "the tutorial names no flagellum subcommand"
    unknown = named - set(main.commands)
    assert not unknown, f"tutorial names unknown subcommands: {sorted(unknown)}"
    for needed in ("simulate", "info", "render", "stability", "critical-torque", "theory",
                   "sweep", "reproduce"):
        assert needed in named, f"the tutorial does not show 'flagellum {needed}'"


def test_tutorial_command_lines_use_existing_options():
    lines = _tutorial_command_lines()
    assert len(lines) >= 10
    for args in lines:
        cmd, path, rest = _resolve(args)
        options = {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)} | {"-h", "--help"}
        if cmd.name == "main" or not path:
            options |= {"--version"}
        for word in rest:
            if word.startswith("-") and not re.match(r"^-\d", word):
                assert word.split("=", 1)[0] in options, \
                    f"'flagellum {' '.join(path)}' has no option {word} (tutorial: {args})"


@pytest.mark.slow
def test_mkdocs_site_builds_with_api_reference(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    pytest.importorskip("mkdocstrings_handlers.python")
    site = tmp_path / "site"
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict",
                           "--config-file", str(ROOT / "mkdocs.yml"), "--site-dir", str(site)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for page in ("index.html", "tutorial.html", "model.html", "api.html"):
        assert (site / page).is_file(), page
    api = "".join((site / p).read_text(encoding="utf-8") for p in
                  ("api.html", "api-numerics.html", "api-analysis.html", "api-workflows.html"))
    for name in ("flagellum.simulator.Simulator", "flagellum.io.read_trajectory",
                 "flagellum.params.Params", "flagellum.analysis.stability.critical_torque",
                 "flagellum.sweep.run_sweep", "flagellum.hydro.rft.resistance_matrix",
                 "flagellum.theory.buckling.solve", "flagellum.export.export_vtk"):
        assert f'id="{name}"' in api, f"{name} missing from the API reference"
    # the docstrings' reST markup was rewritten for Markdown (docs/griffe_docstrings.py)
    assert ":func:`" not in api and ":class:`" not in api
