"""Reproduce the figures of Vogel & Stark (2012): ``flagellum reproduce FIG --output DIR``.

Each target writes into ``DIR/<fig>/`` the figure as PNG and PDF, the data behind it (CSV and
HDF5) and ``comparison.md`` — every number the paper states for that figure next to ours,
with the difference. :func:`reproduce` returns the headline numbers (printed by ``--json``).

Qualities: ``quick`` (CI-size runs, each figure within about two minutes on two cores) and
``full`` (publication quality; all figures within 30 minutes on two cores). See
``docs/reproduce.md`` and :mod:`.common` for the figure numbering.
"""

from __future__ import annotations

import importlib
from pathlib import Path

from .. import parallel
from .common import FIGURES, QUALITIES, Timer, check_quality
from .shared import Cache

#: targets beyond the paper's figures (not part of ``all``): target name → module
EXTRAS = {"force-extension": "force_extension", "tumble": "tumble"}
TARGETS = FIGURES + tuple(EXTRAS) + ("all",)


def reproduce(target: str, out_dir: str | Path = "flagellum-reproduce", quality: str = "quick",
              cache: Cache | None = None, echo=None, hydrodynamics=None) -> dict:
    """Run one figure (``"fig3"`` … ``"fig8"``), ``"all"`` of them, or a target of
    :data:`EXTRAS` (``"force-extension"``, ``"tumble"``); returns the headline numbers.

    ``cache`` (:class:`.shared.Cache`) holds work shared between figures (the simulation
    sweep of Fig. 3/4, the critical points of Fig. 5/7) when several run in one process.
    Each figure module runs as compute → analyse → plot → write (its ``run``).
    ``hydrodynamics`` (:class:`~flagellum.hydro.options.Hydrodynamics`, default local RFT)
    is the filament's mobility in the simulations and stability analyses of Fig. 3–5,
    Fig. 7 and Fig. 8 (the thermal runs of Fig. 4 and the effective-rod theory of Fig. 6
    and Fig. 8 keep RFT; Fig. 6 adds the rigid helix' nonlocal coefficients); it replaces
    that of a given ``cache``.
    """
    from ..errors import ParameterError

    if target not in TARGETS:
        raise ParameterError("figure", target, "one of " + ", ".join(TARGETS))
    check_quality(quality)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ParameterError("output", str(out), "a directory")
    cache = Cache() if cache is None else cache
    if hydrodynamics is not None:
        cache.hydrodynamics = hydrodynamics
    if echo:
        cache.log = True
    targets = FIGURES if target == "all" else (target,)
    result, timer = {}, Timer()
    # one pool of workers for every parallel step of every figure (started once)
    with parallel.shared_pool(parallel.default_workers(2)):
        _run_targets(targets, out, quality, cache, echo, result)
    if target != "all":
        return result[target]
    _write_index(out, result, quality, timer.seconds)
    return {**result, "wall_seconds": timer.seconds, "quality": quality}


def _run_targets(targets, out: Path, quality: str, cache: Cache, echo, result: dict) -> None:
    for fig in targets:
        if echo:
            echo(f"reproducing {fig} ({quality}) …")
        mod = importlib.import_module(f".{EXTRAS.get(fig, fig)}", __name__)
        t = Timer()
        result[fig] = mod.run(out / fig, quality, cache)
        if cache.hydrodynamics is not None and not cache.hydrodynamics.is_local:
            _mark_hydrodynamics(out / fig, result[fig], cache.hydrodynamics)
        if echo:
            echo(f"  {fig} done in {t.seconds:.1f} s → {out / fig}")


def _mark_hydrodynamics(fig_dir: Path, result: dict, hydrodynamics) -> None:
    """State a nonlocal mobility in the figure's headline numbers and ``comparison.md``."""
    from ..io import atomic_write_text

    result["hydrodynamics"] = hydrodynamics.model
    p = fig_dir / "comparison.md"
    if p.exists():
        text = p.read_text()
        text = text.rstrip("\n") + ("\n" if "\nNotes:\n" in text else "\n\nNotes:\n\n")
        atomic_write_text(p, text + f"- Hydrodynamics: `{hydrodynamics.model}` (refresh "
                             f"{hydrodynamics.refresh:g} µm) in the runs and stability analyses of "
                             "this figure, not the paper's local RFT (docs/hydrodynamics.md).\n")


def _write_index(out: Path, result: dict, quality: str, seconds: float) -> None:
    """``DIR/comparison.md``: all comparison tables in one file."""
    from ..io import atomic_write_text

    parts = [f"# flagellum reproduce all (quality `{quality}`, {seconds:.0f} s)", ""]
    for fig in result:
        p = out / fig / "comparison.md"
        if p.exists():
            parts.append(p.read_text().replace("# ", "## ", 1))
    atomic_write_text(out / "comparison.md", "\n".join(parts))


__all__ = ["reproduce", "Cache", "EXTRAS", "TARGETS", "FIGURES", "QUALITIES"]
