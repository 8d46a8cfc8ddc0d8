"""Critical manifold of the helical rod and the critical torque of the filament (paper Sec. 4.2).

The helical filament is replaced by a rod of length L0 = L sin α with the effective bending
rigidity A_eff (App. C) and the friction coefficients per length a⊥, a∥, b∥, c∥ (App. A,
Eq. (39)). A straight rod moving with velocity v towards its base (pushing the
load) and rotating with ω feels (sign convention below) ::

    f∥ = −(a∥ v + c∥ ω)   (compressive thrust density),   m = c∥ v + b∥ ω,   f⊥ = a⊥ v,

so eliminating v and ω gives the plane of Eq. (31) ::

    f⊥ = −a⊥ (b∥ f∥ + c∥ m)/(a∥ b∥ − c∥²),   in hats  f̂⊥ = −a⊥ (b∥ f̂∥ + c∥ L0 m̂)/(a∥ b∥ − c∥²).

Sign convention: c∥ < 0 for a right-handed helix (App. A) and f∥ > 0 compresses the rod, as
in Eq. (29). These are the relations that give the paper's Eq. (16) for the
load sphere; the printed Eq. (31) has f∥ with the opposite sign (the force density on the
rod, negative when it compresses), which would put the anchored helix (v = 0) off f⊥ = 0.

A load sphere of radius a (drag ζ = 6πηa) fixes v = F/ζ with F = f∥ L0 the thrust, so for
each 1/a the critical point lies on a ray through the origin of (m̂, f̂∥, f̂⊥). The radius
correction of Sec. 4.2 replaces R⁻¹ by R⁻¹ + M/(2A cos α) at fixed pitch angle, which scales
b∥ ∝ R² and c∥ ∝ R and makes the plane torque dependent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .._plot import pyplot
from .._util import jsonable
from ..helix import Helix
from ..hydro.rft import effective_bending_rigidity, full_turn_coefficients
from ..parallel import default_workers, pmap
from ..errors import ParameterError
from ..params import Params, check_real
from .buckling import (BucklingProblem, CriticalPoint, NoConvergenceError,
                       TrivialSolutionError, follow, is_tilt_mode, line_path, scan_path,
                       spectrum)

#: Levels f̂⊥ of the buckling curves of Fig. 7(b).
LEVELS = tuple(range(0, 301, 25))


def nonlocal_coefficients(params: Params | None = None) -> dict:
    """Friction coefficients per axial length L0 of the rigid continuum helix with the
    nonlocal mobility (:func:`flagellum.hydro.sbt.resistance_matrix` on the helix' Gauss
    nodes, torques about its axis), in the convention of Eq. (38): ``A_par`` = A∥/L0,
    ``B_par`` = B∥/L0, ``C_par`` = C∥/L0 and ``A_perp`` = A⊥/L0, the mean of the two
    transverse translational drags. They replace the local coefficients of the effective rod
    when the rod is given the nonlocal drag of the whole helix (a rigid-body average: the
    flow of a bending mode is not resolved, docs/theory.md)."""
    from ..hydro import sbt
    from ..hydro.rft import helix_nodes

    params = params or Params()
    helix = Helix.from_filament(params.filament)
    x, t, w = helix_nodes(helix)
    fl = params.fluid
    R = sbt.resistance_matrix(x, fl.filament_radius, fl.viscosity, params.gammas[2],
                              tangents=t, weights=w)
    L0 = helix.axial_length
    return {"A_perp": float((R[0, 0] + R[1, 1]) / (2 * L0)), "A_par": float(R[2, 2] / L0),
            "B_par": float(R[5, 5] / L0), "C_par": float(R[2, 5] / L0)}


@dataclass(frozen=True)
class HelicalRod:
    """The helical filament as an effective rod (paper Sec. 4.1, App. A and C). Units µm, pN, s."""

    L0: float            #: axial length L sin α
    A_eff: float         #: effective bending rigidity (App. C)
    bend_rigidity: float  #: A of the filament (enters the radius correction)
    pitch_angle: float
    radius: float
    chirality: int
    a_perp: float        #: friction coefficients per axial length (Eq. (39))
    a_par: float
    b_par: float
    c_par: float
    viscosity: float

    @classmethod
    def from_params(cls, params: Params | None = None, hydrodynamics=None) -> "HelicalRod":
        """The rod of the filament of ``params``. Its friction per length: the full-turn RFT
        coefficients of Eq. (38) (the paper's, default), or with a nonlocal ``hydrodynamics``
        those of the rigid helix' nonlocal resistance (:func:`nonlocal_coefficients`)."""
        params = params or Params()
        fil = params.filament
        helix = Helix.from_filament(fil)
        gp, gn, _ = params.gammas
        L0 = helix.axial_length
        if not L0 > 0:  # a ring (τ0 = 0) has no helix axis to buckle about
            raise ParameterError("tau0", fil.tau0, "> 0 for the helical rod theory (a helix "
                                 "with an axis)")
        if hydrodynamics is None or hydrodynamics.is_local:
            co = {k: v / L0 for k, v in full_turn_coefficients(helix, gp, gn).items()}
        else:
            co = nonlocal_coefficients(params)
        return cls(L0, effective_bending_rigidity(helix, fil.bend_rigidity, fil.twist_rigidity),
                   fil.bend_rigidity, helix.pitch_angle, helix.radius, helix.chirality,
                   co["A_perp"], co["A_par"], co["B_par"], co["C_par"], params.fluid.viscosity)

    # scales of the hats (Sec. 4.1)
    @property
    def torque_scale(self) -> float:
        """M = m̂ · A_eff/L0 [pN·µm]."""
        return self.A_eff / self.L0

    @property
    def force_scale(self) -> float:
        """F = f̂∥ · A_eff/L0² [pN]."""
        return self.A_eff / self.L0**2

    @property
    def rate_scale(self) -> float:
        """χ = χ̂ · A_eff/(a⊥ L0⁴) [1/s]."""
        return self.A_eff / (self.a_perp * self.L0**4)

    @property
    def master_rate_scale(self) -> float:
        """Rate scale of Fig. 8 (App. C): A_eff/(L0³A⊥/3) = 3 A_eff/(a⊥L0⁴) [1/s], with
        A⊥ = a⊥L0 the whole-filament coefficient of Eq. (38a)."""
        return 3 * self.rate_scale

    def reorientation_rate(self, m_hat: float, radius_correction: bool = False) -> float:
        """Growth rate λ [1/s] of the least stable mode of the straight anchored rod.

        On the anchored line (1/a = 0: f̂⊥ = 0, f̂∥ = −c∥L0 m̂/b∥) it is −min Re μ of
        :func:`~flagellum.theory.buckling.spectrum` times A_eff/(a⊥L0⁴); for m̂ < 0 (pulling)
        the precessing tilt mode, the effective-rod prediction of Fig. 8.
        """
        f_par, f_perp = self.sphere_loads(m_hat, 0.0, radius_correction)
        mu = spectrum(BucklingProblem(m_hat=m_hat, f_par=f_par, f_perp=f_perp))
        return float(-mu[0].real * self.rate_scale)

    def with_thrust_per_torque(self, ratio: float) -> "HelicalRod":
        """The rod with c∥ = −ratio · b∥, so that the anchored helix has F/M = ``ratio`` [1/µm].

        On the anchored line only F/M = −c∥/b∥ enters (f̂∥ = −c∥L0 m̂/b∥); App. A gives
        1.021 /µm for the paper's helix rotating about its own axis, the discrete filament
        pinned at its first bead 0.95 /µm at M_c1 (docs/theory.md).
        """
        return replace(self, c_par=-check_real("ratio", ratio) * self.b_par)

    def coefficients(self, torque: float = 0.0, radius_correction: bool = False):
        """(a∥, b∥, c∥) at motor torque ``torque``; with the radius correction
        R⁻¹ → R⁻¹ + M/(2A cos α) (pitch angle fixed): b∥ ∝ R², c∥ ∝ R."""
        if not radius_correction:
            return self.a_par, self.b_par, self.c_par
        rho = 1.0 / (1.0 + self.chirality * self.radius * torque
                     / (2 * self.bend_rigidity * math.cos(self.pitch_angle)))
        return self.a_par, self.b_par * rho**2, self.c_par * rho

    def plane(self, m_hat: float, f_par: float, radius_correction: bool = False) -> float:
        """f̂⊥ on the plane of Eq. (31) (compressive f̂∥, see module docstring)."""
        a, b, c = self.coefficients(m_hat * self.torque_scale, radius_correction)
        return -self.a_perp * (b * f_par + c * self.L0 * m_hat) / (a * b - c * c)

    def sphere_loads(self, m_hat: float, inv_a: float, radius_correction: bool = False):
        """(f̂∥, f̂⊥) of the straight rod pushing a sphere of radius a at torque m̂.

        With κ = 1/(6πηa) and whole-rod coefficients A = a∥L0, B = b∥L0, C = c∥L0:
        ω = M/(B − C²κ/(Aκ + 1)), v = −Cωκ/(Aκ + 1), F = −Cω/(Aκ + 1); 1/a = 0 is anchored.
        """
        M = m_hat * self.torque_scale
        a, b, c = (x * self.L0 for x in self.coefficients(M, radius_correction))
        kappa = inv_a / (6 * math.pi * self.viscosity)
        omega = M / (b - c * c * kappa / (a * kappa + 1))
        thrust, v = -c * omega / (a * kappa + 1), -c * omega * kappa / (a * kappa + 1)
        return thrust / self.force_scale, self.a_perp * v * self.L0**3 / self.A_eff

    def dimensional(self, cp: CriticalPoint) -> dict:
        """Critical torque M [pN·µm], thrust F [pN], velocity v [µm/s], precession χ [1/s]."""
        return {"M": cp.m_hat * self.torque_scale, "F": cp.f_par * self.force_scale,
                "v": cp.f_perp * self.A_eff / (self.a_perp * self.L0**3),
                "chi_rate": cp.chi * self.rate_scale}

    def as_dict(self) -> dict:
        return {"L0": self.L0, "A_eff": self.A_eff, "A_eff_over_L0": self.torque_scale,
                "pitch_angle_deg": math.degrees(self.pitch_angle), "radius": self.radius,
                "a_perp": self.a_perp, "a_par": self.a_par, "b_par": self.b_par,
                "c_par": self.c_par, "force_scale": self.force_scale,
                "rate_scale": self.rate_scale, "master_rate_scale": self.master_rate_scale}


def _derivative(fun, t, h=1e-6):
    return (np.asarray(fun(t + h)) - np.asarray(fun(t - h))) / (2 * h)


# --------------------------------------------------------------------------------------------
# The manifold f̂⊥(m̂, f̂∥) and its level curves
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class CriticalSurface:
    """Critical f̂⊥ and χ̂ on a grid (m̂ᵢ, f̂∥ⱼ): the stability boundary of the straight rod.

    For f̂⊥ above ``f_perp[i, j]`` the straight rod is stable; at it one mode (precession
    ``chi[i, j]``) turns unstable. NaN where nothing was found in the scanned range.
    """

    m_hat: np.ndarray
    f_par: np.ndarray
    f_perp: np.ndarray
    chi: np.ndarray
    base: str


def _surface_row(args):
    m, f_pars, base, scan = args
    prob = BucklingProblem(m_hat=m, base=base)

    def make_path(f):
        return line_path(replace(prob, f_par=float(f)), "f_perp")

    pts = follow(prob, make_path, f_pars, *scan, stable_start=True)
    return ([np.nan if p is None else p.f_perp for p in pts],
            [np.nan if p is None else p.chi for p in pts])


def critical_surface(m_values, f_par_values, *, base: str = "hinged",
                     scan=(2000.0, -2000.0), workers: int | None = 1) -> CriticalSurface:
    """Stability boundary f̂⊥(m̂, f̂∥) and χ̂ (paper Fig. 7a), row by row in m̂.

    Each row follows the critical point in f̂∥ (:func:`~flagellum.theory.buckling.follow`),
    scanning f̂⊥ downwards from ``scan[0]``; ``workers`` processes share the rows.
    """
    m_values, f_values = np.asarray(m_values, float), np.asarray(f_par_values, float)
    rows = pmap(_surface_row, [(float(m), f_values, base, scan) for m in m_values], workers or 1)
    return CriticalSurface(m_values, f_values, np.array([r[0] for r in rows]),
                           np.array([r[1] for r in rows]), base)


def _level_row(args):
    level, m_values, base, scan = args
    prob = BucklingProblem(f_perp=level, base=base)

    def make_path(m):
        return line_path(replace(prob, m_hat=float(m)), "f_par")

    pts = [None] * len(m_values)
    positive = [k for k, m in enumerate(m_values) if m > 0]
    for k, cp in zip(positive, follow(prob, make_path, m_values[positive], *scan,
                                      end_on_start_change=True, skip=is_tilt_mode)):
        pts[k] = cp
    for k in (k for k, m in enumerate(m_values) if m == 0):   # the rigid tilt is excluded at m̂ = 0
        try:
            pts[k] = scan_path(prob, make_path(0.0), *scan, skip=is_tilt_mode)
        except (NoConvergenceError, TrivialSolutionError):
            pass
    return [(np.nan, np.nan) if p is None else (p.f_par, p.chi) for p in pts]


def level_curves(levels=LEVELS, m_values=np.linspace(0, 20, 41), *, base: str = "hinged",
                 scan=(0.0, 2000.0), workers: int | None = 1) -> dict:
    """Buckling curves f̂∥(m̂) at fixed f̂⊥ (paper Fig. 7b).

    For each m̂ the thrust f̂∥ grows from 0 until one more mode of the straight rod turns
    unstable; precessing tilt modes (:func:`~flagellum.theory.buckling.is_tilt_mode`),
    which may already be unstable at f̂∥ = 0 for small f̂⊥, are passed over. The curve ends
    where the buckling mode is already unstable at f̂∥ = 0. Returns {level: (m̂, f̂∥, χ̂)}, NaN where there is no point.
    """
    m_values = np.asarray(m_values, float)
    rows = pmap(_level_row, [(float(c), m_values, base, scan) for c in levels], workers or 1)
    return {c: (m_values, np.array([r[0] for r in row]), np.array([r[1] for r in row]))
            for c, row in zip(levels, rows)}


# --------------------------------------------------------------------------------------------
# The filament: plane of Eq. (31), load sphere, radius correction
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class CriticalCurve:
    """Critical points along a family of paths, with their dimensional values."""

    parameter: np.ndarray   #: the family parameter (m̂ for the plane, 1/a for the sphere)
    points: tuple           #: CriticalPoint or None per parameter value
    rod: HelicalRod
    radius_correction: bool

    def table(self) -> dict:
        """Columns: parameter, m_hat, f_par, f_perp, chi, M, F, v, chi_rate (NaN if none)."""
        keys = ("m_hat", "f_par", "f_perp", "chi", "M", "F", "v", "chi_rate")
        cols = {k: [] for k in keys}
        for p in self.points:
            vals = {**{n: getattr(p, n) for n in keys[:4]}, **self.rod.dimensional(p)} \
                if p is not None else {}
            for k in keys:
                cols[k].append(vals.get(k, np.nan))
        return {"parameter": self.parameter, **{k: np.array(v) for k, v in cols.items()}}


def plane_intersection(rod: HelicalRod, m_values, *, radius_correction: bool = False,
                       base: str = "hinged") -> CriticalCurve:
    """Critical f̂∥(m̂) where the plane of Eq. (31) meets the manifold (Fig. 7c, d).

    For each m̂ the thrust runs along the plane from the free swimmer (f̂∥ = 0, no load) to
    the anchored helix (f̂⊥ = 0, v = 0), i.e. over all load spheres, and the first
    buckling onset is kept (tilt modes passed over); ``None`` where the straight rod stays
    stable over this range or is unstable already without load (the curve's end).
    """
    prob = BucklingProblem(base=base)

    def make_path(m):
        a, b, c = rod.coefficients(m * rod.torque_scale, radius_correction)
        f_anchored = -c * rod.L0 * m / b          # v = 0
        plane = lambda f: rod.plane(m, f, radius_correction)

        def path(t):   # t ∈ [0, 1]: from no load to anchored
            f = t * f_anchored
            return (np.array([m, f, plane(f), 0.0]),
                    f_anchored * np.array([0.0, 1.0, _derivative(plane, f), 0.0]))
        return path

    m_values = np.asarray(m_values, float)
    pts = follow(prob, make_path, m_values, 0.0, 1.0, skip=is_tilt_mode, end_on_start_change=True)
    pts = [p if p is not None and p.f_perp >= 0 else None for p in pts]
    return CriticalCurve(m_values, tuple(pts), rod, radius_correction)


def load_sphere_curve(rod: HelicalRod, inv_a_values, *, radius_correction: bool = False,
                      base: str = "hinged", m_stop: float = 80.0) -> CriticalCurve:
    """Critical torque M_c1 versus inverse sphere radius 1/a (paper Fig. 5(a); 1/a = 0 anchored).

    Along each ray the torque m̂ grows from 0 with (f̂∥, f̂⊥) of :meth:`HelicalRod.sphere_loads`
    until the straight rod buckles (tilt modes passed over).
    """
    prob = BucklingProblem(base=base)

    def make_path(inv_a):
        loads = lambda m: rod.sphere_loads(m, inv_a, radius_correction)

        def path(t):
            f, fp = loads(t)
            df, dfp = _derivative(loads, t)
            return np.array([t, f, fp, 0.0]), np.array([1.0, df, dfp, 0.0])
        return path

    inv_a_values = np.asarray([check_real("inv_a", x) for x in inv_a_values], float)
    pts = follow(prob, make_path, inv_a_values, 0.0, m_stop, skip=is_tilt_mode)
    return CriticalCurve(inv_a_values, tuple(pts), rod, radius_correction)


# --------------------------------------------------------------------------------------------
# Everything of Fig. 7 in one go (CLI ``flagellum theory manifold``)
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ManifoldResult:
    rod: HelicalRod
    surface: CriticalSurface
    levels: dict
    plane: dict            #: radius_correction (bool) -> CriticalCurve
    sphere: dict           #: radius_correction (bool) -> CriticalCurve
    timings: dict

    def summary(self) -> dict:
        """The theory's critical points of the paper's filament (see docs/theory.md)."""
        out = {"rod": self.rod.as_dict(), "timings_s": self.timings}
        for rc, curve in self.sphere.items():
            tab = curve.table()
            key = "with_radius_correction" if rc else "without_radius_correction"
            anchored = int(np.argmin(np.abs(tab["parameter"])))
            out[key] = {"anchored": {k: float(tab[k][anchored]) for k in
                                     ("m_hat", "f_par", "f_perp", "chi", "M", "F")},
                        "load_sphere": {"inv_a": tab["parameter"].tolist(),
                                        "M_c1": tab["M"].tolist(), "F_c1": tab["F"].tolist()}}
        return out


def compute_manifold(params: Params | None = None, *, m_values=None, f_par_values=None,
                     levels=LEVELS, inv_a_values=None, base: str = "hinged",
                     workers: int | None = None, hydrodynamics=None) -> ManifoldResult:
    """Grid, level curves, plane intersections and load-sphere curves (Fig. 7, Fig. 5(a));
    ``hydrodynamics``: the rod's friction (:meth:`HelicalRod.from_params`)."""
    import time

    rod = HelicalRod.from_params(params, hydrodynamics)
    workers = workers or default_workers(2)
    m_values = np.linspace(0, 20, 41) if m_values is None else np.asarray(m_values, float)
    f_par_values = np.linspace(0, 120, 41) if f_par_values is None else np.asarray(f_par_values, float)
    inv_a_values = np.linspace(0, 5, 21) if inv_a_values is None else np.asarray(inv_a_values, float)
    t0 = time.perf_counter()
    surface = critical_surface(m_values, f_par_values, base=base, workers=workers)
    t1 = time.perf_counter()
    lv = level_curves(levels, m_values, base=base, workers=workers)
    t2 = time.perf_counter()
    jobs = [(kind, rc) for kind in ("plane", "sphere") for rc in (False, True)]
    curves = dict(zip(jobs, pmap(_curve_job, [(k, rc, rod, m_values, inv_a_values, base)
                                             for k, rc in jobs], workers)))
    t3 = time.perf_counter()
    plane = {rc: curves["plane", rc] for rc in (False, True)}
    sphere = {rc: curves["sphere", rc] for rc in (False, True)}
    return ManifoldResult(rod, surface, lv, plane, sphere,
                          {"surface": t1 - t0, "level_curves": t2 - t1,
                           "plane_and_load_sphere": t3 - t2, "total": t3 - t0,
                           "workers": workers})


def _curve_job(args):
    kind, rc, rod, m_values, inv_a_values, base = args
    if kind == "plane":
        return plane_intersection(rod, m_values, radius_correction=rc, base=base)
    return load_sphere_curve(rod, inv_a_values, radius_correction=rc, base=base)


def write_manifold(result: ManifoldResult, out_dir) -> list:
    """CSV tables, ``summary.json`` and ``manifold.png`` in ``out_dir``; returns the paths."""
    import json
    from pathlib import Path

    from ..io import atomic_write_text, write_csv

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    s = result.surface
    mm, ff = np.meshgrid(s.m_hat, s.f_par, indexing="ij")
    tables = {"surface.csv": {"m_hat": mm.ravel(), "f_par": ff.ravel(), "f_perp": s.f_perp.ravel(),
                              "chi": s.chi.ravel()}}
    rows = [[], [], [], []]
    for level, (m, f, chi) in result.levels.items():
        for col, vals in zip(rows, (np.full(len(m), level), m, f, chi)):
            col.extend(vals)
    tables["level_curves.csv"] = dict(zip(("f_perp", "m_hat", "f_par", "chi"), rows))
    for name, curves, pname in (("plane_intersection.csv", result.plane, "m_hat_path"),
                                ("load_sphere.csv", result.sphere, "inv_a")):
        cols, header = None, None
        for rc, curve in curves.items():
            tab = curve.table()
            header = (pname, "radius_correction", *list(tab)[1:])
            block = [tab["parameter"], np.full(len(tab["parameter"]), int(rc)),
                     *[tab[k] for k in list(tab)[1:]]]
            cols = block if cols is None else [np.concatenate([a, b]) for a, b in zip(cols, block)]
        tables[name] = dict(zip(header, cols))
    paths = [write_csv(out / name, table) for name, table in tables.items()]
    atomic_write_text(out / "summary.json", json.dumps(jsonable(result.summary()), indent=2))
    paths.append(out / "summary.json")
    paths.append(plot_manifold(result, out / "manifold.png"))
    return paths


def plot_manifold(result: ManifoldResult, path):
    """Four panels in the spirit of Fig. 7: (a) manifold, (b) buckling curves,
    (c) plane intersections F_c(M_c), (d) M_c1 versus 1/a."""
    plt = pyplot()
    s, rod = result.surface, result.rod
    fig, ax = plt.subplots(2, 2, figsize=(11, 8.5))
    a = ax[0, 0]
    data = np.clip(s.f_perp.T, -200, 1000)
    pc = a.pcolormesh(s.m_hat, s.f_par, data, shading="auto", cmap="viridis")
    a.contour(s.m_hat, s.f_par, s.f_perp.T, levels=[0.0], colors="w", linewidths=1)
    fig.colorbar(pc, ax=a, label=r"critical $\hat f_\perp$ (clipped)")
    a.set(xlabel=r"$\hat m$", ylabel=r"$\hat f_\parallel$",
          title=r"(a) critical $\hat f_\perp$ (white: $\hat f_\perp = 0$)")
    a = ax[0, 1]
    for level, (m, f, _) in result.levels.items():
        a.plot(m, f, label=f"{level:g}" if level % 100 == 0 else None)
    a.set(xlabel=r"$\hat m$", ylabel=r"$\hat f_\parallel$",
          title=r"(b) buckling curves, $\hat f_\perp = 0, 25, \dots$")
    a.legend(title=r"$\hat f_\perp$", fontsize=8)
    a = ax[1, 0]
    for rc, curve in result.plane.items():
        tab = curve.table()
        a.plot(tab["M"], tab["F"], "--" if rc else "-",
               label="torque-dependent radius" if rc else "constant friction")
    for rc, curve in result.sphere.items():
        tab = curve.table()
        a.plot(tab["M"], tab["F"], "o" if not rc else "s", ms=3, mfc="none")
    a.set(xlabel="critical torque M [pN µm]", ylabel="critical thrust F [pN]",
          title="(c) plane ∩ manifold (symbols: load spheres)")
    a.legend(fontsize=8)
    a = ax[1, 1]
    for rc, curve in result.sphere.items():
        tab = curve.table()
        a.plot(tab["parameter"], tab["M"], "--" if rc else "-o", ms=3,
               label="torque-dependent radius" if rc else "constant friction")
    a.set(xlabel="1/a [1/µm]", ylabel=r"$M_{c1}$ [pN µm]", title="(d) critical torque vs 1/a")
    a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
