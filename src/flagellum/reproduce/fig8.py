"""Fig. 8 (``fig: compare reorientation rate``, App. C): the reorientation rate λ of the
anchored filament that pulls (M < 0), for several bending and torsional rigidities A, C and
for two helix geometries (normal form of peritrichous bacteria, κ0 = 1.3, τ0 = 2.1 /µm;
monotrichous, κ0 = 2.2, τ0 = 2.5 /µm). Rescaling the torque by A_eff/L0 and the rate by
A_eff/(L0³A⊥/3) collapses all curves onto one master curve.

Method
------
* λ(M) from the linear stability of the aligned state
  (:func:`flagellum.analysis.stability.linear_stability`) at the same rescaled torques
  m̂ = M L0/A_eff for every variant; L = 10 µm, N = 50, the paper's friction coefficients.
* Collapse: at each m̂ the spread (max − min)/mean of λ̂ = λ L0³A⊥/(3A_eff) over the
  variants; for contrast, the same spread when A is used instead of A_eff in both scales
  (curves interpolated in log–log on a common grid).
* The rescaled buckling threshold m̂_c1 = M_c1 L0/A_eff of each variant
  (:func:`flagellum.analysis.stability.critical_torque`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .common import PAPER, Comparison, Timer, mpl, pmap, save_figure, write_csv, write_h5

A0 = 3.5
#: (label, κ0, τ0, A/A0, C/A0)
VARIANTS = {
    "quick": (("normal, A = C = A0", 1.3, 2.1, 1.0, 1.0),
              ("normal, A = C = 2A0", 1.3, 2.1, 2.0, 2.0),
              ("monotrichous, A = C = A0", 2.2, 2.5, 1.0, 1.0)),
    "full": (("normal, A = C = A0", 1.3, 2.1, 1.0, 1.0),
             ("normal, A = C = 2A0", 1.3, 2.1, 2.0, 2.0),
             ("normal, A = C = A0/2", 1.3, 2.1, 0.5, 0.5),
             ("normal, A = A0, C = 2A0", 1.3, 2.1, 1.0, 2.0),
             ("monotrichous, A = C = A0", 2.2, 2.5, 1.0, 1.0),
             ("monotrichous, A = 2A0, C = A0", 2.2, 2.5, 2.0, 1.0)),
}
#: rescaled torques m̂ = M L0/A_eff: M < 0 is the paper's pulling filament (reorientation);
#: M > 0 adds the relaxation rate of the pushing filament up to its buckling (m̂_c1 ≈ 3)
M_HAT = {"quick": (-0.5, -1.0, -2.0, -3.0, -4.5, 1.5, 2.5, 3.5),
         "full": (-0.25, -0.5, -0.75, -1.0, -1.5, -2.0, -2.5, -3.0, -3.5, -4.0, -5.0, -6.0,
                  1.0, 1.5, 2.0, 2.5, 2.75, 3.0, 3.25, 3.5, 4.0)}


def variant_params(v):
    from ..params import Params

    _, k, t, a, c = v
    return Params().replace(kappa0=k, tau0=t, bend_rigidity=a * A0, twist_rigidity=c * A0)


def scales(params) -> dict:
    from ..theory.manifold import HelicalRod

    rod = HelicalRod.from_params(params)
    A_perp = rod.a_perp * rod.L0  # whole filament, eq. (A.5)
    A = params.filament.bend_rigidity
    return {"L0": rod.L0, "A_eff": rod.A_eff, "A_perp": A_perp, "torque": rod.A_eff / rod.L0,
            "rate": rod.A_eff / (rod.L0 ** 3 * A_perp / 3), "torque_A": A / rod.L0,
            "rate_A": A / (rod.L0 ** 3 * A_perp / 3)}


def _job(job: dict) -> dict:
    from ..analysis.stability import critical_torque, linear_stability

    params = variant_params(job["variant"])
    try:
        if job["kind"] == "lambda":
            r = linear_stability(params, job["torque"])
            return {**job, "lambda": r.lambda_, "frequency": r.frequency}
        g = job["guess"]
        ct = critical_torque(params, bracket=(0.75 * g, 1.35 * g), xtol=1e-3)
        return {**job, "M_c1": ct.critical_torque, "F_c1": ct.critical_force}
    except Exception as exc:  # noqa: BLE001 - report and go on
        return {**job, "error": str(exc)}


def spread(curves: list[tuple[np.ndarray, np.ndarray]], n: int = 30) -> float:
    """Largest (max − min)/mean over a common log-spaced grid in the overlap of the curves."""
    lo = max(np.min(np.abs(x)) for x, _ in curves)
    hi = min(np.max(np.abs(x)) for x, _ in curves)
    if not hi > lo:
        return math.nan
    g = np.geomspace(lo, hi, n)
    vals = []
    for x, y in curves:
        o = np.argsort(np.abs(x))
        ax, ay = np.abs(x)[o], np.asarray(y)[o]
        if np.any(ay <= 0):
            return math.nan
        vals.append(np.exp(np.interp(np.log(g), np.log(ax), np.log(ay))))
    v = np.array(vals)
    return float(np.max((v.max(0) - v.min(0)) / v.mean(0)))


def run(out_dir: Path, quality: str, context: dict | None = None) -> dict:
    timer = Timer()
    out_dir.mkdir(parents=True, exist_ok=True)
    variants = VARIANTS[quality]
    sc = {v[0]: scales(variant_params(v)) for v in variants}
    jobs = []
    for v in variants:
        s = sc[v[0]]
        for mh in M_HAT[quality]:
            jobs.append({"kind": "lambda", "variant": v, "m_hat": mh, "torque": mh * s["torque"],
                         "cost": abs(mh * s["torque"])})
        jobs.append({"kind": "critical", "variant": v, "guess": 3.05 * s["torque"], "cost": 5 * s["torque"]})
    res = pmap(_job, jobs)
    lam = [r for r in res if r["kind"] == "lambda"]
    crit = {r["variant"][0]: r for r in res if r["kind"] == "critical"}

    plt = mpl()
    fig, axs = plt.subplots(1, 3, figsize=(16, 5))
    rows = {k: [] for k in ("variant", "kappa0", "tau0", "A", "C", "torque", "lambda", "m_hat",
                            "lambda_hat", "error")}
    curves, curves_A, pos_hat = [], [], {}
    for v in variants:
        s = sc[v[0]]
        pts = sorted((r for r in lam if r["variant"] == v and "error" not in r), key=lambda r: r["m_hat"])
        for r in (r for r in lam if r["variant"] == v):
            rows["variant"].append(v[0])
            rows["kappa0"].append(v[1])
            rows["tau0"].append(v[2])
            rows["A"].append(v[3] * A0)
            rows["C"].append(v[4] * A0)
            rows["torque"].append(r["torque"])
            rows["lambda"].append(r.get("lambda", math.nan))
            rows["m_hat"].append(r["m_hat"])
            rows["lambda_hat"].append(r.get("lambda", math.nan) / s["rate"])
            rows["error"].append(r.get("error", ""))
        if not pts:
            continue
        M = np.array([r["torque"] for r in pts])
        L = np.array([r["lambda"] for r in pts])
        style = "o-" if v[1] == 1.3 else "s--"
        neg = M < 0
        line, = axs[0].plot(M[neg], L[neg], style, ms=4, label=v[0])
        axs[1].plot(M[neg] / s["torque"], L[neg] / s["rate"], style, ms=4, label=v[0], color=line.get_color())
        axs[2].plot(M / s["torque"], L / s["rate"], style, ms=4, label=v[0], color=line.get_color())
        neg = M < 0
        curves.append((M[neg] / s["torque"], L[neg] / s["rate"]))
        curves_A.append((M[neg] / s["torque_A"], L[neg] / s["rate_A"]))
        pos_hat[v[0]] = {round(r["m_hat"], 6): r["lambda"] / s["rate"] for r in pts if r["m_hat"] > 0}
    for a in axs:
        a.axhline(0, color="0.6", lw=0.7)
        a.legend(fontsize=7.5)
    axs[0].set(xlabel="motor torque M [pN·µm]", ylabel="reorientation rate λ [1/s]",
               title="(a) reorientation rate of the pulling filament")
    axs[1].set(xlabel=r"$M L_0 / A_{eff}$", ylabel=r"$\lambda \, L_0^3 A_\perp / (3 A_{eff})$",
               title=f"(b) rescaled: master curve? (quality {quality})")
    axs[2].axvline(0, color="0.6", lw=0.7)
    axs[2].set(xlabel=r"$M L_0 / A_{eff}$", ylabel=r"$\lambda \, L_0^3 A_\perp / (3 A_{eff})$",
               title="(c) rescaled, both signs (M > 0: relaxation, buckling)")
    fig.tight_layout()
    files = save_figure(fig, out_dir, "fig8")
    files.append(write_csv(out_dir / "reorientation.csv", rows))
    crow = {k: [] for k in ("variant", "L0", "A_eff", "A_perp", "torque_scale", "rate_scale", "M_c1",
                            "m_hat_c1", "error")}
    for v in variants:
        s, c = sc[v[0]], crit.get(v[0], {})
        for k, val in (("variant", v[0]), ("L0", s["L0"]), ("A_eff", s["A_eff"]), ("A_perp", s["A_perp"]),
                       ("torque_scale", s["torque"]), ("rate_scale", s["rate"]),
                       ("M_c1", c.get("M_c1", math.nan)), ("m_hat_c1", c.get("M_c1", math.nan) / s["torque"]),
                       ("error", c.get("error", ""))):
            crow[k].append(val)
    files.append(write_csv(out_dir / "scales.csv", crow))
    files.append(write_h5(out_dir / "fig8.h5", {
        "reorientation": {k: np.asarray(v, object if k in ("variant", "error") else float) for k, v in rows.items()},
        "scales": {k: np.asarray(v, object if k in ("variant", "error") else float) for k, v in crow.items()}},
        {"quality": quality}))

    sp = spread(curves) if len(curves) > 1 else math.nan
    # M > 0: the same m̂ for every variant, spread relative to the largest |λ̂| there
    sp_pos = math.nan
    if len(pos_hat) > 1:
        common = set.intersection(*(set(d) for d in pos_hat.values()))
        vals = [np.array([pos_hat[k][m] for k in pos_hat]) for m in sorted(common)]
        if vals:
            sp_pos = float(max(np.ptp(v) for v in vals) / max(np.abs(v).max() for v in vals))
    sp_A = spread(curves_A) if len(curves_A) > 1 else math.nan
    mhc = [x for x in crow["m_hat_c1"] if math.isfinite(x)]
    normal, mono = sc[variants[0][0]], next((sc[v[0]] for v in variants if v[1] == 2.2), None)
    cmp = Comparison("fig8", "master curve of the reorientation rate (App. C)", quality)
    cmp.add("spread of the rescaled rates λ̂ at equal M L0/A_eff < 0 [paper: one master curve]", 0.0, sp, "",
            f"largest (max − min)/mean over {len(curves)} variants, linear stability")
    cmp.add("same spread with A instead of A_eff in both scales (contrast)", "larger", sp_A, "",
            "log–log interpolation on a common grid")
    cmp.add("spread of λ̂ at equal M L0/A_eff > 0 (pushing, up to buckling)", 0.0, sp_pos, "",
            "largest (max − min) at one m̂ over the largest |λ̂|, linear stability")
    if len(mhc) > 1:
        cmp.add("spread of the rescaled buckling torque M_c1 L0/A_eff", 0.0,
                (max(mhc) - min(mhc)) / np.mean(mhc), "", "critical_torque per variant")
    if mono is not None:
        cmp.add("sin α of the monotrichous helix", PAPER["sin_alpha_mono"][0],
                mono["L0"] / 10.0, "", "L0/L")
    cmp.note("Rate scale A_eff/(L0³A⊥/3) with A⊥ of eq. (A.5) for the whole filament; torque scale "
             f"A_eff/L0 (normal helix, A = C = A0: {normal['torque']:.4f} pN·µm and {normal['rate']:.4f} /s).")
    cmp.note("The paper gives no numbers for this figure; the comparison is the collapse itself.")
    for r in res:
        if "error" in r:
            cmp.note(f"{r['variant'][0]}, {r['kind']} at M = {r.get('torque', r.get('guess')):.3g}: {r['error']}")
    files.append(cmp.write(out_dir))
    return {"collapse_spread": sp, "collapse_spread_with_A": sp_A, "collapse_spread_pushing": sp_pos,
            "m_hat_c1": dict(zip(crow["variant"], crow["m_hat_c1"])),
            "variants": [v[0] for v in variants], "quality": quality, "wall_seconds": timer.seconds,
            "files": [str(f) for f in files]}
