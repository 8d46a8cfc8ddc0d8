"""Linear stability of the free-swimming cell (docs/stability.md, "Free-swimming cell"): a
body free in 3D with the motor on its surface (the paper's filament, N = 50, RFT).

    python docs/data/cell_stability.py

writes docs/data/cell_stability.json: λ(M) for the paper's free hook and the buckling
torque M_c1 of a cell with an elastic hook (k = 5 pN·µm) as a function of the body radius,
a sphere and a prolate spheroid with the motor at its pole.
"""

import json
from pathlib import Path

from flagellum.analysis.bifurcations import critical
from flagellum.analysis.stability import _Branch, linear_stability
from flagellum.motor import Boundary
from flagellum.params import Params

HERE = Path(__file__).resolve().parent


def main() -> None:
    params = Params()
    out = {"free_hook": [], "elastic_hook": []}
    for a in (1.0, 2.0, 5.0, 20.0):
        br = _Branch(params, Boundary(anchor="free", body_radius=a))
        for m in (0.25, 0.5, 1.0, 1.5):
            r = linear_stability(equilibrium=br.at(m))
            out["free_hook"].append({"body_radius": a, "torque": m, "lambda": r.lambda_,
                                     "frequency": r.frequency, "omega": r.omega,
                                     "velocity": r.velocity, "motor_speed": r.motor_speed})
            print(out["free_hook"][-1], flush=True)
    for a, p in ((0.5, 1.0), (1.0, 1.0), (2.0, 1.0), (5.0, 1.0), (20.0, 1.0), (1.0, 2.0), (0.88, 2.84)):
        b = Boundary(anchor="free", body_radius=a, body_aspect=p, hook="elastic", hook_stiffness=5.0)
        c = critical(params, b)
        row = {"body_radius": a, "body_aspect": p, **c}
        if c.get("M_c1") is not None:
            eq = _Branch(params, b).at(c["M_c1"])
            row.update(omega=eq.omega, velocity=eq.velocity, motor_speed=eq.motor_speed,
                       lambda_half=linear_stability(equilibrium=_Branch(params, b).at(0.5 * c["M_c1"])).lambda_)
        out["elastic_hook"].append(row)
        print(row, flush=True)
    anchored = Boundary(hook="elastic", hook_stiffness=5.0)
    out["elastic_anchored"] = critical(params, anchored)
    (HERE / "cell_stability.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
