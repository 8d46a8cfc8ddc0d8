"""``flagellum demo``: the paper's filament below and above the first buckling torque."""

from __future__ import annotations

from pathlib import Path

import click

from .motor import Motor
from .params import Params
from .simulator import Simulator

#: (label, torque [pN·µm], simulated time [s]) — below and above M_c1 ≈ 1.04 pN·µm
#: (label, torque [pN·µm], time [s], save interval [s]): the aligned run is long enough for
#: its slow tilt mode to settle (1/|λ| ≈ 0.3 s at M = 0.8), and saved densely enough that its
#: lab-frame movie shows ~8 frames per motor revolution
DEMO_RUNS = (("aligned", 0.8, 1.0, 1.25e-3), ("buckled", 1.6, 1.0, 2.5e-3))


def run_demo(out_dir: str | Path = "flagellum-demo", progress: bool | None = None,
             runs=DEMO_RUNS, frames: int = 100, size: str = "720p", quiet: bool = False) -> dict:
    """Simulate, classify, and write movies and a figure; returns the headline numbers
    (and prints them, unless ``quiet``).

    Each run gets ``<label>.mp4`` (``size``: a key of :data:`flagellum.viz.SIZES`) and its
    last frame as ``<label>.png``. An aligned filament only turns, so its movie shows the
    lab frame over the last ``frames`` records, one frame per saved record (several per
    motor revolution). Any other regime changes shape slowly: its movie shows the whole
    run in the co-rotating view, ``frames`` frames spread evenly.
    """
    say = (lambda line: None) if quiet else click.echo
    from . import viz

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    params = Params()
    trajs, results = {}, {}
    for label, torque, t_end, save_every in runs:
        sim = Simulator(params, Motor(torque))
        tr = sim.run(t_end, save_every=save_every, output=out_dir / f"{label}.h5",
                     progress=progress)
        s = tr.summary()
        regime = s.regime
        results[label] = {"torque": torque, "regime": regime, "thrust_mean": s.thrust_mean,
                          "thrust_std": s.thrust_std, "omega_mean": s.omega_mean,
                          "chi_mean": s.chi_mean, "wall_seconds": sim.wall_seconds}
        say(f"M = {torque:4.2f} pN·µm: {regime:<12} thrust {s.thrust_mean:.3f} ± "
            f"{s.thrust_std:.3f} pN, motor speed {s.omega_mean:.0f} rad/s, "
            f"precession {s.chi_mean:.1f} rad/s  ({sim.wall_seconds:.1f} s wall)")
        span, view = (slice(-frames, None), "lab") if regime == "aligned" else (slice(None), "corotating")
        viz.movie(tr.t[span], tr.positions[span], out_dir / f"{label}.mp4", max_frames=frames,
                  title=f"M = {torque} pN·µm · {regime}", view=view, size=size,
                  thrust=tr.thrust[span], motor_speed=tr.motor_speed[span])
        trajs[f"M = {torque} pN·µm ({regime})"] = tr
    viz.time_series_figure(trajs, out_dir / "thrust")
    say(f"wrote {out_dir}/: " + ", ".join(sorted(p.name for p in out_dir.iterdir())))
    return results
