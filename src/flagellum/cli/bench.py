"""``flagellum bench``: speed benchmarks."""

from __future__ import annotations

import click

from ._output import emit_json, emit_table, fmt


@click.command(short_help='Speed: wall seconds per simulated second')
@click.option("--quick", is_flag=True, help="shorter windows (a rough number in seconds)")
@click.option("--window", type=float, default=0.2, show_default=True,
              help="simulated time of the steady-state window [s]")
@click.option("--regimes/--no-regimes", "with_regimes", default=True, show_default=True,
              help="the same-work runs from rest (M = 1, 1.6, 3, 5, load sphere, free swimmer, "
                   "thermal) against a tight-tolerance reference")
@click.option("--plot", "plot", type=click.Path(dir_okay=False), default=None,
              help="also run the work–precision comparison (CVODE and the BDF over rtol, BDF2 "
                   "over Δt, with --peer PyElastica over Δt) "
                   "and draw its diagram to this file (PNG)")
@click.option("--plot-regime", "plot_regimes", multiple=True,
              help="regime of the work–precision diagram, a key of flagellum.bench.REGIMES "
                   "(repeatable; default: buckled_M1.6 and from_rest_M1)")
@click.option("--method", type=click.Choice(["cvode", "bdf"]), default=None,
              help="integrator of the deterministic regimes (default: the runs' default "
                   "method, bdf)")
@click.option("--rtol", type=float, default=None,
              help="relative tolerance of the deterministic regimes (default: the solver's)")
@click.option("--peer", is_flag=True,
              help="also run PyElastica on each regime (and over Δt in --plot) from its own "
                   "environment ($FLAGELLUM_PEER_ENV, default /tmp/pyel; made by "
                   "benchmarks/bench_pyelastica.py --install): peer_ratio per regime")
@click.option("--sbt-regimes/--no-sbt-regimes", "with_sbt", default=False, show_default=True,
              help="also the runs from rest at M = 1, 1.6, load sphere and free swimmer with the "
                   "nonlocal mobility (--hydrodynamics sbt), their cost relative to RFT and the "
                   "error of the frozen splitting against the unfrozen one")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def bench(quick, window, with_regimes, plot, plot_regimes, method, rtol, peer, with_sbt, as_json):
    """Speed benchmarks: wall seconds per simulated second, scaling with N, Brownian, and the
    same-work regimes (wall per simulated s, steps, steps per revolution, error of the
    time averages); with --sbt-regimes also the regimes with the nonlocal mobility and their
    cost relative to RFT."""
    from ..bench import REGIMES, bench as run_bench, plot_work_precision
    from ..hydro.options import Hydrodynamics
    from ..params import check_choice, check_range
    from ..simulator import SolverOptions

    for name in plot_regimes:
        check_choice("plot-regime", name, tuple(REGIMES))

    # at least a few records of the shortest save interval (window/100) that a run resolves
    out = run_bench(check_range("window", window, 1e-3, 10.0, lo_open=False), quick=quick, with_regimes=with_regimes,
                    with_work_precision=plot is not None, work_precision_names=plot_regimes,
                    solver=SolverOptions(method=method, **({} if rtol is None else {"rtol": rtol})),
                    peer=peer, hydrodynamics=Hydrodynamics("sbt") if with_sbt else None)
    if plot is not None:
        plot_work_precision(out["work_precision"], plot)
    if as_json:
        emit_json(out)
        return
    skip = ("scaling", "regimes", "work_precision", "sbt_regimes")
    emit_table({k: v for k, v in out.items() if k not in skip}, "flagellum bench")
    for row in out["scaling"]:
        click.echo("  " + ", ".join(f"{k} {fmt(v)}" for k, v in row.items()))
    for name, row in out.get("regimes", {}).items():
        click.echo(f"  {name}: " + ", ".join(
            f"{k} {fmt(row[k])}" for k in ("wall_per_simulated_second", "steps",
                                           "steps_per_revolution", "error", "peer_ratio")
            if row.get(k) is not None)
            + (f", limit {row['limit']['dominant']} ({row['limit']['share']:.0%})"
               if row.get("limit") else ""))
    for name, row in out.get("sbt_regimes", {}).items():
        click.echo(f"  {name} sbt/rft: cpu ×{fmt(row['cpu_ratio'])}, wall ×{fmt(row['wall_ratio'])}"
                   + (f", error {fmt(row['error'])}" if "error" in row else ""))
    for name, d in out.get("work_precision", {}).items():
        for r in d["runs"]:
            setting = f"dt {fmt(r['dt'])}" if "dt" in r else f"rtol {fmt(r['rtol'])}"
            click.echo(f"  {name} {r['method']} {setting}: wall/sim-s "
                       f"{fmt(r['wall_per_simulated_second'])}, error {fmt(r['error'])}")
