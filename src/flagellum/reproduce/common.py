"""Shared machinery of ``flagellum reproduce``: qualities, output files, the comparison
table, the process pool of the figures, and the simulation of one torque (Fig. 3 and Fig. 4).

The targets are named fig3 … fig8 after the figures they reproduce; the paper's source
numbers its figures with the sketches (docs/model.md, "How equations are cited"):

=====  ====================================================  =======  ==========
fig    content                                               source   section
=====  ====================================================  =======  ==========
fig3   thrust F(M), F(t) in the four regimes, tangent tip    Fig. 5   Sec. 3.1.1
fig4   λ, ω and χ, ⟨r⟩/L0, σ/σ0 (with thermal points)        Fig. 6   Sec. 3.1.2
fig5   M_c1(1/a) and F_c1(M_c1) with a load sphere           Fig. 7   Sec. 3.2
fig6   the helical rod of the theory (L0, A_eff, loads)      Fig. 8   Sec. 4.1
fig7   critical manifold, buckling curves, plane ∩ manifold  Fig. 9   Sec. 4.2
fig8   master curve of the reorientation rate                Fig. 11  App. C
=====  ====================================================  =======  ==========
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import parallel
from .._plot import pyplot
from ..analysis.regimes import SIGMA_IV
from ..errors import ParameterError

QUALITIES = ("quick", "full")
FIGURES = ("fig3", "fig4", "fig5", "fig6", "fig7", "fig8")
#: units of the CSV columns of the figures (headers ``name [unit]``; columns not listed are
#: dimensionless or text; the rod theory's hats m̂, f̂∥, f̂⊥, χ̂ have their own names)
UNITS = {
    "torque": "pN·µm", "t": "s", "t_end": "s", "t_from": "s", "wall_seconds": "s",
    "thrust": "pN", "thrust_mean": "pN", "thrust_min": "pN", "thrust_max": "pN",
    "thrust_std": "pN", "omega": "rad/s", "chi": "rad/s", "lambda": "1/s", "frequency": "rad/s",
    "lab_frequency": "rad/s", "r_mean": "µm", "r_std": "µm", "end_to_end": "µm",
    "hook_tilt_max_deg": "deg", "inv_a": "1/µm", "a": "µm", "M_c1": "pN·µm", "F_c1": "pN",
    "velocity": "µm/s", "chi_onset": "rad/s", "kappa0": "1/µm", "tau0": "1/µm", "A": "pN·µm²",
    "C": "pN·µm²", "L": "µm", "L0": "µm", "A_eff": "pN·µm²", "A_perp": "pN·s/µm",
    "torque_scale": "pN·µm", "rate_scale": "1/s",
}


def check_quality(quality: str) -> str:
    if quality not in QUALITIES:
        raise ParameterError("quality", quality, "one of " + ", ".join(QUALITIES))
    return quality


def job_cost(job) -> float:
    """Estimated cost of a job: its ``cost`` key (0 without one)."""
    return float(job.get("cost", 0.0)) if isinstance(job, dict) else 0.0


def pmap(fun, items: list, workers: int | None = None) -> list:
    """``[fun(x) for x in items]`` on the process pool of :func:`flagellum.parallel.pmap`:
    at most 2 workers by default (the reference machine has 2 cores; ``FLAGELLUM_WORKERS``
    overrides it), the jobs with the largest ``cost`` key first, so that they finish together."""
    return parallel.pmap(fun, items, parallel.default_workers(2) if workers is None else workers,
                         cost=job_cost)


# -- output files -----------------------------------------------------------------------------
def save_figure(fig, out_dir: Path, name: str, title: str | None = None,
                tight: bool = True) -> list[Path]:
    """Write ``name.png`` (150 dpi) and ``name.pdf`` (after an optional suptitle and, with
    ``tight``, a tight layout); close the figure."""
    plt = pyplot()
    if title is not None:
        fig.suptitle(title, fontsize=10)
    if tight:
        fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / f"{name}.png", out_dir / f"{name}.pdf"]
    fig.savefig(paths[0], dpi=150, bbox_inches="tight")
    fig.savefig(paths[1], bbox_inches="tight")
    plt.close(fig)
    return paths


def write_h5(path: Path, groups: dict, attrs: dict | None = None) -> Path:
    """``{group: {name: array}}`` as an HDF5 file (the same data as the CSV files)."""
    from ..io import atomic_path, new_hdf5

    with atomic_path(path) as tmp:
        with new_hdf5(tmp) as f:
            for k, v in (attrs or {}).items():
                f.attrs[k] = v
            for g, data in groups.items():
                grp = f.require_group(g)
                for name, arr in data.items():
                    a = np.asarray(arr)
                    if a.dtype == object:
                        a = a.astype(str).astype("S")
                    grp[name] = a
    return path


def pixel_variance(png: Path) -> float:
    """Variance of the grey levels of an image (0 for a blank image)."""
    import matplotlib.image as mpimg

    img = np.asarray(mpimg.imread(png), float)
    if img.ndim == 3:
        img = img[..., :3].mean(axis=-1)
    return float(img.var())


# -- comparison tables ------------------------------------------------------------------------
def _num(x):
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) \
        and math.isfinite(float(x))


def fmt(x, digits: int = 4) -> str:
    if x is None:
        return "–"
    if _num(x):
        x = float(x)
        if x == 0:
            return "0"
        if abs(x) >= 1e4 or abs(x) < 1e-3:
            return f"{x:.{digits - 1}e}"
        return f"{x:.{digits}g}"
    if isinstance(x, float):
        return "n/a"
    return str(x)


@dataclass
class Row:
    quantity: str
    paper: object
    ours: object
    unit: str = ""
    method: str = ""

    def diff(self):
        if _num(self.paper) and _num(self.ours):
            d = float(self.ours) - float(self.paper)
            pct = 100 * d / abs(float(self.paper)) if float(self.paper) != 0 else math.nan
            return d, pct
        return None, None


@dataclass
class Comparison:
    """The table of ``comparison.md``: every number the paper states for a figure, ours
    next to it, the difference (absolute and %), and the method that gave ours."""

    figure: str
    title: str
    quality: str
    rows: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    def add(self, quantity, paper, ours, unit="", method=""):
        self.rows.append(Row(quantity, paper, ours, unit, method))

    def note(self, text: str):
        self.notes.append(text)

    def markdown(self) -> str:
        out = [f"# {self.figure}: {self.title}", "",
               f"Quality: `{self.quality}`. Units: µm, pN, s. Differences are ours − paper.", "",
               "| quantity | paper | ours | unit | difference | difference [%] | method (ours) |",
               "|---|---|---|---|---|---|---|"]
        for r in self.rows:
            d, pct = r.diff()
            out.append(f"| {r.quantity} | {fmt(r.paper)} | {fmt(r.ours)} | {r.unit} | "
                       f"{fmt(d, 3) if d is not None else '–'} | "
                       f"{(f'{pct:+.1f}' if pct is not None and math.isfinite(pct) else '–')} | "
                       f"{r.method} |")
        if self.notes:
            out += ["", "Notes:", ""] + [f"- {n}" for n in self.notes]
        return "\n".join(out) + "\n"

    def write(self, out_dir: Path) -> Path:
        from ..io import atomic_write_text

        p = out_dir / "comparison.md"
        atomic_write_text(p, self.markdown())
        return p

    def as_dict(self) -> list:
        res = []
        for r in self.rows:
            d, pct = r.diff()
            res.append({"quantity": r.quantity, "paper": r.paper, "ours": r.ours, "unit": r.unit,
                        "difference": d, "difference_percent": pct, "method": r.method})
        return res


class Timer:
    def __init__(self):
        self.t0 = time.perf_counter()

    @property
    def seconds(self) -> float:
        return time.perf_counter() - self.t0


# -- simulation of one torque (Fig. 3, Fig. 4) ------------------------------------------------
REGIME_LABELS = {"reorienting": "(i)", "aligned": "(ii)", "buckled": "(iii)", "oscillating": "(iv)"}
#: running-mean window [s] that separates the fast (compressional) part of σ
FAST_WINDOW = 0.01


def simulate_point(spec: dict) -> dict:
    """Simulate the anchored filament at one torque and measure the observables of Fig. 3–4.

    ``spec`` keys: ``torque`` [pN·µm]; ``t_end`` [s]; ``protocol`` ``"rest"`` (start from
    the stress-free helix) or ``"step"`` (the paper's protocol, Sec. 3.1.2: rotate at M = 1
    until ``t_step``, then ramp to ``torque`` within 0.01 s); ``frame`` (``"auto"`` or
    ``"lab"``); ``thermal`` with ``seed`` and ``dt``; ``window`` — the averaging window
    starts at t_end − window·(t_end − t_start); ``series`` — keep time series for plots;
    ``hydrodynamics`` — the filament's mobility (a
    :class:`~flagellum.hydro.options.Hydrodynamics`; default local RFT).

    Returns the observables (thrust mean/min/max/std, ω = mean motor speed, χ, ⟨r⟩, σ,
    regime) or ``error`` when the run failed with every solver setting tried.
    """
    from ..analysis.regimes import classify, run_frame
    from ..helix import Helix
    from ..motor import Motor
    from ..params import Params
    from ..simulator import Simulator, SolverOptions, run_first_success

    params = spec.get("params") or Params()
    helix = Helix.from_filament(params.filament)
    M = float(spec["torque"])
    t_end = float(spec["t_end"])
    protocol = spec.get("protocol", "rest")
    t_step = float(spec.get("t_step", 0.05))
    if protocol == "step":
        motor = Motor(M, schedule=((0.0, 1.0), (t_step, 1.0), (t_step + 0.01, M)))
        t_start = t_step + 0.01
    else:
        motor = Motor(M)
        t_start = 0.0
    thermal = bool(spec.get("thermal", False))
    frames = [spec.get("frame", "auto")]
    if frames[0] == "auto" and not thermal:
        frames.append("lab")
    n_save = int(spec.get("samples", 600))
    wall0 = time.perf_counter()
    attempts = [(None, frame) for frame in frames]  # the run's default method
    if not thermal:
        attempts += [("cvode", frame) for frame in frames] + [("implicit", frames[-1])]

    def make(method, frame):
        solver = SolverOptions(method=method, frame=frame, dt=float(spec.get("dt", 5e-5)))
        return Simulator(params, motor, thermal=thermal, seed=int(spec.get("seed", 0)), solver=solver,
                         hydrodynamics=spec.get("hydrodynamics"))

    tr, _, method, frame, errors = run_first_success(make, attempts, t_end, t_end / n_save)
    err = errors[-1] if tr is None else None
    out = {"torque": M, "t_end": t_end, "protocol": protocol, "thermal": thermal,
           "wall_seconds": time.perf_counter() - wall0}
    if spec.get("log"):
        import sys

        print(f"  {'thermal' if thermal else 'deterministic'} run M = {M:g} pN·µm, {t_end:g} s: "
              f"{'failed' if err else 'done'} in {out['wall_seconds']:.1f} s", file=sys.stderr, flush=True)
    if err is not None:
        return {**out, "error": err}
    out["frame"] = frame
    out["solver"] = method
    if errors:
        out["retried_after"] = "; ".join(errors)
    t_from = t_end - float(spec.get("window", 0.5)) * (t_end - t_start)
    s = tr.summary(t_from)
    sel = tr.t >= t_from - 1e-12
    th = tr.thrust[sel]
    sigma0 = helix.radius / math.sqrt(2)
    regime = classify(tr.t, tr.thrust, tr.positions, helix.radius, helix.axial_length, t_from, tr.kT,
                      **run_frame(tr))
    sig = s.end_to_end_std / sigma0
    # fast part of σ: r about its running mean over FAST_WINDOW (compressional fluctuations,
    # without the slow drifts of weakly damped modes)
    r_win = np.linalg.norm(tr.positions[sel, -1] - tr.positions[sel, 0], axis=1)
    w = int(round(FAST_WINDOW / (t_end / n_save)))
    sig_fast = math.nan
    if w >= 3 and len(r_win) > 4 * w:
        rm = np.convolve(r_win, np.ones(w) / w, mode="same")
        sig_fast = float(np.std((r_win - rm)[w:-w]) / sigma0)
    if regime == "oscillating" and sig <= SIGMA_IV:
        regime = "buckled"
    out.update({
        "regime": regime, "thrust_mean": s.thrust_mean, "thrust_min": float(th.min()),
        "thrust_max": float(th.max()), "thrust_std": s.thrust_std,
        "omega": float(np.mean(tr.motor_speed[sel])), "chi": s.chi_mean,
        "r_mean": s.end_to_end_mean, "r_std": s.end_to_end_std,
        "r_over_L0": s.end_to_end_mean / helix.axial_length, "sigma_over_sigma0": sig,
        "sigma_fast_over_sigma0": sig_fast,
        "centroid_offset": s.centroid_offset, "t_from": t_from,
        "hook_tilt_max_deg": float(np.degrees(np.arccos(np.clip(-tr.hook_tangent[sel, 2], -1, 1))).max()),
    })
    if spec.get("series"):
        out["series"] = {"t": tr.t, "thrust": tr.thrust, "hook_tangent": tr.hook_tangent,
                         "r": np.linalg.norm(tr.positions[:, -1] - tr.positions[:, 0], axis=1)}
    return out


__all__ = ["QUALITIES", "FIGURES", "UNITS", "Comparison", "check_quality", "job_cost", "pmap",
           "save_figure", "write_h5", "simulate_point", "pixel_variance"]
