"""Results that several figures use, computed once per ``reproduce`` call.

* :class:`TorqueSweep` — the deterministic simulations of Fig. 3, also panels (b–d) of Fig. 4;
* :class:`AnchoredThreshold` — M_c1, F_c1 of the anchored filament from linear stability
  (Fig. 3, Fig. 4);
* :class:`LoadSphereThresholds` — M_c1, F_c1 with load spheres from linear stability
  (Fig. 5, the red dots of Fig. 7);
* :func:`rod_theory_curve` — the rod theory of Sec. 4 on load-sphere rays (Fig. 5, Fig. 7).

A :class:`Cache` holds them for the figures of one call (``reproduce all`` computes the
sweep and the load-sphere points once); each figure also runs alone with an empty cache.
The cache also carries the filament's mobility (``hydrodynamics``) into every run and
stability analysis computed through it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from .common import Timer, pmap, simulate_point

if TYPE_CHECKING:
    from ..hydro.options import Hydrodynamics

# -- the deterministic sweep of Fig. 3 and Fig. 4 ----------------------------------------------

#: (torque, simulated time [s]) of the sweep; protocol and frame follow from the torque
SWEEPS = {
    "quick": ((-1.0, 0.15), (-0.5, 0.15), (0.5, 0.15), (1.0, 0.6), (1.3, 0.6), (1.6, 0.4),
              (2.5, 0.3), (3.5, 0.3), (4.5, 0.3)),
    "full": ((-1.0, 0.3), (-0.75, 0.3), (-0.5, 0.3), (-0.25, 0.3), (0.25, 0.3), (0.5, 0.3),
             (0.75, 0.3), (1.0, 0.5), (1.1, 4.0), (1.2, 2.0), (1.3, 1.2), (1.4, 0.9), (1.6, 0.6),
             (1.8, 0.5), (2.0, 0.45), (2.5, 0.45), (3.0, 0.45), (3.5, 0.45), (3.7, 0.45),
             (3.9, 0.45), (4.0, 0.45), (4.1, 0.45), (4.2, 0.45), (4.3, 0.45), (4.4, 0.45),
             (4.5, 0.45), (4.6, 0.45), (5.0, 0.45)),
}
#: torques from this value on follow the paper's protocol (start aligned at M = 1, then
#: step); below it the runs start from the stress-free helix, whose start-up transient
#: seeds the buckling instability faster than the tiny perturbation left after a step
STEP_FROM = 2.0
#: torques whose time series are kept: those shown in panels (b) and (c) of Fig. 3, as in
#: the paper's caption (quick: (iii) at 1.6, because at 1.2 the buckled state needs ≈ 1.5 s
#: to develop)
PANEL_TORQUES = {"quick": {"(i)": -1.0, "(ii)": 1.0, "(iii)": 1.6, "(iv)": 4.5},
                 "full": {"(i)": -1.0, "(ii)": 1.0, "(iii)": 1.2, "(iv)": 4.5}}
#: colour of each regime in Fig. 3 and Fig. 4
REGIME_COLORS = {"reorienting": "tab:green", "aligned": "tab:blue", "buckled": "tab:orange",
                 "oscillating": "tab:red"}


def sweep_specs(quality: str, log: bool = False, hydrodynamics: Hydrodynamics | None = None) -> list[dict]:
    """The :func:`~.common.simulate_point` specs of the sweep (longest runs cost most)."""
    shown = set(PANEL_TORQUES[quality].values())
    specs = []
    for M, t_end in SWEEPS[quality]:
        step = M >= STEP_FROM
        specs.append({"torque": M, "t_end": t_end + (0.06 if step else 0.0),
                      "protocol": "step" if step else "rest",
                      "frame": "lab" if M >= 2.0 else "auto", "series": M in shown,
                      "cost": t_end * (60.0 if M > 1.05 else 3.0), "log": log,
                      "hydrodynamics": hydrodynamics})
    return specs


@dataclass(frozen=True)
class TorqueSweep:
    """The deterministic sweep: one :func:`~.common.simulate_point` result per torque."""

    quality: str
    points: tuple[dict, ...]

    @classmethod
    def compute(cls, quality: str, log: bool = False,
                hydrodynamics: Hydrodynamics | None = None) -> "TorqueSweep":
        return cls(quality, tuple(pmap(simulate_point, sweep_specs(quality, log, hydrodynamics))))


@dataclass(frozen=True)
class AnchoredThreshold:
    """M_c1, F_c1 of the anchored filament: :func:`~flagellum.analysis.stability.critical_torque`
    as a dictionary (``critical_torque``, ``critical_force``, …) and its wall time."""

    values: dict

    @classmethod
    def compute(cls, hydrodynamics: Hydrodynamics | None = None) -> "AnchoredThreshold":
        from ..analysis.stability import critical_torque
        from ..params import Params

        t = Timer()
        ct = critical_torque(Params(), hydrodynamics=hydrodynamics)
        return cls({**ct.to_dict(), "wall_seconds": t.seconds})


# -- load spheres: Fig. 5 and Fig. 7 ----------------------------------------------------------

def rod_theory_curve(inv_a, radius_correction: bool = False, hydrodynamics=None) -> dict:
    """The rod theory's critical points on the load-sphere rays 1/a (the table of
    :meth:`~flagellum.theory.manifold.CriticalCurve.table`; ``parameter`` is 1/a), the rod's
    friction that of ``hydrodynamics`` (:meth:`~flagellum.theory.manifold.HelicalRod.from_params`:
    local RFT's full-turn coefficients, or the rigid helix' nonlocal resistance)."""
    from ..theory.manifold import HelicalRod, load_sphere_curve

    rod = HelicalRod.from_params(hydrodynamics=hydrodynamics)
    return load_sphere_curve(rod, list(inv_a), radius_correction=radius_correction).table()


def load_sphere_threshold(job: dict) -> dict:
    """M_c1 at one 1/a (``job``: ``inv_a``, ``guess``, optional ``hydrodynamics``), the
    bracket widened around the theory's guess until λ changes sign; ``error`` when no root
    was found."""
    from ..analysis.stability import critical_torque
    from ..errors import ParameterError
    from ..motor import Boundary
    from ..params import Params

    inv_a, guess = job["inv_a"], job["guess"]
    boundary = Boundary() if inv_a == 0 else Boundary(anchor="sphere", sphere_radius=1.0 / inv_a)
    timer = Timer()
    lo, hi = max(0.4, 0.8 * guess), 1.25 * guess
    last = None
    for _ in range(4):
        try:
            ct = critical_torque(Params(), boundary, bracket=(lo, hi), xtol=1e-3,
                                 hydrodynamics=job.get("hydrodynamics"))
            return {"inv_a": inv_a, "a": math.inf if inv_a == 0 else 1 / inv_a,
                    "M_c1": ct.critical_torque, "F_c1": ct.critical_force, "omega": ct.omega,
                    "velocity": ct.velocity, "chi_onset": ct.lab_frequency,
                    "wall_seconds": timer.seconds}
        except ParameterError as exc:
            last = str(exc)
            lo, hi = max(0.3, 0.7 * lo), 1.4 * hi
        except Exception as exc:  # noqa: BLE001 - continuation failure: report and go on
            last = str(exc)
            break
    return {"inv_a": inv_a, "error": last, "wall_seconds": timer.seconds}


@dataclass(frozen=True)
class LoadSphereThresholds:
    """:func:`load_sphere_threshold` at each 1/a of ``inv_a`` (in that order)."""

    inv_a: tuple[float, ...]
    points: tuple[dict, ...]

    @classmethod
    def compute(cls, inv_a, fallback_guess: bool = True,
                hydrodynamics: Hydrodynamics | None = None) -> "LoadSphereThresholds":
        """Seeded by :func:`rod_theory_curve`; where the theory has no point the guess is
        1 + 1/a with ``fallback_guess`` (else NaN: that 1/a reports an error)."""
        inv = tuple(float(v) for v in inv_a)
        guess = rod_theory_curve(inv, hydrodynamics=hydrodynamics)["M"]
        jobs = []
        for v, g in zip(inv, guess):
            ok = math.isfinite(g) or not fallback_guess
            jobs.append({"inv_a": v, "guess": float(g) if ok else 1.0 + v,
                         "cost": float(g) if ok else 5.0, "hydrodynamics": hydrodynamics})
        return cls(inv, tuple(pmap(load_sphere_threshold, jobs)))

    @property
    def found(self) -> list[dict]:
        """The points with a critical torque."""
        return [p for p in self.points if "error" not in p]


# -- the cache --------------------------------------------------------------------------------

@dataclass
class Cache:
    """The shared results of one ``reproduce`` call, by quality; ``log`` prints each run."""

    log: bool = False
    hydrodynamics: Hydrodynamics | None = None  #: the filament's mobility (default local RFT)
    sweeps: dict[str, TorqueSweep] = field(default_factory=dict)
    anchored: AnchoredThreshold | None = None
    load_spheres: dict[str, LoadSphereThresholds] = field(default_factory=dict)

    def sweep(self, quality: str) -> TorqueSweep:
        if quality not in self.sweeps:
            self.sweeps[quality] = TorqueSweep.compute(quality, self.log, self.hydrodynamics)
        return self.sweeps[quality]

    def anchored_threshold(self) -> AnchoredThreshold:
        if self.anchored is None:
            self.anchored = AnchoredThreshold.compute(self.hydrodynamics)
        return self.anchored

    def load_sphere_thresholds(self, quality: str, inv_a) -> LoadSphereThresholds:
        if quality not in self.load_spheres:
            self.load_spheres[quality] = LoadSphereThresholds.compute(inv_a,
                                                                      hydrodynamics=self.hydrodynamics)
        return self.load_spheres[quality]


__all__ = ["AnchoredThreshold", "Cache", "LoadSphereThresholds", "PANEL_TORQUES", "REGIME_COLORS",
           "STEP_FROM", "SWEEPS", "TorqueSweep", "load_sphere_threshold", "rod_theory_curve",
           "sweep_specs"]
