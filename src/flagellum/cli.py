"""Command-line interface: ``flagellum COMMAND``.

Every invalid input ends in one line on stderr and exit code 2 (see :func:`run`).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import fields

import click
import numpy as np

from . import __version__
from .errors import FlagellumError
from .params import Filament, Fluid, Friction, Params

_FLAG_HELP = {
    "kappa0": "spontaneous curvature κ0 [1/µm]",
    "tau0": "spontaneous torsion |τ0| [1/µm]",
    "handedness": "helix handedness",
    "bend_rigidity": "bending rigidity A [pN·µm²]",
    "twist_rigidity": "torsional rigidity C [pN·µm²]",
    "stretch_modulus": "stretching modulus K [pN]",
    "length": "contour length L [µm]",
    "segment_length": "bond length h [µm]",
    "viscosity": "viscosity η [pN·s/µm²]",
    "filament_radius": "filament radius r [µm]",
    "kT": "thermal energy kT [pN·µm]",
    "gamma_par": "override γ∥ [pN·s/µm²]",
    "gamma_perp": "override γ⊥ [pN·s/µm²]",
    "gamma_rot": "override γR [pN·s]",
}
_PARAM_NAMES = [f.name for k in (Filament, Fluid) for f in fields(k)] + [
    "gamma_par", "gamma_perp", "gamma_rot"]


def param_options(func):
    """Add one flag per model parameter (same names as the TOML keys) plus ``--config``."""
    for name in reversed(_PARAM_NAMES):
        flag = "--" + name.replace("_", "-")
        if name == "handedness":
            func = click.option(flag, type=click.Choice(["right", "left"]), default=None,
                                help=_FLAG_HELP[name])(func)
        else:
            func = click.option(flag, name, type=float, default=None, help=_FLAG_HELP[name])(func)
    func = click.option("--friction", type=click.Choice(["paper", "lighthill", "custom"]),
                        default=None, help="friction coefficients: paper's rounded values, "
                                           "Lighthill's formulas, or custom γ's")(func)
    func = click.option("--config", type=click.Path(dir_okay=False), default=None,
                        help="TOML file with [filament], [fluid], [friction] tables")(func)
    return func


def params_from_cli(kwargs: dict) -> Params:
    """Pop the parameter flags from ``kwargs`` and build validated :class:`Params`."""
    config = kwargs.pop("config", None)
    base = Params.load_toml(config) if config else Params()
    flat = {name: kwargs.pop(name, None) for name in _PARAM_NAMES + ["friction"]}
    return Params.from_flat(flat, base=base)


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def emit_json(obj) -> None:
    click.echo(json.dumps(_jsonable(obj), indent=2))


def emit_table(rows: dict, title: str | None = None) -> None:
    if title:
        click.echo(title)
    width = max(len(k) for k in rows)
    for k, v in rows.items():
        if isinstance(v, dict):
            click.echo(f"{k}:")
            for k2, v2 in v.items():
                click.echo(f"  {k2:<{width}}  {_fmt(v2)}")
        else:
            click.echo(f"{k:<{width + 2}}  {_fmt(v)}")


def _fmt(v) -> str:
    return f"{v:.6g}" if isinstance(v, (float, np.floating)) else str(v)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="flagellum")
def main():
    """Motor-driven bacterial flagella and their buckling instabilities (Vogel & Stark 2012).

    Units: µm, pN, s.
    """


@main.command()
@param_options
@click.option("--critical-force", type=float, default=1.0, show_default=True,
              help="F_c1 [pN] for the critical-torque line of eq. (25)")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def rft(as_json, critical_force, **kwargs):
    """Rigid-helix resistive-force theory: geometry, friction coefficients, F/M, ω/M."""
    from .hydro.rft import rft_summary
    from .params import check_real

    params = params_from_cli(kwargs)
    out = rft_summary(params, check_real("critical_force", critical_force))
    if as_json:
        emit_json(out)
    else:
        emit_table(out, "Rigid-helix RFT (units µm, pN, s)")


@main.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="flagellum-demo",
              show_default=True, help="output directory")
def demo(out_dir):
    """Quick tour: the paper's filament, its rigid-helix theory and where it buckles."""
    from .hydro.rft import rft_summary

    out = rft_summary(Params())
    emit_table({k: out[k] for k in ("radius", "pitch", "axial_length", "thrust_per_torque",
                                    "omega_per_torque", "A_eff", "pinned")},
               "flagellum demo: the paper's normal-form filament (rigid-helix RFT)")


def _register_optional():
    try:
        from .theory.cli import theory
    except ImportError:  # theory not installed in this build
        return
    main.add_command(theory)


_register_optional()


def run(argv=None) -> int:
    """Entry point: run the CLI, turning every user error into one line and exit code 2."""
    try:
        main.main(args=argv, prog_name="flagellum", standalone_mode=False)
    except FlagellumError as exc:
        click.echo(f"flagellum: error: {exc}", err=True)
        return 2
    except click.exceptions.Abort:
        click.echo("flagellum: aborted", err=True)
        return 130
    except click.ClickException as exc:
        msg = " ".join(exc.format_message().split())
        click.echo(f"flagellum: error: {msg}", err=True)
        return 2
    except click.exceptions.Exit as exc:
        return exc.exit_code
    return 0


def entry():  # console script
    sys.exit(run())


if __name__ == "__main__":
    entry()
