"""The direction of imports: a module imports only modules of its own or lower layers, never
the package face, and no modules import each other in a loop. The layers are read from the
table in docs/architecture.md, so the document and the code cannot drift apart."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "flagellum"


def layer_table() -> dict[str, int]:
    """{module prefix: layer} from the table of docs/architecture.md (`hydro.*` → "hydro")."""
    table = {}
    for line in (ROOT / "docs" / "architecture.md").read_text().splitlines():
        m = re.match(r"\|\s*(\d+)\s[^|]*\|([^|]*)\|", line)
        if m:
            for name in re.findall(r"`([^`]+)`", m.group(2)):
                table[name.removesuffix(".*").removeprefix("flagellum.").replace("flagellum", "")] = int(m.group(1))
    return table


def modules() -> dict[str, Path]:
    """{dotted name below flagellum ("" = the package face): file}."""
    out = {}
    for p in SRC.rglob("*.py"):
        parts = list(p.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def imports(name: str, path: Path, known) -> set[str]:
    """Modules of the package that ``path`` imports anywhere (function-local imports too)."""
    pkg = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    pkg = [p for p in pkg if p]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[:len(pkg) - node.level + 1] if node.level > 1 else list(pkg)
                mod = ".".join(base + ([node.module] if node.module else []))
            elif node.module and (node.module == "flagellum" or node.module.startswith("flagellum.")):
                mod = node.module.removeprefix("flagellum").lstrip(".")
            else:
                continue
            for alias in node.names:  # `from .hydro import rft` imports the module hydro.rft
                sub = f"{mod}.{alias.name}" if mod else alias.name
                found.add(sub if sub in known else mod)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "flagellum" or alias.name.startswith("flagellum."):
                    found.add(alias.name.removeprefix("flagellum").lstrip("."))
    found.discard(name)
    return found


def layer_of(name: str, table: dict[str, int]) -> int | None:
    best = None
    for prefix, layer in table.items():
        if name == prefix or (prefix and name.startswith(prefix + ".")):
            if best is None or len(prefix) > len(best[0]):
                best = (prefix, layer)
    return None if best is None else best[1]


def graph():
    mods = modules()
    return {name: imports(name, path, mods) for name, path in mods.items()}


def test_every_module_has_a_layer():
    table = layer_table()
    assert len(table) > 10, "the layer table in docs/architecture.md was not found"
    missing = sorted(n for n in modules() if layer_of(n, table) is None)
    assert not missing, f"add these modules to the layer table of docs/architecture.md: {missing}"


def test_imports_point_down():
    table = layer_table()
    bad = []
    for name, deps in graph().items():
        if layer_of(name, table) is None:
            continue  # reported by test_every_module_has_a_layer
        for dep in deps:
            if dep == "" and name != "":
                bad.append(f"{name or 'flagellum'} imports the package face flagellum/__init__.py")
            elif (layer_of(dep, table) or 0) > layer_of(name, table):
                bad.append(f"{name} (layer {layer_of(name, table)}) imports {dep} "
                           f"(layer {layer_of(dep, table)})")
    assert not bad, "\n".join(sorted(bad))


def test_no_import_cycles():
    g = graph()
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = 1
        for dep in sorted(g.get(node, ())):
            if state.get(dep) == 1:
                cycles.append(" -> ".join(stack[stack.index(dep):] + [dep]))
            elif dep not in state:
                visit(dep, stack + [dep])
        state[node] = 2

    for node in sorted(g):
        if node not in state:
            visit(node, [node])
    assert not cycles, "\n".join(cycles)


@pytest.mark.parametrize("case,expected", [
    ("rod.model imports simulator", "rod.model (layer 4) imports simulator (layer 7)"),
])
def test_the_check_can_fail(case, expected, monkeypatch):
    # the checker itself: an upward import is reported with both layers
    real = graph()
    fake = {**real, "rod.model": real["rod.model"] | {"simulator"}}
    monkeypatch.setattr(__import__(__name__), "graph", lambda: fake)
    with pytest.raises(AssertionError, match=re.escape(expected)):
        test_imports_point_down()
