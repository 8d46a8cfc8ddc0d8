"""Run and tumble of a free-swimming cell with a polymorphic flagellum:
``flagellum reproduce tumble``.

Not a figure of the paper: the paper holds the filament on the motor axis. This target
puts its filament (shortened, see :data:`LENGTH`) on an E. coli-sized cell body
(:mod:`flagellum.hydro.body`), lets the motor run forward, reverses it for a duration d and
turns it forward again, and measures (:func:`flagellum.analysis.tumble.tumble`) the tumble
angle between the mean swimming directions before and after, the swimming speeds, and the
time course of the transformation (normal → semicoiled → …) and the recovery. A sweep over
d and over the phase of the swimming at which the motor reverses gives the tumble-angle
distribution, compared with the measured mean and spread of Berg & Brown (1972). The runs
are deterministic unless :data:`THERMAL` (or a run's ``seed``) adds the filament's and the
body's Brownian motion (docs/motor.md, "Whole cell").

The landscape (:data:`LANDSCAPE`) has the package default's barrier between normal and
semicoiled (0.25 pN, fitted to Hotani's threshold torque of normal → semicoiled), a lower one
between semicoiled and curly-1 (0.1 pN, so that a wholly curly-1 filament returns) and soft
walls. With the forms' geometry of Darnton et
al. (2007) (:data:`flagellum.params.POLYMORPHIC_FORMS`) a semicoiled domain nucleates at the
hook under the reversed motor and grows along the filament, a curly-1 domain follows it (the
reversed motor's twist drives semicoiled towards the more twisted curly-1), and back at
forward torque the filament returns to normal (docs/polymorphism.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._plot import pyplot
from ..io import write_csv
from ..viz import FORM_COLORS
from .common import Comparison, Timer, pmap, save_figure, write_h5

#: filament length [µm] (the paper's filament is 10 µm; 4 µm keeps a run within a minute)
LENGTH = 4.0
#: the cell body: semi-axes 0.44 × 1.25 µm (an E. coli body 2.5 × 0.88 µm, Darnton et al.,
#: J. Bacteriol. 189, 1756 (2007)), motor at the rear pole; an elastic hook (stiffness
#: [pN·µm], docs/motor.md: with it the cell swims at the measured speed)
BODY = {"body_radius": 0.44, "body_aspect": 1.25 / 0.44, "hook": "elastic", "hook_stiffness": 5.0}
#: the motor torque [pN·µm]: the stall torque of the E. coli motor (H. C. Berg, Annu. Rev.
#: Biochem. 72, 19 (2003)), on whose plateau the swimming cell's motor runs (docs/motor.md)
TORQUE = 1.3
#: the polymorphic landscape of this target: barrier 0.25 pN between normal and semicoiled
#: (the package default, fitted to Hotani's threshold of normal → semicoiled), 0.1 pN between
#: semicoiled and curly-1 (chosen so that a wholly curly-1 filament returns at the forward
#: stall torque, as real filaments do: Darnton et al. 2007; with 0.25 it stays curly-1,
#: docs/polymorphism.md); walls 0.5 pN·µm², equal wells
LANDSCAPE = {"forms": ("normal", "semicoiled", "curly1"), "barrier": (0.25, 0.1),
             "wall_stiffness": 0.5}
#: forward run before the reversal and after it [s] (after: a wholly curly-1 filament is
#: normal again 0.74 s after the motor turns forward, docs/polymorphism.md, then the
#: averaging window); averaging window of each run [s]
RUN_BEFORE, RUN_AFTER, WINDOW = 0.15, 1.0, 0.1
#: reversal durations [s] (CW intervals; E. coli's are ~0.1–1 s) and the shifts of the
#: reversal time [s] (phases of the body's helical path, whose period is ≈ 20 ms)
DURATIONS = {"quick": (0.1, 0.2, 0.35), "full": (0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0)}
PHASES = {"quick": (0.0,), "full": (0.0, 0.007)}
#: thermal noise in the sweep's runs (kT of the package's fluid; run i has seed i + 1, so
#: the sweep is reproducible). Off: with noise the cell's Brownian reorientation between the
#: windows is comparable to the tumble itself (docs/polymorphism.md); the summary's
#: ``recovered_angle_*`` (the window right after the recovery) keeps that time short
THERMAL = False
#: runs per duration and phase with :data:`THERMAL` (seeds 1, 2, …: the noise makes every run
#: different, so the thermal distribution needs several per setting)
THERMAL_REPEATS = 3
#: with :data:`THERMAL`, the run without reversal goes on this much longer [s]: its record then
#: holds many pairs of windows for the mean Brownian turn (:func:`_control_angle`)
THERMAL_CONTROL_EXTRA = 8.0
#: records per second
RATE = 500
#: the measured mean tumble angle [deg] and its standard deviation: wild-type E. coli,
#: H. C. Berg & D. A. Brown, Nature 239, 500 (1972), Table 1
BERG_BROWN_ANGLE, BERG_BROWN_SD = 68.0, 36.0


def run_one(spec: dict) -> dict:
    """One cell: forward for ``RUN_BEFORE + phase``, reversed for ``duration`` (0: never),
    forward for ``RUN_AFTER`` (+ ``spec["extra"]``), with the mobility
    ``spec["hydrodynamics"]`` (a :class:`~flagellum.hydro.options.Hydrodynamics` as a dict;
    None: RFT); with thermal noise of seed ``spec["seed"]`` unless it is None
    (the fixed-step implicit scheme then, as for every thermal run). Returns the
    :class:`~flagellum.analysis.tumble.TumbleSummary` fields and the time series of the
    figure (or ``error``)."""
    from ..analysis.tumble import tumble
    from ..hydro.options import Hydrodynamics
    from ..motor import Boundary, Motor
    from ..params import Params, Polymorphism
    from ..rod.polymorph import fractions
    from ..simulator import Simulator, SolverOptions

    d, phase = float(spec["duration"]), float(spec.get("phase", 0.0))
    t_on = RUN_BEFORE + phase
    t_off = t_on + d
    t_end = t_off + RUN_AFTER + float(spec.get("extra", 0.0))
    params = Params().replace(length=spec.get("length", LENGTH))
    pm = Polymorphism(**spec.get("landscape", LANDSCAPE))
    motor = Motor(spec.get("torque", TORQUE), reversals=(t_on, t_off) if d > 0 else None)
    # the lab frame: the body wobbles and the motor turns both ways, so no co-rotating frame
    # fits for long
    seed = spec.get("seed")
    thermal = seed is not None
    solver = SolverOptions(frame="lab", method="implicit") if thermal else SolverOptions(frame="lab")
    sim = Simulator(params, motor, Boundary(anchor="free", **spec.get("body", BODY)),
                    polymorphism=pm, thermal=thermal, seed=seed, solver=solver,
                    hydrodynamics=Hydrodynamics.from_dict(spec.get("hydrodynamics")))
    timer = Timer()
    out = {"duration": d, "phase": phase, "seed": math.nan if seed is None else float(seed)}
    try:
        tr = sim.run(t_end, save_every=1.0 / RATE)
    except Exception as exc:  # noqa: BLE001 - one failed run is reported, the sweep goes on
        return {**out, "error": str(exc), "wall_seconds": timer.seconds}
    window = spec.get("window", WINDOW)
    # a run without reversal: the same windows as a reversed run of zero length
    s = tumble(tr.t, tr.body_position, tr.body_axis, (t_on, t_off if d > 0 else t_on + 1e-9),
               window, tr.polymorph, pm.forms)
    out.update(s.to_dict())
    out.pop("peak_fractions")
    out.update({f"peak_{k}": v for k, v in (s.peak_fractions or {}).items()},
               wall_seconds=timer.seconds, t_end=t_end)
    frac = fractions(tr.polymorph, len(pm.forms))
    out["series"] = {"t": tr.t, "torque": tr.torque, "fractions": frac,
                     "body_position": tr.body_position, "body_axis": tr.body_axis}
    return out


@dataclass(frozen=True)
class TumbleData:
    """The runs of the sweep (successful ones and failures) and the control without reversal."""

    runs: tuple
    control: dict
    hydrodynamics: str = "rft"  #: the filament's mobility model


def compute(quality: str, cache=None) -> TumbleData:
    """The sweep of :data:`DURATIONS` × :data:`PHASES` and one run without reversal."""
    hyd = getattr(cache, "hydrodynamics", None)
    hyd = None if hyd is None or hyd.is_local else hyd.to_dict()
    repeats = THERMAL_REPEATS if THERMAL else 1
    jobs = [{"duration": d, "phase": p, "cost": d + RUN_BEFORE + RUN_AFTER}
            for d in DURATIONS[quality] for p in PHASES[quality] for _ in range(repeats)]
    # the control runs as long as the longest reversed run, so that its record holds several
    # pairs of windows as far apart as those of the reversed runs (:func:`_control_angle`)
    extra = max(DURATIONS[quality]) + max(PHASES[quality]) + (THERMAL_CONTROL_EXTRA if THERMAL else 0.0)
    jobs.append({"duration": 0.0, "phase": 0.0, "extra": extra,
                 "cost": RUN_BEFORE + RUN_AFTER + extra})
    for i, job in enumerate(jobs):
        job["seed"] = i + 1 if THERMAL else None
        job["hydrodynamics"] = hyd
    res = pmap(run_one, jobs)
    return TumbleData(tuple(res[:-1]), res[-1], (hyd or {}).get("model", "rft"))


def _ok(runs):
    return [r for r in runs if "error" not in r]


def _recovered(runs):
    """The runs whose filament holds the first form in at least half the joints at the end."""
    from ..analysis.tumble import HALF

    return [r for r in runs if not r.get("normal_fraction_final", 1.0) < HALF]


def analyse(data: TumbleData) -> dict:
    """Mean, spread and distribution of the tumble angles
    (:func:`~flagellum.analysis.tumble.angle_distribution`), speeds and times over the
    successful runs."""
    from ..analysis.tumble import angle_distribution

    ok = _ok(data.runs)
    rec = _recovered(ok)
    # a tumble angle is between two runs: a filament that has not returned to normal by the
    # end of the record has no run after the tumble (it pulls the cell), so it is left out
    dist = angle_distribution([r["tumble_angle_deg"] for r in rec])
    near = angle_distribution([r.get("recovered_tumble_angle_deg", math.nan) for r in rec])

    def mean(key, runs=ok):
        return _mean(r.get(key, math.nan) for r in runs)

    return {"runs": len(data.runs), "failed": len(data.runs) - len(ok),
            "not_recovered": len(ok) - len(rec), "angles": len(rec),
            "tumble_angle_mean_deg": dist["mean"], "tumble_angle_std_deg": dist["sd"],
            "tumble_angle_median_deg": dist["median"], "tumble_angle_q25_deg": dist["q25"],
            "tumble_angle_q75_deg": dist["q75"], "tumble_angle_mean_cos": dist["mean_cos"],
            "tumble_angle_max_deg": (float(max(r["tumble_angle_deg"] for r in rec))
                                     if rec else math.nan),
            "histogram_edges_deg": dist["edges"], "histogram_counts": dist["counts"],
            "control_angle_deg": _control_angle(data.control, _mean(map(_end_lag, rec))),
            "recovered_angle_mean_deg": near["mean"], "recovered_angle_std_deg": near["sd"],
            "recovered_angle_median_deg": near["median"], "recovered_angles": near["n"],
            "settle_time": mean("settle_time", rec),
            "control_recovered_angle_deg": _control_angle(data.control, _mean(map(_lag, rec))),
            "speed_before": mean("speed_before"), "speed_after": mean("speed_after", rec),
            "transform_time": mean("transform_time"), "recovery_time": mean("recovery_time"),
            "transformed_fraction_max": mean("transformed_fraction_max"),
            "curly1_reached": sum(1 for r in ok if r.get("peak_curly1", 0) > 0.5)}


def _lag(run: dict) -> float:
    """From the start of the window before the reversal to that of the window right after the
    recovery, less one window [s]: the delay between the two windows."""
    return run["reversal_end"] + run["settle_time"] - run["reversal_start"]


def _end_lag(run: dict) -> float:
    """The same delay for the last window of the record [s]."""
    return run["series"]["t"][-1] - run["window"] - run["reversal_start"]


def _mean(values) -> float:
    v = np.array(list(values), float)
    v = v[np.isfinite(v)]
    return float(v.mean()) if len(v) else math.nan


def _control_angle(control: dict, lag: float) -> float:
    """How far the cell without reversal turns over ``lag`` [s] (wobble, and with noise its
    Brownian rotation): the mean angle between the directions over a window and over the
    window ``lag`` later, for start times one window apart along its record (one run gives
    several such pairs; with noise their mean estimates the expected turn)."""
    from ..analysis.tumble import angle_deg, mean_velocity

    if "series" not in control or not math.isfinite(lag):
        return math.nan
    t, pos, w = control["series"]["t"], control["series"]["body_position"], control["window"]
    starts = np.arange(t[0] + w, t[-1] - lag - w + 1e-9, w)
    if len(starts) == 0:
        return math.nan
    return float(np.mean([angle_deg(mean_velocity(t, pos, s - w, s),
                                    mean_velocity(t, pos, s + lag, s + lag + w)) for s in starts]))


def plot(data: TumbleData, stats: dict, quality: str, out_dir: Path) -> list[Path]:
    """(a) the time course of one tumble: the share of each form and the speed along the
    first run's direction; (b) tumble angle against reversal duration; (c) their histogram."""
    plt = pyplot()
    fig, ax = plt.subplots(1, 3, figsize=(13.5, 4.0))
    ok = _ok(data.runs)
    if ok:
        show = max(ok, key=lambda r: (r["phase"] == 0.0, -abs(r["duration"] - 0.35)))
        s = show["series"]
        t = s["t"]
        for i, f in enumerate(LANDSCAPE["forms"]):
            ax[0].plot(t, s["fractions"][:, i], lw=1.6, label=f, color=FORM_COLORS[i % len(FORM_COLORS)])
        ax[0].axvspan(show["reversal_start"], show["reversal_end"], color="0.85", label="motor CW")
        pos = s["body_position"]
        d0 = pos[np.searchsorted(t, show["reversal_start"])] - pos[0]
        e = d0 / max(np.linalg.norm(d0), 1e-12)
        k = max(1, int(0.02 * RATE))  # speed over 20 ms, about one turn of the helical path
        v = ((pos[k:] - pos[:-k]) @ e) / (t[k:] - t[:-k])
        tw = ax[0].twinx()
        tw.plot(t[k:], v, color="k", lw=0.9, label="speed along the first run")
        tw.set_ylabel("speed along the first run [µm/s]")
        ax[0].set_xlabel("t [s]")
        ax[0].set_ylabel("share of the joints")
        ax[0].set_title(f"(a) one tumble, reversed for {show['duration']:g} s", fontsize=10)
        ax[0].legend(fontsize=7, loc="center left")
    rec = _recovered(ok)
    for r in ok:
        back = r in rec
        ax[1].plot(r["duration"], r["tumble_angle_deg"], "o", color="tab:blue", ms=5,
                   mfc="tab:blue" if back else "none")
        ax[1].plot(r["duration"], r.get("recovered_tumble_angle_deg", math.nan), "x",
                   color="tab:green", ms=5)
    ax[1].plot([], [], "o", color="tab:blue", label="at the end of the record")
    ax[1].plot([], [], "x", color="tab:green", label="right after the recovery")
    if len(rec) < len(ok):
        ax[1].plot([], [], "o", color="tab:blue", mfc="none", label="not back to normal at the end")
    ctrl = stats["control_angle_deg"]
    if math.isfinite(ctrl):
        ax[1].plot(0.0, ctrl, "s", mfc="none", color="tab:blue", label="no reversal (same delay)")
    ax[1].axhspan(BERG_BROWN_ANGLE - BERG_BROWN_SD, BERG_BROWN_ANGLE + BERG_BROWN_SD,
                  color="tab:red", alpha=0.12)
    ax[1].axhline(BERG_BROWN_ANGLE, color="tab:red", lw=1.2,
                  label="E. coli, Berg & Brown 1972 (mean ± sd)")
    ax[1].set_xlabel("reversal duration [s]")
    ax[1].set_ylabel("tumble angle [deg]")
    ax[1].set_ylim(0, 180)
    ax[1].legend(fontsize=7)
    ax[1].set_title("(b) tumble angle", fontsize=10)
    ang = [r["tumble_angle_deg"] for r in rec]
    ax[2].hist(ang, bins=np.linspace(0, 180, 19), color="tab:blue", alpha=0.8, label="ours")
    ax[2].axvline(BERG_BROWN_ANGLE, color="tab:red", lw=1.2, label="Berg & Brown 1972 mean")
    ax[2].set_xlabel("tumble angle [deg]")
    ax[2].set_ylabel("runs")
    ax[2].legend(fontsize=7)
    ax[2].set_title("(c) distribution", fontsize=10)
    return save_figure(fig, out_dir, "tumble", f"Run and tumble of a cell with a polymorphic "
                       f"flagellum (L = {LENGTH:g} µm, quality {quality})")


COLUMNS = ("duration", "phase", "tumble_angle_deg", "axis_tumble_angle_deg", "speed_before",
           "speed_after", "reversal_start", "reversal_end", "transform_time", "recovery_time",
           "transformed_fraction_max", "normal_fraction_final", "peak_semicoiled", "peak_curly1",
           "settle_time", "recovered_tumble_angle_deg", "speed_recovered", "sequence",
           "wall_seconds", "seed")
UNITS = {"duration": "s", "phase": "s", "tumble_angle_deg": "deg", "axis_tumble_angle_deg": "deg",
         "speed_before": "µm/s", "speed_after": "µm/s", "reversal_start": "s", "reversal_end": "s",
         "transform_time": "s", "recovery_time": "s", "settle_time": "s",
         "recovered_tumble_angle_deg": "deg", "speed_recovered": "µm/s", "wall_seconds": "s"}


def write(out_dir: Path, data: TumbleData, quality: str) -> list[Path]:
    """``tumbles.csv`` (one row per run, the control last), ``tumble_angles.csv`` (the
    histogram of the reversed runs' tumble angles) and ``tumble.h5`` (with the time series)."""
    rows = _ok(data.runs) + ([data.control] if "error" not in data.control else [])
    cols = {c: [r.get(c, math.nan) for r in rows] for c in COLUMNS}
    groups = {"tumbles": {c: np.array(v, dtype=object if c == "sequence" else float)
                          for c, v in cols.items()}}
    for i, r in enumerate(rows):
        groups[f"run_{i:02d}"] = {k: np.asarray(v) for k, v in r["series"].items()}
    from ..analysis.tumble import angle_distribution

    dist = angle_distribution([r["tumble_angle_deg"] for r in _ok(data.runs)])
    hist = {"angle_low": dist["edges"][:-1], "angle_high": dist["edges"][1:], "runs": dist["counts"]}
    return [write_csv(out_dir / "tumbles.csv", cols, UNITS),
            write_csv(out_dir / "tumble_angles.csv", hist, {"angle_low": "deg", "angle_high": "deg"}),
            write_h5(out_dir / "tumble.h5", groups, {"quality": quality, "length": LENGTH,
                                                      "torque": TORQUE})]


def compare(data: TumbleData, stats: dict, quality: str) -> Comparison:
    """The literature next to ours."""
    cmp = Comparison("tumble", "run and tumble of a cell with one polymorphic flagellum", quality)
    cmp.add("mean tumble angle (E. coli, Berg & Brown, Nature 239, 500 (1972))", BERG_BROWN_ANGLE,
            stats["tumble_angle_mean_deg"], "deg",
            f"mean over the {stats['angles']} runs whose filament is back to normal at the end "
            f"(of {stats['runs'] - stats['failed']}: durations × phases"
            + (" × seeds" if THERMAL else "") + "), swimming "
            "directions over 0.1 s before and at the end")
    cmp.add("sd of the tumble angle (Berg & Brown 1972)", BERG_BROWN_SD, stats["tumble_angle_std_deg"],
            "deg", "over the same runs (spread from the noise, durations and phases)"
            if THERMAL else "over the same runs (deterministic: spread from durations and phases)")
    cmp.add("median and quartiles of the tumble angle", None,
            f"{stats['tumble_angle_median_deg']:.1f} ({stats['tumble_angle_q25_deg']:.1f}–"
            f"{stats['tumble_angle_q75_deg']:.1f})", "deg", "over the same runs")
    cmp.add("mean cosine of the tumble angle (0: direction forgotten)", None,
            stats["tumble_angle_mean_cos"], "", "over the same runs")
    cmp.add("runs in which curly-1 held more than half the joints", None,
            stats["curly1_reached"], "", f"of {stats['runs'] - stats['failed']}")
    cmp.add("tumble angle without reversal (" + ("wobble and Brownian motion" if THERMAL
                                                 else "wobble only") + ")",
            None if THERMAL else 0.0, stats["control_angle_deg"], "deg",
            "motor never reversed: mean angle between windows as far apart as the reversed "
            "runs' (mean over start times along the record)")
    cmp.add("mean tumble angle right after the recovery (Berg & Brown 1972)", BERG_BROWN_ANGLE,
            stats["recovered_angle_mean_deg"], "deg",
            f"sd {stats['recovered_angle_std_deg']:.1f}°, median "
            f"{stats['recovered_angle_median_deg']:.1f}° over {stats['recovered_angles']} runs: "
            "the window before against the 0.1 s from the moment the filament is wholly normal "
            f"again (mean {stats['settle_time']:.2f} s after the motor's return)")
    cmp.add("the same without reversal", None if THERMAL else 0.0,
            stats["control_recovered_angle_deg"], "deg",
            "motor never reversed: windows as far apart as before and right after the "
            "recovery (mean over start times along the record)")
    cmp.add("swimming speed before (E. coli: 29 ± 6 µm/s, Darnton et al. 2007)", 29.0,
            stats["speed_before"], "µm/s", "net speed |V̄| over the window before the reversal")
    cmp.add("swimming speed after recovery", 29.0, stats["speed_after"], "µm/s",
            "net speed over the last 0.1 s")
    cmp.add("sequence of forms in a tumble (Turner, Ryu & Berg, J. Bacteriol. 182, 2793 (2000))",
            "normal → semicoiled → curly 1", _sequences(data), "",
            "forms in order of first appearance after the reversal")
    cmp.add("time to transform half the filament", None, stats["transform_time"], "s",
            "from the reversal; mean over the runs")
    cmp.add("time to recover half the filament", None, stats["recovery_time"], "s",
            "from the motor's return to forward; mean over the runs")
    cmp.note(f"Model: one filament of L = {LENGTH:g} µm (the paper's helix), an elastic hook "
             f"(k = {BODY['hook_stiffness']:g} pN·µm), a spheroidal body 2.5 × 0.88 µm, torque "
             f"±{TORQUE:g} pN·µm, {data.hydrodynamics.upper()}, "
             + ("thermal noise (kT = 4.1e-3 pN·µm, a seed per run)" if THERMAL else "no thermal noise")
             + ". Landscape: barriers "
             + " / ".join(f"{b:g}" for b in LANDSCAPE["barrier"])
             + f" pN (normal–semicoiled / semicoiled–curly-1), wall stiffness "
             f"{LANDSCAPE['wall_stiffness']:g} pN·µm², equal well energies (the first barrier "
             "fitted to Hotani's −1.1 pN·µm for normal → semicoiled, the second chosen so that "
             "a wholly curly-1 filament returns; see docs/polymorphism.md).")
    cmp.note("E. coli tumbles with a bundle of several flagella: the CW filament leaves the "
             "bundle and pulls the body round. A cell with one flagellum has no bundle to "
             "break up, so a small tumble angle is what this model can give; the comparison "
             "with 68° shows the size of what is missing, not a fit.")
    if stats["not_recovered"]:
        cmp.note(f"{stats['not_recovered']} run(s) left out of the angles: the filament was not "
                 "back to normal at the end of the record (" + ", ".join(
                     f"{r['duration']:g} s" for r in _ok(data.runs) if r not in _recovered(_ok(data.runs)))
                 + " reversal), so there is no run after the tumble to measure a direction from.")
    for r in data.runs:
        if "error" in r:
            cmp.note(f"The run reversed for {r['duration']:g} s (phase {r['phase']:g} s) failed "
                     f"and is left out: {r['error']}")
    return cmp


def _sequences(data: TumbleData) -> str:
    seqs = sorted({"normal → " + " → ".join(r["sequence"].split(",")) if r["sequence"] else "normal"
                   for r in _ok(data.runs)})
    return "; ".join(seqs) if seqs else "–"


def headline(stats: dict, quality: str, seconds: float, files: list) -> dict:
    return {**stats, "quality": quality, "wall_seconds": seconds, "files": [str(f) for f in files]}


def run(out_dir: Path, quality: str, cache=None) -> dict:
    """Compute, analyse, plot and write the tumble target into ``out_dir``."""
    timer = Timer()
    out_dir.mkdir(parents=True, exist_ok=True)
    data = compute(quality, cache)
    stats = analyse(data)
    files = plot(data, stats, quality, out_dir)
    files += write(out_dir, data, quality)
    files.append(compare(data, stats, quality).write(out_dir))
    return headline(stats, quality, timer.seconds, files)


__all__ = ["BERG_BROWN_ANGLE", "BODY", "DURATIONS", "LANDSCAPE", "LENGTH", "TORQUE",
           "TumbleData", "analyse", "compute", "run", "run_one"]
