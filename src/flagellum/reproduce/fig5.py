"""Fig. 5 (Sec. 3.2): the filament attached to a load sphere of radius a that moves
along z. (a) critical torque M_c1 versus 1/a, with the Eq. (16) line in the inset;
(b) critical thrust F_c1 versus M_c1.

Method
------
* M_c1 and F_c1 for each 1/a from the linear stability of the aligned, steadily
  rotating and translating filament (:func:`flagellum.analysis.stability.critical_torque`,
  N = 50, free hook); 1/a = 0 is the anchored filament. The bracket of each root is
  seeded by the rod theory of Sec. 4 (:func:`flagellum.theory.manifold.load_sphere_curve`) and
  widened until λ changes sign.
* The critical line M_c1 = intercept + slope/a: least-squares fit for 1/a ≤ 1 µm⁻¹
  (biological cell sizes a ≈ 1–2 µm), next to Eq. (16) with the full-turn RFT coefficients
  and our anchored F_c1 (:func:`flagellum.hydro.rft.critical_torque_line`).
* "Linear up to 1/a": the first 1/a where M_c1 falls more than 5 % below the fitted line.
* ``full`` quality checks the linear-stability M_c1 by simulation (the paper's dots): at
  1/a = 0.5, 1, 2, 3 µm⁻¹ a 1-s run at 0.9 M_c1 must stay aligned and one at 1.1 M_c1 buckle
  (:class:`flagellum.analysis.bifurcations.RunConfig`, regimes from the observables).
* The collapse of F_c1 at large 1/a: the M_c1 where F_c1 has fallen to half its plateau
  (linear interpolation), and a fit F_c1 = c (M*² − M_c1²) over the points below 80 % of
  the plateau (the classical F_c + M_c²/(4A) law of Eq. (1), with M* the free-swimmer limit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._plot import pyplot
from ..io import write_csv
from ..paper import PAPER
from .common import UNITS, Comparison, Timer, pmap, save_figure, write_h5
from .shared import Cache, rod_theory_curve

INV_A = {"quick": (0.0, 0.5, 1.0, 2.0, 4.0, 10.0, 20.0),
         "full": (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 8.0, 10.0,
                  15.0, 20.0, 30.0, 50.0)}
FIT_MAX_INV_A = 1.0
#: simulations that check the linear-stability M_c1: (1/a values, ± fraction, simulated time)
CONFIRM = {"quick": ((), 0.1, 1.0), "full": ((0.5, 1.0, 2.0, 3.0), 0.1, 1.0)}
#: columns of ``critical.csv`` and of the theory tables
CRITICAL_COLUMNS = ("inv_a", "a", "M_c1", "F_c1", "omega", "velocity", "chi_onset", "wall_seconds",
                    "error")
THEORY_COLUMNS = ("parameter", "M", "F", "m_hat", "f_par", "f_perp", "chi")
#: units of ``theory.csv`` (the hats m̂, f̂∥, f̂⊥, χ̂ are dimensionless)
THEORY_UNITS = {"inv_a": "1/µm", "M": "pN·µm", "F": "pN"}


@dataclass(frozen=True)
class Fig5Data:
    """What Fig. 5 is drawn from: the critical points, the rod theory and the check runs."""

    points: tuple[dict, ...]  #: :func:`~.shared.load_sphere_threshold` per 1/a of the quality
    theory: dict              #: {radius correction: :func:`~.shared.rod_theory_curve` table}
    sims: tuple[dict, ...]    #: :func:`confirmations` (full quality only)

    @property
    def anchored(self) -> tuple[float, float]:
        """(M_c1, F_c1) at 1/a = 0; (NaN, 1 pN) if that point failed."""
        p = next((p for p in self.points if p["inv_a"] == 0 and "error" not in p), None)
        return (p["M_c1"], p["F_c1"]) if p else (math.nan, 1.0)


def theory_inv_a(quality: str) -> np.ndarray:
    """The dense 1/a grid of the rod-theory lines: 0–5 in steps of 0.25, the quality's 1/a and
    a few larger values up to its largest."""
    extra = np.array([6.0, 8.0, 10.0, 15.0, 20.0, 30.0, 50.0])
    return np.unique(np.concatenate([np.linspace(0, 5, 21), extra[extra <= max(INV_A[quality])],
                                     np.array(INV_A[quality])]))


def _confirm(job: dict) -> dict:
    """A simulation at ``torque`` with the load sphere of 1/a: its regime (paper's dots)."""
    from ..analysis.bifurcations import RunConfig
    from ..motor import Boundary
    from ..params import Params

    hydro = {"hydrodynamics": job["hydrodynamics"]} if job.get("hydrodynamics") else {}
    run = RunConfig(Params(), Boundary(anchor="sphere", sphere_radius=1.0 / job["inv_a"]), job["t_end"],
                    **hydro)
    probe, _ = run(job["torque"])
    return {**job, **{k: probe.get(k) for k in ("regime", "thrust", "sigma_over_sigma0",
                                                 "centroid_offset", "wall_seconds", "error")}}


def _as_expected(c: dict) -> bool:
    return c.get("regime") in (("aligned",) if c["side"] == "below" else ("buckled", "oscillating"))


def confirmations(points: list[dict], quality: str, hydrodynamics=None) -> list[dict]:
    """Simulate just below and above the linear-stability M_c1 at a few 1/a."""
    inv, frac, t_end = CONFIRM[quality]
    mc = {p["inv_a"]: p["M_c1"] for p in points if "error" not in p}
    jobs = [{"inv_a": v, "torque": mc[v] * (1 + s * frac), "side": "below" if s < 0 else "above",
             "t_end": t_end, "cost": mc[v], "hydrodynamics": hydrodynamics} for v in inv if v in mc for s in (-1, 1)]
    return pmap(_confirm, jobs) if jobs else []


def analyse(points: list[dict], F_anchored: float) -> dict:
    from ..helix import Helix
    from ..hydro.rft import critical_torque_line, full_turn_coefficients
    from ..params import Params

    ok = sorted((p for p in points if "error" not in p), key=lambda p: p["inv_a"])
    x = np.array([p["inv_a"] for p in ok])
    M = np.array([p["M_c1"] for p in ok])
    F = np.array([p["F_c1"] for p in ok])
    sel = x <= FIT_MAX_INV_A + 1e-12
    slope, intercept = (np.polyfit(x[sel], M[sel], 1) if sel.sum() >= 2 else (math.nan, math.nan))
    linear_until = math.nan
    if math.isfinite(slope):
        dev = (intercept + slope * x - M) / (intercept + slope * x)
        bad = np.nonzero((x > FIT_MAX_INV_A) & (dev > 0.05))[0]
        if len(bad):
            linear_until = float(x[bad[0]])
    params = Params()
    coeffs = full_turn_coefficients(Helix.from_filament(params.filament), *params.gammas[:2])
    eq25 = critical_torque_line(coeffs, F_anchored, params.fluid.viscosity)
    in12 = (M >= 1.0) & (M <= 2.0)
    plateau = float(np.max(F)) if len(F) else math.nan
    m_half, m_star, fit_pts = math.nan, math.nan, 0
    if len(F) and F[-1] < 0.5 * plateau:
        k = int(np.nonzero(F < 0.5 * plateau)[0][0])
        if k > 0:
            m_half = float(M[k - 1] + (M[k] - M[k - 1]) * (0.5 * plateau - F[k - 1]) / (F[k] - F[k - 1]))
    fall = (F < 0.8 * plateau) & (x > FIT_MAX_INV_A)
    if fall.sum() >= 2:
        # F = c (M*² − M²): linear in M² with slope −c and intercept c M*²
        b1, b0 = np.polyfit(M[fall] ** 2, F[fall], 1)
        if b1 < 0:
            m_star, fit_pts = float(math.sqrt(-b0 / b1)), int(fall.sum())
    return {"slope": float(slope), "intercept": float(intercept), "linear_until": linear_until,
            "eq25": eq25, "F_c1_range_1_2": (float(F[in12].min()), float(F[in12].max())) if in12.any()
            else (math.nan, math.nan), "F_plateau": plateau, "M_half": m_half, "M_star": m_star,
            "parabola_points": fit_pts, "x": x, "M": M, "F": F}


def _theory_lines(a, theory, x: str, y: str) -> None:
    for rc, style in ((False, "--"), (True, ":")):
        a.plot(theory[rc][x], theory[rc][y], style, color="tab:green",
               label="rod theory (Sec. 4)" + (", radius correction" if rc else ", constant friction"))


def plot(ana, theory, crit0, quality, out_dir: Path, sims=()):
    plt = pyplot()
    fig, axs = plt.subplots(1, 2, figsize=(12, 5))
    x, M, F = ana["x"], ana["M"], ana["F"]
    a = axs[0]
    a.plot(x, M, "o-", color="tab:blue", label="linear stability (N = 50)")
    _theory_lines(a, theory, "parameter", "M")
    for side, mfc, lab in (("below", "none", "simulation: aligned"), ("above", "tab:red", "simulation: buckled")):
        pts = [c for c in sims if c["side"] == side]
        if pts:
            ok = [c for c in pts if _as_expected(c)]
            a.plot([c["inv_a"] for c in ok], [c["torque"] for c in ok], "s", color="tab:red",
                   mfc=mfc, ms=7, label=f"{lab} (±10 % of $M_{{c1}}$)")
    a.set(xlabel="inverse sphere radius 1/a [1/µm]", ylabel="critical torque $M_{c1}$ [pN·µm]",
          title=f"(a) critical torque versus 1/a (quality {quality})")
    a.legend(fontsize=8, loc="upper left")
    ins = a.inset_axes([0.55, 0.1, 0.42, 0.4])
    s = x <= 2.5
    ins.plot(x[s], M[s], "o", color="tab:blue", ms=4)
    xx = np.linspace(0, 2.5, 20)
    if math.isfinite(ana["slope"]):
        ins.plot(xx, ana["intercept"] + ana["slope"] * xx, "k-", lw=0.8, label="fit, 1/a ≤ 1")
    e = ana["eq25"]
    ins.plot(xx, e["intercept"] + e["slope_per_inverse_radius"] * xx, "r-", lw=1, label="Eq. (16)")
    ins.plot(xx, crit0 + e["slope_per_inverse_radius"] * xx, "r--", lw=0.8, label="Eq. (16), our intercept")
    ins.set_xlabel("1/a [1/µm]", fontsize=7)
    ins.set_ylabel("$M_{c1}$ [pN·µm]", fontsize=7)
    ins.tick_params(labelsize=6)
    ins.legend(fontsize=6)
    a = axs[1]
    a.plot(M, F, "o-", color="tab:blue", label="linear stability (N = 50)")
    _theory_lines(a, theory, "M", "F")
    if math.isfinite(ana["M_star"]):
        fall = (F < 0.8 * ana["F_plateau"]) & (x > FIT_MAX_INV_A)
        mm = np.linspace(M[fall].min() - 0.3, ana["M_star"], 40)
        b1, b0 = np.polyfit(M[fall] ** 2, F[fall], 1)
        a.plot(mm, b0 + b1 * mm ** 2, "k:", lw=1.2, label=f"$F \\propto M^{{*2}} - M^2$, $M^*$ = {ana['M_star']:.2f}")
    a.set(xlabel="critical torque $M_{c1}$ [pN·µm]", ylabel="critical thrust $F_{c1}$ [pN]",
          title="(b) critical force versus critical torque")
    a.set_ylim(0, 1.35 * np.nanmax(F))
    a.legend(fontsize=8, loc="lower left")
    return save_figure(fig, out_dir, "fig5")


def compute(quality: str, cache: Cache | None = None) -> Fig5Data:
    """M_c1, F_c1 by linear stability at each 1/a of the quality (shared with Fig. 7 through
    ``cache``), the rod theory on :func:`theory_inv_a` (its friction that of the cache's
    mobility) and the check runs."""
    cache = Cache() if cache is None else cache
    points = list(cache.load_sphere_thresholds(quality, INV_A[quality]).points)
    theory = {rc: rod_theory_curve(theory_inv_a(quality), rc, cache.hydrodynamics)
              for rc in (False, True)}
    return Fig5Data(tuple(points), theory, tuple(confirmations(points, quality, cache.hydrodynamics)))


def write(out_dir: Path, data: Fig5Data, quality: str) -> list[Path]:
    """``critical.csv``, ``theory.csv`` and ``fig5.h5``."""
    points, theory, cols, tcols = data.points, data.theory, CRITICAL_COLUMNS, THEORY_COLUMNS
    files = [write_csv(out_dir / "critical.csv", {c: [p.get(c, "") for p in points] for c in cols},
                       UNITS)]
    trows = {}
    for rc in (False, True):
        for c in tcols:
            trows.setdefault("radius_correction", [])
            trows.setdefault(c, [])
            trows[c].extend(list(theory[rc][c]))
        trows["radius_correction"].extend([int(rc)] * len(theory[rc]["parameter"]))
    trows["inv_a"] = trows.pop("parameter")
    files.append(write_csv(out_dir / "theory.csv", trows, THEORY_UNITS))
    ok = [p for p in points if "error" not in p]
    files.append(write_h5(out_dir / "fig5.h5", {
        "stability": {c: np.array([float(p.get(c, math.nan)) for p in ok]) for c in cols[:-1]},
        "theory_constant_friction": {c: np.asarray(theory[False][c], float) for c in tcols},
        "theory_radius_correction": {c: np.asarray(theory[True][c], float) for c in tcols}},
        {"quality": quality}))
    return files


def compare(data: Fig5Data, ana: dict, quality: str) -> Comparison:
    """The comparison table of ``comparison.md``."""
    points, theory, sims = data.points, data.theory, data.sims
    F0 = data.anchored[1]
    e = ana["eq25"]
    cmp = Comparison("fig5", "buckling with a load sphere: M_c1(1/a) and F_c1(M_c1)", quality)
    cmp.add("F_c1, anchored filament (1/a = 0)", PAPER["F_c1"].value, F0, "pN",
            "linear stability: thrust at the root of λ(M) (critical_torque)")
    lo, hi = ana["F_c1_range_1_2"]
    cmp.add("F_c1 for M_c1 between 1 and 2 pN·µm: lowest", PAPER["F_c1"].value, lo, "pN", "linear stability")
    cmp.add("F_c1 for M_c1 between 1 and 2 pN·µm: highest", PAPER["F_c1"].value, hi, "pN",
            "linear stability [paper: nearly constant, slow linear increase]")
    cmp.add("M_c1 linear in 1/a up to 1/a ≈", PAPER["linear_until_inv_a"].value, ana["linear_until"], "1/µm",
            f"first 1/a where M_c1 is > 5 % below the line fitted for 1/a ≤ {FIT_MAX_INV_A:g}"
            + ("" if math.isfinite(ana["linear_until"]) else " (not reached in this 1/a range)"))
    cmp.add("slope of M_c1(1/a), Eq. (16) vs fit", e["slope_per_inverse_radius"], ana["slope"], "pN·µm²",
            "paper column: Eq. (16) with full-turn RFT coefficients and our anchored F_c1; ours: fit for "
            f"1/a ≤ {FIT_MAX_INV_A:g}")
    cmp.add("intercept of M_c1(1/a), Eq. (16) vs fit", e["intercept"], ana["intercept"], "pN·µm",
            "paper column: −(B∥/C∥) F_c1 of Eq. (16); ours: fit for 1/a ≤ 1")
    cmp.add("M_c1 where F_c1 collapses (F_c1 at half its plateau)", PAPER["M_c1_quadratic"].value, ana["M_half"],
            "pN·µm", "linear interpolation of the linear-stability points"
            + ("" if math.isfinite(ana["M_half"]) else " (F_c1 does not fall to half in this 1/a range)"))
    cmp.add("torque where F_c1 → 0 (fit F_c1 = c(M*² − M_c1²))", PAPER["M_c1_quadratic"].value, ana["M_star"],
            "pN·µm", f"fit over {ana['parabola_points']} points below 80 % of the plateau"
            if math.isfinite(ana["M_star"]) else "too few points in the collapse for a fit")
    if sims:
        good = [c for c in sims if _as_expected(c)]
        cmp.add("simulations that agree with the linear-stability M_c1 (aligned at 0.9 M_c1, buckled "
                "at 1.1 M_c1) [paper: M_c1(1/a) from simulations]", len(sims), len(good), "runs",
                "1/a = " + ", ".join(f"{v:g}" for v in CONFIRM[quality][0]) + f" µm⁻¹, "
                f"{CONFIRM[quality][2]:g} s each; regimes: "
                + "; ".join(f"{c['inv_a']:g} {c['side']}: {c.get('regime')}" for c in sims))
    cmp.note("The paper states F_c1 ∝ M_c1² 'near M_c1 ≈ 4'; we read it as the classical law "
             "F_c ∝ M*² − M_c² of Eq. (1) and report where the collapse happens.")
    cmp.note("All M_c1, F_c1 here come from linear stability of the aligned state (a Hopf point); "
             "the subcritical character and hysteresis the paper reports at large torque are not "
             "visible in a linear analysis.")
    cmp.note(f"Rod theory of Sec. 4 (green lines): anchored M_c1 = {theory[False]['M'][0]:.3f} (constant "
             f"friction) and {theory[True]['M'][0]:.3f} pN·µm (radius correction).")
    for p in points:
        if "error" in p:
            cmp.note(f"1/a = {p['inv_a']:g}: no critical torque found ({p['error']})")
    return cmp


def headline(data: Fig5Data, ana: dict, quality: str, seconds: float, files: list) -> dict:
    """The numbers ``reproduce`` returns (``eq25``: the critical-torque line of Eq. (16))."""
    points, sims = data.points, data.sims
    M0, F0 = data.anchored
    e = ana["eq25"]
    lo, hi = ana["F_c1_range_1_2"]
    return {"critical_line": {"intercept": ana["intercept"], "slope_per_inverse_radius": ana["slope"],
                              "fit_max_inv_a": FIT_MAX_INV_A, "method": "linear stability + least squares"},
            "eq25": {"intercept": e["intercept"], "slope_per_inverse_radius": e["slope_per_inverse_radius"],
                     "critical_force": F0},
            "F_c1": F0, "M_c1_anchored": M0, "F_c1_range_for_M_c1_1_to_2": [lo, hi],
            "linear_until_inv_a": ana["linear_until"], "M_c1_at_half_F_c1": ana["M_half"],
            "M_star": ana["M_star"],
            "points": [{k: p.get(k) for k in ("inv_a", "M_c1", "F_c1", "error") if k in p} for p in points],
            "simulations": [{k: c.get(k) for k in ("inv_a", "torque", "side", "regime", "thrust")} for c in sims],
            "quality": quality, "wall_seconds": seconds, "files": [str(f) for f in files]}


def run(out_dir: Path, quality: str, cache: Cache | None = None) -> dict:
    """Compute, analyse, plot and write Fig. 5 into ``out_dir``; returns :func:`headline`."""
    timer = Timer()
    out_dir.mkdir(parents=True, exist_ok=True)
    data = compute(quality, cache)
    ana = analyse(data.points, data.anchored[1])
    files = plot(ana, data.theory, data.anchored[0], quality, out_dir, data.sims)
    files += write(out_dir, data, quality)
    files.append(compare(data, ana, quality).write(out_dir))
    return headline(data, ana, quality, timer.seconds, files)
