"""PyElastica, the peer on the same work (``flagellum bench --peer``).

PyElastica (Gazzola et al., R. Soc. Open Sci. 2018; Zhang et al., Nat. Commun. 2019) is an
explicit, inertial Cosserat-rod code (position Verlet at a fixed Δt). It is not a dependency:
it lives in its own environment (``$FLAGELLUM_PEER_ENV``, default ``/tmp/pyel``; made by
``python benchmarks/bench_pyelastica.py --install``) and this file runs there as a script
(``python peer.py`` reads a regime from stdin, prints JSON), so nothing here imports flagellum
at module level and the peer side uses only numpy and PyElastica.

The flagellum side (:func:`spec`) turns one regime (``Params``, the motor torque, the
``Boundary``) into plain numbers: the initial bead positions of flagellum's own run, the
rigidities, the stretch modulus, the local drag γ∥, γ⊥, γR and the load sphere's or body
sphere's Stokes drag 6πηa. The PyElastica model of it:

* the rod: N elements through those positions, radius r = 2√(A/K) so that E·πr² = K and
  E·I = A, shear modulus G = C/J (J = πr⁴/2), rest curvature and twist of the initial
  configuration (a parallel-transport frame; any smooth frame is stress-free there);
  PyElastica's rod is shearable (shear stiffness ≈ G·πr²), flagellum's bonds are not;
* resistive force theory as an external force per node (γ∥, γ⊥ times the node's share of a
  bond, along the node's averaged tangent; ``hydro.local.bead_friction``), a torque −γR h ω3
  per element, the motor torque M e_z on the first element;
* the motor end: held (``fixed``), moving along z only with the sphere's drag ζ = 6πηa added
  (``sphere``), or free with ζ added isotropically (``free``: a body sphere centred on the
  first node; its counter-rotation −M/(8πηa³) does not act back on a centred body);
* inertia: the density is set so that a node relaxes in m/(γ⊥ h) = 1e-5 s (:data:`RELAXATION`),
  well below a motor period (≥ 5 ms here); the sphere's node carries ζ·1e-5 s more mass;
* the thrust is the z component of the internal (elastic) force on the first node, as
  flagellum's (``Trajectory.thrust``), averaged over every step of the last half of the
  window (it rings at the stretch modes' ~1e-5 s period: samples 1e-4 s apart alias); ω the
  mean rate of the first element's d1 about z over that half (its
  azimuth, unwrapped record to record).

Its fixed step costs the same per simulated second in every state (no error control), so a
short window (:data:`WINDOW`) measures its cost for any regime.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

ENV = "FLAGELLUM_PEER_ENV"
DEFAULT_ENV = "/tmp/pyel"
#: Δt tried, largest first [s]; the first that stays finite over the window is "tuned"
DTS = (1e-6, 5e-7, 2.5e-7, 1.25e-7, 6.25e-8)
WINDOW = 0.02  #: simulated seconds of a peer run [s]
RELAXATION = 1e-5  #: inertial relaxation time of a node, m/(γ⊥ h) [s]
RECORD = 1e-4  #: record interval of the averages [s]


# -- flagellum side ------------------------------------------------------------------------
def python() -> str:
    """The peer environment's interpreter (it may not exist)."""
    return os.path.join(os.environ.get(ENV, DEFAULT_ENV), "bin", "python")


def available() -> tuple[bool, str]:
    """Whether PyElastica can run, and if not, why (a one-line reason)."""
    py = python()
    if not os.path.exists(py):
        return False, (f"no PyElastica environment at {os.path.dirname(os.path.dirname(py))} "
                       f"(${ENV}; python benchmarks/bench_pyelastica.py --install makes it)")
    r = subprocess.run([py, "-c", "import elastica"], capture_output=True, text=True)
    if r.returncode:
        return False, f"{py} cannot import elastica"
    return True, ""


def spec(params, torque: float, boundary) -> dict:
    """The regime as plain numbers for the peer (see the module docstring)."""
    from .motor import Motor
    from .rod.model import positions
    from .simulator import Simulator

    sim = Simulator(params, Motor(torque), boundary)  # its initial state only
    f = params.filament
    gpar, gperp, grot = params.gammas
    return {"positions": positions(sim.y).tolist(), "A": f.bend_rigidity, "C": f.twist_rigidity,
            "K": f.stretch_modulus, "gammas": [gpar, gperp, grot], "torque": torque,
            "anchor": boundary.anchor, "zeta": boundary.sphere_drag(params.fluid.viscosity)}


def run(spec_: dict, dts=DTS, window: float = WINDOW, tune: bool = True) -> dict:
    """Run the peer on ``spec_`` in its environment: with ``tune`` the first Δt of ``dts``
    that stays finite (``{"tuned": run, "tried": [...]}``), else every Δt (``{"runs": [...]}``).
    Wall time is the stepping alone (not PyElastica's import, set-up and compile)."""
    job = {"spec": spec_, "dts": list(dts), "window": window, "tune": tune}
    r = subprocess.run([python(), os.path.abspath(__file__)], input=json.dumps(job),
                       capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError("PyElastica run failed: " + " ".join(r.stderr.strip().splitlines()[-1:]))
    return json.loads(r.stdout.strip().splitlines()[-1])


# -- peer side (runs in the PyElastica environment) ----------------------------------------
def _frames(pos):
    """Directors (3, 3, n) of a parallel-transport frame along the polygon ``pos`` (3, n+1)."""
    import numpy as np

    t = np.diff(pos, axis=1)
    t /= np.linalg.norm(t, axis=0)
    n = t.shape[1]
    d = np.zeros((3, 3, n))
    a = np.cross(t[:, 0], [1.0, 0.0, 0.0])
    if np.linalg.norm(a) < 1e-6:
        a = np.cross(t[:, 0], [0.0, 1.0, 0.0])
    d1 = np.cross(a, t[:, 0])
    d1 /= np.linalg.norm(d1)
    for i in range(n):
        if i:  # rotate d1 by the turn from t[i-1] to t[i]
            b = np.cross(t[:, i - 1], t[:, i])
            s, c = np.linalg.norm(b), float(t[:, i - 1] @ t[:, i])
            if s > 1e-14:
                k = b / s
                d1 = d1 * c + np.cross(k, d1) * s + k * (k @ d1) * (1 - c)
            d1 -= (d1 @ t[:, i]) * t[:, i]
            d1 /= np.linalg.norm(d1)
        d[0, :, i], d[1, :, i], d[2, :, i] = d1, np.cross(t[:, i], d1), t[:, i]
    return d


def simulate(spec_: dict, window: float, dt: float) -> dict:
    """One PyElastica run of ``window`` simulated seconds at step ``dt`` (peer side)."""
    import numpy as np
    import elastica as ea
    from elastica.timestepper.symplectic_steppers import PositionVerlet

    pos = np.asarray(spec_["positions"], dtype=float).T  # (3, n+1)
    n = pos.shape[1] - 1
    lengths = np.linalg.norm(np.diff(pos, axis=1), axis=0)
    h = float(lengths.mean())
    A, C, K = spec_["A"], spec_["C"], spec_["K"]
    gpar, gperp, grot = spec_["gammas"]
    torque, anchor, zeta = spec_["torque"], spec_["anchor"], spec_["zeta"]
    r = 2.0 * np.sqrt(A / K)
    E = K / (np.pi * r * r)
    G = C / (np.pi * r ** 4 / 2)
    rho = RELAXATION * gperp * h / (np.pi * r * r * h)  # node mass m = γ⊥ h · RELAXATION
    length = float(lengths.sum())
    direction = (pos[:, -1] - pos[:, 0]) / np.linalg.norm(pos[:, -1] - pos[:, 0])
    normal = np.cross(direction, [1.0, 0.0, 0.0])
    normal /= np.linalg.norm(normal)

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):
        pass

    sim = Sim()
    rod = ea.CosseratRod.straight_rod(n, pos[:, 0].copy(), direction, normal, length, r, rho,
                                      youngs_modulus=E, shear_modulus=G, position=pos,
                                      directors=_frames(pos))
    rod.rest_kappa[:] = rod.kappa
    rod.rest_sigma[:] = 0.0
    if anchor != "fixed":
        rod.mass[0] += zeta * RELAXATION
    sim.append(rod)
    x0 = pos[:, 0].copy()

    class Anchor(ea.ConstraintBase):
        def constrain_values(self, system, time):
            if anchor == "fixed":
                system.position_collection[:, 0] = x0
            elif anchor == "sphere":
                system.position_collection[:2, 0] = x0[:2]

        def constrain_rates(self, system, time):
            if anchor == "fixed":
                system.velocity_collection[:, 0] = 0.0
            elif anchor == "sphere":
                system.velocity_collection[:2, 0] = 0.0

    w = np.full(n + 1, h)
    w[[0, -1]] = h / 2

    class Drag(ea.NoForces):
        def apply_forces(self, system, time=0.0):
            v = system.velocity_collection
            tn = system.tangents
            tt = np.zeros_like(v)
            tt[:, :-1] += tn
            tt[:, 1:] += tn
            tt /= np.linalg.norm(tt, axis=0)
            vt = (v * tt).sum(0)
            system.external_forces[...] -= w * (gpar * vt * tt + gperp * (v - vt * tt))
            if anchor != "fixed":
                system.external_forces[:, 0] -= zeta * v[:, 0]

        def apply_torques(self, system, time=0.0):
            system.external_torques[2] -= grot * h * system.omega_collection[2]
            # M e_z in the first element's material frame (rows d1, d2, d3)
            system.external_torques[:, 0] += torque * system.director_collection[:, 2, 0]

    sim.constrain(rod).using(Anchor, constrained_position_idx=(0,))
    sim.add_forcing_to(rod).using(Drag)
    sim.finalize()
    stepper = PositionVerlet()
    tt = 0.0
    for _ in range(5):  # compile PyElastica's kernels (untimed), then start again from rest
        stepper.step(sim, 0.0, 1e-12)
    steps = int(round(window / dt))
    every = max(1, int(round(RECORD / dt)))
    angle, times = [], []
    wall, ok, half = 0.0, True, 0.5 * window - 0.5 * dt
    force, counted = 0.0, 0
    for k in range(0, steps, every):
        w0 = time.perf_counter()
        for _ in range(min(every, steps - k)):
            tt = stepper.step(sim, tt, dt)
            if tt > half:  # every step: the force rings at the stretch modes' ~1e-5 s period,
                force += rod.internal_forces[2, 0]  # which records 1e-4 s apart would alias
                counted += 1
        wall += time.perf_counter() - w0
        if not np.isfinite(rod.position_collection[:, -1]).all():
            ok = False
            break
        if tt > half:
            d1 = rod.director_collection[0, :, 0]
            angle.append(float(np.arctan2(d1[1], d1[0])))
            times.append(tt)
    strain = float(np.abs(rod.lengths / rod.rest_lengths - 1).max()) if ok else float("inf")
    ok = ok and bool(np.isfinite(strain)) and strain < 0.5
    return {"dt": dt, "steps": steps, "window": window, "wall_seconds": wall, "finite": ok,
            "max_strain": strain, "wall_per_simulated_second": wall / window,
            "thrust": float(force / counted) if ok else None,
            "omega": float(np.diff(np.unwrap(angle)).sum() / (times[-1] - times[0])) if ok else None}


def _main() -> None:
    job = json.loads(sys.stdin.read())
    runs = []
    for dt in job["dts"]:
        res = simulate(job["spec"], job["window"], dt)
        runs.append(res)
        if job["tune"] and res["finite"]:
            print(json.dumps({"tuned": res, "tried": runs}))
            return
    print(json.dumps({"tuned": None, "tried": runs} if job["tune"] else {"runs": runs}))


if __name__ == "__main__":
    _main()
