"""Printing results (one JSON object or a table) and writing JSON result files."""

from __future__ import annotations

import json

import click
import numpy as np

from .._util import jsonable


def to_json(obj) -> str:
    return json.dumps(jsonable(obj), indent=2)


def emit_json(obj) -> None:
    click.echo(to_json(obj))


def write_json(path, obj) -> None:
    """Write ``obj`` as JSON to ``path`` atomically (a reader never sees half a file)."""
    from ..io import atomic_write_text

    atomic_write_text(path, to_json(obj) + "\n")


def emit_table(rows: dict, title: str | None = None) -> None:
    if title:
        click.echo(title)
    width = max(len(k) for k in rows)
    for k, v in rows.items():
        if isinstance(v, dict):
            click.echo(f"{k}:")
            for k2, v2 in v.items():
                click.echo(f"  {k2:<{width}}  {fmt(v2)}")
        else:
            click.echo(f"{k:<{width + 2}}  {fmt(v)}")


def fmt(v) -> str:
    """A table cell: floats to six significant digits, sequences comma-separated."""
    if isinstance(v, (tuple, list)):
        return ", ".join(fmt(x) for x in v) or "-"
    return f"{v:.6g}" if isinstance(v, (float, np.floating)) else str(v)
