"""Speed benchmarks (``flagellum bench``): wall time per simulated second, measured here.

* ``steady``: anchored filament, N = 50, M = 1 pN·µm, in steady rotation: after a warm-up
  (untimed) the default solver runs a window of ``window`` simulated seconds; the thrust is
  compared with a tight-tolerance (rtol = 1e-10) run over the same window.
* ``from_rest``: the same from the helix at rest (transient included).
* ``scaling``: N = 50 … 400 (L fixed): cost per simulated second in steady rotation
  (started from the relative equilibrium), and the cost of one step (from rest).
* ``brownian``: thermal run at N = 50 with the drift-implicit scheme, M = 1, over 0.1
  simulated s after a 2-ms ramp (long enough that the fixed cost of starting a run,
  ≈ 15 ms, adds < 3 %).
* ``regimes`` (:func:`regimes`): the same work a user runs, N = 50 from rest — M = 1, buckled
  M = 1.6, M = 3, oscillating M = 5, a load sphere, a free swimmer, thermal M = 1 — each
  with the wall seconds per simulated second, the solver's steps, steps per motor
  revolution, and the error of the time-averaged thrust, ω and χ (last half of the window)
  against a tight-tolerance run whose own convergence is shown by a second, looser one;
  ``limit``: where that run's wall time went and the next step named for its largest cost
  (:func:`flagellum.costs.limit`, measured in the run itself).
  Any deterministic stepper can run them (``solver``; ``flagellum bench --method cvode``);
  by default each run's default method (the Numba BDF for all deterministic ones).
* ``sbt_regimes`` (:func:`sbt_regimes`, ``flagellum bench --hydrodynamics sbt``): the runs
  from rest at M = 1, 1.6, the load sphere and the free swimmer with RFT and with the
  nonlocal mobility, one after the other, their cost ratio and the error of the frozen
  splitting's time averages against the unfrozen one.
* ``work_precision`` (:func:`work_precision`): error of those averages against wall time for
  CVODE and the Numba BDF (:mod:`flagellum.integrate.bdf`) over rtol and the fixed-step BDF2
  over Δt (buckled M = 1.6 and M = 1 from rest by default, any of :data:`REGIMES`);
  :func:`plot_work_precision` draws the diagram (``flagellum bench --plot``).
* the peer (``flagellum bench --peer``): PyElastica (:mod:`flagellum.peer`, in its own
  environment) on each deterministic regime, ``peer_ratio`` = its wall seconds per simulated
  second over flagellum's (:func:`peer_columns`), and over Δt in the work–precision runs
  (:func:`peer_precision`).
"""

from __future__ import annotations

import contextlib
import os
import time

import numpy as np

from . import costs
from .analysis.observables import summarize
from .motor import Boundary, Motor
from .params import Filament, Params
from .simulator import Simulator, SolverOptions, State


def _timed(sim: Simulator, t_end: float, save_every: float):
    w0, s0 = sim.wall_seconds, sim.steps
    tr = sim.run(t_end, save_every=save_every, progress=False)
    return tr, sim.wall_seconds - w0, sim.steps - s0


def steady_state(torque: float = 1.0, params: Params | None = None, warmup: float = 0.05) -> Simulator:
    """A simulator started from the relative equilibrium (steady rotation), warmed up briefly."""
    from .analysis.stability import relative_equilibrium

    params = params or Params()
    eq = relative_equilibrium(params, torque)
    sim = Simulator.from_state(State(eq.state, eq.charts), params, Motor(torque), omega_frame=eq.omega)
    sim.run(warmup, save_every=warmup / 50, progress=False)
    return sim


def bench(window: float = 0.2, quick: bool = False, with_regimes: bool = True,
          with_work_precision: bool = False, solver: SolverOptions | None = None,
          work_precision_names=None, peer: bool = False, hydrodynamics=None) -> dict:
    """Run all benchmarks; returns the JSON-ready dict (``regimes``: :func:`regimes`, the
    deterministic ones with ``solver`` (default: ``SolverOptions()``); ``work_precision``:
    :func:`work_precision` of ``work_precision_names``, only when asked for; ``peer``:
    PyElastica on the same regimes, :func:`peer_columns` and :func:`peer_precision`;
    ``sbt_regimes``: :func:`sbt_regimes` with a nonlocal ``hydrodynamics``, only then)."""
    out: dict = {"segments": 50, "torque": 1.0, "window": window, "load_average": load_average()}
    sim = steady_state(1.0)
    t0, start, frame0 = sim.t, sim.state(), sim.model.omega_frame
    tr, wall, steps = _timed(sim, t0 + window, window / 100)
    ref = Simulator.from_state(start, Params(), Motor(1.0), t=t0, omega_frame=frame0,
                               solver=SolverOptions(method="cvode", rtol=1e-10, atol=1e-12))
    ref_tr = ref.run(t0 + window, save_every=window / 100, progress=False)
    out.update(wall_per_simulated_second=wall / window, steps=steps,
               thrust=float(np.mean(tr.thrust)),
               thrust_error=float(np.abs(tr.thrust - ref_tr.thrust).max()),
               reference_wall_per_simulated_second=ref.wall_seconds / window)
    # from rest, co-rotating frame and lab frame
    for key, frame in (("from_rest", "auto"), ("from_rest_lab_frame", "lab")):
        s = Simulator(Params(), Motor(1.0), solver=SolverOptions(frame=frame))
        w = 0.05 if quick else 0.1
        _, wall, steps = _timed(s, w, w / 50)
        out[key] = {"wall_per_simulated_second": wall / w, "steps": steps}
    scaling = []
    for n in (50, 100) if quick else (50, 100, 200, 400):
        p = Params(Filament(segment_length=10.0 / n))
        s = steady_state(1.0, p, warmup=0.01)
        w = 0.02 if quick else 0.05
        _, wall, steps = _timed(s, s.t + w, w / 10)
        r = Simulator(p, Motor(1.0))  # from rest: many steps, for the cost of one step
        _, wall_r, steps_r = _timed(r, 0.002, 0.001)
        scaling.append({"segments": n, "wall_per_simulated_second": wall / w, "steps": steps,
                        "from_rest_microseconds_per_step": 1e6 * wall_r / max(steps_r, 1),
                        "from_rest_microseconds_per_step_per_segment":
                            1e6 * wall_r / max(steps_r, 1) / n})
    out["scaling"] = scaling
    opts = SolverOptions(method="implicit")
    b = Simulator(Params(), Motor(1.0, ramp_time=0.002), thermal=True, seed=1, solver=opts)
    b.run(0.002, save_every=0.001, progress=False)
    w = 0.02 if quick else 0.1
    _, wall, steps = _timed(b, 0.002 + w, w / 10)
    out["brownian"] = {"segments": 50, "dt": opts.dt, "wall_per_simulated_second": wall / w,
                       "steps": steps}
    if with_regimes:
        out["regimes"] = regimes(quick, solver=solver, peer=peer)
    if hydrodynamics is not None and not hydrodynamics.is_local:
        out["sbt_regimes"] = sbt_regimes(quick, hydrodynamics=hydrodynamics)
    if with_work_precision:
        out["work_precision"] = work_precision(quick, peer=peer, **(
            {"names": tuple(work_precision_names)} if work_precision_names else {}))
    out["load_average_end"] = load_average()
    return out


# -- same-work regimes -------------------------------------------------------------------
#: name → (torque [pN·µm], window [s], boundary, thermal); all from rest, N = 50
REGIMES = {
    "from_rest_M1": (1.0, 0.1, Boundary(), False),
    "buckled_M1.6": (1.6, 0.3, Boundary(), False),
    "M3": (3.0, 0.1, Boundary(), False),
    "oscillating_M5": (5.0, 0.1, Boundary(), False),
    "load_sphere_M2": (2.0, 0.1, Boundary(anchor="sphere", sphere_radius=1.0), False),
    "free_swimmer_M2": (2.0, 0.1, Boundary(anchor="free", sphere_radius=0.5), False),
    "thermal_M1": (1.0, 0.05, Boundary(), True),
}
REFERENCE_RTOL = 1e-10  #: the reference run of the error columns
CHECK_RTOL = 1e-9  #: its convergence check: the reference's error is ≲ this run's difference
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)  #: work–precision: CVODE and BDF
DTS = (1e-4, 5e-5, 2e-5)  #: work–precision: fixed-step BDF2 [s]
RECORDS = 200  #: records per window (the default of ``Simulator.run``)
SAVE_GRID = 1e-4  #: record interval: a multiple of every Δt of DTS (whole fixed steps) [s]


#: work–precision methods: name → (SolverOptions method, the setting swept, line style)
METHODS = {"cvode": ("cvode", "rtol", "o-"), "bdf": ("bdf", "rtol", "^-"),
           "bdf2": ("implicit", "dt", "s--")}


def _solver(kind: str, value: float | None = None) -> SolverOptions:
    method, setting, _ = METHODS[kind]
    if value is None:
        return SolverOptions(method=method)
    return SolverOptions(method=method, **{setting: value})


def run_regime(name: str, solver: SolverOptions | None = None, window: float | None = None,
               hydrodynamics=None, with_limit: bool = False) -> dict:
    """One run of regime ``name`` of :data:`REGIMES` from rest: wall time of the run itself,
    steps, steps per motor revolution and the time averages (thrust, ω, χ; last half);
    ``hydrodynamics`` the mobility (default RFT); ``cpu_seconds`` the process time of the run;
    ``with_limit``: also ``limit``, where the run's wall time went (:func:`flagellum.costs.limit`,
    measured in this run)."""
    torque, w, boundary, thermal = _regime(name)
    w = w if window is None else window
    if solver is None:
        solver = SolverOptions(method="implicit") if thermal else SolverOptions()
    sim = Simulator(Params(), Motor(torque), boundary, thermal=thermal, seed=1 if thermal else None,
                    solver=solver, hydrodynamics=hydrodynamics)
    # the same records for every solver: the averages compared sample the same instants
    save = SAVE_GRID * max(1, round(w / RECORDS / SAVE_GRID))
    with costs.instrumented(sim) if with_limit else contextlib.nullcontext() as clock:
        cpu0 = time.process_time()
        tr, wall, steps = _timed(sim, w, save)
        cpu = time.process_time() - cpu0
    s = summarize(tr.t, tr.thrust, tr.motor_angle, tr.positions, tr.energy,
                  tr.meta.get("helix_radius", 0.2))
    revolutions = abs(tr.motor_angle[-1] - tr.motor_angle[0]) / (2 * np.pi)
    row = {"method": sim.solver.method, "window": w, "wall_seconds": wall, "cpu_seconds": cpu,
           "wall_per_simulated_second": wall / w,
           "steps": steps, "steps_per_revolution": steps / max(revolutions, 1e-12),
           "thrust": s.thrust_mean, "omega": s.omega_mean, "chi": s.chi_mean}
    if with_limit:
        row["limit"] = costs.limit(clock, wall, revolutions)
    return row


def average_errors(run: dict, ref: dict) -> dict:
    """Errors of the time averages: thrust and ω relative, χ relative to the reference's ω
    (χ ≈ 0 while the filament stays aligned); ``error`` is the largest."""
    scale_w = max(abs(ref["omega"]), 1e-12)
    e = {"thrust_error": abs(run["thrust"] - ref["thrust"]) / max(abs(ref["thrust"]), 1e-12),
         "omega_error": abs(run["omega"] - ref["omega"]) / scale_w,
         "chi_error": abs(run["chi"] - ref["chi"]) / scale_w}
    return {**e, "error": max(e.values())}


def warm_up() -> None:
    """Compile the kernels of every solver and boundary (untimed), so that no timed run pays
    Numba's compile pause."""
    from .warmup import WARM_TIME

    for name, (torque, _, boundary, thermal) in REGIMES.items():
        for solver in ((_solver("bdf2"),) if thermal else
                       (_solver("cvode"), _solver("bdf"), _solver("bdf2"))):
            # 2 ms at 20 records: long enough for the frame to adapt and the charts to move,
            # so the history carry through them is compiled too (2 records reach neither)
            Simulator(Params(), Motor(torque), boundary, thermal=thermal, seed=1,
                      solver=solver).run(WARM_TIME, save_every=WARM_TIME / 20, progress=False)


def regimes(quick: bool = False, names=None, solver: SolverOptions | None = None,
            peer: bool = False) -> dict:
    """:data:`REGIMES` at ``solver`` (default: each run's default method,
    :func:`~flagellum.integrate.default_method`, at the default rtol; thermal: always the
    default fixed-step scheme), each against a CVODE rtol = 1e-10 reference over
    the same window (thermal: no reference, the noise differs per step size). ``reference_check``
    is the error of an rtol = 1e-9 run against the reference, an upper bound on the reference's
    own error. ``quick``: windows a quarter as long, reference rtol 1e-8 checked by 1e-7.
    ``peer``: PyElastica (:mod:`flagellum.peer`) on each deterministic regime right after
    flagellum's runs of it (:func:`peer_columns`); without it, or without its environment,
    ``peer_ratio`` is None and ``peer_reason`` says why."""
    ref_rtol, check_rtol = (1e-8, 1e-7) if quick else (REFERENCE_RTOL, CHECK_RTOL)
    warm_up()
    peer_ok, peer_reason = peer_available() if peer else (False, "not run (flagellum bench --peer)")
    out = {}
    for name in names or REGIMES:
        torque, w, _, thermal = REGIMES[name]
        w = 0.25 * w if quick else w
        row = {"torque": torque, **run_regime(name, None if thermal else solver, window=w,
                                              with_limit=True)}
        if not thermal:
            row["rtol"] = (solver or SolverOptions()).rtol
        if not thermal:
            ref = run_regime(name, _solver("cvode", ref_rtol), w)
            chk = run_regime(name, _solver("cvode", check_rtol), w)
            row.update(average_errors(row, ref), reference_rtol=ref_rtol,
                       reference_check=average_errors(chk, ref)["error"],
                       reference_wall_per_simulated_second=ref["wall_per_simulated_second"])
        else:
            row.update(error=None, dt=SolverOptions().dt)
        if thermal:
            row.update(peer_ratio=None, peer_reason="PyElastica is run without thermal noise here")
        elif peer_ok:
            row.update(peer_columns(name, row["wall_per_simulated_second"], quick))
        else:
            row.update(peer_ratio=None, peer_reason=peer_reason)
        out[name] = row
    return out


#: regimes of :func:`sbt_regimes` that are not :data:`REGIMES` (no PyElastica peer: it has no
#: cell body): a whole cell, body a = 1 µm, motor on its rear pole (CVODE, the cell's method)
CELL_REGIMES = {"cell_M1": (1.0, 0.1, Boundary(anchor="free", body_radius=1.0), False)}
#: the regimes of :func:`sbt_regimes`, each run with RFT and with the nonlocal mobility
SBT_REGIMES = ("from_rest_M1", "buckled_M1.6", "load_sphere_M2", "free_swimmer_M2", "cell_M1")


def _regime(name: str) -> tuple:
    """(torque, window, boundary, thermal) of regime ``name`` (:data:`REGIMES`,
    :data:`CELL_REGIMES`)."""
    return REGIMES[name] if name in REGIMES else CELL_REGIMES[name]
#: the untimed run of each regime before the timed ones [s]: long enough for the code paths
#: that start later (the frame's adaptation and its carry), whose compile a 0.2-ms run left
#: in the first timed run (1.4 s more CPU in RFT's run from rest)
WARM_UP = 0.01


def warm_up_regimes(names, hydrodynamics=(None,)) -> None:
    """Run each regime of ``names`` with each mobility of ``hydrodynamics`` (None: RFT) over
    :data:`WARM_UP`, untimed, so that no timed run compiles."""
    for name in names:
        for h in hydrodynamics:
            run_regime(name, window=min(WARM_UP, _regime(name)[1]), hydrodynamics=h)


def sbt_regimes(quick: bool = False, names=SBT_REGIMES, hydrodynamics=None,
                reference: bool = True) -> dict:
    """:data:`SBT_REGIMES` with RFT and with ``hydrodynamics`` (default: SBT, default
    ``refresh``), each at its default method (the Numba BDF for both), one right after the
    other: per model wall and CPU seconds, steps and time averages, and ``cpu_ratio`` /
    ``wall_ratio`` SBT over RFT (docs/hydrodynamics.md, "Cost against RFT"; the target is
    ≤ 3). ``reference``: also the error of SBT's time averages (:func:`average_errors`)
    against the unfrozen splitting (``refresh`` 0, ΔM rebuilt at every right-hand side;
    CVODE at rtol 1e-8), the accuracy of freezing. ``quick``: windows a quarter as long."""
    from .hydro.options import Hydrodynamics

    hd = hydrodynamics or Hydrodynamics("sbt")
    warm_up_regimes(names, (None, hd))
    out = {}
    for name in names:
        w = _regime(name)[1] * (0.25 if quick else 1.0)
        rft, sbt = run_regime(name, window=w), run_regime(name, window=w, hydrodynamics=hd)
        row = {"torque": _regime(name)[0], "window": w, "model": hd.model, "refresh": hd.refresh,
               "rft": rft, "sbt": sbt,
               "cpu_ratio": sbt["cpu_seconds"] / max(rft["cpu_seconds"], 1e-12),
               "wall_ratio": sbt["wall_seconds"] / max(rft["wall_seconds"], 1e-12)}
        if reference and hd.refresh > 0:
            ref = run_regime(name, _solver("cvode", 1e-8), w,
                             hydrodynamics=Hydrodynamics(hd.model, refresh=0.0))
            row.update(average_errors(sbt, ref), reference_cpu_seconds=ref["cpu_seconds"])
        out[name] = row
    return out


def peer_available() -> tuple[bool, str]:
    """Whether PyElastica's environment is there (:func:`flagellum.peer.available`)."""
    from . import peer

    return peer.available()


def _peer_window(quick: bool) -> float:
    from . import peer

    return peer.WINDOW / 4 if quick else peer.WINDOW


def peer_columns(name: str, wall_per_simulated_second: float, quick: bool = False) -> dict:
    """PyElastica on regime ``name`` at its tuned Δt (:mod:`flagellum.peer`) over a short
    window (its cost per simulated second is the same in every state): its wall seconds per
    simulated second, ``peer_ratio`` = that over flagellum's ``wall_per_simulated_second``,
    and the errors of its time-averaged thrust and ω against a flagellum CVODE rtol 1e-10
    run over the same short window (the two models differ: shearable, inertial rod)."""
    from . import peer

    torque, _, boundary, _ = REGIMES[name]
    w = _peer_window(quick)
    res = peer.run(peer.spec(Params(), torque, boundary), window=w)
    p = res["tuned"]
    if p is None:
        return {"peer_ratio": None, "peer_reason": "PyElastica blew up at every Δt tried",
                "peer": res}
    ref = run_regime(name, _solver("cvode", REFERENCE_RTOL), w)
    return {"peer_ratio": p["wall_per_simulated_second"] / wall_per_simulated_second,
            "peer": {"method": "pyelastica", **p, **_peer_errors(p, ref)}}


def _peer_errors(p: dict, ref: dict) -> dict:
    """Relative errors of a peer run's thrust and ω against flagellum's ``ref``."""
    e = {"thrust_error": abs(p["thrust"] - ref["thrust"]) / max(abs(ref["thrust"]), 1e-12),
         "omega_error": abs(p["omega"] - ref["omega"]) / max(abs(ref["omega"]), 1e-12)}
    return {**e, "error": max(e.values()), "reference_thrust": ref["thrust"],
            "reference_omega": ref["omega"]}


def work_precision(quick: bool = False, names=("buckled_M1.6", "from_rest_M1"),
                   peer: bool = False) -> dict:
    """Error of the time averages against wall time: CVODE and the Numba BDF over
    :data:`RTOLS`, BDF2 over :data:`DTS`, against a CVODE rtol = 1e-10 run (quick: half
    windows, fewer points, 1e-9). The runs of one regime are interleaved by setting (CVODE,
    BDF, CVODE, …), so that a change of the machine's load shifts both lines alike.
    ``peer``: also PyElastica over Δt (:func:`peer_precision`), when its environment is there."""
    warm_up()
    peer_ok = peer and peer_available()[0]
    out = {}
    for name in names:
        w = REGIMES[name][1] * (0.5 if quick else 1.0)
        ref = run_regime(name, _solver("cvode", 1e-9 if quick else REFERENCE_RTOL), w)
        rows = []
        points = [(k, r) for r in (RTOLS[::2] if quick else RTOLS) for k in ("cvode", "bdf")]
        points += [("bdf2", d) for d in (DTS[:2] if quick else DTS)]
        for kind, value in points:
            r = run_regime(name, _solver(kind, value), w)
            rows.append({**r, "method": kind, METHODS[kind][1]: value, **average_errors(r, ref)})
        out[name] = {"window": w, "reference": ref, "runs": rows}
        if peer and peer_ok:
            out[name]["peer"] = peer_precision(name, quick)
    return out


def peer_precision(name: str, quick: bool = False) -> dict:
    """PyElastica over Δt on regime ``name``: its tuned Δt, half and a quarter of it, over
    the short peer window, errors against flagellum's CVODE rtol 1e-10 run over the same
    window (``error``: thrust and ω) and against its own finest Δt (``self_error``: the
    convergence of its own answer)."""
    from . import peer

    torque, _, boundary, _ = REGIMES[name]
    w = _peer_window(quick)
    sp = peer.spec(Params(), torque, boundary)
    tuned = peer.run(sp, window=min(w, 1e-3))["tuned"]
    if tuned is None:
        return {"window": w, "runs": [], "reason": "PyElastica blew up at every Δt tried"}
    dts = [tuned["dt"] / k for k in ((1, 2) if quick else (1, 2, 4))]
    runs = peer.run(sp, dts=dts, window=w, tune=False)["runs"]
    ref = run_regime(name, _solver("cvode", REFERENCE_RTOL), w)
    fine = runs[-1]
    rows = []
    for r in runs:
        if not r["finite"]:
            rows.append({**r, "method": "pyelastica", "failed": True})
            continue
        own = abs(r["thrust"] - fine["thrust"]) / abs(fine["thrust"])
        rows.append({**r, "method": "pyelastica", **_peer_errors(r, ref), "self_error": own})
    return {"window": w, "reference": ref, "runs": rows}


def plot_work_precision(data: dict, path) -> None:
    """The work–precision diagram of :func:`work_precision`: error of the time averages
    against wall seconds per simulated second, one panel per run, a line per method."""
    from ._plot import pyplot

    plt = pyplot()
    cols = min(3, len(data))
    rows_ = -(-len(data) // cols)
    fig, axes = plt.subplots(rows_, cols, figsize=(5.2 * cols, 4.2 * rows_), squeeze=False)
    for ax in axes.flat[len(data):]:
        ax.set_visible(False)
    for ax, (name, d) in zip(axes.flat, data.items()):
        labels = {"cvode": "CVODE (rtol)", "bdf": "Numba BDF (rtol)", "bdf2": "BDF2 (Δt)"}
        for kind, (_, key, marker) in METHODS.items():
            rows = [r for r in d["runs"] if r["method"] == kind and "failed" not in r]
            if not rows:
                continue
            x = [r["wall_per_simulated_second"] for r in rows]
            y = [max(r["error"], 1e-14) for r in rows]
            ax.loglog(x, y, marker, label=labels[kind])
            for r, xi, yi in zip(rows, x, y):
                ax.annotate(f"{r[key]:.0e}", (xi, yi), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
        prow = [r for r in d.get("peer", {}).get("runs", []) if "failed" not in r]
        if prow:
            x = [r["wall_per_simulated_second"] for r in prow]
            ax.loglog(x, [max(r["error"], 1e-14) for r in prow], "D-", color="C3",
                      label=f"PyElastica (Δt; {d['peer']['window']:g} s, vs flagellum)")
            ax.loglog(x[:-1], [max(r["self_error"], 1e-14) for r in prow[:-1]], "D:", color="C3",
                      mfc="none", label="PyElastica vs its own finest Δt")
            for r, xi in zip(prow, x):
                ax.annotate(f"{r['dt']:.2g}", (xi, max(r["error"], 1e-14)), fontsize=7,
                            xytext=(3, 3), textcoords="offset points")
        ax.axhline(1e-3, color="0.6", lw=0.8, ls=":")
        ax.set_title(f"{name}, {d['window']:g} s from rest, N = 50")
        ax.set_xlabel("wall s per simulated s")
        ax.set_ylabel("error of time-averaged F, ω, χ (max, relative)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def load_average() -> float | None:
    """The 1-minute load average of the machine (the timings are only comparable at equal load)."""
    try:
        return os.getloadavg()[0]
    except OSError:  # pragma: no cover - not on every platform
        return None


def main_timing() -> float:
    """Whole-process helper for farm-bench: one warm steady-state window, returns wall."""
    t = time.perf_counter()
    bench(quick=True)
    return time.perf_counter() - t
