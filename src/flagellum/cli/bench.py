"""``flagellum bench``: speed benchmarks."""

from __future__ import annotations

import click

from ._output import emit_json, emit_table, fmt


@click.command(short_help='Speed: wall seconds per simulated second')
@click.option("--quick", is_flag=True, help="shorter windows (a rough number in seconds)")
@click.option("--window", type=float, default=0.2, show_default=True,
              help="simulated time of the steady-state window [s]")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def bench(quick, window, as_json):
    """Speed benchmarks: wall seconds per simulated second, scaling with N, Brownian."""
    from ..bench import bench as run_bench
    from ..params import check_range

    # at least a few records of the shortest save interval (window/100) that a run resolves
    out = run_bench(check_range("window", window, 1e-3, 10.0, lo_open=False), quick=quick)
    if as_json:
        emit_json(out)
    else:
        emit_table({k: v for k, v in out.items() if k != "scaling"}, "flagellum bench")
        for row in out["scaling"]:
            click.echo("  " + ", ".join(f"{k} {fmt(v)}" for k, v in row.items()))
