"""The paper's anchored filament with local RFT and with the nonlocal mobility (SBT): the
figure of docs/hydrodynamics.md.

    python benchmarks/plot_hydro_models.py [--out docs/img/hydro_rft_vs_sbt.png]

(a) Thrust F against motor torque M on the aligned, steadily rotating branch
    (:func:`flagellum.analysis.stability.relative_equilibrium`, N = 50) for both models, up
    to and past each model's buckling threshold M_c1 (computed here by
    :func:`flagellum.analysis.stability.critical_torque`), with the rigid-helix slopes.
(b) The load-sphere line M_c1(1/a): RFT and SBT thresholds by linear stability, read from
    the tables of docs/stability.md (RFT) and docs/hydrodynamics.md (SBT: the sphere at the
    filament's end, centred at x_0 + a e_z, coupled by the grand mobility of beads + body).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from flagellum.analysis.stability import critical_torque, relative_equilibrium
from flagellum.hydro.options import Hydrodynamics
from flagellum.params import Params

#: (1/a [1/µm], M_c1 [pN·µm]) by linear stability, N = 50, free hook: docs/stability.md (RFT)
#: and docs/hydrodynamics.md, "Load sphere" (SBT)
LOAD_SPHERE = {"rft": [(0.0, 1.066), (0.5, 1.552), (1.0, 2.006), (2.0, 2.865)],
               "sbt": [(0.0, 1.585), (0.5, 1.651), (1.0, 1.946), (2.0, 2.595)]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/img/hydro_rft_vs_sbt.png")
    ap.add_argument("--replot", action="store_true", help="redraw from the .json next to --out")
    a = ap.parse_args(argv)
    from flagellum._plot import pyplot

    plt = pyplot()
    p = Params()
    data = {}
    if a.replot:
        with open(a.out.rsplit(".", 1)[0] + ".json") as fh:
            data = json.load(fh)
    for model in () if a.replot else ("rft", "sbt"):
        hyd = Hydrodynamics(model)
        mc = critical_torque(p, hydrodynamics=hyd)
        torques = np.linspace(0.1, 1.25 * mc.critical_torque, 12)
        forces = [float(relative_equilibrium(p, float(m), hydrodynamics=hyd).thrust) for m in torques]
        data[model] = {"torque": torques.tolist(), "thrust": forces, "M_c1": mc.critical_torque,
                       "F_c1": mc.critical_force}
        print(model, json.dumps({k: data[model][k] for k in ("M_c1", "F_c1")}), flush=True)
    fig, axs = plt.subplots(1, 2, figsize=(10, 4))
    for model, color in (("rft", "C0"), ("sbt", "C3")):
        d = data[model]
        m, f = np.array(d["torque"]), np.array(d["thrust"])
        stable = m <= d["M_c1"]
        axs[0].plot(m[stable], f[stable], "-o", color=color, ms=3, label=f"{model.upper()}, aligned")
        axs[0].plot(m[~stable], f[~stable], "o", mfc="none", color=color, ms=4,
                    label=f"{model.upper()}, aligned but unstable")
        axs[0].plot([d["M_c1"]], [d["F_c1"]], "*", color=color, ms=12,
                    label=f"M_c1 = {d['M_c1']:.3f} pN·µm, F_c1 = {d['F_c1']:.3f} pN")
        inv_a, mc1 = np.array(LOAD_SPHERE[model]).T
        axs[1].plot(inv_a, mc1, "-o", color=color, label=model.upper())
    axs[0].axvspan(1.0, 1.5, color="0.9", zorder=0, label="biological motor torques")
    axs[0].set(xlabel="motor torque M [pN·µm]", ylabel="thrust F [pN]",
               title="(a) anchored, N = 50: aligned branch")
    axs[0].legend(fontsize=7)
    axs[1].axhspan(1.0, 1.5, color="0.9", zorder=0)
    axs[1].set(xlabel="1/a [1/µm]", ylabel="M_c1 [pN·µm]",
               title="(b) load sphere of radius a")
    axs[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out, dpi=130)
    with open(a.out.rsplit(".", 1)[0] + ".json", "w") as fh:
        json.dump(data, fh, indent=1)


if __name__ == "__main__":
    main()
