"""Fig. 7 (Sec. 4.2): (a) the manifold of bifurcation points of the helical
rod in (m̂, f̂∥, f̂⊥), (b) buckling curves f̂∥(m̂) for f̂⊥ = 0, 25, …, 300 with the critical
points of the filament (red dots), (c) the plane of Eq. (31) and its intersection with
the manifold, (d) the resulting critical force-torque relation, for constant friction
coefficients and with the torque-dependent radius.

Method
------
* The rod theory of Sec. 4 (:func:`flagellum.theory.manifold.compute_manifold`, shooting with
  exact Newton Jacobians, see docs/theory.md).
* Red dots: M_c1, F_c1 of the filament with load spheres from the linear stability of the
  aligned state (the data of Fig. 5 when run together, otherwise a few load spheres),
  in reduced units m̂ = M L0/A_eff, f̂∥ = F L0²/A_eff.
* Shoulder of the buckling curves (the ridge of the manifold): m̂ of the local minimum of
  the f̂⊥ = 75 curve, where the curves flatten and rise again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._plot import pyplot
from ..io import write_csv
from ..paper import PAPER
from .common import UNITS, Comparison, Timer, save_figure, write_h5
from .shared import Cache, LoadSphereThresholds

if TYPE_CHECKING:
    from ..theory.manifold import ManifoldResult

GRIDS = {"quick": dict(m_values=np.linspace(0, 20, 21), f_par_values=np.linspace(0, 120, 13),
                       inv_a_values=np.linspace(0, 5, 11)),
         "full": dict(m_values=np.linspace(0, 20, 41), f_par_values=np.linspace(0, 120, 41),
                      inv_a_values=np.linspace(0, 5, 21))}
DOT_INV_A = {"quick": (0.0, 1.0, 4.0), "full": (0.0, 0.5, 1.0, 2.0, 4.0, 10.0)}


@dataclass(frozen=True)
class Fig7Data:
    """What Fig. 7 is drawn from: the manifold of the rod theory and the filament's red dots."""

    result: ManifoldResult    #: :func:`~flagellum.theory.manifold.compute_manifold`
    dots: tuple[dict, ...]    #: :func:`red_dots`
    manifold_seconds: float   #: wall time of :func:`~flagellum.theory.manifold.compute_manifold`


def red_dots(quality: str, cache: Cache | None = None) -> list[dict]:
    """Critical points of the filament (linear stability): those of Fig. 5 if the cache holds
    them (this quality first), else a few load spheres."""
    cache = Cache() if cache is None else cache
    for q in (quality, "full", "quick"):
        if q in cache.load_spheres:
            return cache.load_spheres[q].found
    return LoadSphereThresholds.compute(DOT_INV_A[quality], fallback_guess=False,
                                        hydrodynamics=cache.hydrodynamics).found


def shoulder(levels: dict, level: float = 75.0) -> float:
    """m̂ of the local minimum of the f̂⊥ = ``level`` buckling curve (NaN if none)."""
    if level not in levels:
        return math.nan
    m, f, _ = levels[level]
    ok = np.isfinite(f)
    m, f = m[ok], f[ok]
    for k in range(1, len(f) - 1):
        if m[k] > 5 and f[k] < f[k - 1] and f[k] <= f[k + 1]:
            return float(m[k])
    return math.nan


def collapse_torque(tab: dict) -> float:
    """M where the plane-intersection F_c(M) falls to half its maximum (after the maximum)."""
    M, F = np.asarray(tab["M"], float), np.asarray(tab["F"], float)
    ok = np.isfinite(M) & np.isfinite(F)
    M, F = M[ok], F[ok]
    if len(F) < 2:
        return math.nan
    k0 = int(np.argmax(F))
    half = 0.5 * F[k0]
    for k in range(k0 + 1, len(F)):
        if F[k] < half:
            return float(M[k - 1] + (M[k] - M[k - 1]) * (half - F[k - 1]) / (F[k] - F[k - 1]))
    return math.nan


def plot(res, dots, quality, out_dir: Path):
    plt = pyplot()
    rod, s = res.rod, res.surface
    fig = plt.figure(figsize=(13, 10))
    a = fig.add_subplot(2, 2, 1, projection="3d")
    mm, ff = np.meshgrid(s.m_hat, s.f_par, indexing="ij")
    z = np.where(np.isfinite(s.f_perp), np.clip(s.f_perp, -150, 600), np.nan)
    a.plot_surface(mm, ff, z, cmap="viridis", rstride=1, cstride=1, linewidth=0.2, edgecolor="k",
                   alpha=0.9)
    a.set_xlabel(r"$\hat m$")
    a.set_ylabel(r"$\hat f_\parallel$")
    a.set_zlabel(r"critical $\hat f_\perp$ (clipped to [−150, 600])")
    a.set_title("(a) manifold of bifurcation points", fontsize=10)
    a.view_init(elev=25, azim=-130)
    a = fig.add_subplot(2, 2, 2)
    cmap = plt.get_cmap("viridis")
    lv = sorted(res.levels)
    for k, level in enumerate(lv):
        m, f, _ = res.levels[level]
        a.plot(m, f, color=cmap(k / max(1, len(lv) - 1)), lw=1.2,
               label=rf"$\hat f_\perp$ = {level:g}" if level % 100 == 0 or level == 25 else None)
    if dots:
        mh = [p["M_c1"] / rod.torque_scale for p in dots]
        fh = [p["F_c1"] / rod.force_scale for p in dots]
        a.plot(mh, fh, "o", color="red", ms=6, label="filament, linear stability")
    a.set(xlabel=r"$\hat m = M L_0/A_{eff}$", ylabel=r"$\hat f_\parallel = F L_0^2/A_{eff}$",
          title=r"(b) buckling curves, $\hat f_\perp$ = 0, 25, …, 300")
    a.legend(fontsize=7.5)
    a = fig.add_subplot(2, 2, 3)
    data = np.clip(s.f_perp.T, -150, 600)
    pc = a.pcolormesh(s.m_hat, s.f_par, data, shading="auto", cmap="viridis")
    fig.colorbar(pc, ax=a, label=r"critical $\hat f_\perp$ (clipped)")
    mline = np.linspace(0, s.m_hat.max(), 60)
    for rc, style, col in ((False, "-", "tab:blue"), (True, "--", "tab:green")):
        tab = res.plane[rc].table()
        a.plot(tab["m_hat"], tab["f_par"], style, color=col, lw=2,
               label="plane ∩ manifold, " + ("radius correction" if rc else "constant friction"))
    anchored = [(-rod.coefficients(m * rod.torque_scale)[2] * rod.L0 * m / rod.coefficients(m * rod.torque_scale)[1])
                for m in mline]
    a.plot(mline, anchored, "w:", lw=1, label=r"plane at $\hat f_\perp$ = 0 (anchored)")
    a.set_ylim(s.f_par.min(), s.f_par.max())
    a.set(xlabel=r"$\hat m$", ylabel=r"$\hat f_\parallel$", title="(c) plane of Eq. (31) on the manifold")
    a.legend(fontsize=7, loc="upper right")
    a = fig.add_subplot(2, 2, 4)
    for rc, style, col in ((False, "-", "tab:blue"), (True, "--", "tab:green")):
        tab = res.plane[rc].table()
        a.plot(tab["M"], tab["F"], style, color=col, lw=2,
               label="theory, " + ("torque-dependent radius" if rc else "constant friction"))
    if dots:
        a.plot([p["M_c1"] for p in dots], [p["F_c1"] for p in dots], "o", color="red",
               label="filament, linear stability")
    a.set(xlabel="critical torque $M_c$ [pN·µm]", ylabel="critical thrust $F_c$ [pN]",
          title=f"(d) buckling curves (quality {quality})")
    a.set_ylim(bottom=0)
    a.legend(fontsize=8)
    return save_figure(fig, out_dir, "fig7")


def compute(quality: str, cache: Cache | None = None) -> Fig7Data:
    """The manifold on the quality's grid (the rod's friction that of the cache's mobility) and
    the red dots (those of Fig. 5 from ``cache``)."""
    from ..theory.manifold import compute_manifold

    timer = Timer()
    res = compute_manifold(**GRIDS[quality], hydrodynamics=getattr(cache, "hydrodynamics", None))
    seconds = timer.seconds
    return Fig7Data(res, tuple(red_dots(quality, cache)), seconds)


def analyse(data: Fig7Data) -> dict:
    """Anchored thresholds, shoulder, collapse torques and the theory–filament agreement."""
    from ..theory.manifold import load_sphere_curve

    res, dots = data.result, data.dots
    rod = res.rod
    summ = res.summary()
    ridge = shoulder(res.levels)
    coll = {rc: collapse_torque(res.plane[rc].table()) for rc in (False, True)}
    # agreement at low m̂: theory (radius correction) on the load-sphere rays vs linear stability
    agree = math.nan
    low = [p for p in dots if p["M_c1"] / rod.torque_scale < 10]
    if low:
        th = load_sphere_curve(rod, [p["inv_a"] for p in low], radius_correction=True).table()
        rel = [abs(f - p["F_c1"]) / p["F_c1"] for f, p in zip(th["F"], low) if math.isfinite(f)]
        agree = max(rel) if rel else math.nan
    return {"anchored": summ["without_radius_correction"]["anchored"],
            "anchored_radius_correction": summ["with_radius_correction"]["anchored"],
            "shoulder": ridge, "collapse": coll, "agreement": agree, "agreement_dots": low}


def write(out_dir: Path, data: Fig7Data, quality: str) -> list[Path]:
    """``manifold/`` (as ``flagellum theory manifold``), ``red_dots.csv`` and ``fig7.h5``."""
    from ..theory.manifold import write_manifold

    res, dots = data.result, data.dots
    rod = res.rod
    files = write_manifold(res, out_dir / "manifold")
    files.append(write_csv(out_dir / "red_dots.csv", {
        "inv_a": [p["inv_a"] for p in dots], "M_c1": [p["M_c1"] for p in dots],
        "F_c1": [p["F_c1"] for p in dots], "m_hat": [p["M_c1"] / rod.torque_scale for p in dots],
        "f_par_hat": [p["F_c1"] / rod.force_scale for p in dots]}, UNITS))
    s = res.surface
    groups = {"surface": {"m_hat": s.m_hat, "f_par": s.f_par, "f_perp": s.f_perp, "chi": s.chi}}
    for level, (m, f, chi) in res.levels.items():
        groups[f"level_{level:g}"] = {"m_hat": m, "f_par": f, "chi": chi}
    for rc in (False, True):
        tag = "radius_correction" if rc else "constant_friction"
        groups[f"plane_{tag}"] = {k: np.asarray(v, float) for k, v in res.plane[rc].table().items()}
        groups[f"sphere_{tag}"] = {k: np.asarray(v, float) for k, v in res.sphere[rc].table().items()}
    files.append(write_h5(out_dir / "fig7.h5", groups, {"quality": quality}))
    return files


def compare(data: Fig7Data, ana: dict, quality: str) -> Comparison:
    """The comparison table of ``comparison.md``."""
    rod, s = data.result.rod, data.result.surface
    a0, a1 = ana["anchored"], ana["anchored_radius_correction"]
    ridge, coll = ana["shoulder"], ana["collapse"]
    agree, low = ana["agreement"], ana["agreement_dots"]
    cmp = Comparison("fig7", "critical manifold of the helical rod and the force-torque relation", quality)
    cmp.add("anchored M_c1, rod theory with constant friction [paper: simulation ≈ 1.1]",
            PAPER["M_c1"].value, a0["M"], "pN·µm", "compute_manifold: load-sphere ray at 1/a = 0")
    cmp.add("anchored M_c1, rod theory with radius correction [paper: simulation ≈ 1.1]",
            PAPER["M_c1"].value, a1["M"], "pN·µm", "same, R⁻¹ → R⁻¹ + M/(2A cos α)")
    cmp.add("anchored F_c1, rod theory with constant friction", PAPER["F_c1"].value, a0["F"], "pN",
            "compute_manifold")
    cmp.add("anchored F_c1, rod theory with radius correction", PAPER["F_c1"].value, a1["F"], "pN",
            "compute_manifold")
    cmp.add("shoulder of the buckling curves (ridge of the manifold) at m̂ ≈", PAPER["ridge_m_hat"].value,
            ridge, "", "local minimum of the f̂⊥ = 75 buckling curve (grid step "
            f"{np.diff(s.m_hat)[0]:g})")
    cmp.add("theory vs filament for m̂ < 10 [paper: remarkable / quantitative agreement]", 0.0, agree, "",
            "largest relative difference of F_c (theory with radius correction) from the linear-"
            "stability F_c1 on the same load spheres, " + ", ".join(f"1/a = {p['inv_a']:g}" for p in low))
    cmp.add("torque of the collapse of F_c, theory (constant friction) [paper: simulation ≈ 4, theory "
            "shifted to larger torque]", PAPER["M_c1_quadratic"].value, coll[False], "pN·µm",
            "F_c on the plane ∩ manifold at half its maximum")
    cmp.add("torque of the collapse of F_c, theory (radius correction)", PAPER["M_c1_quadratic"].value,
            coll[True], "pN·µm", "same")
    cmp.note("Dimensionless theory in units A_eff/L0 = "
             f"{rod.torque_scale:.4f} pN·µm (torque) and A_eff/L0² = {rod.force_scale:.5f} pN (force).")
    cmp.note("Red dots: linear stability of the filament with load spheres (Fig. 5), not the paper's "
             "simulated points.")
    cmp.note("The paper's printed Eq. (31) has the opposite sign of f∥; the code uses the sign that "
             "reproduces Eq. (16) (docs/theory.md).")
    return cmp


def headline(data: Fig7Data, ana: dict, quality: str, seconds: float, files: list) -> dict:
    """The numbers ``reproduce`` returns."""
    a0, a1, coll = ana["anchored"], ana["anchored_radius_correction"], ana["collapse"]
    return {"M_c1_theory": a0["M"], "M_c1_theory_radius_correction": a1["M"],
            "F_c1_theory": a0["F"], "F_c1_theory_radius_correction": a1["F"],
            "m_hat_c1": a0["m_hat"], "f_par_hat_c1": a0["f_par"], "shoulder_m_hat": ana["shoulder"],
            "collapse_torque": coll[False], "collapse_torque_radius_correction": coll[True],
            "manifold_seconds": data.manifold_seconds, "quality": quality, "wall_seconds": seconds,
            "files": [str(f) for f in files]}


def run(out_dir: Path, quality: str, cache: Cache | None = None) -> dict:
    """Compute, analyse, plot and write Fig. 7 into ``out_dir``; returns :func:`headline`."""
    timer = Timer()
    out_dir.mkdir(parents=True, exist_ok=True)
    data = compute(quality, cache)
    ana = analyse(data)
    files = plot(data.result, data.dots, quality, out_dir)
    files += write(out_dir, data, quality)
    files.append(compare(data, ana, quality).write(out_dir))
    return headline(data, ana, quality, timer.seconds, files)
