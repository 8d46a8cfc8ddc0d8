"""Buckling torque M_c1 of the free swimmer against the load sphere's, by body radius a
(docs/stability.md, "Free swimmer"): linear stability of the paper's filament (N = 50, free
hook, RFT) with the body sphere centred on bead 0, either free in 3D (``--anchor free``)
or sliding along e_z only (the paper's load sphere, Sec. 3.2 / Fig. 8).

    python docs/data/free_swimmer_mc1.py [--plot-only]

writes docs/data/free_swimmer_mc1.json and docs/img/free_swimmer_mc1.png.
"""

import argparse
import json
from pathlib import Path

from flagellum.analysis.stability import _Branch, critical_torque, linear_stability
from flagellum.helix import Helix
from flagellum.hydro import rft
from flagellum.motor import Boundary
from flagellum.params import Params

HERE = Path(__file__).resolve().parent
RADII = (20.0, 10.0, 5.0, 2.0, 1.0, 0.5, 0.35, 0.25)  # µm


def threshold(boundary: Boundary, step: float = 0.25, top: float = 8.0) -> dict:
    """M_c1: the first torque where λ(M) turns positive, bracketed by a scan in steps of
    ``step`` (a small free body makes λ(M) cross zero more than once: a widening bracket
    could step over the first crossing), then refined by :func:`critical_torque`."""
    branch = _Branch(Params(), boundary)
    m = 0.75
    while m <= top:
        if linear_stability(equilibrium=branch.at(m)).lambda_ > 0:
            return critical_torque(Params(), boundary, (m - step, m)).to_dict()
        m += step
    return {}


def compute() -> dict:
    params = Params()
    fixed = critical_torque(params).to_dict()
    coeffs = rft.full_turn_coefficients(Helix.from_filament(params.filament), *params.gammas[:2])
    line = rft.critical_torque_line(coeffs, fixed["critical_force"], params.fluid.viscosity)
    rows = [{"a": a, "sphere": threshold(Boundary("sphere", a)), "free": threshold(Boundary("free", a))}
            for a in RADII]
    return {"anchored": fixed, "eq16_slope": line["slope_per_inverse_radius"], "rows": rows}


def plot(data: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = data["rows"]
    inv = [0.0] + [1 / r["a"] for r in rows]
    m0 = data["anchored"]["critical_torque"]
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    for key, style, label in (("sphere", "o-", "load sphere (z only, paper Fig. 8)"),
                              ("free", "s-", "free swimmer (body free in 3D)")):
        ax.plot(inv, [m0] + [r[key].get("critical_torque") for r in rows], style, label=label)
    x = [0, 1.2]
    ax.plot(x, [m0 + data["eq16_slope"] * v for v in x], "k:", lw=1,
            label="Eq. (16) slope from the anchored M_c1")
    ax.set_xlabel("1/a [1/µm]")
    ax.set_ylabel("M_c1 [pN·µm]")
    ax.set_title("Buckling torque by body radius (N = 50, free hook)", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--plot-only", action="store_true")
    a = p.parse_args()
    js = HERE / "free_swimmer_mc1.json"
    data = json.loads(js.read_text()) if a.plot_only else compute()
    if not a.plot_only:
        js.write_text(json.dumps(data, indent=1))
    plot(data, HERE.parent / "img" / "free_swimmer_mc1.png")


if __name__ == "__main__":
    main()
