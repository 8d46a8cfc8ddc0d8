"""The peer on the same run: PyElastica against flagellum on every deterministic regime of
``flagellum bench`` (``flagellum.bench.REGIMES``: from rest M = 1, buckled M = 1.6, M = 3,
oscillating M = 5, load sphere, free swimmer), N = 50, the paper's filament.

    python benchmarks/bench_pyelastica.py [--install] [--quick] [--no-precision]

``--install`` makes PyElastica's own environment (``$FLAGELLUM_PEER_ENV``, default /tmp/pyel;
not a dependency of flagellum: ``pip install pyelastica`` into a fresh venv). The PyElastica
model and its tuning are in ``flagellum.peer`` (module docstring); ``flagellum bench --peer``
runs the same. Per regime, in one process and in this order: flagellum's run with its
default method, the CVODE rtol 1e-10 reference and its rtol 1e-9 check, then PyElastica at
the largest stable Δt of 1e-6, 5e-7, 2.5e-7, … over 0.02 s (its fixed step costs the same
per simulated second in every state), so the two sit side by side under the same load. Then
the work–precision runs of every regime (CVODE and the Numba BDF over rtol, BDF2 over Δt,
PyElastica over Δt) and their diagram, docs/img/work_precision.png.

Writes benchmarks/bench_pyelastica.json.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def ensure_env() -> str:
    """Create PyElastica's environment if it is missing; returns its interpreter."""
    from flagellum import peer

    py = peer.python()
    if not os.path.exists(py):
        subprocess.run([sys.executable, "-m", "venv", os.path.dirname(os.path.dirname(py))],
                       check=True)
    if subprocess.run([py, "-c", "import elastica"], capture_output=True).returncode:
        subprocess.run([py, "-m", "pip", "install", "-q", "pyelastica"], check=True)
    return py


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--install", action="store_true", help="make the PyElastica environment")
    ap.add_argument("--quick", action="store_true", help="short windows (a smoke test)")
    ap.add_argument("--no-precision", action="store_true", help="skip the work–precision runs")
    ap.add_argument("--reuse-precision", default=None,
                    help="take flagellum's work–precision runs from this earlier output of "
                         "the script and run only PyElastica's over Δt again")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "bench_pyelastica.json"))
    ap.add_argument("--plot", default=str(ROOT / "docs" / "img" / "work_precision.png"))
    args = ap.parse_args()
    if args.install:
        ensure_env()
    from flagellum import peer
    from flagellum.bench import REGIMES, load_average, plot_work_precision, regimes, work_precision

    ok, reason = peer.available()
    if not ok:
        sys.exit(reason)
    version = subprocess.run([peer.python(), "-c", "import importlib.metadata as m; "
                              "print(m.version('pyelastica'))"], capture_output=True,
                             text=True).stdout.strip()
    names = [n for n, r in REGIMES.items() if not r[3]]
    t0 = time.perf_counter()
    out = {"pyelastica": version, "load_average_start": load_average(),
           "regimes": regimes(args.quick, names=names, peer=True)}
    out["load_average_after_regimes"] = load_average()
    for name, row in out["regimes"].items():
        print(name, {k: row.get(k) for k in ("wall_per_simulated_second", "error", "peer_ratio")},
              flush=True)
    if args.reuse_precision:
        from flagellum.bench import peer_precision

        wp = json.loads(Path(args.reuse_precision).read_text())["work_precision"]
        for name in names:
            wp[name]["peer"] = peer_precision(name, args.quick)
        out["work_precision"] = wp
        out["work_precision_flagellum_runs_from"] = args.reuse_precision
        plot_work_precision(wp, args.plot)
    elif not args.no_precision:
        out["work_precision"] = work_precision(args.quick, names=names, peer=True)
        plot_work_precision(out["work_precision"], args.plot)
    out["load_average_end"] = load_average()
    out["script_seconds"] = time.perf_counter() - t0
    Path(args.out).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
