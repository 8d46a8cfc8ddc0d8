"""``flagellum info``: the provenance of an output file."""

from __future__ import annotations

import click

from ._output import emit_json


@click.command(short_help='Parameters and provenance of an output file')
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def info(file, as_json):
    """Provenance of an output file: parameters, version, git revision, seed, status."""
    from ..io import read_trajectory

    data = read_trajectory(file)
    attrs = {k: (v.item() if hasattr(v, "item") else v) for k, v in data["attrs"].items()}
    attrs["records"] = int(len(data.get("t", [])))
    if as_json:
        emit_json(attrs)
    else:
        for k, v in attrs.items():
            click.echo(f"{k}:" + ("\n  " + str(v).replace("\n", "\n  ") if "\n" in str(v) else f" {v}"))
