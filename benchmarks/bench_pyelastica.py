"""The peer on the same run: PyElastica (explicit Cosserat rod, position Verlet) against
flagellum, N = 50, the paper's filament (L = 10 µm, normal helix κ0 = 1.3, τ0 = 2.1 µm⁻¹,
A = C = 3.5 pN·µm², K = 1e3 pN, local drag γ∥ = 1.6e-3, γ⊥ = 2.8e-3 pN·s/µm²,
γR = 1.26e-6 pN·s), anchored at the motor end, from rest at M = 1.6 pN·µm.

    python benchmarks/bench_pyelastica.py [--window 0.01] [--rounds 2]

PyElastica is installed into its own environment (/tmp/pyel; not a dependency of
flagellum) and run in a subprocess; the two are timed alternately (A B A B) and the ratio of
wall seconds per simulated second is reported with the load average: over the same window,
and against flagellum's whole 0.3 s buckling run (PyElastica's fixed step costs the same per
simulated second in every state; flagellum's adaptive steps cost more once buckled).

The PyElastica model: the same rod (radius r = 2√(A/K), so that E·πr² = K and E·I = A,
Poisson ratio 0 so that C = A), rest curvature and twist of the initial helix, resistive
force theory as an external force per node (γ∥, γ⊥ times the node's length) and a torque
−γR ω3 per element, the motor torque about the first element's tangent, the first node held
in place. PyElastica is inertial: the density is chosen so that the inertial relaxation time
of a bead, m/(γ⊥ h), is 1e-5 s, well below a motor period (~6 ms); Δt is the largest of a
halving sequence that keeps the run finite ("tuned").
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

PEER_ENV = "/tmp/pyel"
N, L, KAPPA, TAU, A, K = 50, 10.0, 1.3, 2.1, 3.5, 1.0e3
G_PAR, G_PERP, G_ROT, TORQUE = 1.6e-3, 2.8e-3, 1.26e-6, 1.6


DTS = (1e-6, 5e-7, 2e-7, 1e-7, 5e-8, 2e-8)  #: Δt tried, largest first [s]


def peer(window: float, dts) -> dict:
    """Run inside the PyElastica environment: the first Δt of ``dts`` that stays finite over
    min(window, 1 ms) (tuning), then the window at that Δt; wall time of the stepping itself."""
    tuning = []
    for dt in dts:
        res = peer_run(min(window, 1e-3), dt)
        tuning.append(res)
        if res["finite"]:
            break
    else:
        return {"finite": False, "tuning": tuning}
    return {**peer_run(window, dt), "tuning": tuning}


def peer_run(window: float, dt: float) -> dict:
    """One PyElastica run of ``window`` simulated seconds at step ``dt``."""
    import numpy as np
    import elastica as ea
    from elastica.timestepper.symplectic_steppers import PositionVerlet

    h = L / N
    r = 2.0 * np.sqrt(A / K)
    E = K / (np.pi * r * r)
    rho = 1e-5 * G_PERP * h / (np.pi * r * r * h)  # node mass m = γ⊥ h · 1e-5 s
    s = np.linspace(0.0, L, N + 1)
    k2 = KAPPA ** 2 + TAU ** 2
    R, c = KAPPA / k2, TAU / np.sqrt(k2)  # radius; cos of the pitch angle
    phi = np.sqrt(k2) * s
    pos = np.stack([R * np.cos(phi) - R, R * np.sin(phi), -c * s])  # starts at 0, runs to −z
    t = np.diff(pos, axis=1)
    t /= np.linalg.norm(t, axis=0)
    mid = 0.5 * (phi[1:] + phi[:-1])
    d1 = np.stack([-np.cos(mid), -np.sin(mid), np.zeros(N)])  # towards the axis
    d1 -= (d1 * t).sum(0) * t
    d1 /= np.linalg.norm(d1, axis=0)
    d2 = np.cross(t.T, d1.T).T
    directors = np.stack([d1, d2, t])  # (3, 3, n): rows d1, d2, d3

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):
        pass

    sim = Sim()
    rod = ea.CosseratRod.straight_rod(N, np.zeros(3), np.array([0.0, 0.0, -1.0]),
                                      np.array([1.0, 0.0, 0.0]), L, r, rho, youngs_modulus=E,
                                      shear_modulus=E / 2.0, position=pos, directors=directors)
    rod.rest_kappa[:] = rod.kappa
    rod.rest_sigma[:] = 0.0
    sim.append(rod)

    class Anchor(ea.ConstraintBase):
        def constrain_values(self, system, time):
            system.position_collection[:, 0] = 0.0

        def constrain_rates(self, system, time):
            system.velocity_collection[:, 0] = 0.0

    class Drag(ea.NoForces):
        def apply_forces(self, system, time=0.0):
            v = system.velocity_collection
            tn = system.tangents
            tt = np.zeros_like(v)
            tt[:, :-1] += tn
            tt[:, 1:] += tn
            tt /= np.linalg.norm(tt, axis=0)
            w = np.full(N + 1, h)
            w[[0, -1]] = h / 2
            vt = (v * tt).sum(0)
            system.external_forces[...] -= w * (G_PAR * vt * tt + G_PERP * (v - vt * tt))

        def apply_torques(self, system, time=0.0):
            system.external_torques[2] -= G_ROT * h * system.omega_collection[2]
            system.external_torques[2, 0] += TORQUE

    sim.constrain(rod).using(Anchor, constrained_position_idx=(0,))
    sim.add_forcing_to(rod).using(Drag)
    sim.finalize()
    stepper = PositionVerlet()
    tt = 0.0
    for _ in range(20):  # compile (untimed)
        tt = stepper.step(sim, tt, dt)
    steps = int(round(window / dt))
    w0 = time.perf_counter()
    for _ in range(steps):
        tt = stepper.step(sim, tt, dt)
    wall = time.perf_counter() - w0
    ok = bool(np.all(np.isfinite(rod.position_collection)))
    strain = float(np.abs(rod.lengths / h - 1).max()) if ok else float("inf")
    return {"dt": dt, "steps": steps, "window": window, "wall": wall, "finite": ok and strain < 0.5,
            "max_strain": strain, "wall_per_simulated_second": wall / window}


def ensure_env() -> str:
    py = os.path.join(PEER_ENV, "bin", "python")
    if not os.path.exists(py):
        subprocess.run([sys.executable, "-m", "venv", PEER_ENV], check=True)
    if subprocess.run([py, "-c", "import elastica"], capture_output=True).returncode:
        subprocess.run([os.path.join(PEER_ENV, "bin", "pip"), "install", "-q", "pyelastica"], check=True)
    return py


def run_peer(py: str, window: float, dts) -> dict:
    r = subprocess.run([py, os.path.abspath(__file__), "--peer", str(window), *map(str, dts)],
                       capture_output=True, text=True)
    if r.returncode:
        return {"finite": False, "error": r.stderr.strip().splitlines()[-1:]}
    return json.loads(r.stdout.strip().splitlines()[-1])


def flagellum_run(window: float) -> dict:
    from flagellum.motor import Motor
    from flagellum.params import Params
    from flagellum.simulator import Simulator

    sim = Simulator(Params(), Motor(TORQUE))
    sim.run(window, save_every=window / 50, progress=False)
    return {"wall": sim.wall_seconds, "steps": sim.steps, "wall_per_simulated_second": sim.wall_seconds / window}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--peer", nargs="+", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--window", type=float, default=0.01)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out", default="benchmarks/bench_pyelastica.json")
    args = ap.parse_args()
    if args.peer:
        print(json.dumps(peer(args.peer[0], args.peer[1:])))
        return
    py = ensure_env()
    from flagellum.bench import load_average, warm_up

    warm_up()
    out = {"load_average_start": load_average(), "window": args.window, "rounds": []}
    dts = DTS
    for _ in range(args.rounds):  # interleaved: peer, flagellum, peer, flagellum
        p = run_peer(py, args.window, dts)
        if not p.get("finite"):
            out["rounds"].append({"pyelastica": p})
            break
        dts = (p["dt"],)  # tuned in the first round
        f = flagellum_run(args.window)
        b = flagellum_run(0.3)  # the whole buckling run (PyElastica's cost per s is constant)
        ps = p["wall_per_simulated_second"]
        out["rounds"].append({"pyelastica": p, "flagellum": f, "flagellum_buckled_0.3s": b,
                              "ratio": ps / f["wall_per_simulated_second"],
                              "ratio_buckled_0.3s": ps / b["wall_per_simulated_second"]})
        print(json.dumps(out["rounds"][-1]), flush=True)
    out["load_average_end"] = load_average()
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
