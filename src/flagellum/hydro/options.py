"""The hydrodynamic model as an option (no Numba: the command-line interface builds it
before any kernel is loaded); the numerics are :mod:`flagellum.hydro.dynamics`."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from ..params import check_choice, check_range

MODELS = ("rft", "sbt")
#: default ``refresh``: rebuild ΔM when a bead has moved this far [µm] (docs/hydrodynamics.md)
REFRESH = 0.04


@dataclass(frozen=True)
class Hydrodynamics:
    """Which mobility the filament has.

    model : ``"rft"`` (local resistive-force theory, paper Sec. 2.2: the default) or
        ``"sbt"`` (regularized Stokeslet segments calibrated to slender-body theory,
        :mod:`flagellum.hydro.sbt`, with the load sphere or body coupled to the filament).
    refresh : [µm] the nonlocal correction ΔM is rebuilt (at the simulator's chunk
        boundaries) once a bead has moved this far from the positions it was built at;
        0: at every right-hand-side evaluation (the unfrozen reference, slow; the
        fixed-step scheme: before every step).
    """

    model: str = "rft"
    refresh: float = REFRESH

    def __post_init__(self):
        check_choice("hydrodynamics", self.model, MODELS)
        object.__setattr__(self, "refresh", check_range("refresh", self.refresh, 0.0, 1.0, lo_open=False))

    @property
    def is_local(self) -> bool:
        return self.model == "rft"

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict | None) -> "Hydrodynamics":
        return cls(**(data or {}))


__all__ = ["Hydrodynamics", "MODELS", "REFRESH"]
