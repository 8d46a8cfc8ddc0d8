"""Thrust–speed curve across the buckling transition (docs/motor.md, "Speed-controlled
buckling"): direct simulations under a speed clamp and under a constant torque (two
sweeps), and the aligned state's thrust and linear stability under both drives.

    python docs/data/thrust_speed.py [--time 1.0] [--workers 2]

writes docs/data/thrust_speed.json and docs/img/thrust_speed.png (the paper's filament,
N = 50, anchored, free hook, RFT; each run starts from the stress-free helix, averages over
the last half).
"""

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

from flagellum.analysis.stability import _Branch, critical_speed, critical_torque, linear_stability
from flagellum.motor import Boundary, Motor
from flagellum.params import Params
from flagellum.sweep import Sweep, read_sweep, run_sweep

HERE = Path(__file__).resolve().parent
SPEEDS = "750:975:25"  # rad/s; at 1000 rad/s the clamped filament winds up (docs/motor.md)
TORQUES = "0.8:1.4:0.1"  # pN·µm


def simulations(time: float, workers: int) -> dict:
    out = {}
    with tempfile.TemporaryDirectory() as d:
        for name, axis, values in (("clamp", "motor_speed", SPEEDS), ("torque", "torque", TORQUES)):
            path = Path(d) / f"{name}.nc"
            run_sweep(Sweep.create({axis: values}, {"time": time}), path, workers=workers)
            s = read_sweep(path)
            out[name] = {k: [v.item() if hasattr(v, "item") else v for v in s.data[k].ravel()]
                         for k in ("thrust_mean", "thrust_std", "torque_mean", "motor_speed_mean",
                                   "centroid_offset", "regime", "status")}
            out[name][axis] = [float(v) for v in s.coords[axis]]
    return out


def aligned_branch() -> dict:
    """Thrust and λ of the aligned state along the constant-torque branch, and λ of the
    same states under a clamp at their speed."""
    branch = _Branch(Params(), Boundary())
    rows = []
    for m in np.arange(0.6, 1.501, 0.05):
        eq = branch.at(float(m))
        lt = linear_stability(equilibrium=eq).lambda_
        lc = linear_stability(equilibrium=_with_clamp(eq)).lambda_
        rows.append({"torque": float(m), "omega": eq.omega, "thrust": eq.thrust,
                     "lambda_torque": lt, "lambda_clamp": lc})
    ct, cw = critical_torque(), critical_speed()
    return {"rows": rows, "M_c1": ct.to_dict(), "omega_c1": cw.to_dict()}


def _with_clamp(eq):
    from dataclasses import replace

    return replace(eq, motor=Motor(drive="speed", speed=eq.motor_speed))


def plot(data: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    br = data["branch"]
    rows = br["rows"]
    w = np.array([r["omega"] for r in rows])
    f = np.array([r["thrust"] for r in rows])
    stable = np.array([r["lambda_clamp"] < 0 for r in rows])
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    ax.plot(w, f, "k-", lw=1, alpha=0.35, label="aligned state (linear stability)")
    ax.plot(w[stable], f[stable], "k-", lw=2, label="aligned, stable under the clamp")
    ax.axvline(br["omega_c1"]["motor_speed"], color="C0", ls=":", lw=1)
    ax.axvline(br["M_c1"]["motor_speed"], color="C3", ls=":", lw=1)
    c, t = data["simulations"]["clamp"], data["simulations"]["torque"]
    ok = [i for i, s in enumerate(c["status"]) if s == "ok"]
    ax.errorbar([c["motor_speed"][i] for i in ok], [c["thrust_mean"][i] for i in ok],
                [c["thrust_std"][i] for i in ok], fmt="o", color="C0", ms=5, capsize=2,
                label="speed clamp (simulation)")
    ok = [i for i, s in enumerate(t["status"]) if s == "ok"]
    ax.errorbar([t["motor_speed_mean"][i] for i in ok], [t["thrust_mean"][i] for i in ok],
                [t["thrust_std"][i] for i in ok], fmt="s-", color="C3", ms=5, capsize=2, lw=0.8,
                label="constant torque (simulation)")
    for i in ok:
        ax.annotate(f"{t['torque'][i]:.1f}", (t["motor_speed_mean"][i], t["thrust_mean"][i]),
                    textcoords="offset points", xytext=(-6, 7), fontsize=7, color="C3")
    ax.text(br["omega_c1"]["motor_speed"] - 4, 0.68, "ω_c1 (clamp)", color="C0", fontsize=7,
            ha="right")
    ax.text(br["M_c1"]["motor_speed"] + 4, 0.68, "ω at M_c1", color="C3", fontsize=7)
    ax.set_xlim(620, 990)
    ax.set_ylim(0.65, 1.35)
    ax.set_xlabel("motor speed ω [rad/s]")
    ax.set_ylabel("thrust F [pN]")
    ax.set_title("Thrust–speed curve across buckling (anchored, N = 50; labels: M)", fontsize=10)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--time", type=float, default=1.0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--plot-only", action="store_true")
    p.add_argument("--branch-only", action="store_true", help="recompute the linear stability only")
    a = p.parse_args()
    js = HERE / "thrust_speed.json"
    if a.plot_only:
        data = json.loads(js.read_text())
    elif a.branch_only:
        data = {**json.loads(js.read_text()), "branch": aligned_branch()}
        js.write_text(json.dumps(data, indent=1))
    else:
        data = {"time": a.time, "branch": aligned_branch(), "simulations": simulations(a.time, a.workers)}
        js.write_text(json.dumps(data, indent=1))
    plot(data, HERE.parent / "img" / "thrust_speed.png")


if __name__ == "__main__":
    main()
