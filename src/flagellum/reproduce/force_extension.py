"""Force–extension curves of a polymorphic filament, side by side with Darnton & Berg,
Biophys. J. 92, 2230 (2007): a coiled filament pulled by a moving optical trap transforms to
the normal form above a threshold force (3–5 pN in the experiment), rate dependent.

Not a figure of Vogel & Stark (2012): the pull of Vogel & Stark, Eur. Phys. J. E 33, 259
(2010), with this package's polymorphic filament (:mod:`flagellum.rod.polymorph`). The
filament (L = 4 µm, the paper's rod otherwise, M = 0) starts in the coiled form; forms
(coiled, normal) with the landscape ``LANDSCAPE`` (barrier 1 pN, wall stiffness 8 pN·µm²,
not fitted to the pull; the defaults of :class:`~flagellum.params.Polymorphism` are fitted to
Hotani's torques and let the coiled form go at about 0.9 pN, docs/polymorphism.md); the trap (stiffness ``TRAP`` pN/µm) moves out by ``TRAVEL`` µm at each
rate and back (:func:`flagellum.pulling.pull_cycle`). The single-form filaments (coiled
alone, normal alone) pulled the same way give the static curves of the two branches. A
normal filament between its neighbours in Calladine's sequence (forms coiled, normal,
semicoiled, the same landscape) pulled past Darnton & Berg's 4–7 pN shows that the model
has no transformation from normal under tension: the pull drives normal away from both
neighbours (:func:`flagellum.rod.polymorph.tension_drive`; docs/polymorphism.md).
Panels: (a) force against extension, (b) the transformation force against the pulling rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._plot import pyplot
from ..io import write_csv
from .common import Comparison, Timer, pmap, save_figure, write_h5

LENGTH = 4.0  #: filament length [µm]
TRAP = 10.0  #: trap stiffness [pN/µm]
TRAVEL = 3.0  #: how far the trap's centre moves out (and back) [µm]
FORMS = ("coiled", "normal")
#: the landscape of the pulls: a barrier of 1 pN and walls of 8 pN·µm², set before the fit of
#: the defaults to Hotani's torque thresholds (barrier 0.25 pN, walls 0.5 pN·µm²), which
#: transform the pulled coiled filament at 0.91 pN (1 µm/s), below Darnton & Berg's 3–5 pN
LANDSCAPE = {"barrier": 1.0, "wall_stiffness": 8.0}
RATES = {"quick": (2.0, 8.0), "full": (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)}  #: [µm/s]
#: the pull of a normal filament between its neighbours: forms, rate [µm/s], travel [µm]
#: (to ≈ 11 pN with TRAP, past Darnton & Berg's 4–7 pN)
NORMAL_FORMS, NORMAL_RATE, NORMAL_TRAVEL = ("coiled", "normal", "semicoiled"), 2.0, 1.5
#: Darnton & Berg (2007), abstract: thresholds from the coiled and from the normal form [pN]
DB_COILED, DB_NORMAL = (3.0, 5.0), (4.0, 7.0)
UNITS = {"rate": "µm/s", "t": "s", "force": "pN", "extension": "µm", "force_up": "pN",
         "extension_up": "µm", "t_up": "s", "force_down": "pN", "extension_down": "µm",
         "t_down": "s", "loop_area": "pN·µm"}


@dataclass(frozen=True)
class ForceExtensionData:
    """The pulls: per rate the records (``curves``), the static single-form curves."""

    rates: tuple
    curves: list
    static: dict


def _params():
    from ..params import Filament, Params

    return Params(Filament(length=LENGTH))


def pull(job: dict) -> dict:
    """One pull cycle (a pool job): ``rate`` [µm/s], ``form`` (a single form) or the
    polymorphic filament."""
    from ..params import Filament, Params, Polymorphism, helix_strains, POLYMORPHIC_FORMS
    from ..pulling import pull_cycle, up_down

    v, params, pm = job["rate"], _params(), None
    form = job.get("form")
    if form == "from normal":
        pm = Polymorphism(forms=NORMAL_FORMS, initial="normal", **LANDSCAPE)
        c = pull_cycle(params, pm, trap_stiffness=TRAP, schedule=up_down(v, NORMAL_TRAVEL / v),
                       samples=150)
        away = np.abs(c.phi - NORMAL_FORMS.index("normal"))
        return {"rate": v, "form": form, "t": c.t, "force": c.force, "extension": c.extension,
                "fraction": 1.0 - c.fraction(NORMAL_FORMS.index("normal")),
                "phi_away_max": float(away.max()), "loop_area": c.transitions().loop_area}
    if form == "coiled":  # the coiled form as the filament's own helix (single-state path)
        pitch, diameter, _ = POLYMORPHIC_FORMS["coiled"]
        k, t = helix_strains(pitch, diameter)
        params = Params(Filament(length=LENGTH, kappa0=k, tau0=t))
    elif form is None:
        pm = Polymorphism(forms=FORMS, initial=FORMS[0], **LANDSCAPE)
    c = pull_cycle(params, pm, trap_stiffness=TRAP, schedule=up_down(v, TRAVEL / v), samples=300)
    out = {"rate": v, "form": form or "polymorphic", "t": c.t, "force": c.force,
           "extension": c.extension, "fraction": c.fraction()}
    if pm is not None:
        out["transitions"] = c.transitions().as_dict()
    return out


def compute(quality: str, cache=None) -> ForceExtensionData:
    rates = RATES[quality]
    jobs = [{"rate": v, "cost": TRAVEL / v} for v in rates]
    jobs += [{"rate": 1.0, "form": f, "cost": 0.3} for f in ("coiled", "normal")]
    jobs.append({"rate": NORMAL_RATE, "form": "from normal", "cost": 0.3})
    res = pmap(pull, jobs)
    curves = [r for r in res if r["form"] == "polymorphic"]
    static = {r["form"]: r for r in res if r["form"] != "polymorphic"}
    return ForceExtensionData(tuple(rates), curves, static)


def analyse(data: ForceExtensionData) -> dict:
    """Thresholds per rate and the slope of the threshold force against ln(rate)."""
    tr = [c["transitions"] for c in data.curves]
    f_up = np.array([t["force_up"] for t in tr])
    ok = np.isfinite(f_up)
    slope = float(np.polyfit(np.log(np.array(data.rates)[ok]), f_up[ok], 1)[0]) if ok.sum() > 1 else math.nan
    ref = tr[int(np.argmin(data.rates))]  # the slowest pull
    nrm = data.static["from normal"]
    return {"normal_force_max": float(np.max(nrm["force"])), "normal_phi_away_max": nrm["phi_away_max"],
            "normal_fraction_max": float(np.max(nrm["fraction"])), "normal_loop_area": nrm["loop_area"],
            "normal_drive_per_pN": _normal_drives(),
            **{"rates": list(data.rates), "force_up": f_up.tolist(),
            "extension_up": [t["extension_up"] for t in tr],
            "force_down": [t["force_down"] for t in tr], "loop_area": [t["loop_area"] for t in tr],
            "fraction_max": [t["fraction_max"] for t in tr],
            "slowest_rate": float(min(data.rates)), "force_up_slowest": ref["force_up"],
            "loop_area_slowest": ref["loop_area"],
            "slope_force_up_per_ln_rate": slope}}


def _normal_drives() -> dict:
    """The small-load drive per pN (:func:`~flagellum.rod.polymorph.tension_drive`) of the
    target's normal form towards each neighbour, and of coiled towards normal."""
    from ..params import Polymorphism
    from ..rod.polymorph import tension_drive

    kap, tau = Polymorphism(forms=NORMAL_FORMS).strains(_params().filament)
    d = lambda i, j: tension_drive(kap[i], tau[i], kap[j] - kap[i], tau[j] - tau[i])
    return {"normal->semicoiled": d(1, 2), "normal->coiled": d(1, 0), "coiled->normal": d(0, 1)}


def plot(data: ForceExtensionData, res: dict, out_dir: Path) -> list:
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.8))
    for f, ls in (("coiled", ":"), ("normal", "--")):
        s = data.static[f]
        a.plot(s["extension"], s["force"], ls, color="0.3", lw=1.2, label=f"{f} alone (static)")
    s = data.static["from normal"]
    a.plot(s["extension"], s["force"], color="tab:orange", lw=1.3,
           label=f"normal between coiled and semicoiled, {s['rate']:g} µm/s: no transformation")
    cmap = plt.get_cmap("viridis")
    for i, c in enumerate(data.curves):
        col = cmap(i / max(1, len(data.curves) - 1))
        a.plot(c["extension"], c["force"], color=col, lw=1.3, label=f"coiled ⇄ normal, {c['rate']:g} µm/s")
    a.axhspan(*DB_COILED, color="tab:red", alpha=0.12, label="Darnton & Berg 2007: 3–5 pN (from coiled)")
    a.axhspan(*DB_NORMAL, color="tab:orange", alpha=0.08, label="Darnton & Berg 2007: 4–7 pN (from normal)")
    a.set_ylim(-2.0, 12.0)
    a.set_xlabel("extension x [µm]")
    a.set_ylabel("force on the free end F [pN]")
    a.set_title("(a) force–extension, trap out and back", fontsize=9)
    a.legend(fontsize=7)
    b.semilogx(res["rates"], res["force_up"], "o-", label="ours: transformation force (way up)")
    b.axhspan(*DB_COILED, color="tab:red", alpha=0.12, label="Darnton & Berg 2007 (coiled)")
    b.set_xticks(res["rates"], [f"{v:g}" for v in res["rates"]])
    b.minorticks_off()
    b.set_xlabel("pulling rate v [µm/s]")
    b.set_ylabel("transformation force [pN]")
    b.set_title(f"(b) rate dependence: dF/d ln v = {res['slope_force_up_per_ln_rate']:.2f} pN", fontsize=9)
    b.legend(fontsize=7)
    return save_figure(fig, out_dir, "force-extension",
                       f"coiled and normal filaments pulled by a trap (k = {TRAP:g} pN/µm, L = {LENGTH:g} µm, M = 0)")


def write(out_dir: Path, data: ForceExtensionData, res: dict, quality: str) -> list:
    rows = {k: [] for k in ("form", "rate", "t", "force", "extension", "fraction")}
    for c in data.curves + list(data.static.values()):
        n = len(c["t"])
        rows["form"] += [c["form"]] * n
        rows["rate"] += [c["rate"]] * n
        for k in ("t", "force", "extension", "fraction"):
            rows[k] += list(np.asarray(c[k], float))
    th = {"rate": res["rates"], "force_up": res["force_up"], "extension_up": res["extension_up"],
          "force_down": res["force_down"], "loop_area": res["loop_area"],
          "fraction_max": res["fraction_max"]}
    return [write_csv(out_dir / "curves.csv", rows, UNITS),
            write_csv(out_dir / "thresholds.csv", th, UNITS),
            write_h5(out_dir / "force-extension.h5",
                     {"thresholds": {k: np.asarray(v, float) for k, v in th.items()},
                      **{f"curve_{i}": {k: np.asarray(c[k], float) for k in ("t", "force", "extension", "fraction")}
                         for i, c in enumerate(data.curves)}},
                     {"quality": quality, "trap_stiffness": TRAP, "length": LENGTH})]


def compare(res: dict, quality: str) -> Comparison:
    cmp = Comparison("force-extension", "force–extension of a coiled filament (Darnton & Berg 2007)",
                     quality)
    cmp.add(f"transformation force from coiled at {res['slowest_rate']:g} µm/s [paper: 3–5, "
            "middle given]", sum(DB_COILED) / 2, res["force_up_slowest"], "pN", "pull_cycle, trap 10 pN/µm, the target's landscape; "
            "largest force before half the joints are normal")
    lo, hi = min(res["force_up"]), max(res["force_up"])
    cmp.add(f"range over rates {min(res['rates']):g}–{max(res['rates']):g} µm/s [paper: 3–5 pN]",
            "3–5", f"{lo:.2f}–{hi:.2f}", "pN", "as above, each rate")
    cmp.add("rate dependence of the threshold [paper: 'highly dependent on stretching rate']",
            "rate dependent", res["slope_force_up_per_ln_rate"], "pN per ln(µm/s)",
            "least-squares slope of F_up against ln v")
    cmp.add("transformation force from normal [paper: 4–7]", "4–7",
            f"none up to {res['normal_force_max']:.1f} (largest shift of φ from normal "
            f"{res['normal_phi_away_max']:.1g})", "pN",
            f"forms coiled, normal, semicoiled at {NORMAL_RATE:g} µm/s: the pull drives normal away "
            "from both neighbours (docs/polymorphism.md)")
    dr = res["normal_drive_per_pN"]
    cmp.add("drive of a small pull per pN, normal → semicoiled / normal → coiled / coiled → normal "
            "[sign: + transforms]", "+ from normal (their 'next, longer' form)",
            f"{dr['normal->semicoiled']:+.2f} / {dr['normal->coiled']:+.2f} / {dr['coiled->normal']:+.2f}",
            "pN/µm per pN", "rod.polymorph.tension_drive (Love §270 moment of an axial load)")
    down = [f for f in res["force_down"] if math.isfinite(f)]
    cmp.add("reverse transformation on relaxing [paper: observed]", "observed",
            f"{min(down):.2f} pN" if down else "none", "",
            "force where the normal fraction fell below 1/2 on the way back")
    cmp.note("Landscape: reproduce.force_extension.LANDSCAPE (barrier 1 pN, wall stiffness 8 pN·µm²; friction "
             "0.1 pN·s and equal well energies as the defaults of Polymorphism), not fitted to Darnton & Berg.")
    cmp.note("From normal: pulling drives a joint towards the less curved form (large loads: g = −A κ κ'); "
             "normal (κ = 1.30/µm) is less curved than coiled (2.20) and semicoiled (2.72) and curly-1 (2.30), "
             "so no form of the table is favoured; the form Darnton & Berg's normal filaments went to was not "
             "identified from their text (only its abstract is stored).")
    cmp.note("Coiled form geometry (pitch 0.3 µm, diameter 0.9 µm) is a placeholder of Darnton & Berg's "
             "description (nearly zero pitch), from recall, unverified.")
    cmp.note(f"Loop areas ∮F dx (dissipated work) per rate: "
             + ", ".join(f"{v:g} µm/s: {a:.2f} pN·µm" for v, a in zip(res["rates"], res["loop_area"])))
    return cmp


def headline(res: dict, quality: str, seconds: float, files: list) -> dict:
    return {"normal_force_max": res["normal_force_max"], "normal_phi_away_max": res["normal_phi_away_max"],
            "slowest_rate": res["slowest_rate"], "force_up_slowest": res["force_up_slowest"], "force_up": res["force_up"],
            "rates": res["rates"], "force_down": res["force_down"], "loop_area": res["loop_area"],
            "slope_force_up_per_ln_rate": res["slope_force_up_per_ln_rate"], "quality": quality,
            "wall_seconds": seconds, "files": [str(f) for f in files]}


def run(out_dir: Path, quality: str, cache=None) -> dict:
    """Compute, analyse, plot and write the target into ``out_dir``; returns :func:`headline`."""
    timer = Timer()
    out_dir.mkdir(parents=True, exist_ok=True)
    data = compute(quality, cache)
    res = analyse(data)
    files = plot(data, res, out_dir)
    files += write(out_dir, data, res, quality)
    files.append(compare(res, quality).write(out_dir))
    return headline(res, quality, timer.seconds, files)
