"""``flagellum theory …``: the analytical buckling theory on the command line.

Subcommands: ``buckling`` (critical values of Eq. (29)), ``manifold`` (Fig. 7 data
and plot), ``rigid-helix`` (App. B) and ``effective-rigidity`` (App. C).
"""

from __future__ import annotations

import math

import click
import numpy as np

from ..errors import FlagellumError, ParameterError
from ..paper import HELICES
from ..params import check_range, check_real
from ._options import (hydro_from_cli, hydro_options, output_option, param_options,
                       params_from_cli, time_option)
from ._output import emit_json, emit_table


@click.group(context_settings={"help_option_names": ["-h", "--help"]}, short_help='Analytical buckling theory of the helical rod')
def theory():
    """Analytical buckling theory of the helical rod (paper Sec. 4, App. B and C)."""


def _floats(name: str, text: str | None):
    if text is None:
        return None
    try:
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise ParameterError(name, text, "comma-separated numbers") from None


def _count(name: str, value: int, lo: int, hi: int) -> int:
    if not lo <= value <= hi:
        raise ParameterError(name, value, f"an integer in [{lo}, {hi}]")
    return value


@theory.command(short_help='Critical values of the linearised buckling problem')
@click.option("--m-hat", type=float, default=0.0, show_default=True,
              help="torque m̂ = M L0/A_eff (linear profile: applied at the base)")
@click.option("--f-par", type=float, default=0.0, show_default=True,
              help="compressive thrust f̂∥ = F L0²/A_eff (linear profile)")
@click.option("--f-perp", type=float, default=0.0, show_default=True,
              help="transverse friction f̂⊥ = a⊥ v L0³/A_eff")
@click.option("--chi", type=float, default=0.0, show_default=True,
              help="precession χ̂ = χ a⊥ L0⁴/A_eff")
@click.option("--base", default="hinged", show_default=True, help="hinged | clamped")
@click.option("--top", default="free", show_default=True, help="free | hinged | clamped")
@click.option("--force-profile", default="linear", show_default=True,
              help="linear (self-generated, paper) | uniform (end load)")
@click.option("--torque-profile", default="linear", show_default=True,
              help="linear (paper) | uniform (end torque)")
@click.option("--solve", "unknowns", default="f_perp,chi", show_default=True,
              help="one or two unknowns among m_hat, f_par, f_perp, chi")
@click.option("--guess", default=None,
              help="start values of the unknowns for Newton's method (comma-separated); "
                   "default: global search (needs chi among the unknowns)")
@click.option("--method", default="shooting", show_default=True, help="shooting | collocation")
@click.option("--samples", type=int, default=21, show_default=True,
              help="number of mode samples on z ∈ [0, 1]")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def buckling(m_hat, f_par, f_perp, chi, base, top, force_profile, torque_profile, unknowns,
             guess, method, samples, as_json):
    """Critical values of the linearised buckling equations (paper Sec. 4.1, Eqs. (29)–(30))."""
    from ..theory.buckling import LOAD_LIMIT, BucklingProblem, solve

    loads = [check_range(name, v, -LOAD_LIMIT, LOAD_LIMIT, lo_open=False)
             for name, v in (("m_hat", m_hat), ("f_par", f_par), ("f_perp", f_perp), ("chi", chi))]
    prob = BucklingProblem(*loads, base, top, force_profile, torque_profile)
    cp = solve(prob, unknowns, _floats("guess", guess), method=method)
    mode = cp.mode(_count("samples", samples, 2, 10001))
    out = {**cp.as_dict(), "mode": mode.as_dict()}
    if as_json:
        emit_json(out)
    else:
        emit_table({k: v for k, v in out.items() if k != "mode"},
                   "Critical point of Eq. (29) (dimensionless)")
        click.echo("mode (z, X, Y):")
        for z, x, y in zip(mode.z, mode.X, mode.Y):
            click.echo(f"  {z:6.3f} {x: .6f} {y: .6f}")


@theory.command(short_help='Critical manifold and buckling curves (Sec. 4)')
@param_options
@output_option("out_dir", "output directory for CSV, JSON and PNG", directory=True,
               default="flagellum-theory", show_default=True)
@click.option("--m-max", type=float, default=20.0, show_default=True, help="largest m̂ of the grid")
@click.option("--m-steps", type=int, default=41, show_default=True)
@click.option("--f-par-max", type=float, default=120.0, show_default=True,
              help="largest f̂∥ of the grid")
@click.option("--f-par-steps", type=int, default=41, show_default=True)
@click.option("--inv-a-max", type=float, default=5.0, show_default=True,
              help="largest inverse sphere radius 1/a [1/µm]")
@click.option("--inv-a-steps", type=int, default=21, show_default=True)
@click.option("--base", default="hinged", show_default=True, help="hinged | clamped")
@click.option("--workers", type=int, default=2, show_default=True, help="processes")
@hydro_options
@click.option("--json", "as_json", is_flag=True, help="print the summary as JSON")
def manifold(out_dir, m_max, m_steps, f_par_max, f_par_steps, inv_a_max, inv_a_steps, base,
             workers, as_json, **kwargs):
    """Critical manifold, buckling curves, plane of Eq. (31) and M_c1(1/a) (Fig. 7).

    With ``--hydrodynamics sbt`` the rod's friction per length is that of the rigid helix'
    nonlocal resistance instead of the full-turn RFT coefficients (``--hydro-refresh`` has
    no effect here); the load sphere keeps its Stokes drag alone."""
    from ..parallel import check_workers
    from ..params import check_choice
    from ..theory.buckling import BASES
    from ..theory.manifold import compute_manifold, write_manifold

    hydrodynamics = hydro_from_cli(kwargs)
    params = params_from_cli(kwargs)
    check_choice("base", base, BASES)
    grid = dict(
        m_values=np.linspace(0, check_range("m_max", m_max, 0, 200), _count("m_steps", m_steps, 2, 1001)),
        f_par_values=np.linspace(0, check_range("f_par_max", f_par_max, 0, 5000),
                                 _count("f_par_steps", f_par_steps, 2, 1001)),
        inv_a_values=np.linspace(0, check_range("inv_a_max", inv_a_max, 0, 1000),
                                 _count("inv_a_steps", inv_a_steps, 1, 1001)))
    try:
        result = compute_manifold(params, base=base, workers=check_workers("workers", workers),
                                  hydrodynamics=hydrodynamics, **grid)
    except (ArithmeticError, IndexError, ValueError, np.linalg.LinAlgError) as exc:
        if isinstance(exc, ParameterError):
            raise
        raise FlagellumError(f"the critical manifold cannot be followed for these parameters "
                             f"(γ∥, γ⊥, γR = {', '.join(f'{g:.3g}' for g in params.gammas)}; "
                             f"{type(exc).__name__}: {exc})") from None
    paths = write_manifold(result, out_dir)
    summary = {**result.summary(), "files": [str(p) for p in paths]}
    if as_json:
        emit_json(summary)
    else:
        rows = {"A_eff": result.rod.A_eff, "A_eff/L0": result.rod.torque_scale}
        for key in ("without_radius_correction", "with_radius_correction"):
            a = summary[key]["anchored"]
            rows[f"anchored M_c1 [pN µm] ({key.replace('_', ' ')})"] = a["M"]
            rows[f"anchored F_c1 [pN] ({key.replace('_', ' ')})"] = a["F"]
        rows["time [s]"] = result.timings["total"]
        rows["files"] = ", ".join(p.name for p in paths)
        emit_table(rows, f"Critical manifold written to {out_dir}")


@theory.command("rigid-helix", short_help='Precession of a rigid helix under a torque')
@param_options
@click.option("--torque", type=float, default=1.0, show_default=True, help="|M| [pN µm]")
@click.option("--tilt", type=float, default=30.0, show_default=True,
              help="initial angle between helix axis and torque [deg]")
@time_option(default=None, help="duration [s] (default: two precession periods)")
@click.option("--origin", default="center", show_default=True, help="center | end of the helix")
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
def rigid_helix(torque, tilt, t_end, origin, as_json, **kwargs):
    """Precession of a rigid helix under a constant torque (App. B)."""
    from ..helix import rot_x
    from ..theory.rigid_helix import rotate, rotational_resistance

    params = params_from_cli(kwargs)
    torque, tilt = check_real("torque", torque), check_real("tilt", tilt)
    if not 1e-6 <= abs(torque) <= 1e6:  # (a tiny torque: an endless precession period)
        raise ParameterError("torque", torque, "1e-06 ≤ |torque| ≤ 1e+06")
    B = rotational_resistance(params, origin)
    evals = np.linalg.eigvalsh(B)
    b_perp = float(np.mean(evals[1:]))
    predicted = abs(torque) / b_perp
    period = 2 * math.pi / predicted
    t_end = 2 * period if t_end is None else check_range("time", t_end, 1e-6 * period, 100 * period)
    run = rotate(B, [0.0, 0.0, torque], t_end, R0=rot_x(math.radians(tilt)), n_out=2001)
    m2, p = run.torque_squared, run.dissipation
    out = {"B": B, "B_eigenvalues": evals, "torque": torque, "tilt_deg": tilt, "time": t_end,
           "precession_rate": run.precession_rate(), "precession_rate_predicted": predicted,
           "spin_rate_body": float(np.mean(run.omega_body[:, 2])),
           "M2_relative_drift": float(np.ptp(m2) / m2[0]),
           "P_relative_drift": float(np.ptp(p) / p[0])}
    if as_json:
        emit_json(out)
    else:
        emit_table({k: v for k, v in out.items() if k not in ("B", "B_eigenvalues")},
                   "Rigid helix under constant torque (App. B; units pN, µm, s)")
        click.echo("B eigenvalues [pN µm s]: " + ", ".join(f"{x:.6g}" for x in evals))


def effective_rigidity_summary(params, hydrodynamics=None) -> dict:
    """A_eff (App. C) and the Fig. 8 scales for ``params`` and for the two geometries (the
    rate scale with the rod's friction of ``hydrodynamics``, :meth:`HelicalRod.from_params`)."""
    from ..theory.manifold import HelicalRod

    def scales(p):
        rod = HelicalRod.from_params(p, hydrodynamics)
        return {"kappa0": p.filament.kappa0, "tau0": p.filament.tau0,
                "pitch_angle_deg": math.degrees(rod.pitch_angle), "L0": rod.L0,
                "A_eff": rod.A_eff, "A_eff_over_L0": rod.torque_scale,
                "A_perp": rod.a_perp * rod.L0,   # whole filament, Eq. (38a)
                "torque_scale": rod.torque_scale, "rate_scale": rod.master_rate_scale}

    own = scales(params)
    return {"A_eff": own["A_eff"], "A_eff_over_L0": own["A_eff_over_L0"], "filament": own,
            **{name: scales(params.replace(kappa0=k, tau0=t))
               for name, (k, t) in HELICES.items()}}


@theory.command("effective-rigidity", short_help="Effective bending rigidity A_eff (App. C)")
@param_options
@hydro_options
@click.option("--json", "as_json", is_flag=True, help="print one JSON object")
@click.option("--measure", is_flag=True,
              help="also measure A_eff on the discrete rod (end moments, a few seconds)")
def effective_rigidity(as_json, measure, **kwargs):
    """Effective bending rigidity A_eff (App. C) and the master-curve scales of Fig. 8."""
    hydrodynamics = hydro_from_cli(kwargs)
    params = params_from_cli(kwargs)
    out = effective_rigidity_summary(params, hydrodynamics)
    if measure:
        from ..theory.effective_rigidity import measured_bending_rigidity

        out["A_eff_measured"] = measured_bending_rigidity(params)
    if as_json:
        emit_json(out)
    else:
        emit_table({k: v for k, v in out.items() if not isinstance(v, dict)},
                   "Effective bending rigidity (App. C; units pN, µm, s)")
        for name in ("filament", *HELICES):
            emit_table(out[name], f"{name}:")

