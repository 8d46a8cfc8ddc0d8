"""Fig. 6 (the sketch of Sec. 4.1): the helical filament replaced by a straight rod of length
L0 = L sin α with the effective bending rigidity A_eff (App. C), loaded by the thrust
density f∥ and the torque density m (linear force and torque profiles, Eqs. (21) and (23)),
and by the friction f⊥ and the precession χ.

The paper's figure is a sketch without numbers, so this target computes the quantities it
shows for the paper's filament — L0, α, R, A_eff, the friction coefficients per length and
the scales of the hats — and compares the numbers the paper states about them (Sec. 2.4,
Sec. 3, Sec. 4.2, Sec. 5). Panels: (a) the helix and its rod, (b) the force and torque profiles at the
theory's anchored buckling threshold, (c) A_eff/A versus pitch angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._plot import pyplot
from ..io import write_csv
from ..hydro.rft import effective_bending_rigidity
from ..paper import MONOTRICHOUS_HELIX, PAPER
from .common import Comparison, Timer, save_figure, write_h5

#: units of the quantities (the column ``unit`` of ``quantities.csv``; "" if dimensionless)
QUANTITY_UNITS = {
    "kappa0": "1/µm", "tau0": "1/µm", "radius": "µm", "pitch": "µm", "pitch_angle_deg": "deg",
    "length": "µm", "L0": "µm", "turn_length": "µm", "A": "pN·µm²", "C": "pN·µm²",
    "A_eff": "pN·µm²", "torque_scale_A_eff_over_L0": "pN·µm", "force_scale_A_eff_over_L0sq": "pN",
    "rate_scale_A_eff_over_aperp_L0_4": "1/s", "gamma_par": "pN·s/µm²", "gamma_perp": "pN·s/µm²",
    "gamma_rot": "pN·s", "gamma_par_lighthill": "pN·s/µm²", "gamma_perp_lighthill": "pN·s/µm²",
    "gamma_rot_lighthill": "pN·s", "a_perp": "pN·s/µm²", "a_par": "pN·s/µm²", "b_par": "pN·s",
    "c_par": "pN·s/µm", "theory_M_c1": "pN·µm", "theory_F_c1": "pN", "m_density": "pN",
    "f_par_density": "pN/µm", "spring_constant_A_over_R2L": "pN/µm", "persistence_length": "µm",
    "twist_per_length_at_M_c1": "rad/µm", "radius_at_M_c1_mean_twist": "µm",
    "sbt_a_par": "pN·s/µm²", "sbt_b_par": "pN·s", "sbt_c_par": "pN·s/µm", "sbt_thrust_per_torque": "1/µm"}
#: quantities ``reproduce`` returns
HEADLINE = ("L0", "pitch_angle_deg", "A_eff", "torque_scale_A_eff_over_L0",
            "force_scale_A_eff_over_L0sq", "a_perp", "a_par", "b_par", "c_par", "theory_M_c1",
            "theory_F_c1", "turns", "compression_at_1pN")


@dataclass(frozen=True)
class Fig6Data:
    """What Fig. 6 is drawn from: the numbers of the effective rod (:func:`quantities`)."""

    quantities: dict


def quantities(params=None) -> dict:
    """Numbers of the effective rod (units µm, pN, s)."""
    from ..analysis.stability import relative_equilibrium
    from ..helix import Helix
    from ..hydro.rft import rft_summary
    from ..params import Params
    from ..rod.model import positions
    from ..theory.manifold import HelicalRod, load_sphere_curve

    params = params or Params()
    fil = params.filament
    helix = Helix.from_filament(fil)
    rod = HelicalRod.from_params(params)
    summ = rft_summary(params)
    anchored = load_sphere_curve(rod, [0.0]).table()
    Mc, Fc = float(anchored["M"][0]), float(anchored["F"][0])
    kappa0, tau0 = MONOTRICHOUS_HELIX
    mono = Helix.from_filament(params.replace(kappa0=kappa0, tau0=tau0).filament)
    # bond strain of the aligned rotating state at M = 1 (paper: K keeps it below 1.5 %)
    eq = relative_equilibrium(params, 1.0)
    pos = positions(eq.state)
    strain = float(np.abs(np.linalg.norm(np.diff(pos, axis=0), axis=1) / fil.segment_length - 1).max())
    R, a = helix.radius, helix.pitch_angle
    out = {
        "kappa0": fil.kappa0, "tau0": fil.tau0, "radius": R, "pitch": helix.pitch,
        "pitch_angle_deg": math.degrees(a), "sin_alpha": math.sin(a), "length": fil.length,
        "L0": rod.L0, "turns": helix.n_turns, "turn_length": helix.turn_length,
        "A": fil.bend_rigidity, "C": fil.twist_rigidity, "A_eff": rod.A_eff,
        "torque_scale_A_eff_over_L0": rod.torque_scale, "force_scale_A_eff_over_L0sq": rod.force_scale,
        "rate_scale_A_eff_over_aperp_L0_4": rod.rate_scale,
        "gamma_par": params.gammas[0], "gamma_perp": params.gammas[1], "gamma_rot": params.gammas[2],
        "gamma_par_lighthill": summ["lighthill"]["gamma_par"],
        "gamma_perp_lighthill": summ["lighthill"]["gamma_perp"],
        "gamma_rot_lighthill": summ["lighthill"]["gamma_rot"],
        "a_perp": rod.a_perp, "a_par": rod.a_par, "b_par": rod.b_par, "c_par": rod.c_par,
        "delta": (params.gammas[0] - params.gammas[1]) / params.gammas[1],
        "theory_M_c1": Mc, "theory_F_c1": Fc, "m_density": Mc / rod.L0, "f_par_density": Fc / rod.L0,
        "m_hat": float(anchored["m_hat"][0]), "f_par_hat": float(anchored["f_par"][0]),
        "chi_hat": float(anchored["chi"][0]),
        "spring_constant_A_over_R2L": fil.bend_rigidity / (R ** 2 * fil.length),
        "compression_at_1pN": 1.0 * R ** 2 * fil.length / fil.bend_rigidity / rod.L0,
        "persistence_length": fil.bend_rigidity / params.fluid.kT,
        "twist_per_length_at_M_c1": Mc / fil.bend_rigidity,
        "radius_at_M_c1_mean_twist": 1.0 / (1.0 / R + Mc / (2 * fil.bend_rigidity * math.cos(a))),
        "sin_alpha_monotrichous": math.sin(mono.pitch_angle),
        "force_ratio_monotrichous": math.sin(a) / math.sin(mono.pitch_angle),
        "max_bond_strain_aligned_M1": strain,
    }
    return out


def a_eff_ratio(alpha, A_over_C):
    """A_eff/A of Eq. (17) at pitch angle(s) ``alpha`` [rad]."""
    return effective_bending_rigidity(alpha, A_over_C, 1.0) / A_over_C


def plot(q: dict, quality: str, out_dir: Path):
    from ..helix import Helix
    from ..params import Params

    plt = pyplot()
    fig, axs = plt.subplots(1, 3, figsize=(14, 5.2), gridspec_kw={"width_ratios": [1.0, 1.2, 1.2]})
    a = axs[0]
    helix = Helix.from_filament(Params().filament)
    s = np.linspace(0, helix.length, 800)
    p = helix.positions(s)
    p[:, 2] -= p[0, 2]
    a.plot(p[:, 0], p[:, 2], color="tab:blue", lw=1.5, label=f"helical filament, L = {q['length']:g} µm")
    a.plot([0, 0], [0, q["L0"]], color="0.4", lw=6, alpha=0.4,
           label=f"effective rod, $L_0$ = L sin α = {q['L0']:.2f} µm")
    a.annotate("", xy=(0, -0.6), xytext=(0, -0.05), arrowprops=dict(arrowstyle="<-", color="red", lw=2))
    a.text(0.15, -0.55, "motor torque M e$_z$", color="red", fontsize=8)
    a.annotate("", xy=(0.9, 2.5), xytext=(0.9, 5.5), arrowprops=dict(arrowstyle="->", color="tab:green"))
    a.text(0.95, 4.0, "$f_\\parallel$ (thrust\ndensity)", color="tab:green", fontsize=8)
    a.annotate("", xy=(-1.05, 6.2), xytext=(-0.55, 6.2), arrowprops=dict(arrowstyle="->", color="tab:purple"))
    a.text(-1.2, 6.45, "$f_\\perp$", color="tab:purple", fontsize=9)
    a.text(-1.2, 7.6, f"R = {q['radius']:.3f} µm\nα = {q['pitch_angle_deg']:.1f}°\n"
           f"$A_{{eff}}$ = {q['A_eff']:.3f} pN·µm²", fontsize=8)
    a.set_xlim(-1.4, 1.8)
    a.set_ylim(-1.0, q["L0"] + 0.6)
    a.set_aspect("equal")
    a.set(xlabel="x [µm]", ylabel="z [µm]", title="(a) helix and effective rod")
    a.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    a = axs[1]
    z = np.linspace(0, 1, 50)
    a.plot(z, q["theory_F_c1"] * (1 - z), color="tab:green", label=f"thrust F(z) = $f_\\parallel$(L0 − z), F = {q['theory_F_c1']:.3f} pN")
    a.set(xlabel="position along the rod z/$L_0$", ylabel="internal force F(z) [pN]",
          title="(b) loads at the theory's anchored threshold")
    b = a.twinx()
    b.plot(z, q["theory_M_c1"] * (1 - z), "--", color="red", label=f"torque M(z) = m(L0 − z), M = {q['theory_M_c1']:.3f} pN·µm")
    b.set_ylabel("internal torque M(z) [pN·µm]")
    b.set_ylim(0, 2.0 * q["theory_M_c1"])
    a.set_ylim(0, 1.05 * q["theory_F_c1"])
    h1, l1 = a.get_legend_handles_labels()
    h2, l2 = b.get_legend_handles_labels()
    a.legend(h1 + h2, l1 + l2, fontsize=7.5, loc="upper right")
    a = axs[2]
    al = np.radians(np.linspace(5, 89, 200))
    for r in (0.5, 1.0, 2.0):
        a.plot(np.degrees(al), a_eff_ratio(al, r), label=f"A/C = {r:g}")
    for name, deg, key in (("normal", q["pitch_angle_deg"], None),
                           ("monotrichous", math.degrees(math.asin(q["sin_alpha_monotrichous"])), None)):
        a.plot(deg, a_eff_ratio(math.radians(deg), q["A"] / q["C"]), "ko")
        a.annotate(name, (deg, a_eff_ratio(math.radians(deg), q["A"] / q["C"])), textcoords="offset points",
                   xytext=(5, -12), fontsize=8)
    a.set(xlabel="pitch angle α [deg]", ylabel="$A_{eff}/A$ (Eq. (17))", title="(c) effective bending rigidity")
    a.legend(fontsize=8)
    return save_figure(fig, out_dir, "fig6", f"Fig. 6: the helical rod of Sec. 4.1 (quality {quality})")


def nonlocal_coefficients(params=None) -> dict:
    """The rigid helix' axial coefficients per axial length L0 from the nonlocal mobility
    (:func:`flagellum.theory.manifold.nonlocal_coefficients`), beside the local ones of the
    rod theory: ``sbt_a_par`` = A∥/L0, ``sbt_b_par`` = B∥/L0, ``sbt_c_par`` = C∥/L0 and the
    thrust per torque −C∥/B∥ of the helix held on its axis."""
    from ..theory.manifold import nonlocal_coefficients as rod_coefficients

    co = rod_coefficients(params)
    return {"sbt_a_par": co["A_par"], "sbt_b_par": co["B_par"], "sbt_c_par": co["C_par"],
            "sbt_thrust_per_torque": -co["C_par"] / co["B_par"]}


def compute(quality: str, cache=None) -> Fig6Data:
    """The quantities of the paper's filament (of ``cache`` only its ``hydrodynamics``: with a
    nonlocal one, :func:`nonlocal_coefficients` are added; the rod theory stays local)."""
    q = quantities()
    hyd = getattr(cache, "hydrodynamics", None)
    if hyd is not None and not hyd.is_local:
        q.update(nonlocal_coefficients())
    return Fig6Data(q)


def write(out_dir: Path, data: Fig6Data, quality: str) -> list[Path]:
    """``quantities.csv`` (quantity, value, unit) and ``fig6.h5``."""
    q = data.quantities
    return [write_csv(out_dir / "quantities.csv", {"quantity": list(q), "value": list(q.values()),
                                                   "unit": [QUANTITY_UNITS.get(k, "") for k in q]}),
            write_h5(out_dir / "fig6.h5", {"quantities": {k: np.array(v) for k, v in q.items()}},
                     {"quality": quality})]


def compare(data: Fig6Data, quality: str) -> Comparison:
    """The comparison table of ``comparison.md``."""
    q = data.quantities
    cmp = Comparison("fig6", "the helical rod of the buckling theory (sketch quantities)", quality)
    cmp.add("helical turns of the L = 10 µm filament", PAPER["turns"].value, q["turns"], "",
            "L / (2πR/cos α)")
    for k, lab in (("gamma_par", "γ∥"), ("gamma_perp", "γ⊥"), ("gamma_rot", "γR")):
        cmp.add(f"{lab} from Lighthill's formulas (r = 0.01 µm)", PAPER[k].value, q[f"{k}_lighthill"],
                PAPER[k].unit, "App. A formulas, q = 0.09Λ (the simulations use the paper's rounded values)")
    cmp.add("persistence length A/kT", PAPER["persistence_length"].value, q["persistence_length"], "µm",
            "A = 3.5 pN·µm², kT = 4.1e-3 pN·µm")
    cmp.add("relative compression at F = 1 pN", PAPER["compression"].value, q["compression_at_1pN"], "",
            "F/(A/(R²L)) divided by L0")
    cmp.add("largest bond strain [paper: K keeps length changes below 1.5 %]", "< 0.015",
            q["max_bond_strain_aligned_M1"], "", "aligned rotating state at M = 1 (relative_equilibrium)")
    cmp.add("sin α of the monotrichous helix (κ0 = 2.2, τ0 = 2.5 /µm)", PAPER["sin_alpha_mono"].value,
            q["sin_alpha_monotrichous"], "", "geometry")
    cmp.add("increase of F_c ∝ 1/sin α, monotrichous vs normal", PAPER["force_increase_mono"].value,
            q["force_ratio_monotrichous"] - 1, "", "sin α_normal / sin α_mono − 1")
    cmp.note(f"Effective rod (no paper numbers): L0 = {q['L0']:.4f} µm, α = {q['pitch_angle_deg']:.2f}°, "
             f"A_eff = {q['A_eff']:.4f} pN·µm², A_eff/L0 = {q['torque_scale_A_eff_over_L0']:.4f} pN·µm, "
             f"A_eff/L0² = {q['force_scale_A_eff_over_L0sq']:.5f} pN, a⊥ = {q['a_perp']:.4e}, "
             f"a∥ = {q['a_par']:.4e} pN·s/µm², b∥ = {q['b_par']:.4e} pN·s, c∥ = {q['c_par']:.4e} pN·s/µm.")
    cmp.note(f"Anchored threshold of the rod theory (constant friction): m̂ = {q['m_hat']:.3f}, "
             f"f̂∥ = {q['f_par_hat']:.2f}, χ̂ = {q['chi_hat']:.1f}, i.e. M = {q['theory_M_c1']:.3f} pN·µm, "
             f"F = {q['theory_F_c1']:.3f} pN (see fig7).")
    if "sbt_thrust_per_torque" in q:
        cmp.note(f"Nonlocal mobility (SBT), rigid helix held on its axis: A∥/L0 = {q['sbt_a_par']:.4e}, "
                 f"B∥/L0 = {q['sbt_b_par']:.4e}, C∥/L0 = {q['sbt_c_par']:.4e}, thrust per torque "
                 f"{q['sbt_thrust_per_torque']:.4f} /µm (c∥/b∥ of the local rod: "
                 f"{abs(q['c_par'] / q['b_par']):.4f} /µm). The rod theory of this figure is local.")
    return cmp


def headline(data: Fig6Data, quality: str, seconds: float, files: list) -> dict:
    """The numbers ``reproduce`` returns."""
    return {**{k: data.quantities[k] for k in HEADLINE},
            "quality": quality, "wall_seconds": seconds, "files": [str(f) for f in files]}


def run(out_dir: Path, quality: str, cache=None) -> dict:
    """Compute, plot and write Fig. 6 into ``out_dir`` (no analysis step: the quantities are
    the result); returns :func:`headline`."""
    timer = Timer()
    out_dir.mkdir(parents=True, exist_ok=True)
    data = compute(quality, cache)
    files = plot(data.quantities, quality, out_dir)
    files += write(out_dir, data, quality)
    files.append(compare(data, quality).write(out_dir))
    return headline(data, quality, timer.seconds, files)
