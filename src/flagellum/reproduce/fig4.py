"""Fig. 4 (Sec. 3.1.2): (a) relaxation rate λ of the aligned state versus M,
(b) rotation rate ω and precession rate χ, (c) mean end-to-end distance ⟨r⟩/L0 and
(d) its standard deviation σ/σ0 (σ0 = R/√2), with thermal (Brownian) points.

Method
------
* (a) λ(M) from the spectrum of the aligned state's Jacobian
  (:func:`flagellum.analysis.stability.linear_stability`) instead of the paper's fit of a
  perturbed simulation; docs/stability.md shows that both agree (to 0.1 % at M = 1.2).
* (b–d) the deterministic sweep of Fig. 3 (shared when run together), ω = mean motor
  speed over the averaging window, χ = azimuthal rate of the centroid about the motor
  axis, ⟨r⟩ and σ of r(t) = |r_N − r_0|; L0 = axial length of the helix.
* Thermal points: Brownian dynamics (drift-implicit trapezoidal scheme, Δt = 5·10⁻⁵ s,
  kT = 4.1·10⁻³ pN·µm) in the lab frame, from the stress-free helix, averaged over the last
  part of the run. (In the co-rotating frame the fixed-step scheme damps the buckling
  instability: at M = 1.6 the filament stayed straight for 1.2 s, ⟨r⟩/L0 = 0.97.)
* Equipartition: the compression of the helix has the spring constant A/(R²L)
  (Vogel & Stark 2010), so σ² = kT R² L/A and σ/σ0 = √(2 kT L/A).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._plot import pyplot
from ..io import write_csv
from ..paper import PAPER
from .common import UNITS, Comparison, Timer, pmap, save_figure, simulate_point, write_h5
from .shared import REGIME_COLORS, Cache

LAMBDA_TORQUES = {
    "quick": (-1.0, -0.5, 0.3, 0.5, 0.75, 0.9, 1.0, 1.1, 1.2, 1.5),
    "full": tuple(round(x, 2) for x in np.arange(-1.5, 2.001, 0.1) if abs(x) > 1e-9) + (0.05, 0.15, 0.25),
}
#: thermal runs: (torque, simulated time [s], fraction of the run averaged)
THERMAL = {"quick": ((0.5, 0.15, 2 / 3),),
           "full": ((0.5, 1.0, 0.9), (0.8, 1.0, 0.9), (1.0, 1.0, 0.9), (1.6, 1.2, 0.6))}


def _lambda_side(job) -> list[dict]:
    """λ at the torques of one sign, along one continuation branch (``stability_curve``)."""
    from ..analysis.stability import stability_curve
    from ..params import Params

    torques, hydrodynamics = job
    try:
        res = stability_curve(Params(), torques, hydrodynamics=hydrodynamics, errors="return")
    except Exception as exc:  # noqa: BLE001 - report and go on
        res = [exc] * len(torques)
    return [{"torque": M, "error": str(r)} if isinstance(r, Exception) else
            {"torque": M, "lambda": r.lambda_, "frequency": r.frequency,
             "lab_frequency": r.lab_frequency, "omega": r.omega, "thrust": r.thrust}
            for M, r in zip(torques, res)]


def lambda_curve(quality: str, hydrodynamics=None) -> list[dict]:
    """λ(M) of panel (a): one continuation branch per sign of M, the two in parallel."""
    torques = sorted(LAMBDA_TORQUES[quality])
    jobs = [(tuple(M for M in torques if M < 0), hydrodynamics),
            (tuple(M for M in torques if M > 0), hydrodynamics)]
    return sorted((p for side in pmap(_lambda_side, [j for j in jobs if j[0]]) for p in side),
                  key=lambda p: p["torque"])


def thermal_specs(quality: str, log: bool = False) -> list[dict]:
    return [{"torque": M, "t_end": T, "window": w, "thermal": True, "seed": 11 + k, "dt": 5e-5,
             "protocol": "rest", "frame": "lab", "cost": 40 * T, "log": log}
            for k, (M, T, w) in enumerate(THERMAL[quality])]


def equipartition_sigma(params) -> float:
    """σ/σ0 = √(2 kT L/A) from the helix spring constant A/(R²L)."""
    fil = params.filament
    return math.sqrt(2 * params.fluid.kT * fil.length / fil.bend_rigidity)


def plot(lam, points, thermal, rft_omega, crit, quality, out_dir: Path, sig_eq_line: float = math.nan):
    plt = pyplot()
    fig, axs = plt.subplots(2, 2, figsize=(11, 8.5))
    ok = [p for p in points if "error" not in p]
    okt = [p for p in thermal if "error" not in p]
    a = axs[0, 0]
    ll = [p for p in lam if "error" not in p]
    a.plot([p["torque"] for p in ll], [p["lambda"] for p in ll], "o-", ms=4, label="λ (linear stability)")
    a.axhline(0, color="0.6", lw=0.8)
    a.axvline(crit["critical_torque"], color="0.3", ls="--", lw=1,
              label=f"$M_{{c1}}$ = {crit['critical_torque']:.3f} pN·µm")
    a.set(xlabel="motor torque M [pN·µm]", ylabel="relaxation rate λ [1/s]",
          title="(a) stability of the aligned state")
    a.legend(fontsize=8)
    a = axs[0, 1]
    Ms = np.linspace(min([p["torque"] for p in ok] + [-1.0]), 1.5, 50)
    a.plot(Ms, rft_omega * Ms, "r-", lw=1.2, label=f"RFT, pinned rigid helix ({rft_omega:.0f} M)")
    a.plot([p["torque"] for p in ll], [p["omega"] for p in ll], "k:", lw=1, label="aligned state (stability)")
    for reg in REGIME_COLORS:
        sel = [p for p in ok if p["regime"] == reg]
        if sel:
            a.plot([p["torque"] for p in sel], [p["omega"] for p in sel], "o", color=REGIME_COLORS[reg], label=f"ω, {reg}")
    a.set(xlabel="motor torque M [pN·µm]", ylabel="ω [rad/s]", title="(b) rotation rate ω; inset: precession χ")
    lo, hi = a.get_ylim()
    a.set_ylim(lo, hi + 0.45 * (hi - lo))  # room for the legend
    a.legend(fontsize=7, loc="upper left")
    ins = a.inset_axes([0.55, 0.08, 0.42, 0.3])
    ins.plot([p["torque"] for p in ok], [p["chi"] for p in ok], "s-", ms=3, color="tab:purple")
    ins.set_xlabel("M [pN·µm]", fontsize=7)
    ins.set_ylabel("χ [rad/s]", fontsize=7)
    ins.tick_params(labelsize=6)
    for a, key, lab, title in ((axs[1, 0], "r_over_L0", r"$\langle r\rangle / L_0$", "(c) mean end-to-end distance"),
                               (axs[1, 1], "sigma_over_sigma0", r"$\sigma / \sigma_0$", "(d) its standard deviation")):
        a.plot([p["torque"] for p in ok], [p[key] for p in ok], "o-", color="tab:blue", ms=4,
               label="deterministic")
        if okt:
            a.plot([p["torque"] for p in okt], [p[key] for p in okt], "o", color="red", ms=6,
                   label="thermal (Brownian dynamics)")
            if key == "sigma_over_sigma0":
                a.plot([p["torque"] for p in okt], [p["sigma_fast_over_sigma0"] for p in okt], "o",
                       color="red", mfc="none", ms=7, label="thermal, fast part (about 10-ms mean)")
                a.axhline(sig_eq_line, color="red", ls=":", lw=1, label=f"equipartition {sig_eq_line:.3f}")
        a.axvline(crit["critical_torque"], color="0.3", ls="--", lw=1)
        a.set(xlabel="motor torque M [pN·µm]", ylabel=lab, title=title)
        a.legend(fontsize=8)
    return save_figure(fig, out_dir, "fig4", f"Fig. 4 (quality {quality})")


@dataclass(frozen=True)
class Fig4Data:
    """What Fig. 4 is drawn from."""

    lam: list             #: λ(M) of the aligned state, by torque
    points: tuple         #: the deterministic sweep of Fig. 3
    thermal: list         #: the Brownian runs
    crit: dict            #: :class:`~.shared.AnchoredThreshold` values
    rft_omega: float      #: ω/M of the pinned rigid helix (RFT) [rad/(s·pN·µm)]
    sig_eq: float         #: σ/σ0 from equipartition


def compute(quality: str, cache: Cache | None = None) -> Fig4Data:
    """The thermal runs and the λ curve, then the sweep and M_c1 (shared with Fig. 3)."""
    from ..hydro.rft import rft_summary
    from ..params import Params

    cache = Cache() if cache is None else cache
    params = Params()
    # thermal runs and the λ curve first: the sweep may already be cached by Fig. 3; the
    # thermal runs keep the local mobility (no thermal noise with a nonlocal one)
    thermal = pmap(simulate_point, thermal_specs(quality, cache.log))
    lam = lambda_curve(quality, cache.hydrodynamics)
    points = cache.sweep(quality).points
    crit = cache.anchored_threshold().values
    rft_omega = float(rft_summary(params)["pinned"]["omega_per_torque"])
    return Fig4Data(lam, points, thermal, crit, rft_omega, equipartition_sigma(params))


def analyse(data: Fig4Data) -> dict:
    """σ/σ0 of the thermal runs below M_c1, λ by torque and its root on the grid, ω/M."""
    lam, points, thermal, crit = data.lam, data.points, data.thermal, data.crit
    below = [p for p in thermal if "error" not in p and p["torque"] < crit["critical_torque"]]
    sig_th = float(np.mean([p["sigma_over_sigma0"] for p in below])) if below else math.nan
    sig_fast = float(np.mean([p["sigma_fast_over_sigma0"] for p in below])) if below else math.nan
    ll = [p for p in lam if "error" not in p]
    lam_dict = {f"{p['torque']:g}": p["lambda"] for p in ll}
    root = math.nan
    for p, q in zip(ll, ll[1:]):
        if p["torque"] > 0.5 and p["lambda"] < 0 <= q["lambda"]:
            root = p["torque"] + (q["torque"] - p["torque"]) * (-p["lambda"]) / (q["lambda"] - p["lambda"])
            break
    ok = [p for p in points if "error" not in p]
    aligned = [p for p in ok if p["regime"] == "aligned" and 0 < p["torque"] <= 1.0]
    w_slope = (float(np.sum([p["torque"] * p["omega"] for p in aligned]) /
                     np.sum([p["torque"] ** 2 for p in aligned])) if aligned else math.nan)
    return {"below": below, "sig_th": sig_th, "sig_fast": sig_fast, "lam_dict": lam_dict,
            "root": root, "w_slope": w_slope}


def write(out_dir: Path, data: Fig4Data, quality: str) -> list[Path]:
    """``lambda.csv``, ``observables.csv``, ``thermal.csv`` and ``fig4.h5``."""
    lam, points, thermal = data.lam, data.points, data.thermal
    files = [write_csv(out_dir / "lambda.csv", {k: [p.get(k, math.nan) for p in lam] for k in
                                               ("torque", "lambda", "frequency", "lab_frequency",
                                                "omega", "thrust")}, UNITS)]
    cols = ("torque", "regime", "omega", "chi", "r_mean", "r_std", "r_over_L0", "sigma_over_sigma0")
    files.append(write_csv(out_dir / "observables.csv", {c: [p.get(c, "") for p in points] for c in cols},
                           UNITS))
    tcols = ("torque", "t_end", "t_from", "thrust_mean", "thrust_std", "r_mean", "r_std", "r_over_L0",
             "sigma_over_sigma0", "sigma_fast_over_sigma0", "wall_seconds", "error")
    files.append(write_csv(out_dir / "thermal.csv", {c: [p.get(c, "") for p in thermal] for c in tcols},
                           UNITS))
    num = lambda rows, keys: {k: np.array([float(p.get(k, math.nan)) if not isinstance(p.get(k), str)
                                           else math.nan for p in rows]) for k in keys}
    files.append(write_h5(out_dir / "fig4.h5", {
        "lambda": num(lam, ("torque", "lambda", "frequency", "lab_frequency", "omega", "thrust")),
        "deterministic": num([p for p in points if "error" not in p], cols[:1] + cols[2:]),
        "thermal": num([p for p in thermal if "error" not in p], tcols[:-1])}, {"quality": quality}))
    return files


def compare(data: Fig4Data, ana: dict, quality: str) -> Comparison:
    """The comparison table of ``comparison.md``."""
    from ..params import Params

    points, thermal, crit, rft_omega = data.points, data.thermal, data.crit, data.rft_omega
    params = Params()
    sig_eq, below, sig_th, lam_dict = data.sig_eq, ana["below"], ana["sig_th"], ana["lam_dict"]
    root, w_slope = ana["root"], ana["w_slope"]
    ok = [p for p in points if "error" not in p]
    okt = [p for p in thermal if "error" not in p]
    iii = [p for p in ok if p["regime"] == "buckled"]

    cmp = Comparison("fig4", "λ, ω and χ, ⟨r⟩/L0 and σ/σ0 versus M", quality)
    cmp.add("σ/σ0 below M_c1 from equipartition", PAPER["sigma_equipartition"].value, sig_eq, "",
            "√(2kT L/A) with the helix spring constant A/(R²L), kT = 4.1e-3 pN·µm")
    cmp.add("σ/σ0 below M_c1, simulated with thermal noise (mean of the runs below)",
            PAPER["sigma_simulated"].value, sig_th, "",
            "Brownian dynamics at M = " + ", ".join(f"{p['torque']:g}" for p in below)
            + " pN·µm (" + ", ".join(format(p["t_end"], "g") for p in below) + " s)")
    for p in below:
        cmp.add(f"σ/σ0 with thermal noise at M = {p['torque']:g} pN·µm", PAPER["sigma_simulated"].value,
                p["sigma_over_sigma0"], "", f"std of r(t) over t ≥ {p['t_from']:.3g} s (paper's definition)")
        cmp.add(f"fast part of σ/σ0 at M = {p['torque']:g} pN·µm (compressional fluctuations)",
                PAPER["sigma_simulated"].value, p["sigma_fast_over_sigma0"], "",
                "std of r(t) about its 10-ms running mean")
    cmp.add("M where λ changes sign (supercritical Hopf)", PAPER["M_c1"].value,
            crit["critical_torque"], "pN·µm", "root of λ(M), critical_torque (N = 50)")
    if math.isfinite(root):
        cmp.add("M where λ changes sign, linear interpolation of the λ grid", PAPER["M_c1"].value, root,
                "pN·µm", "λ(M) grid of panel (a)")
    for M in (-1.0, -0.5):
        if f"{M:g}" in lam_dict:
            cmp.add(f"λ at M = {M:g} pN·µm [paper: small and positive]", "small, > 0", lam_dict[f"{M:g}"],
                    "1/s", "linear stability")
    for M in (0.5, 1.0, 1.2):
        if f"{M:g}" in lam_dict:
            cmp.add(f"λ at M = {M:g} pN·µm [paper: < 0 below M_c1, > 0 above]",
                    "< 0" if M < 1.1 else "> 0", lam_dict[f"{M:g}"], "1/s", "linear stability")
    if iii:
        cmp.add("largest σ/σ0 in regime (iii) [paper: σ0 is the maximum of σ in (iii)]", 1.0,
                max(p["sigma_over_sigma0"] for p in iii), "", "deterministic sweep")
    iv = [p for p in ok if p["regime"] == "oscillating"]
    if iv:
        cmp.add("σ/σ0 in regime (iv) [paper: strong increase]", "> 1", max(p["sigma_over_sigma0"] for p in iv),
                "", "deterministic sweep")
    cmp.add("ω/M in the aligned regime [paper: RFT line]", rft_omega, w_slope, "rad/(s·pN·µm)",
            "slope through 0 of the simulated motor speed for 0 < M ≤ 1; paper column = our RFT "
            "(pinned rigid helix)")
    for p in okt:
        det = min(ok, key=lambda q: abs(q["torque"] - p["torque"])) if ok else None
        if det is not None and abs(det["torque"] - p["torque"]) < 1e-9:
            cmp.add(f"thermal ⟨r⟩/L0 at M = {p['torque']:g} [paper: agrees with deterministic]",
                    det["r_over_L0"], p["r_over_L0"], "", "paper column = our deterministic run")
    kT = params.fluid.kT
    cmp.add("persistence length A/kT", PAPER["persistence_length"].value,
            params.filament.bend_rigidity / kT, "µm", "A = 3.5 pN·µm², kT = 4.1e-3 pN·µm")
    if iii:
        p = min(iii, key=lambda q: q["torque"])
        cmp.add(f"precession χ at M = {p['torque']:g} (buckled) [paper: χ ≠ 0 only when buckled]",
                "≠ 0", p["chi"], "rad/s", "deterministic sweep (centroid azimuth)")
    cmp.note("λ: eigenvalue of the aligned state's Jacobian in the co-rotating frame (the paper fits "
             "a perturbed simulation; docs/stability.md compares both).")
    cmp.note("σ of the thermal runs contains slow drifts of weakly damped modes (tilt and, near M_c1, "
             "the buckling mode, with relaxation times up to seconds), so it grows with the run length "
             "and scatters between seeds; its fast part (r about its 10-ms running mean) is the "
             "compressional fluctuation that the equipartition estimate describes.")
    cmp.note("Thermal runs use the lab frame: in the co-rotating frame the fixed-step implicit "
             "scheme (Δt = 5e-5 s) damps the buckling instability (at M = 1.6 the filament stayed "
             "straight for 1.2 s).")
    cmp.note("ω is the mean motor (hook-frame) speed; in the buckled regimes it differs from the "
             "spin about the local helix axis by the precession.")
    for p in [q for q in [*thermal, *points] if "error" in q]:
        cmp.note(f"run at M = {p['torque']:g} failed: {p['error']}")
    return cmp


def headline(data: Fig4Data, ana: dict, quality: str, seconds: float, files: list) -> dict:
    """The numbers ``reproduce`` returns."""
    okt = [p for p in data.thermal if "error" not in p]
    return {"sigma_over_sigma0_thermal": ana["sig_th"], "sigma_over_sigma0_thermal_fast": ana["sig_fast"],
            "sigma_over_sigma0_equipartition": data.sig_eq,
            "thermal_points": {f"{p['torque']:g}": {"sigma_over_sigma0": p["sigma_over_sigma0"],
                                                    "sigma_fast_over_sigma0": p["sigma_fast_over_sigma0"],
                                                    "r_over_L0": p["r_over_L0"]} for p in okt},
            "lambda": ana["lam_dict"], "lambda_root": data.crit["critical_torque"],
            "omega_per_torque": ana["w_slope"], "omega_per_torque_rft": data.rft_omega,
            "quality": quality, "wall_seconds": seconds, "files": [str(f) for f in files]}


def run(out_dir: Path, quality: str, cache: Cache | None = None) -> dict:
    """Compute, analyse, plot and write Fig. 4 into ``out_dir``; returns :func:`headline`."""
    timer = Timer()
    out_dir.mkdir(parents=True, exist_ok=True)
    data = compute(quality, cache)
    files = plot(data.lam, data.points, data.thermal, data.rft_omega, data.crit, quality, out_dir,
                 data.sig_eq)
    files += write(out_dir, data, quality)
    ana = analyse(data)
    files.append(compare(data, ana, quality).write(out_dir))
    return headline(data, ana, quality, timer.seconds, files)
